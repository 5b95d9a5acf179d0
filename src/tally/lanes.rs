//! One batch's sums of many wavelengths, stored by bin and then by
//! wavelength, so that scoring a photon's weights at every wavelength into a
//! bin is one pass over adjacent numbers (vector code), not one visit per
//! wavelength to a separate tally.
//!
//! A spectral batch scores into a [`LaneSums`] and hands its sums to the
//! per-wavelength tallies at the end ([`LaneSums::drain_into`]): each
//! wavelength's sums are the same additions in the same order as scoring
//! that wavelength's tally directly, so the result is the same bit for bit.

use super::Accumulator;

/// [`Accumulator`] sums of `lanes` wavelengths per bin: bin `b` of lane `l`
/// is element `b * lanes + l`.
#[derive(Debug, Clone, PartialEq)]
pub struct LaneAccumulator {
    lanes: usize,
    acc: Accumulator,
}

impl LaneAccumulator {
    /// `bins` bins of `lanes` wavelengths, all sums zero.
    #[must_use]
    pub fn new(bins: usize, lanes: usize) -> Self {
        Self {
            lanes,
            acc: Accumulator::new(bins * lanes),
        }
    }

    /// Score each lane's history total `weights[l]` in `bin`
    /// ([`Accumulator::score`] of every lane).
    ///
    /// # Panics
    /// If `weights` does not hold one weight per lane, or `bin` is out of range.
    #[inline]
    pub fn score(&mut self, bin: usize, weights: &[f64]) {
        let at = bin * self.lanes..(bin + 1) * self.lanes;
        let sum = &mut self.acc.sum[at.clone()];
        let sum_sq = &mut self.acc.sum_sq[at];
        for ((s, q), &w) in sum.iter_mut().zip(sum_sq.iter_mut()).zip(weights) {
            *s += w;
            *q += w * w;
        }
    }

    /// Score `share * weights[l]` for each lane in `bin`.
    #[inline]
    pub fn score_scaled(&mut self, bin: usize, share: f64, weights: &[f64]) {
        let at = bin * self.lanes..(bin + 1) * self.lanes;
        let sum = &mut self.acc.sum[at.clone()];
        let sum_sq = &mut self.acc.sum_sq[at];
        for ((s, q), &w) in sum.iter_mut().zip(sum_sq.iter_mut()).zip(weights) {
            let v = share * w;
            *s += v;
            *q += v * v;
        }
    }

    /// Add lane `l`'s sums into `to` (one bin per bin of this accumulator).
    fn add_lane_into(&self, l: usize, to: &mut Accumulator) {
        let (sum, sum_sq) = (&self.acc.sum, &self.acc.sum_sq);
        for (b, (s, q)) in to.sum.iter_mut().zip(to.sum_sq.iter_mut()).enumerate() {
            *s += sum[b * self.lanes + l];
            *q += sum_sq[b * self.lanes + l];
        }
    }

    /// Every sum back to zero.
    fn clear(&mut self) {
        self.acc.sum.fill(0.0);
        self.acc.sum_sq.fill(0.0);
    }
}

/// Plain sums (no squares) of `lanes` wavelengths per bin, laid out as
/// [`LaneAccumulator`]'s.
#[derive(Debug, Clone, PartialEq)]
pub struct LaneVec {
    lanes: usize,
    sum: Vec<f64>,
}

impl LaneVec {
    /// `bins` bins of `lanes` wavelengths, all zero.
    #[must_use]
    pub fn new(bins: usize, lanes: usize) -> Self {
        Self {
            lanes,
            sum: vec![0.0; bins * lanes],
        }
    }

    /// Add `weights[l]` to lane `l` of `bin`.
    #[inline]
    pub fn add(&mut self, bin: usize, weights: &[f64]) {
        let at = bin * self.lanes..(bin + 1) * self.lanes;
        for (s, &w) in self.sum[at].iter_mut().zip(weights) {
            *s += w;
        }
    }

    fn add_lane_into(&self, l: usize, to: &mut [f64]) {
        for (b, s) in to.iter_mut().enumerate() {
            *s += self.sum[b * self.lanes + l];
        }
    }
}

/// The spectral batch sums of a BRDF trace: what every escaping photon
/// scores at each wavelength (reflected weight, Carlson cells, in-plane
/// bins, reflected weight by reflections).
#[derive(Debug, Clone, PartialEq)]
pub struct LaneSums {
    /// Reflected weight (one bin).
    pub reflected: LaneAccumulator,
    /// Reflected weight per Carlson cell.
    pub carlson: LaneAccumulator,
    /// Reflected weight per in-plane bin.
    pub inplane: LaneAccumulator,
    /// Reflected weight by number of reflections.
    pub by_bounces: LaneVec,
}

