"""Edge-effect study of the micro geometry (Klass et al. 2014, Fig. 2).

The paper checks whether a finite micro geometry is large enough by putting
either a perfect absorber or the same material beside the substrate: when
both give close reflectances, edge effects are negligible. It reports that
100 ellipsoids on 30 x 30 are fine up to 85 degrees incidence (absorbing and
reflecting walls differ by 1-6 %), while 36 ellipsoids on 15 x 15 are fine
only up to 30 degrees. roks also has periodic cells (no edges at all), which
this study adds as the edge-free reference.

Runs `roks brdf` on the six scenes scenes/edge-{30,15}-{absorbing,reflecting,
periodic}.toml and writes, in --out:

* edge_study.csv  one row per scene and incidence angle
* edge_study.md   reflectance table and relative differences
* edge_study.png  reflectance vs incidence angle, and the relative difference

The per-scene roks output folders go to a temporary folder that is deleted
afterwards, unless --keep-runs is given (then they stay in --out/runs/).

Needs numpy and matplotlib (scripts/setup_venv.sh).
"""

from __future__ import annotations

import argparse
import csv
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
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run  # noqa: E402
from roks_tools.summary import BrdfSummary, read_summary  # noqa: E402

REPO = repo_root()
SCENES_DIR = REPO / "scenes"
CELLS = ("30x30", "15x15")
EDGES = ("absorbing", "reflecting", "periodic")
# The paper's reported spread between absorbing and reflecting walls for 30 x 30.
PAPER_BAND = (1.0, 6.0)
COLOURS = {"absorbing": "tab:red", "reflecting": "tab:blue", "periodic": "tab:green"}
CELL_STYLE = {"30x30": "-", "15x15": "--"}
CELL_LABEL = {"30x30": "100 bumps on 30 x 30", "15x15": "36 bumps on 15 x 15"}


def scene_name(cell: str, edges: str) -> str:
    return f"edge-{cell.split('x')[0]}-{edges}"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--roks",
        default=str(default_roks()),
        help="path to the roks binary (default: %(default)s)",
    )
    p.add_argument(
        "--photons",
        type=int,
        default=1_000_000,
        help="photons per incidence angle (default: %(default)s)",
    )
    add_out_argument(p, "edge_study")
    p.add_argument(
        "--scenes",
        default=str(SCENES_DIR),
        help="folder holding the edge-*.toml scenes (default: the repo's scenes/)",
    )
    p.add_argument(
        "--keep-runs",
        action="store_true",
        help="keep the per-scene roks output folders in OUT/runs/ "
        "(default: a temporary folder, deleted at the end)",
    )
    p.add_argument(
        "--replot",
        action="store_true",
        help="do not run roks: redraw OUT/edge_study.md and .png from OUT/edge_study.csv "
        "(give the --photons it was made with, for the labels)",
    )
    a = p.parse_args(argv)
    check_output(a.out, a.overwrite_committed)
    if a.photons <= 0:
        p.error("--photons must be > 0")
    return a


def run_roks(roks: str, scene: Path, out: Path, photons: int) -> BrdfSummary:
    done = run([roks, "brdf", scene, "--out", out, "--photons", photons, "-q"], f"edge_study: {scene}")
    summary = read_summary(out / "summary.json")
    if not isinstance(summary, BrdfSummary):
        raise RunError(f"{out / 'summary.json'}: not a `roks brdf` summary")
    print(f"  {done.wall_s:.1f} s", file=sys.stderr, flush=True)
    return summary


