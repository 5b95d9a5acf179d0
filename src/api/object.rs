//! The macro level through the API: a trace of an object scene
//! ([`TraceJob`]), its result ([`TraceResult`]), written as and read back
//! from a result folder.

use std::ops::Range;
use std::path::Path;

use super::{Error, Table, read_folder, write_folder};
use crate::outdir::file::ResultFile;
use crate::output::object_tallies::{self, TraceDescription, TraceTalliesFile};
use crate::output::summary::TraceSummary;
use crate::scene::WavelengthsSpec;
use crate::scene::object::ObjectScene;
use crate::shard::Shard;
use crate::tally::sum::BATCH;
use crate::transport::object::{ObjectResult, ObjectRun};

/// The object scene at `path`, with `wavelengths` (`--wavelengths`)
/// replacing its `[light] wavelengths_um` when given: an error at that key
/// then names the option.
///
/// # Errors
/// The scene file's error, or [`Error::Option`] naming `--wavelengths`.
pub fn load_object(
    path: &Path,
    wavelengths: Option<&WavelengthsSpec>,
) -> Result<ObjectScene, Error> {
    ObjectScene::load_at(path, wavelengths).map_err(|e| {
        let keys = [("light.wavelengths_um", "--wavelengths")];
        match crate::scene::option_error(&keys[..usize::from(wavelengths.is_some())], &e) {
            Some((option, message)) => Error::Option { option, message },
            None => e.into(),
        }
    })
}

/// What a trace adds to its object scene (`roks trace`'s options besides
/// `--wavelengths`, which [`load_object`] takes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraceOptions {
    /// Photons per beam position, for every source (`--photons`).
    pub photons: Option<u64>,
    /// The tracing seed (`--seed`).
    pub seed: Option<u64>,
    /// Scalar transport even with Fresnel walls (`--no-polarisation`).
    pub no_polarisation: bool,
    /// Trace only block `index` of `count` (`--shard I/N`).
    pub shard: Option<Shard>,
}

/// A trace of an object scene, checked and ready to run.
#[derive(Debug, Clone)]
pub struct TraceJob<'s> {
    scene: &'s ObjectScene,
    run: ObjectRun,
    photons: Vec<u64>,
    description: TraceDescription,
    blocks: Vec<Range<u64>>,
    shard: bool,
}

impl<'s> TraceJob<'s> {
    /// The trace of `scene` with `options`, checked as `roks trace` checks
    /// them (photons, polarisation, shard), before any work.
    ///
    /// # Errors
    /// [`Error::Option`] naming `--photons` or `--shard`; [`Error::Input`]
    /// for a Stokes far field without polarised transport.
    pub fn new(scene: &'s ObjectScene, options: &TraceOptions) -> Result<Self, Error> {
        let mut run = scene.run.clone();
        let mut photons = scene.photons.clone();
        if let Some(p) = options.photons {
            // The scene loader's check of `sources[i].photons`.
            crate::transport::launch::check_count(p).map_err(|e| Error::option("--photons", e))?;
            photons.iter_mut().for_each(|n| *n = p);
        }
        if let Some(s) = options.seed {
            run.seed = s;
        }
        if options.no_polarisation {
            if run.farfield_stokes {
                return Err(Error::Input(format!(
                    "{}: tally.polarisation: \"stokes\" needs polarised transport, which --no-polarisation turns off",
                    scene.scene_file.file
                )));
            }
            run.polarisation = false;
        }
        let description = TraceDescription::new(
            &scene.content,
            &scene.scene_file.file,
            &scene.name,
            &scene.object.surface_names,
            &run,
            &scene.beams,
            &photons,
            options.shard,
        );
        let blocks = description
            .blocks()
            .map_err(|e| Error::option("--shard", e))?;
        Ok(Self {
            scene,
            run,
            photons,
            description,
            blocks,
            shard: options.shard.is_some(),
        })
    }

    /// What the trace runs, in words: `N beam positions[, shard I/N]`.
    #[must_use]
    pub fn what(&self) -> String {
        format!(
            "{} beam positions{}",
            self.photons.len(),
            self.description.shard.map_or(String::new(), |s| format!(
                ", shard {}/{}",
                s.index, s.count
            ))
        )
    }

    /// The photons this trace runs in all (for a progress bar).
    #[must_use]
    pub fn photons(&self) -> u64 {
        let blocks = self.blocks.iter().zip(&self.photons);
        blocks.fold(0, |s: u64, (b, &n)| {
            s.saturating_add(((b.end * BATCH).min(n)).saturating_sub(b.start * BATCH))
        })
    }

