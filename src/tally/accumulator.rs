//! Per-bin sums of photon weights for Monte Carlo estimates with error bars.
//!
//! Each history scores at most once per bin; if a history reaches the same
//! bin twice, the caller adds the two weights first and scores the total.
//! This keeps `sum_sq` the sum of squared *per-history* scores, which is
//! what the standard error below needs.

/// Per-bin running sums of history scores and of their squares.
///
/// Weights are dimensionless photon weights (or whatever unit the caller
/// scores in); `mean` has the same unit per history, `stderr` too.
///
/// Added into another with [`Merge`](super::Merge) (bin by bin, `sum`
/// then `sum_sq`); stored exactly in result files (both vectors as
/// [`super::exact`] numbers).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accumulator {
    /// Sum of the scores in each bin (weight units).
    #[serde(with = "super::exact::vec")]
    pub sum: Vec<f64>,
    /// Sum of the squared scores in each bin (weight units squared).
    #[serde(with = "super::exact::vec")]
    pub sum_sq: Vec<f64>,
}

crate::merge_fields!(Accumulator { sum sum, sum_sq });

impl Accumulator {
    /// An accumulator with `n_bins` bins, all sums zero.
    #[must_use]
    pub fn new(n_bins: usize) -> Self {
        Self {
            sum: vec![0.0; n_bins],
            sum_sq: vec![0.0; n_bins],
        }
    }

    /// Number of bins.
    #[must_use]
    pub fn len(&self) -> usize {
        self.sum.len()
    }

    /// True when there are no bins.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.sum.is_empty()
    }

    /// Add one history's total score `weight` (weight units) to `bin`.
    ///
    /// # Panics
    /// If `bin >= self.len()`.
    pub fn score(&mut self, bin: usize, weight: f64) {
        self.sum[bin] += weight;
        self.sum_sq[bin] += weight * weight;
    }

    /// Mean score per history in `bin`: `sum / n_histories` (weight units).
    ///
    /// Returns 0 when `n_histories` is 0.
    ///
    /// # Panics
    /// If `bin >= self.len()`.
    #[must_use]
    pub fn mean(&self, bin: usize, n_histories: u64) -> f64 {
        if n_histories == 0 {
            return 0.0;
        }
        self.sum[bin] / n_histories as f64
    }

    /// Standard error of [`mean`](Self::mean) (weight units):
    /// `sqrt(max(0, sum_sq/N - mean^2) / (N - 1))`.
    ///
    /// Returns 0 when `n_histories < 2`.
    ///
    /// # Panics
    /// If `bin >= self.len()`.
    #[must_use]
    pub fn stderr(&self, bin: usize, n_histories: u64) -> f64 {
        if n_histories < 2 {
            return 0.0;
        }
        let n = n_histories as f64;
        let mean = self.sum[bin] / n;
        let variance = (self.sum_sq[bin] / n - mean * mean).max(0.0);
        (variance / (n - 1.0)).sqrt()
    }
}

/// `a[i] += b[i]` and `b[i] = 0` for every `i` (the lengths must agree).
pub fn add_clearing(a: &mut [f64], b: &mut [f64]) {
    debug_assert_eq!(a.len(), b.len());
    for (x, y) in a.iter_mut().zip(b) {
        *x += *y;
        *y = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tally::Merge;

    #[test]
    fn new_is_zeroed() {
        let acc = Accumulator::new(3);
        assert_eq!(acc.len(), 3);
        assert!(!acc.is_empty());
        assert_eq!(acc.sum, vec![0.0; 3]);
        assert_eq!(acc.sum_sq, vec![0.0; 3]);
        assert!(Accumulator::new(0).is_empty());
    }

    #[test]
    fn score_mean_and_stderr_match_formulas() {
        // Five histories: scores 1, 2, 3 in bin 0 and two that missed it.
        let mut acc = Accumulator::new(2);
        for w in [1.0, 2.0, 3.0] {
            acc.score(0, w);
        }
        assert_eq!(acc.sum[0], 6.0);
        assert_eq!(acc.sum_sq[0], 14.0);
        let n = 5;
        let mean: f64 = 6.0 / 5.0;
        assert_eq!(acc.mean(0, n), mean);
        let expected = ((14.0 / 5.0 - mean * mean) / 4.0).sqrt();
        assert!((acc.stderr(0, n) - expected).abs() < 1e-15);
        // sqrt(0.34) by hand.
        assert!((acc.stderr(0, n) - 0.34_f64.sqrt()).abs() < 1e-15);
        // Untouched bin.
        assert_eq!(acc.mean(1, n), 0.0);
        assert_eq!(acc.stderr(1, n), 0.0);
    }

    #[test]
    fn small_n_edge_cases() {
        let mut acc = Accumulator::new(1);
        acc.score(0, 2.5);
        assert_eq!(acc.mean(0, 0), 0.0);
        assert_eq!(acc.mean(0, 1), 2.5);
        assert_eq!(acc.stderr(0, 0), 0.0);
        assert_eq!(acc.stderr(0, 1), 0.0);
    }

    #[test]
    fn constant_scores_have_zero_stderr_not_nan() {
        // sum_sq/N - mean^2 may round slightly negative; it must clamp to 0.
        let mut acc = Accumulator::new(1);
        let w = 0.1;
        let n = 7;
        for _ in 0..n {
            acc.score(0, w);
        }
        let s = acc.stderr(0, n);
        assert!(s.is_finite() && (0.0..1e-8).contains(&s));
    }

    #[test]
    fn merge_is_elementwise_sum() {
        let mut a = Accumulator::new(2);
        a.score(0, 1.0);
        a.score(1, 2.0);
        let mut b = Accumulator::new(2);
        b.score(1, 3.0);
        a.merge(&b);
        assert_eq!(a.sum, vec![1.0, 5.0]);
        assert_eq!(a.sum_sq, vec![1.0, 13.0]);
    }

    #[test]
    #[should_panic(expected = "bin counts differ")]
    fn merge_rejects_mismatched_lengths() {
        let mut a = Accumulator::new(2);
        a.merge(&Accumulator::new(3));
    }
}
