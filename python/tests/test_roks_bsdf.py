"""Tests of the Mitsuba plugin `roks_table` (`roks_tools.mitsuba.roks_table`), through
Mitsuba's own BSDF interface (1-4 in the scalar_rgb variant, 5 in polarised
variants):

1. eval integrates to the table's reflectance: exactly, as the sum over the
   Carlson cells of eval / cos(theta_o) at the cell centre times the cell's
   projected solid angle (the table is constant on cells, and with every
   block at light azimuth 0 the two bracketing tables share the cells), at
   tabulated and interpolated incidence angles and a turned wi; and by Monte
   Carlo with uniform directions, within 4 standard errors.
2. sample: weight x pdf = eval and pdf = BSDF.pdf for every sample; the mean
   weight is the reflectance within 4 standard errors (exactly R at a
   tabulated angle); the cells drawn follow the expected mixture
   probabilities (chi-square, p = 1e-4).
3. A table traced at light azimuth 90 degrees (cells turned accordingly)
   evaluates as the same table at azimuth 0.
4. A broken file is refused with a message naming it.
5. Polarised variants (Mueller matrices from mueller.csv;
   scalar_spectral_polarized, and llvm_ad_mono_polarized when libLLVM >= 19
   is found):
   0. the plugin's stokes_basis / rotate_stokes_basis = Mitsuba's;
   1. tables of Mitsuba's own polarised roughconductor (n = 1.6 + 0.2i and
      aluminium) at the cell centres, turned into roks's frames by Mitsuba's
      rotate_mueller_basis: the plugin at cell centres in turned
      configurations = roughconductor.eval, radiance and importance
      transport (the radiance case through Mueller reciprocity);
   2. polariser / analyser readings built from geometry alone (linear states
      along roks's x, y, diagonal and circular, expressed in Mitsuba's
      basis by their angle to stokes_basis) = the table's formulas;
   3. m00 = the unpolarised eval; sample weight x pdf = eval;
   4. no mueller.csv: a depolariser; mueller_filename; a wrong m00 refused;
   5. scalar_rgb unchanged by a mueller.csv beside the table;
   6. llvm_ad_mono_polarized: a batch = the numpy reference, sample, a
      `stokes` render through the plugin;
   and end to end: ``roks brdf --polarisation
   mueller`` on a flat Al substrate -> the plugin at the specular direction
   (integrated over the cell) = Mitsuba's polarised ``conductor``, both
   modes, three light azimuths, within 4 standard errors plus float32.

The reference reflectance is computed here from the CSV text (sum of the
fractions of each block, linear in theta_i), independently of the plugin.
Every check is run and the failures are reported together.
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

from roks_tools.carlson import CarlsonGrid
from roks_tools.mitsuba import roks_table as roks_bsdf
from roks_tools.mitsuba.setup import _find_libllvm
from roks_tools.results import PolarTable, read_columns
from roks_tools.stats import chi2_critical

pytestmark = pytest.mark.mitsuba

M = 6  # bands: 84 cells
THETAS = [0.0, 40.0, 80.0]


def grid(m: int):
    """(band, cell, mu_bot, mu_top, phi_lo, phi_hi, proj) per flat cell."""
    g = CarlsonGrid(m)
    return list(zip(g.band.tolist(), g.cell.tolist(), g.mu_bot.tolist(), g.mu_top.tolist(),
                    g.phi_lo.tolist(), g.phi_hi.tolist(), g.projected_solid_angle.tolist()))


def write_table(path: Path, blocks: list[tuple[float, float, np.ndarray]], m: int = M) -> None:
    g = grid(m)
    lines = [roks_bsdf.BRDF_HEADER]
    k = m * (m + 1)
    for theta, phi_i, f in blocks:
        for (j, c, bot, top, lo, hi, proj), fr in zip(g, map(float, f)):
            lines.append(
                f"{theta!r},{phi_i!r},{j},{c},{math.degrees(math.acos(top))!r},{math.degrees(math.acos(bot))!r},"
                f"{math.degrees(lo)!r},{math.degrees(hi)!r},{math.degrees(math.acos((top + bot) / 2))!r},"
                f"{math.degrees(c * 2 * math.pi / (4 * j))!r},{math.pi / k!r},{proj!r},{fr!r},0,{fr / proj!r},0"
            )
    path.write_text("\n".join(lines) + "\n")


def reference_reflectance(path: Path, theta_deg: float) -> float:
    data = read_columns(path)
    thetas = sorted(set(data["theta_i_deg"]))
    sums = [data["fraction"][data["theta_i_deg"] == t].sum() for t in thetas]
    return float(np.interp(theta_deg, thetas, sums))


def direction(theta: float, phi: float):
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))



# -- polarised variants ---------------------------------------------------

ROTATIONS = [0.0, 1.1, -2.3]  # whole configuration turned about the normal (rad)
Q = np.diag([1.0, 1.0, -1.0, 1.0])


def write_mueller(path: Path, blocks: list[tuple[float, float, np.ndarray]], m: int = M) -> None:
    """mueller.csv rows (stderr 0) of per-cell matrices (cells, 4, 4)."""
    g = grid(m)
    lines = [",".join(roks_bsdf.MUELLER_MATRIX_COLUMNS)]  # the matrix columns (as older files and the Mitsuba tracer write)
    for theta, phi_i, mats in blocks:
        for (j, c, bot, top, lo, hi, proj), mat in zip(g, mats):
            vals = ",".join(f"{float(v)!r},0" for v in mat.reshape(16))
            lines.append(f"{theta!r},{phi_i!r},{j},{c},{math.degrees(math.acos((top + bot) / 2))!r},"
                         f"{math.degrees(c * 2 * math.pi / (4 * j))!r},{vals}")
    path.write_text("\n".join(lines) + "\n")


def write_pair(folder: Path, blocks: list[tuple[float, float, np.ndarray]]) -> Path:
    """brdf.csv (fraction = m00 x proj) and mueller.csv beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    g = grid(M)
    proj = np.array([e[6] for e in g])
    write_table(folder / "brdf.csv", [(t, p, mats[:, 0, 0] * proj) for t, p, mats in blocks])
    write_mueller(folder / "mueller.csv", blocks)
    return folder / "brdf.csv"


