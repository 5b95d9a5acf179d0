//! Polarisation in geometric optics: Stokes vectors, Mueller matrices, the
//! Fresnel reflection of a smooth interface as a Mueller matrix, and the
//! reference frames Stokes vectors are expressed in.
//!
//! # Conventions (Mitsuba 3's, `include/mitsuba/render/mueller.h`)
//!
//! * A Stokes vector `S = (S0, S1, S2, S3)` (intensity, linear 0/90, linear
//!   ±45, circular) is only meaningful with its **reference vector** `x`: a
//!   unit vector perpendicular to the direction of flight `d`. `S1 > 0` is
//!   light linearly polarised along `x`; the frame's second axis is
//!   `y = d × x`, so `(x, y, d)` is right-handed and `S2 > 0` is light
//!   polarised along `(x + y)/√2`. `S3 > 0` is right circular as Mitsuba
//!   defines it (its `right_circular_polarizer` passes `(1, 0, 0, 1)`; the
//!   ellipse is seen by the sensor looking back along the beam).
//! * Changing the reference vector from `x` to `x'` (both ⟂ `d`) by the angle
//!   `a` (positive when `d · (x × x') > 0`, counter-clockwise about `d`)
//!   applies the rotator `[[1,0,0,0],[0,C,S,0],[0,-S,C,0],[0,0,0,1]]`,
//!   `C = cos 2a`, `S = sin 2a` ([`rotate`]; Mitsuba's
//!   `rotate_stokes_basis`). The sign of `x` does not matter (a half turn is
//!   the identity on Stokes vectors).
//! * **Specular reflection** at a facet with unit normal `n` (facing the
//!   photon): the s axis is `s = normalize(n × d_in)` (Mitsuba's
//!   `cross(n, -wo)`), perpendicular to the plane of incidence and shared by
//!   the incoming and outgoing flights. In the s frames the Fresnel Mueller
//!   matrix is ([`FresnelMueller`](super::fresnel::FresnelMueller))
//!
//!   ```text
//!   M = [[a, b, 0, 0], [b, a, 0, 0], [0, 0, c, -d], [0, 0, d, c]]
//!   a = (Rs + Rp)/2, b = (Rs - Rp)/2, c + i d = rs rp*
//!   ```
//!
//!   with the amplitudes `rs = (cos θ - m cos θt)/(cos θ + m cos θt)`,
//!   `rp = (m cos θ - cos θt)/(m cos θ + cos θt)` (the Verdet sign of `rp`:
//!   `rp = -rs` at normal incidence), `m = n + i k`, `m cos θt` the principal
//!   root of `m² - sin² θ` (a wave decaying into the medium). Mitsuba writes
//!   the same matrix as `c = sqrt(Rs Rp) cos δ`, `d = sqrt(Rs Rp) sin δ`,
//!   `δ = arg(a_p) - arg(a_s)` with its amplitudes for `n - i k` (the
//!   complex conjugates of ours). Azzam & Bashara's form with the opposite
//!   handedness is the transpose (the sign of the `c, d` block's
//!   off-diagonal flips). At normal incidence the plane of incidence is
//!   undefined and any s axis gives the same result: the photon's own
//!   reference vector is kept. At grazing incidence `M` is the identity.
//! * **Frames of directions on the hemisphere** (tallies, incident states):
//!   the reference vector of a flight `d` is `normalize(ẑ × d)` (the s axis
//!   of the mean plane, `e_phi` of `d` for upward flights), and for `d` along
//!   `±ẑ` the azimuthal unit vector of the pole azimuth `(-sin φ, cos φ, 0)`
//!   ([`hemisphere_reference`]). For the light arriving along `-omega_i` of a
//!   micro scene this is the s direction of the plane of incidence (the pole
//!   azimuth is `phi_i`), so `"s"` light is `(1, 1, 0, 0)` there.
//!
//! A Mueller matrix `m[i][j]` maps incident Stokes component `j` to outgoing
//! component `i` (row index first).

use glam::DVec3;

/// A Stokes vector `(S0, S1, S2, S3)` (intensity units of the carrier).
pub type Stokes = [f64; 4];

/// A 4 x 4 Mueller matrix, `m[row][column]`.
pub type Mueller = [[f64; 4]; 4];

/// Unpolarised light of unit intensity.
pub const UNPOLARISED: Stokes = [1.0, 0.0, 0.0, 0.0];

/// `(cos 2a, sin 2a)` of the angle `a` that turns reference vector `from`
/// into `to` about the direction of flight `forward` (all unit, `from` and
/// `to` perpendicular to `forward`); positive counter-clockwise about
/// `forward` (Mitsuba's `rotate_stokes_basis`).
#[must_use]
#[inline]
pub fn rotation(forward: DVec3, from: DVec3, to: DVec3) -> (f64, f64) {
    let c = from.dot(to);
    let s = forward.dot(from.cross(to));
    let r2 = c * c + s * s;
    if r2 > 0.0 {
        ((c * c - s * s) / r2, 2.0 * s * c / r2)
    } else {
        (1.0, 0.0)
    }
}

