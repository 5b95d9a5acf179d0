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

use serde_json::{Map, Value, json};

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
        self.reduce(merge);
        Ok(())
    }

    fn reduce(&mut self, merge: &impl Fn(&mut T, &T)) {
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
                let right = self.stack.pop().expect("two nodes");
                let left = self.stack.last_mut().expect("two nodes");
                merge(&mut left.value, &right.value);
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

/// A float as an exactly round-tripping decimal string.
#[must_use]
pub fn f64_text(x: f64) -> Value {
    Value::String(format!("{x:?}"))
}

fn f64s_text(xs: &[f64]) -> Value {
    Value::Array(xs.iter().map(|&x| f64_text(x)).collect())
}

/// Read a float written by [`f64_text`].
///
/// # Errors
/// If `v` is not such a string.
pub fn text_f64(v: &Value, what: &str) -> Result<f64, String> {
    v.as_str()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("{what}: expected a number as a string"))
}

fn text_f64s(v: &Value, what: &str, len: usize) -> Result<Vec<f64>, String> {
    let a = v
        .as_array()
        .ok_or_else(|| format!("{what}: expected an array"))?;
    if a.len() != len {
        return Err(format!("{what}: {} values, expected {len}", a.len()));
    }
    a.iter().map(|x| text_f64(x, what)).collect()
}

fn get<'a>(v: &'a Value, key: &str) -> Result<&'a Value, String> {
    v.get(key).ok_or_else(|| format!("missing `{key}`"))
}

/// An unsigned integer field.
///
/// # Errors
/// If missing or not an unsigned integer.
pub fn get_u64(v: &Value, key: &str) -> Result<u64, String> {
    get(v, key)?
        .as_u64()
        .ok_or_else(|| format!("`{key}`: expected an unsigned integer"))
}

fn acc_json(a: &Accumulator) -> Value {
    json!({"sum": f64s_text(&a.sum), "sum_sq": f64s_text(&a.sum_sq)})
}

