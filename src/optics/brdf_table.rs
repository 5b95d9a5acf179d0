//! A tabulated BRDF read from the `brdf.csv` written by `roks brdf`, for the
//! macro level: a rough wall samples an outgoing direction from the table
//! instead of tracing its micro geometry at every hit.
//!
//! # Frame and units
//!
//! Directions are unit vectors in the **local frame** of the surface: `z` is
//! the surface normal, the plane of incidence is the x-z plane with the light
//! on the `+x` side, i.e. `omega_i = (sin theta_i, 0, cos theta_i)` points
//! toward the light and the specular direction is
//! `(-sin theta_i, 0, cos theta_i)`. Incidence angles passed to the methods
//! are polar angles in **radians**; angles in the file are in degrees; solid
//! angles are in sr; fractions and reflectances are dimensionless (weight per
//! launched photon); BRDF values are in sr⁻¹.
//!
//! # The table
//!
//! A table holds, per tabulated incidence (polar angle and light azimuth,
//! degrees), the fraction of the launched light leaving through each cell
//! of a Carlson equal-solid-angle grid of `M` bands (see [`CarlsonGrid`])
//! and its standard error. [`BrdfTable::from_blocks`] builds one from
//! numbers; the checked reader of the `brdf.csv` written by `roks brdf`
//! (and of the `summary.json` and `mueller.csv` beside it) is
//! [`crate::output::brdf_csv`], which owns the file. Incidences are sorted
//! by angle; no angle twice; each incidence's sum of fractions (its
//! reflectance) is at most 1 (+1e-9 for rounding: a table may not create
//! light).
//!
//! **Spectral tables.** A spectral run's `brdf.csv` holds a block per
//! incidence and wavelength; it reads back as a [`SpectralTables`] (inside
//! a [`BrdfTables::Spectral`]): one [`BrdfTable`] per wavelength, all on
//! one grid at the same incidences, wavelengths (µm) strictly increasing.
//! Every table is checked as a monochrome one. [`BrdfTables`] is what the
//! exports take; a wall that samples one table takes a [`BrdfTable`].
//!
//! **Isotropy.** A block's cells are rotated by `-phi_i_deg` into the local
//! frame, so a table traced at any light azimuth can be used; this assumes
//! the surface is statistically isotropic (its BRDF depends on the azimuth
//! difference only), which is also what lets one table serve every azimuth
//! of incidence.
//!
//! **Several light azimuths.** A run with `[light] phi_deg = [0, 90]`
//! tabulates every incidence angle at every light azimuth: the incidences
//! are `(theta_i_deg, phi_i_deg)` pairs, sorted by `theta_i_deg`, then by
//! `phi_i_deg` (ascending, absolute degrees as written), and an angle with
//! more than one block must have exactly the azimuths of every other
//! ([`BrdfValuesError::Azimuths`] otherwise): incidence `i` of
//! [`BrdfTable::thetas_deg`] is angle `i / n` at azimuth `i % n` of
//! [`BrdfTable::azimuths_deg`] (`n` of them). A table with one block per
//! angle is a table of one azimuth, as it always was, even when its
//! angles were traced at different azimuths (the isotropy above; its
//! [`BrdfTable::azimuths_deg`] is the first block's).
//! Such a table describes an anisotropic surface in its own frame; a
//! consumer that has no surface orientation (a wall of `roks trace`, whose
//! tangent frame follows the light) cannot pick an azimuth and refuses it
//! ([`BrdfTable::require_one_azimuth`]). [`BrdfTable::azimuth`] gives the
//! one-azimuth table of one light azimuth (what the Zemax `Asymmetrical4D`
//! export writes per sample rotation). [`BrdfTable::eval`],
//! [`BrdfTable::reflectance`], [`BrdfTable::reflectance_stderr`] and
//! [`BrdfTable::sample`] of a table with `n > 1` azimuths are those of the
//! **azimuth average**: the mean over the `n` azimuths of each azimuth's
//! table (each rotated into the local frame), i.e. the isotropic BRDF of
//! the surface turned to a uniformly chosen tabulated azimuth (what the
//! MERL export writes); for one azimuth they are exactly as before.
//!
//! # Sampling
//!
//! [`BrdfTable::sample`] takes four uniform numbers `u` in `[0, 1)`:
//! 1. **Incidence** (`u[0]`): with `theta_a <= theta_i < theta_b` the two
//!    tabulated angles bracketing `theta_i` and
//!    `w = (theta_i - theta_a) / (theta_b - theta_a)`, the table at `theta_b`
//!    is used with probability `w`, the one at `theta_a` otherwise
//!    (stochastic interpolation: the expected result is exactly that of the
//!    BRDF interpolated linearly in `theta_i`). Outside the tabulated range
//!    the nearest end table is used (clamping).
//! 2. **Cell** (`u[1]`): cell `c` with probability `fraction_c / R`, where `R`
//!    is the table's reflectance, the sum of its fractions, by binary search
//!    in a cumulative table built at load time. Cells with zero fraction are
//!    never chosen.
//! 3. **Direction in the cell** (`u[2]`, `u[3]`): `mu² = cos² theta` uniform
//!    over `(mu_bot², mu_top²]` and `phi` uniform over `[phi_lo, phi_hi)`
//!    (the cell's edges from the grid), i.e. uniform in projected solid
//!    angle, which is what a BRDF constant over the cell means. Then
//!    `phi - phi_i` gives the local azimuth. The direction has `z > 0`.
//! 4. **Weight**: the returned factor is `R` of the table chosen in step 1;
//!    the caller multiplies the photon weight by it. For every set `A` of
//!    directions, `E[factor * 1{dir in A}] = ∫_A eval cos(theta) dω` with
//!    [`BrdfTable::eval`]: the sampler is unbiased for the table interpolated
//!    linearly in `theta_i`, constant over each cell.
//!
//! A chosen table whose fractions are all 0 returns `None` (absorbed).
//!
//! # Errors of the table
//!
//! [`BrdfTable::reflectance_stderr`] gives the standard error of the
//! reflectance. `brdf.csv` alone does not determine it: a photon leaves
//! through one cell, so the cells are negatively correlated, and the tally
//! shares a photon leaving exactly at the pole among band 1's four cells
//! (positively correlated), so the file lacks the covariances. From the file
//! alone `reflectance_stderr` is `sqrt(sum fraction_stderr²)`, which ignores
//! the covariances: for photon weights of similar size it overestimates the
//! error, by a factor 5 to 18 for the default scene at 0-80 degrees (it can
//! underestimate only when much of the weight leaves exactly at the pole). The exact value is the
//! `reflectance_stderr` that `roks brdf` writes to `summary.json` beside the
//! table; [`BrdfTable::with_summary`] reads it (and checks that the
//! summary's reflectances are the table's). Between tabulated angles the
//! errors are interpolated linearly, which bounds the error of the
//! interpolated reflectance whatever the correlation of the two runs (they
//! share random streams).

use crate::tally::anisotropy::{Anisotropy, Group, Table as AzimuthTable};
use glam::DVec3;
use thiserror::Error;

use crate::tally::CarlsonGrid;

/// Most a fraction, or the sum of the fractions of one incidence, may be:
/// 1 (every photon starts with weight 1 and no weight grows) plus rounding.
pub(crate) const MAX_FRACTION: f64 = 1.0 + 1e-9;

/// The largest `f64` below 1, `1 - 2^-53`.
const BELOW_ONE: f64 = 1.0 - f64::EPSILON / 2.0;

