//! Splitting a `roks brdf` run across machines (`--shard I/N`) and merging the
//! shards back (`roks merge`), exactly.
//!
//! # Blocks
//!
//! The photons of every incidence angle are cut into `B = ceil(photons / BATCH)`
//! batches of [`BATCH`]. Shard `I` of `N` runs the whole batches
//! `[floor(I B / N), floor((I + 1) B / N))`, i.e. the photon indices
//! `[first, last)` with `first` a multiple of `BATCH` (`last` is clipped to the
//! run's photons). Photon `n` draws from the stream `(seed, n)` only, so a
//! shard traces exactly the histories the single run traces for those indices.
//! `N` may not exceed `B` (a shard without a whole batch could not be merged
//! exactly).
//!
//! # Why the sums are exact: a fixed binary tree over batch indices
//!
//! Floating-point addition is not associative, so "the same photons" is not
//! enough: the sums must also be added in the same association. A shard cannot
//! know how the single run associates its sums unless that association is a
//! function of the batch indices alone. So a run reduces its batch tallies over
//! a **fixed dyadic tree** on batch indices, whatever the shard split:
//!
//! * node `(level l, index j)` covers batches `[j 2^l, (j + 1) 2^l) ∩ [0, B)`;
//! * a leaf `(0, b)` is batch `b`'s tally (photons summed in index order);
//! * an inner node is `left + right` (left accumulator, right added into it),
//!   or just `left` when `right` lies wholly past `B`;
//! * the result is the root `(K, 0)`, `2^K >= B`.
//!
//! [`DyadicSum`] computes this with a stack (a binary counter): push nodes in
//! batch order and siblings are combined as soon as both are present. A shard
//! pushes its own batches and stops with a short stack of at most
//! `2 log2 B` complete nodes: these values are bit-identical to the same
//! nodes in the single run, because each depends only on its own batches.
//! `tallies.json` stores them; `roks merge` pushes the nodes of all shards, in
//! shard (photon) order, into one [`DyadicSum`] and gets the root bit for bit.
//! Any split on batch boundaries works (2, 3, 7 shards...), not only
//! power-of-two ones. The single run (`roks brdf` without `--shard`) uses the
//! same tree, so a merge equals it exactly: byte-identical `brdf.csv` and
//! `inplane.csv`, and `summary.json` equal except for timings (`seconds`,
//! `segments_per_second`, which are the sums of the shards' times).
//!
//! Alternatives rejected: storing per-batch partial sums (exact but about
//! 40 kB per batch and incidence: gigabytes for large runs); exact fixed-point
//! or compensated accumulation (would change the `Accumulator` used everywhere,
//! and fixed point is not exact for tiny weights).
//!
//! # `tallies.json`
//!
//! `format: "roks-tallies"`, `format_version`, `shard {index, count}`,
//! `first_photon`, `last_photon`, `batch`, a `settings` object that must be
//! equal in all shards of one run (version, scene file and name, seed, photons
//! per incidence, incidence angles, azimuth, bands, in-plane settings,
//! transport controls, edges, surface statistics), and per incidence angle
//! `theta_deg`, `photons`, `seconds` and `nodes`: `{level, index, tallies}`
//! with the raw sums (`photons`, `reflected`/`carlson`/`inplane` as
//! `{sum, sum_sq}`, `by_bounces`, `bounces`, `segments`,
//! `intersection_tests`, `lost_walls`,
//! `lost_cap`, `lost_numeric`, `capped_histories`, `numeric_histories`, and
//! `replicates`: null, or for a lattice run `{count, reflected, carlson,
//! inplane}` with the sums per replicate), and with a polarisation tally
//! `polar`: `{components, sums {sum, sum_sq}, replicates}` (bins of
//! [`crate::tally::polar`]). Polarised runs add `polarisation` to the
//! settings (`transport`, `incident`, `incident_stokes`, `tally`).
//! Floating-point numbers are written as decimal strings (Rust's shortest
//! round-trip form, e.g. `"0.123"`, `"1e-7"`), so they read back bit for bit.
//!
//! # Reading it back
//!
//! `roks merge` ([`read_shard`], [`merge_shards`]) trusts nothing in the
//! file: the settings must describe a valid run ([`run_from_settings`]
//! applies the scene's run checks, [`BrdfRun::check`]), every number must be
//! finite and within what the photon count allows ([`check_tallies`]), each
//! tree node must hold exactly the photons of its batches, and each shard's
//! nodes must tile exactly its own photon range. Errors are one
//! [`SceneError`] naming the shard's `tallies.json` and the JSON path of the
//! value, e.g. `sh1/tallies.json: incidence[0].nodes[2].tallies.carlson.sum[5]:
//! NaN is not a finite number`.

use std::path::{Path, PathBuf};

use serde_json::{Map, Value, json};

use crate::scene::SceneError;

use crate::optics::polarisation::Incident;
use crate::tally::{Accumulator, PolarTallies, PolarTally, Symmetry};
use crate::transport::BATCH;
use crate::transport::brdf::{BOUNCE_BINS, BrdfRun, Polarisation, Replicates, Tallies};
use crate::transport::launch::Launch;
use crate::transport::micro::Controls;

/// `format` of `tallies.json`.
pub const FORMAT: &str = "roks-tallies";
/// `format_version` of `tallies.json`.
pub const FORMAT_VERSION: u64 = 1;
/// File name of the raw sums in a result folder.
pub const TALLIES_FILE: &str = "tallies.json";

