"""Plot a BRDF result folder written by `roks brdf`.

Reads RESULT_DIR/summary.json, RESULT_DIR/inplane.csv and RESULT_DIR/brdf.csv
(columns and conventions: the doc comment at the top of src/output.rs) and
writes one PNG with three panels:

1. directional-hemispherical reflectance vs incidence angle (error bars
   +-2 standard errors), split into its single-bounce part and its
   multiple-bounce part (reflectance minus the 0- and 1-bounce parts);
2. the in-plane BRDF (sr^-1, log scale) vs the signed outgoing angle
   theta_o (positive on the specular side, negative toward the light) for
   the chosen incidence angles, with a +-2 standard error band and a tick
   at each specular direction (bins with BRDF = 0 are left out);
3. the BRDF on the Carlson equal-solid-angle grid for one incidence (the
   largest chosen angle unless --map-theta says otherwise), each cell drawn
   as its exact polygon in the equal-area (Lambert azimuthal) projection
   r = sqrt(2) sin(theta / 2), log colour scale; the specular direction and
   the direction toward the light are marked.

    .venv/bin/python scripts/plot_brdf.py out/default
    .venv/bin/python scripts/plot_brdf.py out/default --theta 0,30,60,85 --out /tmp/b.png

A spectral result is drawn at one wavelength (`--wavelength`, default the
one nearest 0.55 um; the reflectance panel then shows that wavelength's
reflectance, without the split by bounces, which roks gives for the mean).

Needs numpy and matplotlib (scripts/setup_venv.sh). Exits with status 2 and a
one-line message on stderr naming the file if RESULT_DIR is not a complete,
readable roks result folder (`roks_tools.results`).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from .errors import UsageError, cli  # noqa: E402
from .results import BrdfResult  # noqa: E402

PROG = "plot_brdf"
MAX_DEFAULT_THETAS = 6
# Tolerance (degrees) when matching a requested angle to one in the result.
ANGLE_TOL = 1e-6


def fail(msg: str):
    """A bad option or a result without what was asked for (exit status 2 in `main`)."""
    raise UsageError(msg)


# --------------------------------------------------------------------------- #
# Reading
# --------------------------------------------------------------------------- #


def _columns(table) -> dict[str, np.ndarray]:
    """The array fields of a table dataclass, by column name."""
    return {f.name: getattr(table, f.name) for f in fields(table)
            if isinstance(getattr(table, f.name), np.ndarray)}


def load(folder: Path, wavelength_um: float | None = None
         ) -> tuple[list[dict], dict, dict[str, np.ndarray], dict[str, np.ndarray], float | None]:
    """(incidence entries, summary, in-plane columns, brdf columns, wavelength) of a
    `roks brdf` folder; a spectral run at `wavelength_um` (default: the one
    nearest 0.55 um), whose entries then hold that wavelength's reflectance."""
    r = BrdfResult.load(folder)
    entries = [dict(e.raw) for e in r.summary.incidence]
    waves = r.brdf.wavelengths
    if waves:
        if wavelength_um is None:
            wavelength_um = min(waves, key=lambda w: (round(abs(w - 0.55), 9), w))  # a tie: the shorter
        match = [w for w in waves if abs(w - wavelength_um) <= 1e-9]
        if not match:
            fail(f"--wavelength: {wavelength_um:g} um is not in the result "
                 f"(available: {', '.join(f'{w:g}' for w in waves)})")
        wavelength_um = match[0]
        r = r.at_wavelength(wavelength_um)
        for e, inc in zip(entries, r.summary.incidence):
            w = next(x for x in inc.spectrum if x.wavelength_um == wavelength_um)
            # by_bounces is of the mean over the wavelengths: not drawn for one wavelength
            e.update(reflectance=w.reflectance, reflectance_stderr=w.reflectance_stderr, lost=w.lost,
                     reflectance_by_bounces=None)
    elif wavelength_um is not None:
        fail(f"--wavelength: {folder} is a monochrome result")
    return entries, r.summary.raw, _columns(r.inplane), _columns(r.brdf), wavelength_um


# --------------------------------------------------------------------------- #
# Choices
# --------------------------------------------------------------------------- #


def default_thetas(available: list[float]) -> list[float]:
    if len(available) <= MAX_DEFAULT_THETAS:
        return list(available)
    idx = np.unique(np.round(np.linspace(0, len(available) - 1, MAX_DEFAULT_THETAS)).astype(int))
    return [available[i] for i in idx]


def parse_thetas(text: str, available: list[float]) -> list[float]:
    out = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        try:
            t = float(part)
        except ValueError:
            fail(f"--theta: {part!r} is not a number")
        match = [a for a in available if abs(a - t) <= ANGLE_TOL]
        if not match:
            fail(
                f"--theta: incidence {t:g} deg is not in the result "
                f"(available: {', '.join(f'{a:g}' for a in available)})"
            )
        if match[0] not in out:
            out.append(match[0])
    if not out:
        fail("--theta: no angle given")
    return sorted(out)


