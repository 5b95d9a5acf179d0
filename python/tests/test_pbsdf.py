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
  every cell with light at 0, 30 and 60 degrees, each of the 16 elements,
  turned into roks's frames and divided by cos(theta_i), is mueller.csv's
  within the resampling bound (`resampling_bound`, plus 1e-5 of the
  largest m00 for the file's f32 values): the plugin's value at a point is
  a weighted mean (weights >= 0) of the node values around it, and each
  node value a mean of table cells (the cell holding the turned view and
  its mirror image, at the tabulated incidences the node mixes), turned
  into the plugin's frame at the node; the bound is the largest difference
  between the table's cell and any of those cell values, turned through
  the node's frame and the point's, recomputed here from the grid and
  mueller.csv (no roks code; at normal incidence the writer's ring means,
  `pole_rings`). It is tight (the worst element uses 99.97 % of it) and
  catches a file without the frame rotation (11119 of 33792 elements off
  at 30 degrees), a single element's sign flipped in the writer (m02: 327,
  m12: 24, m23: 2065, m32: 1958; the former bound, any cell within two
  band widths at the neighbouring incidences too, let m02 and m12 pass),
  ring means turned the wrong way (9157 at 0 degrees) and a light that
  misses the pole by rounding (250 at 0 degrees: its Stokes reference
  was that of a random azimuth);
* refusals: 6 wavelengths, no mueller.csv (one line, exit status 2); a
  run of 5 wavelengths gives them as the file's `wvls`.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from roks_tools.carlson import CarlsonGrid
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
ROUGH_CHECKED = [0.0, 30.0, 60.0]
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


# The file's nodes (src/export/pbsdf.rs, "Grid"), in float64.
NODES_THETA_H = (np.arange(46) / 45) ** 2 * np.pi / 2
NODES_THETA_D = np.arange(46) / 45 * np.pi / 2
NODES_PHI_D = -np.pi + np.arange(73) / 72 * 2 * np.pi
HORIZON_Z = 1e-6
Z = np.array([0, 0, 1.0])


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def roks_reference(d):
    """roks's Stokes reference vector of flights d (N, 3): normalize(z x d),
    at the pole (-sin 0, cos 0, 0) (hemisphere_reference of the light's
    azimuth 0)."""
    r = np.cross(Z, d)
    n = np.linalg.norm(r, axis=1, keepdims=True)
    return np.where(n > 1e-140, r / np.where(n > 1e-140, n, 1), [0, 1.0, 0])


def rotators(forward, current, target):
    """`rotate_basis` for arrays of flights (N, 3): (N, 4, 4)."""
    current, target = unit(current), unit(target)
    a = np.arctan2(np.einsum("ni,ni->n", forward, np.cross(current, target)),
                   np.einsum("ni,ni->n", current, target))
    c, s = np.cos(2 * a), np.sin(2 * a)
    r = np.zeros((len(a), 4, 4))
    r[:, 0, 0] = r[:, 3, 3] = 1
    r[:, 1, 1] = r[:, 2, 2] = c
    r[:, 1, 2], r[:, 2, 1] = s, -s
    return r


def rusinkiewicz(light, view):
    """The plugin's directions_to_rusinkiewicz: (phi_d, theta_h, theta_d)."""
    h = unit(light + view)
    b = np.cross(Z, h)
    nb = np.linalg.norm(b, axis=1, keepdims=True)
    b = np.where(nb > 0, b / np.where(nb > 0, nb, 1), [0, 1.0, 0])
    t = unit(np.cross(b, h))
    theta_d = np.arccos(np.clip(np.einsum("ni,ni->n", h, light), -1, 1))
    theta_h = np.arccos(np.clip(h[:, 2], -1, 1))
    p = light - np.einsum("ni,ni->n", light, h)[:, None] * h
    npn = np.linalg.norm(p, axis=1, keepdims=True)
    p = np.where(npn > 0, p / np.where(npn > 0, npn, 1), t)
    phi_d = np.arctan2(np.clip(np.einsum("ni,ni->n", b, p), -1, 1),
                       np.clip(np.einsum("ni,ni->n", t, p), -1, 1))
    return phi_d, theta_h, theta_d


def bracketing(nodes, x):
    """The plugin's linear interpolation: [(node index, weight)] x 2, arrays."""
    k = np.clip(np.searchsorted(nodes, x, side="right"), 1, len(nodes) - 1) - 1
    w = np.clip((x - nodes[k]) / (nodes[k + 1] - nodes[k]), 0, 1)
    return [(k, 1 - w), (k + 1, w)]


