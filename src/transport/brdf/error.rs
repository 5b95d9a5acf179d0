//! Why a run description is refused: [`RunError`] and the errors of its
//! parts (incidence angles, light azimuths, polarisation settings).

#[cfg(doc)]
use super::{Azimuths, BrdfRun, Polarisation, check_incidence};
use crate::num::Num;
use crate::tally::sum::BATCH;

use crate::optics::polarisation::{Incident, IncidentError};
use crate::optics::spectrum::WavelengthListError;
use crate::tally::PolarTally;
use crate::tally::inplane::WidthError;
use crate::transport::launch::PhotonsError;

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

/// Why a scene's polarisation keys do not make a run
/// ([`Polarisation::resolve`]); the scene names the key at fault
/// ([`RunField`](crate::scene::keys::RunField)).
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

/// The name of `tally` in a scene and on the command line (`stokes`).
pub(super) fn polar_tally_name(tally: PolarTally) -> String {
    clap::ValueEnum::to_possible_value(&tally)
        .expect("no variant is skipped")
        .get_name()
        .to_owned()
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
/// failed, with the values it concerns. Its variant is the field at
/// fault; the scene names its key
/// ([`RunField::of`](crate::scene::keys::RunField::of)).
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
