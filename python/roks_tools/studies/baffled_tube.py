"""Write scenes/baffled-tube-N.toml: a baffled tube for `roks trace`.

A cylindrical tube (inner radius 25 mm, wall 2 mm thick) with N annular
baffle vanes, the kind of object stray-light engineers trace: vane k is the
solid between the planes z = -k s and z = -k s - w (spacing s = 10 mm,
thickness w = 0.5 mm), outside the bore cylinder (radius 15 mm) and inside
the tube wall. The tube is open at both ends, runs from z = 0 to
z = -(N + 1) s, and a 4 mm beam enters it at 20 degrees off the axis, so it
lands on the vanes near the entrance and bounces among them.

The vane spacing is the same for every N (the tube grows with N): the
neighbourhood of a photon near the entrance is the same whatever N, so the
cost per macro segment compares only how the tracer scales with the number
of cells (N + 1 solids, 2 N + 3 quadrics). Walls are cheap (ideal specular
plus Lambertian) so the macro geometry dominates the cost.

Usage: scripts/make_baffled_tube.py [N ...]   (default: 10 100 1000)
"""

import math
import sys

from roks_tools.errors import command
from roks_tools.runner import repo_root

BORE = 15.0  # inner radius of the vanes (mm)
WALL = 25.0  # inner radius of the tube (mm)
OUTER = 27.0  # outer radius of the tube (mm)
SPACING = 10.0  # vane pitch along the axis (mm)
THICKNESS = 0.5  # vane thickness (mm)
TILT_DEG = 20.0  # beam angle from the -z axis


def scene(n: int) -> str:
    length = (n + 1) * SPACING
    tilt = math.radians(TILT_DEG)
    lines = [
        f"# A tube with {n} annular baffle vanes (written by scripts/make_baffled_tube.py;",
        "# see there for the geometry). Lengths in mm; the tube is open at both ends.",
        f'name = "baffled-tube-{n}"',
        "seed = 1",
        "",
        "[quadrics]",
        f"bore  = {{ cylinder_z = {{ r = {BORE} }} }}",
        f"wall  = {{ cylinder_z = {{ r = {WALL} }} }}",
        f"outer = {{ cylinder_z = {{ r = {OUTER} }} }}",
        "mouth = { plane = [0.0, 0.0, 1.0, 0.0] }",
        f"end   = {{ plane = [0.0, 0.0, 1.0, {-length!r}] }}",
    ]
    for k in range(1, n + 1):
        top = -k * SPACING
        lines.append(f"v{k}a = {{ plane = [0.0, 0.0, 1.0, {top!r}] }}")
        lines.append(f"v{k}b = {{ plane = [0.0, 0.0, 1.0, {top - THICKNESS!r}] }}")
    lines += [
        "",
        "[[cells]]",
        'name = "tube"',
        'region = "+wall -outer -mouth +end"',
        'fill = "solid"',
    ]
    for k in range(1, n + 1):
        lines += [
            "[[cells]]",
            f'name = "vane{k}"',
            f'region = "+bore -wall -v{k}a +v{k}b"',
            'fill = "solid"',
        ]
    lines += ["", "[walls]", 'bore = "black"', 'wall = "black"', 'outer = "black"']
    for k in range(1, n + 1):
        lines.append(f'v{k}a = "black"')
        lines.append(f'v{k}b = "black"')
    lines += [
        "",
        "[models.black]                  # a cheap black paint: 5 % specular, 15 % Lambertian",
        "specular = 0.05",
        "diffuse = 0.15",
        "",
        "[[sources]]",
        f"beam = {{ direction = [{math.sin(tilt)!r}, 0.0, {-math.cos(tilt)!r}], diameter = 4.0 }}",
        "position = [-10.0, 0.0, 5.0]",
        "photons = 100000",
        "",
        "[transport]",
        "roulette_weight = 1e-4",
        "",
        "[tally]",
        "bands = 16",
        "farfield = true",
        "",
    ]
    return "\n".join(lines)


@command("make_baffled_tube")
def main() -> None:
    counts = [int(a) for a in sys.argv[1:]] or [10, 100, 1000]
    out = repo_root() / "scenes"
    for n in counts:
        (out / f"baffled-tube-{n}.toml").write_text(scene(n))


if __name__ == "__main__":
    main()
