//! `roks fit-model` as one library call: a [`Request`] (the result folder,
//! the models, the options) gives the files to write, their bytes, and the
//! lines to print ([`Report`]). The command line parses its options into a
//! [`Request`], checks the [`Request::outputs`], writes [`Report::files`]
//! and prints [`Report::lines`].
//!
//! Files (default `RESULT_DIR/fit_<model>.json`; `out` moves them all):
//! the JSON, the plot (the JSON's path with the extension `.png`) and, for
//! ABg, OpticStudio's rows (`_opticstudio.txt` in place of the extension).
//! [`ModelChoice::All`] fits every model and adds
//! `RESULT_DIR/fit_summary.json`, the models ranked ([`super::rank`]).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::material::material;
use super::one::{
    Context, Fitted, ModelChoice, NotFitted, OutputKind, Paths, Request, RunError, fit_one,
};
use super::ranking::{FitSummary, ranked, ranking_lines};
use super::{FitResult, ModelKind, observations};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::outdir::file::ResultFile;
use crate::output::brdf_csv::BrdfTableError;
use crate::output::brdf_csv::reader::read_text;

/// What a run made: the files (not yet written) and what to print.
#[derive(Debug)]
pub struct Report {
    /// Every file to write, in order: each model's (OpticStudio's rows,
    /// plot, JSON), then `fit_summary.json`.
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// The lines printed with `--quiet`: every warning.
    quiet_lines: Vec<String>,
    /// The lines printed otherwise.
    lines: Vec<String>,
}

impl Report {
    /// The lines to print on stderr: with `quiet`, only the warnings.
    #[must_use]
    pub fn lines(&self, quiet: bool) -> &[String] {
        if quiet {
            &self.quiet_lines
        } else {
            &self.lines
        }
    }
}

/// The table to fit and what `summary.json` says of its run.
struct Loaded {
    tables: BrdfTables,
    /// The scene file named in `summary.json`.
    scene: Option<String>,
    /// The scene's `name` in `summary.json`.
    name: Option<String>,
    /// The photons of each incidence, by increasing angle.
    photons: Option<Vec<u64>>,
    wavelengths: Vec<f64>,
    /// The wavelength's index in a spectral table (0: one wavelength).
    lane: usize,
}

impl Loaded {
    fn table(&self) -> &BrdfTable {
        &self.tables.tables()[self.lane]
    }
}

impl Request {
    /// `brdf.csv` of the result folder.
    fn csv(&self) -> PathBuf {
        ResultFile::Brdf.path_in(&self.dir)
    }

    /// `summary.json` of the result folder.
    fn summary_path(&self) -> PathBuf {
        ResultFile::Summary.path_in(&self.dir)
    }

    /// The files the run reads: `brdf.csv` and `summary.json`.
    #[must_use]
    pub fn inputs(&self) -> [PathBuf; 2] {
        [self.csv(), self.summary_path()]
    }

    /// Where `fit_summary.json` goes.
    fn summary_out(&self) -> PathBuf {
        ResultFile::FitRanking.path_in(&self.dir)
    }

    /// Each model's files.
    fn paths(&self) -> Vec<Paths> {
        self.model
            .kinds()
            .iter()
            .map(|&k| {
                Paths::of(
                    k,
                    self.out
                        .clone()
                        .unwrap_or_else(|| self.dir.join(format!("fit_{k}.json"))),
                )
            })
            .collect()
    }

    /// Every file the run would write, with its kind; checked before
    /// anything is read.
    ///
    /// # Errors
    /// `dir` is not a folder, or `out` with [`ModelChoice::All`].
    pub fn outputs(&self) -> Result<Vec<(PathBuf, OutputKind)>, RunError> {
        if self.texts.is_none() && !self.dir.is_dir() {
            return Err(RunError::Input(format!(
                "{}: not a folder (expected the result folder of `roks brdf`, with brdf.csv)",
                self.dir.display()
            )));
        }
        if self.model == ModelChoice::All && self.out.is_some() {
            return Err(RunError::Input(
                "--out: --model all writes fit_<model>.json for every model and fit_summary.json into the result folder; give --out with one model"
                    .into(),
            ));
        }
        let mut all: Vec<(PathBuf, OutputKind)> = self
            .paths()
            .iter()
            .flat_map(Paths::all)
            .map(|(p, k)| (p.clone(), k))
            .collect();
        if self.model == ModelChoice::All {
            all.push((self.summary_out(), OutputKind::Json));
        }
        Ok(all)
    }

