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
use crate::render::{PinholeCamera, RenderSettings, ToneSettings, Tonemap};
use crate::scene::SceneKind;
use crate::scene::object::ObjectScene;

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
        t.validate().map_err(|e| Failure::Input(e.to_string()))?;
        Ok(t)
    }
}

/// The background of an object render when `--background` is not given:
/// 1e-3 of the disc's radiance, so that walls the disc leaves dark still
/// show their shape (walls of a few percent reflectance are then a few
/// 1e-5, inside the log preview's automatic range).
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

/// The cost of a `w` x `h` render at `spp` samples per pixel on `threads`
/// cores: its camera paths and an estimate of its seconds; refused above
/// [`MAX_PATHS`], or above [`MAX_SPP`] samples per pixel, unless `force`.
///
/// # Errors
/// Bad input naming `--spp` and `--size`, the paths and the time.
pub fn check_cost(w: u64, h: u64, spp: u32, threads: usize, force: bool) -> Result<u64, Failure> {
    let paths = w.saturating_mul(h).saturating_mul(u64::from(spp));
    if paths > MAX_PATHS && !force {
        let hours = paths as f64 / (PATHS_PER_CORE_SECOND * threads.max(1) as f64) / 3600.0;
        return Err(Failure::Input(format!(
            "--spp: {w} x {h} pixels x {spp} samples = {paths:.3e} camera paths, above the bound of {MAX_PATHS:.0e} (about {hours:.1} h on {threads} cores at {PATHS_PER_CORE_SECOND:.0e} paths/s per core); lower --spp or --size, or give --force-long-render"
        )));
    }
    if spp > MAX_SPP && !force {
        // A pixel's samples are traced one after another on one core.
        let minutes = f64::from(spp) / PATHS_PER_CORE_SECOND / 60.0;
        return Err(Failure::Input(format!(
            "--spp: {spp} samples per pixel, above the bound of {MAX_SPP} (2^24): a pixel's samples are traced one after another on one core (about {minutes:.0} min per pixel at {PATHS_PER_CORE_SECOND:.0e} paths/s); lower --spp, or give --force-long-render"
        )));
    }
    Ok(paths)
}

/// Run `roks render`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: RenderArgs) -> Result<(), Failure> {
    for (name, n) in [
        ("--view", a.view.len()),
        ("--size", a.size.len()),
        ("--light", a.light.as_ref().map_or(2, Vec::len)),
    ] {
        if n != 2 {
            return Err(Failure::Input(format!(
                "{name}: give two comma-separated values"
            )));
        }
    }
    let (w, h) = (a.size[0] as u64, a.size[1] as u64);
    check_memory(
        "--size",
        &format!("a {w} x {h} image (radiance, EXR and PNG)"),
        crate::render::image_memory_bytes(w, h),
    )?;
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
    check_cost(w, h, a.spp, threads, a.force_long_render)?;
    let tone = a.tone()?;
    // A file that cannot be read is left to the micro loader's message.
    if let Some(path) = a
        .scene
        .as_deref()
        .filter(|p| matches!(crate::scene::kind(p), Ok(SceneKind::Object)))
    {
        return object(&a, path, &tone);
    }
    let scene = load_scene(a.scene.as_deref())?;
    check_kept(&a.out, &scene.reads, a.force)?;
    let (light_theta, light_phi) = match &a.light {
        Some(l) => (l[0], l[1]),
        None => (scene.light.theta_deg[0], scene.light.phi_deg[0]),
    };
    let settings = RenderSettings {
        width: a.size[0],
        height: a.size[1],
        spp: a.spp,
        view_theta_deg: a.view[0],
        view_phi_deg: a.view[1],
        light_theta_deg: light_theta,
        light_phi_deg: light_phi,
        light_radius_deg: a.disc,
        light_radiance: 1.0,
        background_radiance: a.background.unwrap_or(0.0),
        seed: a.seed,
        light_sampling: !a.no_light_sampling,
    };
    settings
        .validate()
        .map_err(|e| Failure::Input(e.to_string()))?;
    set_threads(a.threads)?;
    let (img, losses) =
        crate::render::render_at(&scene.surface, &scene.run.wavelengths_um, &settings);
    let paths = (settings.width * settings.height) as u64 * u64::from(settings.spp);
    write_images(&a.out, &img, &tone, losses.lost, paths)
}

