"""Memory stays flat over 1,000 small runs in one process.

1,000 tiny runs of the default scene (64 photons at one incidence, a 16 x 16
statistics grid) through `roks.brdf`, each result dropped. The resident set
(`/proc/self/statm`) is read after run 100, when the allocators and the
module have reached their working size, and after run 1,000. The growth
between them must stay below the bound a leak would cross: a result holds
at least the numpy arrays it hands out (their `nbytes` summed over the
result's array attributes, `result_bytes`), so a leak of one result per run
grows the resident set by at least 900 x result_bytes over those 900 runs.
The bound is half of that, plus 8 MiB for the allocators' own slack (glibc
keeps freed arenas, numpy caches small blocks; measured growth of the
fixed code is reported on failure). `test_a_leak_is_seen` runs the same
loop keeping every result, to run 400 (the bound taken over its 300 runs
from run 100, to keep it short), and checks the growth then exceeds the
bound, so the bound is one a leak of one result per run does cross.

Measured on 2026-12-06 (2 cores, shared): 2.2, 0.0 and 0.2 MiB growth from
run 100 to 1,000 in three runs of the test, against a bound of 87.8 MiB (one
result's arrays 181.5 KiB); keeping every result, 340 MiB over the same 900
runs (about 390 KiB a result: its arrays, the parsed tables and the files'
bytes), and 112.6, 114.5 and 112.8 MiB over the leak check's 300 (bound
34.6 MiB). The two tests take 40 s to 2 minutes on the shared machine
(marked slow).
"""

from __future__ import annotations

import gc
import os

import numpy as np
import pytest

roks = pytest.importorskip("roks")

RUNS = 1000
FROM = 100
LEAK_RUNS = 400
"""Runs of the leak check (`test_a_leak_is_seen`)."""
SLACK = 8 << 20
"""Bytes of resident-set growth allowed besides half a leaked result per run."""


def rss() -> int:
    """Resident set of this process in bytes (Linux: /proc/self/statm)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def tiny_scene():
    return roks.Scene.load().override(photons=64, theta_deg=[30.0], seed=5)


def result_bytes(r) -> int:
    """Bytes of the numpy arrays a result hands out (public attributes, one level into nested ones)."""
    total = 0
    seen = set()

    def add(x, depth):
        nonlocal total
        if isinstance(x, np.ndarray):
            if id(x) not in seen:
                seen.add(id(x))
                total += x.nbytes
        elif depth < 2 and x is not None and not isinstance(x, (int, float, str, bytes, bool)):
            for name in dir(x):
                if name.startswith("_"):
                    continue
                try:
                    v = getattr(x, name)
                except Exception:
                    continue
                if not callable(v):
                    add(v, depth + 1)

    add(r, 0)
    return total


def growth(keep: bool, runs: int = RUNS) -> tuple[int, int]:
    """(RSS growth from run FROM to run `runs`, bytes of one result's arrays)."""
    scene = tiny_scene()
    kept = []
    size = result_bytes(roks.brdf(scene, threads=1, stats_resolution=16))
    base = 0
    for i in range(1, runs + 1):
        r = roks.brdf(scene, threads=1, stats_resolution=16)
        _ = r.reflectance, r.brdf, r.inplane  # hand the arrays out as a caller would
        if keep:
            kept.append(r)
        del r
        if i == FROM:
            gc.collect()
            base = rss()
    gc.collect()
    return rss() - base, size


def bound(size: int, runs: int = RUNS) -> int:
    """Half a result per run from run FROM to `runs`, plus the slack."""
    return (runs - FROM) * size // 2 + SLACK


@pytest.mark.slow
def test_memory_stays_flat_over_1000_runs():
    grown, size = growth(keep=False)
    assert size > 0, "a result hands out no numpy arrays"
    limit = bound(size)
    print(f"rss growth from run {FROM} to {RUNS}: {grown / 2**20:.2f} MiB; one result's arrays "
          f"{size / 2**10:.1f} KiB; bound {limit / 2**20:.2f} MiB")
    assert grown < limit, (f"resident set grew {grown / 2**20:.2f} MiB from run {FROM} to {RUNS} "
                           f"(bound {limit / 2**20:.2f} MiB, one result {size / 2**10:.1f} KiB)")


@pytest.mark.slow
def test_a_leak_is_seen():
    """The same loop keeping every result: the growth crosses the bound."""
    grown, size = growth(keep=True, runs=LEAK_RUNS)
    limit = bound(size, LEAK_RUNS)
    print(f"keeping every result: rss growth {grown / 2**20:.2f} MiB, bound {limit / 2**20:.2f} MiB")
    assert grown > limit, (f"keeping every result grew the resident set only {grown / 2**20:.2f} MiB, "
                           f"under the bound {limit / 2**20:.2f} MiB: the bound cannot see a leak")
