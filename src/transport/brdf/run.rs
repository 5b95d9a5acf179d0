//! The run description: [`BrdfRun`], what a `roks brdf` run traces, with
//! its light azimuths ([`Azimuths`]), shard block ([`ShardRange`]) and
//! polarisation settings ([`Polarisation`]), their checks and their sizes.

use super::error::{AzimuthError, IncidenceError, PolarisationError, RunError};
use super::tallies::{BOUNCE_BINS, BrdfTallies};
use crate::tally::sum::BATCH;

use glam::DVec3;

use crate::optics::polarisation::Incident;
use crate::tally::sum::{DyadicSum, Node};
use crate::tally::{CarlsonGrid, InPlaneTally, Merge, PolarTally, Symmetry};
use crate::transport::launch::Launch;
use crate::transport::micro::Controls;
use crate::transport::wavefront::Kernel;

/// Bytes per in-plane bin and incidence of a run's result files beside its
/// tallies (`inplane.csv` as text, and read back for `inplane.png`), for
/// [`BrdfRun::memory_bytes`]. Measured with `/usr/bin/time -v` on 10
/// angles x 10 light azimuths (1 photon each): 631 MB peak RSS with 0.01
/// degree bins (18001), 142 MB with 1 degree bins (181), so 275 bytes per
/// bin and incidence, 16 of them the tallies counted apart.
pub const INPLANE_ROW_BYTES: u64 = 260;

/// What to run: the one description of a `roks brdf` run, built once from
/// the scene and the command line's overrides
/// ([`crate::scene::micro::Overrides`]), traced as it is, and written as it
/// is into `summary.json` and `tallies.json` (key `run`; keys in
/// alphabetical order, as the fields are declared; floats in the shortest
/// form that reads back (serde_json with `float_roundtrip`), so
/// a run read back is bit for bit the run written).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrdfRun {
    /// Carlson bands.
    pub bands: usize,
    /// History limits.
    pub controls: Controls,
    /// In-plane bin width (degrees).
    pub inplane_step_deg: f64,
    /// In-plane detector full width out of the plane (degrees).
    pub inplane_width_deg: f64,
    /// Entry points: random, or lattice replicates.
    pub launch: Launch,
    /// Light azimuths (degrees, [`Azimuths`]): every incidence angle is
    /// traced at each, `photons` photons per incidence and azimuth.
    pub phi_deg: Azimuths,
    /// Photons per incidence angle and light azimuth of the whole run (of
    /// all its shards).
    #[serde(rename = "photons_per_incidence")]
    pub photons: u64,
    /// Polarised transport, incident state and polarisation tallies.
    pub polarisation: Polarisation,
    /// Surface realisations (`[surface] realisations`): realisation `r`
    /// traces the whole batches [`BrdfRun::realisation_batches`] of every
    /// incidence on its own surface. Absent from the files when 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub realisations: u64,
    /// Tracing seed.
    pub seed: u64,
    /// The block of the run's photons this run traces (`--shard I/N`);
    /// `None`: all of them.
    pub shard: Option<ShardRange>,
    /// Fold mirror images in the plane of incidence into the Carlson cells.
    pub symmetry: Symmetry,
    /// Incidence polar angles (degrees).
    pub theta_deg: Vec<f64>,
    /// The kernel that traces the histories (`--kernel`). Never written to
    /// the files (both kernels give the same bits; a run read back has the
    /// default, scalar).
    #[serde(skip)]
    pub kernel: Kernel,
    /// Vacuum wavelengths (µm, strictly increasing) of a spectral run, each
    /// carried by every photon ([`crate::transport::carrier::LaneCarrier::Spectrum`]); empty for a monochrome run.
    pub wavelengths_um: Vec<f64>,
}

