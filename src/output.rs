//! Result files, written atomically (a temporary file in the same folder, then
//! a rename), so a reader never sees half a file.
//!
//! `roks brdf` writes, in its output folder:
//! * `summary.json`: per incidence `theta_deg`, `phi_deg`, `photons`,
//!   `reflectance`, `reflectance_stderr`, `mean_bounces`, `lost`, `seconds`,
//!   `segments_per_second`, `intersection_tests` and `tests_per_segment`
//!   (quadrics, or height-field squares; and the breakdown of losses, reflectance by bounce
//!   count); `surface` statistics; the seed, scene file and roks version.
//! * `brdf.csv`: one row per incidence and Carlson cell (see [`BRDF_HEADER`]).
//! * `inplane.csv`: the in-plane BRDF, `theta_o_deg` signed (positive on the
//!   specular side, negative toward the light).
//! * `tallies.json` (with `--shard`, and from `roks merge`): the raw sums,
//!   exactly, for merging shards (see [`crate::shard`]).
//! * With `[tally] polarisation = "stokes"`: `stokes.csv` (see
//!   [`STOKES_HEADER`]) and `dop_<theta>deg.png`; with `"mueller"`:
//!   `mueller.csv` ([`MUELLER_HEADER`]). Frames: every outgoing direction's
//!   Stokes reference vector is `normalize(z × d)` (see
//!   [`crate::optics::polarisation`]), the incident one that of the incident
//!   flight (the s axis of the plane of incidence).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use serde_json::{Value, json};

use crate::micro::surface_stats::SurfaceStats;
use crate::optics::polarisation::degree_of_polarisation;
use crate::tally::{CarlsonGrid, InPlaneTally, PolarTally};
use crate::transport::brdf::{BrdfRun, IncidenceResult};

/// Columns of `brdf.csv`.
pub const BRDF_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,fraction,fraction_stderr,brdf,brdf_stderr";

/// Columns of `stokes.csv`: per incidence and Carlson cell, the Stokes BRDF
/// `s_i` (1/sr) of the reflected light for the incident state in the cell
/// direction's frame, with standard errors; `s0` equals `brdf` of
/// `brdf.csv`; `dop = sqrt(s1² + s2² + s3²) / s0` of the means (0 where
/// `s0 = 0`).
pub const STOKES_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,s0,s0_stderr,s1,s1_stderr,s2,s2_stderr,s3,s3_stderr,dop";

/// Columns of `mueller.csv`: per incidence and Carlson cell, the Mueller
/// matrix BRDF `m_ij` (1/sr, row = outgoing component `i`, column = incident
/// component `j`) with standard errors; `m00` is the BRDF for unpolarised light.
pub const MUELLER_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,m00,m00_stderr,m01,m01_stderr,m02,m02_stderr,m03,m03_stderr,m10,m10_stderr,m11,m11_stderr,m12,m12_stderr,m13,m13_stderr,m20,m20_stderr,m21,m21_stderr,m22,m22_stderr,m23,m23_stderr,m30,m30_stderr,m31,m31_stderr,m32,m32_stderr,m33,m33_stderr";

/// The polarisation table of a run with a polarisation tally: its file name
/// (`stokes.csv` or `mueller.csv`) and text; `None` without one.
#[must_use]
pub fn polar_csv(run: &BrdfRun, results: &[IncidenceResult]) -> Option<(&'static str, String)> {
    let (name, header) = match run.polarisation.tally {
        PolarTally::None => return None,
        PolarTally::Stokes => ("stokes.csv", STOKES_HEADER),
        PolarTally::Mueller => ("mueller.csv", MUELLER_HEADER),
    };
    let k = run.polarisation.tally.components();
    let grid: CarlsonGrid = run.grid();
    let mut s = String::with_capacity(40 * (k + 1) * grid.n_cells() * results.len());
    s.push_str(header);
    s.push('\n');
    for r in results {
        let Some(p) = &r.tallies.polar else {
            continue;
        };
        for flat in 0..grid.n_cells() {
            let (band, cell) = grid.band_cell(flat);
            let (theta, phi) = grid.centre(band, cell);
            let proj = grid.projected_solid_angle(band, cell);
            let _ = write!(
                s,
                "{},{},{band},{cell},{},{}",
                r.theta_i_deg,
                r.phi_i_deg,
                theta.to_degrees(),
                phi.to_degrees()
            );
            let mut means = [0.0; 16];
            for (i, m) in means.iter_mut().enumerate().take(k) {
                let (mean, se) = r.polar(p.cell_bin(flat, i)).unwrap_or_default();
                *m = mean / proj;
                let _ = write!(s, ",{:.9e},{:.9e}", mean / proj, se / proj);
            }
            if k == 4 {
                let _ = write!(
                    s,
                    ",{:.9e}",
                    degree_of_polarisation([means[0], means[1], means[2], means[3]])
                );
            }
            s.push('\n');
        }
    }
    Some((name, s))
}

