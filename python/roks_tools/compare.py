"""Compare two `roks brdf`-format output folders (e.g. roks vs the Mitsuba tracer).

    roks-compare-brdf DIR_A DIR_B [--min-signal 0.1]

First the run descriptions (`describe()`, from each summary.json: roks's
`run`, the Mitsuba tracer's own keys): polarisation (the transport, scalar
or polarised, with its tally, and the incident state), wavelengths,
material, Carlson bands, symmetry (mirror folding), incidences and light
azimuths. Every difference is named on one line before any statistic,

    descriptions differ: polarisation roks=stokes vs mitsuba=none

(each side named by the program that wrote it, `roks` or `mitsuba`, or
`A` and `B` when one program wrote both). A difference in what is traced
(polarisation transport or incident state, wavelengths, material, bands,
symmetry) makes the comparison one of unlike runs: the statistics are still
printed, but the verdict is FAIL naming the difference (exit status 1), and
no "too few photons" advice is given. Incidences or azimuths present on one
side only are named and left out; the others are compared. A key one side
does not record (the material in roks's summary.json, which records the
scene's content hash instead) is not compared.

For every incidence (angle and light azimuth) present in both: the reflectances with the z-score
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
cell differs. Exit status 0 when everything passes, 1 on any failure (or a
difference of the descriptions, above), 2 for a folder that cannot be read. A failed angle with sparse cells
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


def _summary(d: Path) -> BrdfSummary:
    s = read_summary(Path(d) / "summary.json")
    if not isinstance(s, BrdfSummary):
        raise ResultError(f"{show(s.path)}: a `roks trace` summary; compare_brdf compares `roks brdf` folders")
    return s


def load(d: Path):
    """summary entries by theta, and {theta: {(band, cell): (fraction, stderr)}} (a run of one light azimuth)."""
    s = _summary(d)
    return s.by_theta(), BrdfTable.read(Path(d) / "brdf.csv").cells()


def load_incidences(d: Path):
    """summary entries by (theta, phi), and {(theta, phi): {(band, cell): (fraction, stderr)}}."""
    s = _summary(d)
    t = BrdfTable.read(Path(d) / "brdf.csv")
    several = len(t.azimuths) > 1
    cells = {}
    for phi in t.azimuths:
        for th, c in t.cells(phi if several else None).items():
            cells[(th, phi)] = c
    return {(e.theta_deg, e.phi_deg): e for e in s.incidence}, cells


# ----------------------------------------------------------------------------
# Run descriptions
# ----------------------------------------------------------------------------

TRACED = ("polarisation", "incident polarisation", "wavelengths", "material", "bands", "symmetry")
"""Description keys whose difference makes two runs unlike (a FAIL)."""


def _incident_stokes(incident) -> list[float] | None:
    """The Stokes vector (S0 = 1) of an incident state as roks writes it
    (`"unpolarised"`, `"s"`, `"p"`, `"right"`, `"left"`, `{"linear": deg}`,
    `{"stokes": [...]}`) or as a list; None if unknown."""
    named = {"unpolarised": [1.0, 0.0, 0.0, 0.0], "s": [1.0, 1.0, 0.0, 0.0], "p": [1.0, -1.0, 0.0, 0.0],
             "right": [1.0, 0.0, 0.0, 1.0], "left": [1.0, 0.0, 0.0, -1.0]}
    if isinstance(incident, str):
        return named.get(incident)
    if isinstance(incident, dict) and "linear" in incident:
        a = math.radians(2 * float(incident["linear"]))
        return [1.0, math.cos(a), math.sin(a), 0.0]
    if isinstance(incident, dict) and "stokes" in incident:
        incident = incident["stokes"]
    if isinstance(incident, list) and len(incident) == 4 and incident[0]:
        return [float(v) / float(incident[0]) for v in incident]
    return None


def describe(d: Path) -> dict:
    """The run description of a `roks brdf` (or Mitsuba tracer) folder from
    its summary.json: `program` ("roks" or "mitsuba"), `transport`
    ("polarised" or "scalar"), `tally` ("none", "stokes", "mueller"),
    `polarisation` (the tally's name for polarised transport with a tally,
    "polarised (no tally)", or "none" for scalar transport), `incident`
    (the Stokes vector, or None), `wavelengths` (um, [] monochrome),
    `material` (None when not recorded), `bands`, `symmetry` (None when not
    recorded), `incidences` [(theta, phi)] and `azimuths`."""
    s = _summary(d)
    raw = s.raw
    program = "mitsuba" if ("mitsuba_version" in raw or "variant" in raw) else "roks"
    pol = s.run.get("polarisation") if isinstance(s.run, dict) else None
    if pol is None:
        pol = raw.get("polarisation")
    if isinstance(pol, dict):
        transport = bool(pol.get("transport", pol.get("tally", "none") != "none"))
        tally = str(pol.get("tally", "none"))
        incident = _incident_stokes(pol.get("incident_stokes") or pol.get("incident", "unpolarised"))
    elif isinstance(pol, str):  # the Mitsuba tracer: its tally is its transport
        tally, transport = pol, pol != "none"
        incident = _incident_stokes(raw.get("incident_stokes", "unpolarised"))
    else:
        tally, transport, incident = "none", False, [1.0, 0.0, 0.0, 0.0]
    if transport:
        label = tally if tally != "none" else "polarised (no tally)"
    else:
        label = "none"
    incidences = [(e.theta_deg, e.phi_deg) for e in s.incidence]
    return {
        "program": program, "transport": "polarised" if transport else "scalar", "tally": tally,
        "polarisation": label, "incident": incident if transport else None,
        "wavelengths": list(s.wavelengths_um or []), "material": raw.get("material"),
        "bands": s.bands, "symmetry": s.symmetry, "incidences": incidences,
        "azimuths": sorted(set(p for _, p in incidences)),
        "content": (s.content.scene_sha256 if s.content is not None else None),
    }


def _show(v) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(_show(x) for x in v) + "]" if v else "none"
    if isinstance(v, tuple):
        return "/".join(f"{x:g}" for x in v)
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, dict):
        return ",".join(f"{k}:{_show(x)}" for k, x in v.items())
    return str(v)


def description_differences(da: dict, db: dict) -> list[tuple[str, str, str]]:
    """(key, value of A, value of B) for every difference of two
    descriptions (`describe`), in the order of `TRACED`, then incidences and
    azimuths; keys one side does not record are skipped."""
    out = []
    if da["polarisation"] != db["polarisation"] and (da["transport"] != db["transport"]):
        out.append(("polarisation", da["polarisation"], db["polarisation"]))
    if (da["transport"] == db["transport"] == "polarised" and da["incident"] is not None
            and db["incident"] is not None and not np.allclose(da["incident"], db["incident"], atol=1e-9)):
        out.append(("incident polarisation", _show(da["incident"]), _show(db["incident"])))
    if (len(da["wavelengths"]) != len(db["wavelengths"])
            or not np.allclose(da["wavelengths"], db["wavelengths"], rtol=1e-12, atol=0)):
        out.append(("wavelengths", _show(da["wavelengths"]) if da["wavelengths"] else "monochrome",
                    _show(db["wavelengths"]) if db["wavelengths"] else "monochrome"))
    for key in ("material", "bands", "symmetry"):
        if da[key] is not None and db[key] is not None and da[key] != db[key]:
            out.append((key, _show(da[key]), _show(db[key])))
    one = len(da["azimuths"]) == 1 and da["azimuths"] == db["azimuths"]
    for key in ("incidences", "azimuths"):
        a, b = set(da[key]), set(db[key])
        if a != b:
            if key == "incidences" and one:  # one and the same azimuth: the angles say it
                a, b = {t for t, _ in a}, {t for t, _ in b}
            out.append((key, _show(sorted(a - b)) if a - b else "-", _show(sorted(b - a)) if b - a else "-"))
    return out


def sides(da: dict, db: dict) -> tuple[str, str]:
    """The names of the two sides: the programs that wrote them, or A and B."""
    return (da["program"], db["program"]) if da["program"] != db["program"] else ("A", "B")


def differences_line(diffs: list[tuple[str, str, str]], names: tuple[str, str]) -> str | None:
    """`descriptions differ: KEY A=... vs B=...; ...` (incidences and
    azimuths: those on one side only), or None."""
    if not diffs:
        return None
    parts = []
    for key, a, b in diffs:
        if key in ("incidences", "azimuths"):
            parts.append(f"{key} only in {names[0]}: {a}, only in {names[1]}: {b} (not compared)")
        else:
            parts.append(f"{key} {names[0]}={a} vs {names[1]}={b}")
    return "descriptions differ: " + "; ".join(parts)


def compare(dir_a: Path, dir_b: Path) -> list[dict]:
    """One dict per incidence (angle and light azimuth) present in both folders."""
    sa, ca = load_incidences(Path(dir_a))
    sb, cb = load_incidences(Path(dir_b))
    rows = []
    for th in sorted(set(sa) & set(sb) & set(ca) & set(cb)):
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
            "theta": th[0], "phi": th[1], "r_a": ea["reflectance"], "se_a": ea["reflectance_stderr"],
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
    """(mode, component names, {(theta, phi): {(band, cell): (values, stderrs)}}) of stokes.csv or
    mueller.csv in folder d, or None when it has neither."""
    t = PolarTable.find(d)
    if t is None:
        return None
    phis = list(dict.fromkeys(t.phi_i_deg.tolist()))
    cells = {(th, phi): c for phi in phis for th, c in t.cells(phi if len(phis) > 1 else None).items()}
    return t.mode, list(t.names), cells


def compare_polarised(dir_a: Path, dir_b: Path, min_signal: float = 0.1) -> list[dict]:
    """One dict per incidence angle present in both folders' stokes.csv (or mueller.csv);
    [] when they do not both hold the same kind (see the module docs)."""
    pa, pb = load_polar(dir_a), load_polar(dir_b)
    if pa is None or pb is None or pa[0] != pb[0]:
        return []
    mode, names, ca = pa
    cb = pb[2]
    sa = {(e.theta_deg, e.phi_deg): e for e in _summary(Path(dir_a)).incidence}
    sb = {(e.theta_deg, e.phi_deg): e for e in _summary(Path(dir_b)).incidence}
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
            "theta": th[0], "phi": th[1], "mode": mode, "names": names,
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


def _angle(r: dict, several: bool) -> str:
    """theta, or theta/phi when the rows have light azimuths other than 0."""
    return f"{r['theta']:g}/{r['phi']:g}" if several else f"{r['theta']:g}"


def _several(rows: list[dict]) -> bool:
    return any(r.get("phi", 0.0) != 0.0 for r in rows)


def table_polarised(rows: list[dict]) -> str:
    several = _several(rows)
    out = [f"{'theta' if not several else 'th/phi':>6} {'kind':>7} {'max|z| R':>9} {'cells':>6} {'terms':>6} {'chi2/dof':>9} "
           f"{'worst chi2 z':>12} {'max|z|':>7} {'exact':>6}"]
    for r in rows:
        worst = max(r["chi2_z_by"], key=r["chi2_z_by"].get)
        out.append(f"{_angle(r, several):>6} {r['mode']:>7} {r['max_refl_z']:9.2f} {r['cells']:6d} {r['terms']:6d} "
                   f"{r['chi2_dof']:9.3f} {r['chi2_z_by'][worst]:6.2f} {worst:>5} {r['max_cell_z']:7.2f} "
                   f"{r['exact'] - r['exact_bad']:>3d}/{r['exact']:<2d}{'' if r['pass'] else '  FAIL'}")
    return "\n".join(out)


def table(rows: list[dict]) -> str:
    several = _several(rows)
    out = [f"{'theta' if not several else 'th/phi':>6} {'R_a':>10} {'R_b':>10} {'z':>7} {'cells':>6} {'chi2/dof':>9} {'max|z|':>7} {'exact':>6}"]
    for r in rows:
        out.append(f"{_angle(r, several):>6} {r['r_a']:10.6f} {r['r_b']:10.6f} {r['z']:7.2f} {r['cells']:6d} "
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
    """Print the comparison of folders a.a and a.b: the differences of their
    run descriptions first, then the statistics; 0 if it passes, else 1
    (a difference in what is traced is a FAIL naming it)."""
    da, db = describe(a.a), describe(a.b)
    names = sides(da, db)
    diffs = description_differences(da, db)
    line = differences_line(diffs, names)
    if line:
        print(line)
    unlike = [k for k, _, _ in diffs if k in TRACED]
    rows = compare(a.a, a.b)
    print(table(rows))
    for r in rows:
        advice = None if unlike else sparse_advice(r)
        if advice:
            print(advice)
    stats_ok = bool(rows) and all(r["pass"] for r in rows)
    prow = compare_polarised(a.a, a.b, a.min_signal)
    if prow:
        print(table_polarised(prow))
        stats_ok = stats_ok and all(r["pass"] for r in prow)
    elif any((Path(d) / f).is_file() for d in (a.a, a.b) for f in POLAR_FILES.values()):
        print("polarised tallies not compared: the folders do not both hold stokes.csv or both mueller.csv")
    if unlike:
        stats = "the statistics pass" if stats_ok else "the statistics fail"
        print(f"verdict: FAIL: the runs are not alike: {', '.join(unlike)} "
              f"({'; '.join(f'{names[0]}={x} vs {names[1]}={y}' for k, x, y in diffs if k in TRACED)}); "
              f"{stats}, but they compare different runs: trace both alike")
        return 1
    if not rows:
        print("verdict: FAIL: no incidence (angle and light azimuth) in both folders")
        return 1
    print("verdict:", "pass" if stats_ok else "FAIL")
    return 0 if stats_ok else 1


if __name__ == "__main__":
    sys.exit(main())
