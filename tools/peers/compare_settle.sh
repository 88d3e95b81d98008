#!/usr/bin/env bash
# Runs the settle benchmark in LIGGGHTS (single process) and in demcal (release build), one after
# the other on an otherwise idle machine, and prints both lines plus the ratios the issue asks for.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
cargo build --release -q -p demcal-cli
lig=$(tools/peers/liggghts_settle.sh | tail -n 1)
dem=$(./target/release/demcal bench settle "$@" | tail -n 1)
echo "$lig"
echo "$dem"
python3 - "$lig" "$dem" <<'PY'
import sys
def fields(line):
    return {k: float(v) for k, v in (f.split("=") for f in line.split()[2:])}
l, d = fields(sys.argv[1]), fields(sys.argv[2])
print(f"wall time demcal/liggghts = {d['wall_s'] / l['wall_s']:.3f}; "
      f"bed height difference = {100 * (d['bed_height_m'] - l['bed_height_m']) / l['bed_height_m']:+.2f} %")
PY
