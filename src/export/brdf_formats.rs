//! Export of a BRDF table (`brdf.csv` of `roks brdf`, read as a
//! [`BrdfTable`]) to the file formats other programs read
//! (`roks export-brdf`, `roks brdf --export`):
//!
//! * [`BrdfFormat::Zemax`]: the Zemax / Radiant tabular BSDF text format
//!   (`brdf.bsdf`; [`super::zemax`]), read by OpticStudio's tabular BSDF
//!   scatter model and other stray-light tools;
//! * [`BrdfFormat::Merl`]: the MERL binary format (`brdf.binary`;
//!   [`super::merl`]), read by graphics BRDF tools.
//!
//! Both resample the table with [`symmetric_eval`] (in
//! [`super::resample`], which the formats share; this module only
//! dispatches to them): the table's BRDF
//! (constant over each Carlson cell, linear in the incidence angle between
//! tabulated angles, clamped outside them) averaged with its mirror image in
//! the plane of incidence. A statistically isotropic surface has a BRDF
//! symmetric about the plane of incidence, both formats assume it, and the
//! average of a cell and its mirror cell keeps every cell's share of the
//! reflectance while halving the Monte Carlo noise of the asymmetric part.
//!
//! [`reflectance_check`] reads an export back with the format's own reader
//! and integrates it over the hemisphere: the difference from the table's
//! reflectance is the resampling error of the export.

use std::fmt;

use crate::optics::brdf_table::BrdfTable;
use glam::DVec3;
use rayon::prelude::*;

pub use super::resample::{FormatError, symmetric_eval};
use super::{merl, zemax};

/// An export format of `roks export-brdf --format` and `roks brdf
/// --export` (the names in lower case).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BrdfFormat {
    /// Zemax / Radiant tabular BSDF text (`brdf.bsdf`).
    #[value(help = None::<&str>)]
    Zemax,
    /// MERL binary (`brdf.binary`).
    #[value(help = None::<&str>)]
    Merl,
}

impl BrdfFormat {
    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Zemax => "zemax",
            Self::Merl => "merl",
        }
    }

    /// The file name `roks brdf --export` writes beside `brdf.csv`.
    #[must_use]
    pub fn file_name(self) -> &'static str {
        match self {
            Self::Zemax => "brdf.bsdf",
            Self::Merl => "brdf.binary",
        }
    }

    /// The file's bytes for `table`; `comment` (one line) goes into the
    /// Zemax header and is ignored by MERL, which has none.
    #[must_use]
    pub fn export(self, table: &BrdfTable, comment: &str) -> Vec<u8> {
        match self {
            Self::Zemax => zemax::ZemaxBsdf::from_table(table)
                .to_text(comment)
                .into_bytes(),
            Self::Merl => merl::Merl::from_table(table).to_bytes(),
        }
    }
}

impl fmt::Display for BrdfFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
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

/// Rings of the quadrature of [`reflectance_check`]: 450 rings x 1800
/// sectors, cells of 0.2 x 0.2 degrees, far finer than the Carlson cells
/// (about 3 degrees for 32 bands) and the exports' grids (1-2 degrees).
pub const CHECK_RINGS: usize = 450;

/// One incidence of [`reflectance_check`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReflectanceCheck {
    /// Tabulated incidence angle (degrees).
    pub theta_i_deg: f64,
    /// The table's reflectance (exact sum of its fractions).
    pub table: f64,
    /// The file read back by its reader and integrated over the hemisphere
    /// (first channel for MERL; the channels are equal).
    pub file: f64,
}

/// Read an export back (`bytes` as written by [`BrdfFormat::export`]) and
/// integrate its BRDF times `cos(theta_o)` over the hemisphere at every
/// tabulated incidence angle of `table` by [`integrate_projected`] with
/// [`CHECK_RINGS`] rings: the file's directional-hemispherical reflectance,
/// beside the table's.
///
/// Zemax: the file's `AngleOfIncidence` blocks, interpolated bilinearly in
/// (azimuth, radial) by [`zemax::ZemaxBsdf::eval`]. MERL: the reference
/// lookup [`merl::Merl::lookup`] (nearest bin, as the MERL reader does) with
/// the light at `theta_i`.
///
/// # Errors
/// If the reader rejects `bytes`.
pub fn reflectance_check(
    table: &BrdfTable,
    format: BrdfFormat,
    bytes: &[u8],
) -> Result<Vec<ReflectanceCheck>, FormatError> {
    let name = format.file_name();
    let file_r: Box<dyn Fn(usize, f64) -> f64> = match format {
        BrdfFormat::Zemax => {
            let text = std::str::from_utf8(bytes).map_err(|e| FormatError {
                file: name.into(),
                message: format!("not UTF-8 text: {e}"),
            })?;
            let z = zemax::ZemaxBsdf::parse(text, name)?;
            Box::new(move |k, _| integrate_projected(CHECK_RINGS, |d| z.eval(k, d)))
        }
        BrdfFormat::Merl => {
            let m = merl::Merl::parse(bytes, name)?;
            Box::new(move |_, theta| {
                let light = DVec3::new(theta.sin(), 0.0, theta.cos());
                integrate_projected(CHECK_RINGS, |d| m.lookup(light, d)[0])
            })
        }
    };
    Ok(table
        .thetas_deg()
        .iter()
        .enumerate()
        .map(|(k, &deg)| {
            let theta = deg.to_radians();
            ReflectanceCheck {
                theta_i_deg: deg,
                table: table.reflectance(theta),
                file: file_r(k, theta),
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_names_are_the_option_values() {
        use clap::ValueEnum as _;
        assert_eq!(BrdfFormat::from_str("zemax", false), Ok(BrdfFormat::Zemax));
        assert_eq!(BrdfFormat::from_str("MERL", true), Ok(BrdfFormat::Merl));
        assert!(BrdfFormat::from_str("pbrt", true).is_err());
        for f in BrdfFormat::value_variants() {
            assert_eq!(f.to_possible_value().unwrap().get_name(), f.name());
            assert_eq!(f.to_string(), f.name());
        }
    }

    /// Constants integrate exactly (`∫ cos dω = pi`); `∫ cos² dω = 2 pi / 3`
    /// to the midpoint rule's second-order error, `(pi/2 / n)² / 24` of the
    /// integrand's curvature, below 1e-4 for n = 64.
    #[test]
    fn quadrature_of_known_integrals() {
        let pi = std::f64::consts::PI;
        assert!((integrate_projected(64, |_| 1.0) - pi).abs() < 1e-13);
        let c2 = integrate_projected(64, |d| d.z);
        assert!((c2 - 2.0 * pi / 3.0).abs() < 1e-4, "{c2}");
        // Azimuthal structure integrates out: cos(phi) over whole sectors.
        assert!(integrate_projected(64, |d| d.x).abs() < 1e-13);
    }
}
