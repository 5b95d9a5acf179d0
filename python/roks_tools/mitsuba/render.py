"""Render a periodic height-field mesh with Mitsuba 3's `path` integrator, matching `roks render`.

Cross-check for `roks render`.

    mitsuba_render.py MESH.ply --size LX,LY [--view THETA,PHI] [--light THETA,PHI]
        [--disc 5] [--res W,H] [--spp N] [--rho R] [--seed S] [--top Z]
        [--block B] [--max-depth D] [--variant auto|llvm|scalar] --out image.exr

Same conventions as src/render.rs (directions (sin t cos p, sin t sin p, cos t),
pointing away from the surface; angles in degrees):

* Camera: `orthographic` sensor with a sheared `to_world`, built so that the
  ray of film position (u, v) in [0, 1]^2 (u right, v down, row 0 at the top)
  travels along -view and crosses the plane z = top at (u Lx, (1 - v) Ly)
  (it starts 1e-3 x the block extent higher, on that same line: a ray
  starting exactly on a flat top would miss it; checked at start-up). `top` defaults to the
  mesh's highest point; pass roks's `surface.top` with --top if it differs
  (an offset dz only shifts the image periodically by dz tan(theta_v), the
  mean is unchanged). Pixel filter `box`: each sample lands in its own pixel,
  as roks's jittered sub-pixel positions.
* Surface: `conductor` with `material = "none"` (Fresnel reflectance exactly 1
  at every angle; checked at start-up with BSDF.sample) times
  `specular_reflectance = rho`: exactly rho per bounce, as roks's constant
  reflectance. Wrapped in `twosided` (a ray can never see the underside of a
  height field, but a float32 seam leak would otherwise be black anyway).
  Geometric face normals (`face_normals = True`), as mitsuba_brdf.py.
* Periodic substrate: one `shapegroup` and (2B+1)^2 `instance`s at
  (i Lx, j Ly). The block must contain every point a camera ray can reach
  before its first hit: from the top plane to the lowest point the ray moves
  (top - zmin) tan(theta_v) sideways, so B defaults to
  1 + ceil((top - zmin) tan(theta_v) / min(Lx, Ly)). Later bounces can still
  leave the block sideways (grazing multiple reflections); in the truncated
  geometry such a ray escapes where the periodic surface might have caught
  it. That is the one approximation of this render (roks wraps periodically);
  check it by raising --block (see scenes_mitsuba/README.md).
* Light: an `area` emitter on a `disk` of radius D tan(r) at distance D along
  omega_l, facing the origin, radiance 1. A ray leaving from a point p hits
  it iff its direction is within r of omega_l up to an error of order
  |p| / D radians; D = 1e5 x the block's extent (float32 hit positions are
  then still ~1e-2 of the disc radius), so the cone test is exact to ~1e-5
  rad. Seen through a delta BSDF only: no emitter sampling can help, the
  `path` integrator adds the emission when a ray hits the disc (MIS weight 1
  after a specular bounce).
* Integrator: `path`, max_depth 1025 (1024 bounces) and rr_depth = max_depth
  (no Russian roulette), `hide_emitters` false. A path cut at max_depth loses
  at most rho^1024 of its weight.

Output: RGB float32 EXR (three equal channels), mi.util.write_bitmap(...,
write_async=False). Prints the image mean and timing.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import RunError, UsageError, command
from .setup import setup_mitsuba


def direction(theta_deg: float, phi_deg: float) -> np.ndarray:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def pair(s: str, name: str, typ=float):
    try:
        a, b = (typ(x) for x in s.split(","))
    except ValueError:
        raise UsageError(f"{name} must be A,B (got {s!r})")
    return a, b


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("--size", required=True, help="period LX,LY")
    ap.add_argument("--view", default="0,0", help="THETA,PHI toward the camera (degrees)")
    ap.add_argument("--light", default="0,0", help="THETA,PHI toward the light's centre")
    ap.add_argument("--disc", type=float, default=5.0, help="angular radius of the light (degrees)")
    ap.add_argument("--res", default="256,256", help="W,H pixels")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rho", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--top", type=float, default=None, help="launch plane z (default: mesh max)")
    ap.add_argument("--block", type=int, default=None, help="instances i, j in -B..B (default: auto)")
    ap.add_argument("--max-depth", type=int, default=1025)
    ap.add_argument("--variant", default="auto", choices=("auto", "llvm", "scalar"))
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    a.lx, a.ly = pair(a.size, "--size")
    a.vt, a.vp = pair(a.view, "--view")
    a.lt, a.lp = pair(a.light, "--light")
    a.w, a.h = pair(a.res, "--res", int)
    if not (0 <= a.vt < 90):
        raise UsageError("view theta must be in [0, 90)")
    if not (0 < a.disc < 90):
        raise UsageError("--disc must be in (0, 90) for a disc emitter")
    if a.w < 1 or a.h < 1 or a.spp < 1:
        raise UsageError("--res and --spp must be positive")
    return a


def frame(n: np.ndarray):
    """Two unit vectors completing n to a right-handed orthonormal frame."""
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    s = np.cross(a, n)
    s /= np.linalg.norm(s)
    return s, np.cross(n, s)


def build_scene(mi, a, zmin, zmax, top, block):
    T = mi.ScalarTransform4f
    L = 2 * block + 1
    extent = max(L * a.lx, L * a.ly, top - zmin, 1.0)
    dist = 1e5 * extent
    wl = direction(a.lt, a.lp)
    # disc at dist * wl, normal (local +z) toward the origin: -wl
    s, t = frame(-wl)
    rad = dist * math.tan(math.radians(a.disc))
    m = np.eye(4)
    m[:3, 0] = s * rad
    m[:3, 1] = t * rad
    m[:3, 2] = -wl
    m[:3, 3] = wl * dist
    mesh = {"type": "ply", "filename": str(a.mesh), "face_normals": True,
            "bsdf": bsdf_dict(a.rho)}
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": a.max_depth, "rr_depth": a.max_depth,
                       "hide_emitters": False},
        "surface": {"type": "shapegroup", "mesh": mesh},
        "light": {"type": "disk", "to_world": T(m.tolist()),
                  "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}},
    }
    for i in range(-block, block + 1):
        for j in range(-block, block + 1):
            scene[f"inst_{i + block}_{j + block}"] = {
                "type": "instance", "shapegroup": {"type": "ref", "id": "surface"},
                "to_world": T().translate([i * a.lx, j * a.ly, 0.0]),
            }
    scene["sensor"] = sensor_dict(mi, a, top, extent)
    return mi.load_dict(scene), dist


def sensor_base(mi, a, to_world, far):
    return {
        "type": "orthographic", "to_world": to_world, "near_clip": 1e-4, "far_clip": far,
        "sampler": {"type": "independent", "sample_count": a.spp, "seed": a.seed},
        "film": {"type": "hdrfilm", "width": a.w, "height": a.h, "pixel_format": "rgb",
                 "component_format": "float32", "rfilter": {"type": "box"}},
    }


def _rays(mi, sensor, pts):
    out = []
    for u, v in pts:
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(u, v), mi.Point2f(0.5, 0.5))
        o = np.array([float(np.ravel(ray.o.x)[0]), float(np.ravel(ray.o.y)[0]), float(np.ravel(ray.o.z)[0])])
        d = np.array([float(np.ravel(ray.d.x)[0]), float(np.ravel(ray.d.y)[0]), float(np.ravel(ray.d.z)[0])])
        out.append((o, d))
    return out


def sensor_dict(mi, a, top, extent):
    """Orthographic sensor whose film (u, v) starts rays at (u Lx, (1-v) Ly, top) along -view.

    The film -> local map of Mitsuba's orthographic sensor (aspect ratio, sign
    flips, near clip) is measured with an identity to_world, then the affine
    to_world that sends it onto the target plane is solved for.
    """
    T = mi.ScalarTransform4f
    far = 1e3 * extent
    probe = mi.load_dict(sensor_base(mi, a, T(), far))
    (p0, d0), (pu, _), (pv, _) = _rays(mi, probe, [(0, 0), (1, 0), (0, 1)])
    view = direction(a.vt, a.vp)
    # rays start a little above the plane, on the line through their point
    # of the plane z = top (a ray starting exactly on a flat top would miss it)
    lift = view * (1e-3 * extent / view[2])
    w0 = np.array([0.0, a.ly, top]) + lift
    wu = np.array([a.lx, a.ly, top]) + lift
    wv = np.array([0.0, 0.0, top]) + lift
    local = np.column_stack([pu - p0, pv - p0, d0])
    world = np.column_stack([wu - w0, wv - w0, -view])
    M = world @ np.linalg.inv(local)
    m = np.eye(4)
    m[:3, :3] = M
    m[:3, 3] = w0 - M @ p0
    return sensor_base(mi, a, T(m.tolist()), far)


def check_sensor(mi, sensor, a, top):
    """Each ray must cross z = top at (u Lx, (1 - v) Ly) and travel along -view."""
    view = direction(a.vt, a.vp)
    pts = [(0, 0), (1, 0), (0, 1), (1, 1), (0.25, 0.75)]
    for (u, v), (o, d) in zip(pts, _rays(mi, sensor, pts)):
        if d[2] >= 0 or o[2] <= top:
            raise RunError(f"camera ray {o} + t {d} does not come down onto z = {top}")
        o = o + d * ((top - o[2]) / d[2])
        want = np.array([u * a.lx, (1 - v) * a.ly, top])
        scale = max(a.lx, a.ly, abs(top), 1.0)
        if np.max(np.abs(o - want)) > 1e-4 * scale or np.max(np.abs(d + view)) > 1e-5:
            raise RunError(f"camera check failed at film ({u}, {v}): "
                             f"origin {o}, want {want}; dir {d}, want {-view}")


def bsdf_dict(rho):
    return {"type": "twosided",
            "material": {"type": "conductor", "material": "none",
                         "specular_reflectance": {"type": "rgb", "value": [rho] * 3}}}


def check_bsdf(mi, rho):
    """conductor/none must reflect exactly rho at every angle, from both sides."""
    bsdf = mi.load_dict(bsdf_dict(rho))
    ctx = mi.BSDFContext()
    for th in (0.0, 30.0, 60.0, 85.0, 89.0, -30.0):
        si = mi.SurfaceInteraction3f()
        c = math.cos(math.radians(th))
        si.wi = mi.Vector3f(math.sin(math.radians(th)), 0.0, c if th >= 0 else -c)
        si.n = mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        bs, val = bsdf.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
        r = float(np.ravel(val.x)[0])
        if abs(r - rho) > 1e-6 * max(rho, 1.0):
            raise RunError(f"conductor reflects {r} at {th} deg, want {rho}")


def mesh_bounds(mi, path):
    m = mi.load_dict({"type": "ply", "filename": str(path)})
    bb = m.bbox()
    lo = [float(np.ravel(c)[0]) for c in (bb.min.x, bb.min.y, bb.min.z)]
    hi = [float(np.ravel(c)[0]) for c in (bb.max.x, bb.max.y, bb.max.z)]
    return lo, hi


@command("mitsuba_render")
def main(argv=None) -> int:
    a = parse_args(argv)
    mi = setup_mitsuba(a.variant)
    lo, hi = mesh_bounds(mi, a.mesh)
    if abs(lo[0]) > 1e-4 * a.lx or abs(lo[1]) > 1e-4 * a.ly or abs(hi[0] - a.lx) > 1e-4 * a.lx \
            or abs(hi[1] - a.ly) > 1e-4 * a.ly:
        print(f"mitsuba_render: warning: mesh bbox x [{lo[0]}, {hi[0]}], y [{lo[1]}, {hi[1]}] "
              f"is not the period [0, {a.lx}] x [0, {a.ly}]", file=sys.stderr)
    zmin, zmax = lo[2], hi[2]
    top = zmax if a.top is None else a.top
    if top < zmax:
        raise UsageError(f"--top {top} is below the mesh's highest point {zmax}")
    reach = (top - zmin) * math.tan(math.radians(a.vt))
    block = a.block if a.block is not None else 1 + math.ceil(reach / min(a.lx, a.ly))
    scene, dist = build_scene(mi, a, zmin, zmax, top, block)
    check_sensor(mi, scene.sensors()[0], a, top)
    check_bsdf(mi, a.rho)
    print(f"mitsuba_render: {mi.variant()}, {(2 * block + 1) ** 2} instances (B = {block}, "
          f"camera reach {reach:.4g}), heights [{zmin:.6g}, {zmax:.6g}], top {top:.6g}, "
          f"disc at {dist:.3g}", file=sys.stderr)
    t0 = time.time()
    img = mi.render(scene, spp=a.spp, seed=a.seed)
    arr = np.array(img, dtype=np.float64)
    dt = time.time() - t0
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    mi.util.write_bitmap(str(out), img, write_async=False)
    print(f"mitsuba_render: {a.w}x{a.h} x {a.spp} spp in {dt:.1f} s, mean {arr[..., 0].mean():.6g} "
          f"-> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
