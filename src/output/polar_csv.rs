//! `stokes.csv` and `mueller.csv`: the polarisation tables of a run with a
//! polarisation tally (`[tally] polarisation = "stokes"` or `"mueller"`).
//! Frames: every outgoing direction's Stokes reference vector is
//! `normalize(z × d)` (see [`crate::optics::polarisation`]), the incident
//! one that of the incident flight (the s axis of the plane of incidence).
//! Numbers with 10 significant digits. A spectral run has `wavelength_um`
//! (µm) after `phi_i_deg`, one block per incidence and wavelength.

use std::fmt::Write as _;

use crate::optics::polarisation::degree_of_polarisation;
use crate::tally::{CarlsonGrid, PolarTally};
use crate::transport::brdf::{BrdfRun, IncidenceResult};

/// Columns of `stokes.csv`: per incidence and Carlson cell, the Stokes BRDF
/// `s_i` (1/sr) of the reflected light for the incident state in the cell
/// direction's frame, with standard errors; `s0` equals `brdf` of
/// `brdf.csv`; `dop = sqrt(s1² + s2² + s3²) / s0` of the means (0 where
/// `s0 = 0`).
pub const STOKES_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,s0,s0_stderr,s1,s1_stderr,s2,s2_stderr,s3,s3_stderr,dop";

/// Columns of `mueller.csv`: per incidence and Carlson cell, the Mueller
/// matrix BRDF `m_ij` (1/sr, row = outgoing component `i`, column = incident
/// component `j`) with standard errors; `m00` is the BRDF for unpolarised light.
pub const MUELLER_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,m00,m00_stderr,m01,m01_stderr,m02,m02_stderr,m03,m03_stderr,m10,m10_stderr,m11,m11_stderr,m12,m12_stderr,m13,m13_stderr,m20,m20_stderr,m21,m21_stderr,m22,m22_stderr,m23,m23_stderr,m30,m30_stderr,m31,m31_stderr,m32,m32_stderr,m33,m33_stderr";

/// The polarisation table of a run with a polarisation tally: its file name
/// (`stokes.csv` or `mueller.csv`) and text; `None` without one.
#[must_use]
pub fn write(run: &BrdfRun, results: &[IncidenceResult]) -> Option<(&'static str, String)> {
    let (name, header) = match run.polarisation.tally {
        PolarTally::None => return None,
        PolarTally::Stokes => ("stokes.csv", STOKES_HEADER),
        PolarTally::Mueller => ("mueller.csv", MUELLER_HEADER),
    };
    let k = run.polarisation.tally.components();
    let grid: CarlsonGrid = run.grid();
    let mut s = String::with_capacity(40 * (k + 1) * grid.n_cells() * results.len());
    s.push_str(&super::with_wavelength(header, "phi_i_deg", run));
    s.push('\n');
    for r in results {
        let Some(p) = &r.tallies.polar else {
            continue;
        };
        for flat in 0..grid.n_cells() {
            let (band, cell) = grid.band_cell(flat);
            let (theta, phi) = grid.centre(band, cell);
            let proj = grid.projected_solid_angle(band, cell);
            let _ = write!(s, "{},{},", r.theta_i_deg, r.phi_i_deg);
            super::write_wavelength(&mut s, r);
            let _ = write!(
                s,
                "{band},{cell},{},{}",
                theta.to_degrees(),
                phi.to_degrees()
            );
            let mut means = [0.0; 16];
            for (i, m) in means.iter_mut().enumerate().take(k) {
                let (mean, se) = r.polar(p.cell_bin(flat, i)).unwrap_or_default();
                *m = mean / proj;
                let _ = write!(s, ",{:.9e},{:.9e}", mean / proj, se / proj);
            }
            if k == 4 {
                let _ = write!(
                    s,
                    ",{:.9e}",
                    degree_of_polarisation([means[0], means[1], means[2], means[3]])
                );
            }
            s.push('\n');
        }
    }
    Some((name, s))
}
