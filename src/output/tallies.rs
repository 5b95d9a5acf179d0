//! `tallies.json` of a micro run: the raw sums of a `roks brdf --shard
//! I/N` run (and of `roks merge`), exactly, for merging shards. The file
//! format, the checks both levels share, the content identity and the
//! merge are [`crate::shard::file`]'s; this module is the micro [`Level`]
//! ([`Micro`]): its file layout, its checks and its result tree.
//!
//! # The file
//!
//! [`TalliesFile`]: `format: "roks-tallies"`, `format_version`, `batch`,
//! the run's [`Description`] (equal in all its shards but for the scene's
//! path and `run.shard`, the block of photons the file holds), the total
//! `seconds`, and per incidence angle (and light azimuth, and wavelength:
//! incidence-major, then azimuth, then wavelength) `theta_deg`, `phi_deg`
//! (only in a run with several light azimuths), `wavelength_um` (only in a
//! spectral run), `photons`, `seconds` and `nodes`:
//! `{level, index, tallies}`, the complete nodes of the batch tree
//! ([`crate::tally::sum`]) with their raw sums ([`BrdfTallies`], serialised
//! field by field). Keys are written in alphabetical order. The sums'
//! floating-point numbers are decimal strings ([`crate::tally::exact`]),
//! the description's are JSON numbers in their shortest round-trip form:
//! both read back bit for bit. Angles are in degrees, wavelengths in µm,
//! times in seconds.
//!
//! # Reading it back
//!
//! `roks merge` ([`read_shard`], [`merge_shards`]) trusts nothing in the
//! file: it must be JSON of [`FORMAT`] version [`FORMAT_VERSION`] with the
//! fields of [`TalliesFile`] and no others; the description must hold a
//! valid run (the scene's run checks, [`BrdfRun::check`]) and be the same
//! in every shard (compared field by field, [`first_difference`](crate::shard::file::first_difference)), every
//! tally must have the run's layout and its numbers be within what the
//! photon count allows ([`check_tallies`]), each tree node must hold
//! exactly the photons of its batches, and each shard's nodes must tile
//! exactly its own photon range. Errors are one [`SceneError`] naming the
//! shard's `tallies.json` and the JSON path of the value, e.g.
//! `sh1/tallies.json: incidence[0].nodes[2].tallies.carlson.sum[5]: NaN is
//! not a finite number`.
//!
//! # Determinism
//!
//! A shard holds the photons `[first, last)` of block `I` of `N` of every
//! leaf ([`Shard::photon_range`]: whole batches); its complete tree nodes
//! are the single run's, and the merge pushes them in photon order into
//! the same tree, so any split gives the single run's sums bit for bit.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::summary::Description;
use crate::scene::SceneError;
use crate::scene::keys::RunField;
use crate::shard::Shard;
use crate::shard::file::{self as shard_file, Contents, Leaf, Level, MergedLeaf, typed};
use crate::shard::file::{FieldError, NodeFile};
use crate::tally::exact::{self, Exact};
use crate::tally::sum::BATCH;
use crate::tally::sum::Node;
use crate::tally::{Accumulator, PolarTally};
use crate::transport::brdf::{
    BOUNCE_BINS, BrdfResult, BrdfRun, BrdfTallies, ByAzimuth, ByIncidence, IncidenceResult,
};

/// `format` of `tallies.json`.
pub const FORMAT: &str = "roks-tallies";
/// `format_version` of `tallies.json`.
pub const FORMAT_VERSION: u64 = 1;

/// One incidence angle of `tallies.json` (of a spectral run: one
/// incidence angle and wavelength, incidence-major).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IncidenceNodes<T = BrdfTallies> {
    /// Complete tree nodes, in batch order.
    pub nodes: Vec<NodeFile<T>>,
    /// Photons of this file at this angle.
    pub photons: u64,
    /// Light azimuth (degrees) of a run with several (absent with one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phi_deg: Option<Exact>,
    /// Wall-clock time (s).
    #[serde(with = "exact")]
    pub seconds: f64,
    /// Incidence polar angle (degrees).
    #[serde(with = "exact")]
    pub theta_deg: f64,
    /// Wavelength (µm) of a spectral run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wavelength_um: Option<Exact>,
}

/// The whole `tallies.json` (see the module docs), with node sums `T`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TalliesFile<T = BrdfTallies> {
    /// Photons per batch ([`BATCH`]).
    pub batch: u64,
    /// The run (with the block of photons held, `run.shard`).
    pub description: Description,
    /// [`FORMAT`].
    pub format: String,
    /// [`FORMAT_VERSION`].
    pub format_version: u64,
    /// Per incidence angle of the run.
    pub incidence: Vec<IncidenceNodes<T>>,
    /// Total wall-clock time (s).
    #[serde(with = "exact")]
    pub seconds: f64,
}

