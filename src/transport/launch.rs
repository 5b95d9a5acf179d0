//! Where photons enter the micro period: independent random points, or a
//! randomised low-discrepancy lattice.
//!
//! A photon enters at a point `(u, v)` of the unit square (scaled to the period
//! on the launch plane). With [`Launch::Random`] every photon draws its point
//! from its own stream, and the standard errors are the usual per-photon ones.
//!
//! [`Launch::Lattice`] spreads the points of a run evenly instead: photon `g`
//! (its index in the whole run) belongs to replicate `r = g mod K`
//! ([`REPLICATES`] = K) and is point `j = g div K` of that replicate's
//! sequence
//!
//! ```text
//! (u, v) = frac(s_r + j (1/p, 1/p²)),   p = 1.3247179572447460 (the plastic number),
//! ```
//!
//! the R2 sequence (Roberts 2018), whose gaps stay near-uniform for any
//! number of points, shifted by the replicate's own uniform random offset
//! `s_r` (a Cranley–Patterson rotation). Each point is exactly uniform over
//! the square (a uniform shift of any point is uniform), so every replicate's
//! mean is an unbiased estimate; the K replicates use independent shifts and
//! independent photon streams (roulette), so their means are independent, and
//! the standard error of a tally is their spread,
//! `sqrt(sum_r (m_r - m)² / (K (K - 1)))` (with K - 1 = 15 degrees of
//! freedom). The per-photon formula would overstate it, since the points are
//! not independent.
//!
//! Why this pays: a BRDF cell collects the photons whose entry point lies in
//! its preimage on the period, a set of small patches (one or more per bump). A
//! random point set covers them with Poisson noise; a lattice of spacing
//! finer than the patches covers them in proportion to their area, so the
//! gain grows with the photons per replicate. Measured on the default scene
//! at 30 and 60 degrees over 8 (4) seeds, spread over seeds of the lattice
//! estimate against the random one: reflectance 0.34 (4e5 photons) and
//! 0.10-0.13 (4e6); BRDF cells 0.87 and 0.73 (median over the cells above
//! 10 % of the peak), i.e. 1.9 times fewer photons per Carlson cell at 4e6.
//! Stratifying each batch of 4096 photons alone gave nothing for the Carlson cells
//! (0.95): 4096 points are coarser than the patches.
//! A lattice run costs a little more time per photon (the replicate sums);
//! results/speed_error has the error against time.
//!
//! The price: a lattice run's standard errors are estimated from 16 numbers
//! (15 degrees of freedom), so a z-score built on them has t-like tails, and
//! in sparse cells (below about 25 photons per replicate, where a
//! replicate's sum is a small count) the estimate is poor: z² of such cells
//! averaged 1.36-1.6 instead of 1 in our runs. Use the random launch where
//! per-cell significance in sparse cells matters; the lattice where the
//! reflectance or well-filled cells do.

use rand::RngExt;

use super::rng::photon_rng;

/// Independent lattice replicates of a [`Launch::Lattice`] run.
pub const REPLICATES: u64 = 16;

/// `1/p` and `1/p²` for the plastic number `p`, the R2 sequence's steps.
const R2_STEP: [f64; 2] = [0.754_877_666_246_692_7, 0.569_840_290_998_053_3];

/// Stream salt of the replicate shifts (kept apart from the photon streams).
const SHIFT_SALT: u64 = 0x6c61_7474_6963_6521;

/// How entry points are chosen (`[light] launch`, `--launch`: the names in
/// lower case).
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
pub enum Launch {
    /// Independent uniform points, one per photon stream.
    #[default]
    #[value(help = None::<&str>)]
    Random,
    /// [`REPLICATES`] randomly shifted R2 lattices (see the module docs).
    #[value(help = None::<&str>)]
    Lattice,
}

impl Launch {
    /// Replicates whose spread gives the standard errors (`None`: per photon).
    #[must_use]
    pub fn replicates(self) -> Option<u64> {
        match self {
            Self::Random => None,
            Self::Lattice => Some(REPLICATES),
        }
    }
}

