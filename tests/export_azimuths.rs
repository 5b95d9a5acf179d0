//! Exports of a table of several light azimuths (`phi_i_deg`): the Zemax
//! file is `Asymmetrical4D` with a block per sample rotation (the light
//! azimuth) and angle of incidence holding that azimuth's table exactly,
//! read back and judged per incidence and azimuth; MERL writes the
//! azimuths' average and warns when they disagree beyond their errors (and
//! only then); RGL writes an anisotropic file for the azimuth sets that
//! fill one of the reader's domains (the whole circle, 0 to 180, 0 to 90)
//! and refuses others with one line naming the file, `phi_i_deg`,
//! `light.phi_deg` and `--phi`, before tracing for `roks brdf --export`.
//! The tables are synthetic: an analytic BRDF integrated exactly over each
//! Carlson cell, written by the `brdf.csv` writer.

mod cli_common;
use cli_common::{roks, roks_within};

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::DVec3;
use roks::export::brdf_formats::reflectance_check;
use roks::export::exporter::BrdfFormat;
use roks::export::merl;
use roks::export::zemax::{self, Symmetry, ZemaxBsdf};
use roks::optics::brdf_table::BrdfTable;
use roks::output::brdf_csv::{Block, write_blocks};
use roks::tally::CarlsonGrid;

/// Relative rounding of the Zemax file's 7 significant digits.
const PRINTED: f64 = 5e-7;

/// `C / pi` of the synthetic BRDF: its reflectance is `C`.
const C: f64 = 0.6;

/// The synthetic BRDF at light azimuth `phi_k` (radians) toward absolute
/// azimuth `phi`: `C / pi (1 + 0.5 cos(phi - s phi_k))`. `s = 1` turns with
/// the light (isotropic: a function of `phi - phi_k` only); `s = 2` does
/// not (anisotropic). Its mean over a cell of band edges `phi_lo..phi_hi`.
fn cell_brdf(phi_lo: f64, phi_hi: f64, phi_k: f64, s: f64) -> f64 {
    let d = phi_hi - phi_lo;
    C / PI * (1.0 + 0.5 * ((phi_hi - s * phi_k).sin() - (phi_lo - s * phi_k).sin()) / d)
}

/// The fractions of the synthetic BRDF at light azimuth `phi_k_deg`: the
/// exact integral over each cell, `mean BRDF x projected solid angle`.
fn fractions(g: &CarlsonGrid, phi_k_deg: f64, s: f64) -> Vec<f64> {
    (0..g.n_cells())
        .map(|flat| {
            let (band, cell) = g.band_cell(flat);
            let (lo, hi) = g.phi_edges(band, cell);
            cell_brdf(lo, hi, phi_k_deg.to_radians(), s) * g.projected_solid_angle(band, cell)
        })
        .collect()
}

/// The `brdf.csv` text of the synthetic BRDF at angles 0, 30, 60 and light
/// azimuths 0 and 90 degrees on `m` bands (errors 1 % of the fractions),
/// in the order of `roks brdf` (angle, then azimuth).
fn csv(m: usize, s: f64) -> String {
    csv_at(m, s, &[0.0, 90.0])
}

/// [`csv`] at the light azimuths `azimuths` (degrees, ascending).
fn csv_at(m: usize, s: f64, azimuths: &[f64]) -> String {
    let g = CarlsonGrid::new(m).unwrap();
    let mut blocks = Vec::new();
    for theta in [0.0, 30.0, 60.0] {
        for &phi in azimuths {
            let f = fractions(&g, phi, s);
            let se: Vec<f64> = f.iter().map(|x| 0.01 * x).collect();
            blocks.push((theta, phi, f, se));
        }
    }
    write_blocks(
        &g,
        blocks.iter().map(|(theta, phi, f, se)| Block {
            theta_i_deg: *theta,
            phi_i_deg: *phi,
            wavelength_um: None,
            fractions: f,
            stderr: se,
        }),
    )
}

/// Turn `d` about `z` by `angle` (radians), as the table does.
fn rotate_z(d: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    DVec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z)
}

