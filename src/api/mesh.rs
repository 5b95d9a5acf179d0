//! The geometry of a scene as files other programs read: a micro scene's
//! top surface over one period or an object scene's solid walls in a box
//! as a triangle mesh (`roks export-mesh`), and a micro scene's heights as
//! a height map file (`roks export-heightfield`). Each check returns the
//! command line's message as an [`Error`].

use glam::DVec3;

use super::{Error, MicroScene, ObjectScene, check_memory};
use crate::export::Mesh;
use crate::export::object_mesh::{MAX_VOXELS_PER_SIDE, memory_bytes};
use crate::micro::heightfield_io::{self, Format, HeightGrid};

/// The grid squares per side of a micro mesh: `resolution` (`--resolution`,
/// default 512) checked against [`crate::export::MAX_CELLS_PER_SIDE`].
///
/// # Errors
/// [`Error::Option`] naming `--resolution`.
pub fn micro_resolution(resolution: Option<usize>) -> Result<usize, Error> {
    let n = resolution.unwrap_or(512);
    let max = crate::export::MAX_CELLS_PER_SIDE;
    if (1..=max).contains(&n) {
        Ok(n)
    } else {
        Err(Error::option(
            "--resolution",
            format!("must be in 1..={max}, got {n}"),
        ))
    }
}

/// Check the mesh of `scene` of `n` squares per side (`resolution` as
/// given): a height field only takes its own grid ([`super::own_grid`]),
/// and the mesh must fit in memory.
///
/// # Errors
/// [`Error::Option`] naming `--resolution`.
pub fn check_micro(scene: &MicroScene, resolution: Option<usize>, n: usize) -> Result<(), Error> {
    super::own_grid(scene, resolution)?;
    let (nx, ny) = scene.surface.heightfield().map_or((n, n), |f| (f.nx, f.ny));
    check_memory(
        "--resolution",
        &format!("a mesh of {nx} x {ny} grid squares"),
        crate::export::mesh_memory_bytes(nx, ny),
    )
}

/// The top surface of `scene` over one period: a height field's own
/// triangles, or `n` x `n` squares of the surface's heights.
#[must_use]
pub fn micro_mesh(scene: &MicroScene, n: usize) -> Mesh {
    match scene.surface.heightfield() {
        Some(field) => crate::export::field_mesh(field),
        None => crate::export::height_field_mesh(&scene.surface, n),
    }
}

/// The box (`--bounds`: XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX) and the voxels
/// along its longest side (`--resolution`, default 512) of an object
/// scene's mesh, checked (and its memory, for a box with positive sides).
///
/// # Errors
/// [`Error::Input`] naming the scene file and `--bounds` when no box is
/// given; [`Error::Option`] naming `--resolution`.
pub fn object_box(
    scene: &ObjectScene,
    bounds: Option<&[f64]>,
    resolution: Option<usize>,
) -> Result<(DVec3, DVec3, usize), Error> {
    let Some(b) = bounds.filter(|b| b.len() == 6) else {
        return Err(Error::Input(format!(
            "{}: --bounds: an object scene needs the box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX to mesh",
            scene.scene_file.file
        )));
    };
    let n = resolution.unwrap_or(512);
    if !(1..=MAX_VOXELS_PER_SIDE).contains(&n) {
        return Err(Error::option(
            "--resolution",
            format!("must be in 1..={MAX_VOXELS_PER_SIDE} for object scenes, got {n}"),
        ));
    }
    let lo = DVec3::new(b[0], b[1], b[2]);
    let hi = DVec3::new(b[3], b[4], b[5]);
    if lo.is_finite() && hi.is_finite() && (hi - lo).min_element() > 0.0 {
        let what = format!("the voxel grid of resolution {n} over --bounds");
        check_memory("--resolution", &what, memory_bytes(lo, hi, n))?;
    }
    Ok((lo, hi, n))
}

