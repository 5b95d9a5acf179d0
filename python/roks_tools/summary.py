"""summary.json, tallies.json and fit.json as typed dataclasses: the one place
that knows their keys.

roks's run descriptions (src/output/summary.rs, src/output/tallies.rs) may
gain or lose keys; each key is one field here, so adapting is one line.
A field with a default is optional (absent in older files, in a monochrome
run, or in the Mitsuba tracer's folders, which write the same `incidence`
entries with fewer run keys); a field without one is required. Keys a
class does not list are kept, untouched, in its `raw` dict (`raw` holds the
whole JSON object), and `obj["key"]` / `obj.get("key")` read `raw`.

Types are checked: `float` takes a JSON number (not a boolean), `int` an
integer, `str` a string, `list[float]` a list of numbers, a dataclass an
object, `dict[str, float]` an object of numbers, `X | None` also null. A
wrong or missing value raises `ResultError` naming the file and the key's
JSON path (e.g. `out/summary.json: incidence[2].photons: expected an
integer, got "12"`). tallies.json writes its floating-point sums as
decimal strings (exact); `ExactFloat` fields read them as floats.

    from roks_tools.summary import read_summary
    s = read_summary("out/default/summary.json")   # BrdfSummary or TraceSummary
    s.incidence[0].reflectance, s.surface.sigma
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NewType, Union

from .errors import ResultError, show

ExactFloat = NewType("ExactFloat", float)
"""A float written as a decimal string (tallies.json), read back bit for bit."""

MAX_JSON_BYTES = 1 << 30
"""Largest JSON file read (1 GiB): a larger one is not a roks file."""


class _Fields:
    """Mixin of the typed JSON objects: `raw` access by key."""

    raw: dict

    def __getitem__(self, key: str):
        return self.raw[key]

    def get(self, key: str, default=None):
        return self.raw.get(key, default)

    def __contains__(self, key: str) -> bool:
        return key in self.raw


def _kind(t) -> str:
    return getattr(t, "__name__", None) or str(t)


def _convert(t, v, where: str):
    """`v` (parsed JSON) as type `t`, or ResultError naming `where`."""
    origin = typing.get_origin(t)
    if origin in (Union, types.UnionType):
        args = typing.get_args(t)
        if v is None and type(None) in args:
            return None
        options = [a for a in args if a is not type(None)]
        for inner in options[:-1]:
            try:
                return _convert(inner, v, where)
            except ResultError:
                pass
        return _convert(options[-1], v, where)
    if t is Any:
        return v
    if t is ExactFloat:
        if isinstance(v, str):
            try:
                v = float(v)
            except ValueError:
                raise ResultError(f"{where}: {v[:40]!r} is not a decimal number") from None
        t = float
    if t is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ResultError(f"{where}: expected a number, got {_short(v)}")
        try:
            x = float(v)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            raise ResultError(f"{where}: {_short(v)} is out of the range of a float")
        return x
    if t is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise ResultError(f"{where}: expected an integer, got {_short(v)}")
        return v
    if t is str:
        if not isinstance(v, str):
            raise ResultError(f"{where}: expected a string, got {_short(v)}")
        return v
    if t is bool:
        if not isinstance(v, bool):
            raise ResultError(f"{where}: expected true or false, got {_short(v)}")
        return v
    if origin is list:
        (inner,) = typing.get_args(t)
        if not isinstance(v, list):
            raise ResultError(f"{where}: expected a list, got {_short(v)}")
        return [_convert(inner, x, f"{where}[{i}]") for i, x in enumerate(v)]
    if origin is dict:
        _, inner = typing.get_args(t)
        if not isinstance(v, dict):
            raise ResultError(f"{where}: expected an object, got {_short(v)}")
        return {k: _convert(inner, x, _key(where, k)) for k, x in v.items()}
    if dataclasses.is_dataclass(t):
        return _object(t, v, where)
    raise TypeError(f"summary: no conversion for {_kind(t)}")  # a bug of this module


def _short(v) -> str:
    s = json.dumps(v) if not isinstance(v, (dict, list)) else type(v).__name__
    return s if len(s) <= 40 else s[:37] + "..."


_HINTS: dict[type, dict] = {}


def _object(cls, v, where: str, **given):
    """The dataclass `cls` from the JSON object `v`; `given` fields are set as is."""
    if not isinstance(v, dict):
        raise ResultError(f"{where}: expected an object, got {_short(v)}")
    hints = _HINTS.get(cls)
    if hints is None:
        hints = _HINTS[cls] = typing.get_type_hints(cls)
    kw = dict(given)
    for f in dataclasses.fields(cls):
        if f.name == "raw" or f.name in given:
            continue
        required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if f.name not in v:
            if required:
                raise ResultError(f"{where}: lacks the key {f.name!r}")
            continue
        kw[f.name] = _convert(hints[f.name], v[f.name], _key(where, f.name))
    return cls(**kw, raw=v)


def _key(where: str, name: str) -> str:
    """`where` + `.name`, or `where name` after the file's `path:` prefix."""
    return f"{where} {name}" if where.endswith(":") else f"{where}.{name}"


