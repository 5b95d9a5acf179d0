"""A rough gold sphere rendered twice in Mitsuba 3: with the `roks_table`
plugin (a spectral roks table of a Gaussian gold micro surface) and with
Mitsuba's own `roughconductor` (material Au, Beckmann, matched alpha), side by
side, with the difference measured and explained.

    .venv/bin/python scripts/gold_sphere.py [--out gold_sphere] [--size 160] [--spp 64]
        [--photons 100000] [--roks target/release/roks] [--keep-runs]

Steps:
1. `roks brdf` on a periodic Gaussian height field (sigma 1, tau 5 on a 128 x
   128 cell, 256^2 grid squares: about 650 correlation areas, so that one
   realisation is nearly isotropic; a small cell's anisotropy shows as swirls
   following the sphere's tangent frames), material `nk =` Mitsuba's own
   data/ior/Au.eta.spd + Au.k.spd (the same n, k as roughconductor's preset
   `Au`, so the comparison is one of models, not of gold data; roks's
   scenes/materials/gold.csv, Johnson & Christy, differs by up to 0.06 in
   reflectance: see the spectral cross-check), wavelengths 0.38-0.78 um
   every 0.02 um, incidence 0-85 deg, roks's default polarised transport.
2. alpha: the Beckmann distribution is the normal distribution of a surface
   with Gaussian slopes, which a Gaussian height field has (GGX's long tails
   are not); its alpha^2 = <tan^2 theta_m> = 2 s^2 with s the rms slope per
   axis, i.e. alpha = sqrt(2) s = rms |grad h|. It is measured on the
   field's own facets (the mesh of `roks export-mesh`: equal projected areas,
   so the mean of tan^2 over the triangles), not taken from the nominal
   2 sigma / tau.
3. Two renders, llvm_ad_spectral (scalar_spectral fallback), one sphere of
   radius 1, orthographic camera along -z, a directional sun from 35 deg
   and a dim constant sky, `path` integrator, two seeds each (noise from the
   seed differences); the plugin runs in wavefront mode.
4. Measured: the relative difference (roks - roughconductor) / roughconductor
   of the mean luminance Y of the sphere's pixels, and per region of the
   sphere: by the angle between the normal and the view (centre cos > 0.8,
   middle 0.45-0.8, rim < 0.45) and the highlight (the normal within 15 deg
   of the half vector of sun and view) vs the rest; and per RGB channel.
   Expected from theory (reported): roks includes multiple scattering,
   which the microfacet model leaves out: roks's hemispherical reflectance
   against the Beckmann single-scattering albedo at 0.55 um
   (`roks_tools.microfacet.albedo_ss`, height-correlated Smith) per
   incidence; also the field's statistics are a finite Gaussian sample, not
   Beckmann's exact distribution, and the table is binned (Carlson cells).

Writes OUT/gold_sphere.png (roks | roughconductor | relative difference),
OUT/gold_sphere.md and OUT/gold_sphere.json.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np

from roks_tools.errors import RunError, command
from roks_tools.runner import add_out_argument, check_output, repo_root, run as run_cmd

ROOT = repo_root()
SUN_DEG = 35.0
THETAS = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_out_argument(ap, "gold_sphere")
    ap.add_argument("--size", type=int, default=160, help="image side in pixels")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--photons", type=int, default=400_000, help="roks photons per incidence")
    ap.add_argument("--bands", type=int, default=16)
    ap.add_argument("--field", type=float, default=128.0,
                    help="side of the periodic cell (tau = 5): large, so that one realisation is nearly isotropic")
    ap.add_argument("--resolution", type=int, default=256, help="grid squares per side of the field")
    ap.add_argument("--roks", type=Path, default=None)
    ap.add_argument("--keep-runs", action="store_true")
    ap.add_argument("-q", "--quiet", action="store_true")
    a = ap.parse_args(argv)
    check_output(a.out, a.overwrite_committed)
    return a


def facet_alpha(mesh: Path) -> tuple[float, float]:
    """(alpha = sqrt(<tan^2 theta_m>), rms slope per axis) of a height-field mesh's triangles."""
    import mitsuba as mi

    m = mi.load_dict({"type": "ply", "filename": str(mesh), "face_normals": True})
    v = np.array(m.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
    f = np.array(m.faces_buffer(), dtype=np.int64).reshape(-1, 3)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= n[:, 2:3]
    if not np.all(np.isfinite(n)):
        raise RunError(f"{mesh}: a vertical facet")
    tan2 = n[:, 0] ** 2 + n[:, 1] ** 2
    return float(math.sqrt(tan2.mean())), float(math.sqrt(0.5 * tan2.mean()))


def scene_dict(mi, bsdf: dict, size: int, spp: int, seed: int) -> dict:
    T = mi.ScalarTransform4f
    s = math.radians(SUN_DEG)
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {
            "type": "orthographic",
            "to_world": T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]) @ T().scale([1.05, 1.05, 1]),
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
        },
        "sun": {"type": "directional", "direction": [-math.sin(s), 0.0, -math.cos(s)], "irradiance": 3.0},
        "sky": {"type": "constant", "radiance": 0.15},
        "ball": {"type": "sphere", "radius": 1.0, "bsdf": bsdf},
    }