/// The solid walls of `scene` in the box `lo` .. `hi`, `n` voxels along
/// its longest side ([`crate::export::object_mesh::object_mesh`]).
///
/// # Errors
/// [`Error::Input`] naming the scene file and `--bounds`: a bad box, or
/// no solid wall inside it.
pub fn object_mesh(scene: &ObjectScene, lo: DVec3, hi: DVec3, n: usize) -> Result<Mesh, Error> {
    let file = &scene.scene_file.file;
    let mesh = crate::export::object_mesh::object_mesh(&scene.object, lo, hi, n)
        .map_err(|e| Error::Input(format!("{file}: --bounds: {e}")))?;
    if mesh.faces.is_empty() {
        return Err(Error::Input(format!(
            "{file}: --bounds: no solid wall inside the box {lo} .. {hi}"
        )));
    }
    Ok(mesh)
}

/// A micro scene's heights as a height map file.
#[derive(Debug, Clone)]
pub struct HeightMapFile {
    /// The vertices written per side (x, y).
    pub grid: (usize, usize),
    /// The pixel pitch (x, y), in the scene's length units.
    pub pitch: (f64, f64),
    /// The cell's size (x, y).
    pub size: (f64, f64),
    /// The file's bytes.
    pub bytes: Vec<u8>,
}

impl HeightMapFile {
    /// The heights of `scene` in `format` (EXR or text): a height field's
    /// own vertex heights, or those of a scene of bumps sampled at the
    /// vertices of an `resolution` x `resolution` grid (default 512).
    ///
    /// # Errors
    /// [`Error::Option`] naming `--resolution` (outside 2..=16384, or
    /// beyond the memory limit); [`Error::Io`] when the file cannot be
    /// encoded.
    pub fn of(
        scene: &MicroScene,
        resolution: Option<usize>,
        format: Format,
    ) -> Result<Self, Error> {
        let grid = match scene.surface.heightfield() {
            Some(f) => HeightGrid {
                nx: f.nx,
                ny: f.ny,
                h: f.h.clone(),
            },
            None => sampled(scene, resolution.unwrap_or(512))?,
        };
        let s = scene.surface.size;
        let (px, py) = (s.x / grid.nx as f64, s.y / grid.ny as f64);
        let comment = format!(
            "roks height map of {}: {} x {} vertices, pitch {px:?} x {py:?} (length units); row j is y = j * pitch",
            scene.scene_file.file, grid.nx, grid.ny
        );
        let bytes =
            heightfield_io::write(&grid, format, &comment).map_err(|e| anyhow::anyhow!(e))?;
        Ok(Self {
            grid: (grid.nx, grid.ny),
            pitch: (px, py),
            size: (s.x, s.y),
            bytes,
        })
    }

    /// The `[surface]` keys that load the file named `file`.
    #[must_use]
    pub fn scene_keys(&self, file: &str) -> String {
        let (px, py) = self.pitch;
        if px == py {
            format!("heightfield = {{ file = {file:?}, pixel = {px:?} }}")
        } else {
            format!(
                "size = [{:?}, {:?}]\nheightfield = {{ file = {file:?} }}",
                self.size.0, self.size.1
            )
        }
    }
}

/// The heights of a scene of bumps at the vertices of an `n` x `n` grid.
fn sampled(scene: &MicroScene, n: usize) -> Result<HeightGrid, Error> {
    if !(2..=16384).contains(&n) {
        return Err(Error::option(
            "--resolution",
            format!("must be in 2..=16384, got {n}"),
        ));
    }
    // Heights (8 bytes) and the file (up to 24 bytes of text) per vertex.
    let bytes = crate::limits::product(&[n as u64, n as u64, 32]);
    check_memory("--resolution", &format!("a {n} x {n} height map"), bytes)?;
    let s = scene.surface.size;
    let mut scratch = crate::micro::Scratch::new(&scene.surface);
    let h: Vec<f64> = (0..n * n)
        .map(|k| {
            let (i, j) = ((k % n) as f64, (k / n) as f64);
            scene
                .surface
                .height_at(s.x * (i / n as f64), s.y * (j / n as f64), &mut scratch)
        })
        .collect();
    Ok(HeightGrid { nx: n, ny: n, h })
}
