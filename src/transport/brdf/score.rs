//! The scores: where an escaping photon lands (its Carlson cells, in-plane
//! bin and reflection-count bin, [`Bins`]) and what a batch adds to its
//! tallies for each history ([`BrdfRun::score_batch`]).

use super::run::BrdfRun;
use super::tallies::{BOUNCE_BINS, BrdfTallies, Replicates};
use super::trace::Spare;

use glam::DVec3;

use crate::optics::polarisation::{Stokes, hemisphere_reference};
use crate::optics::spectrum::MAX_WAVELENGTHS;
use crate::tally::lanes::{LaneSums, LaneTally};
use crate::tally::polar::mirror_sign;
use crate::tally::{InPlaneTally, Locator, PolarTallies, Symmetry, symmetry};
use crate::transport::carrier::Carrier;
use crate::transport::micro::{Fate, History};

impl BrdfRun {
    /// The Carlson cells an escaping photon (direction `out`, weight `w`)
    /// is scored in, as up to two sets with the weight each cell of the set
    /// gets: its own cells, and with [`Symmetry::Mirror`] half in the cells
    /// of its mirror image in the plane of incidence at azimuth `phi`
    /// (given as `(sin phi, cos phi)`; the whole weight once when both are
    /// the same cells). An unused set has weight 0.
    #[inline]
    fn cell_weights(
        &self,
        grid: &Locator,
        out: DVec3,
        w: f64,
        sin_cos_phi: (f64, f64),
    ) -> [(crate::tally::carlson::Cells, f64); 2] {
        let (cells, share) = grid.cells_of(out);
        let (mirrored, mshare) = match self.symmetry {
            Symmetry::Mirror => grid.cells_of(symmetry::mirror_at(out, sin_cos_phi)),
            // Its own cells: the whole weight once (no comparison needed).
            Symmetry::None => return [(cells, share * w), (cells, 0.0)],
        };
        if mirrored == cells {
            [(cells, share * w), (cells, 0.0)]
        } else {
            [(cells, 0.5 * share * w), (mirrored, 0.5 * mshare * w)]
        }
    }

    /// The filters of an escaping photon (direction `out`, after `bounces`
    /// reflections): which Carlson cells (with their shares of weight 1,
    /// [`BrdfRun::cell_weights`]), which in-plane bin and which
    /// reflection-count bin it is scored in.
    #[inline]
    fn filter(
        &self,
        locator: &Locator,
        inplane: &InPlaneTally,
        out: DVec3,
        bounces: u32,
        sin_cos_phi: (f64, f64),
    ) -> Bins {
        // The direction's cells once, for every wavelength.
        let shares = self.cell_weights(locator, out, 1.0, sin_cos_phi);
        Bins {
            shares,
            inplane: inplane.locate(out),
            bounces: (bounces as usize).min(BOUNCE_BINS - 1),
        }
    }

