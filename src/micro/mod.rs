//! The micro level: an explicit rough surface in which photons reflect specularly.
//!
//! A [`MicroSurface`] is a rectangular cell `[0, Lx] x [0, Ly]` of substrate
//! (the half-space `z <= 0`) with solid bodies on it (random bumps or explicit
//! CSG bodies). The visible surface is the upper boundary of the union of the
//! substrate and the bodies. Photons start on the launch plane `z = top` (the
//! highest point of the surface, plus a hair) and leave when they cross it
//! going up. What happens at the sides of the cell is set by [`Edges`].
//!
//! Bodies whose bounds cross a side of a periodic cell are copied (ghosts)
//! shifted by whole periods, so every bump wraps. Bodies with unbounded extent
//! in x or y (for example planes making V-grooves) are tested for every
//! segment; all others are found through a uniform 2-D grid whose cells also
//! store the highest point of what they hold, so rays that pass above a grid
//! cell skip it. The cost per segment stays flat as the bump count grows at
//! constant density.
//!
//! Instead of the substrate and solids, a surface may be a periodic
//! [`heightfield::HeightField`] (a triangulated grid of heights); then
//! [`MicroSurface::next_event`] walks the field, [`Event::Hit`] names it by
//! `solid = HEIGHT_FIELD` and a triangle id, and [`MicroSurface::hit_normal`]
//! gives the normal for either kind, so the photon history has one loop.

pub mod bumps;
pub mod heightfield;
pub mod heightfield_io;
pub mod surface_stats;

use glam::{DVec2, DVec3};

use crate::geometry::body::{Aabb, Body, Ray};
use crate::optics::material::Reflectance;
use heightfield::{FieldEvent, HeightField};

/// `solid` of an [`Event::Hit`] on the height field (its `surface` is the triangle id).
pub const HEIGHT_FIELD: usize = usize::MAX;

/// What happens where a photon reaches a side of the cell below the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edges {
    /// The cell tiles the plane: the photon re-enters on the opposite side.
    Periodic,
    /// Vertical walls up to the top absorb (the paper's perfect absorber).
    Absorbing,
    /// Vertical walls up to the top reflect specularly with the substrate material.
    Reflecting,
}

/// A solid of the micro geometry as placed in cell coordinates.
#[derive(Clone, Debug)]
pub struct Solid {
    /// The body, already translated into the cell (ghosts are separate solids).
    pub body: Body,
    /// Index of the scene body or bump this solid is a copy of.
    pub source: usize,
    /// For bumps: the shape and parameters, which give exact heights over
    /// grid cells (tighter than the bounds).
    pub bump: Option<(bumps::Shape, bumps::Bump)>,
}

impl Solid {
    /// Highest point of the solid over the rectangle `[lo, hi]` (an upper bound).
    fn max_height_over(&self, lo: DVec2, hi: DVec2) -> f64 {
        match &self.bump {
            Some((shape, b)) => {
                // A relative pad keeps the bound above rounding in the body's own test.
                let z = shape.max_height_over(b, lo, hi);
                z + 1e-9 * b.height
            }
            None => self.body.bounds.max.z,
        }
    }
}

/// The next thing a straight flight meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Enters solid `solid` through its surface `surface` at distance `t`.
    Hit {
        /// Distance (units of `|d|`).
        t: f64,
        /// Index into [`MicroSurface::solids`], or [`HEIGHT_FIELD`].
        solid: usize,
        /// Index into that solid's surfaces, or the height field's triangle id.
        surface: usize,
    },
    /// Leaves through the launch plane at distance `t` (escapes).
    Top {
        /// Distance (units of `|d|`).
        t: f64,
    },
    /// Reaches side `axis` (0 = x, 1 = y) of the cell below the top, at the
    /// upper end of the axis when `upper`.
    Side {
        /// Distance (units of `|d|`).
        t: f64,
        /// 0 for the x sides, 1 for the y sides.
        axis: usize,
        /// True at `x = Lx` (or `y = Ly`), false at 0.
        upper: bool,
    },
    /// The flight never ends in the cell (horizontal and above everything); counted as lost.
    Trapped,
}