/// `--shard I/N`: block `index` (0-based) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 0-based block index.
    pub index: u64,
    /// Number of blocks.
    pub count: u64,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("expected I/N (e.g. 0/4), got `{s}`"))?;
        let index: u64 = i
            .trim()
            .parse()
            .map_err(|_| format!("bad shard index `{i}` in `{s}`"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("bad shard count `{n}` in `{s}`"))?;
        if count == 0 || index >= count {
            return Err(format!("need 0 <= I < N, got `{s}`"));
        }
        Ok(Self { index, count })
    }
}

impl Shard {
    /// Photon indices `[first, last)` of this block of a run of `photons`
    /// photons per incidence: whole batches, `first` a multiple of [`BATCH`].
    ///
    /// # Errors
    /// When there are fewer batches than shards.
    pub fn photon_range(self, photons: u64) -> Result<(u64, u64), String> {
        let batches = photons.div_ceil(BATCH);
        if self.count > batches {
            return Err(format!(
                "{} shards but only {batches} batches of {BATCH} photons: use at most {batches} shards or more photons",
                self.count
            ));
        }
        let b0 = (u128::from(self.index) * u128::from(batches) / u128::from(self.count)) as u64;
        let b1 = (u128::from(self.index + 1) * u128::from(batches) / u128::from(self.count)) as u64;
        Ok((b0 * BATCH, (b1 * BATCH).min(photons)))
    }
}

/// A complete node of the fixed dyadic tree over batch indices.
#[derive(Debug, Clone, PartialEq)]
pub struct Node<T> {
    /// Height above the leaves (0: one batch).
    pub level: u32,
    /// Position among the nodes of this level.
    pub index: u64,
    /// The sum of the batches it covers, associated as the tree says.
    pub value: T,
}

impl<T> Node<T> {
    /// First batch covered.
    #[must_use]
    pub fn start(&self) -> u128 {
        u128::from(self.index) << self.level
    }
    /// One past the last batch covered, before clipping to the run.
    #[must_use]
    pub fn end(&self) -> u128 {
        u128::from(self.index + 1) << self.level
    }
}

/// The fixed-tree reduction of `batches` batch tallies (see the module doc):
/// push complete nodes in batch order.
#[derive(Debug, Clone)]
pub struct DyadicSum<T> {
    batches: u64,
    root_level: u32,
    stack: Vec<Node<T>>,
}

impl<T> DyadicSum<T> {
    /// An empty reduction over a run of `batches` batches (>= 1).
    #[must_use]
    pub fn new(batches: u64) -> Self {
        Self {
            batches,
            root_level: batches.max(1).next_power_of_two().trailing_zeros(),
            stack: Vec::new(),
        }
    }

    /// Push a complete node (a leaf: `level` 0, `index` the batch); it must
    /// start where the previous node ended. `merge(left, right)` adds right
    /// into left.
    ///
    /// # Errors
    /// If the node is not contiguous with the previous one or lies past the run.
    pub fn push(&mut self, node: Node<T>, merge: &impl Fn(&mut T, &T)) -> Result<(), String> {
        self.push_with(node, &|left, right| merge(left, right), &mut drop)
    }

    /// [`DyadicSum::push`] with `merge(left, right)` free to change `right`
    /// (e.g. to clear it while adding it), and each right node's value, once
    /// merged, handed to `spent` (e.g. to tally the next batch into it).
    ///
    /// # Errors
    /// As [`DyadicSum::push`].
    pub fn push_with(
        &mut self,
        node: Node<T>,
        merge: &impl Fn(&mut T, &mut T),
        spent: &mut impl FnMut(T),
    ) -> Result<(), String> {
        if node.start() >= u128::from(self.batches) || node.level > self.root_level {
            return Err(format!(
                "tree node ({}, {}) outside the run's {} batches",
                node.level, node.index, self.batches
            ));
        }
        if let Some(top) = self.stack.last() {
            let end = top.end().min(u128::from(self.batches));
            if node.start() != end {
                return Err(format!(
                    "tree node ({}, {}) does not follow batch {}",
                    node.level,
                    node.index,
                    end.saturating_sub(1)
                ));
            }
        }
        self.stack.push(node);
        self.reduce(merge, spent);
        Ok(())
    }

    fn reduce(&mut self, merge: &impl Fn(&mut T, &mut T), spent: &mut impl FnMut(T)) {
        while let Some(top) = self.stack.last() {
            if top.level >= self.root_level {
                break;
            }
            if top.index % 2 == 1 {
                let n = self.stack.len();
                let sibling = n >= 2 && {
                    let below = &self.stack[n - 2];
                    below.level == top.level && below.index + 1 == top.index
                };
                if !sibling {
                    break;
                }
                let mut right = self.stack.pop().expect("two nodes");
                let left = self.stack.last_mut().expect("two nodes");
                merge(&mut left.value, &mut right.value);
                spent(right.value);
                left.level += 1;
                left.index /= 2;
            } else if top.end() >= u128::from(self.batches) {
                // The right sibling is empty: the parent is this node.
                let top = self.stack.last_mut().expect("non-empty");
                top.level += 1;
                top.index /= 2;
            } else {
                break;
            }
        }
    }

    /// The complete nodes so far, in batch order (what a shard stores).
    #[must_use]
    pub fn into_nodes(self) -> Vec<Node<T>> {
        self.stack
    }

