//! The colour of a spectrum: CIE 1931 XYZ under the CIE D65 illuminant, and
//! sRGB (IEC 61966-2-1), for the colour of a spectral BRDF per cell.
//!
//! # Formula
//! For a spectral factor `r(λ)` (a reflectance, or a BRDF times π, per cell)
//! sampled at strictly increasing wavelengths, `r` is interpolated linearly
//! onto the CIE grid `λ_i = 380, 385, …, 780 nm` (81 points) and
//!
//! ```text
//! X = Σ_i S(λ_i) r(λ_i) x̄(λ_i) / N,  Y = Σ_i S(λ_i) r(λ_i) ȳ(λ_i) / N,
//! Z = Σ_i S(λ_i) r(λ_i) z̄(λ_i) / N,  N = Σ_i S(λ_i) ȳ(λ_i),
//! ```
//!
//! with `S` the D65 relative spectral power and `x̄, ȳ, z̄` the CIE 1931
//! 2-degree colour-matching functions: the summation at 5 nm intervals of
//! CIE 015:2018 §7 (the interval Δλ cancels), normalised so the perfect
//! white reflector (`r = 1`) has `Y = 1`. Its chromaticity is then that of
//! D65, `x = 0.31272, y = 0.32903` (CIE 015:2018).
//!
//! # Visible range
//! The visible range counts as covered when the spectrum's first wavelength
//! is at most 0.38 µm and its last at least 0.78 µm ([`VISIBLE_MIN_UM`],
//! [`VISIBLE_MAX_UM`], each with a tolerance of [`COVER_TOLERANCE_UM`] for
//! wavelengths converted from nm). Otherwise there is no colour: the
//! functions return `None` (as they do for unequal lengths, wavelengths not
//! finite and strictly increasing, or values that are not finite).
//!
//! # sRGB
//! Linear sRGB is `M · XYZ` with the IEC 61966-2-1 matrix [`XYZ_TO_SRGB`]
//! (D65 white maps to `(1, 1, 1)` within 1e-3); the 8-bit encoding clips
//! each linear component to `[0, 1]`, applies the sRGB transfer function
//! ([`srgb_encode`]) and rounds `255 V` to the nearest integer.
//!
//! # Tables
//! `x̄, ȳ, z̄` and D65 at 5 nm from 380 to 780 nm: CIE 015:2018 Colorimetry,
//! 4th ed. (CIE, Vienna, 2018, doi:10.25039/TR.015.2018), the CIE 1931
//! standard colorimetric observer and the CIE standard illuminant D65. The
//! numbers were extracted from colour-science 0.4.7
//! (`colour.colorimetry.datasets`: the CIE 1931 table as distributed by CVRL,
//! D65 from the CIE 15:2004 table data, both unchanged in CIE 015:2018) by
//! `scripts/colour_reference.py tables`.

use super::spectrum::Spectrum;

/// Shortest wavelength (µm) a spectrum must reach for its colour: 380 nm.
pub const VISIBLE_MIN_UM: f64 = 0.38;
/// Longest wavelength (µm) a spectrum must reach for its colour: 780 nm.
pub const VISIBLE_MAX_UM: f64 = 0.78;
/// Tolerance (µm) on [`VISIBLE_MIN_UM`] and [`VISIBLE_MAX_UM`]; a grid
/// wavelength within it of the spectrum's end takes the end value.
pub const COVER_TOLERANCE_UM: f64 = 1e-9;
/// Number of points of the CIE grid.
pub const CMF_LEN: usize = 81;
/// The CIE grid (nm): 380, 385, …, 780.
pub const CMF_WAVELENGTH_NM: [f64; CMF_LEN] = cmf_grid();

/// IEC 61966-2-1 (sRGB) matrix from CIE XYZ (D65 white, `Y = 1`) to linear
/// sRGB, rows R, G, B.
pub const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

const fn cmf_grid() -> [f64; CMF_LEN] {
    let mut grid = [0.0; CMF_LEN];
    let mut i = 0;
    while i < CMF_LEN {
        grid[i] = 380.0 + 5.0 * i as f64;
        i += 1;
    }
    grid
}

