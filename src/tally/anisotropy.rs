//! How far a BRDF table traced at several light azimuths departs from
//! isotropy: chi² of the azimuth-shifted tables against each other.
//!
//! # The figure
//! A surface is isotropic (statistically unchanged by rotations about its
//! normal) when the BRDF depends on the outgoing azimuth only through
//! `phi_o - phi_i`: the table lit from `phi_b` is the table lit from
//! `phi_a` turned by `dphi = phi_b - phi_a`. The Carlson grid
//! ([`crate::tally::carlson`]) has absolute azimuth cells: band `j` has
//! `4 j` cells of width `90 / j` degrees, cell `k` centred on
//! `k 90 / j`. A turn by `dphi` maps the cells of band `j` onto cells
//! exactly when `s_j = dphi 4 j / 360 = dphi j / 90` is an integer (within
//! `1e-9`, for azimuths that are not exact binary fractions); then cell `k`
//! of table `a` and cell `(k + s_j) mod 4 j` of table `b` see the same
//! directions relative to the light. Only those bands are compared (all of
//! them for `dphi` a multiple of 90 degrees; none below band 2 for 45).
//!
//! For a pair of tables, with `f` a cell's fraction and `s` its standard
//! error (as `brdf.csv` has them),
//! `chi² = Σ (f_a − f_b)² / (s_a² + s_b²)` over the compared cell pairs
//! where `s_a² + s_b² > 0`, and `dof` the number of those pairs. A pair
//! where one table has no photon (`f = s = 0`) is compared: a lobe one
//! table has and the other lacks is the plainest anisotropy (45-degree
//! V-grooves lit across and along send their light into disjoint cells).
//! The cells' small multinomial covariance (`−f_a f_b / N` within one
//! table) is neglected, and the azimuths' tables are independent (each
//! azimuth is traced with its own seed,
//! [`crate::transport::brdf::BrdfRun::azimuth_seed`]), so for an isotropic
//! surface `chi²` is chi²-distributed with `dof` degrees of freedom in the
//! limit of many photons per cell: `chi²/dof` is 1 within `sqrt(2/dof)`.
//! [`Figure::bound`] is the 4-sigma bound `1 + 4 sqrt(2/dof)`, and
//! [`Figure::p_value`] the upper tail of that chi² distribution
//! (Wilson–Hilferty normal approximation, good to a few per cent of `p`
//! for `dof >= 10`).
//!
//! A run ([`Anisotropy::of`]) compares every pair of azimuths `a < b` at
//! every incidence angle and wavelength, and sums the pairs' chi² and dof.
//! With more than [`ALL_PAIRS_MAX`] azimuths it compares each azimuth with
//! the next one in the run's order only (`n - 1` pairs of `n` azimuths,
//! not `n (n - 1) / 2`: the figure's cost and its list of pairs grow as
//! the azimuths, not as their square; every azimuth is still compared).
//! With more than two azimuths the pairs share tables, so their terms are
//! correlated: the mean of the total `chi²/dof` is still 1 for an isotropic
//! surface, but its spread exceeds `sqrt(2/dof)`; judge the pairs one by
//! one then.
//!
//! A random surface is isotropic only in the mean over realisations
//! (`[surface] realisations`): one realisation has its own hills and
//! valleys, which do not turn with the light, so its table fails the
//! figure by nature once the photons resolve them; the ensemble's table,
//! with the errors of the ensemble mean, is the one to judge. A height
//! field is isotropic only up to its grid:
//! its triangles (every square cut along the same diagonal) are unchanged
//! by a half turn, so azimuths 180 degrees apart are equivalent exactly,
//! others only for a field fine against its correlation length.

use super::carlson::CarlsonGrid;

/// Up to this many azimuths, every pair of azimuths is compared; beyond
/// it, each azimuth with the next one (see the module docs).
pub const ALL_PAIRS_MAX: usize = 8;

/// One table at one light azimuth: the fraction and its standard error
/// per flat Carlson cell (as `brdf.csv`'s `fraction`, `fraction_stderr`).
#[derive(Debug, Clone, Copy)]
pub struct Table<'a> {
    /// Light azimuth (degrees).
    pub phi_deg: f64,
    /// Fraction per flat cell.
    pub fraction: &'a [f64],
    /// Its standard error per flat cell.
    pub stderr: &'a [f64],
}

