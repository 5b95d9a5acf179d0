//! Output paths: result folders replaced whole, single files replaced
//! atomically, and both checked before any work is done.
//!
//! A result folder (`roks brdf`, `trace`, `merge`, `fit`) is the run's: the
//! run is written into a fresh hidden sibling `PARENT/.NAME.new-PID`, synced,
//! and swapped in with one rename, so a reader of `PARENT/NAME` sees either
//! the whole old result or the whole new one, never a mixture, and no file of
//! an earlier run survives a rerun (hemisphere maps of angles no longer run, a
//! `tallies.json` of an earlier `--shard` run, an old `brdf.bsdf` or a file
//! `roks export-brdf` added). On Linux the swap is one
//! `renameat2(RENAME_EXCHANGE)`; elsewhere, or where the file system lacks
//! it, the old folder is first renamed to `PARENT/.NAME.old-PID` and the new
//! one renamed in (a reader may then find no folder for that instant; a kill
//! between the two renames leaves the old result in `.NAME.old-PID`). The
//! old folder is deleted after the swap.
//!
//! A run killed before its swap leaves only its hidden `.NAME.new-PID` (or
//! `.NAME.old-PID`, or a file's `.FILE.PID.tmp`) behind; the next write of
//! the same NAME removes those whose process is gone. Folders of live
//! processes are left alone.
//!
//! An existing folder is only replaced when it is empty or a roks result (it
//! holds a `summary.json` or `fit.json` with a `version`, and no subfolder):
//! anything else is refused before tracing, so `--out ~/Documents` cannot
//! delete a folder roks did not write. A result folder is only replaced
//! when every file in it is roks's own: each folder carries the record of
//! the files roks wrote into it ([`record`]); a file not in it (a user's
//! `notes.txt`) is refused by name before any work, unless `--force`. A
//! rerun removes the files later commands had added to the old result
//! (they were made from its table) and says so in one line.

use std::io::Write as _;
use std::path::{Component, Path, PathBuf};

pub mod check;
pub mod file;
pub mod kind;
pub mod record;
pub mod write;

use file::ResultFile;
use kind::FileKind;
use record::{RECORD, Record};

/// Longest scene name, in bytes, that [`check_name`] accepts as a folder
/// name (a file name may have 255; the staging suffix needs room).
pub const MAX_NAME_BYTES: usize = 200;

/// Why a result folder or file cannot be written at a path ([`check_folder`],
/// [`check_file`]): the reason, for a message after the option and path.
#[derive(Debug, thiserror::Error)]
pub enum OutPathError {
    /// `/`, `.`, `..`: no name to create.
    #[error("must name a file or folder to create (not `/`, `.` or `..`)")]
    NoName,
    /// An ancestor that is a file.
    #[error("{} is a file, not a folder", .0.display())]
    AncestorIsFile(PathBuf),
    /// The file system's refusal to look at `path`.
    #[error("{}: {source}", path.display())]
    Metadata {
        /// The path looked at.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// Nothing can be created in the nearest existing folder.
    #[error("cannot create anything in {}: {source}", folder.display())]
    NotWritable {
        /// The folder.
        folder: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The existing folder cannot be listed.
    #[error("cannot read the folder: {0}")]
    Unreadable(std::io::Error),
    /// An existing folder that is not a roks result (`why`: what it holds).
    #[error(
        "exists and {0}, so it is not a roks result folder, which a run replaces whole; choose a new folder"
    )]
    NotAResult(NotAResult),
    /// A roks result folder that holds a file roks did not write.
    #[error(
        "holds the file {0:?}, which roks did not write; the run replaces the folder whole and would delete it: move the file, write elsewhere, or give --force to replace the folder anyway"
    )]
    Foreign(std::ffi::OsString),
    /// A symbolic link to a file where a folder is wanted.
    #[error("is a link to a file, not a folder")]
    LinkToFile,
    /// A symbolic link to nothing.
    #[error("is a dangling symbolic link ({0})")]
    Dangling(std::io::Error),
    /// A file where a folder is wanted.
    #[error("is a file, not a folder")]
    IsFile,
    /// A folder where a file is wanted.
    #[error("is a folder, not a file")]
    IsFolder,
    /// An existing file that is not the kind of roks output to be written.
    #[error(
        "exists and is not {} that roks wrote, so it is kept: write elsewhere, or give --force to replace it",
        .0.what()
    )]
    NotOurs(FileKind),
    /// An existing path that is not a regular file (a FIFO, a device).
    #[error("exists and is not a regular file, so it is not replaced; write elsewhere")]
    NotRegular,
    /// A path ending in `/` where a file is wanted.
    #[error("ends with `/`, so it names a folder; a file is written here")]
    SlashEnded,
    /// A symbolic link that cannot be resolved.
    #[error("cannot resolve the symbolic link: {0}")]
    Resolve(std::io::Error),
    /// The folder beside a replaced result cannot be written.
    #[error("{0} (a result folder is replaced whole, beside itself)")]
    Beside(Box<OutPathError>),
    /// Another error of the file system.
    #[error("{0}")]
    Io(std::io::Error),
}

