//! The tables of `roks trace`: `reflectance.csv` (one row per beam
//! position), `farfield.csv` and `farfield_stokes.csv` (per beam position
//! and cell of the full-sphere far-field grid). Numbers with 10
//! significant digits, cell geometry as in `brdf.csv`.
//!
//! A spectral run (`[light] wavelengths_um` or `--wavelengths`) has one
//! more column, `wavelength_um` (µm, shortest round-trip form), right after
//! the position columns: after `z` in `reflectance.csv`
//! ([`SPECTRAL_REFLECTANCE_HEADER`]), after `source` in `farfield.csv` and
//! `farfield_stokes.csv` ([`SPECTRAL_FARFIELD_HEADER`],
//! [`SPECTRAL_FARFIELD_STOKES_HEADER`]); rows are position-major, then
//! wavelength in the run's order, then (far field) cell. A monochrome
//! run's files are unchanged.

use std::fmt::Write as _;

use crate::transport::object::{ObjectResult, ObjectRun, PositionResult};

/// Columns of `reflectance.csv` (`roks trace`).
pub const REFLECTANCE_HEADER: &str = "x,y,z,reflectance,reflectance_stderr";

/// Columns of `farfield.csv` (`roks trace`): `brdf.csv`'s cell columns with
/// `source` first; bands `-1..-M` are the mirror images below the horizon
/// (theta measured from +z, 90-180 degrees there).
pub const FARFIELD_HEADER: &str = "source,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,fraction,fraction_stderr,brdf,brdf_stderr";

/// Columns of a spectral run's `reflectance.csv`.
pub const SPECTRAL_REFLECTANCE_HEADER: &str = "x,y,z,wavelength_um,reflectance,reflectance_stderr";

/// Columns of a spectral run's `farfield.csv`: [`FARFIELD_HEADER`] with
/// `wavelength_um` after `source`.
pub const SPECTRAL_FARFIELD_HEADER: &str = "source,wavelength_um,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,fraction,fraction_stderr,brdf,brdf_stderr";

/// Columns of a spectral run's `farfield_stokes.csv`:
/// [`FARFIELD_STOKES_HEADER`] with `wavelength_um` after `source`.
pub const SPECTRAL_FARFIELD_STOKES_HEADER: &str = "source,wavelength_um,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,s0,s0_stderr,s1,s1_stderr,s2,s2_stderr,s3,s3_stderr,dop";

/// Whether results come from a spectral run.
fn spectral(result: &ObjectResult) -> bool {
    result.iter().any(|r| r.wavelength_um.is_some())
}

/// `reflectance.csv`: one row per beam position (and wavelength).
#[must_use]
pub fn reflectance_csv(result: &ObjectResult) -> String {
    let spectral = spectral(result);
    let mut s = String::from(if spectral {
        SPECTRAL_REFLECTANCE_HEADER
    } else {
        REFLECTANCE_HEADER
    });
    s.push('\n');
    for r in result.iter() {
        let p = r.beam.position;
        let (refl, se) = r.reflectance();
        let _ = write!(s, "{},{},{},", p.x, p.y, p.z);
        if let Some(w) = r.wavelength_um {
            let _ = write!(s, "{w},");
        }
        let _ = writeln!(s, "{refl:.9e},{se:.9e}");
    }
    s
}

/// Columns of `farfield_stokes.csv` (`roks trace` with `[tally]
/// polarisation = "stokes"`): `farfield.csv`'s cell columns, then the Stokes
/// components of the light leaving through the cell per projected solid
/// angle (1/sr; `s0` equals `farfield.csv`'s `brdf`) with standard errors,
/// and the degree of polarisation `dop`. Each photon's Stokes vector is
/// taken about `hemisphere_reference(dir, 0)` of its exit direction `dir`
/// ([`crate::transport::object::stokes_reference`]), above and below the horizon.
pub const FARFIELD_STOKES_HEADER: &str = "source,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,s0,s0_stderr,s1,s1_stderr,s2,s2_stderr,s3,s3_stderr,dop";

