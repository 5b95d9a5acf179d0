"""The biconical radiator with polarised transport: cavity reflectance vs beam offset.

    .venv/bin/python scripts/radiator_polarisation.py [--roks target/release/roks] [--photons N]

The Z-302 walls (n = 1.6 + 0.2i) polarise at every bounce, and the cavity
reflects light after several bounces, so the unpolarised weight per bounce
((Rs + Rp)/2, `--no-polarisation`) is not the physics. For the ideal cone and
the apex defect, with walls traced down into the micro geometry at every hit
(scenes/radiator.toml, radiator-defect.toml) and with walls sampling the
Z-302 table (radiator-brdf.toml, radiator-defect-brdf.toml, with the
table's Mueller matrices: `roks brdf scenes/z302-micro.toml --polarisation
mueller` into out/z302/, as scripts/radiator_study.py writes it), runs
`roks trace` with

* polarised transport, unpolarised beam (the default);
* polarised transport, beams linearly polarised along y and along x (the beam
  is swept along x, so y is azimuthal and x radial to the axis);
* `--no-polarisation` (the old approximation), unpolarised beam;
* table walls only: the table without its Mueller matrices (depolarising
  walls; out/z302-depolarising/).

Each run uses its own seed (1 + run number), so the runs are independent and
differences are compared with the root sum of squares of the standard errors.
Writes OUT/polarisation.md, polarisation.csv and
polarisation.png (reflectance vs offset, and the defect / ideal ratio).
"""

from __future__ import annotations

import argparse
import csv
import re
import tempfile
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roks_tools.errors import command
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run
from roks_tools.summary import read_summary

REPO = repo_root()

SCENES = [  # (scene, walls, defect)
    ("radiator", "micro", False),
    ("radiator-defect", "micro", True),
    ("radiator-brdf", "table", False),
    ("radiator-defect-brdf", "table", True),
]
# (label, [[sources]] polarisation, extra options, table with its Mueller matrices)
CASES = [
    ("polarised, unpolarised beam", None, [], True),
    ("polarised, beam linear along y", '"s"', [], True),
    ("polarised, beam linear along x", '"p"', [], True),
    ("unpolarised approximation", None, ["--no-polarisation"], True),
    ("polarised, depolarising table", None, [], False),
]


def scene_text(scene: str, state: str | None, mueller: bool) -> str:
    """The scene file with the beam's state and the table folder set; paths made absolute."""
    text = (REPO / "scenes" / f"{scene}.toml").read_text()
    text = text.replace('micro = "z302-micro.toml"', f'micro = "{REPO / "scenes" / "z302-micro.toml"}"')
    table = REPO / "out" / ("z302" if mueller else "z302-depolarising") / "brdf.csv"
    text = re.sub(r'brdf = "\.\./out/z302/brdf\.csv"', f'brdf = "{table}"', text)
    if state is not None:
        text = text.replace("[[sources]]\n", f"[[sources]]\npolarisation = {state}\n", 1)
    return text


