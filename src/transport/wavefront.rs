//! The wavefront (stream) kernel of the micro level: many photons in
//! flight at once, in structure-of-arrays form, advanced stage by stage.
//!
//! [`trace_wave`] traces a run of photons (a batch, or a part of one) with
//! up to [`WAVE`] of them in flight. Each round runs these stages over the
//! live photons, in this order:
//!
//! 1. **launch** (refill): free slots take the next photons of the run, so
//!    the wave stays full while photons are left (their entry points from
//!    their own streams, computed before the wave, as the scalar kernel's);
//! 2. **search**: the next event of each live photon's flight, four slots
//!    at a time ([`MicroSurface::next_events4`]: on a bump surface the
//!    start of each search, `1 / d`, the period's exit and the substrate
//!    plane, in `wide::f64x4` lanes with masks and blends; then each lane's
//!    grid walk and quadric records on their own), with the ends that need
//!    no arithmetic (escape, caps, periodic sides, walls) settled here;
//! 3. **advance**: the hit points `p + t d`, four lanes at a time
//!    (`wide::f64x4`);
//! 4. **normal**: the facet's normal and material at each hit
//!    ([`MicroSurface::hit_normal`], one lane at a time);
//! 5. **reflect**: `cos_i = -d·n` four lanes at a time, the carrier's
//!    reflectance one lane at a time ([`Carrier::reflect`]: a material
//!    model and, for polarised carriers, a Mueller matrix);
//! 6. **direction**: `normalize(d + 2 cos_i n)` four lanes at a time, with
//!    the numerical guards;
//! 7. **roulette**: each survivor's intensity and its draw from its own
//!    stream;
//! 8. **compaction**: ended photons leave their slots (the last live slot
//!    moves into each), so the live photons stay the first slots of the
//!    arrays and every lane of the four-wide stages carries one.
//!
//! Every photon does exactly the floating-point operations of the scalar
//! kernel ([`super::micro::trace`]) in the same order (no fused
//! multiply-add: `wide` multiplies and adds apart, as glam does), draws
//! from its own stream, and its history lands in its own slot of the
//! output: the histories, hence the tallies (scored afterwards in photon
//! order and summed in the fixed batch tree), are the scalar kernel's bit
//! for bit, for every carrier (scalar weight, Stokes vector, Mueller
//! columns, spectral lanes), surface (bumps, bodies, height fields) and
//! launch (random, lattice). The tests of this module and
//! `tests/golden.rs` compare the two kernels' histories and result folders.
//!
//! Why `wide` ([`wide::f64x4`]) and not run-time dispatch (`pulp`,
//! `multiversion`): the stages done in lanes are a few multiplies, adds, a
//! square root and a division per photon and round; `wide` picks its
//! instructions at compile time (SSE2 on the baseline x86-64 target, two
//! `f64x2` halves; AVX with `-C target-cpu`), needs no `unsafe` in this
//! crate, and the binary runs on every x86-64 machine. The grid walk, the
//! quadric tests, the height field's descent and the normal stay scalar per
//! lane: they are data-dependent loops of different lengths per photon.
//! Measured (`docs/src/performance.md`, 2026-12-06): the search's start in
//! lanes takes 4 mispredicted branches a segment off the wavefront kernel
//! and adds 150 instructions (the loads into lanes and back), the same
//! wall-clock; a branch-free quadric test (every root computed, the answer
//! selected) took 1.7 mispredictions off but added 380 instructions, as
//! the compiler turns selects of floats back into branches, and was
//! dropped.
//!
//! Surfaces large enough for the Morton order ([`super::order::pays`]:
//! over 1 MiB of geometry) are traced by it too, a piece of the order
//! (1024 photons) at a time ([`super::parallel_batches_ordered`]). What
//! stays on the scalar kernel: the micro descents of `roks trace`'s walls
//! ([`super::wall`]), one history at a time inside an object history.

use glam::DVec3;
use wide::f64x4;

use super::carrier::Carrier;
use super::micro::{Controls, Fate, History};
use crate::micro::{Edges, Event, Facet, MAX_CROSSINGS, MicroSurface, Scratch, Skip};

