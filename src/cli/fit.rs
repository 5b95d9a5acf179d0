//! `roks fit`: fit the parameters of a micro scene to a measured in-plane
//! BRDF, and write fit.json, fitted.toml and fit_inplane.csv.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::api::values::{integer, number, positive};
use crate::fit::{FitError, FitOptions, Inputs, evaluation_line};
use crate::outdir::{check::check_out_dir, write::write_folder};

/// The options of `roks fit`.
#[derive(Args, Debug)]
pub struct FitArgs {
    /// Micro scene file (TOML) whose parameters are adjusted.
    pub scene: PathBuf,
    /// Measured in-plane BRDF (CSV: theta_i_deg,theta_o_deg,brdf[,brdf_stderr];
    /// with phi_i_deg after theta_i_deg for several light azimuths).
    pub measured: PathBuf,
    /// A parameter to fit: KEY=LO:HI (repeat for several).
    #[arg(long = "param", required = true, value_name = "KEY=LO:HI")]
    pub params: Vec<String>,
    /// Photons per incidence angle per evaluation.
    #[arg(long, default_value_t = 200_000, value_parser = positive::<u64>)]
    pub photons: u64,
    /// Seed (fixed through the fit).
    #[arg(long, default_value_t = 1, value_parser = integer::<u64>)]
    pub seed: u64,
    /// Most model evaluations.
    #[arg(long, default_value_t = 200, value_parser = positive::<usize>)]
    pub max_evals: usize,
    /// Stop when the misfit spread of the simplex is below this.
    #[arg(long, default_value_t = 1e-6, value_parser = number)]
    pub tolerance: f64,
    /// ... and the simplex is narrower than this fraction of each range.
    #[arg(long, default_value_t = 1e-3, value_parser = number)]
    pub x_tolerance: f64,
    /// Restarts from the best point.
    #[arg(long, default_value_t = 3, value_parser = integer::<usize>)]
    pub restarts: usize,
    /// Points per parameter of the coarse scan before the simplex (0: none).
    #[arg(long, default_value_t = 8, value_parser = integer::<usize>)]
    pub scan: usize,
    /// In-plane bin width for the model (degrees; wider bins, less noise).
    #[arg(long, value_parser = number)]
    pub inplane_step: Option<f64>,
    /// In-plane detector width out of the plane (degrees).
    #[arg(long, value_parser = number)]
    pub inplane_width: Option<f64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = positive::<usize>)]
    pub threads: Option<usize>,
    /// Output folder (default: out/<scene name>-fit/), replaced whole (an
    /// existing one must be empty or a roks result).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output folder even when it holds files roks did not
    /// write (they are deleted; a folder that holds a folder, or is not a
    /// roks result, is still refused).
    #[arg(long)]
    pub force: bool,
    /// No progress lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks fit` ([`crate::fit::Inputs`], [`crate::fit::Prepared::run`]).
///
/// # Errors
/// Bad input (scene, measurements, parameters, options), or a failed write.
pub fn execute(a: FitArgs) -> Result<(), Failure> {
    let inputs = Inputs::read(&a.scene, &a.measured, &a.params)?;
    let opts = FitOptions {
        photons: a.photons,
        seed: a.seed,
        max_evaluations: a.max_evals,
        tolerance: a.tolerance,
        x_tolerance: a.x_tolerance,
        restarts: a.restarts,
        inplane_step_deg: a.inplane_step,
        inplane_width_deg: a.inplane_width,
        scan: a.scan,
    };
    crate::api::set_threads(a.threads)?;
    let fit = inputs.prepare(&opts)?;
    let out = a.out.clone().unwrap_or_else(|| fit.default_out());
    check_out_dir(&out, "--out", &fit.reads(), a.force)?;
    let quiet = a.quiet;
    let outcome = fit.run(&mut |k, values, misfit, rejected| {
        if !quiet {
            eprintln!("{}", evaluation_line(k, values, misfit, rejected));
        }
    })?;
    write_folder(&out, &outcome.files, "fit")?;
    if !quiet {
        for line in outcome.lines(&out) {
            eprintln!("{line}");
        }
    }
    Ok(())
}

/// A fit's error: bad input (scene, measurements, parameters), exit
/// status 2.
impl From<FitError> for Failure {
    fn from(e: FitError) -> Self {
        Self::Input(e.to_string())
    }
}
