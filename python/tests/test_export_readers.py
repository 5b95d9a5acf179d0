"""Every file roks writes has a reader (issue 42, section 5).

One result folder made with every export and fit (`roks brdf
--polarisation mueller --export zemax,merl,rgl,pbsdf`, `roks fit-model`
for each model, `roks export-mesh`, `roks export-brdf` into it), a run of
two light azimuths (Zemax Asymmetrical4D), a spectral run (per-wavelength
Zemax files, and export-brdf's folder with export.json) and the shards of
an object scene (`roks trace --shard`): every file is read by
`read_file` (pictures too: `read_png`), and each reader is checked against
a fact it does not compute itself:

* Zemax: every grid value is the table's BRDF at the grid direction (the
  Carlson cell of brdf.csv holding it, averaged with its mirror image for
  PlaneSymmetrical; the cell of the azimuth's block, turned by the
  SampleRotation, for Asymmetrical4D), the TIS is summary.json's
  reflectance, both to the file's 7 digits;
* MERL: each bin is the reciprocal blend of the table that
  src/export/merl.rs documents, computed here from brdf.csv, through the
  documented channel scales;
* pbsdf: the nodes are the documented ones, and m00 at the specular node of
  a tabulated incidence (theta_h = 0, theta_d = 60 deg) is mueller.csv's
  m00 of the cell holding the specular direction;
* RGL: theta_i is the run's incidences, the grey file's two wavelengths the
  documented 360 and 830 nm;
* fit_<model>.json: each fit's table reflectance is the sum of brdf.csv's
  fractions; fit_abg_opticstudio.txt's rows are the JSON's to the text's
  digits; export.json names the files beside it;
* PLY: (n + 1)^2 vertices on the documented grid and 2 n^2 triangles; their
  heights those of export-heightfield's text height map.

Each new reader also refuses bad bytes (cut, garbage, another format) with
a one-line `ResultError` naming the file.
"""

from __future__ import annotations

import math
import random
import shutil
from pathlib import Path

import numpy as np
import pytest

from roks_tools.exports import (MERL_SCALES, AbgRows, HeightMap, Merl, Pbsdf, PlyMesh, RglBsdf, ZemaxBsdf,
                                zemax_direction)
from roks_tools.results import BrdfTable, InPlane, PolarTable, ResultError, load_result, read_file, read_png
from roks_tools.runner import repo_root, run
from roks_tools.summary import (ExportMarker, FitModelSummary, TraceSummary, TraceTallies, read_summary,
                                read_tallies)
from test_readers_bad_bytes import _mutate, _refused_or_read

SCENES = repo_root() / "scenes"
MODELS = ("abg", "harvey", "ggx", "beckmann")
MESH_N = 16


def _roks(roks, *args):
    run([roks, *args], "test_export_readers", echo=False)


