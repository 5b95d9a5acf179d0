//! Micro scenes: a rough surface for `roks brdf` and `roks stats`.
//!
//! ```toml
//! name = "default"          # optional; output goes to out/<name>/ (default: file stem)
//!
//! [surface]
//! size = [30.0, 30.0]       # period Lx, Ly (relative units)
//! edges = "periodic"        # "periodic" | "absorbing" | "reflecting"
//! material = "paint"        # substrate (and reflecting walls)
//! # heightfield = { gaussian = { sigma = 1.0, tau = 11.9 }, resolution = 1024, seed = 3 }
//! # heightfield = { file = "sample.exr", pixel = 0.5 }   # instead of substrate and bumps;
//! #                         # see HeightFieldSpec (EXR, 16-bit PNG + height_scale, text)
//!
//! [materials.paint]
//! reflectance = 0.8         # or n = .., k = ..; or table = "r.csv"
//!
//! [[bumps]]                 # a random population; several tables allowed
//! shape = "ellipsoid"       # ellipsoid | ellipsoid_on_hyperboloid | paraboloid | cone | cylinder
//! count = 100
//! radius = [2.5, 3.5]       # x semi-axis (waist for ellipsoid_on_hyperboloid): value or range
//! # radius_y = [2.5, 3.5]   # y semi-axis (default: equal to radius)
//! height = [1.5, 3.0]       # top above the substrate
//! # depth = 0.0             # ellipsoid: centre depth below the substrate
//! # cap = 0.5               # ellipsoid_on_hyperboloid: fraction of the height in the cap
//! # base = 1.5              # ellipsoid_on_hyperboloid: radius at the substrate / waist
//! seed = 1                  # geometry seed of this population
//! # material = "paint"      # default: the surface material
//!
//! [quadrics]                # named surfaces for explicit bodies (see scene::QuadricSpec)
//! left = { plane = [-1.0, 0.0, 1.0, 0.0] }
//!
//! [[bodies]]
//! region = "-left -right"   # OpenMC region syntax over [quadrics]
//! # material = "paint"
//!
//! [light]
//! theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]
//! phi_deg = 0.0             # omega_i = (sin t cos p, sin t sin p, cos t) points to the light;
//!                           # or a list of light azimuths in [0, 360): [0, 45, 90]
//! photons = 1000000         # per incidence angle (and light azimuth)
//! seed = 1                  # tracing seed
//! launch = "random"         # entry points: "random" or "lattice" (replicated R2 lattice)
//! polarisation = "unpolarised"  # incident state: "s", "p", "right", "left", { linear = 30 },
//!                           # or [S0, S1, S2, S3]; frame: the s axis of the plane of incidence
//!
//! [tally]
//! bands = 32                # Carlson grid bands
//! inplane_step_deg = 1.0    # in-plane bin width
//! inplane_width_deg = 1.0   # in-plane detector full width out of the plane
//! symmetry = "none"         # "mirror": fold mirror images in the plane of incidence
//! polarisation = "none"     # "stokes": stokes.csv; "mueller": mueller.csv (Mueller-matrix BRDF)
//!
//! [transport]
//! max_bounces = 100000      # bounce cap (cut photons are reported as lost)
//! roulette_weight = 0.01    # Russian roulette below this weight (survival weight 10x)
//! polarisation = true       # default: true with a Fresnel material (Stokes vectors through
//!                           # every bounce); false: the unpolarised weight (Rs + Rp)/2 per bounce
//! ```
//!
//! Limits checked where the scene is built ([`MicroSceneSpec::build`]): every
//! non-zero length (period sides, bump radii, heights and depths, `radius *
//! base`, a map's pixel, the period it makes and its scaled heights, a Gaussian
//! field's `sigma` and `tau`) lies in [`MIN_LENGTH`, `MAX_LENGTH`] =
//! `[1e-30, 1e30]`; no height (a bump's, an explicit body's top, a height
//! field's range) exceeds [`MAX_ASPECT`] = `1e9` times the period's shorter
//! side; a Gaussian field's `tau` is at most the period's longer side; at
//! most [`crate::transport::launch::MAX_PHOTONS`] = 2^53 photons per angle.

use super::keys::RunField;
use crate::num::Num;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::Deserialize;

use super::{
    Content, MaterialSpec, PolarisationSpec, QuadricSpec, Range, SceneError, SceneFile,
    WavelengthsSpec, build_materials, material_index, parse_toml,
};
use crate::geometry::body::{Body, Ray};
use crate::geometry::quadric::Quadric;
use crate::micro::bumps::{Bump, Shape};
use crate::micro::heightfield::HeightField;
use crate::micro::heightfield_io::{self, Format};
use crate::micro::{Edges, MicroSurface, Placed};
use crate::optics::material::Reflectance;
use crate::optics::polarisation::Incident;
use crate::tally::{CarlsonGrid, PolarTally, Symmetry};
use crate::transport::brdf::{Azimuths, BrdfRun, Polarisation};
use crate::transport::launch::Launch;
use crate::transport::micro::Controls;

/// The embedded default scene (also `scenes/default.toml`).
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/default.toml");

/// Largest length a micro scene may hold (scene length units): period sides,
/// bump radii, heights and depths, a map's pixel and its scaled heights, a
/// Gaussian field's `sigma` and `tau`, and the sizes and heights derived
/// from them. With every non-zero length in [`MIN_LENGTH`, `MAX_LENGTH`],
/// their squares, reciprocals and ratios (quadric coefficients, slopes,
/// normals) stay finite and normal in `f64`, and heights stay normal `f32`
/// numbers in the EXR and PLY exports and the Gaussian synthesis.
pub const MAX_LENGTH: f64 = 1e30;

/// Smallest non-zero length a micro scene may hold (see [`MAX_LENGTH`]).
pub const MIN_LENGTH: f64 = 1e-30;

/// Largest height of a micro surface (bump heights, an explicit body's top,
/// a height field's range) in units of the period's shorter side. Higher, a
/// position near the top no longer resolves the period (`f64` spacing of
/// `1e9 L` is `2e-7 L`), and flights cross ever more periods
/// ([`crate::micro::MAX_CROSSINGS`]) between events.
pub const MAX_ASPECT: f64 = 1e9;

/// A length of a micro scene that roks cannot trace (a height too large
/// for its period, or a length out of range); the caller names the key.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum LengthError {
    /// A height more than [`MAX_ASPECT`] times the period's shorter side.
    #[error(
        "a height of {height:e} is more than {MAX_ASPECT:e} times the cell's shorter side {}: positions that high do not resolve the cell",
        Num(*side)
    )]
    Aspect {
        /// The height (scene length units).
        height: f64,
        /// The period's shorter side (scene length units).
        side: f64,
    },
    /// A non-zero length outside [`MIN_LENGTH`, `MAX_LENGTH`].
    #[error(
        "{0:e} is outside the lengths roks traces, [{MIN_LENGTH:e}, {MAX_LENGTH:e}] (scene length units)"
    )]
    Range(f64),
}

/// [`LengthError::Aspect`] when `height` exceeds [`MAX_ASPECT`] times the shorter side of `size`.
fn aspect_bound(height: f64, size: DVec2) -> Result<(), LengthError> {
    let side = size.min_element();
    if height > MAX_ASPECT * side {
        return Err(LengthError::Aspect { height, side });
    }
    Ok(())
}

/// [`LengthError::Range`] when the non-zero length `v` lies outside
/// [`MIN_LENGTH`, `MAX_LENGTH`] (checked after the key's own sign rule).
fn length_bounds(v: f64) -> Result<(), LengthError> {
    if v != 0.0 && !(MIN_LENGTH..=MAX_LENGTH).contains(&v.abs()) {
        return Err(LengthError::Range(v));
    }
    Ok(())
}

