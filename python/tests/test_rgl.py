"""roks's RGL export (`roks export-brdf --format rgl`, src/export/rgl.rs) read
by Mitsuba 3's own `measured` plugin (no roks code on the reading side).

* The file loads in `scalar_spectral` and Mitsuba's `eval` (which is
  f cos(theta_o)) at the centre of every Carlson cell agrees with brdf.csv's
  BRDF times cos(theta_o) within 4 standard errors plus the stated
  resampling error of the cell: the file's value between its nodes is a
  local interpolation of the table (src/export/rgl.rs, "Resampling error"),
  so at a cell's centre it lies between the values of the cells around it
  and of their mirror images; the bound is the largest difference between
  the cell and any cell whose centre is within two band widths (or its
  mirror image's), a number taken from the table, not tuned. Scenes: the
  default (bumps), a Gaussian height field of aluminium (Fresnel n, k), and
  a spectral gold bump field (every wavelength).
* The reflectance of Mitsuba's eval summed over the cells agrees with the
  table's within max(1 %, 4 sigma) + the same resampling bound summed.
* `mitsuba.chi2`: Mitsuba's chi-square test of `sample` against `pdf` on the
  exported file passes (as for its own measured materials).
* pbrt-v4 (not built here): the fields its loader requires, `spectra` and
  `wavelengths` (pbrt-v4 src/pbrt/bxdfs.cpp, MeasuredBxDFData::Create:
  `tensorFile.field("spectra")`, `field("wavelengths")`, and the shapes it
  checks), with `jacobian` = 1 (pbrt applies the Jacobian whatever the flag
  says, so a portable file must be written with it).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from roks_tools.results import read_columns

pytestmark = pytest.mark.mitsuba
ROOT = Path(__file__).resolve().parents[2]


def run(roks, *args):
    p = subprocess.run([roks, *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return p.stderr


def export(roks, tmp: Path, name: str, scene: str | None, *opts):
    out = tmp / name
    args = ["brdf", *([] if scene is None else [ROOT / "scenes" / scene]), "--out", out, "-q", *opts]
    run(roks, *args)
    run(roks, "export-brdf", out, "--format", "rgl", "--out", out / "rgl.bsdf", "-q",
        *([] if scene is None else ["--scene", ROOT / "scenes" / scene]))
    return out


def centres(c, sel):
    to, po = np.radians(c["theta_deg"][sel]), np.radians(c["phi_deg"][sel])
    return np.stack([np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)], axis=1)


def bound(c, sel, bands, mirror=True, phi_deg=0.0):
    """Per cell: the largest |f_n - f_c| over cells n within two band widths
    of the cell or (an isotropic file, averaged with its mirror image:
    `mirror`) of its mirror image in the plane of incidence, at the light
    azimuth `phi_deg` (the stated resampling error)."""
    d = centres(c, sel)
    f = c["brdf"][sel]
    radius = np.cos(2 * np.radians(90 / bands))
    near = d @ d.T > radius
    if mirror:
        u = np.array([np.cos(np.radians(phi_deg)), np.sin(np.radians(phi_deg)), 0.0])
        h = d * np.array([1, 1, 0])
        image = 2 * (h @ u)[:, None] * u - h + d * np.array([0, 0, 1])
        near |= image @ d.T > radius
    return np.array([np.abs(f[row] - f[k]).max() for k, row in enumerate(near)])


def mitsuba_eval(mi, bsdf, theta_deg, dirs, wavelength_nm, phi_deg=0.0):
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    # At exactly normal incidence Mitsuba's light azimuth atan2(0, 0) comes
    # out as pi (the 0-degree slice is read turned by 180 degrees); the light
    # of a roks table is at azimuth 0, the limit from the +x side (at
    # azimuth phi_deg: from that side).
    t, p = max(np.radians(theta_deg), 1e-7), np.radians(phi_deg)
    si.wi = mi.Vector3f(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))
    si.wavelengths = [wavelength_nm] * 4
    return np.array([bsdf.eval(ctx, si, mi.Vector3f(*d))[0] for d in dirs])


CASES = [
    ("default", None, ["--photons", 400_000, "--theta", "0,40,70"], None),
    ("gaussian_al", "gaussian.toml", ["--photons", 400_000, "--theta", "0,40,70"], None),
    ("gold", "gold-spectral.toml", ["--photons", 100_000, "--theta", "30",
                                    "--wavelengths", "0.45,0.55,0.65"], [450.0, 550.0, 650.0]),
    # The Gaussian Al field as an ensemble of 16 realisations (256 x 256
    # each), light at azimuth 45 degrees; the file's NDF pools the facets of
    # all 16.
    ("gaussian_ensemble", "gaussian-ensemble.toml", ["--photons", 262_144, "--theta", "0,40,70"], None),
]


@pytest.fixture(scope="module")
def folders(roks, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("rgl")
    return {name: export(roks, tmp, name, scene, *opts) for name, scene, opts, _ in CASES}


def test_chi2_sample_against_pdf(mi, folders):
    """First in the file: run before the tests that switch to scalar_spectral."""
    import mitsuba as m
    m.set_variant("llvm_ad_spectral")
    from mitsuba import chi2
    path = str(folders["gaussian_al"] / "rgl.bsdf")
    for theta in (0.0, 40.0):
        t = np.radians(theta)
        wi = m.ScalarVector3f(np.sin(t), 0.0, np.cos(t))
        # ires 16: the pdf follows the fine luminance grid; at 8 points a
        # bin side its quadrature overshoots the histogram's sum (1.0038 vs
        # 0.9991 measured at 96 x 96 nodes).
        sample_func, pdf_func = chi2.BSDFAdapter("measured", f'<string name="filename" value="{path}"/>', wi=wi)
        test = chi2.ChiSquareTest(domain=chi2.SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func,
                                  sample_dim=3, res=61, ires=16, sample_count=200_000)
        assert test.run(), test.messages


# Anisotropic files: the 45-degree V-grooves of scenes/grooves.toml (along
# y; half-turn and mirror symmetric), traced at the whole circle and at 0 to
# 180 degrees of light azimuth, exported with the grooves' own NDF.
GROOVES = ROOT / "scenes" / "grooves.toml"
ANISO = {
    "circle": [0, 90, 180, 270],
    "half": [0, 45, 90, 135, 180],
    "quadrant": [0, 45, 90],
}
ANISO_THETA = [0, 30, 60]
IRES_ANISO = 32


@pytest.fixture(scope="module")
def aniso(roks, tmp_path_factory):
    """Per layout: the folder, with rgl.bsdf; and an isotropic file of the
    grooves lit across them alone (azimuth 0) in "iso"."""
    tmp = tmp_path_factory.mktemp("rgl_aniso")
    out = {}
    theta = ",".join(map(str, ANISO_THETA))
    for name, phis in {**ANISO, "iso": [0]}.items():
        d = tmp / name
        run(roks, "brdf", GROOVES, "--out", d, "-q", "--photons", 40_000, "--theta", theta,
            "--phi", ",".join(map(str, phis)))
        run(roks, "export-brdf", d, "--format", "rgl", "--out", d / "rgl.bsdf", "-q", "--scene", GROOVES)
        out[name] = d
    return out


@pytest.mark.parametrize("name,phi_deg", [("half", 90.0), ("half", 60.0), ("circle", 225.0)])
def test_chi2_anisotropic(mi, aniso, name, phi_deg):
    """`mitsuba.chi2` on the anisotropic files at 30 degrees: at a node's
    azimuth (90), between nodes (60; 225 for the circle) where the reader
    interpolates the blocks of the two nodes around."""
    import mitsuba as m
    m.set_variant("llvm_ad_spectral")
    from mitsuba import chi2
    path = str(aniso[name] / "rgl.bsdf")
    t, p = np.radians(30.0), np.radians(phi_deg)
    wi = m.ScalarVector3f(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))
    sample_func, pdf_func = chi2.BSDFAdapter("measured", f'<string name="filename" value="{path}"/>', wi=wi)
    test = chi2.ChiSquareTest(domain=chi2.SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func,
                              sample_dim=3, res=61, ires=IRES_ANISO, sample_count=200_000)
    assert test.run(), test.messages


def test_no_sample_of_zero_weight_above_the_horizon(mi, folders):
    """`sample` never returns an outgoing direction above the horizon with
    weight 0: `luminance` is 0 wherever `spectra` is 0 at every wavelength,
    so no sample lands where f = 0. Such samples are dropped by a renderer
    and by `mitsuba.chi2` while `pdf` counts them (before the fix 3e-4 of
    the samples of the Gaussian field at 40 degrees, and chi2 rejected it at
    96 x 96 nodes, p = 4e-4)."""
    import drjit as dr
    import mitsuba as m
    m.set_variant("llvm_ad_spectral")
    bsdf = m.load_dict({"type": "measured", "filename": str(folders["gaussian_al"] / "rgl.bsdf")})
    n = 200_000
    u = np.random.default_rng(1).random((3, n))
    for theta in (0.0, 40.0, 70.0):
        t = np.radians(theta)
        si = dr.zeros(m.SurfaceInteraction3f, n)
        si.wi = m.ScalarVector3f(np.sin(t), 0.0, np.cos(t))
        bs, weight = bsdf.sample(m.BSDFContext(), si, m.Float(u[0]), m.Point2f(u[1], u[2]))
        up = np.array(bs.wo)[2] > 0
        zero = np.all(np.array(weight) == 0, axis=0)
        assert not (up & zero).any(), (theta, int((up & zero).sum()))


def sample_weight_mean(m, path, theta_deg, phi_deg, n=1_000_000, seed=2):
    """The mean of Mitsuba's `sample` weights (llvm_ad_spectral, 550 nm,
    light at theta_deg, phi_deg) and its standard error: an unbiased
    estimate of the file's reflectance by Mitsuba's own sampling, whatever
    the width of its peaks."""
    import drjit as dr
    m.set_variant("llvm_ad_spectral")
    bsdf = m.load_dict({"type": "measured", "filename": str(path)})
    u = np.random.default_rng(seed).random((3, n))
    t, p = max(np.radians(theta_deg), 1e-7), np.radians(phi_deg)
    si = dr.zeros(m.SurfaceInteraction3f, n)
    si.wi = m.ScalarVector3f(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))
    si.wavelengths = dr.full(type(si.wavelengths), 550.0, n)
    _, weight = bsdf.sample(m.BSDFContext(), si, m.Float(u[0]), m.Point2f(u[1], u[2]))
    w = np.array(weight)[0]
    return w.mean(), w.std() / np.sqrt(n)


def test_sample_weights_average_the_tables_reflectance(mi, folders, aniso):
    """The writer scales each block so that the file's reflectance,
    integrated over the sample square as the renderers sample it, is the
    table's. Mitsuba's own estimate (the mean of 10^6 `sample` weights,
    unbiased whatever the width of the file's peaks) is the table's within
    the export's tolerance max(1 %, 4 combined standard errors): measured
    within 0.09 % (the grooves along their length at 60 degrees: the
    writer's midpoint rule on the sample square), where a normalisation on
    0.5-degree cells of the hemisphere left the grooves' node 0 at 60
    degrees 1.2-1.6 % off. Cases: the Gaussian Al field (0, 40, 70
    degrees) and the grooves' whole-circle file at its node 0 (30, 60: the
    retroreflected spike) and 90 (along the grooves)."""
    cases = [(folders["gaussian_al"], t, 0.0) for t in (0.0, 40.0, 70.0)]
    cases += [(aniso["circle"], t, a) for t in (30.0, 60.0) for a in (0.0, 90.0)]
    bad = []
    for folder, theta, phi in cases:
        c = read_columns(folder / "brdf.csv")
        sel = (c["theta_i_deg"] == theta) & (c["phi_i_deg"] == phi)
        p = c["projected_solid_angle_sr"][sel]
        r_table = (c["brdf"][sel] * p).sum()
        se_table = np.sqrt(((c["brdf_stderr"][sel] * p) ** 2).sum())
        r_file, se_file = sample_weight_mean(mi, folder / "rgl.bsdf", theta, phi)
        if abs(r_file - r_table) > max(0.01 * r_table, 4 * np.hypot(se_file, se_table)):
            bad.append((folder.name, theta, phi, r_file, se_file, r_table, se_table))
    assert not bad, bad


def compare(folder, wavelengths):
    """Per wavelength and incidence: (table BRDF, its standard error,
    Mitsuba's eval / cos(theta_o), the resampling bound, projected solid
    angles, fractions) at the cell centres."""
    import mitsuba as m
    m.set_variant("scalar_spectral")
    c = read_columns(folder / "brdf.csv")
    bsdf = m.load_dict({"type": "measured", "filename": str(folder / "rgl.bsdf")})
    bands = int(c["band"].max())
    for lam in (wavelengths or [550.0]):
        for theta in np.unique(c["theta_i_deg"]):
            sel = c["theta_i_deg"] == theta
            if "wavelength_um" in c:
                sel &= np.isclose(c["wavelength_um"], lam / 1e3)
            dirs = centres(c, sel)
            phi = float(c["phi_i_deg"][sel][0])  # the light's azimuth: the file is relative to it
            got = mitsuba_eval(m, bsdf, theta, dirs, lam, phi) / dirs[:, 2]
            yield (lam, theta, c["brdf"][sel], c["brdf_stderr"][sel], got, bound(c, sel, bands, phi_deg=phi),
                   c["projected_solid_angle_sr"][sel], c["fraction"][sel])


def zero_count_stderr(f, se, proj, fraction):
    """The standard error of each cell, a cell without photons given that of
    one photon's weight (the smallest nonzero fraction of the block over
    the cell's projected solid angle): a Poisson count of 0 is not known to
    better than about one count, and brdf.csv states 0 for it."""
    one = fraction[fraction > 0].min()
    return np.where(f > 0, se, one / proj)


@pytest.mark.parametrize("name,scene,opts,wavelengths", CASES, ids=[c[0] for c in CASES])
def test_measured_eval_matches_the_table_per_cell(mi, folders, name, scene, opts, wavelengths):
    for lam, theta, f, se, got, b, proj, fraction in compare(folders[name], wavelengths):
        se = zero_count_stderr(f, se, proj, fraction)
        allowed = 4 * se + b + 1e-5 * f.max()
        bad = np.abs(got - f) > allowed
        assert not bad.any(), (
            f"{name} {lam} nm theta_i {theta}: {bad.sum()} of {bad.size} cells off, worst "
            f"{np.max((np.abs(got - f) - allowed)[bad]):.3g} 1/sr beyond the allowed: table "
            f"{f[bad]}, Mitsuba {got[bad]}, allowed {allowed[bad]}")


@pytest.mark.parametrize("name,scene,opts,wavelengths", CASES, ids=[c[0] for c in CASES])
def test_measured_reflectance_matches_the_table(mi, folders, name, scene, opts, wavelengths):
    """Mitsuba's eval summed over the cells (times their projected solid
    angles) is the table's reflectance within max(1 %, 4 sigma)."""
    for lam, theta, f, se, got, _, proj, _ in compare(folders[name], wavelengths):
        r_table, r_file = (f * proj).sum(), (got * proj).sum()
        allowed = max(0.01 * r_table, 4 * np.sqrt(((se * proj) ** 2).sum()))
        assert abs(r_file - r_table) <= allowed, (name, lam, theta, r_file, r_table, allowed)


