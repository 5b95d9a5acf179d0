//! `roks fit` as library calls: the inputs read ([`Inputs::read`]), the
//! fit prepared and checked ([`Inputs::prepare`]), then run
//! ([`Prepared::run`]) to the files of the result folder and the lines to
//! print ([`Outcome`]).

use std::path::{Path, PathBuf};

use super::{FitError, FitOptions, FitParam, FitResult, Measured, Observer, Problem};
use crate::outdir::file::ResultFile;
use crate::output::summary::{self, FitParameter, FitStep, FitSummary};
use crate::scene::SceneFile;

/// The inputs of a fit, read and parsed: the scene's text, the
/// measurement, the parameters.
#[derive(Debug, Clone)]
pub struct Inputs {
    scene: PathBuf,
    scene_text: String,
    scene_file: SceneFile,
    measured_path: PathBuf,
    measured_name: String,
    measured: Measured,
    params: Vec<FitParam>,
}

impl Inputs {
    /// Read the micro scene file `scene` and the measured in-plane BRDF
    /// `measured` (CSV, [`Measured::parse`]), and parse `params` (each
    /// `key=lo:hi`, [`FitParam`]).
    ///
    /// # Errors
    /// A file that cannot be read, a malformed measurement or parameter:
    /// one line naming the file or `--param`.
    pub fn read(scene: &Path, measured: &Path, params: &[String]) -> Result<Self, FitError> {
        let scene_text = crate::scene::read_scene_text(scene)?;
        let measured_name = measured.display().to_string();
        let measured_text =
            crate::limits::read_text_capped(measured, crate::limits::max_data_bytes()).map_err(
                |e| FitError::Read {
                    file: measured_name.clone(),
                    message: e.to_string(),
                },
            )?;
        let measured_data = Measured::parse(&measured_text, &measured_name)?;
        let params = params
            .iter()
            .map(|p| p.parse::<FitParam>())
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            scene: scene.to_path_buf(),
            scene_text,
            scene_file: SceneFile::from_path(scene),
            measured_path: measured.to_path_buf(),
            measured_name,
            measured: measured_data,
            params,
        })
    }

    /// The fit with `opts`, checked ([`Problem::new`]).
    ///
    /// # Errors
    /// The scene, a parameter or an option is invalid.
    pub fn prepare(self, opts: &FitOptions) -> Result<Prepared, FitError> {
        let problem = Problem::new(
            &self.scene_text,
            &self.scene_file,
            &self.params,
            &self.measured,
            opts,
        )?;
        Ok(Prepared {
            inputs: self,
            problem,
            seed: opts.seed,
            photons: opts.photons,
        })
    }
}

/// A fit ready to run.
#[derive(Debug, Clone)]
pub struct Prepared {
    inputs: Inputs,
    problem: Problem,
    seed: u64,
    photons: u64,
}

/// What a fit made: the files of its result folder and the lines to print.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The files, by name: `fit_inplane.csv`, `fitted.toml`, `fit.json`.
    pub files: Vec<(&'static str, Vec<u8>)>,
    /// The result.
    pub result: FitResult,
    params: Vec<FitParam>,
}

impl Prepared {
    /// The default result folder: `out/<scene name>-fit`.
    #[must_use]
    pub fn default_out(&self) -> PathBuf {
        let name = self
            .inputs
            .scene
            .file_stem()
            .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
        Path::new("out").join(format!("{name}-fit"))
    }

    /// The files the fit reads: the scene and what it reads, the measurement.
    #[must_use]
    pub fn reads(&self) -> Vec<PathBuf> {
        let mut reads = crate::scene::micro::MicroScene::reads_of(&self.inputs.scene);
        reads.push(self.inputs.measured_path.clone());
        reads
    }

