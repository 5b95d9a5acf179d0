//! The shard file, `tallies.json`, of both levels, and the merge of the
//! shards of one run: one implementation, generic over the [`Level`] (a
//! micro `roks brdf` run, [`crate::output::tallies::Micro`], or an object
//! `roks trace` run, [`crate::output::object_tallies::Object`]).
//!
//! # What a shard file holds
//!
//! A JSON object with the keys, in alphabetical order: `batch` (photons per
//! batch, [`BATCH`]), `description` (the run: the level's
//! [`Level::Description`], with the scene's content identity and the
//! block of photons the file holds), `format` and `format_version`
//! ([`Level::FORMAT`], [`Level::FORMAT_VERSION`]), the list of leaves
//! ([`Level::ENTRIES`]: `incidence` of a micro run, incidence-major, then
//! light azimuth, then wavelength; `positions` of an object run,
//! position-major, then wavelength), and the total wall-clock `seconds`.
//! Each leaf holds its `photons` in this file, its wall-clock `seconds`,
//! its wavelength in µm (`wavelength_um`, spectral runs only) and `nodes`:
//! the complete nodes of the batch tree the shard traced ([`NodeFile`]:
//! `{index, level, tallies}`) with their raw sums, floating-point numbers
//! as decimal strings ([`crate::tally::exact`]) that read back bit for
//! bit. Times are in seconds and are the only values that differ between
//! two runs of the same description.
//!
//! # Determinism
//!
//! Photon `n` draws only from its own random stream, and every leaf sums
//! its batches of [`BATCH`] photons over one fixed dyadic tree
//! ([`crate::tally::sum`]) whatever the shard split: a shard's complete
//! nodes are bit-identical to the single run's nodes over the same batches.
//! [`merge_shards`] pushes the nodes of all shards, in block order, into
//! that tree ([`DyadicSum`]): its root is the single run's sum bit for bit,
//! for any number of shards and any order the folders are given in.
//!
//! # Checks
//!
//! Nothing in a file is trusted. [`read_shard`] needs JSON of the level's
//! format and version, the level's fields and no others, this version's
//! [`BATCH`], and then the level's checks of one file alone
//! ([`Level::check`]: a valid run, the block `--shard I/N` gives, one entry
//! per leaf of the run, nodes that tile the shard's batches exactly with
//! the run's layout, exactly their batches' photons and sums within what
//! those photons allow). [`merge_shards`] needs equal descriptions but for
//! the scene's path and the block (the content identity: [`shared`],
//! compared field by field by [`first_difference`]) and blocks that tile
//! the run ([`Level::order`]). Every error is one [`SceneError`] naming the
//! file and the JSON path of the value ([`FieldError`]).

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::outdir::file::ResultFile;
use crate::scene::SceneError;
use crate::tally::Merge;
use crate::tally::sum::BATCH;
use crate::tally::sum::{DyadicSum, Node};

/// File name of the raw sums in a result folder.
pub const TALLIES_FILE: &str = ResultFile::Tallies.name();

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
        let (path, message) = path_and_message(e);
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

/// `prefix.key`, `prefix[i]` for an index key, either one alone when the
/// other is empty.
#[must_use]
pub fn join_key(prefix: &str, key: &str) -> String {
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

/// The JSON path (empty for the whole value) and the message of a serde
/// error (from a `Value`: no line and column).
fn path_and_message(e: serde_path_to_error::Error<serde_json::Error>) -> (String, String) {
    let path = e.path().to_string();
    let path = if path == "." { String::new() } else { path };
    (path, e.into_inner().to_string())
}

/// Read `v` as a `T`, naming the JSON path of the first bad value; a
/// missing field is named as its own key with the message `missing`.
///
/// # Errors
/// At the path of the value that does not fit `T`.
pub fn typed<T: DeserializeOwned>(v: Value) -> Result<T, FieldError> {
    serde_path_to_error::deserialize(v).map_err(FieldError::from_serde)
}

/// [`typed`], but with serde's own message for a missing field (``missing
/// field `x` `` at the path of the object that lacks it): the messages of
/// `roks trace` shards.
///
/// # Errors
/// At the path of the value that does not fit `T`.
pub fn typed_plain<T: DeserializeOwned>(v: Value) -> Result<T, FieldError> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let (path, message) = path_and_message(e);
        FieldError::new(path, message)
    })
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

/// A complete node of the batch tree as stored: its sums `T` (read first
/// as a JSON value, then checked against the run by the level).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeFile<T> {
    /// Position among the nodes of its level.
    pub index: u64,
    /// Height above the leaves (0: one batch).
    pub level: u64,
    /// The sums of the batches it covers.
    pub tallies: T,
}

