//! Tallies for scoring outgoing photon directions.
//!
//! Conventions: directions are unit vectors with `z` the surface normal and
//! the upper hemisphere `z > 0`; `theta` is the polar angle from `+z`,
//! `mu = cos(theta)`, `phi = atan2(y, x)`. The light direction `omega_i`
//! points *to* the light; its specular direction is
//! `(-omega_i.x, -omega_i.y, omega_i.z)`.
//!
//! - [`Accumulator`]: per-bin sums of weights and squared weights, with mean
//!   and standard error per history.
//! - [`CarlsonGrid`]: the Carlson (1976) equal-solid-angle hemisphere grid.
//! - [`InPlaneTally`]: a fine goniometer tally in the plane of incidence.
//! - [`Symmetry`]: folding mirror images in the plane of incidence.
//! - [`PolarTallies`]: Stokes and Mueller-matrix BRDFs per cell.
//! - [`lanes`]: one batch's sums of many wavelengths, by bin and wavelength.
//! - [`Merge`]: adding tallies field by field ([`merge_fields!`](crate::merge_fields)
//!   derives it from one list of fields).
//! - [`sum`]: the fixed batch tree every run sums its batch tallies over.
//! - [`exact`]: floats stored exactly in result files.
//! - [`anisotropy`]: chi² of the tables of several light azimuths, turned
//!   onto each other.

pub mod accumulator;
pub mod anisotropy;
pub mod carlson;
pub mod exact;
pub mod inplane;
pub mod lanes;
pub mod merge;
pub mod polar;
pub mod realisable;
pub mod sum;
pub mod symmetry;

pub use accumulator::Accumulator;
pub use carlson::{CarlsonGrid, Locator};
pub use inplane::InPlaneTally;
pub use merge::Merge;
pub use polar::{PolarTallies, PolarTally};
pub use symmetry::Symmetry;
