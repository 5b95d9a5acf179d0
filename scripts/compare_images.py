#!/usr/bin/env python3
"""Compare two radiance maps (EXR), e.g. `roks render` against scripts/mitsuba_render.py.

    compare_images.py A.exr B.exr --out DIR [--spp N] [--a2 A_seed2.exr] [--b2 B_seed2.exr]
        [--label-a roks] [--label-b mitsuba] [--nsigma 4]

Writes DIR/report.md, DIR/side_by_side.png, DIR/difference.png and prints the
report. Channel: the mean of R, G, B (the renders are grey).

* Means and their standard errors from the pixel variance,
  SE = std(pixels) / sqrt(N pixels) (treats the pixels as samples of the
  cell; includes the image's structure, so it is conservative).
  Verdict: PASS if |mean_a - mean_b| <= nsigma (default 4) x
  sqrt(SE_a^2 + SE_b^2).
* Per-pixel noise: with second renders of other seeds (--a2, --b2), the
  variance of a pixel is estimated as (A - A2)^2 / 2, smoothed over a 5 x 5
  window (and likewise for B); otherwise with --spp from the bound
  var <= x (1 - x) / spp, valid for per-sample values in [0, 1] (a path
  contributes its weight <= 1 or 0, light radiance 1), x = (A + B) / 2 clipped
  to [0, 1]; conservative. Pixels with |A - B| > nsigma x sigma_diff are
  counted as "beyond noise" (expected fraction for pure noise: about 6e-5 at
  4 sigma if the noise were Gaussian).
* Per-pixel relative difference (A - B) / ((A + B) / 2), the denominator
  floored at 5 % of the mean image value.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np


def read_exr(path: str) -> np.ndarray:
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    a = np.array(mi.Bitmap(path), dtype=np.float64)
    if a.ndim == 3:
        a = a[..., :3].mean(axis=2)
    return a


def box5(x: np.ndarray) -> np.ndarray:
    """Mean over a 5 x 5 window (edges: periodic, the images are one period)."""
    acc = np.zeros_like(x)
    for di in range(-2, 3):
        for dj in range(-2, 3):
            acc += np.roll(np.roll(x, di, axis=0), dj, axis=1)
    return acc / 25.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, default=None, help="samples per pixel (noise bound)")
    ap.add_argument("--a2", default=None, help="A rendered with another seed")
    ap.add_argument("--b2", default=None, help="B rendered with another seed")
    ap.add_argument("--label-a", default="A")
    ap.add_argument("--label-b", default="B")
    ap.add_argument("--nsigma", type=float, default=4.0)
    a = ap.parse_args(argv)

    A, B = read_exr(a.a), read_exr(a.b)
    if A.shape != B.shape:
        raise SystemExit(f"compare_images: sizes differ: {A.shape} vs {B.shape}")
    n = A.size
    ma, mb = A.mean(), B.mean()
    sea, seb = A.std(ddof=1) / math.sqrt(n), B.std(ddof=1) / math.sqrt(n)
    comb = math.hypot(sea, seb)
    diff = ma - mb
    z = diff / comb if comb > 0 else (0.0 if diff == 0 else math.inf)
    ok = abs(diff) <= a.nsigma * comb

    lines = [f"# Image comparison: {a.label_a} vs {a.label_b}", "",
             f"* {a.label_a}: `{a.a}`", f"* {a.label_b}: `{a.b}`",
             f"* size: {A.shape[1]} x {A.shape[0]} pixels", "",
             "| | mean | SE (pixel variance) |", "|---|---:|---:|",
             f"| {a.label_a} | {ma:.6f} | {sea:.6f} |",
             f"| {a.label_b} | {mb:.6f} | {seb:.6f} |",
             f"| difference | {diff:+.6f} ({diff / mb * 100 if mb else float('nan'):+.3f} %) | {comb:.6f} (z = {z:+.2f}) |",
             ""]
    # second-seed estimates of the standard error of the means
    va = vb = None
    if a.a2:
        A2 = read_exr(a.a2)
        va = box5(0.5 * (A - A2) ** 2)
        lines.append(f"* seed-to-seed: {a.label_a} mean {A2.mean():.6f} with the other seed; "
                     f"SE of the mean from the seed difference {np.std(A - A2) / math.sqrt(2 * n):.6f}")
    if a.b2:
        B2 = read_exr(a.b2)
        vb = box5(0.5 * (B - B2) ** 2)
        lines.append(f"* seed-to-seed: {a.label_b} mean {B2.mean():.6f} with the other seed; "
                     f"SE of the mean from the seed difference {np.std(B - B2) / math.sqrt(2 * n):.6f}")
    noise_src = None
    if va is not None and vb is not None:
        var = va + vb
        noise_src = "second seeds (5 x 5 smoothed squared seed differences)"
    elif a.spp:
        x = np.clip(0.5 * (A + B), 0.0, 1.0)
        var = 2.0 * x * (1.0 - x) / a.spp
        noise_src = f"bound x (1 - x) / spp per image, spp = {a.spp}"
    rel = (A - B) / np.maximum(0.5 * (A + B), 0.05 * max(0.5 * (ma + mb), 1e-30))
    lines += ["", "## Per pixel", "",
              f"* relative difference (A - B) / ((A + B) / 2): median |.| {np.median(np.abs(rel)):.4f}, "
              f"95th percentile |.| {np.percentile(np.abs(rel), 95):.4f}, mean {rel.mean():+.4f}"]
    zmap = None
    if noise_src:
        sig = np.sqrt(var)
        with np.errstate(divide="ignore", invalid="ignore"):
            zmap = np.where(sig > 0, (A - B) / sig, np.where(A == B, 0.0, np.inf))
        beyond = np.abs(zmap) > a.nsigma
        lines += [f"* per-pixel noise from {noise_src}",
                  f"* pixels differing beyond {a.nsigma:g} sigma: {beyond.sum()} of {n} "
                  f"({beyond.mean() * 100:.3f} %); |z| > 2: {(np.abs(zmap) > 2).mean() * 100:.2f} % "
                  f"(Gaussian noise: 4.6 %); rms z {np.sqrt(np.mean(np.where(np.isfinite(zmap), zmap, 0) ** 2)):.3f}"]
    verdict = "PASS" if ok else "FAIL"
    lines += ["", "## Verdict", "",
              f"**{verdict}**: |mean_a - mean_b| = {abs(diff):.6f} "
              f"{'<=' if ok else '>'} {a.nsigma:g} x {comb:.6f} = {a.nsigma * comb:.6f}", "",
              "![side by side](side_by_side.png)", "", "![difference](difference.png)", ""]

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    vmax = max(np.percentile(A, 99), np.percentile(B, 99), 1e-30)
    fig, ax = plt.subplots(1, 2, figsize=(10, 4.6))
    for k, (img, lab, m) in enumerate(((A, a.label_a, ma), (B, a.label_b, mb))):
        im = ax[k].imshow(img, cmap="gray", vmin=0, vmax=vmax, interpolation="nearest")
        ax[k].set_title(f"{lab}: mean {m:.4f}")
        ax[k].axis("off")
    fig.colorbar(im, ax=ax, fraction=0.025)
    fig.savefig(out / "side_by_side.png", dpi=110)
    plt.close(fig)
    npan = 2 if zmap is not None else 1
    fig, ax = plt.subplots(1, npan, figsize=(5 * npan + 0.5, 4.6), squeeze=False)
    im = ax[0, 0].imshow(np.clip(rel, -1, 1), cmap="RdBu_r", vmin=-1, vmax=1, interpolation="nearest")
    ax[0, 0].set_title("relative difference (A-B)/((A+B)/2)")
    ax[0, 0].axis("off")
    fig.colorbar(im, ax=ax[0, 0], fraction=0.046)
    if zmap is not None:
        im = ax[0, 1].imshow(np.clip(np.nan_to_num(zmap), -5, 5), cmap="RdBu_r", vmin=-5, vmax=5,
                             interpolation="nearest")
        ax[0, 1].set_title("(A-B)/sigma per pixel")
        ax[0, 1].axis("off")
        fig.colorbar(im, ax=ax[0, 1], fraction=0.046)
    fig.tight_layout()
    fig.savefig(out / "difference.png", dpi=110)
    plt.close(fig)
    text = "\n".join(lines)
    (out / "report.md").write_text(text)
    print(text)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
