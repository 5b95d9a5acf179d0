"""Gaussian height fields in roks against microfacet theory.

For Gaussian random surfaces (autocorrelation sigma^2 exp(-r^2 / tau^2), Beckmann
alpha = 2 sigma / tau) with a white material (rho = 1), compares roks with the
Beckmann + Smith microfacet model of `roks_tools.microfacet`:

(a) single-bounce albedo (reflectance_by_bounces[1]; with rho = 1 every photon
    leaves, so 1 - it is the multiple-scattering share) vs height-correlated and
    uncorrelated Smith, with the nominal alpha, with the alpha measured from the
    traced triangles, and with the triangles' own slope distribution (empirical
    D and Lambda: this isolates Smith's independence assumptions from the
    slope distribution);
(b) the single-bounce BRDF (a max_bounces = 1 run: photons are cut at their 2nd
    hit) cell by cell on the Carlson grid and in the plane of incidence;
(c) the multiple-scattering share and its split by order vs the random walk of
    Heitz et al. 2016 on the Smith microsurface.

Fields: periodic, 512 x 512 grid squares of pitch 1, tau = 12 pitches (cell = 43 tau;
the k = 0 share of the power missing from a periodic cell is pi tau^2 / L^2 = 0.2 %),
sigma = 0.1, 0.25, 0.5 tau; seeds 1 and 2; plus tau = 6 pitches for alpha = 0.5
(sampling of the field). Writes OUT/report.md, OUT/*.png, OUT/data.json; roks
output folders go to OUT/runs/ (deleted unless --keep-runs).

    .venv/bin/python scripts/microfacet_study.py --roks $CARGO_TARGET_DIR/release/roks
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roks_tools import microfacet as mf
from roks_tools.errors import RunError, command
from roks_tools.results import read_columns
from roks_tools.runner import add_out_argument, check_output, default_roks, run as run_cmd

WHO = "microfacet_study"

THETAS = [0, 10, 20, 30, 40, 50, 60, 70, 80]
N = 512          # grid squares per side, pitch 1
CASES = [        # (label, sigma/tau, tau in pitches, seed)
    ("a0.2", 0.1, 12.0, 1),
    ("a0.5", 0.25, 12.0, 1),
    ("a1.0", 0.5, 12.0, 1),
    ("a0.2-s2", 0.1, 12.0, 2),
    ("a0.5-s2", 0.25, 12.0, 2),
    ("a1.0-s2", 0.5, 12.0, 2),
    ("a0.5-tau6", 0.25, 6.0, 1),
]
MAIN = ["a0.2", "a0.5", "a1.0"]
COL = {"a0.2": "tab:blue", "a0.5": "tab:green", "a1.0": "tab:red"}


def scene_text(label: str, s_over_t: float, tau: float, seed: int, photons: int,
               max_bounces: int | None) -> str:
    tr = f"\n[transport]\nmax_bounces = {max_bounces}\n" if max_bounces else ""
    return f"""# microfacet_study.py: Gaussian field, sigma/tau = {s_over_t}, alpha = {2 * s_over_t}
name = "mf-{label}"

[surface]
size = [{float(N)}, {float(N)}]
edges = "periodic"
material = "white"
heightfield = {{ gaussian = {{ sigma = {s_over_t * tau}, tau = {tau} }}, resolution = {N}, seed = {seed} }}

[materials.white]
reflectance = 1.0

[light]
theta_deg = {THETAS}
phi_deg = 0.0
photons = {photons}
seed = 1

