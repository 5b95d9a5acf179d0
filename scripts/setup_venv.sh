#!/usr/bin/env bash
# Create (or update) the project's Python environment in .venv at the repo
# root and install the package of python/ (one wheel, built with maturin:
# the in-process module `roks`, the `roks` command, the tools roks_tools)
# with its extras `mitsuba` (mitsuba, drjit) and `test` (pytest, scipy,
# mypy). The one dependency list, pinned, is python/pyproject.toml. Building the wheel
# compiles roks in release (target/release, shared with cargo: a rerun
# rebuilds only what changed). Run it again after changing the Rust code or
# python/: the package is installed as built, not linked to the clone. Safe
# to run again: an existing .venv is reused and pip only installs what is
# missing or at another version.
#
#   scripts/setup_venv.sh          # then: .venv/bin/python scripts/edge_study.py
#                                  #   or: .venv/bin/roks-plot-brdf out/default
#                                  #   or: .venv/bin/roks --version; .venv/bin/python -c 'import roks'
#                                  # tests: .venv/bin/python -m pytest python/tests
#   PYTHON=python3.12 scripts/setup_venv.sh
#   EXTRAS=test scripts/setup_venv.sh   # without Mitsuba
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$repo/.venv"
python="${PYTHON:-python3}"
extras="${EXTRAS-mitsuba,test}"

if [ ! -x "$venv/bin/python" ]; then
    echo "setup_venv: creating $venv with $("$python" --version 2>&1)"
    "$python" -m venv "$venv"
else
    echo "setup_venv: reusing $venv ($("$venv/bin/python" --version 2>&1))"
fi
# The package was called roks_tools before it held roks: an older .venv's
# editable roks_tools goes, the wheel brings the same package.
if "$venv/bin/python" -m pip show --quiet roks_tools >/dev/null 2>&1; then
    "$venv/bin/python" -m pip uninstall --quiet --yes roks_tools
fi
# pip builds and reinstalls a local folder every time (it cannot know what
# changed in it).
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "$repo/python${extras:+[$extras]}"
"$venv/bin/python" - <<'PY'
import warnings
import numpy, matplotlib, roks, roks_tools
with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # colour-science runs without its optional SciPy
    import colour
extra = []
for name in ("pytest", "scipy", "mitsuba", "drjit"):
    try:
        extra.append(f"{name} {__import__(name).__version__}")
    except ImportError:
        pass
print(f"setup_venv: ok: numpy {numpy.__version__}, matplotlib {matplotlib.__version__}, "
      f"colour-science {colour.__version__}, {', '.join(extra) or 'no extras'}, "
      f"roks {roks.__version__} and roks_tools from {roks_tools.__path__[0]}")
PY
