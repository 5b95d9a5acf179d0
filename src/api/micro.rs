//! The micro level through the API: a BRDF run of a micro scene
//! ([`BrdfJob`]), its result ([`BrdfResult`]), written as and read back
//! from a result folder.

use std::path::Path;

use super::{Error, Table, read_folder, write_folder};
use crate::micro::surface_stats::surface_stats;
use crate::outdir::file::ResultFile;
use crate::output::brdf_folder::BrdfFolder;
use crate::output::summary::{BrdfSummary, Description, Surface};
use crate::scene::micro::MicroScene;
use crate::shard::Shard;
use crate::transport::brdf::{BrdfRun, ShardRange};

/// Height-map samples per side of the grid of the surface statistics,
/// unless given: the same for `roks brdf` (summary.json's `surface`) and
/// `roks stats`, so the two print the same figures.
pub const STATS_RESOLUTION: usize = 512;

/// What a BRDF run adds to its scene (`roks brdf`'s options that are not
/// scene keys; those are [`crate::scene::micro::Overrides`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BrdfOptions {
    /// Trace only photon block `index` of `count` of every incidence
    /// (`--shard I/N`); the result then keeps its raw sums for `roks merge`.
    pub shard: Option<Shard>,
    /// Height-map samples per side for the surface statistics
    /// (`--stats-resolution`; default [`STATS_RESOLUTION`], a height
    /// field: its own grid).
    pub stats_resolution: Option<usize>,
}

/// A BRDF run of a micro scene, checked and ready to trace.
#[derive(Debug, Clone)]
pub struct BrdfJob<'s> {
    scene: &'s MicroScene,
    run: BrdfRun,
    grid: (usize, usize),
}

impl<'s> BrdfJob<'s> {
    /// The run of `scene` with `options`, checked as `roks brdf` checks
    /// them (the statistics grid, then the shard), before any work.
    ///
    /// # Errors
    /// [`Error::Option`] naming `--stats-resolution` or `--shard`.
    pub fn new(scene: &'s MicroScene, options: &BrdfOptions) -> Result<Self, Error> {
        let mut run = scene.brdf_run();
        let grid = super::stats_grid(
            scene,
            options.stats_resolution,
            STATS_RESOLUTION,
            "--stats-resolution",
        )?;
        if let Some(s) = options.shard {
            let (first_photon, last_photon) = s
                .photon_range(run.photons)
                .map_err(|e| Error::option("--shard", e))?;
            run.shard = Some(ShardRange {
                count: s.count,
                first_photon,
                index: s.index,
                last_photon,
            });
        }
        Ok(Self { scene, run, grid })
    }

    /// The run as it will be traced (a shard's block in `run.shard`).
    #[must_use]
    pub fn run(&self) -> &BrdfRun {
        &self.run
    }

    /// What the run traces, in words: `N incidence angles x M light
    /// azimuths, P photons each[, shard I/N]`.
    #[must_use]
    pub fn what(&self) -> String {
        let run = &self.run;
        format!(
            "{} incidence angles x {} light azimuths, {} photons each{}",
            run.theta_deg.len(),
            run.phi_deg.len(),
            run.photons,
            run.shard.map_or(String::new(), |s| format!(
                ", shard {}/{}",
                s.index, s.count
            ))
        )
    }

    /// The photons this run traces in all (for a progress bar).
    #[must_use]
    pub fn photons(&self) -> u64 {
        let r = self.run.photon_range();
        let lanes = (self.run.theta_deg.len() * self.run.phi_deg.len()) as u64;
        (r.end - r.start).saturating_mul(lanes)
    }

