//! Solid bodies: CSG regions over quadric surfaces, and where a ray enters them.
//!
//! A [`Body`] owns its surfaces and a [`Region`] over their indices (OpenMC
//! semantics: `-i` is where surface `i` is negative). Photons always travel in
//! void, so the one query the tracers need is "where does this ray first enter
//! the body". The body is entered at the first crossing after which the region
//! holds; sides are tracked per surface from its crossings (see
//! [`super::quadric`]), with the surface the photon stands on passed explicitly.

use glam::DVec3;

use super::quadric::{Crossings, Diagonal, Quadric, entry_negative, standing_far_root};
use super::region::{Flat, Region};

// Rays and boxes live in `ray` (the regions bound themselves by boxes);
// re-exported here, where the tracers meet them.
pub use super::ray::{Aabb, Ray};

/// Most surfaces a body may have (keeps the per-ray work on the stack).
pub const MAX_SURFACES: usize = 16;

/// Where a ray enters a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// Distance along the ray (units of `|d|`).
    pub t: f64,
    /// Index of the body's surface crossed there.
    pub surface: usize,
}

/// A solid: a region over its own quadric surfaces.
#[derive(Clone, Debug)]
pub struct Body {
    /// Surfaces referenced by `region` (by index).
    pub surfaces: Vec<Quadric>,
    /// Where the body is.
    pub region: Region,
    /// A box known to contain the part of the body that rays can reach.
    pub bounds: Aabb,
    /// Index into the scene's material list.
    pub material: usize,
    /// `Some((i, surfaces[i]))` when the region is exactly `-i`: the fast
    /// path, with the quadric stored inline (no pointer chase in the hot loop).
    single: Option<(usize, Quadric)>,
    /// The single quadric's diagonal form when it has one (most bumps).
    diagonal: Option<Diagonal>,
    /// `region` compiled for the sides of a point (see [`Body::inside`]).
    flat: Option<Flat>,
}

impl Body {
    /// Heap bytes this body owns (its surfaces and region), with a 16-byte
    /// allocator overhead per allocation: for memory estimates.
    #[must_use]
    pub fn heap_bytes(&self) -> usize {
        16 + self.surfaces.capacity() * std::mem::size_of::<Quadric>()
            + self.region.heap_bytes()
            + self.flat.as_ref().map_or(0, Flat::heap_bytes)
    }

    /// A body; `region` must only name indices below `surfaces.len()`,
    /// at most [`MAX_SURFACES`] of them.
    #[must_use]
    pub fn new(surfaces: Vec<Quadric>, region: Region, bounds: Aabb, material: usize) -> Self {
        let flat = region.flat();
        Self::with_flat(surfaces, region, flat, bounds, material)
    }

    /// [`Body::new`] with the region's flat form already at hand.
    fn with_flat(
        surfaces: Vec<Quadric>,
        region: Region,
        flat: Option<Flat>,
        bounds: Aabb,
        material: usize,
    ) -> Self {
        debug_assert!(surfaces.len() <= MAX_SURFACES);
        let single = region.single_negative().map(|i| (i, surfaces[i]));
        let diagonal = single.and_then(|(_, q)| Diagonal::of(&q));
        Self {
            surfaces,
            region,
            bounds,
            material,
            single,
            diagonal,
            flat,
        }
    }

    /// Whether a point with sides `positive` (bit `i`: `f_i > 0`) is inside:
    /// exactly [`Region::contains`], without recursion where the region has
    /// a flat form.
    #[must_use]
    #[inline]
    pub fn inside(&self, positive: u64) -> bool {
        match &self.flat {
            Some(flat) => flat.contains(positive),
            None => self.region.contains(|i| positive >> i & 1 == 1),
        }
    }

    /// The same body moved by `delta` (exact).
    #[must_use]
    pub fn translated(&self, delta: DVec3) -> Self {
        // The region's flat form is kept: a move does not change it (a
        // surface of 10^5 bumps compiled each copy's anew).
        Self::with_flat(
            self.surfaces.iter().map(|q| q.translated(delta)).collect(),
            self.region.clone(),
            self.flat.clone(),
            self.bounds.translated(delta),
            self.material,
        )
    }

