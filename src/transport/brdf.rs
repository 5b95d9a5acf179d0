//! The BRDF generator: photons from each incidence direction, tallied on the
//! Carlson grid and in the plane of incidence, with standard errors.
//!
//! Photons start at uniform points of the cell on the launch plane, random
//! or on randomised lattices ([`super::launch`]), travelling along
//! `-omega_i`. Photon `n` uses the stream `(seed, n)` only;
//! photons are traced in fixed batches of [`BATCH`] and the batch tallies are
//! summed over a fixed binary tree on batch indices ([`crate::tally::sum`]), so
//! results are bit-identical for any thread count, and shards of a run
//! (`--shard I/N`) merge to exactly the single run's sums.
//! `fraction` in a cell is the photon weight leaving through it per launched
//! photon; BRDF = fraction / projected solid angle (sr⁻¹). With
//! [`Symmetry::Mirror`] each escaping photon counts half in its mirror
//! image in the plane of incidence ([`crate::tally::symmetry`]).
//!
//! With [`Polarisation::transport`] photons carry Stokes vectors (or Mueller
//! columns, for [`PolarTally::Mueller`]) through every Fresnel bounce
//! ([`super::carrier`]); `brdf.csv`, `inplane.csv` and the reflectance are
//! then the intensity `S0` for the incident state, and [`PolarTallies`] keep
//! the Stokes or Mueller BRDF per cell ([`crate::tally::polar`]).

use crate::scene::Num;
use std::time::Instant;

use glam::DVec3;
use rand::RngExt;

use super::carrier::{Carrier, LaneCarrier, MAX_WAVELENGTHS, Polarised};
use super::launch::{Lattices, Launch, PhotonsError, replicate_stderr};
use super::micro::{Controls, Fate, History, trace};
use super::order;
use super::rng::photon_rng;
use crate::micro::{MicroSurface, Scratch};
use crate::optics::polarisation::{Incident, IncidentError, Stokes, hemisphere_reference};
use crate::optics::spectrum::WavelengthListError;
use crate::tally::anisotropy::{Anisotropy, Group, Table};
use crate::tally::exact;
use crate::tally::inplane::WidthError;
use crate::tally::lanes::{LaneSums, LaneTally};
use crate::tally::polar::mirror_sign;
use crate::tally::sum::{DyadicSum, Node};
use crate::tally::{
    Accumulator, CarlsonGrid, InPlaneTally, Locator, Merge, PolarTallies, PolarTally, Symmetry,
    symmetry,
};

pub use super::BATCH;

/// Bounce counts tallied individually; longer histories share the last bin.
pub const BOUNCE_BINS: usize = 64;

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

/// A list of light azimuths [`Azimuths::check`] refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AzimuthError {
    /// No azimuth at all.
    #[error("needs at least one azimuth")]
    Empty,
    /// An azimuth outside `[0, 360)` or not finite.
    #[error("must be in [0, 360), got {}", Num(*.value))]
    Range {
        /// Its index in the list.
        index: usize,
        /// The azimuth (degrees).
        value: f64,
    },
    /// An azimuth given twice.
    #[error(
        "{value} is given twice (each light azimuth once: a BRDF table holds one block per incidence and azimuth)"
    )]
    Twice {
        /// The index of its second appearance.
        index: usize,
        /// The azimuth (degrees).
        value: f64,
    },
}