def test_pbrt_fields_and_jacobian(folders):
    from mitsuba import tensor_io
    t = tensor_io.read(str(folders["gold"] / "rgl.bsdf"))
    # pbrt-v4 MeasuredBxDFData::Create reads these fields by name.
    for field in ("theta_i", "phi_i", "ndf", "sigma", "vndf", "luminance", "spectra", "wavelengths",
                  "description", "jacobian"):
        assert field in t, field
    assert t["jacobian"].dtype == np.uint8 and list(t["jacobian"]) == [1]
    assert t["wavelengths"].dtype == np.float32
    np.testing.assert_allclose(t["wavelengths"], [450.0, 550.0, 650.0], rtol=1e-6)
    n_phi, n_theta = t["phi_i"].shape[0], t["theta_i"].shape[0]
    assert t["spectra"].shape[:3] == (n_phi, n_theta, 3)
    assert t["vndf"].shape[:2] == (n_phi, n_theta) and t["luminance"].shape[:2] == (n_phi, n_theta)
    assert t["spectra"].shape[3:] == t["luminance"].shape[2:]
    assert np.all(np.isfinite(t["spectra"])) and np.all(t["spectra"] >= 0)


def sphere_means(mi, bsdf: dict, renders: int, size: int, spp: int):
    """Mean RGB over the pixels wholly on a unit sphere under a constant
    emitter of radiance 1 (so each pixel is the albedo of the BSDF at its
    incidence), per render of `renders` with seeds 0.., and the seconds
    they took. Pixels whose centre ray passes within 0.95 of the centre
    count; a box filter keeps each pixel to its own footprint."""
    import time
    fov = 45.0
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {"type": "perspective", "fov": fov, "fov_axis": "x",
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "emitter": {"type": "constant", "radiance": {"type": "uniform", "value": 1.0}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
    })
    # Pixel centres: ray (x, y, -1) from (0, 0, 4); distance of the line
    # from the origin is 4 |(x, y)| / sqrt(1 + x² + y²).
    half = np.tan(np.radians(fov / 2))
    c = ((np.arange(size) + 0.5) / size * 2 - 1) * half
    x, y = np.meshgrid(c, c)
    mask = 4 * np.hypot(x, y) / np.sqrt(1 + x * x + y * y) < 0.95
    means = []
    start = time.perf_counter()
    for seed in range(renders):
        img = np.array(mi.render(scene, seed=seed, spp=spp))[..., :3]
        means.append(img[mask].mean(axis=0))
    return np.array(means), time.perf_counter() - start


