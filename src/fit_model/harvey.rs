//! The Harvey-Shack scatter model, in the form FRED documents (and ASAP's
//! `HARVEY`).
//!
//! # Definition
//!
//! `BSDF(x) = b0 (1 + (x / l)²)^(s/2)` (sr⁻¹), with `x = |beta - beta0|`
//! the distance between the projected scattered and specular directions
//! in direction-cosine space ([`super::beta_distance`], as in ABg): `b0 >
//! 0` the BSDF at the specular direction (sr⁻¹), `l > 0` the knee (the
//! value of `x` where the curve rolls over, dimensionless), `s` the slope
//! of `log BSDF` against `log x` far from specular (negative). For `x >>
//! l` it is the ABg model with `g = -s`, `A = b0 l^-s`, `B` small.
//!
//! Source: FRED, Scatterers > Scatter Types > Harvey-Shack and the
//! scripting type `T_HARVEYSHACKSCATTER` (members `b0`: "BRDF value at
//! B=B0", `L`: "value of B-B0 for the knee of the curve", `S`: "slope for
//! large B-B0 values"), and Extended Harvey-Shack, whose standard form this
//! is with `b = sin theta`, `b0 = sin theta_0` of the scatter and specular
//! directions.
//! <https://help.photonengr.com/Topics/Script_T_HARVEYSHACKSCATTER.htm>,
//! <https://help.photonengr.com/Topics/IDH_Topic18061.htm>
//!
//! Fitted per incidence ([`fit`]), as ABg; FRED's model has one set.

use glam::DVec3;

use super::{FitError, FitResult, Model, Observations, beta_distance, linear_starts, linspace};
use crate::optics::brdf_table::BrdfTable;

/// Harvey-Shack with internal parameters `[ln b0, ln l, s]`.
#[derive(Debug, Clone, Copy)]
pub struct Harvey;

impl Harvey {
    /// `b0 (1 + (x/l)²)^(s/2)` (sr⁻¹).
    #[must_use]
    pub fn bsdf(b0: f64, l: f64, s: f64, x: f64) -> f64 {
        let r = x / l;
        b0 * (1.0 + r * r).powf(0.5 * s)
    }
}

impl Model for Harvey {
    fn names(&self) -> &'static [&'static str] {
        &["b0", "l", "s"]
    }

    fn brdf(&self, q: &[f64], theta_i: f64, out: DVec3) -> f64 {
        Self::bsdf(q[0].exp(), q[1].exp(), q[2], beta_distance(theta_i, out))
    }

    fn physical(&self, q: &[f64]) -> Vec<(f64, f64)> {
        let (b0, l) = (q[0].exp(), q[1].exp());
        vec![(b0, b0), (l, l), (q[2], 1.0)]
    }

    fn internal(&self, values: &[f64]) -> Vec<f64> {
        vec![values[0].ln(), values[1].ln(), values[2]]
    }
}

/// Fit Harvey-Shack to every incidence of `table` on its own.
///
/// # Errors
/// The first incidence that cannot be fitted.
pub fn fit(table: &BrdfTable, obs: &Observations) -> Result<Vec<FitResult>, FitError> {
    let mut grid = Vec::new();
    for ln_l in linspace(-7.0, 0.5, 14) {
        for s in linspace(-5.0, -0.2, 10) {
            grid.push(vec![ln_l, s]);
        }
    }
    super::per_incidence(&Harvey, table, obs, |cells| {
        linear_starts(cells, &grid, |p, t, d| {
            Harvey::bsdf(1.0, p[0].exp(), p[1], beta_distance(t, d))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_definition() {
        assert_eq!(Harvey::bsdf(3.0, 0.1, -2.0, 0.0), 3.0);
        // At the knee: 2^(s/2).
        assert!((Harvey::bsdf(3.0, 0.1, -2.0, 0.1) - 1.5).abs() < 1e-12);
        // Far: b0 (x/l)^s.
        let far = Harvey::bsdf(3.0, 1e-4, -1.5, 0.5);
        assert!((far / (3.0 * (0.5f64 / 1e-4).powf(-1.5)) - 1.0).abs() < 1e-6);
    }
}
