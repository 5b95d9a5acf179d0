"""Independent multiple-reflection BRDF tracer on Mitsuba 3's `scene.ray_intersect`.

Cross-check for `roks brdf`: traces photons on a triangulated height
field over one period (the PLY of `roks export-mesh`, or of
`roks-make-test-ply`) and writes summary.json, brdf.csv and inplane.csv in
roks's formats (same headers, same Carlson grid and in-plane tally, same
number formatting).

Its Carlson binning (`Carlson` below) is written out here on purpose and
does not use `roks_tools.carlson`: the tracer is an independent check of
roks's binning as well as of its transport, so it shares no grid code with
the readers or with roks.

    roks-mitsuba-brdf MESH.ply --size LX,LY [--theta 0,30,60] [--phi 0]
        [--photons N] [--seed S] (--rho 0.8 | --n N --k K | --material Au --wavelengths W)
        [--bands 32] [--variant auto|llvm|scalar] [--out DIR]
        [--polarisation none|stokes|mueller] [--incident STATE]

Method
* Geometry: one `shapegroup` holding the mesh, instanced (2B+1)^2 times at
  (i Lx, j Ly), i, j in -B..B (`--block B`, default 1: 3 x 3 instances).
* Launch: uniform random points over the central cell [0, Lx) x [0, Ly) on
  the plane z = max height + margin, direction -omega_i,
  omega_i = (sin t cos p, sin t sin p, cos t).
* Wavefront: all live rays of a batch are intersected at once; `dr.eval` after
  each intersection; the results come back to numpy, where the state
  (origins, directions, weights) is kept in float64. Mitsuba itself is
  float32.
* Periodic wrap and long segments: every segment starts in the central cell
  (origins are wrapped by whole periods, x mod Lx, y mod Ly). Its length is
  clipped at the edge of the instance block (B periods on every side of the
  central cell), where the instances are exactly the periodic surface. A ray
  that reaches the clip without a hit is re-launched from the clip point
  (wrapped; a segment, not a bounce), so grazing rays crossing many periods
  are exact with only 3 x 3 instances.
* Hits: specular reflection about the triangle's geometric normal turned to
  face the ray; weight *= reflectance(cos_i) (constant rho, or unpolarised
  Fresnel for n + ik, computed in float64); the new origin is offset from the
  hit point along that normal by `--offset` x the cell scale (self-hit guard).
* Escape: nothing lies above the mesh's highest point zmax, so a ray going up
  that reaches z = zmax with no hit leaves and is tallied with its direction
  and weight; a ray above zmax going down is moved straight to just above
  z = zmax (exact; this skips the long flights of grazing launches).
* Stuck rays: a ray re-launched 1000 times in a row without a hit (e.g. one
  sliding horizontally along a ridge after hitting its tip) is `lost_numeric`.
* Polarisation (`--polarisation stokes|mueller`, needs --n/--k): each photon
  carries Stokes columns (one: the `--incident` state; four: its Mueller
  matrix by columns) with a reference vector, float64 in numpy, composed from
  Mitsuba's own matrices evaluated in a polarised variant (llvm_ad_mono_polarized,
  scalar fallback scalar_spectral_polarized): at a hit the columns are turned
  into the s frame, s = normalize(n x d_in) (conductor.cpp's cross(n, -wo);
  at normal incidence the photon's own reference is kept), by
  `mi.mueller.rotate_stokes_basis`, then multiplied by
  `mi.mueller.specular_reflection(cos_i, n + ik)`; s is the new reference.
  The launch frame and the tally frame of a direction d are roks's
  hemisphere frame: reference normalize(z x d), for d along +-z
  (-sin phi_i, cos phi_i, 0); at escape the columns are turned into it by
  `rotate_stokes_basis`. Writes stokes.csv or mueller.csv (roks's columns)
  and `reflected_stokes` / `reflected_mueller` (with standard errors) in
  summary.json; brdf.csv, inplane.csv and the reflectance stay the intensity
  S0 for the incident state. Roulette and the losses use the intensity of
  the first column (S0 for the incident state; M00 for Mueller), as roks.
* Spectral (`--material NAME --wavelengths 0.45,0.55,0.65` or
  `0.38:0.78:0.02`, um): Mitsuba's own conductor spectra (the preset NAME of
  its `conductor` plugin, data/ior/NAME.eta.spd and NAME.k.spd), one weight
  per wavelength along the same path (as roks's `carrier::Spectral`):
  roulette and the dead test on the largest, survivors scaled so it is the
  survival weight; losses and every tally per wavelength. Spectral variants
  draw a path's wavelengths at random; here they are fixed by setting
  `si.wavelengths` (four at a time) before evaluating. Unpolarised
  (`llvm_ad_spectral`, fallback scalar_spectral): the weight of a hit is the
  `conductor` plugin's own `bsdf.sample` weight, fresnel_conductor(cos_i, n +
  ik) (`MitsubaConductor`). `--polarisation stokes`
  (`llvm_ad_spectral_polarized`): a Stokes vector of the `--incident` state
  per wavelength, composed as above from `mi.mueller.specular_reflection`
  with n, k of Mitsuba's `spectrum` textures of those files evaluated at the
  wavelengths (`mitsuba_ior`, `SpectralPolarisedCarrier`; no stokes.csv).
  Writes brdf.csv / inplane.csv with `wavelength_um` after the incidence
  columns and summary.json with `wavelengths_um` and a `spectrum` per
  incidence, as roks.
* Russian roulette below weight 0.01 (survivors carry 0.1, as roks); a bounce
  cap and a segment cap (cut weight reported as `lost_cap`); a ray found
  below the lowest point of the mesh (a leak through a seam) is
  `lost_numeric`.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import command
from ..results import BRDF_COLUMNS, INPLANE_COLUMNS, SPECTRAL_BRDF_COLUMNS, SPECTRAL_INPLANE_COLUMNS
from .setup import setup_mitsuba  # noqa: F401 (the tracer's entry point sets the variant)

VERSION = "mitsuba_brdf 0.1"
BRDF_HEADER = ",".join(BRDF_COLUMNS)
INPLANE_HEADER = ",".join(INPLANE_COLUMNS)
SPECTRAL_BRDF_HEADER = ",".join(SPECTRAL_BRDF_COLUMNS)
SPECTRAL_INPLANE_HEADER = ",".join(SPECTRAL_INPLANE_COLUMNS)
STOKES_NAMES = [f"s{i}" for i in range(4)]
MUELLER_NAMES = [f"m{i}{j}" for i in range(4) for j in range(4)]


def polar_header(names: list[str], extra: str = "") -> str:
    """Header of stokes.csv / mueller.csv: the cell keys, then each component and its stderr."""
    cols = ",".join(f"{c},{c}_stderr" for c in names)
    return "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg," + cols + extra


STOKES_HEADER = polar_header(STOKES_NAMES, ",dop")
MUELLER_HEADER = polar_header(MUELLER_NAMES)
BOUNCE_BINS = 64  # as roks: reflectance_by_bounces[63] holds 63 and more


# --------------------------------------------------------------------------
# Optics


def fresnel_unpolarised(cos_i: np.ndarray, n: float, k: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a conductor n + ik seen from vacuum (float64)."""
    eta = complex(n, k)
    c = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0).astype(np.complex128)
    s2 = 1.0 - c * c
    ct = np.sqrt(1.0 - s2 / (eta * eta))
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)


