//! The walls of a 3-D object as a closed triangle mesh (`roks export-mesh`
//! of an object scene), for rendering it elsewhere (Mitsuba previews).
//!
//! # Method: dual contouring with exact edge crossings and tangent planes
//!
//! Object zones are regions over quadrics (CSG), so there is no parametric
//! surface to tessellate. The box `[lo, hi]` is covered by a grid of cubic
//! voxels of side `h = (longest side) / n`; every grid vertex is classified
//! inside (in some solid zone, and in the box) or outside. Along every grid
//! edge whose ends differ, the crossing of the boundary is found by bisection
//! of the inside test to double precision (60 halvings), so it lies on the
//! exact surface, and the surface's exact normal there is taken from the
//! gradient of the quadric that separates the edge's ends (nearest to the
//! crossing), or from the box face for a cap. Each voxel with a sign change
//! gets one mesh vertex: the point nearest, in least squares, to the tangent
//! planes of all its crossings (Ju et al. 2002), solved with small
//! eigenvalues dropped (relative 1e-2) about the mean of the crossings, and
//! kept inside the voxel. On a smooth wall that is a point on the wall near
//! the mean; at a sharp edge (an aperture rim, the joint of two cones) it
//! lies on the edge, at a corner or apex on the corner. Each edge with a sign
//! change becomes a quad joining the vertices of the four voxels around it,
//! split into two triangles wound counter-clockwise seen from outside the
//! solid.
//!
//! One layer of voxels outside the box (classified outside) closes the mesh
//! where a solid is cut by the box: the cut is capped on the box face. The
//! mesh is closed and consistently oriented (the connectivity is that of
//! surface nets, watertight by construction). Smooth walls are approximated
//! to second order in `h`; sharp edges and corners are kept. Thin features
//! below one voxel can vanish. Coordinates are in the scene's length units,
//! converted to `f32` at the end.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use super::Mesh;
use crate::object::Object;

/// Most voxels along the longest side (the vertex grid must stay a few
/// hundred MB at most).
pub const MAX_VOXELS_PER_SIDE: usize = 2048;

/// Voxels per axis inside the box `[lo, hi]` with `n` along its longest side.
fn voxels(lo: DVec3, hi: DVec3, n: usize) -> [usize; 3] {
    let size = hi - lo;
    let h = size.max_element() / n as f64;
    // Saturating float-to-int for absurd boxes.
    [0, 1, 2].map(|a| ((size[a] / h).ceil() as usize).max(1))
}

/// Estimated peak memory (bytes) of [`object_mesh`] for the box `[lo, hi]`
/// (finite, positive sides) at resolution `n`: per grid vertex its inside
/// flag, its voxel's optional vertex and its index (1 + 32 + 4 bytes), so
/// about 40 bytes a voxel; the mesh itself is smaller (surface only).
#[must_use]
pub fn memory_bytes(lo: DVec3, hi: DVec3, n: usize) -> u64 {
    let [a, b, c] = voxels(lo, hi, n).map(|v| v as u64 + 3);
    crate::limits::product(&[a, b, c, 40])
}

/// Why an object cannot be meshed ([`object_mesh`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// An empty or non-finite box.
    #[error("box {lo} .. {hi} must be finite with positive sides")]
    Box {
        /// Low corner.
        lo: DVec3,
        /// High corner.
        hi: DVec3,
    },
    /// A resolution outside `1..=MAX_VOXELS_PER_SIDE`.
    #[error("resolution {0} must be in 1..={MAX_VOXELS_PER_SIDE}")]
    Resolution(usize),
    /// A vertex grid beyond 2^31 vertices.
    #[error("{0} grid vertices are too many: lower the resolution")]
    TooManyVertices(usize),
}

