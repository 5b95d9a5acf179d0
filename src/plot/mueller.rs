//! The Mueller matrix of a BRDF over the hemisphere ([`MuellerMaps`],
//! `mueller_<theta>deg.png` and `mueller_stderr_<theta>deg.png`): a 4 x 4
//! grid of equal-area maps, one per element.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::hemisphere::{NO_VALUE, paint_disc, viridis};
use super::{TickFormat, encode_png, register_font, ticks};
use crate::tally::CarlsonGrid;

/// Picture size and layout (pixels).
const W: u32 = 1100;
const H: u32 = 1060;
const PANEL: i32 = 240;
/// The standard errors' picture: taller, a scale bar under each disc.
const H_ERRORS: u32 = 1180;
const ROW_ERRORS: i32 = 270;
/// The scale bar under a disc of the standard errors: its width and
/// height, and its top below the disc's bottom (pixels).
const PANEL_BAR: (i32, i32, i32) = (160, 10, 8);
const TOP: i32 = 90;
const LEFT: i32 = 20;
const R: f64 = 100.0;
const BAR_X: i32 = 1000;
const BAR: (i32, i32) = (200, 800);

/// ColorBrewer's RdBu, 11 stops from blue (lowest) to red (highest).
const DIVERGING: [[u8; 3]; 11] = [
    [5, 48, 97],
    [33, 102, 172],
    [67, 147, 195],
    [146, 197, 222],
    [209, 229, 240],
    [247, 247, 247],
    [253, 219, 199],
    [244, 165, 130],
    [214, 96, 77],
    [178, 24, 43],
    [103, 0, 31],
];

/// The diverging colour at `t` in `[0, 1]` (0.5 the middle, white).
#[must_use]
pub fn diverging(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.5 } else { t.clamp(0.0, 1.0) } * 10.0;
    let k = (t.floor() as usize).min(9);
    let w = t - k as f64;
    let (a, b) = (DIVERGING[k], DIVERGING[k + 1]);
    std::array::from_fn(|i| {
        (f64::from(a[i]) + w * (f64::from(b[i]) - f64::from(a[i]))).round() as u8
    })
}

/// What the panels show.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MuellerKind {
    /// `m_ij / m00` on a diverging scale symmetric about 0 over the largest
    /// magnitude; the `m00` panel the BRDF on a log scale (4 decades).
    Normalised,
    /// The standard errors of `m_ij / m00`, and in the `m00` panel its
    /// relative standard error, each panel on its own linear scale from 0
    /// ([`MuellerMaps::panel_range`]) with its own bar: errors differ by
    /// element, and a shared scale left most panels one colour.
    Errors,
}

/// The 16 elements of a Mueller-matrix BRDF over the hemisphere: panel
/// `(i, j)` (row `i` = outgoing Stokes component, column `j` = incident)
/// is the equal-area map of `values[4 i + j]` per Carlson cell (the
/// projection of [`super::HemisphereMap`]; the specular direction marked).
/// Cells without light (`m00 = 0`: NaN) are striped in [`NO_VALUE`] with a
/// key.
#[derive(Debug, Clone)]
pub struct MuellerMaps {
    /// Title (top line).
    pub title: String,
    /// The cells' grid.
    pub grid: CarlsonGrid,
    /// Per element (row-major), per flat cell.
    pub values: Vec<Vec<f64>>,
    /// What the values are.
    pub kind: MuellerKind,
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
}