def cell_centre(entry, phi_shift: float = 0.0) -> np.ndarray:
    j, c, bot, top, lo, hi, proj = entry
    return np.array(direction(math.acos(0.5 * (bot + top)), 0.5 * (lo + hi) + phi_shift))


def rot_z(v: np.ndarray, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def roks_x(d: np.ndarray, pole_phi: float) -> np.ndarray:
    """roks's Stokes reference vector of a flight d (polarisation.rs:
    normalize(z x d), at the poles (-sin phi, cos phi, 0))."""
    r = math.hypot(d[0], d[1])
    if r > 1e-12:
        return np.array([-d[1] / r, d[0] / r, 0.0])
    return np.array([-math.sin(pole_phi), math.cos(pole_phi), 0.0])


def polarised_checks(check, rng, roks: str | None) -> None:
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_spectral_polarized")
    roks_bsdf.register()
    g = grid(M)
    n_cells = len(g)
    proj = np.array([e[6] for e in g])
    tmp = Path(tempfile.mkdtemp(prefix="roks-bsdf-pol-"))
    ctxs = {"radiance": mi.BSDFContext(mi.TransportMode.Radiance),
            "importance": mi.BSDFContext(mi.TransportMode.Importance)}

    def v3(d) -> "mi.Vector3f":
        return mi.Vector3f(*map(float, d))

    def npv(v) -> np.ndarray:
        return np.array([float(v.x), float(v.y), float(v.z)])

    def mat(spec) -> np.ndarray:
        """mi.Spectrum (Mueller) -> (4, 4); every wavelength must agree."""
        a = np.array(spec)
        check(np.array_equal(a, np.broadcast_to(a[..., :1], a.shape)), "wavelengths of a grey matrix differ")
        return a[..., 0]

    def ev(bsdf, mode: str, wi, wo) -> np.ndarray:
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = v3(wi)
        return mat(bsdf.eval(ctxs[mode], si, v3(wo)))

    def basis(d) -> np.ndarray:
        return npv(mi.mueller.stokes_basis(v3(d)))

    # 0. The plugin's float64 copies of Mitsuba's basis functions.
    worst_b = worst_r = 0.0
    for _ in range(300):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        worst_b = max(worst_b, float(np.abs(roks_bsdf.stokes_basis(d[None])[0] - basis(d)).max()))
        cur, tgt = np.cross(d, rng.normal(size=3)), np.cross(d, rng.normal(size=3))
        r_mi = np.array(mi.mueller.rotate_stokes_basis(v3(d), v3(cur), v3(tgt)))
        r_np = roks_bsdf.rotate_stokes_basis(d[None], cur[None], tgt[None])[0]
        worst_r = max(worst_r, float(np.abs(r_mi - r_np).max()))
    check(worst_b < 1e-6 and worst_r < 1e-5, f"stokes_basis / rotate_stokes_basis differ from Mitsuba's: {worst_b:.1e}, {worst_r:.1e}")
    print(f"polarised 0: stokes_basis and rotate_stokes_basis = Mitsuba's to {worst_b:.1e}, {worst_r:.1e}")

    # 1. Tables of Mitsuba's own polarised roughconductor (values at the
    # cell centres, turned into roks's frames by Mitsuba's
    # rotate_mueller_basis) read back by the plugin at cell centres, in
    # turned configurations, in both transport modes, = roughconductor.eval.
    blocks_def = [(0.0, 30.0), (40.0, 0.0), (80.0, -45.0)]
    for eta, k in ((1.6, 0.2), (1.015, 6.627)):
        rc = mi.load_dict({"type": "roughconductor", "distribution": "beckmann", "alpha": 0.3, "eta": eta, "k": k})
        blocks = []
        for theta_deg, phi_deg in blocks_def:
            wl = np.array(direction(math.radians(theta_deg), math.radians(phi_deg)))
            mats = np.zeros((n_cells, 4, 4))
            for c, entry in enumerate(g):
                d = cell_centre(entry)
                m_mi = rc.eval(ctxs["importance"], _si(mi, dr, wl), v3(d))
                m_roks = mi.mueller.rotate_mueller_basis(
                    m_mi, v3(-wl), v3(basis(-wl)), v3(roks_x(-wl, math.radians(phi_deg))),
                    v3(d), v3(basis(d)), v3(roks_x(d, math.radians(phi_deg))))
                mats[c] = mat(m_roks) / d[2]
            blocks.append((theta_deg, phi_deg, mats))
        path = write_pair(tmp / f"rc_{eta}_{k}", blocks)
        peak = max(float(np.abs(mats * np.array([cell_centre(e)[2] for e in g])[:, None, None]).max())
                   for _, _, mats in blocks)
        plugin = mi.load_dict({"type": "roks_table", "filename": str(path)})
        worst = {"radiance": 0.0, "importance": 0.0}
        for theta_deg, phi_deg in blocks_def:
            phi_t = math.radians(phi_deg)
            wl = np.array(direction(math.radians(theta_deg), phi_t))
            for gamma in (ROTATIONS if theta_deg > 0 else [-phi_t]):
                wi = np.array([0.0, 0.0, 1.0]) if theta_deg == 0 else rot_z(wl, gamma)
                for c, entry in enumerate(g):
                    wo = rot_z(cell_centre(entry), gamma)
                    for mode in worst:
                        a, b = ev(plugin, mode, wi, wo), ev(rc, mode, wi, wo)
                        # Relative to the matrix, floored at 5 % of the table's
                        # largest entry: a float32 wi is not exactly at the
                        # tabulated theta_i, and the ~1e-7 weight of the next
                        # table matters where the lobe is 1e-7 of its peak.
                        worst[mode] = max(worst[mode], float(np.abs(a - b).max() / max(np.abs(b).max(), 0.05 * peak)))
        for mode, w in worst.items():
            check(w < 2e-5, f"roughconductor n = {eta} + {k}i, {mode}: plugin differs by {w:.2e} (relative to max |m|, floored)")
        print(f"polarised 1: n = {eta} + {k}i: plugin = Mitsuba's roughconductor at cell centres, "
              f"max rel. diff radiance {worst['radiance']:.1e}, importance {worst['importance']:.1e}")

    # 2. Polariser / analyser configurations from geometry alone: a random
    # table (blocks at azimuth 0); light linearly polarised along roks's
    # incident x (s), y (p), (x + y)/sqrt 2, or right circular, written in
    # Mitsuba's basis of the arriving flight by its angle to
    # stokes_basis(flight); the eval applied; analysers along the outgoing
    # x, y, diagonal, circular likewise: each of the 16 readings must be
    # e.g. (m00 + m01 + m10 + m11) cos / 2 for s in, x analyser, from the
    # table (interpolated in theta_i by the test; in radiance transport
    # the light comes from wo and the matrix is Q M^T Q).
    mats = [rng.normal(size=(n_cells, 4, 4)) for _ in THETAS]
    for m_ in mats:
        m_[:, 0, 0] = np.abs(m_[:, 0, 0]) + 0.5
        m_[rng.choice(n_cells, 3, replace=False)] = 0.0
    blocks = [(t, 0.0, m_) for t, m_ in zip(THETAS, mats)]
    path = write_pair(tmp / "random", blocks)
    plugin = mi.load_dict({"type": "roks_table", "filename": str(path)})

    def state(f, x, kind: int):
        """(roks Stokes, Mitsuba Stokes) of state kind 0..3 on flight f with roks reference x."""
        y = np.cross(f, x)
        roks_s = np.array([[1, 1, 0, 0], [1, -1, 0, 0], [1, 0, 1, 0], [1, 0, 0, 1]][kind], dtype=float)
        if kind == 3:
            return roks_s, roks_s.copy()
        e = [x, y, (x + y) / math.sqrt(2)][kind]
        b = basis(f)
        a = math.atan2(e @ np.cross(f, b), e @ b)
        return roks_s, np.array([1.0, math.cos(2 * a), math.sin(2 * a), 0.0])

    worst = {"radiance": 0.0, "importance": 0.0}
    for _ in range(60):
        theta = math.radians(89.0 * rng.random())
        phi = 2 * math.pi * rng.random()
        wi = np.array(direction(theta, phi))
        c = int(rng.integers(n_cells))
        wo = cell_centre(g[c], phi)
        t = np.degrees(theta)
        i1 = int(np.searchsorted(THETAS, t, side="right"))
        i1 = min(i1, len(THETAS) - 1)
        i0 = i1 - 1
        w = min(max((t - THETAS[i0]) / (THETAS[i1] - THETAS[i0]), 0.0), 1.0)
        m_tab = ((1 - w) * mats[i0][c] + w * mats[i1][c]) * wo[2]
        for mode in worst:
            m_pl = ev(plugin, mode, wi, wo)
            if mode == "importance":
                f_in, x_in, f_out, x_out, m_exp = -wi, roks_x(-wi, phi), wo, roks_x(wo, phi), m_tab
            else:
                f_in, x_in, f_out, x_out, m_exp = -wo, roks_x(wo, phi), wi, roks_x(-wi, phi), Q @ m_tab.T @ Q
            for kin in range(4):
                s_roks, s_mi = state(f_in, x_in, kin)
                for kout in range(4):
                    a_roks, a_mi = state(f_out, x_out, kout)
                    got = 0.5 * a_mi @ m_pl @ s_mi
                    want = 0.5 * a_roks @ m_exp @ s_roks
                    worst[mode] = max(worst[mode], abs(got - want) / np.abs(m_exp).max())
    for mode, wv in worst.items():
        check(wv < 2e-5, f"polariser/analyser readings, {mode}: off by {wv:.2e} (relative to max |m|)")
    print(f"polarised 2: 16 polariser/analyser readings x 60 configurations = table formulas, "
          f"max rel. diff radiance {worst['radiance']:.1e}, importance {worst['importance']:.1e}")

    # 3. m00 = the unpolarised plugin (scalar_rgb numbers from the same
    # table, here CarlsonTable.eval); sample: weight x pdf = eval (matrix).
    table = roks_bsdf.CarlsonTable(path)
    worst_m00 = worst_s = 0.0
    si = dr.zeros(mi.SurfaceInteraction3f)
    for _ in range(200):
        wi = np.array(direction(math.radians(89.0 * rng.random()), 2 * math.pi * rng.random()))
        wo = np.array(direction(math.radians(89.0 * rng.random()), 2 * math.pi * rng.random()))
        ref = float(table.eval(wi[None], wo[None])[0])
        for mode in ctxs:
            worst_m00 = max(worst_m00, abs(ev(plugin, mode, wi, wo)[0, 0] - ref) / max(abs(ref), 1e-30))
        si.wi = v3(wi)
        for mode, ctx in ctxs.items():
            bs, wgt = plugin.sample(ctx, si, float(rng.random()), mi.Point2f(*map(float, rng.random(2))))
            if bs.pdf > 0:
                e = mat(plugin.eval(ctx, si, bs.wo))
                worst_s = max(worst_s, float(np.abs(mat(wgt) * bs.pdf - e).max() / np.abs(e).max()))
    check(worst_m00 < 1e-6 and worst_s < 1e-5, f"m00 vs intensity {worst_m00:.1e}, sample weight x pdf vs eval {worst_s:.1e}")
    print(f"polarised 3: m00 = intensity eval to {worst_m00:.1e}; sample weight x pdf = eval to {worst_s:.1e}")

    # 4. No mueller.csv: depolarising (f cos, 0, ..., 0); an explicit
    # mueller_filename; a mueller.csv of another run is refused.
    plain = tmp / "plain"
    plain.mkdir()
    (plain / "brdf.csv").write_text(path.read_text())
    dep = mi.load_dict({"type": "roks_table", "filename": str(plain / "brdf.csv")})
    wi, wo = np.array(direction(0.5, 0.3)), np.array(direction(0.7, 2.0))
    m = ev(dep, "radiance", wi, wo)
    ref = float(table.eval(wi[None], wo[None])[0])
    check(abs(m[0, 0] - ref) <= 1e-6 * ref and np.all(m.reshape(16)[1:] == 0), f"no mueller.csv: not a depolariser: {m}")
    named = mi.load_dict({"type": "roks_table", "filename": str(plain / "brdf.csv"),
                          "mueller_filename": str(path.parent / "mueller.csv")})
    check(np.allclose(ev(named, "radiance", wi, wo), ev(plugin, "radiance", wi, wo), rtol=0, atol=1e-7),
          "mueller_filename not used")
    bad = tmp / "bad"
    bad.mkdir()
    (bad / "brdf.csv").write_text(path.read_text())
    lines = (path.parent / "mueller.csv").read_text().splitlines()
    f = lines[5].split(",")
    f[6] = repr(float(f[6]) * 1.001)
    lines[5] = ",".join(f)
    (bad / "mueller.csv").write_text("\n".join(lines) + "\n")
    try:
        mi.load_dict({"type": "roks_table", "filename": str(bad / "brdf.csv")})
        check(False, "a mueller.csv with a wrong m00 was accepted")
    except Exception as e:  # noqa: BLE001
        check(str(bad / "mueller.csv") in str(e) and "m00" in str(e), f"error does not name the file: {e}")
    print("polarised 4: no mueller.csv depolarises; mueller_filename; wrong m00 refused")

    # 5. The non-polarised variant ignores mueller.csv (same numbers as without).
    mi.set_variant("scalar_rgb")
    roks_bsdf.register()
    a = mi.load_dict({"type": "roks_table", "filename": str(path)})
    b = mi.load_dict({"type": "roks_table", "filename": str(plain / "brdf.csv")})
    si = mi.SurfaceInteraction3f()
    ctx = mi.BSDFContext()
    same = True
    for _ in range(50):
        si.wi = v3(direction(math.radians(89.0 * rng.random()), 2 * math.pi * rng.random()))
        wo = v3(direction(math.radians(89.0 * rng.random()), 2 * math.pi * rng.random()))
        same &= float(a.eval(ctx, si, wo)[0]) == float(b.eval(ctx, si, wo)[0])
    c = mi.load_dict({"type": "roks_table", "filename": str(path), "mueller_filename": str(tmp / "absent.csv")})
    si.wi = v3(direction(0.4, 0.2))
    wo = v3(direction(0.6, 2.5))
    same &= float(c.eval(ctx, si, wo)[0]) == float(b.eval(ctx, si, wo)[0])
    check(same, "scalar_rgb eval changes with mueller.csv beside brdf.csv (or mueller_filename)")
    print("polarised 5: scalar_rgb unchanged by mueller.csv (beside, or named by mueller_filename: not read)")

    # 6. A vectorised polarised variant (needs libLLVM >= 19): the same
    # numbers as CarlsonTable.mueller_eval for a batch, sample weight x pdf
    # = eval, and a small `stokes` render runs (wavefront mode) with finite
    # Stokes images.
    if os.environ.get("DRJIT_LIBLLVM_PATH") and "llvm_ad_mono_polarized" in mi.variants():
        vectorised_checks(check, rng, path, table)
    else:
        print("polarised 6: skipped (no libLLVM >= 19 for llvm_ad_mono_polarized)")

    if roks:
        end_to_end(check, roks, tmp)


def vectorised_checks(check, rng, path: Path, table) -> None:
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_mono_polarized")
    dr.set_flag(dr.JitFlag.SymbolicLoops, False)
    dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    roks_bsdf.register()
    plugin = mi.load_dict({"type": "roks_table", "filename": str(path)})
    table.attach_mueller(path.parent / "mueller.csv")
    n = 4000
    th_i, th_o = np.radians(89.0 * rng.random(n)), np.radians(89.0 * rng.random(n))
    def dirs(theta, phi):
        return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)

    wi = dirs(th_i, 2 * math.pi * rng.random(n)).astype(np.float32)
    wo = dirs(th_o, 2 * math.pi * rng.random(n)).astype(np.float32)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(wi[:, 0], wi[:, 1], wi[:, 2])
    worst = worst_s = 0.0
    for radiance, mode in ((True, mi.TransportMode.Radiance), (False, mi.TransportMode.Importance)):
        ctx = mi.BSDFContext(mode)
        got = np.array(plugin.eval(ctx, si, mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])))[:, :, 0, :]
        got = np.moveaxis(got, -1, 0)
        want = table.mueller_eval(wi.astype(np.float64), wo.astype(np.float64), radiance=radiance)
        scale = np.abs(want).max(axis=(1, 2))
        worst = max(worst, float((np.abs(got - want).max(axis=(1, 2)) / np.where(scale > 0, scale, 1.0)).max()))
        bs, w = plugin.sample(ctx, si, mi.Float(rng.random(n).astype(np.float32)),
                              mi.Point2f(rng.random(n).astype(np.float32), rng.random(n).astype(np.float32)))
        e = np.moveaxis(np.array(plugin.eval(ctx, si, bs.wo))[:, :, 0, :], -1, 0)
        wm = np.moveaxis(np.array(w)[:, :, 0, :], -1, 0) * np.array(bs.pdf)[:, None, None]
        ok = np.array(bs.pdf) > 0
        sc = np.abs(e[ok]).max(axis=(1, 2))
        worst_s = max(worst_s, float((np.abs(wm[ok] - e[ok]).max(axis=(1, 2)) / sc).max()))
    check(worst < 1e-5 and worst_s < 1e-5, f"llvm_ad_mono_polarized: eval vs numpy {worst:.1e}, sample {worst_s:.1e}")
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": "path", "max_depth": 3}},
        "sensor": {"type": "perspective", "fov": 30,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, -3, 3], target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": 16, "height": 16},
                   "sampler": {"type": "independent", "sample_count": 4}},
        "plane": {"type": "rectangle", "bsdf": {"type": "roks_table", "filename": str(path)}},
        "light": {"type": "constant"},
    })
    img = np.array(mi.render(scene))  # channels: S0 as RGB + alpha, then S1, S2, S3 as RGB
    check(img.shape[-1] == 13 and np.all(np.isfinite(img)) and img[..., 0].mean() > 0,
          f"stokes render through the plugin: shape {img.shape}, finite {np.all(np.isfinite(img))}")
    img = img[..., [0, 4, 7, 10]]
    print(f"polarised 6: llvm_ad_mono_polarized: batch eval = numpy to {worst:.1e}, sample weight x pdf = eval "
          f"to {worst_s:.1e}; stokes render mean S0..S3 {np.round(img.reshape(-1, img.shape[-1]).mean(axis=0), 5).tolist()}")


