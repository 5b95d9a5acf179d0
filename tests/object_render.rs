//! `roks render` of an object scene (pinhole camera, macro level) against
//! exact images: a mirror plate seen from above and lit by a disc overhead
//! is exactly rho inside the disc's mirror image and exactly 0 outside it.

mod cli_common;
mod object_common;

use std::process::Command;

use glam::DVec3;
use roks::render::{PinholeCamera, RenderSettings, render_object};

use object_common::{scene, scratch};

/// A 10 x 10 plate, top face z = 0, mirror of constant reflectance 0.75
/// (0.75 and its partial sums over 4 samples are exact in f64 and f32).
const PLATE: &str = r#"
seed = 1

[quadrics]
top = { plane = [0.0, 0.0, 1.0, 0.0] }
bottom = { plane = [0.0, 0.0, 1.0, -1.0] }
xp = { plane = [1.0, 0.0, 0.0, 5.0] }
xm = { plane = [1.0, 0.0, 0.0, -5.0] }
yp = { plane = [0.0, 1.0, 0.0, 5.0] }
ym = { plane = [0.0, 1.0, 0.0, -5.0] }

[[cells]]
name = "plate"
region = "-top +bottom -xp +xm -yp +ym"
fill = "solid"

[walls]
top = "mirror"

[models.mirror]
reflectance = 0.75

[[sources]]
beam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }
position = [0.0, 0.0, 5.0]
photons = 10
"#;

fn camera() -> PinholeCamera {
    PinholeCamera {
        position: DVec3::new(0.0, 0.0, 10.0),
        look_at: DVec3::ZERO,
        up: DVec3::Y,
        fov_deg: 40.0,
    }
}

fn settings(light_theta_deg: f64) -> RenderSettings {
    RenderSettings {
        width: 64,
        height: 48,
        spp: 4,
        light_theta_deg,
        light_phi_deg: 0.0,
        light_radius_deg: 5.0,
        seed: 7,
        ..RenderSettings::default()
    }
}

/// Smallest and largest angle (degrees) between the camera axis and the rays
/// through pixel (i, j): |s| (image-plane offset) is convex, so its maximum is
/// at a corner and its minimum is the distance from the axis to the pixel.
fn pixel_angles(i: usize, j: usize, w: usize, h: usize, fov: f64) -> (f64, f64) {
    let t = (0.5 * fov).to_radians().tan();
    let sx = |x: f64| (2.0 * x / w as f64 - 1.0) * t * (w as f64 / h as f64);
    let sy = |y: f64| (1.0 - 2.0 * y / h as f64) * t;
    let (x0, x1) = (sx(i as f64), sx(i as f64 + 1.0));
    let (y0, y1) = (sy(j as f64 + 1.0), sy(j as f64));
    let near = |a: f64, b: f64| {
        if a <= 0.0 && b >= 0.0 {
            0.0
        } else {
            a.abs().min(b.abs())
        }
    };
    let far = |a: f64, b: f64| a.abs().max(b.abs());
    let smin = near(x0, x1).hypot(near(y0, y1));
    let smax = far(x0, x1).hypot(far(y0, y1));
    (smin.atan().to_degrees(), smax.atan().to_degrees())
}

#[test]
fn mirror_plate_is_rho_inside_the_disc_image_and_zero_outside() {
    let dir = scratch("render-plate");
    let s = scene("plate", PLATE, &dir);
    let (w, h) = (64, 48);
    let (img, losses) = render_object(&s, &camera(), &settings(0.0));
    assert_eq!(losses.lost + losses.unmodelled, 0);
    let (mut inside, mut outside) = (0, 0);
    for j in 0..h {
        for i in 0..w {
            let v = img.rgb[j * w + i];
            assert!(v[0] == v[1] && v[1] == v[2]);
            let (amin, amax) = pixel_angles(i, j, w, h, 40.0);
            // Reflected about z, a ray at angle a from -z leaves at angle a from +z.
            if amax < 5.0 - 1e-6 {
                assert_eq!(v[0], 0.75, "pixel ({i}, {j}) inside the disc's image");
                inside += 1;
            } else if amin > 5.0 + 1e-6 {
                assert_eq!(v[0], 0.0, "pixel ({i}, {j}) outside the disc's image");
                outside += 1;
            } else {
                assert!(
                    (0.0..=0.75).contains(&v[0]),
                    "edge pixel ({i}, {j}) = {}",
                    v[0]
                );
            }
        }
    }
    assert!(
        inside >= 16 && outside > 2000,
        "{inside} inside, {outside} outside"
    );
    // Light from below the plate: nothing reaches the camera.
    let (dark, _) = render_object(&s, &camera(), &settings(180.0));
    assert!(dark.rgb.iter().all(|p| p[0] == 0.0));
}

