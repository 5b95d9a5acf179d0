//! `roks._native`: the roks library ([`roks::api`]) in-process, for the
//! Python package `roks` (python/roks), which wraps it with numpy. Its
//! names are documented in python/roks/_native.pyi.
//!
//! * Scenes are loaded with the command line's options (`--photons`,
//!   `--theta`, ...) parsed by the command line's own parser, so a value
//!   goes through the same checks and [`roks::api::Overrides`], with the
//!   same one-line message.
//! * A run traces on a worker thread of its own, on its own pool of
//!   threads ([`roks::api::Control`]), while the calling thread waits in
//!   slices of 50 ms with the GIL released, between them reporting progress
//!   and checking Python's signals: a KeyboardInterrupt cancels the run,
//!   which stops between photon batches and writes nothing.
//! * Errors are exceptions of the kind of the library's error, with its
//!   message word for word.
#![forbid(unsafe_code)]

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use roks::api;
use roks::cli::args::{Cli, Command};
use roks::outdir::file::ResultFile;

create_exception!(
    _native,
    RoksError,
    PyException,
    "Any error of roks: the command line's one-line message."
);
create_exception!(
    _native,
    SceneError,
    RoksError,
    "A scene file (or scene text): the message names the file and the key."
);
create_exception!(
    _native,
    InputError,
    RoksError,
    "Bad input other than a scene key: an input file, a value refused in the light of another."
);
create_exception!(
    _native,
    OptionError,
    InputError,
    "An option (a keyword of Scene.override, or of a run) refused: the message names the command line's option."
);
create_exception!(
    _native,
    OutputError,
    RoksError,
    "An output that cannot be written where asked (a result folder roks did not write, ...)."
);

/// The Python exception of a library error, with the command line's
/// message (control characters escaped, as the command line prints them).
fn py_err(e: api::Error) -> PyErr {
    let message = roks::outdir::check::escape_controls(&match &e {
        api::Error::Io(inner) => format!("{inner:#}"),
        e => e.to_string(),
    });
    match e {
        api::Error::Scene(_) => SceneError::new_err(message),
        api::Error::Option { .. } => OptionError::new_err(message),
        api::Error::Input(_) | api::Error::Render(_) | api::Error::RenderJob(_) => {
            InputError::new_err(message)
        }
        api::Error::Out { .. } => OutputError::new_err(message),
        api::Error::Io(_) => RoksError::new_err(message),
        api::Error::Interrupted => PyKeyboardInterrupt::new_err(message),
    }
}

/// The options of `roks COMMAND` parsed by the command line's parser.
fn parse(command: &str, scene: Option<&str>, args: Vec<String>) -> PyResult<Command> {
    let mut argv = vec!["roks".to_owned(), command.to_owned()];
    argv.extend(scene.map(str::to_owned));
    argv.extend(args);
    roks::cli::messages::try_parse::<Cli>(&argv)
        .map(|c| c.command)
        .map_err(OptionError::new_err)
}

// The scene classes' `name` and `file` are fields read by pyo3's own
// getters (`#[pyo3(get)]`), copied from the scene when it is loaded: a
// class has one `#[pymethods]` block (pyo3 without its
// `multiple-pymethods` feature), which does not expand a shared macro.

/// A micro scene, built and checked (immutable).
#[pyclass(frozen, module = "roks._native")]
struct MicroScene {
    scene: Arc<api::MicroScene>,
    /// The scene's name (`name` key, else the file's stem; `default`,
    /// `scene` for text).
    #[pyo3(get)]
    name: String,
    /// The scene file as messages name it.
    #[pyo3(get)]
    file: String,
}

