//! `summary.json` of `roks brdf` and `roks merge` ([`BrdfSummary`]), of
//! `roks trace` ([`TraceSummary`]), and `fit.json` of `roks fit`
//! ([`FitSummary`]), as typed structs.
//!
//! The files are pretty-printed JSON with a line end ([`to_text`]). Their
//! keys are in alphabetical order at every level, as they have always been
//! written: the fields of each struct are declared in that order. Numbers
//! are JSON numbers in Rust's shortest round-trip form; a quantity that is
//! not finite (e.g. `tests_per_segment` of a run without segments) is
//! `null`. Units: angles in degrees, times in seconds, reflectances and
//! `lost` weights as fractions of the photons launched.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::micro::Edges;
use crate::micro::surface_stats::SurfaceStats;
use crate::scene::Content;
use crate::shard::Shard;
use crate::transport::brdf::{BrdfResult, BrdfRun, IncidenceResult, RealisationResult};
use crate::transport::object::PositionResult;

mod reader;

pub use reader::{EntryKey, SummaryProblem};

/// A summary's text: pretty-printed JSON and a line end.
///
/// # Panics
/// Never for the structs of this module (every value serialises).
#[must_use]
pub fn to_text<T: Serialize>(summary: &T) -> String {
    serde_json::to_string_pretty(summary).expect("summaries serialise") + "\n"
}

/// Why `tau` and `sigma_over_tau` are undefined for a height map.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Undefined {
    /// `tau is <reason>`.
    pub sigma_over_tau: String,
    /// The reason, e.g. "undefined for a flat surface (sigma = 0)".
    pub tau: String,
}

/// Statistics of a surface's height map (lengths in the scene's units,
/// slopes dimensionless), `null` where undefined (then `undefined` says why).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Surface<F = f64> {
    /// Samples per side of the height map the statistics are taken on.
    pub height_map_resolution: usize,
    /// Highest height.
    pub max_height: Option<F>,
    /// Mean height.
    pub mean_height: Option<F>,
    /// Lowest height.
    pub min_height: Option<F>,
    /// RMS slope.
    pub rms_slope: Option<F>,
    /// RMS height.
    pub sigma: Option<F>,
    /// `sigma / tau`.
    pub sigma_over_tau: Option<F>,
    /// Correlation length.
    pub tau: Option<F>,
    /// The reasons for undefined statistics (absent when all are numbers).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub undefined: Option<Undefined>,
}

impl Surface<f64> {
    /// The statistics `stats` of a height map of `resolution` samples per
    /// side; non-finite ones undefined.
    #[must_use]
    pub fn new(stats: &SurfaceStats, resolution: usize) -> Self {
        let num = |x: f64| x.is_finite().then_some(x);
        Self {
            height_map_resolution: resolution,
            max_height: num(stats.max_height),
            mean_height: num(stats.mean),
            min_height: num(stats.min_height),
            rms_slope: num(stats.rms_slope),
            sigma: num(stats.sigma),
            sigma_over_tau: num(stats.sigma_over_tau),
            tau: num(stats.tau),
            undefined: stats.tau_undefined.map(|why| Undefined {
                sigma_over_tau: format!("tau is {why}"),
                tau: why.to_string(),
            }),
        }
    }
}

/// What identifies a `roks brdf` run besides its tallies, as
/// `summary.json` and `tallies.json` record it: the scene (its file as
/// given, name, edges and height-map statistics), the run as traced
/// ([`BrdfRun`]) and the roks version. Shards of one run have equal
/// descriptions but for `scene` (a path) and `run.shard`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Description {
    /// The scene's text and the files it reads, hashed: a scene given by
    /// another path to the same content is the same scene.
    pub content: Content,
    /// How the surface's edges are treated.
    pub edges: Edges,
    /// The scene's `name`.
    pub name: String,
    /// The run.
    pub run: BrdfRun,
    /// The scene file as given.
    pub scene: String,
    /// Statistics of the surface's height map.
    pub surface: Surface,
    /// The roks version that ran it.
    pub version: String,
}

impl Description {
    /// The description of `run` of the scene of `content` given as the
    /// file `scene`, named `name`, with `edges` and height-map statistics
    /// `surface`, by this roks.
    #[must_use]
    pub fn new(
        content: Content,
        scene: &str,
        name: &str,
        edges: Edges,
        run: BrdfRun,
        surface: Surface,
    ) -> Self {
        Self {
            content,
            edges,
            name: name.to_owned(),
            run,
            scene: scene.to_owned(),
            surface,
            version: env!("CARGO_PKG_VERSION").to_owned(),
        }
    }
}

