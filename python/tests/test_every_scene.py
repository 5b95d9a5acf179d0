"""Every scene in scenes/, run by the roks binary at a small photon count,
and every file of its result folder read by `roks_tools.results`.

The scenes are copied to a temporary folder first; the three scenes whose
walls sample a generated BRDF table (radiator-brdf, radiator-cutaway,
radiator-defect-brdf read `../out/z302/brdf.csv`) get it made there first by
`roks brdf z302-micro.toml --out out/z302`, as their comment says. Besides
the scenes as they are, the runs cover the options that write other files:
Stokes and Mueller tallies (monochrome and spectral), a spectral run at one
wavelength (a measured n,k table), two shards and their merge (monochrome
and spectral), and an object scene with a Stokes far field.

For each folder the test asserts that every file in it has a reader (a
file roks writes that no reader knows fails it), and checks the values read
against each other, so a reader that misplaces a column fails: the fractions
of each incidence (and wavelength) add up to summary.json's reflectance; the
BRDF is the fraction over the projected solid angle; m00 and s0 are brdf.csv's
BRDF for unpolarised light; a shard's tallies.json sums over its photons are
brdf.csv's fractions; a trace's reflectance.csv is summary.json's, and its
far field adds up to it.

Photons per incidence or beam position: $ROKS_TEST_PHOTONS (default 1024).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from roks_tools.results import (BrdfResult, FitResult, ResultError, TraceResult, load_result, read_file)
from roks_tools.runner import repo_root, run

SCENES = repo_root() / "scenes"
PHOTONS = int(os.environ.get("ROKS_TEST_PHOTONS", "1024"))
NEEDS_TABLE = {"radiator-brdf", "radiator-cutaway", "radiator-defect-brdf"}
"""Scenes that read out/z302/brdf.csv, made first by the fixture."""


def _is_object(scene: Path) -> bool:
    return "[[sources]]" in scene.read_text()


SCENE_NAMES = sorted(p.stem for p in SCENES.glob("*.toml"))

# (name, scene, extra options): the runs besides every scene as it is.
VARIANTS = [
    ("default-stokes", "default", ["--theta", "0,60", "--polarisation", "stokes"]),
    ("default-mueller", "default", ["--theta", "30", "--polarisation", "mueller"]),
    ("gold-mueller-spectral", "gold-spectral", ["--theta", "0,60", "--polarisation", "mueller",
                                                "--wavelengths", "0.45,0.55,0.65"]),
    ("gold-stokes-spectral", "gold-spectral", ["--theta", "30", "--polarisation", "stokes",
                                               "--wavelengths", "0.5,0.6"]),
    ("gold-one-wavelength", "gold-spectral", ["--theta", "0,45", "--wavelengths", "0.55"]),
]


@pytest.fixture(scope="session")
def workspace(roks, tmp_path_factory) -> Path:
    """A copy of scenes/ (with out/z302/brdf.csv made) in a temporary folder."""
    tmp = tmp_path_factory.mktemp("scenes")
    shutil.copytree(SCENES, tmp / "scenes")
    run([roks, "brdf", tmp / "scenes" / "z302-micro.toml", "--photons", PHOTONS, "--theta", "0,30,60,85",
         "--out", tmp / "out" / "z302", "-q"], "test_every_scene", echo=False)
    # An object scene with a Stokes far field (farfield_stokes.csv): the cavity, 2 beam positions.
    text = (tmp / "scenes" / "cylinder-cavity.toml").read_text()
    text = text.replace("steps = 49", "steps = 2").replace("bands = 32", "bands = 8")
    assert "[tally]" in text.split("[[sources]]")[-1], "cylinder-cavity.toml: [tally] is no longer last"
    (tmp / "scenes" / "cavity-stokes.toml").write_text(text + 'polarisation = "stokes"\n')
    # The ensemble at test size: 2 realisations of a 64² field, each its own
    # whole batch of 4096 photons (_run gives this scene two batches).
    text = (tmp / "scenes" / "gaussian-ensemble.toml").read_text()
    assert "realisations = 16" in text and "resolution = 256" in text, "gaussian-ensemble.toml changed"
    text = text.replace("realisations = 16", "realisations = 2").replace("resolution = 256", "resolution = 64")
    (tmp / "scenes" / "gaussian-ensemble.toml").write_text(text)
    return tmp


# Scenes that need more photons than PHOTONS: one batch of 4096 per realisation.
MIN_PHOTONS = {"gaussian-ensemble": 2 * 4096}


def _run(roks, workspace: Path, scene: str, out: Path, extra: list) -> Path:
    path = workspace / "scenes" / f"{scene}.toml"
    cmd = "trace" if _is_object(path) else "brdf"
    photons = max(PHOTONS, MIN_PHOTONS.get(scene, 0))
    run([roks, cmd, path, "--photons", photons, *extra, "--out", out, "-q"], "test_every_scene", echo=False)
    return out


def _read_every_file(folder: Path):
    """Read every file of the folder with its reader; the result folder whole."""
    names = sorted(p.name for p in folder.iterdir())
    assert "summary.json" in names or "fit.json" in names
    for name in names:
        read_file(folder / name)  # a file without a reader raises ResultError
    return load_result(folder)


def _check_brdf(r: BrdfResult):
    s, b = r.summary, r.brdf
    assert len(b.incidences) == len(s.incidence) > 0
    waves = s.wavelengths_um or [None]
    assert b.wavelengths == (s.wavelengths_um or [])
    grid = b.grid
    if s.bands is not None:
        assert grid.bands == s.bands
    for e in s.incidence:
        assert e.photons > 0 and (s.shard is not None or e.photons == s.photons_per_incidence)
        by_wave = {w.wavelength_um: w for w in e.spectrum} if e.spectrum else {}
        for w in waves:
            t = b.at(e.theta_deg, e.phi_deg, wavelength_um=w)
            assert len(t.fraction) == grid.n_cells
            assert np.array_equal(t.band, grid.band) and np.array_equal(t.cell, grid.cell)
            want = e.reflectance if w is None else by_wave[w].reflectance
            # 10 significant digits per cell in brdf.csv, the reflectance exact in summary.json
            assert abs(t.fraction.sum() - want) <= 1e-9 * grid.n_cells + 1e-12, (e.theta_deg, w)
            assert np.allclose(t.brdf, t.fraction / t.projected_solid_angle_sr, rtol=1e-9, atol=0)
            assert np.allclose(t.solid_angle_sr, grid.solid_angle, rtol=1e-12, atol=0)
            ip = r.inplane.at(e.theta_deg, e.phi_deg if r.inplane.phi_i_deg is not None else None,
                              wavelength_um=w)
            assert len(ip.theta_o_deg) > 0 and np.all(ip.brdf >= 0)
        if w is None:
            assert abs(sum(e.reflectance_by_bounces) - e.reflectance) < 1e-9
    if r.polar is not None:
        assert r.polar.mode == s.polar_tally
        unpolarised = s.polarisation.incident == "unpolarised"
        if unpolarised:  # m00 (or s0) is the BRDF of brdf.csv
            assert np.allclose(r.polar.values[:, 0], b.brdf, rtol=1e-8, atol=1e-300)
        if r.polar.dop is not None:
            ok = ~np.isnan(r.polar.dop)
            assert np.all((r.polar.dop[ok] >= 0) & (r.polar.dop[ok] <= 1 + 1e-6))
    else:
        assert s.polar_tally == "none"
    if r.colour is not None:
        assert s.spectral and min(s.wavelengths_um) <= 0.40 and max(s.wavelengths_um) >= 0.70
        assert len(r.colour.X) == grid.n_cells * len(s.incidence)
        assert np.all(r.colour.Y >= 0)
    if r.tallies is not None:  # a shard or a merge: the raw sums are brdf.csv's fractions
        assert s.shard is None or (r.tallies.shard.index, r.tallies.shard.count) == (s.shard.index, s.shard.count)
        blocks = [(e, w) for e in s.incidence for w in waves]  # incidence-major
        assert len(r.tallies.incidence) == len(blocks)
        for (e, w), ti in zip(blocks, r.tallies.incidence):
            assert ti.theta_deg == e.theta_deg and ti.photons == e.photons and ti.wavelength_um == w
            frac = np.array(ti.carlson_fraction())
            t = b.at(e.theta_deg, e.phi_deg, wavelength_um=w).fraction
            assert len(frac) == len(t)
            assert np.allclose(frac, t, rtol=1e-9, atol=1e-15)


def _check_trace(r: TraceResult):
    s, refl = r.summary, r.reflectance
    # summary.json says whether each far field was tallied: exactly when its file is there.
    assert s.farfield == (r.farfield is not None) and s.farfield_stokes == (r.farfield_stokes is not None)
    waves = s.wavelengths_um or [None]
    nw = len(waves)
    assert len(refl.x) == len(s.sources) * nw > 0
    for k, src in enumerate(s.sources):
        rows = slice(k * nw, (k + 1) * nw)
        assert np.allclose(np.stack([refl.x[rows], refl.y[rows], refl.z[rows]], axis=1), src.position)
        want = [src.reflectance] if waves == [None] else [w.reflectance for w in src.spectrum]
        assert np.allclose(refl.reflectance[rows], want, rtol=1e-8, atol=1e-300)
        if r.farfield is not None:
            for w, rho in zip(waves, want):
                m = r.farfield.source == k
                if w is not None:
                    m &= r.farfield.wavelength_um == w
                assert abs(r.farfield.fraction[m].sum() - rho) <= 1e-9 * m.sum() + 1e-12
        if r.farfield_stokes is not None and r.farfield is not None:
            m = r.farfield_stokes.source == k
            assert np.allclose(r.farfield_stokes.values[m, 0], r.farfield.brdf[r.farfield.source == k],
                               rtol=1e-8, atol=1e-300)


def _check(folder: Path):
    r = _read_every_file(folder)
    (_check_brdf if isinstance(r, BrdfResult) else _check_trace)(r)
    return r


@pytest.mark.slow
@pytest.mark.parametrize("scene", SCENE_NAMES)
def test_scene_runs_and_every_file_reads(roks, workspace, scene):
    out = _run(roks, workspace, scene, workspace / "results" / scene, [])
    r = _check(out)
    assert isinstance(r, TraceResult) == _is_object(workspace / "scenes" / f"{scene}.toml")


@pytest.mark.slow
@pytest.mark.parametrize("name,scene,extra", VARIANTS, ids=[v[0] for v in VARIANTS])
def test_option_variants_read(roks, workspace, name, scene, extra):
    r = _check(_run(roks, workspace, scene, workspace / "results" / name, extra))
    assert (r.polar is not None) == ("--polarisation" in extra)
    if name == "gold-one-wavelength":
        assert r.summary.wavelengths_um == [0.55] and r.brdf.wavelengths == [0.55]


def test_object_far_field_stokes(roks, workspace):
    r = _check(_run(roks, workspace, "cavity-stokes", workspace / "results" / "cavity-stokes", []))
    assert r.farfield_stokes is not None and len(r.summary.sources) == 2


@pytest.mark.slow
@pytest.mark.parametrize("spectral", [False, True], ids=["mono", "spectral"])
def test_shards_and_merge_read(roks, workspace, spectral):
    """Two shards and their merge: tallies.json read and equal to brdf.csv; the merge's brdf.csv
    equals the sum of the shards' raw sums."""
    extra = ["--theta", "0,60"] + (["--wavelengths", "0.45,0.65"] if spectral else [])
    scene = workspace / "scenes" / ("gold-spectral.toml" if spectral else "default.toml")
    base = workspace / "results" / ("shards-spectral" if spectral else "shards")
    shards = []
    for i in range(2):
        out = base / f"{i:03}"
        run([roks, "brdf", scene, "--photons", 8192, *extra, "--shard", f"{i}/2", "--out", out, "-q"],
            "test_every_scene", echo=False)
        shards.append(_check(out))
    run([roks, "merge", *[s.folder for s in shards], "--out", base / "merged", "-q"], "test_every_scene",
        echo=False)
    merged = _check(base / "merged")
    assert merged.tallies is not None and merged.summary.incidence[0].photons == 8192
    waves = merged.summary.wavelengths_um or [None]
    blocks = [(e, w) for e in merged.summary.incidence for w in waves]
    for k, (e, w) in enumerate(blocks):
        parts = [np.array(s.tallies.incidence[k].carlson_fraction()) * s.tallies.incidence[k].photons
                 for s in shards]
        t = merged.brdf.at(e.theta_deg, e.phi_deg, wavelength_um=w)
        assert np.allclose(sum(parts) / e.photons, t.fraction, rtol=1e-9, atol=1e-15)


