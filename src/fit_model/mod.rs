//! Analytic BRDF models fitted to a tabulated BRDF (`roks fit-model`): the
//! scatter models of stray-light programs, ABg ([`abg`]) and Harvey-Shack
//! ([`harvey`]), fitted per incidence, and the microfacet models of
//! renderers, GGX and Beckmann with Smith shadowing-masking and the
//! material's Fresnel factor ([`microfacet`]), fitted jointly over every
//! incidence.
//!
//! # The fit
//!
//! Weighted least squares: the parameters `p` minimise
//! `chi² = Σ_c ((m_c(p) - f_c) / s_c)²` over the table's cells `c`, where
//! `f_c` is the cell's `brdf` (sr⁻¹), `s_c` its `brdf_stderr` and `m_c(p)`
//! the model's BRDF **averaged over the cell** in projected solid angle
//! (what the table's cell holds): a 3 x 3 Gauss-Legendre rule in
//! `(cos² theta, phi)` over the cell's edges, uniform in projected solid
//! angle ([`CellRule`]). A cell that no photon left through has `s_c = 0`;
//! it gets the standard error one photon of weight 1 would give,
//! `1 / (N proj_c)` (`N` the incidence's photons, from `summary.json`), or is
//! left out when the photons are unknown (counted in the result,
//! [`FitResult::cells_left_out`]).
//!
//! The minimiser is Levenberg-Marquardt (the `levenberg-marquardt` crate on
//! `nalgebra`) on internal parameters (logarithms of the positive ones),
//! with a forward-difference Jacobian, started from the best point of a
//! coarse grid over the shape parameters on which every linear amplitude
//! (ABg's `A`, Harvey's `b0`) is solved exactly. The covariance of the
//! internal parameters is `(Jᵀ J)⁻¹` at the minimum (`J` the Jacobian of the
//! weighted residuals), multiplied by `chi²/dof` when that exceeds 1
//! ([`FitResult::covariance_scaled`] says so): the standard errors then
//! include the misfit of the model. Parameters and their standard errors
//! are reported in the models' own units, propagated to first order
//! (`se(exp q) = exp(q) se(q)`).

pub mod abg;
pub mod harvey;
pub mod material;
pub mod microfacet;
pub mod one;
pub mod plot;
pub mod ranking;
pub mod run;
pub mod saved;

pub use ranking::{Judgement, rank};

use glam::DVec3;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};
use serde::Serialize;

use crate::export::resample::ReflectanceCheck;
use crate::optics::brdf_table::BrdfTable;
use crate::tally::CarlsonGrid;

/// The models `roks fit-model` fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelKind {
    /// ABg, per incidence ([`abg`]).
    Abg,
    /// Harvey-Shack, per incidence ([`harvey`]).
    Harvey,
    /// GGX (Trowbridge-Reitz) microfacet with Smith shadowing, joint ([`microfacet`]).
    Ggx,
    /// Beckmann microfacet with Smith shadowing, joint ([`microfacet`]).
    Beckmann,
}

impl ModelKind {
    /// The model's name in file names and `--model`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Abg => "abg",
            Self::Harvey => "harvey",
            Self::Ggx => "ggx",
            Self::Beckmann => "beckmann",
        }
    }
}

impl std::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Points of the 3-point Gauss-Legendre rule on `[0, 1]` and their weights.
const GL3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

/// The directions (local frame of the incidence: light in the x-z plane on
/// the `+x` side) at which a cell's average is taken, and their weights
/// (summing to 1): 3 x 3 Gauss-Legendre in `cos² theta` and `phi` over the
/// cell, i.e. uniform in projected solid angle.
#[derive(Debug, Clone)]
pub struct CellRule {
    /// Unit directions with `z > 0`.
    pub dirs: [DVec3; 9],
    /// Weights, summing to 1.
    pub weights: [f64; 9],
}

impl CellRule {
    /// The rule of flat cell `flat` of `grid` seen from light azimuth
    /// `phi_i` (radians; the cell's absolute azimuths less `phi_i`).
    #[must_use]
    pub fn new(grid: &CarlsonGrid, flat: usize, phi_i: f64) -> Self {
        let (band, cell) = grid.band_cell(flat);
        let (mu_bot, mu_top) = grid.mu_edges(band);
        let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
        let (m2_lo, m2_hi) = (mu_bot * mu_bot, mu_top * mu_top);
        let mut dirs = [DVec3::Z; 9];
        let mut weights = [0.0; 9];
        for (a, &(u, wu)) in GL3.iter().enumerate() {
            let mu2 = m2_lo + u * (m2_hi - m2_lo);
            let (mu, s) = (mu2.sqrt(), (1.0 - mu2).max(0.0).sqrt());
            for (b, &(v, wv)) in GL3.iter().enumerate() {
                let phi = phi_lo + v * (phi_hi - phi_lo) - phi_i;
                let (sp, cp) = phi.sin_cos();
                dirs[3 * a + b] = DVec3::new(s * cp, s * sp, mu);
                weights[3 * a + b] = wu * wv;
            }
        }
        Self { dirs, weights }
    }

