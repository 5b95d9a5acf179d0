"""The exceptions of roks_tools, and the one place that turns them into exit codes.

Library code raises; only the `main` functions of the command-line tools
turn an error into a message and an exit status, through `cli`:

* `RoksToolsError`: the base class of every error the package raises on
  purpose; its message is one line and names the file, option or command.
* `ResultError`: a result file that is missing or not what roks writes
  (bad bytes, another header, a cut table); the message names the file.
* `RunError`: a command (roks, or another program) that cannot be started
  or failed; `BinaryNotFound` when no roks binary is found at all.
* `MitsubaError`: Mitsuba cannot be imported or no variant works.
* `UsageError`: a bad option value of a tool.

`cli(prog, main)` (or the decorator `command(prog)`) runs `main()` and maps `UsageError`, `ResultError` and
`BinaryNotFound` to exit status 2 (bad input), any other `RoksToolsError` to
1, each with the one-line message `prog: error: ...` on stderr.
"""

from __future__ import annotations

import functools
import sys
from typing import Callable


class RoksToolsError(Exception):
    """Any error roks_tools raises on purpose (one line, naming what is wrong)."""


class ResultError(RoksToolsError, ValueError):
    """A result file that is missing or not what roks writes (the message names it)."""


class RunError(RoksToolsError):
    """A command that cannot be started or that failed (the message names it)."""


class BinaryNotFound(RunError):
    """No roks binary: not at $ROKS_BIN, not on PATH, not in the repository's build."""


class MitsubaError(RoksToolsError):
    """Mitsuba 3 cannot be imported, or the variant asked for does not work."""


class UsageError(RoksToolsError):
    """A bad command-line value of a tool (the message names the option)."""


BAD_INPUT = (UsageError, ResultError, BinaryNotFound)
"""Errors of the user's input: exit status 2."""


def cli(prog: str, main: Callable[[], int | None]) -> int:
    """Run `main()`; a `RoksToolsError` becomes `prog: error: MESSAGE` on
    stderr and exit status 2 (bad input, see `BAD_INPUT`) or 1 (a failed
    run). Returns the status for `sys.exit`."""
    try:
        return int(main() or 0)
    except BAD_INPUT as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except RoksToolsError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 1


def command(prog: str):
    """Decorator of a tool's `main`: runs it through `cli(prog, ...)`, so a
    `RoksToolsError` becomes a one-line message and an exit status."""
    def wrap(main):
        @functools.wraps(main)
        def run(*args, **kwargs):
            return cli(prog, lambda: main(*args, **kwargs))
        return run
    return wrap


def show(path) -> str:
    """A path (or any name) for a one-line message: as is when printable,
    else quoted with its control characters escaped (a newline in a file
    name must not split the message)."""
    s = str(path)
    return s if s.isprintable() else repr(s)
