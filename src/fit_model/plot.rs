//! The plot of a fit: the table's BRDF and the model's, cell by cell, in
//! the plane of incidence (top) and across it through the specular
//! direction (bottom), for up to three incidences (the first, middle and
//! last: six curves, six colours of the palette).

use glam::DVec3;

use super::{CellRule, FitResult, Model};
use crate::optics::brdf_table::BrdfTable;
use crate::plot::{LinePlot, Series};

/// Samples along each cut (one per 0.25 degree).
const SAMPLES: usize = 712;

/// The cells a cut through `dirs` (local frame of an incidence at light
/// azimuth `phi_i`, radians) crosses, in order, each with the mean of the
/// cut's coordinate `x` (degrees) over its samples.
fn cut_cells(
    table: &BrdfTable,
    phi_i: f64,
    dirs: impl Iterator<Item = (f64, DVec3)>,
) -> Vec<(usize, f64)> {
    let (s, c) = phi_i.sin_cos();
    let mut out: Vec<(usize, f64, usize)> = Vec::new();
    for (x, d) in dirs {
        let abs = DVec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z);
        let Some(flat) = table.grid().locate(abs) else {
            continue;
        };
        match out.last_mut() {
            Some(last) if last.0 == flat => {
                last.1 += x;
                last.2 += 1;
            }
            _ => out.push((flat, x, 1)),
        }
    }
    out.into_iter().map(|(f, x, n)| (f, x / n as f64)).collect()
}

/// PNG bytes of the plot of `fits` of `model` to `table` (`title` on top).
///
/// # Errors
/// If plotting fails.
pub fn png(
    table: &BrdfTable,
    model: &dyn Model,
    fits: &[FitResult],
    title: &str,
) -> anyhow::Result<Vec<u8>> {
    // (incidence, internal parameters) of every incidence fitted.
    let mut all: Vec<(usize, &[f64])> = fits
        .iter()
        .flat_map(|f| {
            f.incidences
                .iter()
                .map(move |&i| (i, f.internal.as_slice()))
        })
        .collect();
    all.sort_by_key(|p| p.0);
    let n = all.len();
    let chosen: Vec<(usize, &[f64])> = if n <= 3 {
        all
    } else {
        (0..3).map(|k| all[k * (n - 1) / 2]).collect()
    };
    let half = std::f64::consts::FRAC_PI_2 * (1.0 - 1e-9);
    let cut = |across: bool| {
        let mut series = Vec::new();
        for &(i, q) in &chosen {
            let inc = table.incidence(i);
            let (t, phi_i) = (inc.theta_deg.to_radians(), inc.phi_i_deg.to_radians());
            let spec = DVec3::new(-t.sin(), 0.0, t.cos());
            let dirs = (0..SAMPLES).map(|k| {
                let a = -half + 2.0 * half * k as f64 / (SAMPLES - 1) as f64;
                let d = if across {
                    spec * a.cos() + DVec3::Y * a.sin()
                } else {
                    // Signed angle from the normal, positive on the specular side.
                    DVec3::new(-a.sin(), 0.0, a.cos())
                };
                (a.to_degrees(), d)
            });
            let cells = cut_cells(table, phi_i, dirs);
            let grid = table.grid();
            let mut table_pts = Vec::new();
            let mut model_pts = Vec::new();
            for (flat, x) in cells {
                let (band, cell) = grid.band_cell(flat);
                let proj = grid.projected_solid_angle(band, cell);
                let f = table.fractions(i)[flat] / proj;
                let e = table.fraction_stderrs(i)[flat] / proj;
                table_pts.push((x, f, e));
                let rule = CellRule::new(grid, flat, phi_i);
                model_pts.push((x, rule.average(|d| model.brdf(q, t, d)), 0.0));
            }
            series.push(Series {
                label: format!("table {} deg", inc.theta_deg),
                points: table_pts,
            });
            series.push(Series {
                label: format!("fit {} deg", inc.theta_deg),
                points: model_pts,
            });
        }
        series
    };
    let top = LinePlot {
        title: format!("{title}: plane of incidence"),
        x_label: "theta_o (deg, + on the specular side)".into(),
        y_label: "BRDF (1/sr)".into(),
        log_y: true,
        series: cut(false),
    }
    .to_png(900, 520)?;
    let bottom = LinePlot {
        title: format!("{title}: across it, through the specular direction"),
        x_label: "angle from the specular direction across the plane of incidence (deg)".into(),
        y_label: "BRDF (1/sr)".into(),
        log_y: true,
        series: cut(true),
    }
    .to_png(900, 520)?;
    let a = image::load_from_memory(&top)?.to_rgb8();
    let b = image::load_from_memory(&bottom)?.to_rgb8();
    let mut both = image::RgbImage::new(a.width(), a.height() + b.height());
    image::imageops::replace(&mut both, &a, 0, 0);
    image::imageops::replace(&mut both, &b, 0, i64::from(a.height()));
    let mut bytes = std::io::Cursor::new(Vec::new());
    both.write_to(&mut bytes, image::ImageFormat::Png)?;
    Ok(crate::outdir::kind::mark_png(bytes.into_inner()))
}
