//! Writing outputs: one file atomically into place ([`write_file`]), a
//! result folder whole ([`write_folder`]), and the lines that say what a
//! replaced folder lost ([`removed_lines`]).

use std::io::Write as _;
use std::path::Path;

use super::check::{OutputError, escape_controls, shown};
use super::{Replaced, command, record_added};

/// Write `bytes` to `path` atomically, creating its folder. A file written
/// into a result folder is added to its record first ([`record_added`], as
/// written by the running command), so that a rerun knows it as roks's
/// own.
///
/// # Errors
/// [`OutputError::Write`], naming the path.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| OutputError::Write(format!("cannot create {}: {e}", dir.display())))?;
    }
    let _commit = crate::interrupt::commit();
    record_added(path, command()).map_err(|e| {
        OutputError::Write(format!(
            "cannot write the record of {}: {e}",
            path.display()
        ))
    })?;
    write_atomic(path, bytes)
        .map_err(|e| OutputError::Write(format!("cannot write {}: {e}", path.display())))?;
    crate::interrupt::kept(shown(path));
    Ok(())
}

/// Write the result folder `out` whole, `files` as (name, bytes), with the
/// record naming `command` as their writer: staged beside it, then swapped
/// in (see [`super`]); a reader never sees old and new files mixed. The
/// files that later commands had added to the old result, and those roks
/// did not write (only with `--force`), are named on stderr, one line each
/// ([`removed_lines`]).
///
/// # Errors
/// [`OutputError::Write`], naming the folder.
pub fn write_folder<N: AsRef<str>, B: AsRef<[u8]>>(
    out: &Path,
    files: &[(N, B)],
    command: &str,
) -> Result<(), OutputError> {
    let files: Vec<(&str, &[u8])> = files
        .iter()
        .map(|(n, b)| (n.as_ref(), b.as_ref()))
        .collect();
    // The swap and its note for an interrupt's line under one lock.
    let commit = crate::interrupt::commit();
    let replaced = super::write_folder(out, &files, command)
        .map_err(|e| OutputError::Write(format!("cannot write {}: {e}", out.display())))?;
    crate::interrupt::kept(shown(out));
    drop(commit);
    for line in removed_lines(out, &replaced) {
        eprintln!("roks: {}", escape_controls(&line));
    }
    Ok(())
}

/// The lines that say what replacing the result folder `out` removed
/// beside the old run's own files: the files later commands had added (they
/// were made from the old table, so they go with it) and those roks did not
/// write (`--force`).
#[must_use]
pub fn removed_lines(out: &Path, r: &Replaced) -> Vec<String> {
    let mut lines = Vec::new();
    if !r.added.is_empty() {
        let names: Vec<String> = r
            .added
            .iter()
            .map(|(f, by)| format!("{f} ({by})"))
            .collect();
        lines.push(format!(
            "{}: removed {}: added to the old result by later commands and made from its table, which this run replaced; run them again to remake them",
            shown(out),
            names.join(", ")
        ));
    }
    if !r.foreign.is_empty() {
        lines.push(format!(
            "--force: {}: removed {}, which roks did not write",
            shown(out),
            r.foreign.join(", ")
        ));
    }
    lines
}

/// Write `bytes` to `path` atomically (temporary sibling `.NAME.PID.tmp`,
/// synced, then renamed over `path`): a reader sees the old file or the new
/// one. Temporary files of killed writes of `path` are removed first. The
/// write holds the commit lock ([`crate::interrupt::commit`]): an
/// interrupt finds the old file or the new one, and no temporary file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let _commit = crate::interrupt::commit();
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    super::remove_stale_tmp(path);
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
