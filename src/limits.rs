//! The memory budget: every allocation sized by user input (a scene value, a
//! file header, an option) is estimated before it is made and refused above
//! one limit, so a request that cannot run is a one-line answer instead of an
//! allocation failure (or the machine swapping) after minutes of work.
//!
//! The limit is `ROKS_MAX_MEMORY` (bytes; suffixes `K`, `M`, `G`, `T` are
//! powers of 1024, e.g. `512M`, `8G`, `1.5G`; an optional `B` or `iB` may
//! follow), or else the machine's memory (`MemTotal` of `/proc/meminfo`, or
//! [`FALLBACK`] where that cannot be read), lowered to the address-space
//! limit (`ulimit -v`) and the cgroup's `memory.max` where those are set. Estimates are right to about a
//! factor of 2 (they count the big buffers, not the allocator's overhead) and
//! are stated in the message, with the limit:
//!
//! ```text
//! roks: scenes/x.toml: bumps[0]: periodic ghost copies (about 3.6e7 solids) would take about 7.5 GiB, above the memory limit 23.4 GiB (set ROKS_MAX_MEMORY to change it)
//! ```

use std::io::Read as _;
use std::path::Path;
use std::sync::OnceLock;

/// The environment variable that sets the limit (bytes, with an optional suffix).
pub const ENV: &str = "ROKS_MAX_MEMORY";

/// The limit when neither `ROKS_MAX_MEMORY` nor `/proc/meminfo` gives one: 8 GiB.
pub const FALLBACK: u64 = 8 << 30;

/// The most bytes roks reads from a scene file (TOML): far above any scene
/// (the largest shipped is a few kB; inline arrays of per-wavelength values
/// are kB too), far below what parsing it would take in memory (the TOML
/// parser holds several times the text).
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// The most bytes roks reads from a data file (a table, a height map, a
/// shard's tallies, a measured BRDF): an eighth of the memory limit, since
/// parsing holds the text and the values it gives.
#[must_use]
pub fn max_data_bytes() -> u64 {
    max_memory().unwrap_or(FALLBACK) / 8
}

/// The bytes of the file at `path`, reading at most `cap` of them: a larger
/// file (or an endless one such as `/dev/zero`) is an error saying so, so
/// memory stays bounded whatever the path names.
///
/// # Errors
/// The I/O error, or one of kind `InvalidData` for a file above `cap`.
pub fn read_capped(path: &Path, cap: u64) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(cap.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > cap {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "larger than {}, the most roks reads from such a file",
                format_bytes(cap)
            ),
        ));
    }
    Ok(bytes)
}

/// `Ok` when `path` names a regular file (after symbolic links), else an
/// error of kind `InvalidInput` saying what it is (`is a FIFO (named pipe),
/// not a regular file`). Checked before a file a scene reads is opened:
/// opening a FIFO waits for a writer (forever, if none comes), and a
/// device or a socket is no table either.
///
/// # Errors
/// The I/O error of `stat`, or the `InvalidInput` error.
pub fn require_regular(path: &Path) -> std::io::Result<()> {
    let kind = std::fs::metadata(path)?.file_type();
    if kind.is_file() {
        return Ok(());
    }
    let what = if kind.is_dir() {
        "a folder"
    } else {
        special_kind(kind)
    };
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("is {what}, not a regular file"),
    ))
}

/// What a file that is neither a regular file nor a folder is.
#[cfg(unix)]
fn special_kind(kind: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt as _;
    if kind.is_fifo() {
        "a FIFO (named pipe)"
    } else if kind.is_socket() {
        "a socket"
    } else if kind.is_char_device() || kind.is_block_device() {
        "a device"
    } else {
        "a special file"
    }
}

/// What a file that is neither a regular file nor a folder is.
#[cfg(not(unix))]
fn special_kind(_: std::fs::FileType) -> &'static str {
    "a special file"
}

