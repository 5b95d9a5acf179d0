//! A result folder's files read into typed tables, for its pictures
//! ([`crate::plot::folder`]): the summary, and per incidence the cell
//! values of `brdf.csv`, `stokes.csv` and `colour.csv` summed over the
//! wavelengths, the rows of `inplane.csv`, the blocks of `mueller.csv`.
//! Every file is checked here (header, numbers, whole blocks of the grid's
//! cells); a problem is one line naming the file (and line).

use super::polar_csv::MuellerFile;
use super::summary::{BrdfSummary, TraceSummary};
use crate::outdir::file::ResultFile;
use crate::tally::CarlsonGrid;

/// Why a result folder's files cannot be read into tables: the file and
/// what is wrong with it. One line.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct TablesError {
    /// The file's name in the folder, e.g. `brdf.csv`.
    pub file: &'static str,
    /// What is wrong.
    pub problem: FileProblem,
}

/// What is wrong with a file of a result folder ([`TablesError`]).
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
    Mueller(super::polar_csv::MuellerError),
    /// A block of `mueller.csv` that is not the grid's cells long.
    #[error("line {line}: a block is not {cells} cells long")]
    MuellerBlock {
        /// The block's first line.
        line: usize,
        /// Cells of the grid.
        cells: usize,
    },
}

fn bad(file: ResultFile, problem: FileProblem) -> TablesError {
    TablesError {
        file: file.name(),
        problem,
    }
}

/// A result folder's tables: of a micro run (`roks brdf`, `merge`) or of
/// an object run (`roks trace`).
#[derive(Debug, Clone)]
pub enum ResultTables {
    /// A micro run's.
    Micro(Box<MicroTables>),
    /// An object run's: its summary.
    Object(Box<TraceSummary>),
}

/// The tables of a micro run's folder.
#[derive(Debug, Clone)]
pub struct MicroTables {
    /// `summary.json`.
    pub summary: BrdfSummary,
    /// The run's Carlson grid.
    pub grid: CarlsonGrid,
    /// `brdf.csv`: per incidence, the column `brdf`.
    pub brdf: Vec<IncidenceSums>,
    /// `inplane.csv`, in file order.
    pub inplane: Vec<InplaneRow>,
    /// `stokes.csv`, if any: per incidence, `s0`, `s1`, `s2`, `s3`.
    pub stokes: Option<Vec<IncidenceSums>>,
    /// `mueller.csv`, if any, checked to be whole blocks of the grid's
    /// cells, one incidence, azimuth and wavelength each.
    pub mueller: Option<MuellerFile>,
    /// `colour.csv`, if any: per incidence, `X`, `Y`, `Z`, `r`, `g`, `b`.
    pub colour: Option<Vec<IncidenceSums>>,
}

/// Per incidence (in the file's order), per column read, each cell's value
/// summed over the run's wavelengths.
#[derive(Debug, Clone, PartialEq)]
pub struct IncidenceSums {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
    /// Per column, per flat Carlson cell, the sum over the wavelengths.
    pub sums: Vec<Vec<f64>>,
}

/// One row of `inplane.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InplaneRow {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees), in a file of several.
    pub phi_i_deg: Option<f64>,
    /// Signed exit angle (degrees).
    pub theta_o_deg: f64,
    /// BRDF (1/sr).
    pub brdf: f64,
    /// Its standard error (1/sr).
    pub brdf_stderr: f64,
}

impl ResultTables {
    /// The tables of a folder whose files `file` gives (the text, `None`
    /// for a file the folder does not have).
    ///
    /// # Errors
    /// The file (and line) that is missing or cannot be read.
    pub fn read(file: &dyn Fn(ResultFile) -> Option<String>) -> Result<Self, TablesError> {
        const SUMMARY: ResultFile = ResultFile::Summary;
        let json = |e| bad(SUMMARY, FileProblem::Json(e));
        let summary = file(SUMMARY).ok_or(bad(SUMMARY, FileProblem::NotAResult))?;
        let value: serde_json::Value = serde_json::from_str(&summary).map_err(json)?;
        if value.get("incidence").is_some() {
            let s: BrdfSummary = serde_json::from_value(value).map_err(json)?;
            Ok(Self::Micro(Box::new(MicroTables::read(s, file)?)))
        } else if value.get("sources").is_some() {
            let s: TraceSummary = serde_json::from_value(value).map_err(json)?;
            Ok(Self::Object(Box::new(s)))
        } else {
            Err(bad(SUMMARY, FileProblem::NeitherKind))
        }
    }

