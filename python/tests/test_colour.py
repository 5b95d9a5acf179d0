"""The colour roks writes against the colour computed here, independently of
roks's Rust colour code (`roks_tools.colour`: colour-science's CIE 1931
tables, D65 and sRGB):

1. the Python colour itself against published numbers: the D65 white point
   (x, y) = (0.31272, 0.32903) (CIE 015:2018) and white -> linear sRGB
   (1, 1, 1) within 1e-3 (IEC 61966-2-1's rounded matrix);
2. a flat gold mirror at normal incidence (`nk = scenes/materials/gold.csv`,
   0.38-0.78 um every 5 nm): roks's reflectance per wavelength = the Fresnel
   reflectance ((n-1)^2 + k^2) / ((n+1)^2 + k^2) of n, k interpolated
   linearly from the same table here (1e-12); its `colour` in summary.json
   (XYZ, linear sRGB: 1e-12 relative; srgb8 exactly) and colour.csv (band
   1's four cells share the specular photons: XYZ and rgb of R / (4 proj),
   to the file's ten significant digits) = the colour computed here.
   A flat mirror is exact: every photon reflects once with weight R, so
   nothing is statistical.
"""

from __future__ import annotations

import json

import numpy as np

from roks_tools import colour as pc
from roks_tools.carlson import CarlsonGrid
from roks_tools.results import read_columns
from roks_tools.runner import repo_root, run

GOLD = repo_root() / "scenes" / "materials" / "gold.csv"


def test_python_colour_against_published_numbers():
    w = np.round(np.arange(0.38, 0.78 + 1e-9, 0.005) * 1e9) / 1e9
    white = pc.xyz(w, np.ones(len(w)))
    assert abs(white[1] - 1.0) < 1e-12
    xy = white[:2] / white.sum()
    assert abs(xy[0] - 0.31272) < 5e-6 and abs(xy[1] - 0.32903) < 5e-6, xy
    assert np.all(np.abs(pc.linear_srgb(white) - 1.0) < 1e-3)


def test_flat_gold_mirror_srgb(roks, tmp_path):
    scene = tmp_path / "flat-gold.toml"
    scene.write_text(f"""[surface]
size = [10.0, 10.0]
material = "gold"
[materials.gold]
nk = "{GOLD}"
[light]
theta_deg = [0]
photons = 1000
wavelengths_um = {{ from = 0.38, to = 0.78, step = 0.005 }}
[tally]
bands = 4
""")
    out = tmp_path / "out"
    run([roks, "brdf", scene, "--out", out, "-q"], "test_colour", echo=False)
    summary = json.loads((out / "summary.json").read_text())
    wl = np.array(summary["run"]["wavelengths_um"])
    assert len(wl) == 81 and abs(wl[0] - 0.38) < 1e-12 and abs(wl[-1] - 0.78) < 1e-12
    table = pc.read_nk_csv(GOLD)
    expected_r = pc.fresnel_normal(np.interp(wl, table[:, 0], table[:, 1]), np.interp(wl, table[:, 0], table[:, 2]))
    (entry,) = summary["incidence"]
    got_r = np.array([s["reflectance"] for s in entry["spectrum"]])
    assert np.allclose(got_r, expected_r, rtol=1e-12, atol=0), np.max(np.abs(got_r - expected_r))
    # every photon carries R exactly: the standard error is rounding (sqrt of a difference of sums)
    assert all(s["reflectance_stderr"] <= 1e-7 * s["reflectance"] for s in entry["spectrum"])

    xyz = pc.xyz(wl, expected_r)
    rgb = pc.linear_srgb(xyz)
    c = entry["colour"]
    assert np.allclose(c["xyz"], xyz, rtol=1e-12, atol=0), (c["xyz"], xyz)
    assert np.allclose(c["srgb_linear"], rgb, rtol=1e-12, atol=1e-15), (c["srgb_linear"], rgb)
    assert list(c["srgb8"]) == pc.srgb8(rgb).tolist(), (c["srgb8"], pc.srgb8(rgb))
    # gold: red above green above blue, blue well below (a published-shape sanity check)
    assert rgb[0] > rgb[1] > rgb[2] > 0

    cells = read_columns(out / "colour.csv")
    grid = CarlsonGrid(4)
    proj = grid.projected_solid_angle
    for row in range(len(cells["band"])):
        flat = row  # one incidence: rows in flat cell order
        share = 0.25 if cells["band"][row] == 1 else 0.0
        want_xyz = share * xyz / proj[flat]
        want_rgb = share * rgb / proj[flat]
        got_xyz = np.array([cells[k][row] for k in "XYZ"])
        got_rgb = np.array([cells[k][row] for k in "rgb"])
        assert np.allclose(got_xyz, want_xyz, rtol=1e-9, atol=1e-300), (row, got_xyz, want_xyz)
        assert np.allclose(got_rgb, want_rgb, rtol=1e-9, atol=1e-12), (row, got_rgb, want_rgb)
