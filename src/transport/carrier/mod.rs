//! What a photon carries through its history: a scalar weight, or a Stokes
//! vector (or the columns of a Mueller matrix) with its reference vector.
//!
//! * `f64`: the unpolarised weight. A Fresnel facet multiplies it by
//!   `(Rs + Rp) / 2`: exact for one bounce of unpolarised light, an
//!   approximation beyond (`[transport] polarisation = false`). Scenes
//!   without a Fresnel material use it: every other model is non-polarising,
//!   so the result is exact there.
//! * [`Polarised<1>`]: a Stokes vector for one incident state.
//! * [`Polarised<4>`]: the four columns of the path's Mueller matrix
//!   (the responses to the incident basis states `(1,0,0,0)` ... `(0,0,0,1)`),
//!   for the Mueller-matrix BRDF of every incident state in one trace.
//!
//! Conventions (frames, signs) are those of [`crate::optics::polarisation`].
//! Per reflection:
//!
//! | model | Mueller matrix in the s frames |
//! |---|---|
//! | Fresnel `n + i k` | [`FresnelMueller`] |
//! | constant, angle table, ideal specular | `rho diag(1, 1, -1, -1)`: the perfect mirror (the Fresnel matrix of a perfect conductor, and of every material at normal incidence) scaled by `rho`: non-polarising, the state is kept |
//! | Lambertian, unpolarised BRDF table | `rho diag(1, 0, 0, 0)`: depolarising |
//! | BRDF table with its `mueller.csv` | the sampled cell's Mueller matrix divided by its `m00`, times the table's reflectance (`transfer`) |
//!
//! Intensity for Russian roulette and for "absorbed" is `S0` of the first
//! column (for `Polarised<4>`: `M00`, the response to unpolarised light;
//! `|m_ij| <= M00` for a physical matrix, so `M00 = 0` ends everything).

use glam::DVec3;

use crate::optics::fresnel::FresnelMueller;
use crate::optics::material::Reflectance;
use crate::optics::polarisation::{Stokes, rotation};

mod spectral;

pub use spectral::{LaneCarrier, Spectral, SpectralPolarised};

/// The turn of a carrier's reference frame into the s frame of one
/// reflection ([`Carrier::s_turn`]): the rotator `(cos 2a, sin 2a)` if the
/// frame turns, and the s axis, the new reference vector.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct STurn {
    /// The rotator of [`rotation`], or `None` at normal incidence (any axis is exact).
    pub rotator: Option<(f64, f64)>,
    /// The reference vector after the reflection.
    pub s: DVec3,
}

/// The weight a photon carries (see the module docs).
pub trait Carrier: Copy + Send + Sync + std::fmt::Debug {
    /// What one wavelength carries: `Self` for a monochrome carrier, the
    /// lane type of [`Spectral`].
    type Lane: Carrier;

    /// The carrier at launch: `incident` is the incident Stokes vector
    /// (`S0 = 1`), `reference` its reference vector (⟂ the flight), `lanes`
    /// the number of wavelengths (1 for a monochrome carrier, which ignores it).
    fn launch(incident: Stokes, reference: DVec3, lanes: usize) -> Self;

    /// Number of wavelengths carried (1 for a monochrome carrier).
    fn lanes(&self) -> usize {
        1
    }

    /// What wavelength `l` (`< lanes()`) carries.
    fn lane(&self, l: usize) -> Self::Lane;

    /// `f` of what wavelength `l` carries ([`Carrier::lane`]), by reference:
    /// a monochrome carrier hands itself without a copy (a Mueller carrier
    /// is 152 bytes, a copy a `memcpy` call per scored photon).
    #[inline]
    fn with_lane<R>(&self, l: usize, f: impl FnOnce(&Self::Lane) -> R) -> R {
        f(&self.lane(l))
    }

    /// Intensity for roulette and bookkeeping (see the module docs).
    fn intensity(&self) -> f64;

    /// The intensity scored for `incident` (the `brdf.csv` weight).
    fn weight_for(&self, incident: &Stokes) -> f64;

