"""The colour of spectra, computed in Python independently of roks's Rust code
(src/optics/colour.rs): CIE 1931 XYZ under D65 and linear sRGB.

The tables are colour-science's (PyPI `colour-science`): the CIE 1931
2-degree colour-matching functions (`colour.MSDS_CMFS["CIE 1931 2 Degree
Standard Observer"]`, 1 nm) and the CIE D65 relative spectral power
(`colour.SDS_ILLUMINANTS["D65"]`), taken at their tabulated points 380, 385,
..., 780 nm (nothing of colour-science's own interpolation is used, so its
optional SciPy dependency is not needed). The sRGB matrix is
colour-science's (`colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB`),
which is the 4-decimal matrix published in IEC 61966-2-1
(`IEC_XYZ_TO_SRGB`, checked to 1e-12 when it is first used), and the 8-bit
encoding uses colour-science's sRGB transfer function.

Formula (the one documented in src/optics/colour.rs): a spectrum r sampled at
increasing wavelengths covering 0.38-0.78 um is interpolated linearly onto
the 5 nm grid, X = sum_i S_i r_i xbar_i / N (likewise Y, Z), N = sum_i S_i
ybar_i (the perfect white reflector has Y = 1); linear sRGB = M XYZ. Being
linear in r, it is a matrix `weights(wavelengths_um)` (3, L) applied to the
samples: a BRDF per cell gives the colour of the BRDF (1/sr).
"""

from __future__ import annotations

import warnings
from functools import lru_cache

import numpy as np

GRID_NM = np.arange(380, 781, 5).astype(float)
VISIBLE_UM = (0.38, 0.78)
# IEC 61966-2-1 (sRGB), XYZ (D65, Y = 1) -> linear sRGB as published (4 decimals).
IEC_XYZ_TO_SRGB = np.array([
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
])


def _colour():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "SciPy related API features are not available"
        import colour
    return colour


@lru_cache(maxsize=1)
def cie_tables() -> tuple[np.ndarray, np.ndarray]:
    """(cmfs (81, 3): xbar, ybar, zbar; d65 (81,)) at GRID_NM, colour-science's tabulated values."""
    colour = _colour()
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    out = []
    for sd in (cmfs, d65):
        idx = np.searchsorted(sd.wavelengths, GRID_NM)
        if not np.array_equal(sd.wavelengths[idx], GRID_NM):
            raise RuntimeError("colour-science tables lack a 5 nm point in 380-780 nm")
        out.append(np.asarray(sd.values, dtype=np.float64)[idx])
    return out[0], out[1]


@lru_cache(maxsize=1)
def xyz_to_srgb_matrix() -> np.ndarray:
    """colour-science's XYZ -> linear sRGB matrix, checked against IEC 61966-2-1's."""
    m = np.asarray(_colour().RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB, dtype=np.float64)
    if not np.allclose(m, IEC_XYZ_TO_SRGB, rtol=0.0, atol=1e-12):
        raise RuntimeError(f"colour-science's sRGB matrix is not IEC 61966-2-1's: {m.tolist()}")
    return m


def covers_visible(wavelengths_um) -> bool:
    w = np.asarray(wavelengths_um, dtype=float)
    return len(w) > 0 and w[0] <= VISIBLE_UM[0] + 1e-9 and w[-1] >= VISIBLE_UM[1] - 1e-9


def interpolation_matrix(wavelengths_um) -> np.ndarray:
    """A (81, L): A @ r is r (at the wavelengths, um) interpolated linearly onto GRID_NM."""
    w = 1000.0 * np.asarray(wavelengths_um, dtype=float)
    if not covers_visible(w / 1000.0) or np.any(np.diff(w) <= 0):
        raise ValueError("wavelengths must increase and cover 0.38-0.78 um for a colour")
    a = np.zeros((len(GRID_NM), len(w)))
    for i, g in enumerate(GRID_NM):
        g = min(max(g, w[0]), w[-1])
        j = int(np.clip(np.searchsorted(w, g, side="right") - 1, 0, len(w) - 2)) if len(w) > 1 else 0
        if len(w) == 1:
            a[i, 0] = 1.0
            continue
        t = (g - w[j]) / (w[j + 1] - w[j])
        a[i, j] += 1.0 - t
        a[i, j + 1] += t
    return a


def weights(wavelengths_um) -> np.ndarray:
    """W (3, L): XYZ = W @ r for a spectrum r sampled at the wavelengths (D65, Y(white) = 1)."""
    cmfs, d65 = cie_tables()
    norm = float(np.sum(d65 * cmfs[:, 1]))
    return (d65[:, None] * cmfs).T @ interpolation_matrix(wavelengths_um) / norm


def xyz(wavelengths_um, values) -> np.ndarray:
    """XYZ of spectra: values (..., L) -> (..., 3)."""
    return np.asarray(values, dtype=float) @ weights(wavelengths_um).T


def xyz_stderr_bound(wavelengths_um, stderrs) -> np.ndarray:
    """An upper bound of the standard errors of `xyz` from those of the samples
    (..., L): sum_l |W_cl| se_l, exact when the samples are fully correlated
    (one path carries every wavelength) and an upper bound always
    (|cov(a, b)| <= se_a se_b)."""
    return np.asarray(stderrs, dtype=float) @ np.abs(weights(wavelengths_um)).T


def linear_srgb(xyz_values) -> np.ndarray:
    """Linear sRGB (..., 3) of XYZ (..., 3), colour-science's matrix."""
    return np.asarray(xyz_values, dtype=float) @ xyz_to_srgb_matrix().T


def srgb8(linear) -> np.ndarray:
    """8-bit sRGB: clip to [0, 1], colour-science's sRGB transfer function, round(255 v)."""
    colour = _colour()
    v = colour.models.eotf_inverse_sRGB(np.clip(np.asarray(linear, dtype=float), 0.0, 1.0))
    return np.round(255.0 * np.asarray(v)).astype(int)


def fresnel_normal(n, k) -> np.ndarray:
    """Reflectance of a flat conductor n + ik at normal incidence, from vacuum."""
    n, k = np.asarray(n, dtype=float), np.asarray(k, dtype=float)
    return ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)


def read_nk_csv(path) -> np.ndarray:
    """(rows, 3) wavelength_um, n, k of a table in the refractiveindex.info CSV layout."""
    rows = []
    for line in open(path):
        t = line.strip()
        if not t or t.startswith("#") or t.startswith("wavelength"):
            continue
        rows.append([float(x) for x in t.split(",")])
    return np.array(rows)


def read_spd(path) -> np.ndarray:
    """(rows, 2) wavelength_nm, value of a Mitsuba .spd file."""
    rows = []
    for line in open(path):
        t = line.strip()
        if t and not t.startswith("#"):
            rows.append([float(x) for x in t.split()])
    return np.array(rows)
