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
//!
//! # Normalised components
//! Besides the sums and sums of squares of every bin, the tally keeps per
//! bin the sum of the products of a history's component `k` with its
//! component 0 of the same slot (`cross`), so that the standard error of a
//! normalised component `x / y` (`m_ij / m00`, `s_i / s0`) follows from its
//! covariance with the intensity ([`PolarTallies::ratio`]); these sums add
//! like the others, so shards merge to the whole run's bits.

use serde::Deserialize;

use super::Accumulator;

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

/// Signs of the Stokes components under a mirror reflection of the whole
/// configuration (the handedness of every frame flips): `S2`, `S3` change sign.
pub const MIRROR_SIGNS: [f64; 4] = [1.0, 1.0, -1.0, -1.0];

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
    /// Per bin `slot K + k`, the sum over histories of component `k` times
    /// component 0 of the same slot (for [`PolarTallies::ratio`]).
    #[serde(with = "super::exact::vec")]
    pub cross: Vec<f64>,
    /// With a lattice launch: per replicate and bin, `r * bins + bin`.
    #[serde(with = "super::exact::opt_vec")]
    pub replicates: Option<Vec<f64>>,
    /// Per bin sums and sums of squares.
    pub sums: Accumulator,
}

crate::merge_fields!(PolarTallies { same components; sum sums, replicates, cross });

impl PolarTallies {
    /// Zero sums for `components` per slot, `cells` Carlson cells, and
    /// `replicates` lattice replicates (if any).
    #[must_use]
    pub fn new(components: usize, cells: usize, replicates: Option<usize>) -> Self {
        let bins = components * (1 + cells);
        Self {
            components,
            sums: Accumulator::new(bins),
            cross: vec![0.0; bins],
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
        let cross: &mut [f64; K] = (&mut self.cross[at..at + K]).try_into().unwrap();
        for (c, v) in cross.iter_mut().zip(values) {
            *c += v * values[0];
        }
        if let Some(r) = &mut self.replicates {
            let at = replicate * bins + at;
            for (x, v) in r[at..at + K].iter_mut().zip(values) {
                *x += v;
            }
        }
    }
}

impl PolarTallies {
    /// The normalised component `k / 0` of slot `slot` (e.g. `m_ij / m00`
    /// of a Carlson cell: `slot = 1 + cell`) over `photons` histories: the
    /// ratio `r = X / Y` of the sums of component `k` and component 0, and
    /// its standard error by the delta method,
    /// `se² = (Σx² − 2rΣxy + r²Σy²) / (N (N − 1) ȳ²)`, `ȳ = Y / N` (the
    /// variance of the linearised residuals `x − r y`, whose mean is zero,
    /// with the population normalisation and the `N − 1` of
    /// [`Accumulator::stderr`]). With lattice replicates the residuals are
    /// those of the replicate sums: `se² = Σ_r (X_r − r Y_r)² / (R (R − 1))
    /// / (N ȳ / R)²` over `R` replicates. `None` where `Y = 0` (no light:
    /// the ratio is undefined); the error is 0 with fewer than 2 histories
    /// or replicates.
    #[must_use]
    pub fn ratio(&self, slot: usize, k: usize, photons: u64) -> Option<(f64, f64)> {
        let (bx, by) = (slot * self.components + k, slot * self.components);
        let (x, y) = (self.sums.sum[bx], self.sums.sum[by]);
        if y == 0.0 || photons == 0 {
            return None;
        }
        let r = x / y;
        let n = photons as f64;
        let ybar = y / n;
        let se = match &self.replicates {
            Some(reps) => {
                let bins = self.bins();
                let count = reps.len() / bins;
                if count < 2 {
                    0.0
                } else {
                    let per = n / count as f64;
                    let ss: f64 = (0..count)
                        .map(|q| (reps[q * bins + bx] - r * reps[q * bins + by]).powi(2))
                        .sum();
                    let c = count as f64;
                    (ss / (c * (c - 1.0))).sqrt() / (per * ybar)
                }
            }
            None if photons < 2 => 0.0,
            None => {
                let (sxx, syy, sxy) = (self.sums.sum_sq[bx], self.sums.sum_sq[by], self.cross[bx]);
                let var = ((sxx - 2.0 * r * sxy + r * r * syy) / n).max(0.0);
                (var / (n - 1.0)).sqrt() / ybar
            }
        };
        Some((r, se))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The option's values (clap's derive) are the scene's names (serde's
    /// derive): one name per variant, read back by both.
    #[test]
    fn option_values_are_the_scene_names() {
        use clap::ValueEnum as _;
        let names: Vec<String> = PolarTally::value_variants()
            .iter()
            .map(|v| {
                let option = v.to_possible_value().unwrap().get_name().to_owned();
                assert_eq!(serde_json::to_string(v).unwrap(), format!("\"{option}\""));
                assert_eq!(PolarTally::from_str(&option, false), Ok(*v));
                let back: PolarTally = serde_json::from_str(&format!("\"{option}\"")).unwrap();
                assert_eq!(back, *v);
                option
            })
            .collect();
        assert_eq!(names, ["none", "stokes", "mueller"]);
        assert!(PolarTally::from_str("nonsense", false).is_err());
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
    }

