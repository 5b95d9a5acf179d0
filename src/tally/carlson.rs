//! Carlson (1976) equal-solid-angle grid on the upper hemisphere.
//!
//! With `M` bands and `K = M (M + 1)`, band `j = 1..=M` (counted from the
//! pole) spans `mu = cos(theta)` in
//! `[1 - j (j + 1) / K, 1 - (j - 1) j / K]` and is split into `4 j` equal
//! azimuth cells. Every cell then has solid angle `pi / K` sr and there are
//! `2 K` cells in all. Azimuth cell `k` is centred on `phi = k 2 pi / (4 j)`,
//! so cell 0 straddles `phi = 0`.
//!
//! Flat cell indices run band by band from the pole, and within a band by
//! increasing `k`: band `j` starts at flat index `2 j (j - 1)`.
//!
//! Boundary convention: a band holds `mu_bot <= mu < mu_top` (band 1 also
//! holds the pole, `mu = 1`); a cell holds `phi_lo <= phi < phi_hi`.

use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// The Carlson equal-solid-angle grid with a given number of polar bands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CarlsonGrid {
    bands: usize,
}

/// Up to four Carlson cell indices (see [`CarlsonGrid::cells_of`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Cells {
    cells: [usize; 4],
    len: usize,
}

impl Cells {
    /// The indices.
    #[must_use]
    pub fn as_slice(&self) -> &[usize] {
        &self.cells[..self.len]
    }
}

impl CarlsonGrid {
    /// A grid with `bands` polar bands; `None` if `bands == 0`.
    #[must_use]
    pub fn new(bands: usize) -> Option<Self> {
        (bands > 0).then_some(Self { bands })
    }

    /// Number of polar bands `M`.
    #[must_use]
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// `K = M (M + 1)`, the number of cells per steradian times `pi`.
    fn k(&self) -> usize {
        self.bands * (self.bands + 1)
    }

    /// Total number of cells, `2 M (M + 1)`.
    #[must_use]
    pub fn n_cells(&self) -> usize {
        2 * self.k()
    }

    /// Number of azimuth cells in `band` (1-based), `4 band`.
    #[must_use]
    pub fn cells_in_band(&self, band: usize) -> usize {
        4 * band
    }

    /// Flat index of azimuth cell `cell` (0-based) in `band` (1-based).
    ///
    /// # Panics
    /// If `band` is not in `1..=M` or `cell >= 4 band`.
    #[must_use]
    pub fn index(&self, band: usize, cell: usize) -> usize {
        assert!(
            (1..=self.bands).contains(&band) && cell < 4 * band,
            "CarlsonGrid::index: (band {band}, cell {cell}) out of range for {} bands",
            self.bands
        );
        2 * band * (band - 1) + cell
    }

    /// Inverse of [`index`](Self::index): `(band, cell)` of a flat index.
    ///
    /// # Panics
    /// If `flat >= self.n_cells()`.
    #[must_use]
    pub fn band_cell(&self, flat: usize) -> (usize, usize) {
        assert!(
            flat < self.n_cells(),
            "CarlsonGrid::band_cell: index {flat} out of range"
        );
        // Band j starts at 2 j (j - 1); solve for j, then fix any rounding.
        let mut j = ((1.0 + (1.0 + 2.0 * flat as f64).sqrt()) / 2.0).floor() as usize;
        j = j.clamp(1, self.bands);
        while 2 * j * (j + 1) <= flat {
            j += 1;
        }
        while 2 * j * (j - 1) > flat {
            j -= 1;
        }
        (j, flat - 2 * j * (j - 1))
    }

    /// `(mu_bot, mu_top)`, the cosines of the polar edges of `band`.
    ///
    /// Each is computed as an integer ratio rounded once, so e.g. `M = 4`
    /// gives edges 1, 0.9, 0.7, 0.4, 0 correctly rounded.
    ///
    /// # Panics
    /// If `band` is not in `1..=M`.
    #[must_use]
    pub fn mu_edges(&self, band: usize) -> (f64, f64) {
        assert!(
            (1..=self.bands).contains(&band),
            "CarlsonGrid::mu_edges: band {band} out of range"
        );
        let k = self.k();
        let bot = (k - band * (band + 1)) as f64 / k as f64;
        let top = (k - (band - 1) * band) as f64 / k as f64;
        (bot, top)
    }

    /// Azimuth width of every cell in `band`, `2 pi / (4 band)` (radians).
    fn dphi(band: usize) -> f64 {
        TAU / (4 * band) as f64
    }

