//! Every picture of a result folder, made from the folder's files: the one
//! path by which `roks brdf`, `roks merge` and `roks trace` draw their
//! pictures (from the files they are about to write) and `roks plot`
//! redraws them (from the files on disk).
//!
//! A micro folder (`summary.json` of `roks brdf` or `merge`):
//! * `hemisphere_<θ>deg.png` per incidence, from `brdf.csv` (a spectral
//!   run: the mean BRDF over its wavelengths);
//! * `inplane.png`, from `inplane.csv`: one curve per incidence;
//! * `reflectance.png`, from `summary.json`: reflectance against incidence;
//! * with `stokes.csv`: `dop_<θ>deg.png`, the degree of polarisation;
//! * with `mueller.csv`: `mueller_<θ>deg.png` and `mueller_stderr_<θ>deg.png`
//!   (a spectral run: per wavelength, `mueller_<θ>deg_<λ>um.png`, ...);
//! * with `colour.csv`: `colour_<θ>deg.png`.
//!
//! A run with several light azimuths has these pictures per incidence and
//! azimuth, `_phi<φ>` after the incidence's `deg`
//! ([`crate::output::at_azimuth`]: `hemisphere_30deg_phi45.png`), one curve
//! per incidence and azimuth in `inplane.png`, and one reflectance curve
//! per azimuth.
//!
//! An object folder (`summary.json` of `roks trace`): `reflectance.png`,
//! reflectance against beam position (a spectral run: against wavelength,
//! one curve per beam position).
//!
//! Titles give the photons per incidence (or per beam position) and, for a
//! spectral run, that the same photons carry every wavelength. The surface
//! picture (`surface.png`) needs the surface itself, not its results: see
//! [`super::SurfacePicture`].

use std::collections::BTreeMap;
use std::path::Path;

use rayon::prelude::*;

use super::mueller::MuellerKind;
use super::{Grid, HemisphereMap, LinePlot, MapScale, MuellerMaps, Panel, Series};
use crate::outdir::file::{ResultFile, ResultPattern};
use crate::output::number_label;
use crate::output::polar_csv::MuellerFile;
use crate::output::result_tables::TablesError;
use crate::output::result_tables::{IncidenceSums, InplaneRow, MicroTables, ResultTables};
use crate::output::summary::{BrdfSummary, TraceSummary};
use crate::tally::CarlsonGrid;

/// Size of `inplane.png` and of the reflectance plots (pixels).
const LINE_SIZE: (u32, u32) = (1100, 640);

/// A picture before it is drawn.
enum Picture {
    Line(LinePlot),
    Map(HemisphereMap),
    Mueller(MuellerMaps),
}

impl Picture {
    fn png(&self) -> anyhow::Result<Vec<u8>> {
        match self {
            Self::Line(p) => {
                let (w, h) = p.size(LINE_SIZE.0, LINE_SIZE.1);
                p.to_png(w, h)
            }
            Self::Map(m) => m.to_png(),
            Self::Mueller(m) => m.to_png(),
        }
    }
}

/// Why the pictures of a result folder cannot be made: the file (and line)
/// that cannot be read, or the picture that cannot be drawn. One line.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A file of the folder that is missing or does not fit.
    #[error("{0}")]
    File(#[from] TablesError),
    /// A picture that cannot be drawn.
    #[error("{name}: {error}")]
    Draw {
        /// The picture's file name.
        name: String,
        /// The drawing's error.
        error: anyhow::Error,
    },
    /// A folder on disk ([`pictures_in`]).
    #[error("{}: {error}", dir.display())]
    Folder {
        /// The folder.
        dir: std::path::PathBuf,
        /// The error of its files.
        error: Box<PlotError>,
    },
}

/// Every picture of a result folder, from its typed tables, each as its
/// file name and PNG bytes.
///
/// # Errors
/// A picture that cannot be drawn.
pub fn pictures(tables: &ResultTables) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
    let pictures = match tables {
        ResultTables::Micro(t) => micro(t),
        ResultTables::Object(s) => vec![(
            ResultFile::ReflectancePicture.name().to_owned(),
            Picture::Line(object_reflectance(s)),
        )],
    };
    pictures
        .par_iter()
        .map(|(name, p)| {
            p.png()
                .map(|png| (name.clone(), png))
                .map_err(|error| PlotError::Draw {
                    name: name.clone(),
                    error,
                })
        })
        .collect()
}

/// [`pictures`] of a folder's files as `(name, bytes)` (those of a folder
/// about to be written), read by [`ResultTables::of`].
///
/// # Errors
/// A file that cannot be read, or a picture that cannot be drawn.
pub fn pictures_of(files: &[(String, Vec<u8>)]) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
    pictures(&ResultTables::of(files)?)
}

/// Add the [`pictures`] of a folder's files (about to be written) to them.
///
/// # Errors
/// As [`pictures_of`].
pub fn add_pictures(files: &mut Vec<(String, Vec<u8>)>) -> Result<(), PlotError> {
    let pictures = pictures_of(files)?;
    files.extend(pictures);
    Ok(())
}

/// [`pictures`] of the folder `dir` on disk, read by
/// [`ResultTables::read_dir`].
///
/// # Errors
/// As [`pictures_of`], the file names relative to `dir`.
pub fn pictures_in(dir: &Path) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
    ResultTables::read_dir(dir)
        .map_err(PlotError::from)
        .and_then(|t| pictures(&t))
        .map_err(|e| PlotError::Folder {
            dir: dir.to_path_buf(),
            error: Box::new(e),
        })
}