/// Whether wavelengths (µm, increasing) span the visible range
/// 0.38-0.78 µm (see the module documentation).
#[must_use]
pub fn covers_visible(wavelengths_um: &[f64]) -> bool {
    match (wavelengths_um.first(), wavelengths_um.last()) {
        (Some(&first), Some(&last)) => {
            first <= VISIBLE_MIN_UM + COVER_TOLERANCE_UM
                && last >= VISIBLE_MAX_UM - COVER_TOLERANCE_UM
        }
        _ => false,
    }
}

/// CIE 1931 XYZ under D65 (perfect white reflector `Y = 1`) of a spectral
/// factor `values` at `wavelengths_um` (µm), by the module's formula.
///
/// `None` unless the lengths are equal, the wavelengths finite and strictly
/// increasing and [`covers_visible`], and every value finite. For many
/// spectra at the same wavelengths (the cells of a BRDF), build
/// [`XyzWeights`] once instead.
#[must_use]
pub fn xyz_d65(wavelengths_um: &[f64], values: &[f64]) -> Option<[f64; 3]> {
    XyzWeights::d65(wavelengths_um)?.xyz(values)
}

/// The module's formula as the linear map it is, for one list of
/// wavelengths: `XYZ = Σ_j w_j r_j` over the samples `r_j`, the weights
/// `w_j` holding the D65 power, the colour-matching functions, the linear
/// interpolation onto the CIE grid and the normalisation.
#[derive(Debug, Clone, PartialEq)]
pub struct XyzWeights {
    weights: Vec<[f64; 3]>,
}

impl XyzWeights {
    /// The weights for spectra sampled at `wavelengths_um` (µm); `None`
    /// unless the wavelengths are finite, strictly increasing and
    /// [`covers_visible`].
    #[must_use]
    pub fn d65(wavelengths_um: &[f64]) -> Option<Self> {
        if !covers_visible(wavelengths_um)
            || wavelengths_um.iter().any(|w| !w.is_finite())
            || wavelengths_um.windows(2).any(|w| w[1] <= w[0])
        {
            return None;
        }
        let (&first, &last) = (wavelengths_um.first()?, wavelengths_um.last()?);
        let norm: f64 = D65_SPD.iter().zip(CIE_Y_BAR).map(|(s, y)| s * y).sum();
        let mut weights = vec![[0.0; 3]; wavelengths_um.len()];
        for i in 0..CMF_LEN {
            // Within COVER_TOLERANCE_UM of an end, the end's value.
            let at = (CMF_WAVELENGTH_NM[i] / 1000.0).clamp(first, last);
            let (lo, hi, t) = super::spectrum::bracket(wavelengths_um, at)?;
            let s = D65_SPD[i] / norm;
            let bars = [CIE_X_BAR[i], CIE_Y_BAR[i], CIE_Z_BAR[i]];
            for (index, share) in [(lo, 1.0 - t), (hi, t)] {
                let weight = weights.get_mut(index)?;
                for (w, bar) in weight.iter_mut().zip(bars) {
                    *w += s * bar * share;
                }
            }
        }
        Some(Self { weights })
    }

    /// How many samples a spectrum must have.
    #[must_use]
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// Whether there are no samples (never, for weights that were built).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Per sample `j`, the weights of linear sRGB: `M · w_j` with `M` the
    /// matrix [`XYZ_TO_SRGB`], so that the linear sRGB of a spectrum `r`
    /// is `Σ_j (M · w_j) r_j`, which is [`xyz_to_linear_srgb`] of
    /// [`xyz`](Self::xyz) (to rounding: the same sums in another order).
    #[must_use]
    pub fn srgb_weights(&self) -> Vec<[f64; 3]> {
        self.weights
            .iter()
            .map(|&w| xyz_to_linear_srgb(w))
            .collect()
    }

