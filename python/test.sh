#!/usr/bin/env bash
# The Python SDK's tests: builds the wheel users install (`maturin build --release`: abi3, manylinux tag; printed
# with its size), installs it with its test extras into a virtual environment, then runs pytest (which also installs
# the same wheel into a fresh venv outside the repository: tests/test_wheel.py).
#   VB_VENV       the virtual environment (default: ~/.cache/vertibench/venv; created when missing)
#   VB_WHEEL_DIR  where the wheel goes (default: ~/.cache/vertibench/wheels; emptied first)
#   VB_BIN        the `vb` binary, for the tests that compare with `vb eval` and `vb tasks generate` (skipped, and
#                 said so, when unset)
#   VB_SUBMIT_BIN the `vb-submit` binary, for the service tests (skipped, and said so, when unset)
set -euo pipefail
cd "$(dirname "$0")"
venv="${VB_VENV:-$HOME/.cache/vertibench/venv}"
wheels="${VB_WHEEL_DIR:-$HOME/.cache/vertibench/wheels}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q "maturin>=1.7,<2"
rm -rf "$wheels"
"$venv/bin/maturin" build --release --out "$wheels"
wheel="$(ls "$wheels"/vertibench-*.whl)"
echo "wheel: $wheel ($(du -h "$wheel" | cut -f1))"
"$venv/bin/python" -m pip install -q "$wheel[test]"
"$venv/bin/python" -m pip install -q --no-deps --force-reinstall "$wheel"
VB_WHEEL="$wheel" "$venv/bin/python" -m pytest -q -rs tests "$@"