/// [`read_capped`] of a file a scene reads (an n, k table, an angle table,
/// a height map, a BRDF table), refused unless it is a regular file
/// ([`require_regular`]) before it is opened.
///
/// # Errors
/// As [`require_regular`] and [`read_capped`].
pub fn read_input_capped(path: &Path, cap: u64) -> std::io::Result<Vec<u8>> {
    require_regular(path)?;
    read_capped(path, cap)
}

/// [`read_input_capped`] as UTF-8 text.
///
/// # Errors
/// As [`read_input_capped`], or `InvalidData` for text that is not UTF-8.
pub fn read_input_text_capped(path: &Path, cap: u64) -> std::io::Result<String> {
    require_regular(path)?;
    read_text_capped(path, cap)
}

/// [`read_capped`] as UTF-8 text.
///
/// # Errors
/// As [`read_capped`], or `InvalidData` for text that is not UTF-8.
pub fn read_text_capped(path: &Path, cap: u64) -> std::io::Result<String> {
    String::from_utf8(read_capped(path, cap)?).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "stream did not contain valid UTF-8",
        )
    })
}

/// Why a memory estimate is refused, or `ROKS_MAX_MEMORY` is unusable.
/// Messages are one line without file or key (callers put those in front).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MemoryError {
    /// `ROKS_MAX_MEMORY` is not a byte count.
    #[error("{ENV}: {0}")]
    Env(BytesError),
    /// `ROKS_MAX_MEMORY` is not UTF-8.
    #[error("{ENV}: not valid UTF-8 (give bytes, e.g. 512M, 8G or 1.5G)")]
    EnvNotUnicode,
    /// An estimate above the limit.
    #[error(
        "{what} would take about {}, above the memory limit {} (set {ENV} to change it)",
        format_bytes(*bytes),
        format_bytes(*limit)
    )]
    Above {
        /// What would take the memory, e.g. "periodic ghost copies".
        what: String,
        /// The estimate (bytes).
        bytes: u64,
        /// The limit (bytes).
        limit: u64,
    },
}

/// A text that is not a byte count ([`parse_bytes`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("must be a byte count like 512M, 8G or 1.5G, got `{0}`")]
pub struct BytesError(pub String);

/// The memory limit in bytes, or the one-line reason `ROKS_MAX_MEMORY` is
/// unusable (naming it). Read once per process.
///
/// # Errors
/// [`MemoryError::Env`] or [`MemoryError::EnvNotUnicode`].
pub fn max_memory() -> Result<u64, MemoryError> {
    static LIMIT: OnceLock<Result<u64, MemoryError>> = OnceLock::new();
    LIMIT
        .get_or_init(|| match std::env::var(ENV) {
            Ok(v) => parse_bytes(&v).map_err(MemoryError::Env),
            Err(std::env::VarError::NotUnicode(_)) => Err(MemoryError::EnvNotUnicode),
            Err(std::env::VarError::NotPresent) => Ok(default_limit()),
        })
        .clone()
}

/// The limit without `ROKS_MAX_MEMORY`: the machine's memory
/// ([`machine_memory`], or [`FALLBACK`]), lowered to the process's
/// address-space limit (`ulimit -v`) and its cgroup's `memory.max` where
/// those are set, so that a refusal comes before the allocation would fail.
#[must_use]
pub fn default_limit() -> u64 {
    let mut limit = machine_memory().unwrap_or(FALLBACK);
    if let Some(as_limit) = address_space_limit() {
        limit = limit.min(as_limit);
    }
    if let Some(cg) = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u64>().ok())
    {
        limit = limit.min(cg);
    }
    limit
}

/// The soft address-space limit of this process (`Max address space` of
/// `/proc/self/limits`), if set.
fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// The machine's memory (`MemTotal` of `/proc/meminfo`), if readable.
#[must_use]
pub fn machine_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut words = line.split_whitespace().skip(1);
    let n: u64 = words.next()?.parse().ok()?;
    let unit = match words.next() {
        Some("kB") => 1024,
        None => 1,
        _ => return None,
    };
    n.checked_mul(unit).filter(|&b| b > 0)
}