/// Photons in flight at once on a thread (slots of a wave).
pub const WAVE: usize = 64;

/// Which kernel traces the micro histories of a `roks brdf` run
/// (`--kernel`): both give the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Kernel {
    /// One photon at a time ([`super::micro::trace`]), the reference.
    #[default]
    #[value(help = None::<&str>)]
    Scalar,
    /// Stages over a wave of photons in structure-of-arrays form ([`trace_wave`]).
    #[value(help = None::<&str>)]
    Wavefront,
}

/// Where a slot's photon is in a round.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    /// Its flight ended at a hit: advance, normal, reflect, direction.
    Hit,
    /// Reflected (a hit or a reflecting wall): roulette.
    Bounced,
    /// Moved on without a reflection (a periodic side, skipped periods).
    Flying,
    /// Its history ended (written to the output).
    Done,
}

/// How a slot's history ends (its [`Fate`] takes the slot's weight and direction).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    Escaped,
    Absorbed,
    Wall,
    Capped,
    Numeric,
}

/// The wave's slots in structure-of-arrays form (slots `0..live` live).
struct Slots<C> {
    /// Index of the slot's photon in the run (into the output).
    id: Vec<u32>,
    /// Position.
    px: Vec<f64>,
    py: Vec<f64>,
    pz: Vec<f64>,
    /// Direction (unit).
    dx: Vec<f64>,
    dy: Vec<f64>,
    dz: Vec<f64>,
    /// Normal at the hit (stage normal).
    nx: Vec<f64>,
    ny: Vec<f64>,
    nz: Vec<f64>,
    /// Distance to the hit (stage search), `cos_i` (stage reflect).
    t: Vec<f64>,
    cos: Vec<f64>,
    /// The facet hit.
    facet: Vec<Facet>,
    /// What the photon carries.
    w: Vec<C>,
    /// Its stream.
    rng: Vec<rand_pcg::Pcg64Mcg>,
    standing: Vec<Option<Facet>>,
    bounces: Vec<u32>,
    segments: Vec<u32>,
    crossings: Vec<u32>,
    /// Intersection tests so far.
    tests: Vec<u64>,
    step: Vec<Step>,
}

impl<C: Carrier> Slots<C> {
    fn new(launch: C) -> Self {
        let f = || vec![0.0; WAVE];
        let u = || vec![0_u32; WAVE];
        Self {
            id: u(),
            px: f(),
            py: f(),
            pz: f(),
            dx: f(),
            dy: f(),
            dz: f(),
            nx: f(),
            ny: f(),
            nz: f(),
            t: f(),
            cos: f(),
            facet: vec![Facet::Triangle(0); WAVE],
            w: vec![launch; WAVE],
            rng: vec![super::rng::photon_rng(0, 0); WAVE],
            standing: vec![None; WAVE],
            bounces: u(),
            segments: u(),
            crossings: u(),
            tests: vec![0; WAVE],
            step: vec![Step::Done; WAVE],
        }
    }

    /// Move slot `from`'s photon into slot `to`.
    fn move_slot(&mut self, from: usize, to: usize) {
        macro_rules! mv {
            ($($f:ident),*) => { $( self.$f[to] = self.$f[from].clone(); )* };
        }
        mv!(
            id, px, py, pz, dx, dy, dz, w, rng, standing, bounces, segments, crossings, tests, step
        );
    }

    fn p(&self, s: usize) -> DVec3 {
        DVec3::new(self.px[s], self.py[s], self.pz[s])
    }

    fn d(&self, s: usize) -> DVec3 {
        DVec3::new(self.dx[s], self.dy[s], self.dz[s])
    }

    fn set_p(&mut self, s: usize, p: DVec3) {
        (self.px[s], self.py[s], self.pz[s]) = (p.x, p.y, p.z);
    }
}

/// Four consecutive slots of `v` from `s` as lanes.
#[inline]
fn lanes(v: &[f64], s: usize) -> f64x4 {
    f64x4::new([v[s], v[s + 1], v[s + 2], v[s + 3]])
}

