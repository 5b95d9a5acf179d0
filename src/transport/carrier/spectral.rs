//! Carriers of many wavelengths ([`Spectral`], [`SpectralPolarised`]): in
//! geometric optics a photon's path does not depend on the wavelength, only
//! its weights do, so one trace carries a lane per wavelength.
//!
//! [`LaneCarrier::Spectrum`] names the carrier a run of several wavelengths
//! uses for a monochrome carrier: [`Spectral`] (an array of lanes) for the
//! scalar weight, [`SpectralPolarised`] (the Stokes columns of all lanes by
//! component, one reference vector) for the polarised carriers, so that
//! rotations and Fresnel matrices run over the wavelengths in vector code.

use glam::DVec3;

use super::{Carrier, Polarised, STurn, reflect_polarised, s_turn_from};
use crate::optics::fresnel::FresnelMueller;
use crate::optics::fresnel::{CHUNK, FresnelChunk, FresnelLanes};
use crate::optics::material::Reflectance;
use crate::optics::polarisation::{Stokes, rotation};
use crate::optics::spectrum::MAX_WAVELENGTHS;

/// A carrier per wavelength: the photon's path does not depend on the
/// wavelength in geometric optics, only its weights do, so one trace carries
/// lane `l` through every reflection with model [`Reflectance::lane`]`(l)`.
///
/// * Roulette and bookkeeping see the largest intensity of the lanes
///   ([`Carrier::intensity`]); a survivor scales every lane by the same
///   factor, so the roulette is unbiased at every wavelength.
/// * With equal lanes (a material that does not vary) every lane is the
///   monochrome carrier bit for bit.
/// * A reflection that fails (a reflectance that is not a finite number,
///   e.g. for a NaN cosine) fails at the first lane, leaving the carrier
///   unchanged: scene models are valid at every wavelength.
///
/// `CAP` is the most wavelengths it can hold (at most [`MAX_WAVELENGTHS`]):
/// a run uses the smallest of a few capacities that holds its wavelengths,
/// since a photon's carrier is copied a few times per history.
#[derive(Debug, Clone, Copy)]
pub struct Spectral<C, const CAP: usize = MAX_WAVELENGTHS> {
    lanes: [C; CAP],
    len: usize,
}

impl<C: Carrier<Lane = C>, const CAP: usize> Spectral<C, CAP> {
    /// The lanes in use.
    #[inline]
    fn used(&self) -> &[C] {
        &self.lanes[..self.len]
    }

    #[inline]
    fn used_mut(&mut self) -> &mut [C] {
        &mut self.lanes[..self.len]
    }

    /// The index of a lane of largest intensity (the first one).
    #[inline]
    fn brightest(&self) -> usize {
        let mut best = 0;
        for (l, c) in self.used().iter().enumerate().skip(1) {
            if c.intensity() > self.lanes[best].intensity() {
                best = l;
            }
        }
        best
    }

    /// A Fresnel reflection of every wavelength: the coefficients of all
    /// lanes by [`FresnelLanes::chunk`] (vectorised), [`CHUNK`] lanes at a
    /// time, the frame turn once ([`Carrier::s_turn`]: the lanes share their
    /// reference vector).
    #[inline]
    fn reflect_fresnel(&mut self, fresnel: &FresnelLanes, d: DVec3, n: DVec3, cos_i: f64) -> bool {
        // Finite coefficients with a >= 0 for every valid index and any
        // finite cosine (FresnelLanes recomputes the lanes that are not).
        if !cos_i.is_finite() {
            return false;
        }
        let turn = self.lanes[0].s_turn(d, n);
        let mut f = FresnelChunk::ZERO;
        for (index, lanes) in self.lanes[..self.len].chunks_mut(CHUNK).enumerate() {
            if C::POLARISED {
                fresnel.chunk_into::<true>(cos_i, index, &mut f);
            } else {
                fresnel.chunk_into::<false>(cos_i, index, &mut f);
            }
            for (j, lane) in lanes.iter_mut().enumerate() {
                let m = FresnelMueller {
                    a: f.a[j],
                    b: f.b[j],
                    c: f.c[j],
                    d: f.d[j],
                };
                lane.fresnel_in(&turn, &m);
            }
        }
        true
    }

