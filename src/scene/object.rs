//! Object scenes: a 3-D object of quadric zones with rough walls (`roks trace`).
//!
//! ```toml
//! name = "cavity"                  # optional; output goes to out/<name>/ (default: file stem)
//! seed = 1                         # tracing seed (optional)
//!
//! [quadrics]                       # named surfaces (see scene::QuadricSpec): plane, quadric,
//! wall  = { cylinder_z = { r = 25.0 } }              # sphere, ellipsoid, cylinder_x/y/z,
//! front = { plane = [0.0, 0.0, 1.0, 0.0] }           # cone_x/y/z, paraboloid_z
//! back  = { cone_z = { apex = [0.0, 0.0, -150.0], t2 = 0.25 } }
//! tip   = { plane = [0.0, 0.0, 1.0, -150.0] }
//! outer = { cylinder_z = { r = 30.0 } }
//!
//! [[cells]]                            # one zone (the key keeps OpenMC's word)
//! name = "cavity"
//! region = "-wall -front -back +tip"   # OpenMC region syntax
//! fill = "void"                        # "void": photons fly; "solid": they reflect at its boundary
//! [[cells]]
//! name = "body"
//! region = "-outer -front +tip ~(-wall -back)"
//! fill = "solid"
//!
//! [walls]                              # model of each surface, as seen from a void zone
//! wall = "z302"
//! back = "z302"
//!
//! [models.z302]                        # exactly one kind:
//! micro = "z302-micro.toml"            #   descend into a micro scene (periodic) at every hit
//! # brdf = "out/z302/brdf.csv"         #   sample a table written by `roks brdf`
//! # specular = 0.03                    #   ideal reflection: specular and Lambertian parts
//! # diffuse = 0.02
//! # n = 1.5                            #   Fresnel-weighted specular (k optional)
//! # k = 0.1
//! # table = "r.csv"                    #   specular, reflectance vs angle
//! # reflectance = 0.9                  #   specular, constant reflectance
//!
//! [[sources]]
//! beam = { direction = [0.0, 0.0, -1.0], diameter = 2.0 }           # parallel circular beam
//! sweep = { from = [0.0, 0.0, 10.0], to = [24.0, 0.0, 10.0], steps = 49 }
//! # position = [0.0, 0.0, 10.0]        # or one beam position
//! photons = 200000                     # per position
//! # polarisation = "s"                 # state of the beam (default "unpolarised"; see below)
//!
//! [tally]
//! bands = 32                           # far field: Carlson grid mirrored to the full sphere
//! farfield = true
//! # polarisation = "stokes"            # also farfield_stokes.csv (needs farfield = true)
//!
//! [transport]
//! max_bounces = 100000
//! roulette_weight = 0.01
//! # polarisation = false               # force the scalar (unpolarised) approximation; true: force Stokes
//!
//! # [light]                            # optional: a spectral run (see below)
//! # wavelengths_um = [3.0, 8.0, 12.0]  # or { from = 3.0, to = 14.0, step = 0.5 }
//! ```
//!
//! # Wavelengths
//!
//! `[light] wavelengths_um` (the micro scenes' key; `roks trace
//! --wavelengths` overrides it) makes the run spectral: every photon carries
//! a weight per wavelength along one path ([`crate::transport::object`]).
//! The models are sampled at the wavelengths: `n`, `k`, `reflectance` as
//! numbers (the same at every wavelength) or arrays aligned with the
//! wavelengths, `nk = "file"` a measured table, `table` a file or an array
//! of files ([`MaterialSpec`]); a `micro` wall's micro scene is loaded at
//! the object's wavelengths (its own `[light] wavelengths_um` is replaced),
//! so its materials are sampled at them. Ideal walls (`specular`,
//! `diffuse`) and a monochrome `brdf` table apply to every wavelength
//! alike; a spectral `brdf` table (with a `wavelength_um` column, from a
//! spectral `roks brdf`) gives each wavelength its own table: the object's
//! wavelengths must be among the table's, and the wall depolarises
//! ([`crate::transport::wall::SpectralTableWall`]). A monochrome object
//! scene refuses a micro scene that has wavelengths of its own (give the
//! object the `[light]` key instead), and a spectral table.
//!
//! # Polarisation
//!
//! * `[[sources]] polarisation`: the beam's state, as
//!   [`PolarisationSpec`] (`"unpolarised"`, `"s"`, `"p"`, `"right"`,
//!   `"left"`, `{ linear = deg }`, `[S0, S1, S2, S3]`). Its Stokes
//!   reference vector is `hemisphere_reference(direction, 0)` in world
//!   coordinates: `normalize(ẑ × direction)`, and `+y` for a beam along
//!   `±z` ([`Beam::reference`]); `"s"` is linear along it, `{ linear = a }`
//!   turned by `a` degrees toward `direction × reference`.
//! * Polarised transport (the photon carries a Stokes vector through every
//!   bounce, micro descents included) is on when a wall model can polarise
//!   (a Fresnel `n`/`k` model, or a `micro` model whose micro scene has a
//!   Fresnel material) or `[tally] polarisation = "stokes"` asks for it.
//!   `[transport] polarisation = false` (or `roks trace --no-polarisation`)
//!   keeps the scalar weight: every Fresnel bounce weighs `(Rs + Rp) / 2`,
//!   the unpolarised approximation, exact for one bounce of unpolarised
//!   light only. `true` forces polarised transport (the intensities of a
//!   non-polarising scene are then the scalar ones bit for bit). A scene
//!   without a polarising model runs the scalar path unchanged.
//! * Outputs of a polarised run: every source entry of `summary.json` gets
//!   `stokes` (the Stokes vector of the light leaving after at least one
//!   reflection, per unit beam power: each escaping photon's Stokes vector
//!   about `hemisphere_reference(dir, 0)` of its own exit direction `dir`,
//!   summed and divided by the photons launched), `stokes_stderr` and
//!   `polarisation` (the state's name); `reflectance` is `stokes[0]`. With
//!   `[tally] polarisation = "stokes"`, `farfield_stokes.csv` holds per
//!   far-field cell the Stokes components per projected solid angle (`s0`
//!   equals `farfield.csv`'s `brdf`), with standard errors and the degree of
//!   polarisation, in the same frames (below the horizon too).

