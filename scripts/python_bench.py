#!/usr/bin/env python3
"""Small runs in-process against the command line: a benchmark, not a test.

Runs the default scene at one incidence (60 degrees), 4,096 photons a run,
`--runs` times (100) through the module (`roks.brdf`, the result's arrays
read) and as many times through the command line (`roks brdf --photons 4096
--theta 60 --out TMP -q`, one process each, the folder then read with
`roks.load`). The two routes alternate in batches of `--batch` runs (10),
in-process first in even batches and the command first in odd ones, so that
the load of a shared, noisy machine falls on both alike. Prints the median
and mean time of a run of each route, the command's time without its folder
read, and the ratios of the medians (overall, and the median of the ratios
taken batch by batch). `--stats-resolution N` gives both routes the
surface statistics' grid (default 512, as the command line's default: at
4,096 photons the statistics of the 512 x 512 height map are most of a
run's time; 16 leaves the tracing).

    .venv/bin/python scripts/python_bench.py                     # the wheel's roks command
    .venv/bin/python scripts/python_bench.py --roks target/release/roks
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import roks

PHOTONS = 4096
THETA = 60.0


def in_process(scene, stats: int | None) -> float:
    t = time.perf_counter()
    r = roks.brdf(scene, stats_resolution=stats)
    _ = r.reflectance, r.brdf  # the arrays a caller reads
    return time.perf_counter() - t


def by_command(binary: str, out: Path, stats: int | None) -> tuple[float, float]:
    """(run and read, run alone) seconds of one `roks brdf` process."""
    extra = [] if stats is None else ["--stats-resolution", str(stats)]
    t = time.perf_counter()
    subprocess.run([binary, "brdf", "--photons", str(PHOTONS), "--theta", f"{THETA:g}", *extra, "--out", str(out),
                    "--force", "-q"], check=True)
    ran = time.perf_counter() - t
    r = roks.load(out)
    _ = r.reflectance, r.brdf
    return time.perf_counter() - t, ran


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100, help="runs of each route (default 100)")
    ap.add_argument("--batch", type=int, default=10, help="runs of one route in a row (default 10)")
    ap.add_argument("--roks", help="the command line (default: the `roks` command beside this Python, "
                                   "else $ROKS_BIN, else roks on PATH)")
    ap.add_argument("--stats-resolution", type=int, help="the surface statistics' grid of both routes "
                                                          "(default: the command line's, 512)")
    args = ap.parse_args()
    stats = args.stats_resolution
    binary = args.roks or shutil.which("roks", path=str(Path(sys.executable).parent)) \
        or os.environ.get("ROKS_BIN") or shutil.which("roks")
    if binary is None:
        print("python_bench: no roks command found: give --roks", file=sys.stderr)
        return 2
    scene = roks.Scene.load().override(photons=PHOTONS, theta_deg=[THETA])
    version = subprocess.run([binary, "--version"], capture_output=True, text=True, check=True).stdout.strip()
    print(f"python_bench: {args.runs} runs of {PHOTONS} photons at {THETA:g} deg each way, batches of "
          f"{args.batch}, statistics grid {stats or 512}; module {roks.__file__}; command {binary} ({version}); "
          f"{os.cpu_count()} cores, {platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()}, load average {os.getloadavg()[0]:.1f}")

    in_process(scene, stats)  # warm-up: page in the module and the scene
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        by_command(binary, out, stats)
        inp: list[float] = []
        cmd: list[float] = []
        cmd_run: list[float] = []
        ratios: list[float] = []
        batches = -(-args.runs // args.batch)
        for b in range(batches):
            n = min(args.batch, args.runs - b * args.batch)
            a: list[float] = []
            c: list[tuple[float, float]] = []
            for first in ([0, 1] if b % 2 == 0 else [1, 0]):
                if first == 0:
                    a = [in_process(scene, stats) for _ in range(n)]
                else:
                    c = [by_command(binary, out, stats) for _ in range(n)]
            inp += a
            cmd += [x for x, _ in c]
            cmd_run += [y for _, y in c]
            ratios.append(statistics.median(x for x, _ in c) / statistics.median(a))

    def line(name: str, xs: list[float]) -> str:
        return (f"{name:<28} median {1e3 * statistics.median(xs):7.1f} ms, mean {1e3 * statistics.mean(xs):7.1f} ms, "
                f"min {1e3 * min(xs):7.1f} ms, max {1e3 * max(xs):7.1f} ms")

    print(line("in-process roks.brdf", inp))
    print(line("command + roks.load", cmd))
    print(line("command alone", cmd_run))
    print(f"command / in-process: {statistics.median(cmd) / statistics.median(inp):.2f}x (medians), "
          f"{statistics.median(ratios):.2f}x (median of the {len(ratios)} batches' ratios, "
          f"{min(ratios):.2f}-{max(ratios):.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
