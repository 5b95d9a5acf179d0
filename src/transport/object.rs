//! Photon histories through a 3-D object, and the run over beam positions
//! (`roks trace`).
//!
//! A photon starts on its beam's disc and flies until it enters a solid zone;
//! there the wall model of the surface it crosses reflects it (or absorbs
//! it), and it flies on from the hit point, standing on that surface, until
//! it meets no solid: it then escapes. Escaping after at least one reflection
//! counts as reflected (tallied on the full-sphere far-field grid); escaping
//! without any is `missed`. Weight removed at a wall is tallied as absorbed
//! by that surface. Photon `n` of position `k` draws from the stream
//! `(seed, k 2^40 + n)`. Each position's batches of [`BATCH`] photons are
//! summed over the fixed batch tree of [`crate::tally::sum`], so results
//! are bit-identical for any thread count and any shard split: a shard
//! (`roks trace --shard I/N`, [`shard_blocks`]) traces a block of whole
//! batches and keeps the complete tree nodes ([`ObjectRun::run_nodes`]),
//! which `roks merge` adds into the single run's root.
//!
//! **Polarisation.** With [`ObjectRun::polarisation`] the photon carries a
//! Stokes vector ([`Polarised<1>`]) launched with its beam's state about
//! [`Beam::reference`]; otherwise the scalar weight (`f64`, the unpolarised
//! approximation beyond one Fresnel bounce). The reflectance, far field and
//! absorbed shares are the intensity `S0` either way. A polarised run also
//! sums the Stokes vector of the reflected light, each photon's expressed
//! about `hemisphere_reference(dir, 0)` of its own exit direction `dir`
//! ([`stokes_reference`]; below the horizon too), per unit beam power, and
//! with [`ObjectRun::farfield_stokes`] per far-field cell.
//!
//! **Wavelengths.** With [`ObjectRun::wavelengths_um`] the photon carries a
//! lane per wavelength ([`Spectral`]): one path, each lane weighted by its
//! wavelength's model ([`crate::optics::material::Reflectance::lane`]; a
//! BRDF table and ideal walls apply to every wavelength alike). Every tally
//! is kept per wavelength: reflected, missed, absorbed per surface, lost,
//! far field and Stokes sums; the counts (photons, bounces, segments) are
//! the path's, the same in every lane. Russian roulette plays on the
//! largest lane and scales every lane alike, so it is unbiased at each
//! wavelength. [`ObjectRun::trace`] then returns one [`PositionResult`] per
//! beam position and wavelength, position-major. With a model that is the
//! same at every wavelength each lane is the monochrome run bit for bit.

use std::time::Instant;

use glam::DVec3;
use rand::RngExt;

use crate::tally::sum::BATCH;

use super::carrier::{Carrier, Polarised, Spectral, SpectralPolarised};
use super::micro::Controls;
use super::rng::Streams;
use super::wall::{Interaction, WallModel};
use crate::micro::Scratch;
use crate::object::Object;
use crate::object::source::Beam;
use crate::optics::polarisation::{Stokes, hemisphere_reference};
use crate::shard::{Shard, ShardError};
use crate::tally::Merge;
use crate::tally::carlson::Cells;
use crate::tally::sum::{DyadicSum, Node, TreeError};
use crate::tally::{Accumulator, CarlsonGrid};

/// A far-field grid over the full sphere: the Carlson hemisphere grid for
/// `z > 0` and its mirror image for `z < 0` (Carlson cell `i + n_cells`).
#[derive(Debug, Clone, Copy)]
pub struct FarField {
    /// The hemisphere grid.
    pub grid: CarlsonGrid,
}

impl FarField {
    /// Number of cells over the sphere.
    #[must_use]
    pub fn n_cells(&self) -> usize {
        2 * self.grid.n_cells()
    }

    /// The cells of a unit direction over the sphere, the share of its
    /// weight each gets and the offset to add to them: the upper grid for
    /// `z >= 0` (exactly horizontal goes up), the mirrored grid below
    /// (offset `n_cells` of the hemisphere); at a pole shared among band 1's
    /// cells (see [`CarlsonGrid::cells_of`]).
    fn cells_of(&self, dir: DVec3) -> (Cells, f64, usize) {
        if dir.z >= 0.0 {
            let up = if dir.z == 0.0 {
                DVec3::new(dir.x, dir.y, f64::MIN_POSITIVE)
            } else {
                dir
            };
            let (cells, share) = self.grid.cells_of(up);
            (cells, share, 0)
        } else {
            let (cells, share) = self.grid.cells_of(DVec3::new(dir.x, dir.y, -dir.z));
            (cells, share, self.grid.n_cells())
        }
    }

