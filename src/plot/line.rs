//! Line plots with error bars ([`LinePlot`]): one distinct colour per
//! curve (or, past [`PALETTE`]'s ten, a panel per ten curves), the legend
//! in a column beside the data, no line across a point without a value,
//! unique tick labels; or small multiples ([`Grid`]): titled panels on a
//! grid, on the same axes, each curve in the colour it names (so one
//! quantity keeps its colour from panel to panel, and a model's line the
//! colour of the table it was fitted to).

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::{Rect, TickFormat, encode_png, log_ticks, register_font, ticks};

/// One curve: points `(x, y, y_error)` (error bars of ±`y_error`; 0 for
/// none). A point whose `y` is not finite (or not positive on a log axis)
/// has no value: the curve is broken there.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points, in the order they are joined.
    pub points: Vec<(f64, f64, f64)>,
    /// Its colour, an index into [`PALETTE`] (taken modulo its length);
    /// `None`: its place in its panel.
    pub colour: Option<usize>,
    /// How it is drawn.
    pub mark: Mark,
}

impl Series {
    /// A curve of `points` drawn as [`Mark::LinePoints`] in the colour of
    /// its place in its panel.
    #[must_use]
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            colour: None,
            mark: Mark::LinePoints,
        }
    }
}

/// How a [`Series`] is drawn (its legend entry likewise).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Points with their error bars, joined by a line.
    LinePoints,
    /// Points with their error bars, not joined: measured (tabulated) data.
    Points,
    /// A line only: a model's curve.
    Line,
}

/// One panel of a [`LinePlot`] of small multiples: its title and the
/// series it draws (a range of [`LinePlot::series`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Title, above the panel's chart.
    pub title: String,
    /// Its series.
    pub series: std::ops::Range<usize>,
}

/// Small multiples: panels on a grid of `columns` columns, row by row,
/// all on the same axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Columns of the grid (at least 1).
    pub columns: usize,
    /// The panels, row-major.
    pub panels: Vec<Panel>,
}

/// A line plot with error bars.
#[derive(Debug, Clone)]
pub struct LinePlot {
    /// Title (top).
    pub title: String,
    /// x-axis label, with units.
    pub x_label: String,
    /// y-axis label, with units.
    pub y_label: String,
    /// Logarithmic y axis (non-positive values have no value there).
    pub log_y: bool,
    /// Curves.
    pub series: Vec<Series>,
    /// Small multiples; `None`: one panel per ten curves, in a column.
    pub grid: Option<Grid>,
}

/// Curve colours (Tableau 10): ten colours far apart; a plot of more curves
/// gets one panel per ten.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Height of the title strip (pixels).
const TITLE_H: i32 = 40;
/// Height of a small multiple's own title strip (pixels).
const PANEL_TITLE_H: i32 = 22;
/// Pixels per legend entry.
const LEGEND_ROW: i32 = 20;
/// Labels per axis (at most).
const LABELS: usize = 8;

/// An axis's ticks: position (plotted coordinates) and label.
pub type Ticks = Vec<(f64, String)>;

/// Where the parts of a [`LinePlot`] go: per panel, the chart (axes and
/// data) and, to its right and apart from it, the legend.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// Per panel: (chart, legend).
    pub panels: Vec<(Rect, Rect)>,
}

impl LinePlot {
    /// The range of [`Self::series`] of each panel: the grid's panels, or
    /// at most [`PALETTE`]'s length each (one panel for an empty plot).
    #[must_use]
    pub fn panel_ranges(&self) -> Vec<std::ops::Range<usize>> {
        if let Some(g) = &self.grid {
            return g.panels.iter().map(|p| p.series.clone()).collect();
        }
        if self.series.is_empty() {
            return std::iter::once(0..0).collect();
        }
        let n = PALETTE.len();
        (0..self.series.len())
            .step_by(n)
            .map(|a| a..(a + n).min(self.series.len()))
            .collect()
    }

    /// The series of each panel.
    #[must_use]
    pub fn panels(&self) -> Vec<&[Series]> {
        self.panel_ranges()
            .into_iter()
            .map(|r| &self.series[r])
            .collect()
    }

    /// The colour of the `k`-th series of a panel (distinct within it).
    #[must_use]
    pub fn colour(k: usize) -> RGBColor {
        PALETTE[k % PALETTE.len()]
    }

