//! `roks fit-model`: an analytic BRDF model fitted to the table of a `roks
//! brdf` result folder ([`crate::fit_model`]), written as JSON with a plot
//! and, for ABg, the text of OpticStudio's ABg data dialog.
//!
//! Files (default `RESULT_DIR/fit_<model>.json`; `--out FILE` moves them
//! all): `FILE` (JSON), `FILE` with the extension `.png` (the plot) and, for
//! ABg, `FILE` with `_opticstudio.txt` in place of its extension. Each is
//! written atomically (a temporary file renamed over it), and only once
//! every fit is made. `--model all` fits every model, writes each one's
//! files and `RESULT_DIR/fit_summary.json`, the models ranked
//! ([`fit_model::rank`]).
//!
//! Every fit is judged ([`fit_model::warnings`], [`Judgement`]): each
//! warning is printed on stderr (quiet or not), then the verdict in one
//! line. A table no model can take (a mirror's, nothing reflected) is
//! refused with `cannot fit: ...`, exit status 2, nothing written.

use std::path::{Path, PathBuf};

use clap::Args;
use serde_json::json;

use super::Failure;
use super::common::{FileKind, check_out_file, write_file};
use super::parse::number;
use crate::fit_model::microfacet::{Distribution, Microfacet};
use crate::fit_model::{self, FitResult, Judgement, ModelKind, abg, harvey, observations};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::optics::material::{Reflectance, ReflectanceError};

/// The options of `roks fit-model`.
#[derive(Args, Debug)]
pub struct FitModelArgs {
    /// Result folder of `roks brdf` (with brdf.csv and summary.json).
    pub dir: PathBuf,
    /// The model: abg, harvey (per incidence), ggx or beckmann (one
    /// roughness for all incidences, with Smith shadowing and the material's
    /// Fresnel factor), or all (every model, ranked; fit_summary.json).
    #[arg(long, ignore_case = true, hide_possible_values = true)]
    pub model: ModelChoice,
    /// Output JSON (default RESULT_DIR/fit_<model>.json); the plot is
    /// written beside it with the extension .png, OpticStudio's ABg rows
    /// with _opticstudio.txt.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace an existing output (JSON, plot, text) even when it is not that kind of fit-model output that roks
    /// wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
    /// ggx, beckmann: the material's refractive index n (with --k; default:
    /// the material of the scene named in summary.json).
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub n: Option<f64>,
    /// ggx, beckmann: the material's extinction coefficient k (with --n;
    /// default 0).
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub k: Option<f64>,
    /// ggx, beckmann: a constant reflectance instead of Fresnel.
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub reflectance: Option<f64>,
    /// A spectral table: the wavelength (µm) to fit, one of the table's.
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub wavelength: Option<f64>,
    /// No summary on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The path of `out` with its extension replaced by `suffix` (which
/// includes any dot or underscore).
fn beside(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}{suffix}"))
}

