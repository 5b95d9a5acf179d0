//! `roks plot`: redraw every picture of a result folder from its files
//! (micro, object, spectral, polarised, merged or shard folders), and the
//! picture of a micro surface that `roks brdf` and `roks stats --png` draw.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use crate::micro::surface_stats::{HeightMap, SurfaceStats, surface_stats};
use crate::outdir::file::ResultFile;
use crate::output::summary::{BrdfSummary, Surface};
use crate::scene::micro::MicroScene;
use crate::scene::source::SceneSource;

/// The options of `roks plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A result folder of `roks brdf`, `merge` or `trace`.
    pub dir: PathBuf,
    /// Nothing on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// Replace a picture even when the file of its name in DIR is not a
    /// PNG that roks wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
}

/// Run `roks plot`: the pictures made from the folder's files
/// ([`crate::plot::folder`]) written into it, each atomically (a temporary
/// file, then a rename); `surface.png` too when the folder's scene file
/// (`summary.json`'s `scene`) still gives the surface of the run (the same
/// statistics).
///
/// # Errors
/// Bad input: not a result folder, or a file of it that cannot be read
/// (one line naming it); a failed write.
pub fn execute(a: PlotArgs) -> Result<(), Failure> {
    let dir = &a.dir;
    if !ResultFile::Summary.path_in(dir).is_file() {
        return Err(Failure::Input(format!(
            "{}: not a roks result folder (no {})",
            dir.display(),
            ResultFile::Summary
        )));
    }
    let mut pictures =
        crate::plot::folder::pictures_in(dir).map_err(|e| Failure::Input(e.to_string()))?;
    let surface = surface_of(dir);
    match &surface {
        Ok(Some(png)) => pictures.push((ResultFile::SurfacePicture.name().to_owned(), png.clone())),
        Ok(None) => {}
        Err(why) if !a.quiet => {
            eprintln!("roks: {} not redrawn: {why}", ResultFile::SurfacePicture)
        }
        Err(_) => {}
    }
    // Every picture checked before any is written.
    for (name, _) in &pictures {
        let path = dir.join(name);
        crate::outdir::check_replace(&path, crate::outdir::kind::FileKind::Png, a.force)
            .map_err(|e| Failure::Input(format!("{}: {e}", super::common::shown(&path))))?;
    }
    // All or none, for an interrupt.
    let _commit = crate::interrupt::commit();
    for (name, png) in &pictures {
        super::common::write_file(&dir.join(name), png)?;
    }
    if !a.quiet {
        let names: Vec<&str> = pictures.iter().map(|p| p.0.as_str()).collect();
        eprintln!(
            "redrew {} pictures in {}: {}",
            names.len(),
            dir.display(),
            names.join(", ")
        );
    }
    Ok(())
}

/// Why `surface.png` is not redrawn ([`surface_of`]).
#[derive(Debug, thiserror::Error)]
enum NoSurface {
    /// `summary.json` cannot be read.
    #[error("{0}")]
    Summary(std::io::Error),
    /// The scene cannot be loaded.
    #[error("{0}")]
    Scene(crate::scene::SceneError),
    /// The scene's surface is not the run's.
    #[error("the surface of {0} differs from the run's (the scene was edited since)")]
    Edited(String),
    /// The picture cannot be drawn.
    #[error("{0}")]
    Draw(Failure),
}

/// `surface.png` of a micro folder from its scene file: `None` for an
/// object folder; an error (why not) when the scene cannot be loaded or
/// its surface's statistics differ from the run's.
fn surface_of(dir: &Path) -> Result<Option<Vec<u8>>, NoSurface> {
    let text =
        std::fs::read_to_string(ResultFile::Summary.path_in(dir)).map_err(NoSurface::Summary)?;
    let Ok(s) = serde_json::from_str::<BrdfSummary>(&text) else {
        return Ok(None);
    };
    let scene = match SceneSource::from_recorded(&s.scene).path() {
        None => MicroScene::default_scene(),
        Some(p) => MicroScene::load(p).map_err(NoSurface::Scene)?,
    };
    let r = s.surface.height_map_resolution;
    let (rx, ry) = scene.surface.heightfield().map_or((r, r), |f| (f.nx, f.ny));
    let map = scene.surface.height_map(rx, ry);
    let stats = surface_stats(&map);
    let now = Surface::new(&stats, rx);
    // The same to 1e-9 (summary.json's numbers read back may be an ulp off).
    let close = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300),
        (a, b) => a.is_none() && b.is_none(),
    };
    let (a, b) = (&now, &s.surface);
    let same = a.height_map_resolution == b.height_map_resolution
        && close(a.sigma, b.sigma)
        && close(a.tau, b.tau)
        && close(a.rms_slope, b.rms_slope)
        && close(a.mean_height, b.mean_height)
        && close(a.min_height, b.min_height)
        && close(a.max_height, b.max_height);
    if !same {
        return Err(NoSurface::Edited(s.scene));
    }
    surface_png(&scene, &map, &stats)
        .map(Some)
        .map_err(NoSurface::Draw)
}

/// `surface.png` ([`crate::plot::surface_png`]), as a command's failure.
///
/// # Errors
/// If the picture cannot be drawn.
pub fn surface_png(
    scene: &MicroScene,
    map: &HeightMap,
    stats: &SurfaceStats,
) -> Result<Vec<u8>, Failure> {
    crate::plot::surface_png(scene, map, stats).map_err(Failure::Other)
}
