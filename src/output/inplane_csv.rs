//! `inplane.csv`: the in-plane BRDF of a run, per incidence and in-plane
//! bin: `theta_o_deg` signed (positive on the specular side, negative
//! toward the light), `brdf` and `brdf_stderr` (sr⁻¹, 10 significant
//! digits). A run with several light azimuths has `phi_i_deg` (degrees)
//! after `theta_i_deg` ([`AZIMUTH_HEADER`]); a spectral run has
//! `wavelength_um` (µm) after `theta_i_deg` (or `phi_i_deg`). One block per
//! incidence, then azimuth, then wavelength; a run of one azimuth has no
//! `phi_i_deg` column (its file is that of the runs before several
//! azimuths): its azimuth is in `summary.json`.

use std::fmt::Write as _;

use crate::tally::InPlaneTally;
use crate::transport::brdf::{BrdfRun, IncidenceResult};

/// Columns of `inplane.csv`.
pub const HEADER: &str = "theta_i_deg,theta_o_deg,brdf,brdf_stderr";

/// Columns of `inplane.csv` of a run with several light azimuths.
pub const AZIMUTH_HEADER: &str = "theta_i_deg,phi_i_deg,theta_o_deg,brdf,brdf_stderr";

/// The header of `run`'s `inplane.csv`: [`HEADER`] or [`AZIMUTH_HEADER`],
/// with `wavelength_um` after the incidence's columns for a spectral run.
#[must_use]
pub fn header(run: &BrdfRun) -> String {
    if run.phi_deg.len() > 1 {
        super::with_wavelength(AZIMUTH_HEADER, "phi_i_deg", run)
    } else {
        super::with_wavelength(HEADER, "theta_i_deg", run)
    }
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
            let _ = writeln!(
                s,
                "{},{:.9e},{:.9e}",
                tally.centre_deg(bin),
                f / proj,
                fe / proj
            );
        }
    }
    s
}
