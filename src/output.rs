//! Result files: one submodule per format, each the one home of its
//! columns or keys, its writer and (for the files roks reads back) its
//! reader; and writing files atomically ([`write_atomic`](crate::outdir::write::write_atomic): a temporary
//! file in the same folder, then a rename, so a reader never sees half a
//! file).
//!
//! `roks brdf` writes, in its output folder ([`brdf_folder`]):
//! * `brdf.csv` ([`brdf_csv`]): one row per incidence and Carlson cell.
//! * `inplane.csv` ([`inplane_csv`]): the in-plane BRDF.
//! * `summary.json` ([`summary::BrdfSummary`]): per incidence the
//!   reflectance, losses, bounces, segments and timings; `surface`
//!   statistics; the seed, scene file and roks version.
//! * `tallies.json` ([`tallies`], with `--shard`, and from `roks merge`):
//!   the raw sums, exactly, for merging shards.
//! * With `[tally] polarisation = "stokes"`: `stokes.csv`; with
//!   `"mueller"`: `mueller.csv` ([`polar_csv`]).
//! * A spectral run (`[light] wavelengths_um`) covering the visible:
//!   `colour.csv` ([`colour_csv`]).
//! * Pictures made from these files ([`crate::plot::folder`]) and of the
//!   surface (`surface.png`, [`crate::plot::SurfacePicture`]).
//!
//! `roks trace` writes `reflectance.csv`, `farfield.csv` and
//! `farfield_stokes.csv` ([`object_csv`]) and `summary.json`
//! ([`summary::TraceSummary`]); with `--shard` `summary.json` and
//! `tallies.json` ([`object_tallies`]); `roks fit` writes `fit.json`
//! ([`summary::FitSummary`]).

use crate::outdir::file::ResultPattern;
use crate::transport::brdf::{BrdfRun, IncidenceResult};

pub mod brdf_csv;
pub mod brdf_folder;
pub mod colour_csv;
pub mod inplane_csv;
pub mod object_csv;
pub mod object_tallies;
pub mod polar_csv;
pub mod result_tables;
pub mod summary;
pub mod tallies;

/// `header` with `wavelength_um` after column `after` for a spectral `run`;
/// `header` itself for a monochrome one.
#[must_use]
pub fn with_wavelength(header: &str, after: &str, run: &BrdfRun) -> String {
    if run.wavelengths_um.is_empty() {
        return header.to_owned();
    }
    spectral_header(header, after)
}

/// `header` with `wavelength_um` after column `after`: the header of a
/// spectral run's file (written by [`with_wavelength`], checked by the
/// readers).
#[must_use]
pub fn spectral_header(header: &str, after: &str) -> String {
    header
        .split(',')
        .flat_map(|c| {
            let extra = (c == after).then_some("wavelength_um");
            std::iter::once(c).chain(extra)
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// `wavelength_um,` of a spectral run's result (shortest round-trip
/// form); nothing for a monochrome one.
pub fn write_wavelength(s: &mut String, r: &IncidenceResult) {
    use std::fmt::Write as _;
    if let Some(w) = r.wavelength_um {
        let _ = write!(s, "{w},");
    }
}

/// Longest number written in decimal in a file name; longer ones (such as
/// an angle of 1e-300 degrees, 300 digits in decimal) are written in
/// exponent form.
pub const LABEL_DIGITS: usize = 24;

/// `x` as it appears in file names: its shortest round-trip decimal form
/// (`30`, `0.5`, `89.9999999`), or, when that is longer than
/// [`LABEL_DIGITS`], its shortest round-trip exponent form (`1e-300`).
/// Distinct numbers get distinct labels, and file names stay far below
/// the file system's limit.
#[must_use]
pub fn number_label(x: f64) -> String {
    let decimal = x.to_string();
    if decimal.len() <= LABEL_DIGITS {
        decimal
    } else {
        format!("{x:e}")
    }
}

/// File name of the degree-of-polarisation map of incidence `theta_i_deg`.
#[must_use]
pub fn dop_file(theta_i_deg: f64) -> String {
    ResultPattern::Dop.name(&format!("{}deg", number_label(theta_i_deg)))
}

/// The file name `name` of a picture of one incidence (`<what>_<θ>deg...`)
/// for light azimuth `phi_i_deg` of a run with several:
/// `_phi<φ>` after the incidence's `deg` (`hemisphere_30deg.png` at 45
/// degrees: `hemisphere_30deg_phi45.png`); `name` itself for `None` (a run of one azimuth).
#[must_use]
pub fn at_azimuth(name: &str, phi_i_deg: Option<f64>) -> String {
    match (phi_i_deg, name.find("deg")) {
        (Some(phi), Some(k)) => format!(
            "{}_phi{}{}",
            &name[..k + 3],
            number_label(phi),
            &name[k + 3..]
        ),
        _ => name.to_owned(),
    }
}

/// File name of the hemisphere map of incidence `theta_i_deg`.
#[must_use]
pub fn hemisphere_file(theta_i_deg: f64) -> String {
    ResultPattern::Hemisphere.name(&format!("{}deg", number_label(theta_i_deg)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ordinary numbers keep their decimal form in file names; one whose
    /// decimal form passes `LABEL_DIGITS` characters gets its exponent form,
    /// which parses back to it.
    #[test]
    fn number_labels() {
        assert_eq!(hemisphere_file(30.0), "hemisphere_30deg.png");
        assert_eq!(
            at_azimuth(&hemisphere_file(30.0), Some(22.5)),
            "hemisphere_30deg_phi22.5.png"
        );
        assert_eq!(
            at_azimuth("mueller_stderr_10deg_0.55um.png", Some(0.0)),
            "mueller_stderr_10deg_phi0_0.55um.png"
        );
        assert_eq!(at_azimuth("dop_10deg.png", None), "dop_10deg.png");
        assert_eq!(dop_file(89.9999999), "dop_89.9999999deg.png");
        assert_eq!(number_label(0.1 + 0.2), "0.30000000000000004");
        assert_eq!(hemisphere_file(1e-300), "hemisphere_1e-300deg.png");
        assert_eq!(number_label(1e-30), "1e-30");
        for x in [1e-300, 1e-30, 123.456, 0.1 + 0.2, 5e-324] {
            let l = number_label(x);
            assert!(l.len() <= LABEL_DIGITS, "{l}");
            assert_eq!(l.parse::<f64>().unwrap(), x);
        }
    }
}