/// The micro scene as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MicroSceneSpec {
    /// Scene name (output folder); default: file stem.
    pub name: Option<String>,
    /// The substrate period.
    pub surface: SurfaceSpec,
    /// Named materials.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Random bump populations.
    #[serde(default)]
    pub bumps: Vec<BumpSpec>,
    /// Named surfaces for explicit bodies.
    #[serde(default)]
    pub quadrics: BTreeMap<String, QuadricSpec>,
    /// Explicit bodies.
    #[serde(default)]
    pub bodies: Vec<BodySpec>,
    /// Illumination.
    #[serde(default)]
    pub light: LightSpec,
    /// Tallies.
    #[serde(default)]
    pub tally: TallySpec,
    /// Transport controls.
    #[serde(default)]
    pub transport: TransportSpec,
}

/// `[surface]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceSpec {
    /// Period size `[Lx, Ly]` (may be omitted for a height-field file with `pixel`).
    pub size: Option<[f64; 2]>,
    /// Side behaviour (default periodic).
    #[serde(default = "default_edges")]
    pub edges: EdgesSpec,
    /// Substrate material name (the height field's material).
    pub material: String,
    /// A height field replacing substrate, bumps and bodies.
    pub heightfield: Option<HeightFieldSpec>,
    /// Surface realisations of a random surface (a Gaussian field, random
    /// bumps): realisation `r` is drawn from the geometry seeds
    /// [`realisation_seed`]`(seed, r)` and traces its block of every
    /// incidence's batches ([`BrdfRun::realisation_batches`]); default 1.
    pub realisations: Option<u64>,
}

/// The geometry seed of realisation `r` of a random surface whose scene
/// gives geometry seed `seed` (a Gaussian field's `seed`, each bump table's
/// `seed`): `seed + r * 0x9E3779B97F4A7C15` (mod 2^64, the odd constant
/// of Fibonacci hashing), so realisation 0 is the scene's own surface and
/// the seeds of different realisations and tables (1, 2, 3, ... by default)
/// do not meet for any practical number of realisations.
#[must_use]
pub fn realisation_seed(seed: u64, r: u64) -> u64 {
    seed.wrapping_add(r.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// `[surface] heightfield`: a Gaussian random surface or a measured map.
///
/// ```toml
/// heightfield = { gaussian = { sigma = 1.0, tau = 11.9 }, resolution = 1024, seed = 3 }
/// heightfield = { file = "sample.exr", pixel = 0.5 }              # EXR (channel Y or the first)
/// heightfield = { file = "sample.png", pixel = 0.5, height_scale = 1e-4 }  # 16-bit PNG
/// heightfield = { file = "sample.txt", pixel = 0.5 }              # text grid
/// ```
///
/// * `gaussian`: `sigma` (RMS height) and `tau` (autocorrelation length:
///   `C(r) = sigma² exp(-r² / tau²)`), length units; needs `[surface] size`;
///   `resolution`: grid squares per side, `N` or `[Nx, Ny]` (2..=16384, and
///   within the memory limit of [`crate::limits`]: about 60 bytes a vertex
///   with the statistics, so 16384 x 16384 takes about 15 GiB);
///   `seed` (default 1). See [`HeightField::gaussian`].
/// * `file`: path relative to the scene file; the format by extension (see
///   [`crate::micro::heightfield_io`]); row `j` is `y = j pixel`. `pixel`:
///   grid pitch (length units); the period is `nx pixel x ny pixel`. With
///   `pixel` omitted, `[surface] size` gives the period; with both, they must
///   agree (to 1e-9). `height_scale`: length units per file unit (required
///   for PNG, whose heights are counts 0..=65535; default 1 otherwise).
///
/// The field is periodic (`edges = "periodic"`), of the surface material,
/// and cannot be combined with `[[bumps]]`, `[[bodies]]` or `[quadrics]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightFieldSpec {
    /// Gaussian random surface statistics.
    pub gaussian: Option<GaussianSpec>,
    /// Gaussian: grid squares per side.
    pub resolution: Option<Resolution>,
    /// Gaussian: synthesis seed (default 1).
    pub seed: Option<u64>,
    /// Measured map file.
    pub file: Option<String>,
    /// File: grid pitch (length units).
    pub pixel: Option<f64>,
    /// File: length units per file height unit.
    pub height_scale: Option<f64>,
    /// The heights given as an array in place of `file`'s
    /// ([`MicroScene::from_str_map`]); `file` then names it in messages.
    #[serde(skip)]
    pub array: Option<heightfield_io::HeightGrid>,
}

/// The name of a height map given as an array
/// ([`MicroScene::from_str_map`]) in messages: `surface.heightfield.file`'s
/// value.
pub const HEIGHT_MAP_ARRAY: &str = "<height map array>";

/// A height map given as an array (the Python module's numpy array), laid
/// out as a height-map file is ([`crate::micro::heightfield_io`]): `nx` x
/// `ny` heights (length units), row-major, row `j` at `y = j pixel` and
/// column `i` at `x = i pixel`.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMapArray {
    /// The heights.
    pub grid: heightfield_io::HeightGrid,
    /// The grid pitch (length units): `surface.heightfield.pixel`.
    pub pixel: f64,
}

/// `gaussian = { sigma, tau }` (length units).
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussianSpec {
    /// RMS height.
    pub sigma: f64,
    /// Autocorrelation length (1/e of the correlation coefficient).
    pub tau: f64,
}

/// Grid squares per side: one number or `[nx, ny]`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(untagged)]
pub enum Resolution {
    /// Square grid.
    One(usize),
    /// `[nx, ny]`.
    Two([usize; 2]),
}

/// `edges` values.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum EdgesSpec {
    /// Tiled period.
    Periodic,
    /// Absorbing walls.
    Absorbing,
    /// Reflecting walls.
    Reflecting,
}

fn default_edges() -> EdgesSpec {
    EdgesSpec::Periodic
}

/// `[[bumps]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumpSpec {
    /// Shape.
    pub shape: Shape,
    /// Number of bumps (at most 10 million, and within the memory limit of
    /// [`crate::limits`]: about 3 KB a bump with its acceleration grid, more
    /// with periodic ghost copies of bumps wider than the period; so 10
    /// million take about 30 GiB).
    pub count: usize,
    /// x semi-axis (waist radius for `ellipsoid_on_hyperboloid`).
    pub radius: Range,
    /// y semi-axis; default equal to `radius` (circular).
    pub radius_y: Option<Range>,
    /// Top above the substrate.
    pub height: Range,
    /// Ellipsoid: centre depth below the substrate (default 0).
    pub depth: Option<Range>,
    /// Ellipsoid on hyperboloid: cap fraction of the height (default 0.5).
    pub cap: Option<Range>,
    /// Ellipsoid on hyperboloid: substrate radius / waist radius (default 1.5).
    pub base: Option<Range>,
    /// Geometry seed (default: 1 + table index).
    pub seed: Option<u64>,
    /// Material (default: the surface material).
    pub material: Option<String>,
}

/// `[[bodies]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// OpenMC region expression over `[quadrics]` names.
    pub region: String,
    /// Material (default: the surface material).
    pub material: Option<String>,
}

/// `[light]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Incidence angles from the normal (degrees, in [0, 90)).
    #[serde(default = "default_thetas")]
    pub theta_deg: Vec<f64>,
    /// Light azimuths (degrees): a number or a list, each in `[0, 360)`
    /// and given once; every incidence angle is traced at each.
    #[serde(default = "default_azimuths")]
    pub phi_deg: Azimuths,
    /// Photons per incidence angle.
    #[serde(default = "default_photons")]
    pub photons: u64,
    /// Tracing seed.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Entry points: `"random"` (default) or `"lattice"` (see
    /// [`crate::transport::launch`]; photons must then be a multiple of 16).
    #[serde(default)]
    pub launch: Launch,
    /// Incident polarisation state (default unpolarised), in the frame of
    /// the incident flight (see [`crate::optics::polarisation`]).
    pub polarisation: Option<PolarisationSpec>,
    /// Wavelengths (µm) of a spectral run, all carried by every photon
    /// (absent: monochrome).
    pub wavelengths_um: Option<WavelengthsSpec>,
}