def read_json(path: str | Path) -> Any:
    """A JSON file, or ResultError naming it for any bytes that are not
    UTF-8 JSON (nesting too deep, numbers out of range, a cut file)."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            data = f.read(MAX_JSON_BYTES + 1)
    except OSError as e:
        raise ResultError(f"{show(path)}: cannot read: {e.strerror or e}") from None
    if len(data) > MAX_JSON_BYTES:
        raise ResultError(f"{show(path)}: larger than {MAX_JSON_BYTES >> 20} MiB, not a roks file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ResultError(f"{show(path)}: byte {e.start}: not UTF-8 text") from None
    try:
        return json.loads(text, parse_constant=_no_constant)
    except json.JSONDecodeError as e:
        cut = " (the file is cut?)" if e.pos >= len(text.rstrip()) else ""
        raise ResultError(f"{show(path)}: line {e.lineno} column {e.colno}: not JSON: {e.msg}{cut}") from None
    except RecursionError:
        raise ResultError(f"{show(path)}: JSON nested too deeply, not a roks file") from None
    except ValueError as e:  # NaN/Infinity (parse_constant), huge integers
        raise ResultError(f"{show(path)}: not JSON roks writes: {e}") from None


def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _read_object(cls, path: str | Path, refusal: str, keys: tuple[str, ...] = ()):
    """The dataclass `cls` read from the JSON file `path`, and `where` (the
    `path:` prefix of its messages); ResultError `refusal` naming the file
    when it is not an object holding every key of `keys`."""
    path = Path(path)
    data = read_json(path)
    where = show(path) + ":"
    if not isinstance(data, dict) or any(k not in data for k in keys):
        raise ResultError(f"{where} {refusal}")
    return _object(cls, data, where, path=path), where


def read_typed(cls, path: str | Path):
    """A JSON file as the dataclass `cls` (types checked, ResultError naming
    the file and key)."""
    path = Path(path)
    return _object(cls, read_json(path), show(path) + ":")


# ----------------------------------------------------------------------------
# summary.json of `roks brdf` (and `roks merge`, and the Mitsuba tracer)
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Colour(_Fields):
    """The colour of the reflected light of a spectral run covering the visible."""

    xyz: list[float]
    srgb_linear: list[float]
    srgb8: list[int] | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class WavelengthResult(_Fields):
    """One wavelength of a spectral `roks brdf` incidence (`spectrum`)."""

    wavelength_um: float
    reflectance: float
    reflectance_stderr: float
    lost: float | None = None
    lost_cap: float | None = None
    lost_numeric: float | None = None
    lost_walls: float | None = None
    reflected_stokes: list[float] | None = None
    reflected_mueller: list[float] | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Incidence(_Fields):
    """One incidence entry of a `roks brdf` summary.json: reflectance (mean
    over the wavelengths of a spectral run) with its standard error, the
    reflectance by number of bounces, losses, cost."""

    theta_deg: float
    phi_deg: float
    photons: int
    reflectance: float
    reflectance_stderr: float
    reflectance_by_bounces: list[float]
    mean_bounces: float | None = None
    lost: float | None = None
    lost_cap: float | None = None
    lost_numeric: float | None = None
    lost_walls: float | None = None
    capped_photons: int | None = None
    numeric_guard_photons: int | None = None
    intersection_tests: int | None = None
    segments: int | None = None
    seconds: float | None = None
    segments_per_second: float | None = None
    tests_per_segment: float | None = None
    reflected_stokes: list[float] | None = None
    reflected_stokes_stderr: list[float] | None = None
    reflected_mueller: list[float] | None = None
    reflected_mueller_stderr: list[float] | None = None
    spectrum: list[WavelengthResult] | None = None
    colour: Colour | None = None
    # Several surface realisations: reflectance_stderr (and the tables'
    # errors) are the ensemble mean's, from the realisations' spread, with
    # stderr_dof = R - 1 degrees of freedom; the photon noise alone is
    # reflectance_stderr_photon.
    reflectance_stderr_photon: float | None = None
    stderr_dof: int | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Surface(_Fields):
    """Statistics of the micro surface's height map (scene units); None
    where undefined (`undefined` says why)."""

    height_map_resolution: int
    sigma: float | None = None
    tau: float | None = None
    sigma_over_tau: float | None = None
    rms_slope: float | None = None
    mean_height: float | None = None
    min_height: float | None = None
    max_height: float | None = None
    undefined: dict[str, str] | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Polarisation(_Fields):
    """The polarisation settings of a run: the incident state as the scene
    writes it (`"unpolarised"`, `"s"`, `{"linear": 30}`, a Stokes vector...),
    the tally (`"none"`, `"stokes"`, `"mueller"`) and whether the transport
    is polarised."""

    incident: Any
    tally: str
    transport: Any
    incident_stokes: list[float] | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class ShardRange(_Fields):
    """Which photons a `--shard I/N` run traced (of every incidence)."""

    index: int
    count: int
    first_photon: int | None = None
    last_photon: int | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Content(_Fields):
    """The identity of a run's input: the SHA-256 of the scene text and of
    every file it reads, by scene key."""

    scene_sha256: str
    files: dict[str, str] = field(default_factory=dict)
    raw: dict = field(default_factory=dict, repr=False)


RUN_KEYS = ("bands", "seed", "launch", "symmetry", "photons_per_incidence", "polarisation", "shard",
            "wavelengths_um")
"""Keys of roks's run description (`run` in summary.json, `description.run`
in tallies.json) also offered at the top of a BrdfSummary, where roks wrote
them before the description was one object (and the Mitsuba tracer still
does)."""


def _lift_run(data: dict, run) -> dict:
    """`data` with the RUN_KEYS of the run description `run` at its top
    level (keys already there win)."""
    if not isinstance(run, dict):
        return data
    return {**{k: run[k] for k in RUN_KEYS if k in run}, **data}


@dataclass(frozen=True)
class BrdfSummary(_Fields):
    """summary.json of `roks brdf` / `roks merge` (also the Mitsuba tracer's,
    which has `incidence`, `bands`, `seed` and its own run keys)."""

    path: Path
    incidence: list[Incidence]
    run: dict[str, Any] | None = None
    content: Content | None = None
    bands: int | None = None
    seed: int | None = None
    name: str | None = None
    scene: str | None = None
    version: str | None = None
    edges: str | None = None
    launch: str | None = None
    symmetry: str | None = None
    photons_per_incidence: int | None = None
    seconds: float | None = None
    surface: Surface | None = None
    polarisation: Polarisation | str | None = None
    shard: ShardRange | None = None
    wavelengths_um: list[float] | None = None
    raw: dict = field(default_factory=dict, repr=False)

    kind = "brdf"

    @property
    def spectral(self) -> bool:
        """True for a run with `wavelengths_um` (its files have a wavelength_um column)."""
        return bool(self.wavelengths_um)

    @property
    def polar_tally(self) -> str:
        """"stokes", "mueller" or "none": the polarisation file of the folder."""
        p = self.polarisation
        if isinstance(p, Polarisation):
            return p.tally
        return p if p in ("stokes", "mueller") else "none"

    def by_theta(self) -> dict[float, Incidence]:
        return {e.theta_deg: e for e in self.incidence}


# ----------------------------------------------------------------------------
# summary.json of `roks trace`
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class SourceWavelength(_Fields):
    """One wavelength of a spectral `roks trace` beam position."""

    wavelength_um: float
    reflectance: float
    reflectance_stderr: float
    absorbed: dict[str, float]
    absorbed_stderr: dict[str, float]
    emissivity: float
    lost: float
    missed: float
    stokes: list[float] | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Source(_Fields):
    """One beam position of `roks trace`: where, and what became of the beam."""

    position: list[float]
    direction: list[float]
    diameter: float
    photons: int
    reflectance: float
    reflectance_stderr: float
    absorbed: dict[str, float]
    absorbed_stderr: dict[str, float]
    missed: float
    lost: float
    mean_bounces: float | None = None
    seconds: float | None = None
    segments: int | None = None
    polarisation: str | None = None
    stokes: list[float] | None = None
    stokes_stderr: list[float] | None = None
    spectrum: list[SourceWavelength] | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class TraceSummary(_Fields):
    """summary.json of `roks trace`."""

    path: Path
    sources: list[Source]
    name: str | None = None
    scene: str | None = None
    seed: int | None = None
    seconds: float | None = None
    version: str | None = None
    shard: ShardRange | None = None
    wavelengths_um: list[float] | None = None
    farfield: bool = False
    """Whether the far field was tallied (`farfield.csv` written); False
    for files of roks before the key existed."""
    farfield_stokes: bool = False
    """Whether the far field's Stokes vectors were tallied (`farfield_stokes.csv`)."""
    raw: dict = field(default_factory=dict, repr=False)

    kind = "trace"

    @property
    def spectral(self) -> bool:
        return bool(self.wavelengths_um)