use crate::num::Num;
use crate::outdir::file::ResultFile;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Deserialize;

use super::micro::{MicroScene, TransportSpec};
use super::{
    Files, MaterialSpec, PolarisationSpec, QuadricSpec, SceneError, SceneFile, Values,
    WavelengthsSpec, parse_toml,
};
use crate::object::source::Beam;
use crate::object::{Object, SolidZone, VoidZone};
use crate::optics::brdf_table::BrdfTables;
use crate::optics::material::Reflectance;
use crate::optics::polarisation::Incident;
use crate::tally::PolarTally;
use crate::transport::micro::Controls;
use crate::transport::object::{ObjectRun, Walls};
use crate::transport::wall::{MicroWall, SpectralTableWall, WallModel};

/// The object scene as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSceneSpec {
    /// Scene name (output folder); default: file stem.
    pub name: Option<String>,
    /// Tracing seed (default 1).
    pub seed: Option<u64>,
    /// Named surfaces.
    #[serde(default)]
    pub quadrics: BTreeMap<String, QuadricSpec>,
    /// The zones (`[[cells]]`: the key keeps the OpenMC word).
    #[serde(default, rename = "cells")]
    pub zones: Vec<ZoneSpec>,
    /// Surface name -> model name.
    #[serde(default)]
    pub walls: BTreeMap<String, String>,
    /// Wall models.
    #[serde(default)]
    pub models: BTreeMap<String, ModelSpec>,
    /// Light sources.
    #[serde(default)]
    pub sources: Vec<SourceSpec>,
    /// Far-field tally.
    #[serde(default)]
    pub tally: ObjectTallySpec,
    /// History limits and polarised transport (`polarisation`: `None`
    /// decides by the scene, see the module docs).
    #[serde(default)]
    pub transport: TransportSpec,
    /// The wavelengths of a spectral run (see the module docs).
    #[serde(default)]
    pub light: ObjectLightSpec,
}

/// `[light]` of an object scene: only the wavelengths (the beams are
/// `[[sources]]`).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectLightSpec {
    /// Vacuum wavelengths (µm) every photon carries; absent: monochrome.
    pub wavelengths_um: Option<WavelengthsSpec>,
}

/// `[[cells]]`: one zone of the object.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZoneSpec {
    /// Zone name.
    pub name: String,
    /// OpenMC region over `[quadrics]`.
    pub region: String,
    /// `void` or `solid`.
    pub fill: Fill,
}

/// Zone fill.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Fill {
    /// Photons fly here.
    Void,
    /// Photons reflect at its boundary.
    Solid,
}

/// `[models.NAME]`: exactly one kind of model.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// Micro scene file for on-the-fly descent.
    pub micro: Option<String>,
    /// BRDF table written by `roks brdf`.
    pub brdf: Option<String>,
    /// Ideal specular reflectance.
    pub specular: Option<f64>,
    /// Ideal diffuse (Lambertian) reflectance.
    pub diffuse: Option<f64>,
    /// Fresnel: real part of the refractive index (per wavelength: an array).
    pub n: Option<Values>,
    /// Fresnel: extinction coefficient (per wavelength: an array).
    pub k: Option<Values>,
    /// Fresnel: a measured n, k table against wavelength.
    pub nk: Option<String>,
    /// Specular with reflectance vs angle (CSV; per wavelength: an array of files).
    pub table: Option<Files>,
    /// Specular with constant reflectance (per wavelength: an array).
    pub reflectance: Option<Values>,
}

/// `[[sources]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceSpec {
    /// The beam.
    pub beam: BeamSpec,
    /// A sweep of the beam axis.
    pub sweep: Option<SweepSpec>,
    /// One beam position.
    pub position: Option<[f64; 3]>,
    /// Photons per position.
    #[serde(default = "default_photons")]
    pub photons: u64,
    /// Polarisation state of the beam (default unpolarised).
    pub polarisation: Option<PolarisationSpec>,
}

fn default_photons() -> u64 {
    100_000
}

/// `beam = { .. }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamSpec {
    /// Direction of travel.
    pub direction: [f64; 3],
    /// Diameter (length units, >= 0).
    pub diameter: f64,
}

