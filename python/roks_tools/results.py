"""Readers of roks's result files: one per format, returning typed objects.

`roks brdf` writes a folder with `summary.json`, `brdf.csv` (the Carlson
grid, see `roks_tools.carlson`), `inplane.csv`, and with `--polarisation`
`stokes.csv` or `mueller.csv`; `roks trace` writes `summary.json`,
`reflectance.csv` and `farfield.csv` (and `farfield_stokes.csv`). Each
reader checks the file's header against roks's (src/output.rs) and returns
a frozen dataclass of numpy arrays, values beside their standard errors:

    from roks_tools.results import BrdfResult
    r = BrdfResult.load("out/default")
    r.summary.incidence[0].reflectance, r.brdf.at(60.0).fraction

A file that is missing, has another header or a non-numeric cell raises
`ResultError` with a message naming the file. Numbers are parsed by
Python's float(), which is exact for the shortest round-trip form roks
writes.

The Mitsuba tracer (`roks_tools.mitsuba.tracer`) writes the same formats
with its own, independent Carlson binning (on purpose: it checks roks's);
these readers read its folders too.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from .carlson import CarlsonGrid

BRDF_COLUMNS = (
    "theta_i_deg", "phi_i_deg", "band", "cell", "theta_lo_deg", "theta_hi_deg", "phi_lo_deg",
    "phi_hi_deg", "theta_deg", "phi_deg", "solid_angle_sr", "projected_solid_angle_sr",
    "fraction", "fraction_stderr", "brdf", "brdf_stderr",
)
INPLANE_COLUMNS = ("theta_i_deg", "theta_o_deg", "brdf", "brdf_stderr")
# A spectral run's brdf.csv and inplane.csv: `wavelength_um` (um) after the
# incidence columns, one block per incidence and wavelength (incidence-major).
SPECTRAL_BRDF_COLUMNS = BRDF_COLUMNS[:2] + ("wavelength_um",) + BRDF_COLUMNS[2:]
SPECTRAL_INPLANE_COLUMNS = INPLANE_COLUMNS[:1] + ("wavelength_um",) + INPLANE_COLUMNS[1:]
# colour.csv of a spectral run covering the visible: XYZ and linear sRGB of the BRDF (1/sr) per cell.
COLOUR_COLUMNS = ("theta_i_deg", "phi_i_deg", "band", "cell", "theta_deg", "phi_deg", "X", "Y", "Z", "r", "g", "b")
STOKES_NAMES = ("s0", "s1", "s2", "s3")
MUELLER_NAMES = tuple(f"m{i}{j}" for i in range(4) for j in range(4))
POLAR_KEYS = ("theta_i_deg", "phi_i_deg", "band", "cell", "theta_deg", "phi_deg")
STOKES_COLUMNS = POLAR_KEYS + tuple(c for n in STOKES_NAMES for c in (n, n + "_stderr")) + ("dop",)
# mueller.csv: the matrix and its standard errors, then the standard errors of
# m_ij / m00 (nan where m00 = 0); files of roks before these (and the Mitsuba
# tracer's) have the matrix columns only.
MUELLER_MATRIX_COLUMNS = POLAR_KEYS + tuple(c for n in MUELLER_NAMES for c in (n, n + "_stderr"))
MUELLER_COLUMNS = MUELLER_MATRIX_COLUMNS + tuple(n + "_m00_stderr" for n in MUELLER_NAMES[1:])
REFLECTANCE_COLUMNS = ("x", "y", "z", "reflectance", "reflectance_stderr")
FARFIELD_COLUMNS = ("source",) + BRDF_COLUMNS[2:]
FARFIELD_STOKES_COLUMNS = ("source",) + BRDF_COLUMNS[2:12] + tuple(
    c for n in STOKES_NAMES for c in (n, n + "_stderr")) + ("dop",)
POLAR_FILES = {"stokes": "stokes.csv", "mueller": "mueller.csv"}
# A spectral `roks trace` run: `wavelength_um` right after the position columns.
SPECTRAL_REFLECTANCE_COLUMNS = REFLECTANCE_COLUMNS[:3] + ("wavelength_um",) + REFLECTANCE_COLUMNS[3:]
SPECTRAL_FARFIELD_COLUMNS = ("source", "wavelength_um") + FARFIELD_COLUMNS[1:]
SPECTRAL_FARFIELD_STOKES_COLUMNS = ("source", "wavelength_um") + FARFIELD_STOKES_COLUMNS[1:]
SPECTRAL_HEADERS = {
    "reflectance.csv": SPECTRAL_REFLECTANCE_COLUMNS,
    "farfield.csv": SPECTRAL_FARFIELD_COLUMNS,
    "farfield_stokes.csv": SPECTRAL_FARFIELD_STOKES_COLUMNS,
}
"""The columns of the files of a spectral `roks trace` run that differ, by file name."""

HEADERS = {
    "brdf.csv": BRDF_COLUMNS,
    "inplane.csv": INPLANE_COLUMNS,
    "stokes.csv": STOKES_COLUMNS,
    "mueller.csv": MUELLER_COLUMNS,
    "reflectance.csv": REFLECTANCE_COLUMNS,
    "farfield.csv": FARFIELD_COLUMNS,
    "farfield_stokes.csv": FARFIELD_STOKES_COLUMNS,
    "colour.csv": COLOUR_COLUMNS,
}
"""The columns of every CSV file roks writes, by file name."""


class ResultError(ValueError):
    """A result file that is missing or not what roks writes (the message names it)."""


def read_columns(path: str | Path, columns: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """A CSV file of numbers as one float array per column, in file order.

    `columns`: the exact header expected (default: roks's header for the
    file's name, if it is one of `HEADERS`; any header otherwise)."""
    path = Path(path)
    if columns is None:
        columns = HEADERS.get(path.name)
    try:
        with path.open(newline="") as f:
            reader = csv.reader(f)
            header = next(reader, None)
            if header is None:
                raise ResultError(f"{path}: empty file")
            header = [h.lstrip("\ufeff") for h in header]
            if columns is not None and tuple(header) != tuple(columns):
                raise ResultError(f"{path}: line 1: not the header of roks's {path.name} "
                                  f"(expected {','.join(columns)[:80]}...)")
            rows = [r for r in reader if r]
    except OSError as e:
        raise ResultError(f"{path}: cannot read: {e}") from e
    if not rows:
        raise ResultError(f"{path}: no data rows")
    try:
        data = np.array(rows, dtype=float)
    except ValueError as e:
        raise ResultError(f"{path}: not a table of {len(header)} numbers per row: {e}") from e
    return {c: data[:, i] for i, c in enumerate(header)}


def _either(path: Path, columns: tuple[str, ...], spectral: tuple[str, ...]) -> tuple[str, ...]:
    """`spectral` if the file's header is that (a spectral run's), else `columns`."""
    try:
        with Path(path).open(newline="") as f:
            first = f.readline().strip().lstrip("\ufeff")
    except OSError:
        return columns  # read_columns names the file
    return spectral if first == ",".join(spectral) else columns


def _table(cls, path: Path, columns: tuple[str, ...], **extra):
    cols = read_columns(path, columns)
    names = {f.name for f in fields(cls)}
    return cls(path=Path(path), **{k: v for k, v in cols.items() if k in names}, **extra)


def _select(obj, mask: np.ndarray):
    """A copy of a table dataclass with every array field restricted to `mask`."""
    kw = {}
    for f in fields(obj):
        v = getattr(obj, f.name)
        kw[f.name] = v[mask] if isinstance(v, np.ndarray) and v.ndim >= 1 and len(v) == len(mask) else v
    return type(obj)(**kw)


def _close(a: np.ndarray, x: float, tol: float = 1e-9) -> np.ndarray:
    return np.abs(a - x) <= tol


@dataclass(frozen=True)
class BrdfTable:
    """brdf.csv: per incidence (theta_i_deg, phi_i_deg) one block of rows,
    one per Carlson cell in grid order. `fraction` is the share of the
    incident power leaving through the cell, `brdf` = fraction / projected
    solid angle (1/sr); angles in degrees, solid angles in sr."""

    path: Path
    theta_i_deg: np.ndarray
    phi_i_deg: np.ndarray
    band: np.ndarray
    cell: np.ndarray
    theta_lo_deg: np.ndarray
    theta_hi_deg: np.ndarray
    phi_lo_deg: np.ndarray
    phi_hi_deg: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    solid_angle_sr: np.ndarray
    projected_solid_angle_sr: np.ndarray
    fraction: np.ndarray
    fraction_stderr: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray

    @classmethod
    def read(cls, path: str | Path) -> "BrdfTable":
        return _table(cls, Path(path), BRDF_COLUMNS)

    @property
    def incidences(self) -> list[tuple[float, float]]:
        """The (theta_i_deg, phi_i_deg) of the blocks, in file order."""
        seen: dict = {}
        for t, p in zip(self.theta_i_deg.tolist(), self.phi_i_deg.tolist()):
            seen.setdefault((t, p), None)
        return list(seen)

    @property
    def grid(self) -> CarlsonGrid:
        """The Carlson grid of the blocks (ResultError if they are not complete grids of one size)."""
        n = len(self.theta_i_deg) // max(len(self.incidences), 1)
        try:
            return CarlsonGrid.of_cells(n)
        except ValueError as e:
            raise ResultError(f"{self.path}: {e}") from e

    def at(self, theta_i_deg: float, phi_i_deg: float | None = None) -> "BrdfTable":
        """The rows of one incidence (matched within 1e-9 degrees)."""
        m = _close(self.theta_i_deg, theta_i_deg)
        if phi_i_deg is not None:
            m &= _close(self.phi_i_deg, phi_i_deg)
        if not m.any():
            raise ResultError(f"{self.path}: no rows for incidence {theta_i_deg:g} deg")
        return _select(self, m)

    def cells(self) -> dict[float, dict[tuple[int, int], tuple[float, float]]]:
        """{theta_i_deg: {(band, cell): (fraction, fraction_stderr)}}."""
        out: dict = {}
        for t, j, c, f, e in zip(self.theta_i_deg.tolist(), self.band.astype(int).tolist(),
                                 self.cell.astype(int).tolist(), self.fraction.tolist(),
                                 self.fraction_stderr.tolist()):
            out.setdefault(t, {})[(j, c)] = (f, e)
        return out


@dataclass(frozen=True)
class InPlane:
    """inplane.csv: the BRDF (1/sr) in the plane of incidence by outgoing
    angle theta_o_deg (negative: the incident side), per incidence."""

    path: Path
    theta_i_deg: np.ndarray
    theta_o_deg: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray

    @classmethod
    def read(cls, path: str | Path) -> "InPlane":
        return _table(cls, Path(path), INPLANE_COLUMNS)

    def at(self, theta_i_deg: float) -> "InPlane":
        m = _close(self.theta_i_deg, theta_i_deg)
        if not m.any():
            raise ResultError(f"{self.path}: no rows for incidence {theta_i_deg:g} deg")
        return _select(self, m)

    def by_theta(self) -> dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """{theta_i_deg: (theta_o_deg, brdf, brdf_stderr)}."""
        return {t: (s.theta_o_deg, s.brdf, s.brdf_stderr)
                for t in dict.fromkeys(self.theta_i_deg.tolist()) for s in [self.at(t)]}


@dataclass(frozen=True)
class PolarTable:
    """stokes.csv or mueller.csv: per incidence and Carlson cell the Stokes
    BRDF s0..s3 or the Mueller-matrix BRDF m00..m33 (1/sr), `values` and
    `stderr` of shape (rows, components) in `names` order."""

    path: Path
    mode: str
    names: tuple[str, ...]
    theta_i_deg: np.ndarray
    phi_i_deg: np.ndarray
    band: np.ndarray
    cell: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    values: np.ndarray
    stderr: np.ndarray

    @classmethod
    def read(cls, path: str | Path) -> "PolarTable":
        path = Path(path)
        mode = {"stokes.csv": "stokes", "mueller.csv": "mueller"}.get(path.name)
        if mode is None:
            raise ResultError(f"{path}: neither stokes.csv nor mueller.csv")
        names = STOKES_NAMES if mode == "stokes" else MUELLER_NAMES
        if mode == "stokes":
            cols = read_columns(path, STOKES_COLUMNS)
        else:
            try:
                cols = read_columns(path, MUELLER_COLUMNS)
            except ResultError as e:
                try:
                    cols = read_columns(path, MUELLER_MATRIX_COLUMNS)
                except ResultError:
                    raise e from None
        return cls(path=path, mode=mode, names=names,
                   **{k: cols[k] for k in POLAR_KEYS},
                   values=np.stack([cols[n] for n in names], axis=1),
                   stderr=np.stack([cols[n + "_stderr"] for n in names], axis=1))

    @classmethod
    def find(cls, folder: str | Path) -> "PolarTable | None":
        """The stokes.csv or mueller.csv in `folder`, or None when it has neither."""
        for name in POLAR_FILES.values():
            if (Path(folder) / name).is_file():
                return cls.read(Path(folder) / name)
        return None

    def cells(self) -> dict[float, dict[tuple[int, int], tuple[list[float], list[float]]]]:
        """{theta_i_deg: {(band, cell): (values, stderrs)}}."""
        out: dict = {}
        for t, j, c, v, e in zip(self.theta_i_deg.tolist(), self.band.astype(int).tolist(),
                                 self.cell.astype(int).tolist(), self.values.tolist(),
                                 self.stderr.tolist()):
            out.setdefault(t, {})[(j, c)] = (v, e)
        return out


@dataclass(frozen=True)
class Incidence:
    """One incidence entry of a `roks brdf` summary.json (the keys every
    run writes; `raw` holds them all, e.g. `segments`, `seconds`)."""

    theta_deg: float
    phi_deg: float
    photons: int
    reflectance: float
    reflectance_stderr: float
    reflectance_by_bounces: list
    raw: dict = field(repr=False)

    @classmethod
    def from_json(cls, e: dict, where: str) -> "Incidence":
        try:
            return cls(float(e["theta_deg"]), float(e["phi_deg"]), int(e["photons"]),
                       float(e["reflectance"]), float(e["reflectance_stderr"]),
                       list(e["reflectance_by_bounces"]), e)
        except (KeyError, TypeError, ValueError) as err:
            raise ResultError(f"{where}: incidence entry lacks or mistypes {err}") from err

    def __getitem__(self, key: str):
        return self.raw[key]

    def get(self, key: str, default=None):
        return self.raw.get(key, default)


@dataclass(frozen=True)
class Summary:
    """summary.json of `roks brdf` (with `incidence`) or `roks trace`.

    `data` is the whole file as JSON; `incidence` the typed entries of a
    `roks brdf` summary (empty for other summaries)."""

    path: Path
    data: dict
    incidence: list[Incidence]

    @classmethod
    def read(cls, path: str | Path) -> "Summary":
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ResultError(f"{path}: cannot read: {e}") from e
        if not isinstance(data, dict):
            raise ResultError(f"{path}: expected a JSON object")
        inc = data.get("incidence", [])
        if not isinstance(inc, list):
            raise ResultError(f"{path}: 'incidence' is not a list")
        return cls(path, data, [Incidence.from_json(e, str(path)) for e in inc])

    def __getitem__(self, key: str):
        return self.data[key]

    def get(self, key: str, default=None):
        return self.data.get(key, default)

    def by_theta(self) -> dict[float, Incidence]:
        return {e.theta_deg: e for e in self.incidence}


@dataclass(frozen=True)
class Reflectance:
    """reflectance.csv of `roks trace`: per beam position (x, y, z) the
    object's reflectance and its standard error; a spectral run has a row
    per position and wavelength (`wavelength_um`, µm; else None)."""

    path: Path
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    reflectance: np.ndarray
    reflectance_stderr: np.ndarray
    wavelength_um: np.ndarray | None = None

    @classmethod
    def read(cls, path: str | Path) -> "Reflectance":
        path = Path(path)
        return _table(cls, path, _either(path, REFLECTANCE_COLUMNS, SPECTRAL_REFLECTANCE_COLUMNS))


@dataclass(frozen=True)
class FarField:
    """farfield.csv of `roks trace`: per beam position (`source`, its row in
    reflectance.csv) and full-sphere Carlson cell (bands -1..-M below the
    horizon) the fraction of the beam leaving through the cell, as brdf.csv;
    a spectral run has a block per position and wavelength (`wavelength_um`,
    µm; else None)."""

    path: Path
    source: np.ndarray
    band: np.ndarray
    cell: np.ndarray
    theta_lo_deg: np.ndarray
    theta_hi_deg: np.ndarray
    phi_lo_deg: np.ndarray
    phi_hi_deg: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    solid_angle_sr: np.ndarray
    projected_solid_angle_sr: np.ndarray
    fraction: np.ndarray
    fraction_stderr: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray
    wavelength_um: np.ndarray | None = None

    @classmethod
    def read(cls, path: str | Path) -> "FarField":
        path = Path(path)
        return _table(cls, path, _either(path, FARFIELD_COLUMNS, SPECTRAL_FARFIELD_COLUMNS))


def _need(folder: Path, name: str) -> Path:
    p = folder / name
    if not p.is_file():
        raise ResultError(f"{p}: not found")
    return p


@dataclass(frozen=True)
class BrdfResult:
    """A `roks brdf` (or Mitsuba tracer) result folder, read whole."""

    folder: Path
    summary: Summary
    brdf: BrdfTable
    inplane: InPlane
    polar: PolarTable | None

    @classmethod
    def load(cls, folder: str | Path) -> "BrdfResult":
        folder = Path(folder)
        if not folder.is_dir():
            raise ResultError(f"{folder}: not a folder")
        return cls(folder, Summary.read(_need(folder, "summary.json")),
                   BrdfTable.read(_need(folder, "brdf.csv")),
                   InPlane.read(_need(folder, "inplane.csv")), PolarTable.find(folder))


@dataclass(frozen=True)
class TraceResult:
    """A `roks trace` result folder, read whole."""

    folder: Path
    summary: Summary
    reflectance: Reflectance
    farfield: FarField

    @classmethod
    def load(cls, folder: str | Path) -> "TraceResult":
        folder = Path(folder)
        if not folder.is_dir():
            raise ResultError(f"{folder}: not a folder")
        return cls(folder, Summary.read(_need(folder, "summary.json")),
                   Reflectance.read(_need(folder, "reflectance.csv")),
                   FarField.read(_need(folder, "farfield.csv")))


def read_exr(path: str | Path) -> np.ndarray:
    """An EXR render (roks render, Mitsuba) as a 2-D float64 array: the mean
    of its first three channels (needs mitsuba, whose Bitmap reads EXR)."""
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    a = np.array(mi.Bitmap(str(path)), dtype=np.float64)
    if a.ndim == 3:
        a = a[..., :3].mean(axis=2)
    return a