    /// The average of `f` over the cell.
    pub fn average(&self, f: impl Fn(DVec3) -> f64) -> f64 {
        self.dirs
            .iter()
            .zip(&self.weights)
            .map(|(d, w)| w * f(*d))
            .sum()
    }

    /// The cell average of `model`'s BRDF (sr⁻¹) at internal parameters
    /// `q` for incidence `theta_i` (radians): what a fit compares with the
    /// table's cell, the one evaluation of a model over a cell (the fit,
    /// its plot and the report's overlay, [`saved`], all take it).
    pub fn model_average(&self, model: &dyn Model, q: &[f64], theta_i: f64) -> f64 {
        self.average(|d| model.brdf(q, theta_i, d))
    }
}

/// One cell of the table as the fit sees it.
#[derive(Debug, Clone)]
pub struct Observation {
    /// Index of its incidence in the table.
    pub incidence: usize,
    /// Incidence polar angle (radians).
    pub theta_i: f64,
    /// Flat Carlson cell.
    pub flat: usize,
    /// The table's BRDF (sr⁻¹).
    pub brdf: f64,
    /// Its standard error (sr⁻¹), > 0.
    pub stderr: f64,
    /// The cell's quadrature rule in the incidence's local frame.
    pub rule: CellRule,
    /// Projected solid angle of the cell (sr).
    pub proj: f64,
}

/// The cells of a table to fit, and how many were left out for want of a
/// standard error.
#[derive(Debug, Clone)]
pub struct Observations {
    /// The cells, incidence by incidence, flat cells in order.
    pub cells: Vec<Observation>,
    /// Cells with `brdf_stderr = 0` and no photon count to bound it.
    pub left_out: usize,
}

/// The cells of `table` with their standard errors; `photons[i]` (when
/// known) the photons of incidence `i`, which bound the standard error of a
/// cell no photon left through (see the [module documentation](self)).
#[must_use]
pub fn observations(table: &BrdfTable, photons: Option<&[u64]>) -> Observations {
    let grid = table.grid();
    let mut cells = Vec::new();
    let mut left_out = 0;
    for (i, theta_deg) in table.thetas_deg().iter().enumerate() {
        let phi_i = table.incidence(i).phi_i_deg.to_radians();
        let fractions = table.fractions(i);
        let errors = table.fraction_stderrs(i);
        for flat in 0..grid.n_cells() {
            let (band, cell) = grid.band_cell(flat);
            let proj = grid.projected_solid_angle(band, cell);
            let mut se = errors[flat];
            if se <= 0.0 {
                match photons.and_then(|p| p.get(i)) {
                    Some(&n) if n > 0 => se = 1.0 / n as f64,
                    _ => {
                        left_out += 1;
                        continue;
                    }
                }
            }
            cells.push(Observation {
                incidence: i,
                theta_i: theta_deg.to_radians(),
                flat,
                brdf: fractions[flat] / proj,
                stderr: se / proj,
                rule: CellRule::new(grid, flat, phi_i),
                proj,
            });
        }
    }
    Observations { cells, left_out }
}

/// A model as the fitter sees it: internal parameters `q` (logarithms of
/// the positive ones), the BRDF (sr⁻¹) at an outgoing direction for
/// incidence `theta_i` (radians), and the model's parameters from `q`.
pub trait Model: Sync {
    /// Names of the model's parameters, in the order of [`Model::physical`].
    fn names(&self) -> &'static [&'static str];
    /// The BRDF (sr⁻¹) for internal parameters `q` at incidence `theta_i`
    /// (radians) towards unit direction `out` (local frame, `z > 0`).
    fn brdf(&self, q: &[f64], theta_i: f64, out: DVec3) -> f64;
    /// The model's parameters from the internal ones, and the derivative of
    /// each with respect to its internal parameter (for the errors).
    fn physical(&self, q: &[f64]) -> Vec<(f64, f64)>;
    /// The internal parameters of the model's parameters `values` (in the
    /// order of [`Model::names`]): the inverse of [`Model::physical`], for
    /// a fit read back from its JSON ([`saved`]).
    fn internal(&self, values: &[f64]) -> Vec<f64>;
}

/// The cell average of `model` at `q` for cell `o`.
fn cell_model(model: &dyn Model, q: &[f64], o: &Observation) -> f64 {
    o.rule.model_average(model, q, o.theta_i)
}

/// Levenberg-Marquardt's view of the weighted residuals.
struct Problem<'a> {
    model: &'a dyn Model,
    cells: &'a [&'a Observation],
    q: DVector<f64>,
}

impl Problem<'_> {
    fn residuals_at(&self, q: &[f64]) -> DVector<f64> {
        DVector::from_iterator(
            self.cells.len(),
            self.cells
                .iter()
                .map(|o| (cell_model(self.model, q, o) - o.brdf) / o.stderr),
        )
    }

    fn jacobian_at(&self, q: &[f64]) -> DMatrix<f64> {
        let r0 = self.residuals_at(q);
        let mut j = DMatrix::zeros(self.cells.len(), q.len());
        for k in 0..q.len() {
            let h = 1e-7 * q[k].abs().max(1.0);
            let mut qh = q.to_vec();
            qh[k] += h;
            let rh = self.residuals_at(&qh);
            j.set_column(k, &((rh - &r0) / h));
        }
        j
    }
}

