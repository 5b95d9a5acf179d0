//! The acceleration grid of a bump surface, laid out for the hot loop.
//!
//! A uniform 2-D grid over the period lists the solids whose bounds cross each
//! grid cell, with the highest point each reaches over it, tallest first, so a
//! flight passing above a grid cell (or above the rest of its list) stops
//! there. The layout keeps what a flight touches small and close together:
//!
//! * Solids that are one axis-aligned quadric `-q` with no horizontal linear
//!   term (every ellipsoid and paraboloid bump) become 64-byte
//!   [`QuadricRecord`]s, one cache line each, holding the coefficients the
//!   ray test needs, so it never reaches into [`super::Solid`] or its
//!   [`crate::geometry::body::Body`]. Other solids are tested through their body.
//! * Records are sorted by the Morton (Z) order of the grid cell of their
//!   centre, and the grid cells' lists are stored in the Morton order of the
//!   cells, so solids and lists that are near in the plane are near in
//!   memory (the large scenes do not fit the caches).
//! * A list item is 8 bytes: the record index and the solid's height over the
//!   grid cell as an `f32` rounded up (a conservative filter); where the
//!   `f32` cannot decide, the exact `f64` height is read, so the solids tested
//!   are exactly those of an `f64` grid.
//! * A solid is left out of a grid cell's list where it lies wholly under a
//!   bump that fills the cell's whole column up to some height (bumps are
//!   solid below their tops, see [`super::bumps::Shape::min_height_over`]):
//!   no flight reaches it there. Bumps wider than the period overlap by the
//!   hundreds in every cell, their periodic copies included, and most of
//!   them are buried so.

use std::ops::RangeInclusive;

use glam::{DVec2, DVec3};

use super::Solid;
use crate::geometry::body::Body;
use crate::geometry::quadric::{entry_negative, standing_far_root};

/// One axis-aligned single-quadric body `f(p) < 0` with
/// `f(p) = q . (diag q) + lin_z q_z + k`, `q = p - origin` (lengths in scene
/// units): the bump's body reduced to its ray test.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct QuadricRecord {
    origin: DVec3,
    diag: DVec3,
    lin_z: f64,
    k: f64,
}

impl QuadricRecord {
    /// The record of `body` and the index of its surface, if the body is
    /// `-q` of an axis-aligned quadric whose cross and horizontal linear
    /// coefficients are +0 (so the record's tests and normals, which leave
    /// them out, give the body's bits).
    pub(super) fn of(body: &Body) -> Option<(usize, Self)> {
        let (s, f) = body.single_diagonal()?;
        let [_, _, _, dd, e, ff, g, h, _, _] = body.surfaces[s].coef;
        [dd, e, ff, g, h]
            .iter()
            .all(|c| c.to_bits() == 0)
            .then_some((
                s,
                Self {
                    origin: f.origin,
                    diag: f.diag,
                    lin_z: f.lin.z,
                    k: f.k,
                },
            ))
    }

    /// Where the flight `o + t d` first enters the body in `(0, t_max]`, and
    /// whether the root should be polished: the arithmetic of
    /// [`crate::geometry::body::Body::first_entry`] on the same quadric, so
    /// the same bits (the dropped horizontal linear terms are zeros, which
    /// can only change the sign of a zero `b` or `c`, which no root depends on).
    /// `standing`: the flight starts on this surface.
    #[inline(always)]
    pub(super) fn entry(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        standing: bool,
    ) -> Option<(f64, bool)> {
        let q = o - self.origin;
        let (mq, md) = (self.diag * q, self.diag * d);
        let a = d.dot(md);
        let b = d.dot(mq) + 0.5 * (self.lin_z * d.z);
        let c = q.dot(mq) + self.lin_z * q.z + self.k;
        if standing {
            let (t, ill) = entry_negative(a, b, 0.0, t_max)?;
            let t = standing_far_root(t, b, c);
            (t <= t_max).then_some((t, ill))
        } else {
            entry_negative(a, b, c, t_max)
        }
    }