/// The boundary of the solid zones of `object` inside the box `[lo, hi]`,
/// with `n` voxels along the box's longest side (see the module
/// documentation).
///
/// # Errors
/// If the box is empty or not finite, or `n` is 0 or above
/// [`MAX_VOXELS_PER_SIDE`], or the grid would exceed 2^31 vertices.
pub fn object_mesh(object: &Object, lo: DVec3, hi: DVec3, n: usize) -> Result<Mesh, MeshError> {
    let grid = Grid::new(object, lo, hi, n)?;
    // Classify every vertex (parallel over z slices; order-independent).
    let dims = grid.dims;
    let flags: Vec<bool> = (0..dims[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            let grid = &grid;
            (0..dims[1])
                .flat_map(move |j| (0..dims[0]).map(move |i| grid.inside(grid.point(i, j, k))))
        })
        .collect();
    // One vertex per voxel with a sign change (see the module docs).
    let voxel_dims = [dims[0] - 1, dims[1] - 1, dims[2] - 1];
    let voxel_vertex: Vec<Option<DVec3>> = (0..voxel_dims[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            let (grid, flags) = (&grid, &flags);
            (0..voxel_dims[1]).flat_map(move |j| {
                (0..voxel_dims[0]).map(move |i| grid.voxel_vertex(flags, i, j, k))
            })
        })
        .collect();
    // Number the voxel vertices in grid order (deterministic).
    let mut ids = vec![u32::MAX; voxel_vertex.len()];
    let mut vertices = Vec::new();
    for (v, p) in voxel_vertex.iter().enumerate() {
        if let Some(p) = p {
            ids[v] = vertices.len() as u32;
            vertices.push([p.x as f32, p.y as f32, p.z as f32]);
        }
    }
    let faces = grid.faces(&flags, &ids);
    Ok(Mesh { vertices, faces })
}

/// The vertex grid of [`object_mesh`]: the box, its steps and the object's
/// walls.
struct Grid<'a> {
    /// The object.
    object: &'a Object,
    /// Every quadric of its solids.
    surfaces: Vec<&'a crate::geometry::quadric::Quadric>,
    /// The box.
    lo: DVec3,
    /// The box.
    hi: DVec3,
    /// Voxel side along the longest side of the box.
    h: f64,
    /// Grid step per axis.
    step: DVec3,
    /// Vertices per axis (grid indices -1 ..= cells + 1 map to 0 ..= cells + 2).
    dims: [usize; 3],
}

impl<'a> Grid<'a> {
    /// The grid of `n` voxels along the longest side of `[lo, hi]`.
    fn new(object: &'a Object, lo: DVec3, hi: DVec3, n: usize) -> Result<Self, MeshError> {
        if !(lo.is_finite() && hi.is_finite()) || (hi - lo).min_element() <= 0.0 {
            return Err(MeshError::Box { lo, hi });
        }
        if n == 0 || n > MAX_VOXELS_PER_SIDE {
            return Err(MeshError::Resolution(n));
        }
        let size = hi - lo;
        let h = size.max_element() / n as f64;
        let cells = voxels(lo, hi, n);
        let step = DVec3::new(
            size.x / cells[0] as f64,
            size.y / cells[1] as f64,
            size.z / cells[2] as f64,
        );
        // Vertex grid indices -1 ..= cells + 1 map to 0 ..= cells + 2.
        let dims = cells.map(|c| c + 3);
        let total = dims[0] * dims[1] * dims[2];
        if total > i32::MAX as usize {
            return Err(MeshError::TooManyVertices(total));
        }
        let surfaces = object
            .solids
            .iter()
            .flat_map(|s| s.body.surfaces.iter())
            .collect();
        Ok(Self {
            object,
            surfaces,
            lo,
            hi,
            h,
            step,
            dims,
        })
    }

    /// The position of grid vertex `(i, j, k)`.
    fn point(&self, i: usize, j: usize, k: usize) -> DVec3 {
        let step = self.step;
        self.lo
            + DVec3::new(
                (i as f64 - 1.0) * step.x,
                (j as f64 - 1.0) * step.y,
                (k as f64 - 1.0) * step.z,
            )
    }

    /// Whether `p` is in the box and in a solid zone.
    fn inside(&self, p: DVec3) -> bool {
        let in_box = p.cmpge(self.lo).all() && p.cmple(self.hi).all();
        in_box && self.object.solids.iter().any(|s| s.body.contains(p))
    }

    /// The flat index of grid vertex `(i, j, k)`.
    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// The boundary crossing on the edge from vertex `p` to `q`.
    fn crossing(&self, mut p: DVec3, mut q: DVec3) -> DVec3 {
        let a = self.inside(p);
        for _ in 0..60 {
            let m = 0.5 * (p + q);
            if self.inside(m) == a {
                p = m;
            } else {
                q = m;
            }
        }
        0.5 * (p + q)
    }

