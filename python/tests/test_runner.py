"""roks_tools.runner: the peak memory it reports is the command's own."""

import os
import sys

import numpy as np
import pytest

from pathlib import Path

from roks_tools.errors import BinaryNotFound, RunError
from roks_tools.runner import roks_binary, run


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
    with pytest.raises(RunError, match="cannot run no-such-command-roks"):
        run(["no-such-command-roks"], "test_runner", echo=False)


def test_failed_command_is_an_exception_naming_its_last_error_line():
    with pytest.raises(RunError, match=r"test_runner: failed \(exit 3\): .*: it went wrong$"):
        run([sys.executable, "-c", "import sys; print('it went wrong', file=sys.stderr); sys.exit(3)"],
            "test_runner", echo=False)


def _fake_roks(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / "roks"
    p.write_text("#!/bin/sh\n")
    p.chmod(0o755)
    return p


def test_binary_lookup_order(tmp_path, monkeypatch):
    """ROKS_BIN, then roks on PATH, then the repository's build; none: the error says what was tried."""
    import roks_tools.runner as runner
    env_bin, path_bin = _fake_roks(tmp_path / "env"), _fake_roks(tmp_path / "path")
    build = _fake_roks(tmp_path / "repo" / "target" / "release")
    monkeypatch.setattr(runner, "find_repo", lambda: tmp_path / "repo")
    monkeypatch.setenv("PATH", str(tmp_path / "path"))
    monkeypatch.setenv("ROKS_BIN", str(env_bin))
    assert roks_binary() == env_bin
    monkeypatch.delenv("ROKS_BIN")
    assert roks_binary() == path_bin
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert roks_binary() == build
    build.unlink()
    with pytest.raises(BinaryNotFound, match=r"ROKS_BIN unset, no roks on PATH, no .*target/release/roks"):
        roks_binary()
    monkeypatch.setattr(runner, "find_repo", lambda: None)
    with pytest.raises(BinaryNotFound, match="not in a roks checkout"):
        roks_binary()
    monkeypatch.setenv("ROKS_BIN", str(tmp_path / "missing"))
    with pytest.raises(BinaryNotFound, match="ROKS_BIN=.*missing: no executable"):
        roks_binary()