/// The material of a microfacet fit and where it came from.
fn material(
    a: &FitModelArgs,
    kind: ModelKind,
    scene: Option<&str>,
    wavelengths: &[f64],
    lane: usize,
) -> Result<(Reflectance, String), Failure> {
    let bad = |option: &str, e: String| Failure::Input(format!("{option}: {e}"));
    if let Some(r) = a.reflectance {
        if a.n.is_some() || a.k.is_some() {
            return Err(bad(
                "--reflectance",
                "give either --reflectance or --n/--k, not both".into(),
            ));
        }
        let m = Reflectance::Constant(r);
        m.validate()
            .map_err(|e| bad("--reflectance", e.to_string()))?;
        return Ok((m, format!("--reflectance {r}")));
    }
    if let Some(n) = a.n {
        let k = a.k.unwrap_or(0.0);
        let m = Reflectance::Fresnel { n, k };
        m.validate().map_err(|e| {
            let option = match e {
                ReflectanceError::InvalidK(_) => "--k",
                _ => "--n",
            };
            bad(option, e.to_string())
        })?;
        return Ok((m, format!("--n {n} --k {k}")));
    }
    if a.k.is_some() {
        return Err(bad("--k", "needs --n".into()));
    }
    let Some(scene) = scene else {
        return Err(Failure::Input(format!(
            "--model {}: {}: no summary.json naming the scene, so the material is unknown: give --n N --k K or --reflectance R",
            kind,
            a.dir.display()
        )));
    };
    let path = Path::new(scene);
    let loaded = if scene == "<default scene>" {
        load_at(None, wavelengths)
    } else if !path.exists() {
        return Err(Failure::Input(format!(
            "{}: scene: {scene}: no such file (relative to the folder roks brdf ran in?): run from there, or give --n N --k K or --reflectance R",
            a.dir.join("summary.json").display()
        )));
    } else {
        load_at(Some(path), wavelengths)
    }?;
    let surface = &loaded.surface;
    let m = surface.materials[surface.substrate_material]
        .lane(lane)
        .clone();
    let name = loaded
        .material_names
        .get(surface.substrate_material)
        .cloned()
        .unwrap_or_default();
    let others = if surface
        .materials
        .iter()
        .any(|x| x != &surface.materials[surface.substrate_material])
    {
        " (the scene has other materials too; the fit uses the substrate's)"
    } else {
        ""
    };
    let what = match &m {
        Reflectance::Constant(r) => format!("constant reflectance {r}"),
        Reflectance::Fresnel { n, k } => format!("Fresnel n = {n}, k = {k}"),
        Reflectance::Table(_) => "reflectance table".into(),
        Reflectance::Spectral(_) => "spectral".into(),
    };
    Ok((
        m,
        format!("scene {scene}, material `{name}` of the surface: {what}{others}"),
    ))
}

/// What `--model` takes: one model, or every one ranked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelChoice {
    /// ABg, per incidence.
    Abg,
    /// Harvey-Shack, per incidence.
    Harvey,
    /// GGX microfacet, one alpha.
    Ggx,
    /// Beckmann microfacet, one alpha.
    Beckmann,
    /// Every model, ranked (fit_summary.json).
    All,
}

impl ModelChoice {
    /// The models this choice fits, in the order they are fitted.
    fn kinds(self) -> Vec<ModelKind> {
        match self {
            Self::Abg => vec![ModelKind::Abg],
            Self::Harvey => vec![ModelKind::Harvey],
            Self::Ggx => vec![ModelKind::Ggx],
            Self::Beckmann => vec![ModelKind::Beckmann],
            Self::All => vec![
                ModelKind::Abg,
                ModelKind::Harvey,
                ModelKind::Ggx,
                ModelKind::Beckmann,
            ],
        }
    }
}

impl std::fmt::Display for ModelChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::All => f.write_str("all"),
            Self::Abg => f.write_str("abg"),
            Self::Harvey => f.write_str("harvey"),
            Self::Ggx => f.write_str("ggx"),
            Self::Beckmann => f.write_str("beckmann"),
        }
    }
}

/// The files of one model's fit: the JSON, the plot and, for ABg,
/// OpticStudio's rows.
struct Paths {
    json: PathBuf,
    png: PathBuf,
    opticstudio: Option<PathBuf>,
}

impl Paths {
    fn of(kind: ModelKind, json: PathBuf) -> Self {
        Self {
            png: beside(&json, ".png"),
            opticstudio: (kind == ModelKind::Abg).then(|| beside(&json, "_opticstudio.txt")),
            json,
        }
    }

    fn all(&self) -> Vec<(&PathBuf, FileKind)> {
        let mut v = vec![(&self.json, FileKind::FitJson), (&self.png, FileKind::Png)];
        v.extend(self.opticstudio.as_ref().map(|p| (p, FileKind::FitText)));
        v
    }
}

/// One model fitted: its files' bytes (not yet written), fits, warnings
/// and verdict.
struct Fitted {
    kind: ModelKind,
    paths: Paths,
    files: Vec<(PathBuf, Vec<u8>)>,
    fits: Vec<FitResult>,
    material: Option<String>,
    warnings: Vec<String>,
    judgement: Judgement,
}

