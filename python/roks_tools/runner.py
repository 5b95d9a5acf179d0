"""Running roks (and other programs) from the studies and tests: one `run`.

`run` starts a command, waits for it and returns a `Completed` with its
output, wall-clock and CPU seconds and peak resident memory. The memory is
read by GNU `/usr/bin/time -f %M` where it exists: Linux counts the memory a
process held before `exec` in its peak, and Python starts children by
(v)fork, so `os.wait4` on a child of this process reports at least this
process's own peak (about 29 MB with numpy loaded, more than a small roks
run needs). Without `/usr/bin/time` the `os.wait4` figure is used, with that
floor.
On failure it raises `RunError` (roks_tools.errors) naming the caller
(`who`), the command and the last line of its stderr, after writing the
command's output to stderr; the tools' `main` functions turn it into a
one-line message and exit status 1.

`add_out_argument` / `check_output` give the studies their `--out`: a folder
named after the study in the current folder by default, never one holding
files committed to git unless `--overwrite-committed` (regenerating results/).

`roks_binary()` finds roks: `$ROKS_BIN`, then `roks` on PATH (`cargo install
--path .`), then the repository's release build (`target/release/roks`);
`BinaryNotFound` says which places were tried. `repo_root()` finds the
repository (the checkout holding this package, else the current folder or
one above it with Cargo.toml and scenes/).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from .errors import BinaryNotFound, RunError, UsageError, show


@dataclass(frozen=True)
class Completed:
    """A finished command: its output and what it cost."""

    cmd: list[str]
    returncode: int
    stdout: str
    stderr: str
    wall_s: float
    """Wall-clock seconds from start to exit."""
    cpu_s: float
    """User + system CPU seconds of the child (less sensitive to other load than the wall clock)."""
    max_rss_mb: float
    """Peak resident set size of the child in MiB (Linux reports KiB): the
    command's own when `/usr/bin/time` exists, else bounded below by this
    process's peak (see the module's doc)."""


_GNU_TIME = "/usr/bin/time"


def _peak_memory_wrapper(path: str) -> list[str]:
    """The prefix that makes GNU time write the command's peak RSS (KiB) to `path`,
    or [] when GNU time is not installed."""
    if os.access(_GNU_TIME, os.X_OK) and shutil.which(_GNU_TIME):
        return [_GNU_TIME, "-f", "%M", "-o", path]
    return []


def _is_repo(p: Path) -> bool:
    return (p / "Cargo.toml").is_file() and (p / "scenes").is_dir()


def find_repo() -> Path | None:
    """The roks repository: the checkout holding this package (an editable
    install), else the current folder or the nearest folder above it with
    Cargo.toml and scenes/; None outside one."""
    here = Path(__file__).resolve().parents[2]
    if _is_repo(here):
        return here
    cwd = Path.cwd().resolve()
    return next((p for p in (cwd, *cwd.parents) if _is_repo(p)), None)


def repo_root() -> Path:
    """`find_repo()`, or the current folder outside a checkout."""
    return find_repo() or Path.cwd()


def _executable(p: Path) -> bool:
    return p.is_file() and os.access(p, os.X_OK)


def roks_binary() -> Path:
    """The roks binary: `$ROKS_BIN` if set (it must exist), else `roks` on
    PATH, else the repository's `target/release/roks`; BinaryNotFound
    naming the places tried."""
    env = os.environ.get("ROKS_BIN")
    if env:
        if not _executable(Path(env)):
            raise BinaryNotFound(f"ROKS_BIN={show(env)}: no executable file there")
        return Path(env)
    on_path = shutil.which("roks")
    if on_path:
        return Path(on_path)
    repo = find_repo()
    build = repo / "target" / "release" / "roks" if repo else None
    if build is not None and _executable(build):
        return build
    tried = "ROKS_BIN unset, no roks on PATH, " + (
        f"no {show(build)} (cargo build --release)" if build else "not in a roks checkout")
    raise BinaryNotFound(f"no roks binary: {tried}; install it with `cargo install --path .` "
                         f"or set ROKS_BIN")


def default_roks() -> Path:
    """The `--roks` default of the studies: `roks_binary()`, or `roks` when
    none is found (running it then raises the BinaryNotFound of `run`)."""
    try:
        return roks_binary()
    except BinaryNotFound:
        return Path("roks")


def run(cmd: list, who: str, echo: bool = True, cwd: Path | None = None,
        check: bool = True) -> Completed:
    """Run `cmd` (items converted to str) and wait for it.

    `echo` prints the command (prefixed `+ `) to stderr first. A command
    that cannot be started raises RunError. With `check` (the default) a
    non-zero exit writes the command's stdout and stderr to stderr and
    raises RunError naming `who`, the command and its last stderr line.
    """
    cmd = [str(c) for c in cmd]
    if echo:
        print("+ " + " ".join(cmd), file=sys.stderr, flush=True)
    if shutil.which(cmd[0], path=None if os.sep not in cmd[0] else "") is None \
            and not (Path(cwd or ".") / cmd[0]).exists():
        if cmd[0] == "roks":
            roks_binary()  # raises BinaryNotFound saying where it looked
        raise RunError(f"{who}: cannot run {show(cmd[0])}: not found")
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err, \
            tempfile.TemporaryDirectory() as tmp:
        peak_file = str(Path(tmp) / "peak_kib")
        wrapper = _peak_memory_wrapper(peak_file)
        t0 = time.perf_counter()
        try:
            p = subprocess.Popen(wrapper + cmd, cwd=cwd, stdout=out, stderr=err, text=True)
        except OSError as e:
            raise RunError(f"{who}: cannot run {show(cmd[0])}: {e.strerror or e}") from None
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        peak_kib = usage.ru_maxrss
        if wrapper:
            # GNU time writes "Command exited with non-zero status N" before
            # the figure when the command fails; the figure is the last line.
            lines = Path(peak_file).read_text().split() if Path(peak_file).exists() else []
            if lines and lines[-1].isdigit():
                peak_kib = int(lines[-1])
        out.seek(0)
        err.seek(0)
        done = Completed(cmd, p.returncode, out.read(), err.read(), wall,
                         usage.ru_utime + usage.ru_stime, peak_kib / 1024)
    if check and done.returncode != 0:
        sys.stderr.write(done.stdout + done.stderr)
        last = (done.stderr.strip().splitlines() or [""])[-1]
        raise RunError(f"{who}: failed (exit {done.returncode}): {show(' '.join(cmd))}"
                       + (f": {show(last)}" if last else ""))
    return done


def committed_files(folder: Path) -> list[str]:
    """The files under `folder` that git tracks (none when it does not exist,
    is outside a git work tree, or git is not installed)."""
    folder = Path(folder)
    if not folder.exists() or shutil.which("git") is None:
        return []
    where = folder if folder.is_dir() else folder.parent
    try:
        p = subprocess.run(["git", "-C", str(where), "ls-files", "-z", "--", str(folder.resolve())],
                           capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return []
    if p.returncode != 0:
        return []
    return [f for f in p.stdout.decode("utf-8", "replace").split("\0") if f]


def add_out_argument(ap, name: str) -> None:
    """`--out` (default: ./NAME, a folder in the current folder) and
    `--overwrite-committed` of a study's argument parser; call
    `check_output(a.out, a.overwrite_committed)` after parsing."""
    ap.add_argument("--out", type=Path, default=Path(name),
                    help=f"output folder (default: ./{name}); one holding files committed to git is refused "
                         "unless --overwrite-committed")
    ap.add_argument("--overwrite-committed", action="store_true",
                    help="let --out replace files committed to git (regenerating the repository's results/)")


def check_output(out: Path, overwrite_committed: bool = False) -> None:
    """UsageError, before any work, when `out` holds files committed to git
    (e.g. the repository's results/) and `overwrite_committed` is not set."""
    if overwrite_committed:
        return
    files = committed_files(out)
    if files:
        raise UsageError(f"--out {show(out)}: holds {len(files)} file(s) committed to git (e.g. {show(files[0])}); "
                         "give another folder, or --overwrite-committed to regenerate them")