/// Per-thread scratch for [`MicroSurface::next_event`] (mailboxing).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    stamp: Vec<u32>,
    query: u32,
    /// Intersection tests so far: quadrics whose ray polynomial was formed
    /// (bodies), or squares of two triangles tested (height fields).
    pub tests: u64,
}

impl Scratch {
    /// Scratch sized for `surface`.
    #[must_use]
    pub fn new(surface: &MicroSurface) -> Self {
        Self {
            stamp: vec![0; surface.solids.len()],
            query: 0,
            tests: 0,
        }
    }

    fn next_query(&mut self) -> u32 {
        self.query = self.query.wrapping_add(1);
        if self.query == 0 {
            self.stamp.fill(0);
            self.query = 1;
        }
        self.query
    }
}

/// A uniform grid over the cell in x and y, listing solids by their bounds.
#[derive(Clone, Debug)]
struct Grid {
    n: [usize; 2],
    pitch: DVec2,
    inv_pitch: DVec2,
    /// CSR offsets into `items`, one per grid cell plus one.
    start: Vec<u32>,
    /// Solid index and the top of its bounds, so solids below a flight are
    /// skipped without touching them.
    items: Vec<(u32, f64)>,
    /// Highest `bounds.max.z` of the items of each grid cell (`-inf` if empty).
    zmax: Vec<f64>,
}

impl Grid {
    fn build(size: DVec2, solids: &[Solid], gridded: &[usize]) -> Self {
        // Grid pitch: a fifth of the median footprint side, so a bump spans
        // about 6 x 6 grid cells and its exact height over each is a tight
        // bound (pitches of 1/4 to 1/6 measured best on the default scene:
        // 13 % fewer instructions than 1/2).
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
        let nx = ((size.x / target).ceil() as usize).clamp(1, 2048);
        let ny = ((size.y / target).ceil() as usize).clamp(1, 2048);
        let pitch = DVec2::new(size.x / nx as f64, size.y / ny as f64);
        let range = |lo: f64, hi: f64, pitch: f64, n: usize| {
            let a = ((lo / pitch).floor().max(0.0) as usize).min(n - 1);
            let b = ((hi / pitch).floor().max(0.0) as usize).min(n - 1);
            a..=b
        };
        let mut lists = vec![Vec::new(); nx * ny];
        let mut zmax = vec![f64::NEG_INFINITY; nx * ny];
        for &i in gridded {
            let b = &solids[i].body.bounds;
            for iy in range(b.min.y, b.max.y, pitch.y, ny) {
                for ix in range(b.min.x, b.max.x, pitch.x, nx) {
                    let lo = DVec2::new(ix as f64, iy as f64) * pitch;
                    let top = solids[i].max_height_over(lo, lo + pitch);
                    if top == f64::NEG_INFINITY {
                        continue;
                    }
                    lists[iy * nx + ix].push((i as u32, top));
                    zmax[iy * nx + ix] = zmax[iy * nx + ix].max(top);
                }
            }
        }
        let mut start = Vec::with_capacity(nx * ny + 1);
        let mut items = Vec::new();
        start.push(0);
        for mut l in lists {
            // Tallest first, so a flight stops scanning at the first solid below it.
            l.sort_by(|a, b| b.1.total_cmp(&a.1));
            items.extend(l);
            start.push(items.len() as u32);
        }
        Self {
            n: [nx, ny],
            pitch,
            inv_pitch: pitch.recip(),
            start,
            items,
            zmax,
        }
    }

    fn cell_items(&self, cell: usize) -> &[(u32, f64)] {
        &self.items[self.start[cell] as usize..self.start[cell + 1] as usize]
    }
}

/// An explicit rough surface: substrate, solids, edges, materials.
#[derive(Clone, Debug)]
pub struct MicroSurface {
    /// Cell size `(Lx, Ly)` (length units).
    pub size: DVec2,
    /// Side behaviour.
    pub edges: Edges,
    /// All solids in cell coordinates; solid 0 is the substrate.
    pub solids: Vec<Solid>,
    /// Height of the launch plane and of the walls (length units).
    pub top: f64,
    /// Highest point of the surface (length units); `top` is a hair above it.
    pub max_height: f64,
    /// Materials referenced by the solids.
    pub materials: Vec<Reflectance>,
    /// Material of the substrate and of reflecting walls.
    pub substrate_material: usize,
    /// A height field replacing substrate and solids (then `solids` is empty
    /// and the edges are periodic).
    pub heightfield: Option<HeightField>,
    /// Solids tested for every flight (unbounded in x or y).
    global: Vec<usize>,
    grid: Grid,
}

