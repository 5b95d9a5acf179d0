"""The in-process module `roks` (python/roks, its core python/src/lib.rs):
runs in this process give the command line's folders byte for byte, a
numpy height map the result of the same map read from its file, the GIL is
released while tracing, KeyboardInterrupt stops a run within a second
writing nothing, bad input raises roks.RoksError with the command line's
message, and the package's `roks` command is the binary's command line.

The command line is `$ROKS_BIN` (the binary cargo built; see conftest.py);
the module is the one installed in this Python (scripts/setup_venv.sh)."""

from __future__ import annotations

import _thread
import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import roks

REPO = Path(__file__).resolve().parents[2]

# summary.json's figures of the machine, not of the physics (as
# tests/golden.rs strips them): wall-clock time and speeds.
MACHINE_KEYS = ("seconds", "segments_per_second")


def _strip(v):
    if isinstance(v, dict):
        return {k: _strip(x) for k, x in v.items() if k not in MACHINE_KEYS}
    if isinstance(v, list):
        return [_strip(x) for x in v]
    return v


def assert_same_folder(a: Path, b: Path) -> None:
    """Every file of `a` and `b` (the record .roks-files.json included) is
    byte-identical, but summary.json's wall-clock figures."""
    names_a = sorted(p.name for p in a.iterdir())
    names_b = sorted(p.name for p in b.iterdir())
    assert names_a == names_b
    assert ".roks-files.json" in names_a
    for name in names_a:
        x, y = (a / name).read_bytes(), (b / name).read_bytes()
        if name == "summary.json":
            x, y = _strip(json.loads(x)), _strip(json.loads(y))
        assert x == y, f"{name} differs"


def cli(roks_bin: str, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [roks_bin, *args], capture_output=True, text=True, cwd=cwd, timeout=600
    )


@pytest.fixture(scope="session")
def roks_bin() -> str:
    """The roks binary (conftest.py's `roks` fixture, renamed here: this
    file's `roks` is the module)."""
    from roks_tools.errors import BinaryNotFound
    from roks_tools.runner import roks_binary

    try:
        return str(roks_binary())
    except BinaryNotFound as e:
        pytest.fail(str(e))


SMALL = dict(photons=4096, theta_deg=[30, 60])
SMALL_ARGS = ["--photons", "4096", "--theta", "30,60", "--stats-resolution", "32"]


@pytest.mark.parametrize(
    "options,args",
    [
        ({}, []),
        (dict(wavelengths_um=[0.45, 0.6]), ["--wavelengths", "0.45,0.6"]),
        (dict(polarisation="mueller", phi_deg=[0, 90]), ["--polarisation", "mueller", "--phi", "0,90"]),
    ],
    ids=["default", "spectral", "mueller"],
)
def test_brdf_in_process_writes_the_command_lines_folder(roks_bin, tmp_path, options, args):
    scene = roks.Scene.load().override(**SMALL, **options)
    result = roks.brdf(scene, threads=2, stats_resolution=32)
    result.write(tmp_path / "py")
    p = cli(roks_bin, "brdf", *SMALL_ARGS, *args, "--out", str(tmp_path / "cli"), "-q", "--threads", "1")
    assert p.returncode == 0, p.stderr
    assert_same_folder(tmp_path / "py", tmp_path / "cli")
    # Loaded back: the same arrays, and written again the same bytes.
    back = roks.load(tmp_path / "cli")
    assert not back.traced and result.traced
    for name in ("reflectance", "reflectance_stderr", "brdf", "brdf_stderr", "inplane"):
        np.testing.assert_array_equal(getattr(back, name), getattr(result, name))
    back.write(tmp_path / "again")
    assert_same_folder(tmp_path / "again", tmp_path / "cli")


