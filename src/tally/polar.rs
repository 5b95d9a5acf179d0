//! Polarisation tallies of a BRDF run: the Stokes vector (for the incident
//! state) or the Mueller matrix (every incident state at once) of the
//! reflected light per Carlson cell, and over the whole hemisphere.
//!
//! Each escaping photon scores its Stokes columns expressed in the frame of
//! its own outgoing direction ([`crate::optics::polarisation::hemisphere_reference`]);
//! the incident frame is the same function of the incident flight. Cell
//! means per photon launched, divided by the cell's projected solid angle,
//! are the Stokes BRDF `s_i` or Mueller BRDF `m_ij` (1/sr); the hemisphere
//! bin is the reflected Stokes vector (or Mueller matrix) per unit incident
//! power. Components are `K = 4` (`s0..s3`) or `K = 16` (`m_ij`, row-major,
//! row = outgoing component).
//!
//! Bins: `bin(slot, k) = slot K + k`, slot 0 the hemisphere, slot `1 + c`
//! Carlson cell `c`.

use serde::Deserialize;

use super::Accumulator;
use crate::optics::polarisation::MIRROR_SIGNS;

/// Which polarisation tally a run keeps (`[tally] polarisation`,
/// `--polarisation`: the names in lower case).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum PolarTally {
    /// None: the intensity tallies only.
    #[default]
    #[value(help = None::<&str>)]
    None,
    /// The Stokes vector for the incident state (`stokes.csv`).
    #[value(help = None::<&str>)]
    Stokes,
    /// The Mueller matrix (`mueller.csv`).
    #[value(help = None::<&str>)]
    Mueller,
}

impl PolarTally {
    /// The name used in scene files, on the command line and in summaries.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Stokes => "stokes",
            Self::Mueller => "mueller",
        }
    }

    /// Parse [`PolarTally::name`] (also the option's value names, which
    /// clap derives from the same variants).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::value_variants()
            .iter()
            .copied()
            .find(|v| v.name() == name)
    }

    /// Components per bin: 0, 4 or 16.
    #[must_use]
    pub fn components(self) -> usize {
        match self {
            Self::None => 0,
            Self::Stokes => 4,
            Self::Mueller => 16,
        }
    }
}

/// Sign of component `k` (of `components`) under a mirror reflection in the
/// plane of incidence: `S2`, `S3` flip; `m_ij` by the product of its row and
/// column signs (the incident state is mirrored too).
#[must_use]
pub fn mirror_sign(components: usize, k: usize) -> f64 {
    if components == 16 {
        MIRROR_SIGNS[k / 4] * MIRROR_SIGNS[k % 4]
    } else {
        MIRROR_SIGNS[k]
    }
}

/// The sums of a polarisation tally (see the module docs for the bins).
///
/// Fields in the order of `tallies.json`'s keys (alphabetical); added with
/// [`Merge`](super::Merge) in the order `sums`, `replicates`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolarTallies {
    /// 4 or 16.
    pub components: usize,
    /// With a lattice launch: per replicate and bin, `r * bins + bin`.
    #[serde(with = "super::exact::opt_vec")]
    pub replicates: Option<Vec<f64>>,
    /// Per bin sums and sums of squares.
    pub sums: Accumulator,
}

crate::merge_fields!(PolarTallies { same components; sum sums, replicates });

impl PolarTallies {
    /// Zero sums for `components` per slot, `cells` Carlson cells, and
    /// `replicates` lattice replicates (if any).
    #[must_use]
    pub fn new(components: usize, cells: usize, replicates: Option<usize>) -> Self {
        let bins = components * (1 + cells);
        Self {
            components,
            sums: Accumulator::new(bins),
            replicates: replicates.map(|r| vec![0.0; r * bins]),
        }
    }

    /// Number of bins.
    #[must_use]
    pub fn bins(&self) -> usize {
        self.sums.len()
    }

    /// Bin of component `k` of Carlson cell `cell`.
    #[must_use]
    pub fn cell_bin(&self, cell: usize, k: usize) -> usize {
        (1 + cell) * self.components + k
    }

    /// Score one history's `values` of the `K` components of `slot` (0 the
    /// hemisphere, `1 + c` Carlson cell `c`): `values[k]` in bin
    /// `slot K + k` ([`Accumulator::score`]), and in the sums of lattice
    /// replicate `replicate` (ignored for a random launch).
    ///
    /// # Panics
    /// If `K` is not [`PolarTallies::components`] or `slot` is past the last cell.
    #[inline]
    pub fn score_slot<const K: usize>(&mut self, slot: usize, replicate: usize, values: &[f64; K]) {
        assert_eq!(K, self.components, "PolarTallies::score_slot: components");
        let bins = self.bins();
        let at = slot * K;
        let sum: &mut [f64; K] = (&mut self.sums.sum[at..at + K]).try_into().unwrap();
        let sum_sq: &mut [f64; K] = (&mut self.sums.sum_sq[at..at + K]).try_into().unwrap();
        // Two loops, not one: each vectorises (the sums could alias for all
        // the compiler knows).
        for (s, v) in sum.iter_mut().zip(values) {
            *s += v;
        }
        for (q, v) in sum_sq.iter_mut().zip(values) {
            *q += v * v;
        }
        if let Some(r) = &mut self.replicates {
            let at = replicate * bins + at;
            for (x, v) in r[at..at + K].iter_mut().zip(values) {
                *x += v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_values_are_the_names() {
        use clap::ValueEnum as _;
        for v in PolarTally::value_variants() {
            assert_eq!(v.to_possible_value().unwrap().get_name(), v.name());
            assert_eq!(PolarTally::from_name(v.name()), Some(*v));
        }
        assert_eq!(PolarTally::value_variants().len(), 3);
        assert_eq!(PolarTally::from_name("nonsense"), None);
    }

    #[test]
    fn mirror_signs_of_stokes_and_mueller() {
        let s: Vec<f64> = (0..4).map(|k| mirror_sign(4, k)).collect();
        assert_eq!(s, [1.0, 1.0, -1.0, -1.0]);
        // m02 flips, m22 does not, m23 does not, m13 flips.
        assert_eq!(mirror_sign(16, 2), -1.0);
        assert_eq!(mirror_sign(16, 10), 1.0);
        assert_eq!(mirror_sign(16, 11), 1.0);
        assert_eq!(mirror_sign(16, 7), -1.0);
    }

    #[test]
    fn bins_and_names() {
        let t = PolarTallies::new(16, 10, Some(3));
        assert_eq!(t.bins(), 176);
        assert_eq!(t.cell_bin(0, 0), 16);
        assert_eq!(t.replicates.as_ref().map(Vec::len), Some(528));
        for p in [PolarTally::None, PolarTally::Stokes, PolarTally::Mueller] {
            assert_eq!(PolarTally::from_name(p.name()), Some(p));
        }
    }
}
