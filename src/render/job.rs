//! A render as `roks render` asks for it: the options ([`RenderOptions`])
//! turned into checked settings and a camera for a micro scene
//! ([`RenderOptions::micro`]) or an object scene ([`RenderOptions::object`]),
//! the bound on its cost ([`check_cost`]), and the finished images
//! ([`Rendered`]).

use glam::DVec3;

use super::{Image, PinholeCamera, RenderError, RenderSettings, ToneSettings, Tonemap};
use crate::scene::micro::MicroScene;
use crate::scene::object::ObjectScene;

/// The background of an object render when none is given: 1e-3 of the
/// disc's radiance, so that walls the disc leaves dark still show their
/// shape (walls of a few percent reflectance are then a few 1e-5, inside
/// the log preview's automatic range).
pub const OBJECT_BACKGROUND: f64 = 1e-3;

/// The most camera paths (width x height x samples per pixel) a render
/// starts without `--force-long-render`: about an hour on one core at
/// [`PATHS_PER_CORE_SECOND`].
pub const MAX_PATHS: u64 = 10_000_000_000;

/// The most samples per pixel a render starts without
/// `--force-long-render`: 2^24. A pixel's samples are traced in sequence on
/// one core (rows run in parallel), so beyond the bound on all paths
/// ([`MAX_PATHS`]) a small image of many samples would still run for hours
/// on one core (`--size 1,1 --spp 4294967295`: about 24 min per pixel).
/// 2^24 samples take about 6 s per pixel at [`PATHS_PER_CORE_SECOND`], and
/// leave a Monte Carlo error of 1/4096 of one sample's spread.
pub const MAX_SPP: u32 = 1 << 24;

/// Camera paths per second and core of the default micro scene's render,
/// measured (`/usr/bin/time roks render --size 512,512 --spp 64 --threads
/// 1`: 16.8e6 paths in 5.5 s of user time); object scenes with micro
/// walls are slower, so the estimate is a lower bound of the time.
pub const PATHS_PER_CORE_SECOND: f64 = 3e6;

/// Why a render is refused before it starts, or after it ran: one line,
/// naming the option or the scene file.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// An option of two values given another count.
    #[error("{0}: give two comma-separated values")]
    TwoValues(&'static str),
    /// An option of three values given another count.
    #[error("{0}: give three comma-separated values")]
    ThreeValues(&'static str),
    /// More camera paths than [`MAX_PATHS`].
    #[error(
        "--spp: {w} x {h} pixels x {spp} samples = {paths:.3e} camera paths, above the bound of {MAX_PATHS:.0e} (about {hours:.1} h on {threads} cores at {PATHS_PER_CORE_SECOND:.0e} paths/s per core); lower --spp or --size, or give --force-long-render"
    )]
    Paths {
        /// Width (pixels).
        w: u64,
        /// Height (pixels).
        h: u64,
        /// Samples per pixel.
        spp: u32,
        /// Camera paths.
        paths: u64,
        /// Estimated hours.
        hours: f64,
        /// Cores.
        threads: usize,
    },
    /// More samples per pixel than [`MAX_SPP`].
    #[error(
        "--spp: {spp} samples per pixel, above the bound of {MAX_SPP} (2^24): a pixel's samples are traced one after another on one core (about {minutes:.0} min per pixel at {PATHS_PER_CORE_SECOND:.0e} paths/s); lower --spp, or give --force-long-render"
    )]
    Spp {
        /// Samples per pixel.
        spp: u32,
        /// Estimated minutes per pixel.
        minutes: f64,
    },
    /// Settings or camera of an object render refused.
    #[error("{file}: {error}")]
    InScene {
        /// The scene file.
        file: String,
        /// What is wrong.
        error: RenderError,
    },
    /// The camera inside a solid zone.
    #[error("{file}: --camera: the camera position {position} lies inside a solid cell")]
    CameraInside {
        /// The scene file.
        file: String,
        /// The camera position.
        position: DVec3,
    },
    /// Camera paths that met a wall without a model.
    #[error("{file}: walls: {count} camera paths hit a surface without a model in [walls]")]
    Unmodelled {
        /// The scene file.
        file: String,
        /// How many.
        count: u64,
    },
}

