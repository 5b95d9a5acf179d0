"""The `roks` command of the Python package: the same command line as the
Rust binary (`roks brdf ...`, `roks --version`), run by the same code
(`roks::cli::run`) in this process."""

from __future__ import annotations

import sys


def main() -> None:
    """Run `roks` with this process's arguments and exit with its status."""
    from roks._native import main as run

    argv = ["roks", *sys.argv[1:]]
    sys.stdout.flush()
    sys.exit(run(argv))


if __name__ == "__main__":
    main()
