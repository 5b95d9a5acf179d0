//! Height-field micro geometry: a periodic grid of heights, triangulated,
//! traced exactly (issue 5).
//!
//! # Geometry
//!
//! A [`HeightField`] holds `nx x ny` heights `h[j nx + i]` (length units) at
//! the vertices `(x_i, y_j) = (i px, j py)` of a periodic grid over the cell
//! `[0, Lx] x [0, Ly]`, with pitch `(px, py) = (Lx / nx, Ly / ny)`. The field
//! tiles the plane: vertex `(i + nx, j)` is vertex `(i, j)`, and so on.
//!
//! Every grid square `(i, j)` (corners `h00 = h(i, j)`, `h10 = h(i + 1, j)`,
//! `h11 = h(i + 1, j + 1)`, `h01 = h(i, j + 1)`) is split by the FIXED
//! diagonal from `(i, j)` to `(i + 1, j + 1)` into two triangles:
//!
//! * half 0, `A`: `(i, j), (i + 1, j), (i + 1, j + 1)`: where the local
//!   coordinates `a = x / px - i`, `b = y / py - j` have `a >= b`;
//! * half 1, `B`: `(i, j), (i + 1, j + 1), (i, j + 1)`: where `a <= b`.
//!
//! Triangle `2 (j nx + i) + half` is identified by that number. This is the
//! triangulation `roks export-mesh` writes (the same vertices, the same
//! diagonal, the same winding), so a renderer given the mesh sees exactly
//! these triangles. The surface is a graph `z = h(x, y)`, continuous and
//! piecewise linear, with upward normals; the solid lies below it.
//!
//! # Traversal
//!
//! A flight `o + t d` walks the grid squares under it in order (a 2-D DDA in
//! grid units `u = x / px`, `v = y / py`, on unbounded integer square indices
//! taken modulo `nx`, `ny` only to read heights, so the walk crosses the cell's
//! sides as if they were not there: no seam). A max-height mip hierarchy
//! (level 0: the highest corner of each square; level `L`: the highest of
//! the `2^L x 2^L` squares of a node, partial nodes at the ends for any `n`)
//! skips every node the flight passes above: at each step the walk takes the
//! node of the current level containing the current square, and if the
//! lowest point of the flight over that node (at its entry or exit) is above
//! the node's maximum it jumps to the node's exit and moves one level up;
//! otherwise it moves one level down, and at level 0 it tests the square.
//! Far from the surface a flight takes `O(log n)` steps; near the hit it
//! tests the few squares where it is lower than their highest corner.
//!
//! # Watertightness: one function along the flight
//!
//! Along the flight the height of the ray above the surface,
//! `f(t) = z(t) - h(x(t), y(t))`, is continuous and piecewise linear with
//! breakpoints where the flight crosses a square side or a diagonal. The walk
//! evaluates `f` ONCE at each breakpoint (from the heights of the edge the
//! breakpoint lies on) and hands that same value to the next piece, so two
//! triangles sharing an edge can never disagree about which side of the
//! surface the ray is on there: a sign change of `f` cannot fall between two
//! triangles. The flight hits the first piece (a triangle over a `t`
//! interval) whose end value is negative while the ray descends relative to
//! that triangle (`d . n < 0`); the hit distance is the exact ray-plane
//! intersection with that triangle, `t_in + f_in / (-slope)`, clamped to the
//! piece. Values carried into a piece are taken as `max(f, 0)`: every flight
//! starts on or above the surface, so a negative value there is rounding.
//! Consequences: no ray reaches the space below the surface; where two
//! triangles share an edge the hit is attributed to the first in the
//! flight's order; a ray can pass unreflected only where it meets the
//! surface within rounding of an edge while rising relative to the next
//! triangle (it then stays above the surface).
//!
//! # Self-hits
//!
//! A reflected flight starts on its triangle `T` and, by construction,
//! rises relative to `T`'s plane (`d . n_T > 0`), so it cannot meet `T`
//! again: `T` is excluded (its pieces are walked but never hit), which also
//! covers `d . n_T` rounding to a tiny negative value. Every other triangle
//! is tested normally: a concave neighbour across an edge of `T` (a valley)
//! can be hit at any distance down to 0, as it must be; a convex neighbour
//! (a ridge) lies below `T`'s plane near the edge and the rising flight does
//! not descend towards it.
//!
//! # Units
//!
//! Heights, pitches and distances are in the scene's length units (those of
//! `[surface] size`); `t` is in units of `|d|` (the transport passes unit
//! directions).

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