# ----------------------------------------------------------------------------
# fit.json of `roks fit`
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class FitParameter(_Fields):
    key: str
    fitted: float
    start: float
    lo: float
    hi: float
    at_bound: str
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class FitSummary(_Fields):
    """fit.json of `roks fit`."""

    path: Path
    converged: bool
    misfit: float
    start_misfit: float
    evaluations: int
    parameters: list[FitParameter]
    measured: str | None = None
    scene: str | None = None
    seed: int | None = None
    photons: int | None = None
    version: str | None = None
    raw: dict = field(default_factory=dict, repr=False)


def read_summary(path: str | Path) -> BrdfSummary | TraceSummary:
    """summary.json of `roks brdf`/`roks merge` (with `incidence`) or of
    `roks trace` (with `sources`), typed; ResultError naming the file."""
    path = Path(path)
    data = read_json(path)
    where = show(path) + ":"
    if isinstance(data, dict) and "sources" in data and "incidence" not in data:
        cls = TraceSummary
    elif isinstance(data, dict) and "incidence" in data:
        cls = BrdfSummary
        data = _lift_run(data, data.get("run"))
    else:
        raise ResultError(f"{show(path)}: not a roks summary.json (an object with 'incidence' or 'sources')")
    return _object(cls, data, where, path=path)