def test_sphere_render_measured_agrees_with_roks_table(roks, mi, tmp_path):
    """A unit sphere under a constant emitter, rendered in llvm_ad_spectral
    with Mitsuba's own `measured` plugin on the exported file and with our
    `roks_table` plugin on brdf.csv: the mean pixel value over the sphere,
    per channel, agrees within 4 standard errors of the difference (each
    from 4 renders of independent seeds). The two render times are
    printed (pytest -s) and quoted in docs/src/exports.md."""
    import mitsuba as m
    out = tmp_path / "default"
    run(roks, "brdf", "--out", out, "-q", "--photons", 100_000, "--export", "rgl")
    import drjit as dr
    m.set_variant("llvm_ad_spectral")
    from roks_tools.mitsuba import roks_table
    roks_table.register()
    renders, size, spp = 4, 64, 16
    a, t_measured = sphere_means(m, {"type": "measured", "filename": str(out / "brdf_rgl.bsdf")}, renders, size, spp)
    # roks_table is Python code called from the integrator: wavefront mode
    # (its documentation), restored afterwards.
    flags = dr.flag(dr.JitFlag.SymbolicLoops), dr.flag(dr.JitFlag.SymbolicCalls)
    dr.set_flag(dr.JitFlag.SymbolicLoops, False)
    dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    try:
        b, t_table = sphere_means(m, {"type": "roks_table", "filename": str(out / "brdf.csv")}, renders, size, spp)
    finally:
        dr.set_flag(dr.JitFlag.SymbolicLoops, flags[0])
        dr.set_flag(dr.JitFlag.SymbolicCalls, flags[1])
    diff = a.mean(axis=0) - b.mean(axis=0)
    se = np.sqrt(a.var(axis=0, ddof=1) / renders + b.var(axis=0, ddof=1) / renders)
    print(f"\nsphere {size}x{size}, {spp} spp, {renders} renders: measured {t_measured:.2f} s, "
          f"roks_table {t_table:.2f} s; means {a.mean(axis=0)} vs {b.mean(axis=0)}, se {se}")
    assert np.all(np.abs(diff) <= 4 * se), (a.mean(axis=0), b.mean(axis=0), se)