    /// Every lane scaled so that the brightest lane has intensity `s`
    /// (that lane exactly `s`).
    #[inline]
    fn scale_to(&mut self, s: f64) {
        let i = self.intensity();
        if i > 0.0 && s != i {
            let f = s / i;
            for c in self.used_mut() {
                let ci = c.intensity();
                c.survive(if ci == i { s } else { ci * f });
            }
        }
    }
}

impl<C: Carrier<Lane = C>, const CAP: usize> Carrier for Spectral<C, CAP> {
    type Lane = C;

    fn launch(incident: Stokes, reference: DVec3, lanes: usize) -> Self {
        Self {
            lanes: [C::launch(incident, reference, 1); CAP],
            len: lanes.clamp(1, CAP),
        }
    }

    #[inline]
    fn lanes(&self) -> usize {
        self.len
    }

    #[inline]
    fn lane(&self, l: usize) -> C {
        self.lanes[l]
    }

    /// The largest intensity of the lanes.
    #[inline]
    fn intensity(&self) -> f64 {
        largest(self.used(), C::intensity)
    }

    /// The largest of the lanes' weights (tallies score each lane's own).
    fn weight_for(&self, incident: &Stokes) -> f64 {
        self.used()
            .iter()
            .fold(0.0, |m: f64, c| m.max(c.weight_for(incident)))
    }

    #[inline]
    fn weights_for(&self, incident: &Stokes, out: &mut [f64]) {
        for (o, c) in out.iter_mut().zip(self.used()) {
            *o = c.weight_for(incident);
        }
    }

    #[inline]
    fn reflect(&mut self, material: &Reflectance, d: DVec3, n: DVec3, cos_i: f64) -> bool {
        if let Reflectance::Spectral(m) = material
            && let Some(fresnel) = m.fresnel()
            && fresnel.len() >= self.len
        {
            return self.reflect_fresnel(fresnel, d, n, cos_i);
        }
        for (l, c) in self.used_mut().iter_mut().enumerate() {
            if !c.reflect(material.lane(l), d, n, cos_i) {
                return false;
            }
        }
        true
    }

    #[inline]
    fn fresnel_in(&mut self, turn: &STurn, f: &FresnelMueller) {
        for c in self.used_mut() {
            c.fresnel_in(turn, f);
        }
    }

    fn mirror(&mut self, rho: f64, d: DVec3, n: DVec3) {
        for c in self.used_mut() {
            c.mirror(rho, d, n);
        }
    }

    fn depolarise(&mut self, factor: f64, d_out: DVec3) {
        for c in self.used_mut() {
            c.depolarise(factor, d_out);
        }
    }

    fn depolarise_lanes(&mut self, factors: &[f64], d_out: DVec3) {
        for (c, &f) in self.used_mut().iter_mut().zip(factors) {
            c.depolarise(f, d_out);
        }
    }

    fn transfer(&mut self, d: DVec3, x_in: DVec3, m: &[f64; 16], factor: f64, x_out: DVec3) {
        for c in self.used_mut() {
            c.transfer(d, x_in, m, factor, x_out);
        }
    }

    fn transfer_lanes(
        &mut self,
        d: DVec3,
        x_in: DVec3,
        ms: &[&[f64; 16]],
        factors: &[f64],
        x_out: DVec3,
    ) {
        for ((c, m), &f) in self.used_mut().iter_mut().zip(ms).zip(factors) {
            c.transfer(d, x_in, m, f, x_out);
        }
    }

    #[inline]
    fn survive(&mut self, s: f64) {
        self.scale_to(s);
    }

    fn unit(&self) -> Self {
        let mut u = *self;
        u.scale_to(1.0);
        u
    }

    /// The local history's lanes times this carrier's largest intensity;
    /// the intensity removed is that of the brightest lane.
    fn rescaled(&self, local: Self) -> (Self, f64) {
        let reference = self.lanes[self.brightest()];
        let mut out = local;
        for (o, l) in out.used_mut().iter_mut().zip(local.used()) {
            *o = reference.rescaled(*l).0;
        }
        let removed = self.intensity() - out.intensity();
        (out, removed)
    }

    /// [`Spectral::rescaled`] with each lane's removed intensity: a lane as
    /// bright as the brightest gets the brightest lane's own removed
    /// intensity (so equal lanes are the monochrome carrier's bit for bit),
    /// any other lane its intensity before minus after.
    fn rescaled_lanes(&self, local: Self, mut removed: impl FnMut(usize, f64)) -> Self {
        let reference = self.lanes[self.brightest()];
        let top = reference.intensity();
        let mut out = local;
        for (l, (o, loc)) in out.used_mut().iter_mut().zip(local.used()).enumerate() {
            let (after, r) = reference.rescaled(*loc);
            *o = after;
            let before = self.lanes[l].intensity();
            removed(
                l,
                if before == top {
                    r
                } else {
                    before - after.intensity()
                },
            );
        }
        out
    }