impl LightSpec {
    /// Write `-0` as `0` in the incidence angles and light azimuths (the
    /// same direction): a run, its files and its picture names never say
    /// `-0` (`hemisphere_0deg_phi0.png`, not `..._phi-0.png`).
    pub fn zero_signs(&mut self) {
        for x in self.theta_deg.iter_mut().chain(self.phi_deg.0.iter_mut()) {
            // -0 + 0 = +0; every other value is unchanged.
            *x += 0.0;
        }
    }
}

/// The wavelengths of `[light] wavelengths_um` (`None`: a monochrome run,
/// none), expanded but not yet checked ([`BrdfRun::check`] does); an
/// empty list is refused at the key, not taken for a monochrome run.
fn run_wavelengths(
    scene_file: &SceneFile,
    spec: Option<&WavelengthsSpec>,
) -> Result<Vec<f64>, SceneError> {
    let Some(w) = spec else {
        return Ok(Vec::new());
    };
    let values = w
        .expand()
        .map_err(|e| scene_file.error("light.wavelengths_um", e))?;
    if values.is_empty() {
        return Err(scene_file.error(
            "light.wavelengths_um",
            crate::optics::spectrum::WavelengthListError::Empty,
        ));
    }
    Ok(values)
}

impl Default for LightSpec {
    fn default() -> Self {
        Self {
            theta_deg: default_thetas(),
            phi_deg: default_azimuths(),
            photons: default_photons(),
            seed: default_seed(),
            launch: Launch::Random,
            polarisation: None,
            wavelengths_um: None,
        }
    }
}

fn default_azimuths() -> Azimuths {
    Azimuths::one(0.0)
}
fn default_thetas() -> Vec<f64> {
    vec![0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0]
}
fn default_photons() -> u64 {
    1_000_000
}
fn default_seed() -> u64 {
    1
}

/// `[tally]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TallySpec {
    /// Carlson grid bands M.
    #[serde(default = "default_bands")]
    pub bands: usize,
    /// In-plane bin width (degrees).
    #[serde(default = "default_one")]
    pub inplane_step_deg: f64,
    /// In-plane detector full width out of the plane (degrees).
    #[serde(default = "default_one")]
    pub inplane_width_deg: f64,
    /// `"none"` (default) or `"mirror"`: fold mirror images in the plane of
    /// incidence (only for mirror-symmetric statistics; see
    /// [`crate::tally::symmetry`]).
    #[serde(default)]
    pub symmetry: Symmetry,
    /// `"none"` (default), `"stokes"` (`stokes.csv`) or `"mueller"`
    /// (`mueller.csv`); see [`crate::tally::polar`].
    #[serde(default)]
    pub polarisation: PolarTally,
}

impl Default for TallySpec {
    fn default() -> Self {
        Self {
            bands: default_bands(),
            inplane_step_deg: 1.0,
            inplane_width_deg: 1.0,
            symmetry: Symmetry::None,
            polarisation: PolarTally::None,
        }
    }
}

fn default_bands() -> usize {
    32
}
fn default_one() -> f64 {
    1.0
}

/// `[transport]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransportSpec {
    /// Most reflections per photon; cut photons are reported as lost.
    #[serde(default = "default_max_bounces")]
    pub max_bounces: u32,
    /// Russian roulette threshold weight.
    #[serde(default = "default_roulette")]
    pub roulette_weight: f64,
    /// Polarised transport: default on when a material is Fresnel.
    pub polarisation: Option<bool>,
}

impl Default for TransportSpec {
    fn default() -> Self {
        Self {
            max_bounces: default_max_bounces(),
            roulette_weight: default_roulette(),
            polarisation: None,
        }
    }
}

fn default_max_bounces() -> u32 {
    100_000
}
fn default_roulette() -> f64 {
    0.01
}

/// A micro scene ready to trace.
#[derive(Debug, Clone)]
pub struct MicroScene {
    /// Scene name.
    pub name: String,
    /// Where it came from.
    pub scene_file: SceneFile,
    /// The geometry and materials (of realisation 0).
    pub surface: MicroSurface,
    /// The further surface realisations `1..R` (`[surface] realisations`),
    /// each built once; empty for one.
    pub more_realisations: Vec<MicroSurface>,
    /// Whether the surface is drawn at random (a Gaussian height field or
    /// random bumps, no explicit bodies): one realisation of a random
    /// surface, which `[surface] realisations` averages.
    pub random: bool,
    /// Material names, in the order of `surface.materials`.
    pub material_names: Vec<String>,
    /// Illumination as written (with the overrides applied).
    pub light: LightSpec,
    /// The run this scene describes (`[light]`, `[tally]`, `[transport]`
    /// and the overrides it was built with), checked.
    pub run: BrdfRun,
    /// What the scene is made of: its text and the files it reads, hashed.
    pub content: Content,
    /// The files the scene reads, as reached from the working folder: the
    /// scene file itself (loaded from a file) and the files its content
    /// identity hashes ([`MicroSceneSpec::files`]: n, k tables, angle
    /// tables, height maps). No output may replace one
    /// ([`crate::outdir::check::check_kept`]).
    pub reads: Vec<PathBuf>,
}

/// The command line's overrides of a micro scene's run keys, laid over its
/// specification before it is built ([`MicroSceneSpec::build`]), so that
/// each value goes through the one check of the key it replaces. `None`:
/// the scene's own value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// `--photons`: `[light] photons`.
    pub photons: Option<u64>,
    /// `--seed`: `[light] seed`.
    pub seed: Option<u64>,
    /// `--theta`: `[light] theta_deg`.
    pub theta_deg: Option<Vec<f64>>,
    /// `--phi`: `[light] phi_deg`.
    pub phi_deg: Option<Vec<f64>>,
    /// `--wavelengths`: `[light] wavelengths_um`.
    pub wavelengths_um: Option<WavelengthsSpec>,
    /// `--launch`: `[light] launch`.
    pub launch: Option<Launch>,
    /// `--symmetry`: `[tally] symmetry`.
    pub symmetry: Option<Symmetry>,
    /// `--polarisation`: `[tally] polarisation`.
    pub polarisation_tally: Option<PolarTally>,
    /// `--no-polarisation` (`Some(false)`): `[transport] polarisation`.
    pub polarised_transport: Option<bool>,
}

impl Overrides {
    /// The scene keys these overrides replace, each with its option. A
    /// polarisation tally refused for want of polarised transport
    /// (`tally.polarisation`) is `--no-polarisation`'s doing when given.
    fn keys(&self) -> Vec<(&'static str, &'static str)> {
        [
            (
                self.polarised_transport == Some(false),
                "tally.polarisation",
                "--no-polarisation",
            ),
            (self.photons.is_some(), "light.photons", "--photons"),
            (self.seed.is_some(), "light.seed", "--seed"),
            (self.theta_deg.is_some(), "light.theta_deg", "--theta"),
            (self.phi_deg.is_some(), "light.phi_deg", "--phi"),
            (
                self.wavelengths_um.is_some(),
                "light.wavelengths_um",
                "--wavelengths",
            ),
            (self.launch.is_some(), "light.launch", "--launch"),
            (self.symmetry.is_some(), "tally.symmetry", "--symmetry"),
            (
                self.polarisation_tally.is_some(),
                "tally.polarisation",
                "--polarisation",
            ),
            (
                self.polarised_transport.is_some(),
                "transport.polarisation",
                "--no-polarisation",
            ),
        ]
        .into_iter()
        .filter_map(|(given, key, option)| given.then_some((key, option)))
        .collect()
    }

    /// Lay the overrides over `spec`.
    pub fn apply(&self, spec: &mut MicroSceneSpec) {
        let light = &mut spec.light;
        if let Some(p) = self.photons {
            light.photons = p;
        }
        if let Some(s) = self.seed {
            light.seed = s;
        }
        if let Some(t) = &self.theta_deg {
            light.theta_deg.clone_from(t);
        }
        if let Some(p) = &self.phi_deg {
            light.phi_deg = Azimuths(p.clone());
        }
        if let Some(w) = &self.wavelengths_um {
            light.wavelengths_um = Some(w.clone());
        }
        if let Some(l) = self.launch {
            light.launch = l;
        }
        if let Some(s) = self.symmetry {
            spec.tally.symmetry = s;
        }
        if let Some(p) = self.polarisation_tally {
            spec.tally.polarisation = p;
        }
        if let Some(t) = self.polarised_transport {
            spec.transport.polarisation = Some(t);
        }
    }