/// The residual of a cell where the model is not a finite number at a trial
/// point: far above any real misfit (its square, summed over a million
/// cells, stays finite), so such a step is always rejected.
const OVERFLOW_RESIDUAL: f64 = 1e100;

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.q.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.q.clone()
    }

    /// Residuals at a trial point. Where the model overflows there (a step
    /// far out in `ln b0` or `ln l`, say), the residual is a finite penalty,
    /// [`OVERFLOW_RESIDUAL`], so that the step is rejected and the damping
    /// raised, instead of ending the whole fit (the crate ends it on `None`).
    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.residuals_at(self.q.as_slice());
        Some(r.map(|x| if x.is_finite() { x } else { OVERFLOW_RESIDUAL }))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let j = self.jacobian_at(self.q.as_slice());
        j.iter().all(|x| x.is_finite()).then_some(j)
    }
}

/// A fitted parameter: its value and standard error in the model's units.
#[derive(Debug, Clone, Serialize)]
pub struct Parameter {
    /// Name, as in the model's definition.
    pub name: String,
    /// Fitted value.
    pub value: f64,
    /// Standard error (see [`FitResult::covariance_scaled`]); NaN, written
    /// `null`, when the fit's covariance is singular (undetermined).
    pub stderr: f64,
}

/// The standard error of a physical parameter whose derivative with
/// respect to the fitted one is `d`, from the fitted one's variance `var`:
/// `|d| sqrt(var)`, and NaN (written `null`: undetermined) when the
/// covariance is singular (`var` NaN), never 0 for an unknown error.
fn standard_error(d: f64, var: f64) -> f64 {
    if var.is_nan() {
        return f64::NAN;
    }
    d.abs() * var.max(0.0).sqrt()
}

/// One cell's residual in standard errors, and where it is.
#[derive(Debug, Clone, Serialize)]
pub struct Residual {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
    /// Carlson band and cell (as in `brdf.csv`).
    pub band: usize,
    /// Cell in the band.
    pub cell: usize,
    /// Cell centre polar angle (degrees).
    pub theta_deg: f64,
    /// Cell centre absolute azimuth (degrees, as `brdf.csv`'s `phi_deg`).
    pub phi_deg: f64,
    /// Table BRDF (sr⁻¹).
    pub table: f64,
    /// Model BRDF, cell average (sr⁻¹).
    pub model: f64,
    /// Its standard error (sr⁻¹).
    pub stderr: f64,
    /// `(table - model) / stderr`.
    pub sigma: f64,
}

/// The fit of one set of parameters: per incidence (ABg, Harvey) or over
/// all (microfacet).
#[derive(Debug, Clone, Serialize)]
pub struct FitResult {
    /// Incidence polar angles (degrees) fitted.
    pub theta_i_deg: Vec<f64>,
    /// The parameters.
    pub parameters: Vec<Parameter>,
    /// `chi²` at the minimum.
    pub chi2: f64,
    /// Degrees of freedom: cells less parameters.
    pub dof: usize,
    /// `chi² / dof`.
    pub chi2_per_dof: f64,
    /// Whether the covariance was scaled by `chi²/dof` (> 1).
    pub covariance_scaled: bool,
    /// Cells fitted.
    pub cells: usize,
    /// Cells of the whole table left out (no standard error and no photon
    /// count; see the module documentation).
    pub cells_left_out: usize,
    /// Levenberg-Marquardt's termination, as the crate names it.
    pub termination: String,
    /// Whether the minimiser converged: a termination the crate counts as
    /// successful (`Converged`, `Orthogonal`, `ResidualsZero`); any other
    /// (`LostPatience`: out of evaluations, `NoImprovementPossible`,
    /// `Numerical`) is named in the warnings ([`warnings`]).
    pub converged: bool,
    /// Per incidence: the table's reflectance and the model's over the
    /// same cells (Σ BRDF x projected solid angle), and their difference:
    /// for a single-scattering model on a rough surface, mostly the light
    /// scattered more than once.
    pub reflectance: Vec<ReflectanceCompare>,
    /// The largest residuals in standard errors, largest first (at most 10).
    pub largest_residuals: Vec<Residual>,
    /// The internal parameters at the minimum (for [`Model::brdf`]).
    #[serde(skip)]
    pub internal: Vec<f64>,
    /// The table's incidences fitted (indices).
    #[serde(skip)]
    pub incidences: Vec<usize>,
}

/// The table's and the model's reflectance at one incidence.
#[derive(Debug, Clone, Serialize)]
pub struct ReflectanceCompare {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// The table's: its sum of fractions over the cells fitted.
    pub table: f64,
    /// The model's over the same cells.
    pub model: f64,
    /// `table - model`.
    pub difference: f64,
    /// `chi²/cells` of this incidence's cells.
    pub chi2_per_cell: f64,
    /// The standard error of the table's reflectance at this incidence
    /// (as the exports' checks take it: `summary.json`'s, else the cells'
    /// errors added in quadrature; [`BrdfTable::reflectance_stderr`]).
    pub table_stderr: f64,
    /// The largest `|difference|` allowed: `max(1 % of table, 4
    /// table_stderr)`, the rule of the exports' read-back checks
    /// ([`ReflectanceCheck::tolerance`]).
    pub tolerance: f64,
    /// The verdict: `|difference| <= tolerance` (false also when the
    /// model's reflectance is not a number).
    pub ok: bool,
}

