//! The shard of a `roks trace` run (`--shard I/N`): its `tallies.json`, read
//! back and merged by `roks merge` into the folder of the single run.
//!
//! # The split
//!
//! Every beam position's photons are cut into batches of [`BATCH`]; the
//! positions' batches are laid end to end and shard `I` of `N` takes a
//! block of whole batches of them ([`shard_blocks`]), so a beam sweep of
//! many short positions splits as well as one long beam. Photon `n` of
//! position `k` draws only from its stream, and every position (and
//! wavelength) sums its batches over the fixed tree of
//! [`crate::tally::sum`]: a shard's complete tree nodes are bit-identical
//! to the single run's, and the merge pushes the nodes of all shards, in
//! shard order, into the same tree.
//!
//! # The file
//!
//! [`TraceTalliesFile`]: `format: "roks-trace-tallies"`, `format_version`,
//! `batch`, the run's [`TraceDescription`] (the scene's content identity,
//! name, path, the run ([`ObjectRun`]), the beams with their photons, the
//! surface names, the roks version and the shard), the total `seconds`,
//! and per beam position (and wavelength, position-major) its `photons` in
//! this shard, `seconds`, `wavelength_um` and `nodes`: `{level, index,
//! tallies}`, the complete tree nodes with their raw sums
//! ([`ObjectTallies`], floating-point sums as [`crate::tally::exact`]
//! strings).
//!
//! # The merge
//!
//! [`read_shard`] trusts nothing: the JSON must have exactly these fields,
//! a valid run, the layout of the run in every node, finite sums, exactly
//! the photons of the batches a node covers, and nodes that tile exactly
//! the shard's own block. [`merge_shards`] refuses shards whose
//! descriptions differ (but for the scene's path and the shard), naming the
//! first field that differs, and needs shards `0..N-1` of one `N`, each
//! once. The merged folder ([`TraceDescription::folder`], the same code as
//! the single run) is byte for byte the single run's but for the times in
//! `summary.json` (the sum of the shards').

use std::ops::Range;
use std::path::Path;

use glam::DVec3;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::summary::{self, PositionSummary, TraceShard, TraceSummary};
use crate::object::source::Beam;
use crate::optics::polarisation::Incident;
use crate::outdir::file::ResultFile;
use crate::scene::{Content, SceneError};
use crate::shard::file::{
    self as shard_file, Contents, FieldError, Leaf, Level, MergedLeaf, NodeFile, TALLIES_FILE,
    typed_plain,
};
use crate::shard::{Shard, ShardError};
use crate::tally::exact::{self, Exact};
use crate::tally::realisable::SUM_TOLERANCE;
use crate::tally::sum::BATCH;
use crate::tally::sum::Node;
use crate::transport::object::{
    ByPosition, ObjectResult, ObjectRun, ObjectTallies, PositionNodes, PositionResult, shard_blocks,
};

/// `format` of a `roks trace` shard's `tallies.json`.
pub const FORMAT: &str = "roks-trace-tallies";
/// `format_version` of it.
pub const FORMAT_VERSION: u64 = 1;

/// One beam position of the run as traced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamEntry {
    /// Beam diameter (scene units).
    pub diameter: f64,
    /// Unit direction of travel.
    pub direction: [f64; 3],
    /// Photons of the whole run at this position.
    pub photons: u64,
    /// The beam's polarisation state.
    pub polarisation: Incident,
    /// A point on the beam axis (scene units).
    pub position: [f64; 3],
}

impl BeamEntry {
    /// The beam as traced.
    #[must_use]
    pub fn beam(&self) -> Beam {
        Beam {
            position: DVec3::from_array(self.position),
            direction: DVec3::from_array(self.direction),
            diameter: self.diameter,
            polarisation: self.polarisation,
        }
    }
}

