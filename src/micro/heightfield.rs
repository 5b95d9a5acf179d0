//! Height-field micro geometry: a periodic grid of heights, triangulated,
//! traced exactly.
//!
//! # Geometry
//!
//! A [`HeightField`] holds `nx x ny` heights `h[j nx + i]` (length units) at
//! the vertices `(x_i, y_j) = (i px, j py)` of a periodic grid over the period
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
//! grid units `u = x / px`, `v = y / py`). It keeps the square's index
//! within the period and the period's offset apart, so the walk crosses the
//! period's sides as if they were not there (no seam); the hit point, which
//! may lie in a neighbouring period, is moved back into the period by
//! [`HeightField::fold`]. A max-height mip hierarchy (level `L >= 1`: the
//! highest vertex of the `2^L x 2^L` squares of a node, corners included,
//! partial nodes at the ends for any `n`; level 0 is the square itself and
//! is not stored) skips every node the flight passes above: at each step
//! the walk takes the node of the current level containing the current
//! square, and if the lowest point of the flight over that node (at its
//! entry or its exit) is above the node's maximum it jumps to the node's
//! exit and moves one level up; otherwise it moves one level down, and at
//! level 0 it tests the square's two triangles. A flight starting from the
//! launch plane starts at the top level; a reflected flight starts at its
//! own square (every node holding it is above it). Far from the surface a
//! flight takes `O(log n)` steps; near the hit it tests the few squares
//! where it is lower than the nodes around them.
//!
//! The walk reads a copy of the hierarchy rounded to `f32` and tiled (4 x 4
//! nodes a cache line, so a descent reads about one line every two levels);
//! rounding is monotone, so comparing the flight's `f32` height with it
//! decides as the `f64` comparison would, except on a tie, decided from the
//! exact value. When every height is an `f32` (generated fields, EXR maps)
//! the copy is exact, and the walk also reads the corner heights from `f32`
//! tiles of 8 x 8 squares (a square's corners in one tile); otherwise it
//! keeps the `f64` hierarchy for ties and reads the `f64` heights. The
//! triangle tests are in `f64` either way, with the same values. A
//! non-rising flight does not re-test a node it has descended into while it
//! stays inside (the lowest point over the node, at its exit, is the same),
//! but counts the step as if it had.
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
//! triangles. Within a square, the diagonal crossing `t_diag` is computed
//! once and decides both where the square's two pieces meet and which
//! triangle comes first (from the sign of the crossing), so a piece is never
//! given the triangle on the other side of the diagonal, even for a flight
//! through a corner. The flight hits the first piece (a triangle over a `t`
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

use super::{SKIP_COARSE, SKIP_FINE, doubling_periods};
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
    /// Passes above everything for whole periods: the flight goes on from
    /// `at` (in the period, same direction), where a new walk starts.
    Moved {
        /// The new start.
        at: DVec3,
    },
    /// Horizontal above everything, walked `MAX_STEPS` (2^24) steps, or
    /// crossed [`super::MAX_CROSSINGS`] periods.
    Trapped,
}

/// A periodic height field over the period (see the module docs).
#[derive(Clone, Debug)]
pub struct HeightField {
    /// Grid squares (and vertices) per period along x.
    pub nx: usize,
    /// Grid squares (and vertices) per period along y.
    pub ny: usize,
    /// Period size `(Lx, Ly)` (length units).
    pub size: DVec2,
    /// Grid pitch `(Lx / nx, Ly / ny)` (length units).
    pub pitch: DVec2,
    /// Heights at the vertices, `h[j nx + i]` at `(i px, j py)` (length units).
    pub h: Vec<f64>,
    /// Highest vertex (length units).
    pub max: f64,
    /// Lowest vertex (length units).
    pub min: f64,
    /// The max-height hierarchy ([`max_levels`]) rounded to `f32` and
    /// tiled, as the walk reads it.
    tiled: TiledLevels,
    /// The exact (`f64`) hierarchy, which the walk reads on a tie with the
    /// `f32` copy; `None` when every height is an `f32` (generated fields,
    /// EXR maps), so that the copy is exact.
    exact_levels: Option<Vec<Level>>,
    /// The heights as `f32` in tiles of squares (the same values), when
    /// every height is an `f32`: the walk reads a square's corners there.
    height_tiles: Option<CornerTiles>,
    /// Largest slope `|grad h|` of any triangle (a Lipschitz bound of the
    /// surface): from the largest height step along x and along y edges.
    max_slope: f64,
}

/// Periods of one walk after which [`HeightField::skip_periods`] is asked,
/// at every further period (ordinary flights cross fewer).
const SKIP_AFTER: u32 = 64;

/// What [`HeightField::skip_periods`] found.
enum FieldSkip {
    None,
    /// The flight continues from this point (folded into the period), whole
    /// periods on: a new walk starts there (a distance from the old start
    /// would be too coarse after, say, 1e15 periods).
    To(DVec3),
    Escapes,
}

/// One level of the max-height hierarchy.
#[derive(Clone, Debug)]
struct Level {
    /// Nodes along x: `ceil(nx / 2^L)`.
    w: usize,
    /// Highest vertex of each node's squares (corners included), row-major.
    max: Vec<f64>,
}

/// Most levels of a hierarchy (one per bit of a square index).
const LEVELS_MAX: usize = usize::BITS as usize;

/// Nodes of one [`TiledLevels`] tile: 4 x 4, one 64-byte cache line.
const TILE: usize = 4;

/// A 4 x 4 block of node maxima (row-major within the block), aligned to a
/// cache line.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Tile([f32; TILE * TILE]);

/// The max-height hierarchy as the walk reads it: every level's node maxima
/// rounded to nearest `f32` (length units), stored in tiles of 4 x 4 nodes,
/// the tiles of a level row-major, all levels in one array. The 2 x 2
/// children of a node, and its 4 x 4 grandchildren, lie in one tile: a
/// descent reads about one cache line every two levels, where the
/// row-major `f64` levels take one or two a level.
#[derive(Clone, Debug)]
struct TiledLevels {
    /// The tiles of level 1, then level 2, ...
    tiles: Vec<Tile>,
    /// Per level `L >= 1` (`at[L - 1]`): its first tile, tiles along x (a
    /// fixed array, so that the walk's reads need no bounds check: a level
    /// is below `usize::BITS`).
    at: [(usize, usize); LEVELS_MAX],
    /// Levels stored (the top level's index).
    levels: usize,
}

impl TiledLevels {
    /// The `f32` copy of `levels` (each `levels[L - 1]` of `w` nodes along x);
    /// tile padding beyond a level's nodes holds `+inf` (never read).
    fn new(levels: &[Level]) -> Self {
        let mut tiles = Vec::new();
        let mut at = [(0, 0); LEVELS_MAX];
        for (level, lv) in levels.iter().enumerate() {
            let (w, h) = (lv.w, lv.max.len() / lv.w);
            let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
            let first = tiles.len();
            tiles.resize(first + tw * th, Tile([f32::INFINITY; TILE * TILE]));
            for (k, &m) in lv.max.iter().enumerate() {
                let (ni, nj) = (k % w, k / w);
                tiles[first + (nj / TILE) * tw + ni / TILE].0[(nj % TILE) * TILE + ni % TILE] =
                    m as f32;
            }
            at[level] = (first, tw);
        }
        Self {
            tiles,
            at,
            levels: levels.len(),
        }
    }

