"""Cavity reflectance of the biconical radiator (Klass et al. 2014, validation item 3).

The paper computes the reflectance of the cavity of an isothermal biconical
blackbody radiator, its walls painted with Z-302 black paint, lit by a 2 mm
10.6 um laser beam parallel to the axis and moved across the aperture. The
computed reflectance of an ideal cone is smooth and 3-4 times below the
measurement in the middle; an inverted cone 1 cm high (45 degree half-angle)
in the apex, the paper's model of a manufacturing error, raises the central
reflectance almost tenfold.

This study:

1. runs `roks brdf scenes/z302-micro.toml --polarisation mueller --out
   out/z302 -q` (the BRDF table of the stand-in Z-302 micro geometry that the
   *-brdf scenes sample, with its Mueller matrices, so that table walls keep
   the polarisation like the micro walls; the scene's 400000 photons per
   angle);
2. runs `roks trace --photons N` on scenes/radiator.toml, radiator-brdf.toml,
   radiator-defect.toml and radiator-defect-brdf.toml (walls traced down into
   the micro geometry at every hit, or sampled from the BRDF table);
3. writes, in --out:

* radiator.csv  one row per scene and beam position
* radiator.md   reflectance vs beam offset for the four scenes, the
                defect / ideal ratio, run times and micro - table differences
* radiator.png  (a) reflectance vs beam offset, (b) defect / ideal ratio

The per-scene roks output folders go to a temporary folder that is deleted
afterwards, unless --keep-runs is given (then they stay in --out/runs/).
out/z302/ (the BRDF table, relative to the repo root) is always kept: the
*-brdf scenes read it from there.

Needs numpy and matplotlib (scripts/setup_venv.sh).
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roks_tools.errors import RunError, UsageError, command
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run as run_cmd  # noqa: E402

REPO = repo_root()
SCENES_DIR = REPO / "scenes"
MICRO_SCENE = SCENES_DIR / "z302-micro.toml"
TABLE_DIR = REPO / "out" / "z302"  # the *-brdf scenes read ../out/z302/brdf.csv
# (scene, wall model, defect)
SCENES = (
    ("radiator", "micro", False),
    ("radiator-brdf", "brdf", False),
    ("radiator-defect", "micro", True),
    ("radiator-defect-brdf", "brdf", True),
)
LABEL = {
    ("micro", False): "ideal cone, micro-geometry walls",
    ("brdf", False): "ideal cone, BRDF-table walls",
    ("micro", True): "cone with apex defect, micro-geometry walls",
    ("brdf", True): "cone with apex defect, BRDF-table walls",
}
SHORT = {
    ("micro", False): "ideal micro",
    ("brdf", False): "ideal brdf-table",
    ("micro", True): "defect micro",
    ("brdf", True): "defect brdf-table",
}
COLOURS = {False: "tab:blue", True: "tab:red"}
STYLE = {"micro": dict(linestyle="-", marker="o"), "brdf": dict(linestyle="--", marker="s")}
PAPER_RATIO = 10.0  # "almost tenfold in the central part"
PAPER_SPIKE_RADIUS_MM = 6.0  # measured spike within a 6 mm radius ring
CSV_COLS = ["scene", "model", "defect", "x", "y", "z", "reflectance", "reflectance_stderr",
            "mean_bounces", "seconds"]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--roks", default=str(default_roks()),
                   help="path to the roks binary (default: %(default)s)")
    p.add_argument("--photons", type=int, default=100_000,
                   help="photons per beam position (default: %(default)s)")
    add_out_argument(p, "radiator")
    p.add_argument("--keep-runs", action="store_true",
                   help="keep the per-scene roks output folders in OUT/runs/ "
                   "(default: a temporary folder, deleted at the end)")
    p.add_argument("--replot", action="store_true",
                   help="do not run roks: redraw OUT/radiator.md and .png from OUT/radiator.csv "
                   "and OUT/timings.json")
    a = p.parse_args(argv)
    check_output(a.out, a.overwrite_committed)
    if a.photons <= 0:
        p.error("--photons must be > 0")
    return a


def timed_run(cmd: list[str], what: str) -> tuple[float, float]:
    """Run cmd in the repo root; return its wall-clock and CPU (user + system) times.

    The CPU time is less sensitive to other load on the machine than the wall clock."""
    done = run_cmd(cmd, f"radiator_study: {what}", cwd=REPO)
    print(f"  {done.wall_s:.1f} s (CPU {done.cpu_s:.1f} s)", file=sys.stderr, flush=True)
    return done.wall_s, done.cpu_s


def read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise RunError(f"cannot read {path}: {e}")


def rows_from_summary(scene: str, model: str, defect: bool, summary: dict) -> list[dict]:
    rows = []
    for s in summary["sources"]:
        x, y, z = (float(v) for v in s["position"])
        rows.append({
            "scene": scene, "model": model, "defect": defect, "x": x, "y": y, "z": z,
            "reflectance": float(s["reflectance"]),
            "reflectance_stderr": float(s["reflectance_stderr"]),
            "mean_bounces": float(s["mean_bounces"]),
            "seconds": float(s["seconds"]),
        })
    if not rows:
        raise RunError(f"{scene}: no beam positions in summary.json")
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_COLS, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({
                **{k: r[k] for k in CSV_COLS},
                "defect": "true" if r["defect"] else "false",
                "x": f"{r['x']:g}", "y": f"{r['y']:g}", "z": f"{r['z']:g}",
                "reflectance": f"{r['reflectance']:.6e}",
                "reflectance_stderr": f"{r['reflectance_stderr']:.3e}",
                "mean_bounces": f"{r['mean_bounces']:.4f}",
                "seconds": f"{r['seconds']:.4f}",
            })


def read_csv(path: Path) -> list[dict]:
    try:
        with path.open(newline="") as f:
            raw = list(csv.DictReader(f))
    except OSError as e:
        raise RunError(f"cannot read {path}: {e}")
    out = []
    for r in raw:
        d = {k: (float(v) if k not in ("scene", "model", "defect") else v) for k, v in r.items()}
        d["defect"] = r["defect"] == "true"
        out.append(d)
    return out


def tabulate(rows: list[dict]) -> tuple[np.ndarray, dict]:
    """Beam offsets (mm) and {(model, defect): (reflectance, stderr, bounces)} on a common grid."""
    def offset(r: dict) -> float:
        return round(float(np.hypot(r["x"], r["y"])), 9)

    offs = sorted({offset(r) for r in rows})
    data = {}
    for scene, model, defect in SCENES:
        sel = {offset(r): r for r in rows if r["scene"] == scene}
        missing = [o for o in offs if o not in sel]
        if missing:
            raise RunError(f"{scene}: no result at offsets {missing}")
        data[model, defect] = tuple(
            np.array([sel[o][k] for o in offs])
            for k in ("reflectance", "reflectance_stderr", "mean_bounces")
        )
    return np.array(offs), data


def ratio(data: dict, model: str) -> tuple[np.ndarray, np.ndarray]:
    """defect / ideal with its standard error (independent runs assumed)."""
    rd, sd, _ = data[model, True]
    ri, si, _ = data[model, False]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = rd / ri
        se = q * np.sqrt((sd / rd) ** 2 + (si / ri) ** 2)
    return q, se


def pair_stats(data: dict, defect: bool) -> dict:
    """micro vs BRDF-table differences over the beam positions."""
    rm, sm, _ = data["micro", defect]
    rt, st, _ = data["brdf", defect]
    z = np.abs(rm - rt) / np.sqrt(sm**2 + st**2)
    rel = (rt - rm) / rm
    return {
        "mean_abs_sigma": float(np.mean(z)),
        "max_abs_sigma": float(np.max(z)),
        "frac_over_2sigma": float(np.mean(z > 2)),
        "mean_rel": float(np.mean(rel)),
        "mean_abs_rel": float(np.mean(np.abs(rel))),
        "sum_ratio": float(np.sum(rt) / np.sum(rm)),
    }


def central(offs: np.ndarray, upto: float = 1.0) -> np.ndarray:
    return offs <= upto + 1e-9


def markdown(offs: np.ndarray, data: dict, timings: dict, photons: int) -> str:
    keys = [("micro", False), ("brdf", False), ("micro", True), ("brdf", True)]
    qm, qms = ratio(data, "micro")
    qt, qts = ratio(data, "brdf")
    lines = [
        f"Cavity reflectance (reflected / incident power) vs beam offset from the axis, "
        f"{photons:,} photons per beam position; ± one standard error. "
        "ratio = defect / ideal cone.",
        "",
        "| offset (mm) | " + " | ".join(SHORT[k] for k in keys)
        + " | ratio micro | ratio brdf-table |",
        "|" + "|".join(["---:"] * (len(keys) + 3)) + "|",
    ]
    for i, o in enumerate(offs):
        cells = [f"{o:g}"]
        for k in keys:
            r, se, _ = data[k]
            cells.append(f"{r[i]:.3e} ± {se[i]:.1e}")
        cells.append(f"{qm[i]:.1f} ± {qms[i]:.1f}")
        cells.append(f"{qt[i]:.1f} ± {qts[i]:.1f}")
        lines.append("| " + " | ".join(cells) + " |")

    lines += [
        "",
        "Run times: wall clock of the roks process, the sum of the per-position (or "
        "per-angle) `seconds` of summary.json, and the CPU time (user + system, all threads; "
        "less sensitive to other load on the machine).",
        "",
        "| run | wall clock (s) | summary seconds (s) | CPU (s) |",
        "|---|---:|---:|---:|",
        f"| `roks brdf scenes/z302-micro.toml` (BRDF table, "
        f"{timings['brdf']['angles']} angles x {timings['brdf']['photons_per_angle']:,} photons) "
        f"| {timings['brdf']['wall']:.1f} | {timings['brdf']['seconds']:.1f} | "
        f"{timings['brdf']['cpu']:.1f} |",
    ]
    for scene, _, _ in SCENES:
        t = timings[scene]
        lines.append(f"| `roks trace scenes/{scene}.toml` | {t['wall']:.1f} | "
                     f"{t['seconds']:.1f} | {t['cpu']:.1f} |")
    lines += [
        "",
        "Micro-geometry walls vs BRDF-table walls, per pair of scenes (z = |micro - table| / "
        "sqrt(se_micro² + se_table²) at each beam position; relative = (table - micro) / micro):",
        "",
        "| pair | wall time micro / table | CPU time micro / table | mean z | max z | positions with z > 2 | "
        "mean relative | mean abs. relative | sum(table) / sum(micro) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for defect, name in ((False, "ideal cone"), (True, "defect")):
        s = pair_stats(data, defect)
        m, t = ("radiator-defect", "radiator-defect-brdf") if defect else ("radiator",
                                                                          "radiator-brdf")
        tr = timings[m]["wall"] / timings[t]["wall"]
        tc = timings[m]["cpu"] / timings[t]["cpu"]
        lines.append(
            f"| {name} | {tr:.2f} | {tc:.2f} | {s['mean_abs_sigma']:.2f} | {s['max_abs_sigma']:.1f} | "
            f"{100 * s['frac_over_2sigma']:.0f} % | {100 * s['mean_rel']:+.1f} % | "
            f"{100 * s['mean_abs_rel']:.1f} % | {s['sum_ratio']:.3f} |"
        )
    checks = timings.get("checks")
    if checks:
        lines += [
            "",
            "Checks per scene over the beam positions: largest lost and missed weight per "
            "photon, positions with zero reflectance, largest relative standard error, and "
            "the range of reflectance + absorbed + lost + missed (energy balance, should be 1).",
            "",
            "| scene | max lost | max missed | zero R | max se/R | balance min | balance max |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for scene, _, _ in SCENES:
            c = checks[scene]
            lines.append(
                f"| {scene} | {c['max_lost']:.1e} | {c['max_missed']:.1e} | "
                f"{c['zero_reflectance']} | {100 * c['max_rel_stderr']:.1f} % | "
                f"{c['absorbed_plus_reflectance_min']:.10f} | "
                f"{c['absorbed_plus_reflectance_max']:.10f} |"
            )
    return "\n".join(lines) + "\n"


def plot(path: Path, offs: np.ndarray, data: dict, photons: int) -> None:
    fig, (ax1, ax2) = plt.subplots(
        2, 1, figsize=(9, 10), sharex=True, gridspec_kw={"height_ratios": [3, 2]}
    )
    for model, defect in (("micro", False), ("brdf", False), ("micro", True), ("brdf", True)):
        r, se, _ = data[model, defect]
        ax1.errorbar(
            offs + (0.06 if model == "brdf" else 0.0), r, yerr=2 * se, color=COLOURS[defect],
            markersize=3.5, capsize=2, linewidth=1.3, label=LABEL[model, defect],
            **STYLE[model],
        )
    ax1.set_yscale("log")
    ax1.set_ylabel("cavity reflectance (power leaving the aperture / beam power)")
    ax1.set_title(
        "(a) Biconical blackbody cavity lit by a 2 mm beam parallel to its axis\n"
        "parametrised cavity (aperture radius 12.5 mm, entrance cone to radius 40 mm at 100 mm depth, 120° back cone, apex 123 mm deep); walls: stand-in\n"
        f"Z-302 black paint at 10.6 µm (R ≈ 6 % at normal incidence); {photons:,} photons "
        "per position",
        fontsize=10,
    )
    ax1.grid(True, which="both", alpha=0.3)
    ax1.legend(fontsize=8.5, loc="center left")
    ax1.text(0.99, 0.02, "error bars: ±2 standard errors; table curves shifted 0.06 mm "
             "right for legibility", transform=ax1.transAxes, ha="right", va="bottom",
             fontsize=8, color="0.35")

    q, qse = ratio(data, "micro")
    ax2.errorbar(offs, q, yerr=2 * qse, color="black", marker="o", markersize=3.5, capsize=2,
                 linewidth=1.3, label="computed: defect / ideal cone (micro-geometry walls)")
    ax2.axhline(PAPER_RATIO, color="tab:orange", linestyle="--", linewidth=1.5,
                label="paper: defect raises the central reflectance 'almost tenfold'")
    ax2.axhline(1.0, color="0.5", linewidth=0.8)
    ax2.axvline(PAPER_SPIKE_RADIUS_MM, color="0.5", linestyle=":", linewidth=1)
    ax2.text(PAPER_SPIKE_RADIUS_MM + 0.1, 0.97, "measured spike\nwithin 6 mm radius (paper)",
             transform=ax2.get_xaxis_transform(), fontsize=8, color="0.35", ha="left", va="top")
    lo = min(1.0, float(np.nanmin(q - 2 * qse)))
    hi = max(PAPER_RATIO, float(np.nanmax(q + 2 * qse)))
    if hi / max(lo, 1e-12) > 20:
        ax2.set_yscale("log")
    ax2.set_xlabel("beam offset from the cavity axis (mm); aperture radius 12.5 mm")
    ax2.set_ylabel("reflectance ratio, defect / ideal")
    ax2.set_title("(b) Effect of the apex defect: an inverted cone, 45° half-angle, 10 mm high, "
                  "base radius 10 mm,\nstanding in the apex of the 120° back cone; ±2 standard errors",
                  fontsize=10)
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=8.5, loc="lower left")
    ax2.set_xlim(-0.4, offs.max() + 0.5)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def report(out: Path, rows: list[dict], timings: dict, photons: int) -> None:
    offs, data = tabulate(rows)
    md = markdown(offs, data, timings, photons)
    (out / "radiator.md").write_text(md)
    plot(out / "radiator.png", offs, data, photons)
    print(md, end="")


@command("radiator_study")
def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    out = Path(a.out).resolve()
    if a.replot:
        timings = read_json(out / "timings.json")
        report(out, read_csv(out / "radiator.csv"), timings, int(timings["photons"]))
        return 0
    roks = a.roks
    if Path(roks).exists():
        roks = str(Path(roks).resolve())
    elif shutil.which(roks) is None:
        raise UsageError(f"roks binary not found: {roks} (build it: cargo build --release)")
    for scene, _, _ in SCENES:
        if not (SCENES_DIR / f"{scene}.toml").is_file():
            raise RunError(f"scene not found: {SCENES_DIR / scene}.toml")
    out.mkdir(parents=True, exist_ok=True)
    if a.keep_runs:
        runs = out / "runs"
        runs.mkdir(exist_ok=True)
        tmp = None
    else:
        tmp = tempfile.TemporaryDirectory(prefix="radiator_study_")
        runs = Path(tmp.name)

    t_start = time.monotonic()
    timings: dict = {"photons": a.photons}
    # 1. The BRDF table of the Z-302 micro geometry, where the *-brdf scenes read it.
    # With its Mueller matrices (mueller.csv beside brdf.csv): the Z-302 walls
    # are Fresnel, so the table walls keep the polarisation as the micro walls do.
    wall, cpu = timed_run([roks, "brdf", str(MICRO_SCENE.relative_to(REPO)), "--polarisation", "mueller",
                "--out", str(TABLE_DIR.relative_to(REPO)), "-q"], str(MICRO_SCENE))
    bs = read_json(TABLE_DIR / "summary.json")
    timings["brdf"] = {
        "wall": wall,
        "cpu": cpu,
        "seconds": float(sum(i["seconds"] for i in bs["incidence"])),
        "photons_per_angle": int(bs["incidence"][0]["photons"]),
        "angles": len(bs["incidence"]),
    }
    # 2. The four cavity scenes.
    rows: list[dict] = []
    extra: dict = {}
    try:
        for scene, model, defect in SCENES:
            rd = runs / scene
            wall, cpu = timed_run([roks, "trace", f"scenes/{scene}.toml", "--out", str(rd), "--photons",
                        str(a.photons), "-q"], scene)
            summary = read_json(rd / "summary.json")
            timings[scene] = {
                "wall": wall,
                "cpu": cpu,
                "seconds": float(sum(s["seconds"] for s in summary["sources"])),
                "summary_seconds": float(summary.get("seconds", float("nan"))),
            }
            rows.extend(rows_from_summary(scene, model, defect, summary))
            src = summary["sources"]
            extra[scene] = {
                "max_lost": max(float(s["lost"]) for s in src),
                "max_missed": max(float(s["missed"]) for s in src),
                "zero_reflectance": sum(float(s["reflectance"]) == 0.0 for s in src),
                "max_rel_stderr": max(float(s["reflectance_stderr"]) / float(s["reflectance"])
                                      if float(s["reflectance"]) > 0 else float("inf")
                                      for s in src),
                "absorbed_plus_reflectance_min": min(
                    float(s["reflectance"]) + sum(s["absorbed"].values()) + float(s["lost"])
                    + float(s["missed"]) for s in src),
                "absorbed_plus_reflectance_max": max(
                    float(s["reflectance"]) + sum(s["absorbed"].values()) + float(s["lost"])
                    + float(s["missed"]) for s in src),
            }
    finally:
        if tmp is not None:
            tmp.cleanup()
    timings["total_wall"] = time.monotonic() - t_start
    timings["checks"] = extra

    write_csv(out / "radiator.csv", rows)
    (out / "timings.json").write_text(json.dumps(timings, indent=1) + "\n")
    report(out, rows, timings, a.photons)
    print(
        f"\ntotal time {timings['total_wall']:.0f} s; wrote {out / 'radiator.csv'}, "
        f"{out / 'radiator.md'}, {out / 'radiator.png'}, {out / 'timings.json'}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
