//! What the BRDF export formats share: the table resampled symmetrically
//! about the plane of incidence, and the error of a reader. The formats
//! ([`super::zemax`], [`super::merl`]) use this module; the dispatcher
//! [`super::brdf_formats`] uses them.

use glam::DVec3;
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