    /// The tables of a folder's files as `(name, bytes)` (those of a
    /// folder about to be written).
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn of(files: &[(String, Vec<u8>)]) -> Result<Self, TablesError> {
        Self::read(&|f| {
            files
                .iter()
                .find(|x| x.0 == f.name())
                .map(|x| String::from_utf8_lossy(&x.1).into_owned())
        })
    }

    /// The tables of the folder `dir` on disk.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn read_dir(dir: &std::path::Path) -> Result<Self, TablesError> {
        Self::read(&|f| std::fs::read_to_string(f.path_in(dir)).ok())
    }
}

impl MicroTables {
    /// The tables of a micro folder with the summary `s`.
    fn read(
        s: BrdfSummary,
        read: &dyn Fn(ResultFile) -> Option<String>,
    ) -> Result<Self, TablesError> {
        let grid = CarlsonGrid::new(s.run.bands)
            .ok_or_else(|| bad(ResultFile::Summary, FileProblem::Bands(s.run.bands)))?;
        let n = grid.n_cells();
        let lanes = s.run.wavelengths_um.len().max(1);
        let several = s.run.phi_deg.len() > 1;
        let need = |f: ResultFile| read(f).ok_or_else(|| bad(f, FileProblem::Missing));

        let brdf_header = headers(super::brdf_csv::HEADER, "phi_i_deg");
        let brdf = Csv::parse(ResultFile::Brdf, &need(ResultFile::Brdf)?, &brdf_header)?;
        let brdf = brdf.incidence_sums(n, lanes, &["brdf"])?;

        let inplane_header = if several {
            headers(super::inplane_csv::AZIMUTH_HEADER, "phi_i_deg")
        } else {
            headers(super::inplane_csv::HEADER, "theta_i_deg")
        };
        let inplane = Csv::parse(
            ResultFile::Inplane,
            &need(ResultFile::Inplane)?,
            &inplane_header,
        )?
        .inplane_rows();

        let stokes = match read(ResultFile::Stokes) {
            Some(text) => {
                let header = headers(super::polar_csv::STOKES_HEADER, "phi_i_deg");
                let t = Csv::parse(ResultFile::Stokes, &text, &header)?;
                Some(t.incidence_sums(n, lanes, &["s0", "s1", "s2", "s3"])?)
            }
            None => None,
        };
        let mueller = match read(ResultFile::Mueller) {
            Some(text) => Some(mueller_blocks(&text, n)?),
            None => None,
        };
        let colour = match read(ResultFile::Colour) {
            Some(text) => {
                let header = [super::colour_csv::HEADER.to_owned()];
                let t = Csv::parse(ResultFile::Colour, &text, &header)?;
                Some(t.incidence_sums(n, 1, &["X", "Y", "Z", "r", "g", "b"])?)
            }
            None => None,
        };
        Ok(Self {
            summary: s,
            grid,
            brdf,
            inplane,
            stokes,
            mueller,
            colour,
        })
    }
}

/// `mueller.csv` read, and checked to be whole blocks of `n` cells, each
/// of one incidence, azimuth and wavelength.
fn mueller_blocks(text: &str, n: usize) -> Result<MuellerFile, TablesError> {
    const MUELLER: ResultFile = ResultFile::Mueller;
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
    for block in file.rows.chunks(n) {
        let r0 = &block[0];
        let key = (r0.theta_i_deg, r0.phi_i_deg, r0.wavelength_um);
        if block
            .iter()
            .any(|r| (r.theta_i_deg, r.phi_i_deg, r.wavelength_um) != key)
        {
            return Err(bad(
                MUELLER,
                FileProblem::MuellerBlock {
                    line: r0.line,
                    cells: n,
                },
            ));
        }
    }
    Ok(file)
}

