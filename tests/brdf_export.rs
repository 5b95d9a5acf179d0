//! BRDF exports (`roks export-brdf`): the Zemax tabular BSDF and MERL binary
//! files round-trip through their readers, hold exactly rho/pi for a
//! Lambertian table, carry the table's reflectance as TIS, look up the
//! table's values, and integrate back to the table's reflectance within the
//! resampling errors stated in docs/src/exports.md.

use std::f64::consts::PI;

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use roks::export::brdf_formats::reflectance_check;
use roks::export::exporter::BrdfFormat;
use roks::export::merl::{self, Merl};
use roks::export::resample::symmetric_eval;
use roks::export::zemax::{self, ZemaxBsdf};
use roks::optics::brdf_table::BrdfTable;
use roks::scene::micro::MicroScene;
use roks::tally::CarlsonGrid;

/// Relative rounding of the Zemax file's 7 significant digits.
const PRINTED: f64 = 5e-7;

/// A Lambertian table of albedo `rho` (fraction of a cell = rho proj / pi)
/// at 0, 40 and 80 degrees, 12 bands, at full precision (built in memory:
/// `brdf.csv` holds 10 significant digits).
fn lambertian(rho: f64) -> BrdfTable {
    let m = 12;
    let g = CarlsonGrid::new(m).unwrap();
    let f: Vec<f64> = (0..g.n_cells())
        .map(|flat| {
            let (band, cell) = g.band_cell(flat);
            rho * g.projected_solid_angle(band, cell) / PI
        })
        .collect();
    let blocks = [0.0, 40.0, 80.0]
        .iter()
        .map(|&t| (t, 0.0, f.clone(), vec![0.0; f.len()]))
        .collect();
    BrdfTable::from_blocks(g, blocks, "lambert").unwrap()
}

/// The default scene at all its angles with `photons` per angle, as a table
/// read from the text `roks brdf` writes.
fn default_table(photons: u64) -> BrdfTable {
    let scene = MicroScene::default_scene();
    let mut run = scene.brdf_run();
    run.photons = photons;
    let results = run.trace_whole(&scene.surface, &|_| {});
    BrdfTable::parse(&roks::output::brdf_csv::write(&run, &results), "brdf.csv").unwrap()
}

fn zemax_file(t: &BrdfTable) -> ZemaxBsdf {
    let bytes = BrdfFormat::Zemax.export(t, "test").unwrap();
    ZemaxBsdf::parse(std::str::from_utf8(&bytes).unwrap(), "t.bsdf").unwrap()
}

/// Every grid value of the file above the horizon is rho/pi to the printed
/// precision, every value on or below it 0, TIS is rho; the file's grid
/// integrates back to rho within the horizon bound: the bilinear
/// interpolant is exact wherever its four nodes are above the horizon, i.e.
/// farther than the grid cell's diagonal D = hypot(2, 1) degrees from it,
/// and lies in [0, rho/pi] elsewhere, a band of projected solid angle
/// pi sin²(D) (plus half a quadrature ring, 0.1 degrees).
#[test]
fn lambertian_table_exports_rho_over_pi_to_zemax() {
    let rho = 0.7;
    let t = lambertian(rho);
    let z = zemax_file(&t);
    assert_eq!(z.aoi_deg, [0.0, 40.0, 80.0]);
    assert_eq!((z.azimuth_deg.len(), z.radial_deg.len()), (91, 181));
    let (mut above, mut below) = (0, 0);
    for (k, &aoi) in z.aoi_deg.iter().enumerate() {
        assert!((z.tis[k] - rho).abs() <= PRINTED * rho, "TIS {}", z.tis[k]);
        for (a, &psi) in z.azimuth_deg.iter().enumerate() {
            for (r, &rad) in z.radial_deg.iter().enumerate() {
                let v = z.brdf[k][a * z.radial_deg.len() + r];
                if zemax::direction(aoi, psi, rad).z > 1e-12 {
                    assert!(
                        (v - rho / PI).abs() <= PRINTED * rho / PI,
                        "{aoi} {psi} {rad}: {v}"
                    );
                    above += 1;
                } else {
                    assert_eq!(v, 0.0, "{aoi} {psi} {rad}");
                    below += 1;
                }
            }
        }
    }
    assert!(above > 0 && below > 0);
    let d = 5f64.sqrt().to_radians() + 0.1f64.to_radians();
    let bound = rho * d.sin().powi(2);
    let check = reflectance_check(
        &t,
        BrdfFormat::Zemax,
        &BrdfFormat::Zemax.export(&t, "").unwrap(),
    )
    .unwrap();
    for c in check {
        assert!((c.table - rho).abs() < 1e-14);
        assert!(
            (c.file - rho).abs() <= bound,
            "{}: {} vs {rho} (bound {bound})",
            c.theta_i_deg,
            c.file
        );
    }
}

