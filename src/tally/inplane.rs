//! Fine in-plane tally: a goniometer detector swept through the plane of
//! incidence.
//!
//! For incidence azimuth `phi_i` the incidence frame has axes
//! `u = (-cos phi_i, -sin phi_i, 0)` (horizontal, toward the specular side),
//! `v = z x u = (sin phi_i, -cos phi_i, 0)` and `z`. A unit direction with
//! components `(a, b, c)` in `(u, v, z)` has in-plane angle
//! `theta_p = atan2(a, c)` (positive on the specular side, negative toward
//! the light) and out-of-plane angle `psi = asin(b)`. Conversely
//! `dir = (cos psi sin theta_p, sin psi, cos psi cos theta_p)`, for which
//! `d omega = cos psi d psi d theta_p` and `cos theta = cos psi cos theta_p`.
//!
//! Bin `i` is centred on `theta_p = -90 + i step` degrees and covers
//! `[centre - step/2, centre + step/2)` clipped to `[-90, 90]`, for
//! `i = 0..=180/step`: the end bins are half bins. Centring bins on whole
//! multiples of the step puts the specular direction of a whole-degree
//! incidence angle at a bin centre (not on an edge) and matches measured
//! BRDFs, which are given at whole angles. Only directions with
//! `|psi| <= half_width` are accepted, so each bin is a `step x 2 half_width`
//! detector.

use crate::num::Num;
use glam::DVec3;

/// Tolerance on `180 / step_deg` being a whole number.
const WHOLE_TOLERANCE: f64 = 1e-9;

/// An in-plane goniometer tally for one incidence azimuth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InPlaneTally {
    /// Bin width in `theta_p` (degrees), snapped to exactly `180 / n_bins`.
    step_deg: f64,
    /// Half width of the detector out of the plane (degrees).
    half_width_deg: f64,
    /// Incidence azimuth (radians).
    phi_i: f64,
    /// Number of bins, `180 / step_deg + 1`.
    n_bins: usize,
    /// Horizontal unit vector toward the specular side.
    u: DVec3,
    /// `z x u`, the out-of-plane axis.
    v: DVec3,
    /// `|dir . v|` above which a direction is surely out of the detector:
    /// `1.000001 sin(half_width)`.
    reject_above: f64,
}

/// Most bins across the 180 degrees of the plane (a 0.01 degree step): a
/// bound on the memory of every batch tally (16 bytes per bin).
pub const MAX_BINS: usize = 18_000;

/// Why an in-plane detector full width (degrees) is refused
/// ([`InPlaneTally::width_error`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WidthError {
    /// Not in `(0, 180]`.
    #[error("must be in (0, 180], got {}", Num(*.0))]
    Range(f64),
    /// So small that its half rounds to 0.
    #[error("{0:e} is too small: its half rounds to 0 (at least 1e-323)")]
    TooSmall(f64),
}

impl InPlaneTally {
    /// Why [`InPlaneTally::new`] would refuse half of the detector full
    /// width `width_deg` (degrees), if it would: in `(0, 180]`, and its
    /// half a positive number (not below 1e-323).
    #[must_use]
    pub fn width_error(width_deg: f64) -> Option<WidthError> {
        let half = 0.5 * width_deg;
        if !(width_deg > 0.0 && width_deg <= 180.0) {
            Some(WidthError::Range(width_deg))
        } else if !(half > 0.0 && half <= 90.0) {
            Some(WidthError::TooSmall(width_deg))
        } else {
            None
        }
    }

