//! Bump shapes: small solids on the substrate, each a region over quadrics.
//!
//! Every shape stands on the substrate `z = 0` with its top at `height`.
//! Horizontal semi-axes are `radius` (x) and `radius_y` (y). Parts below the
//! substrate are hidden by it, so shapes may extend below `z = 0`; their
//! bounds only need to hold the part at `z >= 0`.
//!
//! | shape | body |
//! |---|---|
//! | `ellipsoid` | ellipsoid centred `depth` below the substrate, vertical semi-axis `height + depth` |
//! | `ellipsoid_on_hyperboloid` | ellipsoid cap (top `cap * height`) on a one-sheet hyperboloid base whose waist matches the cap's equator (tangent-continuous) and whose radius at the substrate is `base` times the waist |
//! | `paraboloid` | paraboloid of revolution, apex at `height`, radius `radius` at the substrate |
//! | `cone` | cone, apex at `height`, radius `radius` at the substrate |
//! | `cylinder` | flat-topped elliptic post of height `height` |

use glam::{DVec2, DVec3};
use serde::Deserialize;

use super::Placed;
#[cfg(test)]
use crate::geometry::body::Ray;
use crate::geometry::body::{Aabb, Body};
use crate::geometry::quadric::Quadric;
use crate::geometry::region;

/// The regions of the bump shapes' bodies, over their surfaces named a, b, c
/// by position ...
const BUMP_EXPRESSIONS: [&str; 3] = ["-a", "-a -b", "-a | (-b -c)"];

/// ... parsed once (a scene of 10^5 bumps parsed them 10^5 times).
static BUMP_REGIONS: std::sync::LazyLock<[region::Region; 3]> = std::sync::LazyLock::new(|| {
    let names = ["a", "b", "c"];
    BUMP_EXPRESSIONS.map(|e| {
        region::parse(e, |n| names.iter().position(|m| *m == n))
            .expect("bump regions are fixed and valid")
    })
});

/// The shapes a bump population can have.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// Ellipsoid (cap) on the substrate.
    Ellipsoid,
    /// Ellipsoid top on an elliptic one-sheet hyperboloid base (the paper's Li & Torrance fit).
    EllipsoidOnHyperboloid,
    /// Paraboloid of revolution (elliptic if `radius_y` differs).
    Paraboloid,
    /// Cone (elliptic if `radius_y` differs).
    Cone,
    /// Flat-topped cylinder (post).
    Cylinder,
}

/// The parameters of one bump (lengths in scene units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bump {
    /// Centre on the substrate.
    pub center: DVec2,
    /// Horizontal semi-axis along x (the waist for `ellipsoid_on_hyperboloid`).
    pub radius: f64,
    /// Horizontal semi-axis along y.
    pub radius_y: f64,
    /// Height of the top above the substrate.
    pub height: f64,
    /// Ellipsoid: depth of the centre below the substrate (>= 0).
    pub depth: f64,
    /// Ellipsoid on hyperboloid: fraction of the height in the cap, (0, 1].
    pub cap: f64,
    /// Ellipsoid on hyperboloid: radius at the substrate / waist radius (> 1).
    pub base: f64,
}

impl Shape {
    /// Every shape.
    pub const ALL: [Self; 5] = [
        Self::Ellipsoid,
        Self::EllipsoidOnHyperboloid,
        Self::Paraboloid,
        Self::Cone,
        Self::Cylinder,
    ];

