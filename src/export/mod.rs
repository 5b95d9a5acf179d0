//! Exports for other programs: micro surfaces as triangle meshes (`roks
//! export-mesh`, this file), the walls of object scenes as meshes
//! ([`object_mesh`]) and BRDF tables in the Zemax, MERL, RGL and pbsdf
//! formats (`roks export-brdf`, `roks brdf --export`): each format is one
//! module ([`zemax`], [`merl`], [`rgl`], [`pbsdf`], sharing [`resample`])
//! implementing [`exporter::Exporter`], named by one line of the registry
//! [`exporter::BrdfFormat`] (its registry in [`brdf_formats`]); [`folder`] exports a result folder. An
//! export returns its files, their read-back checks and the lines to show
//! as values ([`exporter::Export`]), or an [`exporter::ExportError`].
//!
//! [`height_field_mesh`] samples the top surface of a [`MicroSurface`] on a
//! regular grid over one period and triangulates it; [`field_mesh`] writes
//! a height-field surface's own grid and triangles exactly; [`write_ply`] encodes the
//! mesh as binary little-endian PLY, the form Mitsuba 3's `ply` shape reads,
//! and [`read_ply`] decodes it again (tests, round trips).
//!
//! # Geometry and units
//!
//! Coordinates are in the scene's length units (the same units as
//! `[surface] size` and the bump radii and heights); `z` is up and `z = 0` is
//! the substrate. The mesh covers `[0, Lx] x [0, Ly]` with `n x n` square-grid
//! cells, vertex `(i, j)` at `x = i Lx / n`, `y = j Ly / n`, stored at index
//! `j (n + 1) + i`. Each cell is split along its diagonal from `(i, j)` to
//! `(i + 1, j + 1)` into two triangles wound counter-clockwise seen from `+z`,
//! so geometric normals point up (out of the surface, towards the light).
//!
//! The mesh is a height field: it cannot represent overhangs, and steep walls
//! (cylinder posts, the sides of pits) become slanted facets one grid cell
//! wide. Its vertices lie on the exact surface (each height is
//! [`MicroSurface::height_at`], a vertical ray from the launch plane); the
//! faces in between are linear interpolation.
//!
//! # Edges
//!
//! For [`Edges::Periodic`] the vertices on `x = Lx` (`i = n`) and `y = Ly`
//! (`j = n`) are copies of those on `x = 0` and `y = 0`: the same heights,
//! bit for bit, so copies of the mesh shifted by whole periods join without
//! cracks. For absorbing and reflecting edges all `(n + 1)^2` vertices are
//! sampled where they are (the side walls themselves are not part of the mesh).
//!
//! # Precision
//!
//! roks works in `f64`; Mitsuba 3 (and the PLY files written here) store
//! `float32`. Coordinates and heights are converted to `f32` at the very end,
//! after sampling in `f64`, so each is within half an `f32` ulp of the `f64`
//! value: a relative error of at most `2^-24` (about `6e-8`), for example
//! `1.8e-6` at `x = 30`. The vertices `x = Lx` and `y = Ly` are computed as
//! `Lx * (n / n)` and so are exactly `Lx` and `Ly` (rounded to `f32`).

pub mod brdf_formats;
pub mod exporter;
pub mod folder;
pub mod merl;
pub mod object_mesh;
pub mod pbsdf;
pub mod resample;
pub mod rgl;
pub mod zemax;

use glam::DVec2;

use crate::micro::heightfield::HeightField;
use crate::micro::{Edges, MicroSurface, Scratch};

/// An indexed triangle mesh (single precision, as in PLY and Mitsuba 3).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions `[x, y, z]` (scene length units).
    pub vertices: Vec<[f32; 3]>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from
    /// outside the surface (above it for a height field).
    pub faces: Vec<[u32; 3]>,
}

/// Estimated peak memory (bytes) of a height-field mesh of `nx x ny`
/// squares and its PLY file: per vertex its height and position (8 + 12
/// bytes) and file record (12), per square two faces (24) and their records
/// (26): about 82 bytes a square.
#[must_use]
pub fn mesh_memory_bytes(nx: usize, ny: usize) -> u64 {
    crate::limits::product(&[nx as u64 + 1, ny as u64 + 1, 82])
}