def test_rgb_file_loads_in_scalar_rgb_and_matches_the_colour_table(roks, mi, tmp_path):
    """`--rgb`: the gold bump field traced over 0.38-0.78 um; Mitsuba's
    `measured` in scalar_rgb loads the file, and its eval summed over the
    cells (times their projected solid angles) is, per channel, the
    reflectance of colour.csv's linear sRGB (clipped at 0 like the file)
    within 1 % (the criterion of roks's own check); per cell:
    test_rgb_file_per_cell."""
    out, got, c, sel, proj = rgb_eval(roks, tmp_path)
    for k, ch in enumerate("rgb"):
        want = np.maximum(c[ch][sel], 0.0)
        r_table, r_file = (want * proj).sum(), (got[:, k] * proj).sum()
        assert abs(r_file - r_table) <= 0.01 * r_table, (ch, r_file, r_table)


def test_rgb_file_per_cell(roks, mi, tmp_path):
    out, got, c, sel, proj = rgb_eval(roks, tmp_path)
    for k, ch in enumerate("rgb"):
        want = np.maximum(c[ch][sel], 0.0)
        spread = bound({"theta_deg": c["theta_deg"], "phi_deg": c["phi_deg"], "brdf": np.maximum(c[ch], 0.0)},
                       sel, int(c["band"].max()))
        bad = np.abs(got[:, k] - want) > spread + 1e-5 * want.max()
        assert not bad.any(), (ch, bad.sum(), want[bad], got[bad, k])


