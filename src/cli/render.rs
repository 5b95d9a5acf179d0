//! `roks render`: a radiance map (EXR and a PNG preview) of a micro scene
//! seen by an orthographic camera over one period, or of an object scene
//! seen by a pinhole camera, lit by a small bright disc (and, for an object
//! scene, a dim uniform background by default, so that its walls show).

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::api::render::{RenderFiles, render};
use crate::api::values::{integer, number, positive};
use crate::render::job::{RenderOptions, Rendered, check_cost};
use crate::render::{ToneSettings, Tonemap};

/// The options of `roks render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Micro or object scene file (TOML; an object scene has [[cells]]);
    /// omitted: the embedded default micro scene.
    pub scene: Option<PathBuf>,
    /// Output EXR file.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace an existing OUT or its PNG preview even when it is not an EXR (a PNG) that roks
    /// wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
    /// Micro scenes: view direction THETA,PHI in degrees (toward the camera).
    #[arg(long, value_name = "THETA,PHI", value_delimiter = ',', default_value = "0,0", value_parser = number, action = clap::ArgAction::Set)]
    pub view: Vec<f64>,
    /// Direction THETA,PHI toward the light disc's centre, in degrees, polar
    /// angle from +z [default: a micro scene's first incidence; an object
    /// scene's: against its first beam].
    #[arg(long, value_name = "THETA,PHI", value_delimiter = ',', allow_hyphen_values = true, value_parser = number, action = clap::ArgAction::Set)]
    pub light: Option<Vec<f64>>,
    /// Angular radius of the light disc (degrees).
    #[arg(long, value_name = "DEG", default_value_t = 5.0, value_parser = number)]
    pub disc: f64,
    /// Radiance of a uniform background outside the disc, in the disc's units
    /// (a small value shows walls the disc leaves dark) [default: 0 for a
    /// micro scene, 1e-3 for an object scene].
    #[arg(long, value_name = "B", value_parser = number)]
    pub background: Option<f64>,
    /// Image size W,H in pixels.
    #[arg(long, value_name = "W,H", value_delimiter = ',', default_value = "512,512", value_parser = positive::<usize>, action = clap::ArgAction::Set)]
    pub size: Vec<usize>,
    /// Samples per pixel.
    #[arg(long, default_value_t = 16, value_parser = positive::<u32>)]
    pub spp: u32,
    /// Seed.
    #[arg(long, default_value_t = 1, value_parser = integer::<u64>)]
    pub seed: u64,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = positive::<usize>)]
    pub threads: Option<usize>,
    /// Object scenes: pinhole camera position X,Y,Z [default: on the first
    /// beam's axis, 2.5 beam-sweep lengths before its start, at least 50 units].
    #[arg(long, value_name = "X,Y,Z", value_delimiter = ',', allow_hyphen_values = true, value_parser = number, action = clap::ArgAction::Set)]
    pub camera: Option<Vec<f64>>,
    /// Object scenes: point the camera looks at X,Y,Z [default: the first
    /// beam's start point moved 100 units along the beam].
    #[arg(long, value_name = "X,Y,Z", value_delimiter = ',', allow_hyphen_values = true, value_parser = number, action = clap::ArgAction::Set)]
    pub look_at: Option<Vec<f64>>,
    /// Object scenes: up direction X,Y,Z of the image.
    #[arg(long, value_name = "X,Y,Z", value_delimiter = ',', allow_hyphen_values = true, default_value = "0,1,0", value_parser = number, action = clap::ArgAction::Set)]
    pub up: Vec<f64>,
    /// Object scenes: vertical field of view (degrees).
    #[arg(long, value_name = "DEG", default_value_t = 40.0, value_parser = number)]
    pub fov: f64,
    /// Object scenes: do not sample the disc's light at table and Lambertian
    /// walls (next-event estimation); the disc is then only met by chance.
    /// Same expectation, far more noise.
    #[arg(long)]
    pub no_light_sampling: bool,
    /// Tone curve of the PNG preview (the EXR stays linear radiance): log
    /// (--decades from white to black), linear, or filmic (ACES fit).
    #[arg(long, value_enum, default_value_t = Tonemap::Log)]
    pub tonemap: Tonemap,
    /// Exposure of the PNG preview in stops: radiance times 2^EV before the
    /// tone curve (1 is white) [default: automatic, the 99.9th percentile of
    /// the non-zero pixels' luminance is white].
    #[arg(long, value_name = "EV", allow_hyphen_values = true, value_parser = number)]
    pub exposure: Option<f64>,
    /// Render even when the estimated cost exceeds MAX_PATHS (1e10 camera
    /// paths: width x height x spp) or --spp exceeds MAX_SPP (2^24 =
    /// 16777216 samples per pixel), which are otherwise refused up front.
    #[arg(long)]
    pub force_long_render: bool,
    /// Log curve: decades of radiance from white to black [default:
    /// automatic, log10 of the 99.9th over the 1st percentile of the
    /// non-zero pixels' luminance, within 1..8].
    #[arg(long, value_name = "D", value_parser = number)]
    pub decades: Option<f64>,
}

impl RenderArgs {
    /// The preview's tone settings, checked.
    fn tone(&self) -> Result<ToneSettings, Failure> {
        let t = ToneSettings {
            tonemap: self.tonemap,
            exposure_ev: self.exposure,
            decades: self.decades,
        };
        t.validate().map_err(crate::api::Error::from)?;
        Ok(t)
    }

    /// The options of the render itself.
    fn options(&self) -> RenderOptions {
        RenderOptions {
            view: self.view.clone(),
            light: self.light.clone(),
            disc: self.disc,
            background: self.background,
            size: self.size.clone(),
            spp: self.spp,
            seed: self.seed,
            camera: self.camera.clone(),
            look_at: self.look_at.clone(),
            up: self.up.clone(),
            fov: self.fov,
            light_sampling: !self.no_light_sampling,
        }
    }
}

/// Run `roks render`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: RenderArgs) -> Result<(), Failure> {
    let o = a.options();
    o.check_pairs().map_err(crate::api::Error::from)?;
    let (w, h) = (a.size[0] as u64, a.size[1] as u64);
    let what = format!("a {w} x {h} image (radiance, EXR and PNG)");
    crate::api::check_memory("--size", &what, crate::render::image_memory_bytes(w, h))?;
    // Whether a file there may be replaced: after the files the scene
    // reads are known (`RenderFiles::check_kept`).
    let files = RenderFiles::new(&a.out, a.scene.as_slice())?;
    let threads = a.threads.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    check_cost(w, h, a.spp, threads, a.force_long_render).map_err(crate::api::Error::from)?;
    let tone = a.tone()?;
    let (img, lost) = render(a.scene.as_deref(), &o, a.threads, &files, a.force)?;
    if lost > 0 {
        eprintln!(
            "roks: render: {lost} of {} camera paths lost (bounce cap, numerical guard, absorbing edge or micro descent); they add 0",
            o.paths()
        );
    }
    let r = Rendered::of(&img, &tone)?;
    files.write(&r)?;
    eprintln!(
        "wrote {} and {} (mean radiance {:.4e} of the disc's; preview: {}, --exposure {:.3})",
        files.exr.display(),
        files.png.display(),
        r.mean,
        r.curve,
        r.exposure_ev
    );
    Ok(())
}
