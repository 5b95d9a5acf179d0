//! Property tests of the geometry kernel against brute force:
//! random quadrics (planes, spheres, ellipsoids, cylinders, cones,
//! paraboloids, hyperboloids, general ten-coefficient ones, at scales
//! 1e-6 to 1e6) and random rays.
//!
//! The brute force samples `f` along the ray, `f(o + t d)` for 4096 values
//! of t in (0, t_max], and trusts the sign of a sample only where `|f|`
//! exceeds the rounding bound [`tol`]. Properties:
//! * the side the kernel derives from its roots agrees with every trusted
//!   sample (no root missed, none invented);
//! * every entry point `Body::first_entry` reports lies on its surface
//!   (`|f| <= tol`);
//! * for CSG bodies over 2-3 quadrics, the first entry is not after the
//!   first trusted inside sample of a march of `contains`, and no trusted
//!   sample before it is inside; the same for rays standing on a surface
//!   after a specular reflection there.

use glam::DVec3;
use proptest::prelude::*;
use roks::geometry::body::{Aabb, Body, Ray};
use roks::geometry::quadric::{Crossings, Quadric};
use roks::geometry::region;

const SAMPLES: usize = 4096;

/// A quadric of family `kind` about `origin`, shape parameters from `p`
/// (sizes in [0.1, 2]), all lengths times `scale`.
fn quadric(kind: usize, p: [f64; 10], origin: DVec3, scale: f64) -> Quadric {
    let size = |x: f64| 0.1 + 1.9 * x.abs();
    let axis = (p[9].abs() * 3.0) as usize % 3;
    let q = match kind {
        0 => {
            let n = DVec3::new(p[0], p[1], p[2])
                .try_normalize()
                .unwrap_or(DVec3::Z);
            Quadric {
                origin,
                coef: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, n.x, n.y, n.z, 0.0],
            }
        }
        1 => Quadric::sphere(origin, size(p[0])),
        2 => Quadric::ellipsoid(origin, DVec3::new(size(p[0]), size(p[1]), size(p[2]))),
        3 => Quadric::cylinder(axis, origin, size(p[0])),
        4 => Quadric::cone(axis, origin, size(p[0]).powi(2)),
        5 => Quadric::paraboloid_down(origin, size(p[0]), size(p[1]), size(p[2])),
        6 => Quadric::hyperboloid_one_sheet(origin, size(p[0]), size(p[1]), size(p[2])),
        _ => Quadric { origin, coef: p },
    };
    q.scaled(scale)
}

/// `sum |term|` of `f(p)`.
fn eval_abs(q: &Quadric, p: DVec3) -> f64 {
    let [a, b, c, d, e, f, g, h, j, k] = q.coef;
    let r = p - q.origin;
    let (x, y, z) = (r.x, r.y, r.z);
    [
        a * x * x,
        b * y * y,
        c * z * z,
        d * x * y,
        e * y * z,
        f * x * z,
        g * x,
        h * y,
        j * z,
        k,
    ]
    .iter()
    .map(|v| v.abs())
    .sum()
}

/// Rounding bound of `f` at the point `o + t d` as the kernel sees it:
/// evaluating `f` (16 eps of the sum of its terms), the point's own
/// coordinates (16 eps |p| |grad f|), and the ray's coefficients
/// `f(o + t d) = a t² + 2 b t + c`, formed at `o` and solved there (16 eps
/// of `|a| t² + 2 |b| t + |c|` with each coefficient replaced by the sum of
/// its terms' magnitudes, and of `(b² + |a c|) / |a|`, the rounding of the
/// discriminant passed to a root).
fn tol(q: &Quadric, o: DVec3, d: DVec3, t: f64) -> f64 {
    let p = o + t * d;
    let (a, b, c) = q.ray_coefficients(o, d);
    let abs_q = Quadric {
        origin: q.origin,
        coef: q.coef.map(f64::abs),
    };
    let (aa, ba, _) = abs_q.ray_coefficients(o, d.abs());
    let ca = eval_abs(q, o);
    let disc = if a == 0.0 {
        0.0
    } else {
        (b * b + (a * c).abs()) / a.abs()
    };
    let g = q.gradient(p).length();
    16.0 * f64::EPSILON
        * (eval_abs(q, p)
            + g * (p.length() + q.origin.length())
            + aa.abs() * t * t
            + 2.0 * ba.abs() * t
            + ca
            + disc)
}

/// The side (`f > 0`) the crossings imply just after `t`.
fn side(c: &Crossings, t: f64) -> bool {
    let flips = c.t[..c.n].iter().filter(|&&r| r <= t).count();
    c.positive_at_start ^ (flips % 2 == 1)
}

/// A ray from a random point of the box [-3, 3]³ (times scale) toward a
/// random point within 1 (times scale) of the quadric's origin.
fn ray(o: [f64; 3], aim: [f64; 3], center: DVec3, scale: f64) -> Option<(DVec3, DVec3)> {
    let o = DVec3::from(o) * scale;
    let target = center * scale + DVec3::from(aim) * scale;
    Some((o, (target - o).try_normalize()?))
}

fn coef() -> impl Strategy<Value = [f64; 10]> {
    prop::array::uniform10(-1.0..1.0_f64)
}

fn point() -> impl Strategy<Value = [f64; 3]> {
    prop::array::uniform3(-3.0..3.0_f64)
}

fn unit_box() -> impl Strategy<Value = [f64; 3]> {
    prop::array::uniform3(-1.0..1.0_f64)
}