    /// The colour series `k` of [`Self::series`] is drawn in: its own
    /// [`Series::colour`], else that of its place in its panel.
    #[must_use]
    pub fn series_colour(&self, k: usize) -> RGBColor {
        if let Some(c) = self.series[k].colour {
            return Self::colour(c);
        }
        let start = self
            .panel_ranges()
            .into_iter()
            .find(|r| r.contains(&k))
            .map_or(0, |r| r.start);
        Self::colour(k - start)
    }

    /// Columns and rows of the panels.
    fn shape(&self) -> (usize, usize) {
        let n = self.panel_ranges().len().max(1);
        let columns = self.grid.as_ref().map_or(1, |g| g.columns.clamp(1, n));
        (columns, n.div_ceil(columns))
    }

    /// The size (pixels) a picture of this plot is drawn at, from the size
    /// of a plain one (`width x height`): a grid of small multiples gets
    /// at least 700 pixels per column and 320 per row.
    #[must_use]
    pub fn size(&self, width: u32, height: u32) -> (u32, u32) {
        if self.grid.is_none() {
            return (width, height);
        }
        let (c, r) = self.shape();
        (
            width.max(700 * c as u32),
            height.max(TITLE_H as u32 + 320 * r as u32),
        )
    }

    /// Where the charts and legends go on a picture of `width x height`.
    #[must_use]
    pub fn layout(&self, width: u32, height: u32) -> Layout {
        let (w, h) = (width as i32, height as i32);
        let (columns, rows) = self.shape();
        let (cw, ph) = (w / columns as i32, (h - TITLE_H) / rows as i32);
        let longest = self
            .series
            .iter()
            .map(|s| s.label.chars().count())
            .max()
            .unwrap_or(0) as i32;
        let legend_w = if self.series.is_empty() {
            0
        } else {
            (longest * 8 + 50).max(110).min(cw / 3)
        };
        // A panel's own title takes a strip above its chart.
        let strip = if self.grid.is_some() {
            PANEL_TITLE_H
        } else {
            0
        };
        let panels = (0..self.panel_ranges().len() as i32)
            .map(|k| {
                let (col, row) = (k % columns as i32, k / columns as i32);
                let (x0, y0) = (col * cw, TITLE_H + row * ph);
                let chart = Rect {
                    x0,
                    y0: y0 + strip,
                    x1: x0 + cw - legend_w,
                    y1: y0 + ph,
                };
                let legend = Rect {
                    x0: x0 + cw - legend_w,
                    y0: y0 + strip,
                    x1: x0 + cw,
                    y1: y0 + ph,
                };
                (chart, legend)
            })
            .collect();
        Layout { panels }
    }

    /// The plotted `y` of a value: `log10 y` on a log axis; `None` for no value.
    fn plotted(&self, y: f64) -> Option<f64> {
        if !y.is_finite() || (self.log_y && y <= 0.0) {
            None
        } else if self.log_y {
            Some(y.log10())
        } else {
            Some(y)
        }
    }

    /// The runs of points of `s` with values, in plotted coordinates
    /// (`(x, y, y_lo, y_hi)`, error bar ends): a curve is drawn as these
    /// separate runs, so nothing joins across a point without a value.
    #[must_use]
    pub fn segments(&self, s: &Series) -> Vec<Vec<(f64, f64, f64, f64)>> {
        let mut runs: Vec<Vec<(f64, f64, f64, f64)>> = vec![Vec::new()];
        for &(x, y, e) in &s.points {
            match (x.is_finite(), self.plotted(y)) {
                (true, Some(py)) => {
                    let e = if e.is_finite() { e.abs() } else { 0.0 };
                    let (lo, hi) = if self.log_y {
                        ((y - e).max(0.5 * y).log10(), (y + e).log10())
                    } else {
                        (y - e, y + e)
                    };
                    runs.last_mut().expect("one run").push((x, py, lo, hi));
                }
                _ => {
                    if !runs.last().expect("one run").is_empty() {
                        runs.push(Vec::new());
                    }
                }
            }
        }
        runs.retain(|r| !r.is_empty());
        runs
    }