fn one() -> u64 {
    1
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_one(n: &u64) -> bool {
    *n == 1
}

/// The light azimuths of a run (degrees, from the `+x` axis toward `+y`;
/// `[light] phi_deg`, `--phi`): one or several, each finite, in
/// `[0, 360)` and given once ([`Azimuths::check`]). A scene gives a number
/// or a list; the run's files (`summary.json`, `tallies.json`) hold a
/// number for one azimuth (the files of a one-azimuth run are those of
/// the runs before several azimuths) and a list for several.
///
/// Azimuth `a` (0-based, in the order given) is traced with the seed
/// [`BrdfRun::azimuth_seed`]: photon `n` of azimuth `a` draws from the
/// stream `(seed + a * 0xD1B54A32D192ED03, n)`, so the first azimuth's
/// photons are those of a run at that azimuth alone (bit for bit), and the
/// azimuths' tables are statistically independent.
#[derive(Debug, Clone, PartialEq)]
pub struct Azimuths(pub Vec<f64>);

impl Azimuths {
    /// One azimuth.
    #[must_use]
    pub fn one(phi_deg: f64) -> Self {
        Self(vec![phi_deg])
    }

    /// Check the list: at least one azimuth, each finite and in
    /// `[0, 360)`, none given twice.
    ///
    /// # Errors
    /// The offending azimuth ([`AzimuthError::index`]).
    pub fn check(&self) -> Result<(), AzimuthError> {
        if self.0.is_empty() {
            return Err(AzimuthError::Empty);
        }
        if let Some((index, &value)) = self
            .0
            .iter()
            .enumerate()
            .find(|(_, p)| !(p.is_finite() && (0.0..360.0).contains(*p)))
        {
            return Err(AzimuthError::Range { index, value });
        }
        if let Some((index, value)) = first_repeat(&self.0) {
            return Err(AzimuthError::Twice { index, value });
        }
        Ok(())
    }
}

impl std::ops::Deref for Azimuths {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.0
    }
}

impl serde::Serialize for Azimuths {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.0.as_slice() {
            [one] => s.serialize_f64(*one),
            many => many.serialize(s),
        }
    }
}

