//! A solid zone compiled for the flight loop: its surfaces in their ray
//! forms, its single-quadric fast path, and a bounding box derived from its
//! region (the region's flat form is the body's, [`Body::inside`]).
//!
//! [`CompiledZone::entry`] computes where a flight first enters the zone with
//! exactly the arithmetic of [`Body::first_entry`] (the same crossings, the
//! same sweep, the same root polishing), over an unbounded flight,
//! and reports with the distance the threshold `key` for which
//! `Body::first_entry(ray, t_max, standing)` returns it: `key <= t_max`. The
//! nearest-hit search of [`super::Object::next_hit`] uses both to give the
//! answer of the linear scan over zones bit for bit, whatever order it
//! visits zones in.
//!
//! Bounds: a half-space of a plane normal to an axis is a half-infinite
//! slab; the negative side of an axis-aligned quadric with a non-negative
//! diagonal (sphere, ellipsoid, cylinder) is the box of its ellipse (the
//! positive side of one with a non-positive diagonal likewise); every other
//! half-space is unbounded. Regions combine them by
//! [`crate::geometry::region::Region::bounding_box`]. An annular vane
//! between two planes inside a cylinder is then bounded, while the outside
//! of a cone is not. Boxes are widened by 1e-6 of their
//! size and position so that roots computed with rounding stay inside.

use glam::DVec3;

use crate::geometry::body::{Aabb, Body, MAX_SURFACES, Ray, Sweep};
use crate::geometry::quadric::{Diagonal, Quadric, RayForm, entry_negative, standing_far_root};
use crate::geometry::region::Sense;

/// Relative widening of a zone's box (of its size and of its distance from
/// the origin): far above the rounding of any root inside it.
const BOX_MARGIN: f64 = 1e-6;

/// Where a flight enters a zone (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZoneEntry {
    /// The threshold: [`Body::first_entry`] with `t_max` returns this entry
    /// exactly when `key <= t_max` (the unpolished root, or for the single
    /// quadric a ray stands on, the larger of the root and its correction).
    pub key: f64,
    /// Distance along the (unit) direction, polished where ill-conditioned.
    pub t: f64,
    /// Index of the body's surface crossed there.
    pub surface: usize,
}

/// A solid zone's body in the form the flight loop evaluates.
#[derive(Clone, Debug)]
pub struct CompiledZone {
    /// `Some((i, surfaces[i], diagonal form))` when the region is exactly `-i`.
    single: Option<(usize, Quadric, Option<Diagonal>)>,
    /// The body's surfaces in their ray forms, in order.
    forms: Vec<RayForm>,
    /// A box containing the zone, widened for rounding; `None`: unbounded
    /// (or an empty box, which is tested like an unbounded one).
    pub bounds: Option<Aabb>,
}

impl CompiledZone {
    /// Compile `body` (an object zone: its own box is unbounded).
    #[must_use]
    pub fn new(body: &Body) -> Self {
        let single = body.region.single_negative().map(|i| {
            let q = body.surfaces[i];
            (i, q, Diagonal::of(&q))
        });
        let bounds = body
            .region
            .bounding_box(&|i, sense| half_space_box(&body.surfaces[i], sense));
        Self {
            single,
            forms: body.surfaces.iter().map(RayForm::of).collect(),
            bounds: widened(bounds),
        }
    }

    /// Is `p` inside the zone? Exactly [`Body::contains`].
    #[must_use]
    pub fn contains(&self, body: &Body, p: DVec3) -> bool {
        let mut positive = 0_u64;
        for (i, q) in body.surfaces.iter().enumerate() {
            positive |= u64::from(q.eval(p) > 0.0) << i;
        }
        body.inside(positive)
    }

    /// The first entry of `ray` into `body` (this zone's body) for any
    /// `t > 0`, `standing`: the index of the body's surface the ray starts
    /// on. Exactly [`Body::first_entry`] with `t_max` when `key <= t_max`
    /// (see [`ZoneEntry`]).
    #[must_use]
    #[inline]
    pub fn entry(&self, body: &Body, ray: &Ray, standing: Option<usize>) -> Option<ZoneEntry> {
        let (o, d) = (ray.o, ray.d);
        let inf = f64::INFINITY;
        let (key, t, surface, ill) = if let Some((i, quadric, diagonal)) = &self.single {
            let i = *i;
            let (a, b, c) = match diagonal {
                Some(diag) => diag.ray_coefficients(o, d),
                None => quadric.ray_coefficients(o, d),
            };
            if standing == Some(i) {
                let (t0, ill) = entry_negative(a, b, 0.0, inf)?;
                let t = standing_far_root(t0, b, c);
                (t0.max(t), t, i, ill)
            } else {
                let (t, ill) = entry_negative(a, b, c, inf)?;
                (t, t, i, ill)
            }
        } else {
            let (t, surface, ill) = self.csg_entry(body, o, d, standing)?;
            (t, t, surface, ill)
        };
        let t = if ill {
            // Polish the distance where it is used (see Quadric::refine_root).
            body.surfaces[surface].refine_root(o, d, t)
        } else {
            t
        };
        Some(ZoneEntry { key, t, surface })
    }