    /// The root: the sum over all batches.
    ///
    /// # Errors
    /// If the pushed nodes do not cover every batch.
    pub fn finish(mut self) -> Result<T, String> {
        match (self.stack.pop(), self.stack.is_empty()) {
            (Some(root), true) if root.level == self.root_level && root.index == 0 => {
                Ok(root.value)
            }
            _ => Err("the shards do not cover every batch of the run".into()),
        }
    }
}

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
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
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

/// A float as an exactly round-tripping decimal string.
#[must_use]
pub fn f64_text(x: f64) -> Value {
    Value::String(format!("{x:?}"))
}

fn f64s_text(xs: &[f64]) -> Value {
    Value::Array(xs.iter().map(|&x| f64_text(x)).collect())
}

/// Read a finite float written by [`f64_text`] at `key`.
///
/// # Errors
/// If `v` is not such a string or the number is not finite (`"NaN"`,
/// `"inf"`).
pub fn text_f64(v: &Value, key: &str) -> Result<f64, FieldError> {
    let x: f64 = v
        .as_str()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| FieldError::new(key, "expected a number as a string"))?;
    if !x.is_finite() {
        return Err(FieldError::new(key, format!("{x} is not a finite number")));
    }
    Ok(x)
}

fn text_f64s(v: &Value, key: &str, len: usize) -> Result<Vec<f64>, FieldError> {
    let a = v
        .as_array()
        .ok_or_else(|| FieldError::new(key, "expected an array"))?;
    if a.len() != len {
        return Err(FieldError::new(
            key,
            format!("{} values, expected {len}", a.len()),
        ));
    }
    a.iter()
        .enumerate()
        .map(|(i, x)| text_f64(x, &format!("{key}[{i}]")))
        .collect()
}

fn get<'a>(v: &'a Value, key: &str) -> Result<&'a Value, FieldError> {
    v.get(key).ok_or_else(|| FieldError::new(key, "missing"))
}

/// An unsigned integer field.
///
/// # Errors
/// If missing or not an unsigned integer.
pub fn get_u64(v: &Value, key: &str) -> Result<u64, FieldError> {
    get(v, key)?
        .as_u64()
        .ok_or_else(|| FieldError::new(key, "expected an unsigned integer"))
}

fn acc_json(a: &Accumulator) -> Value {
    json!({"sum": f64s_text(&a.sum), "sum_sq": f64s_text(&a.sum_sq)})
}

fn json_acc(v: &Value, key: &str, len: usize) -> Result<Accumulator, FieldError> {
    let v = get(v, key)?;
    Ok(Accumulator {
        sum: text_f64s(
            get(v, "sum").map_err(|e| e.under(key))?,
            &format!("{key}.sum"),
            len,
        )?,
        sum_sq: text_f64s(
            get(v, "sum_sq").map_err(|e| e.under(key))?,
            &format!("{key}.sum_sq"),
            len,
        )?,
    })
}

/// The raw sums of one tally, exactly.
#[must_use]
pub fn tallies_json(t: &Tallies) -> Value {
    let mut v = json!({
        "photons": t.photons,
        "reflected": acc_json(&t.reflected),
        "carlson": acc_json(&t.carlson),
        "inplane": acc_json(&t.inplane),
        "by_bounces": f64s_text(&t.by_bounces),
        "bounces": t.bounces,
        "segments": t.segments,
        "intersection_tests": t.intersection_tests,
        "lost_walls": f64_text(t.lost_walls),
        "lost_cap": f64_text(t.lost_cap),
        "lost_numeric": f64_text(t.lost_numeric),
        "capped_histories": t.capped_histories,
        "numeric_histories": t.numeric_histories,
        "replicates": t.replicates.as_ref().map(|r| json!({
            "count": r.count,
            "reflected": f64s_text(&r.reflected),
            "carlson": f64s_text(&r.carlson),
            "inplane": f64s_text(&r.inplane),
        })),
    });
    if let (Some(p), Value::Object(m)) = (&t.polar, &mut v) {
        m.insert(
            "polar".into(),
            json!({
                "components": p.components,
                "sums": acc_json(&p.sums),
                "replicates": p.replicates.as_deref().map(f64s_text),
            }),
        );
    }
    v
}

