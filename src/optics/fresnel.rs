//! Fresnel reflectance of a smooth interface between vacuum (or air, refractive
//! index 1) and a medium with complex refractive index `n + i k`.
//!
//! The formulas are the classic real-arithmetic closed form (Born & Wolf,
//! *Principles of Optics*, §14.2; also pbrt's conductor Fresnel term). With
//! `c = cos θi`, `s = sin θi` and
//!
//! ```text
//! a² + b² = sqrt((n² − k² − s²)² + 4 n² k²)
//! a²      = (a² + b² + n² − k² − s²) / 2
//! b²      = (a² + b² − n² + k² + s²) / 2
//! ```
//!
//! (`a + i b = sqrt((n + i k)² − s²)`, the principal branch, which is the
//! physical one: `a, b ≥ 0` for `k ≥ 0`), the power reflectances are
//!
//! ```text
//! Rs = ((a − c)² + b²) / ((a + c)² + b²)
//! Rp = Rs · ((a c − s²)² + b² c²) / ((a c + s²)² + b² c²)
//! ```
//!
//! The `Rp` factor is the textbook `(a² + b² − 2 a s tan θ + s² tan² θ) /
//! (a² + b² + 2 a s tan θ + s² tan² θ)` multiplied through by `c²`, so it never
//! divides by `cos θi` and is exact at grazing incidence (`R = 1`). Numerators
//! and denominators are written as sums of squares, so they are never
//! negative and do not suffer from cancellation when `a ≈ c` (e.g. `n ≈ 1`).
//!
//! Dielectrics with `n < 1`, `k = 0` (e.g. X-ray-like indices, or an index
//! ratio seen from the optically denser side) are handled by the same
//! formula: beyond the critical angle `a = 0` and both `Rs` and `Rp` are
//! exactly 1.

use super::polarisation::{Mueller, Stokes};

/// Reflectances `(Rs, Rp)` for s- and p-polarised light (dimensionless, in
/// `[0, 1]`) at a smooth interface from index 1 into a medium of complex
/// refractive index `n + i k`.
///
/// * `cos_i` — cosine of the angle of incidence measured from the surface
///   normal (dimensionless); values outside `[0, 1]` are clamped to it.
/// * `n` — real part of the refractive index (dimensionless, `> 0`).
/// * `k` — extinction coefficient (dimensionless, `≥ 0`; `0` for a lossless
///   dielectric).
///
/// Never panics. For physically meaningless parameters (non-finite values,
/// `n ≤ 0`, `k < 0`) the result is unspecified and may be NaN; validate
/// parameters first (see [`crate::optics::Reflectance::validate`]). A NaN
/// `cos_i` gives NaN.
#[must_use]
pub fn fresnel_sp(cos_i: f64, n: f64, k: f64) -> (f64, f64) {
    let c = cos_i.clamp(0.0, 1.0);
    // |n + ik| <= sqrt(2) max(|n|, |k|): below HUGE_INDEX without a hypot
    // when both are below HUGE_INDEX / 2 (NaN goes to the hypot).
    let small = n.abs() < 0.5 * HUGE_INDEX && k.abs() < 0.5 * HUGE_INDEX;
    if !small && n.hypot(k) > HUGE_INDEX {
        return fresnel_sp_scaled(c, n, k);
    }
    // sin²θ computed as (1 − c)(1 + c) is accurate near normal incidence.
    let s2 = ((1.0 - c) * (1.0 + c)).max(0.0);
    // n² − k² − sin²θ written as (n − 1)(n + 1) − k² + c²: accurate near
    // grazing incidence and for n ≈ 1 (index-matched interfaces give a = c
    // and hence R = 0 at every angle).
    let t0 = (n - 1.0) * (n + 1.0) - k * k + c * c;
    // hypot avoids overflow/underflow of (t0² + 4 n² k²).
    let a2b2 = t0.hypot(2.0 * n * k);
    let a2 = (0.5 * (a2b2 + t0)).max(0.0);
    let b2 = (0.5 * (a2b2 - t0)).max(0.0);
    let a = a2.sqrt();

    let ac = a - c;
    let apc = a + c;
    // Denominator is zero only for a = b = c = 0, i.e. n = 1, k = 0 at
    // grazing incidence: no interface at all, so R = 0 (the limit value).
    let rs = ratio((ac * ac) + b2, (apc * apc) + b2, 0.0);

    let acs_m = a * c - s2;
    let acs_p = a * c + s2;
    let b2c2 = b2 * c * c;
    // Denominator is zero only for s = 0 and a = b = 0 (n = k = 0, invalid):
    // fall back to Rp = Rs, the normal-incidence identity.
    let factor = ratio(acs_m * acs_m + b2c2, acs_p * acs_p + b2c2, 1.0);
    let rp = rs * factor;
    (unit(rs), unit(rp))
}

/// Above this `|n + ik|` the squares in [`fresnel_sp`] overflow (`n² - k²`
/// is `inf - inf`: Rs came out 0 at grazing incidence for n = k = 1e200);
/// [`fresnel_sp_scaled`] is used instead.
const HUGE_INDEX: f64 = 1e100;

