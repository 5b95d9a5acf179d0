//! The models of `roks fit-model --model all` judged and ranked: each
//! model's [`Judgement`], the ranking ([`rank`]), the advice in one line
//! ([`advice`]), the ranking table printed on stderr ([`ranking_lines`]) and
//! `fit_summary.json` ([`FitSummary`]).

use serde::Serialize;

use super::{FitResult, ReflectanceCompare, warnings};

/// How one model's fits did, in numbers: what `roks fit-model` prints as
/// its verdict and ranks the models by ([`Judgement::rank_key`]).
#[derive(Debug, Clone, Serialize)]
pub struct Judgement {
    /// The model (`--model`'s name).
    pub model: String,
    /// `Σ chi² / Σ dof` over the model's fits (for a per-incidence model,
    /// pooled over its incidences).
    pub chi2_per_dof: f64,
    /// Incidences judged.
    pub incidences: usize,
    /// Incidences whose reflectance verdict is `ok`.
    pub incidences_ok: usize,
    /// The largest relative reflectance error `model / table - 1` in
    /// magnitude (signed), and at which incidence (degrees).
    pub worst_reflectance_error: f64,
    /// The incidence (degrees) of [`worst_reflectance_error`](Self::worst_reflectance_error).
    pub worst_at_theta_i_deg: f64,
    /// Fits that did not converge.
    pub not_converged: usize,
    /// Parameters whose standard error exceeds their value or is unknown.
    pub undetermined_parameters: usize,
    /// Number of warnings ([`warnings`]).
    pub warnings: usize,
    /// No warnings: every incidence `ok`, every fit converged, every
    /// parameter determined.
    pub passes: bool,
}

impl Judgement {
    /// The judgement of model `name`'s `fits`.
    #[must_use]
    pub fn of(name: &str, fits: &[FitResult]) -> Self {
        let all: Vec<&ReflectanceCompare> = fits.iter().flat_map(|f| &f.reflectance).collect();
        let rel = |r: &ReflectanceCompare| r.model / r.table - 1.0;
        let worst = all
            .iter()
            .max_by(|a, b| rel(a).abs().total_cmp(&rel(b).abs()))
            .map_or((0.0, f64::NAN), |r| (rel(r), r.theta_i_deg));
        let (chi2, dof) = fits
            .iter()
            .fold((0.0, 0usize), |(c, d), f| (c + f.chi2, d + f.dof));
        let w = warnings(name, fits).len();
        Self {
            model: name.to_owned(),
            chi2_per_dof: chi2 / dof.max(1) as f64,
            incidences: all.len(),
            incidences_ok: all.iter().filter(|r| r.ok).count(),
            worst_reflectance_error: worst.0,
            worst_at_theta_i_deg: worst.1,
            not_converged: fits.iter().filter(|f| !f.converged).count(),
            undetermined_parameters: fits
                .iter()
                .flat_map(|f| &f.parameters)
                .filter(|p| p.stderr.is_nan() || p.stderr > p.value.abs())
                .count(),
            warnings: w,
            passes: w == 0,
        }
    }

    /// The order of the ranking, best first: models without warnings
    /// first, then fewer incidences off the table's reflectance, then
    /// fewer fits not converged, then the smaller `chi²/dof`.
    #[must_use]
    pub fn rank_key(&self) -> (bool, usize, usize, f64) {
        (
            !self.passes,
            self.incidences - self.incidences_ok,
            self.not_converged,
            self.chi2_per_dof,
        )
    }

    /// The one-line verdict: that every check passes, or what fails.
    #[must_use]
    pub fn line(&self) -> String {
        let worst = format!(
            "worst reflectance error {:+.2} % at theta_i {} deg",
            100.0 * self.worst_reflectance_error,
            self.worst_at_theta_i_deg
        );
        if self.passes {
            return format!(
                "{}: ok: every incidence's reflectance within max(1 %, 4 standard errors) of the table's ({worst}), converged, every parameter determined; chi2/dof {:.3}",
                self.model, self.chi2_per_dof
            );
        }
        let mut what = Vec::new();
        let off = self.incidences - self.incidences_ok;
        if off > 0 {
            what.push(format!(
                "{off} of {} incidences off the table's reflectance by more than max(1 %, 4 standard errors) ({worst})",
                self.incidences
            ));
        }
        if self.not_converged > 0 {
            what.push(format!(
                "{} fit{} not converged",
                self.not_converged,
                if self.not_converged == 1 { "" } else { "s" }
            ));
        }
        if self.undetermined_parameters > 0 {
            what.push(format!(
                "{} parameters undetermined (standard error above the value)",
                self.undetermined_parameters
            ));
        }
        format!(
            "{}: NOT OK: {}; chi2/dof {:.3}; {} warnings",
            self.model,
            what.join(", "),
            self.chi2_per_dof,
            self.warnings
        )
    }
}