impl MuellerMaps {
    /// The shared scale `(lo, hi)` of the 15 normalised panels: symmetric
    /// about 0 over their largest magnitude; or of the errors: from 0 to the
    /// 98th percentile of the 15 normalised elements' errors (the errors'
    /// panels are drawn each on its own scale, [`Self::panel_range`]).
    #[must_use]
    pub fn range(&self) -> (f64, f64) {
        let mut v: Vec<f64> = self.values[1..]
            .iter()
            .flatten()
            .filter(|v| v.is_finite())
            .map(|v| v.abs())
            .collect();
        let top = match self.kind {
            MuellerKind::Normalised => v.iter().copied().fold(0.0_f64, f64::max),
            MuellerKind::Errors if v.is_empty() => 0.0,
            MuellerKind::Errors => {
                let k = ((v.len() - 1) as f64 * 0.98).round() as usize;
                *v.select_nth_unstable_by(k, f64::total_cmp).1
            }
        };
        let top = if top > 0.0 { top } else { 1.0 };
        match self.kind {
            MuellerKind::Normalised => (-top, top),
            MuellerKind::Errors => (0.0, top),
        }
    }

    /// The scale `(lo, hi)` of panel `k` (element `k`, row-major): of
    /// the normalised elements the shared [`Self::range`]; of the errors
    /// the panel's own, from 0 to the 98th percentile of its values (a few
    /// cells of two or three photons would otherwise darken every other;
    /// larger errors take the top colour, as its bar says), `(0, 1)` when
    /// they are all 0 or none has a value.
    #[must_use]
    pub fn panel_range(&self, k: usize) -> (f64, f64) {
        if self.kind == MuellerKind::Normalised {
            return self.range();
        }
        let mut v: Vec<f64> = self.values[k]
            .iter()
            .filter(|v| v.is_finite())
            .map(|v| v.abs())
            .collect();
        let top = if v.is_empty() {
            0.0
        } else {
            let at = ((v.len() - 1) as f64 * 0.98).round() as usize;
            *v.select_nth_unstable_by(at, f64::total_cmp).1
        };
        (0.0, if top > 0.0 { top } else { 1.0 })
    }

    /// The largest value of panel `k` (`None`: no value).
    fn panel_max(&self, k: usize) -> Option<f64> {
        self.values[k]
            .iter()
            .filter(|v| v.is_finite())
            .map(|v| v.abs())
            .reduce(f64::max)
    }

    /// The label of the top of panel `k`'s bar: its top, three significant
    /// digits, with the panel's largest value when that is above it
    /// (`0.172 (max 0.654)`); `every value 0` when they all are.
    #[must_use]
    pub fn panel_top_label(&self, k: usize) -> String {
        let Some(max) = self.panel_max(k) else {
            return "no value".into();
        };
        if max == 0.0 {
            return "every value 0".into();
        }
        let (_, top) = self.panel_range(k);
        if max > top {
            format!("{} (max {})", significant(top), significant(max))
        } else {
            significant(top)
        }
    }

    /// The picture's height (pixels).
    fn height(&self) -> u32 {
        match self.kind {
            MuellerKind::Normalised => H,
            MuellerKind::Errors => H_ERRORS,
        }
    }

    /// The colour of every cell of element `k` (`None`: no value).
    fn colours(&self, k: usize) -> Vec<Option<[u8; 3]>> {
        let (lo, hi) = self.panel_range(k);
        if k == 0 && self.kind == MuellerKind::Normalised {
            let top = self.values[0]
                .iter()
                .filter(|v| v.is_finite())
                .fold(0.0_f64, |m, &v| m.max(v));
            let (l1, l0) = (top.log10(), top.log10() - 4.0);
            return self.values[0]
                .iter()
                .map(|&v| (v.is_finite() && v > 0.0).then(|| viridis((v.log10() - l0) / (l1 - l0))))
                .collect();
        }
        self.values[k]
            .iter()
            .map(|&v| {
                v.is_finite().then(|| match self.kind {
                    MuellerKind::Normalised => diverging((v - lo) / (hi - lo)),
                    MuellerKind::Errors => viridis((v - lo) / (hi - lo)),
                })
            })
            .collect()
    }

    /// Centre of panel `(i, j)` (pixels).
    fn centre(&self, i: usize, j: usize) -> (f64, f64) {
        let row = match self.kind {
            MuellerKind::Normalised => PANEL,
            MuellerKind::Errors => ROW_ERRORS,
        };
        (
            f64::from(LEFT + PANEL * j as i32 + PANEL / 2),
            f64::from(TOP + row * i as i32 + PANEL / 2 + 8),
        )
    }