[tally]
bands = 24
{tr}"""


def measure_case(roks: str, runs: Path, label: str, s_over_t: float, tau: float, seed: int,
                 photons: int, single_photons: int, brdf: bool) -> dict:
    d = runs / label
    d.mkdir(parents=True, exist_ok=True)
    full = d / "full.toml"
    full.write_text(scene_text(label, s_over_t, tau, seed, photons, None))
    stats = json.loads(run_cmd([roks, "stats", str(full), "--json"], WHO).stdout)
    run_cmd([roks, "export-heightfield", str(full), "--out", str(d / "map.txt")], WHO)
    h = np.loadtxt(d / "map.txt")
    slopes = mf.heightfield_slopes(h)
    alpha_tri = math.sqrt(float(np.mean(np.sum(slopes**2, axis=1))))
    run_cmd([roks, "brdf", str(full), "--out", str(d / "full"), "-q"], WHO)
    summ = json.loads((d / "full" / "summary.json").read_text())
    out = {"label": label, "sigma_over_tau": s_over_t, "tau": tau, "seed": seed,
           "alpha_nominal": 2 * s_over_t, "alpha_triangles": alpha_tri,
           "stats": stats, "photons": photons, "theta": [], "single": [], "single_se": [],
           "reflectance": [], "lost": [], "by_bounces": []}
    for inc in summ["incidence"]:
        p1 = inc["reflectance_by_bounces"][1]
        out["theta"].append(inc["theta_deg"])
        out["single"].append(p1)
        out["single_se"].append(math.sqrt(p1 * (1 - p1) / inc["photons"]))
        out["reflectance"].append(inc["reflectance"])
        out["lost"].append(inc["lost"])
        out["by_bounces"].append(inc["reflectance_by_bounces"])
    # Smith predictions for this surface.
    lam_emp = mf.empirical_lambda(slopes)
    sub = slopes[:: max(1, len(slopes) // 262144)]
    for key, fn in {
        "smith_nominal": lambda t: mf.albedo_ss(t, 2 * s_over_t),
        "smith_measured": lambda t: mf.albedo_ss(t, alpha_tri),
        "smith_uncorr_measured": lambda t: mf.albedo_ss(t, alpha_tri, correlated=False),
        "smith_facets": lambda t: mf.albedo_facets(t, sub, lam_emp),
    }.items():
        out[key] = [fn(math.radians(t)) for t in out["theta"]]
    if brdf:
        single = d / "single.toml"
        single.write_text(scene_text(label, s_over_t, tau, seed, single_photons, 1))
        run_cmd([roks, "brdf", str(single), "--out", str(d / "single"), "-q"], WHO)
        s1 = json.loads((d / "single" / "summary.json").read_text())
        out["single_run"] = [(i["theta_deg"], i["reflectance"], i["reflectance_stderr"],
                              i["lost_cap"]) for i in s1["incidence"]]
        out["brdf_dir"] = str(d / "single")
    return out


def heitz(case: dict, paths: int) -> None:
    for key, a in (("heitz_nominal", case["alpha_nominal"]), ("heitz_measured", case["alpha_triangles"])):
        rows = []
        for t in case["theta"]:
            r = mf.heitz_walk(math.radians(t), a, paths, seed=7)
            rows.append({"order": r.order_mean[:8].tolist(), "order_se": r.order_stderr[:8].tolist(),
                         "nee_total": r.nee_total, "nee_total_se": r.nee_total_stderr})
        case[key] = rows


def cell_comparison(case: dict) -> dict:
    """Single-bounce BRDF per Carlson cell: roks vs the model with the measured alpha."""
    b = read_columns(Path(case["brdf_dir"]) / "brdf.csv")
    res = {}
    for t in case["theta"]:
        sel = b["theta_i_deg"] == t
        model, frac = mf.carlson_average(math.radians(t), b["theta_lo_deg"][sel], b["theta_hi_deg"][sel],
                                         b["phi_lo_deg"][sel], b["phi_hi_deg"][sel],
                                         case["alpha_triangles"], order=6)
        rk, se = b["brdf"][sel], b["brdf_stderr"][sel]
        # Cells of the lobe: those holding the top 90 % of the model's flux.
        order = np.argsort(frac)[::-1]
        lobe = np.zeros(len(frac), bool)
        lobe[order[: np.searchsorted(np.cumsum(frac[order]), 0.9 * frac.sum()) + 1]] = True
        ok = lobe & (se > 0)
        z = (rk - model) / np.where(se > 0, se, np.inf)
        rel = (rk - model) / np.where(model > 0, model, np.inf)
        res[t] = {"theta": b["theta_deg"][sel], "phi": b["phi_deg"][sel], "rel": rel, "z": z,
                  "lobe": lobe, "model": model, "roks": rk, "se": se,
                  "chi2_dof": float(np.mean(z[ok] ** 2)), "n_lobe": int(ok.sum()),
                  "median_abs_rel": float(np.median(np.abs(rel[ok]))),
                  "flux_weighted_rel": float(np.sum(frac[ok] * rel[ok]) / np.sum(frac[ok]))}
    return res


def plots(out: Path, cases: dict, cells: dict) -> None:
    # (a) single-bounce albedo.
    fig, axes = plt.subplots(2, 1, figsize=(9, 10), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    for lab in MAIN:
        c = cases[lab]
        th = np.array(c["theta"])
        col = COL[lab]
        an, am = c["alpha_nominal"], c["alpha_triangles"]
        axes[0].errorbar(th, c["single"], yerr=c["single_se"], fmt="o", color=col, ms=4, capsize=2,
                         label=f"roks, Gaussian field α={an} (triangles: α={am:.3f})")
        tt = np.linspace(0, 85, 86)
        axes[0].plot(tt, [mf.albedo_ss(math.radians(x), am) for x in tt], "-", color=col, lw=1.2,
                     label=f"Smith height-correlated, α={am:.3f}")
        axes[0].plot(tt, [mf.albedo_ss(math.radians(x), am, correlated=False) for x in tt], ":",
                     color=col, lw=1.2, label="Smith uncorrelated")
        for key, sty in (("smith_measured", "-"), ("smith_facets", "--"), ("smith_uncorr_measured", ":")):
            rel = (np.array(c["single"]) - np.array(c[key])) / np.array(c[key]) * 100
            axes[1].plot(th, rel, sty, marker="o", ms=3, color=col,
                         label=f"α={an}: vs " + {"smith_measured": "Smith corr., measured α",
                                                 "smith_facets": "Smith corr., triangles' own slopes",
                                                 "smith_uncorr_measured": "Smith uncorr., measured α"}[key])
        se = np.array(c["single_se"]) / np.array(c["smith_measured"]) * 100
        axes[1].fill_between(th, -4 * se, 4 * se, color=col, alpha=0.12, lw=0)
    axes[0].set_ylabel("single-bounce albedo")
    axes[0].set_title("Gaussian height fields (512², τ = 12 pitches, ρ = 1): single-bounce albedo\n"
                      "roks (±1 SE) vs Beckmann + Smith")
    axes[0].legend(fontsize=7, ncol=2)
    axes[0].grid(alpha=0.3)
    axes[1].axhline(0, color="0.4", lw=0.8)
    axes[1].set_ylabel("(roks − model) / model (%)")
    axes[1].set_xlabel("θᵢ (deg)")
    axes[1].set_title("relative difference (shaded: ±4 roks SE)", fontsize=10)
    axes[1].legend(fontsize=7, ncol=1)
    axes[1].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "single_albedo.png", dpi=120)
    plt.close(fig)

    # (b) in-plane single-bounce BRDF.
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    for ax, lab in zip(axes, MAIN):
        c = cases[lab]
        ip = read_columns(Path(c["brdf_dir"]) / "inplane.csv")
        for t, col in zip((0, 30, 60, 80), ("k", "tab:blue", "tab:green", "tab:red")):
            sel = (ip["theta_i_deg"] == t) & (ip["brdf"] > 0)
            ax.errorbar(ip["theta_o_deg"][sel], ip["brdf"][sel], yerr=ip["brdf_stderr"][sel], fmt=".",
                        ms=2, color=col, alpha=0.6, label=f"roks θᵢ={t}°")
            to = np.linspace(-89, 89, 357)
            ax.plot(to, mf.inplane(math.radians(t), to, c["alpha_triangles"]), "-", color=col, lw=1)
        ax.set_yscale("log")
        ax.set_ylim(1e-3, None)
        ax.set_xlabel("θₒ (deg, > 0 specular side)")
        ax.set_title(f"α = {c['alpha_nominal']} (lines: model, α = {c['alpha_triangles']:.3f})", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("single-bounce BRDF (sr⁻¹)")
    axes[0].legend(fontsize=8)
    fig.suptitle("Single-bounce in-plane BRDF: roks (max_bounces = 1) vs Beckmann + Smith (height-correlated)")
    fig.tight_layout()
    fig.savefig(out / "inplane_single.png", dpi=120)
    plt.close(fig)

    # (b) relative deviation maps.
    fig, axes = plt.subplots(3, 3, figsize=(13, 13.5), subplot_kw={"projection": "polar"})
    for i, lab in enumerate(MAIN):
        for j, t in enumerate((0, 30, 60)):
            ax = axes[i, j]
            r = cells[lab][t]
            m = r["lobe"]
            sc = ax.scatter(np.radians(r["phi"][m]), r["theta"][m], c=100 * r["rel"][m], cmap="RdBu_r",
                            vmin=-30, vmax=30, s=14)
            ax.set_ylim(0, 90)
            ax.set_title(f"α={cases[lab]['alpha_nominal']}, θᵢ={t}°\nχ²/cell {r['chi2_dof']:.1f}, "
                         f"median |dev| {100 * r['median_abs_rel']:.1f} %", fontsize=9)
            ax.set_yticks([30, 60, 90])
    fig.colorbar(sc, ax=axes, shrink=0.6, label="(roks − model) / model (%), lobe cells (90 % of flux)")
    fig.suptitle("Single-bounce BRDF per Carlson cell (24 bands): roks vs Beckmann + Smith, measured α\n"
                 "(polar angle θₒ radial, light at φ = 0, specular direction at φ = 180°)")
    fig.savefig(out / "cells_deviation.png", dpi=110)
    plt.close(fig)

    # (c) multiple scattering.
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.2))
    for lab in MAIN:
        c = cases[lab]
        th = np.array(c["theta"])
        col = COL[lab]
        ms = 1 - np.array(c["single"])
        axes[0].errorbar(th, ms, yerr=c["single_se"], fmt="o", color=col, ms=4, capsize=2,
                         label=f"roks, α={c['alpha_nominal']}")
        hz = np.array([1 - r["order"][1] for r in c["heitz_measured"]])
        hse = np.array([r["order_se"][1] for r in c["heitz_measured"]])
        axes[0].errorbar(th, hz, yerr=hse, fmt="-", color=col, lw=1.2,
                         label=f"Heitz 2016 walk, α={c['alpha_triangles']:.3f}")
        for k, mk in ((2, "s"), (3, "^")):
            rk = np.array([b[k] for b in c["by_bounces"]])
            hk = np.array([r["order"][k] for r in c["heitz_measured"]])
            axes[1].plot(th, rk, mk, color=col, ms=5, label=f"roks k={k}, α={c['alpha_nominal']}")
            axes[1].plot(th, hk, "-" if k == 2 else "--", color=col, lw=1,
                         label=f"Heitz k={k}")
    axes[0].set_ylabel("multiple-scattering share 1 − single-bounce albedo")
    axes[0].set_xlabel("θᵢ (deg)")
    axes[0].legend(fontsize=8)
    axes[0].grid(alpha=0.3)
    axes[1].set_yscale("log")
    axes[1].set_ylabel("albedo carried by photons leaving after k bounces")
    axes[1].set_xlabel("θᵢ (deg)")
    axes[1].legend(fontsize=6.5, ncol=3)
    axes[1].grid(alpha=0.3)
    fig.suptitle("White furnace (ρ = 1): multiple scattering on Gaussian height fields vs Heitz et al. 2016")
    fig.tight_layout()
    fig.savefig(out / "multiple_scattering.png", dpi=120)
    plt.close(fig)


def report(out: Path, cases: dict, cells: dict, args) -> str:
    L = ["# Gaussian height fields against microfacet theory", "",
         f"`scripts/microfacet_study.py`, {args.photons:,} photons per angle for the full runs "
         f"(rho = 1), {args.single_photons:,} for the single-bounce (max_bounces = 1) runs; "
         f"Heitz walk {args.paths:,} paths per angle. Fields: {N}² squares of pitch 1, periodic.", "",
         "## Surfaces", "",
         "| case | sigma/tau | tau (pitches) | seed | alpha nominal | alpha of the triangles | "
         "`roks stats` sigma | tau | sigma/tau | RMS slope (central diff.) |",
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for lab, c in cases.items():
        s = c["stats"]
        L.append(f"| {lab} | {c['sigma_over_tau']} | {c['tau']:g} | {c['seed']} | {c['alpha_nominal']} | "
                 f"{c['alpha_triangles']:.4f} | {s['sigma']:.4f} | {s['tau']:.3f} | {s['sigma_over_tau']:.4f} | "
                 f"{s['rms_slope']:.4f} |")
    L += ["", "## (a) Single-bounce albedo", "",
          "roks: `reflectance_by_bounces[1]` (binomial SE); nothing is lost (reflectance 1 at every angle: "
          + ("yes" if all(abs(r - 1) < 1e-12 for c in cases.values() for r in c["reflectance"]) else "NO")
          + "). Smith: height-correlated with the triangles' alpha (`corr`), uncorrelated (`unc`), "
          "and with the triangles' own slope distribution for D and Lambda (`facets`); nominal alpha in "
          "`nom`. dz = (roks - corr)/SE.", ""]
    for lab, c in cases.items():
        L += [f"**{lab}** (alpha triangles {c['alpha_triangles']:.4f})", "",
              "| theta_i | roks | SE | Smith corr | dz | Smith facets | Smith unc | Smith nom |",
              "|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for i, t in enumerate(c["theta"]):
            se_i = c["single_se"][i]
            dz = (c["single"][i] - c["smith_measured"][i]) / se_i if se_i > 0 else float("nan")
            L.append(f"| {t:g} | {c['single'][i]:.4f} | {c['single_se'][i]:.1e} | {c['smith_measured'][i]:.4f} | "
                     f"{dz:+.0f} | {c['smith_facets'][i]:.4f} | {c['smith_uncorr_measured'][i]:.4f} | "
                     f"{c['smith_nominal'][i]:.4f} |")
        L.append("")
    L += ["![single-bounce albedo](single_albedo.png)", "",
          "## (b) Single-bounce BRDF per cell", "",
          "max_bounces = 1 runs (photons cut at their second hit, `lost_cap`); model: cell averages of "
          "the height-correlated Beckmann + Smith BRDF with the triangles' alpha. Lobe = the cells "
          "holding 90 % of the model's reflected flux. chi2/cell = mean z² over the lobe (1 if the model "
          "were exact); dev = (roks - model)/model.", "",
          "| case | theta_i | single-bounce reflectance (max_bounces = 1) | lost_cap | lobe cells | chi2/cell | "
          "median abs dev | flux-weighted dev |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for lab in MAIN:
        c = cases[lab]
        for (t, r, se, cap) in c["single_run"]:
            x = cells[lab][t]
            L.append(f"| {lab} | {t:g} | {r:.4f} ± {se:.1e} | {cap:.4f} | {x['n_lobe']} | {x['chi2_dof']:.1f} | "
                     f"{100 * x['median_abs_rel']:.1f} % | {100 * x['flux_weighted_rel']:+.1f} % |")
    L += ["", "![in-plane](inplane_single.png)", "", "![cells](cells_deviation.png)", "",
          "## (c) Multiple scattering vs Heitz et al. 2016", "",
          "Share of the albedo carried by 2 or more bounces (rho = 1: 1 - single), and by exactly 2 and "
          "3, roks vs the Heitz walk (triangles' alpha). The walk's next-event total albedo (energy "
          "conservation) is listed too.", "",
          "| case | theta_i | roks 1 - single | Heitz 1 - single | roks k=2 | Heitz k=2 | roks k=3 | Heitz k=3 | "
          "roks k>=4 | Heitz k>=4 | Heitz NEE total |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for lab in MAIN:
        c = cases[lab]
        for i, t in enumerate(c["theta"]):
            b = c["by_bounces"][i]
            h = c["heitz_measured"][i]
            L.append(f"| {lab} | {t:g} | {1 - c['single'][i]:.4f} | {1 - h['order'][1]:.4f} ± {h['order_se'][1]:.1e} | "
                     f"{b[2]:.4f} | {h['order'][2]:.4f} | {b[3]:.4f} | {h['order'][3]:.4f} | "
                     f"{sum(b[4:]):.4f} | {1 - sum(h['order'][1:4]):.4f} | {h['nee_total']:.4f} ± {h['nee_total_se']:.4f} |")
    L += ["", "![multiple scattering](multiple_scattering.png)", ""]
    return "\n".join(L) + "\n"


@command("microfacet_study")
def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--roks", default=str(default_roks()))
    add_out_argument(p, "microfacet")
    p.add_argument("--photons", type=int, default=1_000_000)
    p.add_argument("--single-photons", type=int, default=2_000_000)
    p.add_argument("--paths", type=int, default=200_000)
    p.add_argument("--keep-runs", action="store_true")
    a = p.parse_args(argv)
    check_output(a.out, a.overwrite_committed)
    if shutil.which(a.roks) is None and not Path(a.roks).exists():
        raise RunError(f"roks not found: {a.roks}")
    out = Path(a.out)
    runs = out / "runs"
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    cases = {}
    for lab, st, tau, seed in CASES:
        cases[lab] = measure_case(a.roks, runs, lab, st, tau, seed, a.photons, a.single_photons,
                                  lab in MAIN)
        if lab in MAIN:
            heitz(cases[lab], a.paths)
    cells = {lab: cell_comparison(cases[lab]) for lab in MAIN}
    plots(out, cases, cells)
    md = report(out, cases, cells, a)
    (out / "report.md").write_text(md)
    slim = {lab: {k: v for k, v in c.items() if k not in ("brdf_dir",)} for lab, c in cases.items()}
    (out / "data.json").write_text(json.dumps(slim, indent=1))
    if not a.keep_runs:
        shutil.rmtree(runs)
    print(md)
    print(f"{time.monotonic() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
