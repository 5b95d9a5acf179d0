//! The macro level: the geometry of a 3-D object made of zones bounded by
//! quadrics.
//!
//! Zones (declared in a scene by `[[cells]]`) are regions over named quadric
//! surfaces (the same kernel and region syntax as the micro level). A zone's
//! fill is `void` (photons fly through it) or `solid` (photons reflect where
//! they would enter it). Space outside every zone is open void; a photon
//! that meets no solid escapes to infinity. The surface a photon crosses
//! into a solid names its wall, whose model
//! ([`crate::transport::wall::WallModel`]) decides the reflection: a descent
//! into a micro geometry (ROKS-RG), a tabulated BRDF, ideal
//! specular/diffuse, or Fresnel. This module holds geometry only (and the
//! beams of [`source`]); the histories are in [`crate::transport::object`].
//!
//! **The nearest hit.** [`Object::next_hit`] finds the nearest entry into a
//! solid without testing every zone: zones whose regions are bounded (see
//! [`zone`]) sit in a bounding-volume hierarchy ([`bvh`]) visited nearest
//! box first, with early exit at the best distance found; unbounded zones
//! are tested always. Each zone's region is evaluated in its flat form
//! (no recursion at every crossing). The answer is bit for bit that of the
//! linear scan over zones in index order, `Body::first_entry(ray, t_max)`
//! with `t_max` the distance of the last zone accepted (so on equal
//! distances the highest index wins): the candidates found below the final
//! bound are replayed in index order with the scan's rule, which is exact
//! when every candidate lies wholly below that bound (checked; otherwise,
//! when a polished root moves across it, the full scan runs).

pub mod bvh;
pub mod source;
pub mod zone;

use glam::DVec3;

use crate::geometry::body::{Body, Ray};
use bvh::Bvh;
use zone::{CompiledZone, ZoneEntry};

/// Most candidate entries one flight keeps before falling back to the scan.
const CANDIDATES: usize = 16;

/// Objects with at most this many solids are scanned directly (the scan
/// costs no more than the hierarchy's bookkeeping there).
const SCAN_SOLIDS: usize = 4;

/// A solid zone: where photons reflect.
#[derive(Clone, Debug)]
pub struct SolidZone {
    /// Zone name (from the scene).
    pub name: String,
    /// The solid.
    pub body: Body,
    /// Global surface index of each of the body's surfaces.
    pub surface_ids: Vec<usize>,
}

/// A void zone (kept to check that photon positions are covered once).
#[derive(Clone, Debug)]
pub struct VoidZone {
    /// Zone name (from the scene).
    pub name: String,
    /// Where the zone is.
    pub body: Body,
}

/// Where a flight enters a solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) direction.
    pub t: f64,
    /// Index into [`Object::solids`].
    pub zone: usize,
    /// Index into that zone's surfaces.
    pub surface: usize,
}

/// The geometry of a 3-D object (build it with [`Object::new`], which
/// compiles the zones for the flight loop).
#[derive(Clone, Debug)]
pub struct Object {
    /// Names of the scene's quadrics; a surface id indexes this list.
    pub surface_names: Vec<String>,
    /// Solid zones.
    pub solids: Vec<SolidZone>,
    /// Void zones.
    pub voids: Vec<VoidZone>,
    /// The solids compiled for the flight loop, one per solid.
    compiled: Vec<CompiledZone>,
    /// Solids without a finite box: tested by every flight.
    unbounded: Vec<usize>,
    /// The hierarchy over the bounded solids.
    bvh: Bvh,
}

