//! Radiance maps (`roks render`) of a micro surface (below) and of an
//! object scene ([`render_object`], with light sampling: the `lit`
//! submodule), written as OpenEXR (linear radiance) with a PNG preview
//! tone-mapped by [`tonemap`].
//!
//! Camera: orthographic, its footprint exactly one period `Lx x Ly` of the
//! substrate on the launch plane `z = surface.top`. Pixel `(i, j)` (column
//! `i`, row `j`, row 0 at the top of the image) covers
//! `[i Lx/w, (i+1) Lx/w] x [Ly - (j+1) Ly/h, Ly - j Ly/h]`, so the image's x
//! axis is the period's x axis and the image's up is the period's +y. Each pixel
//! takes `spp` jittered sub-pixel positions, all drawn from the random stream
//! `photon_rng(seed, pixel index)` (pixel index `j w + i`): the image is the
//! same, bit for bit, for any number of threads.
//!
//! A camera ray starts on the launch plane and travels along `-v`, `v` the
//! view direction (toward the camera), through the periodic geometry with
//! specular reflections weighted by the materials
//! ([`crate::transport::micro::trace`] with default [`Controls`]).
//!
//! Light: a disc of angular radius `r` around `omega_l` (toward the light) of
//! uniform radiance `L`, and a uniform background of radiance `B` (default 0:
//! nothing elsewhere). A path that escapes ([`Fate::Escaped`]) in a direction
//! within `r` of `omega_l` (cosine test, `dir . omega_l >= cos r`)
//! contributes `weight * L`, one that escapes elsewhere `weight * B` (a small
//! `B` shows the shape of walls the disc leaves dark); every other path
//! contributes 0.
//!
//! Units: pixel values are radiance in the units of `L` (with the default
//! `L = 1`, radiance relative to the disc's radiance). Grey: all three
//! channels are equal. A flat mirror of reflectance `rho` seen in the mirror
//! direction of the disc is `rho L` everywhere.

use glam::DVec3;
use rayon::prelude::*;

use crate::micro::{MicroSurface, Scratch};
use crate::transport::carrier::{Carrier, Spectral};
use crate::transport::micro::{Controls, Fate, trace};
use crate::transport::rng::photon_rng;

pub mod job;
mod lit;
pub mod tonemap;

pub use tonemap::{ToneSettings, Tonemap};

/// What to render. Angles in degrees; directions are
/// `(sin t cos p, sin t sin p, cos t)`, pointing away from the surface.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Image width (pixels, >= 1).
    pub width: usize,
    /// Image height (pixels, >= 1).
    pub height: usize,
    /// Samples per pixel (>= 1).
    pub spp: u32,
    /// Polar angle of the view direction (toward the camera), in `[0, 90)`.
    pub view_theta_deg: f64,
    /// Azimuth of the view direction.
    pub view_phi_deg: f64,
    /// Polar angle of the direction toward the light's centre, in `[0, 180]`
    /// (measured from +z: the micro surface's normal, the world's +z for objects).
    pub light_theta_deg: f64,
    /// Azimuth of the direction toward the light's centre.
    pub light_phi_deg: f64,
    /// Angular radius of the light disc (degrees, in `(0, 180]`; default 5).
    pub light_radius_deg: f64,
    /// Radiance of the disc (finite, >= 0; default 1): the unit of the image.
    pub light_radiance: f64,
    /// Radiance of the uniform background outside the disc (finite, >= 0,
    /// at most [`MAX_RADIANCE`]; default 0).
    pub background_radiance: f64,
    /// Seed of the per-pixel random streams.
    pub seed: u64,
    /// Object scenes: sample the disc's light at every wall with a BRDF to
    /// evaluate (next-event estimation, see [`render_object`]); default
    /// true. Same expectation either way; micro renders ignore it.
    pub light_sampling: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 256,
            height: 256,
            spp: 16,
            view_theta_deg: 0.0,
            view_phi_deg: 0.0,
            light_theta_deg: 0.0,
            light_phi_deg: 0.0,
            light_radius_deg: 5.0,
            light_radiance: 1.0,
            background_radiance: 0.0,
            seed: 1,
            light_sampling: true,
        }
    }
}

/// The largest light or background radiance a render takes: the image
/// holds f32 radiances (up to 3.4e38), and a background of 1e308 gave an
/// image of infinities.
pub const MAX_RADIANCE: f64 = 1e30;

/// Why a render cannot be made or written: the `roks render` option that
/// sets the offending value (none for values no option sets), and what is
/// wrong. Shown as one line, `OPTION: PROBLEM`.
#[derive(Debug, thiserror::Error)]
#[error("{}{problem}", option.map_or_else(String::new, |o| format!("{o}: ")))]
pub struct RenderError {
    /// The option, e.g. `--size`.
    pub option: Option<&'static str>,
    /// What is wrong.
    pub problem: RenderProblem,
}

