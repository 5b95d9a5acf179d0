"""Spectral cross-check of roks against Mitsuba 3 with Mitsuba's own gold.

    .venv/bin/python scripts/spectral_crosscheck.py [--out spectral_crosscheck] [--theta 0,50]
        [--wavelengths 0.45,0.55,0.65] [--colour-wavelengths 0.38:0.78:0.02]
        [--photons 200000] [--roks-photons 400000] [--resolution 64] [--bands 8]
        [--roks target/release/roks] [--variant auto|llvm|scalar]

A periodic Gaussian height field of gold (sigma 1, tau 5 on a 32 x 32 cell,
`--resolution` grid squares per side) is traced twice per wavelength set:

* by `roks brdf` on the exact field, material `nk = ` Mitsuba's own
  `data/ior/Au.eta.spd` + `Au.k.spd` (roks reads the pair), wavelengths by
  `[light] wavelengths_um`;
* by the Mitsuba tracer (`roks_tools.mitsuba.tracer`) on the mesh `roks
  export-mesh` writes of the same field (exact: the field is its triangles),
  with `--material Au`: Mitsuba's conductor preset, i.e. Mitsuba's own n, k
  data, interpolated by Mitsuba at each wavelength. The wavelengths are fixed
  (Mitsuba's spectral variants draw them at random): the tracer sets
  `si.wavelengths` itself.

Two pairs (the physics must match on both sides):

* polarised: roks's default transport (Stokes vectors through every Fresnel
  bounce, unpolarised light) against the tracer in
  `llvm_ad_spectral_polarized` (a Stokes vector per wavelength, Mitsuba's
  `mueller.specular_reflection` with Mitsuba's n, k and its
  `rotate_stokes_basis`), at `--wavelengths` and on the `--colour-wavelengths`
  grid;
* unpolarised: `roks brdf --no-polarisation` ((Rs + Rp)/2 per bounce)
  against the tracer in `llvm_ad_spectral`, whose weight per hit is
  Mitsuba's `conductor` plugin itself (`bsdf.sample`, fresnel_conductor), at
  `--wavelengths`.

Checks (each must pass): per incidence and wavelength, the hemispherical
reflectance: |z| <= 4 (z = difference / combined standard error; nothing is
lost on either side here, else the gap between [R, R + lost] is used);
with the colour grid, per Carlson cell with signal (Y's relative standard
error <= 0.2 on both sides), the CIE XYZ of the BRDF under D65 computed
here (`roks_tools.colour`, colour-science's tables, not roks's Rust colour)
from each side's per-wavelength cell fractions: every |z| of X, Y and Z
<= `cell_z_limit` (4, plus the Bonferroni allowance for the number of
comparisons), the standard error of a colour being the bound sum_l |w_l|
se_l (the wavelengths share their photons: exact for fully correlated lanes,
an upper bound always). The chi-square per degree of freedom of the cells is
reported (below 1 by that bound).

Gold data: Mitsuba's Au is the Luxpop table (after Palik's handbook; PBRT's
data, conductor.cpp docs); scenes/materials/gold.csv is Johnson & Christy
(1972). The report tabulates both n, k and the normal-incidence reflectance
per wavelength: they differ far beyond the noise, which is why the
cross-check gives roks Mitsuba's pair, and gold.csv is used elsewhere. A
negative control runs roks with gold.csv against the same Mitsuba run and
must fail.

Writes OUT/report.md and OUT/spectral_crosscheck.json; exit 1 on FAIL. Work
files go to OUT/runs (removed unless --keep-runs).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np

from roks_tools import colour as pc
from roks_tools.errors import RunError, UsageError, command
from roks_tools.results import SPECTRAL_BRDF_COLUMNS, read_columns
from roks_tools.runner import add_out_argument, check_output, repo_root, run as run_cmd
from roks_tools.stats import cell_z_limit, gap

ROOT = repo_root()
GOLD_CSV = ROOT / "scenes" / "materials" / "gold.csv"


def mitsuba_ior_dir() -> Path:
    """Mitsuba's data/ior folder (found without importing mitsuba's variants)."""
    import importlib.util

    spec = importlib.util.find_spec("mitsuba")
    if spec is None or spec.origin is None:
        raise RunError("mitsuba is not installed (scripts/setup_venv.sh)")
    return Path(spec.origin).resolve().parent / "data" / "ior"


def scene_text(nk: Path, wavelengths: str, thetas: list[float], photons: int, bands: int,
               resolution: int, seed: int) -> str:
    if ":" in wavelengths:
        a, b, s = (float(x) for x in wavelengths.split(":"))
        wl = f"{{ from = {a!r}, to = {b!r}, step = {s!r} }}"
    else:
        wl = "[" + ", ".join(repr(float(x)) for x in wavelengths.split(",")) + "]"
    return f"""# spectral cross-check: a Gaussian field of gold (written by roks_tools.studies.spectral_crosscheck)
