//! Reuse of the mirror symmetry of the plane of incidence.
//!
//! When the surface *statistics* are unchanged by reflection in the plane of
//! incidence (populations of axis-aligned bumps at azimuth 0 or 90 degrees,
//! such as the default scene; surfaces without a preferred direction), the
//! BRDF is symmetric under that reflection,
//! `f(theta, phi_i + a) = f(theta, phi_i - a)`.
//!
//! A Gaussian height field is not such a surface at every azimuth: its
//! random heights are isotropic, but every grid square is cut into
//! triangles along the same diagonal, from `(i, j)` to `(i + 1, j + 1)`
//! ([`crate::micro::heightfield`]). On a square cell with a square grid
//! (`Lx = Ly`, `nx = ny`) the ensemble of fields (`[surface] realisations`)
//! is therefore mirror symmetric about the two diagonal planes only, light
//! azimuths 45, 135, 225 and 315 degrees, not about the axis planes (0 and
//! 90 degrees: chi^2/dof of the mirror pairs 1.8 with 64 realisations in
//! `tests/realisations.rs`, which checks the symmetry at 45 degrees);
//! otherwise about no plane. At any azimuth and on any grid it is symmetric
//! under a half turn, `f(phi_i, phi) = f(phi_i + 180, phi + 180)`
//! (`tests/azimuths.rs` at 30 and 210 degrees), which the mirror fold does
//! not use. With
//! [`Symmetry::Mirror`] every escaping photon is scored half in its own
//! direction and half in its mirror image (once, with its full weight, when
//! both fall in the same cell). Each cell then sees the photons of its
//! mirror region too: an unbiased estimate of the symmetrised BRDF, with
//! half the variance off the plane of incidence for a symmetric BRDF. The
//! reflectance, the in-plane tally (its detector is symmetric) and the
//! bounce statistics are unchanged.
//!
//! For a single realisation of a random surface the symmetrised BRDF differs
//! from the unsymmetrised one by the realisation's own asymmetry; it is the
//! better estimate of the ensemble's BRDF, and it is what plane-symmetric
//! formats (the Zemax export) store anyway. Do not use it for surfaces whose
//! statistics are not mirror symmetric (tilted grooves, oriented bumps at an
//! oblique azimuth).

use glam::DVec3;

/// Whether the tallies fold mirror images in the plane of incidence
/// (`[tally] symmetry`, `--symmetry`: the names in lower case).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Symmetry {
    /// Score every photon in its own direction only.
    #[default]
    #[value(help = None::<&str>)]
    None,
    /// Score half in its own direction and half in its mirror image.
    #[value(help = None::<&str>)]
    Mirror,
}

/// The mirror image of `dir` in the vertical plane at azimuth `phi` (radians):
/// the plane of incidence for light at azimuth `phi`.
#[must_use]
#[inline]
pub fn mirror(dir: DVec3, phi: f64) -> DVec3 {
    mirror_at(dir, phi.sin_cos())
}

/// [`mirror`] with `(sin phi, cos phi)` given (once per run, not per photon).
#[must_use]
#[inline]
pub fn mirror_at(dir: DVec3, (s, c): (f64, f64)) -> DVec3 {
    // Unit normal of the plane: (-sin phi, cos phi, 0).
    let along = -dir.x * s + dir.y * c;
    DVec3::new(dir.x + 2.0 * along * s, dir.y - 2.0 * along * c, dir.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_values_are_the_scene_and_file_names() {
        use clap::ValueEnum as _;
        for v in Symmetry::value_variants() {
            let name = v.to_possible_value().unwrap().get_name().to_owned();
            assert_eq!(serde_json::to_value(v).unwrap(), name.as_str());
            assert_eq!(serde_json::from_value::<Symmetry>(name.into()).unwrap(), *v);
        }
        assert_eq!(Symmetry::value_variants().len(), 2);
        assert!(serde_json::from_value::<Symmetry>("nonsense".into()).is_err());
    }

    #[test]
    fn mirror_flips_the_side_of_the_plane_and_keeps_the_plane() {
        let d = DVec3::new(0.3, 0.4, 0.866_025_403_784_438_6);
        // Plane x-z (azimuth 0): y changes sign.
        let m = mirror(d, 0.0);
        assert_eq!(m, DVec3::new(0.3, -0.4, d.z));
        // Plane y-z (azimuth 90 degrees): x changes sign.
        let m = mirror(d, std::f64::consts::FRAC_PI_2);
        assert!((m - DVec3::new(-0.3, 0.4, d.z)).length() < 1e-15);
        // A direction in the plane stays; mirroring twice is the identity;
        // the length is kept.
        let phi = 0.7_f64;
        let inplane = DVec3::new(0.5 * phi.cos(), 0.5 * phi.sin(), 0.75_f64.sqrt());
        assert!((mirror(inplane, phi) - inplane).length() < 1e-15);
        assert!((mirror(mirror(d, phi), phi) - d).length() < 1e-15);
        assert!((mirror(d, phi).length() - d.length()).abs() < 1e-15);
        // The azimuth is reflected: 2 phi - atan2(y, x).
        let m = mirror(d, phi);
        let expect = 2.0 * phi - d.y.atan2(d.x);
        let got = m.y.atan2(m.x);
        let diff = (got - expect).rem_euclid(std::f64::consts::TAU);
        assert!(
            diff.min(std::f64::consts::TAU - diff) < 1e-14,
            "{got} vs {expect}"
        );
    }
}