@pytest.fixture(scope="module")
def folders(roks, tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("exports")
    default = SCENES / "default.toml"
    a = tmp / "all"
    _roks(roks, "brdf", default, "--photons", 2000, "--theta", "0,60", "--polarisation", "mueller",
          "--export", "zemax,merl,rgl,pbsdf", "--out", a, "-q")
    for m in MODELS:
        _roks(roks, "fit-model", a, "--model", m, "-q")
    _roks(roks, "export-mesh", default, "--resolution", MESH_N, "--out", a / "mesh.ply")
    _roks(roks, "export-heightfield", default, "--resolution", MESH_N, "--out", a / "heights.txt")
    _roks(roks, "export-brdf", a, "--format", "zemax", "--grid", "5,2", "--out", a / "coarse.bsdf", "-q")
    two = tmp / "two"
    _roks(roks, "brdf", default, "--photons", 500, "--theta", "0,60", "--phi", "0,90", "--export", "zemax",
          "--out", two, "-q")
    gold = tmp / "gold"
    _roks(roks, "brdf", SCENES / "gold-spectral.toml", "--photons", 500, "--theta", "0,45", "--wavelengths",
          "0.38,0.55,0.78", "--export", "zemax", "--out", gold, "-q")
    _roks(roks, "export-brdf", gold, "--format", "zemax", "--out", tmp / "goldz", "-q")
    scenes = tmp / "scenes"
    shutil.copytree(SCENES, scenes)
    text = (scenes / "cylinder-cavity.toml").read_text()
    (scenes / "cavity.toml").write_text(text.replace("steps = 49", "steps = 2").replace("bands = 32", "bands = 4"))
    for i in (0, 1):
        _roks(roks, "trace", scenes / "cavity.toml", "--photons", 500, "--shard", f"{i}/2", "--out",
              tmp / f"shard{i}", "-q")
    return {"all": a, "two": two, "gold": gold, "goldz": tmp / "goldz", "shard0": tmp / "shard0",
            "shard1": tmp / "shard1"}


# ----------------------------------------------------------------------------
# Every file of the folders
# ----------------------------------------------------------------------------


EXPECTED = {
    "brdf.bsdf": ZemaxBsdf, "coarse.bsdf": ZemaxBsdf, "brdf_rgl.bsdf": RglBsdf, "brdf.pbsdf": Pbsdf,
    "brdf.binary": Merl, "mesh.ply": PlyMesh, "heights.txt": HeightMap, "fit_abg_opticstudio.txt": AbgRows,
    **{f"fit_{m}.json": FitModelSummary for m in MODELS},
}


def test_every_file_of_a_folder_with_all_exports_and_fits_is_read(folders):
    """Every file, pictures included (`read_png`), by `read_file`: none is
    left without a reader (a file roks adds later fails here until it has one)."""
    a = folders["all"]
    names = sorted(p.name for p in a.iterdir())
    assert set(EXPECTED) <= set(names), sorted(set(EXPECTED) - set(names))
    kinds = {}
    for name in names:
        obj = read_file(a / name)
        kinds[name] = type(obj)
        if name.endswith(".png"):
            assert isinstance(obj, np.ndarray) and obj.ndim == 3
    for name, cls in EXPECTED.items():
        assert kinds[name] is cls, name
    for key in ("two", "gold", "goldz", "shard0", "shard1"):
        for p in sorted(folders[key].iterdir()):
            read_file(p)


# ----------------------------------------------------------------------------
# Zemax
# ----------------------------------------------------------------------------


def _zemax_grid(z: ZemaxBsdf, aoi: float):
    psi, r = np.meshgrid(z.azimuth_deg, z.radial_deg, indexing="ij")
    d = zemax_direction(aoi, psi.ravel(), r.ravel())
    # Above the horizon, and not the pole itself (its azimuth, so its cell of band 1, is undefined).
    ok = (d[:, 2] > 1e-12) & (np.hypot(d[:, 0], d[:, 1]) > 1e-12)
    return d, ok, d[:, 2] <= 1e-12


@pytest.mark.parametrize("name", ["brdf.bsdf", "coarse.bsdf"])
def test_zemax_plane_symmetrical_is_the_table(folders, name):
    a = folders["all"]
    z = read_file(a / name)
    s, b = read_summary(a / "summary.json"), BrdfTable.read(a / "brdf.csv")
    g = b.grid
    assert z.symmetry == "PlaneSymmetrical" and list(z.sample_rotation_deg) == [0.0]
    assert list(z.aoi_deg) == [e.theta_deg for e in s.incidence]
    assert any("roks" in c for c in z.comments)
    for e in s.incidence:
        tis, block = z.block(e.theta_deg)
        assert abs(tis - e.reflectance) <= 5e-7 * e.reflectance  # 7 significant digits
        d, ok, below = _zemax_grid(z, e.theta_deg)
        brdf = b.at(e.theta_deg).brdf
        want = 0.5 * (brdf[g.locate(d[ok])] + brdf[g.locate(d[ok] * [1, -1, 1])])
        got = block.ravel()
        assert np.allclose(got[ok], want, rtol=5e-7, atol=0)
        assert np.all(got[below] == 0)
        assert ok.sum() > 0.45 * len(got)


def test_zemax_asymmetrical_4d_is_each_azimuths_table(folders):
    d2 = folders["two"]
    z = read_file(d2 / "brdf.bsdf")
    s, b = read_summary(d2 / "summary.json"), BrdfTable.read(d2 / "brdf.csv")
    g = b.grid
    assert z.symmetry == "Asymmetrical4D" and list(z.sample_rotation_deg) == [0.0, 90.0]
    assert z.azimuth_deg[-1] == 360.0
    with pytest.raises(ResultError, match="2 sample rotations"):
        z.block(60.0)
    for e in s.incidence:
        tis, block = z.block(e.theta_deg, e.phi_deg)
        assert abs(tis - e.reflectance) <= 5e-7 * e.reflectance
        d, ok, _ = _zemax_grid(z, e.theta_deg)
        c, sn = math.cos(math.radians(e.phi_deg)), math.sin(math.radians(e.phi_deg))
        turn = np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1]])  # the light's plane to the sample: +phi_i
        want = b.at(e.theta_deg, phi=e.phi_deg).brdf[g.locate(d[ok] @ turn.T)]
        assert np.allclose(block.ravel()[ok], want, rtol=5e-7, atol=0)


