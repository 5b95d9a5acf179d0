//! Splitting a `roks brdf` run across machines (`--shard I/N`) into blocks
//! of whole photon batches.
//!
//! The photons of every incidence angle are cut into `B = ceil(photons / BATCH)`
//! batches of [`BATCH`]. Shard `I` of `N` runs the whole batches
//! `[floor(I B / N), floor((I + 1) B / N))`, i.e. the photon indices
//! `[first, last)` with `first` a multiple of `BATCH` (`last` is clipped to the
//! run's photons). Photon `n` draws from the stream `(seed, n)` only, so a
//! shard traces exactly the histories the single run traces for those indices.
//! `N` may not exceed `B` (a shard without a whole batch could not be merged
//! exactly).
//!
//! Every run sums its batches over the same fixed tree
//! ([`crate::tally::sum`]), so a shard's complete tree nodes are bit-identical
//! to the single run's; a shard stores them in `tallies.json`
//! ([`crate::output::tallies`]) and `roks merge` pushes the nodes of all
//! shards into one tree: byte-identical `brdf.csv` and `inplane.csv`, and
//! `summary.json` equal except for timings (`seconds`,
//! `segments_per_second`, which are the sums of the shards' times).
//!
//! The shard file of both levels, its checks and the merge are
//! [`file`](mod@file)'s, generic over the level ([`file::Level`]).
//!
//! Alternatives rejected: storing per-batch partial sums (exact but about
//! 40 kB per batch and incidence: gigabytes for large runs); exact fixed-point
//! or compensated accumulation (would change the `Accumulator` used everywhere,
//! and fixed point is not exact for tiny weights).

use crate::tally::sum::BATCH;

pub mod file;

/// `--shard I/N`: block `index` (0-based) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 0-based block index.
    pub index: u64,
    /// Number of blocks.
    pub count: u64,
}

/// Why a `--shard` value, or a shard of a run, was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// No `/`.
    #[error("expected I/N (e.g. 0/4), got `{0}`")]
    Form(String),
    /// `I` is not a whole number.
    #[error("bad shard index `{index}` in `{given}`")]
    Index {
        /// The index text.
        index: String,
        /// The whole value.
        given: String,
    },
    /// `N` is not a whole number.
    #[error("bad shard count `{count}` in `{given}`")]
    Count {
        /// The count text.
        count: String,
        /// The whole value.
        given: String,
    },
    /// Not `0 <= I < N`.
    #[error("need 0 <= I < N, got `{0}`")]
    Range(String),
    /// More shards than batches.
    #[error(
        "{shards} shards but only {batches} batches of {BATCH} photons: use at most {batches} shards or more photons"
    )]
    TooMany {
        /// The shards asked for.
        shards: u64,
        /// The batches of the run.
        batches: u64,
    },
    /// More shards than batches over the beam positions of an object run
    /// ([`crate::transport::object::shard_blocks`]).
    #[error(
        "{shards} shards but only {batches} batches of {BATCH} photons over the beam positions: use at most {batches} shards or more photons"
    )]
    TooManyOverPositions {
        /// The shards asked for.
        shards: u64,
        /// The batches of all beam positions.
        batches: u64,
    },
}

impl std::str::FromStr for Shard {
    type Err = ShardError;
    fn from_str(s: &str) -> Result<Self, ShardError> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| ShardError::Form(s.to_owned()))?;
        let index: u64 = i.trim().parse().map_err(|_| ShardError::Index {
            index: i.to_owned(),
            given: s.to_owned(),
        })?;
        let count: u64 = n.trim().parse().map_err(|_| ShardError::Count {
            count: n.to_owned(),
            given: s.to_owned(),
        })?;
        if count == 0 || index >= count {
            return Err(ShardError::Range(s.to_owned()));
        }
        Ok(Self { index, count })
    }
}

impl Shard {
    /// Photon indices `[first, last)` of this block of a run of `photons`
    /// photons per incidence: whole batches, `first` a multiple of [`BATCH`].
    ///
    /// # Errors
    /// [`ShardError::TooMany`]: fewer batches than shards.
    pub fn photon_range(self, photons: u64) -> Result<(u64, u64), ShardError> {
        let batches = photons.div_ceil(BATCH);
        if self.count > batches {
            return Err(ShardError::TooMany {
                shards: self.count,
                batches,
            });
        }
        let b0 = (u128::from(self.index) * u128::from(batches) / u128::from(self.count)) as u64;
        let b1 = (u128::from(self.index + 1) * u128::from(batches) / u128::from(self.count)) as u64;
        Ok((b0 * BATCH, (b1 * BATCH).min(photons)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_blocks_cover_the_run() {
        for photons in [1_u64, 4095, 4096, 4097, 40_000, 1_000_000] {
            let batches = photons.div_ceil(BATCH);
            for count in 1..=batches.min(9) {
                let mut next = 0;
                for index in 0..count {
                    let (a, b) = Shard { index, count }.photon_range(photons).unwrap();
                    assert_eq!(a, next);
                    assert_eq!(a % BATCH, 0);
                    assert!(b > a);
                    next = b;
                }
                assert_eq!(next, photons);
            }
            assert!(
                Shard {
                    index: 0,
                    count: batches + 1
                }
                .photon_range(photons)
                .is_err()
            );
        }
        assert!("3/3".parse::<Shard>().is_err());
        assert!("x".parse::<Shard>().is_err());
        assert_eq!("2/3".parse::<Shard>(), Ok(Shard { index: 2, count: 3 }));
    }
}