#[pymethods]
impl MicroScene {
    /// Load a micro scene: the file `path`, else the TOML `text` (named
    /// `<scene text>` in messages; relative files resolve against
    /// `base_dir`, default the working folder), else the embedded default
    /// scene; with `args`, the options of `roks brdf` that override scene
    /// keys (`["--photons", "4096", ...]`); and with `heights` (`nx * ny`
    /// little-endian f64, row-major, row j at y = j pixel) as the surface's
    /// height field of grid pitch `pixel`.
    #[staticmethod]
    #[pyo3(signature = (path=None, text=None, base_dir=None, args=Vec::new(), heights=None, nx=0, ny=0, pixel=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn load(
        py: Python<'_>,
        path: Option<PathBuf>,
        text: Option<String>,
        base_dir: Option<PathBuf>,
        args: Vec<String>,
        heights: Option<&[u8]>,
        nx: usize,
        ny: usize,
        pixel: f64,
    ) -> PyResult<Self> {
        let overrides = match parse("brdf", None, args)? {
            Command::Brdf(a) => a.overrides(),
            _ => unreachable!("roks brdf parses as brdf"),
        };
        let map = heights.map(|b| api::HeightMapArray {
            grid: api::HeightGrid {
                nx,
                ny,
                h: b.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                    .collect(),
            },
            pixel,
        });
        if let Some(m) = &map
            && m.grid.h.len() != nx * ny
        {
            return Err(InputError::new_err(format!(
                "{}: {} heights for a {nx} x {ny} grid",
                api::HEIGHT_MAP_ARRAY,
                m.grid.h.len()
            )));
        }
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let source = match (&path, &text) {
            (Some(p), _) => api::MicroSource::File(p),
            (None, Some(t)) => api::MicroSource::Text {
                text: t,
                base_dir: &base,
            },
            (None, None) => api::MicroSource::Default,
        };
        let scene = py
            .detach(|| api::load_micro_from(&source, &overrides, map.as_ref()))
            .map_err(py_err)?;
        Ok(Self {
            name: scene.name.clone(),
            file: scene.scene_file.file.clone(),
            scene: Arc::new(scene),
        })
    }

    /// The surface statistics (`roks stats --json`) on a `resolution` x
    /// `resolution` grid (default 512; a height field: its own), as JSON.
    #[pyo3(signature = (resolution=None))]
    fn stats_json(&self, py: Python<'_>, resolution: Option<usize>) -> PyResult<String> {
        let scene = &self.scene;
        py.detach(|| {
            let grid = api::stats_grid(scene, resolution, api::STATS_RESOLUTION, "--resolution")?;
            let map = scene.surface.height_map(grid.0, grid.1);
            let stats = roks::micro::surface_stats::surface_stats(&map);
            let v = roks::output::summary::Surface::new(&stats, grid.0);
            serde_json::to_string_pretty(&v).map_err(|e| api::Error::Io(e.into()))
        })
        .map_err(py_err)
    }

    /// Trace the BRDF (`roks brdf`) on `threads` worker threads (None: all
    /// cores), `stats_resolution` as `--stats-resolution`; `progress(n,
    /// total)` is called with the photons done since its last call and the
    /// run's photons in all.
    #[pyo3(signature = (threads=None, stats_resolution=None, progress=None))]
    fn brdf(
        &self,
        py: Python<'_>,
        threads: Option<usize>,
        stats_resolution: Option<usize>,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<BrdfResult> {
        let options = api::BrdfOptions {
            shard: None,
            stats_resolution,
        };
        let job = api::BrdfJob::new(&self.scene, &options).map_err(py_err)?;
        let total = job.photons();
        let result = run(py, threads, total, progress.as_ref(), move |c, p| {
            job.trace_with(c, p)
        })?;
        Ok(BrdfResult {
            result,
            scene: Some(self.scene.clone()),
            dir: None,
        })
    }
}

/// An object scene, loaded and checked (immutable).
#[pyclass(frozen, module = "roks._native")]
struct ObjectScene {
    scene: Arc<api::ObjectScene>,
    options: api::TraceOptions,
    /// The scene's name.
    #[pyo3(get)]
    name: String,
    /// The scene file as messages name it.
    #[pyo3(get)]
    file: String,
}

#[pymethods]
impl ObjectScene {
    /// Load the object scene file `path` with `args`, the options of
    /// `roks trace` (`--photons`, `--seed`, `--wavelengths`,
    /// `--no-polarisation`).
    #[staticmethod]
    #[pyo3(signature = (path, args=Vec::new()))]
    fn load(py: Python<'_>, path: PathBuf, args: Vec<String>) -> PyResult<Self> {
        let shown = path.display().to_string();
        let a = match parse("trace", Some(&shown), args)? {
            Command::Trace(a) => a,
            _ => unreachable!("roks trace parses as trace"),
        };
        let options = api::TraceOptions {
            photons: a.tracing.photons,
            seed: a.tracing.seed,
            no_polarisation: a.no_polarisation,
            shard: None,
        };
        let scene = py
            .detach(|| api::load_object(&path, a.wavelengths.as_ref()))
            .map_err(py_err)?;
        // The options' checks, before any run.
        api::TraceJob::new(&scene, &options).map_err(py_err)?;
        Ok(Self {
            name: scene.name.clone(),
            file: scene.scene_file.file.clone(),
            scene: Arc::new(scene),
            options,
        })
    }

