"""Scaling of the micro tracer: bump count, bump size and height-field resolution, 1 and 2 threads.

    .venv/bin/python scripts/scaling.py [--roks target/release/roks] [--out scaling] [--quick]
        [--callgrind] [--kinds bumps,radius,field]

Bumps: the default scene's ellipsoids (radii 2.5-3.5, heights 0.8-4.8) at
constant density, N = 36, 100, 1000, 10 000, 100 000 bumps on a periodic cell
of side 3 sqrt(N) (30 for 100 bumps). Height fields: Gaussian, sigma 1,
tau 8 pitches, 256² to 4096² squares of pitch 0.25. Bump radius: the
default scene (100 such bumps on a 30 x 30 cell) with every radius set to
R = 3, 15, 30, 60, 120, up to four periods wide (hundreds of periodic copies
over every grid cell). Each scene is traced at
60 degrees with `roks brdf` (10^6 photons; 2x10^5 for the largest) with
`--threads 1` and `--threads 2`. Recorded: segments per second (from
summary.json), intersection tests per segment (summary.json: quadrics whose
ray polynomial was formed, or height-field squares tested), peak memory
(maximum resident set size of the roks process, from `/usr/bin/time -f %M`), and for bumps the candidate solids per acceleration-grid cell (`roks stats`,
the quadric bodies a flight through one grid cell may test). Writes
OUT/report.md and OUT/scaling.json. Wall-clock speeds depend on what else
the machine runs; compare within one run. Each row's one-thread rate is also
given relative to 100 bumps, radius 3 or the 256² field (the flat-cost targets:
100 000 bumps >= 0.6 of 100 bumps' rate, a 4096² field >= 0.5 of
256²'s). --callgrind adds instructions per segment (valgrind's callgrind,
one thread, the difference of two photon counts over the difference of
their segments, so start-up and output do not count), immune to the
machine's noise.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from roks_tools.errors import RunError, UsageError, command
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run as run_cmd

ROOT = repo_root()


def bump_scene(n: int) -> str:
    side = 3.0 * math.sqrt(n)
    return f"""name = "bumps-{n}"
[surface]
size = [{side!r}, {side!r}]
edges = "periodic"
material = "paint"
[materials.paint]
reflectance = 0.8
[[bumps]]
shape = "ellipsoid"
count = {n}
radius = [2.5, 3.5]
height = [0.8, 4.8]
seed = 1
[light]
theta_deg = [60]
phi_deg = 0.0
"""


def radius_scene(r: int) -> str:
    """The default scene's 100 bumps, every radius `r`, on its 30 x 30 cell."""
    return bump_scene(100).replace("radius = [2.5, 3.5]", f"radius = [{float(r)!r}, {float(r)!r}]")


def field_scene(n: int) -> str:
    side = 0.25 * n
    return f"""name = "field-{n}"
[surface]
size = [{side!r}, {side!r}]
edges = "periodic"
material = "paint"
heightfield = {{ gaussian = {{ sigma = 1.0, tau = 2.0 }}, resolution = {n}, seed = 1 }}
[materials.paint]
reflectance = 0.8
[light]
theta_deg = [60]
phi_deg = 0.0
"""


def measure(roks: Path, scene: Path, threads: int, photons: int, out: Path) -> dict:
    done = run_cmd([roks, "brdf", scene, "--photons", photons, "--threads", threads, "--out", out, "-q",
                    "--stats-resolution", "64"], "scaling", echo=False)
    inc = json.loads((out / "summary.json").read_text())["incidence"][0]
    return {"segments_per_second": inc["segments_per_second"], "seconds": inc["seconds"],
            "segments_per_photon": inc["segments"] / inc["photons"], "max_rss_mb": done.max_rss_mb,
            "tests_per_segment": inc["tests_per_segment"]}


def instructions_per_segment(roks: Path, scene: Path, out: Path, photons: tuple[int, int]) -> float:
    """Callgrind's instruction count at two photon counts, differenced, per segment."""
    counts, segs = [], []
    for n in photons:
        d = out / f"cg_{n}"
        cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}/cg.out", str(roks), "brdf",
               str(scene), "--photons", str(n), "--threads", "1", "--out", str(d), "-q", "--stats-resolution", "16"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            sys.stderr.write(p.stderr)
            raise RunError(f"failed: {' '.join(cmd)}")
        counts.append(int(re.search(r"Collected : (\d+)", p.stderr).group(1)))
        segs.append(json.loads((d / "summary.json").read_text())["incidence"][0]["segments"])
    return (counts[1] - counts[0]) / (segs[1] - segs[0])


