//! The tables the command line prints after a run, as values: each
//! `Display`s as the lines `roks` writes on stderr.

use std::fmt;

use crate::micro::surface_stats::SurfaceStats;
use crate::output::brdf_folder::BrdfFolder;
use crate::scene::micro::MicroScene;
use crate::tally::anisotropy::Figure;
use crate::transport::brdf::IncidenceResult;
use crate::transport::object::{ObjectResult, ObjectRun};

/// The table of a BRDF result per incidence angle (and light azimuth, with
/// several): reflectance, standard error, bounces, losses, speed; with
/// several realisations their spread; with several azimuths the anisotropy
/// figure ([`crate::tally::anisotropy`]) and, beyond its bound, what that
/// means ([`anisotropy_note`]). Each line ends in a newline.
#[derive(Debug, Clone, Copy)]
pub struct BrdfReport<'a> {
    /// The result folder's contents.
    pub folder: &'a BrdfFolder,
    /// Whether the surface is random ([`crate::scene::micro::MicroScene::random`];
    /// `None`: unknown, as for merged shards).
    pub random: Option<bool>,
}

impl fmt::Display for BrdfReport<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let folder = self.folder;
        let results = &folder.results;
        let azimuths = folder.run().phi_deg.len() > 1;
        let spectral = results.iter().any(|r| r.wavelength_um.is_some());
        let lambda = |r: &IncidenceResult| {
            let mut s = String::new();
            if azimuths {
                s += &format!(" {:>7}", r.phi_i_deg);
            }
            if let Some(w) = r.wavelength_um {
                s += &format!(" {w:>8}");
            }
            s
        };
        let columns = format!(
            "{}{}",
            if azimuths { "   phi_i" } else { "" },
            if spectral { "  lambda_um" } else { "" }
        );
        writeln!(
            f,
            "{:>9}{} {:>12} {:>10} {:>8} {:>9} {:>12}",
            "theta_i", columns, "reflectance", "stderr", "bounces", "lost", "Msegments/s"
        )?;
        for r in results {
            let (refl, se) = r.reflectance();
            writeln!(
                f,
                "{:>9.2}{} {:>12.6} {:>10.2e} {:>8.3} {:>9.2e} {:>12.2}",
                r.theta_i_deg,
                lambda(r),
                refl,
                se,
                r.mean_bounces(),
                r.lost(),
                r.segments_per_second() / 1e6
            )?;
        }
        // Several surface realisations: their spread beside the photon noise.
        if results.iter().any(|r| r.realisations.len() > 1) {
            let most = results.iter().map(|r| r.realisations.len()).max();
            writeln!(
                f,
                "{:>9}{} {:>12} {:>14} {:>14}  ({} realisations)",
                "theta_i",
                columns,
                "spread",
                "surface_spread",
                "monte_carlo",
                most.unwrap_or(0)
            )?;
            for r in results {
                if let Some(s) = crate::output::summary::RealisationsSummary::new(&r.realisations) {
                    writeln!(
                        f,
                        "{:>9.2}{} {:>12.2e} {:>14.2e} {:>14.2e}",
                        r.theta_i_deg,
                        lambda(r),
                        s.spread,
                        s.surface_spread,
                        s.monte_carlo_spread
                    )?;
                }
            }
        }
        if let Some(a) = results.anisotropy(&folder.run().grid()) {
            let fig = &a.figure;
            writeln!(
                f,
                "anisotropy: chi2/dof {:.3} over {} cells of {} pairs of azimuths (isotropic within 4 sigma below {:.3}; p = {:.2e})",
                fig.chi2_dof, fig.dof, a.pair_count, fig.bound, fig.p_value
            )?;
            if let Some(note) = anisotropy_note(fig, folder.run().realisations, self.random) {
                writeln!(f, "anisotropy: {note}")?;
            }
        }
        Ok(())
    }
}

/// What an anisotropy figure `f` beyond its bound means for a run of
/// `realisations` surface realisations of a surface that is random or not
/// (`random`; `None`: unknown): one realisation of a random surface is
/// anisotropic by nature (its own hills and valleys do not turn with the
/// light), and the random surface's BRDF is the mean over realisations;
/// an ensemble is judged with its own errors. `None` within the bound, and
/// for a surface known not to be random (its anisotropy is the surface's).
#[must_use]
pub fn anisotropy_note(f: &Figure, realisations: u64, random: Option<bool>) -> Option<String> {
    if f.isotropic() || random == Some(false) {
        return None;
    }
    let what = "one realisation of a random surface is anisotropic by nature (its own hills and valleys do not turn with the light), while the random surface's BRDF is the mean over realisations";
    let advice = "set [surface] realisations = R (16 or more; the tables' errors are then the ensemble's) and judge the ensemble";
    Some(match (realisations, random) {
        (1, Some(true)) => format!("{what}: {advice}"),
        (1, _) => format!(
            "if the surface is random (a gaussian height field, random bumps), {what}: {advice}"
        ),
        (r, _) => format!(
            "beyond the bound with the errors of the mean over {r} realisations: the random surface itself is anisotropic (a height field's triangles turn onto themselves only by half turns), or the realisations are too few to average its hills and valleys"
        ),
    })
}

