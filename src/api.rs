//! The library API: what the command line, the Python module and the
//! report call. Load a scene (a file, or the embedded default) with
//! overrides; trace a micro scene to a [`BrdfResult`] or an object scene to
//! a [`TraceResult`]; write either as a result folder; read a result folder
//! back into the same type; print its table ([`BrdfReport`],
//! [`TraceReport`]). Every error is an [`Error`] whose `Display` is the
//! command line's one-line message.
//!
//! ```
//! use roks::api::{BrdfJob, BrdfOptions, Overrides, load_micro};
//!
//! let overrides = Overrides { photons: Some(2048), ..Overrides::default() };
//! let scene = load_micro(None, &overrides)?;
//! let options = BrdfOptions { stats_resolution: Some(16), ..BrdfOptions::default() };
//! let result = BrdfJob::new(&scene, &options)?.trace(&|_| {})?;
//! // One reflectance per incidence angle of the default scene.
//! assert_eq!(result.reflectance().len(), result.theta_deg().len());
//! let brdf = result.brdf()?;
//! let cells = result.cells();
//! assert_eq!(brdf.column("brdf").unwrap().len(), result.theta_deg().len() * cells);
//! # Ok::<(), roks::api::Error>(())
//! ```

use std::path::Path;

mod error;
pub mod merge;
pub mod mesh;
mod micro;
mod object;
pub mod redraw;
pub mod render;
mod report;
mod table;
pub mod values;

pub use error::Error;
pub use micro::{BrdfJob, BrdfOptions, BrdfResult, STATS_RESOLUTION};
pub use object::{TraceJob, TraceOptions, TraceResult, load_object};
pub use report::{BrdfReport, StatsReport, TraceReport, anisotropy_note};
pub use table::{Table, TableError};

pub use crate::interrupt::Cancel;
pub use crate::micro::heightfield_io::HeightGrid;
pub use crate::scene::WavelengthsSpec;
pub use crate::scene::micro::{HEIGHT_MAP_ARRAY, HeightMapArray, MicroScene, Overrides};
pub use crate::scene::object::ObjectScene;
pub use crate::shard::Shard;

/// The micro scene at `path` (`None`: the embedded default scene) with
/// `overrides` laid over its keys, built and checked once: an error at a
/// key an override set names its option (`--theta: angle 1: ...`).
///
/// # Errors
/// [`Error::Scene`] naming the scene file and key, or [`Error::Option`].
pub fn load_micro(path: Option<&Path>, overrides: &Overrides) -> Result<MicroScene, Error> {
    let source = match path {
        Some(p) => MicroSource::File(p),
        None => MicroSource::Default,
    };
    load_micro_from(&source, overrides, None)
}

/// The name of a scene given as text ([`MicroSource::Text`]) in messages
/// and in its result's description.
pub const SCENE_TEXT: &str = "<scene text>";

/// Where a micro scene comes from.
#[derive(Debug, Clone, Copy)]
pub enum MicroSource<'a> {
    /// The embedded default scene.
    Default,
    /// A scene file (relative files resolve against its folder).
    File(&'a Path),
    /// Scene text (TOML), named [`SCENE_TEXT`] in messages; its relative
    /// files resolve against `base_dir`; its name, without a `name` key,
    /// is `scene`.
    Text {
        /// The TOML text.
        text: &'a str,
        /// The folder its relative file names are in.
        base_dir: &'a Path,
    },
}

/// [`load_micro`] from any [`MicroSource`], and with `map` (when given)
/// as the surface's height field: `[surface] heightfield = { file, pixel }`
/// with the array's heights in place of the file's, checked exactly as that
/// key is ([`MicroScene::from_str_map`]; the file is named
/// [`HEIGHT_MAP_ARRAY`] in messages).
///
/// # Errors
/// As [`load_micro`].
pub fn load_micro_from(
    source: &MicroSource<'_>,
    overrides: &Overrides,
    map: Option<&HeightMapArray>,
) -> Result<MicroScene, Error> {
    use crate::scene::SceneFile;
    use crate::scene::micro::BuildError;
    match source {
        MicroSource::File(p) => MicroScene::load_map(p, overrides, map),
        MicroSource::Default => MicroScene::default_map(overrides, map),
        MicroSource::Text { text, base_dir } => {
            let scene_file = SceneFile {
                file: SCENE_TEXT.into(),
                dir: base_dir.to_path_buf(),
            };
            MicroScene::from_str_map(text, scene_file, "scene".into(), overrides, map)
        }
    }
    .map_err(|e| match e {
        BuildError::Scene(e) => Error::Scene(e),
        BuildError::Option { option, message } => Error::Option { option, message },
    })
}