    /// Trace the scene (`roks trace`) on `threads` worker threads;
    /// `progress(n, total)` as for [`MicroScene::brdf`].
    #[pyo3(signature = (threads=None, progress=None))]
    fn trace(
        &self,
        py: Python<'_>,
        threads: Option<usize>,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<TraceResult> {
        let job = api::TraceJob::new(&self.scene, &self.options).map_err(py_err)?;
        let total = job.photons();
        let result = run(py, threads, total, progress.as_ref(), move |c, p| {
            job.trace_with(c, p)
        })?;
        Ok(TraceResult { result })
    }
}

/// Run `work` on a thread of its own under a [`api::Control`] of
/// `threads` and a cancel token, waiting with the GIL released: between
/// slices of 50 ms the progress is reported (`progress(photons done since
/// the last call, total photons)`) and Python's signals checked;
/// an exception there (KeyboardInterrupt) cancels the run, waits for it to
/// stop (between photon batches) and is raised.
fn run<R: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    total: u64,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&api::Control, &(dyn Fn(u64) + Sync)) -> Result<R, api::Error> + Send,
) -> PyResult<R> {
    let cancel = api::Cancel::new();
    let control = api::Control {
        threads,
        cancel: Some(cancel.clone()),
    };
    let done = AtomicU64::new(0);
    let finished = AtomicBool::new(false);
    std::thread::scope(|s| {
        let handle = s.spawn(|| {
            // Set when the work ends, by a return or a panic.
            let _end = Finished(&finished);
            work(&control, &|n| {
                done.fetch_add(n, Ordering::Relaxed);
            })
        });
        let mut shown = 0;
        let stop = |e: PyErr| {
            cancel.cancel();
            let _ = py.detach(|| handle_wait(&finished));
            Err(e)
        };
        loop {
            py.detach(|| {
                for _ in 0..50 {
                    if finished.load(Ordering::Acquire) {
                        break;
                    }
                    std::thread::sleep(Duration::from_millis(1));
                }
            });
            let now = done.load(Ordering::Relaxed);
            if let Some(cb) = progress
                && now > shown
            {
                if let Err(e) = cb.call1((now - shown, total)) {
                    return stop(e);
                }
                shown = now;
            }
            if finished.load(Ordering::Acquire) {
                break;
            }
            if let Err(e) = py.check_signals() {
                return stop(e);
            }
        }
        match py.detach(|| handle.join()) {
            Ok(r) => r.map_err(py_err),
            Err(_) => Err(RoksError::new_err(
                "roks: the run panicked (a defect of roks)",
            )),
        }
    })
}

/// Sets its flag when dropped: a run's end, returned or panicked.
struct Finished<'a>(&'a AtomicBool);

impl Drop for Finished<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