def rgb_eval(roks, tmp_path):
    """The gold RGB export and Mitsuba's scalar_rgb eval / cos at the cell
    centres of 30 degrees."""
    import mitsuba as m
    out = tmp_path / "gold"
    scene = ROOT / "scenes" / "gold-spectral.toml"
    run(roks, "brdf", scene, "--out", out, "-q", "--photons", 20_000, "--theta", "30")
    run(roks, "export-brdf", out, "--format", "rgl", "--rgb", "--out", out / "rgb.bsdf", "-q", "--scene", scene)
    from mitsuba import tensor_io
    t = tensor_io.read(str(out / "rgb.bsdf"))
    assert "rgb" in t and "spectra" not in t and "wavelengths" not in t
    m.set_variant("scalar_rgb")
    bsdf = m.load_dict({"type": "measured", "filename": str(out / "rgb.bsdf")})
    c = read_columns(out / "colour.csv")
    b = read_columns(out / "brdf.csv")
    sel = c["theta_i_deg"] == 30.0
    proj = b["projected_solid_angle_sr"][np.isclose(b["wavelength_um"], b["wavelength_um"][0]) & (b["theta_i_deg"] == 30.0)]
    dirs = centres(c, sel)
    ctx = m.BSDFContext()
    si = m.SurfaceInteraction3f()
    si.wi = m.Vector3f(np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0)))
    got = np.array([np.array(bsdf.eval(ctx, si, m.Vector3f(*d))) for d in dirs]) / dirs[:, 2:3]
    return out, got, c, sel, proj