/// What makes an existing folder not a roks result ([`OutPathError::NotAResult`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NotAResult {
    /// It holds a subfolder.
    #[error("holds the folder {0:?}")]
    Subfolder(std::ffi::OsString),
    /// No result marker with a `version`.
    #[error(
        "has no roks {}, {} or {}",
        ResultFile::Summary,
        ResultFile::Fit,
        ResultFile::Export
    )]
    NoMarker,
}

/// Why a name cannot be the result folder `out/NAME` ([`check_name`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{why}: the name is the result folder out/NAME, so it must be one plain folder name, got {name:?}"
)]
pub struct NameError {
    /// What is wrong with it.
    pub why: NameProblem,
    /// The name.
    pub name: String,
}

/// What is wrong with a result folder's name ([`NameError`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameProblem {
    /// No name.
    #[error("is empty")]
    Empty,
    /// A separator or control character.
    #[error("contains {0:?}")]
    Contains(char),
    /// A leading `.`.
    #[error("starts with `.` (`.` and `..` lead outside out/, others are hidden)")]
    Dot,
    /// Too long.
    #[error("is {0} bytes long (at most {MAX_NAME_BYTES})")]
    TooLong(usize),
}

/// Why `name` cannot be the name of a result folder `out/NAME`, or `None`
/// when it can: it must be one plain path component (not empty, no `/`,
/// `\`, NUL or control character, not starting with `.`, which also rules
/// out `.` and `..`), at most [`MAX_NAME_BYTES`] bytes.
#[must_use]
pub fn check_name(name: &str) -> Option<NameError> {
    let why = if name.is_empty() {
        NameProblem::Empty
    } else if let Some(c) = name
        .chars()
        .find(|&c| c == '/' || c == '\\' || c.is_control())
    {
        NameProblem::Contains(c)
    } else if name.starts_with('.') {
        NameProblem::Dot
    } else if name.len() > MAX_NAME_BYTES {
        NameProblem::TooLong(name.len())
    } else {
        return None;
    };
    Some(NameError {
        why,
        name: name.to_owned(),
    })
}

/// The parent folder of `path` (`.` for a bare name) and its last
/// component, or why `path` names no file or folder (`/`, `..`, `a/..`).
/// The parent is rebuilt from the components, so that `a/b/.` is `a` and
/// `b`, as the file system sees it.
fn split(path: &Path) -> Result<(PathBuf, std::ffi::OsString), OutPathError> {
    let mut components = path.components();
    match components.next_back() {
        Some(Component::Normal(name)) => {
            let parent = components.as_path();
            let parent = if parent.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                parent.to_path_buf()
            };
            Ok((parent, name.to_os_string()))
        }
        _ => Err(OutPathError::NoName),
    }
}

/// Whether a metadata error means that nothing is there (a missing path, or
/// one that runs through a file: then the file is reported).
fn absent(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory
    )
}

