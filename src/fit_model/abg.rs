//! The ABg scatter model, as Zemax OpticStudio and FRED define it.
//!
//! # Definition
//!
//! `BSDF(x) = A / (B + x^g)` (sr⁻¹), with `x = |beta - beta0|`: `beta` is
//! the scattered direction projected onto the surface (a vector of length
//! `sin theta_s`) and `beta0` the specular direction's (length `sin
//! theta_r`, here `theta_r = theta_i`), so `x` is the distance between the
//! two in direction-cosine space, between 0 and 2 ([`super::beta_distance`]).
//! `A >= 0` (sr⁻¹), `B > 0` (dimensionless), `g` (dimensionless, typically
//! 0 to 3); the BSDF at the specular direction is `A / B`, and the model
//! depends on the incidence only through `beta0` (shift invariance). It is
//! the BRDF of all the light the table holds: roks's tables have no
//! separate specular ray, so in FRED the model goes with "Halt Incident
//! Ray" checked, and the total integrated scatter (TIS) of the fit is the
//! surface's reflectance.
//!
//! Sources (the vendors' documentation):
//! * OpticStudio User Guide, "Available Scatter Models", ABg Model
//!   Scattering: `BSDF(x) = A / (B + |x|^g)`, `x = beta - beta0` the
//!   projected scattered minus projected specular vector ("Scatter
//!   Models": `|beta0| = sin theta_r`, `|beta| = sin theta_s`); `A >= 0`,
//!   `B > 1e-12` unless `g = 0`.
//!   <https://ansyshelp.ansys.com/public/Views/Secured/Zemax/v251/en/OpticStudio_User_Guide/OpticStudio_Help/topics/Available_Scatter_Models.html>
//! * OpticStudio "ABg Scatter Data Catalogs" dialog: per ABg data name a
//!   wavelength `Wave` (µm; 0: no scaling with wavelength) and up to 10
//!   rows `Angle` (angle of incidence, degrees, 0 to 90; linearly
//!   interpolated in cosine space, clamped outside), `A`, `B`, `g`.
//! * FRED, Scatterers > Scatter Types > ABg: `Acoef`, `Bcoef`, `G` ("slope
//!   of the BSDF at large B-B0"), `BSDF = A / (B + |b - b0|^g)` with `b`,
//!   `b0` the sines of the scatter and specular angles (projected
//!   vectors); linear-shift invariant, one set of coefficients (no
//!   dependence on incidence).
//!   <https://help.photonengr.com/Topics/Tree_Scatterers_EditCreateNewABg.htm>
//!
//! One ABg set is fitted per tabulated incidence ([`fit`]); OpticStudio
//! takes them all as the rows of one ABg data entry ([`opticstudio_text`]),
//! FRED takes one set (the [`fred`] choice: the incidence nearest 30
//! degrees, the others listed for its extended models).

use glam::DVec3;
use serde::Serialize;

use super::{FitError, FitResult, Model, Observations, beta_distance, linear_starts, linspace};
use crate::optics::brdf_table::BrdfTable;

/// ABg with internal parameters `[ln A, ln B, g]`.
#[derive(Debug, Clone, Copy)]
pub struct Abg;

impl Abg {
    /// `A / (B + x^g)` for `x` = `|beta - beta0|` (sr⁻¹).
    #[must_use]
    pub fn bsdf(a: f64, b: f64, g: f64, x: f64) -> f64 {
        a / (b + x.powf(g))
    }
}

impl Model for Abg {
    fn names(&self) -> &'static [&'static str] {
        &["A", "B", "g"]
    }

    fn brdf(&self, q: &[f64], theta_i: f64, out: DVec3) -> f64 {
        Self::bsdf(q[0].exp(), q[1].exp(), q[2], beta_distance(theta_i, out))
    }

    fn physical(&self, q: &[f64]) -> Vec<(f64, f64)> {
        let (a, b) = (q[0].exp(), q[1].exp());
        vec![(a, a), (b, b), (q[2], 1.0)]
    }

    fn internal(&self, values: &[f64]) -> Vec<f64> {
        vec![values[0].ln(), values[1].ln(), values[2]]
    }
}

/// Fit ABg to every incidence of `table` on its own.
///
/// # Errors
/// The first incidence that cannot be fitted.
pub fn fit(table: &BrdfTable, obs: &Observations) -> Result<Vec<FitResult>, FitError> {
    let mut grid = Vec::new();
    for ln_b in linspace(-12.0, 1.0, 14) {
        for g in linspace(0.2, 3.8, 10) {
            grid.push(vec![ln_b, g]);
        }
    }
    super::per_incidence(&Abg, table, obs, |cells| {
        linear_starts(cells, &grid, |s, t, d| {
            Abg::bsdf(1.0, s[0].exp(), s[1], beta_distance(t, d))
        })
    })
}