    /// The tally of a batch from its photons' lattice replicates, histories
    /// and the intersection tests each took, in photon index order, at the
    /// light azimuth `phi` (radians: the plane of incidence of the mirror
    /// and the polarisation frames):
    /// `photons(score)` calls `score(replicate, history, tests)` for each
    /// (by reference: a spectral carrier is large).
    pub(super) fn score_batch<C: Carrier>(
        &self,
        locator: &Locator,
        inplane: &InPlaneTally,
        phi: f64,
        spare: &Spare,
        photons: impl FnOnce(&mut dyn FnMut(usize, &History<C>, u64)),
    ) -> Vec<BrdfTallies> {
        let grid = locator.grid();
        let mut lanes: Vec<BrdfTallies> = {
            let mut spare = spare.tallies.lock().expect("spare tallies");
            (0..self.lane_count())
                .map(|_| {
                    spare
                        .pop()
                        .unwrap_or_else(|| self.empty_tallies(grid, inplane))
                })
                .collect()
        };
        let sin_cos_phi = phi.sin_cos();
        let incident: Stokes = self.polarisation.incident.stokes();
        let mut components = [0.0; 16];
        // Several wavelengths: the escaping photons' weights scored bin by
        // bin for all wavelengths at once (`LaneSums`), handed to each
        // wavelength's tallies (cleared ones: the same bits) at the end.
        let n_lanes = self.lane_count();
        let mut interleaved = (n_lanes > 1).then(|| {
            let found = spare.lane_sums.lock().expect("spare sums").pop();
            found.unwrap_or_else(|| {
                LaneSums::new(n_lanes, grid.n_cells(), inplane.n_bins(), BOUNCE_BINS)
            })
        });
        // Lane by lane: everything of a monochrome run, the replicate and
        // polarisation sums of a spectral one.
        let by_lane =
            interleaved.is_none() || lanes[0].replicates.is_some() || lanes[0].polar.is_some();
        let mut weights = [0.0; MAX_WAVELENGTHS];
        let mirror = self.symmetry == Symmetry::Mirror;
        // One wavelength with the intensity sums alone (the usual run): its
        // weight straight into its tallies, what the loop below does then.
        let plain = n_lanes == 1 && lanes[0].replicates.is_none() && lanes[0].polar.is_none();
        let mut score = |replicate: usize, h: &History<C>, tests: u64| {
            score_counts(&mut lanes[0], h, tests);
            // By reference: a spectral carrier is large.
            match &h.fate {
                Fate::Escaped {
                    dir: out,
                    weight: carried,
                } => {
                    let bins = self.filter(locator, inplane, *out, h.bounces, sin_cos_phi);
                    if plain {
                        score_weight(&mut lanes[0], &bins, carried.lane(0).weight_for(&incident));
                        return;
                    }
                    let reference = lanes[0]
                        .polar
                        .is_some()
                        .then(|| hemisphere_reference(*out, phi));
                    if let Some(sums) = &mut interleaved {
                        let w = &mut weights[..n_lanes];
                        carried.weights_for(&incident, w);
                        score_all_lanes(sums, &bins, w);
                    }
                    for (l, t) in lanes.iter_mut().enumerate().filter(|_| by_lane) {
                        // By reference: no copy of a monochrome carrier.
                        carried.with_lane(l, |carried| {
                            let weight = carried.weight_for(&incident);
                            if interleaved.is_none() {
                                score_weight(t, &bins, weight);
                            }
                            if let Some(r) = &mut t.replicates {
                                let n_bins = (grid.n_cells(), inplane.n_bins());
                                score_replicate(r, replicate, &bins, weight, n_bins);
                            }
                            if let (Some(p), Some(reference)) = (&mut t.polar, reference) {
                                let k = carried.components(*out, reference, &mut components);
                                score_polarisation(p, &components[..k], &bins, mirror, replicate);
                            }
                        });
                    }
                }
                Fate::Absorbed => {}
                fate => score_loss(&mut lanes, fate, &incident),
            }
        };
        photons(&mut score);
        if let Some(mut sums) = interleaved {
            sums.drain_into(lanes.iter_mut().map(|t| {
                debug_assert!(t.carlson.sum.iter().all(|&v| v == 0.0), "cleared tallies");
                LaneTally {
                    reflected: &mut t.reflected,
                    carlson: &mut t.carlson,
                    inplane: &mut t.inplane,
                    by_bounces: &mut t.by_bounces,
                }
            }));
            spare.lane_sums.lock().expect("spare sums").push(sums);
        }
        let (first, rest) = lanes.split_first_mut().expect("one wavelength at least");
        for t in rest {
            t.intersection_tests = first.intersection_tests;
            t.photons = first.photons;
            t.bounces = first.bounces;
            t.segments = first.segments;
        }
        lanes
    }
}

