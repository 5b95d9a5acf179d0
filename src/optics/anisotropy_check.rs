//! How far a BRDF table of several light azimuths departs from isotropy:
//! [`anisotropy`], a chi² of the azimuth blocks against each other on the
//! cells that map onto each other exactly under the azimuth shift.
//!
//! # The figure
//!
//! An isotropic surface has a BRDF that depends on the azimuth difference
//! only, so the block traced with the light at `phi_k` is the block at
//! `phi_0` turned by `d = phi_k - phi_0`. Band `j` of the Carlson grid (see
//! [`crate::tally::CarlsonGrid`]) has `4 j` cells of `360 / (4 j)` degrees
//! centred at `c 360 / (4 j)`, so the turn maps cell `c` of band `j` onto
//! cell `c + s` exactly when `s = d 4 j / 360` is an integer (to 1e-9);
//! bands where it is not are left out (for `d = 90` degrees every band
//! maps; for `d = 45` the even bands). Over every angle of incidence, every
//! azimuth `k > 0` against azimuth 0 and every such cell pair with a
//! positive combined error,
//!
//! `chi² = Σ (f_0[c] - f_k[c + s])² / (σ_0[c]² + σ_k[c + s]²)`,
//!
//! with `f` the cell's fraction and `σ` its standard error (`brdf.csv`'s
//! `fraction_stderr`), and `dof` the number of pairs. For an isotropic
//! surface and independent cells, `chi²/dof` has mean 1 and standard
//! deviation `sqrt(2 / dof)`; [`Anisotropy::anisotropic`] flags
//! `chi²/dof > 1 + 4 sqrt(2 / dof)`. Cells of one block are slightly
//! anticorrelated (a photon leaves through one cell) and blocks traced
//! with shared random streams positively correlated; both make the figure
//! of an isotropic table smaller, not larger, so the flag errs toward
//! silence.
//!
//! This module is named `anisotropy_check` so as not to clash with a
//! `tally::anisotropy` of the run itself.

use crate::optics::brdf_table::BrdfTable;

/// The cell pair that departs most from isotropy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorstPair {
    /// Incidence angle (degrees).
    pub theta_i_deg: f64,
    /// The light azimuth compared with the first one (degrees).
    pub phi_i_deg: f64,
    /// Band of the cell at the first azimuth (1-based, from the pole).
    pub band: usize,
    /// Cell in the band at the first azimuth.
    pub cell: usize,
    /// Its difference in standard errors, `(f_k - f_0) / sqrt(σ_0² + σ_k²)`.
    pub z: f64,
}

/// The figure of [`anisotropy`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anisotropy {
    /// The chi² of the cell pairs.
    pub chi2: f64,
    /// Number of cell pairs compared.
    pub dof: usize,
    /// The pair of largest `|z|`.
    pub worst: WorstPair,
}

impl Anisotropy {
    /// `chi² / dof`: about 1 for an isotropic surface.
    #[must_use]
    pub fn chi2_per_dof(&self) -> f64 {
        self.chi2 / self.dof as f64
    }

    /// The largest `chi² / dof` an isotropic surface passes:
    /// `1 + 4 sqrt(2 / dof)`.
    #[must_use]
    pub fn bound(&self) -> f64 {
        1.0 + 4.0 * (2.0 / self.dof as f64).sqrt()
    }

    /// Whether the table departs from isotropy beyond its errors.
    #[must_use]
    pub fn anisotropic(&self) -> bool {
        self.chi2_per_dof() > self.bound()
    }
}

/// The shift in cells that turns band `band` by `d_deg` degrees, when it
/// maps cells exactly.
fn exact_shift(band: usize, d_deg: f64) -> Option<usize> {
    let cells = 4 * band;
    let s = d_deg * cells as f64 / 360.0;
    let r = s.round();
    ((s - r).abs() <= 1e-9).then(|| (r as i64).rem_euclid(cells as i64) as usize)
}

