#!/usr/bin/env bash
# Runs the LIGGGHTS settle benchmark (tools/peers/liggghts/settle.lig, single process; see
# docs/benchmarks.md) and prints its loop time plus the same bed height and kinetic energy that
# `demcal bench settle` prints.
#   tools/peers/liggghts_settle.sh [--scale S] [--steps N] [--ranks R]
# --scale S widens the box and the lattice S times in x and y, as `demcal bench settle --scale S`
# does (5 000 steps unless --steps, like demcal); --ranks R runs R MPI processes.
# The stock input is copied unchanged except for the widening, the step count and one dump of
# the final positions, so the peer does exactly the benchmark's work.
set -euo pipefail
scale=1
steps=""
ranks=1
while [ $# -gt 0 ]; do
    case "$1" in
        --scale) scale=$2; shift 2 ;;
        --steps) steps=$2; shift 2 ;;
        --ranks) ranks=$2; shift 2 ;;
        *) echo "unknown option $1 (expected --scale S, --steps N, --ranks R)" >&2; exit 2 ;;
    esac
done
case "$scale" in ''|*[!0-9]*) echo "--scale: expected a whole number, got $scale" >&2; exit 2 ;; esac
if [ -z "$steps" ]; then
    if [ "$scale" = 1 ]; then steps=50000; else steps=5000; fi
fi
here=$(cd "$(dirname "$0")" && pwd)
lig=$here/liggghts/settle.lig
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Millimetres, as demcal writes the widened scene.
box=$((100 * scale)); lattice=$((100 * scale - 2))
sed -e "s/^region reg block 0 0.1 0 0.1 0 0.4/region reg block 0 ${box}e-3 0 ${box}e-3 0 0.4/" \
    -e "s/xplane 0.1$/xplane ${box}e-3/" -e "s/yplane 0.1$/yplane ${box}e-3/" \
    -e "s/^region ins block 0.002 0.098 0.002 0.098 0.002 0.17/region ins block 0.002 ${lattice}e-3 0.002 ${lattice}e-3 0.002 0.17/" \
    -e "s/^run 50000/dump final all custom $steps final.dump id x y z radius vx vy vz omegax omegay omegaz mass\nrun $steps/" \
    "$lig" > "$work/settle.lig"
cd "$work"
if [ "$ranks" = 1 ]; then
    liggghts -in settle.lig > log.txt
else
    mpirun --allow-run-as-root -np "$ranks" liggghts -in settle.lig > log.txt
fi
grep -E "^Loop time" log.txt
python3 - "$steps" "$ranks" <<'PY'
import math, re, sys
steps, ranks = int(sys.argv[1]), int(sys.argv[2])
lines = open("final.dump").read().split("ITEM: TIMESTEP")[-1].splitlines()
start = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS")) + 1
rows = [list(map(float, l.split())) for l in lines[start:] if l.strip()]
tops = sorted((r[3] + r[4] for r in rows), reverse=True)
k = max(1, len(tops) // 100)
bed = sum(tops[:k]) / k
ke = 0.0
for r in rows:
    m, rad = r[11], r[4]
    ke += 0.5 * m * (r[5]**2 + r[6]**2 + r[7]**2)
    ke += 0.5 * 0.4 * m * rad * rad * (r[8]**2 + r[9]**2 + r[10]**2)
loop = float(re.search(r"Loop time of ([0-9.eE+-]+)", open("log.txt").read()).group(1))
n = len(rows)
print(f"liggghts settle: ranks={ranks} particles={n} steps={steps} wall_s={loop:.1f} particle_steps_per_s={n*steps/loop:.2e} bed_height_m={bed:.4f} kinetic_energy_j={ke:.2e}")
PY
