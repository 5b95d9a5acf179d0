"""roks_tools.runner: the peak memory it reports is the command's own."""

import os
import sys

import numpy as np
import pytest

from roks_tools.runner import run


def test_peak_memory_counts_what_the_command_allocates():
    # 160 MiB written byte by byte, so every page is resident.
    done = run([sys.executable, "-c", "b = bytearray(160 << 20); b[::4096] = b'x' * len(b[::4096])"],
               "test_runner", echo=False)
    assert done.max_rss_mb >= 160


@pytest.mark.skipif(not os.access("/usr/bin/time", os.X_OK), reason="GNU time not installed")
def test_peak_memory_is_not_floored_by_this_process():
    # This process holds 300 MiB; `true` needs about 1 MiB. os.wait4 alone
    # would report at least 300 (Linux keeps the pre-exec peak of a forked child).
    ballast = np.ones(300 << 17)  # 300 MiB of float64, resident
    done = run(["true"], "test_runner", echo=False)
    assert ballast.sum() == 300 << 17
    assert done.max_rss_mb < 50


def test_missing_command_is_a_clear_error():
    with pytest.raises(SystemExit, match="cannot run no-such-command-roks"):
        run(["no-such-command-roks"], "test_runner", echo=False)
