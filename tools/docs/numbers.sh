#!/usr/bin/env bash
# The numbers the docs quote (docs/tutorial.md, README.md, the examples' headers), from the
# binary: runs the quickstart examples in a scratch folder (about 6 minutes on 2 cores) and
# rewrites the numbers between the docs' markers, or lists every one that differs.
#
#   bash tools/docs/numbers.sh --write                 # rewrite the docs
#   bash tools/docs/numbers.sh --check                 # fail listing what differs (CI)
#   DEMCAL=target/debug/demcal bash tools/docs/numbers.sh --check   # with a binary already built
#   bash tools/docs/numbers.sh --write --work /tmp/docs-work        # keep the runs for a rerun
#   bash tools/docs/numbers.sh --write --times         # also the run times within twofold
#
# Without DEMCAL it builds the release binary. The test profile's binary (what `cargo test`
# leaves in target/debug) gives the same numbers bit for bit: Rust does not contract or reorder
# floating-point operations at any optimisation level. Run times are each study's CPU time over
# 2 cores (its wall time on 2 free cores), written rounded and not checked. The markers and the
# table of numbers are described at the top of numbers.py.
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ -z "${DEMCAL:-}" ]; then
  cargo build --release -p demcal-cli
  DEMCAL=target/release/demcal
fi
exec python3 tools/docs/numbers.py --demcal "$DEMCAL" "$@"