/// What a micro run's titles say of its photons: per incidence, and for a
/// spectral run that they carry every wavelength.
fn photons_text(s: &BrdfSummary) -> String {
    // The photons this folder holds (a shard's block, or the whole run).
    let n = s.incidence.first().map_or(s.run.photons, |i| i.photons);
    match s.run.wavelengths_um.len() {
        0 => format!("{n} photons per incidence"),
        l => format!("{n} photons per incidence, each carrying all {l} wavelengths"),
    }
}

/// What every picture of one micro folder shares: its tables, the titles'
/// photons text and wavelength note, and how it names an incidence.
struct Micro<'a> {
    t: &'a MicroTables,
    photons: String,
    /// `, mean over the wavelengths` for a spectral run.
    mean: &'static str,
    /// Several light azimuths: the azimuth in every picture's name and title.
    several: bool,
}

impl Micro<'_> {
    /// The picture `name` of one incidence at light azimuth `phi`.
    fn file(&self, name: &str, phi: f64) -> String {
        crate::output::at_azimuth(name, self.several.then_some(phi))
    }

    /// The incidence in a title.
    fn at(&self, theta: f64, phi: f64) -> String {
        if self.several {
            format!("θi = {theta}°, φi = {phi}°")
        } else {
            format!("θi = {theta}°")
        }
    }

    /// A hemisphere map of one incidence.
    fn map(&self, b: &IncidenceSums, title: String, values: Vec<f64>, scale: MapScale) -> Picture {
        Picture::Map(HemisphereMap {
            title,
            grid: self.t.grid,
            values,
            scale,
            empty_label: "no photon".into(),
            theta_i_deg: b.theta_i_deg,
            phi_i_deg: b.phi_i_deg,
        })
    }
}

/// The pictures of a micro folder.
fn micro(t: &MicroTables) -> Vec<(String, Picture)> {
    let s = &t.summary;
    let m = Micro {
        t,
        photons: photons_text(s),
        mean: if s.run.wavelengths_um.is_empty() {
            ""
        } else {
            ", mean over the wavelengths"
        },
        several: s.run.phi_deg.len() > 1,
    };
    let lanes = s.run.wavelengths_um.len().max(1);
    let mut out = Vec::new();
    // brdf.csv: per incidence, the mean BRDF over the wavelengths per cell.
    for b in &t.brdf {
        let values = b.sums[0]
            .iter()
            .map(|&v| if v > 0.0 { v / lanes as f64 } else { f64::NAN })
            .collect();
        let (theta, phi) = (b.theta_i_deg, b.phi_i_deg);
        let title = format!(
            "{}: BRDF at {} ({}{})",
            s.name,
            m.at(theta, phi),
            m.photons,
            m.mean
        );
        out.push((
            m.file(&crate::output::hemisphere_file(theta), phi),
            m.map(b, title, values, MapScale::LogBrdf),
        ));
    }
    out.push((
        ResultFile::InplanePicture.name().to_owned(),
        Picture::Line(inplane_plot(s, &t.inplane, lanes, &m.photons)),
    ));
    out.push((
        ResultFile::ReflectancePicture.name().to_owned(),
        Picture::Line(micro_reflectance(s, &m.photons)),
    ));
    for b in t.stokes.iter().flatten() {
        out.push(dop_picture(&m, b));
    }
    if let Some(file) = &t.mueller {
        out.extend(mueller_pictures(s, &t.grid, file, &m.photons));
    }
    for c in t.colour.iter().flatten() {
        out.push(colour_picture(&m, c));
    }
    out
}

/// `dop_<θ>deg.png`: the degree of polarisation of the Stokes vector
/// summed over the wavelengths (`stokes.csv`).
fn dop_picture(m: &Micro<'_>, b: &IncidenceSums) -> (String, Picture) {
    let s = &m.t.summary;
    let sums = &b.sums;
    let dop: Vec<f64> = (0..m.t.grid.n_cells())
        .map(|c| {
            let s0 = sums[0][c];
            if s0 > 0.0 {
                (sums[1][c].powi(2) + sums[2][c].powi(2) + sums[3][c].powi(2)).sqrt() / s0
            } else {
                f64::NAN
            }
        })
        .collect();
    let (lo, hi) = dop
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    let (theta, phi) = (b.theta_i_deg, b.phi_i_deg);
    let title = format!(
        "{}: degree of polarisation at {} ({} light, {}{})",
        s.name,
        m.at(theta, phi),
        s.run.polarisation.incident.name(),
        m.photons,
        m.mean
    );
    let scale = MapScale::Linear {
        label: "degree of polarisation".into(),
        lo,
        hi,
    };
    let mut picture = m.map(b, title, dop, scale);
    if let Picture::Map(map) = &mut picture {
        map.empty_label = "no light: undefined".into();
    }
    (m.file(&crate::output::dop_file(theta), phi), picture)
}

/// `colour_<θ>deg.png`: the colour of the BRDF (`colour.csv`), where
/// `brdf.csv` has light.
fn colour_picture(m: &Micro<'_>, v: &IncidenceSums) -> (String, Picture) {
    let s = &m.t.summary;
    let (theta, phi) = (v.theta_i_deg, v.phi_i_deg);
    let v_ = &v.sums;
    let cells: Vec<([f64; 3], [f64; 3])> = (0..m.t.grid.n_cells())
        .map(|c| {
            (
                [v_[0][c], v_[1][c], v_[2][c]],
                [v_[3][c], v_[4][c], v_[5][c]],
            )
        })
        .collect();
    let lit = |c: usize| {
        m.t.brdf
            .iter()
            .find(|b| (b.theta_i_deg, b.phi_i_deg) == (theta, phi))
            .is_none_or(|b| b.sums[0][c] > 0.0)
    };
    let title = format!(
        "{}: colour of the BRDF (D65, sRGB) at {} ({})",
        s.name,
        m.at(theta, phi),
        m.photons
    );
    let values = (0..m.t.grid.n_cells())
        .map(|c| if lit(c) { v_[1][c] } else { f64::NAN })
        .collect();
    let scale = MapScale::Rgb {
        label: "luminance Y of the BRDF (1/sr)".into(),
        colours: crate::output::colour_csv::display_colours(&cells),
    };
    (
        m.file(&crate::output::colour_csv::colour_file(theta), phi),
        m.map(v, title, values, scale),
    )
}