    /// The outward unit normal of the wall at the crossing `x` of the edge
    /// from `p_in` (inside) to `p_out`: the quadric that separates the two
    /// ends and lies nearest to `x` (distance estimate |f| / |grad f|), or a
    /// box face.
    fn normal(&self, x: DVec3, p_in: DVec3, p_out: DVec3) -> Option<DVec3> {
        let along = p_out - p_in;
        let mut best: Option<(f64, DVec3)> = None;
        for q in &self.surfaces {
            if (q.eval(p_in) > 0.0) == (q.eval(p_out) > 0.0) {
                continue;
            }
            let g = q.gradient(x);
            let len = g.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let dist = q.eval(x).abs() / len;
            if best.is_none_or(|(d, _)| dist < d) {
                best = Some((dist, g / len));
            }
        }
        // A cap on the box: the crossing lies on a face.
        for a in 0..3 {
            for (face, sign) in [(self.lo[a], -1.0), (self.hi[a], 1.0)] {
                let dist = (x[a] - face).abs();
                if dist <= 1e-9 * self.h && best.is_none_or(|(d, _)| dist < d) {
                    let mut n = DVec3::ZERO;
                    n[a] = sign;
                    best = Some((dist, n));
                }
            }
        }
        best.map(|(_, n)| if n.dot(along) < 0.0 { -n } else { n })
    }

    /// The mesh vertex of voxel `(i, j, k)` (its low corner's grid vertex),
    /// `None` without a sign change among its corners' `flags`.
    fn voxel_vertex(&self, flags: &[bool], i: usize, j: usize, k: usize) -> Option<DVec3> {
        let corner = |c: usize| {
            let (di, dj, dk) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
            (i + di, j + dj, k + dk)
        };
        let f = |c: usize| {
            let (a, b, d) = corner(c);
            flags[self.index(a, b, d)]
        };
        let first = f(0);
        if (1..8).all(|c| f(c) == first) {
            return None;
        }
        let mut planes = [(DVec3::ZERO, None); 12];
        let mut count = 0;
        for c in 0..8 {
            for bit in 0..3 {
                let o = c ^ (1 << bit);
                if o > c && f(c) != f(o) {
                    let (ci, co) = if f(c) { (c, o) } else { (o, c) };
                    let (a, b, d) = corner(ci);
                    let p_in = self.point(a, b, d);
                    let (a, b, d) = corner(co);
                    let p_out = self.point(a, b, d);
                    let x = self.crossing(p_in, p_out);
                    planes[count] = (x, self.normal(x, p_in, p_out));
                    count += 1;
                }
            }
        }
        let (a, b, d) = corner(0);
        let (v_lo, v_hi) = (self.point(a, b, d), self.point(a + 1, b + 1, d + 1));
        Some(qef_vertex(&planes[..count], v_lo, v_hi))
    }

    /// A quad for every edge with a sign change of `flags`, around it
    /// through the four voxels sharing it (`ids`: their vertices); (a, b,
    /// c) cyclic, so the order (0,0), (-1,0), (-1,-1), (0,-1) in (b, c) is
    /// counter-clockwise seen from +a.
    fn faces(&self, flags: &[bool], ids: &[u32]) -> Vec<[u32; 3]> {
        let dims = self.dims;
        let voxel_dims = [dims[0] - 1, dims[1] - 1, dims[2] - 1];
        let vindex = |i: usize, j: usize, k: usize| (k * voxel_dims[1] + j) * voxel_dims[0] + i;
        let mut faces = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let here = [i, j, k];
                    let f0 = flags[self.index(i, j, k)];
                    for a in 0..3 {
                        let mut next = here;
                        next[a] += 1;
                        if next[a] >= dims[a] || flags[self.index(next[0], next[1], next[2])] == f0
                        {
                            continue;
                        }
                        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                        // (An edge in the padding's outer planes has both ends outside.)
                        debug_assert!(here[b] > 0 && here[c] > 0);
                        let quad = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(db, dc)| {
                            let mut v = here;
                            v[b] -= db;
                            v[c] -= dc;
                            ids[vindex(v[0], v[1], v[2])]
                        });
                        // Outward normal +a when the inside is at `here`.
                        let q = if f0 {
                            quad
                        } else {
                            [quad[0], quad[3], quad[2], quad[1]]
                        };
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    }
                }
            }
        }
        faces
    }
}

/// The point nearest, in least squares, to the planes through `x` with unit
/// normal `n` (where known), about the mean of the `x` (the mass point):
/// eigenvalues of the normal matrix below 1e-2 of the largest are dropped
/// (directions the planes do not fix stay at the mass point), and the result
/// is kept inside the voxel `[lo, hi]`.
fn qef_vertex(planes: &[(DVec3, Option<DVec3>)], lo: DVec3, hi: DVec3) -> DVec3 {
    let mass = planes.iter().map(|p| p.0).sum::<DVec3>() / planes.len() as f64;
    let mut ata = DMat3::ZERO;
    let mut atb = DVec3::ZERO;
    for &(x, n) in planes {
        if let Some(n) = n {
            ata += DMat3::from_cols(n * n.x, n * n.y, n * n.z);
            atb += n * n.dot(x - mass);
        }
    }
    let (values, vectors) = symmetric_eigen(ata);
    let largest = values.max_element();
    if largest.is_nan() || largest <= 0.0 {
        return mass;
    }
    let mut y = DVec3::ZERO;
    for k in 0..3 {
        if values[k] > 1e-2 * largest {
            let v = vectors.col(k);
            y += v * (v.dot(atb) / values[k]);
        }
    }
    (mass + y).clamp(lo, hi)
}

