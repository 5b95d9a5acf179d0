"""Speed against error: roks vs the Mitsuba tracer, and the radiator's two wall models.

    .venv/bin/python scripts/speed_error.py [--roks target/release/roks] [--out speed_error]
        [--quick]

Part 1, micro level (the default scene at 30 and 60 degrees). `roks brdf`
runs 1e3 ... 1e7 photons per angle (seeds 1, 2, ...), and the Mitsuba
wavefront tracer of the cross-check (`roks_tools.mitsuba.tracer`) runs
1e3 ... 1e6 photons on the same surface exported as a 1024^2 mesh
(`roks export-mesh`). Each is compared with a long run of its own (roks:
3e7 photons, Mitsuba: 1e7, other seeds), so the error measured is the
statistical error of each tracer on its own geometry (the mesh's faceting
bias is the cross-check's subject, results/crosscheck):

* BRDF cells: RMS over the Carlson cells holding at least 1e-4 of the
  incident power in the reference of (brdf - brdf_ref) / brdf_ref;
* in-plane BRDF: the same over the in-plane bins with reference BRDF >= 0.1 / sr;
* reflectance: |R - R_ref|.

roks runs twice: with random entry points, and with the lattice launch
(`--launch lattice`: 16 randomly shifted R2 lattices; photon counts rounded
up to a multiple of 16). The lattice ladder is compared with a lattice
reference of the same length (other seed) and its measured error is used
as it is, without removing the reference's share: that overstates its error,
so its time to 1 % is an upper bound.

Part 2, macro level: `roks trace` of the radiator with the apex defect,
`micro` walls (descent into the Z-302 micro geometry at every hit,
scenes/radiator-defect.toml) and `brdf` walls (sampling its table,
scenes/radiator-defect-brdf.toml), 1e2 ... 1e5 photons per beam position
(24 positions) against 1e6-photon references of the same model: RMS over
the positions of the relative error of the cavity reflectance.

Time is each process's wall clock (start-up, mesh loading and BVH build
included; the tracing time alone from summary.json is recorded too). All
runs happen in this one script on this machine, so the ratios hold even if
the machine is noisy. Writes OUT/report.md, OUT/speed_error.json,
OUT/micro.png, OUT/radiator.png. --quick: small ladders for a smoke test.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from roks_tools import compare as cb
from roks_tools.errors import command
from roks_tools.results import InPlane, Reflectance
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run as run_cmd

ROOT = repo_root()

WHO = ("roks", "roks_lattice", "mitsuba")
CELL_FLOOR = 1e-4      # fraction of the incident power in a cell
INPLANE_FLOOR = 0.1    # 1/sr


def timed(cmd: list) -> float:
    """Wall seconds of `cmd`, run from the repository root."""
    return run_cmd(cmd, "speed_error", echo=False, cwd=ROOT).wall_s


def inplane(d: Path) -> dict:
    """{theta_i_deg: {theta_o_deg: brdf}} of a folder's inplane.csv."""
    return {t: dict(zip(o.tolist(), b.tolist()))
            for t, (o, b, _) in InPlane.read(Path(d) / "inplane.csv").by_theta().items()}


def micro_errors(run: Path, ref: Path) -> dict:
    """Per incidence angle: RMS relative error of cells and in-plane bins, |dR|."""
    sr, cr = cb.load(ref)
    sx, cx = cb.load(run)
    ir, ix = inplane(ref), inplane(run)
    out = {}
    for th in sorted(set(sr) & set(sx)):
        rel = [(cx[th].get(k, (0.0, 0.0))[0] - f) / f for k, (f, _) in cr[th].items() if f >= CELL_FLOOR]
        rel_ip = [(ix[th][o] - b) / b for o, b in ir[th].items() if b >= INPLANE_FLOOR]
        out[th] = {"cells": float(np.sqrt(np.mean(np.square(rel)))), "n_cells": len(rel),
                   "inplane": float(np.sqrt(np.mean(np.square(rel_ip)))), "n_inplane": len(rel_ip),
                   "reflectance": abs(sx[th]["reflectance"] - sr[th]["reflectance"]),
                   "trace_seconds": sx[th]["seconds"]}
    return out