/// The anisotropy figure of `table` (see the module documentation);
/// `None` for a table of one light azimuth, or when no cell pair maps
/// exactly (azimuth differences that are not a multiple of `360 / (4 j)`
/// degrees for any band `j`) or has a positive error.
#[must_use]
pub fn anisotropy(table: &BrdfTable) -> Option<Anisotropy> {
    let azimuths = table.azimuths_deg();
    let n = azimuths.len();
    if n < 2 {
        return None;
    }
    let grid = table.grid();
    let thetas = table.thetas_deg();
    let (mut chi2, mut dof) = (0.0, 0usize);
    let mut worst: Option<WorstPair> = None;
    for t in 0..thetas.len() / n {
        let base = t * n;
        let (f0, s0) = (table.fractions(base), table.fraction_stderrs(base));
        for k in 1..n {
            let (fk, sk) = (table.fractions(base + k), table.fraction_stderrs(base + k));
            let d = azimuths[k] - azimuths[0];
            for band in 1..=grid.bands() {
                let Some(shift) = exact_shift(band, d) else {
                    continue;
                };
                for cell in 0..4 * band {
                    let a = grid.index(band, cell);
                    let b = grid.index(band, (cell + shift) % (4 * band));
                    let var = s0[a] * s0[a] + sk[b] * sk[b];
                    if var <= 0.0 {
                        continue;
                    }
                    let z = (fk[b] - f0[a]) / var.sqrt();
                    chi2 += z * z;
                    dof += 1;
                    if worst.is_none_or(|w| z.abs() > w.z.abs()) {
                        worst = Some(WorstPair {
                            theta_i_deg: thetas[base],
                            phi_i_deg: azimuths[k],
                            band,
                            cell,
                            z,
                        });
                    }
                }
            }
        }
    }
    worst.map(|worst| Anisotropy { chi2, dof, worst })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tally::CarlsonGrid;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A table at 30 degrees, light azimuths 0 and 90: block 0 `base`, block
    /// 90 `base` turned by 90 degrees (cell c -> c + j) plus `noise(cell)`,
    /// standard error `se` everywhere.
    fn two_azimuths(m: usize, noise: &mut dyn FnMut(usize) -> f64, se: f64) -> BrdfTable {
        let g = CarlsonGrid::new(m).unwrap();
        let mut r = Pcg64Mcg::seed_from_u64(1);
        let base: Vec<f64> = (0..g.n_cells())
            .map(|_| 0.001 * r.random::<f64>())
            .collect();
        let mut turned = vec![0.0; g.n_cells()];
        for (flat, &v) in base.iter().enumerate() {
            let (band, cell) = g.band_cell(flat);
            let to = g.index(band, (cell + band) % (4 * band));
            turned[to] = (v + noise(to)).max(0.0);
        }
        let se = vec![se; g.n_cells()];
        BrdfTable::from_blocks(
            g,
            vec![(30.0, 0.0, base, se.clone()), (30.0, 90.0, turned, se)],
            "t.csv",
        )
        .unwrap()
    }

    /// Noise of the stated error gives chi²/dof near 1, below the bound;
    /// a turned table that is not the turn of the first (a change in one
    /// direction of 10 standard errors over a sector) is flagged, and its
    /// worst pair is in that sector.
    #[test]
    fn isotropic_passes_and_anisotropic_is_flagged() {
        let se = 1e-4;
        let mut r = Pcg64Mcg::seed_from_u64(7);
        // Gaussian noise of standard deviation se*sqrt(2) (Box-Muller): the
        // pair's combined error.
        let mut gauss = move |_: usize| {
            let (u, v): (f64, f64) = (r.random(), r.random());
            se * 2f64.sqrt() * (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let iso = anisotropy(&two_azimuths(12, &mut gauss, se)).unwrap();
        assert_eq!(iso.dof, CarlsonGrid::new(12).unwrap().n_cells());
        assert!(
            !iso.anisotropic() && (iso.chi2_per_dof() - 1.0).abs() < 4.0 * (2.0 / 312.0f64).sqrt(),
            "{iso:?}"
        );
        let g = CarlsonGrid::new(12).unwrap();
        let mut sector = |flat: usize| {
            let (band, cell) = g.band_cell(flat);
            if band > 6 && cell < band {
                10.0 * se
            } else {
                0.0
            }
        };
        let aniso = anisotropy(&two_azimuths(12, &mut sector, se)).unwrap();
        assert!(aniso.anisotropic(), "{aniso:?}");
        // The worst pair: a cell at 0 deg turned into the sector.
        assert!(
            aniso.worst.band > 6 && (aniso.worst.z - 10.0 / 2f64.sqrt()).abs() < 1e-6,
            "{aniso:?}"
        );
        assert_eq!(aniso.worst.phi_i_deg, 90.0);
    }

    /// Shifts map cells exactly only at multiples of the band's cell width.
    #[test]
    fn exact_shifts() {
        assert_eq!(exact_shift(1, 90.0), Some(1));
        assert_eq!(exact_shift(3, 90.0), Some(3));
        assert_eq!(exact_shift(2, 45.0), Some(1));
        assert_eq!(exact_shift(1, 45.0), None);
        assert_eq!(exact_shift(2, -90.0), Some(6));
        assert_eq!(exact_shift(5, 7.0), None);
    }

    /// One azimuth has no figure; neither have azimuths 7 degrees apart on
    /// a grid of 5 bands (no band's cells are a divisor of 7 degrees).
    #[test]
    fn no_figure_without_exact_pairs() {
        let g = CarlsonGrid::new(5).unwrap();
        let f = vec![0.001; g.n_cells()];
        let one = BrdfTable::from_blocks(g, vec![(0.0, 0.0, f.clone(), f.clone())], "a").unwrap();
        assert!(anisotropy(&one).is_none());
        let seven = BrdfTable::from_blocks(
            g,
            vec![(0.0, 0.0, f.clone(), f.clone()), (0.0, 7.0, f.clone(), f)],
            "b",
        )
        .unwrap();
        assert!(anisotropy(&seven).is_none());
    }
}
