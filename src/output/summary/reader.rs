//! The reader of `summary.json` beside a `brdf.csv`: the file is read
//! through its typed struct ([`BrdfSummary`], the one `roks brdf` writes),
//! checked against the table it describes, and its exact reflectance
//! standard errors attached to the table ([`BrdfTable::with_summary`],
//! [`BrdfTables::with_summary`]).
//!
//! A file that is not JSON, or JSON that is not a `roks brdf` summary (a
//! key missing or of the wrong type), fails with serde's message naming
//! the key, line and column; the checks against the table name the key
//! (`incidence[k].reflectance`, `run.bands`, ...) and the table's file.

use std::path::Path;

use super::{BrdfSummary, IncidenceSummary};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::output::brdf_csv::BrdfTableError;
use crate::output::brdf_csv::reader::read_text;

/// The summary in `text` (of the file `name`), or the one-line reason it
/// is not that of a `roks brdf` run.
fn parse(text: &str, name: &str) -> Result<BrdfSummary, BrdfTableError> {
    serde_json::from_str(text).map_err(|e| BrdfTableError::Summary {
        file: name.to_owned(),
        message: if e.is_syntax() || e.is_eof() {
            format!("invalid JSON: {e}")
        } else {
            format!("not the summary.json of a roks brdf run: {e}")
        },
    })
}

impl BrdfTables {
    /// The same tables with the exact reflectance standard errors of the
    /// `summary.json` at `path` (see [`with_summary_text`](Self::with_summary_text)).
    ///
    /// # Errors
    /// [`BrdfTableError::Io`] if it cannot be read, otherwise as
    /// [`with_summary_text`](Self::with_summary_text).
    pub fn with_summary(self, path: &Path) -> Result<Self, BrdfTableError> {
        let (name, text) = read_text(path)?;
        self.with_summary_text(&text, &name)
    }

    /// As [`BrdfTable::with_summary_text`] for a monochrome table. For a
    /// spectral one the summary must be that of a spectral run with the
    /// same wavelengths (`run.wavelengths_um`), and each wavelength's
    /// table is checked against, and takes its standard errors from,
    /// `incidence[k].spectrum[l]` (`wavelength_um`, `reflectance`,
    /// `reflectance_stderr`) with the checks of the monochrome case.
    ///
    /// # Errors
    /// [`BrdfTableError::Summary`] naming the file, the key and what is
    /// wrong.
    pub fn with_summary_text(self, text: &str, name: &str) -> Result<Self, BrdfTableError> {
        let summary = parse(text, name)?;
        let fail = |message: String| BrdfTableError::Summary {
            file: name.to_owned(),
            message,
        };
        // The wavelengths of a spectral run (an empty list: monochrome).
        let wavelengths = &summary.run.wavelengths_um;
        match self {
            Self::Monochrome(t) => {
                if !wavelengths.is_empty() {
                    return Err(fail(format!(
                        "wavelengths_um: the summary of a spectral run, but {} is a table of one wavelength",
                        t.file()
                    )));
                }
                Ok(Self::Monochrome(t.apply_summary(&summary, name, None)?))
            }
            Self::Spectral(mut s) => {
                if wavelengths.as_slice() != s.wavelengths_um() {
                    return Err(fail(format!(
                        "wavelengths_um: {wavelengths:?} is not the table's wavelengths {:?} um in {} (a summary of another run?)",
                        s.wavelengths_um(),
                        s.tables()[0].file()
                    )));
                }
                let wavelengths = s.wavelengths_um().to_vec();
                for (l, (t, w)) in s.tables_mut().iter_mut().zip(wavelengths).enumerate() {
                    *t = t.clone().apply_summary(&summary, name, Some((l, w)))?;
                }
                Ok(Self::Spectral(s))
            }
        }
    }
}

impl BrdfTable {
    /// The same table with the exact reflectance standard errors of the
    /// `summary.json` at `path` (written by `roks brdf` beside `brdf.csv`).
    ///
    /// # Errors
    /// [`BrdfTableError::Io`] if it cannot be read, otherwise as
    /// [`with_summary_text`](Self::with_summary_text).
    pub fn with_summary(self, path: &Path) -> Result<Self, BrdfTableError> {
        let (name, text) = read_text(path)?;
        self.with_summary_text(&text, &name)
    }