/// `inplane.png`: per incidence, the in-plane BRDF (mean over the
/// wavelengths) against signed `θo`, error bars of 2 standard errors (the
/// mean of the wavelengths' errors, an upper bound of the mean's error);
/// broken at bins without photons.
fn inplane_plot(s: &BrdfSummary, rows: &[InplaneRow], lanes: usize, photons: &str) -> LinePlot {
    // Per incidence (and azimuth): (theta_i, phi_i) and, by theta_o's
    // order key, (theta_o, sums of brdf and stderr).
    type Curve = ((f64, Option<f64>), BTreeMap<u64, (f64, f64, f64)>);
    let mut curves: Vec<Curve> = Vec::new();
    for r in rows {
        let key = (r.theta_i_deg, r.phi_i_deg);
        let at = match curves.iter().position(|c| c.0 == key) {
            Some(k) => k,
            None => {
                curves.push((key, BTreeMap::new()));
                curves.len() - 1
            }
        };
        // Ordered by theta_o: the key is the f64's order-preserving bits.
        let key = {
            let b = r.theta_o_deg.to_bits();
            if r.theta_o_deg < 0.0 {
                !b
            } else {
                b | (1 << 63)
            }
        };
        let e = curves[at].1.entry(key).or_insert((r.theta_o_deg, 0.0, 0.0));
        e.1 += r.brdf;
        e.2 += r.brdf_stderr;
    }
    let l = lanes as f64;
    let keys: Vec<(f64, Option<f64>)> = curves.iter().map(|c| c.0).collect();
    let series = curves
        .into_iter()
        .map(|(_, bins)| {
            bins.values()
                .map(|&(x, b, e)| {
                    if b == 0.0 && e == 0.0 {
                        (x, f64::NAN, 0.0)
                    } else {
                        (x, b / l, 2.0 * e / l)
                    }
                })
                .collect()
        })
        .collect();
    let spectral = if lanes > 1 {
        ", mean over the wavelengths".to_owned()
    } else {
        String::new()
    };
    let (series, grid, note) = per_incidence(&keys, series);
    LinePlot {
        title: format!(
            "{}: BRDF in the plane of incidence ({photons}{spectral}{note})",
            s.name
        ),
        x_label: "θo (deg): negative toward the light, positive on the specular side".into(),
        y_label: "BRDF (1/sr), error bars 2 standard errors".into(),
        log_y: true,
        series,
        grid,
    }
}

/// At most this many incidences share a panel of `inplane.png` (or of a
/// spectral run's `reflectance.png`): more make a tangle of crossing
/// curves and error bars.
pub const PER_PANEL: usize = 5;

/// Small multiples of curves per incidence and light azimuth: the grid's
/// columns and, row-major, per panel its azimuth (`None`: the run has one)
/// and the indices of its incidences.
#[derive(Debug, Clone, PartialEq)]
pub struct Multiples {
    /// Columns: one per light azimuth.
    pub columns: usize,
    /// Per panel: its light azimuth and its incidences (indices into the
    /// run's incidence angles, in order).
    pub panels: Vec<(Option<f64>, Vec<usize>)>,
}

/// The small multiples of `incidences` curves at each of `azimuths`
/// (degrees; empty or one: a run of one azimuth): a column per azimuth and
/// a row per group of at most [`PER_PANEL`] consecutive incidences (groups
/// as even as can be: 7 incidences are 4 and 3). `None` when every curve
/// fits one panel (one azimuth, at most [`PER_PANEL`] incidences).
#[must_use]
pub fn multiples(incidences: usize, azimuths: &[f64]) -> Option<Multiples> {
    if incidences <= PER_PANEL && azimuths.len() <= 1 {
        return None;
    }
    let groups = incidences.div_ceil(PER_PANEL).max(1);
    let (size, extra) = (incidences / groups, incidences % groups);
    let mut start = 0;
    let mut rows = Vec::new();
    for g in 0..groups {
        let n = size + usize::from(g < extra);
        rows.push((start..start + n).collect::<Vec<usize>>());
        start += n;
    }
    let columns: Vec<Option<f64>> = if azimuths.len() > 1 {
        azimuths.iter().map(|&p| Some(p)).collect()
    } else {
        vec![None]
    };
    Some(Multiples {
        columns: columns.len(),
        panels: rows
            .iter()
            .flat_map(|r| columns.iter().map(move |&p| (p, r.clone())))
            .collect(),
    })
}

