"""Running roks (and other programs) from the studies and tests: one `run`.

`run` starts a command, waits for it and returns a `Completed` with its
output, wall-clock and CPU seconds and peak resident memory. The memory is
read by GNU `/usr/bin/time -f %M` where it exists: Linux counts the memory a
process held before `exec` in its peak, and Python starts children by
(v)fork, so `os.wait4` on a child of this process reports at least this
process's own peak (about 29 MB with numpy loaded, more than a small roks
run needs). Without `/usr/bin/time` the `os.wait4` figure is used, with that
floor.
On failure it writes the command's output to stderr and exits naming the
caller (`who`) and the command, the way every study reports a failed run.

`repo_root()` and `roks_binary()` find the repository and its release build
(`target/release/roks`) when the package is used from a checkout.
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


def repo_root() -> Path:
    """The repository holding this package (python/roks_tools/ -> the repo), or
    the current folder when the package is installed elsewhere."""
    here = Path(__file__).resolve().parents[2]
    return here if (here / "Cargo.toml").is_file() else Path.cwd()


def roks_binary() -> Path:
    """`$ROKS_BIN` if set, else the repository's `target/release/roks`."""
    env = os.environ.get("ROKS_BIN")
    return Path(env) if env else repo_root() / "target" / "release" / "roks"


def run(cmd: list, who: str, echo: bool = True, cwd: Path | None = None,
        check: bool = True) -> Completed:
    """Run `cmd` (items converted to str) and wait for it.

    `echo` prints the command (prefixed `+ `) to stderr first. With `check`
    (the default) a non-zero exit writes the command's stdout and stderr to
    stderr and raises SystemExit naming `who` and the command.
    """
    cmd = [str(c) for c in cmd]
    if echo:
        print("+ " + " ".join(cmd), file=sys.stderr, flush=True)
    if shutil.which(cmd[0], path=None if os.sep not in cmd[0] else "") is None \
            and not (Path(cwd or ".") / cmd[0]).exists():
        raise SystemExit(f"{who}: cannot run {cmd[0]}: not found")
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err, \
            tempfile.TemporaryDirectory() as tmp:
        peak_file = str(Path(tmp) / "peak_kib")
        wrapper = _peak_memory_wrapper(peak_file)
        t0 = time.perf_counter()
        try:
            p = subprocess.Popen(wrapper + cmd, cwd=cwd, stdout=out, stderr=err, text=True)
        except OSError as e:
            raise SystemExit(f"{who}: cannot run {cmd[0]}: {e}") from e
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
        raise SystemExit(f"{who}: failed (exit {done.returncode}): {' '.join(cmd)}")
    return done