    /// The scale bar under panel `k` of the errors: `(x0, y0, x1, y1)`,
    /// pixels, inclusive.
    fn panel_bar(&self, k: usize) -> (i32, i32, i32, i32) {
        let (cx, cy) = self.centre(k / 4, k % 4);
        let (w, h, below) = PANEL_BAR;
        let (x0, y0) = (cx as i32 - w / 2, (cy + R) as i32 + below);
        (x0, y0, x0 + w, y0 + h)
    }

    /// Render to PNG bytes (1100 x 1060 pixels; the errors 1100 x 1180).
    ///
    /// # Errors
    /// If drawing or encoding fails.
    pub fn to_png(&self) -> anyhow::Result<Vec<u8>> {
        register_font();
        let h = self.height();
        let mut buf = vec![255u8; (W * h * 3) as usize];
        let mut empty = false;
        for k in 0..16 {
            let c = self.colours(k);
            empty |= c.iter().any(Option::is_none);
            let (cx, cy) = self.centre(k / 4, k % 4);
            paint_disc(&mut buf, W, (cx, cy, R), &self.grid, &c);
            if self.kind == MuellerKind::Errors {
                let (x0, y0, x1, y1) = self.panel_bar(k);
                for x in x0..=x1 {
                    let c = viridis(f64::from(x - x0) / f64::from(x1 - x0));
                    for y in y0..=y1 {
                        let at = 3 * (y as u32 * W + x as u32) as usize;
                        buf[at..at + 3].copy_from_slice(&c);
                    }
                }
            }
        }
        for y in BAR.0..=BAR.1 {
            if self.kind == MuellerKind::Errors {
                // Each panel has its own bar.
                break;
            }
            let t = f64::from(BAR.1 - y) / f64::from(BAR.1 - BAR.0);
            let c = match self.kind {
                MuellerKind::Normalised => diverging(t),
                MuellerKind::Errors => viridis(t),
            };
            for x in BAR_X..BAR_X + 24 {
                let at = 3 * (y as u32 * W + x as u32) as usize;
                buf[at..at + 3].copy_from_slice(&c);
            }
        }
        if empty {
            for y in BAR.1 + 40..BAR.1 + 62 {
                for x in BAR_X..BAR_X + 22 {
                    let at = 3 * (y as u32 * W + x as u32) as usize;
                    buf[at..at + 3].copy_from_slice(&NO_VALUE[(((x + y) / 4) % 2) as usize]);
                }
            }
        }
        self.overlay(&mut buf, empty)
            .map_err(|e| anyhow::anyhow!("Mueller maps: {e}"))?;
        encode_png(W, h, buf)
    }

    fn overlay(&self, buf: &mut [u8], empty: bool) -> Result<(), super::DrawError> {
        let root = BitMapBackend::with_buffer(buf, (W, self.height())).into_drawing_area();
        self.draw_heading(&root)?;
        self.draw_panel_frames(&root)?;
        self.draw_colour_bar(&root, empty)?;
        root.present()?;
        Ok(())
    }

