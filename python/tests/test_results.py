"""The readers of `roks_tools.results` on files the roks binary writes (a
tiny run of the default scene and of an object scene in a temporary folder),
checked against the Carlson grid and the files' own invariants, and their
refusals of broken files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roks_tools.carlson import CarlsonGrid
from roks_tools.results import (HEADERS, SPECTRAL_HEADERS, BrdfResult, BrdfTable, InPlane, PolarTable, ResultError,
                                TraceResult, read_columns, read_summary)
from roks_tools.runner import repo_root, run

SCENES = repo_root() / "scenes"


@pytest.fixture(scope="module")
def brdf_runs(roks, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("brdf")
    for name, extra in (("plain", ["--theta", "0,60"]), ("mueller", ["--theta", "30", "--polarisation", "mueller"]),
                        ("stokes", ["--theta", "30", "--polarisation", "stokes"])):
        run([roks, "brdf", SCENES / "default.toml", "--photons", 4096, *extra, "--out", tmp / name, "-q"],
            "test_results", echo=False)
    return tmp


@pytest.fixture(scope="module")
def trace_run(roks, tmp_path_factory):
    out = tmp_path_factory.mktemp("trace") / "cavity"
    run([roks, "trace", SCENES / "cylinder-cavity.toml", "--photons", 2000, "--out", out, "-q"],
        "test_results", echo=False)
    return out


def test_headers_are_the_files(brdf_runs, trace_run):
    for path in [brdf_runs / "plain" / "brdf.csv", brdf_runs / "plain" / "inplane.csv",
                 brdf_runs / "mueller" / "mueller.csv", brdf_runs / "stokes" / "stokes.csv",
                 trace_run / "reflectance.csv", trace_run / "farfield.csv"]:
        assert path.read_text().splitlines()[0] == ",".join(HEADERS[path.name]), path


def test_brdf_result_against_grid_and_summary(brdf_runs):
    r = BrdfResult.load(brdf_runs / "plain")
    assert r.polar is None
    assert [e.theta_deg for e in r.summary.incidence] == [0.0, 60.0]
    assert r.brdf.incidences == [(0.0, 0.0), (60.0, 0.0)]
    g = r.brdf.grid
    assert g == CarlsonGrid(r.summary["bands"])
    for e in r.summary.incidence:
        b = r.brdf.at(e.theta_deg)
        assert e.photons == 4096
        assert np.array_equal(b.band, g.band) and np.array_equal(b.cell, g.cell)
        # the cell columns are the grid's bounds (to the last bits of acos and the degree factor)
        deg = dict(rtol=0, atol=1e-12)
        assert np.allclose(b.theta_lo_deg, np.degrees(np.arccos(g.mu_top)), **deg)
        assert np.allclose(b.theta_hi_deg, np.degrees(np.arccos(g.mu_bot)), **deg)
        assert np.allclose(b.phi_lo_deg, np.degrees(g.phi_lo), **deg)
        assert np.allclose(b.phi_hi_deg, np.degrees(g.phi_hi), **deg)
        assert np.all(b.phi_lo_deg[b.cell == 0] < 0)
        assert np.allclose(b.theta_deg, np.degrees(g.theta_centre), rtol=1e-15, atol=1e-13)
        assert np.allclose(b.solid_angle_sr, g.solid_angle, rtol=1e-12, atol=0)
        assert np.allclose(b.projected_solid_angle_sr, g.projected_solid_angle, rtol=1e-12, atol=0)
        # fractions add up to the reflectance (10 digits each), brdf = fraction / projected
        assert abs(b.fraction.sum() - e.reflectance) < 1e-8
        assert abs(sum(e.reflectance_by_bounces) - e.reflectance) < 1e-12
        assert np.allclose(b.brdf, b.fraction / b.projected_solid_angle_sr, rtol=1e-9, atol=0)
        assert np.allclose(b.brdf_stderr, b.fraction_stderr / b.projected_solid_angle_sr, rtol=1e-9, atol=0)
        assert np.all(b.fraction_stderr >= 0)
    cells = r.brdf.cells()
    assert set(cells) == {0.0, 60.0} and len(cells[60.0]) == g.n_cells
    ip = r.inplane.at(60.0)
    assert len(ip.theta_o_deg) == len(r.inplane.theta_o_deg) // 2
    assert set(r.inplane.by_theta()) == {0.0, 60.0}


def test_mueller_and_stokes_tables(brdf_runs):
    m = BrdfResult.load(brdf_runs / "mueller")
    assert m.polar is not None and m.polar.mode == "mueller" and m.polar.values.shape[1] == 16
    assert np.array_equal(m.polar.band, m.brdf.band) and np.array_equal(m.polar.cell, m.brdf.cell)
    # unpolarised incidence: brdf.csv holds m00
    assert np.allclose(m.polar.values[:, 0], m.brdf.brdf, rtol=1e-8, atol=1e-300)
    refl = m.summary.incidence[0]["reflected_mueller"]
    assert len(refl) == 16 and abs(refl[0] - m.summary.incidence[0].reflectance) < 1e-12
    s = BrdfResult.load(brdf_runs / "stokes")
    assert s.polar.mode == "stokes" and s.polar.names == ("s0", "s1", "s2", "s3")
    assert np.array_equal(s.polar.values[:, 0], s.brdf.brdf)
    assert np.array_equal(s.polar.stderr[:, 0], s.brdf.brdf_stderr)
    cells = s.polar.cells()[30.0]
    assert len(cells) == s.brdf.grid.n_cells and len(cells[(1, 0)][0]) == 4


def test_trace_result(trace_run):
    t = TraceResult.load(trace_run)
    sources = t.summary["sources"]
    assert len(sources) == len(t.reflectance.x) > 0
    assert np.allclose(t.reflectance.reflectance, [s["reflectance"] for s in sources], rtol=1e-8, atol=1e-300)
    ff = t.farfield
    n_sources = len(sources)
    assert len(ff.source) % n_sources == 0
    grid = CarlsonGrid.of_cells(len(ff.source) // n_sources // 2)  # both hemispheres
    assert set(np.abs(ff.band).astype(int)) == set(range(1, grid.bands + 1))
    for k in range(n_sources):
        f = ff.fraction[ff.source == k]
        assert abs(f.sum() - t.reflectance.reflectance[k]) < 1e-6 * max(1.0, f.sum()), k
    assert np.allclose(ff.solid_angle_sr, grid.solid_angle, rtol=1e-12, atol=0)


def test_spectral_trace_result(roks, tmp_path):
    """A spectral trace: the readers take the wavelength_um columns; each
    wavelength's far field adds up to its reflectance, and the summary's
    spectrum holds the same reflectances and emissivity = 1 - R - missed."""
    out = tmp_path / "spectral"
    run([roks, "trace", SCENES / "radiator-spectral.toml", "--photons", 300,
         "--wavelengths", "3,8,12", "--out", out, "-q"], "test_results", echo=False)
    t = TraceResult.load(out)
    assert t.summary["wavelengths_um"] == [3.0, 8.0, 12.0]
    r, ff = t.reflectance, t.farfield
    assert (out / "reflectance.csv").read_text().splitlines()[0] == ",".join(
        SPECTRAL_HEADERS["reflectance.csv"])
    sources = t.summary["sources"]
    assert len(r.x) == 3 * len(sources)
    assert list(r.wavelength_um[:3]) == [3.0, 8.0, 12.0]
    for k, s in enumerate(sources):
        spectrum = s["spectrum"]
        assert [w["wavelength_um"] for w in spectrum] == [3.0, 8.0, 12.0]
        assert np.allclose(r.reflectance[3 * k:3 * k + 3], [w["reflectance"] for w in spectrum],
                           rtol=1e-8, atol=1e-300)
        for w in spectrum:
            assert abs(w["emissivity"] - (1 - w["reflectance"] - w["missed"])) < 1e-15
            f = ff.fraction[(ff.source == k) & (ff.wavelength_um == w["wavelength_um"])]
            assert abs(f.sum() - w["reflectance"]) < 1e-8
        assert abs(s["reflectance"] - np.mean([w["reflectance"] for w in spectrum])) < 1e-15


def test_broken_files_are_refused_naming_them(tmp_path):
    bad = tmp_path / "brdf.csv"
    bad.write_text("theta,phi\n1,2\n")
    with pytest.raises(ResultError, match=str(bad)):
        BrdfTable.read(bad)
    ip = tmp_path / "inplane.csv"
    ip.write_text(",".join(HEADERS["inplane.csv"]) + "\n0,1,x,2\n")
    with pytest.raises(ResultError, match="inplane.csv"):
        InPlane.read(ip)
    ip.write_text(",".join(HEADERS["inplane.csv"]) + "\n")
    with pytest.raises(ResultError, match="no data rows"):
        read_columns(ip)
    with pytest.raises(ResultError, match="not found"):
        BrdfResult.load(tmp_path)
    js = tmp_path / "summary.json"
    js.write_text("[1, 2]")
    with pytest.raises(ResultError, match="not a roks summary.json"):
        read_summary(js)
    js.write_text('{"incidence": [{"theta_deg": 0}]}')
    with pytest.raises(ResultError, match=r"summary.json: incidence\[0\]: lacks the key 'phi_deg'"):
        read_summary(js)
    with pytest.raises(ResultError):
        PolarTable.read(tmp_path / "other.csv")


def test_read_columns_any_header(tmp_path):
    p = tmp_path / "rows.csv"
    p.write_text("a,b\n1,2.5\n3,1e-3\n")
    cols = read_columns(p)
    assert list(cols) == ["a", "b"] and cols["b"].tolist() == [2.5, 1e-3]
    assert math.isclose(cols["a"].sum(), 4.0)


def test_roks_load_agrees_with_these_readers(brdf_runs):
    """`roks.load` (the module's result type, roks's own reader) against
    these readers, written apart from it, on the same folders: every array
    the same to the bit, on the result tree's axes."""
    roks = pytest.importorskip("roks")
    for name in ("plain", "mueller", "stokes"):
        d = brdf_runs / name
        r, t = roks.load(d), BrdfResult.load(d)
        assert r.shape[:3] == (len(t.summary.incidence), 1, 1)
        assert r.shape[3] == t.brdf.grid.n_cells
        for i, e in enumerate(t.summary.incidence):
            assert r.theta_deg[i] == e.theta_deg and r.phi_deg[0] == e.phi_deg
            assert r.reflectance[i, 0, 0] == e.reflectance
            assert r.reflectance_stderr[i, 0, 0] == e.reflectance_stderr
            b = t.brdf.at(e.theta_deg)
            for col in ("brdf", "brdf_stderr", "fraction"):
                assert np.array_equal(getattr(r, col)[i, 0, 0], getattr(b, col)), (name, col)
            ip = t.inplane.at(e.theta_deg)
            assert np.array_equal(r.inplane[i, 0, 0], ip.brdf) and np.array_equal(r.inplane_theta_deg, ip.theta_o_deg)
            assert np.array_equal(r.inplane_stderr[i, 0, 0], ip.brdf_stderr)
        for col in ("theta_deg", "phi_deg", "theta_lo_deg", "theta_hi_deg", "phi_lo_deg", "phi_hi_deg",
                    "solid_angle_sr", "projected_solid_angle_sr"):
            assert np.array_equal(getattr(r.cells, col), getattr(b, col)), col
        polar = {"mueller": (r.mueller, r.mueller_stderr), "stokes": (r.stokes, r.stokes_stderr)}.get(name)
        if polar is None:
            assert r.mueller is None and r.stokes is None and t.polar is None
        else:
            n = t.polar.values.shape[1]
            assert np.array_equal(polar[0].reshape(-1, n), t.polar.values)
            assert np.array_equal(polar[1].reshape(-1, n), t.polar.stderr)
