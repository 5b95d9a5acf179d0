//! `roks render`: a radiance map (EXR and a PNG preview) of a micro scene
//! seen by an orthographic camera over one period, or of an object scene
//! seen by a pinhole camera, lit by a small bright disc (and, for an object
//! scene, a dim uniform background by default, so that its walls show).

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use super::common::{
    FileKind, Written, check_memory, check_out_file, load_scene, set_threads, write_file,
};
use super::parse::{integer, number, positive};
use crate::api::{Error, ObjectScene};
use crate::render::job::{RenderOptions, Rendered, check_unmodelled};
use crate::render::{ToneSettings, Tonemap};
use crate::scene::SceneKind;

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

/// The bound on a render's cost (kept here for the tests that name it).
pub use crate::render::job::check_cost;

/// Run `roks render`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: RenderArgs) -> Result<(), Failure> {
    let o = a.options();
    o.check_pairs().map_err(Error::from)?;
    let (w, h) = (a.size[0] as u64, a.size[1] as u64);
    let what = format!("a {w} x {h} image (radiance, EXR and PNG)");
    check_memory("--size", &what, crate::render::image_memory_bytes(w, h))?;
    // Whether a file there may be replaced: after the files the scene
    // reads are known (`check_kept`).
    check_out_file(&a.out, a.scene.as_slice(), FileKind::Exr, true)?;
    let png = a.out.with_extension("png");
    if png == a.out {
        return Err(Failure::Input(format!(
            "--out: {}: is the name of the PNG preview; give the EXR file (OUT.exr, beside which OUT.png is written)",
            a.out.display()
        )));
    }
    check_out_file(&png, a.scene.as_slice(), FileKind::Png, true)?;
    let threads = a.threads.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    check_cost(w, h, a.spp, threads, a.force_long_render).map_err(Error::from)?;
    let tone = a.tone()?;
    // A file that cannot be read is left to the micro loader's message.
    let (img, lost) = match a.scene.as_deref() {
        Some(path) if matches!(crate::scene::kind(path), Ok(SceneKind::Object)) => {
            let scene = ObjectScene::load(path)?;
            check_kept(&a.out, &scene.reads, a.force)?;
            let (camera, settings) = o.object(&scene).map_err(Error::from)?;
            set_threads(a.threads)?;
            let (img, losses) = crate::render::render_object(&scene, &camera, &settings);
            let file = &scene.scene_file.file;
            check_unmodelled(file, losses.unmodelled).map_err(Error::from)?;
            (img, losses.lost)
        }
        path => {
            let scene = load_scene(path)?;
            check_kept(&a.out, &scene.reads, a.force)?;
            let settings = o.micro(&scene).map_err(Error::from)?;
            set_threads(a.threads)?;
            let wavelengths = &scene.run.wavelengths_um;
            let (img, losses) = crate::render::render_at(&scene.surface, wavelengths, &settings);
            (img, losses.lost)
        }
    };
    write_images(&a.out, &img, &tone, lost, o.paths())
}

/// Refuse an `out` (EXR) or its PNG preview beside it that would replace
/// one of `reads`, the files the scene reads (a height map, a 16-bit PNG
/// map, an n, k table); then refuse an existing OUT or OUT.png that is
/// not an EXR (a PNG) roks wrote, unless `force`
/// ([`crate::outdir::check_replace`]).
fn check_kept(out: &Path, reads: &[PathBuf], force: bool) -> Result<(), Failure> {
    let png = out.with_extension("png");
    let written = [Written::File(out), Written::File(&png)];
    super::common::check_kept("--out", &written, reads)?;
    for (path, kind) in [(out, FileKind::Exr), (png.as_path(), FileKind::Png)] {
        crate::outdir::check_replace(path, kind, force)
            .map_err(|e| Failure::Input(format!("--out: {}: {e}", super::common::shown(path))))?;
    }
    Ok(())
}

/// Write `img` as OUT (EXR) and OUT.png (preview, tone-mapped by `tone`),
/// and report the mean, the exposure used and the `lost` camera paths
/// (caps, guards, edge walls, micro descents) of `paths`. Each file is
/// replaced atomically, the EXR first: a reader sees each old or new, and
/// for an instant (or after a kill between the two) a new EXR beside the
/// old PNG.
fn write_images(
    out: &Path,
    img: &crate::render::Image,
    tone: &ToneSettings,
    lost: u64,
    paths: u64,
) -> Result<(), Failure> {
    if lost > 0 {
        eprintln!(
            "roks: render: {lost} of {paths} camera paths lost (bounce cap, numerical guard, absorbing edge or micro descent); they add 0"
        );
    }
    let r = Rendered::of(img, tone)?;
    let png_path = out.with_extension("png");
    // Both or neither, for an interrupt.
    let commit = crate::interrupt::commit();
    for (path, bytes) in [(out, &r.exr), (png_path.as_path(), &r.png)] {
        write_file(path, bytes)?;
    }
    drop(commit);
    eprintln!(
        "wrote {} and {} (mean radiance {:.4e} of the disc's; preview: {}, --exposure {:.3})",
        out.display(),
        png_path.display(),
        r.mean,
        r.curve,
        r.exposure_ev
    );
    Ok(())
}
