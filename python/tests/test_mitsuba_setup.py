"""The Mitsuba variant choice (`roks_tools.mitsuba.setup`): an LLVM that
aborts the process is found out in a child process, and the tools fall back
to the scalar variant instead of dying with `LLVM ERROR`.

libLLVM 15 cannot select drjit's `fmaximum` and aborts (signal 6); where it
is installed, the probe and `roks-render-table` are run against it. A path
that is no libLLVM at all is the other broken case, on every machine.
"""

from __future__ import annotations

import glob
import os
import subprocess
import sys

import pytest

from roks_tools.errors import MitsubaError
from roks_tools.mitsuba import setup
from roks_tools.runner import repo_root, run

LLVM15 = sorted(glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM-15.so*"))


@pytest.mark.mitsuba
def test_a_missing_libllvm_fails_the_probe_not_the_process(tmp_path):
    why = setup.probe_variant("llvm_ad_rgb", str(tmp_path / "libLLVM-nothing.so"))
    assert why is not None and why.startswith("llvm_ad_rgb failed in a test process") and "\n" not in why


@pytest.mark.mitsuba
@pytest.mark.skipif(not LLVM15, reason="no libLLVM 15 installed (the one that aborts on fmaximum)")
def test_llvm15_abort_is_caught_and_auto_falls_back(monkeypatch, capsys):
    why = setup.probe_variant("llvm_ad_rgb", LLVM15[0])
    assert why is not None and ("signal 6" in why or "LLVM ERROR" in why), why
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", LLVM15[0])
    assert setup.choose_variant("auto") == "scalar_rgb"
    assert "falling back to scalar_rgb" in capsys.readouterr().err
    with pytest.raises(MitsubaError, match="llvm_ad_rgb unavailable"):
        setup.choose_variant("llvm")
    assert setup.choose_variant("scalar") == "scalar_rgb"


@pytest.mark.mitsuba
@pytest.mark.skipif(not LLVM15, reason="no libLLVM 15 installed (the one that aborts on fmaximum)")
def test_render_table_falls_back_instead_of_aborting(roks, tmp_path):
    """`roks-render-table` with libLLVM 15: scalar_rgb, a picture, exit 0 (it aborted before)."""
    run([roks, "brdf", repo_root() / "scenes" / "default.toml", "--photons", 1024, "--theta", "0,60",
         "--out", tmp_path / "res", "-q"], "test_mitsuba_setup", echo=False)
    env = {**os.environ, "DRJIT_LIBLLVM_PATH": LLVM15[0]}
    p = subprocess.run([sys.executable, "-m", "roks_tools.mitsuba.render_table", tmp_path / "res",
                        "--out", tmp_path / "s.png", "--spp", "1", "--size", "8,6"],
                       env=env, capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "falling back to scalar_rgb" in p.stderr and (tmp_path / "s.png").is_file()


@pytest.mark.mitsuba
def test_unknown_variant_is_a_usage_error():
    from roks_tools.errors import UsageError
    with pytest.raises(UsageError, match="unknown --variant 'cuda'"):
        setup.choose_variant("cuda")
