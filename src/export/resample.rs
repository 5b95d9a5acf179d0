//! What the BRDF export formats share: the table resampled symmetrically
//! about the plane of incidence, the error of a reader and the check of
//! a written file's reflectance against the table (with its quadrature,
//! [`integrate_projected`]). The formats
//! ([`super::zemax`], [`super::merl`], [`super::pbsdf`]) use this module; the dispatcher
//! [`super::brdf_formats`] uses them.

use glam::DVec3;
use rayon::prelude::*;
use thiserror::Error;

use crate::optics::brdf_table::BrdfTable;

/// A file that a reader of this module cannot accept: one line naming the
/// file and, where there is one, the line and keyword.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{file}: {message}")]
pub struct FormatError {
    /// File name.
    pub file: String,
    /// What is wrong (one line).
    pub message: String,
}

/// The table's BRDF (sr⁻¹) at incidence `theta_i_rad` (radians) toward
/// `dir` (local frame of [`BrdfTable`], light on the `+x` side), averaged
/// with the value at the mirror direction `(x, -y, z)`. Its integral
/// `∫ f cos(theta) dω` over the hemisphere is the table's reflectance.
#[must_use]
pub fn symmetric_eval(table: &BrdfTable, theta_i_rad: f64, dir: DVec3) -> f64 {
    let mirror = DVec3::new(dir.x, -dir.y, dir.z);
    0.5 * (table.eval(theta_i_rad, dir) + table.eval(theta_i_rad, mirror))
}

/// One incidence of a format's reflectance check
/// ([`super::brdf_formats::reflectance_check`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReflectanceCheck {
    /// Tabulated incidence angle (degrees).
    pub theta_i_deg: f64,
    /// The light azimuth (degrees) of a check of one azimuth of a table of
    /// several (a Zemax `Asymmetrical4D` block); `None` for a table of one
    /// azimuth, and for the azimuth average that MERL writes.
    pub phi_i_deg: Option<f64>,
    /// The table's reflectance (exact sum of its fractions).
    pub table: f64,
    /// The file read back by its reader and integrated over the hemisphere
    /// (first channel for MERL; the channels are equal).
    pub file: f64,
    /// The standard error of `table` (the run's stated one when
    /// `summary.json` was read, else the cells' errors added in quadrature;
    /// for a colour channel the wavelengths' errors added with the
    /// channel's absolute weights, an upper bound).
    pub table_stderr: f64,
}

impl ReflectanceCheck {
    /// The check of `file`, a file's reflectance read back at incidence
    /// `theta_i_deg` (degrees), against `table`'s reflectance and its
    /// standard error there (`phi_i_deg: None`).
    #[must_use]
    pub fn of_table(table: &BrdfTable, theta_i_deg: f64, file: f64) -> Self {
        let theta = theta_i_deg.to_radians();
        Self {
            theta_i_deg,
            phi_i_deg: None,
            table: table.reflectance(theta),
            file,
            table_stderr: table.reflectance_stderr(theta),
        }
    }

    /// The largest difference between file and table that the export is
    /// allowed: `max(1 % of the table's reflectance, 4 standard errors)`.
    #[must_use]
    pub fn tolerance(&self) -> f64 {
        (0.01 * self.table.abs()).max(4.0 * self.table_stderr)
    }

    /// Whether the file's reflectance is the table's within
    /// [`tolerance`](Self::tolerance).
    #[must_use]
    pub fn passes(&self) -> bool {
        (self.file - self.table).abs() <= self.tolerance()
    }
}

/// `|difference|` counted in standard errors `stderr` as the verdicts
/// word it: `N.N standard errors` (one decimal), or `no standard error`
/// where `stderr` is not positive.
#[must_use]
pub fn standard_errors(difference: f64, stderr: f64) -> String {
    if stderr > 0.0 {
        format!("{:.1} standard errors", difference.abs() / stderr)
    } else {
        "no standard error".to_owned()
    }
}

/// `∫ f(ω) cos(theta) dω` over the upper hemisphere by the midpoint rule on
/// `n` rings of equal polar width `90 / n` degrees times `4 n` equal azimuth
/// sectors (cells about `90 / n` degrees square), each weighted by its exact
/// projected solid angle `(sin² theta_b - sin² theta_a) dphi / 2` sr, so a
/// constant `f` integrates to `pi f` to rounding. Rings are summed in
/// parallel and added in ring order (same result for any number of threads).
#[must_use]
pub fn integrate_projected(n: usize, f: impl Fn(DVec3) -> f64 + Sync) -> f64 {
    let sectors = 4 * n;
    let dtheta = std::f64::consts::FRAC_PI_2 / n as f64;
    let dphi = std::f64::consts::TAU / sectors as f64;
    let rings: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (a, b) = (i as f64 * dtheta, (i + 1) as f64 * dtheta);
            let weight = 0.5 * (b.sin().powi(2) - a.sin().powi(2)) * dphi;
            let (s, mu) = (0.5 * (a + b)).sin_cos();
            let sum: f64 = (0..sectors)
                .map(|k| {
                    let phi = (k as f64 + 0.5) * dphi;
                    f(DVec3::new(s * phi.cos(), s * phi.sin(), mu))
                })
                .sum();
            sum * weight
        })
        .collect();
    rings.iter().sum()
}

/// Rings of the quadrature of [`super::brdf_formats::reflectance_check`]: 450 rings x 1800
/// sectors, cells of 0.2 x 0.2 degrees, far finer than the Carlson cells
/// (about 3 degrees for 32 bands) and the exports' grids (1-2 degrees).
pub const CHECK_RINGS: usize = 450;