    /// Trace; `progress` is called with the photons done after each batch.
    ///
    /// # Errors
    /// [`Error::Input`] naming the scene file and key when photons met a
    /// wall without a model or started inside a solid cell.
    pub fn trace(self, progress: &(dyn Fn(u64) + Sync)) -> Result<TraceResult, Error> {
        let scene = self.scene;
        let (run, d) = (&self.run, &self.description);
        let clock = std::time::Instant::now();
        let nodes = run.run_nodes(
            &scene.object,
            &scene.walls,
            &scene.models,
            &scene.beams,
            &self.photons,
            &self.blocks,
            progress,
        );
        if crate::interrupt::cancelled() {
            return Err(Error::Interrupted);
        }
        let seconds = clock.elapsed().as_secs_f64();
        let n_surfaces = scene.object.surface_names.len();
        let (result, tallies) = if self.shard {
            let result = object_tallies::partial_results(d, &nodes);
            // The file lists the leaves in order: position, then wavelength.
            let nodes = nodes.into_iter().flatten().collect();
            (result, Some(TraceTalliesFile::new(d, nodes, seconds)))
        } else {
            (
                ObjectResult::roots(nodes, &|| run.tallies(n_surfaces)),
                None,
            )
        };
        check_photons(scene, &result)?;
        let shard = tallies.is_some();
        let mut files = d.folder(&result, seconds, tallies);
        if !shard {
            crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
        }
        Ok(TraceResult {
            summary: d.summary(&result, seconds),
            files,
            traced: Some((self.run, result)),
        })
    }
}

impl TraceJob<'_> {
    /// [`trace`](Self::trace) in-process under `control`: on the run's
    /// own worker threads, stopped between photon batches by its cancel
    /// token. The result does not depend on the threads.
    ///
    /// # Errors
    /// As [`trace`](Self::trace) and [`Control::run`](super::Control::run)
    /// ([`Error::Interrupted`] when cancelled).
    pub fn trace_with(
        self,
        control: &super::Control,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<TraceResult, Error> {
        control.run(|| self.trace(progress))
    }
}

/// Refuse a result whose photons met a wall without a model, or started
/// inside a solid cell: a scene error, before any output.
fn check_photons(scene: &ObjectScene, result: &ObjectResult) -> Result<(), Error> {
    if let Some(r) = result.iter().find(|r| r.tallies.unmodelled.0 > 0) {
        let name = &scene.object.surface_names[r.tallies.unmodelled.1];
        return Err(Error::Input(format!(
            "{}: walls.{name}: photons hit surface `{name}` ({} of them from beam position {}), which has no model in [walls]",
            scene.scene_file.file, r.tallies.unmodelled.0, r.beam.position
        )));
    }
    if let Some((k, r)) = result
        .groups()
        .enumerate()
        .find_map(|(k, lanes)| Some((k, lanes.iter().find(|r| r.tallies.started_inside > 0)?)))
    {
        return Err(Error::Input(format!(
            "{}: sources[{}].beam.diameter: {} photons of beam position {} started inside a solid cell",
            scene.scene_file.file, scene.beam_source[k], r.tallies.started_inside, r.beam.position
        )));
    }
    Ok(())
}

/// The result of an object trace: traced ([`TraceJob::trace`]) or read
/// back from its result folder ([`TraceResult::read`]), with the same
/// accessors either way. Nested as beam position x wavelength: the rows of
/// [`reflectance`](Self::reflectance) run over the positions, then the
/// wavelengths ([`wavelengths_um`](Self::wavelengths_um)).
///
/// ```
/// use roks::api::{TraceJob, TraceOptions, TraceResult, load_object};
///
/// // A diffuse plate of reflectance 0.5 lit straight down.
/// let scene = r#"
/// [quadrics]
/// top = { plane = [0.0, 0.0, 1.0, 0.0] }
/// bottom = { plane = [0.0, 0.0, 1.0, -1.0] }
/// [[cells]]
/// name = "plate"
/// region = "-top +bottom"
/// fill = "solid"
/// [walls]
/// top = "paint"
/// [models.paint]
/// diffuse = 0.5
/// [[sources]]
/// beam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }
/// position = [0.0, 0.0, 5.0]
/// photons = 4096
/// "#;
/// let dir = std::env::temp_dir().join(format!("roks-api-trace-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// std::fs::write(dir.join("plate.toml"), scene)?;
/// let scene = load_object(&dir.join("plate.toml"), None)?;
/// let result = TraceJob::new(&scene, &TraceOptions::default())?.trace(&|_| {})?;
/// let table = result.reflectance()?;
/// let (r, se) = (table.column("reflectance").unwrap(), table.column("reflectance_stderr").unwrap());
/// assert!((r[0] - 0.5).abs() <= 4.0 * se[0] + 1e-9, "{r:?} {se:?}");
///
/// // Written and read back: the same table.
/// result.write(&dir.join("out"), false)?;
/// let back = TraceResult::read(&dir.join("out"))?;
/// assert_eq!(back.reflectance()?, table);
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct TraceResult {
    summary: TraceSummary,
    files: Vec<(String, Vec<u8>)>,
    traced: Option<(ObjectRun, ObjectResult)>,
}