impl<T: Clone> NodeFile<T> {
    /// The stored form of a tree node.
    #[must_use]
    pub fn of(node: &Node<T>) -> Self {
        Self {
            index: node.index,
            level: u64::from(node.level),
            tallies: node.value.clone(),
        }
    }
}

/// One leaf of a shard (an incidence angle, light azimuth and wavelength;
/// a beam position and wavelength), checked: its complete tree nodes in
/// batch order and its wall-clock time (s).
#[derive(Debug, Clone, PartialEq)]
pub struct Leaf<T> {
    /// Complete tree nodes tiling the shard's batches of this leaf.
    pub nodes: Vec<Node<T>>,
    /// Wall-clock time (s).
    pub seconds: f64,
}

/// What the level's checks of one file give: the description, the leaves
/// in file order and the total time (s).
#[derive(Debug, Clone)]
pub struct Contents<L: Level> {
    /// The run, with the block the file holds.
    pub description: L::Description,
    /// Per leaf, in file order.
    pub leaves: Vec<Leaf<L::Tallies>>,
    /// Total wall-clock time (s).
    pub seconds: f64,
}

/// A level of roks whose runs can be split into shards: how its
/// `tallies.json` is laid out and described, what its shards must share,
/// how their blocks tile the run and how the summed leaves make its result.
/// The file format, the checks common to both levels, the content identity
/// and the merge are this module's, once.
pub trait Level: Sized {
    /// The run as the file describes it (serialised in key order).
    type Description: Clone + std::fmt::Debug + PartialEq + Serialize;
    /// The raw sums of one tree node.
    type Tallies: Clone + std::fmt::Debug + Merge;
    /// The whole file with its node sums still JSON values (so that a bad
    /// sum is named by its key after the layout is known).
    type File: DeserializeOwned;
    /// The merged result: the level's tree of leaves.
    type Result: Clone + std::fmt::Debug;

    /// `format` of the file.
    const FORMAT: &'static str;
    /// `format_version` of the file.
    const FORMAT_VERSION: u64;
    /// What the file is called in the message of a wrong format
    /// (`roks tallies file`).
    const KIND: &'static str;
    /// The key of the list of leaves (`incidence`, `positions`).
    const ENTRIES: &'static str;
    /// Whether the merge keeps the description (its scene path) of the
    /// first block of the run (`true`) or of the first folder given.
    const DESCRIBED_BY_FIRST_BLOCK: bool;

    /// The file from its JSON value (default: [`typed`]).
    ///
    /// # Errors
    /// At the path of the first value that does not fit [`Level::File`].
    fn parse(v: Value) -> Result<Self::File, FieldError> {
        typed(v)
    }

    /// `batch` of the file.
    fn batch(file: &Self::File) -> u64;

    /// The level's checks of one file alone (see the module docs); the
    /// format and `batch` are checked.
    ///
    /// # Errors
    /// The first problem, at its key.
    fn check(file: Self::File) -> Result<Contents<Self>, FieldError>;

    /// `d` without the block of photons it holds (the whole run).
    fn unshard(d: &mut Self::Description);

    /// The path of the scene file in `d` (it may differ between shards).
    fn scene_mut(d: &mut Self::Description) -> &mut String;

    /// Sort the shards (in the order they were given: the first names the
    /// run in messages) by block and check that their blocks tile the run.
    ///
    /// # Errors
    /// One [`SceneError`] naming the shard at fault.
    fn order(parts: &mut Vec<ShardFile<Self>>) -> Result<(), SceneError>;

    /// Batches of leaf `leaf` of the whole run `d` (at least 1: a run
    /// has photons at every leaf).
    fn leaf_batches(d: &Self::Description, leaf: usize) -> u64;

    /// Whether the merge keeps every leaf's nodes (e.g. for the sums of
    /// each realisation of a run of several).
    fn keeps_nodes(_d: &Self::Description) -> bool {
        false
    }

    /// Add the counts of `t` into the running `count` of a leaf over all
    /// shards, refusing a sum that would overflow (default: nothing to
    /// count).
    ///
    /// # Errors
    /// At the key (under the node) of the count that overflows.
    fn add_counts(_count: &mut u64, _t: &Self::Tallies) -> Result<(), FieldError> {
        Ok(())
    }

    /// The level's result of the whole run `d` from its merged leaves in
    /// file order.
    fn result(d: &Self::Description, leaves: Vec<MergedLeaf<Self::Tallies>>) -> Self::Result;
}