/// Wait for a cancelled run to end.
fn handle_wait(finished: &AtomicBool) {
    while !finished.load(Ordering::Acquire) {
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// Column names and their values (little-endian f64 bytes each).
type Columns = (Vec<String>, Vec<Py<PyBytes>>);

/// The CSV file `name` (its `bytes`) as columns; a table that cannot be
/// read raises [`InputError`] with the reader's line.
fn table_columns(py: Python<'_>, name: &str, bytes: &[u8]) -> PyResult<Columns> {
    let t = api::Table::parse(&String::from_utf8_lossy(bytes), name)
        .map_err(|e| InputError::new_err(e.to_string()))?;
    Ok(columns(py, &t))
}

fn columns(py: Python<'_>, t: &api::Table) -> Columns {
    let names = t.names().to_vec();
    let values = names
        .iter()
        .map(|n| {
            let v = t.column(n).expect("a named column");
            let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
            PyBytes::new(py, &bytes).unbind()
        })
        .collect();
    (names, values)
}

/// A BRDF result: traced (with its scene), or read back from its folder.
#[pyclass(frozen, module = "roks._native")]
struct BrdfResult {
    result: api::BrdfResult,
    /// The traced scene (for an export's NDF); None when read back.
    scene: Option<Arc<api::MicroScene>>,
    /// The folder it was read from; None when traced.
    dir: Option<PathBuf>,
}

#[pymethods]
impl BrdfResult {
    /// The result folder `dir` of `roks brdf` or `roks merge`, read back.
    #[staticmethod]
    fn read(py: Python<'_>, dir: PathBuf) -> PyResult<Self> {
        let result = py.detach(|| api::BrdfResult::read(&dir)).map_err(py_err)?;
        Ok(Self {
            result,
            scene: None,
            dir: Some(dir),
        })
    }

    /// The export of the table in `format` (`roks export-brdf --format`;
    /// `args`: its further options, `--grid`, `--scene`, `--rgb`): a traced
    /// result as `roks brdf --export` makes it, a read one as `roks
    /// export-brdf` does, read back and judged. Written to `out` when given
    /// (one file, or a folder of several, checked as `--out` is). Returns
    /// (files as (name, bytes), checks as (what, theta_i_deg, phi_i_deg,
    /// table reflectance, file reflectance, table stderr), notices as the
    /// lines the command line prints).
    #[pyo3(signature = (format, out=None, force=false, args=Vec::new()))]
    fn export(
        &self,
        py: Python<'_>,
        format: &str,
        out: Option<PathBuf>,
        force: bool,
        args: Vec<String>,
    ) -> PyResult<ExportValues> {
        let dir = self.dir.clone().unwrap_or_else(|| PathBuf::from("."));
        let mut argv = vec![
            dir.display().to_string(),
            "--format".into(),
            format.into(),
            "--out".into(),
            out.as_ref()
                .map_or_else(|| "-".into(), |o| o.display().to_string()),
        ];
        argv.extend(args);
        let a = match parse("export-brdf", None, argv)? {
            Command::ExportBrdf(a) => a,
            _ => unreachable!("roks export-brdf parses as export-brdf"),
        };
        let export = py
            .detach(|| export_values(self, &a, out.as_deref(), force))
            .map_err(py_err)?;
        let files = export
            .files
            .iter()
            .map(|f| (f.file_name.clone(), PyBytes::new(py, &f.bytes).unbind()))
            .collect();
        let checks = export
            .checks
            .iter()
            .flat_map(|j| {
                j.checks.iter().map(|c| {
                    (
                        j.what.clone(),
                        c.theta_i_deg,
                        c.phi_i_deg,
                        c.table,
                        c.file,
                        c.table_stderr,
                    )
                })
            })
            .collect();
        let notices = export
            .notices
            .iter()
            .filter_map(|n| n.line(false))
            .collect();
        Ok((files, checks, notices))
    }

    /// Fit the analytic model `model` (`roks fit-model --model`; `args`:
    /// its further options, `--n`, `--k`, `--reflectance`, `--wavelength`)
    /// to the table, writing nothing: returns the files `roks fit-model`
    /// would write, as (name, bytes), and the lines it prints (the verdict,
    /// warnings). A traced result is fitted from its `brdf.csv` and
    /// `summary.json` as values, nothing written: its files are named by
    /// their bare names (the JSON's `table`: `brdf.csv`), and OpticStudio's
    /// rows are named `roks` (a folder's fit: the folder's name).
    #[pyo3(signature = (model, args=Vec::new()))]
    fn fit_model(
        &self,
        py: Python<'_>,
        model: &str,
        args: Vec<String>,
    ) -> PyResult<(Vec<(String, Py<PyBytes>)>, Vec<String>)> {
        let (files, lines) = py.detach(|| fit(self, model, args))?;
        Ok((
            files
                .into_iter()
                .map(|(n, b)| (n, PyBytes::new(py, &b).unbind()))
                .collect(),
            lines,
        ))
    }

    /// The folder's file `name` (`summary.json`, `brdf.csv`, ...), if it
    /// has one.
    fn file<'py>(&self, py: Python<'py>, name: &str) -> Option<Bound<'py, PyBytes>> {
        let bytes = py.detach(|| self.result.file(name))?;
        Some(PyBytes::new(py, &bytes))
    }

    /// The CSV file `name` of the folder as columns: (names, values as
    /// little-endian f64 bytes); None when the folder has no such file.
    fn table(&self, py: Python<'_>, name: &str) -> PyResult<Option<Columns>> {
        self.result
            .file(name)
            .map(|bytes| table_columns(py, name, &bytes))
            .transpose()
    }

    /// The shape [incidences, azimuths, wavelengths (1: monochrome), cells].
    #[getter]
    fn shape(&self) -> [usize; 4] {
        self.result.shape()
    }

    /// Whether the result was traced in this process (not read back).
    #[getter]
    fn traced(&self) -> bool {
        self.result.traced().is_some()
    }

    /// Every file of the result folder, (name, bytes), as written.
    fn files<'py>(&self, py: Python<'py>) -> PyResult<Vec<(String, Bound<'py, PyBytes>)>> {
        let files = py
            .detach(|| self.result.files(Vec::new()))
            .map_err(py_err)?;
        Ok(files
            .into_iter()
            .map(|(n, b)| (n, PyBytes::new(py, &b)))
            .collect())
    }

    /// Write the result folder `out` as `roks brdf` writes it (replaced
    /// whole; `force`: replace files roks did not write).
    #[pyo3(signature = (out, force=false))]
    fn write(&self, py: Python<'_>, out: PathBuf, force: bool) -> PyResult<()> {
        py.detach(|| self.result.write(&out, force)).map_err(py_err)
    }
}

