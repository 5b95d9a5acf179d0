"""roks's RGL export read and evaluated the way pbrt-v4 does it
(`roks_tools.pbrt_measured`, a numpy port of pbrt-v4's `MeasuredBxDF`:
pbrt itself is in no package registry and needs its git submodules, so CI
cannot build it).

The exported files are test_rgl.py's (its `folders` fixture and helpers,
imported from there): the default scene, the Gaussian aluminium field and
the spectral gold bumps.

* Per cell (numpy only): pbrt's `f(wo, wi)` with `wo` towards the camera
  along the table's incidence and `wi` towards the light at the centre of
  every Carlson cell (so `f cos(theta_wi)` is the table's BRDF times
  cos(theta_o)) agrees with brdf.csv within 4 standard errors plus the
  stated resampling bound (test_rgl.py's `bound`), as Mitsuba's `measured`
  does there; monochrome files at 4 wavelengths pbrt samples, the gold one
  at each of its wavelengths.
* pbrt against Mitsuba (`mitsuba`): at 3000 random pairs of directions and
  4 wavelengths each (drawn as pbrt draws them), pbrt's `f cos(theta_wi)`
  is Mitsuba 3's `measured` `eval` (scalar_spectral, its `si.wi` = pbrt's
  `wo`) within float rounding (Mitsuba computes in float32): 1e-4
  relative plus the float32 epsilon in the warped sample point times the
  steepest slope of `spectra` (`pbrt_vs_mitsuba`; 1.9e-5 of the largest
  value). A file with `jacobian = 0` is where they part: Mitsuba drops the
  factor `ndf / (4 sigma)`, pbrt applies it whatever the flag says.
* Broken files (numpy only): those of test_rgl.py's
  test_broken_files_are_caught load in pbrt (they are well formed) and its
  per-cell comparison puts at least 100 cells outside the bound (the axes
  of `spectra` or of `vndf` swapped, `sigma` doubled), or, for the
  jacobian flag off, pbrt's values are those of the intact file (the flag
  is ignored; the Mitsuba test above catches that file). Files pbrt
  refuses (a missing field, as in an RGB export; a wrong type or shape; a
  half-circle anisotropic file; a damaged container) raise `PbrtError`
  with pbrt's message.
* `PiecewiseLinear2D` against exact formulas: bilinear interpolation
  reproduces a bilinear function, and the inverse warp of a density
  linear in x is the normalised integral of it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from roks_tools.pbrt_measured import (FIELDS, MeasuredData, PbrtError, PiecewiseLinear2D, read_tensor,
                                      sample_visible_wavelengths, write_tensor)
from roks_tools.results import read_columns
from test_rgl import CASES as RGL_CASES
from test_rgl import ANISO, ROOT, aniso, bound, centres, folders, run, zero_count_stderr  # noqa: F401 (fixtures)

CASES = [c for c in RGL_CASES if c[0] in ("default", "gaussian_al", "gold")]
IDS = [c[0] for c in CASES]

PBRT_WAVELENGTHS = sample_visible_wavelengths(np.array([0.3]))[0][0]
"""4 wavelengths (nm) of one pbrt camera ray: 494, 559, 635 and 398 nm."""


def pbrt_compare(folder: Path, wavelengths, path: Path | None = None):
    """Per wavelength and incidence: (wavelengths, theta_i, table BRDF, its
    standard error, pbrt's f at the cell centres (cells x 4), resampling
    bound, projected solid angles, fractions). A monochrome file is
    evaluated at `PBRT_WAVELENGTHS`, a spectral one at each of its
    wavelengths (4 times)."""
    c = read_columns(folder / "brdf.csv")
    brdf = MeasuredData.load(path or folder / "rgl.bsdf")
    bands = int(c["band"].max())
    for lam in (wavelengths or [None]):
        lams = PBRT_WAVELENGTHS if lam is None else [lam] * 4
        for theta in np.unique(c["theta_i_deg"]):
            sel = c["theta_i_deg"] == theta
            if lam is not None:
                sel &= np.isclose(c["wavelength_um"], lam / 1e3)
            wi = centres(c, sel)
            t = np.radians(theta)
            wo = np.tile([np.sin(t), 0.0, np.cos(t)], (len(wi), 1))
            yield (lams, theta, c["brdf"][sel], c["brdf_stderr"][sel], brdf.f(wo, wi, lams),
                   bound(c, sel, bands), c["projected_solid_angle_sr"][sel], c["fraction"][sel])


def cells_off(folder: Path, wavelengths, path: Path | None = None) -> tuple[int, int, list[str]]:
    """Cells (times wavelengths) where pbrt's f is outside 4 standard errors
    + the resampling bound, of how many, and a line per bad incidence."""
    off, total, lines = 0, 0, []
    for lams, theta, f, se, got, b, proj, fraction in pbrt_compare(folder, wavelengths, path):
        allowed = (4 * zero_count_stderr(f, se, proj, fraction) + b + 1e-5 * f.max())[:, None]
        bad = ~(np.abs(got - f[:, None]) <= allowed)  # NaN (pbrt undefined) is off
        off, total = off + int(bad.sum()), total + bad.size
        if bad.any():
            worst = np.nanmax((np.abs(got - f[:, None]) - allowed)[bad])
            lines.append(f"{lams} nm theta_i {theta}: {bad.sum()} of {bad.size} off, worst {worst:.3g} 1/sr "
                         f"beyond the allowed; table {f[bad.any(axis=1)][:5]}, pbrt {got[bad.any(axis=1)][:5]}")
    return off, total, lines


@pytest.mark.parametrize("name,scene,opts,wavelengths", CASES, ids=IDS)
def test_pbrt_f_matches_the_table_per_cell(folders, name, scene, opts, wavelengths):
    off, total, lines = cells_off(folders[name], wavelengths)
    assert total > 0 and off == 0, "\n".join(lines)


@pytest.mark.parametrize("name,scene,opts,wavelengths", CASES, ids=IDS)
def test_pbrt_reflectance_matches_the_table(folders, name, scene, opts, wavelengths):
    """pbrt's f summed over the cells (times their projected solid angles)
    is the table's reflectance within max(1 %, 4 sigma), at every wavelength."""
    for lams, theta, f, se, got, _, proj, _ in pbrt_compare(folders[name], wavelengths):
        r_table, r_file = (f * proj).sum(), (got * proj[:, None]).sum(axis=0)
        allowed = max(0.01 * r_table, 4 * np.sqrt(((se * proj) ** 2).sum()))
        assert np.all(np.abs(r_file - r_table) <= allowed), (name, lams, theta, r_file, r_table, allowed)