    /// Score weight `w` of a unit direction into `acc` (one bin per cell).
    pub fn score(&self, acc: &mut Accumulator, dir: DVec3, w: f64) {
        Self::score_in(acc, &self.cells_of(dir), w);
    }

    /// [`FarField::score`] into the cells of a direction found once.
    fn score_in(acc: &mut Accumulator, (cells, share, offset): &(Cells, f64, usize), w: f64) {
        for &c in cells.as_slice() {
            acc.score(offset + c, share * w);
        }
    }

    /// Score the Stokes vector `s` of a direction into `acc`, into the
    /// cells of the direction found once ([`FarField::cells_of`]), four bins
    /// per cell: bin `4 cell + j` holds `S_j`.
    fn score_stokes_in(
        acc: &mut Accumulator,
        (cells, share, offset): &(Cells, f64, usize),
        s: &Stokes,
    ) {
        for &c in cells.as_slice() {
            for (j, v) in s.iter().enumerate() {
                acc.score(4 * (offset + c) + j, share * v);
            }
        }
    }
}

/// The reference vector the Stokes vector of light leaving along unit `dir`
/// is tallied about: `hemisphere_reference(dir, 0)`, `normalize(ẑ × dir)`
/// (`+y` along `±z`), for directions above and below the horizon alike.
#[must_use]
pub fn stokes_reference(dir: DVec3) -> DVec3 {
    hemisphere_reference(dir, 0.0)
}

/// Wall model of every surface id (`None`: no model).
pub type Walls = Vec<Option<usize>>;

/// What to run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectRun {
    /// Tracing seed.
    pub seed: u64,
    /// Carlson bands of the far field.
    pub bands: usize,
    /// Tally the far field.
    pub farfield: bool,
    /// History limits at the macro level.
    pub controls: Controls,
    /// Polarised transport: photons carry a Stokes vector (see the module
    /// docs); `false`: the scalar weight.
    pub polarisation: bool,
    /// Tally the Stokes vector per far-field cell (with `farfield` and
    /// `polarisation` only).
    pub farfield_stokes: bool,
    /// Vacuum wavelengths (µm) carried by every photon, one lane each
    /// ([`Spectral`]); empty for a monochrome run. The wall models must
    /// have been built at them.
    pub wavelengths_um: Vec<f64>,
}

/// Sums for one beam position (stored exactly in a shard's `tallies.json`:
/// the floating-point sums as [`crate::tally::exact`] numbers).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectTallies {
    /// Photons launched.
    pub photons: u64,
    /// Weight escaping after at least one reflection.
    pub reflected: Accumulator,
    /// Weight escaping without a reflection.
    #[serde(with = "crate::tally::exact")]
    pub missed: f64,
    /// Weight absorbed per surface id.
    pub absorbed: Accumulator,
    /// Far-field weight per full-sphere cell (empty if not tallied).
    pub farfield: Accumulator,
    /// Stokes vector `(S0, S1, S2, S3)` of the light escaping after at least
    /// one reflection, about [`stokes_reference`] of each exit direction
    /// (four bins; empty for scalar runs).
    pub stokes: Accumulator,
    /// The same per far-field cell: bin `4 cell + j` holds `S_j` (empty if
    /// not tallied).
    pub farfield_stokes: Accumulator,
    /// Macro reflections, summed.
    pub bounces: u64,
    /// Straight flights at the macro level.
    pub segments: u64,
    /// Weight cut by caps or guards (macro or inside micro descents).
    #[serde(with = "crate::tally::exact")]
    pub lost: f64,
    /// Histories that hit a surface without a model: their count and the
    /// surface id of the first.
    pub unmodelled: FirstUnmodelled,
    /// Photons whose start point lies inside a solid (not traced; a scene error).
    pub started_inside: u64,
}