/// An export's files, checks and notices ([`BrdfResult::export`]).
type ExportValues = (
    Vec<(String, Py<PyBytes>)>,
    Vec<(String, f64, Option<f64>, f64, f64, f64)>,
    Vec<String>,
);

/// The export of `r` as `a` asks, written to `out` when given.
fn export_values(
    r: &BrdfResult,
    a: &roks::cli::export_brdf::ExportBrdfArgs,
    out: Option<&Path>,
    force: bool,
) -> Result<roks::export::exporter::Export, api::Error> {
    use roks::export::folder::{EXPORT_MARKER, ExportMarker, FolderExport, export_folder};
    use roks::outdir::check::{check_out_dir, check_out_file_as};
    let input = |e: roks::export::exporter::ExportError| {
        if e.is_input() {
            api::Error::Input(e.to_string())
        } else {
            api::Error::Io(anyhow::Error::msg(e.to_string()))
        }
    };
    let (export, csv) = match (r.result.traced(), &r.scene, &r.dir) {
        (Some(folder), Some(scene), _) => {
            let photons = r.result.run().photon_range();
            let comment = api::export_comment(&scene.name, photons.end - photons.start);
            let export =
                export_folder(folder, &[a.format], &comment, &scene.surfaces()).map_err(input)?;
            (export, PathBuf::from(ResultFile::Brdf.name()))
        }
        (_, _, Some(dir)) => {
            let request = FolderExport {
                dir,
                format: a.format,
                grid: a.grid,
                scene: a.scene.as_deref(),
                rgb: a.rgb,
            };
            let export = request.export(request.writes_folder()).map_err(input)?;
            (export, request.csv())
        }
        _ => unreachable!("a result is traced with its scene, or read from a folder"),
    };
    let Some(out) = out else {
        return Ok(export);
    };
    let reads = r
        .dir
        .iter()
        .map(|d| ResultFile::Brdf.path_in(d))
        .collect::<Vec<_>>();
    if export.files.len() > 1 {
        check_out_dir(out, "--out", &reads, force)?;
        let mut written = export.named_files();
        let marker = ExportMarker::new(a.format, &csv, &export).text();
        written.push((EXPORT_MARKER.to_owned(), marker.into_bytes()));
        roks::outdir::write::write_folder(out, &written, "export-brdf")?;
    } else if let Some(file) = export.files.first() {
        check_out_file_as("--out", out, &reads, a.format.file_kind(), force)?;
        roks::outdir::write::write_file(out, &file.bytes)?;
    }
    Ok(export)
}