class MitsubaConductor:
    """Mitsuba's own smooth conductor (the `conductor` plugin with a `material`
    preset, e.g. "Au": the n, k spectra of Mitsuba's data/ior/NAME.eta.spd and
    NAME.k.spd, interpolated by Mitsuba's `irregular` spectrum) evaluated at
    fixed wavelengths, in a spectral variant (llvm_ad_spectral, scalar fallback
    scalar_spectral).

    Spectral variants draw the wavelengths of a path at random (four per ray);
    here they are fixed instead: a SurfaceInteraction3f is built for each
    batch of hits with ``si.wi = (sin t, 0, cos t)`` in the local frame and
    ``si.wavelengths`` set to four of the requested wavelengths (nm), and
    ``bsdf.sample`` returns the plugin's weight, ``fresnel_conductor(cos t,
    n + ik)`` per wavelength (conductor.cpp; unpolarised variants), which is
    the reflectance of the hit. Float32, as Mitsuba."""

    def __init__(self, mi, material: str, wavelengths_um: list[float]):
        v = mi.variant()
        if "spectral" not in v or v.endswith("_polarized"):
            raise ValueError(f"Mitsuba's conductor spectra need an unpolarised spectral variant, not {v}")
        import drjit as dr

        self.mi, self.dr = mi, dr
        self.material = material
        self.wavelengths_um = [float(x) for x in wavelengths_um]
        self.bsdf = mi.load_dict({"type": "conductor", "material": material})
        self.scalar = v.startswith("scalar")
        self.ctx = mi.BSDFContext()

    @property
    def lanes(self) -> int:
        return len(self.wavelengths_um)

    def _groups(self):
        """The wavelengths (nm) in groups of four (the last padded with its last)."""
        nm = [1000.0 * x for x in self.wavelengths_um]
        for g in range(0, len(nm), 4):
            part = nm[g:g + 4]
            yield g, len(part), part + [part[-1]] * (4 - len(part))

    def __call__(self, cos_i: np.ndarray) -> np.ndarray:
        """Reflectance (N, lanes) of hits at cosines cos_i (N,)."""
        mi, dr = self.mi, self.dr
        c = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
        n = len(c)
        out = np.zeros((n, self.lanes))
        if n == 0:
            return out
        sin = np.sqrt(np.maximum(1.0 - c * c, 0.0))
        if self.scalar:
            for i in range(n):
                si = dr.zeros(mi.SurfaceInteraction3f)
                si.wi = mi.Vector3f(float(sin[i]), 0.0, float(c[i]))
                for g, k, nm in self._groups():
                    si.wavelengths = type(si.wavelengths)(*nm)
                    _, val = self.bsdf.sample(self.ctx, si, 0.5, mi.Point2f(0.5, 0.5))
                    out[i, g:g + k] = np.array(val, dtype=np.float64)[:k]
            return out
        f32 = np.float32
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(mi.Float(sin.astype(f32)), mi.Float(np.zeros(n, f32)), mi.Float(c.astype(f32)))
        for g, k, nm in self._groups():
            si.wavelengths = type(si.wavelengths)(*nm)
            _, val = self.bsdf.sample(self.ctx, si, mi.Float(0.5), mi.Point2f(0.5, 0.5))
            dr.eval(val)
            out[:, g:g + k] = np.asarray(val.numpy(), dtype=np.float64)[:k].T
        return out


def parse_wavelengths(text: str) -> list[float]:
    """`--wavelengths`: a comma-separated list of um, or FROM:TO:STEP (um,
    both ends included, as roks's `--wavelengths`)."""
    t = text.strip()
    if ":" in t:
        parts = [float(x) for x in t.split(":")]
        if len(parts) != 3 or not (parts[2] > 0 and parts[1] >= parts[0] > 0):
            raise ValueError(f"{text!r}: FROM:TO:STEP with 0 < FROM <= TO and STEP > 0")
        a, b, step = parts
        count = int(math.floor((b - a) / step * (1.0 + 1e-12))) + 1
        return [round((a + i * step) * 1e9) / 1e9 for i in range(count)]  # as roks (scene/mod.rs)
    out = [float(x) for x in t.split(",") if x.strip()]
    if not out or any(not (x > 0) for x in out) or any(b <= a for a, b in zip(out, out[1:])):
        raise ValueError(f"{text!r}: positive wavelengths (um), strictly increasing")
    return out


# --------------------------------------------------------------------------
# Polarisation: roks's frames and states (src/optics/polarisation.rs), Mitsuba's matrices

INCIDENT_STATES = {
    "unpolarised": (1.0, 0.0, 0.0, 0.0),
    "s": (1.0, 1.0, 0.0, 0.0),
    "p": (1.0, -1.0, 0.0, 0.0),
    "right": (1.0, 0.0, 0.0, 1.0),
    "left": (1.0, 0.0, 0.0, -1.0),
}


def parse_incident(text: str) -> np.ndarray:
    """An incident Stokes vector of unit intensity from `--incident`: unpolarised, s, p,
    right, left, linear=DEG (from the reference vector toward y = d x x), or S0,S1,S2,S3."""
    t = text.strip().lower()
    if t in INCIDENT_STATES:
        return np.array(INCIDENT_STATES[t])
    if t.startswith("linear="):
        a = 2.0 * math.radians(float(t.split("=", 1)[1]))
        return np.array([1.0, math.cos(a), math.sin(a), 0.0])
    v = np.array([float(x) for x in t.split(",")])
    if v.shape != (4,) or not np.all(np.isfinite(v)) or not v[0] > 0:
        raise ValueError(f"Stokes vector {text!r}: four finite numbers with S0 > 0")
    if np.dot(v[1:], v[1:]) > v[0] * v[0] * (1.0 + 1e-12):
        raise ValueError(f"Stokes vector {text!r}: degree of polarisation > 1")
    return v / v[0]


def hemisphere_reference(d: np.ndarray, pole_phi: float) -> np.ndarray:
    """roks's reference vectors of flights d (N, 3): normalize(z x d), or
    (-sin phi, cos phi, 0) of the pole azimuth (radians) for d along +-z."""
    r2 = d[:, 0] ** 2 + d[:, 1] ** 2
    pole = r2 <= 1e-280
    r = np.sqrt(np.where(pole, 1.0, r2))
    x = np.stack([-d[:, 1] / r, d[:, 0] / r, np.zeros(len(d))], axis=1)
    x[pole] = (-math.sin(pole_phi), math.cos(pole_phi), 0.0)
    return x