/// What identifies a `roks trace` run besides its tallies. Shards of one
/// run have equal descriptions but for `scene` (a path) and `shard`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceDescription {
    /// The beam positions, source by source, with their photons.
    pub beams: Vec<BeamEntry>,
    /// The scene's text and the files it reads, hashed.
    pub content: Content,
    /// The scene's `name`.
    pub name: String,
    /// The run as traced (seed, far field, controls, polarisation, wavelengths).
    pub run: ObjectRun,
    /// The scene file as given.
    pub scene: String,
    /// The block of a shard (absent: the whole run).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<TraceShard>,
    /// Surface names by surface id.
    pub surfaces: Vec<String>,
    /// The roks version that ran it.
    pub version: String,
}

impl TraceDescription {
    /// The description of `run` of the scene of `content` given as the file
    /// `scene`, named `name`, with surfaces `surfaces`, beams `beams` of
    /// `photons[k]` photons each, and the block `shard`.
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        content: &Content,
        scene: &str,
        name: &str,
        surfaces: &[String],
        run: &ObjectRun,
        beams: &[Beam],
        photons: &[u64],
        shard: Option<Shard>,
    ) -> Self {
        Self {
            beams: beams
                .iter()
                .zip(photons)
                .map(|(b, &photons)| BeamEntry {
                    diameter: b.diameter,
                    direction: b.direction.to_array(),
                    photons,
                    polarisation: b.polarisation,
                    position: b.position.to_array(),
                })
                .collect(),
            content: content.clone(),
            name: name.to_owned(),
            run: run.clone(),
            scene: scene.to_owned(),
            shard: shard.map(TraceShard::from),
            surfaces: surfaces.to_vec(),
            version: env!("CARGO_PKG_VERSION").to_owned(),
        }
    }

    /// Photons of the whole run per beam position.
    #[must_use]
    pub fn photons(&self) -> Vec<u64> {
        self.beams.iter().map(|b| b.photons).collect()
    }

    /// The batches of each position this run (or shard) traces.
    ///
    /// # Errors
    /// A shard count above the run's batches.
    pub fn blocks(&self) -> Result<Vec<Range<u64>>, ShardError> {
        let photons = self.photons();
        match self.shard {
            Some(s) => shard_blocks(
                &photons,
                Shard {
                    index: s.index,
                    count: s.count,
                },
            ),
            None => Ok(photons.iter().map(|n| 0..n.div_ceil(BATCH)).collect()),
        }
    }

    /// Zero sums of the run's layout.
    fn zero(&self) -> ObjectTallies {
        self.run.tallies(self.surfaces.len())
    }

    /// The `summary.json` of this run (a whole run, a merge or a shard):
    /// one entry per beam position of `result` (a spectral run's averages
    /// its wavelengths), total time `seconds`.
    #[must_use]
    pub fn summary(&self, result: &ObjectResult, seconds: f64) -> TraceSummary {
        let spectral = !self.run.wavelengths_um.is_empty();
        let surface_names = &self.surfaces;
        TraceSummary {
            content: self.content.clone(),
            farfield: self.run.farfield,
            farfield_stokes: self.run.tallies_farfield_stokes(),
            name: self.name.clone(),
            scene: self.scene.clone(),
            seconds,
            seed: self.run.seed,
            shard: self.shard,
            sources: result
                .groups()
                .map(|lanes| match lanes {
                    [one] if !spectral => PositionSummary::new(one, surface_names),
                    _ => PositionSummary::spectral(lanes, surface_names),
                })
                .collect(),
            version: self.version.clone(),
            wavelengths_um: self.run.wavelengths_um.clone(),
        }
    }

    /// The result folder's files for `result` (the roots, or a shard's
    /// partial sums) and total time `seconds`: `reflectance.csv`,
    /// `farfield.csv` and `farfield_stokes.csv` when tallied, and
    /// `summary.json` (the caller adds the pictures,
    /// [`crate::plot::folder::add_pictures`]); a shard (with its `tallies`
    /// file) writes `summary.json` and `tallies.json` only.
    #[must_use]
    pub fn folder(
        &self,
        result: &ObjectResult,
        seconds: f64,
        tallies: Option<TraceTalliesFile>,
    ) -> Vec<(String, Vec<u8>)> {
        let summary = summary::to_text(&self.summary(result, seconds));
        let mut files: Vec<(String, Vec<u8>)> = Vec::new();
        if let Some(t) = tallies {
            files.push((ResultFile::Summary.name().into(), summary.into_bytes()));
            files.push((TALLIES_FILE.into(), t.to_text().into_bytes()));
            return files;
        }
        let run = &self.run;
        files.push((
            ResultFile::Reflectance.name().into(),
            super::object_csv::reflectance_csv(result).into_bytes(),
        ));
        if run.farfield {
            let f = super::object_csv::farfield_csv(run, result);
            files.push((ResultFile::Farfield.name().into(), f.into_bytes()));
        }
        if run.tallies_farfield_stokes() {
            let f = super::object_csv::farfield_stokes_csv(run, result);
            files.push((ResultFile::FarfieldStokes.name().into(), f.into_bytes()));
        }
        files.push((ResultFile::Summary.name().into(), summary.into_bytes()));
        files
    }

    /// Check a description read from a file: a run the tracer can lay out
    /// (bands, wavelengths, the far-field flags), beams with photons, and
    /// a shard within its count and the run's batches.
    fn check(&self) -> Result<(), FieldError> {
        let run = &self.run;
        if !(1..=1000).contains(&run.bands) {
            return Err(FieldError::new(
                "run.bands",
                format!("must be in 1..=1000, got {}", run.bands),
            ));
        }
        if let Some(i) = run
            .wavelengths_um
            .iter()
            .position(|w| !(w.is_finite() && *w > 0.0))
        {
            return Err(FieldError::new(
                format!("run.wavelengths_um[{i}]"),
                "must be a finite number > 0",
            ));
        }
        if run.farfield_stokes && !(run.farfield && run.polarisation) {
            return Err(FieldError::new(
                "run.farfield_stokes",
                "needs farfield and polarisation",
            ));
        }
        if self.beams.is_empty() {
            return Err(FieldError::new("beams", "needs at least one beam position"));
        }
        for (k, b) in self.beams.iter().enumerate() {
            let at = |key: &str, m: &str| Err(FieldError::new(format!("beams[{k}].{key}"), m));
            crate::transport::launch::check_count(b.photons)
                .map_err(|e| FieldError::new(format!("beams[{k}].photons"), e))?;
            if !DVec3::from_array(b.position).is_finite() {
                return at("position", "must be finite");
            }
            if !DVec3::from_array(b.direction).is_normalized() {
                return at("direction", "must be a unit vector");
            }
            if !(b.diameter.is_finite() && b.diameter >= 0.0) {
                return at("diameter", "must be a finite number >= 0");
            }
        }
        if let Some(s) = self.shard {
            if s.count == 0 || s.index >= s.count {
                return Err(FieldError::new(
                    "shard",
                    format!("need 0 <= index < count, got {} of {}", s.index, s.count),
                ));
            }
        }
        self.blocks().map_err(|e| FieldError::new("shard", e))?;
        Ok(())
    }
}

