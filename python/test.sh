#!/usr/bin/env bash
# The Python SDK's tests: installs the package the way users do (`pip install ./python`, a PEP 517 build by maturin
# that compiles the Rust extension) with its test extras into a virtual environment, then runs pytest.
#   VB_VENV   the virtual environment (default: ~/.cache/vertibench/venv; created when missing)
#   VB_BIN    the `vb` binary, for the test that compares with `vb eval` (skipped, and said so, when unset)
#   VB_SUBMIT_BIN  the `vb-submit` binary, for the service tests (skipped, and said so, when unset)
set -euo pipefail
cd "$(dirname "$0")"
venv="${VB_VENV:-$HOME/.cache/vertibench/venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q ".[test]"
"$venv/bin/python" -m pytest -q -rs tests "$@"