    /// The same body with all lengths multiplied by `s > 0`.
    #[must_use]
    pub fn scaled(&self, s: f64) -> Self {
        Self::new(
            self.surfaces.iter().map(|q| q.scaled(s)).collect(),
            self.region.clone(),
            Aabb {
                min: self.bounds.min * s,
                max: self.bounds.max * s,
            },
            self.material,
        )
    }

    /// `Some((i, form))` when the body is exactly `-i` of an axis-aligned
    /// quadric `surfaces[i]` (most bumps) with its diagonal form: what a
    /// compact test needs to give the bits of [`Body::first_entry`].
    #[must_use]
    pub fn single_diagonal(&self) -> Option<(usize, Diagonal)> {
        Some((self.single?.0, self.diagonal?))
    }

    /// Is `p` inside the body (points on a surface count by `f > 0` = positive side)?
    #[must_use]
    pub fn contains(&self, p: DVec3) -> bool {
        self.region.contains(|i| self.surfaces[i].eval(p) > 0.0)
    }

    /// First entry of the ray `o + t d` into the body for `t` in `(0, t_max]`.
    ///
    /// `standing`: index of the body's surface the ray starts on, if any.
    /// A ray that starts inside (only possible within rounding of a surface of
    /// another body) enters at its next entry after leaving.
    #[must_use]
    #[inline(always)]
    pub fn first_entry(&self, ray: &Ray, t_max: f64, standing: Option<usize>) -> Option<Entry> {
        self.first_entry_counting(ray, t_max, standing, &mut 0)
    }

    /// [`Body::first_entry`], adding to `quadric_tests` the number of this
    /// body's quadrics whose ray polynomial was formed (none when the flight
    /// misses the bounding box).
    #[must_use]
    #[inline(always)]
    pub fn first_entry_counting(
        &self,
        ray: &Ray,
        t_max: f64,
        standing: Option<usize>,
        quadric_tests: &mut u64,
    ) -> Option<Entry> {
        let (o, d) = (ray.o, ray.d);
        let (entry, ill_conditioned) = if let Some((i, quadric)) = &self.single {
            let i = *i;
            *quadric_tests += 1;
            // One quadric: its own test is as cheap as a box test, so no box.
            let (a, b, c) = match &self.diagonal {
                Some(diag) => diag.ray_coefficients(o, d),
                None => quadric.ray_coefficients(o, d),
            };
            let (t, ill) = if standing == Some(i) {
                let (t, ill) = entry_negative(a, b, 0.0, t_max)?;
                let t = standing_far_root(t, b, c);
                (t <= t_max).then_some((t, ill))?
            } else {
                entry_negative(a, b, c, t_max)?
            };
            (Entry { t, surface: i }, ill)
        } else {
            let (_, t_hi) = self.bounds.clip(ray, t_max)?;
            *quadric_tests += self.surfaces.len() as u64;
            self.first_entry_csg(o, d, t_hi, standing)?
        };
        if !ill_conditioned {
            return Some(entry);
        }
        // Polish the distance where it is used (see Quadric::refine_root).
        let t = self.surfaces[entry.surface].refine_root(o, d, entry.t);
        Some(Entry { t, ..entry })
    }

    fn first_entry_csg(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        standing: Option<usize>,
    ) -> Option<(Entry, bool)> {
        debug_assert!(self.surfaces.len() <= MAX_SURFACES);
        match self.surfaces.len() {
            0..=4 => self.first_entry_in::<8>(o, d, t_max, standing),
            5..=8 => self.first_entry_in::<16>(o, d, t_max, standing),
            _ => self.first_entry_in::<{ 2 * MAX_SURFACES }>(o, d, t_max, standing),
        }
    }

    /// [`Self::first_entry_csg`] with `S >= 2 * surfaces` crossing slots.
    #[inline(always)]
    fn first_entry_in<const S: usize>(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        standing: Option<usize>,
    ) -> Option<(Entry, bool)> {
        let mut sweep = Sweep::<S>::new();
        for (i, q) in self.surfaces.iter().enumerate() {
            sweep.add(i, &q.crossings(o, d, t_max, standing == Some(i)));
        }
        let (t, surface, ill) = sweep.first_entry(|positive| self.inside(positive))?;
        Some((Entry { t, surface }, ill))
    }
}