/// Read [`tallies_json`] back for `run`, checking the bin counts (the
/// run's grid, in-plane bins, replicates of its launch and polarisation
/// tally), that it counts `photons` photons, and every number as
/// [`check_tallies`] says.
///
/// # Errors
/// On a missing field, a bad number or a wrong bin count, at its key.
pub fn json_tallies(v: &Value, run: &BrdfRun, photons: u64) -> Result<Tallies, FieldError> {
    let found = get_u64(v, "photons")?;
    if found != photons {
        return Err(FieldError::new(
            "photons",
            format!("{found} is not the {photons} photons of its batches"),
        ));
    }
    let carlson_cells = run.grid().n_cells();
    let inplane_bins = run.inplane().n_bins();
    let expected_replicates = run.launch.replicates();
    let replicates = match v.get("replicates") {
        None | Some(Value::Null) => None,
        Some(r) => Some(
            usize::try_from(get_u64(r, "count").map_err(|e| e.under("replicates"))?)
                .map_err(|e| FieldError::new("replicates.count", e.to_string()))?,
        ),
    };
    if replicates.map(|k| k as u64) != expected_replicates {
        return Err(FieldError::new(
            "replicates",
            match expected_replicates {
                Some(k) => format!("a lattice run needs {{count: {k}, ...}}"),
                None => "must be null for a random launch".into(),
            },
        ));
    }
    let polar = match (run.polarisation.tally, v.get("polar")) {
        (PolarTally::None, None) => None,
        (PolarTally::None, Some(_)) => {
            return Err(FieldError::new("polar", "not expected for this run"));
        }
        (_, None) => return Err(FieldError::new("polar", "missing")),
        (kind, Some(p)) => {
            let k = kind.components();
            if get_u64(p, "components").map_err(|e| e.under("polar"))? != k as u64 {
                return Err(FieldError::new("polar.components", format!("expected {k}")));
            }
            let mut t = PolarTallies::new(k, carlson_cells, replicates);
            let bins = t.bins();
            t.sums = json_acc(p, "sums", bins).map_err(|e| e.under("polar"))?;
            t.replicates = match (replicates, p.get("replicates")) {
                (None, None | Some(Value::Null)) => None,
                (Some(r), Some(x)) => Some(text_f64s(x, "polar.replicates", r * bins)?),
                _ => {
                    return Err(FieldError::new(
                        "polar.replicates",
                        "does not match `replicates`",
                    ));
                }
            };
            Some(t)
        }
    };
    let t = Tallies {
        polar,
        photons: get_u64(v, "photons")?,
        reflected: json_acc(v, "reflected", 1)?,
        carlson: json_acc(v, "carlson", carlson_cells)?,
        inplane: json_acc(v, "inplane", inplane_bins)?,
        by_bounces: text_f64s(get(v, "by_bounces")?, "by_bounces", BOUNCE_BINS)?,
        bounces: get_u64(v, "bounces")?,
        segments: get_u64(v, "segments")?,
        intersection_tests: get_u64(v, "intersection_tests")?,
        lost_walls: text_f64(get(v, "lost_walls")?, "lost_walls")?,
        lost_cap: text_f64(get(v, "lost_cap")?, "lost_cap")?,
        lost_numeric: text_f64(get(v, "lost_numeric")?, "lost_numeric")?,
        capped_histories: get_u64(v, "capped_histories")?,
        numeric_histories: get_u64(v, "numeric_histories")?,
        replicates: match (replicates, v.get("replicates")) {
            (Some(k), Some(r)) => Some(Replicates {
                count: k,
                reflected: text_f64s(
                    get(r, "reflected").map_err(|e| e.under("replicates"))?,
                    "replicates.reflected",
                    k,
                )?,
                carlson: text_f64s(
                    get(r, "carlson").map_err(|e| e.under("replicates"))?,
                    "replicates.carlson",
                    k * carlson_cells,
                )?,
                inplane: text_f64s(
                    get(r, "inplane").map_err(|e| e.under("replicates"))?,
                    "replicates.inplane",
                    k * inplane_bins,
                )?,
            }),
            _ => None,
        },
    };
    check_tallies(&t, run)?;
    Ok(t)
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
/// max_segments`. All up to [`SUM_TOL`] relative.
///
/// # Errors
/// The first value out of bounds, at its key.
pub fn check_tallies(t: &Tallies, run: &BrdfRun) -> Result<(), FieldError> {
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
    }
    Ok(())
}

/// Nodes as JSON.
#[must_use]
pub fn nodes_json(nodes: &[Node<Tallies>]) -> Value {
    Value::Array(
        nodes
            .iter()
            .map(|n| json!({"level": n.level, "index": n.index, "tallies": tallies_json(&n.value)}))
            .collect(),
    )
}

/// Nodes from JSON (see [`json_tallies`]) of a run with `run.photons`
/// photons per incidence: each node of the tree over the run's batches,
/// with exactly the photons of the batches it covers.
///
/// # Errors
/// On a malformed node, at its key (`[k].tallies.photons`, ...).
pub fn json_nodes(v: &Value, run: &BrdfRun) -> Result<Vec<Node<Tallies>>, FieldError> {
    let batches = run.photons.div_ceil(BATCH);
    let root_level = batches.max(1).next_power_of_two().trailing_zeros();
    v.as_array()
        .ok_or_else(|| FieldError::new("", "expected an array"))?
        .iter()
        .enumerate()
        .map(|(k, n)| {
            let at = format!("[{k}]");
            let level = get_u64(n, "level").map_err(|e| e.under(&at))?;
            let index = get_u64(n, "index").map_err(|e| e.under(&at))?;
            if level > u64::from(root_level) {
                return Err(FieldError::new(
                    format!("{at}.level"),
                    format!("{level} is above the root level {root_level} of the run's {batches} batches"),
                ));
            }
            let level = level as u32; // <= 64
            let node = Node {
                level,
                index,
                value: (),
            };
            if node.start() >= u128::from(batches) {
                return Err(FieldError::new(
                    format!("{at}.index"),
                    format!("tree node ({level}, {index}) lies past the run's {batches} batches"),
                ));
            }
            let first = node.start() * u128::from(BATCH);
            let last = (node.end() * u128::from(BATCH)).min(u128::from(run.photons));
            let photons = u64::try_from(last - first).unwrap_or(u64::MAX);
            let value = json_tallies(get(n, "tallies").map_err(|e| e.under(&at))?, run, photons)
                .map_err(|e| e.under(&format!("{at}.tallies")))?;
            Ok(Node {
                level,
                index,
                value,
            })
        })
        .collect()
}

/// A JSON object with its float values (numbers) replaced by exact strings,
/// for values that must be rewritten bit for bit (surface statistics).
#[must_use]
pub fn exact_object(v: &Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .map(|(k, x)| {
                    let x = match x {
                        Value::Number(n) if n.is_f64() => f64_text(n.as_f64().unwrap_or(f64::NAN)),
                        other => other.clone(),
                    };
                    (k.clone(), x)
                })
                .collect::<Map<_, _>>(),
        ),
        other => other.clone(),
    }
}