/// Most photons per incidence angle (per beam position of an object scene):
/// 2^53. Every tally is an `f64` sum of per-photon weights of at most 1, and
/// the counts are divided as `f64`: up to 2^53 a sum of whole weights (a
/// reflectance of 1), the count and every sum of squares are exact or
/// bounded by the count, so that the means and standard errors can be
/// formed; beyond it `n + 1 == n` in `f64` and photons stop being counted.
pub const MAX_PHOTONS: u64 = 1 << 53;

/// A photon count that a run cannot take ([`check_count`],
/// [`check_photons`]); the key or option it concerns is named by the caller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PhotonsError {
    /// No photons.
    #[error("must be > 0")]
    Zero,
    /// More than [`MAX_PHOTONS`].
    #[error(
        "must be at most 2^53 = {MAX_PHOTONS} (the f64 tallies cannot count more exactly), got {0}"
    )]
    TooMany(u64),
    /// A lattice run whose photons are not a multiple of its replicates.
    #[error("must be a multiple of {replicates} with launch = \"lattice\", got {photons}")]
    NotReplicates {
        /// The replicates of the launch.
        replicates: u64,
        /// The photons given.
        photons: u64,
    },
}

/// A photon count per incidence angle (per beam position of an object
/// scene), from a scene file or the command line: at least 1 and at most
/// [`MAX_PHOTONS`].
///
/// # Errors
/// [`PhotonsError::Zero`] or [`PhotonsError::TooMany`].
pub fn check_count(photons: u64) -> Result<(), PhotonsError> {
    if photons == 0 {
        return Err(PhotonsError::Zero);
    }
    if photons > MAX_PHOTONS {
        return Err(PhotonsError::TooMany(photons));
    }
    Ok(())
}

/// Photons per incidence angle allowed with `launch`: a count
/// ([`check_count`]), and for a lattice run a multiple of [`REPLICATES`]
/// (equal replicates).
///
/// # Errors
/// As [`check_count`], or [`PhotonsError::NotReplicates`].
pub fn check_photons(launch: Launch, photons: u64) -> Result<(), PhotonsError> {
    check_count(photons)?;
    match launch.replicates() {
        Some(k) if photons % k != 0 => Err(PhotonsError::NotReplicates {
            replicates: k,
            photons,
        }),
        _ => Ok(()),
    }
}

/// The random shifts of the [`REPLICATES`] lattices of one tracing seed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattices {
    shifts: [[f64; 2]; REPLICATES as usize],
}

impl Lattices {
    /// The shifts for tracing seed `seed` (replicate `r` draws from the
    /// stream `(seed ^ salt, r)`).
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self {
            shifts: std::array::from_fn(|r| {
                let mut shift = photon_rng(seed ^ SHIFT_SALT, r as u64);
                [shift.random(), shift.random()]
            }),
        }
    }

    /// The entry point of photon `g` (index in the run): its replicate and
    /// `(u, v)` in `[0, 1)²`.
    #[must_use]
    #[inline]
    pub fn point(&self, g: u64) -> (usize, [f64; 2]) {
        let r = (g % REPLICATES) as usize;
        let j = (g / REPLICATES) as f64;
        let s = self.shifts[r];
        let point = [0, 1].map(|k| {
            // The fraction of j * step is good to about 2^-53 j (1e-10 at j = 1e6).
            let x = s[k] + (j * R2_STEP[k]).fract();
            if x >= 1.0 { x - 1.0 } else { x }
        });
        (r, point)
    }
}