    /// A tally with bins `step_deg` wide (degrees) in `theta_p`, accepting
    /// `|psi| <= half_width_deg` (degrees), for light at azimuth `phi_i_rad`
    /// (radians).
    ///
    /// Returns `None` unless `180 / step_deg` is a whole number (within
    /// 1e-9), `0 < half_width_deg <= 90` and `phi_i_rad` is finite.
    /// The usual detector is `new(1.0, 0.5, phi_i)`: 1 deg x 1 deg.
    #[must_use]
    pub fn new(step_deg: f64, half_width_deg: f64, phi_i_rad: f64) -> Option<Self> {
        let ratio = 180.0 / step_deg;
        let n = ratio.round();
        let valid = step_deg > 0.0
            && ratio.is_finite()
            && n >= 1.0
            && n <= MAX_BINS as f64
            && (ratio - n).abs() <= WHOLE_TOLERANCE
            && half_width_deg > 0.0
            && half_width_deg <= 90.0
            && phi_i_rad.is_finite();
        if !valid {
            return None;
        }
        let u = DVec3::new(-phi_i_rad.cos(), -phi_i_rad.sin(), 0.0);
        Some(Self {
            step_deg: 180.0 / n,
            half_width_deg,
            phi_i: phi_i_rad,
            n_bins: n as usize + 1,
            u,
            v: DVec3::Z.cross(u),
            reject_above: 1.000_001 * half_width_deg.to_radians().sin(),
        })
    }

    /// Bin width in `theta_p` (degrees).
    #[must_use]
    pub fn step_deg(&self) -> f64 {
        self.step_deg
    }

    /// Out-of-plane half width of the detector (degrees).
    #[must_use]
    pub fn half_width_deg(&self) -> f64 {
        self.half_width_deg
    }

    /// Incidence azimuth `phi_i` (radians).
    #[must_use]
    pub fn phi_i(&self) -> f64 {
        self.phi_i
    }

    /// Number of bins, `180 / step_deg + 1`.
    #[must_use]
    pub fn n_bins(&self) -> usize {
        self.n_bins
    }

    /// `(theta_p, psi)` of a unit direction, in degrees: in-plane angle
    /// (positive toward the specular side) and out-of-plane angle.
    #[must_use]
    pub fn in_plane_angles(&self, dir: DVec3) -> (f64, f64) {
        let theta_p = dir.dot(self.u).atan2(dir.z).to_degrees();
        let psi = dir.dot(self.v).clamp(-1.0, 1.0).asin().to_degrees();
        (theta_p, psi)
    }

    /// Bin of the unit direction `dir`, or `None` if it is below or on the
    /// horizon (`dir.z <= 0`), non-finite, or outside the detector
    /// (`|psi| > half_width_deg`).
    #[must_use]
    pub fn locate(&self, dir: DVec3) -> Option<usize> {
        if !dir.is_finite() || dir.z <= 0.0 {
            return None;
        }
        // Cheap rejection of directions clearly out of the detector (most of
        // them) before the trigonometry; the exact test follows.
        let s = dir.dot(self.v).abs();
        if s > self.reject_above {
            return None;
        }
        let (theta_p, psi) = self.in_plane_angles(dir);
        if psi.abs() > self.half_width_deg {
            return None;
        }
        let bin = ((theta_p + 90.0) / self.step_deg + 0.5).floor().max(0.0) as usize;
        Some(bin.min(self.n_bins - 1))
    }

    /// `(lo, hi)` edges of `bin` in `theta_p` (degrees).
    ///
    /// # Panics
    /// If `bin >= self.n_bins()`.
    #[must_use]
    pub fn edges_deg(&self, bin: usize) -> (f64, f64) {
        assert!(bin < self.n_bins, "InPlaneTally: bin {bin} out of range");
        let centre = -90.0 + bin as f64 * self.step_deg;
        let half = 0.5 * self.step_deg;
        ((centre - half).max(-90.0), (centre + half).min(90.0))
    }

    /// Signed centre of `bin` (degrees): `theta_o`, positive on the
    /// specular side; `-90 + bin step`, except the half bins at the ends
    /// whose centres are `±(90 - step/4)`.
    ///
    /// # Panics
    /// If `bin >= self.n_bins()`.
    #[must_use]
    pub fn centre_deg(&self, bin: usize) -> f64 {
        let (lo, hi) = self.edges_deg(bin);
        0.5 * (lo + hi)
    }

