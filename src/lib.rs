//! roks: Monte Carlo reflection of light from rough surfaces and rough 3-D
//! objects in geometric optics, after the program ROKS-RG (Klass, Shakhovsky,
//! Badyuk, Ulyanov, J. Opt. Technol. 2014).
//!
//! # Using roks as a library
//!
//! The library API is [`api`], re-exported here: load a scene
//! ([`load_micro`], [`load_object`]) with [`Overrides`]; trace it
//! ([`BrdfJob`] to a [`BrdfResult`], [`TraceJob`] to a [`TraceResult`]);
//! write the result folder (`write`) or read one back (`read`) into the
//! same type; take its tables as columns ([`Table::column`], plain `f64`
//! slices for numpy) and the tree's axes (`theta_deg`, `phi_deg`,
//! `wavelengths_um`). Errors are one [`Error`], whose `Display` is the
//! command line's one-line message. The command line calls only this.
//!
//! ```
//! let overrides = roks::Overrides { photons: Some(1024), ..Default::default() };
//! let scene = roks::load_micro(None, &overrides)?;
//! let result = roks::BrdfJob::new(&scene, &roks::BrdfOptions {
//!     stats_resolution: Some(16),
//!     ..Default::default()
//! })?
//! .trace(&|_| {})?;
//! println!("reflectance per incidence: {:?}", result.reflectance());
//! # Ok::<(), roks::Error>(())
//! ```
//!
//! Layout, by physics. The geometry sits at the bottom: [`geometry`] uses
//! no other module, [`micro`] and [`object`] use it and [`optics`], and
//! [`transport`] traces histories through them; [`scene`] builds all of
//! them from files, and the commands put the pieces together.
//! * [`geometry`]: the one geometry kernel (quadrics, CSG regions, rays and
//!   boxes, bodies).
//! * [`optics`]: reflectance models (constant, Fresnel for n + ik, tables),
//!   BRDF tables, the Fresnel reflection and its Mueller matrix
//!   ([`optics::fresnel`]), and polarisation (Stokes vectors, Mueller
//!   matrices, frames).
//! * [`micro`]: the micro level's geometry: one period of an explicit rough
//!   surface (substrate and bumps or bodies, or a height field), its
//!   acceleration grid and its statistics.
//! * [`object`]: the macro level's geometry: a 3-D object of zones bounded
//!   by quadrics, and its beams.
//! * [`transport`]: photon histories at both levels and what a photon
//!   carries (a weight, or a Stokes vector or Mueller matrix with its
//!   frame), the wall models of objects, random streams, launch points,
//!   the BRDF generator.
//! * [`tally`]: angular grids (Carlson, in-plane), Stokes and Mueller tallies,
//!   accumulators with standard errors, adding tallies ([`tally::Merge`]) and
//!   the fixed batch tree every run sums over ([`tally::sum`]).
//! * [`scene`]: TOML scene files, validated with one-line errors.
//! * [`shard`]: splitting a BRDF run across machines in blocks of whole batches
//!   (an object run: [`transport::object::shard_blocks`]).
//! * [`output`]: result files, one submodule per format (`brdf.csv`,
//!   `summary.json`, `tallies.json`, ...), the result folder of `roks brdf`
//!   and `roks merge`, written atomically; [`outdir`]: result folders
//!   replaced whole.
//! * [`export`]: a micro surface as a triangle mesh (binary PLY for Mitsuba 3);
//!   BRDF tables as Zemax tabular BSDF and MERL binary files.
//! * [`render`]: radiance maps of a micro surface or an object (EXR, PNG preview).
//! * [`fit`]: fitting a micro scene to a measured in-plane BRDF (`roks fit`).
//! * [`fit_model`]: analytic BRDF models (ABg, Harvey-Shack, GGX, Beckmann)
//!   fitted to a table (`roks fit-model`).
//! * [`plot`]: PNG plots with titles, axes and legends (embedded font).
//! * [`limits`]: the memory budget (`ROKS_MAX_MEMORY`): sizes estimated before allocating.
//! * [`api`]: the library API over all of these (above).
//! * [`cli`]: the command line: one module per command over shared arguments,
//!   value parsers and one-line messages (the binary only dispatches).
//!
//! # Glossary
//!
//! One word per concept; scene keys and file columns keep their historical
//! names, which the glossary gives where they differ.
//! * **Micro level, macro level**: the rough surface traced explicitly
//!   ([`micro`]), and a 3-D object whose walls may descend into one ([`object`]).
//! * **Period**: the rectangle `[0, Lx] x [0, Ly]` of a micro surface
//!   (`surface.size` in a scene file; some messages still call it the
//!   cell), tiled periodically or closed by walls ([`micro::Edges`]).
//! * **Solid**: at the micro level a body placed in the period: the
//!   substrate (solid 0), a bump, a CSG body, or a **ghost** (a copy of a
//!   body shifted by whole periods, so bumps wrap). At the macro level a
//!   solid zone.
//! * **Relief**: what a micro surface is made of: solids, or a **height
//!   field** (a triangulated periodic grid of heights) ([`micro::Relief`]).
//! * **Facet**: the piece of a micro surface a flight hits or stands on: a
//!   surface of a solid, or a triangle of the height field ([`micro::Facet`]).
//! * **Grid cell**: a cell of the acceleration grid over a period, which
//!   lists the solids whose bounds cross it and their highest point.
//! * **Square**: a rectangle `px x py` of a height field's grid of
//!   vertices, split into two triangles ([`micro::heightfield`]).
//! * **Carlson cell**: a cell of the equal-solid-angle grid of the
//!   hemisphere ([`tally::carlson`]), in bands; one row of `brdf.csv`. A
//!   **far-field cell** is a Carlson cell of either hemisphere of an
//!   object's far field.
//! * **Zone**: a region of an object over its quadrics, `solid` or `void`
//!   (declared by `[[cells]]` in a scene file, after OpenMC; in the code
//!   always a zone).
//! * **Wall**: a surface of an object seen where a photon enters a solid
//!   zone; its **wall model** ([`transport::wall::WallModel`]) reflects the
//!   photon: a **micro descent** into a periodic micro surface, a BRDF
//!   table, ideal specular/diffuse, or specular with a reflectance.
//! * **Launch plane**: `z = top` just above a micro surface's highest
//!   point; photons start on it and escape through it.
//! * **Segment**: one straight flight between two events (a query of the
//!   geometry). **Bounce**: one reflection. **History**: one photon from
//!   launch to its **fate** (escaped, absorbed, or lost with its weight:
//!   capped, numerical guard, absorbing edge wall, unmodelled surface);
//!   [`transport::micro::trace`] and [`transport::object::trace`] give a
//!   `History` whose `Fate` says how it ended.
//! * **Carrier**: what a photon carries ([`transport::carrier`]): a scalar
//!   weight, or a Stokes vector or Mueller matrix with its reference frame.
//! * **Batch**: [`tally::sum::BATCH`] consecutive photons, the unit of
//!   parallel work; batches are summed in index order, so results are
//!   bit-identical for any thread count. **Shard**: a contiguous range of
//!   a BRDF run's batches run on its own and merged exactly (`roks merge`);
//!   its block is [`transport::brdf::ShardRange`], beside the photons of
//!   the whole run in the run's description (an object run's shard: a
//!   block of its positions' batches laid end to end,
//!   [`output::object_tallies`]).
//! * **Run description**: what a BRDF run traces,
//!   [`transport::brdf::BrdfRun`], built once from the scene's `[light]`,
//!   `[tally]` and `[transport]` with the command line's
//!   [`scene::micro::Overrides`] laid over them; with the scene's
//!   [`scene::Content`] (hashes of its text and files), path, name and
//!   statistics it is the [`output::summary::Description`] that
//!   `summary.json` and `tallies.json` hold and `roks merge` compares.
//! * **Result** of a BRDF trace: [`transport::brdf::BrdfResult`], returned
//!   by the micro level's one entry point
//!   [`transport::brdf::BrdfRun::trace_realisations`] (through [`api::BrdfJob`]) and nested
//!   as incidence x light azimuth x wavelength; a **leaf**
//!   ([`transport::brdf::IncidenceResult`]) holds one incidence's,
//!   azimuth's and wavelength's sums and the batch-tree nodes a shard
//!   keeps (a whole run's root once, as the sums). An object trace's result,
//!   [`transport::object::ObjectResult`], is nested as beam position x
//!   wavelength.
//! * **Filter** and **score** (after OpenMC): a filter decides which bins
//!   an escaping photon lands in (Carlson cells, in-plane bin, bounce bin,
//!   replicate), a score what is added there (weight, Stokes, Mueller, per
//!   wavelength).
//! * **Stream**: the random numbers of one photon, from (seed, photon
//!   index) ([`transport::rng`]). **Replicate**: one of the 16 shifted
//!   lattices of a `launch = "lattice"` run ([`transport::launch`]).
//! * **Source**: an object scene's light (`[[sources]]`: a beam over one or
//!   more positions, [`object::source`]); at the micro level the light is
//!   the incidence angles of `[light]`. The file a scene was read from is
//!   its **scene file** ([`scene::SceneFile`]: the name for messages and the
//!   folder its relative paths are read from), never a source.
#![forbid(unsafe_code)]

pub mod api;
pub mod cli;
pub mod export;
pub mod fit;
pub mod fit_model;
pub mod geometry;
pub mod interrupt;
pub mod limits;
pub mod micro;
pub mod num;
pub mod object;
pub mod optics;
pub mod outdir;
pub mod output;
pub mod plot;
pub mod render;
pub mod report;
pub mod scene;
pub mod shard;
pub mod tally;
pub mod transport;

#[cfg(test)]
mod test_streams;

pub use api::{
    BrdfJob, BrdfOptions, BrdfReport, BrdfResult, Error, MicroScene, ObjectScene, Overrides, Table,
    TraceJob, TraceOptions, TraceReport, TraceResult, load_micro, load_object,
};
