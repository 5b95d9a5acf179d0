"""Fit the RMS height sigma of a Gaussian random surface to a "measured"
in-plane BRDF with scipy.optimize, in-process, then the same fit through the
command line (one `roks brdf` process and one folder read per evaluation),
and print both times and their ratio.

The measurement is made by roks itself at a known sigma (`--truth`, 1.0)
with its own photon seed, plus 2 % Gaussian "instrument" noise of known
size, so the recovered value can be checked against the truth within the
uncertainty the fit states. The model traces the same realisation of the
field (same `seed` of the height field, so sigma only scales its heights)
at a fixed photon seed: common random numbers make the misfit a
deterministic function of sigma, so a bounded scalar search converges.
A real measurement adds the spread between realisations of the field (see
the guide's Height fields page); here the only differences between data and
model are sigma, photon noise and the instrument noise.

Misfit: chi^2 = sum over the in-plane bins (both incidences) of
(model - measured)^2 / (se_measured^2 + se_model^2 + instrument^2), with the
standard errors roks reports. The uncertainty of the fitted sigma is where
chi^2 rises by 1 (a parabola through chi^2 at the minimum and +-h).
Exit status 1 when the recovered sigma is more than 4 standard errors from
the truth.

    python python/examples/fit_sigma.py                       # 20 000 photons per angle
    ROKS_PHOTONS=4096 python python/examples/fit_sigma.py     # quicker, looser
    python python/examples/fit_sigma.py --roks target/release/roks
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

import roks

SCENE = """\
name = "fit-sigma"

[surface]
size = [24.0, 24.0]
edges = "periodic"
material = "al"
heightfield = {{ gaussian = {{ sigma = {sigma!r}, tau = 3.0 }}, resolution = 128, seed = 3 }}

[materials.al]
n = 1.015
k = 6.627

[light]
theta_deg = [20, 50]
phi_deg = 0.0
photons = {photons}
seed = {seed}

[tally]
inplane_step_deg = 5.0        # wide in-plane bins: 1-degree bins hold too few photons
inplane_width_deg = 10.0
"""

INSTRUMENT = 0.02
"""Relative standard deviation of the instrument noise added to the measurement."""

BOUNDS = (0.4, 2.0)
"""The search interval of sigma (length units; tau is 3)."""


def scene_text(sigma: float, photons: int, seed: int) -> str:
    return SCENE.format(sigma=float(sigma), photons=photons, seed=seed)


def inplane(result) -> tuple[np.ndarray, np.ndarray]:
    """The in-plane BRDF (1/sr) and its standard error of every incidence,
    as one flat vector each (incidences one after another)."""
    return np.ravel(result.inplane), np.ravel(result.inplane_stderr)


def brdf_in_process(sigma: float, photons: int, seed: int):
    return roks.brdf(roks.Scene.from_toml(scene_text(sigma, photons, seed)))


def brdf_by_command(binary: str, work: Path, sigma: float, photons: int, seed: int):
    """The same run through the command line: a scene file, one `roks brdf`
    process writing a folder, the folder read back."""
    scene = work / "scene.toml"
    scene.write_text(scene_text(sigma, photons, seed))
    out = work / "out"
    subprocess.run([binary, "brdf", str(scene), "--out", str(out), "--force", "-q"], check=True)
    return roks.load(out)


class Fit:
    """chi^2(sigma) against the measurement, counting its evaluations."""

    def __init__(self, measured: np.ndarray, var_measured: np.ndarray, run):
        self.measured, self.var_measured, self.run = measured, var_measured, run
        self.evaluations = 0

    def chi2(self, sigma: float) -> float:
        self.evaluations += 1
        model, se = inplane(self.run(sigma))
        var = self.var_measured + se**2
        used = var > 0  # bins empty in both contribute nothing
        return float(np.sum((model[used] - self.measured[used]) ** 2 / var[used]))

    def solve(self, h: float = 0.05) -> tuple[float, float, float]:
        """The fitted sigma, its standard error (chi^2 + 1) and chi^2 at the minimum."""
        best = minimize_scalar(self.chi2, bounds=BOUNDS, method="bounded", options={"xatol": 2e-3})
        s = float(best.x)
        c0, cm, cp = float(best.fun), self.chi2(s - h), self.chi2(s + h)
        curvature = (cp - 2 * c0 + cm) / h**2  # d2 chi^2 / d sigma^2
        stderr = float(np.sqrt(2 / curvature)) if curvature > 0 else float("inf")
        return s, stderr, c0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photons", type=int, default=int(os.environ.get("ROKS_PHOTONS", 20000)),
                    help="photons per incidence angle of each model run (default: $ROKS_PHOTONS or 20000)")
    ap.add_argument("--truth", type=float, default=1.0, help="the sigma of the measurement (default 1.0)")
    ap.add_argument("--roks", help="the command line to time (default: the `roks` command installed "
                                   "beside this Python, else $ROKS_BIN, else roks on PATH)")
    ap.add_argument("--data-seed", type=int, default=1007,
                    help="photon seed of the measurement (its instrument noise: this + 1); default 1007")
    ap.add_argument("--no-command", action="store_true", help="skip the fit through the command line")
    args = ap.parse_args()

    # The measurement: 4x the model's photons, its own photon seed, plus instrument noise.
    meas = brdf_in_process(args.truth, 4 * args.photons, seed=args.data_seed)
    b, se = inplane(meas)
    noise = np.random.default_rng(args.data_seed + 1).normal(0.0, INSTRUMENT, b.shape)
    measured = b * (1 + noise)
    var_measured = se**2 + (INSTRUMENT * b) ** 2

    fit = Fit(measured, var_measured, lambda s: brdf_in_process(s, args.photons, seed=7))
    t = time.perf_counter()
    sigma, stderr, chi2 = fit.solve()
    t_in = time.perf_counter() - t
    dof = int(np.count_nonzero(var_measured > 0)) - 1
    z = (sigma - args.truth) / stderr
    print(f"in-process: sigma = {sigma:.4f} +- {stderr:.4f} (truth {args.truth}, z = {z:+.2f}), "
          f"chi2/dof = {chi2:.1f}/{dof}, {fit.evaluations} runs of {args.photons} photons x 2 angles "
          f"in {t_in:.2f} s ({1e3 * t_in / fit.evaluations:.1f} ms a run)")

    if not args.no_command:
        binary = args.roks or shutil.which("roks", path=str(Path(sys.executable).parent)) \
            or os.environ.get("ROKS_BIN") or shutil.which("roks")
        if binary is None:
            print("no roks command found: give --roks", file=sys.stderr)
            return 2
        with tempfile.TemporaryDirectory() as tmp:
            cmd = Fit(measured, var_measured, lambda s: brdf_by_command(binary, Path(tmp), s, args.photons, 7))
            t = time.perf_counter()
            sigma_cmd, stderr_cmd, _ = cmd.solve()
            t_cmd = time.perf_counter() - t
        print(f"command:    sigma = {sigma_cmd:.4f} +- {stderr_cmd:.4f}, {cmd.evaluations} runs of `{binary} brdf` "
              f"+ roks.load in {t_cmd:.2f} s ({1e3 * t_cmd / cmd.evaluations:.1f} ms a run)")
        print(f"command / in-process: {t_cmd / t_in:.2f}x")
        if sigma_cmd != sigma:
            print("the two fits differ: the command line and the module gave different results", file=sys.stderr)
            return 1
    if not abs(z) <= 4:
        print(f"recovered sigma {sigma:.4f} is {z:+.1f} standard errors from the truth {args.truth}",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