/// [`fresnel_sp`] for huge `|m|`, `m = n + ik`, in terms of `m̂ = m / |m|`
/// and `e = 1 / |m|`: `u e = sqrt(m̂² - sin² θ e²)` (principal root),
/// `rs = (c e - u e)/(c e + u e)`, `cos θt = u e / m̂`,
/// `rp = (m̂ c - cos θt e)/(m̂ c + cos θt e)`, all finite.
fn fresnel_sp_scaled(c: f64, n: f64, k: f64) -> (f64, f64) {
    let e = 1.0 / n.hypot(k);
    let (hn, hk) = (n * e, k * e);
    let sin2e2 = ((1.0 - c) * (1.0 + c)).max(0.0) * e * e;
    let (wr, wi) = ((hn - hk) * (hn + hk) - sin2e2, 2.0 * hn * hk);
    let r = wr.hypot(wi);
    let ua = (0.5 * (r + wr)).max(0.0).sqrt();
    let ub = (0.5 * (r - wr)).max(0.0).sqrt();
    // Ratios of moduli by hypot, squared afterwards: `e²` would underflow.
    let rs = ratio((c * e - ua).hypot(ub), (c * e + ua).hypot(ub), 0.0).powi(2);
    // cos θt = (ua + i ub) / (hn + i hk) (|m̂| = 1), times e.
    let (ctr, cti) = ((ua * hn + ub * hk) * e, (ub * hn - ua * hk) * e);
    let rp = ratio(
        (hn * c - ctr).hypot(hk * c - cti),
        (hn * c + ctr).hypot(hk * c + cti),
        0.0,
    )
    .powi(2);
    (unit(rs), unit(rp))
}

/// Reflectance of unpolarised light, `(Rs + Rp) / 2` (dimensionless, in
/// `[0, 1]`), at a smooth interface from index 1 into a medium of complex
/// refractive index `n + i k`.
///
/// Parameters are as for [`fresnel_sp`]: `cos_i` is the cosine of the angle
/// of incidence (clamped to `[0, 1]`), `n > 0` the real index and `k ≥ 0`
/// the extinction coefficient. At normal incidence this is
/// `((n − 1)² + k²) / ((n + 1)² + k²)`; at grazing incidence (`cos_i = 0`) it
/// is exactly 1 for any interface with `(n, k) ≠ (1, 0)`.
///
/// Never panics; invalid parameters may give NaN (see [`fresnel_sp`]).
#[must_use]
pub fn fresnel_unpolarised(cos_i: f64, n: f64, k: f64) -> f64 {
    let (rs, rp) = fresnel_sp(cos_i, n, k);
    0.5 * (rs + rp)
}

/// `num / den`, or `fallback` when `den == 0`.
fn ratio(num: f64, den: f64, fallback: f64) -> f64 {
    if den == 0.0 { fallback } else { num / den }
}

/// Clamp rounding excursions into `[0, 1]`; NaN passes through.
fn unit(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

/// Wavelengths per chunk of [`FresnelLanes::chunk`].
pub const CHUNK: usize = 16;

/// The Fresnel reflection of many wavelengths at once: one material's
/// complex index `m_l = n_l + i k_l` per wavelength, stored by component
/// and padded to whole chunks of [`CHUNK`] so that the loops over
/// wavelengths compile to vector instructions.
///
/// For incidence cosine `c` (sine² `s²`), with `u = sqrt(m² - s²)`
/// (principal root, `Re u, Im u >= 0`):
/// `rs = (c - u) / (c + u)`, `rp = (m² c - u) / (m² c + u)` (Born & Wolf
/// §14.2), and the Mueller coefficients of
/// [`FresnelMueller`]: `a = (Rs + Rp) / 2`,
/// `b = (Rs - Rp) / 2`, `c + i d = rs rp*`. `u` comes from the real closed
/// form `|u|² = sqrt(t² + 4 n² k²)`, `t = (n - 1)(n + 1) - k² + c²`, its
/// larger component by a square root and the smaller as `n k` divided by
/// it (no cancellation). The results agree with [`fresnel_sp`] and
/// `FresnelMueller::new` to about 1e-13 (a unit test checks both against
/// complex arithmetic); a lane whose result is not finite, or whose
/// denominators overflow (indices beyond about 1e70 in modulus), or
/// `n = 1, k = 0` at grazing incidence, is computed again by those exact
/// scalar functions.
#[derive(Debug, Clone, PartialEq)]
pub struct FresnelLanes {
    len: usize,
    n: Vec<f64>,
    k: Vec<f64>,
    /// `(n - 1)(n + 1) - k²`.
    t: Vec<f64>,
    /// `n k`.
    nk: Vec<f64>,
    /// `Re m² = n² - k²`.
    m2r: Vec<f64>,
    /// `Im m² = 2 n k`.
    m2i: Vec<f64>,
}

/// The Fresnel coefficients of one chunk of wavelengths (see
/// [`FresnelLanes::chunk`]); `b`, `c`, `d` are zero when not asked for.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FresnelChunk {
    /// `(Rs + Rp) / 2`.
    pub a: [f64; CHUNK],
    /// `(Rs - Rp) / 2`.
    pub b: [f64; CHUNK],
    /// `Re(rs rp*)`.
    pub c: [f64; CHUNK],
    /// `Im(rs rp*)`.
    pub d: [f64; CHUNK],
}