/// What the builder needs to know of a body placed on the substrate.
#[derive(Clone, Debug)]
pub struct Placed {
    /// The body in cell coordinates.
    pub body: Body,
    /// Highest point of the body (length units).
    pub max_height: f64,
    /// Copy into neighbouring periods when it crosses a side (bumps do).
    pub wraps: bool,
    /// For bumps: shape and parameters (exact heights for the grid).
    pub bump: Option<(bumps::Shape, bumps::Bump)>,
}

/// Bytes one grid item costs while [`Grid::build`] runs: the entry in its
/// cell's list (with the list's growth slack) and in the final `items`.
const GRID_ITEM_BYTES: u64 = 32;

/// Estimated peak memory (bytes) and solid count that one body adds to a
/// surface built by [`MicroSurface::new`] over a cell of `size` with `edges`:
/// the body in the input list, each of its solids (periodic ghost copies
/// included: one per whole-period shift whose copy reaches into the cell,
/// on average `(1 + w / Lx) (1 + h / Ly)` for a footprint `w x h` placed at
/// random) with its heap, its mailbox stamp per worker thread, and its
/// entries in the acceleration grid (one per grid cell its bounds cover,
/// the grid pitch being a fifth of the body's footprint side as
/// [`Grid::build`] takes it from the median, at most 2048 cells a side).
/// Right to a factor of about 2; used to refuse a scene before allocating.
#[must_use]
pub fn placed_cost(placed: &Placed, size: DVec2, edges: Edges) -> (u64, u64) {
    let b = &placed.body.bounds;
    let (w, h) = (b.max.x - b.min.x, b.max.y - b.min.y);
    let bounded = w.is_finite() && h.is_finite();
    let heap = placed.body.heap_bytes() as u64;
    let own = std::mem::size_of::<Placed>() as u64 + heap;
    if !bounded {
        return (1, own + std::mem::size_of::<Solid>() as u64 + heap);
    }
    let per_axis = |extent: f64, side: f64| -> f64 {
        if edges == Edges::Periodic && placed.wraps {
            1.0 + extent / side
        } else {
            1.0
        }
    };
    // Saturating float-to-int: an absurd ratio stays huge, not wrapped.
    let copies = (per_axis(w, size.x) * per_axis(h, size.y)).round() as u64;
    let items_per_axis = |extent: f64, side: f64| -> u64 {
        let target = extent.max(f64::MIN_POSITIVE) / 5.0;
        let cells = ((side / target).ceil() as u64).clamp(1, 2048);
        let pitch = side / cells as f64;
        ((extent.min(side) / pitch).ceil() as u64 + 1).min(cells)
    };
    let items = items_per_axis(w, size.x) * items_per_axis(h, size.y);
    let threads = std::thread::available_parallelism().map_or(1, usize::from) as u64;
    let per_solid =
        std::mem::size_of::<Solid>() as u64 + heap + 4 * threads + items * GRID_ITEM_BYTES;
    (copies, own.saturating_add(copies.saturating_mul(per_solid)))
}