def read_fit(path: str | Path) -> FitSummary:
    """fit.json of `roks fit`, typed."""
    path = Path(path)
    data = read_json(path)
    if not isinstance(data, dict):
        raise ResultError(f"{show(path)}: expected a JSON object")
    return _object(FitSummary, data, show(path) + ":", path=path)


# ----------------------------------------------------------------------------
# tallies.json of `roks brdf --shard I/N` and `roks merge`
# ----------------------------------------------------------------------------

TALLIES_FORMAT = "roks-tallies"
TALLIES_VERSION = 1


@dataclass(frozen=True)
class TallyNode(_Fields):
    """A complete node of the batch tree: `level`, `index` and its raw sums
    (`tallies`: `photons`, `carlson.sum`, ... as JSON, floats as decimal strings)."""

    level: int
    index: int
    tallies: dict[str, Any]
    raw: dict = field(default_factory=dict, repr=False)

    @property
    def photons(self) -> int:
        return int(self.tallies.get("photons", 0))

    def sums(self, name: str, key: str = "sum") -> list[float]:
        """The float sums of tally `name` (e.g. `carlson`, `inplane`), exactly."""
        v = self.tallies.get(name)
        if not isinstance(v, dict):
            raise ResultError(f"tallies.json: node ({self.level}, {self.index}) has no tally {name!r}")
        return _convert(list[ExactFloat], v.get(key), f"tallies.json: {name}.{key}")