/// Curves per incidence and light azimuth (`keys`: `(θi, φi)`, `φi`
/// `None` for a run of one azimuth; `points`: each curve's) as the series
/// of a [`LinePlot`], each in the colour of its incidence (the same in
/// every panel), with its [`Grid`] of [`multiples`] and what the title
/// adds to say so (`""` for a single panel).
fn per_incidence(
    keys: &[(f64, Option<f64>)],
    mut points: Vec<Vec<(f64, f64, f64)>>,
) -> (Vec<Series>, Option<Grid>, String) {
    let mut thetas: Vec<f64> = Vec::new();
    let mut phis: Vec<f64> = Vec::new();
    for &(t, p) in keys {
        if !thetas.contains(&t) {
            thetas.push(t);
        }
        if let Some(p) = p.filter(|p| !phis.contains(p)) {
            phis.push(p);
        }
    }
    let colour = |t: f64| thetas.iter().position(|&x| x == t);
    let Some(m) = multiples(thetas.len(), &phis) else {
        let series = keys
            .iter()
            .zip(points)
            .map(|(&(theta, phi), pts)| Series {
                colour: colour(theta),
                ..Series::new(
                    match phi {
                        Some(phi) => format!("θi = {theta}°, φi = {phi}°"),
                        None => format!("θi = {theta}°"),
                    },
                    pts,
                )
            })
            .collect();
        return (series, None, String::new());
    };
    let mut series = Vec::new();
    let mut panels = Vec::new();
    for (phi, group) in &m.panels {
        let start = series.len();
        let ts: Vec<f64> = group.iter().map(|&k| thetas[k]).collect();
        for &t in &ts {
            let Some(k) = keys
                .iter()
                .position(|&(kt, kp)| kt == t && (phi.is_none() || kp == *phi))
            else {
                continue;
            };
            series.push(Series {
                colour: colour(t),
                ..Series::new(format!("θi = {t}°"), std::mem::take(&mut points[k]))
            });
        }
        let mut title = Vec::new();
        if let Some(p) = phi {
            title.push(format!("φi = {p}°"));
        }
        if m.panels.len() > m.columns {
            let list: Vec<String> = ts.iter().map(|t| format!("{t}°")).collect();
            title.push(format!("θi = {}", list.join(", ")));
        }
        panels.push(Panel {
            title: title.join(": "),
            series: start..series.len(),
        });
    }
    let rows = m.panels.len() / m.columns;
    let mut note = Vec::new();
    if rows > 1 {
        note.push(format!(
            "{} incidences in {rows} rows of at most {PER_PANEL}",
            thetas.len()
        ));
    }
    if m.columns > 1 {
        note.push("a column per light azimuth φi".to_owned());
    }
    let note = format!("; small multiples: {}", note.join(", "));
    (
        series,
        Some(Grid {
            columns: m.columns,
            panels,
        }),
        note,
    )
}

/// `reflectance.png` of a micro run: the directional-hemispherical
/// reflectance against the incidence angle, error bars of 2 standard
/// errors, one curve per light azimuth; a spectral run of two or more
/// wavelengths: against the wavelength, one curve per incidence (and
/// azimuth; small multiples as `inplane.png`'s), from `summary.json`'s
/// `spectrum` (the mean over the wavelengths would hide the spectrum).
fn micro_reflectance(s: &BrdfSummary, photons: &str) -> LinePlot {
    let lanes = s.run.wavelengths_um.len();
    if lanes > 1 {
        return spectral_reflectance(s, photons);
    }
    let label = if lanes > 0 {
        format!("mean over {lanes} wavelengths")
    } else {
        "reflectance".to_owned()
    };
    LinePlot {
        title: format!("{}: reflectance against incidence ({photons})", s.name),
        x_label: "incidence angle θi (deg)".into(),
        y_label: "reflectance (fraction of the incident power)".into(),
        log_y: false,
        // One curve per light azimuth.
        series: s
            .run
            .phi_deg
            .iter()
            .map(|&phi| {
                Series::new(
                    if s.run.phi_deg.len() > 1 {
                        format!("{label}, φi = {phi}°")
                    } else {
                        label.clone()
                    },
                    s.incidence
                        .iter()
                        .filter(|i| i.phi_deg == phi)
                        .map(|i| (i.theta_deg, i.reflectance, 2.0 * i.reflectance_stderr))
                        .collect(),
                )
            })
            .collect(),
        grid: None,
    }
}

/// `reflectance.png` of a spectral run: per incidence (and azimuth) its
/// reflectance against the wavelength, error bars of 2 standard errors.
fn spectral_reflectance(s: &BrdfSummary, photons: &str) -> LinePlot {
    let several = s.run.phi_deg.len() > 1;
    let keys: Vec<(f64, Option<f64>)> = s
        .incidence
        .iter()
        .map(|i| (i.theta_deg, several.then_some(i.phi_deg)))
        .collect();
    let points = s
        .incidence
        .iter()
        .map(|i| {
            i.spectrum
                .iter()
                .flatten()
                .map(|w| (w.wavelength_um, w.reflectance, 2.0 * w.reflectance_stderr))
                .collect()
        })
        .collect();
    let (series, grid, note) = per_incidence(&keys, points);
    LinePlot {
        title: format!(
            "{}: reflectance against wavelength ({photons}{note})",
            s.name
        ),
        x_label: "vacuum wavelength λ (µm)".into(),
        // Short enough for a panel of small multiples.
        y_label: "reflectance (fraction), 2-sigma error bars".into(),
        log_y: false,
        series,
        grid,
    }
}