/// The CSG sweep of both levels, [`Body`]'s entries and the macro level's
/// zones ([`crate::object`]): the crossings of a flight with a body's
/// surfaces, kept in fixed places, and the first after which the region
/// holds where it did not before.
///
/// Slot `2 i + k` holds the `k`-th (ascending) crossing of surface `i`.
/// Nothing is sorted or moved: the nearest crossings left are picked in
/// turn, all those at one distance applied before the region is asked
/// (edges, tangents), and a flight usually enters at its first. `S` is at
/// least twice the number of surfaces.
pub struct Sweep<const S: usize> {
    /// Crossing distances by slot; only those in `present` are set.
    t: [f64; S],
    /// Bit `k`: slot `k` holds a crossing.
    present: u64,
    /// Bit `i`: the flight starts on the positive side of surface `i`.
    positive: u64,
    /// Bit `i`: surface `i`'s roots are ill-conditioned.
    ill: u64,
}

impl<const S: usize> Default for Sweep<S> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const S: usize> Sweep<S> {
    /// No surfaces yet.
    #[must_use]
    #[inline(always)]
    pub fn new() -> Self {
        Self {
            t: [0.0; S],
            present: 0,
            positive: 0,
            ill: 0,
        }
    }

    /// Surface `i`'s crossings and sides.
    #[inline(always)]
    pub fn add(&mut self, i: usize, c: &Crossings) {
        self.positive |= u64::from(c.positive_at_start) << i;
        self.ill |= u64::from(c.ill_conditioned) << i;
        self.t[2 * i] = c.t[0];
        self.t[2 * i + 1] = c.t[1];
        self.present |= ((1_u64 << c.n) - 1) << (2 * i);
    }

    /// The first crossing after which `inside` holds where it did not
    /// before: (distance, surface, ill-conditioned). Exactly
    /// `first_entering_event` (the tests' reference) of the crossings listed surface by surface:
    /// the slots' order is that list's, so the order of its stable sort
    /// among equal distances, whose last is the surface reported.
    #[inline(always)]
    pub fn first_entry(mut self, inside: impl Fn(u64) -> bool) -> Option<(f64, usize, bool)> {
        let mut positive = self.positive;
        let mut was_inside = inside(positive);
        while self.present != 0 {
            // The nearest distance left (crossings are never NaN).
            let mut rest = self.present;
            let mut nearest = self.t[rest.trailing_zeros() as usize];
            rest &= rest - 1;
            while rest != 0 {
                let t = self.t[rest.trailing_zeros() as usize];
                if t < nearest {
                    nearest = t;
                }
                rest &= rest - 1;
            }
            // Every crossing at it, in slot order.
            let mut last = 0;
            let mut rest = self.present;
            while rest != 0 {
                let k = rest.trailing_zeros() as usize;
                if self.t[k] == nearest {
                    last = k / 2;
                    positive ^= 1 << last;
                    self.present &= !(1 << k);
                }
                rest &= rest - 1;
            }
            let now_inside = inside(positive);
            if now_inside && !was_inside {
                return Some((nearest, last, self.ill >> last & 1 == 1));
            }
            was_inside = now_inside;
        }
        None
    }
}