/// Store lanes `x` into four consecutive slots of `v` from `s`.
#[inline]
fn store(v: &mut [f64], s: usize, x: f64x4) {
    v[s..s + 4].copy_from_slice(&x.to_array());
}

/// Trace `n` photons entering along unit `dir` (z < 0), photon `k` at
/// `start(k)` (on the launch plane, inside the period) with its stream, all
/// carrying `launch`: `out(k, history, tests)` receives each history and the
/// intersection tests it took, once per photon, in the order they end.
/// The histories are those of [`super::micro::trace`] bit for bit (see the
/// module docs).
#[allow(clippy::too_many_arguments)]
pub fn trace_wave<C: Carrier>(
    surface: &MicroSurface,
    n: usize,
    start: impl Fn(usize) -> (DVec3, rand_pcg::Pcg64Mcg),
    dir: DVec3,
    launch: C,
    controls: &Controls,
    scratch: &mut Scratch,
    mut out: impl FnMut(usize, History<C>, u64),
) {
    let mut w = Slots::new(launch);
    let mut next = 0_usize;
    let mut live = 0_usize;
    let mut end = |w: &mut Slots<C>, s: usize, how: End| {
        let weight = w.w[s];
        let fate = match how {
            End::Escaped => Fate::Escaped {
                dir: w.d(s),
                weight,
            },
            End::Absorbed => Fate::Absorbed,
            End::Wall => Fate::Wall { weight },
            End::Capped => Fate::Capped { weight },
            End::Numeric => Fate::Numeric { weight },
        };
        let h = History {
            fate,
            bounces: w.bounces[s],
            segments: w.segments[s],
        };
        out(w.id[s] as usize, h, w.tests[s]);
        w.step[s] = Step::Done;
    };
    while live > 0 || next < n {
        // Launch: refill the free slots.
        while live < WAVE && next < n {
            let s = live;
            let (p, rng) = start(next);
            w.id[s] = next as u32;
            w.set_p(s, p);
            (w.dx[s], w.dy[s], w.dz[s]) = (dir.x, dir.y, dir.z);
            w.w[s] = launch;
            w.rng[s] = rng;
            w.standing[s] = None;
            w.bounces[s] = 0;
            w.segments[s] = 0;
            w.crossings[s] = 0;
            w.tests[s] = 0;
            next += 1;
            live += 1;
        }
        // Search: the next event of every live flight, four slots at a
        // time (MicroSurface::next_events4: the start of each search in
        // lanes, then each lane's grid walk).
        let mut s0 = 0;
        while s0 < live {
            let lanes_here = (live - s0).min(4);
            let mut active = [false; 4];
            let (mut o, mut d, mut on) = ([DVec3::ZERO; 4], [DVec3::ZERO; 4], [None; 4]);
            for k in 0..lanes_here {
                let s = s0 + k;
                if w.segments[s] >= controls.max_segments {
                    end(&mut w, s, End::Capped);
                    continue;
                }
                w.segments[s] += 1;
                active[k] = true;
                (o[k], d[k], on[k]) = (w.p(s), w.d(s), w.standing[s]);
            }
            let mut tests = [0_u64; 4];
            let events = surface.next_events4(o, d, on, active, scratch, &mut tests);
            for k in (0..lanes_here).filter(|&k| active[k]) {
                let s = s0 + k;
                w.tests[s] += tests[k];
                w.step[s] = Step::Flying;
                match events[k] {
                    Event::Top { .. } => {
                        end(&mut w, s, End::Escaped);
                    }
                    Event::Trapped => end(&mut w, s, End::Capped),
                    Event::Moved { at } => {
                        w.set_p(s, at);
                        w.standing[s] = None;
                        w.crossings[s] += 1;
                        if w.crossings[s] >= MAX_CROSSINGS {
                            end(&mut w, s, End::Capped);
                        }
                    }
                    Event::Hit { t, facet } => {
                        if w.bounces[s] >= controls.max_bounces {
                            end(&mut w, s, End::Capped);
                        } else {
                            w.t[s] = t;
                            w.facet[s] = facet;
                            w.step[s] = Step::Hit;
                        }
                    }
                    Event::Side { t, axis, upper } => {
                        side(surface, controls, &mut w, s, t, axis, upper, &mut end);
                    }
                }
            }
            s0 += 4;
        }
        // Advance: p += t d at the hits (four lanes at a time; the others
        // keep their position bit for bit).
        let mut s = 0;
        while s < live {
            if s + 4 <= live {
                let t = lanes(&w.t, s);
                let hit = f64x4::new(std::array::from_fn(|k| {
                    if w.step[s + k] == Step::Hit {
                        f64::from_bits(u64::MAX)
                    } else {
                        0.0
                    }
                }));
                for (pv, dv) in [(&mut w.px, &w.dx), (&mut w.py, &w.dy), (&mut w.pz, &w.dz)] {
                    let (x, dx) = (lanes(pv, s), lanes(dv, s));
                    store(pv, s, hit.blend(x + t * dx, x));
                }
                s += 4;
            } else {
                if w.step[s] == Step::Hit {
                    let p = w.p(s) + w.t[s] * w.d(s);
                    w.set_p(s, p);
                }
                s += 1;
            }
        }
        // Normal: the facet's normal and material at each hit; the
        // carrier's reflectance.
        for s in 0..live {
            if w.step[s] != Step::Hit {
                continue;
            }
            let mut p = w.p(s);
            let d = w.d(s);
            let Some((n, material)) = surface.hit_normal(&mut p, d, w.facet[s]) else {
                end(&mut w, s, End::Numeric);
                continue;
            };
            w.set_p(s, p);
            (w.nx[s], w.ny[s], w.nz[s]) = (n.x, n.y, n.z);
            let cos_i = -d.dot(n);
            w.cos[s] = cos_i;
            if !w.w[s].reflect(&surface.materials[material], d, n, cos_i) {
                end(&mut w, s, End::Numeric);
            }
        }
        // Direction: d + 2 cos_i n, normalised (or zero), four lanes at a
        // time, as glam's `normalize_or_zero` computes it.
        let mut s = 0;
        while s < live {
            if s + 4 <= live {
                let (dx, dy, dz) = (lanes(&w.dx, s), lanes(&w.dy, s), lanes(&w.dz, s));
                let (nx, ny, nz) = (lanes(&w.nx, s), lanes(&w.ny, s), lanes(&w.nz, s));
                let k = f64x4::splat(2.0) * lanes(&w.cos, s);
                let (rx, ry, rz) = (dx + k * nx, dy + k * ny, dz + k * nz);
                let rcp = f64x4::ONE / (rx * rx + ry * ry + rz * rz).sqrt();
                let (rx, ry, rz) = (rx * rcp, ry * rcp, rz * rcp);
                let rcp = rcp.to_array();
                let (rx, ry, rz) = (rx.to_array(), ry.to_array(), rz.to_array());
                for k in 0..4 {
                    if w.step[s + k] == Step::Hit {
                        let r = rcp[k];
                        let d = if r.is_finite() && r > 0.0 {
                            DVec3::new(rx[k], ry[k], rz[k])
                        } else {
                            DVec3::ZERO
                        };
                        settle(&mut w, s + k, d, &mut end);
                    }
                }
                s += 4;
            } else {
                if w.step[s] == Step::Hit {
                    let n = DVec3::new(w.nx[s], w.ny[s], w.nz[s]);
                    let d = (w.d(s) + 2.0 * w.cos[s] * n).normalize_or_zero();
                    settle(&mut w, s, d, &mut end);
                }
                s += 1;
            }
        }
        // Roulette: every reflected photon, from its own stream.
        for s in 0..live {
            if w.step[s] != Step::Bounced {
                continue;
            }
            w.bounces[s] += 1;
            let intensity = w.w[s].intensity();
            if intensity <= 0.0 {
                end(&mut w, s, End::Absorbed);
                continue;
            }
            match super::roulette(intensity, controls.roulette_weight, &mut w.rng[s]) {
                Some(survivor) if survivor == intensity => {}
                Some(survivor) => w.w[s].survive(survivor),
                None => end(&mut w, s, End::Absorbed),
            }
        }
        // Compaction: the last live photon into each ended one's slot.
        let mut s = 0;
        while s < live {
            if w.step[s] == Step::Done {
                live -= 1;
                if s < live {
                    w.move_slot(live, s);
                }
            } else {
                s += 1;
            }
        }
    }
}