/// One incidence of `summary.json` of `roks brdf`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IncidenceSummary {
    /// Histories cut by the caps.
    pub capped_photons: u64,
    /// A spectral run covering the visible: the colour of the reflectance
    /// spectrum (the light reflected into the whole hemisphere) under D65.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<ColourSummary>,
    /// Intersection tests (quadrics, or height-field squares).
    pub intersection_tests: u64,
    /// Weight lost, all causes.
    pub lost: f64,
    /// Weight cut by the caps.
    pub lost_cap: f64,
    /// Weight stopped by numerical guards.
    pub lost_numeric: f64,
    /// Weight absorbed by walls.
    pub lost_walls: f64,
    /// Mean reflections per photon.
    pub mean_bounces: f64,
    /// Histories stopped by numerical guards.
    pub numeric_guard_photons: u64,
    /// Incidence azimuth.
    pub phi_deg: f64,
    /// Photons launched.
    pub photons: u64,
    /// With several surface realisations: each one's reflectance and the
    /// spread between them beside the Monte Carlo error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub realisations: Option<RealisationsSummary>,
    /// Reflected weight per photon.
    pub reflectance: f64,
    /// Reflectance by number of reflections.
    pub reflectance_by_bounces: Vec<f64>,
    /// Standard error of `reflectance`: with several surface realisations
    /// (`[surface] realisations = R > 1`), that of the ensemble mean, from
    /// the spread between the realisations (`stderr_dof` degrees of
    /// freedom, see [`crate::transport::brdf::Ensemble`]); else from the
    /// photons (or the replicates of a lattice launch).
    pub reflectance_stderr: f64,
    /// With several surface realisations: the standard error of
    /// `reflectance` from the photons alone (the photon noise part of
    /// `reflectance_stderr`, without the surfaces' variation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflectance_stderr_photon: Option<f64>,
    /// With a Mueller tally: the hemisphere's Mueller matrix, row-major.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflected_mueller: Option<Vec<f64>>,
    /// Its standard errors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflected_mueller_stderr: Option<Vec<f64>>,
    /// With a Stokes tally: the reflected Stokes vector.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflected_stokes: Option<Vec<f64>>,
    /// Its standard errors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflected_stokes_stderr: Option<Vec<f64>>,
    /// Wall-clock time.
    pub seconds: f64,
    /// Straight flights traced.
    pub segments: u64,
    /// Segments per wall-clock second.
    pub segments_per_second: f64,
    /// A spectral run's results per wavelength (the entry's own
    /// `reflectance`, losses and polarisation sums are then their means over
    /// these wavelengths).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<Vec<WavelengthSummary>>,
    /// With several surface realisations: the degrees of freedom of the
    /// standard errors of this incidence (here and in `brdf.csv`,
    /// `inplane.csv`, `stokes.csv`, `mueller.csv`), `R - 1` for `R`
    /// realisations: the errors come from `R` values, so a
    /// `z = difference / stderr` follows Student's t with these degrees of
    /// freedom.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stderr_dof: Option<u64>,
    /// Intersection tests per segment.
    pub tests_per_segment: Option<f64>,
    /// Incidence polar angle.
    pub theta_deg: f64,
}

/// The reflectances of the surface realisations of one incidence
/// (`[surface] realisations = R`, R > 1) and how far they spread.
///
/// With `r_k` realisation `k`'s reflectance and `s_k` its Monte Carlo
/// standard error (its own photons): `spread` is the sample standard
/// deviation `sqrt(sum (r_k - mean)² / (R - 1))`; `monte_carlo_spread` =
/// `sqrt(sum s_k² / R)` the spread photon noise alone would give;
/// `surface_spread` = `sqrt(max(0, spread² - monte_carlo_spread²))` the
/// part that comes from the surfaces differing. When `surface_spread`
/// dominates, more realisations (not more photons) narrow the ensemble's
/// error. `spread / sqrt(R)` is the error of the mean over realisations,
/// which includes the surfaces' variation; the incidence's
/// `reflectance_stderr` is that of the ensemble mean (the same for
/// realisations of equal photons; photon-weighted otherwise, see
/// [`crate::transport::brdf::Ensemble`]) and `reflectance_stderr_photon`
/// its Monte Carlo part, from all photons.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealisationsSummary {
    /// `sqrt(sum s_k² / R)`.
    pub monte_carlo_spread: f64,
    /// Photons of each realisation.
    pub photons: Vec<u64>,
    /// Reflectance of each realisation.
    pub reflectance: Vec<f64>,
    /// Its Monte Carlo standard error.
    pub reflectance_stderr: Vec<f64>,
    /// Sample standard deviation of the realisations' reflectances.
    pub spread: f64,
    /// `spread / sqrt(R)`: the standard error of the mean over realisations.
    pub spread_stderr_of_mean: f64,
    /// `sqrt(max(0, spread² - monte_carlo_spread²))`.
    pub surface_spread: f64,
}