/// `sweep = { .. }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// First beam position.
    pub from: [f64; 3],
    /// Last beam position.
    pub to: [f64; 3],
    /// Number of positions (>= 1).
    pub steps: usize,
}

/// `[tally]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectTallySpec {
    /// Carlson bands of the far field (per hemisphere).
    #[serde(default = "default_bands")]
    pub bands: usize,
    /// Write farfield.csv.
    #[serde(default)]
    pub farfield: bool,
    /// Polarisation tallies: `"none"` (default) or `"stokes"`
    /// (farfield_stokes.csv); `"mueller"` is for micro scenes only.
    #[serde(default)]
    pub polarisation: PolarTally,
}

impl Default for ObjectTallySpec {
    fn default() -> Self {
        Self {
            bands: default_bands(),
            farfield: false,
            polarisation: PolarTally::None,
        }
    }
}

fn default_bands() -> usize {
    32
}

/// An object scene ready to trace.
#[derive(Debug, Clone)]
pub struct ObjectScene {
    /// Scene name.
    pub name: String,
    /// Where it came from.
    pub scene_file: SceneFile,
    /// The geometry.
    pub object: Object,
    /// Model of each surface id.
    pub walls: Walls,
    /// Models, indexed by `walls`.
    pub models: Vec<WallModel>,
    /// Model names.
    pub model_names: Vec<String>,
    /// Beam positions, source by source.
    pub beams: Vec<Beam>,
    /// Which `[[sources]]` entry each beam comes from.
    pub beam_source: Vec<usize>,
    /// Photons per position, per beam.
    pub photons: Vec<u64>,
    /// What to run (photons per position is per source; see `photons`).
    pub run: ObjectRun,
    /// The files the scene reads, as reached from the working folder: the
    /// scene file (loaded from a file) and the files its content identity
    /// hashes ([`ObjectSceneSpec::files`]: every file its models name, n, k
    /// and angle tables, each `micro` wall's scene and its files, each
    /// `brdf` wall's table with the `summary.json` and `mueller.csv` beside
    /// it). No output may replace one
    /// ([`crate::outdir::check::check_kept`]).
    pub reads: Vec<PathBuf>,
    /// SHA-256 of the scene text and of every file it reads
    /// ([`ObjectSceneSpec::files`]; empty for a scene built from a spec).
    pub content: super::Content,
}

impl ObjectScene {
    /// Load a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_at(path, None)
    }

    /// Load a scene file with its `[light] wavelengths_um` replaced by
    /// `wavelengths` (`roks trace --wavelengths`; `None`: the file's),
    /// checked as the key is.
    pub fn load_at(path: &Path, wavelengths: Option<&WavelengthsSpec>) -> Result<Self, SceneError> {
        let text = super::read_scene_text(path)?;
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        let mut scene = Self::from_str_at(
            &text,
            SceneFile::from_path(path),
            name.unwrap_or_default(),
            wavelengths,
        )?;
        scene.reads.insert(0, path.to_path_buf());
        Ok(scene)
    }

    /// Parse and build from TOML text.
    pub fn from_str(
        text: &str,
        scene_file: SceneFile,
        fallback_name: String,
    ) -> Result<Self, SceneError> {
        Self::from_str_at(text, scene_file, fallback_name, None)
    }

    /// [`ObjectScene::from_str`] with the wavelengths replaced (see
    /// [`ObjectScene::load_at`]).
    pub fn from_str_at(
        text: &str,
        scene_file: SceneFile,
        fallback_name: String,
        wavelengths: Option<&WavelengthsSpec>,
    ) -> Result<Self, SceneError> {
        let mut spec: ObjectSceneSpec = parse_toml(&scene_file, text)
            .map_err(|e| super::other_kind(text, "surface", e, "a micro scene ([surface]): roks brdf traces it; roks trace takes object scenes ([[cells]])"))?;
        if let Some(w) = wavelengths {
            spec.light.wavelengths_um = Some(w.clone());
        }
        let files = spec.files(&scene_file);
        let mut scene = spec.build(scene_file, fallback_name)?;
        scene.content = super::Content::of(&scene.scene_file, text, &files)?;
        scene.reads = scene.scene_file.paths(&files);
        Ok(scene)
    }
}

