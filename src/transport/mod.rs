//! Photon transport: random streams, histories, and the runs built on them.
//!
//! * [`rng`]: one reproducible stream per photon.
//! * [`carrier`]: what a photon carries: a weight, or a Stokes vector or Mueller matrix with its frame.
//! * [`micro`]: one history in a micro surface (specular reflections, weights, roulette).
//! * [`launch`]: where photons enter the micro period (random or lattice).
//! * [`order`]: the order a batch's photons are traced in (Morton order of entry points).
//! * [`wavefront`]: the wavefront kernel: a wave of photons advanced stage by stage, four lanes at a time.
//! * [`brdf`]: the BRDF generator (`roks brdf`).
//! * [`wall`]: the wall models of objects (micro descent, BRDF table, ideal, specular).
//! * [`object`]: histories through a 3-D object (`roks trace`).
//!
//! Both levels name their history loop `trace` and its end `Fate`
//! ([`micro::trace`], [`object::trace`]; the module path tells them apart);
//! both return the one [`History`], over their own fate
//! ([`micro::History`], [`object::History`]).

pub mod brdf;
pub mod carrier;
pub mod launch;
pub mod micro;
pub mod object;
pub mod order;
pub mod rng;
pub mod wall;
pub mod wavefront;

use rand::RngExt;
use rayon::prelude::*;

use crate::tally::sum::BATCH;

/// A finished history at either level: how it ended (`F`, the level's
/// fate: [`micro::Fate`] or [`object::Fate`], each over what the photon
/// carried) and what it cost. The two fates differ on purpose: the micro
/// level tells apart the weight absorbed by its absorbing walls, cut by a
/// cap and stopped by a numerical guard (`tallies.json` counts each), the
/// object level lumps them as lost and has an end of its own, a surface
/// without a wall model ([`object::Fate::Unmodelled`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct History<F> {
    /// How it ended.
    pub fate: F,
    /// Reflections: at bodies and reflecting walls (micro level), at walls
    /// (object level: 0 for an escape, the photon missed the object).
    pub bounces: u32,
    /// Straight flights traced (queries of the geometry).
    pub segments: u32,
}

/// Most bytes of batch tallies [`parallel_batches`] and [`parallel_batches_ordered`] hold at a
/// time, as whole chunks of batches (see [`pending_batches`]).
const PENDING_BYTES: usize = 8 << 20;

/// Batches traced in one chunk (whose tallies are all held until the chunk
/// is done) when one batch tally takes `tally_bytes` and `threads` threads
/// trace: as many as fit in `PENDING_BYTES` (8 MiB), but at least two per thread
/// and at most 64.
#[must_use]
pub fn pending_batches(tally_bytes: u64, threads: u64) -> u64 {
    (PENDING_BYTES as u64 / tally_bytes.max(1))
        .max(2 * threads)
        .min(64)
}

/// [`pending_batches`] for the threads of the current rayon pool.
fn pending_here(tally_bytes: u64) -> u64 {
    pending_batches(tally_bytes, rayon::current_num_threads() as u64)
}

/// Trace `photons` photons in fixed batches of [`BATCH`] in parallel and hand
/// each batch's tally to `consume(batch index, tally)` in batch order, so the
/// result is bit-identical for any number of threads. `trace(range)` traces
/// the photons of one index range into a fresh tally of about `tally_bytes`;
/// `progress` receives the photons done. Pending batch tallies are bounded
/// by working in chunks of [`pending_batches`] for the threads of the pool.
pub fn parallel_batches<T: Send>(
    photons: u64,
    tally_bytes: u64,
    trace: impl Fn(std::ops::Range<u64>) -> T + Sync,
    mut consume: impl FnMut(u64, T),
    progress: &(dyn Fn(u64) + Sync),
) {
    let chunk = pending_here(tally_bytes);
    let n_batches = photons.div_ceil(BATCH);
    let mut b0 = 0;
    while b0 < n_batches {
        let b1 = (b0 + chunk).min(n_batches);
        // A cancelled run (crate::interrupt::cancelled) stops between
        // batches; its caller discards what was consumed.
        let parts: Option<Vec<T>> = (b0..b1)
            .into_par_iter()
            .map(|b| {
                if crate::interrupt::cancelled() {
                    return None;
                }
                let range = b * BATCH..((b + 1) * BATCH).min(photons);
                let n = range.end - range.start;
                let t = trace(range);
                progress(n);
                Some(t)
            })
            .collect();
        let Some(parts) = parts else { return };
        for (b, part) in (b0..b1).zip(parts) {
            consume(b, part);
        }
        b0 = b1;
    }
}

