"""Readers of roks's result files: one per format, returning typed objects.

`roks brdf` writes a folder with `summary.json`, `brdf.csv` (the Carlson
grid, see `roks_tools.carlson`), `inplane.csv`, with `--polarisation`
`stokes.csv` or `mueller.csv`, for a spectral run covering the visible
`colour.csv`, and with `--shard` (and from `roks merge`) `tallies.json`;
a spectral run's tables have a `wavelength_um` column (um). `roks trace`
writes `summary.json`, `reflectance.csv` and, with `[tally] farfield =
true`, `farfield.csv` (and `farfield_stokes.csv`); `roks fit` writes `fit.json`,
`fit_inplane.csv` and `fitted.toml`. Each reader checks the
file's header against roks's (src/output/*.rs) and the shape of the table
(whole blocks, one per incidence or beam position and wavelength, each a
complete Carlson grid) and returns a frozen dataclass of numpy arrays,
values beside their standard errors. summary.json and tallies.json are
read by `roks_tools.summary` (typed dataclasses, the one place that knows
their keys).

    from roks_tools.results import load_result
    r = load_result("out/default")           # BrdfResult or TraceResult
    r.summary.incidence[0].reflectance, r.brdf.at(60.0).fraction
    r.brdf.at_wavelength(0.55)               # one wavelength of a spectral run

A file that is missing, not UTF-8 text, has another header, a row of
another length, a cell that is not a finite number, ends inside its last
line (a cut file) or is not a whole table raises `ResultError`, one line
naming the file (and the line and column). Numbers are parsed by Python's
float(), which is exact for the shortest round-trip form roks writes.

The Mitsuba tracer (`roks_tools.mitsuba.tracer`) writes the same formats
with its own, independent Carlson binning (on purpose: it checks roks's);
these readers read its folders too.
"""

from __future__ import annotations

import io
import re
import warnings
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from .carlson import CarlsonGrid
from .errors import ResultError, show
from .summary import (BrdfSummary, FitSummary, Tallies, TraceSummary, TraceTallies, read_fit, read_summary,
                      read_tallies)

__all__ = [
    "ResultError", "read_columns", "BrdfTable", "InPlane", "PolarTable", "ColourTable", "Reflectance",
    "FarField", "FarFieldStokes", "FitInPlane", "BrdfResult", "TraceResult", "FitResult", "load_result",
    "read_file", "read_exr", "read_summary", "read_tallies", "read_fit", "read_toml", "HEADERS", "SPECTRAL_HEADERS",
]

BRDF_COLUMNS = (
    "theta_i_deg", "phi_i_deg", "band", "cell", "theta_lo_deg", "theta_hi_deg", "phi_lo_deg",
    "phi_hi_deg", "theta_deg", "phi_deg", "solid_angle_sr", "projected_solid_angle_sr",
    "fraction", "fraction_stderr", "brdf", "brdf_stderr",
)
INPLANE_COLUMNS = ("theta_i_deg", "theta_o_deg", "brdf", "brdf_stderr")
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


def _spectral(columns: tuple[str, ...], after: str) -> tuple[str, ...]:
    """`columns` with `wavelength_um` after `after` (roks's `spectral_header`)."""
    i = columns.index(after) + 1
    return columns[:i] + ("wavelength_um",) + columns[i:]


# A spectral run's files: `wavelength_um` (um) after the incidence (or position) columns.
SPECTRAL_BRDF_COLUMNS = _spectral(BRDF_COLUMNS, "phi_i_deg")
SPECTRAL_INPLANE_COLUMNS = _spectral(INPLANE_COLUMNS, "theta_i_deg")
SPECTRAL_STOKES_COLUMNS = _spectral(STOKES_COLUMNS, "phi_i_deg")
SPECTRAL_MUELLER_COLUMNS = _spectral(MUELLER_COLUMNS, "phi_i_deg")
SPECTRAL_REFLECTANCE_COLUMNS = _spectral(REFLECTANCE_COLUMNS, "z")
SPECTRAL_FARFIELD_COLUMNS = _spectral(FARFIELD_COLUMNS, "source")
SPECTRAL_FARFIELD_STOKES_COLUMNS = _spectral(FARFIELD_STOKES_COLUMNS, "source")

HEADERS = {
    "brdf.csv": BRDF_COLUMNS,
    "inplane.csv": INPLANE_COLUMNS,
    "stokes.csv": STOKES_COLUMNS,
    "mueller.csv": MUELLER_COLUMNS,
    "reflectance.csv": REFLECTANCE_COLUMNS,
    "farfield.csv": FARFIELD_COLUMNS,
    "farfield_stokes.csv": FARFIELD_STOKES_COLUMNS,
    "colour.csv": COLOUR_COLUMNS,
    "fit_inplane.csv": ("theta_i_deg", "theta_o_deg", "measured", "model"),
}
"""The columns of every CSV file roks writes (a monochrome run), by file name."""

SPECTRAL_HEADERS = {
    "brdf.csv": SPECTRAL_BRDF_COLUMNS,
    "inplane.csv": SPECTRAL_INPLANE_COLUMNS,
    "stokes.csv": SPECTRAL_STOKES_COLUMNS,
    "mueller.csv": SPECTRAL_MUELLER_COLUMNS,
    "reflectance.csv": SPECTRAL_REFLECTANCE_COLUMNS,
    "farfield.csv": SPECTRAL_FARFIELD_COLUMNS,
    "farfield_stokes.csv": SPECTRAL_FARFIELD_STOKES_COLUMNS,
}
"""The columns of the files of a spectral run (`wavelength_um` added), by file name."""

AZIMUTH_INPLANE_COLUMNS = ("theta_i_deg", "phi_i_deg", "theta_o_deg", "brdf", "brdf_stderr")
AZIMUTH_HEADERS = {
    "inplane.csv": (AZIMUTH_INPLANE_COLUMNS, _spectral(AZIMUTH_INPLANE_COLUMNS, "phi_i_deg")),
    # roks fit of a measurement with light azimuths (phi_i_deg column).
    "fit_inplane.csv": (("theta_i_deg", "phi_i_deg", "theta_o_deg", "measured", "model"),),
}
"""The columns of a file that has `phi_i_deg` only for a run of several light
azimuths (mono and spectral), by file name."""

PHOTON_COLUMNS = {
    "brdf.csv": ("fraction_stderr_photon", "brdf_stderr_photon"),
    "inplane.csv": ("brdf_stderr_photon",),
}
"""The columns that end the header of a run of several surface realisations
(`[surface] realisations = R > 1`), by file name: the standard errors from the
photons alone. The file's `fraction_stderr` / `brdf_stderr` are then the
ensemble mean's (the spread between the realisations, `stderr_dof` degrees of
freedom in summary.json)."""


