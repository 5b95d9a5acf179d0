//! Second-order surfaces, the one primitive of the roks geometry kernel.
//!
//! A [`Quadric`] is the zero set of
//! `f(p) = A x² + B y² + C z² + D xy + E yz + F xz + G x + H y + J z + K`
//! where `(x, y, z) = p - origin`. Keeping a local origin (rather than folding
//! a translation into G, H, J, K) keeps `f` accurate for small surfaces far
//! from the coordinate origin: a bump of radius 3e-5 at x = 30 loses no digits.
//! Translating a quadric moves its origin and is exact.
//!
//! Lengths are in the scene's (relative) units; geometric optics has no scale.
//!
//! # Ray crossings without a fudge epsilon
//! Along a ray `p(t) = o + t d`, `f(p(t)) = a t² + 2 b t + c`. The roots are
//! found with the cancellation-free form `q = -(b + sign(b) sqrt(b² - a c))`,
//! `t = q / a, c / q`. The side of the surface at any `t` is then derived from
//! the roots alone (it starts at `sign(a)` at `t = -inf` and flips at each
//! root), so sides and crossings can never disagree. A photon standing on the
//! surface (it was just reflected there) passes `on_surface = true`: `c` is set
//! to exactly 0 for the side and the root at the start, so one root is exactly
//! `t = 0`; the other, `-2b/a`, then gets the first-order correction for the
//! standing point's rounding, `+f(o)/(2b)`. This is how OpenMC treats the
//! surface a particle stands on; no offset, no lost or doubled hits.

use glam::DVec3;

/// A general second-order surface with a local origin.
///
/// Coefficients act on `p - origin`; names follow OpenMC / the scene format:
/// `A x² + B y² + C z² + D xy + E yz + F xz + G x + H y + J z + K`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadric {
    /// Reference point of the coefficients (length units).
    pub origin: DVec3,
    /// `[A, B, C, D, E, F, G, H, J, K]`.
    pub coef: [f64; 10],
}

/// An axis-aligned quadric (no xy, yz, xz terms) in the form the hot loop
/// wants: `f(p) = q . (diag * q) + lin . q + k`, `q = p - origin`. Every bump
/// ellipsoid, paraboloid and plane is one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diagonal {
    /// Reference point `origin` (length units).
    pub origin: DVec3,
    /// `(A, B, C)`, the squared terms.
    pub diag: DVec3,
    /// `(G, H, J)`, the linear terms.
    pub lin: DVec3,
    /// `K`, the constant term.
    pub k: f64,
}

impl Diagonal {
    /// The diagonal form of `q`, if it has no cross terms.
    #[must_use]
    pub fn of(q: &Quadric) -> Option<Self> {
        let [a, b, c, dd, e, f, g, h, j, k] = q.coef;
        (dd == 0.0 && e == 0.0 && f == 0.0).then(|| Self {
            origin: q.origin,
            diag: DVec3::new(a, b, c),
            lin: DVec3::new(g, h, j),
            k,
        })
    }

    /// As [`Quadric::ray_coefficients`] (the same arithmetic, so the same bits).
    #[must_use]
    #[inline(always)]
    pub fn ray_coefficients(&self, o: DVec3, d: DVec3) -> (f64, f64, f64) {
        let q = o - self.origin;
        let (mq, md) = (self.diag * q, self.diag * d);
        (
            d.dot(md),
            d.dot(mq) + 0.5 * self.lin.dot(d),
            q.dot(mq) + self.lin.dot(q) + self.k,
        )
    }
}

/// Crossings of a ray with a quadric within `(0, t_max]`.
///
/// The side of the surface is `positive_at_start` just after `t = 0` and flips
/// at each entry of `t` (ascending). A tangent touch gives two equal entries,
/// i.e. no net change of side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossings {
    /// Crossing distances (units of `|d|`), ascending; only `t[..n]` are valid.
    pub t: [f64; 2],
    /// Number of valid crossings (0, 1 or 2).
    pub n: usize,
    /// True when the ray is on the positive side (`f > 0`) just after `t = 0`.
    pub positive_at_start: bool,
    /// True when `b² - a c` cancelled by more than about 10 bits: the roots
    /// should be polished with [`Quadric::refine_root`] before use.
    pub ill_conditioned: bool,
}

