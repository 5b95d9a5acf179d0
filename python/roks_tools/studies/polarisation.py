"""How much polarised transport changes the BRDF of the Fresnel scenes in scenes/.

    .venv/bin/python scripts/polarisation_study.py [--roks target/release/roks] [--photons N]

For every micro scene with a Fresnel material (gaussian.toml, gaussian-rough.toml,
z302-micro.toml) runs `roks brdf` twice with the same photons: with polarised
transport (the default for Fresnel materials: a Stokes vector through every
bounce, seed 1) and with `--no-polarisation` (the unpolarised weight (Rs + Rp)/2
per bounce, seed 2, so the runs are independent). Reports per incidence the two
reflectances with their difference in standard errors (root sum of squares), the
relative change of the part reflected after two or more bounces, and chi2/dof of
the Carlson cells between the two (cells lit in both): near 1 where polarisation
changes nothing detectable. Also writes the degree-of-polarisation map of gaussian-rough.toml
at 60 degrees (`--polarisation stokes`).

Writes OUT/report.md, report.json and dop_gaussian-rough_60deg.png (--out, default
./polarisation; the repository's results/polarisation with --overwrite-committed).
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np

from roks_tools.errors import command
from roks_tools.results import read_columns
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run

REPO = repo_root()

SCENES = ["gaussian.toml", "gaussian-rough.toml", "z302-micro.toml"]
THETAS = "0,30,60,80"


def brdf(roks: str, scene: str, out: Path, photons: int, extra: list[str]) -> tuple[dict, dict]:
    run([roks, "brdf", REPO / "scenes" / scene, "--theta", THETAS, "--photons", photons,
         "--out", out, "-q", *extra], "polarisation_study")
    return json.loads((out / "summary.json").read_text()), read_columns(out / "brdf.csv")


def compare(pol: tuple[dict, dict], unp: tuple[dict, dict]) -> list[dict]:
    rows = []
    (sp, cp), (su, cu) = pol, unp
    for ip, iu in zip(sp["incidence"], su["incidence"]):
        theta = ip["theta_deg"]
        rp, ep, ru, eu = ip["reflectance"], ip["reflectance_stderr"], iu["reflectance"], iu["reflectance_stderr"]
        multi_p = rp - ip["reflectance_by_bounces"][1]
        multi_u = ru - iu["reflectance_by_bounces"][1]
        sel_p, sel_u = cp["theta_i_deg"] == theta, cu["theta_i_deg"] == theta
        fp, fep = cp["fraction"][sel_p], cp["fraction_stderr"][sel_p]
        fu, feu = cu["fraction"][sel_u], cu["fraction_stderr"][sel_u]
        ok = (fp > 0) & (fu > 0) & (fep > 0) & (feu > 0)
        chi2 = float(np.sum((fp[ok] - fu[ok]) ** 2 / (fep[ok] ** 2 + feu[ok] ** 2)))
        rows.append({
            "theta_deg": theta,
            "reflectance_polarised": rp, "stderr_polarised": ep,
            "reflectance_unpolarised": ru, "stderr_unpolarised": eu,
            "relative_change": rp / ru - 1 if ru > 0 else 0.0,
            "z": (rp - ru) / max(np.hypot(ep, eu), 1e-300),
            "multiple_polarised": multi_p, "multiple_unpolarised": multi_u,
            "multiple_relative_change": multi_p / multi_u - 1 if multi_u > 0 else 0.0,
            "cells": int(ok.sum()), "chi2_per_dof": chi2 / max(int(ok.sum()), 1),
        })
    return rows


@command("polarisation_study")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", default=str(default_roks()))
    ap.add_argument("--photons", type=int, default=1_000_000)
    add_out_argument(ap, "polarisation")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    work = REPO / "out" / "polarisation_study"
    res = a.out
    res.mkdir(parents=True, exist_ok=True)
    report = {"photons": a.photons, "scenes": {}}
    lines = [
        "# Polarised against unpolarised transport (roks brdf)",
        "",
        f"`scripts/polarisation_study.py --photons {a.photons}`: each scene with polarised transport "
        "(default for Fresnel materials, seed 1) and with `--no-polarisation` (seed 2, independent). "
        "`multi` is the reflectance carried by paths of two or more bounces (the part "
        "polarisation changes); z = difference / root sum of squares of the standard errors; "
        "chi2/dof over the Carlson cells lit in both.",
        "",
    ]
    for scene in SCENES:
        stem = Path(scene).stem
        pol = brdf(a.roks, scene, work / f"{stem}-pol", a.photons, [])
        # Another seed: the two runs are independent, so z and chi2 use the
        # root sum of squares of their errors honestly.
        unp = brdf(a.roks, scene, work / f"{stem}-unpol", a.photons, ["--no-polarisation", "--seed", "2"])
        rows = compare(pol, unp)
        report["scenes"][scene] = rows
        lines += [f"## {scene}", "",
                  "| theta_i | R polarised | R unpolarised | change | z | multi pol. | multi unpol. | multi change | cells | chi2/dof |",
                  "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in rows:
            lines.append(
                f"| {r['theta_deg']:g} | {r['reflectance_polarised']:.5f} ± {r['stderr_polarised']:.1e} "
                f"| {r['reflectance_unpolarised']:.5f} ± {r['stderr_unpolarised']:.1e} "
                f"| {100 * r['relative_change']:+.2f} % | {r['z']:+.1f} "
                f"| {r['multiple_polarised']:.5f} | {r['multiple_unpolarised']:.5f} "
                f"| {100 * r['multiple_relative_change']:+.1f} % | {r['cells']} | {r['chi2_per_dof']:.2f} |")
        lines.append("")
    dop = work / "gaussian-rough-stokes"
    run([a.roks, "brdf", REPO / "scenes" / "gaussian-rough.toml", "--theta", "60", "--photons",
         a.photons, "--polarisation", "stokes", "--out", dop, "-q"], "polarisation_study")
    shutil.copy(dop / "dop_60deg.png", res / "dop_gaussian-rough_60deg.png")
    s = json.loads((dop / "summary.json").read_text())["incidence"][0]
    st, se = s["reflected_stokes"], s["reflected_stokes_stderr"]
    report["gaussian-rough_60deg_reflected_stokes"] = {"stokes": st, "stderr": se}
    lines += ["## Stokes picture of rough aluminium (gaussian-rough.toml, 60 deg, unpolarised light)", "",
              "Reflected Stokes vector per unit incident power (each photon in its own direction's frame): "
              + ", ".join(f"S{i} = {v:.5f} ± {e:.1e}" for i, (v, e) in enumerate(zip(st, se))), "",
              "![degree of polarisation](dop_gaussian-rough_60deg.png)", ""]
    (res / "report.md").write_text("\n".join(lines))
    (res / "report.json").write_text(json.dumps(report, indent=1) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
