"""Scenes: loaded from a file, from TOML text, or the embedded default;
overridden with the command line's options by their scene keys; with a
height map given as a numpy array."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from roks import _native
from roks._native import OptionError

# Scene.override's keywords of a micro scene and the `roks brdf` option each
# one is (the command line parses and checks the value, with its message).
MICRO_OPTIONS: dict[str, str] = {
    "photons": "--photons",
    "seed": "--seed",
    "theta_deg": "--theta",
    "phi_deg": "--phi",
    "wavelengths_um": "--wavelengths",
    "launch": "--launch",
    "symmetry": "--symmetry",
    "polarisation": "--polarisation",
    "polarised_transport": "--no-polarisation",
}

# Scene.override's keywords of an object scene, as `roks trace` options.
OBJECT_OPTIONS: dict[str, str] = {
    "photons": "--photons",
    "seed": "--seed",
    "wavelengths_um": "--wavelengths",
    "polarised_transport": "--no-polarisation",
}


def _value(x: Any) -> str:
    """One option value as the command line takes it: numbers exactly
    (repr of a float round-trips), lists comma-separated."""
    if isinstance(x, str):
        return x
    if isinstance(x, (bool, np.bool_)):
        raise TypeError("a boolean is not a number")
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if isinstance(x, (float, np.floating)):
        return repr(float(x))
    if isinstance(x, (list, tuple, np.ndarray)):
        return ",".join(_value(v) for v in np.asarray(x).ravel().tolist())
    raise TypeError(f"{type(x).__name__} is not a number, a list of numbers nor a string")


def _args(options: Mapping[str, Any], known: Mapping[str, str]) -> list[str]:
    """The command-line options of `options` (Scene.override's keywords)."""
    args: list[str] = []
    for key, value in options.items():
        flag = known.get(key)
        if flag is None:
            raise OptionError(
                f"{key}: not an option of this scene; the options are {', '.join(known)}"
            )
        if key == "polarised_transport":
            if value is False:
                args.append(flag)
            elif value is not True:
                raise OptionError(f"{key}: must be True or False, got {value!r}")
            continue
        try:
            args.append(f"{flag}={_value(value)}")
        except TypeError as e:
            raise OptionError(f"{key} ({flag}): {e}") from None
    return args


def _is_object_scene(path: Path) -> bool:
    """Whether the scene file at `path` is an object scene (`[[cells]]`);
    a file that cannot be read or parsed is left to the micro loader, which
    names what is wrong."""
    try:
        with open(path, "rb") as f:
            return "cells" in tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return False


class Scene:
    """A scene of roks, built and checked: a micro scene (`roks brdf`,
    `roks stats`) or an object scene (`roks trace`). Immutable:
    `override` and `with_height_map` return new scenes.

    Make one with `Scene.load(path)` (a file, or the embedded default scene
    with no argument) or `Scene.from_toml(text, base_dir)`."""

    __slots__ = ("_kind", "_path", "_text", "_base_dir", "_options", "_map", "_native")

    def __init__(self) -> None:  # pragma: no cover - use the constructors
        raise TypeError("use roks.Scene.load(path) or roks.Scene.from_toml(text)")

    @classmethod
    def _make(
        cls,
        kind: str,
        path: Path | None,
        text: str | None,
        base_dir: Path | None,
        options: dict[str, Any],
        height_map: tuple[np.ndarray, float] | None,
    ) -> "Scene":
        self = object.__new__(cls)
        self._kind = kind
        self._path = path
        self._text = text
        self._base_dir = base_dir
        self._options = dict(options)
        self._map = height_map
        if kind == "object":
            self._native = _native.ObjectScene.load(str(path), _args(options, OBJECT_OPTIONS))
        else:
            kw: dict[str, Any] = {}
            if height_map is not None:
                heights, pixel = height_map
                kw = dict(
                    heights=heights.astype("<f8", copy=False).tobytes(),
                    ny=heights.shape[0],
                    nx=heights.shape[1],
                    pixel=pixel,
                )
            self._native = _native.MicroScene.load(
                path=None if path is None else str(path),
                text=text,
                base_dir=None if base_dir is None else str(base_dir),
                args=_args(options, MICRO_OPTIONS),
                **kw,
            )
        return self

    @classmethod
    def load(cls, path: str | os.PathLike[str] | None = None) -> "Scene":
        """The scene file at `path` (TOML; a micro scene or an object scene),
        or the embedded default micro scene when `path` is None.

        Raises `roks.SceneError` naming the file and the key for a scene
        that is not valid."""
        if path is None:
            return cls._make("micro", None, None, None, {}, None)
        p = Path(path)
        kind = "object" if _is_object_scene(p) else "micro"
        return cls._make(kind, p, None, None, {}, None)

    @classmethod
    def from_toml(cls, text: str, base_dir: str | os.PathLike[str] | None = None) -> "Scene":
        """The micro scene of the TOML `text`. Files it names (n, k tables,
        height maps) are relative to `base_dir` (default: the working
        folder). Messages name the scene `<scene text>`; without a `name`
        key it is named `scene`."""
        base = None if base_dir is None else Path(base_dir)
        return cls._make("micro", None, text, base, {}, None)

    def override(self, **options: Any) -> "Scene":
        """A new scene with the command line's options laid over its keys,
        by their scene keys: for a micro scene `photons`, `seed`,
        `theta_deg`, `phi_deg` (a number or a list), `wavelengths_um` (a
        list, or "FROM:TO:STEP"), `launch` ("random", "lattice"), `symmetry`
        ("none", "mirror"), `polarisation` (the tally: "none", "stokes",
        "mueller"), `polarised_transport` (False: the unpolarised
        approximation); for an object scene `photons`, `seed`,
        `wavelengths_um`, `polarised_transport`. Each value is checked as
        the option and the key it replaces are, through the same overrides
        as `roks brdf` / `roks trace`: `roks.OptionError` names the option
        (`--theta: ...`) or the key."""
        return Scene._make(
            self._kind, self._path, self._text, self._base_dir,
            {**self._options, **options}, self._map,
        )

    def with_height_map(self, heights: Any, pixel: float) -> "Scene":
        """A new micro scene whose surface is the height field `heights`, a
        2-D array of shape (ny, nx) (length units; row j at y = j pixel,
        column i at x = i pixel, as a height-map file is read), with grid
        pitch `pixel`: exactly `[surface] heightfield = { file = ...,
        pixel = ... }` with the array in place of the file, replacing the
        scene's own height field and checked as that key is (at least 2 x 2
        finite heights, the cell against `[surface] size`, no bumps, bodies
        or quadrics beside it). Messages name the array `<height map
        array>`."""
        if self._kind != "micro":
            raise OptionError("with_height_map: an object scene has no micro surface")
        a = np.array(heights, dtype=np.float64, copy=True)
        if a.ndim != 2:
            raise OptionError(f"with_height_map: a 2-D array of heights, got {a.ndim} dimensions")
        return Scene._make(
            "micro", self._path, self._text, self._base_dir, self._options, (a, float(pixel))
        )

    @property
    def name(self) -> str:
        """The scene's name (its `name` key, else the file's stem)."""
        return self._native.name

    @property
    def file(self) -> str:
        """The scene file as messages name it (`<default scene>`,
        `<scene text>` for the other sources)."""
        return self._native.file

    @property
    def is_object(self) -> bool:
        """Whether this is an object scene (for `roks.trace`)."""
        return self._kind == "object"

    @property
    def options(self) -> dict[str, Any]:
        """The overrides laid over the scene's keys (Scene.override's)."""
        return dict(self._options)

    def __repr__(self) -> str:
        kind = "object scene" if self.is_object else "micro scene"
        extra = f", options={self._options!r}" if self._options else ""
        return f"<roks.Scene {self.name!r}: {kind} {self.file}{extra}>"