impl ObjectTallies {
    /// Zero sums with `n_surfaces` absorbed bins, `farfield_cells` far-field
    /// cells; Stokes bins if `stokes` (4) and `farfield_stokes` (4 per cell).
    #[must_use]
    pub fn new(
        n_surfaces: usize,
        farfield_cells: usize,
        stokes: bool,
        farfield_stokes: bool,
    ) -> Self {
        Self {
            photons: 0,
            reflected: Accumulator::new(1),
            missed: 0.0,
            absorbed: Accumulator::new(n_surfaces),
            farfield: Accumulator::new(farfield_cells),
            stokes: Accumulator::new(if stokes { 4 } else { 0 }),
            farfield_stokes: Accumulator::new(if farfield_stokes {
                4 * farfield_cells
            } else {
                0
            }),
            bounces: 0,
            segments: 0,
            lost: 0.0,
            unmodelled: FirstUnmodelled::default(),
            started_inside: 0,
        }
    }

    /// Size (bytes) of the sums: 16 per bin.
    fn bytes(&self) -> u64 {
        let bins = self.reflected.len()
            + self.absorbed.len()
            + self.farfield.len()
            + self.stokes.len()
            + self.farfield_stokes.len();
        16 * bins as u64
    }

    /// Histories that hit a surface without a model, and the surface id
    /// of the first (`None`: none did).
    #[must_use]
    pub fn unmodelled(&self) -> Option<(u64, usize)> {
        self.unmodelled
            .first()
            .map(|s| (self.unmodelled.count(), s))
    }
}

crate::merge_fields!(ObjectTallies {
    sum photons,
    reflected,
    missed,
    absorbed,
    farfield,
    stokes,
    farfield_stokes,
    bounces,
    segments,
    lost,
    unmodelled,
    started_inside,
});

/// Histories that hit a surface without a model: `.0` their count, `.1`
/// the surface id of the first (meaningful only while `.0 > 0`; read it
/// with [`first`](Self::first)). Merging adds the counts and keeps the
/// first surface of the first tally that has one, so merged batches name
/// the surface a whole run in batch order would.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FirstUnmodelled(pub u64, pub usize);

impl FirstUnmodelled {
    /// One more history hitting `surface`.
    pub fn record(&mut self, surface: usize) {
        if self.0 == 0 {
            self.1 = surface;
        }
        self.0 += 1;
    }

    /// Number of histories.
    #[must_use]
    pub fn count(&self) -> u64 {
        self.0
    }

    /// Surface id of the first history; `None` if there was none.
    #[must_use]
    pub fn first(&self) -> Option<usize> {
        (self.0 > 0).then_some(self.1)
    }
}

impl Merge for FirstUnmodelled {
    fn merge(&mut self, other: &Self) {
        if other.0 > 0 && self.0 == 0 {
            self.1 = other.1;
        }
        self.0 += other.0;
    }
    fn merge_clearing(&mut self, other: &mut Self) {
        self.merge(other);
        *other = Self::default();
    }
}

/// The result of an object trace ([`ObjectRun::trace`]), nested as beam
/// position x wavelength: `position[k].wavelength[l]` is the leaf of beam
/// position `k` (the scene's beams in order) and wavelength `l` (the one
/// lane of a monochrome run).
#[derive(Debug, Clone)]
pub struct ObjectResult {
    /// One entry per beam position.
    pub position: Vec<ByPosition>,
}

/// The results at one beam position.
#[derive(Debug, Clone)]
pub struct ByPosition {
    /// One leaf per wavelength (one for a monochrome run).
    pub wavelength: Vec<PositionResult>,
}

impl ObjectResult {
    /// The leaf of beam position `k` and wavelength `l`.
    ///
    /// # Panics
    /// If an index is out of its axis.
    #[must_use]
    pub fn leaf(&self, k: usize, l: usize) -> &PositionResult {
        &self.position[k].wavelength[l]
    }

    /// The leaves of each beam position, one slice of wavelengths each.
    pub fn groups(&self) -> impl Iterator<Item = &[PositionResult]> {
        self.position.iter().map(|p| p.wavelength.as_slice())
    }

    /// Every leaf in file order: position, then wavelength.
    pub fn iter(&self) -> impl Iterator<Item = &PositionResult> {
        self.groups().flatten()
    }

