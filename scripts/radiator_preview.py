#!/usr/bin/env python3
"""Pinhole previews of the radiator cavity: ideal cone vs the 45-degree apex defect.

    .venv/bin/python scripts/radiator_preview.py [--roks target/release/roks] [--spp 256]

Renders scenes/radiator-brdf.toml and scenes/radiator-defect-brdf.toml (walls
sample the Z-302 BRDF table out/z302/brdf.csv, written first by
`roks brdf scenes/z302-micro.toml` if missing) with `roks render`: a camera
on the axis 40 mm above the aperture looking down into the cavity (30 deg
field of view, so the whole image lies inside the aperture but for the
corners), lit by a 5 deg disc along the axis (the laser's direction). Writes
results/radiator/preview.png: both images on a log10 scale of radiance in the
disc's units (4 x 4-pixel means for display), and the EXRs to
out/radiator_preview/.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from compare_images import read_exr  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", default=str(REPO / "target" / "release" / "roks"))
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--size", type=int, default=256)
    a = ap.parse_args()
    if not (REPO / "out" / "z302" / "brdf.csv").exists():
        subprocess.run([a.roks, "brdf", "scenes/z302-micro.toml", "--out", "out/z302", "-q"], cwd=REPO, check=True)
    out = REPO / "out" / "radiator_preview"
    imgs = []
    for scene, title in (("radiator-brdf", "ideal cone"), ("radiator-defect-brdf", "45 deg apex defect")):
        exr = out / f"{scene}.exr"
        subprocess.run([a.roks, "render", f"scenes/{scene}.toml", "--camera", "0,0,40", "--look-at", "0,0,-115",
                        "--fov", "30", "--light", "0,0", "--disc", "5", "--size", f"{a.size},{a.size}",
                        "--spp", str(a.spp), "--out", str(exr)], cwd=REPO, check=True)
        imgs.append((read_exr(exr), title))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(10, 4.6))
    k = 4
    for i, (img, title) in enumerate(imgs):
        n = (img.shape[0] // k) * k
        b = img[:n, :n].reshape(n // k, k, n // k, k).mean(axis=(1, 3))
        im = ax[i].imshow(np.log10(np.maximum(b, 1e-7)), vmin=-6, vmax=-3, cmap="inferno")
        c = img[n // 2 - n // 16:n // 2 + n // 16, n // 2 - n // 16:n // 2 + n // 16].mean()
        ax[i].set_title(f"{title}: centre {c:.2e}")
        ax[i].axis("off")
    fig.colorbar(im, ax=ax, label="log10 radiance / disc radiance")
    fig.suptitle("Radiator cavity seen from 40 mm above the aperture, lit along the axis (roks render, Z-302 table walls)")
    dest = REPO / "results" / "radiator" / "preview.png"
    fig.savefig(dest, dpi=90)
    print(f"radiator_preview: wrote {dest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
