//! The micro level: an explicit rough surface in which photons reflect specularly.
//!
//! A [`MicroSurface`] is a rectangular period `[0, Lx] x [0, Ly]` of substrate
//! (the half-space `z <= 0`) with solid bodies on it (random bumps or explicit
//! CSG bodies). The visible surface is the upper boundary of the union of the
//! substrate and the bodies. Photons start on the launch plane `z = top` (the
//! highest point of the surface, plus a hair) and leave when they cross it
//! going up. What happens at the sides of the period is set by [`Edges`].
//!
//! Bodies whose bounds cross a side of a periodic surface are copied (ghosts)
//! shifted by whole periods, so every bump wraps. Bodies with unbounded extent
//! in x or y (for example planes making V-grooves) are tested for every
//! segment; all others are found through a uniform 2-D grid whose cells also
//! store the highest point of what they hold, so rays that pass above a grid
//! cell skip it. The cost per segment stays flat as the bump count grows at
//! constant density.
//!
//! Instead of the substrate and solids, a surface may be a periodic
//! [`heightfield::HeightField`] (a triangulated grid of heights): the
//! surface's [`Relief`] is one kind or the other. [`MicroSurface::next_event`]
//! walks whichever it is, [`Event::Hit`] names the [`Facet`] met (a surface
//! of a solid, or a triangle of the field), and [`MicroSurface::hit_normal`]
//! gives the normal for either kind, so the photon history has one loop.

pub mod bumps;
mod grid;
pub mod heightfield;
pub mod heightfield_io;
pub mod surface_stats;

use glam::{DVec2, DVec3};

use crate::geometry::body::{Aabb, Body, Ray};
use crate::optics::material::Reflectance;
use grid::Grid;
use heightfield::{FieldEvent, HeightField};

/// Most periodic sides one straight flight may cross (bump surfaces:
/// side events in a row between reflections; height fields: periods the walk
/// enters). A flight crossing more without meeting anything is cut and
/// reported as capped (`lost_cap` in `summary.json`): this bounds the work of
/// flights that travel far compared to the period, such as incidence within
/// about `height range / (MAX_CROSSINGS * period side)` radians of grazing, or
/// surfaces whose heights are many periods tall.
pub const MAX_CROSSINGS: u32 = 1 << 16;

/// What happens where a photon reaches a side of the period below the top
/// (`[surface] edges`; in result files the names in lower case).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Edges {
    /// The period tiles the plane: the photon re-enters on the opposite side.
    Periodic,
    /// Vertical walls up to the top absorb (the paper's perfect absorber).
    Absorbing,
    /// Vertical walls up to the top reflect specularly with the substrate material.
    Reflecting,
}

/// A solid of the micro geometry as placed in period coordinates.
#[derive(Clone, Debug)]
pub struct Solid {
    /// The body, already translated into the period (ghosts are separate solids).
    pub body: Body,
    /// Index of the scene body or bump this solid is a copy of (`None` for
    /// the substrate).
    pub source: Option<u32>,
    /// For bumps: the shape and parameters, which give exact heights over
    /// grid cells (tighter than the bounds).
    pub bump: Option<(bumps::Shape, bumps::Bump)>,
}

/// The relative pad (of a bump's height) around its exact heights over a
/// grid cell: above its highest point and below its lowest top, so that the
/// bounds stay clear of rounding in the body's own test.
const GRID_HEIGHT_PAD: f64 = 1e-9;

impl Solid {
    /// Highest point of the solid within horizontal distance `w` of the
    /// segment from `a` to `b` (an upper bound: exact for bumps, whose
    /// heights fall with the scaled distance from their centre, plus the
    /// same relative pad as [`Self::max_height_over`]; the bounds' top
    /// otherwise).
    /// `pad` is the relative pad above the exact profile (of the bump's height)
    /// that keeps the bound above rounding in the body's own test.
    fn max_height_near(&self, a: DVec2, b: DVec2, w: f64, pad: f64) -> f64 {
        match &self.bump {
            Some((shape, bump)) => {
                let r = DVec2::new(bump.radius, bump.radius_y);
                let (qa, qb) = ((a - bump.center) / r, (b - bump.center) / r);
                let e = qb - qa;
                let len2 = e.length_squared();
                let t = if len2 > 0.0 {
                    (-qa.dot(e) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let s = (qa + t * e).length() - w / r.min_element();
                shape.profile(bump, s.max(0.0)) + pad * bump.height
            }
            None => self.body.bounds.max.z,
        }
    }

    /// A height up to which the solid holds the whole column over the
    /// rectangle `[lo, hi]` from the substrate (a lower bound: a bump's
    /// lowest top there, less [`GRID_HEIGHT_PAD`];
    /// `-inf` for other solids, or where the rectangle is not all under the
    /// bump).
    fn covers_over(&self, lo: DVec2, hi: DVec2) -> f64 {
        match &self.bump {
            Some((shape, b)) => shape.min_height_over(b, lo, hi) - GRID_HEIGHT_PAD * b.height,
            None => f64::NEG_INFINITY,
        }
    }

    /// Highest point of the solid over the rectangle `[lo, hi]` (an upper
    /// bound: a bump's exact highest point there plus [`GRID_HEIGHT_PAD`]).
    fn max_height_over(&self, lo: DVec2, hi: DVec2) -> f64 {
        match &self.bump {
            Some((shape, b)) => {
                let z = shape.max_height_over(b, lo, hi);
                z + GRID_HEIGHT_PAD * b.height
            }
            None => self.body.bounds.max.z,
        }
    }
}

/// A piece of the surface a flight hits or stands on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Facet {
    /// Surface `surface` of solid `solid` of a [`Relief::Solids`] surface.
    Solid {
        /// Index into [`Solids::list`].
        solid: usize,
        /// Index into that solid's surfaces.
        surface: usize,
    },
    /// A triangle of a [`Relief::HeightField`] surface, by its id (see
    /// [`HeightField::normal`]).
    Triangle(usize),
}

/// The next thing a straight flight meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Meets `facet` at distance `t`, going into the material.
    Hit {
        /// Distance (units of `|d|`).
        t: f64,
        /// What it meets.
        facet: Facet,
    },
    /// Leaves through the launch plane at distance `t` (escapes).
    Top {
        /// Distance (units of `|d|`).
        t: f64,
    },
    /// Reaches side `axis` (0 = x, 1 = y) of the period below the top, at the
    /// upper end of the axis when `upper`.
    Side {
        /// Distance (units of `|d|`).
        t: f64,
        /// 0 for the x sides, 1 for the y sides.
        axis: usize,
        /// True at `x = Lx` (or `y = Ly`), false at 0.
        upper: bool,
    },
    /// Passes above everything for whole periods (a height field's walk
    /// skipped them, see [`HeightField`]): the flight goes on from `at`, in
    /// the period, with the same direction.
    Moved {
        /// The new start.
        at: DVec3,
    },
    /// The flight never ends in the period (horizontal and above everything); counted as lost.
    Trapped,
}

