//! The output checks every command makes before any work: a result folder
//! ([`result_dir`], [`check_out_dir`]) or a single file
//! ([`check_out_file_as`]) can be written, and writing it destroys none of
//! the files the run reads ([`check_kept`]). Each refusal is one line
//! naming the option (or scene key) and the path ([`OutputError::Refused`]).

use std::path::{Path, PathBuf};

use super::file::ResultFile;
use super::kind::FileKind;
use super::{OutPathError, check_file, check_folder_shape, check_replace, replaces};

/// Why an output cannot be written: a refusal of the option or path given
/// (bad input), or a write that failed. One line each.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output is refused before any work (bad input), with its message.
    #[error("{0}")]
    Refused(String),
    /// Writing failed (the file system's error, naming the path).
    #[error("{0}")]
    Write(String),
}

/// The result folder: `given` (`--out`), or `out/<name>` (named in messages
/// by the scene file's `name` key), checked before any work is done: it
/// can be a result folder, and replacing it destroys none of `reads`, the
/// files the run reads ([`check_kept`]).
///
/// The default folder is never taken over from another scene file: when
/// `out/<name>` holds the result of a scene at another path (its
/// `summary.json` names it), the run is refused, so an edited copy of a
/// scene that kept its `name` cannot silently replace the original's
/// result. `--out` names a folder on purpose and may replace any result.
/// `force` (`--force`) replaces a result folder that holds files roks did
/// not write ([`super::check_folder`]).
///
/// # Errors
/// [`OutputError::Refused`] when the folder cannot be a result folder, or
/// is the default folder of another scene file.
pub fn result_dir(
    given: Option<&Path>,
    scene_file: &str,
    name: &str,
    reads: &[PathBuf],
    force: bool,
) -> Result<PathBuf, OutputError> {
    let Some(out) = given else {
        let out = Path::new("out").join(name);
        let key = format!("{scene_file}: name");
        check_out_dir(&out, &key, reads, force)?;
        if let Some(other) = recorded_scene(&out)
            .filter(|o| o != scene_file && !same_file(Path::new(o), Path::new(scene_file)))
        {
            return Err(OutputError::Refused(format!(
                "{key}: {} holds the result of {}, another scene named {name:?}; give --out, or another name",
                shown(&out),
                other.escape_debug()
            )));
        }
        return Ok(out);
    };
    check_out_dir(out, "--out", reads, force)?;
    Ok(out.to_path_buf())
}

/// The scene file recorded in the `summary.json` of the result folder
/// `out` (`None` when there is none to read).
fn recorded_scene(out: &Path) -> Option<String> {
    let text = std::fs::read(ResultFile::Summary.path_in(out)).ok()?;
    let v: serde_json::Value = serde_json::from_slice(&text).ok()?;
    v.get("scene")?.as_str().map(str::to_owned)
}

/// Whether `a` and `b` are one existing file: both resolve (links, `..`,
/// relative to the working folder) to the same path.
fn same_file(a: &Path, b: &Path) -> bool {
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}

/// Check a result folder before any work is done; `key` names it in the
/// message (`--out`, or `SCENE: name` for the default out/NAME), in this
/// order: it can be a result folder ([`check_folder_shape`]), replacing it
/// destroys none of `reads`, the files the run reads ([`check_kept`]), and
/// every file in it is roks's own unless `force` (`--force`,
/// [`super::Listing::check_foreign`]). The folder is listed and its record
/// read once.
///
/// # Errors
/// [`OutputError::Refused`] when the folder exists and is neither empty
/// nor a roks result, holds one of `reads`, or (without `force`) holds a
/// file roks did not write.
pub fn check_out_dir(
    out: &Path,
    key: &str,
    reads: &[PathBuf],
    force: bool,
) -> Result<(), OutputError> {
    let bad = |e| OutputError::Refused(format!("{key}: {}: {e}", shown(out)));
    let listing = check_folder_shape(out).map_err(bad)?;
    check_kept(key, &[Written::Folder(out)], reads)?;
    match listing {
        Some(l) => l.check_foreign(force).map_err(bad),
        None => Ok(()),
    }
}