    /// The roots of a whole run's nodes (as [`ObjectRun::run_nodes`] gives
    /// them: per beam position, per wavelength); `zero` gives the run's
    /// zero sums.
    ///
    /// # Panics
    /// If a leaf's nodes do not cover all its batches (not a whole run).
    #[must_use]
    pub fn roots(nodes: Vec<Vec<PositionNodes>>, zero: &dyn Fn() -> ObjectTallies) -> Self {
        let position = nodes
            .into_iter()
            .map(|lanes| ByPosition {
                wavelength: lanes
                    .into_iter()
                    .map(|p| p.into_root(zero).expect("a whole run covers its batches"))
                    .collect(),
            })
            .collect();
        Self { position }
    }

    /// The leaves in file order, owned.
    #[must_use]
    pub fn into_leaves(self) -> Vec<PositionResult> {
        self.position
            .into_iter()
            .flat_map(|p| p.wavelength)
            .collect()
    }
}

/// The leaf of an [`ObjectResult`]: one beam position (and, in a spectral
/// run, one wavelength).
#[derive(Debug, Clone)]
pub struct PositionResult {
    /// The beam.
    pub beam: Beam,
    /// The wavelength (µm) of these tallies in a spectral run; `None`: monochrome.
    pub wavelength_um: Option<f64>,
    /// Sums.
    pub tallies: ObjectTallies,
    /// Wall-clock time (s).
    pub seconds: f64,
}

impl PositionResult {
    /// Reflectance (fraction of the beam's flux leaving after >= 1 reflection) and its standard error.
    #[must_use]
    pub fn reflectance(&self) -> (f64, f64) {
        let n = self.tallies.photons;
        (
            self.tallies.reflected.mean(0, n),
            self.tallies.reflected.stderr(0, n),
        )
    }

    /// The Stokes vector of the reflected light per unit beam power (see
    /// [`ObjectTallies::stokes`]) and its standard errors; `None` for a scalar run.
    #[must_use]
    pub fn stokes(&self) -> Option<(Stokes, Stokes)> {
        let (acc, n) = (&self.tallies.stokes, self.tallies.photons);
        (!acc.is_empty()).then(|| {
            (
                std::array::from_fn(|j| acc.mean(j, n)),
                std::array::from_fn(|j| acc.stderr(j, n)),
            )
        })
    }
}

/// The complete batch-tree nodes of one beam position (and, in a spectral
/// run, one wavelength) over a block of its batches: what
/// [`ObjectRun::run_nodes`] returns and a shard stores.
#[derive(Debug, Clone)]
pub struct PositionNodes {
    /// The beam.
    pub beam: Beam,
    /// The wavelength (µm) of a spectral run; `None`: monochrome.
    pub wavelength_um: Option<f64>,
    /// Batches of the whole run at this position (the tree's leaves).
    pub batches: u64,
    /// Complete nodes, in batch order.
    pub nodes: Vec<Node<ObjectTallies>>,
    /// Wall-clock time (s).
    pub seconds: f64,
}

impl PositionNodes {
    /// The result of the whole run at this position: the root of its
    /// tree (`zero`: the run's zero sums, for a position without photons).
    ///
    /// # Errors
    /// When the nodes do not cover every batch (a shard's).
    pub fn into_root(self, zero: &dyn Fn() -> ObjectTallies) -> Result<PositionResult, TreeError> {
        Ok(PositionResult {
            beam: self.beam,
            wavelength_um: self.wavelength_um,
            tallies: root(self.nodes, self.batches, zero)?,
            seconds: self.seconds,
        })
    }
}

/// The root of the batch tree over `batches` batches from its complete
/// `nodes` in batch order (those of one run, or of all shards in shard
/// order); zero sums from `zero` for a position without photons.
///
/// # Errors
/// When the nodes do not follow each other or do not cover every batch.
pub fn root(
    nodes: Vec<Node<ObjectTallies>>,
    batches: u64,
    zero: &dyn Fn() -> ObjectTallies,
) -> Result<ObjectTallies, TreeError> {
    if batches == 0 && nodes.is_empty() {
        return Ok(zero());
    }
    let mut sum = DyadicSum::new(batches);
    for node in nodes {
        sum.push(node, &ObjectTallies::merge)?;
    }
    sum.finish()
}