impl ReflectanceCompare {
    /// The comparison at incidence `i` of `table`: the table's
    /// reflectance `table_r` and the model's `model_r` over the same
    /// cells, judged by the exports' rule ([`ReflectanceCheck`]) against
    /// the table's standard error at that incidence.
    fn judged(table: &BrdfTable, i: usize, table_r: f64, model_r: f64, chi2_per_cell: f64) -> Self {
        let theta_i_deg = table.incidence(i).theta_deg;
        let check = ReflectanceCheck {
            theta_i_deg,
            phi_i_deg: None,
            table: table_r,
            file: model_r,
            table_stderr: table.reflectance_stderr(theta_i_deg.to_radians()),
        };
        Self {
            theta_i_deg,
            table: table_r,
            model: model_r,
            difference: table_r - model_r,
            chi2_per_cell,
            table_stderr: check.table_stderr,
            tolerance: check.tolerance(),
            ok: check.passes(),
        }
    }
}

/// Why a fit could not be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct FitError(pub String);

/// The most cells one direction's light falls in: 4, at the pole, where
/// the four cells of band 1 meet and roks shares it among them (elsewhere
/// 1, or 2 on an edge).
pub const MIRROR_CELLS: usize = 4;

/// Whether `table` holds something a model can be fitted to, the same for
/// every model: at every incidence finite numbers and a positive
/// reflectance spread over more than [`MIRROR_CELLS`] cells. A flat mirror's table (all the light in the
/// specular cell) or an absorbing surface's (no light) has no lobe to fit:
/// a least-squares fit to either runs its widths to 0 or infinity and ends
/// at parameters that are not numbers.
///
/// # Errors
/// The first incidence that fails, named, and why.
pub fn check_representable(table: &BrdfTable) -> Result<(), FitError> {
    for (i, theta) in table.thetas_deg().iter().enumerate() {
        let fractions = table.fractions(i);
        let stderrs = table.fraction_stderrs(i);
        if let Some(k) = fractions
            .iter()
            .zip(stderrs)
            .position(|(f, e)| !f.is_finite() || !e.is_finite())
        {
            return Err(FitError(format!(
                "theta_i {theta} deg: cell {k} of the table is not a number"
            )));
        }
        let lit = fractions.iter().filter(|&&f| f > 0.0).count();
        let reflectance: f64 = fractions.iter().sum();
        if lit == 0 {
            return Err(FitError(format!(
                "theta_i {theta} deg: the table reflects nothing there (reflectance 0): no lobe to fit"
            )));
        }
        if lit <= MIRROR_CELLS {
            return Err(FitError(format!(
                "theta_i {theta} deg: all the light ({reflectance:.6}) is in {lit} cell{} (one direction falls in at most {MIRROR_CELLS}, where cells meet): a mirror's reflection, narrower than the grid's cells, whose width no model can be fitted to; use the table itself",
                if lit == 1 { "" } else { "s" }
            )));
        }
    }
    Ok(())
}

/// Fit `model` to `cells` of `table`, starting from the best of `starts`
/// (internal parameters).
///
/// # Errors
/// Fewer cells than parameters, no start with a finite `chi²`, or a
/// minimum at parameters that are not finite numbers.
pub fn fit(
    model: &dyn Model,
    table: &BrdfTable,
    cells: &[&Observation],
    starts: &[Vec<f64>],
    left_out: usize,
) -> Result<FitResult, FitError> {
    let n_par = model.names().len();
    if cells.len() <= n_par {
        return Err(FitError(format!(
            "{} cells with a standard error, but the model has {n_par} parameters",
            cells.len()
        )));
    }
    let chi2_of = |q: &[f64]| -> f64 {
        cells
            .iter()
            .map(|o| ((cell_model(model, q, o) - o.brdf) / o.stderr).powi(2))
            .sum()
    };
    let start = starts
        .iter()
        .map(|q| (chi2_of(q), q))
        .filter(|(c, _)| c.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, q)| q.clone())
        .ok_or_else(|| FitError("no starting point with a finite chi^2".into()))?;
    let problem = Problem {
        model,
        cells,
        q: DVector::from_vec(start),
    };
    let (problem, report) = LevenbergMarquardt::new().minimize(problem);
    let q: Vec<f64> = problem.q.iter().copied().collect();
    let chi2 = chi2_of(&q);
    let dof = cells.len() - n_par;
    let chi2_per_dof = chi2 / dof as f64;
    let j = problem.jacobian_at(&q);
    let scale = chi2_per_dof.max(1.0);
    let cov = (j.transpose() * &j)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(n_par, n_par, f64::NAN))
        * scale;
    let parameters = model
        .physical(&q)
        .into_iter()
        .zip(model.names())
        .enumerate()
        .map(|(k, ((value, d), name))| Parameter {
            name: (*name).to_owned(),
            value,
            stderr: standard_error(d, cov[(k, k)]),
        })
        .collect::<Vec<Parameter>>();
    if let Some(p) = parameters.iter().find(|p| !p.value.is_finite()) {
        return Err(FitError(format!(
            "the fit ends at {} = {} (termination {:?}): the table is not of this model's form",
            p.name, p.value, report.termination
        )));
    }
    if !chi2.is_finite() {
        return Err(FitError(format!(
            "the fit ends at chi^2 = {chi2} (termination {:?}): the table is not of this model's form",
            report.termination
        )));
    }
    let (residuals, reflectance, thetas) = judge(model, table, cells, &q);
    Ok(FitResult {
        theta_i_deg: thetas
            .iter()
            .map(|&i| table.incidence(i).theta_deg)
            .collect(),
        parameters,
        chi2,
        dof,
        chi2_per_dof,
        covariance_scaled: chi2_per_dof > 1.0,
        cells: cells.len(),
        cells_left_out: left_out,
        termination: format!("{:?}", report.termination),
        converged: report.termination.was_successful(),
        reflectance,
        largest_residuals: residuals,
        internal: q,
        incidences: thetas,
    })
}

