//! One model of `roks fit-model` fitted (`fit_one`): its fits, warnings
//! and verdict, and the bytes of its files: the JSON document, the plot
//! and, for ABg, OpticStudio's rows.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use super::material::MaterialOptions;
use super::microfacet::{Distribution, Microfacet};
use super::{FitResult, Judgement, Model, ModelKind, Observations, abg, harvey};
use crate::optics::brdf_table::BrdfTable;
use crate::optics::material::Reflectance;
use crate::outdir::file::ResultPattern;

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
    #[must_use]
    pub fn kinds(self) -> Vec<ModelKind> {
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

/// Why `roks fit-model` failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Bad input (the result folder, its table or summary, the options),
    /// or a table no model can be fitted to (`cannot fit: ...`): one line.
    #[error("{0}")]
    Input(String),
    /// Anything else (making the plot or the JSON).
    #[error(transparent)]
    Other(#[from] anyhow::Error),
}

/// The kind of a file `roks fit-model` writes (for the output checks).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// A model's JSON, or `fit_summary.json`.
    Json,
    /// A model's plot (PNG).
    Png,
    /// ABg's rows for OpticStudio (text).
    Text,
}

/// The text of a result's `brdf.csv` and `summary.json`, given as values
/// ([`Request::texts`]) rather than read from its folder.
#[derive(Debug, Clone)]
pub struct TableTexts {
    /// The text of `brdf.csv`.
    pub csv: String,
    /// The text of `summary.json` (`None`: the result has none).
    pub summary: Option<String>,
}

/// One `roks fit-model` run: the options as given.
#[derive(Debug, Clone)]
pub struct Request {
    /// The result folder of `roks brdf` (with `brdf.csv`, and
    /// `summary.json` for the photons and the scene). With
    /// [`texts`](Self::texts) nothing is read from it: it only names the
    /// files in messages, in the JSON's `table` and as the outputs' folder
    /// (an empty path: their bare names, `brdf.csv`, `fit_abg.json`).
    pub dir: PathBuf,
    /// The table and summary as values (a result traced in-process), read
    /// by the same parsers as the folder's files; `None`: read `dir`.
    pub texts: Option<TableTexts>,
    /// The model(s).
    pub model: ModelChoice,
    /// The model's JSON (default `dir/fit_<model>.json`); one model only.
    pub out: Option<PathBuf>,
    /// The material of a microfacet fit.
    pub material: MaterialOptions,
    /// A spectral table: the wavelength (µm) to fit, one of the table's.
    pub wavelength: Option<f64>,
}

/// The path of `out` with its extension replaced by `suffix` (which
/// includes any dot or underscore).
fn beside(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}{suffix}"))
}

/// The files of one model's fit: the JSON, the plot and, for ABg,
/// OpticStudio's rows.
pub(crate) struct Paths {
    pub(crate) json: PathBuf,
    png: PathBuf,
    opticstudio: Option<PathBuf>,
}

impl Paths {
    /// The files of `kind` whose JSON is `json`.
    pub(crate) fn of(kind: ModelKind, json: PathBuf) -> Self {
        Self {
            png: beside(&json, ResultPattern::FitPicture.parts().1),
            opticstudio: (kind == ModelKind::Abg)
                .then(|| beside(&json, ResultPattern::FitOpticStudio.parts().1)),
            json,
        }
    }

    /// Every file with its kind: the JSON, the plot, OpticStudio's rows.
    pub(crate) fn all(&self) -> Vec<(&PathBuf, OutputKind)> {
        let mut v = vec![(&self.json, OutputKind::Json), (&self.png, OutputKind::Png)];
        v.extend(self.opticstudio.as_ref().map(|p| (p, OutputKind::Text)));
        v
    }
}

/// One model fitted: its files' bytes (not yet written), fits, warnings
/// and verdict.
pub(crate) struct Fitted {
    pub(crate) kind: ModelKind,
    pub(crate) paths: Paths,
    /// OpticStudio's rows (ABg), the plot, the JSON: in the order written.
    pub(crate) files: Vec<(PathBuf, Vec<u8>)>,
    pub(crate) fits: Vec<FitResult>,
    /// Where a microfacet model's material came from, in words.
    pub(crate) material: Option<String>,
    pub(crate) warnings: Vec<String>,
    pub(crate) judgement: Judgement,
}

/// Why a model was not fitted.
pub(crate) enum NotFitted {
    /// The table is not of a form the model takes (`cannot fit: ...`),
    /// or, with `--model all`, a microfacet model has no material.
    Skipped(String),
    /// Bad input or another failure: the run fails.
    Failed(RunError),
}

impl From<anyhow::Error> for NotFitted {
    fn from(e: anyhow::Error) -> Self {
        Self::Failed(RunError::Other(e))
    }
}