    /// `e` of a scene built with these overrides: at a key an option
    /// set, the option's error ([`super::option_error`]); else the scene
    /// file's.
    #[must_use]
    pub fn blame(&self, e: SceneError) -> BuildError {
        match super::option_error(&self.keys(), &e) {
            Some((option, message)) => BuildError::Option { option, message },
            None => BuildError::Scene(e),
        }
    }
}

/// Why a micro scene with command-line [`Overrides`] cannot be built: its
/// file (a key it set), or an option (a key the option set).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// The scene file's error, naming the file and the key.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// An option's value refused by the check of the key it replaces.
    #[error("{option}: {message}")]
    Option {
        /// The option (`--theta`, ...).
        option: &'static str,
        /// What is wrong.
        message: String,
    },
}

impl MicroScene {
    /// Whether a material of the surface is Fresnel (polarising).
    #[must_use]
    pub fn has_fresnel(&self) -> bool {
        any_fresnel(&self.surface.materials)
    }

    /// The surface of every realisation, realisation 0 first: the
    /// relief the batches of each realisation's block are traced on
    /// ([`BrdfRun::trace_realisations`]).
    #[must_use]
    pub fn surfaces(&self) -> Vec<&MicroSurface> {
        std::iter::once(&self.surface)
            .chain(&self.more_realisations)
            .collect()
    }

    /// The BRDF run this scene describes (a copy of [`MicroScene::run`]).
    #[must_use]
    pub fn brdf_run(&self) -> BrdfRun {
        self.run.clone()
    }

    /// Load a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = super::read_scene_text(path)?;
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        let mut scene =
            Self::from_str(&text, SceneFile::from_path(path), name.unwrap_or_default())?;
        scene.reads.insert(0, path.to_path_buf());
        Ok(scene)
    }

    /// The files the scene file at `path` reads, as [`MicroScene::reads`]
    /// (without building it: a scene that does not parse reads itself only).
    #[must_use]
    pub fn reads_of(path: &Path) -> Vec<PathBuf> {
        let mut reads = vec![path.to_path_buf()];
        let scene_file = SceneFile::from_path(path);
        let spec = super::read_scene_text(path)
            .ok()
            .and_then(|text| parse_toml::<MicroSceneSpec>(&scene_file, &text).ok());
        if let Some(spec) = spec {
            reads.extend(scene_file.paths(&spec.files()));
        }
        reads
    }

    /// Load a scene file with `overrides` laid over its keys before it is
    /// built (its materials are sampled at overriding wavelengths).
    pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Self, BuildError> {
        Self::load_map(path, overrides, None)
    }

    /// [`MicroScene::load_with`] with a height map given as an array
    /// ([`MicroScene::from_str_map`]).
    pub fn load_map(
        path: &Path,
        overrides: &Overrides,
        map: Option<&HeightMapArray>,
    ) -> Result<Self, BuildError> {
        let text = super::read_scene_text(path)?;
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        let mut scene = Self::from_str_map(
            &text,
            SceneFile::from_path(path),
            name.unwrap_or_default(),
            overrides,
            map,
        )?;
        scene.reads.insert(0, path.to_path_buf());
        Ok(scene)
    }

    /// The embedded default scene.
    #[must_use]
    pub fn default_scene() -> Self {
        let scene_file = SceneFile {
            file: super::source::DEFAULT_SCENE.into(),
            dir: ".".into(),
        };
        Self::from_str(DEFAULT_SCENE, scene_file, "default".into())
            .expect("the default scene is valid")
    }

    /// Parse and build from TOML text.
    pub fn from_str(
        text: &str,
        scene_file: SceneFile,
        fallback_name: String,
    ) -> Result<Self, SceneError> {
        Self::from_str_with(text, scene_file, fallback_name, &Overrides::default()).map_err(|e| {
            match e {
                BuildError::Scene(e) => e,
                BuildError::Option { .. } => unreachable!("no overrides"),
            }
        })
    }

    /// [`MicroScene::from_str`] with `overrides` (see [`MicroScene::load_with`]).
    pub fn from_str_with(
        text: &str,
        scene_file: SceneFile,
        fallback_name: String,
        overrides: &Overrides,
    ) -> Result<Self, BuildError> {
        Self::from_str_map(text, scene_file, fallback_name, overrides, None)
    }

    /// [`MicroScene::from_str_with`], and with `map` (when given) as the
    /// surface's height field: `[surface] heightfield = { file, pixel }`
    /// with the heights of the array in place of the file's (file named
    /// [`HEIGHT_MAP_ARRAY`]), replacing the scene's own height field and
    /// checked exactly as such a key is (the grid, the cell it makes with
    /// `[surface] size`, and no `[[bumps]]`, `[[bodies]]` nor
    /// `[quadrics]` beside it). Its content hash
    /// (`surface.heightfield.file`) is that of the grid's dimensions and
    /// heights (little-endian `u64` nx, ny, then `f64` heights).
    pub fn from_str_map(
        text: &str,
        scene_file: SceneFile,
        fallback_name: String,
        overrides: &Overrides,
        map: Option<&HeightMapArray>,
    ) -> Result<Self, BuildError> {
        let mut spec: MicroSceneSpec = parse_toml(&scene_file, text)
            .map_err(|e| super::other_kind(text, "cells", e, "an object scene ([[cells]]): roks trace traces it; this command takes micro scenes ([surface])"))?;
        if *overrides != Overrides::default() {
            // The file's own run values, which the options replace, are
            // still the file's: checked (once) as written.
            let wavelengths = run_wavelengths(&scene_file, spec.light.wavelengths_um.as_ref())?;
            brdf_run_of(&spec, Polarisation::default(), wavelengths)
                .check()
                .map_err(|e| scene_file.error(RunField::of(&e).scene_key(), e))?;
        }
        overrides.apply(&mut spec);
        spec.light.zero_signs();
        if let Some(m) = map {
            spec.surface.heightfield = Some(HeightFieldSpec {
                gaussian: None,
                resolution: None,
                seed: None,
                file: Some(HEIGHT_MAP_ARRAY.into()),
                pixel: Some(m.pixel),
                height_scale: None,
                array: Some(m.grid.clone()),
            });
        }
        let files = spec.files();
        let mut scene = spec
            .build(scene_file, fallback_name)
            .map_err(|e| overrides.blame(e))?;
        scene.content = Content::of(&scene.scene_file, text, &files)?;
        if let Some(m) = map {
            scene
                .content
                .files
                .insert("surface.heightfield.file".into(), array_sha256(&m.grid));
        }
        scene.reads = scene.scene_file.paths(&files);
        Ok(scene)
    }

    /// The embedded default scene with `overrides`.
    pub fn default_with(overrides: &Overrides) -> Result<Self, BuildError> {
        Self::default_map(overrides, None)
    }

    /// The embedded default scene with `overrides` and a height map given
    /// as an array ([`MicroScene::from_str_map`]).
    pub fn default_map(
        overrides: &Overrides,
        map: Option<&HeightMapArray>,
    ) -> Result<Self, BuildError> {
        let scene_file = SceneFile {
            file: super::source::DEFAULT_SCENE.into(),
            dir: ".".into(),
        };
        Self::from_str_map(DEFAULT_SCENE, scene_file, "default".into(), overrides, map)
    }
}