/// The batches of each beam position that shard `shard` traces, for a run
/// of `photons[k]` photons at position `k`: the positions' batches of
/// [`BATCH`] photons are laid end to end (position-major, `B` in all) and
/// the shard takes the whole batches `[floor(I B / N), floor((I + 1) B /
/// N))` of them, so a beam sweep of many short positions splits as well as
/// one long one. Returns one range of batch indices per position (empty
/// where the shard has none).
///
/// # Errors
/// [`ShardError::TooManyOverPositions`]: fewer batches than shards.
pub fn shard_blocks(
    photons: &[u64],
    shard: Shard,
) -> Result<Vec<std::ops::Range<u64>>, ShardError> {
    let total: u64 = photons
        .iter()
        .fold(0, |a: u64, n| a.saturating_add(n.div_ceil(BATCH)));
    if shard.count > total {
        return Err(ShardError::TooManyOverPositions {
            shards: shard.count,
            batches: total,
        });
    }
    let at = |i: u64| (u128::from(i) * u128::from(total) / u128::from(shard.count)) as u64;
    let (b0, b1) = (at(shard.index), at(shard.index + 1));
    let mut offset = 0_u64;
    Ok(photons
        .iter()
        .map(|n| {
            let batches = n.div_ceil(BATCH);
            let lo = b0.clamp(offset, offset + batches) - offset;
            let hi = b1.clamp(offset, offset + batches) - offset;
            offset += batches;
            lo..hi
        })
        .collect())
}

impl ObjectRun {
    /// The far-field grid.
    #[must_use]
    pub fn farfield_grid(&self) -> FarField {
        FarField {
            grid: CarlsonGrid::new(self.bands).expect("bands >= 1 checked by the scene"),
        }
    }

    /// Number of wavelengths carried (1 for a monochrome run).
    #[must_use]
    pub fn lane_count(&self) -> usize {
        self.wavelengths_um.len().max(1)
    }

    /// The wavelength of lane `l` (`None` for a monochrome run).
    #[must_use]
    pub fn wavelength(&self, l: usize) -> Option<f64> {
        self.wavelengths_um.get(l).copied()
    }

    /// Whether the Stokes vector is tallied per far-field cell.
    #[must_use]
    pub fn tallies_farfield_stokes(&self) -> bool {
        self.farfield && self.farfield_stokes && self.polarisation
    }

    /// Zero sums for this run with `n_surfaces` surfaces: the layout every
    /// batch, tree node and total of the run has.
    #[must_use]
    pub fn tallies(&self, n_surfaces: usize) -> ObjectTallies {
        let ff_cells = if self.farfield {
            self.farfield_grid().n_cells()
        } else {
            0
        };
        ObjectTallies::new(
            n_surfaces,
            ff_cells,
            self.polarisation,
            self.tallies_farfield_stokes(),
        )
    }

    /// Trace every beam, `photons[k]` photons for beam `k`; `progress`
    /// receives photons done. The object level's one transport entry
    /// point: a result per beam position and wavelength.
    pub fn trace(
        &self,
        object: &Object,
        walls: &Walls,
        models: &[WallModel],
        beams: &[Beam],
        photons: &[u64],
        progress: &(dyn Fn(u64) + Sync),
    ) -> ObjectResult {
        let blocks: Vec<_> = photons.iter().map(|n| 0..n.div_ceil(BATCH)).collect();
        let n_surfaces = object.surface_names.len();
        let nodes = self.run_nodes(object, walls, models, beams, photons, &blocks, progress);
        ObjectResult::roots(nodes, &|| self.tallies(n_surfaces))
    }