def test_broken_files_are_caught(mi, folders, tmp_path):
    """The comparisons above catch a writer's defects: the default scene's
    file broken as a writer could break it (the jacobian flag off, the two
    axes of `spectra` or of `vndf` swapped, `sigma` doubled, as a wrong vndf
    normalisation would) puts at least 100 cells outside the per-cell bound
    (the intact file: none of 6336)."""
    import shutil
    from mitsuba import tensor_io
    src = folders["default"]
    orig = {k: np.asarray(v) for k, v in tensor_io.read(str(src / "rgl.bsdf")).items()}
    breaks = {
        "jacobian off": {"jacobian": np.array([0], np.uint8)},
        "spectra axes swapped": {"spectra": np.ascontiguousarray(np.swapaxes(orig["spectra"], 3, 4))},
        "vndf axes swapped": {"vndf": np.ascontiguousarray(np.swapaxes(orig["vndf"], 2, 3))},
        "sigma doubled": {"sigma": orig["sigma"] * 2},
    }
    for what, change in breaks.items():
        d = tmp_path / what.replace(" ", "_")
        d.mkdir()
        shutil.copy(src / "brdf.csv", d / "brdf.csv")
        tensor_io.write(str(d / "rgl.bsdf"), **{**orig, **change})
        off = 0
        for lam, theta, f, se, got, b, proj, fraction in compare(d, None):
            se = zero_count_stderr(f, se, proj, fraction)
            off += int((np.abs(got - f) > 4 * se + b + 1e-5 * f.max()).sum())
        assert off >= 100, (what, off)


def aniso_compare(mi, folder, query_phi=None, turn=False, file="rgl.bsdf", mirror=False):
    """Per incidence and light azimuth a of the run: (a, theta, table BRDF,
    its standard error with zero-count cells given one photon's, Mitsuba's
    eval / cos(theta_o), the resampling bound). Mitsuba is queried with the
    light at azimuth `query_phi(a)` (default a) towards the cell centres,
    turned by a half turn when `turn`."""
    mi.set_variant("scalar_spectral")
    c = read_columns(folder / "brdf.csv")
    bsdf = mi.load_dict({"type": "measured", "filename": str(folder / file)})
    bands = int(c["band"].max())
    for a in np.unique(c["phi_i_deg"]) if "phi_i_deg" in c else [0.0]:
        for theta in np.unique(c["theta_i_deg"]):
            sel = c["theta_i_deg"] == theta
            if "phi_i_deg" in c:
                sel &= c["phi_i_deg"] == a
            dirs = centres(c, sel)
            q = dirs * np.array([-1, -1, 1]) if turn else dirs
            got = mitsuba_eval(mi, bsdf, theta, q, 550.0,
                               a if query_phi is None else query_phi(a)) / dirs[:, 2]
            f, se = c["brdf"][sel], c["brdf_stderr"][sel]
            se = zero_count_stderr(f, se, c["projected_solid_angle_sr"][sel], c["fraction"][sel])
            yield a, theta, f, se, got, bound(c, sel, bands, mirror=mirror)