/// Undo [`exact_object`].
#[must_use]
pub fn unexact_object(v: &Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .map(|(k, x)| {
                    let x = match x {
                        Value::String(s) => {
                            s.parse::<f64>().map_or_else(|_| x.clone(), |f| json!(f))
                        }
                        other => other.clone(),
                    };
                    (k.clone(), x)
                })
                .collect::<Map<_, _>>(),
        ),
        other => other.clone(),
    }
}

/// The run settings that must agree between shards of one run; floats exact.
#[must_use]
pub fn settings_json(
    scene_file: &str,
    name: &str,
    edges: &str,
    run: &BrdfRun,
    surface: &Value,
) -> Value {
    let mut v = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "scene": scene_file,
        "name": name,
        "seed": run.seed,
        "photons_per_incidence": run.photons,
        "theta_deg": f64s_text(&run.theta_deg),
        "phi_deg": f64_text(run.phi_deg),
        "bands": run.bands,
        "inplane_step_deg": f64_text(run.inplane_step_deg),
        "inplane_width_deg": f64_text(run.inplane_width_deg),
        "max_bounces": run.controls.max_bounces,
        "roulette_weight": f64_text(run.controls.roulette_weight),
        "max_segments": run.controls.max_segments,
        "launch": run.launch.name(),
        "symmetry": run.symmetry.name(),
        "edges": edges,
        "surface": exact_object(surface),
    });
    let p = &run.polarisation;
    if let (true, Value::Object(m)) = (p.transport, &mut v) {
        m.insert(
            "polarisation".into(),
            json!({
                "transport": "stokes",
                "incident": p.incident.name(),
                "incident_stokes": f64s_text(&p.incident.stokes()),
                "tally": p.tally.name(),
            }),
        );
    }
    v
}

/// The polarisation of settings written by [`settings_json`] (scalar
/// transport when absent).
fn polarisation_from_settings(s: &Value, symmetry: Symmetry) -> Result<Polarisation, FieldError> {
    let Some(p) = s.get("polarisation") else {
        return Ok(Polarisation::default());
    };
    let under = |e: FieldError| e.under("polarisation");
    let stokes = text_f64s(
        get(p, "incident_stokes").map_err(under)?,
        "polarisation.incident_stokes",
        4,
    )?;
    let incident = Incident::Stokes([stokes[0], stokes[1], stokes[2], stokes[3]]);
    incident
        .validate()
        .map_err(|e| FieldError::new("polarisation.incident_stokes", e))?;
    let name = get(p, "tally").map_err(under)?.as_str().unwrap_or("");
    let tally = PolarTally::from_name(name)
        .ok_or_else(|| FieldError::new("polarisation.tally", format!("unknown `{name}`")))?;
    Polarisation::resolve(true, Some(true), incident, tally, symmetry).map_err(|(key, e)| {
        let key = if key == "tally.symmetry" {
            "symmetry"
        } else {
            "polarisation"
        };
        FieldError::new(key, e)
    })
}

/// The key of `settings` holding the run value a scene holds at
/// `scene_key` (as [`BrdfRun::check`] names it): `light.photons` is
/// `photons_per_incidence`, the others lose their section
/// (`tally.bands` is `bands`, `light.theta_deg[1]` is `theta_deg[1]`).
#[must_use]
pub fn settings_key(scene_key: &str) -> String {
    if scene_key == "light.photons" {
        return "photons_per_incidence".into();
    }
    scene_key
        .split_once('.')
        .map_or(scene_key, |(_, rest)| rest)
        .to_owned()
}

/// The run described by [`settings_json`] (all photons, from index 0),
/// checked as a scene's run is ([`BrdfRun::check`]).
///
/// # Errors
/// On a missing, malformed or invalid field, at its key under `settings`'
/// root (e.g. `bands`).
pub fn run_from_settings(s: &Value) -> Result<BrdfRun, FieldError> {
    let theta = get(s, "theta_deg")?
        .as_array()
        .ok_or_else(|| FieldError::new("theta_deg", "expected an array"))?
        .iter()
        .enumerate()
        .map(|(i, t)| text_f64(t, &format!("theta_deg[{i}]")))
        .collect::<Result<Vec<_>, _>>()?;
    let u32_of = |key: &str| -> Result<u32, FieldError> {
        u32::try_from(get_u64(s, key)?).map_err(|e| FieldError::new(key, e.to_string()))
    };
    let name_of = |key: &str| -> Result<&str, FieldError> {
        get(s, key)?
            .as_str()
            .ok_or_else(|| FieldError::new(key, "expected a string"))
    };
    let symmetry = {
        let name = name_of("symmetry")?;
        Symmetry::from_name(name)
            .ok_or_else(|| FieldError::new("symmetry", format!("unknown `{name}`")))?
    };
    let run = BrdfRun {
        theta_deg: theta,
        phi_deg: text_f64(get(s, "phi_deg")?, "phi_deg")?,
        photons: get_u64(s, "photons_per_incidence")?,
        first_photon: 0,
        seed: get_u64(s, "seed")?,
        bands: usize::try_from(get_u64(s, "bands")?)
            .map_err(|e| FieldError::new("bands", e.to_string()))?,
        inplane_step_deg: text_f64(get(s, "inplane_step_deg")?, "inplane_step_deg")?,
        inplane_width_deg: text_f64(get(s, "inplane_width_deg")?, "inplane_width_deg")?,
        controls: Controls {
            max_bounces: u32_of("max_bounces")?,
            roulette_weight: text_f64(get(s, "roulette_weight")?, "roulette_weight")?,
            max_segments: u32_of("max_segments")?,
        },
        launch: {
            let name = name_of("launch")?;
            Launch::from_name(name)
                .ok_or_else(|| FieldError::new("launch", format!("unknown `{name}`")))?
        },
        symmetry,
        polarisation: polarisation_from_settings(s, symmetry)?,
    };
    run.check()
        .map_err(|(key, e)| FieldError::new(settings_key(&key), e))?;
    Ok(run)
}

