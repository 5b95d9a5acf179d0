//! `tallies.json`: the raw sums of a `roks brdf --shard I/N` run (and of
//! `roks merge`), exactly, for merging shards.
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
//! both read back bit for bit.
//!
//! # Reading it back
//!
//! `roks merge` ([`read_shard`], [`merge_shards`]) trusts nothing in the
//! file: it must be JSON of [`FORMAT`] version [`FORMAT_VERSION`] with the
//! fields of [`TalliesFile`] and no others; the description must hold a
//! valid run (the scene's run checks, [`BrdfRun::check`]) and be the same
//! in every shard (compared field by field, [`first_difference`]), every tally must have the run's layout and its
//! numbers be within what the photon count allows ([`check_tallies`]),
//! each tree node must hold exactly the photons of its batches, and each
//! shard's nodes must tile exactly its own photon range. Errors are one
//! [`SceneError`] naming the shard's `tallies.json` and the JSON path of the
//! value, e.g. `sh1/tallies.json: incidence[0].nodes[2].tallies.carlson.sum[5]:
//! NaN is not a finite number`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::summary::Description;
use crate::scene::SceneError;
use crate::scene::keys::RunField;
use crate::shard::Shard;
use crate::tally::exact::{self, Exact};
use crate::tally::sum::{DyadicSum, Node};
use crate::tally::{Accumulator, Merge, PolarTally};
use crate::transport::BATCH;
use crate::transport::brdf::{
    BOUNCE_BINS, BrdfResult, BrdfRun, BrdfTallies, ByAzimuth, ByIncidence, IncidenceResult,
};

/// `format` of `tallies.json`.
pub const FORMAT: &str = "roks-tallies";
/// `format_version` of `tallies.json`.
pub const FORMAT_VERSION: u64 = 1;
/// File name of the raw sums in a result folder.
pub const TALLIES_FILE: &str = "tallies.json";

/// A problem at a key of a `tallies.json`: the JSON path of the value
/// (e.g. `incidence[0].nodes[2].tallies.carlson.sum[5]`) and what is wrong.
/// [`FieldError::in_file`] makes it the one-line [`SceneError`] of a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldError {
    /// JSON path (empty: the whole file).
    pub key: String,
    /// What is wrong (one line).
    pub message: String,
}

impl FieldError {
    /// An error at `key`.
    #[must_use]
    pub fn new(key: impl Into<String>, message: impl std::fmt::Display) -> Self {
        Self {
            key: key.into(),
            message: message.to_string(),
        }
    }

    /// The same error with its key under `prefix`: `prefix.key`,
    /// `prefix[i]` for an index key, `prefix` for an empty key.
    #[must_use]
    pub fn under(mut self, prefix: &str) -> Self {
        self.key = join_key(prefix, &self.key);
        self
    }

    /// As the error of file `file` (a path as shown to the user).
    #[must_use]
    pub fn in_file(self, file: &str) -> SceneError {
        SceneError {
            file: file.to_owned(),
            key: self.key,
            message: self.message,
        }
    }

    /// The error of reading a JSON value as a typed struct, at its path:
    /// a missing field is named as its own key (`settings.seed: missing`).
    fn from_serde(e: serde_path_to_error::Error<serde_json::Error>) -> Self {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        // From a `Value` the message has no line and column.
        let message = e.into_inner().to_string();
        if let Some(field) = message
            .strip_prefix("missing field `")
            .and_then(|m| m.strip_suffix('`'))
        {
            return Self::new(join_key(&path, field), "missing");
        }
        Self::new(path, message)
    }
}

impl std::fmt::Display for FieldError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.key, self.message)
        }
    }
}

fn join_key(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_owned()
    } else if key.is_empty() {
        prefix.to_owned()
    } else if key.starts_with('[') {
        format!("{prefix}{key}")
    } else {
        format!("{prefix}.{key}")
    }
}

/// Read `v` as a `T`, naming the JSON path of the first bad value.
///
/// # Errors
/// At the path of the value that does not fit `T`.
fn typed<T: serde::de::DeserializeOwned>(v: Value) -> Result<T, FieldError> {
    serde_path_to_error::deserialize(v).map_err(FieldError::from_serde)
}