def test_object_trace_in_process_writes_the_command_lines_folder(roks_bin, tmp_path, monkeypatch):
    # The scene named as the command line is given it (summary.json and
    # the pictures name it).
    monkeypatch.chdir(REPO)
    scene = roks.Scene.load("scenes/cylinder-cavity.toml").override(photons=1000)
    assert scene.is_object
    result = roks.trace(scene, threads=2)
    result.write(tmp_path / "py")
    p = cli(
        roks_bin, "trace", "scenes/cylinder-cavity.toml", "--photons", "1000",
        "--out", str(tmp_path / "cli"), "-q",
    )
    assert p.returncode == 0, p.stderr
    assert_same_folder(tmp_path / "py", tmp_path / "cli")
    back = roks.load(tmp_path / "cli")
    assert isinstance(back, roks.TraceResult) and not back.traced and result.traced
    assert set(back.reflectance) == set(result.reflectance)
    for k, v in result.reflectance.items():
        np.testing.assert_array_equal(back.reflectance[k], v)
    with pytest.raises(roks.OptionError, match="roks.brdf takes micro scenes"):
        roks.brdf(scene)


def test_the_shapes_follow_the_result_tree():
    r = roks.brdf(
        roks.Scene.load().override(photons=4096, theta_deg=[20, 40, 60], phi_deg=[0, 45],
                                   wavelengths_um=[0.5, 0.6], polarisation="mueller"),
        stats_resolution=16,
    )
    cells = r.shape[3]
    assert r.shape == (3, 2, 2, cells)
    assert r.reflectance.shape == (3, 2, 2)
    assert r.brdf.shape == r.brdf_stderr.shape == (3, 2, 2, cells)
    assert r.mueller.shape == (3, 2, 2, cells, 4, 4)
    assert r.stokes is None
    assert r.cells.theta_deg.shape == (cells,)
    assert r.description.run.theta_deg == (20.0, 40.0, 60.0)
    # The rows of brdf.csv in tree order: the block of (40 deg, phi 45,
    # 0.6 um) is where the tree puts it.
    t = roks._results._columns(r._native, "brdf.csv")
    rows = (t["theta_i_deg"] == 40) & (t["phi_i_deg"] == 45) & (t["wavelength_um"] == 0.6)
    np.testing.assert_array_equal(r.brdf[1, 1, 1], t["brdf"][rows])
    s = r.select(theta_deg=40, phi_deg=45, wavelength_um=0.6)
    np.testing.assert_array_equal(s.brdf, r.brdf[1, 1, 1])
    assert s.reflectance == r.reflectance[1, 1, 1]
    # Never a silent mix: an axis of several values must be named, a value
    # not in the run is refused.
    with pytest.raises(roks.SelectionError, match="phi_deg: the run has 2 values"):
        r.select(theta_deg=40, wavelength_um=0.6)
    with pytest.raises(roks.SelectionError, match="theta_deg: 30 is not in the run"):
        r.select(theta_deg=30, phi_deg=0, wavelength_um=0.6)


def test_a_numpy_height_map_is_the_same_map_read_from_its_file(tmp_path):
    rng = np.random.default_rng(3)
    ny, nx = 24, 32
    h = rng.normal(scale=0.2, size=(ny, nx))
    # The text map, exactly (repr round-trips), row j at y = j pixel.
    (tmp_path / "map.txt").write_text("\n".join(" ".join(repr(float(z)) for z in row) for row in h) + "\n")
    text = """
name = "measured"
[materials.metal]
n = 1.015
k = 6.627
[surface]
material = "metal"
heightfield = { file = "map.txt", pixel = 0.25 }
[light]
photons = 4096
theta_deg = [20]
"""
    (tmp_path / "scene.toml").write_text(text)
    from_file = roks.brdf(roks.Scene.load(tmp_path / "scene.toml"))
    scene = roks.Scene.from_toml(text, base_dir=tmp_path).with_height_map(h, pixel=0.25)
    from_array = roks.brdf(scene)
    for name in ("reflectance", "reflectance_stderr", "brdf", "brdf_stderr", "inplane"):
        np.testing.assert_array_equal(getattr(from_array, name), getattr(from_file, name))
    assert from_array.description.surface == from_file.description.surface
    # The array transposed is another surface (the layout is checked).
    other = roks.brdf(roks.Scene.from_toml(text, base_dir=tmp_path).with_height_map(
        np.ascontiguousarray(h[:, ::-1]), pixel=0.25))
    assert not np.array_equal(other.brdf, from_file.brdf)
    # Checked as the file's key is: one row is too few, NaN not a height.
    with pytest.raises(roks.SceneError, match=r"surface\.heightfield\.file: <height map array>: .*"):
        roks.Scene.from_toml(text, base_dir=tmp_path).with_height_map(h[:1], pixel=0.25)
    bad = h.copy()
    bad[2, 5] = np.nan
    with pytest.raises(roks.SceneError, match="height at row 2, column 5 is not finite"):
        roks.Scene.from_toml(text, base_dir=tmp_path).with_height_map(bad, pixel=0.25)


