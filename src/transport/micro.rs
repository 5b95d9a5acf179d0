//! One photon history in a micro surface.
//!
//! A photon carries a statistical weight (start 1): a scalar, or a Stokes
//! vector or Mueller matrix with its reference frame ([`super::carrier`]).
//! Every hit on a body is a specular reflection about the local normal; the
//! weight is multiplied by the material's reflectance at the local incidence
//! angle (for polarised carriers: its Mueller matrix in the s frames). Low weights play
//! Russian roulette (unbiased). The history ends when the photon crosses the
//! launch plane going up (it escapes with its direction and weight), or it is
//! absorbed (weight 0 or roulette), or it is lost: absorbed by a wall, cut by
//! the bounce cap, or stopped by a numerical guard. Lost weight is reported,
//! never dropped silently.

use glam::DVec3;

use super::carrier::Carrier;
use crate::micro::{Edges, Event, Facet, MAX_CROSSINGS, MicroSurface, Scratch, Skip};

/// Periodic crossings of one flight after which [`MicroSurface::skip_periods`]
/// is asked, at every further crossing, for whole periods the flight passes
/// above everything (ordinary flights cross fewer, and are traced exactly as
/// before).
pub(crate) const SKIP_AFTER: u32 = 64;

/// Limits of a history.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Controls {
    /// Most reflections before the photon is cut (reported as lost).
    pub max_bounces: u32,
    /// Most straight flights (including periodic wraps) before the photon is cut.
    pub max_segments: u32,
    /// Russian roulette below this weight; survivors carry `min(10 w_rr, 1)`.
    pub roulette_weight: f64,
}

impl Default for Controls {
    fn default() -> Self {
        Self {
            max_bounces: 100_000,
            roulette_weight: 0.01,
            max_segments: 10_000_000,
        }
    }
}

/// How a history in a micro surface ended; `C` is what the photon carried
/// ([`Carrier`]). Not the object level's [`super::object::Fate`]: see
/// [`super::History`] for why they differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fate<C = f64> {
    /// Left through the launch plane with this direction (unit, z > 0) and weight.
    Escaped {
        /// Outgoing direction.
        dir: DVec3,
        /// Weight on leaving.
        weight: C,
    },
    /// Absorbed by the materials (weight reached 0 or lost the roulette): physics, not loss.
    Absorbed,
    /// Absorbed by an absorbing wall (edge effect), with the weight it carried.
    Wall {
        /// Weight carried into the wall.
        weight: C,
    },
    /// Cut by the bounce, segment or crossing cap ([`MAX_CROSSINGS`]), with
    /// the weight it carried.
    Capped {
        /// Weight carried when cut.
        weight: C,
    },
    /// Stopped by a numerical guard (degenerate normal, non-finite direction
    /// or position, a reflectance that is not a finite number >= 0).
    Numeric {
        /// Weight carried when stopped.
        weight: C,
    },
}

/// A finished history in a micro surface ([`super::History`] of a
/// micro [`Fate`]).
pub type History<C = f64> = super::History<Fate<C>>;

/// Trace a photon entering the micro surface at `start` (on or above the
/// launch plane, inside the period) travelling along unit `dir` (z < 0),
/// carrying `w` (its reference vector, if any, in the period's coordinates).
pub fn trace<C: Carrier>(
    surface: &MicroSurface,
    start: DVec3,
    dir: DVec3,
    mut w: C,
    controls: &Controls,
    rng: &mut impl rand::Rng,
    scratch: &mut Scratch,
) -> History<C> {
    let mut p = start;
    let mut d = dir;
    let mut standing: Option<Facet> = None;
    let mut bounces = 0_u32;
    let mut segments = 0_u32;
    // Periodic sides crossed by the current flight (since its last reflection).
    let mut crossings = 0_u32;
    let end = |fate, bounces, segments| History {
        fate,
        bounces,
        segments,
    };
    loop {
        if segments >= controls.max_segments {
            return end(Fate::Capped { weight: w }, bounces, segments);
        }
        segments += 1;
        match surface.next_event(p, d, standing, scratch) {
            Event::Top { .. } => {
                return end(Fate::Escaped { dir: d, weight: w }, bounces, segments);
            }
            Event::Trapped => return end(Fate::Capped { weight: w }, bounces, segments),
            Event::Moved { at } => {
                // Whole periods on (counted as one crossing of the flight).
                p = at;
                standing = None;
                crossings += 1;
                if crossings >= MAX_CROSSINGS {
                    return end(Fate::Capped { weight: w }, bounces, segments);
                }
                continue;
            }
            Event::Hit { t, facet } => {
                if bounces >= controls.max_bounces {
                    return end(Fate::Capped { weight: w }, bounces, segments);
                }
                p += t * d;
                let Some((n, material)) = surface.hit_normal(&mut p, d, facet) else {
                    return end(Fate::Numeric { weight: w }, bounces, segments);
                };
                // Specular reflection, weighted by the reflectance at the local
                // angle (a reflectance that is not a finite number >= 0, also
                // NaN, never reaches a tally).
                let cos_i = -d.dot(n);
                if !w.reflect(&surface.materials[material], d, n, cos_i) {
                    return end(Fate::Numeric { weight: w }, bounces, segments);
                }
                d = (d + 2.0 * cos_i * n).normalize_or_zero();
                if !(p.is_finite() && d.is_finite()) || d == DVec3::ZERO {
                    return end(Fate::Numeric { weight: w }, bounces, segments);
                }
                standing = Some(facet);
                crossings = 0;
            }
            Event::Side { t, axis, upper } => {
                p += t * d;
                let boundary = if upper { surface.size[axis] } else { 0.0 };
                p[axis] = boundary;
                standing = None;
                match surface.edges {
                    Edges::Periodic => {
                        p[axis] = surface.size[axis] - boundary;
                        crossings += 1;
                        if crossings >= SKIP_AFTER {
                            match surface.skip_periods(p, d, axis) {
                                Skip::None => {}
                                Skip::To { at, .. } => p = at,
                                Skip::Escapes => {
                                    return end(
                                        Fate::Escaped { dir: d, weight: w },
                                        bounces,
                                        segments,
                                    );
                                }
                            }
                        }
                        if crossings >= MAX_CROSSINGS {
                            return end(Fate::Capped { weight: w }, bounces, segments);
                        }
                        continue;
                    }
                    Edges::Absorbing => return end(Fate::Wall { weight: w }, bounces, segments),
                    Edges::Reflecting => {
                        if bounces >= controls.max_bounces {
                            return end(Fate::Capped { weight: w }, bounces, segments);
                        }
                        let cos_i = d[axis].abs();
                        let mut n = DVec3::ZERO;
                        n[axis] = -d[axis].signum();
                        let wall = &surface.materials[surface.substrate_material];
                        if !w.reflect(wall, d, n, cos_i) {
                            return end(Fate::Numeric { weight: w }, bounces, segments);
                        }
                        d[axis] = -d[axis];
                        crossings = 0;
                    }
                }
            }
        }
        bounces += 1;
        // The intensity once (a spectral carrier's is a pass over its
        // wavelengths); a survivor keeping its weight is left as it is.
        let intensity = w.intensity();
        if intensity <= 0.0 {
            return end(Fate::Absorbed, bounces, segments);
        }
        match super::roulette(intensity, controls.roulette_weight, rng) {
            Some(survivor) if survivor == intensity => {}
            Some(survivor) => w.survive(survivor),
            None => return end(Fate::Absorbed, bounces, segments),
        }
    }
}