/// Largest `n` for [`height_field_mesh`]: the `(n + 1)^2` vertex indices must
/// fit the PLY `int` (i32) index type.
pub const MAX_CELLS_PER_SIDE: usize = 46_339;

/// The top surface of a micro scene as a triangulated height field over one
/// period.
///
/// An `n x n` grid of square-topology cells over `[0, Lx] x [0, Ly]` (they are
/// square only if `Lx = Ly`), heights sampled at the `(n + 1) x (n + 1)`
/// vertices `x = i Lx / n`, `y = j Ly / n` with [`MicroSurface::height_at`];
/// for periodic edges vertex `i = n` takes the height of `i = 0` (and `j = n`
/// that of `j = 0`) so that tiled copies are seamless. Two triangles per cell,
/// counter-clockwise seen from `+z`. The mesh has `(n + 1)^2` vertices and
/// `2 n^2` faces; see the module documentation for layout, units and `f32`
/// precision.
///
/// Rows are sampled in parallel with rayon (one [`Scratch`] per row); the
/// result does not depend on the number of threads.
///
/// # Panics
///
/// If `n` is 0 or greater than [`MAX_CELLS_PER_SIDE`].
#[must_use]
pub fn height_field_mesh(surface: &MicroSurface, n: usize) -> Mesh {
    use rayon::prelude::*;

    assert!(
        (1..=MAX_CELLS_PER_SIDE).contains(&n),
        "height_field_mesh: n = {n} cells per side, must be in 1..={MAX_CELLS_PER_SIDE}"
    );
    let size = surface.size;
    let periodic = surface.edges == Edges::Periodic;
    // Grid coordinate k of n along one side; k = n gives exactly `len`.
    let coord = |k: usize, len: f64| len * (k as f64 / n as f64);
    // Periodic: rows and columns 0..n are sampled, n is a copy of 0.
    let sampled = if periodic { n } else { n + 1 };
    let side = n + 1;

    let mut heights: Vec<f64> = (0..sampled)
        .into_par_iter()
        .flat_map_iter(|j| {
            let mut scratch = Scratch::new(surface);
            let y = coord(j, size.y);
            let mut row: Vec<f64> = (0..sampled)
                .map(|i| surface.height_at(coord(i, size.x), y, &mut scratch))
                .collect();
            if periodic {
                row.push(row[0]);
            }
            row
        })
        .collect();
    if periodic {
        heights.extend_from_within(..side);
    }
    debug_assert_eq!(heights.len(), side * side);

    grid_mesh(size, n, n, &heights)
}

/// The mesh of a height field's own grid: its `(nx + 1) x (ny + 1)` vertices
/// (the last row and column repeat the first: one period, tiling without
/// cracks) with its heights, and its triangles, the same diagonal and
/// winding as [`HeightField`] traces, so that a renderer sees the very
/// triangles roks traces (to the `f32` rounding of the coordinates; none at
/// all when the pitch and heights are `f32` numbers, as for generated fields
/// on power-of-two grids of power-of-two cells).
///
/// # Panics
///
/// If the grid has more than [`MAX_CELLS_PER_SIDE`] squares per side.
#[must_use]
pub fn field_mesh(field: &HeightField) -> Mesh {
    let (nx, ny) = (field.nx, field.ny);
    assert!(
        nx.max(ny) <= MAX_CELLS_PER_SIDE,
        "field_mesh: {nx} x {ny} squares, at most {MAX_CELLS_PER_SIDE} per side"
    );
    let heights: Vec<f64> = (0..=ny)
        .flat_map(|j| (0..=nx).map(move |i| field.vertex(i as i64, j as i64)))
        .collect();
    grid_mesh(field.size, nx, ny, &heights)
}