def rows_from_summary(scene: str, cell: str, edges: str, summary: BrdfSummary) -> list[dict]:
    if summary.edges not in (None, edges):
        raise RunError(f"{scene}: summary says edges={summary.edges}, expected {edges}")
    rows = []
    for inc in summary.incidence:
        rows.append(
            {
                "scene": scene,
                "cell": cell,
                "edges": edges,
                "theta_deg": float(inc.theta_deg),
                "reflectance": float(inc.reflectance),
                "reflectance_stderr": float(inc.reflectance_stderr),
                "lost": float(inc.lost),
                "mean_bounces": float(inc.mean_bounces),
            }
        )
    if not rows:
        raise RunError(f"{scene}: no incidence results")
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    cols = ["scene", "cell", "edges", "theta_deg", "reflectance", "reflectance_stderr", "lost",
            "mean_bounces"]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow(
                {
                    **r,
                    "theta_deg": f"{r['theta_deg']:g}",
                    "reflectance": f"{r['reflectance']:.8f}",
                    "reflectance_stderr": f"{r['reflectance_stderr']:.2e}",
                    "lost": f"{r['lost']:.8f}",
                    "mean_bounces": f"{r['mean_bounces']:.4f}",
                }
            )


def tabulate(rows: list[dict]) -> tuple[np.ndarray, dict]:
    """Angles and {(cell, edges): (reflectance, stderr, lost)} arrays on a common grid."""
    thetas = sorted({r["theta_deg"] for r in rows})
    theta = np.array(thetas)
    data = {}
    for cell in CELLS:
        for edges in EDGES:
            sel = {r["theta_deg"]: r for r in rows if r["cell"] == cell and r["edges"] == edges}
            missing = [t for t in thetas if t not in sel]
            if missing:
                raise RunError(f"{cell} {edges}: no result at theta {missing}")
            data[cell, edges] = (
                np.array([sel[t]["reflectance"] for t in thetas]),
                np.array([sel[t]["reflectance_stderr"] for t in thetas]),
                np.array([sel[t]["lost"] for t in thetas]),
            )
    return theta, data


def rel_diff(data: dict, cell: str) -> tuple[np.ndarray, np.ndarray]:
    """(reflecting - absorbing) / reflecting in percent, with its standard error."""
    ra, sa, _ = data[cell, "absorbing"]
    rr, sr, _ = data[cell, "reflecting"]
    d = 100.0 * (rr - ra) / rr
    # d = 100 (1 - ra/rr), errors propagated as if independent. Both runs use the same
    # tracing seed (same start points), so their errors correlate and this overstates it.
    se = 100.0 * (ra / rr) * np.sqrt((sa / ra) ** 2 + (sr / rr) ** 2)
    return d, se


