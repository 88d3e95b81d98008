#!/usr/bin/env bash
# The Python package's tests: builds and installs `python/` (PyO3, maturin from PyPI) into a
# virtual environment in target/python-env, with pytest and the examples' packages (pandas,
# Optuna, matplotlib, GrainLearning), then runs `pytest python/tests`. The extension is built
# with the workspace's dev profile (optimised), reusing what `cargo test` built.
#
#   bash tools/python-tests.sh [pytest options]
#
# DEMCAL_PYTHON_ENV names another environment folder; DEMCAL_PYTHON_MINIMAL=1 installs only
# pytest beside the package (the examples' tests then say they are skipped).
set -euo pipefail
cd "$(dirname "$0")/.."
env_dir="${DEMCAL_PYTHON_ENV:-target/python-env}"
python="${PYTHON:-python3}"
if [ ! -x "$env_dir/bin/python" ]; then
  if ! "$python" -m venv "$env_dir" 2>/dev/null; then
    # Debian's python3 keeps venv in its own package.
    rm -rf "$env_dir"
    if command -v apt-get >/dev/null 2>&1; then
      apt-get update -qq && apt-get install -y -qq python3-venv python3-pip
    fi
    "$python" -m venv "$env_dir"
  fi
fi
py="$env_dir/bin/python"
"$py" -m pip install -q --upgrade pip
if [ "${DEMCAL_PYTHON_MINIMAL:-0}" = 1 ]; then
  extras="test"
else
  extras="test,pandas,examples"
fi
# GrainLearning 2.0 wants numpy below 2; one resolution for everything keeps them compatible.
"$py" -m pip install -q "./python[$extras]"
"$py" -m pytest python/tests "$@"