/// One beam position (and wavelength) of a shard's `tallies.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionFile<T = ObjectTallies> {
    /// Complete tree nodes, in batch order.
    pub nodes: Vec<NodeFile<T>>,
    /// Photons of this file at this position.
    pub photons: u64,
    /// Wall-clock time (s).
    #[serde(with = "exact")]
    pub seconds: f64,
    /// Wavelength (µm) of a spectral run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wavelength_um: Option<Exact>,
}

/// The whole `tallies.json` of a `roks trace` shard (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceTalliesFile<T = ObjectTallies> {
    /// Photons per batch ([`BATCH`]).
    pub batch: u64,
    /// The run, with the shard's block.
    pub description: TraceDescription,
    /// [`FORMAT`].
    pub format: String,
    /// [`FORMAT_VERSION`].
    pub format_version: u64,
    /// Per beam position (and wavelength, position-major).
    pub positions: Vec<PositionFile<T>>,
    /// Total wall-clock time (s).
    #[serde(with = "exact")]
    pub seconds: f64,
}

impl TraceTalliesFile {
    /// The file of the run `description` with per position `nodes` and
    /// total time `seconds`.
    #[must_use]
    pub fn new(description: &TraceDescription, nodes: Vec<PositionNodes>, seconds: f64) -> Self {
        Self {
            batch: BATCH,
            description: description.clone(),
            format: FORMAT.to_owned(),
            format_version: FORMAT_VERSION,
            positions: nodes
                .into_iter()
                .map(|p| PositionFile {
                    photons: p.nodes.iter().map(|n| n.value.photons).sum(),
                    nodes: p
                        .nodes
                        .into_iter()
                        .map(|n| NodeFile {
                            index: n.index,
                            level: u64::from(n.level),
                            tallies: n.value,
                        })
                        .collect(),
                    seconds: p.seconds,
                    wavelength_um: p.wavelength_um.map(Exact),
                })
                .collect(),
            seconds,
        }
    }

