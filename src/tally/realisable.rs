//! Physical realisability of summed polarisation tallies, checked when
//! `roks merge` reads a shard: every history scores a realisable Stokes
//! vector (or Mueller matrix) into a cell, and realisable ones form a convex
//! cone, so each cell's sum must be realisable too, and its intensity must
//! be the Carlson sum of the same cell. A cell's Mueller matrix, summed or
//! read from `mueller.csv`, is checked by [`unrealisable`].

use super::{Accumulator, PolarTallies};

/// Relative tolerance of the Stokes and Carlson checks: the sums are of the
/// same scores in one order, differing only by rounding (about 1e-16 per
/// addition), far below 1e-9.
pub const SUM_TOLERANCE: f64 = 1e-9;

/// Relative tolerance of [`unrealisable`]: a cell's Mueller matrix may miss
/// the cone of physical outputs by this fraction of the sum of its
/// absolute elements. A Monte Carlo tally is a sum of the realisable
/// matrices of single paths (Fresnel reflections between frame rotations),
/// and realisable matrices form a convex cone, so the tallied matrix is
/// realisable exactly; only the text's rounding (10 significant digits in
/// `mueller.csv`, relative 5e-10 per element) moves it, far below 1e-6.
pub const REALISABLE_TOLERANCE: f64 = 1e-6;

/// Pure input states (unit Stokes vectors, `S0 = 1` left out) at which
/// [`unrealisable`] probes a Mueller matrix: the six axis states (s, p,
/// +-45 deg, right, left) and 250 points of a Fibonacci lattice on the
/// Poincaré sphere.
fn probe_states() -> impl Iterator<Item = [f64; 3]> {
    const LATTICE: usize = 250;
    let axes = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let golden = std::f64::consts::PI * (3.0 - 5.0_f64.sqrt());
    let lattice = (0..LATTICE).map(move |k| {
        let z = 1.0 - (2.0 * k as f64 + 1.0) / LATTICE as f64;
        let r = (1.0 - z * z).sqrt();
        let a = golden * k as f64;
        [r * a.cos(), r * a.sin(), z]
    });
    axes.into_iter().chain(lattice)
}

/// Why `m`, a cell's Mueller-matrix BRDF (row-major, `m[4 i + j]` =
/// `m_ij`), cannot be that of a physical surface, or `None`. Checked, each
/// within [`REALISABLE_TOLERANCE`] of the sum of `|m_ij|`:
/// `m00 >= 0`; for unpolarised input the output's degree of polarisation
/// at most 1, `sqrt(m10² + m20² + m30²) <= m00`; and the same for the
/// output `S = M (1, s)` of every pure input state `s` of a probe set (the
/// six axis states and a 250-point Fibonacci lattice on the Poincaré
/// sphere): `S0 >= sqrt(S1² + S2² + S3²)`. The exact condition is this for
/// every `s` on the sphere (Givens & Kostinski's); the probes are a
/// sampled necessary condition, catching any violation wider than the
/// lattice spacing (about 0.22 rad).
#[must_use]
pub fn unrealisable(m: &[f64; 16]) -> Option<String> {
    let tol = REALISABLE_TOLERANCE * m.iter().map(|v| v.abs()).sum::<f64>();
    if m.iter().any(|v| !v.is_finite()) {
        return Some("a Mueller element is not finite".into());
    }
    if m[0] < -tol {
        return Some(format!("m00 = {} < 0", m[0]));
    }
    let out = |s: [f64; 3]| -> [f64; 4] {
        std::array::from_fn(|i| {
            m[4 * i] + m[4 * i + 1] * s[0] + m[4 * i + 2] * s[1] + m[4 * i + 3] * s[2]
        })
    };
    let dop_check = |state: &str, o: [f64; 4]| {
        let pol = (o[1] * o[1] + o[2] * o[2] + o[3] * o[3]).sqrt();
        (o[0] + tol < pol).then(|| {
            format!(
                "the output of {state} has S0 = {} < |S1, S2, S3| = {pol} (degree of polarisation {:.4} > 1)",
                o[0],
                pol / o[0].abs().max(f64::MIN_POSITIVE)
            )
        })
    };
    if let Some(why) = dop_check("unpolarised light", [m[0], m[4], m[8], m[12]]) {
        return Some(why);
    }
    probe_states().find_map(|s| {
        dop_check(
            &format!("the pure state (1, {:.4}, {:.4}, {:.4})", s[0], s[1], s[2]),
            out(s),
        )
    })
}

/// Why a Carlson cell's polarisation sums cannot be those of a run
/// ([`check_sums`]), naming the cell.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SumsError {
    /// The polarisation tallies have no sums for the cell.
    #[error("has no sums for Carlson cell {cell}")]
    Missing {
        /// The Carlson cell.
        cell: usize,
    },
    /// The Mueller sum is not a realisable Mueller matrix.
    #[error("cell {cell}: the Mueller sum is not physical: {why}")]
    Mueller {
        /// The Carlson cell.
        cell: usize,
        /// What is not realisable
        /// ([`unrealisable`]).
        why: String,
    },
    /// The Stokes sum is polarised beyond its intensity.
    #[error(
        "cell {cell}: the Stokes sum has S0 = {s0} < |S1, S2, S3| = {polarised} (degree of polarisation above 1)"
    )]
    Stokes {
        /// The Carlson cell.
        cell: usize,
        /// `S0`.
        s0: f64,
        /// `sqrt(S1² + S2² + S3²)`.
        polarised: f64,
    },
    /// The intensity of the polarisation sums is not the Carlson sum.
    #[error(
        "cell {cell}: the polarisation sums give the intensity {intensity}, not the Carlson sum {carlson} of the same histories"
    )]
    Intensity {
        /// The Carlson cell.
        cell: usize,
        /// The intensity of the polarisation sums.
        intensity: f64,
        /// The Carlson sum.
        carlson: f64,
    },
}

