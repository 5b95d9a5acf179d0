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

use std::fmt;
use std::path::Path;

use thiserror::Error;

use super::{BrdfSummary, IncidenceSummary};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::output::brdf_csv::BrdfTableError;
use crate::output::brdf_csv::reader::read_text;

/// The entry of `summary.json` that holds a table's reflectance:
/// `incidence[k]`, or `incidence[k].spectrum[l]` for wavelength `l` of a
/// spectral run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EntryKey {
    /// `k`, 0-based.
    pub incidence: usize,
    /// `l`, 0-based (`None`: a monochrome run).
    pub spectrum: Option<usize>,
}

impl fmt::Display for EntryKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "incidence[{}]", self.incidence)?;
        match self.spectrum {
            Some(l) => write!(f, ".spectrum[{l}]"),
            None => Ok(()),
        }
    }
}

/// Why a `summary.json` does not fit the BRDF table it is read with
/// ([`BrdfTableError::Summary`] names the file). Each names the key; angles
/// in degrees, wavelengths in µm; `table` is the table's file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SummaryProblem {
    /// Not JSON (serde's message, with line and column).
    #[error("invalid JSON: {0}")]
    Json(String),
    /// JSON that is not a `roks brdf` summary: the key (empty: the whole
    /// file) and serde's message (with line and column).
    #[error("{}{message}", if key.is_empty() { "not the summary.json of a roks brdf run".to_owned() } else { key.clone() } + ": ")]
    NotASummary {
        /// Dotted key path, e.g. `incidence[1].reflectance_stderr`.
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// The summary of a spectral run beside a table of one wavelength.
    #[error(
        "wavelengths_um: the summary of a spectral run, but {table} is a table of one wavelength"
    )]
    Spectral {
        /// The table's file.
        table: String,
    },
    /// Other wavelengths than the table's.
    #[error(
        "wavelengths_um: {found:?} is not the table's wavelengths {expected:?} um in {table} (a summary of another run?)"
    )]
    Wavelengths {
        /// The summary's.
        found: Vec<f64>,
        /// The table's.
        expected: Vec<f64>,
        /// The table's file.
        table: String,
    },
    /// Other bands than the table's.
    #[error("bands: {found} is not the {expected} bands of {table} (a summary of another run?)")]
    Bands {
        /// The summary's.
        found: usize,
        /// The table's.
        expected: usize,
        /// The table's file.
        table: String,
    },
    /// An entry of an incidence the table does not have.
    #[error(
        "incidence[{k}]: theta_deg = {theta_deg:?}, phi_deg = {phi_deg:?} is not tabulated in {table} (a truncated table, or a summary of another run?)"
    )]
    NotTabulated {
        /// The entry, 0-based.
        k: usize,
        /// Its incidence angle.
        theta_deg: f64,
        /// Its light azimuth.
        phi_deg: f64,
        /// The table's file.
        table: String,
    },
    /// An entry without photons.
    #[error("incidence[{0}].photons: must be an integer > 0")]
    NoPhotons(usize),
    /// An entry whose photons are not those of the run (or shard).
    #[error("incidence[{k}].photons: {found} is not photons_per_incidence = {expected}")]
    Photons {
        /// The entry, 0-based.
        k: usize,
        /// Its photons.
        found: u64,
        /// The folder's photons per incidence.
        expected: u64,
    },
    /// A tabulated incidence without an entry.
    #[error(
        "incidence: no entry with theta_deg = {theta_deg}, phi_deg = {phi_deg} (tabulated in {table})"
    )]
    NoEntry {
        /// The incidence angle.
        theta_deg: f64,
        /// The light azimuth.
        phi_deg: f64,
        /// The table's file.
        table: String,
    },
    /// An entry without the spectrum entry of a wavelength's table.
    #[error("{key}: missing (theta_deg = {theta_deg}; {table} has a table at {wavelength_um} um)")]
    NoWavelength {
        /// The missing entry.
        key: EntryKey,
        /// The incidence angle.
        theta_deg: f64,
        /// The table's file.
        table: String,
        /// The wavelength.
        wavelength_um: f64,
    },
    /// A spectrum entry of another wavelength.
    #[error(
        "{key}.wavelength_um: {found:?} is not the table's {expected} um in {table} (a summary of another run?)"
    )]
    Wavelength {
        /// The entry.
        key: EntryKey,
        /// Its wavelength.
        found: f64,
        /// The table's.
        expected: f64,
        /// The table's file.
        table: String,
    },
    /// A reflectance other than the table's sum of fractions.
    #[error(
        "{key}.reflectance: {found} at theta_deg = {theta_deg} is not the table's {expected} in {table} (a summary of another run?)"
    )]
    Reflectance {
        /// The entry.
        key: EntryKey,
        /// Its reflectance.
        found: f64,
        /// The incidence angle.
        theta_deg: f64,
        /// The table's reflectance.
        expected: f64,
        /// The table's file.
        table: String,
    },
    /// A standard error that is negative or not finite.
    #[error("{key}.reflectance_stderr: not a finite number >= 0 (theta_deg = {theta_deg})")]
    Stderr {
        /// The entry.
        key: EntryKey,
        /// The incidence angle.
        theta_deg: f64,
    },
    /// A standard error no mean of scores in `[0, 1]` can have.
    #[error(
        "{key}.reflectance_stderr: {found} exceeds {bound}, the most a mean reflectance of {reflectance} over {photons} photons can have (theta_deg = {theta_deg})"
    )]
    StderrBound {
        /// The entry.
        key: EntryKey,
        /// Its standard error.
        found: f64,
        /// The largest possible.
        bound: f64,
        /// Its reflectance.
        reflectance: f64,
        /// Its photons.
        photons: u64,
        /// The incidence angle.
        theta_deg: f64,
    },
}