    /// Run the fit, calling `observe` after every model run ([`Problem::fit_observed`]).
    ///
    /// # Errors
    /// The scene rejects the start point or the fitted values.
    pub fn run(&self, observe: &mut Observer<'_>) -> Result<Outcome, FitError> {
        let result = self.problem.fit_observed(observe)?;
        let fitted = self.problem.apply(&result.values)?;
        let inputs = &self.inputs;
        let summary = FitSummary::new(
            &inputs.scene_file.file,
            &inputs.measured_name,
            self.seed,
            self.photons,
            &inputs.params,
            &result,
        );
        let csv = inplane_csv(&inputs.measured, &result);
        Ok(Outcome {
            files: vec![
                (ResultFile::FitInplane.name(), csv.into_bytes()),
                (ResultFile::Fitted.name(), fitted.into_bytes()),
                (
                    ResultFile::Fit.name(),
                    summary::to_text(&summary).into_bytes(),
                ),
            ],
            result,
            params: inputs.params.clone(),
        })
    }
}

impl Outcome {
    /// The lines printed at the end: each parameter's value, then the
    /// misfit and where the folder `out` was written.
    #[must_use]
    pub fn lines(&self, out: &Path) -> Vec<String> {
        let r = &self.result;
        let mut lines: Vec<String> = self
            .params
            .iter()
            .enumerate()
            .map(|(i, p)| {
                format!(
                    "{} = {:.6} (start {:.6}, bounds {}:{})",
                    p.key, r.values[i], r.start[i], p.lo, p.hi
                )
            })
            .collect();
        lines.push(format!(
            "misfit {:.3e} (start {:.3e}), {} evaluations; wrote {}",
            r.misfit,
            r.start_misfit,
            r.evaluations,
            out.display()
        ));
        lines
    }
}

/// The progress line of model run `k` at `values`: its misfit, or why the
/// scene rejected the values.
#[must_use]
pub fn evaluation_line(k: usize, values: &[f64], misfit: f64, rejected: Option<&str>) -> String {
    match rejected {
        Some(why) => format!("evaluation {k:>4}: rejected by the scene at {values:?}: {why}"),
        None => format!("evaluation {k:>4}: misfit {misfit:.6e} at {values:?}"),
    }
}

/// The text of `fit_inplane.csv`: every measured point with the model's
/// value at the fitted parameters (with the measurement's light azimuths:
/// its `phi_i_deg` column too).
fn inplane_csv(measured: &Measured, result: &FitResult) -> String {
    let mut csv = match measured.phi_i_deg {
        Some(_) => String::from("theta_i_deg,phi_i_deg,theta_o_deg,measured,model\n"),
        None => String::from("theta_i_deg,theta_o_deg,measured,model\n"),
    };
    for (k, ((ti, to, b, _), m)) in measured.points.iter().zip(&result.model).enumerate() {
        let phi = measured
            .phi_i_deg
            .as_ref()
            .map_or(String::new(), |p| format!("{},", p[k]));
        csv.push_str(&format!("{ti},{phi}{to},{b:.9e},{m:.9e}\n"));
    }
    csv
}

impl FitSummary {
    /// The summary of fit `result` of `params` to `measured` (as given) on
    /// scene file `scene`, with `photons` per model run and `seed`.
    #[must_use]
    pub fn new(
        scene: &str,
        measured: &str,
        seed: u64,
        photons: u64,
        params: &[FitParam],
        result: &FitResult,
    ) -> Self {
        Self {
            converged: result.converged,
            evaluations: result.evaluations,
            history: result
                .history
                .iter()
                .enumerate()
                .map(|(k, (v, m))| {
                    let rejected = result.rejected.iter().find(|r| r.0 == k);
                    FitStep {
                        misfit: rejected.is_none().then_some(*m).filter(|m| m.is_finite()),
                        rejected: rejected.map(|r| r.1.clone()),
                        values: v.clone(),
                    }
                })
                .collect(),
            measured: measured.to_owned(),
            misfit: result.misfit,
            parameters: params
                .iter()
                .enumerate()
                .map(|(i, p)| FitParameter {
                    at_bound: format!("{:?}", result.at_bounds[i]).to_lowercase(),
                    fitted: result.values[i],
                    hi: p.hi,
                    key: p.key.clone(),
                    lo: p.lo,
                    start: result.start[i],
                })
                .collect(),
            photons,
            rejected_evaluations: result.rejected.len(),
            scene: scene.to_owned(),
            seed,
            start_misfit: result.start_misfit,
            version: env!("CARGO_PKG_VERSION").to_owned(),
        }
    }
}