def test_zemax_per_wavelength_files_and_export_json(folders):
    gold, goldz = folders["gold"], folders["goldz"]
    s = read_summary(gold / "summary.json")
    names = [f"brdf_{w:.2f}um.bsdf" for w in s.wavelengths_um]
    marker = read_file(goldz / "export.json")
    assert isinstance(marker, ExportMarker) and marker.format == "zemax" and marker.files == names
    assert marker.source.endswith("brdf.csv")
    for folder in (gold, goldz):
        for name, w in zip(names, s.wavelengths_um):
            z = read_file(folder / name)
            assert z.wavelength_um == w
            for e in s.incidence:
                want = next(x for x in e.spectrum if x.wavelength_um == w).reflectance
                assert abs(z.block(e.theta_deg)[0] - want) <= 5e-7 * want
    bad = goldz / "export.json"
    (goldz / names[1]).rename(goldz / "moved.bsdf")
    try:
        with pytest.raises(ResultError, match=r"export.json: files\[1\]: brdf_0.55um.bsdf is not beside it"):
            read_file(bad)
    finally:
        (goldz / "moved.bsdf").rename(goldz / names[1])


# ----------------------------------------------------------------------------
# MERL
# ----------------------------------------------------------------------------


def _rotate(v, axis, a):
    c, s = math.cos(a), math.sin(a)
    return v * c + axis * axis.dot(v) * (1 - c) + np.cross(axis, v) * s


