"""Type stubs of roks._native, the compiled core of the package roks (its
Rust source: python/src/lib.rs). Use the package `roks`, which wraps it
with numpy."""

from typing import Callable, Optional, final

__all__ = [
    "__version__",
    "RoksError",
    "SceneError",
    "InputError",
    "OptionError",
    "OutputError",
    "MicroScene",
    "ObjectScene",
    "BrdfResult",
    "TraceResult",
    "main",
    "is_trace_folder",
]

__version__: str

class RoksError(Exception):
    """Any error of roks: the command line's one-line message."""

class SceneError(RoksError):
    """A scene file (or scene text): the message names the file and the key."""

class InputError(RoksError):
    """Bad input other than a scene key."""

class OptionError(InputError):
    """An option (a keyword of Scene.override, or of a run) refused."""

class OutputError(RoksError):
    """An output that cannot be written where asked."""

_Progress = Optional[Callable[[int, int], None]]

@final
class MicroScene:
    @staticmethod
    def load(
        path: Optional[str] = None,
        text: Optional[str] = None,
        base_dir: Optional[str] = None,
        args: list[str] = ...,
        heights: Optional[bytes] = None,
        nx: int = 0,
        ny: int = 0,
        pixel: float = 0.0,
    ) -> MicroScene: ...
    @property
    def name(self) -> str: ...
    @property
    def file(self) -> str: ...
    def stats_json(self, resolution: Optional[int] = None) -> str: ...
    def brdf(
        self,
        threads: Optional[int] = None,
        stats_resolution: Optional[int] = None,
        progress: _Progress = None,
    ) -> BrdfResult: ...

@final
class ObjectScene:
    @staticmethod
    def load(path: str, args: list[str] = ...) -> ObjectScene: ...
    @property
    def name(self) -> str: ...
    @property
    def file(self) -> str: ...
    def trace(self, threads: Optional[int] = None, progress: _Progress = None) -> TraceResult: ...

@final
class BrdfResult:
    @staticmethod
    def read(dir: str) -> BrdfResult: ...
    def file(self, name: str) -> Optional[bytes]: ...
    def table(self, name: str) -> Optional[tuple[list[str], list[bytes]]]: ...
    @property
    def shape(self) -> tuple[int, int, int, int]: ...
    @property
    def traced(self) -> bool: ...
    def files(self) -> list[tuple[str, bytes]]: ...
    def write(self, out: str, force: bool = False) -> None: ...
    def export(
        self, format: str, out: Optional[str] = None, force: bool = False, args: list[str] = ...
    ) -> tuple[
        list[tuple[str, bytes]],
        list[tuple[str, float, Optional[float], float, float, float]],
        list[str],
    ]: ...
    def fit_model(
        self, model: str, args: list[str] = ...
    ) -> tuple[list[tuple[str, bytes]], list[str]]: ...

@final
class TraceResult:
    @staticmethod
    def read(dir: str) -> TraceResult: ...
    def file(self, name: str) -> Optional[bytes]: ...
    def table(self, name: str) -> Optional[tuple[list[str], list[bytes]]]: ...
    @property
    def traced(self) -> bool: ...
    def files(self) -> list[tuple[str, bytes]]: ...
    def write(self, out: str, force: bool = False) -> None: ...

def main(argv: list[str]) -> int: ...
def is_trace_folder(dir: str) -> bool: ...