def _accepted(name: str) -> tuple[tuple[str, ...], ...]:
    """The headers roks writes for the file `name`: monochrome, spectral,
    several azimuths, each with the photon-noise columns of several surface
    realisations where the file has them."""
    plain = tuple(h for h in (HEADERS[name], SPECTRAL_HEADERS.get(name),
                              *AZIMUTH_HEADERS.get(name, ())) if h)
    extra = PHOTON_COLUMNS.get(name)
    return plain + tuple(h + extra for h in plain) if extra else plain


EXTRA_POLAR_COLUMN = re.compile(r"^[ms][0-3]{1,2}[a-z0-9_]*$")
"""Columns that may follow the known ones of stokes.csv / mueller.csv (e.g.
standard errors of the normalised elements, `m01_norm_stderr`): read into
`PolarTable.extra` (NaN allowed: a ratio where m00 = 0), so a file that
gains such columns still reads."""

EXTRA_ERROR_COLUMN = re.compile(r"^[a-z][a-z0-9_]*(stderr|photon|dof|realisation|spread)[a-z0-9_]*$")
"""Columns that may stand anywhere among the known ones of any table roks
writes: more standard errors and their parts (e.g. `brdf_stderr_photon`,
the photon-noise part of an ensemble's error, or degrees of freedom),
read into the table's `extra` dict (NaN allowed), so a file that gains
them still reads. A column of any other name is refused."""

NAN_COLUMNS = frozenset({"dop"} | {n + "_m00_stderr" for n in MUELLER_NAMES[1:]})
"""Columns where NaN is a value (an undefined degree of polarisation; the
error of m_ij/m00 where m00 = 0)."""

MAX_TABLE_BYTES = 4 << 30
"""Largest CSV file read (4 GiB)."""


def _text(path: Path) -> str:
    """The file as text, or ResultError naming it (unreadable, NUL bytes, not UTF-8)."""
    try:
        size = path.stat().st_size
        if size > MAX_TABLE_BYTES:
            raise ResultError(f"{show(path)}: {size} bytes, larger than any roks table")
        data = path.read_bytes()
    except FileNotFoundError:
        raise ResultError(f"{show(path)}: not found") from None
    except OSError as e:
        raise ResultError(f"{show(path)}: cannot read: {e.strerror or e}") from None
    nul = data.find(b"\0")
    if nul >= 0:
        raise ResultError(f"{show(path)}: byte {nul}: a NUL byte, not a text table")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ResultError(f"{show(path)}: byte {e.start}: not UTF-8 text") from None


def _base_header(header: tuple[str, ...], accept, extra) -> tuple[str, ...] | None:
    """The accepted header that `header` is, once the columns matching
    `extra` or `EXTRA_ERROR_COLUMN` are taken out (the known columns in
    their order, the others anywhere among them); None if there is none."""
    if header in accept:
        return header
    best = None
    for a in accept:
        known = set(a)
        if tuple(c for c in header if c in known) != a:
            continue
        if all((extra is not None and extra.match(c)) or EXTRA_ERROR_COLUMN.match(c)
               for c in header if c not in known):
            if best is None or len(a) > len(best):
                best = a
    return best


def _table_text(path: Path, accept: tuple[tuple[str, ...], ...] | None, extra=None):
    """(header, rows of cells as float array) of a CSV table of numbers.

    `accept`: the headers allowed (None: any); `extra`: a regex that more
    columns among an accepted header's may match, besides
    `EXTRA_ERROR_COLUMN` (their names are returned too). A column whose
    name holds `stderr` must not be negative."""
    text = _text(path)
    if not text:
        raise ResultError(f"{show(path)}: empty file")
    if not text.endswith("\n"):
        n = text.count("\n") + 1
        raise ResultError(f"{show(path)}: line {n}: the file ends inside a line (cut?)")
    lines = text.split("\n")
    lines.pop()
    header = tuple(lines[0].lstrip("\ufeff").rstrip("\r").split(","))
    base = header
    if accept is not None:
        base = _base_header(header, accept, extra)
        if base is None:
            want = " or ".join(",".join(a)[:60] + "..." for a in accept[:2])
            raise ResultError(f"{show(path)}: line 1: not the header of roks's {path.name} (expected {want})")
    if len(set(header)) != len(header):
        raise ResultError(f"{show(path)}: line 1: a column name appears twice")
    if len(lines) < 2:
        raise ResultError(f"{show(path)}: no data rows")
    ncol = len(header)
    body = text[len(lines[0]) + 1:]
    data = None
    if "\n\n" not in body and not body.startswith("\n"):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # e.g. an empty input: an error, not a warning
                data = np.loadtxt(io.StringIO(body), delimiter=",", comments=None, ndmin=2, dtype=float)
        except (ValueError, OverflowError, UserWarning):
            data = None
    if data is None or data.shape[1] != ncol:
        _explain(path, header, lines[1:])
    bad = ~np.isfinite(data)
    extras = set(header) - set(base)
    for j, name in enumerate(header):
        if name in NAN_COLUMNS or name in extras:
            bad[:, j] &= ~np.isnan(data[:, j])
    if bad.any():
        i, j = np.argwhere(bad)[0]
        cell = lines[i + 1].rstrip("\r").split(",")[j]
        raise ResultError(f"{show(path)}: line {i + 2} column {header[j]}: {cell[:30]!r} is not a finite number")
    errors = [j for j, name in enumerate(header) if "stderr" in name]
    if errors:
        negative = data[:, errors] < 0  # NaN compares false: allowed where NaN is
        if negative.any():
            i, k = np.argwhere(negative)[0]
            j = errors[k]
            cell = lines[i + 1].rstrip("\r").split(",")[j]
            raise ResultError(f"{show(path)}: line {i + 2} column {header[j]}: {cell[:30]!r} is a negative "
                              f"standard error")
    return header, data


def _explain(path: Path, header: tuple[str, ...], rows: list[str]):
    """Raise the ResultError that says which row or cell of a table is wrong."""
    ncol = len(header)
    for i, r in enumerate(rows):
        c = r.rstrip("\r").split(",")
        if len(c) != ncol:
            what = "an empty line" if c == [""] else f"{len(c)} values"
            raise ResultError(f"{show(path)}: line {i + 2}: {what}, the header has {ncol} columns")
        for j, v in enumerate(c):
            try:
                float(v)
            except ValueError:
                raise ResultError(f"{show(path)}: line {i + 2} column {header[j]}: "
                                  f"{v[:30]!r} is not a number") from None
    raise ResultError(f"{show(path)}: not a table of {ncol} numbers per row")