    /// The unit normal at `p` facing the flight along `d`, as
    /// [`crate::geometry::quadric::Quadric::facing_normal`] gives it for the
    /// same quadric (the same arithmetic, its zero cross and horizontal
    /// linear terms included, so the same bits); `None` where the gradient
    /// vanishes.
    #[inline]
    pub(super) fn facing_normal(&self, p: DVec3, d: DVec3) -> Option<DVec3> {
        let (a, b, c) = (self.diag.x, self.diag.y, self.diag.z);
        let q = p - self.origin;
        let (x, y, z) = (q.x, q.y, q.z);
        let g = DVec3::new(
            2.0 * a * x + 0.0 * y + 0.0 * z + 0.0,
            2.0 * b * y + 0.0 * x + 0.0 * z + 0.0,
            2.0 * c * z + 0.0 * y + 0.0 * x + self.lin_z,
        );
        let n = g.try_normalize()?;
        Some(if n.dot(d) > 0.0 { -n } else { n })
    }
}

/// What a record stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct RecordId {
    /// Index into [`super::MicroSurface::solids`].
    pub(super) solid: u32,
    /// The surface of a compact record (`u32::MAX` for a solid tested through its body).
    pub(super) surface: u32,
    /// The solid's material.
    pub(super) material: u32,
}

/// One entry of a grid cell's list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Item {
    /// Record index (below [`Grid::records`]'s length: a [`QuadricRecord`];
    /// otherwise a solid tested through its body).
    pub(super) rec: u32,
    /// Highest point of the solid over the grid cell, rounded up to `f32`.
    pub(super) z_up: f32,
}

/// A grid cell: the highest point of what it lists and where its list is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct GridCell {
    /// Highest point over the grid cell (`-inf` if its list is empty).
    pub(super) zmax: f64,
    /// The list is `items[start..end]`.
    pub(super) start: u32,
    /// End of the list.
    pub(super) end: u32,
}

/// A uniform grid over the period in x and y, listing solids by their bounds.
#[derive(Clone, Debug)]
pub(super) struct Grid {
    /// Grid cells along x and y.
    pub(super) n: [usize; 2],
    /// Grid cell sides (length units).
    pub(super) pitch: DVec2,
    /// `1 / pitch`.
    pub(super) inv_pitch: DVec2,
    /// Row-major (`iy * nx + ix`).
    pub(super) cells: Vec<GridCell>,
    /// All lists, in the Morton order of their grid cells.
    pub(super) items: Vec<Item>,
    /// The exact `f64` height of each item.
    pub(super) exact: Vec<f64>,
    /// The compact bodies, in the Morton order of their centres' grid cells.
    pub(super) records: Vec<QuadricRecord>,
    /// `(solid, surface)` of every record index (records first, then the
    /// solids tested through their bodies).
    pub(super) ids: Vec<RecordId>,
    /// Record index of every solid (`u32::MAX` for solids not in the grid).
    pub(super) record_of: Vec<u32>,
}

impl Grid {
    /// The compact record of `surface` of solid `solid`, if it has one.
    #[inline]
    pub(super) fn compact(&self, solid: usize, surface: usize) -> Option<usize> {
        let r = *self.record_of.get(solid)? as usize;
        (r < self.records.len() && self.ids[r].surface as usize == surface).then_some(r)
    }
}

/// The Morton (Z-order) code of grid cell `(ix, iy)`: their bits interleaved.
fn morton(ix: usize, iy: usize) -> u64 {
    let spread = |v: usize| {
        let mut v = v as u64 & 0xffff_ffff;
        v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
        v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        (v | (v << 1)) & 0x5555_5555_5555_5555
    };
    spread(ix) | (spread(iy) << 1)
}

/// The cells `iy * nx + ix` of an `nx x ny` grid in increasing Morton
/// order of `(ix, iy)` ([`morton`]), without a sort: the codes of the
/// enclosing power-of-two square in turn, decoded, those outside skipped
/// (fewer than 4 times the cells).
fn morton_order(nx: usize, ny: usize) -> impl Iterator<Item = usize> {
    let side = nx.max(ny).next_power_of_two() as u64;
    let compact = |v: u64| {
        let mut v = v & 0x5555_5555_5555_5555;
        v = (v | (v >> 1)) & 0x3333_3333_3333_3333;
        v = (v | (v >> 2)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v >> 4)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v >> 8)) & 0x0000_ffff_0000_ffff;
        ((v | (v >> 16)) & 0xffff_ffff) as usize
    };
    (0..side * side)
        .map(move |m| (compact(m), compact(m >> 1)))
        .filter(move |&(ix, iy)| ix < nx && iy < ny)
        .map(move |(ix, iy)| iy * nx + ix)
}