impl RenderError {
    fn at(option: &'static str, problem: RenderProblem) -> Self {
        Self {
            option: Some(option),
            problem,
        }
    }
}

impl From<RenderProblem> for RenderError {
    fn from(problem: RenderProblem) -> Self {
        Self {
            option: None,
            problem,
        }
    }
}

/// What is wrong with a render's settings, camera, tone mapping or image
/// ([`RenderError`]). Angles in degrees.
#[derive(Debug, thiserror::Error)]
pub enum RenderProblem {
    /// An image without pixels.
    #[error("image size {width}x{height} must be at least 1x1")]
    Size {
        /// Width (pixels).
        width: usize,
        /// Height (pixels).
        height: usize,
    },
    /// No samples per pixel.
    #[error("spp must be at least 1")]
    Spp,
    /// An angle that is not finite (`name`, e.g. "view phi").
    #[error("{name} = {value} is not finite")]
    NotFinite {
        /// The value's name.
        name: &'static str,
        /// The value.
        value: f64,
    },
    /// A view polar angle outside `[0, 90)`.
    #[error("view theta = {0} degrees must be in [0, 90)")]
    ViewTheta(f64),
    /// A light polar angle outside `[0, 180]`.
    #[error("light theta = {0} degrees must be in [0, 180]")]
    LightTheta(f64),
    /// A light disc radius outside `(0, 180]`.
    #[error("light radius = {0} degrees must be in (0, 180]")]
    LightRadius(f64),
    /// A negative or non-finite radiance.
    #[error("{name} = {value} must be finite and >= 0")]
    Radiance {
        /// The radiance's name.
        name: &'static str,
        /// The value.
        value: f64,
    },
    /// A radiance above [`MAX_RADIANCE`].
    #[error(
        "{name} = {value} is above {MAX_RADIANCE:e}: the image holds f32 radiances (at most 3.4e38)"
    )]
    RadianceTooLarge {
        /// The radiance's name.
        name: &'static str,
        /// The value.
        value: f64,
    },
    /// A camera vector that is not finite.
    #[error("{0} must be finite")]
    Vector(DVec3),
    /// A look-at point at the camera.
    #[error("must differ from the camera position")]
    LookAtIsCamera,
    /// An up vector that is zero or along the viewing axis.
    #[error("must not be zero or parallel to the viewing axis")]
    Up,
    /// A field of view outside `(0, 180)`.
    #[error("fov = {0} degrees must be in (0, 180)")]
    Fov(f64),
    /// An exposure that is NaN or beyond [`tonemap::MAX_EV`].
    #[error("EV = {0} must be finite and in [-{max}, {max}]", max = tonemap::MAX_EV)]
    Exposure(f64),
    /// Log-curve decades outside `(0, 300]`.
    #[error("D = {0} must be in (0, 300]")]
    Decades(f64),
    /// An image whose pixels do not fill it.
    #[error("image of {width}x{height} with {pixels} pixels cannot be written")]
    Image {
        /// Width (pixels).
        width: usize,
        /// Height (pixels).
        height: usize,
        /// Pixels held.
        pixels: usize,
    },
    /// The EXR encoder failed.
    #[error("writing EXR: {0}")]
    Exr(exr::error::Error),
    /// An image wider than PNG allows.
    #[error("image too wide for PNG")]
    PngWidth,
    /// An image taller than PNG allows.
    #[error("image too tall for PNG")]
    PngHeight,
    /// The PNG encoder failed.
    #[error("writing PNG: {0}")]
    Png(image::ImageError),
}