/// One shard folder's `tallies.json`, read and checked alone.
#[derive(Debug, Clone)]
pub struct ShardFile<L: Level> {
    /// The folder.
    pub dir: PathBuf,
    /// `dir/tallies.json` as shown in messages.
    pub file: String,
    /// Its description (checked), with its block.
    pub description: L::Description,
    /// Per leaf in file order: the checked nodes and the time.
    pub leaves: Vec<Leaf<L::Tallies>>,
    /// Total wall-clock time (s).
    pub seconds: f64,
}

impl<L: Level> ShardFile<L> {
    /// The shard file `file` of folder `dir` from its parsed contents:
    /// `batch` must be [`BATCH`], then the level's checks ([`Level::check`]).
    ///
    /// # Errors
    /// One [`SceneError`] naming `file` and the key.
    pub fn checked(dir: &Path, file: String, raw: L::File) -> Result<Self, SceneError> {
        let batch = L::batch(&raw);
        if batch != BATCH {
            return Err(FieldError::new(
                "batch",
                format!("{batch} is not this version's batch of {BATCH} photons"),
            )
            .in_file(&file));
        }
        let c = L::check(raw).map_err(|e| e.in_file(&file))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            file,
            description: c.description,
            leaves: c.leaves,
            seconds: c.seconds,
        })
    }
}

/// The text of `dir/tallies.json` as a JSON value, read within the data
/// size limit; the file's name as shown in messages.
fn read_json(dir: &Path) -> (String, Result<Value, String>) {
    let path = dir.join(TALLIES_FILE);
    let file = path.display().to_string();
    let value = crate::limits::read_text_capped(&path, crate::limits::max_data_bytes())
        .map_err(|e| format!("cannot read: {e}"))
        .and_then(|text| {
            serde_json::from_str::<Value>(&text).map_err(|e| format!("invalid JSON: {e}"))
        });
    (file, value)
}

/// Whether `dir/tallies.json` is of the format of level `L`; `false` for
/// any other or unreadable file.
#[must_use]
pub fn is_format<L: Level>(dir: &Path) -> bool {
    read_json(dir).1.is_ok_and(|v| v["format"] == L::FORMAT)
}

/// Read `dir/tallies.json` of level `L`: JSON of [`Level::FORMAT`] version
/// [`Level::FORMAT_VERSION`] with the fields of [`Level::File`] and no
/// others, then [`ShardFile::checked`].
///
/// # Errors
/// One [`SceneError`] naming the file and the key (JSON path).
pub fn read_shard<L: Level>(dir: &Path) -> Result<ShardFile<L>, SceneError> {
    let (file, value) = read_json(dir);
    let v = value.map_err(|m| FieldError::new("", m).in_file(&file))?;
    if v["format"] != L::FORMAT || v["format_version"] != L::FORMAT_VERSION {
        return Err(FieldError::new(
            "format",
            format!(
                "not a {} (format \"{}\", format_version {})",
                L::KIND,
                L::FORMAT,
                L::FORMAT_VERSION
            ),
        )
        .in_file(&file));
    }
    let raw = L::parse(v).map_err(|e| e.in_file(&file))?;
    ShardFile::checked(dir, file, raw)
}

/// The content identity of a run: its description without the scene's
/// path and the block, as JSON (what every shard of one run shares).
#[must_use]
pub fn shared<L: Level>(d: &L::Description) -> Value {
    let mut d = d.clone();
    L::scene_mut(&mut d).clear();
    L::unshard(&mut d);
    serde_json::to_value(d).unwrap_or_default()
}

/// A leaf of the merged run: its tree's root, the sum of the shards'
/// times (s) and, when the level keeps them, the shards' nodes.
#[derive(Debug, Clone)]
pub struct MergedLeaf<T> {
    /// The root of the leaf's tree: the sum over all its batches.
    pub tallies: T,
    /// The sum of the shards' times of this leaf (s).
    pub seconds: f64,
    /// The nodes of all shards in batch order ([`Level::keeps_nodes`]),
    /// else empty.
    pub nodes: Vec<Node<T>>,
}

/// Shards of one run, checked against each other and summed.
#[derive(Debug, Clone)]
pub struct Merged<L: Level> {
    /// The whole run (no block), as the first shard given (or the first
    /// block, [`Level::DESCRIBED_BY_FIRST_BLOCK`]) describes it.
    pub description: L::Description,
    /// The whole run's result: each leaf's sums are its tree's root.
    pub results: L::Result,
    /// Sum of the shards' total times (s).
    pub seconds: f64,
}