/// The Zemax file of the anisotropic table is `Asymmetrical4D`: sample
/// rotations 0 and 90 (the light azimuths), azimuths 0-360, a block per
/// rotation and angle of incidence (rotation-major) whose every node above
/// the horizon holds the synthetic BRDF's mean over the Carlson cell the
/// node's direction falls in, turned to the rotation's light azimuth
/// (computed here from the formula, not by the table), every node on or
/// below it 0; TIS is the reflectance C. It reads back to the same text,
/// and integrates back to each azimuth's reflectance within 1 %, judged per
/// incidence and azimuth. Averaging the rotation-90 block with its mirror
/// image (as PlaneSymmetrical does) or swapping the rotations fails the
/// node check by far: the BRDF there is `1 + 0.5 sin(psi)`-like across the
/// plane of incidence.
#[test]
fn zemax_asymmetrical4d_holds_each_azimuth() {
    let m = 24;
    let g = CarlsonGrid::new(m).unwrap();
    let table = BrdfTable::parse(&csv(m, 2.0), "aniso.csv").unwrap();
    assert_eq!(table.azimuths_deg(), &[0.0, 90.0]);
    let bytes = BrdfFormat::Zemax.export(&table, "two azimuths").unwrap();
    let text = std::str::from_utf8(&bytes).unwrap();
    assert!(
        text.contains("\nSymmetry  Asymmetrical4D\n"),
        "{}",
        &text[..400]
    );
    assert!(text.contains("\nSampleRotation  2\n0 90\n"));
    let z = ZemaxBsdf::parse(text, "t.bsdf").unwrap();
    assert_eq!(z.symmetry, Symmetry::Asymmetrical4D);
    assert_eq!(z.rotation_deg, vec![0.0, 90.0]);
    assert_eq!(z.aoi_deg, vec![0.0, 30.0, 60.0]);
    assert_eq!(z.azimuth_deg.first(), Some(&0.0));
    assert_eq!(z.azimuth_deg.last(), Some(&360.0));
    assert_eq!(z.tis.len(), 6);
    assert_eq!(
        z.to_text("two azimuths"),
        text,
        "reads back to the same text"
    );
    let (na, nr) = (z.azimuth_deg.len(), z.radial_deg.len());
    let mut checked = 0;
    for (j, &rho) in z.rotation_deg.iter().enumerate() {
        for (t, &aoi) in z.aoi_deg.iter().enumerate() {
            let k = j * z.aoi_deg.len() + t;
            assert_eq!((z.block_rotation_deg(k), z.block_aoi_deg(k)), (rho, aoi));
            assert!((z.tis[k] / C - 1.0).abs() < 1e-6, "TIS {}", z.tis[k]);
            for a in 0..na {
                for r in 0..nr {
                    let v = z.brdf[k][a * nr + r];
                    let d = zemax::direction(aoi, z.azimuth_deg[a], z.radial_deg[r]);
                    if d.z <= 1e-12 {
                        assert_eq!(v, 0.0);
                        continue;
                    }
                    let abs = rotate_z(d.normalize(), rho.to_radians());
                    let flat = g.locate(abs).unwrap();
                    let (band, cell) = g.band_cell(flat);
                    let (lo, hi) = g.phi_edges(band, cell);
                    let want = cell_brdf(lo, hi, rho.to_radians(), 2.0);
                    assert!(
                        (v / want - 1.0).abs() < PRINTED + 1e-9,
                        "rotation {rho} aoi {aoi} psi {} r {}: {v} vs {want}",
                        z.azimuth_deg[a],
                        z.radial_deg[r]
                    );
                    checked += 1;
                }
            }
        }
    }
    // 181 x 181 nodes per block, about half above the horizon.
    assert!(checked > 6 * 15_000, "{checked}");
    let checks = reflectance_check(&table, BrdfFormat::Zemax, &bytes).unwrap();
    let keys: Vec<(f64, Option<f64>)> = checks
        .iter()
        .map(|c| (c.theta_i_deg, c.phi_i_deg))
        .collect();
    assert_eq!(
        keys,
        [0.0, 30.0, 60.0]
            .iter()
            .flat_map(|&t| [(t, Some(0.0)), (t, Some(90.0))])
            .collect::<Vec<_>>()
    );
    for c in &checks {
        assert!((c.table / C - 1.0).abs() < 1e-9, "{c:?}");
        assert!(c.passes(), "{c:?}");
    }
}