/// Check that a folder can be created in `parent` (creating the missing
/// part of it later): its nearest existing ancestor is a folder in which a
/// folder can be made (tried: made and removed, which also catches read-only
/// file systems and `/proc`, where permission bits do not tell).
fn check_parent(parent: &Path) -> Result<(), OutPathError> {
    let mut p = parent;
    let existing = loop {
        match std::fs::metadata(p) {
            Ok(m) if m.is_dir() => break p,
            Ok(_) => return Err(OutPathError::AncestorIsFile(p.to_path_buf())),
            Err(e) if absent(&e) => match p.parent().filter(|q| !q.as_os_str().is_empty()) {
                Some(q) => p = q,
                None => break Path::new("."),
            },
            Err(source) => {
                return Err(OutPathError::Metadata {
                    path: p.to_path_buf(),
                    source,
                });
            }
        }
    };
    remove_stale(existing, &[(".roks-probe-".into(), "")]);
    let probe = existing.join(format!(".roks-probe-{}", std::process::id()));
    std::fs::create_dir(&probe)
        .and_then(|()| std::fs::remove_dir(&probe))
        .map_err(|source| OutPathError::NotWritable {
            folder: existing.to_path_buf(),
            source,
        })
}

/// Whose an entry of a result folder is ([`Listing`]).
#[derive(Debug, Clone, PartialEq, Eq)]
enum Owner {
    /// The record itself, or a temporary file of a killed roks write.
    Roks,
    /// A file the folder's own command wrote.
    Run,
    /// A file a later command added (the command; `an earlier roks` in a
    /// folder without a record).
    Added(String),
    /// A file roks did not write.
    Foreign,
}

/// The entries of an existing folder, sorted by name, each with its owner
/// by the folder's record ([`record`]; a folder without one: by name,
/// [`record::known_name`]): the folder listed and its record read once,
/// for every check and report on it.
#[derive(Debug, Clone)]
pub struct Listing {
    /// The folder (a symbolic link's target).
    dir: PathBuf,
    /// Each entry's name, whether it is a folder, and its owner.
    entries: Vec<(std::ffi::OsString, bool, Owner)>,
}

impl Listing {
    /// List `dir` and judge its entries.
    fn read(dir: &Path) -> std::io::Result<Self> {
        let rec = Record::read(dir);
        let mut entries: Vec<(std::ffi::OsString, bool, Owner)> = std::fs::read_dir(dir)?
            .map(|e| {
                let e = e?;
                let name = e.file_name();
                let owner = name
                    .to_str()
                    .map_or(Owner::Foreign, |n| owner(n, rec.as_ref()));
                Ok((name, e.file_type().is_ok_and(|t| t.is_dir()), owner))
            })
            .collect::<std::io::Result<_>>()?;
        entries.sort_by(|a, b| a.0.cmp(&b.0));
        Ok(Self {
            dir: dir.to_path_buf(),
            entries,
        })
    }

    /// Whether the folder may be replaced by a new result as a folder:
    /// empty, or a roks result (no subfolder, and a
    /// [`ResultFile::MARKERS`] file with a `version`). Its files are
    /// [`Self::check_foreign`]'s.
    ///
    /// # Errors
    /// [`OutPathError::NotAResult`].
    fn check_shape(&self) -> Result<(), OutPathError> {
        if self.entries.is_empty() {
            return Ok(());
        }
        let refuse = |why| Err(OutPathError::NotAResult(why));
        if let Some(sub) = self.entries.iter().find(|e| e.1) {
            return refuse(NotAResult::Subfolder(sub.0.clone()));
        }
        if !marked(&self.dir) {
            return refuse(NotAResult::NoMarker);
        }
        Ok(())
    }

    /// Check that every file of the folder is roks's own, unless `force`.
    ///
    /// # Errors
    /// [`OutPathError::Foreign`], naming the first such file.
    pub fn check_foreign(&self, force: bool) -> Result<(), OutPathError> {
        match self.foreign().next() {
            Some(name) if !force => Err(OutPathError::Foreign(name.clone())),
            _ => Ok(()),
        }
    }

    /// The entries roks did not write, sorted by name.
    fn foreign(&self) -> impl Iterator<Item = &std::ffi::OsString> {
        self.entries
            .iter()
            .filter(|e| e.2 == Owner::Foreign)
            .map(|e| &e.0)
    }

    /// What writing `new` (file names) over the folder removes beside the
    /// old run's own files ([`Replaced`]).
    fn replaced(&self, new: &[&str]) -> Replaced {
        let mut out = Replaced::default();
        for (name, _, owner) in &self.entries {
            let name = name.to_string_lossy().into_owned();
            if new.contains(&name.as_str()) {
                continue;
            }
            match owner {
                Owner::Added(by) => out.added.push((name, by.clone())),
                Owner::Foreign => out.foreign.push(name),
                Owner::Roks | Owner::Run => {}
            }
        }
        out
    }
}