/// Tolerance of the period skips (bumps and height fields), relative to the
/// scene's scale: a hair, as the launch plane's margin above the highest point.
pub(crate) const SKIP_COARSE: f64 = 1e-9;

/// The skips' second tolerance, for a flight within [`SKIP_COARSE`] of what
/// it can meet: such a flight descends so slowly that it would cross the
/// period for ever (at one ulp below 90 degrees, 5e-15 a period: 6e6
/// periods through the launch plane's 3e-8). Still a hundred times the
/// rounding of a position (an ulp of the height) and ten times that of a
/// bump's test (about 1e-14 of its height).
pub(crate) const SKIP_FINE: f64 = 1e-13;

/// The most periods, doubling from one and fewer than `limit`, for which
/// `clear(k)` holds (0 if not even one): `clear` holds for fewer periods
/// whenever it holds for more (a band that grows with the periods).
pub(crate) fn doubling_periods(limit: f64, clear: impl Fn(f64) -> bool) -> f64 {
    let (mut k, mut next) = (0.0_f64, 1.0_f64);
    while next < limit && clear(next) {
        k = next;
        next *= 2.0;
    }
    k
}

/// What [`MicroSurface::skip_periods`] found for a flight on a periodic side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Skip {
    /// Nothing to skip: trace on.
    None,
    /// The flight meets nothing in the next `periods` whole periods along the
    /// crossed axis: continue from `at`, the same side that many periods on.
    To {
        /// The new start (on the same side of the period).
        at: DVec3,
        /// Whole periods skipped.
        periods: f64,
    },
    /// The flight rises above everything it can still pass over: it escapes.
    Escapes,
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
        let records = match &surface.relief {
            Relief::Solids(s) => s.grid.ids.len(),
            Relief::HeightField(_) => 0,
        };
        Self {
            stamp: vec![0; records],
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

/// What a micro surface is made of: one of two kinds.
#[derive(Clone, Debug)]
pub enum Relief {
    /// The substrate and solids (bumps, CSG bodies), found through a grid.
    Solids(Solids),
    /// A periodic height field, the whole surface (the edges are periodic).
    HeightField(HeightField),
}

/// The solids of a [`Relief::Solids`] surface and the acceleration grid over them.
#[derive(Clone, Debug)]
pub struct Solids {
    /// All solids in period coordinates; solid 0 is the substrate.
    pub list: Vec<Solid>,
    /// Solids tested for every flight (unbounded in x or y), the substrate first.
    global: Vec<usize>,
    grid: Grid,
}

/// An explicit rough surface: one period of it ([`Relief`]), its edges and materials.
#[derive(Clone, Debug)]
pub struct MicroSurface {
    /// Period size `(Lx, Ly)` (length units).
    pub size: DVec2,
    /// Side behaviour.
    pub edges: Edges,
    /// What the surface is made of.
    pub relief: Relief,
    /// Height of the launch plane and of the walls (length units).
    pub top: f64,
    /// Highest point of the surface (length units); `top` is a hair above it.
    pub max_height: f64,
    /// Materials referenced by the solids.
    pub materials: Vec<Reflectance>,
    /// Material of the substrate (or of the height field) and of reflecting walls.
    pub substrate_material: usize,
}

/// What the builder needs to know of a body placed on the substrate.
#[derive(Clone, Debug)]
pub struct Placed {
    /// The body in period coordinates.
    pub body: Body,
    /// Highest point of the body (length units).
    pub max_height: f64,
    /// Copy into neighbouring periods when it crosses a side (bumps do).
    pub wraps: bool,
    /// For bumps: shape and parameters (exact heights for the grid).
    pub bump: Option<(bumps::Shape, bumps::Bump)>,
}

/// Bytes one grid item costs while [`Grid::build`] runs: its slot in the
/// flat array of the cells' lists (12) and its entry in the final `items`
/// and `exact` (16), rounded up.
const GRID_ITEM_BYTES: u64 = 32;

/// Estimated peak memory (bytes) and solid count that one body adds to a
/// surface built by [`MicroSurface::new`] over a period of `size` with `edges`:
/// the body in the input list, each of its solids (periodic ghost copies
/// included: one per whole-period shift whose copy reaches into the period,
/// on average `(1 + w / Lx) (1 + h / Ly)` for a footprint `w x h` placed at
/// random) with its heap, its mailbox stamp per worker thread, and its
/// entries in the acceleration grid (one per grid cell its bounds cover,
/// the grid pitch being a fifth of the body's footprint side as
/// `Grid::build` takes it from the median, at most 2048 cells a side).
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
    /// `bodies` are in period coordinates. The substrate (solid 0) is added here
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
            source: None,
            bump: None,
        }];
        let mut max_height: f64 = 0.0;
        let period = Aabb {
            min: DVec3::new(0.0, 0.0, f64::NEG_INFINITY),
            max: DVec3::new(size.x, size.y, f64::INFINITY),
        };
        // Every whole-period shift whose copy of a bounded, wrapping body
        // reaches into the period.
        let shifts = |b: Aabb| {
            let kx = ((b.max.x - b.min.x) / size.x + 1.0).ceil() as i64;
            let ky = ((b.max.y - b.min.y) / size.y + 1.0).ceil() as i64;
            (-ky..=ky)
                .flat_map(move |jy| {
                    (-kx..=kx)
                        .map(move |jx| DVec3::new(jx as f64 * size.x, jy as f64 * size.y, 0.0))
                })
                .filter(move |&shift| overlaps_xy(&b.translated(shift), &period))
        };
        let bounded = |b: &Aabb| {
            b.min.x.is_finite() && b.max.x.is_finite() && b.min.y.is_finite() && b.max.y.is_finite()
        };
        let copied = |p: &Placed| edges == Edges::Periodic && p.wraps && bounded(&p.body.bounds);
        // The solids counted first: a list grown by doubling would hold two
        // copies of itself at its peak (of the order of 100 MB for 10^5 bumps).
        let count = bodies
            .iter()
            .map(|p| {
                if copied(p) {
                    shifts(p.body.bounds).count()
                } else {
                    1
                }
            })
            .sum::<usize>();
        solids.reserve_exact(count);
        for (source, placed) in bodies.into_iter().enumerate() {
            // Bodies are far fewer than 2^32 (each costs memory).
            let source = Some(source as u32);
            max_height = max_height.max(placed.max_height);
            let b = placed.body.bounds;
            if copied(&placed) {
                for shift in shifts(b) {
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
            } else if !bounded(&b) || overlaps_xy(&b, &period) {
                solids.push(Solid {
                    body: placed.body,
                    source,
                    bump: placed.bump,
                });
            }
        }
        let (global, gridded): (Vec<usize>, Vec<usize>) =
            (0..solids.len()).partition(|&i| !bounded(&solids[i].body.bounds));
        let grid = Grid::build(size, &solids, &gridded);
        // The launch plane sits a hair above the highest point so that no
        // photon starts on or inside a body (relative to the scene's scale).
        let scale = size.max_element().max(max_height.abs());
        let top = max_height + 1e-9 * scale;
        Self {
            size,
            edges,
            relief: Relief::Solids(Solids {
                list: solids,
                global,
                grid,
            }),
            top,
            max_height,
            materials,
            substrate_material,
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
            relief: Relief::HeightField(field),
            top: max_height + 1e-9 * scale,
            max_height,
            materials,
            substrate_material: material,
        }
    }

    /// The height field, if the surface is one.
    #[must_use]
    pub fn heightfield(&self) -> Option<&HeightField> {
        match &self.relief {
            Relief::HeightField(f) => Some(f),
            Relief::Solids(_) => None,
        }
    }

    /// The solids (substrate first), or none for a height field.
    #[must_use]
    pub fn solids(&self) -> &[Solid] {
        match &self.relief {
            Relief::Solids(s) => &s.list,
            Relief::HeightField(_) => &[],
        }
    }

    /// The unit normal facing the flight (`n . d <= 0`) and the material
    /// where a flight along `d` ended in `Event::Hit { facet, .. }` at `p`.
    /// A height-field hit may lie in a neighbouring period: `p` is then
    /// moved back into the period by whole periods. `None` where the normal
    /// is undefined (a cone apex), or for a facet of the other kind.
    #[must_use]
    #[inline]
    pub fn hit_normal(&self, p: &mut DVec3, d: DVec3, facet: Facet) -> Option<(DVec3, usize)> {
        match (facet, &self.relief) {
            (Facet::Triangle(triangle), Relief::HeightField(field)) => {
                *p = field.fold(*p);
                // Hits are only taken while the flight descends onto the triangle.
                Some((field.normal(triangle), self.substrate_material))
            }
            (Facet::Solid { solid, surface }, Relief::Solids(s)) => {
                if let Some(r) = s.grid.compact(solid, surface) {
                    // From the record the test just read (no reach into the solid).
                    let n = s.grid.records[r].facing_normal(*p, d)?;
                    return Some((n, s.grid.ids[r].material as usize));
                }
                let body = &s.list[solid].body;
                let n = body.surfaces[surface].facing_normal(*p, d)?;
                Some((n, body.material))
            }
            _ => None,
        }
    }

    /// The next event of the flight from `o` along unit `d`, which starts inside
    /// the period. `standing`: the facet the flight starts on.
    #[must_use]
    pub fn next_event(
        &self,
        o: DVec3,
        d: DVec3,
        standing: Option<Facet>,
        scratch: &mut Scratch,
    ) -> Event {
        let s = match &self.relief {
            Relief::HeightField(field) => {
                return self.next_field_event(field, o, d, standing, &mut scratch.tests);
            }
            Relief::Solids(s) => s,
        };
        let ray = Ray::new(o, d);
        let (exit, t_exit) = self.period_exit(&ray);
        let mut near = Nearest {
            t: t_exit,
            hit: None,
            tests: 0,
        };
        s.global_entry(&ray, standing, &mut near);
        let q = scratch.next_query();
        s.walk_grid(&ray, standing, &mut scratch.stamp[..], q, &mut near);
        scratch.tests += near.tests;
        match near.hit {
            None => exit,
            Some((solid, surface)) => Event::Hit {
                t: near.t,
                facet: Facet::Solid { solid, surface },
            },
        }
    }

    /// The next events of four flights at once: lane `k` (where `live[k]`)
    /// gets [`Self::next_event`]`(o[k], d[k], standing[k], scratch)` bit for
    /// bit, and the intersection tests it took are added to `tests[k]` (and
    /// to `scratch.tests`); other lanes get [`Event::Trapped`].
    ///
    /// On a bump surface whose only unbounded solid is the substrate, the
    /// start of the search is computed four lanes at a time
    /// (`wide::f64x4`, masks and blends instead of branches): the
    /// reciprocal direction, the period's exit (top or side) and the
    /// substrate plane, the same operations on each lane as the scalar
    /// search; then each lane walks the grid on its own (its cells, item
    /// lists and quadric records are data-dependent). A lane whose exit
    /// distance is not positive (a flight starting on a side, where the
    /// scalar search clamps it to 0) and other surfaces are searched one
    /// lane at a time.
    pub fn next_events4(
        &self,
        o: [DVec3; 4],
        d: [DVec3; 4],
        standing: [Option<Facet>; 4],
        live: [bool; 4],
        scratch: &mut Scratch,
        tests: &mut [u64; 4],
    ) -> [Event; 4] {
        use wide::{CmpGe, CmpGt, CmpLe, CmpLt, f64x4};
        let mut events = [Event::Trapped; 4];
        let one_by_one =
            |events: &mut [Event; 4], scratch: &mut Scratch, tests: &mut [u64; 4], k: usize| {
                let before = scratch.tests;
                events[k] = self.next_event(o[k], d[k], standing[k], scratch);
                tests[k] += scratch.tests - before;
            };
        let s = match &self.relief {
            Relief::Solids(s) if s.global == [0] => s,
            _ => {
                for k in (0..4).filter(|&k| live[k]) {
                    one_by_one(&mut events, scratch, tests, k);
                }
                return events;
            }
        };
        let col = |v: &[DVec3; 4], i: usize| f64x4::new([v[0][i], v[1][i], v[2][i], v[3][i]]);
        let (ox, oy, oz) = (col(&o, 0), col(&o, 1), col(&o, 2));
        let (dx, dy, dz) = (col(&d, 0), col(&d, 1), col(&d, 2));
        let (zero, neg) = (f64x4::ZERO, f64x4::splat(-1.0));
        // Ray::new: 1 / d.
        let (ix, iy, iz) = (f64x4::ONE / dx, f64x4::ONE / dy, f64x4::ONE / dz);
        // period_exit: the top (rising flights), then each side crossed,
        // the nearer replacing; kind 0 trapped, 1 top, 2 + 2 axis + upper
        // a side. `-x` is `x * -1` (exact, the sign of zero included).
        let rises = dz.cmp_gt(zero);
        let t_top = (f64x4::splat(self.top) - oz) * iz;
        let mut t_best = rises.blend(t_top, f64x4::splat(f64::INFINITY));
        let mut kind = rises.blend(f64x4::ONE, zero);
        // Lanes where a distance is not positive (or NaN): `max(0.0)` decides there.
        let mut odd = rises & !t_top.cmp_gt(zero);
        for (axis, (ok, dk, ik)) in [(ox, dx, ix), (oy, dy, iy)].into_iter().enumerate() {
            let (up, down) = (dk.cmp_gt(zero), dk.cmp_lt(zero));
            let t = up.blend((f64x4::splat(self.size[axis]) - ok) * ik, (ok * neg) * ik);
            let crossed = up | down;
            odd |= crossed & !t.cmp_gt(zero);
            let nearer = crossed & t.cmp_lt(t_best);
            t_best = nearer.blend(t, t_best);
            let side = f64x4::splat(2.0 + 2.0 * axis as f64);
            kind = nearer.blend(up.blend(side + f64x4::ONE, side), kind);
        }
        // global_entry's substrate (z = 0, entered going down).
        let on_substrate = f64x4::new(std::array::from_fn(|k| {
            if standing[k]
                == Some(Facet::Solid {
                    solid: 0,
                    surface: 0,
                })
            {
                f64::from_bits(u64::MAX)
            } else {
                0.0
            }
        }));
        let counted = !(dz.cmp_ge(zero) & oz.cmp_gt(zero));
        let b = f64x4::splat(0.5) * dz;
        let t_sub = (oz * neg) / (f64x4::splat(2.0) * b);
        let hit_sub =
            counted & b.cmp_lt(zero) & !on_substrate & t_sub.cmp_gt(zero) & t_sub.cmp_le(t_best);
        let near_t = hit_sub.blend(t_sub, t_best).to_array();
        let (ix, iy, iz) = (ix.to_array(), iy.to_array(), iz.to_array());
        let (t_best, kind) = (t_best.to_array(), kind.to_array());
        let (counted, hit_sub, odd) = (counted.move_mask(), hit_sub.move_mask(), odd.move_mask());
        for k in (0..4).filter(|&k| live[k]) {
            if odd & (1 << k) != 0 {
                one_by_one(&mut events, scratch, tests, k);
                continue;
            }
            let ray = Ray {
                o: o[k],
                d: d[k],
                inv_d: DVec3::new(ix[k], iy[k], iz[k]),
            };
            let exit = match kind[k] as usize {
                0 => Event::Trapped,
                1 => Event::Top { t: t_best[k] },
                c => Event::Side {
                    t: t_best[k],
                    axis: (c - 2) / 2,
                    upper: c % 2 == 1,
                },
            };
            let mut near = Nearest {
                t: near_t[k],
                hit: (hit_sub & (1 << k) != 0).then_some((0, 0)),
                tests: u64::from(counted & (1 << k) != 0),
            };
            let q = scratch.next_query();
            s.walk_grid(&ray, standing[k], &mut scratch.stamp[..], q, &mut near);
            scratch.tests += near.tests;
            tests[k] += near.tests;
            events[k] = match near.hit {
                None => exit,
                Some((solid, surface)) => Event::Hit {
                    t: near.t,
                    facet: Facet::Solid { solid, surface },
                },
            };
        }
        events
    }

    /// Where a flight starting inside the period leaves the period's box:
    /// the top or a side ([`Event::Trapped`] at infinity for a flight
    /// along the plane that leaves by neither), and the distance.
    #[inline]
    fn period_exit(&self, ray: &Ray) -> (Event, f64) {
        let (o, d, inv) = (ray.o, ray.d, ray.inv_d);
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
        (exit, t_best)
    }
}

