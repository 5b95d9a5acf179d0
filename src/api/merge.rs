//! Merging result folders: the shard folders of one `roks brdf --shard
//! I/N` or `roks trace --shard I/N` run into the files of the folder of the
//! whole run (what `roks merge` writes).
//!
//! Each shard folder holds a `tallies.json` (the shard file of its level,
//! [`crate::shard::file`]); [`ShardKind::of`] tells the levels apart by the
//! first folder's `format`. [`merge_brdf`] and [`merge_trace`] read every
//! shard, check it alone and against the others, and sum the shards'
//! complete tree nodes in block order into each leaf's fixed tree: the
//! merged sums are the single run's bit for bit, for any split and any
//! order of the folders, so the merged folder's tables, pictures and
//! `tallies.json` are byte for byte those of the single run, and its
//! `summary.json` differs only in the times (the sums of the shards', in
//! seconds).
//!
//! Nothing here writes to disk or prints: the caller writes the files
//! ([`BrdfMerge::files`], [`TraceMerge::files`]) and adds exports.
//!
//! ```
//! use std::path::PathBuf;
//! use roks::api::merge::{ShardKind, merge_brdf};
//!
//! // Two shards of one `roks brdf` run (test data of the repository).
//! let dirs: Vec<PathBuf> = ["s0", "s1"]
//!     .iter()
//!     .map(|s| PathBuf::from("tests/bad_inputs/data/tables-shards").join(s))
//!     .collect();
//! assert_eq!(ShardKind::of(&dirs[0]), ShardKind::Brdf);
//! let merged = merge_brdf(&dirs)?;
//! assert_eq!(merged.shards, 2);
//! // The whole run: no block of photons.
//! assert!(merged.folder.description.run.shard.is_none());
//! let files = merged.files(Vec::new())?;
//! assert!(files.iter().any(|(name, _)| name == "brdf.csv"));
//! assert!(files.iter().any(|(name, _)| name == "tallies.json"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::{Path, PathBuf};

use crate::export::exporter::BrdfFormat;
use crate::outdir::file::ResultFile;
use crate::output::brdf_folder::BrdfFolder;
use crate::output::object_tallies::{self, Object};
use crate::output::tallies::{self, Micro};
use crate::plot::folder::PlotError;
use crate::scene::SceneError;
use crate::scene::micro::{MicroScene, Overrides};
use crate::scene::source::SceneSource;
use crate::shard::file::{self as shard_file, Level, ShardFile, TALLIES_FILE};

/// The level of a shard folder, by its `tallies.json`'s `format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardKind {
    /// A `roks brdf` shard (and any folder that is not a `roks trace`
    /// shard: its errors are the micro reader's).
    Brdf,
    /// A `roks trace` shard.
    Trace,
}

impl ShardKind {
    /// The kind of the shard folder `dir`.
    #[must_use]
    pub fn of(dir: &Path) -> Self {
        if object_tallies::is_trace_shard(dir) {
            Self::Trace
        } else {
            Self::Brdf
        }
    }
}