    /// Trace the batches `blocks[k]` (batch indices, of [`BATCH`] photons)
    /// of beam `k`'s `photons[k]` photons, for every beam, and reduce each
    /// beam's (and wavelength's) batches over the fixed tree: its complete
    /// nodes, per beam position one [`PositionNodes`] per wavelength (one
    /// for a monochrome run). An empty block traces nothing (no nodes).
    #[allow(clippy::too_many_arguments)]
    pub fn run_nodes(
        &self,
        object: &Object,
        walls: &Walls,
        models: &[WallModel],
        beams: &[Beam],
        photons: &[u64],
        blocks: &[std::ops::Range<u64>],
        progress: &(dyn Fn(u64) + Sync),
    ) -> Vec<Vec<PositionNodes>> {
        let spectral = !self.wavelengths_um.is_empty();
        let n_surfaces = object.surface_names.len();
        beams
            .iter()
            .zip(photons)
            .zip(blocks)
            .enumerate()
            .map(|(k, ((beam, &n_photons), block))| {
                let clock = Instant::now();
                let ff = self.farfield_grid();
                let batches = n_photons.div_ceil(BATCH);
                let mut sums: Vec<DyadicSum<ObjectTallies>> = (0..self.lane_count())
                    .map(|_| DyadicSum::new(batches))
                    .collect();
                let bytes = self.lane_count() as u64 * self.tallies(n_surfaces).bytes();
                let position = k as u64;
                // The block's photons, from its first batch's first photon.
                let first = block.start * BATCH;
                let last = (block.end * BATCH).min(n_photons);
                super::parallel_batches(
                    last.saturating_sub(first),
                    bytes,
                    |range| {
                        let range = first + range.start..first + range.end;
                        let args = (object, walls, models, beam, position, &ff, range);
                        match (spectral, self.polarisation) {
                            (false, false) => self.trace_batch::<f64>(args),
                            (false, true) => self.trace_batch::<Polarised<1>>(args),
                            // The smallest capacity that holds the wavelengths.
                            (true, false) => match self.lane_count() {
                                0..=8 => self.trace_batch::<Spectral<f64, 8>>(args),
                                9..=32 => self.trace_batch::<Spectral<f64, 32>>(args),
                                _ => self.trace_batch::<Spectral<f64>>(args),
                            },
                            (true, true) => match self.lane_count() {
                                0..=8 => self.trace_batch::<SpectralPolarised<1, 8>>(args),
                                9..=32 => self.trace_batch::<SpectralPolarised<1, 32>>(args),
                                _ => self.trace_batch::<SpectralPolarised<1>>(args),
                            },
                        }
                    },
                    |b, parts| {
                        for (sum, value) in sums.iter_mut().zip(parts) {
                            sum.push(
                                Node {
                                    level: 0,
                                    index: block.start + b,
                                    value,
                                },
                                &ObjectTallies::merge,
                            )
                            .expect("batches in order");
                        }
                    },
                    progress,
                );
                let seconds = clock.elapsed().as_secs_f64();
                sums.into_iter()
                    .enumerate()
                    .map(|(l, sum)| PositionNodes {
                        beam: *beam,
                        wavelength_um: self.wavelength(l),
                        batches,
                        nodes: sum.into_nodes(),
                        seconds,
                    })
                    .collect()
            })
            .collect()
    }

    /// Trace photons `photons` of beam `position`, carrying `C`: the
    /// tallies of each wavelength (one for a monochrome carrier).
    fn trace_batch<C: Carrier>(
        &self,
        (object, walls, models, beam, position, ff, photons): BatchArgs<'_>,
    ) -> Vec<ObjectTallies> {
        let n_surfaces = object.surface_names.len();
        let lanes = self.lane_count();
        let mut lane_tallies: Vec<ObjectTallies> =
            (0..lanes).map(|_| self.tallies(n_surfaces)).collect();
        let launch = C::launch(beam.polarisation.stokes(), beam.reference(), lanes);
        let mut scratch: Vec<Option<Scratch>> = vec![None; models.len()];
        // Absorbed in this history, per surface and lane (`sid * lanes + l`).
        let mut absorbed = vec![0.0; n_surfaces * lanes];
        let mut is_touched = vec![false; n_surfaces];
        let mut touched: Vec<usize> = Vec::new();
        // The seed is mixed once for the batch; photon `n` of beam position
        // `position` draws from stream `(position << 40) | n` as before.
        let streams = Streams::new(self.seed);
        for n in photons {
            let mut rng = streams.photon((position << 40) | n);
            let p = beam.start(rng.random(), rng.random());
            if object.in_solid(p) {
                for t in &mut lane_tallies {
                    t.photons += 1;
                    t.started_inside += 1;
                }
                continue;
            }
            let end = trace(
                object,
                walls,
                models,
                &self.controls,
                p,
                beam.direction,
                launch,
                &mut rng,
                &mut scratch,
                |sid, l, a| {
                    if !is_touched[sid] {
                        is_touched[sid] = true;
                        touched.push(sid);
                    }
                    absorbed[sid * lanes + l] += a;
                },
            );
            // The far-field cells of an escape, once for every wavelength.
            let cells = match end.fate {
                Fate::Escaped { dir, .. } if end.bounces > 0 && self.farfield => {
                    Some(ff.cells_of(dir))
                }
                _ => None,
            };
            for (l, t) in lane_tallies.iter_mut().enumerate() {
                t.photons += 1;
                match end.fate {
                    Fate::Escaped { dir, weight } => {
                        let weight = weight.lane(l);
                        let intensity = weight.intensity();
                        if end.bounces == 0 {
                            t.missed += intensity;
                        } else {
                            t.reflected.score(0, intensity);
                            if let Some(cells) = &cells {
                                FarField::score_in(&mut t.farfield, cells, intensity);
                            }
                            let mut c = [0.0; 16];
                            if !t.stokes.is_empty()
                                && weight.components(dir, stokes_reference(dir), &mut c) == 4
                            {
                                let s: Stokes = [c[0], c[1], c[2], c[3]];
                                for (j, v) in s.iter().enumerate() {
                                    t.stokes.score(j, *v);
                                }
                                if let (false, Some(cells)) = (t.farfield_stokes.is_empty(), &cells)
                                {
                                    FarField::score_stokes_in(&mut t.farfield_stokes, cells, &s);
                                }
                            }
                        }
                    }
                    Fate::Unmodelled { surface } => {
                        t.unmodelled.record(surface);
                    }
                    Fate::Lost { weight } => t.lost += weight.lane(l).intensity(),
                    Fate::Absorbed => {}
                }
                t.segments += u64::from(end.segments);
                t.bounces += u64::from(end.bounces);
            }
            // One score per surface per history (for the standard errors).
            for sid in touched.drain(..) {
                is_touched[sid] = false;
                for (l, t) in lane_tallies.iter_mut().enumerate() {
                    t.absorbed.score(sid, absorbed[sid * lanes + l]);
                    absorbed[sid * lanes + l] = 0.0;
                }
            }
        }
        lane_tallies
    }
}