/// Columns of `inplane.csv`.
pub const INPLANE_HEADER: &str = "theta_i_deg,theta_o_deg,brdf,brdf_stderr";

/// Write `bytes` to `path` atomically (temporary sibling `.NAME.PID.tmp`,
/// synced, then renamed over `path`): a reader sees the old file or the new
/// one. Temporary files of killed writes of `path` are removed first.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    crate::outdir::remove_stale_tmp(path);
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// `brdf.csv` for all incidences.
#[must_use]
pub fn brdf_csv(run: &BrdfRun, results: &[IncidenceResult]) -> String {
    let grid: CarlsonGrid = run.grid();
    let omega = grid.solid_angle();
    let mut s = String::with_capacity(200 * grid.n_cells() * results.len());
    s.push_str(BRDF_HEADER);
    s.push('\n');
    for r in results {
        let n = r.tallies.photons;
        for flat in 0..grid.n_cells() {
            let (band, cell) = grid.band_cell(flat);
            let (mu_bot, mu_top) = grid.mu_edges(band);
            let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
            let (theta, phi) = grid.centre(band, cell);
            let proj = grid.projected_solid_angle(band, cell);
            let f = r.tallies.carlson.mean(flat, n);
            let fe = r.carlson_stderr(flat);
            let _ = writeln!(
                s,
                "{},{},{band},{cell},{},{},{},{},{},{},{omega:.12e},{proj:.12e},{f:.9e},{fe:.9e},{:.9e},{:.9e}",
                r.theta_i_deg,
                r.phi_i_deg,
                mu_top.acos().to_degrees(),
                mu_bot.acos().to_degrees(),
                phi_lo.to_degrees(),
                phi_hi.to_degrees(),
                theta.to_degrees(),
                phi.to_degrees(),
                f / proj,
                fe / proj,
            );
        }
    }
    s
}

/// `inplane.csv` for all incidences.
#[must_use]
pub fn inplane_csv(run: &BrdfRun, results: &[IncidenceResult]) -> String {
    let tally: InPlaneTally = run.inplane();
    let mut s = String::new();
    s.push_str(INPLANE_HEADER);
    s.push('\n');
    for r in results {
        let n = r.tallies.photons;
        for bin in 0..tally.n_bins() {
            let proj = tally.projected_solid_angle(bin);
            let f = r.tallies.inplane.mean(bin, n);
            let fe = r.inplane_stderr(bin);
            let _ = writeln!(
                s,
                "{},{},{:.9e},{:.9e}",
                r.theta_i_deg,
                tally.centre_deg(bin),
                f / proj,
                fe / proj
            );
        }
    }
    s
}

/// Surface statistics as JSON. A statistic that is undefined for the map
/// (`tau` and `sigma_over_tau` of a flat surface, or of heights correlated
/// over more than half the cell) is `null`, and the object then has the key
/// `undefined` mapping each such statistic to the reason, e.g. `"tau":
/// "undefined for a flat surface (sigma = 0)"` (absent when every statistic
/// is a number).
#[must_use]
pub fn surface_json(stats: &SurfaceStats, resolution: usize) -> Value {
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let mut v = json!({
        "sigma": num(stats.sigma),
        "tau": num(stats.tau),
        "sigma_over_tau": num(stats.sigma_over_tau),
        "rms_slope": num(stats.rms_slope),
        "max_height": num(stats.max_height),
        "mean_height": num(stats.mean),
        "min_height": num(stats.min_height),
        "height_map_resolution": resolution,
    });
    if let (Some(why), Value::Object(m)) = (stats.tau_undefined, &mut v) {
        m.insert(
            "undefined".into(),
            json!({"tau": why.to_string(), "sigma_over_tau": format!("tau is {why}")}),
        );
    }
    v
}

