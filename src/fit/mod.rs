//! Fitting a micro scene to a measured in-plane BRDF (`roks fit`).
//!
//! The paper (Klass et al. 2014, validation 3) fitted the Z-302 micro geometry
//! so that the computed BRDF of a flat Z-302 layer matched measured BRDFs at
//! 30 and 60 degrees incidence. This module does that for any micro scene:
//! it adjusts chosen numbers of the scene file until the scene's in-plane
//! BRDF matches a measured one.
//!
//! # Inputs
//! * The micro scene as TOML text, with its [`SceneFile`](crate::scene::SceneFile) (file name for
//!   messages, folder for relative paths such as reflectance tables).
//! * The measured in-plane BRDF ([`Measured`]): a CSV with the header
//!   `theta_i_deg,theta_o_deg,brdf` and optionally a fourth column
//!   `brdf_stderr`; `theta_o_deg` is signed exactly like roks's own
//!   `inplane.csv` (positive on the specular side, negative toward the light),
//!   so an `inplane.csv` is itself a valid measured file. A measurement at
//!   several light azimuths has the column `phi_i_deg` (degrees, in
//!   `[0, 360)`) after `theta_i_deg`, as `inplane.csv` of a run of several
//!   azimuths has; without it the scene must trace one azimuth (its
//!   `[light] phi_deg`), since nothing says which azimuth a row was
//!   measured at.
//! * The parameters ([`FitParam`], written `key=lo:hi`): TOML key paths into
//!   the scene with bounds, e.g. `bumps[0].radius=1:4`,
//!   `materials.z302.n=1:3`, `materials.z302.k=0:1`. A key whose value is a
//!   range `[lo, hi]` is fitted one end at a time, `bumps[0].height[1]=0.5:5`
//!   (a whole range cannot be one parameter: fix it to `[h, h]` to fit a
//!   single height). Keys are bare TOML keys (`A-Z a-z 0-9 _ -`) joined by
//!   `.` with `[i]` array indices.
//!
//! # Method
//! 1. **Model.** The parameter values are written into the parsed TOML table
//!    (as floats), and the scene is rebuilt from the table's text with
//!    [`MicroScene::from_str`](crate::scene::micro::MicroScene::from_str), so every check of the scene file applies. The
//!    scene's [`BrdfRun`](crate::transport::brdf::BrdfRun) is run at only the
//!    distinct measured incidence angles (and, with a `phi_i_deg` column,
//!    the distinct measured light azimuths, every angle at every azimuth;
//!    each row is compared with the curve of its own incidence and
//!    azimuth), with [`FitOptions::photons`] photons
//!    and the **fixed** seed [`FitOptions::seed`]. The in-plane BRDF of each
//!    bin is `inplane.mean(bin, n) / projected_solid_angle(bin)`, and the
//!    model value at a measured `theta_o` is the linear interpolation between
//!    the two nearest bin centres (beyond the outermost centres, the outermost
//!    bin's value). The in-plane bins are the scene's `[tally]
//!    inplane_step_deg` and `inplane_width_deg`, unless
//!    [`FitOptions::inplane_step_deg`] / [`FitOptions::inplane_width_deg`]
//!    override them. **The bins must hold enough photons**: the misfit is
//!    only useful where the model noise is small against the change being
//!    fitted. With 30 000 photons per angle, 1 degree x 1 degree bins hold a
//!    few photons each and the misfit of a 20-bump test scene is pure noise
//!    0.01 away from the true height; 5 degree x 10 degree bins (~100 photons
//!    each) give a misfit that falls steadily to 0 at the truth. Raise the
//!    photons (cost linear) or widen the bins (cost: angular resolution, and
//!    the detector then averages out of the plane), and compare like with
//!    like: the measurement's own detector size is the natural choice.
//! 2. **Common random numbers.** With the seed fixed, photon `n` starts at the
//!    same point with the same random stream at every parameter value, so
//!    the misfit changes only through the geometry and the materials: it is a
//!    (piecewise) smooth function of the parameters instead of a fresh
//!    Monte Carlo draw at every evaluation, and a direct search can converge
//!    on it. The fitted values are then the best values *for this sample of
//!    photons*; their Monte Carlo uncertainty can be judged by refitting with
//!    other seeds.
//! 3. **Misfit.** The mean over the measured points of
//!    `(ln(model + eps) - ln(measured + eps))^2`, `eps = 1e-3 * max measured
//!    BRDF`. BRDFs span decades (a specular peak over a diffuse floor); a
//!    linear least-squares misfit would fit the peak and ignore the rest. The
//!    log weighs relative errors equally everywhere; `eps` keeps empty model
//!    bins and zero measurements finite and stops values 1000 times below the
//!    peak (mostly noise) from dominating. The measured `brdf_stderr` is
//!    read but not used as a weight.
//!
//!    **Values the scene rejects** (a reversed range `lo > hi`, `cap > 1`,
//!    `n <= 0`, a radius of 0, ...). Before any photon is traced, the scene
//!    is built at the start point and at both bounds of every parameter
//!    (the others at their start values); a rejection there is an error
//!    naming `--param`, the key and the scene's reason, since the bounds
//!    themselves are wrong. Points the search can still meet are
//!    combinations (two ends of one range crossing): they have an infinite
//!    misfit and are recorded with the scene's reason in
//!    [`FitResult::rejected`] (in `fit.json`: `"misfit": null` beside
//!    `"rejected": reason`), a constraint of the search, not a failure.
//! 4. **Search.** Nelder-Mead (reflection 1, expansion 2, contraction 1/2,
//!    shrink 1/2) in the unit cube: parameter `j` is `lo_j + x_j (hi_j -
//!    lo_j)`. Simplex vertices may leave the cube; the model is evaluated at
//!    the clamped point and the squared distance outside the cube is added as
//!    a penalty, which keeps the simplex from collapsing onto a face and
//!    pulls it back. The start is the scene's current values, clamped into
//!    the bounds; the initial simplex steps each coordinate by 10 % of its
//!    range (away from the nearer bound). The search stops when the spread of
//!    the misfit over the simplex is at most [`FitOptions::tolerance`] and the
//!    simplex fits in a box of [`FitOptions::x_tolerance`] (in units of each
//!    range), or after [`FitOptions::max_evaluations`] model runs. Repeated
//!    points are not rerun. [`FitResult::at_bounds`] flags parameters that
//!    ended on a bound, within `x_tolerance` (the optimum may lie beyond it).
//!
//! # Limitations
//! * Only numbers can be fitted; integer keys (`count`, `seed`) are written
//!   as floats and the scene rejects them.
//! * The fitted scene text ([`Problem::apply`]) is re-serialised from the
//!   TOML table: comments and formatting of the original file are lost.
//! * The misfit is piecewise constant on a fine scale (a photon changes bin
//!   or bounce count discontinuously). Nelder-Mead copes, but gradients would
//!   not; the minimum found is local.

