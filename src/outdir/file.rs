//! Every file a result folder can hold, by name and kind: the one home of
//! their names. Writers and readers name a file by its [`ResultFile`] (a
//! fixed name: `summary.json`, `brdf.csv`, `brdf.bsdf`...) or its
//! [`ResultPattern`] (a name made from a value: `dop_<θ>deg.png`,
//! `brdf_<λ>um.bsdf`, `fit_<model>.json`...), never by a string literal.
//!
//! A folder written before the record existed is judged by these names
//! ([`super::record::known_name`]).

use std::path::Path;

use super::kind::FileKind;

/// What a file of a result folder is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A table of results (CSV): `brdf.csv`, `mueller.csv`, `reflectance.csv`...
    Table,
    /// The run's description and summary (`summary.json`), or a fit's
    /// (`fit.json`), or a folder of exports' (`export.json`): what marks a
    /// folder as a roks result ([`ResultFile::MARKERS`]).
    Description,
    /// The raw sums of a shard or a merge (`tallies.json`).
    Shard,
    /// A BRDF exported for another program (Zemax, MERL, RGL, pbsdf).
    Export,
    /// A fit of a model or a scene (`fit-model`, `fit`).
    Fit,
    /// A picture (PNG).
    Picture,
    /// The interactive report of the folder (`report.html`).
    Report,
    /// The record of the files roks wrote ([`super::record`]).
    Record,
}

/// A file of a result folder with a fixed name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ResultFile {
    /// `summary.json`: the run (`roks brdf`, `trace`, `merge`) and its sums.
    Summary,
    /// `brdf.csv`: the BRDF per incidence and Carlson cell.
    Brdf,
    /// `inplane.csv`: the in-plane BRDF.
    Inplane,
    /// `tallies.json`: the raw sums of a shard or a merge.
    Tallies,
    /// `stokes.csv`: the Stokes vectors per cell.
    Stokes,
    /// `mueller.csv`: the Mueller matrices per cell.
    Mueller,
    /// `colour.csv`: the colour of the BRDF per cell (a spectral run).
    Colour,
    /// `reflectance.csv`: reflectance per beam position (`roks trace`).
    Reflectance,
    /// `farfield.csv`: the far field of an object run.
    Farfield,
    /// `farfield_stokes.csv`: its Stokes vectors.
    FarfieldStokes,
    /// `fit.json`: the summary of `roks fit`.
    Fit,
    /// `fitted.toml`: the scene fitted by `roks fit`.
    Fitted,
    /// `fit_inplane.csv`: the fitted in-plane BRDF of `roks fit`.
    FitInplane,
    /// `export.json`: the marker of a folder of per-wavelength exports.
    Export,
    /// `surface.png`: the height map of the micro surface.
    SurfacePicture,
    /// `inplane.png`: the in-plane BRDF.
    InplanePicture,
    /// `reflectance.png`: reflectance against incidence or beam position.
    ReflectancePicture,
    /// `brdf.bsdf`: the Zemax tabular BSDF.
    Zemax,
    /// `brdf.binary`: the MERL BRDF.
    Merl,
    /// `brdf_rgl.bsdf`: the RGL tensor file.
    Rgl,
    /// `brdf.pbsdf`: the polarised tensor file.
    Pbsdf,
    /// `fit_abg_opticstudio.txt`: ABg for OpticStudio.
    AbgOpticStudio,
    /// `fit_harvey_fred.txt`: Harvey-Shack for FRED.
    HarveyFred,
    /// `fit_abg_fred.txt`: ABg for FRED.
    AbgFred,
    /// `fit_summary.json`: the ranking of `fit-model --model all`.
    FitRanking,
    /// `report.html`: the interactive report of the folder.
    Report,
    /// `.roks-files.json`: the record of the files roks wrote.
    Record,
}