    /// [`Carrier::weight_for`] of every wavelength: `out[l]` for lane `l`
    /// (`out` holds [`Carrier::lanes`] numbers).
    #[inline]
    fn weights_for(&self, incident: &Stokes, out: &mut [f64]) {
        for (l, o) in out.iter_mut().enumerate() {
            *o = self.lane(l).weight_for(incident);
        }
    }

    /// Specular reflection off a facet of `material`: unit incoming `d`,
    /// unit normal `n` facing it, `cos_i = -d · n`. Returns false, leaving
    /// the carrier unchanged, when the reflectance is not a finite number >= 0.
    fn reflect(&mut self, material: &Reflectance, d: DVec3, n: DVec3, cos_i: f64) -> bool;

    /// Whether the carrier keeps a polarisation state (a Fresnel reflection
    /// needs all four coefficients of [`FresnelMueller`], not only `a`).
    const POLARISED: bool = false;

    /// The turn of the reference frame into the s frame of a reflection of
    /// the flight `d` about the normal `n`: what [`Carrier::fresnel_in`]
    /// applies (computed once for all wavelengths of a [`Spectral`] carrier,
    /// whose lanes share their reference vector).
    fn s_turn(&self, _d: DVec3, _n: DVec3) -> STurn {
        STurn::default()
    }

    /// A Fresnel reflection given its coefficients `f` (finite, `a >= 0`)
    /// and the frame turn `turn` of this reflection ([`Carrier::s_turn`]).
    fn fresnel_in(&mut self, turn: &STurn, f: &FresnelMueller);

    /// Non-polarising specular reflection with reflectance `rho` (>= 0).
    fn mirror(&mut self, rho: f64, d: DVec3, n: DVec3);

    /// Multiply by `factor` and depolarise; `d_out` is the new flight.
    fn depolarise(&mut self, factor: f64, d_out: DVec3);

    /// [`Carrier::depolarise`] with a factor per wavelength: lane `l` by
    /// `factors[l]` (`factors` holds at least [`Carrier::lanes`] numbers;
    /// a monochrome carrier takes `factors[0]`). A spectral BRDF table wall
    /// weighs each wavelength by its own table.
    #[inline]
    fn depolarise_lanes(&mut self, factors: &[f64], d_out: DVec3) {
        self.depolarise(factors[0], d_out);
    }

    /// A tabulated Mueller-matrix reflection: turn into the reference vector
    /// `x_in` (⟂ the incoming flight `d`), apply `m` (row-major, divided by
    /// its `m00`) times `factor`, and continue about `x_out` (⟂ the new flight).
    fn transfer(&mut self, d: DVec3, x_in: DVec3, m: &[f64; 16], factor: f64, x_out: DVec3);

    /// [`Carrier::transfer`] with a matrix and a factor per wavelength:
    /// lane `l` by `ms[l]` times `factors[l]` (both hold at least
    /// [`Carrier::lanes`] entries; a monochrome carrier takes entry 0). A
    /// spectral BRDF table wall with its Mueller tables.
    #[inline]
    fn transfer_lanes(
        &mut self,
        d: DVec3,
        x_in: DVec3,
        ms: &[&[f64; 16]],
        factors: &[f64],
        x_out: DVec3,
    ) {
        self.transfer(d, x_in, ms[0], factors[0], x_out);
    }

    /// A roulette survivor: the intensity becomes `s`.
    fn survive(&mut self, s: f64);

    /// The same state with intensity 1 (a wall's local history starts from it).
    #[must_use]
    fn unit(&self) -> Self;

    /// This carrier after a wall whose history, started from [`Carrier::unit`],
    /// ended as `local`; and the intensity the wall removed.
    #[must_use]
    fn rescaled(&self, local: Self) -> (Self, f64);

    /// [`Carrier::rescaled`], handing the intensity the wall removed from
    /// each wavelength to `removed(lane, intensity)` (lanes in order; a
    /// monochrome carrier: lane 0, `rescaled`'s removed intensity).
    #[must_use]
    #[inline]
    fn rescaled_lanes(&self, local: Self, mut removed: impl FnMut(usize, f64)) -> Self {
        let (out, r) = self.rescaled(local);
        removed(0, r);
        out
    }