/// What [`ObjectRun::trace_batch`] traces: the object, its walls and
/// models, the beam, its position index, the far-field grid and the photons.
type BatchArgs<'a> = (
    &'a Object,
    &'a Walls,
    &'a [WallModel],
    &'a Beam,
    u64,
    &'a FarField,
    std::ops::Range<u64>,
);

/// How a history through an object ended (see [`trace`]); `C` is what
/// the photon carried ([`Carrier`]). Not the micro level's
/// [`super::micro::Fate`]: see [`super::History`] for why they differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fate<C = f64> {
    /// Met no solid any more: leaves to infinity along unit `dir` with `weight`.
    Escaped {
        /// Direction of flight.
        dir: DVec3,
        /// Weight on leaving.
        weight: C,
    },
    /// Weight reached 0 at a wall, or the photon lost the roulette (physics).
    Absorbed,
    /// Hit surface id `surface`, which has no wall model (a scene error; counted).
    Unmodelled {
        /// Global surface id.
        surface: usize,
    },
    /// Cut by the bounce cap, stopped by a numerical guard (degenerate
    /// normal, non-finite direction or position, a wall factor that is not a
    /// finite number >= 0), or lost inside a micro descent.
    Lost {
        /// What the photon carried when lost (the lost intensity of each wavelength).
        weight: C,
    },
}

/// A finished history through an object ([`super::History`] of an object
/// [`Fate`]).
pub type History<C = f64> = super::History<Fate<C>>;

