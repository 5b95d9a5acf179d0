"""roks in Python: trace rough surfaces and objects in-process, numpy in
and out. See the guide's page "roks in Python"."""

from roks._native import __version__

__all__ = ["__version__"]