impl RealisationsSummary {
    /// The summary of `realisations` (`None` for fewer than 2).
    #[must_use]
    pub fn new(realisations: &[RealisationResult]) -> Option<Self> {
        let count = realisations.len();
        if count < 2 {
            return None;
        }
        let n = count as f64;
        let reflectance: Vec<f64> = realisations.iter().map(|r| r.reflectance).collect();
        let reflectance_stderr: Vec<f64> =
            realisations.iter().map(|r| r.reflectance_stderr).collect();
        let mean = reflectance.iter().sum::<f64>() / n;
        let spread =
            (reflectance.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let monte_carlo_spread = (reflectance_stderr.iter().map(|s| s * s).sum::<f64>() / n).sqrt();
        Some(Self {
            monte_carlo_spread,
            photons: realisations.iter().map(|r| r.photons).collect(),
            reflectance,
            reflectance_stderr,
            spread,
            spread_stderr_of_mean: spread / n.sqrt(),
            surface_spread: (spread * spread - monte_carlo_spread * monte_carlo_spread)
                .max(0.0)
                .sqrt(),
        })
    }

    /// The mean, realisation by realisation, of the summaries of several
    /// wavelengths (of a spectral run: reflectances and their errors
    /// averaged, spreads recomputed from those).
    fn mean(all: &[&Self]) -> Option<Self> {
        let first = all.first()?;
        let n = all.len() as f64;
        let per = |k: usize| RealisationResult {
            photons: first.photons[k],
            reflectance: all.iter().map(|a| a.reflectance[k]).sum::<f64>() / n,
            reflectance_stderr: all.iter().map(|a| a.reflectance_stderr[k]).sum::<f64>() / n,
        };
        Self::new(&(0..first.photons.len()).map(per).collect::<Vec<_>>())
    }
}

/// The colour of a reflectance spectrum under the CIE D65 illuminant
/// ([`crate::optics::colour`]: CIE 1931 2-degree observer, the perfect
/// white reflector at `Y = 1`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColourSummary {
    /// 8-bit sRGB (clipped to the gamut, sRGB transfer function).
    pub srgb8: [u8; 3],
    /// Linear sRGB, not clipped.
    pub srgb_linear: [f64; 3],
    /// CIE XYZ.
    pub xyz: [f64; 3],
}

impl ColourSummary {
    /// The colour of `values` at `wavelengths_um`; `None` unless they cover
    /// the visible.
    #[must_use]
    pub fn new(wavelengths_um: &[f64], values: &[f64]) -> Option<Self> {
        let xyz = crate::optics::colour::xyz_d65(wavelengths_um, values)?;
        let linear = crate::optics::colour::xyz_to_linear_srgb(xyz);
        Some(Self {
            srgb8: crate::optics::colour::srgb8(linear),
            srgb_linear: linear,
            xyz,
        })
    }
}

/// One wavelength of an incidence of a spectral run's `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WavelengthSummary {
    /// Weight lost, all causes.
    pub lost: f64,
    /// Weight cut by the caps.
    pub lost_cap: f64,
    /// Weight stopped by numerical guards.
    pub lost_numeric: f64,
    /// Weight absorbed by walls.
    pub lost_walls: f64,
    /// Reflected weight per photon at this wavelength.
    pub reflectance: f64,
    /// Standard error of `reflectance`.
    pub reflectance_stderr: f64,
    /// With a Mueller tally: the hemisphere's Mueller matrix, row-major.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflected_mueller: Option<Vec<f64>>,
    /// With a Stokes tally: the reflected Stokes vector.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflected_stokes: Option<Vec<f64>>,
    /// Vacuum wavelength (µm).
    pub wavelength_um: f64,
}

impl WavelengthSummary {
    /// The entry of one wavelength's result.
    #[must_use]
    pub fn new(r: &IncidenceResult) -> Self {
        let one = IncidenceSummary::new(r);
        Self {
            lost: one.lost,
            lost_cap: one.lost_cap,
            lost_numeric: one.lost_numeric,
            lost_walls: one.lost_walls,
            reflectance: one.reflectance,
            reflectance_stderr: one.reflectance_stderr,
            reflected_mueller: one.reflected_mueller,
            reflected_stokes: one.reflected_stokes,
            wavelength_um: r.wavelength_um.unwrap_or(f64::NAN),
        }
    }
}