    /// The `f32` maximum of node `(ni, nj)` of `level` (>= 1).
    #[inline(always)]
    fn max(&self, level: usize, ni: usize, nj: usize) -> f32 {
        let (first, tw) = self.at[(level - 1) % LEVELS_MAX];
        self.tiles[first + (nj / TILE) * tw + ni / TILE].0[(nj % TILE) * TILE + ni % TILE]
    }
}

/// Squares of a [`CornerTiles`] tile along each axis.
const CORNER_TILE: usize = 8;

/// The `(CORNER_TILE + 1)²` corner heights of a tile's squares, row-major
/// (row stride `CORNER_TILE + 1`), padded to three 128-byte line pairs.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(128))]
struct CornerTile([f32; 96]);

/// The heights as `f32` in tiles of 8 x 8 squares, each tile holding the 9 x 9
/// vertices of its squares (the far row and column repeated from the
/// neighbouring tiles, wrapped across the period's sides), the tiles
/// row-major: a square's four corners are two neighbouring pairs 36 bytes
/// apart in one tile, where the row-major `f64` heights put them a row
/// apart. About 6 bytes a vertex.
#[derive(Clone, Debug)]
struct CornerTiles {
    tiles: Vec<CornerTile>,
    /// Tiles along x.
    w: usize,
}

impl CornerTiles {
    /// The tiles of the `nx x ny` periodic heights `h` (row-major), each of
    /// which is an `f32`; padding holds `NaN` (never read).
    fn new(nx: usize, ny: usize, h: &[f64]) -> Self {
        const N: usize = CORNER_TILE;
        let w = nx.div_ceil(N);
        let mut tiles = vec![CornerTile([f32::NAN; 96]); w * ny.div_ceil(N)];
        for (k, tile) in tiles.iter_mut().enumerate() {
            let (i0, j0) = ((k % w) * N, (k / w) * N);
            for b in 0..=N {
                for a in 0..=N {
                    let z = h[((j0 + b) % ny) * nx + (i0 + a) % nx];
                    tile.0[b * (N + 1) + a] = z as f32;
                }
            }
        }
        Self { tiles, w }
    }

    /// Corner heights `[h00, h10, h01, h11]` of square `(i, j)` of the
    /// period (length units).
    #[inline(always)]
    fn corners(&self, i: usize, j: usize) -> [f64; 4] {
        const N: usize = CORNER_TILE;
        let tile = &self.tiles[(j / N) * self.w + i / N].0;
        let k = (j % N) * (N + 1) + i % N;
        [tile[k], tile[k + 1], tile[k + N + 1], tile[k + N + 2]].map(f64::from)
    }
}

/// Side `k` of the period whose square 0 has unbounded index `base`, in grid units.
#[inline]
fn side(k: usize, base: i64) -> f64 {
    (base + k as i64) as f64
}

impl HeightField {
    /// Estimated peak memory (bytes) of an `nx x ny` field over a run that
    /// also takes its statistics on its own grid: the heights (8 bytes a
    /// vertex), the walk's `f32` hierarchy (4/3) and either the heights'
    /// `f32` tiles (4) or the `f64` hierarchy (8/3) kept, and the larger of
    /// what building them takes beside (the level-1 scratch and the `f64`
    /// hierarchy, 11; the Gaussian synthesis' complex buffer and transpose,
    /// 32) and what [`super::surface_stats`] takes (48). So about 60 bytes a
    /// vertex.
    #[must_use]
    pub fn memory_bytes(nx: usize, ny: usize) -> u64 {
        crate::limits::product(&[nx as u64, ny as u64, 60])
    }

    /// A height field of `nx x ny` vertex heights `h[j nx + i]` over a period of
    /// `size` (length units).
    ///
    /// # Panics
    ///
    /// If `nx` or `ny` is below 2, `h.len() != nx ny`, a height is not
    /// finite, or the size is not finite and positive.
    #[must_use]
    pub fn new(nx: usize, ny: usize, size: DVec2, h: Vec<f64>) -> Self {
        assert!(
            nx >= 2 && ny >= 2,
            "height field of {nx} x {ny}: need 2 x 2"
        );
        assert_eq!(h.len(), nx * ny, "height field: {nx} x {ny} heights");
        assert!(
            h.iter().all(|z| z.is_finite()),
            "height field: non-finite height"
        );
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
        let levels = max_levels(nx, ny, &h);
        let f32_exact = h.iter().all(|&z| f64::from(z as f32) == z);
        let height_tiles = f32_exact.then(|| CornerTiles::new(nx, ny, &h));
        let pitch = DVec2::new(size.x / nx as f64, size.y / ny as f64);
        let (mut step_x, mut step_y) = (0.0_f64, 0.0_f64);
        for j in 0..ny {
            for i in 0..nx {
                step_x = step_x.max((at(i + 1, j) - at(i, j)).abs());
                step_y = step_y.max((at(i, j + 1) - at(i, j)).abs());
            }
        }
        let max_slope = (step_x / pitch.x).hypot(step_y / pitch.y);
        Self {
            nx,
            ny,
            size,
            pitch,
            h,
            max,
            min,
            tiled: TiledLevels::new(&levels),
            exact_levels: (!f32_exact).then_some(levels),
            height_tiles,
            max_slope,
        }
    }

