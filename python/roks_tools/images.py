"""Compare two radiance maps (EXR), e.g. `roks render` against `roks_tools.mitsuba.render`.

    compare_images.py A.exr B.exr --out DIR [--a2 A_seed2.exr] [--b2 B_seed2.exr]
        [--spp N] [--block 8] [--label-a roks] [--label-b mitsuba]

Writes DIR/report.md, DIR/side_by_side.png, DIR/difference.png and prints the
report. Channel: the mean of R, G, B (the renders are grey). Exit status 1 on FAIL.

Noise model. With a second render of each side by another seed (--a2, --b2,
the intended use) each side is the mean of its two renders and the variance
of that mean in a pixel is estimated as (A - A2)^2 / 4: unbiased, one degree
of freedom per pixel. Without them, --spp gives the conservative bound
x (1 - x) / spp for per-sample values in [0, 1] (a path carries weight <= 1,
light radiance 1).

Tests (`compare()`; each must hold for PASS):
* **Mean**: |mean_A - mean_B| <= 4 standard errors, the SE of each mean
  being the root sum of its pixel variances over the pixel count.
* **Blocks**: the image is cut into blocks of `--block` x `--block` pixels;
  per block z = (block mean difference) / sqrt(sum of the pixel variances of
  both sides / pixels^2). With seeds and --spp both given, a pixel's variance
  is at least the bound x (1 - x) / (2 spp) at the pooled mean x of the
  four renders: a pixel lit by a rare glint can show no spread between two
  renders of one side, and one degree of freedom per pixel misses such
  heavy tails. Pixel variances pooled over a block have many
  degrees of freedom, so z is close to a standard normal when the two
  renderers agree. The block chi-square per degree of freedom must stay below
  its p = 1e-3 point (Wilson-Hilferty), and max |z| below the limit that
  n independent normals exceed with probability 1e-3. Blocks with no noise on
  either side must agree exactly (to 1e-6 of the image mean).
* Per pixel (reported, no verdict: one degree of freedom per pixel makes a
  per-pixel test meaningless): the relative difference (A - B) / ((A + B)/2)
  with the denominator floored at 5 % of the image mean, and the fraction of
  pixels beyond 4 sigma.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from .errors import RunError, UsageError, command
from .results import read_exr  # noqa: F401 (the reader lives in results)
from .stats import cell_z_limit, wilson_hilferty


def block_sums(x: np.ndarray, k: int) -> np.ndarray:
    h, w = (x.shape[0] // k) * k, (x.shape[1] // k) * k
    return x[:h, :w].reshape(h // k, k, w // k, k).sum(axis=(1, 3))


def compare(a1, b1, a2=None, b2=None, spp=None, block=8) -> dict:
    """Statistics and verdict of two renders (paths), see the module doc."""
    A1, B1 = read_exr(a1), read_exr(b1)
    if A1.shape != B1.shape:
        raise RunError(f"sizes differ: {A1.shape} vs {B1.shape}")
    if (a2 is None) != (b2 is None):
        raise UsageError("give both --a2 and --b2, or neither")
    n = A1.size
    if a2 is not None:
        A2, B2 = read_exr(a2), read_exr(b2)
        A, B = 0.5 * (A1 + A2), 0.5 * (B1 + B2)
        va, vb = 0.25 * (A1 - A2) ** 2, 0.25 * (B1 - B2) ** 2
        noise = "second renders of other seeds, (A1 - A2)^2 / 4 per pixel"
    elif spp:
        A, B = A1, B1
        va = np.clip(A, 0, 1) * (1 - np.clip(A, 0, 1)) / spp
        vb = np.clip(B, 0, 1) * (1 - np.clip(B, 0, 1)) / spp
        noise = f"bound x (1 - x) / spp, spp = {spp}"
    else:
        raise UsageError("need --a2 and --b2, or --spp, for the noise")
    ma, mb = A.mean(), B.mean()
    sea, seb = math.sqrt(va.sum()) / n, math.sqrt(vb.sum()) / n
    comb = math.hypot(sea, seb)
    diff = ma - mb
    z = diff / comb if comb > 0 else (0.0 if diff == 0 else math.inf)
    # blocks: with seeds and spp both known, each pixel's variance is the larger
    # of the seed-difference estimate and the [0, 1] bound at the pooled mean
    # (a pixel lit by a rare glint can show no spread in two renders of one
    # side: one degree of freedom per pixel misses heavy tails)
    vpa, vpb = va, vb
    if a2 is not None and spp:
        x = np.clip(0.5 * (A + B), 0.0, 1.0)
        bound = x * (1.0 - x) / (2 * spp)
        vpa, vpb = np.maximum(va, bound), np.maximum(vb, bound)
        noise += f"; blocks: at least the bound x (1 - x) / (2 spp) at the pooled mean, spp = {spp}"
    k = block
    npx = k * k
    db = block_sums(A - B, k) / npx
    vbk = block_sums(vpa + vpb, k) / npx ** 2
    tiny = 1e-6 * max(abs(ma), abs(mb), 1e-300)
    exact = vbk == 0
    exact_bad = int(np.sum(exact & (np.abs(db) > tiny)))
    zb = db[~exact] / np.sqrt(vbk[~exact])
    dof = zb.size
    chi2 = float(np.sum(zb ** 2) / dof) if dof else 0.0
    zmaxb = float(np.max(np.abs(zb))) if dof else 0.0
    limit = cell_z_limit(dof)
    # per pixel (reported)
    rel = (A - B) / np.maximum(0.5 * (A + B), 0.05 * max(0.5 * (ma + mb), 1e-30))
    sig = np.sqrt(vpa + vpb)
    with np.errstate(divide="ignore", invalid="ignore"):
        zmap = np.where(sig > 0, (A - B) / sig, np.where(np.abs(A - B) <= tiny, 0.0, np.inf))
    res = {
        "A": A, "B": B, "rel": rel, "zmap": zmap, "noise": noise, "shape": A.shape,
        "mean_a": ma, "mean_b": mb, "se_a": sea, "se_b": seb, "diff": diff, "z": z,
        "block": k, "blocks": dof, "block_chi2_dof": chi2, "block_chi2_z": wilson_hilferty(chi2, dof),
        "block_max_z": zmaxb, "block_z_limit": limit, "blocks_exact": int(exact.sum()),
        "blocks_exact_bad": exact_bad,
        "rel_median": float(np.median(np.abs(rel))), "rel_p95": float(np.percentile(np.abs(rel), 95)),
        "pixels_beyond_4": float(np.mean(np.abs(zmap) > 4)),
    }
    res["pass_mean"] = abs(z) <= 4.0
    res["pass_blocks"] = res["block_chi2_z"] <= 3.1 and zmaxb <= limit and exact_bad == 0
    res["pass"] = res["pass_mean"] and res["pass_blocks"]
    return res


def figures(r: dict, out: Path, label_a: str, label_b: str) -> None:
    """side_by_side.png and difference.png in `out`."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out.mkdir(parents=True, exist_ok=True)
    A, B = r["A"], r["B"]
    vmax = max(np.percentile(A, 99), np.percentile(B, 99), 1e-30)
    fig, ax = plt.subplots(1, 2, figsize=(10, 4.6))
    for k, (img, lab, m) in enumerate(((A, label_a, r["mean_a"]), (B, label_b, r["mean_b"]))):
        im = ax[k].imshow(img, cmap="gray", vmin=0, vmax=vmax, interpolation="nearest")
        ax[k].set_title(f"{lab}: mean radiance {m:.4f}")
        ax[k].axis("off")
    fig.colorbar(im, ax=ax, fraction=0.025, label="radiance / disc radiance")
    fig.savefig(out / "side_by_side.png", dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(1, 2, figsize=(10.5, 4.6))
    im = ax[0].imshow(np.clip(r["rel"], -1, 1), cmap="RdBu_r", vmin=-1, vmax=1, interpolation="nearest")
    ax[0].set_title(f"relative difference ({label_a} - {label_b}) / mean")
    ax[0].axis("off")
    fig.colorbar(im, ax=ax[0], fraction=0.046)
    im = ax[1].imshow(np.clip(np.nan_to_num(r["zmap"], posinf=5, neginf=-5), -5, 5), cmap="RdBu_r",
                      vmin=-5, vmax=5, interpolation="nearest")
    ax[1].set_title("difference / noise sigma, per pixel")
    ax[1].axis("off")
    fig.colorbar(im, ax=ax[1], fraction=0.046)
    fig.tight_layout()
    fig.savefig(out / "difference.png", dpi=110)
    plt.close(fig)


def report_lines(r: dict, label_a: str, label_b: str) -> list[str]:
    mb = r["mean_b"]
    return [
        f"* size {r['shape'][1]} x {r['shape'][0]} pixels; noise from {r['noise']}", "",
        "| | mean radiance | SE |", "|---|---:|---:|",
        f"| {label_a} | {r['mean_a']:.6f} | {r['se_a']:.2e} |",
        f"| {label_b} | {mb:.6f} | {r['se_b']:.2e} |",
        f"| difference | {r['diff']:+.6f} ({r['diff'] / mb * 100 if mb else float('nan'):+.3f} %) "
        f"| z = {r['z']:+.2f} |", "",
        f"* blocks of {r['block']} x {r['block']} pixels: {r['blocks']} with noise, chi2/dof "
        f"{r['block_chi2_dof']:.3f} (normal deviate {r['block_chi2_z']:+.2f}, limit 3.1), max |z| "
        f"{r['block_max_z']:.2f} (limit {r['block_z_limit']:.2f}); {r['blocks_exact']} noiseless blocks, "
        f"{r['blocks_exact_bad']} of them differing",
        f"* per pixel: median |relative difference| {r['rel_median']:.4f}, 95th percentile "
        f"{r['rel_p95']:.4f}; {r['pixels_beyond_4'] * 100:.3f} % of pixels beyond 4 sigma",
        f"* verdict: mean {'pass' if r['pass_mean'] else 'FAIL'}, blocks "
        f"{'pass' if r['pass_blocks'] else 'FAIL'}: **{'PASS' if r['pass'] else 'FAIL'}**",
    ]


@command("compare_images")
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, default=None, help="samples per pixel (noise bound without seeds)")
    ap.add_argument("--a2", default=None, help="A rendered with another seed")
    ap.add_argument("--b2", default=None, help="B rendered with another seed")
    ap.add_argument("--block", type=int, default=8, help="block size in pixels for the block test")
    ap.add_argument("--label-a", default="A")
    ap.add_argument("--label-b", default="B")
    a = ap.parse_args(argv)
    r = compare(a.a, a.b, a.a2, a.b2, a.spp, a.block)
    out = Path(a.out)
    figures(r, out, a.label_a, a.label_b)
    lines = [f"# Image comparison: {a.label_a} vs {a.label_b}", "",
             f"* {a.label_a}: `{a.a}`" + (f", `{a.a2}`" if a.a2 else ""),
             f"* {a.label_b}: `{a.b}`" + (f", `{a.b2}`" if a.b2 else "")]
    lines += report_lines(r, a.label_a, a.label_b)
    lines += ["", "![side by side](side_by_side.png)", "", "![difference](difference.png)", ""]
    text = "\n".join(lines)
    (out / "report.md").write_text(text)
    print(text)
    return 0 if r["pass"] else 1


if __name__ == "__main__":
    sys.exit(main())