    fn map_frame(&mut self, f: impl Fn(DVec3) -> DVec3) {
        for c in self.used_mut() {
            c.map_frame(&f);
        }
    }

    fn is_valid(&self) -> bool {
        self.used().iter().all(Carrier::is_valid)
    }

    /// The components of the first lane (tallies take each lane's own).
    fn components(&self, d: DVec3, to: DVec3, out: &mut [f64; 16]) -> usize {
        self.lanes[0].components(d, to, out)
    }
}

/// The Stokes columns of [`Polarised<N>`] at many wavelengths, stored by
/// component, column and wavelength: `rows[i][j][l]` is component `i` of
/// column `j` at wavelength `l` (lane `l` is `Polarised { rows[i][j] =
/// rows[i][j][l], x }`). The lanes share one reference vector `x`: their
/// paths, and so their frames, are the same.
///
/// The same carrier as [`Spectral<Polarised<N>>`], with the same arithmetic
/// lane by lane (a unit test checks that bit for bit), laid out so that
/// frame turns, Fresnel matrices and roulette scale all wavelengths in
/// vector code; and smaller (one reference vector, not one per lane).
/// Roulette, unit and rescaling follow [`Spectral`]: the brightest lane
/// decides, every lane scales alike.
#[derive(Debug, Clone, Copy)]
pub struct SpectralPolarised<const N: usize, const CAP: usize = MAX_WAVELENGTHS> {
    rows: [[[f64; CAP]; N]; 4],
    x: DVec3,
    len: usize,
}

impl<const N: usize, const CAP: usize> SpectralPolarised<N, CAP> {
    /// Apply the rotator `(cos 2a, sin 2a)` of [`rotation`] to every lane
    /// (the products and sums of [`super::rotate_rows`]).
    #[inline]
    fn rotate(&mut self, (c2, s2): (f64, f64)) {
        let len = self.len;
        let [_, r1, r2, _] = &mut self.rows;
        for (r1, r2) in r1.iter_mut().zip(r2.iter_mut()) {
            for (v1, v2) in r1[..len].iter_mut().zip(&mut r2[..len]) {
                let (a, b) = (*v1, *v2);
                *v1 = c2 * a + s2 * b;
                *v2 = -s2 * a + c2 * b;
            }
        }
    }

    /// The Fresnel matrices of lanes `at..` (as many as `f` holds, up to
    /// the lanes in use) in the s frame, after the frame turn `rotator`
    /// ([`SpectralPolarised::rotate`], in the same pass): the products and
    /// sums of [`Polarised::fresnel_in`].
    #[inline]
    fn turn_and_apply(&mut self, at: usize, f: &FresnelChunk, rotator: Option<(f64, f64)>) {
        match rotator {
            Some(r) => self.apply::<true>(at, f, r),
            None => self.apply::<false>(at, f, (1.0, 0.0)),
        }
    }

    /// [`SpectralPolarised::turn_and_apply`], turning the frame by
    /// `(c2, s2)` if `TURN`.
    #[inline]
    fn apply<const TURN: bool>(&mut self, at: usize, f: &FresnelChunk, (c2, s2): (f64, f64)) {
        let to = (at + CHUNK).min(self.len);
        let m = to - at;
        let [r0, r1, r2, r3] = &mut self.rows;
        for j in 0..N {
            let lanes = r0[j][at..to]
                .iter_mut()
                .zip(&mut r1[j][at..to])
                .zip(r2[j][at..to].iter_mut().zip(&mut r3[j][at..to]));
            let coefficients = f.a[..m]
                .iter()
                .zip(&f.b[..m])
                .zip(f.c[..m].iter().zip(&f.d[..m]));
            for (((v0, v1), (v2, v3)), ((&a, &b), (&c, &d))) in lanes.zip(coefficients) {
                let (x0, mut x1, mut x2, x3) = (*v0, *v1, *v2, *v3);
                if TURN {
                    (x1, x2) = (c2 * x1 + s2 * x2, -s2 * x1 + c2 * x2);
                }
                *v0 = a * x0 + b * x1;
                *v1 = b * x0 + a * x1;
                *v2 = c * x2 - d * x3;
                *v3 = d * x2 + c * x3;
            }
        }
    }

