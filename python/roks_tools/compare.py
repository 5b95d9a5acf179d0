"""Compare two `roks brdf`-format output folders (e.g. roks vs the Mitsuba tracer).

    roks-compare-brdf DIR_A DIR_B [--min-signal 0.1]

For every incidence angle present in both: the reflectances with the z-score
(difference over the combined standard error), and over the Carlson cells
where either side has weight the chi-square per degree of freedom of the cell
fractions and the largest |z|. Cells where both standard errors are zero
must agree exactly (to 1e-9) and are counted apart ('exact' column).

Lost weight (`lost` in summary.json: bounce caps, numerical guards) is
weight whose fate is unknown: the true reflectance of a run lies in
[R, R + lost]. The reflectance difference used for z is the gap between the
two intervals (0 where they overlap); with nothing lost it is R_a - R_b.

Verdict per angle (`verdict()`): fail if the reflectance |z| > 4, or any cell
|z| > 4 + a Bonferroni allowance for the number of cells (`cell_z_limit`), or
the cell chi-square exceeds its p = 1e-3 point (Wilson-Hilferty), or an exact
cell differs. Exit status 1 on any failure. A failed angle with sparse cells
(relative standard error above 20 % on a side: a few photons, whose z is far
from normal) gets one more line (`sparse_advice`): how many, and the photons
per angle on each side that would bring 90 % of the cells with weight below
20 % (a relative error falls as 1/sqrt(photons): `photons_needed`). `roks_tools.studies.crosscheck` uses
`compare()` for its markdown report.

Polarisation (`compare_polarised()`, when both folders hold stokes.csv, or
both mueller.csv; otherwise only the intensity is compared, with a note):
per incidence angle
* the reflected Stokes vector / Mueller matrix of summary.json
  (`reflected_stokes`, `reflected_mueller`), component by component: z of the
  difference, reduced by the lost weight of both runs (|m_ij| <= m00, so lost
  weight moves no component by more than itself); each |z| <= 4;
* the cells: every component of the cells with enough signal, i.e. where
  on both sides S0 (m00) is positive with a relative standard error at most
  `--min-signal` (0.1: about 100 photons or more; with fewer the per-photon
  variance estimates are too rough for 4-sigma tails; the intensity of every
  cell is compared by `compare()` on brdf.csv). Per component the chi-square
  per degree of freedom, whose Wilson-Hilferty deviate must stay below the
  one-sided p = 1e-3 point Bonferroni-corrected for the number of components
  (the components of one cell come from the same photons, so they are
  correlated: their chi-squares are judged one by one; the pooled chi2/dof is
  reported); the largest |z| over all components and cells against
  `cell_z_limit` of their number; components with zero standard error on
  both sides agree to 1e-5 of S0. Mitsuba's matrices are float32: a
  rounding error of 1e-6 S0 is added in quadrature to the standard errors
  (a component that is exactly zero on one side, e.g. m13 of one-bounce
  paths at normal incidence, is 1e-17 with a 1e-18 spread on the other).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from .errors import ResultError, cli, show
from .results import POLAR_FILES, BrdfTable, PolarTable
from .summary import BrdfSummary, read_summary
from .stats import cell_z_limit, gap, normal_two_sided, wilson_hilferty  # noqa: F401 (re-exported)

ROUNDING = 1e-6  # relative rounding of a component (Mitsuba's matrices are float32)
SPARSE_REL_SE = 0.2
"""A cell whose fraction has a relative standard error above this on either
side holds a few photons: its z is far from normal (`sparse_advice`)."""
SPARSE_QUANTILE = 0.9
"""`sparse_advice` asks for the photons that bring this share of the cells
with weight to `SPARSE_REL_SE` on both sides."""


def load(d: Path):
    """summary entries by theta, and {theta: {(band, cell): (fraction, stderr)}}."""
    s = read_summary(Path(d) / "summary.json")
    if not isinstance(s, BrdfSummary):
        raise ResultError(f"{show(s.path)}: a `roks trace` summary; compare_brdf compares `roks brdf` folders")
    return s.by_theta(), BrdfTable.read(Path(d) / "brdf.csv").cells()


def compare(dir_a: Path, dir_b: Path) -> list[dict]:
    """One dict per incidence angle present in both folders."""
    sa, ca = load(Path(dir_a))
    sb, cb = load(Path(dir_b))
    rows = []
    for th in sorted(set(sa) & set(sb)):
        ea, eb = sa[th], sb[th]
        se = math.hypot(ea["reflectance_stderr"], eb["reflectance_stderr"])
        d = gap(ea["reflectance"], ea.get("lost", 0.0), eb["reflectance"], eb.get("lost", 0.0))
        z = d / se if se > 0 else (0.0 if abs(d) < 1e-9 else math.inf)
        chi2, dof, zmax, exact_bad, exact_n = 0.0, 0, 0.0, 0, 0
        rel_a, rel_b, sparse = [], [], 0
        for key in set(ca[th]) | set(cb[th]):
            fa, sea = ca[th].get(key, (0.0, 0.0))
            fb, seb = cb[th].get(key, (0.0, 0.0))
            if fa == 0 and fb == 0:
                continue
            s = math.hypot(sea, seb)
            if s == 0 or s < 1e-12 * max(fa, fb):
                exact_n += 1
                exact_bad += abs(fa - fb) > 1e-9
                continue
            zc = (fa - fb) / s
            chi2 += zc * zc
            dof += 1
            zmax = max(zmax, abs(zc))
            ra_, rb_ = (sea / fa if fa > 0 else math.inf), (seb / fb if fb > 0 else math.inf)
            rel_a.append(ra_)
            rel_b.append(rb_)
            sparse += max(ra_, rb_) > SPARSE_REL_SE
        red = chi2 / dof if dof else 0.0
        rows.append({
            "theta": th, "r_a": ea["reflectance"], "se_a": ea["reflectance_stderr"],
            "r_b": eb["reflectance"], "se_b": eb["reflectance_stderr"], "diff": d, "z": z,
            "lost_a": ea.get("lost", 0.0), "lost_b": eb.get("lost", 0.0),
            "cells": dof, "chi2_dof": red, "chi2_z": wilson_hilferty(red, dof), "max_cell_z": zmax,
            "cell_z_limit": cell_z_limit(dof), "exact": exact_n, "exact_bad": exact_bad,
            "sparse": sparse, "photons_a": int(ea.get("photons", 0)), "photons_b": int(eb.get("photons", 0)),
            "photons_needed_a": photons_needed(rel_a, int(ea.get("photons", 0))),
            "photons_needed_b": photons_needed(rel_b, int(eb.get("photons", 0))),
        })
    for r in rows:
        r["pass"] = verdict(r)
    return rows


def photons_needed(rel_se: list[float], photons: int) -> int | None:
    """Photons per angle that would bring the `SPARSE_QUANTILE` quantile of
    the cells' relative standard errors `rel_se` (at `photons` photons) down
    to `SPARSE_REL_SE`: a relative standard error falls as 1/sqrt(photons).
    A cell with no weight on this side counts as the largest finite one times
    sqrt(2) (at least one photon more). None when there is nothing to scale."""
    finite = [r for r in rel_se if math.isfinite(r)]
    if not finite or photons <= 0:
        return None
    worst = max(finite) * math.sqrt(2)
    q = float(np.quantile([r if math.isfinite(r) else worst for r in rel_se], SPARSE_QUANTILE))
    need = photons * (q / SPARSE_REL_SE) ** 2
    return max(photons, int(math.ceil(need / 1000.0)) * 1000)


def sparse_advice(r: dict) -> str | None:
    """For a failed row with sparse cells: one line saying so and how many
    photons per angle on each side would do (`photons_needed`); None when
    the row passes or has no sparse cell."""
    if r.get("pass", True) or not r.get("sparse"):
        return None
    a, b = r.get("photons_needed_a"), r.get("photons_needed_b")
    more = [f"{name} {need:,} (now {now:,})" for name, need, now in
            (("A", a, r["photons_a"]), ("B", b, r["photons_b"])) if need and need > now]
    tail = ("; photons per angle that bring {:.0%} of the cells below {:.0%}: {}".format(
        SPARSE_QUANTILE, SPARSE_REL_SE, ", ".join(more)) if more else "")
    return (f"theta {r['theta']:g}: {r['sparse']} of {r['cells']} cells are sparse (relative standard "
            f"error above {SPARSE_REL_SE:.0%} on a side: a few photons, whose z is far from normal), so "
            f"this FAIL may be too few photons rather than a difference{tail}")


def verdict(r: dict) -> bool:
    return (abs(r["z"]) <= 4.0 and r["max_cell_z"] <= r["cell_z_limit"]
            and r["chi2_z"] <= 3.1 and r["exact_bad"] == 0)


def load_polar(d: Path):
    """(mode, component names, {theta: {(band, cell): (values, stderrs)}}) of stokes.csv or
    mueller.csv in folder d, or None when it has neither."""
    t = PolarTable.find(d)
    return None if t is None else (t.mode, list(t.names), t.cells())


def compare_polarised(dir_a: Path, dir_b: Path, min_signal: float = 0.1) -> list[dict]:
    """One dict per incidence angle present in both folders' stokes.csv (or mueller.csv);
    [] when they do not both hold the same kind (see the module docs)."""
    pa, pb = load_polar(dir_a), load_polar(dir_b)
    if pa is None or pb is None or pa[0] != pb[0]:
        return []
    mode, names, ca = pa
    cb = pb[2]
    sa, _ = load(Path(dir_a))
    sb, _ = load(Path(dir_b))
    key = f"reflected_{mode}"
    rows = []
    for th in sorted(set(sa) & set(sb) & set(ca) & set(cb)):
        ea, eb = sa[th], sb[th]
        lost = ea.get("lost", 0.0) + eb.get("lost", 0.0)
        refl_z = []
        for va, sea, vb, seb in zip(ea[key], ea[key + "_stderr"], eb[key], eb[key + "_stderr"]):
            d = math.copysign(max(abs(va - vb) - lost, 0.0), va - vb)
            se = math.hypot(sea, seb)
            refl_z.append(d / se if se > 0 else (0.0 if abs(d) <= 1e-5 * ea[key][0] else math.inf))
        nc = len(names)
        chi2, dof = [0.0] * nc, [0] * nc
        zmax, zmax_at, exact_n, exact_bad, n_cells = 0.0, None, 0, 0, 0
        for cell in sorted(set(ca[th]) & set(cb[th])):
            (va, sea), (vb, seb) = ca[th][cell], cb[th][cell]
            if not (va[0] > 0 and vb[0] > 0 and sea[0] <= min_signal * va[0] and seb[0] <= min_signal * vb[0]):
                continue
            n_cells += 1
            for c in range(nc):
                s0 = 0.5 * (va[0] + vb[0])
                if sea[c] == 0 and seb[c] == 0:
                    exact_n += 1
                    exact_bad += abs(va[c] - vb[c]) > 1e-5 * s0
                    continue
                z = (va[c] - vb[c]) / math.sqrt(sea[c] ** 2 + seb[c] ** 2 + (ROUNDING * s0) ** 2)
                chi2[c] += z * z
                dof[c] += 1
                if abs(z) > zmax:
                    zmax, zmax_at = abs(z), (names[c], cell)
        per = {names[c]: (chi2[c] / dof[c] if dof[c] else 0.0, dof[c]) for c in range(nc)}
        chi2_z = {c: wilson_hilferty(v, n) for c, (v, n) in per.items()}
        total = sum(dof)
        rows.append({
            "theta": th, "mode": mode, "names": names,
            "refl_a": ea[key], "refl_b": eb[key], "refl_z": refl_z,
            "max_refl_z": max(abs(z) for z in refl_z), "cells": n_cells, "terms": total,
            "chi2_dof": sum(chi2) / total if total else 0.0, "chi2_dof_by": per, "chi2_z_by": chi2_z,
            "max_chi2_z": max(chi2_z.values()), "chi2_z_limit": normal_two_sided(2e-3 / nc),
            "max_cell_z": zmax, "max_cell_z_at": zmax_at, "cell_z_limit": cell_z_limit(total),
            "exact": exact_n, "exact_bad": exact_bad,
        })
    for r in rows:
        r["pass"] = verdict_polarised(r)
    return rows


def verdict_polarised(r: dict) -> bool:
    return (r["max_refl_z"] <= 4.0 and r["max_cell_z"] <= r["cell_z_limit"]
            and r["max_chi2_z"] <= r["chi2_z_limit"] and r["exact_bad"] == 0)


def table_polarised(rows: list[dict]) -> str:
    out = [f"{'theta':>6} {'kind':>7} {'max|z| R':>9} {'cells':>6} {'terms':>6} {'chi2/dof':>9} "
           f"{'worst chi2 z':>12} {'max|z|':>7} {'exact':>6}"]
    for r in rows:
        worst = max(r["chi2_z_by"], key=r["chi2_z_by"].get)
        out.append(f"{r['theta']:6g} {r['mode']:>7} {r['max_refl_z']:9.2f} {r['cells']:6d} {r['terms']:6d} "
                   f"{r['chi2_dof']:9.3f} {r['chi2_z_by'][worst]:6.2f} {worst:>5} {r['max_cell_z']:7.2f} "
                   f"{r['exact'] - r['exact_bad']:>3d}/{r['exact']:<2d}{'' if r['pass'] else '  FAIL'}")
    return "\n".join(out)


def table(rows: list[dict]) -> str:
    out = [f"{'theta':>6} {'R_a':>10} {'R_b':>10} {'z':>7} {'cells':>6} {'chi2/dof':>9} {'max|z|':>7} {'exact':>6}"]
    for r in rows:
        out.append(f"{r['theta']:6g} {r['r_a']:10.6f} {r['r_b']:10.6f} {r['z']:7.2f} {r['cells']:6d} "
                   f"{r['chi2_dof']:9.3f} {r['max_cell_z']:7.2f} {r['exact'] - r['exact_bad']:>3d}/{r['exact']:<2d}"
                   f"{'' if r['pass'] else '  FAIL'}")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--min-signal", type=float, default=0.1,
                    help="polarised cells: largest relative standard error of S0 (m00) on both sides")
    a = ap.parse_args(argv)
    return cli("compare_brdf", lambda: report(a))


def report(a: argparse.Namespace) -> int:
    """Print the comparison of folders a.a and a.b; 0 if it passes, else 1."""
    rows = compare(a.a, a.b)
    print(table(rows))
    for r in rows:
        advice = sparse_advice(r)
        if advice:
            print(advice)
    ok = bool(rows) and all(r["pass"] for r in rows)
    prow = compare_polarised(a.a, a.b, a.min_signal)
    if prow:
        print(table_polarised(prow))
        ok = ok and all(r["pass"] for r in prow)
    elif any((Path(d) / f).is_file() for d in (a.a, a.b) for f in POLAR_FILES.values()):
        print("polarised tallies not compared: the folders do not both hold stokes.csv or both mueller.csv")
    print("verdict:", "pass" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
