//! The result folder of `roks brdf` (a whole run or one shard of it) and of
//! `roks merge`: one path from a run to its files.
//!
//! [`BrdfFolder::traced`] is the folder of a trace ([`BrdfRun::trace`]):
//! a whole run, or block `--shard I/N` of it, whose leaves' tree nodes go
//! to its `tallies.json`. [`BrdfFolder::merged`] is the folder of merged
//! shards. Neither traces: this module only formats. [`BrdfFolder::files`]
//! writes either: `brdf.csv`, `inplane.csv`, the polarisation table,
//! extra files (pictures, exports), `tallies.json` (shards and merges)
//! and `summary.json`.

use super::summary::{BrdfSummary, Description, to_text};
use super::tallies::{Merged, TalliesFile};
use super::{brdf_csv, inplane_csv, polar_csv};
use crate::optics::brdf_table::BrdfTables;
use crate::outdir::file::ResultFile;
use crate::transport::brdf::{BrdfResult, BrdfRun};

/// A result folder's contents, before they are written.
#[derive(Debug, Clone)]
pub struct BrdfFolder {
    /// The run of this folder (for a shard: the whole run's photons, the
    /// shard's block in `run.shard`) and its scene.
    pub description: Description,
    /// This folder's sums, nested by incidence, azimuth and wavelength.
    pub results: BrdfResult,
    /// The raw sums for `tallies.json` (shards and merges).
    pub tallies: Option<TalliesFile>,
    /// Wall-clock time (s; for a merge the shards' sum).
    pub seconds: f64,
    /// The polarisation table's file name and text, made once
    /// ([`polar_table`](Self::polar_table)) for the folder and its exports.
    polar: std::sync::OnceLock<Option<(&'static str, String)>>,
}

impl BrdfFolder {
    /// The folder of `results`, traced for the run of `description` (all
    /// its photons, or its shard's block of them) in `seconds`; a shard
    /// keeps its leaves' tree nodes for its `tallies.json`.
    #[must_use]
    pub fn traced(description: Description, results: BrdfResult, seconds: f64) -> Self {
        let tallies = description
            .run
            .shard
            .is_some()
            .then(|| TalliesFile::new(&description, &results, seconds));
        Self {
            description,
            results,
            tallies,
            seconds,
            polar: std::sync::OnceLock::new(),
        }
    }

    /// The folder of merged shards: the whole run's sums, and its
    /// `tallies.json` (the tree's roots).
    #[must_use]
    pub fn merged(merged: Merged) -> Self {
        let Merged {
            description,
            results,
            seconds,
        } = merged;
        let tallies = Some(TalliesFile::new(&description, &results, seconds));
        Self {
            description,
            results,
            tallies,
            seconds,
            polar: std::sync::OnceLock::new(),
        }
    }

    /// The run of this folder.
    #[must_use]
    pub fn run(&self) -> &BrdfRun {
        &self.description.run
    }

    /// `summary.json`.
    #[must_use]
    pub fn summary(&self) -> BrdfSummary {
        BrdfSummary::new(&self.description, &self.results, self.seconds)
    }

    /// The BRDF table as `brdf.csv` holds it (one per wavelength for a
    /// spectral run), for exports (see [`brdf_csv::table`]).
    #[must_use]
    pub fn table(&self) -> BrdfTables {
        brdf_csv::table(self.run(), &self.results)
    }

    /// The polarisation table (`stokes.csv` or `mueller.csv`, see
    /// [`polar_csv::write`]): its file name and text, `None` for a run
    /// without one. Made on the first call and kept, so the folder's file
    /// and an export that reads it (`--export pbsdf`) share one text.
    #[must_use]
    pub fn polar_table(&self) -> Option<(&'static str, &str)> {
        self.polar
            .get_or_init(|| polar_csv::write(self.run(), &self.results))
            .as_ref()
            .map(|(name, text)| (*name, text.as_str()))
    }

    /// Every file of the folder, with `extra` files (images, exports)
    /// after the tables: `brdf.csv`, `inplane.csv`, the polarisation table,
    /// `extra`, `tallies.json` (if any), `summary.json`.
    #[must_use]
    pub fn files(&self, extra: Vec<(String, Vec<u8>)>) -> Vec<(String, Vec<u8>)> {
        let mut files = vec![
            (
                ResultFile::Brdf.name().to_owned(),
                brdf_csv::write(self.run(), &self.results).into_bytes(),
            ),
            (
                ResultFile::Inplane.name().to_owned(),
                inplane_csv::write(self.run(), &self.results).into_bytes(),
            ),
        ];
        if let Some((name, text)) = self.polar_table() {
            files.push((name.to_owned(), text.as_bytes().to_vec()));
        }
        if let Some(text) = super::colour_csv::write(self.run(), &self.results) {
            files.push((ResultFile::Colour.name().to_owned(), text.into_bytes()));
        }
        files.extend(extra);
        if let Some(t) = &self.tallies {
            files.push((
                ResultFile::Tallies.name().to_owned(),
                t.to_text().into_bytes(),
            ));
        }
        files.push((
            ResultFile::Summary.name().to_owned(),
            to_text(&self.summary()).into_bytes(),
        ));
        files
    }
}
