"""The readers of `roks_tools.results` and `roks_tools.summary` on broken
copies of files roks writes: whatever the bytes, a reader returns or raises
`ResultError` naming the file, never another exception (UnicodeDecodeError,
OverflowError, _csv.Error, RecursionError, IndexError, ...), and a table or
JSON file cut anywhere, even inside its last number, is refused.

The genuine files come from small runs of the roks binary: a Stokes and a
Mueller run of the default scene, a spectral run of gold (colour.csv), a
shard (tallies.json), an object scene with a Stokes far field and a fit. The
random corruptions use a fixed seed, so a failure repeats.
"""

from __future__ import annotations

import json
import random
import shutil
from pathlib import Path

import pytest

from roks_tools.results import ResultError, TraceResult, load_result, read_file
from roks_tools.runner import repo_root, run

SCENES = repo_root() / "scenes"


@pytest.fixture(scope="module")
def genuine(roks, tmp_path_factory) -> dict[str, Path]:
    """{file name: a genuine file roks wrote} (small tables)."""
    tmp = tmp_path_factory.mktemp("genuine")
    q = ["-q"]
    run([roks, "brdf", SCENES / "default.toml", "--photons", 1024, "--theta", "0,60", "--polarisation", "stokes",
         "--out", tmp / "stokes", *q], "test_readers_bad_bytes", echo=False)
    run([roks, "brdf", SCENES / "default.toml", "--photons", 1024, "--theta", "30", "--polarisation", "mueller",
         "--out", tmp / "mueller", *q], "test_readers_bad_bytes", echo=False)
    run([roks, "brdf", SCENES / "gold-spectral.toml", "--photons", 1024, "--theta", "0",
         "--out", tmp / "gold", *q], "test_readers_bad_bytes", echo=False)
    run([roks, "brdf", SCENES / "default.toml", "--photons", 8192, "--theta", "0", "--shard", "0/2",
         "--out", tmp / "shard", *q], "test_readers_bad_bytes", echo=False)
    shutil.copytree(SCENES, tmp / "scenes")
    text = (tmp / "scenes" / "cylinder-cavity.toml").read_text()
    text = text.replace("steps = 49", "steps = 2").replace("bands = 32", "bands = 4")
    (tmp / "scenes" / "cavity.toml").write_text(text + 'polarisation = "stokes"\n')
    run([roks, "trace", tmp / "scenes" / "cavity.toml", "--photons", 500, "--out", tmp / "trace", *q],
        "test_readers_bad_bytes", echo=False)
    run([roks, "fit", SCENES / "default.toml", tmp / "stokes" / "inplane.csv", "--param", "bumps[0].height[1]=3:6",
         "--photons", 1024, "--max-evals", 3, "--out", tmp / "fit", *q], "test_readers_bad_bytes", echo=False)
    files = {
        "brdf.csv": tmp / "stokes" / "brdf.csv",
        "inplane.csv": tmp / "stokes" / "inplane.csv",
        "stokes.csv": tmp / "stokes" / "stokes.csv",
        "mueller.csv": tmp / "mueller" / "mueller.csv",
        "colour.csv": tmp / "gold" / "colour.csv",
        "summary.json": tmp / "gold" / "summary.json",
        "tallies.json": tmp / "shard" / "tallies.json",
        "reflectance.csv": tmp / "trace" / "reflectance.csv",
        "farfield.csv": tmp / "trace" / "farfield.csv",
        "farfield_stokes.csv": tmp / "trace" / "farfield_stokes.csv",
        "trace-summary.json": tmp / "trace" / "summary.json",
        "fit.json": tmp / "fit" / "fit.json",
        "fit_inplane.csv": tmp / "fit" / "fit_inplane.csv",
    }
    for path in files.values():
        read_file(path)  # the genuine files read
    return files


def _broken(tmp_path: Path, src: Path, data: bytes) -> Path:
    """`data` written under the genuine file's name in a fresh folder."""
    folder = tmp_path / f"case{len(list(tmp_path.iterdir()))}"
    folder.mkdir()
    p = folder / src.name
    p.write_bytes(data)
    return p


def _refused(path: Path, what: str = ""):
    with pytest.raises(ResultError) as e:
        read_file(path)
    msg = str(e.value)
    assert str(path) in msg and "\n" not in msg, msg
    assert what in msg, msg
    return msg