/// One row of OpticStudio's ABg data entry.
#[derive(Debug, Clone, Serialize)]
pub struct OpticStudioRow {
    /// Angle of incidence (degrees).
    pub angle_deg: f64,
    /// A (sr⁻¹).
    pub a: f64,
    /// B.
    pub b: f64,
    /// g.
    pub g: f64,
    /// The fit's TIS over the table's cells.
    pub tis: f64,
    /// The table's reflectance over the same cells.
    pub table_tis: f64,
    /// The verdict of the fit's reflectance at this angle
    /// ([`super::ReflectanceCompare::ok`]): the TIS within `max(1 %, 4
    /// standard errors)` of the table's.
    pub ok: bool,
}

/// The parameters in FRED's ABg dialog (one set).
#[derive(Debug, Clone, Serialize)]
pub struct Fred {
    /// `Acoef` (sr⁻¹).
    pub acoef: f64,
    /// `Bcoef`.
    pub bcoef: f64,
    /// `G`.
    pub g: f64,
    /// The incidence (degrees) whose fit this is: the one nearest 30
    /// degrees (FRED's ABg does not depend on incidence).
    pub from_theta_i_deg: f64,
    /// Check "Halt Incident Ray": the table holds all reflected light.
    pub halt_incident_ray: bool,
}

/// OpticStudio's rows from the per-incidence fits (at most 10, as the
/// dialog takes: evenly chosen when there are more).
#[must_use]
pub fn opticstudio_rows(fits: &[FitResult]) -> Vec<OpticStudioRow> {
    let n = fits.len();
    let pick: Vec<usize> = if n <= 10 {
        (0..n).collect()
    } else {
        (0..10).map(|k| (k * (n - 1) + 4) / 9).collect()
    };
    pick.into_iter()
        .map(|k| {
            let f = &fits[k];
            OpticStudioRow {
                angle_deg: f.theta_i_deg[0],
                a: f.parameters[0].value,
                b: f.parameters[1].value,
                g: f.parameters[2].value,
                tis: f.reflectance[0].model,
                table_tis: f.reflectance[0].table,
                ok: f.reflectance[0].ok,
            }
        })
        .collect()
}

/// FRED's one set: the fit at the incidence nearest 30 degrees.
///
/// # Panics
/// If `fits` is empty.
#[must_use]
pub fn fred(fits: &[FitResult]) -> Fred {
    let f = super::nearest(fits, 30.0);
    Fred {
        acoef: f.parameters[0].value,
        bcoef: f.parameters[1].value,
        g: f.parameters[2].value,
        from_theta_i_deg: f.theta_i_deg[0],
        halt_incident_ray: true,
    }
}

/// The text for OpticStudio's "ABg Scatter Data Catalogs" dialog: the
/// entry's name and wavelength, the fit's verdict and every warning
/// ([`super::warnings`]) as comments, then one row per angle of incidence
/// with the dialog's fields `Angle A B g` in its order (and, as a comment,
/// the TIS of the fit, the table's and the verdict: `ok`, or `OFF` where
/// they differ by more than `max(1 %, 4 standard errors)`), for typing in
/// or pasting into an ABg data file.
#[must_use]
pub fn opticstudio_text(
    name: &str,
    wavelength_um: f64,
    rows: &[OpticStudioRow],
    verdict: &str,
    warnings: &[String],
) -> String {
    let mut s = format!(
        "! ABg data for OpticStudio (Setup > ABg Scatter Data Catalogs), fitted by roks fit-model\n\
         ! BSDF = A / (B + |beta - beta0|^g), beta, beta0 the projected scattered and specular directions, 1/sr\n\
         ! Name {name}\n\
         ! Wave {wavelength_um} (um; 0 = no scaling with wavelength)\n\
         ! Verdict {verdict}\n"
    );
    for w in warnings {
        s.push_str(&format!("! WARNING {w}\n"));
    }
    s.push_str(
        "! Angle(deg) A B g   ! TIS of the fit, the table's, verdict (ok: within max(1 %, 4 standard errors))\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{} {:.6e} {:.6e} {:.6}   ! {:.5} {:.5} {}\n",
            r.angle_deg,
            r.a,
            r.b,
            r.g,
            r.tis,
            r.table_tis,
            if r.ok { "ok" } else { "OFF" }
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_definition() {
        // A / B at the specular direction; falls as x^-g far from it.
        assert_eq!(Abg::bsdf(0.02, 0.01, 2.0, 0.0), 2.0);
        let far = Abg::bsdf(0.02, 1e-9, 2.0, 0.5);
        assert!((far - 0.02 / 0.25).abs() < 1e-9);
        let m = Abg;
        let q = [0.02f64.ln(), 0.01f64.ln(), 2.0];
        let t: f64 = 0.5;
        let spec = DVec3::new(-t.sin(), 0.0, t.cos());
        assert!((m.brdf(&q, t, spec) - 2.0).abs() < 1e-12);
    }
}