/// Every bin of every channel is rho/pi (stored as rho/pi / scale), so the
/// file integrates back to rho exactly (the quadrature's weights are exact
/// projected solid angles).
#[test]
fn lambertian_table_exports_rho_over_pi_to_merl() {
    let rho = 0.7;
    let t = lambertian(rho);
    let bytes = BrdfFormat::Merl.export(&t, "").unwrap();
    assert_eq!(bytes.len(), 12 + 24 * merl::N);
    assert_eq!(&bytes[..12], &[90, 0, 0, 0, 90, 0, 0, 0, 180, 0, 0, 0]);
    for c in 0..3 {
        let at = 12 + 8 * (c * merl::N + 12_345);
        let stored = f64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
        let expect = rho / PI / merl::SCALES[c];
        assert!(
            (stored - expect).abs() <= 1e-15 * expect,
            "channel {c}: {stored}"
        );
    }
    let m = Merl::parse(&bytes, "t.binary").unwrap();
    for (n, v) in m.values.iter().enumerate() {
        assert!((v - rho / PI).abs() <= 1e-15, "value {n}: {v}");
    }
    for c in reflectance_check(&t, BrdfFormat::Merl, &bytes).unwrap() {
        assert!(
            (c.file - rho).abs() < 1e-12,
            "{}: {}",
            c.theta_i_deg,
            c.file
        );
    }
}

/// Write, read: the grids exactly, TIS the table's reflectance and every
/// value the resampled table (its mirror-symmetrised BRDF at the node's
/// direction, computed here from `BrdfTable::eval`) to 7 digits; in the
/// plane of incidence (azimuth 0 or 180) the table's own value.
#[test]
fn zemax_round_trip_to_printed_precision() {
    let t = default_table(20_000);
    let z0 = ZemaxBsdf::from_table(&t);
    let z = ZemaxBsdf::parse(&z0.to_text("round trip"), "t.bsdf").unwrap();
    assert_eq!(
        (&z.aoi_deg, &z.azimuth_deg, &z.radial_deg),
        (&z0.aoi_deg, &z0.azimuth_deg, &z0.radial_deg)
    );
    assert_eq!(z.aoi_deg, t.thetas_deg());
    let nr = z.radial_deg.len();
    for (k, &aoi) in z.aoi_deg.iter().enumerate() {
        let theta = aoi.to_radians();
        let r = t.reflectance(theta);
        assert!(
            (z.tis[k] - r).abs() <= PRINTED * r,
            "TIS {} vs {r}",
            z.tis[k]
        );
        for (a, &psi) in z.azimuth_deg.iter().enumerate() {
            for (i, &rad) in z.radial_deg.iter().enumerate() {
                let d = zemax::direction(aoi, psi, rad);
                let expect = if d.z > 1e-12 {
                    let m = DVec3::new(d.x, -d.y, d.z);
                    0.5 * (t.eval(theta, d) + t.eval(theta, m))
                } else {
                    0.0
                };
                let v = z.brdf[k][a * nr + i];
                assert!(
                    (v - expect).abs() <= PRINTED * expect,
                    "{aoi} {psi} {rad}: {v} vs {expect}"
                );
                if (psi == 0.0 || psi == 180.0) && d.z > 1e-12 && d.y.abs() < 1e-12 {
                    let own = t.eval(theta, d);
                    assert!(
                        (v - own).abs() <= PRINTED * own,
                        "in plane {aoi} {psi} {rad}"
                    );
                }
            }
        }
    }
}