impl AzimuthError {
    /// The index of the offending azimuth (`None` for an empty list).
    #[must_use]
    pub fn index(&self) -> Option<usize> {
        match self {
            Self::Empty => None,
            Self::Range { index, .. } | Self::Twice { index, .. } => Some(*index),
        }
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

/// A checked field of a [`BrdfRun`] ([`BrdfRun::check`]), with its index
/// in a list where it has one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunField {
    /// `theta_deg` (an angle of it).
    ThetaDeg(Option<usize>),
    /// `phi_deg` (an azimuth of it).
    PhiDeg(Option<usize>),
    /// `wavelengths_um` (a wavelength of it).
    WavelengthsUm(Option<usize>),
    /// `photons_per_incidence`.
    Photons,
    /// `bands`.
    Bands,
    /// `inplane_step_deg`.
    InplaneStepDeg,
    /// `inplane_width_deg`.
    InplaneWidthDeg,
    /// `controls.max_bounces`.
    MaxBounces,
    /// `controls.max_segments`.
    MaxSegments,
    /// `controls.roulette_weight`.
    RouletteWeight,
    /// `polarisation.incident`.
    Incident,
    /// `polarisation.tally`.
    PolarTally,
    /// `symmetry`.
    Symmetry,
    /// `realisations`.
    Realisations,
}

impl RunField {
    /// The key a micro scene holds it at (`light.theta_deg[1]`,
    /// `tally.bands`; `transport.max_segments`, which a scene cannot set,
    /// for the segment cap).
    #[must_use]
    pub fn scene_key(self) -> String {
        let (key, index) = match self {
            Self::ThetaDeg(i) => ("light.theta_deg", i),
            Self::PhiDeg(i) => ("light.phi_deg", i),
            Self::WavelengthsUm(i) => ("light.wavelengths_um", i),
            Self::Photons => ("light.photons", None),
            Self::Bands => ("tally.bands", None),
            Self::InplaneStepDeg => ("tally.inplane_step_deg", None),
            Self::InplaneWidthDeg => ("tally.inplane_width_deg", None),
            Self::MaxBounces => ("transport.max_bounces", None),
            Self::MaxSegments => ("transport.max_segments", None),
            Self::RouletteWeight => ("transport.roulette_weight", None),
            Self::Incident => ("light.polarisation", None),
            Self::PolarTally => ("tally.polarisation", None),
            Self::Symmetry => ("tally.symmetry", None),
            Self::Realisations => ("surface.realisations", None),
        };
        with_index(key, index)
    }

    /// Its key in a serialised [`BrdfRun`] (`theta_deg[1]`, `bands`,
    /// `controls.max_bounces`).
    #[must_use]
    pub fn run_key(self) -> String {
        let (key, index) = match self {
            Self::ThetaDeg(i) => ("theta_deg", i),
            Self::PhiDeg(i) => ("phi_deg", i),
            Self::WavelengthsUm(i) => ("wavelengths_um", i),
            Self::Photons => ("photons_per_incidence", None),
            Self::Bands => ("bands", None),
            Self::InplaneStepDeg => ("inplane_step_deg", None),
            Self::InplaneWidthDeg => ("inplane_width_deg", None),
            Self::MaxBounces => ("controls.max_bounces", None),
            Self::MaxSegments => ("controls.max_segments", None),
            Self::RouletteWeight => ("controls.roulette_weight", None),
            Self::Incident => ("polarisation.incident", None),
            Self::PolarTally => ("polarisation.tally", None),
            Self::Symmetry => ("symmetry", None),
            Self::Realisations => ("realisations", None),
        };
        with_index(key, index)
    }
}

/// `key[i]`, or `key` without an index.
fn with_index(key: &str, index: Option<usize>) -> String {
    match index {
        Some(i) => format!("{key}[{i}]"),
        None => key.to_owned(),
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

/// Why a scene's polarisation keys do not make a run
/// ([`Polarisation::resolve`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PolarisationError {
    /// A polarisation tally with polarised transport turned off.
    #[error(
        "`{}` needs polarised transport, but [transport] polarisation = false",
        polar_tally_name(*.0)
    )]
    TallyWithoutTransport(PolarTally),
    /// Mirror symmetry with an incident state the mirror changes.
    #[error(
        "mirror symmetry maps the incident state `{}` to another (S2 or S3 non-zero): use an unpolarised, s, p or 0/90 deg linear state, or symmetry = \"none\"",
        .0.name()
    )]
    MirrorChangesIncident(Incident),
}

impl PolarisationError {
    /// The micro scene key at fault.
    #[must_use]
    pub fn scene_key(&self) -> &'static str {
        match self {
            Self::TallyWithoutTransport(_) => "tally.polarisation",
            Self::MirrorChangesIncident(_) => "tally.symmetry",
        }
    }
}