/// The end of a hit's stage direction at slot `s`: the new direction `d`
/// and the guards of [`super::micro::trace`].
#[inline]
fn settle<C: Carrier>(
    w: &mut Slots<C>,
    s: usize,
    d: DVec3,
    end: &mut impl FnMut(&mut Slots<C>, usize, End),
) {
    if !(w.p(s).is_finite() && d.is_finite()) || d == DVec3::ZERO {
        end(w, s, End::Numeric);
        return;
    }
    (w.dx[s], w.dy[s], w.dz[s]) = (d.x, d.y, d.z);
    w.standing[s] = Some(w.facet[s]);
    w.crossings[s] = 0;
    w.step[s] = Step::Bounced;
}

/// A flight of slot `s` reaching side `axis` (`upper`) at distance `t`: what
/// [`super::micro::trace`] does there (periodic wrap and period skips,
/// absorbing wall, reflecting wall).
#[allow(clippy::too_many_arguments)]
fn side<C: Carrier>(
    surface: &MicroSurface,
    controls: &Controls,
    w: &mut Slots<C>,
    s: usize,
    t: f64,
    axis: usize,
    upper: bool,
    end: &mut impl FnMut(&mut Slots<C>, usize, End),
) {
    let mut d = w.d(s);
    let mut p = w.p(s) + t * d;
    let boundary = if upper { surface.size[axis] } else { 0.0 };
    p[axis] = boundary;
    w.standing[s] = None;
    match surface.edges {
        Edges::Periodic => {
            p[axis] = surface.size[axis] - boundary;
            w.crossings[s] += 1;
            if w.crossings[s] >= super::micro::SKIP_AFTER {
                match surface.skip_periods(p, d, axis) {
                    Skip::None => {}
                    Skip::To { at, .. } => p = at,
                    Skip::Escapes => {
                        w.set_p(s, p);
                        end(w, s, End::Escaped);
                        return;
                    }
                }
            }
            w.set_p(s, p);
            if w.crossings[s] >= MAX_CROSSINGS {
                end(w, s, End::Capped);
            }
        }
        Edges::Absorbing => {
            w.set_p(s, p);
            end(w, s, End::Wall);
        }
        Edges::Reflecting => {
            w.set_p(s, p);
            if w.bounces[s] >= controls.max_bounces {
                end(w, s, End::Capped);
                return;
            }
            let cos_i = d[axis].abs();
            let mut n = DVec3::ZERO;
            n[axis] = -d[axis].signum();
            let wall = &surface.materials[surface.substrate_material];
            if !w.w[s].reflect(wall, d, n, cos_i) {
                end(w, s, End::Numeric);
                return;
            }
            d[axis] = -d[axis];
            (w.dx[s], w.dy[s], w.dz[s]) = (d.x, d.y, d.z);
            w.crossings[s] = 0;
            w.step[s] = Step::Bounced;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::polarisation::hemisphere_reference;
    use crate::scene::micro::{DEFAULT_SCENE, MicroScene};
    use crate::transport::carrier::{LaneCarrier, Polarised};
    use crate::transport::micro::trace;
    use crate::transport::rng::photon_rng;
    use rand::RngExt;

    /// `photons` histories on `surface` at incidence `theta_deg`, traced
    /// by the scalar kernel and by the wavefront kernel (photon `k` from
    /// stream `k`, entering at a point it draws), printed with `{:?}` (so
    /// that `-0.0` and `0.0` differ too), and the tests of each.
    fn both<C: Carrier>(
        surface: &MicroSurface,
        theta_deg: f64,
        photons: usize,
        lanes: usize,
        controls: &Controls,
    ) -> (Vec<String>, Vec<String>) {
        let th = theta_deg.to_radians();
        let dir = DVec3::new(th.sin(), 0.0, -th.cos());
        let launch = C::launch([1.0, 0.3, 0.2, 0.1], hemisphere_reference(dir, 0.0), lanes);
        let start = |k: usize| {
            let mut rng = photon_rng(5, k as u64);
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            let p = DVec3::new(u * surface.size.x, v * surface.size.y, surface.top);
            (p, rng)
        };
        let mut scratch = Scratch::new(surface);
        let scalar = (0..photons)
            .map(|k| {
                let (p, mut rng) = start(k);
                let tests = scratch.tests;
                let h = trace(surface, p, dir, launch, controls, &mut rng, &mut scratch);
                format!("{h:?} {}", scratch.tests - tests)
            })
            .collect();
        let mut wave = vec![String::new(); photons];
        trace_wave(
            surface,
            photons,
            start,
            dir,
            launch,
            controls,
            &mut Scratch::new(surface),
            |k, h, tests| {
                assert!(wave[k].is_empty(), "photon {k} ended twice");
                wave[k] = format!("{h:?} {tests}");
            },
        );
        (scalar, wave)
    }

    fn scene(text: &str) -> MicroScene {
        let file = crate::scene::SceneFile {
            file: "t.toml".into(),
            dir: ".".into(),
        };
        MicroScene::from_str(text, file, "t".into()).unwrap()
    }

    /// The wavefront kernel's histories are the scalar kernel's, bit for
    /// bit (fates, weights, directions, bounces, segments, tests), for the
    /// scalar weight, Stokes vectors, Mueller columns and spectral lanes,
    /// on bumps (periodic, absorbing and reflecting edges), a height field,
    /// at normal, oblique and grazing incidence, with and without tight
    /// bounce and segment caps (a partial last round of lanes included:
    /// 1001 photons).
    #[test]
    fn the_wave_traces_the_scalar_histories() {
        let al = DEFAULT_SCENE.replace("reflectance = 0.8", "n = 1.015\nk = 6.627");
        let edges = |e: &str| DEFAULT_SCENE.replace("\"periodic\"", &format!("\"{e}\""));
        let field = "[surface]\nsize = [16.0, 16.0]\nmaterial = \"al\"\n\
            heightfield = { gaussian = { sigma = 1.0, tau = 2.0 }, resolution = 64, seed = 3 }\n\
            [materials.al]\nn = 1.015\nk = 6.627\n";
        let surfaces = [
            scene(DEFAULT_SCENE),
            scene(&al),
            scene(&edges("absorbing")),
            scene(&edges("reflecting")),
            scene(field),
        ];
        let tight = Controls {
            max_bounces: 2,
            max_segments: 3,
            roulette_weight: 0.9,
        };
        let mut ended = std::collections::BTreeSet::new();
        for s in &surfaces {
            for theta in [0.0, 60.0, 89.0] {
                for controls in [Controls::default(), tight] {
                    let s = &s.surface;
                    let cases = [
                        both::<f64>(s, theta, 1001, 1, &controls),
                        both::<Polarised<1>>(s, theta, 301, 1, &controls),
                        both::<Polarised<4>>(s, theta, 301, 1, &controls),
                        both::<<f64 as LaneCarrier>::Spectrum<8>>(s, theta, 101, 5, &controls),
                    ];
                    for (scalar, wave) in cases {
                        for (k, (a, b)) in scalar.iter().zip(&wave).enumerate() {
                            assert_eq!(a, b, "photon {k} at {theta} deg");
                            for fate in ["Escaped", "Absorbed", "Wall", "Capped"] {
                                if a.contains(&format!("fate: {fate}")) {
                                    ended.insert(fate);
                                }
                            }
                        }
                    }
                }
            }
        }
        // Every end was reached.
        for fate in ["Escaped", "Absorbed", "Wall", "Capped"] {
            assert!(ended.contains(fate), "no {fate} in {ended:?}");
        }
    }
}