/// Why shard folders cannot be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// Bad input: a shard's `tallies.json`, shards of different runs, gaps
    /// or overlaps, or a merged run above the memory limit. One line
    /// naming the file and the key.
    #[error(transparent)]
    Input(#[from] SceneError),
    /// A picture of the merged folder that cannot be made.
    #[error(transparent)]
    Picture(#[from] PlotError),
}

/// Read and check every shard folder of `dirs` (in the order given).
fn read_all<L: Level>(dirs: &[PathBuf]) -> Result<Vec<ShardFile<L>>, SceneError> {
    dirs.iter()
        .map(|d| shard_file::read_shard::<L>(d))
        .collect()
}

/// The merged shards of one `roks brdf` run.
#[derive(Debug, Clone)]
pub struct BrdfMerge {
    /// The whole run's folder: its sums and its `tallies.json` (the trees'
    /// roots).
    pub folder: BrdfFolder,
    /// How many shards were merged.
    pub shards: usize,
    /// The first shard's `surface.png`, if it has one: the surface's
    /// picture comes from the micro geometry, not the sums, and every
    /// shard of one run drew the same one (their descriptions, with the
    /// scene's content and the statistics grid, are equal).
    pub surface_png: Option<Vec<u8>>,
}

impl BrdfMerge {
    /// The merged folder's files: those of [`BrdfFolder::files`] with
    /// `extra` (e.g. exports), the pictures, and `surface.png`.
    ///
    /// # Errors
    /// A picture that cannot be drawn.
    pub fn files(
        &self,
        extra: Vec<(String, Vec<u8>)>,
    ) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
        let mut files = self.folder.files(extra);
        crate::plot::folder::add_pictures(&mut files)?;
        if let Some(png) = &self.surface_png {
            files.push((ResultFile::SurfacePicture.name().into(), png.clone()));
        }
        Ok(files)
    }

    /// The comment the exports of the merged table carry (as those of the
    /// single run, [`crate::api::export_comment`]).
    #[must_use]
    pub fn export_comment(&self) -> String {
        let d = &self.folder.description;
        crate::api::export_comment(&d.name, d.run.photons)
    }

    /// The micro scene whose surfaces (every realisation) give the NDF an
    /// rgl export of the merged shards writes: that of the scene file the
    /// shards name (the embedded default for
    /// [`crate::scene::source::DEFAULT_SCENE`]), when `formats` hold rgl
    /// and the file loads; `None` otherwise.
    #[must_use]
    pub fn rgl_scene(&self, formats: &[BrdfFormat]) -> Option<MicroScene> {
        if !formats.contains(&BrdfFormat::Rgl) {
            return None;
        }
        let source = SceneSource::from_recorded(&self.folder.description.scene);
        crate::api::load_micro(source.path(), &Overrides::default()).ok()
    }
}

/// Merge the shard folders `dirs` (any order) of one `roks brdf` run
/// ([`tallies::merge_shards`]) and check that the merged tallies and
/// tables fit in memory.
///
/// # Errors
/// [`MergeError::Input`]: the first problem, naming the file and the key.
pub fn merge_brdf(dirs: &[PathBuf]) -> Result<BrdfMerge, MergeError> {
    let parts = read_all::<Micro>(dirs)?;
    let shards = parts.len();
    let merged = tallies::merge_shards(parts)?;
    let bytes = merged.description.run.memory_bytes();
    crate::limits::check("the merged tallies and tables", bytes).map_err(|e| SceneError {
        file: format!("{}: {TALLIES_FILE}", dirs[0].display()),
        key: "description.run.bands".into(),
        message: e.to_string(),
    })?;
    Ok(BrdfMerge {
        folder: BrdfFolder::merged(merged),
        shards,
        surface_png: std::fs::read(ResultFile::SurfacePicture.path_in(&dirs[0])).ok(),
    })
}

/// The merged shards of one `roks trace` run.
#[derive(Debug, Clone)]
pub struct TraceMerge {
    /// The whole run: its description, per beam position and wavelength
    /// the root of its tree, and the sum of the shards' times (s).
    pub merged: object_tallies::Merged,
    /// How many shards were merged.
    pub shards: usize,
}

impl TraceMerge {
    /// The merged folder's files ([`object_tallies::TraceDescription::folder`],
    /// the same code as the single run's).
    ///
    /// # Errors
    /// A picture that cannot be drawn.
    pub fn files(&self) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
        let m = &self.merged;
        let mut files = m.description.folder(&m.results, m.seconds, None);
        crate::plot::folder::add_pictures(&mut files)?;
        Ok(files)
    }
}

/// Merge the shard folders `dirs` (any order) of one `roks trace` run
/// ([`object_tallies::merge_shards`]).
///
/// # Errors
/// [`MergeError::Input`]: the first problem, naming the file and the key.
pub fn merge_trace(dirs: &[PathBuf]) -> Result<TraceMerge, MergeError> {
    let parts = read_all::<Object>(dirs)?;
    let shards = parts.len();
    Ok(TraceMerge {
        merged: object_tallies::merge_shards(parts)?,
        shards,
    })
}