impl ObjectSceneSpec {
    /// The files the scene reads, `(key, path relative to the scene's
    /// folder)`, for its content identity: per model its micro scene
    /// (`models.NAME.micro`) and the files that one reads
    /// (`models.NAME.micro.materials.gold.nk`, ...), a BRDF table
    /// (`models.NAME.brdf`) with the `summary.json` and `mueller.csv`
    /// beside it when present (`models.NAME.brdf.summary`,
    /// `models.NAME.brdf.mueller`), an n, k table (`models.NAME.nk`) and
    /// angle tables (`models.NAME.table`, `models.NAME.table[i]`). A micro
    /// scene that cannot be read adds only its own key (loading it reports
    /// the error).
    #[must_use]
    pub fn files(&self, scene_file: &SceneFile) -> Vec<(String, String)> {
        let mut files = Vec::new();
        for (name, m) in &self.models {
            let key = format!("models.{name}");
            if let Some(f) = &m.micro {
                files.push((format!("{key}.micro"), f.clone()));
                let path = scene_file.dir.join(f);
                let micro = SceneFile::from_path(&path);
                let spec = super::read_scene_text(&path).ok().and_then(|text| {
                    super::parse_toml::<super::micro::MicroSceneSpec>(&micro, &text).ok()
                });
                let dir = Path::new(f).parent().unwrap_or(Path::new(""));
                for (k, sub) in spec.map(|s| s.files()).unwrap_or_default() {
                    let sub = dir.join(sub).to_string_lossy().into_owned();
                    files.push((format!("{key}.micro.{k}"), sub));
                }
            }
            if let Some(f) = &m.brdf {
                files.push((format!("{key}.brdf"), f.clone()));
                let table = Path::new(f);
                for (beside, k) in [
                    (ResultFile::Summary.name(), "summary"),
                    (ResultFile::Mueller.name(), "mueller"),
                ] {
                    let other = table.with_file_name(beside);
                    if scene_file.dir.join(&other).exists() {
                        let other = other.to_string_lossy().into_owned();
                        files.push((format!("{key}.brdf.{k}"), other));
                    }
                }
            }
            files.extend(m.material().files(&key));
        }
        files
    }

    /// Check everything and build the scene.
    pub fn build(
        self,
        scene_file: SceneFile,
        fallback_name: String,
    ) -> Result<ObjectScene, SceneError> {
        let surface_names: Vec<String> = self.quadrics.keys().cloned().collect();
        let object = self.build_object(&scene_file, &surface_names)?;
        let transport = self.transport;
        let controls = transport_controls(&scene_file, &transport)?;
        let wavelengths_um = self.wavelengths(&scene_file)?;
        let lanes = wavelengths_um.len().max(1) as u64;
        let model_names: Vec<String> = self.models.keys().cloned().collect();
        let mut models = Vec::new();
        for (name, m) in &self.models {
            models.push(m.build(
                &scene_file,
                &format!("models.{name}"),
                controls,
                &wavelengths_um,
            )?);
        }
        let walls = self.build_walls(&scene_file, &surface_names, &model_names)?;

        let tally = &self.tally;
        let farfield_stokes = check_tally(&scene_file, tally)?;
        let polarisation = match transport.polarisation {
            Some(false) if farfield_stokes => {
                return Err(scene_file.error(
                    "transport.polarisation",
                    "false conflicts with [tally] polarisation = \"stokes\" (Stokes tallies need polarised transport)",
                ));
            }
            Some(on) => on,
            None => farfield_stokes || models.iter().any(WallModel::polarises),
        };
        let memory = position_memory_bytes(
            surface_names.len(),
            tally.bands,
            tally.farfield,
            farfield_stokes,
        );
        let launches = self.build_beams(&scene_file, &object, memory, lanes)?;
        let (per_position, fixed) = memory;
        scene_file.check_memory(
            "tally.bands",
            &format!(
                "the tallies and tables of {} Carlson bands for {} beam positions{}",
                tally.bands,
                launches.beams.len(),
                if wavelengths_um.is_empty() {
                    String::new()
                } else {
                    format!(" and {lanes} wavelengths")
                }
            ),
            fixed.saturating_mul(lanes).saturating_add(
                (launches.beams.len() as u64).saturating_mul(per_position.saturating_mul(lanes)),
            ),
        )?;
        let run = ObjectRun {
            seed: self.seed.unwrap_or(1),
            bands: tally.bands,
            farfield: tally.farfield,
            controls,
            polarisation,
            farfield_stokes,
            wavelengths_um,
        };
        Ok(ObjectScene {
            name: super::scene_name(&scene_file, self.name, fallback_name)?,
            scene_file,
            object,
            walls,
            models,
            model_names,
            beams: launches.beams,
            beam_source: launches.beam_source,
            photons: launches.photons,
            run,
            reads: Vec::new(),
            content: super::Content::default(),
        })
    }

    /// The geometry: `[quadrics]` built and `[[cells]]` sorted into solid
    /// and void zones (at least one cell, at least one solid).
    fn build_object(
        &self,
        scene_file: &SceneFile,
        surface_names: &[String],
    ) -> Result<Object, SceneError> {
        let mut quadrics = Vec::new();
        for (name, q) in &self.quadrics {
            quadrics.push(q.build(scene_file, &format!("quadrics.{name}"))?);
        }
        if self.zones.is_empty() {
            return Err(scene_file.error("cells", "the object needs at least one cell"));
        }
        let mut solids = Vec::new();
        let mut voids = Vec::new();
        for (c, zone) in self.zones.iter().enumerate() {
            let key = format!("cells[{c}].region");
            let (body, ids) =
                super::region_body(scene_file, &key, &zone.region, surface_names, &quadrics, 0)?;
            match zone.fill {
                Fill::Solid => solids.push(SolidZone {
                    name: zone.name.clone(),
                    body,
                    surface_ids: ids,
                }),
                Fill::Void => voids.push(VoidZone {
                    name: zone.name.clone(),
                    body,
                }),
            }
        }
        if solids.is_empty() {
            return Err(scene_file.error("cells", "no solid cell: nothing to reflect from"));
        }
        Ok(Object::new(surface_names.to_vec(), solids, voids))
    }

