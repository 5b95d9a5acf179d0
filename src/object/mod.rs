//! The macro level: a 3-D object made of cells (zones) bounded by quadrics.
//!
//! Cells are regions over named quadric surfaces (the same kernel and region
//! syntax as the micro level). A cell's fill is `void` (photons fly through
//! it) or `solid` (photons reflect where they would enter it). Space outside
//! every cell is open void; a photon that meets no solid escapes to infinity.
//! The surface a photon crosses into a solid names its wall, whose model
//! ([`wall::WallModel`]) decides the reflection: a descent into a micro
//! geometry (ROKS-RG), a tabulated BRDF, ideal specular/diffuse, or Fresnel.
//!
//! **The nearest hit.** [`Object::next_hit`] finds the nearest entry into a
//! solid without testing every cell: cells whose regions are bounded (see
//! [`cell`]) sit in a bounding-volume hierarchy ([`bvh`]) visited nearest
//! box first, with early exit at the best distance found; unbounded cells
//! are tested always. Each cell's region is evaluated in its flat form
//! (no recursion at every crossing). The answer is bit for bit that of the
//! linear scan over cells in index order, `Body::first_entry(ray, t_max)`
//! with `t_max` the distance of the last cell accepted (so on equal
//! distances the highest index wins): the candidates found below the final
//! bound are replayed in index order with the scan's rule, which is exact
//! when every candidate lies wholly below that bound (checked; otherwise,
//! when a polished root moves across it, the full scan runs).

pub mod bvh;
pub mod cell;
pub mod source;
pub mod wall;

use glam::DVec3;

use crate::geometry::body::{Body, Ray};
use bvh::Bvh;
use cell::{CellEntry, CompiledCell};

/// Most candidate entries one flight keeps before falling back to the scan.
const CANDIDATES: usize = 16;

/// Objects with at most this many solids are scanned directly (the scan
/// costs no more than the hierarchy's bookkeeping there).
const SCAN_SOLIDS: usize = 4;

/// A solid cell: where photons reflect.
#[derive(Clone, Debug)]
pub struct SolidCell {
    /// Cell name (from the scene).
    pub name: String,
    /// The solid.
    pub body: Body,
    /// Global surface index of each of the body's surfaces.
    pub surface_ids: Vec<usize>,
}

/// A void cell (kept to check that photon positions are covered once).
#[derive(Clone, Debug)]
pub struct VoidCell {
    /// Cell name (from the scene).
    pub name: String,
    /// Where the cell is.
    pub body: Body,
}

/// Where a flight enters a solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) direction.
    pub t: f64,
    /// Index into [`Object::solids`].
    pub cell: usize,
    /// Index into that cell's surfaces.
    pub surface: usize,
}

/// The geometry of a 3-D object (build it with [`Object::new`], which
/// compiles the cells for the flight loop).
#[derive(Clone, Debug)]
pub struct Object {
    /// Names of the scene's quadrics; a surface id indexes this list.
    pub surface_names: Vec<String>,
    /// Solid cells.
    pub solids: Vec<SolidCell>,
    /// Void cells.
    pub voids: Vec<VoidCell>,
    /// The solids compiled for the flight loop, one per solid.
    compiled: Vec<CompiledCell>,
    /// Solids without a finite box: tested by every flight.
    unbounded: Vec<usize>,
    /// The hierarchy over the bounded solids.
    bvh: Bvh,
}

impl Object {
    /// The object of these cells (solid bodies with unbounded own boxes, as
    /// scenes build them).
    #[must_use]
    pub fn new(surface_names: Vec<String>, solids: Vec<SolidCell>, voids: Vec<VoidCell>) -> Self {
        let compiled: Vec<CompiledCell> =
            solids.iter().map(|s| CompiledCell::new(&s.body)).collect();
        let unbounded = (0..solids.len())
            .filter(|&i| compiled[i].bounds.is_none())
            .collect();
        let boxes: Vec<_> = compiled
            .iter()
            .enumerate()
            .filter_map(|(i, c)| c.bounds.map(|b| (i, b)))
            .collect();
        Self {
            surface_names,
            solids,
            voids,
            compiled,
            unbounded,
            bvh: Bvh::new(&boxes),
        }
    }

