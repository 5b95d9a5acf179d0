"""A height map that is a numpy array: a Gaussian random field made with
numpy, handed to roks without a file, its statistics checked and traced.

The field is made as roks makes its own `gaussian = { sigma, tau }` field
(see the guide's Height fields page): white noise, FFT, filtered by the
square root of the power spectrum S(k) ~ exp(-k^2 tau^2 / 4), inverse FFT,
the mean removed and the heights scaled to RMS sigma. `roks.stats` of the
scene then gives sigma exactly (to the f32 the heights are stored in), and
its RMS slope is compared with the array's own (forward differences, as a
triangle grid has them). The scene is traced at 0 and 60 degrees.

    python python/examples/height_map.py                    # 100 000 photons per angle
    ROKS_PHOTONS=4096 python python/examples/height_map.py
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import roks

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--photons", type=int, default=int(os.environ.get("ROKS_PHOTONS", 100000)))
ap.add_argument("--sigma", type=float, default=0.5, help="RMS height (default 0.5)")
ap.add_argument("--tau", type=float, default=3.0, help="correlation length (default 3)")
args = ap.parse_args()

n, pixel = 256, 0.125  # 256 x 256 samples 0.125 apart: a 32 x 32 periodic cell
rng = np.random.default_rng(42)
kx = 2 * np.pi * np.fft.fftfreq(n, d=pixel)
k2 = kx[None, :] ** 2 + kx[:, None] ** 2
spectrum = np.fft.fft2(rng.standard_normal((n, n))) * np.sqrt(np.exp(-k2 * args.tau**2 / 4))
spectrum[0, 0] = 0.0  # mean height 0
heights = np.real(np.fft.ifft2(spectrum))
heights *= args.sigma / np.sqrt(np.mean(heights**2))  # heights[j, i]: row j is y = j * pixel

SCENE = """\
name = "numpy-field"

[surface]
size = [32.0, 32.0]
edges = "periodic"
material = "al"               # flat until with_height_map gives it the array

[materials.al]
n = 1.015                  # aluminium at 0.55 um
k = 6.627

[light]
theta_deg = [0, 60]
photons = 100000
"""
scene = roks.Scene.from_toml(SCENE).with_height_map(heights, pixel=pixel).override(photons=args.photons)

s = roks.stats(scene)
slope = np.sqrt(np.mean(np.diff(heights, axis=1, append=heights[:, :1]) ** 2
                        + np.diff(heights, axis=0, append=heights[:1, :]) ** 2)) / pixel
print(f"numpy: sigma {np.sqrt(np.mean(heights**2)):.6f}, RMS slope {slope:.4f} "
      f"(the ensemble's 2 sigma / tau = {2 * args.sigma / args.tau:.4f}; one periodic realisation differs)")
print(f"roks.stats: sigma {s['sigma']:.6f}, tau {s['tau']:.3f}, RMS slope {s['rms_slope']:.4f}")
if abs(s["sigma"] - args.sigma) > 1e-6 * args.sigma:
    sys.exit(f"roks.stats gives sigma {s['sigma']}, the array {args.sigma}")

r = roks.brdf(scene)
for i, theta in enumerate(r.theta_deg):
    print(f"theta {theta:4.0f} deg: R = {r.reflectance[i, 0, 0]:.4f} +- {r.reflectance_stderr[i, 0, 0]:.1e}")