def random_pairs(n: int, seed: int):
    """n pairs of directions uniform in projected solid angle over the upper
    hemisphere, and 4 wavelengths per pair drawn as pbrt draws them."""
    rng = np.random.default_rng(seed)

    def hemisphere():
        u = rng.random((2, n))
        s = np.sqrt(u[0])
        return np.stack([s * np.cos(2 * np.pi * u[1]), s * np.sin(2 * np.pi * u[1]), np.sqrt(1 - u[0])], axis=1)

    wo, wi = hemisphere(), hemisphere()
    return wo, wi, sample_visible_wavelengths(rng.random(n))[0]


def mitsuba_eval_pairs(path: Path, wo, wi, lam):
    """Mitsuba 3's `measured` eval (scalar_spectral) with `si.wi` = pbrt's
    `wo` and the eval direction = pbrt's `wi`, at each pair's wavelengths."""
    import mitsuba as m
    m.set_variant("scalar_spectral")
    bsdf = m.load_dict({"type": "measured", "filename": str(path)})
    ctx, si = m.BSDFContext(), m.SurfaceInteraction3f()
    out = np.empty((len(wo), 4))
    for k in range(len(wo)):
        si.wi = m.Vector3f(*wo[k])
        si.wavelengths = lam[k].tolist()
        out[k] = np.array(bsdf.eval(ctx, si, m.Vector3f(*wi[k])))
    return out