/// The mean of each position of equal-length vectors.
fn mean_vectors<'a>(vs: impl Iterator<Item = &'a Vec<f64>> + Clone) -> Vec<f64> {
    let count = vs.clone().count().max(1) as f64;
    let len = vs.clone().next().map_or(0, Vec::len);
    (0..len)
        .map(|i| vs.clone().map(|v| v[i]).sum::<f64>() / count)
        .collect()
}

impl IncidenceSummary {
    /// The entry of one incidence of a spectral run from its results per
    /// wavelength (`lanes`, in order): counts and times are the trace's
    /// (the same for every wavelength); `reflectance`, the losses,
    /// `reflectance_by_bounces` and polarisation sums are means over the
    /// wavelengths; `reflectance_stderr` is the mean of the wavelengths'
    /// standard errors, an upper bound of the mean's (the wavelengths share
    /// their photons, so their errors are correlated).
    #[must_use]
    pub fn spectral(lanes: &[IncidenceResult]) -> Self {
        let all: Vec<Self> = lanes.iter().map(Self::new).collect();
        let count = all.len().max(1) as f64;
        let mean = |f: fn(&Self) -> f64| all.iter().map(f).sum::<f64>() / count;
        let mean_opt = |f: fn(&Self) -> &Option<Vec<f64>>| {
            all.iter()
                .map(|e| f(e).as_ref())
                .collect::<Option<Vec<&Vec<f64>>>>()
                .map(|v| mean_vectors(v.into_iter()))
        };
        let mut first = all[0].clone();
        first.lost = mean(|e| e.lost);
        first.lost_cap = mean(|e| e.lost_cap);
        first.lost_numeric = mean(|e| e.lost_numeric);
        first.lost_walls = mean(|e| e.lost_walls);
        first.reflectance = mean(|e| e.reflectance);
        first.reflectance_stderr = mean(|e| e.reflectance_stderr);
        first.reflectance_stderr_photon = all
            .iter()
            .map(|e| e.reflectance_stderr_photon)
            .sum::<Option<f64>>()
            .map(|s| s / count);
        first.reflectance_by_bounces = mean_vectors(all.iter().map(|e| &e.reflectance_by_bounces));
        first.reflected_mueller = mean_opt(|e| &e.reflected_mueller);
        first.reflected_mueller_stderr = mean_opt(|e| &e.reflected_mueller_stderr);
        first.reflected_stokes = mean_opt(|e| &e.reflected_stokes);
        first.reflected_stokes_stderr = mean_opt(|e| &e.reflected_stokes_stderr);
        let wavelengths: Vec<f64> = lanes.iter().filter_map(|r| r.wavelength_um).collect();
        let reflectances: Vec<f64> = all.iter().map(|e| e.reflectance).collect();
        first.colour = ColourSummary::new(&wavelengths, &reflectances);
        first.spectrum = Some(lanes.iter().map(WavelengthSummary::new).collect());
        first.realisations = RealisationsSummary::mean(
            &all.iter()
                .filter_map(|e| e.realisations.as_ref())
                .collect::<Vec<_>>(),
        );
        first
    }
}

impl IncidenceSummary {
    /// The entry of one incidence's result (of a monochrome run).
    #[must_use]
    pub fn new(r: &IncidenceResult) -> Self {
        let t = &r.tallies;
        let (reflectance, reflectance_stderr) = r.reflectance();
        let n = t.photons as f64;
        let polar = t.polar.as_ref().map(|p| {
            let pairs: Vec<(f64, f64)> = (0..p.components)
                .map(|i| r.polar(i).unwrap_or_default())
                .collect();
            (
                p.components == 4,
                pairs.iter().map(|x| x.0).collect::<Vec<_>>(),
                pairs.iter().map(|x| x.1).collect::<Vec<_>>(),
            )
        });
        let (stokes, mueller) = match polar {
            Some((true, m, s)) => (Some((m, s)), None),
            Some((false, m, s)) => (None, Some((m, s))),
            None => (None, None),
        };
        let tests = r.tests_per_segment();
        Self {
            capped_photons: t.capped_histories,
            colour: None,
            intersection_tests: t.intersection_tests,
            lost: r.lost(),
            lost_cap: t.lost_cap / n,
            lost_numeric: t.lost_numeric / n,
            lost_walls: t.lost_walls / n,
            mean_bounces: r.mean_bounces(),
            numeric_guard_photons: t.numeric_histories,
            phi_deg: r.phi_i_deg,
            photons: t.photons,
            realisations: RealisationsSummary::new(&r.realisations),
            reflectance,
            reflectance_by_bounces: t.by_bounces.iter().map(|w| w / n).collect(),
            reflectance_stderr,
            reflectance_stderr_photon: (!r.realisations.is_empty())
                .then(|| r.reflectance_stderr_photon()),
            reflected_mueller_stderr: mueller.as_ref().map(|x| x.1.clone()),
            reflected_mueller: mueller.map(|x| x.0),
            reflected_stokes_stderr: stokes.as_ref().map(|x| x.1.clone()),
            reflected_stokes: stokes.map(|x| x.0),
            seconds: r.seconds,
            segments: t.segments,
            segments_per_second: r.segments_per_second(),
            spectrum: None,
            stderr_dof: r.stderr_dof(),
            tests_per_segment: tests.is_finite().then_some(tests),
            theta_deg: r.theta_i_deg,
        }
    }
}

