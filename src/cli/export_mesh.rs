//! `roks export-mesh`: a micro scene's top surface over one period, or an
//! object scene's solid walls in a box, as a binary PLY triangle mesh.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use super::common::{FileKind, check_memory, check_out_file, load_scene, own_grid, write_file};
use super::parse::{integer, number};
use crate::export::object_mesh::{MAX_VOXELS_PER_SIDE, object_mesh};
use crate::scene::SceneKind;
use crate::scene::object::ObjectScene;

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
    let resolution = a.resolution.unwrap_or(512);
    if !(1..=crate::export::MAX_CELLS_PER_SIDE).contains(&resolution) {
        return Err(Failure::Input(format!(
            "--resolution: must be in 1..={}, got {resolution}",
            crate::export::MAX_CELLS_PER_SIDE,
        )));
    }
    let scene = load_scene(a.scene.as_deref())?;
    own_grid(&scene, a.resolution)?;
    let n = scene
        .surface
        .heightfield()
        .map_or((resolution, resolution), |f| (f.nx, f.ny));
    check_memory(
        "--resolution",
        &format!("a mesh of {} x {} grid squares", n.0, n.1),
        crate::export::mesh_memory_bytes(n.0, n.1),
    )?;
    check_out_file(&a.out, &scene.reads, FileKind::Ply, a.force)?;
    let mesh = match scene.surface.heightfield() {
        Some(field) => crate::export::field_mesh(field),
        None => crate::export::height_field_mesh(&scene.surface, resolution),
    };
    write_file(&a.out, &crate::export::write_ply(&mesh))?;
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
    let Some(b) = a.bounds.as_ref().filter(|b| b.len() == 6) else {
        return Err(Failure::Input(format!(
            "{}: --bounds: an object scene needs the box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX to mesh",
            scene.scene_file.file
        )));
    };
    let resolution = a.resolution.unwrap_or(512);
    if !(1..=MAX_VOXELS_PER_SIDE).contains(&resolution) {
        return Err(Failure::Input(format!(
            "--resolution: must be in 1..={MAX_VOXELS_PER_SIDE} for object scenes, got {resolution}"
        )));
    }
    let lo = glam::DVec3::new(b[0], b[1], b[2]);
    let hi = glam::DVec3::new(b[3], b[4], b[5]);
    if lo.is_finite() && hi.is_finite() && (hi - lo).min_element() > 0.0 {
        let bytes = crate::export::object_mesh::memory_bytes(lo, hi, resolution);
        let what = format!("the voxel grid of resolution {resolution} over --bounds");
        check_memory("--resolution", &what, bytes)?;
    }
    check_out_file(&a.out, &scene.reads, FileKind::Ply, a.force)?;
    let mesh = object_mesh(&scene.object, lo, hi, resolution)
        .map_err(|e| Failure::Input(format!("{}: --bounds: {e}", scene.scene_file.file)))?;
    if mesh.faces.is_empty() {
        return Err(Failure::Input(format!(
            "{}: --bounds: no solid wall inside the box {lo} .. {hi}",
            scene.scene_file.file
        )));
    }
    write_file(&a.out, &crate::export::write_ply(&mesh))?;
    eprintln!(
        "wrote {} ({} vertices, {} triangles: the solid walls of {} in the box)",
        a.out.display(),
        mesh.vertices.len(),
        mesh.faces.len(),
        scene.name
    );
    Ok(())
}
