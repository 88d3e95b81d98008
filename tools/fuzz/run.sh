#!/usr/bin/env bash
# Coverage-guided fuzzing of every file demcal reads (docs/reliability.md): scene, test, study,
# job JSON, lab CSV, design CSV, STL, images, sphere dumps. Installs what it needs (the nightly
# toolchain and cargo-fuzz), builds the targets in fuzz/ with AddressSanitizer, then runs each
# for RUNS executions from its seeds (fuzz/seeds/) and the corpus grown so far (fuzz/corpus/).
#
#   tools/fuzz/run.sh [RUNS] [TARGET ...]      RUNS: executions per target (default 1000000)
#   FUZZ_PARALLEL=2 tools/fuzz/run.sh          targets run two at a time (default: the cores)
#
# A crash (a panic, a multi-line or nameless error, an allocation over 1 GB, a process over
# 2 GB with the sanitizer's own share) or a hang (one input over 10 s) stops that target with
# the input saved under fuzz/artifacts/TARGET/; rerun it with
#   cd fuzz && cargo +nightly fuzz run -O TARGET artifacts/TARGET/crash-...
# The last line per target gives executions, seconds, crashes and hangs; the exit status is
# non-zero when any target found one.
set -uo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-1000000}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(scene test_file study job lab_csv design_csv stl image dump)
fi
parallel=${FUZZ_PARALLEL:-$(nproc)}

rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked

cd fuzz
cargo +nightly fuzz build -O || exit 1
mkdir -p logs

one() {
  local t=$1
  mkdir -p "corpus/$t" "artifacts/$t"
  local start=$SECONDS
  # The binaries built above, run directly: `cargo fuzz run` would build again for each.
  "target/x86_64-unknown-linux-gnu/release/$t" "corpus/$t" "seeds/$t" \
    -artifact_prefix="artifacts/$t/" -runs="$runs" -timeout=10 -malloc_limit_mb=1024 \
    -rss_limit_mb=2048 -print_final_stats=1 -close_fd_mask=1 >"logs/$t.log" 2>&1
  local rc=$?
  local execs crashes hangs slowest rss
  execs=$(grep -a -o 'stat::number_of_executed_units: *[0-9]*' "logs/$t.log" | grep -o '[0-9]*$' | tail -1)
  slowest=$(grep -a -o 'stat::slowest_unit_time_sec: *[0-9]*' "logs/$t.log" | grep -o '[0-9]*$' | tail -1)
  rss=$(grep -a -o 'stat::peak_rss_mb: *[0-9]*' "logs/$t.log" | grep -o '[0-9]*$' | tail -1)
  crashes=$(ls "artifacts/$t" | grep -c -E '^(crash|oom|leak)-' || true)
  hangs=$(ls "artifacts/$t" | grep -c -E '^(timeout|slow-unit)-' || true)
  printf '%-11s executions %-9s seconds %-5s slowest_s %-3s peak_rss_mb %-5s crashes %s hangs %s exit %s\n' \
    "$t" "${execs:-?}" "$((SECONDS - start))" "${slowest:-?}" "${rss:-?}" "$crashes" "$hangs" "$rc"
  return $rc
}

status=0
running=0
for t in "${targets[@]}"; do
  one "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$parallel" ]; then
    wait -n || status=1
    running=$((running - 1))
  fi
done
while [ "$running" -gt 0 ]; do
  wait -n || status=1
  running=$((running - 1))
done
exit $status
