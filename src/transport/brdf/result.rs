//! The result tree of a run: [`BrdfResult`], nested incidence x light
//! azimuth x wavelength down to the leaves ([`IncidenceResult`]), their
//! standard errors, and the spread of an ensemble of surface realisations
//! ([`Ensemble`]).

use super::run::BrdfRun;
use super::tallies::{BrdfTallies, Replicates, add_up};
#[cfg(doc)]
use crate::tally::PolarTallies;

use crate::tally::anisotropy::{Anisotropy, Group, Table};
use crate::tally::sum::Node;
use crate::tally::{Accumulator, CarlsonGrid};

/// The result of tracing a run's photons ([`BrdfRun::trace`]), nested as
/// incidence x light azimuth x wavelength: `incidence[i].azimuth[a]
/// .wavelength[l]` is the leaf of `run.theta_deg[i]`, the light azimuth
/// `run.phi_deg[a]` and
/// `run.wavelengths_um[l]` (the one lane of a monochrome run).
#[derive(Debug, Clone)]
pub struct BrdfResult {
    /// One entry per incidence angle, in the run's order.
    pub incidence: Vec<ByIncidence>,
}

/// The results at one incidence angle.
#[derive(Debug, Clone)]
pub struct ByIncidence {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// One entry per light azimuth.
    pub azimuth: Vec<ByAzimuth>,
}

/// The results at one incidence angle and light azimuth.
#[derive(Debug, Clone)]
pub struct ByAzimuth {
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
    /// One leaf per wavelength (one for a monochrome run).
    pub wavelength: Vec<IncidenceResult>,
}

impl BrdfResult {
    /// The leaf of incidence `i`, light azimuth `a` and wavelength `l`.
    ///
    /// # Panics
    /// If an index is out of its axis.
    #[must_use]
    pub fn leaf(&self, i: usize, a: usize, l: usize) -> &IncidenceResult {
        &self.incidence[i].azimuth[a].wavelength[l]
    }

    /// Every leaf in file order: incidence, then azimuth, then wavelength.
    pub fn iter(&self) -> impl Iterator<Item = &IncidenceResult> {
        self.groups().flatten()
    }

    /// The leaves of every incidence and azimuth, one slice of wavelengths
    /// each, in file order.
    pub fn groups(&self) -> impl Iterator<Item = &[IncidenceResult]> {
        self.incidence
            .iter()
            .flat_map(|i| i.azimuth.iter().map(|a| a.wavelength.as_slice()))
    }

    /// The leaves of wavelength `l` (of the one lane of a monochrome run),
    /// per incidence and azimuth in file order.
    pub fn lane(&self, l: usize) -> impl Iterator<Item = &IncidenceResult> {
        self.groups().map(move |g| &g[l])
    }

    /// The number of leaves.
    #[must_use]
    pub fn len(&self) -> usize {
        self.groups().map(<[IncidenceResult]>::len).sum()
    }

    /// True without leaves.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How far the tables depart from isotropy
    /// ([`crate::tally::anisotropy`]): every pair of light azimuths at each
    /// incidence and wavelength, tables on `grid` (the run's); `None` for
    /// one azimuth.
    #[must_use]
    pub fn anisotropy(&self, grid: &CarlsonGrid) -> Option<Anisotropy> {
        // Per leaf: its fractions and standard errors per cell.
        type Columns = (Vec<f64>, Vec<f64>);
        // An incidence, its wavelength and each azimuth's columns.
        type Held = (f64, Option<f64>, Vec<(f64, Columns)>);
        let columns = |r: &IncidenceResult| -> Columns {
            let n = r.tallies.photons;
            (0..grid.n_cells())
                .map(|c| (r.tallies.carlson.mean(c, n), r.carlson_stderr(c)))
                .unzip()
        };
        // Per incidence and wavelength: each azimuth's columns.
        let columns = &columns;
        let held: Vec<Held> = self
            .incidence
            .iter()
            .flat_map(|inc| {
                let lanes = inc.azimuth.first().map_or(0, |a| a.wavelength.len());
                (0..lanes).map(move |l| {
                    let tables = inc.azimuth.iter();
                    (
                        inc.theta_i_deg,
                        inc.azimuth[0].wavelength[l].wavelength_um,
                        tables
                            .map(|a| (a.phi_i_deg, columns(&a.wavelength[l])))
                            .collect(),
                    )
                })
            })
            .collect();
        let groups: Vec<Group> = held
            .iter()
            .map(|(theta_i_deg, wavelength_um, tables)| Group {
                theta_i_deg: *theta_i_deg,
                wavelength_um: *wavelength_um,
                tables: tables
                    .iter()
                    .map(|(phi_deg, (f, s))| Table {
                        phi_deg: *phi_deg,
                        fraction: f,
                        stderr: s,
                    })
                    .collect(),
            })
            .collect();
        Anisotropy::of(grid, &groups)
    }