    /// Trace the run; `progress` is called with the photons done after
    /// each batch (from any thread).
    ///
    /// # Errors
    /// [`Error::Io`] when the picture of the surface cannot be drawn.
    pub fn trace(self, progress: &(dyn Fn(u64) + Sync)) -> Result<BrdfResult, Error> {
        let scene = self.scene;
        let (rx, ry) = self.grid;
        let map = scene.surface.height_map(rx, ry);
        let stats = surface_stats(&map);
        let surface_png = crate::plot::SurfacePicture {
            title: format!(
                "{}: the micro surface, one period ({} x {} scene units)",
                scene.name, scene.surface.size.x, scene.surface.size.y
            ),
            map: &map,
            stats: Surface::new(&stats, map.nx),
        }
        .to_png()?;
        drop(map);
        let photons = self.run.photon_range();
        let description = Description::new(
            scene.content.clone(),
            &scene.scene_file.file,
            &scene.name,
            scene.surface.edges,
            self.run,
            Surface::new(&stats, rx),
        );
        let clock = std::time::Instant::now();
        let results = description
            .run
            .trace_realisations(&scene.surfaces(), photons, progress);
        if crate::interrupt::cancelled() {
            return Err(Error::Interrupted);
        }
        let folder = BrdfFolder::traced(description, results, clock.elapsed().as_secs_f64());
        Ok(BrdfResult {
            summary: std::sync::OnceLock::new(),
            files: Vec::new(),
            traced: Some(Traced {
                folder,
                surface_png,
                random: scene.random,
            }),
        })
    }
}

impl BrdfJob<'_> {
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
    ) -> Result<BrdfResult, Error> {
        control.run(|| self.trace(progress))
    }
}

/// What only a traced result holds: the exact sums.
#[derive(Debug, Clone)]
struct Traced {
    folder: BrdfFolder,
    surface_png: Vec<u8>,
    random: bool,
}

/// The result of a BRDF run: traced ([`BrdfJob::trace`]) or read back
/// from its result folder ([`BrdfResult::read`]), with the same accessors
/// either way.
///
/// The result tree is nested as incidence angle ([`theta_deg`](Self::theta_deg))
/// x light azimuth ([`phi_deg`](Self::phi_deg)) x wavelength
/// ([`wavelengths_um`](Self::wavelengths_um); none for a monochrome run);
/// [`brdf`](Self::brdf) gives the table of `brdf.csv`, whose rows run in
/// that order and then over the Carlson cells of the run's grid.
///
/// ```
/// use roks::api::{BrdfJob, BrdfOptions, BrdfResult, Overrides, load_micro};
///
/// // The embedded default scene, at one incidence, with few photons.
/// let overrides = Overrides {
///     photons: Some(4096),
///     theta_deg: Some(vec![30.0]),
///     ..Overrides::default()
/// };
/// let scene = load_micro(None, &overrides)?;
/// let options = BrdfOptions { stats_resolution: Some(32), ..BrdfOptions::default() };
/// let result = BrdfJob::new(&scene, &options)?.trace(&|_| {})?;
/// assert_eq!(result.theta_deg(), [30.0]);
/// let (r, se) = (result.reflectance(), result.reflectance_stderr());
/// assert!(r[0] > 0.0 && r[0] <= 1.0 && se[0] > 0.0);
///
/// // Written as a result folder and read back: the same tables.
/// let dir = std::env::temp_dir().join(format!("roks-api-doc-{}", std::process::id()));
/// result.write(&dir, false)?;
/// let back = BrdfResult::read(&dir)?;
/// assert_eq!(back.reflectance(), r);
/// let brdf = result.brdf()?;
/// assert_eq!(back.brdf()?.column("brdf"), brdf.column("brdf"));
/// assert_eq!(brdf.rows(), result.cells());
/// assert_eq!(result.shape(), [1, 1, 1, result.cells()]);
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct BrdfResult {
    /// `summary.json`: read, or made on the first call from the traced sums.
    summary: std::sync::OnceLock<BrdfSummary>,
    /// A result read back: its files as read.
    files: Vec<(String, Vec<u8>)>,
    traced: Option<Traced>,
}

impl BrdfResult {
    /// The result folder `dir` of `roks brdf` or `roks merge`, read back:
    /// `summary.json` (typed) and `brdf.csv`, checked against each other
    /// by the checked readers ([`crate::optics::brdf_table::BrdfTables`]),
    /// and every other file of the folder as it is.
    ///
    /// # Errors
    /// [`Error::Input`] for a file that is missing or does not fit (one
    /// line naming it), [`Error::Io`] for a folder that cannot be read.
    pub fn read(dir: &Path) -> Result<Self, Error> {
        Self::from_files(dir, read_folder(dir)?)
    }