impl FresnelChunk {
    /// Every coefficient zero.
    pub const ZERO: Self = Self {
        a: [0.0; CHUNK],
        b: [0.0; CHUNK],
        c: [0.0; CHUNK],
        d: [0.0; CHUNK],
    };
}

impl FresnelLanes {
    /// The lanes of indices `(n_l, k_l)` (each `n > 0`, `k >= 0`, finite).
    #[must_use]
    pub fn new(nk: &[(f64, f64)]) -> Self {
        let len = nk.len();
        // Padding lanes: glass, harmless and never read.
        let padded: Vec<(f64, f64)> = nk
            .iter()
            .copied()
            .chain(std::iter::repeat((1.5, 0.0)))
            .take(len.div_ceil(CHUNK).max(1) * CHUNK)
            .collect();
        let col = |f: &dyn Fn(f64, f64) -> f64| padded.iter().map(|&(n, k)| f(n, k)).collect();
        Self {
            len,
            n: col(&|n, _| n),
            k: col(&|_, k| k),
            t: col(&|n, k| (n - 1.0) * (n + 1.0) - k * k),
            nk: col(&|n, k| n * k),
            m2r: col(&|n, k| (n - k) * (n + k)),
            m2i: col(&|n, k| 2.0 * n * k),
        }
    }

    /// Number of wavelengths.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The coefficients of wavelengths `CHUNK * index ..` (up to `CHUNK`
    /// of them; lanes past [`FresnelLanes::len`] are padding) at incidence
    /// cosine `cos_i` (clamped to `[0, 1]`): `a` only, or with `MUELLER`
    /// all four.
    ///
    /// # Panics
    /// If the chunk lies past the lanes.
    #[must_use]
    pub fn chunk<const MUELLER: bool>(&self, cos_i: f64, index: usize) -> FresnelChunk {
        let mut out = FresnelChunk::ZERO;
        self.chunk_into::<MUELLER>(cos_i, index, &mut out);
        out
    }

    /// [`FresnelLanes::chunk`] into `out` (without `MUELLER`, `b`, `c`, `d`
    /// are left as they are): the form for loops over chunks, which keep
    /// one `out`.
    ///
    /// # Panics
    /// If the chunk lies past the lanes.
    #[inline(always)]
    pub fn chunk_into<const MUELLER: bool>(
        &self,
        cos_i: f64,
        index: usize,
        out: &mut FresnelChunk,
    ) {
        let c = cos_i.clamp(0.0, 1.0);
        let c2 = c * c;
        let range = CHUNK * index..CHUNK * (index + 1);
        let take =
            |v: &Vec<f64>| -> [f64; CHUNK] { v[range.clone()].try_into().expect("whole chunks") };
        let (t, nk, m2r, m2i) = (
            take(&self.t),
            take(&self.nk),
            take(&self.m2r),
            take(&self.m2i),
        );
        // The lanes in passes, each with one long-latency operation (square
        // root, division) per lane, so that the lanes' square roots and
        // divisions overlap instead of waiting on each other: the same
        // expressions as one pass, so the same numbers.
        let mut t0 = [0.0; CHUNK];
        let mut q = [0.0; CHUNK];
        for l in 0..CHUNK {
            t0[l] = t[l] + c2;
            q[l] = (t0[l] * t0[l] + 4.0 * nk[l] * nk[l]).sqrt();
        }
        let mut big = [0.0; CHUNK];
        for l in 0..CHUNK {
            big[l] = (0.5 * (q[l] + t0[l].abs())).sqrt();
        }
        let (mut ua, mut ub) = ([0.0; CHUNK], [0.0; CHUNK]);
        for l in 0..CHUNK {
            // big = 0 only for n k = 0 and t0 = 0: then small = 0 too.
            let small = nk[l] / big[l].max(f64::MIN_POSITIVE);
            let pos = t0[l] >= 0.0;
            ua[l] = if pos { big[l] } else { small };
            ub[l] = if pos { small } else { big[l] };
        }
        // NaN where a lane is not ordinary: a result that is not finite, or
        // a denominator that is zero (inv infinite) or overflows (infinite).
        let mut check = [0.0; CHUNK];
        for l in 0..CHUNK {
            let (ua, ub) = (ua[l], ub[l]);
            // rs = (c - u) / (c + u); rp = (m² c - u) / (m² c + u).
            let (sn0, sn1, sd0, sd1) = (c - ua, -ub, c + ua, ub);
            let (pn0, pn1) = (m2r[l] * c - ua, m2i[l] * c - ub);
            let (pd0, pd1) = (m2r[l] * c + ua, m2i[l] * c + ub);
            let ns = sn0 * sn0 + sn1 * sn1;
            let ds = sd0 * sd0 + sd1 * sd1;
            let np = pn0 * pn0 + pn1 * pn1;
            let dp = pd0 * pd0 + pd1 * pd1;
            let den = ds * dp;
            let inv = 1.0 / den;
            let (rs, rp) = (ns * dp * inv, np * ds * inv);
            out.a[l] = 0.5 * (rs + rp);
            if MUELLER {
                out.b[l] = 0.5 * (rs - rp);
                // rs rp* = (sn sd*) (pn pd*)* / (|sd|² |pd|²).
                let (zs0, zs1) = (sn0 * sd0 + sn1 * sd1, sn1 * sd0 - sn0 * sd1);
                let (zp0, zp1) = (pn0 * pd0 + pn1 * pd1, pn1 * pd0 - pn0 * pd1);
                out.c[l] = (zs0 * zp0 + zs1 * zp1) * inv;
                out.d[l] = (zs1 * zp0 - zs0 * zp1) * inv;
            }
            let mut sum = out.a[l] + den + inv;
            if MUELLER {
                sum += out.b[l] + out.c[l] + out.d[l];
            }
            check[l] = sum * 0.0;
        }
        let lanes = (self.len - CHUNK * index).min(CHUNK);
        // NaN propagates through the sum (a scalar reduction of CHUNK adds).
        if check[..lanes].iter().sum::<f64>().is_nan() {
            self.redo(c, index, lanes, &check, out);
        }
    }