/// The finest grid [`Grid::build`] lays: cells per gridded solid ...
const GRID_CELLS_PER_SOLID: usize = 64;
/// ... unless the grid has fewer cells than this.
const MIN_GRID_CELLS: usize = 4096;

/// The `f32` nearest above or at `z` (`-inf` stays `-inf`), without
/// data-dependent branches.
#[inline(always)]
pub(super) fn f32_up(z: f64) -> f32 {
    let r = z as f32;
    let bits = r.to_bits();
    // Rounded down (never for NaN): one step up, i.e. away from zero when
    // positive (+0 included: the least positive f32, z being positive), toward
    // zero when negative (-inf included).
    let down = u32::from(f64::from(r) < z);
    let step = 1_u32.wrapping_sub((bits >> 31) << 1);
    f32::from_bits(bits.wrapping_add(down.wrapping_mul(step)))
}

impl Grid {
    /// The grid over a period of `size` for `solids[i]`, `i` in `gridded` (ascending).
    pub(super) fn build(size: DVec2, solids: &[Solid], gridded: &[usize]) -> Self {
        let shape = Shape::of(size, solids, gridded);
        // Records: compact ones first, each group in the Morton order of the
        // grid cell of its centre (ties by solid index).
        let compact = |i: usize| QuadricRecord::of(&solids[i].body);
        let mut order: Vec<(bool, u64, usize)> = gridded
            .iter()
            .map(|&i| (compact(i).is_none(), shape.centre_key(&solids[i]), i))
            .collect();
        order.sort_unstable();
        let mut records = Vec::new();
        let mut ids = Vec::with_capacity(order.len());
        let mut record_of = vec![u32::MAX; solids.len()];
        for &(_, _, i) in &order {
            record_of[i] = ids.len() as u32;
            match compact(i) {
                Some((surface, record)) => {
                    records.push(record);
                    ids.push(RecordId {
                        solid: i as u32,
                        surface: surface as u32,
                        material: solids[i].body.material as u32,
                    });
                }
                // A solid tested through its body has no fixed surface.
                None => ids.push(RecordId {
                    solid: i as u32,
                    surface: u32::MAX,
                    material: solids[i].body.material as u32,
                }),
            }
        }
        let mut slots = Slots::fill(&shape, solids, &order, &record_of);
        slots.drop_buried();
        let (cells, items, exact) = slots.into_cells(&shape, &ids);
        Self {
            n: [shape.nx, shape.ny],
            pitch: shape.pitch,
            inv_pitch: shape.pitch.recip(),
            cells,
            items,
            exact,
            records,
            ids,
            record_of,
        }
    }
}

/// The cells of a grid under construction: `nx` x `ny` over the period,
/// each `pitch` wide (length units).
struct Shape {
    /// Cells along x.
    nx: usize,
    /// Cells along y.
    ny: usize,
    /// Cell sides (length units).
    pitch: DVec2,
}

impl Shape {
    /// The cells over a period of `size` for `solids[i]`, `i` in `gridded`.
    fn of(size: DVec2, solids: &[Solid], gridded: &[usize]) -> Self {
        // Grid pitch: a fifth of the median footprint side, so a bump spans
        // about 6 x 6 grid cells and its exact height over each is a tight
        // bound (coarser pitches test more bumps per segment, finer ones
        // walk more grid cells).
        let mut sides: Vec<f64> = gridded
            .iter()
            .map(|&i| {
                let b = &solids[i].body.bounds;
                (b.max.x - b.min.x).max(b.max.y - b.min.y)
            })
            .filter(|s| s.is_finite() && *s > 0.0)
            .collect();
        sides.sort_by(f64::total_cmp);
        let target = sides
            .get(sides.len() / 2)
            .map_or(size.max_element(), |s| s / 5.0);
        // But no finer than GRID_CELLS_PER_SOLID cells a solid (at least
        // MIN_GRID_CELLS in all): small sparse bumps would otherwise get up
        // to 2048² cells, nearly all empty, which take memory to build and
        // time to walk through.
        let budget = (GRID_CELLS_PER_SOLID * gridded.len()).max(MIN_GRID_CELLS) as f64;
        let target = target.max((size.x * size.y / budget).sqrt());
        let nx = ((size.x / target).ceil() as usize).clamp(1, 2048);
        let ny = ((size.y / target).ceil() as usize).clamp(1, 2048);
        let pitch = DVec2::new(size.x / nx as f64, size.y / ny as f64);
        Self { nx, ny, pitch }
    }