class MitsubaMueller:
    """Mitsuba's own Mueller matrices (`mi.mueller` of the polarised variant that
    is set, float32) for a batch, returned as float64 numpy arrays (N, 4, 4),
    row index first."""

    def __init__(self, mi, n: float, k: float):
        if not mi.variant().endswith("_polarized"):
            raise ValueError(f"polarisation needs a *_polarized variant, not {mi.variant()}")
        self.mi = mi
        self.n, self.k = n, k
        self.scalar = mi.variant().startswith("scalar")

    def _vec(self, v: np.ndarray):
        f = np.float32
        return self.mi.Vector3f(*(self.mi.Float(v[:, i].astype(f)) for i in range(3)))

    @staticmethod
    def _batch(m) -> np.ndarray:
        # a drjit Matrix4f over N lanes: numpy (4, 4, N) -> (N, 4, 4)
        return np.moveaxis(np.asarray(m.numpy(), dtype=np.float64).reshape(4, 4, -1), -1, 0)

    def specular_reflection(self, cos_i: np.ndarray) -> np.ndarray:
        """`mi.mueller.specular_reflection(cos_i, n + ik)` (its s frames)."""
        mi = self.mi
        if len(cos_i) == 0:
            return np.zeros((0, 4, 4))
        if self.scalar:
            eta = mi.ScalarComplex2f(self.n, self.k)
            return np.array([np.array(mi.mueller.specular_reflection(float(c), eta), dtype=np.float64)
                             for c in cos_i])
        eta = mi.Complex2f(mi.Float(self.n), mi.Float(self.k))
        return self._batch(mi.mueller.specular_reflection(mi.Float(cos_i.astype(np.float32)), eta))

    def rotate_stokes_basis(self, forward: np.ndarray, current: np.ndarray,
                            target: np.ndarray) -> np.ndarray:
        """`mi.mueller.rotate_stokes_basis(forward, current, target)` for unit (N, 3) arrays."""
        mi = self.mi
        if len(forward) == 0:
            return np.zeros((0, 4, 4))
        if self.scalar:
            V = mi.ScalarVector3f
            return np.array([np.array(mi.mueller.rotate_stokes_basis(V(*f), V(*c), V(*t)), dtype=np.float64)
                             for f, c, t in zip(forward, current, target)])
        return self._batch(mi.mueller.rotate_stokes_basis(self._vec(forward), self._vec(current),
                                                          self._vec(target)))