/// `summary.json` of `roks brdf` (and `roks merge`): the run's
/// [`Description`] (its fields at the top level, the run under `run`), its
/// results per incidence and the time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrdfSummary {
    /// With several light azimuths: how far the tables depart from
    /// isotropy ([`crate::tally::anisotropy`]); absent for one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anisotropy: Option<crate::tally::anisotropy::Anisotropy>,
    /// The scene's text and the files it reads, hashed.
    pub content: Content,
    /// How the surface's edges are treated.
    pub edges: Edges,
    /// Per incidence angle.
    pub incidence: Vec<IncidenceSummary>,
    /// The scene's `name`.
    pub name: String,
    /// The run (for a shard: the whole run's photons and the shard's block).
    pub run: BrdfRun,
    /// The scene file as given.
    pub scene: String,
    /// Total wall-clock time (the shards' sum, for a merge).
    pub seconds: f64,
    /// Statistics of the surface's height map.
    pub surface: Surface,
    /// The roks version that ran it.
    pub version: String,
}

impl BrdfSummary {
    /// The summary of the run `description`, its `results`, total time
    /// `seconds`: one entry per incidence (and azimuth), its wavelengths
    /// summed up ([`IncidenceSummary::spectral`]) for a spectral run.
    #[must_use]
    pub fn new(description: &Description, results: &BrdfResult, seconds: f64) -> Self {
        let d = description.clone();
        let spectral = !d.run.wavelengths_um.is_empty();
        Self {
            anisotropy: results.anisotropy(&d.run.grid()),
            content: d.content,
            edges: d.edges,
            incidence: results
                .groups()
                .map(|lanes| {
                    if spectral {
                        IncidenceSummary::spectral(lanes)
                    } else {
                        IncidenceSummary::new(&lanes[0])
                    }
                })
                .collect(),
            name: d.name,
            run: d.run,
            scene: d.scene,
            seconds,
            surface: d.surface,
            version: d.version,
        }
    }
}

/// One beam position of `summary.json` of `roks trace`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionSummary {
    /// Weight absorbed per photon, by surface name (surfaces that absorbed).
    pub absorbed: BTreeMap<String, f64>,
    /// Its standard errors.
    pub absorbed_stderr: BTreeMap<String, f64>,
    /// Beam diameter (scene units).
    pub diameter: f64,
    /// Unit direction of travel.
    pub direction: [f64; 3],
    /// Weight lost to caps and guards, per photon.
    pub lost: f64,
    /// Macro reflections per photon.
    pub mean_bounces: f64,
    /// Weight escaping without a reflection, per photon.
    pub missed: f64,
    /// Photons launched.
    pub photons: u64,
    /// The beam's polarisation state (polarised runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polarisation: Option<String>,
    /// A point on the beam axis (scene units).
    pub position: [f64; 3],
    /// Reflected weight per photon.
    pub reflectance: f64,
    /// Its standard error.
    pub reflectance_stderr: f64,
    /// Wall-clock time.
    pub seconds: f64,
    /// Straight flights at the macro level.
    pub segments: u64,
    /// A spectral run's results per wavelength (the entry's own
    /// `reflectance`, `missed`, `lost`, `absorbed` and Stokes sums are then
    /// their means over these wavelengths).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<Vec<PositionWavelengthSummary>>,
    /// Stokes vector of the reflected light (polarised runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stokes: Option<[f64; 4]>,
    /// Its standard errors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stokes_stderr: Option<[f64; 4]>,
}