    /// The lanes that are not ordinary, by the exact scalar functions.
    #[cold]
    fn redo(
        &self,
        c: f64,
        index: usize,
        lanes: usize,
        check: &[f64; CHUNK],
        out: &mut FresnelChunk,
    ) {
        for l in 0..lanes {
            if !check[l].is_nan() {
                continue;
            }
            let at = CHUNK * index + l;
            let f = FresnelMueller::new(c, self.n[at], self.k[at]);
            (out.a[l], out.b[l], out.c[l], out.d[l]) = (f.a, f.b, f.c, f.d);
        }
    }
}

/// The Fresnel reflection of a smooth interface as a Mueller matrix in the
/// s frames of the plane of incidence (see the module docs):
/// `[[a, b, 0, 0], [b, a, 0, 0], [0, 0, c, -d], [0, 0, d, c]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FresnelMueller {
    /// `(Rs + Rp) / 2`, the unpolarised reflectance.
    pub a: f64,
    /// `(Rs - Rp) / 2`, the diattenuation term.
    pub b: f64,
    /// `Re(rs rp*) = sqrt(Rs Rp) cos δ`.
    pub c: f64,
    /// `Im(rs rp*) = sqrt(Rs Rp) sin δ`, the retardance term.
    pub d: f64,
}

impl FresnelMueller {
    /// The matrix at incidence cosine `cos_i` (clamped to `[0, 1]`) from
    /// index 1 into `n + i k` (`n > 0`, `k >= 0`). `a` and `b` come from
    /// [`fresnel_sp`] (so `a` is bit for bit the unpolarised reflectance);
    /// `c`, `d` are `sqrt(Rs Rp)` times the phase of `rs rp*`, computed from
    /// unit phasors so that nothing overflows for huge indices and
    /// `c² + d² = Rs Rp` holds to rounding. Never panics; NaN in gives NaN out.
    #[must_use]
    pub fn new(cos_i: f64, n: f64, k: f64) -> Self {
        let cos = cos_i.clamp(0.0, 1.0);
        let (rs, rp) = fresnel_sp(cos, n, k);
        let a = 0.5 * (rs + rp);
        let b = 0.5 * (rs - rp);
        let amplitude = (rs * rp).sqrt();
        if amplitude == 0.0 {
            return Self {
                a,
                b,
                c: 0.0,
                d: 0.0,
            };
        }
        let (cos_d, sin_d) = phase_rs_rp(cos, n, k);
        Self {
            a,
            b,
            c: amplitude * cos_d,
            d: amplitude * sin_d,
        }
    }

    /// The full matrix.
    #[must_use]
    pub fn matrix(&self) -> Mueller {
        let Self { a, b, c, d } = *self;
        [
            [a, b, 0.0, 0.0],
            [b, a, 0.0, 0.0],
            [0.0, 0.0, c, -d],
            [0.0, 0.0, d, c],
        ]
    }

    /// Apply to a Stokes vector in the incoming s frame; the result is in
    /// the outgoing s frame.
    #[must_use]
    #[inline]
    pub fn apply(&self, s: Stokes) -> Stokes {
        let Self { a, b, c, d } = *self;
        [
            a * s[0] + b * s[1],
            b * s[0] + a * s[1],
            c * s[2] - d * s[3],
            d * s[2] + c * s[3],
        ]
    }
}