    /// `light.wavelengths_um` resolved (µm; empty for a monochrome run).
    fn wavelengths(&self, scene_file: &SceneFile) -> Result<Vec<f64>, SceneError> {
        Ok(match &self.light.wavelengths_um {
            Some(w) => w.resolve().map_err(|e| match e.index() {
                Some(i) => scene_file.error(format!("light.wavelengths_um[{i}]"), e),
                None => scene_file.error("light.wavelengths_um", e),
            })?,
            None => Vec::new(),
        })
    }

    /// `[walls]`: the model index of each surface id (`None`: absorbing),
    /// every surface and model named checked against `[quadrics]` and
    /// `[models]` (both sorted names).
    fn build_walls(
        &self,
        scene_file: &SceneFile,
        surface_names: &[String],
        model_names: &[String],
    ) -> Result<Walls, SceneError> {
        let mut walls: Walls = vec![None; surface_names.len()];
        for (surface, model) in &self.walls {
            let key = format!("walls.{surface}");
            // Sorted (the keys of a BTreeMap): binary search keeps loading linear.
            let sid = surface_names.binary_search(surface).map_err(|_| {
                scene_file.error(
                    &key,
                    format!("unknown surface `{surface}` (not in [quadrics])"),
                )
            })?;
            let mid = model_names.binary_search(model).map_err(|_| {
                scene_file.error(
                    &key,
                    format!(
                        "unknown model `{model}` (known: {})",
                        model_names.join(", ")
                    ),
                )
            })?;
            walls[sid] = Some(mid);
        }
        Ok(walls)
    }

    /// Every `[[sources]]` entry's beams, position by position, each
    /// checked to start in open space or one void cell. `memory` is
    /// [`position_memory_bytes`] and `lanes` the wavelengths per photon
    /// (for the memory check of a sweep).
    fn build_beams(
        &self,
        scene_file: &SceneFile,
        object: &Object,
        memory: (u64, u64),
        lanes: u64,
    ) -> Result<Launches, SceneError> {
        if self.sources.is_empty() {
            return Err(scene_file.error("sources", "needs at least one [[sources]] entry"));
        }
        let mut launches = Launches::default();
        for (i, s) in self.sources.iter().enumerate() {
            let key = |k: &str| format!("sources[{i}].{k}");
            let dir = DVec3::from_array(s.beam.direction);
            let Some(direction) = dir.try_normalize().filter(|d| d.is_finite()) else {
                return Err(
                    scene_file.error(key("beam.direction"), "must be a non-zero finite vector")
                );
            };
            if !(s.beam.diameter.is_finite() && s.beam.diameter >= 0.0) {
                return Err(scene_file.error(key("beam.diameter"), "must be >= 0"));
            }
            crate::transport::launch::check_count(s.photons)
                .map_err(|e| scene_file.error(key("photons"), e))?;
            let state = match &s.polarisation {
                Some(spec) => spec.build(scene_file, &key("polarisation"))?,
                None => Incident::Unpolarised,
            };
            let before = launches.beams.len() as u64;
            for p in source_positions(scene_file, i, s, before, memory, lanes)? {
                let beam = Beam {
                    position: p,
                    direction,
                    diameter: s.beam.diameter,
                    polarisation: state,
                };
                check_beam_start(scene_file, object, i, &beam)?;
                launches.beams.push(beam);
                launches.beam_source.push(i);
                launches.photons.push(s.photons);
            }
        }
        Ok(launches)
    }
}

/// The beams of an object scene, each with its `[[sources]]` entry and
/// photons (three parallel lists).
#[derive(Debug, Default)]
struct Launches {
    /// Beam positions, source by source.
    beams: Vec<Beam>,
    /// Which `[[sources]]` entry each beam comes from.
    beam_source: Vec<usize>,
    /// Photons per position, per beam.
    photons: Vec<u64>,
}

/// `[transport]` checked into the history limits of a run.
fn transport_controls(
    scene_file: &SceneFile,
    transport: &TransportSpec,
) -> Result<Controls, SceneError> {
    if transport.max_bounces == 0 {
        return Err(scene_file.error("transport.max_bounces", "must be > 0"));
    }
    if !(transport.roulette_weight >= 0.0 && transport.roulette_weight < 1.0) {
        return Err(scene_file.error("transport.roulette_weight", "must be in [0, 1)"));
    }
    Ok(Controls {
        max_bounces: transport.max_bounces,
        roulette_weight: transport.roulette_weight,
        ..Controls::default()
    })
}

/// `[tally]` checked (bands, the polarisation an object scene can tally);
/// returns whether the far field tallies Stokes vectors.
fn check_tally(scene_file: &SceneFile, tally: &ObjectTallySpec) -> Result<bool, SceneError> {
    if !(1..=1000).contains(&tally.bands) {
        return Err(scene_file.error(
            "tally.bands",
            format!("must be in 1..=1000, got {}", tally.bands),
        ));
    }
    if tally.polarisation == PolarTally::Mueller {
        return Err(scene_file.error(
            "tally.polarisation",
            "\"mueller\" is for micro scenes (roks brdf); object scenes tally \"stokes\" or \"none\"",
        ));
    }
    let farfield_stokes = tally.polarisation == PolarTally::Stokes;
    if farfield_stokes && !tally.farfield {
        return Err(scene_file.error(
            "tally.polarisation",
            "\"stokes\" tallies the far field: set [tally] farfield = true",
        ));
    }
    Ok(farfield_stokes)
}