/// Eigenvalues and eigenvectors (columns) of a symmetric 3 x 3 matrix, by
/// cyclic Jacobi rotations (converged to rounding in a few sweeps).
fn symmetric_eigen(m: DMat3) -> (DVec3, DMat3) {
    let mut a = m.to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        if off <= 1e-30 * (a[0][0].powi(2) + a[1][1].powi(2) + a[2][2].powi(2)) || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = 0.5 * (a[q][q] - a[p][p]) / a[p][q];
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // a = J^T a J with the rotation J in the (p, q) plane.
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * row_p[k] - s * row_q[k];
                a[q][k] = s * row_p[k] + c * row_q[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let values = DVec3::new(a[0][0], a[1][1], a[2][2]);
    // v rows are the original axes; its columns the eigenvectors.
    let vectors = DMat3::from_cols(
        DVec3::new(v[0][0], v[1][0], v[2][0]),
        DVec3::new(v[0][1], v[1][1], v[2][1]),
        DVec3::new(v[0][2], v[1][2], v[2][2]),
    );
    (values, vectors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneFile;
    use crate::scene::object::ObjectScene;

    fn sphere_object(r: f64) -> Object {
        object(
            &format!("s = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = {r} }} }}"),
            "-s",
        )
    }

    /// Signed volume (divergence theorem) and area of a closed mesh.
    fn volume_area(m: &Mesh) -> (f64, f64) {
        let v = |i: u32| {
            let p = m.vertices[i as usize];
            DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
        };
        m.faces.iter().fold((0.0, 0.0), |(vol, area), f| {
            let (a, b, c) = (v(f[0]), v(f[1]), v(f[2]));
            (
                vol + a.dot(b.cross(c)) / 6.0,
                area + 0.5 * (b - a).cross(c - a).length(),
            )
        })
    }

    #[test]
    fn sphere_mesh_is_closed_outward_and_converges_to_the_sphere() {
        use std::collections::HashMap;
        let r = 2.0;
        let obj = sphere_object(r);
        let exact_v = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        let exact_a = 4.0 * std::f64::consts::PI * r * r;
        let mut errors = Vec::new();
        for n in [16, 32, 64] {
            let m = object_mesh(&obj, DVec3::splat(-3.0), DVec3::splat(3.0), n).unwrap();
            // Closed and consistently oriented: every directed edge once,
            // its reverse once.
            let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
            for f in &m.faces {
                for e in 0..3 {
                    *edges.entry((f[e], f[(e + 1) % 3])).or_default() += 1;
                }
            }
            for (&(a, b), &c) in &edges {
                assert_eq!(c, 1, "directed edge twice");
                assert_eq!(edges.get(&(b, a)), Some(&1), "open edge");
            }
            // Vertices lie near the sphere (within one voxel diagonal).
            let h = 6.0 / n as f64;
            for p in &m.vertices {
                let d = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])).length();
                assert!((d - r).abs() < h * 3f64.sqrt(), "vertex at radius {d}");
            }
            let (vol, area) = volume_area(&m);
            assert!(vol > 0.0, "faces wound inward");
            errors.push(((vol - exact_v) / exact_v, (area - exact_a) / exact_a));
        }
        // Volume error shrinks at least like h (roughly h^2 for smooth walls).
        assert!(
            errors[2].0.abs() < 0.6 * errors[0].0.abs() && errors[2].0.abs() < 0.01,
            "{errors:?}"
        );
    }

    /// An object of one solid zone `region` over the `[quadrics]` lines
    /// `quadrics` (walls and source only as the scene format needs them).
    fn object(quadrics: &str, region: &str) -> Object {
        let text = format!(
            r#"
[quadrics]
{quadrics}
[[cells]]
name = "solid"
region = "{region}"
fill = "solid"
[models.m]
reflectance = 0.5
[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 0.1 }}
position = [0.0, 0.0, 10.0]
photons = 1
"#
        );
        let scene_file = SceneFile {
            file: "solid.toml".into(),
            dir: std::env::temp_dir(),
        };
        ObjectScene::from_str(&text, scene_file, "solid".into())
            .unwrap()
            .object
    }

    #[test]
    fn symmetric_eigen_diagonalises() {
        let m = DMat3::from_cols(
            DVec3::new(4.0, 1.0, -2.0),
            DVec3::new(1.0, 3.0, 0.5),
            DVec3::new(-2.0, 0.5, 1.0),
        );
        let (values, vectors) = symmetric_eigen(m);
        for k in 0..3 {
            let v = vectors.col(k);
            assert!((v.length() - 1.0).abs() < 1e-12);
            assert!((m * v - values[k] * v).length() < 1e-12, "{k}: {values}");
        }
        // Trace and determinant are kept.
        assert!((values.element_sum() - 8.0).abs() < 1e-12);
        assert!((values.x * values.y * values.z - m.determinant()).abs() < 1e-10);
    }

    /// A cube not aligned with the voxel grid keeps its 8 corners and 12
    /// edges: its volume is exact to rounding (f32 coordinates), where
    /// surface nets would round every edge over a voxel.
    #[test]
    fn cube_keeps_its_corners_and_volume() {
        let (a, b) = (-1.03, 0.97);
        let planes = format!(
            "x0 = {{ plane = [-1.0, 0.0, 0.0, {}] }}\nx1 = {{ plane = [1.0, 0.0, 0.0, {b}] }}\n\
             y0 = {{ plane = [0.0, -1.0, 0.0, {}] }}\ny1 = {{ plane = [0.0, 1.0, 0.0, {b}] }}\n\
             z0 = {{ plane = [0.0, 0.0, -1.0, {}] }}\nz1 = {{ plane = [0.0, 0.0, 1.0, {b}] }}",
            -a, -a, -a
        );
        let obj = object(&planes, "-x0 -x1 -y0 -y1 -z0 -z1");
        let m = object_mesh(&obj, DVec3::splat(-3.0), DVec3::splat(3.0), 16).unwrap();
        let (vol, _) = volume_area(&m);
        assert!((vol - 8.0).abs() < 1e-5, "volume {vol}");
        for c in 0..8 {
            let corner = DVec3::new(
                if c & 1 == 0 { a } else { b },
                if c & 2 == 0 { a } else { b },
                if c & 4 == 0 { a } else { b },
            );
            let nearest = m
                .vertices
                .iter()
                .map(|v| {
                    (DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])) - corner)
                        .length()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-6, "corner {corner}: nearest vertex {nearest}");
        }
    }

    /// The apex of a cone (a spike like the radiator's defect) is kept.
    #[test]
    fn cone_apex_is_kept() {
        // 45 degree cone, apex at z = 0.7 (off the grid), cut at z = -1.3.
        let obj = object(
            "c = { cone_z = { apex = [0.0, 0.0, 0.7], t2 = 1.0 } }\nb = { plane = [0.0, 0.0, -1.0, 1.3] }\nt = { plane = [0.0, 0.0, 1.0, 0.7] }",
            "-c -b -t",
        );
        let m = object_mesh(&obj, DVec3::splat(-3.0), DVec3::splat(3.0), 24).unwrap();
        let top = m
            .vertices
            .iter()
            .map(|v| f64::from(v[2]))
            .fold(f64::NEG_INFINITY, f64::max);
        assert!((top - 0.7).abs() < 1e-6, "highest vertex {top}");
        // Volume pi r² h / 3 with r = h = 2, to the cone's own faceting.
        let (vol, _) = volume_area(&m);
        let exact = std::f64::consts::PI * 4.0 * 2.0 / 3.0;
        assert!(((vol - exact) / exact).abs() < 0.01, "{vol} vs {exact}");
    }

    #[test]
    fn box_cut_caps_the_solid() {
        // A sphere cut by a box through its centre: a closed hemisphere.
        let obj = sphere_object(2.0);
        let m = object_mesh(&obj, DVec3::new(-3.0, -3.0, 0.0), DVec3::splat(3.0), 48).unwrap();
        let (vol, _) = volume_area(&m);
        let exact = 2.0 / 3.0 * std::f64::consts::PI * 8.0;
        assert!(((vol - exact) / exact).abs() < 0.01, "{vol} vs {exact}");
        assert!(object_mesh(&obj, DVec3::ZERO, DVec3::ZERO, 8).is_err());
        assert!(object_mesh(&obj, DVec3::splat(-1.0), DVec3::ONE, 0).is_err());
    }
}