/// `(cos, sin)` of `arg(rs rp*)` for incidence cosine `cos` in `[0, 1]`.
///
/// Everything is computed in units of `scale = max(n, k, 1)`, so every
/// quantity is of order 1 and plain products cannot overflow; only the
/// phase of the product `(c - u)(c + u)* [(m c - cos θt)(m c + cos θt)*]*`
/// is needed, normalised once at the end.
fn phase_rs_rp(cos: f64, n: f64, k: f64) -> (f64, f64) {
    let scale = n.abs().max(k.abs()).max(1.0);
    let (n1, k1, c1, one) = (n / scale, k / scale, cos / scale, 1.0 / scale);
    // u = m cos θt = sqrt(m² - sin² θ), principal root (Re, Im >= 0), from
    // the same real closed form as `fresnel_sp` (here divided by `scale`).
    let t0 = (n1 - one) * (n1 + one) - k1 * k1 + c1 * c1;
    let a2b2 = (t0 * t0 + 4.0 * n1 * n1 * k1 * k1).sqrt();
    let ua = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let ub = (0.5 * (a2b2 - t0)).max(0.0).sqrt();
    // rs = (c - u)/(c + u).
    let ps = mul_conj((c1 - ua, -ub), (c1 + ua, ub));
    // cos θt = u / m (scale-free); rp = (m c - cos θt)/(m c + cos θt), both
    // terms divided by `scale`.
    let mm = n1 * n1 + k1 * k1;
    let ct = if mm > 0.0 {
        (
            (ua * n1 + ub * k1) / mm * one,
            (ub * n1 - ua * k1) / mm * one,
        )
    } else {
        (0.0, 0.0)
    };
    let mc = (n1 * cos, k1 * cos);
    // Both terms can be tiny (huge m at grazing incidence): bring them to order 1.
    let big = mc.0.abs().max(mc.1.abs()).max(ct.0.abs()).max(ct.1.abs());
    let t = if big > 0.0 { 1.0 / big } else { 1.0 };
    let (mc, ct) = ((mc.0 * t, mc.1 * t), (ct.0 * t, ct.1 * t));
    let pp = mul_conj((mc.0 - ct.0, mc.1 - ct.1), (mc.0 + ct.0, mc.1 + ct.1));
    // rs rp*: phase ps - pp.
    let z = mul_conj(ps, pp);
    let norm2 = z.0 * z.0 + z.1 * z.1;
    if norm2 > 0.0 && norm2.is_finite() {
        let inv = 1.0 / norm2.sqrt();
        (z.0 * inv, z.1 * inv)
    } else {
        (0.0, 0.0)
    }
}