/// Apply the rotator `(cos 2a, sin 2a)` of [`rotation`] to a Stokes vector.
#[must_use]
#[inline]
pub fn rotate(s: Stokes, (c2, s2): (f64, f64)) -> Stokes {
    [s[0], c2 * s[1] + s2 * s[2], -s2 * s[1] + c2 * s[2], s[3]]
}

/// Reference vector of a flight along unit `d` in the hemisphere frame:
/// `normalize(ẑ × d)`, or `(-sin φ, cos φ, 0)` of the pole azimuth
/// `pole_phi` (radians) when `d` is along `±ẑ` (see the module docs).
#[must_use]
pub fn hemisphere_reference(d: DVec3, pole_phi: f64) -> DVec3 {
    let r2 = d.x * d.x + d.y * d.y;
    if r2 > 1e-280 {
        let r = r2.sqrt();
        DVec3::new(-d.y / r, d.x / r, 0.0)
    } else {
        DVec3::new(-pole_phi.sin(), pole_phi.cos(), 0.0)
    }
}

/// A polarisation state of incident light, as written in scene files
/// (`[light] polarisation`, `[[sources]] polarisation`). In a run's
/// description ([`crate::transport::brdf::BrdfRun`]) it is written as the
/// scene writes it: `"unpolarised"`, `"s"`, `"p"`, `"right"`, `"left"`,
/// `{"linear": deg}` or `{"stokes": [S0, S1, S2, S3]}`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Incident {
    /// Natural light `(1, 0, 0, 0)` (the default).
    Unpolarised,
    /// Linear along the reference vector (s for a micro scene): `(1, 1, 0, 0)`.
    S,
    /// Linear across it (p for a micro scene): `(1, -1, 0, 0)`.
    P,
    /// Linear at `angle_deg` from the reference vector toward `y = d × x`:
    /// `(1, cos 2a, sin 2a, 0)`.
    Linear(f64),
    /// Right circular, `(1, 0, 0, 1)`.
    Right,
    /// Left circular, `(1, 0, 0, -1)`.
    Left,
    /// A given Stokes vector (normalised to `S0 = 1` by [`Incident::stokes`]).
    Stokes(Stokes),
}

/// Why a given incident polarisation state is refused ([`Incident::validate`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum IncidentError {
    /// A Stokes vector that is not finite, or has `S0 <= 0`.
    #[error("Stokes vector {0:?} must be finite with S0 > 0")]
    Stokes([f64; 4]),
    /// A Stokes vector polarised more than fully.
    #[error("Stokes vector {stokes:?} has a degree of polarisation {degree} > 1")]
    Degree {
        /// The vector.
        stokes: [f64; 4],
        /// Its degree of polarisation.
        degree: f64,
    },
    /// A linear polarisation angle that is not finite (degrees).
    #[error("linear polarisation angle {0} is not finite")]
    Angle(f64),
}

impl Incident {
    /// The Stokes vector of unit intensity.
    #[must_use]
    pub fn stokes(&self) -> Stokes {
        match *self {
            Self::Unpolarised => UNPOLARISED,
            Self::S => [1.0, 1.0, 0.0, 0.0],
            Self::P => [1.0, -1.0, 0.0, 0.0],
            Self::Linear(deg) => {
                // Exact at multiples of 45 deg (0, ±1): `sin(2 * 90 deg)` in
                // floating point is 1.2e-16, not the 0 of p light, which
                // would e.g. make linear 90 deg look mirror-asymmetric.
                // Reduced before doubling (exactly: both steps are exact),
                // so that a huge angle (1e308) does not overflow to NaN.
                let twice = 2.0 * deg.rem_euclid(180.0);
                if twice == 0.0 {
                    [1.0, 1.0, 0.0, 0.0]
                } else if twice == 90.0 {
                    [1.0, 0.0, 1.0, 0.0]
                } else if twice == 180.0 {
                    [1.0, -1.0, 0.0, 0.0]
                } else if twice == 270.0 {
                    [1.0, 0.0, -1.0, 0.0]
                } else {
                    let a = twice.to_radians();
                    [1.0, a.cos(), a.sin(), 0.0]
                }
            }
            Self::Right => [1.0, 0.0, 0.0, 1.0],
            Self::Left => [1.0, 0.0, 0.0, -1.0],
            Self::Stokes(s) => [1.0, s[1] / s[0], s[2] / s[0], s[3] / s[0]],
        }
    }

    /// Whether a mirror reflection in the plane of incidence maps the state
    /// to itself (`S2 = S3 = 0`).
    #[must_use]
    pub fn is_mirror_symmetric(&self) -> bool {
        let s = self.stokes();
        s[2] == 0.0 && s[3] == 0.0
    }