def pbrt_vs_mitsuba(path: Path, seed: int, pairs=None):
    """(pbrt's f cos(theta_wi), Mitsuba's eval, which values differ beyond
    float rounding). Float rounding: 1e-4 relative, plus the float32
    epsilon in the warped sample point times the steepest slope `spectra`
    can have, its largest value over one cell, 1/(n - 1) of the unit
    square: eps (n - 1) max (n = 160 nodes a side: 1.9e-5 of the largest).
    At 3000 `random_pairs`, or at the given (wo, wi, lam) `pairs`."""
    wo, wi, lam = random_pairs(3000, seed) if pairs is None else pairs
    pbrt = MeasuredData.load(path).f(wo, wi, lam) * wi[:, 2:3]
    mitsuba = mitsuba_eval_pairs(path, wo, wi, lam)
    n = read_tensor(path)["spectra"].shape[-1]
    allowed = 1e-4 * np.abs(mitsuba) + np.finfo(np.float32).eps * (n - 1) * np.abs(mitsuba).max()
    return pbrt, mitsuba, ~(np.abs(pbrt - mitsuba) <= allowed)


@pytest.mark.mitsuba
@pytest.mark.parametrize("name,scene,opts,wavelengths", CASES, ids=IDS)
def test_pbrt_f_cos_is_mitsuba_measured_eval(mi, folders, name, scene, opts, wavelengths):
    pbrt, mitsuba, off = pbrt_vs_mitsuba(folders[name] / "rgl.bsdf", seed=IDS.index(name))
    assert (mitsuba > 0).sum() > 4000  # not a comparison of zeros (measured: 4188 to 10908 of 12000)
    assert not off.any(), (off.sum(), pbrt[off][:5], mitsuba[off][:5])


@pytest.mark.parametrize("name", list(ANISO))
def test_anisotropic_files_load_in_pbrt(aniso, name):
    """The anisotropic files of test_rgl.py (the grooves at the whole
    circle, 0-180 and 0-90 of light azimuths) span the whole circle, so
    pbrt-v4's loader takes them (it refuses any reduction but 1: a 0-180
    file written with Mitsuba's reduction 2 was refused), anisotropic, and
    its f at the first node's light is not 0 everywhere."""
    path = aniso[name] / "rgl.bsdf"
    data = MeasuredData.load(path)
    assert not data.isotropic
    wo, wi, lam = random_pairs(2000, seed=10 + list(ANISO).index(name))
    assert (data.f(wo, wi, lam) > 0).any()


def sampled_pairs(path: Path, n: int, seed: int):
    """n pairs where the file's BRDF is not 0: `wo` (pbrt's, Mitsuba's
    `si.wi`) uniform in projected solid angle, `wi` drawn by Mitsuba's
    `measured` `sample` from it (scalar_spectral), and 4 wavelengths per
    pair as pbrt draws them. Uniform pairs miss the grooves' spikes: 340
    to 440 of 12 000 values are not 0."""
    import mitsuba as m
    m.set_variant("scalar_spectral")
    bsdf = m.load_dict({"type": "measured", "filename": str(path)})
    wo, _, lam = random_pairs(n, seed)
    u = np.random.default_rng(seed + 1000).random((n, 3))
    ctx, si = m.BSDFContext(), m.SurfaceInteraction3f()
    wi = np.empty_like(wo)
    for k in range(n):
        si.wi = m.Vector3f(*wo[k])
        si.wavelengths = lam[k].tolist()
        bs, _ = bsdf.sample(ctx, si, float(u[k, 0]), m.Point2f(float(u[k, 1]), float(u[k, 2])))
        wi[k] = np.array(bs.wo)
    keep = wi[:, 2] > 0
    return wo[keep], wi[keep], lam[keep]


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", list(ANISO))
def test_pbrt_f_cos_is_mitsuba_eval_on_anisotropic_files(mi, aniso, name):
    """pbrt's `f cos` is Mitsuba's `eval` on the anisotropic files too,
    within the float rounding bound of the isotropic test above, at 3000
    pairs drawn by Mitsuba's `sample` (so on the grooves' spikes and NDF
    peaks, where uniform pairs give 0). With 96 x 96 `spectra` nodes
    taken at the nodes, 16 of 12 000 values of the 0-90 file were 3e-4
    apart at the NDF peaks."""
    path = aniso[name] / "rgl.bsdf"
    seed = 20 + list(ANISO).index(name)
    pbrt, mitsuba, off = pbrt_vs_mitsuba(path, seed, sampled_pairs(path, 3000, seed))
    assert (mitsuba > 0).sum() > 0.9 * mitsuba.size, (mitsuba > 0).sum()
    assert not off.any(), (off.sum(), pbrt[off][:5], mitsuba[off][:5])


