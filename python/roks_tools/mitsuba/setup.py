"""Choosing and importing a Mitsuba 3 variant for the tracers and renders.

`setup_mitsuba` prefers drjit's LLVM backend (needs a libLLVM >= 19, found
by `_find_libllvm` or `$DRJIT_LIBLLVM_PATH`) and falls back to the scalar
variants with a warning.
"""

from __future__ import annotations

import glob
import os
import sys


def _find_libllvm() -> str | None:
    """A libLLVM of version >= 19 (drjit's LLVM backend aborts on 15 and 16)."""
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env:
        return env
    cands = []
    for pat in (
        "/usr/lib/x86_64-linux-gnu/libLLVM.so.*",
        "/usr/lib/x86_64-linux-gnu/libLLVM-*.so",
        "/usr/lib/llvm-*/lib/libLLVM*.so*",
        "/usr/lib64/libLLVM*.so*",
    ):
        for p in glob.glob(pat):
            base = os.path.basename(p)
            digits = "".join(c if c.isdigit() else " " for c in base).split()
            if digits and int(digits[0]) >= 19:
                cands.append((int(digits[0]), p))
    return max(cands)[1] if cands else None


def setup_mitsuba(variant: str = "auto", polarised: bool = False, spectral: bool = False):
    """Import mitsuba with llvm_ad_rgb if possible, else scalar_rgb (warning);
    with `polarised`, llvm_ad_mono_polarized, else scalar_spectral_polarized;
    with `spectral`, llvm_ad_spectral, else scalar_spectral (both:
    llvm_ad_spectral_polarized, else scalar_spectral_polarized).

    Returns the mitsuba module; `mi.variant()` tells which variant is set.
    """
    if spectral:
        fast, slow = (("llvm_ad_spectral_polarized", "scalar_spectral_polarized") if polarised
                      else ("llvm_ad_spectral", "scalar_spectral"))
    else:
        fast, slow = (("llvm_ad_mono_polarized", "scalar_spectral_polarized") if polarised
                      else ("llvm_ad_rgb", "scalar_rgb"))
    if variant not in ("auto", "llvm", "scalar"):
        raise SystemExit(f"mitsuba_brdf: unknown --variant {variant!r}")
    lib = None
    if variant in ("auto", "llvm"):
        lib = _find_libllvm()
        if lib:
            os.environ.setdefault("DRJIT_LIBLLVM_PATH", lib)
    import mitsuba as mi  # noqa: E402

    if variant != "scalar":
        if lib is None:
            why = "no libLLVM >= 19 found (apt-get install libllvm19)"
            if variant == "llvm":
                raise SystemExit(f"mitsuba_brdf: {why}")
            print(f"mitsuba_brdf: warning: {why}; falling back to {slow} (slow)", file=sys.stderr)
        else:
            try:
                mi.set_variant(fast)
                return mi
            except Exception as e:  # noqa: BLE001
                if variant == "llvm":
                    raise SystemExit(f"mitsuba_brdf: {fast} unavailable: {e}")
                print(f"mitsuba_brdf: warning: {fast} unavailable ({e}); "
                      f"falling back to {slow} (slow)", file=sys.stderr)
    mi.set_variant(slow)
    return mi