def test_merl_bins_are_the_documented_blend_of_the_table(folders):
    """Each bin holds `w f(theta_i; omega_o) + (1 - w) f(theta_o; omega_i)` at
    the bin centre in index space (src/export/merl.rs): `f` the table's BRDF
    (the cell of brdf.csv, mean with its mirror image, linear in theta_i
    between the tabulated incidences, clamped beyond), `w = d_o / (d_i +
    d_o)` from the distances to the nearest tabulated incidence; the stored
    numbers times 1/1500, 1.15/1500, 1.66/1500 (a grey file: three equal
    channels)."""
    a = folders["all"]
    m = read_file(a / "brdf.binary")
    b = BrdfTable.read(a / "brdf.csv")
    g = b.grid
    thetas = np.array([t for t, _ in b.incidences])
    table = {t: b.at(t).brdf for t in thetas}
    assert m.brdf.shape == (90, 90, 180, 3)
    assert np.allclose(m.brdf, m.stored.transpose(1, 2, 3, 0) * np.array(MERL_SCALES), rtol=1e-15, atol=0)
    assert np.allclose(m.brdf[..., 1], m.brdf[..., 0], rtol=1e-13, atol=0)
    assert np.allclose(m.brdf[..., 2], m.brdf[..., 0], rtol=1e-13, atol=0)

    def f(theta, d):
        deg = math.degrees(theta)
        i1 = int(np.searchsorted(thetas, deg, side="right"))
        if i1 == 0 or i1 >= len(thetas):
            t0 = t1 = thetas[min(i1, len(thetas) - 1)]
            w = 0.0
        else:
            t0, t1 = thetas[i1 - 1], thetas[i1]
            w = min(max((deg - t0) / (t1 - t0), 0.0), 1.0)
        d = d / np.linalg.norm(d)
        cells = g.locate(np.array([d, d * [1, -1, 1]]))
        v = 0.5 * table[t0][cells].sum()
        return v if w == 0 else (1 - w) * v + w * 0.5 * table[t1][cells].sum()

    def frame(light, view):  # polar angle of light; view turned so that light is at azimuth 0
        a_ = -math.atan2(light[1], light[0])
        c, s = math.cos(a_), math.sin(a_)
        return (math.atan2(math.hypot(light[0], light[1]), light[2]),
                np.array([c * view[0] - s * view[1], s * view[0] + c * view[1], view[2]]))

    def distance(theta):
        d = float(np.min(np.abs(thetas - math.degrees(theta))))
        return 0.0 if d < 1e-9 else d

    rng = np.random.default_rng(42)
    y = np.array([0.0, 1.0, 0.0])
    checked = 0
    for _ in range(1500):
        i, j, k = (int(x) for x in rng.integers([90, 90, 180]))
        th, td, pd = ((i + 0.5) / 90) ** 2 * math.pi / 2, (j + 0.5) / 90 * math.pi / 2, (k + 0.5) / 180 * math.pi
        wi = _rotate(np.array([math.sin(td) * math.cos(pd), math.sin(td) * math.sin(pd), math.cos(td)]), y, th)
        h = np.array([math.sin(th), 0.0, math.cos(th)])
        wo = 2 * wi.dot(h) * h - wi
        if wi[2] <= 1e-6 or wo[2] <= 1e-6:
            continue  # the documented horizon raise: not checked here
        ti, out = frame(wi, wo)
        to, inc = frame(wo, wi)
        di, do = distance(ti), distance(to)
        w = do / (di + do) if di + do > 0 else 0.5
        want = (w * f(ti, out) if w > 0 else 0.0) + ((1 - w) * f(to, inc) if w < 1 else 0.0)
        assert np.allclose(m.brdf[i, j, k], want, rtol=1e-9, atol=1e-300), (i, j, k)
        # the lookup of the bin centre's own directions finds the bin
        assert np.array_equal(m.lookup(wi, wo)[0], m.brdf[i, j, k])
        checked += 1
    assert checked > 1000


# ----------------------------------------------------------------------------
# RGL and pbsdf
# ----------------------------------------------------------------------------


def test_rgl_fields(folders):
    a = folders["all"]
    r = read_file(a / "brdf_rgl.bsdf")
    s = read_summary(a / "summary.json")
    assert np.array_equal(r.theta_i, np.radians([e.theta_deg for e in s.incidence]).astype(np.float32))
    assert list(r.phi_i) == [0.0]
    assert not r.rgb and list(r.wavelengths) == [360.0, 830.0]  # a monochrome table: grey
    assert r.values.shape[:3] == (1, 2, 2) and np.array_equal(r.values[:, :, 0], r.values[:, :, 1])
    assert r.values.max() > 0 and list(r.fields["jacobian"]) == [1]
    assert {"ndf", "sigma", "vndf", "luminance", "description"} <= set(r.fields)


def test_pbsdf_nodes_and_the_specular_m00(folders):
    a = folders["all"]
    p = read_file(a / "brdf.pbsdf")
    f32 = np.float32
    assert np.array_equal(p.theta_h, f32((np.arange(46) / 45) ** 2 * math.pi / 2))
    assert np.array_equal(p.theta_d, f32(np.arange(46) / 45 * math.pi / 2))
    assert np.array_equal(p.phi_d, f32(-math.pi + np.arange(73) / 72 * 2 * math.pi))
    assert list(p.wvls) == [450, 500, 550, 600, 650]  # a monochrome table: the documented grey wavelengths
    assert p.M.shape == (73, 46, 46, 5, 4, 4)
    pol = PolarTable.read(a / "mueller.csv")
    g = BrdfTable.read(a / "brdf.csv").grid
    t = math.radians(60.0)
    cell = g.locate(np.array([[-math.sin(t), 0.0, math.cos(t)]]))[0]
    m00 = pol.values[pol.theta_i_deg == 60.0, 0][cell]
    # theta_h = 0 (node 0), theta_d = 60 deg (node 30): the light at 60 deg, the view at its mirror direction
    assert np.allclose(p.M[:, 30, 0, :, 0, 0], f32(m00), rtol=1e-6, atol=0)