    /// As [`with_summary`](Self::with_summary), from the text of
    /// `summary.json`; `name` names it in error messages. The summary and
    /// the table must describe the same run:
    /// * every tabulated incidence has an entry of `incidence` with the same
    ///   `theta_deg` and `phi_deg`, and every entry is tabulated (a table cut
    ///   at a block boundary has lost an incidence its summary lists);
    /// * per entry `photons` is > 0 and the photons per incidence of the
    ///   summary's folder (`run.photons_per_incidence`, or a shard's block
    ///   `run.shard.last_photon - run.shard.first_photon`), `reflectance` is
    ///   within 1e-7 of the table's sum of fractions (the table rounds
    ///   fractions to 10 digits), and `reflectance_stderr` is a finite
    ///   number >= 0 no larger than any mean of `photons` scores in `[0, 1]`
    ///   can have, `sqrt(R (1 - R) / (k - 1))` with `k = min(photons, 16)`
    ///   (16: the replicates of a lattice launch);
    /// * `run.bands` is the table's.
    ///
    /// # Errors
    /// [`BrdfTableError::Summary`] naming the file, the key and what is
    /// wrong (and the table's file where they disagree).
    pub fn with_summary_text(self, text: &str, name: &str) -> Result<Self, BrdfTableError> {
        let summary = parse(text, name)?;
        self.apply_summary(&summary, name, None)
    }