/// Write, read: doubles survive exactly up to the scale's rounding (2 ulp);
/// each bin-centre direction pair looks up the value stored for it, which is
/// the reciprocal blend; with the light at a tabulated angle the blend is
/// the table's own (symmetrised) BRDF toward the viewer; the file is
/// reciprocal and symmetric about the plane of incidence (bins k and
/// 179 - k are mirror images).
#[test]
fn merl_round_trip_and_lookups() {
    let t = default_table(20_000);
    let m0 = Merl::from_table(&t);
    let m = Merl::parse(&m0.to_bytes(), "t.binary").unwrap();
    for (a, b) in m.values.iter().zip(&m0.values) {
        assert!((a - b).abs() <= 2.0 * f64::EPSILON * b.abs(), "{a} vs {b}");
    }
    // Mirror bins agree to rounding (of the largest value: the blends add
    // terms of the size of the peak).
    let scale = m.values.iter().fold(0.0_f64, |a, &b| a.max(b));
    for i in 0..merl::THETA_H {
        for j in 0..merl::THETA_D {
            for k in 0..merl::PHI_D / 2 {
                let (a, b) = (
                    m.values[merl::index(i, j, k)],
                    m.values[merl::index(i, j, merl::PHI_D - 1 - k)],
                );
                assert!(
                    (a - b).abs() <= 1e-12 * scale,
                    "bin {i} {j} {k}: {a} vs {b}"
                );
            }
        }
    }
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let mut checked = 0;
    while checked < 2000 {
        let (i, j, k) = (
            rng.random_range(0..merl::THETA_H),
            rng.random_range(0..merl::THETA_D),
            rng.random_range(0..merl::PHI_D),
        );
        let (wi, wo) = merl::bin_directions(i, j, k);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            continue;
        }
        let expect = merl::reciprocal_eval(&t, wi, wo);
        let got = m.lookup(wi, wo);
        for (c, g) in got.iter().enumerate() {
            assert!(
                (g - expect).abs() <= 4.0 * f64::EPSILON * expect,
                "bin {i} {j} {k} channel {c}"
            );
        }
        checked += 1;
    }
    for &deg in t.thetas_deg() {
        let theta = deg.to_radians();
        let wi = DVec3::new(theta.sin(), 0.0, theta.cos());
        for _ in 0..200 {
            let (ct, p) = (
                rng.random::<f64>(),
                rng.random::<f64>() * std::f64::consts::TAU,
            );
            let st = (1.0 - ct * ct).sqrt();
            let wo = DVec3::new(st * p.cos(), st * p.sin(), ct);
            let off_table = t
                .thetas_deg()
                .iter()
                .all(|a| (a - ct.acos().to_degrees()).abs() > 1e-9);
            if ct > 0.0 && off_table {
                let (r, e) = (
                    merl::reciprocal_eval(&t, wi, wo),
                    symmetric_eval(&t, theta, wo),
                );
                assert!((r - e).abs() <= 1e-12 * scale, "{r} vs {e}");
                // Swapped: the same bin, or at normal incidence (phi_diff
                // exactly 0 or 180 degrees, the fold's two ends) its mirror
                // bin 179 - k, which holds the same value (plane symmetry).
                let (a, b) = (m.lookup(wi, wo), m.lookup(wo, wi));
                for c in 0..3 {
                    assert!((a[c] - b[c]).abs() <= 1e-12 * a[c], "{a:?} vs {b:?}");
                }
            }
        }
    }
}