def read_columns(path: str | Path, columns: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """A CSV file of numbers as one float array per column, in file order.

    `columns`: the exact header expected (default: roks's header for the
    file's name, monochrome or spectral, if it is one of `HEADERS`; any
    header otherwise). ResultError naming the file for anything else."""
    path = Path(path)
    if columns is not None:
        accept = (tuple(columns),)
    elif path.name in HEADERS:
        accept = _accepted(path.name)
    else:
        accept = None
    header, data = _table_text(path, accept)
    return {c: data[:, i] for i, c in enumerate(header)}


def _table(cls, path: Path, **extra):
    """The dataclass `cls` from its file (mono or spectral header, or a
    run of several light azimuths'), shape-checked."""
    plain = tuple(h for h in (HEADERS[cls.FILE], SPECTRAL_HEADERS.get(cls.FILE),
                              *AZIMUTH_HEADERS.get(cls.FILE, ())) if h)
    header, data = _table_text(path, _accepted(cls.FILE))
    names = {f.name for f in fields(cls)} - {"extra"}
    known = set().union(*plain)
    more = {c: data[:, i] for i, c in enumerate(header) if c not in known}
    if "extra" in {f.name for f in fields(cls)}:
        extra = {**extra, "extra": more}
    obj = cls(path=path, **{c: data[:, i] for i, c in enumerate(header) if c in names}, **extra)
    obj._check()
    return obj


def _select(obj, mask: np.ndarray):
    """A copy of a table dataclass with every array field restricted to `mask`."""
    def cut(v):
        if isinstance(v, np.ndarray) and v.ndim >= 1 and len(v) == len(mask):
            return v[mask]
        if isinstance(v, dict):
            return {k: cut(x) for k, x in v.items()}
        return v
    return type(obj)(**{f.name: cut(getattr(obj, f.name)) for f in fields(obj)})


def _close(a: np.ndarray, x: float, tol: float = 1e-9) -> np.ndarray:
    return np.abs(a - x) <= tol


def _blocks(path: Path, keys: list[np.ndarray], what: str) -> int:
    """The number of rows per block, checking that the rows come in whole
    blocks of equal length, each with one value of every key column, in
    distinct, contiguous runs."""
    n = len(keys[0])
    k = np.zeros(n, dtype=bool)
    for a in keys:
        k[1:] |= a[1:] != a[:-1]
    starts = np.flatnonzero(k)
    nblocks = len(starts) + 1
    size = n // nblocks
    if size * nblocks != n or (len(starts) and not np.all(starts == size * np.arange(1, nblocks))):
        raise ResultError(f"{show(path)}: the rows are not whole blocks of one {what} each "
                          f"({n} rows, {nblocks} blocks): a cut or edited file?")
    seen = set(zip(*(a[::size].tolist() for a in keys)))
    if len(seen) != nblocks:
        raise ResultError(f"{show(path)}: a {what} appears in two blocks")
    return size


def _check_grid(path: Path, band: np.ndarray, cell: np.ndarray, size: int, full_sphere: bool = False):
    """Each block of `size` rows is the Carlson grid in grid order (both hemispheres: bands 1..M then -1..-M)."""
    n = size // 2 if full_sphere else size
    try:
        g = CarlsonGrid.of_cells(n)
    except ValueError as e:
        raise ResultError(f"{show(path)}: blocks of {size} rows: {e}") from None
    want_band = np.concatenate([g.band, -g.band]) if full_sphere else g.band
    want_cell = np.concatenate([g.cell, g.cell]) if full_sphere else g.cell
    nb = len(band) // size
    if not (np.array_equal(band, np.tile(want_band, nb)) and np.array_equal(cell, np.tile(want_cell, nb))):
        raise ResultError(f"{show(path)}: the band and cell columns are not the Carlson grid of "
                          f"{g.bands} bands in grid order")
    return g


class _Spectral:
    """Selection by wavelength of a table with an optional `wavelength_um` column."""

    wavelength_um: np.ndarray | None

    @property
    def wavelengths(self) -> list[float]:
        """The wavelengths (um) of a spectral run's table, in file order ([] if monochrome)."""
        if self.wavelength_um is None:
            return []
        return list(dict.fromkeys(self.wavelength_um.tolist()))

    def at_wavelength(self, wavelength_um: float):
        """The rows of one wavelength (matched within 1e-9 um), as the table of a monochrome run."""
        if self.wavelength_um is None:
            raise ResultError(f"{show(self.path)}: a monochrome table has no wavelength {wavelength_um:g} um")
        m = _close(self.wavelength_um, wavelength_um)
        if not m.any():
            raise ResultError(f"{show(self.path)}: no rows for wavelength {wavelength_um:g} um "
                              f"(has {', '.join(f'{w:g}' for w in self.wavelengths)})")
        out = _select(self, m)
        return _replace_field(out, "wavelength_um", None)


def _monochrome(table):
    if table.wavelength_um is not None:
        raise ResultError(f"{show(table.path)}: a spectral table: choose a wavelength (at_wavelength) first")


def _list(values) -> str:
    return ", ".join(f"{v:g}" for v in values)


def _phi(table, phi_i_deg: float | None, phi: float | None) -> float | None:
    """The azimuth asked for by `phi_i_deg` or its short name `phi`."""
    if phi is not None and phi_i_deg is not None and phi != phi_i_deg:
        raise ResultError(f"{show(table.path)}: two azimuths asked for ({phi_i_deg:g} and {phi:g} deg)")
    return phi if phi is not None else phi_i_deg


def _at(table, theta_i_deg: float, phi_i_deg: float | None, wavelength_um: float | None):
    """The rows of one incidence (theta, and phi of a run of several light
    azimuths) and wavelength (of a spectral table of several), refusing to
    mix the blocks of several azimuths or wavelengths."""
    m = _close(table.theta_i_deg, theta_i_deg)
    if not m.any():
        raise ResultError(f"{show(table.path)}: no rows for incidence {theta_i_deg:g} deg")
    phis = table.phi_i_deg
    if phi_i_deg is not None:
        if phis is None:  # a one-azimuth in-plane table has no phi_i_deg column
            raise ResultError(f"{show(table.path)}: a table of one light azimuth has no phi_i_deg column: "
                              f"at({theta_i_deg:g}) without phi")
        m &= _close(phis, phi_i_deg)
        if not m.any():
            raise ResultError(f"{show(table.path)}: no rows for incidence {theta_i_deg:g} deg at azimuth "
                              f"{phi_i_deg:g} deg (has {_list(dict.fromkeys(phis.tolist()))})")
    elif phis is not None:
        there = list(dict.fromkeys(phis[m].tolist()))
        if len(there) > 1:
            raise ResultError(f"{show(table.path)}: incidence {theta_i_deg:g} deg has {len(there)} light azimuths "
                              f"({_list(there)} deg): name one, e.g. at({theta_i_deg:g}, phi={there[0]:g})")
    waves = table.wavelength_um
    if wavelength_um is not None:
        if waves is None:
            raise ResultError(f"{show(table.path)}: a monochrome table has no wavelength {wavelength_um:g} um")
        m &= _close(waves, wavelength_um)
        if not m.any():
            raise ResultError(f"{show(table.path)}: no rows for incidence {theta_i_deg:g} deg at wavelength "
                              f"{wavelength_um:g} um (has {_list(dict.fromkeys(waves.tolist()))})")
    elif waves is not None:
        there = list(dict.fromkeys(waves[m].tolist()))
        if len(there) > 1:
            raise ResultError(f"{show(table.path)}: incidence {theta_i_deg:g} deg has {len(there)} wavelengths "
                              f"({_list(there)} um): name one, e.g. at({theta_i_deg:g}, "
                              f"wavelength_um={there[0]:g}), or at_wavelength first")
    return _select(table, m)


def _one_azimuth(table, phi_i_deg: float | None):
    """The rows of light azimuth `phi_i_deg` (all rows of a table of one
    azimuth); a table of several needs it named."""
    phis = table.phi_i_deg
    there = [] if phis is None else list(dict.fromkeys(phis.tolist()))
    if phi_i_deg is None:
        if len(there) > 1:
            raise ResultError(f"{show(table.path)}: {len(there)} light azimuths ({_list(there)} deg): name one "
                              f"(phi_i_deg)")
        return table
    if phis is None:
        raise ResultError(f"{show(table.path)}: a table of one light azimuth has no phi_i_deg column")
    m = _close(phis, phi_i_deg)
    if not m.any():
        raise ResultError(f"{show(table.path)}: no rows at azimuth {phi_i_deg:g} deg (has {_list(there)})")
    return _select(table, m)


def _replace_field(obj, name, value):
    kw = {f.name: getattr(obj, f.name) for f in fields(obj)}
    kw[name] = value
    return type(obj)(**kw)


@dataclass(frozen=True)
class BrdfTable(_Spectral):
    """brdf.csv: per incidence (theta_i_deg, phi_i_deg) and, for a spectral
    run, wavelength (wavelength_um, um; else None) one block of rows, one
    per Carlson cell in grid order. `fraction` is the share of the incident
    power leaving through the cell, `brdf` = fraction / projected solid
    angle (1/sr); angles in degrees, solid angles in sr."""

    FILE = "brdf.csv"

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
    wavelength_um: np.ndarray | None = None
    extra: dict | None = None
    """Columns beyond roks's known ones (`EXTRA_ERROR_COLUMN`, e.g. the
    photon-noise part of an ensemble's standard errors), by name."""

    @classmethod
    def read(cls, path: str | Path) -> "BrdfTable":
        return _table(cls, Path(path))

    def _check(self):
        keys = [self.theta_i_deg, self.phi_i_deg] + ([self.wavelength_um] if self.wavelength_um is not None else [])
        size = _blocks(self.path, keys, "incidence and wavelength" if len(keys) == 3 else "incidence")
        _check_grid(self.path, self.band, self.cell, size)

    @property
    def incidences(self) -> list[tuple[float, float]]:
        """The (theta_i_deg, phi_i_deg) of the blocks, in file order."""
        return list(dict.fromkeys(zip(self.theta_i_deg.tolist(), self.phi_i_deg.tolist())))

    @property
    def grid(self) -> CarlsonGrid:
        """The Carlson grid of the blocks."""
        n = len(self.theta_i_deg) // (max(len(self.incidences), 1) * max(len(self.wavelengths), 1))
        try:
            return CarlsonGrid.of_cells(n)
        except ValueError as e:
            raise ResultError(f"{show(self.path)}: {e}") from None

    @property
    def azimuths(self) -> list[float]:
        """The light azimuths phi_i_deg of the blocks (degrees), in file order."""
        return list(dict.fromkeys(self.phi_i_deg.tolist()))

    def at(self, theta_i_deg: float, phi_i_deg: float | None = None, *, phi: float | None = None,
           wavelength_um: float | None = None) -> "BrdfTable":
        """The block of one incidence (matched within 1e-9 degrees; `phi` is
        `phi_i_deg`): of a run of several light azimuths the azimuth must be
        named, and of a spectral run of several wavelengths the wavelength
        (or `at_wavelength` first); else ResultError saying so."""
        return _at(self, theta_i_deg, _phi(self, phi_i_deg, phi), wavelength_um)

    def cells(self, phi_i_deg: float | None = None) -> dict[float, dict[tuple[int, int], tuple[float, float]]]:
        """{theta_i_deg: {(band, cell): (fraction, fraction_stderr)}} (a
        monochrome table; of a run of several light azimuths, the azimuth
        `phi_i_deg`, which must then be given)."""
        _monochrome(self)
        t = _one_azimuth(self, phi_i_deg)
        out: dict = {}
        for th, j, c, f, e in zip(t.theta_i_deg.tolist(), t.band.astype(int).tolist(),
                                  t.cell.astype(int).tolist(), t.fraction.tolist(),
                                  t.fraction_stderr.tolist()):
            out.setdefault(th, {})[(j, c)] = (f, e)
        return out


@dataclass(frozen=True)
class InPlane(_Spectral):
    """inplane.csv: the BRDF (1/sr) in the plane of incidence by outgoing
    angle theta_o_deg (negative: the incident side), per incidence and, for
    a spectral run, wavelength (`wavelength_um`, um; else None)."""

    FILE = "inplane.csv"

    path: Path
    theta_i_deg: np.ndarray
    theta_o_deg: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray
    wavelength_um: np.ndarray | None = None
    phi_i_deg: np.ndarray | None = None
    """The light azimuth of a run of several (`None`: one azimuth, in summary.json)."""
    extra: dict | None = None
    """Columns beyond roks's known ones (`EXTRA_ERROR_COLUMN`, e.g. the
    photon-noise part of an ensemble's standard errors), by name."""

    @classmethod
    def read(cls, path: str | Path) -> "InPlane":
        return _table(cls, Path(path))

    def _check(self):
        keys = ([self.theta_i_deg] + ([self.phi_i_deg] if self.phi_i_deg is not None else [])
                + ([self.wavelength_um] if self.wavelength_um is not None else []))
        size = _blocks(self.path, keys, "incidence")
        bins = self.theta_o_deg.reshape(-1, size)
        if not np.all(bins == bins[0]) or not np.all(np.diff(bins[0]) > 0):
            raise ResultError(f"{show(self.path)}: the theta_o_deg bins differ between blocks or do not increase")

    def at(self, theta_i_deg: float, phi_i_deg: float | None = None, *, phi: float | None = None,
           wavelength_um: float | None = None) -> "InPlane":
        """The block of one incidence, as `BrdfTable.at` (a run of several
        light azimuths or wavelengths: name the one)."""
        return _at(self, theta_i_deg, _phi(self, phi_i_deg, phi), wavelength_um)

    def by_theta(self, phi_i_deg: float | None = None) -> dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """{theta_i_deg: (theta_o_deg, brdf, brdf_stderr)} (a monochrome table;
        of a run of several light azimuths, the azimuth `phi_i_deg`)."""
        _monochrome(self)
        t = _one_azimuth(self, phi_i_deg)
        return {th: (s.theta_o_deg, s.brdf, s.brdf_stderr)
                for th in dict.fromkeys(t.theta_i_deg.tolist()) for s in [t.at(th)]}


@dataclass(frozen=True)
class PolarTable(_Spectral):
    """stokes.csv or mueller.csv: per incidence, wavelength (spectral run)
    and Carlson cell the Stokes BRDF s0..s3 or the Mueller-matrix BRDF
    m00..m33 (1/sr), `values` and `stderr` of shape (rows, components) in
    `names` order; stokes.csv's degree of polarisation in `dop` (NaN where
    undefined, if roks writes it so); columns after the known ones (see
    `EXTRA_POLAR_COLUMN`) in `extra`."""

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
    dop: np.ndarray | None = None
    wavelength_um: np.ndarray | None = None
    extra: dict | None = None

    @classmethod
    def read(cls, path: str | Path) -> "PolarTable":
        path = Path(path)
        mode = {"stokes.csv": "stokes", "mueller.csv": "mueller"}.get(path.name)
        if mode is None:
            raise ResultError(f"{show(path)}: neither stokes.csv nor mueller.csv")
        names = STOKES_NAMES if mode == "stokes" else MUELLER_NAMES
        # The matrix columns first; what follows (mueller.csv's m_ij/m00
        # errors, absent in older files and the Mitsuba tracer's) is extra.
        base = STOKES_COLUMNS if mode == "stokes" else MUELLER_MATRIX_COLUMNS
        header, data = _table_text(path, (base, _spectral(base, "phi_i_deg")), EXTRA_POLAR_COLUMN)
        cols = {c: data[:, i] for i, c in enumerate(header)}
        known = set(_spectral(base, "phi_i_deg"))
        t = cls(path=path, mode=mode, names=names,
                **{k: cols[k] for k in POLAR_KEYS},
                values=np.stack([cols[n] for n in names], axis=1),
                stderr=np.stack([cols[n + "_stderr"] for n in names], axis=1),
                dop=cols.get("dop"), wavelength_um=cols.get("wavelength_um"),
                extra={c: v for c, v in cols.items() if c not in known})
        keys = [t.theta_i_deg, t.phi_i_deg] + ([t.wavelength_um] if t.wavelength_um is not None else [])
        _check_grid(path, t.band, t.cell, _blocks(path, keys, "incidence and wavelength"))
        return t

    @classmethod
    def find(cls, folder: str | Path) -> "PolarTable | None":
        """The stokes.csv or mueller.csv in `folder`, or None when it has neither."""
        for name in POLAR_FILES.values():
            if (Path(folder) / name).is_file():
                return cls.read(Path(folder) / name)
        return None

    def cells(self, phi_i_deg: float | None = None) -> dict[float, dict[tuple[int, int], tuple[list[float], list[float]]]]:
        """{theta_i_deg: {(band, cell): (values, stderrs)}} (a monochrome table;
        of a run of several light azimuths, the azimuth `phi_i_deg`)."""
        _monochrome(self)
        t = _one_azimuth(self, phi_i_deg)
        out: dict = {}
        for th, j, c, v, e in zip(t.theta_i_deg.tolist(), t.band.astype(int).tolist(),
                                  t.cell.astype(int).tolist(), t.values.tolist(),
                                  t.stderr.tolist()):
            out.setdefault(th, {})[(j, c)] = (v, e)
        return out


@dataclass(frozen=True)
class ColourTable:
    """colour.csv of a spectral run covering the visible: per incidence and
    Carlson cell the CIE 1931 XYZ and the linear sRGB (r, g, b) of the BRDF
    (1/sr) under equal-energy light."""

    FILE = "colour.csv"

    path: Path
    theta_i_deg: np.ndarray
    phi_i_deg: np.ndarray
    band: np.ndarray
    cell: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    Z: np.ndarray
    r: np.ndarray
    g: np.ndarray
    b: np.ndarray
    extra: dict | None = None
    """Columns beyond roks's known ones (`EXTRA_ERROR_COLUMN`, e.g. the
    photon-noise part of an ensemble's standard errors), by name."""

    @classmethod
    def read(cls, path: str | Path) -> "ColourTable":
        return _table(cls, Path(path))

    def _check(self):
        _check_grid(self.path, self.band, self.cell, _blocks(self.path, [self.theta_i_deg, self.phi_i_deg],
                                                             "incidence"))


@dataclass(frozen=True)
class Reflectance:
    """reflectance.csv of `roks trace`: per beam position (x, y, z) the
    object's reflectance and its standard error; a spectral run has a row
    per position and wavelength (`wavelength_um`, um; else None)."""

    FILE = "reflectance.csv"

    path: Path
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    reflectance: np.ndarray
    reflectance_stderr: np.ndarray
    wavelength_um: np.ndarray | None = None
    extra: dict | None = None
    """Columns beyond roks's known ones (`EXTRA_ERROR_COLUMN`, e.g. the
    photon-noise part of an ensemble's standard errors), by name."""

    @classmethod
    def read(cls, path: str | Path) -> "Reflectance":
        return _table(cls, Path(path))

    def _check(self):
        if np.any(self.reflectance_stderr < 0):
            raise ResultError(f"{show(self.path)}: a negative standard error")
        if self.wavelength_um is not None:
            w = self.wavelength_um
            n = len(dict.fromkeys(w.tolist()))
            if len(w) % n or not np.array_equal(w, np.tile(w[:n], len(w) // n)):
                raise ResultError(f"{show(self.path)}: the wavelengths are not the same for every position")


@dataclass(frozen=True)
class FarField(_Spectral):
    """farfield.csv of `roks trace`: per beam position (`source`, its row in
    reflectance.csv) and full-sphere Carlson cell (bands -1..-M below the
    horizon) the fraction of the beam leaving through the cell, as brdf.csv;
    a spectral run has a block per position and wavelength (`wavelength_um`,
    um; else None)."""

    FILE = "farfield.csv"

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
    extra: dict | None = None
    """Columns beyond roks's known ones (`EXTRA_ERROR_COLUMN`, e.g. the
    photon-noise part of an ensemble's standard errors), by name."""

    @classmethod
    def read(cls, path: str | Path) -> "FarField":
        return _table(cls, Path(path))

    def _check(self):
        keys = [self.source] + ([self.wavelength_um] if self.wavelength_um is not None else [])
        _check_grid(self.path, self.band, self.cell, _blocks(self.path, keys, "position and wavelength"),
                    full_sphere=True)


@dataclass(frozen=True)
class FarFieldStokes(_Spectral):
    """farfield_stokes.csv of `roks trace` (`[tally] polarisation = "stokes"`):
    per beam position and full-sphere Carlson cell the Stokes vector of the
    light leaving through it as a BRDF (1/sr), `values`/`stderr` of shape
    (rows, 4), and its degree of polarisation `dop`."""

    FILE = "farfield_stokes.csv"

    path: Path
    source: np.ndarray
    band: np.ndarray
    cell: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    solid_angle_sr: np.ndarray
    projected_solid_angle_sr: np.ndarray
    values: np.ndarray
    stderr: np.ndarray
    dop: np.ndarray
    wavelength_um: np.ndarray | None = None

    @classmethod
    def read(cls, path: str | Path) -> "FarFieldStokes":
        path = Path(path)
        header, data = _table_text(path, (FARFIELD_STOKES_COLUMNS, SPECTRAL_FARFIELD_STOKES_COLUMNS))
        c = {h: data[:, i] for i, h in enumerate(header)}
        t = cls(path=path, **{k: c[k] for k in ("source", "band", "cell", "theta_deg", "phi_deg", "solid_angle_sr",
                                                "projected_solid_angle_sr", "dop")},
                values=np.stack([c[n] for n in STOKES_NAMES], axis=1),
                stderr=np.stack([c[n + "_stderr"] for n in STOKES_NAMES], axis=1),
                wavelength_um=c.get("wavelength_um"))
        keys = [t.source] + ([t.wavelength_um] if t.wavelength_um is not None else [])
        _check_grid(path, t.band, t.cell, _blocks(path, keys, "position and wavelength"), full_sphere=True)
        return t


@dataclass(frozen=True)
class FitInPlane:
    """fit_inplane.csv of `roks fit`: the measured in-plane BRDF (1/sr) and
    the fitted model's at each measured point (theta_i_deg, signed theta_o_deg;
    phi_i_deg when the measurement gave light azimuths, else None)."""

    FILE = "fit_inplane.csv"

    path: Path
    theta_i_deg: np.ndarray
    theta_o_deg: np.ndarray
    measured: np.ndarray
    model: np.ndarray
    phi_i_deg: np.ndarray | None = None
    extra: dict | None = None
    """Columns beyond roks's known ones (`EXTRA_ERROR_COLUMN`, e.g. the
    photon-noise part of an ensemble's standard errors), by name."""

    @classmethod
    def read(cls, path: str | Path) -> "FitInPlane":
        return _table(cls, Path(path))

    def _check(self):
        if np.any(self.model < 0):
            raise ResultError(f"{show(self.path)}: a negative model BRDF")


def read_toml(path: str | Path) -> dict:
    """A TOML file roks writes (fitted.toml of `roks fit`: the scene with the
    fitted values) as a dict; ResultError naming the file."""
    import tomllib
    path = Path(path)
    try:
        return tomllib.loads(_text(path))
    except tomllib.TOMLDecodeError as e:
        raise ResultError(f"{show(path)}: not TOML: {str(e).splitlines()[0]}") from None
    except RecursionError:
        raise ResultError(f"{show(path)}: TOML nested too deeply") from None


def _need(folder: Path, name: str) -> Path:
    p = folder / name
    if not p.is_file():
        raise ResultError(f"{show(p)}: not found")
    return p


def _optional(folder: Path, name: str, reader):
    p = folder / name
    return reader(p) if p.is_file() else None


def _agree(path: Path, what: str, a, b, rtol: float = 1e-8):
    """ResultError naming `path` when the arrays a and b differ (a file of another run?)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape or not np.allclose(a, b, rtol=rtol, atol=1e-300):
        raise ResultError(f"{show(path)}: {what} do not agree with summary.json (a file of another run?)")


@dataclass(frozen=True)
class BrdfResult:
    """A `roks brdf` (or `roks merge`, or Mitsuba tracer) result folder, read
    whole: the files every run writes and those of its options (None when
    absent). The tables are checked against summary.json: the same
    incidences and wavelengths."""

    folder: Path
    summary: BrdfSummary
    brdf: BrdfTable
    inplane: InPlane
    polar: PolarTable | None
    colour: ColourTable | None = None
    tallies: Tallies | None = None

    @classmethod
    def load(cls, folder: str | Path) -> "BrdfResult":
        folder = Path(folder)
        if not folder.is_dir():
            raise ResultError(f"{show(folder)}: not a folder")
        summary = read_summary(_need(folder, "summary.json"))
        if not isinstance(summary, BrdfSummary):
            raise ResultError(f"{show(folder / 'summary.json')}: a `roks trace` summary, not `roks brdf`'s")
        r = cls(folder, summary, BrdfTable.read(_need(folder, "brdf.csv")),
                InPlane.read(_need(folder, "inplane.csv")), PolarTable.find(folder),
                _optional(folder, "colour.csv", ColourTable.read),
                _optional(folder, "tallies.json", read_tallies))
        r._check()
        return r

    def _check(self):
        s, b = self.summary, self.brdf
        want = [(e.theta_deg, e.phi_deg) for e in s.incidence]
        if b.incidences != want:
            raise ResultError(f"{show(b.path)}: incidences {b.incidences} but summary.json has {want}")
        if b.wavelengths != (s.wavelengths_um or []):
            raise ResultError(f"{show(b.path)}: wavelengths {b.wavelengths} but summary.json has "
                              f"{s.wavelengths_um or 'none'}")
        for t in (self.inplane, self.polar):
            if t is not None and t.wavelengths != b.wavelengths:
                raise ResultError(f"{show(t.path)}: wavelengths differ from brdf.csv's")
        if self.polar is not None and (len(self.polar.band) != len(b.band)
                                       or not np.array_equal(self.polar.theta_i_deg, b.theta_i_deg)):
            raise ResultError(f"{show(self.polar.path)}: not the rows of brdf.csv (a file of another run?)")
        if s.bands is not None and b.grid.bands != s.bands:
            raise ResultError(f"{show(b.path)}: {b.grid.bands} bands but summary.json says {s.bands}")

    def at_wavelength(self, wavelength_um: float) -> "BrdfResult":
        """The tables of one wavelength of a spectral run (colour and tallies dropped)."""
        return BrdfResult(self.folder, self.summary, self.brdf.at_wavelength(wavelength_um),
                          self.inplane.at_wavelength(wavelength_um),
                          None if self.polar is None else self.polar.at_wavelength(wavelength_um))


@dataclass(frozen=True)
class TraceResult:
    """A `roks trace` result folder, read whole (farfield.csv and
    farfield_stokes.csv None when the run did not ask for them). The
    folder of a shard (`roks trace --shard I/N`) holds summary.json and
    tallies.json only: `tallies` is its raw sums (`TraceTallies`), the
    tables None."""

    folder: Path
    summary: TraceSummary
    reflectance: Reflectance | None
    farfield: FarField | None
    farfield_stokes: FarFieldStokes | None = None
    tallies: "TraceTallies | None" = None

    @classmethod
    def load(cls, folder: str | Path) -> "TraceResult":
        folder = Path(folder)
        if not folder.is_dir():
            raise ResultError(f"{show(folder)}: not a folder")
        summary = read_summary(_need(folder, "summary.json"))
        if not isinstance(summary, TraceSummary):
            raise ResultError(f"{show(folder / 'summary.json')}: a `roks brdf` summary, not `roks trace`'s")
        if summary.shard is not None and not (folder / "reflectance.csv").exists():
            tallies = read_tallies(_need(folder, "tallies.json"))
            if not isinstance(tallies, TraceTallies):
                raise ResultError(f"{show(tallies.path)}: the tallies of a `roks brdf` shard beside a "
                                  f"`roks trace` summary.json")
            if (tallies.shard.index, tallies.shard.count) != (summary.shard.index, summary.shard.count):
                raise ResultError(f"{show(tallies.path)}: shard {tallies.shard.index}/{tallies.shard.count} but "
                                  f"summary.json says {summary.shard.index}/{summary.shard.count}")
            nw = len(tallies.positions) // max(len(summary.sources), 1)  # position-major, then wavelength
            if [p.photons for p in tallies.positions] != [x.photons for x in summary.sources for _ in range(nw)]:
                raise ResultError(f"{show(tallies.path)}: the photons of the positions differ from summary.json's")
            return cls(folder, summary, None, None, None, tallies)
        r = cls(folder, summary, Reflectance.read(_need(folder, "reflectance.csv")),
                _optional(folder, "farfield.csv", FarField.read),
                _optional(folder, "farfield_stokes.csv", FarFieldStokes.read))
        r._check()
        return r

    def _check(self):
        s, r = self.summary, self.reflectance
        nw = max(len(s.wavelengths_um or []), 1)
        if len(r.x) != len(s.sources) * nw:
            raise ResultError(f"{show(r.path)}: {len(r.x)} rows for {len(s.sources)} positions x {nw} "
                              f"wavelengths in summary.json (a cut file?)")
        pos = np.repeat([src.position for src in s.sources], nw, axis=0)
        _agree(r.path, "the positions", np.stack([r.x, r.y, r.z], axis=1), pos)
        if s.wavelengths_um:
            _agree(r.path, "the wavelengths", r.wavelength_um, np.tile(s.wavelengths_um, len(s.sources)))
        for name, key in (("farfield.csv", "farfield"), ("farfield_stokes.csv", "farfield_stokes")):
            # summary.json says whether the far field was tallied (older
            # files lack the key: then the file's presence is all there is).
            if key in s.raw and getattr(s, key) != (getattr(self, key) is not None):
                said = "was" if getattr(s, key) else "was not"
                raise ResultError(f"{show(self.folder / name)}: summary.json says the far field {said} "
                                  f"tallied, but the file is {'missing' if getattr(s, key) else 'there'}")
        for t in (self.farfield, self.farfield_stokes):
            if t is not None and (t.source.max() >= len(s.sources) or len(t.source) % (len(s.sources) * nw)):
                raise ResultError(f"{show(t.path)}: not {len(s.sources)} positions x {nw} wavelengths "
                                  f"of summary.json (a cut file?)")


@dataclass(frozen=True)
class FitResult:
    """A `roks fit` result folder: fit.json (typed), fit_inplane.csv and
    fitted.toml (the scene with the fitted values, as a dict)."""

    folder: Path
    summary: FitSummary
    inplane: FitInPlane
    fitted: dict

    @classmethod
    def load(cls, folder: str | Path) -> "FitResult":
        folder = Path(folder)
        if not folder.is_dir():
            raise ResultError(f"{show(folder)}: not a folder")
        r = cls(folder, read_fit(_need(folder, "fit.json")), FitInPlane.read(_need(folder, "fit_inplane.csv")),
                read_toml(_need(folder, "fitted.toml")))
        for p in r.summary.parameters:
            if not p.lo <= p.fitted <= p.hi:
                raise ResultError(f"{show(r.summary.path)}: {p.key} = {p.fitted} outside its bounds [{p.lo}, {p.hi}]")
        return r


def load_result(folder: str | Path) -> BrdfResult | TraceResult | FitResult:
    """The result folder of `roks brdf` / `roks merge` (BrdfResult), of
    `roks trace` (TraceResult), by its summary.json, or of `roks fit`
    (FitResult, by its fit.json)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ResultError(f"{show(folder)}: not a folder")
    if (folder / "fit.json").is_file() and not (folder / "summary.json").exists():
        return FitResult.load(folder)
    s = read_summary(_need(folder, "summary.json"))
    return (BrdfResult if isinstance(s, BrdfSummary) else TraceResult).load(folder)


def read_png(path: str | Path) -> np.ndarray:
    """A PNG picture roks writes, as an array (rows, columns, channels)."""
    path = Path(path)
    import matplotlib.image as mpimg
    try:
        return mpimg.imread(path, format="png")
    except FileNotFoundError:
        raise ResultError(f"{show(path)}: not found") from None
    except Exception as e:  # noqa: BLE001 (Pillow raises many kinds on bad bytes)
        raise ResultError(f"{show(path)}: not a PNG picture: {type(e).__name__}") from None


def _read_bsdf(path: str | Path):
    """A `.bsdf` file: the RGL tensor file (`brdf_rgl.bsdf`) by its magic
    bytes, else a Zemax text (`brdf.bsdf`, `brdf_<wavelength>um.bsdf`)."""
    from .exports import is_tensor_file, read_rgl, read_zemax
    return read_rgl(path) if is_tensor_file(path) else read_zemax(path)


def _read_json(path: str | Path):
    """A JSON file of another name, by its content: a fit-model file (`model`
    and `fits`), an export marker (`format` and `files`), a summary
    (`incidence` or `sources`), a tallies file (`format` roks-tallies...)."""
    from .summary import read_export_marker, read_fit_model, read_json
    path = Path(path)
    data = read_json(path)
    if isinstance(data, dict):
        if "model" in data and "fits" in data:
            return read_fit_model(path)
        if str(data.get("format", "")).endswith("tallies"):
            return read_tallies(path)
        if "files" in data and "format" in data:
            return read_export_marker(path)
        if "incidence" in data or "sources" in data:
            return read_summary(path)
        if "ranking" in data:
            from .summary import read_fit_ranking
            return read_fit_ranking(path)
        if "parameters" in data and "misfit" in data:
            return read_fit(path)
    raise ResultError(f"{show(path)}: not a JSON file roks writes (a summary, tallies, fit or export file)")


def _lazy(module: str, name: str):
    def read(path):
        import importlib
        return getattr(importlib.import_module(f"roks_tools.{module}"), name)(path)
    read.__name__ = name
    return read


READERS = {
    "summary.json": read_summary,
    "tallies.json": read_tallies,
    "brdf.csv": BrdfTable.read,
    "inplane.csv": InPlane.read,
    "stokes.csv": PolarTable.read,
    "mueller.csv": PolarTable.read,
    "colour.csv": ColourTable.read,
    "reflectance.csv": Reflectance.read,
    "farfield.csv": FarField.read,
    "farfield_stokes.csv": FarFieldStokes.read,
    "fit.json": read_fit,
    "fit_inplane.csv": FitInPlane.read,
    "fitted.toml": read_toml,
    "export.json": _lazy("summary", "read_export_marker"),
    "fit_summary.json": _lazy("summary", "read_fit_ranking"),
    ".roks-files.json": _lazy("summary", "read_files_record"),
}
"""The reader of every file roks writes, by name (other names: by
extension, `SUFFIX_READERS`, and `read_file`)."""

SUFFIX_READERS = {
    ".bsdf": _read_bsdf,
    ".pbsdf": _lazy("exports", "read_pbsdf"),
    ".binary": _lazy("exports", "read_merl"),
    ".ply": _lazy("exports", "read_ply"),
    ".json": _read_json,
}
"""Readers by extension: Zemax (`brdf.bsdf`, `brdf_<wavelength>um.bsdf`)
or RGL (`brdf_rgl.bsdf`) by content, pbsdf, MERL, PLY (export-mesh), and
JSON files of other names by content (`fit_<model>.json` of fit-model, or
any file given as `--out`)."""


def _first_line(path: Path) -> str:
    """The first line of a file (up to 200 bytes), or '' when it cannot be read."""
    try:
        with open(path, "rb") as f:
            return f.read(200).split(b"\n", 1)[0].decode("utf-8", "replace").lstrip("\ufeff")
    except OSError:
        return ""


def read_file(path: str | Path):
    """Any file roks writes into a result folder (or as `--out`), by its
    name: the tables and JSON files (`READERS`), `fit_<model>.json`
    (`summary.read_fit_model`), `*_opticstudio.txt` (ABg rows,
    `exports.read_opticstudio_abg`), other `*.txt` whose first line is
    export-heightfield's `# roks height map ...` (`exports.read_height_map`;
    a height map of yours: call it directly), the exports by extension
    (`SUFFIX_READERS`: `.bsdf` Zemax or RGL, `.pbsdf`, `.binary` MERL,
    `.ply`), `*.png` pictures (`read_png`), `*.exr` renders (`read_exr`,
    needs mitsuba). Each returns its typed object; ResultError naming the
    file for a file of no known name or that is not what roks writes."""
    path = Path(path)
    if path.name in READERS:
        return READERS[path.name](path)
    if path.name.startswith("fit_") and path.suffix == ".json":
        from .summary import read_fit_model
        return read_fit_model(path)
    if path.name.endswith("_opticstudio.txt"):
        from .exports import read_opticstudio_abg
        return read_opticstudio_abg(path)
    if path.suffix == ".txt" and _first_line(path).startswith("# roks height map"):
        from .exports import read_height_map
        return read_height_map(path)
    if path.suffix in SUFFIX_READERS:
        return SUFFIX_READERS[path.suffix](path)
    if path.suffix == ".png":
        return read_png(path)
    if path.suffix == ".exr":
        return read_exr(path)
    raise ResultError(f"{show(path)}: not a file roks writes (no reader for {path.name!r})")


def read_exr(path: str | Path) -> np.ndarray:
    """An EXR render (roks render, Mitsuba) as a 2-D float64 array: the mean
    of its first three channels (needs mitsuba, whose Bitmap reads EXR;
    sets scalar_rgb when no variant is set)."""
    path = Path(path)
    if not path.is_file():
        raise ResultError(f"{show(path)}: not found")
    try:
        import mitsuba as mi
    except ImportError:
        from .errors import MitsubaError
        raise MitsubaError(f"{show(path)}: reading EXR needs mitsuba (pip install './python[mitsuba]')") from None
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    try:
        a = np.array(mi.Bitmap(str(path)), dtype=np.float64)
    except Exception as e:  # noqa: BLE001 (mitsuba raises RuntimeError and others on bad bytes)
        raise ResultError(f"{show(path)}: not an EXR image mitsuba reads: {str(e).splitlines()[0][:120] if str(e) else type(e).__name__}") from None
    if a.ndim == 3:
        a = a[..., :3].mean(axis=2)
    return a