impl RenderSettings {
    /// Check the settings; `Err` is one line starting with the `roks render`
    /// option that sets the offending field (`--size`, `--spp`, `--view`,
    /// `--light`, `--disc`, `--background`), then the field and its range.
    ///
    /// # Errors
    /// The first offending field, as a [`RenderError`].
    pub fn validate(&self) -> Result<(), RenderError> {
        use RenderProblem as P;
        if self.width == 0 || self.height == 0 {
            return Err(RenderError::at(
                "--size",
                P::Size {
                    width: self.width,
                    height: self.height,
                },
            ));
        }
        if self.spp == 0 {
            return Err(RenderError::at("--spp", P::Spp));
        }
        let fin = |option, name, value: f64| {
            if value.is_finite() {
                Ok(())
            } else {
                Err(RenderError::at(option, P::NotFinite { name, value }))
            }
        };
        fin("--view", "view phi", self.view_phi_deg)?;
        fin("--light", "light phi", self.light_phi_deg)?;
        if !(0.0..90.0).contains(&self.view_theta_deg) {
            return Err(RenderError::at("--view", P::ViewTheta(self.view_theta_deg)));
        }
        // Above 90 degrees (object scenes: light from below) is allowed; a
        // micro surface is then simply dark.
        if !(0.0..=180.0).contains(&self.light_theta_deg) {
            return Err(RenderError::at(
                "--light",
                P::LightTheta(self.light_theta_deg),
            ));
        }
        if !(self.light_radius_deg > 0.0 && self.light_radius_deg <= 180.0) {
            return Err(RenderError::at(
                "--disc",
                P::LightRadius(self.light_radius_deg),
            ));
        }
        for (option, name, value) in [
            (None, "light radiance", self.light_radiance),
            (
                Some("--background"),
                "background radiance",
                self.background_radiance,
            ),
        ] {
            let problem = if !(value.is_finite() && value >= 0.0) {
                P::Radiance { name, value }
            } else if value > MAX_RADIANCE {
                P::RadianceTooLarge { name, value }
            } else {
                continue;
            };
            return Err(RenderError { option, problem });
        }
        Ok(())
    }
}

/// An RGB image of f32 radiances, row-major, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width (pixels).
    pub width: usize,
    /// Height (pixels).
    pub height: usize,
    /// `width * height` pixels; pixel `(i, j)` is `rgb[j * width + i]`.
    pub rgb: Vec<[f32; 3]>,
}

impl Image {
    /// `Err` unless the image has at least one pixel and `width * height` of them.
    fn check(&self) -> Result<(), RenderProblem> {
        if self.width == 0 || self.height == 0 || self.rgb.len() != self.width * self.height {
            return Err(RenderProblem::Image {
                width: self.width,
                height: self.height,
                pixels: self.rgb.len(),
            });
        }
        Ok(())
    }
}

/// Estimated peak memory (bytes) of rendering and writing a `w x h` image:
/// per pixel the rows and the image (12 + 12 bytes of f32 RGB), then the EXR
/// file (up to 12) and the PNG preview's luminances, bytes and file
/// (8 + 3 + 3) beside the image: about 40 bytes a pixel.
#[must_use]
pub fn image_memory_bytes(w: u64, h: u64) -> u64 {
    crate::limits::product(&[w, h, 40])
}

