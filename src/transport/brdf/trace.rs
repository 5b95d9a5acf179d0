//! The trace loop of the micro level. Its one entry point,
//! [`BrdfRun::trace_realisations`], traces every incidence, light azimuth
//! and realisation in batches, in parallel, and reduces the batch tallies
//! over the fixed batch tree; [`BrdfRun::trace`] and
//! [`BrdfRun::trace_whole`] are shorthands of it for one surface.

use super::result::{BrdfResult, ByAzimuth, ByIncidence, IncidenceResult};
use super::run::{BrdfRun, toward_light};
use super::tallies::{BrdfTallies, add_up};
use crate::tally::sum::BATCH;
use std::time::Instant;

use glam::DVec3;
use rand::RngExt;

use crate::micro::{MicroSurface, Scratch};
use crate::optics::polarisation::{Stokes, hemisphere_reference};
use crate::optics::spectrum::MAX_WAVELENGTHS;
use crate::tally::lanes::LaneSums;
use crate::tally::sum::{DyadicSum, Node};
use crate::tally::{InPlaneTally, Locator, Merge, PolarTally};
use crate::transport::carrier::{Carrier, LaneCarrier, Polarised};
use crate::transport::launch::{Lattices, Launch};
use crate::transport::micro::History as MicroHistory;
use crate::transport::micro::trace;
use crate::transport::order;
use crate::transport::rng::Streams;
use crate::transport::wavefront::{Kernel, WAVE, trace_wave};

/// Bytes of histories the wavefront kernel holds at a time for scoring in
/// photon order ([`BrdfRun::trace_ordered`]).
const WAVE_HELD_BYTES: usize = 256 << 10;

