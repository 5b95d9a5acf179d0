#!/usr/bin/env python3
"""Tests of the Mitsuba plugin `roks_table` (scripts/roks_bsdf.py), through
Mitsuba's own BSDF interface in the scalar_rgb variant:

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

The reference reflectance is computed here from the CSV text (sum of the
fractions of each block, linear in theta_i), independently of the plugin.
Runs in about 20 s:

    /work/main/.venv/bin/python scripts/test_roks_bsdf.py
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import roks_bsdf  # noqa: E402

M = 6  # bands: 84 cells
THETAS = [0.0, 40.0, 80.0]


def grid(m: int):
    """(band, cell, mu_bot, mu_top, phi_lo, phi_hi, proj) per flat cell."""
    k = m * (m + 1)
    out = []
    for j in range(1, m + 1):
        dphi = 2 * math.pi / (4 * j)
        for c in range(4 * j):
            out.append((j, c, (k - j * (j + 1)) / k, (k - (j - 1) * j) / k, (c - 0.5) * dphi, (c + 0.5) * dphi,
                        math.pi * (k - j * j) / (k * k)))
    return out


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
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    thetas = sorted(set(data[:, 0]))
    sums = [data[data[:, 0] == t, 12].sum() for t in thetas]
    return float(np.interp(theta_deg, thetas, sums))


def direction(theta: float, phi: float):
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))


def chi2_critical(dof: float, z: float = 3.719) -> float:
    """Wilson-Hilferty upper quantile of chi-square, z = 3.719: p = 1e-4."""
    return dof * (1 - 2 / (9 * dof) + z * math.sqrt(2 / (9 * dof))) ** 3


def main() -> int:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    roks_bsdf.register()
    rng = np.random.default_rng(7)
    g = grid(M)
    n_cells = len(g)
    tmp = Path(tempfile.mkdtemp(prefix="roks-bsdf-"))
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
    failures = []

    def check(ok: bool, what: str) -> None:
        if not ok:
            failures.append(what)
            print("FAIL:", what)

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

    print("FAILED" if failures else "all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
