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
//! reflectance against beam position.
//!
//! Titles give the photons per incidence (or per beam position) and, for a
//! spectral run, that the same photons carry every wavelength. The surface
//! picture (`surface.png`) needs the surface itself, not its results: see
//! [`super::SurfacePicture`].

use std::collections::BTreeMap;
use std::path::Path;

use rayon::prelude::*;

use super::mueller::MuellerKind;
use super::{HemisphereMap, LinePlot, MapScale, MuellerMaps, Series};
use crate::output::number_label;
use crate::output::polar_csv::MuellerFile;
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
            Self::Line(p) => p.to_png(LINE_SIZE.0, LINE_SIZE.1),
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
    #[error("{file}: {problem}")]
    File {
        /// The file's name in the folder, e.g. `brdf.csv`.
        file: &'static str,
        /// What is wrong.
        problem: FileProblem,
    },
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

/// What is wrong with a file of a result folder ([`PlotError::File`]).
#[derive(Debug, thiserror::Error)]
pub enum FileProblem {
    /// No `summary.json`.
    #[error("missing (not a roks result folder)")]
    NotAResult,
    /// A file the pictures need is missing.
    #[error("missing")]
    Missing,
    /// JSON that is not a summary.
    #[error("{0}")]
    Json(serde_json::Error),
    /// A summary of neither kind of run.
    #[error("neither of roks brdf (incidence) nor of roks trace (sources)")]
    NeitherKind,
    /// A summary's bands that make no Carlson grid.
    #[error("bands: {0} is not a grid")]
    Bands(usize),
    /// A CSV without its header (the file's name).
    #[error("line 1: not the header of roks's {0}")]
    Header(&'static str),
    /// A CSV field that is not a number (1-based line and column).
    #[error("line {line}: column {column}: `{text}` is not a number")]
    Number {
        /// Line.
        line: usize,
        /// Column.
        column: usize,
        /// The field.
        text: String,
    },
    /// A CSV row without the header's columns.
    #[error("line {line}: expected {expected} columns, found {found}")]
    Columns {
        /// Line.
        line: usize,
        /// The header's columns.
        expected: usize,
        /// The row's.
        found: usize,
    },
    /// Rows that are not whole blocks of the grid's cells.
    #[error("{rows} rows are not whole blocks of {cells} cells")]
    Blocks {
        /// Rows.
        rows: usize,
        /// Cells of the grid.
        cells: usize,
    },
    /// A block of one incidence that is not the grid's cells long.
    #[error("a block of theta_i_deg = {theta_i_deg} is not {cells} cells long")]
    Block {
        /// The block's incidence (degrees).
        theta_i_deg: f64,
        /// Cells of the grid.
        cells: usize,
    },
    /// An incidence without one block per wavelength.
    #[error(
        "theta_i_deg = {theta_i_deg} has {blocks} blocks, expected {lanes} (one per wavelength)"
    )]
    Lanes {
        /// The incidence (degrees).
        theta_i_deg: f64,
        /// Its blocks.
        blocks: usize,
        /// The run's wavelengths (1: monochrome).
        lanes: usize,
    },
    /// A `mueller.csv` that cannot be read.
    #[error("{0}")]
    Mueller(crate::output::polar_csv::MuellerError),
    /// A block of `mueller.csv` that is not the grid's cells long.
    #[error("line {line}: a block is not {cells} cells long")]
    MuellerBlock {
        /// The block's first line.
        line: usize,
        /// Cells of the grid.
        cells: usize,
    },
}

fn bad(file: &'static str, problem: FileProblem) -> PlotError {
    PlotError::File { file, problem }
}

