#!/usr/bin/env bash
# Create (or update) the project's Python environment in .venv at the repo root
# and install scripts/requirements.txt into it. Safe to run again: an existing
# .venv is reused and pip only installs what is missing or at another version.
#
#   scripts/setup_venv.sh          # then: .venv/bin/python scripts/edge_study.py
#   PYTHON=python3.12 scripts/setup_venv.sh
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$repo/.venv"
req="$repo/scripts/requirements.txt"
python="${PYTHON:-python3}"

if [ ! -x "$venv/bin/python" ]; then
    echo "setup_venv: creating $venv with $("$python" --version 2>&1)"
    "$python" -m venv "$venv"
else
    echo "setup_venv: reusing $venv ($("$venv/bin/python" --version 2>&1))"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req"
"$venv/bin/python" - <<'PY'
import numpy, matplotlib
print(f"setup_venv: ok: numpy {numpy.__version__}, matplotlib {matplotlib.__version__}")
PY