[surface]
size = [32.0, 32.0]
edges = "periodic"
material = "au"
heightfield = {{ gaussian = {{ sigma = 1.0, tau = 5.0 }}, resolution = {resolution}, seed = 3 }}

[materials.au]
nk = "{nk}"

[light]
theta_deg = [{", ".join(repr(float(t)) for t in thetas)}]
photons = {photons}
seed = {seed}
wavelengths_um = {wl}

[tally]
bands = {bands}
"""


def load_side(folder: Path) -> dict:
    """summary spectrum and brdf.csv cells of a spectral folder:
    {theta: {"wl": [...], "R": [...], "se": [...], "lost": [...], "f": (L, cells), "fe": (L, cells), "proj": (cells,)}}"""
    summary = json.loads((folder / "summary.json").read_text())
    cols = read_columns(folder / "brdf.csv", SPECTRAL_BRDF_COLUMNS)
    out = {}
    for e in summary["incidence"]:
        th = float(e["theta_deg"])
        wl = [s["wavelength_um"] for s in e["spectrum"]]
        sel = np.abs(cols["theta_i_deg"] - th) < 1e-9
        f, fe = [], []
        for w in wl:
            m = sel & (np.abs(cols["wavelength_um"] - w) < 1e-9)
            f.append(cols["fraction"][m])
            fe.append(cols["fraction_stderr"][m])
            proj = cols["projected_solid_angle_sr"][m]
        out[th] = {"wl": np.array(wl), "R": np.array([s["reflectance"] for s in e["spectrum"]]),
                   "se": np.array([s["reflectance_stderr"] for s in e["spectrum"]]),
                   "lost": np.array([s["lost"] for s in e["spectrum"]]),
                   "f": np.array(f), "fe": np.array(fe), "proj": proj}
    return out


def compare_reflectance(a: dict, b: dict) -> list[dict]:
    rows = []
    for th in sorted(a):
        A, B = a[th], b[th]
        if not np.allclose(A["wl"], B["wl"], atol=1e-9):
            raise RunError(f"theta {th}: the two runs have other wavelengths")
        for l, w in enumerate(A["wl"]):
            d = gap(A["R"][l], A["lost"][l], B["R"][l], B["lost"][l])
            se = math.hypot(A["se"][l], B["se"][l])
            z = d / se if se > 0 else (0.0 if d == 0 else math.inf)
            rows.append({"theta": th, "wavelength_um": float(w), "roks": float(A["R"][l]),
                         "roks_se": float(A["se"][l]), "mitsuba": float(B["R"][l]),
                         "mitsuba_se": float(B["se"][l]), "diff": float(d), "z": float(z),
                         "pass": bool(abs(z) <= 4.0)})
    return rows


def compare_colour(a: dict, b: dict, min_signal: float = 0.2) -> list[dict]:
    """Per incidence: XYZ of the BRDF per Carlson cell from both sides' per-wavelength fractions."""
    rows = []
    for th in sorted(a):
        A, B = a[th], b[th]
        wl = A["wl"]
        cells = {}
        for name, side in (("a", A), ("b", B)):
            brdf = side["f"] / side["proj"][None, :]
            brdf_se = side["fe"] / side["proj"][None, :]
            cells[name] = (pc.xyz(wl, brdf.T), pc.xyz_stderr_bound(wl, brdf_se.T))  # (cells, 3)
        (xa, sa), (xb, sb) = cells["a"], cells["b"]
        signal = (xa[:, 1] > 0) & (xb[:, 1] > 0) & (sa[:, 1] <= min_signal * xa[:, 1]) & (sb[:, 1] <= min_signal * xb[:, 1])
        se = np.hypot(sa, sb)[signal]
        z = (xa - xb)[signal] / se
        n = int(z.size)
        limit = cell_z_limit(n)
        chi2 = float(np.sum(z * z) / n) if n else 0.0
        # colour of the whole hemisphere (the reflectance spectrum), from the summaries
        xr_a, xr_b = pc.xyz(wl, A["R"]), pc.xyz(wl, B["R"])
        sr = np.hypot(pc.xyz_stderr_bound(wl, A["se"]), pc.xyz_stderr_bound(wl, B["se"]))
        zr = (xr_a - xr_b) / sr
        rows.append({"theta": th, "cells": int(signal.sum()), "skipped": int((~signal & ((xa[:, 1] > 0) | (xb[:, 1] > 0))).sum()),
                     "chi2_dof": chi2, "max_z": float(np.max(np.abs(z))) if n else 0.0, "limit": limit,
                     "hemisphere_xyz_roks": xr_a.tolist(), "hemisphere_xyz_mitsuba": xr_b.tolist(),
                     "hemisphere_srgb_roks": pc.linear_srgb(xr_a).tolist(),
                     "hemisphere_srgb8_roks": pc.srgb8(pc.linear_srgb(xr_a)).tolist(),
                     "hemisphere_z": zr.tolist(),
                     "pass": bool(n > 0 and float(np.max(np.abs(z))) <= limit and np.all(np.abs(zr) <= 4.0))})
    return rows