/// The owner of the entry `name` of a result folder with the record `rec`
/// (`None`: a folder of an earlier roks, judged by name).
fn owner(name: &str, rec: Option<&Record>) -> Owner {
    if name == RECORD || record::temporary(name) {
        return Owner::Roks;
    }
    match rec {
        Some(r) => match r.files.get(name) {
            Some(by) if *by != r.command => Owner::Added(by.clone()),
            Some(_) => Owner::Run,
            None => Owner::Foreign,
        },
        None if record::known_name(name) => Owner::Added("an earlier roks".to_owned()),
        None => Owner::Foreign,
    }
}

/// Whether `dir` holds a [`ResultFile::MARKERS`] file with a `version`.
fn marked(dir: &Path) -> bool {
    ResultFile::MARKERS.iter().any(|m| {
        crate::limits::read_capped(&m.path_in(dir), crate::limits::MAX_SCENE_BYTES)
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .is_some_and(|v| v.get("version").is_some_and(serde_json::Value::is_string))
    })
}

/// The entries of the result folder `dir` that roks did not write, sorted
/// by name: not in its record ([`record`]), nor the record itself, nor a
/// temporary file of a killed roks write; a folder without a record (an
/// earlier roks's): those whose names roks does not write
/// ([`record::known_name`]).
#[must_use]
pub fn foreign(dir: &Path) -> Vec<std::ffi::OsString> {
    Listing::read(dir)
        .map(|l| l.foreign().cloned().collect())
        .unwrap_or_default()
}

/// Check, before any work, that a result folder can be written at `path`
/// (a symbolic link to a folder: at its target, which is replaced). The
/// error is the reason, for a message after the option and path.
///
/// With `force`, a roks result folder is replaced even when it holds files
/// roks did not write (never a folder that is not a roks result, nor one
/// that holds a folder). The same as [`check_folder_shape`], then
/// [`Listing::check_foreign`] of the folder it found.
///
/// # Errors
/// `path` is a file or a link to one, names no folder (`/`, `..`), is a
/// folder that is neither empty nor a roks result, or one that holds a file
/// roks did not write (without `force`), or no folder can be created
/// beside it.
pub fn check_folder(path: &Path, force: bool) -> Result<(), OutPathError> {
    match check_folder_shape(path)? {
        Some(listing) => listing.check_foreign(force),
        None => Ok(()),
    }
}

/// The shape part of [`check_folder`]: `path` can be a result folder (it
/// is none, or an empty folder or a roks result, and a folder can be
/// created beside it), whoever wrote its files. The existing folder's
/// [`Listing`] (`None` when there is none), for the check of its files.
///
/// # Errors
/// As [`check_folder`], but for a file roks did not write.
pub fn check_folder_shape(path: &Path) -> Result<Option<Listing>, OutPathError> {
    let (parent, name) = split(path)?;
    let path = &parent.join(name);
    match std::fs::symlink_metadata(path) {
        Ok(m) => {
            let target = if m.file_type().is_symlink() {
                match std::fs::metadata(path) {
                    Ok(t) if t.is_dir() => resolve(path)?,
                    Ok(_) => return Err(OutPathError::LinkToFile),
                    Err(e) => return Err(OutPathError::Dangling(e)),
                }
            } else if m.is_dir() {
                path.to_path_buf()
            } else {
                return Err(OutPathError::IsFile);
            };
            let listing = Listing::read(&target).map_err(OutPathError::Unreadable)?;
            listing.check_shape()?;
            check_parent(&split(&target)?.0).map_err(|e| OutPathError::Beside(Box::new(e)))?;
            Ok(Some(listing))
        }
        Err(e) if absent(&e) => check_parent(&parent).map(|()| None),
        Err(e) => Err(OutPathError::Io(e)),
    }
}

/// `path`, or its target when it is a symbolic link.
fn resolve(path: &Path) -> Result<PathBuf, OutPathError> {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        std::fs::canonicalize(path).map_err(OutPathError::Resolve)
    } else {
        Ok(path.to_path_buf())
    }
}