/// A CSV table of numbers, read by its header's column names.
struct Csv {
    columns: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Csv {
    /// Parse `text` of file `name`, whose header must be one of `headers`.
    fn parse(name: &'static str, text: &str, headers: &[String]) -> Result<Self, PlotError> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let header = lines.next().map_or("", |(_, l)| l);
        let header = header.strip_prefix('\u{feff}').unwrap_or(header).trim_end();
        if !headers.iter().any(|h| h == header) {
            return Err(bad(name, FileProblem::Header(name)));
        }
        let columns: Vec<String> = header.split(',').map(str::to_owned).collect();
        let mut rows = Vec::new();
        for (i, l) in lines {
            let row: Vec<f64> = l
                .split(',')
                .enumerate()
                .map(|(c, f)| {
                    f.trim().parse::<f64>().map_err(|_| {
                        bad(
                            name,
                            FileProblem::Number {
                                line: i + 1,
                                column: c + 1,
                                text: f.trim().to_owned(),
                            },
                        )
                    })
                })
                .collect::<Result<_, _>>()?;
            if row.len() != columns.len() {
                return Err(bad(
                    name,
                    FileProblem::Columns {
                        line: i + 1,
                        expected: columns.len(),
                        found: row.len(),
                    },
                ));
            }
            rows.push(row);
        }
        Ok(Self { columns, rows })
    }

    /// Index of column `c` (which the header has).
    fn col(&self, c: &str) -> usize {
        self.columns
            .iter()
            .position(|x| x == c)
            .expect("a column of the header")
    }
}

/// `header` and, with `wavelength_um` after `after`, its spectral form.
fn headers(header: &str, after: &str) -> Vec<String> {
    let plain = [
        header.to_owned(),
        crate::output::spectral_header(header, after),
    ];
    // With several surface realisations, the photon-noise columns end the
    // header of brdf.csv and inplane.csv.
    let photon = [
        crate::output::brdf_csv::PHOTON_COLUMNS,
        crate::output::inplane_csv::PHOTON_COLUMN,
    ];
    let with_photon: Vec<String> = plain
        .iter()
        .flat_map(|h| photon.iter().map(move |p| format!("{h},{p}")))
        .collect();
    plain.into_iter().chain(with_photon).collect()
}

/// Every picture of a result folder whose files `file(name)` gives (the
/// text, `None` for a file the folder does not have), each as its file
/// name and PNG bytes.
///
/// # Errors
/// A one-line message naming the file (and line) that cannot be read, or
/// a picture that cannot be drawn.
pub fn pictures(
    file: &dyn Fn(&str) -> Option<String>,
) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
    const SUMMARY: &str = "summary.json";
    let json = |e| bad(SUMMARY, FileProblem::Json(e));
    let summary = file(SUMMARY).ok_or(bad(SUMMARY, FileProblem::NotAResult))?;
    let value: serde_json::Value = serde_json::from_str(&summary).map_err(json)?;
    let pictures = if value.get("incidence").is_some() {
        let s: BrdfSummary = serde_json::from_value(value).map_err(json)?;
        micro(&s, file)?
    } else if value.get("sources").is_some() {
        let s: TraceSummary = serde_json::from_value(value).map_err(json)?;
        vec![(
            "reflectance.png".to_owned(),
            Picture::Line(object_reflectance(&s)),
        )]
    } else {
        return Err(bad(SUMMARY, FileProblem::NeitherKind));
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
/// about to be written).
///
/// # Errors
/// As [`pictures`].
pub fn pictures_of(files: &[(String, Vec<u8>)]) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
    pictures(&|name| {
        files
            .iter()
            .find(|f| f.0 == name)
            .map(|f| String::from_utf8_lossy(&f.1).into_owned())
    })
}

/// Add the [`pictures`] of a folder's files (about to be written) to them.
///
/// # Errors
/// As [`pictures`].
pub fn add_pictures(files: &mut Vec<(String, Vec<u8>)>) -> Result<(), PlotError> {
    let pictures = pictures_of(files)?;
    files.extend(pictures);
    Ok(())
}

/// [`pictures`] of the folder `dir` on disk.
///
/// # Errors
/// As [`pictures`], the file names relative to `dir`.
pub fn pictures_in(dir: &Path) -> Result<Vec<(String, Vec<u8>)>, PlotError> {
    pictures(&|name| std::fs::read_to_string(dir.join(name)).ok()).map_err(|e| PlotError::Folder {
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

/// The pictures of a micro folder.
fn micro(
    s: &BrdfSummary,
    read: &dyn Fn(&str) -> Option<String>,
) -> Result<Vec<(String, Picture)>, PlotError> {
    let grid = CarlsonGrid::new(s.run.bands)
        .ok_or_else(|| bad("summary.json", FileProblem::Bands(s.run.bands)))?;
    let n = grid.n_cells();
    let lanes = s.run.wavelengths_um.len().max(1);
    let spectral = !s.run.wavelengths_um.is_empty();
    let photons = photons_text(s);
    // Several light azimuths: the azimuth in every picture's name and title.
    let several = s.run.phi_deg.len() > 1;
    let file = |name: String, phi: f64| crate::output::at_azimuth(&name, several.then_some(phi));
    let at = |theta: f64, phi: f64| {
        if several {
            format!("θi = {theta}°, φi = {phi}°")
        } else {
            format!("θi = {theta}°")
        }
    };
    let mean = if spectral {
        ", mean over the wavelengths".to_owned()
    } else {
        String::new()
    };
    let mut out = Vec::new();

    // brdf.csv: per incidence, the mean BRDF over the wavelengths per cell.
    let text = read("brdf.csv").ok_or_else(|| bad("brdf.csv", FileProblem::Missing))?;
    let brdf = Csv::parse(
        "brdf.csv",
        &text,
        &headers(crate::output::brdf_csv::HEADER, "phi_i_deg"),
    )?;
    let blocks = incidence_blocks(&brdf, "brdf.csv", n, lanes, &["brdf"])?;
    for ((theta, phi), sums) in &blocks {
        let values = sums[0]
            .iter()
            .map(|&v| if v > 0.0 { v / lanes as f64 } else { f64::NAN })
            .collect();
        out.push((
            file(crate::output::hemisphere_file(*theta), *phi),
            Picture::Map(HemisphereMap {
                title: format!("{}: BRDF at {} ({photons}{mean})", s.name, at(*theta, *phi)),
                grid,
                values,
                scale: MapScale::LogBrdf,
                empty_label: "no photon".into(),
                theta_i_deg: *theta,
                phi_i_deg: *phi,
            }),
        ));
    }

    // inplane.csv: one curve per incidence.
    let text = read("inplane.csv").ok_or_else(|| bad("inplane.csv", FileProblem::Missing))?;
    let inplane = Csv::parse(
        "inplane.csv",
        &text,
        &if several {
            headers(crate::output::inplane_csv::AZIMUTH_HEADER, "phi_i_deg")
        } else {
            headers(crate::output::inplane_csv::HEADER, "theta_i_deg")
        },
    )?;
    out.push((
        "inplane.png".to_owned(),
        Picture::Line(inplane_plot(s, &inplane, lanes, &photons)),
    ));
    out.push((
        "reflectance.png".to_owned(),
        Picture::Line(micro_reflectance(s, &photons)),
    ));

    // stokes.csv: the degree of polarisation of the Stokes vector summed
    // over the wavelengths.
    if let Some(text) = read("stokes.csv") {
        let stokes = Csv::parse(
            "stokes.csv",
            &text,
            &headers(crate::output::polar_csv::STOKES_HEADER, "phi_i_deg"),
        )?;
        let incident = s.run.polarisation.incident.name();
        for ((theta, phi), sums) in
            incidence_blocks(&stokes, "stokes.csv", n, lanes, &["s0", "s1", "s2", "s3"])?
        {
            let dop: Vec<f64> = (0..n)
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
            out.push((
                file(crate::output::dop_file(theta), phi),
                Picture::Map(HemisphereMap {
                    title: format!(
                        "{}: degree of polarisation at {} ({incident} light, {photons}{mean})",
                        s.name,
                        at(theta, phi)
                    ),
                    grid,
                    values: dop,
                    scale: MapScale::Linear {
                        label: "degree of polarisation".into(),
                        lo,
                        hi,
                    },
                    empty_label: "no light: undefined".into(),
                    theta_i_deg: theta,
                    phi_i_deg: phi,
                }),
            ));
        }
    }

    if let Some(text) = read("mueller.csv") {
        out.extend(mueller_pictures(s, &grid, &text, &photons)?);
    }

    if let Some(text) = read("colour.csv") {
        let colour = Csv::parse(
            "colour.csv",
            &text,
            &[crate::output::colour_csv::HEADER.to_owned()],
        )?;
        for ((theta, phi), v) in
            incidence_blocks(&colour, "colour.csv", n, 1, &["X", "Y", "Z", "r", "g", "b"])?
        {
            let cells: Vec<([f64; 3], [f64; 3])> = (0..n)
                .map(|c| ([v[0][c], v[1][c], v[2][c]], [v[3][c], v[4][c], v[5][c]]))
                .collect();
            let lit = |c: usize| {
                blocks
                    .iter()
                    .find(|b| b.0 == (theta, phi))
                    .is_none_or(|b| b.1[0][c] > 0.0)
            };
            out.push((
                file(crate::output::colour_csv::colour_file(theta), phi),
                Picture::Map(HemisphereMap {
                    title: format!(
                        "{}: colour of the BRDF (D65, sRGB) at {} ({photons})",
                        s.name,
                        at(theta, phi)
                    ),
                    grid,
                    values: (0..n)
                        .map(|c| if lit(c) { v[1][c] } else { f64::NAN })
                        .collect(),
                    scale: MapScale::Rgb {
                        label: "luminance Y of the BRDF (1/sr)".into(),
                        colours: crate::output::colour_csv::display_colours(&cells),
                    },
                    empty_label: "no photon".into(),
                    theta_i_deg: theta,
                    phi_i_deg: phi,
                }),
            ));
        }
    }
    Ok(out)
}

/// Per incidence `(theta_i_deg, phi_i_deg)`, in the file's order: per
/// column of `columns`, the sum over the wavelengths of each cell's value.
/// Every block (incidence and wavelength) must hold the `n` cells in grid
/// order, and each incidence `lanes` blocks.
#[allow(clippy::type_complexity)]
fn incidence_blocks(
    t: &Csv,
    name: &'static str,
    n: usize,
    lanes: usize,
    columns: &[&str],
) -> Result<Vec<((f64, f64), Vec<Vec<f64>>)>, PlotError> {
    let (ct, cp) = (t.col("theta_i_deg"), t.col("phi_i_deg"));
    let cols: Vec<usize> = columns.iter().map(|c| t.col(c)).collect();
    if t.rows.len() % n != 0 {
        return Err(bad(
            name,
            FileProblem::Blocks {
                rows: t.rows.len(),
                cells: n,
            },
        ));
    }
    let mut out: Vec<((f64, f64), Vec<Vec<f64>>, usize)> = Vec::new();
    for block in t.rows.chunks(n) {
        let key = (block[0][ct], block[0][cp]);
        if block.iter().any(|r| (r[ct], r[cp]) != key) {
            return Err(bad(
                name,
                FileProblem::Block {
                    theta_i_deg: key.0,
                    cells: n,
                },
            ));
        }
        let at = match out.iter().position(|o| o.0 == key) {
            Some(k) => k,
            None => {
                out.push((key, vec![vec![0.0; n]; cols.len()], 0));
                out.len() - 1
            }
        };
        out[at].2 += 1;
        for (k, &c) in cols.iter().enumerate() {
            for (cell, r) in block.iter().enumerate() {
                out[at].1[k][cell] += r[c];
            }
        }
    }
    if let Some(o) = out.iter().find(|o| o.2 != lanes) {
        return Err(bad(
            name,
            FileProblem::Lanes {
                theta_i_deg: o.0.0,
                blocks: o.2,
                lanes,
            },
        ));
    }
    Ok(out.into_iter().map(|o| (o.0, o.1)).collect())
}

/// `inplane.png`: per incidence, the in-plane BRDF (mean over the
/// wavelengths) against signed `θo`, error bars of 2 standard errors (the
/// mean of the wavelengths' errors, an upper bound of the mean's error);
/// broken at bins without photons.
fn inplane_plot(s: &BrdfSummary, t: &Csv, lanes: usize, photons: &str) -> LinePlot {
    let (ci, co, cb, ce) = (
        t.col("theta_i_deg"),
        t.col("theta_o_deg"),
        t.col("brdf"),
        t.col("brdf_stderr"),
    );
    // Several light azimuths: the column of the azimuth.
    let cp = t.columns.iter().position(|c| c == "phi_i_deg");
    // Per incidence (and azimuth): (theta_i, phi_i) and, by theta_o's
    // order key, (theta_o, sums of brdf and stderr).
    type Curve = ((f64, Option<f64>), BTreeMap<u64, (f64, f64, f64)>);
    let mut curves: Vec<Curve> = Vec::new();
    for r in &t.rows {
        let key = (r[ci], cp.map(|c| r[c]));
        let at = match curves.iter().position(|c| c.0 == key) {
            Some(k) => k,
            None => {
                curves.push((key, BTreeMap::new()));
                curves.len() - 1
            }
        };
        // Ordered by theta_o: the key is the f64's order-preserving bits.
        let key = {
            let b = r[co].to_bits();
            if r[co] < 0.0 { !b } else { b | (1 << 63) }
        };
        let e = curves[at].1.entry(key).or_insert((r[co], 0.0, 0.0));
        e.1 += r[cb];
        e.2 += r[ce];
    }
    let l = lanes as f64;
    let series = curves
        .into_iter()
        .map(|((theta, phi), bins)| Series {
            label: match phi {
                Some(phi) => format!("θi = {theta}°, φi = {phi}°"),
                None => format!("θi = {theta}°"),
            },
            points: bins
                .values()
                .map(|&(x, b, e)| {
                    if b == 0.0 && e == 0.0 {
                        (x, f64::NAN, 0.0)
                    } else {
                        (x, b / l, 2.0 * e / l)
                    }
                })
                .collect(),
        })
        .collect();
    let spectral = if lanes > 1 {
        ", mean over the wavelengths".to_owned()
    } else {
        String::new()
    };
    LinePlot {
        title: format!(
            "{}: BRDF in the plane of incidence ({photons}{spectral})",
            s.name
        ),
        x_label: "θo (deg): negative toward the light, positive on the specular side".into(),
        y_label: "BRDF (1/sr), error bars 2 standard errors".into(),
        log_y: true,
        series,
    }
}

/// `reflectance.png` of a micro run: the directional-hemispherical
/// reflectance against the incidence angle, error bars of 2 standard errors.
fn micro_reflectance(s: &BrdfSummary, photons: &str) -> LinePlot {
    let lanes = s.run.wavelengths_um.len();
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
            .map(|&phi| Series {
                label: if s.run.phi_deg.len() > 1 {
                    format!("{label}, φi = {phi}°")
                } else {
                    label.clone()
                },
                points: s
                    .incidence
                    .iter()
                    .filter(|i| i.phi_deg == phi)
                    .map(|i| (i.theta_deg, i.reflectance, 2.0 * i.reflectance_stderr))
                    .collect(),
            })
            .collect(),
    }
}

/// `reflectance.png` of an object run: reflectance against beam position,
/// one curve per run of consecutive positions on a line at equal steps with
/// one beam (a sweep), x the distance from its first position.
fn object_reflectance(s: &TraceSummary) -> LinePlot {
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
            Series {
                label,
                points: p[r.clone()]
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
            }
        })
        .collect();
    let (lo, hi) = p
        .iter()
        .map(|q| q.reflectance)
        .fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
    let photons: Vec<u64> = p.iter().map(|q| q.photons).collect();
    let per = if photons.windows(2).all(|w| w[0] == w[1]) {
        format!(
            "{} photons per position",
            photons.first().copied().unwrap_or(0)
        )
    } else {
        "photons per position as in summary.json".to_owned()
    };
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
    }
}