def radiator_reflectance(d: Path) -> np.ndarray:
    """The reflectance per beam position of a `roks trace` folder (reflectance.csv)."""
    return Reflectance.read(Path(d) / "reflectance.csv").reflectance


def time_to(runs: list[tuple[int, float, float]], n_ref: int, target: float) -> float | None:
    """Wall time to reach error `target`, extrapolated from the largest run.

    `runs` are (photons, wall seconds, measured error). The measured error
    includes the reference's own noise: e_meas² = e² (1 + n / n_ref) for
    independent runs, so e = e_meas / sqrt(1 + n / n_ref). Start-up time
    (the wall time of the smallest run) is fixed; tracing time grows as
    1 / e²: t = t0 + (t_n - t0) (e / target)²."""
    if len(runs) < 2:
        return None
    n, t, e = max(runs)
    t0 = min(r[1] for r in runs)
    e_true = e / math.sqrt(1.0 + n / n_ref)
    return t0 + max(t - t0, 0.0) * (e_true / target) ** 2


@command("speed_error")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", type=Path, default=default_roks())
    add_out_argument(ap, "speed_error")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--skip-radiator", action="store_true")
    ap.add_argument("--reuse-radiator", action="store_true",
                    help="keep the radiator part of OUT/speed_error.json instead of rerunning it")
    ap.add_argument("--report-only", action="store_true", help="redo the report from OUT/speed_error.json")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    if a.report_only:
        report_only(a.out)
        return 0
    py = sys.executable
    work = a.out / "runs"
    work.mkdir(parents=True, exist_ok=True)
    q = a.quick
    roks_ladder = [10 ** k for k in range(3, 6 if q else 8)]
    mi_ladder = [10 ** k for k in range(3, 5 if q else 7)]
    roks_ref_n, mi_ref_n = (10 ** 6, 10 ** 5) if q else (3 * 10 ** 7, 10 ** 7)
    res: dict = {"micro": {"roks": [], "roks_lattice": [], "mitsuba": [], "roks_ref_photons": roks_ref_n,
                           "roks_lattice_ref_photons": roks_ref_n, "mitsuba_ref_photons": mi_ref_n},
                 "radiator": {}}

    # ---------- micro level
    mesh = work / "default_1024.ply"
    timed([a.roks, "export-mesh", "--resolution", 1024, "--out", mesh])
    ref = work / "roks_ref"
    res["micro"]["roks_ref_seconds"] = timed([a.roks, "brdf", "--theta", "30,60", "--photons", roks_ref_n,
                                              "--seed", 999, "--out", ref, "-q"])
    mref = work / "mitsuba_ref"
    mi_args = [py, "-m", "roks_tools.mitsuba.tracer", mesh, "--size", "30,30", "--theta", "30,60", "--rho", 0.8, "-q"]
    res["micro"]["mitsuba_ref_seconds"] = timed(mi_args + ["--photons", mi_ref_n, "--seed", 999, "--out", mref])
    lref = work / "roks_lattice_ref"
    res["micro"]["roks_lattice_ref_seconds"] = timed(
        [a.roks, "brdf", "--theta", "30,60", "--photons", roks_ref_n, "--launch", "lattice",
         "--seed", 998, "--out", lref, "-q"])
    for k, n in enumerate(roks_ladder):
        d = work / f"roks_{n}"
        t = timed([a.roks, "brdf", "--theta", "30,60", "--photons", n, "--seed", k + 1, "--out", d, "-q"])
        res["micro"]["roks"].append({"photons": n, "seconds": t, "errors": micro_errors(d, ref)})
        print(f"roks {n}: {t:.2f} s", file=sys.stderr)
        n16 = -(-n // 16) * 16
        d = work / f"roks_lattice_{n16}"
        t = timed([a.roks, "brdf", "--theta", "30,60", "--photons", n16, "--launch", "lattice",
                   "--seed", k + 1, "--out", d, "-q"])
        res["micro"]["roks_lattice"].append({"photons": n16, "seconds": t, "errors": micro_errors(d, lref)})
        print(f"roks lattice {n16}: {t:.2f} s", file=sys.stderr)
    for k, n in enumerate(mi_ladder):
        d = work / f"mitsuba_{n}"
        t = timed(mi_args + ["--photons", n, "--seed", k + 1, "--out", d])
        res["micro"]["mitsuba"].append({"photons": n, "seconds": t, "errors": micro_errors(d, mref)})
        print(f"mitsuba {n}: {t:.2f} s", file=sys.stderr)

    # ---------- radiator
    if a.reuse_radiator:
        res["radiator"] = json.loads((a.out / "speed_error.json").read_text())["radiator"]
    elif not a.skip_radiator:
        if not (ROOT / "out" / "z302" / "brdf.csv").exists():
            timed([a.roks, "brdf", "scenes/z302-micro.toml", "--out", "out/z302", "-q"])
        rad_ladder = [10 ** k for k in range(2, 4 if q else 6)]
        rad_ref = 10 ** 4 if q else 10 ** 6
        for model, scene in (("micro", "scenes/radiator-defect.toml"), ("brdf", "scenes/radiator-defect-brdf.toml")):
            rdir = work / f"rad_{model}_ref"
            tref = timed([a.roks, "trace", scene, "--photons", rad_ref, "--seed", 999, "--out", rdir, "-q"])
            r_ref = radiator_reflectance(rdir)
            runs = []
            for k, n in enumerate(rad_ladder):
                d = work / f"rad_{model}_{n}"
                t = timed([a.roks, "trace", scene, "--photons", n, "--seed", k + 1, "--out", d, "-q"])
                r = radiator_reflectance(d)
                err = float(np.sqrt(np.mean(((r - r_ref) / r_ref) ** 2)))
                runs.append({"photons_per_position": n, "seconds": t, "rms_relative_error": err})
                print(f"radiator {model} {n}: {t:.2f} s, error {err:.3g}", file=sys.stderr)
            res["radiator"][model] = {"reference_seconds": tref, "reference_photons": rad_ref, "runs": runs}

    write_report(a.out, res)
    return 0


def report_only(out: Path) -> None:
    """Rewrite the report from OUT/speed_error.json (no runs)."""
    res = json.loads((out / "speed_error.json").read_text())
    for who in WHO:
        for r in res["micro"].get(who, []):
            r["errors"] = {float(k): v for k, v in r["errors"].items()}
    write_report(out, res)


def write_report(out: Path, res: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    lines = ["# Speed against error", "",
             "Produced by `scripts/speed_error.py` on this machine (2 cores; other work may have "
             "been running: compare ratios within the run). Errors against a long run of the same "
             "tracer on the same geometry (statistical error); time = wall clock of the process.", ""]
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    metrics = (("cells", f"BRDF cells (>= {CELL_FLOOR:g} of the power): RMS relative error"),
               ("inplane", f"in-plane BRDF (>= {INPLANE_FLOOR:g}/sr): RMS relative error"),
               ("reflectance", "reflectance: absolute error"))
    summary = {}
    for j, (m, title) in enumerate(metrics):
        for who, style in (("roks", "o-"), ("roks_lattice", "^-"), ("mitsuba", "s--")):
            runs = res["micro"].get(who, [])
            for th in (30.0, 60.0):
                t = [r["seconds"] for r in runs]
                e = [r["errors"][th][m] for r in runs]
                ax[j].loglog(t, e, style, label=f"{who}, {th:g} deg")
                if m == "cells":
                    # The lattice's error is used as measured (its reference's
                    # noise is not removed): an upper bound.
                    n_ref = math.inf if who == "roks_lattice" else res["micro"][f"{who}_ref_photons"]
                    summary[(who, th)] = time_to([(r["photons"], r["seconds"], r["errors"][th][m]) for r in runs],
                                                 n_ref, 0.01)
        tt = np.logspace(-1, 3, 10)
        ref_e = res["micro"]["roks"][-1]["errors"][30.0][m]
        ref_t = res["micro"]["roks"][-1]["seconds"]
        ax[j].loglog(tt, ref_e * np.sqrt(ref_t / tt), ":", color="grey", label="1/sqrt(t)")
        if m != "reflectance":
            ax[j].axhline(0.01, color="k", lw=0.6)
        ax[j].set_xlabel("wall time (s)")
        ax[j].set_title(title, fontsize=9)
        ax[j].grid(alpha=0.3, which="both")
        ax[j].legend(fontsize=7)
    fig.suptitle("Default scene: roks (exact quadrics) vs Mitsuba wavefront tracer (1024^2 mesh)")
    fig.tight_layout()
    fig.savefig(out / "micro.png", dpi=100)
    plt.close(fig)

    lines += ["## Micro level: default scene, 30 and 60 degrees", "", "![micro](micro.png)", "",
              "| tracer | photons per angle | wall s | cells 30° | cells 60° | in-plane 30° | in-plane 60° "
              "| dR 30° | dR 60° |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for who in WHO:
        for r in res["micro"].get(who, []):
            e = r["errors"]
            lines.append(f"| {who} | {r['photons']:.0e} | {r['seconds']:.2f} | {e[30.0]['cells']:.3g} | "
                         f"{e[60.0]['cells']:.3g} | {e[30.0]['inplane']:.3g} | {e[60.0]['inplane']:.3g} | "
                         f"{e[30.0]['reflectance']:.1e} | {e[60.0]['reflectance']:.1e} |")
    lines += ["", "Wall time to reach 1 % RMS relative error of the BRDF cells, extrapolated from the "
              "largest run (its error corrected for the reference's own noise, e² (1 + n/n_ref); start-up "
              "time = the smallest run's, fixed; tracing time growing as 1/e²):", "",
              "| angle | roks (s) | roks lattice (s) | Mitsuba (s) | ratio Mitsuba/roks | ratio Mitsuba/lattice |",
              "|---:|---:|---:|---:|---:|---:|"]
    res["time_to_1pct"] = {}
    for th in (30.0, 60.0):
        r_, l_, m_ = (summary.get((w, th)) for w in WHO)
        ratio = m_ / r_ if r_ and m_ else float("nan")
        ratio_l = m_ / l_ if l_ and m_ else float("nan")
        res["time_to_1pct"][str(th)] = {"roks": r_, "roks_lattice": l_, "mitsuba": m_, "ratio": ratio,
                                        "ratio_lattice": ratio_l}
        nan = float("nan")
        lines.append(f"| {th:g} | {r_ or nan:.3g} | {l_ or nan:.3g} | {m_ or nan:.3g} | {ratio:.1f} | "
                     f"{ratio_l:.1f} |")
    lines += [""]

    if res["radiator"]:
        fig, ax = plt.subplots(figsize=(6.5, 4.6))
        lines += ["## Macro level: radiator with the apex defect, 24 beam positions", "",
                  "![radiator](radiator.png)", "",
                  "| walls | photons per position | wall s | RMS relative error of the reflectance |",
                  "|---|---:|---:|---:|"]
        for model, d in res["radiator"].items():
            t = [r["seconds"] for r in d["runs"]]
            e = [r["rms_relative_error"] for r in d["runs"]]
            ax.loglog(t, e, "o-", label=f"{model} walls")
            for r in d["runs"]:
                lines.append(f"| {model} | {r['photons_per_position']:.0e} | {r['seconds']:.2f} | "
                             f"{r['rms_relative_error']:.3g} |")
            d["time_to_1pct"] = time_to([(r["photons_per_position"], r["seconds"], r["rms_relative_error"])
                                         for r in d["runs"]], d["reference_photons"], 0.01)
        ax.axhline(0.01, color="k", lw=0.6)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("RMS relative error of the cavity reflectance")
        ax.set_title("Radiator with apex defect: micro descent vs BRDF table walls")
        ax.grid(alpha=0.3, which="both")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "radiator.png", dpi=100)
        plt.close(fig)
        lines += ["", "Wall time to 1 % RMS relative error (extrapolated as above): " + ", ".join(
            f"{m} walls {d['time_to_1pct']:.3g} s" for m, d in res["radiator"].items() if d["time_to_1pct"]), ""]
    (out / "report.md").write_text("\n".join(lines))
    (out / "speed_error.json").write_text(json.dumps(res, indent=1, default=str))
    print(f"speed_error: wrote {out / 'report.md'}")


if __name__ == "__main__":
    sys.exit(main())
