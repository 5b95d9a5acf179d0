//! Light sources of the macro level: parallel circular beams, each with a
//! polarisation state.

use glam::DVec3;

use crate::optics::polarisation::{Incident, hemisphere_reference};

/// A parallel beam of circular cross-section.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beam {
    /// A point on the beam axis where photons start (length units).
    pub position: DVec3,
    /// Unit direction of travel.
    pub direction: DVec3,
    /// Beam diameter (length units; 0 = a pencil beam).
    pub diameter: f64,
    /// Polarisation state of the light, about [`Beam::reference`].
    pub polarisation: Incident,
}

impl Beam {
    /// Start point of a photon: uniform over the beam's disc through
    /// `position`, perpendicular to the direction (`u`, `v` uniform in [0, 1)).
    #[must_use]
    pub fn start(&self, u: f64, v: f64) -> DVec3 {
        let (e1, e2) = self.direction.any_orthonormal_pair();
        let r = 0.5 * self.diameter * u.sqrt();
        let a = std::f64::consts::TAU * v;
        self.position + r * (a.cos() * e1 + a.sin() * e2)
    }

    /// The reference vector of the beam's Stokes vector (world coordinates):
    /// `hemisphere_reference(direction, 0)`, i.e. `normalize(ẑ × direction)`,
    /// and `+y` for a beam along `±z` (see [`crate::optics::polarisation`]).
    /// `"s"` light is linearly polarised along it.
    #[must_use]
    pub fn reference(&self) -> DVec3 {
        hemisphere_reference(self.direction, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_fill_the_disc_uniformly_and_stay_in_its_plane() {
        let beam = Beam {
            position: DVec3::new(1.0, 2.0, 3.0),
            direction: DVec3::new(0.0, 0.6, -0.8),
            diameter: 2.0,
            polarisation: Incident::Unpolarised,
        };
        let n = 200;
        let mut inner = 0;
        for i in 0..n {
            for j in 0..n {
                let p = beam.start((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let q = p - beam.position;
                assert!(q.dot(beam.direction).abs() < 1e-12);
                assert!(q.length() <= 1.0 + 1e-12);
                if q.length() < 0.5 {
                    inner += 1;
                }
            }
        }
        // A quarter of the area lies within half the radius (exact for this stratification).
        assert_eq!(inner, n * n / 4);
    }
}