impl Quadric {
    /// A quadric from its ten coefficients about the coordinate origin.
    #[must_use]
    pub const fn general(coef: [f64; 10]) -> Self {
        Self {
            origin: DVec3::ZERO,
            coef,
        }
    }

    /// The plane `a x + b y + c z - d = 0` (the scene's `plane = [a, b, c, d]`).
    ///
    /// The negative side is where `a x + b y + c z < d`.
    #[must_use]
    pub const fn plane(a: f64, b: f64, c: f64, d: f64) -> Self {
        Self::general([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, a, b, c, -d])
    }

    /// The horizontal plane `z = z0`; negative below it.
    #[must_use]
    pub fn plane_z(z0: f64) -> Self {
        Self {
            origin: DVec3::new(0.0, 0.0, z0),
            coef: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        }
    }

    /// An axis-aligned ellipsoid with the given centre and semi-axes; negative inside.
    #[must_use]
    pub fn ellipsoid(center: DVec3, semi_axes: DVec3) -> Self {
        let s = semi_axes.recip() * semi_axes.recip();
        Self {
            origin: center,
            coef: [s.x, s.y, s.z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0],
        }
    }

    /// A sphere; negative inside.
    #[must_use]
    pub fn sphere(center: DVec3, radius: f64) -> Self {
        Self::ellipsoid(center, DVec3::splat(radius))
    }

