//! A prepared fit ([`Problem`]): the scene as a TOML table, the parameters
//! and the measurement checked; the model's in-plane BRDF and the misfit
//! at any parameter values. The search is in `search.rs`.

use toml::{Table, Value};

use super::params::range_parent;
use super::{FitError, FitParam, KeyPath, Measured};
use crate::scene::SceneFile;
use crate::scene::micro::MicroScene;
use crate::tally::InPlaneTally;

// ---------------------------------------------------------------- options, result

/// How to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Photons per incidence angle and evaluation.
    pub photons: u64,
    /// Tracing seed, the same at every evaluation (common random numbers).
    pub seed: u64,
    /// Most model runs.
    pub max_evaluations: usize,
    /// Stop when the misfit spread over the simplex is at most this ...
    pub tolerance: f64,
    /// ... and the simplex fits in a box this wide in every unit coordinate
    /// (a fraction of each parameter's range).
    pub x_tolerance: f64,
    /// Restarts from the best point after convergence (stops early when a
    /// restart gains less than `tolerance`).
    pub restarts: usize,
    /// In-plane bin width (degrees, must divide 180); `None`: the scene's.
    pub inplane_step_deg: Option<f64>,
    /// In-plane detector full width out of the plane (degrees); `None`: the scene's.
    pub inplane_width_deg: Option<f64>,
    /// Points per parameter of the coarse global scan that picks the
    /// simplex's starting point (0 or 1: none). At most 256 points in all:
    /// fewer per parameter when needed, none when even 2 per parameter are
    /// more (9 parameters or more).
    pub scan: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            photons: 200_000,
            seed: 1,
            max_evaluations: 200,
            tolerance: 1e-6,
            x_tolerance: 1e-3,
            restarts: 3,
            inplane_step_deg: None,
            inplane_width_deg: None,
            scan: 8,
        }
    }
}

/// Where a parameter ended relative to its bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// Strictly inside.
    Inside,
    /// At the lower bound.
    Lower,
    /// At the upper bound.
    Upper,
}

/// The outcome of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitResult {
    /// Best parameter values, in the order of the parameters.
    pub values: Vec<f64>,
    /// Misfit at `values`.
    pub misfit: f64,
    /// Start values (the scene's, clamped into the bounds).
    pub start: Vec<f64>,
    /// Misfit at `start`.
    pub start_misfit: f64,
    /// Model runs made.
    pub evaluations: usize,
    /// True if the tolerances were met (false: `max_evaluations` ran out).
    pub converged: bool,
    /// Per parameter: did it end on a bound (within `x_tolerance` of its range)?
    pub at_bounds: Vec<Bound>,
    /// Every model run: parameter values and misfit (infinite: rejected by the scene).
    pub history: Vec<(Vec<f64>, f64)>,
    /// The runs of `history` the scene rejected: their index in `history`
    /// and the reason ([`reason`]: key and message). Only combinations of
    /// parameters can be rejected (each bound alone is checked up front).
    pub rejected: Vec<(usize, String)>,
    /// Model in-plane BRDF at `values`, one per measured point.
    pub model: Vec<f64>,
}

// ---------------------------------------------------------------- the problem

/// A prepared fit: the parsed scene, parameters and measurement.
#[derive(Debug, Clone)]
pub struct Problem {
    table: Table,
    scene_file: SceneFile,
    name: String,
    pub(super) params: Vec<FitParam>,
    paths: Vec<KeyPath>,
    measured: Measured,
    thetas: Vec<f64>,
    /// The measured light azimuths (degrees), traced instead of the
    /// scene's; `None`: the scene's one azimuth.
    phis: Option<Vec<f64>>,
    eps: f64,
    pub(super) opts: FitOptions,
}

/// Called after every model run of a fit with `(evaluation, values, misfit,
/// rejected)`: the 1-based evaluation number, the parameter values, the
/// misfit (infinite when rejected) and why the scene rejected the values.
pub type Observer<'a> = dyn FnMut(usize, &[f64], f64, Option<&str>) + 'a;

/// Why a point cannot be evaluated: its parameter values make the scene invalid.
#[derive(Debug, Clone, PartialEq)]
pub struct Infeasible(pub FitError);

/// The scene's objection to a point, as `key: message` (the file is the
/// fit's scene; a line number, which would count lines of the rewritten
/// table rather than of the user's file, is left out).
#[must_use]
pub fn reason(e: &FitError) -> String {
    match e {
        FitError::Scene(s) => {
            let m = s.message.as_str();
            let m = match m.rfind(" (line ") {
                Some(i) if m.ends_with(')') => &m[..i],
                _ => m,
            };
            if s.key.is_empty() {
                m.to_string()
            } else {
                format!("{}: {m}", s.key)
            }
        }
        FitError::Key { key, message, .. } => format!("{key}: {message}"),
        other => other.to_string(),
    }
}