impl ResultFile {
    /// Every fixed-name file.
    pub const ALL: [Self; 27] = [
        Self::Summary,
        Self::Brdf,
        Self::Inplane,
        Self::Tallies,
        Self::Stokes,
        Self::Mueller,
        Self::Colour,
        Self::Reflectance,
        Self::Farfield,
        Self::FarfieldStokes,
        Self::Fit,
        Self::Fitted,
        Self::FitInplane,
        Self::Export,
        Self::SurfacePicture,
        Self::InplanePicture,
        Self::ReflectancePicture,
        Self::Zemax,
        Self::Merl,
        Self::Rgl,
        Self::Pbsdf,
        Self::AbgOpticStudio,
        Self::HarveyFred,
        Self::AbgFred,
        Self::FitRanking,
        Self::Report,
        Self::Record,
    ];

    /// The files by which a folder is recognised as a roks result (with a
    /// `version` key inside): a run's summary, a fit's, a folder of
    /// per-wavelength exports'.
    pub const MARKERS: [Self; 3] = [Self::Summary, Self::Fit, Self::Export];

    /// The file's name in the folder.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Summary => "summary.json",
            Self::Brdf => "brdf.csv",
            Self::Inplane => "inplane.csv",
            Self::Tallies => "tallies.json",
            Self::Stokes => "stokes.csv",
            Self::Mueller => "mueller.csv",
            Self::Colour => "colour.csv",
            Self::Reflectance => "reflectance.csv",
            Self::Farfield => "farfield.csv",
            Self::FarfieldStokes => "farfield_stokes.csv",
            Self::Fit => "fit.json",
            Self::Fitted => "fitted.toml",
            Self::FitInplane => "fit_inplane.csv",
            Self::Export => "export.json",
            Self::SurfacePicture => "surface.png",
            Self::InplanePicture => "inplane.png",
            Self::ReflectancePicture => "reflectance.png",
            Self::Zemax => "brdf.bsdf",
            Self::Merl => "brdf.binary",
            Self::Rgl => "brdf_rgl.bsdf",
            Self::Pbsdf => "brdf.pbsdf",
            Self::AbgOpticStudio => "fit_abg_opticstudio.txt",
            Self::HarveyFred => "fit_harvey_fred.txt",
            Self::AbgFred => "fit_abg_fred.txt",
            Self::FitRanking => "fit_summary.json",
            Self::Report => "report.html",
            Self::Record => ".roks-files.json",
        }
    }

    /// What the file is for.
    #[must_use]
    pub const fn kind(self) -> Kind {
        match self {
            Self::Brdf
            | Self::Inplane
            | Self::Stokes
            | Self::Mueller
            | Self::Colour
            | Self::Reflectance
            | Self::Farfield
            | Self::FarfieldStokes => Kind::Table,
            Self::Summary | Self::Fit | Self::Export => Kind::Description,
            Self::Tallies => Kind::Shard,
            Self::Zemax | Self::Merl | Self::Rgl | Self::Pbsdf => Kind::Export,
            Self::Fitted
            | Self::FitInplane
            | Self::AbgOpticStudio
            | Self::HarveyFred
            | Self::AbgFred
            | Self::FitRanking => Kind::Fit,
            Self::SurfacePicture | Self::InplanePicture | Self::ReflectancePicture => Kind::Picture,
            Self::Report => Kind::Report,
            Self::Record => Kind::Record,
        }
    }

    /// The kind of single-file output it is, as its bytes tell
    /// ([`FileKind::recognises`]), for those roks recognises.
    #[must_use]
    pub const fn file_kind(self) -> Option<FileKind> {
        match self {
            Self::Zemax => Some(FileKind::Zemax),
            Self::Merl => Some(FileKind::Merl),
            Self::Rgl => Some(FileKind::Rgl),
            Self::Pbsdf => Some(FileKind::Pbsdf),
            Self::SurfacePicture | Self::InplanePicture | Self::ReflectancePicture => {
                Some(FileKind::Png)
            }
            Self::FitRanking => Some(FileKind::FitJson),
            Self::Report => Some(FileKind::Report),
            Self::AbgOpticStudio | Self::HarveyFred | Self::AbgFred => Some(FileKind::FitText),
            _ => None,
        }
    }

    /// The file of this name, if any.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The file in the folder `dir`.
    #[must_use]
    pub fn path_in(self, dir: &Path) -> std::path::PathBuf {
        dir.join(self.name())
    }
}