/// The first field (a JSON path, in key order) at which `a` and `b`
/// differ, `None` when they are equal: objects key by key, arrays index by
/// index (a longer array differs at its first extra index).
#[must_use]
pub fn first_difference(a: &Value, b: &Value) -> Option<String> {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_difference(u, v).map(|rest| join_key(k, &rest)),
                _ => Some(k.clone()),
            })
        }
        (Value::Array(x), Value::Array(y)) => (0..x.len().max(y.len())).find_map(|i| {
            let at = format!("[{i}]");
            match (x.get(i), y.get(i)) {
                (Some(u), Some(v)) => first_difference(u, v).map(|rest| join_key(&at, &rest)),
                _ => Some(at),
            }
        }),
        _ => (a != b).then(String::new),
    }
}

/// What must agree between the shards of one run: the description
/// without the scene's path and the shard's block.
fn shared(d: &Description) -> Value {
    let mut d = d.clone();
    d.scene = String::new();
    d.run.shard = None;
    serde_json::to_value(d).unwrap_or_default()
}

/// A complete node of the batch tree as stored: its sums `T`
/// ([`BrdfTallies`]; read first as a JSON value, then checked against the
/// run, see [`checked_nodes`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeFile<T = BrdfTallies> {
    /// Position among the nodes of its level.
    pub index: u64,
    /// Height above the leaves (0: one batch).
    pub level: u64,
    /// The sums of the batches it covers.
    pub tallies: T,
}

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
    let n = t.photons as f64;
    let most = n * (1.0 + SUM_TOL) + 1e-12;
    let in_range = |x: f64, key: String, signed: bool| -> Result<(), FieldError> {
        if !signed && x < 0.0 {
            return Err(FieldError::new(key, format!("{x} must be >= 0")));
        }
        if x.abs() > most {
            return Err(FieldError::new(
                key,
                format!(
                    "{x} exceeds the {} photons of the tally (each photon carries a weight of at most 1)",
                    t.photons
                ),
            ));
        }
        Ok(())
    };
    let acc = |a: &Accumulator, key: &str, signed: bool| -> Result<(), FieldError> {
        for (i, (&s, &q)) in a.sum.iter().zip(&a.sum_sq).enumerate() {
            in_range(s, format!("{key}.sum[{i}]"), signed)?;
            in_range(q, format!("{key}.sum_sq[{i}]"), false)?;
            if !signed && q > s * (1.0 + SUM_TOL) + 1e-300 {
                return Err(FieldError::new(
                    format!("{key}.sum_sq[{i}]"),
                    format!("{q} exceeds the sum {s} (scores of at most 1 have x² <= x)"),
                ));
            }
            if s * s > n * q * (1.0 + SUM_TOL) + 1e-300 {
                return Err(FieldError::new(
                    format!("{key}.sum_sq[{i}]"),
                    format!(
                        "{q} is too small for the sum {s} over {} photons (sum² <= photons × sum_sq)",
                        t.photons
                    ),
                ));
            }
        }
        Ok(())
    };
    acc(&t.reflected, "reflected", false)?;
    acc(&t.carlson, "carlson", false)?;
    acc(&t.inplane, "inplane", false)?;
    for (i, &x) in t.by_bounces.iter().enumerate() {
        in_range(x, format!("by_bounces[{i}]"), false)?;
    }
    for (x, key) in [
        (t.lost_walls, "lost_walls"),
        (t.lost_cap, "lost_cap"),
        (t.lost_numeric, "lost_numeric"),
    ] {
        in_range(x, key.into(), false)?;
    }
    let spent = t.reflected.sum[0] + t.lost_walls + t.lost_cap + t.lost_numeric;
    if spent > most {
        return Err(FieldError::new(
            "reflected.sum[0]",
            format!(
                "reflected plus lost weight {spent} exceeds the {} photons launched",
                t.photons
            ),
        ));
    }
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
    if let Some(r) = &t.replicates {
        for (xs, key) in [
            (&r.reflected, "replicates.reflected"),
            (&r.carlson, "replicates.carlson"),
            (&r.inplane, "replicates.inplane"),
        ] {
            for (i, &x) in xs.iter().enumerate() {
                in_range(x, format!("{key}[{i}]"), false)?;
            }
        }
    }
    if let Some(p) = &t.polar {
        acc(&p.sums, "polar.sums", true)?;
        for (i, &x) in p.replicates.iter().flatten().enumerate() {
            in_range(x, format!("polar.replicates[{i}]"), true)?;
        }
        for (i, &x) in p.cross.iter().enumerate() {
            in_range(x, format!("polar.cross[{i}]"), true)?;
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

/// One shard folder's `tallies.json`, read and checked alone.
#[derive(Debug, Clone)]
pub struct ShardFile {
    /// The folder.
    pub dir: PathBuf,
    /// `dir/tallies.json` as shown in messages.
    pub file: String,
    /// Its contents, the sums of each node still as JSON.
    pub tallies: TalliesFile<Value>,
}

impl ShardFile {
    /// Photon indices `[first, last)` it holds.
    #[must_use]
    pub fn photons(&self) -> (u64, u64) {
        let r = self.tallies.description.run.photon_range();
        (r.start, r.end)
    }
}

/// Read `dir/tallies.json`: JSON of [`FORMAT`] version [`FORMAT_VERSION`]
/// with the fields of [`TalliesFile`], `batch` = [`BATCH`], a valid run
/// ([`BrdfRun::check`]) and, for a shard, the block `--shard I/N` gives.
///
/// # Errors
/// One [`SceneError`] naming the file and the key.
pub fn read_shard(dir: &Path) -> Result<ShardFile, SceneError> {
    let path = dir.join(TALLIES_FILE);
    let file = path.display().to_string();
    let err = |key: &str, message: String| FieldError::new(key, message).in_file(&file);
    let text = crate::limits::read_text_capped(&path, crate::limits::max_data_bytes())
        .map_err(|e| err("", format!("cannot read: {e}")))?;
    let v: Value =
        serde_json::from_str(&text).map_err(|e| err("", format!("invalid JSON: {e}")))?;
    if v["format"] != FORMAT || v["format_version"] != FORMAT_VERSION {
        return Err(err(
            "format",
            format!(
                "not a roks tallies file (format \"{FORMAT}\", format_version {FORMAT_VERSION})"
            ),
        ));
    }
    let batch = v["batch"].clone();
    let tallies: TalliesFile<Value> = typed(v).map_err(|e| e.in_file(&file))?;
    if tallies.batch != BATCH {
        return Err(err(
            "batch",
            format!("{batch} is not this version's batch of {BATCH} photons"),
        ));
    }
    let run = &tallies.description.run;
    run.check().map_err(|e| {
        err(
            &format!("description.run.{}", RunField::of(&e).run_key()),
            e.to_string(),
        )
    })?;
    if let Some(s) = run.shard {
        let block = Shard {
            index: s.index,
            count: s.count,
        };
        let expected = (s.count > 0 && s.index < s.count)
            .then(|| block.photon_range(run.photons).ok())
            .flatten();
        if expected != Some((s.first_photon, s.last_photon)) {
            return Err(err(
                "description.run.shard",
                format!(
                    "photons [{}, {}) are not block {} of {} of the run's {} photons",
                    s.first_photon, s.last_photon, s.index, s.count, run.photons
                ),
            ));
        }
    }
    Ok(ShardFile {
        dir: dir.to_path_buf(),
        file,
        tallies,
    })
}

/// Shards of one run, checked against each other and summed.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The run (all photons: no shard), as the first shard describes it.
    pub description: Description,
    /// The whole run's sums; each leaf's one node is its tree's root, its
    /// time the sum of the shards' times (s).
    pub results: BrdfResult,
    /// Sum of the shards' total times (s).
    pub seconds: f64,
}

/// Check that shards sorted by photon range tile the run's `total`
/// photons in blocks of whole batches, without gaps or overlaps.
///
/// # Errors
/// One [`SceneError`] naming the shard at fault.
fn check_tiling(parts: &[ShardFile], total: u64) -> Result<(), SceneError> {
    let mut next = 0;
    for (k, p) in parts.iter().enumerate() {
        let (first, last) = p.photons();
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

/// Merge shard files (any order): equal descriptions (but for the scene's
/// path and the shard, [`first_difference`]), photon ranges that tile the run in whole
/// batches, per shard an `incidence` list of the run's angles whose nodes
/// tile exactly that shard's batches and pass [`checked_nodes`], and
/// counts that add up without overflow. The nodes of all shards are pushed
/// in photon order into one [`DyadicSum`] per incidence: its root is the
/// single run's sum bit for bit.
///
/// # Errors
/// One [`SceneError`] naming the shard file at fault and the key (JSON
/// path) of the value.
pub fn merge_shards(mut parts: Vec<ShardFile>) -> Result<Merged, SceneError> {
    let Some(p0) = parts.first() else {
        return Err(FieldError::new("", "no shard folders").in_file("merge"));
    };
    let mut description = p0.tallies.description.clone();
    let f0 = p0.file.clone();
    let first = shared(&description);
    for p in &parts[1..] {
        if let Some(key) = first_difference(&first, &shared(&p.tallies.description)) {
            let key = join_key("description", &key);
            return Err(FieldError::new(
                key.clone(),
                format!("differs from {f0} (`{key}` differs: not a shard of the same run)"),
            )
            .in_file(&p.file));
        }
    }
    description.run.shard = None;
    let run = description.run.clone();
    let total = run.photons;
    parts.sort_by_key(ShardFile::photons);
    check_tiling(&parts, total)?;

    let batches = total.div_ceil(BATCH);
    let lanes = run.lane_count();
    let azimuths = run.phi_deg.len();
    let leaves = run.theta_deg.len() * azimuths * lanes;
    let mut seconds = 0.0;
    for p in &parts {
        let at = |e: FieldError| e.in_file(&p.file);
        seconds += check_seconds(p.tallies.seconds).map_err(at)?;
        let n = p.tallies.incidence.len();
        if n != leaves {
            return Err(at(FieldError::new(
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
            )));
        }
    }
    // Per incidence angle, light azimuth and wavelength: the tree's sum,
    // time, tests and (several realisations) the nodes.
    #[allow(clippy::type_complexity)]
    let mut sums: Vec<Vec<(DyadicSum<BrdfTallies>, f64, u64, Vec<Node<BrdfTallies>>)>> =
        (0..run.theta_deg.len() * azimuths)
            .map(|_| {
                (0..lanes)
                    .map(|_| (DyadicSum::new(batches), 0.0, 0, Vec::new()))
                    .collect()
            })
            .collect();
    for p in parts {
        let range = p.photons();
        // The file lists the leaves incidence-major, then azimuth, then
        // wavelength.
        let mut entries = p.tallies.incidence.into_iter().enumerate();
        for (ta, lane_sums) in sums.iter_mut().enumerate() {
            let (t, a) = (ta / azimuths, ta % azimuths);
            let (theta, phi) = (run.theta_deg[t], run.phi_deg[a]);
            for (l, (sum, secs, tests, kept)) in lane_sums.iter_mut().enumerate() {
                let (i, inc) = entries.next().expect("the number of leaves was checked");
                let key = format!("incidence[{i}]");
                let at = |e: FieldError| e.under(&key).in_file(&p.file);
                let wavelength = run.wavelength(l);
                if inc.theta_deg.to_bits() != theta.to_bits() {
                    return Err(at(FieldError::new(
                        "theta_deg",
                        format!(
                            "{} is not description.run.theta_deg[{t}] = {theta}",
                            inc.theta_deg
                        ),
                    )));
                }
                let several = (azimuths > 1).then_some(phi);
                if inc.phi_deg.map(|p| p.0.to_bits()) != several.map(f64::to_bits) {
                    return Err(at(FieldError::new(
                        "phi_deg",
                        match (inc.phi_deg, several) {
                            (_, Some(p)) => format!(
                                "{} is not description.run.phi_deg[{a}] = {p}",
                                inc.phi_deg.map_or("absent".into(), |p| p.0.to_string())
                            ),
                            _ => "not expected in a run of one light azimuth".into(),
                        },
                    )));
                }
                if inc.wavelength_um.map(|w| w.0.to_bits()) != wavelength.map(f64::to_bits) {
                    return Err(at(FieldError::new(
                        "wavelength_um",
                        match (inc.wavelength_um, wavelength) {
                            (_, Some(w)) => format!(
                                "{} is not description.run.wavelengths_um[{l}] = {w}",
                                inc.wavelength_um
                                    .map_or("absent".into(), |w| w.0.to_string())
                            ),
                            _ => "not expected in a monochrome run".into(),
                        },
                    )));
                }
                *secs += check_seconds(inc.seconds).map_err(at)?;
                let nodes = checked_nodes(inc.nodes, &run).map_err(|e| at(e.under("nodes")))?;
                check_node_tiling(&nodes, range, batches).map_err(at)?;
                if inc.photons != range.1 - range.0 {
                    return Err(at(FieldError::new(
                        "photons",
                        format!(
                            "{} is not last_photon - first_photon = {}",
                            inc.photons,
                            range.1 - range.0
                        ),
                    )));
                }
                for (k, node) in nodes.into_iter().enumerate() {
                    crate::tally::realisable::check_sums(
                        node.value.polar.as_ref(),
                        &node.value.carlson,
                        run.polarisation.incident.stokes(),
                    )
                    .map_err(|e| at(FieldError::new(format!("nodes[{k}].tallies.polar"), e)))?;
                    *tests = tests
                        .checked_add(node.value.intersection_tests)
                        .ok_or_else(|| {
                            at(FieldError::new(
                                format!("nodes[{k}].tallies.intersection_tests"),
                                "the shards' counts add up past 2^64",
                            ))
                        })?;
                    // Several realisations: the shards' nodes (each within
                    // one realisation's block) kept for the sums of each.
                    if run.realisations > 1 {
                        kept.push(node.clone());
                    }
                    sum.push(node, &BrdfTallies::merge)
                        .map_err(|e| at(FieldError::new(format!("nodes[{k}]"), e)))?;
                }
            }
        }
    }
    // The roots, nested as a trace's result.
    let mut i = 0;
    let mut incidence: Vec<ByIncidence> = Vec::with_capacity(run.theta_deg.len());
    for (ta, lane_sums) in sums.into_iter().enumerate() {
        let (theta, phi) = (run.theta_deg[ta / azimuths], run.phi_deg[ta % azimuths]);
        let mut wavelength = Vec::with_capacity(lanes);
        for (l, (sum, seconds, _, kept)) in lane_sums.into_iter().enumerate() {
            let tallies = sum
                .finish()
                .map_err(|e| FieldError::new(format!("incidence[{i}].nodes"), e).in_file(&f0))?;
            i += 1;
            let (realisations, ensemble) = run.realisation_results(theta, phi, &kept, &tallies);
            wavelength.push(IncidenceResult {
                theta_i_deg: theta,
                phi_i_deg: phi,
                wavelength_um: run.wavelength(l),
                // The root is kept once, as the sums.
                nodes: Vec::new(),
                tallies,
                seconds,
                realisations,
                ensemble,
            });
        }
        let by_azimuth = ByAzimuth {
            phi_i_deg: phi,
            wavelength,
        };
        if ta % azimuths == 0 {
            incidence.push(ByIncidence {
                theta_i_deg: theta,
                azimuth: vec![by_azimuth],
            });
        } else {
            incidence
                .last_mut()
                .expect("azimuth 0 came first")
                .azimuth
                .push(by_azimuth);
        }
    }
    Ok(Merged {
        description,
        results: BrdfResult { incidence },
        seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::micro::Edges;
    use crate::output::brdf_folder::BrdfFolder;
    use crate::output::summary::Surface;
    use crate::scene::micro::MicroScene;

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

    /// The shard folders' `tallies.json` of `run` cut in `count` blocks.
    fn shards(scene: &MicroScene, run: &BrdfRun, count: u64) -> Vec<ShardFile> {
        (0..count)
            .map(|index| {
                let f = traced(scene, description(&block(run, index, count)));
                let text = f.tallies.unwrap().to_text();
                ShardFile {
                    dir: PathBuf::from(format!("s{index}")),
                    file: format!("s{index}/tallies.json"),
                    tallies: serde_json::from_str(&text).unwrap(),
                }
            })
            .collect()
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
        other[1].tallies.description.run.seed += 1;
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
        let mut parts = shards(&scene, &run, 2);
        // The second shard's first node moved to the first shard.
        let node = parts[1].tallies.incidence[0].nodes.remove(0);
        parts[0].tallies.incidence[0].nodes.push(node);
        let e = merge_shards(parts).err().unwrap();
        assert_eq!(e.file, "s0/tallies.json");
        assert!(e.key.starts_with("incidence[0].nodes["), "{e}");
        let mut parts = shards(&scene, &run, 2);
        parts[1].tallies.incidence[1].nodes[0].tallies["lost_walls"] = "-1.0".into();
        let e = merge_shards(parts).err().unwrap();
        assert_eq!(e.key, "incidence[1].nodes[0].tallies.lost_walls");
        assert_eq!(e.message, "-1 must be >= 0");
        let mut parts = shards(&scene, &run, 2);
        parts[0].tallies.incidence[0].nodes[0].tallies["polar"] = serde_json::json!({});
        let e = merge_shards(parts).err().unwrap();
        assert_eq!(e.key, "incidence[0].nodes[0].tallies.polar");
        assert_eq!(e.message, "not expected for this run");
    }
}