    /// The axis ranges `(x0..x1, y0..y1)` in plotted coordinates: the
    /// points with values and their error bars, padded; a single value is
    /// centred in a range about it.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let mut x = (f64::INFINITY, f64::NEG_INFINITY);
        let mut y = (f64::INFINITY, f64::NEG_INFINITY);
        for s in &self.series {
            for run in self.segments(s) {
                for (px, py, lo, hi) in run {
                    x = (x.0.min(px), x.1.max(px));
                    y = (y.0.min(lo.min(py)), y.1.max(hi.max(py)));
                }
            }
        }
        if !x.0.is_finite() {
            // Nothing to draw: the x range of the points without values.
            x = self
                .series
                .iter()
                .flat_map(|s| &s.points)
                .filter(|p| p.0.is_finite())
                .fold(x, |a, p| (a.0.min(p.0), a.1.max(p.0)));
        }
        let about = |(lo, hi): (f64, f64), unit: f64| {
            if !lo.is_finite() {
                (0.0, 1.0)
            } else if hi - lo <= 1e-12 * lo.abs().max(hi.abs()) {
                let d = 0.5 * lo.abs().max(unit);
                (lo - d, hi + d)
            } else {
                let pad = 0.04 * (hi - lo);
                (lo - pad, hi + pad)
            }
        };
        let x = about(x, 1.0);
        let y = about(y, if self.log_y { 1.0 } else { 1e-300 });
        (x, y)
    }

    /// The ticks of the two axes (plotted coordinates) and their labels:
    /// `(x, y)`, each a list of `(tick, label)`.
    #[must_use]
    pub fn axis_ticks(&self) -> (Ticks, Ticks) {
        let ((x0, x1), (y0, y1)) = self.ranges();
        let tx = ticks(x0, x1, LABELS);
        let ty = if self.log_y {
            log_ticks(y0, y1, LABELS)
        } else {
            ticks(y0, y1, LABELS)
        };
        let (fx, fy) = (
            TickFormat::for_ticks(&tx, false),
            TickFormat::for_ticks(&ty, self.log_y),
        );
        (
            tx.iter().map(|&t| (t, fx.label(t))).collect(),
            ty.iter().map(|&t| (t, fy.label(t))).collect(),
        )
    }

    /// Render to PNG bytes of `width x height` pixels.
    ///
    /// # Errors
    /// If drawing or encoding fails.
    pub fn to_png(&self, width: u32, height: u32) -> anyhow::Result<Vec<u8>> {
        register_font();
        let mut buf = vec![255u8; (width * height * 3) as usize];
        self.draw(&mut buf, width, height)
            .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        encode_png(width, height, buf)
    }

    fn draw(&self, buf: &mut [u8], width: u32, height: u32) -> Result<(), super::DrawError> {
        let root = BitMapBackend::with_buffer(buf, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let title = super::title_lines(&self.title, (width / 11) as usize);
        for (k, l) in title.iter().enumerate() {
            let (y, size) = match (title.len(), k) {
                (1, _) => (TITLE_H / 2, 19),
                (_, 0) => (11, 16),
                _ => (29, 14),
            };
            root.draw(&Text::new(l.clone(), (width as i32 / 2, y), centred(size)))?;
        }
        let ((x0, x1), (y0, y1)) = self.ranges();
        let ticks = self.axis_ticks();
        let layout = self.layout(width, height);
        let mut first = 0;
        let titles: Vec<&str> = self
            .grid
            .as_ref()
            .map(|g| g.panels.iter().map(|p| p.title.as_str()).collect())
            .unwrap_or_default();
        for (k, (range, (chart_r, legend_r))) in self
            .panel_ranges()
            .into_iter()
            .zip(&layout.panels)
            .enumerate()
        {
            if let Some(t) = titles.get(k) {
                root.draw(&Text::new(
                    (*t).to_owned(),
                    (
                        (chart_r.x0 + legend_r.x1) / 2,
                        chart_r.y0 - PANEL_TITLE_H / 2 + 2,
                    ),
                    centred(15),
                ))?;
            }
            let area = root.clone().shrink(
                (chart_r.x0, chart_r.y0),
                (
                    (chart_r.x1 - chart_r.x0) as u32,
                    (chart_r.y1 - chart_r.y0) as u32,
                ),
            );
            let mut chart = ChartBuilder::on(&area)
                .margin(10)
                .x_label_area_size(45)
                .y_label_area_size(80)
                .build_cartesian_2d(x0..x1, y0..y1)?;
            // Axes and their labels; the ticks, grid lines and tick labels
            // are this plot's own (unique, at whole decades on a log axis).
            chart
                .configure_mesh()
                .disable_mesh()
                .x_labels(0)
                .y_labels(0)
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .axis_desc_style(("sans-serif", 14))
                .draw()?;
            draw_ticks(&root, &mut chart, ((x0, x1), (y0, y1)), &ticks)?;
            let colours: Vec<RGBColor> = range.clone().map(|i| self.series_colour(i)).collect();
            let series = &self.series[range];
            self.draw_curves(&mut chart, series, &colours)?;
            draw_legend(&root, legend_r, series, &colours)?;
            first += series.len();
        }
        debug_assert_eq!(first, self.series.len());
        if self.series.iter().all(|s| self.segments(s).is_empty()) {
            let note = if self.log_y {
                "no reflected light (every value is zero)"
            } else {
                "no data"
            };
            root.draw(&Text::new(
                note,
                (width as i32 / 2, height as i32 / 2),
                centred(24),
            ))?;
        }
        root.present()?;
        Ok(())
    }

    /// Draw each of `series` (one panel's) in its colour (`colours`, one
    /// per series) as its [`Mark`] says: its runs of points joined, the
    /// points, their error bars.
    fn draw_curves(
        &self,
        chart: &mut Chart<'_, '_>,
        series: &[Series],
        colours: &[RGBColor],
    ) -> Result<(), super::DrawError> {
        for (s, &colour) in series.iter().zip(colours) {
            for run in self.segments(s) {
                if s.mark != Mark::Points {
                    chart.draw_series(LineSeries::new(
                        run.iter().map(|p| (p.0, p.1)),
                        colour.stroke_width(2),
                    ))?;
                }
                if s.mark == Mark::Line {
                    continue;
                }
                chart.draw_series(
                    run.iter()
                        .map(|p| Circle::new((p.0, p.1), 3, colour.filled())),
                )?;
                chart.draw_series(run.iter().filter(|p| p.3 > p.2).map(|p| {
                    ErrorBar::new_vertical(p.0, p.2, p.1, p.3, colour.stroke_width(1), 6)
                }))?;
            }
        }
        Ok(())
    }
}