/// The name of `tally` in a scene and on the command line (`stokes`).
fn polar_tally_name(tally: PolarTally) -> String {
    clap::ValueEnum::to_possible_value(&tally)
        .expect("no variant is skipped")
        .get_name()
        .to_owned()
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
    /// [`PolarisationError`] (its [`PolarisationError::scene_key`] names the
    /// key): a polarisation tally without polarised transport, or mirror
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

/// Everything tallied for one incidence direction (sums; see [`IncidenceResult`]).
///
/// Fields are declared in the order of `tallies.json`'s keys (alphabetical:
/// the file stores a tally field by field, floats exactly, see
/// [`crate::output::tallies`]); they are added ([`Merge`]) in the order of
/// the `merge_fields!` list below. A new field is one line here and one
/// name in that list.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrdfTallies {
    /// Sum of reflections over all histories.
    pub bounces: u64,
    /// Reflected weight by number of reflections (last bin: `>= BOUNCE_BINS - 1`).
    #[serde(with = "exact::vec")]
    pub by_bounces: Vec<f64>,
    /// Histories cut by the caps.
    pub capped_histories: u64,
    /// Reflected weight per Carlson cell.
    pub carlson: Accumulator,
    /// Reflected weight per in-plane bin.
    pub inplane: Accumulator,
    /// Intersection tests ([`Scratch::tests`]: quadrics, or height-field squares).
    pub intersection_tests: u64,
    /// Weight cut by the bounce, segment or crossing cap
    /// ([`crate::micro::MAX_CROSSINGS`]).
    #[serde(with = "exact")]
    pub lost_cap: f64,
    /// Weight stopped by numerical guards.
    #[serde(with = "exact")]
    pub lost_numeric: f64,
    /// Weight absorbed by walls.
    #[serde(with = "exact")]
    pub lost_walls: f64,
    /// Histories stopped by numerical guards.
    pub numeric_histories: u64,
    /// Photons launched.
    pub photons: u64,
    /// Stokes or Mueller sums (with a polarisation tally).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polar: Option<PolarTallies>,
    /// Reflected weight (one bin).
    pub reflected: Accumulator,
    /// With [`Launch::Lattice`]: the reflected weight summed per replicate.
    pub replicates: Option<Replicates>,
    /// Straight flights traced.
    pub segments: u64,
}

crate::merge_fields!(BrdfTallies {
    sum photons,
    reflected,
    carlson,
    inplane,
    by_bounces,
    bounces,
    segments,
    intersection_tests,
    lost_walls,
    lost_cap,
    lost_numeric,
    capped_histories,
    numeric_histories,
    replicates,
    polar,
});

/// Reflected weight summed per lattice replicate, from which the standard
/// errors of a lattice run come. Bins are replicate-major: bin `b` of
/// replicate `r` is `r * bins + b`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Replicates {
    /// Per replicate and Carlson cell.
    #[serde(with = "exact::vec")]
    pub carlson: Vec<f64>,
    /// Number of replicates.
    pub count: usize,
    /// Per replicate and in-plane bin.
    #[serde(with = "exact::vec")]
    pub inplane: Vec<f64>,
    /// Reflected weight, one per replicate.
    #[serde(with = "exact::vec")]
    pub reflected: Vec<f64>,
}

crate::merge_fields!(Replicates { same count; sum reflected, carlson, inplane });

impl Replicates {
    /// Zero sums for `count` replicates of `cells` Carlson cells and `bins` in-plane bins.
    #[must_use]
    pub fn new(count: usize, cells: usize, bins: usize) -> Self {
        Self {
            count,
            reflected: vec![0.0; count],
            carlson: vec![0.0; count * cells],
            inplane: vec![0.0; count * bins],
        }
    }

    /// Standard error of the mean of `bin` of `sums` over `photons` photons
    /// split equally between the replicates.
    fn stderr(&self, sums: &[f64], bin: usize, photons: u64) -> f64 {
        let bins = sums.len() / self.count;
        let per = photons / self.count as u64;
        replicate_stderr((0..self.count).map(|r| sums[r * bins + bin]), per)
    }
}

impl BrdfTallies {
    /// All sums zero, bins for `grid` and `inplane`, replicate sums for
    /// `replicates` (see [`Launch::replicates`]), polarisation sums for `polar`.
    #[must_use]
    pub fn new(
        grid: &CarlsonGrid,
        inplane: &InPlaneTally,
        replicates: Option<u64>,
        polar: PolarTally,
    ) -> Self {
        Self {
            photons: 0,
            reflected: Accumulator::new(1),
            carlson: Accumulator::new(grid.n_cells()),
            inplane: Accumulator::new(inplane.n_bins()),
            by_bounces: vec![0.0; BOUNCE_BINS],
            bounces: 0,
            segments: 0,
            intersection_tests: 0,
            lost_walls: 0.0,
            lost_cap: 0.0,
            lost_numeric: 0.0,
            capped_histories: 0,
            numeric_histories: 0,
            replicates: replicates
                .map(|k| Replicates::new(k as usize, grid.n_cells(), inplane.n_bins())),
            polar: (polar != PolarTally::None).then(|| {
                PolarTallies::new(
                    polar.components(),
                    grid.n_cells(),
                    replicates.map(|k| k as usize),
                )
            }),
        }
    }
}