@dataclass(frozen=True)
class TalliesIncidence(_Fields):
    """One incidence (of a spectral run: one incidence and wavelength,
    incidence-major) of tallies.json: its photons and its tree nodes."""

    theta_deg: ExactFloat
    photons: int
    seconds: ExactFloat
    nodes: list[TallyNode]
    wavelength_um: ExactFloat | None = None
    raw: dict = field(default_factory=dict, repr=False)

    def carlson_fraction(self) -> list[float]:
        """The mean weight per Carlson cell (and wavelength) over the nodes'
        photons: sum over nodes of `carlson.sum`, over `photons` (as brdf.csv's fraction)."""
        total = None
        for n in self.nodes:
            s = n.sums("carlson")
            total = s if total is None else [a + b for a, b in zip(total, s)]
        return [x / self.photons for x in (total or [])]


@dataclass(frozen=True)
class Tallies(_Fields):
    """tallies.json: the raw sums of a shard (or of a merge), exactly."""

    path: Path
    format: str
    format_version: int
    batch: int
    seconds: ExactFloat
    description: dict[str, Any]
    incidence: list[TalliesIncidence]
    first_photon: int = 0
    last_photon: int = 0
    shard: ShardRange | None = None
    raw: dict = field(default_factory=dict, repr=False)

    @property
    def run(self) -> dict[str, Any]:
        """The run description (as summary.json's `run`)."""
        return self.description.get("run", {})


TRACE_TALLIES_FORMAT = "roks-trace-tallies"
TRACE_TALLIES_VERSION = 1


@dataclass(frozen=True)
class TalliesPosition(_Fields):
    """One beam position (of a spectral run: one position and wavelength,
    position-major) of a `roks trace` shard's tallies.json: its photons in
    the shard and its tree nodes (`tallies`: the raw sums, floats as
    decimal strings)."""

    photons: int
    seconds: ExactFloat
    nodes: list[TallyNode]
    wavelength_um: ExactFloat | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class TraceTallies(_Fields):
    """tallies.json of a `roks trace --shard I/N` run (format
    `roks-trace-tallies`): the raw sums of the shard's block of every beam
    position, exactly, and the run's description (beams, run, shard)."""

    path: Path
    format: str
    format_version: int
    batch: int
    seconds: ExactFloat
    description: dict[str, Any]
    positions: list[TalliesPosition]
    raw: dict = field(default_factory=dict, repr=False)

    @property
    def run(self) -> dict[str, Any]:
        """The run as traced (seed, far field, polarisation, wavelengths)."""
        return self.description.get("run", {})

    @property
    def shard(self) -> ShardRange | None:
        """The shard's index and count (None: a whole run)."""
        s = self.description.get("shard")
        return None if s is None else _object(ShardRange, s, f"{show(self.path)}: description.shard")