/// Why numbers are not a [`BrdfTable`] (or [`SpectralTables`]): an
/// incidence angle twice, fractions that create light, or tables per
/// wavelength that do not fit together. (Reading a `brdf.csv` fails with
/// [`crate::output::brdf_csv::BrdfTableError`], which wraps this one.) Every message is one line naming the file and, for a
/// table read from a file, the line (0: not from a file).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BrdfValuesError {
    /// The same incidence (angle and light azimuth) in two blocks.
    #[error(
        "{file}: line {line}: incidence theta_i_deg = {theta_i_deg}{azimuth} already tabulated from line {first}"
    )]
    Duplicate {
        /// File name.
        file: String,
        /// First line of the second block.
        line: usize,
        /// First line of the first block.
        first: usize,
        /// The angle (degrees).
        theta_i_deg: f64,
        /// `, phi_i_deg = <azimuth>` in a table of several light azimuths,
        /// else empty (the message of a one-azimuth table is unchanged).
        azimuth: String,
    },
    /// Light azimuths that do not make a complete table: an incidence
    /// angle lacking an azimuth that another angle has.
    #[error("{file}: line {line}, column {column} (phi_i_deg): {message}")]
    Azimuths {
        /// File name.
        file: String,
        /// First line of the block concerned (0: not from a file).
        line: usize,
        /// The file's `phi_i_deg` column (1-based): 2.
        column: usize,
        /// What is wrong (one line).
        message: String,
    },
    /// A table of several light azimuths given to a consumer that takes
    /// one ([`BrdfTable::require_one_azimuth`]).
    #[error(
        "{file}: column 2 (phi_i_deg): a table of {count} light azimuths ({list} deg) describes an anisotropic surface in its own frame; {what} takes a table of one light azimuth (trace one, `[light] phi_deg = <azimuth>`, or keep the rows of one phi_i_deg)"
    )]
    SeveralAzimuths {
        /// File name.
        file: String,
        /// Number of light azimuths.
        count: usize,
        /// The azimuths, comma-separated (degrees).
        list: String,
        /// The consumer that refuses, e.g. "a BRDF wall of roks trace".
        what: String,
    },
    /// The fractions of a block sum to more than 1: a surface that would
    /// reflect more light than it receives.
    #[error(
        "{file}: line {line}, column {column} (fraction): the fractions of incidence theta_i_deg = {theta_i_deg} (the block from this line) sum to a reflectance of {total}, more than 1 (a surface that creates light)"
    )]
    Sum {
        /// File name.
        file: String,
        /// First line of the block.
        line: usize,
        /// The file's `fraction` column (1-based): 13, or 14 in a spectral
        /// table.
        column: usize,
        /// The angle (degrees).
        theta_i_deg: f64,
        /// The sum of the block's fractions.
        total: f64,
    },
    /// Tables per wavelength that do not fit together (see
    /// [`SpectralTables::new`]).
    #[error("{file}: {message}")]
    Spectral {
        /// File name.
        file: String,
        /// What is wrong (one line).
        message: String,
    },
}

/// Fixed geometry of one Carlson cell (radians, sr).
#[derive(Debug, Clone, Copy)]
struct Cell {
    /// `cos² theta` at the cell's lower (horizon-side) edge.
    mu2_bot: f64,
    /// `cos² theta` at the cell's upper (pole-side) edge.
    mu2_top: f64,
    /// Absolute azimuth edges (radians; cell 0 has `phi_lo < 0`).
    phi_lo: f64,
    phi_hi: f64,
    /// Exact projected solid angle (sr).
    proj: f64,
}

/// One tabulated incidence.
#[derive(Debug, Clone)]
struct Incidence {
    /// Incidence polar angle (radians).
    theta: f64,
    /// Light azimuth of the block (radians).
    phi_i: f64,
    /// Fraction per flat cell (dimensionless).
    fractions: Vec<f64>,
    /// Inclusive cumulative sums of `fractions`.
    cdf: Vec<f64>,
    /// Reflectance `R`, the sum of the fractions (the last `cdf` entry).
    reflectance: f64,
    /// Last cell with a positive fraction (`None`: all zero).
    last_positive: Option<usize>,
    /// Standard error of each fraction (dimensionless).
    fraction_stderr: Vec<f64>,
    /// `sqrt(sum fraction_stderr²)`.
    cell_stderr: f64,
    /// Incidence angle and light azimuth as written (degrees), to match
    /// `summary.json`.
    theta_deg: f64,
    phi_i_deg: f64,
    /// `reflectance_stderr` from `summary.json`, if attached.
    stated_stderr: Option<f64>,
    /// With a `mueller.csv` attached: per flat cell the Mueller-matrix BRDF
    /// divided by its `m00` (row-major; zeros where `m00 = 0`).
    mueller: Option<Vec<[f64; 16]>>,
}

/// A BRDF tabulated on a Carlson grid at several incidence angles, read from
/// `brdf.csv`; see the [module documentation](self) for the frame, the file
/// checks and the sampling method.
#[derive(Debug, Clone)]
pub struct BrdfTable {
    grid: CarlsonGrid,
    cells: Vec<Cell>,
    /// Incidences sorted by angle, then light azimuth: incidence
    /// `t * azimuths_deg.len() + k` is angle `t` at azimuth `k`.
    incidences: Vec<Incidence>,
    /// Their angles in degrees, as in the file (one per incidence: an
    /// angle repeats once per azimuth).
    thetas_deg: Vec<f64>,
    /// The distinct incidence angles (radians), ascending.
    angles: Vec<f64>,
    /// The light azimuths (degrees, as in the file), ascending; one for a
    /// table of one azimuth.
    azimuths_deg: Vec<f64>,
    /// The file's name as given to [`BrdfTable::parse`] (for messages that
    /// name it beside `summary.json` or `mueller.csv`).
    file: String,
}

/// One incidence's numbers, checked, for [`BrdfTable::from_checked`].
pub(crate) struct BlockData {
    /// Its first line in the file (0: not from a file).
    pub(crate) line: usize,
    pub(crate) theta_deg: f64,
    pub(crate) phi_i_deg: f64,
    pub(crate) fractions: Vec<f64>,
    pub(crate) fraction_stderr: Vec<f64>,
}

/// What the readers of `summary.json` and `mueller.csv` match against: a
/// tabulated incidence's angles as written (degrees) and its reflectance.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tabulated {
    pub(crate) theta_deg: f64,
    pub(crate) phi_i_deg: f64,
    pub(crate) reflectance: f64,
}

/// Sort incidence blocks by angle, then light azimuth (the order of a
/// table's incidences; see the module documentation).
pub(crate) fn sort_incidences(blocks: &mut [BlockData]) {
    blocks.sort_by(|a, b| {
        a.theta_deg
            .total_cmp(&b.theta_deg)
            .then(a.phi_i_deg.total_cmp(&b.phi_i_deg))
    });
}

/// `, phi_i_deg = <phi>` when the table has `several` light azimuths, else
/// empty: the azimuth part of a message about an incidence.
pub(crate) fn azimuth_note(several: bool, phi_i_deg: f64) -> String {
    if several {
        format!(", phi_i_deg = {phi_i_deg}")
    } else {
        String::new()
    }
}