    /// Whole periods the flight `ray`, entering a period across a side
    /// `u = const` (`exit_u`) or `v = const` at `t`, passes above the
    /// surface and can skip exactly (see [`crate::micro::MicroSurface::skip_periods`]
    /// for bump surfaces). Over the next period the flight's path is a
    /// segment; the surface along it is piecewise linear, so its highest
    /// point there is at one of the segment's crossings of square sides and
    /// diagonals (evaluated exactly). Each further period shifts the folded
    /// segment by the drift of the other coordinate modulo its period: over
    /// `k` periods the path stays within `k |drift| + margin` of the first
    /// segment, where the surface is at most `max_slope` times that higher.
    /// Descending, periods whose far end stays above that bound are skipped;
    /// rising above it until the highest vertex, the flight escapes.
    fn skip_periods(&self, ray: &GridRay, t: f64, exit_u: bool) -> FieldSkip {
        let d = ray.d;
        let (a, b) = if exit_u { (0, 1) } else { (1, 0) };
        let n = [self.nx as f64, self.ny as f64];
        let dg = [ray.du, ray.dv];
        if dg[a] == 0.0 || d.z == 0.0 {
            return FieldSkip::None;
        }
        let dt = n[a] / dg[a].abs();
        let drift = dt * dg[b];
        if drift.is_nan() || drift.abs() > 4.0 * n[b] {
            return FieldSkip::None;
        }
        // In length units along the other axis.
        let drift_mod = (drift - (drift / n[b]).round() * n[b]) * self.pitch[b];
        if drift_mod.is_nan() || 16.0 * drift_mod.abs() > self.pitch[b] {
            return FieldSkip::None;
        }
        // A hair relative to the scene, then, for a flight that stays
        // within it, the fine tolerance (see [`SKIP_FINE`]).
        let scale = self
            .size
            .max_element()
            .max(self.max.abs())
            .max(self.min.abs());
        // The surface's highest point along the next period's segment.
        let (u0, v0) = (ray.ou + t * ray.du, ray.ov + t * ray.dv);
        let (u1, v1) = (u0 + dt * ray.du, v0 + dt * ray.dv);
        let at = |s: f64| {
            let s = s.clamp(0.0, 1.0);
            self.height_at(
                (u0 + s * (u1 - u0)) * self.pitch.x,
                (v0 + s * (v1 - v0)) * self.pitch.y,
            )
        };
        let mut line = at(0.0).max(at(1.0));
        let mut crossings = |c0: f64, c1: f64| {
            if c0 == c1 {
                return;
            }
            let (lo, hi) = (c0.min(c1), c0.max(c1));
            let mut m = lo.ceil();
            while m <= hi {
                line = line.max(at((m - c0) / (c1 - c0)));
                m += 1.0;
            }
        };
        crossings(u0, u1);
        crossings(v0, v1);
        crossings(u0 - v0, u1 - v1);
        let g = self.max_slope;
        let z = ray.z_at(t);
        let dz = dt * d.z;
        // The start `k` periods on, folded into the period.
        let moved = |k: f64| {
            let mut p = DVec3::new(u0 * self.pitch.x, v0 * self.pitch.y, z + k * dz);
            p[b] += k * drift * self.pitch[b];
            FieldSkip::To(self.fold(p))
        };
        if dz < 0.0 {
            // Lowest point of period k (0-based) at its far end: z + (k + 1) dz.
            let descend = |rel: f64| {
                let margin = rel * scale;
                let room = z - line - (g + 1.0) * margin - margin;
                let k = (room / (-dz + g * drift_mod.abs())).floor() - 1.0;
                (k >= 1.0).then_some(k)
            };
            match descend(SKIP_COARSE).or_else(|| descend(SKIP_FINE)) {
                Some(k) => moved(k),
                None => FieldSkip::None,
            }
        } else {
            // Rising: above the surface within `k` periods' band, from the
            // start (its lowest point in each period)?
            let above = |k: f64, rel: f64| {
                let margin = rel * scale;
                z > line + g * (k * drift_mod.abs() + margin) + margin
            };
            let k_top = ((self.max - z) / dz).ceil().max(1.0);
            if above(k_top, SKIP_COARSE) || above(k_top, SKIP_FINE) {
                return FieldSkip::Escapes;
            }
            // Otherwise the most periods, doubling from one, above the
            // surface within their band.
            let k = doubling_periods(k_top, |k| above(k, SKIP_FINE));
            if k >= 1.0 { moved(k) } else { FieldSkip::None }
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

    /// Corner heights `[h00, h10, h01, h11]` of square `(i, j)` of the period.
    #[inline(always)]
    fn corners(&self, i: usize, j: usize) -> [f64; 4] {
        if let Some(tiles) = &self.height_tiles {
            return tiles.corners(i, j);
        }
        let i1 = if i + 1 == self.nx { 0 } else { i + 1 };
        let j1 = if j + 1 == self.ny { 0 } else { j + 1 };
        let (r0, r1) = (j * self.nx, j1 * self.nx);
        [
            self.h[r0 + i],
            self.h[r0 + i1],
            self.h[r1 + i],
            self.h[r1 + i1],
        ]
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
        let g = self.gradient(
            self.corners(square % self.nx, square / self.nx),
            triangle % 2,
        );
        DVec3::new(-g.x, -g.y, 1.0).normalize()
    }

    /// The three vertices of triangle `triangle` in period coordinates, in the
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
        let (ii, _) = wrap(i as i64, self.nx);
        let (jj, _) = wrap(j as i64, self.ny);
        surface_height(self.corners(ii, jj), u - i, v - j)
    }

    /// `p` shifted by whole periods into the period `[0, Lx] x [0, Ly]`.
    #[must_use]
    #[inline]
    pub fn fold(&self, p: DVec3) -> DVec3 {
        let fold = |x: f64, len: f64| x - (x / len).floor() * len;
        DVec3::new(fold(p.x, self.size.x), fold(p.y, self.size.y), p.z)
    }

    /// The first hit of the flight `o + t d` (`t > 0`), which starts on or
    /// above the surface; `standing`: the triangle it starts on (excluded).
    /// See the module docs for the walk and its robustness rules. (The
    /// tests' entry point; the tracer counts its tests with
    /// [`HeightField::first_hit_counting`].)
    #[cfg(test)]
    #[must_use]
    pub fn first_hit(&self, o: DVec3, d: DVec3, standing: Option<usize>) -> FieldEvent {
        self.first_hit_counting(o, d, standing, &mut 0)
    }

    /// The first hit of the flight `o + t d` (`t > 0`), which starts on or
    /// above the surface; `standing`: the triangle it starts on (excluded).
    /// Adds to `square_tests` the number of squares (two triangles each)
    /// whose surface was tested. See the module docs for the walk and its
    /// robustness rules.
    #[must_use]
    #[inline]
    pub fn first_hit_counting(
        &self,
        o: DVec3,
        d: DVec3,
        standing: Option<usize>,
        square_tests: &mut u64,
    ) -> FieldEvent {
        if d.z >= 0.0 && o.z > self.max {
            return if d.z > 0.0 {
                FieldEvent::Escapes
            } else {
                FieldEvent::Trapped
            };
        }
        let ray = GridRay {
            o,
            d,
            ou: o.x / self.pitch.x,
            ov: o.y / self.pitch.y,
            du: d.x / self.pitch.x,
            dv: d.y / self.pitch.y,
        };
        let inv = (1.0 / ray.du, 1.0 / ray.dv);
        let top = self.tiled.levels;
        // A flight leaving the surface is below every node holding its start:
        // begin at its square instead of descending to it.
        let mut level = if standing.is_some() { 0 } else { top };
        let mut t = 0.0_f64;
        // f at t when carried from the square just tested (None after a skip).
        let mut f_carried: Option<f64> = None;
        // Square (i, j) of the period whose square 0 has unbounded index (bi, bj).
        let (mut i, mut bi) = wrap(floor_i64(ray.ou), self.nx);
        let (mut j, mut bj) = wrap(floor_i64(ray.ov), self.ny);
        let mut steps = 0_u32;
        let mut periods = 0_u32;
        // Over a node, a descending flight is lowest at the node's exit, any
        // other at its entry (exactly so in floating point: `t_exit >= t` and
        // `z_at` is monotone).
        let descending = d.z < 0.0;
        // Bit L set: the node of level L holding square (i, j) was descended
        // into, and the flight neither rises nor has left it, so its test
        // (the height at the node's exit, whose `t` does not change while the
        // walk stays inside) would descend again: the walk does not repeat it.
        let mut known: u64 = 0;
        loop {
            steps += 1;
            if steps > MAX_STEPS {
                return FieldEvent::Trapped;
            }
            let z = ray.z_at(t);
            if d.z > 0.0 && z > self.max {
                return FieldEvent::Escapes;
            }
            // Down the hierarchy to the first node the flight passes above
            // (skipped), or to the square (tested). Each level visited is a step.
            let exit = loop {
                if level == 0 {
                    break self.node_exit(&ray, inv, 0, (i, bi), (j, bj), t);
                }
                if known & (1 << level) == 0 {
                    let (ni, nj) = (i >> level, j >> level);
                    if descending {
                        let exit = self.node_exit(&ray, inv, level, (i, bi), (j, bj), t);
                        if self.passes_above(level, ni, nj, ray.z_at(exit.t)) {
                            break exit;
                        }
                    } else if self.passes_above(level, ni, nj, z) {
                        break self.node_exit(&ray, inv, level, (i, bi), (j, bj), t);
                    }
                    if d.z <= 0.0 {
                        known |= 1 << level;
                    }
                }
                level -= 1;
                steps += 1;
                if steps > MAX_STEPS {
                    return FieldEvent::Trapped;
                }
            };
            let NodeExit {
                t: t_exit,
                exit_u,
                u: (u0, u1),
                v: (v0, v1),
            } = exit;
            if level > 0 {
                // The flight passes above the whole node: skip it.
                f_carried = None;
            } else {
                let f_in = f_carried.unwrap_or_else(|| {
                    let a = (ray.ou - side(i, bi) + t * ray.du).clamp(0.0, 1.0);
                    let b = (ray.ov - side(j, bj) + t * ray.dv).clamp(0.0, 1.0);
                    z - surface_height(self.corners(i, j), a, b)
                });
                let local = (ray.ou - side(i, bi), ray.ov - side(j, bj));
                *square_tests += 1;
                match self.square(i, j, &ray, local, (t, t_exit), exit_u, f_in, standing) {
                    Ok(hit) => return hit,
                    Err(f_out) => f_carried = Some(f_out),
                }
            }
            if t_exit == f64::INFINITY {
                // A vertical flight above its column, or rising out of its square.
                return if d.z > 0.0 {
                    FieldEvent::Escapes
                } else {
                    FieldEvent::Trapped
                };
            }
            t = t_exit;
            // Step into the neighbouring node across the exit side; the other
            // index comes from the exit point, kept within the node's range so
            // the walk always advances.
            let base = (bi, bj);
            let (from_i, from_j) = (i, j);
            if exit_u {
                (i, bi) = step(i, bi, u0, u1, ray.du > 0.0, self.nx);
                let k = floor_i64(ray.ov + t * ray.dv) - bj;
                j = k.clamp(v0 as i64, v1 as i64 - 1) as usize;
            } else {
                (j, bj) = step(j, bj, v0, v1, ray.dv > 0.0, self.ny);
                let k = floor_i64(ray.ou + t * ray.du) - bi;
                i = k.clamp(u0 as i64, u1 as i64 - 1) as usize;
            }
            // Nodes of the levels above the highest bit in which the square's
            // indices changed still hold it.
            let moved = (from_i ^ i) | (from_j ^ j);
            // (`moved` < 2^63: a shift of at most 63; 0 when nothing moved.)
            known &= u64::MAX << (usize::BITS - moved.leading_zeros());
            if (bi, bj) != base {
                known = 0;
                // Into the next period: the flight's travel is bounded in periods.
                periods += 1;
                if periods >= super::MAX_CROSSINGS {
                    return FieldEvent::Trapped;
                }
                if periods >= SKIP_AFTER {
                    match self.skip_periods(&ray, t, exit_u) {
                        FieldSkip::None => {}
                        FieldSkip::Escapes => return FieldEvent::Escapes,
                        FieldSkip::To(at) => return FieldEvent::Moved { at },
                    }
                }
            }
            // One level up again (measured: fewer steps than staying down
            // within the same parent node, since rising flights climb sooner).
            level = (level + 1).min(top);
        }
    }

    /// Where the flight leaves, from `t` on, the node of `level` holding
    /// square `(i, j)` (with the period bases `bi`, `bj`), with the node's
    /// squares; `exit_u` when it leaves through a side `u = const` (also on a
    /// tie). `inv`: `(1 / du, 1 / dv)`.
    #[inline(always)]
    fn node_exit(
        &self,
        ray: &GridRay,
        (inv_u, inv_v): (f64, f64),
        level: usize,
        (i, bi): (usize, i64),
        (j, bj): (usize, i64),
        t: f64,
    ) -> NodeExit {
        let (u0, u1) = node_span(i, level, self.nx);
        let (v0, v1) = node_span(j, level, self.ny);
        // Where the flight leaves [lo, hi) along one axis (infinite if parallel).
        let leave = |dk: f64, ok: f64, inv: f64, lo: f64, hi: f64| {
            if dk > 0.0 {
                (hi - ok) * inv
            } else if dk < 0.0 {
                (lo - ok) * inv
            } else {
                f64::INFINITY
            }
        };
        let tu = leave(ray.du, ray.ou, inv_u, side(u0, bi), side(u1, bi));
        let tv = leave(ray.dv, ray.ov, inv_v, side(v0, bj), side(v1, bj));
        NodeExit {
            t: tu.min(tv).max(t),
            exit_u: tu <= tv,
            u: (u0, u1),
            v: (v0, v1),
        }
    }

    /// Whether a flight whose lowest height over node `(ni, nj)` of `level`
    /// (>= 1) is `z_low` passes above it (`z_low` greater than the node's
    /// highest vertex, or NaN). Decided from the node's `f32` copy: rounding
    /// to `f32` is monotone, so `f32(z_low)` below or above that copy puts
    /// `z_low` below or above the exact `f64` maximum; only on a tie is the
    /// `f64` level read. The answer is that of the `f64` comparison.
    #[inline(always)]
    fn passes_above(&self, level: usize, ni: usize, nj: usize, z_low: f64) -> bool {
        let near = self.tiled.max(level, ni, nj);
        let z = z_low as f32;
        if z > near {
            true
        } else if z < near {
            false
        } else {
            let exact = match &self.exact_levels {
                Some(levels) => {
                    let lv = &levels[level - 1];
                    lv.max[nj * lv.w + ni]
                }
                None => f64::from(near),
            };
            z_low
                .partial_cmp(&exact)
                .is_none_or(std::cmp::Ordering::is_gt)
        }
    }

    /// Test square `(i, j)` (of the period) over `[t0, t1]` with the carried
    /// `f_in` at `t0`; `(a0, b0)`: the flight's local coordinates in the square
    /// at `t = 0`. `exit_u`: the flight leaves through a side `u = const`
    /// (else `v = const`). Returns the hit, or `Err(f at t1)` computed on the
    /// edge shared with the next square.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn square(
        &self,
        i: usize,
        j: usize,
        ray: &GridRay,
        (a0, b0): (f64, f64),
        (t0, t1): (f64, f64),
        exit_u: bool,
        f_in: f64,
        standing: Option<usize>,
    ) -> Result<FieldEvent, f64> {
        let c = self.corners(i, j);
        let [h00, h10, h01, h11] = c;
        let GridRay { d, du, dv, .. } = *ray;
        let z_at = |t: f64| ray.z_at(t);
        let square = j * self.nx + i;
        // Where the flight crosses the diagonal a = b, if inside (t0, t1).
        let ds = du - dv;
        let t_diag = if ds == 0.0 { f64::NAN } else { (b0 - a0) / ds };
        let split = t_diag > t0 && t_diag < t1;
        // Which triangle the first piece lies in, from the same t_diag: a - b
        // changes sign at t_diag, from the sign of -ds to that of ds (B is
        // a < b), so a piece is never given the other side of the diagonal.
        let after = if ds > 0.0 { 0 } else { 1 };
        let first_half = if ds == 0.0 {
            usize::from(a0 < b0)
        } else if split || t_diag >= t1 {
            1 - after
        } else {
            after
        };
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
    /// period of `size` (length units), deterministic from `seed`.
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
    /// power (see the guide, docs/src/height-fields.md).
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
            let s = if 2 * m < n {
                m as f64
            } else {
                m as f64 - n as f64
            };
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

/// The max-height hierarchy of the `nx x ny` periodic heights `h` (row-major,
/// length units): levels 1, 2, ... (`[L - 1]`: nodes of `2^L x 2^L` squares,
/// the highest vertex of their squares, corners included; partial nodes at
/// the ends for any `n`); the last level is one node for the period. Level 0
/// (the squares' highest corners) is not stored: the walk tests squares
/// directly.
fn max_levels(nx: usize, ny: usize, h: &[f64]) -> Vec<Level> {
    let at = |i: usize, j: usize| h[(j % ny) * nx + i % nx];
    // Level 0 (the squares' highest corners) is not stored: the walk tests
    // squares directly. Level 1 onwards, each from the one below.
    let mut below: Vec<f64> = (0..nx * ny)
        .map(|k| {
            let (i, j) = (k % nx, k / nx);
            at(i, j)
                .max(at(i + 1, j))
                .max(at(i, j + 1))
                .max(at(i + 1, j + 1))
        })
        .collect();
    let mut levels: Vec<Level> = Vec::new();
    let (mut w, mut hgt) = (nx, ny);
    while w > 1 || hgt > 1 {
        let (w2, h2) = (w.div_ceil(2), hgt.div_ceil(2));
        let max: Vec<f64> = (0..w2 * h2)
            .map(|k| {
                let (i, j) = (k % w2, k / w2);
                let mut m = f64::NEG_INFINITY;
                for cj in (2 * j)..(2 * j + 2).min(hgt) {
                    for ci in (2 * i)..(2 * i + 2).min(w) {
                        m = m.max(below[cj * w + ci]);
                    }
                }
                m
            })
            .collect();
        below.clone_from(&max);
        levels.push(Level { w: w2, max });
        (w, hgt) = (w2, h2);
    }
    levels
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

/// Where a flight leaves a node ([`HeightField::node_exit`]).
#[derive(Clone, Copy, Debug)]
struct NodeExit {
    /// Distance at the exit (units of `|d|`), at least the flight's `t`.
    t: f64,
    /// It leaves through a side `u = const` (also on a tie), else `v = const`.
    exit_u: bool,
    /// The node's squares `[u0, u1)` along x and `[v0, v1)` along y, of the period.
    u: (usize, usize),
    v: (usize, usize),
}

/// A flight in grid units: `u = x / px`, `v = y / py`, same `t`.
#[derive(Clone, Copy, Debug)]
struct GridRay {
    o: DVec3,
    d: DVec3,
    ou: f64,
    ov: f64,
    du: f64,
    dv: f64,
}

impl GridRay {
    /// Height of the flight at `t` (also for horizontal flights and infinite `t`).
    #[inline]
    fn z_at(&self, t: f64) -> f64 {
        if self.d.z == 0.0 {
            self.o.z
        } else {
            self.o.z + t * self.d.z
        }
    }
}

/// `floor(x)` as an integer (`x` well inside the `i64` range).
#[inline]
fn floor_i64(x: f64) -> i64 {
    let k = x as i64;
    k - i64::from(k as f64 > x)
}

/// Unbounded square index `k` as `(square of the period, unbounded index of
/// the period's square 0)` on an axis of `n` squares.
#[inline]
fn wrap(k: i64, n: usize) -> (usize, i64) {
    // Flights start in the period: most squares are of the period already.
    if (0..n as i64).contains(&k) {
        return (k as usize, 0);
    }
    let r = k.rem_euclid(n as i64);
    (r as usize, k - r)
}

/// The squares `[first, end)` of the node of `level` holding square `k` of a
/// period of `n` squares (the last node of a level may be partial). Level 0
/// is the square itself.
#[inline]
fn node_span(k: usize, level: usize, n: usize) -> (usize, usize) {
    let first = (k >> level) << level;
    (first, (first + (1 << level)).min(n))
}

/// The square entered across the far (`forward`) or near side of the node
/// `[first, end)`, with the period base `base` updated when it wraps.
#[inline]
fn step(k: usize, base: i64, first: usize, end: usize, forward: bool, n: usize) -> (usize, i64) {
    debug_assert!(first <= k && k < end);
    if forward {
        if end == n {
            (0, base + n as i64)
        } else {
            (end, base)
        }
    } else if first == 0 {
        (n - 1, base - n as i64)
    } else {
        (first - 1, base)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::micro::surface_stats::{HeightMap, surface_stats};
    use proptest::prelude::*;

    /// Möller-Trumbore (independent of the walk): distance along `d` from `o`
    /// to the triangle `v`, if the ray meets it from above (`d . n < 0`, `n`
    /// the counter-clockwise normal) with barycentrics inside up to `slack`.
    fn moller_trumbore(o: DVec3, d: DVec3, v: [DVec3; 3], slack: f64) -> Option<f64> {
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        if d.dot(e1.cross(e2)) >= 0.0 {
            return None;
        }
        let p = d.cross(e2);
        let det = e1.dot(p);
        let s = o - v[0];
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let w = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (u >= -slack && w >= -slack && u + w <= 1.0 + slack).then_some(t)
    }

    /// Every copy of triangle `tri` in the periods `[kx0, kx1] x [ky0, ky1]`:
    /// the nearest hit with `t > t_min`.
    fn nearest_copy(
        f: &HeightField,
        tri: usize,
        o: DVec3,
        d: DVec3,
        tiles: ([i64; 2], [i64; 2]),
        t_min: f64,
        slack: f64,
    ) -> Option<f64> {
        let v = f.triangle_vertices(tri);
        let mut best: Option<f64> = None;
        for ky in tiles.1[0]..=tiles.1[1] {
            for kx in tiles.0[0]..=tiles.0[1] {
                let shift = DVec3::new(kx as f64 * f.size.x, ky as f64 * f.size.y, 0.0);
                let w = [v[0] + shift, v[1] + shift, v[2] + shift];
                if let Some(t) = moller_trumbore(o, d, w, slack) {
                    if t > t_min && best.is_none_or(|b| t < b) {
                        best = Some(t);
                    }
                }
            }
        }
        best
    }

    /// Brute force: the nearest hit over all triangles of all periods the
    /// flight can reach before it falls below the lowest vertex (or rises
    /// above the highest), excluding `standing`.
    fn brute_force(
        f: &HeightField,
        o: DVec3,
        d: DVec3,
        standing: Option<usize>,
        t_min: f64,
    ) -> Option<(f64, usize)> {
        let t_end = if d.z < 0.0 {
            (f.min - o.z) / d.z
        } else {
            (f.max - o.z) / d.z
        }
        .max(0.0);
        let (a, b) = (o, o + t_end * d);
        let tile = |x: f64, len: f64| (x / len).floor() as i64;
        let tiles = (
            [
                tile(a.x.min(b.x), f.size.x) - 1,
                tile(a.x.max(b.x), f.size.x) + 1,
            ],
            [
                tile(a.y.min(b.y), f.size.y) - 1,
                tile(a.y.max(b.y), f.size.y) + 1,
            ],
        );
        let mut best: Option<(f64, usize)> = None;
        for tri in 0..2 * f.nx * f.ny {
            if standing == Some(tri) {
                continue;
            }
            if let Some(t) = nearest_copy(f, tri, o, d, tiles, t_min, 1e-12) {
                if best.is_none_or(|(b, _)| t < b) {
                    best = Some((t, tri));
                }
            }
        }
        best
    }

    fn field_strategy() -> impl Strategy<Value = HeightField> {
        (2usize..=13, 2usize..=11, 0.1f64..0.6, 0.1f64..0.6).prop_flat_map(|(nx, ny, px, py)| {
            prop::collection::vec(-1.0f64..1.0, nx * ny).prop_map(move |h| {
                HeightField::new(nx, ny, DVec2::new(nx as f64 * px, ny as f64 * py), h)
            })
        })
    }

    fn direction(phi: f64, cos_theta: f64) -> DVec3 {
        let s = (1.0 - cos_theta * cos_theta).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), cos_theta)
    }

    /// The walk's answer against brute force: the same first distance to
    /// 1e-9 relative, and the same triangle or one the flight meets at the
    /// same distance (a tie on a shared edge, checked with a 1e-9 slack).
    fn check_against_brute_force(
        f: &HeightField,
        o: DVec3,
        d: DVec3,
        standing: Option<usize>,
        t_min: f64,
    ) -> Result<(), TestCaseError> {
        let walk = f.first_hit(o, d, standing);
        let brute = brute_force(f, o, d, standing, t_min);
        match (walk, brute) {
            (FieldEvent::Hit { t, triangle }, Some((tb, tri_b))) => {
                prop_assert!(
                    (t - tb).abs() <= 1e-9 * tb.max(1.0),
                    "walk t {t} (triangle {triangle}), brute force {tb} (triangle {tri_b})"
                );
                if triangle != tri_b {
                    let big = ([-1000, 1000], [-1000, 1000]);
                    let tie = nearest_copy(f, triangle, o, d, big, t_min - 1e-9, 1e-9);
                    prop_assert!(
                        tie.is_some_and(|tt| (tt - tb).abs() <= 1e-9 * tb.max(1.0)),
                        "walk triangle {triangle} at {t} is not met at {tb} ({tie:?})"
                    );
                }
            }
            (FieldEvent::Escapes, None) => prop_assert!(d.z > 0.0),
            (w, b) => prop_assert!(false, "walk {w:?}, brute force {b:?}"),
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, max_global_rejects: 100_000, ..ProptestConfig::default() })]

        /// Flights from above the surface, downwards.
        #[test]
        fn walk_matches_brute_force_from_above(
            f in field_strategy(),
            fx in 0.0f64..1.0, fy in 0.0f64..1.0, lift in 0.001f64..2.0,
            phi in 0.0f64..std::f64::consts::TAU, cos_theta in -1.0f64..-0.35,
        ) {
            let (x, y) = (fx * f.size.x, fy * f.size.y);
            let o = DVec3::new(x, y, f.height_at(x, y) + lift);
            check_against_brute_force(&f, o, direction(phi, cos_theta), None, 0.0)?;
        }

        /// Flights aimed exactly at a point of a shared edge (a square side
        /// or a diagonal) or at a vertex: they must not slip through.
        #[test]
        fn walk_does_not_slip_between_triangles(
            f in field_strategy(),
            square in 0usize..10_000, edge in 0usize..4, s in 0.0f64..1.0, back in 0.01f64..3.0,
            phi in 0.0f64..std::f64::consts::TAU, cos_theta in -1.0f64..-0.35,
        ) {
            let sq = square % (f.nx * f.ny);
            let (i, j) = ((sq % f.nx) as f64, (sq / f.nx) as f64);
            // Side u = i, side v = j, the diagonal, or the vertex (i, j).
            let (a, b) = [(0.0, s), (s, 0.0), (s, s), (0.0, 0.0)][edge];
            let (x, y) = ((i + a) * f.pitch.x, (j + b) * f.pitch.y);
            let target = DVec3::new(x, y, f.height_at(x, y));
            let d = direction(phi, cos_theta);
            let o = target - back * d;
            // The start must be above the surface for the flight to be valid,
            // and the flight must go below it right after the point (not
            // touch a peak or a ridge from above, a tie brute force may count).
            prop_assume!(o.z > f.height_at(o.x, o.y) + 1e-9);
            let after = target + 1e-6 * d;
            prop_assume!(after.z < f.height_at(after.x, after.y) - 1e-12);
            let o = f.fold(o);
            check_against_brute_force(&f, o, d, None, 0.0)?;
            if let FieldEvent::Hit { t, .. } = f.first_hit(o, d, None) {
                prop_assert!(t <= back * (1.0 + 1e-9) + 1e-9, "passed the aimed point: {t} > {back}");
            }
        }

        /// Flights leaving a point of a triangle (the standing one, excluded),
        /// in any direction rising relative to it: concave neighbours can be
        /// hit at any distance, nothing is hit behind the start.
        #[test]
        fn walk_matches_brute_force_from_the_surface(
            f in field_strategy(),
            square in 0usize..10_000, half in 0usize..2,
            ba in 0.0f64..1.0, bb in 0.0f64..1.0,
            phi in 0.0f64..std::f64::consts::TAU, cos_theta in 0.35f64..1.0, flip in any::<bool>(),
        ) {
            let tri = 2 * (square % (f.nx * f.ny)) + half;
            let v = f.triangle_vertices(tri);
            let (ba, bb) = if ba + bb > 1.0 { (1.0 - ba, 1.0 - bb) } else { (ba, bb) };
            let o = v[0] + ba * (v[1] - v[0]) + bb * (v[2] - v[0]);
            let mut d = direction(phi, if flip { -cos_theta } else { cos_theta });
            let n = f.normal(tri);
            if d.dot(n) <= 0.0 {
                d -= 2.0 * d.dot(n) * n;
            }
            prop_assume!(d.z.abs() >= 0.3 && d.dot(n) > 1e-3);
            check_against_brute_force(&f, o, d, Some(tri), 1e-12)?;
        }
    }

