#!/usr/bin/env bash
# Runs the settle benchmark in LIGGGHTS (single process) and in demcal (release build), one after
# the other on an otherwise idle machine, and prints both lines plus the ratios the issue asks for.
#   tools/peers/compare_settle.sh [--scale S] [--steps N] [--ranks R] [demcal bench options]
# --scale, --steps go to both engines; --ranks R runs LIGGGHTS with R MPI processes; anything
# else (--threads T) goes to demcal.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
both=()
lig_only=()
dem_only=()
while [ $# -gt 0 ]; do
    case "$1" in
        --scale|--steps) both+=("$1" "$2"); shift 2 ;;
        --ranks) lig_only+=("$1" "$2"); shift 2 ;;
        *) dem_only+=("$1"); shift ;;
    esac
done
cargo build --release -q -p demcal-cli
lig=$(tools/peers/liggghts_settle.sh ${both[@]+"${both[@]}"} ${lig_only[@]+"${lig_only[@]}"} | tail -n 1)
dem_out=$(./target/release/demcal bench settle ${both[@]+"${both[@]}"} ${dem_only[@]+"${dem_only[@]}"})
dem=$(echo "$dem_out" | tail -n 1)
echo "$lig"
echo "$dem_out" | grep '^stages:' || true
echo "$dem"
python3 - "$lig" "$dem" <<'PY'
import sys
def fields(line):
    return {k: float(v) for k, v in (f.split("=") for f in line.split()[2:] if "=" in f)}
l, d = fields(sys.argv[1]), fields(sys.argv[2])
print(f"wall time demcal/liggghts = {d['wall_s'] / l['wall_s']:.3f} "
      f"(demcal {l['wall_s'] / d['wall_s']:.2f}x faster); "
      f"bed height difference = {100 * (d['bed_height_m'] - l['bed_height_m']) / l['bed_height_m']:+.2f} %")
PY