/// chi² of a comparison and its degrees of freedom.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Figure {
    /// `Σ (f_a − f_b)² / (s_a² + s_b²)` over the compared cells.
    pub chi2: f64,
    /// chi² per degree of freedom (0 without a compared cell).
    pub chi2_dof: f64,
    /// Compared cells.
    pub dof: u64,
    /// The 4-sigma bound of an isotropic surface, `1 + 4 sqrt(2/dof)` (0
    /// without a compared cell).
    pub bound: f64,
    /// Probability of a chi² at least this large for an isotropic surface
    /// (Wilson–Hilferty; 1 without a compared cell).
    pub p_value: f64,
}

impl Figure {
    /// The figure of a chi² over `dof` cells.
    #[must_use]
    pub fn new(chi2: f64, dof: u64) -> Self {
        if dof == 0 {
            return Self {
                chi2,
                chi2_dof: 0.0,
                dof,
                bound: 0.0,
                p_value: 1.0,
            };
        }
        let nu = dof as f64;
        // Wilson–Hilferty: (chi²/nu)^(1/3) is normal with mean
        // 1 − 2/(9 nu) and variance 2/(9 nu).
        let v = 2.0 / (9.0 * nu);
        let z = ((chi2 / nu).cbrt() - (1.0 - v)) / v.sqrt();
        Self {
            chi2,
            chi2_dof: chi2 / nu,
            dof,
            bound: 1.0 + 4.0 * (2.0 / nu).sqrt(),
            p_value: 0.5 * libm::erfc(z / std::f64::consts::SQRT_2),
        }
    }

    /// Whether the tables agree within the 4-sigma bound.
    #[must_use]
    pub fn isotropic(&self) -> bool {
        self.chi2_dof <= self.bound
    }
}

/// The shift `s_j` (in cells, in `0..4j`) that turns band `j` by `dphi`
/// degrees onto itself, if it is a whole number of cells.
#[must_use]
pub fn band_shift(j: usize, dphi_deg: f64) -> Option<usize> {
    let s = dphi_deg * j as f64 / 90.0;
    let r = s.round();
    ((s - r).abs() <= 1e-9 * s.abs().max(1.0)).then(|| (r as i64).rem_euclid(4 * j as i64) as usize)
}

/// chi² and dof of table `b` against table `a` turned by
/// `b.phi_deg − a.phi_deg` (see the module docs).
///
/// # Panics
/// If a table does not have the grid's cells.
#[must_use]
pub fn compare(grid: &CarlsonGrid, a: &Table, b: &Table) -> Figure {
    let n = grid.n_cells();
    assert!(a.fraction.len() == n && a.stderr.len() == n);
    assert!(b.fraction.len() == n && b.stderr.len() == n);
    let dphi = b.phi_deg - a.phi_deg;
    let (mut chi2, mut dof) = (0.0, 0);
    for j in 1..=grid.bands() {
        let Some(s) = band_shift(j, dphi) else {
            continue;
        };
        let cells = 4 * j;
        for k in 0..cells {
            let (ca, cb) = (grid.index(j, k), grid.index(j, (k + s) % cells));
            let var = a.stderr[ca].powi(2) + b.stderr[cb].powi(2);
            if var > 0.0 {
                chi2 += (a.fraction[ca] - b.fraction[cb]).powi(2) / var;
                dof += 1;
            }
        }
    }
    Figure::new(chi2, dof)
}

/// One compared pair of azimuths of a run, at one incidence and wavelength.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pair {
    /// The comparison.
    #[serde(flatten)]
    pub figure: Figure,
    /// First azimuth (degrees).
    pub phi_a_deg: f64,
    /// Second azimuth (degrees).
    pub phi_b_deg: f64,
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Wavelength (µm) of a spectral run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wavelength_um: Option<f64>,
}