    /// Every component of lane `l` times `g[l]`.
    #[inline]
    fn scale_lanes(&mut self, g: &[f64; CAP]) {
        let len = self.len;
        for row in self.rows.iter_mut().flatten() {
            for (v, g) in row[..len].iter_mut().zip(&g[..len]) {
                *v *= g;
            }
        }
    }

    /// Every lane scaled so that the brightest lane has intensity `s`: each
    /// lane as [`Spectral::scale_to`] and [`Polarised::survive`] scale it.
    #[inline]
    fn scale_to(&mut self, s: f64) {
        let i = self.intensity();
        if !(i > 0.0 && s != i) {
            return;
        }
        let f = s / i;
        // Lane l: factor g[l] and new intensity `after[l]` (a lane that
        // `Polarised::survive` leaves as it is keeps factor 1 and its own).
        let mut g = [1.0; CAP];
        let mut after = self.rows[0][0];
        let mut any = false;
        for (l, a) in after[..self.len].iter_mut().enumerate() {
            let ci = *a;
            let t = if ci == i { s } else { ci * f };
            if t != ci && ci > 0.0 {
                g[l] = t / ci;
                *a = t;
                any = true;
            }
        }
        if any {
            self.scale_lanes(&g);
            // Exactly the target, as `Polarised::survive` leaves it.
            self.rows[0][0][..self.len].copy_from_slice(&after[..self.len]);
        }
    }

    /// Every component of every lane times `f`.
    #[inline]
    fn scale(&mut self, f: f64) {
        let len = self.len;
        for row in self.rows.iter_mut().flatten() {
            for v in &mut row[..len] {
                *v *= f;
            }
        }
    }

    /// A Fresnel reflection of every wavelength, the coefficients
    /// [`CHUNK`] lanes at a time by [`FresnelLanes::chunk`], the frame turn
    /// once.
    #[inline]
    fn reflect_fresnel(&mut self, fresnel: &FresnelLanes, d: DVec3, n: DVec3, cos_i: f64) -> bool {
        // Finite coefficients with a >= 0 for every valid index and any
        // finite cosine (FresnelLanes recomputes the lanes that are not).
        if !cos_i.is_finite() {
            return false;
        }
        let turn = self.s_turn(d, n);
        let mut f = FresnelChunk::ZERO;
        for index in 0..self.len.div_ceil(CHUNK) {
            fresnel.chunk_into::<true>(cos_i, index, &mut f);
            self.turn_and_apply(CHUNK * index, &f, turn.rotator);
        }
        self.x = turn.s;
        true
    }

    /// A reflection off a material whose wavelengths differ in kind (not all
    /// Fresnel): lane by lane as [`Polarised::reflect`], all or none.
    fn reflect_each(&mut self, material: &Reflectance, d: DVec3, n: DVec3, cos_i: f64) -> bool {
        let mut out = *self;
        for l in 0..self.len {
            let mut lane = self.lane(l);
            if !lane.reflect(material.lane(l), d, n, cos_i) {
                return false;
            }
            out.set_lane(l, &lane);
        }
        *self = out;
        true
    }

    /// Lane `l` becomes `p` (the reference vector too: the lanes share it).
    fn set_lane(&mut self, l: usize, p: &Polarised<N>) {
        for (rows, prow) in self.rows.iter_mut().zip(&p.rows) {
            for (row, &v) in rows.iter_mut().zip(prow) {
                row[l] = v;
            }
        }
        self.x = p.x;
    }
}

impl<const N: usize, const CAP: usize> Carrier for SpectralPolarised<N, CAP> {
    type Lane = Polarised<N>;

    fn launch(incident: Stokes, reference: DVec3, lanes: usize) -> Self {
        let one = Polarised::<N>::launch(incident, reference, 1);
        Self {
            rows: one.rows.map(|r| r.map(|v| [v; CAP])),
            x: reference,
            len: lanes.clamp(1, CAP),
        }
    }

    #[inline]
    fn lanes(&self) -> usize {
        self.len
    }

    #[inline]
    fn lane(&self, l: usize) -> Polarised<N> {
        Polarised {
            rows: std::array::from_fn(|i| std::array::from_fn(|j| self.rows[i][j][l])),
            x: self.x,
        }
    }