# ----------------------------------------------------------------------------
# Fits, ABg rows, PLY
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("model", MODELS)
def test_fit_model_json(folders, model):
    a = folders["all"]
    f = read_file(a / f"fit_{model}.json")
    b = BrdfTable.read(a / "brdf.csv")
    assert f.model.lower() == model and f.table.endswith("brdf.csv")
    per_incidence = model in ("abg", "harvey")
    assert len(f.fits) == (2 if per_incidence else 1)
    for fit in f.fits:
        assert fit.parameters and fit.termination
        for r in fit.reflectance:
            if not fit.cells_left_out:  # every cell fitted: the table's reflectance is the sum of brdf.csv's fractions
                assert abs(r.table - b.at(r.theta_i_deg).fraction.sum()) <= 1e-9
    assert sorted(t for fit in f.fits for t in fit.theta_i_deg) == [0.0, 60.0]


def test_opticstudio_rows_are_the_fits(folders):
    a = folders["all"]
    rows = read_file(a / "fit_abg_opticstudio.txt")
    f = read_file(a / "fit_abg.json")
    want = f.opticstudio["rows"]
    assert rows.name == a.name and rows.wave_um == 0.0
    assert list(rows.angle_deg) == [r["angle_deg"] for r in want]
    assert np.allclose(rows.a, [r["a"] for r in want], rtol=5e-7, atol=0)
    assert np.allclose(rows.b, [r["b"] for r in want], rtol=5e-7, atol=0)
    assert np.allclose(rows.g, [r["g"] for r in want], rtol=0, atol=5e-7)
    assert np.allclose(rows.tis, [r["tis"] for r in want], rtol=0, atol=5e-6)
    for fit, r in zip(f.fits, want):  # the rows are the fitted parameters
        assert math.isclose(fit.parameter("A").value, r["a"], rel_tol=1e-12)


def test_ply_of_export_mesh_is_the_grid(folders):
    mesh = read_file(folders["all"] / "mesh.ply")
    n = MESH_N
    assert mesh.vertices.shape == ((n + 1) ** 2, 3) and mesh.faces.shape == (2 * n * n, 3)
    import tomllib
    lx, ly = tomllib.loads((SCENES / "default.toml").read_text())["surface"]["size"]  # one period
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="xy")  # vertex (i, j) at j (n + 1) + i
    assert np.array_equal(mesh.vertices[:, 0], np.float32(lx * (i.ravel() / n)))
    assert np.array_equal(mesh.vertices[:, 1], np.float32(ly * (j.ravel() / n)))
    # the heights of export-heightfield at the same vertices (the periodic copies i = n, j = n: those of 0)
    h = read_file(folders["all"] / "heights.txt").heights
    assert h.shape == (n, n) and any("roks height map" in c for c in read_file(folders["all"] / "heights.txt").comments)
    assert np.array_equal(mesh.vertices[:, 2], np.float32(h[j.ravel() % n, i.ravel() % n]))
    # counter-clockwise seen from above: every face normal points up
    v = mesh.vertices.astype(float)[mesh.faces]
    normal_z = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])[:, 2]
    assert np.all(normal_z > 0)


# ----------------------------------------------------------------------------
# Object shards (roks trace --shard): tallies.json
# ----------------------------------------------------------------------------