@command("radiator_polarisation")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", default=str(default_roks()))
    ap.add_argument("--photons", type=int, default=100_000)
    ap.add_argument("--replot", action="store_true", help="only redraw from polarisation.csv")
    add_out_argument(ap, "radiator_polarisation")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    res = a.out
    res.mkdir(parents=True, exist_ok=True)
    if a.replot:
        with (res / "polarisation.csv").open(newline="") as f:
            rows = [{k: (v == "True" if k == "defect" else v if k in ("scene", "walls", "case") else float(v))
                     for k, v in r.items()} for r in csv.DictReader(f)]
        report(res, rows, a.photons)
        return 0
    # The Z-302 tables: plain (depolarising walls) and with Mueller matrices.
    run([a.roks, "brdf", REPO / "scenes" / "z302-micro.toml", "--out", REPO / "out" / "z302-depolarising",
         "-q"], "radiator_polarisation")
    run([a.roks, "brdf", REPO / "scenes" / "z302-micro.toml", "--polarisation", "mueller",
         "--out", REPO / "out" / "z302", "-q"], "radiator_polarisation")
    rows = []
    seed = 1
    with tempfile.TemporaryDirectory(prefix="radiator_pol_") as tmp:
        for scene, walls, defect in SCENES:
            for label, state, extra, mueller in CASES:
                if walls == "micro" and not mueller:
                    continue  # the depolarising-table case is for table walls only
                seed += 1
                path = Path(tmp) / f"{scene}-{seed}.toml"
                path.write_text(scene_text(scene, state, mueller))
                out = Path(tmp) / f"out-{seed}"
                secs = run([a.roks, "trace", path, "--photons", a.photons, "--seed", seed,
                            "--out", out, "-q", *extra], "radiator_polarisation").wall_s
                for s in read_summary(out / "summary.json").sources:
                    st = s.stokes or [s.reflectance, 0, 0, 0]
                    rows.append({
                        "scene": scene, "walls": walls, "defect": defect, "case": label,
                        "offset_mm": float(s.position[0]),
                        "reflectance": float(s.reflectance),
                        "stderr": float(s.reflectance_stderr),
                        "s1_over_s0": float(st[1]) / float(st[0]) if float(st[0]) > 0 else 0.0,
                        "seconds": secs,
                    })
    with (res / "polarisation.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    report(res, rows, a.photons)
    return 0


def series(rows, walls, defect, case):
    sel = [r for r in rows if r["walls"] == walls and r["defect"] == defect and r["case"] == case]
    sel.sort(key=lambda r: r["offset_mm"])
    return (np.array([r["offset_mm"] for r in sel]), np.array([r["reflectance"] for r in sel]),
            np.array([r["stderr"] for r in sel]), np.array([r["s1_over_s0"] for r in sel]))


def report(res: Path, rows: list[dict], photons: int) -> None:
    lines = [
        "# The radiator with polarised transport",
        "",
        f"`scripts/radiator_polarisation.py --photons {photons}` ({photons} photons per beam position, "
        "24 positions, independent seeds per run). Mean cavity reflectance over the beam positions "
        "(± its standard error), the ratio to the polarised run with an unpolarised beam (z of the "
        "difference of the means), the defect / ideal ratio of the means, and the mean S1/S0 of the "
        "light leaving (its own direction's frame, ẑ × d: S1 > 0 azimuthal, S1 < 0 radial for the "
        "light leaving upward).",
        "",
        "| walls | case | ideal cone | vs polarised (z) | apex defect | vs polarised (z) | defect / ideal | S1/S0 ideal |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for walls in ("micro", "table"):
        base = {d: series(rows, walls, d, CASES[0][0]) for d in (False, True)}
        for label, _, _, mueller in CASES:
            if walls == "micro" and not mueller:
                continue
            cells = []
            means = {}
            for d in (False, True):
                _, r, e, _ = series(rows, walls, d, label)
                m, se = r.mean(), np.sqrt((e ** 2).sum()) / len(e)
                b = base[d]
                bm, bse = b[1].mean(), np.sqrt((b[2] ** 2).sum()) / len(b[2])
                z = (m - bm) / np.hypot(se, bse) if label != CASES[0][0] else 0.0
                means[d] = (m, se)
                cells += [f"{m:.3e} ± {se:.1e}", f"{m / bm:.3f} ({z:+.1f})" if label != CASES[0][0] else "1"]
            ratio = means[True][0] / means[False][0]
            rerr = ratio * np.hypot(means[True][1] / means[True][0], means[False][1] / means[False][0])
            s1 = series(rows, walls, False, label)[3].mean()
            lines.append(f"| {walls} | {label} | {cells[0]} | {cells[1]} | {cells[2]} | {cells[3]} "
                         f"| {ratio:.2f} ± {rerr:.2f} | {s1:+.2f} |")
    lines += ["", "![reflectance vs beam offset](polarisation.png)", ""]
    (res / "polarisation.md").write_text("\n".join(lines))
    print("\n".join(lines))

    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2))
    colours = dict(zip([c[0] for c in CASES[:4]], ["C0", "C2", "C3", "C7"]))
    for walls, style in (("micro", "-"), ("table", "--")):
        for label, _, _, mueller in CASES[:4]:
            for d, ax in ((False, axes[0]), (True, axes[1])):
                x, r, e, _ = series(rows, walls, d, label)
                ax.errorbar(x, r, yerr=e, ls=style, marker=".", capsize=0, lw=1,
                            color=colours[label], label=f"{walls} walls: {label}")
            x, ri, ei, _ = series(rows, walls, False, label)
            _, rd, ed, _ = series(rows, walls, True, label)
            axes[2].plot(x, rd / ri, ls=style, marker=".", color=colours[label],
                         label=f"{walls} walls: {label}")
    for ax, title in ((axes[0], "(a) ideal cone"), (axes[1], "(b) apex defect")):
        ax.set_yscale("log")
        ax.set_xlabel("beam offset from the axis (mm)")
        ax.set_ylabel("cavity reflectance (± 1 standard error)")
        ax.set_title(title)
    axes[2].set_xlabel("beam offset from the axis (mm)")
    axes[2].set_ylabel("defect / ideal")
    axes[2].set_title("(c) defect / ideal cone")
    axes[2].legend(fontsize=7, loc="upper left")
    fig.suptitle("Biconical radiator, Z-302 walls (n = 1.6 + 0.2i): polarised transport against the unpolarised approximation")
    fig.tight_layout()
    fig.savefig(res / "polarisation.png", dpi=110)


if __name__ == "__main__":
    raise SystemExit(main())