    /// [`with_summary_text`](Self::with_summary_text) of the read
    /// `summary`; for the table of wavelength `l` of a spectral run (`lane =
    /// Some((l, wavelength_um))`) the reflectance and its standard error are
    /// those of `incidence[k].spectrum[l]`, whose `wavelength_um` must be
    /// the table's.
    fn apply_summary(
        mut self,
        summary: &BrdfSummary,
        name: &str,
        lane: Option<(usize, f64)>,
    ) -> Result<Self, BrdfTableError> {
        let fail = |message: String| BrdfTableError::Summary {
            file: name.to_owned(),
            message,
        };
        let table = self.file().to_owned();
        let entries = &summary.incidence;
        let run = &summary.run;
        if run.bands != self.grid().bands() {
            return Err(fail(format!(
                "bands: {} is not the {} bands of {table} (a summary of another run?)",
                run.bands,
                self.grid().bands()
            )));
        }
        // Photons per incidence of this summary's folder: the run's, or
        // its shard's block.
        let per_incidence = run.shard.as_ref().map_or(run.photons, |s| {
            s.last_photon.saturating_sub(s.first_photon)
        });
        let at =
            |e: &IncidenceSummary, theta: f64, phi: f64| e.theta_deg == theta && e.phi_deg == phi;
        for (k, e) in entries.iter().enumerate() {
            let listed = (0..self.thetas_deg().len())
                .map(|i| self.incidence(i))
                .any(|inc| at(e, inc.theta_deg, inc.phi_i_deg));
            if !listed {
                return Err(fail(format!(
                    "incidence[{k}]: theta_deg = {:?}, phi_deg = {:?} is not tabulated in {table} (a truncated table, or a summary of another run?)",
                    e.theta_deg, e.phi_deg,
                )));
            }
            if e.photons == 0 {
                return Err(fail(format!(
                    "incidence[{k}].photons: must be an integer > 0"
                )));
            }
            if e.photons != per_incidence {
                return Err(fail(format!(
                    "incidence[{k}].photons: {} is not photons_per_incidence = {per_incidence}",
                    e.photons
                )));
            }
        }
        for i in 0..self.thetas_deg().len() {
            let inc = self.incidence(i);
            let theta = inc.theta_deg;
            let (k, entry) = entries
                .iter()
                .enumerate()
                .find(|(_, e)| at(e, theta, inc.phi_i_deg))
                .ok_or_else(|| {
                    fail(format!(
                        "incidence: no entry with theta_deg = {theta}, phi_deg = {} (tabulated in {table})",
                        inc.phi_i_deg
                    ))
                })?;
            // This table's reflectance and its standard error, and their key.
            let (r, se, key) = match lane {
                None => (
                    entry.reflectance,
                    entry.reflectance_stderr,
                    format!("incidence[{k}]"),
                ),
                Some((l, w)) => {
                    let key = format!("incidence[{k}].spectrum[{l}]");
                    let v = entry
                        .spectrum
                        .as_ref()
                        .and_then(|s| s.get(l))
                        .ok_or_else(|| {
                            fail(format!(
                                "{key}: missing (theta_deg = {theta}; {table} has a table at {w} um)"
                            ))
                        })?;
                    if v.wavelength_um != w {
                        return Err(fail(format!(
                            "{key}.wavelength_um: {:?} is not the table's {w} um in {table} (a summary of another run?)",
                            v.wavelength_um
                        )));
                    }
                    (v.reflectance, v.reflectance_stderr, key)
                }
            };
            let close = (r - inc.reflectance).abs() <= 1e-7; // false for NaN
            if !close {
                return Err(fail(format!(
                    "{key}.reflectance: {r} at theta_deg = {theta} is not the table's {} in {table} (a summary of another run?)",
                    inc.reflectance
                )));
            }
            if !(se.is_finite() && se >= 0.0) {
                return Err(fail(format!(
                    "{key}.reflectance_stderr: not a finite number >= 0 (theta_deg = {theta})"
                )));
            }
            let photons = entry.photons;
            if photons >= 2 {
                let dof = photons.min(16) as f64 - 1.0;
                let rc = r.clamp(0.0, 1.0);
                let bound = (rc * (1.0 - rc) / dof).sqrt();
                if se > bound * (1.0 + 1e-6) + 1e-12 {
                    return Err(fail(format!(
                        "{key}.reflectance_stderr: {se} exceeds {bound}, the most a mean reflectance of {r} over {photons} photons can have (theta_deg = {theta})"
                    )));
                }
            }
            self.set_stated_stderr(i, se);
        }
        Ok(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::summary::{Description, Surface};
    use serde_json::{Value, json};

    /// A short run of the default scene (8 bands, incidences 0, 30 and 60
    /// degrees): its `brdf.csv` read back as a table, its results, and its
    /// `summary.json` as JSON, both from the writers.
    fn run_files() -> (
        BrdfTable,
        Vec<crate::transport::brdf::IncidenceResult>,
        Value,
    ) {
        let scene = crate::scene::micro::MicroScene::default_scene();
        let mut run = scene.brdf_run();
        run.photons = 1024;
        run.bands = 8;
        run.theta_deg = vec![0.0, 30.0, 60.0];
        let results = run.run(&scene.surface, &|_| {});
        let csv = crate::output::brdf_csv::write(&run, &results);
        let table = BrdfTable::parse(&csv, "t.csv").unwrap();
        let stats = crate::micro::surface_stats::surface_stats(&scene.surface.height_map(8, 8));
        let description = Description::new(
            scene.content.clone(),
            "default",
            "default",
            crate::micro::Edges::Periodic,
            run,
            Surface::new(&stats, 8),
        );
        let summary = BrdfSummary::new(&description, &results, 1.0);
        let json = serde_json::from_str(&crate::output::summary::to_text(&summary)).unwrap();
        (table, results, json)
    }

    #[test]
    fn the_writers_summary_gives_the_exact_standard_errors() {
        let (t, results, json) = run_files();
        assert!(!t.has_stated_stderr());
        let te = t
            .clone()
            .with_summary_text(&json.to_string(), "s.json")
            .unwrap();
        assert!(te.has_stated_stderr());
        for r in &results {
            let theta = r.theta_i_deg.to_radians();
            let (_, se) = r.reflectance();
            let exact = te.reflectance_stderr(theta);
            assert!((exact - se).abs() <= 1e-12 * se, "stderr {exact} vs {se}");
            assert!(t.reflectance_stderr(theta) >= exact);
        }
    }

    #[test]
    fn summary_errors_name_the_file_and_key() {
        let (t, _, good) = run_files();
        let bad = |edit: &dyn Fn(&mut Value), needle: &str| {
            let mut json = good.clone();
            edit(&mut json);
            let e = t
                .clone()
                .with_summary_text(&json.to_string(), "s.json")
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("s.json: ") && e.contains(needle) && !e.contains('\n'),
                "{e}"
            );
        };
        let e = t.clone().with_summary_text("{", "s.json").unwrap_err();
        assert!(e.to_string().starts_with("s.json: invalid JSON"), "{e}");
        bad(
            &|j| *j = json!({}),
            "not the summary.json of a roks brdf run: missing field",
        );
        bad(
            &|j| {
                j["incidence"].as_array_mut().unwrap().pop();
            },
            "theta_deg = 60",
        );
        bad(
            &|j| j["incidence"][1]["reflectance"] = json!(0.99),
            "incidence[1].reflectance: 0.99 at theta_deg = 30 is not the table's",
        );
        bad(
            &|j| j["incidence"][0]["reflectance_stderr"] = json!(-1e-4),
            "incidence[0].reflectance_stderr: not a finite number >= 0",
        );
        // An incidence the table lacks (cut at a block boundary).
        bad(
            &|j| {
                let mut extra = j["incidence"][2].clone();
                extra["theta_deg"] = json!(80.0);
                j["incidence"].as_array_mut().unwrap().push(extra);
            },
            "incidence[3]: theta_deg = 80.0, phi_deg = 0.0 is not tabulated in t.csv",
        );
        // Photon counts, bands, an impossible standard error.
        bad(
            &|j| j["incidence"][1]["photons"] = json!(0),
            "incidence[1].photons: must be an integer > 0",
        );
        bad(
            &|j| j["run"]["photons_per_incidence"] = json!(999),
            "incidence[0].photons: 1024 is not photons_per_incidence = 999",
        );
        bad(
            &|j| j["run"]["bands"] = json!(7),
            "bands: 7 is not the 8 bands of t.csv",
        );
        bad(
            &|j| j["incidence"][1]["reflectance_stderr"] = json!(0.2),
            "incidence[1].reflectance_stderr: 0.2 exceeds",
        );
        let e = t
            .with_summary(Path::new("/nonexistent/summary.json"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("/nonexistent/summary.json: cannot read"),
            "{e}"
        );
    }
}