/// Why the polarisation sums `polar` (with the Carlson sums `carlson` of
/// the same histories, and the run's incident Stokes vector `incident`,
/// `S0 = 1`) cannot be those of a run, or `Ok`: per Carlson cell, a Stokes
/// sum has `S0 >= sqrt(S1² + S2² + S3²)` and `S0` equal to the Carlson sum;
/// a Mueller sum is realisable
/// ([`unrealisable`]) and `m00 + m01 s1 + m02
/// s2 + m03 s3` (its intensity for the incident state `s`) equals the
/// Carlson sum; each within [`SUM_TOLERANCE`] of the sum of the absolute
/// terms.
///
/// # Errors
/// The cell and the check ([`SumsError`]), for a message after the file
/// and key.
pub fn check_sums(
    polar: Option<&PolarTallies>,
    carlson: &Accumulator,
    incident: [f64; 4],
) -> Result<(), SumsError> {
    let Some(p) = polar else { return Ok(()) };
    let k = p.components;
    for (cell, &c) in carlson.sum.iter().enumerate() {
        let bin = p.cell_bin(cell, 0);
        let Some(v) = p.sums.sum.get(bin..bin + k) else {
            return Err(SumsError::Missing { cell });
        };
        let (intensity, scale) = if k == 16 {
            let m: [f64; 16] = v.try_into().expect("16 components");
            if let Some(why) = unrealisable(&m) {
                return Err(SumsError::Mueller { cell, why });
            }
            let i: f64 = (0..4).map(|j| m[j] * incident[j]).sum();
            let s: f64 = (0..4).map(|j| (m[j] * incident[j]).abs()).sum();
            (i, s)
        } else {
            let pol = (v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt();
            let scale = v.iter().map(|x| x.abs()).sum::<f64>();
            if !(v[0] + SUM_TOLERANCE * scale >= pol) {
                return Err(SumsError::Stokes {
                    cell,
                    s0: v[0],
                    polarised: pol,
                });
            }
            (v[0], scale)
        };
        if !((intensity - c).abs() <= SUM_TOLERANCE * (scale + c.abs()) + f64::MIN_POSITIVE) {
            return Err(SumsError::Intensity {
                cell,
                intensity,
                carlson: c,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tallies(components: usize, cell: &[f64]) -> PolarTallies {
        let mut p = PolarTallies::new(components, 1, None);
        let bin = p.cell_bin(0, 0);
        p.sums.sum[bin..bin + components].copy_from_slice(cell);
        p
    }

    fn carlson(c: f64) -> Accumulator {
        let mut a = Accumulator::new(1);
        a.sum[0] = c;
        a
    }

    const UNPOLARISED: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

    #[test]
    fn stokes_sums_beyond_full_polarisation_are_refused() {
        let ok = tallies(4, &[2.0, 1.2, 1.6, 0.0]); // fully polarised
        assert_eq!(check_sums(Some(&ok), &carlson(2.0), UNPOLARISED), Ok(()));
        let bad = tallies(4, &[2.0, 3.0, 4.0, 0.0]); // |S1, S2| = 2.5 S0
        let e = check_sums(Some(&bad), &carlson(2.0), UNPOLARISED).unwrap_err();
        assert_eq!(
            e,
            SumsError::Stokes {
                cell: 0,
                s0: 2.0,
                polarised: 5.0
            }
        );
        assert_eq!(
            e.to_string(),
            "cell 0: the Stokes sum has S0 = 2 < |S1, S2, S3| = 5 (degree of polarisation above 1)"
        );
        let e = check_sums(Some(&ok), &carlson(2.1), UNPOLARISED).unwrap_err();
        assert_eq!(
            e,
            SumsError::Intensity {
                cell: 0,
                intensity: 2.0,
                carlson: 2.1
            }
        );
        assert_eq!(check_sums(None, &carlson(2.1), UNPOLARISED), Ok(()));
    }

    #[test]
    fn mueller_sums_are_realisable_and_match_the_carlson_sum() {
        // An ideal linear polariser along s, times 0.5: m00 = m01 = m10 =
        // m11 = 0.25.
        let mut m = [0.0; 16];
        for i in [0, 1, 4, 5] {
            m[i] = 0.25;
        }
        let p = tallies(16, &m);
        assert_eq!(check_sums(Some(&p), &carlson(0.25), UNPOLARISED), Ok(()));
        // s light: intensity m00 + m01 = 0.5.
        let s = [1.0, 1.0, 0.0, 0.0];
        assert_eq!(check_sums(Some(&p), &carlson(0.5), s), Ok(()));
        assert!(matches!(
            check_sums(Some(&p), &carlson(0.25), s),
            Err(SumsError::Intensity { cell: 0, .. })
        ));
        // m01 = 5 m00: unpolarised... and s-state outputs beyond DoP 1.
        m[1] = 1.25;
        m[4] = 1.25;
        let e = check_sums(Some(&tallies(16, &m)), &carlson(0.25), UNPOLARISED).unwrap_err();
        assert!(matches!(e, SumsError::Mueller { cell: 0, .. }), "{e}");
    }
}