NAMES = ["brdf.csv", "inplane.csv", "stokes.csv", "mueller.csv", "colour.csv", "summary.json", "tallies.json",
         "reflectance.csv", "farfield.csv", "farfield_stokes.csv", "trace-summary.json", "fit.json", "fit_inplane.csv"]


@pytest.mark.parametrize("name", NAMES)
def test_cut_inside_the_last_number_is_refused(genuine, tmp_path, name):
    data = genuine[name].read_bytes()
    assert data.endswith(b"\n") or name.endswith(".json")
    body = data.rstrip(b"\n")
    # the end of line gone (a table), then the last characters of the last number (or of the JSON) one by one
    for cut in range(1 if name.endswith(".json") else 0, 5):
        _refused(_broken(tmp_path, genuine[name], body[:len(body) - cut]))


@pytest.mark.parametrize("name", ["brdf.csv", "inplane.csv", "stokes.csv", "mueller.csv", "colour.csv",
                                  "farfield.csv", "farfield_stokes.csv"])
def test_cut_at_the_end_of_a_line_is_refused(genuine, tmp_path, name):
    """Whole last lines missing: the blocks are no longer complete Carlson grids (or equal in-plane blocks)."""
    lines = genuine[name].read_bytes().splitlines(keepends=True)
    for drop in (1, 2, len(lines) // 3):
        _refused(_broken(tmp_path, genuine[name], b"".join(lines[:-drop])))


def test_reflectance_cut_at_a_line_end_is_refused_by_the_folder(genuine, tmp_path):
    folder = tmp_path / "trace"
    shutil.copytree(genuine["reflectance.csv"].parent, folder)
    lines = (folder / "reflectance.csv").read_bytes().splitlines(keepends=True)
    (folder / "reflectance.csv").write_bytes(b"".join(lines[:-1]))
    with pytest.raises(ResultError, match=r"reflectance.csv: 1 rows for 2 positions"):
        TraceResult.load(folder)


def _replace_number(data: bytes, new: bytes) -> bytes:
    """The first number of the second line replaced by `new`."""
    first, rest = data.split(b"\n", 1)
    cell, tail = rest.split(b",", 1)
    return first + b"\n" + new + b"," + tail


@pytest.mark.parametrize("bad,what", [
    (b"\xff\xfe", "not UTF-8"),
    (b"1\x002", "NUL byte"),
    (b"1e999", "not a finite number"),
    (b"nan", "not a finite number"),
    (b"-inf", "not a finite number"),
    (b"x" * 200_000, "is not a number"),        # larger than the csv module's field limit
    (b'"1\n2"', "line 2"),                       # a quoted field with an end of line
    (b"", "is not a number"),
])
@pytest.mark.parametrize("name", ["brdf.csv", "stokes.csv", "farfield.csv", "reflectance.csv"])
def test_bad_cells_are_named(genuine, tmp_path, name, bad, what):
    _refused(_broken(tmp_path, genuine[name], _replace_number(genuine[name].read_bytes(), bad)), what)


@pytest.mark.parametrize("text,what", [
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"incidence": [], "bands": 1e999}', "expected an integer"),
    ('{"incidence": [{"theta_deg": 0, "phi_deg": 0, "photons": 1e999}]}', "expected an integer"),
    ('{"incidence": [], "seconds": NaN}', "NaN is not a JSON number"),
    ('{"incidence": [], "seconds": 1e999}', "out of the range of a float"),
    ('{"incidence": "x"}', "incidence: expected a list"),
    ('{"incidence": [], "surface": {"height_map_resolution": true}}', "surface.height_map_resolution"),
    ("\ufeff{}", "not JSON"),
    ("", "not JSON"),
])
def test_bad_json_is_named(genuine, tmp_path, text, what):
    _refused(_broken(tmp_path, genuine["summary.json"], text.encode()), what)
    (tmp_path / "tallies.json").write_text(text)
    with pytest.raises(ResultError, match="tallies.json"):
        read_file(tmp_path / "tallies.json")


def _refused_or_read(p: Path) -> bool:
    """Read `p`: True when refused with a ResultError of one line naming it,
    False when read (any other exception fails the test)."""
    try:
        read_file(p)
    except ResultError as e:
        assert str(p) in str(e) and "\n" not in str(e), str(e)
        return True
    return False


