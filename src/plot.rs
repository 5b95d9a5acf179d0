//! PNG plots a person can read: titles, labelled axes with units, legends.
//!
//! Drawn with `plotters` into an RGB buffer and encoded by `image` (png
//! only). The font, DejaVu Sans, is embedded (assets/fonts, free licence), so
//! plots look the same on every machine and need no system fonts.

use std::sync::Once;

use plotters::prelude::*;

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // Registering a valid embedded font cannot fail; ignore the impossible error.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One curve: points `(x, y, y_error)` (error bars of +-`y_error`; 0 for none).
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64, f64)>,
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
    /// Logarithmic y axis (non-positive values are left out).
    pub log_y: bool,
    /// Curves.
    pub series: Vec<Series>,
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(0, 0, 0),
];

impl LinePlot {
    /// Render to PNG bytes of `width x height` pixels.
    pub fn to_png(&self, width: u32, height: u32) -> anyhow::Result<Vec<u8>> {
        register_font();
        let mut buf = vec![255u8; (width * height * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
            root.fill(&WHITE)
                .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
            let pts = || {
                self.series
                    .iter()
                    .flat_map(|s| s.points.iter().copied())
                    .filter(|p| p.0.is_finite() && p.1.is_finite() && (!self.log_y || p.1 > 0.0))
            };
            let (mut x0, mut x1) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
            let (mut y0, mut y1) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1 - p.2.abs()), b.max(p.1 + p.2.abs()))
            });
            if !x0.is_finite() {
                (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
            }
            if x1 <= x0 {
                x1 = x0 + 1.0;
            }
            let draw = |chart_area: &DrawingArea<BitMapBackend, _>| -> Result<(), String> {
                let mut builder = ChartBuilder::on(chart_area);
                builder
                    .caption(&self.title, ("sans-serif", 22))
                    .margin(12)
                    .x_label_area_size(45)
                    .y_label_area_size(80);
                if self.log_y {
                    let lo = pts()
                        .map(|p| (p.1 - p.2.abs()).max(p.1 * 0.5))
                        .fold(f64::INFINITY, f64::min);
                    let (lo, hi) = (lo.max(1e-300) * 0.8, y1.max(lo * 10.0) * 1.25);
                    let mut chart = builder
                        .build_cartesian_2d(x0..x1, (lo..hi).log_scale())
                        .map_err(|e| e.to_string())?;
                    chart
                        .configure_mesh()
                        .x_desc(&self.x_label)
                        .y_desc(&self.y_label)
                        .y_label_formatter(&|v| format!("{v:.0e}"))
                        .label_style(("sans-serif", 14))
                        .draw()
                        .map_err(|e| e.to_string())?;
                    self.draw_series(&mut chart).map_err(|e| e.to_string())?;
                } else {
                    let pad = 0.08 * (y1 - y0).abs().max(1e-12);
                    let mut chart = builder
                        .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
                        .map_err(|e| e.to_string())?;
                    chart
                        .configure_mesh()
                        .x_desc(&self.x_label)
                        .y_desc(&self.y_label)
                        .label_style(("sans-serif", 14))
                        .draw()
                        .map_err(|e| e.to_string())?;
                    self.draw_series(&mut chart).map_err(|e| e.to_string())?;
                }
                Ok(())
            };
            draw(&root).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
            root.present().map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        }
        let img = image::RgbImage::from_raw(width, height, buf)
            .ok_or_else(|| anyhow::anyhow!("plot: buffer size"))?;
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
        Ok(png)
    }

    fn draw_series<'a, 'b: 'a, X, Y>(
        &self,
        chart: &mut ChartContext<'a, BitMapBackend<'b>, Cartesian2d<X, Y>>,
    ) -> Result<(), DrawingAreaErrorKind<<BitMapBackend<'b> as DrawingBackend>::ErrorType>>
    where
        X: Ranged<ValueType = f64>,
        Y: Ranged<ValueType = f64>,
    {
        for (i, s) in self.series.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            let pts: Vec<(f64, f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite() && (!self.log_y || p.1 > 0.0))
                .collect();
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|p| (p.0, p.1)),
                    color.stroke_width(2),
                ))?
                .label(s.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart.draw_series(
                pts.iter()
                    .map(|p| Circle::new((p.0, p.1), 3, color.filled())),
            )?;
            chart.draw_series(pts.iter().filter(|p| p.2 > 0.0).map(|p| {
                let lo = if self.log_y {
                    (p.1 - p.2).max(p.1 * 0.5)
                } else {
                    p.1 - p.2
                };
                ErrorBar::new_vertical(p.0, lo, p.1, p.1 + p.2, color.stroke_width(1), 6)
            }))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_a_png_of_the_requested_size() {
        let plot = LinePlot {
            title: "test".into(),
            x_label: "x (mm)".into(),
            y_label: "y (-)".into(),
            log_y: true,
            series: vec![Series {
                label: "a".into(),
                points: vec![(0.0, 1e-4, 1e-5), (1.0, 3e-4, 2e-5), (2.0, 0.0, 0.0)],
            }],
        };
        let png = plot.to_png(640, 400).unwrap();
        let img = image::load_from_memory(&png).unwrap();
        assert_eq!((img.width(), img.height()), (640, 400));
        // Something was drawn: not all white.
        assert!(img.to_rgb8().pixels().any(|p| p.0 != [255, 255, 255]));
    }
}