    /// The leaves in file order, owned.
    #[must_use]
    pub fn into_leaves(self) -> Vec<IncidenceResult> {
        self.incidence
            .into_iter()
            .flat_map(|i| i.azimuth.into_iter().flat_map(|a| a.wavelength))
            .collect()
    }
}

impl<'a> IntoIterator for &'a BrdfResult {
    type Item = &'a IncidenceResult;
    type IntoIter = Box<dyn Iterator<Item = &'a IncidenceResult> + 'a>;
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

/// The leaf of a [`BrdfResult`]: one incidence direction, light azimuth and
/// wavelength.
#[derive(Debug, Clone)]
pub struct IncidenceResult {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
    /// Vacuum wavelength (µm) of a spectral run; `None` for a monochrome run.
    pub wavelength_um: Option<f64>,
    /// Sums: the nodes added left to right (for a whole run of one
    /// realisation, the tree's root).
    pub tallies: BrdfTallies,
    /// The complete nodes of the whole run's batch tree that the traced
    /// photons fill, in batch order ([`crate::tally::sum`]), except the
    /// root: a whole run of one realisation keeps its root once, as
    /// `tallies`, and no nodes (so does an empty range, with no photons).
    /// [`IncidenceResult::tree_nodes`] gives the nodes `tallies.json`
    /// writes.
    pub nodes: Vec<Node<BrdfTallies>>,
    /// Wall-clock time (s) of the incidence's trace (all its wavelengths).
    pub seconds: f64,
    /// With several surface realisations, each one's reflectance (from the
    /// tree nodes over its block of batches); empty for one.
    pub realisations: Vec<RealisationResult>,
    /// With several surface realisations (at least two with photons): the
    /// spread between them, from which every standard error of this leaf
    /// comes ([`Ensemble`]); `None` otherwise (photon noise, or lattice
    /// replicates).
    pub ensemble: Option<Ensemble>,
}

/// The spread between the surface realisations of an ensemble at one leaf
/// (incidence, azimuth, wavelength): the errors of the ensemble mean.
///
/// The ensemble's estimate of a bin is its pooled mean `m = S / N` (`S`
/// the sum over all `N` photons), the mean of the realisations' estimates
/// `m_r = S_r / n_r` weighted by their photons `w_r = n_r / N`. Its
/// standard error over the population of surfaces is that of a cluster
/// sample of `R` realisations,
/// `se² = R / (R - 1) · Σ_r w_r² (m_r - m)² = R / (R - 1) · Σ_r (S_r - n_r m)² / N²`,
/// with `R - 1` degrees of freedom: for realisations of equal photons, the
/// sample standard deviation of the `R` estimates over `sqrt(R)`. It
/// counts the photon noise too (each `m_r` has its own). Kept per bin as
/// the sums of squares `Σ_r (S_r - n_r m)²`, one realisation at a time (not
/// `R` copies of the table); made from the leaf's tree nodes
/// ([`BrdfRun::realisation_results`]), so bit for bit the same for any
/// thread count and shard split.
#[derive(Debug, Clone, PartialEq)]
pub struct Ensemble {
    /// `R`: the realisations with photons (at least 2).
    pub count: u64,
    /// `N`: the photons of all of them.
    pub photons: u64,
    /// `Σ_r (S_r - n_r m)²` of the reflected weight (one bin).
    pub reflected: Vec<f64>,
    /// The same per Carlson cell.
    pub carlson: Vec<f64>,
    /// The same per in-plane bin.
    pub inplane: Vec<f64>,
    /// The same per polarisation bin (with a polarisation tally).
    pub polar: Option<Vec<f64>>,
    /// Per polarisation bin `slot K + k`: `Σ_r (X_r - ρ Y_r)²` with `X_r`,
    /// `Y_r` realisation `r`'s sums of component `k` and component 0 of the
    /// slot and `ρ = X / Y` the ensemble's ratio (the linearised residuals
    /// of [`IncidenceResult::polar_ratio`]); 0 where `Y = 0`.
    pub ratio: Option<Vec<f64>>,
}

impl Ensemble {
    /// The spread of the realisations `parts` (each one's sums) about the
    /// ensemble `total` (their sum); `None` with fewer than 2 realisations
    /// with photons.
    #[must_use]
    pub fn of(total: &BrdfTallies, parts: impl Iterator<Item = BrdfTallies>) -> Option<Self> {
        let big_n = total.photons as f64;
        // Σ (S_r - n_r S / N)² per bin, added into `d`.
        let add = |d: &mut [f64], s_r: &[f64], s: &[f64], w: f64| {
            for ((d, &x), &all) in d.iter_mut().zip(s_r).zip(s) {
                *d += (x - w * all).powi(2);
            }
        };
        let mut e = Self {
            count: 0,
            photons: total.photons,
            reflected: vec![0.0; total.reflected.len()],
            carlson: vec![0.0; total.carlson.len()],
            inplane: vec![0.0; total.inplane.len()],
            polar: total.polar.as_ref().map(|p| vec![0.0; p.bins()]),
            ratio: total.polar.as_ref().map(|p| vec![0.0; p.bins()]),
        };
        for part in parts {
            if part.photons == 0 {
                continue;
            }
            e.count += 1;
            let w = part.photons as f64 / big_n;
            add(
                &mut e.reflected,
                &part.reflected.sum,
                &total.reflected.sum,
                w,
            );
            add(&mut e.carlson, &part.carlson.sum, &total.carlson.sum, w);
            add(&mut e.inplane, &part.inplane.sum, &total.inplane.sum, w);
            if let (Some(d), Some(p), Some(all)) = (&mut e.polar, &part.polar, &total.polar) {
                add(d, &p.sums.sum, &all.sums.sum, w);
            }
            if let (Some(d), Some(p), Some(all)) = (&mut e.ratio, &part.polar, &total.polar) {
                let k = all.components;
                for (slot, d) in d.chunks_mut(k).enumerate() {
                    let at = slot * k;
                    let y = all.sums.sum[at];
                    if y == 0.0 {
                        continue;
                    }
                    for (j, d) in d.iter_mut().enumerate() {
                        let rho = all.sums.sum[at + j] / y;
                        *d += (p.sums.sum[at + j] - rho * p.sums.sum[at]).powi(2);
                    }
                }
            }
        }
        (e.count >= 2).then_some(e)
    }