/// Follow one photon (or camera ray, by reciprocity) from `p` along unit `d`
/// through `object`: the one history loop of the macro level, used by
/// `roks trace` and by `roks render` of object scenes. At each wall the
/// model of the surface reflects it; `absorbed(surface id, lane, weight)`
/// receives the weight each wall removes from each wavelength (lane 0 only
/// for a monochrome carrier). `scratch` holds one micro scratch per model.
/// The photon starts carrying `w` (see [`Carrier`]; `1.0` unpolarised).
#[allow(clippy::too_many_arguments)]
pub fn trace<C: Carrier>(
    object: &Object,
    walls: &Walls,
    models: &[WallModel],
    controls: &Controls,
    mut p: DVec3,
    mut d: DVec3,
    mut w: C,
    rng: &mut impl rand::Rng,
    scratch: &mut [Option<Scratch>],
    mut absorbed: impl FnMut(usize, usize, f64),
) -> History<C> {
    let mut standing = None;
    let mut bounces = 0_u32;
    let mut segments = 0_u32;
    let end = |fate, bounces, segments| History {
        fate,
        bounces,
        segments,
    };
    // Cut by the cap or a guard: the intensity carried is reported as lost.
    let lost = |w: &C, bounces, segments| end(Fate::Lost { weight: *w }, bounces, segments);
    loop {
        segments += 1;
        let Some(hit) = object.next_hit(p, d, standing) else {
            return end(Fate::Escaped { dir: d, weight: w }, bounces, segments);
        };
        let sid = object.surface_id(hit.zone, hit.surface);
        let Some(m) = walls[sid] else {
            return end(Fate::Unmodelled { surface: sid }, bounces, segments);
        };
        if bounces >= controls.max_bounces {
            return lost(&w, bounces, segments);
        }
        p += hit.t * d;
        if !p.is_finite() {
            return lost(&w, bounces, segments);
        }
        let quadric = &object.solids[hit.zone].body.surfaces[hit.surface];
        let Some(normal) = quadric.facing_normal(p, d) else {
            return lost(&w, bounces, segments);
        };
        bounces += 1;
        match models[m].interact(d, normal, w.unit(), rng, &mut scratch[m]) {
            Interaction::Reflected { dir, weight } => {
                if !weight.is_valid() {
                    // Also NaN: such a weight never reaches a tally.
                    return lost(&w, bounces, segments);
                }
                w = w.rescaled_lanes(weight, |l, removed| absorbed(sid, l, removed));
                d = dir;
            }
            Interaction::Absorbed => {
                for l in 0..w.lanes() {
                    absorbed(sid, l, w.lane(l).intensity());
                }
                return end(Fate::Absorbed, bounces, segments);
            }
            Interaction::Lost => return lost(&w, bounces, segments),
        }
        // The intensity once (a spectral carrier's is a pass over its
        // wavelengths); a survivor keeping its weight is left as it is.
        let intensity = w.intensity();
        if intensity <= 0.0 {
            return end(Fate::Absorbed, bounces, segments);
        }
        if !d.is_finite() {
            return lost(&w, bounces, segments);
        }
        standing = Some((hit.zone, hit.surface));
        match super::roulette(intensity, controls.roulette_weight, rng) {
            Some(survivor) if survivor == intensity => {}
            Some(survivor) => w.survive(survivor),
            None => return end(Fate::Absorbed, bounces, segments),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shards' blocks tile every position's batches exactly once, in
    /// shard order, and differ in size by at most one batch.
    #[test]
    fn shard_blocks_tile_every_position() {
        let b = BATCH;
        for photons in [vec![1], vec![3 * b, 1, 5 * b - 7, b], vec![b; 40]] {
            let total: u64 = photons.iter().map(|n| n.div_ceil(b)).sum();
            for count in 1..=total {
                let mut next = vec![0_u64; photons.len()];
                let mut sizes = Vec::new();
                for index in 0..count {
                    let blocks = shard_blocks(&photons, Shard { index, count }).unwrap();
                    let mut size = 0;
                    for (k, r) in blocks.iter().enumerate() {
                        if !r.is_empty() {
                            assert_eq!(r.start, next[k], "{photons:?} {index}/{count}");
                            next[k] = r.end;
                        }
                        size += r.end - r.start;
                    }
                    sizes.push(size);
                }
                let full: Vec<u64> = photons.iter().map(|n| n.div_ceil(b)).collect();
                assert_eq!(next, full, "{photons:?} in {count}");
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= 1 && *lo >= 1, "{sizes:?}");
            }
            let over = Shard {
                index: 0,
                count: total + 1,
            };
            assert_eq!(
                shard_blocks(&photons, over),
                Err(ShardError::TooManyOverPositions {
                    shards: total + 1,
                    batches: total
                })
            );
        }
    }

    /// Counts add; the first surface is the first tally's that has one.
    #[test]
    fn first_unmodelled_merges_first_wins() {
        let mut a = FirstUnmodelled::default();
        assert_eq!(a.first(), None);
        let mut b = FirstUnmodelled::default();
        b.record(3);
        b.record(5);
        let mut c = FirstUnmodelled::default();
        c.record(7);
        a.merge(&b);
        a.merge(&c);
        assert_eq!((a.count(), a.first()), (3, Some(3)));
        let mut d = FirstUnmodelled::default();
        d.merge_clearing(&mut c);
        assert_eq!((d, c), (FirstUnmodelled(1, 7), FirstUnmodelled::default()));
    }
}
