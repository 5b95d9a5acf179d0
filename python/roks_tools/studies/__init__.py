"""The studies behind results/: each module has a `main(argv)` entry point
(`roks-<name>` in pyproject.toml; scripts/<old name>.py wraps it)."""