/// The summary in `text` (of the file `name`), or the one-line reason it
/// is not that of a `roks brdf` run, naming the key.
fn parse(text: &str, name: &str) -> Result<BrdfSummary, BrdfTableError> {
    let problem = |e: serde_json::Error, key: String| {
        if e.is_syntax() || e.is_eof() {
            SummaryProblem::Json(e.to_string())
        } else {
            SummaryProblem::NotASummary {
                key,
                message: e.to_string(),
            }
        }
    };
    let fail = |problem| BrdfTableError::Summary {
        file: name.to_owned(),
        problem,
    };
    let mut de = serde_json::Deserializer::from_str(text);
    let summary = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let key = e.path().to_string();
        let key = if key == "." { String::new() } else { key };
        fail(problem(e.into_inner(), key))
    })?;
    // Nothing but white space after the summary.
    de.end().map_err(|e| fail(problem(e, String::new())))?;
    Ok(summary)
}

impl BrdfSummary {
    /// The `summary.json` of `roks brdf` at `path`, read through its typed
    /// struct.
    ///
    /// # Errors
    /// [`BrdfTableError::Io`] if it cannot be read; [`BrdfTableError::Summary`]
    /// if it is not JSON or not that of a `roks brdf` run, naming the key.
    pub fn read(path: &Path) -> Result<Self, BrdfTableError> {
        let (name, text) = read_text(path)?;
        parse(&text, &name)
    }
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
        let fail = |problem| BrdfTableError::Summary {
            file: name.to_owned(),
            problem,
        };
        // The wavelengths of a spectral run (an empty list: monochrome).
        let wavelengths = &summary.run.wavelengths_um;
        match self {
            Self::Monochrome(t) => {
                if !wavelengths.is_empty() {
                    return Err(fail(SummaryProblem::Spectral {
                        table: t.file().to_owned(),
                    }));
                }
                Ok(Self::Monochrome(t.apply_summary(&summary, name, None)?))
            }
            Self::Spectral(mut s) => {
                if wavelengths.as_slice() != s.wavelengths_um() {
                    return Err(fail(SummaryProblem::Wavelengths {
                        found: wavelengths.clone(),
                        expected: s.wavelengths_um().to_vec(),
                        table: s.tables()[0].file().to_owned(),
                    }));
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
    ///   (16: the replicates of a lattice launch), or for an ensemble of
    ///   `S` surface realisations (`stderr_dof = S - 1`) the most its error
    ///   can be, `sqrt(S / (S - 1) max(w_s) R (1 - R))` (`w_s` a
    ///   realisation's share of the photons);
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
        let fail = |problem| BrdfTableError::Summary {
            file: name.to_owned(),
            problem,
        };
        let run = &summary.run;
        if run.bands != self.grid().bands() {
            return Err(fail(SummaryProblem::Bands {
                found: run.bands,
                expected: self.grid().bands(),
                table: self.file().to_owned(),
            }));
        }
        self.check_entries(summary).map_err(fail)?;
        for i in 0..self.thetas_deg().len() {
            let (entry, key, r, se) = self.summary_value(summary, i, lane).map_err(fail)?;
            check_stderr(entry, key, r, se, self.incidence(i).theta_deg).map_err(fail)?;
            self.set_stated_stderr(i, se);
        }
        Ok(self)
    }

    /// Check that every entry of `summary` is an incidence of this table,
    /// with the photons per incidence of the summary's run (or its shard's
    /// block).
    fn check_entries(&self, summary: &BrdfSummary) -> Result<(), SummaryProblem> {
        let run = &summary.run;
        // Photons per incidence of this summary's folder: the run's, or
        // its shard's block.
        let per_incidence = run.shard.as_ref().map_or(run.photons, |s| {
            s.last_photon.saturating_sub(s.first_photon)
        });
        for (k, e) in summary.incidence.iter().enumerate() {
            let listed = (0..self.thetas_deg().len())
                .map(|i| self.incidence(i))
                .any(|inc| entry_at(e, inc.theta_deg, inc.phi_i_deg));
            if !listed {
                return Err(SummaryProblem::NotTabulated {
                    k,
                    theta_deg: e.theta_deg,
                    phi_deg: e.phi_deg,
                    table: self.file().to_owned(),
                });
            }
            if e.photons == 0 {
                return Err(SummaryProblem::NoPhotons(k));
            }
            if e.photons != per_incidence {
                return Err(SummaryProblem::Photons {
                    k,
                    found: e.photons,
                    expected: per_incidence,
                });
            }
        }
        Ok(())
    }

    /// The entry of `summary` for this table's incidence `i`, the key of
    /// its value for this table (`lane`: see
    /// [`apply_summary`](Self::apply_summary)), and that value's
    /// reflectance and standard error, the reflectance checked to be the
    /// table's (within 1e-7).
    fn summary_value<'s>(
        &self,
        summary: &'s BrdfSummary,
        i: usize,
        lane: Option<(usize, f64)>,
    ) -> Result<(&'s IncidenceSummary, EntryKey, f64, f64), SummaryProblem> {
        let inc = self.incidence(i);
        let theta = inc.theta_deg;
        let table = || self.file().to_owned();
        let (k, entry) = summary
            .incidence
            .iter()
            .enumerate()
            .find(|(_, e)| entry_at(e, theta, inc.phi_i_deg))
            .ok_or_else(|| SummaryProblem::NoEntry {
                theta_deg: theta,
                phi_deg: inc.phi_i_deg,
                table: table(),
            })?;
        // This table's reflectance and its standard error, and their key.
        let (r, se, key) = match lane {
            None => (
                entry.reflectance,
                entry.reflectance_stderr,
                EntryKey {
                    incidence: k,
                    spectrum: None,
                },
            ),
            Some((l, w)) => {
                let key = EntryKey {
                    incidence: k,
                    spectrum: Some(l),
                };
                let v = entry
                    .spectrum
                    .as_ref()
                    .and_then(|s| s.get(l))
                    .ok_or_else(|| SummaryProblem::NoWavelength {
                        key,
                        theta_deg: theta,
                        table: table(),
                        wavelength_um: w,
                    })?;
                if v.wavelength_um != w {
                    return Err(SummaryProblem::Wavelength {
                        key,
                        found: v.wavelength_um,
                        expected: w,
                        table: table(),
                    });
                }
                (v.reflectance, v.reflectance_stderr, key)
            }
        };
        let close = (r - inc.reflectance).abs() <= 1e-7; // false for NaN
        if !close {
            return Err(SummaryProblem::Reflectance {
                key,
                found: r,
                theta_deg: theta,
                expected: inc.reflectance,
                table: table(),
            });
        }
        Ok((entry, key, r, se))
    }
}

/// Whether summary entry `e` is the incidence at polar angle `theta` and
/// azimuth `phi` (degrees, exactly).
fn entry_at(e: &IncidenceSummary, theta: f64, phi: f64) -> bool {
    e.theta_deg == theta && e.phi_deg == phi
}

/// Check the standard error `se` a summary `entry` states for its value
/// `key` of reflectance `r` (at polar angle `theta`, degrees): finite,
/// >= 0, and within the largest a mean of its photons can have.
fn check_stderr(
    entry: &IncidenceSummary,
    key: EntryKey,
    r: f64,
    se: f64,
    theta: f64,
) -> Result<(), SummaryProblem> {
    if !(se.is_finite() && se >= 0.0) {
        return Err(SummaryProblem::Stderr {
            key,
            theta_deg: theta,
        });
    }
    let photons = entry.photons;
    // The errors of an ensemble of R surface realisations (the
    // photon share w_r of each): R / (R - 1) sum w_r² (m_r - m)²,
    // at most R / (R - 1) max(w_r) m (1 - m).
    let ensemble = entry
        .stderr_dof
        .zip(entry.realisations.as_ref())
        .filter(|(dof, _)| *dof >= 1 && photons > 0)
        .map(|(dof, re)| {
            let w = re.photons.iter().max().copied().unwrap_or(photons) as f64 / photons as f64;
            (dof as f64 + 1.0) / dof as f64 * w
        });
    if photons >= 2 {
        let dof = photons.min(16) as f64 - 1.0;
        let rc = r.clamp(0.0, 1.0);
        let bound = (rc * (1.0 - rc) / dof)
            .max(rc * (1.0 - rc) * ensemble.unwrap_or(0.0))
            .sqrt();
        if se > bound * (1.0 + 1e-6) + 1e-12 {
            return Err(SummaryProblem::StderrBound {
                key,
                found: se,
                bound,
                reflectance: r,
                photons,
                theta_deg: theta,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::summary::{Description, Surface};
    use serde_json::{Value, json};

    /// A short run of the default scene (8 bands, incidences 0, 30 and 60
    /// degrees): its `brdf.csv` read back as a table, its results, and its
    /// `summary.json` as JSON, both from the writers.
    fn run_files() -> (BrdfTable, crate::transport::brdf::BrdfResult, Value) {
        let scene = crate::scene::micro::MicroScene::default_scene();
        let mut run = scene.brdf_run();
        run.photons = 1024;
        run.bands = 8;
        run.theta_deg = vec![0.0, 30.0, 60.0];
        let results = run.trace_whole(&scene.surface, &|_| {});
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
            &|j| j["incidence"][1]["reflectance_stderr"] = Value::Null,
            "s.json: incidence[1].reflectance_stderr: invalid type: null, expected f64",
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