    /// The largest intensity of the lanes.
    #[inline]
    fn intensity(&self) -> f64 {
        largest(&self.rows[0][0][..self.len], |&c| c)
    }

    /// The largest of the lanes' weights (tallies score each lane's own).
    fn weight_for(&self, incident: &Stokes) -> f64 {
        (0..self.len).fold(0.0, |m: f64, l| m.max(self.lane(l).weight_for(incident)))
    }

    #[inline]
    fn weights_for(&self, incident: &Stokes, out: &mut [f64]) {
        if N == 1 {
            // `Polarised::<1>::weight_for`: S0.
            out.copy_from_slice(&self.rows[0][0][..out.len()]);
        } else {
            for (l, o) in out.iter_mut().enumerate() {
                *o = self.lane(l).weight_for(incident);
            }
        }
    }

    #[inline]
    fn reflect(&mut self, material: &Reflectance, d: DVec3, n: DVec3, cos_i: f64) -> bool {
        match material {
            Reflectance::Spectral(m) => match m.fresnel() {
                Some(fresnel) if fresnel.len() >= self.len => {
                    self.reflect_fresnel(fresnel, d, n, cos_i)
                }
                _ => self.reflect_each(material, d, n, cos_i),
            },
            // One model for every wavelength: `Polarised::reflect`, once.
            other => reflect_polarised(self, other, d, n, cos_i),
        }
    }

    const POLARISED: bool = true;

    #[inline]
    fn s_turn(&self, d: DVec3, n: DVec3) -> STurn {
        s_turn_from(self.x, d, n)
    }

    #[inline]
    fn fresnel_in(&mut self, turn: &STurn, f: &FresnelMueller) {
        let chunk = FresnelChunk {
            a: [f.a; CHUNK],
            b: [f.b; CHUNK],
            c: [f.c; CHUNK],
            d: [f.d; CHUNK],
        };
        for at in (0..self.len).step_by(CHUNK) {
            self.turn_and_apply(at, &chunk, turn.rotator);
        }
        self.x = turn.s;
    }

    fn mirror(&mut self, rho: f64, d: DVec3, n: DVec3) {
        let turn = self.s_turn(d, n);
        if let Some(r) = turn.rotator {
            self.rotate(r);
        }
        let len = self.len;
        for (i, rows) in self.rows.iter_mut().enumerate() {
            let f = if i < 2 { rho } else { -rho };
            for row in rows {
                for v in &mut row[..len] {
                    *v *= f;
                }
            }
        }
        self.x = turn.s;
    }

    fn depolarise(&mut self, factor: f64, d_out: DVec3) {
        let len = self.len;
        for row in &mut self.rows[0] {
            for v in &mut row[..len] {
                *v *= factor;
            }
        }
        for rows in &mut self.rows[1..] {
            *rows = [[0.0; CAP]; N];
        }
        self.x = d_out.any_orthonormal_vector();
    }

    fn depolarise_lanes(&mut self, factors: &[f64], d_out: DVec3) {
        let len = self.len;
        for row in &mut self.rows[0] {
            for (v, f) in row[..len].iter_mut().zip(factors) {
                *v *= f;
            }
        }
        for rows in &mut self.rows[1..] {
            *rows = [[0.0; CAP]; N];
        }
        self.x = d_out.any_orthonormal_vector();
    }

    fn transfer(&mut self, d: DVec3, x_in: DVec3, m: &[f64; 16], factor: f64, x_out: DVec3) {
        self.rotate(rotation(d, self.x, x_in));
        let v = self.rows;
        for (i, rows) in self.rows.iter_mut().enumerate() {
            for (j, row) in rows.iter_mut().enumerate() {
                for (l, o) in row[..self.len].iter_mut().enumerate() {
                    *o = factor
                        * (m[4 * i] * v[0][j][l]
                            + m[4 * i + 1] * v[1][j][l]
                            + m[4 * i + 2] * v[2][j][l]
                            + m[4 * i + 3] * v[3][j][l]);
                }
            }
        }
        self.x = x_out;
    }