/// Whether the result folder `dir` holds an object run (`roks trace`:
/// `reflectance.csv` and no `brdf.csv`), else a micro run (`roks brdf`).
#[must_use]
pub fn is_trace_folder(dir: &Path) -> bool {
    use crate::outdir::file::ResultFile;
    !ResultFile::Brdf.path_in(dir).exists() && ResultFile::Reflectance.path_in(dir).exists()
}

/// The comment the exported tables of a run carry (`roks brdf --export`,
/// `roks merge --export`): `scene NAME, N photons per angle`.
#[must_use]
pub fn export_comment(scene: &str, photons_per_angle: u64) -> String {
    format!("scene {scene}, {photons_per_angle} photons per angle")
}

/// Use `threads` worker threads for every later trace or render (`None`:
/// all cores). Results do not depend on it. Set once per process.
///
/// # Errors
/// [`Error::Option`] naming `--threads` when their stacks exceed the memory
/// limit ([`crate::limits`]); [`Error::Io`] when the pool was set already.
pub fn set_threads(threads: Option<usize>) -> Result<(), Error> {
    if let Some(t) = threads {
        // Each worker reserves a 2 MiB stack (rayon's default).
        let bytes = crate::limits::product(&[t as u64, 2 << 20]);
        let what = format!("the stacks of {t} worker threads");
        check_memory("--threads", &what, bytes)?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(anyhow::Error::from)?;
    }
    Ok(())
}

/// How an in-process run runs (the Python module's): on its own pool of
/// worker threads, and stopped by a cancel token. Neither changes results.
/// The command line instead sets the process's pool once ([`set_threads`])
/// and is stopped by its signal handler.
#[derive(Debug, Clone, Default)]
pub struct Control {
    /// Worker threads of this run (`None`: all cores), in a pool of its
    /// own: other runs of the process keep theirs.
    pub threads: Option<usize>,
    /// The token that stops the run between photon batches
    /// ([`Cancel::cancel`]); the run then ends with [`Error::Interrupted`].
    pub cancel: Option<Cancel>,
}

impl Control {
    /// Run `op` on this run's own pool of worker threads, each watching
    /// the cancel token ([`crate::interrupt::watch`]).
    ///
    /// # Errors
    /// [`Error::Option`] naming `--threads` for 0 threads or stacks beyond
    /// the memory limit; [`Error::Interrupted`] when the token was
    /// cancelled before `op` returned; else `op`'s error.
    pub fn run<R: Send>(&self, op: impl FnOnce() -> Result<R, Error> + Send) -> Result<R, Error> {
        let threads = match self.threads {
            Some(t) => {
                let t = crate::api::values::positive::<usize>(&t.to_string())
                    .map_err(|e| Error::option("--threads", e))?;
                let bytes = crate::limits::product(&[t as u64, 2 << 20]);
                let what = format!("the stacks of {t} worker threads");
                check_memory("--threads", &what, bytes)?;
                t
            }
            // rayon's default: all cores (or RAYON_NUM_THREADS).
            None => 0,
        };
        let token = self.cancel.clone();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .start_handler(move |_| crate::interrupt::watch(token.clone()))
            .build()
            .map_err(anyhow::Error::from)?;
        let result = pool.install(op);
        if self.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
            return Err(Error::Interrupted);
        }
        result
    }
}

/// Refuse `option` when `bytes`, the estimate for `what`, exceed the memory
/// limit ([`crate::limits`]).
///
/// # Errors
/// [`Error::Option`] naming `option`.
pub fn check_memory(option: &'static str, what: &str, bytes: u64) -> Result<(), Error> {
    crate::limits::check(what, bytes).map_err(|e| Error::option(option, e))
}

/// The height-map grid for statistics: `requested` (checked; `option`
/// names it), or the height field's own grid, or `default` x `default`.
///
/// # Errors
/// [`Error::Option`] for fewer than 2 samples or a grid beyond the memory
/// limit.
pub fn stats_grid(
    scene: &MicroScene,
    requested: Option<usize>,
    default: usize,
    option: &'static str,
) -> Result<(usize, usize), Error> {
    match (requested, scene.surface.heightfield()) {
        (Some(r), _) if r < 2 => Err(Error::option(option, "must be >= 2")),
        (Some(r), _) => {
            let what = format!("the statistics of a {r} x {r} height map");
            check_memory(option, &what, scene.surface.stats_memory_bytes(r, r))?;
            Ok((r, r))
        }
        (None, Some(f)) => Ok((f.nx, f.ny)),
        (None, None) => Ok((default, default)),
    }
}