def markdown(theta: np.ndarray, data: dict, photons: int) -> str:
    head = ["theta (deg)"]
    for cell in CELLS:
        for edges in EDGES:
            head.append(f"{cell} {edges}")
    head += ["30x30 diff (%)", "15x15 diff (%)"]
    lines = [
        f"Reflectance (directional-hemispherical) vs incidence angle, {photons:,} photons per "
        "angle (standard error <= "
        f"{max(float(np.max(v[1])) for v in data.values()):.1e}). "
        "diff = (reflecting - absorbing) / reflecting.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "|".join(["---:"] * len(head)) + "|",
    ]
    diffs = {cell: rel_diff(data, cell)[0] for cell in CELLS}
    for i, t in enumerate(theta):
        cells = [f"{t:g}"]
        for cell in CELLS:
            for edges in EDGES:
                cells.append(f"{data[cell, edges][0][i]:.4f}")
        cells += [f"{diffs[c][i]:.1f}" for c in CELLS]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot(path: Path, theta: np.ndarray, data: dict, photons: int) -> None:
    fig, (ax1, ax2) = plt.subplots(
        2, 1, figsize=(9, 9.5), sharex=True, gridspec_kw={"height_ratios": [3, 2]}
    )
    for cell in CELLS:
        for edges in EDGES:
            r, se, _ = data[cell, edges]
            ax1.errorbar(
                theta, r, yerr=se, color=COLOURS[edges], linestyle=CELL_STYLE[cell],
                marker="o" if cell == "30x30" else "s", markersize=3.5, capsize=2, linewidth=1.4,
                label=f"{CELL_LABEL[cell]}, {edges} {'edges' if edges == 'periodic' else 'walls'}",
            )
    ax1.set_ylabel("reflectance (reflected / incident power)")
    ax1.set_title(
        "Edge effects of a finite micro geometry (Klass et al. 2014, Fig. 2 set-up)\n"
        "ellipsoid bumps (radii 2.5-3.5, heights 0.8-4.8, RMS height about 1),\n"
        f"per-bounce reflectance 0.8, {photons:,} photons per angle"
    )
    ax1.grid(True, alpha=0.3)
    ax1.legend(fontsize=8.5, loc="lower left")
    ax1.text(0.66, 0.02, "error bars: ±1 standard error (smaller than the markers)",
             transform=ax1.transAxes, ha="center", va="bottom", fontsize=8, color="0.35")

    ax2.axhspan(*PAPER_BAND, color="0.85", label="paper (Fig. 2): 30 x 30 walls differ by 1-6 % up to 85°")
    for cell in CELLS:
        d, se = rel_diff(data, cell)
        ax2.errorbar(
            theta, d, yerr=se, color="black", linestyle=CELL_STYLE[cell],
            marker="o" if cell == "30x30" else "s", markersize=3.5, capsize=2, linewidth=1.4,
            label=f"{CELL_LABEL[cell]}",
        )
    ax2.axvline(30, color="0.5", linestyle=":", linewidth=1)
    ax2.text(29.5, 0.5, "30°: paper's limit\nfor 15 x 15", transform=ax2.get_xaxis_transform(),
             fontsize=8, color="0.35", ha="right", va="center")
    ax2.axhline(0, color="0.5", linewidth=0.8)
    ax2.set_xlabel("incidence angle θᵢ from the surface normal (degrees)")
    ax2.set_ylabel("(reflecting - absorbing) / reflecting (%)")
    ax2.set_title("Relative difference between reflecting and absorbing walls", fontsize=10)
    ax2.grid(True, alpha=0.3)
    ax2.legend(fontsize=8.5, loc="upper left")
    ax2.set_xlim(-2, 87)
    ax2.set_xticks(np.arange(0, 90, 10))
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def read_csv(path: Path) -> list[dict]:
    try:
        with path.open(newline="") as f:
            raw = list(csv.DictReader(f))
    except OSError as e:
        raise RunError(f"cannot read {path}: {e}")
    num = ("theta_deg", "reflectance", "reflectance_stderr", "lost", "mean_bounces")
    return [{k: (float(v) if k in num else v) for k, v in r.items()} for r in raw]


def report(out: Path, rows: list[dict], photons: int) -> None:
    theta, data = tabulate(rows)
    md = markdown(theta, data, photons)
    (out / "edge_study.md").write_text(md)
    plot(out / "edge_study.png", theta, data, photons)
    print(md, end="")


@command("edge_study")
def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    if a.replot:
        out = Path(a.out)
        report(out, read_csv(out / "edge_study.csv"), a.photons)
        return 0
    roks = a.roks
    if not Path(roks).exists() and shutil.which(roks) is None:
        raise UsageError(f"roks binary not found: {roks} (build it: cargo build --release)")
    scenes_dir = Path(a.scenes)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    if a.keep_runs:
        runs = out / "runs"
        runs.mkdir(exist_ok=True)
        tmp = None
    else:
        tmp = tempfile.TemporaryDirectory(prefix="edge_study_")
        runs = Path(tmp.name)

    rows: list[dict] = []
    t0 = time.monotonic()
    try:
        for cell in CELLS:
            for edges in EDGES:
                name = scene_name(cell, edges)
                scene = scenes_dir / f"{name}.toml"
                if not scene.is_file():
                    raise RunError(f"scene not found: {scene}")
                summary = run_roks(roks, scene, runs / name, a.photons)
                rows.extend(rows_from_summary(name, cell, edges, summary))
    finally:
        if tmp is not None:
            tmp.cleanup()
    elapsed = time.monotonic() - t0

    write_csv(out / "edge_study.csv", rows)
    report(out, rows, a.photons)
    print(
        f"\nroks time {elapsed:.0f} s; wrote {out / 'edge_study.csv'}, "
        f"{out / 'edge_study.md'}, {out / 'edge_study.png'}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
