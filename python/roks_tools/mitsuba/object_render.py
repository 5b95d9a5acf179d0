"""Render the exported walls of an object (radiator previews) with Mitsuba 3, matching `roks render`.

    mitsuba_object_render.py WALLS.ply --camera X,Y,Z --look-at X,Y,Z [--up 0,1,0] [--fov 40]
        [--light THETA,PHI] [--disc 5] [--background B] [--res W,H] [--spp N] [--seed S]
        (--diffuse R | --mirror R | --brdf DIR/brdf.csv) --out image.exr

The mesh is `roks export-mesh OBJECT.toml --bounds ...` (closed, outward
faces). Same conventions as `roks render` of an object scene
(src/render.rs, `render_object`): a pinhole camera at --camera looking at
--look-at, vertical field of view --fov degrees, image up along --up; the
light a disc of angular radius --disc at infinity toward world direction
(THETA, PHI) (polar angle from +z), radiance 1, and a uniform background
of radiance --background B outside it (default 0; a `constant` emitter,
hidden behind the disc as `roks render --background` leaves it out of the
disc); pixel values are radiance in the disc's units. Walls: Lambertian
(`diffuse`, reflectance R), a mirror of constant reflectance R
(`conductor`, material none), or a roks BRDF table through the
`roks_table` plugin of `roks_tools.mitsuba.roks_table`.
Integrator `path`, no Russian roulette, max depth 1025. The disc is an
`area` emitter on a `disk` 1e5 x the mesh extent away (as
`roks_tools.mitsuba.render`), so the cone test is exact to ~1e-5 rad. The
camera orientation is checked at start-up: the film centre ray must travel
toward --look-at and the film's right and up edges must lie along
(axis x up) and up.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import RunError, UsageError, command
from .render import direction, frame, mesh_bounds
from .setup import setup_mitsuba


def triple(s: str, name: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in s.split(",")])
    except ValueError:
        v = np.array([])
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise UsageError(f"{name}: give three comma-separated numbers")
    return v


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("--camera", required=True)
    ap.add_argument("--look-at", required=True)
    ap.add_argument("--up", default="0,1,0")
    ap.add_argument("--fov", type=float, default=40.0)
    ap.add_argument("--light", default="0,0")
    ap.add_argument("--disc", type=float, default=5.0)
    ap.add_argument("--background", type=float, default=0.0)
    ap.add_argument("--res", default="256,256")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seed", type=int, default=1)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--diffuse", type=float)
    g.add_argument("--mirror", type=float)
    g.add_argument("--brdf", type=Path)
    ap.add_argument("--max-depth", type=int, default=1025)
    ap.add_argument("--variant", default="auto", choices=("auto", "llvm", "scalar"))
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    a.cam, a.target, a.upv = triple(a.camera, "--camera"), triple(a.look_at, "--look-at"), triple(a.up, "--up")
    a.lt, a.lp = (float(x) for x in a.light.split(","))
    a.w, a.h = (int(x) for x in a.res.split(","))
    return a


def bsdf(a, mi):
    if a.diffuse is not None:
        return {"type": "twosided", "material": {"type": "diffuse",
                                                 "reflectance": {"type": "rgb", "value": [a.diffuse] * 3}}}
    if a.mirror is not None:
        return {"type": "twosided", "material": {"type": "conductor", "material": "none",
                                                 "specular_reflectance": {"type": "rgb", "value": [a.mirror] * 3}}}
    import drjit as dr
    from roks_tools.mitsuba import roks_table as roks_bsdf  # registers `roks_table`
    if "llvm" in mi.variant():
        # a Python BSDF inside JIT-compiled loops: see `roks_tools.mitsuba.roks_table`
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    roks_bsdf.register()
    return {"type": "twosided", "material": {"type": "roks_table", "filename": str(a.brdf)}}


@command("mitsuba_object_render")
def main(argv=None) -> int:
    a = parse_args(argv)
    mi = setup_mitsuba(a.variant)
    T = mi.ScalarTransform4f
    lo, hi = mesh_bounds(mi, a.mesh)
    extent = max(max(h - l for l, h in zip(lo, hi)), float(np.linalg.norm(a.cam - np.array(lo))), 1.0)
    dist = 1e5 * extent
    wl = direction(a.lt, a.lp)
    s, t = frame(-wl)
    rad = dist * math.tan(math.radians(a.disc))
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = s * rad, t * rad, -wl, wl * dist
    sky = {"type": "constant", "radiance": {"type": "rgb", "value": [a.background] * 3}}
    background = {"background": sky} if a.background > 0 else {}
    scene = mi.load_dict({
        "type": "scene",
        **background,
        "integrator": {"type": "path", "max_depth": a.max_depth, "rr_depth": a.max_depth},
        "walls": {"type": "ply", "filename": str(a.mesh), "face_normals": True, "bsdf": bsdf(a, mi)},
        "light": {"type": "disk", "to_world": T(m.tolist()),
                  "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}},
        "sensor": {"type": "perspective", "fov": a.fov, "fov_axis": "y", "near_clip": 1e-3 * extent,
                   "far_clip": 10 * dist,
                   "to_world": T().look_at(origin=a.cam.tolist(), target=a.target.tolist(), up=a.upv.tolist()),
                   "sampler": {"type": "independent", "sample_count": a.spp, "seed": a.seed},
                   "film": {"type": "hdrfilm", "width": a.w, "height": a.h, "pixel_format": "rgb",
                            "component_format": "float32", "rfilter": {"type": "box"}}},
    })
    # orientation check: centre ray along the axis, film right along axis x up
    sensor = scene.sensors()[0]
    axis = (a.target - a.cam) / np.linalg.norm(a.target - a.cam)
    right = np.cross(axis, a.upv)
    right /= np.linalg.norm(right)

    def ray_dir(u, v):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(u, v), mi.Point2f(0.5, 0.5))
        return np.array([float(np.ravel(c)[0]) for c in (ray.d.x, ray.d.y, ray.d.z)])
    if np.max(np.abs(ray_dir(0.5, 0.5) - axis)) > 1e-5 or np.dot(ray_dir(1.0, 0.5) - ray_dir(0.0, 0.5), right) <= 0 \
            or np.dot(ray_dir(0.5, 0.0) - ray_dir(0.5, 1.0), np.cross(right, axis)) <= 0:
        raise RunError("camera orientation check failed")
    t0 = time.time()
    img = mi.render(scene, spp=a.spp, seed=a.seed)
    dt = time.time() - t0
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    mi.util.write_bitmap(str(out), img, write_async=False)
    arr = np.array(img, dtype=np.float64)
    print(f"mitsuba_object_render: {a.w}x{a.h} x {a.spp} spp in {dt:.1f} s, mean {arr[..., 0].mean():.6g} -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