    /// The first crossing after which the region holds: (distance, surface,
    /// ill-conditioned), as `Body`'s CSG path.
    fn csg_entry(
        &self,
        body: &Body,
        o: DVec3,
        d: DVec3,
        standing: Option<usize>,
    ) -> Option<(f64, usize, bool)> {
        match self.forms.len() {
            0..=4 => self.csg_entry_in::<8>(body, o, d, standing),
            5..=8 => self.csg_entry_in::<16>(body, o, d, standing),
            _ => self.csg_entry_in::<{ 2 * MAX_SURFACES }>(body, o, d, standing),
        }
    }

    /// [`Self::csg_entry`] with `S >= 2 * surfaces` crossing slots. The
    /// same few lines as `Body::first_entry_in` over the zone's ray forms (a
    /// helper shared by both, taking the crossings as a closure by index, by
    /// slice element or as an iterator, cost the radiator 1.4-6 % more
    /// instructions per photon, and bumps tested through their bodies up to
    /// 16 %).
    #[inline(always)]
    fn csg_entry_in<const S: usize>(
        &self,
        body: &Body,
        o: DVec3,
        d: DVec3,
        standing: Option<usize>,
    ) -> Option<(f64, usize, bool)> {
        let mut sweep = Sweep::<S>::new();
        for (i, q) in self.forms.iter().enumerate() {
            sweep.add(i, &q.crossings(o, d, f64::INFINITY, standing == Some(i)));
        }
        sweep.first_entry(|positive| body.inside(positive))
    }
}

/// A box containing the half-space `sense` of `q` (see the module docs).
#[must_use]
pub fn half_space_box(q: &Quadric, sense: Sense) -> Aabb {
    // The half-space is {g < 0} (with its boundary), g = ±f.
    let s = if sense == Sense::Negative { 1.0 } else { -1.0 };
    let [a, b, c, dd, e, f, g, h, j, k] = q.coef.map(|x| s * x);
    let mut out = Aabb::EVERYTHING;
    if dd != 0.0 || e != 0.0 || f != 0.0 {
        return out;
    }
    let (diag, lin) = ([a, b, c], [g, h, j]);
    if diag == [0.0; 3] {
        // A plane: bounded when normal to an axis.
        let axes: Vec<usize> = (0..3).filter(|&i| lin[i] != 0.0).collect();
        if let [i] = axes[..] {
            let at = q.origin[i] - k / lin[i];
            if lin[i] > 0.0 {
                out.max[i] = at;
            } else {
                out.min[i] = at;
            }
        }
        return out;
    }
    // sum a_i q_i² + g_i q_i + k < 0 with every a_i >= 0 (and no linear term
    // where a_i = 0): sum a_i (q_i + g_i / 2a_i)² < r.
    if (0..3).any(|i| diag[i] < 0.0 || (diag[i] == 0.0 && lin[i] != 0.0)) {
        return out;
    }
    let r = (0..3)
        .filter(|&i| diag[i] > 0.0)
        .map(|i| lin[i] * lin[i] / (4.0 * diag[i]))
        .sum::<f64>()
        - k;
    for i in (0..3).filter(|&i| diag[i] > 0.0) {
        let centre = q.origin[i] - lin[i] / (2.0 * diag[i]);
        // r < 0: empty, kept as a box with min > max.
        let half = if r < 0.0 { -1.0 } else { (r / diag[i]).sqrt() };
        out.min[i] = centre - half;
        out.max[i] = centre + half;
    }
    out
}

