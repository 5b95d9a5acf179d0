"""The package's type stubs match the module, and every public name has a docstring.

The package `roks` is Python with inline annotations (`py.typed`) around
the compiled `roks._native`, whose names an editor knows only from its stub
`roks/_native.pyi`. `mypy.stubtest` (mypy pinned in the `test` extra)
imports `roks._native` and compares every name, signature and type of the
stub with the runtime objects: a name missing from the stub (an editor
would not complete it), a stub of a name that is not there, a signature
that differs, or a class the stub lets one subclass that the runtime does
not (pyo3's frozen classes: `@final`) fails.
The docstring check walks the module's public names (`__all__`, else those
without a leading underscore) and the public attributes of its classes.
"""

from __future__ import annotations

import inspect
import subprocess
import sys

import pytest

roks = pytest.importorskip("roks")
pytest.importorskip("mypy")


def public(obj) -> list[str]:
    names = getattr(obj, "__all__", None)
    if names is None:
        names = [n for n in dir(obj) if not n.startswith("_")]
    return sorted(names)


def test_stubtest_finds_no_difference():
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", "roks._native"],
                         capture_output=True, text=True)
    assert out.returncode == 0, f"stubtest:\n{out.stdout}\n{out.stderr}"


def test_every_public_name_has_a_docstring():
    missing = []
    assert (roks.__doc__ or "").strip(), "the module roks has no docstring"
    for name in public(roks):
        obj = getattr(roks, name)
        if inspect.ismodule(obj):
            continue
        if not (getattr(obj, "__doc__", None) or "").strip():
            missing.append(f"roks.{name}")
        if inspect.isclass(obj):
            for attr in dir(obj):
                if attr.startswith("_"):
                    continue
                owner = next((k for k in obj.__mro__ if attr in vars(k)), None)
                if owner is None or not owner.__module__.startswith("roks"):
                    continue  # inherited from object, Exception, ...
                raw = vars(owner)[attr]
                if not (callable(raw) or inspect.isdatadescriptor(raw) or inspect.ismethoddescriptor(raw)
                        or isinstance(raw, (classmethod, staticmethod))):
                    continue  # a plain class constant carries its value's type's docstring
                if not (getattr(raw, "__doc__", None) or "").strip():
                    missing.append(f"roks.{name}.{attr}")
    assert not missing, "no docstring: " + ", ".join(missing)