/// `mueller_<θ>deg.png` and `mueller_stderr_<θ>deg.png` per incidence (a
/// spectral run: per incidence and wavelength, `_<λ>um` before `.png`).
fn mueller_pictures(
    s: &BrdfSummary,
    grid: &CarlsonGrid,
    text: &str,
    photons: &str,
) -> Result<Vec<(String, Picture)>, PlotError> {
    const MUELLER: &str = "mueller.csv";
    let n = grid.n_cells();
    let file = MuellerFile::parse(text).map_err(|e| bad(MUELLER, FileProblem::Mueller(e)))?;
    if file.rows.len() % n != 0 {
        return Err(bad(
            MUELLER,
            FileProblem::Blocks {
                rows: file.rows.len(),
                cells: n,
            },
        ));
    }
    let mut out = Vec::new();
    for block in file.rows.chunks(n) {
        let r0 = &block[0];
        let (theta, w) = (r0.theta_i_deg, r0.wavelength_um);
        if block
            .iter()
            .any(|r| (r.theta_i_deg, r.phi_i_deg, r.wavelength_um) != (theta, r0.phi_i_deg, w))
        {
            return Err(bad(
                MUELLER,
                FileProblem::MuellerBlock {
                    line: r0.line,
                    cells: n,
                },
            ));
        }
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
                &format!("mueller_{}deg{suffix}.png", number_label(theta)),
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
                    &format!("mueller_stderr_{}deg{suffix}.png", number_label(theta)),
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
    Ok(out)
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
}