/// The run-level fields of `summary.json` (all but `incidence` and `seconds`).
///
/// # Errors
/// On a missing field.
pub fn summary_fields(s: &Value) -> Result<Map<String, Value>, FieldError> {
    let mut m = Map::new();
    for key in [
        "scene",
        "name",
        "version",
        "seed",
        "photons_per_incidence",
        "bands",
        "launch",
        "symmetry",
        "edges",
    ] {
        m.insert(key.into(), get(s, key)?.clone());
    }
    let surface = get(s, "surface")?;
    if let Value::Object(fields) = surface {
        for (k, x) in fields {
            if let Value::String(t) = x {
                if t.parse::<f64>().is_ok_and(|f| !f.is_finite()) {
                    return Err(FieldError::new(
                        format!("surface.{k}"),
                        format!(
                            "{t} is not a finite number (write null for an undefined statistic)"
                        ),
                    ));
                }
            }
        }
    }
    m.insert("surface".into(), unexact_object(surface));
    if let Some(p) = s.get("polarisation") {
        let mut p = p.clone();
        let stokes = text_f64s(
            get(&p, "incident_stokes").map_err(|e| e.under("polarisation"))?,
            "polarisation.incident_stokes",
            4,
        )?;
        p["incident_stokes"] = json!(stokes);
        m.insert("polarisation".into(), p);
    }
    Ok(m)
}

/// One incidence angle of a shard, for [`tallies_file`].
pub struct ShardIncidence<'a> {
    /// Incidence polar angle (degrees).
    pub theta_deg: f64,
    /// Wall-clock time (s).
    pub seconds: f64,
    /// Complete tree nodes, in batch order.
    pub nodes: &'a [Node<Tallies>],
}