    /// The entry of the flight into solid `cell` (see [`CompiledCell::entry`]).
    #[inline]
    fn entry(&self, cell: usize, ray: &Ray, standing: Option<(usize, usize)>) -> Option<CellEntry> {
        let on = standing.and_then(|(c, s)| (c == cell).then_some(s));
        self.compiled[cell].entry(&self.solids[cell].body, ray, on)
    }

    /// The nearest entry into any solid of the flight from `o` along unit
    /// `d`, or `None` if it escapes. `standing`: `(cell, surface)` it starts
    /// on. Bit for bit the linear scan's answer (see the module docs).
    #[must_use]
    pub fn next_hit(&self, o: DVec3, d: DVec3, standing: Option<(usize, usize)>) -> Option<Hit> {
        let ray = Ray::new(o, d);
        if self.solids.len() <= SCAN_SOLIDS {
            return self.scan(&ray, standing);
        }
        let mut found = [(
            0_usize,
            CellEntry {
                key: 0.0,
                t: 0.0,
                surface: 0,
            },
        ); CANDIDATES];
        let mut n = 0;
        let mut overflow = false;
        let mut test = |cell: usize, bound: f64| match self.entry(cell, &ray, standing) {
            Some(e) => {
                if n < CANDIDATES {
                    found[n] = (cell, e);
                    n += 1;
                } else {
                    overflow = true;
                }
                bound.min(e.key.max(e.t))
            }
            None => bound,
        };
        let mut bound = f64::INFINITY;
        for &cell in &self.unbounded {
            bound = test(cell, bound);
        }
        let bound = self.bvh.traverse(&ray, bound, &mut test);
        if overflow {
            return self.scan(&ray, standing);
        }
        // Replay the scan's rule over the candidates at or below the bound,
        // in index order; cells beyond it (or never tested, their boxes
        // beyond it) would be refused by the scan.
        let candidates = &mut found[..n];
        candidates.sort_unstable_by_key(|c| c.0);
        let mut nearest = Nearest::default();
        for &(cell, e) in candidates.iter() {
            if e.key.min(e.t) > bound {
                continue;
            }
            if e.key.max(e.t) > bound {
                // A polished root across the bound: the replay could differ.
                return self.scan(&ray, standing);
            }
            nearest.offer(cell, e);
        }
        nearest.best
    }

    /// The linear scan over every solid in index order: a cell is taken
    /// when `Body::first_entry(ray, t_max)` finds it, `t_max` the distance
    /// of the last taken.
    fn scan(&self, ray: &Ray, standing: Option<(usize, usize)>) -> Option<Hit> {
        let mut nearest = Nearest::default();
        for cell in 0..self.solids.len() {
            if let Some(e) = self.entry(cell, ray, standing) {
                nearest.offer(cell, e);
            }
        }
        nearest.best
    }

    /// Is `p` inside any solid? (Exactly `Body::contains` of some solid.)
    #[must_use]
    pub fn in_solid(&self, p: DVec3) -> bool {
        let inside = |i: usize| self.compiled[i].contains(&self.solids[i].body, p);
        self.unbounded.iter().any(|&i| inside(i)) || self.bvh.any_containing(p, inside)
    }

    /// The solid and void cells containing `p` (for checks of photon positions).
    #[must_use]
    pub fn cells_at(&self, p: DVec3) -> (Vec<usize>, Vec<usize>) {
        let solids = (0..self.solids.len())
            .filter(|&i| self.solids[i].body.contains(p))
            .collect();
        let voids = (0..self.voids.len())
            .filter(|&i| self.voids[i].body.contains(p))
            .collect();
        (solids, voids)
    }

    /// Global surface id of surface `surface` of solid `cell`.
    #[must_use]
    pub fn surface_id(&self, cell: usize, surface: usize) -> usize {
        self.solids[cell].surface_ids[surface]
    }
}

/// The scan's rule for the nearest entry, cells offered in index order: a
/// cell's entry is taken when its `key` is at most the distance of the
/// last taken (see [`CellEntry`]). [`Object::next_hit`] replays the
/// candidates of its hierarchy through the same rule.
struct Nearest {
    best: Option<Hit>,
    t_max: f64,
}

impl Default for Nearest {
    fn default() -> Self {
        Self {
            best: None,
            t_max: f64::INFINITY,
        }
    }
}

