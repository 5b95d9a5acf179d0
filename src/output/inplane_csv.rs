//! `inplane.csv`: the in-plane BRDF of a run, per incidence and in-plane
//! bin: `theta_o_deg` signed (positive on the specular side, negative
//! toward the light), `brdf` and `brdf_stderr` (sr⁻¹, 10 significant
//! digits). A spectral run has `wavelength_um` (µm) after `theta_i_deg`,
//! one block per incidence and wavelength.

use std::fmt::Write as _;

use crate::tally::InPlaneTally;
use crate::transport::brdf::{BrdfRun, IncidenceResult};

/// Columns of `inplane.csv`.
pub const HEADER: &str = "theta_i_deg,theta_o_deg,brdf,brdf_stderr";

/// `inplane.csv` of a run's `results` (its leaves in file order: a
/// [`crate::transport::brdf::BrdfResult`], or some of its leaves).
#[must_use]
pub fn write<'a>(run: &BrdfRun, results: impl IntoIterator<Item = &'a IncidenceResult>) -> String {
    let tally: InPlaneTally = run.inplane();
    let mut s = String::new();
    s.push_str(&super::with_wavelength(HEADER, "theta_i_deg", run));
    s.push('\n');
    for r in results {
        let n = r.tallies.photons;
        for bin in 0..tally.n_bins() {
            let proj = tally.projected_solid_angle(bin);
            let f = r.tallies.inplane.mean(bin, n);
            let fe = r.inplane_stderr(bin);
            let _ = write!(s, "{},", r.theta_i_deg);
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