def _si(mi, dr, wi):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*map(float, wi))
    return si


AL_N, AL_K = 1.015, 6.627
E2E_THETAS = [30.0, 60.0, 75.0]
E2E_BANDS = 16


def end_to_end(check, roks: str, tmp: Path) -> None:
    """roks brdf --polarisation mueller on a flat Al substrate -> the
    plugin's polarised eval at the specular direction, times the cell's
    projected solid angle over cos(theta_o) (the eval integrated over the
    cell), = Mitsuba's polarised `conductor` (its sample's Mueller weight)
    for the same incidence, both transport modes, light azimuths 0 and
    turned; tolerance 4 standard errors of the cell plus float32."""
    import subprocess

    import drjit as dr
    import mitsuba as mi

    scene = tmp / "flat_al.toml"
    scene.write_text(f"""
[surface]
size = [1.0, 1.0]
material = "al"

[materials.al]
n = {AL_N!r}
k = {AL_K!r}

[light]
theta_deg = [{", ".join(map(repr, E2E_THETAS))}]
phi_deg = 0.0
photons = 4096
seed = 5

[tally]
bands = {E2E_BANDS}
""")
    out = tmp / "flat_al"
    r = subprocess.run([roks, "brdf", str(scene), "--polarisation", "mueller", "--out", str(out)],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"roks brdf failed: {r.stderr[-2000:]}")
    if r.returncode != 0:
        return
    mi.set_variant("scalar_spectral_polarized")
    roks_bsdf.register()
    plugin = mi.load_dict({"type": "roks_table", "filename": str(out / "brdf.csv")})
    cond = mi.load_dict({"type": "conductor", "eta": AL_N, "k": AL_K})
    table = roks_bsdf.CarlsonTable(out / "brdf.csv")
    se = PolarTable.read(out / "mueller.csv").stderr.reshape(len(E2E_THETAS), table.fractions.shape[1], 4, 4)
    worst_z, worst_rel, shown = 0.0, 0.0, None
    for t, theta_deg in enumerate(sorted(E2E_THETAS)):
        for gamma in (0.0, 0.8, -2.0):
            wi = np.array(direction(math.radians(theta_deg), gamma))
            spec = np.array([-wi[0], -wi[1], wi[2]])
            c = int(table.locate(rot_z(spec, -gamma)[None])[0])
            for mode in (mi.TransportMode.Radiance, mi.TransportMode.Importance):
                ctx = mi.BSDFContext(mode)
                si = _si(mi, dr, wi)
                e = np.array(plugin.eval(ctx, si, mi.Vector3f(*map(float, spec))))[..., 0]
                got = e * table.proj[c] / spec[2]
                bs, w = cond.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
                want = np.array(w)[..., 0]
                tol = 4 * se[t, c] * table.proj[c] + 2e-5 * np.abs(want).max()
                dev = np.abs(got - want)
                worst_rel = max(worst_rel, float(dev.max() / np.abs(want).max()))
                worst_z = max(worst_z, float((dev / tol).max()))
                if shown is None and theta_deg == 60.0 and gamma == 0.0:
                    shown = (got, want)
    check(worst_z <= 1.0, f"end to end: plugin vs conductor off by {worst_z:.2f} x tolerance (rel {worst_rel:.1e})")
    print(f"polarised end to end (roks brdf, flat Al, {E2E_BANDS} bands): plugin = Mitsuba's polarised conductor, "
          f"max rel. diff {worst_rel:.1e}, max |diff| / tolerance {worst_z:.2f}")
    if shown is not None:
        np.set_printoptions(precision=5, suppress=True)
        print("  60 deg, radiance, plugin:\n", shown[0], "\n  conductor:\n", shown[1])