/// Check an output file of `kind`, given by `option` (`--out`, `--png`),
/// before any work is done: it can be written as a file (not a folder, nor
/// a path ending in `/`; its folder can be made), writing it replaces none
/// of `inputs`, the files the command reads ([`check_kept`]), and a file
/// already there is that kind of roks output, or roks's by its folder's
/// record, or `force` (`--force`) is given ([`check_replace`]).
///
/// # Errors
/// [`OutputError::Refused`] when `out` cannot be written as a file, would
/// replace one of `inputs`, or is a file roks may not replace.
pub fn check_out_file_as(
    option: &str,
    out: &Path,
    inputs: &[PathBuf],
    kind: FileKind,
    force: bool,
) -> Result<(), OutputError> {
    let bad = |e: OutPathError| OutputError::Refused(format!("{option}: {}: {e}", shown(out)));
    check_file(out).map_err(bad)?;
    check_kept(option, &[Written::File(out)], inputs)?;
    check_replace(out, kind, force).map_err(bad)
}

/// What a command writes, to be checked against what it reads.
#[derive(Debug, Clone, Copy)]
pub enum Written<'a> {
    /// A result folder, replaced whole (every file in it goes).
    Folder(&'a Path),
    /// One file, replaced.
    File(&'a Path),
}

/// The one decision, for every command, that its outputs destroy no input:
/// refuse (naming `option`) when one of `outputs` is, holds (a folder
/// replaced whole) or would replace one of `inputs` (the scene, every file
/// it names, a table wall's files, merged folders), however either path is
/// spelt: symbolic links, `..`, trailing `/`, hard links ([`replaces`]).
/// Call it before any work.
///
/// # Errors
/// [`OutputError::Refused`] naming the option, the output and the input.
pub fn check_kept(
    option: &str,
    outputs: &[Written<'_>],
    inputs: &[PathBuf],
) -> Result<(), OutputError> {
    for w in outputs {
        let (out, folder) = match *w {
            Written::Folder(p) => (p, true),
            Written::File(p) => (p, false),
        };
        if let Some(input) = inputs.iter().find(|i| replaces(out, folder, i)) {
            let how = if folder && !replaces(out, false, input) {
                "holds"
            } else {
                "is"
            };
            return Err(OutputError::Refused(format!(
                "{option}: {}: {how} {}, a file this run reads, which writing {} would destroy; write elsewhere",
                shown(out),
                shown(input),
                if folder {
                    "the folder (replaced whole)"
                } else {
                    "it"
                }
            )));
        }
    }
    Ok(())
}

/// `path` for a message: as given, with control characters (a newline in
/// a file name) escaped as `\n`, `\u{1b}`, so that every message stays one
/// line.
#[must_use]
pub fn shown(path: &Path) -> String {
    escape_controls(&path.display().to_string())
}

/// `text` with its control characters escaped (`\n`, `\t`, `\u{7f}`).
#[must_use]
pub fn escape_controls(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The refusals of a result folder come in one order: its shape, then
    /// the inputs it would destroy, then the files roks did not write
    /// (which `--force` lets go).
    #[test]
    fn a_folder_is_refused_for_its_shape_then_its_inputs_then_its_files() {
        let d = std::env::temp_dir().join(format!("roks-outdir-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        let out = d.join("r");
        let summary = br#"{"version": "0.1.0"}"#.as_slice();
        super::super::write_folder(&out, &[("summary.json", summary)], "brdf").unwrap();
        std::fs::write(out.join("scene.toml"), b"mine").unwrap();
        let reads = [out.join("scene.toml")];
        let message = |reads: &[PathBuf], force| match check_out_dir(&out, "--out", reads, force) {
            Err(OutputError::Refused(m)) => m,
            other => panic!("{other:?}"),
        };
        let shown_out = shown(&out);
        // The input the run reads, before the file roks did not write.
        let m = message(&reads, false);
        assert!(
            m.starts_with(&format!("--out: {shown_out}: holds "))
                && m.ends_with("a file this run reads, which writing the folder (replaced whole) would destroy; write elsewhere"),
            "{m}"
        );
        assert!(
            message(&[], false).contains("holds the file \"scene.toml\", which roks did not write")
        );
        assert!(check_out_dir(&out, "--out", &[], true).is_ok());
        // Not a result folder: refused for that first, even with --force.
        std::fs::remove_file(out.join("summary.json")).unwrap();
        assert!(message(&reads, true).contains("not a roks result folder"));
        let _ = std::fs::remove_dir_all(&d);
    }
}