/// Check, before any work, that a single file can be written at `path` (not
/// a folder; its folder can be created and written). Whether a file there
/// may be replaced is [`check_replace`]'s.
///
/// # Errors
/// The reason, as for [`check_folder`].
pub fn check_file(path: &Path) -> Result<(), OutPathError> {
    let (parent, _) = split(path)?;
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        return Err(OutPathError::IsFolder);
    }
    let text = path.as_os_str().as_encoded_bytes();
    if text.ends_with(b"/") || text.ends_with(b"/.") || text == b"." {
        return Err(OutPathError::SlashEnded);
    }
    check_parent(&parent)
}

/// Check, before any work, that the file at `path`, if any, may be
/// replaced by a single-file output of `kind`: there is none (or a
/// dangling link), it is empty, it is that kind of roks output by its own
/// bytes ([`FileKind::recognises`]), or the record of the result folder it
/// is in lists it (a folder of an earlier roks without a record: a name
/// roks writes there); with `force`, any regular file. Never a FIFO or
/// device.
///
/// # Errors
/// [`OutPathError::NotOurs`], [`OutPathError::NotRegular`], or the path
/// names no file.
pub fn check_replace(path: &Path, kind: FileKind, force: bool) -> Result<(), OutPathError> {
    let (parent, name) = split(path)?;
    let (parent, name) = (parent.as_path(), name.as_os_str());
    let Ok(m) = std::fs::metadata(path) else {
        return Ok(());
    };
    if !m.is_file() {
        return Err(OutPathError::NotRegular);
    }
    let recorded = || {
        let name = name.to_string_lossy();
        Record::read(parent).map_or_else(
            || marked(parent) && record::known_name(&name),
            |r| r.files.contains_key(name.as_ref()),
        )
    };
    if force || m.len() == 0 || kind.recognises(path) || recorded() {
        Ok(())
    } else {
        Err(OutPathError::NotOurs(kind))
    }
}

/// `path` as the system reaches it: absolute (from the working folder), its
/// existing part resolved (symbolic links, `.`, `..`), the rest (which does
/// not exist yet) normalised by name. Two spellings of one place give the
/// same path; a trailing `/` is no part of it.
#[must_use]
pub fn resolved(path: &Path) -> PathBuf {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(path)
    };
    let mut out = PathBuf::new();
    let mut exists = true;
    for c in abs.components() {
        match c {
            Component::Prefix(_) | Component::RootDir => out.push(c.as_os_str()),
            Component::CurDir => {}
            // `out` is resolved (no link in it) or names nothing yet: its
            // parent is the parent by name.
            Component::ParentDir => {
                out.pop();
            }
            Component::Normal(n) => {
                out.push(n);
                if exists {
                    match std::fs::canonicalize(&out) {
                        Ok(p) => out = p,
                        Err(_) => exists = false,
                    }
                }
            }
        }
    }
    out
}

/// The places `path` stands for: [`resolved`], and its folder resolved
/// with its own last name kept (a symbolic link itself, which a rename
/// replaces and a folder swap deletes).
fn places(path: &Path) -> Vec<PathBuf> {
    let mut v = vec![resolved(path)];
    if let Ok((parent, name)) = split(path) {
        v.push(resolved(&parent).join(name));
    }
    v
}

/// Whether writing `out`, a result folder replaced whole (`folder`) or one
/// file, would replace, delete or overwrite `input`, a file or folder the
/// run reads: `out` is `input` (however either is spelt: links, `..`,
/// trailing `/`, hard links of one file), or, for a folder, holds it.
#[must_use]
pub fn replaces(out: &Path, folder: bool, input: &Path) -> bool {
    let (outs, ins) = (places(out), places(input));
    let hit = outs.iter().any(|o| {
        ins.iter()
            .any(|i| if folder { i.starts_with(o) } else { i == o })
    });
    hit || same_inode(out, input)
}

