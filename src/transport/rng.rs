//! Random streams: one per photon, from (seed, photon index) only.
//!
//! Results therefore do not depend on the number of threads or on how photons
//! are split into batches or shards. The generator is PCG-64 (MCG variant,
//! `rand_pcg::Pcg64Mcg`), whose output is specified and portable; its 128-bit
//! state is made from the seed and the index by SplitMix64 mixing, so nearby
//! indices give unrelated streams.

use rand_pcg::Pcg64Mcg;

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
#[must_use]
#[inline]
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of photon `index` under `seed`.
#[must_use]
#[inline]
pub fn photon_rng(seed: u64, index: u64) -> Pcg64Mcg {
    Streams::new(seed).photon(index)
}

/// The photon streams of one seed: [`photon_rng`] with the seed's own
/// mixing done once, not once a photon (the same streams).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Streams {
    /// `splitmix64(seed)`.
    mixed: u64,
}

impl Streams {
    /// The streams of `seed`.
    #[must_use]
    #[inline]
    pub fn new(seed: u64) -> Self {
        Self {
            mixed: splitmix64(seed),
        }
    }

    /// The stream of photon `index`: `photon_rng(seed, index)`.
    #[must_use]
    #[inline]
    pub fn photon(&self, index: u64) -> Pcg64Mcg {
        let a = self.mixed;
        let hi = splitmix64(a ^ index);
        let lo = splitmix64(hi ^ a.rotate_left(17));
        Pcg64Mcg::new((u128::from(hi) << 64) | u128::from(lo))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn streams_depend_only_on_seed_and_index() {
        let x: f64 = photon_rng(7, 123).random();
        let y: f64 = photon_rng(7, 123).random();
        let z: f64 = photon_rng(7, 124).random();
        let w: f64 = photon_rng(8, 123).random();
        assert_eq!(x, y);
        assert_ne!(x, z);
        assert_ne!(x, w);
    }

    /// The streams of [`Streams`] are [`photon_rng`]'s, against the
    /// mixing written out (the definition before `Streams`).
    #[test]
    fn streams_are_the_photon_streams() {
        for seed in [0, 1, 7, u64::MAX, 0x5eed_1234_5678_9abc] {
            let streams = Streams::new(seed);
            for index in [0, 1, 2, 4095, 1 << 40, u64::MAX] {
                let a = splitmix64(seed);
                let hi = splitmix64(a ^ index);
                let lo = splitmix64(hi ^ a.rotate_left(17));
                let mut want = Pcg64Mcg::new((u128::from(hi) << 64) | u128::from(lo));
                let mut got = streams.photon(index);
                let mut old = photon_rng(seed, index);
                for _ in 0..4 {
                    let w: u64 = want.random();
                    assert_eq!(got.random::<u64>(), w);
                    assert_eq!(old.random::<u64>(), w);
                }
            }
        }
    }

    #[test]
    fn first_draws_of_neighbouring_streams_are_uniform() {
        // Mean and variance of the first draw over 100k consecutive indices.
        let n = 100_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let u: f64 = photon_rng(1, i).random();
            s += u;
            s2 += u * u;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // Standard error of the mean of U(0,1): sqrt(1/12/n) = 9.1e-4.
        assert!(
            (mean - 0.5).abs() < 4.0 * (1.0 / 12.0 / n as f64).sqrt(),
            "{mean}"
        );
        // Standard error of the sample variance: sqrt((mu4 - sigma^4) / n), mu4 = 1/80.
        let var_se = ((1.0 / 80.0 - 1.0 / 144.0) / n as f64).sqrt();
        assert!((var - 1.0 / 12.0).abs() < 4.0 * var_se, "{var}");
    }
}
