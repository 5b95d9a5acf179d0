#!/usr/bin/env bash
# Create (or update) the project's Python environment in .venv at the repo root,
# install scripts/requirements.txt into it and the package roks_tools (python/,
# editable: edits to python/roks_tools take effect without reinstalling). Safe
# to run again: an existing .venv is reused and pip only installs what is
# missing or at another version.
#
#   scripts/setup_venv.sh          # then: .venv/bin/python scripts/edge_study.py
#                                  #   or: .venv/bin/roks-edge-study
#                                  # tests: .venv/bin/python -m pytest python/tests
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
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps -e "$repo/python"
"$venv/bin/python" - <<'PY'
import warnings
import numpy, matplotlib, pytest, roks_tools
with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # colour-science runs without its optional SciPy
    import colour
print(f"setup_venv: ok: numpy {numpy.__version__}, matplotlib {matplotlib.__version__}, "
      f"pytest {pytest.__version__}, colour-science {colour.__version__}, roks_tools from {roks_tools.__path__[0]}")
PY