/// The residuals of `model` at `q` on `cells` of `table`, the largest ten
/// by magnitude, and each incidence's reflectance judged (with the
/// incidences, in the order of `cells`).
fn judge(
    model: &dyn Model,
    table: &BrdfTable,
    cells: &[&Observation],
    q: &[f64],
) -> (Vec<Residual>, Vec<ReflectanceCompare>, Vec<usize>) {
    let grid = table.grid();
    let mut residuals: Vec<Residual> = cells
        .iter()
        .map(|o| {
            let m = cell_model(model, q, o);
            let (band, cell) = grid.band_cell(o.flat);
            let (theta, phi) = grid.centre(band, cell);
            let inc = table.incidence(o.incidence);
            Residual {
                theta_i_deg: inc.theta_deg,
                phi_i_deg: inc.phi_i_deg,
                band,
                cell,
                theta_deg: theta.to_degrees(),
                phi_deg: phi.to_degrees(),
                table: o.brdf,
                model: m,
                stderr: o.stderr,
                sigma: (o.brdf - m) / o.stderr,
            }
        })
        .collect();
    let mut thetas: Vec<usize> = cells.iter().map(|o| o.incidence).collect();
    thetas.dedup();
    let reflectance = thetas
        .iter()
        .map(|&i| {
            let mine = || {
                cells
                    .iter()
                    .zip(&residuals)
                    .filter(|(o, _)| o.incidence == i)
            };
            let table_r: f64 = mine().map(|(o, _)| o.brdf * o.proj).sum();
            let model_r: f64 = mine().map(|(o, r)| r.model * o.proj).sum();
            let (n, c2) = mine().fold((0usize, 0.0), |(n, c), (_, r)| {
                (n + 1, c + r.sigma * r.sigma)
            });
            ReflectanceCompare::judged(table, i, table_r, model_r, c2 / n.max(1) as f64)
        })
        .collect();
    residuals.sort_by(|a, b| b.sigma.abs().total_cmp(&a.sigma.abs()));
    residuals.truncate(10);
    (residuals, reflectance, thetas)
}

/// Fit `model` to every incidence of `table` on its own, each started
/// from the best of `starts(cells)`.
///
/// # Errors
/// The first incidence that cannot be fitted, naming it.
pub fn per_incidence(
    model: &dyn Model,
    table: &BrdfTable,
    obs: &Observations,
    starts: impl Fn(&[&Observation]) -> Vec<Vec<f64>>,
) -> Result<Vec<FitResult>, FitError> {
    check_representable(table)?;
    (0..table.thetas_deg().len())
        .map(|i| {
            let cells: Vec<&Observation> = obs.cells.iter().filter(|o| o.incidence == i).collect();
            fit(model, table, &cells, &starts(&cells), obs.left_out)
                .map_err(|e| FitError(format!("theta_i {} deg: {}", table.thetas_deg()[i], e.0)))
        })
        .collect()
}

/// Per incidence of `obs`, the reflectance of `model` at internal
/// parameters `q` (one set for every incidence, as FRED takes ABg and
/// Harvey-Shack) over the cells of `obs` beside the table's, judged as
/// [`FitResult::reflectance`] is.
#[must_use]
pub fn reflectance_of(
    model: &dyn Model,
    q: &[f64],
    table: &BrdfTable,
    obs: &Observations,
) -> Vec<ReflectanceCompare> {
    (0..table.thetas_deg().len())
        .filter_map(|i| {
            let mine: Vec<&Observation> = obs.cells.iter().filter(|o| o.incidence == i).collect();
            if mine.is_empty() {
                return None;
            }
            let (mut t, mut m, mut c2) = (0.0, 0.0, 0.0);
            for o in &mine {
                let v = cell_model(model, q, o);
                t += o.brdf * o.proj;
                m += v * o.proj;
                c2 += ((o.brdf - v) / o.stderr).powi(2);
            }
            Some(ReflectanceCompare::judged(
                table,
                i,
                t,
                m,
                c2 / mine.len() as f64,
            ))
        })
        .collect()
}

