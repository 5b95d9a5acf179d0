//! Camera paths through an object scene with light sampling (next-event
//! estimation toward the light disc).
//!
//! **Estimator.** The pixel value is the radiance `I` reaching the camera,
//! `I = sum over paths of T(path) * (L or B at its end)`, `T` the camera
//! path's throughput (the weight the wall models give it, as
//! [`crate::transport::object::trace`] does). Meeting a small disc by
//! chance after a glossy or diffuse bounce is rare, so at every wall whose
//! BRDF `f` can be evaluated (a BRDF table, monochrome or spectral, and a
//! Lambertian wall: `diffuse = d` without `specular`), the light the disc
//! sends there is estimated directly: one direction `l` drawn uniformly in
//! the disc's cone (solid angle `Omega = 2 pi (1 - cos r)`, density
//! `1 / Omega`) adds
//!
//! `T * f(d, l) * max(0, n . l) * L * Omega`
//!
//! when the ray from the hit along `l` leaves the object (a shadow ray,
//! [`crate::object::Object::next_hit`] from the same surface). `d` is the
//! camera path's flight (its incidence, by the reciprocity the object render
//! already uses), `f` the model's BRDF in sr⁻¹ (the table cell holding `l`
//! in the frame [`crate::transport::wall`] samples in, interpolated in
//! incidence as the sampling is: [`crate::optics::brdf_table::BrdfTable::eval`]).
//! The path then continues by the wall model's own sampling; if the next
//! flight escapes into the disc it adds 0 (that light was counted by the
//! sample), elsewhere the background `B` as before. Mirrors, Fresnel and
//! angle-table walls, ideal walls with a specular part and micro descents
//! have no BRDF to evaluate here: after them the disc is met by chance, as
//! without light sampling. The expectation is the same with and without
//! light sampling (tested on a Lambertian plate, `rho sin² r` exactly, and
//! on a plate of a BRDF table); only the variance differs.

use glam::DVec3;
use rand::RngExt;

use super::{PathEnd, RenderSettings, direction};
use crate::micro::Scratch;
use crate::scene::object::ObjectScene;
use crate::transport::carrier::Carrier;
use crate::transport::wall::{Interaction, WallModel};

/// The light disc at infinity: a cone of half-angle `r` about `axis`
/// (toward the light), of radiance `radiance`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Disc {
    axis: DVec3,
    e1: DVec3,
    e2: DVec3,
    /// `1 - cos r`, as `2 sin²(r/2)` (no cancellation for small discs).
    one_minus_cos: f64,
    /// `2 pi (1 - cos r)` (sr).
    solid_angle: f64,
    radiance: f64,
}

impl Disc {
    pub(super) fn new(s: &RenderSettings) -> Self {
        let axis = direction(s.light_theta_deg, s.light_phi_deg);
        let (e1, e2) = axis.any_orthonormal_pair();
        let half = (0.5 * s.light_radius_deg).to_radians().sin();
        let one_minus_cos = 2.0 * half * half;
        Self {
            axis,
            e1,
            e2,
            one_minus_cos,
            solid_angle: std::f64::consts::TAU * one_minus_cos,
            radiance: s.light_radiance,
        }
    }

    /// A direction uniform in the cone, from two uniform numbers in `[0, 1)`.
    fn sample(&self, u: f64, v: f64) -> DVec3 {
        let z = 1.0 - u * self.one_minus_cos;
        let s = (1.0 - z * z).max(0.0).sqrt();
        let (sp, cp) = (std::f64::consts::TAU * v).sin_cos();
        s * cp * self.e1 + s * sp * self.e2 + z * self.axis
    }
}

/// What a row of an object render keeps between paths: one micro scratch
/// per wall model, and the BRDF of each wavelength at a light sample.
pub(super) struct LitScratch {
    micro: Vec<Option<Scratch>>,
    f: Vec<f64>,
}

impl LitScratch {
    pub(super) fn new(models: usize, lanes: usize) -> Self {
        Self {
            micro: vec![None; models],
            f: vec![0.0; lanes.max(1)],
        }
    }
}

/// Whether the disc's light is sampled at a wall of this model (it has a
/// BRDF [`brdf`] evaluates).
fn samples_light(model: &WallModel) -> bool {
    match model {
        WallModel::Table(_) | WallModel::SpectralTable(_) => true,
        WallModel::Ideal { specular, diffuse } => *specular == 0.0 && *diffuse > 0.0,
        WallModel::Micro(_) | WallModel::Specular(_) => false,
    }
}

/// The BRDF (sr⁻¹) of `model` (one for which [`samples_light`] holds) for
/// a flight along unit `d` meeting a wall of unit normal `n` (facing it),
/// toward unit `l`, per wavelength into `f` (every entry the same for a
/// monochrome model). A table is read in the frame its sampling uses: first
/// tangent toward `-d`'s side of the plane of incidence, a random one at
/// exactly normal incidence (`rng`).
fn brdf(model: &WallModel, d: DVec3, n: DVec3, l: DVec3, rng: &mut impl rand::Rng, f: &mut [f64]) {
    match model {
        WallModel::Table(t) => {
            let (loc, theta) = table_local(d, n, l, rng);
            f.fill(t.eval(theta, loc));
        }
        WallModel::SpectralTable(w) => {
            let (loc, theta) = table_local(d, n, l, rng);
            for (fl, t) in f.iter_mut().zip(w.tables().tables()) {
                *fl = t.eval(theta, loc);
            }
        }
        WallModel::Ideal { diffuse, .. } => f.fill(diffuse / std::f64::consts::PI),
        WallModel::Micro(_) | WallModel::Specular(_) => f.fill(0.0),
    }
}

