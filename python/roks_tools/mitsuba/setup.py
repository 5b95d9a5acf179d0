"""Choosing and importing a Mitsuba 3 variant for the tracers and renders.

`setup_mitsuba` prefers drjit's LLVM backend (needs a libLLVM >= 19, found
by `_find_libllvm` or `$DRJIT_LIBLLVM_PATH`) and falls back to the scalar
variants with a warning; it never aborts. An LLVM that cannot compile what
drjit asks of it (libLLVM 15 and `llvm.maximum`: `LLVM ERROR: Cannot select
... fmaximum`) kills the whole process from C++, which Python cannot catch,
so the LLVM variant is first tried in a child process (`probe_variant`: set
the variant, evaluate min/max/sqrt/select kernels, render a 4 x 4 image);
only when the child succeeds is it set in this process. The probe's verdict
is kept for the process (one probe of about two seconds per variant).
"""

from __future__ import annotations

import functools
import glob
import os
import subprocess
import sys

from ..errors import MitsubaError, UsageError

PROBE = r"""
import sys
import drjit as dr
import mitsuba as mi
mi.set_variant(sys.argv[1])
x = mi.Float([1.0, -2.0, 3.0])
y = dr.maximum(x, 0.5) + dr.minimum(x, 0.1) + dr.sqrt(dr.abs(x)) + dr.select(x > 0, x, 1.0)
dr.eval(y)
scene = mi.load_dict({
    "type": "scene", "integrator": {"type": "path", "max_depth": 3},
    "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 4, "height": 4},
               "sampler": {"type": "independent", "sample_count": 1}},
    "shape": {"type": "sphere", "bsdf": {"type": "roughconductor"}}, "sky": {"type": "constant"}})
img = mi.render(scene)
dr.eval(img)
print("probe ok", mi.variant())
"""
"""The probe run in a child process: the kernels drjit's LLVM backend must
compile for the tracers, the renders and the `roks_table` plugin."""

PROBE_TIMEOUT_S = 300


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


@functools.cache
def probe_variant(variant: str, libllvm: str | None = None) -> str | None:
    """None if `variant` works in a child process (with DRJIT_LIBLLVM_PATH =
    `libllvm` when given), else why not (one line: the child's last error
    line, e.g. `LLVM ERROR: Cannot select: ... fmaximum`, or its signal)."""
    env = dict(os.environ)
    if libllvm:
        env["DRJIT_LIBLLVM_PATH"] = libllvm
    try:
        p = subprocess.run([sys.executable, "-c", PROBE, variant], env=env, capture_output=True, text=True,
                           timeout=PROBE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return f"the probe of {variant} took more than {PROBE_TIMEOUT_S} s"
    if p.returncode == 0 and "probe ok" in p.stdout:
        return None
    lines = [ln.strip() for ln in p.stderr.splitlines() if ln.strip()]
    why = next((ln for ln in lines if ln.startswith("LLVM ERROR")), lines[-1] if lines else "")
    status = f"signal {-p.returncode}" if p.returncode < 0 else f"exit {p.returncode}"
    return f"{variant} failed in a test process ({status}){': ' + why[:200] if why else ''}"


def variants(polarised: bool = False, spectral: bool = False) -> tuple[str, str]:
    """(LLVM variant, scalar variant) for the kind of transport asked for."""
    if spectral:
        return (("llvm_ad_spectral_polarized", "scalar_spectral_polarized") if polarised
                else ("llvm_ad_spectral", "scalar_spectral"))
    return (("llvm_ad_mono_polarized", "scalar_spectral_polarized") if polarised
            else ("llvm_ad_rgb", "scalar_rgb"))


def choose_variant(variant: str = "auto", polarised: bool = False, spectral: bool = False) -> str:
    """The variant `setup_mitsuba` sets: with `auto`, the LLVM one when a
    libLLVM >= 19 is found and the probe passes, else the scalar one (with a
    warning on stderr); `llvm` insists (MitsubaError when it does not work);
    `scalar` takes the scalar one; a full variant name (e.g. `llvm_ad_rgb`)
    is probed like `llvm` when it is an LLVM variant."""
    fast, slow = variants(polarised, spectral)
    if variant not in ("auto", "llvm", "scalar"):
        if variant.startswith("llvm_"):
            fast, variant = variant, "llvm"
        elif variant.startswith("scalar_"):
            return variant
        else:
            raise UsageError(f"unknown --variant {variant!r} (auto, llvm, scalar or a Mitsuba variant name)")
    if variant == "scalar":
        return slow
    lib = _find_libllvm()
    why = "no libLLVM >= 19 found (apt-get install libllvm19)" if lib is None else probe_variant(fast, lib)
    if why is None:
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", lib)
        return fast
    if variant == "llvm":
        raise MitsubaError(f"{fast} unavailable: {why}")
    print(f"roks_tools: warning: {why}; falling back to {slow} (slow)", file=sys.stderr)
    return slow


def setup_mitsuba(variant: str = "auto", polarised: bool = False, spectral: bool = False):
    """Import mitsuba with the variant `choose_variant` picks: llvm_ad_rgb if
    it works, else scalar_rgb; with `polarised`, llvm_ad_mono_polarized, else
    scalar_spectral_polarized; with `spectral`, llvm_ad_spectral, else
    scalar_spectral (both: llvm_ad_spectral_polarized, else
    scalar_spectral_polarized).

    Returns the mitsuba module; `mi.variant()` tells which variant is set.
    MitsubaError when mitsuba cannot be imported or the variant not set."""
    name = choose_variant(variant, polarised, spectral)
    try:
        import mitsuba as mi
    except ImportError as e:
        raise MitsubaError(f"mitsuba cannot be imported ({e}): pip install './python[mitsuba]'") from None
    try:
        mi.set_variant(name)
    except Exception as e:  # noqa: BLE001 (mitsuba raises ImportError/ValueError/AttributeError)
        raise MitsubaError(f"mitsuba variant {name} unavailable: {e}") from None
    return mi