/// The first of `events` (distance, surface index) after which `inside`
/// holds where it did not before: `(distance, surface)`. `positive` has bit
/// `i` set where the flight starts on the positive side of surface `i`;
/// each event flips its surface's bit. The events are sorted (a stable
/// insertion sort), and all events at one distance are applied before
/// `inside` is asked (edges, tangents). The reference [`Sweep`] is checked
/// against.
#[cfg(test)]
pub fn first_entering_event(
    events: &mut [(f64, usize)],
    mut positive: u64,
    inside: impl Fn(u64) -> bool,
) -> Option<(f64, usize)> {
    for k in 1..events.len() {
        let mut j = k;
        while j > 0 && events[j - 1].0 > events[j].0 {
            events.swap(j - 1, j);
            j -= 1;
        }
    }
    let mut was_inside = inside(positive);
    let mut k = 0;
    while k < events.len() {
        let t = events[k].0;
        let mut last = events[k].1;
        while k < events.len() && events[k].0 == t {
            last = events[k].1;
            positive ^= 1 << last;
            k += 1;
        }
        let now_inside = inside(positive);
        if now_inside && !was_inside {
            return Some((t, last));
        }
        was_inside = now_inside;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::region;

    fn body(surfaces: Vec<Quadric>, expr: &str, names: &[&str]) -> Body {
        let region = region::parse(expr, |s| names.iter().position(|n| *n == s)).unwrap();
        Body::new(surfaces, region, Aabb::EVERYTHING, 0)
    }

    /// The sweep gives the sorted sweep's answer for crossings with many
    /// ties (distances from a set of five, infinity included), random sides
    /// at the start and random regions (truth tables), 1 to 16 surfaces.
    #[test]
    fn the_sweep_is_the_sorted_sweep() {
        let mut next = crate::test_streams::bits(3);
        let values = [0.5, 1.0, 1.5, 2.0, f64::INFINITY];
        let mut entered = 0;
        for _ in 0..20_000 {
            let n = 1 + (next() % 16) as usize;
            let table = next() ^ (next() << 21);
            let inside = |positive: u64| {
                table >> (positive.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 58) & 1 == 1
            };
            let mut sweep = Sweep::<{ 2 * MAX_SURFACES }>::new();
            let mut events = Vec::new();
            let mut positive = 0;
            let mut ill = 0;
            for i in 0..n {
                let k = (next() % 3) as usize;
                let mut t = [f64::INFINITY; 2];
                for slot in t.iter_mut().take(k) {
                    *slot = values[(next() % 5) as usize];
                }
                t.sort_by(f64::total_cmp);
                let c = Crossings {
                    t,
                    n: k,
                    positive_at_start: next() % 2 == 0,
                    ill_conditioned: next() % 4 == 0,
                };
                positive |= u64::from(c.positive_at_start) << i;
                ill |= u64::from(c.ill_conditioned) << i;
                events.extend(c.t[..k].iter().map(|&t| (t, i)));
                sweep.add(i, &c);
            }
            let want = first_entering_event(&mut events, positive, inside)
                .map(|(t, s)| (t, s, ill >> s & 1 == 1));
            assert_eq!(sweep.first_entry(inside), want);
            entered += usize::from(want.is_some());
        }
        assert!(entered > 5000, "{entered}");
    }

    #[test]
    fn aabb_clip() {
        let b = Aabb {
            min: DVec3::ZERO,
            max: DVec3::ONE,
        };
        let r = |o: DVec3, d: DVec3| Ray::new(o, d);
        let (t0, t1) = b
            .clip(&r(DVec3::new(-1.0, 0.5, 0.5), DVec3::X), 10.0)
            .unwrap();
        assert_eq!((t0, t1), (1.0, 2.0));
        assert!(
            b.clip(&r(DVec3::new(-1.0, 2.0, 0.5), DVec3::X), 10.0)
                .is_none()
        );
        assert!(
            b.clip(&r(DVec3::new(-1.0, 0.5, 0.5), DVec3::X), 0.5)
                .is_none()
        );
        let slab = Aabb {
            min: DVec3::new(0.0, f64::NEG_INFINITY, f64::NEG_INFINITY),
            max: DVec3::new(1.0, f64::INFINITY, f64::INFINITY),
        };
        assert_eq!(
            slab.clip(&r(DVec3::new(-1.0, 0.0, 0.0), DVec3::X), 5.0),
            Some((1.0, 2.0))
        );
    }

    #[test]
    fn v_groove_ridge_entry_from_above() {
        // z < x and z < 2 - x: a ridge with its peak at x = 1, z = 1.
        let left = Quadric::plane(-1.0, 0.0, 1.0, 0.0);
        let right = Quadric::plane(1.0, 0.0, 1.0, 2.0);
        let b = body(vec![left, right], "-left -right", &["left", "right"]);
        let e = b
            .first_entry(
                &Ray::new(DVec3::new(0.5, 0.3, 2.0), DVec3::NEG_Z),
                10.0,
                None,
            )
            .unwrap();
        assert_eq!(e, Entry { t: 1.5, surface: 0 });
        let e = b
            .first_entry(
                &Ray::new(DVec3::new(1.5, 0.3, 2.0), DVec3::NEG_Z),
                10.0,
                None,
            )
            .unwrap();
        assert_eq!(e, Entry { t: 1.5, surface: 1 });
        // Standing on the left wall (z = x) at x = 0.5 and leaving along -x,
        // away from the ridge: no re-entry.
        let away = Ray::new(DVec3::new(0.5, 0.3, 0.5), DVec3::NEG_X);
        assert!(b.first_entry(&away, 10.0, Some(0)).is_none());
        // ... but leaving along +x, into the ridge, enters at once (t = 0 is excluded,
        // so it must report no spurious entry at 0 and, since it is then inside, none at all).
        let into = Ray::new(DVec3::new(0.5, 0.3, 0.5), DVec3::X);
        assert!(b.first_entry(&into, 10.0, Some(0)).is_none());
    }

    #[test]
    fn capped_cone_lower_nappe_only() {
        let k = Quadric::cone_down(DVec3::new(0.0, 0.0, 1.0), 1.0, 1.0, 1.0);
        let top = Quadric::plane_z(1.0);
        let b = body(vec![k, top], "-k -top", &["k", "top"]);
        // From above through the apex region of the upper nappe: must enter the lower one.
        let e = b
            .first_entry(
                &Ray::new(DVec3::new(0.25, 0.0, 3.0), DVec3::NEG_Z),
                10.0,
                None,
            )
            .unwrap();
        // |x| = 0.25 meets the lower nappe at z = 0.75 (the upper one at 1.25 is outside).
        assert!((e.t - 2.25).abs() < 1e-15, "{e:?}");
        assert_eq!(e.surface, 0);
    }

    #[test]
    fn single_surface_fast_path_agrees_with_csg() {
        let s = Quadric::sphere(DVec3::new(0.1, 0.2, 0.0), 1.0);
        let fast = body(vec![s], "-s", &["s"]);
        let slow = body(vec![s, Quadric::plane_z(-100.0)], "-s +p", &["s", "p"]);
        for k in 0..200 {
            let a = k as f64 * 0.1;
            let o = DVec3::new(3.0 * a.cos(), 3.0 * a.sin(), 0.5 * (a * 0.7).sin());
            let d = (DVec3::new(0.1 * (a * 1.3).sin(), 0.05, 0.0) - o).normalize();
            assert_eq!(
                fast.first_entry(&Ray::new(o, d), 10.0, None),
                slow.first_entry(&Ray::new(o, d), 10.0, None)
            );
        }
    }

    /// A moved body is the body `new` makes of the moved surfaces, field
    /// for field (its flat form is carried over, not derived again).
    #[test]
    fn translated_is_new_of_the_moved_surfaces() {
        let delta = DVec3::new(30.0, -0.1, 0.0);
        let bodies = [
            body(
                vec![Quadric::sphere(DVec3::new(0.1, 0.2, 0.0), 1.0)],
                "-s",
                &["s"],
            ),
            body(
                vec![
                    Quadric::cone(2, DVec3::new(1.0, 2.0, 3.0), 0.5),
                    Quadric::plane_z(2.0),
                ],
                "-k -p",
                &["k", "p"],
            ),
            body(
                vec![
                    Quadric::ellipsoid(DVec3::new(0.0, 0.0, 1.0), DVec3::new(2.0, 3.0, 1.0)),
                    Quadric::hyperboloid_one_sheet(DVec3::new(0.0, 0.0, 1.0), 2.0, 3.0, 0.7),
                    Quadric::plane_z(1.0),
                ],
                "-a | (-b -c)",
                &["a", "b", "c"],
            ),
        ];
        for b in &bodies {
            let moved = b.translated(delta);
            let made = Body::new(
                b.surfaces.iter().map(|q| q.translated(delta)).collect(),
                b.region.clone(),
                b.bounds.translated(delta),
                b.material,
            );
            assert_eq!(format!("{moved:?}"), format!("{made:?}"));
        }
    }
}