/// `a, b, c` of angles in degrees.
fn list_deg(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The light azimuths (ascending) of blocks sorted by
/// [`sort_incidences`], no incidence twice, when every angle has the same
/// ones; or, when every angle has one block, the first block's azimuth
/// (the others may differ: a table of one azimuth per angle, read as
/// always).
///
/// # Errors
/// [`BrdfValuesError::Azimuths`] naming the first block of an angle that lacks
/// an azimuth of the first angle, or the first block of an azimuth that
/// the first angle lacks.
fn azimuth_layout(blocks: &[BlockData], file: &str) -> Result<Vec<f64>, BrdfValuesError> {
    let Some(first) = blocks.first() else {
        return Ok(vec![0.0]);
    };
    let first_theta = first.theta_deg;
    let azimuths: Vec<f64> = blocks
        .iter()
        .take_while(|b| b.theta_deg == first_theta)
        .map(|b| b.phi_i_deg)
        .collect();
    let fail = |line: usize, message: String| BrdfValuesError::Azimuths {
        file: file.to_owned(),
        line,
        column: 2,
        message,
    };
    let mut start = 0;
    while start < blocks.len() {
        let theta = blocks[start].theta_deg;
        let group: Vec<&BlockData> = blocks[start..]
            .iter()
            .take_while(|b| b.theta_deg == theta)
            .collect();
        start += group.len();
        // One block per angle: one light azimuth each, which may differ
        // between angles (a table of an isotropic surface, as always read).
        if azimuths.len() == 1 && group.len() == 1 {
            continue;
        }
        let phis: Vec<f64> = group.iter().map(|b| b.phi_i_deg).collect();
        if let Some(b) = group.iter().find(|b| !azimuths.contains(&b.phi_i_deg)) {
            return Err(fail(
                b.line,
                format!(
                    "incidence theta_i_deg = {theta} at light azimuth {} deg, which incidence theta_i_deg = {first_theta} (from line {}) lacks: every incidence angle needs the same light azimuths ({} deg there)",
                    b.phi_i_deg,
                    first.line,
                    list_deg(&azimuths)
                ),
            ));
        }
        if let Some(missing) = azimuths.iter().find(|a| !phis.contains(a)) {
            return Err(fail(
                group[0].line,
                format!(
                    "incidence theta_i_deg = {theta} (from this line) lacks light azimuth {missing} deg: every incidence angle needs the light azimuths of theta_i_deg = {first_theta} (from line {}: {} deg), it has {} deg",
                    first.line,
                    list_deg(&azimuths),
                    list_deg(&phis)
                ),
            ));
        }
    }
    Ok(azimuths)
}

/// Clamp a uniform number into `[0, 1)` (NaN to 0).
fn unit(u: f64) -> f64 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, BELOW_ONE)
    }
}

/// Rotate `d` about `z` by `angle` (radians, counter-clockwise seen from
/// `+z`).
pub(crate) fn rotate_z(d: DVec3, angle: f64) -> DVec3 {
    if angle == 0.0 {
        return d;
    }
    let (s, c) = angle.sin_cos();
    DVec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z)
}

impl BrdfTable {
    /// The table of `blocks` on `grid` (each: incidence and light azimuth
    /// in degrees, and per flat cell the fraction and its standard error),
    /// as [`BrdfTable::parse`] (in [`crate::output::brdf_csv`]) would read the rows written by
    /// [`crate::output::brdf_csv::write_blocks`] with these numbers;
    /// `file` names it in messages.
    ///
    /// # Errors
    /// If a block does not have one value per cell, a fraction is negative
    /// or not finite, an angle repeats, or a block's fractions add up to more
    /// than 1.
    pub fn from_blocks(
        grid: CarlsonGrid,
        blocks: Vec<(f64, f64, Vec<f64>, Vec<f64>)>,
        file: &str,
    ) -> Result<Self, BrdfValuesError> {
        let mut data: Vec<BlockData> = blocks
            .into_iter()
            .map(
                |(theta_deg, phi_i_deg, fractions, fraction_stderr)| BlockData {
                    line: 0,
                    theta_deg,
                    phi_i_deg,
                    fractions,
                    fraction_stderr,
                },
            )
            .collect();
        let bad = |theta_i_deg: f64, total: f64| BrdfValuesError::Sum {
            file: file.to_owned(),
            line: 0,
            column: 13,
            theta_i_deg,
            total,
        };
        for b in &data {
            if b.fractions.len() != grid.n_cells() || b.fraction_stderr.len() != grid.n_cells() {
                return Err(bad(b.theta_deg, f64::NAN));
            }
            if b.fractions.iter().any(|f| !(f.is_finite() && *f >= 0.0)) {
                return Err(bad(b.theta_deg, f64::NAN));
            }
        }
        sort_incidences(&mut data);
        if let Some(w) = data
            .windows(2)
            .find(|w| (w[0].theta_deg, w[0].phi_i_deg) == (w[1].theta_deg, w[1].phi_i_deg))
        {
            let several = data.iter().any(|b| b.phi_i_deg != data[0].phi_i_deg);
            return Err(BrdfValuesError::Duplicate {
                file: file.to_owned(),
                line: 0,
                first: 0,
                theta_i_deg: w[1].theta_deg,
                azimuth: azimuth_note(several, w[1].phi_i_deg),
            });
        }
        Self::from_checked(grid, data, file.to_owned())
    }

    /// The table of `blocks` on `grid`, sorted by angle and then light
    /// azimuth ([`sort_incidences`]), no incidence twice, one value per
    /// cell (as checked by [`BrdfTable::from_blocks`] and by the reader of
    /// `brdf.csv`); `file` names it in messages.
    ///
    /// # Errors
    /// [`BrdfValuesError::Azimuths`] unless every angle has the same light
    /// azimuths; [`BrdfValuesError::Sum`] if a block's fractions add up to more
    /// than 1.
    pub(crate) fn from_checked(
        grid: CarlsonGrid,
        blocks: Vec<BlockData>,
        file: String,
    ) -> Result<Self, BrdfValuesError> {
        let cells = Self::cells(&grid);
        Self::build(grid, cells, blocks, file)
    }

    /// The fixed geometry of every cell of `grid`.
    fn cells(grid: &CarlsonGrid) -> Vec<Cell> {
        (0..grid.n_cells())
            .map(|flat| {
                let (band, cell) = grid.band_cell(flat);
                let (mu_bot, mu_top) = grid.mu_edges(band);
                let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
                Cell {
                    mu2_bot: mu_bot * mu_bot,
                    mu2_top: mu_top * mu_top,
                    phi_lo,
                    phi_hi,
                    proj: grid.projected_solid_angle(band, cell),
                }
            })
            .collect()
    }

    /// The table of checked blocks sorted by angle: the cumulative
    /// fractions for sampling.
    fn build(
        grid: CarlsonGrid,
        cells: Vec<Cell>,
        blocks: Vec<BlockData>,
        file: String,
    ) -> Result<Self, BrdfValuesError> {
        let azimuths_deg = azimuth_layout(&blocks, &file)?;
        let mut incidences = Vec::with_capacity(blocks.len());
        for b in blocks {
            let mut cdf = Vec::with_capacity(b.fractions.len());
            let mut total = 0.0;
            for &f in &b.fractions {
                total += f;
                cdf.push(total);
            }
            if total.is_nan() || total > MAX_FRACTION {
                return Err(BrdfValuesError::Sum {
                    file,
                    line: b.line,
                    column: 13,
                    theta_i_deg: b.theta_deg,
                    total,
                });
            }
            incidences.push(Incidence {
                theta: b.theta_deg.to_radians(),
                phi_i: b.phi_i_deg.to_radians(),
                last_positive: b.fractions.iter().rposition(|&f| f > 0.0),
                cell_stderr: b.fraction_stderr.iter().map(|e| e * e).sum::<f64>().sqrt(),
                theta_deg: b.theta_deg,
                phi_i_deg: b.phi_i_deg,
                stated_stderr: None,
                mueller: None,
                fractions: b.fractions,
                fraction_stderr: b.fraction_stderr,
                cdf,
                reflectance: total,
            });
        }
        Ok(Self {
            grid,
            cells,
            thetas_deg: incidences.iter().map(|i| i.theta_deg).collect(),
            angles: incidences
                .iter()
                .step_by(azimuths_deg.len())
                .map(|i| i.theta)
                .collect(),
            azimuths_deg,
            incidences,
            file,
        })
    }

    /// The light azimuths of the table (degrees, as in the file's
    /// `phi_i_deg`), ascending: one for a table of one azimuth.
    #[must_use]
    pub fn azimuths_deg(&self) -> &[f64] {
        &self.azimuths_deg
    }

    /// How far the table's light azimuths depart from isotropy: the figure
    /// `summary.json` states for the run ([`crate::tally::anisotropy`]:
    /// every pair of azimuths at every angle, on the cells the azimuth
    /// difference maps exactly onto cells); `None` for a table of one
    /// azimuth. Incidence `t n + k` is angle `t`, azimuth `k` of `n`.
    #[must_use]
    pub fn anisotropy(&self) -> Option<Anisotropy> {
        let azimuths = self.azimuths_deg();
        let n = azimuths.len();
        if n < 2 {
            return None;
        }
        let thetas = self.thetas_deg();
        let groups: Vec<Group> = (0..thetas.len() / n)
            .map(|t| Group {
                theta_i_deg: thetas[t * n],
                wavelength_um: None,
                tables: (0..n)
                    .map(|k| AzimuthTable {
                        phi_deg: azimuths[k],
                        fraction: self.fractions(t * n + k),
                        stderr: self.fraction_stderrs(t * n + k),
                    })
                    .collect(),
            })
            .collect();
        Anisotropy::of(self.grid(), &groups)
    }