/// One incidence's entry in `summary.json`.
#[must_use]
pub fn incidence_json(r: &IncidenceResult) -> Value {
    let t = &r.tallies;
    let (refl, refl_se) = r.reflectance();
    let n = t.photons as f64;
    let mut v = json!({
        "theta_deg": r.theta_i_deg,
        "phi_deg": r.phi_i_deg,
        "photons": t.photons,
        "reflectance": refl,
        "reflectance_stderr": refl_se,
        "mean_bounces": r.mean_bounces(),
        "lost": r.lost(),
        "lost_walls": t.lost_walls / n,
        "lost_cap": t.lost_cap / n,
        "lost_numeric": t.lost_numeric / n,
        "capped_photons": t.capped_histories,
        "numeric_guard_photons": t.numeric_histories,
        "reflectance_by_bounces": t.by_bounces.iter().map(|w| w / n).collect::<Vec<_>>(),
        "segments": t.segments,
        "intersection_tests": t.intersection_tests,
        "tests_per_segment": r.tests_per_segment(),
        "seconds": r.seconds,
        "segments_per_second": r.segments_per_second(),
    });
    if let (Some(p), Value::Object(m)) = (&t.polar, &mut v) {
        let key = if p.components == 4 {
            "reflected_stokes"
        } else {
            "reflected_mueller"
        };
        let pairs: Vec<(f64, f64)> = (0..p.components)
            .map(|i| r.polar(i).unwrap_or_default())
            .collect();
        m.insert(
            key.into(),
            json!(pairs.iter().map(|x| x.0).collect::<Vec<_>>()),
        );
        m.insert(
            format!("{key}_stderr"),
            json!(pairs.iter().map(|x| x.1).collect::<Vec<_>>()),
        );
    }
    v
}

/// `summary.json` of `roks brdf` (and `roks merge`): the run-level `fields`
/// plus `incidence` and the total `seconds`.
#[must_use]
pub fn brdf_summary(
    fields: &serde_json::Map<String, Value>,
    results: &[IncidenceResult],
    seconds: f64,
) -> Value {
    let mut m = fields.clone();
    m.insert(
        "incidence".into(),
        Value::Array(results.iter().map(incidence_json).collect()),
    );
    m.insert("seconds".into(), json!(seconds));
    Value::Object(m)
}

/// Columns of `reflectance.csv` (`roks trace`).
pub const REFLECTANCE_HEADER: &str = "x,y,z,reflectance,reflectance_stderr";

/// Columns of `farfield.csv` (`roks trace`): `brdf.csv`'s cell columns with
/// `source` first; bands `-1..-M` are the mirror images below the horizon
/// (theta measured from +z, 90-180 degrees there).
pub const FARFIELD_HEADER: &str = "source,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,fraction,fraction_stderr,brdf,brdf_stderr";

/// `reflectance.csv`: one row per beam position.
#[must_use]
pub fn reflectance_csv(results: &[crate::transport::object::PositionResult]) -> String {
    let mut s = String::from(REFLECTANCE_HEADER);
    s.push('\n');
    for r in results {
        let p = r.beam.position;
        let (refl, se) = r.reflectance();
        let _ = writeln!(s, "{},{},{},{refl:.9e},{se:.9e}", p.x, p.y, p.z);
    }
    s
}

/// Columns of `farfield_stokes.csv` (`roks trace` with `[tally]
/// polarisation = "stokes"`): `farfield.csv`'s cell columns, then the Stokes
/// components of the light leaving through the cell per projected solid
/// angle (1/sr; `s0` equals `farfield.csv`'s `brdf`) with standard errors,
/// and the degree of polarisation `dop`. Each photon's Stokes vector is
/// taken about `hemisphere_reference(dir, 0)` of its exit direction `dir`
/// ([`crate::transport::object::stokes_reference`]), above and below the horizon.
pub const FARFIELD_STOKES_HEADER: &str = "source,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,s0,s0_stderr,s1,s1_stderr,s2,s2_stderr,s3,s3_stderr,dop";