def off_cells(rows):
    """Cells beyond 4 standard errors + the resampling bound, per (a, theta)."""
    return {(a, theta): int((np.abs(got - f) > 4 * se + b + 1e-5 * f.max()).sum())
            for a, theta, f, se, got, b in rows}


@pytest.mark.parametrize("name", list(ANISO))
def test_anisotropic_eval_matches_the_table_per_cell(mi, aniso, name):
    """Mitsuba's eval of the anisotropic file with the light at each run
    azimuth agrees at every cell centre with that azimuth's table within 4
    standard errors + the resampling bound (cells within two band widths;
    no mirror image: an anisotropic file is not averaged with it). For
    "half" the light at 90 or 135 degrees has wi.y > 0, which the reader
    turns by a half turn onto the node a - 180. The grooves' table is a few
    lone spike cells, whose neighbours are 0, so this bound only pins the
    cells farther than two band widths from any lit cell: a writer that
    skips the half turn, or takes the half vector's azimuth relative to the
    light's, still passes it (checked); the reflectance and lobe test below
    fails for both."""
    off = off_cells(aniso_compare(mi, aniso[name]))
    assert not any(off.values()), off


def test_half_turn_reaches_the_other_half(mi, aniso):
    """The 0-180 file read with the light at a + 180 (225, 270, 315: the
    nodes a - 180, filled by the half turn) towards the cell centres
    turned by a half turn is the table at a: the file holds azimuth a
    turned (within the per-cell bound of the test above, as weak at the
    grooves' spikes; the lobe test below also reads at a + 180)."""
    rows = [r for r in aniso_compare(mi, aniso["half"], query_phi=lambda a: a + 180.0, turn=True)
            if 0 < r[0] < 180]
    off = off_cells(rows)
    assert len(off) == 9 and not any(off.values()), off


def mitsuba_reflectance(mi, path, theta_deg, phi_deg, rings=360, lobe=False):
    """The reflectance of Mitsuba's eval (f cos(theta_o)) in scalar_spectral
    at 550 nm with the light at theta_deg, phi_deg: the midpoint rule on
    `rings` rings of equal polar width times 4 rings azimuth sectors, each
    cell weighted by its solid angle. With `lobe`, also the mean outgoing
    direction of the reflected light (a vector, weighted by f cos dω)."""
    mi.set_variant("scalar_spectral")
    bsdf = mi.load_dict({"type": "measured", "filename": str(path)})
    dt, dp = np.pi / 2 / rings, 2 * np.pi / (4 * rings)
    t = (np.arange(rings) + 0.5) * dt
    p = (np.arange(4 * rings) + 0.5) * dp
    tt, pp = np.meshgrid(t, p, indexing="ij")
    dirs = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1).reshape(-1, 3)
    solid = ((np.cos(t - dt / 2) - np.cos(t + dt / 2)) * dp)[:, None].repeat(4 * rings, axis=1).ravel()
    w = mitsuba_eval(mi, bsdf, theta_deg, dirs, 550.0, phi_deg) * solid
    return (w.sum(), (w[:, None] * dirs).sum(axis=0) / w.sum()) if lobe else w.sum()