    /// The distinct tabulated incidence angles (degrees), ascending (for a
    /// table of one azimuth, [`thetas_deg`](Self::thetas_deg)).
    #[must_use]
    pub fn angles_deg(&self) -> Vec<f64> {
        self.thetas_deg
            .iter()
            .step_by(self.azimuths_deg.len())
            .copied()
            .collect()
    }

    /// The table of light azimuth `k` of [`azimuths_deg`](Self::azimuths_deg)
    /// alone: its incidences, with what `summary.json` and `mueller.csv`
    /// attached to them. Azimuth 0 of a one-azimuth table is the table.
    ///
    /// # Panics
    /// If there is no azimuth `k`.
    #[must_use]
    pub fn azimuth(&self, k: usize) -> BrdfTable {
        let n = self.azimuths_deg.len();
        assert!(k < n, "azimuth {k} of {n}");
        let incidences: Vec<Incidence> =
            self.incidences.iter().skip(k).step_by(n).cloned().collect();
        Self {
            grid: self.grid,
            cells: self.cells.clone(),
            thetas_deg: incidences.iter().map(|i| i.theta_deg).collect(),
            angles: self.angles.clone(),
            azimuths_deg: vec![self.azimuths_deg[k]],
            incidences,
            file: self.file.clone(),
        }
    }

    /// `Ok` for a table of one light azimuth; for several, the refusal of
    /// `what` (the consumer, e.g. "a BRDF wall of roks trace"): one line
    /// naming the file and `phi_i_deg`.
    ///
    /// # Errors
    /// [`BrdfValuesError::SeveralAzimuths`].
    pub fn require_one_azimuth(&self, what: &str) -> Result<(), BrdfValuesError> {
        if self.azimuths_deg.len() == 1 {
            return Ok(());
        }
        Err(BrdfValuesError::SeveralAzimuths {
            file: self.file.clone(),
            count: self.azimuths_deg.len(),
            list: list_deg(&self.azimuths_deg),
            what: what.to_owned(),
        })
    }

    /// The Mueller matrix of incidence block `incidence`, flat cell `cell`,
    /// divided by its `m00` (row-major), if a `mueller.csv` is attached.
    #[must_use]
    pub fn mueller(&self, incidence: usize, cell: usize) -> Option<&[f64; 16]> {
        self.incidences.get(incidence)?.mueller.as_ref()?.get(cell)
    }

    /// Whether a Mueller table is attached.
    #[must_use]
    pub fn has_mueller(&self) -> bool {
        self.incidences.iter().all(|i| i.mueller.is_some()) && !self.incidences.is_empty()
    }

    /// Tabulated incidence polar angles (degrees), ascending, one per
    /// incidence: with several light azimuths an angle repeats once per
    /// azimuth (incidence `i` is at azimuth `i % n` of
    /// [`azimuths_deg`](Self::azimuths_deg); distinct angles:
    /// [`angles_deg`](Self::angles_deg)).
    #[must_use]
    pub fn thetas_deg(&self) -> &[f64] {
        &self.thetas_deg
    }

    /// Number of Carlson bands `M` of the table's grid.
    #[must_use]
    pub fn bands(&self) -> usize {
        self.grid.bands()
    }

    /// Incidence blocks bracketing `theta` (radians) and the weight of the
    /// upper one: the value at `theta` is `(1 - w) v[i0] + w v[i1]`.
    /// Clamped at the ends; `None` for NaN.
    /// Angles (indices into `angles`; the incidence of angle `t` and
    /// azimuth `k` is `t * n + k`) bracketing `theta` (radians) and the
    /// weight of the upper one: the value at `theta` is
    /// `(1 - w) v[i0] + w v[i1]`. Clamped at the ends; `None` for NaN.
    fn bracket(&self, theta: f64) -> Option<(usize, usize, f64)> {
        if theta.is_nan() {
            return None;
        }
        let n = self.angles.len();
        let i1 = self.angles.partition_point(|&a| a <= theta);
        if i1 == 0 {
            return Some((0, 0, 0.0));
        }
        if i1 >= n {
            return Some((n - 1, n - 1, 0.0));
        }
        let (a, b) = (self.angles[i1 - 1], self.angles[i1]);
        let w = ((theta - a) / (b - a)).clamp(0.0, 1.0);
        Some((i1 - 1, i1, w))
    }

    /// Interpolate a per-incidence value linearly in `theta` (radians); with
    /// several light azimuths, the mean over the azimuths of each one's
    /// interpolation.
    fn interpolate(&self, theta: f64, value: impl Fn(&Incidence) -> f64) -> f64 {
        let n = self.azimuths_deg.len();
        match self.bracket(theta) {
            None => f64::NAN,
            Some((t0, t1, w)) => {
                let at = |k: usize| {
                    let v0 = value(&self.incidences[t0 * n + k]);
                    if w == 0.0 {
                        v0
                    } else {
                        (1.0 - w) * v0 + w * value(&self.incidences[t1 * n + k])
                    }
                };
                if n == 1 {
                    at(0)
                } else {
                    (0..n).map(at).sum::<f64>() / n as f64
                }
            }
        }
    }

    /// Directional-hemispherical reflectance (dimensionless) at incidence
    /// `theta_i_rad` (radians): the sum of the fractions of each tabulated
    /// incidence, interpolated linearly in `theta_i` and clamped to the end
    /// values outside the tabulated range. NaN for a NaN angle.
    #[must_use]
    pub fn reflectance(&self, theta_i_rad: f64) -> f64 {
        self.interpolate(theta_i_rad, |inc| inc.reflectance)
    }

    /// Standard error (dimensionless) of [`reflectance`](Self::reflectance),
    /// interpolated linearly in `theta_i`: per tabulated incidence the value
    /// of `summary.json` after [`with_summary`](Self::with_summary), else
    /// `sqrt(sum fraction_stderr²)`, usually an overestimate (see the module
    /// documentation); with several light azimuths the mean of theirs (a
    /// bound on the error of their average, whatever their correlation).
    /// NaN for a NaN angle.
    #[must_use]
    pub fn reflectance_stderr(&self, theta_i_rad: f64) -> f64 {
        self.interpolate(theta_i_rad, |inc| {
            inc.stated_stderr.unwrap_or(inc.cell_stderr)
        })
    }

    /// True when the standard errors come from `summary.json` (exact).
    #[must_use]
    pub fn has_stated_stderr(&self) -> bool {
        self.incidences
            .iter()
            .all(|inc| inc.stated_stderr.is_some())
    }

    /// Sample an outgoing direction for incidence `theta_i_rad` (radians) by
    /// the method of the module documentation, from four uniform numbers `u`
    /// in `[0, 1)` (out-of-range values are clamped, NaN taken as 0).
    ///
    /// With several light azimuths `u[0]` first picks one uniformly (the
    /// azimuth average of the module documentation).
    ///
    /// Returns the unit direction (local frame, `z > 0`) and the weight
    /// factor, the reflectance of the tabulated incidence chosen; `None` if
    /// that incidence reflects nothing (all fractions 0) or `theta_i_rad` is
    /// NaN.
    #[must_use]
    pub fn sample(&self, theta_i_rad: f64, u: [f64; 4]) -> Option<(DVec3, f64)> {
        self.sample_cell(theta_i_rad, u).map(|s| (s.0, s.1))
    }