    /// Height of the bump's top surface at scaled radial distance
    /// `s = sqrt(((x - cx)/rx)² + ((y - cy)/ry)²)` from its centre
    /// (`-inf` outside its footprint). Non-increasing in `s` for every shape.
    #[must_use]
    pub fn profile(self, b: &Bump, s: f64) -> f64 {
        let h = b.height;
        let z = match self {
            Self::Ellipsoid => -b.depth + (h + b.depth) * (1.0 - s * s).max(0.0).sqrt(),
            Self::Paraboloid => h * (1.0 - s * s),
            Self::Cone => h * (1.0 - s),
            Self::Cylinder => h,
            Self::EllipsoidOnHyperboloid => {
                let cap = (b.cap * h).min(h);
                let zj = h - cap;
                if s <= 1.0 || zj <= 0.0 {
                    zj + cap * (1.0 - s * s).max(0.0).sqrt()
                } else {
                    let ch = zj / (b.base * b.base - 1.0).sqrt();
                    zj - ch * (s * s - 1.0).sqrt()
                }
            }
        };
        let outside = match self {
            Self::EllipsoidOnHyperboloid => s > b.base.max(1.0),
            _ => s > 1.0,
        };
        if outside { f64::NEG_INFINITY } else { z }
    }

    /// The highest point of the bump over the rectangle `[lo, hi]` of the
    /// plane (length units): its height at the rectangle's point nearest the
    /// centre in scaled coordinates (exact, since heights fall with `s`).
    #[must_use]
    pub fn max_height_over(self, b: &Bump, lo: DVec2, hi: DVec2) -> f64 {
        let nearest = b.center.clamp(lo, hi);
        let q = (nearest - b.center) / DVec2::new(b.radius, b.radius_y);
        self.profile(b, q.length())
    }

    /// The lowest point of the bump's top over the rectangle `[lo, hi]` of
    /// the plane (length units): its height at the rectangle's point farthest
    /// from the centre in scaled coordinates (exact, since heights fall with
    /// `s`); `-inf` when that point is outside the footprint.
    ///
    /// Every shape is solid below its top: over the rectangle, its body holds
    /// every point from the substrate `z = 0` up to this height (the
    /// ellipsoid's underside, the cone's lower nappe, the paraboloid, the
    /// post and the hyperboloid base all reach below `z = 0` inside the
    /// footprint). Whatever lies under it there cannot be reached by a flight.
    #[must_use]
    pub fn min_height_over(self, b: &Bump, lo: DVec2, hi: DVec2) -> f64 {
        let far = |c: f64, lo: f64, hi: f64| if c - lo > hi - c { lo } else { hi };
        let farthest = DVec2::new(far(b.center.x, lo.x, hi.x), far(b.center.y, lo.y, hi.y));
        let q = (farthest - b.center) / DVec2::new(b.radius, b.radius_y);
        self.profile(b, q.length())
    }