/// The nearest entry into a solid a flight has found so far.
struct Nearest {
    /// Its distance, or that of the period's exit while `hit` is `None`.
    t: f64,
    /// (solid, surface) entered.
    hit: Option<(usize, usize)>,
    /// Intersection tests made (see [`Scratch::tests`]).
    tests: u64,
}

impl Solids {
    /// Test the solids every flight meets (the global ones, unbounded in
    /// x or y), the substrate first, for an entry nearer than `near`.
    #[inline]
    fn global_entry(&self, ray: &Ray, standing: Option<Facet>, near: &mut Nearest) {
        let (o, d) = (ray.o, ray.d);
        // The substrate (solid 0, always the first global solid) inline: the
        // arithmetic of its body's test of the plane z = 0 (`a = 0`,
        // `b = d.z / 2`, `c = o.z`, entered going down), which a rising
        // flight above it skips, and a flight standing on it never meets.
        if !(d.z >= 0.0 && o.z > 0.0) {
            near.tests += 1;
            let b = 0.5 * d.z;
            if b < 0.0
                && standing
                    != Some(Facet::Solid {
                        solid: 0,
                        surface: 0,
                    })
            {
                let t = -o.z / (2.0 * b);
                if t > 0.0 && t <= near.t {
                    near.t = t;
                    near.hit = Some((0, 0));
                }
            }
        }
        for &i in &self.global[1..] {
            // A rising flight above a solid's top cannot enter it.
            if d.z >= 0.0 && o.z > self.list[i].body.bounds.max.z {
                continue;
            }
            if let Some(e) = self.body_entry(i, ray, near.t, standing, &mut near.tests) {
                near.t = e.t;
                near.hit = Some((i, e.surface));
            }
        }
    }

