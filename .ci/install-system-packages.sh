#!/usr/bin/env bash
# Installs the Debian packages the tests use beyond the Rust toolchain: PostgreSQL (the cluster store's tests),
# Chromium (the leaderboard's browser test) and Python's venv (the SDK's tests). Building and running vertibench
# itself needs none of them.
set -euo pipefail
need=()
ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || need+=(postgresql)
command -v chromium >/dev/null 2>&1 || need+=(chromium)
command -v psql >/dev/null 2>&1 || need+=(postgresql-client)
# The Python tests make a virtual environment (Debian splits venv and pip out of python3).
python3 -c 'import ensurepip, venv' >/dev/null 2>&1 || need+=(python3-venv python3-pip)
if [ ${#need[@]} -eq 0 ]; then
    echo "system packages present: postgresql, chromium, python3-venv"
    exit 0
fi
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
echo "installing ${need[*]} (apt)"
if ! $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${need[@]}"; then
    $SUDO apt-get update -q
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${need[@]}"
fi