impl Problem {
    /// Check everything: the scene builds, every key leads to a number, the
    /// bounds and the options are valid.
    pub fn new(
        scene_text: &str,
        scene_file: &SceneFile,
        params: &[FitParam],
        measured: &Measured,
        opts: &FitOptions,
    ) -> Result<Self, FitError> {
        let name = std::path::Path::new(&scene_file.file)
            .file_stem()
            .map_or_else(|| "fit".to_string(), |s| s.to_string_lossy().into_owned());
        // The scene as given must be valid (this also reports TOML syntax errors).
        let scene = MicroScene::from_str(scene_text, scene_file.clone(), name.clone())?;
        check_scene(&scene, scene_file, measured)?;
        let table: Table = toml::from_str(scene_text)
            .map_err(|e| scene_file.error("", format!("invalid TOML: {}", e.message())))?;
        let opt = |option: &str, message: String| FitError::Options {
            option: option.into(),
            message,
        };
        if params.is_empty() {
            return Err(opt("--param", "give at least one parameter".into()));
        }
        let paths = key_paths(params, &table, scene_file)?;
        check_options(opts)?;
        let max = measured.points.iter().map(|p| p.2).fold(0.0, f64::max);
        if measured.points.is_empty() || max <= 0.0 || max.is_nan() {
            return Err(FitError::Measured {
                file: "measured".into(),
                line: 0,
                message: "no positive brdf values".into(),
            });
        }
        let problem = Self {
            table,
            scene_file: scene_file.clone(),
            name,
            params: params.to_vec(),
            paths,
            measured: measured.clone(),
            thetas: measured.incidence_angles(),
            phis: measured.azimuths(),
            eps: 1e-3 * max,
            opts: opts.clone(),
        };
        problem.check_bounds()?;
        Ok(problem)
    }

    /// Refuse bounds the scene rejects, before any photon is traced: the
    /// scene is built (every check of the scene file, no tracing) at the
    /// start point, and at both bounds of every parameter with the others at
    /// their start values. What the search can still meet is a combination
    /// (two ends of one range crossing, say); such points are recorded with
    /// their reason in [`FitResult::rejected`].
    fn check_bounds(&self) -> Result<(), FitError> {
        let start = self.start();
        let infeasible = |spec: String, at: String, e: Infeasible| FitError::Infeasible {
            file: self.scene_file.file.clone(),
            spec,
            at,
            reason: reason(&e.0),
        };
        if let Err(e) = self.build(&start) {
            let spec = self
                .params
                .iter()
                .map(|p| format!("{}={}:{}", p.key, p.lo, p.hi))
                .collect::<Vec<_>>()
                .join(" --param ");
            let at = self
                .params
                .iter()
                .zip(&start)
                .map(|(p, v)| format!("{} = {v}", p.key))
                .collect::<Vec<_>>()
                .join(", ");
            return Err(infeasible(
                spec,
                format!("at the start ({at}: the scene's values clamped into the bounds)"),
                e,
            ));
        }
        for (j, p) in self.params.iter().enumerate() {
            for v in [p.lo, p.hi] {
                let mut values = start.clone();
                values[j] = v;
                if let Err(e) = self.build(&values) {
                    return Err(infeasible(
                        format!("{}={}:{}", p.key, p.lo, p.hi),
                        format!("at {} = {v}", p.key),
                        e,
                    ));
                }
            }
        }
        Ok(())
    }

    /// The start point: the scene's current values clamped into the bounds.
    fn start(&self) -> Vec<f64> {
        self.params
            .iter()
            .zip(self.current())
            .map(|(p, v)| p.value_at(p.unit(v).clamp(0.0, 1.0)))
            .collect()
    }

