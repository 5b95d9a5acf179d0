"""The small, fast version of the whole Mitsuba cross-check chain.

Run by `cargo test` through tests/mitsuba_chain.rs (which passes the roks
binary it built in $ROKS_BIN). On 45 degree V-grooves the exported mesh IS the scene
(the profile is piecewise linear with its ridges on grid lines), so roks and
Mitsuba must agree statistically at every mesh resolution:

1. `roks_tools.studies.crosscheck --exact-mesh`, rho = 0.8 and 1, meshes 2 and 4
   cells per side, incidence 0 and 30 deg, and a retro-reflection image
   (view 30,180, light 30,180: the lit fraction is 1 - 1/sqrt 3, exact):
   verdict PASS, and the numbers behind it checked here against exact values
   (R(0) = rho^2 with every photon bouncing twice, white furnace R = 1 to 1e-12).
2. The same chain with Mitsuba's rho perturbed by 2 %: verdict FAIL, for
   the BRDF and for the images (the comparison has the power to see it).
Takes about 20 s with the llvm variant, longer with the scalar fallback.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from roks_tools.runner import repo_root

ROOT = repo_root()
pytestmark = [pytest.mark.mitsuba, pytest.mark.slow]


def chain(roks: str, out: Path, extra: list[str]) -> tuple[int, dict]:
    cmd = [sys.executable, "-m", "roks_tools.studies.crosscheck", "--scene", str(ROOT / "scenes_mitsuba" / "vgroove45.toml"),
           "--exact-mesh", "--rho", "0.8,1", "--resolutions", "2,4", "--theta", "0,30",
           "--photons", "20000", "--roks-photons", "20000", "--image", "64,64", "--spp", "4",
           "--view", "30,180", "--light", "30,180", "--roks", roks, "--out", str(out), "-q", *extra]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 1):
        sys.stderr.write(p.stdout + p.stderr)
        raise AssertionError(f"crosscheck.py crashed with status {p.returncode}")
    return p.returncode, json.loads((out / "crosscheck.json").read_text())


def test_exact_vgrooves_pass_and_rho_error_fails(roks, tmp_path):
    tmp = tmp_path
    status, res = chain(roks, tmp / "good", [])
    assert status == 0 and res["verdict"] == "PASS", f"exact V-grooves: {res['verdict']}"
    for key, rho in (("0.8", 0.8), ("1", 1.0)):
        for p in res["brdf"][key]["0.0"]:
            # every photon bounces exactly twice at normal incidence
            assert abs(p["r_a"] - rho ** 2) < 1e-12 and abs(p["r_b"] - rho ** 2) < 1e-9, p
        for p in res["brdf"][key]["30.0"]:
            assert p["cells"] > 0 and p["pass"], p
            if rho == 1.0:
                assert abs(p["r_a"] - 1) < 1e-12 and abs(p["r_b"] - 1) < 1e-9, p
        for r in res["images"][key]:
            assert r["pass"] and r["blocks"] > 0, r
            exact = (1 - 1 / math.sqrt(3)) * rho ** 2   # lit strip fraction x two bounces
            # image mean against the exact value, 4 standard errors of each side
            assert abs(r["mean_a"] - exact) < 4 * r["se_a"] + 1e-6, (r["mean_a"], exact)
            assert abs(r["mean_b"] - exact) < 4 * r["se_b"] + 1e-6, (r["mean_b"], exact)
    status, res = chain(roks, tmp / "bad", ["--perturb-rho", "0.98"])
    assert status == 1 and res["verdict"] == "FAIL", "a 2 % error in rho went unnoticed"
    for key in ("0.8", "1"):
        assert not all(p["pass"] for pts in res["brdf"][key].values() for p in pts), key
        assert not all(r["pass"] for r in res["images"][key]), key