/// `reflectance.png` of an object run: reflectance against beam position,
/// one curve per run of consecutive positions on a line at equal steps with
/// one beam (a sweep), x the distance from its first position; a spectral
/// run of two or more wavelengths: [`object_spectral_reflectance`].
fn object_reflectance(s: &TraceSummary) -> LinePlot {
    if s.wavelengths_um.len() > 1 {
        return object_spectral_reflectance(s);
    }
    let p = &s.sources;
    // Split into sweeps: same direction, diameter, photons and step.
    let mut runs: Vec<std::ops::Range<usize>> = Vec::new();
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    for k in 0..p.len() {
        let joins = runs.last().is_some_and(|r| {
            let prev = &p[k - 1];
            let same = prev.direction == p[k].direction
                && prev.diameter == p[k].diameter
                && prev.photons == p[k].photons;
            let step = sub(p[k].position, prev.position);
            let first_step =
                (r.len() >= 2).then(|| sub(p[r.start + 1].position, p[r.start].position));
            same && first_step
                .is_none_or(|f| (0..3).all(|i| (f[i] - step[i]).abs() <= 1e-9 * (1.0 + f[i].abs())))
        });
        if joins {
            runs.last_mut().expect("a run").end = k + 1;
        } else {
            runs.push(k..k + 1);
        }
    }
    let series: Vec<Series> = runs
        .iter()
        .map(|r| {
            let first = p[r.start].position;
            let label = if r.len() == 1 {
                format!(
                    "position {}, beam ⌀ {} units",
                    r.start + 1,
                    p[r.start].diameter
                )
            } else {
                format!(
                    "positions {}–{}, beam ⌀ {} units",
                    r.start + 1,
                    r.end,
                    p[r.start].diameter
                )
            };
            Series::new(
                label,
                p[r.clone()]
                    .iter()
                    .map(|q| {
                        let d = sub(q.position, first);
                        (
                            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(),
                            q.reflectance,
                            2.0 * q.reflectance_stderr,
                        )
                    })
                    .collect(),
            )
        })
        .collect();
    let (lo, hi) = p
        .iter()
        .map(|q| q.reflectance)
        .fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
    let per = photons_per_position(s);
    let what = match s.wavelengths_um.len() {
        0 => "reflectance".to_owned(),
        l => format!("reflectance (mean over {l} wavelengths)"),
    };
    LinePlot {
        title: format!("{}: {what} against beam position ({per})", s.name),
        x_label: "distance of the beam axis from the first position of its sweep (scene units)"
            .into(),
        y_label: "reflectance (fraction of the beam's flux), error bars 2 standard errors".into(),
        log_y: lo > 0.0 && hi > 20.0 * lo,
        series,
        grid: None,
    }
}

/// The photons of an object run's beam positions, for a title: one number
/// when every position has the same, else a pointer to the summary.
fn photons_per_position(s: &TraceSummary) -> String {
    let photons: Vec<u64> = s.sources.iter().map(|q| q.photons).collect();
    if photons.windows(2).all(|w| w[0] == w[1]) {
        format!(
            "{} photons per position",
            photons.first().copied().unwrap_or(0)
        )
    } else {
        format!("photons per position as in {}", ResultFile::Summary)
    }
}

/// What the titles of an object run say of its photons: per position
/// (one number when every position has the same), and for a spectral run
/// that they carry every wavelength.
fn object_photons(s: &TraceSummary) -> String {
    let per = photons_per_position(s);
    match s.wavelengths_um.len() {
        0 | 1 => per,
        l => format!("{per}, each carrying all {l} wavelengths"),
    }
}

/// A beam position's place and point in a legend: `position 2 (3.8, 0, 10)`
/// (coordinates to 4 decimals, trailing zeros dropped).
fn position_label(k: usize, p: [f64; 3]) -> String {
    let c = |x: f64| {
        let s = format!("{x:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".to_owned()
        } else {
            s.to_owned()
        }
    };
    format!("position {} ({}, {}, {})", k + 1, c(p[0]), c(p[1]), c(p[2]))
}

/// `reflectance.png` of a spectral object run: per beam position its
/// reflectance against the wavelength, from `summary.json`'s `spectrum`
/// (each position's mean over the wavelengths would hide the spectrum),
/// error bars of 2 standard errors; more than [`PER_PANEL`] positions:
/// small multiples of at most [`PER_PANEL`] consecutive positions a panel
/// (as [`multiples`] groups incidences), two columns past three rows.
fn object_spectral_reflectance(s: &TraceSummary) -> LinePlot {
    let p = &s.sources;
    let series: Vec<Series> = p
        .iter()
        .enumerate()
        .map(|(k, q)| {
            Series::new(
                position_label(k, q.position),
                q.spectrum
                    .iter()
                    .flatten()
                    .map(|w| (w.wavelength_um, w.reflectance, 2.0 * w.reflectance_stderr))
                    .collect(),
            )
        })
        .collect();
    let (grid, note) = match multiples(p.len(), &[]) {
        None => (None, String::new()),
        Some(m) => {
            let panels: Vec<Panel> = m
                .panels
                .iter()
                .map(|(_, ks)| {
                    let (a, b) = (ks[0], ks[ks.len() - 1]);
                    Panel {
                        title: format!("positions {}–{}", a + 1, b + 1),
                        series: a..b + 1,
                    }
                })
                .collect();
            let note = format!(
                "; small multiples: {} positions in {} panels of at most {PER_PANEL}",
                p.len(),
                panels.len()
            );
            let columns = if panels.len() > 3 { 2 } else { 1 };
            (Some(Grid { columns, panels }), note)
        }
    };
    LinePlot {
        title: format!(
            "{}: reflectance against wavelength per beam position ({}{note})",
            s.name,
            object_photons(s)
        ),
        x_label: "vacuum wavelength λ (µm)".into(),
        y_label: "reflectance (fraction of the beam's flux), 2-sigma error bars".into(),
        log_y: false,
        series,
        grid,
    }
}

