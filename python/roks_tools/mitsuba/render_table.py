"""Demo: render two spheres on a grey plate with Mitsuba 3, the left one with
the BRDF table of a `roks brdf` result (plugin `roks_table`,
`roks_tools.mitsuba.roks_table`), the right one Lambertian with the table's normal-
incidence reflectance, under a sun (directional emitter) and a dim sky.

    roks-render-table out/default --out spheres.png

Options: --variant (default auto: llvm_ad_rgb when a test process shows it
works with the libLLVM found, else scalar_rgb with a warning, see
`roks_tools.mitsuba.setup`; scalar_rgb calls Python per sample: minutes),
--spp (64), --size W,H (320,200). Writes OUT (PNG, sRGB; default
spheres.png in the current folder) and OUT with .exr (linear). The LLVM variants run the plugin in wavefront mode
(symbolic loops and calls off), see `roks_tools.mitsuba.roks_table`.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..errors import ResultError, command, show
from .setup import setup_mitsuba


@command("render_roks_bsdf")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("result", type=Path, help="roks brdf result folder (with brdf.csv)")
    ap.add_argument("--out", type=Path, default=Path("spheres.png"))
    ap.add_argument("--variant", default="auto",
                    help="auto (llvm_ad_rgb when it works here, else scalar_rgb), llvm, scalar, or a variant name")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", default="320,200")
    a = ap.parse_args()
    csv = a.result / "brdf.csv"
    if not csv.is_file():
        raise ResultError(f"{show(csv)}: not found")
    w, h = (int(v) for v in a.size.split(","))

    import drjit as dr

    mi = setup_mitsuba(a.variant)
    if dr.is_array_v(mi.Float):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    from roks_tools.mitsuba import roks_table as roks_bsdf

    roks_bsdf.register()
    table = roks_bsdf.CarlsonTable(csv)
    rho0 = float(table.reflectance[0])
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 6},
        "sensor": {
            "type": "perspective",
            "fov": 32,
            "to_world": T().look_at(origin=[0, -7, 3.2], target=[0, 0, 0.6], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": w, "height": h},
            "sampler": {"type": "independent", "sample_count": a.spp},
        },
        "roks": {"type": "sphere", "center": [-1.0, 0, 0.8], "radius": 0.8,
                 "bsdf": {"type": "roks_table", "filename": str(csv)}},
        "lambert": {"type": "sphere", "center": [1.0, 0, 0.8], "radius": 0.8,
                    "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rho0}}},
        "plate": {"type": "rectangle", "to_world": T().scale([4, 4, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.25, 0.25, 0.3]}}},
        "sun": {"type": "directional", "direction": [-0.4, 0.7, -0.6],
                "irradiance": {"type": "rgb", "value": 3.0}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.15}},
    })
    t = time.time()
    img = mi.render(scene)
    secs = time.time() - t
    mi.util.write_bitmap(str(a.out), img, write_async=False)
    mi.util.write_bitmap(str(a.out.with_suffix(".exr")), img, write_async=False)
    print(f"wrote {a.out} and {a.out.with_suffix('.exr')} ({w}x{h}, {a.spp} spp, {secs:.1f} s); "
          f"left: roks table {csv}, right: Lambertian rho = {rho0:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