/// A table of one light azimuth is still written PlaneSymmetrical, with
/// one sample rotation and azimuths 0-180, exactly the text of a table
/// built from the azimuth's rows alone.
#[test]
fn one_azimuth_stays_plane_symmetrical() {
    let m = 8;
    let table = BrdfTable::parse(&csv(m, 2.0), "aniso.csv").unwrap();
    let alone = table.azimuth(0);
    let bytes = BrdfFormat::Zemax.export(&alone, "one").unwrap();
    let text = std::str::from_utf8(&bytes).unwrap();
    assert!(
        text.contains("\nSymmetry  PlaneSymmetrical\n")
            && text.contains("\nSampleRotation  1\n0\n")
    );
    let z = ZemaxBsdf::parse(text, "t.bsdf").unwrap();
    assert_eq!(z.symmetry, Symmetry::PlaneSymmetrical);
    assert_eq!(z.azimuth_deg.last(), Some(&180.0));
    assert_eq!(z.tis.len(), 3);
}

/// MERL of several azimuths: the anisotropic table gets a warning naming
/// the anisotropy (chi^2/dof, the worst cell pair); the isotropic one (each
/// azimuth's block the other's turned) a note that they agree, no warning.
/// The file holds the azimuths' average: its values are those of the MERL
/// file of a table whose eval is that average by construction (mean of the
/// two azimuths' files, to rounding).
#[test]
fn merl_averages_and_warns_on_anisotropy() {
    let m = 8;
    let aniso = BrdfTable::parse(&csv(m, 2.0), "aniso.csv").unwrap();
    let iso = BrdfTable::parse(&csv(m, 1.0), "iso.csv").unwrap();
    let (warn, line) = merl::azimuth_note(&aniso).unwrap();
    assert!(
        warn && line.contains("anisotropic") && line.contains("chi^2/dof"),
        "{line}"
    );
    let (warn, line) = merl::azimuth_note(&iso).unwrap();
    assert!(
        !warn && line.contains("agree within their errors"),
        "{line}"
    );
    assert!(merl::azimuth_note(&aniso.azimuth(0)).is_none());
    let both = merl::resample(&aniso);
    let (a, b) = (
        merl::resample(&aniso.azimuth(0)),
        merl::resample(&aniso.azimuth(1)),
    );
    for i in (0..both.len()).step_by(97) {
        let mean = 0.5 * (a[i] + b[i]);
        assert!(
            (both[i] - mean).abs() <= 1e-12 * mean.abs().max(1e-3),
            "{i}: {} vs {mean}",
            both[i]
        );
    }
}

