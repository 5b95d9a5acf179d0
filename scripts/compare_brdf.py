#!/usr/bin/env python3
"""Compare two `roks brdf`-format output folders (e.g. roks vs scripts/mitsuba_brdf.py).

    compare_brdf.py DIR_A DIR_B

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
cell differs. Exit status 1 on any failure. `scripts/crosscheck.py` uses
`compare()` for its markdown report.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections import defaultdict
from pathlib import Path


def load(d: Path):
    """summary entries by theta, and {theta: {(band, cell): (fraction, stderr)}}."""
    summ = {e["theta_deg"]: e for e in json.load(open(d / "summary.json"))["incidence"]}
    cells = defaultdict(dict)
    for r in csv.DictReader(open(d / "brdf.csv")):
        cells[float(r["theta_i_deg"])][(int(r["band"]), int(r["cell"]))] = (
            float(r["fraction"]), float(r["fraction_stderr"]))
    return summ, cells


def cell_z_limit(n: int, p: float = 1e-3) -> float:
    """|z| that n independent standard normals all stay below with probability 1 - p."""
    # two-sided tail per cell q = p / n; invert erfc by bisection (no scipy)
    q = p / max(n, 1)
    lo, hi = 0.0, 40.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if math.erfc(mid / math.sqrt(2.0)) > q:
            lo = mid
        else:
            hi = mid
    return max(4.0, hi)


def wilson_hilferty(chi2_per_dof: float, dof: int) -> float:
    """Normal deviate of a chi-square per degree of freedom (Wilson-Hilferty)."""
    if dof <= 0:
        return 0.0
    v = 2.0 / (9.0 * dof)
    return (chi2_per_dof ** (1.0 / 3.0) - (1.0 - v)) / math.sqrt(v)


def gap(ra: float, lost_a: float, rb: float, lost_b: float) -> float:
    """Signed distance between the intervals [ra, ra + lost_a] and [rb, rb + lost_b] (0 if they overlap)."""
    if ra > rb + lost_b:
        return ra - (rb + lost_b)
    if rb > ra + lost_a:
        return ra + lost_a - rb
    return 0.0


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
        red = chi2 / dof if dof else 0.0
        rows.append({
            "theta": th, "r_a": ea["reflectance"], "se_a": ea["reflectance_stderr"],
            "r_b": eb["reflectance"], "se_b": eb["reflectance_stderr"], "diff": d, "z": z,
            "lost_a": ea.get("lost", 0.0), "lost_b": eb.get("lost", 0.0),
            "cells": dof, "chi2_dof": red, "chi2_z": wilson_hilferty(red, dof), "max_cell_z": zmax,
            "cell_z_limit": cell_z_limit(dof), "exact": exact_n, "exact_bad": exact_bad,
        })
    for r in rows:
        r["pass"] = verdict(r)
    return rows


def verdict(r: dict) -> bool:
    return (abs(r["z"]) <= 4.0 and r["max_cell_z"] <= r["cell_z_limit"]
            and r["chi2_z"] <= 3.1 and r["exact_bad"] == 0)


def table(rows: list[dict]) -> str:
    out = [f"{'theta':>6} {'R_a':>10} {'R_b':>10} {'z':>7} {'cells':>6} {'chi2/dof':>9} {'max|z|':>7} {'exact':>6}"]
    for r in rows:
        out.append(f"{r['theta']:6g} {r['r_a']:10.6f} {r['r_b']:10.6f} {r['z']:7.2f} {r['cells']:6d} "
                   f"{r['chi2_dof']:9.3f} {r['max_cell_z']:7.2f} {r['exact'] - r['exact_bad']:>3d}/{r['exact']:<2d}"
                   f"{'' if r['pass'] else '  FAIL'}")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    a = ap.parse_args()
    rows = compare(a.a, a.b)
    print(table(rows))
    ok = bool(rows) and all(r["pass"] for r in rows)
    print("verdict:", "pass" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
