"""The spectral cross-check against Mitsuba 3 with Mitsuba's own gold
(`roks_tools.studies.spectral_crosscheck`, small):

1. the tracer's gold is Mitsuba's: `MitsubaConductor` (llvm_ad_spectral,
   the `conductor` plugin, preset Au, at fixed wavelengths) = the
   unpolarised Fresnel reflectance of n, k interpolated linearly here from
   Mitsuba's Au.eta.spd / Au.k.spd (float32: 1e-6), and `mitsuba_ior`
   (llvm_ad_spectral_polarized) returns those n, k;
2. the whole check on a Gaussian field of gold: roks (nk = Mitsuba's .spd
   pair) against the tracer on the exported mesh, polarised
   (llvm_ad_spectral_polarized) and unpolarised (llvm_ad_spectral),
   reflectance per incidence and wavelength |z| <= 4, XYZ per Carlson cell
   on a 0.38-0.78 um grid within the Bonferroni limit; the verdict PASS;
3. its power: roks with Johnson & Christy's gold (scenes/materials/gold.csv)
   against the same Mitsuba run fails (the two gold data sets differ by
   0.02-0.06 in normal reflectance, hundreds of standard errors).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from roks_tools import colour as pc
from roks_tools.mitsuba.tracer import fresnel_unpolarised
from roks_tools.runner import repo_root

pytestmark = pytest.mark.mitsuba

WAVELENGTHS = [0.40, 0.45, 0.55, 0.65, 0.75]


def _python(code: str) -> dict:
    """Run `code` in a fresh interpreter (a Mitsuba variant per process) and return its JSON."""
    o = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=repo_root())
    assert o.returncode == 0, o.stderr
    return json.loads(o.stdout.strip().splitlines()[-1])


def spd_nk(wavelengths_um):
    from roks_tools.studies.spectral_crosscheck import mitsuba_ior_dir

    ior = mitsuba_ior_dir()
    eta, k = pc.read_spd(ior / "Au.eta.spd"), pc.read_spd(ior / "Au.k.spd")
    nm = 1000 * np.asarray(wavelengths_um)
    return np.interp(nm, eta[:, 0], eta[:, 1]), np.interp(nm, k[:, 0], k[:, 1])


def test_tracer_gold_is_mitsubas():
    cos = [1.0, 0.9, 0.6427876, 0.3, 0.05]
    got = _python(f"""
import json, numpy as np
from roks_tools.mitsuba.setup import setup_mitsuba
from roks_tools.mitsuba.tracer import MitsubaConductor
mi = setup_mitsuba("auto", spectral=True)
r = MitsubaConductor(mi, "Au", {WAVELENGTHS!r})(np.array({cos!r}))
print(json.dumps({{"variant": mi.variant(), "r": r.tolist()}}))""")
    n, k = spd_nk(WAVELENGTHS)
    want = np.stack([fresnel_unpolarised(np.array(cos), a, b) for a, b in zip(n, k)], axis=1)
    assert "spectral" in got["variant"]
    assert np.allclose(got["r"], want, rtol=0, atol=1e-6), (got["r"], want)
    nk = _python(f"""
import json
from roks_tools.mitsuba.setup import setup_mitsuba
from roks_tools.mitsuba.tracer import mitsuba_ior
mi = setup_mitsuba("auto", spectral=True, polarised=True)
print(json.dumps(mitsuba_ior(mi, "Au", {WAVELENGTHS!r})))""")
    assert np.allclose(nk[0], n, rtol=1e-6) and np.allclose(nk[1], k, rtol=1e-6), (nk, n, k)


@pytest.mark.slow
def test_spectral_crosscheck_on_a_gaussian_field_of_gold(roks, tmp_path):
    from roks_tools.studies import spectral_crosscheck as sc

    out = tmp_path / "sc"
    code = sc.main(["--out", str(out), "--roks", roks, "--photons", "100000", "--roks-photons", "200000",
                    "--colour-wavelengths", "0.38:0.78:0.04", "-q"])
    res = json.loads((out / "spectral_crosscheck.json").read_text())
    failures = []
    for name, e in res["pairs"].items():
        for r in e["reflectance"]:
            if not abs(r["z"]) <= 4:
                failures.append(f"{name}: theta {r['theta']} wavelength {r['wavelength_um']}: z {r['z']:.2f}")
        for c in e.get("colour", []):
            if not (c["cells"] > 50 and c["max_z"] <= c["limit"]):
                failures.append(f"{name}: colour theta {c['theta']}: {c['cells']} cells, max z {c['max_z']:.2f}")
    variants = {name: e["variant"] for name, e in res["pairs"].items()}
    assert variants["few_polarised"].endswith("spectral_polarized"), variants
    assert variants["few_unpolarised"].endswith("_spectral"), variants
    # the data sets differ beyond any noise: the control must fail
    assert res["control"]["fails"], res["control"]
    assert max(abs(r["z"]) for r in res["control"]["reflectance"]) > 20
    assert max(abs(g["R0_jc"] - g["R0_mitsuba"]) for g in res["gold_data"]) > 0.01
    assert not failures, "\n".join(failures)
    assert code == 0 and res["verdict"] == "PASS"