    /// The walk as it was before the tiled `f32` hierarchy (row-major `f64`
    /// levels, every level visited tested), kept on purpose as test code: an
    /// independent reference the walk must reproduce bit for bit, event and
    /// distance.
    fn reference_first_hit(
        f: &HeightField,
        o: DVec3,
        d: DVec3,
        standing: Option<usize>,
    ) -> FieldEvent {
        if d.z >= 0.0 && o.z > f.max {
            return if d.z > 0.0 {
                FieldEvent::Escapes
            } else {
                FieldEvent::Trapped
            };
        }
        let ray = GridRay {
            o,
            d,
            ou: o.x / f.pitch.x,
            ov: o.y / f.pitch.y,
            du: d.x / f.pitch.x,
            dv: d.y / f.pitch.y,
        };
        let (inv_u, inv_v) = (1.0 / ray.du, 1.0 / ray.dv);
        let levels = max_levels(f.nx, f.ny, &f.h);
        let top = levels.len();
        // A flight leaving the surface is below every node holding its start:
        // begin at its square instead of descending to it.
        let mut level = if standing.is_some() { 0 } else { top };
        let mut t = 0.0_f64;
        // f at t when carried from the square just tested (None after a skip).
        let mut f_carried: Option<f64> = None;
        // Square (i, j) of the period whose square 0 has unbounded index (bi, bj).
        let (mut i, mut bi) = wrap(floor_i64(ray.ou), f.nx);
        let (mut j, mut bj) = wrap(floor_i64(ray.ov), f.ny);
        let mut steps = 0_u32;
        let mut periods = 0_u32;
        loop {
            steps += 1;
            if steps > MAX_STEPS {
                return FieldEvent::Trapped;
            }
            let z = ray.z_at(t);
            if d.z > 0.0 && z > f.max {
                return FieldEvent::Escapes;
            }
            // The node of this level holding square (i, j): squares [u0, u1) x [v0, v1).
            let (u0, u1) = node_span(i, level, f.nx);
            let (v0, v1) = node_span(j, level, f.ny);
            let side = |k: usize, base: i64| (base + k as i64) as f64;
            // Where the flight leaves [lo, hi) along one axis (infinite if parallel).
            let leave = |dk: f64, ok: f64, inv: f64, lo: f64, hi: f64| {
                if dk > 0.0 {
                    (hi - ok) * inv
                } else if dk < 0.0 {
                    (lo - ok) * inv
                } else {
                    f64::INFINITY
                }
            };
            let tu = leave(ray.du, ray.ou, inv_u, side(u0, bi), side(u1, bi));
            let tv = leave(ray.dv, ray.ov, inv_v, side(v0, bj), side(v1, bj));
            let t_exit = tu.min(tv).max(t);
            let exit_u = tu <= tv;
            if level > 0 {
                let lv = &levels[level - 1];
                let node_max = lv.max[(j >> level) * lv.w + (i >> level)];
                if z.min(ray.z_at(t_exit)) <= node_max {
                    level -= 1;
                    continue;
                }
                // The flight passes above the whole node: skip it.
                f_carried = None;
            } else {
                let f_in = f_carried.unwrap_or_else(|| {
                    let a = (ray.ou - side(i, bi) + t * ray.du).clamp(0.0, 1.0);
                    let b = (ray.ov - side(j, bj) + t * ray.dv).clamp(0.0, 1.0);
                    z - surface_height(f.corners(i, j), a, b)
                });
                let local = (ray.ou - side(i, bi), ray.ov - side(j, bj));
                match f.square(i, j, &ray, local, (t, t_exit), exit_u, f_in, standing) {
                    Ok(hit) => return hit,
                    Err(f_out) => f_carried = Some(f_out),
                }
            }
            if t_exit == f64::INFINITY {
                // A vertical flight above its column, or rising out of its square.
                return if d.z > 0.0 {
                    FieldEvent::Escapes
                } else {
                    FieldEvent::Trapped
                };
            }
            t = t_exit;
            // Step into the neighbouring node across the exit side; the other
            // index comes from the exit point, kept within the node's range so
            // the walk always advances.
            let base = (bi, bj);
            if exit_u {
                (i, bi) = step(i, bi, u0, u1, ray.du > 0.0, f.nx);
                let k = floor_i64(ray.ov + t * ray.dv) - bj;
                j = k.clamp(v0 as i64, v1 as i64 - 1) as usize;
            } else {
                (j, bj) = step(j, bj, v0, v1, ray.dv > 0.0, f.ny);
                let k = floor_i64(ray.ou + t * ray.du) - bi;
                i = k.clamp(u0 as i64, u1 as i64 - 1) as usize;
            }
            if (bi, bj) != base {
                // Into the next period: the flight's travel is bounded in periods.
                periods += 1;
                if periods >= crate::micro::MAX_CROSSINGS {
                    return FieldEvent::Trapped;
                }
                if periods >= SKIP_AFTER {
                    match f.skip_periods(&ray, t, exit_u) {
                        FieldSkip::None => {}
                        FieldSkip::Escapes => return FieldEvent::Escapes,
                        FieldSkip::To(at) => return FieldEvent::Moved { at },
                    }
                }
            }
            // One level up again (measured: fewer steps than staying down
            // within the same parent node, since rising flights climb sooner).
            level = (level + 1).min(top);
        }
    }