/// The files and lines of `roks fit-model --model MODEL ARGS` on `r`'s
/// table, nothing written: a read result's folder, a traced result's
/// `brdf.csv` and `summary.json` as values (named by their bare names).
fn fit(
    r: &BrdfResult,
    model: &str,
    args: Vec<String>,
) -> PyResult<(Vec<(String, Vec<u8>)>, Vec<String>)> {
    use roks::fit_model::material::MaterialOptions;
    use roks::fit_model::one::{Request, RunError, TableTexts};
    let shown = r.dir.as_deref().unwrap_or(Path::new("."));
    let mut argv = vec![shown.display().to_string(), "--model".into(), model.into()];
    argv.extend(args);
    let a = match parse("fit-model", None, argv)? {
        Command::FitModel(a) => a,
        _ => unreachable!("roks fit-model parses as fit-model"),
    };
    let text = |name: &str| {
        r.result.file(name).map(|bytes| {
            String::from_utf8(bytes).map_err(|e| RoksError::new_err(format!("{name}: {e}")))
        })
    };
    let texts = match r.dir {
        Some(_) => None,
        None => Some(TableTexts {
            csv: text(ResultFile::Brdf.name()).unwrap_or_else(|| Ok(String::new()))?,
            summary: text(ResultFile::Summary.name()).transpose()?,
        }),
    };
    let request = Request {
        dir: r.dir.clone().unwrap_or_default(),
        texts,
        model: a.model,
        out: None,
        material: MaterialOptions {
            n: a.n,
            k: a.k,
            reflectance: a.reflectance,
        },
        wavelength: a.wavelength,
    };
    let report = request.run().map_err(|e| match e {
        RunError::Input(m) => InputError::new_err(m),
        RunError::Other(e) => RoksError::new_err(format!("{e:#}")),
    })?;
    let files = report
        .files
        .iter()
        .map(|(p, b)| {
            let name = p
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            (name, b.clone())
        })
        .collect();
    Ok((files, report.lines(false).to_vec()))
}

/// An object scene's result: traced, or read back from its folder.
#[pyclass(frozen, module = "roks._native")]
struct TraceResult {
    result: api::TraceResult,
}

#[pymethods]
impl TraceResult {
    /// The result folder `dir` of `roks trace`, read back.
    #[staticmethod]
    fn read(py: Python<'_>, dir: PathBuf) -> PyResult<Self> {
        let result = py.detach(|| api::TraceResult::read(&dir)).map_err(py_err)?;
        Ok(Self { result })
    }

    /// The folder's file `name`, if it has one.
    fn file<'py>(&self, py: Python<'py>, name: &str) -> Option<Bound<'py, PyBytes>> {
        let files = self.result.files();
        files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| PyBytes::new(py, b))
    }

    /// The CSV file `name` as columns, as [`BrdfResult::table`].
    fn table(&self, py: Python<'_>, name: &str) -> PyResult<Option<Columns>> {
        let files = self.result.files();
        files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, bytes)| table_columns(py, name, bytes))
            .transpose()
    }

    /// Whether the result was traced in this process.
    #[getter]
    fn traced(&self) -> bool {
        self.result.traced().is_some()
    }

    /// Every file of the result folder, (name, bytes).
    fn files<'py>(&self, py: Python<'py>) -> Vec<(String, Bound<'py, PyBytes>)> {
        self.result
            .files()
            .iter()
            .map(|(n, b)| (n.clone(), PyBytes::new(py, b)))
            .collect()
    }

    /// Write the result folder `out` as `roks trace` writes it.
    #[pyo3(signature = (out, force=false))]
    fn write(&self, py: Python<'_>, out: PathBuf, force: bool) -> PyResult<()> {
        py.detach(|| self.result.write(&out, force)).map_err(py_err)
    }
}

/// Run the `roks` command line `argv` (program name first) in this process
/// and return its exit status (the `roks` console command; it installs the
/// command line's interrupt handler).
#[pyfunction]
fn main(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| roks::cli::run(argv.into_iter().map(Into::into)))
}

/// Whether `dir` holds the result of `roks trace` (else of `roks brdf`).
#[pyfunction]
fn is_trace_folder(dir: PathBuf) -> bool {
    api::is_trace_folder(&dir)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("RoksError", py.get_type::<RoksError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("OptionError", py.get_type::<OptionError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add_class::<MicroScene>()?;
    m.add_class::<ObjectScene>()?;
    m.add_class::<BrdfResult>()?;
    m.add_class::<TraceResult>()?;
    m.add_function(wrap_pyfunction!(main, m)?)?;
    m.add_function(wrap_pyfunction!(is_trace_folder, m)?)?;
    Ok(())
}