/// A height-field scene's own grid, refusing any other `resolution`
/// (`--resolution`).
///
/// # Errors
/// [`Error::Option`] when `resolution` is not the field's own.
pub fn own_grid(scene: &MicroScene, resolution: Option<usize>) -> Result<(), Error> {
    match (scene.surface.heightfield(), resolution) {
        (Some(f), Some(r)) if (r, r) != (f.nx, f.ny) => Err(Error::option(
            "--resolution",
            format!(
                "{}: a height field is written on its own {} x {} grid, got {r}",
                scene.scene_file.file, f.nx, f.ny
            ),
        )),
        _ => Ok(()),
    }
}

/// Every file of the result folder `dir` (not its record of roks's files),
/// by name.
fn read_folder(dir: &Path) -> Result<Vec<(String, Vec<u8>)>, Error> {
    let cannot = |e: std::io::Error| anyhow::anyhow!("cannot read {}: {e}", dir.display());
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(cannot)? {
        let entry = entry.map_err(cannot)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') || !entry.file_type().map_err(cannot)?.is_file() {
            continue;
        }
        let bytes = std::fs::read(entry.path()).map_err(cannot)?;
        files.push((name, bytes));
    }
    files.sort();
    Ok(files)
}

/// Write the result folder `out` whole, as `command` wrote it, after the
/// output checks ([`crate::outdir::check_folder`]).
fn write_folder(
    out: &Path,
    files: &[(String, Vec<u8>)],
    command: &str,
    force: bool,
) -> Result<(), Error> {
    crate::outdir::check_folder(out, force).map_err(|error| Error::Out {
        path: out.to_path_buf(),
        error,
    })?;
    let files: Vec<(&str, &[u8])> = files.iter().map(|(n, b)| (n.as_str(), &b[..])).collect();
    crate::outdir::write_folder(out, &files, command)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", out.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    /// A height-field scene reading `map.txt` beside it.
    const MAP_SCENE: &str = r#"
name = "measured"
[materials.metal]
n = 1.015
k = 6.627
[surface]
material = "metal"
heightfield = { file = "map.txt", pixel = 0.25 }
[light]
photons = 4096
theta_deg = [20]
"#;

    fn temp_dir(tag: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("roks-api-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A 16 x 12 map of heights that a text file holds exactly.
    fn grid() -> HeightGrid {
        let (nx, ny) = (16, 12);
        let h = (0..nx * ny)
            .map(|k| ((k * 37 % 23) as f64 - 11.0) * 0.0125)
            .collect();
        HeightGrid { nx, ny, h }
    }

    fn brdf_column(scene: &MicroScene) -> Vec<f64> {
        let options = BrdfOptions {
            stats_resolution: Some(16),
            ..BrdfOptions::default()
        };
        let r = BrdfJob::new(scene, &options)
            .unwrap()
            .trace(&|_| {})
            .unwrap();
        r.brdf().unwrap().column("brdf").unwrap().to_vec()
    }

    #[test]
    fn a_height_map_array_is_its_file() {
        let dir = temp_dir("array");
        let g = grid();
        let text: String =
            g.h.chunks(g.nx)
                .map(|row| row.iter().map(|z| format!("{z:?} ")).collect::<String>() + "\n")
                .collect();
        std::fs::write(dir.join("map.txt"), text).unwrap();
        std::fs::write(dir.join("s.toml"), MAP_SCENE).unwrap();
        let o = Overrides::default();
        let from_file = load_micro(Some(&dir.join("s.toml")), &o).unwrap();
        // Scene text: map.txt resolves against the base dir.
        let source = MicroSource::Text {
            text: MAP_SCENE,
            base_dir: &dir,
        };
        let from_text = load_micro_from(&source, &o, None).unwrap();
        assert_eq!(from_text.scene_file.file, SCENE_TEXT);
        let map = HeightMapArray {
            grid: g.clone(),
            pixel: 0.25,
        };
        let from_array = load_micro_from(&source, &o, Some(&map)).unwrap();
        let traced = brdf_column(&from_file);
        assert_eq!(brdf_column(&from_text), traced);
        assert_eq!(brdf_column(&from_array), traced);
        // Mirrored, it is another surface.
        let mut m = map.clone();
        m.grid.h =
            g.h.chunks(g.nx)
                .flat_map(|r| r.iter().rev().copied())
                .collect();
        let mirrored = load_micro_from(&source, &o, Some(&m)).unwrap();
        assert_ne!(brdf_column(&mirrored), traced);
        // Checked as the file's key is, the array named in place of it.
        m.grid = HeightGrid {
            nx: 3,
            ny: 1,
            h: vec![0.0; 3],
        };
        let e = load_micro_from(&source, &o, Some(&m)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "<scene text>: surface.heightfield.file: <height map array>: 3 x 1 heights: need at least 2 x 2"
        );
        m.grid = g.clone();
        m.grid.h[17] = f64::NAN;
        let e = load_micro_from(&source, &o, Some(&m)).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("<height map array>: height at row 1, column 1 is not finite"),
            "{e}"
        );
        let e = load_micro_from(&MicroSource::Default, &o, Some(&map)).unwrap_err();
        assert!(e.to_string().starts_with("<default scene>: "), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_threads_of_a_run_do_not_change_its_result() {
        let o = Overrides {
            photons: Some(3 * 4096),
            theta_deg: Some(vec![40.0]),
            ..Overrides::default()
        };
        let scene = load_micro(None, &o).unwrap();
        let options = BrdfOptions {
            stats_resolution: Some(16),
            ..BrdfOptions::default()
        };
        let run = |threads| {
            let control = Control {
                threads: Some(threads),
                cancel: None,
            };
            let r = BrdfJob::new(&scene, &options)
                .unwrap()
                .trace_with(&control, &|_| {})
                .unwrap();
            r.brdf().unwrap().column("brdf").unwrap().to_vec()
        };
        assert_eq!(run(1), run(3));
        let zero = Control {
            threads: Some(0),
            cancel: None,
        };
        let e = zero.run(|| Ok(())).unwrap_err();
        assert!(e.to_string().starts_with("--threads: "), "{e}");
    }

    /// Cancel `control`'s token after `after`, and time the run from then.
    fn stopped_within<R: Send>(
        control: &Control,
        after: Duration,
        run: impl FnOnce() -> Result<R, Error> + Send,
    ) -> (Result<R, Error>, Duration) {
        let token = control.cancel.clone().unwrap();
        std::thread::scope(|s| {
            let t = s.spawn(move || {
                std::thread::sleep(after);
                token.cancel();
                Instant::now()
            });
            let r = run();
            let end = Instant::now();
            let cancelled = t.join().unwrap();
            (r, end.saturating_duration_since(cancelled))
        })
    }

    #[test]
    fn a_cancelled_micro_run_stops_within_a_second() {
        let o = Overrides {
            photons: Some(200_000_000),
            theta_deg: Some(vec![30.0]),
            ..Overrides::default()
        };
        let scene = load_micro(None, &o).unwrap();
        let options = BrdfOptions {
            stats_resolution: Some(16),
            ..BrdfOptions::default()
        };
        let control = Control {
            threads: Some(2),
            cancel: Some(Cancel::new()),
        };
        let job = BrdfJob::new(&scene, &options).unwrap();
        let (r, latency) = stopped_within(&control, Duration::from_millis(300), || {
            job.trace_with(&control, &|_| {})
        });
        assert!(matches!(r, Err(Error::Interrupted)), "{r:?}");
        assert!(latency < Duration::from_secs(1), "{latency:?}");
        assert_eq!(
            Error::Interrupted.to_string(),
            "interrupted: nothing written"
        );
        assert!(!Error::Interrupted.is_input());
    }

    #[test]
    fn a_cancelled_object_run_stops_within_a_second() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let scene = load_object(&root.join("scenes/cylinder-cavity.toml"), None).unwrap();
        let options = TraceOptions {
            photons: Some(100_000_000),
            ..TraceOptions::default()
        };
        let control = Control {
            threads: Some(2),
            cancel: Some(Cancel::new()),
        };
        let job = TraceJob::new(&scene, &options).unwrap();
        let (r, latency) = stopped_within(&control, Duration::from_millis(300), || {
            job.trace_with(&control, &|_| {})
        });
        assert!(matches!(r, Err(Error::Interrupted)), "{r:?}");
        assert!(latency < Duration::from_secs(1), "{latency:?}");
    }

    #[test]
    fn grids_for_statistics() {
        let scene = MicroScene::default_scene();
        assert_eq!(stats_grid(&scene, None, 512, "--x").unwrap(), (512, 512));
        assert_eq!(stats_grid(&scene, Some(64), 512, "--x").unwrap(), (64, 64));
        let e = stats_grid(&scene, Some(1), 512, "--stats-resolution").unwrap_err();
        assert_eq!(e.to_string(), "--stats-resolution: must be >= 2");
        assert!(e.is_input());
        // Bumps have no grid of their own: any resolution is theirs.
        assert!(own_grid(&scene, Some(3)).is_ok());
    }
}
