//! A render of a micro or an object scene (`roks render`): the checks of
//! its two files (the EXR and its PNG preview beside it), the render
//! itself, and the files written.

use std::path::{Path, PathBuf};

use super::Error;
use crate::outdir::check::{Written, check_kept, check_out_file_as, shown};
use crate::outdir::kind::FileKind;
use crate::render::Image;
use crate::render::job::{RenderOptions, Rendered, check_unmodelled};
use crate::scene::SceneKind;
use crate::scene::object::ObjectScene;

/// The two files of a render: `exr` (linear radiance) and `png` (the
/// preview, `exr` with the extension `.png`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RenderFiles {
    /// The EXR file (`--out`).
    pub exr: PathBuf,
    /// The PNG preview beside it.
    pub png: PathBuf,
}

impl RenderFiles {
    /// The files of `--out` `out`, checked as outputs of a render of the
    /// scene file `inputs` (none: the default scene) before the scene is
    /// read ([`check_out_file_as`]; whether an existing file may be
    /// replaced is checked by [`Self::check_kept`]).
    ///
    /// # Errors
    /// [`Error::Input`] naming `--out`: a path that cannot be written as a
    /// file, the name of the PNG preview itself, or a file roks may not
    /// replace.
    pub fn new(out: &Path, inputs: &[PathBuf]) -> Result<Self, Error> {
        check_out_file_as("--out", out, inputs, FileKind::Exr, true)?;
        let png = out.with_extension("png");
        if png == out {
            return Err(Error::Input(format!(
                "--out: {}: is the name of the PNG preview; give the EXR file (OUT.exr, beside which OUT.png is written)",
                out.display()
            )));
        }
        check_out_file_as("--out", &png, inputs, FileKind::Png, true)?;
        Ok(Self {
            exr: out.to_owned(),
            png,
        })
    }

    /// Refuse either file when it would replace one of `reads`, the files
    /// the scene reads (a height map, a 16-bit PNG map, an n, k table);
    /// then refuse an existing one that is not an EXR (a PNG) roks wrote,
    /// unless `force` ([`crate::outdir::check_replace`]).
    ///
    /// # Errors
    /// [`Error::Input`] naming `--out` and the file.
    pub fn check_kept(&self, reads: &[PathBuf], force: bool) -> Result<(), Error> {
        let written = [Written::File(&self.exr), Written::File(&self.png)];
        check_kept("--out", &written, reads)?;
        for (path, kind) in [(&self.exr, FileKind::Exr), (&self.png, FileKind::Png)] {
            crate::outdir::check_replace(path, kind, force)
                .map_err(|e| Error::Input(format!("--out: {}: {e}", shown(path))))?;
        }
        Ok(())
    }

    /// Write `r`: each file replaced atomically, the EXR first, both or
    /// neither for an interrupt: a reader sees each old or new, and for an
    /// instant (or after a kill between the two) a new EXR beside the old
    /// PNG.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn write(&self, r: &Rendered) -> Result<(), Error> {
        let commit = crate::interrupt::commit();
        for (path, bytes) in [(&self.exr, &r.exr), (&self.png, &r.png)] {
            crate::outdir::write::write_file(path, bytes)?;
        }
        drop(commit);
        Ok(())
    }
}

/// Render the scene file `path` (an object scene when it has `[[cells]]`;
/// `None`, or a file that is not: a micro scene, the embedded default for
/// `None`) with `o` on `threads` worker threads ([`super::set_threads`]),
/// after `files` are checked against the files the scene reads
/// ([`RenderFiles::check_kept`]). Returns the image and the camera paths
/// lost (caps, guards, edge walls, micro descents).
///
/// # Errors
/// Bad input (the scene, the options against it, unmodelled walls met,
/// the files), or [`Error::Io`].
pub fn render(
    path: Option<&Path>,
    o: &RenderOptions,
    threads: Option<usize>,
    files: &RenderFiles,
    force: bool,
) -> Result<(Image, u64), Error> {
    // A file that cannot be read is left to the micro loader's message.
    match path {
        Some(path) if matches!(crate::scene::kind(path), Ok(SceneKind::Object)) => {
            let scene = ObjectScene::load(path)?;
            files.check_kept(&scene.reads, force)?;
            let (camera, settings) = o.object(&scene)?;
            super::set_threads(threads)?;
            let (img, losses) = crate::render::render_object(&scene, &camera, &settings);
            check_unmodelled(&scene.scene_file.file, losses.unmodelled)?;
            Ok((img, losses.lost))
        }
        path => {
            let scene = super::load_micro(path, &super::Overrides::default())?;
            files.check_kept(&scene.reads, force)?;
            let settings = o.micro(&scene)?;
            super::set_threads(threads)?;
            let wavelengths = &scene.run.wavelengths_um;
            let (img, losses) = crate::render::render_at(&scene.surface, wavelengths, &settings);
            Ok((img, losses.lost))
        }
    }
}