@pytest.mark.parametrize("name", [
    "circle",
    "half",
    "quadrant",
])
def test_anisotropic_reflectance_and_lobe_per_azimuth(mi, aniso, name):
    """Per run azimuth a and incidence: the reflectance of Mitsuba's eval
    with the light at a ([mitsuba_reflectance]) is the table's within
    max(1 %, 4 sigma), and the mean outgoing direction of its light is the
    table's (fractions times cell centres) within two band widths (the
    cells' own spread). For the 0-180 file also with the light at a + 180
    for 0 < a < 180 (the node a - 180, filled by the half turn): the same
    reflectance and the table's mean direction turned by a half turn; for
    the 0-90 file at 180 - a, 360 - a and a + 180 (the nodes filled by the
    mirror about yz, about xz and the half turn), the mean direction moved
    alike. Every file spans the whole circle (reduction 1: pbrt-v4 reads
    no other). The per-cell
    comparison above bounds a lone spike cell by its own value (its
    neighbours are 0), so a file that loses or moves a spike can pass it;
    this test cannot be passed so (checked: a writer skipping the half turn,
    or taking the half vector's azimuth relative to the light's, fails it
    for the 0-180 file)."""
    c = read_columns(aniso[name] / "brdf.csv")
    bands = int(c["band"].max())
    path = aniso[name] / "rgl.bsdf"
    bad = []
    for a in ANISO[name]:
        for theta in ANISO_THETA:
            sel = (c["theta_i_deg"] == theta) & (c["phi_i_deg"] == a)
            p, f = c["projected_solid_angle_sr"][sel], c["fraction"][sel]
            r_table = (c["brdf"][sel] * p).sum()
            allowed = max(0.01 * r_table, 4 * np.sqrt(((c["brdf_stderr"][sel] * p) ** 2).sum()))
            mean = (f[:, None] * centres(c, sel)).sum(axis=0) / f.sum()
            queries = [(a, mean)]
            if name == "half" and 0 < a < 180:
                queries.append((a + 180, mean * np.array([-1, -1, 1])))
            if name == "quadrant":
                # the rest of the circle, filled by the mirrors and the half turn
                if a < 90:
                    queries.append((180 - a, mean * np.array([-1, 1, 1])))
                    queries.append((a + 180, mean * np.array([-1, -1, 1])))
                if a > 0:
                    queries.append((360 - a, mean * np.array([1, -1, 1])))
            for q, want in queries:
                r_file, got = mitsuba_reflectance(mi, path, theta, q, lobe=True)
                if abs(r_file - r_table) > allowed:
                    bad.append(("reflectance", a, q, theta, r_file, r_table, allowed))
                if np.linalg.norm(got - want) > 2 * np.radians(90 / bands):
                    bad.append(("lobe", a, q, theta, got.round(3), want.round(3)))
    assert not bad, (name, bad)


def test_anisotropic_file_differs_from_the_isotropic_one(mi, aniso):
    """Along the grooves (light at 90 degrees) every photon meets both walls
    once: reflectance 0.64 at every incidence; across them (0) at 30
    degrees 0.7324 (docs/src/anisotropy.md). The isotropic file of the
    grooves lit across them turns with the light, so read at 90 it gives
    the across table's reflectance; the anisotropic files give the along
    one. The reflectance of Mitsuba's eval ([mitsuba_reflectance], 0.25-degree
    cells, a quadrature independent of the writer's normalisation over the
    sample square) at 30 and 60 degrees: the anisotropic files within
    max(1 %, 4 sigma) of the table at 90 (measured 0.06-0.16 % off), the
    isotropic one beyond 5 times that."""
    c = read_columns(aniso["circle"] / "brdf.csv")
    for theta in (30.0, 60.0):
        sel = (c["theta_i_deg"] == theta) & (c["phi_i_deg"] == 90.0)
        p = c["projected_solid_angle_sr"][sel]
        r_table = (c["brdf"][sel] * p).sum()
        allowed = max(0.01 * r_table, 4 * np.sqrt(((c["brdf_stderr"][sel] * p) ** 2).sum()))
        for name in ("circle", "half"):
            r_file = mitsuba_reflectance(mi, aniso[name] / "rgl.bsdf", theta, 90.0)
            assert abs(r_file - r_table) <= allowed, (name, theta, r_file, r_table, allowed)
        r_iso = mitsuba_reflectance(mi, aniso["iso"] / "rgl.bsdf", theta, 90.0)
        assert abs(r_iso - r_table) > 5 * allowed, (theta, r_iso, r_table, allowed)


def test_anisotropic_export_checks_each_azimuth(roks, aniso, tmp_path):
    """The export's read-back check prints one row per incidence and light
    azimuth (a phi_i column), file within the tolerance (no warning), and a
    note on the half-turn symmetry the 0-180 file assumes."""
    for name, phis in ANISO.items():
        err = run(roks, "export-brdf", aniso[name], "--format", "rgl", "--out", tmp_path / f"{name}.bsdf",
                  "--scene", GROOVES)
        rows = [line.split() for line in err.splitlines()
                if len(line.split()) == 5 and all(_number(w) for w in line.split()[:4])]
        assert sorted((float(r[0]), float(r[1])) for r in rows) == sorted(
            (float(t), float(p)) for t in ANISO_THETA for p in phis), err
        assert "warning" not in err, err
        assert ("assumes a half turn" in err) == (name == "half"), err
        assert ("assumes the surface is mirror symmetric" in err) == (name == "quadrant"), err


def _number(w):
    try:
        float(w)
        return True
    except ValueError:
        return False