/// The beam positions of `[[sources]]` entry `i`: its `position`, or the
/// `steps` evenly spaced points of its `sweep` (checked against the memory
/// of `before` earlier positions plus these, see [`position_memory_bytes`]).
fn source_positions(
    scene_file: &SceneFile,
    i: usize,
    s: &SourceSpec,
    before: u64,
    (per_position, fixed): (u64, u64),
    lanes: u64,
) -> Result<Vec<DVec3>, SceneError> {
    let key = |k: &str| format!("sources[{i}].{k}");
    match (&s.sweep, &s.position) {
        (Some(_), Some(_)) | (None, None) => Err(scene_file.error(
            format!("sources[{i}]"),
            "give exactly one of `sweep`, `position`",
        )),
        (None, Some(p)) => Ok(vec![DVec3::from_array(*p)]),
        (Some(sw), None) => {
            if sw.steps == 0 {
                return Err(scene_file.error(key("sweep.steps"), "must be >= 1"));
            }
            let positions = before.saturating_add(sw.steps as u64);
            let bytes = fixed
                .saturating_mul(lanes)
                .saturating_add(positions.saturating_mul(per_position.saturating_mul(lanes)));
            scene_file.check_memory(
                &key("sweep.steps"),
                &format!("{positions} beam positions (tallies and result tables)"),
                bytes,
            )?;
            let (a, b) = (DVec3::from_array(sw.from), DVec3::from_array(sw.to));
            Ok((0..sw.steps)
                .map(|j| {
                    let f = if sw.steps == 1 {
                        0.0
                    } else {
                        j as f64 / (sw.steps - 1) as f64
                    };
                    a + (b - a) * f
                })
                .collect())
        }
    }
}

/// Check that a beam of `[[sources]]` entry `i` starts in open space or in
/// exactly one void cell, its whole launch disc too (rings of it; photons
/// starting inside a solid are also counted at run time and reported).
fn check_beam_start(
    scene_file: &SceneFile,
    object: &Object,
    i: usize,
    beam: &Beam,
) -> Result<(), SceneError> {
    let key = |k: &str| format!("sources[{i}].{k}");
    let p = beam.position;
    if !p.is_finite() {
        return Err(scene_file.error(key("position"), "must be finite"));
    }
    let (in_solids, in_voids) = object.zones_at(p);
    if let Some(&c) = in_solids.first() {
        return Err(scene_file.error(
            key("position"),
            format!(
                "beam position {p} is inside solid cell `{}`",
                object.solids[c].name
            ),
        ));
    }
    if in_voids.len() > 1 {
        let names: Vec<&str> = in_voids
            .iter()
            .map(|&v| object.voids[v].name.as_str())
            .collect();
        return Err(scene_file.error(
            "cells",
            format!(
                "void cells {} overlap at beam position {p}",
                names.join(" and ")
            ),
        ));
    }
    for ring in 1..=4 {
        for k in 0..32 {
            let q = beam.start(f64::from(ring) * 0.25, f64::from(k) / 32.0);
            if let Some(&c) = object.zones_at(q).0.first() {
                return Err(scene_file.error(
                    key("beam.diameter"),
                    format!(
                        "the beam's disc at {p} reaches into solid cell `{}` (at {q})",
                        object.solids[c].name
                    ),
                ));
            }
        }
    }
    Ok(())
}

impl ModelSpec {
    /// The material keys of a Fresnel, table or constant-reflectance wall
    /// (all `None` for the other kinds).
    fn material(&self) -> MaterialSpec {
        MaterialSpec {
            reflectance: self.reflectance.clone(),
            n: self.n.clone(),
            k: self.k.clone(),
            nk: self.nk.clone(),
            table: self.table.clone(),
        }
    }