/// `l` in a table's local frame at a wall of normal `n` met along `d`, and
/// the incidence angle (radians); see [`brdf`].
fn table_local(d: DVec3, n: DVec3, l: DVec3, rng: &mut impl rand::Rng) -> (DVec3, f64) {
    let toward = -d;
    let t1 = (toward - toward.dot(n) * n)
        .try_normalize()
        .unwrap_or_else(|| {
            let (e1, e2) = n.any_orthonormal_pair();
            let a = std::f64::consts::TAU * rng.random::<f64>();
            a.cos() * e1 + a.sin() * e2
        });
    let t2 = n.cross(t1);
    (
        DVec3::new(l.dot(t1), l.dot(t2), l.dot(n)),
        (-d.dot(n)).clamp(0.0, 1.0).acos(),
    )
}

/// Follow the camera path from `p` along unit `d`, carrying `w`, through
/// the object of `scene`: the history loop of
/// [`crate::transport::object::trace`] (same walls, caps, guards and
/// roulette), with the disc's light sampled at every wall that
/// [`samples_light`] when `sample_light` (see the module documentation).
/// The sampled radiance of wavelength `l` is added to `lit[l]`; the end of
/// the path is returned, its escape marked as not seeing the disc when the
/// last wall sampled it.
#[allow(clippy::too_many_arguments)]
pub(super) fn trace_lit<C: Carrier>(
    scene: &ObjectScene,
    disc: &Disc,
    sample_light: bool,
    mut p: DVec3,
    mut d: DVec3,
    mut w: C,
    rng: &mut impl rand::Rng,
    scratch: &mut LitScratch,
    lit: &mut [f64],
) -> PathEnd<C> {
    let object = &scene.object;
    let models = &scene.models;
    let walls = &scene.walls;
    let controls = &scene.run.controls;
    let mut standing = None;
    let mut bounces = 0_u32;
    let mut disc_seen = true;
    loop {
        let Some(hit) = object.next_hit(p, d, standing) else {
            return PathEnd::Escaped {
                dir: d,
                weight: w,
                disc: disc_seen,
            };
        };
        let sid = object.surface_id(hit.zone, hit.surface);
        let Some(m) = walls[sid] else {
            return PathEnd::Unmodelled;
        };
        if bounces >= controls.max_bounces {
            return PathEnd::Lost;
        }
        p += hit.t * d;
        if !p.is_finite() {
            return PathEnd::Lost;
        }
        let quadric = &object.solids[hit.zone].body.surfaces[hit.surface];
        let Some(normal) = quadric.facing_normal(p, d) else {
            return PathEnd::Lost;
        };
        bounces += 1;
        let model = &models[m];
        disc_seen = !(sample_light && samples_light(model));
        if !disc_seen {
            let l = disc.sample(rng.random(), rng.random());
            let cos_l = l.dot(normal);
            if cos_l > 0.0
                && object
                    .next_hit(p, l, Some((hit.zone, hit.surface)))
                    .is_none()
            {
                brdf(model, d, normal, l, rng, &mut scratch.f);
                let g = cos_l * disc.solid_angle * disc.radiance;
                for (lane, (sum, f)) in lit.iter_mut().zip(&scratch.f).enumerate() {
                    *sum += w.lane(lane).intensity() * f * g;
                }
            }
        }
        match model.interact(d, normal, w.unit(), rng, &mut scratch.micro[m]) {
            Interaction::Reflected { dir, weight } => {
                if !weight.is_valid() {
                    return PathEnd::Lost;
                }
                w = w.rescaled_lanes(weight, |_, _| {});
                d = dir;
            }
            Interaction::Absorbed => return PathEnd::Absorbed,
            Interaction::Lost => return PathEnd::Lost,
        }
        let intensity = w.intensity();
        if intensity <= 0.0 {
            return PathEnd::Absorbed;
        }
        if !d.is_finite() {
            return PathEnd::Lost;
        }
        standing = Some((hit.zone, hit.surface));
        match crate::transport::roulette(intensity, controls.roulette_weight, rng) {
            Some(survivor) if survivor == intensity => {}
            Some(survivor) => w.survive(survivor),
            None => return PathEnd::Absorbed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Directions drawn in the cone are unit, inside it, and uniform in
    /// `cos` (mean `1 - (1 - cos r) / 2`, to 4 standard errors).
    #[test]
    fn disc_samples_are_uniform_in_the_cone() {
        use rand::RngExt;
        let s = RenderSettings {
            light_theta_deg: 40.0,
            light_phi_deg: 70.0,
            light_radius_deg: 12.0,
            ..RenderSettings::default()
        };
        let disc = Disc::new(&s);
        let cos_r = 12f64.to_radians().cos();
        assert!((disc.solid_angle - std::f64::consts::TAU * (1.0 - cos_r)).abs() < 1e-15);
        let mut rng = crate::transport::rng::photon_rng(5, 0);
        let n = 100_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let l = disc.sample(rng.random(), rng.random());
            assert!((l.length() - 1.0).abs() < 1e-12);
            let c = l.dot(disc.axis);
            assert!(c >= cos_r - 1e-12);
            sum += c;
        }
        let mean = sum / f64::from(n);
        let width = 1.0 - cos_r;
        let se = width / 12f64.sqrt() / f64::from(n).sqrt();
        assert!((mean - (1.0 - width / 2.0)).abs() < 4.0 * se, "{mean}");
    }
}