impl<'de> serde::Deserialize<'de> for Azimuths {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Azimuths;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or a list of numbers (degrees)")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Azimuths, E> {
                Ok(Azimuths::one(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Azimuths, E> {
                Ok(Azimuths::one(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Azimuths, E> {
                Ok(Azimuths::one(v as f64))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Azimuths, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    v.push(x);
                }
                Ok(Azimuths(v))
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// Block `index` of `count` of a run's photons (`--shard I/N`): the photon
/// indices `[first_photon, last_photon)` of every incidence
/// ([`crate::shard::Shard::photon_range`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardRange {
    /// Number of blocks.
    pub count: u64,
    /// First photon index traced (a multiple of [`BATCH`]).
    pub first_photon: u64,
    /// 0-based block index.
    pub index: u64,
    /// One past the last photon index traced.
    pub last_photon: u64,
}

/// Polarisation settings of a run (`[light] polarisation`, `[tally]
/// polarisation`, `[transport] polarisation`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Polarisation {
    /// Incident state, in the frame of the incident flight (s = `(1, 1, 0, 0)`).
    pub incident: Incident,
    /// Polarisation tallies (need `transport`).
    pub tally: PolarTally,
    /// Carry a Stokes vector (or Mueller columns) per photon; false: the
    /// scalar weight (unpolarised reflectance per bounce).
    pub transport: bool,
}

impl Polarisation {
    /// The settings a run uses: polarised transport when asked
    /// (`transport = Some(true)`), or by default when the surface has a
    /// Fresnel material (`has_fresnel`: every other material is
    /// non-polarising, so the scalar weight is exact there) or a
    /// polarisation tally is asked for.
    ///
    /// # Errors
    /// [`PolarisationError`] (the scene names the key at fault,
    /// [`RunField`](crate::scene::keys::RunField)): a polarisation tally without polarised transport, or mirror
    /// symmetry with an incident state that the mirror changes (`S2` or
    /// `S3` non-zero).
    pub fn resolve(
        has_fresnel: bool,
        transport: Option<bool>,
        incident: Incident,
        tally: PolarTally,
        symmetry: Symmetry,
    ) -> Result<Self, PolarisationError> {
        if tally != PolarTally::None && transport == Some(false) {
            return Err(PolarisationError::TallyWithoutTransport(tally));
        }
        let on = transport.unwrap_or(has_fresnel || tally != PolarTally::None);
        if on && symmetry == Symmetry::Mirror && !incident.is_mirror_symmetric() {
            return Err(PolarisationError::MirrorChangesIncident(incident));
        }
        Ok(Self {
            transport: on,
            incident,
            tally,
        })
    }
}

impl Default for Polarisation {
    fn default() -> Self {
        Self {
            transport: false,
            incident: Incident::Unpolarised,
            tally: PolarTally::None,
        }
    }
}

impl BrdfRun {
    /// Check what the run later assumes, for every source of a run (a
    /// scene's `[light]`, `[tally]` and `[transport]` with the command
    /// line's overrides, or the `run` of a `tallies.json`): incidence
    /// angles in `[0, 90)` and each once, a finite azimuth, wavelengths
    /// ([`crate::optics::spectrum::check_wavelengths`]), photons > 0 (a
    /// multiple of 16 with a lattice launch), bands in `1..=1000`, an
    /// in-plane step the tally accepts, an in-plane width in `(0, 180]`,
    /// history caps > 0, a roulette weight in `[0, 1)`, and an incident
    /// state that is a state.
    ///
    /// # Errors
    /// The check that failed ([`RunError`]; the scene names the field at
    /// fault, as the scene key or the file's key:
    /// [`RunField::of`](crate::scene::keys::RunField::of)).
    pub fn check(&self) -> Result<(), RunError> {
        check_incidence(&self.theta_deg)?;
        self.phi_deg.check()?;
        if !self.wavelengths_um.is_empty() {
            crate::optics::spectrum::check_wavelengths(&self.wavelengths_um)?;
        }
        crate::transport::launch::check_photons(self.launch, self.photons)?;
        let batches = self.photons.div_ceil(BATCH);
        if self.realisations == 0 || self.realisations > batches {
            return Err(RunError::Realisations {
                batches,
                photons: self.photons,
                realisations: self.realisations,
            });
        }
        if !(1..=1000).contains(&self.bands) {
            return Err(RunError::Bands(self.bands));
        }
        let step = self.inplane_step_deg;
        if InPlaneTally::new(step, 0.5, 0.0).is_none() {
            return Err(RunError::InplaneStep(step));
        }
        if let Some(e) = InPlaneTally::width_error(self.inplane_width_deg) {
            return Err(e.into());
        }
        if self.controls.max_bounces == 0 {
            return Err(RunError::MaxBounces);
        }
        if self.controls.max_segments == 0 {
            return Err(RunError::MaxSegments);
        }
        let rr = self.controls.roulette_weight;
        if !(0.0..1.0).contains(&rr) {
            return Err(RunError::RouletteWeight);
        }
        let p = &self.polarisation;
        p.incident.validate()?;
        if p.tally != PolarTally::None && !p.transport {
            return Err(RunError::PolarTally);
        }
        if p.transport && self.symmetry == Symmetry::Mirror && !p.incident.is_mirror_symmetric() {
            return Err(RunError::Symmetry);
        }
        Ok(())
    }

    /// The Carlson grid of this run.
    #[must_use]
    pub fn grid(&self) -> CarlsonGrid {
        CarlsonGrid::new(self.bands).expect("bands >= 1 checked by the scene")
    }

    /// Estimated peak memory (bytes) of this run's tallies and result
    /// files: [`BrdfRun::tally_bytes`] per tally; a run holds up to
    /// [`crate::transport::pending_batches`] batch tallies in flight (counted for one
    /// thread: two more per further thread when the tallies are large), a stack of
    /// partial sums (one per bit of the batch count) and one result per
    /// incidence (every angle at every light azimuth and wavelength); the
    /// files take about `2 (200 + 40 (components + 1) + 64)` bytes per
    /// Carlson cell and incidence (`brdf.csv` and the polarisation table as
    /// text, and read back for the pictures and exports: measured 2.48 GB
    /// peak RSS for 1000 bands at 2 incidences, 2.0e6 cells each, 610 bytes
    /// per cell and incidence) and [`INPLANE_ROW_BYTES`] per in-plane bin and
    /// incidence. Right to a factor of about 2, for refusing a run before
    /// it starts.
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        use crate::limits::product;
        let cells = CarlsonGrid::new(self.bands).map_or(0, |g| g.n_cells()) as u64;
        let bins = self.inplane_bins();
        let k = self.polarisation.tally.components() as u64;
        let tallies = self.tally_bytes();
        let batches = self.photons.div_ceil(BATCH).max(1);
        let incidences = product(&[
            self.theta_deg.len() as u64,
            self.phi_deg.len() as u64,
            self.lane_count() as u64,
        ]);
        let live = batches
            .min(crate::transport::pending_batches(tallies, 1))
            .saturating_add(u64::from(64 - batches.leading_zeros()))
            .saturating_add(1)
            .saturating_add(incidences);
        let files = product(&[cells, incidences, 2 * (200 + 40 * (k + 1) + 64)])
            .saturating_add(product(&[bins, incidences, INPLANE_ROW_BYTES]));
        product(&[tallies, live]).saturating_add(files)
    }

    /// The in-plane bins of this run's tally (0 for settings it refuses).
    #[must_use]
    pub fn inplane_bins(&self) -> u64 {
        InPlaneTally::new(self.inplane_step_deg, 0.5 * self.inplane_width_deg, 0.0)
            .map_or(0, |t| t.n_bins()) as u64
    }

    /// Estimated size (bytes) of one [`BrdfTallies`]: 16 bytes per Carlson
    /// cell and in-plane bin (sum and sum of squares), 8 more per lattice
    /// replicate, and its polarisation sums (4 or 16 components per cell and
    /// the hemisphere, alike, with 8 more per bin for the products with
    /// component 0).
    #[must_use]
    pub fn tally_bytes(&self) -> u64 {
        use crate::limits::product;
        let cells = CarlsonGrid::new(self.bands).map_or(0, |g| g.n_cells()) as u64;
        let bins = self.inplane_bins();
        let replicates = self.launch.replicates().unwrap_or(0);
        let per_bin = 16 + 8 * replicates;
        let k = self.polarisation.tally.components() as u64;
        let one = product(&[cells + bins + 1, per_bin])
            .saturating_add(product(&[k, cells + 1, per_bin + 8]))
            .saturating_add(8 * BOUNCE_BINS as u64 + 256);
        product(&[one, self.lane_count() as u64])
    }

    /// Wavelengths carried per photon: those of a spectral run, 1 for a
    /// monochrome run.
    #[must_use]
    pub fn lane_count(&self) -> usize {
        self.wavelengths_um.len().max(1)
    }

    /// The wavelength of lane `l` (`None` for a monochrome run).
    #[must_use]
    pub fn wavelength(&self, l: usize) -> Option<f64> {
        self.wavelengths_um.get(l).copied()
    }

    /// Zero tallies of this run's layout.
    #[must_use]
    pub fn empty_tallies(&self, grid: &CarlsonGrid, inplane: &InPlaneTally) -> BrdfTallies {
        BrdfTallies::new(
            grid,
            inplane,
            self.launch.replicates(),
            self.polarisation.tally,
        )
    }

    /// The in-plane tally of this run at its first light azimuth (its
    /// bins, their centres and solid angles are those of every azimuth).
    #[must_use]
    pub fn inplane(&self) -> InPlaneTally {
        self.inplane_at(self.phi_deg[0])
    }

    /// The in-plane tally of this run in the plane of incidence at light
    /// azimuth `phi_deg` (degrees).
    #[must_use]
    pub fn inplane_at(&self, phi_deg: f64) -> InPlaneTally {
        InPlaneTally::new(
            self.inplane_step_deg,
            0.5 * self.inplane_width_deg,
            phi_deg.to_radians(),
        )
        .expect("in-plane settings checked by the scene")
    }

    /// The seed azimuth `a` (an index of `phi_deg`) is traced with:
    /// `seed + a * 0xD1B54A32D192ED03` (wrapping; the run's seed for the
    /// first azimuth). See [`Azimuths`].
    #[must_use]
    pub fn azimuth_seed(&self, a: usize) -> u64 {
        self.seed
            .wrapping_add((a as u64).wrapping_mul(0xD1B5_4A32_D192_ED03))
    }

    /// The level of the root of the run's batch tree: the smallest `K`
    /// with `2^K` at least the run's batches ([`crate::tally::sum`]).
    #[must_use]
    pub fn root_level(&self) -> u32 {
        self.photons
            .div_ceil(BATCH)
            .max(1)
            .next_power_of_two()
            .trailing_zeros()
    }

    /// `nodes` (in batch order, contiguous) pushed into the run's batch
    /// tree: its complete nodes (the root alone when they cover the run).
    /// The nodes of a piece of the run, split anywhere on node bounds,
    /// combine to the nodes of the piece's leaves, bit for bit.
    ///
    /// # Panics
    /// If the nodes are not contiguous or lie past the run.
    #[must_use]
    pub fn combine<'a>(
        &self,
        nodes: impl Iterator<Item = &'a Node<BrdfTallies>>,
    ) -> Vec<Node<BrdfTallies>> {
        let mut sum = DyadicSum::new(self.photons.div_ceil(BATCH));
        for n in nodes {
            sum.push(n.clone(), &BrdfTallies::merge)
                .expect("contiguous nodes of the run");
        }
        sum.into_nodes()
    }

    /// The batches `[b0, b1)` (of every incidence) that realisation `r`
    /// traces: of the run's `B = ceil(photons / BATCH)` batches,
    /// `[floor(r B / R), floor((r + 1) B / R))` for `R` realisations (the
    /// rule of [`crate::shard::Shard::photon_range`]): whole batches,
    /// their numbers differing by one at most, realisation 0 first.
    #[must_use]
    pub fn realisation_batches(&self, r: u64) -> (u64, u64) {
        let b = u128::from(self.photons.div_ceil(BATCH));
        let n = u128::from(self.realisations.max(1));
        let at = |k: u64| (u128::from(k) * b / n) as u64;
        (at(r), at(r + 1))
    }

    /// The photon indices this run traces of every incidence: its shard's,
    /// or all `0..photons`.
    #[must_use]
    pub fn photon_range(&self) -> std::ops::Range<u64> {
        self.shard
            .map_or(0..self.photons, |s| s.first_photon..s.last_photon)
    }
}

/// The first angle that repeats an earlier one: its index and value.
pub(super) fn first_repeat(angles: &[f64]) -> Option<(usize, f64)> {
    angles
        .iter()
        .enumerate()
        .find(|(i, t)| angles[..*i].contains(t))
        .map(|(i, t)| (i, *t))
}

/// The unit vector toward the light, `(sin t cos p, sin t sin p, cos t)`.
#[must_use]
pub fn toward_light(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Check incidence angles, from a scene's `[light] theta_deg` or
/// `--theta`: at least one, each in `[0, 90)` degrees, none given twice (a
/// BRDF table holds one block per angle).
///
/// # Errors
/// The first problem, as an [`IncidenceError`].
pub fn check_incidence(theta_deg: &[f64]) -> Result<(), IncidenceError> {
    if theta_deg.is_empty() {
        return Err(IncidenceError::Empty);
    }
    if let Some((index, &theta_deg)) = theta_deg
        .iter()
        .enumerate()
        .find(|(_, t)| !(t.is_finite() && (0.0..90.0).contains(*t)))
    {
        return Err(IncidenceError::Range { index, theta_deg });
    }
    if let Some((index, theta_deg)) = first_repeat(theta_deg) {
        return Err(IncidenceError::Twice { index, theta_deg });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incidence_angles() {
        assert_eq!(check_incidence(&[0.0, 45.0, 89.9]), Ok(()));
        let message = |t: &[f64]| {
            let e = check_incidence(t).unwrap_err();
            (e.index(), e.to_string())
        };
        assert_eq!(message(&[]), (None, "needs at least one angle".into()));
        assert_eq!(
            message(&[10.0, 90.0]),
            (Some(1), "must be in [0, 90), got 90".into())
        );
        assert_eq!(
            message(&[-1e-300]),
            (Some(0), "must be in [0, 90), got -1e-300".into())
        );
        assert!(matches!(
            check_incidence(&[f64::NAN]),
            Err(IncidenceError::Range { index: 0, .. })
        ));
        let (i, e) = message(&[10.0, 20.0, 10.0]);
        assert_eq!(i, Some(2));
        assert!(e.starts_with("10 is given twice"), "{e}");
    }
}