fn json_acc(v: &Value, what: &str, len: usize) -> Result<Accumulator, String> {
    Ok(Accumulator {
        sum: text_f64s(get(v, "sum")?, &format!("{what}.sum"), len)?,
        sum_sq: text_f64s(get(v, "sum_sq")?, &format!("{what}.sum_sq"), len)?,
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

/// Read [`tallies_json`] back, checking bin counts (`polar`: the run's
/// polarisation tally, whose sums must be present exactly when it is not
/// `None`).
///
/// # Errors
/// On a missing field, a bad number or a wrong bin count.
pub fn json_tallies(
    v: &Value,
    carlson_cells: usize,
    inplane_bins: usize,
    polar: PolarTally,
) -> Result<Tallies, String> {
    let replicates = match v.get("replicates") {
        None | Some(Value::Null) => None,
        Some(r) => Some(usize::try_from(get_u64(r, "count")?).map_err(|e| e.to_string())?),
    };
    let polar = match (polar, v.get("polar")) {
        (PolarTally::None, None) => None,
        (PolarTally::None, Some(_)) => return Err("`polar`: not expected for this run".into()),
        (_, None) => return Err("missing `polar`".into()),
        (kind, Some(p)) => {
            let k = kind.components();
            if get_u64(p, "components")? != k as u64 {
                return Err(format!("`polar.components`: expected {k}"));
            }
            let mut t = PolarTallies::new(k, carlson_cells, replicates);
            let bins = t.bins();
            t.sums = json_acc(get(p, "sums")?, "polar.sums", bins)?;
            t.replicates = match (replicates, p.get("replicates")) {
                (None, None | Some(Value::Null)) => None,
                (Some(r), Some(x)) => Some(text_f64s(x, "polar.replicates", r * bins)?),
                _ => return Err("`polar.replicates`: does not match `replicates`".into()),
            };
            Some(t)
        }
    };
    Ok(Tallies {
        polar,
        photons: get_u64(v, "photons")?,
        reflected: json_acc(get(v, "reflected")?, "reflected", 1)?,
        carlson: json_acc(get(v, "carlson")?, "carlson", carlson_cells)?,
        inplane: json_acc(get(v, "inplane")?, "inplane", inplane_bins)?,
        by_bounces: text_f64s(get(v, "by_bounces")?, "by_bounces", BOUNCE_BINS)?,
        bounces: get_u64(v, "bounces")?,
        segments: get_u64(v, "segments")?,
        intersection_tests: get_u64(v, "intersection_tests")?,
        lost_walls: text_f64(get(v, "lost_walls")?, "lost_walls")?,
        lost_cap: text_f64(get(v, "lost_cap")?, "lost_cap")?,
        lost_numeric: text_f64(get(v, "lost_numeric")?, "lost_numeric")?,
        capped_histories: get_u64(v, "capped_histories")?,
        numeric_histories: get_u64(v, "numeric_histories")?,
        replicates: match v.get("replicates") {
            None | Some(Value::Null) => None,
            Some(r) => {
                let k = usize::try_from(get_u64(r, "count")?).map_err(|e| e.to_string())?;
                Some(Replicates {
                    count: k,
                    reflected: text_f64s(get(r, "reflected")?, "replicates.reflected", k)?,
                    carlson: text_f64s(
                        get(r, "carlson")?,
                        "replicates.carlson",
                        k * carlson_cells,
                    )?,
                    inplane: text_f64s(get(r, "inplane")?, "replicates.inplane", k * inplane_bins)?,
                })
            }
        },
    })
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

/// Nodes from JSON (see [`json_tallies`]).
///
/// # Errors
/// On a malformed node.
pub fn json_nodes(
    v: &Value,
    carlson_cells: usize,
    inplane_bins: usize,
    polar: PolarTally,
) -> Result<Vec<Node<Tallies>>, String> {
    v.as_array()
        .ok_or("`nodes`: expected an array")?
        .iter()
        .map(|n| {
            Ok(Node {
                level: u32::try_from(get_u64(n, "level")?).map_err(|e| e.to_string())?,
                index: get_u64(n, "index")?,
                value: json_tallies(get(n, "tallies")?, carlson_cells, inplane_bins, polar)?,
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
fn polarisation_from_settings(s: &Value) -> Result<Polarisation, String> {
    let Some(p) = s.get("polarisation") else {
        return Ok(Polarisation::default());
    };
    let stokes = text_f64s(
        get(p, "incident_stokes")?,
        "polarisation.incident_stokes",
        4,
    )?;
    let incident = Incident::Stokes([stokes[0], stokes[1], stokes[2], stokes[3]]);
    incident
        .validate()
        .map_err(|e| format!("`polarisation.incident_stokes`: {e}"))?;
    let name = get(p, "tally")?.as_str().unwrap_or("");
    Ok(Polarisation {
        transport: true,
        incident,
        tally: PolarTally::from_name(name)
            .ok_or_else(|| format!("`polarisation.tally`: unknown `{name}`"))?,
    })
}

/// The run described by [`settings_json`] (all photons, from index 0).
///
/// # Errors
/// On a missing or malformed field.
pub fn run_from_settings(s: &Value) -> Result<BrdfRun, String> {
    let theta = get(s, "theta_deg")?
        .as_array()
        .ok_or("`theta_deg`: expected an array")?
        .iter()
        .map(|t| text_f64(t, "theta_deg"))
        .collect::<Result<Vec<_>, _>>()?;
    let u32_of = |key: &str| -> Result<u32, String> {
        u32::try_from(get_u64(s, key)?).map_err(|e| format!("`{key}`: {e}"))
    };
    Ok(BrdfRun {
        theta_deg: theta,
        phi_deg: text_f64(get(s, "phi_deg")?, "phi_deg")?,
        photons: get_u64(s, "photons_per_incidence")?,
        first_photon: 0,
        seed: get_u64(s, "seed")?,
        bands: usize::try_from(get_u64(s, "bands")?).map_err(|e| e.to_string())?,
        inplane_step_deg: text_f64(get(s, "inplane_step_deg")?, "inplane_step_deg")?,
        inplane_width_deg: text_f64(get(s, "inplane_width_deg")?, "inplane_width_deg")?,
        controls: Controls {
            max_bounces: u32_of("max_bounces")?,
            roulette_weight: text_f64(get(s, "roulette_weight")?, "roulette_weight")?,
            max_segments: u32_of("max_segments")?,
        },
        launch: {
            let name = get(s, "launch")?.as_str().unwrap_or("");
            Launch::from_name(name).ok_or_else(|| format!("`launch`: unknown `{name}`"))?
        },
        symmetry: {
            let name = get(s, "symmetry")?.as_str().unwrap_or("");
            Symmetry::from_name(name).ok_or_else(|| format!("`symmetry`: unknown `{name}`"))?
        },
        polarisation: polarisation_from_settings(s)?,
    })
}

/// The run-level fields of `summary.json` (all but `incidence` and `seconds`).
///
/// # Errors
/// On a missing field.
pub fn summary_fields(s: &Value) -> Result<Map<String, Value>, String> {
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
    m.insert("surface".into(), unexact_object(get(s, "surface")?));
    if let Some(p) = s.get("polarisation") {
        let mut p = p.clone();
        let stokes = text_f64s(get(&p, "incident_stokes")?, "incident_stokes", 4)?;
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