    /// The title and, below it, what the panels show.
    fn draw_heading(&self, root: &Root<'_>) -> Result<(), super::DrawError> {
        let title = super::title_lines(&self.title, 110);
        for (k, l) in title.iter().enumerate() {
            root.draw(&Text::new(
                l.clone(),
                (W as i32 / 2, 16 + 18 * k as i32),
                text(if k == 0 { 17 } else { 14 }, HPos::Center),
            ))?;
        }
        let below = 40 + 12 * (title.len() as i32 - 1);
        let note = match self.kind {
            MuellerKind::Normalised => {
                "row i: outgoing Stokes component, column j: incident; panels m_ij / m00, m00 itself: BRDF (1/sr, log, 4 decades)"
            }
            MuellerKind::Errors => {
                "standard errors of m_ij / m00 (from each element's covariance with m00); m00 panel: relative error of m00; each panel on its own linear scale (its bar)"
            }
        };
        root.draw(&Text::new(
            note,
            (W as i32 / 2, below),
            text(13, HPos::Center),
        ))?;
        root.draw(&Text::new(
            format!(
                "each disc: the hemisphere in equal-area projection, φ = 0 to the right; ring: specular direction (θi = {}°)",
                self.theta_i_deg
            ),
            (W as i32 / 2, below + 17),
            text(13, HPos::Center),
        ))?;
        Ok(())
    }

    /// Each of the 16 panels' outline, name and ring at the specular
    /// direction.
    fn draw_panel_frames(&self, root: &Root<'_>) -> Result<(), super::DrawError> {
        let spec_theta = self.theta_i_deg.to_radians();
        let rho = R * super::hemisphere::equal_area_radius(spec_theta);
        let (s, c) = (self.phi_i_deg + 180.0).to_radians().sin_cos();
        for k in 0..16 {
            let (i, j) = (k / 4, k % 4);
            let (cx, cy) = self.centre(i, j);
            root.draw(&Circle::new(
                (cx.round() as i32, cy.round() as i32),
                R as i32,
                BLACK.stroke_width(1),
            ))?;
            let name = if k == 0 && self.kind == MuellerKind::Normalised {
                "m00 (1/sr)".to_owned()
            } else if k == 0 {
                "m00: relative error".to_owned()
            } else {
                format!("m{i}{j} / m00")
            };
            root.draw(&Text::new(
                name,
                (cx.round() as i32, (cy - R - 12.0).round() as i32),
                text(14, HPos::Center),
            ))?;
            let spec = ((cx + rho * c).round() as i32, (cy - rho * s).round() as i32);
            root.draw(&Circle::new(spec, 7, BLACK.stroke_width(3)))?;
            root.draw(&Circle::new(spec, 7, WHITE.stroke_width(1)))?;
        }
        Ok(())
    }

    /// The colour bar's frame, labels and ticks (of the errors: each
    /// panel's, [`Self::draw_panel_bars`]), and (`empty`: some cell has no
    /// light) the key of the cells without a value.
    fn draw_colour_bar(&self, root: &Root<'_>, empty: bool) -> Result<(), super::DrawError> {
        if self.kind == MuellerKind::Errors {
            return self.draw_panel_bars(root, empty);
        }
        root.draw(&Rectangle::new(
            [(BAR_X - 1, BAR.0 - 1), (BAR_X + 24, BAR.1 + 1)],
            BLACK.stroke_width(1),
        ))?;
        let label = "m_ij / m00";
        root.draw(&Text::new(
            label,
            (BAR_X + 12, BAR.0 - 28),
            text(14, HPos::Center),
        ))?;
        root.draw(&Text::new(
            "linear scale",
            (BAR_X + 12, BAR.0 - 12),
            text(12, HPos::Center),
        ))?;
        let (lo, hi) = self.range();
        let t: Vec<f64> = ticks(lo, hi, 8)
            .into_iter()
            .filter(|v| (lo..=hi).contains(v))
            .collect();
        let f = TickFormat::for_ticks(&t, false);
        for v in t {
            let y = BAR.1 - ((v - lo) / (hi - lo) * f64::from(BAR.1 - BAR.0)).round() as i32;
            root.draw(&PathElement::new(
                vec![(BAR_X + 24, y), (BAR_X + 30, y)],
                BLACK.stroke_width(1),
            ))?;
            root.draw(&Text::new(
                f.label(v),
                (BAR_X + 33, y),
                text(13, HPos::Left),
            ))?;
        }
        if empty {
            draw_no_light_key(root)?;
        }
        Ok(())
    }