def above_horizon(d):
    flat = d * np.array([1, 1, 0.0])
    n = np.linalg.norm(flat, axis=1, keepdims=True)
    flat = np.where(n > 0, flat / np.where(n > 0, n, 1), [1.0, 0, 0])
    return np.where(d[:, 2:] > HORIZON_Z, d, unit(flat + Z * HORIZON_Z))


def turn_y(d, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * d[:, 0] - s * d[:, 2], d[:, 1], s * d[:, 0] + c * d[:, 2]], axis=1)


def node_sources(phi_d, theta_h, theta_d, thetas_deg):
    """Where the writer takes a node's value from (src/export/pbsdf.rs,
    "Resampling", written again here): per tabulated incidence k with a
    weight > 0, the turned pair (l, v) in the table's frame, the reference
    vector of the plugin's frame at the node, and k."""
    h = np.stack([np.sin(theta_h), 0 * theta_h, np.cos(theta_h)], axis=1)
    t = np.cross([0, 1.0, 0], h)
    d = np.cos(phi_d)[:, None] * t + np.sin(phi_d)[:, None] * np.array([0, 1.0, 0])
    ct, st = np.cos(theta_d)[:, None], np.sin(theta_d)[:, None]
    light, view = above_horizon(ct * h + st * d), above_horizon(ct * h - st * d)
    a = np.arctan2(light[:, 1], light[:, 0])
    c, s = np.cos(-a)[:, None], np.sin(-a)[:, None]
    turn = lambda v: np.stack([c[:, 0] * v[:, 0] - s[:, 0] * v[:, 1],
                               s[:, 0] * v[:, 0] + c[:, 0] * v[:, 1], v[:, 2]], axis=1)
    light, view, d = turn(light), turn(view), turn(d)
    theta_i = np.degrees(np.arctan2(np.hypot(light[:, 0], light[:, 1]), light[:, 2]))
    thetas = np.asarray(thetas_deg, dtype=float)
    upper = np.searchsorted(thetas, theta_i, side="right")
    inside = (upper > 0) & (upper < len(thetas))
    lo, hi = np.clip(upper - 1, 0, len(thetas) - 1), np.clip(upper, 0, len(thetas) - 1)
    w = np.where(inside, (theta_i - thetas[lo]) / (thetas[hi] - thetas[lo] + (~inside)), 0.0)
    out = []
    for k, wk in ((lo, 1 - w), (hi, w)):
        use = wk > 0
        shift = np.radians(theta_i - thetas[k])
        # At the tabulated incidence exactly (at 0 the pole, reference y).
        l = direction(thetas[k], 0.0)
        v = above_horizon(turn_y(view, -shift))
        diff = l - v
        nd = np.linalg.norm(diff, axis=1, keepdims=True)
        diff = np.where(nd > 0, diff / np.where(nd > 0, nd, 1), d)
        ref = unit(np.cross(diff, unit(l + v)))
        out.append((use, k, l, v, ref))
    return out


def pole_rings(grid, cells):
    """The writer's ring means of a normal incidence (`cells`: its (cells,
    16) array): per band, each cell's matrix with its incident reference
    vector turned with the cell to azimuth 0 (from (sin a, cos a, 0) to y
    about -z, a the cell's azimuth), averaged over the band's cells."""
    out = []
    for band in range(1, grid.bands + 1):
        flat = grid.start(band) + np.arange(4 * band)
        a = grid.phi_centre[flat]
        r = rotators(np.tile(-Z, (len(a), 1)), np.stack([np.sin(a), np.cos(a), 0 * a], axis=1),
                     np.tile([0, 1.0, 0], (len(a), 1)))
        out.append((cells[flat].reshape(-1, 4, 4) @ np.transpose(r, (0, 2, 1))).mean(axis=0))
    return np.array(out)


def writer_cells(grid, table, rings, thetas, k, v):
    """The matrix the writer takes for the turned view v (N, 3) at tabulated
    incidence thetas[k]: the cell holding v, or at normal incidence the
    ring mean of v's band turned to v's azimuth (its incident reference
    vector from (-sin phi, cos phi, 0) back to y)."""
    flat = grid.locate(v)
    out = np.array([table[thetas[kk]][cell] for kk, cell in zip(k, flat)])
    pole = thetas[k] == 0
    if pole.any():
        p = np.arctan2(v[pole, 1], v[pole, 0])
        r = rotators(np.tile(-Z, (len(p), 1)), np.stack([-np.sin(p), np.cos(p), 0 * p], axis=1),
                     np.tile([0, 1.0, 0], (len(p), 1)))
        m = rings[grid.band[flat[pole]] - 1] @ np.transpose(r, (0, 2, 1))
        out[pole] = m.reshape(-1, 16)
    return out