/// Why a model was not fitted.
enum NotFitted {
    /// The table is not of a form the model takes (`cannot fit: ...`),
    /// or, with `--model all`, a microfacet model has no material.
    Skipped(String),
    /// Bad input or a failed write: the command fails.
    Failed(Failure),
}

impl From<Failure> for NotFitted {
    fn from(f: Failure) -> Self {
        Self::Failed(f)
    }
}

impl From<anyhow::Error> for NotFitted {
    fn from(e: anyhow::Error) -> Self {
        Self::Failed(Failure::Other(e))
    }
}

/// What every model's fit reads.
struct Context<'a> {
    a: &'a FitModelArgs,
    csv: &'a Path,
    table: &'a BrdfTable,
    obs: &'a fit_model::Observations,
    scene: Option<&'a str>,
    wavelengths: &'a [f64],
    lane: usize,
}

/// Run `roks fit-model`.
///
/// # Errors
/// Bad input (the result folder, its table or summary, options), a table
/// no model can be fitted to (`cannot fit: ...`, exit status 2), or a
/// failed write.
pub fn execute(a: FitModelArgs) -> Result<(), Failure> {
    let input = |e: String| Failure::Input(e);
    if !a.dir.is_dir() {
        return Err(input(format!(
            "{}: not a folder (expected the result folder of `roks brdf`, with brdf.csv)",
            a.dir.display()
        )));
    }
    let csv = a.dir.join("brdf.csv");
    let summary_path = a.dir.join("summary.json");
    if a.model == ModelChoice::All && a.out.is_some() {
        return Err(input(
            "--out: --model all writes fit_<model>.json for every model and fit_summary.json into the result folder; give --out with one model"
                .into(),
        ));
    }
    let kinds = a.model.kinds();
    let paths: Vec<Paths> = kinds
        .iter()
        .map(|&k| {
            Paths::of(
                k,
                a.out
                    .clone()
                    .unwrap_or_else(|| a.dir.join(format!("fit_{k}.json"))),
            )
        })
        .collect();
    let summary_out = a.dir.join("fit_summary.json");
    let inputs = [csv.clone(), summary_path.clone()];
    for (p, kind) in paths.iter().flat_map(Paths::all) {
        check_out_file(p, &inputs, kind, a.force)?;
    }
    if a.model == ModelChoice::All {
        check_out_file(&summary_out, &inputs, FileKind::FitJson, a.force)?;
    }
    let mut tables = BrdfTables::load(&csv).map_err(|e| input(e.to_string()))?;
    tables
        .require_one_azimuth("roks fit-model (its models are isotropic)")
        .map_err(|e| input(e.to_string()))?;
    let mut scene = None;
    let mut photons: Option<Vec<u64>> = None;
    if summary_path.exists() {
        tables = tables
            .with_summary(&summary_path)
            .map_err(|e| input(e.to_string()))?;
        // Checked by with_summary: the same run. Its scene and photons.
        let text = crate::limits::read_text_capped(&summary_path, crate::limits::max_data_bytes())
            .map_err(|e| input(format!("{}: {e}", summary_path.display())))?;
        let summary: crate::output::summary::BrdfSummary = serde_json::from_str(&text)
            .map_err(|e| input(format!("{}: {e}", summary_path.display())))?;
        let mut by_angle: Vec<(f64, u64)> = summary
            .incidence
            .iter()
            .map(|e| (e.theta_deg, e.photons))
            .collect();
        by_angle.sort_by(|x, y| x.0.total_cmp(&y.0));
        photons = Some(by_angle.into_iter().map(|p| p.1).collect());
        scene = Some(summary.scene);
    }
    let wavelengths = tables.wavelengths_um().to_vec();
    let (table, lane): (&BrdfTable, usize) = match (tables.spectral(), a.wavelength) {
        (None, None) => (&tables.tables()[0], 0),
        (None, Some(_)) => {
            return Err(input(format!(
                "--wavelength: {} is a table of one wavelength",
                csv.display()
            )));
        }
        (Some(_), None) => {
            return Err(input(format!(
                "--wavelength: {} is spectral ({:?} um): name the wavelength to fit",
                csv.display(),
                wavelengths
            )));
        }
        (Some(s), Some(w)) => {
            let l = s
                .wavelengths_um()
                .iter()
                .position(|&x| x == w)
                .ok_or_else(|| {
                    input(format!(
                        "--wavelength: {w} um is not one of the wavelengths of {} ({:?} um)",
                        csv.display(),
                        wavelengths
                    ))
                })?;
            (&s.tables()[l], l)
        }
    };
    if a.model == ModelChoice::Abg || a.model == ModelChoice::Harvey {
        for (option, given) in [
            ("--n", a.n.is_some()),
            ("--k", a.k.is_some()),
            ("--reflectance", a.reflectance.is_some()),
        ] {
            if given {
                return Err(input(format!(
                    "{option}: only ggx and beckmann take a material (--model {})",
                    a.model
                )));
            }
        }
    }
    let obs = observations(table, photons.as_deref());
    let ctx = Context {
        a: &a,
        csv: &csv,
        table,
        obs: &obs,
        scene: scene.as_deref(),
        wavelengths: &wavelengths,
        lane,
    };
    let mut fitted = Vec::new();
    let mut skipped: Vec<(ModelKind, String)> = Vec::new();
    for (&kind, p) in kinds.iter().zip(paths) {
        match fit_one(&ctx, kind, p) {
            Ok(f) => fitted.push(f),
            Err(NotFitted::Failed(e)) => return Err(e),
            Err(NotFitted::Skipped(why)) => {
                if a.model != ModelChoice::All {
                    return Err(input(why));
                }
                skipped.push((kind, why));
            }
        }
    }
    if fitted.is_empty() {
        // --model all and no model fitted: the first reason.
        let why = skipped.first().map_or_else(String::new, |s| s.1.clone());
        return Err(input(why));
    }
    let summary_text = (a.model == ModelChoice::All)
        .then(|| summary_json(&csv, &fitted, &skipped))
        .transpose()?;
    // All or none, for an interrupt.
    let commit = crate::interrupt::commit();
    for f in &fitted {
        for (path, bytes) in &f.files {
            write_file(path, bytes)?;
        }
    }
    if let Some(text) = &summary_text {
        write_file(&summary_out, text.as_bytes())?;
    }
    drop(commit);
    for f in &fitted {
        if !a.quiet && a.model != ModelChoice::All {
            print_parameters(&f.fits);
            if let Some(m) = &f.material {
                eprintln!("material: {m}");
            }
        }
        for w in &f.warnings {
            eprintln!("warning: {w}");
        }
    }
    if a.quiet {
        return Ok(());
    }
    if a.model == ModelChoice::All {
        for (kind, why) in &skipped {
            eprintln!("{kind}: not fitted: {why}");
        }
        print_ranking(&fitted);
        eprintln!(
            "wrote {} and fit_<model>.json, .png (abg: _opticstudio.txt) for {}",
            summary_out.display(),
            fitted
                .iter()
                .map(|f| f.kind.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    } else {
        let f = &fitted[0];
        eprintln!("verdict: {}", f.judgement.line());
        eprintln!(
            "wrote {}",
            f.paths
                .all()
                .iter()
                .map(|(p, _)| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

/// The parameter lines of a single model's fits on stderr.
fn print_parameters(fits: &[FitResult]) {
    for f in fits {
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
        eprintln!(
            "{at}: {}; chi2/dof {:.3}{}",
            params.join(", "),
            f.chi2_per_dof,
            if f.covariance_scaled {
                " (errors scaled by it)"
            } else {
                ""
            }
        );
    }
}

/// The models ranked ([`fit_model::rank`]), best first.
fn ranked(fitted: &[Fitted]) -> Vec<Judgement> {
    let mut j: Vec<Judgement> = fitted.iter().map(|f| f.judgement.clone()).collect();
    fit_model::rank(&mut j);
    j
}

/// Which model to use, in one line, from the ranking (best first).
fn advice(ranking: &[Judgement]) -> String {
    match ranking.first() {
        Some(best) if best.passes => format!(
            "use {}: its reflectance is within max(1 %, 4 standard errors) of the table's at every incidence, with no warning (chi2/dof {:.3})",
            best.model, best.chi2_per_dof
        ),
        Some(best) => format!(
            "no model passes every check; the nearest is {} ({} of {} incidences ok, chi2/dof {:.3}): read its warnings before using it, or use the table itself",
            best.model, best.incidences_ok, best.incidences, best.chi2_per_dof
        ),
        None => "no model was fitted".into(),
    }
}

/// The ranking table and the advice on stderr.
fn print_ranking(fitted: &[Fitted]) {
    let ranking = ranked(fitted);
    eprintln!(
        "{:>4} {:<9} {:>10} {:>14} {:>20} {:>9} {:>8}",
        "rank", "model", "chi2/dof", "incidences ok", "worst reflectance", "converged", "warnings"
    );
    for (k, j) in ranking.iter().enumerate() {
        eprintln!(
            "{:>4} {:<9} {:>10.3} {:>14} {:>20} {:>9} {:>8}",
            k + 1,
            j.model,
            j.chi2_per_dof,
            format!("{} of {}", j.incidences_ok, j.incidences),
            format!(
                "{:+.2} % at {}",
                100.0 * j.worst_reflectance_error,
                j.worst_at_theta_i_deg
            ),
            if j.not_converged == 0 { "yes" } else { "no" },
            j.warnings
        );
    }
    eprintln!("{}", advice(&ranking));
}

/// The text of `fit_summary.json`: the models ranked, the advice, and the
/// models not fitted with why.
fn summary_json(
    csv: &Path,
    fitted: &[Fitted],
    skipped: &[(ModelKind, String)],
) -> Result<String, Failure> {
    let ranking = ranked(fitted);
    let file_of = |name: &str| {
        fitted
            .iter()
            .find(|f| f.kind.name() == name)
            .map(|f| f.paths.json.display().to_string())
    };
    let doc = json!({
        "table": csv.display().to_string(),
        "rule": "ranked: models with no warning first, then fewer incidences whose reflectance is off the table's by more than max(1 %, 4 standard errors), then fewer fits not converged, then the smaller chi2/dof (pooled over the model's fits: sum chi2 / sum dof)",
        "use": ranking.first().filter(|j| j.passes).map(|j| j.model.clone()),
        "advice": advice(&ranking),
        "ranking": ranking
            .iter()
            .map(|j| {
                let mut v = serde_json::to_value(j).unwrap_or_default();
                v["file"] = json!(file_of(&j.model));
                v["verdict"] = json!(j.line());
                v
            })
            .collect::<Vec<_>>(),
        "not_fitted": skipped
            .iter()
            .map(|(k, why)| json!({"model": k.name(), "reason": why}))
            .collect::<Vec<_>>(),
        "version": env!("CARGO_PKG_VERSION"),
    });
    Ok(serde_json::to_string_pretty(&doc).map_err(anyhow::Error::from)? + "\n")
}

/// Fit `kind` and make its files' bytes.
fn fit_one(ctx: &Context<'_>, kind: ModelKind, paths: Paths) -> Result<Fitted, NotFitted> {
    let (a, table, obs) = (ctx.a, ctx.table, ctx.obs);
    let cannot = |e: fit_model::FitError| {
        NotFitted::Skipped(format!(
            "cannot fit: {}: --model {kind}: {e}",
            ctx.csv.display()
        ))
    };
    let mut doc = json!({
        "model": kind.name(),
        "table": ctx.csv.display().to_string(),
        "wavelength_um": a.wavelength,
        "errors": "standard errors from the covariance (J^T J)^-1 of the weighted residuals at the minimum, multiplied by chi2/dof where that exceeds 1 (covariance_scaled); first-order propagation to the model's parameters",
        "cells": "every cell of the table with its brdf_stderr; a cell no photon left through gets 1/(N x projected solid angle), N the incidence's photons in summary.json, or is left out without it (cells_left_out)",
        "cell_average": "the model's BRDF averaged over each Carlson cell in projected solid angle (3 x 3 Gauss-Legendre in cos^2 theta and phi)",
        "verdicts": "fits[].reflectance[].ok: the model's reflectance within tolerance = max(1 % of the table's, 4 table_stderr) of the table's, the rule of the exports' read-back checks; warnings: every incidence that fails it, every fit that did not converge, every parameter whose standard error exceeds its value or is unknown",
        "version": env!("CARGO_PKG_VERSION"),
    });
    let title;
    let mut material_line = None;
    let (fits, plot_model): (Vec<FitResult>, Box<dyn fit_model::Model>) = match kind {
        ModelKind::Abg => {
            let fits = abg::fit(table, obs).map_err(cannot)?;
            doc["definition"] = json!(
                "BSDF = A / (B + |beta - beta0|^g) (1/sr); beta, beta0: the scattered and specular directions projected on the surface (lengths sin theta_s, sin theta_i); per incidence"
            );
            let rows = abg::opticstudio_rows(&fits);
            doc["opticstudio"] = json!({
                "dialog": "Setup > ABg Scatter Data Catalogs: one entry, Wave = the wavelength (0: no scaling), one row per angle of incidence (at most 10; interpolated in cosine space)",
                "wave_um": a.wavelength.unwrap_or(0.0),
                "rows": rows,
            });
            let near = fit_model::nearest(&fits, 30.0);
            doc["fred"] = json!({
                "dialog": "Scatterers > Create a new scatter model > ABg scatter: Acoef, Bcoef, G; one set (FRED's ABg does not depend on incidence): the fit nearest 30 degrees; check Halt Incident Ray (the table holds all reflected light)",
                "abg": abg::fred(&fits),
            });
            fred_verdict(&mut doc, &abg::Abg, &near.internal, table, obs);
            title = "ABg".to_owned();
            (fits, Box::new(abg::Abg))
        }
        ModelKind::Harvey => {
            let fits = harvey::fit(table, obs).map_err(cannot)?;
            doc["definition"] = json!(
                "BSDF = b0 (1 + (|beta - beta0| / l)^2)^(s/2) (1/sr); beta, beta0 as for ABg; per incidence"
            );
            let f = fit_model::nearest(&fits, 30.0);
            doc["fred"] = json!({
                "dialog": "Scatterers > Harvey-Shack: b0, L, S; one set: the fit nearest 30 degrees",
                "harvey_shack": {
                    "b0": f.parameters[0].value,
                    "L": f.parameters[1].value,
                    "S": f.parameters[2].value,
                    "from_theta_i_deg": f.theta_i_deg[0],
                },
            });
            fred_verdict(&mut doc, &harvey::Harvey, &f.internal, table, obs);
            title = "Harvey-Shack".to_owned();
            (fits, Box::new(harvey::Harvey))
        }
        ModelKind::Ggx | ModelKind::Beckmann => {
            let explicit = a.n.is_some() || a.k.is_some() || a.reflectance.is_some();
            let (material, source) = match material(a, kind, ctx.scene, ctx.wavelengths, ctx.lane) {
                Ok(m) => m,
                // --model all: without a material the microfacet
                // models are left out, and the ranking says why.
                Err(Failure::Input(why)) if a.model == ModelChoice::All && !explicit => {
                    return Err(NotFitted::Skipped(why));
                }
                Err(e) => return Err(e.into()),
            };
            let distribution = if kind == ModelKind::Ggx {
                Distribution::Ggx
            } else {
                Distribution::Beckmann
            };
            let model = Microfacet {
                distribution,
                material,
            };
            let fit = fit_model::microfacet::fit(&model, table, obs).map_err(cannot)?;
            doc["definition"] = json!(format!(
                "f = F(wi.h) D(h) G2 / (4 cos_i cos_o), {} distribution, Smith height-correlated G2 = 1 / (1 + Lambda_i + Lambda_o); one alpha for every incidence{}",
                if distribution == Distribution::Ggx {
                    "GGX (Trowbridge-Reitz)"
                } else {
                    "Beckmann"
                },
                if distribution == Distribution::Beckmann {
                    "; alpha = RMS slope sqrt(<|grad h|^2>) (= 2 sigma/tau for a Gaussian surface with autocorrelation sigma^2 exp(-r^2/tau^2))"
                } else {
                    "; alpha has no RMS-slope relation (infinite slope variance); D(n) = 1/(pi alpha^2) as Beckmann's"
                }
            ));
            doc["material"] = json!(source);
            material_line = Some(source);
            doc["single_scattering"] = json!(
                "the model scatters once: reflectance[].difference (table - model) is mostly the light the surface scatters twice or more"
            );
            title = if distribution == Distribution::Ggx {
                "GGX"
            } else {
                "Beckmann"
            }
            .to_owned();
            (vec![fit], Box::new(model))
        }
    };
    let mut warnings = fit_model::warnings(kind.name(), &fits);
    if matches!(kind, ModelKind::Ggx | ModelKind::Beckmann) {
        // Where a single-scattering model is below the table, say what it
        // cannot hold (summary.json's reflectance_by_bounces tells how much).
        for w in &mut warnings {
            if w.contains("the model's reflectance") && w.contains("% off") && w.contains(" is -") {
                w.push_str("; the model scatters once: the table's light scattered twice or more (summary.json: reflectance_by_bounces) is not in it");
            }
        }
    }
    let judgement = Judgement::of(kind.name(), &fits);
    doc["fits"] = serde_json::to_value(&fits).map_err(anyhow::Error::from)?;
    doc["warnings"] = json!(warnings);
    doc["verdict"] = json!(judgement.line());
    let png = fit_model::plot::png(table, plot_model.as_ref(), &fits, &title)?;
    let text = serde_json::to_string_pretty(&doc).map_err(anyhow::Error::from)? + "\n";
    let mut files = Vec::new();
    if let Some(p) = &paths.opticstudio {
        let name = a
            .dir
            .file_name()
            .map_or_else(|| "roks".into(), |s| s.to_string_lossy().into_owned());
        let rows = abg::opticstudio_rows(&fits);
        let body = abg::opticstudio_text(
            &name,
            a.wavelength.unwrap_or(0.0),
            &rows,
            &judgement.line(),
            &warnings,
        );
        files.push((p.clone(), body.into_bytes()));
    }
    files.push((paths.png.clone(), png));
    files.push((paths.json.clone(), text.into_bytes()));
    Ok(Fitted {
        kind,
        paths,
        files,
        fits,
        material: material_line,
        warnings,
        judgement,
    })
}

/// FRED takes one set of a per-incidence model for every incidence: that
/// set's reflectance at each of the table's incidences, judged, into
/// `doc["fred"]["verdict"]` (a line) and `["reflectance"]` (per incidence).
fn fred_verdict(
    doc: &mut serde_json::Value,
    model: &dyn fit_model::Model,
    q: &[f64],
    table: &BrdfTable,
    obs: &fit_model::Observations,
) {
    let r = fit_model::reflectance_of(model, q, table, obs);
    let off: Vec<String> = r
        .iter()
        .filter(|c| !c.ok)
        .map(|c| {
            format!(
                "{} deg ({:+.1} %)",
                c.theta_i_deg,
                100.0 * (c.model / c.table - 1.0)
            )
        })
        .collect();
    let line = if off.is_empty() {
        "ok: the one set's reflectance is within max(1 %, 4 standard errors) of the table's at every incidence".to_owned()
    } else {
        format!(
            "OFF: the one set's reflectance is off the table's by more than max(1 %, 4 standard errors) at {} of {} incidences: {}",
            off.len(),
            r.len(),
            off.join(", ")
        )
    };
    doc["fred"]["verdict"] = json!(line);
    doc["fred"]["reflectance"] = serde_json::to_value(&r).unwrap_or_default();
}

/// The micro scene at `path` (`None`: the embedded default) built at
/// `wavelengths_um` (µm; empty: as the scene says), for its material.
fn load_at(
    path: Option<&Path>,
    wavelengths_um: &[f64],
) -> Result<crate::scene::micro::MicroScene, Failure> {
    let overrides = crate::scene::micro::Overrides {
        wavelengths_um: (!wavelengths_um.is_empty())
            .then(|| crate::scene::WavelengthsSpec::List(wavelengths_um.to_vec())),
        ..Default::default()
    };
    super::common::load_scene_with(path, &overrides)
}