impl Nearest {
    fn offer(&mut self, cell: usize, e: CellEntry) {
        if e.key <= self.t_max {
            self.t_max = e.t;
            self.best = Some(Hit {
                t: e.t,
                cell,
                surface: e.surface,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::body::Aabb;
    use crate::geometry::quadric::Quadric;
    use crate::geometry::region;

    /// A tube (r 25..27, z -110..0) with 10 vanes (r 15..25, 0.5 thick, every
    /// 10), an unbounded cone solid below it, and a sphere sharing a plane.
    fn tube() -> Object {
        let solid = |name: &str, surfaces: Vec<Quadric>, expr: &str, names: &[&str]| {
            let region = region::parse(expr, |s| names.iter().position(|n| *n == s)).unwrap();
            SolidCell {
                name: name.to_string(),
                body: Body::new(surfaces, region, Aabb::EVERYTHING, 0),
                surface_ids: (0..names.len()).collect(),
            }
        };
        let cyl = |r| Quadric::cylinder(2, DVec3::ZERO, r);
        let z = |z0: f64| Quadric::plane(0.0, 0.0, 1.0, z0);
        let mut solids = vec![solid(
            "tube",
            vec![cyl(25.0), cyl(27.0), z(0.0), z(-110.0)],
            "+w -o -m +e",
            &["w", "o", "m", "e"],
        )];
        for k in 1..=10 {
            let top = -10.0 * f64::from(k);
            solids.push(solid(
                "vane",
                vec![cyl(15.0), cyl(25.0), z(top), z(top - 0.5)],
                "+b -w -a +c",
                &["b", "w", "a", "c"],
            ));
        }
        solids.push(solid(
            "cone",
            vec![
                Quadric::cone(2, DVec3::new(0.0, 0.0, -300.0), 0.04),
                z(-150.0),
            ],
            "-k -p",
            &["k", "p"],
        ));
        solids.push(solid(
            "ball",
            vec![Quadric::sphere(DVec3::new(0.0, 0.0, -60.0), 5.0)],
            "-s",
            &["s"],
        ));
        Object::new(vec![], solids, vec![])
    }

    /// The scan as it was: `Body::first_entry` over every solid in order.
    fn reference(
        object: &Object,
        o: DVec3,
        d: DVec3,
        standing: Option<(usize, usize)>,
    ) -> Option<Hit> {
        let ray = Ray::new(o, d);
        let mut best = None;
        let mut t_max = f64::INFINITY;
        for (cell, solid) in object.solids.iter().enumerate() {
            let on = standing.and_then(|(c, s)| (c == cell).then_some(s));
            if let Some(e) = solid.body.first_entry(&ray, t_max, on) {
                t_max = e.t;
                best = Some(Hit {
                    t: e.t,
                    cell,
                    surface: e.surface,
                });
            }
        }
        best
    }

    #[test]
    fn next_hit_is_the_linear_scan_bit_for_bit() {
        let object = tube();
        assert_eq!(object.unbounded, vec![object.solids.len() - 2]);
        let mut hits = 0;
        for n in 0..20_000_u32 {
            let a = f64::from(n) * 0.618_033_988_749_895;
            let o = DVec3::new(
                14.0 * (7.0 * a).sin(),
                14.0 * (3.0 * a).cos(),
                5.0 - 120.0 * (a % 1.0),
            );
            let d =
                DVec3::new((11.0 * a).sin(), (13.0 * a).cos(), -0.8 * (5.0 * a).cos()).normalize();
            let want = reference(&object, o, d, None);
            assert_eq!(object.next_hit(o, d, None), want, "{o} {d}");
            assert_eq!(
                object.in_solid(o),
                object.solids.iter().any(|s| s.body.contains(o))
            );
            // Fly on from the hit, standing on its surface, along a turned direction.
            if let Some(h) = want {
                hits += 1;
                let p = o + h.t * d;
                let d2 = DVec3::new(-d.x, d.y, -d.z);
                let on = Some((h.cell, h.surface));
                assert_eq!(
                    object.next_hit(p, d2, on),
                    reference(&object, p, d2, on),
                    "{p} {d2}"
                );
            }
        }
        assert!(hits > 10_000, "{hits}");
    }
}