use thiserror::Error;

use crate::scene::SceneError;

mod measured;
mod params;
mod problem;
mod run;
mod search;

pub use measured::Measured;
pub use params::{BoundsError, FitParam, KeyError, KeyPath, KeyPathError, Segment};
pub use problem::{
    Bound, FitOptions, FitResult, Infeasible, Observer, Problem, fit, misfit, reason,
};
pub use run::{Inputs, Outcome, Prepared, evaluation_line};

/// Why a fit cannot run. Every message is one line naming the file, the
/// `roks fit` option (`--param`, `--photons`, ...) and the scene key.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    /// The scene file is invalid (at its current values).
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// A parameter key path does not lead to a number in the scene.
    #[error("{file}: --param {key}: {message}")]
    Key {
        /// Scene file.
        file: String,
        /// The key path as given.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A parameter specification `key=lo:hi` is malformed.
    #[error("--param {spec}: {message}")]
    Param {
        /// The specification as given.
        spec: String,
        /// What is wrong.
        message: String,
    },
    /// The measured BRDF file is malformed.
    #[error("{file}: line {line}: {message}")]
    Measured {
        /// Measured file name.
        file: String,
        /// Line number (1-based; 0: the file as a whole).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A parameter's bounds (or the start point) reach values the scene
    /// rejects: found before the fit by building the scene at both bounds of
    /// every parameter (the others at their start values) and at the start.
    #[error("{file}: --param {spec}: {at}, the scene is invalid: {reason}")]
    Infeasible {
        /// Scene file.
        file: String,
        /// The parameter as given, `key=lo:hi`, or all of them for the start.
        spec: String,
        /// Where, e.g. `at bumps[0].radius = 0`.
        at: String,
        /// The scene's objection: key and message (see [`reason`]).
        reason: String,
    },
    /// A file cannot be read.
    #[error("{file}: cannot read: {message}")]
    Read {
        /// The file as given.
        file: String,
        /// Why.
        message: String,
    },
    /// A bad fit option.
    #[error("{option}: {message}")]
    Options {
        /// The `roks fit` command-line option that sets it, e.g. `--photons`.
        option: String,
        /// What is wrong.
        message: String,
    },
}