/// Standard error of a mean from `K` replicate sums `sums` (each over the
/// same number of photons `per_replicate`): the spread of the replicate
/// means, `sqrt(sum (m_r - m)² / (K (K - 1)))`.
#[must_use]
pub fn replicate_stderr(sums: impl Iterator<Item = f64> + Clone, per_replicate: u64) -> f64 {
    let n = per_replicate as f64;
    let k = sums.clone().count() as f64;
    if k < 2.0 || n == 0.0 {
        return 0.0;
    }
    let mean = sums.clone().sum::<f64>() / (k * n);
    let ss: f64 = sums.map(|s| (s / n - mean).powi(2)).sum();
    (ss / (k * (k - 1.0))).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_values_are_the_scene_and_file_names() {
        use clap::ValueEnum as _;
        for v in Launch::value_variants() {
            let name = v.to_possible_value().unwrap().get_name().to_owned();
            assert_eq!(serde_json::to_value(v).unwrap(), name.as_str());
            assert_eq!(serde_json::from_value::<Launch>(name.into()).unwrap(), *v);
        }
        assert_eq!(Launch::value_variants().len(), 2);
        assert!(serde_json::from_value::<Launch>("nonsense".into()).is_err());
    }

    #[test]
    fn photon_counts() {
        assert_eq!(check_count(0).unwrap_err().to_string(), "must be > 0");
        assert_eq!(check_count(1), Ok(()));
        assert_eq!(check_count(MAX_PHOTONS), Ok(()));
        assert_eq!(
            check_count(MAX_PHOTONS + 1).unwrap_err().to_string(),
            "must be at most 2^53 = 9007199254740992 (the f64 tallies cannot count more exactly), got 9007199254740993"
        );
        assert_eq!(check_photons(Launch::Random, 100), Ok(()));
        assert_eq!(check_photons(Launch::Lattice, 160), Ok(()));
        assert_eq!(
            check_photons(Launch::Lattice, 100).unwrap_err().to_string(),
            "must be a multiple of 16 with launch = \"lattice\", got 100"
        );
        // The count's limit comes first, also for a lattice.
        assert!(check_photons(Launch::Lattice, 0).unwrap_err() == PhotonsError::Zero);
    }

    #[test]
    fn steps_are_the_plastic_number_powers() {
        // p³ = p + 1; the steps to a few ulp of f64 arithmetic.
        let p: f64 = 1.324_717_957_244_746;
        assert!((p * p * p - p - 1.0).abs() < 1e-15);
        assert!((R2_STEP[0] - 1.0 / p).abs() < 1e-15);
        assert!((R2_STEP[1] - 1.0 / (p * p)).abs() < 1e-15);
    }

    #[test]
    fn points_are_in_the_square_and_replicates_interleave() {
        for g in [0, 1, 15, 16, 17, 4095, 4096, 1 << 40, u64::MAX] {
            let (r, p) = Lattices::new(7).point(g);
            assert_eq!(r as u64, g % REPLICATES);
            assert!(p.iter().all(|x| (0.0..1.0).contains(x)), "{g}: {p:?}");
        }
        // Same replicate, consecutive points: the R2 step modulo 1.
        let (_, a) = Lattices::new(3).point(5);
        let (_, b) = Lattices::new(3).point(5 + REPLICATES);
        for k in 0..2 {
            let step = (b[k] - a[k]).rem_euclid(1.0);
            assert!((step - R2_STEP[k]).abs() < 1e-12, "{k}: {step}");
        }
    }

    /// Every replicate of N points covers the square evenly: each of the
    /// 16 x 16 boxes holds N/256 points to within a few, far below the
    /// Poisson spread sqrt(N/256) of random points (here 8).
    #[test]
    fn a_replicate_is_evenly_spread() {
        let n = 16_384_u64;
        let mut boxes = [0_i64; 256];
        for j in 0..n {
            let (r, p) = Lattices::new(11).point(j * REPLICATES + 3);
            assert_eq!(r, 3);
            boxes[(p[1] * 16.0) as usize * 16 + (p[0] * 16.0) as usize] += 1;
        }
        let expect = (n / 256) as i64;
        let worst = boxes.iter().map(|b| (b - expect).abs()).max().unwrap();
        assert!(worst <= 3, "largest deviation {worst} of {expect}");
    }

    #[test]
    fn replicate_stderr_matches_the_formula() {
        // Means 1, 2, 3, 6 of 10 photons each: mean 3, squares 4+1+0+9 = 14.
        let sums = [10.0, 20.0, 30.0, 60.0];
        let se = replicate_stderr(sums.iter().copied(), 10);
        assert!((se - (14.0_f64 / 12.0).sqrt()).abs() < 1e-15);
        assert_eq!(replicate_stderr([5.0].iter().copied(), 10), 0.0);
    }
}
