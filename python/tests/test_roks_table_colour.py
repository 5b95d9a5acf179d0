"""The Mitsuba plugin `roks_table` with spectral tables (a `brdf.csv` with
`wavelength_um`), through Mitsuba's BSDF interface in scalar_spectral and
scalar_rgb:

1. grey: a spectral table of a grey surface (constant reflectance 0.8 on a
   rough Gaussian field, 0.38-0.78 um every 0.05 um: roks's spectral run
   equals its monochrome run bit for bit, tests/spectral.rs) evaluates as
   the monochrome table of the same run: spectral variant, at any sampled
   wavelength, the same value (1e-12 relative before float32, here 1e-6);
   RGB variant, the monochrome value times the linear sRGB of the perfect
   white reflector (M W 1, ~ (1, 1, 1)); and sample() draws the same
   directions with the same weight (R of the table at a tabulated angle);
2. gold: a spectral table of a rough gold field (nk = scenes/materials/gold.csv,
   0.38-0.78 um every 0.02 um): in scalar_rgb the eval at each Carlson cell
   centre divided by cos(theta_o) = (r, g, b) of that cell in roks's
   colour.csv (written by roks's Rust colour code: an independent
   implementation of the formula; float32: 2e-6 relative); in
   scalar_spectral at the table's own wavelengths = brdf.csv's BRDF x cos,
   between them linear in wavelength, outside them clamped (360 nm = 380 nm,
   830 nm = 780 nm); sample weight x pdf = eval per wavelength;
3. a spectral table that does not cover the visible is refused in RGB
   variants, with a message naming the file.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from roks_tools.mitsuba import roks_table
from roks_tools.results import SPECTRAL_BRDF_COLUMNS, read_columns
from roks_tools.runner import repo_root, run

pytestmark = pytest.mark.mitsuba

GOLD = repo_root() / "scenes" / "materials" / "gold.csv"


def scene(material: str, wavelengths: str | None, bands: int = 4, photons: int = 20000) -> str:
    wl = f"wavelengths_um = {wavelengths}\n" if wavelengths else ""
    return f"""[surface]
