#!/usr/bin/env bash
# The GPU measurements of docs/benchmarks.md in one run: builds demcal, names the device, then
# measures on the GPU back end and, on the same machine, the CPU engine's scaling over threads.
#
#   bash tools/gpu/measure.sh            # the full set (under 8 minutes on an H100 box)
#   bash tools/gpu/measure.sh --quick    # small sizes, to check the script end to end (lavapipe)
#   bash tools/gpu/measure.sh --gpu-only # the GPU steps alone (a rerun after tuning the GPU)
#   DEMCAL=target/debug/demcal bash tools/gpu/measure.sh --quick   # with a binary already built
#
# What it runs (each line of output is a demcal bench line, so the numbers can be pasted):
#   1. the device: nvidia-smi or vulkaninfo where present, and the adapter demcal picks;
#   2. settle (21 160 spheres) and settle x8 (1 444 000) on the GPU, in particle-steps/s;
#   3. the bonded bench (the seed-000 stalk specimen, its bonds on the device with the particles)
#      on the GPU;
#   4. bench batch: 32 quickstart repose tests on the GPU in shared launches against the CPU runner
#      with as many jobs as cores, in simulations per hour;
#   5. bench worlds: 32 seed-000-sized worlds (4 000 spheres) for 2 000 steps, all at once, on the
#      GPU and on the CPU; the kernels' shares of the device time (timestamp queries,
#      DEMCAL_GPU_PROFILE=1) in settle and in worlds;
#   6. the CPU settle and settle x8 at 1, 2, 4, 8 and 16 threads (those the machine has);
#      `--gpu-only` leaves out these and `bench worlds` on the CPU.
# Each step has a time limit (MEASURE_LIMIT seconds, 600 by default, 120 with --quick); a step
# that fails or passes it is reported and the rest still run; the exit status counts them.
set -uo pipefail
cd "$(dirname "$0")/../.."

quick=0
gpu_only=0
for a in "$@"; do
  case "$a" in
    --quick) quick=1 ;;
    --gpu-only) gpu_only=1 ;;
    -h|--help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "unknown option $a (expected --quick or --gpu-only)" >&2; exit 2 ;;
  esac
done

if [ -z "${DEMCAL:-}" ]; then
  cargo build --release -p demcal-cli || exit 1
  DEMCAL=target/release/demcal
fi
limit="${MEASURE_LIMIT:-$([ "$quick" = 1 ] && echo 120 || echo 600)}"
cores=$(nproc)
failed=0
started=$(date +%s)

# step NAME COMMAND...: runs one measurement under the time limit, printing its lines.
step() {
  local name="$1"
  shift
  echo "== $name: $*"
  local t0=$(date +%s%N)
  timeout -k 10 "$limit" "$@" 2>&1 | grep -v '^\s*$'
  local rc=${PIPESTATUS[0]}
  local t1=$(date +%s%N)
  if [ "$rc" -ne 0 ]; then
    failed=$((failed + 1))
    [ "$rc" -eq 124 ] && echo "!! $name: over the ${limit} s limit" || echo "!! $name: exit $rc"
  fi
  local ds=$(( (t1 - t0) / 100000000 ))
  echo "-- $name: $((ds / 10)).$((ds % 10)) s"
}

echo "== device"
if command -v nvidia-smi >/dev/null 2>&1; then
  nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.max.sm --format=csv,noheader
fi
if command -v vulkaninfo >/dev/null 2>&1; then
  vulkaninfo --summary 2>/dev/null | grep -E 'deviceName|driverName|apiVersion' | sort -u
fi
echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $cores cores"

if [ "$quick" = 1 ]; then
  settle_steps=200; profile_steps=200; wide_scale=2; wide_steps=50; bonded_steps=200
  batch_runs=2; world_runs=4; world_steps=100; cpu_steps=500; cpu_wide_steps=50
  batch_test=(--test tools/gpu/small-repose.toml)
else
  settle_steps=20000; profile_steps=2000; wide_scale=8; wide_steps=500; bonded_steps=20000
  batch_runs=32; world_runs=32; world_steps=2000; cpu_steps=20000; cpu_wide_steps=500
  batch_test=()
fi
[ -f "${batch_test[1]:-/dev/null}" ] || batch_test=()

step "settle gpu" "$DEMCAL" bench settle --backend gpu --steps "$settle_steps"
step "settle x$wide_scale gpu" "$DEMCAL" bench settle --backend gpu --scale "$wide_scale" --steps "$wide_steps"
step "bonded gpu" "$DEMCAL" bench bonded --backend gpu --steps "$bonded_steps"
step "batch gpu vs cpu" "$DEMCAL" bench batch --backend gpu --runs "$batch_runs" --cpu-jobs "$cores" ${batch_test[@]+"${batch_test[@]}"}
step "worlds gpu" "$DEMCAL" bench worlds --backend gpu --runs "$world_runs" --steps "$world_steps"
# Kernel time shares from timestamp queries (each launch in a pass of its own, so a little slower).
step "kernel shares, settle gpu" env DEMCAL_GPU_PROFILE=1 "$DEMCAL" bench settle --backend gpu --steps "$profile_steps"
step "kernel shares, worlds gpu" env DEMCAL_GPU_PROFILE=1 "$DEMCAL" bench worlds --backend gpu --runs "$world_runs" --steps "$world_steps"
if [ "$gpu_only" = 1 ]; then
  echo "== measure.sh: $failed step(s) failed, $(( $(date +%s) - started )) s in all"
  [ "$failed" -eq 0 ]
  exit
fi
step "worlds cpu" "$DEMCAL" bench worlds --backend cpu --runs "$world_runs" --steps "$world_steps"
for t in 1 2 4 8 16; do
  [ "$t" -le "$cores" ] || continue
  step "settle cpu $t threads" "$DEMCAL" bench settle --threads "$t" --steps "$cpu_steps"
  step "settle x$wide_scale cpu $t threads" "$DEMCAL" bench settle --threads "$t" --scale "$wide_scale" --steps "$cpu_wide_steps"
done

echo "== measure.sh: $failed step(s) failed, $(( $(date +%s) - started )) s in all"
[ "$failed" -eq 0 ]