    /// An infinite circular cylinder of radius `r` along coordinate `axis`
    /// (0 = x, 1 = y, 2 = z) through `point`; negative inside.
    #[must_use]
    pub fn cylinder(axis: usize, point: DVec3, r: f64) -> Self {
        let mut coef = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -r * r];
        coef[axis.min(2)] = 0.0;
        Self {
            origin: point,
            coef,
        }
    }

    /// A double circular cone along coordinate `axis` with apex `apex`:
    /// `rho² - t2 (s - s_apex)² = 0`, `t2` = tan² of the half-angle; negative inside.
    #[must_use]
    pub fn cone(axis: usize, apex: DVec3, t2: f64) -> Self {
        let mut coef = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        coef[axis.min(2)] = -t2;
        Self { origin: apex, coef }
    }

    /// An elliptic paraboloid opening downward from `apex`, reaching radii
    /// `(rx, ry)` at depth `depth` below it:
    /// `(x/rx)² + (y/ry)² + (z - z_apex)/depth = 0`; negative inside (below).
    #[must_use]
    pub fn paraboloid_down(apex: DVec3, rx: f64, ry: f64, depth: f64) -> Self {
        Self {
            origin: apex,
            coef: [
                1.0 / (rx * rx),
                1.0 / (ry * ry),
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                1.0 / depth,
                0.0,
            ],
        }
    }

    /// An elliptic cone with apex at `apex`, opening downward, reaching radii
    /// `(rx, ry)` at depth `depth` below the apex (both nappes; cut it with a plane).
    #[must_use]
    pub fn cone_down(apex: DVec3, rx: f64, ry: f64, depth: f64) -> Self {
        Self {
            origin: apex,
            coef: [
                1.0 / (rx * rx),
                1.0 / (ry * ry),
                -1.0 / (depth * depth),
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
        }
    }

    /// An elliptic hyperboloid of one sheet with vertical axis and waist at
    /// `waist` (semi-axes `rx, ry` there): `(x/rx)² + (y/ry)² - (z/c)² - 1 = 0`;
    /// negative inside.
    #[must_use]
    pub fn hyperboloid_one_sheet(waist: DVec3, rx: f64, ry: f64, c: f64) -> Self {
        Self {
            origin: waist,
            coef: [
                1.0 / (rx * rx),
                1.0 / (ry * ry),
                -1.0 / (c * c),
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                -1.0,
            ],
        }
    }

    /// The same surface translated by `delta` (exact: only the origin moves).
    #[must_use]
    pub fn translated(&self, delta: DVec3) -> Self {
        Self {
            origin: self.origin + delta,
            coef: self.coef,
        }
    }

    /// The same surface with all lengths multiplied by `s > 0` (sides preserved).
    ///
    /// Coefficients of degree n are divided by `s^n`; the constant term is kept,
    /// so `f` keeps its sign everywhere.
    #[must_use]
    pub fn scaled(&self, s: f64) -> Self {
        let [a, b, c, d, e, f, g, h, j, k] = self.coef;
        let s2 = s * s;
        Self {
            origin: self.origin * s,
            coef: [
                a / s2,
                b / s2,
                c / s2,
                d / s2,
                e / s2,
                f / s2,
                g / s,
                h / s,
                j / s,
                k,
            ],
        }
    }

    /// `f(p)`.
    #[must_use]
    #[inline]
    pub fn eval(&self, p: DVec3) -> f64 {
        let [a, b, c, d, e, f, g, h, j, k] = self.coef;
        let q = p - self.origin;
        let (x, y, z) = (q.x, q.y, q.z);
        x * (a * x + d * y + f * z + g) + y * (b * y + e * z + h) + z * (c * z + j) + k
    }

    /// `grad f(p)` (not normalised; units of f per length).
    #[must_use]
    #[inline]
    pub fn gradient(&self, p: DVec3) -> DVec3 {
        let [a, b, c, d, e, f, g, h, j, _] = self.coef;
        let q = p - self.origin;
        let (x, y, z) = (q.x, q.y, q.z);
        DVec3::new(
            2.0 * a * x + d * y + f * z + g,
            2.0 * b * y + d * x + e * z + h,
            2.0 * c * z + e * y + f * x + j,
        )
    }

    /// Unit normal at `p`, oriented against the direction `d` (so that `n . d <= 0`).
    ///
    /// Returns `None` where the gradient vanishes (a cone apex) or is not finite.
    #[must_use]
    #[inline]
    pub fn facing_normal(&self, p: DVec3, d: DVec3) -> Option<DVec3> {
        let n = self.gradient(p).try_normalize()?;
        Some(if n.dot(d) > 0.0 { -n } else { n })
    }

    /// Coefficients `(a, b, c)` of `f(o + t d) = a t² + 2 b t + c`.
    #[must_use]
    #[inline(always)]
    pub fn ray_coefficients(&self, o: DVec3, d: DVec3) -> (f64, f64, f64) {
        let [a, b, c, dd, e, f, g, h, j, k] = self.coef;
        let q = o - self.origin;
        let lin = DVec3::new(g, h, j);
        if let Some(diag) = Diagonal::of(self) {
            return diag.ray_coefficients(o, d);
        }
        // M p with M the symmetric matrix of the quadratic part (off-diagonals halved).
        let m = |p: DVec3| {
            DVec3::new(
                a * p.x + 0.5 * (dd * p.y + f * p.z),
                b * p.y + 0.5 * (dd * p.x + e * p.z),
                c * p.z + 0.5 * (e * p.y + f * p.x),
            )
        };
        let (mq, md) = (m(q), m(d));
        let qa = d.dot(md);
        let half_b = d.dot(mq) + 0.5 * lin.dot(d);
        let qc = q.dot(mq) + lin.dot(q) + k;
        (qa, half_b, qc)
    }

    /// A root `t` of the ray `o + t d` polished by one correction step solved at
    /// the point `o + t d` itself.
    ///
    /// When the ray starts far from a small surface, `b² - a c` cancels and the
    /// root loses digits (relative error ~ eps (distance / size)²); at the
    /// nearby point the constant term is tiny and the small root of the local
    /// quadratic recovers them. Returns `t` unchanged if the step is not finite
    /// or would not stay positive.
    #[must_use]
    #[inline]
    pub fn refine_root(&self, o: DVec3, d: DVec3, t: f64) -> f64 {
        let (a, b, c) = self.ray_coefficients(o + t * d, d);
        let disc = (b * b - a * c).max(0.0);
        let q = -(b + disc.sqrt().copysign(b));
        let step = if a == 0.0 && b != 0.0 {
            -c / (2.0 * b)
        } else {
            c / q
        };
        let refined = t + step;
        if step.is_finite() && refined > 0.0 {
            refined
        } else {
            t
        }
    }

    /// Crossings of the ray `o + t d`, `t` in `(0, t_max]`, with this surface.
    ///
    /// `on_surface`: the ray starts on this surface. The side and the root at
    /// the start are taken from `c = 0` exactly (see the module docs); the far
    /// root is then moved by the rounding of the standing point, see
    /// [`standing_far_root`].
    #[must_use]
    #[inline]
    pub fn crossings(&self, o: DVec3, d: DVec3, t_max: f64, on_surface: bool) -> Crossings {
        let (a, b, c) = self.ray_coefficients(o, d);
        crossings_of_coefficients(a, b, c, t_max, on_surface)
    }
}

