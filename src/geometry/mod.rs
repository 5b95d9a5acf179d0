//! The geometry kernel shared by the micro and macro levels.
//!
//! * [`quadric`]: second-order surfaces and their ray crossings (f64, no fudge epsilon).
//! * [`region`]: OpenMC-style region expressions (`-a +b | ~(-c)`) over surfaces.
//! * [`body`]: solids = regions over quadrics, and where a ray enters them.
//! * [`ray`]: rays and the axis-aligned boxes they are clipped by.

pub mod body;
pub mod quadric;
pub mod ray;
pub mod region;