    /// As [`sample`](Self::sample), also returning the incidence block and
    /// the flat cell chosen (for [`mueller`](Self::mueller)).
    #[must_use]
    pub fn sample_cell(&self, theta_i_rad: f64, u: [f64; 4]) -> Option<(DVec3, f64, usize, usize)> {
        let (t0, t1, w) = self.bracket(theta_i_rad)?;
        let n = self.azimuths_deg.len();
        // Several azimuths: u[0] picks one uniformly, and its remainder the
        // angle (for one azimuth, k = 0 and u0 = u[0] exactly).
        let scaled = unit(u[0]) * n as f64;
        let k = (scaled as usize).min(n - 1);
        let u0 = scaled - k as f64;
        let chosen = n * if u0 < w { t1 } else { t0 } + k;
        let inc = &self.incidences[chosen];
        let last = inc.last_positive?;
        let x = unit(u[1]) * inc.reflectance;
        let flat = inc.cdf.partition_point(|&c| c <= x).min(last);
        let c = &self.cells[flat];
        // mu² in (mu2_bot, mu2_top]: z > 0 even in the horizon band.
        let mu2 = c.mu2_top - unit(u[2]) * (c.mu2_top - c.mu2_bot);
        let mu = mu2.sqrt();
        let s = (1.0 - mu2).max(0.0).sqrt();
        let phi = c.phi_lo + unit(u[3]) * (c.phi_hi - c.phi_lo) - inc.phi_i;
        let (sp, cp) = phi.sin_cos();
        Some((
            DVec3::new(s * cp, s * sp, mu),
            inc.reflectance,
            chosen,
            flat,
        ))
    }

    /// BRDF (sr⁻¹) of the tabulated cell holding `dir` (local frame; need not
    /// be normalised), `fraction / projected solid angle`, interpolated
    /// linearly in `theta_i` between the two bracketing incidences (each
    /// rotated by its own `phi_i`) and clamped outside the range.
    ///
    /// 0 for directions with `z <= 0` or of zero length; NaN for a NaN angle
    /// or a non-finite `dir`. `∫ eval cos(theta) dω` over the hemisphere is
    /// [`reflectance`](Self::reflectance).
    #[must_use]
    pub fn eval(&self, theta_i_rad: f64, dir: DVec3) -> f64 {
        if !dir.is_finite() {
            return f64::NAN;
        }
        let len = dir.length();
        let d = if dir.z > 0.0 && len > 0.0 {
            Some(dir / len)
        } else {
            None
        };
        self.interpolate(theta_i_rad, |inc| {
            d.and_then(|d| self.grid.locate(rotate_z(d, inc.phi_i)))
                .map_or(0.0, |flat| inc.fractions[flat] / self.cells[flat].proj)
        })
    }

    /// The file's name, as given to the reader or to
    /// [`from_blocks`](Self::from_blocks) (for messages of the readers of
    /// `summary.json` and `mueller.csv` that name it).
    pub(crate) fn file(&self) -> &str {
        &self.file
    }

    /// The table's Carlson grid.
    pub(crate) fn grid(&self) -> &CarlsonGrid {
        &self.grid
    }

    /// Tabulated incidence `i` (in the order of [`thetas_deg`](Self::thetas_deg)).
    ///
    /// # Panics
    /// If there is no incidence `i`.
    pub(crate) fn incidence(&self, i: usize) -> Tabulated {
        let inc = &self.incidences[i];
        Tabulated {
            theta_deg: inc.theta_deg,
            phi_i_deg: inc.phi_i_deg,
            reflectance: inc.reflectance,
        }
    }

    /// BRDF (sr⁻¹) of flat cell `flat` of incidence `i`, `fraction /
    /// projected solid angle`.
    pub(crate) fn cell_brdf(&self, i: usize, flat: usize) -> f64 {
        self.incidences[i].fractions[flat] / self.cells[flat].proj
    }

    /// Attach the exact standard error of incidence `i`'s reflectance (from
    /// `summary.json`).
    pub(crate) fn set_stated_stderr(&mut self, i: usize, stderr: f64) {
        self.incidences[i].stated_stderr = Some(stderr);
    }

    /// Attach incidence `i`'s Mueller matrices per flat cell, divided by
    /// `m00` (from `mueller.csv`).
    pub(crate) fn set_mueller(&mut self, i: usize, normalised: Vec<[f64; 16]>) {
        self.incidences[i].mueller = Some(normalised);
    }

    /// Replace the fractions of incidence `i` by `fractions` (a run with a
    /// polarised incident state: the unpolarised ones of its Mueller
    /// table's `m00`), keeping their standard errors; the reflectance
    /// stated by `summary.json` (the polarised state's) no longer applies.
    ///
    /// # Errors
    /// The new reflectance, when it exceeds 1 (+1e-9).
    pub(crate) fn set_fractions(&mut self, i: usize, fractions: Vec<f64>) -> Result<(), f64> {
        let inc = &mut self.incidences[i];
        let mut total = 0.0;
        let cdf: Vec<f64> = fractions
            .iter()
            .map(|f| {
                total += f;
                total
            })
            .collect();
        if total.is_nan() || total > MAX_FRACTION {
            return Err(total);
        }
        inc.last_positive = fractions.iter().rposition(|&f| f > 0.0);
        inc.fractions = fractions;
        inc.cdf = cdf;
        inc.reflectance = total;
        inc.stated_stderr = None;
        Ok(())
    }

    /// Projected solid angle (sr) of flat cell `flat`.
    pub(crate) fn cell_proj(&self, flat: usize) -> f64 {
        self.cells[flat].proj
    }

    /// The fraction of flat cell `flat` of incidence `i` (dimensionless).
    ///
    /// # Panics
    /// If there is no such incidence or cell.
    pub(crate) fn fraction(&self, i: usize, flat: usize) -> f64 {
        self.incidences[i].fractions[flat]
    }

    /// The fractions of incidence `i`.
    pub(crate) fn fractions(&self, i: usize) -> &[f64] {
        &self.incidences[i].fractions
    }

    /// The standard error of each fraction of incidence `i` (the file's
    /// `fraction_stderr`; for a [`SpectralTables::linear_combination`]
    /// the bound `Σ |w_l| se_l`, whatever the wavelengths' correlation).
    pub(crate) fn fraction_stderrs(&self, i: usize) -> &[f64] {
        &self.incidences[i].fraction_stderr
    }

    /// `sqrt(sum fraction_stderr²)` of incidence `i`.
    #[cfg(test)]
    pub(crate) fn cell_stderr(&self, i: usize) -> f64 {
        self.incidences[i].cell_stderr
    }
}

/// The BRDF of a spectral run (`[light] wavelengths_um`): one
/// [`BrdfTable`] per wavelength, all on the same Carlson grid at the same
/// incidences (angles and light azimuths), wavelengths strictly increasing.
/// Read from a spectral `brdf.csv` by [`BrdfTables::parse`] (in
/// [`crate::output::brdf_csv`], which owns the file), or built from tables
/// by [`SpectralTables::new`].
#[derive(Debug, Clone)]
pub struct SpectralTables {
    /// Vacuum wavelengths (µm), strictly increasing.
    wavelengths_um: Vec<f64>,
    /// The table of each wavelength, in the same order.
    tables: Vec<BrdfTable>,
}