impl MicroSurface {
    /// Assemble a micro surface.
    ///
    /// `bodies` are in cell coordinates. The substrate (solid 0) is added here
    /// with `substrate_material`.
    #[must_use]
    pub fn new(
        size: DVec2,
        edges: Edges,
        bodies: Vec<Placed>,
        materials: Vec<Reflectance>,
        substrate_material: usize,
    ) -> Self {
        use crate::geometry::quadric::Quadric;

        let substrate = Body::new(
            vec![Quadric::plane_z(0.0)],
            crate::geometry::region::parse("-s", |_| Some(0)).expect("fixed region"),
            Aabb {
                min: DVec3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
                max: DVec3::new(f64::INFINITY, f64::INFINITY, 0.0),
            },
            substrate_material,
        );
        let mut solids = vec![Solid {
            body: substrate,
            source: usize::MAX,
            bump: None,
        }];
        let mut max_height: f64 = 0.0;
        let cell = Aabb {
            min: DVec3::new(0.0, 0.0, f64::NEG_INFINITY),
            max: DVec3::new(size.x, size.y, f64::INFINITY),
        };
        for (source, placed) in bodies.into_iter().enumerate() {
            max_height = max_height.max(placed.max_height);
            let b = placed.body.bounds;
            let bounded = b.min.x.is_finite()
                && b.max.x.is_finite()
                && b.min.y.is_finite()
                && b.max.y.is_finite();
            if edges == Edges::Periodic && placed.wraps && bounded {
                // Every whole-period shift whose copy reaches into the cell.
                let kx = (b.max.x - b.min.x) / size.x + 1.0;
                let ky = (b.max.y - b.min.y) / size.y + 1.0;
                let (kx, ky) = (kx.ceil() as i64, ky.ceil() as i64);
                for jy in -ky..=ky {
                    for jx in -kx..=kx {
                        let shift = DVec3::new(jx as f64 * size.x, jy as f64 * size.y, 0.0);
                        if overlaps_xy(&b.translated(shift), &cell) {
                            let bump = placed.bump.map(|(shape, mut bump)| {
                                bump.center += shift.truncate();
                                (shape, bump)
                            });
                            solids.push(Solid {
                                body: placed.body.translated(shift),
                                source,
                                bump,
                            });
                        }
                    }
                }
            } else if !bounded || overlaps_xy(&b, &cell) {
                solids.push(Solid {
                    body: placed.body,
                    source,
                    bump: placed.bump,
                });
            }
        }
        let (global, gridded): (Vec<usize>, Vec<usize>) = (0..solids.len()).partition(|&i| {
            let b = &solids[i].body.bounds;
            !(b.min.x.is_finite()
                && b.max.x.is_finite()
                && b.min.y.is_finite()
                && b.max.y.is_finite())
        });
        let grid = Grid::build(size, &solids, &gridded);
        // The launch plane sits a hair above the highest point so that no
        // photon starts on or inside a body (relative to the scene's scale).
        let scale = size.max_element().max(max_height.abs());
        let top = max_height + 1e-9 * scale;
        Self {
            size,
            edges,
            solids,
            top,
            max_height,
            materials,
            substrate_material,
            heightfield: None,
            global,
            grid,
        }
    }

    /// A periodic surface made of the height field `field` alone, of
    /// material `material` (an index into `materials`).
    #[must_use]
    pub fn from_height_field(
        field: HeightField,
        materials: Vec<Reflectance>,
        material: usize,
    ) -> Self {
        let size = field.size;
        let max_height = field.max;
        let scale = size.max_element().max(field.max.abs()).max(field.min.abs());
        Self {
            size,
            edges: Edges::Periodic,
            solids: Vec::new(),
            top: max_height + 1e-9 * scale,
            max_height,
            materials,
            substrate_material: material,
            heightfield: Some(field),
            global: Vec::new(),
            grid: Grid::build(size, &[], &[]),
        }
    }

    /// The unit normal facing the flight (`n . d <= 0`) and the material
    /// where a flight along `d` ended in `Event::Hit { solid, surface, .. }`
    /// at `p`. A height-field hit may lie in a neighbouring period: `p` is
    /// then moved back into the cell by whole periods. `None` where the
    /// normal is undefined (a cone apex).
    #[must_use]
    #[inline]
    pub fn hit_normal(
        &self,
        p: &mut DVec3,
        d: DVec3,
        solid: usize,
        surface: usize,
    ) -> Option<(DVec3, usize)> {
        if solid == HEIGHT_FIELD {
            let field = self.heightfield.as_ref()?;
            *p = field.fold(*p);
            // Hits are only taken while the flight descends onto the triangle.
            return Some((field.normal(surface), self.substrate_material));
        }
        let body = &self.solids[solid].body;
        let n = body.surfaces[surface].facing_normal(*p, d)?;
        Some((n, body.material))
    }