/// Most walk steps of one flight before it is given up as trapped (a ray
/// almost horizontal and below the highest point can otherwise wander for
/// very long); the transport reports such photons as capped.
const MAX_STEPS: u32 = 1 << 24;

/// What a flight through a height field meets first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FieldEvent {
    /// Hits triangle `triangle` at distance `t` (the point may lie in a
    /// neighbouring period: fold it back with [`HeightField::fold`]).
    Hit {
        /// Distance (units of `|d|`).
        t: f64,
        /// Triangle id `2 (j nx + i) + half` (see the module docs).
        triangle: usize,
    },
    /// Rises above the highest point: nothing more to meet.
    Escapes,
    /// Horizontal above everything, or walked [`MAX_STEPS`] steps.
    Trapped,
}

/// A periodic height field over the cell (see the module docs).
#[derive(Clone, Debug)]
pub struct HeightField {
    /// Grid squares (and vertices) per period along x.
    pub nx: usize,
    /// Grid squares (and vertices) per period along y.
    pub ny: usize,
    /// Cell size `(Lx, Ly)` (length units).
    pub size: DVec2,
    /// Grid pitch `(Lx / nx, Ly / ny)` (length units).
    pub pitch: DVec2,
    /// Heights at the vertices, `h[j nx + i]` at `(i px, j py)` (length units).
    pub h: Vec<f64>,
    /// Highest vertex (length units).
    pub max: f64,
    /// Lowest vertex (length units).
    pub min: f64,
    /// Max-height mip levels; level 0 per square, the last one node for the period.
    levels: Vec<Level>,
}

/// One level of the max-height hierarchy.
#[derive(Clone, Debug)]
struct Level {
    /// Nodes along x: `ceil(nx / 2^L)`.
    w: usize,
    /// Highest vertex of each node's squares (corners included), row-major.
    max: Vec<f64>,
}