    /// `(phi_lo, phi_hi)` of a cell in radians: `(k -/+ 1/2) 2 pi / (4 band)`.
    ///
    /// Cell 0 is reported as `[-h, +h]`, so `phi_lo` may be negative.
    ///
    /// # Panics
    /// If `band` or `cell` is out of range.
    #[must_use]
    pub fn phi_edges(&self, band: usize, cell: usize) -> (f64, f64) {
        let _ = self.index(band, cell);
        let dphi = Self::dphi(band);
        let centre = cell as f64 * dphi;
        (centre - 0.5 * dphi, centre + 0.5 * dphi)
    }

    /// `(theta, phi)` of a cell's centre in radians.
    ///
    /// `theta = acos((mu_top + mu_bot) / 2)` splits the cell's solid angle in
    /// half; `phi = cell 2 pi / (4 band)` is the centre azimuth, in `[0, 2 pi)`.
    ///
    /// # Panics
    /// If `band` or `cell` is out of range.
    #[must_use]
    pub fn centre(&self, band: usize, cell: usize) -> (f64, f64) {
        let _ = self.index(band, cell);
        let (bot, top) = self.mu_edges(band);
        ((0.5 * (top + bot)).acos(), cell as f64 * Self::dphi(band))
    }

    /// Solid angle of every cell, `pi / (M (M + 1))` sr.
    #[must_use]
    pub fn solid_angle(&self) -> f64 {
        PI / self.k() as f64
    }

    /// Projected solid angle of a cell, the exact integral of `cos(theta)`
    /// over it: `dphi (mu_top^2 - mu_bot^2) / 2` sr.
    ///
    /// With `dphi = pi / (2 j)` and the edges above this equals
    /// `pi (K - j^2) / K^2` (`K = M (M + 1)`, `j = band`), which is how it is
    /// evaluated: the difference of squares cancels badly near the pole.
    ///
    /// # Panics
    /// If `band` or `cell` is out of range.
    #[must_use]
    pub fn projected_solid_angle(&self, band: usize, cell: usize) -> f64 {
        let _ = self.index(band, cell);
        let k = self.k() as f64;
        PI * (self.k() - band * band) as f64 / (k * k)
    }

    /// Flat index of the cell holding the unit direction `dir`, or `None` if
    /// `dir.z <= 0` or any component is not finite.
    ///
    /// The band is exact with respect to [`mu_edges`](Self::mu_edges):
    /// a closed-form guess is corrected against those edges. The azimuth
    /// cell is the one of `phi = atan2(y, x)` (see `cell_of_xy`).
    #[must_use]
    pub fn locate(&self, dir: DVec3) -> Option<usize> {
        if !dir.is_finite() || dir.z <= 0.0 {
            return None;
        }
        let k = self.k();
        let band = self.band_of_mu(dir.z, |j| (k - j * (j + 1)) as f64 / k as f64);
        Some(flat_index(band, cell_of_xy(band, dir.y, dir.x)))
    }

    /// Score weight `w` of a unit direction (`dir.z > 0`) into `acc` at
    /// `offset` + its cell. Exactly at the pole (`x = y = 0`, e.g. a flat
    /// facet at normal incidence) the azimuth is undefined: the weight is
    /// shared equally among the four cells of band 1.
    pub fn score(&self, acc: &mut crate::tally::Accumulator, offset: usize, dir: DVec3, w: f64) {
        let (cells, share) = self.cells_of(dir);
        for &c in cells.as_slice() {
            acc.score(offset + c, share * w);
        }
    }

    /// The cells [`CarlsonGrid::score`] puts a direction's weight in and the
    /// share each gets: its own cell (share 1), the four cells of band 1 at
    /// the pole (share 1/4), or none (not a finite upward direction).
    #[must_use]
    #[inline]
    pub fn cells_of(&self, dir: DVec3) -> (Cells, f64) {
        shares(dir, |d| self.locate(d))
    }

