//! `roks render` of an object scene (pinhole camera, macro level) against
//! exact images: a mirror plate seen from above and lit by a disc overhead
//! is exactly rho inside the disc's mirror image and exactly 0 outside it;
//! a Lambertian plate is `rho sin² r` with and without light sampling
//! (next-event estimation), and light sampling agrees with meeting the disc
//! by chance on a corner of BRDF-table and Lambertian walls, shadows and
//! interreflections included, within the standard error.

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
    // A linear preview at exposure 0: the mirror's 0.75 inside the disc's
    // image, 0.75 times the object default background 1e-3 outside it.
    let o = Command::new(exe)
        .args([
            "render",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--camera", "0,0,10", "--look-at", "0,0,0", "--light", "0,0"])
        .args(["--size", "32,24", "--spp", "2"])
        .args(["--tonemap", "linear", "--exposure", "0"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("preview: linear, --exposure 0.000"));
    let png = image::open(out.with_extension("png")).unwrap().to_rgb8();
    let srgb = |x: f64| (roks::optics::colour::srgb_encode(x) * 255.0).round() as u8;
    assert_eq!(png.get_pixel(16, 12).0, [srgb(0.75); 3]);
    assert_eq!(png.get_pixel(0, 0).0, [srgb(0.75e-3); 3]);
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

/// Mean and standard error of the pixels' first channel (independent
/// pixel estimates: each pixel draws from its own stream).
fn mean_se(px: impl Iterator<Item = f64>) -> (f64, f64) {
    let px: Vec<f64> = px.collect();
    let n = px.len() as f64;
    let mean = px.iter().sum::<f64>() / n;
    let var = px.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn lambertian_plate_has_radiance_rho_sin2_r() {
    // Every camera ray meets the top face once. Without light sampling it
    // leaves cosine-distributed, into the disc (half-angle r, overhead) with
    // probability sin^2 r; with it, the disc's light is (rho / pi) times
    // the integral of cos over the disc, pi sin^2 r: the same radiance.
    let dir = scratch("render-diffuse");
    let text = PLATE.replace("reflectance = 0.75", "diffuse = 0.6");
    let s = scene("plate", &text, &dir);
    let exact = 0.6 * 20f64.to_radians().sin().powi(2);
    let mut se_of = [0.0; 2];
    for (k, sampling) in [false, true].into_iter().enumerate() {
        let mut st = settings(0.0);
        st.light_radius_deg = 20.0;
        st.spp = 16;
        st.light_sampling = sampling;
        let (img, losses) = render_object(&s, &camera(), &st);
        assert_eq!(losses.lost + losses.unmodelled, 0);
        let (mean, se) = mean_se(img.rgb.iter().map(|p| f64::from(p[0])));
        assert!(
            (mean - exact).abs() < 4.0 * se,
            "light sampling {sampling}: {mean} ± {se} vs {exact}"
        );
        assert!(se < 0.05 * exact, "too noisy to test: se {se}");
        se_of[k] = se;
    }
    // The point of sampling the light: the same answer, less noise.
    assert!(se_of[1] < 0.5 * se_of[0], "{se_of:?}");
}

/// A floor of 10 x 10 (top face z = 0) with a block standing on its +x
/// edge (x in [5, 6], up to z = 6): the floor's top `{floor}`, the block's
/// face toward the floor (x = 5) and its top Lambertian of 0.5. A light
/// from +x, 40 degrees from the zenith, leaves the floor beyond the block's
/// shadow (x < 0) lit, the shadow (0 < x < 5) and the block's face lit only
/// by the floor.
fn corner(floor: &str) -> String {
    format!(
        r#"
seed = 1

[quadrics]
top = {{ plane = [0.0, 0.0, 1.0, 0.0] }}
bottom = {{ plane = [0.0, 0.0, 1.0, -1.0] }}
xp = {{ plane = [1.0, 0.0, 0.0, 5.0] }}
xm = {{ plane = [1.0, 0.0, 0.0, -5.0] }}
yp = {{ plane = [0.0, 1.0, 0.0, 5.0] }}
ym = {{ plane = [0.0, 1.0, 0.0, -5.0] }}
bx = {{ plane = [1.0, 0.0, 0.0, 6.0] }}
btop = {{ plane = [0.0, 0.0, 1.0, 6.0] }}

[[cells]]
name = "floor"
region = "-top +bottom -xp +xm -yp +ym"
fill = "solid"

[[cells]]
name = "block"
region = "+xp -bx -btop +bottom -yp +ym"
fill = "solid"

[walls]
top = "floor"
xp = "wall"
btop = "wall"
xm = "wall"
yp = "wall"
ym = "wall"
bx = "wall"
bottom = "wall"

[models.floor]
{floor}

[models.wall]
diffuse = 0.5

[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 1.0 }}
position = [0.0, 0.0, 5.0]
photons = 10
"#
    )
}

/// Light sampling against meeting the disc by chance, on the corner with a
/// Lambertian floor and with a floor of a BRDF table (a `roks brdf` run of
/// a bumpy paint): the two renders estimate the same image, so the
/// per-pixel differences (independent streams: seeds 7 and 8) average to 0
/// within 4 standard errors; the lit floor and the shadow are both in view.
#[test]
fn light_sampling_agrees_with_meeting_the_disc_by_chance() {
    let dir = scratch("render-corner");
    std::fs::write(dir.join("micro.toml"), TABLE_MICRO).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .arg("brdf")
        .arg(dir.join("micro.toml"))
        .arg("--out")
        .arg(dir.join("out"))
        .args(["--theta", "0,10,20,30,40,50,60,70,80,89"])
        .args(["--photons", "20000", "--stats-resolution", "32", "-q"])
        .output()
        .expect("run roks brdf");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cam = PinholeCamera {
        position: DVec3::new(-6.0, -9.0, 12.0),
        look_at: DVec3::new(0.5, 0.0, 0.0),
        up: DVec3::Z,
        fov_deg: 50.0,
    };
    for (name, floor) in [
        ("lambertian", "diffuse = 0.7"),
        ("table", r#"brdf = "out/brdf.csv""#),
    ] {
        let s = scene(name, &corner(floor), &dir);
        let render = |sampling: bool, seed: u64| {
            let st = RenderSettings {
                width: 48,
                height: 36,
                spp: 512,
                light_theta_deg: 40.0,
                light_phi_deg: 0.0,
                light_radius_deg: 10.0,
                light_sampling: sampling,
                seed,
                ..RenderSettings::default()
            };
            let (img, losses) = render_object(&s, &cam, &st);
            assert_eq!(losses.lost + losses.unmodelled, 0);
            img
        };
        let (lit, chance) = (render(true, 7), render(false, 8));
        let (mean, _) = mean_se(lit.rgb.iter().map(|p| f64::from(p[0])));
        let (d, se) = mean_se(
            lit.rgb
                .iter()
                .zip(&chance.rgb)
                .map(|(a, b)| f64::from(a[0]) - f64::from(b[0])),
        );
        eprintln!("{name}: image mean {mean:.5}, difference {d:.2e} ± {se:.2e}");
        assert!(d.abs() < 4.0 * se, "{name}: difference {d} ± {se}");
        assert!(
            se < 0.025 * mean,
            "{name}: too noisy to test: {se} vs {mean}"
        );
        // Both the lit floor and the shadow are seen (values differ by 10x).
        let dark = lit.rgb.iter().filter(|p| p[0] < 0.1 * mean as f32).count();
        let bright = lit.rgb.iter().filter(|p| p[0] > mean as f32).count();
        assert!(
            dark > 50 && bright > 50,
            "{name}: {dark} dark, {bright} bright pixels"
        );
    }
}

/// The bumpy paint of the table floor (a glossy lobe and a diffuse part).
const TABLE_MICRO: &str = r#"
name = "paint"

[surface]
size = [10.0, 10.0]
edges = "periodic"
material = "paint"

[materials.paint]
reflectance = 0.8

[[bumps]]
shape = "ellipsoid"
count = 20
radius = [1.5, 2.5]
height = [0.3, 1.0]
seed = 7

[light]
theta_deg = [40]
photons = 20000

[tally]
bands = 8
"#;

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
    st.light_sampling = false;
    let (img, losses) = render_object(&s, &camera(), &st);
    assert_eq!(losses.lost + losses.unmodelled, 0);
    for p in &img.rgb {
        assert!((f64::from(p[0]) - 0.3).abs() < 1e-6, "{}", p[0]);
    }
    // With light sampling the disc's part is sampled and the sky's met by
    // chance (an escape into the disc adds 0): rho B within the error.
    st.light_sampling = true;
    st.spp = 16;
    let (img, _) = render_object(&s, &camera(), &st);
    let (mean, se) = mean_se(img.rgb.iter().map(|p| f64::from(p[0])));
    assert!((mean - 0.3).abs() < 4.0 * se && se < 1e-3, "{mean} ± {se}");
}
