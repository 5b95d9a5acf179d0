//! Wall models: what happens where a photon meets a wall of an object.
//!
//! They live in `transport/`, not beside the object's geometry in
//! [`crate::object`], because they are behaviour of a history: they act on
//! what the photon carries ([`Carrier`]) and a micro descent traces a micro
//! history ([`super::micro::trace`]). Each model holds all it uses (a micro
//! descent: the micro surface and its history limits, [`MicroWall`]), so
//! the dependencies point one way: `transport` uses `object` (geometry),
//! `micro` and `optics`; none of them uses `transport`.
//!
//! Users pick one per surface (`[walls]` maps surface names to `[models]`),
//! modelling only what a scene needs:
//!
//! | model | keys | cost | error |
//! |---|---|---|---|
//! | micro descent (ROKS-RG) | `micro = "scene.toml"` | a micro trace per hit | none beyond Monte Carlo |
//! | tabulated BRDF | `brdf = "brdf.csv"` (and `mueller.csv` beside it, if there) | a table lookup | the table's (binning, interpolation in incidence angle, its own noise); without `mueller.csv` it depolarises |
//! | spectral tabulated BRDF | `brdf = "brdf.csv"` of a spectral run | a table lookup and a factor per wavelength | as the tabulated BRDF; depolarises |
//! | ideal specular + diffuse | `specular = s`, `diffuse = d` | trivial | model error |
//! | Fresnel specular | `n = .., k = ..` | trivial | smooth surface only |
//! | specular vs angle | `table = "r.csv"` or `reflectance = r` | trivial | smooth surface only |
//!
//! **Wavelengths.** A spectral carrier ([`crate::transport::carrier::Spectral`])
//! goes through every model along one path: Fresnel, angle-table and
//! constant walls weigh lane `l` with their model at wavelength `l`
//! ([`Reflectance::lane`]), a micro descent carries the lanes through a
//! micro surface whose materials were sampled at the run's wavelengths,
//! ideal walls and a monochrome BRDF table apply the same factor to every
//! wavelength, and a spectral BRDF table ([`SpectralTableWall`]) samples
//! the direction from the mean of its wavelengths' tables and weighs lane
//! `l` by `f_l / f_mean` of the cell chosen (unbiased for every
//! wavelength: the expected weight into a cell is `f_l`); with the
//! `mueller.csv` of its run, lane `l` also takes the Mueller matrix of its
//! own table in that cell, otherwise it depolarises. What a wall
//! removes is tallied per wavelength ([`Carrier::rescaled_lanes`]).
//!
//! **Micro descent.** At the hit the macro surface's local frame is built
//! (normal `n` toward the photon's side, a tangent pair turned by a uniform
//! random angle about `n`); the photon enters the periodic micro surface at a
//! uniform random point of its launch plane, with its direction expressed in
//! that frame, is traced until it leaves the top, and its direction and weight
//! are mapped back.

use glam::DVec3;
use rand::RngExt;

use super::carrier::Carrier;
use super::micro::{Controls, Fate, trace};
use crate::micro::{Edges, MicroSurface, Scratch};
use crate::optics::brdf_table::{BrdfTable, SpectralTables};
use crate::optics::material::Reflectance;
use crate::optics::polarisation::hemisphere_reference;
use crate::optics::spectrum::MAX_WAVELENGTHS;

/// What a micro descent needs: a periodic micro surface and the limits of
/// a history in it.
#[derive(Debug, Clone)]
pub struct MicroWall {
    surface: MicroSurface,
    controls: Controls,
}

impl MicroWall {
    /// The descent into `surface` with `controls`; `None` unless the
    /// surface's edges are periodic (a descent enters it anywhere and the
    /// rough surface must tile the wall).
    #[must_use]
    pub fn new(surface: MicroSurface, controls: Controls) -> Option<Self> {
        (surface.edges == Edges::Periodic).then_some(Self { surface, controls })
    }

    /// The micro surface.
    #[must_use]
    pub fn surface(&self) -> &MicroSurface {
        &self.surface
    }

    /// The history limits inside the micro surface.
    #[must_use]
    pub fn controls(&self) -> &Controls {
        &self.controls
    }
}

/// A BRDF table per wavelength of the run (a spectral `roks brdf` table at
/// the object's wavelengths), sampled through their mean (see the module
/// docs). With Mueller tables attached to every wavelength's table (the
/// run's spectral `mueller.csv`) each lane is transferred by its own
/// matrix; without, the wall depolarises.
#[derive(Debug, Clone)]
pub struct SpectralTableWall {
    /// The mean of the tables: where directions are sampled from.
    mean: BrdfTable,
    /// The table of each wavelength (lane), in the run's order.
    tables: SpectralTables,
    /// Whether every wavelength's table has its Mueller table.
    polarising: bool,
}