    /// Walk the grid cells under the flight (Amanatides & Woo), nearest
    /// first, testing the solids listed in each that reach down to the
    /// flight there, until the nearest entry is within the cell walked.
    /// `stamp` and `q`: records already tested by this query are skipped.
    /// Inlined into both callers ([`MicroSurface::next_event`] and
    /// [`MicroSurface::next_events4`]): out of line it cost about 30
    /// instructions a segment in calls and spills.
    #[inline(always)]
    fn walk_grid(
        &self,
        ray: &Ray,
        standing: Option<Facet>,
        stamp: &mut [u32],
        q: u32,
        near: &mut Nearest,
    ) {
        let (o, d) = (ray.o, ray.d);
        let g = &self.grid;
        // The record the flight stands on (a compact one, on its surface), if any.
        let standing_rec = match standing {
            Some(Facet::Solid { solid, surface }) => g.compact(solid, surface),
            _ => None,
        }
        .unwrap_or(usize::MAX);
        let mut walk = GridWalk::start(g, ray);
        let n_records = g.records.len();
        let rising = d.z >= 0.0;
        let mut t_enter = 0.0_f64;
        while t_enter <= near.t {
            let t_leave = min_of(walk.t_next[0], walk.t_next[1]);
            let gc = g.cells[walk.at[1] * g.n[0] + walk.at[0]];
            // Lowest point of the flight within this grid cell.
            let z_low = if rising {
                o.z + t_enter * d.z
            } else {
                o.z + min_of(t_leave, near.t) * d.z
            };
            if z_low <= gc.zmax {
                // An item's f32 height `z_up` (rounded up) is below z_low
                // when below `low`, the least f32 at or above z_low, and
                // above it when above; only at `low` the exact height decides.
                let low = grid::f32_up(z_low);
                let (lo, hi) = (gc.start as usize, gc.end as usize);
                for (it, &exact) in g.items[lo..hi].iter().zip(&g.exact[lo..hi]) {
                    if it.z_up < low || (it.z_up == low && exact < z_low) {
                        break;
                    }
                    let r = it.rec as usize;
                    if stamp[r] == q {
                        continue;
                    }
                    stamp[r] = q;
                    if r < n_records {
                        near.tests += 1;
                        if let Some((t, ill)) = g.records[r].entry(o, d, near.t, r == standing_rec)
                        {
                            let id = g.ids[r];
                            let (solid, surface) = (id.solid as usize, id.surface as usize);
                            // Polish the distance where it is used (see Quadric::refine_root).
                            near.t = if ill {
                                self.refine(solid, surface, o, d, t)
                            } else {
                                t
                            };
                            near.hit = Some((solid, surface));
                        }
                    } else {
                        let solid = g.ids[r].solid as usize;
                        if let Some(e) =
                            self.body_entry(solid, ray, near.t, standing, &mut near.tests)
                        {
                            near.t = e.t;
                            near.hit = Some((solid, e.surface));
                        }
                    }
                }
            }
            if near.t <= t_leave {
                break;
            }
            match walk.step(g) {
                Some(t) => t_enter = t,
                None => break,
            }
        }
    }
}