/// The warnings of the fits of model `name` (one line each, no trailing
/// period), in the order of the fits: every incidence whose reflectance
/// is off the table's by more than `max(1 %, 4 standard errors)`
/// ([`ReflectanceCompare::ok`]), every fit that did not converge
/// ([`FitResult::converged`]), and every parameter whose standard error
/// exceeds its value in magnitude, or has none (singular covariance).
#[must_use]
pub fn warnings(name: &str, fits: &[FitResult]) -> Vec<String> {
    let mut out = Vec::new();
    for f in fits {
        let at = if f.theta_i_deg.len() == 1 {
            format!("theta_i {} deg", f.theta_i_deg[0])
        } else {
            "all incidences".to_owned()
        };
        if !f.converged {
            out.push(format!(
                "{name}: {at}: the fit did not converge (termination {}): its parameters are not a minimum of chi^2",
                f.termination
            ));
        }
        for p in &f.parameters {
            if p.stderr.is_nan() {
                out.push(format!(
                    "{name}: {at}: {} = {:.5e} has no standard error (singular covariance: undetermined)",
                    p.name, p.value
                ));
            } else if p.stderr > p.value.abs() {
                out.push(format!(
                    "{name}: {at}: {} = {:.5e} +- {:.2e}: the standard error exceeds the value (undetermined)",
                    p.name, p.value, p.stderr
                ));
            }
        }
        for r in f.reflectance.iter().filter(|r| !r.ok) {
            out.push(format!("{name}: {}", reflectance_off(r)));
        }
    }
    out
}

/// The words of a failed reflectance verdict, in the exports' wording:
/// `theta_i X deg: the model's reflectance ... is ... % off the table's ...
/// (N standard errors; allowed: max(1 %, 4 standard errors))`.
#[must_use]
pub fn reflectance_off(r: &ReflectanceCompare) -> String {
    let sigmas = crate::export::resample::standard_errors(r.model - r.table, r.table_stderr);
    format!(
        "theta_i {} deg: the model's reflectance {:.6} is {:+.2} % off the table's {:.6} ({sigmas}; allowed: max(1 %, 4 standard errors))",
        r.theta_i_deg,
        r.model,
        100.0 * (r.model / r.table - 1.0),
        r.table
    )
}

/// For a model `amplitude x shape(s)`: per shape point `s` of `grid`, the
/// weighted least-squares amplitude over `cells` (exact, as the model is
/// linear in it), giving the starting points `[ln amplitude, s...]`.
/// `shape(s, theta_i, out)` is the model with amplitude 1.
pub fn linear_starts(
    cells: &[&Observation],
    grid: &[Vec<f64>],
    shape: impl Fn(&[f64], f64, DVec3) -> f64,
) -> Vec<Vec<f64>> {
    grid.iter()
        .filter_map(|s| {
            let (mut num, mut den) = (0.0, 0.0);
            for o in cells {
                let m = o.rule.average(|d| shape(s, o.theta_i, d));
                let w = 1.0 / (o.stderr * o.stderr);
                num += w * m * o.brdf;
                den += w * m * m;
            }
            let a = num / den;
            (a.is_finite() && a > 0.0).then(|| {
                let mut q = vec![a.ln()];
                q.extend_from_slice(s);
                q
            })
        })
        .collect()
}

/// The per-incidence fit whose incidence is nearest `theta_deg` (degrees):
/// the one set a program whose model does not depend on incidence takes.
///
/// # Panics
/// If `fits` is empty.
#[must_use]
pub fn nearest(fits: &[FitResult], theta_deg: f64) -> &FitResult {
    let off = |f: &FitResult| (f.theta_i_deg[0] - theta_deg).abs();
    fits.iter()
        .min_by(|a, b| off(a).total_cmp(&off(b)))
        .expect("at least one fit")
}

/// `n` points from `lo` to `hi` evenly.
#[must_use]
pub fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1).max(1) as f64)
        .collect()
}

/// The specular direction's projection on the surface, `beta0 = (-sin
/// theta_i, 0)`, and `|beta - beta0|` for outgoing direction `out` (local
/// frame): the distance in direction-cosine space from the specular
/// direction, the variable of ABg and Harvey-Shack.
#[must_use]
pub fn beta_distance(theta_i: f64, out: DVec3) -> f64 {
    let bx = out.x + theta_i.sin();
    (bx * bx + out.y * out.y).sqrt()
}