/// [`Quadric::crossings`] from the ray polynomial `a t² + 2 b t + c`.
#[inline(always)]
fn crossings_of_coefficients(a: f64, b: f64, c: f64, t_max: f64, on_surface: bool) -> Crossings {
    let mut out = quadratic_crossings(a, b, if on_surface { 0.0 } else { c }, t_max);
    if !on_surface {
        return out;
    }
    for t in &mut out.t[..out.n] {
        *t = standing_far_root(*t, b, c);
    }
    out
}

/// A quadric in the form whose ray polynomial is cheapest to form, for
/// loops that test the same surfaces at every flight (the cells of an
/// object). [`RayForm::crossings`] is bit for bit [`Quadric::crossings`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayForm {
    /// A plane (no squared or cross terms): `f(p) = lin . (p - origin) + k`,
    /// `lin = (G, H, J)`, `k = K`.
    Plane {
        /// Reference point `origin` (length units).
        origin: DVec3,
        /// `(G, H, J)`.
        lin: DVec3,
        /// `K`.
        k: f64,
    },
    /// Axis-aligned with some squared term.
    Diagonal(Diagonal),
    /// With cross terms.
    General(Quadric),
}

impl RayForm {
    /// The cheapest form of `q`.
    #[must_use]
    pub fn of(q: &Quadric) -> Self {
        match Diagonal::of(q) {
            Some(g) if g.diag == DVec3::ZERO => Self::Plane {
                origin: g.origin,
                lin: g.lin,
                k: g.k,
            },
            Some(g) => Self::Diagonal(g),
            None => Self::General(*q),
        }
    }

    /// Exactly [`Quadric::crossings`] of the quadric this form was made of.
    ///
    /// For a plane the diagonal form's `a = d . (0 d)` is `+0`, its `c`
    /// gains `q . (0 q) = +0`, and its `b` gains a signed zero, which
    /// changes nothing: `b + (±0) = b` unless `b` is zero, and a zero `b`
    /// of either sign means no crossing (finite rays; a non-finite one
    /// gives a non-finite `b` or `c` in both forms).
    #[must_use]
    #[inline(always)]
    pub fn crossings(&self, o: DVec3, d: DVec3, t_max: f64, on_surface: bool) -> Crossings {
        match self {
            Self::Plane { origin, lin, k } => {
                let q = o - *origin;
                let b = 0.5 * lin.dot(d);
                let c = (0.0 + lin.dot(q)) + k;
                if !on_surface {
                    return linear_crossings(b, c, t_max);
                }
                let mut out = linear_crossings(b, 0.0, t_max);
                for t in &mut out.t[..out.n] {
                    *t = standing_far_root(*t, b, c);
                }
                out
            }
            Self::Diagonal(g) => {
                let (a, b, c) = g.ray_coefficients(o, d);
                crossings_of_coefficients(a, b, c, t_max, on_surface)
            }
            Self::General(q) => q.crossings(o, d, t_max, on_surface),
        }
    }
}

/// Exactly [`crossings_of_quadratic`] with `a = 0`: the crossing of
/// `2 b t + c` in `(0, t_max]` and the side just after 0.
#[must_use]
#[inline(always)]
pub fn linear_crossings(b: f64, c: f64, t_max: f64) -> Crossings {
    let mut out = Crossings {
        t: [f64::INFINITY; 2],
        n: 0,
        positive_at_start: c > 0.0,
        ill_conditioned: false,
    };
    // Not finite, or constant: no crossing, the side of c.
    if !(b.is_finite() && c.is_finite()) || b == 0.0 {
        return out;
    }
    let r = -c / (2.0 * b);
    // Negative at -inf when b > 0; flipped by a root at or behind the start.
    let mut positive = b < 0.0;
    if r <= 0.0 {
        positive = !positive;
    } else if r <= t_max {
        out.t[0] = r;
        out.n = 1;
    }
    out.positive_at_start = positive;
    out
}

