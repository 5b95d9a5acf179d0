//! The two-dimensional warp that Mitsuba 3's `measured` plugin and pbrt-v4's
//! `MeasuredBxDF` build from the `vndf` and `luminance` fields: a density
//! given at the `w x h` nodes of a regular grid over `[0, 1]²` (node `(i,
//! j)` at `(i / (w - 1), j / (h - 1))`, stored row by row, `x` fastest),
//! interpolated bilinearly and normalised to integrate to 1. A uniform
//! point `s` is mapped to `u` by inverting first the marginal distribution
//! of `y` (piecewise linear, since bilinear interpolation integrated over
//! `x` is linear in `y`), then the conditional distribution of `x` at that
//! `y` (piecewise linear in `x`): the "continuous" scheme of the
//! interpolants in Dupuy & Jakob 2018, section 5 (Mitsuba's
//! `Marginal2D<.., Continuous = true>`). The mapping is a bijection of the
//! unit square where the density is positive; [`Warp::invert`] undoes
//! [`Warp::sample`].
//!
//! roks uses it to place the nodes of the `spectra` table where the
//! renderer's warp puts them (so that the table is resampled exactly at the
//! points the renderer interpolates between), and to read its own files
//! back. Everything here is `f64`; the renderers work in `f32`.

/// A bilinear density on `[0, 1]²` and its marginal and conditional CDFs.
#[derive(Debug, Clone)]
pub struct Warp {
    w: usize,
    h: usize,
    /// Node values, normalised (integral 1).
    data: Vec<f64>,
    /// Per row `j`, the integral over `x` of the density along the row.
    row: Vec<f64>,
    /// Marginal CDF of `y` at the nodes `0..h`.
    marg: Vec<f64>,
}