impl MicroSceneSpec {
    /// The files the scene reads, `(key, path relative to the scene's
    /// folder)`: n, k tables, angle tables and a height map.
    #[must_use]
    pub fn files(&self) -> Vec<(String, String)> {
        let mut files = Vec::new();
        for (name, m) in &self.materials {
            files.extend(m.files(&format!("materials.{name}")));
        }
        if let Some(f) = self
            .surface
            .heightfield
            .as_ref()
            .filter(|h| h.array.is_none())
            .and_then(|h| h.file.as_ref())
        {
            files.push(("surface.heightfield.file".into(), f.clone()));
        }
        files
    }

    /// Check everything and build the scene (its [`MicroScene::content`]
    /// empty: [`MicroScene::from_str_with`] hashes it).
    pub fn build(
        self,
        scene_file: SceneFile,
        fallback_name: String,
    ) -> Result<MicroScene, SceneError> {
        let given_size = self
            .surface
            .size
            .map(|size| check_size(&scene_file, size))
            .transpose()?;
        let wavelengths_um = run_wavelengths(&scene_file, self.light.wavelengths_um.as_ref())?;
        // The run's values, checked here once (a merge checks a run read
        // back the same way); the polarisation, which needs the materials,
        // is resolved below.
        let mut run = brdf_run_of(&self, Polarisation::default(), wavelengths_um);
        run.check()
            .map_err(|e| scene_file.error(RunField::of(&e).scene_key(), e))?;
        let (names, materials) =
            build_materials(&scene_file, &self.materials, &run.wavelengths_um)?;
        let substrate = material_index(
            &scene_file,
            &names,
            &self.surface.material,
            "surface.material",
        )?;
        let edges = match self.surface.edges {
            EdgesSpec::Periodic => Edges::Periodic,
            EdgesSpec::Absorbing => Edges::Absorbing,
            EdgesSpec::Reflecting => Edges::Reflecting,
        };
        let field = self.height_field(&scene_file, given_size, edges)?;
        let size = match (given_size, &field) {
            (_, Some(f)) => f.size,
            (Some(size), None) => size,
            (None, None) => return Err(scene_file.error("surface.size", "missing")),
        };
        let (placed, bytes) = self.place_solids(&scene_file, &names, substrate, size, edges)?;
        let random = self.is_random();
        let more_realisations = self.more_realisations(
            &scene_file,
            (size, edges),
            (&materials, &names, substrate),
            field
                .as_ref()
                .map_or(bytes, |f| HeightField::memory_bytes(f.nx, f.ny)),
            run.realisations,
        )?;
        let (light, tally, transport) = (self.light, self.tally, self.transport);
        let incident = match &light.polarisation {
            Some(p) => p.build(&scene_file, "light.polarisation")?,
            None => Incident::Unpolarised,
        };
        run.polarisation = Polarisation::resolve(
            any_fresnel(&materials),
            transport.polarisation,
            incident,
            tally.polarisation,
            tally.symmetry,
        )
        .map_err(|e| scene_file.error(RunField::from(&e).scene_key(), e))?;

        let surface = match field {
            Some(field) => MicroSurface::from_height_field(field, materials, substrate),
            None => MicroSurface::new(size, edges, placed, materials, substrate),
        };
        let scene = MicroScene {
            name: super::scene_name(&scene_file, self.name, fallback_name)?,
            scene_file,
            surface,
            more_realisations,
            random,
            material_names: names,
            light,
            run,
            content: Content::default(),
            reads: Vec::new(),
        };
        scene.check_run_memory(&scene.run)?;
        Ok(scene)
    }

    /// The `surface.heightfield`, if given, built (over `given_size`, if
    /// given): refused with bumps, bodies or quadrics (the height field is
    /// the whole surface) and with edges other than periodic.
    fn height_field(
        &self,
        scene_file: &SceneFile,
        given_size: Option<DVec2>,
        edges: Edges,
    ) -> Result<Option<HeightField>, SceneError> {
        let Some(hf) = &self.surface.heightfield else {
            return Ok(None);
        };
        for (key, given) in [
            ("bumps", !self.bumps.is_empty()),
            ("bodies", !self.bodies.is_empty()),
            ("quadrics", !self.quadrics.is_empty()),
        ] {
            if given {
                return Err(scene_file.error(
                    key,
                    "cannot be combined with surface.heightfield (the height field is the whole surface)",
                ));
            }
        }
        if edges != Edges::Periodic {
            return Err(scene_file.error(
                "surface.edges",
                "a height field is periodic: edges must be \"periodic\"",
            ));
        }
        Some(hf.build(scene_file, given_size)).transpose()
    }

    /// The solids over a period of `size`: every `[[bumps]]` table's bumps
    /// placed, then the `[[bodies]]` over `[quadrics]` (material
    /// `substrate` unless given); with the estimated bytes of the bumps'
    /// surface (see `placed_cost`).
    fn place_solids(
        &self,
        scene_file: &SceneFile,
        names: &[String],
        substrate: usize,
        size: DVec2,
        edges: Edges,
    ) -> Result<(Vec<Placed>, u64), SceneError> {
        let mut placed = Vec::new();
        // Estimated bytes of the built surface so far (see `placed_cost`).
        let mut bytes = 0;
        for (t, spec) in self.bumps.iter().enumerate() {
            let material = match &spec.material {
                Some(m) => material_index(scene_file, names, m, &format!("bumps[{t}].material"))?,
                None => substrate,
            };
            placed.extend(spec.populate(scene_file, t, size, edges, material, &mut bytes)?);
        }

        let mut quadrics = BTreeMap::new();
        for (name, q) in &self.quadrics {
            quadrics.insert(
                name.clone(),
                q.build(scene_file, &format!("quadrics.{name}"))?,
            );
        }
        for (b, spec) in self.bodies.iter().enumerate() {
            let key = format!("bodies[{b}]");
            let material = match &spec.material {
                Some(m) => material_index(scene_file, names, m, &format!("{key}.material"))?,
                None => substrate,
            };
            placed.push(explicit_body(
                scene_file, &key, spec, &quadrics, size, material,
            )?);
        }
        Ok((placed, bytes))
    }

    /// Whether the surface is drawn at random (a generated height field or
    /// bump tables, and no explicit bodies).
    fn is_random(&self) -> bool {
        self.bodies.is_empty()
            && (self
                .surface
                .heightfield
                .as_ref()
                .is_some_and(|f| f.file.is_none())
                || !self.bumps.is_empty())
    }
}

impl MicroSceneSpec {
    /// The surfaces of realisations `1..count` of a random surface
    /// (`[surface] realisations`), from the geometry seeds
    /// [`realisation_seed`]: a Gaussian field's, or every bump table's
    /// (each table's own seed, default `1 + index`). Refused for a measured
    /// map, explicit bodies and a surface with nothing random, and when the
    /// `count` surfaces of about `bytes` each exceed the memory limit.
    fn more_realisations(
        &self,
        scene_file: &SceneFile,
        (size, edges): (DVec2, Edges),
        (materials, names, substrate): (&[Reflectance], &[String], usize),
        bytes: u64,
        count: u64,
    ) -> Result<Vec<MicroSurface>, SceneError> {
        if count <= 1 {
            return Ok(Vec::new());
        }
        let key = "surface.realisations";
        let one_surface = |what: &str| {
            Err(scene_file.error(
                key,
                format!(
                    "{what} is one surface: realisations apply to random surfaces (a gaussian height field, random bumps)"
                ),
            ))
        };
        let field = self.surface.heightfield.as_ref();
        if field.is_some_and(|f| f.file.is_some()) {
            return one_surface("a measured height map");
        }
        if !self.bodies.is_empty() {
            return one_surface("a surface with explicit bodies");
        }
        if field.is_none() && self.bumps.is_empty() {
            return one_surface("a flat substrate");
        }
        scene_file.check_memory(
            key,
            &format!("{count} surface realisations"),
            bytes.saturating_mul(count),
        )?;
        (1..count)
            .map(|r| {
                if let Some(f) = field {
                    let f = HeightFieldSpec {
                        seed: Some(realisation_seed(f.seed.unwrap_or(1), r)),
                        ..f.clone()
                    };
                    let field = f.build(scene_file, Some(size))?;
                    return Ok(MicroSurface::from_height_field(
                        field,
                        materials.to_vec(),
                        substrate,
                    ));
                }
                let mut placed = Vec::new();
                let mut bytes = 0;
                for (t, spec) in self.bumps.iter().enumerate() {
                    let material = match &spec.material {
                        Some(m) => {
                            material_index(scene_file, names, m, &format!("bumps[{t}].material"))?
                        }
                        None => substrate,
                    };
                    let spec = BumpSpec {
                        seed: Some(realisation_seed(spec.seed.unwrap_or(1 + t as u64), r)),
                        ..spec.clone()
                    };
                    placed.extend(spec.populate(scene_file, t, size, edges, material, &mut bytes)?);
                }
                Ok(MicroSurface::new(
                    size,
                    edges,
                    placed,
                    materials.to_vec(),
                    substrate,
                ))
            })
            .collect()
    }
}