    /// The solid for one bump, with its bounds and top.
    #[must_use]
    pub fn body(self, b: &Bump, material: usize) -> Placed {
        let c = DVec3::new(b.center.x, b.center.y, 0.0);
        let (rx, ry, h) = (b.radius, b.radius_y, b.height);
        let single = |q: Quadric| (vec![q], "-a");
        let (surfaces, expr, foot) = match self {
            Self::Ellipsoid => {
                let center = c - DVec3::Z * b.depth;
                let q = Quadric::ellipsoid(center, DVec3::new(rx, ry, h + b.depth));
                let (s, e) = single(q);
                (s, e, DVec2::new(rx, ry))
            }
            Self::Paraboloid => {
                let (s, e) = single(Quadric::paraboloid_down(c + DVec3::Z * h, rx, ry, h));
                (s, e, DVec2::new(rx, ry))
            }
            Self::Cone => (
                vec![
                    Quadric::cone_down(c + DVec3::Z * h, rx, ry, h),
                    Quadric::plane_z(h),
                ],
                "-a -b",
                DVec2::new(rx, ry),
            ),
            Self::Cylinder => {
                let wall = Quadric {
                    origin: c,
                    coef: [
                        1.0 / (rx * rx),
                        1.0 / (ry * ry),
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        -1.0,
                    ],
                };
                (vec![wall, Quadric::plane_z(h)], "-a -b", DVec2::new(rx, ry))
            }
            Self::EllipsoidOnHyperboloid => {
                // Junction (waist) height, cap semi-axis and hyperboloid c from
                // radius(z = 0) = waist * base: base² = 1 + zj² / c².
                let cap = (b.cap * h).min(h);
                let zj = h - cap;
                let waist = c + DVec3::Z * zj;
                let top = Quadric::ellipsoid(waist, DVec3::new(rx, ry, cap));
                if zj <= 0.0 {
                    let (s, e) = single(top);
                    (s, e, DVec2::new(rx, ry))
                } else {
                    let ch = zj / (b.base * b.base - 1.0).sqrt();
                    (
                        vec![
                            top,
                            Quadric::hyperboloid_one_sheet(waist, rx, ry, ch),
                            Quadric::plane_z(zj),
                        ],
                        "-a | (-b -c)",
                        DVec2::new(rx, ry) * b.base,
                    )
                }
            }
        };
        let region = BUMP_REGIONS[BUMP_EXPRESSIONS
            .iter()
            .position(|e| *e == expr)
            .expect("every shape's region is listed")]
        .clone();
        // Relative pad so rounding in the bounds never clips a real hit. The
        // horizontal pad grows with the height only up to 1000 footprints
        // (rounding of a hit is relative to its coordinates, about 1e-16 of
        // them): a needle far taller than wide keeps its footprint, and its
        // periodic copies their number.
        let pad = 1e-9 * foot.max_element().max(h);
        let pad_xy = 1e-9 * foot.max_element().max(h.min(1e3 * foot.max_element()));
        let bounds = Aabb {
            min: DVec3::new(c.x - foot.x - pad_xy, c.y - foot.y - pad_xy, -h - pad),
            max: DVec3::new(c.x + foot.x + pad_xy, c.y + foot.y + pad_xy, h + pad),
        };
        Placed {
            body: Body::new(surfaces, region, bounds, material),
            max_height: h,
            wraps: true,
            bump: Some((self, *b)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bump(h: f64) -> Bump {
        Bump {
            center: DVec2::new(5.0, 5.0),
            radius: 2.0,
            radius_y: 1.5,
            height: h,
            depth: 0.5,
            cap: 0.4,
            base: 1.5,
        }
    }

    /// The top of every shape is at `height` above the centre, and the body
    /// contains points just below it but not just above.
    #[test]
    fn every_shape_peaks_at_its_height_over_its_centre() {
        for shape in Shape::ALL {
            let p = shape.body(&bump(1.7), 0);
            assert_eq!(p.max_height, 1.7);
            let e = p
                .body
                .first_entry(
                    &Ray::new(DVec3::new(5.0, 5.0, 10.0), DVec3::NEG_Z),
                    100.0,
                    None,
                )
                .unwrap();
            assert!(
                (10.0 - e.t - 1.7).abs() < 1e-12,
                "{shape:?}: {}",
                10.0 - e.t
            );
            assert!(p.body.contains(DVec3::new(5.0, 5.0, 1.69)));
            assert!(!p.body.contains(DVec3::new(5.0, 5.0, 1.71)));
        }
    }

    /// The profile is the body's top: a vertical ray at scaled distance s meets
    /// the body at profile(s), for every shape and a sweep of s.
    #[test]
    fn profile_matches_vertical_rays() {
        let b = bump(1.7);
        for shape in Shape::ALL {
            let p = shape.body(&b, 0);
            for k in 0..40 {
                let s = k as f64 * 0.04;
                for dir in [DVec2::X, DVec2::Y, DVec2::new(0.6, 0.8)] {
                    let xy = b.center + dir * s / (dir / DVec2::new(b.radius, b.radius_y)).length();
                    let ray = Ray::new(DVec3::new(xy.x, xy.y, 10.0), DVec3::NEG_Z);
                    let hit = p.body.first_entry(&ray, 100.0, None).map(|e| 10.0 - e.t);
                    let want = shape.profile(&b, s);
                    match hit {
                        Some(z) if z >= 0.0 => {
                            assert!(
                                (z - want).abs() < 1e-9,
                                "{shape:?} s={s}: ray {z}, profile {want}"
                            );
                        }
                        _ => assert!(
                            want <= 1e-9,
                            "{shape:?} s={s}: no hit above 0, profile {want}"
                        ),
                    }
                }
            }
        }
    }

    /// Every shape's body holds the column from the substrate up to its
    /// lowest top over a rectangle, for rectangles inside, across and
    /// beyond the footprint (random bumps of every shape).
    #[test]
    fn bodies_hold_the_column_under_their_lowest_top() {
        let mut u = crate::test_streams::uniform(7);
        let mut covered = 0;
        for _ in 0..400 {
            let b = Bump {
                center: DVec2::new(10.0 * u(), 10.0 * u()),
                radius: 0.5 + 5.0 * u(),
                radius_y: 0.5 + 5.0 * u(),
                height: 0.1 + 4.0 * u(),
                depth: 2.0 * u(),
                cap: 0.05 + 0.95 * u(),
                base: 1.01 + 2.0 * u(),
            };
            for shape in Shape::ALL {
                let body = shape.body(&b, 0).body;
                let lo = DVec2::new(12.0 * u() - 1.0, 12.0 * u() - 1.0);
                let hi = lo + DVec2::new(3.0 * u(), 3.0 * u());
                let floor = shape.min_height_over(&b, lo, hi);
                if floor <= 0.0 {
                    continue;
                }
                covered += 1;
                // The lowest top is the least profile over the rectangle.
                let mut least = f64::INFINITY;
                for i in 0..=8 {
                    for j in 0..=8 {
                        let xy = lo + (hi - lo) * DVec2::new(f64::from(i), f64::from(j)) / 8.0;
                        let s = ((xy - b.center) / DVec2::new(b.radius, b.radius_y)).length();
                        least = least.min(shape.profile(&b, s));
                        for k in 0..=8 {
                            let z = floor * (1.0 - 1e-9) * f64::from(k) / 8.0;
                            assert!(
                                body.contains(DVec3::new(xy.x, xy.y, z)),
                                "{shape:?} {b:?} at {xy} z {z} under {floor}"
                            );
                        }
                    }
                }
                assert!(
                    (least - floor).abs() <= 1e-12 * b.height.max(1.0),
                    "{shape:?}"
                );
            }
        }
        assert!(covered > 200, "{covered} rectangles under a top");
    }

    /// Footprints at the substrate: the bounds hold the body at z >= 0.
    #[test]
    fn footprint_radii_at_the_substrate() {
        let b = bump(2.0);
        // Ellipsoid centred 0.5 below: footprint radius rx sqrt(1 - (0.5/2.5)²).
        let e = Shape::Ellipsoid.body(&b, 0);
        let r = 2.0 * (1.0 - (0.5_f64 / 2.5).powi(2)).sqrt();
        assert!(e.body.contains(DVec3::new(5.0 + r - 1e-9, 5.0, 1e-12)));
        assert!(!e.body.contains(DVec3::new(5.0 + r + 1e-9, 5.0, 1e-12)));
        // Hyperboloid base: radius waist * base at z = 0.
        let hb = Shape::EllipsoidOnHyperboloid.body(&b, 0);
        assert!(hb.body.contains(DVec3::new(5.0 + 3.0 - 1e-9, 5.0, 0.0)));
        assert!(!hb.body.contains(DVec3::new(5.0 + 3.0 + 1e-9, 5.0, 0.0)));
        // ... and the cap's equator joins the waist at zj = h (1 - cap) = 1.2 with radius rx.
        assert!(hb.body.contains(DVec3::new(5.0 + 2.0 - 1e-9, 5.0, 1.2)));
        assert!(!hb.body.contains(DVec3::new(5.0 + 2.0 + 1e-9, 5.0, 1.2)));
        for p in [e, hb] {
            assert!(p.body.bounds.max.x >= 5.0 + 3.0 || p.body.bounds.max.x >= 5.0 + r);
        }
    }
}
