#!/usr/bin/env bash
# Runs the LIGGGHTS settle benchmark (tools/peers/liggghts/settle.lig, single process; see
# docs/benchmarks.md) and prints its loop time plus the same bed height and kinetic energy that
# `demcal bench settle` prints.
# The stock input is copied unchanged except for one dump of the final positions, so the peer
# does exactly the benchmark's work.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
lig=$here/liggghts/settle.lig
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The dump fires at step 0 and at the last step; the final one is what we read.
sed 's/^run 50000/dump final all custom 50000 final.dump id x y z radius vx vy vz omegax omegay omegaz mass\nrun 50000/' "$lig" > "$work/settle.lig"
cd "$work"
liggghts -in settle.lig > log.txt
grep -E "^Loop time" log.txt
python3 - <<'PY'
import math, re
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
print(f"liggghts settle: particles={n} steps=50000 wall_s={loop:.1f} particle_steps_per_s={n*50000/loop:.2e} bed_height_m={bed:.4f} kinetic_energy_j={ke:.2e}")
PY