/// Triangulate `(nx + 1) x (ny + 1)` vertex heights (row-major, `j (nx + 1) + i`)
/// over `[0, Lx] x [0, Ly]`: vertex `(i, j)` at `(Lx i / nx, Ly j / ny)`, two
/// triangles per square split along the diagonal `(i, j)`-`(i + 1, j + 1)`,
/// counter-clockwise seen from `+z`.
fn grid_mesh(size: DVec2, nx: usize, ny: usize, heights: &[f64]) -> Mesh {
    let side = nx + 1;
    debug_assert_eq!(heights.len(), side * (ny + 1));
    let coord = |k: usize, n: usize, len: f64| len * (k as f64 / n as f64);
    let vertices = heights
        .iter()
        .enumerate()
        .map(|(k, &z)| {
            let p = DVec2::new(coord(k % side, nx, size.x), coord(k / side, ny, size.y));
            [p.x as f32, p.y as f32, z as f32]
        })
        .collect();

    let mut faces = Vec::with_capacity(2 * nx * ny);
    let index = |i: usize, j: usize| (j * side + i) as u32;
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    Mesh { vertices, faces }
}

/// The PLY header [`write_ply`] writes for `vertices` vertices and `faces` faces.
fn ply_header(vertices: usize, faces: usize) -> String {
    format!(
        "ply\n\
         format binary_little_endian 1.0\n\
         element vertex {vertices}\n\
         property float x\n\
         property float y\n\
         property float z\n\
         element face {faces}\n\
         property list uchar int vertex_indices\n\
         end_header\n"
    )
}

/// Binary little-endian PLY (format 1.0) of `mesh`.
///
/// The header is exactly
///
/// ```text
/// ply
/// format binary_little_endian 1.0
/// element vertex N
/// property float x
/// property float y
/// property float z
/// element face M
/// property list uchar int vertex_indices
/// end_header
/// ```
///
/// (lines end in `\n`), then `N` records of three `f32` and `M` records of a
/// `u8` 3 and three `i32` indices, all little-endian: the form Mitsuba 3's
/// `ply` shape reads. No normals are written (Mitsuba computes them; set
/// `face_normals = true` on the shape for flat facets).
///
/// # Panics
///
/// If a vertex index does not fit an `i32` (over 2^31 vertices).
#[must_use]
pub fn write_ply(mesh: &Mesh) -> Vec<u8> {
    let header = ply_header(mesh.vertices.len(), mesh.faces.len());
    let mut out =
        Vec::with_capacity(header.len() + 12 * mesh.vertices.len() + 13 * mesh.faces.len());
    out.extend_from_slice(header.as_bytes());
    for v in &mesh.vertices {
        for c in v {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in &mesh.faces {
        out.push(3);
        for &k in f {
            let k = i32::try_from(k).expect("PLY vertex index fits an i32");
            out.extend_from_slice(&k.to_le_bytes());
        }
    }
    out
}

/// Why bytes are not a PLY as [`write_ply`] writes it ([`read_ply`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlyError {
    /// No `end_header` line.
    #[error("PLY: no end_header line")]
    NoEnd,
    /// A header that is not UTF-8.
    #[error("PLY: header is not UTF-8")]
    NotUtf8,
    /// A header line other than the one expected (`found`: `None` at the
    /// header's end).
    #[error("PLY header: expected `{expected}`, {}", found.as_ref().map_or_else(|| "header ended".to_owned(), |l| format!("got `{l}`")))]
    Line {
        /// The line expected.
        expected: String,
        /// The line found.
        found: Option<String>,
    },
    /// No `element` line.
    #[error("PLY header: no `element {0}` line")]
    NoElement(&'static str),
    /// A malformed `element` line.
    #[error("PLY header: expected `element {element} <count>`, got `{found}`")]
    Element {
        /// `vertex` or `face`.
        element: &'static str,
        /// The line found.
        found: String,
    },
    /// A line after the face list's property.
    #[error("PLY header: unexpected line `{0}`")]
    Unexpected(String),
    /// Element counts whose data size overflows.
    #[error("PLY: element counts overflow")]
    Overflow,
    /// Data of the wrong length.
    #[error(
        "PLY: {found} bytes of data, expected {expected} for {vertices} vertices and {faces} triangles"
    )]
    Length {
        /// Bytes found.
        found: usize,
        /// Bytes expected.
        expected: usize,
        /// Vertices declared.
        vertices: usize,
        /// Faces declared.
        faces: usize,
    },
    /// A face that is not a triangle.
    #[error("PLY: face {face} has {count} vertices, expected 3")]
    NotTriangle {
        /// 0-based face.
        face: usize,
        /// Its vertex count.
        count: u8,
    },
    /// A vertex index out of range.
    #[error("PLY: face {face} vertex index {index} out of range (0..{vertices})")]
    Index {
        /// 0-based face.
        face: usize,
        /// The index.
        index: i64,
        /// Vertices declared.
        vertices: usize,
    },
}