/// Where [`LaneSums::drain_into`] adds one wavelength's sums: that
/// wavelength's reflected, Carlson, in-plane and by-reflections tallies.
pub struct LaneTally<'a> {
    /// Reflected weight (one bin).
    pub reflected: &'a mut Accumulator,
    /// Per Carlson cell.
    pub carlson: &'a mut Accumulator,
    /// Per in-plane bin.
    pub inplane: &'a mut Accumulator,
    /// By number of reflections.
    pub by_bounces: &'a mut [f64],
}

impl LaneSums {
    /// Zero sums of `lanes` wavelengths for `cells` Carlson cells, `bins`
    /// in-plane bins and `bounce_bins` reflection counts.
    #[must_use]
    pub fn new(lanes: usize, cells: usize, bins: usize, bounce_bins: usize) -> Self {
        Self {
            reflected: LaneAccumulator::new(1, lanes),
            carlson: LaneAccumulator::new(cells, lanes),
            inplane: LaneAccumulator::new(bins, lanes),
            by_bounces: LaneVec::new(bounce_bins, lanes),
        }
    }

    /// Add wavelength `l`'s sums into the `l`-th of `to` (one per
    /// wavelength, in order), then clear. Into zero tallies this gives each
    /// wavelength's sums bit for bit as if scored there directly (`0 + s = s`).
    pub fn drain_into<'a>(&mut self, to: impl IntoIterator<Item = LaneTally<'a>>) {
        let mut drained = 0;
        for (l, t) in to.into_iter().enumerate() {
            self.reflected.add_lane_into(l, t.reflected);
            self.carlson.add_lane_into(l, t.carlson);
            self.inplane.add_lane_into(l, t.inplane);
            self.by_bounces.add_lane_into(l, t.by_bounces);
            drained += 1;
        }
        debug_assert_eq!(drained, self.reflected.lanes, "one tally per wavelength");
        self.reflected.clear();
        self.carlson.clear();
        self.inplane.clear();
        self.by_bounces.sum.fill(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One lane's four tallies: reflected, Carlson, in-plane, by reflections.
    type Four = (Accumulator, Accumulator, Accumulator, Vec<f64>);

    /// Interleaved scoring then draining gives each lane's accumulator the
    /// same bits as scoring it directly, and leaves the sums cleared.
    #[test]
    fn drained_sums_are_direct_scores() {
        let lanes = 5;
        let mut sums = LaneSums::new(lanes, 7, 3, 4);
        let mut direct: Vec<Four> = (0..lanes)
            .map(|_| {
                (
                    Accumulator::new(1),
                    Accumulator::new(7),
                    Accumulator::new(3),
                    vec![0.0; 4],
                )
            })
            .collect();
        let mut x = 0.123_f64;
        for photon in 0..1000 {
            let w: Vec<f64> = (0..lanes)
                .map(|_| {
                    x = (x * 3.7 + 0.31).fract();
                    x
                })
                .collect();
            let (cell, share, bin, b) = (photon % 7, 0.25 + x, photon % 3, photon % 4);
            sums.reflected.score(0, &w);
            sums.carlson.score_scaled(cell, share, &w);
            sums.inplane.score(bin, &w);
            sums.by_bounces.add(b, &w);
            for (l, d) in direct.iter_mut().enumerate() {
                d.0.score(0, w[l]);
                d.1.score(cell, share * w[l]);
                d.2.score(bin, w[l]);
                d.3[b] += w[l];
            }
        }
        let mut got: Vec<Four> = (0..lanes)
            .map(|_| {
                (
                    Accumulator::new(1),
                    Accumulator::new(7),
                    Accumulator::new(3),
                    vec![0.0; 4],
                )
            })
            .collect();
        sums.drain_into(got.iter_mut().map(|g| LaneTally {
            reflected: &mut g.0,
            carlson: &mut g.1,
            inplane: &mut g.2,
            by_bounces: &mut g.3,
        }));
        let bits = |a: &Accumulator| {
            a.sum
                .iter()
                .chain(&a.sum_sq)
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        for (g, d) in got.iter().zip(&direct) {
            assert_eq!(bits(&g.0), bits(&d.0));
            assert_eq!(bits(&g.1), bits(&d.1));
            assert_eq!(bits(&g.2), bits(&d.2));
            assert_eq!(g.3, d.3);
            assert!(g.1.sum.iter().all(|&s| s > 0.0));
        }
        assert_eq!(sums, LaneSums::new(lanes, 7, 3, 4));
    }
}