/// The far root `t` of a ray standing on a surface, computed with `c = 0`
/// (where it is `-2b/a`), corrected for the actual `c = f(o)`.
///
/// The standing point is on the surface only to rounding, `f(o) = c ≠ 0`.
/// The roots of `a t² + 2 b t + c` are then `-c/(2b) + O(c²)` (kept at exactly
/// 0, so the side at the start stays consistent) and `-2b/a + c/(2b)`. Without
/// the correction the far hit is off its surface by about
/// `|c| |∇f(p)·d| / |∇f(o)·d|`. The correction is dropped if it is not finite
/// or would move the root to or behind the start.
#[must_use]
#[inline(always)]
pub fn standing_far_root(t: f64, b: f64, c: f64) -> f64 {
    let corrected = t + c / (2.0 * b);
    if corrected > 0.0 && corrected.is_finite() {
        corrected
    } else {
        t
    }
}

/// Where the ray enters the negative side of `a t² + 2 b t + c` for the
/// first time in `(0, t_max]`, and whether the root is ill-conditioned.
///
/// The fast path for bodies made of one quadric (`-q`). It gives exactly
/// the answer of [`crossings_of_quadratic`] followed by a scan for the first
/// positive-to-negative flip (see the test that compares them): roots at or
/// below zero count as already crossed, tangent (double) roots do not enter.
#[must_use]
#[inline(always)]
pub fn entry_negative(a: f64, b: f64, c: f64, t_max: f64) -> Option<(f64, bool)> {
    if a == 0.0 {
        // Linear: positive before the root when b < 0.
        if b < 0.0 {
            let t = -c / (2.0 * b);
            return (t > 0.0 && t <= t_max).then_some((t, false));
        }
        return None;
    }
    let disc = b * b - a * c;
    // Also rejects a NaN discriminant.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(disc > 0.0) {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return None;
    }
    let (r1, r2) = (q / a, c / q);
    let (lo, hi) = if r1 <= r2 { (r1, r2) } else { (r2, r1) };
    // a > 0: negative between the roots, entered at the lower one if it is ahead.
    // a < 0: negative outside them, (re-)entered at the upper one if it is ahead.
    let t = if a > 0.0 {
        if lo > 0.0 { lo } else { return None }
    } else if hi > 0.0 {
        hi
    } else {
        return None;
    };
    if t > t_max {
        return None;
    }
    let ill = (b * b).max((a * c).abs()) > 1024.0 * disc;
    Some((t, ill))
}

/// Crossings in `(0, t_max]` of `a t² + 2 b t + c`, and its side just after 0.
///
/// The side is derived from the roots (see the module docs), so a root at or
/// below zero is consistently "already crossed". Non-finite input gives no
/// crossings and the sign of `c` (callers guard against NaN rays).
#[must_use]
#[inline]
pub fn crossings_of_quadratic(a: f64, b: f64, c: f64, t_max: f64) -> Crossings {
    quadratic_crossings(a, b, c, t_max)
}

/// [`crossings_of_quadratic`] inlined into the loops over cell surfaces.
#[inline(always)]
fn quadratic_crossings(a: f64, b: f64, c: f64, t_max: f64) -> Crossings {
    let mut out = Crossings {
        t: [f64::INFINITY; 2],
        n: 0,
        positive_at_start: c > 0.0,
        ill_conditioned: a != 0.0 && (b * b).max((a * c).abs()) > 1024.0 * (b * b - a * c).abs(),
    };
    let (roots, n_roots, sign_at_minus_inf) = real_roots(a, b, c);
    let Some(mut positive) = sign_at_minus_inf else {
        return out;
    };
    for &r in &roots[..n_roots] {
        if r <= 0.0 {
            positive = !positive;
        } else if r <= t_max {
            out.t[out.n] = r;
            out.n += 1;
        }
    }
    out.positive_at_start = positive;
    out
}

