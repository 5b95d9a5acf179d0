//! The material of a microfacet fit (`roks fit-model --model ggx` or
//! `beckmann`): given on the command line (`--n`/`--k`, `--reflectance`),
//! or the substrate material of the scene named in the result folder's
//! `summary.json`, rebuilt at the table's wavelengths.

use std::path::Path;

use super::ModelKind;
use crate::optics::material::{Reflectance, ReflectanceError};
use crate::outdir::file::ResultFile;
use crate::scene::micro::{MicroScene, Overrides};

/// The material options of `roks fit-model`, as given.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MaterialOptions {
    /// `--n`: the refractive index (with `k`).
    pub n: Option<f64>,
    /// `--k`: the extinction coefficient (with `n`; default 0).
    pub k: Option<f64>,
    /// `--reflectance`: a constant reflectance instead of Fresnel.
    pub reflectance: Option<f64>,
}

impl MaterialOptions {
    /// Whether any material option is given.
    #[must_use]
    pub fn given(&self) -> bool {
        self.n.is_some() || self.k.is_some() || self.reflectance.is_some()
    }
}

/// The material of a microfacet fit of `kind` and where it came from, in
/// words: the options `m`, or else the substrate material of `scene` (the
/// scene named in `dir`'s `summary.json`, `None` without one) at lane
/// `lane` of the scene built at `wavelengths` (µm).
///
/// # Errors
/// A one-line message naming the option (or `summary.json` and the
/// scene): bad or conflicting options, no scene, or a scene that cannot
/// be loaded.
pub fn material(
    m: &MaterialOptions,
    dir: &Path,
    kind: ModelKind,
    scene: Option<&str>,
    wavelengths: &[f64],
    lane: usize,
) -> Result<(Reflectance, String), String> {
    if let Some(given) = from_options(m)? {
        return Ok(given);
    }
    let Some(scene) = scene else {
        return Err(format!(
            "--model {}: {}: no summary.json naming the scene, so the material is unknown: give --n N --k K or --reflectance R",
            kind,
            dir.display()
        ));
    };
    let path = Path::new(scene);
    let loaded = if scene == crate::scene::source::DEFAULT_SCENE {
        load_at(None, wavelengths)
    } else if !path.exists() {
        return Err(format!(
            "{}: scene: {scene}: no such file (relative to the folder roks brdf ran in?): run from there, or give --n N --k K or --reflectance R",
            ResultFile::Summary.path_in(dir).display()
        ));
    } else {
        load_at(Some(path), wavelengths)
    }?;
    Ok(substrate(&loaded, scene, lane))
}

/// The material the options give, if they give one.
fn from_options(a: &MaterialOptions) -> Result<Option<(Reflectance, String)>, String> {
    let bad = |option: &str, e: String| format!("{option}: {e}");
    if let Some(r) = a.reflectance {
        if a.n.is_some() || a.k.is_some() {
            return Err(bad(
                "--reflectance",
                "give either --reflectance or --n/--k, not both".into(),
            ));
        }
        let m = Reflectance::Constant(r);
        m.validate()
            .map_err(|e| bad("--reflectance", e.to_string()))?;
        return Ok(Some((m, format!("--reflectance {r}"))));
    }
    if let Some(n) = a.n {
        let k = a.k.unwrap_or(0.0);
        let m = Reflectance::Fresnel { n, k };
        m.validate().map_err(|e| {
            let option = match e {
                ReflectanceError::InvalidK(_) => "--k",
                _ => "--n",
            };
            bad(option, e.to_string())
        })?;
        return Ok(Some((m, format!("--n {n} --k {k}"))));
    }
    if a.k.is_some() {
        return Err(bad("--k", "needs --n".into()));
    }
    Ok(None)
}

/// The substrate material of `loaded` (the scene `scene`) at `lane`, and
/// where it came from in words.
fn substrate(loaded: &MicroScene, scene: &str, lane: usize) -> (Reflectance, String) {
    let surface = &loaded.surface;
    let m = surface.materials[surface.substrate_material]
        .lane(lane)
        .clone();
    let name = loaded
        .material_names
        .get(surface.substrate_material)
        .cloned()
        .unwrap_or_default();
    let others = if surface
        .materials
        .iter()
        .any(|x| x != &surface.materials[surface.substrate_material])
    {
        " (the scene has other materials too; the fit uses the substrate's)"
    } else {
        ""
    };
    let what = match &m {
        Reflectance::Constant(r) => format!("constant reflectance {r}"),
        Reflectance::Fresnel { n, k } => format!("Fresnel n = {n}, k = {k}"),
        Reflectance::Table(_) => "reflectance table".into(),
        Reflectance::Spectral(_) => "spectral".into(),
    };
    (
        m,
        format!("scene {scene}, material `{name}` of the surface: {what}{others}"),
    )
}

/// The micro scene at `path` (`None`: the embedded default) built at
/// `wavelengths_um` (µm; empty: as the scene says), for its material.
fn load_at(path: Option<&Path>, wavelengths_um: &[f64]) -> Result<MicroScene, String> {
    let overrides = Overrides {
        wavelengths_um: (!wavelengths_um.is_empty())
            .then(|| crate::scene::WavelengthsSpec::List(wavelengths_um.to_vec())),
        ..Default::default()
    };
    match path {
        Some(p) => MicroScene::load_with(p, &overrides),
        None => MicroScene::default_with(&overrides),
    }
    .map_err(|e| e.to_string())
}