@pytest.mark.mitsuba
def test_jacobian_flag_off_parts_mitsuba_and_pbrt(mi, folders, tmp_path):
    """A file with `jacobian = 0`: Mitsuba leaves out ndf / (4 sigma), pbrt
    does not, so they differ at most pairs (the reason roks writes 1)."""
    t = read_tensor(folders["default"] / "rgl.bsdf")
    write_tensor(tmp_path / "j0.bsdf", {**t, "jacobian": np.array([0], np.uint8)})
    _, mitsuba, off = pbrt_vs_mitsuba(tmp_path / "j0.bsdf", seed=0)
    assert off.sum() > 0.5 * (mitsuba > 0).sum(), (off.sum(), (mitsuba > 0).sum())


BREAKS = {
    "spectra axes swapped": lambda t: {"spectra": np.ascontiguousarray(np.swapaxes(t["spectra"], 3, 4))},
    "vndf axes swapped": lambda t: {"vndf": np.ascontiguousarray(np.swapaxes(t["vndf"], 2, 3))},
    "sigma doubled": lambda t: {"sigma": t["sigma"] * np.float32(2)},
}
"""test_rgl.py's broken files that pbrt loads and evaluates wrongly."""


def test_pbrt_broken_files_are_caught(folders, tmp_path):
    """The broken files load in pbrt; the per-cell comparison puts at least
    100 cell values outside the bound (the intact file: none of 25 344,
    6336 cells at 4 wavelengths; measured 11 568, 14 708 and 10 624 for
    the three breaks). With the jacobian flag off pbrt's f is the intact
    file's, bit for bit."""
    src = folders["default"]
    orig = read_tensor(src / "rgl.bsdf")
    for what, change in BREAKS.items():
        path = tmp_path / (what.replace(" ", "_") + ".bsdf")
        write_tensor(path, {**orig, **change(orig)})
        off, total, _ = cells_off(src, None, path)
        assert off >= 100, (what, off, total)
    write_tensor(tmp_path / "j0.bsdf", {**orig, "jacobian": np.array([0], np.uint8)})
    for intact, j0 in zip(pbrt_compare(src, None), pbrt_compare(src, None, tmp_path / "j0.bsdf")):
        assert np.array_equal(intact[4], j0[4])


def test_pbrt_clamps_at_zero_and_interpolates_wavelengths(folders, tmp_path):
    """pbrt's `max(0, spectra)`: a file with `spectra` negated gives f = 0
    everywhere (Mitsuba would give -f). Between the gold file's wavelengths
    pbrt's f is linear in the wavelength, outside them the nearest one's."""
    gold = folders["gold"] / "rgl.bsdf"
    t = read_tensor(gold)
    write_tensor(tmp_path / "negative.bsdf", {**t, "spectra": -t["spectra"]})
    wo, wi, lam = random_pairs(500, seed=7)
    f = MeasuredData.load(gold).f(wo, wi, lam)
    assert (f > 0).sum() > 500
    assert np.array_equal(MeasuredData.load(tmp_path / "negative.bsdf").f(wo, wi, lam), np.zeros_like(f))
    at = MeasuredData.load(gold).f
    f450, f500, f550 = (at(wo, wi, [nm] * 4)[:, 0] for nm in (450.0, 500.0, 550.0))
    np.testing.assert_allclose(f500, 0.5 * (f450 + f550), rtol=1e-6, atol=1e-12)
    np.testing.assert_array_equal(at(wo, wi, [400.0] * 4)[:, 0], f450)
    np.testing.assert_array_equal(at(wo, wi, [700.0] * 4)[:, 0], at(wo, wi, [650.0] * 4)[:, 0])