    /// The file's text: compact JSON and a line end.
    ///
    /// # Panics
    /// Never: every value serialises.
    #[must_use]
    pub fn to_text(&self) -> String {
        serde_json::to_string(self).expect("tallies serialise") + "\n"
    }
}

/// The partial sums of a shard's nodes at each position, added in batch
/// order (not the tree's root: what the shard's own `summary.json`
/// reports, and what the tracer's checks of unmodelled walls look at).
#[must_use]
pub fn partial_results(d: &TraceDescription, nodes: &[Vec<PositionNodes>]) -> ObjectResult {
    use crate::tally::Merge as _;
    let leaf = |p: &PositionNodes| {
        let mut tallies = d.zero();
        for n in &p.nodes {
            tallies.merge(&n.value);
        }
        PositionResult {
            beam: p.beam,
            wavelength_um: p.wavelength_um,
            tallies,
            seconds: p.seconds,
        }
    };
    ObjectResult {
        position: nodes
            .iter()
            .map(|lanes| ByPosition {
                wavelength: lanes.iter().map(leaf).collect(),
            })
            .collect(),
    }
}

/// Whether `dir/tallies.json` is a `roks trace` shard's (its `format`);
/// `false` for any other or unreadable file.
#[must_use]
pub fn is_trace_shard(dir: &Path) -> bool {
    shard_file::is_format::<Object>(dir)
}

/// Check a node's sums against the run: the bins of its layout, exactly
/// `photons` photons, finite sums, non-negative weights.
fn check_node(t: &ObjectTallies, zero: &ObjectTallies, photons: u64) -> Result<(), FieldError> {
    if t.photons != photons {
        return Err(FieldError::new(
            "photons",
            format!("{} is not the {photons} photons of its batches", t.photons),
        ));
    }
    let accs = [
        ("reflected", &t.reflected, &zero.reflected),
        ("absorbed", &t.absorbed, &zero.absorbed),
        ("farfield", &t.farfield, &zero.farfield),
        ("stokes", &t.stokes, &zero.stokes),
        ("farfield_stokes", &t.farfield_stokes, &zero.farfield_stokes),
    ];
    for (name, acc, layout) in accs {
        for (part, v) in [("sum", &acc.sum), ("sum_sq", &acc.sum_sq)] {
            if v.len() != layout.len() {
                return Err(FieldError::new(
                    format!("{name}.{part}"),
                    format!("{} bins, but the run has {}", v.len(), layout.len()),
                ));
            }
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(FieldError::new(
                    format!("{name}.{part}[{i}]"),
                    format!("{} is not a finite number", v[i]),
                ));
            }
        }
        // Weights and squares are >= 0 (Stokes S1..S3 may be negative).
        let signed = |i: usize| name.contains("stokes") && i % 4 != 0;
        if let Some(i) =
            (0..acc.len()).find(|&i| acc.sum_sq[i] < 0.0 || (acc.sum[i] < 0.0 && !signed(i)))
        {
            return Err(FieldError::new(
                format!("{name}.sum[{i}]"),
                "a negative sum of weights",
            ));
        }
    }
    check_stokes_sums(t)?;
    for (name, v) in [("missed", t.missed), ("lost", t.lost)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(FieldError::new(
                name,
                format!("{v} must be a finite number >= 0"),
            ));
        }
    }
    if t.started_inside > photons || t.unmodelled.count() > photons {
        return Err(FieldError::new("started_inside", "more than the photons"));
    }
    if t.unmodelled.count() > 0 && t.unmodelled.1 >= zero.absorbed.len() {
        return Err(FieldError::new("unmodelled", "no such surface id"));
    }
    Ok(())
}

