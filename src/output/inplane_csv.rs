//! `inplane.csv`: the in-plane BRDF of a run, per incidence and in-plane
//! bin: `theta_o_deg` signed (positive on the specular side, negative
//! toward the light), `brdf` and `brdf_stderr` (sr⁻¹, 10 significant
//! digits). A run with several light azimuths has `phi_i_deg` (degrees)
//! after `theta_i_deg` ([`AZIMUTH_HEADER`]); a spectral run has
//! `wavelength_um` (µm) after `theta_i_deg` (or `phi_i_deg`). One block per
//! incidence, then azimuth, then wavelength; a run of one azimuth has no
//! `phi_i_deg` column (its file is that of the runs before several
//! azimuths): its azimuth is in `summary.json`. With several surface
//! realisations (`[surface] realisations = R > 1`) `brdf_stderr` is the
//! standard error of the ensemble mean (the spread between the
//! realisations, see [`crate::transport::brdf::Ensemble`]) and one more
//! column ends every row, [`PHOTON_COLUMN`]: the photon noise alone.

use std::fmt::Write as _;

use crate::tally::InPlaneTally;
use crate::transport::brdf::{BrdfRun, IncidenceResult};

/// Columns of `inplane.csv`.
pub const HEADER: &str = "theta_i_deg,theta_o_deg,brdf,brdf_stderr";

/// Columns of `inplane.csv` of a run with several light azimuths.
pub const AZIMUTH_HEADER: &str = "theta_i_deg,phi_i_deg,theta_o_deg,brdf,brdf_stderr";

/// The column that ends the header of a run of several surface
/// realisations: the standard error of `brdf` from the photons alone.
pub const PHOTON_COLUMN: &str = "brdf_stderr_photon";

/// The header of `run`'s `inplane.csv`: [`HEADER`] or [`AZIMUTH_HEADER`],
/// with `wavelength_um` after the incidence's columns for a spectral run,
/// and [`PHOTON_COLUMN`] at the end for several surface realisations.
#[must_use]
pub fn header(run: &BrdfRun) -> String {
    let mut h = if run.phi_deg.len() > 1 {
        super::with_wavelength(AZIMUTH_HEADER, "phi_i_deg", run)
    } else {
        super::with_wavelength(HEADER, "theta_i_deg", run)
    };
    if run.realisations > 1 {
        h = format!("{h},{PHOTON_COLUMN}");
    }
    h
}

/// `inplane.csv` of a run's `results` (its leaves in file order: a
/// [`crate::transport::brdf::BrdfResult`], or some of its leaves).
#[must_use]
pub fn write<'a>(run: &BrdfRun, results: impl IntoIterator<Item = &'a IncidenceResult>) -> String {
    let tally: InPlaneTally = run.inplane();
    let mut s = String::new();
    let azimuths = run.phi_deg.len() > 1;
    s.push_str(&header(run));
    s.push('\n');
    for r in results {
        let n = r.tallies.photons;
        for bin in 0..tally.n_bins() {
            let proj = tally.projected_solid_angle(bin);
            let f = r.tallies.inplane.mean(bin, n);
            let fe = r.inplane_stderr(bin);
            let _ = write!(s, "{},", r.theta_i_deg);
            if azimuths {
                let _ = write!(s, "{},", r.phi_i_deg);
            }
            super::write_wavelength(&mut s, r);
            let _ = write!(
                s,
                "{},{:.9e},{:.9e}",
                tally.centre_deg(bin),
                f / proj,
                fe / proj
            );
            if run.realisations > 1 {
                let _ = write!(s, ",{:.9e}", r.inplane_stderr_photon(bin) / proj);
            }
            s.push('\n');
        }
    }
    s
}