    /// Band (1-based) holding `mu > 0`; `mu >= 1` goes to band 1. `bot(j)`
    /// is `mu_bot` of band `j` for `j` in `0..=M` as [`mu_edges`](Self::mu_edges)
    /// gives it (`bot(j - 1)` is `mu_top` of band `j`, `bot(0) = 1`).
    #[inline]
    fn band_of_mu(&self, mu: f64, bot: impl Fn(usize) -> f64) -> usize {
        // Closed form: band j holds j (j - 1) < x <= j (j + 1), x = (1 - mu) K.
        let x = (1.0 - mu) * self.k() as f64;
        let guess = (-1.0 + (1.0 + 4.0 * x).sqrt()) / 2.0;
        // ceil by truncation (guess >= 0; `as` saturates and maps NaN from
        // mu > 1 to 0), then clamp; no libm call in this per-photon path.
        let mut j = guess as usize;
        if (j as f64) < guess {
            j += 1;
        }
        let mut j = j.clamp(1, self.bands);
        // Correct the rounding against the exact, once-rounded edges.
        while j < self.bands && mu < bot(j) {
            j += 1;
        }
        while j > 1 && mu >= bot(j - 1) {
            j -= 1;
        }
        j
    }

    /// Azimuth cell in `band` holding `phi` (radians, any range): the
    /// reference for [`cell_of_xy`], which falls back on it near cell edges.
    fn cell_of_phi(band: usize, phi: f64) -> usize {
        let n = 4 * band as i64;
        // phi / dphi is in [-n/2, n/2] for atan2 output; shifting by n makes it
        // positive so truncation is the floor (other ranges still land mod n).
        let v = phi / Self::dphi(band) + 0.5 + n as f64;
        let k = if v >= 0.0 { v as i64 } else { v.floor() as i64 };
        k.rem_euclid(n) as usize
    }
}

/// Flat index of azimuth cell `cell` in `band` (1-based), unchecked: see
/// [`CarlsonGrid::index`].
#[inline]
fn flat_index(band: usize, cell: usize) -> usize {
    2 * band * (band - 1) + cell
}

/// The cells and shares of [`CarlsonGrid::cells_of`], with `locate` the
/// grid's [`CarlsonGrid::locate`] (or [`Locator::locate`], the same cells).
#[inline]
fn shares(dir: DVec3, locate: impl Fn(DVec3) -> Option<usize>) -> (Cells, f64) {
    if dir.x == 0.0 && dir.y == 0.0 {
        // Band 1's four cells are flat indices 0..4.
        let cells = Cells {
            cells: [0, 1, 2, 3],
            len: 4,
        };
        return if dir.z > 0.0 {
            (cells, 0.25)
        } else {
            (Cells::default(), 0.0)
        };
    }
    match locate(dir) {
        Some(c) => (
            Cells {
                cells: [c, 0, 0, 0],
                len: 1,
            },
            1.0,
        ),
        None => (Cells::default(), 0.0),
    }
}

/// Coefficients `c_i` of `atan(t) ~ t sum_i c_i t^(2 i)` on `[0, 1]`: the
/// Chebyshev interpolant of degree 8 in `t^2` of `atan(t) / t` (Chebyshev
/// nodes in `t^2`), with a largest error of 9.7e-9 rad (checked in the tests).
const ATAN_COEFFS: [f64; 9] = [
    0.999_999_981_788_655_6,
    -0.333_330_367_092_928_46,
    0.199_918_720_292_643_07,
    -0.141_977_977_954_079_88,
    0.106_183_706_424_793_12,
    -0.074_568_548_385_217_22,
    0.042_137_623_745_702_51,
    -0.015_731_249_223_588_546,
    0.002_766_283_528_318_227_7,
];

/// Bound (radians) used on the error of [`atan2_approx`]: ten times its
/// largest error.
const ATAN_GUARD: f64 = 1e-7;