/// RGL of the anisotropic synthetic table (`s = 2`) at the whole circle
/// (0, 90, 180, 270: `phi_i` nodes -180 (the 180 block), -90, 0, 90, 180),
/// at 0 to 180 (0, 45, .., 180: nodes -180..180 every 45 degrees, node `a`
/// the azimuth `a`, node `a - 180` the azimuth `a` turned by a half turn)
/// and at 0 to 90 (0, 45, 90: nodes every 45 degrees, filled by the
/// mirrors and the half turn): every file spans the whole circle, the only
/// domain pbrt-v4 reads. The file read back evaluates, at every node and
/// incidence, towards directions all over the hemisphere, to the synthetic
/// BRDF of the run's azimuth that the node comes from (the formula, not the
/// table) at the run's direction (the file's `wo` moved by the node's
/// isometry, written out here: a half turn `(-x, -y)`, the mirror about yz
/// `(-x, y)`, about xz `(x, -y)`): at the centres of the cells of bands
/// 6-24 of 24 (cells at most 15 degrees wide), its mean over the cell
/// holding the run's direction, within 2 % of `C / pi` (measured worst:
/// 0.66 % for the circle, 1.06 % for 0 to 180, 0.73 % for 0 to 90, with
/// the nodes' boxes averaged; 2.4-2.9 % with values at the nodes). Left out: the cells where
/// the half vector is within 10 degrees of the normal (at the specular
/// direction the vndf warp is singular and the writer's resampling error
/// reaches 10 % of the value, in an isotropic file alike: 7 % at a
/// single-azimuth file's specular direction, measured) and the two bands at
/// the horizon. Skipping the isometry puts the value at `1 + 0.5 cos(phi +
/// 180 - 2 phi_k)` or its mirror instead, off by up to `C / pi` (checked:
/// the test then fails). The reflectance check is per angle and azimuth, in
/// the table's order, every one within its tolerance; a set of no domain
/// (0, 90) is refused naming what is accepted.
#[test]
fn rgl_anisotropic_holds_each_azimuth() {
    use roks::export::rgl::{Ndf, Rgl, layout};
    use roks::optics::brdf_table::BrdfTables;
    let m = 24;
    let g = CarlsonGrid::new(m).unwrap();
    // (node, run azimuth, isometry: 'i' identity, 'h' half turn, 'x'
    // mirror x -> -x, 'y' mirror y -> -y)
    let cases: [(&[f64], &[(f64, f64, char)]); 3] = [
        (
            &[0.0, 90.0, 180.0, 270.0],
            &[
                (-180.0, 180.0, 'i'),
                (-90.0, 270.0, 'i'),
                (0.0, 0.0, 'i'),
                (90.0, 90.0, 'i'),
                (180.0, 180.0, 'i'),
            ],
        ),
        (
            &[0.0, 45.0, 90.0, 135.0, 180.0],
            &[
                (-180.0, 0.0, 'h'),
                (-135.0, 45.0, 'h'),
                (-90.0, 90.0, 'h'),
                (-45.0, 135.0, 'h'),
                (0.0, 0.0, 'i'),
                (45.0, 45.0, 'i'),
                (90.0, 90.0, 'i'),
                (135.0, 135.0, 'i'),
                (180.0, 180.0, 'i'),
            ],
        ),
        (
            &[0.0, 45.0, 90.0],
            &[
                (-180.0, 0.0, 'h'),
                (-135.0, 45.0, 'h'),
                (-90.0, 90.0, 'y'),
                (-45.0, 45.0, 'y'),
                (0.0, 0.0, 'i'),
                (45.0, 45.0, 'i'),
                (90.0, 90.0, 'i'),
                (135.0, 45.0, 'x'),
                (180.0, 0.0, 'x'),
            ],
        ),
    ];
    for (azimuths, nodes) in cases {
        let table = BrdfTable::parse(&csv_at(m, 2.0, azimuths), "aniso.csv").unwrap();
        let tables = BrdfTables::Monochrome(table);
        let bytes = Rgl::from_tables(&tables, &Ndf::uniform(), "aniso")
            .unwrap()
            .to_bytes();
        let back = Rgl::parse(&bytes, "aniso.bsdf").unwrap();
        let got_nodes: Vec<f64> = back.phi_i.iter().map(|p| p.to_degrees()).collect();
        assert_eq!(got_nodes.len(), nodes.len(), "{got_nodes:?} vs {nodes:?}");
        for (a, b) in got_nodes.iter().zip(nodes) {
            assert!((a - b.0).abs() < 1e-4, "{got_nodes:?} vs {nodes:?}");
        }
        let ni = back.theta_i.len();
        let mut worst: f64 = 0.0;
        for (p, &(node, phi_k, how)) in nodes.iter().enumerate() {
            for k in 0..ni {
                for flat in (g.index(6, 0)..g.n_cells()).step_by(7) {
                    let (band, cell) = g.band_cell(flat);
                    let (t, f) = g.centre(band, cell);
                    let wo = DVec3::new(t.sin() * f.cos(), t.sin() * f.sin(), t.cos());
                    let run_wo = match how {
                        'h' => rotate_z(wo, PI),
                        'x' => DVec3::new(-wo.x, wo.y, wo.z),
                        'y' => DVec3::new(wo.x, -wo.y, wo.z),
                        _ => wo,
                    };
                    let (b, c) = g.band_cell(g.locate(run_wo).unwrap());
                    let (lo, hi) = g.phi_edges(b, c);
                    let want = cell_brdf(lo, hi, phi_k.to_radians(), 2.0);
                    // Not where the half vector is within 10 degrees of
                    // the normal (the specular direction; see above).
                    let wi = DVec3::new(
                        back.theta_i[k].sin() * back.phi_i[p].cos(),
                        back.theta_i[k].sin() * back.phi_i[p].sin(),
                        back.theta_i[k].cos(),
                    );
                    if (wi + wo).normalize().z > 10f64.to_radians().cos() || band > 22 {
                        continue;
                    }
                    let got = back.eval_cos(p * ni + k, wo)[0] / wo.z;
                    let off = (got - want).abs() / (C / PI);
                    worst = worst.max(off);
                    assert!(
                        off < 0.02,
                        "{azimuths:?} node {node} theta {} wo {wo}: {got} vs {want}",
                        back.theta_i[k].to_degrees()
                    );
                }
            }
        }
        eprintln!("{azimuths:?}: worst {worst:.4} of C/pi");
        let checks = roks::export::rgl::check(&tables, &bytes, "aniso.bsdf").unwrap();
        let keys: Vec<(f64, Option<f64>)> = checks[0]
            .iter()
            .map(|c| (c.theta_i_deg, c.phi_i_deg))
            .collect();
        let want: Vec<(f64, Option<f64>)> = [0.0, 30.0, 60.0]
            .iter()
            .flat_map(|&t| azimuths.iter().map(move |&a| (t, Some(a))))
            .collect();
        assert_eq!(keys, want);
        for c in &checks[0] {
            assert!((c.table / C - 1.0).abs() < 1e-9 && c.passes(), "{c:?}");
        }
    }
    let table = BrdfTable::parse(&csv(8, 2.0), "aniso.csv").unwrap();
    let e = Rgl::from_tables(&BrdfTables::Monochrome(table), &Ndf::uniform(), "x")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(layout::ACCEPTED) && e.contains("0, 90 deg"),
        "{e}"
    );
}