def gold_data_table(ior: Path, wavelengths: list[float]) -> list[dict]:
    eta, k = pc.read_spd(ior / "Au.eta.spd"), pc.read_spd(ior / "Au.k.spd")
    jc = pc.read_nk_csv(GOLD_CSV)
    rows = []
    for w in wavelengths:
        nm_ = float(np.interp(1000 * w, eta[:, 0], eta[:, 1]))
        km = float(np.interp(1000 * w, k[:, 0], k[:, 1]))
        nj = float(np.interp(w, jc[:, 0], jc[:, 1]))
        kj = float(np.interp(w, jc[:, 0], jc[:, 2]))
        rm, rj = float(pc.fresnel_normal(nm_, km)), float(pc.fresnel_normal(nj, kj))
        rows.append({"wavelength_um": w, "n_mitsuba": nm_, "k_mitsuba": km, "n_jc": nj, "k_jc": kj,
                     "R0_mitsuba": rm, "R0_jc": rj})
    return rows


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_out_argument(ap, "spectral_crosscheck")
    ap.add_argument("--theta", default="0,50")
    ap.add_argument("--wavelengths", default="0.45,0.55,0.65")
    ap.add_argument("--colour-wavelengths", default="0.38:0.78:0.02",
                    help="FROM:TO:STEP (um) covering 0.38-0.78 for the colour check; empty: none")
    ap.add_argument("--photons", type=int, default=200_000, help="Mitsuba photons per angle")
    ap.add_argument("--roks-photons", type=int, default=400_000)
    ap.add_argument("--resolution", type=int, default=64, help="grid squares per side of the field")
    ap.add_argument("--bands", type=int, default=8)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--roks", type=Path, default=None, help="roks binary (default: $ROKS_BIN or target/release/roks)")
    ap.add_argument("--variant", default="auto", choices=("auto", "llvm", "scalar"))
    ap.add_argument("--keep-runs", action="store_true")
    ap.add_argument("-q", "--quiet", action="store_true")
    a = ap.parse_args(argv)
    check_output(a.out, a.overwrite_committed)
    a.thetas = [float(x) for x in a.theta.split(",") if x.strip()]
    return a