    /// Degrees of freedom of the errors: `R - 1`.
    #[must_use]
    pub fn dof(&self) -> u64 {
        self.count - 1
    }

    /// The standard error of a mean per photon whose sum of squares
    /// (`Σ_r (S_r - n_r m)²`) is `d`: `sqrt(R / (R - 1) · d) / N`.
    #[must_use]
    pub fn stderr(&self, d: f64) -> f64 {
        let r = self.count as f64;
        (r / (r - 1.0) * d).sqrt() / self.photons as f64
    }

    /// The standard error of the ratio `X / Y` of polarisation bin `bin`
    /// (component `k` of a slot) to component 0 of its slot, `y` being
    /// `Y`, the ensemble's sum of component 0: the delta method over the
    /// realisations, `sqrt(R / (R - 1) · Σ_r (X_r - ρ Y_r)²) / Y` (that of
    /// [`PolarTallies::ratio`] over lattice replicates, with realisations
    /// for replicates).
    fn ratio_stderr(&self, bin: usize, y: f64) -> Option<f64> {
        let d = self.ratio.as_ref()?[bin];
        let r = self.count as f64;
        Some((r / (r - 1.0) * d).sqrt() / y.abs())
    }
}

/// The reflectance of one surface realisation of a run (its block of
/// batches, [`BrdfRun::realisation_batches`]) at one incidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RealisationResult {
    /// Photons of the realisation traced.
    pub photons: u64,
    /// Reflected weight per photon (0 without photons).
    pub reflectance: f64,
    /// Its standard error (Monte Carlo only: the realisation's own photons).
    pub reflectance_stderr: f64,
}