    /// The errors' scales: under each panel its bar's frame and its ends'
    /// labels (0 and the panel's top, with the panel's largest value when
    /// above it); beside the grid what the bars are, and (`empty`) the key
    /// of the cells without a value.
    fn draw_panel_bars(&self, root: &Root<'_>, empty: bool) -> Result<(), super::DrawError> {
        for k in 0..16 {
            let (x0, y0, x1, y1) = self.panel_bar(k);
            root.draw(&Rectangle::new(
                [(x0 - 1, y0 - 1), (x1 + 1, y1 + 1)],
                BLACK.stroke_width(1),
            ))?;
            let y = y1 + 11;
            root.draw(&Text::new("0", (x0, y), text(12, HPos::Left)))?;
            root.draw(&Text::new(
                self.panel_top_label(k),
                (x1, y),
                text(12, HPos::Right),
            ))?;
        }
        let lines = [
            (14, "standard error"),
            (12, "linear scale,"),
            (12, "each panel its"),
            (12, "own (its bar):"),
            (12, "0 to its 98th"),
            (12, "percentile; larger"),
            (12, "errors in the"),
            (12, "top colour"),
        ];
        for (k, (size, l)) in lines.iter().enumerate() {
            root.draw(&Text::new(
                *l,
                (BAR_X + 12, BAR.0 + 16 * k as i32),
                text(*size, HPos::Center),
            ))?;
        }
        if empty {
            draw_no_light_key(root)?;
        }
        Ok(())
    }
}

/// The key of the cells without a value (its stripes painted by
/// [`MuellerMaps::to_png`]).
fn draw_no_light_key(root: &Root<'_>) -> Result<(), super::DrawError> {
    root.draw(&Rectangle::new(
        [(BAR_X - 1, BAR.1 + 39), (BAR_X + 22, BAR.1 + 62)],
        BLACK.stroke_width(1),
    ))?;
    root.draw(&Text::new(
        "no light:",
        (BAR_X, BAR.1 + 76),
        text(13, HPos::Left),
    ))?;
    root.draw(&Text::new(
        "undefined",
        (BAR_X, BAR.1 + 92),
        text(13, HPos::Left),
    ))?;
    Ok(())
}

/// `v` (positive) to three significant digits: fixed from 1e-3 to below
/// 1e5, else exponent form.
fn significant(v: f64) -> String {
    if (1e-3..1e5).contains(&v) {
        let d = (2 - v.log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.2e}")
    }
}

