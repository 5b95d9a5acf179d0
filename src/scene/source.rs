//! Where a run's scene came from: a scene file, or the embedded default
//! scene. Recorded in `summary.json`'s `scene` (and in messages) as the
//! file's path, or as [`DEFAULT_SCENE`] for the embedded scene.

use std::path::{Path, PathBuf};

/// The text that stands for the embedded default scene where a scene
/// file's path would be (`summary.json`'s `scene`, messages).
pub const DEFAULT_SCENE: &str = "<default scene>";

/// Where a scene came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SceneSource {
    /// The embedded default scene (printed as [`DEFAULT_SCENE`]).
    Default,
    /// A scene file.
    File(PathBuf),
}

impl SceneSource {
    /// The source recorded as `text` (a path, or [`DEFAULT_SCENE`]).
    #[must_use]
    pub fn from_recorded(text: &str) -> Self {
        if text == DEFAULT_SCENE {
            Self::Default
        } else {
            Self::File(PathBuf::from(text))
        }
    }

    /// The scene file's path; `None` for the default scene.
    #[must_use]
    pub fn path(&self) -> Option<&Path> {
        match self {
            Self::Default => None,
            Self::File(p) => Some(p),
        }
    }
}

impl std::fmt::Display for SceneSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Default => f.write_str(DEFAULT_SCENE),
            Self::File(p) => write!(f, "{}", p.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scene_reads_back() {
        for text in [DEFAULT_SCENE, "scenes/a.toml"] {
            assert_eq!(SceneSource::from_recorded(text).to_string(), text);
        }
        assert_eq!(SceneSource::from_recorded(DEFAULT_SCENE).path(), None);
    }
}
