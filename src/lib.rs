//! roks: Monte Carlo reflection of light from rough surfaces and rough 3-D
//! objects in geometric optics, after the program ROKS-RG (Klass, Shakhovsky,
//! Badyuk, Ulyanov, J. Opt. Technol. 2014).
//!
//! Layout, by physics:
//! * [`cli`]: the command line: one module per command over shared arguments,
//!   value parsers and one-line messages (the binary only dispatches).
//! * [`export`]: a micro surface as a triangle mesh (binary PLY for Mitsuba 3);
//!   BRDF tables as Zemax tabular BSDF and MERL binary files.
//! * [`fit`]: fitting a micro scene to a measured in-plane BRDF (`roks fit`).
//! * [`geometry`]: the one geometry kernel (quadrics, CSG regions, bodies).
//! * [`limits`]: the memory budget (`ROKS_MAX_MEMORY`): sizes estimated before allocating.
//! * [`optics`]: reflectance models (constant, Fresnel for n + ik, tables),
//!   BRDF tables, and polarisation (Stokes vectors, Fresnel Mueller matrices, frames).
//! * [`micro`]: the explicit rough surface (substrate, bumps, edges) and its statistics.
//! * [`object`]: the macro level: 3-D objects of quadric cells with rough walls.
//! * [`transport`]: photon histories and what a photon carries (a weight, or a
//!   Stokes vector or Mueller matrix with its frame), random streams, the BRDF generator.
//! * [`tally`]: angular grids (Carlson, in-plane), Stokes and Mueller tallies,
//!   accumulators with standard errors, adding tallies ([`tally::Merge`]) and
//!   the fixed batch tree every run sums over ([`tally::sum`]).
//! * [`scene`]: TOML scene files, validated with one-line errors.
//! * [`shard`]: splitting a BRDF run across machines in blocks of whole batches.
//! * [`output`]: result files, one submodule per format (`brdf.csv`,
//!   `summary.json`, `tallies.json`, ...), the result folder of `roks brdf`
//!   and `roks merge`, written atomically.
//! * [`plot`]: PNG plots with titles, axes and legends (embedded font).
//! * [`render`]: radiance maps of a micro surface (EXR, PNG preview).
#![forbid(unsafe_code)]

pub mod cli;
pub mod export;
pub mod fit;
pub mod geometry;
pub mod limits;
pub mod micro;
pub mod object;
pub mod optics;
pub mod outdir;
pub mod output;
pub mod plot;
pub mod render;
pub mod scene;
pub mod shard;
pub mod tally;
pub mod transport;
