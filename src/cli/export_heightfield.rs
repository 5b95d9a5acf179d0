//! `roks export-heightfield`: the heights of a micro scene as a height map
//! file (EXR or text) that a scene's `heightfield = { file = ... }` loads.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::common::{FileKind, check_memory, check_out_file, load_scene, own_grid, write_file};
use super::parse::integer;
use crate::micro::heightfield_io::{self, Format, HeightGrid};

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
    let scene = load_scene(a.scene.as_deref())?;
    own_grid(&scene, a.resolution)?;
    let kind = if format == Format::Exr {
        FileKind::Exr
    } else {
        FileKind::HeightText
    };
    check_out_file(&a.out, &scene.reads, kind, a.force)?;
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
    let grid = match scene.surface.heightfield() {
        Some(f) => HeightGrid {
            nx: f.nx,
            ny: f.ny,
            h: f.h.clone(),
        },
        None => {
            let n = a.resolution.unwrap_or(512);
            if !(2..=16384).contains(&n) {
                return Err(Failure::Input(format!(
                    "--resolution: must be in 2..=16384, got {n}"
                )));
            }
            // Heights (8 bytes) and the file (up to 24 bytes of text) per vertex.
            let bytes = crate::limits::product(&[n as u64, n as u64, 32]);
            check_memory("--resolution", &format!("a {n} x {n} height map"), bytes)?;
            let s = scene.surface.size;
            let mut scratch = crate::micro::Scratch::new(&scene.surface);
            let h: Vec<f64> = (0..n * n)
                .map(|k| {
                    let (i, j) = ((k % n) as f64, (k / n) as f64);
                    scene.surface.height_at(
                        s.x * (i / n as f64),
                        s.y * (j / n as f64),
                        &mut scratch,
                    )
                })
                .collect();
            HeightGrid { nx: n, ny: n, h }
        }
    };
    let size = scene.surface.size;
    let (px, py) = (size.x / grid.nx as f64, size.y / grid.ny as f64);
    let comment = format!(
        "roks height map of {}: {} x {} vertices, pitch {px:?} x {py:?} (length units); row j is y = j * pitch",
        scene.scene_file.file, grid.nx, grid.ny
    );
    let bytes = heightfield_io::write(&grid, format, &comment).map_err(|e| anyhow::anyhow!(e))?;
    write_file(&a.out, &bytes)?;
    let file = a
        .out
        .file_name()
        .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    let keys = if px == py {
        format!("heightfield = {{ file = {file:?}, pixel = {px:?} }}")
    } else {
        format!(
            "size = [{:?}, {:?}]\nheightfield = {{ file = {file:?} }}",
            size.x, size.y
        )
    };
    eprintln!(
        "wrote {} ({} x {} heights); load it with, in [surface]:\n{keys}",
        a.out.display(),
        grid.nx,
        grid.ny
    );
    Ok(())
}