impl MicroScene {
    /// Refuse `run` (this scene's, or with options applied) when its
    /// tallies and result tables ([`BrdfRun::memory_bytes`]) exceed the
    /// memory limit; the error names their main factor: `light.phi_deg`
    /// for several light azimuths (each multiplies every tally and table),
    /// else `tally.inplane_step_deg` when the in-plane bins outnumber the
    /// Carlson cells, else `tally.bands`.
    pub fn check_run_memory(&self, run: &BrdfRun) -> Result<(), SceneError> {
        let azimuths = run.phi_deg.len();
        let bins = run.inplane_bins();
        let cells = CarlsonGrid::new(run.bands).map_or(0, |g| g.n_cells()) as u64;
        let key = if azimuths > 1 {
            "light.phi_deg"
        } else if bins > cells {
            "tally.inplane_step_deg"
        } else {
            "tally.bands"
        };
        let what = format!(
            "the tallies and tables of {} Carlson bands for {} incidences{}{}{}{}",
            run.bands,
            run.theta_deg.len(),
            if azimuths > 1 {
                format!(" x {azimuths} light azimuths")
            } else {
                String::new()
            },
            if bins > cells {
                format!(" with {bins} in-plane bins each")
            } else {
                String::new()
            },
            match run.polarisation.tally {
                PolarTally::None => "",
                PolarTally::Stokes => " with Stokes sums",
                PolarTally::Mueller => " with Mueller sums",
            },
            if run.launch == Launch::Lattice {
                " and lattice replicates"
            } else {
                ""
            },
        );
        self.scene_file.check_memory(key, &what, run.memory_bytes())
    }
}

/// The BRDF run of a scene's `[light]`, `[tally]`, `[transport]` and
/// `[surface] realisations`.
fn brdf_run_of(
    spec: &MicroSceneSpec,
    polarisation: Polarisation,
    wavelengths_um: Vec<f64>,
) -> BrdfRun {
    let (light, tally, transport) = (&spec.light, &spec.tally, &spec.transport);
    BrdfRun {
        realisations: spec.surface.realisations.unwrap_or(1),
        theta_deg: light.theta_deg.clone(),
        phi_deg: light.phi_deg.clone(),
        photons: light.photons,
        shard: None,
        seed: light.seed,
        launch: light.launch,
        polarisation,
        wavelengths_um,
        bands: tally.bands,
        inplane_step_deg: tally.inplane_step_deg,
        inplane_width_deg: tally.inplane_width_deg,
        symmetry: tally.symmetry,
        kernel: crate::transport::wavefront::Kernel::default(),
        controls: Controls {
            max_bounces: transport.max_bounces,
            roulette_weight: transport.roulette_weight,
            ..Controls::default()
        },
    }
}

/// Whether any of `materials` is Fresnel (the only polarising model).
fn any_fresnel(materials: &[Reflectance]) -> bool {
    materials.iter().any(Reflectance::polarises)
}

/// A checked period size.
fn check_size(scene_file: &SceneFile, [lx, ly]: [f64; 2]) -> Result<DVec2, SceneError> {
    for (i, l) in [lx, ly].into_iter().enumerate() {
        if !(l.is_finite() && l > 0.0) {
            return Err(scene_file.error(
                format!("surface.size[{i}]"),
                format!("must be > 0, got {}", Num(l)),
            ));
        }
        length_bounds(l).map_err(|e| scene_file.error(format!("surface.size[{i}]"), e))?;
    }
    Ok(DVec2::new(lx, ly))
}