impl SpectralTables {
    /// The tables of `tables`, table `l` at wavelength `wavelengths_um[l]`
    /// (µm); `file` names them in messages.
    ///
    /// # Errors
    /// [`BrdfValuesError::Spectral`] unless there is at least one table, one
    /// wavelength per table, the wavelengths are finite, `> 0` and strictly
    /// increasing, and every table has the first one's bands and incidences
    /// (`theta_i_deg` and `phi_i_deg`, in order).
    pub fn new(
        wavelengths_um: Vec<f64>,
        tables: Vec<BrdfTable>,
        file: &str,
    ) -> Result<Self, BrdfValuesError> {
        let fail = |message: String| BrdfValuesError::Spectral {
            file: file.to_owned(),
            message,
        };
        if tables.is_empty() || tables.len() != wavelengths_um.len() {
            return Err(fail(format!(
                "{} tables for {} wavelengths (need one table per wavelength, at least one)",
                tables.len(),
                wavelengths_um.len()
            )));
        }
        if let Some(w) = wavelengths_um
            .iter()
            .find(|w| !(w.is_finite() && **w > 0.0))
        {
            return Err(fail(format!(
                "wavelength {w} um is not a finite number > 0"
            )));
        }
        if let Some(p) = wavelengths_um.windows(2).find(|p| p[1] <= p[0]) {
            return Err(fail(format!(
                "wavelengths must be strictly increasing: {} um after {} um",
                p[1], p[0]
            )));
        }
        let first = &tables[0];
        let incidences = |t: &BrdfTable| -> Vec<(f64, f64)> {
            (0..t.incidences.len())
                .map(|i| (t.incidences[i].theta_deg, t.incidences[i].phi_i_deg))
                .collect()
        };
        for (t, w) in tables.iter().zip(&wavelengths_um).skip(1) {
            if t.bands() != first.bands() || incidences(t) != incidences(first) {
                return Err(fail(format!(
                    "the table at {w} um has other bands or incidences than the one at {} um",
                    wavelengths_um[0]
                )));
            }
        }
        Ok(Self {
            wavelengths_um,
            tables,
        })
    }

    /// The wavelengths (µm), strictly increasing.
    #[must_use]
    pub fn wavelengths_um(&self) -> &[f64] {
        &self.wavelengths_um
    }

    /// The table of each wavelength, in the order of
    /// [`wavelengths_um`](Self::wavelengths_um).
    #[must_use]
    pub fn tables(&self) -> &[BrdfTable] {
        &self.tables
    }

    /// The tables, mutable (to attach what the summary adds).
    pub(crate) fn tables_mut(&mut self) -> &mut [BrdfTable] {
        &mut self.tables
    }

    /// Tabulated incidence polar angles (degrees), ascending, one per
    /// incidence (those of every wavelength; [`BrdfTable::thetas_deg`]).
    #[must_use]
    pub fn thetas_deg(&self) -> &[f64] {
        self.tables[0].thetas_deg()
    }

    /// The mean of the wavelengths' tables, fraction by fraction: the table
    /// a spectral BRDF wall samples directions from (one path for every
    /// wavelength), each wavelength then weighed by its own fraction over
    /// the mean's in the cell chosen. A mean of non-negative fractions,
    /// so a table like any other (no stated standard errors, no Mueller
    /// matrices).
    #[must_use]
    pub fn mean(&self) -> BrdfTable {
        let n = self.tables.len() as f64;
        self.linear_combination(&vec![1.0 / n; self.tables.len()])
    }

    /// The tables at `wavelengths_um` (µm), each one of this set's
    /// wavelengths exactly, in the order given.
    ///
    /// # Errors
    /// The first wavelength that is not one of the set's.
    pub fn select(&self, wavelengths_um: &[f64]) -> Result<SpectralTables, f64> {
        let tables = wavelengths_um
            .iter()
            .map(|&w| {
                let l = self.wavelengths_um.iter().position(|&x| x == w).ok_or(w)?;
                Ok(self.tables[l].clone())
            })
            .collect::<Result<Vec<_>, f64>>()?;
        Ok(SpectralTables {
            wavelengths_um: wavelengths_um.to_vec(),
            tables,
        })
    }

    /// The linear combination `Σ_l weights[l] f_l` of the wavelengths'
    /// tables, fraction by fraction (so cell by cell, BRDF by BRDF): for
    /// resampling a linear function of the spectrum (e.g. one linear sRGB
    /// channel) in one pass instead of one per wavelength. The result may
    /// hold negative fractions and is meant for [`BrdfTable::eval`] and
    /// [`BrdfTable::reflectance`] only, which are linear in the fractions:
    /// `eval` of the combination is the combination of the `eval`s (to
    /// rounding). Its sampling is meaningless; it is not part of the public
    /// API for that reason.
    ///
    /// # Panics
    /// Unless there is one weight per wavelength.
    #[must_use]
    pub(crate) fn linear_combination(&self, weights: &[f64]) -> BrdfTable {
        assert_eq!(
            weights.len(),
            self.tables.len(),
            "one weight per wavelength"
        );
        let mut out = self.tables[0].clone();
        for (i, inc) in out.incidences.iter_mut().enumerate() {
            let mut total = 0.0;
            for (flat, f) in inc.fractions.iter_mut().enumerate() {
                *f = self
                    .tables
                    .iter()
                    .zip(weights)
                    .map(|(t, w)| w * t.incidences[i].fractions[flat])
                    .sum();
            }
            for (flat, e) in inc.fraction_stderr.iter_mut().enumerate() {
                *e = self
                    .tables
                    .iter()
                    .zip(weights)
                    .map(|(t, w)| w.abs() * t.incidences[i].fraction_stderr[flat])
                    .sum();
            }
            for (c, f) in inc.cdf.iter_mut().zip(&inc.fractions) {
                total += f;
                *c = total;
            }
            inc.reflectance = total;
            inc.last_positive = inc.fractions.iter().rposition(|&f| f > 0.0);
            inc.stated_stderr = None;
            inc.mueller = None;
        }
        out
    }
}

/// The BRDF of a `brdf.csv`: one table (a monochrome run) or one per
/// wavelength (a spectral run, [`SpectralTables`]).
#[derive(Debug, Clone)]
pub enum BrdfTables {
    /// A monochrome table.
    Monochrome(BrdfTable),
    /// A table per wavelength.
    Spectral(SpectralTables),
}

impl BrdfTables {
    /// The tables: the one monochrome table, or one per wavelength.
    #[must_use]
    pub fn tables(&self) -> &[BrdfTable] {
        match self {
            Self::Monochrome(t) => std::slice::from_ref(t),
            Self::Spectral(s) => s.tables(),
        }
    }

    /// The wavelengths (µm) of a spectral table; empty for a monochrome one.
    #[must_use]
    pub fn wavelengths_um(&self) -> &[f64] {
        match self {
            Self::Monochrome(_) => &[],
            Self::Spectral(s) => s.wavelengths_um(),
        }
    }

    /// Tabulated incidence polar angles (degrees), ascending, one per
    /// incidence ([`BrdfTable::thetas_deg`]).
    #[must_use]
    pub fn thetas_deg(&self) -> &[f64] {
        self.tables()[0].thetas_deg()
    }

    /// The light azimuths (degrees), ascending ([`BrdfTable::azimuths_deg`];
    /// every wavelength's table has the same).
    #[must_use]
    pub fn azimuths_deg(&self) -> &[f64] {
        self.tables()[0].azimuths_deg()
    }

    /// As [`BrdfTable::require_one_azimuth`].
    ///
    /// # Errors
    /// [`BrdfValuesError::SeveralAzimuths`].
    pub fn require_one_azimuth(&self, what: &str) -> Result<(), BrdfValuesError> {
        self.tables()[0].require_one_azimuth(what)
    }

    /// The monochrome table, if it is one.
    #[must_use]
    pub fn monochrome(&self) -> Option<&BrdfTable> {
        match self {
            Self::Monochrome(t) => Some(t),
            Self::Spectral(_) => None,
        }
    }