def test_fit_folder_reads(roks, workspace):
    """`roks fit` of the default scene to its own in-plane BRDF: fit.json, fit_inplane.csv, fitted.toml."""
    measured = workspace / "results" / "fit-measured"
    _run(roks, workspace, "default", measured, ["--theta", "30"])
    out = workspace / "results" / "fit"
    run([roks, "fit", workspace / "scenes" / "default.toml", measured / "inplane.csv", "--param",
         "bumps[0].height[1]=3:6", "--photons", PHOTONS, "--max-evals", 4, "--out", out, "-q"],
        "test_every_scene", echo=False)
    r = _read_every_file(out)
    assert isinstance(r, FitResult)
    (p,) = r.summary.parameters
    assert p.key == "bumps[0].height[1]" and (p.lo, p.hi) == (3.0, 6.0)
    ip = read_file(measured / "inplane.csv")
    assert np.array_equal(r.inplane.theta_o_deg, ip.theta_o_deg)
    assert np.allclose(r.inplane.measured, ip.brdf, rtol=1e-9, atol=0)
    assert r.fitted["bumps"][0]["height"][1] == p.fitted


def test_fit_folder_of_two_azimuths_reads(roks, workspace):
    """`roks fit` to an inplane.csv of two light azimuths (its phi_i_deg
    column): fit_inplane.csv keeps the column, row for row."""
    measured = workspace / "results" / "fit-measured-phi"
    _run(roks, workspace, "default", measured, ["--theta", "30", "--phi", "0,90"])
    out = workspace / "results" / "fit-phi"
    run([roks, "fit", workspace / "scenes" / "default.toml", measured / "inplane.csv", "--param",
         "bumps[0].height[1]=3:6", "--photons", PHOTONS, "--max-evals", 2, "--scan", 0, "--restarts", 0,
         "--out", out, "-q"], "test_every_scene", echo=False)
    r = _read_every_file(out)
    assert isinstance(r, FitResult)
    ip = read_file(measured / "inplane.csv")
    assert r.inplane.phi_i_deg is not None and set(r.inplane.phi_i_deg) == {0.0, 90.0}
    assert np.array_equal(r.inplane.phi_i_deg, ip.phi_i_deg)
    assert np.array_equal(r.inplane.theta_o_deg, ip.theta_o_deg)
    assert np.allclose(r.inplane.measured, ip.brdf, rtol=1e-9, atol=0)


def test_a_file_without_reader_is_named(tmp_path):
    p = tmp_path / "notes.txt"
    p.write_text("x\n")
    with pytest.raises(ResultError, match="notes.txt.*not a file roks writes"):
        read_file(p)
