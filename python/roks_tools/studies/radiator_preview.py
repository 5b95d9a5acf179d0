"""Pictures of the radiator cavity: down the axis (ideal cone vs apex defect), and a cutaway.

    .venv/bin/python scripts/radiator_preview.py [--roks target/release/roks] [--spp 256] [--size 256]
    .venv/bin/python scripts/radiator_preview.py --cutaway [--spp 1024] [--size 512]
        [--mitsuba-spp 64] [--resolution 384]

Both modes write the Z-302 BRDF table out/z302/brdf.csv first if missing
(`roks brdf scenes/z302-micro.toml`); the walls sample it, and the light is a
5 deg disc along the axis (the laser's direction, -z).

Default: renders scenes/radiator-brdf.toml and scenes/radiator-defect-brdf.toml
with `roks render`: a camera on the axis 40 mm above the aperture looking down
into the cavity (30 deg field of view, so the whole image lies inside the
aperture but for the corners). Writes OUT/preview.png (--out, default
./radiator_preview; results/radiator with --overwrite-committed): both
images on a log10 scale of radiance in the disc's units (4 x 4-pixel means
for display), and the EXRs to out/radiator_preview/.

--cutaway: scenes/radiator-cutaway.toml (the ideal cavity with the half x > 0
of the body removed) seen from the open side and above (camera CUT_VIEW), with
a uniform background of 1e-3 of the disc's radiance so the walls the disc
leaves dark still show their shape. `roks render` traces the exact quadrics;
Mitsuba renders the walls exported by `roks export-mesh --bounds` (voxels
along the 143 mm side: --resolution) with scripts/mitsuba_object_render.py
(same camera, disc and background, `roks_table` walls). Writes
OUT/cutaway.png (roks and Mitsuba side by side, log10 radiance,
with the apex region enlarged below) and OUT/cutaway.json (wall
times of each step, image and apex-window means), the EXRs and the mesh to
out/radiator_preview/.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from roks_tools.errors import command
from roks_tools.results import read_exr
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run as run_cmd

REPO = repo_root()

OUT = REPO / "out" / "radiator_preview"
RESULTS = Path("radiator_preview")  # --out
# The cutaway view: from the open (+x) side, 34 deg above the apex; image up +z.
CUT_CAMERA, CUT_LOOK_AT, CUT_UP, CUT_FOV = (300.0, 90.0, 90.0), (0.0, 0.0, -42.0), (0.0, 0.0, 1.0), 31.0
CUT_LIGHT = ["--light", "0,0", "--disc", "5", "--background", "1e-3"]
CUT_BOUNDS = "-52,-52,-137,2,52,2"
APEX_Z = -123.09401076758503


def csv3(v) -> str:
    return ",".join(f"{x:g}" for x in v)


def cut_view() -> list[str]:
    """The camera options shared by `roks render` and mitsuba_object_render.py."""
    return ["--camera", csv3(CUT_CAMERA), "--look-at", csv3(CUT_LOOK_AT), "--up", csv3(CUT_UP),
            "--fov", f"{CUT_FOV:g}", *CUT_LIGHT]


def project(p, w: int, h: int) -> tuple[float, float]:
    """Pixel coordinates (x right, y down) of world point `p` in the cutaway view (PinholeCamera's model)."""
    cam, f = np.array(CUT_CAMERA), np.array(CUT_LOOK_AT) - np.array(CUT_CAMERA)
    f /= np.linalg.norm(f)
    r = np.cross(f, CUT_UP)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.asarray(p, dtype=float) - cam
    t = np.tan(np.radians(CUT_FOV / 2))
    sx, sy = d @ r / (d @ f), d @ u / (d @ f)
    return (sx / (t * w / h) + 1) * w / 2, (1 - sy / t) * h / 2


def ensure_table(a) -> None:
    if not (REPO / "out" / "z302" / "brdf.csv").exists():
        run_cmd([a.roks, "brdf", "scenes/z302-micro.toml", "--out", "out/z302", "-q"], "radiator_preview",
                    cwd=REPO)


def log_radiance(img: np.ndarray) -> np.ndarray:
    return np.log10(np.maximum(img, 1e-7))


def axis_previews(a, plt) -> Path:
    imgs = []
    for scene, title in (("radiator-brdf", "ideal cone"), ("radiator-defect-brdf", "45 deg apex defect")):
        exr = OUT / f"{scene}.exr"
        run_cmd([a.roks, "render", f"scenes/{scene}.toml", "--camera", "0,0,40", "--look-at", "0,0,-115",
                     "--fov", "30", "--light", "0,0", "--disc", "5", "--background", "0", "--size", f"{a.size},{a.size}",
                     "--spp", a.spp, "--out", exr], "radiator_preview", cwd=REPO)
        imgs.append((read_exr(exr), title))
    fig, ax = plt.subplots(1, 2, figsize=(10, 4.6))
    k = 4
    for i, (img, title) in enumerate(imgs):
        n = (img.shape[0] // k) * k
        b = img[:n, :n].reshape(n // k, k, n // k, k).mean(axis=(1, 3))
        im = ax[i].imshow(log_radiance(b), vmin=-6, vmax=-3, cmap="inferno")
        c = img[n // 2 - n // 16:n // 2 + n // 16, n // 2 - n // 16:n // 2 + n // 16].mean()
        ax[i].set_title(f"{title}: centre {c:.2e}")
        ax[i].axis("off")
    fig.colorbar(im, ax=ax, label="log10 radiance / disc radiance")
    fig.suptitle("Radiator cavity seen from 40 mm above the aperture, lit along the axis (roks render, Z-302 table walls)")
    dest = RESULTS / "preview.png"
    fig.savefig(dest, dpi=90)
    return dest


def cutaway(a, plt) -> Path:
    scene, n = "scenes/radiator-cutaway.toml", a.size
    roks_exr, mi_exr = OUT / "cutaway_roks.exr", OUT / "cutaway_mitsuba.exr"
    mesh = OUT / f"cutaway_walls_{a.resolution}.ply"
    run = lambda cmd: run_cmd(cmd, "radiator_preview", cwd=REPO).wall_s  # noqa: E731
    t = {"roks_render": run([a.roks, "render", scene, *cut_view(), "--size", f"{n},{n}", "--spp", a.spp,
                             "--out", roks_exr]),
         "export_mesh": run([a.roks, "export-mesh", scene, f"--bounds={CUT_BOUNDS}", "--resolution",
                             a.resolution, "--out", mesh]),
         "mitsuba_render": run([sys.executable, "-m", "roks_tools.mitsuba.object_render", mesh, *cut_view(),
                                "--res", f"{n},{n}", "--spp", a.mitsuba_spp, "--brdf", "out/z302/brdf.csv",
                                "--out", mi_exr])}
    imgs = {"roks": read_exr(roks_exr), "mitsuba": read_exr(mi_exr)}
    # The apex window: n/4 x n/4 pixels around the lit bottom of the back cone.
    cx, cy = project((0.0, 0.0, APEX_Z + 6.0), n, n)
    m = n // 8
    x0, y0 = int(round(cx)) - m, int(round(cy)) - m
    win = (slice(y0, y0 + 2 * m), slice(x0, x0 + 2 * m))
    stats = {k: {"mean": float(v.mean()), "apex_window_mean": float(v[win].mean())} for k, v in imgs.items()}
    labels = {"roks": f"roks render: exact quadrics, {a.spp} spp, {t['roks_render']:.0f} s",
              "mitsuba": f"Mitsuba 3: {a.resolution}-voxel wall mesh, {a.mitsuba_spp} spp, "
                         f"{t['mitsuba_render']:.0f} s"}
    fig, ax = plt.subplots(2, 2, figsize=(11, 9.4), gridspec_kw={"height_ratios": [2, 1]}, layout="constrained")
    for col, (k, img) in enumerate(imgs.items()):
        im = ax[0, col].imshow(log_radiance(img), vmin=-6, vmax=-1.5, cmap="inferno")
        ax[0, col].set_title(labels[k], fontsize=10)
        ax[0, col].add_patch(plt.Rectangle((x0, y0), 2 * m, 2 * m, fill=False, ec="w", lw=0.8, ls=":"))
        (ax0, ay0), (ax1, ay1) = project((0.0, 0.0, 30.0), n, n), project((0.0, 0.0, 5.0), n, n)
        ax[0, col].annotate("", xy=(ax1, ay1), xytext=(ax0, ay0),
                            arrowprops={"arrowstyle": "->", "color": "c", "lw": 1.5})
        ax[0, col].text(ax0 + 8, ay0, "light along the axis\n(laser direction)", color="w", fontsize=8, va="top",
                         bbox={"fc": "k", "ec": "none", "alpha": 0.6})
        ax[1, col].imshow(log_radiance(img[win]), vmin=-6, vmax=-1.5, cmap="inferno", interpolation="nearest")
        ax[1, col].set_title(f"apex window (dotted), mean {stats[k]['apex_window_mean']:.3g}\n"
                             f"(whole image mean {stats[k]['mean']:.3g})", fontsize=9)
        for r in ax[:, col]:
            r.axis("off")
    fig.colorbar(im, ax=ax, shrink=0.5, label="log10 radiance / disc radiance")
    fig.suptitle("Radiator cavity (scenes/radiator-cutaway.toml), half of the body (x > 0) removed; Z-302 table walls\n"
                 "lit by a 5 deg disc along the axis through the aperture, and a uniform background of 1e-3",
                 fontsize=11)
    dest = RESULTS / "cutaway.png"
    fig.savefig(dest, dpi=120)  # each image panel over 512 pixels wide
    (RESULTS / "cutaway.json").write_text(json.dumps(
        {"size": n, "roks_spp": a.spp, "mitsuba_spp": a.mitsuba_spp, "mesh_resolution": a.resolution,
         "wall_seconds": t, "images": stats}, indent=1) + "\n")
    return dest


@command("radiator_preview")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", default=str(default_roks()))
    ap.add_argument("--cutaway", action="store_true", help="the cutaway picture instead of the axis previews")
    ap.add_argument("--spp", type=int, help="roks samples per pixel (default 256; cutaway 1024)")
    ap.add_argument("--size", type=int, help="image side in pixels (default 256; cutaway 512)")
    ap.add_argument("--mitsuba-spp", type=int, default=64, help="cutaway: Mitsuba samples per pixel")
    ap.add_argument("--resolution", type=int, default=384, help="cutaway: voxels of the exported mesh")
    add_out_argument(ap, "radiator_preview")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    global RESULTS
    RESULTS = a.out
    RESULTS.mkdir(parents=True, exist_ok=True)
    a.spp = a.spp or (1024 if a.cutaway else 256)
    a.size = a.size or (512 if a.cutaway else 256)
    OUT.mkdir(parents=True, exist_ok=True)
    ensure_table(a)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    dest = (cutaway if a.cutaway else axis_previews)(a, plt)
    print(f"radiator_preview: wrote {dest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