/// A panel's chart: plotted x and y coordinates on the picture.
type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Black sans-serif text of `size` pixels centred on its position.
fn centred(size: u32) -> TextStyle<'static> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    ("sans-serif", size)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center))
}

/// Draw the grid lines of `ticks` (x, y) across `chart` (axis ranges
/// `((x0, x1), (y0, y1))`, plotted coordinates), and the tick marks and
/// their labels on `root` beside its axes.
fn draw_ticks(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    chart: &mut Chart<'_, '_>,
    ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64)),
    (tx, ty): &(Ticks, Ticks),
) -> Result<(), super::DrawError> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let grid = RGBColor(220, 220, 220);
    for (t, _) in ty {
        chart.draw_series(LineSeries::new([(x0, *t), (x1, *t)], grid.stroke_width(1)))?;
    }
    for (t, _) in tx {
        chart.draw_series(LineSeries::new([(*t, y0), (*t, y1)], grid.stroke_width(1)))?;
    }
    let tick = |h: HPos, v: VPos| {
        ("sans-serif", 14)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(h, v))
    };
    for (t, label) in ty {
        let (px, py) = chart.backend_coord(&(x0, *t));
        root.draw(&PathElement::new(
            vec![(px - 5, py), (px, py)],
            BLACK.stroke_width(1),
        ))?;
        root.draw(&Text::new(
            label.clone(),
            (px - 8, py),
            tick(HPos::Right, VPos::Center),
        ))?;
    }
    for (t, label) in tx {
        let (px, py) = chart.backend_coord(&(*t, y0));
        root.draw(&PathElement::new(
            vec![(px, py), (px, py + 5)],
            BLACK.stroke_width(1),
        ))?;
        root.draw(&Text::new(
            label.clone(),
            (px, py + 8),
            tick(HPos::Center, VPos::Top),
        ))?;
    }
    Ok(())
}