/// A CSV table of numbers, read by its header's column names.
struct Csv {
    file: ResultFile,
    columns: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Csv {
    /// Parse `text` of `file`, whose header must be one of `headers`.
    fn parse(file: ResultFile, text: &str, headers: &[String]) -> Result<Self, TablesError> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let header = lines.next().map_or("", |(_, l)| l);
        let header = header.strip_prefix('\u{feff}').unwrap_or(header).trim_end();
        if !headers.iter().any(|h| h == header) {
            return Err(bad(file, FileProblem::Header(file.name())));
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
                            file,
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
                    file,
                    FileProblem::Columns {
                        line: i + 1,
                        expected: columns.len(),
                        found: row.len(),
                    },
                ));
            }
            rows.push(row);
        }
        Ok(Self {
            file,
            columns,
            rows,
        })
    }

    /// Index of column `c` (which the header has).
    fn col(&self, c: &str) -> usize {
        self.columns
            .iter()
            .position(|x| x == c)
            .expect("a column of the header")
    }

    /// Per incidence `(theta_i_deg, phi_i_deg)`, in the file's order: per
    /// column of `columns`, the sum over the wavelengths of each cell's
    /// value. Every block (incidence and wavelength) must hold the `n`
    /// cells in grid order, and each incidence `lanes` blocks.
    fn incidence_sums(
        &self,
        n: usize,
        lanes: usize,
        columns: &[&str],
    ) -> Result<Vec<IncidenceSums>, TablesError> {
        let name = self.file;
        let (ct, cp) = (self.col("theta_i_deg"), self.col("phi_i_deg"));
        let cols: Vec<usize> = columns.iter().map(|c| self.col(c)).collect();
        if self.rows.len() % n != 0 {
            return Err(bad(
                name,
                FileProblem::Blocks {
                    rows: self.rows.len(),
                    cells: n,
                },
            ));
        }
        let mut out: Vec<(IncidenceSums, usize)> = Vec::new();
        for block in self.rows.chunks(n) {
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
            let at = match out
                .iter()
                .position(|o| (o.0.theta_i_deg, o.0.phi_i_deg) == key)
            {
                Some(k) => k,
                None => {
                    let sums = IncidenceSums {
                        theta_i_deg: key.0,
                        phi_i_deg: key.1,
                        sums: vec![vec![0.0; n]; cols.len()],
                    };
                    out.push((sums, 0));
                    out.len() - 1
                }
            };
            out[at].1 += 1;
            for (k, &c) in cols.iter().enumerate() {
                for (cell, r) in block.iter().enumerate() {
                    out[at].0.sums[k][cell] += r[c];
                }
            }
        }
        if let Some(o) = out.iter().find(|o| o.1 != lanes) {
            return Err(bad(
                name,
                FileProblem::Lanes {
                    theta_i_deg: o.0.theta_i_deg,
                    blocks: o.1,
                    lanes,
                },
            ));
        }
        Ok(out.into_iter().map(|o| o.0).collect())
    }

    /// The rows of `inplane.csv`.
    fn inplane_rows(&self) -> Vec<InplaneRow> {
        let (ci, co, cb, ce) = (
            self.col("theta_i_deg"),
            self.col("theta_o_deg"),
            self.col("brdf"),
            self.col("brdf_stderr"),
        );
        let cp = self.columns.iter().position(|c| c == "phi_i_deg");
        self.rows
            .iter()
            .map(|r| InplaneRow {
                theta_i_deg: r[ci],
                phi_i_deg: cp.map(|c| r[c]),
                theta_o_deg: r[co],
                brdf: r[cb],
                brdf_stderr: r[ce],
            })
            .collect()
    }
}

/// `header` and, with `wavelength_um` after `after`, its spectral form.
fn headers(header: &str, after: &str) -> Vec<String> {
    let plain = [header.to_owned(), super::spectral_header(header, after)];
    // With several surface realisations, the photon-noise columns end the
    // header of brdf.csv and inplane.csv.
    let photon = [
        super::brdf_csv::PHOTON_COLUMNS,
        super::inplane_csv::PHOTON_COLUMN,
    ];
    let with_photon: Vec<String> = plain
        .iter()
        .flat_map(|h| photon.iter().map(move |p| format!("{h},{p}")))
        .collect();
    plain.into_iter().chain(with_photon).collect()
}
