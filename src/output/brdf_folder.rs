//! The result folder of `roks brdf` (a whole run or one shard of it) and of
//! `roks merge`: one path from a run to its files.
//!
//! [`BrdfFolder::trace`] traces a run, whole or block `--shard I/N` of it
//! ([`BrdfRun::photon_range`]), the same way: each incidence's batches are summed over the fixed batch
//! tree ([`crate::tally::sum`]) into its complete nodes; the folder's sums
//! are those nodes added left to right (for a whole run the one node is the
//! root), and a shard keeps the nodes for its `tallies.json`.
//! [`BrdfFolder::merged`] is the folder of merged shards. [`BrdfFolder::files`]
//! writes either: `brdf.csv`, `inplane.csv`, the polarisation table,
//! extra files (pictures, exports), `tallies.json` (shards and merges)
//! and `summary.json`.

use std::time::Instant;

use super::summary::{BrdfSummary, Description, to_text};
use super::tallies::{Merged, TALLIES_FILE, TalliesFile};
use super::{brdf_csv, inplane_csv, polar_csv};
use crate::micro::MicroSurface;
use crate::optics::brdf_table::BrdfTables;
use crate::transport::brdf::{BrdfRun, IncidenceResult};

/// A result folder's contents, before they are written.
#[derive(Debug, Clone)]
pub struct BrdfFolder {
    /// The run of this folder (for a shard: the whole run's photons, the
    /// shard's block in `run.shard`) and its scene.
    pub description: Description,
    /// Per incidence angle: this folder's sums.
    pub results: Vec<IncidenceResult>,
    /// The raw sums for `tallies.json` (shards and merges).
    pub tallies: Option<TalliesFile>,
    /// Wall-clock time (s; for a merge the shards' sum).
    pub seconds: f64,
}

impl BrdfFolder {
    /// Trace the run of `description` (all its photons, or its shard's
    /// block of them) on `surfaces` (one per realisation); `progress` is
    /// called with photons done.
    #[must_use]
    pub fn trace(
        surfaces: &[&MicroSurface],
        description: Description,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Self {
        let run = &description.run;
        let clock = Instant::now();
        let mut results = Vec::with_capacity(run.blocks().len());
        let mut parts = Vec::new();
        for &theta in &run.theta_deg {
            let (lanes, seconds) = run.run_shard_one(surfaces, theta, progress);
            for (l, nodes) in lanes.into_iter().enumerate() {
                results.push(run.result(theta, l, &nodes, seconds));
                if run.shard.is_some() {
                    parts.push((theta, run.wavelength(l), seconds, nodes));
                }
            }
        }
        let seconds = clock.elapsed().as_secs_f64();
        let tallies = run
            .shard
            .is_some()
            .then(|| TalliesFile::new(&description, parts, seconds));
        Self {
            description,
            results,
            tallies,
            seconds,
        }
    }

    /// The folder of merged shards: the whole run's sums, and its
    /// `tallies.json` (the tree's roots).
    #[must_use]
    pub fn merged(merged: Merged) -> Self {
        let tallies = merged.tallies_file();
        let Merged {
            description,
            incidence,
            seconds,
        } = merged;
        let results = incidence
            .into_iter()
            .map(|i| IncidenceResult {
                theta_i_deg: i.theta_deg,
                phi_i_deg: description.run.phi_deg,
                wavelength_um: i.wavelength_um,
                realisations: description.run.realisation_results(i.theta_deg, &i.nodes),
                tallies: i.tallies,
                seconds: i.seconds,
            })
            .collect();
        Self {
            description,
            results,
            tallies: Some(tallies),
            seconds,
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

    /// Every file of the folder, with `extra` files (images, exports)
    /// after the tables: `brdf.csv`, `inplane.csv`, the polarisation table,
    /// `extra`, `tallies.json` (if any), `summary.json`.
    #[must_use]
    pub fn files(&self, extra: Vec<(String, Vec<u8>)>) -> Vec<(String, Vec<u8>)> {
        let mut files = vec![
            (
                "brdf.csv".to_owned(),
                brdf_csv::write(self.run(), &self.results).into_bytes(),
            ),
            (
                "inplane.csv".to_owned(),
                inplane_csv::write(self.run(), &self.results).into_bytes(),
            ),
        ];
        if let Some((name, text)) = polar_csv::write(self.run(), &self.results) {
            files.push((name.to_owned(), text.into_bytes()));
        }
        if let Some(text) = super::colour_csv::write(self.run(), &self.results) {
            files.push(("colour.csv".to_owned(), text.into_bytes()));
        }
        files.extend(extra);
        if let Some(t) = &self.tallies {
            files.push((TALLIES_FILE.to_owned(), t.to_text().into_bytes()));
        }
        files.push((
            "summary.json".to_owned(),
            to_text(&self.summary()).into_bytes(),
        ));
        files
    }
}