/// `atan2(y, x)` in `[-pi, pi]` to within 1e-8 rad, for finite `(x, y)` not
/// both zero, without a libm call: reduced to `t = min / max` of `|x|, |y|`
/// in `[0, 1]`, [`ATAN_COEFFS`], then unfolded by octant and sign.
#[inline]
fn atan2_approx(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    let t = lo / hi;
    let s = t * t;
    let [c0, rest @ ..] = ATAN_COEFFS;
    let p = rest.iter().rev().fold(0.0, |p, &c| (p + c) * s) + c0;
    let mut a = t * p;
    if ay > ax {
        a = std::f64::consts::FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    a.copysign(y)
}

/// Azimuth cell in `band` (1-based) of the direction with horizontal
/// components `(x, y)` (finite, not both zero): exactly
/// `cell_of_phi(band, y.atan2(x))`, the cell of libm's `atan2`. The cell
/// comes from [`atan2_approx`] unless that puts the azimuth within the
/// guard ([`ATAN_GUARD`] plus rounding) of a cell edge; there, where the
/// two could disagree, `atan2` itself decides.
#[inline]
fn cell_of_xy(band: usize, y: f64, x: f64) -> usize {
    let n = 4 * band;
    let per_radian = n as f64 * (1.0 / TAU);
    // Cells from the edge below cell 0, shifted by n to be positive (in
    // [n/2, 3n/2 + 1/2]), so truncation is the floor. Truncated to i64, not
    // usize: the same integer for these values, and fewer instructions
    // (x86-64 has no unsigned conversion).
    let v = atan2_approx(y, x) * per_radian + (0.5 + n as f64);
    let k = v as i64;
    let frac = v - k as f64;
    // 1e-9 cells covers the rounding of v and per_radian (n <= 4000:
    // ulp(6000) = 9e-13).
    let guard = ATAN_GUARD * per_radian + 1e-9;
    if frac > guard && frac < 1.0 - guard {
        let n = n as i64;
        (if k >= n { k - n } else { k }) as usize
    } else {
        CarlsonGrid::cell_of_phi(band, y.atan2(x))
    }
}

/// A [`CarlsonGrid`] with its band edges tabulated: the same cells as
/// [`CarlsonGrid::locate`] and [`CarlsonGrid::cells_of`] without their
/// divisions and square root, for scoring many photons.
///
/// The band of `mu` starts from a guess read from a table of `mu`'s
/// buckets (the band of the bucket's top) and is corrected against the
/// same once-rounded edges as [`CarlsonGrid::locate`]'s closed-form guess
/// (`CarlsonGrid::band_of_mu`), whose corrections end on the one band
/// holding `mu` from any start: the same band for every input. With at least
/// two buckets per band's width in `mu` the correction is at most one step.
#[derive(Debug, Clone, PartialEq)]
pub struct Locator {
    grid: CarlsonGrid,
    /// `mu_bot` of band `j` at `j` for `j = 0..=M` ([`CarlsonGrid::mu_edges`];
    /// 1 at 0, the top of band 1).
    mu_bot: Vec<f64>,
    /// Per bucket `b` of `mu` (`[b, b + 1) / buckets`), the band of its top
    /// `(b + 1) / buckets`: the band of smallest index that meets it.
    guess: Vec<u32>,
    /// Buckets per unit of `mu` (`guess.len()`, as `f64`).
    per_mu: f64,
}

/// Most buckets of a [`Locator`]'s band guesses (16 KiB of guesses): the
/// narrowest band, band 1, is `2 / K` wide in `mu`, so up to 1024 bands'
/// worth of `K` the guess is at most one band off (M = 32: 4096 buckets
/// for 1056).
const MAX_BUCKETS: usize = 4096;

impl Locator {
    /// The locator of `grid`.
    #[must_use]
    pub fn new(grid: CarlsonGrid) -> Self {
        let mut mu_bot = vec![1.0];
        mu_bot.extend((1..=grid.bands).map(|j| grid.mu_edges(j).0));
        let buckets = (2 * grid.k()).next_power_of_two().clamp(64, MAX_BUCKETS);
        let guess = (1..=buckets)
            .map(|b| {
                let top = b as f64 / buckets as f64;
                let band = grid.band_of_mu(top, |j| mu_bot[j]);
                u32::try_from(band).unwrap_or(u32::MAX)
            })
            .collect();
        Self {
            grid,
            mu_bot,
            guess,
            per_mu: buckets as f64,
        }
    }

    /// The grid.
    #[must_use]
    pub fn grid(&self) -> &CarlsonGrid {
        &self.grid
    }

    /// [`CarlsonGrid::locate`].
    #[must_use]
    #[inline]
    pub fn locate(&self, dir: DVec3) -> Option<usize> {
        // Finite and upward: `v - v` is 0 for a finite `v`, NaN otherwise
        // (one test, no branch per component).
        #[allow(clippy::eq_op, reason = "v - v tests v for finiteness")]
        let finite = (dir.x - dir.x) + (dir.y - dir.y) + (dir.z - dir.z) == 0.0;
        if !(finite && dir.z > 0.0) {
            return None;
        }
        let band = self.band_of_mu(dir.z);
        Some(flat_index(band, cell_of_xy(band, dir.y, dir.x)))
    }

    /// `CarlsonGrid::band_of_mu` of finite `mu > 0` from the bucket's guess.
    #[inline]
    fn band_of_mu(&self, mu: f64) -> usize {
        let last = self.guess.len() - 1;
        // mu > 0, so the truncation is the floor; mu >= 1 is the last bucket.
        let bucket = ((mu * self.per_mu) as i64).min(last as i64) as usize;
        let mut j = (self.guess[bucket] as usize).clamp(1, self.grid.bands);
        // Correct against the edges, as `CarlsonGrid::band_of_mu`.
        while j < self.grid.bands && mu < self.mu_bot[j] {
            j += 1;
        }
        while j > 1 && mu >= self.mu_bot[j - 1] {
            j -= 1;
        }
        j
    }

    /// [`CarlsonGrid::cells_of`].
    #[must_use]
    #[inline]
    pub fn cells_of(&self, dir: DVec3) -> (Cells, f64) {
        shares(dir, |d| self.locate(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn dir_from(mu: f64, phi: f64) -> DVec3 {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), mu)
    }

    /// Cosine-weighted direction: P(mu < m) = m^2, phi uniform in `[0, phi_max)`.
    fn sample_cosine(rng: &mut Pcg64Mcg, phi_max: f64) -> DVec3 {
        let mu = rng.random::<f64>().sqrt();
        let phi = phi_max * rng.random::<f64>();
        dir_from(mu, phi)
    }

    /// The cell of `dir` as the grid located it before [`cell_of_xy`]:
    /// the band against [`CarlsonGrid::mu_edges`], the azimuth cell of
    /// libm's `atan2`.
    fn reference_locate(g: &CarlsonGrid, dir: DVec3) -> Option<usize> {
        if !dir.is_finite() || dir.z <= 0.0 {
            return None;
        }
        let band = g.band_of_mu(dir.z, |j| if j == 0 { 1.0 } else { g.mu_edges(j).0 });
        Some(g.index(band, CarlsonGrid::cell_of_phi(band, dir.y.atan2(dir.x))))
    }

    #[test]
    fn atan2_approx_within_its_bound() {
        let mut worst = 0.0_f64;
        let n = 2_000_000;
        for i in 0..=n {
            let phi = -PI + TAU * i as f64 / n as f64;
            let (y, x) = phi.sin_cos();
            for r in [1.0, 1e-3, 7.5e5] {
                let err = (atan2_approx(r * y, r * x) - (r * y).atan2(r * x)).abs();
                worst = worst.max(err);
            }
        }
        assert!(worst < 1e-8, "{worst}");
        assert!(10.0 * worst < ATAN_GUARD + 1e-9);
        for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (1.0, 1.0)] {
            assert!((atan2_approx(y, x) - f64::atan2(y, x)).abs() < 1e-8);
        }
    }

    /// Azimuths on and around every cell edge of many bands (a few ulps
    /// either side in x and y), the axes with either sign of zero and random
    /// directions: always the cell of libm's atan2.
    #[test]
    fn cell_of_xy_is_the_cell_of_atan2() {
        let mut rng = Pcg64Mcg::seed_from_u64(14);
        let check = |band: usize, y: f64, x: f64| {
            assert_eq!(
                cell_of_xy(band, y, x),
                CarlsonGrid::cell_of_phi(band, y.atan2(x)),
                "band {band} y {y:e} x {x:e}"
            );
        };
        let bands = (1..=64).chain([100, 127, 128, 250, 333, 500, 999, 1000]);
        for band in bands {
            let n = 4 * band;
            for e in 0..n {
                let edge = (e as f64 + 0.5) * TAU / n as f64;
                for phi in [edge, edge - TAU, edge.next_up(), edge.next_down()] {
                    let (y0, x0) = phi.sin_cos();
                    for r in [1.0, 0.3, 1e-8] {
                        let (mut y, mut x) = (r * y0, r * x0);
                        for _ in 0..3 {
                            check(band, y, x);
                            check(band, y.next_up(), x);
                            check(band, y.next_down(), x);
                            check(band, y, x.next_up());
                            check(band, y, x.next_down());
                            (y, x) = (y.next_up(), x.next_down());
                        }
                    }
                }
                // Near the edge within the guard band and just outside it.
                for off in [1e-6, 1e-9, 1e-12, 3e-8, 2e-7] {
                    for phi in [edge + off, edge - off] {
                        let (y, x) = phi.sin_cos();
                        check(band, y, x);
                    }
                }
            }
            for (y, x) in [
                (0.0, 1.0),
                (-0.0, 1.0),
                (0.0, -1.0),
                (-0.0, -1.0),
                (1.0, 0.0),
                (1.0, -0.0),
                (-1.0, 0.0),
                (-1.0, -0.0),
                (1.0, 1.0),
                (-1.0, 1.0),
                (1.0, -1.0),
                (-1.0, -1.0),
                (1e-300, 1.0),
                (1.0, 1e-300),
                (-5e-324, -1.0),
            ] {
                check(band, y, x);
            }
            for _ in 0..2000 {
                let phi = TAU * rng.random::<f64>();
                let (y, x) = phi.sin_cos();
                check(band, y, x);
            }
        }
    }

    /// [`CarlsonGrid::locate`], [`Locator::locate`] and the reference agree
    /// on random directions, band edges, the pole and the horizon, and so do
    /// the cells and shares.
    #[test]
    fn locator_matches_the_grid_and_the_reference() {
        let mut rng = Pcg64Mcg::seed_from_u64(1976);
        for m in (1..=40).chain([100, 1000]) {
            let g = CarlsonGrid::new(m).unwrap();
            let l = Locator::new(g);
            assert_eq!(l.grid(), &g);
            let check = |d: DVec3| {
                let want = reference_locate(&g, d);
                assert_eq!(g.locate(d), want, "M {m} {d}");
                assert_eq!(l.locate(d), want, "M {m} {d}");
                assert_eq!(l.cells_of(d), g.cells_of(d), "M {m} {d}");
            };
            for _ in 0..5000 {
                check(sample_cosine(&mut rng, TAU));
            }
            for band in 1..=m {
                let (bot, top) = g.mu_edges(band);
                for mu in [bot, top, bot.next_up(), top.next_down(), bot.next_down()] {
                    for phi in [0.0, 1.0, -2.5, PI] {
                        check(dir_from(mu, phi));
                    }
                }
            }
            for d in [
                DVec3::Z,
                DVec3::new(0.0, 0.0, 1.0 + 1e-12),
                DVec3::new(1e-300, 0.0, 1.0),
                DVec3::new(1.0, 0.0, 1e-300),
                DVec3::new(0.0, -1.0, 5e-324),
                DVec3::new(0.6, 0.0, 0.8),
                DVec3::X,
                DVec3::new(f64::NAN, 0.0, 0.5),
                DVec3::new(0.0, 0.0, -1.0),
            ] {
                check(d);
            }
        }
    }

    /// The band of [`Locator`]'s bucket guesses is the band of
    /// [`CarlsonGrid::locate`] on every edge, a few ulps either side of it,
    /// every bucket boundary and either side of it, the pole, past the
    /// pole and near the horizon, for grids up to past the buckets'
    /// resolution (5000 bands: several corrections a lookup).
    #[test]
    fn locator_bands_are_the_grid_bands() {
        for m in (1..=300).chain([500, 1000, 2000, 5000]) {
            let g = CarlsonGrid::new(m).unwrap();
            let l = Locator::new(g);
            let k = g.k();
            let check = |mu: f64| {
                if mu > 0.0 {
                    let want = g.band_of_mu(mu, |j| (k - j * (j + 1)) as f64 / k as f64);
                    assert_eq!(l.band_of_mu(mu), want, "M {m} mu {mu:e}");
                }
            };
            let near = |mu: f64| {
                let (mut up, mut down) = (mu, mu);
                for _ in 0..3 {
                    check(up);
                    check(down);
                    (up, down) = (up.next_up(), down.next_down());
                }
            };
            for band in 1..=m {
                near(g.mu_edges(band).0);
            }
            let buckets = l.guess.len();
            for b in 0..=buckets {
                near(b as f64 / buckets as f64);
            }
            for mu in [1.0, 1.0 + 1e-12, 1.5, 1e300, 5e-324, 1e-300, 1e-9] {
                check(mu);
            }
        }
    }

    #[test]
    fn zero_bands_rejected() {
        assert!(CarlsonGrid::new(0).is_none());
        assert_eq!(CarlsonGrid::new(1).unwrap().n_cells(), 4);
    }

    #[test]
    fn m4_edges_and_counts() {
        let g = CarlsonGrid::new(4).unwrap();
        let expected = [1.0, 0.9, 0.7, 0.4, 0.0];
        for band in 1..=4 {
            let (bot, top) = g.mu_edges(band);
            assert!((top - expected[band - 1]).abs() <= 1e-15);
            assert!((bot - expected[band]).abs() <= 1e-15);
            assert_eq!(g.cells_in_band(band), 4 * band);
        }
        assert_eq!(
            (1..=4).map(|b| g.cells_in_band(b)).collect::<Vec<_>>(),
            vec![4, 8, 12, 16]
        );
        assert_eq!(g.n_cells(), 40);
        assert!((g.solid_angle() - PI / 20.0).abs() < 1e-16);
    }

    #[test]
    fn index_round_trips() {
        for m in 1..=30 {
            let g = CarlsonGrid::new(m).unwrap();
            let mut flat = 0;
            for band in 1..=m {
                for cell in 0..4 * band {
                    assert_eq!(g.index(band, cell), flat);
                    assert_eq!(g.band_cell(flat), (band, cell));
                    flat += 1;
                }
            }
            assert_eq!(flat, g.n_cells());
        }
    }

    #[test]
    fn solid_angles_sum_to_two_pi_and_match_edges() {
        for m in 1..=40 {
            let g = CarlsonGrid::new(m).unwrap();
            let mut total = 0.0;
            for band in 1..=m {
                let (bot, top) = g.mu_edges(band);
                for cell in 0..4 * band {
                    let (lo, hi) = g.phi_edges(band, cell);
                    let omega = (hi - lo) * (top - bot);
                    assert!((omega - g.solid_angle()).abs() < 1e-13 * g.solid_angle());
                    total += omega;
                }
            }
            assert!((total - TAU).abs() < 1e-12, "M = {m}: {total}");
            assert!((g.n_cells() as f64 * g.solid_angle() - TAU).abs() < 1e-12);
        }
    }

    #[test]
    fn projected_solid_angles_sum_to_pi_and_match_closed_form() {
        for m in 1..=40 {
            let g = CarlsonGrid::new(m).unwrap();
            let k = (m * (m + 1)) as f64;
            let mut total = 0.0;
            for band in 1..=m {
                // The defining formula, dphi (mu_top^2 - mu_bot^2) / 2; it loses
                // a few digits to cancellation, hence the looser tolerance.
                let (bot, top) = g.mu_edges(band);
                let dphi = TAU / (4 * band) as f64;
                let by_edges = dphi * (top * top - bot * bot) / 2.0;
                // Exact rational form pi (K - j^2) / K^2.
                let exact = PI * (k - (band * band) as f64) / (k * k);
                for cell in 0..4 * band {
                    let p = g.projected_solid_angle(band, cell);
                    assert!((p - exact).abs() <= 1e-15 * exact, "M {m} band {band}");
                    assert!((p - by_edges).abs() <= 1e-12 * exact, "M {m} band {band}");
                    total += p;
                }
            }
            assert!((total - PI).abs() < 1e-12, "M = {m}: {total}");
        }
    }

    #[test]
    fn phi_edges_and_centres() {
        let g = CarlsonGrid::new(3).unwrap();
        let h = TAU / 12.0; // band 3: 12 cells of width h
        let (lo, hi) = g.phi_edges(3, 0);
        assert!((lo + h / 2.0).abs() < 1e-15 && (hi - h / 2.0).abs() < 1e-15);
        let (lo, hi) = g.phi_edges(3, 5);
        assert!((lo - 4.5 * h).abs() < 1e-15 && (hi - 5.5 * h).abs() < 1e-15);
        let (theta, phi) = g.centre(3, 5);
        let (bot, top) = g.mu_edges(3);
        assert!((theta.cos() - (top + bot) / 2.0).abs() < 1e-15);
        assert!((phi - 5.0 * h).abs() < 1e-15);
    }

    #[test]
    fn locate_cell_centres() {
        for m in 1..=40 {
            let g = CarlsonGrid::new(m).unwrap();
            for band in 1..=m {
                for cell in 0..4 * band {
                    let (theta, phi) = g.centre(band, cell);
                    let d = DVec3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    );
                    assert_eq!(
                        g.locate(d),
                        Some(g.index(band, cell)),
                        "M {m} {band} {cell}"
                    );
                }
            }
        }
    }

    #[test]
    fn locate_band_edges_exactly() {
        for m in 1..=200 {
            let g = CarlsonGrid::new(m).unwrap();
            let band_of = |mu: f64| g.band_cell(g.locate(dir_from(mu, 0.0)).unwrap()).0;
            for band in 1..m {
                // mu_bot of `band` is the edge between `band` and `band + 1`.
                let edge = g.mu_edges(band).0;
                assert_eq!(g.mu_edges(band + 1).1, edge);
                assert_eq!(band_of(edge), band, "M {m} at edge of band {band}");
                assert_eq!(band_of(edge.next_up()), band, "M {m} above {band}");
                assert_eq!(band_of(edge.next_down()), band + 1, "M {m} below {band}");
                assert_eq!(band_of(edge + 1e-12), band);
                assert_eq!(band_of(edge - 1e-12), band + 1);
            }
            // Pole and horizon.
            assert_eq!(g.locate(DVec3::Z), Some(0));
            assert_eq!(band_of(1e-300), m);
        }
    }

    #[test]
    fn locate_azimuth_edges() {
        let g = CarlsonGrid::new(2).unwrap(); // band 2: 8 cells, h = pi/8
        let mu = g.centre(2, 0).0.cos();
        let h = PI / 8.0;
        let cell_of = |phi: f64| g.band_cell(g.locate(dir_from(mu, phi)).unwrap()).1;
        assert_eq!(cell_of(0.0), 0);
        assert_eq!(cell_of(h - 1e-9), 0);
        assert_eq!(cell_of(h + 1e-9), 1);
        assert_eq!(cell_of(-h + 1e-9), 0);
        assert_eq!(cell_of(-h - 1e-9), 7);
        assert_eq!(cell_of(TAU - 1e-9), 0);
        assert_eq!(cell_of(PI), 4);
    }

    #[test]
    fn locate_rejects_lower_hemisphere_and_non_finite() {
        let g = CarlsonGrid::new(5).unwrap();
        assert_eq!(g.locate(DVec3::X), None);
        assert_eq!(g.locate(DVec3::new(0.0, 0.6, -0.8)), None);
        assert_eq!(g.locate(DVec3::new(f64::NAN, 0.0, 0.5)), None);
        assert_eq!(g.locate(DVec3::new(0.0, f64::INFINITY, 0.5)), None);
        // Slightly non-unit pole still lands in band 1.
        assert_eq!(g.locate(DVec3::new(0.0, 0.0, 1.0 + 1e-12)), Some(0));
    }

    #[test]
    fn lambertian_band_fractions() {
        for m in [3, 10] {
            let g = CarlsonGrid::new(m).unwrap();
            let mut rng = Pcg64Mcg::seed_from_u64(0x5eed + m as u64);
            let n = 200_000;
            // counts[j - 1] is the number of samples in band j.
            let mut counts = vec![0u64; m];
            for _ in 0..n {
                let flat = g.locate(sample_cosine(&mut rng, TAU)).unwrap();
                counts[g.band_cell(flat).0 - 1] += 1;
            }
            for (band, &count) in (1..=m).zip(&counts) {
                let (bot, top) = g.mu_edges(band);
                let p = top * top - bot * bot;
                let frac = count as f64 / n as f64;
                let sigma = (p * (1.0 - p) / n as f64).sqrt();
                assert!(
                    (frac - p).abs() < 4.0 * sigma,
                    "M {m} band {band}: {frac} vs {p} (sigma {sigma})"
                );
            }
        }
    }

    /// Chi-square over cells for a cosine-weighted source confined to the
    /// quadrant `phi in [0, pi/2)`, which also checks the half-cell azimuth
    /// offset (cell 0 and cell `band` are only half lit).
    #[test]
    fn lambertian_quadrant_chi_square() {
        let m = 10;
        let g = CarlsonGrid::new(m).unwrap();
        let mut rng = Pcg64Mcg::seed_from_u64(1976);
        let n = 200_000;
        let mut counts = vec![0u64; g.n_cells()];
        for _ in 0..n {
            counts[g.locate(sample_cosine(&mut rng, PI / 2.0)).unwrap()] += 1;
        }
        let mut chi2 = 0.0;
        let mut dof = 0usize;
        for (flat, &count) in counts.iter().enumerate() {
            let (band, cell) = g.band_cell(flat);
            let (bot, top) = g.mu_edges(band);
            let (lo, hi) = g.phi_edges(band, cell);
            let overlap = (hi.min(PI / 2.0) - lo.max(0.0)).max(0.0);
            let p = (top * top - bot * bot) * overlap / (PI / 2.0);
            if p == 0.0 {
                assert_eq!(count, 0, "cell {flat} outside the quadrant was hit");
                continue;
            }
            let expected = p * n as f64;
            chi2 += (count as f64 - expected).powi(2) / expected;
            dof += 1;
        }
        let dof = (dof - 1) as f64;
        assert!(
            chi2 < dof + 5.0 * (2.0 * dof).sqrt(),
            "chi2 {chi2} for {dof} dof"
        );
    }
}