/// One wavelength of a beam position of a spectral `roks trace` run.
///
/// `emissivity` is `1 - reflectance - missed`: the share of the beam's
/// flux the object keeps (absorbed, by the energy balance; `lost` aside).
/// By Kirchhoff's law and reciprocity it is the effective (directional)
/// emissivity of the cavity toward the reversed beam direction, over the
/// beam's footprint, when the walls are opaque (no transmission), the
/// cavity is isothermal and the beam enters it fully (`missed = 0`): then
/// the directional emissivity equals the directional-hemispherical
/// absorptance `1 - reflectance`. With `missed > 0` the beam is partly
/// outside the aperture and the number is only the absorbed share.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionWavelengthSummary {
    /// Weight absorbed per photon, by surface name (surfaces that absorbed
    /// at this wavelength).
    pub absorbed: BTreeMap<String, f64>,
    /// Its standard errors.
    pub absorbed_stderr: BTreeMap<String, f64>,
    /// `1 - reflectance - missed` (see the type's docs).
    pub emissivity: f64,
    /// Weight lost to caps and guards, per photon.
    pub lost: f64,
    /// Weight escaping without a reflection, per photon.
    pub missed: f64,
    /// Reflected weight per photon at this wavelength.
    pub reflectance: f64,
    /// Its standard error.
    pub reflectance_stderr: f64,
    /// Stokes vector of the reflected light (polarised runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stokes: Option<[f64; 4]>,
    /// Vacuum wavelength (µm).
    pub wavelength_um: f64,
}

impl PositionWavelengthSummary {
    /// The entry of one wavelength's result.
    #[must_use]
    pub fn new(r: &PositionResult, surface_names: &[String]) -> Self {
        let one = PositionSummary::new(r, surface_names);
        Self {
            absorbed: one.absorbed,
            absorbed_stderr: one.absorbed_stderr,
            emissivity: 1.0 - one.reflectance - one.missed,
            lost: one.lost,
            missed: one.missed,
            reflectance: one.reflectance,
            reflectance_stderr: one.reflectance_stderr,
            stokes: one.stokes,
            wavelength_um: r.wavelength_um.unwrap_or(f64::NAN),
        }
    }
}

impl PositionSummary {
    /// The entry of one beam position of a spectral run from its results
    /// per wavelength (`lanes`, in order): counts and times are the trace's
    /// (the same for every wavelength); `reflectance`, `missed`, `lost`,
    /// `absorbed` (by every surface that absorbed at some wavelength) and
    /// the Stokes sums are means over the wavelengths, and their standard
    /// errors the means of the wavelengths' standard errors, an upper bound
    /// of the mean's (the wavelengths share their photons).
    #[must_use]
    pub fn spectral(lanes: &[PositionResult], surface_names: &[String]) -> Self {
        let all: Vec<Self> = lanes.iter().map(|r| Self::new(r, surface_names)).collect();
        let count = all.len().max(1) as f64;
        let mean = |f: &dyn Fn(&Self) -> f64| all.iter().map(f).sum::<f64>() / count;
        let mean_map = |f: &dyn Fn(&Self) -> &BTreeMap<String, f64>| {
            let mut m = BTreeMap::new();
            for e in &all {
                for (k, v) in f(e) {
                    *m.entry(k.clone()).or_insert(0.0) += v;
                }
            }
            m.values_mut().for_each(|v| *v /= count);
            m
        };
        let mean4 = |f: &dyn Fn(&Self) -> Option<[f64; 4]>| {
            let vs: Option<Vec<[f64; 4]>> = all.iter().map(f).collect();
            vs.map(|vs| std::array::from_fn(|j| vs.iter().map(|v| v[j]).sum::<f64>() / count))
        };
        let mut first = all[0].clone();
        first.absorbed = mean_map(&|e| &e.absorbed);
        first.absorbed_stderr = mean_map(&|e| &e.absorbed_stderr);
        first.lost = mean(&|e| e.lost);
        first.missed = mean(&|e| e.missed);
        first.reflectance = mean(&|e| e.reflectance);
        first.reflectance_stderr = mean(&|e| e.reflectance_stderr);
        first.stokes = mean4(&|e| e.stokes);
        first.stokes_stderr = mean4(&|e| e.stokes_stderr);
        first.spectrum = Some(
            lanes
                .iter()
                .map(|r| PositionWavelengthSummary::new(r, surface_names))
                .collect(),
        );
        first
    }

