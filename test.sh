#!/usr/bin/env bash
# The whole test suite: the Rust tests (core, CLI, viewer, browser), then the Python module
# and the Ray farm, built into a virtual environment (.venv, or $PATHTRACER_VENV).
set -euo pipefail
cd "$(dirname "$0")"
cargo test --release
venv="${PATHTRACER_VENV:-.venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q "./python[test]"
"$venv/bin/python" -m pytest -q -p no:cacheprovider --rootdir python python/tests