/// Whether `a` and `b` exist and are one file (one inode: hard links too).
fn same_inode(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        matches!(
            (std::fs::metadata(a), std::fs::metadata(b)),
            (Ok(x), Ok(y)) if (x.dev(), x.ino()) == (y.dev(), y.ino())
        )
    }
    #[cfg(not(unix))]
    {
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

/// Whether process `pid` may still be running (and so own its staging
/// folder). Unknown (not Unix, or not a plain positive pid): yes.
fn pid_alive(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Some(p) = i32::try_from(pid)
            .ok()
            .and_then(rustix::process::Pid::from_raw)
        else {
            return true;
        };
        // kill(pid, 0): ESRCH is the only sure sign that it is gone.
        !matches!(rustix::process::test_kill_process(p), Err(e) if e == rustix::io::Errno::SRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// Remove the leftovers of killed runs in `parent`: entries named
/// `PREFIX<pid>SUFFIX` for a `prefix` and `suffix` of `patterns`, whose pid is
/// not a running process. Best effort: a failure leaves them.
fn remove_stale(parent: &Path, patterns: &[(String, &str)]) {
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        for (prefix, suffix) in patterns {
            let pid = name
                .strip_prefix(prefix.as_str())
                .and_then(|r| r.strip_suffix(suffix))
                .filter(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
                .and_then(|d| d.parse::<u32>().ok());
            if pid.is_some_and(|p| p != std::process::id() && !pid_alive(p)) {
                let path = e.path();
                let _ = if e.file_type().is_ok_and(|t| t.is_dir()) {
                    std::fs::remove_dir_all(&path)
                } else {
                    std::fs::remove_file(&path)
                };
            }
        }
    }
}

/// Remove the temporary files `.NAME.PID.tmp` of killed writes of
/// `path` (see [`crate::outdir::write::write_atomic`]).
pub fn remove_stale_tmp(path: &Path) {
    if let Ok((parent, name)) = split(path) {
        let name = name.to_string_lossy();
        remove_stale(&parent, &[(format!(".{name}."), ".tmp")]);
    }
}

/// Sync a folder's entries to disk (where the platform can open folders).
fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}

/// What replacing a result folder removed beside the old run's own files
/// ([`write_folder`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Replaced {
    /// Files that later commands had added to the old result (name, the
    /// command that wrote it; `an earlier roks` for a folder without a
    /// record), which the new run did not write again.
    pub added: Vec<(String, String)>,
    /// Files roks did not write (only with `--force`).
    pub foreign: Vec<String>,
}

/// Write `files` (name, bytes) as the result folder `path`, replacing any
/// folder there whole (see the module documentation), with the record of
/// its files ([`record`]) naming `command` as their writer. `path` should
/// have passed [`check_folder`]. The write holds the commit lock
/// ([`crate::interrupt::commit`]): an interrupt finds the old folder or
/// the new one, and no staging folder.
///
/// # Errors
/// Creating, writing, syncing or renaming failed (the staging folder is
/// then removed and any old result left in place).
pub fn write_folder(
    path: &Path,
    files: &[(&str, &[u8])],
    command: &str,
) -> std::io::Result<Replaced> {
    let _commit = crate::interrupt::commit();
    let (parent, name) = split(path).map_err(std::io::Error::other)?;
    let path = &resolve(&parent.join(name)).map_err(std::io::Error::other)?;
    let (parent, name) = split(path).map_err(std::io::Error::other)?;
    let name = name.to_string_lossy().into_owned();
    std::fs::create_dir_all(&parent)?;
    remove_stale(
        &parent,
        &[(format!(".{name}.new-"), ""), (format!(".{name}.old-"), "")],
    );
    let pid = std::process::id();
    let staging = parent.join(format!(".{name}.new-{pid}"));
    if std::fs::symlink_metadata(&staging).is_ok() {
        std::fs::remove_dir_all(&staging)?;
    }
    let names: Vec<&str> = files.iter().map(|f| f.0).collect();
    let report = Listing::read(path)
        .map(|l| l.replaced(&names))
        .unwrap_or_default();
    let record = Record::new(command, names.iter().copied()).to_bytes();
    std::fs::create_dir(&staging)?;
    let written = (|| {
        for (file, bytes) in files.iter().copied().chain([(RECORD, record.as_slice())]) {
            let mut f = std::fs::File::create(staging.join(file))?;
            f.write_all(bytes)?;
            f.sync_all()?;
        }
        sync_dir(&staging);
        swap_in(&staging, path, &parent.join(format!(".{name}.old-{pid}")))
    })();
    if written.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    written?;
    sync_dir(&parent);
    Ok(report)
}

/// The name of the running command (`brdf`, `fit-model`, ...), for the
/// records of result folders ([`record_added`]); set once by the binary
/// ([`set_command`]), `roks` until then.
static COMMAND: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();

/// Name the running command (once; later calls are ignored).
pub fn set_command(name: &'static str) {
    let _ = COMMAND.set(name);
}

/// The running command ([`set_command`]), `roks` when none was named.
#[must_use]
pub fn command() -> &'static str {
    COMMAND.get().copied().unwrap_or("roks")
}

