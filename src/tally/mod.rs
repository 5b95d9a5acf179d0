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

pub mod accumulator;
pub mod carlson;
pub mod inplane;
pub mod polar;
pub mod symmetry;

pub use accumulator::Accumulator;
pub use carlson::{CarlsonGrid, Locator};
pub use inplane::InPlaneTally;
pub use polar::{PolarTallies, PolarTally};
pub use symmetry::Symmetry;
