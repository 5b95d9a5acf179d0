"""A notebook-style run: load a scene, override it, trace, plot.

Each block is what one notebook cell would hold. It loads the embedded
default scene (100 ellipsoid bumps, reflectance 0.8), sweeps the incidence
over three angles, traces in-process, prints the reflectance per incidence
with its standard error, and draws the in-plane BRDF of each incidence
with matplotlib into `notebook_run.png` (or `--out`).

    python python/examples/notebook_run.py                 # 100 000 photons per angle
    ROKS_PHOTONS=4096 python python/examples/notebook_run.py --out inplane.png
"""

from __future__ import annotations

import argparse
import os

import matplotlib

matplotlib.use("Agg")  # a file, not a window; in a notebook leave this out
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import roks  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--out", default="notebook_run.png", help="the picture (default notebook_run.png)")
ap.add_argument("--photons", type=int, default=int(os.environ.get("ROKS_PHOTONS", 100000)))
args = ap.parse_args()

# --- cell 1: the scene, with the command line's options by their scene keys
scene = roks.Scene.load()  # the embedded default scene; roks.Scene.load("scenes/x.toml") for a file
scene = scene.override(photons=args.photons, theta_deg=[0.0, 30.0, 60.0], seed=1)

# --- cell 2: trace (the GIL is released; Ctrl-C stops it within a second)
result = roks.brdf(scene)

# --- cell 3: numbers, with their standard errors; axes incidence x azimuth x wavelength
R, dR = result.reflectance, result.reflectance_stderr
for i, theta in enumerate(result.theta_deg):
    print(f"theta {theta:4.0f} deg: R = {R[i, 0, 0]:.4f} +- {dR[i, 0, 0]:.1e}")

# --- cell 4: the in-plane BRDF of each incidence, (incidence, azimuth, wavelength, exit angle)
fig, ax = plt.subplots(figsize=(6, 4))
for i, theta in enumerate(result.theta_deg):
    b, se = result.inplane[i, 0, 0], result.inplane_stderr[i, 0, 0]
    ax.errorbar(result.inplane_theta_deg, b, yerr=se, fmt=".-", ms=3, lw=0.8, label=f"{theta:g} deg")
ax.set_xlabel("theta_o (deg, negative: towards the source)")
ax.set_ylabel("BRDF (1/sr)")
ax.set_yscale("log")
ax.legend(title="incidence")
ax.set_title(f"{scene.name}: in-plane BRDF, {args.photons} photons per angle")
fig.tight_layout()
fig.savefig(args.out, dpi=100)
print(f"wrote {args.out}: in-plane BRDF of {len(result.theta_deg)} incidences, "
      f"largest {np.nanmax(result.inplane):.3g} 1/sr")