def resampling_bound(grid, table, thetas, light, views, f):
    """Per cell centre `views` (N, 3) lit from `light`, the largest
    difference of each element (roks's frames) between the table's value
    `f` (N, 16) and any value that the plugin's interpolation at that point
    mixes: each of the (up to 8) nodes around it, from each tabulated
    incidence that node mixes, the matrix the writer takes (the cell of the
    turned view averaged with its mirror image) turned into the plugin's
    frame at the node, then out of the plugin's frame at the point into
    roks's frames there. The file's value there is a weighted mean of these
    (weights >= 0, summing to 1), so it is within this bound of `f` (up to
    the f32 values). `table[k]` is incidence k's (cells, 16) array."""
    n = len(views)
    lights = np.repeat(light[None], n, axis=0)
    pd, th, td = rusinkiewicz(lights, views)
    # Out of the plugin's frame at the point into roks's frames.
    ref_x = unit(np.cross(unit(lights - views), unit(lights + views)))
    back_in = rotators(-lights, ref_x, roks_reference(-lights))
    back_out = rotators(views, ref_x, roks_reference(views))
    signs = np.outer(MIRROR_SIGNS, MIRROR_SIGNS)
    rings = pole_rings(grid, table[0.0]) if 0.0 in table else None
    bound = np.zeros((n, 16))
    for ip, wp in bracketing(NODES_PHI_D, pd):
        for iq, wq in bracketing(NODES_THETA_D, td):
            for ir, wr in bracketing(NODES_THETA_H, th):
                node = (wp > 0) & (wq > 0) & (wr > 0)
                for use, k, l, v, ref in node_sources(NODES_PHI_D[ip], NODES_THETA_H[ir],
                                                      NODES_THETA_D[iq], thetas):
                    use = use & node
                    mirror = v * np.array([1, -1, 1.0])
                    a = writer_cells(grid, table, rings, thetas, k, v)
                    b = writer_cells(grid, table, rings, thetas, k, mirror)
                    m = 0.5 * (a + b * signs.ravel()).reshape(n, 4, 4)
                    to_in = rotators(-l, roks_reference(-l), ref)
                    to_out = rotators(v, roks_reference(v), ref)
                    m = to_out @ m @ np.transpose(to_in, (0, 2, 1))
                    m = back_out @ m @ np.transpose(back_in, (0, 2, 1))
                    dev = np.abs(m.reshape(n, 16) - f)
                    bound = np.where(use[:, None], np.maximum(bound, dev), bound)
    return bound


def rough_check(m, folder):
    """Per checked incidence: (mitsuba's elements in roks's frames / cos,
    the table's, the resampling bound), arrays of cells x 16."""
    c = read_columns(folder / "mueller.csv")
    bsdf = m.load_dict({"type": "measured_polarized", "filename": str(folder / "brdf.pbsdf")})
    names = [f"m{i}{j}" for i in range(4) for j in range(4)]
    grid = CarlsonGrid(int(c["band"].max()))
    thetas = np.unique(c["theta_i_deg"])
    table = {}
    for t in thetas:
        sel = c["theta_i_deg"] == t
        flat = np.array([grid.start(int(b)) + int(k) for b, k in zip(c["band"][sel], c["cell"][sel])])
        assert np.array_equal(flat, np.arange(grid.n_cells)), "mueller.csv rows in flat cell order"
        table[t] = np.stack([c[x][sel] for x in names], axis=1)
    for theta in ROUGH_CHECKED:
        sel = c["theta_i_deg"] == theta
        dirs = direction(c["theta_deg"][sel], c["phi_deg"][sel])
        light = direction(theta, 0.0)
        got = mitsuba_eval(m, bsdf, light, dirs)
        ref_in = roks_reference(-light[None])[0]
        roks = np.array([into_frames(m, g, light, d, ref_in, np.cross(Z, d)).ravel() / light[2]
                         for g, d in zip(got, dirs)])
        f = table[theta]
        yield theta, roks, f, resampling_bound(grid, table, thetas, light, dirs, f)


def test_rough_metal_matches_mueller_csv_per_cell(mi, folders):
    """Each element of Mitsuba's eval at a cell centre is the table's within
    the resampling bound (`resampling_bound`: the file's value is a mean of
    values within it) plus the f32 rounding of the file (1e-5 of the
    largest m00). No Monte Carlo term: the bound holds for the table as
    traced, whatever its noise."""
    import mitsuba as m
    m.set_variant("scalar_spectral_polarized")
    for theta, got, f, b in rough_check(m, folders["rough"]):
        allowed = b + 1e-5 * f[:, 0].max()
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