/// The rows of a far-field table: per beam position `k` and full-sphere cell
/// `flat`, `row(s, k, result, flat, projected solid angle)` appends the
/// columns after the cell's (`source` to `projected_solid_angle_sr`, with
/// the comma before them written) and the line end.
fn farfield_rows(
    header: &str,
    run: &crate::transport::object::ObjectRun,
    results: &[crate::transport::object::PositionResult],
    row: impl Fn(&mut String, &crate::transport::object::PositionResult, usize, f64),
) -> String {
    let grid = run.farfield_grid().grid;
    let half = grid.n_cells();
    let omega = grid.solid_angle();
    let mut s = String::from(header);
    s.push('\n');
    for (k, r) in results.iter().enumerate() {
        for flat in 0..2 * half {
            let lower = flat >= half;
            let (band, cell) = grid.band_cell(flat % half);
            let (mu_bot, mu_top) = grid.mu_edges(band);
            let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
            let (theta, phi) = grid.centre(band, cell);
            let (t_lo, t_hi, t_c) = if lower {
                (
                    180.0 - mu_bot.acos().to_degrees(),
                    180.0 - mu_top.acos().to_degrees(),
                    180.0 - theta.to_degrees(),
                )
            } else {
                (
                    mu_top.acos().to_degrees(),
                    mu_bot.acos().to_degrees(),
                    theta.to_degrees(),
                )
            };
            let band_label = if lower { -(band as i64) } else { band as i64 };
            let proj = grid.projected_solid_angle(band, cell);
            let _ = write!(
                s,
                "{k},{band_label},{cell},{t_lo},{t_hi},{},{},{t_c},{},{omega:.12e},{proj:.12e},",
                phi_lo.to_degrees(),
                phi_hi.to_degrees(),
                phi.to_degrees(),
            );
            row(&mut s, r, flat, proj);
            s.push('\n');
        }
    }
    s
}

/// `farfield.csv`: per beam position and cell of the full-sphere grid, the
/// share of the source's flux leaving through the cell; `brdf` is that share
/// per projected solid angle about the z axis (for a flat plate lit along
/// -omega_i this is the plate's BRDF, comparable with `brdf.csv`).
#[must_use]
pub fn farfield_csv(
    run: &crate::transport::object::ObjectRun,
    results: &[crate::transport::object::PositionResult],
) -> String {
    farfield_rows(FARFIELD_HEADER, run, results, |s, r, flat, proj| {
        let n = r.tallies.photons;
        let f = r.tallies.farfield.mean(flat, n);
        let fe = r.tallies.farfield.stderr(flat, n);
        let _ = write!(s, "{f:.9e},{fe:.9e},{:.9e},{:.9e}", f / proj, fe / proj);
    })
}

/// `farfield_stokes.csv` (see [`FARFIELD_STOKES_HEADER`]); the run must
/// have tallied it ([`crate::transport::object::ObjectRun::tallies_farfield_stokes`]).
#[must_use]
pub fn farfield_stokes_csv(
    run: &crate::transport::object::ObjectRun,
    results: &[crate::transport::object::PositionResult],
) -> String {
    farfield_rows(FARFIELD_STOKES_HEADER, run, results, |s, r, flat, proj| {
        let (acc, n) = (&r.tallies.farfield_stokes, r.tallies.photons);
        let stokes: [f64; 4] = std::array::from_fn(|j| acc.mean(4 * flat + j, n) / proj);
        for (j, v) in stokes.iter().enumerate() {
            let _ = write!(s, "{v:.9e},{:.9e},", acc.stderr(4 * flat + j, n) / proj);
        }
        let dop = crate::optics::polarisation::degree_of_polarisation(stokes);
        let _ = write!(s, "{dop:.9e}");
    })
}

/// One beam position's entry in `summary.json` of `roks trace`.
#[must_use]
pub fn position_json(
    r: &crate::transport::object::PositionResult,
    surface_names: &[String],
) -> Value {
    let t = &r.tallies;
    let n = t.photons as f64;
    let (refl, se) = r.reflectance();
    let absorbed: serde_json::Map<String, Value> = surface_names
        .iter()
        .enumerate()
        .filter(|(i, _)| t.absorbed.sum[*i] != 0.0)
        .map(|(i, name)| (name.clone(), json!(t.absorbed.mean(i, t.photons))))
        .collect();
    let absorbed_se: serde_json::Map<String, Value> = surface_names
        .iter()
        .enumerate()
        .filter(|(i, _)| t.absorbed.sum[*i] != 0.0)
        .map(|(i, name)| (name.clone(), json!(t.absorbed.stderr(i, t.photons))))
        .collect();
    let mut entry = json!({
        "position": r.beam.position.to_array(),
        "direction": r.beam.direction.to_array(),
        "diameter": r.beam.diameter,
        "photons": t.photons,
        "reflectance": refl,
        "reflectance_stderr": se,
        "missed": t.missed / n,
        "absorbed": absorbed,
        "absorbed_stderr": absorbed_se,
        "mean_bounces": t.bounces as f64 / n,
        "lost": t.lost / n,
        "segments": t.segments,
        "seconds": r.seconds,
    });
    if let (Some((stokes, stokes_se)), Value::Object(m)) = (r.stokes(), &mut entry) {
        m.insert("stokes".into(), json!(stokes));
        m.insert("stokes_stderr".into(), json!(stokes_se));
        m.insert("polarisation".into(), json!(r.beam.polarisation.name()));
    }
    entry
}