    /// The wall model at `key` (the files it reads are listed by
    /// [`ObjectSceneSpec::files`]).
    fn build(
        &self,
        scene_file: &SceneFile,
        key: &str,
        controls: Controls,
        wavelengths_um: &[f64],
    ) -> Result<WallModel, SceneError> {
        let ideal = self.specular.is_some() || self.diffuse.is_some();
        let kinds = [
            self.micro.is_some(),
            self.brdf.is_some(),
            ideal,
            self.n.is_some() || self.k.is_some() || self.nk.is_some(),
            self.table.is_some(),
            self.reflectance.is_some(),
        ];
        if kinds.iter().filter(|&&k| k).count() != 1 {
            return Err(scene_file.error(
                key,
                "give exactly one kind: `micro`, `brdf`, `specular`/`diffuse`, `n`/`k`, `table` or `reflectance`",
            ));
        }
        if let Some(file) = &self.micro {
            let path = scene_file.dir.join(file);
            // A spectral object samples the micro scene's materials at its wavelengths.
            let at = (!wavelengths_um.is_empty()).then_some(wavelengths_um);
            let overrides = super::micro::Overrides {
                wavelengths_um: at.map(|w| WavelengthsSpec::List(w.to_vec())),
                ..Default::default()
            };
            let scene = MicroScene::load_with(&path, &overrides)
                .map_err(|e| scene_file.error(format!("{key}.micro"), e.to_string()))?;
            if at.is_none() && !scene.run.wavelengths_um.is_empty() {
                return Err(scene_file.error(
                    format!("{key}.micro"),
                    format!(
                        "the micro scene {} is spectral ([light] wavelengths_um) but this object scene is not: give the object scene [light] wavelengths_um (they replace the micro scene's)",
                        path.display()
                    ),
                ));
            }
            if scene.run.realisations > 1 {
                return Err(scene_file.error(
                    format!("{key}.micro"),
                    format!(
                        "the micro scene {} has surface.realisations = {}; a micro wall traces one surface: give it realisations = 1",
                        path.display(),
                        scene.run.realisations
                    ),
                ));
            }
            let Some(micro) = MicroWall::new(scene.surface, controls) else {
                return Err(scene_file.error(
                    format!("{key}.micro"),
                    "the micro scene must have periodic edges",
                ));
            };
            return Ok(WallModel::Micro(Box::new(micro)));
        }
        if let Some(file) = &self.brdf {
            let path = scene_file.dir.join(file);
            return brdf_wall(scene_file, &format!("{key}.brdf"), &path, wavelengths_um);
        }
        if ideal {
            let (s, d) = (self.specular.unwrap_or(0.0), self.diffuse.unwrap_or(0.0));
            for (v, name) in [(s, "specular"), (d, "diffuse")] {
                if !(0.0..=1.0).contains(&v) {
                    return Err(scene_file.error(
                        format!("{key}.{name}"),
                        format!("must be in [0, 1], got {}", Num(v)),
                    ));
                }
            }
            if s + d > 1.0 {
                return Err(scene_file.error(
                    key,
                    format!("specular + diffuse = {} exceeds 1", Num(s + d)),
                ));
            }
            return Ok(WallModel::Ideal {
                specular: s,
                diffuse: d,
            });
        }
        // Fresnel, table and constant reflectance share the material builder.
        let material = self.material();
        let r: Reflectance = material.build(scene_file, key, wavelengths_um)?;
        Ok(WallModel::Specular(r))
    }
}

/// The wall of the `brdf.csv` at `path` (scene key `key`), with the
/// `summary.json` beside it (exact reflectance errors) and, for a
/// monochrome table, the `mueller.csv` beside it (the wall then keeps
/// polarisation). A monochrome table applies to every wavelength of a
/// spectral object. A spectral table (a `wavelength_um` column) needs a
/// spectral object whose every wavelength is one of the table's (each
/// lane takes the table of its wavelength, [`SpectralTableWall`]), and a
/// spectral `mueller.csv` beside it gives each lane its own Mueller table.
fn brdf_wall(
    scene_file: &SceneFile,
    key: &str,
    path: &Path,
    wavelengths_um: &[f64],
) -> Result<WallModel, SceneError> {
    let fail = |e: &dyn std::fmt::Display| scene_file.error(key, e.to_string());
    if !path.exists() {
        return Err(fail(&format_args!(
            "{}: no such file: {}",
            path.display(),
            table_recipe(scene_file, path)
        )));
    }
    let mut tables = BrdfTables::load(path).map_err(|e| fail(&e))?;
    // A wall's tangent frame follows the light: it has no surface azimuth
    // to pick a light azimuth of the table by.
    tables
        .require_one_azimuth("a BRDF wall (its tangent frame follows the light, so the wall has no surface azimuth to choose one by)")
        .map_err(|e| fail(&e))?;
    // The run's summary beside the table carries the exact reflectance errors.
    let summary = path.with_file_name(ResultFile::Summary.name());
    if summary.exists() {
        tables = tables.with_summary(&summary).map_err(|e| fail(&e))?;
    }
    let mueller = path.with_file_name(ResultFile::Mueller.name());
    let spectral = match tables {
        BrdfTables::Monochrome(mut table) => {
            // A Mueller table of the same run beside it: the wall keeps polarisation.
            if mueller.exists() {
                table = table.with_mueller(&mueller).map_err(|e| fail(&e))?;
            }
            return Ok(WallModel::Table(Box::new(table)));
        }
        BrdfTables::Spectral(s) => s,
    };
    let listed = |w: &[f64]| {
        w.iter()
            .map(|w| Num(*w).to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if wavelengths_um.is_empty() {
        return Err(fail(&format_args!(
            "{} is a spectral table (wavelengths {} um) but this object scene is monochrome: give it [light] wavelengths_um from the table's, or use a monochrome table",
            path.display(),
            listed(spectral.wavelengths_um())
        )));
    }
    // The spectral Mueller table of the same run beside it: each lane keeps
    // its polarisation.
    let spectral = if mueller.exists() {
        spectral.with_mueller(&mueller).map_err(|e| fail(&e))?
    } else {
        spectral
    };
    let selected = spectral.select(wavelengths_um).map_err(|w| {
        fail(&format_args!(
            "{} has no table at {} um (its wavelengths: {} um); the object's [light] wavelengths_um must be among them",
            path.display(),
            Num(w),
            listed(spectral.wavelengths_um())
        ))
    })?;
    SpectralTableWall::new(selected)
        .map(|w| WallModel::SpectralTable(Box::new(w)))
        .ok_or_else(|| fail(&"more wavelengths than a run carries"))
}

/// How to make the missing BRDF table `path` of an object scene: the `roks
/// brdf` command of the micro scene beside the object scene (in
/// `source.dir`) whose `name` is the table's folder name (the folder `roks
/// brdf` writes by default), else the command's general form.
fn table_recipe(scene_file: &SceneFile, path: &Path) -> String {
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    let maker = dir
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|name| micro_scene_named(&scene_file.dir, name));
    match maker {
        Some(scene) => format!(
            "it is the table of `roks brdf {} --out {}`: run that first",
            scene.display(),
            dir.display()
        ),
        None => format!(
            "it is a table written by `roks brdf MICRO_SCENE --out {}`: run that first",
            dir.display()
        ),
    }
}

/// The first (by file name) micro scene (`[surface]`) of the folder `dir`
/// whose `name` (or, without one, file stem) is `name`; files over 1 MiB
/// are skipped (scenes are small).
fn micro_scene_named(dir: &Path, name: &str) -> Option<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .filter(|p| std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.len() <= 1 << 20))
        .collect();
    files.sort();
    files.into_iter().find(|p| {
        std::fs::read_to_string(p)
            .ok()
            .and_then(|t| t.parse::<toml::Table>().ok())
            .is_some_and(|t| {
                // A scene without `name` is named by its file stem.
                let named = t.get("name").map_or_else(
                    || p.file_stem().and_then(|s| s.to_str()) == Some(name),
                    |n| n.as_str() == Some(name),
                );
                t.contains_key("surface") && named
            })
    })
}