/// The cost of a `w` x `h` render at `spp` samples per pixel on `threads`
/// cores: its camera paths and an estimate of its seconds; refused above
/// [`MAX_PATHS`], or above [`MAX_SPP`] samples per pixel, unless `force`.
///
/// # Errors
/// [`JobError::Paths`] or [`JobError::Spp`], naming `--spp` and `--size`,
/// the paths and the time.
pub fn check_cost(w: u64, h: u64, spp: u32, threads: usize, force: bool) -> Result<u64, JobError> {
    let paths = w.saturating_mul(h).saturating_mul(u64::from(spp));
    if paths > MAX_PATHS && !force {
        let hours = paths as f64 / (PATHS_PER_CORE_SECOND * threads.max(1) as f64) / 3600.0;
        let (spp, threads) = (spp, threads);
        return Err(JobError::Paths {
            w,
            h,
            spp,
            paths,
            hours,
            threads,
        });
    }
    if spp > MAX_SPP && !force {
        // A pixel's samples are traced one after another on one core.
        let minutes = f64::from(spp) / PATHS_PER_CORE_SECOND / 60.0;
        return Err(JobError::Spp { spp, minutes });
    }
    Ok(paths)
}

/// What `roks render` asks for, as given (angles in degrees, lengths in
/// scene units): [`micro`](Self::micro) and [`object`](Self::object)
/// check it and fill in the scene's defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Micro scenes: view direction THETA, PHI (toward the camera).
    pub view: Vec<f64>,
    /// Direction THETA, PHI toward the light disc's centre (default: a micro
    /// scene's first incidence; an object scene's: against its first beam).
    pub light: Option<Vec<f64>>,
    /// Angular radius of the light disc.
    pub disc: f64,
    /// Radiance of the background (default 0 for a micro scene,
    /// [`OBJECT_BACKGROUND`] for an object scene).
    pub background: Option<f64>,
    /// Image size W, H (pixels).
    pub size: Vec<usize>,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed.
    pub seed: u64,
    /// Object scenes: camera position X, Y, Z (default: on the first beam's
    /// axis, 2.5 beam-sweep lengths before its start, at least 50 units).
    pub camera: Option<Vec<f64>>,
    /// Object scenes: the point looked at (default: the first beam's start
    /// moved 100 units along the beam).
    pub look_at: Option<Vec<f64>>,
    /// Object scenes: up direction of the image.
    pub up: Vec<f64>,
    /// Object scenes: vertical field of view.
    pub fov: f64,
    /// Object scenes: sample the disc's light at table and Lambertian walls.
    pub light_sampling: bool,
}

impl RenderOptions {
    /// Check that the options of two values have two (`--view`, `--size`,
    /// `--light`).
    ///
    /// # Errors
    /// [`JobError::TwoValues`] naming the option.
    pub fn check_pairs(&self) -> Result<(), JobError> {
        for (name, n) in [
            ("--view", self.view.len()),
            ("--size", self.size.len()),
            ("--light", self.light.as_ref().map_or(2, Vec::len)),
        ] {
            if n != 2 {
                return Err(JobError::TwoValues(name));
            }
        }
        Ok(())
    }

    /// The camera paths of the render.
    #[must_use]
    pub fn paths(&self) -> u64 {
        (self.size[0] * self.size[1]) as u64 * u64::from(self.spp)
    }

    /// The settings with the light toward `light` (degrees) and the
    /// background `background` unless given.
    fn settings(&self, light: (f64, f64), background: f64) -> RenderSettings {
        let (light_theta_deg, light_phi_deg) = match &self.light {
            Some(l) => (l[0], l[1]),
            None => light,
        };
        RenderSettings {
            width: self.size[0],
            height: self.size[1],
            spp: self.spp,
            view_theta_deg: self.view[0],
            view_phi_deg: self.view[1],
            light_theta_deg,
            light_phi_deg,
            light_radius_deg: self.disc,
            light_radiance: 1.0,
            background_radiance: self.background.unwrap_or(background),
            seed: self.seed,
            light_sampling: self.light_sampling,
        }
    }

    /// The settings of a render of the micro `scene`, checked.
    ///
    /// # Errors
    /// The first offending setting ([`RenderSettings::validate`]).
    pub fn micro(&self, scene: &MicroScene) -> Result<RenderSettings, RenderError> {
        let light = (scene.light.theta_deg[0], scene.light.phi_deg[0]);
        let settings = self.settings(light, 0.0);
        settings.validate()?;
        Ok(settings)
    }