    /// Lane `l` by `ms[l]` and `factors[l]`: the arithmetic of `transfer`
    /// lane by lane, so equal matrices and factors give its bits.
    fn transfer_lanes(
        &mut self,
        d: DVec3,
        x_in: DVec3,
        ms: &[&[f64; 16]],
        factors: &[f64],
        x_out: DVec3,
    ) {
        self.rotate(rotation(d, self.x, x_in));
        let v = self.rows;
        for (i, rows) in self.rows.iter_mut().enumerate() {
            for (j, row) in rows.iter_mut().enumerate() {
                for (l, o) in row[..self.len].iter_mut().enumerate() {
                    let (m, factor) = (ms[l], factors[l]);
                    *o = factor
                        * (m[4 * i] * v[0][j][l]
                            + m[4 * i + 1] * v[1][j][l]
                            + m[4 * i + 2] * v[2][j][l]
                            + m[4 * i + 3] * v[3][j][l]);
                }
            }
        }
        self.x = x_out;
    }

    #[inline]
    fn survive(&mut self, s: f64) {
        self.scale_to(s);
    }

    fn unit(&self) -> Self {
        let mut u = *self;
        u.scale_to(1.0);
        u
    }

    /// The local history's lanes times this carrier's largest intensity;
    /// the intensity removed is that of the brightest lane.
    fn rescaled(&self, mut local: Self) -> (Self, f64) {
        let top = self.intensity();
        local.scale(top);
        let removed = top - local.intensity();
        (local, removed)
    }

    /// [`SpectralPolarised::rescaled`] with each lane's removed intensity,
    /// its intensity before minus after (for the brightest lane the same
    /// number as [`Spectral::rescaled_lanes`] gives it).
    fn rescaled_lanes(&self, mut local: Self, mut removed: impl FnMut(usize, f64)) -> Self {
        local.scale(self.intensity());
        for l in 0..self.len {
            removed(l, self.rows[0][0][l] - local.rows[0][0][l]);
        }
        local
    }

    fn map_frame(&mut self, f: impl Fn(DVec3) -> DVec3) {
        self.x = f(self.x);
    }

    fn is_valid(&self) -> bool {
        let len = self.len;
        self.x.is_finite()
            && self.rows[0][0][..len].iter().all(|&i| i >= 0.0)
            && self
                .rows
                .iter()
                .flatten()
                .all(|row| row[..len].iter().all(|v| v.is_finite()))
    }

    /// The components of the first lane (tallies take each lane's own).
    fn components(&self, d: DVec3, to: DVec3, out: &mut [f64; 16]) -> usize {
        self.lane(0).components(d, to, out)
    }
}

/// The largest of `f(item)` and 0 (NaN never wins): the number
/// `items.fold(0.0, |m, x| if f(x) > m { f(x) } else { m })` gives, by four
/// running maxima (a fold of one is a chain of dependent comparisons).
#[inline]
fn largest<T>(items: &[T], f: impl Fn(&T) -> f64) -> f64 {
    let mut m = [0.0_f64; 4];
    let chunks = items.chunks_exact(4);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (m, x) in m.iter_mut().zip(chunk) {
            let v = f(x);
            if v > *m {
                *m = v;
            }
        }
    }
    for (m, x) in m.iter_mut().zip(rest) {
        let v = f(x);
        if v > *m {
            *m = v;
        }
    }
    let pick = |a: f64, b: f64| if b > a { b } else { a };
    pick(pick(m[0], m[1]), pick(m[2], m[3]))
}

/// A monochrome carrier (the lane) and the carrier of many wavelengths made
/// of such lanes.
pub trait LaneCarrier: Carrier<Lane = Self> {
    /// The carrier of up to `CAP` wavelengths whose lanes are `Self`.
    type Spectrum<const CAP: usize>: Carrier<Lane = Self>;
}

impl LaneCarrier for f64 {
    type Spectrum<const CAP: usize> = Spectral<f64, CAP>;
}

