//! The height-field mesh export (`roks export-mesh`): geometry against
//! analytic surfaces, periodic seams, and the binary PLY encoding.

mod common;

use roks::export::{Mesh, PlyError, height_field_mesh, read_ply, write_ply};
use roks::micro::bumps::Shape;
use roks::scene::micro::MicroScene;

/// A scene on an `lx x ly` substrate with the given edges and extra TOML.
fn scene(lx: f64, ly: f64, edges: &str, extra: &str) -> MicroScene {
    common::scene(
        "mesh",
        &format!(
            "[surface]\nsize = [{lx:?}, {ly:?}]\nedges = \"{edges}\"\nmaterial = \"m\"\n\n\
             [materials.m]\nreflectance = 0.5\n\n{extra}"
        ),
    )
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|k| f64::from(a[k]) - f64::from(b[k]))
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Twice the area vector of each face (right-hand rule over its winding).
fn face_normals(mesh: &Mesh) -> Vec<[f64; 3]> {
    mesh.faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|k| mesh.vertices[k as usize]);
            cross(sub(b, a), sub(c, a))
        })
        .collect()
}

#[test]
fn flat_substrate_is_a_flat_upward_sheet_of_the_cell_area() {
    for edges in ["periodic", "absorbing", "reflecting"] {
        let (lx, ly, n) = (10.0, 6.0, 8);
        let mesh = height_field_mesh(&scene(lx, ly, edges, "").surface, n);
        assert_eq!(mesh.vertices.len(), (n + 1) * (n + 1));
        assert_eq!(mesh.faces.len(), 2 * n * n);
        for (k, v) in mesh.vertices.iter().enumerate() {
            assert_eq!(v[2], 0.0, "{edges}: vertex {k} {v:?}");
            let (i, j) = (k % (n + 1), k / (n + 1));
            assert_eq!(f64::from(v[0]), lx * i as f64 / n as f64);
            assert_eq!(f64::from(v[1]), ly * j as f64 / n as f64);
        }
        let normals = face_normals(&mesh);
        let area: f64 = normals.iter().map(|n| 0.5 * n[2]).sum();
        assert!(
            (area - lx * ly).abs() < 1e-12 * lx * ly,
            "{edges}: area {area}"
        );
        for (k, nrm) in normals.iter().enumerate() {
            assert!(
                nrm[2] > 0.0 && nrm[0] == 0.0 && nrm[1] == 0.0,
                "{edges}: face {k} normal {nrm:?}"
            );
        }
    }
}

#[test]
fn cone_bump_vertices_lie_on_the_analytic_cone() {
    let (lx, ly, n) = (10.0, 8.0, 50);
    let (radius, height) = (2.0, 1.0);
    for edges in ["periodic", "absorbing"] {
        let scene = scene(
            lx,
            ly,
            edges,
            &format!(
                "[[bumps]]\nshape = \"cone\"\ncount = 1\nradius = {radius:?}\nheight = {height:?}\nseed = 7\n"
            ),
        );
        // The bump's (seeded random) centre, from the built surface.
        let (shape, bump) = scene
            .surface
            .solids()
            .iter()
            .find_map(|s| s.bump)
            .expect("one bump");
        assert_eq!(shape, Shape::Cone);
        assert_eq!((bump.radius, bump.height), (radius, height));
        let c = bump.center;
        let periodic = edges == "periodic";
        let cone = |x: f64, y: f64| {
            let (mut dx, mut dy) = (x - c.x, y - c.y);
            if periodic {
                // Nearest periodic copy (the cone is smaller than half a period).
                dx -= lx * (dx / lx).round();
                dy -= ly * (dy / ly).round();
            }
            (height * (1.0 - dx.hypot(dy) / radius)).max(0.0)
        };
        let mesh = height_field_mesh(&scene.surface, n);
        let mut on_cone = 0;
        for (k, v) in mesh.vertices.iter().enumerate() {
            let (i, j) = (k % (n + 1), k / (n + 1));
            let (x, y) = (lx * i as f64 / n as f64, ly * j as f64 / n as f64);
            let want = cone(x, y);
            let got = f64::from(v[2]);
            assert!(
                (got - want).abs() <= 1e-6,
                "{edges}: vertex ({i}, {j}) at ({x}, {y}): z = {got}, cone {want}"
            );
            on_cone += usize::from(want > 0.0);
        }
        // pi r^2 / cell area of the 10 x 8 / 50^2 grid: about 392 vertices.
        assert!(
            on_cone > 300,
            "{edges}: only {on_cone} vertices on the cone"
        );
        assert!(
            face_normals(&mesh).iter().all(|n| n[2] > 0.0),
            "{edges}: a face looks down"
        );
    }
}

