#!/usr/bin/env bash
# Every test of the repository: the Rust workspace's (`cargo test --workspace`), then the Python
# package's (tools/python-tests.sh: builds and installs python/ into target/python-env and runs
# pytest). Options go to cargo test.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace "$@"
bash tools/python-tests.sh -q