impl<const N: usize> LaneCarrier for Polarised<N> {
    type Spectrum<const CAP: usize> = SpectralPolarised<N, CAP>;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Per-lane removed intensities: each lane's before minus after, and
    /// equal lanes the monochrome carrier's `rescaled` bit for bit.
    #[test]
    fn rescaled_lanes_gives_each_lanes_removed_intensity() {
        let (d, n) = (DVec3::NEG_Z, DVec3::Z);
        let mut w = Spectral::<f64>::launch([1.0, 0.0, 0.0, 0.0], DVec3::X, 3);
        let lanes = Reflectance::Spectral(std::sync::Arc::new(
            crate::optics::material::SpectralModel::new(vec![
                Reflectance::Constant(0.7),
                Reflectance::Constant(0.35),
                Reflectance::Constant(0.7),
            ]),
        ));
        assert!(w.reflect(&lanes, d, n, 1.0));
        let mut local = w.unit();
        assert!(local.reflect(&Reflectance::Constant(0.3), d, n, 1.0));
        let mut removed = Vec::new();
        let out = w.rescaled_lanes(local, |l, r| removed.push((l, r)));
        let mono = 0.7_f64.rescaled(0.3);
        assert_eq!((out.lane(0), removed[0]), (mono.0, (0, mono.1)));
        assert_eq!((out.lane(2), removed[2]), (mono.0, (2, mono.1)));
        assert_eq!(removed[1].0, 1);
        assert!((removed[1].1 - 0.35 * 0.7).abs() < 1e-15, "{removed:?}");
        assert!((out.lane(1) - 0.35 * 0.3).abs() < 1e-15);
        // The scalar carrier: `rescaled`'s removed intensity, lane 0.
        let mut one = Vec::new();
        assert_eq!(0.7.rescaled_lanes(0.3, |l, r| one.push((l, r))), mono.0);
        assert_eq!(one, [(0, mono.1)]);
    }