impl RealisationResult {
    /// The reflectance of the realisation summed in `tallies`.
    fn of(tallies: BrdfTallies, theta_deg: f64, phi_deg: f64) -> Self {
        let r = IncidenceResult {
            theta_i_deg: theta_deg,
            phi_i_deg: phi_deg,
            wavelength_um: None,
            tallies,
            nodes: Vec::new(),
            seconds: 0.0,
            realisations: Vec::new(),
            ensemble: None,
        };
        let (reflectance, reflectance_stderr) = if r.tallies.photons == 0 {
            (0.0, 0.0)
        } else {
            r.reflectance()
        };
        Self {
            photons: r.tallies.photons,
            reflectance,
            reflectance_stderr,
        }
    }
}

impl IncidenceResult {
    /// The complete tree nodes of this leaf of `run`, in batch order, as a
    /// shard's or a merge's `tallies.json` lists them: `nodes`, or the root
    /// `(level, 0)` holding `tallies` when the leaf is the whole run's root
    /// (no nodes, some photons).
    #[must_use]
    pub fn tree_nodes(&self, run: &BrdfRun) -> std::borrow::Cow<'_, [Node<BrdfTallies>]> {
        if self.nodes.is_empty() && self.tallies.photons > 0 {
            std::borrow::Cow::Owned(vec![Node {
                level: run.root_level(),
                index: 0,
                value: self.tallies.clone(),
            }])
        } else {
            std::borrow::Cow::Borrowed(&self.nodes)
        }
    }

    /// Directional-hemispherical reflectance and its standard error (with
    /// several surface realisations, that of the ensemble mean: see
    /// [`Ensemble`]).
    #[must_use]
    pub fn reflectance(&self) -> (f64, f64) {
        let n = self.tallies.photons;
        (
            self.tallies.reflected.mean(0, n),
            self.stderr(|t| &t.reflected, |r| &r.reflected, |e| &e.reflected, 0),
        )
    }

    /// The standard error of the reflectance from the photons alone
    /// (lattice replicates for a lattice launch), without the spread
    /// between surface realisations.
    #[must_use]
    pub fn reflectance_stderr_photon(&self) -> f64 {
        self.photon_stderr(|t| &t.reflected, |r| &r.reflected, 0)
    }

    /// Standard error of the weight fraction in Carlson cell `cell` (with
    /// several surface realisations, of the ensemble mean).
    #[must_use]
    pub fn carlson_stderr(&self, cell: usize) -> f64 {
        self.stderr(|t| &t.carlson, |r| &r.carlson, |e| &e.carlson, cell)
    }

    /// [`IncidenceResult::carlson_stderr`] from the photons alone.
    #[must_use]
    pub fn carlson_stderr_photon(&self, cell: usize) -> f64 {
        self.photon_stderr(|t| &t.carlson, |r| &r.carlson, cell)
    }

    /// Standard error of the weight fraction in in-plane bin `bin` (with
    /// several surface realisations, of the ensemble mean).
    #[must_use]
    pub fn inplane_stderr(&self, bin: usize) -> f64 {
        self.stderr(|t| &t.inplane, |r| &r.inplane, |e| &e.inplane, bin)
    }

    /// [`IncidenceResult::inplane_stderr`] from the photons alone.
    #[must_use]
    pub fn inplane_stderr_photon(&self, bin: usize) -> f64 {
        self.photon_stderr(|t| &t.inplane, |r| &r.inplane, bin)
    }

    /// The degrees of freedom of this leaf's standard errors when they come
    /// from the spread between surface realisations (`R - 1`); `None` for
    /// photon noise.
    #[must_use]
    pub fn stderr_dof(&self) -> Option<u64> {
        self.ensemble.as_ref().map(Ensemble::dof)
    }

    /// Mean per launched photon of polarisation bin `bin` (see
    /// [`crate::tally::polar`]), and its standard error (with several
    /// surface realisations, of the ensemble mean); `None` without a
    /// polarisation tally.
    #[must_use]
    pub fn polar(&self, bin: usize) -> Option<(f64, f64)> {
        let t = &self.tallies;
        let p = t.polar.as_ref()?;
        let mean = p.sums.mean(bin, t.photons);
        let se = match self
            .ensemble
            .as_ref()
            .and_then(|e| Some((e, e.polar.as_ref()?)))
        {
            Some((e, d)) => e.stderr(d[bin]),
            None => match (&t.replicates, &p.replicates) {
                (Some(r), Some(sums)) => r.stderr(sums, bin, t.photons),
                _ => p.sums.stderr(bin, t.photons),
            },
        };
        Some((mean, se))
    }

    /// The normalised component `k / 0` of polarisation slot `slot` and
    /// its standard error ([`PolarTallies::ratio`]; with several surface
    /// realisations, of the ensemble's ratio, [`Ensemble`]); `None` without
    /// a polarisation tally or where component 0 is 0.
    #[must_use]
    pub fn polar_ratio(&self, slot: usize, k: usize) -> Option<(f64, f64)> {
        let t = &self.tallies;
        let p = t.polar.as_ref()?;
        let (ratio, se) = p.ratio(slot, k, t.photons)?;
        let y = p.sums.sum[slot * p.components];
        let bin = slot * p.components + k;
        let se = self
            .ensemble
            .as_ref()
            .and_then(|e| e.ratio_stderr(bin, y))
            .unwrap_or(se);
        Some((ratio, se))
    }

    /// From the realisations' spread if there is one ([`Ensemble`]), else
    /// [`IncidenceResult::photon_stderr`].
    fn stderr(
        &self,
        per_photon: impl Fn(&BrdfTallies) -> &Accumulator,
        per_replicate: impl Fn(&Replicates) -> &[f64],
        per_realisation: impl Fn(&Ensemble) -> &[f64],
        bin: usize,
    ) -> f64 {
        match &self.ensemble {
            Some(e) => e.stderr(per_realisation(e)[bin]),
            None => self.photon_stderr(per_photon, per_replicate, bin),
        }
    }

    /// Per photon, or from the replicate spread for a lattice run.
    fn photon_stderr(
        &self,
        per_photon: impl Fn(&BrdfTallies) -> &Accumulator,
        per_replicate: impl Fn(&Replicates) -> &[f64],
        bin: usize,
    ) -> f64 {
        let t = &self.tallies;
        match &t.replicates {
            Some(r) => r.stderr(per_replicate(r), bin, t.photons),
            None => per_photon(t).stderr(bin, t.photons),
        }
    }

    /// Lost weight per launched photon (walls + caps + numerical guards).
    #[must_use]
    pub fn lost(&self) -> f64 {
        let t = &self.tallies;
        (t.lost_walls + t.lost_cap + t.lost_numeric) / t.photons as f64
    }

    /// Mean reflections per launched photon.
    #[must_use]
    pub fn mean_bounces(&self) -> f64 {
        self.tallies.bounces as f64 / self.tallies.photons as f64
    }

    /// Intersection tests per straight flight.
    #[must_use]
    pub fn tests_per_segment(&self) -> f64 {
        self.tallies.intersection_tests as f64 / self.tallies.segments.max(1) as f64
    }

    /// Straight flights per second of wall time.
    #[must_use]
    pub fn segments_per_second(&self) -> f64 {
        self.tallies.segments as f64 / self.seconds.max(1e-9)
    }
}