/// `mueller_<θ>deg.png` and `mueller_stderr_<θ>deg.png` per incidence (a
/// spectral run: per incidence and wavelength, `_<λ>um` before `.png`).
fn mueller_pictures(
    s: &BrdfSummary,
    grid: &CarlsonGrid,
    file: &MuellerFile,
    photons: &str,
) -> Vec<(String, Picture)> {
    let n = grid.n_cells();
    let mut out = Vec::new();
    // Whole blocks of one incidence, azimuth and wavelength (checked by
    // the reader).
    for block in file.rows.chunks(n) {
        let r0 = &block[0];
        let (theta, w) = (r0.theta_i_deg, r0.wavelength_um);
        let suffix = w.map_or(String::new(), |w| format!("_{}um", number_label(w)));
        let mut at_w = w.map_or(String::new(), |w| format!(" at {w} µm"));
        // Several light azimuths: the azimuth in the names and titles.
        let phi = (s.run.phi_deg.len() > 1).then_some(r0.phi_i_deg);
        if let Some(phi) = phi {
            at_w = format!(", φi = {phi}°{at_w}");
        }
        let mut values = vec![vec![f64::NAN; n]; 16];
        let mut errors = vec![vec![f64::NAN; n]; 16];
        for (c, r) in block.iter().enumerate() {
            if r.m[0] > 0.0 {
                values[0][c] = r.m[0];
                errors[0][c] = r.stderr[0] / r.m[0];
                for k in 1..16 {
                    values[k][c] = r.m[k] / r.m[0];
                    errors[k][c] = r.normalised_stderr.map_or(f64::NAN, |e| e[k]);
                }
            }
        }
        let title = |what: &str| format!("{}: {what} at θi = {theta}°{at_w} ({photons})", s.name);
        out.push((
            crate::output::at_azimuth(
                &ResultPattern::Mueller.name(&format!("{}deg{suffix}", number_label(theta))),
                phi,
            ),
            Picture::Mueller(MuellerMaps {
                title: title("Mueller matrix BRDF, normalised by m00"),
                grid: *grid,
                values,
                kind: MuellerKind::Normalised,
                theta_i_deg: theta,
                phi_i_deg: r0.phi_i_deg,
            }),
        ));
        if r0.normalised_stderr.is_some() {
            out.push((
                crate::output::at_azimuth(
                    &ResultPattern::Mueller
                        .name(&format!("stderr_{}deg{suffix}", number_label(theta))),
                    phi,
                ),
                Picture::Mueller(MuellerMaps {
                    title: title("standard errors of the normalised Mueller matrix"),
                    grid: *grid,
                    values: errors,
                    kind: MuellerKind::Errors,
                    theta_i_deg: theta,
                    phi_i_deg: r0.phi_i_deg,
                }),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Titles and labels: every axis label carries a unit in parentheses;
    /// a spectral run's titles give the photons per incidence, not times
    /// the wavelengths.
    #[test]
    fn titles_and_units() {
        let mut run = crate::scene::micro::MicroScene::default_scene().brdf_run();
        run.photons = 1000;
        run.theta_deg = vec![30.0];
        run.wavelengths_um = vec![0.5, 0.6, 0.7];
        let text = format!(
            r#"{{"content":{{"files":{{}},"scene_sha256":"0"}},"edges":"periodic","incidence":[
            {{"capped_photons":0,"intersection_tests":1,"lost":0,"lost_cap":0,"lost_numeric":0,"lost_walls":0,"mean_bounces":1,"numeric_guard_photons":0,"phi_deg":0,"photons":1000,"reflectance":0.5,"reflectance_by_bounces":[0.5],"reflectance_stderr":0.01,"seconds":1,"segments":1,"segments_per_second":1,"tests_per_segment":1,"theta_deg":30}}],
            "name":"s","run":{},"scene":"s.toml","seconds":1,
            "surface":{{"height_map_resolution":4,"max_height":0,"mean_height":0,"min_height":0,"rms_slope":0,"sigma":0,"sigma_over_tau":null,"tau":null}},
            "version":"0"}}"#,
            serde_json::to_string(&run).unwrap()
        );
        let s: BrdfSummary = serde_json::from_str(&text).unwrap();
        let photons = photons_text(&s);
        assert_eq!(
            photons,
            "1000 photons per incidence, each carrying all 3 wavelengths"
        );
        let p = micro_reflectance(&s, &photons);
        for l in [&p.x_label, &p.y_label] {
            assert!(l.contains('(') && l.contains(')'), "{l}");
        }
        assert!(p.title.contains("1000 photons") && !p.title.contains("3000"));
    }

    /// The small multiples of `inplane.png`: ten incidences at two light
    /// azimuths are four panels, a column per azimuth and a row per five
    /// incidences; five incidences at one azimuth stay one panel; seven
    /// are split 4 + 3.
    #[test]
    fn panels_of_small_multiples() {
        let m = multiples(10, &[0.0, 90.0]).unwrap();
        assert_eq!(m.columns, 2);
        let (a, b): (Vec<usize>, Vec<usize>) = ((0..5).collect(), (5..10).collect());
        assert_eq!(
            m.panels,
            [
                (Some(0.0), a.clone()),
                (Some(90.0), a),
                (Some(0.0), b.clone()),
                (Some(90.0), b)
            ]
        );
        assert_eq!(multiples(5, &[0.0]), None);
        assert_eq!(multiples(5, &[]), None);
        let m = multiples(7, &[30.0]).unwrap();
        assert_eq!(m.columns, 1);
        assert_eq!(m.panels, [(None, vec![0, 1, 2, 3]), (None, vec![4, 5, 6])]);
        let m = multiples(2, &[0.0, 45.0, 90.0]).unwrap();
        assert_eq!(m.columns, 3);
        assert_eq!(m.panels.len(), 3);
        assert!(m.panels.iter().all(|p| p.1 == [0, 1]));
    }

    /// A run's summary (`summary.json`'s text) at incidences `thetas` and
    /// azimuths `phis`, with wavelengths `lanes` (each incidence's spectrum
    /// `R(λ) = λ + θi / 1000`, standard error `λ / 100`).
    fn summary(thetas: &[f64], phis: &[f64], lanes: &[f64]) -> BrdfSummary {
        let mut run = crate::scene::micro::MicroScene::default_scene().brdf_run();
        run.photons = 1000;
        run.theta_deg = thetas.to_vec();
        run.phi_deg = crate::transport::brdf::Azimuths(phis.to_vec());
        run.wavelengths_um = lanes.to_vec();
        let mut incidence = Vec::new();
        for &t in thetas {
            for &p in phis {
                let spectrum: Vec<String> = lanes
                    .iter()
                    .map(|&w| {
                        format!(
                            r#"{{"lost":0,"lost_cap":0,"lost_numeric":0,"lost_walls":0,"reflectance":{},"reflectance_stderr":{},"wavelength_um":{w}}}"#,
                            w + t / 1000.0,
                            w / 100.0
                        )
                    })
                    .collect();
                let spectrum = if lanes.is_empty() {
                    String::new()
                } else {
                    format!(r#","spectrum":[{}]"#, spectrum.join(","))
                };
                incidence.push(format!(
                    r#"{{"capped_photons":0,"intersection_tests":1,"lost":0,"lost_cap":0,"lost_numeric":0,"lost_walls":0,"mean_bounces":1,"numeric_guard_photons":0,"phi_deg":{p},"photons":1000,"reflectance":0.5,"reflectance_by_bounces":[0.5],"reflectance_stderr":0.01,"seconds":1,"segments":1,"segments_per_second":1,"tests_per_segment":1,"theta_deg":{t}{spectrum}}}"#
                ));
            }
        }
        let text = format!(
            r#"{{"content":{{"files":{{}},"scene_sha256":"0"}},"edges":"periodic","incidence":[{}],
            "name":"s","run":{},"scene":"s.toml","seconds":1,
            "surface":{{"height_map_resolution":4,"max_height":0,"mean_height":0,"min_height":0,"rms_slope":0,"sigma":0,"sigma_over_tau":null,"tau":null}},
            "version":"0"}}"#,
            incidence.join(","),
            serde_json::to_string(&run).unwrap()
        );
        serde_json::from_str(&text).unwrap()
    }

    /// `inplane.png` of ten incidences at two azimuths: four titled panels
    /// of five curves, each incidence in the same colour in both columns
    /// (its place among the incidences), the title saying so.
    #[test]
    fn inplane_of_ten_incidences_at_two_azimuths() {
        let thetas: Vec<f64> = vec![0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0];
        let s = summary(&thetas, &[0.0, 90.0], &[]);
        let mut rows = Vec::new();
        for &t in &thetas {
            for p in [0.0, 90.0] {
                for x in [-10.0, 0.0, 10.0] {
                    rows.push(InplaneRow {
                        theta_i_deg: t,
                        phi_i_deg: Some(p),
                        theta_o_deg: x,
                        brdf: 1.0 + t + p,
                        brdf_stderr: 0.1,
                    });
                }
            }
        }
        let plot = inplane_plot(&s, &rows, 1, "1000 photons per incidence");
        assert_eq!(
            plot.title,
            "s: BRDF in the plane of incidence (1000 photons per incidence; small multiples: \
             10 incidences in 2 rows of at most 5, a column per light azimuth φi)"
        );
        let grid = plot.grid.as_ref().expect("small multiples");
        assert_eq!(grid.columns, 2);
        let titles: Vec<&str> = grid.panels.iter().map(|p| p.title.as_str()).collect();
        assert_eq!(
            titles,
            [
                "φi = 0°: θi = 0°, 10°, 20°, 30°, 40°",
                "φi = 90°: θi = 0°, 10°, 20°, 30°, 40°",
                "φi = 0°: θi = 50°, 60°, 70°, 80°, 85°",
                "φi = 90°: θi = 50°, 60°, 70°, 80°, 85°",
            ]
        );
        for (k, p) in grid.panels.iter().enumerate() {
            assert_eq!(p.series.len(), 5);
            let phi = if k % 2 == 0 { 0.0 } else { 90.0 };
            for (j, i) in p.series.clone().enumerate() {
                let theta = thetas[5 * (k / 2) + j];
                assert_eq!(plot.series[i].label, format!("θi = {theta}°"));
                // Its own data, in its incidence's colour.
                assert_eq!(plot.series[i].points[0].1, 1.0 + theta + phi);
                assert_eq!(
                    plot.series_colour(i),
                    crate::plot::line::PALETTE[5 * (k / 2) + j]
                );
            }
        }
        let png = plot.to_png(1100, 640).unwrap();
        assert!(image::load_from_memory(&png).is_ok());
        assert_eq!(plot.size(1100, 640), (1400, 680));
    }

    /// A spectral run's `reflectance.png`: per incidence its reflectance
    /// against the wavelength from `summary.json`'s spectrum (not the mean
    /// over the wavelengths), error bars of 2 standard errors; one
    /// wavelength: against incidence as before.
    #[test]
    fn spectral_reflectance_is_drawn_per_wavelength() {
        let lanes = [0.4, 0.5, 0.6, 0.7];
        let s = summary(&[0.0, 30.0, 60.0], &[0.0], &lanes);
        let p = micro_reflectance(&s, "x");
        assert!(
            p.title.starts_with("s: reflectance against wavelength"),
            "{}",
            p.title
        );
        assert!(p.x_label.contains("wavelength") && p.grid.is_none());
        let labels: Vec<&str> = p.series.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(labels, ["θi = 0°", "θi = 30°", "θi = 60°"]);
        for (s, t) in p.series.iter().zip([0.0, 30.0, 60.0]) {
            let expect: Vec<(f64, f64, f64)> = lanes
                .iter()
                .map(|&w| (w, w + t / 1000.0, 2.0 * (w / 100.0)))
                .collect();
            assert_eq!(s.points, expect);
        }
        // Ten incidences at two azimuths: small multiples as inplane.png's.
        let thetas: Vec<f64> = (0..10).map(|k| f64::from(k) * 8.0).collect();
        let p = micro_reflectance(&summary(&thetas, &[0.0, 90.0], &lanes), "x");
        let g = p.grid.as_ref().unwrap();
        assert_eq!((g.columns, g.panels.len(), p.series.len()), (2, 4, 20));
        // One wavelength: reflectance against incidence.
        let p = micro_reflectance(&summary(&[0.0, 30.0], &[0.0], &[0.5]), "x");
        assert!(p.title.contains("against incidence"));
        assert_eq!(p.series[0].points, [(0.0, 0.5, 0.02), (30.0, 0.5, 0.02)]);
    }

    /// `summary.json` of a `roks trace` run of `positions` beam positions at
    /// `lanes` wavelengths: at position k and wavelength w the reflectance
    /// `w / 10 + k / 100` with standard error `w / 1000` (the means over the
    /// wavelengths are the entry's own, as the tracer writes them).
    fn trace_summary(positions: usize, lanes: &[f64]) -> TraceSummary {
        let sources: Vec<serde_json::Value> = (0..positions)
            .map(|k| {
                let r = |w: f64| w / 10.0 + k as f64 / 100.0;
                let spectrum: Vec<serde_json::Value> = lanes
                    .iter()
                    .map(|&w| {
                        serde_json::json!({"absorbed": {}, "absorbed_stderr": {}, "emissivity": 1.0 - r(w),
                            "lost": 0.0, "missed": 0.0, "reflectance": r(w), "reflectance_stderr": w / 1000.0, "wavelength_um": w})
                    })
                    .collect();
                let n = lanes.len().max(1) as f64;
                let mut v = serde_json::json!({"absorbed": {}, "absorbed_stderr": {}, "diameter": 2.0, "direction": [0.0, 0.0, -1.0],
                    "lost": 0.0, "mean_bounces": 1.0, "missed": 0.0, "photons": 1000, "position": [0.1 * k as f64, 0.0, 10.0],
                    "reflectance": if lanes.is_empty() { r(0.0) } else { lanes.iter().map(|&w| r(w)).sum::<f64>() / n }, "reflectance_stderr": 0.01, "seconds": 1.0, "segments": 1});
                if !lanes.is_empty() {
                    v["spectrum"] = serde_json::json!(spectrum);
                }
                v
            })
            .collect();
        serde_json::from_value(
            serde_json::json!({"name": "cavity", "scene": "c.toml", "seconds": 1.0, "seed": 1,
            "sources": sources, "version": "0", "wavelengths_um": lanes}),
        )
        .unwrap()
    }

    /// A spectral `roks trace` run's `reflectance.png`: per beam position
    /// its reflectance against the wavelength, the summary's spectrum
    /// (not the mean over the wavelengths), error bars of 2 standard
    /// errors, the title saying so; many positions: small multiples of at
    /// most five; a monochrome run: against beam position as before.
    #[test]
    fn spectral_trace_reflectance_is_drawn_per_wavelength() {
        let lanes = [3.0, 3.5, 4.0, 8.0];
        let s = trace_summary(4, &lanes);
        let p = object_reflectance(&s);
        assert_eq!(
            p.title,
            "cavity: reflectance against wavelength per beam position (1000 photons per position, each carrying all 4 wavelengths)"
        );
        assert!(p.x_label.contains("wavelength") && p.grid.is_none());
        assert_eq!(p.series.len(), 4);
        for (k, series) in p.series.iter().enumerate() {
            let spectrum = s.sources[k].spectrum.as_ref().unwrap();
            let want: Vec<(f64, f64, f64)> = spectrum
                .iter()
                .map(|w| (w.wavelength_um, w.reflectance, 2.0 * w.reflectance_stderr))
                .collect();
            assert_eq!(series.points, want);
            assert_eq!(series.points[3].1, 0.8 + k as f64 / 100.0);
            assert_eq!(series.points[0].2, 2.0 * 0.003);
        }
        assert_eq!(p.series[1].label, "position 2 (0.1, 0, 10)");
        assert!(image::load_from_memory(&p.to_png(1100, 640).unwrap()).is_ok());
        // Twelve positions: three panels of four, in one column.
        let p = object_reflectance(&trace_summary(12, &lanes));
        let g = p.grid.as_ref().unwrap();
        assert_eq!((g.columns, g.panels.len(), p.series.len()), (1, 3, 12));
        assert_eq!(g.panels[2].title, "positions 9–12");
        assert!(
            p.title
                .ends_with("small multiples: 12 positions in 3 panels of at most 5)")
        );
        // Monochrome: against beam position, one sweep.
        let p = object_reflectance(&trace_summary(4, &[]));
        assert!(
            p.title
                .starts_with("cavity: reflectance against beam position"),
            "{}",
            p.title
        );
        assert_eq!(p.series.len(), 1);
        assert_eq!(p.series[0].points[2].1, 0.02);
    }
}