def _without(name):
    return lambda t: {k: v for k, v in t.items() if k != name}


def _with(**change):
    return lambda t: {**t, **{k: f(t) for k, f in change.items()}}


REFUSED = {
    **{f"no {name}": (_without(name), f"no field '{name}'") for name in FIELDS},
    "theta_i float64": (_with(theta_i=lambda t: t["theta_i"].astype(np.float64)), "theta_i float32 of rank 1"),
    "description int8": (_with(description=lambda t: t["description"].astype(np.int8)), "description uint8"),
    "ndf of rank 1": (_with(ndf=lambda t: t["ndf"].ravel()), "ndf float32 of rank 2"),
    "one wavelength less": (_with(wavelengths=lambda t: t["wavelengths"][:-1]), "spectra float32 [n_phi"),
    "vndf of another theta_i": (_with(vndf=lambda t: t["vndf"][:, :-1]), "vndf float32 [n_phi, n_theta"),
    "luminance not square": (_with(luminance=lambda t: t["luminance"][..., :-1]), "luminance float32"),
    "luminance finer than spectra": (_with(luminance=lambda t: np.repeat(np.repeat(t["luminance"], 2, 2), 2, 3)),
                                     "luminance and spectra of the same n"),
    "jacobian of two": (_with(jacobian=lambda t: np.array([1, 1], np.uint8)), "jacobian uint8 of shape [1]"),
    "jacobian as int32": (_with(jacobian=lambda t: np.array([1], np.int32)), "jacobian uint8 of shape [1]"),
}
"""Files pbrt-v4 refuses: the change to an intact file, and the message."""


def anisotropic_half_circle(t):
    """Three light azimuths over 0-180 degrees: Mitsuba's reduction 2
    (mirror symmetry), which pbrt does not support."""
    n = 3
    return {**t, "phi_i": np.linspace(0, np.pi, n, dtype=np.float32),
            **{k: np.repeat(t[k], n, axis=0) for k in ("vndf", "luminance", "spectra")}}


def test_pbrt_refuses_what_pbrt_refuses(folders, tmp_path):
    orig = read_tensor(folders["default"] / "rgl.bsdf")
    MeasuredData.load(folders["default"] / "rgl.bsdf")
    cases = {**REFUSED, "anisotropic half circle": (anisotropic_half_circle, "reduction 2 (!= 1) not supported")}
    for what, (change, message) in cases.items():
        path = tmp_path / (what.replace(" ", "_") + ".bsdf")
        write_tensor(path, change(orig))
        with pytest.raises(PbrtError, match=r"^\S+: .*" + re.escape(message)):
            MeasuredData.load(path)
    # The same file over the whole circle loads (anisotropic, reduction 1).
    whole = anisotropic_half_circle(orig)
    whole["phi_i"] = np.linspace(-np.pi, np.pi, 3, dtype=np.float32)
    write_tensor(tmp_path / "whole.bsdf", whole)
    assert not MeasuredData.load(tmp_path / "whole.bsdf").isotropic


def test_pbrt_refuses_damaged_containers(folders, tmp_path):
    raw = (folders["default"] / "rgl.bsdf").read_bytes()
    cases = {
        "too short": (raw[:17], "too small, truncated?"),
        "header": (b"tensor_fild\0" + raw[12:], "invalid header."),
        "version": (raw[:12] + b"\x02\x00" + raw[14:], "unknown file version."),
        "unknown type": (raw.replace(b"theta_i\x01\x00\x0a", b"theta_i\x01\x00\x0c", 1), "unknown type."),
        "cut short": (raw[:-100], "Unable to read data.get()."),
    }
    for what, (data, message) in cases.items():
        path = tmp_path / (what.replace(" ", "_") + ".bsdf")
        path.write_bytes(data)
        with pytest.raises(PbrtError, match="Tensor: .*" + re.escape(message)):
            MeasuredData.load(path)