/// Check that the Stokes sums of `t` (the reflected light's, and each
/// far-field cell's: bins `4 cell + j` hold `S_j`) are physical: every
/// history scores a Stokes vector with `S0 >= |S1, S2, S3|`, such vectors
/// form a convex cone, so every sum of them has the same property, within
/// [`SUM_TOLERANCE`] of the sum of its absolute terms (rounding).
///
/// # Errors
/// The first sum with a degree of polarisation above 1, by its key.
fn check_stokes_sums(t: &ObjectTallies) -> Result<(), FieldError> {
    for (name, acc) in [
        ("stokes", &t.stokes),
        ("farfield_stokes", &t.farfield_stokes),
    ] {
        for (cell, v) in acc.sum.chunks_exact(4).enumerate() {
            let pol = (v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt();
            let scale: f64 = v.iter().map(|x| x.abs()).sum();
            if !(v[0] + SUM_TOLERANCE * scale >= pol) {
                return Err(FieldError::new(
                    format!("{name}.sum[{}]", 4 * cell),
                    format!(
                        "S0 = {} < |S1, S2, S3| = {pol}: a degree of polarisation above 1, which no light has",
                        v[0]
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The object level ([`Level`]): `roks trace` runs, their
/// [`TraceTalliesFile`] and [`ObjectResult`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Object;

/// One shard folder's `tallies.json` of a `roks trace` run, read and
/// checked alone.
pub type ShardFile = shard_file::ShardFile<Object>;

/// Shards of one `roks trace` run, checked against each other and summed:
/// per position and wavelength the root of its tree.
pub type Merged = shard_file::Merged<Object>;

impl Level for Object {
    type Description = TraceDescription;
    type Tallies = ObjectTallies;
    type File = TraceTalliesFile<Value>;
    type Result = ObjectResult;

    const FORMAT: &'static str = FORMAT;
    const FORMAT_VERSION: u64 = FORMAT_VERSION;
    const KIND: &'static str = "roks trace tallies file";
    const ENTRIES: &'static str = "positions";
    const DESCRIBED_BY_FIRST_BLOCK: bool = true;

    fn parse(v: Value) -> Result<Self::File, FieldError> {
        typed_plain(v)
    }

    fn batch(file: &Self::File) -> u64 {
        file.batch
    }

    /// A valid description, one entry per position and wavelength of the
    /// run (its wavelength, time and nodes), a total time `>= 0`.
    fn check(t: Self::File) -> Result<Contents<Self>, FieldError> {
        let d = t.description;
        d.check().map_err(|e| e.under("description"))?;
        let lanes = d.run.lane_count();
        if t.positions.len() != d.beams.len() * lanes {
            return Err(FieldError::new(
                "positions",
                format!(
                    "must list the run's {} beam positions x {lanes} wavelengths, found {}",
                    d.beams.len(),
                    t.positions.len()
                ),
            ));
        }
        let blocks = d
            .blocks()
            .map_err(|e| FieldError::new("description.shard", e))?;
        let zero = d.zero();
        // The file lists position, then wavelength.
        let leaves = t
            .positions
            .into_iter()
            .enumerate()
            .map(|(i, p)| {
                let (k, l) = (i / lanes, i % lanes);
                check_position(p, &d, (k, l), &blocks[k], &zero)
                    .map_err(|e| e.under(&format!("positions[{i}]")))
            })
            .collect::<Result<_, _>>()?;
        if t.seconds < 0.0 {
            return Err(FieldError::new("seconds", "must be >= 0"));
        }
        Ok(Contents {
            description: d,
            leaves,
            seconds: t.seconds,
        })
    }

    fn unshard(d: &mut TraceDescription) {
        d.shard = None;
    }

    fn scene_mut(d: &mut TraceDescription) -> &mut String {
        &mut d.scene
    }

    /// By shard index: shards `0..N-1` of one `N`, each once.
    fn order(parts: &mut Vec<ShardFile>) -> Result<(), SceneError> {
        let f0 = parts[0].file.clone();
        let count = parts[0].description.shard.map_or(1, |s| s.count);
        for p in parts.iter() {
            let c = p.description.shard.map_or(1, |s| s.count);
            if c != count {
                return Err(FieldError::new(
                    "description.shard.count",
                    format!("{c} shards, but {f0} is one of {count}"),
                )
                .in_file(&p.file));
            }
        }
        let index = |p: &ShardFile| p.description.shard.map_or(0, |s| s.index);
        parts.sort_by_key(index);
        for (k, w) in parts.windows(2).enumerate() {
            if index(&w[0]) == index(&w[1]) {
                return Err(FieldError::new(
                    "description.shard.index",
                    format!(
                        "shard {} of {count} given twice (also {})",
                        index(&w[1]),
                        w[0].file
                    ),
                )
                .in_file(&parts[k + 1].file));
            }
        }
        let missing: Vec<String> = (0..count)
            .filter(|i| parts.binary_search_by_key(i, index).is_err())
            .take(10)
            .map(|i| i.to_string())
            .collect();
        if !missing.is_empty() {
            return Err(FieldError::new(
                "description.shard",
                format!(
                    "the run has {count} shards; missing: {}",
                    missing.join(", ")
                ),
            )
            .in_file(&f0));
        }
        Ok(())
    }

    fn leaf_batches(d: &TraceDescription, leaf: usize) -> u64 {
        d.beams[leaf / d.run.lane_count()].photons.div_ceil(BATCH)
    }

    fn result(d: &TraceDescription, leaves: Vec<MergedLeaf<ObjectTallies>>) -> ObjectResult {
        let mut leaves = leaves.into_iter();
        let position = d
            .beams
            .iter()
            .map(|beam| ByPosition {
                wavelength: (0..d.run.lane_count())
                    .map(|l| {
                        let leaf = leaves.next().expect("one leaf per lane");
                        PositionResult {
                            beam: beam.beam(),
                            wavelength_um: d.run.wavelength(l),
                            tallies: leaf.tallies,
                            seconds: leaf.seconds,
                        }
                    })
                    .collect(),
            })
            .collect();
        ObjectResult { position }
    }
}

/// Check entry `(k, l)` (beam position, wavelength) of a shard of the run
/// `d`: the run's wavelength, a time `>= 0`, and nodes that tile exactly
/// the shard's batches `block` of the position, each with the layout of
/// `zero` and exactly its batches' photons ([`check_node`]).
///
/// # Errors
/// The first problem, at its key under the entry.
fn check_position(
    p: PositionFile<Value>,
    d: &TraceDescription,
    (k, l): (usize, usize),
    block: &Range<u64>,
    zero: &ObjectTallies,
) -> Result<Leaf<ObjectTallies>, FieldError> {
    if p.wavelength_um.map(|w| w.0.to_bits()) != d.run.wavelength(l).map(f64::to_bits) {
        return Err(FieldError::new(
            "wavelength_um",
            "is not the run's wavelength of this entry",
        ));
    }
    // Exact numbers are finite.
    if p.seconds < 0.0 {
        return Err(FieldError::new("seconds", "must be >= 0"));
    }
    let n_photons = d.beams[k].photons;
    let batches = n_photons.div_ceil(BATCH);
    let mut next = u128::from(block.start);
    let mut nodes = Vec::with_capacity(p.nodes.len());
    for (j, n) in p.nodes.into_iter().enumerate() {
        let at = |e: FieldError| e.under(&format!("nodes[{j}]"));
        let node = Node {
            level: u32::try_from(n.level).unwrap_or(u32::MAX).min(64),
            index: n.index,
            value: (),
        };
        // The start first: a node that starts at `next` has an index
        // within the run (no overflow in its end).
        let follows = node.start() == next;
        let end = if follows {
            node.end().min(u128::from(batches))
        } else {
            0
        };
        if !follows || end > u128::from(block.end) {
            return Err(at(FieldError::new(
                "",
                format!(
                    "tree node ({}, {}) is not the next of this shard's batches [{}, {}) from {next}",
                    n.level, n.index, block.start, block.end
                ),
            )));
        }
        let value: ObjectTallies = typed_plain(n.tallies).map_err(|e| at(e.under("tallies")))?;
        let first = node.start() * u128::from(BATCH);
        let last = (end * u128::from(BATCH)).min(u128::from(n_photons));
        check_node(
            &value,
            zero,
            u64::try_from(last - first).unwrap_or(u64::MAX),
        )
        .map_err(|e| at(e.under("tallies")))?;
        next = end;
        nodes.push(Node {
            level: node.level,
            index: n.index,
            value,
        });
    }
    if next != u128::from(block.end) && block.start < block.end {
        return Err(FieldError::new(
            "nodes",
            format!(
                "cover batches up to {next}, but this shard holds [{}, {})",
                block.start, block.end
            ),
        ));
    }
    Ok(Leaf {
        nodes,
        seconds: p.seconds,
    })
}

/// Read `dir/tallies.json` of a `roks trace` shard: JSON of [`FORMAT`]
/// version [`FORMAT_VERSION`] with the fields of [`TraceTalliesFile`],
/// `batch` = [`BATCH`], a valid description, one entry per position and
/// wavelength of the run, and nodes that tile exactly the shard's block,
/// each with the run's layout and exactly its batches' photons.
///
/// # Errors
/// One [`SceneError`] naming the file and the key (JSON path).
pub fn read_shard(dir: &Path) -> Result<ShardFile, SceneError> {
    shard_file::read_shard::<Object>(dir)
}

/// Merge `roks trace` shard files (any order,
/// [`shard_file::merge_shards`]): equal descriptions (but for the scene's
/// path and the shard, [`shard_file::first_difference`]), shards `0..N-1` of one `N`,
/// each once; the nodes of all shards pushed in shard order into each
/// position's tree: its root is the single run's sum bit for bit.
///
/// # Errors
/// One [`SceneError`] naming the shard file at fault and the key.
pub fn merge_shards(parts: Vec<ShardFile>) -> Result<Merged, SceneError> {
    shard_file::merge_shards(parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stokes_sums_above_full_polarisation_are_refused() {
        // Two far-field cells; fully polarised light (DoP = 1) passes.
        let mut t = ObjectTallies::new(1, 2, true, true);
        for (bin, w) in [(0, 1.0), (1, 0.6), (2, 0.0), (3, 0.8)] {
            t.stokes.score(bin, w);
            t.farfield_stokes.score(4 + bin, w);
        }
        assert!(check_stokes_sums(&t).is_ok());
        // S1 = 1.5 S0 in far-field cell 1: refused, naming its first bin.
        t.farfield_stokes.score(5, 0.9);
        let e = check_stokes_sums(&t).unwrap_err().to_string();
        assert!(e.contains("farfield_stokes.sum[4]"), "{e}");
        assert!(e.contains("degree of polarisation above 1"), "{e}");
        // The reflected light's sum too.
        let mut t = ObjectTallies::new(1, 2, true, false);
        t.stokes.score(0, 1.0);
        t.stokes.score(3, -1.5);
        let e = check_stokes_sums(&t).unwrap_err().to_string();
        assert!(e.contains("stokes.sum[0]"), "{e}");
    }
}
