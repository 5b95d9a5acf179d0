//! [`BrdfTallies`]: the sums of one incidence (one batch, a tree node or
//! a whole run), and [`add_up`] of tree nodes.

#[cfg(doc)]
use super::IncidenceResult;
#[cfg(doc)]
use crate::micro::Scratch;
use crate::tally::exact;
use crate::tally::sum::Node;
use crate::tally::{Accumulator, CarlsonGrid, InPlaneTally, Merge, PolarTallies, PolarTally};
#[cfg(doc)]
use crate::transport::launch::Launch;
use crate::transport::launch::replicate_stderr;

/// Bounce counts tallied individually; longer histories share the last bin.
pub const BOUNCE_BINS: usize = 64;

/// Everything tallied for one incidence direction (sums; see [`IncidenceResult`]).
///
/// Fields are declared in the order of `tallies.json`'s keys (alphabetical:
/// the file stores a tally field by field, floats exactly, see
/// [`crate::output::tallies`]); they are added ([`Merge`]) in the order of
/// the `merge_fields!` list below. A new field is one line here and one
/// name in that list.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrdfTallies {
    /// Sum of reflections over all histories.
    pub bounces: u64,
    /// Reflected weight by number of reflections (last bin: `>= BOUNCE_BINS - 1`).
    #[serde(with = "exact::vec")]
    pub by_bounces: Vec<f64>,
    /// Histories cut by the caps.
    pub capped_histories: u64,
    /// Reflected weight per Carlson cell.
    pub carlson: Accumulator,
    /// Reflected weight per in-plane bin.
    pub inplane: Accumulator,
    /// Intersection tests ([`Scratch::tests`]: quadrics, or height-field squares).
    pub intersection_tests: u64,
    /// Weight cut by the bounce, segment or crossing cap
    /// ([`crate::micro::MAX_CROSSINGS`]).
    #[serde(with = "exact")]
    pub lost_cap: f64,
    /// Weight stopped by numerical guards.
    #[serde(with = "exact")]
    pub lost_numeric: f64,
    /// Weight absorbed by walls.
    #[serde(with = "exact")]
    pub lost_walls: f64,
    /// Histories stopped by numerical guards.
    pub numeric_histories: u64,
    /// Photons launched.
    pub photons: u64,
    /// Stokes or Mueller sums (with a polarisation tally).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polar: Option<PolarTallies>,
    /// Reflected weight (one bin).
    pub reflected: Accumulator,
    /// With [`Launch::Lattice`]: the reflected weight summed per replicate.
    pub replicates: Option<Replicates>,
    /// Straight flights traced.
    pub segments: u64,
}

crate::merge_fields!(BrdfTallies {
    sum photons,
    reflected,
    carlson,
    inplane,
    by_bounces,
    bounces,
    segments,
    intersection_tests,
    lost_walls,
    lost_cap,
    lost_numeric,
    capped_histories,
    numeric_histories,
    replicates,
    polar,
});

/// Reflected weight summed per lattice replicate, from which the standard
/// errors of a lattice run come. Bins are replicate-major: bin `b` of
/// replicate `r` is `r * bins + b`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Replicates {
    /// Per replicate and Carlson cell.
    #[serde(with = "exact::vec")]
    pub carlson: Vec<f64>,
    /// Number of replicates.
    pub count: usize,
    /// Per replicate and in-plane bin.
    #[serde(with = "exact::vec")]
    pub inplane: Vec<f64>,
    /// Reflected weight, one per replicate.
    #[serde(with = "exact::vec")]
    pub reflected: Vec<f64>,
}

crate::merge_fields!(Replicates { same count; sum reflected, carlson, inplane });

impl Replicates {
    /// Zero sums for `count` replicates of `cells` Carlson cells and `bins` in-plane bins.
    #[must_use]
    pub fn new(count: usize, cells: usize, bins: usize) -> Self {
        Self {
            count,
            reflected: vec![0.0; count],
            carlson: vec![0.0; count * cells],
            inplane: vec![0.0; count * bins],
        }
    }

    /// Standard error of the mean of `bin` of `sums` over `photons` photons
    /// split equally between the replicates.
    pub(super) fn stderr(&self, sums: &[f64], bin: usize, photons: u64) -> f64 {
        let bins = sums.len() / self.count;
        let per = photons / self.count as u64;
        replicate_stderr((0..self.count).map(|r| sums[r * bins + bin]), per)
    }
}

impl BrdfTallies {
    /// All sums zero, bins for `grid` and `inplane`, replicate sums for
    /// `replicates` (see [`Launch::replicates`]), polarisation sums for `polar`.
    #[must_use]
    pub fn new(
        grid: &CarlsonGrid,
        inplane: &InPlaneTally,
        replicates: Option<u64>,
        polar: PolarTally,
    ) -> Self {
        Self {
            photons: 0,
            reflected: Accumulator::new(1),
            carlson: Accumulator::new(grid.n_cells()),
            inplane: Accumulator::new(inplane.n_bins()),
            by_bounces: vec![0.0; BOUNCE_BINS],
            bounces: 0,
            segments: 0,
            intersection_tests: 0,
            lost_walls: 0.0,
            lost_cap: 0.0,
            lost_numeric: 0.0,
            capped_histories: 0,
            numeric_histories: 0,
            replicates: replicates
                .map(|k| Replicates::new(k as usize, grid.n_cells(), inplane.n_bins())),
            polar: (polar != PolarTally::None).then(|| {
                PolarTallies::new(
                    polar.components(),
                    grid.n_cells(),
                    replicates.map(|k| k as usize),
                )
            }),
        }
    }
}

/// The sum of complete tree nodes in batch order, added left to right
/// (`None` without nodes): a whole run's root, or a shard's sums.
#[must_use]
pub fn add_up(nodes: &[Node<BrdfTallies>]) -> Option<BrdfTallies> {
    let (first, rest) = nodes.split_first()?;
    let mut t = first.value.clone();
    for n in rest {
        t.merge(&n.value);
    }
    Some(t)
}