/// The picture being drawn on.
type Root<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Black sans-serif text of `size` pixels, anchored at `h` and centred
/// vertically on its position.
fn text(size: u32, h: HPos) -> TextStyle<'static> {
    ("sans-serif", size)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(h, VPos::Center))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The diverging scale is white at 0 and its colours, like viridis's,
    /// stay far from the stripes of cells without light.
    #[test]
    fn diverging_scale_and_no_value() {
        assert_eq!(diverging(0.5), [247, 247, 247]);
        assert_eq!(diverging(0.0), DIVERGING[0]);
        assert_eq!(diverging(1.0), DIVERGING[10]);
        for c in NO_VALUE {
            for k in 0..=1000 {
                let v = diverging(f64::from(k) / 1000.0);
                let d: f64 = (0..3)
                    .map(|i| (f64::from(c[i]) - f64::from(v[i])).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(d > 40.0, "{c:?} near {v:?}");
            }
        }
    }

    /// A depolarising surface (m00 only; every other element 0, cells
    /// without light NaN): the normalised panels are white where there is
    /// light, striped where there is none; the scale is symmetric.
    #[test]
    fn panels_show_each_element() {
        let grid = CarlsonGrid::new(6).unwrap();
        let n = grid.n_cells();
        let mut values = vec![vec![0.0; n]; 16];
        values[0] = vec![0.2; n];
        values[5] = vec![0.5; n]; // m11 / m00
        for v in values.iter_mut().skip(1) {
            v[n - 1] = f64::NAN;
        }
        values[0][n - 1] = f64::NAN;
        let maps = MuellerMaps {
            title: "t".into(),
            grid,
            values,
            kind: MuellerKind::Normalised,
            theta_i_deg: 0.0,
            phi_i_deg: 0.0,
        };
        assert_eq!(maps.range(), (-0.5, 0.5));
        let img = image::load_from_memory(&maps.to_png().unwrap())
            .unwrap()
            .to_rgb8();
        // Half way out along phi = 225 degrees (clear of the markers).
        let at = |i: usize, j: usize| {
            let (cx, cy) = maps.centre(i, j);
            let d = 0.5 * R * std::f64::consts::FRAC_1_SQRT_2;
            img.get_pixel((cx - d) as u32, (cy + d) as u32).0
        };
        assert_eq!(at(0, 1), diverging(0.5));
        assert_eq!(at(1, 1), diverging(1.0));
        assert_eq!(at(0, 0), viridis(1.0)); // constant m00: the top of its scale
    }

    /// The standard errors' panels each have their own scale, from 0 to
    /// the 98th percentile of their own values: a panel of errors 100
    /// times smaller than another's still spans the whole scale (on the
    /// shared scale it was one dark colour); a constant panel is its top
    /// colour; an all-zero one says so.
    #[test]
    fn error_panels_each_have_their_own_scale() {
        let grid = CarlsonGrid::new(6).unwrap();
        let n = grid.n_cells();
        // m00: relative errors 0.5; m01: 0 .. 0.01 rising with the cell;
        // m11: 0 .. 1; m22: 0.003 everywhere; the rest 0.
        let mut values = vec![vec![0.0; n]; 16];
        values[0] = vec![0.5; n];
        values[1] = (0..n).map(|c| 0.01 * c as f64 / (n - 1) as f64).collect();
        values[5] = (0..n).map(|c| c as f64 / (n - 1) as f64).collect();
        values[10] = vec![0.003; n];
        let maps = MuellerMaps {
            title: "t".into(),
            grid,
            values: values.clone(),
            kind: MuellerKind::Errors,
            theta_i_deg: 0.0,
            phi_i_deg: 0.0,
        };
        for (k, v) in values.iter().enumerate() {
            let mut v = v.clone();
            v.sort_by(f64::total_cmp);
            let p98 = v[((n - 1) as f64 * 0.98).round() as usize];
            let top = if p98 > 0.0 { p98 } else { 1.0 };
            assert_eq!(maps.panel_range(k), (0.0, top), "panel {k}");
        }
        assert_eq!(maps.panel_range(10), (0.0, 0.003));
        assert_eq!(maps.panel_top_label(10), "0.00300");
        assert_eq!(maps.panel_top_label(2), "every value 0");
        assert_eq!(
            maps.panel_top_label(5),
            format!("{:.3} (max 1.00)", maps.panel_range(5).1)
        );
        let img = image::load_from_memory(&maps.to_png().unwrap())
            .unwrap()
            .to_rgb8();
        assert_eq!((img.width(), img.height()), (W, H_ERRORS));
        let at = |k: usize| {
            let (cx, cy) = maps.centre(k / 4, k % 4);
            let d = 0.5 * R * std::f64::consts::FRAC_1_SQRT_2;
            img.get_pixel((cx - d) as u32, (cy + d) as u32).0
        };
        // The constant panels: the top of their scales (m00, m22), or its
        // bottom (all zero).
        assert_eq!(at(0), viridis(1.0));
        assert_eq!(at(10), viridis(1.0));
        assert_eq!(at(2), viridis(0.0));
        // Each panel's bar runs the whole scale.
        let (x0, y0, x1, _) = maps.panel_bar(5);
        assert_eq!(img.get_pixel(x0 as u32, y0 as u32 + 2).0, viridis(0.0));
        assert_eq!(img.get_pixel(x1 as u32, y0 as u32 + 2).0, viridis(1.0));
    }
}