impl TraceResult {
    /// The result folder `dir` of `roks trace` (or `roks merge` of its
    /// shards), read back: `summary.json` (typed) and every other file.
    ///
    /// # Errors
    /// [`Error::Input`] for a file that is missing or does not fit,
    /// [`Error::Io`] for a folder that cannot be read.
    pub fn read(dir: &Path) -> Result<Self, Error> {
        Self::from_files(dir, read_folder(dir)?)
    }

    /// The result folder `dir` whose `files` (name, bytes) are given, not
    /// yet written (`--report`), read back as [`read`](Self::read) reads it
    /// from disk; `dir` only names its files in messages.
    ///
    /// # Errors
    /// As [`read`](Self::read).
    pub fn from_files(dir: &Path, files: Vec<(String, Vec<u8>)>) -> Result<Self, Error> {
        let name = ResultFile::Summary.path_in(dir).display().to_string();
        let (_, text) = files
            .iter()
            .find(|(n, _)| n == ResultFile::Summary.name())
            .ok_or_else(|| Error::Input(format!("{name}: missing")))?;
        let summary: TraceSummary =
            serde_json::from_slice(text).map_err(|e| Error::Input(format!("{name}: {e}")))?;
        let result = Self {
            summary,
            files,
            traced: None,
        };
        result.reflectance()?;
        // A far field tallied has its file, one never tallied none.
        let tallied = [
            (ResultFile::Farfield, result.summary.farfield),
            (ResultFile::FarfieldStokes, result.summary.farfield_stokes),
        ];
        for (file, said) in tallied {
            if result.table(file.name())?.is_some() != said {
                let how = if said { "missing" } else { "present" };
                return Err(Error::Input(format!(
                    "{}: {how}, while {name} says the far field was{} tallied",
                    file.path_in(dir).display(),
                    if said { "" } else { " not" }
                )));
            }
        }
        Ok(result)
    }

    /// The typed `summary.json`: per beam position the reflectance, the
    /// light missed and absorbed, bounces and losses.
    #[must_use]
    pub fn summary(&self) -> &TraceSummary {
        &self.summary
    }

    /// The wavelengths (µm) of a spectral run; empty for a monochrome one.
    #[must_use]
    pub fn wavelengths_um(&self) -> &[f64] {
        &self.summary.wavelengths_um
    }

    /// `reflectance.csv` as columns: `x`, `y`, `z`, (`wavelength_um`),
    /// `reflectance`, `reflectance_stderr`.
    ///
    /// # Errors
    /// [`Error::Input`] for a table that cannot be read.
    pub fn reflectance(&self) -> Result<Table, Error> {
        self.table(ResultFile::Reflectance.name())?
            .ok_or_else(|| Error::Input(format!("{}: missing", ResultFile::Reflectance)))
    }

    /// `farfield.csv` as columns, `None` when the far field was not tallied.
    ///
    /// # Errors
    /// As [`reflectance`](Self::reflectance).
    pub fn farfield(&self) -> Result<Option<Table>, Error> {
        self.table(ResultFile::Farfield.name())
    }

    /// The result as traced (the run and its sums); `None` when read back.
    #[must_use]
    pub fn traced(&self) -> Option<(&ObjectRun, &ObjectResult)> {
        self.traced.as_ref().map(|(run, result)| (run, result))
    }

    fn table(&self, name: &str) -> Result<Option<Table>, Error> {
        let Some((_, bytes)) = self.files.iter().find(|(n, _)| n == name) else {
            return Ok(None);
        };
        Table::parse(&String::from_utf8_lossy(bytes), name)
            .map(Some)
            .map_err(|e| Error::Input(e.to_string()))
    }

    /// Every file of the result folder.
    #[must_use]
    pub fn files(&self) -> &[(String, Vec<u8>)] {
        &self.files
    }

    /// Write the result folder `out`, replaced whole, after the checks of
    /// [`crate::outdir::check_folder`] (`force`: replace files roks did not
    /// write).
    ///
    /// # Errors
    /// [`Error::Out`] when `out` cannot be a result folder, [`Error::Io`]
    /// when writing fails.
    pub fn write(&self, out: &Path, force: bool) -> Result<(), Error> {
        write_folder(out, &self.files, "trace", force)
    }
}
