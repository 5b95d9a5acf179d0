//! A fit read back from its JSON document (`fit_<model>.json` of `roks
//! fit-model`) and evaluated again at a table's cells: the model of the
//! document's `model`, its parameters per fitted incidence (`fits[]`), and
//! for GGX and Beckmann the material the fit used, rebuilt as the fit built
//! it ([`material_again`]). The report draws it over its table
//! (`crate::report`).
//!
//! Every value comes from [`CellRule::model_average`], the one evaluation
//! of a model over a Carlson cell the fit itself compares with the table,
//! at the internal parameters of the document's values
//! ([`Model::internal`]; `ln` of `exp`, so within a few ulps of the fit's
//! own). The in-plane values ([`SavedFit::inplane`]) average the same
//! [`Model::brdf`] over the bins of `inplane.csv`'s goniometer detector.

use glam::DVec3;
use serde_json::Value;

use super::material::{MaterialOptions, material};
use super::microfacet::{Distribution, Microfacet};
use super::{CellRule, Model, ModelKind, abg, harvey};
use crate::optics::material::Reflectance;
use crate::tally::{CarlsonGrid, InPlaneTally};

/// A fit read back from its document.
pub struct SavedFit {
    /// The model.
    pub kind: ModelKind,
    /// The wavelength (µm) of a spectral table's fit (`wavelength_um`).
    pub wavelength_um: Option<f64>,
    /// The model, with its material for GGX and Beckmann.
    pub model: Box<dyn Model>,
    /// Per fitted incidence, in the document's order: its angle (degrees)
    /// and the internal parameters of the fit that covers it (ABg and
    /// Harvey-Shack: its own; GGX and Beckmann: the one set of every
    /// incidence).
    pub sets: Vec<(f64, Vec<f64>)>,
}

impl std::fmt::Debug for SavedFit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SavedFit")
            .field("kind", &self.kind)
            .field("wavelength_um", &self.wavelength_um)
            .field("sets", &self.sets)
            .finish_non_exhaustive()
    }
}

impl SavedFit {
    /// The fit of the document `doc`; `material(words, kind)` gives the
    /// material of a GGX or Beckmann fit from the document's `material`
    /// (the words the fit wrote, [`material_again`]).
    ///
    /// # Errors
    /// In words: a document that is not a fit of roks's models (no known
    /// `model`, `fits` without incidences or with other parameters, values
    /// that are not finite), or the material's error.
    pub fn from_doc(
        doc: &Value,
        material: &dyn Fn(&str, ModelKind) -> Result<Reflectance, String>,
    ) -> Result<Self, String> {
        let name = doc["model"].as_str().unwrap_or("");
        let kind = [
            ModelKind::Abg,
            ModelKind::Harvey,
            ModelKind::Ggx,
            ModelKind::Beckmann,
        ]
        .into_iter()
        .find(|k| k.name() == name)
        .ok_or_else(|| format!("model {name:?} is not one of roks fit-model's"))?;
        let model: Box<dyn Model> = match kind {
            ModelKind::Abg => Box::new(abg::Abg),
            ModelKind::Harvey => Box::new(harvey::Harvey),
            ModelKind::Ggx | ModelKind::Beckmann => {
                let words = doc["material"]
                    .as_str()
                    .ok_or("the document names no material")?;
                Box::new(Microfacet {
                    distribution: if kind == ModelKind::Ggx {
                        Distribution::Ggx
                    } else {
                        Distribution::Beckmann
                    },
                    material: material(words, kind)?,
                })
            }
        };
        let fits = doc["fits"].as_array().ok_or("the document has no fits")?;
        let mut sets = Vec::new();
        for f in fits {
            let params = f["parameters"]
                .as_array()
                .ok_or("a fit has no parameters")?;
            let names: Vec<&str> = params.iter().filter_map(|p| p["name"].as_str()).collect();
            if names != model.names() {
                return Err(format!(
                    "parameters {names:?}, not {:?} of {kind}",
                    model.names()
                ));
            }
            let values: Vec<f64> = params.iter().filter_map(|p| p["value"].as_f64()).collect();
            if values.len() != names.len() || values.iter().any(|v| !v.is_finite()) {
                return Err("a parameter is not a finite number".into());
            }
            let q = model.internal(&values);
            let thetas = f["theta_i_deg"]
                .as_array()
                .ok_or("a fit has no incidences")?;
            for t in thetas {
                let t = t.as_f64().ok_or("an incidence is not a number")?;
                sets.push((t, q.clone()));
            }
        }
        if sets.is_empty() {
            return Err("the document fits no incidence".into());
        }
        Ok(Self {
            kind,
            wavelength_um: doc["wavelength_um"].as_f64(),
            model,
            sets,
        })
    }