    /// [`SpectralPolarised`] against the array of lanes [`Spectral`] of the
    /// same [`Polarised`] carrier, bit for bit, over random chains of every
    /// operation (Fresnel lanes, one Fresnel material, mirrors, tabulated
    /// Mueller matrices, depolarisers, roulette, wall rescaling).
    fn soa_is_the_array_of_lanes<const N: usize>(lanes: usize, seed: u64) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let unit = |rng: &mut rand_pcg::Pcg64Mcg| loop {
            let v = DVec3::new(
                rng.random::<f64>() * 2.0 - 1.0,
                rng.random::<f64>() * 2.0 - 1.0,
                rng.random::<f64>() * 2.0 - 1.0,
            );
            if let Some(u) = v.try_normalize().filter(|_| v.length() <= 1.0) {
                return u;
            }
        };
        let nk: Vec<(f64, f64)> = (0..lanes)
            .map(|_| (0.1 + 3.0 * rng.random::<f64>(), 8.0 * rng.random::<f64>()))
            .collect();
        let fresnel = Reflectance::Spectral(std::sync::Arc::new(
            crate::optics::material::SpectralModel::new(
                nk.iter()
                    .map(|&(n, k)| Reflectance::Fresnel { n, k })
                    .collect(),
            ),
        ));
        assert!(matches!(&fresnel, Reflectance::Spectral(m) if m.fresnel().is_some()));
        // Lanes of different kinds: no FresnelLanes, lane by lane.
        let mixed = Reflectance::Spectral(std::sync::Arc::new(
            crate::optics::material::SpectralModel::new(
                (0..lanes)
                    .map(|l| {
                        if l % 2 == 0 {
                            Reflectance::Constant(0.5 + 0.01 * l as f64)
                        } else {
                            Reflectance::Fresnel {
                                n: nk[l].0,
                                k: nk[l].1,
                            }
                        }
                    })
                    .collect(),
            ),
        ));
        let one = Reflectance::Fresnel { n: 1.3, k: 2.0 };
        let state = [1.0, 0.3, -0.4, 0.5];
        let mut d = unit(&mut rng);
        let x = d.any_orthonormal_vector();
        let mut a = SpectralPolarised::<N, 128>::launch(state, x, lanes);
        let mut b = Spectral::<Polarised<N>, 128>::launch(state, x, lanes);
        let same = |a: &SpectralPolarised<N, 128>, b: &Spectral<Polarised<N>, 128>| {
            assert_eq!(a.lanes(), b.lanes());
            for l in 0..a.lanes() {
                assert_eq!(a.lane(l), b.lane(l), "lane {l}");
            }
            assert_eq!(a.intensity().to_bits(), b.intensity().to_bits());
            assert_eq!(
                a.weight_for(&state).to_bits(),
                b.weight_for(&state).to_bits()
            );
            assert_eq!(a.is_valid(), b.is_valid());
        };
        for step in 0..400 {
            let mut n = unit(&mut rng);
            if n.dot(d) > 0.0 {
                n = -n;
            }
            let cos_i = -d.dot(n);
            let out = (d + 2.0 * cos_i * n).normalize();
            match step % 9 {
                0..=2 => {
                    assert!(a.reflect(&fresnel, d, n, cos_i));
                    assert!(b.reflect(&fresnel, d, n, cos_i));
                }
                3 => {
                    assert!(a.reflect(&mixed, d, n, cos_i));
                    assert!(b.reflect(&mixed, d, n, cos_i));
                }
                4 => {
                    assert!(a.reflect(&one, d, n, cos_i));
                    assert!(b.reflect(&one, d, n, cos_i));
                }
                5 => {
                    let m: [f64; 16] = std::array::from_fn(|i| {
                        if i == 0 {
                            1.0
                        } else {
                            0.4 * rng.random::<f64>() - 0.2
                        }
                    });
                    let (x_in, x_out) = (d.any_orthonormal_vector(), out.any_orthonormal_vector());
                    a.transfer(d, x_in, &m, 0.7, x_out);
                    b.transfer(d, x_in, &m, 0.7, x_out);
                    // And a matrix and factor of each lane's own.
                    let ms: Vec<[f64; 16]> = (0..lanes)
                        .map(|_| {
                            std::array::from_fn(|i| {
                                if i == 0 {
                                    1.0
                                } else {
                                    0.4 * rng.random::<f64>() - 0.2
                                }
                            })
                        })
                        .collect();
                    let refs: Vec<&[f64; 16]> = ms.iter().collect();
                    let f: Vec<f64> = (0..lanes)
                        .map(|_| 0.5 + 0.5 * rng.random::<f64>())
                        .collect();
                    let (x_in, x_out) = (d.any_orthonormal_vector(), out.any_orthonormal_vector());
                    a.transfer_lanes(d, x_in, &refs, &f, x_out);
                    b.transfer_lanes(d, x_in, &refs, &f, x_out);
                }
                6 => {
                    a.mirror(0.9, d, n);
                    b.mirror(0.9, d, n);
                }
                7 if step % 5 == 0 => {
                    a.depolarise(0.8, out);
                    b.depolarise(0.8, out);
                }
                _ => {
                    // A wall: the local history from the unit carrier, rescaled.
                    let (mut la, mut lb) = (a.unit(), b.unit());
                    same(&la, &lb);
                    assert!(la.reflect(&fresnel, d, n, cos_i));
                    assert!(lb.reflect(&fresnel, d, n, cos_i));
                    let (mut ra, mut rb) = (Vec::new(), Vec::new());
                    let (na, nb) = (
                        a.rescaled_lanes(la, |l, r| ra.push((l, r.to_bits()))),
                        b.rescaled_lanes(lb, |l, r| rb.push((l, r.to_bits()))),
                    );
                    assert_eq!(ra, rb);
                    let (pa, pb) = (a.rescaled(la), b.rescaled(lb));
                    assert_eq!(pa.1.to_bits(), pb.1.to_bits());
                    (a, b) = (na, nb);
                }
            }
            d = out;
            same(&a, &b);
            let i = a.intensity();
            if i < 0.05 {
                a.survive(0.5);
                b.survive(0.5);
                same(&a, &b);
            }
        }
        // A failed reflection leaves both unchanged.
        let (a0, b0) = (a, b);
        assert!(!a.reflect(&fresnel, d, -d, f64::NAN));
        assert!(!b.reflect(&fresnel, d, -d, f64::NAN));
        same(&a, &b);
        same(&a0, &b0);
    }

    /// `largest` is the sequential fold's number, NaN, zeros and ties included.
    #[test]
    fn largest_is_the_fold() {
        let mut x = 7_u64;
        for len in 0..40 {
            for _ in 0..50 {
                let v: Vec<f64> = (0..len)
                    .map(|_| {
                        x = x
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        match x >> 60 {
                            0 => f64::NAN,
                            1 => -0.0,
                            2 => 0.0,
                            3 => -1.0,
                            _ => ((x >> 11) % 5) as f64 * 0.25,
                        }
                    })
                    .collect();
                let fold = v.iter().fold(0.0, |m: f64, &c| if c > m { c } else { m });
                assert_eq!(largest(&v, |&c| c).to_bits(), fold.to_bits(), "{v:?}");
            }
        }
    }

    #[test]
    fn soa_stokes_is_the_array_of_lanes() {
        for (lanes, seed) in [(1, 1), (3, 2), (16, 3), (17, 4), (32, 5), (77, 6), (128, 7)] {
            soa_is_the_array_of_lanes::<1>(lanes, seed);
        }
    }

    #[test]
    fn soa_mueller_is_the_array_of_lanes() {
        for (lanes, seed) in [(1, 11), (5, 12), (33, 13), (128, 14)] {
            soa_is_the_array_of_lanes::<4>(lanes, seed);
        }
    }
}