    /// Map the reference vector into other coordinates (a wall's local frame and back).
    fn map_frame(&mut self, f: impl Fn(DVec3) -> DVec3);

    /// Finite, with intensity >= 0.
    fn is_valid(&self) -> bool;

    /// The components polarisation tallies score, re-expressed about the
    /// reference vector `to` (⟂ the flight `d`): the Stokes vector (`N = 1`,
    /// 4 values) or the Mueller matrix row-major (`N = 4`, 16 values) in
    /// `out`; returns how many (0 for the scalar weight).
    fn components(&self, d: DVec3, to: DVec3, out: &mut [f64; 16]) -> usize;
}

impl Carrier for f64 {
    type Lane = Self;
    #[inline]
    fn launch(_: Stokes, _: DVec3, _: usize) -> Self {
        1.0
    }
    #[inline]
    fn lane(&self, _: usize) -> Self {
        *self
    }
    #[inline]
    fn intensity(&self) -> f64 {
        *self
    }
    #[inline]
    fn weight_for(&self, _: &Stokes) -> f64 {
        *self
    }
    #[inline]
    fn reflect(&mut self, material: &Reflectance, _: DVec3, _: DVec3, cos_i: f64) -> bool {
        let r = material.reflectance(cos_i);
        if !(r >= 0.0 && r.is_finite()) {
            // Also NaN: a weight that is not a number never reaches a tally.
            return false;
        }
        *self *= r;
        true
    }
    #[inline]
    fn fresnel_in(&mut self, _: &STurn, f: &FresnelMueller) {
        *self *= f.a;
    }
    #[inline]
    fn mirror(&mut self, rho: f64, _: DVec3, _: DVec3) {
        *self *= rho;
    }
    #[inline]
    fn depolarise(&mut self, factor: f64, _: DVec3) {
        *self *= factor;
    }
    #[inline]
    fn transfer(&mut self, _: DVec3, _: DVec3, _: &[f64; 16], factor: f64, _: DVec3) {
        *self *= factor;
    }
    #[inline]
    fn survive(&mut self, s: f64) {
        *self = s;
    }
    #[inline]
    fn unit(&self) -> Self {
        1.0
    }
    #[inline]
    fn rescaled(&self, local: Self) -> (Self, f64) {
        (self * local, self * (1.0 - local))
    }
    #[inline]
    fn map_frame(&mut self, _: impl Fn(DVec3) -> DVec3) {}
    #[inline]
    fn is_valid(&self) -> bool {
        *self >= 0.0 && self.is_finite()
    }
    #[inline]
    fn components(&self, _: DVec3, _: DVec3, _: &mut [f64; 16]) -> usize {
        0
    }
}

/// Stokes columns with their common reference vector `x` (unit, ⟂ the
/// flight): `N = 1` a Stokes vector, `N = 4` a Mueller matrix by columns.
///
/// Stored component-major: `rows[i][j]` is Stokes component `i` of column
/// `j` (for `N = 4` the Mueller matrix `m_ij`, row-major), so rotations and
/// Fresnel matrices act on each row `rows[i]` lane by lane across the columns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polarised<const N: usize> {
    /// Component `i` of each column: column `j` is the Stokes vector leaving
    /// for incident basis state `j` (`N = 4`), or for the incident state (`N = 1`).
    pub rows: [[f64; N]; 4],
    /// Reference vector of the columns.
    pub x: DVec3,
}

impl<const N: usize> Polarised<N> {
    /// Turn the columns into the s frame of a reflection about `n` of a
    /// flight along `d`; returns the s axis (the photon's own reference
    /// vector at normal incidence, where any axis is exact).
    #[inline]
    fn turn_to_s_frame(&mut self, d: DVec3, n: DVec3) -> DVec3 {
        let s = n.cross(d);
        let len2 = s.length_squared();
        if len2 > 1e-24 {
            let s = s / len2.sqrt();
            rotate_rows(&mut self.rows, rotation(d, self.x, s));
            s
        } else {
            self.x
        }
    }