/// Unit direction from polar angle and azimuth in degrees.
fn direction(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = phi_deg.to_radians().sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

/// The largest f64 below a positive finite `x` (`f64::next_down` needs Rust 1.86).
fn below(x: f64) -> f64 {
    f64::from_bits(x.to_bits() - 1)
}

/// How a camera path ended, for [`render_pixels`]; `C` is what it carried.
enum PathEnd<C> {
    /// Left the scene along `dir` with `weight`; `disc`: whether the light
    /// disc is seen there (false when the last wall sampled the disc's
    /// light: an escape into the disc then adds 0, see [`render_object`]).
    Escaped { dir: DVec3, weight: C, disc: bool },
    /// Absorbed (physics): adds 0.
    Absorbed,
    /// Cut by a cap or guard, or absorbed by an edge wall: adds 0, counted.
    Lost,
    /// Met a surface without a wall model: adds 0, counted.
    Unmodelled,
}

/// The pixel loop of both renders. Pixel `(i, j)` draws its `spp` sub-pixel
/// positions `(u, v)` in `[0, 1)²` (u first) and every path from
/// `photon_rng(seed, j w + i)`; `path(scratch, i, j, u, v, rng, lit)` follows one
/// camera path and adds the radiance it samples from the light to `lit`
/// (one entry per wavelength). A path that escapes within the light disc
/// (and sees it) adds `weight * light_radiance`, one that escapes elsewhere
/// `weight * background_radiance`. Rows run in parallel with one `scratch` each;
/// the image does not depend on the thread count.
///
/// `to_rgb[l]` turns the weight of wavelength `l` into R, G, B (for a
/// monochrome render `[[1, 1, 1]]`: three equal channels; see [`to_rgb`]).
fn render_pixels<S, C: Carrier>(
    s: &RenderSettings,
    to_rgb: &[[f64; 3]],
    scratch: impl Fn() -> S + Sync,
    path: impl Fn(&mut S, usize, usize, f64, f64, &mut rand_pcg::Pcg64Mcg, &mut [f64]) -> PathEnd<C>
    + Sync,
) -> (Image, RenderLosses) {
    use rand::RngExt;
    let (w, h) = (s.width, s.height);
    let light = direction(s.light_theta_deg, s.light_phi_deg);
    let cos_r = s.light_radius_deg.to_radians().cos();
    let rows: Vec<(Vec<[f32; 3]>, RenderLosses)> = (0..h)
        .into_par_iter()
        .map(|j| {
            let mut state = scratch();
            let mut losses = RenderLosses::default();
            // The pixel's radiance per wavelength, summed over its samples.
            let mut lanes = vec![0.0_f64; to_rgb.len()];
            let row = (0..w)
                .map(|i| {
                    let mut rng = photon_rng(s.seed, (j * w + i) as u64);
                    lanes.fill(0.0);
                    for _ in 0..s.spp {
                        let u: f64 = rng.random();
                        let v: f64 = rng.random();
                        match path(&mut state, i, j, u, v, &mut rng, &mut lanes) {
                            PathEnd::Escaped { dir, weight, disc } => {
                                let radiance = if dir.dot(light) < cos_r {
                                    s.background_radiance
                                } else if disc {
                                    s.light_radiance
                                } else {
                                    0.0
                                };
                                for (l, sum) in lanes.iter_mut().enumerate() {
                                    *sum += weight.lane(l).intensity() * radiance;
                                }
                            }
                            PathEnd::Absorbed => {}
                            PathEnd::Lost => losses.lost += 1,
                            PathEnd::Unmodelled => losses.unmodelled += 1,
                        }
                    }
                    let mut sum = [0.0_f64; 3];
                    for (lane, m) in lanes.iter().zip(to_rgb) {
                        for (c, f) in sum.iter_mut().zip(m) {
                            *c += lane * f;
                        }
                    }
                    sum.map(|c| (c / f64::from(s.spp)) as f32)
                })
                .collect();
            (row, losses)
        })
        .collect();
    let mut losses = RenderLosses::default();
    let mut rgb = Vec::with_capacity(w * h);
    for (row, l) in rows {
        rgb.extend(row);
        losses.lost += l.lost;
        losses.unmodelled += l.unmodelled;
    }
    (
        Image {
            width: w,
            height: h,
            rgb,
        },
        losses,
    )
}

/// Radiance map of a micro scene (see the module documentation for the
/// camera, the light and the units), and the camera paths lost (bounce or
/// segment cap, numerical guard, absorbing edge wall; they add 0).
///
/// # Panics
/// If `s` fails [`RenderSettings::validate`].
#[must_use]
pub fn render(surface: &MicroSurface, s: &RenderSettings) -> (Image, RenderLosses) {
    render_at(surface, &[], s)
}

/// [`render`] of a spectral scene: every camera path carries a weight per
/// wavelength of `wavelengths_um` (empty: monochrome, [`render`]), and the
/// pixel is their colour ([`to_rgb`]): linear sRGB under D65 when the
/// wavelengths cover the visible, else their mean in all three channels.
///
/// # Panics
/// If `s` fails [`RenderSettings::validate`].
#[must_use]
pub fn render_at(
    surface: &MicroSurface,
    wavelengths_um: &[f64],
    s: &RenderSettings,
) -> (Image, RenderLosses) {
    if let Err(e) = s.validate() {
        panic!("render: {e}");
    }
    let dir = -direction(s.view_theta_deg, s.view_phi_deg);
    let controls = Controls::default();
    let (lx, ly) = (surface.size.x, surface.size.y);
    let (px, py) = (lx / s.width as f64, ly / s.height as f64);
    let rgb = to_rgb(wavelengths_um);
    let lanes = wavelengths_um.len();
    if lanes > 0 {
        return render_pixels(
            s,
            &rgb,
            || Scratch::new(surface),
            |scratch, i, j, u, v, rng, _| {
                let start = pixel_start(surface, (px, py), i, j, u, v);
                let w = Spectral::<f64>::launch([1.0, 0.0, 0.0, 0.0], DVec3::X, lanes);
                micro_end(trace(surface, start, dir, w, &controls, rng, scratch).fate)
            },
        );
    }
    render_pixels(
        s,
        &rgb,
        || Scratch::new(surface),
        |scratch, i, j, u, v, rng, _| {
            let start = pixel_start(surface, (px, py), i, j, u, v);
            micro_end(trace(surface, start, dir, 1.0, &controls, rng, scratch).fate)
        },
    )
}

/// Where the camera path of pixel `(i, j)` at sub-pixel `(u, v)` enters a
/// micro surface of pixels `(px, py)`.
fn pixel_start(
    surface: &MicroSurface,
    (px, py): (f64, f64),
    i: usize,
    j: usize,
    u: f64,
    v: f64,
) -> DVec3 {
    let (lx, ly) = (surface.size.x, surface.size.y);
    // x in [i px, (i+1) px), y in [Ly - (j+1) py, Ly - j py):
    // both strictly inside the period's half-open range.
    let x = ((i as f64 + u) * px).clamp(0.0, lx);
    let y = (ly - (j as f64 + 1.0 - v) * py).clamp(0.0, ly);
    // Rounding can reach the far side: step just inside.
    let x = if x >= lx { below(lx) } else { x };
    let y = if y >= ly { below(ly) } else { y };
    DVec3::new(x, y, surface.top)
}

/// A micro history's end as a camera path's.
fn micro_end<C>(fate: Fate<C>) -> PathEnd<C> {
    match fate {
        Fate::Escaped { dir, weight } => PathEnd::Escaped {
            dir,
            weight,
            disc: true,
        },
        Fate::Absorbed => PathEnd::Absorbed,
        Fate::Wall { .. } | Fate::Capped { .. } | Fate::Numeric { .. } => PathEnd::Lost,
    }
}

/// The weights that turn the radiance of each of `wavelengths_um` into
/// R, G, B: for wavelengths covering the visible, linear sRGB under D65
/// (`optics::colour`: XYZ weights times the IEC 61966-2-1 matrix, so a
/// radiance of 1 at every wavelength gives the D65 white, about (1, 1, 1));
/// otherwise the mean over the wavelengths in all three channels; for a
/// monochrome render (no wavelengths) three equal channels.
#[must_use]
pub fn to_rgb(wavelengths_um: &[f64]) -> Vec<[f64; 3]> {
    if wavelengths_um.is_empty() {
        return vec![[1.0; 3]];
    }
    match crate::optics::colour::XyzWeights::d65(wavelengths_um) {
        Some(w) => w.srgb_weights(),
        None => vec![[1.0 / wavelengths_um.len() as f64; 3]; wavelengths_um.len()],
    }
}

/// A pinhole camera for object scenes (macro level). Lengths in the scene's
/// units; `fov_deg` is the vertical full angle of view in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Eye position.
    pub position: DVec3,
    /// Point the optical axis passes through.
    pub look_at: DVec3,
    /// Approximate up direction of the image (made orthogonal to the axis).
    pub up: DVec3,
    /// Vertical full field of view (degrees, in `(0, 180)`).
    pub fov_deg: f64,
}