def test_tracing_releases_the_gil():
    scene = roks.Scene.load().override(photons=1_000_000, theta_deg=[30])
    counts = [0]
    stop = threading.Event()

    def count():
        while not stop.is_set():
            counts[0] += 1

    t = threading.Thread(target=count)
    t.start()
    try:
        # Let the counter run alone first: its rate with the GIL free.
        time.sleep(0.2)
        before = counts[0]
        start = time.perf_counter()
        roks.brdf(scene, threads=1, stats_resolution=16)
        seconds = time.perf_counter() - start
        during = counts[0] - before
    finally:
        stop.set()
        t.join()
    # The counter ran all along: far more than the few iterations a thread
    # gets when another holds the GIL (it is handed over every 5 ms).
    assert seconds > 0.2
    assert during > 10_000 * seconds, (during, seconds)


def test_keyboard_interrupt_stops_a_long_run_within_a_second(tmp_path):
    scene = roks.Scene.load().override(photons=100_000_000, theta_deg=[30])
    timer = threading.Timer(1.0, _thread.interrupt_main)
    timer.start()
    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        roks.brdf(scene, threads=2, stats_resolution=16).write(tmp_path / "out")
    latency = time.perf_counter() - start - 1.0
    timer.join()
    assert latency < 1.0, latency
    assert not (tmp_path / "out").exists()
    assert list(tmp_path.iterdir()) == []
    # The process goes on: another run works.
    assert roks.brdf(roks.Scene.load().override(photons=4096, theta_deg=[30]),
                     stats_resolution=16).reflectance.shape == (1, 1, 1)


def test_bad_input_raises_the_command_lines_message(roks_bin, tmp_path):
    text = '[surface]\nmaterial = "m"\nsize = [1.0, 1.0]\ncolour = 3\n'
    (tmp_path / "bad.toml").write_text(text)
    with pytest.raises(roks.RoksError) as e:
        roks.Scene.load(tmp_path / "bad.toml")
    assert isinstance(e.value, roks.SceneError)
    p = cli(roks_bin, "brdf", str(tmp_path / "bad.toml"), "--check")
    assert p.returncode == 2
    assert p.stderr.strip() == f"roks: {e.value}"
    assert "surface.colour" in str(e.value)
    # From text: the same key, the text named <scene text>.
    with pytest.raises(roks.SceneError, match=r"^<scene text>: .*surface\.colour"):
        roks.Scene.from_toml(text)
    # An option: the command line's message naming the option.
    with pytest.raises(roks.OptionError) as e:
        roks.Scene.load().override(theta_deg=[95])
    p = cli(roks_bin, "brdf", "--theta", "95", "--check")
    assert p.returncode == 2 and p.stderr.strip() == f"roks: {e.value}"
    with pytest.raises(roks.OptionError, match="colour: not an option"):
        roks.Scene.load().override(colour=3)
    # An output roks did not write is refused (roks.OutputError).
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine/notes.txt").write_text("keep")
    r = roks.brdf(roks.Scene.load().override(photons=4096, theta_deg=[30]), stats_resolution=16)
    with pytest.raises(roks.OutputError):
        r.write(tmp_path / "mine")
    assert (tmp_path / "mine/notes.txt").read_text() == "keep"


def test_threads_do_not_change_the_result():
    scene = roks.Scene.load().override(photons=8192, theta_deg=[45])
    one = roks.brdf(scene, threads=1, stats_resolution=16)
    three = roks.brdf(scene, threads=3, stats_resolution=16)
    np.testing.assert_array_equal(one.brdf, three.brdf)
    with pytest.raises(roks.OptionError, match="^--threads: "):
        roks.brdf(scene, threads=0)