size = [32.0, 32.0]
edges = "periodic"
material = "m"
heightfield = {{ gaussian = {{ sigma = 1.0, tau = 5.0 }}, resolution = 32, seed = 3 }}
[materials.m]
{material}
[light]
theta_deg = [0, 40]
photons = {photons}
{wl}[tally]
bands = {bands}
"""


@pytest.fixture(scope="module")
def tables(roks, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("colour-tables")
    runs = {
        "grey_mono": scene("reflectance = 0.8", None),
        "grey_spectral": scene("reflectance = 0.8", "{ from = 0.38, to = 0.78, step = 0.05 }"),
        "gold": scene(f'nk = "{GOLD}"', "{ from = 0.38, to = 0.78, step = 0.02 }"),
        "gold_red": scene(f'nk = "{GOLD}"', "[0.6, 0.65, 0.7]"),
    }
    for name, text in runs.items():
        (tmp / f"{name}.toml").write_text(text)
        run([roks, "brdf", tmp / f"{name}.toml", "--out", tmp / name, "-q"], "test_roks_table_colour", echo=False)
    return tmp


def directions(rng, n):
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1)[:, None]


def _si(mi, dr, wi, wavelengths=None):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*map(float, wi))
    if wavelengths is not None:
        si.wavelengths = type(si.wavelengths)(*wavelengths)
    return si


def test_grey_spectral_table_is_the_monochrome_one(mi, tables):
    import drjit as dr
    import mitsuba

    from roks_tools import colour as pc

    mono = roks_table.CarlsonTable(tables / "grey_mono" / "brdf.csv")
    spec = roks_table.CarlsonTable(tables / "grey_spectral" / "brdf.csv")
    assert spec.wavelengths_um is not None and len(spec.wavelengths_um) == 9
    assert np.array_equal(spec.spectral, np.repeat(mono.fractions[:, :, None], 9, axis=2))
    rng = np.random.default_rng(5)
    wi, wo = directions(rng, 200), directions(rng, 200)
    lam = rng.uniform(360, 830, size=(200, 4))
    want = mono.eval(wi, wo)
    assert np.allclose(spec.eval_spectrum(wi, wo, lam), want[:, None], rtol=1e-12, atol=0)
    white = pc.xyz_to_srgb_matrix() @ pc.weights(spec.wavelengths_um) @ np.ones(9)
    assert np.allclose(spec.eval_rgb(wi, wo), want[:, None] * white[None, :], rtol=1e-12, atol=0)

    for variant in ("scalar_spectral", "scalar_rgb"):
        mitsuba.set_variant(variant)
        roks_table.register()
        bm = mitsuba.load_dict({"type": "roks_table", "filename": str(tables / "grey_mono" / "brdf.csv")})
        bs_ = mitsuba.load_dict({"type": "roks_table", "filename": str(tables / "grey_spectral" / "brdf.csv")})
        ctx = mitsuba.BSDFContext()
        for k in range(40):
            si = _si(mitsuba, dr, wi[k], lam[k] if variant == "scalar_spectral" else None)
            wo_k = mitsuba.Vector3f(*map(float, wo[k]))
            a = np.array(bm.eval(ctx, si, wo_k), dtype=float).reshape(-1)
            b = np.array(bs_.eval(ctx, si, wo_k), dtype=float).reshape(-1)
            expect = a if variant == "scalar_spectral" else a * white
            assert np.allclose(b, expect, rtol=2e-6, atol=1e-12), (variant, k, a, b)
            u = (float(rng.random()), mitsuba.Point2f(float(rng.random()), float(rng.random())))
            sa, wa = bm.sample(ctx, si, *u)
            sb, wb = bs_.sample(ctx, si, *u)
            assert np.allclose(np.array(sa.wo), np.array(sb.wo), atol=1e-6) and abs(sa.pdf - sb.pdf) <= 1e-5 * sa.pdf
            wa, wb = np.array(wa, dtype=float).reshape(-1), np.array(wb, dtype=float).reshape(-1)
            expect = wa if variant == "scalar_spectral" else wa * white
            assert np.allclose(wb, expect, rtol=2e-6, atol=1e-12), (variant, k, wa, wb)


def test_gold_table_colour_and_spectrum(mi, tables):
    import drjit as dr
    import mitsuba

    folder = tables / "gold"
    t = roks_table.CarlsonTable(folder / "brdf.csv")
    cols = read_columns(folder / "brdf.csv", SPECTRAL_BRDF_COLUMNS)
    colours = read_columns(folder / "colour.csv")
    wl = np.array(t.wavelengths_um)
    assert len(wl) == 21

    mitsuba.set_variant("scalar_rgb")
    roks_table.register()
    b = mitsuba.load_dict({"type": "roks_table", "filename": str(folder / "brdf.csv")})
    ctx = mitsuba.BSDFContext()
    worst = 0.0
    checked = 0
    for row in range(len(colours["band"])):
        th_i = colours["theta_i_deg"][row]
        rgb = np.array([colours[c][row] for c in "rgb"])
        if rgb.max() <= 0:
            continue
        th, ph = math.radians(colours["theta_deg"][row]), math.radians(colours["phi_deg"][row])
        wo = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
        wi = (math.sin(math.radians(th_i)), 0.0, math.cos(math.radians(th_i)))
        v = np.array(b.eval(ctx, _si(mitsuba, dr, wi), mitsuba.Vector3f(*wo)), dtype=float) / wo[2]
        scale = np.abs(rgb).max()
        worst = max(worst, float(np.abs(v - rgb).max() / scale))
        checked += 1
    assert checked >= 30 and worst <= 2e-6, (checked, worst)
    # gold: red above green above blue in the specular cells at normal incidence
    first = colours["theta_i_deg"] == 0
    assert np.all(colours["r"][first & (colours["band"] == 1)] > colours["b"][first & (colours["band"] == 1)])

    mitsuba.set_variant("scalar_spectral")
    roks_table.register()
    b = mitsuba.load_dict({"type": "roks_table", "filename": str(folder / "brdf.csv")})
    ctx = mitsuba.BSDFContext()
    sel = (cols["theta_i_deg"] == 40) & (cols["band"] == 2) & (cols["cell"] == 0)
    brdf = cols["brdf"][sel]  # per wavelength, in order
    th, ph = math.radians(cols["theta_deg"][sel][0]), math.radians(cols["phi_deg"][sel][0])
    wo = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
    wi = (math.sin(math.radians(40)), 0.0, math.cos(math.radians(40)))
    for lam in ([380.0, 450.0, 560.0, 780.0], [390.0, 555.0, 360.0, 830.0]):
        v = np.array(b.eval(ctx, _si(mitsuba, dr, wi, lam), mitsuba.Vector3f(*wo)), dtype=float).reshape(-1)
        want = np.interp(np.array(lam), 1000 * wl, brdf) * wo[2]  # np.interp clamps at the ends
        assert np.allclose(v, want, rtol=2e-6, atol=0), (lam, v, want)
    rng = np.random.default_rng(3)
    for _ in range(30):
        lam = rng.uniform(360, 830, 4)
        si = _si(mitsuba, dr, wi, lam)
        bs, w = b.sample(ctx, si, float(rng.random()), mitsuba.Point2f(float(rng.random()), float(rng.random())))
        if bs.pdf <= 0:
            continue
        ev = np.array(b.eval(ctx, si, bs.wo), dtype=float).reshape(-1)
        assert np.allclose(np.array(w, dtype=float).reshape(-1) * bs.pdf, ev, rtol=1e-5, atol=1e-9)


def test_spectral_table_without_the_visible_is_refused_in_rgb(mi, tables):
    import mitsuba

    mitsuba.set_variant("scalar_rgb")
    roks_table.register()
    path = tables / "gold_red" / "brdf.csv"
    with pytest.raises(Exception, match="gold_red/brdf.csv.*do not cover"):
        mitsuba.load_dict({"type": "roks_table", "filename": str(path)})
    # the spectral variant takes it (clamped outside 0.6-0.7 um)
    mitsuba.set_variant("scalar_spectral")
    roks_table.register()
    mitsuba.load_dict({"type": "roks_table", "filename": str(path)})