impl SpectralTableWall {
    /// The wall of `tables`, one per wavelength of the run, in its order;
    /// `None` for more wavelengths than a carrier holds
    /// ([`MAX_WAVELENGTHS`]).
    #[must_use]
    pub fn new(tables: SpectralTables) -> Option<Self> {
        (tables.tables().len() <= MAX_WAVELENGTHS).then(|| Self {
            mean: tables.mean(),
            polarising: tables.tables().iter().all(BrdfTable::has_mueller),
            tables,
        })
    }

    /// The tables, one per wavelength.
    #[must_use]
    pub fn tables(&self) -> &SpectralTables {
        &self.tables
    }

    /// Whether every wavelength's table has its Mueller table.
    #[must_use]
    pub fn polarising(&self) -> bool {
        self.polarising
    }
}

/// How a wall reflects.
#[derive(Debug, Clone)]
pub enum WallModel {
    /// Descend into an explicit micro geometry (periodic) at every hit.
    Micro(Box<MicroWall>),
    /// Sample a BRDF table written by `roks brdf`.
    Table(Box<BrdfTable>),
    /// Sample the tables of a spectral `roks brdf` run, one per wavelength.
    SpectralTable(Box<SpectralTableWall>),
    /// Ideal reflection: specular with probability `specular`, Lambertian
    /// with probability `diffuse`, absorbed otherwise.
    Ideal {
        /// Specular reflectance.
        specular: f64,
        /// Diffuse (Lambertian) reflectance.
        diffuse: f64,
    },
    /// Specular reflection weighted by a reflectance model (Fresnel, table, constant).
    Specular(Reflectance),
}

/// The outcome of one wall interaction; `C` is the photon's [`Carrier`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Interaction<C = f64> {
    /// Reflected into `dir` (unit, on the photon's side); `weight` is what
    /// the wall made of the carrier it was given (intensity 1): the
    /// intensity factor, >= 0, which may exceed 1 after Russian roulette in
    /// a micro descent.
    Reflected {
        /// New direction.
        dir: DVec3,
        /// The carrier leaving the wall.
        weight: C,
    },
    /// Absorbed by the wall (physics).
    Absorbed,
    /// Lost: a reflectance that is not a finite number >= 0, or inside a
    /// micro descent (bounce cap or numerical guard).
    Lost,
}

/// The local frame of a BRDF table at a wall of unit normal `n` met by the
/// flight `d`: tangents `(t1, t2)` with `t1` toward the light's side of the
/// plane of incidence (a random azimuth at normal incidence), `t2 = n x t1`.
fn table_frame(d: DVec3, n: DVec3, rng: &mut impl rand::Rng) -> (DVec3, DVec3) {
    let toward_light = -d;
    let tangential = toward_light - toward_light.dot(n) * n;
    let t1 = tangential.try_normalize().unwrap_or_else(|| {
        let (e1, e2) = n.any_orthonormal_pair();
        let a = std::f64::consts::TAU * rng.random::<f64>();
        a.cos() * e1 + a.sin() * e2
    });
    (t1, n.cross(t1))
}

/// The Stokes reference vectors of a table reflection in world coordinates:
/// the incoming flight `d`'s and the outgoing local direction `l`'s, each
/// the hemisphere reference of the table's local frame `(t1, t2, n)` (light
/// azimuth 0), as a `mueller.csv` tabulates them.
fn table_references(d: DVec3, l: DVec3, (t1, t2, n): (DVec3, DVec3, DVec3)) -> (DVec3, DVec3) {
    let world = |v: DVec3| v.x * t1 + v.y * t2 + v.z * n;
    let local_in = DVec3::new(d.dot(t1), d.dot(t2), d.dot(n));
    (
        world(hemisphere_reference(local_in, 0.0)),
        world(hemisphere_reference(l, 0.0)),
    )
}

/// A unit vector uniformly distributed in cosine about +z (Lambertian).
#[must_use]
pub fn cosine_local(u: f64, v: f64) -> DVec3 {
    let r = u.sqrt();
    let a = std::f64::consts::TAU * v;
    DVec3::new(r * a.cos(), r * a.sin(), (1.0 - u).max(0.0).sqrt())
}