def test_read_tallies_reads_an_object_shard(folders):
    parts = [read_tallies(folders[f"shard{i}"] / "tallies.json") for i in (0, 1)]
    for i, t in enumerate(parts):
        assert isinstance(t, TraceTallies) and (t.shard.index, t.shard.count) == (i, 2)
        s = read_summary(folders[f"shard{i}"] / "summary.json")
        assert isinstance(s, TraceSummary)
        assert [p.photons for p in t.positions] == [x.photons for x in s.sources]
        for p in t.positions:  # the nodes hold the position's photons
            assert sum(int(n.tallies["photons"]) for n in p.nodes) == p.photons
        r = load_result(folders[f"shard{i}"])  # the shard's folder: summary.json and tallies.json
        assert r.reflectance is None and r.tallies.positions == t.positions
    beams = parts[0].description["beams"]
    assert [a.photons + b.photons for a, b in zip(*(t.positions for t in parts))] == [x["photons"] for x in beams]


# ----------------------------------------------------------------------------
# Selection by azimuth and wavelength; standard errors
# ----------------------------------------------------------------------------


def test_at_names_the_azimuth_of_a_run_of_several(folders):
    d2 = folders["two"]
    b, ip = BrdfTable.read(d2 / "brdf.csv"), InPlane.read(d2 / "inplane.csv")
    s = read_summary(d2 / "summary.json")
    for t in (b, ip):
        with pytest.raises(ResultError, match=r"incidence 60 deg has 2 light azimuths \(0, 90 deg\): name one, "
                                              r"e.g. at\(60, phi=0\)"):
            t.at(60)
        with pytest.raises(ResultError, match="2 light azimuths"):
            t.by_theta() if t is ip else t.cells()
    n = b.grid.n_cells
    for e in s.incidence:
        t = b.at(e.theta_deg, phi=e.phi_deg)
        assert len(t.fraction) == n and np.all(t.phi_i_deg == e.phi_deg)
        assert abs(t.fraction.sum() - e.reflectance) <= 1e-9 * n
        assert np.array_equal(b.at(e.theta_deg, e.phi_deg).fraction, t.fraction)
        assert np.all(ip.at(e.theta_deg, phi=e.phi_deg).phi_i_deg == e.phi_deg)
        assert set(b.cells(e.phi_deg)) == {0.0, 60.0}
    with pytest.raises(ResultError, match="no rows for incidence 60 deg at azimuth 45 deg"):
        b.at(60, phi=45)


def test_at_names_the_wavelength_of_a_spectral_run(folders):
    b = BrdfTable.read(folders["gold"] / "brdf.csv")
    with pytest.raises(ResultError, match=r"incidence 45 deg has 3 wavelengths \(0.38, 0.55, 0.78 um\)"):
        b.at(45)
    t = b.at(45, wavelength_um=0.55)
    assert len(t.fraction) == b.grid.n_cells and np.all(t.wavelength_um == 0.55)
    assert np.array_equal(b.at_wavelength(0.55).at(45).fraction, t.fraction)


def _edit_cell(path: Path, out: Path, line: int, column: str, value: str) -> Path:
    lines = path.read_text().split("\n")
    header = lines[0].split(",")
    cells = lines[line - 1].split(",")
    cells[header.index(column)] = value
    lines[line - 1] = ",".join(cells)
    out.mkdir(exist_ok=True)
    p = out / path.name
    p.write_text("\n".join(lines))
    return p


@pytest.mark.parametrize("name,column", [("mueller.csv", "m21_stderr"), ("mueller.csv", "m21_m00_stderr"),
                                         ("brdf.csv", "brdf_stderr"), ("inplane.csv", "brdf_stderr")])
def test_a_negative_standard_error_is_refused(folders, tmp_path, name, column):
    p = _edit_cell(folders["all"] / name, tmp_path / "neg", 6, column, "-1e-3")
    with pytest.raises(ResultError) as e:
        read_file(p)
    msg = str(e.value)
    assert msg == f"{p}: line 6 column {column}: '-1e-3' is a negative standard error", msg