impl From<serde_json::Error> for NotFitted {
    fn from(e: serde_json::Error) -> Self {
        Self::Failed(RunError::Other(e.into()))
    }
}

/// The material of a microfacet model of a kind, and where it came from.
pub(crate) type MaterialOf<'a> = dyn Fn(ModelKind) -> Result<(Reflectance, String), String> + 'a;

/// What every model's fit reads.
pub(crate) struct Context<'a> {
    pub(crate) req: &'a Request,
    /// The scene's `name` in `summary.json` (`None`: no summary).
    pub(crate) scene_name: Option<&'a str>,
    pub(crate) csv: &'a Path,
    pub(crate) table: &'a BrdfTable,
    pub(crate) obs: &'a Observations,
    pub(crate) material: &'a MaterialOf<'a>,
}

/// A model's fits, before they are judged.
struct ModelFits {
    fits: Vec<FitResult>,
    /// The model, for the plot.
    model: Box<dyn Model>,
    /// The plot's title.
    title: &'static str,
    /// Where the material came from (microfacet models).
    material: Option<String>,
}

/// The JSON document's fields every model has.
fn base_doc(kind: ModelKind, csv: &Path, wavelength: Option<f64>) -> Value {
    json!({
        "model": kind.name(),
        "table": csv.display().to_string(),
        "wavelength_um": wavelength,
        "errors": "standard errors from the covariance (J^T J)^-1 of the weighted residuals at the minimum, multiplied by chi2/dof where that exceeds 1 (covariance_scaled); first-order propagation to the model's parameters",
        "cells": "every cell of the table with its brdf_stderr; a cell no photon left through gets 1/(N x projected solid angle), N the incidence's photons in summary.json, or is left out without it (cells_left_out)",
        "cell_average": "the model's BRDF averaged over each Carlson cell in projected solid angle (3 x 3 Gauss-Legendre in cos^2 theta and phi)",
        "verdicts": "fits[].reflectance[].ok: the model's reflectance within tolerance = max(1 % of the table's, 4 table_stderr) of the table's, the rule of the exports' read-back checks; warnings: every incidence that fails it, every fit that did not converge, every parameter whose standard error exceeds its value or is unknown",
        "version": env!("CARGO_PKG_VERSION"),
    })
}

/// Fit `kind` and make its files' bytes.
pub(crate) fn fit_one(
    ctx: &Context<'_>,
    kind: ModelKind,
    paths: Paths,
) -> Result<Fitted, NotFitted> {
    let cannot = |e: super::FitError| {
        NotFitted::Skipped(format!(
            "cannot fit: {}: --model {kind}: {e}",
            ctx.csv.display()
        ))
    };
    let mut doc = base_doc(kind, ctx.csv, ctx.req.wavelength);
    let m = match kind {
        ModelKind::Abg => fit_abg(ctx, &mut doc).map_err(cannot)?,
        ModelKind::Harvey => fit_harvey(ctx, &mut doc).map_err(cannot)?,
        ModelKind::Ggx | ModelKind::Beckmann => fit_microfacet(ctx, kind, &mut doc, &cannot)?,
    };
    let mut warnings = super::warnings(kind.name(), &m.fits);
    if matches!(kind, ModelKind::Ggx | ModelKind::Beckmann) {
        // Where a single-scattering model is below the table, say what it
        // cannot hold (summary.json's reflectance_by_bounces tells how much).
        for w in &mut warnings {
            if w.contains("the model's reflectance") && w.contains("% off") && w.contains(" is -") {
                w.push_str("; the model scatters once: the table's light scattered twice or more (summary.json: reflectance_by_bounces) is not in it");
            }
        }
    }
    let judgement = Judgement::of(kind.name(), &m.fits);
    doc["fits"] = serde_json::to_value(&m.fits)?;
    doc["warnings"] = json!(warnings);
    doc["verdict"] = json!(judgement.line());
    let png = super::plot::png(ctx.table, m.model.as_ref(), &m.fits, m.title)?;
    let text = serde_json::to_string_pretty(&doc)? + "\n";
    let mut files = Vec::new();
    if let Some(p) = &paths.opticstudio {
        let body = opticstudio(ctx, &m.fits, &judgement, &warnings);
        files.push((p.clone(), body.into_bytes()));
    }
    files.push((paths.png.clone(), png));
    files.push((paths.json.clone(), text.into_bytes()));
    Ok(Fitted {
        kind,
        paths,
        files,
        fits: m.fits,
        material: m.material,
        warnings,
        judgement,
    })
}