impl TalliesFile {
    /// The file of the run `description` (its photons
    /// [`BrdfRun::photon_range`]): the nodes of each leaf of `results` in
    /// file order (incidence-major, then azimuth, then wavelength), with total time
    /// `seconds`.
    #[must_use]
    pub fn new(description: &Description, results: &BrdfResult, seconds: f64) -> Self {
        Self {
            batch: BATCH,
            description: description.clone(),
            format: FORMAT.to_owned(),
            format_version: FORMAT_VERSION,
            incidence: results
                .iter()
                .map(|leaf| (leaf, leaf.tree_nodes(&description.run)))
                .map(|(leaf, nodes)| IncidenceNodes {
                    photons: nodes.iter().map(|n| n.value.photons).sum(),
                    nodes: nodes
                        .iter()
                        .map(|n| NodeFile {
                            index: n.index,
                            level: u64::from(n.level),
                            tallies: n.value.clone(),
                        })
                        .collect(),
                    phi_deg: (description.run.phi_deg.len() > 1).then_some(Exact(leaf.phi_i_deg)),
                    seconds: leaf.seconds,
                    theta_deg: leaf.theta_i_deg,
                    wavelength_um: leaf.wavelength_um.map(Exact),
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

/// Check that tallies read from a file have the layout of `run`: its
/// Carlson cells, in-plane bins, bounce bins, replicates of its launch and
/// polarisation tally, and `photons` photons.
///
/// # Errors
/// The first mismatch, at its key.
pub fn check_layout(t: &BrdfTallies, run: &BrdfRun, photons: u64) -> Result<(), FieldError> {
    if t.photons != photons {
        return Err(FieldError::new(
            "photons",
            format!("{} is not the {photons} photons of its batches", t.photons),
        ));
    }
    let cells = run.grid().n_cells();
    let bins = run.inplane().n_bins();
    let expected_replicates = run.launch.replicates();
    let replicates = t.replicates.as_ref().map(|r| r.count);
    if replicates.map(|k| k as u64) != expected_replicates {
        return Err(FieldError::new(
            "replicates",
            match expected_replicates {
                Some(k) => format!("a lattice run needs {{count: {k}, ...}}"),
                None => "must be null for a random launch".into(),
            },
        ));
    }
    let len = |xs: &[f64], key: &str, n: usize| -> Result<(), FieldError> {
        if xs.len() == n {
            Ok(())
        } else {
            Err(FieldError::new(
                key,
                format!("{} values, expected {n}", xs.len()),
            ))
        }
    };
    let acc = |a: &Accumulator, key: &str, n: usize| -> Result<(), FieldError> {
        len(&a.sum, &format!("{key}.sum"), n)?;
        len(&a.sum_sq, &format!("{key}.sum_sq"), n)
    };
    match (run.polarisation.tally, &t.polar) {
        (PolarTally::None, None) => {}
        (PolarTally::None, Some(_)) => {
            return Err(FieldError::new("polar", "not expected for this run"));
        }
        (_, None) => return Err(FieldError::new("polar", "missing")),
        (kind, Some(p)) => {
            let k = kind.components();
            if p.components != k {
                return Err(FieldError::new("polar.components", format!("expected {k}")));
            }
            let polar_bins = k * (1 + cells);
            acc(&p.sums, "polar.sums", polar_bins)?;
            len(&p.cross, "polar.cross", polar_bins)?;
            match (replicates, &p.replicates) {
                (None, None) => {}
                (Some(r), Some(x)) => len(x, "polar.replicates", r * polar_bins)?,
                _ => {
                    return Err(FieldError::new(
                        "polar.replicates",
                        "does not match `replicates`",
                    ));
                }
            }
        }
    }
    acc(&t.reflected, "reflected", 1)?;
    acc(&t.carlson, "carlson", cells)?;
    acc(&t.inplane, "inplane", bins)?;
    len(&t.by_bounces, "by_bounces", BOUNCE_BINS)?;
    if let Some(r) = &t.replicates {
        len(&r.reflected, "replicates.reflected", r.count)?;
        len(&r.carlson, "replicates.carlson", r.count * cells)?;
        len(&r.inplane, "replicates.inplane", r.count * bins)?;
    }
    Ok(())
}

/// Relative slack of the bounds in [`check_tallies`] for the rounding of
/// sums of many terms (a tampered number is off by far more).
const SUM_TOL: f64 = 1e-6;

/// The bounds of [`check_tallies`] for a tally of `photons` photons.
struct Bounds {
    /// The photons, as a number.
    n: f64,
    /// The photons with the rounding slack: the largest sum of weights.
    most: f64,
    /// The photons.
    photons: u64,
}

impl Bounds {
    fn new(photons: u64) -> Self {
        let n = photons as f64;
        Self {
            n,
            most: n * (1.0 + SUM_TOL) + 1e-12,
            photons,
        }
    }

    /// A weight sum (`signed`: a polarisation sum, `|x| <= n`) at `key`.
    fn value(&self, x: f64, key: String, signed: bool) -> Result<(), FieldError> {
        if !signed && x < 0.0 {
            return Err(FieldError::new(key, format!("{x} must be >= 0")));
        }
        if x.abs() > self.most {
            return Err(FieldError::new(
                key,
                format!(
                    "{x} exceeds the {} photons of the tally (each photon carries a weight of at most 1)",
                    self.photons
                ),
            ));
        }
        Ok(())
    }

    /// Every value of `xs`, at `key[i]`.
    fn values(&self, xs: &[f64], key: &str, signed: bool) -> Result<(), FieldError> {
        for (i, &x) in xs.iter().enumerate() {
            self.value(x, format!("{key}[{i}]"), signed)?;
        }
        Ok(())
    }

    /// The sums and sums of squares of an accumulator at `key`.
    fn accumulator(&self, a: &Accumulator, key: &str, signed: bool) -> Result<(), FieldError> {
        for (i, (&s, &q)) in a.sum.iter().zip(&a.sum_sq).enumerate() {
            self.value(s, format!("{key}.sum[{i}]"), signed)?;
            self.value(q, format!("{key}.sum_sq[{i}]"), false)?;
            if !signed && q > s * (1.0 + SUM_TOL) + 1e-300 {
                return Err(FieldError::new(
                    format!("{key}.sum_sq[{i}]"),
                    format!("{q} exceeds the sum {s} (scores of at most 1 have x² <= x)"),
                ));
            }
            if s * s > self.n * q * (1.0 + SUM_TOL) + 1e-300 {
                return Err(FieldError::new(
                    format!("{key}.sum_sq[{i}]"),
                    format!(
                        "{q} is too small for the sum {s} over {} photons (sum² <= photons × sum_sq)",
                        self.photons
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The bounds every tally of a run obeys, with `n` its photons: each
/// history scores a weight in `[0, 1]` (photons start with weight 1 and no
/// reflection, roulette survival or symmetry fold makes it larger), so per
/// bin of `reflected`, `carlson` and `inplane`: `0 <= sum <= n`,
/// `0 <= sum_sq <= sum` (`x² <= x`) and `sum² <= n sum_sq` (Cauchy-Schwarz);
/// polarisation sums alike with `|sum| <= n` (`|s_i| <= s0`); `by_bounces`,
/// the lost weights and the replicate sums in `[0, n]` (polarisation
/// replicates `|x| <= n`); reflected plus lost weight at most `n`; counted
/// histories at most `n`; `bounces <= n max_bounces`, `segments <= n
/// max_segments`. All up to `SUM_TOL` (1e-6) relative.
///
/// # Errors
/// The first value out of bounds, at its key.
pub fn check_tallies(t: &BrdfTallies, run: &BrdfRun) -> Result<(), FieldError> {
    let b = Bounds::new(t.photons);
    b.accumulator(&t.reflected, "reflected", false)?;
    b.accumulator(&t.carlson, "carlson", false)?;
    b.accumulator(&t.inplane, "inplane", false)?;
    b.values(&t.by_bounces, "by_bounces", false)?;
    for (x, key) in [
        (t.lost_walls, "lost_walls"),
        (t.lost_cap, "lost_cap"),
        (t.lost_numeric, "lost_numeric"),
    ] {
        b.value(x, key.into(), false)?;
    }
    let spent = t.reflected.sum[0] + t.lost_walls + t.lost_cap + t.lost_numeric;
    if spent > b.most {
        return Err(FieldError::new(
            "reflected.sum[0]",
            format!(
                "reflected plus lost weight {spent} exceeds the {} photons launched",
                t.photons
            ),
        ));
    }
    check_counts(t, run)?;
    if let Some(r) = &t.replicates {
        b.values(&r.reflected, "replicates.reflected", false)?;
        b.values(&r.carlson, "replicates.carlson", false)?;
        b.values(&r.inplane, "replicates.inplane", false)?;
    }
    if let Some(p) = &t.polar {
        b.accumulator(&p.sums, "polar.sums", true)?;
        if let Some(r) = &p.replicates {
            b.values(r, "polar.replicates", true)?;
        }
        b.values(&p.cross, "polar.cross", true)?;
    }
    Ok(())
}

/// The counts of [`check_tallies`]: capped and numeric histories at most
/// the photons, bounces and segments at most the photons times the run's
/// caps.
fn check_counts(t: &BrdfTallies, run: &BrdfRun) -> Result<(), FieldError> {
    for (x, key) in [
        (t.capped_histories, "capped_histories"),
        (t.numeric_histories, "numeric_histories"),
    ] {
        if x > t.photons {
            return Err(FieldError::new(
                key,
                format!("{x} histories of {} photons", t.photons),
            ));
        }
    }
    let c = &run.controls;
    for (x, cap, key, what) in [
        (t.bounces, c.max_bounces, "bounces", "max_bounces"),
        (t.segments, c.max_segments, "segments", "max_segments"),
    ] {
        if u128::from(x) > u128::from(t.photons) * u128::from(cap) {
            return Err(FieldError::new(
                key,
                format!("{x} exceeds {} photons × {what} {cap}", t.photons),
            ));
        }
    }
    Ok(())
}

/// The tree nodes of one incidence of a file, checked for `run` (all its
/// photons): each node of the tree over the run's batches, with a
/// polarisation tally if the run has one, sums of the types of
/// [`BrdfTallies`], the layout of the run ([`check_layout`]), exactly the
/// photons of the batches it covers, and numbers within [`check_tallies`].
///
/// # Errors
/// On a malformed node, at its key (`[k].tallies.photons`, ...).
pub fn checked_nodes(
    nodes: Vec<NodeFile<Value>>,
    run: &BrdfRun,
) -> Result<Vec<Node<BrdfTallies>>, FieldError> {
    let batches = run.photons.div_ceil(BATCH);
    let root_level = batches.max(1).next_power_of_two().trailing_zeros();
    nodes
        .into_iter()
        .enumerate()
        .map(|(k, n)| {
            let at = format!("[{k}]");
            if n.level > u64::from(root_level) {
                return Err(FieldError::new(
                    format!("{at}.level"),
                    format!(
                        "{} is above the root level {root_level} of the run's {batches} batches",
                        n.level
                    ),
                ));
            }
            let tallies_at = format!("{at}.tallies");
            let polar = n.tallies.get("polar").is_some();
            match (run.polarisation.tally, polar) {
                (PolarTally::None, true) => {
                    return Err(FieldError::new(
                        format!("{tallies_at}.polar"),
                        "not expected for this run",
                    ));
                }
                (PolarTally::Stokes | PolarTally::Mueller, false) => {
                    return Err(FieldError::new(format!("{tallies_at}.polar"), "missing"));
                }
                _ => {}
            }
            let value: BrdfTallies = typed(n.tallies).map_err(|e| e.under(&tallies_at))?;
            let node = Node {
                level: n.level as u32, // <= 64
                index: n.index,
                value,
            };
            if node.start() >= u128::from(batches) {
                return Err(FieldError::new(
                    format!("{at}.index"),
                    format!(
                        "tree node ({}, {}) lies past the run's {batches} batches",
                        node.level, node.index
                    ),
                ));
            }
            let first = node.start() * u128::from(BATCH);
            let last = (node.end() * u128::from(BATCH)).min(u128::from(run.photons));
            let photons = u64::try_from(last - first).unwrap_or(u64::MAX);
            check_layout(&node.value, run, photons)
                .and_then(|()| check_tallies(&node.value, run))
                .map_err(|e| e.under(&tallies_at))?;
            Ok(node)
        })
        .collect()
}

/// The micro level ([`Level`]): `roks brdf` runs, their [`TalliesFile`]
/// and [`BrdfResult`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Micro;

/// One shard folder's `tallies.json` of a `roks brdf` run, read and
/// checked alone.
pub type ShardFile = shard_file::ShardFile<Micro>;

/// Shards of one `roks brdf` run, checked against each other and summed:
/// the whole run's sums, each leaf's one node its tree's root and its time
/// the sum of the shards' times (s).
pub type Merged = shard_file::Merged<Micro>;

impl Level for Micro {
    type Description = Description;
    type Tallies = BrdfTallies;
    type File = TalliesFile<Value>;
    type Result = BrdfResult;

    const FORMAT: &'static str = FORMAT;
    const FORMAT_VERSION: u64 = FORMAT_VERSION;
    const KIND: &'static str = "roks tallies file";
    const ENTRIES: &'static str = "incidence";
    const DESCRIBED_BY_FIRST_BLOCK: bool = false;

    fn batch(file: &Self::File) -> u64 {
        file.batch
    }

    /// A valid run ([`BrdfRun::check`]), the block `--shard I/N` gives, a
    /// time `>= 0`, and one entry per leaf of the run (its angles, time and nodes).
    fn check(file: Self::File) -> Result<Contents<Self>, FieldError> {
        let run = &file.description.run;
        run.check().map_err(|e| {
            FieldError::new(
                format!("description.run.{}", RunField::of(&e).run_key()),
                e.to_string(),
            )
        })?;
        check_block(run)?;
        let seconds = check_seconds(file.seconds)?;
        check_leaf_count(run, file.incidence.len())?;
        let leaves = file
            .incidence
            .into_iter()
            .enumerate()
            .map(|(i, inc)| {
                check_leaf(inc, i, run).map_err(|e| e.under(&format!("incidence[{i}]")))
            })
            .collect::<Result<_, _>>()?;
        Ok(Contents {
            description: file.description,
            leaves,
            seconds,
        })
    }

    fn unshard(d: &mut Description) {
        d.run.shard = None;
    }

    fn scene_mut(d: &mut Description) -> &mut String {
        &mut d.scene
    }

    /// By photon range, which must tile the run in whole batches.
    fn order(parts: &mut Vec<ShardFile>) -> Result<(), SceneError> {
        let total = parts.first().map_or(0, |p| p.description.run.photons);
        parts.sort_by_key(photons);
        check_tiling(parts, total)
    }

    fn leaf_batches(d: &Description, _leaf: usize) -> u64 {
        d.run.photons.div_ceil(BATCH)
    }

    /// Several realisations: the shards' nodes (each within one
    /// realisation's block) make the sums of each.
    fn keeps_nodes(d: &Description) -> bool {
        d.run.realisations > 1
    }

    /// The intersection tests, which must add up within 2^64.
    fn add_counts(count: &mut u64, t: &BrdfTallies) -> Result<(), FieldError> {
        *count = count.checked_add(t.intersection_tests).ok_or_else(|| {
            FieldError::new(
                "tallies.intersection_tests",
                "the shards' counts add up past 2^64",
            )
        })?;
        Ok(())
    }

    /// The roots nested as a trace's result (incidence, azimuth,
    /// wavelength), with the realisations' sums of a run of several.
    fn result(d: &Description, leaves: Vec<MergedLeaf<BrdfTallies>>) -> BrdfResult {
        let run = &d.run;
        let lanes = run.lane_count();
        let mut leaves = leaves.into_iter();
        let incidence = run
            .theta_deg
            .iter()
            .map(|&theta| ByIncidence {
                theta_i_deg: theta,
                azimuth: run
                    .phi_deg
                    .iter()
                    .map(|&phi| ByAzimuth {
                        phi_i_deg: phi,
                        wavelength: (0..lanes)
                            .map(|l| {
                                let leaf = leaves.next().expect("one leaf per lane");
                                incidence_result(run, theta, phi, l, leaf)
                            })
                            .collect(),
                    })
                    .collect(),
            })
            .collect();
        BrdfResult { incidence }
    }
}

/// The merged leaf of incidence `theta`, light azimuth `phi` (degrees) and
/// lane `l` of `run`.
fn incidence_result(
    run: &BrdfRun,
    theta: f64,
    phi: f64,
    l: usize,
    leaf: MergedLeaf<BrdfTallies>,
) -> IncidenceResult {
    let (realisations, ensemble) = run.realisation_results(theta, phi, &leaf.nodes, &leaf.tallies);
    IncidenceResult {
        theta_i_deg: theta,
        phi_i_deg: phi,
        wavelength_um: run.wavelength(l),
        // The root is kept once, as the sums.
        nodes: Vec::new(),
        tallies: leaf.tallies,
        seconds: leaf.seconds,
        realisations,
        ensemble,
    }
}

/// Photon indices `[first, last)` a shard holds.
fn photons(p: &ShardFile) -> (u64, u64) {
    let r = p.description.run.photon_range();
    (r.start, r.end)
}

/// Read `dir/tallies.json` of a `roks brdf` shard: JSON of [`FORMAT`]
/// version [`FORMAT_VERSION`] with the fields of [`TalliesFile`], `batch` =
/// [`BATCH`], a valid run ([`BrdfRun::check`]), for a shard the block
/// `--shard I/N` gives, and the run's leaves (angles, times, nodes).
///
/// # Errors
/// One [`SceneError`] naming the file and the key.
pub fn read_shard(dir: &std::path::Path) -> Result<ShardFile, SceneError> {
    shard_file::read_shard::<Micro>(dir)
}

/// Merge the shard files of one `roks brdf` run (any order,
/// [`shard_file::merge_shards`]): equal descriptions (but for the scene's
/// path and the shard, [`first_difference`](crate::shard::file::first_difference)) and photon ranges that tile
/// the run in whole batches. The nodes of all shards are pushed in photon
/// order into one tree per leaf: its root is the single run's sum bit for
/// bit.
///
/// # Errors
/// One [`SceneError`] naming the shard file at fault and the key (JSON
/// path) of the value.
pub fn merge_shards(parts: Vec<ShardFile>) -> Result<Merged, SceneError> {
    shard_file::merge_shards(parts)
}

/// For a shard, that `run.shard` is the block of photons `--shard I/N`
/// gives.
fn check_block(run: &BrdfRun) -> Result<(), FieldError> {
    let Some(s) = run.shard else {
        return Ok(());
    };
    let block = Shard {
        index: s.index,
        count: s.count,
    };
    let expected = (s.count > 0 && s.index < s.count)
        .then(|| block.photon_range(run.photons).ok())
        .flatten();
    if expected != Some((s.first_photon, s.last_photon)) {
        return Err(FieldError::new(
            "description.run.shard",
            format!(
                "photons [{}, {}) are not block {} of {} of the run's {} photons",
                s.first_photon, s.last_photon, s.index, s.count, run.photons
            ),
        ));
    }
    Ok(())
}

/// That a file lists `n` leaves, those of `run`.
fn check_leaf_count(run: &BrdfRun, n: usize) -> Result<(), FieldError> {
    let azimuths = run.phi_deg.len();
    if n == run.theta_deg.len() * azimuths * run.lane_count() {
        return Ok(());
    }
    Err(FieldError::new(
        "incidence",
        format!(
            "must list the run's {} incidence angles{}{}, found {n}",
            run.theta_deg.len(),
            if azimuths > 1 {
                format!(" at {azimuths} light azimuths")
            } else {
                String::new()
            },
            if run.wavelengths_um.is_empty() {
                String::new()
            } else {
                format!(" at {} wavelengths", run.wavelengths_um.len())
            }
        ),
    ))
}

/// That leaf `i` of a file of `run` is the run's: its incidence angle,
/// light azimuth and wavelength, its time, and nodes that pass
/// [`checked_nodes`], tile exactly the shard's batches, hold its photons
/// and realisable polarisation sums.
///
/// # Errors
/// The first problem, at its key under the leaf.
fn check_leaf(
    inc: IncidenceNodes<Value>,
    i: usize,
    run: &BrdfRun,
) -> Result<Leaf<BrdfTallies>, FieldError> {
    let (azimuths, lanes) = (run.phi_deg.len(), run.lane_count());
    let (t, a, l) = (i / lanes / azimuths, i / lanes % azimuths, i % lanes);
    check_angles(&inc, run, (t, a, l))?;
    let seconds = check_seconds(inc.seconds)?;
    let nodes = checked_nodes(inc.nodes, run).map_err(|e| e.under("nodes"))?;
    let range = run.photon_range();
    check_node_tiling(
        &nodes,
        (range.start, range.end),
        run.photons.div_ceil(BATCH),
    )?;
    if inc.photons != range.end - range.start {
        return Err(FieldError::new(
            "photons",
            format!(
                "{} is not last_photon - first_photon = {}",
                inc.photons,
                range.end - range.start
            ),
        ));
    }
    for (k, node) in nodes.iter().enumerate() {
        crate::tally::realisable::check_sums(
            node.value.polar.as_ref(),
            &node.value.carlson,
            run.polarisation.incident.stokes(),
        )
        .map_err(|e| FieldError::new(format!("nodes[{k}].tallies.polar"), e))?;
    }
    Ok(Leaf { nodes, seconds })
}

/// That a leaf is at incidence `t`, light azimuth `a` and lane `l` of
/// `run`, bit for bit.
fn check_angles(
    inc: &IncidenceNodes<Value>,
    run: &BrdfRun,
    (t, a, l): (usize, usize, usize),
) -> Result<(), FieldError> {
    let (theta, phi) = (run.theta_deg[t], run.phi_deg[a]);
    let wavelength = run.wavelength(l);
    if inc.theta_deg.to_bits() != theta.to_bits() {
        return Err(FieldError::new(
            "theta_deg",
            format!(
                "{} is not description.run.theta_deg[{t}] = {theta}",
                inc.theta_deg
            ),
        ));
    }
    let several = (run.phi_deg.len() > 1).then_some(phi);
    if inc.phi_deg.map(|p| p.0.to_bits()) != several.map(f64::to_bits) {
        return Err(FieldError::new(
            "phi_deg",
            match (inc.phi_deg, several) {
                (_, Some(p)) => format!(
                    "{} is not description.run.phi_deg[{a}] = {p}",
                    inc.phi_deg.map_or("absent".into(), |p| p.0.to_string())
                ),
                _ => "not expected in a run of one light azimuth".into(),
            },
        ));
    }
    if inc.wavelength_um.map(|w| w.0.to_bits()) != wavelength.map(f64::to_bits) {
        return Err(FieldError::new(
            "wavelength_um",
            match (inc.wavelength_um, wavelength) {
                (_, Some(w)) => format!(
                    "{} is not description.run.wavelengths_um[{l}] = {w}",
                    inc.wavelength_um
                        .map_or("absent".into(), |w| w.0.to_string())
                ),
                _ => "not expected in a monochrome run".into(),
            },
        ));
    }
    Ok(())
}

/// Check that shards sorted by photon range tile the run's `total`
/// photons in blocks of whole batches, without gaps or overlaps.
///
/// # Errors
/// One [`SceneError`] naming the shard at fault.
fn check_tiling(parts: &[ShardFile], total: u64) -> Result<(), SceneError> {
    let mut next = 0;
    for (k, p) in parts.iter().enumerate() {
        let (first, last) = photons(p);
        let err = |key: &str, m: String| Err(FieldError::new(key, m).in_file(&p.file));
        if first % BATCH != 0 || last > total || (last % BATCH != 0 && last != total) {
            return err(
                if first % BATCH == 0 {
                    "description.run.shard.last_photon"
                } else {
                    "description.run.shard.first_photon"
                },
                format!(
                    "photons [{first}, {last}) are not a block of whole batches of the run's {total}"
                ),
            );
        }
        if first < next {
            return err(
                "description.run.shard.first_photon",
                format!(
                    "photons [{first}, {last}) overlap those of {}",
                    parts[k - 1].file
                ),
            );
        }
        if first > next {
            return err(
                "description.run.shard.first_photon",
                format!("photons [{next}, {first}) are missing before this shard"),
            );
        }
        next = last;
    }
    if next != total {
        let last = &parts[parts.len() - 1];
        return Err(FieldError::new(
            "description.run.shard.last_photon",
            format!("photons [{next}, {total}) are missing after this shard"),
        )
        .in_file(&last.file));
    }
    Ok(())
}

/// Check that `nodes` tile exactly the batches `[first / BATCH, ceil(last
/// / BATCH))` of a shard, in order, in a run of `batches` batches.
fn check_node_tiling(
    nodes: &[Node<BrdfTallies>],
    (first, last): (u64, u64),
    batches: u64,
) -> Result<(), FieldError> {
    let mut b = u128::from(first / BATCH);
    let end = u128::from(last.div_ceil(BATCH));
    for (k, node) in nodes.iter().enumerate() {
        if node.start() != b || node.end().min(u128::from(batches)) > end {
            return Err(FieldError::new(
                format!("nodes[{k}]"),
                format!(
                    "tree node ({}, {}) covers batches [{}, {}), not the next of this shard's batches [{}, {end}) from {b}",
                    node.level,
                    node.index,
                    node.start(),
                    node.end().min(u128::from(batches)),
                    first / BATCH
                ),
            ));
        }
        b = node.end().min(u128::from(batches));
    }
    if b != end {
        return Err(FieldError::new(
            "nodes",
            format!(
                "cover batches up to {b}, but this shard holds [{}, {end})",
                first / BATCH
            ),
        ));
    }
    Ok(())
}

/// A time read from a file: not negative.
fn check_seconds(s: f64) -> Result<f64, FieldError> {
    if s < 0.0 {
        return Err(FieldError::new("seconds", format!("{s} must be >= 0")));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::micro::Edges;
    use crate::output::brdf_folder::BrdfFolder;
    use crate::output::summary::Surface;
    use crate::scene::micro::MicroScene;
    use crate::shard::file::first_difference;

    /// A small run of the default scene: 3 whole batches and a partial one.
    fn scene_and_run() -> (MicroScene, BrdfRun) {
        let scene = MicroScene::default_scene();
        let mut run = scene.brdf_run();
        run.photons = 3 * BATCH + 100;
        run.theta_deg = vec![30.0, 70.0];
        run.bands = 3;
        (scene, run)
    }

    fn description(run: &BrdfRun) -> Description {
        let surface = Surface {
            height_map_resolution: 8,
            max_height: Some(0.1 + 0.2),
            mean_height: Some(1.0 / 3.0),
            min_height: Some(0.0),
            rms_slope: Some(1e-7),
            sigma: None,
            sigma_over_tau: None,
            tau: None,
            undefined: None,
        };
        let content = MicroScene::default_scene().content;
        Description::new(
            content,
            "s.toml",
            "s",
            Edges::Periodic,
            run.clone(),
            surface,
        )
    }

    /// `run` as block `index` of `count`.
    fn block(run: &BrdfRun, index: u64, count: u64) -> BrdfRun {
        let (first_photon, last_photon) = Shard { index, count }.photon_range(run.photons).unwrap();
        let mut run = run.clone();
        run.shard = Some(crate::transport::brdf::ShardRange {
            count,
            first_photon,
            index,
            last_photon,
        });
        run
    }

    /// The folder of the run of `d` traced on `scene`.
    fn traced(scene: &MicroScene, d: Description) -> BrdfFolder {
        let results = d.run.trace_whole(&scene.surface, &|_| {});
        BrdfFolder::traced(d, results, 0.0)
    }

    /// The shard folders' `tallies.json` of `run` cut in `count` blocks,
    /// as read back (node sums as JSON), with their file names.
    fn raw_shards(
        scene: &MicroScene,
        run: &BrdfRun,
        count: u64,
    ) -> Vec<(String, TalliesFile<Value>)> {
        (0..count)
            .map(|index| {
                let f = traced(scene, description(&block(run, index, count)));
                let text = f.tallies.unwrap().to_text();
                (
                    format!("s{index}/tallies.json"),
                    serde_json::from_str(&text).unwrap(),
                )
            })
            .collect()
    }

    /// Shard files checked alone ([`ShardFile::checked`]), as `roks merge`
    /// reads them.
    fn checked(raw: Vec<(String, TalliesFile<Value>)>) -> Result<Vec<ShardFile>, SceneError> {
        raw.into_iter()
            .enumerate()
            .map(|(k, (file, t))| {
                ShardFile::checked(std::path::Path::new(&format!("s{k}")), file, t)
            })
            .collect()
    }

    /// The checked shard files of `run` cut in `count` blocks.
    fn shards(scene: &MicroScene, run: &BrdfRun, count: u64) -> Vec<ShardFile> {
        checked(raw_shards(scene, run, count)).unwrap()
    }

    #[test]
    fn descriptions_round_trip_exactly() {
        let (_, mut run) = scene_and_run();
        run.theta_deg = vec![0.1 + 0.2, 89.999_999_999_999_99, 5e-324];
        run.controls.roulette_weight = 1.0 / 3.0;
        run.polarisation.incident = crate::optics::polarisation::Incident::Linear(0.1 + 0.7);
        let d = description(&block(&run, 1, 3));
        let text = serde_json::to_string(&d).unwrap();
        assert!(
            text.contains(r#""max_height":0.30000000000000004"#),
            "{text}"
        );
        assert!(
            text.contains(r#""incident":{"linear":0.7999999999999999}"#),
            "{text}"
        );
        let back: Description = serde_json::from_str(&text).unwrap();
        assert_eq!(serde_json::to_string(&back).unwrap(), text);
        assert_eq!(back, d);
        for (a, b) in back.run.theta_deg.iter().zip(&d.run.theta_deg) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        // A missing or bad field is named by its key.
        let mut v = serde_json::to_value(&d).unwrap();
        v["run"].as_object_mut().unwrap().remove("seed");
        assert_eq!(
            typed::<Description>(v).unwrap_err(),
            FieldError::new("run.seed", "missing")
        );
    }

    /// The first differing field of two values, by its path.
    #[test]
    fn first_differences() {
        use serde_json::json;
        let a = json!({"a": 1, "b": {"c": [1, 2, {"d": "x"}]}});
        assert_eq!(first_difference(&a, &a), None);
        let b = json!({"a": 1, "b": {"c": [1, 2, {"d": "y"}]}});
        assert_eq!(first_difference(&a, &b).as_deref(), Some("b.c[2].d"));
        let c = json!({"a": 2, "b": {"c": [1]}});
        assert_eq!(first_difference(&a, &c).as_deref(), Some("a"));
        let d = json!({"a": 1, "b": {"c": [1, 2]}});
        assert_eq!(first_difference(&a, &d).as_deref(), Some("b.c[2]"));
        let e = json!({"a": 1, "b": {"c": [1, 2, {"d": "x"}]}, "e": null});
        assert_eq!(first_difference(&a, &e).as_deref(), Some("e"));
    }

    #[test]
    fn merged_shards_are_the_whole_run_bit_for_bit() {
        let (scene, run) = scene_and_run();
        let whole = traced(&scene, description(&run));
        for count in [2, 3, 4] {
            let mut parts = shards(&scene, &run, count);
            parts.reverse(); // any order
            let merged = merge_shards(parts).unwrap();
            assert_eq!(merged.description, description(&run));
            assert_eq!(merged.results.len(), whole.results.len());
            for (m, w) in merged.results.iter().zip(&whole.results) {
                assert_eq!(m.theta_i_deg, w.theta_i_deg);
                // Equal bits (PartialEq on f64 would also accept -0 for 0).
                assert_eq!(
                    serde_json::to_string(&m.tallies).unwrap(),
                    serde_json::to_string(&w.tallies).unwrap(),
                    "{count} shards"
                );
            }
            // The merge's own file holds the roots.
            let file = BrdfFolder::merged(merged).tallies.unwrap();
            assert_eq!(file.description.run.photon_range(), 0..run.photons);
            assert_eq!(file.incidence[0].nodes.len(), 1);
            assert_eq!(file.incidence[0].nodes[0].level, 2);
        }
    }

    #[test]
    fn shards_that_do_not_tile_the_run_are_refused() {
        let (scene, run) = scene_and_run();
        let parts = shards(&scene, &run, 3);
        let gap = vec![parts[0].clone(), parts[2].clone()];
        let e = merge_shards(gap).err().unwrap();
        assert_eq!(
            (e.file.as_str(), e.key.as_str()),
            ("s2/tallies.json", "description.run.shard.first_photon")
        );
        assert!(e.message.contains("are missing before this shard"), "{e}");
        let twice = vec![
            parts[0].clone(),
            parts[0].clone(),
            parts[1].clone(),
            parts[2].clone(),
        ];
        let e = merge_shards(twice).err().unwrap();
        assert!(
            e.message.contains("overlap those of s0/tallies.json"),
            "{e}"
        );
        let short = vec![parts[0].clone(), parts[1].clone()];
        let e = merge_shards(short).err().unwrap();
        assert_eq!(
            (e.file.as_str(), e.key.as_str()),
            ("s1/tallies.json", "description.run.shard.last_photon")
        );
        let mut other = parts.clone();
        other[1].description.run.seed += 1;
        let e = merge_shards(other).err().unwrap();
        assert_eq!(
            (e.file.as_str(), e.key.as_str()),
            ("s1/tallies.json", "description.run.seed")
        );
        assert!(e.message.contains("`description.run.seed` differs"), "{e}");
        assert!(merge_shards(Vec::new()).is_err());
    }

    #[test]
    fn nodes_must_tile_their_shard_and_hold_sound_sums() {
        let (scene, run) = scene_and_run();
        let merged = |raw| checked(raw).and_then(merge_shards).err().unwrap();
        let mut parts = raw_shards(&scene, &run, 2);
        // The second shard's first node moved to the first shard.
        let node = parts[1].1.incidence[0].nodes.remove(0);
        parts[0].1.incidence[0].nodes.push(node);
        let e = merged(parts);
        assert_eq!(e.file, "s0/tallies.json");
        assert!(e.key.starts_with("incidence[0].nodes["), "{e}");
        let mut parts = raw_shards(&scene, &run, 2);
        parts[1].1.incidence[1].nodes[0].tallies["lost_walls"] = "-1.0".into();
        let e = merged(parts);
        assert_eq!(e.key, "incidence[1].nodes[0].tallies.lost_walls");
        assert_eq!(e.message, "-1 must be >= 0");
        let mut parts = raw_shards(&scene, &run, 2);
        parts[0].1.incidence[0].nodes[0].tallies["polar"] = serde_json::json!({});
        let e = merged(parts);
        assert_eq!(e.key, "incidence[0].nodes[0].tallies.polar");
        assert_eq!(e.message, "not expected for this run");
    }
}