/// Merge the shard files of one run, given in any order: equal
/// descriptions but for the scene's path and the block ([`shared`]),
/// blocks that tile the run ([`Level::order`]), counts that add up without
/// overflow. The nodes of all shards are pushed in block order into one
/// [`DyadicSum`] per leaf: its root is the single run's sum bit for bit.
///
/// # Errors
/// One [`SceneError`] naming the shard file at fault and the key (JSON
/// path) of the value.
pub fn merge_shards<L: Level>(mut parts: Vec<ShardFile<L>>) -> Result<Merged<L>, SceneError> {
    let Some(p0) = parts.first() else {
        return Err(FieldError::new("", "no shard folders").in_file("merge"));
    };
    let f0 = p0.file.clone();
    let first = shared::<L>(&p0.description);
    for p in &parts[1..] {
        if let Some(key) = first_difference(&first, &shared::<L>(&p.description)) {
            let key = join_key("description", &key);
            return Err(FieldError::new(
                key.clone(),
                format!("differs from {f0} (`{key}` differs: not a shard of the same run)"),
            )
            .in_file(&p.file));
        }
    }
    let mut description = p0.description.clone();
    L::order(&mut parts)?;
    if L::DESCRIBED_BY_FIRST_BLOCK {
        description = parts[0].description.clone();
    }
    L::unshard(&mut description);
    let seconds = parts.iter().fold(0.0, |s, p| s + p.seconds);
    let leaves = sum_leaves(&description, parts, &f0)?;
    Ok(Merged {
        results: L::result(&description, leaves),
        description,
        seconds,
    })
}