    /// A photon's Stokes components in cell 0: with probability 0.3 it
    /// lands there with `s0` uniform on 0.5..1.5 and `s1 = 0.4 s0 + 0.1 u`
    /// (strongly correlated with `s0`), otherwise it scores nothing.
    fn synthetic(rng: &mut impl rand::RngExt) -> Option<[f64; 4]> {
        (rng.random::<f64>() < 0.3).then(|| {
            let y = 0.5 + rng.random::<f64>();
            let x = 0.4 * y + 0.1 * (rng.random::<f64>() - 0.5);
            [y, x, 0.0, -x]
        })
    }

    /// The ratio's standard error is the two-pass one of the linearised
    /// residuals `x − r y` over every photon (those scoring nothing
    /// included), computed here from the list of scores; with lattice
    /// replicates, that of the replicate sums' residuals.
    #[test]
    fn ratio_error_is_the_two_pass_formula() {
        let mut rng = crate::transport::rng::photon_rng(3, 0);
        let photons = 1000_u64;
        let scores: Vec<Option<[f64; 4]>> = (0..photons).map(|_| synthetic(&mut rng)).collect();
        let mut t = PolarTallies::new(4, 1, None);
        let mut reps = PolarTallies::new(4, 1, Some(4));
        for (n, s) in scores.iter().enumerate() {
            if let Some(v) = s {
                t.score_slot(1, 0, v);
                reps.score_slot(1, n % 4, v);
            }
        }
        let xy = |s: &Option<[f64; 4]>| s.map_or((0.0, 0.0), |v| (v[1], v[0]));
        let (sx, sy) = scores
            .iter()
            .map(xy)
            .fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
        let r = sx / sy;
        let n = photons as f64;
        let ss: f64 = scores
            .iter()
            .map(xy)
            .map(|(x, y)| (x - r * y).powi(2))
            .sum();
        let expect = (ss / (n * (n - 1.0))).sqrt() / (sy / n);
        let (got_r, got) = t.ratio(1, 1, photons).unwrap();
        assert!((got_r - r).abs() <= 1e-12 * r.abs(), "{got_r} vs {r}");
        assert!((got - expect).abs() <= 1e-9 * expect, "{got} vs {expect}");
        // Replicates: photon n in replicate n mod 4, 250 photons each.
        let mut rx = [0.0; 4];
        let mut ry = [0.0; 4];
        for (k, s) in scores.iter().enumerate() {
            let (x, y) = xy(s);
            rx[k % 4] += x;
            ry[k % 4] += y;
        }
        let ss: f64 = (0..4)
            .map(|q| (rx[q] / 250.0 - r * ry[q] / 250.0).powi(2))
            .sum();
        let expect = (ss / 12.0).sqrt() / (sy / n);
        let (_, got) = reps.ratio(1, 1, photons).unwrap();
        assert!((got - expect).abs() <= 1e-9 * expect, "{got} vs {expect}");
        // No light in the hemisphere slot: undefined.
        assert_eq!(t.ratio(0, 1, photons), None);
    }

    /// The reported error of `s1 / s0` matches the spread of the ratio over
    /// 400 independent runs of 2000 photons: the sample standard deviation
    /// of 400 values is within 4 of its relative standard errors (1/√798,
    /// 3.5 %) of the root-mean-square reported error. Without the
    /// covariance term (`cross` zero) the error is more than 3 times too
    /// large (about 20).
    #[test]
    fn ratio_error_matches_the_spread_of_runs() {
        let (runs, photons) = (400, 2000_u64);
        let mut ratios = Vec::with_capacity(runs);
        let mut se2 = 0.0;
        let mut naive2 = 0.0;
        for run in 0..runs {
            let mut rng = crate::transport::rng::photon_rng(11, run as u64);
            let mut t = PolarTallies::new(4, 1, None);
            for _ in 0..photons {
                if let Some(v) = synthetic(&mut rng) {
                    t.score_slot(1, 0, &v);
                }
            }
            let (r, se) = t.ratio(1, 1, photons).unwrap();
            ratios.push(r);
            se2 += se * se;
            t.cross.iter_mut().for_each(|c| *c = 0.0);
            let (_, naive) = t.ratio(1, 1, photons).unwrap();
            naive2 += naive * naive;
        }
        let m = runs as f64;
        let mean = ratios.iter().sum::<f64>() / m;
        let sd = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
        let rms = (se2 / m).sqrt();
        let tol = 4.0 / (2.0 * (m - 1.0)).sqrt();
        assert!(
            (sd / rms - 1.0).abs() < tol,
            "spread {sd} vs reported {rms}"
        );
        let naive = (naive2 / m).sqrt();
        assert!(naive / sd > 3.0, "without covariance: {naive} vs {sd}");
    }
}
