#!/usr/bin/env bash
# The seed-000 shear runs of the investigation (examples/stalks/README.md) that want more cores
# than a laptop, as one batch for a 16-core machine: the published file at density_scaling = 10
# over the full travel (8 threads), and every variant of variants.py at density_scaling = 1e4
# (8 at a time, 1 thread each). Each run is stopped after LIMIT seconds (default 540) and
# reports how far it came.
#   bash examples/stalks/investigation/device_batch.sh [DEMCAL] [OUT]
set -u
cd "$(dirname "$0")/../../.."
B=${1:-target/release/demcal}
OUT=${2:-investigation_out}
LIMIT=${LIMIT:-540}
V=examples/stalks/investigation/variants.py
mkdir -p "$OUT"
nproc > "$OUT/nproc.txt"
python3 $V "$B" shear "$OUT/f10" published --scaling 10 --threads 8 --timeout "$LIMIT" \
  --set "side_views = 8" > "$OUT/f10.txt" 2>&1 &
python3 $V "$B" shear "$OUT/screen" --scaling 1e4 --jobs 8 --threads 1 --timeout "$LIMIT" \
  --set "side_views = 4" > "$OUT/screen.txt" 2>&1 &
wait
cat "$OUT/f10.txt" "$OUT/screen.txt"