/// Draw the legend of `series` (one panel's, in `colours`) in its own
/// column `legend_r` of `root`: per curve its line and point (as its
/// [`Mark`] draws it) in its colour, and its label.
fn draw_legend(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    legend_r: &Rect,
    series: &[Series],
    colours: &[RGBColor],
) -> Result<(), super::DrawError> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let label = ("sans-serif", 14)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (k, (s, &colour)) in series.iter().zip(colours).enumerate() {
        let y = legend_r.y0 + 20 + LEGEND_ROW * k as i32;
        let x = legend_r.x0 + 6;
        if s.mark != Mark::Points {
            root.draw(&PathElement::new(
                vec![(x, y), (x + 24, y)],
                colour.stroke_width(2),
            ))?;
        }
        if s.mark != Mark::Line {
            root.draw(&Circle::new((x + 12, y), 3, colour.filled()))?;
        }
        if s.mark == Mark::Points {
            root.draw(&PathElement::new(
                vec![(x + 12, y - 7), (x + 12, y + 7)],
                colour.stroke_width(1),
            ))?;
        }
        root.draw(&Text::new(s.label.clone(), (x + 32, y), label.clone()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(n: usize, points: Vec<(f64, f64, f64)>) -> Vec<Series> {
        (0..n)
            .map(|k| Series::new(format!("θi = {} deg", 10 * k), points.clone()))
            .collect()
    }

    fn plot(series: Vec<Series>, log_y: bool) -> LinePlot {
        LinePlot {
            title: "test".into(),
            x_label: "x (mm)".into(),
            y_label: "y (1/sr)".into(),
            log_y,
            series,
            grid: None,
        }
    }

    #[test]
    fn renders_a_png_of_the_requested_size() {
        let p = plot(
            series(
                1,
                vec![(0.0, 1e-4, 1e-5), (1.0, 3e-4, 2e-5), (2.0, 0.0, 0.0)],
            ),
            true,
        );
        let png = p.to_png(640, 400).unwrap();
        let img = image::load_from_memory(&png).unwrap();
        assert_eq!((img.width(), img.height()), (640, 400));
        assert!(img.to_rgb8().pixels().any(|p| p.0 != [255, 255, 255]));
    }

    /// All-zero (a black surface) and single-value data on a log axis: the
    /// plot is drawn, in bounded time (it used to spin on an inf..inf axis).
    #[test]
    fn degenerate_log_plots_are_drawn() {
        for points in [
            vec![(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)],
            vec![(0.0, 2.0, 0.0)],
            vec![(0.0, 2.0, 0.0), (1.0, 2.0, 0.0)],
            vec![],
        ] {
            let p = plot(series(1, points), true);
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || tx.send(p.to_png(320, 200).map(|p| p.len())));
            let len = rx
                .recv_timeout(std::time::Duration::from_secs(60))
                .expect("the plot finishes within a minute")
                .expect("the plot is drawn");
            assert!(len > 0);
        }
    }

    /// Every curve of a panel has its own colour, far from the others (at
    /// least 60 apart in RGB); ten curves fill one panel (inplane.png's
    /// ten incidence angles shared six colours), eleven make two.
    #[test]
    fn each_curve_has_its_own_colour() {
        for (i, a) in PALETTE.iter().enumerate() {
            for b in &PALETTE[..i] {
                let d = [(a.0, b.0), (a.1, b.1), (a.2, b.2)]
                    .iter()
                    .map(|&(x, y)| (f64::from(x) - f64::from(y)).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(d > 60.0, "{a:?} vs {b:?}: {d}");
            }
        }
        let ten = plot(series(10, vec![(0.0, 1.0, 0.0)]), false);
        assert_eq!(ten.panels().len(), 1);
        let eleven = plot(series(11, vec![(0.0, 1.0, 0.0)]), false);
        let panels = eleven.panels();
        assert_eq!(panels.iter().map(|p| p.len()).collect::<Vec<_>>(), [10, 1]);
    }

    /// The legend is a column of its own: it overlaps no chart (where the
    /// data are), and its entries fit inside it.
    #[test]
    fn legend_is_outside_the_data() {
        for n in [1, 10, 13] {
            let p = plot(series(n, vec![(0.0, 1.0, 0.0), (1.0, 2.0, 0.0)]), true);
            let l = p.layout(1000, 620);
            for (chart, legend) in &l.panels {
                for (other, _) in &l.panels {
                    assert!(!legend.overlaps(other), "{legend:?} on {other:?}");
                }
                assert!(legend.x0 >= chart.x1);
                let rows = p.panels()[0].len() as i32;
                assert!(
                    20 + LEGEND_ROW * rows <= legend.y1 - legend.y0,
                    "{n} entries"
                );
            }
        }
        // Drawn: the legend column holds the coloured entries only, the
        // chart column the data: no pixel of a curve's colour right of the
        // chart but in the legend's entry rows.
        let p = plot(series(2, vec![(0.0, 1.0, 0.0), (1.0, 2.0, 0.0)]), false);
        let img = image::load_from_memory(&p.to_png(800, 500).unwrap())
            .unwrap()
            .to_rgb8();
        let (_, legend) = p.layout(800, 500).panels[0];
        let c = PALETTE[1];
        for (x, y, px) in img.enumerate_pixels() {
            if px.0 == [c.0, c.1, c.2] && legend.contains((x as i32, y as i32)) {
                assert!(
                    (y as i32 - (legend.y0 + 20 + LEGEND_ROW)).abs() <= 4,
                    "{x} {y}"
                );
            }
        }
    }

    /// A curve is broken where a point has no value (an empty bin: NaN, or
    /// zero on a log axis): no segment joins the points on either side.
    #[test]
    fn no_line_across_empty_bins() {
        let points = vec![
            (0.0, 1.0, 0.1),
            (1.0, 2.0, 0.1),
            (2.0, f64::NAN, 0.0),
            (3.0, 0.0, 0.0),
            (4.0, 3.0, 0.1),
            (5.0, 4.0, 0.0),
            (6.0, 0.0, 0.0),
        ];
        let p = plot(series(1, points.clone()), true);
        let runs = p.segments(&p.series[0]);
        let xs: Vec<Vec<f64>> = runs
            .iter()
            .map(|r| r.iter().map(|p| p.0).collect())
            .collect();
        assert_eq!(xs, [vec![0.0, 1.0], vec![4.0, 5.0]]);
        // On a linear axis zero is a value, NaN is not.
        let p = plot(series(1, points), false);
        let xs: Vec<Vec<f64>> = p
            .segments(&p.series[0])
            .iter()
            .map(|r| r.iter().map(|p| p.0).collect())
            .collect();
        assert_eq!(xs, [vec![0.0, 1.0], vec![3.0, 4.0, 5.0, 6.0]]);
    }

    /// One point (a single beam position) sits in the middle of its x
    /// range, not at the edge of 0..1; the tick labels are unique.
    #[test]
    fn one_point_is_centred_and_labels_are_unique() {
        let p = plot(series(1, vec![(3.0, 2.5e-5, 1e-6)]), false);
        let ((x0, x1), (y0, y1)) = p.ranges();
        assert!((0.5 * (x0 + x1) - 3.0).abs() < 1e-12 && x1 > x0);
        assert!(y0 < 2.4e-5 && y1 > 2.6e-5);
        let (xl, yl) = p.axis_ticks();
        for labels in [xl, yl] {
            let labels: Vec<String> = labels.into_iter().map(|t| t.1).collect();
            let mut u = labels.clone();
            u.sort();
            u.dedup();
            assert_eq!(u.len(), labels.len(), "{labels:?}");
        }
    }

    /// Small multiples: the panels of a 2 x 2 grid sit side by side and
    /// row under row, none overlapping another or its legend; each series
    /// is drawn in the colour it names (else its place in its panel); the
    /// picture grows to 700 pixels per column and 320 per row.
    #[test]
    fn grid_of_panels() {
        let mut p = plot(series(8, vec![(0.0, 1.0, 0.1), (1.0, 2.0, 0.1)]), true);
        p.series[5].colour = Some(7);
        p.series[6].mark = Mark::Points;
        p.grid = Some(Grid {
            columns: 2,
            panels: (0..4)
                .map(|k| Panel {
                    title: format!("panel {k}"),
                    series: 2 * k..2 * k + 2,
                })
                .collect(),
        });
        assert_eq!(p.size(1100, 640), (1400, 680));
        assert_eq!(
            p.panels().iter().map(|s| s.len()).collect::<Vec<_>>(),
            [2; 4]
        );
        let l = p.layout(1400, 680);
        assert_eq!(l.panels.len(), 4);
        let (a, b, c) = (l.panels[0].0, l.panels[1].0, l.panels[2].0);
        assert!(b.x0 >= 700 && a.x1 <= 700 && a.y0 == b.y0);
        assert!(c.y0 >= a.y1 && c.x0 == a.x0);
        let rects: Vec<Rect> = l.panels.iter().flat_map(|(c, g)| [*c, *g]).collect();
        for (i, r) in rects.iter().enumerate() {
            for o in &rects[..i] {
                assert!(!r.overlaps(o), "{r:?} on {o:?}");
            }
        }
        assert_eq!(p.series_colour(4), PALETTE[0]);
        assert_eq!(p.series_colour(5), PALETTE[7]);
        assert_eq!(p.series_colour(3), PALETTE[1]);
        let png = p.to_png(1400, 680).unwrap();
        let img = image::load_from_memory(&png).unwrap();
        assert_eq!((img.width(), img.height()), (1400, 680));
        // Without a grid, as before: one panel per ten curves, its place's colour.
        let q = plot(series(12, vec![(0.0, 1.0, 0.0)]), false);
        assert_eq!(q.size(1100, 640), (1100, 640));
        assert_eq!(q.series_colour(11), PALETTE[1]);
    }
}
