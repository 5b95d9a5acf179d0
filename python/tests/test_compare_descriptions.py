"""roks-compare-brdf compares the run descriptions before the statistics
(issue 42, section 4): a polarised run against an unpolarised one is named
as such ("descriptions differ: polarisation roks=stokes vs mitsuba=none")
and judged FAIL for that reason, not as "too few photons", even where the
cells agree; like runs are judged on their statistics alone."""

from __future__ import annotations

import json
import shutil

import pytest

from roks_tools import compare as cb
from roks_tools.runner import repo_root, run

SCENES = repo_root() / "scenes"


@pytest.fixture(scope="module")
def runs(roks, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("compare")
    # The default scene's paint is a constant reflectance: polarised transport does not change the
    # intensity, so the scalar and the Stokes run agree cell by cell; only their descriptions differ.
    run([roks, "brdf", SCENES / "default.toml", "--photons", 3000, "--theta", "0,30", "--out", tmp / "scalar",
         "-q"], "test_compare_descriptions", echo=False)
    run([roks, "brdf", SCENES / "default.toml", "--photons", 3000, "--theta", "30,60", "--seed", 2,
         "--polarisation", "stokes", "--out", tmp / "stokes", "-q"], "test_compare_descriptions", echo=False)
    run([roks, "brdf", SCENES / "default.toml", "--photons", 300, "--theta", "0,60", "--phi", "0,90",
         "--out", tmp / "two", "-q"], "test_compare_descriptions", echo=False)
    # The scalar run as the Mitsuba tracer writes its summary.json (its own keys, `polarisation`: "none").
    mitsuba = tmp / "mitsuba"
    shutil.copytree(tmp / "scalar", mitsuba)
    s = json.loads((tmp / "scalar" / "summary.json").read_text())
    (mitsuba / "summary.json").write_text(json.dumps({
        "incidence": s["incidence"], "seed": 1, "bands": s["run"]["bands"], "polarisation": "none",
        "incident_stokes": [1.0, 0.0, 0.0, 0.0], "material": {"reflectance": 0.8}, "variant": "scalar_rgb",
        "mitsuba_version": "3.9.1", "version": "test"}))
    return tmp


def _report(capsys, a, b):
    code = cb.main([str(a), str(b)])
    return code, capsys.readouterr().out.splitlines()


def test_polarised_against_unpolarised_is_named_first(runs, capsys):
    code, out = _report(capsys, runs / "stokes", runs / "mitsuba")
    assert out[0] == ("descriptions differ: polarisation roks=stokes vs mitsuba=none; incidences only in roks: "
                      "[60], only in mitsuba: [0] (not compared)"), out[0]
    (row,) = cb.compare(runs / "stokes", runs / "mitsuba")
    assert row["theta"] == 30.0 and row["pass"]  # the cells agree
    assert out[-1].startswith("verdict: FAIL: the runs are not alike: polarisation (roks=stokes vs mitsuba=none); "
                              "the statistics pass"), out[-1]
    assert not any("too few photons" in line for line in out)
    assert code == 1


def test_the_sides_are_a_and_b_when_roks_wrote_both(runs, capsys):
    code, out = _report(capsys, runs / "scalar", runs / "stokes")
    assert out[0].startswith("descriptions differ: polarisation A=none vs B=stokes;"), out[0]
    assert code == 1


def test_like_runs_are_judged_on_their_statistics(runs, capsys):
    code, out = _report(capsys, runs / "scalar", runs / "scalar")
    assert not any(line.startswith("descriptions differ") for line in out)
    # incidences and azimuths on one side only are left out, not a reason to fail: the verdict is the statistics'
    assert out[-1] in ("verdict: pass", "verdict: FAIL") and code == (out[-1] == "verdict: FAIL")
    # the scalar run and its Mitsuba-style copy: the same description (roks records no material)
    da, db = cb.describe(runs / "scalar"), cb.describe(runs / "mitsuba")
    assert cb.description_differences(da, db) == []
    assert cb.sides(da, db) == ("roks", "mitsuba")


def test_description_differences_name_each_key(runs):
    d = cb.describe(runs / "stokes")
    assert (d["transport"], d["tally"], d["polarisation"], d["incident"]) == ("polarised", "stokes", "stokes",
                                                                               [1.0, 0.0, 0.0, 0.0])
    other = {**d, "wavelengths": [0.45, 0.55], "bands": 16, "symmetry": "mirror", "incident": [1.0, 1.0, 0.0, 0.0]}
    diffs = cb.description_differences(d, other)
    assert [k for k, _, _ in diffs] == ["incident polarisation", "wavelengths", "bands", "symmetry"]
    assert cb.differences_line(diffs, ("A", "B")) == (
        "descriptions differ: incident polarisation A=[1, 0, 0, 0] vs B=[1, 1, 0, 0]; wavelengths A=monochrome "
        "vs B=[0.45, 0.55]; bands A=32 vs B=16; symmetry A=none vs B=mirror")
    assert cb._incident_stokes({"linear": 45}) == pytest.approx([1.0, 0.0, 1.0, 0.0], abs=1e-15)


def test_several_azimuths_are_compared_one_by_one(runs, capsys):
    """Blocks are matched by incidence angle and azimuth (a table of two azimuths was keyed by angle)."""
    rows = cb.compare(runs / "two", runs / "two")
    assert [(r["theta"], r["phi"]) for r in rows] == [(0.0, 0.0), (0.0, 90.0), (60.0, 0.0), (60.0, 90.0)]
    assert all(r["pass"] and r["chi2_dof"] == 0 for r in rows)
    text = cb.table(rows)
    assert text.splitlines()[0].split()[0] == "th/phi" and text.splitlines()[4].split()[0] == "60/90"
    code, out = _report(capsys, runs / "two", runs / "scalar")
    assert out[0] == ("descriptions differ: incidences only in A: [0/90, 60/0, 60/90], only in B: [30/0] "
                      "(not compared); azimuths only in A: [90], only in B: - (not compared)"), out[0]
    assert out[1].split()[0] == "theta" and out[2].split()[0] == "0"  # the one incidence in both
    # incidences and azimuths on one side only are left out, not a reason to fail: the verdict is the statistics'
    assert out[-1] in ("verdict: pass", "verdict: FAIL") and code == (out[-1] == "verdict: FAIL")