/// Sort `judgements` best first by [`Judgement::rank_key`] (stable: equal
/// keys keep their order).
pub fn rank(judgements: &mut [Judgement]) {
    judgements.sort_by(|a, b| {
        let (x, y) = (a.rank_key(), b.rank_key());
        x.0.cmp(&y.0)
            .then(x.1.cmp(&y.1))
            .then(x.2.cmp(&y.2))
            .then(x.3.total_cmp(&y.3))
    });
}

/// `judgements` ranked ([`rank`]), best first.
#[must_use]
pub fn ranked(judgements: &[Judgement]) -> Vec<Judgement> {
    let mut j = judgements.to_vec();
    rank(&mut j);
    j
}

/// Which model to use, in one line, from the ranking (best first).
#[must_use]
pub fn advice(ranking: &[Judgement]) -> String {
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

/// The ranking as a table (a header line, one line per model, best
/// first) and the advice: the lines `roks fit-model --model all` prints.
#[must_use]
pub fn ranking_lines(ranking: &[Judgement]) -> Vec<String> {
    let mut lines = vec![format!(
        "{:>4} {:<9} {:>10} {:>14} {:>20} {:>9} {:>8}",
        "rank", "model", "chi2/dof", "incidences ok", "worst reflectance", "converged", "warnings"
    )];
    for (k, j) in ranking.iter().enumerate() {
        lines.push(format!(
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
        ));
    }
    lines.push(advice(ranking));
    lines
}

/// The rule of the ranking, in `fit_summary.json`.
const RULE: &str = "ranked: models with no warning first, then fewer incidences whose reflectance is off the table's by more than max(1 %, 4 standard errors), then fewer fits not converged, then the smaller chi2/dof (pooled over the model's fits: sum chi2 / sum dof)";

/// `fit_summary.json`: the models ranked, the advice, and the models not
/// fitted with why. The fields are in the order they are written
/// (alphabetical).
#[derive(Debug, Clone, Serialize)]
pub struct FitSummary {
    /// [`advice`] of the ranking.
    pub advice: String,
    /// The models not fitted, and why.
    pub not_fitted: Vec<NotFitted>,
    /// The models fitted, best first.
    pub ranking: Vec<Ranked>,
    /// How the models are ranked, in words.
    pub rule: String,
    /// The table fitted (`brdf.csv` of the result folder).
    pub table: String,
    /// The model to use: the best, if it passes every check.
    #[serde(rename = "use")]
    pub use_model: Option<String>,
    /// The roks version that wrote it.
    pub version: String,
}

/// A model of the ranking of [`FitSummary`]: its [`Judgement`], its JSON
/// file and its verdict line (fields alphabetical).
#[derive(Debug, Clone, Serialize)]
#[allow(missing_docs)]
pub struct Ranked {
    pub chi2_per_dof: f64,
    /// The model's JSON file, `None` if not written.
    pub file: Option<String>,
    pub incidences: usize,
    pub incidences_ok: usize,
    pub model: String,
    pub not_converged: usize,
    pub passes: bool,
    pub undetermined_parameters: usize,
    /// [`Judgement::line`].
    pub verdict: String,
    pub warnings: usize,
    pub worst_at_theta_i_deg: f64,
    pub worst_reflectance_error: f64,
}

/// A model `roks fit-model --model all` left out, and why.
#[derive(Debug, Clone, Serialize)]
pub struct NotFitted {
    /// The model's name.
    pub model: String,
    /// Why it was not fitted (the message it gives on its own).
    pub reason: String,
}

impl FitSummary {
    /// The summary of the models `judged` (each with its JSON file) fitted
    /// to `table`, and those `skipped` (name, why).
    #[must_use]
    pub fn new(table: &str, judged: &[(Judgement, String)], skipped: &[(&str, String)]) -> Self {
        let judgements: Vec<Judgement> = judged.iter().map(|j| j.0.clone()).collect();
        let ranking = ranked(&judgements);
        let file_of = |name: &str| {
            judged
                .iter()
                .find(|j| j.0.model == name)
                .map(|j| j.1.clone())
        };
        Self {
            advice: advice(&ranking),
            not_fitted: skipped
                .iter()
                .map(|(model, why)| NotFitted {
                    model: (*model).to_owned(),
                    reason: why.clone(),
                })
                .collect(),
            ranking: ranking
                .iter()
                .map(|j| Ranked {
                    chi2_per_dof: j.chi2_per_dof,
                    file: file_of(&j.model),
                    incidences: j.incidences,
                    incidences_ok: j.incidences_ok,
                    model: j.model.clone(),
                    not_converged: j.not_converged,
                    passes: j.passes,
                    undetermined_parameters: j.undetermined_parameters,
                    verdict: j.line(),
                    warnings: j.warnings,
                    worst_at_theta_i_deg: j.worst_at_theta_i_deg,
                    worst_reflectance_error: j.worst_reflectance_error,
                })
                .collect(),
            rule: RULE.to_owned(),
            table: table.to_owned(),
            use_model: ranking
                .first()
                .filter(|j| j.passes)
                .map(|j| j.model.clone()),
            version: env!("CARGO_PKG_VERSION").to_owned(),
        }
    }

    /// The text of `fit_summary.json` (pretty-printed, a final newline).
    ///
    /// # Errors
    /// None in practice (serialising plain values).
    pub fn to_text(&self) -> serde_json::Result<String> {
        Ok(serde_json::to_string_pretty(self)? + "\n")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn judgement(model: &str, passes: bool, chi2: f64, worst_at: f64) -> Judgement {
        Judgement {
            model: model.into(),
            chi2_per_dof: chi2,
            incidences: 3,
            incidences_ok: if passes { 3 } else { 1 },
            worst_reflectance_error: -0.0123,
            worst_at_theta_i_deg: worst_at,
            not_converged: 0,
            undetermined_parameters: usize::from(!passes),
            warnings: if passes { 0 } else { 2 },
            passes,
        }
    }

    /// `fit_summary.json` as the struct writes it is byte for byte the
    /// document the command built before with `json!` (an untyped map,
    /// keys sorted; each ranked entry the judgement's fields with `file`
    /// and `verdict` added), a NaN incidence included.
    #[test]
    fn the_summary_is_the_untyped_document_byte_for_byte() {
        let judged = vec![
            (
                judgement("abg", false, 2.5, 30.0),
                "r/fit_abg.json".to_owned(),
            ),
            (
                judgement("ggx", true, 1.1, f64::NAN),
                "r/fit_ggx.json".to_owned(),
            ),
        ];
        let skipped = [("beckmann", "cannot fit: why".to_owned())];
        let typed = FitSummary::new("r/brdf.csv", &judged, &skipped)
            .to_text()
            .unwrap();
        let mut ranking: Vec<Judgement> = judged.iter().map(|j| j.0.clone()).collect();
        rank(&mut ranking);
        let untyped = json!({
            "table": "r/brdf.csv",
            "rule": RULE,
            "use": ranking.first().filter(|j| j.passes).map(|j| j.model.clone()),
            "advice": advice(&ranking),
            "ranking": ranking
                .iter()
                .map(|j| {
                    let mut v = serde_json::to_value(j).unwrap();
                    v["file"] = json!(format!("r/fit_{}.json", j.model));
                    v["verdict"] = json!(j.line());
                    v
                })
                .collect::<Vec<_>>(),
            "not_fitted": [{"model": "beckmann", "reason": "cannot fit: why"}],
            "version": env!("CARGO_PKG_VERSION"),
        });
        let untyped = serde_json::to_string_pretty(&untyped).unwrap() + "\n";
        assert_eq!(typed, untyped);
        assert!(typed.contains("\"use\": \"ggx\""), "{typed}");
        assert!(typed.contains("\"worst_at_theta_i_deg\": null"), "{typed}");
    }
}