class PolarisedCarrier:
    """Stokes columns (N, 4, C) with reference vectors (N, 3) through a batch of
    paths: C = 1 the Stokes vector of the incident state, C = 4 the path's
    Mueller matrix by columns (the responses to the incident basis states)."""

    def __init__(self, mueller: MitsubaMueller, mode: str, incident: np.ndarray, pole_phi: float):
        if mode not in ("stokes", "mueller"):
            raise ValueError(f"polarisation mode {mode!r}")
        self.mueller, self.mode = mueller, mode
        self.incident = np.asarray(incident, dtype=np.float64)
        self.pole_phi = pole_phi
        self.names = STOKES_NAMES if mode == "stokes" else MUELLER_NAMES

    def launch(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = len(d)
        if self.mode == "stokes":
            cols = np.tile(self.incident[None, :, None], (m, 1, 1))
        else:
            cols = np.tile(np.eye(4)[None], (m, 1, 1))
        return cols, hemisphere_reference(d, self.pole_phi)

    def reflect(self, cols: np.ndarray, x: np.ndarray, d_in: np.ndarray, n: np.ndarray,
                cos_i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Specular reflection about unit normals n facing the flights d_in: the new
        columns and reference vectors (the s axes)."""
        s = np.cross(n, d_in)
        len2 = np.einsum("ij,ij->i", s, s)
        ok = len2 > 1e-24  # else normal incidence: any s axis is exact, keep x
        s = np.where(ok[:, None], s / np.sqrt(np.where(ok, len2, 1.0))[:, None], x)
        R = self.mueller.rotate_stokes_basis(d_in, x, s)
        F = self.mueller.specular_reflection(cos_i)
        return np.einsum("nij,njk,nkc->nic", F, R, cols), s

    def to_hemisphere(self, cols: np.ndarray, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The columns re-expressed in the hemisphere frames of the flights d."""
        R = self.mueller.rotate_stokes_basis(d, x, hemisphere_reference(d, self.pole_phi))
        return np.einsum("nij,njc->nic", R, cols)

    def intensity(self, cols: np.ndarray) -> np.ndarray:
        """S0 of the first column (roulette, as roks)."""
        return cols[:, 0, 0]

    def weight_for(self, cols: np.ndarray) -> np.ndarray:
        """The intensity for the incident state (the brdf.csv weight)."""
        return cols[:, 0, 0] if self.mode == "stokes" else cols[:, 0, :] @ self.incident

    def components(self, cols: np.ndarray) -> np.ndarray:
        """(N, 4) Stokes vectors, or (N, 16) Mueller matrices row-major (m_ij at 4 i + j)."""
        return cols.reshape(len(cols), -1)


def mitsuba_ior(mi, material: str, wavelengths_um: list[float]) -> tuple[list[float], list[float]]:
    """Mitsuba's own n and k of a conductor preset at the wavelengths (um):
    its files data/ior/MATERIAL.eta.spd and .k.spd loaded as Mitsuba
    `spectrum` textures (the `irregular` spectrum that conductor.cpp's
    complex_ior_from_file builds) and evaluated by Mitsuba at those
    wavelengths (a spectral variant; float32)."""
    import drjit as dr

    if "spectral" not in mi.variant():
        raise ValueError(f"Mitsuba's conductor spectra need a spectral variant, not {mi.variant()}")
    root = Path(mi.__file__).resolve().parent / "data" / "ior"
    texs = []
    for part in ("eta", "k"):
        f = root / f"{material}.{part}.spd"
        if not f.is_file():
            raise ValueError(f"{f}: no such Mitsuba conductor preset {material!r}")
        texs.append(mi.load_dict({"type": "spectrum", "filename": str(f)}))
    out = ([], [])
    nm = [1000.0 * x for x in wavelengths_um]
    for g in range(0, len(nm), 4):
        part = nm[g:g + 4]
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wavelengths = type(si.wavelengths)(*(part + [part[-1]] * (4 - len(part))))
        for t, o in zip(texs, out):
            v = np.asarray(t.eval(si).numpy() if hasattr(t.eval(si), "numpy") else t.eval(si),
                           dtype=np.float64).reshape(-1)
            o.extend(float(x) for x in v[:len(part)])
    return out


class SpectralPolarisedCarrier:
    """Stokes vectors of the incident state, one per wavelength, through a batch
    of paths: columns (N, 4, L), lane l the Stokes vector at wavelength l, with
    one reference vector per photon (the geometry is shared). At a hit the
    columns are turned into the s frame by Mitsuba's rotate_stokes_basis (the
    same for every lane) and multiplied by Mitsuba's
    specular_reflection(cos_i, n_l + i k_l) per lane, n_l and k_l Mitsuba's own
    spectra (`mitsuba_ior`). The interface of `PolarisedCarrier` (the tracer's
    loop is shared): the intensity for roulette is the largest lane's S0, the
    brdf.csv weight the S0 of every lane (N, L); no Stokes tallies are kept
    (`names` is empty)."""

    mode = "stokes"
    names: list[str] = []

    def __init__(self, mi, n: list[float], k: list[float], incident: np.ndarray, pole_phi: float):
        self.lanes = [MitsubaMueller(mi, a, b) for a, b in zip(n, k)]
        self.rot = self.lanes[0]
        self.incident = np.asarray(incident, dtype=np.float64)
        self.pole_phi = pole_phi

    def launch(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cols = np.tile(self.incident[None, :, None], (len(d), 1, len(self.lanes)))
        return cols, hemisphere_reference(d, self.pole_phi)

    def reflect(self, cols, x, d_in, n, cos_i):
        s = np.cross(n, d_in)
        len2 = np.einsum("ij,ij->i", s, s)
        ok = len2 > 1e-24
        s = np.where(ok[:, None], s / np.sqrt(np.where(ok, len2, 1.0))[:, None], x)
        turned = np.einsum("nij,njl->nil", self.rot.rotate_stokes_basis(d_in, x, s), cols)
        out = np.empty_like(cols)
        for l, m in enumerate(self.lanes):
            out[:, :, l] = np.einsum("nij,nj->ni", m.specular_reflection(cos_i), turned[:, :, l])
        return out, s

    def to_hemisphere(self, cols, x, d):
        R = self.rot.rotate_stokes_basis(d, x, hemisphere_reference(d, self.pole_phi))
        return np.einsum("nij,njl->nil", R, cols)

    def intensity(self, cols):
        return cols[:, 0, :].max(axis=1)

    def weight_for(self, cols):
        return cols[:, 0, :]

    def components(self, cols):
        return np.zeros((len(cols), 0))


# --------------------------------------------------------------------------
# Tallies (roks's Carlson grid and in-plane goniometer)


class Carlson:
    """Carlson equal-solid-angle grid, M bands, 4j cells in band j."""

    def __init__(self, bands: int):
        self.M = bands
        self.K = bands * (bands + 1)
        self.n_cells = 2 * self.K
        self.offset = np.array([2 * j * (j - 1) for j in range(bands + 2)])  # flat index of (j, 0)

    def mu_edges(self, j):
        """(mu_bot, mu_top) of band j (1-based), as roks computes them."""
        return (self.K - j * (j + 1)) / self.K, (self.K - (j - 1) * j) / self.K

    def locate(self, d: np.ndarray) -> np.ndarray:
        """Flat cell index of unit directions d (N, 3), d_z > 0."""
        mu = d[:, 2]
        x = (1.0 - mu) * self.K
        j = np.ceil((-1.0 + np.sqrt(1.0 + 4.0 * np.maximum(x, 0.0))) / 2.0).astype(np.int64)
        j = np.clip(j, 1, self.M)
        for _ in range(2):  # correct rounding against the exact edges
            bot, top = self.mu_edges(j)
            j = np.where((j < self.M) & (mu < bot), j + 1, j)
            bot, top = self.mu_edges(j)
            j = np.where((j > 1) & (mu >= top), j - 1, j)
        n = 4 * j
        dphi = math.tau / n
        v = np.arctan2(d[:, 1], d[:, 0]) / dphi + 0.5 + n
        cell = np.mod(np.floor(v).astype(np.int64), n)
        return self.offset[j] + cell

    def rows(self):
        """(band, cell, theta_lo, theta_hi, phi_lo, phi_hi, theta, phi, omega, proj) in degrees."""
        omega = math.pi / self.K
        for j in range(1, self.M + 1):
            bot, top = self.mu_edges(j)
            dphi = math.tau / (4 * j)
            proj = math.pi * (self.K - j * j) / (self.K * self.K)
            theta = math.degrees(math.acos(0.5 * (top + bot)))
            for c in range(4 * j):
                centre = c * dphi
                yield (j, c, math.degrees(math.acos(top)), math.degrees(math.acos(bot)),
                       math.degrees(centre - 0.5 * dphi), math.degrees(centre + 0.5 * dphi),
                       theta, math.degrees(centre), omega, proj)


class InPlane:
    """roks's in-plane goniometer: 1 degree bins centred on whole degrees -90..90
    (half bins at the ends), detector 2 x half_width degrees out of the plane."""

    def __init__(self, phi_i_deg: float, step_deg: float = 1.0, half_width_deg: float = 0.5):
        p = math.radians(phi_i_deg)
        self.u = np.array([-math.cos(p), -math.sin(p), 0.0])
        self.v = np.array([math.sin(p), -math.cos(p), 0.0])
        n = round(180.0 / step_deg)
        self.step = 180.0 / n
        self.n_bins = n + 1
        self.hw = half_width_deg

    def locate(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(mask of directions in the detector, their bins)."""
        tp = np.degrees(np.arctan2(d @ self.u, d[:, 2]))
        psi = np.degrees(np.arcsin(np.clip(d @ self.v, -1.0, 1.0)))
        ok = (d[:, 2] > 0.0) & (np.abs(psi) <= self.hw)
        b = np.floor((tp + 90.0) / self.step + 0.5)
        b = np.clip(b, 0, self.n_bins - 1).astype(np.int64)
        return ok, b

    def edges(self, b: int):
        c = -90.0 + b * self.step
        return max(c - 0.5 * self.step, -90.0), min(c + 0.5 * self.step, 90.0)

    def centre(self, b: int) -> float:
        lo, hi = self.edges(b)
        return 0.5 * (lo + hi)

    def proj(self, b: int) -> float:
        lo, hi = self.edges(b)
        w = math.radians(self.hw)
        return (w + math.sin(2 * w) / 2.0) * (math.sin(math.radians(hi)) - math.sin(math.radians(lo)))


class Acc:
    """Per-bin sums of per-photon scores and of their squares (float64); with
    `width`, each score is a vector of that many components."""

    def __init__(self, n: int, width: int | None = None):
        shape = (n,) if width is None else (n, width)
        self.s = np.zeros(shape)
        self.s2 = np.zeros(shape)

    def add(self, bins: np.ndarray, w: np.ndarray) -> None:
        n = len(self.s)
        if w.ndim == 1:
            self.s += np.bincount(bins, weights=w, minlength=n)
            self.s2 += np.bincount(bins, weights=w * w, minlength=n)
            return
        for c in range(w.shape[1]):
            self.s[:, c] += np.bincount(bins, weights=w[:, c], minlength=n)
            self.s2[:, c] += np.bincount(bins, weights=w[:, c] ** 2, minlength=n)

    def add_directions(self, grid: "Carlson", d: np.ndarray, w: np.ndarray) -> None:
        """Carlson cells of unit directions d (N, 3): a direction along +z, whose
        azimuth is undefined, is shared among band 1's four cells (as roks)."""
        pole = (d[:, 0] == 0.0) & (d[:, 1] == 0.0)
        if pole.any():
            wp = 0.25 * w[pole]
            for c in range(4):
                self.add(np.full(len(wp), c, dtype=np.int64), wp)
        if (~pole).any():
            self.add(grid.locate(d[~pole]), w[~pole])

    def mean(self, n: int) -> np.ndarray:
        return self.s / n

    def stderr(self, n: int) -> np.ndarray:
        if n < 2:
            return np.zeros_like(self.s)
        m = self.s / n
        return np.sqrt(np.maximum(self.s2 / n - m * m, 0.0) / (n - 1))


# --------------------------------------------------------------------------
# Number formatting as roks (Rust `{}` and `{:.9e}`)


def rs(x: float) -> str:
    """Rust's `{}` for f64 (shortest round-trip, no exponent, no trailing .0)."""
    x = float(x)
    if x == int(x) and abs(x) < 1e16:
        return str(int(x)) if x != 0 else ("-0" if math.copysign(1, x) < 0 else "0")
    r = repr(x)
    if "e" in r:
        r = np.format_float_positional(x, unique=True, trim="-")
    return r


def re_(x: float, digits: int = 9) -> str:
    """Rust's `{:.Ne}` (e.g. 5.807645337e-3, 0.000000000e0)."""
    m, e = f"{float(x):.{digits}e}".split("e")
    return f"{m}e{int(e)}"


# --------------------------------------------------------------------------
# Tracer


class Tracer:
    def __init__(self, mi, mesh_path: str, lx: float, ly: float, block: int = 1,
                 offset: float = 1e-5):
        import drjit as dr

        self.mi, self.dr = mi, dr
        self.lx, self.ly, self.block = lx, ly, block
        self.scalar = mi.variant().startswith("scalar")
        mesh_dict = {"type": "ply", "filename": str(mesh_path), "face_normals": True}
        mesh = mi.load_dict(mesh_dict)
        bb = mesh.bbox()
        self.zmin, self.zmax = float(bb.min.z), float(bb.max.z)
        self.bbox = ((float(bb.min.x), float(bb.min.y)), (float(bb.max.x), float(bb.max.y)))
        self.n_triangles = int(mesh.face_count())
        scene = {"type": "scene", "surface": {"type": "shapegroup", "mesh": mesh_dict}}
        T = mi.ScalarTransform4f
        for i in range(-block, block + 1):
            for j in range(-block, block + 1):
                scene[f"cell_{i + block}_{j + block}"] = {
                    "type": "instance",
                    "shapegroup": {"type": "ref", "id": "surface"},
                    "to_world": T().translate([i * lx, j * ly, 0.0]),
                }
        self.scene = mi.load_dict(scene)
        self.scale = max(lx, ly, self.zmax - self.zmin)
        self.eps = offset * self.scale
        # launch / escape plane just above the highest point
        self.ztop = self.zmax + 1e-4 * self.scale

    # -- one wavefront of intersections: numpy float64 in, numpy out --------
    def intersect(self, o: np.ndarray, d: np.ndarray, maxt: np.ndarray):
        mi, dr = self.mi, self.dr
        n = len(o)
        if self.scalar:
            hit = np.zeros(n, dtype=bool)
            t = np.full(n, np.inf)
            nrm = np.zeros((n, 3))
            for k in range(n):
                ray = mi.Ray3f(mi.Point3f(*o[k]), mi.Vector3f(*d[k]))
                ray.maxt = float(maxt[k]) if np.isfinite(maxt[k]) else float("inf")
                si = self.scene.ray_intersect(ray, ray_flags=mi.RayFlags.Minimal, coherent=False)
                if si.is_valid():
                    hit[k] = True
                    t[k] = si.t
                    nrm[k] = (si.n[0], si.n[1], si.n[2])
            return hit, t, nrm
        f32 = np.float32
        ray = mi.Ray3f(
            mi.Point3f(mi.Float(o[:, 0].astype(f32)), mi.Float(o[:, 1].astype(f32)), mi.Float(o[:, 2].astype(f32))),
            mi.Vector3f(mi.Float(d[:, 0].astype(f32)), mi.Float(d[:, 1].astype(f32)), mi.Float(d[:, 2].astype(f32))),
        )
        ray.maxt = mi.Float(maxt.astype(f32))
        si = self.scene.ray_intersect(ray, ray_flags=mi.RayFlags.Minimal, coherent=False)
        valid = si.is_valid()
        dr.eval(valid, si.t, si.n)
        hit = valid.numpy().astype(bool)
        t = si.t.numpy().astype(np.float64)
        nrm = si.n.numpy().astype(np.float64).T
        return hit, t, nrm

    def _wrap(self, o: np.ndarray) -> None:
        """Periodic wrap of origins into the central cell by whole periods (in place)."""
        lx, ly = self.lx, self.ly
        o[:, 0] = np.mod(o[:, 0], lx)
        o[:, 1] = np.mod(o[:, 1], ly)
        # np.mod can return exactly lx for tiny negative inputs
        o[:, 0] = np.where(o[:, 0] >= lx, 0.0, o[:, 0])
        o[:, 1] = np.where(o[:, 1] >= ly, 0.0, o[:, 1])

    def run(self, theta_deg: float, phi_deg: float, photons: int, seed: int, index: int,
            reflectance, bands: int, max_bounces: int = 100_000, max_segments: int = 10_000,
            roulette_weight: float = 0.01, batch: int = 1 << 20, max_misses: int = 1000,
            polarised: PolarisedCarrier | None = None, lanes: int | None = None):
        """Trace `photons` at incidence (theta, phi). `reflectance(cos_i)` weighs the
        scalar path; with `polarised` the photons carry its Stokes columns instead
        (and `w` is their intensity, `polarised.intensity`). With `lanes` (spectral:
        one weight per wavelength, `reflectance(cos_i)` then returns (N, lanes)) `w`
        is (N, lanes), every tally has a component per lane, and roulette and the
        dead test use the largest lane (survivors are scaled so it is w_s: unbiased
        for every lane, as roks's `carrier::Spectral`)."""
        lx, ly, B = self.lx, self.ly, self.block
        pol = polarised
        rng = np.random.default_rng([seed, index, int(round(theta_deg * 1e6)) & 0xFFFFFFFF])
        grid = Carlson(bands)
        inpl = InPlane(phi_deg)
        carl, ipt = Acc(grid.n_cells, lanes), Acc(inpl.n_bins, lanes)
        refl = Acc(1, lanes)
        if pol:
            width = len(pol.names)
            carl_pol, refl_pol = Acc(grid.n_cells, width), Acc(1, width)
        by_b = np.zeros(BOUNCE_BINS if lanes is None else (BOUNCE_BINS, lanes))
        zero_loss = 0.0 if lanes is None else np.zeros(lanes)
        stats = dict(bounces=0, segments=0, lost_cap=zero_loss, lost_numeric=zero_loss,
                     capped_histories=0, numeric_histories=0)
        t_, p_ = math.radians(theta_deg), math.radians(phi_deg)
        w_i = np.array([math.sin(t_) * math.cos(p_), math.sin(t_) * math.sin(p_), math.cos(t_)])
        w_s = min(10.0 * roulette_weight, 1.0)
        t0 = time.perf_counter()
        done = 0
        while done < photons:
            m = min(batch, photons - done)
            done += m
            o = np.empty((m, 3))
            o[:, 0] = rng.random(m) * lx
            o[:, 1] = rng.random(m) * ly
            o[:, 2] = self.ztop
            d = np.tile(-w_i, (m, 1))
            w = np.ones(m if lanes is None else (m, lanes))
            cols = x = None
            if pol:
                cols, x = pol.launch(d)
                w = pol.intensity(cols)
            nb = np.zeros(m, dtype=np.int64)
            ns = np.zeros(m, dtype=np.int64)
            nm = np.zeros(m, dtype=np.int64)  # consecutive segments without a hit
            while len(w):
                # nothing lies above zmax: a ray there going down moves straight to
                # z = zmax (the launch at grazing incidence, near-horizontal rays
                # leaving a ridge), then is wrapped into the central cell
                above = (o[:, 2] > self.zmax) & (d[:, 2] < 0)
                if above.any():
                    # stop eps short along the ray: the origin must not lie on the surface
                    ta = np.maximum((self.zmax - o[above, 2]) / d[above, 2] - self.eps, 0.0)
                    o[above] += ta[:, None] * d[above]
                    self._wrap(o)
                # segment length: to the edge of the instance block, or up to z = zmax
                # (a ray at or above zmax that does not go down leaves at once: maxt 0)
                with np.errstate(divide="ignore", invalid="ignore"):
                    tx = np.where(d[:, 0] > 0, ((B + 1) * lx - o[:, 0]) / d[:, 0],
                                  np.where(d[:, 0] < 0, (o[:, 0] + B * lx) / -d[:, 0], np.inf))
                    ty = np.where(d[:, 1] > 0, ((B + 1) * ly - o[:, 1]) / d[:, 1],
                                  np.where(d[:, 1] < 0, (o[:, 1] + B * ly) / -d[:, 1], np.inf))
                    ttop = np.where(d[:, 2] > 0, np.maximum((self.zmax - o[:, 2]) / d[:, 2], 0.0),
                                    np.where((d[:, 2] == 0) & (o[:, 2] >= self.zmax), 0.0, np.inf))
                tbox = np.minimum(tx, ty)
                maxt = np.minimum(tbox, ttop)
                hit, t, nrm = self.intersect(o, d, maxt)
                ns += 1
                stats["segments"] += len(w)
                keep = np.ones(len(w), dtype=bool)

                # escapes: reached z = zmax going up (or horizontal above it) without a hit
                esc = ~hit & (ttop <= tbox)
                if esc.any():
                    de, we = d[esc], w[esc]
                    zero = np.zeros(len(we), dtype=np.int64)
                    if pol:
                        ce = pol.to_hemisphere(cols[esc], x[esc], de)
                        we = pol.weight_for(ce)
                        comp = pol.components(ce)
                        refl_pol.add(zero, comp)
                        carl_pol.add_directions(grid, de, comp)
                    refl.add(zero, we)
                    carl.add_directions(grid, de, we)
                    ok, b = inpl.locate(de)
                    if ok.any():
                        ipt.add(b[ok], we[ok])
                    np.add.at(by_b, np.minimum(nb[esc], BOUNCE_BINS - 1), we)
                    keep &= ~esc

                # misses that did not escape: re-launch from the clip point
                rel = ~hit & ~esc
                if rel.any():
                    nm[rel] += 1
                    nm[hit] = 0
                    # a ray relaunched max_misses times in a row is stuck (e.g. sliding
                    # horizontally along a ridge at zmax): a numerical loss
                    bad = rel & (~np.isfinite(tbox) | (nm >= max_misses))
                    tr = np.where(np.isfinite(tbox), tbox, 0.0)
                    o[rel] = o[rel] + tr[rel, None] * d[rel]
                    bad |= rel & (o[:, 2] < self.zmin - self.eps)
                    if bad.any():
                        stats["lost_numeric"] = stats["lost_numeric"] + self._lost(pol, w, cols, bad)
                        stats["numeric_histories"] += int(bad.sum())
                        keep &= ~bad

                # hits: specular reflection about the geometric normal facing the ray
                if hit.any():
                    dh, nh = d[hit], nrm[hit]
                    nh /= np.linalg.norm(nh, axis=1)[:, None]
                    dn = np.einsum("ij,ij->i", dh, nh)
                    nh[dn > 0] *= -1.0
                    cos_i = np.abs(dn)
                    p = o[hit] + t[hit, None] * dh
                    dr_ = dh + (2.0 * cos_i)[:, None] * nh
                    dr_ /= np.linalg.norm(dr_, axis=1)[:, None]
                    if pol:
                        cols[hit], x[hit] = pol.reflect(cols[hit], x[hit], dh, nh, cos_i)
                        w[hit] = pol.intensity(cols[hit])
                    else:
                        w[hit] *= reflectance(cos_i)
                    d[hit] = dr_
                    o[hit] = p + self.eps * nh
                    nb[hit] += 1
                    stats["bounces"] += int(hit.sum())
                    lead = w if w.ndim == 1 else w.max(axis=1)
                    dead = hit & (lead <= 0.0)
                    keep &= ~dead
                    low = hit & keep & (lead < roulette_weight)
                    if low.any():
                        survive = rng.random(int(low.sum())) * w_s < lead[low]
                        idx = np.flatnonzero(low)
                        if pol:
                            cols[idx[survive]] *= (w_s / w[idx[survive]])[:, None, None]
                        if w.ndim == 1:
                            w[idx[survive]] = w_s
                        else:
                            w[idx[survive]] *= (w_s / lead[idx[survive]])[:, None]
                        keep[idx[~survive]] = False

                # caps
                cap = keep & ((nb >= max_bounces) | (ns >= max_segments))
                if cap.any():
                    stats["lost_cap"] = stats["lost_cap"] + self._lost(pol, w, cols, cap)
                    stats["capped_histories"] += int(cap.sum())
                    keep &= ~cap

                o, d, w, nb, ns, nm = o[keep], d[keep], w[keep], nb[keep], ns[keep], nm[keep]
                if pol:
                    cols, x = cols[keep], x[keep]
                self._wrap(o)
        seconds = time.perf_counter() - t0
        polar = dict(mode=pol.mode, names=pol.names, carlson=carl_pol, refl=refl_pol) if pol else None
        return dict(theta_deg=theta_deg, phi_deg=phi_deg, photons=photons, grid=grid, inplane=inpl,
                    carlson=carl, inplane_acc=ipt, refl=refl, by_bounces=by_b, seconds=seconds,
                    polar=polar, **stats)

    @classmethod
    def _lost(cls, pol, w: np.ndarray, cols, sel: np.ndarray):
        """The summed weight of the photons `sel`: a float, or per lane (spectral)."""
        v = cls._score(pol, w, cols, sel)
        return float(v.sum()) if v.ndim == 1 else v.sum(axis=0)

    @staticmethod
    def _score(pol, w: np.ndarray, cols, sel: np.ndarray) -> np.ndarray:
        """Intensity for the incident state of the photons `sel` (the lost weight)."""
        return pol.weight_for(cols[sel]) if pol else w[sel]


# --------------------------------------------------------------------------
# Output


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def summary_entry(r: dict) -> dict:
    if r.get("wavelengths_um") is not None:
        return spectral_summary_entry(r)
    n = r["photons"]
    segs = r["segments"]
    lost = r["lost_cap"] / n + r["lost_numeric"] / n
    entry = {
        "theta_deg": r["theta_deg"],
        "phi_deg": r["phi_deg"],
        "photons": n,
        "reflectance": float(r["refl"].mean(n)[0]),
        "reflectance_stderr": float(r["refl"].stderr(n)[0]),
        "mean_bounces": r["bounces"] / n,
        "lost": lost,
        "lost_walls": 0.0,
        "lost_cap": r["lost_cap"] / n,
        "lost_numeric": r["lost_numeric"] / n,
        "capped_histories": r["capped_histories"],
        "numeric_histories": r["numeric_histories"],
        "reflectance_by_bounces": [float(x) / n for x in r["by_bounces"]],
        "segments": segs,
        "seconds": r["seconds"],
        "segments_per_second": segs / r["seconds"] if r["seconds"] > 0 else 0.0,
    }
    if r.get("polar"):
        pz = r["polar"]
        key = f"reflected_{pz['mode']}"
        entry[key] = [float(v) for v in pz["refl"].mean(n)[0]]
        entry[f"{key}_stderr"] = [float(v) for v in pz["refl"].stderr(n)[0]]
    return entry


def spectral_summary_entry(r: dict) -> dict:
    """A spectral run's incidence entry, as roks's: `spectrum` per wavelength
    (reflectance, its standard error, the losses); the entry's own
    reflectance, losses and `reflectance_by_bounces` are the means over the
    wavelengths, its `reflectance_stderr` the mean of theirs."""
    n = r["photons"]
    wl = r["wavelengths_um"]
    refl, se = r["refl"].mean(n)[0], r["refl"].stderr(n)[0]
    cap, num = np.asarray(r["lost_cap"]) / n, np.asarray(r["lost_numeric"]) / n
    spectrum = [{"wavelength_um": float(w), "reflectance": float(refl[l]),
                 "reflectance_stderr": float(se[l]), "lost": float(cap[l] + num[l]),
                 "lost_cap": float(cap[l]), "lost_numeric": float(num[l]), "lost_walls": 0.0}
                for l, w in enumerate(wl)]
    segs = r["segments"]
    return {
        "theta_deg": r["theta_deg"],
        "phi_deg": r["phi_deg"],
        "photons": n,
        "reflectance": float(refl.mean()),
        "reflectance_stderr": float(se.mean()),
        "mean_bounces": r["bounces"] / n,
        "lost": float((cap + num).mean()),
        "lost_walls": 0.0,
        "lost_cap": float(cap.mean()),
        "lost_numeric": float(num.mean()),
        "capped_histories": r["capped_histories"],
        "numeric_histories": r["numeric_histories"],
        "reflectance_by_bounces": [float(x) / n for x in r["by_bounces"].mean(axis=1)],
        "segments": segs,
        "seconds": r["seconds"],
        "segments_per_second": segs / r["seconds"] if r["seconds"] > 0 else 0.0,
        "spectrum": spectrum,
    }


def write_spectral_outputs(out: Path, results: list[dict], meta: dict) -> None:
    """brdf.csv and inplane.csv in roks's spectral layout (`wavelength_um`
    after `phi_i_deg`, resp. `theta_i_deg`; a block per incidence and
    wavelength, incidence-major) and summary.json with `wavelengths_um` and
    `spectrum` per incidence."""
    out.mkdir(parents=True, exist_ok=True)
    lines = [SPECTRAL_BRDF_HEADER]
    for r in results:
        n = r["photons"]
        f, fe = r["carlson"].mean(n), r["carlson"].stderr(n)
        for l, wl in enumerate(r["wavelengths_um"]):
            for flat, row in enumerate(r["grid"].rows()):
                band, cell, tlo, thi, plo, phi_hi, th, ph, omega, proj = row
                lines.append(",".join([
                    rs(r["theta_deg"]), rs(r["phi_deg"]), rs(wl), str(band), str(cell), rs(tlo), rs(thi),
                    rs(plo), rs(phi_hi), rs(th), rs(ph), re_(omega, 12), re_(proj, 12),
                    re_(f[flat, l]), re_(fe[flat, l]), re_(f[flat, l] / proj), re_(fe[flat, l] / proj)]))
    _atomic_write(out / "brdf.csv", "\n".join(lines) + "\n")
    lines = [SPECTRAL_INPLANE_HEADER]
    for r in results:
        n = r["photons"]
        ip = r["inplane"]
        f, fe = r["inplane_acc"].mean(n), r["inplane_acc"].stderr(n)
        for l, wl in enumerate(r["wavelengths_um"]):
            for b in range(ip.n_bins):
                pr = ip.proj(b)
                lines.append(f"{rs(r['theta_deg'])},{rs(wl)},{rs(ip.centre(b))},{re_(f[b, l] / pr)},"
                             f"{re_(fe[b, l] / pr)}")
    _atomic_write(out / "inplane.csv", "\n".join(lines) + "\n")
    summary = {"incidence": [summary_entry(r) for r in results], **meta}
    _atomic_write(out / "summary.json", json.dumps(summary, indent=2) + "\n")


def write_outputs(out: Path, results: list[dict], meta: dict) -> None:
    if results and results[0].get("wavelengths_um") is not None:
        return write_spectral_outputs(out, results, meta)
    out.mkdir(parents=True, exist_ok=True)
    lines = [BRDF_HEADER]
    for r in results:
        n = r["photons"]
        f, fe = r["carlson"].mean(n), r["carlson"].stderr(n)
        for flat, row in enumerate(r["grid"].rows()):
            band, cell, tlo, thi, plo, phi_hi, th, ph, omega, proj = row
            lines.append(",".join([
                rs(r["theta_deg"]), rs(r["phi_deg"]), str(band), str(cell), rs(tlo), rs(thi),
                rs(plo), rs(phi_hi), rs(th), rs(ph), re_(omega, 12), re_(proj, 12),
                re_(f[flat]), re_(fe[flat]), re_(f[flat] / proj), re_(fe[flat] / proj)]))
    _atomic_write(out / "brdf.csv", "\n".join(lines) + "\n")
    lines = [INPLANE_HEADER]
    for r in results:
        n = r["photons"]
        ip = r["inplane"]
        f, fe = r["inplane_acc"].mean(n), r["inplane_acc"].stderr(n)
        for b in range(ip.n_bins):
            pr = ip.proj(b)
            lines.append(f"{rs(r['theta_deg'])},{rs(ip.centre(b))},{re_(f[b] / pr)},{re_(fe[b] / pr)}")
    _atomic_write(out / "inplane.csv", "\n".join(lines) + "\n")
    if results and results[0].get("polar"):
        mode = results[0]["polar"]["mode"]
        name, header = ("stokes.csv", STOKES_HEADER) if mode == "stokes" else ("mueller.csv", MUELLER_HEADER)
        lines = [header]
        for r in results:
            n = r["photons"]
            acc = r["polar"]["carlson"]
            v, ve = acc.mean(n), acc.stderr(n)
            for flat, row in enumerate(r["grid"].rows()):
                band, cell, _, _, _, _, th, ph, _, proj = row
                f = [rs(r["theta_deg"]), rs(r["phi_deg"]), str(band), str(cell), rs(th), rs(ph)]
                for c in range(v.shape[1]):
                    f += [re_(v[flat, c] / proj), re_(ve[flat, c] / proj)]
                if mode == "stokes":
                    s0 = v[flat, 0]
                    f.append(re_(math.sqrt(float(v[flat, 1:] @ v[flat, 1:])) / s0 if s0 > 0 else 0.0))
                lines.append(",".join(f))
        _atomic_write(out / name, "\n".join(lines) + "\n")
    summary = {"incidence": [summary_entry(r) for r in results], **meta}
    _atomic_write(out / "summary.json", json.dumps(summary, indent=2) + "\n")


# --------------------------------------------------------------------------


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", help="binary PLY height field over one period [0, Lx] x [0, Ly]")
    ap.add_argument("--size", required=True, help="LX,LY: the period")
    ap.add_argument("--theta", default="0,30,60", help="incidence polar angles (deg), comma separated")
    ap.add_argument("--phi", type=float, default=0.0, help="incidence azimuth (deg)")
    ap.add_argument("--photons", type=int, default=100_000, help="per incidence angle")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rho", type=float, default=None, help="constant reflectance per bounce")
    ap.add_argument("--n", type=float, default=None, help="refractive index (unpolarised Fresnel)")
    ap.add_argument("--k", type=float, default=0.0, help="extinction coefficient (with --n)")
    ap.add_argument("--material", default=None,
                    help="Mitsuba conductor preset (e.g. Au: Mitsuba's own n, k spectra), spectral run "
                         "at --wavelengths in a spectral variant (llvm_ad_spectral)")
    ap.add_argument("--wavelengths", default=None,
                    help="with --material: wavelengths in um, W1,W2,... or FROM:TO:STEP (as roks)")
    ap.add_argument("--bands", type=int, default=32, help="Carlson grid bands")
    ap.add_argument("--out", default="out/mitsuba", help="output folder")
    ap.add_argument("--variant", default="auto", choices=["auto", "llvm", "scalar"],
                    help="llvm_ad_rgb (needs libLLVM >= 19) or scalar_rgb; auto: llvm, else scalar")
    ap.add_argument("--block", type=int, default=1, help="instances i, j in -B..B ((2B+1)^2 of them)")
    ap.add_argument("--batch", type=int, default=1 << 20, help="photons per wavefront")
    ap.add_argument("--max-bounces", type=int, default=100_000)
    ap.add_argument("--max-segments", type=int, default=10_000)
    ap.add_argument("--roulette-weight", type=float, default=0.01)
    ap.add_argument("--offset", type=float, default=1e-5,
                    help="origin offset along the normal after a hit, times max(Lx, Ly, height range)")
    ap.add_argument("--polarisation", default="none", choices=["none", "stokes", "mueller"],
                    help="carry Stokes vectors / Mueller matrices (Mitsuba's, polarised variant; needs --n)")
    ap.add_argument("--incident", default="unpolarised",
                    help="incident state: unpolarised, s, p, right, left, linear=DEG or S0,S1,S2,S3")
    ap.add_argument("-q", "--quiet", action="store_true")
    a = ap.parse_args(argv)
    try:
        a.lx, a.ly = (float(s) for s in a.size.split(","))
        a.thetas = [float(s) for s in a.theta.split(",") if s.strip()]
    except ValueError:
        ap.error("--size LX,LY and --theta T1,T2,... take numbers")
    if not (a.lx > 0 and a.ly > 0):
        ap.error("--size: periods must be positive")
    if any(not (0 <= t < 90) for t in a.thetas):
        ap.error("--theta: angles in [0, 90)")
    if sum(x is not None for x in (a.rho, a.n, a.material)) != 1:
        ap.error("give exactly one of --rho, --n [--k] or --material NAME --wavelengths W")
    if (a.material is None) != (a.wavelengths is None):
        ap.error("--material and --wavelengths go together")
    a.wavelengths_um = None
    if a.wavelengths is not None:
        try:
            a.wavelengths_um = parse_wavelengths(a.wavelengths)
        except ValueError as e:
            ap.error(f"--wavelengths: {e}")
        if a.polarisation == "mueller":
            ap.error("--material (spectral): --polarisation stokes or none")
    if a.rho is not None and not (0 <= a.rho <= 1):
        ap.error("--rho in [0, 1]")
    try:
        a.incident_stokes = parse_incident(a.incident)
    except ValueError as e:
        ap.error(f"--incident: {e}")
    if a.polarisation != "none" and a.rho is not None:
        ap.error("--polarisation needs a Fresnel material (--n, --k)")
    if a.polarisation == "none" and np.any(a.incident_stokes[1:] != 0):
        ap.error("--incident: a polarised state needs --polarisation stokes or mueller")
    if a.photons < 1 or a.bands < 1 or a.block < 1:
        ap.error("--photons, --bands and --block must be >= 1")
    if not Path(a.mesh).is_file():
        ap.error(f"{a.mesh}: no such file")
    return a


@command("mitsuba_brdf")
def main(argv=None) -> int:
    a = parse_args(argv)
    mi = setup_mitsuba(a.variant, polarised=a.polarisation != "none", spectral=a.material is not None)
    tracer = Tracer(mi, a.mesh, a.lx, a.ly, block=a.block, offset=a.offset)
    (x0, y0), (x1, y1) = tracer.bbox
    tol = 1e-4 * tracer.scale
    if abs(x0) > tol or abs(y0) > tol or abs(x1 - a.lx) > tol or abs(y1 - a.ly) > tol:
        print(f"mitsuba_brdf: warning: mesh spans [{x0}, {x1}] x [{y0}, {y1}], not one period "
              f"[0, {a.lx}] x [0, {a.ly}]", file=sys.stderr)
    if a.rho is not None:
        rho = a.rho

        def reflectance(c):
            return np.full(len(c), rho)
        material = {"reflectance": rho}
    elif a.material is not None:
        reflectance = None if a.polarisation != "none" else MitsubaConductor(mi, a.material, a.wavelengths_um)
        material = {"mitsuba_conductor": a.material}
    else:
        n_, k_ = a.n, a.k

        def reflectance(c):
            return fresnel_unpolarised(c, n_, k_)
        material = {"n": n_, "k": k_}
    polarised = None
    if a.material is not None and a.polarisation != "none":
        n_, k_ = mitsuba_ior(mi, a.material, a.wavelengths_um)
        material.update(n=n_, k=k_)
        polarised = SpectralPolarisedCarrier(mi, n_, k_, a.incident_stokes, math.radians(a.phi))
    elif a.polarisation != "none":
        polarised = PolarisedCarrier(MitsubaMueller(mi, a.n, a.k), a.polarisation, a.incident_stokes,
                                     math.radians(a.phi))
    results = []
    if not a.quiet:
        print(f"mitsuba_brdf: {mi.variant()}, {tracer.n_triangles} triangles, "
              f"{(2 * a.block + 1) ** 2} instances, heights [{tracer.zmin:.6g}, {tracer.zmax:.6g}]",
              file=sys.stderr)
        print(f"{'theta':>6} {'reflectance':>12} {'stderr':>9} {'bounces':>8} {'lost':>9} "
              f"{'seconds':>8} {'Mseg/s':>7}", file=sys.stderr)
    for i, th in enumerate(a.thetas):
        r = tracer.run(th, a.phi, a.photons, a.seed, i, reflectance, a.bands,
                       max_bounces=a.max_bounces, max_segments=a.max_segments,
                       roulette_weight=a.roulette_weight, batch=a.batch, polarised=polarised,
                       lanes=None if a.wavelengths_um is None else len(a.wavelengths_um))
        r["wavelengths_um"] = a.wavelengths_um
        results.append(r)
        if not a.quiet:
            s = summary_entry(r)
            print(f"{th:6g} {s['reflectance']:12.6f} {s['reflectance_stderr']:9.2e} "
                  f"{s['mean_bounces']:8.4f} {s['lost']:9.2e} {s['seconds']:8.2f} "
                  f"{s['segments_per_second'] / 1e6:7.3f}", file=sys.stderr)
    meta = {
        "seed": a.seed,
        "mesh": str(a.mesh),
        "size": [a.lx, a.ly],
        "material": material,
        "bands": a.bands,
        "polarisation": a.polarisation,
        "incident_stokes": [float(v) for v in a.incident_stokes],
        "variant": mi.variant(),
        "instances": (2 * a.block + 1) ** 2,
        "triangles": tracer.n_triangles,
        "max_height": tracer.zmax,
        "min_height": tracer.zmin,
        "version": VERSION,
        "mitsuba_version": mi.__version__,
    }
    if a.wavelengths_um is not None:
        meta["wavelengths_um"] = a.wavelengths_um
    write_outputs(Path(a.out), results, meta)
    return 0


if __name__ == "__main__":
    sys.exit(main())