/// The text of OpticStudio's ABg rows of `fits`, named after the result
/// folder, else (a result given as values) after the scene's `name`, else
/// `roks`.
fn opticstudio(
    ctx: &Context<'_>,
    fits: &[FitResult],
    judgement: &Judgement,
    warnings: &[String],
) -> String {
    let req = ctx.req;
    let name = req.dir.file_name().map_or_else(
        || ctx.scene_name.unwrap_or("roks").to_owned(),
        |s| s.to_string_lossy().into_owned(),
    );
    let rows = abg::opticstudio_rows(fits);
    abg::opticstudio_text(
        &name,
        req.wavelength.unwrap_or(0.0),
        &rows,
        &judgement.line(),
        warnings,
    )
}

/// ABg fitted per incidence; its definition, OpticStudio's and FRED's
/// settings into `doc`.
fn fit_abg(ctx: &Context<'_>, doc: &mut Value) -> Result<ModelFits, super::FitError> {
    let fits = abg::fit(ctx.table, ctx.obs)?;
    doc["definition"] = json!(
        "BSDF = A / (B + |beta - beta0|^g) (1/sr); beta, beta0: the scattered and specular directions projected on the surface (lengths sin theta_s, sin theta_i); per incidence"
    );
    let rows = abg::opticstudio_rows(&fits);
    doc["opticstudio"] = json!({
        "dialog": "Setup > ABg Scatter Data Catalogs: one entry, Wave = the wavelength (0: no scaling), one row per angle of incidence (at most 10; interpolated in cosine space)",
        "wave_um": ctx.req.wavelength.unwrap_or(0.0),
        "rows": rows,
    });
    let near = super::nearest(&fits, 30.0);
    doc["fred"] = json!({
        "dialog": "Scatterers > Create a new scatter model > ABg scatter: Acoef, Bcoef, G; one set (FRED's ABg does not depend on incidence): the fit nearest 30 degrees; check Halt Incident Ray (the table holds all reflected light)",
        "abg": abg::fred(&fits),
    });
    fred_verdict(doc, &abg::Abg, &near.internal, ctx.table, ctx.obs);
    Ok(ModelFits {
        fits,
        model: Box::new(abg::Abg),
        title: "ABg",
        material: None,
    })
}

/// Harvey-Shack fitted per incidence; its definition and FRED's settings
/// into `doc`.
fn fit_harvey(ctx: &Context<'_>, doc: &mut Value) -> Result<ModelFits, super::FitError> {
    let fits = harvey::fit(ctx.table, ctx.obs)?;
    doc["definition"] = json!(
        "BSDF = b0 (1 + (|beta - beta0| / l)^2)^(s/2) (1/sr); beta, beta0 as for ABg; per incidence"
    );
    let f = super::nearest(&fits, 30.0);
    doc["fred"] = json!({
        "dialog": "Scatterers > Harvey-Shack: b0, L, S; one set: the fit nearest 30 degrees",
        "harvey_shack": {
            "b0": f.parameters[0].value,
            "L": f.parameters[1].value,
            "S": f.parameters[2].value,
            "from_theta_i_deg": f.theta_i_deg[0],
        },
    });
    fred_verdict(doc, &harvey::Harvey, &f.internal, ctx.table, ctx.obs);
    Ok(ModelFits {
        fits,
        model: Box::new(harvey::Harvey),
        title: "Harvey-Shack",
        material: None,
    })
}

/// GGX or Beckmann fitted jointly over every incidence with its material;
/// its definition and material into `doc`.
fn fit_microfacet(
    ctx: &Context<'_>,
    kind: ModelKind,
    doc: &mut Value,
    cannot: &dyn Fn(super::FitError) -> NotFitted,
) -> Result<ModelFits, NotFitted> {
    let req = ctx.req;
    let (material, source) = match (ctx.material)(kind) {
        Ok(m) => m,
        // --model all: without a material the microfacet
        // models are left out, and the ranking says why.
        Err(why) if req.model == ModelChoice::All && !req.material.given() => {
            return Err(NotFitted::Skipped(why));
        }
        Err(why) => return Err(NotFitted::Failed(RunError::Input(why))),
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
    let fit = super::microfacet::fit(&model, ctx.table, ctx.obs).map_err(cannot)?;
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
    doc["single_scattering"] = json!(
        "the model scatters once: reflectance[].difference (table - model) is mostly the light the surface scatters twice or more"
    );
    Ok(ModelFits {
        fits: vec![fit],
        model: Box::new(model),
        title: if distribution == Distribution::Ggx {
            "GGX"
        } else {
            "Beckmann"
        },
        material: Some(source),
    })
}

/// FRED takes one set of a per-incidence model for every incidence: that
/// set's reflectance at each of the table's incidences, judged, into
/// `doc["fred"]["verdict"]` (a line) and `["reflectance"]` (per incidence).
fn fred_verdict(
    doc: &mut Value,
    model: &dyn Model,
    q: &[f64],
    table: &BrdfTable,
    obs: &Observations,
) {
    let r = super::reflectance_of(model, q, table, obs);
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
