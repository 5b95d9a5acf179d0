"""roks's polarised measured export (`roks export-brdf --format pbsdf`,
src/export/pbsdf.rs) read by Mitsuba 3's own `measured_polarized` plugin in
`scalar_spectral_polarized` (no roks code on the reading side).

Frames. Mitsuba's `eval(ctx, si, wo)` (radiance mode: `wo` towards the
light, `si.wi` towards the viewer) returns the Mueller-matrix BRDF times
the cosine of `wo` (the light's polar angle: its `cos_theta_o`) with the incident Stokes reference vector
`stokes_basis(-wo)` and the outgoing one `stokes_basis(si.wi)`
(measured_polarized.cpp, its last `rotate_mueller_basis`). The tests turn
it into other frames with their own numpy rotator (mueller.h's convention:
`R_out M R_in^T`, `R = rotator(angle)` of the signed angle from the current
reference vector to the target one about the flight):

* the s frames `normalize(n x d)` of each flight, where a flat interface's
  Mueller matrix is the textbook one, computed here from the complex
  Fresnel amplitudes;
* roks's frames `normalize(z x d)` (docs/src/polarisation.md), where
  `mueller.csv` is written.

Checks:

* flat Fresnel surfaces (glass n = 1.5, aluminium n, k): near the specular
  direction (0.3 degrees out of the plane, inside the specular cell) the
  normalised matrix is the exact one within 2e-3 (the f32 values and the
  interpolation between nodes whose matrices differ by the table's
  interpolation between its incidences: measured 1e-4) and m00 is the
  table's specular cell's BRDF within 0.5 %;
* a rough aluminium field (scenes/gaussian-rough.toml): at the centre of
  every cell with light at 30 and 60 degrees, each of the 16 elements,
  turned into roks's frames and divided by cos(theta_i), is mueller.csv's
  within 4 standard errors plus the resampling bound: the file's value at a
  point is an interpolation of node values, each the table's value in a
  cell near it, so the bound is the largest difference between the cell's
  element and that of any cell within two band widths of it or of its
  mirror image (mirror elements with the signs of S2, S3 flipped), at the
  same incidence and at the neighbouring tabulated ones;
* refusals: 6 wavelengths, no mueller.csv (one line, exit status 2); a
  run of 5 wavelengths gives them as the file's `wvls`.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from roks_tools.results import read_columns

pytestmark = pytest.mark.mitsuba
ROOT = Path(__file__).resolve().parents[2]

FLAT_SCENE = """name = "flat_{name}"
[surface]
size = [1.0, 1.0]
material = "m"
[materials.m]
n = {n}
k = {k}
[light]
theta_deg = [20, 30, 40, 50, 60, 70]
phi_deg = 0.0
photons = 2000
seed = 3
[tally]
bands = 32
polarisation = "mueller"
"""
FLAT = {"glass": (1.5, 0.0), "aluminium": (1.015, 6.627)}
ROUGH_THETAS = [0, 10, 20, 30, 40, 50, 60, 70, 80]
ROUGH_CHECKED = [30.0, 60.0]
MIRROR_SIGNS = np.array([1.0, 1.0, -1.0, -1.0])


def run(roks, *args, ok=True):
    p = subprocess.run([roks, *map(str, args)], capture_output=True, text=True)
    if ok:
        assert p.returncode == 0, p.stderr
    return p


@pytest.fixture(scope="module")
def folders(roks, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pbsdf")
    out = {}
    for name, (n, k) in FLAT.items():
        scene = tmp / f"{name}.toml"
        scene.write_text(FLAT_SCENE.format(name=name, n=n, k=k))
        out[name] = tmp / name
        run(roks, "brdf", scene, "--out", out[name], "-q")
    out["rough"] = tmp / "rough"
    run(roks, "brdf", ROOT / "scenes" / "gaussian-rough.toml", "--out", out["rough"], "-q",
        "--theta", ",".join(map(str, ROUGH_THETAS)), "--photons", 200_000, "--polarisation", "mueller")
    for f in out.values():
        run(roks, "export-brdf", f, "--format", "pbsdf", "--out", f / "brdf.pbsdf", "-q")
    return out


def rotator(angle):
    c, s = np.cos(2 * angle), np.sin(2 * angle)
    return np.array([[1, 0, 0, 0], [0, c, s, 0], [0, -s, c, 0], [0, 0, 0, 1.0]])


def rotate_basis(forward, current, target):
    """The Mueller matrix that re-expresses a Stokes vector of reference
    vector `current` in reference vector `target` (both normal to
    `forward`)."""
    current, target = current / np.linalg.norm(current), target / np.linalg.norm(target)
    return rotator(np.arctan2(forward @ np.cross(current, target), current @ target))


def mitsuba_eval(m, bsdf, light, views, wavelength=550.0):
    """Mitsuba's eval (Mueller BRDF times cos(theta_o), its own frames) of
    light from `light` towards each of `views`, first wavelength."""
    ctx = m.BSDFContext()
    si = m.SurfaceInteraction3f()
    si.sh_frame = m.Frame3f(m.Vector3f(0, 0, 1))
    si.wavelengths = [wavelength] * 4
    out = []
    for v in views:
        si.wi = m.Vector3f(*v)
        out.append(np.array(bsdf.eval(ctx, si, m.Vector3f(*light)))[..., 0])
    return np.array(out)


def into_frames(m, matrix, light, view, ref_in, ref_out):
    """`matrix` (Mitsuba's frames) with reference vectors `ref_in` for the
    incident flight -light and `ref_out` for view."""
    basis = lambda d: np.array(m.mueller.stokes_basis(m.Vector3f(*d)))
    r_in = rotate_basis(-light, basis(-light), ref_in)
    r_out = rotate_basis(view, basis(view), ref_out)
    return r_out @ matrix @ r_in.T


def fresnel(cos_i, n, k):
    """The Mueller matrix of a flat interface of index n + ik in the s
    frames: [[a, b, 0, 0], [b, a, 0, 0], [0, 0, c, -d], [0, 0, d, c]],
    a, b = (Rs +- Rp)/2, c + id = rs rp* (rp = -rs at normal incidence)."""
    eta = n + 1j * k
    cos_t = np.sqrt(1 - (1 - cos_i**2) / eta**2)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    a, b = (abs(rs) ** 2 + abs(rp) ** 2) / 2, (abs(rs) ** 2 - abs(rp) ** 2) / 2
    z = rs * np.conj(rp)
    return np.array([[a, b, 0, 0], [b, a, 0, 0], [0, 0, z.real, -z.imag], [0, 0, z.imag, z.real]])


def direction(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


@pytest.mark.parametrize("name", list(FLAT))
def test_flat_fresnel_surface_at_the_specular_direction(mi, folders, name):
    import mitsuba as m
    m.set_variant("scalar_spectral_polarized")
    n, k = FLAT[name]
    bsdf = m.load_dict({"type": "measured_polarized", "filename": str(folders[name] / "brdf.pbsdf")})
    c = read_columns(folders[name] / "mueller.csv")
    normal = np.array([0, 0, 1.0])
    for theta in (30.0, 60.0):
        light = direction(theta, 0.0)
        # The mirror direction turned 0.3 degrees out of the plane of
        # incidence (exactly there the plugin's phi_d is undefined).
        view = direction(theta, 179.7)
        got = mitsuba_eval(m, bsdf, light, [view])[0]
        s = into_frames(m, got, light, view, np.cross(normal, -light), np.cross(normal, view))
        want = fresnel(np.cos(np.radians(theta)), n, k)
        # The numpy formula is Mitsuba's own (mueller.h specular_reflection).
        import drjit as dr
        own = np.array(m.mueller.specular_reflection(float(np.cos(np.radians(theta))),
                                                     dr.scalar.Complex2f(n, k)))
        np.testing.assert_allclose(want, own, atol=1e-6)
        np.testing.assert_allclose(s / s[0, 0], want / want[0, 0], atol=2e-3, err_msg=f"{name} {theta}")
        # m00 is the specular cell's BRDF (the cell holding the mirror direction).
        sel = (c["theta_i_deg"] == theta) & (c["m00"] > 0)
        assert sel.sum() == 1, "a flat surface lights one cell"
        brdf = c["m00"][sel][0]
        assert abs(s[0, 0] / light[2] / brdf - 1) < 5e-3, (name, theta, s[0, 0] / light[2], brdf)


def rough_check(m, folder):
    """Per checked incidence: (mitsuba's elements in roks's frames / cos,
    the table's, their standard errors, the resampling bound), arrays of
    cells x 16."""
    c = read_columns(folder / "mueller.csv")
    bsdf = m.load_dict({"type": "measured_polarized", "filename": str(folder / "brdf.pbsdf")})
    names = [f"m{i}{j}" for i in range(4) for j in range(4)]
    bands = int(c["band"].max())
    radius = np.cos(2 * np.radians(90 / bands))
    thetas = np.unique(c["theta_i_deg"])
    table = {t: np.stack([c[x][c["theta_i_deg"] == t] for x in names], axis=1) for t in thetas}
    for theta in ROUGH_CHECKED:
        sel = c["theta_i_deg"] == theta
        dirs = direction(c["theta_deg"][sel], c["phi_deg"][sel])
        light = direction(theta, 0.0)
        got = mitsuba_eval(m, bsdf, light, dirs)
        z = np.array([0, 0, 1.0])
        ref_in = np.cross(z, -light)
        roks = np.array([into_frames(m, g, light, d, ref_in, np.cross(z, d)).ravel() / light[2]
                         for g, d in zip(got, dirs)])
        f = table[theta]
        se = np.stack([c[x + "_stderr"][sel] for x in names], axis=1)
        mirror = dirs * np.array([1, -1, 1])
        near = (dirs @ dirs.T > radius) | (mirror @ dirs.T > radius)
        mirrored = f * np.outer(MIRROR_SIGNS, MIRROR_SIGNS).ravel()
        # Same incidence and the neighbouring tabulated ones.
        k = int(np.searchsorted(thetas, theta))
        around = [table[t] for t in thetas[max(k - 1, 0):k + 2]]
        b = np.zeros_like(f)
        for cell, row in enumerate(near):
            for g in around:
                gm = g * np.outer(MIRROR_SIGNS, MIRROR_SIGNS).ravel()
                b[cell] = np.maximum(b[cell], np.abs(g[row] - f[cell]).max(axis=0))
                b[cell] = np.maximum(b[cell], np.abs(gm[row] - mirrored[cell]).max(axis=0))
        yield theta, roks, f, se, b


def test_rough_metal_matches_mueller_csv_per_cell(mi, folders):
    import mitsuba as m
    m.set_variant("scalar_spectral_polarized")
    for theta, got, f, se, b in rough_check(m, folders["rough"]):
        allowed = 4 * se + b + 1e-5 * f[:, 0].max()
        bad = np.abs(got - f) > allowed
        assert not bad.any(), (
            f"theta_i {theta}: {bad.sum()} of {bad.size} elements off, e.g. cell "
            f"{np.argwhere(bad)[0]}: {got[bad][0]:.4g} vs {f[bad][0]:.4g} (allowed {allowed[bad][0]:.3g})")


def test_refusals(roks, folders, tmp_path):
    # No mueller.csv: a run without the Mueller tally.
    plain = tmp_path / "plain"
    run(roks, "brdf", "--photons", 2000, "--theta", "30", "--out", plain, "-q")
    p = run(roks, "export-brdf", plain, "--format", "pbsdf", "--out", tmp_path / "a.pbsdf", ok=False)
    assert p.returncode == 2 and "mueller.csv" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not (tmp_path / "a.pbsdf").exists()
    # Six wavelengths are refused; five are the file's.
    for lams in ("0.45,0.5,0.55,0.6,0.65,0.7", "0.45,0.5,0.55,0.6,0.65"):
        folder = tmp_path / f"gold{lams.count(',') + 1}"
        run(roks, "brdf", ROOT / "scenes" / "gold-spectral.toml", "--photons", 2000, "--theta", "30",
            "--wavelengths", lams, "--polarisation", "mueller", "--out", folder, "-q")
        out = folder / "brdf.pbsdf"
        p = run(roks, "export-brdf", folder, "--format", "pbsdf", "--out", out, "-q", ok=False)
        if lams.count(",") == 5:
            lines = p.stderr.strip().splitlines()
            assert p.returncode == 2 and len(lines) == 1, p.stderr
            assert "brdf.csv" in lines[0] and "wavelength_um" in lines[0] and "6 wavelengths" in lines[0], lines
            assert not out.exists()
        else:
            assert p.returncode == 0, p.stderr
            from mitsuba import tensor_io
            t = tensor_io.read(str(out))
            assert t["wvls"].dtype == np.uint16 and list(t["wvls"]) == [450, 500, 550, 600, 650]
            assert t["M"].shape == (73, 46, 46, 5, 4, 4) and t["theta_h"].shape == (1, 46)
            # The wavelengths hold their own tables: gold is redder at 650 nm.
            assert t["M"][..., 4, 0, 0].sum() > 1.2 * t["M"][..., 0, 0, 0].sum()