    /// The tables per wavelength, if spectral.
    #[must_use]
    pub fn spectral(&self) -> Option<&SpectralTables> {
        match self {
            Self::Monochrome(_) => None,
            Self::Spectral(s) => Some(s),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;
    use std::f64::consts::{PI, TAU};

    /// One block of a test table: angle, light azimuth (degrees), fraction
    /// per flat cell.
    struct TestBlock {
        theta: f64,
        phi_i: f64,
        fractions: Vec<f64>,
    }

    /// The table of `blocks` on a grid of `m` bands, standard errors 1% of
    /// the fractions.
    fn table(m: usize, blocks: &[TestBlock], name: &str) -> BrdfTable {
        let blocks = blocks
            .iter()
            .map(|b| {
                let se = b.fractions.iter().map(|f| 0.01 * f).collect();
                (b.theta, b.phi_i, b.fractions.clone(), se)
            })
            .collect();
        BrdfTable::from_blocks(CarlsonGrid::new(m).unwrap(), blocks, name).unwrap()
    }

    fn lambertian(m: usize, albedo: f64) -> Vec<f64> {
        let g = CarlsonGrid::new(m).unwrap();
        (0..g.n_cells())
            .map(|flat| {
                let (band, cell) = g.band_cell(flat);
                albedo * g.projected_solid_angle(band, cell) / PI
            })
            .collect()
    }

    fn dir(theta_deg: f64, phi_deg: f64) -> DVec3 {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// Upper `p = 1e-4` point of chi-square with `dof` degrees of freedom
    /// (Wilson-Hilferty).
    fn chi2_crit(dof: f64) -> f64 {
        let z = 3.719; // one-sided normal quantile of 1e-4
        let h = 2.0 / (9.0 * dof);
        dof * (1.0 - h + z * h.sqrt()).powi(3)
    }

    /// Kolmogorov-Smirnov distance of samples from uniform on [0, 1].
    fn ks_uniform(mut x: Vec<f64>) -> f64 {
        x.sort_by(f64::total_cmp);
        let n = x.len() as f64;
        x.iter()
            .enumerate()
            .map(|(i, &v)| (v - i as f64 / n).abs().max(((i + 1) as f64 / n - v).abs()))
            .fold(0.0, f64::max)
    }

    fn uniforms(rng: &mut Pcg64Mcg) -> [f64; 4] {
        [rng.random(), rng.random(), rng.random(), rng.random()]
    }

    fn lambert_table() -> BrdfTable {
        let m = 8;
        let blocks: Vec<TestBlock> = [0.0, 30.0, 60.0]
            .iter()
            .map(|&theta| TestBlock {
                theta,
                phi_i: 0.0,
                fractions: lambertian(m, 0.7),
            })
            .collect();
        table(m, &blocks, "lambert.csv")
    }

    #[test]
    fn lambertian_reflectance_and_eval() {
        let t = lambert_table();
        assert_eq!(t.thetas_deg(), &[0.0, 30.0, 60.0]);
        assert_eq!(t.bands(), 8);
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        // The file holds 10 significant digits (as `roks brdf` writes it).
        for theta in [-0.3, 0.0, 0.2, 30f64.to_radians(), 0.9, 1.2, 1.5] {
            assert!((t.reflectance(theta) - 0.7).abs() < 1e-9, "{theta}");
            // From the file alone: sqrt(sum (0.01 f)^2).
            let sum_f2: f64 = lambertian(8, 0.7).iter().map(|f| f * f).sum();
            let bound = 0.01 * sum_f2.sqrt();
            assert!((t.reflectance_stderr(theta) / bound - 1.0).abs() < 1e-9);
            for _ in 0..200 {
                let d = dir(90.0 * rng.random::<f64>(), 360.0 * rng.random::<f64>());
                assert!((t.eval(theta, d) - 0.7 / PI).abs() < 1e-9);
                // Not normalised: same value.
                assert!((t.eval(theta, 3.0 * d) - 0.7 / PI).abs() < 1e-9);
            }
            assert_eq!(t.eval(theta, DVec3::new(0.3, 0.1, -0.5)), 0.0);
            assert_eq!(t.eval(theta, DVec3::ZERO), 0.0);
        }
    }

    /// 2e5 samples at an angle between tables: mu² and phi uniform (KS) and
    /// cell counts proportional to projected solid angle (chi-square), all at
    /// p = 1e-4; weight 0.7 (to the file's 10 digits) every time.
    #[test]
    fn lambertian_sampling() {
        let t = lambert_table();
        let g = CarlsonGrid::new(8).unwrap();
        let n = 200_000;
        let mut rng = Pcg64Mcg::seed_from_u64(2024);
        let mut mu2 = Vec::with_capacity(n);
        let mut phi = Vec::with_capacity(n);
        let mut counts = vec![0u64; g.n_cells()];
        for _ in 0..n {
            let (d, w) = t.sample(45f64.to_radians(), uniforms(&mut rng)).unwrap();
            // The reflectance of a file of 10 significant digits.
            assert!((w - 0.7).abs() < 1e-9);
            assert!(d.z > 0.0 && (d.length() - 1.0).abs() < 1e-14);
            mu2.push(d.z * d.z);
            phi.push((d.y.atan2(d.x) + PI) / (2.0 * PI));
            counts[g.locate(d).unwrap()] += 1;
        }
        let crit = (-(1e-4f64 / 2.0).ln() / (2.0 * n as f64)).sqrt();
        let (d_mu, d_phi) = (ks_uniform(mu2), ks_uniform(phi));
        assert!(d_mu < crit, "KS mu^2: {d_mu} >= {crit}");
        assert!(d_phi < crit, "KS phi: {d_phi} >= {crit}");
        let chi2: f64 = counts
            .iter()
            .enumerate()
            .map(|(flat, &c)| {
                let (band, cell) = g.band_cell(flat);
                let e = n as f64 * g.projected_solid_angle(band, cell) / PI;
                (c as f64 - e).powi(2) / e
            })
            .sum();
        let dof = (g.n_cells() - 1) as f64;
        assert!(chi2 < chi2_crit(dof), "chi2 {chi2} for {dof} dof");
    }

    /// All the weight in one cell per incidence (the specular cell), with a
    /// different reflectance per incidence.
    fn mirror_blocks(m: usize, phi_i: f64) -> (Vec<TestBlock>, Vec<usize>) {
        let g = CarlsonGrid::new(m).unwrap();
        let mut cells = Vec::new();
        let blocks = [(0.0, 0.5), (30.0, 0.6), (60.0, 0.9)]
            .iter()
            .map(|&(theta, r)| {
                // Specular direction in absolute azimuth phi_i + 180.
                // (At normal incidence the azimuth still follows phi_i.)
                let c = g.locate(dir(f64::max(theta, 1e-6), phi_i + 180.0)).unwrap();
                cells.push(c);
                let mut fractions = vec![0.0; g.n_cells()];
                fractions[c] = r;
                TestBlock {
                    theta,
                    phi_i,
                    fractions,
                }
            })
            .collect();
        (blocks, cells)
    }

    #[test]
    fn mirror_cells_and_interpolation_weights() {
        let m = 10;
        let g = CarlsonGrid::new(m).unwrap();
        let (blocks, cells) = mirror_blocks(m, 0.0);
        let t = table(m, &blocks, "mirror.csv");
        let mut rng = Pcg64Mcg::seed_from_u64(99);
        // At, below and above the tabulated angles: one cell, one weight.
        for (theta, k) in [(0.0, 0), (-0.2, 0), (30.0, 1), (60.0, 2), (85.0, 2)] {
            let r = [0.5, 0.6, 0.9][k];
            for _ in 0..2000 {
                let (d, w) = t
                    .sample(f64::to_radians(theta), uniforms(&mut rng))
                    .unwrap();
                assert_eq!(g.locate(d), Some(cells[k]), "theta {theta}");
                assert_eq!(w, r);
            }
            assert_eq!(t.reflectance(f64::to_radians(theta)), r);
        }
        // Between 30 and 60: the 60 table with probability w (binomial, 4 sigma).
        for (theta, w) in [(40.0, 1.0 / 3.0), (55.0, 5.0 / 6.0), (15.0, 0.5)] {
            let (lo, hi) = if theta < 30.0 { (0, 1) } else { (1, 2) };
            let n = 100_000;
            let mut upper = 0u64;
            for _ in 0..n {
                let (d, wt) = t
                    .sample(f64::to_radians(theta), uniforms(&mut rng))
                    .unwrap();
                let c = g.locate(d).unwrap();
                if c == cells[hi] {
                    upper += 1;
                    assert_eq!(wt, [0.5, 0.6, 0.9][hi]);
                } else {
                    assert_eq!(c, cells[lo]);
                    assert_eq!(wt, [0.5, 0.6, 0.9][lo]);
                }
            }
            let sigma = (n as f64 * w * (1.0 - w)).sqrt();
            assert!(
                (upper as f64 - n as f64 * w).abs() < 4.0 * sigma,
                "theta {theta}: {upper} of {n}, expected {w}"
            );
            let r = [0.5, 0.6, 0.9];
            let expect = (1.0 - w) * r[lo] + w * r[hi];
            assert!((t.reflectance(f64::to_radians(theta)) - expect).abs() < 1e-12);
        }
    }

    #[test]
    fn all_zero_is_absorbed() {
        let m = 3;
        let g = CarlsonGrid::new(m).unwrap();
        let mut half = vec![0.0; g.n_cells()];
        half[5] = 0.4;
        let blocks = [
            TestBlock {
                theta: 10.0,
                phi_i: 0.0,
                fractions: vec![0.0; g.n_cells()],
            },
            TestBlock {
                theta: 20.0,
                phi_i: 0.0,
                fractions: half,
            },
        ];
        let t = table(m, &blocks, "zero.csv");
        assert_eq!(t.sample(0.1, [0.5; 4]), None);
        assert_eq!(t.reflectance(0.0), 0.0);
        assert_eq!(t.reflectance_stderr(0.0), 0.0);
        // 15 degrees: absorbed exactly when u[0] >= 0.5.
        let th = 15f64.to_radians();
        assert_eq!(t.sample(th, [0.6, 0.5, 0.5, 0.5]), None);
        let (d, w) = t.sample(th, [0.4, 0.5, 0.5, 0.5]).unwrap();
        assert_eq!((g.locate(d), w), (Some(5), 0.4));
        assert!((t.reflectance(th) - 0.2).abs() < 1e-15);
    }

    /// A table traced with the light at phi_i = 90 deg, i.e. the phi_i = 0
    /// table turned by 90 deg (cell k of band j -> k + j), samples the same
    /// local directions and has the same BRDF in the local frame.
    #[test]
    fn rotation_to_the_incidence_azimuth() {
        let m = 6;
        let g = CarlsonGrid::new(m).unwrap();
        // Mirror tables: the same u give the same direction.
        let (b0, _) = mirror_blocks(m, 0.0);
        let (b90, _) = mirror_blocks(m, 90.0);
        let t0 = table(m, &b0, "phi0.csv");
        let t90 = table(m, &b90, "phi90.csv");
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        for _ in 0..10_000 {
            let theta = 1.5 * rng.random::<f64>();
            let u = uniforms(&mut rng);
            let (d0, w0) = t0.sample(theta, u).unwrap();
            let (d90, w90) = t90.sample(theta, u).unwrap();
            assert!((d0 - d90).length() < 1e-12, "{d0} vs {d90}");
            assert_eq!(w0, w90);
        }
        // A structured table: eval agrees everywhere, and samples from the
        // turned table follow the fractions of the unturned one in the local
        // frame (chi-square, p = 1e-4).
        let turn = |f: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; f.len()];
            for (flat, &v) in f.iter().enumerate() {
                let (band, cell) = g.band_cell(flat);
                out[g.index(band, (cell + band) % (4 * band))] = v;
            }
            out
        };
        let mut r = Pcg64Mcg::seed_from_u64(11);
        let f0: Vec<Vec<f64>> = (0..2)
            .map(|_| (0..g.n_cells()).map(|_| r.random::<f64>() * 0.02).collect())
            .collect();
        let mk = |phi_i: f64, turned: bool| -> BrdfTable {
            let blocks: Vec<TestBlock> = [20.0, 50.0]
                .iter()
                .zip(&f0)
                .map(|(&theta, f)| TestBlock {
                    theta,
                    phi_i,
                    fractions: if turned { turn(f) } else { f.clone() },
                })
                .collect();
            table(m, &blocks, "t.csv")
        };
        let (t0, t90) = (mk(0.0, false), mk(90.0, true));
        for _ in 0..2000 {
            let d = dir(89.9 * rng.random::<f64>(), 360.0 * rng.random::<f64>());
            let theta = 1.4 * rng.random::<f64>();
            let (a, b) = (t0.eval(theta, d), t90.eval(theta, d));
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{a} vs {b}");
        }
        let n = 200_000;
        let mut counts = vec![0u64; g.n_cells()];
        for _ in 0..n {
            let (d, _) = t90.sample(20f64.to_radians(), uniforms(&mut rng)).unwrap();
            counts[g.locate(d).unwrap()] += 1;
        }
        let total: f64 = f0[0].iter().sum();
        let chi2: f64 = counts
            .iter()
            .zip(&f0[0])
            .map(|(&c, &f)| {
                let e = n as f64 * f / total;
                (c as f64 - e).powi(2) / e
            })
            .sum();
        let dof = (g.n_cells() - 1) as f64;
        assert!(chi2 < chi2_crit(dof), "chi2 {chi2} for {dof} dof");
    }

    /// `∫ eval cos dω = reflectance` at any angle, with tables turned to
    /// azimuths that do not align their cells with the local grid. The
    /// rotation keeps `z`, so within a band `eval` is piecewise constant in
    /// `phi` with breaks at the cell edges of each table, shifted by its
    /// `-phi_i`: the integral over the band is exact as a sum over those
    /// intervals.
    #[test]
    fn eval_integrates_to_reflectance() {
        let m = 5;
        let g = CarlsonGrid::new(m).unwrap();
        let mut r = Pcg64Mcg::seed_from_u64(3);
        let phis = [0.0, 30.0, 200.0];
        let blocks: Vec<TestBlock> = [0.0, 45.0, 80.0]
            .iter()
            .zip(phis)
            .map(|(&theta, phi_i)| TestBlock {
                theta,
                phi_i,
                fractions: (0..g.n_cells()).map(|_| r.random::<f64>() * 0.02).collect(),
            })
            .collect();
        let t = table(m, &blocks, "t.csv");
        for theta in [-0.1, 0.0, 0.3, 45f64.to_radians(), 1.0, 1.4, 1.5] {
            let mut integral = 0.0;
            for band in 1..=m {
                let (bot, top) = g.mu_edges(band);
                let mu = 0.5 * (bot + top);
                let dphi = TAU / (4 * band) as f64;
                let mut breaks: Vec<f64> = phis
                    .iter()
                    .flat_map(|p| {
                        (0..4 * band).map(move |k| {
                            ((k as f64 - 0.5) * dphi - p.to_radians()).rem_euclid(TAU)
                        })
                    })
                    .collect();
                breaks.sort_by(f64::total_cmp);
                breaks.push(breaks[0] + TAU);
                for w in breaks.windows(2) {
                    let p = 0.5 * (w[0] + w[1]);
                    let s = (1.0 - mu * mu).sqrt();
                    let d = DVec3::new(s * p.cos(), s * p.sin(), mu);
                    integral += t.eval(theta, d) * (w[1] - w[0]) * 0.5 * (top * top - bot * bot);
                }
            }
            let refl = t.reflectance(theta);
            assert!((integral - refl).abs() < 1e-12, "{integral} vs {refl}");
        }
    }

    /// Bad input: no panics, NaN or None.
    #[test]
    fn bad_arguments() {
        let t = lambert_table();
        assert!(t.reflectance(f64::NAN).is_nan());
        assert!(t.reflectance_stderr(f64::NAN).is_nan());
        assert!(t.eval(f64::NAN, DVec3::Z).is_nan());
        assert!(t.eval(0.1, DVec3::new(f64::NAN, 0.0, 1.0)).is_nan());
        assert_eq!(t.sample(f64::NAN, [0.5; 4]), None);
        for u in [
            [f64::NAN; 4],
            [1.0; 4],
            [-3.0; 4],
            [f64::INFINITY; 4],
            [0.0; 4],
        ] {
            let (d, w) = t.sample(0.4, u).unwrap();
            assert!(d.z > 0.0 && d.is_finite() && (d.length() - 1.0).abs() < 1e-14);
            assert_eq!(w, t.incidences[0].reflectance);
        }
        assert!(t.sample(f64::INFINITY, [0.5; 4]).is_some());
        assert!(t.sample(f64::NEG_INFINITY, [0.5; 4]).is_some());
    }
}