impl WallModel {
    /// Reflect a photon travelling along unit `d` at a wall whose unit normal
    /// `n` faces it (`n . d <= 0`), carrying `w` (intensity 1, its reference
    /// vector in the object's coordinates). `scratch` is this model's micro
    /// scratch. Polarisation (see [`crate::transport::carrier`]): Fresnel
    /// walls apply their Mueller matrix; constant and angle-table walls and
    /// the specular part of ideal walls are non-polarising mirrors; the
    /// Lambertian part and BRDF tables depolarise; a micro descent carries
    /// the state through the micro geometry.
    ///
    /// Always inlined into its one caller, the object loop: left to the
    /// compiler, it was inlined or not as unrelated code changed, and out of
    /// line the carrier's copies in and out cost the radiator 1.1 % more
    /// instructions per photon (41 832 against 41 359).
    #[inline(always)]
    pub fn interact<C: Carrier>(
        &self,
        d: DVec3,
        n: DVec3,
        mut w: C,
        rng: &mut impl rand::Rng,
        scratch: &mut Option<Scratch>,
    ) -> Interaction<C> {
        let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
        let mirror = || (d + 2.0 * cos_i * n).normalize();
        match self {
            Self::Specular(r) => {
                if !w.reflect(r, d, n, cos_i) {
                    return Interaction::Lost;
                }
                Interaction::Reflected {
                    dir: mirror(),
                    weight: w,
                }
            }
            Self::Ideal { specular, diffuse } => {
                let total = specular + diffuse;
                if total <= 0.0 {
                    return Interaction::Absorbed;
                }
                let dir = if rng.random::<f64>() * total < *specular {
                    w.mirror(total, d, n);
                    mirror()
                } else {
                    let (t1, t2) = n.any_orthonormal_pair();
                    let l = cosine_local(rng.random(), rng.random());
                    let dir = l.x * t1 + l.y * t2 + l.z * n;
                    w.depolarise(total, dir);
                    dir
                };
                Interaction::Reflected { dir, weight: w }
            }
            Self::Table(table) => {
                let (t1, t2) = table_frame(d, n, rng);
                let u: [f64; 4] = std::array::from_fn(|_| rng.random());
                match table.sample_cell(cos_i.acos(), u) {
                    Some((l, factor, incidence, cell)) => {
                        let world = |v: DVec3| v.x * t1 + v.y * t2 + v.z * n;
                        let dir = world(l).normalize();
                        match table.mueller(incidence, cell) {
                            // Frames of the table: hemisphere references in
                            // its local frame (light azimuth 0).
                            Some(m) => {
                                let (x_in, x_out) = table_references(d, l, (t1, t2, n));
                                w.transfer(d, x_in, m, factor, x_out);
                            }
                            None => w.depolarise(factor, dir),
                        }
                        Interaction::Reflected { dir, weight: w }
                    }
                    None => Interaction::Absorbed,
                }
            }
            Self::SpectralTable(wall) => {
                let (t1, t2) = table_frame(d, n, rng);
                let u: [f64; 4] = std::array::from_fn(|_| rng.random());
                let Some((l, factor, incidence, cell)) = wall.mean.sample_cell(cos_i.acos(), u)
                else {
                    return Interaction::Absorbed;
                };
                let dir = (l.x * t1 + l.y * t2 + l.z * n).normalize();
                // The cell chosen has a mean fraction > 0 (sample_cell).
                let mean = wall.mean.fraction(incidence, cell);
                let tables = wall.tables.tables();
                let mut factors = [0.0; MAX_WAVELENGTHS];
                for (f, t) in factors.iter_mut().zip(tables) {
                    *f = factor * (t.fraction(incidence, cell) / mean);
                }
                let factors = &factors[..tables.len()];
                if wall.polarising {
                    // Each lane's matrix in the cell chosen (every table has
                    // its Mueller table, so every cell has its matrix).
                    let mut ms = [&[0.0; 16]; MAX_WAVELENGTHS];
                    for (m, t) in ms.iter_mut().zip(tables) {
                        if let Some(tm) = t.mueller(incidence, cell) {
                            *m = tm;
                        }
                    }
                    let (x_in, x_out) = table_references(d, l, (t1, t2, n));
                    w.transfer_lanes(d, x_in, &ms[..tables.len()], factors, x_out);
                } else {
                    w.depolarise_lanes(factors, dir);
                }
                Interaction::Reflected { dir, weight: w }
            }
            Self::Micro(micro) => {
                let MicroWall { surface, controls } = micro.as_ref();
                // Frame turned by a uniform random angle about n.
                let (e1, e2) = n.any_orthonormal_pair();
                let a = std::f64::consts::TAU * rng.random::<f64>();
                let t1 = a.cos() * e1 + a.sin() * e2;
                let t2 = n.cross(t1);
                let local = DVec3::new(d.dot(t1), d.dot(t2), d.dot(n));
                let Some(local) = local.try_normalize().filter(|l| l.z < 0.0) else {
                    return Interaction::Lost;
                };
                let start = DVec3::new(
                    rng.random::<f64>() * surface.size.x,
                    rng.random::<f64>() * surface.size.y,
                    surface.top,
                );
                let scratch = scratch.get_or_insert_with(|| Scratch::new(surface));
                w.map_frame(|x| DVec3::new(x.dot(t1), x.dot(t2), x.dot(n)));
                let h = trace(surface, start, local, w, controls, rng, scratch);
                match h.fate {
                    Fate::Escaped { dir: l, mut weight } => {
                        weight.map_frame(|x| x.x * t1 + x.y * t2 + x.z * n);
                        Interaction::Reflected {
                            dir: (l.x * t1 + l.y * t2 + l.z * n).normalize(),
                            weight,
                        }
                    }
                    Fate::Absorbed => Interaction::Absorbed,
                    Fate::Wall { .. } | Fate::Capped { .. } | Fate::Numeric { .. } => {
                        Interaction::Lost
                    }
                }
            }
        }
    }