def _mutate(data: bytes, rng: random.Random, kinds: int = 8) -> bytes:
    """One random corruption of `data`, of one of the first `kinds` kinds
    (4: the byte-level ones only, for binary files)."""
    n = len(data)
    i = rng.randrange(n)
    kind = rng.randrange(kinds)
    if kind == 0:  # one byte changed to any byte
        return data[:i] + bytes([rng.randrange(256)]) + data[i + 1:]
    if kind == 1:  # random bytes inserted
        return data[:i] + bytes(rng.randrange(256) for _ in range(rng.randrange(1, 8))) + data[i:]
    if kind == 2:  # a span deleted
        return data[:i] + data[i + rng.randrange(1, 200):]
    if kind == 3:  # cut anywhere
        return data[:i]
    lines = data.split(b"\n")
    j, k = rng.randrange(len(lines)), rng.randrange(len(lines))
    if kind == 4:  # a line duplicated
        lines.insert(j, lines[k])
    elif kind == 5:  # two lines swapped
        lines[j], lines[k] = lines[k], lines[j]
    else:  # a token put in place of a number or key
        token = rng.choice([b"nan", b"inf", b"-", b"1e999", b"", b'"', b"0x1", b"\xc3\xa9", b"1,2", b"{", b"[[",
                            b"null", b"true", b"-1", b"99999999999999999999999", b"1.5"])
        parts = lines[j].split(b",")
        parts[rng.randrange(len(parts))] = token
        lines[j] = b",".join(parts)
    return b"\n".join(lines)


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_random_corruptions_raise_only_result_error(genuine, tmp_path, name):
    rng = random.Random(f"roks-{name}")
    data = genuine[name].read_bytes()
    refused = 0
    for _ in range(60):
        refused += _refused_or_read(_broken(tmp_path, genuine[name], _mutate(data, rng)))
    assert refused > 0


def test_whole_folder_with_a_file_of_another_run_is_refused(genuine, tmp_path):
    folder = tmp_path / "mixed"
    shutil.copytree(genuine["stokes.csv"].parent, folder)
    shutil.copy(genuine["colour.csv"].parent / "summary.json", folder / "summary.json")
    with pytest.raises(ResultError, match="summary.json"):
        load_result(folder)


def test_a_file_name_with_an_end_of_line_is_one_line(tmp_path):
    folder = tmp_path / "a\nb"
    folder.mkdir()
    (folder / "brdf.csv").write_text("x\n")
    with pytest.raises(ResultError) as e:
        read_file(folder / "brdf.csv")
    assert "\n" not in str(e.value) and "a\\nb" in str(e.value)


def test_polar_table_with_more_columns_reads(genuine, tmp_path):
    """mueller.csv that gains columns (e.g. standard errors of m_ij/m00, NaN where m00 = 0) still reads;
    a column of another name is refused."""
    from roks_tools.results import PolarTable
    lines = genuine["mueller.csv"].read_text().splitlines()
    head = lines[0] + ",m01_norm_stderr"
    body = [ln + (",nan" if i == 0 else ",0.5") for i, ln in enumerate(lines[1:])]
    p = _broken(tmp_path, genuine["mueller.csv"], ("\n".join([head, *body]) + "\n").encode())
    t = PolarTable.read(p)
    # roks's own m_ij/m00 errors are extra columns too, then the new one.
    assert list(t.extra) == [f"m{i}{j}_m00_stderr" for i in range(4) for j in range(4)][1:] + ["m01_norm_stderr"]
    assert t.extra["m01_norm_stderr"][1] == 0.5
    p.write_text("\n".join([lines[0] + ",other", *(ln + ",1" for ln in lines[1:])]) + "\n")
    _refused(p, "not the header")


def test_a_missing_far_field_is_told_from_one_never_tallied(genuine, tmp_path):
    """summary.json of roks trace says whether each far field was tallied
    (`farfield`, `farfield_stokes`): a folder that lost farfield.csv is
    refused naming it, and one whose summary says the far field was not
    tallied reads without it."""
    folder = tmp_path / "trace"
    shutil.copytree(genuine["trace-summary.json"].parent, folder)
    r = load_result(folder)
    assert r.summary.farfield and r.summary.farfield_stokes and r.farfield is not None
    (folder / "farfield.csv").unlink()
    with pytest.raises(ResultError, match=r"farfield\.csv: summary\.json says the far field was tallied, but the file is missing"):
        load_result(folder)
    s = json.loads((folder / "summary.json").read_text())
    s["farfield"] = False
    (folder / "summary.json").write_text(json.dumps(s))
    r = load_result(folder)
    assert not r.summary.farfield and r.farfield is None
