//! `roks fit`: fit the parameters of a micro scene to a measured in-plane
//! BRDF, and write fit.json, fitted.toml and fit_inplane.csv.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use super::common::{check_out_dir, set_threads, write_folder};
use super::parse::{integer, number, positive};
use crate::fit::{FitError, FitOptions, FitParam, Measured, Problem};
use crate::output::summary::{self, FitSummary};

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

/// Run `roks fit`.
///
/// # Errors
/// Bad input (scene, measurements, parameters, options), or a failed write.
pub fn execute(a: FitArgs) -> Result<(), Failure> {
    let input = |e: FitError| Failure::Input(e.to_string());
    let text = crate::scene::read_scene_text(&a.scene)?;
    let scene_file = crate::scene::SceneFile::from_path(&a.scene);
    let measured_text =
        crate::limits::read_text_capped(&a.measured, crate::limits::max_data_bytes())
            .map_err(|e| Failure::Input(format!("{}: cannot read: {e}", a.measured.display())))?;
    let measured =
        Measured::parse(&measured_text, &a.measured.display().to_string()).map_err(input)?;
    let params = a
        .params
        .iter()
        .map(|p| p.parse::<FitParam>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(input)?;
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
    set_threads(a.threads)?;
    let problem = Problem::new(&text, &scene_file, &params, &measured, &opts).map_err(input)?;
    let name = a
        .scene
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("{name}-fit")));
    let mut reads = crate::scene::micro::MicroScene::reads_of(&a.scene);
    reads.push(a.measured.clone());
    check_out_dir(&out, "--out", &reads, a.force)?;
    let quiet = a.quiet;
    let result = problem
        .fit_observed(&mut |k, values, misfit, rejected| {
            if !quiet {
                match rejected {
                    Some(why) => {
                        eprintln!("evaluation {k:>4}: rejected by the scene at {values:?}: {why}");
                    }
                    None => eprintln!("evaluation {k:>4}: misfit {misfit:.6e} at {values:?}"),
                }
            }
        })
        .map_err(input)?;
    let fitted = problem.apply(&result.values).map_err(input)?;
    let summary = FitSummary::new(
        &scene_file.file,
        &a.measured.display().to_string(),
        a.seed,
        a.photons,
        &params,
        &result,
    );
    // With the measurement's light azimuths: its phi_i_deg column too.
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
    let text = summary::to_text(&summary);
    write_folder(
        &out,
        &[
            ("fit_inplane.csv", csv.as_bytes()),
            ("fitted.toml", fitted.as_bytes()),
            ("fit.json", text.as_bytes()),
        ],
        "fit",
    )?;
    if !quiet {
        for (i, p) in params.iter().enumerate() {
            eprintln!(
                "{} = {:.6} (start {:.6}, bounds {}:{})",
                p.key, result.values[i], result.start[i], p.lo, p.hi
            );
        }
        eprintln!(
            "misfit {:.3e} (start {:.3e}), {} evaluations; wrote {}",
            result.misfit,
            result.start_misfit,
            result.evaluations,
            out.display()
        );
    }
    Ok(())
}
