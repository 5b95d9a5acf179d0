"""Results as numpy: one type per kind of run, traced in this process or
read back from a result folder, with the axes of the result tree."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from roks import _native
from roks._native import InputError


class SelectionError(InputError, ValueError):
    """A value asked of `select` that the run does not have (or an axis of
    several values left unnamed)."""


@dataclasses.dataclass(frozen=True)
class Polarisation:
    """The polarisation of a micro run (`run.polarisation` of summary.json)."""

    incident: Any
    """The incident state ("unpolarised", ...)."""
    tally: str
    """The polarisation tally: "none", "stokes" or "mueller"."""
    transport: bool
    """Whether Stokes vectors were carried through every bounce."""


@dataclasses.dataclass(frozen=True)
class Run:
    """The run of a micro scene as described in its summary.json."""

    theta_deg: tuple[float, ...]
    """Incidence angles (degrees from the normal): axis 0."""
    phi_deg: tuple[float, ...]
    """Light azimuths (degrees): axis 1."""
    wavelengths_um: tuple[float, ...]
    """Wavelengths (µm): axis 2; empty for a monochrome run (axis of 1)."""
    photons_per_incidence: int
    seed: int
    launch: str
    symmetry: str
    bands: int
    """Carlson bands of the grid: 2 M (M + 1) cells."""
    inplane_step_deg: float
    inplane_width_deg: float
    polarisation: Polarisation
    shard: Any
    controls: dict[str, Any]


@dataclasses.dataclass(frozen=True)
class Description:
    """What was run: the scene, its content hashes, the run, the surface's
    statistics and the roks version (summary.json without the figures)."""

    name: str
    scene: str
    """The scene file as given (`<default scene>`, `<scene text>`)."""
    version: str
    edges: str
    run: Run
    surface: dict[str, Any]
    """The surface statistics (sigma, tau, rms_slope, ...)."""
    content: dict[str, Any]
    """SHA-256 of the scene text and of each file it reads."""
    seconds: float
    """Wall-clock time of the run."""


def _axis(v: Any) -> tuple[float, ...]:
    """An axis of summary.json's run: a list, or one number (one light
    azimuth is written as a number), or absent."""
    if v is None:
        return ()
    return tuple(float(x) for x in np.atleast_1d(np.asarray(v, dtype=float)))


def _description(summary: dict[str, Any]) -> Description:
    r = dict(summary["run"])
    pol = r.pop("polarisation")
    run = Run(
        theta_deg=_axis(r["theta_deg"]),
        phi_deg=_axis(r["phi_deg"]),
        wavelengths_um=_axis(r.get("wavelengths_um")),
        photons_per_incidence=r["photons_per_incidence"],
        seed=r["seed"],
        launch=r["launch"],
        symmetry=r["symmetry"],
        bands=r["bands"],
        inplane_step_deg=r["inplane_step_deg"],
        inplane_width_deg=r["inplane_width_deg"],
        polarisation=Polarisation(pol["incident"], pol["tally"], pol["transport"]),
        shard=r.get("shard"),
        controls=r.get("controls", {}),
    )
    return Description(
        name=summary["name"],
        scene=summary["scene"],
        version=summary["version"],
        edges=summary["edges"],
        run=run,
        surface=summary["surface"],
        content=summary["content"],
        seconds=summary["seconds"],
    )


def _columns(native: Any, name: str) -> dict[str, np.ndarray] | None:
    t = native.table(name)
    if t is None:
        return None
    names, values = t
    return {n: np.frombuffer(v, dtype="<f8") for n, v in zip(names, values)}


@dataclasses.dataclass(frozen=True)
class Cells:
    """The Carlson cells of the run's grid (the last axis of `brdf`),
    centres and bounds in degrees, solid angles in sr."""

    band: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    theta_lo_deg: np.ndarray
    theta_hi_deg: np.ndarray
    phi_lo_deg: np.ndarray
    phi_hi_deg: np.ndarray
    solid_angle_sr: np.ndarray
    projected_solid_angle_sr: np.ndarray


@dataclasses.dataclass(frozen=True)
class Selection:
    """One incidence, azimuth and wavelength of a BRDF result
    (`BrdfResult.select`)."""

    theta_deg: float
    phi_deg: float
    wavelength_um: float | None
    reflectance: float
    reflectance_stderr: float
    brdf: np.ndarray
    """BRDF per cell (1/sr), shape (cells,)."""
    brdf_stderr: np.ndarray
    cells: Cells
    inplane_theta_deg: np.ndarray
    inplane: np.ndarray
    inplane_stderr: np.ndarray
    mueller: np.ndarray | None
    """(cells, 4, 4) when tallied."""
    stokes: np.ndarray | None
    """(cells, 4) when tallied."""


@dataclasses.dataclass(frozen=True)
class ExportCheck:
    """The read-back check of one exported file at one incidence: the
    file's reflectance beside the table's (and the table's standard
    error)."""

    what: str
    """The format, with the wavelength or channel (`zemax (0.55 um)`)."""
    theta_i_deg: float
    phi_i_deg: float | None
    table: float
    file: float
    table_stderr: float

    @property
    def sigmas(self) -> float:
        """|file - table| in standard errors of the table."""
        d = abs(self.file - self.table)
        return d / self.table_stderr if self.table_stderr > 0 else (0.0 if d == 0 else float("inf"))


@dataclasses.dataclass(frozen=True)
class Export:
    """An export of a BRDF table (`BrdfResult.export`)."""

    format: str
    files: dict[str, bytes]
    """The files, by their names beside brdf.csv."""
    checks: list[ExportCheck]
    notices: list[str]
    """The notes and warnings the command line prints."""


@dataclasses.dataclass(frozen=True)
class ModelFit:
    """A model fitted to a BRDF table (`BrdfResult.fit_model`)."""

    model: str
    results: dict[str, Any]
    """The JSON documents `roks fit-model` writes, by file name
    (`fit_abg.json`: parameters, the verdict, warnings; `fit_summary.json`
    for "all")."""
    lines: list[str]
    """The lines the command line prints: warnings, then the verdict."""
    files: dict[str, bytes]
    """Every file `roks fit-model` would write (JSON, plot, OpticStudio text)."""


class BrdfResult:
    """The result of a BRDF run of a micro scene (`roks.brdf`), or read
    back from its folder (`roks.load`): the same arrays either way.

    Arrays have the axes of the result tree: incidence (`theta_deg`) x
    light azimuth (`phi_deg`) x wavelength (`wavelengths_um`; one entry for
    a monochrome run) x Carlson cell (`cells`)."""

    def __init__(self, native: Any) -> None:
        self._native = native
        self._cache: dict[str, Any] = {}

    # -- the run ---------------------------------------------------------
    @property
    def summary(self) -> dict[str, Any]:
        """summary.json, parsed."""
        if "summary" not in self._cache:
            self._cache["summary"] = json.loads(self._native.file("summary.json"))
        return self._cache["summary"]

    @property
    def description(self) -> Description:
        """The run description (typed)."""
        return _description(self.summary)

    @property
    def theta_deg(self) -> np.ndarray:
        """Axis 0: the incidence angles (degrees)."""
        return np.array(_axis(self.summary["run"]["theta_deg"]))

    @property
    def phi_deg(self) -> np.ndarray:
        """Axis 1: the light azimuths (degrees)."""
        return np.array(_axis(self.summary["run"]["phi_deg"]))

    @property
    def wavelengths_um(self) -> np.ndarray:
        """Axis 2: the wavelengths (µm); empty for a monochrome run, whose
        axis 2 has one entry."""
        return np.array(_axis(self.summary["run"].get("wavelengths_um")))

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(incidences, azimuths, wavelengths or 1, cells)."""
        return tuple(self._native.shape)

    @property
    def traced(self) -> bool:
        """Whether this result was traced in this process (not loaded)."""
        return self._native.traced

    # -- reflectance -----------------------------------------------------
    def _reflectance(self, key: str) -> np.ndarray:
        t, p, l, _ = self.shape
        out = np.empty((t, p, l))
        for k, inc in enumerate(self.summary["incidence"]):
            lanes = inc.get("spectrum") or [inc]
            out[k // p, k % p, :] = [s[key] for s in lanes]
        return out

    @property
    def reflectance(self) -> np.ndarray:
        """Directional-hemispherical reflectance, (incidences, azimuths,
        wavelengths)."""
        return self._reflectance("reflectance")

    @property
    def reflectance_stderr(self) -> np.ndarray:
        """Standard errors of `reflectance`."""
        return self._reflectance("reflectance_stderr")

    @property
    def realisations(self) -> list[dict[str, Any] | None]:
        """Per incidence and azimuth (tree order), the figures of the
        surface realisations (`[surface] realisations = R > 1`: each one's
        reflectance, their spread), None for a single realisation."""
        return [inc.get("realisations") for inc in self.summary["incidence"]]

    # -- tables ----------------------------------------------------------
    def _table(self, name: str) -> dict[str, np.ndarray] | None:
        if name not in self._cache:
            self._cache[name] = _columns(self._native, name)
        return self._cache[name]

    def _tree(self, values: np.ndarray) -> np.ndarray:
        return values.reshape(self.shape)

    @property
    def brdf(self) -> np.ndarray:
        """The BRDF per Carlson cell (1/sr), (incidences, azimuths,
        wavelengths, cells)."""
        return self._tree(self._table("brdf.csv")["brdf"])

    @property
    def brdf_stderr(self) -> np.ndarray:
        """Standard errors of `brdf`."""
        return self._tree(self._table("brdf.csv")["brdf_stderr"])

    @property
    def fraction(self) -> np.ndarray:
        """The fraction of the incident power reflected into each cell."""
        return self._tree(self._table("brdf.csv")["fraction"])

    @property
    def cells(self) -> Cells:
        """The cells' centres, bounds and solid angles."""
        t = self._table("brdf.csv")
        n = self.shape[3]
        return Cells(**{f.name: t[f.name][:n].copy() for f in dataclasses.fields(Cells)})

    @property
    def inplane_theta_deg(self) -> np.ndarray:
        """The in-plane BRDF's signed exit angles (degrees; negative:
        towards the source)."""
        t = self._table("inplane.csv")
        a, b, c, _ = self.shape
        return t["theta_o_deg"][: t["theta_o_deg"].size // (a * b * c)].copy()

    def _inplane(self, col: str) -> np.ndarray:
        a, b, c, _ = self.shape
        return self._table("inplane.csv")[col].reshape(a, b, c, -1)

    @property
    def inplane(self) -> np.ndarray:
        """The BRDF in the plane of incidence, (incidences, azimuths,
        wavelengths, `inplane_theta_deg`)."""
        return self._inplane("brdf")

    @property
    def inplane_stderr(self) -> np.ndarray:
        """Standard errors of `inplane`."""
        return self._inplane("brdf_stderr")

    def _matrix(self, name: str, prefix: str, n: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray] | None:
        t = self._table(name)
        if t is None:
            return None
        idx = [f"{prefix}{i}{j}" for i in range(4) for j in range(4)] if len(n) == 2 else [
            f"{prefix}{i}" for i in range(4)
        ]
        v = np.stack([t[k] for k in idx], axis=-1).reshape(*self.shape, *n)
        e = np.stack([t[k + "_stderr"] for k in idx], axis=-1).reshape(*self.shape, *n)
        return v, e

    @property
    def mueller(self) -> np.ndarray | None:
        """The Mueller-matrix BRDF per cell, (incidences, azimuths,
        wavelengths, cells, 4, 4); None unless tallied (`polarisation =
        "mueller"`)."""
        m = self._matrix("mueller.csv", "m", (4, 4))
        return None if m is None else m[0]

    @property
    def mueller_stderr(self) -> np.ndarray | None:
        """Standard errors of `mueller`."""
        m = self._matrix("mueller.csv", "m", (4, 4))
        return None if m is None else m[1]

    @property
    def stokes(self) -> np.ndarray | None:
        """The Stokes BRDF per cell for the incident state, (incidences,
        azimuths, wavelengths, cells, 4); None unless tallied."""
        m = self._matrix("stokes.csv", "s", (4,))
        return None if m is None else m[0]

    @property
    def stokes_stderr(self) -> np.ndarray | None:
        """Standard errors of `stokes`."""
        m = self._matrix("stokes.csv", "s", (4,))
        return None if m is None else m[1]

    # -- selection -------------------------------------------------------
    def _index(self, axis: str, values: np.ndarray, wanted: float | None) -> int:
        if len(values) == 0:
            if wanted is not None:
                raise SelectionError(f"{axis}: the run is monochrome, it has no wavelengths")
            return 0
        if wanted is None:
            if len(values) == 1:
                return 0
            raise SelectionError(
                f"{axis}: the run has {len(values)} values ({', '.join(f'{v:g}' for v in values)}): name one"
            )
        hits = np.flatnonzero(np.isclose(values, float(wanted), rtol=0, atol=1e-9))
        if hits.size == 0:
            raise SelectionError(
                f"{axis}: {wanted:g} is not in the run ({', '.join(f'{v:g}' for v in values)})"
            )
        return int(hits[0])

    def select(
        self,
        theta_deg: float | None = None,
        phi_deg: float | None = None,
        wavelength_um: float | None = None,
    ) -> Selection:
        """One incidence, light azimuth and wavelength, by value. An axis
        of one value may be left out; an axis of several must be named, and
        a value not in the run raises `roks.SelectionError` (never a mix of
        azimuths)."""
        i = self._index("theta_deg", self.theta_deg, theta_deg)
        j = self._index("phi_deg", self.phi_deg, phi_deg)
        k = self._index("wavelength_um", self.wavelengths_um, wavelength_um)
        wl = self.wavelengths_um
        mu, st = self.mueller, self.stokes
        return Selection(
            theta_deg=float(self.theta_deg[i]),
            phi_deg=float(self.phi_deg[j]),
            wavelength_um=float(wl[k]) if len(wl) else None,
            reflectance=float(self.reflectance[i, j, k]),
            reflectance_stderr=float(self.reflectance_stderr[i, j, k]),
            brdf=self.brdf[i, j, k].copy(),
            brdf_stderr=self.brdf_stderr[i, j, k].copy(),
            cells=self.cells,
            inplane_theta_deg=self.inplane_theta_deg,
            inplane=self.inplane[i, j, k].copy(),
            inplane_stderr=self.inplane_stderr[i, j, k].copy(),
            mueller=None if mu is None else mu[i, j, k].copy(),
            stokes=None if st is None else st[i, j, k].copy(),
        )

    # -- exports and fits ------------------------------------------------
    def export(
        self,
        format: str,
        path: str | os.PathLike[str] | None = None,
        force: bool = False,
        grid: str | None = None,
        rgb: bool = False,
    ) -> "Export":
        """The table exported in `format` ("zemax", "merl", "rgl",
        "pbsdf"; as `roks brdf --export` for a traced result, `roks
        export-brdf` for a loaded one), each file read back by its reader
        and its reflectance checked against the table's. Written to `path`
        when given (one file, or a folder of per-wavelength files), after
        the checks of `--out`. `grid` is `--grid` (Zemax), `rgb` `--rgb`
        (RGL). Raises roks.InputError when the format cannot hold the
        table."""
        args: list[str] = []
        if grid is not None:
            args += ["--grid", grid]
        if rgb:
            args.append("--rgb")
        files, checks, notices = self._native.export(
            format, None if path is None else str(path), force, args
        )
        return Export(
            format=format,
            files=dict(files),
            checks=[ExportCheck(*c) for c in checks],
            notices=list(notices),
        )

    def fit_model(
        self,
        model: str,
        n: float | None = None,
        k: float | None = None,
        reflectance: float | None = None,
        wavelength_um: float | None = None,
    ) -> "ModelFit":
        """An analytic BRDF model fitted to the table, as `roks fit-model
        --model MODEL` fits it ("abg", "harvey", "ggx", ... or "all"),
        writing nothing: the fitted parameters, the fit's verdict and its
        warnings as values. `n`, `k`, `reflectance`, `wavelength_um` are
        its options `--n`, `--k`, `--reflectance`, `--wavelength`. A
        traced result is fitted from its `brdf.csv` and `summary.json` as
        values: its JSON's `table` is `brdf.csv`, OpticStudio's rows are
        named `roks`."""
        args: list[str] = []
        for flag, v in (("--n", n), ("--k", k), ("--reflectance", reflectance),
                        ("--wavelength", wavelength_um)):
            if v is not None:
                args.append(f"{flag}={float(v)!r}")
        files, lines = self._native.fit_model(model, args)
        files = dict(files)
        docs = {name: json.loads(b) for name, b in files.items() if name.endswith(".json")}
        # Nothing was written: the command line's `wrote ...` line goes.
        lines = [line for line in lines if not line.startswith("wrote ")]
        return ModelFit(model=model, results=docs, lines=lines, files=files)

    # -- files -----------------------------------------------------------
    def file(self, name: str) -> bytes | None:
        """The result folder's file `name` as roks writes it, or None."""
        return self._native.file(name)

    def files(self) -> dict[str, bytes]:
        """Every file of the result folder, by name, as `write` writes them
        (a traced result draws its pictures)."""
        return dict(self._native.files())

    def write(self, dir: str | os.PathLike[str], force: bool = False) -> Path:
        """Write the result folder `dir` as `roks brdf` writes it, byte for
        byte: replaced whole, never half-written; `force` replaces a folder
        holding files roks did not write. Raises `roks.OutputError`."""
        self._native.write(str(dir), force)
        return Path(dir)

    def __repr__(self) -> str:
        d = self.summary
        how = "traced" if self.traced else "loaded"
        return f"<roks.BrdfResult {d['name']!r} ({how}): shape {self.shape}>"


class TraceResult:
    """The result of a trace of an object scene (`roks.trace`), or read
    back from its folder (`roks.load`)."""

    def __init__(self, native: Any) -> None:
        self._native = native
        self._cache: dict[str, Any] = {}

    @property
    def summary(self) -> dict[str, Any]:
        """summary.json, parsed: per source and beam position the
        reflectance, absorption, losses."""
        if "summary" not in self._cache:
            self._cache["summary"] = json.loads(self._native.file("summary.json"))
        return self._cache["summary"]

    @property
    def traced(self) -> bool:
        """Whether this result was traced in this process (not loaded)."""
        return self._native.traced

    def table(self, name: str) -> dict[str, np.ndarray] | None:
        """The CSV file `name` of the folder (`reflectance.csv`,
        `farfield.csv`, ...) as columns, None when it has none."""
        if name not in self._cache:
            self._cache[name] = _columns(self._native, name)
        return self._cache[name]

    @property
    def reflectance(self) -> dict[str, np.ndarray]:
        """reflectance.csv as columns (one row per beam position, and
        wavelength)."""
        return self.table("reflectance.csv")

    @property
    def farfield(self) -> dict[str, np.ndarray] | None:
        """farfield.csv as columns, None unless tallied."""
        return self.table("farfield.csv")

    def file(self, name: str) -> bytes | None:
        """The result folder's file `name`, or None."""
        return self._native.file(name)

    def files(self) -> dict[str, bytes]:
        """Every file of the result folder, by name."""
        return dict(self._native.files())

    def write(self, dir: str | os.PathLike[str], force: bool = False) -> Path:
        """Write the result folder `dir` as `roks trace` writes it, byte
        for byte. Raises `roks.OutputError`."""
        self._native.write(str(dir), force)
        return Path(dir)

    def __repr__(self) -> str:
        how = "traced" if self.traced else "loaded"
        return f"<roks.TraceResult {self.summary['name']!r} ({how})>"


def load(dir: str | os.PathLike[str]) -> BrdfResult | TraceResult:
    """Read back any result folder (`roks brdf`, `roks merge`, `roks
    trace`) into the result type a run in this process gives."""
    d = str(dir)
    if _native.is_trace_folder(d):
        return TraceResult(_native.TraceResult.read(d))
    return BrdfResult(_native.BrdfResult.read(d))