/// A byte count as `ROKS_MAX_MEMORY` takes it: a positive number (decimals
/// allowed) with an optional suffix `K`, `M`, `G` or `T` (powers of 1024,
/// either case), optionally followed by `B` or `iB`.
///
/// # Errors
/// [`BytesError`] naming the text.
pub fn parse_bytes(s: &str) -> Result<u64, BytesError> {
    let bad = || BytesError(s.to_owned());
    let t = s.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .or_else(|| t.strip_suffix('b'))
        .unwrap_or(t);
    let (number, scale) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 1u64 << 10),
        Some('M') => (&t[..t.len() - 1], 1 << 20),
        Some('G') => (&t[..t.len() - 1], 1 << 30),
        Some('T') => (&t[..t.len() - 1], 1 << 40),
        _ => (t, 1),
    };
    let x: f64 = number.trim().parse().map_err(|_| bad())?;
    let bytes = x * scale as f64;
    // Below 2^64, and at least one byte.
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(bad());
    }
    Ok(bytes as u64)
}

/// `bytes` for a person: `512 B`, `1.5 KiB`, `7.5 GiB`, `3.2e3 TiB`.
#[must_use]
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut x = bytes as f64;
    let mut u = 0;
    while x >= 1024.0 && u + 1 < UNITS.len() {
        x /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else if x >= 1e4 {
        format!("{x:.1e} {}", UNITS[u])
    } else {
        format!("{x:.1} {}", UNITS[u])
    }
}

/// `Ok` if `bytes` (an estimate for `what`, e.g. "periodic ghost copies")
/// fits the limit; else the one-line message, without file or key (callers
/// put those in front):
/// `periodic ghost copies would take about 7.5 GiB, above the memory limit 4.0 GiB (set ROKS_MAX_MEMORY to change it)`.
///
/// # Errors
/// [`MemoryError::Above`], or the reason the limit is unusable.
pub fn check(what: &str, bytes: u64) -> Result<(), MemoryError> {
    let limit = max_memory()?;
    if bytes <= limit {
        return Ok(());
    }
    Err(MemoryError::Above {
        what: what.to_owned(),
        bytes,
        limit,
    })
}

/// `a * b * ...` in bytes, saturating (an estimate never wraps around).
#[must_use]
pub fn product(factors: &[u64]) -> u64 {
    factors.iter().fold(1u64, |p, &f| p.saturating_mul(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_parse_with_binary_suffixes() {
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("8G"), Ok(8 << 30));
        assert_eq!(parse_bytes("1.5G"), Ok(3 << 29));
        assert_eq!(parse_bytes("100"), Ok(100));
        assert_eq!(parse_bytes("2k"), Ok(2048));
        assert_eq!(parse_bytes("4GiB"), Ok(4 << 30));
        assert_eq!(parse_bytes(" 1T "), Ok(1 << 40));
        for bad in ["", "G", "-1G", "0", "abc", "1e30", "NaN", "inf", "1.5X"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn sizes_print_in_binary_units() {
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(3 << 29), "1.5 GiB");
        assert_eq!(format_bytes(100 << 20), "100.0 MiB");
    }

    #[test]
    fn only_regular_files_are_inputs() {
        let dir = std::env::temp_dir().join(format!("roks-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("t.csv");
        std::fs::write(&file, "x").unwrap();
        assert_eq!(read_input_capped(&file, 10).unwrap(), b"x");
        let fifo = dir.join("fifo.csv");
        let _ = std::fs::remove_file(&fifo);
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        // Refused before it is opened: no writer, yet no wait.
        let e = read_input_text_capped(&fifo, 10).unwrap_err();
        assert_eq!(e.to_string(), "is a FIFO (named pipe), not a regular file");
        let e = read_input_capped(Path::new("/dev/zero"), 10).unwrap_err();
        assert_eq!(e.to_string(), "is a device, not a regular file");
        let e = require_regular(&dir).unwrap_err();
        assert_eq!(e.to_string(), "is a folder, not a regular file");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn products_saturate() {
        assert_eq!(product(&[u64::MAX, 2]), u64::MAX);
        assert_eq!(product(&[3, 4]), 12);
    }
}