/// The leaves of the whole run `d` from its shards in block order: each
/// leaf's nodes pushed into its tree, its times summed. Errors name the
/// node's shard, or `f0` for a tree left incomplete.
fn sum_leaves<L: Level>(
    d: &L::Description,
    parts: Vec<ShardFile<L>>,
    f0: &str,
) -> Result<Vec<MergedLeaf<L::Tallies>>, SceneError> {
    struct Running<T> {
        sum: DyadicSum<T>,
        seconds: f64,
        count: u64,
        kept: Vec<Node<T>>,
    }
    let keep = L::keeps_nodes(d);
    let n = parts.first().map_or(0, |p| p.leaves.len());
    let mut running: Vec<Running<L::Tallies>> = (0..n)
        .map(|i| Running {
            sum: DyadicSum::new(L::leaf_batches(d, i)),
            seconds: 0.0,
            count: 0,
            kept: Vec::new(),
        })
        .collect();
    for p in parts {
        for (i, (leaf, r)) in p.leaves.into_iter().zip(&mut running).enumerate() {
            r.seconds += leaf.seconds;
            for (k, node) in leaf.nodes.into_iter().enumerate() {
                let at = |e: FieldError| {
                    e.under(&format!("{}[{i}].nodes[{k}]", L::ENTRIES))
                        .in_file(&p.file)
                };
                L::add_counts(&mut r.count, &node.value).map_err(at)?;
                if keep {
                    r.kept.push(node.clone());
                }
                r.sum
                    .push(node, &<L::Tallies as Merge>::merge)
                    .map_err(|e| at(FieldError::new("", e)))?;
            }
        }
    }
    running
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let tallies = r.sum.finish().map_err(|e| {
                FieldError::new(format!("{}[{i}].nodes", L::ENTRIES), e).in_file(f0)
            })?;
            Ok(MergedLeaf {
                tallies,
                seconds: r.seconds,
                nodes: r.kept,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A level of one leaf of `batches` batches whose sums are bins of
    /// weights: the generic file, identity and merge without the physics.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    struct Toy;

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    struct ToyDescription {
        batches: u64,
        scene: String,
        seed: u64,
        /// `(index, count)` of a shard: batches `[index, index + 1)` of
        /// leaf 0 and so on, one batch per shard.
        shard: Option<(u64, u64)>,
    }

    #[derive(Debug, Clone, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct ToyFile {
        batch: u64,
        description: ToyDescription,
        format: String,
        format_version: u64,
        nodes: Vec<NodeFile<Value>>,
        seconds: f64,
    }

    impl Level for Toy {
        type Description = ToyDescription;
        type Tallies = Vec<f64>;
        type File = ToyFile;
        type Result = Vec<f64>;
        const FORMAT: &'static str = "toy";
        const FORMAT_VERSION: u64 = 1;
        const KIND: &'static str = "toy file";
        const ENTRIES: &'static str = "leaves";
        const DESCRIBED_BY_FIRST_BLOCK: bool = false;

        fn batch(file: &ToyFile) -> u64 {
            file.batch
        }
        fn check(file: ToyFile) -> Result<Contents<Self>, FieldError> {
            let nodes = file
                .nodes
                .into_iter()
                .map(|n| {
                    Ok(Node {
                        level: n.level as u32,
                        index: n.index,
                        value: typed(n.tallies)?,
                    })
                })
                .collect::<Result<_, FieldError>>()?;
            Ok(Contents {
                description: file.description,
                leaves: vec![Leaf {
                    nodes,
                    seconds: file.seconds,
                }],
                seconds: file.seconds,
            })
        }
        fn unshard(d: &mut ToyDescription) {
            d.shard = None;
        }
        fn scene_mut(d: &mut ToyDescription) -> &mut String {
            &mut d.scene
        }
        fn order(parts: &mut Vec<ShardFile<Self>>) -> Result<(), SceneError> {
            parts.sort_by_key(|p| p.description.shard);
            Ok(())
        }
        fn leaf_batches(d: &ToyDescription, _leaf: usize) -> u64 {
            d.batches
        }
        fn result(_d: &ToyDescription, leaves: Vec<MergedLeaf<Vec<f64>>>) -> Vec<f64> {
            leaves.into_iter().next().unwrap().tallies
        }
    }

    /// The sums of batch `b`: weights whose sums round differently in
    /// different orders.
    fn batch(b: u64) -> Vec<f64> {
        vec![
            0.1 * (b + 1) as f64,
            1.0 / (b + 3) as f64,
            1e16 / (b + 1) as f64,
        ]
    }

    /// Shard `index` of `count` (one batch each) of a run of `count`
    /// batches, as read from `scene`, with time `seconds`.
    fn shard(index: u64, count: u64, scene: &str, seconds: f64) -> ShardFile<Toy> {
        let raw = ToyFile {
            batch: BATCH,
            description: ToyDescription {
                batches: count,
                scene: scene.into(),
                seed: 7,
                shard: Some((index, count)),
            },
            format: "toy".into(),
            format_version: 1,
            nodes: vec![NodeFile {
                index,
                level: 0,
                tallies: serde_json::to_value(batch(index)).unwrap(),
            }],
            seconds,
        };
        let v = serde_json::to_value(raw).unwrap();
        ShardFile::checked(
            Path::new("s"),
            format!("s{index}/{TALLIES_FILE}"),
            Toy::parse(v).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn shards_in_any_order_sum_to_the_single_tree_bit_for_bit() {
        let mut whole = DyadicSum::new(5);
        for b in 0..5 {
            whole
                .push(
                    Node {
                        level: 0,
                        index: b,
                        value: batch(b),
                    },
                    &<Vec<f64> as Merge>::merge,
                )
                .unwrap();
        }
        let whole = whole.finish().unwrap();
        let parts: Vec<_> = [3, 0, 4, 1, 2]
            .into_iter()
            .map(|i| shard(i, 5, &format!("path{i}.toml"), 0.5))
            .collect();
        let merged = merge_shards(parts).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&merged.results), bits(&whole));
        // Summed in another order the sums differ: the test can fail.
        let flat = (0..5).fold(vec![0.0; 3], |mut s, b| {
            s.merge(&batch(b));
            s
        });
        assert_ne!(bits(&flat), bits(&whole));
        assert_eq!(merged.seconds, 2.5);
        // The whole run, described by the first folder given.
        assert_eq!(merged.description.shard, None);
        assert_eq!(merged.description.scene, "path3.toml");
    }

    #[test]
    fn shards_of_another_run_or_none_are_refused() {
        let mut other = shard(1, 2, "b.toml", 0.0);
        other.description.seed = 8;
        let e = merge_shards(vec![shard(0, 2, "a.toml", 0.0), other]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "s1/tallies.json: description.seed: differs from s0/tallies.json \
             (`description.seed` differs: not a shard of the same run)"
        );
        let e = merge_shards::<Toy>(Vec::new()).unwrap_err();
        assert_eq!(e.to_string(), "merge: no shard folders");
        // A batch of another size.
        let mut v = serde_json::to_value(shard(0, 1, "a.toml", 0.0).description).unwrap();
        v = serde_json::json!({
            "batch": BATCH + 1, "description": v, "format": "toy", "format_version": 1,
            "nodes": [], "seconds": 0.0
        });
        let e = ShardFile::<Toy>::checked(Path::new("s"), "f".into(), Toy::parse(v).unwrap())
            .unwrap_err();
        assert_eq!(e.key, "batch");
        // A missing field is named by its key.
        let e = typed::<ToyFile>(serde_json::json!({"batch": 1})).unwrap_err();
        assert_eq!(e, FieldError::new("description", "missing"));
    }
}