impl HeightField {
    /// A height field of `nx x ny` vertex heights `h[j nx + i]` over a cell of
    /// `size` (length units).
    ///
    /// # Panics
    ///
    /// If `nx` or `ny` is below 2, `h.len() != nx ny`, a height is not
    /// finite, or the size is not finite and positive.
    #[must_use]
    pub fn new(nx: usize, ny: usize, size: DVec2, h: Vec<f64>) -> Self {
        assert!(nx >= 2 && ny >= 2, "height field of {nx} x {ny}: need 2 x 2");
        assert_eq!(h.len(), nx * ny, "height field: {nx} x {ny} heights");
        assert!(h.iter().all(|z| z.is_finite()), "height field: non-finite height");
        assert!(
            size.is_finite() && size.min_element() > 0.0,
            "height field: size {size}"
        );
        let (min, max) = h
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &z| {
                (lo.min(z), hi.max(z))
            });
        let at = |i: usize, j: usize| h[(j % ny) * nx + i % nx];
        let mut levels = vec![Level {
            w: nx,
            max: (0..nx * ny)
                .map(|k| {
                    let (i, j) = (k % nx, k / nx);
                    at(i, j)
                        .max(at(i + 1, j))
                        .max(at(i, j + 1))
                        .max(at(i + 1, j + 1))
                })
                .collect(),
        }];
        let (mut w, mut hgt) = (nx, ny);
        while w > 1 || hgt > 1 {
            let (w2, h2) = (w.div_ceil(2), hgt.div_ceil(2));
            let below = levels.last().expect("level 0");
            let max = (0..w2 * h2)
                .map(|k| {
                    let (i, j) = (k % w2, k / w2);
                    let mut m = f64::NEG_INFINITY;
                    for cj in (2 * j)..(2 * j + 2).min(hgt) {
                        for ci in (2 * i)..(2 * i + 2).min(w) {
                            m = m.max(below.max[cj * w + ci]);
                        }
                    }
                    m
                })
                .collect();
            levels.push(Level { w: w2, max });
            (w, hgt) = (w2, h2);
        }
        Self {
            nx,
            ny,
            size,
            pitch: DVec2::new(size.x / nx as f64, size.y / ny as f64),
            h,
            max,
            min,
            levels,
        }
    }

    /// Height of vertex `(i, j)`, indices taken modulo the period.
    #[must_use]
    #[inline]
    pub fn vertex(&self, i: i64, j: i64) -> f64 {
        let i = i.rem_euclid(self.nx as i64) as usize;
        let j = j.rem_euclid(self.ny as i64) as usize;
        self.h[j * self.nx + i]
    }

    /// Corner heights `[h00, h10, h01, h11]` of square `(i, j)` (any integers).
    #[inline]
    fn corners(&self, i: i64, j: i64) -> [f64; 4] {
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let (i0, j0) = (i.rem_euclid(nx) as usize, j.rem_euclid(ny) as usize);
        let i1 = if i0 + 1 == self.nx { 0 } else { i0 + 1 };
        let j1 = if j0 + 1 == self.ny { 0 } else { j0 + 1 };
        let (r0, r1) = (j0 * self.nx, j1 * self.nx);
        [self.h[r0 + i0], self.h[r0 + i1], self.h[r1 + i0], self.h[r1 + i1]]
    }

    /// Gradient `(dh/dx, dh/dy)` of triangle `half` of a square with corners `c`.
    #[inline]
    fn gradient(&self, c: [f64; 4], half: usize) -> DVec2 {
        let [h00, h10, h01, h11] = c;
        if half == 0 {
            DVec2::new((h10 - h00) / self.pitch.x, (h11 - h10) / self.pitch.y)
        } else {
            DVec2::new((h11 - h01) / self.pitch.x, (h01 - h00) / self.pitch.y)
        }
    }

    /// Upward unit normal of triangle `triangle` (see the module docs for ids).
    #[must_use]
    pub fn normal(&self, triangle: usize) -> DVec3 {
        let square = triangle / 2;
        let (i, j) = ((square % self.nx) as i64, (square / self.nx) as i64);
        let g = self.gradient(self.corners(i, j), triangle % 2);
        DVec3::new(-g.x, -g.y, 1.0).normalize()
    }

    /// The three vertices of triangle `triangle` in cell coordinates, in the
    /// order of the module docs (counter-clockwise seen from above); vertices
    /// on the far sides have `x = Lx` or `y = Ly`.
    #[must_use]
    pub fn triangle_vertices(&self, triangle: usize) -> [DVec3; 3] {
        let square = triangle / 2;
        let (i, j) = (square % self.nx, square / self.nx);
        let p = |di: usize, dj: usize| {
            let (ii, jj) = (i + di, j + dj);
            DVec3::new(
                self.size.x * (ii as f64 / self.nx as f64),
                self.size.y * (jj as f64 / self.ny as f64),
                self.vertex(ii as i64, jj as i64),
            )
        };
        if triangle % 2 == 0 {
            [p(0, 0), p(1, 0), p(1, 1)]
        } else {
            [p(0, 0), p(1, 1), p(0, 1)]
        }
    }

    /// Height of the surface at `(x, y)` (any point of the plane; periodic).
    #[must_use]
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        let (u, v) = (x / self.pitch.x, y / self.pitch.y);
        let (i, j) = (u.floor(), v.floor());
        surface_height(self.corners(i as i64, j as i64), u - i, v - j)
    }

    /// `p` shifted by whole periods into the cell `[0, Lx] x [0, Ly]`.
    #[must_use]
    #[inline]
    pub fn fold(&self, p: DVec3) -> DVec3 {
        let fold = |x: f64, len: f64| x - (x / len).floor() * len;
        DVec3::new(fold(p.x, self.size.x), fold(p.y, self.size.y), p.z)
    }

    /// The first hit of the flight `o + t d` (`t > 0`), which starts on or
    /// above the surface; `standing`: the triangle it starts on (excluded).
    /// See the module docs for the walk and its robustness rules.
    #[must_use]
    pub fn first_hit(&self, o: DVec3, d: DVec3, standing: Option<usize>) -> FieldEvent {
        if d.z >= 0.0 && o.z > self.max {
            return if d.z > 0.0 {
                FieldEvent::Escapes
            } else {
                FieldEvent::Trapped
            };
        }
        let (ou, ov) = (o.x / self.pitch.x, o.y / self.pitch.y);
        let (du, dv) = (d.x / self.pitch.x, d.y / self.pitch.y);
        let (inv_u, inv_v) = (1.0 / du, 1.0 / dv);
        let z_at = |t: f64| if d.z == 0.0 { o.z } else { o.z + t * d.z };
        let top = self.levels.len() - 1;
        let mut level = top;
        let mut t = 0.0_f64;
        // f at t when carried from the square just tested (None after a skip).
        let mut f_carried: Option<f64> = None;
        let mut i = ou.floor() as i64;
        let mut j = ov.floor() as i64;
        let mut steps = 0_u32;
        loop {
            steps += 1;
            if steps > MAX_STEPS {
                return FieldEvent::Trapped;
            }
            let z = z_at(t);
            if d.z > 0.0 && z > self.max {
                return FieldEvent::Escapes;
            }
            // The node of this level holding square (i, j), in unbounded square indices.
            let (u0, u1, ni) = node_span(i, level, self.nx);
            let (v0, v1, nj) = node_span(j, level, self.ny);
            let tu = if du > 0.0 {
                (u1 as f64 - ou) * inv_u
            } else if du < 0.0 {
                (u0 as f64 - ou) * inv_u
            } else {
                f64::INFINITY
            };
            let tv = if dv > 0.0 {
                (v1 as f64 - ov) * inv_v
            } else if dv < 0.0 {
                (v0 as f64 - ov) * inv_v
            } else {
                f64::INFINITY
            };
            let t_exit = tu.min(tv).max(t);
            let lv = &self.levels[level];
            if z.min(z_at(t_exit)) > lv.max[nj * lv.w + ni] {
                // The flight passes above the whole node: skip it.
                if t_exit == f64::INFINITY {
                    return if d.z > 0.0 {
                        FieldEvent::Escapes
                    } else {
                        FieldEvent::Trapped
                    };
                }
                t = t_exit;
                f_carried = None;
                (i, j) = step_out(tu <= tv, (u0, u1, v0, v1), (du, dv), (ou, ov), t);
                level = (level + 1).min(top);
                continue;
            }
            if level > 0 {
                level -= 1;
                continue;
            }
            let f_in = f_carried.unwrap_or_else(|| {
                let a = (ou - i as f64 + t * du).clamp(0.0, 1.0);
                let b = (ov - j as f64 + t * dv).clamp(0.0, 1.0);
                z - surface_height(self.corners(i, j), a, b)
            });
            match self.square(i, j, (o, d, ou, ov, du, dv), t, t_exit, tu <= tv, f_in, standing) {
                Ok(t_hit_tri) => return t_hit_tri,
                Err(f_out) => f_carried = Some(f_out),
            }
            if t_exit == f64::INFINITY {
                // A vertical flight that rose out of its square's reach.
                return if d.z > 0.0 {
                    FieldEvent::Escapes
                } else {
                    FieldEvent::Trapped
                };
            }
            t = t_exit;
            (i, j) = step_out(tu <= tv, (u0, u1, v0, v1), (du, dv), (ou, ov), t);
            level = 1.min(top);
        }
    }

    /// Test square `(i, j)` over `[t0, t1]` with the carried `f_in` at `t0`.
    /// `exit_u`: the flight leaves through a side `u = const` (else `v = const`).
    /// Returns the hit, or `Err(f at t1)` computed on the edge shared with
    /// the next square.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn square(
        &self,
        i: i64,
        j: i64,
        (o, d, ou, ov, du, dv): (DVec3, DVec3, f64, f64, f64, f64),
        t0: f64,
        t1: f64,
        exit_u: bool,
        f_in: f64,
        standing: Option<usize>,
    ) -> Result<FieldEvent, f64> {
        let c = self.corners(i, j);
        let [h00, h10, h01, h11] = c;
        let (a0, b0) = (ou - i as f64, ov - j as f64);
        let z_at = |t: f64| if d.z == 0.0 { o.z } else { o.z + t * d.z };
        let square = (j.rem_euclid(self.ny as i64) as usize) * self.nx
            + i.rem_euclid(self.nx as i64) as usize;
        // Where the flight crosses the diagonal a = b, if inside (t0, t1).
        let ds = du - dv;
        let t_diag = if ds == 0.0 {
            f64::NAN
        } else {
            (b0 - a0) / ds
        };
        let split = t_diag > t0 && t_diag < t1;
        let t_first_end = if split { t_diag } else { t1 };
        // Which triangle the first piece lies in: the sign of a - b at its middle.
        let t_mid = if t_first_end.is_finite() {
            0.5 * (t0 + t_first_end)
        } else {
            t0 + 1.0
        };
        let first_half = usize::from(a0 - b0 + t_mid * ds < 0.0);
        // f at the end of the flight through the square, on the shared edge.
        let f_exit = || {
            if t1 == f64::INFINITY {
                return f64::NAN;
            }
            let z = z_at(t1);
            if exit_u {
                let b = (b0 + t1 * dv).clamp(0.0, 1.0);
                let (lo, hi) = if du > 0.0 { (h10, h11) } else { (h00, h01) };
                z - (lo + (hi - lo) * b)
            } else {
                let a = (a0 + t1 * du).clamp(0.0, 1.0);
                let (lo, hi) = if dv > 0.0 { (h01, h11) } else { (h00, h10) };
                z - (lo + (hi - lo) * a)
            }
        };
        let piece = |half: usize, ta: f64, tb: f64, fa: f64, fb: f64| -> Option<FieldEvent> {
            let triangle = 2 * square + half;
            if standing == Some(triangle) || tb <= ta {
                return None;
            }
            let g = self.gradient(c, half);
            let slope = d.z - g.x * d.x - g.y * d.y;
            // fb is NaN only for an endless piece (vertical flight): decided by the slope.
            if slope < 0.0 && (fb < 0.0 || fb.is_nan()) {
                let t = (ta + fa.max(0.0) / -slope).min(tb);
                Some(FieldEvent::Hit { t, triangle })
            } else {
                None
            }
        };
        if split {
            let a = (a0 + t_diag * du).clamp(0.0, 1.0);
            let f_diag = z_at(t_diag) - (h00 + (h11 - h00) * a);
            if let Some(hit) = piece(first_half, t0, t_diag, f_in, f_diag) {
                return Ok(hit);
            }
            let f1 = f_exit();
            match piece(1 - first_half, t_diag, t1, f_diag.max(0.0), f1) {
                Some(hit) => Ok(hit),
                None => Err(f1),
            }
        } else {
            let f1 = f_exit();
            match piece(first_half, t0, t1, f_in, f1) {
                Some(hit) => Ok(hit),
                None => Err(f1),
            }
        }
    }

    /// Periodic spectral synthesis of a Gaussian random surface with
    /// autocorrelation `sigma² exp(-r² / tau²)` on an `nx x ny` grid over a
    /// cell of `size` (length units), deterministic from `seed`.
    ///
    /// White noise (`nx ny` standard normals from `Pcg64Mcg(seed)`, row-major,
    /// Box-Muller) is Fourier transformed, filtered by the square root of the
    /// Gaussian power spectrum `S(k) ∝ exp(-|k|² tau² / 4)` on the periodic
    /// frequency lattice `k = 2 pi (m / Lx, n / Ly)` and transformed back. The
    /// `k = 0` term is left out, so the mean height is 0: `z = 0` is the mean
    /// plane. The realisation is then rescaled so that its RMS height is
    /// exactly `sigma`, and every height is rounded to the nearest `f32`
    /// (relative change below `6e-8`), so that the field survives export to
    /// EXR and PLY (`f32`) bit for bit. The realised RMS is `sigma` to that
    /// rounding; the realised autocorrelation length carries sampling error,
    /// and its estimate from one period is biased low by the missing `k = 0`
    /// power (see the README, "Height fields").
    ///
    /// # Panics
    ///
    /// If `nx` or `ny` is below 2, or `sigma`, `tau` or the size is not finite
    /// and positive.
    #[must_use]
    pub fn gaussian(nx: usize, ny: usize, size: DVec2, sigma: f64, tau: f64, seed: u64) -> Self {
        assert!(sigma.is_finite() && sigma > 0.0 && tau.is_finite() && tau > 0.0);
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut buf: Vec<Complex<f64>> = Vec::with_capacity(nx * ny + 1);
        while buf.len() < nx * ny {
            // Box-Muller: two normals from two uniforms, u1 in (0, 1].
            let u1: f64 = 1.0 - rng.random::<f64>();
            let u2: f64 = rng.random::<f64>();
            let r = (-2.0 * u1.ln()).sqrt();
            let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
            buf.push(Complex::new(r * c, 0.0));
            buf.push(Complex::new(r * s, 0.0));
        }
        buf.truncate(nx * ny);
        let mut planner = FftPlanner::new();
        super::surface_stats::fft2(&mut planner, &mut buf, nx, ny, false);
        let k = |m: usize, n: usize, len: f64| {
            let s = if 2 * m < n { m as f64 } else { m as f64 - n as f64 };
            std::f64::consts::TAU * s / len
        };
        for (idx, b) in buf.iter_mut().enumerate() {
            let (kx, ky) = (k(idx % nx, nx, size.x), k(idx / nx, ny, size.y));
            // sqrt of the spectrum; the overall scale is set by the rescaling below.
            let amp = if idx == 0 {
                0.0
            } else {
                (-(kx * kx + ky * ky) * tau * tau / 8.0).exp()
            };
            *b *= amp;
        }
        super::surface_stats::fft2(&mut planner, &mut buf, nx, ny, true);
        let mut h: Vec<f64> = buf.iter().map(|c| c.re).collect();
        drop(buf);
        let n = h.len() as f64;
        let mean = h.iter().sum::<f64>() / n;
        let rms = (h.iter().map(|z| (z - mean) * (z - mean)).sum::<f64>() / n).sqrt();
        let scale = sigma / rms;
        for z in &mut h {
            *z = f64::from(((*z - mean) * scale) as f32);
        }
        Self::new(nx, ny, size, h)
    }
}