@command("spectral_crosscheck")
def main(argv=None) -> int:
    from roks_tools.runner import roks_binary

    a = parse_args(argv)
    roks = a.roks or roks_binary()
    if not Path(roks).is_file():
        raise UsageError(f"{roks} not found: build it with `cargo build --release`")
    out, work = a.out, a.out / "runs"
    work.mkdir(parents=True, exist_ok=True)
    ior = mitsuba_ior_dir()
    seconds: dict[str, float] = {}

    def step(name, cmd):
        seconds[name] = run_cmd(cmd, f"spectral_crosscheck: step '{name}'", echo=not a.quiet).wall_s

    theta = ",".join(f"{t:g}" for t in a.thetas)
    sets = [("few", a.wavelengths)] + ([("colour", a.colour_wavelengths)] if a.colour_wavelengths else [])
    mesh = work / "mesh.ply"
    first = work / "scene_few.toml"
    first.write_text(scene_text(ior / "Au.eta.spd", a.wavelengths, a.thetas, a.roks_photons, a.bands,
                                a.resolution, a.seed))
    step("export-mesh", [roks, "export-mesh", first, "--out", mesh])
    py = sys.executable
    res: dict = {"thetas": a.thetas, "photons": a.photons, "roks_photons": a.roks_photons,
                 "resolution": a.resolution, "bands": a.bands, "pairs": {}}
    folders = {}
    for key, wl in sets:
        scene = work / f"scene_{key}.toml"
        scene.write_text(scene_text(ior / "Au.eta.spd", wl, a.thetas, a.roks_photons, a.bands, a.resolution, a.seed))
        pols = [("polarised", [], ["--polarisation", "stokes"])]
        if key == "few":
            pols.append(("unpolarised", ["--no-polarisation"], []))
        for pol, roks_extra, mi_extra in pols:
            r_dir, m_dir = work / f"roks_{key}_{pol}", work / f"mitsuba_{key}_{pol}"
            step(f"roks brdf {key} {pol}", [roks, "brdf", scene, "--out", r_dir, "-q", *roks_extra])
            step(f"mitsuba {key} {pol}",
                 [py, "-m", "roks_tools.mitsuba.tracer", mesh, "--size", "32,32", "--theta", theta,
                  "--photons", a.photons, "--seed", a.seed + 1000, "--bands", a.bands, "--material", "Au",
                  "--wavelengths", wl, "--variant", a.variant, "--out", m_dir, "-q", *mi_extra])
            folders[(key, pol)] = (r_dir, m_dir)
    # negative control: roks with Johnson & Christy's gold against Mitsuba's Au
    ctrl = work / "scene_control.toml"
    ctrl.write_text(scene_text(GOLD_CSV, a.wavelengths, a.thetas, a.roks_photons, a.bands, a.resolution, a.seed))
    step("roks brdf control (gold.csv)", [roks, "brdf", ctrl, "--out", work / "roks_control", "-q"])

    overall = True
    for (key, pol), (r_dir, m_dir) in folders.items():
        ra, mb = load_side(r_dir), load_side(m_dir)
        variant = json.loads((m_dir / "summary.json").read_text())["variant"]
        entry = {"variant": variant, "reflectance": compare_reflectance(ra, mb)}
        ok = all(r["pass"] for r in entry["reflectance"])
        if key == "colour":
            entry["colour"] = compare_colour(ra, mb)
            ok &= all(r["pass"] for r in entry["colour"])
        entry["pass"] = ok
        overall &= ok
        res["pairs"][f"{key}_{pol}"] = entry
    control = compare_reflectance(load_side(work / "roks_control"), load_side(folders[("few", "polarised")][1]))
    res["control"] = {"reflectance": control, "fails": not all(r["pass"] for r in control)}
    overall &= res["control"]["fails"]
    wls = sorted({r["wavelength_um"] for r in res["pairs"]["few_polarised"]["reflectance"]})
    res["gold_data"] = gold_data_table(ior, wls)
    res["seconds"] = seconds
    res["verdict"] = "PASS" if overall else "FAIL"
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.md").write_text(report(res, a))
    (out / "spectral_crosscheck.json").write_text(json.dumps(res, indent=1, sort_keys=True))
    if not a.keep_runs:
        shutil.rmtree(work)
    print(f"spectral_crosscheck: {res['verdict']}: report in {out / 'report.md'}")
    return 0 if overall else 1