    /// The scene with `values` written in (built and checked, not traced).
    fn build(&self, values: &[f64]) -> Result<MicroScene, Infeasible> {
        let text = self.table_with(values)?.to_string();
        MicroScene::from_str(&text, self.scene_file.clone(), self.name.clone())
            .map_err(|e| Infeasible(e.into()))
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &[FitParam] {
        &self.params
    }

    /// The scene's current values of the parameters (not clamped).
    #[must_use]
    pub fn current(&self) -> Vec<f64> {
        self.paths
            .iter()
            .map(|p| p.get_number(&self.table).expect("checked in new"))
            .collect()
    }

    /// `eps` of the log misfit: 1e-3 of the largest measured BRDF.
    #[must_use]
    pub fn eps(&self) -> f64 {
        self.eps
    }

    /// The scene table with `values` written in; ranges touched must stay `lo <= hi`.
    fn table_with(&self, values: &[f64]) -> Result<Table, Infeasible> {
        assert_eq!(values.len(), self.paths.len(), "one value per parameter");
        let mut t = self.table.clone();
        for (path, &v) in self.paths.iter().zip(values) {
            path.set_number(&mut t, v).expect("checked in new");
        }
        for path in &self.paths {
            if let Some(range) = range_parent(path) {
                let v = range.get_mut(&mut t).expect("checked in new");
                if let Value::Array(a) = v {
                    let num = |x: &Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
                    if let (Some(lo), Some(hi)) = (a.first().and_then(num), a.get(1).and_then(num))
                    {
                        if lo > hi {
                            return Err(Infeasible(FitError::Scene(self.scene_file.error(
                                range.to_string(),
                                format!("range [{lo}, {hi}] is reversed"),
                            ))));
                        }
                    }
                }
            }
        }
        Ok(t)
    }

    /// The scene text with `values` written in (comments and layout are not kept).
    pub fn apply(&self, values: &[f64]) -> Result<String, FitError> {
        self.table_with(values)
            .map(|t| t.to_string())
            .map_err(|e| e.0)
    }

    /// The model in-plane BRDF at every measured point, for `values`.
    pub fn model(&self, values: &[f64]) -> Result<Vec<f64>, Infeasible> {
        let scene = self.build(values)?;
        let mut run = scene.brdf_run();
        run.theta_deg.clone_from(&self.thetas);
        if let Some(phis) = &self.phis {
            run.phi_deg = crate::transport::brdf::Azimuths(phis.clone());
        }
        run.photons = self.opts.photons;
        run.seed = self.opts.seed;
        run.shard = None;
        if let Some(s) = self.opts.inplane_step_deg {
            run.inplane_step_deg = s;
        }
        if let Some(w) = self.opts.inplane_width_deg {
            run.inplane_width_deg = w;
        }
        let results = run.trace_whole(&scene.surface, &|_| {});
        let tally = run.inplane();
        let centres: Vec<f64> = (0..tally.n_bins()).map(|b| tally.centre_deg(b)).collect();
        // The curve of incidence `i` and light azimuth `a` (the result is
        // nested incidence x azimuth x wavelength; one wavelength).
        let curve = |i: usize, a: usize| -> Vec<f64> {
            let r = results.leaf(i, a, 0);
            let n = r.tallies.photons;
            (0..tally.n_bins())
                .map(|b| r.tallies.inplane.mean(b, n) / tally.projected_solid_angle(b))
                .collect()
        };
        let curves: Vec<Vec<Vec<f64>>> = (0..results.incidence.len())
            .map(|i| {
                (0..results.incidence[i].azimuth.len())
                    .map(|a| curve(i, a))
                    .collect()
            })
            .collect();
        Ok(self
            .measured
            .points
            .iter()
            .enumerate()
            .map(|(p, &(ti, to, _, _))| {
                let i = self
                    .thetas
                    .iter()
                    .position(|&t| t == ti)
                    .expect("distinct angles");
                let a = match (&self.phis, &self.measured.phi_i_deg) {
                    (Some(phis), Some(phi)) => phis
                        .iter()
                        .position(|&q| q == phi[p])
                        .expect("distinct azimuths"),
                    _ => 0,
                };
                interpolate(&centres, &curves[i][a], to)
            })
            .collect())
    }

    /// The log misfit of a model curve against the measurement.
    #[must_use]
    pub fn misfit_of(&self, model: &[f64]) -> f64 {
        let sum: f64 = self
            .measured
            .points
            .iter()
            .zip(model)
            .map(|(p, &m)| {
                let d = (m + self.eps).ln() - (p.2 + self.eps).ln();
                d * d
            })
            .sum();
        sum / self.measured.points.len() as f64
    }

    /// The misfit at `values` (infinite where the scene rejects them).
    #[must_use]
    pub fn misfit(&self, values: &[f64]) -> f64 {
        self.model(values)
            .map_or(f64::INFINITY, |m| self.misfit_of(&m))
    }

    /// Nelder-Mead from the scene's current values (see the module doc).
    pub fn fit(&self) -> Result<FitResult, FitError> {
        self.fit_observed(&mut |_, _, _, _| {})
    }
}

/// Refuse a scene whose model is not one in-plane curve per measured
/// incidence (and azimuth): several wavelengths, several light azimuths
/// for a measurement without `phi_i_deg`, several realisations.
fn check_scene(
    scene: &MicroScene,
    scene_file: &SceneFile,
    measured: &Measured,
) -> Result<(), FitError> {
    // A measured in-plane BRDF is one curve per incidence angle: the
    // model must be one too, so one wavelength at most.
    let wavelengths = scene.brdf_run().wavelengths_um.len();
    if wavelengths > 1 {
        return Err(FitError::Scene(scene_file.error(
                "light.wavelengths_um",
                format!(
                    "roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces {wavelengths} wavelengths: fit one wavelength at a time ([light] wavelengths_um = [W])"
                ),
            )));
    }
    // A measurement without azimuths is one curve per incidence angle:
    // the model must be one too, so one light azimuth.
    let azimuths = scene.brdf_run().phi_deg.len();
    if azimuths > 1 && measured.phi_i_deg.is_none() {
        return Err(FitError::Scene(scene_file.error(
                "light.phi_deg",
                format!(
                    "roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces {azimuths} light azimuths and the measurement has no phi_i_deg column: give each row's azimuth (column phi_i_deg after theta_i_deg, as inplane.csv of such a run has) or fit one azimuth ([light] phi_deg = P)"
                ),
            )));
    }
    // The model traces the scene's own surface (realisation 0) only.
    let realisations = scene.brdf_run().realisations;
    if realisations > 1 {
        return Err(FitError::Scene(scene_file.error(
                "surface.realisations",
                format!(
                    "roks fit traces one surface, but the scene has {realisations} realisations: fit with realisations = 1"
                ),
            )));
    }
    Ok(())
}

/// The key path of every parameter in `table` (the scene's), each checked:
/// its bounds, that it leads to a number, that it is given once.
fn key_paths(
    params: &[FitParam],
    table: &Table,
    scene_file: &SceneFile,
) -> Result<Vec<KeyPath>, FitError> {
    let mut paths = Vec::new();
    for p in params {
        let key_err = |message: &dyn std::fmt::Display| FitError::Key {
            file: scene_file.file.clone(),
            key: p.key.clone(),
            message: message.to_string(),
        };
        p.check().map_err(|m| FitError::Param {
            spec: format!("{}={}:{}", p.key, p.lo, p.hi),
            message: m.to_string(),
        })?;
        let path: KeyPath = p.key.parse().map_err(|e| key_err(&e))?;
        path.get_number(table).map_err(|e| key_err(&e))?;
        if paths.contains(&path) {
            return Err(key_err(&"given twice"));
        }
        paths.push(path);
    }
    Ok(paths)
}

/// Refuse bad fit options, naming the option.
fn check_options(opts: &FitOptions) -> Result<(), FitError> {
    let opt = |option: &str, message: String| FitError::Options {
        option: option.into(),
        message,
    };
    if let Err(e) = crate::transport::launch::check_count(opts.photons) {
        return Err(opt("--photons", e.to_string()));
    }
    if opts.max_evaluations == 0 {
        return Err(opt("--max-evals", "must be > 0".into()));
    }
    if opts.tolerance.is_nan() || opts.tolerance < 0.0 {
        return Err(opt(
            "--tolerance",
            format!("must be >= 0, got {}", opts.tolerance),
        ));
    }
    if opts.x_tolerance.is_nan() || opts.x_tolerance < 0.0 {
        return Err(opt(
            "--x-tolerance",
            format!("must be >= 0, got {}", opts.x_tolerance),
        ));
    }
    if let Some(s) = opts.inplane_step_deg {
        if InPlaneTally::new(s, 0.5, 0.0).is_none() {
            return Err(opt(
                "--inplane-step",
                format!(
                    "must divide 180 into at most {} bins (a step of at least 0.01 deg), got {s}",
                    crate::tally::inplane::MAX_BINS
                ),
            ));
        }
    }
    if let Some(w) = opts.inplane_width_deg {
        if let Some(e) = InPlaneTally::width_error(w) {
            return Err(opt("--inplane-width", e.to_string()));
        }
    }
    Ok(())
}

/// Linear interpolation of per-bin values `bins` at signed in-plane angle
/// `theta_o` between the bin centres `centres` (increasing); constant beyond
/// the outermost centres.
fn interpolate(centres: &[f64], bins: &[f64], theta_o: f64) -> f64 {
    let n = bins.len();
    if theta_o <= centres[0] {
        return bins[0];
    }
    if theta_o >= centres[n - 1] {
        return bins[n - 1];
    }
    // First centre above theta_o: in 1..n.
    let hi = centres.partition_point(|&c| c <= theta_o);
    let lo = hi - 1;
    let t = (theta_o - centres[lo]) / (centres[hi] - centres[lo]);
    if t == 0.0 {
        bins[lo]
    } else {
        (1.0 - t) * bins[lo] + t * bins[hi]
    }
}

/// Fit `params` of the micro scene `scene_text` to `measured` (see the module doc).
pub fn fit(
    scene_text: &str,
    scene_file: &SceneFile,
    params: &[FitParam],
    measured: &Measured,
    opts: &FitOptions,
) -> Result<FitResult, FitError> {
    Problem::new(scene_text, scene_file, params, measured, opts)?.fit()
}

/// The misfit at `values` of `params` (infinite where the scene rejects them).
pub fn misfit(
    scene_text: &str,
    scene_file: &SceneFile,
    params: &[FitParam],
    values: &[f64],
    measured: &Measured,
    opts: &FitOptions,
) -> Result<f64, FitError> {
    let p = Problem::new(scene_text, scene_file, params, measured, opts)?;
    if values.len() != params.len() {
        return Err(FitError::Options {
            option: "values".into(),
            message: format!("{} values for {} parameters", values.len(), params.len()),
        });
    }
    Ok(p.misfit(values))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::FitParam;
    use crate::output::inplane_csv::write as inplane_csv;

    fn scene_file() -> SceneFile {
        SceneFile {
            file: "test.toml".into(),
            dir: ".".into(),
        }
    }

    fn table(text: &str) -> Table {
        toml::from_str(text).unwrap()
    }

    fn path(s: &str) -> KeyPath {
        s.parse().unwrap()
    }

    #[test]
    fn interpolation_between_centres() {
        let c = [-88.75, -85.0, -80.0, 0.0, 88.75];
        let b = [1.0, 2.0, 4.0, 8.0, 16.0];
        assert_eq!(interpolate(&c, &b, -90.0), 1.0);
        assert_eq!(interpolate(&c, &b, -88.75), 1.0);
        assert_eq!(interpolate(&c, &b, -85.0), 2.0);
        assert_eq!(interpolate(&c, &b, -82.5), 3.0);
        assert_eq!(interpolate(&c, &b, -40.0), 6.0);
        assert_eq!(interpolate(&c, &b, 0.0), 8.0);
        assert_eq!(interpolate(&c, &b, 90.0), 16.0);
    }

    // ------------------------------------------------------------ the fit

    /// 20 ellipsoid bumps of radius `r` and height `h` on a 12 x 12 periodic
    /// cell; `material` is the body of `[materials.m]`. The in-plane tally is
    /// 5 degree bins with a 10 degree detector: with 30 000 photons per angle
    /// that is ~100 photons per bin, enough for a misfit that falls steadily
    /// toward the truth (1 degree bins hold a few photons each and the misfit
    /// is noise a few hundredths away from the true value).
    fn scene(material: &str, h: &str, r: f64) -> String {
        format!(
            "[surface]\nsize = [12.0, 12.0]\nedges = \"periodic\"\nmaterial = \"m\"\n\
             [materials.m]\n{material}\n\
             [[bumps]]\nshape = \"ellipsoid\"\ncount = 20\nradius = {r:?}\nheight = {h}\nseed = 3\n\
             [light]\ntheta_deg = [0.0]\n\
             [tally]\ninplane_step_deg = 5.0\ninplane_width_deg = 10.0\n"
        )
    }

    const PHOTONS: u64 = 30_000;

    fn opts() -> FitOptions {
        FitOptions {
            photons: PHOTONS,
            seed: 7,
            ..FitOptions::default()
        }
    }

    /// The "measurement": roks's own `inplane.csv` of the true scene at 30
    /// and 60 degrees (same photons and seed as the fit), read back and
    /// sampled every 5 degrees from -80 to 80 by linear interpolation between
    /// its rows (independent of the fit's model code).
    fn measured_from(truth: &str) -> Measured {
        let scene = MicroScene::from_str(truth, scene_file(), "truth".into()).unwrap();
        let mut run = scene.brdf_run();
        run.theta_deg = vec![30.0, 60.0];
        run.photons = PHOTONS;
        run.seed = 7;
        let results = run.trace_whole(&scene.surface, &|_| {});
        let csv = inplane_csv(&run, &results);
        let rows: Vec<[f64; 4]> = csv
            .lines()
            .skip(1)
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|f| f.parse().unwrap()).collect();
                [v[0], v[1], v[2], v[3]]
            })
            .collect();
        // Linear interpolation between the CSV rows around `to`.
        let at = |ti: f64, to: f64| {
            let curve: Vec<&[f64; 4]> = rows.iter().filter(|r| r[0] == ti).collect();
            let k = curve.iter().position(|r| r[1] >= to).unwrap();
            if curve[k][1] == to {
                return curve[k][2];
            }
            let (a, b) = (curve[k - 1], curve[k]);
            let t = (to - a[1]) / (b[1] - a[1]);
            a[2] + t * (b[2] - a[2])
        };
        let mut text = String::from("theta_i_deg,theta_o_deg,brdf\n");
        for ti in [30.0, 60.0] {
            for k in -16..=16 {
                let to = 5.0 * f64::from(k);
                text.push_str(&format!("{ti},{to},{:e}\n", at(ti, to)));
            }
        }
        let m = Measured::parse(&text, "synthetic.csv").unwrap();
        assert_eq!(m.points.len(), 66);
        // Not a trivial measurement: the curve spans a decade or more.
        let (lo, hi) = m.points.iter().fold((f64::INFINITY, 0.0_f64), |(a, b), p| {
            (a.min(p.2), b.max(p.2))
        });
        assert!(hi > 10.0 * lo.max(1e-3 * hi), "flat curve {lo} .. {hi}");
        m
    }

    const PAINT: &str = "reflectance = 0.8";

    #[test]
    fn misfit_at_the_true_parameters_is_zero() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let params: Vec<FitParam> = vec![
            "bumps[0].height[1]=1:3".parse().unwrap(),
            "bumps[0].radius=1:4".parse().unwrap(),
        ];
        let probe = Measured {
            points: vec![
                (30.0, 0.0, 1.0, None),
                (60.0, 7.0, 1.0, None),
                (60.0, 89.0, 1.0, None),
            ],
            phi_i_deg: None,
        };
        // Model points from the fit's own model; then the misfit there is exactly 0.
        let p = Problem::new(&truth, &scene_file(), &params, &probe, &opts()).unwrap();
        assert_eq!(p.current(), vec![1.8, 2.5]);
        let model = p.model(&[1.8, 2.5]).unwrap();
        assert!(model.iter().all(|&b| b > 0.0), "{model:?}");
        let m = Measured {
            points: probe
                .points
                .iter()
                .zip(&model)
                .map(|(q, &b)| (q.0, q.1, b, None))
                .collect(),
            phi_i_deg: None,
        };
        let zero = misfit(&truth, &scene_file(), &params, &[1.8, 2.5], &m, &opts()).unwrap();
        assert_eq!(zero, 0.0);
        let off = misfit(&truth, &scene_file(), &params, &[1.7, 2.5], &m, &opts()).unwrap();
        assert!(off > 1e-4, "{off}");
        // Against roks's own inplane.csv route (9-digit CSV values): 0 to rounding.
        let m = measured_from(&truth);
        let p = Problem::new(&truth, &scene_file(), &params, &m, &opts()).unwrap();
        let near_zero = p.misfit(&[1.8, 2.5]);
        assert!(near_zero < 1e-15, "{near_zero}");
        // The model at every measured point, to the CSV's 9 digits.
        let model = p.model(&[1.8, 2.5]).unwrap();
        for (q, b) in m.points.iter().zip(&model) {
            assert!((b - q.2).abs() <= 1e-8 * q.2.max(1e-12), "{q:?} vs {b}");
        }
    }

    /// A scene of two light azimuths (issue 42): each measured row is
    /// compared with the curve of its own incidence and azimuth. The
    /// measurement is roks's own `inplane.csv` of the true scene at 30 and
    /// 60 degrees and azimuths 0 and 90 (its `phi_i_deg` column; same
    /// photons and seed as the fit), read whole: the misfit at the truth is
    /// 0 to the CSV's 9 digits, and the model at every row is that row.
    /// Each azimuth draws its own photons, so a row compared with another
    /// azimuth's or incidence's curve would differ. A measurement without
    /// azimuths cannot say which curve a row belongs to: refused.
    #[test]
    fn two_azimuths_compare_each_row_with_its_own_block() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5).replace(
            "[light]\ntheta_deg = [0.0]\n",
            "[light]\ntheta_deg = [0.0]\nphi_deg = [0.0, 90.0]\n",
        );
        let s = MicroScene::from_str(&truth, scene_file(), "truth".into()).unwrap();
        let mut run = s.brdf_run();
        assert_eq!(run.phi_deg.len(), 2);
        run.theta_deg = vec![30.0, 60.0];
        run.photons = PHOTONS;
        run.seed = 7;
        let results = run.trace_whole(&s.surface, &|_| {});
        let csv = inplane_csv(&run, &results);
        assert!(csv.starts_with("theta_i_deg,phi_i_deg,"), "{}", &csv[..60]);
        let m = Measured::parse(&csv, "truth/inplane.csv").unwrap();
        assert_eq!(m.azimuths(), Some(vec![0.0, 90.0]));
        let params: Vec<FitParam> = vec!["bumps[0].radius=1:4".parse().unwrap()];
        let p = Problem::new(&truth, &scene_file(), &params, &m, &opts()).unwrap();
        let model = p.model(&[2.5]).unwrap();
        let mut differ = 0;
        for (q, b) in m.points.iter().zip(&model) {
            assert!((b - q.2).abs() <= 1e-8 * q.2.max(1e-12), "{q:?} vs {b}");
            differ += usize::from(q.2 > 0.0 && (b - q.2).abs() > 1e-3 * q.2);
        }
        assert_eq!(differ, 0);
        let near_zero = p.misfit(&[2.5]);
        assert!(near_zero < 1e-15, "{near_zero}");
        // The blocks differ from each other (other photons, other angle):
        // a row read against another block's curve would show.
        let n = m.points.len() / 4;
        let block = |k: usize| &m.points[k * n..(k + 1) * n];
        let apart = |a: &[(f64, f64, f64, Option<f64>)], b: &[(f64, f64, f64, Option<f64>)]| {
            a.iter()
                .zip(b)
                .filter(|(x, y)| (x.2 - y.2).abs() > 1e-6 * x.2.max(y.2))
                .count()
        };
        assert!(apart(block(1), block(2)) > n / 2, "(30, 90) vs (60, 0)");
        assert!(apart(block(0), block(1)) > n / 2, "(30, 0) vs (30, 90)");
        // The measured azimuths are traced, whatever the scene's.
        let one = truth.replace("phi_deg = [0.0, 90.0]", "phi_deg = 45.0");
        let p = Problem::new(&one, &scene_file(), &params, &m, &opts()).unwrap();
        assert!(p.misfit(&[2.5]) < 1e-15);
        // Without phi_i_deg: refused, naming the key.
        let rows = Measured {
            points: m.points.clone(),
            phi_i_deg: None,
        };
        let e = Problem::new(&truth, &scene_file(), &params, &rows, &opts()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.toml: light.phi_deg: roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces 2 light azimuths and the measurement has no phi_i_deg column: give each row's azimuth (column phi_i_deg after theta_i_deg, as inplane.csv of such a run has) or fit one azimuth ([light] phi_deg = P)"
        );
    }

    #[test]
    fn infeasible_points_have_infinite_misfit() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let m = Measured {
            points: vec![(30.0, 0.0, 1.0, None)],
            phi_i_deg: None,
        };
        // Each bound alone is valid (with the other end at its start value),
        // but the two ends can cross.
        let params: Vec<FitParam> = vec![
            "bumps[0].height[0]=0.5:1.6".parse().unwrap(),
            "bumps[0].height[1]=1.3:3".parse().unwrap(),
        ];
        let p = Problem::new(&truth, &scene_file(), &params, &m, &opts()).unwrap();
        // hi < lo: a reversed range.
        assert_eq!(p.misfit(&[1.5, 1.4]), f64::INFINITY);
        let e = p.apply(&[1.5, 1.4]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.toml: bumps[0].height: range [1.5, 1.4] is reversed"
        );
        assert_eq!(reason(&e), "bumps[0].height: range [1.5, 1.4] is reversed");
        assert!(p.misfit(&[1.4, 1.4]).is_finite());
        // Values the scene itself rejects.
        let r: FitParam = "materials.m.reflectance=0:1".parse().unwrap();
        let p = Problem::new(&truth, &scene_file(), &[r], &m, &opts()).unwrap();
        assert_eq!(p.misfit(&[1.5]), f64::INFINITY);
        assert!(matches!(
            p.model(&[1.5]),
            Err(Infeasible(FitError::Scene(_)))
        ));
        // The fitted scene text carries the value.
        let text = p.apply(&[0.25]).unwrap();
        let back = MicroScene::from_str(&text, scene_file(), "x".into()).unwrap();
        assert_eq!(back.surface.materials.len(), 1);
        assert_eq!(
            path("materials.m.reflectance").get_number(&table(&text)),
            Ok(0.25)
        );
    }

    #[test]
    fn problem_errors_name_file_and_key() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let m = Measured {
            points: vec![(30.0, 0.0, 1.0, None)],
            phi_i_deg: None,
        };
        let new = |spec: &str| {
            let p: FitParam = spec.parse().unwrap();
            Problem::new(&truth, &scene_file(), &[p], &m, &opts())
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            new("bumps[0].hieght=1:2"),
            "test.toml: --param bumps[0].hieght: no key `hieght` in `bumps[0]` (keys: count, height, radius, seed, shape)"
        );
        assert_eq!(
            new("bumps[1].height=1:2"),
            "test.toml: --param bumps[1].height: index [1] out of range: `bumps` has 1 element"
        );
        assert_eq!(
            new("bumps[0].shape=1:2"),
            "test.toml: --param bumps[0].shape: is a string, not a number"
        );
        assert_eq!(
            new("bumps[0].height=1:2"),
            "test.toml: --param bumps[0].height: is a range [1.0, 1.8]; fit one end: bumps[0].height[0] or bumps[0].height[1]"
        );
        // Bounds the scene rejects, found by building it at both bounds.
        assert_eq!(
            new("bumps[0].radius=0:3"),
            "test.toml: --param bumps[0].radius=0:3: at bumps[0].radius = 0, the scene is invalid: bumps[0].radius: must be > 0, got 0"
        );
        assert_eq!(
            new("bumps[0].height[1]=0.5:3"),
            "test.toml: --param bumps[0].height[1]=0.5:3: at bumps[0].height[1] = 0.5, the scene is invalid: bumps[0].height: range [1, 0.5] is reversed"
        );
        assert_eq!(
            new("materials.m.reflectance=0.5:1.5"),
            "test.toml: --param materials.m.reflectance=0.5:1.5: at materials.m.reflectance = 1.5, the scene is invalid: materials.m.reflectance: must be in [0, 1], got 1.5"
        );
        // A spectral scene: one model curve per angle and wavelength, where
        // the measurement has one per angle; one wavelength is fine.
        let spectral = |w: &str| {
            let text = truth.replace("[light]\n", &format!("[light]\nwavelengths_um = {w}\n"));
            let p: FitParam = "bumps[0].radius=1:3".parse().unwrap();
            Problem::new(&text, &scene_file(), &[p], &m, &opts()).map(|_| ())
        };
        assert_eq!(
            spectral("[0.45, 0.65]").unwrap_err().to_string(),
            "test.toml: light.wavelengths_um: roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces 2 wavelengths: fit one wavelength at a time ([light] wavelengths_um = [W])"
        );
        assert!(spectral("[0.55]").is_ok());
        let bad_scene = truth.replace("\"ellipsoid\"", "\"blob\"");
        let p: FitParam = "bumps[0].radius=1:2".parse().unwrap();
        let e = Problem::new(
            &bad_scene,
            &scene_file(),
            std::slice::from_ref(&p),
            &m,
            &opts(),
        )
        .unwrap_err();
        assert!(matches!(e, FitError::Scene(_)));
        assert!(
            e.to_string()
                .starts_with("test.toml: bumps[0].shape: unknown variant `blob`"),
            "{e}"
        );
        let e =
            Problem::new(&truth, &scene_file(), &[p.clone(), p.clone()], &m, &opts()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.toml: --param bumps[0].radius: given twice"
        );
        let e = Problem::new(&truth, &scene_file(), &[], &m, &opts()).unwrap_err();
        assert_eq!(e.to_string(), "--param: give at least one parameter");
        let o = FitOptions {
            inplane_step_deg: Some(7.0),
            ..opts()
        };
        let e = Problem::new(&truth, &scene_file(), &[p], &m, &o).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--inplane-step: must divide 180 into at most 18000 bins (a step of at least 0.01 deg), got 7"
        );
    }

    #[test]
    fn recovers_one_height() {
        // Same seed for data and fit: this tests the search and the pipeline
        // exactly (a wrong key path, interpolation or bound mapping misses
        // the exact zero), not the statistics; tests/fit_recovery.rs fits
        // data with independent noise.
        // Truth h = 1.8; start at 1.0 in bounds 0.5:3. With common random
        // numbers the misfit is exactly 0 at h = 1.8 and already ~1e-3 at
        // 1.8 -+ 0.001-0.01 (a scan of this scene), rising steadily to 0.9 at
        // h = 1.0; the search stops on a simplex 1e-3 of the range wide
        // (0.0025 in h). So h must come back to a few thousandths: we ask 0.01
        // (0.6 %).
        let truth = scene(PAINT, "1.8", 2.5);
        let m = measured_from(&truth);
        let start = scene(PAINT, "1.0", 2.5);
        let params = vec!["bumps[0].height=0.5:3".parse::<FitParam>().unwrap()];
        let clock = std::time::Instant::now();
        let r = fit(&start, &scene_file(), &params, &m, &opts()).unwrap();
        eprintln!(
            "one height: {:?} misfit {:.2e} (start {:.2e}) in {} runs, {:.2} s",
            r.values,
            r.misfit,
            r.start_misfit,
            r.evaluations,
            clock.elapsed().as_secs_f64()
        );
        assert_eq!(r.start, vec![1.0]);
        assert!(r.start_misfit > 0.1, "{}", r.start_misfit);
        assert!(r.converged);
        assert!((r.values[0] - 1.8).abs() < 0.01, "{:?}", r.values);
        assert!(r.misfit < 1e-4, "{}", r.misfit);
        assert_eq!(r.at_bounds, vec![Bound::Inside]);
        assert_eq!(r.evaluations, r.history.len());
        assert!(r.evaluations <= FitOptions::default().max_evaluations);
        assert_eq!(r.model.len(), m.points.len());
        // The best point is the least misfit of the history.
        let least = r.history.iter().map(|h| h.1).fold(f64::INFINITY, f64::min);
        assert_eq!(r.misfit, least);
    }

    #[test]
    fn recovers_one_end_of_a_range() {
        // height = [1.2, 2.2]; fit the top end from 1.5 in 1.2:3 (bounds
        // below 1.2 would reverse the range: refused before the fit).
        let truth = scene(PAINT, "[1.2, 2.2]", 2.5);
        let m = measured_from(&truth);
        let start = scene(PAINT, "[1.2, 1.5]", 2.5);
        let params = vec!["bumps[0].height[1]=1.2:3".parse::<FitParam>().unwrap()];
        let r = fit(&start, &scene_file(), &params, &m, &opts()).unwrap();
        eprintln!(
            "range end: {:?} misfit {:.2e} in {} runs",
            r.values, r.misfit, r.evaluations
        );
        assert!((r.values[0] - 2.2).abs() < 0.01, "{:?}", r.values);
        assert!(r.misfit < 1e-4, "{}", r.misfit);
    }

    #[test]
    fn rejected_points_are_recorded_with_their_reason() {
        // Both ends of the height range: each bound is valid with the other
        // end at its start (1.0 and 1.8), but the scan meets points where the
        // ends cross. They are recorded with the scene's reason, not dropped.
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let m = measured_from(&truth);
        let params: Vec<FitParam> = vec![
            "bumps[0].height[0]=0.5:1.75".parse().unwrap(),
            "bumps[0].height[1]=1.1:3".parse().unwrap(),
        ];
        let o = FitOptions {
            photons: 2000,
            scan: 4,
            max_evaluations: 20,
            restarts: 0,
            ..opts()
        };
        let mut seen = Vec::new();
        let r = Problem::new(&truth, &scene_file(), &params, &m, &o)
            .unwrap()
            .fit_observed(&mut |k, _, g, why| seen.push((k, g, why.map(str::to_string))))
            .unwrap();
        assert!(!r.rejected.is_empty());
        assert!(r.misfit.is_finite());
        for (k, why) in &r.rejected {
            let (v, g) = &r.history[*k];
            assert!(v[0] > v[1], "{v:?}");
            assert_eq!(*g, f64::INFINITY);
            assert_eq!(
                *why,
                format!("bumps[0].height: range [{}, {}] is reversed", v[0], v[1])
            );
            assert_eq!(seen[*k], (k + 1, f64::INFINITY, Some(why.clone())));
        }
        // Every infinite misfit of the history is a recorded rejection.
        let infinite = r.history.iter().filter(|h| h.1.is_infinite()).count();
        assert_eq!(infinite, r.rejected.len());
    }

    #[test]
    fn recovers_height_and_refractive_index() {
        // Fresnel dielectric n = 1.5 (k = 0), h = 1.8; start n = 1.2, h = 1.0.
        // Same argument as for one height; n's range 1.05:3 gives a stopping
        // box of 0.002 in n: ask 1 % for both.
        let truth = scene("n = 1.5\nk = 0.0", "1.8", 2.5);
        let m = measured_from(&truth);
        let start = scene("n = 1.2\nk = 0.0", "1.0", 2.5);
        let params: Vec<FitParam> = vec![
            "bumps[0].height=0.5:3".parse().unwrap(),
            "materials.m.n=1.05:3".parse().unwrap(),
        ];
        let clock = std::time::Instant::now();
        let r = fit(&start, &scene_file(), &params, &m, &opts()).unwrap();
        eprintln!(
            "height and n: {:?} misfit {:.2e} (start {:.2e}) in {} runs, {:.2} s",
            r.values,
            r.misfit,
            r.start_misfit,
            r.evaluations,
            clock.elapsed().as_secs_f64()
        );
        assert!(r.converged);
        assert!((r.values[0] - 1.8).abs() < 0.018, "{:?}", r.values);
        assert!((r.values[1] - 1.5).abs() < 0.015, "{:?}", r.values);
        assert!(r.misfit < 1e-4, "{}", r.misfit);
        assert_eq!(r.at_bounds, vec![Bound::Inside, Bound::Inside]);
    }

    #[test]
    fn reports_bounds() {
        // The truth (h = 1.8) lies above the bounds 0.5:1.5: the fit ends on
        // the upper bound and says so.
        let truth = scene(PAINT, "1.8", 2.5);
        let m = measured_from(&truth);
        let params = vec!["bumps[0].height=0.5:1.5".parse::<FitParam>().unwrap()];
        let start = scene(PAINT, "1.0", 2.5);
        let o = FitOptions {
            restarts: 0,
            ..opts()
        };
        let r = fit(&start, &scene_file(), &params, &m, &o).unwrap();
        assert_eq!(r.at_bounds, vec![Bound::Upper], "{:?}", r.values);
        assert!(
            r.values[0] >= 1.5 - 1e-3 * 1.0 && r.values[0] <= 1.5,
            "{:?}",
            r.values
        );
    }
}