/// Height of the triangulated surface at local coordinates `(a, b)` in
/// `[0, 1]²` of a square with corners `c = [h00, h10, h01, h11]`.
#[inline]
fn surface_height(c: [f64; 4], a: f64, b: f64) -> f64 {
    let [h00, h10, h01, h11] = c;
    if a >= b {
        h00 + (h10 - h00) * a + (h11 - h10) * b
    } else {
        h00 + (h11 - h01) * a + (h01 - h00) * b
    }
}

/// The node of `level` holding square `k` (any integer) on an axis of `n`
/// squares: its first and one-past-last square (unbounded indices) and its
/// index within the level.
#[inline]
fn node_span(k: i64, level: usize, n: usize) -> (i64, i64, usize) {
    let km = k.rem_euclid(n as i64) as usize;
    let node = km >> level;
    let first = node << level;
    let start = k - km as i64 + first as i64;
    let len = (1usize << level).min(n - first);
    (start, start + len as i64, node)
}

/// The square entered when the flight leaves the node `[u0, u1) x [v0, v1)`
/// at `t`, through a side `u = const` when `exit_u` (else `v = const`). The
/// other index is taken from the exit point, kept inside the node's range so
/// the walk always advances to a neighbour.
#[inline]
fn step_out(
    exit_u: bool,
    (u0, u1, v0, v1): (i64, i64, i64, i64),
    (du, dv): (f64, f64),
    (ou, ov): (f64, f64),
    t: f64,
) -> (i64, i64) {
    if exit_u {
        let i = if du > 0.0 { u1 } else { u0 - 1 };
        let j = ((ov + t * dv).floor() as i64).clamp(v0, v1 - 1);
        (i, j)
    } else {
        let j = if dv > 0.0 { v1 } else { v0 - 1 };
        let i = ((ou + t * du).floor() as i64).clamp(u0, u1 - 1);
        (i, j)
    }
}