impl PinholeCamera {
    /// Check the camera; `Err` is one line starting with the `roks render`
    /// option that sets the offending field (`--camera`, `--look-at`,
    /// `--up`, `--fov`).
    ///
    /// # Errors
    /// The first offending field, as a [`RenderError`].
    pub fn validate(&self) -> Result<(), RenderError> {
        use RenderProblem as P;
        for (option, v) in [
            ("--camera", self.position),
            ("--look-at", self.look_at),
            ("--up", self.up),
        ] {
            if !v.is_finite() {
                return Err(RenderError::at(option, P::Vector(v)));
            }
        }
        let f = self.look_at - self.position;
        if f.length() == 0.0 {
            return Err(RenderError::at("--look-at", P::LookAtIsCamera));
        }
        if f.normalize().cross(self.up).length() < 1e-9 {
            return Err(RenderError::at("--up", P::Up));
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(RenderError::at("--fov", P::Fov(self.fov_deg)));
        }
        Ok(())
    }

    /// Unit direction of the ray through image point `(x, y)` in pixels
    /// (`x` right in `[0, w]`, `y` down in `[0, h]`).
    #[must_use]
    pub fn ray(&self, x: f64, y: f64, w: usize, h: usize) -> DVec3 {
        let f = (self.look_at - self.position).normalize();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        let t = (0.5 * self.fov_deg).to_radians().tan();
        let sx = (2.0 * x / w as f64 - 1.0) * t * (w as f64 / h as f64);
        let sy = (1.0 - 2.0 * y / h as f64) * t;
        (f + sx * r + sy * u).normalize()
    }
}

