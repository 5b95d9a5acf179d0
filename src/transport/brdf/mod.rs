//! The BRDF generator: photons from each incidence direction, tallied on the
//! Carlson grid and in the plane of incidence, with standard errors.
//!
//! Photons start at uniform points of the cell on the launch plane, random
//! or on randomised lattices ([`super::launch`]), travelling along
//! `-omega_i`. Photon `n` uses the stream `(seed, n)` only;
//! photons are traced in fixed batches of [`BATCH`](crate::tally::sum::BATCH) and the batch tallies are
//! summed over a fixed binary tree on batch indices ([`crate::tally::sum`]), so
//! results are bit-identical for any thread count, and shards of a run
//! (`--shard I/N`) merge to exactly the single run's sums.
//! `fraction` in a cell is the photon weight leaving through it per launched
//! photon; BRDF = fraction / projected solid angle (sr⁻¹). With
//! [`Symmetry::Mirror`] each escaping photon counts half in its mirror
//! image in the plane of incidence ([`crate::tally::symmetry`]).
//!
//! With [`Polarisation::transport`] photons carry Stokes vectors (or Mueller
//! columns, for [`PolarTally::Mueller`]) through every Fresnel bounce
//! ([`super::carrier`]); `brdf.csv`, `inplane.csv` and the reflectance are
//! then the intensity `S0` for the incident state, and [`PolarTallies`] keep
//! the Stokes or Mueller BRDF per cell ([`crate::tally::polar`]).
//!
//! The one entry point is [`BrdfRun::trace_realisations`] (one surface per
//! realisation; [`BrdfRun::trace`] and [`BrdfRun::trace_whole`] are its
//! shorthands for one surface). By concern: the run description
//! ([`BrdfRun`] and its parts, `run.rs`), why a run is refused
//! (`error.rs`), the sums of one incidence ([`BrdfTallies`], `tallies.rs`),
//! the trace loop (`trace.rs`), the scores of each history (`score.rs`) and
//! the result tree ([`BrdfResult`] down to [`IncidenceResult`],
//! `result.rs`). The scene key of each field of a run is the scene's
//! ([`crate::scene::keys::RunField`]).

#[cfg(doc)]
use crate::tally::{PolarTallies, PolarTally, Symmetry};

mod error;
mod result;
mod run;
mod score;
mod tallies;
mod trace;

pub use error::{AzimuthError, IncidenceError, PolarisationError, RunError};
pub use result::{
    BrdfResult, ByAzimuth, ByIncidence, Ensemble, IncidenceResult, RealisationResult,
};
pub use run::{
    Azimuths, BrdfRun, INPLANE_ROW_BYTES, Polarisation, ShardRange, check_incidence, toward_light,
};
pub use tallies::{BOUNCE_BINS, BrdfTallies, Replicates, add_up};
