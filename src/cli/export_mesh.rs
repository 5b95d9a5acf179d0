//! `roks export-mesh`: a micro scene's top surface over one period, or an
//! object scene's solid walls in a box, as a binary PLY triangle mesh.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use crate::api::values::{integer, number};
use crate::api::{ObjectScene, Overrides, load_micro, mesh};
use crate::export::write_ply;
use crate::outdir::{check::check_out_file_as, kind::FileKind, write::write_file};
use crate::scene::SceneKind;

/// The options of `roks export-mesh`.
#[derive(Args, Debug)]
pub struct ExportMeshArgs {
    /// Micro or object scene file (TOML; an object scene has [[cells]]);
    /// omitted: the embedded default micro scene.
    pub scene: Option<PathBuf>,
    /// Output PLY file.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace an existing OUT even when it is not a PLY mesh that roks
    /// wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
    /// Grid cells per side of the period (default 512; a height-field scene
    /// writes its own grid and triangles, and only accepts its own
    /// resolution); for object scenes, voxels along the longest side of
    /// --bounds (default 512).
    #[arg(long, value_parser = integer::<usize>)]
    pub resolution: Option<usize>,
    /// Object scenes (required there): the box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX
    /// whose solid walls are meshed (solids cut by it are capped).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_parser = number, action = clap::ArgAction::Set)]
    pub bounds: Option<Vec<f64>>,
}

/// Run `roks export-mesh`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: ExportMeshArgs) -> Result<(), Failure> {
    // A file that cannot be read is left to the micro loader's message.
    if let Some(path) = a
        .scene
        .as_deref()
        .filter(|p| matches!(crate::scene::kind(p), Ok(SceneKind::Object)))
    {
        return object(&a, path);
    }
    if a.bounds.is_some() {
        // A micro scene's mesh is its one period: nothing to box.
        return Err(Failure::Input(
            "--bounds: only for an object scene (a micro scene's mesh is one period of its surface)"
                .to_owned(),
        ));
    }
    let n = mesh::micro_resolution(a.resolution)?;
    let scene = load_micro(a.scene.as_deref(), &Overrides::default())?;
    mesh::check_micro(&scene, a.resolution, n)?;
    check_out_file_as("--out", &a.out, &scene.reads, FileKind::Ply, a.force)?;
    let mesh = mesh::micro_mesh(&scene, n);
    write_file(&a.out, &write_ply(&mesh))?;
    eprintln!(
        "wrote {} ({} vertices, {} triangles, one {} x {} period)",
        a.out.display(),
        mesh.vertices.len(),
        mesh.faces.len(),
        scene.surface.size.x,
        scene.surface.size.y
    );
    Ok(())
}

/// `roks export-mesh` of an object scene: its solid walls in a box.
fn object(a: &ExportMeshArgs, path: &Path) -> Result<(), Failure> {
    let scene = ObjectScene::load(path)?;
    let (lo, hi, n) = mesh::object_box(&scene, a.bounds.as_deref(), a.resolution)?;
    check_out_file_as("--out", &a.out, &scene.reads, FileKind::Ply, a.force)?;
    let mesh = mesh::object_mesh(&scene, lo, hi, n)?;
    write_file(&a.out, &write_ply(&mesh))?;
    eprintln!(
        "wrote {} ({} vertices, {} triangles: the solid walls of {} in the box)",
        a.out.display(),
        mesh.vertices.len(),
        mesh.faces.len(),
        scene.name
    );
    Ok(())
}
