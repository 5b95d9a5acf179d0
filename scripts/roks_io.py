"""Small helpers shared by the study scripts: run a command, read roks's CSV files."""

from __future__ import annotations

import csv
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def run(cmd: list, who: str, echo: bool = True, cwd: Path | None = None) -> tuple[str, float]:
    """Run `cmd` (items converted to str); returns (stdout, wall seconds).

    On failure, writes the command's output to stderr and exits naming `who`
    and the command.
    """
    cmd = [str(c) for c in cmd]
    if echo:
        print("+ " + " ".join(cmd), file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        sys.stderr.write(p.stdout + p.stderr)
        raise SystemExit(f"{who}: failed: {' '.join(cmd)}")
    return p.stdout, dt


def read_columns(path: Path) -> dict[str, np.ndarray]:
    """A CSV file of numbers (brdf.csv, inplane.csv) as one float array per column."""
    with Path(path).open(newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