impl BrdfRun {
    /// With several realisations, each one's reflectance at incidence
    /// `theta_deg` (and light azimuth `phi_deg`) from the tree `nodes` of a trace or of merged shards, in
    /// batch order, each within one realisation's block: realisation `r`'s
    /// sums are its nodes pushed into the run's tree and added left to
    /// right (so a shard split anywhere gives the same bits); and their
    /// spread about `total` (the leaf's sums, those of all the nodes), the
    /// [`Ensemble`] the leaf's standard errors come from (`None` with fewer
    /// than two realisations with photons). Empty and `None` for one
    /// realisation.
    #[must_use]
    pub fn realisation_results(
        &self,
        theta_deg: f64,
        phi_deg: f64,
        nodes: &[Node<BrdfTallies>],
        total: &BrdfTallies,
    ) -> (Vec<RealisationResult>, Option<Ensemble>) {
        if self.realisations <= 1 {
            return (Vec::new(), None);
        }
        let mut results = Vec::with_capacity(self.realisations as usize);
        let parts = (0..self.realisations).map(|r| {
            let (b0, b1) = self.realisation_batches(r);
            let inside = nodes
                .iter()
                .filter(|n| n.start() >= u128::from(b0) && n.start() < u128::from(b1));
            let sums = add_up(&self.combine(inside))
                .unwrap_or_else(|| self.empty_tallies(&self.grid(), &self.inplane()));
            results.push(RealisationResult::of(sums.clone(), theta_deg, phi_deg));
            sums
        });
        let ensemble = Ensemble::of(total, parts);
        (results, ensemble)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tally::{InPlaneTally, Merge, PolarTally};

    /// Tallies of `photons` photons whose Carlson cells (one band: 4
    /// cells), reflected weight and Mueller cell sums hold `sums` (component
    /// `k` of a cell's Mueller sums: `sums[cell] * (k + 1) + k`).
    fn synthetic(photons: u64, sums: [f64; 4]) -> BrdfTallies {
        let grid = CarlsonGrid::new(1).unwrap();
        let inplane = InPlaneTally::new(10.0, 1.0, 0.0).unwrap();
        let mut t = BrdfTallies::new(&grid, &inplane, None, PolarTally::Mueller);
        t.photons = photons;
        t.carlson.sum.copy_from_slice(&sums);
        t.reflected.sum[0] = sums.iter().sum();
        let p = t.polar.as_mut().unwrap();
        for (c, s) in sums.iter().enumerate() {
            for k in 0..16 {
                let bin = p.cell_bin(c, k);
                p.sums.sum[bin] = s * (k + 1) as f64 + k as f64;
            }
        }
        t
    }

    /// The leaf of an ensemble of realisations `parts`.
    fn ensemble_leaf(parts: &[BrdfTallies]) -> IncidenceResult {
        let mut total = parts[0].clone();
        for p in &parts[1..] {
            total.merge(p);
        }
        let ensemble = Ensemble::of(&total, parts.iter().cloned());
        IncidenceResult {
            theta_i_deg: 0.0,
            phi_i_deg: 0.0,
            wavelength_um: None,
            tallies: total,
            nodes: Vec::new(),
            seconds: 0.0,
            realisations: Vec::new(),
            ensemble,
        }
    }

    /// Four realisations of 10 photons each: the ensemble's standard error
    /// of a cell is the sample standard deviation of the four realisations'
    /// estimates over sqrt(4), with 3 degrees of freedom (the formula
    /// written out); the photon-noise error stays that of the sums.
    #[test]
    fn ensemble_stderr_is_the_sample_formula() {
        let cells = [
            [1.0, 0.0, 2.0, 7.0],
            [2.0, 0.0, 2.0, 5.0],
            [3.0, 1.0, 2.0, 6.0],
            [6.0, 0.0, 2.0, 9.0],
        ];
        let parts: Vec<BrdfTallies> = cells.iter().map(|c| synthetic(10, *c)).collect();
        let leaf = ensemble_leaf(&parts);
        assert_eq!(leaf.stderr_dof(), Some(3));
        let sample = |m: [f64; 4]| {
            let mean = m.iter().sum::<f64>() / 4.0;
            let var = m.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 3.0;
            (var / 4.0).sqrt()
        };
        for c in 0..4 {
            let m = cells.map(|r| r[c] / 10.0);
            let want = sample(m);
            let got = leaf.carlson_stderr(c);
            assert!((got - want).abs() <= 1e-15, "cell {c}: {got} vs {want}");
        }
        // Cell 0: estimates 0.1, 0.2, 0.3, 0.6, spread sqrt(14/12) / 10.
        assert!((leaf.carlson_stderr(0) - (14.0_f64 / 12.0).sqrt() / 10.0).abs() < 1e-15);
        // The same in every realisation: no spread.
        assert_eq!(leaf.carlson_stderr(2), 0.0);
        let r = cells.map(|r| r.iter().sum::<f64>() / 10.0);
        assert!((leaf.reflectance().1 - sample(r)).abs() <= 1e-15);
        // The photon noise: the accumulator's own formula over all photons.
        let t = &leaf.tallies;
        assert_eq!(
            leaf.carlson_stderr_photon(1),
            t.carlson.stderr(1, t.photons)
        );
        assert_eq!(
            leaf.reflectance_stderr_photon(),
            t.reflected.stderr(0, t.photons)
        );
        // A Mueller element: the same sample formula.
        let p = t.polar.as_ref().unwrap();
        let bin = p.cell_bin(3, 5);
        let m = cells.map(|r| (r[3] * 6.0 + 5.0) / 10.0);
        assert!((leaf.polar(bin).unwrap().1 - sample(m)).abs() <= 1e-15);
        // m_05 / m_00 of cell 3: the delta method over the realisations,
        // sqrt(R / (R - 1) sum (X_r - rho Y_r)²) / Y.
        let (x, y) = (cells.map(|r| r[3] * 6.0 + 5.0), cells.map(|r| r[3]));
        let rho = x.iter().sum::<f64>() / y.iter().sum::<f64>();
        let ss: f64 = (0..4).map(|q| (x[q] - rho * y[q]).powi(2)).sum();
        let want = (4.0 / 3.0 * ss).sqrt() / y.iter().sum::<f64>();
        let (ratio, se) = leaf.polar_ratio(4, 5).unwrap();
        assert!((ratio - rho).abs() < 1e-15);
        assert!((se - want).abs() <= 1e-15 * want, "{se} vs {want}");
    }

    /// Realisations of unequal photons (10, 20, 30): the error of the
    /// photon-weighted ensemble mean, `sqrt(R / (R - 1) sum w_r² (m_r -
    /// m)²)` with `w_r = n_r / N`; a realisation without photons does not
    /// count, and fewer than two with photons give no ensemble (the photon
    /// noise then).
    #[test]
    fn ensemble_of_unequal_realisations() {
        let (n, s) = ([10_u64, 20, 30], [3.0, 4.0, 12.0]);
        let mut parts: Vec<BrdfTallies> = (0..3)
            .map(|i| synthetic(n[i], [s[i], 0.0, 0.0, 0.0]))
            .collect();
        parts.push(synthetic(0, [0.0; 4]));
        let leaf = ensemble_leaf(&parts);
        assert_eq!(leaf.stderr_dof(), Some(2));
        let big_n = 60.0;
        let m = s.iter().sum::<f64>() / big_n;
        let ss: f64 = (0..3)
            .map(|i| (n[i] as f64 / big_n * (s[i] / n[i] as f64 - m)).powi(2))
            .sum();
        let want = (1.5 * ss).sqrt();
        assert!((leaf.carlson_stderr(0) - want).abs() <= 1e-15, "{want}");
        let one = ensemble_leaf(&[synthetic(10, [1.0; 4]), synthetic(0, [0.0; 4])]);
        assert!(one.ensemble.is_none());
        assert_eq!(one.stderr_dof(), None);
        assert_eq!(one.carlson_stderr(0), one.carlson_stderr_photon(0));
    }
}