impl std::fmt::Display for ResultFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl AsRef<Path> for ResultFile {
    fn as_ref(&self) -> &Path {
        Path::new(self.name())
    }
}

impl AsRef<str> for ResultFile {
    fn as_ref(&self) -> &str {
        self.name()
    }
}

/// A file of a result folder whose name is made from a value (an angle, a
/// wavelength, a model): `PREFIX<value>SUFFIX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ResultPattern {
    /// `hemisphere_<θ>deg.png`: the hemisphere map of one incidence.
    Hemisphere,
    /// `dop_<θ>deg.png`: the degree of polarisation of one incidence.
    Dop,
    /// `mueller_<θ>deg.png` (also `mueller_stderr_<θ>deg.png`, and with
    /// `_<λ>um` before `.png`): the Mueller maps of one incidence.
    Mueller,
    /// `colour_<θ>deg.png`: the colour of the BRDF of one incidence.
    Colour,
    /// `brdf_<λ>um.bsdf`: the Zemax table of one wavelength.
    ZemaxAt,
    /// `fit_<model>.json`: a fit of `fit-model`.
    FitJson,
    /// `fit_<model>.png`: its plot.
    FitPicture,
    /// `fit_<model>_opticstudio.txt`: its OpticStudio text.
    FitOpticStudio,
}

impl ResultPattern {
    /// Every pattern.
    pub const ALL: [Self; 8] = [
        Self::Hemisphere,
        Self::Dop,
        Self::Mueller,
        Self::Colour,
        Self::ZemaxAt,
        Self::FitJson,
        Self::FitPicture,
        Self::FitOpticStudio,
    ];

    /// The text before and after the value.
    #[must_use]
    pub const fn parts(self) -> (&'static str, &'static str) {
        match self {
            Self::Hemisphere => ("hemisphere_", ".png"),
            Self::Dop => ("dop_", ".png"),
            Self::Mueller => ("mueller_", ".png"),
            Self::Colour => ("colour_", ".png"),
            Self::ZemaxAt => ("brdf_", "um.bsdf"),
            Self::FitJson => ("fit_", ".json"),
            Self::FitPicture => ("fit_", ".png"),
            Self::FitOpticStudio => ("fit_", "_opticstudio.txt"),
        }
    }

    /// What the file is for.
    #[must_use]
    pub const fn kind(self) -> Kind {
        match self {
            Self::Hemisphere | Self::Dop | Self::Mueller | Self::Colour => Kind::Picture,
            Self::ZemaxAt => Kind::Export,
            Self::FitJson | Self::FitPicture | Self::FitOpticStudio => Kind::Fit,
        }
    }

    /// The name of the file of `value` (`dop_30deg.png` for `30deg` ...):
    /// `PREFIX<value>SUFFIX`.
    #[must_use]
    pub fn name(self, value: &str) -> String {
        let (p, s) = self.parts();
        format!("{p}{value}{s}")
    }

    /// Whether `name` is a file of this pattern (with a value that is not
    /// empty).
    #[must_use]
    pub fn matches(self, name: &str) -> bool {
        let (p, s) = self.parts();
        name.len() > p.len() + s.len() && name.starts_with(p) && name.ends_with(s)
    }
}

/// Whether `name` is a file roks writes into a result folder, by name or
/// pattern (the record itself excepted).
#[must_use]
pub fn known(name: &str) -> bool {
    ResultFile::from_name(name).is_some_and(|f| f != ResultFile::Record)
        || ResultPattern::ALL.iter().any(|p| p.matches(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_read_back() {
        for f in ResultFile::ALL {
            assert_eq!(ResultFile::from_name(f.name()), Some(f));
        }
        assert_eq!(ResultPattern::Dop.name("30deg"), "dop_30deg.png");
        assert!(ResultPattern::FitJson.matches("fit_abg.json"));
        assert!(!ResultPattern::FitJson.matches("fit_.json"));
        assert!(known("summary.json") && known("brdf_0.55um.bsdf"));
        assert!(!known(".roks-files.json") && !known("notes.txt"));
    }
}