/// Parse a binary little-endian PLY as [`write_ply`] writes it.
///
/// Accepted: the header of [`write_ply`], with optional `comment` and
/// `obj_info` lines and the face index type `int` or `uint`; every face must
/// be a triangle with indices in range and the data must end exactly after
/// the last face. Anything else is an error naming what is wrong.
///
/// # Errors
/// A [`PlyError`].
pub fn read_ply(bytes: &[u8]) -> Result<Mesh, PlyError> {
    const END: &[u8] = b"end_header\n";
    let end = bytes
        .windows(END.len())
        .position(|w| w == END)
        .ok_or(PlyError::NoEnd)?
        + END.len();
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| PlyError::NotUtf8)?;
    let mut lines = header
        .lines()
        .filter(|l| !(l.starts_with("comment") || l.starts_with("obj_info")));
    let expect = |line: Option<&str>, want: &str| match line {
        Some(l) if l.trim_end() == want => Ok(()),
        found => Err(PlyError::Line {
            expected: want.to_owned(),
            found: found.map(str::to_owned),
        }),
    };
    expect(lines.next(), "ply")?;
    expect(lines.next(), "format binary_little_endian 1.0")?;
    let count = |line: Option<&str>, element: &'static str| -> Result<usize, PlyError> {
        let line = line.ok_or(PlyError::NoElement(element))?;
        line.strip_prefix(&format!("element {element} "))
            .and_then(|n| n.trim_end().parse().ok())
            .ok_or_else(|| PlyError::Element {
                element,
                found: line.to_owned(),
            })
    };
    let n_vertices = count(lines.next(), "vertex")?;
    for axis in ["x", "y", "z"] {
        expect(lines.next(), &format!("property float {axis}"))?;
    }
    let n_faces = count(lines.next(), "face")?;
    let signed = match lines.next().map(str::trim_end) {
        Some("property list uchar int vertex_indices") => true,
        Some("property list uchar uint vertex_indices") => false,
        other => {
            return Err(PlyError::Line {
                expected: "property list uchar int vertex_indices".to_owned(),
                found: Some(other.unwrap_or("end of header").to_owned()),
            });
        }
    };
    match lines.next() {
        Some("end_header") => {}
        Some(l) => return Err(PlyError::Unexpected(l.to_owned())),
        None => return Err(PlyError::NoEnd),
    }

    let body = &bytes[end..];
    let want = n_vertices
        .checked_mul(12)
        .and_then(|v| n_faces.checked_mul(13).and_then(|f| v.checked_add(f)))
        .ok_or(PlyError::Overflow)?;
    if body.len() != want {
        return Err(PlyError::Length {
            found: body.len(),
            expected: want,
            vertices: n_vertices,
            faces: n_faces,
        });
    }
    let word = |at: usize| -> [u8; 4] { body[at..at + 4].try_into().expect("4 bytes") };
    let vertices = (0..n_vertices)
        .map(|k| std::array::from_fn(|c| f32::from_le_bytes(word(12 * k + 4 * c))))
        .collect();
    let faces_at = 12 * n_vertices;
    let mut faces = Vec::with_capacity(n_faces);
    for k in 0..n_faces {
        let at = faces_at + 13 * k;
        if body[at] != 3 {
            return Err(PlyError::NotTriangle {
                face: k,
                count: body[at],
            });
        }
        let mut f = [0u32; 3];
        for (c, slot) in f.iter_mut().enumerate() {
            let raw = word(at + 1 + 4 * c);
            let index = if signed {
                i64::from(i32::from_le_bytes(raw))
            } else {
                i64::from(u32::from_le_bytes(raw))
            };
            if !(0..n_vertices as i64).contains(&index) {
                return Err(PlyError::Index {
                    face: k,
                    index,
                    vertices: n_vertices,
                });
            }
            *slot = index as u32;
        }
        faces.push(f);
    }
    Ok(Mesh { vertices, faces })
}