/// `p q*` of two complex numbers.
fn mul_conj(p: (f64, f64), q: (f64, f64)) -> (f64, f64) {
    (p.0 * q.0 + p.1 * q.1, p.1 * q.0 - p.0 * q.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;

    /// The scaled form for huge indices agrees with the plain one where both
    /// work, and gives a perfect conductor (Rs = Rp = 1) for huge indices.
    #[test]
    fn huge_indices_are_a_perfect_conductor() {
        for &(n, k) in &[(1.015, 6.627), (27.16, 89.89), (1e30, 3e30), (2.0, 0.0)] {
            for c in [1.0, 0.8, 0.3, 0.01, 0.0] {
                let (p, q) = (fresnel_sp(c, n, k), fresnel_sp_scaled(c, n, k));
                assert!(
                    (p.0 - q.0).abs() < 1e-12 && (p.1 - q.1).abs() < 1e-12,
                    "{n} {k} {c}: {p:?} {q:?}"
                );
            }
        }
        for &(n, k) in &[(1e200, 1e200), (1e150, 0.0), (3e120, 7e121)] {
            for c in [1.0, 0.5, 1e-3, 0.0] {
                let (rs, rp) = fresnel_sp(c, n, k);
                assert!(
                    (rs - 1.0).abs() < 1e-12 && (rp - 1.0).abs() < 1e-12,
                    "{n} {k} {c}: {rs} {rp}"
                );
            }
        }
    }

    /// Independent textbook implementation in complex arithmetic.
    ///
    /// `rs = (cos_i − η cos_t) / (cos_i + η cos_t)`,
    /// `rp = (η cos_i − cos_t) / (η cos_i + cos_t)` with
    /// `η cos_t = sqrt(η² − sin²θi)` (principal branch: Re ≥ 0, and Im ≥ 0
    /// because Im(η²) = 2 n k ≥ 0, i.e. a wave decaying into the medium).
    fn reference(cos_i: f64, n: f64, k: f64) -> (f64, f64) {
        let eta = Complex64::new(n, k);
        // η² − sin²θi, with sin²θi = 1 − cos²θi folded in for accuracy near
        // grazing incidence (the result would otherwise jump for η ≈ 1).
        let eta_cos_t = (eta * eta - 1.0 + cos_i * cos_i).sqrt();
        assert!(eta_cos_t.re >= 0.0 && eta_cos_t.im >= 0.0, "branch");
        let cos_t = eta_cos_t / eta;
        let ci = Complex64::new(cos_i, 0.0);
        let rs = (ci - eta_cos_t) / (ci + eta_cos_t);
        let rp = (eta * ci - cos_t) / (eta * ci + cos_t);
        (rs.norm_sqr(), rp.norm_sqr())
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-15
    }

    const MATERIALS: &[(f64, f64)] = &[
        (1.5, 0.0),
        (1.33, 0.0),
        (2.4, 0.0),
        (1.0, 0.0),
        (0.7, 0.0),
        (0.95, 0.0),
        (1.015, 6.627),
        (0.43, 2.455),
        (0.06, 3.586),
        (27.16, 89.89),
        (1.5, 0.01),
        (0.5, 0.5),
        (3.0, 1e-6),
        (0.2, 1e-3),
    ];

    #[test]
    fn matches_complex_reference_on_grid() {
        for &(n, k) in MATERIALS {
            for deg10 in 0..=900 {
                let theta = (f64::from(deg10) / 10.0).to_radians();
                let c = theta.cos().max(0.0);
                let (rs, rp) = fresnel_sp(c, n, k);
                let (rs_ref, rp_ref) = reference(c, n, k);
                assert!(
                    close(rs, rs_ref, 1e-12),
                    "Rs n={n} k={k} θ={}: {rs} vs {rs_ref}",
                    f64::from(deg10) / 10.0
                );
                assert!(
                    close(rp, rp_ref, 1e-12),
                    "Rp n={n} k={k} θ={}: {rp} vs {rp_ref}",
                    f64::from(deg10) / 10.0
                );
                let r = fresnel_unpolarised(c, n, k);
                assert!(close(r, 0.5 * (rs_ref + rp_ref), 1e-12));
                assert!((0.0..=1.0).contains(&r));
            }
        }
    }

    #[test]
    fn normal_incidence_closed_form() {
        for &(n, k) in MATERIALS {
            let expect = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
            let (rs, rp) = fresnel_sp(1.0, n, k);
            assert!(close(rs, expect, 1e-14), "{n} {k}");
            assert_eq!(rs, rp);
        }
    }

    #[test]
    fn published_normal_incidence_values() {
        let r4 = |n, k| (fresnel_unpolarised(1.0, n, k) * 1e4).round() / 1e4;
        assert_eq!(r4(1.015, 6.627), 0.9154); // Al (Rakic), visible
        assert_eq!(r4(0.43, 2.455), 0.7869); // Au
        assert_eq!(r4(0.06, 3.586), 0.9828); // Ag
        assert_eq!(r4(27.16, 89.89), 0.9878); // Al at 10.6 µm
    }

    #[test]
    fn glass_normal_incidence_is_exactly_four_percent() {
        assert_eq!(fresnel_unpolarised(1.0, 1.5, 0.0), 0.04);
        assert_eq!(fresnel_sp(1.0, 1.5, 0.0), (0.04, 0.04));
    }

    #[test]
    fn glass_brewster_angle() {
        let theta_b = 1.5f64.atan();
        let (rs, rp) = fresnel_sp(theta_b.cos(), 1.5, 0.0);
        assert!(rp.abs() < 1e-15, "Rp at Brewster = {rp}");
        // Rs at Brewster: ((n² − 1) / (n² + 1))² for incidence from index 1.
        let rs_exact = ((1.5f64 * 1.5 - 1.0) / (1.5 * 1.5 + 1.0)).powi(2);
        assert!(close(rs, rs_exact, 1e-13));
        let r = fresnel_unpolarised(theta_b.cos(), 1.5, 0.0);
        assert!(close(r, rs / 2.0, 1e-12));
    }

    #[test]
    fn grazing_incidence_is_total() {
        for &(n, k) in MATERIALS {
            if n == 1.0 && k == 0.0 {
                continue;
            }
            assert_eq!(fresnel_sp(0.0, n, k), (1.0, 1.0), "{n} {k}");
            assert_eq!(fresnel_unpolarised(0.0, n, k), 1.0);
        }
    }

    #[test]
    fn index_matched_interface_reflects_nothing() {
        for c in [0.0, 1e-300, 0.3, 0.5, 1.0] {
            assert_eq!(fresnel_sp(c, 1.0, 0.0), (0.0, 0.0), "c = {c}");
        }
    }

    #[test]
    fn n_below_one_total_reflection_beyond_critical_angle() {
        let n: f64 = 0.7;
        let crit = n.asin();
        for deg in 0..=90 {
            let theta = f64::from(deg).to_radians();
            let (rs, rp) = fresnel_sp(theta.cos(), n, 0.0);
            if theta > crit + 1e-9 {
                assert_eq!((rs, rp), (1.0, 1.0), "θ = {deg}");
            } else {
                assert!(rs < 1.0 && rp < 1.0, "θ = {deg}");
            }
        }
        // Exactly at the critical angle R = 1 as well (a = b = 0).
        let c = (1.0 - n * n).sqrt();
        let (rs, _) = fresnel_sp(c, n, 0.0);
        assert!(close(rs, 1.0, 1e-7));
    }

    #[test]
    fn cos_is_clamped() {
        assert_eq!(fresnel_sp(1.5, 1.5, 0.0), fresnel_sp(1.0, 1.5, 0.0));
        assert_eq!(fresnel_sp(-0.2, 1.5, 0.3), fresnel_sp(0.0, 1.5, 0.3));
    }

    #[test]
    fn bad_input_does_not_panic() {
        assert!(fresnel_unpolarised(f64::NAN, 1.5, 0.0).is_nan());
        let _ = fresnel_sp(0.5, f64::NAN, 0.0);
        let _ = fresnel_sp(0.5, f64::INFINITY, f64::INFINITY);
        let _ = fresnel_sp(1.0, 0.0, 0.0);
        let _ = fresnel_sp(0.5, -1.0, -2.0);
        // Huge but finite indices do not overflow to NaN.
        let r = fresnel_unpolarised(0.5, 1e200, 1e200);
        assert!(close(r, 1.0, 1e-12));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]

        /// Random media and angles: agreement with the complex reference,
        /// results in [0, 1], and Rp <= Rs (the factor multiplying Rs is
        /// ((ac - s²)² + b²c²) / ((ac + s²)² + b²c²) <= 1 since a, c >= 0).
        #[test]
        fn random_media_match_reference(
            c in 0.0f64..=1.0,
            n in 0.05f64..50.0,
            k in proptest::prop_oneof![proptest::strategy::Just(0.0), 0.0f64..100.0],
        ) {
            let (rs, rp) = fresnel_sp(c, n, k);
            let (rs_ref, rp_ref) = reference(c, n, k);
            proptest::prop_assert!((rs - rs_ref).abs() <= 1e-10 * rs_ref + 1e-13, "Rs {} vs {}", rs, rs_ref);
            proptest::prop_assert!((rp - rp_ref).abs() <= 1e-10 * rp_ref + 1e-13, "Rp {} vs {}", rp, rp_ref);
            proptest::prop_assert!((0.0..=1.0).contains(&rs) && (0.0..=1.0).contains(&rp));
            proptest::prop_assert!(rp <= rs);
        }
    }

    /// The lane form against the scalar functions, over random indices
    /// (dielectrics, metals, n < 1) and angles including normal and grazing.
    #[test]
    fn lanes_agree_with_the_scalar_functions() {
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let nk: Vec<(f64, f64)> = (0..7)
                .map(|j| {
                    let n = 0.05 + 5.0 * next();
                    let k = if j % 3 == 0 { 0.0 } else { 12.0 * next() };
                    (n, k)
                })
                .chain([(1.0, 0.0), (1e70, 1e70), (1.5, 0.0)])
                .collect();
            let lanes = FresnelLanes::new(&nk);
            let r = next();
            let cos = if r < 0.2 {
                0.0
            } else if r < 0.4 {
                1.0
            } else {
                next()
            };
            let full = lanes.chunk::<true>(cos, 0);
            let only = lanes.chunk::<false>(cos, 0);
            let (a, b, c, d) = (full.a, full.b, full.c, full.d);
            for (l, &(n, k)) in nk.iter().enumerate() {
                assert_eq!(a[l], only.a[l]);
                // The textbook amplitudes in complex arithmetic (for
                // moderate indices; the huge one against the scalar code).
                let f = FresnelMueller::new(cos, n, k);
                let expect = if n < 1e3 && !(n == 1.0 && k == 0.0 && cos == 0.0) {
                    let m = Complex64::new(n, k);
                    let cc = Complex64::new(cos, 0.0);
                    let u = (m * m - (1.0 - cos * cos)).sqrt();
                    let rs = (cc - u) / (cc + u);
                    let rp = (m * m * cc - u) / (m * m * cc + u);
                    let z = rs * rp.conj();
                    let (rs2, rp2) = (rs.norm_sqr(), rp.norm_sqr());
                    [0.5 * (rs2 + rp2), 0.5 * (rs2 - rp2), z.re, z.im]
                } else {
                    [f.a, f.b, f.c, f.d]
                };
                for (name, got, want, scalar) in [
                    ("a", a[l], expect[0], f.a),
                    ("b", b[l], expect[1], f.b),
                    ("c", c[l], expect[2], f.c),
                    ("d", d[l], expect[3], f.d),
                ] {
                    assert!(
                        (got - want).abs() <= 1e-13,
                        "{name} {n} {k} {cos}: {got} vs {want}"
                    );
                    assert!(
                        (got - scalar).abs() <= 1e-12,
                        "{name} {n} {k} {cos}: {got} vs {scalar}"
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod mueller_tests {
    use super::*;
    use num_complex::Complex64;

    /// Textbook amplitudes in complex arithmetic (independent of the phasor code).
    fn amplitudes(cos: f64, n: f64, k: f64) -> (Complex64, Complex64) {
        let m = Complex64::new(n, k);
        let u = (m * m - 1.0 + cos * cos).sqrt();
        let ct = u / m;
        let c = Complex64::new(cos, 0.0);
        ((c - u) / (c + u), (m * c - ct) / (m * c + ct))
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn matches_complex_amplitudes() {
        for &(n, k) in &[
            (1.015, 6.627),
            (0.43, 2.455),
            (1.6, 0.2),
            (1.5, 0.0),
            (0.7, 0.0),
            (27.16, 89.89),
            (0.06, 3.586),
        ] {
            for deg in 0..=90 {
                let c = f64::from(deg).to_radians().cos().max(0.0);
                let (rs, rp) = amplitudes(c, n, k);
                let z = rs * rp.conj();
                let f = FresnelMueller::new(c, n, k);
                assert!(close(f.a, 0.5 * (rs.norm_sqr() + rp.norm_sqr()), 1e-13));
                assert!(close(f.b, 0.5 * (rs.norm_sqr() - rp.norm_sqr()), 1e-13));
                assert!(
                    close(f.c, z.re, 1e-12),
                    "{n} {k} {deg}: {} vs {}",
                    f.c,
                    z.re
                );
                assert!(
                    close(f.d, z.im, 1e-12),
                    "{n} {k} {deg}: {} vs {}",
                    f.d,
                    z.im
                );
            }
        }
    }

    /// REFERENCE.md (Azzam & Bashara with Python's cmath): c/a and d/a.
    #[test]
    fn published_retardance_values() {
        let rows = [
            (1.015, 6.627, 45.0, 0.939707, 0.883049, -0.978225, 0.205205),
            (1.015, 6.627, 60.0, 0.957092, 0.843598, -0.906081, 0.418384),
            (1.015, 6.627, 80.0, 0.984919, 0.734633, -0.190484, 0.970840),
            (0.43, 2.455, 45.0, 0.849414, 0.721504, -0.860808, 0.502374),
            (0.43, 2.455, 60.0, 0.892820, 0.683443, -0.509375, 0.850231),
        ];
        for (n, k, deg, rs, rp, re, im) in rows {
            let f = FresnelMueller::new(f64::to_radians(deg).cos(), n, k);
            assert!(close(f.a + f.b, rs, 1e-6) && close(f.a - f.b, rp, 1e-6));
            assert!(close(f.c / f.a, re, 1e-6), "{}", f.c / f.a);
            assert!(close(f.d / f.a, im, 1e-6), "{}", f.d / f.a);
        }
    }

    #[test]
    fn normal_and_grazing_incidence_are_exact() {
        for &(n, k) in &[(1.015, 6.627), (1.5, 0.0), (1.6, 0.2), (1e200, 1e200)] {
            let f = FresnelMueller::new(1.0, n, k);
            assert_eq!(f.b, 0.0);
            assert!(
                close(f.c, -f.a, 1e-15 * f.a.max(1.0)) && f.d.abs() < 1e-15,
                "{n} {k}: {f:?}"
            );
            let g = FresnelMueller::new(0.0, n, k);
            assert_eq!((g.a, g.b), (1.0, 0.0));
            assert!(close(g.c, 1.0, 1e-15) && g.d.abs() < 1e-15, "{g:?}");
            assert!(f.matrix().iter().flatten().all(|x| x.is_finite()));
        }
        // Huge indices (everything in units of max(n, k, 1)): a perfect conductor at every
        // angle, rs rp* = -Rs Rp, except exactly at grazing (identity).
        for &(n, k) in &[(1e200, 1e200), (1e150, 0.0), (3e120, 7e121)] {
            for c in [1.0, 0.7, 0.1, 1e-3] {
                let f = FresnelMueller::new(c, n, k);
                assert!(
                    close(f.c, -f.a, 1e-12) && f.d.abs() < 1e-12,
                    "{n} {k} {c}: {f:?}"
                );
            }
        }
        // Brewster angle of glass: Rp = 0, so no c, d term and no NaN.
        let f = FresnelMueller::new(1.5f64.atan().cos(), 1.5, 0.0);
        assert!(f.c.abs() < 1e-9 && f.d.abs() < 1e-9);
        // Index matched: nothing reflected.
        assert_eq!(FresnelMueller::new(0.5, 1.0, 0.0).matrix(), [[0.0; 4]; 4]);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]
        /// The Fresnel matrix is a pure (non-depolarising) Mueller matrix:
        /// c² + d² = Rs Rp, so it maps fully polarised light to fully polarised light.
        #[test]
        fn fresnel_keeps_pure_states_pure(
            c in 0.0f64..=1.0, n in 0.05f64..50.0, k in 0.0f64..100.0,
            t in 0.0f64..std::f64::consts::PI, p in 0.0f64..std::f64::consts::TAU,
        ) {
            let f = FresnelMueller::new(c, n, k);
            let s = [1.0, t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
            let o = f.apply(s);
            let pol = (o[1] * o[1] + o[2] * o[2] + o[3] * o[3]).sqrt();
            proptest::prop_assert!((pol - o[0]).abs() <= 1e-12 * o[0].max(1e-300) + 1e-300);
        }
    }
}