# --------------------------------------------------------------------------- #
# Panels
# --------------------------------------------------------------------------- #


def panel_reflectance(ax, incidence: list[dict]) -> None:
    inc = sorted(incidence, key=lambda e: e["theta_deg"])
    theta = np.array([e["theta_deg"] for e in inc], float)
    refl = np.array([e["reflectance"] for e in inc], float)
    se = np.array([e["reflectance_stderr"] for e in inc], float)
    split = all(e.get("reflectance_by_bounces") is not None for e in inc)
    by = [list(e["reflectance_by_bounces"] if split else []) + [0.0, 0.0] for e in inc]
    b0 = np.array([b[0] for b in by], float)
    b1 = np.array([b[1] for b in by], float)
    multi = refl - b0 - b1

    ax.errorbar(theta, refl, yerr=2 * se, fmt="o-", color="k", ms=4, capsize=3,
                label="total reflectance (±2 SE)")
    if split:
        ax.plot(theta, b1, "s--", color="tab:blue", ms=4, label="single bounce")
        ax.plot(theta, multi, "^--", color="tab:red", ms=4, label="multiple bounces (≥ 2)")
    if np.any(b0 > 0):
        ax.plot(theta, b0, "x:", color="tab:gray", label="no bounce (passed through)")
    lost = np.array([e.get("lost", 0.0) or 0.0 for e in inc], float)
    if np.any(lost > 0):
        ax.plot(theta, lost, "d:", color="tab:purple", ms=4, label="lost (walls, cap, numeric)")
    ax.set_xlabel("incidence angle θᵢ (deg)")
    ax.set_ylabel("directional-hemispherical reflectance (–)")
    ax.set_title("Reflectance vs incidence angle")
    ax.set_xlim(min(0.0, theta.min()) - 2, max(90.0, theta.max()) + 2)
    ax.set_ylim(0, max(1.0, refl.max() * 1.05))
    ax.grid(True, alpha=0.3)
    ax.legend(loc="center left", fontsize=8)
    ax.text(0.02, 0.02, f"max 2 SE of total: {2 * se.max():.1e} (error bars smaller than markers)"
            if 2 * se.max() < 0.005 else "", transform=ax.transAxes, fontsize=7, color="0.35")


def panel_inplane(ax, inplane: dict[str, np.ndarray], thetas: list[float]) -> None:
    cmap = plt.get_cmap("viridis")
    colours = [cmap(x) for x in np.linspace(0.0, 0.9, len(thetas))]
    positives = []
    for t, c in zip(thetas, colours):
        sel = np.abs(inplane["theta_i_deg"] - t) <= ANGLE_TOL
        to = inplane["theta_o_deg"][sel]
        b = inplane["brdf"][sel]
        e = inplane["brdf_stderr"][sel]
        order = np.argsort(to)
        to, b, e = to[order], b[order], e[order]
        pos = b > 0
        positives.append(b[pos])
        yb = np.where(pos, b, np.nan)  # zero bins: gaps on the log axis
        lo = np.where(pos, b - 2 * e, np.nan)
        hi = np.where(pos, b + 2 * e, np.nan)
        ax.plot(to, yb, "-", color=c, lw=1.2, label=f"θᵢ = {t:g}°")
        ax.fill_between(to, np.where(lo > 0, lo, 1e-30), hi, color=c, alpha=0.2, lw=0)
    allpos = np.concatenate(positives) if positives else np.array([1.0])
    ymin = max(np.percentile(allpos, 1) / 3, allpos.max() * 1e-6) if allpos.size else 1e-3
    ymax = allpos.max() * 3 if allpos.size else 10.0
    ax.set_yscale("log")
    ax.set_ylim(ymin, ymax)
    # Specular ticks: short marks hanging from the top of the axes, at +theta_i.
    trans = ax.get_xaxis_transform()
    for t, c in zip(thetas, colours):
        ax.plot([t, t], [0.93, 1.0], transform=trans, color=c, lw=2.5, solid_capstyle="butt")
    ax.axvline(0, color="0.6", lw=0.8, ls=":")
    ax.set_xlim(-90, 90)
    ax.set_xticks(np.arange(-90, 91, 30))
    ax.set_xlabel("signed outgoing angle θₒ in the plane of incidence (deg)\n"
                  "← toward the light        specular side →")
    ax.set_ylabel("BRDF (sr⁻¹)")
    ax.set_title("In-plane BRDF (shaded: ±2 SE)")
    ax.grid(True, which="major", alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], color="0.3", lw=2.5))
    labels.append("tick at top: specular θₒ = θᵢ")
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(0.0, 0.91), fontsize=8)
    step = float(np.median(np.diff(np.unique(inplane["theta_o_deg"]))))
    ax.text(0.99, 0.015, f"bins {step:g}° wide, centred on whole multiples; the narrow spike at θₒ = θᵢ\n"
            "is mirror reflection off flat substrate between the bumps",
            transform=ax.transAxes, fontsize=7, color="0.35", ha="right", va="bottom")