    /// XYZ (perfect white reflector `Y = 1`) of a spectrum sampled at the
    /// weights' wavelengths; `None` for a wrong length or a value that is
    /// not finite.
    #[must_use]
    pub fn xyz(&self, values: &[f64]) -> Option<[f64; 3]> {
        if values.len() != self.weights.len() || values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut xyz = [0.0; 3];
        for (weight, &r) in self.weights.iter().zip(values) {
            for (c, w) in xyz.iter_mut().zip(weight) {
                *c += w * r;
            }
        }
        Some(xyz)
    }
}

/// [`xyz_d65`] of a tabulated [`Spectrum`].
#[must_use]
pub fn spectrum_xyz_d65(spectrum: &Spectrum) -> Option<[f64; 3]> {
    xyz_d65(spectrum.wavelengths_um(), spectrum.values())
}

/// XYZ of the perfect white reflector under D65 (`Y = 1`): the white point
/// of the tables, about `(0.95043, 1, 1.08880)`.
#[must_use]
pub fn d65_white_xyz() -> [f64; 3] {
    let mut sum = [0.0; 3];
    for i in 0..CMF_LEN {
        sum[0] += D65_SPD[i] * CIE_X_BAR[i];
        sum[1] += D65_SPD[i] * CIE_Y_BAR[i];
        sum[2] += D65_SPD[i] * CIE_Z_BAR[i];
    }
    let y = sum[1];
    sum.map(|c| c / y)
}

/// Chromaticity `(x, y) = (X, Y) / (X + Y + Z)`; `None` when `X + Y + Z`
/// is not a finite number `> 0`.
#[must_use]
pub fn chromaticity(xyz: [f64; 3]) -> Option<[f64; 2]> {
    let total = xyz[0] + xyz[1] + xyz[2];
    (total.is_finite() && total > 0.0).then(|| [xyz[0] / total, xyz[1] / total])
}