    /// Solid angle of `bin` (sr): `2 sin(psi_w) (tp_hi - tp_lo)`, angles in
    /// radians, `psi_w` the half width.
    ///
    /// # Panics
    /// If `bin >= self.n_bins()`.
    #[must_use]
    pub fn solid_angle(&self, bin: usize) -> f64 {
        let (lo, hi) = self.edges_deg(bin);
        let psi_w = self.half_width_deg.to_radians();
        2.0 * psi_w.sin() * (hi.to_radians() - lo.to_radians())
    }

    /// Projected solid angle of `bin` (sr), the exact integral of
    /// `cos(theta) d omega` over it:
    /// `(psi_w + sin(2 psi_w) / 2) (sin tp_hi - sin tp_lo)`.
    ///
    /// # Panics
    /// If `bin >= self.n_bins()`.
    #[must_use]
    pub fn projected_solid_angle(&self, bin: usize) -> f64 {
        let (lo, hi) = self.edges_deg(bin);
        let psi_w = self.half_width_deg.to_radians();
        (psi_w + (2.0 * psi_w).sin() / 2.0) * (hi.to_radians().sin() - lo.to_radians().sin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;
    use std::f64::consts::{PI, TAU};

    /// Direction with in-plane angle `tp` and out-of-plane angle `psi`
    /// (degrees), built from the tally's own axes.
    fn dir_at(t: &InPlaneTally, tp: f64, psi: f64) -> DVec3 {
        let (tp, psi) = (tp.to_radians(), psi.to_radians());
        psi.cos() * tp.sin() * t.u + psi.sin() * t.v + psi.cos() * tp.cos() * DVec3::Z
    }

    fn polar(theta: f64, phi: f64) -> DVec3 {
        DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    #[test]
    fn constructor_validation() {
        assert_eq!(InPlaneTally::new(1.0, 0.5, 0.0).unwrap().n_bins(), 181);
        assert_eq!(InPlaneTally::new(0.1, 0.5, 0.0).unwrap().n_bins(), 1801);
        assert_eq!(
            InPlaneTally::new(180.0 / 7.0, 0.5, 0.0).unwrap().n_bins(),
            8
        );
        assert_eq!(InPlaneTally::new(180.0, 90.0, 0.0).unwrap().n_bins(), 2);
        assert!(InPlaneTally::new(0.7, 0.5, 0.0).is_none());
        assert!(InPlaneTally::new(0.0, 0.5, 0.0).is_none());
        assert!(InPlaneTally::new(-1.0, 0.5, 0.0).is_none());
        assert!(InPlaneTally::new(200.0, 0.5, 0.0).is_none());
        assert!(InPlaneTally::new(f64::NAN, 0.5, 0.0).is_none());
        assert!(InPlaneTally::new(1.0, 0.0, 0.0).is_none());
        assert!(InPlaneTally::new(1.0, 90.1, 0.0).is_none());
        assert!(InPlaneTally::new(1.0, 0.5, f64::NAN).is_none());
    }

    #[test]
    fn frame_axes() {
        let phi = 0.3_f64;
        let t = InPlaneTally::new(1.0, 0.5, phi).unwrap();
        assert!((t.u - DVec3::new(-phi.cos(), -phi.sin(), 0.0)).length() < 1e-15);
        assert!((t.v - DVec3::new(phi.sin(), -phi.cos(), 0.0)).length() < 1e-15);
        assert!((t.v - DVec3::Z.cross(t.u)).length() < 1e-15);
    }

    #[test]
    fn centres_and_edges() {
        let t = InPlaneTally::new(1.0, 0.5, 0.0).unwrap();
        // Whole-degree centres; half bins at the ends.
        assert_eq!(t.centre_deg(0), -89.75);
        assert_eq!(t.edges_deg(0), (-90.0, -89.5));
        assert_eq!(t.centre_deg(130), 40.0);
        assert_eq!(t.centre_deg(180), 89.75);
        assert_eq!(t.edges_deg(180), (89.5, 90.0));
        assert_eq!(t.edges_deg(130), (39.5, 40.5));
    }

    #[test]
    fn locate_bin_centres() {
        for (step, phi_i) in [(1.0, 0.0), (1.0, 0.3), (0.25, 2.0), (5.0, 5.5)] {
            let t = InPlaneTally::new(step, 0.5, phi_i).unwrap();
            for bin in 0..t.n_bins() {
                let c = t.centre_deg(bin);
                assert_eq!(t.locate(dir_at(&t, c, 0.0)), Some(bin));
                assert_eq!(t.locate(dir_at(&t, c, 0.49)), Some(bin));
                assert_eq!(t.locate(dir_at(&t, c, -0.49)), Some(bin));
                assert_eq!(t.locate(dir_at(&t, c, 0.51)), None);
                assert_eq!(t.locate(dir_at(&t, c, -0.51)), None);
            }
        }
    }

    #[test]
    fn locate_rejects_horizon_and_non_finite() {
        let t = InPlaneTally::new(1.0, 0.5, 0.3).unwrap();
        assert_eq!(t.locate(t.u), None);
        assert_eq!(t.locate(-DVec3::Z), None);
        assert_eq!(t.locate(DVec3::new(f64::NAN, 0.0, 1.0)), None);
        assert_eq!(t.locate(DVec3::Z), Some(90));
    }

    #[test]
    fn specular_and_light_sides() {
        let phi_i = 0.3_f64;
        let t = InPlaneTally::new(1.0, 0.5, phi_i).unwrap();

        // The exact specular direction of theta_i = 40 deg has theta_p = 40.
        let omega_i = polar(40f64.to_radians(), phi_i);
        let specular = DVec3::new(-omega_i.x, -omega_i.y, omega_i.z);
        let (tp, psi) = t.in_plane_angles(specular);
        assert!((tp - 40.0).abs() < 1e-12 && psi.abs() < 1e-12);
        let (tp, psi) = t.in_plane_angles(omega_i);
        assert!((tp + 40.0).abs() < 1e-12 && psi.abs() < 1e-12);

        // The specular direction itself lands at the centre of bin [39.5, 40.5].
        let bin = t.locate(specular).unwrap();
        assert_eq!(t.edges_deg(bin), (39.5, 40.5));
        assert_eq!(t.centre_deg(bin), 40.0);

        // Toward the light at theta = 40 deg lands in bin [-40.5, -39.5].
        let back = polar(40f64.to_radians(), phi_i);
        let bin = t.locate(back).unwrap();
        assert_eq!(t.edges_deg(bin), (-40.5, -39.5));
        assert_eq!(t.centre_deg(bin), -40.0);

        // Rotating the forward direction about the normal by dphi moves it
        // out of plane by psi = asin(sin(theta) sin(dphi)).
        let theta = 40f64.to_radians();
        let off_plane = |psi_deg: f64| {
            let dphi = (psi_deg.to_radians().sin() / theta.sin()).asin();
            polar(theta, phi_i + PI + dphi)
        };
        assert_eq!(t.locate(off_plane(0.4)), Some(130));
        assert_eq!(t.locate(off_plane(-0.4)), Some(130));
        assert_eq!(t.locate(off_plane(0.6)), None);
        assert_eq!(t.locate(off_plane(-0.6)), None);
    }

    #[test]
    fn solid_angle_formulas() {
        let t = InPlaneTally::new(1.0, 0.5, 0.0).unwrap();
        let w = 0.5f64.to_radians();
        let (lo, hi) = (39.5f64.to_radians(), 40.5f64.to_radians());
        let proj = (w + (2.0 * w).sin() / 2.0) * (hi.sin() - lo.sin());
        assert!((t.projected_solid_angle(130) - proj).abs() < 1e-18);
        let omega = 2.0 * w.sin() * (hi - lo);
        assert!((t.solid_angle(130) - omega).abs() < 1e-18);
    }

    #[test]
    fn full_width_sums_to_hemisphere() {
        // With half width 90 deg the bins tile the hemisphere.
        let t = InPlaneTally::new(2.0, 90.0, 1.0).unwrap();
        let proj: f64 = (0..t.n_bins()).map(|b| t.projected_solid_angle(b)).sum();
        let omega: f64 = (0..t.n_bins()).map(|b| t.solid_angle(b)).sum();
        assert!((proj - PI).abs() < 1e-13, "{proj}");
        assert!((omega - TAU).abs() < 1e-13, "{omega}");
    }

    /// Brute force: midpoint rule for `∫ cos(theta) dω` over the bin, with
    /// `dω = |∂d/∂tp × ∂d/∂psi| dtp dpsi` from finite differences of the
    /// direction map itself, so neither the Jacobian nor `cos(theta)` is
    /// taken from the closed form.
    #[test]
    fn projected_solid_angle_matches_quadrature() {
        for (step, half_width, bin) in [
            (1.0, 0.5, 130),
            (1.0, 0.5, 0),
            (5.0, 10.0, 20),
            (6.0, 60.0, 2),
        ] {
            let t = InPlaneTally::new(step, half_width, 0.7).unwrap();
            let (lo, hi) = t.edges_deg(bin);
            let n = 200;
            let h = 1e-5;
            let (mut proj, mut omega) = (0.0, 0.0);
            for i in 0..n {
                let tp = lo + (hi - lo) * (i as f64 + 0.5) / n as f64;
                for j in 0..n {
                    let psi = -half_width + 2.0 * half_width * (j as f64 + 0.5) / n as f64;
                    let d = dir_at(&t, tp, psi);
                    let d_tp = (dir_at(&t, tp + h, psi) - dir_at(&t, tp - h, psi)) / (2.0 * h);
                    let d_psi = (dir_at(&t, tp, psi + h) - dir_at(&t, tp, psi - h)) / (2.0 * h);
                    // Derivatives are per degree; the cell is in degrees too.
                    let jac = d_tp.cross(d_psi).length();
                    let area = (hi - lo) / n as f64 * (2.0 * half_width) / n as f64;
                    proj += d.z * jac * area;
                    omega += jac * area;
                }
            }
            let p = t.projected_solid_angle(bin);
            let s = t.solid_angle(bin);
            // Midpoint error is ~1e-6 relative for the widest cell; a wrong
            // psi factor (e.g. 2 psi_w) would be off by >= 1e-4 even at 0.5 deg.
            assert!((proj - p).abs() < 1e-5 * p, "proj {proj} vs {p}");
            assert!((omega - s).abs() < 1e-5 * s, "omega {omega} vs {s}");
        }
    }

    fn cosine_fractions(t: &InPlaneTally, n: u64, seed: u64) {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut counts = vec![0u64; t.n_bins()];
        for _ in 0..n {
            let mu = rng.random::<f64>().sqrt();
            let phi = TAU * rng.random::<f64>();
            let s = (1.0 - mu * mu).sqrt();
            if let Some(bin) = t.locate(DVec3::new(s * phi.cos(), s * phi.sin(), mu)) {
                counts[bin] += 1;
            }
        }
        for (bin, &count) in counts.iter().enumerate() {
            let p = t.projected_solid_angle(bin) / PI;
            let frac = count as f64 / n as f64;
            let sigma = (p * (1.0 - p) / n as f64).sqrt();
            assert!(
                (frac - p).abs() < 4.0 * sigma,
                "bin {bin}: {frac} vs {p} (sigma {sigma})"
            );
        }
    }

    #[test]
    fn cosine_sample_fractions_default_detector() {
        cosine_fractions(&InPlaneTally::new(1.0, 0.5, 0.3).unwrap(), 2_000_000, 42);
    }

    #[test]
    fn cosine_sample_fractions_wide_detector() {
        cosine_fractions(&InPlaneTally::new(5.0, 10.0, 4.0).unwrap(), 400_000, 7);
    }
}
