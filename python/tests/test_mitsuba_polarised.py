"""Polarised Mitsuba cross-check: exact checks of the polarised mode of
the Mitsuba tracer (`roks_tools.mitsuba.tracer`), then roks against it on a
Gaussian height field (4, marked slow; `-m "not slow"` runs only 1-3).

Run by `cargo test` through tests/mitsuba_chain.rs (which passes the roks
binary it built in $ROKS_BIN). About 30 s on 2 cores with the llvm variant
(the scalar fallback is far slower).

1. Mitsuba's convention, numerically: `mi.mueller.specular_reflection` for
   aluminium at 45 deg has element (2, 3) / (0, 0) = -0.205205 (roks's
   `[[a, b, 0, 0], [b, a, 0, 0], [0, 0, c, -d], [0, 0, d, c]]`,
   c + i d = rs rp* of the n + ik amplitudes, d / a = +0.205205).
2. Flat Fresnel plane, aluminium (1.015 + 6.627i) and 1.6 + 0.2i, incidence
   0, 30, 60, 80 deg at azimuths 0 and 35 deg: the reflected Mueller matrix
   and the specular cell (band 1's four cells at normal incidence) are the
   Fresnel matrix above, computed here from the complex amplitudes (in the
   hemisphere frames the s axes of both flights are the tally reference
   vectors); Stokes mode: s, p, linear 30 deg and right circular light give
   F S, and S0 is the reflectance in brdf.csv's weight.
3. 45 deg V-grooves (running along y) at normal incidence: every photon
   meets both walls at 45 deg with the s axis along the grooves, so the
   Mueller matrix is F(45)^2 exactly; at incidence azimuth 0 the pole
   reference vector is along the grooves (s light: Rs^2, p light: Rp^2);
   at azimuth 90 it is across them, where the matrix is D F(45)^2 D,
   D = diag(1, -1, -1, 1) (s light now gets Rp^2).
4. roks against Mitsuba on the exact mesh of a Gaussian height field
   (`roks export-mesh`; sigma/tau = 0.5, 32 x 32 grid squares), aluminium
   and 1.6 + 0.2i, incidence 0 and 50 deg: `roks brdf --polarisation mueller`
   and the tracer's `--polarisation mueller`, compared by
   `roks_tools.compare.compare` (reflectance, cells) and
   `roks_tools.compare.compare_polarised` (reflected Mueller matrix z <= 4 per
   component; chi2 per dof of every Mueller component over the cells with
   signal; largest cell |z| under the Bonferroni limit); and the same for
   Stokes tallies of light linearly polarised at 45 deg (elliptical after
   one bounce), incidence 50 deg. All must pass, with many cells, and the
   weight of two or more bounces above 5 % (10 to 46 % here: polarisation
   matters). Power:
   Mitsuba's Mueller cells in the mirror-image handedness (S2, S3 flipped)
   must fail.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from roks_tools import compare as cb
from roks_tools import meshes as mk
from roks_tools.mitsuba import tracer as mb
from roks_tools.mitsuba.setup import setup_mitsuba
from roks_tools.runner import run

pytestmark = pytest.mark.mitsuba
TRACER = [sys.executable, "-m", "roks_tools.mitsuba.tracer"]

AL = (1.015, 6.627)
ABSORBER = (1.6, 0.2)
F32 = 3e-6  # Mitsuba's matrices are float32
BANDS = 16  # Carlson bands of the Gaussian comparison


def fresnel_mueller(cos_i: float, n: float, k: float) -> np.ndarray:
    """The Fresnel Mueller matrix in the s frames from the complex amplitudes of m = n + ik:
    rs = (c - u)/(c + u), rp = (m c - u/m)/(m c + u/m), u = m cos(theta_t) = sqrt(m^2 - sin^2)."""
    m = complex(n, k)
    c = cos_i
    u = np.sqrt(m * m - (1.0 - c * c))
    if u.imag < 0:
        u = -u
    rs = (c - u) / (c + u)
    rp = (m * c - u / m) / (m * c + u / m)
    Rs, Rp, z = abs(rs) ** 2, abs(rp) ** 2, rs * np.conj(rp)
    a, b = 0.5 * (Rs + Rp), 0.5 * (Rs - Rp)
    return np.array([[a, b, 0, 0], [b, a, 0, 0], [0, 0, z.real, -z.imag], [0, 0, z.imag, z.real]])


def check_convention(mi) -> None:
    ops = mb.MitsubaMueller(mi, *AL)
    M = ops.specular_reflection(np.array([math.cos(math.radians(45.0))]))[0]
    F = fresnel_mueller(math.cos(math.radians(45.0)), *AL)
    assert abs(F[3, 2] / F[0, 0] - 0.205205) < 1e-6, F
    assert abs(M[2, 3] / M[0, 0] + 0.205205) < 1e-6, M
    assert np.allclose(M, F, atol=F32, rtol=0), (M, F)
    print(f"Mitsuba convention: specular_reflection(45 deg, Al) (2,3)/(0,0) = {M[2, 3] / M[0, 0]:+.6f} "
          f"(roks -d/a = {-F[3, 2] / F[0, 0]:+.6f}): ok")


def trace(tracer, mi, mode, incident, th, ph, n, k, photons=200, bands=8):
    """One incidence of the polarised tracer, without Russian roulette (exact weights)."""
    pol = mb.PolarisedCarrier(mb.MitsubaMueller(mi, n, k), mode, mb.parse_incident(incident), math.radians(ph))
    r = tracer.run(th, ph, photons, 1, 0, None, bands, roulette_weight=0.0, polarised=pol)
    return r, mb.summary_entry(r)


def check_flat(mi, tmp: Path) -> None:
    mk.write_ply(tmp / "flat.ply", *mk.flat(2.0, 2.0))
    flat = mb.Tracer(mi, tmp / "flat.ply", 2.0, 2.0)
    for n, k in (AL, ABSORBER):
        for ph in (0.0, 35.0):
            for th in (0.0, 30.0, 60.0, 80.0):
                F = fresnel_mueller(math.cos(math.radians(th)), n, k)
                r, s = trace(flat, mi, "mueller", "unpolarised", th, ph, n, k)
                M = np.array(s["reflected_mueller"]).reshape(4, 4)
                assert np.allclose(M, F, atol=F32, rtol=0), (n, k, th, ph, M, F)
                assert max(s["reflected_mueller_stderr"]) == 0 and s["lost"] == 0, s
                assert abs(s["reflectance"] - F[0, 0]) < F32, s
                cells = r["polar"]["carlson"].mean(r["photons"])
                grid = r["grid"]
                if th == 0.0:
                    assert np.allclose(cells[:4], F.ravel() / 4, atol=F32, rtol=0)
                    assert np.all(cells[4:] == 0)
                else:
                    t, p = math.radians(th), math.radians(ph)
                    spec = np.array([[-math.sin(t) * math.cos(p), -math.sin(t) * math.sin(p), math.cos(t)]])
                    c = grid.locate(spec)[0]
                    assert np.allclose(cells[c], F.ravel(), atol=F32, rtol=0), (th, ph)
                    assert np.abs(np.delete(cells, c, axis=0)).sum() == 0
            for inc in ("s", "p", "linear=30", "right"):
                th = 60.0
                F = fresnel_mueller(math.cos(math.radians(th)), n, k)
                _, s = trace(flat, mi, "stokes", inc, th, ph, n, k)
                want = F @ mb.parse_incident(inc)
                assert np.allclose(s["reflected_stokes"], want, atol=F32, rtol=0), (inc, s, want)
                assert abs(s["reflectance"] - want[0]) < F32
    print("flat Fresnel plane (Al, 1.6 + 0.2i; 0..80 deg; azimuths 0, 35; Mueller and Stokes): ok")


def check_command_line(tmp: Path, scalar_too: bool) -> None:
    """stokes.csv / mueller.csv / summary.json as roks writes them, and the scalar fallback."""
    th, inc = 60.0, "right"
    F = fresnel_mueller(math.cos(math.radians(th)), *ABSORBER)
    want = F @ mb.parse_incident(inc)
    for v in ["auto", "scalar"] if scalar_too else ["auto"]:
        for mode in ("stokes", "mueller"):
            out = tmp / f"cli_{v}_{mode}"
            run([*TRACER, tmp / "flat.ply", "--size", "2,2", "--theta", th,
                 "--photons", 50, "--n", ABSORBER[0], "--k", ABSORBER[1], "--bands", 4, "--polarisation", mode,
                 "--incident", inc, "--roulette-weight", 0, "--variant", v, "--out", out, "-q"],
                "test_mitsuba_polarised", echo=False)
            # read as text: s0 and brdf must be the same digits, not only the same numbers
            rows = list(csv.DictReader(open(out / f"{mode}.csv")))
            header = open(out / f"{mode}.csv").readline().strip()
            assert header == (mb.STOKES_HEADER if mode == "stokes" else mb.MUELLER_HEADER), header
            brdf = list(csv.DictReader(open(out / "brdf.csv")))
            assert len(rows) == len(brdf) == 2 * 4 * 5
            e = json.load(open(out / "summary.json"))["incidence"][0]
            if mode == "stokes":
                assert np.allclose(e["reflected_stokes"], want, atol=F32, rtol=0), e
                assert len(e["reflected_stokes_stderr"]) == 4
                for r, b in zip(rows, brdf):
                    assert (r["band"], r["cell"], r["theta_deg"], r["phi_deg"]) == (
                        b["band"], b["cell"], b["theta_deg"], b["phi_deg"])
                    assert r["s0"] == b["brdf"] and r["s0_stderr"] == b["brdf_stderr"]
                    if float(r["s0"]) > 0:
                        assert abs(float(r["dop"]) - 1.0) < F32, r  # a pure state stays pure
            else:
                assert np.allclose(e["reflected_mueller"], F.ravel(), atol=F32, rtol=0), e
                assert len(e["reflected_mueller_stderr"]) == 16
                # brdf.csv holds the intensity for the incident state: row 0 of M times S
                for r, b in zip(rows, brdf):
                    s0 = sum(float(r[f"m0{j}"]) * want_j for j, want_j in enumerate(mb.parse_incident(inc)))
                    assert abs(s0 - float(b["brdf"])) <= 1e-8 * abs(s0) + 1e-300, (r, b)
    p = subprocess.run([*TRACER, tmp / "flat.ply", "--size", "2,2",
                        "--rho", "0.8", "--polarisation", "stokes", "--out", tmp / "no"], capture_output=True)
    assert p.returncode == 2 and b"--polarisation needs a Fresnel material" in p.stderr, p.stderr
    print(f"command line (headers, s0 = brdf, DoP 1, summary; variants {'auto, scalar' if scalar_too else 'auto'}): ok")


def check_vgrooves(mi, tmp: Path) -> None:
    mk.write_ply(tmp / "vg.ply", *mk.vgroove(2.0, 2.0, 45.0))
    vg = mb.Tracer(mi, tmp / "vg.ply", 2.0, 2.0)
    D = np.diag([1.0, -1.0, -1.0, 1.0])
    for n, k in (AL, ABSORBER):
        F = fresnel_mueller(math.cos(math.radians(45.0)), n, k)
        Rs, Rp = F[0, 0] + F[0, 1], F[0, 0] - F[0, 1]
        for ph, want in ((0.0, F @ F), (90.0, D @ F @ F @ D)):
            r, s = trace(vg, mi, "mueller", "unpolarised", 0.0, ph, n, k, photons=2000)
            assert s["mean_bounces"] == 2.0 and s["lost"] == 0, s
            M = np.array(s["reflected_mueller"]).reshape(4, 4)
            assert np.allclose(M, want, atol=F32, rtol=0), (n, k, ph, M, want)
            cells = r["polar"]["carlson"].mean(r["photons"])
            assert np.allclose(cells[:4], want.ravel() / 4, atol=F32, rtol=0) and np.all(cells[4:] == 0)
            for inc, along in (("s", Rs * Rs), ("p", Rp * Rp)):
                _, s = trace(vg, mi, "stokes", inc, 0.0, ph, n, k, photons=2000)
                exact = along if ph == 0.0 else (Rp * Rp if inc == "s" else Rs * Rs)
                assert abs(s["reflectance"] - exact) < F32, (inc, ph, s["reflectance"], exact)
                assert np.allclose(s["reflected_stokes"], want @ mb.parse_incident(inc), atol=F32, rtol=0)
    print("V-grooves at normal incidence (two bounces: F(45)^2; s along the grooves -> Rs^2): ok")


GAUSSIAN_SCENE = """name = "gaussian_polarised"
[surface]
size = [16.0, 16.0]
edges = "periodic"
material = "m"
heightfield = {{ gaussian = {{ sigma = 1.0, tau = 2.0 }}, resolution = 32, seed = 3 }}
[materials.m]
n = {n}
k = {k}
[light]
theta_deg = [{thetas}]
phi_deg = 0.0
photons = {photons}
seed = 1
polarisation = {incident}
[tally]
bands = {bands}
"""

# (tally, incident state as the scene writes it, as mitsuba_brdf.py takes it, incidence angles)
GAUSSIAN_CASES = [
    ("mueller", '"unpolarised"', "unpolarised", [0.0, 50.0]),
    ("stokes", "{ linear = 45.0 }", "linear=45", [50.0]),
]


def handedness_flipped(src: Path, dst: Path) -> None:
    """A copy of a mueller.csv result folder in the mirror-image convention (S2, S3 -> -S2, -S3
    on both sides: M -> D M D, D = diag(1, 1, -1, -1)), the error a wrong frame handedness makes."""
    shutil.copytree(src, dst)
    sign = np.outer([1, 1, -1, -1], [1, 1, -1, -1]).ravel()
    summ = json.loads((src / "summary.json").read_text())
    for e in summ["incidence"]:
        e["reflected_mueller"] = list(np.array(e["reflected_mueller"]) * sign)
    (dst / "summary.json").write_text(json.dumps(summ))
    lines = (src / "mueller.csv").read_text().splitlines()
    out = [lines[0]]
    for line in lines[1:]:
        f = line.split(",")
        for c in range(16):
            if sign[c] < 0:
                f[6 + 2 * c] = mb.re_(-float(f[6 + 2 * c]))
        out.append(",".join(f))
    (dst / "mueller.csv").write_text("\n".join(out) + "\n")


def check_gaussian(roks: str, tmp: Path, photons: int, mitsuba_photons: int) -> None:
    who = "test_mitsuba_polarised"
    for n, k in (AL, ABSORBER):
        for mode, inc_scene, inc, thetas in GAUSSIAN_CASES:
            work = tmp / f"gauss_{n:g}_{k:g}_{mode}"
            work.mkdir()
            scene = work / "scene.toml"
            scene.write_text(GAUSSIAN_SCENE.format(n=n, k=k, thetas=", ".join(f"{t:g}" for t in thetas),
                                                   photons=photons, incident=inc_scene, bands=BANDS))
            run([roks, "export-mesh", scene, "--out", work / "mesh.ply"], who, echo=False)
            t_roks = run([roks, "brdf", scene, "--polarisation", mode, "-q", "--out", work / "roks"],
                         who, echo=False).wall_s
            t_mi = run([*TRACER, work / "mesh.ply", "--size", "16,16",
                           "--theta", ",".join(f"{t:g}" for t in thetas), "--photons", mitsuba_photons,
                           "--n", n, "--k", k, "--bands", BANDS, "--polarisation", mode,
                        "--incident", inc, "--out", work / "mitsuba", "-q"], who, echo=False).wall_s
            rows = cb.compare(work / "roks", work / "mitsuba")
            prow = cb.compare_polarised(work / "roks", work / "mitsuba")
            print(f"n + ik = {n} + {k}i, {mode}, incident {inc} (roks {t_roks:.1f} s, Mitsuba {t_mi:.1f} s)")
            print(cb.table(rows))
            print(cb.table_polarised(prow))
            assert [r["theta"] for r in rows] == thetas and [r["theta"] for r in prow] == thetas
            for r, p in zip(rows, prow):
                assert r["pass"], r
                assert p["pass"], p
                assert p["cells"] >= 50 and p["terms"] >= len(p["names"]) * 50, p
            for e in cb.load(work / "mitsuba")[0].values():
                # enough multiple scattering for polarisation to matter
                assert sum(e["reflectance_by_bounces"][2:]) > 0.05 * e["reflectance"], e
            if mode == "mueller":
                handedness_flipped(work / "mitsuba", work / "flipped")
                bad = cb.compare_polarised(work / "roks", work / "flipped")
                assert not any(p["pass"] for p in bad), cb.table_polarised(bad)
    print("Gaussian height field, roks vs Mitsuba (Mueller, Stokes): ok; flipped handedness: fails")


@pytest.fixture
def pmi():
    """mitsuba in a polarised variant (llvm_ad_mono_polarized, else scalar_spectral_polarized)."""
    return setup_mitsuba("auto", polarised=True)


def test_mitsuba_convention(pmi):
    check_convention(pmi)


def test_flat_fresnel_plane(pmi, tmp_path):
    check_flat(pmi, tmp_path)


def test_vgrooves(pmi, tmp_path):
    check_vgrooves(pmi, tmp_path)


def test_command_line(pmi, tmp_path):
    mk.write_ply(tmp_path / "flat.ply", *mk.flat(2.0, 2.0))
    check_command_line(tmp_path, scalar_too=not pmi.variant().startswith("scalar"))


@pytest.mark.slow
def test_gaussian_roks_vs_mitsuba(pmi, roks, tmp_path):
    check_gaussian(roks, tmp_path, photons=1_000_000, mitsuba_photons=200_000)