    /// Checks a given Stokes vector: finite, `S0 > 0`, degree of
    /// polarisation at most 1 (to 1e-12).
    ///
    /// # Errors
    /// The reason, as an [`IncidentError`].
    pub fn validate(&self) -> Result<(), IncidentError> {
        match *self {
            Self::Stokes(s) => {
                if !s.iter().all(|x| x.is_finite()) || s[0] <= 0.0 {
                    return Err(IncidentError::Stokes(s));
                }
                let p2 = s[1] * s[1] + s[2] * s[2] + s[3] * s[3];
                if p2 > s[0] * s[0] * (1.0 + 1e-12) {
                    return Err(IncidentError::Degree {
                        stokes: s,
                        degree: p2.sqrt() / s[0],
                    });
                }
                Ok(())
            }
            Self::Linear(a) if !a.is_finite() => Err(IncidentError::Angle(a)),
            _ => Ok(()),
        }
    }

    /// A short name for summaries: `unpolarised`, `s`, `p`, `linear 30 deg`,
    /// `right`, `left`, or the Stokes vector.
    #[must_use]
    pub fn name(&self) -> String {
        match *self {
            Self::Unpolarised => "unpolarised".into(),
            Self::S => "s".into(),
            Self::P => "p".into(),
            Self::Linear(a) => format!("linear {a} deg"),
            Self::Right => "right".into(),
            Self::Left => "left".into(),
            Self::Stokes(s) => format!("stokes {s:?}"),
        }
    }
}

/// Degree of polarisation `sqrt(S1² + S2² + S3²) / S0` (0 for `S0 <= 0`).
#[must_use]
pub fn degree_of_polarisation(s: Stokes) -> f64 {
    if s[0] > 0.0 {
        (s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt() / s[0]
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn rotation_follows_mitsuba_docstring() {
        // Horizontal light in basis x reads as +45 deg linear in basis (1,-1,0)/√2.
        let to = DVec3::new(1.0, -1.0, 0.0).normalize();
        let r = rotation(DVec3::Z, DVec3::X, to);
        let s = rotate([1.0, 1.0, 0.0, 0.0], r);
        assert!(close(s[1], 0.0, 1e-15) && close(s[2], 1.0, 1e-15));
        // A half turn is the identity.
        let r = rotation(DVec3::Z, DVec3::X, -DVec3::X);
        assert_eq!(rotate([1.0, 0.3, -0.2, 0.1], r), [1.0, 0.3, -0.2, 0.1]);
    }

    #[test]
    fn hemisphere_reference_is_perpendicular_and_s_like() {
        let d = DVec3::new(0.3, -0.4, 0.5).normalize();
        let x = hemisphere_reference(d, 0.0);
        assert!(x.dot(d).abs() < 1e-15 && (x.length() - 1.0).abs() < 1e-15 && x.z == 0.0);
        assert_eq!(hemisphere_reference(DVec3::Z, 0.0), DVec3::Y);
        let x = hemisphere_reference(-DVec3::Z, std::f64::consts::FRAC_PI_2);
        assert!(close(x.x, -1.0, 1e-15) && x.y.abs() < 1e-15);
    }

    #[test]
    fn incident_states() {
        assert_eq!(Incident::S.stokes(), [1.0, 1.0, 0.0, 0.0]);
        let l = Incident::Linear(45.0).stokes();
        assert!(close(l[1], 0.0, 1e-15) && close(l[2], 1.0, 1e-15));
        // Multiples of 45 deg are exact, so 0 and 90 deg keep the mirror symmetry.
        assert_eq!(Incident::Linear(90.0).stokes(), Incident::P.stokes());
        assert_eq!(Incident::Linear(-45.0).stokes(), [1.0, 0.0, -1.0, 0.0]);
        assert_eq!(Incident::Linear(180.0).stokes(), Incident::S.stokes());
        assert!(Incident::Linear(90.0).is_mirror_symmetric());
        let l = Incident::Linear(30.0).stokes();
        assert!(close(l[1], 0.5, 1e-15) && close(l[2], 0.75f64.sqrt(), 1e-15));
        assert_eq!(
            Incident::Stokes([2.0, 1.0, 0.0, 0.0]).stokes(),
            [1.0, 0.5, 0.0, 0.0]
        );
        assert!(Incident::Stokes([1.0, 1.0, 1.0, 0.0]).validate().is_err());
        assert!(Incident::Stokes([0.0, 0.0, 0.0, 0.0]).validate().is_err());
        assert!(Incident::Stokes([1.0, 0.6, 0.8, 0.0]).validate().is_ok());
        assert!(Incident::P.is_mirror_symmetric() && !Incident::Right.is_mirror_symmetric());
        // Huge angles are reduced modulo 180 deg before doubling (2 x 1e308
        // overflowed to a NaN state, found by fuzzing); 1e308 deg is
        // 1e308 mod 180 deg, exactly, and the state is fully polarised.
        for a in [1e308, -1e308, f64::MAX, 1e20] {
            let l = Incident::Linear(a).stokes();
            assert_eq!(l, Incident::Linear(a.rem_euclid(180.0)).stokes(), "{a}");
            assert!(close(l[1].hypot(l[2]), 1.0, 1e-15), "{a}: {l:?}");
        }
        assert_eq!(
            Incident::Linear(180.0 * 2f64.powi(60)).stokes(),
            Incident::S.stokes()
        );
    }
}