    /// Scale every column by `f`.
    #[inline]
    fn scale(&mut self, f: f64) {
        for v in self.rows.iter_mut().flatten() {
            *v *= f;
        }
    }
}

/// The turn of the reference vector `x` into the s frame of a reflection
/// of the flight `d` about the normal `n` ([`Carrier::s_turn`]).
#[inline]
fn s_turn_from(x: DVec3, d: DVec3, n: DVec3) -> STurn {
    let s = n.cross(d);
    let len2 = s.length_squared();
    if len2 > 1e-24 {
        let s = s / len2.sqrt();
        STurn {
            rotator: Some(rotation(d, x, s)),
            s,
        }
    } else {
        STurn {
            rotator: None,
            s: x,
        }
    }
}

/// [`Carrier::reflect`] of a polarised carrier off a model that is the same
/// at every wavelength: a Fresnel matrix in the s frame, or a mirror
/// scaled by the reflectance (false, unchanged, when the coefficients are
/// not finite with `a >= 0`).
fn reflect_polarised<C: Carrier>(
    carrier: &mut C,
    material: &Reflectance,
    d: DVec3,
    n: DVec3,
    cos_i: f64,
) -> bool {
    match material {
        Reflectance::Fresnel { n: re, k } => {
            let f = FresnelMueller::new(cos_i, *re, *k);
            if !(f.a >= 0.0 && [f.a, f.b, f.c, f.d].iter().all(|v| v.is_finite())) {
                return false;
            }
            // `FresnelMueller::apply` on each column, in the s frame.
            let turn = carrier.s_turn(d, n);
            carrier.fresnel_in(&turn, &f);
            true
        }
        other => {
            let r = other.reflectance(cos_i);
            if !(r >= 0.0 && r.is_finite()) {
                return false;
            }
            carrier.mirror(r, d, n);
            true
        }
    }
}

/// Apply the rotator `(cos 2a, sin 2a)` of [`rotation`] to every column of
/// `rows` (component-major, see [`Polarised`]): [`rotate`](crate::optics::polarisation::rotate)
/// column by column, the same products and sums.
#[inline]
fn rotate_rows<const N: usize>(rows: &mut [[f64; N]; 4], turn: (f64, f64)) {
    let (r1, r2) = (rows[1], rows[2]);
    for j in 0..N {
        (rows[1][j], rows[2][j]) = turned(turn, r1[j], r2[j]);
    }
}

/// Entries `a` of row 1 and `b` of row 2 turned by `(c2, s2) = (cos 2ψ,
/// sin 2ψ)`: `(c2 a + s2 b, -s2 a + c2 b)`, the one formula of
/// [`rotate_rows`] and [`Polarised::components`].
#[inline(always)]
fn turned((c2, s2): (f64, f64), a: f64, b: f64) -> (f64, f64) {
    (c2 * a + s2 * b, -s2 * a + c2 * b)
}

impl<const N: usize> Carrier for Polarised<N> {
    type Lane = Self;
    #[inline]
    fn lane(&self, _: usize) -> Self {
        *self
    }
    #[inline]
    fn with_lane<R>(&self, _: usize, f: impl FnOnce(&Self) -> R) -> R {
        f(self)
    }

    fn launch(incident: Stokes, reference: DVec3, _: usize) -> Self {
        let mut rows = [[0.0; N]; 4];
        if N == 1 {
            for (row, s) in rows.iter_mut().zip(incident) {
                row[0] = s;
            }
        } else {
            for (j, row) in rows.iter_mut().enumerate() {
                row[j] = 1.0;
            }
        }
        Self { rows, x: reference }
    }

    const POLARISED: bool = true;

    #[inline]
    fn s_turn(&self, d: DVec3, n: DVec3) -> STurn {
        s_turn_from(self.x, d, n)
    }