/// Where an escaping photon is scored: the filters of
/// [`BrdfRun::filter`].
struct Bins {
    /// Its Carlson cells and their shares of weight 1, as
    /// [`BrdfRun::cell_weights`] gives them (the mirrored half second).
    shares: [(crate::tally::carlson::Cells, f64); 2],
    /// Its in-plane bin, if any.
    inplane: Option<usize>,
    /// Its reflection-count bin.
    bounces: usize,
}

impl Bins {
    /// The `(cell, share)` pairs scored: the cells of `shares` with a
    /// non-zero share, in order (made as they are used, not stored: a
    /// history's bins are built once and read once or twice).
    #[inline]
    fn for_each_hit(&self, mut f: impl FnMut(usize, f64)) {
        for (cells, share) in &self.shares {
            if *share != 0.0 {
                for &c in cells.as_slice() {
                    f(c, *share);
                }
            }
        }
    }
}

/// Score the counts of a history (the same at every wavelength: kept in the
/// first wavelength's tallies, copied to the others at the end of a batch):
/// photons, reflections, straight flights and intersection tests.
#[inline]
fn score_counts<C: Carrier>(t: &mut BrdfTallies, h: &History<C>, tests: u64) {
    t.intersection_tests += tests;
    t.photons += 1;
    t.bounces += u64::from(h.bounces);
    t.segments += u64::from(h.segments);
}

/// Score the weights `w` (one per wavelength) of an escaping photon in the
/// interleaved sums of all wavelengths at once, bin by bin.
#[inline]
fn score_all_lanes(sums: &mut LaneSums, bins: &Bins, w: &[f64]) {
    sums.reflected.score(0, w);
    bins.for_each_hit(|c, share| sums.carlson.score_scaled(c, share, w));
    if let Some(c) = bins.inplane {
        sums.inplane.score(c, w);
    }
    sums.by_bounces.add(bins.bounces, w);
}

/// Score the weight of an escaping photon in one wavelength's tallies: the
/// reflectance, its cells, its in-plane bin and its reflection count.
#[inline]
fn score_weight(t: &mut BrdfTallies, bins: &Bins, weight: f64) {
    t.reflected.score(0, weight);
    // The cells' shares for weight 1 (the polarisation tally's), then times
    // the weight: the same products as `cell_weights(.., weight, ..)`, bit
    // for bit (a zero product adds nothing to the non-negative sums).
    if weight != 0.0 {
        bins.for_each_hit(|c, share| t.carlson.score(c, share * weight));
    }
    if let Some(c) = bins.inplane {
        t.inplane.score(c, weight);
    }
    t.by_bounces[bins.bounces] += weight;
}

/// Score the weight of an escaping photon in the sums of its lattice
/// replicate `replicate` (`n_bins`: Carlson cells and in-plane bins).
#[inline]
fn score_replicate(
    r: &mut Replicates,
    replicate: usize,
    bins: &Bins,
    weight: f64,
    (n_cells, n_inplane): (usize, usize),
) {
    let halves = bins.shares.map(|(cells, share)| (cells, share * weight));
    r.reflected[replicate] += weight;
    for (cs, w) in &halves {
        for &c in cs.as_slice() {
            r.carlson[replicate * n_cells + c] += w;
        }
    }
    if let Some(c) = bins.inplane {
        r.inplane[replicate * n_inplane + c] += weight;
    }
}

/// Score the polarisation components `c` (4 Stokes or 16 Mueller, in the
/// photon's outgoing frame) of an escaping photon ([`score_polar`]).
#[inline]
fn score_polarisation(
    p: &mut PolarTallies,
    c: &[f64],
    bins: &Bins,
    mirror: bool,
    replicate: usize,
) {
    match *c {
        [c0, c1, c2, c3] => score_polar(p, &[c0, c1, c2, c3], &bins.shares, mirror, replicate),
        _ => {
            let c: &[f64; 16] = c.try_into().expect("4 or 16 polarisation components");
            score_polar(p, c, &bins.shares, mirror, replicate);
        }
    }
}

