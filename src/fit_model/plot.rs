//! The plot of a fit: the table's BRDF and the model's, cell by cell, in
//! the plane of incidence (top) and across it through the specular
//! direction (bottom), for up to three incidences (the first, middle and
//! last, [`shown`]; the titles name them and those left out). Each
//! incidence has one colour: its table as points with error bars, the
//! model fitted to it as a line.

use glam::DVec3;

use super::{CellRule, FitResult, Model};
use crate::optics::brdf_table::BrdfTable;
use crate::plot::{LinePlot, Mark, Series};

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

/// The incidences a fit's plot shows, as indices into the `n` fitted
/// (in increasing order): all of up to three, else the first, the middle
/// and the last.
#[must_use]
pub fn shown(n: usize) -> Vec<usize> {
    if n <= 3 {
        (0..n).collect()
    } else {
        (0..3).map(|k| k * (n - 1) / 2).collect()
    }
}

/// What the titles say of the incidences shown (`thetas`: every fitted
/// incidence angle in degrees, in order; `shown`: the indices drawn).
fn shown_text(thetas: &[f64], shown: &[usize]) -> String {
    let list = |ks: &mut dyn Iterator<Item = usize>| {
        ks.map(|k| format!("{}°", thetas[k]))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let drawn = list(&mut shown.iter().copied());
    if shown.len() == thetas.len() {
        format!("θi = {drawn}")
    } else {
        let left = list(&mut (0..thetas.len()).filter(|k| !shown.contains(k)));
        format!(
            "θi = {drawn} of the {} fitted; not shown: {left}",
            thetas.len()
        )
    }
}

/// The two plots of `fits` of `model` to `table` (`title` first in their
/// titles): in the plane of incidence and across it. Per incidence shown
/// (the `k`-th), the table (points with error bars) and the model (a
/// line) in the same colour, palette index `k`.
#[must_use]
pub fn plots(
    table: &BrdfTable,
    model: &dyn Model,
    fits: &[FitResult],
    title: &str,
) -> [LinePlot; 2] {
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
    let picked = shown(all.len());
    let thetas: Vec<f64> = all
        .iter()
        .map(|&(i, _)| table.incidence(i).theta_deg)
        .collect();
    let which = shown_text(&thetas, &picked);
    let chosen: Vec<(usize, &[f64])> = picked.iter().map(|&k| all[k]).collect();
    let half = std::f64::consts::FRAC_PI_2 * (1.0 - 1e-9);
    let cut = |across: bool| {
        let mut series = Vec::new();
        for (k, &(i, q)) in chosen.iter().enumerate() {
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
                model_pts.push((x, rule.model_average(model, q, t), 0.0));
            }
            series.push(Series {
                colour: Some(k),
                mark: Mark::Points,
                ..Series::new(format!("table, θi = {}°", inc.theta_deg), table_pts)
            });
            series.push(Series {
                colour: Some(k),
                mark: Mark::Line,
                ..Series::new(format!("fit, θi = {}°", inc.theta_deg), model_pts)
            });
        }
        series
    };
    [
        LinePlot {
            title: format!("{title}: plane of incidence ({which})"),
            x_label: "theta_o (deg, + on the specular side)".into(),
            y_label: "BRDF (1/sr)".into(),
            log_y: true,
            series: cut(false),
            grid: None,
        },
        LinePlot {
            title: format!("{title}: across it, through the specular direction ({which})"),
            x_label: "angle from the specular direction across the plane of incidence (deg)".into(),
            y_label: "BRDF (1/sr)".into(),
            log_y: true,
            series: cut(true),
            grid: None,
        },
    ]
}

/// PNG bytes of the plot of `fits` of `model` to `table` (`title` on top):
/// [`plots`] one above the other.
///
/// # Errors
/// If plotting fails.
pub fn png(
    table: &BrdfTable,
    model: &dyn Model,
    fits: &[FitResult],
    title: &str,
) -> anyhow::Result<Vec<u8>> {
    let [top, bottom] = plots(table, model, fits, title);
    let top = top.to_png(900, 520)?;
    let bottom = bottom.to_png(900, 520)?;
    let a = image::load_from_memory(&top)?.to_rgb8();
    let b = image::load_from_memory(&bottom)?.to_rgb8();
    let mut both = image::RgbImage::new(a.width(), a.height() + b.height());
    image::imageops::replace(&mut both, &a, 0, 0);
    image::imageops::replace(&mut both, &b, 0, i64::from(a.height()));
    let mut bytes = std::io::Cursor::new(Vec::new());
    both.write_to(&mut bytes, image::ImageFormat::Png)?;
    Ok(crate::outdir::kind::mark_png(bytes.into_inner()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tally::CarlsonGrid;

    /// Which incidences are drawn, and the titles say so.
    #[test]
    fn the_titles_name_the_incidences_shown() {
        assert_eq!(shown(2), [0, 1]);
        assert_eq!(shown(3), [0, 1, 2]);
        assert_eq!(shown(5), [0, 2, 4]);
        assert_eq!(shown(4), [0, 1, 3]);
        let t = [0.0, 20.0, 40.0, 60.0, 80.0];
        assert_eq!(
            shown_text(&t, &shown(5)),
            "θi = 0°, 40°, 80° of the 5 fitted; not shown: 20°, 60°"
        );
        assert_eq!(shown_text(&t[..2], &shown(2)), "θi = 0°, 20°");
    }

    /// An ABg fit to a table of five incidences: three drawn, each table
    /// (points with error bars) and its fitted model (a line) in one
    /// colour, the three colours distinct; the titles say which; the PNG
    /// decodes at 900 x 1040.
    #[test]
    fn each_fit_has_the_colour_of_its_table() {
        let thetas = [0.0, 20.0, 40.0, 60.0, 80.0];
        let truth = [0.01f64.ln(), 0.004f64.ln(), 1.7];
        let blocks = super::super::synthetic(
            &super::super::abg::Abg,
            |_| truth.to_vec(),
            &thetas,
            8,
            0.03,
            5,
        );
        let table = BrdfTable::from_blocks(CarlsonGrid::new(8).unwrap(), blocks, "s").unwrap();
        let obs = super::super::observations(&table, None);
        let fits = super::super::abg::fit(&table, &obs).unwrap();
        for plot in plots(&table, &super::super::abg::Abg, &fits, "ABg") {
            assert!(
                plot.title
                    .ends_with("(θi = 0°, 40°, 80° of the 5 fitted; not shown: 20°, 60°)"),
                "{}",
                plot.title
            );
            assert_eq!(plot.series.len(), 6);
            let mut colours = Vec::new();
            for (k, pair) in plot.series.chunks(2).enumerate() {
                let theta = thetas[2 * k];
                assert_eq!(pair[0].label, format!("table, θi = {theta}°"));
                assert_eq!(pair[1].label, format!("fit, θi = {theta}°"));
                assert_eq!((pair[0].mark, pair[1].mark), (Mark::Points, Mark::Line));
                let (a, b) = (plot.series_colour(2 * k), plot.series_colour(2 * k + 1));
                assert_eq!(a, b, "{theta}");
                colours.push(a);
            }
            assert!(
                colours[0] != colours[1] && colours[1] != colours[2] && colours[0] != colours[2]
            );
        }
        let png = png(&table, &super::super::abg::Abg, &fits, "ABg").unwrap();
        let img = image::load_from_memory(&png).unwrap();
        assert_eq!((img.width(), img.height()), (900, 1040));
    }
}