/// Most bytes of entries and histories [`parallel_batches_ordered`] holds at a time
/// (whole batches, at least one).
const ORDERED_BYTES: usize = 32 << 20;

/// Bytes of histories [`parallel_batches_ordered`] copies into index order at a time for
/// scoring (a block that stays in the first-level cache).
const GATHER_BYTES: usize = 16 << 10;

/// Photons a thread traces in one piece of the Morton order of [`parallel_batches_ordered`].
const PIECE: usize = 1024;

/// Like [`parallel_batches`], but each chunk of batches is traced in the Morton
/// order of its photons' entry points ([`order`]), so that photons entering
/// near each other are traced one after the other (by pieces of `PIECE` (1024)
/// photons spread over the threads), and each batch is then scored from its
/// histories in photon index order: the tallies are bit-identical to
/// [`parallel_batches`]'s for any thread count.
///
/// `entry(n)` gives photon `n`'s Morton code and what its history starts
/// from (`E`: its stream and entry point); `trace(entries, scratch, out)`
/// pushes the histories of a piece's entries onto `out`, in their order,
/// with a scratch from `scratch()` per rayon job (reused over its
/// pieces); `score(range, visit)` a batch's tally, where `visit(f)` calls
/// `f(entry, history)` for the batch's photons in index order; `consume` and
/// `progress` as for [`parallel_batches`]. Chunks hold
/// at most about `ORDERED_BYTES` (32 MiB) of entries and histories, and at most
/// [`pending_batches`] of batch tallies of `tally_bytes`.
#[allow(clippy::too_many_arguments)]
pub fn parallel_batches_ordered<E: Clone + Send + Sync, H: Clone + Send + Sync, S, T: Send>(
    photons: u64,
    tally_bytes: u64,
    entry: impl Fn(u64) -> (u16, E) + Sync,
    scratch: impl Fn() -> S + Sync,
    trace: impl Fn(&[E], &mut S, &mut Vec<H>) + Sync,
    score: impl Fn(std::ops::Range<u64>, &dyn Fn(&mut dyn FnMut(&E, &H))) -> T + Sync,
    mut consume: impl FnMut(u64, T),
    progress: &(dyn Fn(u64) + Sync),
) {
    let per_photon = std::mem::size_of::<E>() + std::mem::size_of::<H>() + 16;
    let chunk = ((ORDERED_BYTES / (per_photon * BATCH as usize)).clamp(1, 64) as u64)
        .min(pending_here(tally_bytes));
    // Histories copied at a time for scoring: about `GATHER_BYTES` (at least one).
    let gather = (GATHER_BYTES / std::mem::size_of::<H>().max(1)).clamp(1, BATCH as usize);
    let n_batches = photons.div_ceil(BATCH);
    let mut b0 = 0;
    while b0 < n_batches {
        let b1 = (b0 + chunk).min(n_batches);
        let first = b0 * BATCH;
        let end = (b1 * BATCH).min(photons);
        let (codes, entries): (Vec<u16>, Vec<E>) = (first..end).into_par_iter().map(&entry).unzip();
        let sorted = order::sorted_by_code(&codes);
        let pieces: Vec<Vec<H>> = sorted
            .par_chunks(PIECE)
            // A scratch per rayon job, not per piece: a large surface's
            // mailbox is big, and zeroing it per piece would flush the caches
            // the order is there to keep warm.
            //
            // The piece's entries are first copied out of the index-ordered
            // array: the copies are independent loads that the core overlaps,
            // whereas reading each entry just before tracing it would stall
            // on a cache miss per photon (a chunk's entries far exceed the
            // caches).
            .map_init(
                || (scratch(), Vec::with_capacity(PIECE)),
                |(s, local), piece| {
                    if crate::interrupt::cancelled() {
                        return Vec::new();
                    }
                    local.clear();
                    local.extend(piece.iter().map(|&i| entries[i as usize].clone()));
                    let mut h = Vec::with_capacity(local.len());
                    trace(local, s, &mut h);
                    assert_eq!(h.len(), local.len(), "a history per photon");
                    progress(piece.len() as u64);
                    h
                },
            )
            .collect();
        // A cancelled run stops here, its pieces incomplete.
        if crate::interrupt::cancelled() {
            return;
        }
        // Where each photon's history is in `pieces`.
        let mut at = vec![0_u32; sorted.len()];
        for (k, &i) in sorted.iter().enumerate() {
            at[i as usize] = k as u32;
        }
        let parts: Vec<T> = (b0..b1)
            .into_par_iter()
            .map(|b| {
                let range = b * BATCH..((b + 1) * BATCH).min(photons);
                let local = (range.start - first) as usize..(range.end - first) as usize;
                // The histories are where their pieces put them, scattered
                // over the chunk (far beyond the caches): they are copied in
                // blocks, in index order, before they are scored. The copies
                // are independent loads that the core overlaps, whereas
                // scoring each in place would stall on a cache miss per
                // photon (the scoring of one photon fills the core's window).
                let visit = |f: &mut dyn FnMut(&E, &H)| {
                    let mut block: Vec<H> = Vec::with_capacity(gather);
                    for (es, ks) in entries[local.clone()]
                        .chunks(gather)
                        .zip(at[local.clone()].chunks(gather))
                    {
                        block.clear();
                        block.extend(
                            ks.iter()
                                .map(|&k| pieces[k as usize / PIECE][k as usize % PIECE].clone()),
                        );
                        for (e, h) in es.iter().zip(&block) {
                            f(e, h);
                        }
                    }
                };
                score(range, &visit)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A history of `N` words: the photon's index and a payload derived from it.
    #[derive(Clone)]
    struct Words<const N: usize>([u64; N]);

    /// `parallel_batches_ordered` hands every batch its photons in index order, each with
    /// its own entry and history, whether the histories are copied for
    /// scoring many at a time (small), a few (medium) or one (large, above
    /// `GATHER_BYTES`).
    fn visits_in_index_order<const N: usize>() {
        let photons = 3 * BATCH + 1000;
        let mut seen = Vec::new();
        parallel_batches_ordered(
            photons,
            1,
            // Codes that scatter the photons over the Morton order.
            |n| ((n.wrapping_mul(40_503) % 65_536) as u16, n),
            || (),
            |es: &[u64], (), out: &mut Vec<Words<N>>| {
                out.extend(
                    es.iter()
                        .map(|&n| Words::<N>(std::array::from_fn(|k| n * 7 + k as u64))),
                );
            },
            |range, visit| {
                let mut got = Vec::new();
                visit(&mut |&n, h: &Words<N>| {
                    assert!(
                        h.0.iter().enumerate().all(|(k, &x)| x == n * 7 + k as u64),
                        "photon {n}: another photon's history"
                    );
                    got.push(n);
                });
                (range, got)
            },
            |b, (range, got)| {
                assert_eq!(range, b * BATCH..((b + 1) * BATCH).min(photons));
                assert_eq!(got, range.collect::<Vec<u64>>(), "batch {b}");
                seen.push(b);
            },
            &|_| {},
        );
        assert_eq!(seen, (0..photons.div_ceil(BATCH)).collect::<Vec<_>>());
    }

    #[test]
    fn ordered_runs_score_in_index_order() {
        visits_in_index_order::<1>();
        visits_in_index_order::<100>();
        visits_in_index_order::<4096>();
    }
}
