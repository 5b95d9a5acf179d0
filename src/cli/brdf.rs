//! `roks brdf`: the tabulated BRDF of a micro scene, whole or one shard of
//! a run, and its result folder.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::parse::{integer, number, positive};
use crate::export::brdf_formats::BrdfFormat;

/// The options of `roks brdf`.
#[derive(Args, Debug)]
pub struct BrdfArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    pub scene: Option<PathBuf>,
    /// Output folder (default: out/<scene name>/), replaced whole by the run
    /// (an existing one must be empty or a roks result).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Photons per incidence angle (overrides [light] photons).
    #[arg(long, value_parser = positive::<u64>)]
    pub photons: Option<u64>,
    /// Tracing seed (overrides [light] seed). Same seed, same result, for any thread count.
    #[arg(long, value_parser = integer::<u64>)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = positive::<usize>)]
    pub threads: Option<usize>,
    /// Incidence angles in degrees, comma-separated (overrides [light] theta_deg).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = number)]
    pub theta: Option<Vec<f64>>,
    /// Entry points (overrides [light] launch): random, or lattice (16
    /// randomly shifted R2 lattices; standard errors from their spread;
    /// photons a multiple of 16).
    #[arg(long, value_parser = ["random", "lattice"])]
    pub launch: Option<String>,
    /// Fold mirror images in the plane of incidence into the Carlson cells
    /// (overrides [tally] symmetry): none, or mirror (only for surfaces whose
    /// statistics are mirror symmetric; halves the variance off the plane).
    #[arg(long, value_parser = ["none", "mirror"])]
    pub symmetry: Option<String>,
    /// Polarisation tally (overrides [tally] polarisation): none, stokes
    /// (DIR/stokes.csv: the Stokes BRDF per cell for the incident state, and
    /// DIR/dop_<theta>deg.png) or mueller (DIR/mueller.csv: the Mueller-matrix
    /// BRDF per cell). Implies polarised transport.
    #[arg(long, value_parser = ["none", "stokes", "mueller"])]
    pub polarisation: Option<String>,
    /// The unpolarised approximation: the weight times (Rs + Rp)/2 at every
    /// Fresnel bounce (overrides [transport] polarisation; default: Stokes
    /// vectors through every bounce when a material is Fresnel).
    #[arg(long)]
    pub no_polarisation: bool,
    /// Height-map resolution for the surface statistics in the summary
    /// (default 512; a height field: its own grid).
    #[arg(long, value_parser = integer::<usize>)]
    pub stats_resolution: Option<usize>,
    /// Run only photon block I of N (0-based; whole batches of 4096 photons)
    /// of every incidence angle and also write DIR/tallies.json, the raw sums
    /// that `roks merge` adds up exactly.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Also export the table, comma-separated formats: zemax (DIR/brdf.bsdf),
    /// merl (DIR/brdf.binary); see `roks export-brdf`.
    #[arg(long, value_delimiter = ',')]
    pub export: Vec<String>,
    /// No progress bar and no table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parse export format names (`--export`), each once, in the order given.
///
/// # Errors
/// Bad input naming `option` for an unknown name.
pub fn parse_formats(names: &[String], option: &str) -> Result<Vec<BrdfFormat>, Failure> {
    let mut formats: Vec<BrdfFormat> = Vec::new();
    for n in names {
        let f = n
            .parse::<BrdfFormat>()
            .map_err(|e| Failure::Input(format!("{option}: {e}")))?;
        if !formats.contains(&f) {
            formats.push(f);
        }
    }
    Ok(formats)
}
