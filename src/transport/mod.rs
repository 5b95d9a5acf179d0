//! Photon transport: random streams, histories, and the runs built on them.
//!
//! * [`rng`]: one reproducible stream per photon.
//! * [`micro`]: one history in a micro surface (specular reflections, weights, roulette).
//! * [`brdf`]: the BRDF generator (`roks brdf`).
//! * [`object`]: histories through a 3-D object (`roks trace`).

pub mod brdf;
pub mod micro;
pub mod object;
pub mod rng;
