"""Exact checks of the Mitsuba tracer `roks_tools.mitsuba.tracer`.

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

import math
import subprocess
import sys

import numpy as np
import pytest

from roks_tools import meshes as mk
from roks_tools.results import BrdfResult, read_columns

pytestmark = pytest.mark.mitsuba
RHO = 0.8


@pytest.fixture(scope="module")
def mb(mi):
    from roks_tools.mitsuba import tracer
    return tracer


@pytest.fixture(scope="module")
def surfaces(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mitsuba_brdf")
    mk.write_ply(tmp / "flat.ply", *mk.flat(2.0, 2.0))
    mk.write_ply(tmp / "vg.ply", *mk.vgroove(2.0, 2.0, 45.0))
    mk.write_ply(tmp / "sine.ply", *mk.sine(10.0, 10.0, 1.0, 32))
    return tmp


@pytest.fixture(scope="module")
def scalar(mi) -> bool:
    return mi.variant().startswith("scalar")


@pytest.fixture(scope="module")
def N(scalar) -> int:
    return 2_000 if scalar else 100_000


def const(rho):
    return lambda c: np.full(len(c), rho)


def test_flat_plane_constant_rho(mi, mb, surfaces, N):
    rho = RHO
    flat = mb.Tracer(mi, surfaces / "flat.ply", 2.0, 2.0)
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


def test_flat_plane_aluminium_fresnel(mi, mb, surfaces, N, scalar):
    flat = mb.Tracer(mi, surfaces / "flat.ply", 2.0, 2.0)
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


def test_vgrooves_two_bounces_and_zipin(mi, mb, surfaces, N):
    rho = RHO
    vg = mb.Tracer(mi, surfaces / "vg.ply", 2.0, 2.0)
    r = vg.run(0.0, 0.0, N, 3, 0, const(rho), 8)
    s = mb.summary_entry(r)
    assert s["mean_bounces"] == 2.0 and s["lost"] == 0, s
    assert abs(s["reflectance"] - rho ** 2) < 1e-9, s
    assert abs(s["reflectance_by_bounces"][2] - rho ** 2) < 1e-9
    r = vg.run(30.0, 0.0, N, 3, 1, const(rho), 8)
    s = mb.summary_entry(r)
    p1 = s["reflectance_by_bounces"][1] / rho
    p2 = s["reflectance_by_bounces"][2] / rho ** 2
    exact = 1.0 / math.sqrt(3.0)
    sigma = math.sqrt(exact * (1 - exact) / N)
    assert abs(p1 - exact) < 4 * sigma, (p1, exact, sigma)
    assert abs(p1 + p2 - 1.0) < 1e-9 and s["lost"] == 0, s


def test_sine_grazing_nothing_lost(mi, mb, surfaces, N):
    sine = mb.Tracer(mi, surfaces / "sine.ply", 10.0, 10.0)
    r = sine.run(85.0, 0.0, N // 10, 4, 0, const(1.0), 8)
    s = mb.summary_entry(r)
    assert s["lost"] == 0 and abs(s["reflectance"] - 1.0) < 1e-9, s
    assert abs(r["carlson"].mean(N // 10).sum() - 1.0) < 1e-9


@pytest.mark.slow
def test_command_line_files(mi, mb, surfaces, scalar):
    """Headers, grid sums and summary of `python -m roks_tools.mitsuba.tracer`, read by the
    package's readers; the scalar fallback too."""
    variants = ["scalar"] if scalar else ["auto", "scalar"]
    for v in variants:
        out = surfaces / f"out_{v}"
        photons = "2000" if v == "scalar" else "20000"
        subprocess.run([sys.executable, "-m", "roks_tools.mitsuba.tracer", str(surfaces / "vg.ply"),
                        "--size", "2,2", "--theta", "0,30", "--photons", photons, "--rho", "0.8",
                        "--bands", "8", "--variant", v, "--out", str(out), "-q"], check=True)
        with open(out / "brdf.csv") as f:
            assert f.readline().strip() == mb.BRDF_HEADER
        res = BrdfResult.load(out)
        t = res.brdf
        assert len(t.theta_i_deg) == 2 * 2 * 8 * 9
        body = t.at(0.0)
        assert abs(body.solid_angle_sr.sum() - 2 * math.pi) < 1e-9
        assert abs(body.projected_solid_angle_sr.sum() - math.pi) < 1e-9
        inc = res.summary.incidence
        assert [e.theta_deg for e in inc] == [0.0, 30.0]
        for key in ("photons", "reflectance", "reflectance_stderr", "mean_bounces", "lost",
                    "seconds", "segments_per_second"):
            assert key in inc[0].raw, key
        for e in inc:
            f = t.at(e.theta_deg).fraction.sum()
            assert abs(f - e.reflectance) < 1e-8, (f, e.reflectance)
        assert abs(inc[0].reflectance - 0.64) < 1e-9
        with open(out / "inplane.csv") as f:
            assert f.readline().strip() == mb.INPLANE_HEADER
        assert len(read_columns(out / "inplane.csv")["brdf"]) == 2 * 181
        assert res.summary["variant"] == ("scalar_rgb" if v == "scalar" else mi.variant())