    /// The table, the scene and photons of `summary.json`, the wavelength:
    /// from [`Request::texts`], else from the files of `dir`.
    fn load(&self) -> Result<Loaded, RunError> {
        let input = |e: BrdfTableError| RunError::Input(e.to_string());
        let csv = self.csv();
        let summary_path = self.summary_path();
        let csv_text = match &self.texts {
            Some(t) => Cow::Borrowed(t.csv.as_str()),
            None => Cow::Owned(read_text(&csv).map_err(input)?.1),
        };
        let mut tables = BrdfTables::parse(&csv_text, &csv.display().to_string()).map_err(input)?;
        drop(csv_text);
        tables
            .require_one_azimuth("roks fit-model (its models are isotropic)")
            .map_err(|e| RunError::Input(e.to_string()))?;
        let summary_text = match &self.texts {
            Some(t) => t.summary.as_deref().map(Cow::Borrowed),
            None if summary_path.exists() => {
                Some(Cow::Owned(read_text(&summary_path).map_err(input)?.1))
            }
            None => None,
        };
        let mut scene = None;
        let mut scene_name = None;
        let mut photons: Option<Vec<u64>> = None;
        if let Some(text) = summary_text {
            let name = summary_path.display().to_string();
            tables = tables.with_summary_text(&text, &name).map_err(input)?;
            // Checked by with_summary_text: the same run. Its scene and photons.
            let summary: crate::output::summary::BrdfSummary =
                serde_json::from_str(&text).map_err(|e| RunError::Input(format!("{name}: {e}")))?;
            let mut by_angle: Vec<(f64, u64)> = summary
                .incidence
                .iter()
                .map(|e| (e.theta_deg, e.photons))
                .collect();
            by_angle.sort_by(|x, y| x.0.total_cmp(&y.0));
            photons = Some(by_angle.into_iter().map(|p| p.1).collect());
            scene = Some(summary.scene);
            scene_name = Some(summary.name);
        }
        let wavelengths = tables.wavelengths_um().to_vec();
        let lane = self.lane(&tables, &csv)?;
        Ok(Loaded {
            tables,
            scene,
            name: scene_name,
            photons,
            wavelengths,
            lane,
        })
    }

    /// The index of the wavelength to fit in `tables` (read from `csv`).
    fn lane(&self, tables: &BrdfTables, csv: &Path) -> Result<usize, RunError> {
        let wavelengths = tables.wavelengths_um();
        match (tables.spectral(), self.wavelength) {
            (None, None) => Ok(0),
            (None, Some(_)) => Err(RunError::Input(format!(
                "--wavelength: {} is a table of one wavelength",
                csv.display()
            ))),
            (Some(_), None) => Err(RunError::Input(format!(
                "--wavelength: {} is spectral ({:?} um): name the wavelength to fit",
                csv.display(),
                wavelengths
            ))),
            (Some(s), Some(w)) => {
                s.wavelengths_um()
                    .iter()
                    .position(|&x| x == w)
                    .ok_or_else(|| {
                        RunError::Input(format!(
                            "--wavelength: {w} um is not one of the wavelengths of {} ({:?} um)",
                            csv.display(),
                            wavelengths
                        ))
                    })
            }
        }
    }

    /// Refuse a material for a model that takes none.
    fn check_material(&self) -> Result<(), RunError> {
        if self.model == ModelChoice::Abg || self.model == ModelChoice::Harvey {
            let m = &self.material;
            for (option, given) in [
                ("--n", m.n.is_some()),
                ("--k", m.k.is_some()),
                ("--reflectance", m.reflectance.is_some()),
            ] {
                if given {
                    return Err(RunError::Input(format!(
                        "{option}: only ggx and beckmann take a material (--model {})",
                        self.model
                    )));
                }
            }
        }
        Ok(())
    }