/// The `t` in `[0, 1]` where `∫_0^t lerp(a, b, τ) dτ = c` (a linear density
/// on one interval, `a, b >= 0`), in the form that is stable both for
/// `a ≈ b` and for `a = 0`.
fn solve_segment(c: f64, a: f64, b: f64) -> f64 {
    let root = (a * a + 2.0 * (b - a) * c).max(0.0).sqrt();
    let denom = a + root;
    if denom > 0.0 {
        (2.0 * c / denom).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// `∫_0^t lerp(a, b, τ) dτ`.
fn segment_integral(t: f64, a: f64, b: f64) -> f64 {
    a * t + 0.5 * (b - a) * t * t
}

/// Index `k` in `0..n-1` of the interval `[cdf[k], cdf[k+1]]` holding `c`.
fn interval(cdf: &[f64], c: f64) -> usize {
    let k = cdf.partition_point(|&v| v <= c);
    k.clamp(1, cdf.len() - 1) - 1
}

impl Warp {
    /// The warp of the node values `values` (`w x h`, row-major, `x`
    /// fastest, non-negative, not all zero).
    ///
    /// # Panics
    /// If `w` or `h` is below 2, the count is not `w h`, or the total is not
    /// positive.
    #[must_use]
    pub fn new(values: &[f64], w: usize, h: usize) -> Self {
        assert!(w >= 2 && h >= 2 && values.len() == w * h, "warp {w} x {h}");
        let (dx, dy) = (1.0 / (w - 1) as f64, 1.0 / (h - 1) as f64);
        let row_of = |v: &[f64], j: usize| -> f64 {
            (0..w - 1)
                .map(|i| 0.5 * (v[j * w + i] + v[j * w + i + 1]) * dx)
                .sum()
        };
        let rows: Vec<f64> = (0..h).map(|j| row_of(values, j)).collect();
        let total: f64 = (0..h - 1).map(|j| 0.5 * (rows[j] + rows[j + 1]) * dy).sum();
        assert!(total > 0.0, "warp of a density that is nowhere positive");
        let data: Vec<f64> = values.iter().map(|v| v / total).collect();
        let row: Vec<f64> = rows.iter().map(|r| r / total).collect();
        let mut marg = vec![0.0; h];
        for j in 1..h {
            marg[j] = marg[j - 1] + 0.5 * (row[j - 1] + row[j]) * dy;
        }
        Self {
            w,
            h,
            data,
            row,
            marg,
        }
    }

    fn value(&self, i: usize, j: usize) -> f64 {
        self.data[j * self.w + i]
    }

    /// The conditional density's node values along `x` at height `y` in
    /// row interval `j` with fraction `t`, and its CDF at the nodes.
    fn conditional(&self, j: usize, t: f64) -> (Vec<f64>, Vec<f64>) {
        let dx = 1.0 / (self.w - 1) as f64;
        let c: Vec<f64> = (0..self.w)
            .map(|i| self.value(i, j) * (1.0 - t) + self.value(i, j + 1) * t)
            .collect();
        let mut cdf = vec![0.0; self.w];
        for i in 1..self.w {
            cdf[i] = cdf[i - 1] + 0.5 * (c[i - 1] + c[i]) * dx;
        }
        (c, cdf)
    }

    /// The point `u` of the unit square that the uniform point `s` maps to.
    #[must_use]
    pub fn sample(&self, s: [f64; 2]) -> [f64; 2] {
        let (dx, dy) = (1.0 / (self.w - 1) as f64, 1.0 / (self.h - 1) as f64);
        let target = s[1].clamp(0.0, 1.0) * self.marg[self.h - 1];
        let j = interval(&self.marg, target);
        let t = solve_segment((target - self.marg[j]) / dy, self.row[j], self.row[j + 1]);
        let (c, cdf) = self.conditional(j, t);
        let target = s[0].clamp(0.0, 1.0) * cdf[self.w - 1];
        let i = interval(&cdf, target);
        let r = solve_segment((target - cdf[i]) / dx, c[i], c[i + 1]);
        [(i as f64 + r) * dx, (j as f64 + t) * dy]
    }

    /// The uniform point that [`sample`](Self::sample) maps to `u`.
    #[must_use]
    pub fn invert(&self, u: [f64; 2]) -> [f64; 2] {
        let (nx, ny) = ((self.w - 1) as f64, (self.h - 1) as f64);
        let (x, y) = (u[0].clamp(0.0, 1.0) * nx, u[1].clamp(0.0, 1.0) * ny);
        let j = (y as usize).min(self.h - 2);
        let t = y - j as f64;
        let sy = self.marg[j] + segment_integral(t, self.row[j], self.row[j + 1]) / ny;
        let (c, cdf) = self.conditional(j, t);
        let i = (x as usize).min(self.w - 2);
        let r = x - i as f64;
        let sx = cdf[i] + segment_integral(r, c[i], c[i + 1]) / nx;
        let total_x = cdf[self.w - 1];
        [
            if total_x > 0.0 { sx / total_x } else { 0.0 },
            sy / self.marg[self.h - 1],
        ]
    }

    /// The normalised density at `u`: the bilinear interpolation of the
    /// nodes.
    #[must_use]
    pub fn eval(&self, u: [f64; 2]) -> f64 {
        bilinear(&self.data, self.w, self.h, u)
    }
}

/// The midpoints of the `n x n` equal cells of the unit square, row by
/// row (`x` fastest): the points of the midpoint rule on it.
pub fn midpoints(n: usize) -> impl Iterator<Item = [f64; 2]> {
    (0..n * n).map(move |k| {
        [
            ((k % n) as f64 + 0.5) / n as f64,
            ((k / n) as f64 + 0.5) / n as f64,
        ]
    })
}

/// Bilinear interpolation at `u` in `[0, 1]²` (clamped) of node values
/// `values` (`w x h`, row-major, `x` fastest): Mitsuba's
/// `Marginal2D::eval` without normalisation.
#[must_use]
pub fn bilinear(values: &[f64], w: usize, h: usize, u: [f64; 2]) -> f64 {
    let (x, y) = (
        u[0].clamp(0.0, 1.0) * (w - 1) as f64,
        u[1].clamp(0.0, 1.0) * (h - 1) as f64,
    );
    let (i, j) = ((x as usize).min(w - 2), (y as usize).min(h - 2));
    let (a, b) = (x - i as f64, y - j as f64);
    let v = |di: usize, dj: usize| values[(j + dj) * w + i + di];
    (1.0 - b) * ((1.0 - a) * v(0, 0) + a * v(1, 0)) + b * ((1.0 - a) * v(0, 1) + a * v(1, 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warp() -> Warp {
        // A lopsided density with a zero node (as the vndf has at theta = 0).
        let w = 5;
        let h = 4;
        let values: Vec<f64> = (0..w * h)
            .map(|k| {
                let (i, j) = ((k % w) as f64, (k / w) as f64);
                i * (1.0 + j * j) + 0.3 * j
            })
            .collect();
        Warp::new(&values, w, h)
    }

    /// The density integrates to 1 (midpoint rule on a fine grid: exact for
    /// a bilinear patch to the rule's error).
    #[test]
    fn density_is_normalised() {
        let w = warp();
        let n = 400;
        let sum: f64 = midpoints(n).map(|u| w.eval(u)).sum::<f64>() / (n * n) as f64;
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
    }

    /// invert(sample(s)) = s, and the Jacobian of `sample` is 1 / density:
    /// a small square of samples maps to an area of (its area / density).
    #[test]
    fn sample_and_invert_are_inverse_and_carry_the_density() {
        let w = warp();
        for k in 0..200 {
            let s = [
                ((k * 37) % 199) as f64 / 199.0 * 0.98 + 0.01,
                ((k * 53) % 197) as f64 / 197.0 * 0.98 + 0.01,
            ];
            let u = w.sample(s);
            let back = w.invert(u);
            assert!(
                (back[0] - s[0]).abs() < 1e-10 && (back[1] - s[1]).abs() < 1e-10,
                "{s:?} {back:?}"
            );
            let e = 1e-6;
            let ux = w.sample([s[0] + e, s[1]]);
            let uy = w.sample([s[0], s[1] + e]);
            let det = ((ux[0] - u[0]) * (uy[1] - u[1]) - (ux[1] - u[1]) * (uy[0] - u[0])) / (e * e);
            let want = 1.0 / w.eval(u);
            assert!((det / want - 1.0).abs() < 1e-3, "{s:?}: {det} vs {want}");
        }
    }

    #[test]
    fn bilinear_hits_nodes_and_midpoints() {
        let v = [1.0, 2.0, 3.0, 5.0];
        assert_eq!(bilinear(&v, 2, 2, [0.0, 0.0]), 1.0);
        assert_eq!(bilinear(&v, 2, 2, [1.0, 1.0]), 5.0);
        assert_eq!(bilinear(&v, 2, 2, [0.5, 0.5]), 2.75);
    }
}