/// The table of an object trace per beam position (a spectral run: per
/// position and wavelength; a shard: the positions it traced):
/// reflectance, standard error, missed light, bounces, losses. Each line
/// ends in a newline.
#[derive(Debug, Clone, Copy)]
pub struct TraceReport<'a> {
    /// The run traced.
    pub run: &'a ObjectRun,
    /// Its result.
    pub result: &'a ObjectResult,
}

impl fmt::Display for TraceReport<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let spectral = !self.run.wavelengths_um.is_empty();
        writeln!(
            f,
            "{:>28}{} {:>12} {:>10} {:>9} {:>8} {:>9}",
            "beam position",
            if spectral { "  wavelength_um" } else { "" },
            "reflectance",
            "stderr",
            "missed",
            "bounces",
            "lost"
        )?;
        for r in self.result.iter().filter(|r| r.tallies.photons > 0) {
            let (refl, se) = r.reflectance();
            let n = r.tallies.photons as f64;
            let p = r.beam.position;
            writeln!(
                f,
                "{:>28}{} {:>12.4e} {:>10.2e} {:>9.4} {:>8.3} {:>9.2e}",
                format!("({:.3}, {:.3}, {:.3})", p.x, p.y, p.z),
                r.wavelength_um
                    .map_or_else(String::new, |w| format!(" {w:>14}")),
                refl,
                se,
                r.tallies.missed / n,
                r.tallies.bounces as f64 / n,
                r.tallies.lost / n
            )?;
        }
        Ok(())
    }
}

/// The surface statistics of a micro scene as `roks stats` prints them:
/// the scene file, the cell, the height-map grid, with several
/// realisations a line saying the statistics are realisation 0's, then
/// sigma, tau, sigma/tau, RMS slope, heights and the solids' acceleration
/// figures, one per line (each ending in a newline).
#[derive(Debug, Clone, Copy)]
pub struct StatsReport<'a> {
    /// The scene.
    pub scene: &'a MicroScene,
    /// The statistics of its height map.
    pub stats: &'a SurfaceStats,
    /// The height map's samples per side (x, y).
    pub grid: (usize, usize),
}

impl fmt::Display for StatsReport<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (scene, s, (r, ry)) = (self.scene, self.stats, self.grid);
        let size = scene.surface.size;
        writeln!(f, "scene            {}", scene.scene_file.file)?;
        writeln!(
            f,
            "cell             {} x {} ({:?} edges)",
            size.x, size.y, scene.surface.edges
        )?;
        writeln!(f, "height map       {r} x {ry}")?;
        let realisations = scene.run.realisations;
        if realisations > 1 {
            writeln!(
                f,
                "realisations     {realisations}: statistics of realisation 0 (the scene's own seed) only"
            )?;
        }
        writeln!(
            f,
            "sigma            {:.6}   RMS height about the mean",
            s.sigma
        )?;
        match s.tau_undefined {
            None => {
                writeln!(
                    f,
                    "tau              {:.6}   lag where the radial autocorrelation falls to 1/e",
                    s.tau
                )?;
                writeln!(f, "sigma_over_tau   {:.6}", s.sigma_over_tau)?;
            }
            Some(why) => {
                writeln!(f, "tau              {why}")?;
                writeln!(f, "sigma_over_tau   undefined (tau is undefined)")?;
            }
        }
        writeln!(
            f,
            "rms_slope        {:.6}   sqrt(mean |grad h|^2)",
            s.rms_slope
        )?;
        writeln!(f, "mean_height      {:.6}", s.mean)?;
        writeln!(f, "max_height       {:.6}", s.max_height)?;
        writeln!(f, "min_height       {:.6}", s.min_height)?;
        let (global, per_cell) = scene.surface.acceleration_stats();
        writeln!(
            f,
            "solids           {} ({} tested per flight, {:.1} per grid cell)",
            scene.surface.solids().len(),
            global,
            per_cell
        )
    }
}