def _variant(mi, name: str) -> None:
    """Set a Mitsuba variant (LLVM found as the tracers do) with the plugin registered."""
    lib = _find_libllvm()
    if lib:
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", lib)
    mi.set_variant(name)
    roks_bsdf.register()


class Checks:
    """Collects failed checks, so one run reports them all."""

    def __init__(self):
        self.failures: list[str] = []

    def __call__(self, ok: bool, what: str) -> None:
        if not ok:
            self.failures.append(what)
            print("FAIL:", what)

    def done(self) -> None:
        assert not self.failures, "\n".join(self.failures)


@pytest.mark.slow
def test_polarised_variants(mi, roks):
    """5: the polarised variants, with the end-to-end check on a `roks brdf` table."""
    check = Checks()
    _variant(mi, "scalar_rgb")
    polarised_checks(check, np.random.default_rng(8), roks)
    check.done()


@pytest.mark.slow
def test_scalar_rgb(mi, tmp_path):
    """1-4 in scalar_rgb."""
    _variant(mi, "scalar_rgb")
    rng = np.random.default_rng(7)
    g = grid(M)
    n_cells = len(g)
    tmp = tmp_path
    fractions = []
    for t in THETAS:
        f = rng.random(n_cells) * 0.012
        f[rng.choice(n_cells, 5, replace=False)] = 0.0  # some empty cells
        fractions.append(f)
    path = tmp / "brdf.csv"
    write_table(path, [(t, 0.0, f) for t, f in zip(THETAS, fractions)])
    bsdf = mi.load_dict({"type": "roks_table", "filename": str(path)})
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    check = Checks()

    def ev(wi, wo) -> float:
        si.wi = mi.Vector3f(*wi)
        return float(bsdf.eval(ctx, si, mi.Vector3f(*wo))[0])

    # 1. eval integrates to the reflectance, exactly over cells.
    for theta_deg, phi_wi in [(0, 0), (40, 0), (80, 0), (20, 0), (65, 0), (89, 0), (30, 0.7)]:
        theta = math.radians(theta_deg)
        wi = direction(theta, phi_wi)
        total = 0.0
        for (j, c, bot, top, lo, hi, proj) in g:
            mu = 0.5 * (bot + top)
            d = direction(math.acos(mu), 0.5 * (lo + hi) + phi_wi)
            total += ev(wi, d) / d[2] * proj
        ref = reference_reflectance(path, min(theta_deg, THETAS[-1]))
        check(abs(total - ref) <= 1e-5 * ref, f"cell sum at {theta_deg} deg: {total} vs {ref}")
        # Monte Carlo, uniform over the hemisphere (pdf 1 / 2 pi).
        n = 2000
        u = rng.random((n, 2))
        vals = np.array([ev(wi, direction(math.acos(1 - a), 2 * math.pi * b)) * 2 * math.pi for a, b in u])
        mean, se = vals.mean(), vals.std(ddof=1) / math.sqrt(n)
        check(abs(mean - ref) <= 4 * se, f"MC integral at {theta_deg} deg: {mean} +- {se} vs {ref}")
        print(f"theta_i {theta_deg:>4} deg: cell sum {total:.7f}, MC {mean:.5f} +- {se:.5f}, table {ref:.7f}")

    # 2. sampling: weight, pdf and eval consistent; mean weight = R; cells.
    table = roks_bsdf.CarlsonTable(path)
    for theta_deg in (25.0, 40.0):
        theta = math.radians(theta_deg)
        si.wi = mi.Vector3f(*direction(theta, 0.0))
        n = 8000
        weights = np.empty(n)
        cells = np.empty(n, dtype=np.int64)
        bad = 0
        for i in range(n):
            s1, s2a, s2b = rng.random(3)
            bs, w = bsdf.sample(ctx, si, float(s1), mi.Point2f(float(s2a), float(s2b)))
            wo = bs.wo
            e = float(bsdf.eval(ctx, si, wo)[0])
            p = float(bsdf.pdf(ctx, si, wo))
            wk = float(w[0])
            ok = bs.pdf > 0 and wo.z > 0
            ok = ok and abs(wk * bs.pdf - e) <= 1e-5 * e and abs(p - bs.pdf) <= 1e-5 * p
            bad += not ok
            weights[i] = wk
            cells[i] = table.locate(np.array([[wo.x, wo.y, wo.z]], dtype=np.float64))[0]
        ref = reference_reflectance(path, theta_deg)
        mean, se = weights.mean(), weights.std(ddof=1) / math.sqrt(n)
        check(bad == 0, f"{bad} samples at {theta_deg} deg with weight x pdf != eval or pdf != BSDF.pdf")
        check(abs(mean - ref) <= 4 * se + 1e-6 * ref, f"mean weight at {theta_deg} deg: {mean} +- {se} vs {ref}")
        # Expected cell probabilities of the mixture.
        i0, i1, w = table.bracket(np.array([theta]))
        prob = np.zeros(n_cells)
        for idx, wt in ((i0[0], 1 - w[0]), (i1[0], w[0])):
            prob += wt * table.fractions[idx] / table.reflectance[idx]
        counts = np.bincount(cells, minlength=n_cells)
        check(np.all(counts[prob == 0] == 0), f"samples in empty cells at {theta_deg} deg")
        e = n * prob[prob > 0]
        chi2 = float(((counts[prob > 0] - e) ** 2 / e).sum())
        dof = int((prob > 0).sum()) - 1
        check(chi2 < chi2_critical(dof), f"chi2 {chi2:.1f} > {chi2_critical(dof):.1f} ({dof} dof) at {theta_deg} deg")
        print(f"sample at {theta_deg} deg: mean weight {mean:.6f} +- {se:.6f} (table {ref:.6f}), chi2 {chi2:.1f} for {dof} dof")

    # 3. A table at light azimuth 90 degrees with turned cells = the same table.
    turned = []
    for f in fractions:
        t = np.zeros(n_cells)
        for flat, (j, c, *_rest) in enumerate(g):
            t[2 * j * (j - 1) + (c + j) % (4 * j)] = f[flat]
        turned.append(t)
    path90 = tmp / "brdf90.csv"
    write_table(path90, [(t, 90.0, f) for t, f in zip(THETAS, turned)])
    b90 = mi.load_dict({"type": "roks_table", "filename": str(path90)})
    worst = 0.0
    for _ in range(500):
        wi = direction(math.radians(89.9 * rng.random()), 2 * math.pi * rng.random())
        wo = direction(math.radians(89.9 * rng.random()), 2 * math.pi * rng.random())
        si.wi = mi.Vector3f(*wi)
        a = float(bsdf.eval(ctx, si, mi.Vector3f(*wo))[0])
        b = float(b90.eval(ctx, si, mi.Vector3f(*wo))[0])
        worst = max(worst, abs(a - b) / max(a, 1e-30))
    check(worst <= 1e-5, f"turned table differs by {worst:.2e}")

    # 4. A broken file.
    broken = tmp / "broken.csv"
    broken.write_text("theta,phi\n1,2\n")
    try:
        mi.load_dict({"type": "roks_table", "filename": str(broken)})
        check(False, "broken file accepted")
    except Exception as e:  # Mitsuba wraps the plugin's exception
        check(str(broken) in str(e), f"error does not name the file: {e}")

    check.done()