    /// The next event of the flight from `o` along unit `d`, which starts inside
    /// the cell. `standing`: `(solid, surface)` the flight starts on.
    #[must_use]
    pub fn next_event(
        &self,
        o: DVec3,
        d: DVec3,
        standing: Option<(usize, usize)>,
        scratch: &mut Scratch,
    ) -> Event {
        if let Some(field) = &self.heightfield {
            return self.next_field_event(field, o, d, standing, &mut scratch.tests);
        }
        let ray = Ray::new(o, d);
        let inv = ray.inv_d;
        // Where the flight leaves the cell box: the top or a side.
        let mut exit = Event::Trapped;
        let mut t_best = f64::INFINITY;
        if d.z > 0.0 {
            t_best = ((self.top - o.z) * inv.z).max(0.0);
            exit = Event::Top { t: t_best };
        }
        for axis in 0..2 {
            let (dk, ok, len) = (d[axis], o[axis], self.size[axis]);
            let (t, upper) = if dk > 0.0 {
                ((len - ok) * inv[axis], true)
            } else if dk < 0.0 {
                (-ok * inv[axis], false)
            } else {
                continue;
            };
            let t = t.max(0.0);
            if t < t_best {
                t_best = t;
                exit = Event::Side { t, axis, upper };
            }
        }
        let mut best: Option<(f64, usize, usize)> = None;
        let mut tests = 0_u64;
        let test = |i: usize,
                    t_best: &mut f64,
                    best: &mut Option<(f64, usize, usize)>,
                    tests: &mut u64| {
            let on = standing.and_then(|(s, f)| (s == i).then_some(f));
            if let Some(e) = self.solids[i]
                .body
                .first_entry_counting(&ray, *t_best, on, tests)
            {
                *t_best = e.t;
                *best = Some((e.t, i, e.surface));
            }
        };
        for &i in &self.global {
            // A rising flight above a solid's top cannot enter it (the substrate, mostly).
            if d.z >= 0.0 && o.z > self.solids[i].body.bounds.max.z {
                continue;
            }
            test(i, &mut t_best, &mut best, &mut tests);
        }
        // Walk the grid cells under the flight (Amanatides & Woo), nearest first.
        let q = scratch.next_query();
        let g = &self.grid;
        let mut cell = [0usize; 2];
        let mut t_next = [f64::INFINITY; 2];
        let mut t_delta = [f64::INFINITY; 2];
        let mut step = [0isize; 2];
        for k in 0..2 {
            // o is inside the cell, so truncation is the floor (and `as` saturates).
            let c = ((o[k] * g.inv_pitch[k]) as usize).min(g.n[k] - 1);
            cell[k] = c;
            if d[k] > 0.0 {
                step[k] = 1;
                t_next[k] = ((c + 1) as f64 * g.pitch[k] - o[k]) * inv[k];
                t_delta[k] = g.pitch[k] * inv[k];
            } else if d[k] < 0.0 {
                step[k] = -1;
                t_next[k] = (c as f64 * g.pitch[k] - o[k]) * inv[k];
                t_delta[k] = -g.pitch[k] * inv[k];
            }
        }
        let mut t_enter = 0.0_f64;
        while t_enter <= t_best {
            let t_leave = t_next[0].min(t_next[1]);
            let idx = cell[1] * g.n[0] + cell[0];
            // Lowest point of the flight within this grid cell.
            let z_low = if d.z >= 0.0 {
                o.z + t_enter * d.z
            } else {
                o.z + t_leave.min(t_best) * d.z
            };
            if z_low <= g.zmax[idx] {
                for &(i, zmax) in g.cell_items(idx) {
                    if zmax < z_low {
                        break;
                    }
                    let i = i as usize;
                    if scratch.stamp[i] != q {
                        scratch.stamp[i] = q;
                        test(i, &mut t_best, &mut best, &mut tests);
                    }
                }
            }
            if t_best <= t_leave {
                break;
            }
            let k = usize::from(t_next[1] < t_next[0]);
            let c = cell[k] as isize + step[k];
            if c < 0 || c >= g.n[k] as isize {
                break;
            }
            cell[k] = c as usize;
            t_enter = t_next[k];
            t_next[k] += t_delta[k];
        }
        scratch.tests += tests;
        match best {
            Some((t, solid, surface)) => Event::Hit { t, solid, surface },
            None => exit,
        }
    }