def test_more_error_columns_are_read_as_extra(folders, tmp_path):
    """A table that gains columns of standard errors (an ensemble's photon-noise part) still reads; the
    values are kept in `extra` and follow a selection; a column of another name is refused."""
    src = folders["all"] / "brdf.csv"
    lines = src.read_text().splitlines()
    head = lines[0].split(",")
    k = head.index("brdf_stderr") + 1
    rows = [ln.split(",") for ln in lines[1:]]
    out = tmp_path / "extra"
    out.mkdir()
    for name in ("brdf_stderr_photon", "other"):
        new = [",".join(head[:k] + [name] + head[k:])]
        new += [",".join(r[:k] + [str(i * 0.5)] + r[k:]) for i, r in enumerate(rows)]
        (out / "brdf.csv").write_text("\n".join(new) + "\n")
        if name == "other":
            with pytest.raises(ResultError, match="not the header of roks's brdf.csv"):
                read_file(out / "brdf.csv")
            continue
        t = read_file(out / "brdf.csv")
        assert list(t.extra) == [name] and t.extra[name][3] == 1.5
        assert np.array_equal(t.brdf, BrdfTable.read(src).brdf)
        t60 = t.at(60)
        assert len(t60.extra[name]) == len(t60.brdf) and t60.extra[name][0] == 0.5 * len(t60.brdf)


# ----------------------------------------------------------------------------
# Bad bytes
# ----------------------------------------------------------------------------

BAD_NAMES = ["brdf.bsdf", "brdf_rgl.bsdf", "brdf.pbsdf", "brdf.binary", "fit_abg.json", "fit_harvey.json",
             "fit_abg_opticstudio.txt", "mesh.ply", "heights.txt", "export.json", "tallies.json"]


def _source(folders, name: str) -> Path:
    if name == "export.json":
        return folders["goldz"] / name
    if name == "tallies.json":
        return folders["shard0"] / name
    return folders["all"] / name


def _broken(tmp_path: Path, src: Path, data: bytes) -> Path:
    folder = tmp_path / f"case{len(list(tmp_path.iterdir()))}"
    folder.mkdir()
    if src.name == "export.json":  # the files it names, beside it
        for f in src.parent.iterdir():
            if f.name != "export.json":
                (folder / f.name).symlink_to(f)
    p = folder / src.name
    p.write_bytes(data)
    return p


def _refused(path: Path) -> str:
    with pytest.raises(ResultError) as e:
        read_file(path)
    msg = str(e.value)
    assert str(path) in msg and "\n" not in msg, msg
    return msg


@pytest.mark.parametrize("name", BAD_NAMES)
def test_cut_files_are_refused(folders, tmp_path, name):
    data = _source(folders, name).read_bytes()
    for cut in (0, 1, 7, 13, 100, len(data) // 2, len(data) - 9, len(data) - 2):
        if 0 <= cut < len(data):
            _refused(_broken(tmp_path, _source(folders, name), data[:cut]))


@pytest.mark.parametrize("name", BAD_NAMES)
def test_garbage_and_other_formats_are_refused(folders, tmp_path, name):
    src = _source(folders, name)
    rng = random.Random(f"garbage-{name}")
    _refused(_broken(tmp_path, src, bytes(rng.randrange(256) for _ in range(5000))))
    _refused(_broken(tmp_path, src, b"\x00" * 4096))
    # another of roks's files under this name
    other = folders["all"] / ("brdf.csv" if name != "brdf.bsdf" else "brdf.binary")
    _refused(_broken(tmp_path, src, other.read_bytes()[:200_000]))


@pytest.mark.parametrize("data,what", [
    (b"tensor_file\x00\x01\x00\xff\xff\xff\xff", "fields cannot fit"),
    (b"tensor_file\x00\x02\x00\x00\x00\x00\x00", "version 2.0"),
])
def test_tensor_header_faults_are_named(folders, tmp_path, data, what):
    p = _broken(tmp_path, folders["all"] / "brdf.pbsdf", data)
    assert what in _refused(p)


def test_zemax_faults_are_named(folders, tmp_path):
    text = (folders["all"] / "brdf.bsdf").read_text()
    cases = [
        (text.replace("ScatterType  BRDF", "ScatterType  BTDF"), "ScatterType: 'BTDF' is not supported"),
        (text.replace("Symmetry  PlaneSymmetrical", "Symmetry  Isotropic"), "Symmetry: 'Isotropic'"),
        (text.replace("TIS ", "TIS -", 1), "a negative value"),
        (text.replace("DataEnd", "0.5 DataEnd"), "expected keyword DataEnd"),
        (text + "1\n", "'1' after DataEnd"),
        (text.replace("E-01", "E-0x", 1), "is not a finite number"),
        (text.replace("ScatterRadial  181", "ScatterRadial  99999999"), "unexpected end of file"),
    ]
    for bad, what in cases:
        msg = _refused(_broken(tmp_path, folders["all"] / "brdf.bsdf", bad.encode()))
        assert what in msg and "line " in msg, msg
    # the other spelling of the Zemax documents reads too
    p = _broken(tmp_path, folders["all"] / "brdf.bsdf", folders["two"].joinpath("brdf.bsdf").read_bytes()
                .replace(b"Asymmetrical4D", b"ASymmetrical4D"))
    assert read_file(p).symmetry == "Asymmetrical4D"


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in BAD_NAMES if n not in ("brdf.pbsdf", "brdf.binary")])
def test_random_corruptions_raise_only_result_error(folders, tmp_path, name):
    rng = random.Random(f"roks-export-{name}")
    data = _source(folders, name).read_bytes()
    refused = 0
    for _ in range(40):
        refused += _refused_or_read(_broken(tmp_path, _source(folders, name), _mutate(data, rng, kinds=4)))
    assert refused > 0