    #[inline]
    fn fresnel_in(&mut self, turn: &STurn, f: &FresnelMueller) {
        if let Some(r) = turn.rotator {
            rotate_rows(&mut self.rows, r);
        }
        let FresnelMueller { a, b, c, d } = *f;
        let [r0, r1, r2, r3] = self.rows;
        self.rows = [
            std::array::from_fn(|j| a * r0[j] + b * r1[j]),
            std::array::from_fn(|j| b * r0[j] + a * r1[j]),
            std::array::from_fn(|j| c * r2[j] - d * r3[j]),
            std::array::from_fn(|j| d * r2[j] + c * r3[j]),
        ];
        self.x = turn.s;
    }

    #[inline]
    fn intensity(&self) -> f64 {
        self.rows[0][0]
    }

    #[inline]
    fn weight_for(&self, incident: &Stokes) -> f64 {
        if N == 1 {
            self.rows[0][0]
        } else {
            (0..N).map(|j| self.rows[0][j] * incident[j]).sum()
        }
    }

    fn reflect(&mut self, material: &Reflectance, d: DVec3, n: DVec3, cos_i: f64) -> bool {
        reflect_polarised(self, material.lane(0), d, n, cos_i)
    }

    fn mirror(&mut self, rho: f64, d: DVec3, n: DVec3) {
        let s = self.turn_to_s_frame(d, n);
        for (i, row) in self.rows.iter_mut().enumerate() {
            let f = if i < 2 { rho } else { -rho };
            for v in row {
                *v *= f;
            }
        }
        self.x = s;
    }

    fn depolarise(&mut self, factor: f64, d_out: DVec3) {
        for v in &mut self.rows[0] {
            *v *= factor;
        }
        self.rows[1..].fill([0.0; N]);
        self.x = d_out.any_orthonormal_vector();
    }