    /// The result folder `dir` whose `files` (name, bytes) are given, not
    /// yet written (`roks merge --report`), read back as [`read`](Self::read)
    /// reads it from disk; `dir` only names its files in messages.
    ///
    /// # Errors
    /// As [`read`](Self::read).
    pub fn from_files(dir: &Path, files: Vec<(String, Vec<u8>)>) -> Result<Self, Error> {
        let file = |name: &str| {
            files
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, b)| String::from_utf8_lossy(b).into_owned())
                .ok_or_else(|| Error::Input(format!("{}: missing", dir.join(name).display())))
        };
        let summary_name = ResultFile::Summary.path_in(dir).display().to_string();
        let summary_text = file(ResultFile::Summary.name())?;
        let summary: BrdfSummary = serde_json::from_str(&summary_text)
            .map_err(|e| Error::Input(format!("{summary_name}: {e}")))?;
        let table_name = ResultFile::Brdf.path_in(dir).display().to_string();
        let tables = crate::optics::brdf_table::BrdfTables::parse(
            &file(ResultFile::Brdf.name())?,
            &table_name,
        )
        .and_then(|t| t.with_summary_text(&summary_text, &summary_name))
        .map_err(|e| Error::Input(e.to_string()))?;
        if let Ok(text) = file(ResultFile::Mueller.name()) {
            let name = ResultFile::Mueller.path_in(dir).display().to_string();
            tables
                .with_mueller_text(&text, &name)
                .map_err(|e| Error::Input(e.to_string()))?;
        }
        Ok(Self {
            summary: summary.into(),
            files,
            traced: None,
        })
    }

    /// The typed `summary.json`: the run, the scene and per incidence (and
    /// azimuth) the reflectance, losses and speed.
    #[must_use]
    pub fn summary(&self) -> &BrdfSummary {
        self.summary.get_or_init(|| {
            let t = self
                .traced
                .as_ref()
                .expect("a result read back has its summary");
            t.folder.summary()
        })
    }

    /// The run (for a shard: the whole run's photons, its block in `shard`).
    #[must_use]
    pub fn run(&self) -> &BrdfRun {
        match &self.traced {
            Some(t) => t.folder.run(),
            None => &self.summary().run,
        }
    }

    /// Axis 1 of the tree: the incidence angles (degrees from the normal).
    #[must_use]
    pub fn theta_deg(&self) -> &[f64] {
        &self.run().theta_deg
    }

    /// Axis 2 of the tree: the light azimuths (degrees).
    #[must_use]
    pub fn phi_deg(&self) -> &[f64] {
        &self.run().phi_deg
    }

    /// Axis 3 of the tree: the wavelengths (µm); empty for a monochrome run.
    #[must_use]
    pub fn wavelengths_um(&self) -> &[f64] {
        &self.run().wavelengths_um
    }

    /// The shape of the tree's tables, `[incidence angles, light azimuths,
    /// wavelengths (1 for a monochrome run), Carlson cells]`: the rows of
    /// [`brdf`](Self::brdf) reshaped (row-major) to it.
    #[must_use]
    pub fn shape(&self) -> [usize; 4] {
        let lanes = self.wavelengths_um().len().max(1);
        [
            self.theta_deg().len(),
            self.phi_deg().len(),
            lanes,
            self.cells(),
        ]
    }

    /// The Carlson cells of one incidence's block of `brdf.csv`: `2 M (M + 1)`
    /// for `M` bands.
    #[must_use]
    pub fn cells(&self) -> usize {
        self.run().grid().n_cells()
    }

    /// The reflectance per incidence angle and azimuth (directional-
    /// hemispherical, summed over the wavelengths' mean for a spectral
    /// run), in tree order.
    #[must_use]
    pub fn reflectance(&self) -> Vec<f64> {
        self.summary()
            .incidence
            .iter()
            .map(|i| i.reflectance)
            .collect()
    }

    /// The standard errors of [`reflectance`](Self::reflectance).
    #[must_use]
    pub fn reflectance_stderr(&self) -> Vec<f64> {
        let i = &self.summary().incidence;
        i.iter().map(|i| i.reflectance_stderr).collect()
    }

    /// `brdf.csv` as columns (`fraction`, `brdf`, `brdf_stderr`, the cell
    /// geometry, ...).
    ///
    /// # Errors
    /// [`Error::Input`] for a table that cannot be read (a folder whose
    /// file was altered).
    pub fn brdf(&self) -> Result<Table, Error> {
        self.table(ResultFile::Brdf.name())
    }

    /// `inplane.csv` (the BRDF in the plane of incidence) as columns.
    ///
    /// # Errors
    /// As [`brdf`](Self::brdf).
    pub fn inplane(&self) -> Result<Table, Error> {
        self.table(ResultFile::Inplane.name())
    }

    /// The polarisation table (`stokes.csv` or `mueller.csv`) as columns,
    /// `None` for a run without one.
    ///
    /// # Errors
    /// As [`brdf`](Self::brdf).
    pub fn polarisation(&self) -> Result<Option<Table>, Error> {
        [ResultFile::Stokes.name(), ResultFile::Mueller.name()]
            .into_iter()
            .find(|n| self.file(n).is_some())
            .map(|n| self.table(n))
            .transpose()
    }

    /// The result as traced: the exact sums of every leaf (incidence,
    /// azimuth, wavelength) and the run's description; `None` for a result
    /// read back from its files.
    #[must_use]
    pub fn traced(&self) -> Option<&BrdfFolder> {
        self.traced.as_ref().map(|t| &t.folder)
    }

    /// Whether the traced surface is random (`None` when read back).
    #[must_use]
    pub fn random(&self) -> Option<bool> {
        self.traced.as_ref().map(|t| t.random)
    }

    /// The folder's file `name` (a read result's, or a traced result's
    /// tables), if it has one.
    #[must_use]
    pub fn file(&self, name: &str) -> Option<Vec<u8>> {
        match &self.traced {
            Some(t) => t
                .folder
                .files(Vec::new())
                .into_iter()
                .find(|(n, _)| n == name)
                .map(|(_, b)| b),
            None => self
                .files
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, b)| b.clone()),
        }
    }

    /// The names of the folder's files (a read result's, or a traced
    /// result's tables), in the folder's order.
    #[must_use]
    pub fn file_names(&self) -> Vec<String> {
        match &self.traced {
            Some(t) => t
                .folder
                .files(Vec::new())
                .into_iter()
                .map(|(n, _)| n)
                .collect(),
            None => self.files.iter().map(|(n, _)| n.clone()).collect(),
        }
    }

    fn table(&self, name: &str) -> Result<Table, Error> {
        let bytes = self
            .file(name)
            .ok_or_else(|| Error::Input(format!("{name}: missing")))?;
        Table::parse(&String::from_utf8_lossy(&bytes), name)
            .map_err(|e| Error::Input(e.to_string()))
    }

    /// Every file of the result folder, `extra` (exports) after the tables:
    /// traced, the tables, `extra`, `tallies.json` (a shard), `summary.json`,
    /// the pictures and `surface.png`; read back, the files as read and
    /// `extra`.
    ///
    /// # Errors
    /// [`Error::Io`] when a picture cannot be drawn.
    pub fn files(&self, extra: Vec<(String, Vec<u8>)>) -> Result<Vec<(String, Vec<u8>)>, Error> {
        let Some(t) = &self.traced else {
            let mut files = self.files.clone();
            files.extend(extra);
            return Ok(files);
        };
        let mut files = t.folder.files(extra);
        crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
        files.push((
            ResultFile::SurfacePicture.name().into(),
            t.surface_png.clone(),
        ));
        Ok(files)
    }

    /// Write the result folder `out`, replaced whole, after the checks of
    /// [`crate::outdir::check_folder`] (`force`: replace files roks did not
    /// write).
    ///
    /// # Errors
    /// [`Error::Out`] when `out` cannot be a result folder, [`Error::Io`]
    /// when writing fails.
    pub fn write(&self, out: &Path, force: bool) -> Result<(), Error> {
        write_folder(out, &self.files(Vec::new())?, "brdf", force)
    }
}
