"""Spectral emissivity of the biconical radiator, 3-14 um, in one trace per wall.

    .venv/bin/python scripts/radiator_spectral.py [--roks target/release/roks] [--photons N]

The cavity of scenes/radiator.toml traced over the thermal infrared (3 to
14 um at 0.5 um: 23 wavelengths carried by every photon, `[light]
wavelengths_um`), its walls traced down into a rough micro geometry at every
hit, with two measured materials (scenes/materials/):

* scenes/radiator-spectral.toml: a paint-like absorber, PMMA (Zhang et al.
  2020), on the Z-302 stand-in roughness (scenes/radiator-spectral-micro.toml);
* scenes/radiator-spectral-aluminium.toml: bare aluminium (Ordal et al.
  1988) with the same roughness (scenes/radiator-spectral-aluminium-micro.toml).

For each beam position (0, 3.8, 7.6 and 11.4 mm off the axis, a 2 mm beam
parallel to it) and wavelength `summary.json` gives the cavity reflectance R
and the effective emissivity `1 - R - missed`. For an opaque (no
transmission), isothermal cavity lit by a beam that enters it fully
(`missed = 0`, checked here), Kirchhoff's law and reciprocity make the
directional emissivity toward the reversed beam equal to the
directional-hemispherical absorptance `1 - R` over the beam's footprint.
The flat-wall reference is the normal-incidence Fresnel absorptance of the
same n + ik, `1 - |(m - 1)/(m + 1)|^2`, computed here from the tables.

Writes results/radiator/spectral.png ((a) emissivity vs wavelength of the
painted cavity per beam position, as 1 - emissivity on a log axis since it
is close to 1; (b) the same for aluminium, linear; both with the flat-wall
absorptance), spectral.json (every number) and spectral.md (tables).
Runs in about a minute on 2 cores with the scenes' photons.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roks_tools.errors import RunError, command
from roks_tools.runner import add_out_argument, check_output, default_roks, repo_root, run  # noqa: E402

REPO = repo_root()
# (scene, label, n + ik table)
SCENES = (
    ("radiator-spectral", "PMMA paint walls", "pmma.csv"),
    ("radiator-spectral-aluminium", "bare aluminium walls", "aluminium-ir.csv"),
)


def nk_table(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """wavelength_um, n, k of a scenes/materials table (comment lines skipped)."""
    rows = [line for line in (REPO / "scenes" / "materials" / name).read_text().splitlines()
            if line and not line.startswith("#")]
    assert rows[0] == "wavelength_um,n,k", rows[0]
    a = np.array([[float(x) for x in r.split(",")] for r in rows[1:]])
    return a[:, 0], a[:, 1], a[:, 2]


def flat_absorptance(name: str, wavelengths: np.ndarray) -> np.ndarray:
    """1 - R of a smooth half-space at normal incidence, n + ik interpolated
    linearly in the table (as roks does)."""
    w, n, k = nk_table(name)
    m = np.interp(wavelengths, w, n) + 1j * np.interp(wavelengths, w, k)
    return 1.0 - np.abs((m - 1.0) / (m + 1.0)) ** 2


def trace(roks: str, scene: str, photons: int | None, out: Path) -> tuple[dict, float]:
    cmd = [roks, "trace", REPO / "scenes" / f"{scene}.toml", "--out", out, "-q"]
    if photons is not None:
        cmd += ["--photons", photons]
    done = run(cmd, "radiator_spectral")
    return json.loads((out / "summary.json").read_text()), done.wall_s


@command("radiator_spectral")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--roks", default=str(default_roks()))
    ap.add_argument("--photons", type=int, default=None,
                    help="photons per beam position (default: the scenes')")
    add_out_argument(ap, "radiator_spectral")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    res = Path(a.out)
    res.mkdir(parents=True, exist_ok=True)
    data = {"scenes": []}
    with tempfile.TemporaryDirectory(prefix="radiator_spectral_") as tmp:
        for scene, label, table in SCENES:
            summary, seconds = trace(a.roks, scene, a.photons, Path(tmp) / scene)
            wl = np.array(summary["wavelengths_um"])
            positions = []
            for s in summary["sources"]:
                spec = s["spectrum"]
                missed = max(w["missed"] for w in spec)
                if missed != 0.0:
                    raise RunError(f"{scene}: beam at {s['position']} misses the cavity "
                                     f"({missed}): emissivity = 1 - R does not hold")
                positions.append({
                    "offset_mm": s["position"][0],
                    "photons": s["photons"],
                    "mean_bounces": s["mean_bounces"],
                    "wavelength_um": [w["wavelength_um"] for w in spec],
                    "reflectance": [w["reflectance"] for w in spec],
                    "reflectance_stderr": [w["reflectance_stderr"] for w in spec],
                    "emissivity": [w["emissivity"] for w in spec],
                    "lost": [w["lost"] for w in spec],
                })
            data["scenes"].append({
                "scene": f"scenes/{scene}.toml", "label": label, "table": f"scenes/materials/{table}",
                "seconds": seconds, "wavelengths_um": wl.tolist(),
                "flat_absorptance_normal": flat_absorptance(table, wl).tolist(),
                "positions": positions,
            })
    (res / "spectral.json").write_text(json.dumps(data, indent=1) + "\n")
    plot(res / "spectral.png", data)
    report(res / "spectral.md", data)
    print(f"wrote {res / 'spectral.png'}, spectral.json, spectral.md")
    return 0


def plot(path: Path, data: dict) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, 4))
    for ax, sc, tag in zip(axes, data["scenes"], "ab"):
        wl = np.array(sc["wavelengths_um"])
        flat = np.array(sc["flat_absorptance_normal"])
        log = tag == "a"
        for p, c in zip(sc["positions"], colours):
            r = np.array(p["reflectance"])
            e = np.array(p["reflectance_stderr"])
            y = r if log else 1.0 - r
            ax.errorbar(wl, y, yerr=2 * e, color=c, marker="o", ms=3, capsize=2,
                        label=f"beam {p['offset_mm']:.1f} mm off axis")
        ax.plot(wl, 1.0 - flat if log else flat, "k--", lw=1,
                label="flat wall, normal incidence (Fresnel)")
        ax.set_xlabel("wavelength (um)")
        if log:
            ax.set_yscale("log")
            ax.set_ylabel("1 - effective emissivity = cavity reflectance")
        else:
            ax.set_ylabel("effective emissivity = 1 - cavity reflectance")
        ax.set_title(f"({tag}) {sc['label']}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Biconical radiator: spectral effective emissivity (opaque isothermal walls, "
                 "beam inside the aperture); error bars 2 standard errors")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def report(path: Path, data: dict) -> None:
    lines = ["# The radiator's spectral effective emissivity (3-14 um)", "",
             "Written by `scripts/radiator_spectral.py` (`roks_tools.studies.radiator_spectral`). "
             "Effective emissivity = 1 - cavity reflectance (opaque, isothermal walls; the beam "
             "enters the aperture fully: missed = 0 at every position and wavelength). "
             "Flat: the normal-incidence absorptance of a smooth wall of the same n + ik.", ""]
    for sc in data["scenes"]:
        wl = sc["wavelengths_um"]
        lines += [f"## {sc['label']} (`{sc['scene']}`, n + ik from `{sc['table']}`)", "",
                  f"{len(wl)} wavelengths in one trace, {sc['positions'][0]['photons']} photons per "
                  f"beam position, {sc['seconds']:.1f} s wall clock.", ""]
        head = "| wavelength (um) | flat |" + "".join(
            f" {p['offset_mm']:.1f} mm |" for p in sc["positions"])
        lines += [head, "|---:|---:|" + "---:|" * len(sc["positions"])]
        for i, w in enumerate(wl):
            cells = "".join(f" {p['emissivity'][i]:.6f} ± {p['reflectance_stderr'][i]:.1e} |"
                            for p in sc["positions"])
            lines.append(f"| {w:g} | {sc['flat_absorptance_normal'][i]:.4f} |{cells}")
        bounces = ", ".join(f"{p['mean_bounces']:.1f}" for p in sc["positions"])
        lines += ["", f"Mean macro reflections per photon by position: {bounces}.", ""]
    path.write_text("\n".join(lines))


if __name__ == "__main__":
    raise SystemExit(main())