    /// The model's BRDF (sr⁻¹) in every cell of `grid` (flat order, as
    /// `brdf.csv`'s rows) for set `set` at light azimuth `phi_i_deg`
    /// (degrees): each cell's average, as the fit compares it with the
    /// table's ([`CellRule::model_average`], the rule [`super::observations`]
    /// builds).
    ///
    /// # Panics
    /// If `set` is not one of [`SavedFit::sets`].
    #[must_use]
    pub fn cells(&self, set: usize, grid: &CarlsonGrid, phi_i_deg: f64) -> Vec<f64> {
        let (theta_deg, q) = &self.sets[set];
        let (theta_i, phi_i) = (theta_deg.to_radians(), phi_i_deg.to_radians());
        (0..grid.n_cells())
            .map(|flat| {
                CellRule::new(grid, flat, phi_i).model_average(self.model.as_ref(), q, theta_i)
            })
            .collect()
    }

    /// The model's BRDF (sr⁻¹) averaged over every bin of the in-plane
    /// detector `tally` (`inplane.csv`'s rows of one incidence) for set
    /// `set` ([`inplane_average`]).
    ///
    /// # Panics
    /// If `set` is not one of [`SavedFit::sets`].
    #[must_use]
    pub fn inplane(&self, set: usize, tally: &InPlaneTally) -> Vec<f64> {
        let (theta_deg, q) = &self.sets[set];
        (0..tally.n_bins())
            .map(|bin| inplane_average(self.model.as_ref(), q, theta_deg.to_radians(), tally, bin))
            .collect()
    }
}

/// Points of the 4-point Gauss-Legendre rule on `[0, 1]` and their
/// weights: an even rule, with no point at the middle of the interval.
const GL4: [(f64, f64); 4] = [
    (0.069_431_844_202_973_71, 0.173_927_422_568_726_9),
    (0.330_009_478_207_571_9, 0.326_072_577_431_273_1),
    (0.669_990_521_792_428_1, 0.326_072_577_431_273_1),
    (0.930_568_155_797_026_3, 0.173_927_422_568_726_9),
];

/// The average of `model`'s BRDF (sr⁻¹) at internal parameters `q` and
/// incidence `theta_i` (radians) over bin `bin` of the in-plane detector
/// `tally` (`theta_p` between the bin's edges, `|psi|` up to the half
/// width; see [`crate::tally::inplane`]), uniform in projected solid angle
/// as the detector counts it: 4 x 4 Gauss-Legendre in `(theta_p, psi)`
/// with the weight `cos² psi cos theta_p` of `cos theta d omega`,
/// normalised. The rule has no point at the bin's centre, where the
/// specular direction of a whole-degree incidence falls: a model that
/// peaks there without bound (ABg with `B` near 0) is averaged, not
/// taken at its pole. Directions in the model's frame: the light on the
/// `+x` side, the specular side `-x`.
///
/// # Panics
/// If `bin >= tally.n_bins()`.
#[must_use]
pub fn inplane_average(
    model: &dyn Model,
    q: &[f64],
    theta_i: f64,
    tally: &InPlaneTally,
    bin: usize,
) -> f64 {
    let (lo, hi) = tally.edges_deg(bin);
    let (lo, hi) = (lo.to_radians(), hi.to_radians());
    let w = tally.half_width_deg().to_radians();
    let (mut sum, mut weight) = (0.0, 0.0);
    for &(u, wu) in &GL4 {
        let tp = lo + u * (hi - lo);
        for &(v, wv) in &GL4 {
            let psi = -w + v * 2.0 * w;
            let c = psi.cos();
            let x = wu * wv * c * c * tp.cos();
            let d = DVec3::new(-c * tp.sin(), -psi.sin(), c * tp.cos());
            sum += x * model.brdf(q, theta_i, d);
            weight += x;
        }
    }
    sum / weight
}

/// The material options whose words [`material`] wrote (`--reflectance R`,
/// `--n N --k K`; `scene ...`: none, the scene's substrate), `None` for
/// other words.
#[must_use]
pub fn options_of(words: &str) -> Option<MaterialOptions> {
    let number = |s: &str| s.parse::<f64>().ok();
    if let Some(r) = words.strip_prefix("--reflectance ") {
        return Some(MaterialOptions {
            reflectance: Some(number(r)?),
            ..MaterialOptions::default()
        });
    }
    if let Some(rest) = words.strip_prefix("--n ") {
        let (n, k) = rest.split_once(" --k ")?;
        return Some(MaterialOptions {
            n: Some(number(n)?),
            k: Some(number(k)?),
            ..MaterialOptions::default()
        });
    }
    words.starts_with("scene ").then(MaterialOptions::default)
}