/// The box widened by [`BOX_MARGIN`] of its size and position on every
/// axis; `None` if it is unbounded on some axis, empty, not finite or the
/// single point at the origin.
fn widened(b: Aabb) -> Option<Aabb> {
    let finite = b.min.is_finite() && b.max.is_finite();
    if !finite || (0..3).any(|i| b.min[i] > b.max[i]) {
        return None;
    }
    let scale = (b.max - b.min).max_element() + b.min.abs().max(b.max.abs()).max_element();
    if scale == 0.0 {
        // A point at the origin: no margin to widen by.
        return None;
    }
    let pad = DVec3::splat(BOX_MARGIN * scale);
    Some(Aabb {
        min: b.min - pad,
        max: b.max + pad,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::region;

    fn body(surfaces: Vec<Quadric>, expr: &str, names: &[&str]) -> Body {
        let region = region::parse(expr, |s| names.iter().position(|n| *n == s)).unwrap();
        Body::new(surfaces, region, Aabb::EVERYTHING, 0)
    }

    fn vane() -> Body {
        body(
            vec![
                Quadric::cylinder(2, DVec3::ZERO, 15.0),
                Quadric::cylinder(2, DVec3::ZERO, 25.0),
                Quadric::plane(0.0, 0.0, 1.0, -10.0),
                Quadric::plane(0.0, 0.0, 1.0, -10.5),
            ],
            "+bore -wall -top +bottom",
            &["bore", "wall", "top", "bottom"],
        )
    }

    #[test]
    fn boxes_of_half_spaces() {
        let cyl = Quadric::cylinder(2, DVec3::new(1.0, 2.0, 0.0), 3.0);
        let b = half_space_box(&cyl, Sense::Negative);
        assert_eq!((b.min.x, b.max.x, b.min.y, b.max.y), (-2.0, 4.0, -1.0, 5.0));
        assert_eq!((b.min.z, b.max.z), (f64::NEG_INFINITY, f64::INFINITY));
        assert_eq!(half_space_box(&cyl, Sense::Positive), Aabb::EVERYTHING);
        let below = Quadric::plane(0.0, 0.0, 2.0, 3.0); // z < 1.5
        assert_eq!(half_space_box(&below, Sense::Negative).max.z, 1.5);
        assert_eq!(half_space_box(&below, Sense::Positive).min.z, 1.5);
        let tilted = Quadric::plane(1.0, 0.0, 1.0, 0.0);
        assert_eq!(half_space_box(&tilted, Sense::Negative), Aabb::EVERYTHING);
        let s = Quadric::sphere(DVec3::new(0.0, 0.0, 5.0), 2.0);
        let b = half_space_box(&s, Sense::Negative);
        assert_eq!(
            (b.min, b.max),
            (DVec3::new(-2.0, -2.0, 3.0), DVec3::new(2.0, 2.0, 7.0))
        );
        let cone = Quadric::cone(2, DVec3::ZERO, 0.25);
        assert_eq!(half_space_box(&cone, Sense::Negative), Aabb::EVERYTHING);
    }

    #[test]
    fn an_annular_vane_is_bounded() {
        let b = CompiledZone::new(&vane()).bounds.unwrap();
        let pad = BOX_MARGIN * (50.0 + 25.0);
        assert_eq!(b.min, DVec3::new(-25.0 - pad, -25.0 - pad, -10.5 - pad));
        assert_eq!(b.max, DVec3::new(25.0 + pad, 25.0 + pad, -10.0 + pad));
        // The outside of a cylinder alone is not.
        let outside = body(vec![Quadric::cylinder(2, DVec3::ZERO, 1.0)], "+c", &["c"]);
        assert!(CompiledZone::new(&outside).bounds.is_none());
    }

    #[test]
    fn entries_match_the_body_bit_for_bit() {
        let bodies = [
            vane(),
            body(
                vec![Quadric::sphere(DVec3::new(0.1, 0.2, -20.0), 9.0)],
                "-s",
                &["s"],
            ),
            body(
                vec![
                    Quadric::cone(2, DVec3::new(0.0, 0.0, -30.0), 0.25),
                    Quadric::plane(0.0, 0.0, 1.0, -12.0),
                    Quadric::cylinder(2, DVec3::ZERO, 22.0),
                ],
                "-k -p | +k -c -p",
                &["k", "p", "c"],
            ),
        ];
        for b in &bodies {
            let zone = CompiledZone::new(b);
            for n in 0..2000 {
                let a = f64::from(n) * 0.37;
                let o = DVec3::new(
                    20.0 * a.cos(),
                    18.0 * (1.3 * a).sin(),
                    5.0 - 0.01 * f64::from(n),
                );
                let d = DVec3::new((0.7 * a).sin(), (0.9 * a).cos(), -1.0 - a.sin()).normalize();
                let ray = Ray::new(o, d);
                let e = zone.entry(b, &ray, None);
                for t_max in [
                    f64::INFINITY,
                    5.0,
                    30.0,
                    e.map_or(1.0, |e| e.t),
                    e.map_or(1.0, |e| e.key),
                ] {
                    let want = b.first_entry(&ray, t_max, None);
                    let got = e.filter(|e| e.key <= t_max).map(|e| (e.t, e.surface));
                    assert_eq!(got, want.map(|w| (w.t, w.surface)), "{o} {d} {t_max}");
                }
                // Standing on the surface it entered, flying on.
                if let Some(e) = e {
                    let p = o + e.t * d;
                    let back = Ray::new(p, -d);
                    let s = zone.entry(b, &back, Some(e.surface));
                    let want = b.first_entry(&back, f64::INFINITY, Some(e.surface));
                    assert_eq!(s.map(|s| (s.t, s.surface)), want.map(|w| (w.t, w.surface)));
                }
                assert_eq!(zone.contains(b, o), b.contains(o));
                if let Some(bx) = zone.bounds {
                    if let Some(e) = e {
                        let p = o + e.t * d;
                        assert!(p.cmpge(bx.min).all() && p.cmple(bx.max).all(), "{p}");
                    }
                }
            }
        }
    }
}