def lambert_r(theta_deg: np.ndarray | float) -> np.ndarray | float:
    return math.sqrt(2.0) * np.sin(np.radians(theta_deg) / 2.0)


def cell_polygon(t_lo: float, t_hi: float, p_lo: float, p_hi: float) -> np.ndarray:
    """Exact outline of a (theta, phi) cell in the equal-area projection."""
    n = max(2, math.ceil((p_hi - p_lo) / 3.0))  # a segment every <= 3 deg of azimuth
    phi = np.radians(np.linspace(p_lo, p_hi, n + 1))
    r_lo, r_hi = lambert_r(t_lo), lambert_r(t_hi)
    outer = np.column_stack([r_hi * np.cos(phi), r_hi * np.sin(phi)])
    if r_lo <= 0.0:
        inner = np.zeros((1, 2))  # cells touching the pole are wedges
    else:
        inner = np.column_stack([r_lo * np.cos(phi[::-1]), r_lo * np.sin(phi[::-1])])
    return np.vstack([outer, inner])


def panel_map(fig, ax, brdf: dict[str, np.ndarray], theta_i: float, phi_i: float) -> None:
    sel = np.abs(brdf["theta_i_deg"] - theta_i) <= ANGLE_TOL
    if not np.any(sel):
        fail(f"brdf.csv has no rows for incidence {theta_i:g} deg")
    cols = {k: v[sel] for k, v in brdf.items()}
    polys = [cell_polygon(a, b, c, d) for a, b, c, d in zip(
        cols["theta_lo_deg"], cols["theta_hi_deg"], cols["phi_lo_deg"], cols["phi_hi_deg"])]
    val = cols["brdf"]
    pos = val > 0
    vmin = val[pos].min() if np.any(pos) else 1e-3
    vmax = val[pos].max() if np.any(pos) else 1.0
    # Keep the colour range readable: at most 5 decades below the maximum
    # (cells below that are drawn in blue, with an arrow on the colour bar).
    vmin = max(vmin, vmax * 1e-5)
    norm = LogNorm(vmin=vmin, vmax=vmax)
    cmap = plt.get_cmap("magma").with_extremes(bad="0.8", under="tab:blue")  # bad: cells with no photon
    coll = PolyCollection(polys, array=np.ma.masked_where(~pos, val), cmap=cmap, norm=norm,
                          edgecolors="face", linewidths=0.2)
    ax.add_collection(coll)
    extend = "min" if np.any(val[pos] < vmin) else "neither"

    # Reference circles (theta) and azimuth labels.
    ring = np.radians(np.linspace(0, 360, 361))
    for t in (30, 60, 90):
        r = lambert_r(t)
        ax.plot(r * np.cos(ring), r * np.sin(ring), color="w" if t < 90 else "k",
                lw=0.6 if t < 90 else 1.0, ls=":" if t < 90 else "-", alpha=0.8)
        if t < 90:
            ax.text(r * math.cos(math.radians(100)), r * math.sin(math.radians(100)), f"θ={t}°",
                    color="w", fontsize=7, ha="center", va="center")
    for p, ha, va in ((0, "left", "center"), (90, "center", "bottom"),
                      (180, "right", "center"), (270, "center", "top")):
        rr = 1.04
        ax.text(rr * math.cos(math.radians(p)), rr * math.sin(math.radians(p)), f"φ={p}°",
                fontsize=8, ha=ha, va=va)

    # Specular direction (theta_i, phi_i + 180) and toward the light (theta_i, phi_i).
    r = lambert_r(theta_i)
    spec = (r * math.cos(math.radians(phi_i + 180)), r * math.sin(math.radians(phi_i + 180)))
    light = (r * math.cos(math.radians(phi_i)), r * math.sin(math.radians(phi_i)))
    ax.plot(*spec, marker="o", ms=11, mfc="none", mec="cyan", mew=2, ls="none",
            label=f"specular (θ={theta_i:g}°, φ={(phi_i + 180) % 360:g}°)")
    ax.plot(*light, marker="*", ms=13, mfc="yellow", mec="k", mew=0.8, ls="none",
            label=f"toward the light (θ={theta_i:g}°, φ={phi_i % 360:g}°)")
    ax.set_aspect("equal")
    ax.set_xlim(-1.25, 1.25)
    ax.set_ylim(-1.12, 1.12)
    ax.set_axis_off()
    # Colour bar beside the disc (axes fractions of the square, equal-aspect box).
    cax = ax.inset_axes([1.03, 0.12, 0.045, 0.76])
    cb = fig.colorbar(coll, cax=cax, extend=extend)
    cb.set_label("BRDF (sr⁻¹)")
    ax.set_title(f"BRDF over the hemisphere, θᵢ = {theta_i:g}°\n"
                 "(equal-area projection r = √2·sin(θ/2); Carlson cells, grey: no photon)")
    ax.legend(loc="lower center", bbox_to_anchor=(0.5, -0.13), fontsize=8, ncol=1,
              frameon=False)


