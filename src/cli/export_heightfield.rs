//! `roks export-heightfield`: the heights of a micro scene as a height map
//! file (EXR or text) that a scene's `heightfield = { file = ... }` loads.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::api::mesh::HeightMapFile;
use crate::api::values::integer;
use crate::api::{Overrides, load_micro, own_grid};
use crate::micro::heightfield_io::Format;
use crate::outdir::{check::check_out_file_as, kind::FileKind, write::write_file};

/// The options of `roks export-heightfield`.
#[derive(Args, Debug)]
pub struct ExportHeightfieldArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    pub scene: Option<PathBuf>,
    /// Output file: .exr (one f32 channel Y) or .txt (text grid, exact).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace an existing OUT even when it is not a height map that roks
    /// wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
    /// Vertices per side for a scene of bumps (default 512); a height-field
    /// scene writes its own grid and only accepts its own resolution.
    #[arg(long, value_parser = integer::<usize>)]
    pub resolution: Option<usize>,
}

/// Run `roks export-heightfield`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: ExportHeightfieldArgs) -> Result<(), Failure> {
    let format = Format::of(&a.out);
    if format == Format::Png {
        return Err(Failure::Input(
            "--out: PNG height maps are read, not written; use .exr or .txt".into(),
        ));
    }
    let scene = load_micro(a.scene.as_deref(), &Overrides::default())?;
    own_grid(&scene, a.resolution)?;
    let kind = if format == Format::Exr {
        FileKind::Exr
    } else {
        FileKind::HeightText
    };
    check_out_file_as("--out", &a.out, &scene.reads, kind, a.force)?;
    let ext = a
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("exr" | "txt")) {
        return Err(Failure::Input(format!(
            "--out: the extension picks the format, .exr or .txt; got `{}`",
            a.out.display()
        )));
    }
    let file = HeightMapFile::of(&scene, a.resolution, format)?;
    write_file(&a.out, &file.bytes)?;
    let name = a
        .out
        .file_name()
        .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    eprintln!(
        "wrote {} ({} x {} heights); load it with, in [surface]:\n{}",
        a.out.display(),
        file.grid.0,
        file.grid.1,
        file.scene_keys(&name)
    );
    Ok(())
}