/// Real roots of `a t² + 2 b t + c` (ascending) and the sign of the polynomial
/// as `t -> -inf` (`Some(true)` = positive). `None` for the sign when the
/// polynomial is identically constant zero or not finite.
#[inline]
fn real_roots(a: f64, b: f64, c: f64) -> ([f64; 2], usize, Option<bool>) {
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return ([0.0; 2], 0, None);
    }
    if a == 0.0 {
        if b == 0.0 {
            // Constant polynomial: no crossing; side from c (c = 0: on a degenerate surface).
            return ([0.0; 2], 0, if c == 0.0 { None } else { Some(c > 0.0) });
        }
        // Linear: single root; negative at -inf when b > 0.
        return ([-c / (2.0 * b), 0.0], 1, Some(b < 0.0));
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return ([0.0; 2], 0, Some(a > 0.0));
    }
    if disc == 0.0 {
        // A tangent: one double root, exactly equal so that it flips twice.
        let r = -b / a;
        return ([r, r], 2, Some(a > 0.0));
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        // b = 0 and a c = 0 with a != 0, so c = 0: a double root at t = 0.
        return ([0.0, 0.0], 2, Some(a > 0.0));
    }
    let (r1, r2) = (q / a, c / q);
    let roots = if r1 <= r2 { [r1, r2] } else { [r2, r1] };
    ([roots[0], roots[1]], 2, Some(a > 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stream of numbers in [-1, 1) (a 64-bit LCG), the
    /// rays and coefficients of the sweeps below.
    fn stream(seed: u64) -> impl FnMut() -> f64 {
        let mut uniform = crate::test_streams::uniform(seed);
        move || uniform() * 2.0 - 1.0
    }

    fn side_by_eval(q: &Quadric, o: DVec3, d: DVec3, t: f64) -> bool {
        q.eval(o + t * d) > 0.0
    }

    #[test]
    fn unit_sphere_from_outside_hits_at_distance_r_minus_one() {
        let s = Quadric::sphere(DVec3::ZERO, 1.0);
        let c = s.crossings(
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::NEG_Z,
            f64::INFINITY,
            false,
        );
        assert_eq!(c.n, 2);
        assert!(c.positive_at_start);
        assert_eq!(c.t, [4.0, 6.0]);
    }

    #[test]
    fn on_surface_has_exactly_one_root_at_zero_and_one_at_minus_2b_over_a() {
        // Start on a sphere of radius 3 at (3,0,0), heading inward along -x: other root at 6.
        let s = Quadric::sphere(DVec3::new(10.0, -4.0, 2.0), 3.0);
        let o = DVec3::new(13.0, -4.0, 2.0);
        let inward = s.crossings(o, DVec3::NEG_X, f64::INFINITY, true);
        assert!(!inward.positive_at_start);
        assert_eq!(inward.n, 1);
        assert_eq!(inward.t[0], 6.0);
        let outward = s.crossings(o, DVec3::X, f64::INFINITY, true);
        assert!(outward.positive_at_start);
        assert_eq!(outward.n, 0);
        // Tangent on the surface: stays outside, no crossing.
        let tangent = s.crossings(o, DVec3::Y, f64::INFINITY, true);
        assert!(tangent.positive_at_start);
        assert_eq!(tangent.n, 0);
    }

    #[test]
    fn standing_far_root_is_corrected_for_the_rounding_of_the_start() {
        // Standing 1e-9 outside a unit sphere, heading through its centre:
        // the actual crossings are r0 - 1 (the "start", taken as 0) and r0 + 1.
        let s = Quadric::sphere(DVec3::ZERO, 1.0);
        let r0 = 1.0 + 1e-9;
        let c = s.crossings(DVec3::new(r0, 0.0, 0.0), DVec3::NEG_X, 10.0, true);
        assert!(!c.positive_at_start);
        assert_eq!(c.n, 1);
        // Uncorrected -2b/a = 2 r0 would be 1e-9 too far.
        assert!((c.t[0] - (r0 + 1.0)).abs() < 1e-15, "{c:?}");
        // Exactly on the surface nothing changes.
        let on = s.crossings(DVec3::X, DVec3::NEG_X, 10.0, true);
        assert_eq!(on.t[0], 2.0);
    }

    #[test]
    fn tangent_ray_gives_double_root_or_nothing_never_a_single_flip() {
        let s = Quadric::sphere(DVec3::ZERO, 1.0);
        let c = s.crossings(DVec3::new(-5.0, 1.0, 0.0), DVec3::X, f64::INFINITY, false);
        assert!(c.positive_at_start);
        assert!(c.n == 0 || c.n == 2, "{c:?}");
        if c.n == 2 {
            assert_eq!(c.t[0], c.t[1]);
        }
    }

    #[test]
    fn stable_roots_for_nearly_linear_quadratic() {
        // a tiny: the naive formula loses the small root to cancellation.
        let c = crossings_of_quadratic(1e-20, -1.0, 1.0, f64::INFINITY);
        assert_eq!(c.n, 2);
        assert!((c.t[0] - 0.5).abs() < 1e-15, "{c:?}");
        let lin = crossings_of_quadratic(0.0, -1.0, 1.0, f64::INFINITY);
        assert_eq!((lin.n, lin.t[0], lin.positive_at_start), (1, 0.5, true));
    }

    /// The one-quadric fast path agrees with the general crossing logic on
    /// random quadratics, including rays standing on the surface (c = 0),
    /// linear ones (a = 0) and tangents (disc = 0).
    #[test]
    fn entry_negative_matches_general_crossings() {
        let mut uniform = stream(99);
        let mut next = || uniform() * 4.0;
        let general = |a: f64, b: f64, c: f64, t_max: f64| {
            let cr = crossings_of_quadratic(a, b, c, t_max);
            let mut positive = cr.positive_at_start;
            for &t in &cr.t[..cr.n] {
                if positive && cr.n == 2 && cr.t[0] == cr.t[1] {
                    return None;
                }
                if positive {
                    return Some(t);
                }
                positive = !positive;
            }
            None
        };
        for k in 0..20000 {
            let (mut a, b, mut c) = (next(), next(), next());
            match k % 5 {
                0 => c = 0.0,
                1 => a = 0.0,
                2 => c = b * b / a, // tangent (up to rounding)
                3 => a = a.round(),
                _ => {}
            }
            let t_max = next().abs() * 3.0;
            assert_eq!(
                entry_negative(a, b, c, t_max).map(|e| e.0),
                general(a, b, c, t_max),
                "a={a} b={b} c={c} t_max={t_max}"
            );
        }
    }

    /// Ray forms give the crossings of their quadrics bit for bit, planes
    /// (axis-aligned, tilted, with an origin) included, standing or not.
    #[test]
    fn ray_forms_cross_as_their_quadrics() {
        let quadrics = [
            Quadric::plane(0.0, 0.0, 1.0, -100.0),
            Quadric::plane(0.0, 0.0, -2.0, 0.0),
            Quadric::plane(0.3, -0.2, 1.0, 0.1),
            Quadric::plane_z(0.25),
            Quadric::plane(1.0, 0.0, 0.0, 0.0),
            Quadric::cone(2, DVec3::new(0.0, 0.0, 1.0), 0.25),
            Quadric::cylinder(2, DVec3::ZERO, 0.5),
            Quadric::sphere(DVec3::new(0.2, -0.1, 0.3), 0.7),
            Quadric::general([1.0, 2.0, -1.0, 0.5, 0.0, 0.1, 0.0, 1.0, 0.0, -0.3]),
        ];
        assert!(matches!(RayForm::of(&quadrics[0]), RayForm::Plane { .. }));
        assert!(matches!(RayForm::of(&quadrics[5]), RayForm::Diagonal(_)));
        assert!(matches!(RayForm::of(&quadrics[8]), RayForm::General(_)));
        let mut next = stream(4242);
        let axes = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::NEG_X, DVec3::NEG_Z];
        for q in &quadrics {
            let form = RayForm::of(q);
            for k in 0..4000 {
                let mut o = DVec3::new(next(), next(), next()) * 2.0;
                let d = if k % 7 == 0 {
                    axes[k % axes.len()]
                } else {
                    let Some(d) = DVec3::new(next(), next(), next()).try_normalize() else {
                        continue;
                    };
                    d
                };
                if k % 3 == 0 {
                    // Start on the surface (to rounding), where a crossing is.
                    if let Some(&t) = q.crossings(o, d, f64::INFINITY, false).t.first() {
                        if t.is_finite() {
                            o += t * d;
                        }
                    }
                }
                if k % 11 == 0 {
                    o.z = 0.0;
                }
                for on in [false, true] {
                    for t_max in [f64::INFINITY, 1.0] {
                        assert_eq!(
                            form.crossings(o, d, t_max, on),
                            q.crossings(o, d, t_max, on),
                            "{q:?} {o} {d} {on}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn plane_and_paraboloid_sides_match_evaluation() {
        let p = Quadric::plane(-1.0, 0.0, 1.0, 0.0); // z < x is negative
        assert!(p.eval(DVec3::new(1.0, 0.0, 0.5)) < 0.0);
        let par = Quadric::paraboloid_down(DVec3::new(1.0, 2.0, 3.0), 2.0, 2.0, 3.0);
        assert_eq!(par.eval(DVec3::new(3.0, 2.0, 0.0)), 0.0);
        assert!(par.eval(DVec3::new(1.0, 2.0, 2.0)) < 0.0);
    }

    #[test]
    fn translation_and_scaling_keep_values_to_rounding() {
        let e = Quadric::ellipsoid(DVec3::new(0.3, 0.1, -0.2), DVec3::new(2.0, 1.0, 0.5));
        let p = DVec3::new(1.1, 0.4, 0.1);
        // A whole-period shift of a power of two is exact in binary.
        let shift = DVec3::new(32.0, -32.0, 0.0);
        assert_eq!(e.translated(shift).eval(p + shift), e.eval(p));
        for s in [1e-3, 1e3, 1e-9, 1e9] {
            let es = e.scaled(s);
            let rel = (es.eval(p * s) - e.eval(p)).abs() / e.eval(p).abs();
            assert!(rel < 1e-14, "scale {s}: {rel}");
        }
    }

    #[test]
    fn small_far_surface_keeps_precision_after_refinement() {
        // A sphere of radius 3e-5 seen from distance 1: the plain root is off by
        // ~eps (1/r)² r; the refined one by a few ulps of t.
        let r = 3e-5;
        let s = Quadric::sphere(DVec3::new(30.0, 30.0, 0.0), r);
        for (o, d) in [
            (DVec3::new(30.0, 30.0, 1.0), DVec3::NEG_Z),
            (DVec3::new(29.0, 30.0, 0.0), DVec3::X),
        ] {
            let c = s.crossings(o, d, f64::INFINITY, false);
            assert_eq!(c.n, 2);
            let plain_error = (c.t[0] - (1.0 - r)).abs();
            let t = s.refine_root(o, d, c.t[0]);
            // Exact to the rounding of coordinates near 30 (the hit point's own precision).
            let ulp30 = 30.0 * f64::EPSILON;
            assert!((t - (1.0 - r)).abs() <= ulp30, "{}", t - (1.0 - r));
            assert!(
                plain_error > 100.0 * ulp30,
                "the test must exercise the cancellation"
            );
        }
    }

    #[test]
    fn sides_from_roots_agree_with_evaluation_away_from_roots() {
        // Deterministic sweep of rays against assorted quadrics.
        let quadrics = [
            Quadric::sphere(DVec3::new(0.2, -0.1, 0.3), 0.7),
            Quadric::cone(2, DVec3::new(0.0, 0.0, 1.0), 0.25),
            Quadric::cylinder(0, DVec3::ZERO, 0.5),
            Quadric::hyperboloid_one_sheet(DVec3::ZERO, 0.5, 0.8, 0.3),
            Quadric::plane(0.3, -0.2, 1.0, 0.1),
            Quadric::paraboloid_down(DVec3::ZERO, 1.0, 0.5, 2.0),
        ];
        let mut next = stream(12345);
        for q in &quadrics {
            for _ in 0..2000 {
                let o = DVec3::new(next(), next(), next()) * 2.0;
                let Some(d) = DVec3::new(next(), next(), next()).try_normalize() else {
                    continue;
                };
                let c = q.crossings(o, d, 10.0, false);
                // Probe midway between consecutive crossings.
                let mut edges = vec![0.0];
                edges.extend_from_slice(&c.t[..c.n]);
                edges.push(10.0);
                let mut positive = c.positive_at_start;
                for w in edges.windows(2) {
                    if w[1] - w[0] > 1e-6 {
                        let mid = 0.5 * (w[0] + w[1]);
                        assert_eq!(side_by_eval(q, o, d, mid), positive, "{q:?} {o} {d} {c:?}");
                    }
                    positive = !positive;
                }
            }
        }
    }
}