impl Object {
    /// The object of these zones (solid bodies with unbounded own boxes, as
    /// scenes build them).
    #[must_use]
    pub fn new(surface_names: Vec<String>, solids: Vec<SolidZone>, voids: Vec<VoidZone>) -> Self {
        let compiled: Vec<CompiledZone> =
            solids.iter().map(|s| CompiledZone::new(&s.body)).collect();
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

    /// The entry of the flight into solid `zone` (see [`CompiledZone::entry`]).
    #[inline]
    fn entry(&self, zone: usize, ray: &Ray, standing: Option<(usize, usize)>) -> Option<ZoneEntry> {
        let on = standing.and_then(|(c, s)| (c == zone).then_some(s));
        self.compiled[zone].entry(&self.solids[zone].body, ray, on)
    }

    /// The nearest entry into any solid of the flight from `o` along unit
    /// `d`, or `None` if it escapes. `standing`: `(zone, surface)` it starts
    /// on. Bit for bit the linear scan's answer (see the module docs).
    #[must_use]
    pub fn next_hit(&self, o: DVec3, d: DVec3, standing: Option<(usize, usize)>) -> Option<Hit> {
        let ray = Ray::new(o, d);
        if self.solids.len() <= SCAN_SOLIDS {
            return self.scan(&ray, standing);
        }
        let mut found = [(
            0_usize,
            ZoneEntry {
                key: 0.0,
                t: 0.0,
                surface: 0,
            },
        ); CANDIDATES];
        let mut n = 0;
        let mut overflow = false;
        let mut test = |zone: usize, bound: f64| match self.entry(zone, &ray, standing) {
            Some(e) => {
                if n < CANDIDATES {
                    found[n] = (zone, e);
                    n += 1;
                } else {
                    overflow = true;
                }
                bound.min(e.key.max(e.t))
            }
            None => bound,
        };
        let mut bound = f64::INFINITY;
        for &zone in &self.unbounded {
            bound = test(zone, bound);
        }
        let bound = self.bvh.traverse(&ray, bound, &mut test);
        if overflow {
            return self.scan(&ray, standing);
        }
        // Replay the scan's rule over the candidates at or below the bound,
        // in index order; zones beyond it (or never tested, their boxes
        // beyond it) would be refused by the scan.
        let candidates = &mut found[..n];
        candidates.sort_unstable_by_key(|c| c.0);
        let mut nearest = Nearest::default();
        for &(zone, e) in candidates.iter() {
            if e.key.min(e.t) > bound {
                continue;
            }
            if e.key.max(e.t) > bound {
                // A polished root across the bound: the replay could differ.
                return self.scan(&ray, standing);
            }
            nearest.offer(zone, e);
        }
        nearest.best
    }

    /// The linear scan over every solid in index order: a zone is taken
    /// when `Body::first_entry(ray, t_max)` finds it, `t_max` the distance
    /// of the last taken.
    fn scan(&self, ray: &Ray, standing: Option<(usize, usize)>) -> Option<Hit> {
        let mut nearest = Nearest::default();
        for zone in 0..self.solids.len() {
            if let Some(e) = self.entry(zone, ray, standing) {
                nearest.offer(zone, e);
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

    /// The solid and void zones containing `p` (for checks of photon positions).
    #[must_use]
    pub fn zones_at(&self, p: DVec3) -> (Vec<usize>, Vec<usize>) {
        let solids = (0..self.solids.len())
            .filter(|&i| self.solids[i].body.contains(p))
            .collect();
        let voids = (0..self.voids.len())
            .filter(|&i| self.voids[i].body.contains(p))
            .collect();
        (solids, voids)
    }

    /// Global surface id of surface `surface` of solid `zone`.
    #[must_use]
    pub fn surface_id(&self, zone: usize, surface: usize) -> usize {
        self.solids[zone].surface_ids[surface]
    }
}

/// The scan's rule for the nearest entry, zones offered in index order: a
/// zone's entry is taken when its `key` is at most the distance of the
/// last taken (see [`ZoneEntry`]). [`Object::next_hit`] replays the
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
    fn offer(&mut self, zone: usize, e: ZoneEntry) {
        if e.key <= self.t_max {
            self.t_max = e.t;
            self.best = Some(Hit {
                t: e.t,
                zone,
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
            SolidZone {
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
        for (zone, solid) in object.solids.iter().enumerate() {
            let on = standing.and_then(|(c, s)| (c == zone).then_some(s));
            if let Some(e) = solid.body.first_entry(&ray, t_max, on) {
                t_max = e.t;
                best = Some(Hit {
                    t: e.t,
                    zone,
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
                let on = Some((h.zone, h.surface));
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