def report(res: dict, a) -> str:
    L = ["# Spectral cross-check: roks vs Mitsuba 3 with Mitsuba's own gold", "",
         f"**Verdict: {res['verdict']}**", "",
         f"Gaussian height field of gold (sigma 1, tau 5, 32 x 32 cell, {a.resolution}^2 grid squares; "
         f"Mitsuba traces the exact mesh of `roks export-mesh`), incidence {a.theta} deg, {a.bands} Carlson bands; "
         f"roks {a.roks_photons:,} photons per angle, Mitsuba {a.photons:,}. Both use Mitsuba's Au n, k "
         "(roks: `nk = \".../mitsuba/data/ior/Au.eta.spd\"`; Mitsuba: `conductor` preset `Au`). "
         "z = (roks - Mitsuba) / combined standard error.", ""]
    for name, e in res["pairs"].items():
        L += [f"## {name.replace('_', ', ')} (Mitsuba {e['variant']}): **{'PASS' if e['pass'] else 'FAIL'}**", ""]
        if name.startswith("few") or len(e["reflectance"]) <= 12:
            L += ["| theta | wavelength (um) | roks R | Mitsuba R | difference | z |", "|---:|---:|---:|---:|---:|---:|"]
            for r in e["reflectance"]:
                L.append(f"| {r['theta']:g} | {r['wavelength_um']:g} | {r['roks']:.5f} ± {r['roks_se']:.5f} "
                         f"| {r['mitsuba']:.5f} ± {r['mitsuba_se']:.5f} | {r['diff']:+.5f} | {r['z']:+.2f} |")
        else:
            zs = np.array([r["z"] for r in e["reflectance"]])
            L += [f"Reflectance at {len(zs)} (theta, wavelength) pairs: max |z| {np.max(np.abs(zs)):.2f}, "
                  f"mean z^2 {np.mean(zs ** 2):.2f}.", ""]
        L.append("")
        for c in e.get("colour", []):
            L += [f"Colour, theta {c['theta']:g} deg: {c['cells']} cells with signal (+{c['skipped']} sparse), "
                  f"XYZ chi2/dof {c['chi2_dof']:.3f} (bounded errors), max |z| {c['max_z']:.2f} (limit {c['limit']:.2f}); "
                  f"hemisphere XYZ roks {np.round(c['hemisphere_xyz_roks'], 5).tolist()} vs Mitsuba "
                  f"{np.round(c['hemisphere_xyz_mitsuba'], 5).tolist()} (z {np.round(c['hemisphere_z'], 2).tolist()}), "
                  f"sRGB8 {c['hemisphere_srgb8_roks']}: **{'pass' if c['pass'] else 'FAIL'}**", ""]
    L += ["## Gold data: Mitsuba's Au vs scenes/materials/gold.csv", "",
          "Mitsuba's `Au` (data/ior/Au.eta.spd, Au.k.spd): the Luxpop table, after Palik's handbook "
          "(the data PBRT ships; conductor.cpp docs). gold.csv: Johnson & Christy 1972. Both linearly "
          "interpolated; R0 = normal-incidence reflectance.", "",
          "| wavelength (um) | n Mitsuba | k Mitsuba | n J&C | k J&C | R0 Mitsuba | R0 J&C | R0 difference |",
          "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for g in res["gold_data"]:
        L.append(f"| {g['wavelength_um']:g} | {g['n_mitsuba']:.4f} | {g['k_mitsuba']:.4f} | {g['n_jc']:.4f} "
                 f"| {g['k_jc']:.4f} | {g['R0_mitsuba']:.4f} | {g['R0_jc']:.4f} | {g['R0_jc'] - g['R0_mitsuba']:+.4f} |")
    c = res["control"]
    zs = [r["z"] for r in c["reflectance"]]
    L += ["", f"Negative control: roks with gold.csv (J&C) against Mitsuba's Au run: |z| up to "
          f"{max(abs(z) for z in zs):.0f}: {'fails, as it must' if c['fails'] else 'PASSES: the check has no power'}.", "",
          "## Wall time of each step (s)", "", "| step | s |", "|---|---:|"]
    L += [f"| {k} | {v:.1f} |" for k, v in res["seconds"].items()]
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    sys.exit(main())
