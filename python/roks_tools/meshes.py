"""Write small test height fields over one period as binary little-endian PLY.

Stand-ins for `roks export-mesh`: the same layout,
one period [0, Lx] x [0, Ly], vertices `float x, y, z`, faces
`list uchar int vertex_indices`, triangles wound counter-clockwise seen from
above (geometric normals up).

    make_test_ply.py flat OUT.ply [--size 2,2]
    make_test_ply.py vgroove OUT.ply [--size 2,2] [--alpha 45]
    make_test_ply.py sine OUT.ply [--size 10,10] [--amp 1] [--res 64]

`vgroove`: grooves along y, a triangle wave in x with ridges at x = 0 and Lx
and the bottom at Lx/2, walls at `alpha` degrees from horizontal.
`sine`: z = amp sin(2 pi x / Lx) sin(2 pi y / Ly) on a res x res grid.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from .errors import command


def write_ply(path: str | Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Binary little-endian PLY: float x, y, z; list uchar int vertex_indices."""
    v = np.ascontiguousarray(vertices, dtype="<f4")
    f = np.asarray(faces, dtype="<i4")
    header = (
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment roks test height field (one period)\n"
        f"element vertex {len(v)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(f)}\n"
        "property list uchar int vertex_indices\n"
        "end_header\n"
    )
    rec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rec["n"] = 3
    rec["i"] = f
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(v.tobytes())
        fh.write(rec.tobytes())


def grid_mesh(xs: np.ndarray, ys: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a height field z[i, j] at (xs[i], ys[j]), normals up."""
    nx, ny = len(xs), len(ys)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    verts = np.stack([X.ravel(), Y.ravel(), z.ravel()], axis=1)
    idx = np.arange(nx * ny).reshape(nx, ny)
    a = idx[:-1, :-1].ravel()  # (i, j)
    b = idx[1:, :-1].ravel()   # (i+1, j)
    c = idx[1:, 1:].ravel()    # (i+1, j+1)
    d = idx[:-1, 1:].ravel()   # (i, j+1)
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return verts, faces


def flat(lx: float, ly: float) -> tuple[np.ndarray, np.ndarray]:
    return grid_mesh(np.array([0.0, lx]), np.array([0.0, ly]), np.zeros((2, 2)))


def vgroove(lx: float, ly: float, alpha_deg: float = 45.0) -> tuple[np.ndarray, np.ndarray]:
    xs = np.array([0.0, lx / 2, lx])
    h = (lx / 2) * math.tan(math.radians(alpha_deg))
    z = np.array([[h, h], [0.0, 0.0], [h, h]])
    return grid_mesh(xs, np.array([0.0, ly]), z)


def sine(lx: float, ly: float, amp: float = 1.0, res: int = 64) -> tuple[np.ndarray, np.ndarray]:
    xs = np.linspace(0.0, lx, res + 1)
    ys = np.linspace(0.0, ly, res + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    z = amp * np.sin(2 * np.pi * X / lx) * np.sin(2 * np.pi * Y / ly)
    return grid_mesh(xs, ys, z)


@command("make_test_ply")
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kind", choices=["flat", "vgroove", "sine"])
    ap.add_argument("out")
    ap.add_argument("--size", default=None, help="LX,LY (default 2,2; sine 10,10)")
    ap.add_argument("--alpha", type=float, default=45.0, help="V-groove wall angle (deg)")
    ap.add_argument("--amp", type=float, default=1.0)
    ap.add_argument("--res", type=int, default=64)
    a = ap.parse_args()
    default = "10,10" if a.kind == "sine" else "2,2"
    lx, ly = (float(s) for s in (a.size or default).split(","))
    if a.kind == "flat":
        v, f = flat(lx, ly)
    elif a.kind == "vgroove":
        v, f = vgroove(lx, ly, a.alpha)
    else:
        v, f = sine(lx, ly, a.amp, a.res)
    write_ply(a.out, v, f)
    print(f"{a.out}: {len(v)} vertices, {len(f)} triangles")


if __name__ == "__main__":
    main()