#[test]
fn periodic_seams_copy_the_opposite_side_exactly() {
    let scene = MicroScene::default_scene();
    let (lx, ly) = (scene.surface.size.x as f32, scene.surface.size.y as f32);
    let n = 96;
    let mesh = height_field_mesh(&scene.surface, n);
    let v = |i: usize, j: usize| mesh.vertices[j * (n + 1) + i];
    let mut raised = 0;
    for k in 0..=n {
        assert_eq!(
            v(n, k)[2].to_bits(),
            v(0, k)[2].to_bits(),
            "x seam at row {k}"
        );
        assert_eq!(
            v(k, n)[2].to_bits(),
            v(k, 0)[2].to_bits(),
            "y seam at column {k}"
        );
        assert_eq!((v(n, k)[0], v(0, k)[0]), (lx, 0.0));
        assert_eq!((v(k, n)[1], v(k, 0)[1]), (ly, 0.0));
        assert_eq!(v(n, k)[1], v(0, k)[1]);
        assert_eq!(v(k, n)[0], v(k, 0)[0]);
        raised += usize::from(v(0, k)[2] > 0.0) + usize::from(v(k, 0)[2] > 0.0);
    }
    // The default scene's bumps do cross the sides, so the seams are not trivially flat.
    assert!(
        raised > 10,
        "only {raised} seam vertices above the substrate"
    );
}

#[test]
fn ply_header_is_exactly_the_mitsuba_form() {
    let mesh = height_field_mesh(&scene(2.0, 2.0, "periodic", "").surface, 3);
    let bytes = write_ply(&mesh);
    let header = "ply\n\
                  format binary_little_endian 1.0\n\
                  element vertex 16\n\
                  property float x\n\
                  property float y\n\
                  property float z\n\
                  element face 18\n\
                  property list uchar int vertex_indices\n\
                  end_header\n";
    assert_eq!(std::str::from_utf8(&bytes[..header.len()]).unwrap(), header);
    assert_eq!(bytes.len(), header.len() + 16 * 12 + 18 * 13);
    // First vertex (0, 0, 0), then the first face: count 3, indices 0 1 5 (little-endian).
    let data = &bytes[header.len()..];
    assert_eq!(&data[..12], &[0u8; 12]);
    let face = &data[16 * 12..16 * 12 + 13];
    assert_eq!(face, &[3, 0, 0, 0, 0, 1, 0, 0, 0, 5, 0, 0, 0]);
    // The second vertex is x = 2/3 as a little-endian f32.
    assert_eq!(&data[12..16], &(2.0f32 / 3.0).to_le_bytes());
}

#[test]
fn ply_round_trip_is_identical() {
    let mesh = height_field_mesh(&MicroScene::default_scene().surface, 40);
    let bytes = write_ply(&mesh);
    let back = read_ply(&bytes).expect("read back");
    assert_eq!(back, mesh);
    assert!(
        back.vertices
            .iter()
            .zip(&mesh.vertices)
            .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits))
    );
    assert_eq!(write_ply(&back), bytes);
    // The empty mesh too.
    assert_eq!(
        read_ply(&write_ply(&Mesh::default())).unwrap(),
        Mesh::default()
    );
}

#[test]
fn read_ply_rejects_damaged_files() {
    let mesh = height_field_mesh(&scene(2.0, 2.0, "periodic", "").surface, 2);
    let bytes = write_ply(&mesh);
    let header_len = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;

    let err = read_ply(&bytes[..bytes.len() - 1]).unwrap_err();
    assert!(matches!(err, PlyError::Length { .. }), "{err}");
    assert!(err.to_string().contains("bytes of data"), "{err}");
    let err = read_ply(b"ply\nformat ascii 1.0\nend_header\n").unwrap_err();
    assert!(err.to_string().contains("binary_little_endian"), "{err}");
    assert_eq!(read_ply(b"not a ply").unwrap_err(), PlyError::NoEnd);

    let mut quad = bytes.clone();
    quad[header_len + 9 * 12] = 4;
    assert_eq!(
        read_ply(&quad).unwrap_err(),
        PlyError::NotTriangle { face: 0, count: 4 }
    );
    let mut out_of_range = bytes.clone();
    out_of_range[header_len + 9 * 12 + 1] = 9;
    let err = read_ply(&out_of_range).unwrap_err();
    assert!(matches!(err, PlyError::Index { face: 0, .. }), "{err}");
    assert!(err.to_string().contains("out of range"), "{err}");
}