/// `roks render` of an object scene: a pinhole camera view.
fn object(a: &RenderArgs, path: &Path, tone: &ToneSettings) -> Result<(), Failure> {
    let scene = ObjectScene::load(path)?;
    check_kept(&a.out, &scene.reads, a.force)?;
    for (name, v) in [("--camera", &a.camera), ("--look-at", &a.look_at)] {
        if v.as_ref().is_some_and(|v| v.len() != 3) {
            return Err(Failure::Input(format!(
                "{name}: give three comma-separated values"
            )));
        }
    }
    if a.up.len() != 3 {
        return Err(Failure::Input(
            "--up: give three comma-separated values".into(),
        ));
    }
    let beam = scene.beams[0];
    let v3 = |v: &Vec<f64>| glam::DVec3::new(v[0], v[1], v[2]);
    let sweep = scene
        .beams
        .iter()
        .map(|b| (b.position - beam.position).length())
        .fold(0.0_f64, f64::max);
    let look_at = a
        .look_at
        .as_ref()
        .map_or(beam.position + 100.0 * beam.direction, v3);
    let position = a
        .camera
        .as_ref()
        .map_or(beam.position - (2.5 * sweep).max(50.0) * beam.direction, v3);
    let camera = PinholeCamera {
        position,
        look_at,
        up: v3(&a.up),
        fov_deg: a.fov,
    };
    let (light_theta, light_phi) = match &a.light {
        Some(l) => (l[0], l[1]),
        None => {
            // Toward the light: against the first beam.
            let t = -beam.direction;
            (
                t.z.clamp(-1.0, 1.0).acos().to_degrees(),
                t.y.atan2(t.x).to_degrees(),
            )
        }
    };
    let settings = RenderSettings {
        width: a.size[0],
        height: a.size[1],
        spp: a.spp,
        light_theta_deg: light_theta,
        light_phi_deg: light_phi,
        light_radius_deg: a.disc,
        light_radiance: 1.0,
        background_radiance: a.background.unwrap_or(OBJECT_BACKGROUND),
        seed: a.seed,
        light_sampling: !a.no_light_sampling,
        ..RenderSettings::default()
    };
    settings
        .validate()
        .and_then(|()| camera.validate())
        .map_err(|e| Failure::Input(format!("{}: {e}", scene.scene_file.file)))?;
    if scene
        .object
        .solids
        .iter()
        .any(|s| s.body.contains(camera.position))
    {
        return Err(Failure::Input(format!(
            "{}: --camera: the camera position {} lies inside a solid cell",
            scene.scene_file.file, camera.position
        )));
    }
    set_threads(a.threads)?;
    let (img, losses) = crate::render::render_object(&scene, &camera, &settings);
    if losses.unmodelled > 0 {
        return Err(Failure::Input(format!(
            "{}: walls: {} camera paths hit a surface without a model in [walls]",
            scene.scene_file.file, losses.unmodelled
        )));
    }
    let paths = (settings.width * settings.height) as u64 * u64::from(settings.spp);
    write_images(&a.out, &img, tone, losses.lost, paths)
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
/// and report the mean, the exposure used and the `lost` camera paths (caps, guards, edge walls, micro descents). Each
/// file is replaced atomically, the EXR first: a reader sees each old or
/// new, and for an instant (or after a kill between the two) a new EXR
/// beside the old PNG.
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
    use crate::render::{write_exr, write_png_preview};
    let exr = write_exr(img).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (png, applied) = write_png_preview(img, tone).map_err(|e| anyhow::anyhow!("{e}"))?;
    let png_path = out.with_extension("png");
    // Both or neither, for an interrupt.
    let commit = crate::interrupt::commit();
    for (path, bytes) in [(out, &exr), (png_path.as_path(), &png)] {
        write_file(path, bytes)?;
    }
    drop(commit);
    let mean = img.rgb.iter().map(|p| f64::from(p[0])).sum::<f64>() / img.rgb.len() as f64;
    let curve = match tone.tonemap {
        Tonemap::Log => format!("log, --decades {:.3}", applied.decades),
        Tonemap::Linear => "linear".into(),
        Tonemap::Filmic => "filmic".into(),
    };
    eprintln!(
        "wrote {} and {} (mean radiance {mean:.4e} of the disc's; preview: {curve}, --exposure {:.3})",
        out.display(),
        png_path.display(),
        applied.exposure_ev
    );
    Ok(())
}