    /// The camera and settings of a render of the object `scene`, checked.
    ///
    /// # Errors
    /// An option of three values given another count, a setting or the
    /// camera refused (naming the scene file), a camera inside a solid.
    pub fn object(&self, scene: &ObjectScene) -> Result<(PinholeCamera, RenderSettings), JobError> {
        for (name, v) in [("--camera", &self.camera), ("--look-at", &self.look_at)] {
            if v.as_ref().is_some_and(|v| v.len() != 3) {
                return Err(JobError::ThreeValues(name));
            }
        }
        if self.up.len() != 3 {
            return Err(JobError::ThreeValues("--up"));
        }
        let beam = scene.beams[0];
        let v3 = |v: &Vec<f64>| DVec3::new(v[0], v[1], v[2]);
        let sweep = scene
            .beams
            .iter()
            .map(|b| (b.position - beam.position).length())
            .fold(0.0_f64, f64::max);
        let look_at = self
            .look_at
            .as_ref()
            .map_or(beam.position + 100.0 * beam.direction, v3);
        let position = self
            .camera
            .as_ref()
            .map_or(beam.position - (2.5 * sweep).max(50.0) * beam.direction, v3);
        let camera = PinholeCamera {
            position,
            look_at,
            up: v3(&self.up),
            fov_deg: self.fov,
        };
        // Toward the light: against the first beam.
        let t = -beam.direction;
        let light = (
            t.z.clamp(-1.0, 1.0).acos().to_degrees(),
            t.y.atan2(t.x).to_degrees(),
        );
        let settings = RenderSettings {
            view_theta_deg: 0.0,
            view_phi_deg: 0.0,
            ..self.settings(light, OBJECT_BACKGROUND)
        };
        let file = &scene.scene_file.file;
        settings
            .validate()
            .and_then(|()| camera.validate())
            .map_err(|error| JobError::InScene {
                file: file.clone(),
                error,
            })?;
        if scene
            .object
            .solids
            .iter()
            .any(|s| s.body.contains(camera.position))
        {
            return Err(JobError::CameraInside {
                file: file.clone(),
                position: camera.position,
            });
        }
        Ok((camera, settings))
    }
}

/// A finished render: the EXR file, the PNG preview and what the preview
/// applied, with the line `roks render` prints about them.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// The EXR file's bytes (linear radiance).
    pub exr: Vec<u8>,
    /// The PNG preview's bytes.
    pub png: Vec<u8>,
    /// The tone curve, in words (`log, --decades 3.000`, `linear`, `filmic`).
    pub curve: String,
    /// The exposure applied (stops).
    pub exposure_ev: f64,
    /// The mean radiance of the image's first channel, in the disc's units.
    pub mean: f64,
}

impl Rendered {
    /// The files of `img`, its preview tone-mapped by `tone`.
    ///
    /// # Errors
    /// An image without its pixels, bad tone settings, or an encoder's failure.
    pub fn of(img: &Image, tone: &ToneSettings) -> anyhow::Result<Self> {
        let exr = super::write_exr(img).map_err(|e| anyhow::anyhow!("{e}"))?;
        let (png, applied) =
            super::write_png_preview(img, tone).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mean = img.rgb.iter().map(|p| f64::from(p[0])).sum::<f64>() / img.rgb.len() as f64;
        let curve = match tone.tonemap {
            Tonemap::Log => format!("log, --decades {:.3}", applied.decades),
            Tonemap::Linear => "linear".into(),
            Tonemap::Filmic => "filmic".into(),
        };
        Ok(Self {
            exr,
            png,
            curve,
            exposure_ev: applied.exposure_ev,
            mean,
        })
    }
}

/// Refuse a render of the object scene `file` whose camera paths met
/// `unmodelled` walls without a model.
///
/// # Errors
/// [`JobError::Unmodelled`].
pub fn check_unmodelled(file: &str, unmodelled: u64) -> Result<(), JobError> {
    if unmodelled > 0 {
        return Err(JobError::Unmodelled {
            file: file.to_owned(),
            count: unmodelled,
        });
    }
    Ok(())
}