/// Linear sRGB of CIE XYZ (D65 white, `Y = 1`) by [`XYZ_TO_SRGB`]; not
/// clipped (out-of-gamut components are below 0 or above 1).
#[must_use]
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    XYZ_TO_SRGB.map(|row| row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2])
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear component,
/// clipped to `[0, 1]` first: `12.92 L` for `L ≤ 0.0031308`, else
/// `1.055 L^(1/2.4) − 0.055`. NaN gives 0.
#[must_use]
pub fn srgb_encode(linear: f64) -> f64 {
    let l = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB of linear sRGB: [`srgb_encode`] of each component, times 255,
/// rounded to the nearest integer.
#[must_use]
pub fn srgb8(linear: [f64; 3]) -> [u8; 3] {
    // srgb_encode is in [0, 1], so the rounded value is in [0, 255].
    linear.map(|c| (255.0 * srgb_encode(c)).round().clamp(0.0, 255.0) as u8)
}

// CIE 015:2018 tables at CMF_WAVELENGTH_NM, written by scripts/colour_reference.py tables.

/// CIE 1931 2-degree x-bar at [`CMF_WAVELENGTH_NM`] (dimensionless).
pub const CIE_X_BAR: [f64; 81] = [
    0.001368,
    0.002236,
    0.004243,
    0.00765,
    0.01431,
    0.02319,
    0.04351,
    0.07763,
    0.13438,
    0.21477,
    0.2839,
    0.3285,
    0.34828,
    0.34806,
    0.3362,
    0.3187,
    0.2908,
    0.2511,
    0.19536,
    0.1421,
    0.09564,
    0.05795001,
    0.03201,
    0.0147,
    0.0049,
    0.0024,
    0.0093,
    0.0291,
    0.06327,
    0.1096,
    0.1655,
    0.2257499,
    0.2904,
    0.3597,
    0.4334499,
    0.5120501,
    0.5945,
    0.6784,
    0.7621,
    0.8425,
    0.9163,
    0.9786,
    1.0263,
    1.0567,
    1.0622,
    1.0456,
    1.0026,
    0.9384,
    0.8544499,
    0.7514,
    0.6424,
    0.5419,
    0.4479,
    0.3608,
    0.2835,
    0.2187,
    0.1649,
    0.1212,
    0.0874,
    0.0636,
    0.04677,
    0.0329,
    0.0227,
    0.01584,
    0.01135916,
    0.008110916,
    0.005790346,
    0.004109457,
    0.002899327,
    0.00204919,
    0.001439971,
    0.0009999493,
    0.0006900786,
    0.0004760213,
    0.0003323011,
    0.0002348261,
    0.0001661505,
    0.000117413,
    8.307527e-05,
    5.870652e-05,
    4.150994e-05,
];

/// CIE 1931 2-degree y-bar at [`CMF_WAVELENGTH_NM`] (dimensionless).
pub const CIE_Y_BAR: [f64; 81] = [
    3.9e-05, 6.4e-05, 0.00012, 0.000217, 0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073,
    0.0116, 0.01684, 0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126, 0.13902, 0.1693,
    0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082, 0.71, 0.7932, 0.862, 0.9148501, 0.954, 0.9803,
    0.9949501, 1.0, 0.995, 0.9786, 0.952, 0.9154, 0.87, 0.8163, 0.757, 0.6949, 0.631, 0.5668,
    0.503, 0.4412, 0.381, 0.321, 0.265, 0.217, 0.175, 0.1382, 0.107, 0.0816, 0.061, 0.04458, 0.032,
    0.0232, 0.017, 0.01192, 0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484, 0.001047,
    0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012, 8.48e-05, 6e-05, 4.24e-05, 3e-05,
    2.12e-05, 1.499e-05,
];

/// CIE 1931 2-degree z-bar at [`CMF_WAVELENGTH_NM`] (dimensionless).
pub const CIE_Z_BAR: [f64; 81] = [
    0.006450001,
    0.01054999,
    0.02005001,
    0.03621,
    0.06785001,
    0.1102,
    0.2074,
    0.3713,
    0.6456,
    1.0390501,
    1.3856,
    1.62296,
    1.74706,
    1.7826,
    1.77211,
    1.7441,
    1.6692,
    1.5281,
    1.28764,
    1.0419,
    0.8129501,
    0.6162,
    0.46518,
    0.3533,
    0.272,
    0.2123,
    0.1582,
    0.1117,
    0.07824999,
    0.05725001,
    0.04216,
    0.02984,
    0.0203,
    0.0134,
    0.008749999,
    0.005749999,
    0.0039,
    0.002749999,
    0.0021,
    0.0018,
    0.001650001,
    0.0014,
    0.0011,
    0.001,
    0.0008,
    0.0006,
    0.00034,
    0.00024,
    0.00019,
    0.0001,
    4.999999e-05,
    3e-05,
    2e-05,
    1e-05,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
];

/// CIE D65 relative spectral power at [`CMF_WAVELENGTH_NM`] (100 at 560 nm).
pub const D65_SPD: [f64; 81] = [
    49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204, 91.486, 92.4589, 93.4318, 90.057,
    86.6823, 95.7736, 104.865, 110.936, 117.008, 117.41, 117.812, 116.336, 114.861, 115.392,
    115.923, 112.367, 108.811, 109.082, 109.354, 108.578, 107.802, 106.296, 104.79, 106.239,
    107.689, 106.047, 104.405, 104.225, 104.046, 102.023, 100.0, 98.1671, 96.3342, 96.0611, 95.788,
    92.2368, 88.6856, 89.3459, 90.0062, 89.8026, 89.5991, 88.6489, 87.6987, 85.4936, 83.2886,
    83.4939, 83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.281, 78.2842,
    74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765, 61.604, 65.7448, 69.8856, 72.4863,
    75.087, 69.3398, 63.5927, 55.0054, 46.4182, 56.6118, 66.8054, 65.0941, 63.3828,
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::spectrum::NkSpectrum;
    use std::path::Path;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    fn white_spectrum() -> (Vec<f64>, Vec<f64>) {
        (vec![0.3, 0.5, 0.9], vec![1.0; 3])
    }

    #[test]
    fn tables_are_the_cie_ones() {
        assert_eq!(CMF_WAVELENGTH_NM[0], 380.0);
        assert_eq!(CMF_WAVELENGTH_NM[CMF_LEN - 1], 780.0);
        // D65 is normalised to 100 at 560 nm; y-bar peaks at 1 at 555 nm.
        assert_eq!(D65_SPD[36], 100.0);
        assert_eq!(CIE_Y_BAR[35], 1.0);
        let peak = CIE_Y_BAR.iter().copied().fold(0.0, f64::max);
        assert_eq!(peak, 1.0);
        // CIE 015:2018 values at 380 and 780 nm.
        assert_eq!(
            (CIE_X_BAR[0], CIE_Y_BAR[0], CIE_Z_BAR[0]),
            (0.001368, 0.000039, 0.006450001)
        );
        assert_eq!(D65_SPD[0], 49.9755);
        assert_eq!(D65_SPD[CMF_LEN - 1], 63.3828);
    }

    /// CIE 015:2018 gives D65's chromaticity as x = 0.31272, y = 0.32903.
    #[test]
    fn d65_white_point() {
        let (w, r) = white_spectrum();
        let xyz = xyz_d65(&w, &r).expect("covered");
        assert!(close(xyz[1], 1.0, 1e-12), "{xyz:?}");
        for (a, b) in xyz.iter().zip(d65_white_xyz()) {
            assert!(close(*a, b, 1e-14), "{xyz:?}");
        }
        let [x, y] = chromaticity(xyz).expect("positive");
        assert!(
            close(x, 0.31272, 5e-6) && close(y, 0.32903, 5e-6),
            "{x} {y}"
        );
        // sRGB's rounded white point (IEC 61966-2-1): 0.3127, 0.3290.
        assert!(close(x, 0.3127, 1e-4) && close(y, 0.3290, 1e-4));
    }

    #[test]
    fn perfect_white_reflector_is_srgb_white() {
        let (w, r) = white_spectrum();
        let rgb = xyz_to_linear_srgb(xyz_d65(&w, &r).expect("covered"));
        for c in rgb {
            assert!(close(c, 1.0, 1e-3), "{rgb:?}");
        }
        assert_eq!(srgb8(rgb), [255, 255, 255]);
        // A 18% grey is neutral too.
        let grey = xyz_to_linear_srgb(xyz_d65(&w, &[0.18; 3]).expect("covered"));
        assert_eq!(srgb8(grey), [118, 118, 118]);
    }

    /// The equal-energy illuminant E has chromaticity (1/3, 1/3): the three
    /// colour-matching functions have equal integrals.
    #[test]
    fn equal_energy_white_from_the_cmfs() {
        let sums = [CIE_X_BAR, CIE_Y_BAR, CIE_Z_BAR].map(|bar| bar.iter().sum::<f64>());
        let [x, y] = chromaticity(sums).expect("positive");
        assert!(
            close(x, 1.0 / 3.0, 2e-5) && close(y, 1.0 / 3.0, 2e-5),
            "{x} {y}"
        );
    }

    /// One set of weights serves every cell: the same XYZ as one call per
    /// spectrum, and linear in the spectrum.
    #[test]
    fn weights_serve_many_spectra() {
        let wavelengths = [0.36, 0.41, 0.45, 0.52, 0.6, 0.66, 0.71, 0.8];
        let weights = XyzWeights::d65(&wavelengths).expect("covered");
        let cells: Vec<Vec<f64>> = (0..5)
            .map(|c| {
                (0..8)
                    .map(|j| f64::from((c * 3 + j * 5) % 7) / 7.0)
                    .collect()
            })
            .collect();
        for cell in &cells {
            let a = weights.xyz(cell).expect("valid");
            let b = xyz_d65(&wavelengths, cell).expect("valid");
            assert_eq!(a, b);
            let doubled: Vec<f64> = cell.iter().map(|v| 2.0 * v).collect();
            let d = weights.xyz(&doubled).expect("valid");
            for (x, y) in d.iter().zip(a) {
                assert!(close(*x, 2.0 * y, 1e-14));
            }
        }
        let white = weights.xyz(&[1.0; 8]).expect("valid");
        for (a, b) in white.iter().zip(d65_white_xyz()) {
            assert!(close(*a, b, 1e-14), "{white:?}");
        }
    }

    #[test]
    fn srgb_transfer_function() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!(close(srgb_encode(1.0), 1.0, 1e-15));
        assert_eq!(srgb_encode(-0.5), 0.0);
        assert!(close(srgb_encode(2.0), 1.0, 1e-15));
        assert_eq!(srgb_encode(f64::NAN), 0.0);
        assert!(close(srgb_encode(0.5), 0.735_356_983_052_449_5, 1e-12));
        // The two branches meet at 0.0031308 (within the standard's rounding).
        let t = 0.003_130_8;
        assert!(close(12.92 * t, 1.055 * t.powf(1.0 / 2.4) - 0.055, 1e-7));
        assert_eq!(srgb8([0.0, 1.0, 0.5]), [0, 255, 188]);
    }

    #[test]
    fn no_colour_without_the_visible_range() {
        assert_eq!(xyz_d65(&[0.4, 0.78], &[1.0, 1.0]), None);
        assert_eq!(xyz_d65(&[0.38, 0.7], &[1.0, 1.0]), None);
        assert_eq!(xyz_d65(&[], &[]), None);
        assert_eq!(xyz_d65(&[0.5], &[1.0]), None);
        assert_eq!(xyz_d65(&[0.38, 0.78], &[1.0]), None);
        assert_eq!(xyz_d65(&[0.38, 0.5, 0.5, 0.78], &[1.0; 4]), None);
        assert_eq!(xyz_d65(&[0.38, 0.6, 0.5, 0.78], &[1.0; 4]), None);
        assert_eq!(xyz_d65(&[0.38, f64::NAN, 0.78], &[1.0; 3]), None);
        assert_eq!(xyz_d65(&[0.38, 0.78], &[1.0, f64::INFINITY]), None);
        assert_eq!(xyz_d65(&[f64::NEG_INFINITY, 0.78], &[1.0, 1.0]), None);
        // Exactly 0.38-0.78 um is covered, also from nanometres.
        assert!(xyz_d65(&[0.38, 0.78], &[1.0, 1.0]).is_some());
        assert!(xyz_d65(&[380.0 / 1000.0, 780.0 / 1000.0], &[1.0, 1.0]).is_some());
        assert!(xyz_d65(&[0.38 + 1e-10, 0.78 - 1e-10], &[1.0, 1.0]).is_some());
        assert!(!covers_visible(&[0.3801, 0.9]));
        let weights = XyzWeights::d65(&[0.38, 0.5, 0.78]).expect("covered");
        assert_eq!(weights.len(), 3);
        assert_eq!(weights.xyz(&[1.0, 1.0]), None);
        assert_eq!(weights.xyz(&[1.0, f64::NAN, 1.0]), None);
        assert_eq!(chromaticity([0.0; 3]), None);
    }

    /// ColorChecker patch 15 "red", spectral reflectance measured by N. Ohta,
    /// "The basis of color reproduction engineering" (Corona-sha, 1997),
    /// 380-780 nm at 5 nm, as held by colour-science 0.4.7
    /// (`colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]["red"]`). Expected
    /// values from colour-science as the independent implementation:
    /// `/tmp/cvenv/bin/python scripts/colour_reference.py expected`
    /// (colour-science 0.4.7: `sd_to_XYZ_integration` with the same tables,
    /// `XYZ_to_RGB` to sRGB, `eotf_inverse_sRGB`).
    #[test]
    fn colorchecker_red_matches_colour_science() {
        const OHTA_RED: [f64; CMF_LEN] = [
            0.052, 0.052, 0.052, 0.052, 0.051, 0.051, 0.05, 0.05, 0.049, 0.049, 0.049, 0.049,
            0.049, 0.049, 0.049, 0.048, 0.048, 0.047, 0.047, 0.046, 0.045, 0.045, 0.044, 0.044,
            0.044, 0.044, 0.044, 0.044, 0.044, 0.044, 0.044, 0.044, 0.045, 0.046, 0.047, 0.048,
            0.05, 0.053, 0.057, 0.063, 0.072, 0.086, 0.109, 0.143, 0.192, 0.256, 0.332, 0.413,
            0.486, 0.55, 0.598, 0.631, 0.654, 0.672, 0.686, 0.694, 0.7, 0.704, 0.707, 0.712, 0.718,
            0.721, 0.724, 0.727, 0.729, 0.73, 0.73, 0.729, 0.727, 0.728, 0.729, 0.729, 0.727,
            0.723, 0.721, 0.724, 0.728, 0.727, 0.702, 0.68, 0.664,
        ];
        let grid_um = CMF_WAVELENGTH_NM.map(|nm| nm / 1000.0);
        let xyz = xyz_d65(&grid_um, &OHTA_RED).expect("covered");
        let expected = [
            0.2017586847941633,
            0.11825571581317064,
            0.051994754391160906,
        ];
        for (a, b) in xyz.iter().zip(expected) {
            assert!(close(*a, b, 1e-12), "{xyz:?}");
        }
        let rgb = xyz_to_linear_srgb(xyz);
        let expected = [
            0.44611192305652697,
            0.02849786433251382,
            0.042072248108605166,
        ];
        for (a, b) in rgb.iter().zip(expected) {
            assert!(close(*a, b, 1e-9), "{rgb:?}");
        }
        assert_eq!(srgb8(rgb), [178, 47, 58]);
    }

    /// A flat gold mirror at normal incidence, R = ((n-1)² + k²)/((n+1)² + k²),
    /// n and k of scenes/materials/gold.csv (Johnson and Christy 1972)
    /// interpolated linearly onto the CIE grid. colour-science 0.4.7 gives
    /// sRGB8 (255, 222, 163) (`scripts/colour_reference.py expected`, which
    /// interpolates n and k with numpy.interp).
    #[test]
    fn gold_mirror_matches_colour_science() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/materials/gold.csv");
        let gold = NkSpectrum::read_csv(&path).expect("gold table");
        let grid_um = CMF_WAVELENGTH_NM.map(|nm| nm / 1000.0);
        let nk = gold.sample(&grid_um).expect("gold covers the visible");
        let r: Vec<f64> = nk.iter().map(|nk| nk.normal_reflectance()).collect();
        let xyz = xyz_d65(&grid_um, &r).expect("covered");
        let expected = [0.754138242465918, 0.7678484246093248, 0.45334253602582675];
        for (a, b) in xyz.iter().zip(expected) {
            assert!(close(*a, b, 1e-9), "{xyz:?}");
        }
        let rgb = xyz_to_linear_srgb(xyz);
        let expected = [1.0374872017631225, 0.7284592470020154, 0.3645474820643482];
        for (a, b) in rgb.iter().zip(expected) {
            assert!(close(*a, b, 1e-6), "{rgb:?}");
        }
        let ours = srgb8(rgb);
        for (a, b) in ours.iter().zip([255u8, 222, 163]) {
            assert!(a.abs_diff(b) <= 1, "{ours:?}");
        }
        // The same through a Spectrum of the reflectance at the table's own
        // wavelengths differs only by where the interpolation happens.
        let own: Vec<(f64, f64)> = gold
            .n()
            .wavelengths_um()
            .iter()
            .map(|&w| (w, gold.at(w).expect("tabulated").normal_reflectance()))
            .collect();
        let spectrum = Spectrum::new("gold R", &own).expect("valid");
        let coarse = srgb8(xyz_to_linear_srgb(
            spectrum_xyz_d65(&spectrum).expect("covered"),
        ));
        for (a, b) in coarse.iter().zip(ours) {
            assert!(a.abs_diff(b) <= 3, "{coarse:?} vs {ours:?}");
        }
    }
}