def test_png_reader_is_the_picture_reader(folders):
    """Pictures are read by `read_png` (matplotlib), not skipped: RGBA rows x columns."""
    p = folders["all"] / "surface.png"
    a = read_file(p)
    assert np.array_equal(a, read_png(p)) and a.shape[2] in (3, 4)


# ----------------------------------------------------------------------------
# Files of the same folders written by newer commands: the record of the files
# roks wrote (.roks-files.json) and fit-model --model all's ranking
# ----------------------------------------------------------------------------

RECORD = {"roks": "0.1.0", "command": "brdf",
          "files": {"brdf.csv": "brdf", "summary.json": "brdf", "fit_abg.json": "fit-model"}}
RANKING = {"ranking": [{"model": "beckmann", "file": "fit_beckmann.json", "chi2_per_dof": 1.2, "passes": True,
                        "verdict": "ok", "incidences": 3, "incidences_ok": 3},
                       {"model": "abg", "file": "fit_abg.json", "chi2_per_dof": 0.9, "passes": False,
                        "verdict": "2 incidences off"}],
           "use": "beckmann", "advice": "use beckmann", "rule": "no warning first", "not_fitted": [],
           "table": "out/brdf.csv", "version": "0.1.0"}


def test_files_record_and_fit_ranking_read(tmp_path):
    import json
    (tmp_path / ".roks-files.json").write_text(json.dumps(RECORD, indent=2) + "\n")
    r = read_file(tmp_path / ".roks-files.json")
    assert r.command == "brdf" and r.added() == {"fit_abg.json": "fit-model"}
    (tmp_path / "fit_summary.json").write_text(json.dumps(RANKING, indent=2) + "\n")
    f = read_file(tmp_path / "fit_summary.json")
    assert [m.model for m in f.ranking] == ["beckmann", "abg"] and f.use == "beckmann"
    assert f.ranking[0]["incidences_ok"] == 3  # keys the class does not name are kept
    for name, doc, what in [
        (".roks-files.json", {**RECORD, "files": {"../x": "brdf"}}, "is not a file name"),
        (".roks-files.json", {**RECORD, "files": ["brdf.csv"]}, "files: expected an object"),
        ("fit_summary.json", {**RANKING, "use": "ggx"}, "use: 'ggx' is not a model of the ranking"),
        ("fit_summary.json", {"models": []}, "not a roks fit_summary.json"),
    ]:
        p = tmp_path / f"case-{what[:8].replace(' ', '_')}" / name
        p.parent.mkdir(exist_ok=True)
        p.write_text(json.dumps(doc))
        assert what in _refused(p)
        p.write_text(json.dumps(doc)[:-3])
        _refused(p)
