"""The tools' plumbing: studies' outputs never overwrite committed files and
default to the current folder; library code raises, `main` returns exit
codes; the cross-check's advice for a FAIL made of sparse cells."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import pytest

from roks_tools import compare as cb
from roks_tools.errors import UsageError
from roks_tools.runner import check_output, committed_files, repo_root

ROOT = repo_root()


def test_photons_needed_scales_as_the_square_of_the_relative_error():
    # every cell at 40 % with 1000 photons: 20 % needs (0.4 / 0.2)^2 = 4 times the photons
    assert cb.photons_needed([0.4] * 10, 1000) == 4000
    # 90 % quantile (linear) of nine cells at 10 % and one at 40 %: 0.13 -> 1000 * 0.4225, at least the photons run
    assert cb.photons_needed([0.1] * 9 + [0.4], 1000) == 1000
    # 90 % quantile of 0.3 everywhere at 10 000 photons: 22 500, rounded up to a thousand
    assert cb.photons_needed([0.3] * 5, 10_000) == 23_000
    # a cell without weight on this side counts as the largest finite one times sqrt(2)
    # ([0.4, 0.566] -> quantile 0.549 -> 7 538 photons -> 8 000)
    assert cb.photons_needed([0.4, math.inf], 1000) == 8000
    assert cb.photons_needed([math.inf], 1000) is None


def test_sparse_advice_only_for_a_fail_with_sparse_cells():
    row = {"theta": 30.0, "pass": False, "sparse": 12, "cells": 400, "photons_a": 1000, "photons_b": 2000,
           "photons_needed_a": 4000, "photons_needed_b": 2000}
    msg = cb.sparse_advice(row)
    assert msg.startswith("theta 30: 12 of 400 cells are sparse") and "too few photons" in msg
    assert "A 4,000 (now 1,000)" in msg and "B " not in msg  # B already has enough
    assert cb.sparse_advice({**row, "pass": True}) is None
    assert cb.sparse_advice({**row, "sparse": 0}) is None


def test_compare_reports_sparse_cells(roks, tmp_path):
    """Two runs of 64 photons: most cells hold a photon or two, so they are counted sparse."""
    from roks_tools.runner import run
    for seed in (1, 2):
        run([roks, "brdf", ROOT / "scenes" / "default.toml", "--photons", 64, "--theta", "30", "--seed", seed,
             "--out", tmp_path / f"s{seed}", "-q"], "test_tools", echo=False)
    (r,) = cb.compare(tmp_path / "s1", tmp_path / "s2")
    assert r["photons_a"] == r["photons_b"] == 64
    assert 0 < r["sparse"] <= r["cells"]
    assert r["photons_needed_a"] > 64 and r["photons_needed_a"] % 1000 == 0


def _git(*args, cwd):
    subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True)


def test_check_output_refuses_committed_files(tmp_path):
    repo = tmp_path / "repo"
    (repo / "results" / "study").mkdir(parents=True)
    (repo / "results" / "study" / "report.md").write_text("committed\n")
    _git("init", "-q", cwd=repo)
    _git("-c", "user.name=t", "-c", "user.email=t@t", "add", ".", cwd=repo)
    _git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "x", cwd=repo)
    out = repo / "results" / "study"
    assert committed_files(out) == ["report.md"]
    with pytest.raises(UsageError, match=r"--out .*results/study: holds 1 file\(s\) committed to git"):
        check_output(out)
    check_output(out, overwrite_committed=True)
    check_output(repo / "results" / "new")  # nothing there yet
    (repo / "scratch").mkdir()
    (repo / "scratch" / "x.md").write_text("not committed\n")
    check_output(repo / "scratch")
    check_output(tmp_path / "elsewhere")  # outside any git work tree


def test_crosscheck_defaults_to_the_current_folder_and_keeps_the_committed_report(tmp_path, monkeypatch):
    from roks_tools.studies import crosscheck
    monkeypatch.chdir(tmp_path)
    assert crosscheck.parse_args([]).out == Path("crosscheck")
    committed = ROOT / "results" / "crosscheck"
    if not committed_files(committed):
        pytest.skip("results/crosscheck is not committed in this checkout")
    before = {p: p.stat().st_mtime_ns for p in committed.rglob("*") if p.is_file()}
    assert crosscheck.main(["--out", str(committed), "--roks", "/nonexistent/roks"]) == 2
    assert before == {p: p.stat().st_mtime_ns for p in committed.rglob("*") if p.is_file()}


def test_library_code_raises_and_main_returns_the_status(tmp_path, capsys):
    from roks_tools import plot
    from roks_tools.results import ResultError, load_result
    with pytest.raises(ResultError):
        load_result(tmp_path)
    assert plot.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("plot_brdf: error: ") and str(tmp_path) in err and "\n" not in err


def test_no_system_exit_in_library_code():
    """SystemExit only in the `if __name__ == "__main__"` lines and scripts/ wrappers."""
    pkg = Path(__file__).resolve().parents[1] / "roks_tools"
    bad = [f"{p.relative_to(pkg)}:{i}" for p in pkg.rglob("*.py")
           for i, line in enumerate(p.read_text().splitlines(), 1)
           if ("SystemExit" in line or "sys.exit(" in line) and "main())" not in line
           and not line.lstrip().startswith("#")]
    assert bad == []


def test_plot_brdf_draws_a_spectral_result(roks, tmp_path):
    """roks-plot-brdf on a spectral folder (it said "not a roks result folder"): one wavelength drawn."""
    from roks_tools import plot
    from roks_tools.runner import run
    run([roks, "brdf", ROOT / "scenes" / "gold-spectral.toml", "--photons", 1024, "--theta", "0,60",
         "--wavelengths", "0.45,0.65", "--out", tmp_path / "gold", "-q"], "test_tools", echo=False)
    assert plot.main([str(tmp_path / "gold"), "--out", str(tmp_path / "a.png"), "--dpi", "40"]) == 0
    assert plot.main([str(tmp_path / "gold"), "--wavelength", "0.65", "--out", str(tmp_path / "b.png"),
                      "--dpi", "40"]) == 0
    assert (tmp_path / "a.png").stat().st_size > 0 and (tmp_path / "b.png").stat().st_size > 0
    assert plot.main([str(tmp_path / "gold"), "--wavelength", "0.55", "--out", str(tmp_path / "c.png")]) == 2
    entries, _, _, brdf, w = plot.load(tmp_path / "gold")
    assert w == 0.45 and set(brdf["theta_i_deg"]) == {0.0, 60.0}  # nearest 0.55 of 0.45, 0.65: the first


def test_every_study_writes_to_its_out_and_refuses_committed_results():
    """Every study script takes --out (default ./<name> in the current folder)
    and refuses, before any work, a folder of the repository's committed
    results/ unless --overwrite-committed (exit 2, one line naming --out)."""
    import subprocess
    import sys
    scripts = sorted((ROOT / "scripts").glob("*.py"))
    # make_baffled_tube.py generates the committed scenes/baffled-tube-*.toml
    # on purpose: a scene generator, not a study with results.
    studies = [s for s in scripts if "roks_tools.studies" in s.read_text() and s.name != "make_baffled_tube.py"]
    assert len(studies) >= 10, studies
    committed = ROOT / "results" / "radiator"
    if not committed_files(committed):
        pytest.skip("results/radiator is not committed in this checkout")
    for script in studies:
        helps = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True)
        assert helps.returncode == 0, (script, helps.stderr)
        assert "--out" in helps.stdout and "--overwrite-committed" in helps.stdout, script.name
        o = subprocess.run([sys.executable, str(script), "--out", str(committed)],
                           capture_output=True, text=True, timeout=120)
        assert o.returncode == 2, (script.name, o.returncode, o.stderr)
        line = o.stderr.strip()
        assert "\n" not in line and "committed to git" in line, (script.name, o.stderr)
