//! `roks fit-model`: an analytic BRDF model fitted to the table of a `roks
//! brdf` result folder ([`crate::fit_model`]), written as JSON with a plot
//! and, for ABg, the text of OpticStudio's ABg data dialog.
//!
//! Files (default `RESULT_DIR/fit_<model>.json`; `--out FILE` moves them
//! all): `FILE` (JSON), `FILE` with the extension `.png` (the plot) and, for
//! ABg, `FILE` with `_opticstudio.txt` in place of its extension. Each is
//! written atomically (a temporary file renamed over it).

use std::path::{Path, PathBuf};

use clap::Args;
use serde_json::json;

use super::Failure;
use super::common::{FileKind, check_out_file, write_file};
use super::parse::number;
use crate::fit_model::microfacet::{Distribution, Microfacet};
use crate::fit_model::{self, FitResult, ModelKind, abg, harvey, observations};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::optics::material::{Reflectance, ReflectanceError};

/// The options of `roks fit-model`.
#[derive(Args, Debug)]
pub struct FitModelArgs {
    /// Result folder of `roks brdf` (with brdf.csv and summary.json).
    pub dir: PathBuf,
    /// The model: abg, harvey (per incidence), ggx or beckmann (one
    /// roughness for all incidences, with Smith shadowing and the material's
    /// Fresnel factor).
    #[arg(long, ignore_case = true, hide_possible_values = true)]
    pub model: ModelKind,
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
            a.model,
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

/// Run `roks fit-model`.
///
/// # Errors
/// Bad input (the result folder, its table or summary, options), a fit
/// that cannot be made, or a failed write.
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
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| a.dir.join(format!("fit_{}.json", a.model)));
    let png_path = beside(&out, ".png");
    let abg_path = beside(&out, "_opticstudio.txt");
    let inputs = [csv.clone(), summary_path.clone()];
    for (p, kind) in [
        (&out, FileKind::FitJson),
        (&png_path, FileKind::Png),
        (&abg_path, FileKind::FitText),
    ] {
        check_out_file(p, &inputs, kind, a.force)?;
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
    if a.model == ModelKind::Abg || a.model == ModelKind::Harvey {
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
    let fail =
        |e: fit_model::FitError| input(format!("{}: --model {}: {e}", csv.display(), a.model));
    let mut doc = json!({
        "model": a.model.name(),
        "table": csv.display().to_string(),
        "wavelength_um": a.wavelength,
        "errors": "standard errors from the covariance (J^T J)^-1 of the weighted residuals at the minimum, multiplied by chi2/dof where that exceeds 1 (covariance_scaled); first-order propagation to the model's parameters",
        "cells": "every cell of the table with its brdf_stderr; a cell no photon left through gets 1/(N x projected solid angle), N the incidence's photons in summary.json, or is left out without it (cells_left_out)",
        "cell_average": "the model's BRDF averaged over each Carlson cell in projected solid angle (3 x 3 Gauss-Legendre in cos^2 theta and phi)",
        "version": env!("CARGO_PKG_VERSION"),
    });
    let title;
    let (fits, plot_model): (Vec<FitResult>, Box<dyn fit_model::Model>) = match a.model {
        ModelKind::Abg => {
            let fits = abg::fit(table, &obs).map_err(fail)?;
            doc["definition"] = json!(
                "BSDF = A / (B + |beta - beta0|^g) (1/sr); beta, beta0: the scattered and specular directions projected on the surface (lengths sin theta_s, sin theta_i); per incidence"
            );
            let rows = abg::opticstudio_rows(&fits);
            doc["opticstudio"] = json!({
                "dialog": "Setup > ABg Scatter Data Catalogs: one entry, Wave = the wavelength (0: no scaling), one row per angle of incidence (at most 10; interpolated in cosine space)",
                "wave_um": a.wavelength.unwrap_or(0.0),
                "rows": rows,
            });
            doc["fred"] = json!({
                "dialog": "Scatterers > Create a new scatter model > ABg scatter: Acoef, Bcoef, G; one set (FRED's ABg does not depend on incidence): the fit nearest 30 degrees; check Halt Incident Ray (the table holds all reflected light)",
                "abg": abg::fred(&fits),
            });
            title = "ABg".to_owned();
            (fits, Box::new(abg::Abg))
        }
        ModelKind::Harvey => {
            let fits = harvey::fit(table, &obs).map_err(fail)?;
            doc["definition"] = json!(
                "BSDF = b0 (1 + (|beta - beta0| / l)^2)^(s/2) (1/sr); beta, beta0 as for ABg; per incidence"
            );
            let near30 = (!fits.is_empty())
                .then(|| fit_model::nearest(&fits, 30.0))
                .map(|f| {
                    json!({
                        "b0": f.parameters[0].value,
                        "L": f.parameters[1].value,
                        "S": f.parameters[2].value,
                        "from_theta_i_deg": f.theta_i_deg[0],
                    })
                });
            doc["fred"] = json!({
                "dialog": "Scatterers > Harvey-Shack: b0, L, S; one set: the fit nearest 30 degrees",
                "harvey_shack": near30,
            });
            title = "Harvey-Shack".to_owned();
            (fits, Box::new(harvey::Harvey))
        }
        ModelKind::Ggx | ModelKind::Beckmann => {
            let (material, source) = material(&a, scene.as_deref(), &wavelengths, lane)?;
            let distribution = if a.model == ModelKind::Ggx {
                Distribution::Ggx
            } else {
                Distribution::Beckmann
            };
            let model = Microfacet {
                distribution,
                material,
            };
            let fit = fit_model::microfacet::fit(&model, table, &obs).map_err(fail)?;
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
            title = if distribution == Distribution::Ggx {
                "GGX"
            } else {
                "Beckmann"
            }
            .to_owned();
            (vec![fit], Box::new(model))
        }
    };
    doc["fits"] = serde_json::to_value(&fits).map_err(anyhow::Error::from)?;
    let png = fit_model::plot::png(table, plot_model.as_ref(), &fits, &title)?;
    let text = serde_json::to_string_pretty(&doc).map_err(anyhow::Error::from)? + "\n";
    // All or none, for an interrupt.
    let commit = crate::interrupt::commit();
    if a.model == ModelKind::Abg {
        let name = a
            .dir
            .file_name()
            .map_or_else(|| "roks".into(), |s| s.to_string_lossy().into_owned());
        let rows = abg::opticstudio_rows(&fits);
        write_file(
            &abg_path,
            abg::opticstudio_text(&name, a.wavelength.unwrap_or(0.0), &rows).as_bytes(),
        )?;
    }
    write_file(&png_path, &png)?;
    write_file(&out, text.as_bytes())?;
    drop(commit);
    if !a.quiet {
        for f in &fits {
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
        if let Some(m) = doc.get("material") {
            eprintln!("material: {}", m.as_str().unwrap_or_default());
        }
        eprintln!(
            "wrote {}, {}{}",
            out.display(),
            png_path.display(),
            if a.model == ModelKind::Abg {
                format!(", {}", abg_path.display())
            } else {
                String::new()
            }
        );
    }
    Ok(())
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