/// The whole `tallies.json`.
#[must_use]
pub fn tallies_file(
    settings: &Value,
    shard: Shard,
    photons: (u64, u64),
    incidence: &[ShardIncidence<'_>],
    seconds: f64,
) -> Value {
    json!({
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "shard": {"index": shard.index, "count": shard.count},
        "first_photon": photons.0,
        "last_photon": photons.1,
        "batch": BATCH,
        "settings": settings,
        "seconds": f64_text(seconds),
        "incidence": incidence.iter().map(|i| json!({
            "theta_deg": f64_text(i.theta_deg),
            "photons": i.nodes.iter().map(|n| n.value.photons).sum::<u64>(),
            "seconds": f64_text(i.seconds),
            "nodes": nodes_json(i.nodes),
        })).collect::<Vec<_>>(),
    })
}

/// One shard folder's `tallies.json`, read and checked alone.
#[derive(Debug, Clone)]
pub struct ShardFile {
    /// The folder.
    pub dir: PathBuf,
    /// `dir/tallies.json` as shown in messages.
    pub file: String,
    /// Its JSON.
    pub v: Value,
    /// Photon indices `[first, last)` it holds.
    pub first: u64,
    /// See `first`.
    pub last: u64,
}

/// Read `dir/tallies.json`: JSON of [`FORMAT`] version [`FORMAT_VERSION`]
/// with `first_photon <= last_photon` and `batch` = [`BATCH`].
///
/// # Errors
/// One [`SceneError`] naming the file and the key.
pub fn read_shard(dir: &Path) -> Result<ShardFile, SceneError> {
    let path = dir.join(TALLIES_FILE);
    let file = path.display().to_string();
    let err = |key: &str, message: String| FieldError::new(key, message).in_file(&file);
    let text = std::fs::read_to_string(&path).map_err(|e| err("", format!("cannot read: {e}")))?;
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
    let at = |e: FieldError| e.in_file(&file);
    if get_u64(&v, "batch").map_err(at)? != BATCH {
        return Err(err(
            "batch",
            format!(
                "{} is not this version's batch of {BATCH} photons",
                v["batch"]
            ),
        ));
    }
    let first = get_u64(&v, "first_photon").map_err(at)?;
    let last = get_u64(&v, "last_photon").map_err(at)?;
    if last < first {
        return Err(err(
            "last_photon",
            format!("{last} is below first_photon = {first}"),
        ));
    }
    Ok(ShardFile {
        dir: dir.to_path_buf(),
        file,
        v,
        first,
        last,
    })
}

/// One incidence of merged shards: angle (degrees), summed wall-clock
/// time (s) and the root tallies.
pub struct MergedIncidence {
    /// Incidence polar angle (degrees).
    pub theta_deg: f64,
    /// Sum of the shards' times (s).
    pub seconds: f64,
    /// The sums over the whole run (the tree's root).
    pub tallies: Tallies,
}

/// Shards of one run, checked against each other and summed.
pub struct Merged {
    /// The run (all photons).
    pub run: BrdfRun,
    /// Its settings, as in every shard.
    pub settings: Value,
    /// Per incidence angle of the run.
    pub incidence: Vec<MergedIncidence>,
    /// Sum of the shards' total times (s).
    pub seconds: f64,
}

/// Merge shard files (any order): equal `settings` that describe a valid
/// run ([`run_from_settings`]), photon ranges that tile the run in whole
/// batches, per shard an `incidence` list of the run's angles whose nodes
/// tile exactly that shard's batches, every node's numbers within the
/// bounds of [`check_tallies`], and counts that add up without overflow.
///
/// # Errors
/// One [`SceneError`] naming the shard file at fault and the key (JSON
/// path) of the value.
pub fn merge_shards(mut parts: Vec<ShardFile>) -> Result<Merged, SceneError> {
    let Some(p0) = parts.first() else {
        return Err(FieldError::new("", "no shard folders").in_file("merge"));
    };
    let settings = p0.v["settings"].clone();
    let f0 = p0.file.clone();
    for p in &parts[1..] {
        let other = &p.v["settings"];
        if *other != settings {
            let keys = |v: &Value| {
                v.as_object()
                    .map(|m| m.keys().cloned().collect::<Vec<_>>())
                    .unwrap_or_default()
            };
            let mut all = keys(&settings);
            all.extend(keys(other));
            let key = all
                .into_iter()
                .find(|k| other.get(k) != settings.get(k))
                .unwrap_or_default();
            return Err(FieldError::new(
                join_key("settings", &key),
                format!("differs from {f0} (`{key}` differs: not a shard of the same run)"),
            )
            .in_file(&p.file));
        }
    }
    let run = run_from_settings(&settings).map_err(|e| e.under("settings").in_file(&f0))?;
    let total = run.photons;
    parts.sort_by_key(|p| (p.first, p.last));
    let mut next = 0;
    for (k, p) in parts.iter().enumerate() {
        let err = |key: &str, m: String| Err(FieldError::new(key, m).in_file(&p.file));
        if p.first % BATCH != 0 || p.last > total || (p.last % BATCH != 0 && p.last != total) {
            return err(
                if p.first % BATCH == 0 {
                    "last_photon"
                } else {
                    "first_photon"
                },
                format!(
                    "photons [{}, {}) are not a block of whole batches of the run's {total}",
                    p.first, p.last
                ),
            );
        }
        if p.first < next {
            return err(
                "first_photon",
                format!(
                    "photons [{}, {}) overlap those of {}",
                    p.first,
                    p.last,
                    parts[k - 1].file
                ),
            );
        }
        if p.first > next {
            return err(
                "first_photon",
                format!(
                    "photons [{next}, {}) are missing before this shard",
                    p.first
                ),
            );
        }
        next = p.last;
    }
    if next != total {
        let last = &parts[parts.len() - 1];
        return Err(FieldError::new(
            "last_photon",
            format!("photons [{next}, {total}) are missing after this shard"),
        )
        .in_file(&last.file));
    }

    let batches = total.div_ceil(BATCH);
    let mut incidence = Vec::with_capacity(run.theta_deg.len());
    let mut seconds = 0.0;
    for p in &parts {
        let at = |e: FieldError| e.in_file(&p.file);
        let s = text_f64(get(&p.v, "seconds").map_err(at)?, "seconds").map_err(at)?;
        if s < 0.0 {
            return Err(at(FieldError::new("seconds", format!("{s} must be >= 0"))));
        }
        seconds += s;
        let n = p.v["incidence"].as_array().map_or(0, Vec::len);
        if n != run.theta_deg.len() {
            return Err(at(FieldError::new(
                "incidence",
                format!(
                    "must list the run's {} incidence angles, found {n}",
                    run.theta_deg.len()
                ),
            )));
        }
    }
    for (i, &theta) in run.theta_deg.iter().enumerate() {
        let mut sum = DyadicSum::new(batches);
        let mut secs = 0.0;
        let mut tests: u64 = 0;
        for p in &parts {
            let key = format!("incidence[{i}]");
            let at = |e: FieldError| e.under(&key).in_file(&p.file);
            let inc = &p.v["incidence"][i];
            let t = text_f64(get(inc, "theta_deg").map_err(at)?, "theta_deg").map_err(at)?;
            if t.to_bits() != theta.to_bits() {
                return Err(at(FieldError::new(
                    "theta_deg",
                    format!("{t} is not settings.theta_deg[{i}] = {theta}"),
                )));
            }
            let s = text_f64(get(inc, "seconds").map_err(at)?, "seconds").map_err(at)?;
            if s < 0.0 {
                return Err(at(FieldError::new("seconds", format!("{s} must be >= 0"))));
            }
            secs += s;
            let nodes = json_nodes(get(inc, "nodes").map_err(at)?, &run)
                .map_err(|e| at(e.under("nodes")))?;
            // The nodes tile exactly this shard's batches.
            let mut b = u128::from(p.first / BATCH);
            let end = u128::from(p.last.div_ceil(BATCH));
            for (k, node) in nodes.iter().enumerate() {
                if node.start() != b || node.end().min(u128::from(batches)) > end {
                    return Err(at(FieldError::new(
                        format!("nodes[{k}]"),
                        format!(
                            "tree node ({}, {}) covers batches [{}, {}), not the next of this shard's batches [{}, {end}) from {b}",
                            node.level,
                            node.index,
                            node.start(),
                            node.end().min(u128::from(batches)),
                            p.first / BATCH
                        ),
                    )));
                }
                b = node.end().min(u128::from(batches));
            }
            if b != end {
                return Err(at(FieldError::new(
                    "nodes",
                    format!(
                        "cover batches up to {b}, but this shard holds [{}, {end})",
                        p.first / BATCH
                    ),
                )));
            }
            let photons = get_u64(inc, "photons").map_err(at)?;
            if photons != p.last - p.first {
                return Err(at(FieldError::new(
                    "photons",
                    format!(
                        "{photons} is not last_photon - first_photon = {}",
                        p.last - p.first
                    ),
                )));
            }
            for (k, node) in nodes.into_iter().enumerate() {
                tests = tests
                    .checked_add(node.value.intersection_tests)
                    .ok_or_else(|| {
                        at(FieldError::new(
                            format!("nodes[{k}].tallies.intersection_tests"),
                            "the shards' counts add up past 2^64",
                        ))
                    })?;
                sum.push(node, &Tallies::merge)
                    .map_err(|e| at(FieldError::new(format!("nodes[{k}]"), e)))?;
            }
        }
        let last = &parts[parts.len() - 1];
        let t = sum
            .finish()
            .map_err(|e| FieldError::new(format!("incidence[{i}].nodes"), e).in_file(&last.file))?;
        incidence.push(MergedIncidence {
            theta_deg: theta,
            seconds: secs,
            tallies: t,
        });
    }
    Ok(Merged {
        run,
        settings,
        incidence,
        seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tree sum of leaves `vals` by pushing leaves, and by pushing the nodes of
    /// contiguous pieces, must agree bit for bit.
    fn tree(vals: &[f64], cuts: &[usize]) -> (f64, f64) {
        let add = |a: &mut f64, b: &f64| *a += b;
        let n = vals.len() as u64;
        let mut whole = DyadicSum::new(n);
        for (b, &v) in vals.iter().enumerate() {
            whole
                .push(
                    Node {
                        level: 0,
                        index: b as u64,
                        value: v,
                    },
                    &add,
                )
                .unwrap();
        }
        let mut merged = DyadicSum::new(n);
        let mut bounds = vec![0];
        bounds.extend_from_slice(cuts);
        bounds.push(vals.len());
        for w in bounds.windows(2) {
            let mut part = DyadicSum::new(n);
            for (b, &value) in vals.iter().enumerate().take(w[1]).skip(w[0]) {
                part.push(
                    Node {
                        level: 0,
                        index: b as u64,
                        value,
                    },
                    &add,
                )
                .unwrap();
            }
            for node in part.into_nodes() {
                merged.push(node, &add).unwrap();
            }
        }
        (whole.finish().unwrap(), merged.finish().unwrap())
    }

    #[test]
    fn any_split_reproduces_the_tree() {
        let mut x = 0.1_f64;
        let vals: Vec<f64> = (0..40)
            .map(|i| {
                x = (x * 7.13 + 0.37).fract();
                x * 10f64.powi(i % 7 - 3)
            })
            .collect();
        for n in 1..=vals.len() {
            let v = &vals[..n];
            // Every split into at most three pieces.
            for a in 1..n {
                let (w, m) = tree(v, &[a]);
                assert_eq!(w.to_bits(), m.to_bits(), "n {n}, cut {a}");
                for b in a + 1..n {
                    let (w, m) = tree(v, &[a, b]);
                    assert_eq!(w.to_bits(), m.to_bits(), "n {n}, cuts {a} {b}");
                }
            }
            // Every batch its own shard.
            let cuts: Vec<usize> = (1..n).collect();
            let (w, m) = tree(v, &cuts);
            assert_eq!(w.to_bits(), m.to_bits(), "n {n}, singletons");
        }
    }

    #[test]
    fn missing_or_overlapping_nodes_are_refused() {
        let add = |a: &mut f64, b: &f64| *a += b;
        let mut s = DyadicSum::new(4);
        s.push(
            Node {
                level: 0,
                index: 0,
                value: 1.0,
            },
            &add,
        )
        .unwrap();
        assert!(
            s.push(
                Node {
                    level: 0,
                    index: 2,
                    value: 1.0
                },
                &add
            )
            .is_err()
        );
        assert!(s.clone().finish().is_err());
        s.push(
            Node {
                level: 0,
                index: 1,
                value: 1.0,
            },
            &add,
        )
        .unwrap();
        assert!(
            s.push(
                Node {
                    level: 0,
                    index: 1,
                    value: 1.0
                },
                &add
            )
            .is_err()
        );
    }

    #[test]
    fn shard_blocks_cover_the_run() {
        for photons in [1_u64, 4095, 4096, 4097, 40_000, 1_000_000] {
            let batches = photons.div_ceil(BATCH);
            for count in 1..=batches.min(9) {
                let mut next = 0;
                for index in 0..count {
                    let (a, b) = Shard { index, count }.photon_range(photons).unwrap();
                    assert_eq!(a, next);
                    assert_eq!(a % BATCH, 0);
                    assert!(b > a);
                    next = b;
                }
                assert_eq!(next, photons);
            }
            assert!(
                Shard {
                    index: 0,
                    count: batches + 1
                }
                .photon_range(photons)
                .is_err()
            );
        }
        assert!("3/3".parse::<Shard>().is_err());
        assert!("x".parse::<Shard>().is_err());
        assert_eq!("2/3".parse::<Shard>(), Ok(Shard { index: 2, count: 3 }));
    }
}