def render(mi, bsdf: dict, size: int, spp: int, seed: int) -> np.ndarray:
    scene = mi.load_dict(scene_dict(mi, bsdf, size, spp, seed))
    img = mi.render(scene, spp=spp, seed=seed)
    return np.array(img, dtype=np.float64)[..., :3]  # linear sRGB


def regions(size: int, sun_right: bool = True) -> dict[str, np.ndarray]:
    """Pixel masks of the sphere's regions (orthographic view along -z, image
    row 0 at +y; the sun's side, world +x, on the right unless `sun_right` is false)."""
    half = 1.05
    c = (np.arange(size) + 0.5) / size * 2 * half - half
    x, y = np.meshgrid(c if sun_right else -c, c[::-1])
    r2 = x * x + y * y
    inside = r2 < 0.98 ** 2  # off the silhouette's anti-aliased pixels
    nz = np.sqrt(np.clip(1 - r2, 0, 1))
    s = math.radians(SUN_DEG)
    h = np.array([math.sin(s), 0.0, 1.0 + math.cos(s)])
    h /= np.linalg.norm(h)
    cos_h = x * h[0] + y * h[1] + nz * h[2]
    highlight = inside & (cos_h > math.cos(math.radians(15)))
    return {"sphere": inside, "centre (cos_v > 0.8)": inside & (nz > 0.8),
            "middle (0.45-0.8)": inside & (nz > 0.45) & (nz <= 0.8), "rim (cos_v < 0.45)": inside & (nz <= 0.45),
            "highlight (15 deg of h)": highlight, "off highlight": inside & ~highlight}


def luminance(img: np.ndarray) -> np.ndarray:
    return img @ np.array([0.2126, 0.7152, 0.0722])  # Y of linear sRGB (IEC 61966-2-1)


