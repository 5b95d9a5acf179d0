"""The progress bar of `progress=True`: tqdm's (tqdm.auto: a terminal bar,
or a widget in a notebook) when tqdm is installed, else a plain line of
percentages on stderr."""

from __future__ import annotations

import sys
from typing import Callable

Callback = Callable[[int, int], None]


class _Plain:
    """`NAME: 42%`, rewritten in place on a terminal, one line per 10 %
    elsewhere (a notebook's stderr, a log)."""

    def __init__(self, desc: str) -> None:
        self.desc = desc
        self.done = 0
        self.shown = -1
        self.tty = sys.stderr.isatty()

    def __call__(self, n: int, total: int) -> None:
        self.done += n
        pct = int(100 * self.done / total) if total else 100
        step = pct if self.tty else pct - pct % 10
        if step != self.shown:
            self.shown = step
            end = "" if self.tty else "\n"
            start = "\r" if self.tty else ""
            print(f"{start}{self.desc}: {step}%", end=end, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.tty and self.shown >= 0:
            print(file=sys.stderr, flush=True)


class _Tqdm:
    def __init__(self, tqdm, desc: str) -> None:  # type: ignore[no-untyped-def]
        self.bar = tqdm(total=None, desc=desc, unit="photon", unit_scale=True, leave=False)

    def __call__(self, n: int, total: int) -> None:
        if self.bar.total != total:
            self.bar.total = total
        self.bar.update(n)

    def close(self) -> None:
        self.bar.close()


def progress_bar(enabled: bool, desc: str):  # type: ignore[no-untyped-def]
    """A callback `(photons done since the last call, photons in all)`
    with a `close()`, or None when not `enabled`."""
    if not enabled:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _Plain(desc)
    return _Tqdm(tqdm, desc)
