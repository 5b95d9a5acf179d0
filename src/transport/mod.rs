//! Photon transport: random streams, histories, and the runs built on them.
//!
//! * [`rng`]: one reproducible stream per photon.
//! * [`carrier`]: what a photon carries: a weight, or a Stokes vector or Mueller matrix with its frame.
//! * [`micro`]: one history in a micro surface (specular reflections, weights, roulette).
//! * [`launch`]: where photons enter the micro cell (random or lattice).
//! * [`brdf`]: the BRDF generator (`roks brdf`).
//! * [`object`]: histories through a 3-D object (`roks trace`).

pub mod brdf;
pub mod carrier;
pub mod launch;
pub mod micro;
pub mod object;
pub mod rng;

use rand::RngExt;
use rayon::prelude::*;

/// Photons per batch: the unit of parallel work and of summation order.
pub const BATCH: u64 = 4096;

/// Trace `photons` photons in fixed batches of [`BATCH`] in parallel and hand
/// each batch's tally to `consume(batch index, tally)` in batch order, so the
/// result is bit-identical for any number of threads. `trace(range)` traces
/// the photons of one index range into a fresh tally; `progress` receives the
/// photons done. Pending batch tallies are bounded by working in chunks.
pub fn run_batches<T: Send>(
    photons: u64,
    trace: impl Fn(std::ops::Range<u64>) -> T + Sync,
    mut consume: impl FnMut(u64, T),
    progress: &(dyn Fn(u64) + Sync),
) {
    const CHUNK: u64 = 64;
    let n_batches = photons.div_ceil(BATCH);
    let mut b0 = 0;
    while b0 < n_batches {
        let b1 = (b0 + CHUNK).min(n_batches);
        let parts: Vec<T> = (b0..b1)
            .into_par_iter()
            .map(|b| {
                let range = b * BATCH..((b + 1) * BATCH).min(photons);
                let n = range.end - range.start;
                let t = trace(range);
                progress(n);
                t
            })
            .collect();
        for (b, part) in (b0..b1).zip(parts) {
            consume(b, part);
        }
        b0 = b1;
    }
}

/// Russian roulette (unbiased): below `threshold` a weight survives with
/// probability `w / s` and then carries `s = min(10 threshold, 1)`; returns
/// the new weight, or `None` if the photon is absorbed.
#[inline]
pub fn roulette(w: f64, threshold: f64, rng: &mut impl rand::Rng) -> Option<f64> {
    if w >= threshold {
        return Some(w);
    }
    let survival = (10.0 * threshold).min(1.0);
    (rng.random::<f64>() * survival < w).then_some(survival)
}