/// The BRDF of one incidence of a run as an equal-area hemisphere map
/// (`hemisphere_<theta>deg.png`).
#[must_use]
pub fn hemisphere_map(
    name: &str,
    run: &BrdfRun,
    r: &IncidenceResult,
) -> crate::plot::HemisphereMap {
    let grid = run.grid();
    let n = r.tallies.photons;
    let brdf = (0..grid.n_cells())
        .map(|flat| {
            let (band, cell) = grid.band_cell(flat);
            r.tallies.carlson.mean(flat, n) / grid.projected_solid_angle(band, cell)
        })
        .collect();
    crate::plot::HemisphereMap {
        title: format!(
            "{name}: BRDF at incidence θi = {}° ({} photons)",
            r.theta_i_deg, n
        ),
        grid,
        brdf,
        scale: crate::plot::MapScale::LogBrdf,
        theta_i_deg: r.theta_i_deg,
        phi_i_deg: r.phi_i_deg,
    }
}

/// The degree of polarisation of the reflected light per Carlson cell of
/// one incidence of a run with a Stokes tally (`dop_<theta>deg.png`), on a
/// linear scale from 0 to 1; cells without light show 0. `None` without a
/// Stokes tally.
#[must_use]
pub fn dop_map(
    name: &str,
    run: &BrdfRun,
    r: &IncidenceResult,
) -> Option<crate::plot::HemisphereMap> {
    let p = r.tallies.polar.as_ref().filter(|p| p.components == 4)?;
    let grid = run.grid();
    let dop = (0..grid.n_cells())
        .map(|flat| {
            let s: [f64; 4] =
                std::array::from_fn(|i| r.polar(p.cell_bin(flat, i)).unwrap_or_default().0);
            degree_of_polarisation(s)
        })
        .collect();
    Some(crate::plot::HemisphereMap {
        title: format!(
            "{name}: degree of polarisation at θi = {}° ({}, {} photons)",
            r.theta_i_deg,
            run.polarisation.incident.name(),
            r.tallies.photons
        ),
        grid,
        brdf: dop,
        scale: crate::plot::MapScale::Linear {
            label: "degree of polarisation".into(),
            lo: 0.0,
            hi: 1.0,
        },
        theta_i_deg: r.theta_i_deg,
        phi_i_deg: r.phi_i_deg,
    })
}

/// File name of the degree-of-polarisation map of incidence `theta_i_deg`.
#[must_use]
pub fn dop_file(theta_i_deg: f64) -> String {
    format!("dop_{theta_i_deg}deg.png")
}

/// File name of the hemisphere map of incidence `theta_i_deg`.
#[must_use]
pub fn hemisphere_file(theta_i_deg: f64) -> String {
    format!("hemisphere_{theta_i_deg}deg.png")
}

/// The in-plane BRDF curves of a run as a plot (`inplane.png`): one curve
/// per incidence angle, log BRDF vs signed theta_o, 2-sigma error bars.
#[must_use]
pub fn inplane_plot(
    name: &str,
    run: &BrdfRun,
    results: &[IncidenceResult],
) -> crate::plot::LinePlot {
    use crate::plot::{LinePlot, Series};
    let tally: InPlaneTally = run.inplane();
    let series = results
        .iter()
        .map(|r| {
            let n = r.tallies.photons;
            let points = (0..tally.n_bins())
                .map(|bin| {
                    let proj = tally.projected_solid_angle(bin);
                    (
                        tally.centre_deg(bin),
                        r.tallies.inplane.mean(bin, n) / proj,
                        2.0 * r.inplane_stderr(bin) / proj,
                    )
                })
                .collect();
            Series {
                label: format!("theta_i = {} deg", r.theta_i_deg),
                points,
            }
        })
        .collect();
    LinePlot {
        title: format!(
            "{name}: BRDF in the plane of incidence ({} photons per angle)",
            run.photons
        ),
        x_label: "theta_o (deg): negative toward the light, positive on the specular side".into(),
        y_label: "BRDF (1/sr), error bars 2 standard errors".into(),
        log_y: true,
        series,
    }
}