/// The rows of a far-field table: per beam position `k` (and wavelength) and
/// full-sphere cell `flat`, `row(s, result, flat, projected solid angle)`
/// appends the columns after the cell's (`source` to
/// `projected_solid_angle_sr`, with the comma before them written) and the
/// line end. `header` is the monochrome header, `spectral_header` a
/// spectral run's.
fn farfield_rows(
    header: &str,
    spectral_header: &str,
    run: &ObjectRun,
    result: &ObjectResult,
    row: impl Fn(&mut String, &PositionResult, usize, f64),
) -> String {
    let grid = run.farfield_grid().grid;
    let mut s = String::from(if spectral(result) {
        spectral_header
    } else {
        header
    });
    s.push('\n');
    for (k, lanes) in result.groups().enumerate() {
        for r in lanes {
            farfield_leaf(&mut s, &grid, k, r, &row);
        }
    }
    s
}

/// The rows of beam position `k`'s leaf `r` (one wavelength) in a far-field
/// table (see [`farfield_rows`]).
fn farfield_leaf(
    s: &mut String,
    grid: &crate::tally::CarlsonGrid,
    k: usize,
    r: &PositionResult,
    row: &impl Fn(&mut String, &PositionResult, usize, f64),
) {
    let half = grid.n_cells();
    let omega = grid.solid_angle();
    let lambda = r
        .wavelength_um
        .map_or_else(String::new, |w| format!("{w},"));
    for flat in 0..2 * half {
        let lower = flat >= half;
        let (band, cell) = grid.band_cell(flat % half);
        let (mu_bot, mu_top) = grid.mu_edges(band);
        let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
        let (theta, phi) = grid.centre(band, cell);
        let (t_lo, t_hi, t_c) = if lower {
            (
                180.0 - mu_bot.acos().to_degrees(),
                180.0 - mu_top.acos().to_degrees(),
                180.0 - theta.to_degrees(),
            )
        } else {
            (
                mu_top.acos().to_degrees(),
                mu_bot.acos().to_degrees(),
                theta.to_degrees(),
            )
        };
        let band_label = if lower { -(band as i64) } else { band as i64 };
        let proj = grid.projected_solid_angle(band, cell);
        let _ = write!(
            s,
            "{k},{lambda}{band_label},{cell},{t_lo},{t_hi},{},{},{t_c},{},{omega:.12e},{proj:.12e},",
            phi_lo.to_degrees(),
            phi_hi.to_degrees(),
            phi.to_degrees(),
        );
        row(s, r, flat, proj);
        s.push('\n');
    }
}

/// `farfield.csv`: per beam position and cell of the full-sphere grid, the
/// share of the source's flux leaving through the cell; `brdf` is that share
/// per projected solid angle about the z axis (for a flat plate lit along
/// -omega_i this is the plate's BRDF, comparable with `brdf.csv`).
#[must_use]
pub fn farfield_csv(run: &ObjectRun, result: &ObjectResult) -> String {
    farfield_rows(
        FARFIELD_HEADER,
        SPECTRAL_FARFIELD_HEADER,
        run,
        result,
        |s, r, flat, proj| {
            let n = r.tallies.photons;
            let f = r.tallies.farfield.mean(flat, n);
            let fe = r.tallies.farfield.stderr(flat, n);
            let _ = write!(s, "{f:.9e},{fe:.9e},{:.9e},{:.9e}", f / proj, fe / proj);
        },
    )
}

/// `farfield_stokes.csv` (see [`FARFIELD_STOKES_HEADER`]); the run must
/// have tallied it ([`crate::transport::object::ObjectRun::tallies_farfield_stokes`]).
#[must_use]
pub fn farfield_stokes_csv(run: &ObjectRun, result: &ObjectResult) -> String {
    farfield_rows(
        FARFIELD_STOKES_HEADER,
        SPECTRAL_FARFIELD_STOKES_HEADER,
        run,
        result,
        |s, r, flat, proj| {
            let (acc, n) = (&r.tallies.farfield_stokes, r.tallies.photons);
            let stokes: [f64; 4] = std::array::from_fn(|j| acc.mean(4 * flat + j, n) / proj);
            for (j, v) in stokes.iter().enumerate() {
                let _ = write!(s, "{v:.9e},{:.9e},", acc.stderr(4 * flat + j, n) / proj);
            }
            let dop = crate::optics::polarisation::degree_of_polarisation(stokes);
            let _ = write!(s, "{dop:.9e}");
        },
    )
}