/// The distances compared in the grid walk are never NaN (finite start and
/// direction), so a plain select makes the comparisons of `f64::min`.
#[inline]
fn min_of(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

/// The state of a walk through the grid's cells along a flight
/// (Amanatides & Woo): the cell it is in and where it crosses the next
/// cell boundary in x and in y.
struct GridWalk {
    /// The cell (x, y).
    at: [usize; 2],
    /// Distance to the next boundary crossed in x and in y.
    t_next: [f64; 2],
    /// Distance between boundaries in x and in y.
    t_delta: [f64; 2],
    /// The step in cells at each crossing (+1, -1, or 0: never crossed).
    step: [isize; 2],
}

impl GridWalk {
    /// The walk of `ray`, which starts inside the period, through grid `g`.
    #[inline]
    fn start(g: &grid::Grid, ray: &Ray) -> Self {
        let (o, d, inv) = (ray.o, ray.d, ray.inv_d);
        let mut walk = Self {
            at: [0; 2],
            t_next: [f64::INFINITY; 2],
            t_delta: [f64::INFINITY; 2],
            step: [0; 2],
        };
        for k in 0..2 {
            // o is inside the period, so truncation is the floor (and `as`
            // saturates; grids have at most 2048 cells a side).
            let c = ((o[k] * g.inv_pitch[k]) as u32 as usize).min(g.n[k] - 1);
            walk.at[k] = c;
            // Without data-dependent branches (the sign of d mispredicted
            // half a branch a segment): for d > 0 the boundary above
            // (c + 1) and +pitch, for d < 0 the one below and -pitch (the
            // sign bit flipped: the same operations as either branch did);
            // never crossed for d = 0 (rare: flights along an axis).
            let (up, down) = (d[k] > 0.0, d[k] < 0.0);
            walk.step[k] = isize::from(up) - isize::from(down);
            walk.t_next[k] = ((c + usize::from(up)) as f64 * g.pitch[k] - o[k]) * inv[k];
            let pitch = f64::from_bits(g.pitch[k].to_bits() ^ (u64::from(down) << 63));
            walk.t_delta[k] = pitch * inv[k];
            if !(up | down) {
                walk.t_next[k] = f64::INFINITY;
                walk.t_delta[k] = f64::INFINITY;
            }
        }
        walk
    }

    /// Cross into the next cell: the distance where it is entered, or
    /// `None` when the flight leaves the grid.
    #[inline]
    fn step(&mut self, g: &grid::Grid) -> Option<f64> {
        let k = usize::from(self.t_next[1] < self.t_next[0]);
        let c = self.at[k].wrapping_add_signed(self.step[k]);
        if c >= g.n[k] {
            return None;
        }
        self.at[k] = c;
        let t_enter = self.t_next[k];
        self.t_next[k] += self.t_delta[k];
        Some(t_enter)
    }
}

impl Solids {
    /// Where `ray` first enters solid `i` within `t_max` through its body
    /// (solids without a compact record), counting its quadric tests; kept
    /// out of line so the grid walk keeps its registers.
    #[inline(never)]
    fn body_entry(
        &self,
        i: usize,
        ray: &Ray,
        t_max: f64,
        standing: Option<Facet>,
        tests: &mut u64,
    ) -> Option<crate::geometry::body::Entry> {
        let on = match standing {
            Some(Facet::Solid { solid, surface }) if solid == i => Some(surface),
            _ => None,
        };
        self.list[i]
            .body
            .first_entry_counting(ray, t_max, on, tests)
    }

    /// The distance `t` to surface `surface` of solid `solid` polished (see
    /// [`crate::geometry::quadric::Quadric::refine_root`]); rare, so out of line.
    #[cold]
    #[inline(never)]
    fn refine(&self, solid: usize, surface: usize, o: DVec3, d: DVec3, t: f64) -> f64 {
        self.list[solid].body.surfaces[surface].refine_root(o, d, t)
    }
}

impl MicroSurface {
    /// Whole periods a flight along unit `d`, at `p` on a side `x = 0 / Lx`
    /// (`axis = 0`) or `y = 0 / Ly` (`axis = 1`) of a periodic bump surface,
    /// can skip exactly: those in which it passes above every solid it can
    /// meet. Flights nearly along a lattice direction of the period (along an
    /// axis, or a diagonal of a square period) at grazing incidence otherwise
    /// cross about `1 / cos(theta)` periods, passing over the same folded
    /// path again and again, a little lower each time.
    ///
    /// Over one period along `axis` the flight's path, folded into the period,
    /// is a few segments; each further period shifts them by the drift of
    /// its other coordinate modulo that period. Over `k` periods the paths
    /// lie within `k |drift| + margin` of the first period's segments, and
    /// each solid's highest point that close to them bounds what the flight
    /// can meet (exact profiles for bumps, the bounds' top otherwise, and
    /// the substrate's `z = 0`). While the flight's lowest point in a period
    /// (its far end, descending) stays above that, the period is skipped:
    /// the position moves by whole periods and nothing that could be met is
    /// passed. A rising flight above everything it passes over before the
    /// launch plane escapes. Applies to bump surfaces whose only unbounded
    /// solid is the substrate, and to paths that drift less than a grid
    /// pitch in 16 periods (otherwise [`Skip::None`]).
    #[must_use]
    pub fn skip_periods(&self, p: DVec3, d: DVec3, axis: usize) -> Skip {
        let Relief::Solids(solids) = &self.relief else {
            return Skip::None;
        };
        if self.edges != Edges::Periodic || solids.global != [0] {
            return Skip::None;
        }
        let b = 1 - axis;
        let (da, len_a, len_b) = (d[axis], self.size[axis], self.size[b]);
        if da == 0.0 || d.z == 0.0 {
            return Skip::None;
        }
        let dt = len_a / da.abs();
        let (drift, dz) = (dt * d[b], dt * d.z);
        if drift.is_nan() || drift.abs() > 4.0 * len_b {
            return Skip::None;
        }
        let drift_mod = drift - (drift / len_b).round() * len_b;
        if drift_mod.is_nan() || 16.0 * drift_mod.abs() > solids.grid.pitch[b] {
            return Skip::None;
        }
        // What the tolerances (rounding of positions and of the solids'
        // heights) are relative to.
        let scale = self.size.max_element().max(self.max_height.abs());
        // The first period's path, folded into the period: pieces between the
        // crossings of the other axis' sides.
        let point = |sigma: f64| {
            let mut q = DVec2::ZERO;
            q[axis] = if da > 0.0 { sigma } else { len_a - sigma };
            q[b] = p[b] + sigma / len_a * drift;
            q
        };
        let mut cuts = vec![0.0, len_a];
        let (m0, m1) = ((p[b] / len_b).floor(), ((p[b] + drift) / len_b).floor());
        let mut m = m0.min(m1);
        while m <= m0.max(m1) + 1.0 {
            let sigma = (m * len_b - p[b]) / drift * len_a;
            if sigma > 0.0 && sigma < len_a {
                cuts.push(sigma);
            }
            m += 1.0;
        }
        cuts.sort_by(f64::total_cmp);
        let pieces: Vec<(DVec2, DVec2)> = cuts
            .windows(2)
            .map(|c| {
                let (mut a0, mut a1) = (point(c[0]), point(c[1]));
                let fold = (0.5 * (a0[b] + a1[b]) / len_b).floor() * len_b;
                a0[b] -= fold;
                a1[b] -= fold;
                (a0, a1)
            })
            .collect();
        // The highest solid within `w` of the pieces (and of their copies
        // one period away across the other axis' sides), padded by `rel`.
        let highest_near = |w: f64, rel: f64| -> f64 {
            let mut top = 0.0_f64;
            for solid in &solids.list[1..] {
                for &(a0, a1) in &pieces {
                    for shift in [-len_b, 0.0, len_b] {
                        let mut s = DVec2::ZERO;
                        s[b] = shift;
                        top = top.max(solid.max_height_near(a0 + s, a1 + s, w, rel));
                    }
                }
            }
            top
        };
        // The start `k` periods on, on the same side of the period.
        let moved = |k: f64| {
            let mut at = p;
            at[b] += k * drift;
            at[b] -= (at[b] / len_b).floor() * len_b;
            at.z += k * dz;
            Skip::To { at, periods: k }
        };
        if dz < 0.0 {
            // Whole periods to skip with tolerance `rel`, if at least one.
            let descend = |rel: f64| -> Option<f64> {
                let margin = rel * scale;
                // The lowest point of period n (0-based) is at its far end: p.z + (n + 1) dz.
                let k1 = ((p.z - highest_near(margin, rel) - margin) / -dz).floor() - 1.0;
                if k1.is_nan() || k1 < 1.0 {
                    return None;
                }
                // Every band of fewer periods lies within the band of k1.
                let m = highest_near((k1 * drift_mod).abs() + margin, rel);
                let k = k1.min(((p.z - m - margin) / -dz).floor() - 1.0);
                (k >= 1.0).then_some(k)
            };
            match descend(SKIP_COARSE).or_else(|| descend(SKIP_FINE)) {
                Some(k) => moved(k),
                None => Skip::None,
            }
        } else {
            // Rising: above everything it passes over until the launch plane?
            let k_top = ((self.top - p.z) / dz).ceil().max(1.0);
            // Above everything within `band + margin` of the path from its
            // start (a rising flight's lowest point in each period)?
            let above = |band: f64, rel: f64| {
                let margin = rel * scale;
                p.z > highest_near(band + margin, rel) + margin
            };
            let band = |k: f64| (k * drift_mod).abs();
            if above(band(k_top), SKIP_COARSE) || above(band(k_top), SKIP_FINE) {
                return Skip::Escapes;
            }
            // Not above all it may pass before the launch plane, e.g. just
            // off the top of the bump it left, drifting over it: skip the
            // most periods, doubling from one, above everything within
            // their band (the band grows with the periods, the flight's
            // lowest point is where it starts).
            let k = doubling_periods(k_top, |k| above(band(k), SKIP_FINE));
            if k >= 1.0 { moved(k) } else { Skip::None }
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
        standing: Option<Facet>,
        tests: &mut u64,
    ) -> Event {
        let standing = match standing {
            Some(Facet::Triangle(triangle)) => Some(triangle),
            _ => None,
        };
        match field.first_hit_counting(o, d, standing, tests) {
            FieldEvent::Hit { t, triangle } => Event::Hit {
                t,
                facet: Facet::Triangle(triangle),
            },
            FieldEvent::Escapes => Event::Top {
                t: ((self.top - o.z) / d.z).max(0.0),
            },
            FieldEvent::Moved { at } => Event::Moved { at },
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
        let periodic = self.heightfield().is_some() || self.edges == Edges::Periodic;
        surface_stats::memory_bytes(nx, ny, periodic)
    }

    /// The height map on an `nx x ny` grid of pixel centres over the period.
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
            .heightfield()
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
        let Relief::Solids(s) = &self.relief else {
            return (0, 0.0);
        };
        let cells = s.grid.n[0] * s.grid.n[1];
        (s.global.len(), s.grid.items.len() as f64 / cells as f64)
    }
}

fn overlaps_xy(a: &Aabb, b: &Aabb) -> bool {
    a.min.x < b.max.x && a.max.x > b.min.x && a.min.y < b.max.y && a.max.y > b.min.y
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white() -> Vec<Reflectance> {
        vec![Reflectance::Constant(1.0)]
    }

    /// `next_events4` gives each live lane `next_event`'s event (printed
    /// with `{:?}`, so `-0.0` and `0.0` differ) and tests, on the default
    /// scene: random flights from inside the period, from its sides and
    /// corners (exit distance 0: the lane is searched alone), along the
    /// axes and level, standing on the substrate or not, with lanes off.
    #[test]
    fn four_lanes_search_as_one() {
        let file = crate::scene::SceneFile {
            file: "t.toml".into(),
            dir: ".".into(),
        };
        let scene = crate::scene::micro::MicroScene::from_str(
            crate::scene::micro::DEFAULT_SCENE,
            file,
            "t".into(),
        )
        .unwrap();
        let s = &scene.surface;
        let mut x = 0x853c_49e6_748f_ea9b_u64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1_u64 << 53) as f64
        };
        let substrate = Facet::Solid {
            solid: 0,
            surface: 0,
        };
        let (mut one, mut four) = (Scratch::new(s), Scratch::new(s));
        let mut kinds = std::collections::BTreeSet::new();
        for round in 0..20_000 {
            let mut o = [DVec3::ZERO; 4];
            let mut d = [DVec3::ZERO; 4];
            let mut standing = [None; 4];
            let mut live = [false; 4];
            for k in 0..4 {
                let mut p = DVec3::new(next() * s.size.x, next() * s.size.y, next() * s.top);
                match (round + k) % 7 {
                    0 => p.x = 0.0,
                    1 => p.y = s.size.y,
                    2 => (p.x, p.y) = (s.size.x, 0.0),
                    // On the substrate, or a rounding above it (where only
                    // the flight's standing keeps it from the plane).
                    3 => p.z = [0.0, 1e-13][k % 2],
                    _ => {}
                }
                let mut dir = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                match (round / 7 + k) % 9 {
                    0 => dir.x = 0.0,
                    1 => dir.y = 0.0,
                    2 => dir.z = 0.0,
                    3 => dir = DVec3::NEG_Z,
                    _ => {}
                }
                o[k] = p;
                d[k] = dir.normalize();
                standing[k] = (p.z < 1e-9).then_some(substrate);
                live[k] = (round + 3 * k) % 5 != 0;
            }
            let mut tests = [0_u64; 4];
            let got = s.next_events4(o, d, standing, live, &mut four, &mut tests);
            for k in 0..4 {
                if !live[k] {
                    assert_eq!(got[k], Event::Trapped);
                    assert_eq!(tests[k], 0);
                    continue;
                }
                let before = one.tests;
                let want = s.next_event(o[k], d[k], standing[k], &mut one);
                assert_eq!(
                    format!("{:?}", got[k]),
                    format!("{want:?}"),
                    "{o:?} {d:?} {k}"
                );
                assert_eq!(tests[k], one.tests - before);
                kinds.insert(
                    format!("{want:?}")
                        .split([' ', '{'])
                        .next()
                        .unwrap()
                        .to_owned(),
                );
            }
        }
        for kind in ["Hit", "Top", "Side"] {
            assert!(kinds.contains(kind), "{kinds:?}");
        }
    }

    #[test]
    fn a_bare_substrate_is_met_straight_below() {
        let s = MicroSurface::new(
            DVec2::new(2.0, 3.0),
            Edges::Periodic,
            Vec::new(),
            white(),
            0,
        );
        assert!(s.heightfield().is_none());
        assert_eq!(s.solids().len(), 1);
        assert_eq!(s.solids()[0].source, None);
        let substrate = Facet::Solid {
            solid: 0,
            surface: 0,
        };
        let mut scratch = Scratch::new(&s);
        let e = s.next_event(DVec3::new(0.5, 0.5, 1.0), DVec3::NEG_Z, None, &mut scratch);
        assert_eq!(
            e,
            Event::Hit {
                t: 1.0,
                facet: substrate
            }
        );
        let mut p = DVec3::new(0.5, 0.5, 0.0);
        assert_eq!(
            s.hit_normal(&mut p, DVec3::NEG_Z, substrate),
            Some((DVec3::Z, 0))
        );
        // A facet of the other kind names nothing on this surface.
        assert_eq!(s.hit_normal(&mut p, DVec3::NEG_Z, Facet::Triangle(0)), None);
        // Standing on the substrate, a flight going up escapes through the top.
        let up = DVec3::new(0.0, 0.0, 1.0);
        assert!(matches!(
            s.next_event(p, up, Some(substrate), &mut scratch),
            Event::Top { .. }
        ));
    }

    /// The nearest entry into any solid, by testing every one of them
    /// (the grid's independent reference).
    fn nearest_by_scan(
        s: &MicroSurface,
        o: DVec3,
        d: DVec3,
        standing: Option<Facet>,
    ) -> Option<(f64, Facet)> {
        let ray = Ray::new(o, d);
        let mut best: Option<(f64, Facet)> = None;
        for (i, solid) in s.solids().iter().enumerate() {
            let on = match standing {
                Some(Facet::Solid { solid, surface }) if solid == i => Some(surface),
                _ => None,
            };
            let t_max = best.map_or(f64::INFINITY, |b| b.0);
            if let Some(e) = solid.body.first_entry(&ray, t_max, on) {
                let facet = Facet::Solid {
                    solid: i,
                    surface: e.surface,
                };
                best = Some((e.t, facet));
            }
        }
        best
    }

    /// Bumps wider than the period, of every shape: hundreds of copies over
    /// every grid cell, most of them buried under others and left out of
    /// the grid. Flights from the launch plane and from the points they hit
    /// meet exactly what a scan over every solid meets.
    #[test]
    fn buried_solids_left_out_of_the_grid_change_no_event() {
        use bumps::{Bump, Shape};
        let mut u = crate::test_streams::uniform(11);
        let shapes = Shape::ALL;
        let placed = (0..40)
            .map(|k| {
                let b = Bump {
                    center: DVec2::new(30.0 * u(), 30.0 * u()),
                    radius: 20.0 + 25.0 * u(),
                    radius_y: 20.0 + 25.0 * u(),
                    height: 0.5 + 4.0 * u(),
                    depth: u(),
                    cap: 0.2 + 0.8 * u(),
                    base: 1.2 + u(),
                };
                shapes[k % shapes.len()].body(&b, 0)
            })
            .collect();
        let s = MicroSurface::new(DVec2::new(30.0, 30.0), Edges::Periodic, placed, white(), 0);
        let (_, per_cell) = s.acceleration_stats();
        // Each of the 40 bumps reaches over every grid cell in some copy.
        assert!(per_cell < 40.0, "{per_cell} listed per grid cell");
        assert!(s.solids().len() > 400, "{} solids", s.solids().len());
        let (hits, exits) = events_against_scan(&s, &mut u, 3000, None);
        assert!(hits > 2000 && exits > 2000, "{hits} hits, {exits} exits");
    }

    /// Every grid cell lists its solids tallest first over it, ties in the
    /// solids' order, however the grid was filled: posts of one height tie
    /// over every grid cell two of them reach, and the Morton order the
    /// grid is filled in differs from the solids' order.
    #[test]
    fn grid_cells_list_tallest_first_ties_in_solid_order() {
        use bumps::{Bump, Shape};
        let mut u = crate::test_streams::uniform(17);
        let placed = (0..60)
            .map(|_| {
                let r = 2.0 + 2.0 * u();
                let b = Bump {
                    center: DVec2::new(30.0 * u(), 30.0 * u()),
                    radius: r,
                    radius_y: r,
                    height: 2.0,
                    depth: 0.0,
                    cap: 0.5,
                    base: 1.5,
                };
                Shape::Cylinder.body(&b, 0)
            })
            .collect();
        let s = MicroSurface::new(DVec2::new(30.0, 30.0), Edges::Periodic, placed, white(), 0);
        let Relief::Solids(solids) = &s.relief else {
            panic!("bumps make solids")
        };
        let g = &solids.grid;
        let solid = |k: usize| g.ids[g.items[k].rec as usize].solid;
        let (mut ties, mut out_of_index_order) = (0, 0);
        for cell in &g.cells {
            for k in cell.start as usize + 1..cell.end as usize {
                assert!(g.exact[k - 1] >= g.exact[k], "not tallest first");
                if g.exact[k - 1] == g.exact[k] {
                    ties += 1;
                    assert!(solid(k - 1) < solid(k), "a tie out of the solids' order");
                }
            }
        }
        // The records (the grid's fill order) are not in the solids' order.
        for r in 1..g.ids.len() {
            if g.ids[r - 1].solid > g.ids[r].solid {
                out_of_index_order += 1;
            }
        }
        assert!(ties > 100, "{ties} ties");
        assert!(out_of_index_order > 10, "{out_of_index_order}");
    }

    /// Small sparse bumps (100 of radius 0.025-0.035 on a 30 x 30 period):
    /// their footprints would ask for 2048² grid cells, nearly all empty;
    /// the grid stops at 64 cells a solid, and flights meet what a scan
    /// over every solid meets.
    #[test]
    fn small_sparse_bumps_get_a_grid_of_a_few_cells_a_solid() {
        use bumps::{Bump, Shape};
        let mut u = crate::test_streams::uniform(13);
        let centres: Vec<DVec2> = (0..100)
            .map(|_| DVec2::new(30.0 * u(), 30.0 * u()))
            .collect();
        let placed = centres
            .iter()
            .map(|&center| {
                let b = Bump {
                    center,
                    radius: 0.025 + 0.01 * u(),
                    radius_y: 0.025 + 0.01 * u(),
                    height: 0.008 + 0.04 * u(),
                    depth: 0.0,
                    cap: 1.0,
                    base: 1.5,
                };
                Shape::Ellipsoid.body(&b, 0)
            })
            .collect();
        let s = MicroSurface::new(DVec2::new(30.0, 30.0), Edges::Periodic, placed, white(), 0);
        let Relief::Solids(solids) = &s.relief else {
            panic!("a bump surface")
        };
        let cells = solids.grid.n[0] * solids.grid.n[1];
        // 64 a solid, give or take the rounding of the sides: not 2048².
        assert!(cells > 1000 && cells < 8000, "{cells} grid cells");
        // Aimed at the bumps.
        let (hits, exits) = events_against_scan(&s, &mut u, 3000, Some((&centres, 0.03)));
        assert!(hits > 2000 && exits > 2000, "{hits} hits, {exits} exits");
        // Straight down onto a centre meets its bump.
        let mut scratch = Scratch::new(&s);
        let on_bumps = centres
            .iter()
            .filter(|c| {
                let o = DVec3::new(c.x, c.y, s.top);
                matches!(
                    s.next_event(o, DVec3::NEG_Z, None, &mut scratch),
                    Event::Hit { facet: Facet::Solid { solid, .. }, .. } if solid > 0
                )
            })
            .count();
        assert_eq!(on_bumps, centres.len());
    }

    /// `flights` flights from the launch plane of a 30 x 30 period in random
    /// directions, followed over up to three events: each event is what a
    /// scan over every solid gives. A flight starts at a random point, or
    /// with `aim`, on its way to a point within `aim.1` of a random one of
    /// `aim.0` on the substrate. Returns (hits, exits).
    fn events_against_scan(
        s: &MicroSurface,
        u: &mut impl FnMut() -> f64,
        flights: usize,
        aim: Option<(&[DVec2], f64)>,
    ) -> (usize, usize) {
        let mut scratch = Scratch::new(s);
        let (mut hits, mut exits) = (0, 0);
        for _ in 0..flights {
            let (ct, phi) = (0.05 + 0.95 * u(), std::f64::consts::TAU * u());
            let st = (1.0 - ct * ct).sqrt();
            let d = DVec3::new(st * phi.cos(), st * phi.sin(), -ct);
            let xy = match aim {
                Some((points, r)) => {
                    let at = points[(u() * points.len() as f64) as usize]
                        + r * DVec2::new(2.0 * u() - 1.0, 2.0 * u() - 1.0);
                    let back = at - d.truncate() * (s.top / ct);
                    DVec2::new(back.x.rem_euclid(30.0), back.y.rem_euclid(30.0))
                }
                None => DVec2::new(30.0 * u(), 30.0 * u()),
            };
            let o = DVec3::new(xy.x, xy.y, s.top);
            let (mut o, mut d, mut standing) = (o, d, None);
            for _ in 0..3 {
                let e = s.next_event(o, d, standing, &mut scratch);
                let scan = nearest_by_scan(s, o, d, standing);
                match e {
                    Event::Hit { t, facet } => {
                        assert_eq!(scan, Some((t, facet)), "{o} {d}");
                        hits += 1;
                        let mut p = o + t * d;
                        let (n, _) = s.hit_normal(&mut p, d, facet).expect("a normal");
                        (o, d, standing) = (p, d - 2.0 * d.dot(n) * n, Some(facet));
                    }
                    Event::Top { t } | Event::Side { t, .. } => {
                        assert!(scan.is_none_or(|(ts, _)| ts > t), "{o} {d} {e:?} {scan:?}");
                        exits += 1;
                        break;
                    }
                    other => panic!("{other:?}"),
                }
            }
        }
        (hits, exits)
    }

    #[test]
    fn a_height_field_surface_names_its_triangles() {
        let field = HeightField::new(2, 2, DVec2::ONE, vec![0.0; 4]);
        let s = MicroSurface::from_height_field(field, white(), 0);
        assert!(s.solids().is_empty());
        assert!(s.heightfield().is_some());
        assert_eq!(s.acceleration_stats(), (0, 0.0));
        let mut scratch = Scratch::new(&s);
        let o = DVec3::new(0.25, 0.75, 0.5);
        let Event::Hit {
            t,
            facet: Facet::Triangle(triangle),
        } = s.next_event(o, DVec3::NEG_Z, None, &mut scratch)
        else {
            panic!("no triangle hit");
        };
        assert!((t - 0.5).abs() < 1e-15, "{t}");
        let mut p = o + t * DVec3::NEG_Z;
        let (n, material) = s
            .hit_normal(&mut p, DVec3::NEG_Z, Facet::Triangle(triangle))
            .expect("a flat triangle's normal");
        assert!((n - DVec3::Z).length() < 1e-15, "{n}");
        assert_eq!(material, 0);
        let solid = Facet::Solid {
            solid: 0,
            surface: 0,
        };
        assert_eq!(s.hit_normal(&mut p, DVec3::NEG_Z, solid), None);
        // Skipping periods is for surfaces of solids only.
        let grazing = DVec3::new(1.0, 0.0, -1e-3).normalize();
        assert_eq!(
            s.skip_periods(DVec3::new(0.0, 0.5, 0.4), grazing, 0),
            Skip::None
        );
    }
}
