//! Microfacet BRDFs with Smith shadowing-masking, as renderers take them:
//! GGX (Trowbridge-Reitz) and Beckmann, isotropic, fitted jointly to every
//! incidence of a table with the material's Fresnel factor.
//!
//! # Definition
//!
//! `f(wi, wo) = F(wi . h) D(h) G2(wi, wo) / (4 cos_i cos_o)` (sr⁻¹), `h =
//! (wi + wo) / |wi + wo|` the half vector, `cos_i`, `cos_o` the cosines of
//! the light and viewing directions to the mean normal, `F` the material's
//! reflectance at the micro facet's angle (unpolarised Fresnel of `n + ik`,
//! or a constant), `G2 = 1 / (1 + Lambda(wi) + Lambda(wo))` Smith's
//! height-correlated shadowing-masking (Heitz 2014, "Understanding the
//! masking-shadowing function in microfacet-based BRDFs", JCGT 3(2), eq.
//! 99), and, with `theta_h` the polar angle of `h` and `theta` that of a
//! direction:
//! * **Beckmann**: `D = exp(-tan² theta_h / alpha²) / (pi alpha² cos⁴
//!   theta_h)`, `Lambda = (erf(a) - 1) / 2 + exp(-a²) / (2 a sqrt(pi))`,
//!   `a = 1 / (alpha tan theta)` (Heitz 2014 eqs. 71-72). The slopes are
//!   Gaussian with variance `alpha² / 2` per axis, so **`alpha` is the RMS
//!   slope** `sqrt(<|grad h|²>)` (both axes together, as `roks stats`'s
//!   `rms_slope`); for a Gaussian surface with autocorrelation `sigma²
//!   exp(-r² / tau²)` (roks's Gaussian height fields, `tau` the 1/e
//!   length), each slope has variance `2 sigma² / tau²`, so `alpha = 2
//!   sigma / tau`.
//! * **GGX**: `D = alpha² / (pi cos⁴ theta_h (alpha² + tan² theta_h)²)`,
//!   `Lambda = (-1 + sqrt(1 + alpha² tan² theta)) / 2` (Walter, Marschner,
//!   Li, Torrance 2007, "Microfacet models for refraction through rough
//!   surfaces", eqs. 33-34; Heitz 2014 eq. 86). Its slope distribution has
//!   no finite variance, so `alpha` has no RMS-slope relation (both
//!   distributions have `D(n) = 1 / (pi alpha²)` at the mean normal). Its
//!   tails (slope density falling as `r^-4`) put light where a Gaussian
//!   surface has none, so a GGX fit to a Gaussian surface's table pays
//!   for them with a narrower core: for the Gaussian field of
//!   `tests/fit_model.rs` (RMS slope 0.196) GGX gives alpha 0.102 at
//!   chi²/dof 177, Beckmann 0.183 at 13.
//!
//! These are single-scattering models: the light a rough surface scatters
//! twice or more is not in them, and shows as the table's reflectance above
//! the model's ([`super::FitResult::reflectance`]), growing with `alpha` and
//! the incidence angle.

use glam::DVec3;

use super::{FitError, FitResult, Model, Observation, Observations, linspace};
use crate::optics::brdf_table::BrdfTable;
use crate::optics::material::Reflectance;

/// The distribution of normals.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Distribution {
    /// Trowbridge-Reitz / GGX.
    Ggx,
    /// Beckmann.
    Beckmann,
}

impl Distribution {
    /// `D(h)` (sr⁻¹ of normals, per projected area) for `cos theta_h`.
    #[must_use]
    pub fn d(self, alpha: f64, cos_h: f64) -> f64 {
        if cos_h <= 0.0 {
            return 0.0;
        }
        let c2 = cos_h * cos_h;
        let tan2 = (1.0 - c2) / c2;
        let a2 = alpha * alpha;
        match self {
            Self::Beckmann => (-tan2 / a2).exp() / (std::f64::consts::PI * a2 * c2 * c2),
            Self::Ggx => {
                let t = a2 + tan2;
                a2 / (std::f64::consts::PI * c2 * c2 * t * t)
            }
        }
    }

    /// Smith's `Lambda` for a direction of polar cosine `cos_t > 0`.
    #[must_use]
    pub fn lambda(self, alpha: f64, cos_t: f64) -> f64 {
        let c = cos_t.clamp(1e-12, 1.0);
        let tan = (1.0 - c * c).max(0.0).sqrt() / c;
        if tan == 0.0 {
            return 0.0;
        }
        match self {
            Self::Beckmann => {
                let a = 1.0 / (alpha * tan);
                0.5 * (libm::erf(a) - 1.0)
                    + (-a * a).exp() / (2.0 * a * std::f64::consts::PI.sqrt())
            }
            Self::Ggx => 0.5 * ((1.0 + alpha * alpha * tan * tan).sqrt() - 1.0),
        }
    }
}