/// Score the weight a history lost (absorbed by a wall, cut by a cap or by
/// a numerical guard) in every wavelength's tallies.
#[inline]
fn score_loss<C: Carrier>(lanes: &mut [BrdfTallies], fate: &Fate<C>, incident: &Stokes) {
    for (l, t) in lanes.iter_mut().enumerate() {
        match fate {
            Fate::Wall { weight } => t.lost_walls += weight.lane(l).weight_for(incident),
            Fate::Capped { weight } => {
                t.lost_cap += weight.lane(l).weight_for(incident);
                t.capped_histories += 1;
            }
            Fate::Numeric { weight } => {
                t.lost_numeric += weight.lane(l).weight_for(incident);
                t.numeric_histories += 1;
            }
            Fate::Escaped { .. } | Fate::Absorbed => {}
        }
    }
}

/// Score an escaping photon's polarisation components `c` (in its outgoing
/// frame): the hemisphere slot, and the cells of `halves` with their shares
/// (see [`BrdfRun::cell_weights`] of weight 1; the mirrored half with the
/// mirror signs of [`mirror_sign`]), and the replicate sums of a lattice run.
///
/// With `mirror` (mirror symmetry) the photon counts half as itself and half
/// as its mirror image, whose components have the signs of [`mirror_sign`].
/// Where both halves land in the same bins (the hemisphere slot; cells
/// straddling the plane of incidence, which [`BrdfRun::cell_weights`] gives
/// as one set with the whole weight) a component scores
/// `(1 + sign) / 2` times itself: itself for `S0`, `S1`, zero for `S2`, `S3`
/// (the two halves cancel), so the intensity components stay bit for bit
/// those of the intensity tallies.
fn score_polar<const K: usize>(
    p: &mut PolarTallies,
    c: &[f64; K],
    halves: &[(crate::tally::carlson::Cells, f64); 2],
    mirror: bool,
    replicate: usize,
) {
    if !mirror {
        // Without the symmetry (the usual run) every factor below is 1 and
        // the second half has weight 0: the hemisphere slot gets the
        // components themselves and the photon's cells `w * c`, the same
        // products as the general path (`1 * w * c` is `w * c`, bit for bit).
        debug_assert_eq!(halves[1].1, 0.0, "one set of cells without the symmetry");
        p.score_slot(0, replicate, c);
        let (cells, w) = &halves[0];
        if *w != 0.0 {
            let values: [f64; K] = std::array::from_fn(|i| w * c[i]);
            for &cell in cells.as_slice() {
                p.score_slot(1 + cell, replicate, &values);
            }
        }
        return;
    }
    // Factor of a component whose two halves share a bin.
    let both: [f64; K] = std::array::from_fn(|i| {
        if mirror && mirror_sign(K, i) < 0.0 {
            0.0
        } else {
            1.0
        }
    });
    if mirror {
        let hemisphere: [f64; K] = std::array::from_fn(|i| both[i] * c[i]);
        p.score_slot(0, replicate, &hemisphere);
    } else {
        // Every factor is 1: the components themselves, the same bits.
        p.score_slot(0, replicate, c);
    }
    // The first half is the photon's own cells, the second its mirror image
    // (weight 0: in the same cells as the first, which then has the whole weight).
    let same = halves[1].1 == 0.0;
    for (half, (cells, w)) in halves.iter().enumerate() {
        if *w == 0.0 {
            continue;
        }
        let values: [f64; K] = match (half, same) {
            (1, _) => std::array::from_fn(|i| mirror_sign(K, i) * w * c[i]),
            (_, true) => std::array::from_fn(|i| both[i] * w * c[i]),
            // `1 * w * c` is `w * c`, bit for bit.
            _ => std::array::from_fn(|i| w * c[i]),
        };
        for &cell in cells.as_slice() {
            p.score_slot(1 + cell, replicate, &values);
        }
    }
}