def read_tallies(path: str | Path) -> Tallies | TraceTallies:
    """tallies.json, typed: of `roks brdf --shard` / `roks merge` (format
    `roks-tallies` version 1, `Tallies`) or of `roks trace --shard` (format
    `roks-trace-tallies` version 1, `TraceTallies`); ResultError naming the
    file."""
    path = Path(path)
    data = read_json(path)
    where = show(path) + ":"
    if isinstance(data, dict) and data.get("format") == TRACE_TALLIES_FORMAT:
        if data.get("format_version") != TRACE_TALLIES_VERSION:
            raise ResultError(f"{where} format_version {_short(data.get('format_version'))}, this reader knows "
                              f"{TRACE_TALLIES_VERSION}")
        t = _object(TraceTallies, data, where, path=path)
        beams = t.description.get("beams")
        if not isinstance(beams, list) or not beams:
            raise ResultError(f"{where} description.beams: expected a list of the beam positions")
        waves = t.run.get("wavelengths_um") if isinstance(t.run, dict) else None
        nw = len(waves) if isinstance(waves, list) and waves else 1
        if len(t.positions) != len(beams) * nw:
            raise ResultError(f"{where} positions: {len(t.positions)} entries for {len(beams)} beam positions x "
                              f"{nw} wavelengths (a cut file?)")
        return t
    if not isinstance(data, dict) or data.get("format") != TALLIES_FORMAT:
        raise ResultError(f"{where} not a roks tallies.json (format {TALLIES_FORMAT!r} or "
                          f"{TRACE_TALLIES_FORMAT!r})")
    if data.get("format_version") != TALLIES_VERSION:
        raise ResultError(f"{where} format_version {data.get('format_version')!r}, this reader knows {TALLIES_VERSION}")
    # The photons held: the shard's block of the run, or the whole run.
    run = data.get("description", {}).get("run", {}) if isinstance(data.get("description"), dict) else {}
    if isinstance(run, dict):
        shard = run.get("shard")
        if isinstance(shard, dict):
            data = {"first_photon": shard.get("first_photon"), "last_photon": shard.get("last_photon"),
                    "shard": shard, **data}
        elif isinstance(run.get("photons_per_incidence"), int):
            data = {"first_photon": 0, "last_photon": run["photons_per_incidence"], **data}
    t = _object(Tallies, data, where, path=path)
    if t.format_version != TALLIES_VERSION:
        raise ResultError(f"{where} format_version {t.format_version}, this reader knows {TALLIES_VERSION}")
    return t


# ----------------------------------------------------------------------------
# fit_<model>.json of `roks fit-model`
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelParameter(_Fields):
    """One parameter of an analytic model's fit: its value and standard
    error (None: undetermined, a singular covariance; a value roks could
    not compute, NaN in the fit, is written null and read None)."""

    name: str
    value: float | None
    stderr: float | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class ModelReflectance(_Fields):
    """One incidence of a fit: the table's reflectance and the model's over
    the same cells, their difference and, where roks judges it, `ok`."""

    theta_i_deg: float
    table: float
    model: float | None = None
    difference: float | None = None
    chi2_per_cell: float | None = None
    table_stderr: float | None = None
    tolerance: float | None = None
    ok: bool | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class ModelFit(_Fields):
    """One fit of `fit_<model>.json`: per incidence (ABg, Harvey) or over
    all incidences (GGX, Beckmann)."""

    theta_i_deg: list[float]
    parameters: list[ModelParameter]
    termination: str
    converged: bool | None = None
    chi2: float | None = None
    dof: int | None = None
    chi2_per_dof: float | None = None
    covariance_scaled: bool | None = None
    cells: int | None = None
    cells_left_out: int | None = None
    reflectance: list[ModelReflectance] = field(default_factory=list)
    largest_residuals: list[dict[str, Any]] = field(default_factory=list)
    raw: dict = field(default_factory=dict, repr=False)

    def parameter(self, name: str) -> ModelParameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)


@dataclass(frozen=True)
class FitModelSummary(_Fields):
    """fit_<model>.json of `roks fit-model`: the model, the table fitted,
    the fits, and (ABg) the rows of OpticStudio's dialog and FRED's
    parameters; `warnings` where roks writes them."""

    path: Path
    model: str
    fits: list[ModelFit]
    table: str | None = None
    wavelength_um: float | None = None
    version: str | None = None
    definition: str | None = None
    material: str | None = None
    opticstudio: dict[str, Any] | None = None
    fred: dict[str, Any] | None = None
    warnings: list[Any] | None = None
    raw: dict = field(default_factory=dict, repr=False)