/// SHA-256 (lower-case hex) of a height map given as an array: its
/// dimensions and heights, little-endian (`u64` nx, ny; `f64` heights).
fn array_sha256(grid: &heightfield_io::HeightGrid) -> String {
    use sha2::Digest as _;
    let mut hasher = sha2::Sha256::new();
    hasher.update((grid.nx as u64).to_le_bytes());
    hasher.update((grid.ny as u64).to_le_bytes());
    for z in &grid.h {
        hasher.update(z.to_le_bytes());
    }
    hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

impl HeightFieldSpec {
    /// Synthesise or load the field; `size`: the checked `[surface] size`, if given.
    fn build(
        &self,
        scene_file: &SceneFile,
        size: Option<DVec2>,
    ) -> Result<HeightField, SceneError> {
        match (&self.gaussian, &self.file) {
            (Some(_), Some(_)) => Err(scene_file.error(
                "surface.heightfield",
                "give either gaussian or file, not both",
            )),
            (None, None) => Err(scene_file.error(
                "surface.heightfield",
                "needs gaussian = { sigma, tau } or file = \"...\"",
            )),
            (Some(g), None) => self.gaussian(scene_file, g, size),
            (None, Some(file)) => self.load_map(scene_file, file, size),
        }
    }

    /// The full key of `surface.heightfield.k`.
    fn key(k: &str) -> String {
        format!("surface.heightfield.{k}")
    }

    /// Refuse key `k`, `given` though it applies to `what` only.
    fn refuse(scene_file: &SceneFile, k: &str, given: bool, what: &str) -> Result<(), SceneError> {
        if given {
            Err(scene_file.error(Self::key(k), format!("applies to {what} only")))
        } else {
            Ok(())
        }
    }

    /// Length `v` of key `k`, checked > 0 and within the traced lengths.
    fn length(scene_file: &SceneFile, k: &str, v: f64) -> Result<f64, SceneError> {
        if !(v.is_finite() && v > 0.0) {
            return Err(scene_file.error(Self::key(k), format!("must be > 0, got {}", Num(v))));
        }
        length_bounds(v).map_err(|e| scene_file.error(Self::key(k), e))?;
        Ok(v)
    }

    /// Synthesise a Gaussian field `g` over the cell `size` (which it
    /// needs), checked: resolution, memory, and a correlation length
    /// between the grid pitch and the cell's longer side.
    fn gaussian(
        &self,
        scene_file: &SceneFile,
        g: &GaussianSpec,
        size: Option<DVec2>,
    ) -> Result<HeightField, SceneError> {
        let key = Self::key;
        Self::refuse(scene_file, "pixel", self.pixel.is_some(), "file maps")?;
        Self::refuse(
            scene_file,
            "height_scale",
            self.height_scale.is_some(),
            "file maps",
        )?;
        let size = size.ok_or_else(|| {
            scene_file.error(
                "surface.size",
                "missing (a gaussian height field needs the cell)",
            )
        })?;
        let (nx, ny) = match self.resolution {
            Some(Resolution::One(n)) => (n, n),
            Some(Resolution::Two([nx, ny])) => (nx, ny),
            None => return Err(scene_file.error(key("resolution"), "missing")),
        };
        if ![nx, ny].iter().all(|n| (2..=16384).contains(n)) {
            return Err(scene_file.error(
                key("resolution"),
                format!("must be in 2..=16384, got {nx} x {ny}"),
            ));
        }
        scene_file.check_memory(
            &key("resolution"),
            &format!("a {nx} x {ny} height field (heights, hierarchy, statistics)"),
            HeightField::memory_bytes(nx, ny),
        )?;
        let sigma = Self::length(scene_file, "gaussian.sigma", g.sigma)?;
        let tau = Self::length(scene_file, "gaussian.tau", g.tau)?;
        let pitch = (size.x / nx as f64).max(size.y / ny as f64);
        if tau < pitch {
            return Err(scene_file.error(
                key("gaussian.tau"),
                format!("{tau} is below the grid pitch {pitch}: raise the resolution"),
            ));
        }
        // The synthesis keeps the spectrum's modes of the period; for
        // tau beyond the period they vanish (the field would be one
        // sinusoid, or nothing once exp(-k² tau² / 8) underflows).
        let longest = size.max_element();
        if tau > longest {
            return Err(scene_file.error(
                key("gaussian.tau"),
                format!(
                    "{tau} exceeds the cell's longer side {longest}: a Gaussian field needs at least one correlation length in the cell"
                ),
            ));
        }
        let field = HeightField::gaussian(nx, ny, size, sigma, tau, self.seed.unwrap_or(1));
        check_field(scene_file, &field, &key("gaussian.sigma"))?;
        Ok(field)
    }

    /// Load the height map `file` (relative to the scene's folder), its
    /// memory checked before it is decoded, its heights scaled by
    /// `height_scale` and its cell from `size` or `pixel`.
    fn load_map(
        &self,
        scene_file: &SceneFile,
        file: &str,
        size: Option<DVec2>,
    ) -> Result<HeightField, SceneError> {
        let key = Self::key;
        Self::refuse(
            scene_file,
            "resolution",
            self.resolution.is_some(),
            "gaussian fields",
        )?;
        Self::refuse(scene_file, "seed", self.seed.is_some(), "gaussian fields")?;
        // An array is named as given, not as a path in the scene's folder.
        let path = match self.array {
            Some(_) => PathBuf::from(file),
            None => scene_file.dir.join(file),
        };
        let format = Format::of(&path);
        let scale = match self.height_scale {
            Some(s) => Self::length(scene_file, "height_scale", s)?,
            None if format == Format::Png => {
                return Err(scene_file.error(
                    key("height_scale"),
                    "missing: a PNG map holds counts 0..=65535; give the height of one count (length units)",
                ));
            }
            None => 1.0,
        };
        let file_error = |e: heightfield_io::HeightMapError| {
            scene_file.error(key("file"), format!("{}: {e}", path.display()))
        };
        // The memory from the header (or the text's length) before decoding.
        let check = |bytes: u64, (nx, ny): (usize, usize)| {
            let what = format!(
                "{}: a {nx} x {ny} height map (heights, hierarchy, statistics)",
                path.display()
            );
            scene_file.check_memory(&key("file"), &what, bytes)
        };
        let grid = if let Some(grid) = &self.array {
            heightfield_io::check(grid.clone()).map_err(file_error)?
        } else {
            let (read_bytes, declared) =
                heightfield_io::read_memory_bytes(&path).map_err(file_error)?;
            if let Some((nx, ny)) = declared {
                check(read_bytes.max(HeightField::memory_bytes(nx, ny)), (nx, ny))?;
            } else {
                let what = format!("{}: reading the text height map", path.display());
                scene_file.check_memory(&key("file"), &what, read_bytes)?;
            }
            heightfield_io::read(&path).map_err(file_error)?
        };
        let (nx, ny) = (grid.nx, grid.ny);
        check(HeightField::memory_bytes(nx, ny), (nx, ny))?;
        let size = self.map_size(scene_file, (nx, ny), size)?;
        // Scaled heights within the traced lengths, before the field
        // (which assumes finite heights) is built.
        let scale_key = if self.height_scale.is_some() {
            key("height_scale")
        } else {
            key("file")
        };
        let h: Vec<f64> = grid.h.into_iter().map(|z| z * scale).collect();
        if let Some(z) = h.iter().find(|z| z.is_nan() || z.abs() > MAX_LENGTH) {
            return Err(scene_file.error(
                scale_key,
                format!(
                    "{}: a height of {z:e} after scaling by {scale} is beyond the largest length {MAX_LENGTH:e}",
                    path.display()
                ),
            ));
        }
        let field = HeightField::new(nx, ny, size, h);
        check_field(scene_file, &field, &scale_key)?;
        Ok(field)
    }

    /// The cell of an `nx` x `ny` height map: `[surface] size` (`given`),
    /// or `pixel` times the pixels, or both when they agree.
    fn map_size(
        &self,
        scene_file: &SceneFile,
        (nx, ny): (usize, usize),
        given: Option<DVec2>,
    ) -> Result<DVec2, SceneError> {
        Ok(match (self.pixel, given) {
            (None, None) => {
                return Err(scene_file.error(
                    "surface.size",
                    "missing: give surface.size or surface.heightfield.pixel",
                ));
            }
            (None, Some(size)) => size,
            (Some(p), given) => {
                let p = Self::length(scene_file, "pixel", p)?;
                let derived = DVec2::new(nx as f64 * p, ny as f64 * p);
                if derived.max_element() > MAX_LENGTH {
                    return Err(scene_file.error(
                        Self::key("pixel"),
                        format!(
                            "{nx} x {ny} pixels of {p} make a cell of [{:e}, {:e}], beyond the largest length {MAX_LENGTH:e}",
                            derived.x, derived.y
                        ),
                    ));
                }
                match given {
                    Some(s) if ((s - derived).abs().cmpgt(1e-9 * derived)).any() => {
                        return Err(scene_file.error(
                            "surface.size",
                            format!(
                                "[{}, {}] contradicts the height map: {nx} x {ny} pixels of {p} make [{}, {}]",
                                s.x, s.y, derived.x, derived.y
                            ),
                        ));
                    }
                    Some(s) => s,
                    None => derived,
                }
            }
        })
    }
}

/// What the height-field walk assumes of a built field, checked in one
/// place: finite heights whose range is within [`MAX_LENGTH`] and
/// [`MAX_ASPECT`] period sides (so slopes, range over the pitch, and their
/// squares in the normals stay finite); `key` is blamed.
fn check_field(scene_file: &SceneFile, field: &HeightField, key: &str) -> Result<(), SceneError> {
    let range = field.max - field.min;
    if !(field.max.is_finite() && field.min.is_finite() && range.is_finite()) {
        return Err(scene_file.error(key, "the field's heights are not finite numbers"));
    }
    if range > MAX_LENGTH {
        return Err(scene_file.error(
            key,
            format!("the heights span {range:e}, beyond the largest length {MAX_LENGTH:e}"),
        ));
    }
    aspect_bound(range, field.size).map_err(|e| scene_file.error(key, e))?;
    Ok(())
}

impl BumpSpec {
    /// Draw the bumps of this table (deterministic from its seed), after
    /// adding their estimated memory to `bytes` (the surface's so far) and
    /// refusing the table if the sum exceeds the limit ([`crate::limits`]).
    fn populate(
        &self,
        scene_file: &SceneFile,
        t: usize,
        size: DVec2,
        edges: Edges,
        material: usize,
        bytes: &mut u64,
    ) -> Result<Vec<Placed>, SceneError> {
        let ranges = self.checked_ranges(scene_file, t, size)?;
        self.check_memory(scene_file, t, (size, edges), material, &ranges, bytes)?;
        let BumpRanges { depth, cap, base } = ranges;
        let mut rng = Pcg64Mcg::seed_from_u64(self.seed.unwrap_or(1 + t as u64));
        let mut out = Vec::with_capacity(self.count);
        for _ in 0..self.count {
            // Fixed draw order: every parameter draws whether or not it is a range.
            let u: [f64; 7] = std::array::from_fn(|_| rng.random::<f64>());
            let radius = self.radius.at(u[2]);
            let bump = Bump {
                center: DVec2::new(u[0] * size.x, u[1] * size.y),
                radius,
                radius_y: self.radius_y.map_or(radius, |r| r.at(u[3])),
                height: self.height.at(u[4]),
                depth: depth.at(u[5]),
                cap: cap.at(u[6]),
                base: base.at(u[6]),
            };
            out.push(self.shape.body(&bump, material));
        }
        Ok(out)
    }

    /// Check table `t`'s ranges (over a period of `size`) and the keys its
    /// shape uses, and return its depth, cap and base with their defaults.
    fn checked_ranges(
        &self,
        scene_file: &SceneFile,
        t: usize,
        size: DVec2,
    ) -> Result<BumpRanges, SceneError> {
        let key = |k: &str| format!("bumps[{t}].{k}");
        self.radius.check(scene_file, &key("radius"), 0.0, false)?;
        self.height.check(scene_file, &key("height"), 0.0, false)?;
        if let Some(r) = &self.radius_y {
            r.check(scene_file, &key("radius_y"), 0.0, false)?;
        }
        let depth = self.depth.unwrap_or(Range::One(0.0));
        depth.check(scene_file, &key("depth"), 0.0, true)?;
        let cap = self.cap.unwrap_or(Range::One(0.5));
        cap.check(scene_file, &key("cap"), 0.0, false)?;
        if cap.bounds().1 > 1.0 {
            return Err(scene_file.error(key("cap"), "must be <= 1"));
        }
        let base = self.base.unwrap_or(Range::One(1.5));
        base.check(scene_file, &key("base"), 1.0, false)?;
        // Lengths (and the footprint radius * base) within the traced lengths.
        let radius_y = self.radius_y.unwrap_or(self.radius);
        for (name, r) in [
            ("radius", self.radius),
            ("radius_y", radius_y),
            ("height", self.height),
            ("depth", depth),
        ] {
            let (lo, hi) = r.bounds();
            length_bounds(lo)
                .and_then(|()| length_bounds(hi))
                .map_err(|e| scene_file.error(key(name), e))?;
        }
        aspect_bound(self.height.bounds().1, size)
            .map_err(|e| scene_file.error(key("height"), e))?;
        let foot = self.radius.bounds().1.max(radius_y.bounds().1) * base.bounds().1;
        length_bounds(foot)
            .map_err(|e| scene_file.error(key("base"), format!("radius * base: {e}")))?;
        let used = |name: &str, given: bool, shape_ok: bool| {
            if given && !shape_ok {
                Err(scene_file.error(
                    key(name),
                    format!("does not apply to shape {:?}", self.shape),
                ))
            } else {
                Ok(())
            }
        };
        used(
            "depth",
            self.depth.is_some(),
            self.shape == Shape::Ellipsoid,
        )?;
        let eoh = self.shape == Shape::EllipsoidOnHyperboloid;
        used("cap", self.cap.is_some(), eoh)?;
        used("base", self.base.is_some(), eoh)?;
        Ok(BumpRanges { depth, cap, base })
    }

    /// Add table `t`'s estimated memory (from its largest bump, every
    /// range at its top, over a period of `size` with `edges`) to `bytes`
    /// and refuse the table if the sum exceeds the limit; also refuses
    /// more than 10 million bumps.
    fn check_memory(
        &self,
        scene_file: &SceneFile,
        t: usize,
        (size, edges): (DVec2, Edges),
        material: usize,
        ranges: &BumpRanges,
        bytes: &mut u64,
    ) -> Result<(), SceneError> {
        let key = |k: &str| format!("bumps[{t}].{k}");
        if self.count > 10_000_000 {
            return Err(scene_file.error(key("count"), "more than 10 million bumps"));
        }
        // Memory, from the largest bump of the table (every range at its top).
        let top = |r: &Range| r.bounds().1;
        let largest = Bump {
            center: DVec2::ZERO,
            radius: top(&self.radius),
            radius_y: top(&self.radius_y.unwrap_or(self.radius)),
            height: top(&self.height),
            depth: top(&ranges.depth),
            cap: top(&ranges.cap),
            base: top(&ranges.base),
        };
        let (copies, per_bump) =
            crate::micro::placed_cost(&self.shape.body(&largest, material), size, edges);
        *bytes = bytes.saturating_add(per_bump.saturating_mul(self.count as u64));
        let solids = copies as f64 * self.count as f64;
        if copies > 2 {
            let what = format!("periodic ghost copies (about {solids:.1e} solids)");
            scene_file.check_memory(&format!("bumps[{t}]"), &what, *bytes)
        } else {
            let what = format!("{} bumps (solids and acceleration grid)", self.count);
            scene_file.check_memory(&key("count"), &what, *bytes)
        }
    }
}

/// A bump table's ranges with their defaults filled in.
struct BumpRanges {
    /// `depth` (default 0).
    depth: Range,
    /// `cap` (default 0.5).
    cap: Range,
    /// `base` (default 1.5).
    base: Range,
}

/// An explicit `[[bodies]]` entry: tested for every flight, its top found by
/// sampling vertical rays and refining the highest.
fn explicit_body(
    scene_file: &SceneFile,
    key: &str,
    spec: &BodySpec,
    quadrics: &BTreeMap<String, Quadric>,
    size: DVec2,
    material: usize,
) -> Result<Placed, SceneError> {
    let names: Vec<String> = quadrics.keys().cloned().collect();
    let list: Vec<Quadric> = quadrics.values().copied().collect();
    let (body, _) = super::region_body(
        scene_file,
        &format!("{key}.region"),
        &spec.region,
        &names,
        &list,
        material,
    )?;

    // Unbounded above? Probe far above the period (relative to its size).
    let scale = size.max_element();
    let z_far = 1e6 * scale;
    for (fx, fy) in [
        (0.5, 0.5),
        (0.0, 0.0),
        (1.0, 0.0),
        (0.0, 1.0),
        (1.0, 1.0),
        (0.25, 0.75),
    ] {
        if body.contains(DVec3::new(fx * size.x, fy * size.y, z_far)) {
            return Err(scene_file.error(
                format!("{key}.region"),
                "the body is unbounded above (photons must start above the surface)",
            ));
        }
    }
    let max_height = explicit_max_height(&body, size, z_far);
    if !max_height.is_finite() {
        return Err(scene_file.error(
            format!("{key}.region"),
            "the body never rises into the cell (empty or below everything)",
        ));
    }
    aspect_bound(max_height, size).map_err(|e| scene_file.error(format!("{key}.region"), e))?;
    Ok(Placed {
        body,
        max_height: max_height.max(0.0),
        wraps: false,
        bump: None,
    })
}

/// Highest point of `body` over the period: vertical rays on a grid, then a
/// compass search from the best sample down to 1e-13 of the period size.
fn explicit_max_height(body: &Body, size: DVec2, z_far: f64) -> f64 {
    let height = |x: f64, y: f64| {
        let x = x.clamp(0.0, size.x);
        let y = y.clamp(0.0, size.y);
        body.first_entry(
            &Ray::new(DVec3::new(x, y, z_far), DVec3::NEG_Z),
            f64::INFINITY,
            None,
        )
        .map_or(f64::NEG_INFINITY, |e| z_far - e.t)
    };
    let n = 256;
    let mut best = (f64::NEG_INFINITY, 0.0, 0.0);
    for iy in 0..=n {
        for ix in 0..=n {
            let (x, y) = (size.x * ix as f64 / n as f64, size.y * iy as f64 / n as f64);
            let h = height(x, y);
            if h > best.0 {
                best = (h, x, y);
            }
        }
    }
    if !best.0.is_finite() {
        return best.0;
    }
    let mut step = size / n as f64;
    let floor = 1e-13 * size.max_element();
    while step.max_element() > floor {
        let mut improved = false;
        for (dx, dy) in [
            (1.0, 0.0),
            (-1.0, 0.0),
            (0.0, 1.0),
            (0.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1.0, -1.0),
            (-1.0, 1.0),
        ] {
            let (x, y) = (best.1 + dx * step.x, best.2 + dy * step.y);
            let h = height(x, y);
            if h > best.0 {
                best = (h, x.clamp(0.0, size.x), y.clamp(0.0, size.y));
                improved = true;
            }
        }
        if !improved {
            step *= 0.5;
        }
    }
    // The vertical rays start at z_far: their heights carry its rounding error.
    best.0 + 4.0 * f64::EPSILON * z_far
}