#[test]
fn object_render_is_the_same_for_any_thread_count() {
    let dir = scratch("render-threads");
    let s = scene("plate", PLATE, &dir);
    let mut cam = camera();
    cam.position = DVec3::new(2.0, -3.0, 8.0);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let a = one.install(|| render_object(&s, &cam, &settings(20.0)));
    let b = two.install(|| render_object(&s, &cam, &settings(20.0)));
    assert_eq!(a, b);
}

#[test]
fn cli_renders_an_object_scene_and_rejects_a_camera_inside_a_solid() {
    let dir = scratch("render-cli");
    let path = dir.join("plate.toml");
    std::fs::write(&path, PLATE).unwrap();
    let exe = env!("CARGO_BIN_EXE_roks");
    let out = dir.join("img.exr");
    let o = Command::new(exe)
        .args([
            "render",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--camera", "0,0,10", "--look-at", "0,0,0", "--light", "0,0"])
        .args(["--size", "32,24", "--spp", "2"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.exists() && out.with_extension("png").exists());
    let bad = dir.join("bad.exr");
    let o = Command::new(exe)
        .args([
            "render",
            path.to_str().unwrap(),
            "--out",
            bad.to_str().unwrap(),
        ])
        .args(["--camera", "0,0,-0.5", "--look-at", "0,0,-10"])
        .output()
        .unwrap();
    cli_common::assert_input_error(
        "camera inside",
        &o,
        &path,
        &bad,
        &["--camera", "inside a solid"],
    );
    assert!(!bad.with_extension("png").exists());
}

#[test]
fn lambertian_plate_has_radiance_rho_sin2_r() {
    // Every camera ray meets the top face once; it leaves cosine-distributed,
    // into the disc (half-angle r, overhead) with probability sin^2 r.
    let dir = scratch("render-diffuse");
    let text = PLATE.replace("reflectance = 0.75", "diffuse = 0.6");
    let s = scene("plate", &text, &dir);
    let mut st = settings(0.0);
    st.light_radius_deg = 20.0;
    st.spp = 16;
    let (img, losses) = render_object(&s, &camera(), &st);
    assert_eq!(losses.lost + losses.unmodelled, 0);
    let px: Vec<f64> = img.rgb.iter().map(|p| f64::from(p[0])).collect();
    let n = px.len() as f64;
    let mean = px.iter().sum::<f64>() / n;
    let var = px.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    let exact = 0.6 * 20f64.to_radians().sin().powi(2);
    assert!((mean - exact).abs() < 4.0 * se, "{mean} ± {se} vs {exact}");
    assert!(se < 0.05 * exact, "too noisy to test: se {se}");
}

#[test]
fn background_is_seen_outside_the_disc_and_a_uniform_sky_is_a_furnace() {
    let dir = scratch("render-background");
    // Mirror: 0.75 inside the disc's image, 0.75 B (exact) everywhere else.
    let s = scene("plate", PLATE, &dir);
    let mut st = settings(0.0);
    st.background_radiance = 0.5;
    let (img, _) = render_object(&s, &camera(), &st);
    let (w, h) = (64, 48);
    for j in 0..h {
        for i in 0..w {
            let v = img.rgb[j * w + i][0];
            let (amin, amax) = pixel_angles(i, j, w, h, 40.0);
            if amax < 5.0 - 1e-6 {
                assert_eq!(v, 0.75, "pixel ({i}, {j}) inside the disc's image");
            } else if amin > 5.0 + 1e-6 {
                assert_eq!(v, 0.375, "pixel ({i}, {j}) outside the disc's image");
            }
        }
    }
    // Lambertian plate under a sky of one radiance B, disc included: rho B.
    let text = PLATE.replace("reflectance = 0.75", "diffuse = 0.6");
    let s = scene("plate", &text, &dir);
    let mut st = settings(0.0);
    st.light_radiance = 0.5;
    st.background_radiance = 0.5;
    let (img, losses) = render_object(&s, &camera(), &st);
    assert_eq!(losses.lost + losses.unmodelled, 0);
    for p in &img.rgb {
        assert!((f64::from(p[0]) - 0.3).abs() < 1e-6, "{}", p[0]);
    }
}
