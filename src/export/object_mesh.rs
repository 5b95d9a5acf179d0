//! The walls of a 3-D object as a closed triangle mesh (`roks export-mesh`
//! of an object scene), for rendering it elsewhere (Mitsuba previews).
//!
//! # Method: surface nets with exact edge crossings
//!
//! Object cells are regions over quadrics (CSG), so there is no parametric
//! surface to tessellate. The box `[lo, hi]` is covered by a grid of cubic
//! voxels of side `h = (longest side) / n`; every grid vertex is classified
//! inside (in some solid cell, and in the box) or outside. Along every grid
//! edge whose ends differ, the crossing of the boundary is found by bisection
//! of the inside test to double precision (60 halvings), so it lies on the
//! exact surface. Each voxel with a sign change gets one mesh vertex, the
//! mean of its edge crossings; each edge with a sign change becomes a quad
//! joining the vertices of the four voxels around it, split into two
//! triangles wound counter-clockwise seen from outside the solid.
//!
//! One layer of voxels outside the box (classified outside) closes the mesh
//! where a solid is cut by the box: the cut is capped on the box face. The
//! mesh is closed and consistently oriented (watertight by construction).
//! Smooth walls are approximated to second order in `h`; sharp edges and
//! corners (an aperture rim, a cone apex) are rounded over about one voxel.
//! Thin features below one voxel can vanish. Coordinates are in the scene's
//! length units, converted to `f32` at the end.

use glam::DVec3;
use rayon::prelude::*;

use super::Mesh;
use crate::object::Object;

/// Most voxels along the longest side (the vertex grid must stay a few
/// hundred MB at most).
pub const MAX_VOXELS_PER_SIDE: usize = 2048;

/// The boundary of the solid cells of `object` inside the box `[lo, hi]`,
/// with `n` voxels along the box's longest side (see the module
/// documentation).
///
/// # Errors
/// If the box is empty or not finite, or `n` is 0 or above
/// [`MAX_VOXELS_PER_SIDE`], or the grid would exceed 2^31 vertices.
pub fn object_mesh(object: &Object, lo: DVec3, hi: DVec3, n: usize) -> Result<Mesh, String> {
    if !(lo.is_finite() && hi.is_finite()) || (hi - lo).min_element() <= 0.0 {
        return Err(format!(
            "box {lo} .. {hi} must be finite with positive sides"
        ));
    }
    if n == 0 || n > MAX_VOXELS_PER_SIDE {
        return Err(format!(
            "resolution {n} must be in 1..={MAX_VOXELS_PER_SIDE}"
        ));
    }
    let size = hi - lo;
    let h = size.max_element() / n as f64;
    // Voxels per axis inside the box, plus one padding voxel each side.
    let cells = [0, 1, 2].map(|a| ((size[a] / h).ceil() as usize).max(1));
    let step = DVec3::new(
        size.x / cells[0] as f64,
        size.y / cells[1] as f64,
        size.z / cells[2] as f64,
    );
    // Vertex grid indices -1 ..= cells + 1 map to 0 ..= cells + 2.
    let dims = cells.map(|c| c + 3);
    let total = dims[0] * dims[1] * dims[2];
    if total > i32::MAX as usize {
        return Err(format!(
            "{total} grid vertices are too many: lower the resolution"
        ));
    }
    let point = |i: usize, j: usize, k: usize| {
        lo + DVec3::new(
            (i as f64 - 1.0) * step.x,
            (j as f64 - 1.0) * step.y,
            (k as f64 - 1.0) * step.z,
        )
    };
    let in_box = |p: DVec3| p.cmpge(lo).all() && p.cmple(hi).all();
    let inside = |p: DVec3| in_box(p) && object.solids.iter().any(|s| s.body.contains(p));
    let index = |i: usize, j: usize, k: usize| (k * dims[1] + j) * dims[0] + i;

    // Classify every vertex (parallel over z slices; order-independent).
    let flags: Vec<bool> = (0..dims[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            (0..dims[1]).flat_map(move |j| (0..dims[0]).map(move |i| inside(point(i, j, k))))
        })
        .collect();

    // The boundary crossing on the edge from vertex p (inside == a) to q.
    let crossing = |mut p: DVec3, mut q: DVec3| {
        let a = inside(p);
        for _ in 0..60 {
            let m = 0.5 * (p + q);
            if inside(m) == a {
                p = m;
            } else {
                q = m;
            }
        }
        0.5 * (p + q)
    };

    // One vertex per voxel with a sign change: the mean of its edge crossings.
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    let voxel_dims = [dims[0] - 1, dims[1] - 1, dims[2] - 1];
    let voxel_vertex: Vec<Option<DVec3>> = (0..voxel_dims[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            let flags = &flags;
            (0..voxel_dims[1]).flat_map(move |j| {
                (0..voxel_dims[0]).map(move |i| {
                    let corner = |c: usize| {
                        let (di, dj, dk) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
                        (i + di, j + dj, k + dk)
                    };
                    let f = |c: usize| {
                        let (a, b, d) = corner(c);
                        flags[index(a, b, d)]
                    };
                    let first = f(0);
                    if (1..8).all(|c| f(c) == first) {
                        return None;
                    }
                    let mut sum = DVec3::ZERO;
                    let mut count = 0.0;
                    for c in 0..8 {
                        for (bit, _) in axes.iter().enumerate() {
                            let o = c ^ (1 << bit);
                            if o > c && f(c) != f(o) {
                                let (a, b, d) = corner(c);
                                let (a2, b2, d2) = corner(o);
                                sum += crossing(point(a, b, d), point(a2, b2, d2));
                                count += 1.0;
                            }
                        }
                    }
                    Some(sum / count)
                })
            })
        })
        .collect();
    let vindex = |i: usize, j: usize, k: usize| (k * voxel_dims[1] + j) * voxel_dims[0] + i;

    // Number the voxel vertices in grid order (deterministic).
    let mut ids = vec![u32::MAX; voxel_vertex.len()];
    let mut vertices = Vec::new();
    for (v, p) in voxel_vertex.iter().enumerate() {
        if let Some(p) = p {
            ids[v] = vertices.len() as u32;
            vertices.push([p.x as f32, p.y as f32, p.z as f32]);
        }
    }

    // A quad for every edge with a sign change, around it through the four
    // voxels sharing it; (a, b, c) cyclic, so the order (0,0), (-1,0),
    // (-1,-1), (0,-1) in (b, c) is counter-clockwise seen from +a.
    let mut faces = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let here = [i, j, k];
                let f0 = flags[index(i, j, k)];
                for a in 0..3 {
                    let mut next = here;
                    next[a] += 1;
                    if next[a] >= dims[a] || flags[index(next[0], next[1], next[2])] == f0 {
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
    Ok(Mesh { vertices, faces })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Source;
    use crate::scene::object::ObjectScene;

    fn sphere_object(r: f64) -> Object {
        let text = format!(
            r#"
[quadrics]
s = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = {r} }} }}
[[cells]]
name = "ball"
region = "-s"
fill = "solid"
[walls]
s = "m"
[models.m]
reflectance = 0.5
[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 0.1 }}
position = [0.0, 0.0, 10.0]
photons = 1
"#
        );
        let source = Source {
            file: "sphere.toml".into(),
            dir: std::env::temp_dir(),
        };
        ObjectScene::from_str(&text, source, "sphere".into())
            .unwrap()
            .object
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