/// Radiance map of an object scene seen through a pinhole camera.
///
/// Each camera ray is followed backward through the object by the macro
/// history loop (that of [`crate::transport::object::trace`], the same wall
/// models as `roks trace`); by reciprocity of the walls' BRDFs a path that
/// leaves the object (or misses it) in a direction within
/// `light_radius_deg` of the light direction contributes
/// `weight * light_radiance`, any other `weight * background_radiance`.
/// The light is a disc at infinity in world direction `(light_theta_deg,
/// light_phi_deg)` (polar angle from world +z). With `light_sampling`, the
/// disc's light is also sampled at every wall that has a BRDF to evaluate
/// (tables, Lambertian walls: next-event estimation, the estimator of the
/// `lit` module's documentation), and a path escaping into the disc after
/// such a wall adds 0 instead: the same expectation, far less noise on
/// glossy and diffuse walls. `view_*` of `s` are not used. Pixel `(i, j)`
/// draws from `photon_rng(seed, j w + i)`: the same image for any thread
/// count. Histories cut by caps or guards, or hitting unmodelled surfaces,
/// add 0 and are counted in the returned [`RenderLosses`].
///
/// # Panics
/// If `s` or `camera` fail their `validate`.
#[must_use]
pub fn render_object(
    scene: &crate::scene::object::ObjectScene,
    camera: &PinholeCamera,
    s: &RenderSettings,
) -> (Image, RenderLosses) {
    if let Err(e) = s.validate().and_then(|()| camera.validate()) {
        panic!("render_object: {e}");
    }
    let wavelengths = &scene.run.wavelengths_um;
    let rgb = to_rgb(wavelengths);
    let scratch = || lit::LitScratch::new(scene.models.len(), wavelengths.len());
    if wavelengths.is_empty() {
        render_pixels(s, &rgb, scratch, object_path(scene, camera, s, 1.0))
    } else {
        let w = Spectral::<f64>::launch([1.0, 0.0, 0.0, 0.0], DVec3::X, wavelengths.len());
        render_pixels(s, &rgb, scratch, object_path(scene, camera, s, w))
    }
}

/// The camera path of an object render, carrying `w` at launch.
fn object_path<'a, C: Carrier + 'a>(
    scene: &'a crate::scene::object::ObjectScene,
    camera: &'a PinholeCamera,
    s: &'a RenderSettings,
    w: C,
) -> impl Fn(
    &mut lit::LitScratch,
    usize,
    usize,
    f64,
    f64,
    &mut rand_pcg::Pcg64Mcg,
    &mut [f64],
) -> PathEnd<C>
+ Sync
+ 'a {
    let disc = lit::Disc::new(s);
    move |scratch, i, j, u, v, rng, lit| {
        let d = camera.ray(i as f64 + u, j as f64 + v, s.width, s.height);
        lit::trace_lit(
            scene,
            &disc,
            s.light_sampling,
            camera.position,
            d,
            w,
            rng,
            scratch,
            lit,
        )
    }
}

/// Camera paths of a render that ended without a physical outcome.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderLosses {
    /// Cut by the bounce cap, a numerical guard, or lost in a micro descent.
    pub lost: u64,
    /// Met a surface without a wall model.
    pub unmodelled: u64,
}

/// The image as an OpenEXR file in memory: one layer, scanline blocks, ZIP
/// compression (16 lines per block), f32 channels R, G, B, increasing line
/// order. Write the bytes to a path with `crate::output`'s atomic writer.
///
/// # Errors
/// An image without its pixels, or the encoder's failure.
pub fn write_exr(img: &Image) -> Result<Vec<u8>, RenderProblem> {
    use exr::prelude::*;
    img.check()?;
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let w = img.width;
    let layer = Layer::new(
        (img.width, img.height),
        LayerAttributes {
            software_name: Some(Text::from(crate::outdir::kind::EXR_SOFTWARE)),
            ..LayerAttributes::named("radiance")
        },
        encoding,
        SpecificChannels::rgb(|p: Vec2<usize>| {
            let [r, g, b] = img.rgb[p.y() * w + p.x()];
            (r, g, b)
        }),
    );
    let image = exr::image::Image::from_layer(layer);
    let mut buf = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut buf)
        .map_err(RenderProblem::Exr)?;
    Ok(buf.into_inner())
}