    fn transfer(&mut self, d: DVec3, x_in: DVec3, m: &[f64; 16], factor: f64, x_out: DVec3) {
        rotate_rows(&mut self.rows, rotation(d, self.x, x_in));
        let v = self.rows;
        self.rows = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                factor
                    * (m[4 * i] * v[0][j]
                        + m[4 * i + 1] * v[1][j]
                        + m[4 * i + 2] * v[2][j]
                        + m[4 * i + 3] * v[3][j])
            })
        });
        self.x = x_out;
    }

    #[inline]
    fn survive(&mut self, s: f64) {
        let i = self.intensity();
        if s != i && i > 0.0 {
            self.scale(s / i);
            // Exactly `s`, as for the scalar carrier (`i * (s / i)` may be
            // off by an ulp), so the intensity of a non-polarising scene is
            // the scalar one bit for bit.
            self.rows[0][0] = s;
        }
    }

    fn unit(&self) -> Self {
        let mut u = *self;
        let i = self.intensity();
        if i > 0.0 && i != 1.0 {
            u.scale(1.0 / i);
            u.rows[0][0] = 1.0;
        }
        u
    }

    fn rescaled(&self, mut local: Self) -> (Self, f64) {
        let i = self.intensity();
        local.scale(i);
        (local, i - local.intensity())
    }

    fn map_frame(&mut self, f: impl Fn(DVec3) -> DVec3) {
        self.x = f(self.x);
    }

    fn is_valid(&self) -> bool {
        self.intensity() >= 0.0
            && self.x.is_finite()
            && self.rows.iter().flatten().all(|v| v.is_finite())
    }

    #[inline]
    fn components(&self, d: DVec3, to: DVec3, out: &mut [f64; 16]) -> usize {
        // Row-major m_ij for N = 4; the Stokes vector for N = 1: rows 0
        // and 3 as they are, rows 1 and 2 turned ([`turned`], as
        // [`rotate_rows`] turns them), written in place without a copy of
        // the rows.
        let turn = rotation(d, self.x, to);
        let [r0, r1, r2, r3] = &self.rows;
        for j in 0..N {
            out[j] = r0[j];
            (out[N + j], out[2 * N + j]) = turned(turn, r1[j], r2[j]);
            out[3 * N + j] = r3[j];
        }
        4 * N
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::polarisation::degree_of_polarisation;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn random_unit(rng: &mut Pcg64Mcg) -> DVec3 {
        loop {
            let v = DVec3::new(
                rng.random::<f64>() * 2.0 - 1.0,
                rng.random::<f64>() * 2.0 - 1.0,
                rng.random::<f64>() * 2.0 - 1.0,
            );
            if let Some(u) = v.try_normalize().filter(|_| v.length() <= 1.0) {
                return u;
            }
        }
    }

    /// Many random chains of reflections (Fresnel of random media, mirrors,
    /// depolarisers): every Stokes column keeps S1² + S2² + S3² <= S0², the
    /// reference vector stays a unit vector perpendicular to the flight.
    #[test]
    fn random_paths_stay_physical() {
        let mut rng = Pcg64Mcg::seed_from_u64(12);
        for path in 0..20_000 {
            let mut d = random_unit(&mut rng);
            let a = TAUF * rng.random::<f64>();
            let t = std::f64::consts::PI * rng.random::<f64>();
            let state = [1.0, t.sin() * a.cos(), t.sin() * a.sin(), t.cos()];
            let mut p = Polarised::<1>::launch(state, d.any_orthonormal_vector(), 1);
            let mut m = Polarised::<4>::launch(state, p.x, 1);
            for bounce in 0..30 {
                let mut n = random_unit(&mut rng);
                if n.dot(d) > 0.0 {
                    n = -n;
                }
                let cos_i = -d.dot(n);
                let material = Reflectance::Fresnel {
                    n: 0.05 + 5.0 * rng.random::<f64>(),
                    k: if rng.random::<f64>() < 0.3 {
                        0.0
                    } else {
                        10.0 * rng.random::<f64>()
                    },
                };
                let out = (d + 2.0 * cos_i * n).normalize();
                match (path + bounce) % 7 {
                    0 => {
                        p.mirror(0.9, d, n);
                        m.mirror(0.9, d, n);
                    }
                    _ => {
                        assert!(p.reflect(&material, d, n, cos_i));
                        assert!(m.reflect(&material, d, n, cos_i));
                    }
                }
                d = out;
                for s in [p.rows.map(|r| r[0]), m.rows.map(|r| r[0])] {
                    assert!(degree_of_polarisation(s) <= 1.0 + 1e-9, "{s:?}");
                }
                assert!(p.x.dot(d).abs() < 1e-9 && (p.x.length() - 1.0).abs() < 1e-9);
                // The matrix applied to the state equals the carried vector.
                let via_m = m.weight_for(&state);
                assert!((via_m - p.intensity()).abs() <= 1e-9 * p.intensity().max(1e-300));
                let i = p.intensity();
                if i < 1e-6 {
                    p.survive(1.0);
                    m.survive(1.0 / i * m.intensity());
                }
            }
        }
    }

    const TAUF: f64 = std::f64::consts::TAU;

    #[test]
    #[allow(clippy::needless_range_loop)] // m.rows[i][j] against f[i][j]
    fn flat_fresnel_is_the_textbook_matrix() {
        // Light along -omega_i in the x-z plane onto z = 0: the s axis is ±y.
        let d = DVec3::new(0.5, 0.0, -(0.75f64).sqrt());
        let mut m = Polarised::<4>::launch([1.0, 0.0, 0.0, 0.0], DVec3::Y, 1);
        let mat = Reflectance::Fresnel { n: 1.015, k: 6.627 };
        assert!(m.reflect(&mat, d, DVec3::Z, -d.z));
        let f = FresnelMueller::new(-d.z, 1.015, 6.627).matrix();
        for j in 0..4 {
            for i in 0..4 {
                assert!((m.rows[i][j] - f[i][j]).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn scalar_carrier_is_the_old_arithmetic() {
        let mut w = 0.7_f64;
        let mat = Reflectance::Fresnel { n: 1.5, k: 0.1 };
        assert!(w.reflect(&mat, DVec3::NEG_Z, DVec3::Z, 0.6));
        assert_eq!(w, 0.7 * mat.reflectance(0.6));
        assert_eq!(0.7.rescaled(0.3), (0.7 * 0.3, 0.7 * (1.0 - 0.3)));
        assert!(!w.reflect(
            &Reflectance::Constant(f64::NAN),
            DVec3::NEG_Z,
            DVec3::Z,
            1.0
        ));
    }
}