def test_stats_are_roks_stats_json(roks_bin):
    p = cli(roks_bin, "stats", "--json", "--resolution", "64")
    assert p.returncode == 0, p.stderr
    assert roks.stats(roks.Scene.load(), resolution=64) == json.loads(p.stdout)


def _installed_roks() -> str | None:
    """The `roks` console command of this Python's environment."""
    exe = Path(sys.executable).with_name("roks")
    return str(exe) if exe.exists() else None


def test_the_console_command_is_the_binarys_command_line(roks_bin, tmp_path):
    exe = _installed_roks()
    if exe is None:
        pytest.skip(f"no roks command beside {sys.executable}")
    assert exe != roks_bin
    v = cli(exe, "--version")
    assert v.returncode == 0 and v.stdout == cli(roks_bin, "--version").stdout
    args = ["brdf", "--photons", "4096", "--theta", "30", "--stats-resolution", "16", "-q"]
    a = cli(exe, *args, "--out", str(tmp_path / "a"))
    b = cli(roks_bin, *args, "--out", str(tmp_path / "b"))
    assert a.returncode == b.returncode == 0, a.stderr + b.stderr
    assert_same_folder(tmp_path / "a", tmp_path / "b")
    # Bad input: the same line and status.
    a, b = cli(exe, "brdf", "--seed", "-1"), cli(roks_bin, "brdf", "--seed", "-1")
    assert (a.returncode, a.stderr) == (b.returncode, b.stderr) == (2, b.stderr)


def test_exports_and_fits_are_the_command_lines(roks_bin, tmp_path):
    args = ["--photons", "4096", "--theta", "20,50", "--stats-resolution", "16", "-q"]
    p = cli(roks_bin, "brdf", *args, "--export", "zemax", "--out", str(tmp_path / "cli"))
    assert p.returncode == 0, p.stderr
    traced = roks.brdf(roks.Scene.load().override(photons=4096, theta_deg=[20, 50]), stats_resolution=16)
    e = traced.export("zemax")
    # As `roks brdf --export zemax` makes it, with its checks as values.
    assert e.files == {"brdf.bsdf": (tmp_path / "cli/brdf.bsdf").read_bytes()}
    assert [c.theta_i_deg for c in e.checks] == [20.0, 50.0]
    assert all(np.isfinite(c.sigmas) for c in e.checks)
    # A loaded result as `roks export-brdf` makes it, written where asked.
    loaded = roks.load(tmp_path / "cli")
    loaded.export("zemax", tmp_path / "py.bsdf")
    p = cli(roks_bin, "export-brdf", str(tmp_path / "cli"), "--format", "zemax",
            "--out", str(tmp_path / "cli.bsdf"), "-q")
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "py.bsdf").read_bytes() == (tmp_path / "cli.bsdf").read_bytes()
    with pytest.raises(roks.OptionError, match="--format"):
        loaded.export("nonsense")
    # A fit: the JSON roks fit-model writes, as a value.
    fit = loaded.fit_model("abg")
    p = cli(roks_bin, "fit-model", str(tmp_path / "cli"), "--model", "abg", "-q")
    assert p.returncode == 0, p.stderr
    assert fit.results["fit_abg.json"] == json.loads((tmp_path / "cli/fit_abg.json").read_text())
    assert not (tmp_path / "cli/fit_abg.png").exists() or fit.files["fit_abg.png"]
    traced_fit = traced.fit_model("abg")
    a, b = traced_fit.results["fit_abg.json"], fit.results["fit_abg.json"]
    a.pop("table"), b.pop("table")
    assert a == b
    # Fitted from its files as values, nothing written: the command line's
    # bytes, the table named by its bare name, the same lines.
    table = json.dumps(str(tmp_path / "cli/brdf.csv"))
    cli_json = (tmp_path / "cli/fit_abg.json").read_text()
    assert traced_fit.files["fit_abg.json"].decode() == cli_json.replace(
        f'"table": {table}', '"table": "brdf.csv"')
    assert traced_fit.files["fit_abg.png"] == fit.files["fit_abg.png"]
    assert traced_fit.lines == fit.lines
