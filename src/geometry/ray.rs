//! Rays and the axis-aligned boxes they are clipped by: the bounding
//! geometry that [`super::region`] (the box of a CSG expression),
//! [`super::body`] and the acceleration structures share.

use glam::DVec3;

/// A ray `o + t d` with its reciprocal direction precomputed for box tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin (length units).
    pub o: DVec3,
    /// Direction (unit for distances in length units).
    pub d: DVec3,
    /// `1 / d` per component (infinite where `d` is 0).
    pub inv_d: DVec3,
}

impl Ray {
    /// A ray from `o` along `d`.
    #[must_use]
    #[inline]
    pub fn new(o: DVec3, d: DVec3) -> Self {
        Self {
            o,
            d,
            inv_d: d.recip(),
        }
    }
}

/// An axis-aligned box, possibly unbounded (infinite extents allowed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner (length units).
    pub min: DVec3,
    /// Upper corner (length units).
    pub max: DVec3,
}

impl Aabb {
    /// The box containing everything.
    pub const EVERYTHING: Self = Self {
        min: DVec3::splat(f64::NEG_INFINITY),
        max: DVec3::splat(f64::INFINITY),
    };

    /// Parameter interval `[t0, t1]` of `ray` inside the box, intersected with
    /// `[0, t_max]`; `None` if empty.
    #[must_use]
    #[inline]
    pub fn clip(&self, ray: &Ray, t_max: f64) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (0.0_f64, t_max);
        for k in 0..3 {
            let (lo, hi, ok, inv) = (self.min[k], self.max[k], ray.o[k], ray.inv_d[k]);
            if inv.is_infinite() {
                if ok < lo || ok > hi {
                    return None;
                }
                continue;
            }
            // Infinite slabs give (-inf, inf): never NaN for a finite origin.
            let (a, b) = ((lo - ok) * inv, (hi - ok) * inv);
            let (a, b) = if a > b { (b, a) } else { (a, b) };
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }

    /// The box moved by `delta`.
    #[must_use]
    pub fn translated(&self, delta: DVec3) -> Self {
        Self {
            min: self.min + delta,
            max: self.max + delta,
        }
    }
}