# --------------------------------------------------------------------------- #
# Main
# --------------------------------------------------------------------------- #


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="plot_brdf.py",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("result_dir", metavar="RESULT_DIR", help="folder written by `roks brdf`")
    p.add_argument("--out", metavar="PNG", help="output PNG (default: RESULT_DIR/brdf.png)")
    p.add_argument(
        "--theta",
        metavar="LIST",
        help="incidence angles (deg, comma-separated) for the in-plane panel; the largest "
        f"is also mapped (default: all in the result, at most {MAX_DEFAULT_THETAS} evenly picked)",
    )
    p.add_argument("--map-theta", metavar="DEG", type=float,
                   help="incidence angle of the hemisphere map (default: the largest chosen angle)")
    p.add_argument("--wavelength", metavar="UM", type=float,
                   help="a spectral result: the wavelength (um) to draw (default: the one nearest 0.55)")
    p.add_argument("--dpi", type=int, default=150, help="PNG resolution (default: %(default)s)")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    return cli(PROG, lambda: plot(Path(args.result_dir), args))


def plot(folder: Path, args: argparse.Namespace) -> int:
    """Draw the picture of `folder` as `args` asks; returns 0."""
    incidence, summary, inplane, brdf, wavelength = load(folder, args.wavelength)
    available = sorted({float(e["theta_deg"]) for e in incidence})
    thetas = parse_thetas(args.theta, available) if args.theta else default_thetas(available)
    map_theta = max(thetas)
    if args.map_theta is not None:
        map_theta = parse_thetas(str(args.map_theta), available)[0]
    inplane_angles = set(np.unique(inplane["theta_i_deg"]).tolist())
    for t in thetas:
        if not any(abs(t - a) <= ANGLE_TOL for a in inplane_angles):
            fail(f"inplane.csv has no rows for incidence {t:g} deg")
    phi_i = float(next(e["phi_deg"] for e in incidence if float(e["theta_deg"]) == map_theta))

    name = summary.get("name", "?")
    photons = {int(e["photons"]) for e in incidence}
    if len(photons) == 1:
        ph = f"{photons.pop():,} photons per incidence angle"
    else:
        ph = f"{min(photons):,}–{max(photons):,} photons per incidence angle"
    phis = {float(e["phi_deg"]) for e in incidence}
    details = [f"seed {summary['seed']}" if "seed" in summary else None,
               f"edges: {summary['edges']}" if "edges" in summary else None,
               f"{summary['bands']} Carlson bands" if "bands" in summary else None,
               f"light azimuth φᵢ = {', '.join(f'{p:g}' for p in sorted(phis))}°",
               f"roks {summary['version']}" if "version" in summary else None]
    surf = summary.get("surface") or {}
    if isinstance(surf.get("sigma"), (int, float)) and isinstance(surf.get("rms_slope"), (int, float)):
        details.append(f"surface RMS height {surf['sigma']:.3g}, RMS slope {surf['rms_slope']:.3g}")

    fig = plt.figure(figsize=(19, 6.6))
    gs = fig.add_gridspec(1, 3, width_ratios=[1, 1.25, 1.0], wspace=0.2)
    ax1, ax2, ax3 = (fig.add_subplot(gs[0, i]) for i in range(3))
    panel_reflectance(ax1, incidence)
    panel_inplane(ax2, inplane, thetas)
    panel_map(fig, ax3, brdf, map_theta, phi_i)
    at = f" at {wavelength:g} µm" if wavelength is not None else ""
    fig.suptitle(f"roks BRDF of scene '{name}'{at} — {ph}", fontsize=14, y=0.995)
    fig.text(0.5, 0.925, " · ".join(d for d in details if d), ha="center", fontsize=9,
             color="0.3")
    fig.subplots_adjust(left=0.045, right=0.95, top=0.84, bottom=0.14)

    out = Path(args.out) if args.out else folder / "brdf.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=args.dpi)
    print(f"{PROG}: wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