/// The symmetry a reduced RGL file assumes, judged from the table: the
/// synthetic BRDF that turns with the light (`s = 1`, isotropic: unchanged
/// by a half turn, and mirror symmetric about the plane of incidence)
/// passes both (chi^2/dof within the bound: the cells are exact, so 0 to
/// rounding); the one that does not (`s = 2`: `1 + 0.5 cos(phi - 2 phi_k)`)
/// fails both: at 180 its table is `1 + 0.5 cos(phi)`, the one at 0
/// turned is `1 - 0.5 cos(phi)`; at 90 it is `1 - 0.5 cos(phi)`, not
/// symmetric about the yz plane. The whole circle assumes nothing (no
/// cell compared).
#[test]
fn rgl_symmetry_figure_judges_the_assumption() {
    use roks::export::rgl::layout::{Reduction, symmetry_figure};
    let m = 16;
    for (azimuths, reduction) in [
        (&[0.0, 90.0, 180.0][..], Reduction::HalfTurn),
        (&[0.0, 45.0, 90.0], Reduction::Quadrant),
    ] {
        let iso = BrdfTable::parse(&csv_at(m, 1.0, azimuths), "iso.csv").unwrap();
        let aniso = BrdfTable::parse(&csv_at(m, 2.0, azimuths), "aniso.csv").unwrap();
        let f = symmetry_figure(&[&iso], reduction);
        assert!(
            f.dof > 100 && f.isotropic() && f.chi2_dof < 1e-6,
            "{reduction:?} {f:?}"
        );
        let f = symmetry_figure(&[&aniso], reduction);
        assert!(f.dof > 100 && !f.isotropic(), "{reduction:?} {f:?}");
        assert_eq!(symmetry_figure(&[&aniso], Reduction::Circle).dof, 0);
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-azimuths-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Through the binary: `roks export-brdf --format merl` of the anisotropic
/// folder prints one warning naming the anisotropy, of the isotropic folder
/// none (a note); `--format zemax` judges per incidence and azimuth (a
/// `phi_i` column, six rows) without a warning; `--format rgl` is refused
/// with status 2 and one line naming the table and `phi_i_deg`, writing
/// nothing.
#[test]
fn export_brdf_cli_of_several_azimuths() {
    let dir = scratch("cli");
    let folder = |name: &str, s_: f64| {
        let f = dir.join(name);
        std::fs::create_dir_all(&f).unwrap();
        std::fs::write(f.join("brdf.csv"), csv(8, s_)).unwrap();
        f
    };
    let (aniso, iso) = (folder("aniso", 2.0), folder("iso", 1.0));
    let run = |f: &Path, format: &str, out: &Path| {
        roks(&["export-brdf", s(f), "--format", format, "--out", s(out)])
    };
    let stderr = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).into_owned();
    let warnings = |e: &str| {
        e.lines()
            .filter(|l| l.starts_with("warning: "))
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    // The warnings about the azimuths (MERL's own resampling error at normal
    // incidence, about 1 %, may add one of its own).
    let azimuth_warnings = |e: &str| {
        warnings(e)
            .into_iter()
            .filter(|l| l.contains("light azimuths"))
            .collect::<Vec<_>>()
    };

    let o = run(&aniso, "merl", &dir.join("a.binary"));
    assert!(o.status.success(), "{}", stderr(&o));
    let w = azimuth_warnings(&stderr(&o));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("anisotropic") && w[0].contains("2 light azimuths (0, 90 deg)"),
        "{}",
        w[0]
    );

    let o = run(&iso, "merl", &dir.join("i.binary"));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(azimuth_warnings(&stderr(&o)).is_empty(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("note: merl: the table has 2 light azimuths"),
        "{}",
        stderr(&o)
    );

    let o = run(&aniso, "zemax", &dir.join("a.bsdf"));
    let e = stderr(&o);
    assert!(o.status.success() && warnings(&e).is_empty(), "{e}");
    assert!(e.contains("phi_i"), "{e}");
    let rows = e
        .lines()
        .filter(|l| {
            l.split_whitespace()
                .filter(|w| w.parse::<f64>().is_ok())
                .count()
                == 5
        })
        .count();
    assert_eq!(rows, 6, "{e}");
    assert!(
        std::fs::read_to_string(dir.join("a.bsdf"))
            .unwrap()
            .contains("Asymmetrical4D")
    );

    let out = dir.join("r.bsdf");
    let o = run(&aniso, "rgl", &out);
    cli_common::assert_input_error(
        "rgl of two azimuths",
        &o,
        &aniso.join("brdf.csv"),
        &out,
        &[
            "phi_i_deg",
            "light.phi_deg",
            "--phi",
            "0, 90 deg",
            "0 to 180",
        ],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `roks brdf --export rgl` (or pbsdf) of light azimuths that no file of
/// the format holds is refused before tracing: 10^12 photons would not
/// finish, and the child is killed after 20 seconds, which fails the test
/// (checked: with the refusal of rgl disabled the run is still tracing at
/// 20 s). One line naming `--export`, `light.phi_deg` and `--phi` (rgl:
/// and what is accepted), status 2, nothing written. Sets refused for rgl:
/// 0 and 90 (two nodes of a quadrant: the reader would take them as
/// isotropic), 0, 45, 135 (no domain), 30, 120, 210 (no 0 nor 180);
/// pbsdf refuses any two.
#[test]
fn several_azimuths_refused_before_tracing() {
    let dir = scratch("refuse");
    let out = dir.join("run");
    for (format, phi, extra) in [
        ("rgl", "0,90", None),
        ("rgl", "0,45,135", None),
        ("rgl", "30,120,210", None),
        ("pbsdf", "0,180", Some("mueller")),
    ] {
        let mut args = vec!["brdf", "--out", s(&out), "--phi", phi];
        args.extend(["--photons", "1000000000000", "--export", format]);
        if let Some(p) = extra {
            args.extend(["--polarisation", p]);
        }
        let o = roks_within(&args, 20)
            .unwrap_or_else(|| panic!("{format} {phi}: not refused within 20 s (tracing)"));
        let expect: Vec<String> = if format == "rgl" {
            vec![
                "--export rgl: light.phi_deg (--phi)".into(),
                format!("the light azimuths {} deg", phi.replace(',', ", ")),
                "0 to 90 (first 0, last 90, at least three".into(),
            ]
        } else {
            vec![
                "--export pbsdf: the table has 2 light azimuths".into(),
                "the pbsdf format holds phi_i = 0 only".into(),
            ]
        };
        let expect: Vec<&str> = expect.iter().map(String::as_str).collect();
        cli_common::assert_input_error(format, &o, Path::new("--export"), &out, &expect);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