/// Zero batch tallies of one trace's layout, for batches to tally into
/// instead of allocating and clearing fresh ones (they come back cleared
/// from [`BrdfTallies::merge_clearing`] in the batch tree, spectral batch
/// sums from [`LaneSums::drain_into`]).
#[derive(Default)]
struct Spare {
    /// Batch tallies, one per wavelength of a batch.
    tallies: std::sync::Mutex<Vec<BrdfTallies>>,
    /// A spectral batch's interleaved sums ([`LaneSums`]).
    lane_sums: std::sync::Mutex<Vec<LaneSums>>,
}

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

/// The sum of complete tree nodes in batch order, added left to right
/// (`None` without nodes): a whole run's root, or a shard's sums.
#[must_use]
pub fn add_up(nodes: &[Node<BrdfTallies>]) -> Option<BrdfTallies> {
    let (first, rest) = nodes.split_first()?;
    let mut t = first.value.clone();
    for n in rest {
        t.merge(&n.value);
    }
    Some(t)
}

/// The first angle that repeats an earlier one: its index and value.
fn first_repeat(angles: &[f64]) -> Option<(usize, f64)> {
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

/// Why incidence angles are refused ([`check_incidence`]);
/// [`IncidenceError::index`] names the angle at fault.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum IncidenceError {
    /// No angle.
    #[error("needs at least one angle")]
    Empty,
    /// An angle outside `[0, 90)` degrees.
    #[error("must be in [0, 90), got {}", Num(*theta_deg))]
    Range {
        /// Its index in the list.
        index: usize,
        /// The angle (degrees).
        theta_deg: f64,
    },
    /// An angle given twice.
    #[error(
        "{theta_deg} is given twice (each incidence angle once: a BRDF table holds one block per angle)"
    )]
    Twice {
        /// The index of its second occurrence.
        index: usize,
        /// The angle (degrees).
        theta_deg: f64,
    },
}

impl IncidenceError {
    /// The index of the angle at fault (`None`: the whole list).
    #[must_use]
    pub fn index(&self) -> Option<usize> {
        match *self {
            Self::Empty => None,
            Self::Range { index, .. } | Self::Twice { index, .. } => Some(index),
        }
    }
}