    /// [`Self::next_event`] on the height field (kept out of line, so the
    /// bump path's code stays as it was).
    #[inline(never)]
    fn next_field_event(
        &self,
        field: &HeightField,
        o: DVec3,
        d: DVec3,
        standing: Option<(usize, usize)>,
        tests: &mut u64,
    ) -> Event {
        let standing = standing.and_then(|(s, tri)| (s == HEIGHT_FIELD).then_some(tri));
        match field.first_hit_counting(o, d, standing, tests) {
            FieldEvent::Hit { t, triangle } => Event::Hit {
                t,
                solid: HEIGHT_FIELD,
                surface: triangle,
            },
            FieldEvent::Escapes => Event::Top {
                t: ((self.top - o.z) / d.z).max(0.0),
            },
            FieldEvent::Trapped => Event::Trapped,
        }
    }

    /// Height of the surface at `(x, y)` (a vertical ray from the top).
    #[must_use]
    pub fn height_at(&self, x: f64, y: f64, scratch: &mut Scratch) -> f64 {
        let o = DVec3::new(x, y, self.top);
        match self.next_event(o, DVec3::NEG_Z, None, scratch) {
            Event::Hit { t, .. } => self.top - t,
            _ => f64::NAN,
        }
    }

    /// Estimated peak memory (bytes) of the statistics of this surface on an
    /// `nx x ny` map ([`surface_stats::memory_bytes`]), for memory checks.
    #[must_use]
    pub fn stats_memory_bytes(&self, nx: usize, ny: usize) -> u64 {
        let periodic = self.heightfield.is_some() || self.edges == Edges::Periodic;
        surface_stats::memory_bytes(nx, ny, periodic)
    }

    /// The height map on an `nx x ny` grid of pixel centres over the cell.
    ///
    /// For a height field whose grid is a multiple of `nx x ny` the samples
    /// are its vertex heights themselves (every `k`-th vertex), exact and
    /// offset by half a pixel from the centres (which changes no statistic of
    /// a periodic map); otherwise vertical rays sample the surface.
    #[must_use]
    pub fn height_map(&self, nx: usize, ny: usize) -> surface_stats::HeightMap {
        use rayon::prelude::*;
        let dx = self.size.x / nx as f64;
        let dy = self.size.y / ny as f64;
        if let Some(f) = self
            .heightfield
            .as_ref()
            .filter(|f| nx > 0 && ny > 0 && f.nx % nx == 0 && f.ny % ny == 0)
        {
            let (kx, ky) = (f.nx / nx, f.ny / ny);
            return surface_stats::HeightMap {
                nx,
                ny,
                dx,
                dy,
                h: (0..nx * ny)
                    .map(|k| f.h[(k / nx) * ky * f.nx + (k % nx) * kx])
                    .collect(),
                periodic: true,
            };
        }
        let h: Vec<f64> = (0..ny)
            .into_par_iter()
            .flat_map_iter(|iy| {
                let mut scratch = Scratch::new(self);
                (0..nx)
                    .map(|ix| {
                        self.height_at((ix as f64 + 0.5) * dx, (iy as f64 + 0.5) * dy, &mut scratch)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        surface_stats::HeightMap {
            nx,
            ny,
            dx,
            dy,
            h,
            periodic: self.edges == Edges::Periodic,
        }
    }

    /// Number of solids tested for every flight, and the mean number of solids
    /// listed per grid cell (for reports).
    #[must_use]
    pub fn acceleration_stats(&self) -> (usize, f64) {
        if self.heightfield.is_some() {
            return (0, 0.0);
        }
        let cells = self.grid.n[0] * self.grid.n[1];
        (
            self.global.len(),
            self.grid.items.len() as f64 / cells as f64,
        )
    }
}

fn overlaps_xy(a: &Aabb, b: &Aabb) -> bool {
    a.min.x < b.max.x && a.max.x > b.min.x && a.min.y < b.max.y && a.max.y > b.min.y
}