    /// Same event, same distance to the bit, as [`reference_first_hit`].
    fn same_event(a: FieldEvent, b: FieldEvent) -> bool {
        match (a, b) {
            (
                FieldEvent::Hit { t, triangle },
                FieldEvent::Hit {
                    t: tb,
                    triangle: tri_b,
                },
            ) => t.to_bits() == tb.to_bits() && triangle == tri_b,
            (a, b) => a == b,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

        /// The walk gives exactly the reference walk's event, from above and
        /// from the surface, for flights in any direction (rising, level,
        /// descending, nearly horizontal ones crossing many periods).
        #[test]
        fn walk_matches_the_reference_walk_bit_for_bit(
            f in field_strategy(),
            square in 0usize..10_000, half in 0usize..2,
            ba in 0.0f64..1.0, bb in 0.0f64..1.0, lift in 0.0f64..2.0,
            phi in 0.0f64..std::f64::consts::TAU, cos_theta in -1.0f64..1.0,
        ) {
            let tri = 2 * (square % (f.nx * f.ny)) + half;
            let v = f.triangle_vertices(tri);
            let (ba, bb) = if ba + bb > 1.0 { (1.0 - ba, 1.0 - bb) } else { (ba, bb) };
            let on = v[0] + ba * (v[1] - v[0]) + bb * (v[2] - v[0]);
            let d = direction(phi, cos_theta);
            let above = on + DVec3::new(0.0, 0.0, lift);
            prop_assert!(same_event(f.first_hit(above, d, None), reference_first_hit(&f, above, d, None)));
            if d.dot(f.normal(tri)) > 0.0 {
                let (w, r) = (f.first_hit(on, d, Some(tri)), reference_first_hit(&f, on, d, Some(tri)));
                prop_assert!(same_event(w, r), "walk {w:?}, reference {r:?}");
            }
        }
    }

    /// A generated field (f32-exact heights, so flights meet node maxima
    /// exactly), flights from the launch plane and back up from their hits:
    /// the walk and the reference walk agree bit for bit.
    #[test]
    fn walk_matches_the_reference_walk_on_a_gaussian_field() {
        let f = HeightField::gaussian(64, 48, DVec2::new(16.0, 12.0), 1.0, 2.0, 7);
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        for _ in 0..20_000 {
            let o = DVec3::new(
                rng.random::<f64>() * f.size.x,
                rng.random::<f64>() * f.size.y,
                f.max + 0.5,
            );
            let d = direction(
                rng.random::<f64>() * std::f64::consts::TAU,
                -rng.random::<f64>(),
            );
            let w = f.first_hit(o, d, None);
            assert!(
                same_event(w, reference_first_hit(&f, o, d, None)),
                "{o} {d}"
            );
            if let FieldEvent::Hit { t, triangle } = w {
                let n = f.normal(triangle);
                let r = d - 2.0 * d.dot(n) * n;
                let p = f.fold(o + t * d);
                let (a, b) = (
                    f.first_hit(p, r, Some(triangle)),
                    reference_first_hit(&f, p, r, Some(triangle)),
                );
                assert!(same_event(a, b), "{p} {r}: {a:?} {b:?}");
            }
        }
    }

    /// The `f32` test of a node is the `f64` comparison, also for heights at
    /// and next to the node's maximum and to its `f32` rounding.
    #[test]
    fn passes_above_is_the_exact_comparison() {
        // Heights that are not all f32 (the f64 levels kept) and that are.
        let fields = [1e-9, 0.0].map(|eps| {
            let h: Vec<f64> = (0..17 * 9)
                .map(|k| ((k * 37 % 101) as f64 - 50.0) / 8.0 + eps * k as f64)
                .collect();
            HeightField::new(17, 9, DVec2::new(4.0, 3.0), h)
        });
        assert!(fields[0].exact_levels.is_some() && fields[0].height_tiles.is_none());
        assert!(fields[1].exact_levels.is_none() && fields[1].height_tiles.is_some());
        for f in &fields {
            for (l, lv) in max_levels(f.nx, f.ny, &f.h).iter().enumerate() {
                for (k, &m) in lv.max.iter().enumerate() {
                    let (ni, nj) = (k % lv.w, k / lv.w);
                    let r = f64::from(m as f32);
                    for z in [
                        m,
                        m.next_up(),
                        m.next_down(),
                        r,
                        r.next_up(),
                        r.next_down(),
                        m - 1.0,
                        m + 1.0,
                        f64::NAN,
                    ] {
                        let above = z > m || z.is_nan();
                        assert_eq!(
                            f.passes_above(l + 1, ni, nj, z),
                            above,
                            "level {} node {k} z {z}",
                            l + 1
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn vertical_flights_give_the_triangle_heights() {
        let f = HeightField::new(
            3,
            2,
            DVec2::new(3.0, 2.0),
            vec![0.0, 1.0, 2.0, 3.0, 5.0, 4.0],
        );
        // Square (0, 0): h00 = 0, h10 = 1, h01 = 3, h11 = 5; at (a, b) = (0.75, 0.25)
        // (triangle A) the height is 0 + 1 * 0.75 + (5 - 1) * 0.25 = 1.75.
        for (x, y, want) in [
            (0.75, 0.25, 1.75),
            (0.25, 0.75, 0.0 + 2.0 * 0.25 + 3.0 * 0.75),
        ] {
            assert_eq!(f.height_at(x, y), want);
            match f.first_hit(DVec3::new(x, y, 10.0), DVec3::NEG_Z, None) {
                FieldEvent::Hit { t, .. } => assert!((10.0 - t - want).abs() < 1e-14),
                e => panic!("{e:?}"),
            }
        }
        // Periodic: vertex (3, 0) is vertex (0, 0), and one period away is the same point.
        for (x, y) in [(-0.5, 0.1), (5.5, 2.1)] {
            assert!((f.height_at(2.5, 0.1) - f.height_at(x, y)).abs() < 1e-14);
        }
        assert_eq!(
            f.fold(DVec3::new(-0.5, 4.25, 1.0)),
            DVec3::new(2.5, 0.25, 1.0)
        );
    }

    #[test]
    fn hierarchy_nodes_cover_odd_sizes() {
        // 5 squares: level 1 nodes [0, 2), [2, 4), [4, 5); level 2 [0, 4), [4, 5).
        assert_eq!(node_span(4, 1, 5), (4, 5));
        assert_eq!(node_span(3, 1, 5), (2, 4));
        assert_eq!(node_span(4, 2, 5), (4, 5));
        assert_eq!(node_span(3, 0, 5), (3, 4));
        assert_eq!(wrap(-1, 5), (4, -5));
        assert_eq!(wrap(7, 5), (2, 5));
        assert_eq!(step(4, 0, 4, 5, true, 5), (0, 5));
        assert_eq!(step(0, 5, 0, 2, false, 5), (4, 0));
        assert_eq!(
            (floor_i64(-0.5), floor_i64(2.0), floor_i64(2.5)),
            (-1, 2, 2)
        );
        let h: Vec<f64> = (0..35).map(|k| ((k * 7) % 11) as f64).collect();
        let f = HeightField::new(7, 5, DVec2::new(7.0, 5.0), h);
        let levels = max_levels(f.nx, f.ny, &f.h);
        let top = levels.last().unwrap();
        assert_eq!((top.w, top.max.len()), (1, 1));
        assert_eq!(top.max[0], f.max);
        // Level 1 node (3, 2) is the partial node of square (6, 4), whose
        // corners wrap to vertices (6, 4), (0, 4), (6, 0), (0, 0).
        let want = [(6, 4), (0, 4), (6, 0), (0, 0)]
            .iter()
            .map(|&(i, j)| f.vertex(i, j))
            .fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(levels[0].max[2 * 4 + 3], want);
        // The walk's copies: the f32 tiles of every level, the corners from the height tiles.
        assert!(f.exact_levels.is_none());
        for (l, lv) in levels.iter().enumerate() {
            for (k, &m) in lv.max.iter().enumerate() {
                assert_eq!(f64::from(f.tiled.max(l + 1, k % lv.w, k / lv.w)), m);
            }
        }
        for (i, j) in [(0, 0), (3, 2), (6, 4), (4, 3), (6, 0), (0, 4)] {
            let want = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(a, b)| f.vertex(i + a, j + b));
            assert_eq!(f.corners(i as usize, j as usize), want);
        }
    }

    /// Normal deviates of the spectrum weight `w_k = exp(-|k|² tau² / 4)` on the
    /// period lattice, as the synthesis uses (its k = 0 term included).
    fn spectrum(n: usize, len: f64, tau: f64) -> Vec<(f64, f64, f64)> {
        let k = |m: usize| {
            let s = if 2 * m < n {
                m as f64
            } else {
                m as f64 - n as f64
            };
            std::f64::consts::TAU * s / len
        };
        (0..n * n)
            .map(|i| {
                let (kx, ky) = (k(i % n), k(i / n));
                (kx, ky, (-(kx * kx + ky * ky) * tau * tau / 4.0).exp())
            })
            .collect()
    }

    /// Gaussian synthesis over 8 seeds: RMS height exactly sigma (to the f32
    /// rounding of the heights), mean 0, and the estimated tau and RMS slope
    /// agree with their expectations for this spectrum within 4 standard
    /// errors of the mean, the standard error taken from the spread over the
    /// seeds. Expectations: the estimator removes the mean, so it sees the
    /// spectrum without its k = 0 share s0 = w_0 / sum w: the normalised
    /// autocorrelation is (exp(-r²/tau²) - s0) / (1 - s0), which falls to
    /// 1/e at r = tau sqrt(-ln(s0 + (1 - s0)/e)); central differences of
    /// pitch p see per axis sum_k w_k sin²(k_x p) / p² / sum_(k != 0) w_k
    /// times sigma².
    #[test]
    fn gaussian_synthesis_gives_back_sigma_and_tau() {
        let (n, len, sigma, tau) = (256usize, 64.0, 0.7, 3.0);
        let spec = spectrum(n, len, tau);
        let total: f64 = spec.iter().map(|s| s.2).sum();
        let s0 = 1.0 / total;
        let tau_expected = tau * (-(s0 + (1.0 - s0) / std::f64::consts::E).ln()).sqrt();
        let p = len / n as f64;
        let gx2: f64 = spec
            .iter()
            .map(|&(kx, _, w)| w * (kx * p).sin().powi(2))
            .sum::<f64>()
            / (p * p)
            / (total - 1.0);
        let slope_expected = sigma * (2.0 * gx2).sqrt();
        let (mut taus, mut slopes) = (Vec::new(), Vec::new());
        for seed in 1..=8 {
            let f = HeightField::gaussian(n, n, DVec2::splat(len), sigma, tau, seed);
            let again = HeightField::gaussian(n, n, DVec2::splat(len), sigma, tau, seed);
            assert_eq!(f.h, again.h, "seed {seed}: not deterministic");
            let map = HeightMap {
                nx: n,
                ny: n,
                dx: p,
                dy: p,
                h: f.h.clone(),
                periodic: true,
            };
            let s = surface_stats(&map);
            assert!(
                (s.sigma - sigma).abs() < 1e-7 * sigma,
                "seed {seed}: sigma {}",
                s.sigma
            );
            assert!(s.mean.abs() < 1e-7 * sigma, "seed {seed}: mean {}", s.mean);
            taus.push(s.tau);
            slopes.push(s.rms_slope);
        }
        let mean_and_error = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
            (m, (var / v.len() as f64).sqrt())
        };
        let (tau_mean, tau_se) = mean_and_error(&taus);
        assert!(
            (tau_mean - tau_expected).abs() <= 4.0 * tau_se,
            "tau {tau_mean} +- {tau_se}, expected {tau_expected} (taus {taus:?})"
        );
        let (slope_mean, slope_se) = mean_and_error(&slopes);
        assert!(
            (slope_mean - slope_expected).abs() <= 4.0 * slope_se,
            "rms slope {slope_mean} +- {slope_se}, expected {slope_expected}"
        );
        // A different seed is a different surface.
        let a = HeightField::gaussian(16, 16, DVec2::splat(8.0), 1.0, 2.0, 1);
        let b = HeightField::gaussian(16, 16, DVec2::splat(8.0), 1.0, 2.0, 2);
        assert_ne!(a.h, b.h);
    }
}