@command("gold_sphere")
def main(argv=None) -> int:
    from roks_tools.runner import roks_binary
    from roks_tools.mitsuba.setup import setup_mitsuba
    from roks_tools.studies.spectral_crosscheck import mitsuba_ior_dir

    a = parse_args(argv)
    roks = a.roks or roks_binary()
    out, work = a.out, a.out / "gold_sphere_runs"
    work.mkdir(parents=True, exist_ok=True)
    ior = mitsuba_ior_dir()
    scene = work / "gold_field.toml"
    scene.write_text(f"""# gold sphere study: a Gaussian field of Mitsuba's gold (roks_tools.studies.gold_sphere)
[surface]
size = [{a.field}, {a.field}]
edges = "periodic"
material = "au"
heightfield = {{ gaussian = {{ sigma = 1.0, tau = 5.0 }}, resolution = {a.resolution}, seed = 3 }}
[materials.au]
nk = "{ior / 'Au.eta.spd'}"
[light]
theta_deg = {THETAS}
photons = {a.photons}
wavelengths_um = {{ from = 0.38, to = 0.78, step = 0.02 }}
[tally]
bands = {a.bands}
""")
    table = work / "roks_gold"
    seconds = {}
    seconds["roks brdf"] = run_cmd([roks, "brdf", scene, "--out", table, "-q"], "gold_sphere", echo=not a.quiet).wall_s
    run_cmd([roks, "export-mesh", scene, "--out", work / "mesh.ply"], "gold_sphere", echo=False)

    mi = setup_mitsuba("auto", spectral=True)
    import drjit as dr

    if dr.is_array_v(mi.Float):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    from roks_tools.mitsuba import roks_table

    roks_table.register()
    alpha, slope = facet_alpha(work / "mesh.ply")
    bsdfs = {"roks": {"type": "roks_table", "filename": str(table / "brdf.csv")},
             "roughconductor": {"type": "roughconductor", "material": "Au", "distribution": "beckmann",
                                "alpha": alpha, "sample_visible": True}}
    import time

    imgs = {}
    for name, b in bsdfs.items():
        t0 = time.perf_counter()
        imgs[name] = [render(mi, b, a.size, a.spp, seed) for seed in (1, 2)]
        seconds[f"render {name} (2 seeds)"] = time.perf_counter() - t0
    # which image side world +x (the sun) is on: the brighter half of Mitsuba's own render
    yb = luminance(imgs["roughconductor"][0])
    sun_right = bool(yb[:, a.size // 2:].sum() > yb[:, : a.size // 2].sum())
    masks = regions(a.size, sun_right)
    res = {"alpha": alpha, "rms_slope_per_axis": slope, "nominal_alpha": 2 * 1.0 / 5.0, "variant": mi.variant(),
           "size": a.size, "spp": a.spp, "regions": {}}
    A = [luminance(x) for x in imgs["roks"]]
    B = [luminance(x) for x in imgs["roughconductor"]]
    for name, m in masks.items():
        n = int(m.sum())
        ma, mb = 0.5 * (A[0][m].mean() + A[1][m].mean()), 0.5 * (B[0][m].mean() + B[1][m].mean())
        # noise of a two-seed mean from the seed difference (independent renders)
        se_a = abs(A[0][m].mean() - A[1][m].mean()) / 2 if n else 0.0
        se_b = abs(B[0][m].mean() - B[1][m].mean()) / 2 if n else 0.0
        sd_a = float(np.std(A[0][m] - A[1][m]) / math.sqrt(4 * n)) if n else 0.0
        sd_b = float(np.std(B[0][m] - B[1][m]) / math.sqrt(4 * n)) if n else 0.0
        rgb_a = 0.5 * (imgs["roks"][0][m].mean(0) + imgs["roks"][1][m].mean(0))
        rgb_b = 0.5 * (imgs["roughconductor"][0][m].mean(0) + imgs["roughconductor"][1][m].mean(0))
        res["regions"][name] = {"pixels": n, "roks_Y": float(ma), "roughconductor_Y": float(mb),
                                "rel_diff": float((ma - mb) / mb), "rel_se": float(math.hypot(sd_a, sd_b) / mb),
                                "rel_diff_rgb": ((rgb_a - rgb_b) / rgb_b).tolist(),
                                "seed_spread": [float(se_a), float(se_b)]}
    # theory: roks's hemispherical reflectance vs Beckmann single scattering at 0.55 um
    from roks_tools import microfacet as mf

    summ = json.loads((table / "summary.json").read_text())
    eta, kk = (np.loadtxt(ior / f"Au.{p}.spd", comments="#") for p in ("eta", "k"))
    n55, k55 = float(np.interp(550, eta[:, 0], eta[:, 1])), float(np.interp(550, kk[:, 0], kk[:, 1]))
    fres = mf.make_fresnel(n=n55, k=k55)
    theory = []
    for e in summ["incidence"]:
        r55 = [s for s in e["spectrum"] if abs(s["wavelength_um"] - 0.54) < 1e-9 or abs(s["wavelength_um"] - 0.56) < 1e-9]
        r = float(np.mean([s["reflectance"] for s in r55]))
        ss = float(mf.albedo_ss(math.radians(e["theta_deg"]), alpha, fres))
        theory.append({"theta_deg": e["theta_deg"], "roks_R_055": r, "beckmann_ss_055": ss,
                       "excess": (r - ss) / ss, "mean_bounces": e["mean_bounces"]})
    res["theory"] = theory
    res["seconds"] = seconds
    figure(imgs, out / "gold_sphere.png", res)
    (out / "gold_sphere.json").write_text(json.dumps(res, indent=1, sort_keys=True))
    (out / "gold_sphere.md").write_text(report(res))
    if not a.keep_runs:
        shutil.rmtree(work)
    if not a.quiet:
        print(report(res))
    return 0


def figure(imgs: dict, path: Path, res: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a = 0.5 * (imgs["roks"][0] + imgs["roks"][1])
    b = 0.5 * (imgs["roughconductor"][0] + imgs["roughconductor"][1])
    top = max(np.percentile(a, 99.5), np.percentile(b, 99.5))

    def srgb(x):
        x = np.clip(x / top, 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)

    ya, yb = luminance(a), luminance(b)
    m = regions(a.shape[0])["sphere"]  # symmetric in x
    rel = np.where(m, (ya - yb) / np.where(yb > 0, yb, 1.0), np.nan)
    fig, ax = plt.subplots(1, 3, figsize=(12, 4.3))
    ax[0].imshow(srgb(a))
    ax[0].set_title("roks_table (roks: Gaussian gold field)")
    ax[1].imshow(srgb(b))
    ax[1].set_title(f"roughconductor Au, Beckmann alpha {res['alpha']:.3f}")
    lim = max(0.05, float(np.nanpercentile(np.abs(rel), 98)))
    im = ax[2].imshow(rel, cmap="RdBu_r", vmin=-lim, vmax=lim)
    ax[2].set_title(f"(roks - rough) / rough, Y: mean {res['regions']['sphere']['rel_diff'] * 100:+.1f} %")
    fig.colorbar(im, ax=ax[2], fraction=0.046)
    for x in ax:
        x.set_xticks([])
        x.set_yticks([])
    fig.suptitle(f"Gold sphere, Mitsuba {res['variant']}, {res['size']}^2 px, {res['spp']} spp x 2 seeds, "
                 "sun 35 deg + sky, same exposure")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def report(res: dict) -> str:
    L = ["# Gold sphere: roks_table vs roughconductor", "",
         f"Mitsuba {res['variant']}; roughconductor `Au`, Beckmann alpha = {res['alpha']:.4f} (the field's "
         f"facets: sqrt(<tan^2>) = sqrt(2) x rms slope per axis {res['rms_slope_per_axis']:.4f}; nominal 2 sigma / tau "
         f"= {res['nominal_alpha']:.3f}). roks's table: the same Au n, k.", "",
         "![gold sphere](gold_sphere.png)", "",
         "| region | pixels | roks Y | roughconductor Y | (roks - rc) / rc | noise (1 SE) | R, G, B |",
         "|---|---:|---:|---:|---:|---:|---|"]
    for name, r in res["regions"].items():
        L.append(f"| {name} | {r['pixels']} | {r['roks_Y']:.4f} | {r['roughconductor_Y']:.4f} | "
                 f"{r['rel_diff'] * 100:+.2f} % | {r['rel_se'] * 100:.2f} % | "
                 + ", ".join(f"{v * 100:+.1f} %" for v in r["rel_diff_rgb"]) + " |")
    L += ["", "Theory at 0.55 um: roks's hemispherical reflectance (multiple scattering included) against "
          "the Beckmann single-scattering albedo (height-correlated Smith) of the same alpha and n, k:", "",
          "| theta_i | roks R | Beckmann single scattering | excess | roks mean bounces |", "|---:|---:|---:|---:|---:|"]
    for t in res["theory"]:
        L.append(f"| {t['theta_deg']:g} | {t['roks_R_055']:.4f} | {t['beckmann_ss_055']:.4f} | "
                 f"{t['excess'] * 100:+.2f} % | {t['mean_bounces']:.3f} |")
    reg = res["regions"]
    L += ["", "Why they differ:", "",
          "* Multiple scattering. roughconductor is the single-scattering microfacet model; roks traces "
          "every reflection on the field, and a second or third bounce on gold (R ~ 0.85 at 0.55 um) returns "
          "most of the light single scattering loses. The excess above grows with incidence to about 10 % at "
          "60-70 deg: on the sphere the light and the view are grazing toward the rim, where roks is brighter by "
          f"{reg['rim (cos_v < 0.45)']['rel_diff'] * 100:+.1f} %, against {reg['centre (cos_v > 0.8)']['rel_diff'] * 100:+.1f} % "
          "at the centre; R, G and B differ alike (over the sphere "
          + ", ".join(f"{v * 100:+.1f} %" for v in reg["sphere"]["rel_diff_rgb"])
          + "): at these reflectances the extra bounces hardly change the hue.",
          "* Statistics. The table is one finite realisation of a Gaussian field (its own alpha, measured on "
          "its facets); Beckmann is the exact distribution of Gaussian slopes; the sample is not exactly "
          "isotropic, and the plugin turns its one light azimuth with the sphere's tangent frame.",
          "* Binning. The table is constant on Carlson cells (here 16 bands, about 5.6 deg in theta) and "
          "linear between the tabulated incidences (10 deg steps): the facetted look of the roks sphere, and "
          "large relative differences on the flanks of the highlight where the lobe falls steeply (cell "
          "averages raise the far side of a cell); the highlight itself agrees to "
          f"{reg['highlight (15 deg of h)']['rel_diff'] * 100:+.1f} %.", ""]
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    sys.exit(main())