    /// The entry of one beam position's result; `surface_names` by surface id.
    #[must_use]
    pub fn new(r: &PositionResult, surface_names: &[String]) -> Self {
        let t = &r.tallies;
        // A shard's position without photons of its own: zeros, not NaN.
        let n = t.photons.max(1) as f64;
        let (reflectance, reflectance_stderr) = r.reflectance();
        let absorbed = |f: &dyn Fn(usize) -> f64| -> BTreeMap<String, f64> {
            surface_names
                .iter()
                .enumerate()
                .filter(|(i, _)| t.absorbed.sum[*i] != 0.0)
                .map(|(i, name)| (name.clone(), f(i)))
                .collect()
        };
        let stokes = r.stokes();
        Self {
            absorbed: absorbed(&|i| t.absorbed.mean(i, t.photons)),
            absorbed_stderr: absorbed(&|i| t.absorbed.stderr(i, t.photons)),
            diameter: r.beam.diameter,
            direction: r.beam.direction.to_array(),
            lost: t.lost / n,
            mean_bounces: t.bounces as f64 / n,
            missed: t.missed / n,
            photons: t.photons,
            polarisation: stokes.map(|_| r.beam.polarisation.name()),
            position: r.beam.position.to_array(),
            reflectance,
            reflectance_stderr,
            seconds: r.seconds,
            segments: t.segments,
            spectrum: None,
            stokes: stokes.map(|s| s.0),
            stokes_stderr: stokes.map(|s| s.1),
        }
    }
}

/// `summary.json` of `roks trace`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceSummary {
    /// The scene's text and the files it reads, hashed (empty when read
    /// from an older file without it).
    #[serde(default)]
    pub content: Content,
    /// Whether the far field was tallied (`[tally] farfield = true`): then
    /// the folder holds `farfield.csv`, else it was never written (false
    /// when read from an older file without the key).
    #[serde(default)]
    pub farfield: bool,
    /// Whether the Stokes vector was tallied per far-field cell (`[tally]
    /// polarisation = "stokes"` with polarised transport): then the folder
    /// holds `farfield_stokes.csv`.
    #[serde(default)]
    pub farfield_stokes: bool,
    /// The scene's `name`.
    pub name: String,
    /// The scene file as given.
    pub scene: String,
    /// Total wall-clock time.
    pub seconds: f64,
    /// Tracing seed.
    pub seed: u64,
    /// The block of a shard (`roks trace --shard I/N`; its sums are that
    /// block's only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<TraceShard>,
    /// Per beam position, in the order of the scene's sources.
    pub sources: Vec<PositionSummary>,
    /// The roks version that ran it.
    pub version: String,
    /// Wavelengths (µm) of a spectral run (absent: monochrome).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub wavelengths_um: Vec<f64>,
}

/// `--shard I/N` of a `roks trace` run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceShard {
    /// Number of shards.
    pub count: u64,
    /// This shard, 0-based.
    pub index: u64,
}

impl From<Shard> for TraceShard {
    fn from(s: Shard) -> Self {
        Self {
            count: s.count,
            index: s.index,
        }
    }
}

/// One fitted parameter of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitParameter {
    /// Which bound it ended on (`none`, `lower`, `upper`).
    pub at_bound: String,
    /// Fitted value.
    pub fitted: f64,
    /// Upper bound.
    pub hi: f64,
    /// The scene key, e.g. `bumps[0].height[1]`.
    pub key: String,
    /// Lower bound.
    pub lo: f64,
    /// Start value.
    pub start: f64,
}

/// One model run of a fit: parameter values and misfit (`null` and the
/// scene's reason for a rejected point).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitStep {
    /// Misfit (`null`: rejected).
    pub misfit: Option<f64>,
    /// Why the scene rejected the point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rejected: Option<String>,
    /// Parameter values.
    pub values: Vec<f64>,
}