    /// The cell indices `lo..=hi` (length units) falls in along an axis
    /// of `n` cells `pitch` wide, clamped to the grid.
    fn span(lo: f64, hi: f64, pitch: f64, n: usize) -> RangeInclusive<usize> {
        let a = ((lo / pitch).floor().max(0.0) as usize).min(n - 1);
        let b = ((hi / pitch).floor().max(0.0) as usize).min(n - 1);
        a..=b
    }

    /// The Morton index of the cell of a solid's bounds' centre.
    fn centre_key(&self, solid: &Solid) -> u64 {
        let b = &solid.body.bounds;
        let c = 0.5 * (b.min + b.max);
        let ix = *Self::span(c.x, c.x, self.pitch.x, self.nx).start();
        let iy = *Self::span(c.y, c.y, self.pitch.y, self.ny).start();
        morton(ix, iy)
    }

    /// The cells (x and y ranges) a solid's bounds cover.
    fn footprint(&self, solid: &Solid) -> (RangeInclusive<usize>, RangeInclusive<usize>) {
        let b = &solid.body.bounds;
        (
            Self::span(b.min.x, b.max.x, self.pitch.x, self.nx),
            Self::span(b.min.y, b.max.y, self.pitch.y, self.ny),
        )
    }
}

/// The solids listed per grid cell while the grid is built: the lists in
/// one flat array (`rec`, `top`), cell `c`'s in
/// `first[c]..first[c] + len[c]`; no list of its own per cell.
struct Slots {
    /// Start of each cell's slots (`nx * ny + 1` entries).
    first: Vec<usize>,
    /// Slots used per cell.
    len: Vec<u32>,
    /// Record of each slot.
    rec: Vec<u32>,
    /// Height of the solid over the cell of each slot (length units).
    top: Vec<f64>,
    /// Highest solid over each cell.
    zmax: Vec<f64>,
    /// The height up to which some solid fills the grid cell's whole
    /// column: a flight over the cell (outside every solid) stays above
    /// it, so a solid wholly below it there is not listed there (buried
    /// under larger bumps; it is listed wherever it reaches above them).
    floor: Vec<f64>,
}

impl Slots {
    /// Every solid of `order` (records' order) listed in the cells its
    /// bounds cover where it reaches up, with its exact height there.
    fn fill(
        shape: &Shape,
        solids: &[Solid],
        order: &[(bool, u64, usize)],
        record_of: &[u32],
    ) -> Self {
        let (nx, ny, pitch) = (shape.nx, shape.ny, shape.pitch);
        // Each cell's slots are reserved by a first pass over the solids'
        // bounds (an upper bound: a solid leaves the cells where it does not
        // reach up).
        // Both passes visit the solids in the records' order (the
        // Morton order of their centres), so that neighbouring solids write
        // neighbouring cells one after the other: in the solids' own order
        // (random places) every solid's cells were cache misses. Their cell
        // ranges are gathered first, in a loop of independent loads.
        let ranges: Vec<_> = order
            .iter()
            .map(|&(_, _, i)| shape.footprint(&solids[i]))
            .collect();
        let mut first = vec![0_usize; nx * ny + 1];
        for (xs, ys) in ranges.iter().cloned() {
            for iy in ys {
                for ix in xs.clone() {
                    first[iy * nx + ix + 1] += 1;
                }
            }
        }
        for c in 0..nx * ny {
            first[c + 1] += first[c];
        }
        let slots = first[nx * ny];
        let mut s = Self {
            first,
            len: vec![0_u32; nx * ny],
            // Record and height of each slot, in two arrays (no padding).
            rec: vec![0_u32; slots],
            top: vec![0.0_f64; slots],
            zmax: vec![f64::NEG_INFINITY; nx * ny],
            floor: vec![f64::NEG_INFINITY; nx * ny],
        };
        for (&(_, _, i), (xs, ys)) in order.iter().zip(ranges) {
            for iy in ys {
                for ix in xs.clone() {
                    let lo = DVec2::new(ix as f64, iy as f64) * pitch;
                    let top = solids[i].max_height_over(lo, lo + pitch);
                    if top == f64::NEG_INFINITY {
                        continue;
                    }
                    let c = iy * nx + ix;
                    let slot = s.first[c] + s.len[c] as usize;
                    (s.rec[slot], s.top[slot]) = (record_of[i], top);
                    s.len[c] += 1;
                    s.zmax[c] = s.zmax[c].max(top);
                    s.floor[c] = s.floor[c].max(solids[i].covers_over(lo, lo + pitch));
                }
            }
        }
        s
    }