/// A microfacet BRDF of one distribution and material; internal parameter
/// `[ln alpha]`.
#[derive(Debug, Clone)]
pub struct Microfacet {
    /// The distribution of normals.
    pub distribution: Distribution,
    /// The material (reflectance at the facet's angle).
    pub material: Reflectance,
}

impl Microfacet {
    /// The BRDF (sr⁻¹) at roughness `alpha` for light from `wi` towards
    /// `wo` (unit vectors, local frame).
    #[must_use]
    pub fn eval(&self, alpha: f64, wi: DVec3, wo: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        let f = self.material.reflectance(wi.dot(h));
        let d = self.distribution.d(alpha, h.z);
        let g2 = 1.0
            / (1.0 + self.distribution.lambda(alpha, wi.z) + self.distribution.lambda(alpha, wo.z));
        f * d * g2 / (4.0 * wi.z * wo.z)
    }
}

impl Model for Microfacet {
    fn names(&self) -> &'static [&'static str] {
        &["alpha"]
    }

    fn brdf(&self, q: &[f64], theta_i: f64, out: DVec3) -> f64 {
        let wi = DVec3::new(theta_i.sin(), 0.0, theta_i.cos());
        self.eval(q[0].exp(), wi, out)
    }

    fn physical(&self, q: &[f64]) -> Vec<(f64, f64)> {
        let a = q[0].exp();
        vec![(a, a)]
    }

    fn internal(&self, values: &[f64]) -> Vec<f64> {
        vec![values[0].ln()]
    }
}

/// Fit `model`'s `alpha` to every incidence of `table` together.
///
/// # Errors
/// A table no model represents ([`super::check_representable`]), too few
/// cells, or no finite start.
pub fn fit(
    model: &Microfacet,
    table: &BrdfTable,
    obs: &Observations,
) -> Result<FitResult, FitError> {
    super::check_representable(table)?;
    let cells: Vec<&Observation> = obs.cells.iter().collect();
    let starts: Vec<Vec<f64>> = linspace(0.01f64.ln(), 2.0f64.ln(), 40)
        .into_iter()
        .map(|q| vec![q])
        .collect();
    super::fit(model, table, &cells, &starts, obs.left_out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ D(h) cos theta_h dω_h = 1 (the projected area of the facets is the
    /// mean plane's), by quadrature in theta_h.
    #[test]
    fn distributions_are_normalised() {
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            for alpha in [0.1, 0.3, 0.8] {
                let n = 200_000;
                let mut s = 0.0;
                for k in 0..n {
                    let t = (k as f64 + 0.5) / n as f64 * std::f64::consts::FRAC_PI_2;
                    s += dist.d(alpha, t.cos()) * t.cos() * t.sin();
                }
                s *= 2.0 * std::f64::consts::PI * std::f64::consts::FRAC_PI_2 / n as f64;
                assert!((s - 1.0).abs() < 2e-3, "{dist:?} {alpha}: {s}");
            }
        }
    }

    /// Smith's Lambda satisfies the projected-area identity
    /// `cos theta (1 + Lambda) = ∫ max(0, w.h) D(h) dω_h` (Heitz 2014 eq.
    /// 43), by quadrature: an independent check of both closed forms.
    #[test]
    fn lambda_is_smiths() {
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            let alpha = 0.4;
            for theta in [0.3f64, 0.9, 1.3] {
                let w = DVec3::new(theta.sin(), 0.0, theta.cos());
                let (nt, np) = (1500, 256);
                let mut s = 0.0;
                for a in 0..nt {
                    let th = (a as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
                    for b in 0..np {
                        let ph = (b as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
                        let h = DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                        s += w.dot(h).max(0.0) * dist.d(alpha, h.z) * th.sin();
                    }
                }
                s *= std::f64::consts::FRAC_PI_2 / nt as f64 * 2.0 * std::f64::consts::PI
                    / np as f64;
                let want = theta.cos() * (1.0 + dist.lambda(alpha, theta.cos()));
                assert!(
                    (s / want - 1.0).abs() < 3e-3,
                    "{dist:?} {theta}: {s} vs {want}"
                );
            }
        }
    }

    #[test]
    fn reciprocal_and_white_furnace_bounded() {
        let m = Microfacet {
            distribution: Distribution::Ggx,
            material: Reflectance::Constant(1.0),
        };
        let wi = DVec3::new(0.5, 0.1, 0.75f64.sqrt()).normalize();
        let wo = DVec3::new(-0.3, 0.4, 0.8).normalize();
        assert!((m.eval(0.3, wi, wo) - m.eval(0.3, wo, wi)).abs() < 1e-12);
    }
}