/// Tone-mapped 8-bit RGB PNG preview, in memory (exposure, curve and
/// sRGB encoding: [`tonemap`]), and the exposure and decades used.
///
/// # Errors
/// An image without its pixels, bad tone settings, or the encoder's failure.
pub fn write_png_preview(
    img: &Image,
    tone: &ToneSettings,
) -> Result<(Vec<u8>, tonemap::Applied), RenderError> {
    use image::ImageEncoder;
    img.check()?;
    tone.validate()?;
    let (bytes, applied) = tonemap::map(img, tone);
    let mut out = Vec::new();
    let width = u32::try_from(img.width).map_err(|_| RenderProblem::PngWidth)?;
    let height = u32::try_from(img.height).map_err(|_| RenderProblem::PngHeight)?;
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&bytes, width, height, image::ExtendedColorType::Rgb8)
        .map_err(RenderProblem::Png)?;
    Ok((crate::outdir::kind::mark_png(out), applied))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::micro::Edges;
    use crate::optics::material::Reflectance;
    use glam::DVec2;

    fn flat(rho: f64) -> MicroSurface {
        MicroSurface::new(
            DVec2::new(30.0, 20.0),
            Edges::Periodic,
            vec![],
            vec![Reflectance::Constant(rho)],
            0,
        )
    }

    fn settings() -> RenderSettings {
        RenderSettings {
            width: 16,
            height: 12,
            spp: 4,
            view_theta_deg: 30.0,
            view_phi_deg: 180.0,
            light_theta_deg: 30.0,
            light_phi_deg: 0.0,
            light_radius_deg: 5.0,
            // rho L = 1.5 and every partial sum of it are exact in f64 and f32.
            light_radiance: 2.0,
            background_radiance: 0.0,
            seed: 3,
            light_sampling: true,
        }
    }

    #[test]
    fn flat_mirror_in_the_mirror_direction_is_rho_l() {
        let (img, _) = render(&flat(0.75), &settings());
        assert_eq!((img.width, img.height, img.rgb.len()), (16, 12, 16 * 12));
        for p in &img.rgb {
            assert_eq!(*p, [1.5_f32; 3]);
        }
    }

    /// A flat mirror whose reflectance varies with wavelength, seen in the
    /// mirror direction: each pixel is the colour of `rho(λ) L` (linear
    /// sRGB under D65, computed here from `optics::colour` directly); a
    /// grey mirror gives `rho L` times D65's white in sRGB, about (1, 1, 1).
    #[test]
    fn spectral_flat_mirror_is_the_colour_of_its_reflectance() {
        use crate::optics::colour::{xyz_d65, xyz_to_linear_srgb};
        use crate::optics::material::SpectralModel;
        let wavelengths: Vec<f64> = (0..21).map(|i| 0.38 + 0.02 * f64::from(i)).collect();
        let rho: Vec<f64> = (0..21).map(|i| 0.2 + 0.03 * f64::from(i)).collect();
        let model = Reflectance::Spectral(std::sync::Arc::new(SpectralModel::new(
            rho.iter().map(|&r| Reflectance::Constant(r)).collect(),
        )));
        let surface = MicroSurface::new(
            DVec2::new(30.0, 20.0),
            Edges::Periodic,
            vec![],
            vec![model],
            0,
        );
        let (img, _) = render_at(&surface, &wavelengths, &settings());
        let radiance: Vec<f64> = rho.iter().map(|r| r * 2.0).collect();
        let expect = xyz_to_linear_srgb(xyz_d65(&wavelengths, &radiance).unwrap());
        for p in &img.rgb {
            for c in 0..3 {
                assert!(
                    (f64::from(p[c]) - expect[c]).abs() <= 1e-6 * expect[c].abs(),
                    "{p:?} vs {expect:?}"
                );
            }
        }
        // Wavelengths that miss the visible: the mean over them, grey.
        let ir: Vec<f64> = (0..21).map(|i| 3.0 + 0.5 * f64::from(i)).collect();
        let (img, _) = render_at(&surface, &ir, &settings());
        let mean = radiance.iter().sum::<f64>() / 21.0;
        for p in &img.rgb {
            assert!(
                p.iter()
                    .all(|&c| (f64::from(c) - mean).abs() <= 1e-6 * mean),
                "{p:?}"
            );
        }
    }

    #[test]
    fn flat_mirror_away_from_the_disc_is_black() {
        let mut s = settings();
        s.view_theta_deg = 50.0; // 20 degrees from the mirror direction
        let (img, _) = render(&flat(0.75), &s);
        assert!(img.rgb.iter().all(|p| *p == [0.0; 3]));
        let mut s = settings();
        s.view_theta_deg = 10.0; // 20 degrees from the mirror direction, other side
        let (img, _) = render(&flat(0.75), &s);
        assert!(img.rgb.iter().all(|p| *p == [0.0; 3]));
    }

    #[test]
    fn flat_mirror_away_from_the_disc_is_rho_b() {
        let mut s = settings();
        s.view_theta_deg = 50.0;
        s.background_radiance = 0.5;
        let (img, _) = render(&flat(0.75), &s);
        assert!(img.rgb.iter().all(|p| *p == [0.375_f32; 3]));
        // The disc keeps its own radiance: the background does not add to it.
        s.view_theta_deg = 30.0;
        let (img, _) = render(&flat(0.75), &s);
        assert!(img.rgb.iter().all(|p| *p == [1.5_f32; 3]));
    }

    #[test]
    fn same_image_for_any_thread_count() {
        let scene = crate::scene::micro::MicroScene::default_scene();
        let s = RenderSettings {
            width: 24,
            height: 16,
            spp: 2,
            view_theta_deg: 20.0,
            view_phi_deg: 180.0,
            light_theta_deg: 20.0,
            light_phi_deg: 0.0,
            light_radius_deg: 10.0,
            ..RenderSettings::default()
        };
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render(&scene.surface, &s).0)
        };
        let a = run(1);
        let b = run(3);
        assert_eq!(a, b);
        assert!(a.rgb.iter().any(|p| p[0] > 0.0), "some light is seen");
        assert!(
            a.rgb
                .iter()
                .all(|p| p[0] >= 0.0 && p[0] == p[1] && p[1] == p[2])
        );
    }

    #[test]
    fn exr_round_trip() {
        use exr::prelude::*;
        let (w, h) = (7, 5);
        let rgb: Vec<[f32; 3]> = (0..w * h)
            .map(|k| {
                [
                    k as f32 * 0.25,
                    1.0 / (k as f32 + 1.0),
                    -(k as f32) * 3.5e-3,
                ]
            })
            .collect();
        let img = super::Image {
            width: w,
            height: h,
            rgb,
        };
        let bytes = write_exr(&img).unwrap();
        let read = read()
            .no_deep_data()
            .largest_resolution_level()
            .rgb_channels(
                |res, _| vec![[0.0_f32; 3]; res.width() * res.height()],
                move |px: &mut Vec<[f32; 3]>, pos, (r, g, b): (f32, f32, f32)| {
                    px[pos.y() * w + pos.x()] = [r, g, b];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(&bytes))
            .unwrap();
        let layer = &read.layer_data;
        assert_eq!(layer.size, Vec2(w, h));
        assert_eq!(layer.encoding.compression, Compression::ZIP16);
        assert_eq!(layer.encoding.blocks, Blocks::ScanLines);
        assert_eq!(layer.channel_data.pixels, img.rgb);
    }

    #[test]
    fn png_preview_has_the_requested_size() {
        let (img, _) = render(&flat(0.75), &settings());
        let (png, _) = write_png_preview(&img, &ToneSettings::default()).unwrap();
        let dec = image::load_from_memory_with_format(&png, image::ImageFormat::Png).unwrap();
        assert_eq!((dec.width(), dec.height()), (16, 12));
        // A uniform image maps to white.
        assert!(dec.to_rgb8().pixels().all(|p| p.0 == [255, 255, 255]));
        // All black stays black.
        let black = Image {
            width: 3,
            height: 2,
            rgb: vec![[0.0; 3]; 6],
        };
        let (png, _) = write_png_preview(&black, &ToneSettings::default()).unwrap();
        let dec = image::load_from_memory(&png).unwrap();
        assert_eq!((dec.width(), dec.height()), (3, 2));
        assert!(dec.to_rgb8().pixels().all(|p| p.0 == [0, 0, 0]));
    }

    #[test]
    fn bad_settings_are_refused() {
        let mut s = settings();
        s.view_theta_deg = 90.0;
        assert!(s.validate().is_err());
        let mut s = settings();
        s.spp = 0;
        assert!(s.validate().is_err());
        let mut s = settings();
        s.background_radiance = -1.0;
        assert!(s.validate().is_err());
        s.background_radiance = 1e308;
        let e = s.validate().unwrap_err();
        assert_eq!(e.option, Some("--background"));
        assert!(e.to_string().starts_with("--background: "), "{e}");
        s.background_radiance = MAX_RADIANCE;
        assert!(s.validate().is_ok());
        assert!(settings().validate().is_ok());
    }

    /// Timing of a full-size render of the default scene:
    /// `cargo test --lib render::tests::time_default_scene -- --ignored --nocapture`.
    #[test]
    #[ignore = "timing only"]
    fn time_default_scene() {
        let scene = crate::scene::micro::MicroScene::default_scene();
        let s = RenderSettings {
            view_theta_deg: 30.0,
            view_phi_deg: 180.0,
            light_theta_deg: 30.0,
            light_phi_deg: 0.0,
            ..RenderSettings::default()
        };
        let t = std::time::Instant::now();
        let (img, _) = render(&scene.surface, &s);
        let dt = t.elapsed().as_secs_f64();
        let mean = img.rgb.iter().map(|p| f64::from(p[0])).sum::<f64>() / img.rgb.len() as f64;
        let lit = img.rgb.iter().filter(|p| p[0] > 0.0).count();
        eprintln!(
            "{}x{}x{} spp: {dt:.2} s on {} threads ({:.2} M paths/s); mean {mean:.4} L, {lit} lit pixels",
            s.width,
            s.height,
            s.spp,
            rayon::current_num_threads(),
            (s.width * s.height) as f64 * f64::from(s.spp) / dt / 1e6
        );
    }
}
