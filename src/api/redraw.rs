//! The pictures of a result folder redrawn from its files (`roks plot`):
//! those its tables give ([`crate::plot::folder`]) and, for a micro folder,
//! `surface.png` when the scene file it names still gives the run's
//! surface.

use std::path::Path;

use super::Error;
use crate::micro::surface_stats::surface_stats;
use crate::outdir::check::shown;
use crate::outdir::file::ResultFile;
use crate::outdir::kind::FileKind;
use crate::output::summary::{BrdfSummary, Surface};
use crate::scene::micro::MicroScene;
use crate::scene::source::SceneSource;

/// Why `surface.png` is not redrawn ([`Redrawn::surface`]).
#[derive(Debug, thiserror::Error)]
pub enum NoSurface {
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
    #[error("{0:#}")]
    Draw(anyhow::Error),
}

/// The pictures of a result folder, by file name, not yet written.
#[derive(Debug)]
pub struct Redrawn {
    /// Every picture, `surface.png` last when it is redrawn.
    pub pictures: Vec<(String, Vec<u8>)>,
    /// Why `surface.png` is not among them (`Ok`: it is, or the folder is
    /// an object folder).
    pub surface: Result<(), NoSurface>,
}

/// Redraw the pictures of the result folder `dir`.
///
/// # Errors
/// [`Error::Input`]: not a result folder, or a file of it that cannot be
/// read (one line naming it).
pub fn redraw(dir: &Path) -> Result<Redrawn, Error> {
    if !ResultFile::Summary.path_in(dir).is_file() {
        return Err(Error::Input(format!(
            "{}: not a roks result folder (no {})",
            dir.display(),
            ResultFile::Summary
        )));
    }
    let mut pictures =
        crate::plot::folder::pictures_in(dir).map_err(|e| Error::Input(e.to_string()))?;
    let surface = match surface_of(dir) {
        Ok(Some(png)) => {
            pictures.push((ResultFile::SurfacePicture.name().to_owned(), png));
            Ok(())
        }
        Ok(None) => Ok(()),
        Err(why) => Err(why),
    };
    Ok(Redrawn { pictures, surface })
}

impl Redrawn {
    /// Refuse to replace, in `dir`, a file of a picture's name that is not
    /// a PNG roks wrote, unless `force` ([`crate::outdir::check_replace`]).
    ///
    /// # Errors
    /// [`Error::Input`] naming the first such file.
    pub fn check_replace(&self, dir: &Path, force: bool) -> Result<(), Error> {
        for (name, _) in &self.pictures {
            let path = dir.join(name);
            crate::outdir::check_replace(&path, FileKind::Png, force)
                .map_err(|e| Error::Input(format!("{}: {e}", shown(&path))))?;
        }
        Ok(())
    }
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
    crate::plot::surface_png(&scene, &map, &stats)
        .map(Some)
        .map_err(NoSurface::Draw)
}
