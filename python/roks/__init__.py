"""roks in Python: trace rough surfaces (micro scenes: BRDF tables) and
rough 3-D objects (object scenes) in this process, numpy in and out.

    import roks
    scene = roks.Scene.load().override(photons=4096, theta_deg=[30, 60])
    result = roks.brdf(scene)            # a BrdfResult, numpy arrays
    result.reflectance                   # (incidences, azimuths, wavelengths)
    result.select(theta_deg=30).brdf     # one incidence, per Carlson cell
    result.write("out/default")          # the folder `roks brdf` writes

The `roks` command installed with this package is the command line of the
Rust binary, run by the same code. Bad input raises `roks.RoksError` (or a
subclass: SceneError, InputError, OptionError, OutputError) with the
command line's one-line message naming the file and the key. Runs release
the GIL; Ctrl-C (KeyboardInterrupt) stops a run within a fraction of a
second, writing nothing."""

from __future__ import annotations

import json
from typing import Any

from roks import _native
from roks._native import (
    InputError,
    OptionError,
    OutputError,
    RoksError,
    SceneError,
    __version__,
)
from roks._progress import progress_bar
from roks._results import (
    BrdfResult,
    Cells,
    Description,
    Export,
    ExportCheck,
    ModelFit,
    Polarisation,
    Run,
    Selection,
    SelectionError,
    TraceResult,
    load,
)
from roks._scene import Scene

__all__ = [
    "BrdfResult",
    "Cells",
    "Description",
    "Export",
    "ExportCheck",
    "ModelFit",
    "InputError",
    "OptionError",
    "OutputError",
    "Polarisation",
    "RoksError",
    "Run",
    "Scene",
    "SceneError",
    "Selection",
    "SelectionError",
    "TraceResult",
    "__version__",
    "brdf",
    "load",
    "stats",
    "trace",
]


def _run(native_call, scene: Scene, progress: bool, **kw: Any):  # type: ignore[no-untyped-def]
    bar = progress_bar(progress, scene.name)
    try:
        return native_call(progress=bar, **kw)
    finally:
        if bar is not None:
            bar.close()


def brdf(
    scene: Scene,
    threads: int | None = None,
    progress: bool = False,
    stats_resolution: int | None = None,
) -> BrdfResult:
    """Trace the BRDF of the micro scene `scene` (as `roks brdf`) on
    `threads` worker threads (None: all cores; results do not depend on
    it), with a progress bar when `progress`. `stats_resolution` is
    `--stats-resolution` (the surface statistics' grid, default 512).
    Releases the GIL; KeyboardInterrupt stops the run."""
    if scene.is_object:
        raise OptionError(f"{scene.file}: an object scene: roks.trace traces it; roks.brdf takes micro scenes")
    native = _run(
        scene._native.brdf, scene, progress, threads=threads, stats_resolution=stats_resolution
    )
    return BrdfResult(native)


def trace(scene: Scene, threads: int | None = None, progress: bool = False) -> TraceResult:
    """Trace the object scene `scene` (as `roks trace`) on `threads`
    worker threads, with a progress bar when `progress`. Releases the GIL;
    KeyboardInterrupt stops the run."""
    if not scene.is_object:
        raise OptionError(f"{scene.file}: a micro scene: roks.brdf traces it; roks.trace takes object scenes")
    return TraceResult(_run(scene._native.trace, scene, progress, threads=threads))


def stats(scene: Scene, resolution: int | None = None) -> dict[str, Any]:
    """The surface statistics of the micro scene `scene` (as `roks stats
    --json`) on a `resolution` x `resolution` height map (default 512; a
    height field: its own grid): sigma, tau, rms_slope, heights."""
    if scene.is_object:
        raise OptionError(f"{scene.file}: an object scene has no micro surface")
    return json.loads(scene._native.stats_json(resolution))