    /// Buried solids leave their cells' slots (in place, in order).
    fn drop_buried(&mut self) {
        for c in 0..self.len.len() {
            let mut kept = 0;
            for k in self.first[c]..self.first[c] + self.len[c] as usize {
                if self.top[k] >= self.floor[c] {
                    let to = self.first[c] + kept;
                    (self.rec[to], self.top[to]) = (self.rec[k], self.top[k]);
                    kept += 1;
                }
            }
            self.len[c] = kept as u32;
        }
    }

    /// The grid's cells, items and exact heights: the cells' lists laid
    /// out in the Morton order of the cells, each tallest first.
    fn into_cells(self, shape: &Shape, ids: &[RecordId]) -> (Vec<GridCell>, Vec<Item>, Vec<f64>) {
        let (nx, ny) = (shape.nx, shape.ny);
        let mut cells = vec![
            GridCell {
                zmax: f64::NEG_INFINITY,
                start: 0,
                end: 0
            };
            nx * ny
        ];
        let kept: usize = self.len.iter().map(|&n| n as usize).sum();
        let mut items = Vec::with_capacity(kept);
        let mut exact = Vec::with_capacity(kept);
        let mut l: Vec<(u32, f64)> = Vec::new();
        for c in morton_order(nx, ny) {
            l.clear();
            let own = self.first[c]..self.first[c] + self.len[c] as usize;
            l.extend(
                self.rec[own.clone()]
                    .iter()
                    .copied()
                    .zip(self.top[own].iter().copied()),
            );
            // Tallest first (ties in the solids' order), so a flight stops
            // scanning at the first solid below it.
            l.sort_unstable_by(|a, b| {
                b.1.total_cmp(&a.1)
                    .then_with(|| ids[a.0 as usize].solid.cmp(&ids[b.0 as usize].solid))
            });
            let start = items.len() as u32;
            for &(rec, top) in &l {
                items.push(Item {
                    rec,
                    z_up: f32_up(top),
                });
                exact.push(top);
            }
            cells[c] = GridCell {
                zmax: self.zmax[c],
                start,
                end: items.len() as u32,
            };
        }
        (cells, items, exact)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_order_is_the_order_of_the_codes() {
        for (nx, ny) in [(1, 1), (3, 5), (8, 8), (13, 2), (64, 33)] {
            let mut want: Vec<usize> = (0..nx * ny).collect();
            want.sort_by_key(|&c| morton(c % nx, c / nx));
            assert_eq!(
                morton_order(nx, ny).collect::<Vec<_>>(),
                want,
                "{nx} x {ny}"
            );
        }
    }

    #[test]
    fn morton_interleaves_bits() {
        assert_eq!(morton(0, 0), 0);
        assert_eq!(morton(1, 0), 1);
        assert_eq!(morton(0, 1), 2);
        assert_eq!(morton(3, 3), 15);
        assert_eq!(morton(2047, 0), 0x0015_5555);
        assert_eq!(morton(0, 2047), 0x002a_aaaa);
    }

    #[test]
    fn f32_up_is_the_nearest_f32_at_or_above() {
        for z in [0.0, 1.0, 0.1, -0.1, 4.8, 1e-30, -1e-30, 1e-50, -3.3, -1e39] {
            let r = f32_up(z);
            assert!(f64::from(r) >= z, "{z}");
            // The f32 just below (one step away from +inf) is below z.
            let below = if r > 0.0 {
                f32::from_bits(r.to_bits() - 1)
            } else if r == 0.0 {
                -f32::from_bits(1)
            } else {
                f32::from_bits(r.to_bits() + 1)
            };
            assert!(f64::from(below) < z, "{z}");
        }
    }

    /// Records give the bits of their bodies' entries and normals, for
    /// every compact bump shape, from outside and standing on the surface.
    #[test]
    fn records_agree_with_their_bodies_bit_for_bit() {
        use crate::geometry::body::Ray;
        use crate::micro::bumps::{Bump, Shape};
        let bump = Bump {
            center: DVec2::new(5.3, 4.1),
            radius: 2.7,
            radius_y: 1.9,
            height: 3.1,
            depth: 0.7,
            cap: 1.0,
            base: 1.5,
        };
        let mut checked = 0;
        for shape in [
            Shape::Ellipsoid,
            Shape::Paraboloid,
            Shape::EllipsoidOnHyperboloid,
        ] {
            let body = shape
                .body(&bump, 0)
                .body
                .translated(DVec3::new(30.0, -30.0, 0.0));
            let (i, rec) = QuadricRecord::of(&body).expect("compact");
            let quadric = body.surfaces[i];
            for k in 0..2000 {
                let a = f64::from(k) * 0.618_033_988_749_895;
                let o = DVec3::new(
                    35.3 + 6.0 * a.cos(),
                    -25.9 + 6.0 * (1.3 * a).sin(),
                    5.0 * (0.7 * a).sin().abs(),
                );
                let target = DVec3::new(
                    35.3 + 2.0 * (2.1 * a).sin(),
                    -25.9 + 1.5 * (1.7 * a).cos(),
                    3.0 * (0.3 * a).cos(),
                );
                let d = (target - o).normalize();
                let want = body.first_entry(&Ray::new(o, d), 50.0, None);
                let got = rec.entry(o, d, 50.0, false).map(|(t, ill)| {
                    if ill { quadric.refine_root(o, d, t) } else { t }
                });
                assert_eq!(
                    want.map(|e| e.t.to_bits()),
                    got.map(f64::to_bits),
                    "{shape:?} {k}"
                );
                if let Some(e) = want {
                    checked += 1;
                    let p = o + e.t * d;
                    assert_eq!(quadric.facing_normal(p, d), rec.facing_normal(p, d));
                    // Standing at the hit, reflected: the far root.
                    let n = quadric.facing_normal(p, d).unwrap();
                    let r = (d - 2.0 * d.dot(n) * n).normalize();
                    let want = body.first_entry(&Ray::new(p, r), 50.0, Some(i));
                    let got = rec.entry(p, r, 50.0, true).map(|(t, ill)| {
                        if ill { quadric.refine_root(p, r, t) } else { t }
                    });
                    assert_eq!(want.map(|e| e.t.to_bits()), got.map(f64::to_bits));
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    /// The branch-free `f32_up` gives the bits of the branching one it
    /// replaced (kept here as the reference), for every class of input.
    #[test]
    fn f32_up_without_branches_is_the_branching_one() {
        fn reference(z: f64) -> f32 {
            let r = z as f32;
            if f64::from(r) >= z || r.is_nan() {
                r
            } else if r == 0.0 {
                f32::from_bits(1)
            } else if r > 0.0 {
                f32::from_bits(r.to_bits() + 1)
            } else {
                f32::from_bits(r.to_bits() - 1)
            }
        }
        let mut z = vec![
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MAX,
            -f64::MAX,
            f64::MIN_POSITIVE,
            1e-300,
            -1e-300,
            1e-46,
            -1e-46,
            f64::from(f32::MAX),
            f64::from(f32::MAX) * (1.0 + 1e-12),
            -f64::from(f32::MAX) * (1.0 + 1e-12),
        ];
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            z.push(f64::from_bits(x));
            // Heights of a scene's scale, either sign.
            z.push((x >> 11) as f64 / (1_u64 << 53) as f64 * 20.0 - 5.0);
        }
        for z in z {
            assert_eq!(f32_up(z).to_bits(), reference(z).to_bits(), "{z:e}");
        }
    }

    #[test]
    fn records_are_one_cache_line() {
        assert_eq!(std::mem::size_of::<QuadricRecord>(), 64);
        assert_eq!(std::mem::align_of::<QuadricRecord>(), 64);
        assert_eq!(std::mem::size_of::<Item>(), 8);
    }
}