/// `fit.json` of `roks fit`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSummary {
    /// True if the tolerances were met.
    pub converged: bool,
    /// Model runs made.
    pub evaluations: usize,
    /// Every model run.
    pub history: Vec<FitStep>,
    /// The measured file as given.
    pub measured: String,
    /// Misfit at the fitted values.
    pub misfit: f64,
    /// Per parameter.
    pub parameters: Vec<FitParameter>,
    /// Photons per model run.
    pub photons: u64,
    /// Model runs the scene rejected.
    pub rejected_evaluations: usize,
    /// The scene file as given.
    pub scene: String,
    /// Tracing seed.
    pub seed: u64,
    /// Misfit at the start values.
    pub start_misfit: f64,
    /// The roks version that ran it.
    pub version: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::brdf_folder::BrdfFolder;
    use crate::scene::micro::MicroScene;

    /// The text with keys in declaration order equals the text of the same
    /// JSON with sorted keys (`serde_json::Value` sorts them): the structs
    /// keep the files' alphabetical key order.
    fn assert_sorted<T: Serialize>(x: &T) {
        let sorted = serde_json::to_value(x).unwrap();
        assert_eq!(
            to_text(x),
            serde_json::to_string_pretty(&sorted).unwrap() + "\n"
        );
    }

    #[test]
    fn summaries_keep_the_keys_in_alphabetical_order() {
        let scene = MicroScene::default_scene();
        let mut run = scene.brdf_run();
        run.photons = 5000;
        run.theta_deg = vec![20.0];
        run.bands = 2;
        let stats = crate::micro::surface_stats::surface_stats(&scene.surface.height_map(16, 16));
        let mut surface = Surface::new(&stats, 16);
        surface.undefined = Some(Undefined {
            sigma_over_tau: "tau is x".into(),
            tau: "x".into(),
        });
        run.polarisation.transport = true;
        run.polarisation.incident = crate::optics::polarisation::Incident::Linear(30.0);
        run.polarisation.tally = crate::tally::PolarTally::Stokes;
        run.shard = Some(crate::transport::brdf::ShardRange {
            count: 2,
            first_photon: 4096,
            index: 1,
            last_photon: 5000,
        });
        let description = Description::new(
            scene.content.clone(),
            "s.toml",
            "s",
            Edges::Periodic,
            run,
            surface,
        );
        let results = description.run.trace_whole(&scene.surface, &|_| {});
        let folder = BrdfFolder::traced(description, results, 0.0);
        let mut summary = folder.summary();
        assert_eq!(summary.run.photons, 5000);
        assert_eq!(summary.incidence[0].photons, 5000 - 4096);
        summary.incidence[0].reflected_stokes = Some(vec![0.5; 4]);
        summary.incidence[0].reflected_stokes_stderr = Some(vec![0.1; 4]);
        assert_sorted(&summary);
        summary.incidence[0].reflected_mueller = Some(vec![0.5; 16]);
        summary.incidence[0].reflected_mueller_stderr = Some(vec![0.1; 16]);
        assert_sorted(&summary);
        assert_sorted(folder.tallies.as_ref().unwrap());

        let position = PositionSummary {
            absorbed: [("b".to_owned(), 0.1), ("a".to_owned(), 0.2)].into(),
            absorbed_stderr: BTreeMap::new(),
            diameter: 1.0,
            direction: [0.0, 0.0, -1.0],
            lost: 0.0,
            mean_bounces: 1.5,
            missed: 0.25,
            photons: 10,
            polarisation: Some("s".into()),
            position: [1.0, 2.0, 3.0],
            reflectance: 0.5,
            reflectance_stderr: 0.01,
            seconds: 0.1,
            segments: 30,
            spectrum: Some(vec![PositionWavelengthSummary {
                absorbed: [("b".to_owned(), 0.1), ("a".to_owned(), 0.2)].into(),
                absorbed_stderr: BTreeMap::new(),
                emissivity: 0.25,
                lost: 0.0,
                missed: 0.25,
                reflectance: 0.5,
                reflectance_stderr: 0.01,
                stokes: Some([0.5, 0.1, 0.0, 0.0]),
                wavelength_um: 3.0,
            }]),
            stokes: Some([0.5, 0.1, 0.0, 0.0]),
            stokes_stderr: Some([0.01; 4]),
        };
        assert_sorted(&TraceSummary {
            content: Content::default(),
            farfield: true,
            farfield_stokes: false,
            name: "n".into(),
            scene: "s.toml".into(),
            seconds: 1.0,
            seed: 1,
            shard: None,
            sources: vec![position],
            version: "0".into(),
            wavelengths_um: vec![3.0],
        });
        assert_sorted(&FitSummary {
            converged: true,
            evaluations: 2,
            history: vec![
                FitStep {
                    misfit: Some(0.5),
                    rejected: None,
                    values: vec![1.0],
                },
                FitStep {
                    misfit: None,
                    rejected: Some("why".into()),
                    values: vec![2.0],
                },
            ],
            measured: "m.csv".into(),
            misfit: 0.5,
            parameters: vec![FitParameter {
                at_bound: "none".into(),
                fitted: 1.0,
                hi: 2.0,
                key: "k".into(),
                lo: 0.0,
                start: 1.5,
            }],
            photons: 100,
            rejected_evaluations: 1,
            scene: "s.toml".into(),
            seed: 1,
            start_misfit: 0.7,
            version: "0".into(),
        });
    }
}