def read_fit_model(path: str | Path) -> FitModelSummary:
    """fit_<model>.json of `roks fit-model`, typed; ResultError naming the file."""
    f, where = _read_object(
        FitModelSummary, path, "not a roks fit-model file (an object with 'model' and 'fits')", ("fits", "model")
    )
    if not f.fits:
        raise ResultError(f"{where} fits: no fit")
    for i, fit in enumerate(f.fits):
        if not fit.parameters:
            raise ResultError(f"{where} fits[{i}].parameters: no parameter")
        for j, p in enumerate(fit.parameters):
            if p.stderr is not None and p.stderr < 0:
                raise ResultError(f"{where} fits[{i}].parameters[{j}].stderr: {p.stderr} is negative")
    return f


@dataclass(frozen=True)
class RankedModel(_Fields):
    """One model of fit_summary.json's ranking."""

    model: str
    file: str | None = None
    chi2_per_dof: float | None = None
    passes: bool | None = None
    verdict: str | None = None
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class FitRanking(_Fields):
    """fit_summary.json of `roks fit-model --model all`: the models ranked
    (best first), the one to `use` (None when none passes), the `advice`
    line, the models `not_fitted` and why."""

    path: Path
    ranking: list[RankedModel]
    use: str | None = None
    advice: str | None = None
    rule: str | None = None
    not_fitted: list[dict[str, Any]] | None = None
    table: str | None = None
    version: str | None = None
    raw: dict = field(default_factory=dict, repr=False)


def read_fit_ranking(path: str | Path) -> FitRanking:
    """fit_summary.json of `roks fit-model --model all`, typed; ResultError naming the file."""
    r, where = _read_object(FitRanking, path, "not a roks fit_summary.json (an object with 'ranking')", ("ranking",))
    names = [m.model for m in r.ranking]
    if r.use is not None and r.use not in names:
        raise ResultError(f"{where} use: {r.use!r} is not a model of the ranking")
    return r


# ----------------------------------------------------------------------------
# .roks-files.json: the record of the files roks wrote into a result folder
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class FilesRecord(_Fields):
    """.roks-files.json: the command that wrote the result folder (`command`),
    the roks version (`roks`) and every file roks wrote into it with the
    command that wrote it (`files`: name -> command)."""

    path: Path
    roks: str
    command: str
    files: dict[str, str]
    raw: dict = field(default_factory=dict, repr=False)

    def added(self) -> dict[str, str]:
        """The files later commands (export-brdf, fit-model, plot) added."""
        return {f: c for f, c in self.files.items() if c != self.command}


def read_files_record(path: str | Path) -> FilesRecord:
    """.roks-files.json, typed; every entry a plain file name (ResultError naming the file)."""
    r, where = _read_object(FilesRecord, path, "expected a JSON object")
    for name in r.files:
        if "/" in name or "\\" in name or name in ("", ".", ".."):
            raise ResultError(f"{where} files: {name!r} is not a file name")
    return r


# ----------------------------------------------------------------------------
# export.json of `roks export-brdf` (a folder of per-wavelength files)
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class ExportMarker(_Fields):
    """export.json: the files of a folder of per-wavelength exports of
    `roks export-brdf` (spectral Zemax), their format and table."""

    path: Path
    format: str
    files: list[str]
    version: str | None = None
    raw: dict = field(default_factory=dict, repr=False)

    @property
    def source(self) -> str | None:
        """The table exported (`from`)."""
        return self.raw.get("from")


def read_export_marker(path: str | Path) -> ExportMarker:
    """export.json, typed; every file it names must be beside it (else
    ResultError naming the file and the missing one)."""
    m, where = _read_object(ExportMarker, path, "expected a JSON object")
    if "from" in m.raw and not isinstance(m.raw["from"], str):
        raise ResultError(f"{where} from: expected a string, got {_short(m.raw['from'])}")
    if not m.files:
        raise ResultError(f"{where} files: names no file")
    for i, name in enumerate(m.files):
        if "/" in name or "\\" in name or name in ("", ".", ".."):
            raise ResultError(f"{where} files[{i}]: {name!r} is not a file name")
        if not (m.path.parent / name).is_file():
            raise ResultError(f"{where} files[{i}]: {name} is not beside it (an incomplete set?)")
    return m