/// The anisotropy of a run with several light azimuths (`summary.json`'s
/// `anisotropy`): the sum over every pair of azimuths at every incidence
/// and wavelength, and each pair.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Anisotropy {
    /// The sum over the pairs.
    #[serde(flatten)]
    pub figure: Figure,
    /// Pairs compared.
    pub pair_count: u64,
    /// Each pair, in the order incidence, wavelength, `a`, `b`.
    pub pairs: Vec<Pair>,
}

/// The tables of one incidence and wavelength at each azimuth, with that
/// incidence and wavelength.
pub struct Group<'a> {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Wavelength (µm) of a spectral run.
    pub wavelength_um: Option<f64>,
    /// One table per azimuth.
    pub tables: Vec<Table<'a>>,
}

impl Anisotropy {
    /// Compare every pair of azimuths of each group (of more than
    /// [`ALL_PAIRS_MAX`] azimuths, each with the next); `None` when no
    /// group has two azimuths.
    #[must_use]
    pub fn of(grid: &CarlsonGrid, groups: &[Group]) -> Option<Self> {
        let mut pairs = Vec::new();
        for g in groups {
            let all = g.tables.len() <= ALL_PAIRS_MAX;
            for (i, a) in g.tables.iter().enumerate() {
                let later = &g.tables[i + 1..];
                let partners = if all {
                    later
                } else {
                    &later[..later.len().min(1)]
                };
                for b in partners {
                    pairs.push(Pair {
                        figure: compare(grid, a, b),
                        phi_a_deg: a.phi_deg,
                        phi_b_deg: b.phi_deg,
                        theta_i_deg: g.theta_i_deg,
                        wavelength_um: g.wavelength_um,
                    });
                }
            }
        }
        if pairs.is_empty() {
            return None;
        }
        let chi2 = pairs.iter().map(|p| p.figure.chi2).sum();
        let dof = pairs.iter().map(|p| p.figure.dof).sum();
        Some(Self {
            figure: Figure::new(chi2, dof),
            pair_count: pairs.len() as u64,
            pairs,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table whose fraction depends on the cell's azimuth relative to
    /// `phi_deg` through `shape`, with error `e` everywhere.
    fn table(grid: &CarlsonGrid, phi_deg: f64, shape: impl Fn(f64) -> f64) -> Vec<f64> {
        (0..grid.n_cells())
            .map(|c| {
                let (b, k) = grid.band_cell(c);
                let (_, phi) = grid.centre(b, k);
                shape(phi.to_degrees() - phi_deg)
            })
            .collect()
    }

    #[test]
    fn shifts_are_whole_cells_only() {
        assert_eq!(band_shift(1, 90.0), Some(1));
        assert_eq!(band_shift(1, 45.0), None);
        assert_eq!(band_shift(2, 45.0), Some(1));
        assert_eq!(band_shift(3, 30.0), Some(1));
        assert_eq!(band_shift(2, 30.0), None);
        assert_eq!(band_shift(1, -90.0), Some(3));
        assert_eq!(band_shift(5, 180.0), Some(10));
    }

    /// An isotropic table (a function of `phi - phi_i`) turned exactly:
    /// chi² 0 over every cell of the bands a turn of 30 degrees maps (the
    /// bands `j` divisible by 3); a table that does not turn with the
    /// light: chi² by the formula.
    #[test]
    fn turned_tables_agree_and_fixed_ones_do_not() {
        let grid = CarlsonGrid::new(6).unwrap();
        let shape = |d: f64| 2.0 + d.to_radians().cos();
        let e = vec![0.1; grid.n_cells()];
        let (fa, fb) = (table(&grid, 10.0, shape), table(&grid, 40.0, shape));
        fn t<'a>(phi_deg: f64, f: &'a [f64], e: &'a [f64]) -> Table<'a> {
            Table {
                phi_deg,
                fraction: f,
                stderr: e,
            }
        }
        let same = compare(&grid, &t(10.0, &fa, &e), &t(40.0, &fb, &e));
        assert_eq!(same.dof, (4 * 3 + 4 * 6) as u64);
        assert!(same.chi2 < 1e-20, "{same:?}");
        assert!(same.isotropic());
        // The table lit from 40 degrees that stays the one of 10 degrees:
        // cell k against cell k + s, each term (f(k) − f(k + s))² / 0.02.
        let fixed = compare(&grid, &t(10.0, &fa, &e), &t(40.0, &fa, &e));
        let mut want = 0.0;
        for j in [3, 6] {
            let s = j / 3;
            for k in 0..4 * j {
                let (x, y) = (grid.index(j, k), grid.index(j, (k + s) % (4 * j)));
                want += (fa[x] - fa[y]).powi(2) / 0.02;
            }
        }
        assert!(
            (fixed.chi2 - want).abs() <= 1e-12 * want,
            "{fixed:?} {want}"
        );
        assert!(!fixed.isotropic());
    }

    /// The figure's bound and p-value: chi² = dof gives p near 0.5, a
    /// chi² at the 4-sigma bound a p-value of order 1e-4 (Wilson–Hilferty
    /// 7.4e-5 at dof 1000: the chi² tail is heavier than the normal's 3.2e-5).
    #[test]
    fn figure_bound_and_p_value() {
        let f = Figure::new(1000.0, 1000);
        assert_eq!(f.chi2_dof, 1.0);
        assert!((f.p_value - 0.5).abs() < 0.01, "{f:?}");
        assert!((f.bound - (1.0 + 4.0 * 0.002f64.sqrt())).abs() < 1e-15);
        let at = Figure::new(f.bound * 1000.0, 1000);
        assert!(at.p_value > 1e-5 && at.p_value < 1e-4, "{at:?}");
        assert_eq!(Figure::new(0.0, 0).p_value, 1.0);
    }

    /// Up to [`ALL_PAIRS_MAX`] azimuths every pair is compared, beyond it
    /// each azimuth with the next: `n (n - 1) / 2` pairs, then `n - 1`,
    /// each the [`compare`] of its two tables.
    #[test]
    fn pairs_of_few_and_of_many_azimuths() {
        let grid = CarlsonGrid::new(4).unwrap();
        let e = vec![0.1; grid.n_cells()];
        let shape = |d: f64| 2.0 + (2.0 * d.to_radians()).cos();
        for n in [2, 3, ALL_PAIRS_MAX, ALL_PAIRS_MAX + 1, 1000] {
            let phis: Vec<f64> = (0..n).map(|i| 90.0 * i as f64).collect();
            let fs: Vec<Vec<f64>> = phis.iter().map(|&p| table(&grid, p + 5.0, shape)).collect();
            let tables = phis
                .iter()
                .zip(&fs)
                .map(|(&phi_deg, f)| Table {
                    phi_deg,
                    fraction: f,
                    stderr: &e,
                })
                .collect();
            let a = Anisotropy::of(
                &grid,
                &[Group {
                    theta_i_deg: 30.0,
                    wavelength_um: None,
                    tables,
                }],
            )
            .unwrap();
            let want: Vec<(f64, f64)> = if n <= ALL_PAIRS_MAX {
                (0..n)
                    .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
                    .map(|(i, j)| (phis[i], phis[j]))
                    .collect()
            } else {
                phis.windows(2).map(|w| (w[0], w[1])).collect()
            };
            let got: Vec<(f64, f64)> = a.pairs.iter().map(|p| (p.phi_a_deg, p.phi_b_deg)).collect();
            assert_eq!(got, want, "{n} azimuths");
            assert_eq!(a.pair_count, want.len() as u64);
            // The tables turn with the light by whole cells: chi² 0.
            assert!(a.figure.chi2 < 1e-20 && a.figure.dof > 0, "{:?}", a.figure);
        }
    }

    /// Cells empty in both tables are not compared; a cell lit in one only
    /// is.
    #[test]
    fn empty_cells() {
        let grid = CarlsonGrid::new(1).unwrap();
        let zero = vec![0.0; 4];
        let lit = vec![0.5, 0.0, 0.0, 0.0];
        let lit_e = vec![0.1, 0.0, 0.0, 0.0];
        let a = Table {
            phi_deg: 0.0,
            fraction: &lit,
            stderr: &lit_e,
        };
        let b = Table {
            phi_deg: 90.0,
            fraction: &zero,
            stderr: &zero,
        };
        let f = compare(&grid, &a, &b);
        assert_eq!(f.dof, 1);
        assert!((f.chi2 - 25.0).abs() < 1e-12);
    }
}
