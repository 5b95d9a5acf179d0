//! The record of the files roks wrote into a result folder: the hidden
//! file [`RECORD`] (`.roks-files.json`) in the folder, written with it.
//!
//! ```json
//! {
//!   "roks": "0.1.0",
//!   "command": "brdf",
//!   "files": {
//!     "brdf.csv": "brdf",
//!     "fit_abg.json": "fit-model",
//!     ...
//!   }
//! }
//! ```
//!
//! `command` is the command that wrote the folder (`brdf`, `trace`,
//! `merge`, `fit`, `export-brdf` of a spectral Zemax set); `files` names
//! every file roks wrote into it and the command that wrote it: the run's
//! own files, and those that later commands (`export-brdf`, `fit-model`,
//! `plot`, any `--out` file) added, which are recorded before they are
//! written. A folder is replaced only when every entry in it is in its
//! record (or is the record itself, or a temporary file `.NAME.PID.tmp` of
//! a killed roks write). A folder written before the record existed (a
//! result marker, no record) is judged by name instead: every entry must
//! be a name roks writes ([`known_name`]).

use std::collections::BTreeMap;
use std::path::Path;

/// The record's file name in a result folder.
pub const RECORD: &str = super::file::ResultFile::Record.name();

/// The record of a result folder (see the module documentation).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Record {
    /// The roks version that wrote the folder.
    pub roks: String,
    /// The command that wrote the folder.
    pub command: String,
    /// Every file roks wrote into the folder, and the command that wrote it.
    pub files: BTreeMap<String, String>,
}

impl Record {
    /// The record of a folder that `command` writes with `files`.
    #[must_use]
    pub fn new<'a>(command: &str, files: impl IntoIterator<Item = &'a str>) -> Self {
        Self {
            roks: env!("CARGO_PKG_VERSION").to_owned(),
            command: command.to_owned(),
            files: files
                .into_iter()
                .map(|f| (f.to_owned(), command.to_owned()))
                .collect(),
        }
    }

    /// The record's bytes (pretty JSON, a final newline; the same files
    /// give the same bytes).
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut text = serde_json::to_string_pretty(self).unwrap_or_default();
        text.push('\n');
        text.into_bytes()
    }

    /// The record of the folder `dir`: `None` when it has none or it cannot
    /// be read as one.
    #[must_use]
    pub fn read(dir: &Path) -> Option<Self> {
        let bytes =
            crate::limits::read_capped(&dir.join(RECORD), crate::limits::MAX_SCENE_BYTES).ok()?;
        serde_json::from_slice(&bytes).ok()
    }

    /// The files that commands other than the folder's own added to it,
    /// with the commands that did.
    pub fn added(&self) -> impl Iterator<Item = (&str, &str)> {
        self.files
            .iter()
            .filter(|(_, by)| **by != self.command)
            .map(|(f, by)| (f.as_str(), by.as_str()))
    }
}

/// Whether `name` is a temporary file of an atomic write of roks
/// (`.NAME.PID.tmp`, [`crate::outdir::write::write_atomic`]), left by a kill.
#[must_use]
pub fn temporary(name: &str) -> bool {
    name.strip_prefix('.')
        .and_then(|r| r.strip_suffix(".tmp"))
        .and_then(|r| r.rsplit_once('.'))
        .is_some_and(|(file, pid)| {
            !file.is_empty() && !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit())
        })
}

/// Whether `name` is a file name roks writes into a result folder (its
/// tables, summaries, pictures, exports and fits, by name or pattern:
/// [`super::file`]): how a folder without a record (written by an earlier
/// roks) is judged.
#[must_use]
pub fn known_name(name: &str) -> bool {
    super::file::known(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert!(temporary(".brdf.csv.123.tmp"));
        assert!(!temporary(".brdf.csv.tmp"));
        assert!(!temporary("notes.tmp"));
        assert!(known_name("hemisphere_30deg.png"));
        assert!(known_name("fit_abg.json"));
        assert!(known_name("brdf_0.55um.bsdf"));
        assert!(!known_name("notes.txt"));
        assert!(!known_name("fit_.json"));
        assert!(!known_name("scene.toml"));
    }

    #[test]
    fn the_record_reads_back_and_names_what_was_added() {
        let mut r = Record::new("brdf", ["brdf.csv", "summary.json"]);
        r.files.insert("fit_abg.json".into(), "fit-model".into());
        let back: Record = serde_json::from_slice(&r.to_bytes()).unwrap();
        assert_eq!(back, r);
        assert_eq!(
            r.added().collect::<Vec<_>>(),
            [("fit_abg.json", "fit-model")]
        );
    }
}