def test_pbrt_refuses_the_rgb_export(roks, tmp_path):
    """`export-brdf --rgb` writes `rgb` instead of `spectra` and
    `wavelengths` (for Mitsuba's RGB variants): pbrt stops at the first
    missing field it fetches."""
    out = tmp_path / "gold"
    scene = ROOT / "scenes" / "gold-spectral.toml"
    run(roks, "brdf", scene, "--out", out, "-q", "--photons", 20_000, "--theta", "30")
    run(roks, "export-brdf", out, "--format", "rgl", "--rgb", "--out", out / "rgb.bsdf", "-q", "--scene", scene)
    assert "rgb" in read_tensor(out / "rgb.bsdf")
    with pytest.raises(PbrtError, match="no field 'spectra'"):
        MeasuredData.load(out / "rgb.bsdf")


def test_tensor_round_trip(folders, tmp_path):
    """write_tensor(read_tensor(file)) keeps every field, type and shape."""
    orig = read_tensor(folders["gold"] / "rgl.bsdf")
    write_tensor(tmp_path / "copy.bsdf", orig)
    copy = read_tensor(tmp_path / "copy.bsdf")
    assert list(copy) == list(orig)
    for k in orig:
        assert copy[k].dtype == orig[k].dtype and copy[k].shape == orig[k].shape
        assert np.array_equal(copy[k], orig[k])


def test_piecewise_linear_2d_exact():
    """Evaluate reproduces a bilinear function (no normalisation) and, with
    a parameter, interpolates linearly between its slices; Invert of the
    density p(x, y) = (1 + a x) / (1 + a / 2) (3 x 2 nodes) is
    (x + a x^2 / 2) / (1 + a / 2) in x and y in y, with density p."""
    x, y = np.linspace(0, 1, 5), np.linspace(0, 1, 4)
    g = lambda x, y: 1 + 2 * x + 3 * y + 4 * x * y  # noqa: E731
    table = g(x[None, :], y[:, None])
    pts = np.random.default_rng(0).random((50, 2))
    got = PiecewiseLinear2D(table, normalize=False, build_cdf=False).evaluate(pts)
    np.testing.assert_allclose(got, g(pts[:, 0], pts[:, 1]), rtol=1e-6)

    slices = PiecewiseLinear2D(np.stack([table, 3 * table]), ([10.0, 20.0],), normalize=False, build_cdf=False)
    for p, scale in ((10.0, 1.0), (12.5, 1.5), (20.0, 3.0), (5.0, 1.0), (30.0, 3.0)):
        np.testing.assert_allclose(slices.evaluate(pts, np.full(len(pts), p)), scale * g(pts[:, 0], pts[:, 1]),
                                   rtol=1e-6)

    a = 3.0
    xs = np.linspace(0, 1, 3)
    density = np.tile(1 + a * xs, (2, 1))
    u, pdf = PiecewiseLinear2D(density).invert(pts)
    norm = 1 + a / 2
    np.testing.assert_allclose(u[:, 0], (pts[:, 0] + a * pts[:, 0] ** 2 / 2) / norm, rtol=1e-6)
    np.testing.assert_allclose(u[:, 1], pts[:, 1], rtol=1e-6)
    np.testing.assert_allclose(pdf, (1 + a * pts[:, 0]) / norm, rtol=1e-6)


def test_sample_visible_wavelengths():
    """pbrt's visible-wavelength sampling: u = 0 gives 360 nm and u -> 1
    830 nm (its tabulated fit), the 4 wavelengths of a ray are quarter
    periods apart in u, and the density integrates to 1 over 360-830 nm."""
    lam, pdf = sample_visible_wavelengths(np.array([0.0, 0.25]))
    np.testing.assert_allclose(lam[0, 0], 360.0, atol=0.05)
    np.testing.assert_allclose(lam[0, 1:], lam[1, :3])
    grid = np.linspace(0, 1, 200_001)[1:-1]
    l, p = sample_visible_wavelengths(grid)
    np.testing.assert_allclose(l[-1, 0], 830.0, atol=0.5)
    np.testing.assert_allclose(np.trapezoid(p[:, 0], l[:, 0]), 1.0, rtol=1e-3)