    /// Fit the model(s): every file's bytes, and the lines to print.
    ///
    /// # Errors
    /// Bad input (the result folder, its table or summary, options), a
    /// table no model can be fitted to (`cannot fit: ...`), or a failure to
    /// make a plot or a JSON.
    pub fn run(&self) -> Result<Report, RunError> {
        self.outputs()?;
        let loaded = self.load()?;
        self.check_material()?;
        let table = loaded.table();
        let obs = observations(table, loaded.photons.as_deref());
        let csv = self.csv();
        let ctx = Context {
            req: self,
            scene_name: loaded.name.as_deref(),
            csv: &csv,
            table,
            obs: &obs,
            material: &|kind: ModelKind| {
                material(
                    &self.material,
                    &self.dir,
                    kind,
                    loaded.scene.as_deref(),
                    &loaded.wavelengths,
                    loaded.lane,
                )
            },
        };
        let mut fitted = Vec::new();
        let mut skipped: Vec<(ModelKind, String)> = Vec::new();
        for (&kind, p) in self.model.kinds().iter().zip(self.paths()) {
            match fit_one(&ctx, kind, p) {
                Ok(f) => fitted.push(f),
                Err(NotFitted::Failed(e)) => return Err(e),
                Err(NotFitted::Skipped(why)) => {
                    if self.model != ModelChoice::All {
                        return Err(RunError::Input(why));
                    }
                    skipped.push((kind, why));
                }
            }
        }
        if fitted.is_empty() {
            // --model all and no model fitted: the first reason.
            let why = skipped.first().map_or_else(String::new, |s| s.1.clone());
            return Err(RunError::Input(why));
        }
        self.report(&csv, fitted, &skipped)
    }

    /// The files and lines of the models `fitted` and `skipped`.
    fn report(
        &self,
        csv: &Path,
        fitted: Vec<Fitted>,
        skipped: &[(ModelKind, String)],
    ) -> Result<Report, RunError> {
        let all = self.model == ModelChoice::All;
        let mut files = Vec::new();
        let (mut quiet_lines, mut lines) = (Vec::new(), Vec::new());
        for f in &fitted {
            files.extend(f.files.iter().cloned());
            if !all {
                lines.extend(parameter_lines(&f.fits));
                lines.extend(f.material.iter().map(|m| format!("material: {m}")));
            }
            let warnings = f.warnings.iter().map(|w| format!("warning: {w}"));
            quiet_lines.extend(warnings.clone());
            lines.extend(warnings);
        }
        if all {
            let judged: Vec<_> = fitted
                .iter()
                .map(|f| (f.judgement.clone(), f.paths.json.display().to_string()))
                .collect();
            let names: Vec<_> = skipped.iter().map(|(k, w)| (k.name(), w.clone())).collect();
            let summary = FitSummary::new(&csv.display().to_string(), &judged, &names);
            let text = summary.to_text().map_err(anyhow::Error::from)?;
            files.push((self.summary_out(), text.into_bytes()));
            lines.extend(
                skipped
                    .iter()
                    .map(|(k, why)| format!("{k}: not fitted: {why}")),
            );
            let judgements: Vec<_> = fitted.iter().map(|f| f.judgement.clone()).collect();
            lines.extend(ranking_lines(&ranked(&judgements)));
            lines.push(format!(
                "wrote {} and fit_<model>.json, .png (abg: _opticstudio.txt) for {}",
                self.summary_out().display(),
                fitted
                    .iter()
                    .map(|f| f.kind.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        } else {
            let f = &fitted[0];
            lines.push(format!("verdict: {}", f.judgement.line()));
            lines.push(format!(
                "wrote {}",
                f.paths
                    .all()
                    .iter()
                    .map(|(p, _)| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        Ok(Report {
            files,
            quiet_lines,
            lines,
        })
    }
}

/// The parameter lines of a single model's fits.
fn parameter_lines(fits: &[FitResult]) -> Vec<String> {
    fits.iter()
        .map(|f| {
            let params: Vec<String> = f
                .parameters
                .iter()
                .map(|p| {
                    if p.stderr.is_nan() {
                        format!("{} = {:.5e} (undetermined)", p.name, p.value)
                    } else {
                        format!("{} = {:.5e} +- {:.2e}", p.name, p.value, p.stderr)
                    }
                })
                .collect();
            let at = if f.theta_i_deg.len() == 1 {
                format!("theta_i {:>5} deg", f.theta_i_deg[0])
            } else {
                "all incidences".into()
            };
            format!(
                "{at}: {}; chi2/dof {:.3}{}",
                params.join(", "),
                f.chi2_per_dof,
                if f.covariance_scaled {
                    " (errors scaled by it)"
                } else {
                    ""
                }
            )
        })
        .collect()
}