impl BrdfRun {
    /// Trace the photons `photons` (a range of photon indices that starts
    /// on a batch) of every incidence angle, the batches of realisation `r`
    /// ([`BrdfRun::realisation_batches`]) on `surfaces[r]`; `progress` is
    /// called with photons done. This is the micro level's one transport
    /// entry point ([`BrdfRun::trace`] and [`BrdfRun::trace_whole`] are
    /// shorthands of it for one surface, the object level's is
    /// [`crate::transport::object::ObjectRun::trace`]): each leaf of the result has the complete nodes of the
    /// whole run's batch tree over each realisation's part of the range, in
    /// batch order (the root alone for a whole run of one realisation), the
    /// sums of those nodes pushed into the tree ([`BrdfRun::combine`]) and
    /// added left to right, and per realisation its sums
    /// ([`BrdfRun::realisation_results`]).
    ///
    /// # Panics
    /// If the range does not start on a batch or exceeds the run's
    /// photons, or `surfaces` is not one per realisation.
    pub fn trace_realisations(
        &self,
        surfaces: &[&MicroSurface],
        photons: std::ops::Range<u64>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> BrdfResult {
        assert!(photons.start % BATCH == 0, "shards start on a batch");
        assert!(photons.start <= photons.end && photons.end <= self.photons);
        assert_eq!(
            surfaces.len() as u64,
            self.realisations,
            "one surface per realisation"
        );
        let incidence = self
            .theta_deg
            .iter()
            .map(|&theta| ByIncidence {
                theta_i_deg: theta,
                azimuth: (0..self.phi_deg.len())
                    .map(|a| self.trace_azimuth(surfaces, theta, a, &photons, progress))
                    .collect(),
            })
            .collect();
        BrdfResult { incidence }
    }

    /// A shorthand of the entry point [`BrdfRun::trace_realisations`] for
    /// one surface: trace the photons `photons` (a range of photon indices
    /// that starts on a batch: [`BrdfRun::photon_range`] for the run's own)
    /// of every incidence angle on `surface`, as every realisation's.
    ///
    /// # Panics
    /// If the range does not start on a batch or exceeds the run's photons.
    pub fn trace(
        &self,
        surface: &MicroSurface,
        photons: std::ops::Range<u64>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> BrdfResult {
        let surfaces = vec![surface; self.realisations as usize];
        self.trace_realisations(&surfaces, photons, progress)
    }

    /// Trace the photons `photons` of incidence `theta` at light azimuth
    /// `a` (an index of `phi_deg`), realisation by realisation
    /// ([`BrdfRun::trace_realisations`]).
    fn trace_azimuth(
        &self,
        surfaces: &[&MicroSurface],
        theta: f64,
        a: usize,
        photons: &std::ops::Range<u64>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> ByAzimuth {
        let phi = self.phi_deg[a];
        let clock = Instant::now();
        let mut lanes = vec![Vec::new(); self.lane_count()];
        for (r, surface) in (0..).zip(surfaces) {
            let (b0, b1) = self.realisation_batches(r);
            let part = (b0 * BATCH).max(photons.start)..(b1 * BATCH).min(photons.end);
            if part.is_empty() {
                continue;
            }
            let nodes = self.run_nodes(surface, theta, a, part, progress);
            for (all, some) in lanes.iter_mut().zip(nodes) {
                all.extend(some);
            }
        }
        let seconds = clock.elapsed().as_secs_f64();
        let wavelength = lanes
            .into_iter()
            .enumerate()
            .map(|(l, mut nodes)| {
                let tallies = add_up(&self.combine(nodes.iter()))
                    .unwrap_or_else(|| self.empty_tallies(&self.grid(), &self.inplane()));
                let (realisations, ensemble) =
                    self.realisation_results(theta, phi, &nodes, &tallies);
                // The root is kept once, as the sums.
                if let [n] = nodes.as_slice()
                    && (n.level, n.index) == (self.root_level(), 0)
                {
                    nodes.clear();
                }
                IncidenceResult {
                    theta_i_deg: theta,
                    phi_i_deg: phi,
                    wavelength_um: self.wavelength(l),
                    tallies,
                    realisations,
                    ensemble,
                    nodes,
                    seconds,
                }
            })
            .collect();
        ByAzimuth {
            phi_i_deg: phi,
            wavelength,
        }
    }

    /// A shorthand of the entry point [`BrdfRun::trace_realisations`]:
    /// [`BrdfRun::trace`] of the run's own photons
    /// ([`BrdfRun::photon_range`]) on one surface.
    pub fn trace_whole(
        &self,
        surface: &MicroSurface,
        progress: &(dyn Fn(u64) + Sync),
    ) -> BrdfResult {
        self.trace(surface, self.photon_range(), progress)
    }

    /// Trace the photons `photons` of one incidence angle and light azimuth
    /// `a` (an index of `phi_deg`) in batches (batch
    /// `k` of the range is batch `photons.start / BATCH + k` of the run),
    /// in parallel, and reduce them in batch order over the fixed tree;
    /// returns its complete nodes, one list per wavelength. Large surfaces
    /// are traced in the Morton order of the entry points ([`order::pays`]).
    fn run_nodes(
        &self,
        surface: &MicroSurface,
        theta_deg: f64,
        a: usize,
        photons: std::ops::Range<u64>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Vec<Vec<Node<BrdfTallies>>> {
        let ordered = order::pays(surface);
        self.run_nodes_in(surface, theta_deg, a, photons, ordered, progress)
    }

    /// [`BrdfRun::run_nodes`], in Morton order if `ordered`.
    fn run_nodes_in(
        &self,
        surface: &MicroSurface,
        theta_deg: f64,
        a: usize,
        photons: std::ops::Range<u64>,
        ordered: bool,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Vec<Vec<Node<BrdfTallies>>> {
        let base = photons.start / BATCH;
        let total_batches = self.photons.div_ceil(BATCH);
        let grid = Locator::new(self.grid());
        let phi_deg = self.phi_deg[a];
        let inplane = self.inplane_at(phi_deg);
        let dir = -toward_light(theta_deg, phi_deg);
        let mut sums: Vec<_> = (0..self.lane_count())
            .map(|_| DyadicSum::new(total_batches))
            .collect();
        let spare = Spare::default();
        let mut consume = |k, values: Vec<BrdfTallies>| {
            for (sum, value) in sums.iter_mut().zip(values) {
                sum.push_with(
                    Node {
                        level: 0,
                        index: base + k,
                        value,
                    },
                    &BrdfTallies::merge_clearing,
                    &mut |t| spare.tallies.lock().expect("spare tallies").push(t),
                )
                .expect("batches in order");
            }
        };
        let args = TraceArgs {
            surface,
            locator: &grid,
            inplane: &inplane,
            dir,
            phi: phi_deg.to_radians(),
            seed: self.azimuth_seed(a),
            ordered,
            photons,
            spare: &spare,
        };
        let spectral = !self.wavelengths_um.is_empty();
        let (c, p) = (&mut consume, progress);
        match (
            spectral,
            self.polarisation.transport,
            self.polarisation.tally,
        ) {
            (true, false, _) => self.trace_spectral::<f64>(&args, c, p),
            (true, true, PolarTally::Mueller) => self.trace_spectral::<Polarised<4>>(&args, c, p),
            (true, true, _) => self.trace_spectral::<Polarised<1>>(&args, c, p),
            (false, false, _) => self.trace_ordered::<f64>(&args, c, p),
            (false, true, PolarTally::Mueller) => self.trace_ordered::<Polarised<4>>(&args, c, p),
            (false, true, _) => self.trace_ordered::<Polarised<1>>(&args, c, p),
        }
        sums.into_iter().map(DyadicSum::into_nodes).collect()
    }

    /// [`BrdfRun::trace_ordered`] with the spectral carrier of lanes `C` ([`LaneCarrier::Spectrum`])
    /// and the smallest capacity (8, 32, 128) that holds the run's wavelengths.
    fn trace_spectral<C: LaneCarrier>(
        &self,
        args: &TraceArgs,
        consume: &mut dyn FnMut(u64, Vec<BrdfTallies>),
        progress: &(dyn Fn(u64) + Sync),
    ) {
        match self.lane_count() {
            0..=8 => self.trace_ordered::<C::Spectrum<8>>(args, consume, progress),
            9..=32 => self.trace_ordered::<C::Spectrum<32>>(args, consume, progress),
            _ => self.trace_ordered::<C::Spectrum<MAX_WAVELENGTHS>>(args, consume, progress),
        }
    }

    /// Trace this run's photons carrying `C` (see [`crate::transport::carrier`]),
    /// with `ordered` in the Morton order of their entry points
    /// ([`crate::transport::parallel_batches_ordered`]), else in index order, and hand each batch's
    /// tallies (one per wavelength), scored in index order (the same tallies either way), to
    /// `consume(batch index, tally)` in batch order. Batches tally into the
    /// cleared tallies of `spare` while there are any.
    fn trace_ordered<C: Carrier>(
        &self,
        args: &TraceArgs,
        consume: &mut dyn FnMut(u64, Vec<BrdfTallies>),
        progress: &(dyn Fn(u64) + Sync),
    ) {
        let TraceArgs {
            surface,
            locator,
            inplane,
            dir,
            phi,
            seed,
            ordered,
            ref photons,
            spare,
        } = *args;
        let lattices = (self.launch == Launch::Lattice).then(|| Lattices::new(seed));
        let tally_bytes = self.tally_bytes();
        let incident: Stokes = self.polarisation.incident.stokes();
        let launch = C::launch(incident, hemisphere_reference(dir, phi), self.lane_count());
        // Photon n's stream (after the entry draws) and entry point.
        let (first, last) = (photons.start, photons.end);
        let streams = Streams::new(seed);
        let entry = |n: u64| {
            let g = first + n;
            let mut rng = streams.photon(g);
            let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
            let mut replicate = 0;
            if let Some(lattices) = &lattices {
                let (r, [lu, lv]) = lattices.point(g);
                (replicate, u, v) = (r, lu, lv);
            }
            Entry {
                rng,
                u,
                v,
                replicate,
            }
        };
        // A history (its intersection tests counted in `scratch.tests`).
        let history_only = |e: &Entry, scratch: &mut Scratch| {
            let start = DVec3::new(e.u * surface.size.x, e.v * surface.size.y, surface.top);
            let mut rng = e.rng.clone();
            trace(
                surface,
                start,
                dir,
                launch,
                &self.controls,
                &mut rng,
                scratch,
            )
        };
        // A history and the intersection tests it took.
        let history = |e: &Entry, scratch: &mut Scratch| {
            let tests = scratch.tests;
            let h = history_only(e, scratch);
            (h, scratch.tests - tests)
        };
        // The histories of `entries` by the wavefront kernel, into `held`
        // (one per entry, in the entries' order) with the tests each took.
        let wave = |entries: &[Entry],
                    scratch: &mut Scratch,
                    held: &mut Vec<Option<(MicroHistory<C>, u64)>>| {
            held.clear();
            held.resize(entries.len(), None);
            trace_wave(
                surface,
                entries.len(),
                |k| {
                    let e = &entries[k];
                    let start = DVec3::new(e.u * surface.size.x, e.v * surface.size.y, surface.top);
                    (start, e.rng.clone())
                },
                dir,
                launch,
                &self.controls,
                scratch,
                |k, h, tests| held[k] = Some((h, tests)),
            );
        };
        if !ordered {
            // A small surface stays in the caches in any order: trace and
            // score each photon in turn, batch by batch.
            let batch = |range: std::ops::Range<u64>| {
                let mut scratch = Scratch::new(surface);
                self.score_batch(locator, inplane, phi, spare, |score| match self.kernel {
                    Kernel::Scalar => {
                        for n in range {
                            let e = entry(n);
                            // The history scored where it was made (no
                            // move into a pair: a Mueller history is a
                            // `memcpy` of 200 bytes).
                            let tests = scratch.tests;
                            let h = history_only(&e, &mut scratch);
                            score(e.replicate, &h, scratch.tests - tests);
                        }
                    }
                    Kernel::Wavefront => {
                        // Chunks of the batch traced as one wave each, then
                        // scored in photon order (at most about 256 KiB of
                        // histories held).
                        let chunk = (WAVE_HELD_BYTES / std::mem::size_of::<MicroHistory<C>>())
                            .clamp(WAVE, 1024);
                        let mut held: Vec<Option<(MicroHistory<C>, u64)>> = Vec::new();
                        let mut entries = Vec::with_capacity(chunk);
                        let mut n = range.start;
                        while n < range.end {
                            let m = (range.end - n).min(chunk as u64);
                            entries.clear();
                            entries.extend((n..n + m).map(&entry));
                            wave(&entries, &mut scratch, &mut held);
                            for (e, h) in entries.iter().zip(&held) {
                                let (h, tests) = h.as_ref().expect("every photon of a wave ends");
                                score(e.replicate, h, *tests);
                            }
                            n += m;
                        }
                    }
                })
            };
            return crate::transport::parallel_batches(
                last - first,
                tally_bytes,
                batch,
                consume,
                progress,
            );
        }
        crate::transport::parallel_batches_ordered(
            last - first,
            tally_bytes,
            |n| {
                let e = entry(n);
                (order::morton(e.u, e.v), e)
            },
            || (Scratch::new(surface), Vec::new()),
            |entries: &[Entry], (scratch, held), out| match self.kernel {
                Kernel::Scalar => out.extend(entries.iter().map(|e| history(e, scratch))),
                Kernel::Wavefront => {
                    wave(entries, scratch, held);
                    out.extend(
                        held.drain(..)
                            .map(|h| h.expect("every photon of a wave ends")),
                    );
                }
            },
            |_, visit| {
                self.score_batch(locator, inplane, phi, spare, |score| {
                    visit(&mut |e, (h, tests)| score(e.replicate, h, *tests));
                })
            },
            consume,
            progress,
        );
    }
}

/// Zero batch tallies of one trace's layout, for batches to tally into
/// instead of allocating and clearing fresh ones (they come back cleared
/// from [`BrdfTallies::merge_clearing`] in the batch tree, spectral batch
/// sums from [`LaneSums::drain_into`]).
#[derive(Default)]
pub(super) struct Spare {
    /// Batch tallies, one per wavelength of a batch.
    pub(super) tallies: std::sync::Mutex<Vec<BrdfTallies>>,
    /// A spectral batch's interleaved sums ([`LaneSums`]).
    pub(super) lane_sums: std::sync::Mutex<Vec<LaneSums>>,
}

/// What every photon of one incidence's trace shares.
#[derive(Clone)]
struct TraceArgs<'a> {
    surface: &'a MicroSurface,
    locator: &'a Locator,
    inplane: &'a InPlaneTally,
    /// The incident flight (unit, z < 0).
    dir: DVec3,
    /// The light azimuth (radians).
    phi: f64,
    /// The azimuth's tracing seed ([`BrdfRun::azimuth_seed`]).
    seed: u64,
    /// Trace in the Morton order of the entry points.
    ordered: bool,
    /// The photon indices traced.
    photons: std::ops::Range<u64>,
    spare: &'a Spare,
}

#[derive(Clone)]
struct Entry {
    /// Its stream, after the two draws of the random entry point.
    rng: rand_pcg::Pcg64Mcg,
    /// Entry point on the unit square (scaled to the cell).
    u: f64,
    /// See `u`.
    v: f64,
    /// Lattice replicate (0 for a random launch).
    replicate: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::micro::{DEFAULT_SCENE, MicroScene};
    use crate::tally::Symmetry;

    /// Tracing in Morton order and in index order, with either kernel,
    /// gives the same tallies, bit for bit, for the scalar weight, Stokes vectors and Mueller
    /// columns, random and lattice launches, with mirror symmetry, and a
    /// partial last batch.
    #[test]
    fn morton_order_gives_the_index_order_tallies() {
        let scene_file = crate::scene::SceneFile {
            file: "default.toml".into(),
            dir: ".".into(),
        };
        let al = DEFAULT_SCENE.replace("reflectance = 0.8", "n = 1.015\nk = 6.627");
        for (text, tally, launch, symmetry) in [
            (
                DEFAULT_SCENE,
                PolarTally::None,
                Launch::Random,
                Symmetry::None,
            ),
            (
                DEFAULT_SCENE,
                PolarTally::None,
                Launch::Lattice,
                Symmetry::Mirror,
            ),
            (
                al.as_str(),
                PolarTally::Stokes,
                Launch::Random,
                Symmetry::Mirror,
            ),
            (
                al.as_str(),
                PolarTally::Mueller,
                Launch::Lattice,
                Symmetry::None,
            ),
        ] {
            let scene = MicroScene::from_str(text, scene_file.clone(), "t".into()).unwrap();
            let mut run = scene.brdf_run();
            run.photons = 3 * BATCH + 16 * 37;
            run.launch = launch;
            run.symmetry = symmetry;
            run.polarisation.tally = tally;
            run.polarisation.transport = tally != PolarTally::None;
            let nodes = |ordered, kernel| {
                let mut run = run.clone();
                run.kernel = kernel;
                run.run_nodes_in(&scene.surface, 60.0, 0, 0..run.photons, ordered, &|_| {})
            };
            let by_index = nodes(false, Kernel::Scalar);
            assert!(by_index[0][0].value.photons > 0);
            for (ordered, kernel) in [
                (true, Kernel::Scalar),
                (false, Kernel::Wavefront),
                (true, Kernel::Wavefront),
            ] {
                assert_eq!(
                    by_index,
                    nodes(ordered, kernel),
                    "{tally:?} {launch:?} {symmetry:?} {ordered} {kernel:?}"
                );
            }
        }
    }
}