/// The material of a GGX or Beckmann fit (`kind`) read back from the words
/// `words` its document holds: rebuilt by [`material`] as `roks fit-model`
/// built it (from the options the words name, or from the substrate of
/// `scene`, the scene named in the folder `dir`'s `summary.json`, at lane
/// `lane` of `wavelengths`), and kept only when [`material`] gives the same
/// words again.
///
/// # Errors
/// In words: words [`material`] does not write, a scene that does not load,
/// or one whose substrate is not the fit's any more.
pub fn material_again(
    words: &str,
    dir: &std::path::Path,
    kind: ModelKind,
    scene: Option<&str>,
    wavelengths: &[f64],
    lane: usize,
) -> Result<Reflectance, String> {
    let options =
        options_of(words).ok_or_else(|| format!("material {words:?}: not rebuilt from words"))?;
    let (m, again) = material(&options, dir, kind, scene, wavelengths, lane)?;
    if again != words {
        return Err(format!(
            "its material was {words:?}, the scene gives {again:?} now"
        ));
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every model's internal parameters are the inverse of its
    /// parameters; the words of the options give the options back.
    #[test]
    fn documents_give_back_the_fit() {
        let q = [0.02f64.ln(), 1e-3f64.ln(), 1.7];
        for m in [&abg::Abg as &dyn Model, &harvey::Harvey] {
            let values: Vec<f64> = m.physical(&q).iter().map(|p| p.0).collect();
            let back = m.internal(&values);
            for (a, b) in back.iter().zip(q) {
                assert!((a - b).abs() <= 4.0 * f64::EPSILON * b.abs(), "{a} {b}");
            }
        }
        for o in [
            MaterialOptions {
                reflectance: Some(0.83),
                ..MaterialOptions::default()
            },
            MaterialOptions {
                n: Some(0.183_1),
                k: Some(3.43),
                ..MaterialOptions::default()
            },
        ] {
            let (_, words) =
                material(&o, std::path::Path::new("."), ModelKind::Ggx, None, &[], 0).unwrap();
            assert_eq!(options_of(&words), Some(o), "{words}");
        }
        assert_eq!(
            options_of("scene s.toml, material `m` of the surface: constant reflectance 0.5"),
            Some(MaterialOptions::default())
        );
        assert_eq!(options_of("--n x --k 1"), None);
    }

    /// The in-plane rule: a constant model averages to itself, and its
    /// weights integrate the bin's projected solid angle (the closed form
    /// of [`InPlaneTally::projected_solid_angle`]).
    #[test]
    fn the_inplane_rule_is_the_detectors() {
        let tally = InPlaneTally::new(1.0, 2.5, 0.0).unwrap();
        // Harvey-Shack with s = 0 is the constant b0.
        let q = [0.37f64.ln(), 0.1f64.ln(), 0.0];
        for bin in [0, 45, 90, 179, 180] {
            let v = inplane_average(&harvey::Harvey, &q, 0.4, &tally, bin);
            assert!((v - 0.37).abs() < 1e-15, "{bin}: {v}");
            let (lo, hi) = tally.edges_deg(bin);
            let (lo, hi) = (lo.to_radians(), hi.to_radians());
            let w = 2.5f64.to_radians();
            let mut s = 0.0;
            for &(u, wu) in &GL4 {
                for &(v, wv) in &GL4 {
                    let (tp, psi) = (lo + u * (hi - lo), -w + v * 2.0 * w);
                    s += wu * wv * psi.cos().powi(2) * tp.cos();
                }
            }
            s *= (hi - lo) * 2.0 * w;
            let exact = tally.projected_solid_angle(bin);
            assert!((s / exact - 1.0).abs() < 1e-9, "{bin}: {s} {exact}");
        }
        let sum: f64 = GL4.iter().map(|p| p.1).sum();
        assert!((sum - 1.0).abs() < 1e-15);
        // Exact for x^7 on [0, 1]: 1/8.
        let x7: f64 = GL4.iter().map(|&(x, w)| w * x.powi(7)).sum();
        assert!((x7 - 0.125).abs() < 1e-15, "{x7}");
    }
}