/// A synthetic table of `model` (for tests and demonstrations): per
/// incidence `thetas_deg[i]` (light azimuth 0) with internal parameters
/// `q_of(i)`, on the Carlson grid of `bands` bands, each cell's fraction
/// the model's cell average times the projected solid angle, its standard
/// error `rel` times that, plus Gaussian noise of that standard error
/// (Box-Muller on the stream `seed`). Blocks as
/// [`BrdfTable::from_blocks`] and [`crate::output::brdf_csv`] take them:
/// `(theta_i_deg, phi_i_deg, fractions, fraction_stderr)`.
///
/// # Panics
/// If `bands` is 0.
#[must_use]
pub fn synthetic(
    model: &dyn Model,
    q_of: impl Fn(usize) -> Vec<f64>,
    thetas_deg: &[f64],
    bands: usize,
    rel: f64,
    seed: u64,
) -> Vec<(f64, f64, Vec<f64>, Vec<f64>)> {
    use rand::{RngExt, SeedableRng};
    let grid = CarlsonGrid::new(bands).expect("bands > 0");
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let mut gauss = move || {
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        (-2.0 * (1.0 - u).ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    };
    thetas_deg
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let q = q_of(i);
            let (mut f, mut e) = (Vec::new(), Vec::new());
            for flat in 0..grid.n_cells() {
                let (band, cell) = grid.band_cell(flat);
                let proj = grid.projected_solid_angle(band, cell);
                let rule = CellRule::new(&grid, flat, 0.0);
                let exact = proj * rule.model_average(model, &q, t.to_radians());
                let se = rel * exact;
                f.push((exact + se * gauss()).max(0.0));
                e.push(se);
            }
            (t, 0.0, f, e)
        })
        .collect()
}

#[cfg(test)]
mod tests {

    /// A singular covariance gives an undetermined (NaN) error, not 0; a
    /// regular one the delta method's |d| sqrt(var).
    #[test]
    fn singular_covariance_gives_no_standard_error() {
        assert!(super::standard_error(2.0, f64::NAN).is_nan());
        assert_eq!(super::standard_error(-2.0, 0.25), 1.0);
        assert_eq!(super::standard_error(3.0, -1e-30), 0.0);
    }
    use super::*;

    /// ABg and GGX fitted to tables made from themselves with 3 % noise
    /// recover their parameters within 4 standard errors, chi²/dof within
    /// 4 sqrt(2/dof) of 1.
    #[test]
    fn synthetic_tables_give_back_their_parameters() {
        let thetas = [0.0, 40.0];
        let truth = [0.01f64.ln(), 0.004f64.ln(), 1.7];
        let blocks = synthetic(&abg::Abg, |_| truth.to_vec(), &thetas, 12, 0.03, 5);
        let table = BrdfTable::from_blocks(CarlsonGrid::new(12).unwrap(), blocks, "s").unwrap();
        let obs = observations(&table, None);
        assert_eq!(obs.left_out, 0);
        for f in abg::fit(&table, &obs).unwrap() {
            check(&f, &[0.01, 0.004, 1.7]);
        }
        let model = microfacet::Microfacet {
            distribution: microfacet::Distribution::Ggx,
            material: crate::optics::material::Reflectance::Fresnel { n: 1.5, k: 3.0 },
        };
        let blocks = synthetic(&model, |_| vec![0.25f64.ln()], &thetas, 12, 0.03, 6);
        let table = BrdfTable::from_blocks(CarlsonGrid::new(12).unwrap(), blocks, "s").unwrap();
        let obs = observations(&table, None);
        check(&microfacet::fit(&model, &table, &obs).unwrap(), &[0.25]);
    }

    fn check(f: &FitResult, truth: &[f64]) {
        for (p, t) in f.parameters.iter().zip(truth) {
            assert!(
                (p.value - t).abs() < 4.0 * p.stderr && p.stderr > 0.0,
                "{}: {} +- {} vs {t}",
                p.name,
                p.value,
                p.stderr
            );
        }
        let tol = 4.0 * (2.0 / f.dof as f64).sqrt();
        assert!(
            (f.chi2_per_dof - 1.0).abs() < tol,
            "chi2/dof {}",
            f.chi2_per_dof
        );
    }

