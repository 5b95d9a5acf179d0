//! Scene key names of a run's fields ([`RunField`]): where a micro scene
//! holds each field of a [`BrdfRun`] (`light.theta_deg[1]`) and where its
//! serialised form does (`theta_deg[1]`), for the one-line messages that
//! name the key at fault. Transport checks a run and says which check
//! failed ([`RunError`], [`PolarisationError`]); this module names the key.

#[cfg(doc)]
use crate::transport::brdf::BrdfRun;
use crate::transport::brdf::{PolarisationError, RunError};

/// A checked field of a [`BrdfRun`] ([`BrdfRun::check`]), with its index
/// in a list where it has one: the field at fault of a [`RunError`]
/// ([`RunField::of`]) or of a [`PolarisationError`] ([`RunField::from`]).
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

    /// The field at fault of `e`, with the index of the angle or wavelength.
    #[must_use]
    pub fn of(e: &RunError) -> Self {
        match e {
            RunError::Incidence(e) => Self::ThetaDeg(e.index()),
            RunError::PhiDeg(e) => Self::PhiDeg(e.index()),
            RunError::Wavelengths(e) => Self::WavelengthsUm(e.index()),
            RunError::Photons(_) => Self::Photons,
            RunError::Realisations { .. } => Self::Realisations,
            RunError::Bands(_) => Self::Bands,
            RunError::InplaneStep(_) => Self::InplaneStepDeg,
            RunError::InplaneWidth(_) => Self::InplaneWidthDeg,
            RunError::MaxBounces => Self::MaxBounces,
            RunError::MaxSegments => Self::MaxSegments,
            RunError::RouletteWeight => Self::RouletteWeight,
            RunError::Incident(_) => Self::Incident,
            RunError::PolarTally => Self::PolarTally,
            RunError::Symmetry => Self::Symmetry,
        }
    }
}

impl From<&PolarisationError> for RunField {
    /// The micro scene key at fault: `tally.polarisation` for a tally
    /// without polarised transport, `tally.symmetry` for a mirror that
    /// changes the incident state.
    fn from(e: &PolarisationError) -> Self {
        match e {
            PolarisationError::TallyWithoutTransport(_) => Self::PolarTally,
            PolarisationError::MirrorChangesIncident(_) => Self::Symmetry,
        }
    }
}

/// `key[i]`, or `key` without an index.
fn with_index(key: &str, index: Option<usize>) -> String {
    match index {
        Some(i) => format!("{key}[{i}]"),
        None => key.to_owned(),
    }
}