/// The measured resampling error of the default scene's table (docs/src/exports.md's:
/// 10 angles x 10^6 photons, seed 1): TIS is the table's reflectance to 7 digits; the files
/// read back and integrated over the hemisphere (0.2 degree quadrature;
/// halving its cells changes the results by < 1e-6 for Zemax, < 6e-4 for MERL) give the table's reflectance within 0.5 % (Zemax,
/// bilinear in 2 x 1 degree steps) and 2 % (MERL, nearest bin). These bounds
/// are about twice the largest errors measured (0.27 % at 10 degrees and
/// 1.1 % at normal incidence, where the narrow single-bounce peak meets the
/// grids); the resampling error of a given table is deterministic, not Monte
/// Carlo noise, so they are regression bounds for this table.
#[test]
fn exports_integrate_back_to_the_table_reflectance() {
    let t = default_table(1_000_000);
    let z = zemax_file(&t);
    for (k, &deg) in z.aoi_deg.iter().enumerate() {
        let r = t.reflectance(deg.to_radians());
        assert!((z.tis[k] - r).abs() <= PRINTED * r);
    }
    for (format, bound) in [(BrdfFormat::Zemax, 5e-3), (BrdfFormat::Merl, 2e-2)] {
        let check = reflectance_check(&t, format, &format.export(&t, "").unwrap()).unwrap();
        for c in &check {
            let rel = c.file / c.table - 1.0;
            eprintln!(
                "{format} {:>5} table {:.6} file {:.6} relative {rel:+.2e}",
                c.theta_i_deg, c.table, c.file
            );
            assert!(
                rel.abs() < bound,
                "{format} at {}: {rel:+.2e}",
                c.theta_i_deg
            );
        }
    }
}

/// Same table, same bytes (rayon ordering does not leak into the files).
#[test]
fn exports_are_deterministic() {
    let t = lambertian(0.3);
    let a = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for f in [BrdfFormat::Zemax, BrdfFormat::Merl] {
        let one = a.install(|| f.export(&t, "x").unwrap());
        assert!(one == f.export(&t, "x").unwrap(), "{f}");
    }
}

/// Readers reject broken files with one line naming the file, the line and
/// the keyword (Zemax) or what is wrong (MERL).
#[test]
fn readers_name_file_and_key() {
    let text = zemax::ZemaxBsdf::from_table(&lambertian(0.5)).to_text("");
    let err = |s: &str| ZemaxBsdf::parse(s, "bad.bsdf").unwrap_err().to_string();
    let check = |e: String, needles: &[&str]| {
        assert!(e.starts_with("bad.bsdf: line ") && !e.contains('\n'), "{e}");
        for n in needles {
            assert!(e.contains(n), "`{n}` not in {e}");
        }
    };
    check(
        err(&text.replace("PlaneSymmetrical", "Asymmetrical")),
        &["Symmetry", "Asymmetrical"],
    );
    check(
        err(&text.replace("AngleOfIncidence  3", "AngleOfIncidence  4")),
        &["ScatterAzimuth"],
    );
    check(
        err(&text.replacen("TIS 5.000000E-01", "TIS x", 1)),
        &["TIS", "`x`"],
    );
    check(
        err(&text.replace("DataEnd\n", "")),
        &["DataEnd", "end of file"],
    );
    check(err(&text.replacen("1.591549E-01", "-1", 1)), &["negative"]);
    let bytes = BrdfFormat::Merl.export(&lambertian(0.5), "").unwrap();
    let merr = |b: &[u8]| Merl::parse(b, "bad.binary").unwrap_err().to_string();
    assert!(merr(&bytes[..100]).contains("expected"));
    let mut dims = bytes.clone();
    dims[8] = 104; // 360 phi_diff bins (low byte)
    dims[9] = 1;
    assert!(
        merr(&dims).contains("dimensions 90 x 90 x 360"),
        "{}",
        merr(&dims)
    );
    assert!(merr(&bytes[..5]).starts_with("bad.binary: 5 bytes"));
}
