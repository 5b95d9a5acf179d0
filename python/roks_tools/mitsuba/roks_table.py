"""Mitsuba 3 BSDF plugin `roks_table`: render with a BRDF table written by `roks brdf`.

Register it, then use it like any BSDF:

    import mitsuba as mi
    mi.set_variant("scalar_rgb")            # or llvm_ad_rgb, see below
    from roks_tools.mitsuba import roks_table
    roks_table.register()
    bsdf = mi.load_dict({"type": "roks_table", "filename": "out/default/brdf.csv"})

Parameters

* ``filename`` (string): a ``brdf.csv`` written by ``roks brdf`` (columns and
  conventions: src/optics/brdf_table.rs; the checks here are those of
  ``BrdfTable::parse`` that matter for rendering: header, complete blocks of
  one Carlson grid, finite non-negative fractions, incidence in [0, 90)).
* ``scale`` (float, default 1): multiplies the BRDF (a tinted or dimmed copy).
* ``mueller_filename`` (string; used in polarised variants, accepted and
  ignored in the others): the ``mueller.csv`` of the same run; default:
  ``mueller.csv`` beside ``filename`` if it exists.

What it computes (the same table as roks's ``BrdfTable``, grey or spectral
(below), reflection only, front side only):

* ``eval(wi, wo)`` = f(theta_i; wo) cos(theta_o), Mitsuba's convention (the
  BSDF times the foreshortening of ``wo``). f is the table's BRDF (1/sr):
  the fraction of the Carlson cell holding ``wo`` divided by the cell's exact
  projected solid angle, linear in theta_i between the two tabulated
  incidences that bracket theta_i (clamped outside), each block turned by its
  light azimuth; ``wo`` is taken relative to the azimuth of ``wi``. The table
  is indexed by ``wi``, the direction Mitsuba arrives from (the camera side
  in radiance transport): this assumes reciprocity, f(a -> b) = f(b -> a),
  which the roks BRDF obeys (tests/reciprocity.rs) and which makes ``sample``
  draw from the table that ``eval`` reads.
* ``sample(wi, sample1, sample2)``: as ``BrdfTable::sample`` -- the upper
  bracketing table with probability w (the linear weight), else the lower
  (``sample1`` decides, then is reused, rescaled, for the cell); a cell with
  probability fraction / R (R the table's reflectance); a direction uniform
  in projected solid angle inside the cell (mu^2 uniform between the cell's
  edges by ``sample2.x``, phi uniform by ``sample2.y``). Its pdf (solid
  angle) is the mixture sum_t w_t fraction_t / (R_t proj) cos(theta_o), which
  ``pdf`` returns too, and the weight is eval / pdf (equal to R of the table
  when wi is at a tabulated angle). Integrated over the hemisphere ``eval``
  gives the table's reflectance R(theta_i); the expected weight is R(theta_i).

Spectral tables (a ``brdf.csv`` of a spectral run: ``wavelength_um`` after
``phi_i_deg``, a block per incidence and wavelength, the same strictly
increasing wavelengths for every incidence; checked, TableError otherwise):

* spectral variants (``scalar_spectral``, ``llvm_ad_spectral``, ...): eval
  returns the spectrum at Mitsuba's sampled wavelengths ``si.wavelengths``,
  the table linear in wavelength between its tabulated wavelengths and, out
  of its range, the value at the nearest end (clamped: a table of 0.38-0.78
  um renders under Mitsuba's 360-830 nm sampling without black bands; a
  renderer that needs zero there must cut the light instead);
* RGB variants: the linear sRGB of the BRDF under D65, the formula of
  src/optics/colour.rs (linear interpolation onto 380-780 nm at 5 nm, CIE
  1931 2-degree XYZ normalised to Y = 1 for the perfect white reflector, the
  IEC 61966-2-1 matrix), computed by ``roks_tools.colour`` (colour-science's
  tables); a table whose wavelengths do not cover 0.38-0.78 um is refused
  (TableError naming the file);
* mono variants: CIE Y of the same colour;
* polarised variants: a depolariser per wavelength (m00 as above); a
  ``mueller_filename`` is refused (Mueller tables of spectral runs are not
  read) and a ``mueller.csv`` beside the table is not read (with a warning).
* sample draws directions from the mean over wavelengths of the table (the
  pdf is that of the mean table) and returns eval / pdf per channel:
  unbiased for every wavelength, the weights varying with wavelength.

A monochrome table is grey in every variant, as before.

Polarised variants (``*_polarized``): eval and sample return Mueller
matrices (grey: the same for every wavelength).

* With a ``mueller.csv`` (``roks brdf --polarisation mueller``: per incidence
  and Carlson cell the Mueller-matrix BRDF m_ij, row = outgoing Stokes
  component; checked as roks's ``BrdfTable::with_mueller_text``: a block for
  every incidence of brdf.csv, m00 within 1e-6 of its brdf, and stored as
  the matrix over m00 times that brdf, so m00 is exactly the unpolarised
  eval): the cell's matrix, interpolated in theta_i and turned exactly as
  the intensity, times cos(theta_o), in Mitsuba's Stokes bases. Frames of the
  file (roks, src/optics/polarisation.rs, which follows Mitsuba's
  mueller.h: y = d x x, S2 > 0 along (x + y)/sqrt 2, S3 > 0 right circular,
  rotator [[1,0,0,0],[0,C,S,0],[0,-S,C,0],[0,0,0,1]]): reference vector
  x = normalize(z x d) of a flight d, (-sin phi_i, cos phi_i, 0) along
  +-z, the incident flight -omega_i. Those frames turn with the
  configuration about the normal, so a block's matrices hold at any light
  azimuth. What the plugin returns follows Mitsuba's conductor and
  roughconductor: light arrives along -wo_hat and leaves along wi_hat,
  (wo_hat, wi_hat) = (wo, si.wi) in radiance transport (the default) and
  (si.wi, wo) in importance transport, and the matrix maps Stokes vectors
  in ``mueller::stokes_basis(-wo_hat)`` to ``stokes_basis(wi_hat)``, in the
  local frame (the integrators turn it to world with
  ``si.to_world_mueller``). The table is read with si.wi as the light (as
  for the intensity); in importance transport that is the physical
  direction, and the matrix is rotated with ``rotate_mueller_basis`` from
  roks's frames (x = e_phi of si.wi for the arriving flight -si.wi, e_phi of
  wo for the leaving one); in radiance transport the light comes from wo,
  and the plugin returns the reciprocal matrix Q M^T Q, Q = diag(1, 1, -1,
  1), in the frames with the same reference vectors (x = e_phi(wo) for the
  arriving flight -wo, e_phi(si.wi) for the leaving si.wi), then rotated
  likewise. This assumes Mueller reciprocity, M(o -> i) = Q M(i -> o)^T Q,
  as the intensity path assumes f(a -> b) = f(b -> a); m00 is unchanged by
  it. sample draws as before and returns the Mueller matrix over the pdf.
* Without one: a depolariser, diag(f cos, 0, 0, 0) (as roks's table walls
  of an unpolarised table).

In non-polarised variants ``mueller.csv`` is not read: behaviour and numbers
as without it.

Variants: the arithmetic is numpy on whole arrays, so the plugin runs in
``scalar_rgb``, ``scalar_spectral_polarized`` and in the LLVM/CUDA
variants (``llvm_ad_rgb``, ``llvm_ad_mono_polarized``, ...) in wavefront mode, i.e. with
``dr.set_flag(dr.JitFlag.SymbolicLoops, False)`` and
``dr.set_flag(dr.JitFlag.SymbolicCalls, False)`` (Python code called from a
recorded loop cannot read values). Tests: python/tests/test_roks_bsdf.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..carlson import CarlsonGrid
from ..results import (BRDF_COLUMNS, MUELLER_COLUMNS, MUELLER_MATRIX_COLUMNS, SPECTRAL_BRDF_COLUMNS,
                       ResultError, read_columns)

BRDF_HEADER = ",".join(BRDF_COLUMNS)
SPECTRAL_HEADER = ",".join(SPECTRAL_BRDF_COLUMNS)
C_THETA_I, C_PHI_I, C_BAND, C_CELL, C_PROJ, C_FRACTION = 0, 1, 2, 3, 11, 12
MUELLER_HEADER = ",".join(MUELLER_COLUMNS)
# Q = diag(1, 1, -1, 1): Mueller reciprocity M(o -> i) = Q M(i -> o)^T Q.
Q_SIGNS = np.array([1.0, 1.0, -1.0, 1.0])


class TableError(ResultError):
    """A brdf.csv this plugin cannot use (message names the file)."""


def _read_table(path: Path, header: str, what: str, columns: int, keep: int | None = None) -> np.ndarray:
    """The numbers of a roks CSV file `what` (brdf.csv, mueller.csv) with
    exactly `header` of `columns` columns, as a 2-D array of its first `keep`
    (default: all) columns, which must be finite; a TableError naming the
    file otherwise."""
    try:
        cols = read_columns(path, tuple(header.split(",")))
    except ResultError as e:
        raise TableError(str(e)) from e
    data = np.stack(list(cols.values()), axis=1)
    if data.shape[1] != columns:
        raise TableError(f"{path}: not {columns} columns")
    data = data[:, :keep]
    if data.shape[0] == 0 or not np.all(np.isfinite(data)):
        raise TableError(f"{path}: no data rows, or not {data.shape[1]} finite columns")
    return data


def _first_line(path: Path) -> str:
    try:
        with path.open() as f:
            return f.readline().strip().lstrip("\ufeff")
    except OSError as e:
        raise TableError(f"{path}: cannot read: {e}") from e


def _spectral_blocks(path: Path):
    """A spectral brdf.csv (`wavelength_um` after `phi_i_deg`; a block per
    incidence and wavelength, incidence-major, as roks writes it) as (rows of
    the first wavelength of each incidence in the monochrome layout, fractions
    (incidences, cells, L) in file order, wavelengths (um)); TableError unless
    every incidence has the same strictly increasing wavelengths and every
    block the same number of rows."""
    data = _read_table(path, SPECTRAL_HEADER, "brdf.csv", 17)
    key = data[:, :3]
    starts = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
    sizes = np.diff(np.r_[starts, len(data)])
    if np.any(sizes != sizes[0]):
        raise TableError(f"{path}: (incidence, wavelength) blocks of different sizes")
    rows = int(sizes[0])
    inc = key[starts, :2]
    inc_starts = np.flatnonzero(np.r_[True, np.any(inc[1:] != inc[:-1], axis=1)])
    per = np.diff(np.r_[inc_starts, len(starts)])
    if np.any(per != per[0]):
        raise TableError(f"{path}: incidences with different numbers of wavelengths")
    lanes = int(per[0])
    wl = key[starts, 2].reshape(-1, lanes)
    if np.any(wl <= 0) or np.any(np.diff(wl, axis=1) <= 0) or np.any(wl != wl[0]):
        raise TableError(f"{path}: wavelength_um must be positive, strictly increasing and the same for every incidence")
    fr = data[:, 13].reshape(len(inc_starts), lanes, rows)  # (incidences, L, cells)
    first = np.concatenate([np.arange(s, s + rows) for s in starts[inc_starts]])
    return np.delete(data[first], 2, axis=1), np.swapaxes(fr, 1, 2).copy(), wl[0].tolist()


class CarlsonTable:
    """The BRDF table of a brdf.csv as numpy arrays, with eval / pdf / sample
    on arrays of directions (local frame, z the normal). Pure numpy: the
    Mitsuba plugin wraps it, the tests call it directly too."""

    def __init__(self, path: str | Path):
        path = Path(path)
        spectral, wavelengths = None, None
        if _first_line(path) == SPECTRAL_HEADER:
            data, spectral, wavelengths = _spectral_blocks(path)
        else:
            data = _read_table(path, BRDF_HEADER, "brdf.csv", 16)
        # Blocks of consecutive rows with the same (theta_i, phi_i).
        key = data[:, [C_THETA_I, C_PHI_I]]
        starts = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
        sizes = np.diff(np.r_[starts, len(data)])
        rows = int(sizes[0])
        try:
            grid = CarlsonGrid.of_cells(rows)
        except ValueError:
            grid = None
        if grid is None or np.any(sizes != rows):
            raise TableError(f"{path}: incidence blocks are not complete Carlson grids of one size")
        self.grid = grid
        m = self.bands = grid.bands
        k = self.k = grid.k
        band, cell = grid.band, grid.cell
        for s in starts:
            block = data[s : s + rows]
            if np.any(block[:, C_BAND] != band) or np.any(block[:, C_CELL] != cell):
                raise TableError(f"{path}: line {s + 2}: band/cell not in Carlson grid order")
        theta_deg = key[starts, 0]
        if np.any((theta_deg < 0) | (theta_deg >= 90)) or len(np.unique(theta_deg)) != len(theta_deg):
            raise TableError(f"{path}: theta_i_deg must be distinct and in [0, 90)")
        fractions = np.stack([data[s : s + rows, C_FRACTION] for s in starts])
        if spectral is not None:
            if spectral.shape[1] != rows:
                raise TableError(f"{path}: incidence blocks are not complete Carlson grids of one size")
            fractions = spectral.mean(axis=2)  # the sampling table: the mean over wavelengths
        if np.any(fractions < 0) or (spectral is not None and np.any(spectral < 0)):
            raise TableError(f"{path}: negative fraction")
        order = np.argsort(theta_deg)
        # Spectral tables: fractions per wavelength (incidences, cells, L) and the wavelengths (um).
        self.wavelengths_um = wavelengths
        self.spectral = None if spectral is None else spectral[order]
        self.path = path
        self.theta_deg = theta_deg[order]
        self.phi_i_deg = key[starts, 1][order]
        self.mueller = None  # (incidences, cells, 4, 4) in 1/sr after attach_mueller
        self.theta = np.radians(theta_deg[order])
        self.phi_i = np.radians(key[starts, 1][order])
        self.fractions = fractions[order]
        self.cdf = np.cumsum(self.fractions, axis=1)
        self.reflectance = self.cdf[:, -1].copy()
        positive = self.fractions > 0
        self.last_positive = np.where(positive.any(axis=1), rows - 1 - np.argmax(positive[:, ::-1], axis=1), -1)
        # Cell geometry from the grid: mu edges as integer ratios, projected
        # solid angle pi (K - j^2) / K^2.
        self.band = band
        self.mu_bot, self.mu_top = grid.mu_bot, grid.mu_top
        self.phi_lo, self.phi_hi = grid.phi_lo, grid.phi_hi
        self.proj = grid.projected_solid_angle
        if np.any(np.abs(data[:rows, C_PROJ] - self.proj) > 1e-6 * self.proj):
            raise TableError(f"{path}: projected_solid_angle_sr does not match the Carlson grid of {m} bands")

    # -- spectral tables ----------------------------------------------------

    def brdf_lanes(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """A spectral table's BRDF (N, L), 1/sr, at its own wavelengths (as ``brdf``)."""
        if self.spectral is None:
            raise TableError(f"{self.path}: not a spectral table")
        _, terms = self._terms(wi, wo)
        return sum(wt[:, None] * self.spectral[idx, c] / self.proj[c][:, None] for wt, idx, c in terms)

    def eval_spectrum(self, wi: np.ndarray, wo: np.ndarray, wavelengths_nm: np.ndarray) -> np.ndarray:
        """f cos(theta_o) (N, W) at the wavelengths (N, W) in nm (Mitsuba's
        ``si.wavelengths``): the table linear in wavelength between its
        tabulated wavelengths; outside its range the nearest end's value
        (clamped). A monochrome table: the same grey value at every wavelength."""
        lam = np.atleast_2d(np.asarray(wavelengths_nm, dtype=np.float64))
        if self.spectral is None:
            return np.broadcast_to(self.eval(wi, wo)[:, None], lam.shape).copy()
        lanes = self.brdf_lanes(wi, wo) * np.maximum(wo[:, 2], 0.0)[:, None]
        grid = 1000.0 * np.asarray(self.wavelengths_um)
        if len(grid) == 1:
            return np.broadcast_to(lanes[:, :1], lam.shape).copy()
        x = np.clip(lam, grid[0], grid[-1])
        j = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, len(grid) - 2)
        t = (x - grid[j]) / (grid[j + 1] - grid[j])
        rows = np.arange(len(lanes))[:, None]
        return (1.0 - t) * lanes[rows, j] + t * lanes[rows, j + 1]

    def colour_matrix(self) -> np.ndarray:
        """(6, L): rows X, Y, Z, r, g, b of the colour of a spectrum at the
        table's wavelengths, D65 (``roks_tools.colour``: the formula of
        src/optics/colour.rs, colour-science's tables); a TableError unless
        the wavelengths cover 0.38-0.78 um."""
        if self.spectral is None:
            raise TableError(f"{self.path}: not a spectral table")
        from .. import colour as pc

        if not pc.covers_visible(self.wavelengths_um):
            raise TableError(
                f"{self.path}: wavelengths {self.wavelengths_um[0]}-{self.wavelengths_um[-1]} um do not cover "
                "0.38-0.78 um: no RGB or luminance (use a spectral variant)")
        w = pc.weights(self.wavelengths_um)
        return np.vstack([w, pc.xyz_to_srgb_matrix() @ w])

    def eval_rgb(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """f cos(theta_o) (N, 3) as linear sRGB under D65 (a monochrome table: grey)."""
        if self.spectral is None:
            return np.repeat(self.eval(wi, wo)[:, None], 3, axis=1)
        return (self.brdf_lanes(wi, wo) @ self.colour_matrix()[3:].T) * np.maximum(wo[:, 2], 0.0)[:, None]

    def eval_luminance(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """f cos(theta_o) (N,) as CIE Y under D65 (mono variants; a monochrome table: itself)."""
        if self.spectral is None:
            return self.eval(wi, wo)
        return (self.brdf_lanes(wi, wo) @ self.colour_matrix()[1]) * np.maximum(wo[:, 2], 0.0)

    def attach_mueller(self, path: str | Path) -> None:
        """Read the Mueller-matrix BRDF of the same run (``mueller.csv``,
        ``roks brdf --polarisation mueller``) into ``self.mueller``, checked
        as roks's ``BrdfTable::with_mueller_text``: header, 38 finite
        columns, complete blocks in Carlson grid order, a block for every
        incidence of the table (same theta_i_deg and phi_i_deg), m00 within
        1e-6 (relative) of the table's brdf. Stored as the matrix divided by
        its m00 times the table's brdf, so m00 is exactly the intensity
        table (a cell with brdf 0 gets the zero matrix)."""
        path = Path(path)
        # The matrix columns (the normalised errors after them may be nan).
        header = MUELLER_HEADER if _first_line(path) == MUELLER_HEADER else ",".join(MUELLER_MATRIX_COLUMNS)
        data = _read_table(path, header, "mueller.csv", 53 if header == MUELLER_HEADER else 38, keep=38)
        k = self.fractions.shape[1]  # cells per block
        if data.shape[0] % k:
            raise TableError(f"{path}: {data.shape[0]} rows are not whole blocks of {k} cells")
        blocks = data.reshape(-1, k, 38)
        band, cell = self.grid.band, self.grid.cell
        for b, block in enumerate(blocks):
            if np.any(block[:, 0] != block[0, 0]) or np.any(block[:, 1] != block[0, 1]):
                raise TableError(f"{path}: line {b * k + 2}: an incidence block is not {k} rows")
            if np.any(block[:, 2] != band) or np.any(block[:, 3] != cell):
                raise TableError(f"{path}: line {b * k + 2}: band/cell not in Carlson grid order")
        out = np.zeros((len(self.theta), k, 4, 4))
        for t in range(len(self.theta)):
            hit = np.flatnonzero((blocks[:, 0, 0] == self.theta_deg[t]) & (blocks[:, 0, 1] == self.phi_i_deg[t]))
            if len(hit) == 0:
                raise TableError(
                    f"{path}: no block for theta_i_deg = {self.theta_deg[t]}, "
                    f"phi_i_deg = {self.phi_i_deg[t]} (the table's)"
                )
            m = blocks[hit[0], :, 6::2].reshape(k, 4, 4)
            brdf = self.fractions[t] / self.proj
            bad = np.abs(m[:, 0, 0] - brdf) > 1e-6 * np.maximum(np.abs(brdf), np.abs(m[:, 0, 0])) + 1e-300
            if np.any(bad):
                c = int(np.argmax(bad))
                raise TableError(
                    f"{path}: theta_i_deg = {self.theta_deg[t]}: cell {c}: m00 = {m[c, 0, 0]} is not "
                    f"the table's brdf {brdf[c]} (a file of another run?)"
                )
            pos = m[:, 0, 0] > 0
            out[t, pos] = m[pos] * (brdf[pos] / m[pos, 0, 0])[:, None, None]
        self.mueller = out

    # -- geometry ---------------------------------------------------------

    def locate(self, d: np.ndarray) -> np.ndarray:
        """Flat Carlson cell of unit directions d (N, 3) with z > 0."""
        return self.grid.locate(d)

    def bracket(self, theta: np.ndarray):
        """(i0, i1, w): the value at theta is (1 - w) v[i0] + w v[i1]; clamped."""
        n = len(self.theta)
        i1 = np.searchsorted(self.theta, theta, side="right")
        lo = i1 == 0
        hi = i1 >= n
        i0 = np.clip(i1 - 1, 0, n - 1)
        i1c = np.clip(i1, 0, n - 1)
        span = np.where(i1c > i0, self.theta[i1c] - self.theta[i0], 1.0)
        w = np.clip((theta - self.theta[i0]) / span, 0.0, 1.0)
        w = np.where(lo | hi, 0.0, w)
        i0 = np.where(lo, 0, i0)
        i1c = np.where(lo, 0, np.where(hi, n - 1, i1c))
        return i0, i1c, w

    @staticmethod
    def _turn(d: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Rotate directions d (N, 3) about z by angle (N,) radians."""
        c, s = np.cos(angle), np.sin(angle)
        return np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1], d[:, 2]], axis=1)

    @staticmethod
    def _frame(wi: np.ndarray):
        """Polar angle and azimuth of wi (N, 3)."""
        return np.arctan2(np.hypot(wi[:, 0], wi[:, 1]), wi[:, 2]), np.arctan2(wi[:, 1], wi[:, 0])

    def _terms(self, wi: np.ndarray, wo: np.ndarray):
        """Per bracketing table t (two): weight w_t, table index, and the
        cell of wo in that table's frame; valid = both above the horizon."""
        valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        theta, phi = self._frame(wi)
        i0, i1, w = self.bracket(theta)
        local = self._turn(wo, -phi)
        out = []
        for idx, wt in ((i0, 1.0 - w), (i1, w)):
            d = self._turn(local, self.phi_i[idx])
            d[:, 2] = np.where(valid, d[:, 2], 1.0)  # any cell; masked below
            out.append((np.where(valid, wt, 0.0), idx, self.locate(d)))
        return valid, out

    # -- BSDF -------------------------------------------------------------

    def brdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """f(theta_i; wo) in 1/sr (0 below the horizon)."""
        _, terms = self._terms(wi, wo)
        return sum(wt * self.fractions[idx, c] / self.proj[c] for wt, idx, c in terms)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """f cos(theta_o), as Mitsuba's BSDF.eval."""
        return self.brdf(wi, wo) * np.maximum(wo[:, 2], 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Solid-angle density of sample(): sum_t w_t f_t / (R_t proj) cos."""
        _, terms = self._terms(wi, wo)
        p = np.zeros(len(wi))
        for wt, idx, c in terms:
            r = self.reflectance[idx]
            p += np.where(r > 0, wt * self.fractions[idx, c] / (np.where(r > 0, r, 1.0) * self.proj[c]), 0.0)
        return p * np.maximum(wo[:, 2], 0.0)

    # -- polarisation -----------------------------------------------------

    def mueller_roks(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """The Mueller-matrix BRDF (N, 4, 4), 1/sr, for light from wi (toward
        the light) reflected into wo, in roks's frames: reference vector of
        the incident flight -wi e_phi(phi(wi)), of the outgoing flight wo
        e_phi(phi(wo)) (e_phi(phi(wi)) when wo is the pole), signs of x
        immaterial. Interpolated in theta_i and turned as ``brdf`` (the
        frames turn with the configuration, so a block's matrices hold at any
        light azimuth); m00 is ``brdf``. Zero below the horizon."""
        if self.mueller is None:
            raise TableError(f"{self.path}: no mueller.csv attached (attach_mueller)")
        _, terms = self._terms(wi, wo)
        return sum(wt[:, None, None] * self.mueller[idx, c] for wt, idx, c in terms)

    def mueller_eval(self, wi: np.ndarray, wo: np.ndarray, radiance: bool = True) -> np.ndarray:
        """Mitsuba's polarised BSDF.eval (N, 4, 4) for the local directions
        wi (``si.wi``) and wo: f cos(theta_o) as a Mueller matrix from the
        Stokes basis ``stokes_basis(-wo_hat)`` of the arriving light to
        ``stokes_basis(wi_hat)`` of the leaving light, with (as Mitsuba's
        conductor and roughconductor) wo_hat, wi_hat = wo, wi in radiance
        transport and wi, wo in importance transport. The table is read with
        wi as the light (as ``eval``); in radiance transport the light
        arrives from wo, and the matrix is the reciprocal one,
        Q M(wi -> wo)^T Q with Q = diag(1, 1, -1, 1), in the frames with the
        same reference vectors (m00 unchanged)."""
        m = self.mueller_roks(wi, wo) * np.maximum(wo[:, 2], 0.0)[:, None, None]
        phi_a = np.arctan2(wi[:, 1], wi[:, 0])
        phi_b = np.where(np.hypot(wo[:, 0], wo[:, 1]) > 0, np.arctan2(wo[:, 1], wo[:, 0]), phi_a)
        x_a, x_b = azimuthal(phi_a), azimuthal(phi_b)
        if radiance:
            m = Q_SIGNS[:, None] * np.swapaxes(m, 1, 2) * Q_SIGNS[None, :]
            f_in, x_in, f_out, x_out = -wo, x_b, wi, x_a
        else:
            f_in, x_in, f_out, x_out = -wi, x_a, wo, x_b
        r_in = rotate_stokes_basis(f_in, x_in, stokes_basis(f_in))
        r_out = rotate_stokes_basis(f_out, x_out, stokes_basis(f_out))
        return r_out @ m @ np.swapaxes(r_in, 1, 2)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray):
        """(wo, pdf, weight, valid) for uniforms u1 (N,), u2 (N, 2)."""
        theta, phi = self._frame(wi)
        i0, i1, w = self.bracket(theta)
        u1 = np.clip(u1, 0.0, 1.0 - 2.0**-53)
        upper = u1 < w
        idx = np.where(upper, i1, i0)
        # Reuse u1 for the cell: uniform again within the chosen branch.
        u = np.where(upper, u1 / np.where(w > 0, w, 1.0), (u1 - w) / np.where(w < 1, 1.0 - w, 1.0))
        u = np.clip(u, 0.0, 1.0 - 2.0**-53)
        r = self.reflectance[idx]
        x = u * r
        c = np.zeros(len(x), dtype=np.int64)
        for t in np.unique(idx):
            sel = idx == t
            c[sel] = np.searchsorted(self.cdf[t], x[sel], side="right")
        c = np.minimum(c, np.maximum(self.last_positive[idx], 0))
        mu2_top, mu2_bot = self.mu_top[c] ** 2, self.mu_bot[c] ** 2
        mu2 = mu2_top - np.clip(u2[:, 0], 0.0, 1.0 - 2.0**-53) * (mu2_top - mu2_bot)
        mu = np.sqrt(mu2)
        s = np.sqrt(np.maximum(1.0 - mu2, 0.0))
        ph = self.phi_lo[c] + np.clip(u2[:, 1], 0.0, 1.0 - 2.0**-53) * (self.phi_hi[c] - self.phi_lo[c]) - self.phi_i[idx]
        local = np.stack([s * np.cos(ph), s * np.sin(ph), mu], axis=1)
        wo = self._turn(local, phi)
        valid = (wi[:, 2] > 0) & (r > 0) & (self.last_positive[idx] >= 0)
        pdf = np.where(valid, self.pdf(wi, wo), 0.0)
        valid &= pdf > 0
        weight = np.where(valid, self.eval(wi, wo) / np.where(valid, pdf, 1.0), 0.0)
        return wo, pdf, weight, valid


def azimuthal(phi: np.ndarray) -> np.ndarray:
    """e_phi = (-sin phi, cos phi, 0), (N, 3): roks's Stokes reference vector
    of a flight at azimuth phi (up to sign) and of the poles."""
    return np.stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)], axis=1)


def stokes_basis(d: np.ndarray) -> np.ndarray:
    """Mitsuba's ``mueller::stokes_basis(d)`` (the first vector of
    ``coordinate_system(d)``, Duff et al. 2017) for unit d (N, 3), float64."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    sign = np.copysign(1.0, z)
    a = -1.0 / (sign + z)
    b = x * y * a
    return np.stack([sign * x * x * a + 1.0, sign * b, -sign * x], axis=1)


def rotate_stokes_basis(forward: np.ndarray, current: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Mitsuba's ``mueller::rotate_stokes_basis`` (N, 4, 4): the rotator
    [[1,0,0,0],[0,C,S,0],[0,-S,C,0],[0,0,0,1]], C = cos 2t, S = sin 2t, that
    re-expresses a Stokes vector of a flight ``forward`` with reference
    vector ``current`` in the basis ``target`` (t the angle from current to
    target, positive counter-clockwise about forward)."""
    cur = current / np.linalg.norm(current, axis=1, keepdims=True)
    tgt = target / np.linalg.norm(target, axis=1, keepdims=True)
    t = np.arctan2(np.einsum("ij,ij->i", forward, np.cross(cur, tgt)), np.einsum("ij,ij->i", cur, tgt))
    c, s = np.cos(2 * t), np.sin(2 * t)
    r = np.zeros((len(t), 4, 4))
    r[:, 0, 0] = r[:, 3, 3] = 1.0
    r[:, 1, 1] = r[:, 2, 2] = c
    r[:, 1, 2] = s
    r[:, 2, 1] = -s
    return r


def register(name: str = "roks_table") -> None:
    """Register the plugin with the current Mitsuba variant (call after
    mi.set_variant)."""
    import drjit as dr
    import mitsuba as mi

    scalar = not dr.is_array_v(mi.Float)

    def arr(x) -> np.ndarray:
        return np.atleast_1d(np.asarray(x, dtype=np.float64))

    def vec(v) -> np.ndarray:
        return np.stack([arr(v.x), arr(v.y), arr(v.z)], axis=1)

    def back_f(a: np.ndarray):
        return mi.Float(float(a[0])) if scalar else mi.Float(a.astype(np.float32))

    def back_b(a: np.ndarray):
        return mi.Bool(bool(a[0])) if scalar else mi.Bool(a)

    def back_v(a: np.ndarray):
        return mi.Vector3f(back_f(a[:, 0]), back_f(a[:, 1]), back_f(a[:, 2]))

    def mask(active, n: int) -> np.ndarray:
        return np.broadcast_to(np.atleast_1d(np.asarray(active, dtype=bool)), (n,))

    polarised = bool(mi.is_polarized)
    spectral_variant = bool(mi.is_spectral)
    rgb_variant = bool(mi.is_rgb)

    def back_m(a: np.ndarray):
        """(N, 4, 4) numpy -> mi.Spectrum (a Mueller matrix, grey), or
        (N, 4, 4, C) -> one per channel (a spectral variant's wavelengths)."""
        out = dr.zeros(mi.Spectrum) if scalar else dr.zeros(mi.Spectrum, len(a))
        for i in range(4):
            for j in range(4):
                if a.ndim == 3:
                    out[i, j] = mi.UnpolarizedSpectrum(back_f(a[:, i, j]))
                else:
                    out[i, j] = mi.UnpolarizedSpectrum(*(back_f(a[:, i, j, c]) for c in range(a.shape[3])))
        return out

    def back_s(a: np.ndarray):
        """(N, C) numpy -> mi.Spectrum of C channels (unpolarised)."""
        return mi.Spectrum(*(back_f(a[:, c]) for c in range(a.shape[1])))

    def wavelengths(si) -> np.ndarray:
        """si.wavelengths (N, W) in nm."""
        w = si.wavelengths
        return np.stack([arr(w[c]) for c in range(len(w))], axis=1)

    def depolariser(v: np.ndarray) -> np.ndarray:
        m = np.zeros((len(v), 4, 4))
        m[:, 0, 0] = v
        return m

    class RoksTableBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.filename = str(props["filename"])
            self.scale = float(props["scale"]) if "scale" in props else 1.0
            self.table = CarlsonTable(self.filename)
            # Read (so Mitsuba sees it used) in every variant, used in polarised ones.
            named = str(props["mueller_filename"]) if "mueller_filename" in props else None
            self.mueller_filename = None
            spectral_table = self.table.spectral is not None
            if spectral_table and not spectral_variant:
                self.table.colour_matrix()  # refuses (TableError) a table that does not cover the visible
            if spectral_table and polarised:
                if named is not None:
                    raise TableError(f"{named}: Mueller tables of spectral runs are not supported "
                                     "(a spectral table renders as a depolariser per wavelength)")
                if (Path(self.filename).parent / "mueller.csv").is_file():
                    mi.Log(mi.LogLevel.Warn, f"roks_table: {self.filename} is spectral: the mueller.csv "
                                             "beside it is not used (a depolariser per wavelength)")
            elif polarised:
                beside = Path(self.filename).parent / "mueller.csv"
                self.mueller_filename = named if named is not None else (str(beside) if beside.is_file() else None)
                if self.mueller_filename is not None:
                    self.table.attach_mueller(self.mueller_filename)
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_components = [flags]
            self.m_flags = flags

        def channels(self, si, wi: np.ndarray, o: np.ndarray) -> np.ndarray:
            """A spectral table's eval (N, C): at si.wavelengths (spectral
            variants), linear sRGB (RGB variants) or Y (mono variants)."""
            t = self.table
            if spectral_variant:
                return t.eval_spectrum(wi, o, wavelengths(si))
            if rgb_variant:
                return t.eval_rgb(wi, o)
            return t.eval_luminance(wi, o)[:, None]

        def value(self, ctx, wi: np.ndarray, o: np.ndarray, si=None) -> np.ndarray:
            """eval (N,) or, polarised, (N, 4, 4) in Mitsuba's bases; a
            spectral table: (N, C), polarised (N, 4, 4, C) depolarisers."""
            if self.table.spectral is not None:
                v = self.channels(si, wi, o)
                if not polarised:
                    return v
                m = np.zeros((len(v), 4, 4, v.shape[1]))
                m[:, 0, 0, :] = v
                return m
            if not polarised:
                return self.table.eval(wi, o)
            if self.table.mueller is None:
                return depolariser(self.table.eval(wi, o))
            return self.table.mueller_eval(wi, o, radiance=ctx.mode == mi.TransportMode.Radiance)

        def wrap(self, v: np.ndarray):
            if polarised:
                return back_m(v)
            return back_s(v) if v.ndim == 2 else mi.Spectrum(back_f(v))

        def eval(self, ctx, si, wo, active=True):
            wi, o = vec(si.wi), vec(wo)
            v = self.value(ctx, wi, o, si)
            m = mask(active, len(wi)).reshape((-1,) + (1,) * (v.ndim - 1))
            return self.wrap(self.scale * (m * v))

        def pdf(self, ctx, si, wo, active=True):
            wi, o = vec(si.wi), vec(wo)
            return back_f(self.table.pdf(wi, o) * mask(active, len(wi)))

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = vec(si.wi)
            u2 = np.stack([arr(sample2.x), arr(sample2.y)], axis=1)
            wo, pdf, weight, valid = self.table.sample(wi, np.broadcast_to(arr(sample1), (len(wi),)), u2)
            valid &= mask(active, len(wi))
            bs = mi.BSDFSample3f()
            bs.wo = back_v(wo)
            bs.pdf = back_f(np.where(valid, pdf, 0.0))
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            if self.table.spectral is not None or polarised:
                v = self.value(ctx, wi, wo, si)
                shape = (-1,) + (1,) * (v.ndim - 1)
                w = np.where(valid.reshape(shape), self.scale * (v / np.where(valid, pdf, 1.0).reshape(shape)), 0.0)
                return bs, dr.select(back_b(valid), self.wrap(w), mi.Spectrum(0.0))
            w = np.where(valid, self.scale * weight, 0.0)
            return bs, dr.select(back_b(valid), mi.Spectrum(back_f(w)), mi.Spectrum(0.0))

        def traverse(self, callback):
            pass

        def to_string(self):
            t = self.table
            return (
                f"RoksTableBSDF[filename={self.filename!r}, bands={t.bands}, "
                f"theta_i_deg={np.degrees(t.theta).round(6).tolist()}, scale={self.scale}, "
                f"mueller_filename={self.mueller_filename!r}]"
            )

    mi.register_bsdf(name, lambda props: RoksTableBSDF(props))