    #[test]
    fn the_cell_rule_integrates_the_projected_solid_angle() {
        // The average of cos(theta) x (1/cos theta) = 1 exactly, and the
        // average of x² over a cell uniform in projected solid angle is the
        // closed form ∫ sin²θ cos²φ dΩ_proj / proj for any cell.
        let grid = CarlsonGrid::new(6).unwrap();
        for flat in 0..grid.n_cells() {
            let rule = CellRule::new(&grid, flat, 0.3);
            assert!((rule.weights.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            for d in rule.dirs {
                assert!((d.length() - 1.0).abs() < 1e-12 && d.z > 0.0);
                assert_eq!(grid.locate(rotate(d, 0.3)), Some(flat), "{flat}");
            }
            // <sin² theta> over mu² uniform in [a, b]: 1 - (a + b)/2, exact
            // for a polynomial of degree 1 in mu².
            let (band, _) = grid.band_cell(flat);
            let (lo, hi) = grid.mu_edges(band);
            let want = 1.0 - (lo * lo + hi * hi) / 2.0;
            let got = rule.average(|d| d.x * d.x + d.y * d.y);
            assert!((got - want).abs() < 1e-14, "{got} {want}");
        }
    }

    fn rotate(d: DVec3, a: f64) -> DVec3 {
        let (s, c) = a.sin_cos();
        DVec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z)
    }

    /// A table with no light at an incidence, or all of it in one cell, is
    /// refused before any fit, naming the incidence; a lobe over many cells
    /// is not.
    #[test]
    fn tables_without_a_lobe_are_not_representable() {
        let grid = CarlsonGrid::new(6).unwrap();
        let n = grid.n_cells();
        let lobe = synthetic(
            &abg::Abg,
            |_| vec![0.01f64.ln(), 0.01f64.ln(), 2.0],
            &[0.0, 30.0],
            6,
            0.03,
            1,
        );
        let table = |blocks| BrdfTable::from_blocks(grid, blocks, "t").unwrap();
        assert_eq!(check_representable(&table(lobe.clone())), Ok(()));
        let mut dark = lobe.clone();
        dark[1].2 = vec![0.0; n];
        dark[1].3 = vec![0.0; n];
        let e = check_representable(&table(dark)).unwrap_err().0;
        assert!(
            e.starts_with("theta_i 30 deg: the table reflects nothing"),
            "{e}"
        );
        let mut mirror = lobe;
        mirror[1].2 = vec![0.0; n];
        mirror[1].2[n - 1] = 0.9;
        mirror[1].3 = vec![0.0; n];
        let e = check_representable(&table(mirror)).unwrap_err().0;
        assert!(
            e.starts_with("theta_i 30 deg: all the light (0.900000) is in 1 cell "),
            "{e}"
        );
    }

    /// A fit result of one incidence with these parameters `(value,
    /// stderr)`, termination and reflectance verdict.
    fn result(params: &[(f64, f64)], converged: bool, ok: bool, chi2: f64) -> FitResult {
        FitResult {
            theta_i_deg: vec![15.0],
            parameters: params
                .iter()
                .enumerate()
                .map(|(k, &(value, stderr))| Parameter {
                    name: format!("p{k}"),
                    value,
                    stderr,
                })
                .collect(),
            chi2,
            dof: 10,
            chi2_per_dof: chi2 / 10.0,
            covariance_scaled: false,
            cells: 12,
            cells_left_out: 0,
            termination: if converged {
                "Converged"
            } else {
                "LostPatience"
            }
            .into(),
            converged,
            reflectance: vec![ReflectanceCompare {
                theta_i_deg: 15.0,
                table: 0.5,
                model: if ok { 0.499 } else { 0.4 },
                difference: if ok { 0.001 } else { 0.1 },
                chi2_per_cell: 1.0,
                table_stderr: 1e-3,
                tolerance: 0.005,
                ok,
            }],
            largest_residuals: Vec::new(),
            internal: Vec::new(),
            incidences: vec![0],
        }
    }

    /// Every failed judgement is one warning naming the model, the
    /// incidence and what failed; a clean fit has none; the ranking puts
    /// the clean fit first, then fewer failing incidences, then fewer fits
    /// not converged, then the smaller chi²/dof.
    #[test]
    fn warnings_and_ranking() {
        let clean = result(&[(1.0, 0.1), (-2.0, 1.9)], true, true, 30.0);
        assert!(warnings("m", std::slice::from_ref(&clean)).is_empty());
        let bad = result(&[(1.0, 1.5), (-2.0, f64::NAN)], false, false, 5.0);
        let w = warnings("m", std::slice::from_ref(&bad));
        assert_eq!(w.len(), 4, "{w:#?}");
        assert!(
            w[0].starts_with(
                "m: theta_i 15 deg: the fit did not converge (termination LostPatience)"
            )
        );
        assert!(w[1].contains("p0 = 1.00000e0 +- 1.50e0: the standard error exceeds the value"));
        assert!(w[2].contains("p1 = -2.00000e0 has no standard error"));
        assert!(w[3].starts_with("m: theta_i 15 deg: the model's reflectance 0.400000 is -20.00 % off the table's 0.500000 (100.0 standard errors;"));
        let j = |name, r: &FitResult| Judgement::of(name, std::slice::from_ref(r));
        let unconverged = result(&[(1.0, 0.1)], false, true, 1.0);
        let off = result(&[(1.0, 0.1)], true, false, 2.0);
        let off_unconverged = result(&[(1.0, 0.1)], false, false, 1.0);
        let mut all = vec![
            j("d", &off_unconverged),
            j("c", &off),
            j("b", &unconverged),
            j("a", &clean),
        ];
        rank(&mut all);
        let order: Vec<&str> = all.iter().map(|x| x.model.as_str()).collect();
        assert_eq!(order, ["a", "b", "c", "d"]);
        assert!(all[0].passes && all[0].line().starts_with("a: ok: "));
        assert!(
            all[3]
                .line()
                .starts_with("d: NOT OK: 1 of 1 incidences off"),
            "{}",
            all[3].line()
        );
    }

    #[test]
    fn beta_is_zero_at_the_specular_direction() {
        let t: f64 = 0.6;
        let spec = DVec3::new(-t.sin(), 0.0, t.cos());
        assert!(beta_distance(t, spec).abs() < 1e-15);
        assert!((beta_distance(t, DVec3::Z) - t.sin()).abs() < 1e-15);
    }
}