    /// Whether the model can change the polarisation of light in a way its
    /// intensity depends on: a Fresnel wall, a micro descent whose micro
    /// scene has a Fresnel material, or a BRDF table with its Mueller table.
    /// Every other model is non-polarising or depolarising (see
    /// [`WallModel::interact`]), so scalar transport is exact for it
    /// whatever the incident state.
    #[must_use]
    pub fn polarises(&self) -> bool {
        match self {
            Self::Specular(r) => r.polarises(),
            Self::Micro(micro) => micro.surface.materials.iter().any(Reflectance::polarises),
            Self::Table(t) => t.has_mueller(),
            Self::SpectralTable(w) => w.polarising(),
            Self::Ideal { .. } => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    #[test]
    fn cosine_sampling_has_the_lambertian_moments() {
        // E[mu] = 2/3, E[mu^2] = 1/2 for a cosine-weighted hemisphere.
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let n = 200_000;
        let (mut s1, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let l = cosine_local(rng.random(), rng.random());
            assert!((l.length() - 1.0).abs() < 1e-12 && l.z >= 0.0);
            s1 += l.z;
            s2 += l.z * l.z;
        }
        let (m1, m2) = (s1 / n as f64, s2 / n as f64);
        // Standard errors: sd(mu) = sqrt(1/2 - 4/9) = 0.236; sd(mu^2) = sqrt(1/3 - 1/4) = 0.289.
        assert!(
            (m1 - 2.0 / 3.0).abs() < 4.0 * 0.236 / (n as f64).sqrt(),
            "{m1}"
        );
        assert!((m2 - 0.5).abs() < 4.0 * 0.289 / (n as f64).sqrt(), "{m2}");
    }

    #[test]
    fn a_micro_wall_needs_periodic_edges_and_mirrors_on_a_flat_surface() {
        let surface = |edges| {
            MicroSurface::new(
                glam::DVec2::ONE,
                edges,
                Vec::new(),
                vec![Reflectance::Constant(0.5)],
                0,
            )
        };
        assert!(MicroWall::new(surface(Edges::Absorbing), Controls::default()).is_none());
        assert!(MicroWall::new(surface(Edges::Reflecting), Controls::default()).is_none());
        let wall = MicroWall::new(surface(Edges::Periodic), Controls::default()).expect("periodic");
        assert_eq!(wall.controls(), &Controls::default());
        assert_eq!(wall.surface().solids().len(), 1);
        // A bare substrate of reflectance 0.5: the descent is a mirror of 0.5.
        let model = WallModel::Micro(Box::new(wall));
        assert!(!model.polarises());
        let d = DVec3::new(1.0, 0.0, -1.0).normalize();
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        for _ in 0..100 {
            match model.interact(d, DVec3::Z, 1.0, &mut rng, &mut None) {
                Interaction::Reflected { dir, weight } => {
                    assert!((dir - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12);
                    assert_eq!(weight, 0.5);
                }
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn specular_wall_mirrors_and_weights() {
        let wall = WallModel::Specular(Reflectance::Constant(0.3));
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        let d = DVec3::new(1.0, 0.0, -1.0).normalize();
        match wall.interact(d, DVec3::Z, 1.0, &mut rng, &mut None) {
            Interaction::Reflected {
                dir,
                weight: factor,
            } => {
                assert!((dir - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-15);
                assert_eq!(factor, 0.3);
            }
            other => panic!("{other:?}"),
        }
    }
}