/// Why a [`BrdfRun`] is refused ([`BrdfRun::check`]): the check that
/// failed, with the values it concerns; [`RunError::field`] names the
/// field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunError {
    /// `theta_deg`.
    #[error(transparent)]
    Incidence(#[from] IncidenceError),
    /// `phi_deg`.
    #[error(transparent)]
    PhiDeg(#[from] AzimuthError),
    /// `wavelengths_um`.
    #[error(transparent)]
    Wavelengths(#[from] WavelengthListError),
    /// `photons_per_incidence`.
    #[error(transparent)]
    Photons(#[from] PhotonsError),
    /// `realisations` not in `1..=batches`.
    #[error(
        "must be in 1..={batches} (each realisation traces whole batches of {BATCH} of the {photons} photons per incidence), got {realisations}"
    )]
    Realisations {
        /// The run's batches per incidence.
        batches: u64,
        /// Photons per incidence.
        photons: u64,
        /// The realisations asked for.
        realisations: u64,
    },
    /// `bands` not in `1..=1000`.
    #[error("must be in 1..=1000, got {0}")]
    Bands(usize),
    /// An in-plane step the tally refuses.
    #[error(
        "must divide 180 into at most {} bins (a step of at least 0.01 deg), got {}",
        crate::tally::inplane::MAX_BINS,
        Num(*.0)
    )]
    InplaneStep(f64),
    /// `inplane_width_deg`.
    #[error(transparent)]
    InplaneWidth(#[from] WidthError),
    /// `controls.max_bounces` of 0.
    #[error("must be > 0")]
    MaxBounces,
    /// `controls.max_segments` of 0.
    #[error("must be > 0")]
    MaxSegments,
    /// `controls.roulette_weight` not in `[0, 1)`.
    #[error("must be in [0, 1)")]
    RouletteWeight,
    /// `polarisation.incident` not a state.
    #[error(transparent)]
    Incident(#[from] IncidentError),
    /// A polarisation tally without polarised transport.
    #[error("a polarisation tally needs polarised transport")]
    PolarTally,
    /// Mirror symmetry with an incident state the mirror changes.
    #[error("mirror symmetry needs an incident state the mirror keeps (S2 = S3 = 0)")]
    Symmetry,
}

impl RunError {
    /// The field at fault, with the index of the angle or wavelength.
    #[must_use]
    pub fn field(&self) -> RunField {
        match self {
            Self::Incidence(e) => RunField::ThetaDeg(e.index()),
            Self::PhiDeg(e) => RunField::PhiDeg(e.index()),
            Self::Wavelengths(e) => RunField::WavelengthsUm(e.index()),
            Self::Photons(_) => RunField::Photons,
            Self::Realisations { .. } => RunField::Realisations,
            Self::Bands(_) => RunField::Bands,
            Self::InplaneStep(_) => RunField::InplaneStepDeg,
            Self::InplaneWidth(_) => RunField::InplaneWidthDeg,
            Self::MaxBounces => RunField::MaxBounces,
            Self::MaxSegments => RunField::MaxSegments,
            Self::RouletteWeight => RunField::RouletteWeight,
            Self::Incident(_) => RunField::Incident,
            Self::PolarTally => RunField::PolarTally,
            Self::Symmetry => RunField::Symmetry,
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
    /// The check that failed ([`RunError`]; [`RunError::field`] names the
    /// field, as the scene key or the file's key).
    pub fn check(&self) -> Result<(), RunError> {
        check_incidence(&self.theta_deg)?;
        self.phi_deg.check()?;
        if !self.wavelengths_um.is_empty() {
            crate::optics::spectrum::check_wavelengths(&self.wavelengths_um)?;
        }
        super::launch::check_photons(self.launch, self.photons)?;
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
    /// [`super::pending_batches`] batch tallies in flight (counted for one
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
            .min(super::pending_batches(tallies, 1))
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

    /// Trace the photons `photons` (a range of photon indices that starts
    /// on a batch: [`BrdfRun::photon_range`] for the run's own) of every
    /// incidence angle on `surface` (as every realisation's);
    /// [`BrdfRun::trace_realisations`] with `surface` for each.
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

    /// Trace the photons `photons` (a range of photon indices that starts
    /// on a batch) of every incidence angle, the batches of realisation `r`
    /// ([`BrdfRun::realisation_batches`]) on `surfaces[r]`; `progress` is
    /// called with photons done. This is the micro level's one transport
    /// entry point: each leaf of the result has the complete nodes of the
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

    /// [`BrdfRun::trace`] of the run's own photons ([`BrdfRun::photon_range`]).
    pub fn trace_whole(
        &self,
        surface: &MicroSurface,
        progress: &(dyn Fn(u64) + Sync),
    ) -> BrdfResult {
        self.trace(surface, self.photon_range(), progress)
    }

    /// The photon indices this run traces of every incidence: its shard's,
    /// or all `0..photons`.
    #[must_use]
    pub fn photon_range(&self) -> std::ops::Range<u64> {
        self.shard
            .map_or(0..self.photons, |s| s.first_photon..s.last_photon)
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
            Symmetry::None => (cells, share),
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
        // The (cell, share) pairs the weight is scored into.
        let mut hits = [(0, 0.0); 8];
        let mut n_hits = 0;
        for (cs, share) in shares.iter().filter(|h| h.1 != 0.0) {
            for &c in cs.as_slice() {
                hits[n_hits] = (c, *share);
                n_hits += 1;
            }
        }
        Bins {
            shares,
            hits,
            n_hits,
            inplane: inplane.locate(out),
            bounces: (bounces as usize).min(BOUNCE_BINS - 1),
        }
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

    /// Trace this run's photons carrying `C` (see [`super::carrier`]),
    /// with `ordered` in the Morton order of their entry points
    /// ([`super::parallel_batches_ordered`]), else in index order, and hand each batch's
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
        let entry = |n: u64| {
            let g = first + n;
            let mut rng = photon_rng(seed, g);
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
        // A history and the intersection tests it took.
        let history = |e: &Entry, scratch: &mut Scratch| {
            let start = DVec3::new(e.u * surface.size.x, e.v * surface.size.y, surface.top);
            let mut rng = e.rng.clone();
            let tests = scratch.tests;
            let h = trace(
                surface,
                start,
                dir,
                launch,
                &self.controls,
                &mut rng,
                scratch,
            );
            (h, scratch.tests - tests)
        };
        if !ordered {
            // A small surface stays in the caches in any order: trace and
            // score each photon in turn, batch by batch.
            let batch = |range: std::ops::Range<u64>| {
                let mut scratch = Scratch::new(surface);
                self.score_batch(locator, inplane, phi, spare, |score| {
                    for n in range {
                        let e = entry(n);
                        let (h, tests) = history(&e, &mut scratch);
                        score(e.replicate, &h, tests);
                    }
                })
            };
            return super::parallel_batches(last - first, tally_bytes, batch, consume, progress);
        }
        super::parallel_batches_ordered(
            last - first,
            tally_bytes,
            |n| {
                let e = entry(n);
                (order::morton(e.u, e.v), e)
            },
            || Scratch::new(surface),
            history,
            |_, visit| {
                self.score_batch(locator, inplane, phi, spare, |score| {
                    visit(&mut |e, (h, tests)| score(e.replicate, h, *tests));
                })
            },
            consume,
            progress,
        );
    }

    /// The tally of a batch from its photons' lattice replicates, histories
    /// and the intersection tests each took, in photon index order, at the
    /// light azimuth `phi` (radians: the plane of incidence of the mirror
    /// and the polarisation frames):
    /// `photons(score)` calls `score(replicate, history, tests)` for each
    /// (by reference: a spectral carrier is large).
    fn score_batch<C: Carrier>(
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
        let mut score = |replicate: usize, h: &History<C>, tests: u64| {
            score_counts(&mut lanes[0], h, tests);
            // By reference: a spectral carrier is large.
            match &h.fate {
                Fate::Escaped {
                    dir: out,
                    weight: carried,
                } => {
                    let bins = self.filter(locator, inplane, *out, h.bounces, sin_cos_phi);
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
                        let carried = carried.lane(l);
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

/// Where an escaping photon is scored: the filters of
/// [`BrdfRun::filter`].
struct Bins {
    /// Its Carlson cells and their shares of weight 1, as
    /// [`BrdfRun::cell_weights`] gives them (the mirrored half second).
    shares: [(crate::tally::carlson::Cells, f64); 2],
    /// The cells of `shares` with a non-zero share, flattened: `(cell, share)`.
    hits: [(usize, f64); 8],
    /// Entries of `hits` used.
    n_hits: usize,
    /// Its in-plane bin, if any.
    inplane: Option<usize>,
    /// Its reflection-count bin.
    bounces: usize,
}

impl Bins {
    /// The `(cell, share)` pairs scored.
    fn hits(&self) -> &[(usize, f64)] {
        &self.hits[..self.n_hits]
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
    for &(c, share) in bins.hits() {
        sums.carlson.score_scaled(c, share, w);
    }
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
        for &(c, share) in bins.hits() {
            t.carlson.score(c, share * weight);
        }
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
    // Factor of a component whose two halves share a bin.
    let both: [f64; K] = std::array::from_fn(|i| {
        if mirror && mirror_sign(K, i) < 0.0 {
            0.0
        } else {
            1.0
        }
    });
    let hemisphere: [f64; K] = std::array::from_fn(|i| both[i] * c[i]);
    p.score_slot(0, replicate, &hemisphere);
    // The first half is the photon's own cells, the second its mirror image
    // (weight 0: in the same cells as the first, which then has the whole weight).
    let same = halves[1].1 == 0.0;
    for (half, (cells, w)) in halves.iter().enumerate() {
        if *w == 0.0 {
            continue;
        }
        let signs: [f64; K] = match (half, same) {
            (1, _) => std::array::from_fn(|i| mirror_sign(K, i)),
            (_, true) => both,
            _ => [1.0; K],
        };
        let values: [f64; K] = std::array::from_fn(|i| signs[i] * w * c[i]);
        for &cell in cells.as_slice() {
            p.score_slot(1 + cell, replicate, &values);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::micro::{DEFAULT_SCENE, MicroScene};

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

    /// Tracing in Morton order and in index order gives the same tallies,
    /// bit for bit, for the scalar weight, Stokes vectors and Mueller
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
            let nodes = |ordered| {
                run.run_nodes_in(&scene.surface, 60.0, 0, 0..run.photons, ordered, &|_| {})
            };
            let (by_index, by_morton) = (nodes(false), nodes(true));
            assert!(by_index[0][0].value.photons > 0);
            assert_eq!(by_index, by_morton, "{tally:?} {launch:?} {symmetry:?}");
        }
    }
}