fn body(surfaces: Vec<Quadric>, expr: &str) -> Body {
    let names = ["a", "b", "c"];
    let region = region::parse(expr, |n| names.iter().position(|m| *m == n)).expect("valid");
    Body::new(surfaces, region, Aabb::EVERYTHING, 0)
}

/// Brute-force check of `first_entry` for `body` along `o + t d`, `t` in
/// (0, t_max]: the first entry is not after the first trusted inside
/// sample, and no trusted sample before it is inside (a ray starting
/// inside enters at its first entry after leaving: inside samples before
/// the first trusted outside one do not count). A sample is trusted when
/// every surface's `|f|` exceeds its rounding bound there.
fn check_entry(
    body: &Body,
    o: DVec3,
    d: DVec3,
    t_max: f64,
    standing: Option<usize>,
    starts_inside: bool,
) {
    let entry = body.first_entry(&Ray::new(o, d), t_max, standing);
    if let Some(e) = entry {
        let q = &body.surfaces[e.surface];
        let p = o + e.t * d;
        assert!(
            q.eval(p).abs() <= tol(q, o, d, e.t),
            "entry {e:?} off its surface: f = {:e}, tolerance {:e}",
            q.eval(p),
            tol(q, o, d, e.t)
        );
    }
    let t_entry = entry.map_or(f64::INFINITY, |e| e.t);
    let mut left = !starts_inside;
    for i in 0..SAMPLES {
        let t = t_max * (i as f64 + 0.5) / SAMPLES as f64;
        let p = o + t * d;
        let trusted = body
            .surfaces
            .iter()
            .all(|q| q.eval(p).abs() > tol(q, o, d, t));
        if !trusted {
            continue;
        }
        let inside = body.contains(p);
        if t < t_entry {
            assert!(
                !(inside && left),
                "inside at t = {t} before the entry {entry:?} (t_max {t_max})"
            );
            left |= !inside;
        } else {
            // The first trusted sample after the entry is the body's.
            break;
        }
    }
}

// A fixed seed: CI runs the same 3000 cases every time (same seed, same
// result); edit the seed to explore others.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 3000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x726f_6b73),
        ..ProptestConfig::default()
    })]

    /// Sides from the kernel's roots agree with every trusted sample, for
    /// rays starting off the surface; every root lies on the surface.
    #[test]
    fn roots_agree_with_sampling(
        kind in 0usize..8,
        p in coef(),
        center in unit_box(),
        exp in -6i32..=6,
        o in point(),
        aim in unit_box(),
    ) {
        let scale = 10f64.powi(exp);
        let q = quadric(kind, p, DVec3::from(center), scale);
        let Some((o, d)) = ray(o, aim, DVec3::from(center), scale) else { return Ok(()) };
        let t_max = 10.0 * scale;
        let c = q.crossings(o, d, t_max, false);
        prop_assume!(q.eval(o).abs() > tol(&q, o, d, 0.0));
        prop_assert_eq!(c.positive_at_start, q.eval(o) > 0.0);
        for &t in &c.t[..c.n] {
            let t = if c.ill_conditioned { q.refine_root(o, d, t) } else { t };
            let f = q.eval(o + t * d);
            prop_assert!(f.abs() <= tol(&q, o, d, t), "root {} off the surface: f = {:e}, tol {:e}", t, f, tol(&q, o, d, t));
        }
        for i in 0..SAMPLES {
            let t = t_max * (i as f64 + 0.5) / SAMPLES as f64;
            let f = q.eval(o + t * d);
            if f.abs() > tol(&q, o, d, t) {
                prop_assert_eq!(side(&c, t), f > 0.0, "t = {}, f = {:e}, {:?}", t, f, c);
            }
        }
    }

    /// Single quadrics and CSG bodies: the first entry against a march of
    /// `contains`, from outside and standing on the surface after a
    /// reflection.
    ///
    /// With the fixed seed this finds a flight standing on a flat ellipsoid
    /// (semi-axes 10, 94, 81; "+a") whose far root, computed with f(o) taken
    /// as exactly 0, was off the surface by 1.2x the rounding bound; the far
    /// root now carries the correction f(o)/(2b) (`standing_far_root`).
    #[test]
    fn first_entry_agrees_with_marching(
        kinds in prop::array::uniform3(0usize..8),
        p in prop::array::uniform3(coef()),
        centers in prop::array::uniform3(unit_box()),
        exp in -6i32..=6,
        expr in prop::sample::select(vec!["-a", "+a", "-a -b", "-a | -b", "-a +b", "~(-a -b)", "(-a | -b) -c", "-a ~(-b | +c)"]),
        o in point(),
        aim in unit_box(),
    ) {
        let scale = 10f64.powi(exp);
        let surfaces: Vec<Quadric> = (0..3)
            .map(|i| quadric(kinds[i], p[i], DVec3::from(centers[i]), scale))
            .collect();
        let b = body(surfaces, expr);
        let Some((o, d)) = ray(o, aim, DVec3::from(centers[0]), scale) else { return Ok(()) };
        prop_assume!(b.surfaces.iter().all(|q| q.eval(o).abs() > tol(q, o, d, 0.0)));
        let t_max = 10.0 * scale;
        check_entry(&b, o, d, t_max, None, b.contains(o));
        // Reflect at the entry and go on standing on that surface.
        if let Some(e) = b.first_entry(&Ray::new(o, d), t_max, None) {
            let hit = o + e.t * d;
            if let Some(n) = b.surfaces[e.surface].facing_normal(hit, d) {
                let r = d - 2.0 * d.dot(n) * n;
                if let Some(r) = r.try_normalize() {
                    check_entry(&b, hit, r, t_max, Some(e.surface), false);
                }
            }
        }
    }
}
