//! `roks plot`: redraw every picture of a result folder from its files
//! (micro, object, spectral, polarised, merged or shard folders), made by
//! [`crate::api::redraw`].

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::outdir::file::ResultFile;

/// The options of `roks plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A result folder of `roks brdf`, `merge` or `trace`.
    pub dir: PathBuf,
    /// Nothing on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// Replace a picture even when the file of its name in DIR is not a
    /// PNG that roks wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
}

/// Run `roks plot`: the pictures made from the folder's files
/// ([`crate::api::redraw`]) written into it, each atomically (a temporary
/// file, then a rename); `surface.png` too when the folder's scene file
/// (`summary.json`'s `scene`) still gives the surface of the run (the same
/// statistics).
///
/// # Errors
/// Bad input: not a result folder, or a file of it that cannot be read
/// (one line naming it); a failed write.
pub fn execute(a: PlotArgs) -> Result<(), Failure> {
    let dir = &a.dir;
    let redrawn = crate::api::redraw::redraw(dir)?;
    if let (Err(why), false) = (&redrawn.surface, a.quiet) {
        eprintln!("roks: {} not redrawn: {why}", ResultFile::SurfacePicture);
    }
    // Every picture checked before any is written.
    redrawn.check_replace(dir, a.force)?;
    // All or none, for an interrupt.
    let _commit = crate::interrupt::commit();
    for (name, png) in &redrawn.pictures {
        crate::outdir::write::write_file(&dir.join(name), png)?;
    }
    if !a.quiet {
        let names: Vec<&str> = redrawn.pictures.iter().map(|p| p.0.as_str()).collect();
        eprintln!(
            "redrew {} pictures in {}: {}",
            names.len(),
            dir.display(),
            names.join(", ")
        );
    }
    Ok(())
}