/// Add `path`, a file about to be written by `command`, to the record of
/// the result folder it is in, if that folder has one (and does not list
/// it yet): later checks then know it as roks's own. Recorded before the
/// file is written, so a kill between the two leaves a record naming a
/// missing file, never a file roks wrote missing from the record.
///
/// # Errors
/// The record cannot be rewritten.
pub fn record_added(path: &Path, command: &str) -> std::io::Result<()> {
    let Ok((dir, name)) = split(path) else {
        return Ok(());
    };
    let Some(mut rec) = Record::read(&dir) else {
        return Ok(());
    };
    let name = name.to_string_lossy().into_owned();
    if name == RECORD || rec.files.contains_key(&name) {
        return Ok(());
    }
    rec.files.insert(name, command.to_owned());
    // Atomically, as `crate::outdir::write::write_atomic` writes.
    let path = dir.join(RECORD);
    let tmp = dir.join(format!(".{RECORD}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&rec.to_bytes())?;
        f.sync_all()?;
        std::fs::rename(&tmp, &path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Put the complete folder `staging` at `path`. A folder already at `path`
/// is exchanged with it atomically where the system can (then removed from
/// `staging`), else moved to `old` first; no folder: one rename.
fn swap_in(staging: &Path, path: &Path, old: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => std::fs::rename(staging, path),
        Err(e) => Err(e),
        Ok(m) if !m.is_dir() => Err(std::io::Error::other(format!(
            "{} is no longer a folder",
            path.display()
        ))),
        Ok(_) => {
            if exchange(staging, path)? {
                let _ = std::fs::remove_dir_all(staging);
                Ok(())
            } else {
                swap_by_two_renames(staging, path, old)
            }
        }
    }
}

/// The portable swap: `path` to `old`, `staging` to `path`, remove `old`
/// (on failure of the second rename, the old folder is put back).
fn swap_by_two_renames(staging: &Path, path: &Path, old: &Path) -> std::io::Result<()> {
    std::fs::rename(path, old)?;
    if let Err(e) = std::fs::rename(staging, path) {
        let _ = std::fs::rename(old, path);
        return Err(e);
    }
    let _ = std::fs::remove_dir_all(old);
    Ok(())
}

/// Exchange the folders `a` and `b` atomically; `Ok(false)` when the system
/// or file system cannot (then nothing changed).
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    use rustix::io::Errno;
    match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
        Ok(()) => Ok(true),
        Err(e) if e == Errno::INVAL || e == Errno::NOSYS || e == Errno::OPNOTSUPP => Ok(false),
        Err(e) => Err(e.into()),
    }
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> std::io::Result<bool> {
    Ok(false)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("roks-outdir-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn names_that_are_not_one_plain_folder_are_refused() {
        for bad in [
            "", ".", "..", "../x", "a/b", "a\\b", "a\0b", ".hidden", "a\nb",
        ] {
            assert!(check_name(bad).is_some(), "{bad:?}");
        }
        assert!(check_name(&"x".repeat(MAX_NAME_BYTES + 1)).is_some());
        for good in ["default", "edge-15 periodic", "x.y", "a..b", "Zähler"] {
            assert_eq!(check_name(good), None, "{good:?}");
        }
    }

    #[test]
    fn the_portable_swap_replaces_the_folder_whole() {
        let d = scratch("two-renames");
        let out = d.join("r");
        write_folder(&out, &[("a.txt", b"old"), ("summary.json", b"{}")], "brdf").unwrap();
        let staging = d.join(".r.new-1");
        std::fs::create_dir(&staging).unwrap();
        std::fs::write(staging.join("b.txt"), b"new").unwrap();
        swap_by_two_renames(&staging, &out, &d.join(".r.old-1")).unwrap();
        assert_eq!(names(&out), ["b.txt"]);
        assert_eq!(names(&d), ["r"]);
    }

    #[test]
    fn a_rerun_leaves_only_its_own_files_and_removes_dead_leftovers() {
        let d = scratch("rerun");
        let out = d.join("r");
        write_folder(&out, &[("old.png", b"1"), ("summary.json", b"{}")], "brdf").unwrap();
        // Leftovers of a killed run (no such pid) and of a live one (ours is
        // skipped by name, so use pid 1, which always exists).
        for dead in [".r.new-4294967", ".r.old-4294968"] {
            std::fs::create_dir(d.join(dead)).unwrap();
            std::fs::write(d.join(dead).join("x"), b"").unwrap();
        }
        std::fs::create_dir(d.join(".r.new-1")).unwrap();
        let report = write_folder(&out, &[("summary.json", b"{}")], "brdf").unwrap();
        assert_eq!(report, Replaced::default());
        assert_eq!(names(&out), [RECORD, "summary.json"]);
        assert_eq!(names(&d), [".r.new-1", "r"]);
    }

    fn check_folder_(p: &Path) -> Result<(), OutPathError> {
        check_folder(p, false)
    }

    #[test]
    fn only_empty_or_result_folders_are_replaced() {
        let d = scratch("replaceable");
        assert!(check_folder_(&d.join("new")).is_ok());
        std::fs::create_dir(d.join("empty")).unwrap();
        assert!(check_folder_(&d.join("empty")).is_ok());
        std::fs::create_dir_all(d.join("mine/sub")).unwrap();
        assert!(
            check_folder_(&d.join("mine"))
                .unwrap_err()
                .to_string()
                .contains("holds the folder")
        );
        std::fs::create_dir(d.join("notes")).unwrap();
        std::fs::write(d.join("notes/summary.json"), b"{\"a\": 1}").unwrap();
        assert!(
            check_folder_(&d.join("notes"))
                .unwrap_err()
                .to_string()
                .contains("no roks summary.json")
        );
        std::fs::write(d.join("notes/summary.json"), b"{\"version\": \"0.1.0\"}").unwrap();
        assert!(check_folder_(&d.join("notes")).is_ok());
        // A result of an earlier roks (no record) is judged by its names.
        std::fs::write(d.join("notes/notes.txt"), b"mine").unwrap();
        let e = check_folder_(&d.join("notes")).unwrap_err().to_string();
        assert!(
            e.starts_with("holds the file \"notes.txt\", which roks did not write"),
            "{e}"
        );
        assert!(check_folder(&d.join("notes"), true).is_ok());
        std::fs::write(d.join("file"), b"").unwrap();
        assert!(
            check_folder_(&d.join("file"))
                .unwrap_err()
                .to_string()
                .contains("is a file")
        );
        assert!(
            check_folder_(&d.join("file/x"))
                .unwrap_err()
                .to_string()
                .contains("is a file")
        );
        assert!(check_folder_(Path::new("/")).is_err());
        assert!(check_folder_(&d.join("..")).is_err());
        assert_eq!(split(Path::new("a/b/.")).unwrap(), ("a".into(), "b".into()));
        assert_eq!(split(Path::new("b/")).unwrap(), (".".into(), "b".into()));
        assert_eq!(split(Path::new("/b")).unwrap(), ("/".into(), "b".into()));
    }

    #[test]
    fn a_result_folder_is_replaced_only_when_every_file_is_recorded() {
        let d = scratch("record");
        let out = d.join("r");
        let summary = br#"{"version": "0.1.0"}"#.as_slice();
        write_folder(
            &out,
            &[("summary.json", summary), ("brdf.csv", b"x")],
            "brdf",
        )
        .unwrap();
        assert!(check_folder(&out, false).is_ok());
        // A later export recorded before it is written; a user's file not.
        record_added(&out.join("mine.bsdf"), "export-brdf").unwrap();
        std::fs::write(out.join("mine.bsdf"), b"z").unwrap();
        assert!(check_folder(&out, false).is_ok());
        std::fs::write(out.join("a note"), b"mine").unwrap();
        assert_eq!(foreign(&out), ["a note"]);
        assert!(
            matches!(check_folder(&out, false), Err(OutPathError::Foreign(n)) if n == "a note")
        );
        // With --force the rerun replaces it, and says what it removed.
        let report = write_folder(&out, &[("summary.json", summary)], "brdf").unwrap();
        assert_eq!(
            report.added,
            [("mine.bsdf".to_owned(), "export-brdf".to_owned())]
        );
        assert_eq!(report.foreign, ["a note"]);
        assert_eq!(names(&out), [RECORD, "summary.json"]);
    }
}