/// Estimated memory (bytes) of an object run per beam position, and the
/// fixed part: a position's tallies are 16 bytes (sum and sum of squares)
/// per surface and far-field cell (`4 M (M + 1)` cells over the sphere for
/// `bands` M, 5 sums per cell with Stokes far-field tallies), kept for every
/// position, with the position itself (about 200 bytes) and its lines of
/// the result tables (about 100 bytes per far-field cell); up to 64 batch
/// tallies are in flight (the fixed part).
fn position_memory_bytes(
    surfaces: usize,
    bands: usize,
    farfield: bool,
    stokes: bool,
) -> (u64, u64) {
    let cells = if farfield {
        4 * bands as u64 * (bands as u64 + 1)
    } else {
        0
    };
    let sums = 1 + surfaces as u64 + 4 + cells * if stokes { 5 } else { 1 };
    let tallies = 16 * sums + 256;
    (tallies + 200 + 100 * cells, 64 * tallies)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The files an object scene keeps from being overwritten (`reads`)
    /// are the scene and exactly the files its content identity hashes:
    /// a `micro` wall's scene and the angle table that scene names (in its
    /// own folder), and an angle-table wall's table.
    #[test]
    fn reads_are_the_files_the_content_hashes() {
        let dir = std::env::temp_dir().join(format!("roks-object-reads-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("m")).unwrap();
        let table = "angle_deg,reflectance\n0,0.5\n90,1\n";
        std::fs::write(dir.join("m/r.csv"), table).unwrap();
        std::fs::write(dir.join("r2.csv"), table).unwrap();
        std::fs::write(
            dir.join("m/micro.toml"),
            r#"[surface]
size = [30.0, 30.0]
material = "m"
[materials.m]
table = "r.csv"
[[bumps]]
shape = "ellipsoid"
count = 4
radius = 2.5
height = 1.0
seed = 1
"#,
        )
        .unwrap();
        std::fs::write(
            dir.join("obj.toml"),
            r#"[quadrics]
top = { plane = [0.0, 0.0, 1.0, 0.0] }
ball = { sphere = { center = [0.0, 0.0, -10.0], r = 100.0 } }
[[cells]]
name = "body"
region = "-top -ball"
fill = "solid"
[[cells]]
name = "air"
region = "+top"
fill = "void"
[walls]
top = "t"
ball = "u"
[models.t]
micro = "m/micro.toml"
[models.u]
table = "r2.csv"
[[sources]]
beam = { direction = [0.0, 0.0, -1.0], diameter = 2.0 }
position = [0.0, 0.0, 10.0]
photons = 1000
"#,
        )
        .unwrap();
        let scene = ObjectScene::load(&dir.join("obj.toml")).unwrap();
        let keys: Vec<&str> = scene.content.files.keys().map(String::as_str).collect();
        assert_eq!(
            keys,
            [
                "models.t.micro",
                "models.t.micro.materials.m.table",
                "models.u.table"
            ]
        );
        let canonical = |p: &Path| std::fs::canonicalize(p).unwrap();
        let mut reads: Vec<PathBuf> = scene.reads.iter().map(|p| canonical(p)).collect();
        reads.sort();
        let mut expected: Vec<PathBuf> = ["obj.toml", "m/micro.toml", "m/r.csv", "r2.csv"]
            .iter()
            .map(|f| canonical(&dir.join(f)))
            .collect();
        expected.sort();
        assert_eq!(reads, expected);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