def candidates(roks: Path, scene: Path) -> float | None:
    p = subprocess.run([str(roks), "stats", str(scene), "--resolution", "64"], capture_output=True, text=True)
    m = re.search(r"solids\s+\d+ \((\d+) tested per flight, ([\d.]+) per grid cell\)", p.stdout + p.stderr)
    return float(m.group(2)) if m else None


@command("scaling")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", type=Path, default=default_roks())
    add_out_argument(ap, "scaling")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--callgrind", action="store_true", help="also count instructions per segment")
    ap.add_argument("--kinds", default="bumps,radius,field",
                    help="comma-separated: bumps (count), radius (bump size), field (height-field resolution)")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    kinds = set(a.kinds.split(","))
    if not kinds <= {"bumps", "radius", "field"}:
        raise UsageError(f"--kinds {a.kinds}: the kinds are bumps, radius, field")
    a.out.mkdir(parents=True, exist_ok=True)
    bumps = [36, 100, 1000] if a.quick else [36, 100, 1000, 10_000, 100_000]
    fields = [256, 512] if a.quick else [256, 1024, 4096]
    radii = [3, 30, 120] if a.quick else [3, 15, 30, 60, 120]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for key, kind, sizes, make in (("bumps", "bumps", bumps, bump_scene),
                                       ("radius", "bump radius", radii, radius_scene),
                                       ("field", "height field", fields, field_scene)):
            if key not in kinds:
                continue
            for n in sizes:
                scene = tmp / f"{key}{n}.toml"
                scene.write_text(make(n))
                photons = 200_000 if (kind == "bumps" and n >= 100_000) or (kind == "height field" and n >= 4096) \
                    else 1_000_000
                if a.quick:
                    photons = 100_000
                row = {"kind": kind, "n": n, "photons": photons,
                       "candidates_per_cell": candidates(a.roks, scene) if kind != "height field" else None}
                for t in (1, 2):
                    row[f"threads_{t}"] = measure(a.roks, scene, t, photons, tmp / f"out_{key}{n}_{t}")
                    print(f"{kind} {n} threads {t}: {row[f'threads_{t}']['segments_per_second'] / 1e6:.2f} M seg/s, "
                          f"{row[f'threads_{t}']['max_rss_mb']:.0f} MB", file=sys.stderr)
                if a.callgrind:
                    row["instructions_per_segment"] = instructions_per_segment(
                        a.roks, scene, tmp, (4_000, 20_000) if a.quick else (20_000, 100_000))
                rows.append(row)
    lines = ["# Scaling of the micro tracer", "",
             "`scripts/scaling.py`: 60 degrees, `roks brdf`, segments per second from summary.json, "
             "peak memory of the roks process (`/usr/bin/time -f %M`). Bumps at constant density (cell side 3 sqrt(N)); height fields "
             "Gaussian, tau = 8 pitches. Bump radius: 100 bumps of radius R on a 30 x 30 cell. Tests/segment: quadrics whose ray polynomial was formed (bumps) "
             "or squares of two triangles tested (height fields).", "",
             "| surface | size | photons | segments/photon | M segments/s, 1 thread | vs 100 bumps / R 3 / 256² | 2 threads "
             "| speed-up | peak memory (MB) | tests/segment | candidate solids per grid cell | instructions/segment |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    # The reference of each kind: 100 bumps, radius 3 and the 256² field (else the kind's first row).
    reference = {"bumps": 100, "bump radius": 3, "height field": 256}
    smallest = {}
    for r in rows:
        if r["n"] == reference[r["kind"]] or r["kind"] not in smallest:
            smallest[r["kind"]] = r["threads_1"]["segments_per_second"]
    for r in rows:
        t1, t2 = r["threads_1"], r["threads_2"]
        size = {"bumps": f"{r['n']} bumps", "bump radius": f"R = {r['n']}"}.get(r["kind"], f"{r['n']}²")
        cand = f"{r['candidates_per_cell']:.1f}" if r["candidates_per_cell"] is not None else "-"
        ips = f"{r['instructions_per_segment']:.0f}" if "instructions_per_segment" in r else "-"
        lines.append(f"| {r['kind']} | {size} | {r['photons']:.0e} | {t1['segments_per_photon']:.2f} | "
                     f"{t1['segments_per_second'] / 1e6:.2f} | "
                     f"{t1['segments_per_second'] / smallest[r['kind']]:.2f} | "
                     f"{t2['segments_per_second'] / 1e6:.2f} | "
                     f"{t2['segments_per_second'] / t1['segments_per_second']:.2f} | {t2['max_rss_mb']:.0f} | "
                     f"{t1['tests_per_segment']:.2f} | {cand} | {ips} |")
    (a.out / "report.md").write_text("\n".join(lines) + "\n")
    (a.out / "scaling.json").write_text(json.dumps(rows, indent=1))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
