#!/usr/bin/env python3
"""Exact checks of scripts/mitsuba_brdf.py (plain asserts, about 30 s).

    .venv/bin/python scripts/test_mitsuba_brdf.py

* flat plane, rho = 0.8: reflectance exactly rho, one bounce, nothing lost,
  all weight in the specular Carlson cell (at normal incidence: shared by
  band 1's four cells, as roks does) and in the specular in-plane bin;
* flat plane, Al (n = 1.015, k = 6.627): the unpolarised Fresnel value
  (R(0) = 0.9154, Rakic 1995; mi.fresnel_conductor at other angles);
* 45 degree V-grooves on a 2 x 2 cell, beam across the grooves: at normal
  incidence every photon bounces exactly twice (rho^2); at 30 degrees the
  one-bounce fraction is 1/sqrt 3 (Zipin 1966), within 4 binomial sigma;
* a sinusoidal surface at 85 degrees (long grazing segments across many
  periods): nothing lost;
* the command line: roks's exact CSV headers, Carlson solid angles summing to
  2 pi and pi, cell fractions summing to the reflectance; the scalar_rgb
  fallback gives the same flat-plane result.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import make_test_ply as mk  # noqa: E402
import mitsuba_brdf as mb  # noqa: E402


def const(rho):
    return lambda c: np.full(len(c), rho)


def main() -> None:
    t_start = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix="mitsuba_brdf_test_"))
    mk.write_ply(tmp / "flat.ply", *mk.flat(2.0, 2.0))
    mk.write_ply(tmp / "vg.ply", *mk.vgroove(2.0, 2.0, 45.0))
    mk.write_ply(tmp / "sine.ply", *mk.sine(10.0, 10.0, 1.0, 32))
    mi = mb.setup_mitsuba("auto")
    print(f"variant {mi.variant()}")
    scalar = mi.variant().startswith("scalar")
    N = 2_000 if scalar else 100_000
    rho = 0.8
    passed = 0

    # --- flat plane, constant rho -------------------------------------------
    flat = mb.Tracer(mi, tmp / "flat.ply", 2.0, 2.0)
    for i, th in enumerate([0.0, 30.0, 60.0, 85.0]):
        r = flat.run(th, 0.0, N, 1, i, const(rho), 8)
        s = mb.summary_entry(r)
        assert abs(s["reflectance"] - rho) < 1e-9, s
        assert s["lost"] == 0 and s["mean_bounces"] == 1.0, s
        frac = r["carlson"].mean(N)
        grid = r["grid"]
        if th == 0.0:
            assert np.allclose(frac[:4], rho / 4, atol=1e-12) and frac[4:].sum() == 0.0
        else:
            spec = np.array([[-math.sin(math.radians(th)), 0.0, math.cos(math.radians(th))]])
            c = grid.locate(spec)[0]
            assert abs(frac[c] - rho) < 1e-9 and abs(frac.sum() - frac[c]) < 1e-12, (th, c)
        ip = r["inplane"]
        b = int(round(th)) + 90
        assert abs(r["inplane_acc"].mean(N)[b] - rho) < 1e-9, th
        passed += 1
    print("flat plane rho: ok")

    # --- flat plane, Fresnel (Al) ---------------------------------------------
    n, k = 1.015, 6.627
    r0 = ((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k)
    assert abs(r0 - 0.9154) < 5e-5
    for i, th in enumerate([0.0, 45.0, 80.0]):
        r = flat.run(th, 0.0, N // 10, 2, i, lambda c: mb.fresnel_unpolarised(c, n, k), 8)
        R = mb.summary_entry(r)["reflectance"]
        c = math.cos(math.radians(th))
        if scalar:
            ref = float(mi.fresnel_conductor(c, mi.ScalarComplex2f(n, k)))
        else:
            ref = float(mi.fresnel_conductor(mi.Float(c), mi.Complex2f(n, k))[0])
        assert abs(R - ref) < 2e-6, (th, R, ref)  # mi.fresnel_conductor is float32
        if th == 0.0:
            assert abs(R - r0) < 1e-12, (R, r0)
        passed += 1
    print("flat plane Fresnel: ok")

    # --- 45 degree V-grooves ----------------------------------------------------
    vg = mb.Tracer(mi, tmp / "vg.ply", 2.0, 2.0)
    r = vg.run(0.0, 0.0, N, 3, 0, const(rho), 8)
    s = mb.summary_entry(r)
    assert s["mean_bounces"] == 2.0 and s["lost"] == 0, s
    assert abs(s["reflectance"] - rho ** 2) < 1e-9, s
    assert abs(s["reflectance_by_bounces"][2] - rho ** 2) < 1e-9
    passed += 1
    r = vg.run(30.0, 0.0, N, 3, 1, const(rho), 8)
    s = mb.summary_entry(r)
    p1 = s["reflectance_by_bounces"][1] / rho
    p2 = s["reflectance_by_bounces"][2] / rho ** 2
    exact = 1.0 / math.sqrt(3.0)
    sigma = math.sqrt(exact * (1 - exact) / N)
    assert abs(p1 - exact) < 4 * sigma, (p1, exact, sigma)
    assert abs(p1 + p2 - 1.0) < 1e-9 and s["lost"] == 0, s
    print(f"V-grooves: ok (30 deg: one bounce {p1:.5f}, exact {exact:.5f}, sigma {sigma:.1e})")
    passed += 1

    # --- sine surface at grazing incidence: long segments, nothing lost ---------
    sine = mb.Tracer(mi, tmp / "sine.ply", 10.0, 10.0)
    r = sine.run(85.0, 0.0, N // 10, 4, 0, const(1.0), 8)
    s = mb.summary_entry(r)
    assert s["lost"] == 0 and abs(s["reflectance"] - 1.0) < 1e-9, s
    assert abs(r["carlson"].mean(N // 10).sum() - 1.0) < 1e-9
    print("sine, 85 deg, rho = 1: ok")
    passed += 1

    # --- command line: files, headers, grid sums; scalar fallback ----------------
    py = sys.executable
    script = str(HERE / "mitsuba_brdf.py")
    outs = {}
    variants = ["scalar"] if scalar else ["auto", "scalar"]
    for v in variants:
        out = tmp / f"out_{v}"
        photons = "2000" if v == "scalar" else "20000"
        subprocess.run([py, script, str(tmp / "vg.ply"), "--size", "2,2", "--theta", "0,30",
                        "--photons", photons, "--rho", "0.8", "--bands", "8", "--variant", v,
                        "--out", str(out), "-q"], check=True)
        outs[v] = out
        rows = list(csv.reader(open(out / "brdf.csv")))
        assert ",".join(rows[0]) == mb.BRDF_HEADER
        assert len(rows) == 1 + 2 * 2 * 8 * 9
        body = [r for r in rows[1:] if r[0] == "0"]
        assert abs(sum(float(r[10]) for r in body) - 2 * math.pi) < 1e-9
        assert abs(sum(float(r[11]) for r in body) - math.pi) < 1e-9
        summ = json.load(open(out / "summary.json"))
        inc = summ["incidence"]
        assert [e["theta_deg"] for e in inc] == [0.0, 30.0]
        for key in ("photons", "reflectance", "reflectance_stderr", "mean_bounces", "lost",
                    "seconds", "segments_per_second"):
            assert key in inc[0], key
        for e in inc:
            f = sum(float(r[12]) for r in rows[1:] if float(r[0]) == e["theta_deg"])
            assert abs(f - e["reflectance"]) < 1e-8, (f, e["reflectance"])
        assert abs(inc[0]["reflectance"] - 0.64) < 1e-9
        ip = list(csv.reader(open(out / "inplane.csv")))
        assert ",".join(ip[0]) == mb.INPLANE_HEADER and len(ip) == 1 + 2 * 181
        assert summ["variant"] == ("scalar_rgb" if v == "scalar" else mi.variant())
        passed += 1
    print("command line: ok")
    print(f"{passed} passed, 0 failed ({time.perf_counter() - t_start:.1f} s)")


if __name__ == "__main__":
    main()
