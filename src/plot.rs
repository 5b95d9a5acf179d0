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
            // The x range of the drawable points, or of every finite point
            // when none can be drawn (all zero on a log axis).
            let x_range = |p: &mut dyn Iterator<Item = (f64, f64, f64)>| {
                p.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    (a.min(p.0), b.max(p.0))
                })
            };
            let (mut x0, mut x1) = x_range(&mut pts());
            if !x0.is_finite() {
                (x0, x1) = x_range(
                    &mut self
                        .series
                        .iter()
                        .flat_map(|s| s.points.iter().copied())
                        .filter(|p| p.0.is_finite()),
                );
            }
            let (mut y0, mut y1) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1 - p.2.abs()), b.max(p.1 + p.2.abs()))
            });
            if !x0.is_finite() {
                (x0, x1) = (0.0, 1.0);
            }
            if !y0.is_finite() {
                (y0, y1) = (0.0, 1.0);
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
                    let (mut lo, mut hi) = (lo.max(1e-300) * 0.8, y1.max(lo * 10.0) * 1.25);
                    // Nothing positive to draw (e.g. a black surface): a fixed
                    // decade range instead of inf..inf, and a note on the plot.
                    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                        (lo, hi) = (1e-3, 1.0);
                    }
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
            if pts().next().is_none() {
                use plotters::style::text_anchor::{HPos, Pos, VPos};
                let style = ("sans-serif", 24)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Center));
                let at = (width as i32 / 2, height as i32 / 2);
                let note = if self.log_y {
                    "no reflected light (every value is zero)"
                } else {
                    "no data"
                };
                root.draw(&Text::new(note, at, style))
                    .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
            }
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

/// Viridis colour map (matplotlib's), 9 stops, linear in between.
const VIRIDIS: [(f64, [u8; 3]); 9] = [
    (0.0, [68, 1, 84]),
    (0.125, [71, 44, 122]),
    (0.25, [59, 81, 139]),
    (0.375, [44, 113, 142]),
    (0.5, [33, 144, 141]),
    (0.625, [39, 173, 129]),
    (0.75, [92, 200, 99]),
    (0.875, [170, 220, 50]),
    (1.0, [253, 231, 37]),
];

/// The viridis colour at `t` in `[0, 1]` (clamped; NaN gives the lowest).
#[must_use]
pub fn viridis(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let k = VIRIDIS
        .partition_point(|s| s.0 <= t)
        .clamp(1, VIRIDIS.len() - 1);
    let ((t0, c0), (t1, c1)) = (VIRIDIS[k - 1], VIRIDIS[k]);
    let w = (t - t0) / (t1 - t0);
    std::array::from_fn(|i| {
        (f64::from(c0[i]) + w * (f64::from(c1[i]) - f64::from(c0[i]))).round() as u8
    })
}

/// A BRDF over the hemisphere of outgoing directions as an equal-area polar
/// map (`hemisphere_<theta>deg.png` of `roks brdf`).
///
/// The hemisphere is drawn in the Lambert azimuthal equal-area projection:
/// the direction at polar angle `theta` and azimuth `phi` is at radius
/// `R sqrt(2) sin(theta / 2)` (the normal at the centre, the horizon on the
/// rim, `R` the disc's radius in pixels) and angle `phi`, counter-clockwise
/// from the right (`phi = 0`, +x). Equal areas on the picture are equal solid
/// angles, so every Carlson cell covers the same number of pixels. Each
/// pixel takes the colour of the cell holding its direction, viridis on
/// `log10 BRDF` over at most 4 decades below the largest value (cells below
/// the range, including zeros, take the lowest colour). Rings mark
/// `theta = 30, 60, 90` degrees, ticks every 30 degrees of azimuth; a white
/// ring with a black outline around the specular direction (open, so the
/// cells there stay visible) and a cross on the direction toward the light.
#[derive(Debug, Clone)]
pub struct HemisphereMap {
    /// Title (top line).
    pub title: String,
    /// The grid of `brdf`.
    pub grid: crate::tally::CarlsonGrid,
    /// BRDF per flat cell of `grid` (sr⁻¹), cells at absolute azimuths (or
    /// the quantity of [`HemisphereMap::scale`]).
    pub brdf: Vec<f64>,
    /// How values map to colours.
    pub scale: MapScale,
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees); the specular direction is at `phi_i + 180`.
    pub phi_i_deg: f64,
}

/// Colour scale of a [`HemisphereMap`].
#[derive(Debug, Clone, PartialEq)]
pub enum MapScale {
    /// `log10` of a BRDF, at most 4 decades (the default).
    LogBrdf,
    /// Given display colours per cell (a colour map): `brdf` holds the
    /// quantity whose log10 the colour bar's range shows (four decades
    /// below its largest value), labelled `label`; the bar is a grey ramp.
    Rgb {
        /// Colour-bar label.
        label: String,
        /// 8-bit sRGB per flat cell.
        colours: Vec<[u8; 3]>,
    },
    /// A linear quantity on `[lo, hi]` (e.g. the degree of polarisation on
    /// `[0, 1]`), labelled `label` on the colour bar.
    Linear {
        /// Colour-bar label.
        label: String,
        /// Value of the lowest colour.
        lo: f64,
        /// Value of the highest colour.
        hi: f64,
    },
}

/// Picture size and layout of [`HemisphereMap`] (pixels).
const MAP_W: u32 = 760;
const MAP_H: u32 = 720;
const MAP_R: f64 = 260.0;
const MAP_CX: f64 = 330.0;
const MAP_CY: f64 = 390.0;
const BAR_X: (u32, u32) = (655, 680);
const BAR_Y: (u32, u32) = (170, 610);

/// Normalised radius in the disc (0 centre, 1 rim) of polar angle `theta`
/// (radians): `sqrt(2) sin(theta / 2)`.
fn equal_area_radius(theta: f64) -> f64 {
    std::f64::consts::SQRT_2 * (0.5 * theta).sin()
}

impl HemisphereMap {
    /// Colour range `(log10 lo, log10 hi)`: the largest value and at most 4
    /// decades below it, down to the smallest positive value; one decade
    /// about a constant; `(-1, 0)` if nothing is positive.
    fn log_range(&self) -> (f64, f64) {
        if let MapScale::Linear { lo, hi, .. } = &self.scale {
            return (*lo, *hi);
        }
        let pos = self
            .brdf
            .iter()
            .copied()
            .filter(|v| *v > 0.0 && v.is_finite());
        let (lo, hi) = pos.fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
        if hi <= 0.0 {
            return (-1.0, 0.0);
        }
        let (lo, hi) = (lo.max(hi * 1e-4).log10(), hi.log10());
        if hi - lo < 1e-9 {
            (lo - 0.5, hi + 0.5)
        } else {
            (lo, hi)
        }
    }

    /// Colour of a value on the range `(lo, hi)` (of log10 for a BRDF).
    fn colour(&self, v: f64, (lo, hi): (f64, f64)) -> [u8; 3] {
        if let MapScale::Linear { .. } = self.scale {
            return viridis(((v - lo) / (hi - lo)).clamp(0.0, 1.0));
        }
        if v > 0.0 {
            viridis((v.log10() - lo) / (hi - lo))
        } else {
            viridis(0.0)
        }
    }

    /// Paint the disc into an RGB buffer of `width` pixels per row: every
    /// pixel whose centre lies in the disc takes its cell's colour.
    fn paint_disc(&self, buf: &mut [u8], width: u32, range: (f64, f64)) {
        let r = MAP_R;
        let (y0, y1) = ((MAP_CY - r).floor() as u32, (MAP_CY + r).ceil() as u32);
        let (x0, x1) = ((MAP_CX - r).floor() as u32, (MAP_CX + r).ceil() as u32);
        let colours: Vec<[u8; 3]> = match &self.scale {
            MapScale::Rgb { colours, .. } => colours.clone(),
            _ => self.brdf.iter().map(|&v| self.colour(v, range)).collect(),
        };
        for py in y0..=y1 {
            for px in x0..=x1 {
                let (dx, dy) = (f64::from(px) + 0.5 - MAP_CX, MAP_CY - (f64::from(py) + 0.5));
                let rho = dx.hypot(dy) / r;
                if rho > 1.0 {
                    continue;
                }
                let theta = 2.0 * (rho / std::f64::consts::SQRT_2).min(1.0).asin();
                let phi = dy.atan2(dx);
                let (st, ct) = theta.sin_cos();
                let dir = glam::DVec3::new(st * phi.cos(), st * phi.sin(), ct);
                if let Some(cell) = self.grid.locate(dir) {
                    let at = 3 * (py * width + px) as usize;
                    buf[at..at + 3].copy_from_slice(&colours[cell]);
                }
            }
        }
    }

    /// Pixel of the direction at polar angle `theta_deg`, azimuth `phi_deg`.
    fn pixel(theta_deg: f64, phi_deg: f64) -> (i32, i32) {
        let rho = MAP_R * equal_area_radius(theta_deg.to_radians());
        let (s, c) = phi_deg.to_radians().sin_cos();
        (
            (MAP_CX + rho * c).round() as i32,
            (MAP_CY - rho * s).round() as i32,
        )
    }

    /// Render to PNG bytes (760 x 720 pixels).
    ///
    /// # Errors
    /// If drawing or encoding fails.
    pub fn to_png(&self) -> anyhow::Result<Vec<u8>> {
        let img = self.to_image()?;
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
        Ok(png)
    }

    /// The picture as an RGB image.
    ///
    /// # Errors
    /// If drawing fails.
    pub fn to_image(&self) -> anyhow::Result<image::RgbImage> {
        register_font();
        let (w, h) = (MAP_W, MAP_H);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        let range = self.log_range();
        self.paint_disc(&mut buf, w, range);
        // Colour bar: log10 from lo (bottom) to hi (top).
        for py in BAR_Y.0..=BAR_Y.1 {
            let t = f64::from(BAR_Y.1 - py) / f64::from(BAR_Y.1 - BAR_Y.0);
            let c = match self.scale {
                MapScale::Rgb { .. } => {
                    let g = (255.0 * crate::optics::colour::srgb_encode(t)).round() as u8;
                    [g, g, g]
                }
                _ => viridis(t),
            };
            for px in BAR_X.0..=BAR_X.1 {
                let at = 3 * (py * w + px) as usize;
                buf[at..at + 3].copy_from_slice(&c);
            }
        }
        self.overlay(&mut buf, range)
            .map_err(|e| anyhow::anyhow!("hemisphere map: {e}"))?;
        image::RgbImage::from_raw(w, h, buf)
            .ok_or_else(|| anyhow::anyhow!("hemisphere map: buffer size"))
    }

    /// Rings, ticks, markers, labels, title and the colour bar's scale.
    fn overlay(&self, buf: &mut [u8], (lo, hi): (f64, f64)) -> Result<(), String> {
        use plotters::style::text_anchor::{HPos, Pos, VPos};
        let root = BitMapBackend::with_buffer(buf, (MAP_W, MAP_H)).into_drawing_area();
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        let text = |size: u32, colour: RGBColor, h: HPos| {
            ("sans-serif", size)
                .into_font()
                .color(&colour)
                .pos(Pos::new(h, VPos::Center))
        };
        let (cx, cy) = (MAP_CX.round() as i32, MAP_CY.round() as i32);
        // Rings of constant theta; labels along phi = 90 degrees.
        for (deg, colour) in [(30.0, WHITE), (60.0, WHITE), (90.0, BLACK)] {
            let r = (MAP_R * equal_area_radius(f64::to_radians(deg))).round() as i32;
            root.draw(&Circle::new((cx, cy), r, colour.stroke_width(1)))
                .map_err(e)?;
            root.draw(&Text::new(
                format!("θ = {deg}°"),
                (cx, cy - r + 11),
                text(13, WHITE, HPos::Center),
            ))
            .map_err(e)?;
        }
        // Azimuth ticks and labels outside the rim.
        for k in 0..12 {
            let phi = f64::from(k) * 30.0;
            let (s, c) = phi.to_radians().sin_cos();
            let at = |rr: f64| {
                (
                    (MAP_CX + rr * c).round() as i32,
                    (MAP_CY - rr * s).round() as i32,
                )
            };
            root.draw(&PathElement::new(
                vec![at(MAP_R), at(MAP_R + 9.0)],
                BLACK.stroke_width(2),
            ))
            .map_err(e)?;
            let h = if c > 0.3 {
                HPos::Left
            } else if c < -0.3 {
                HPos::Right
            } else {
                HPos::Center
            };
            root.draw(&Text::new(
                format!("{phi}°"),
                at(MAP_R + 14.0),
                text(14, BLACK, h),
            ))
            .map_err(e)?;
        }
        // Specular direction and the direction toward the light.
        let spec = Self::pixel(self.theta_i_deg, self.phi_i_deg + 180.0);
        root.draw(&Circle::new(spec, 15, BLACK.stroke_width(4)))
            .map_err(e)?;
        root.draw(&Circle::new(spec, 15, WHITE.stroke_width(2)))
            .map_err(e)?;
        let light = Self::pixel(self.theta_i_deg, self.phi_i_deg);
        if self.theta_i_deg > 0.0 {
            for (a, b) in [((-7, -7), (7, 7)), ((-7, 7), (7, -7))] {
                let p = |d: (i32, i32)| (light.0 + d.0, light.1 + d.1);
                root.draw(&PathElement::new(vec![p(a), p(b)], BLACK.stroke_width(4)))
                    .map_err(e)?;
                root.draw(&PathElement::new(vec![p(a), p(b)], WHITE.stroke_width(2)))
                    .map_err(e)?;
            }
        }
        // Title and legend.
        root.draw(&Text::new(
            self.title.clone(),
            (MAP_W as i32 / 2, 22),
            text(19, BLACK, HPos::Center),
        ))
        .map_err(e)?;
        let lines = [
            "outgoing directions over the hemisphere, equal-area projection (radius ∝ sin(θ/2));"
                .to_string(),
            format!(
                "θ from the surface normal (centre), azimuth φ from the x axis; light at θ = {}°, φ = {}°",
                self.theta_i_deg, self.phi_i_deg
            ),
            "ring: specular direction, cross: toward the light".to_string(),
        ];
        for (k, l) in lines.iter().enumerate() {
            root.draw(&Text::new(
                l.clone(),
                (MAP_W as i32 / 2, 50 + 18 * k as i32),
                text(13, BLACK, HPos::Center),
            ))
            .map_err(e)?;
        }
        // Colour bar frame, decade ticks and label.
        let (bx0, bx1) = (BAR_X.0 as i32, BAR_X.1 as i32);
        let (by0, by1) = (BAR_Y.0 as i32, BAR_Y.1 as i32);
        root.draw(&Rectangle::new(
            [(bx0 - 1, by0 - 1), (bx1 + 1, by1 + 1)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?;
        let (label, kind) = match &self.scale {
            MapScale::LogBrdf => ("BRDF (1/sr)".to_string(), "log scale"),
            MapScale::Linear { label, .. } => (label.clone(), "linear scale"),
            MapScale::Rgb { label, .. } => (label.clone(), "log scale"),
        };
        root.draw(&Text::new(
            label,
            ((bx0 + bx1) / 2, by0 - 28),
            text(14, BLACK, HPos::Center),
        ))
        .map_err(e)?;
        root.draw(&Text::new(
            kind.to_string(),
            ((bx0 + bx1) / 2, by0 - 12),
            text(12, BLACK, HPos::Center),
        ))
        .map_err(e)?;
        let y_of = |l: f64| by1 - ((l - lo) / (hi - lo) * f64::from(by1 - by0)).round() as i32;
        if let MapScale::Linear { .. } = self.scale {
            for q in 0..=4 {
                let l = lo + (hi - lo) * f64::from(q) / 4.0;
                let y = y_of(l);
                root.draw(&PathElement::new(
                    vec![(bx1 + 1, y), (bx1 + 6, y)],
                    BLACK.stroke_width(1),
                ))
                .map_err(e)?;
                root.draw(&Text::new(
                    format!("{l:.2}"),
                    (bx1 + 9, y),
                    text(13, BLACK, HPos::Left),
                ))
                .map_err(e)?;
            }
            root.present().map_err(e)?;
            return Ok(());
        }
        let mut decade = lo.ceil() as i32;
        let mut ticks: Vec<f64> = Vec::new();
        while f64::from(decade) <= hi + 1e-9 {
            ticks.push(f64::from(decade));
            decade += 1;
        }
        if ticks.len() < 2 {
            // Less than a decade: label the ends too.
            ticks.extend([lo, hi]);
        }
        for l in ticks {
            let y = y_of(l);
            root.draw(&PathElement::new(
                vec![(bx1 + 1, y), (bx1 + 6, y)],
                BLACK.stroke_width(1),
            ))
            .map_err(e)?;
            let label = if (l - l.round()).abs() < 1e-9 {
                format!("1e{}", l.round() as i32)
            } else {
                format!("{:.3}", 10f64.powf(l))
            };
            root.draw(&Text::new(label, (bx1 + 9, y), text(13, BLACK, HPos::Left)))
                .map_err(e)?;
        }
        root.present().map_err(e)?;
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
            let plot = LinePlot {
                title: "degenerate".into(),
                x_label: "x".into(),
                y_label: "y".into(),
                log_y: true,
                series: vec![Series {
                    label: "a".into(),
                    points,
                }],
            };
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || tx.send(plot.to_png(320, 200).map(|p| p.len())));
            let len = rx
                .recv_timeout(std::time::Duration::from_secs(60))
                .expect("the plot finishes within a minute")
                .expect("the plot is drawn");
            assert!(len > 0);
        }
    }

    fn constant_map(m: usize, v: f64, theta_i_deg: f64) -> HemisphereMap {
        let grid = crate::tally::CarlsonGrid::new(m).unwrap();
        HemisphereMap {
            title: "test".into(),
            grid,
            brdf: vec![v; grid.n_cells()],
            scale: MapScale::LogBrdf,
            theta_i_deg,
            phi_i_deg: 0.0,
        }
    }

    /// A Lambertian (constant) BRDF paints the disc in one colour, the
    /// middle of the one-decade range: every pixel on three circles between
    /// the rings (theta = 15, 45, 75 degrees) over the lower half of the
    /// disc, away from the labels and the markers, is exactly that colour.
    #[test]
    fn lambertian_map_is_one_colour() {
        let map = constant_map(16, 0.7 / std::f64::consts::PI, 40.0);
        let png = map.to_png().unwrap();
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!((img.width(), img.height()), (MAP_W, MAP_H));
        let expect = viridis(0.5);
        let mut n = 0;
        for theta in [15.0, 45.0, 75.0] {
            for k in 0..=160 {
                let phi = 190.0 + f64::from(k); // 190..350 degrees
                let (x, y) = HemisphereMap::pixel(theta, phi);
                assert_eq!(
                    img.get_pixel(x as u32, y as u32).0,
                    expect,
                    "theta {theta} phi {phi}"
                );
                n += 1;
            }
        }
        assert_eq!(n, 483);
        // Outside the disc, beyond the labels: white.
        assert_eq!(img.get_pixel(5, MAP_H - 5).0, [255, 255, 255]);
    }

    /// Equal area: with the first k of M bands at one value and the rest at
    /// another, the high-value pixels fill the fraction k (k + 1) / (M (M + 1))
    /// of the disc (their solid angle over 2 pi), to the pixels the two
    /// circles cross (at most 4 (2 r + 2) for a circle of radius r pixels).
    #[test]
    fn equal_area_projection() {
        let (m, k) = (32, 20);
        let mut map = constant_map(m, 0.1, 0.0);
        for (flat, v) in map.brdf.iter_mut().enumerate() {
            if map.grid.band_cell(flat).0 <= k {
                *v = 10.0;
            }
        }
        let mut buf = vec![255u8; (MAP_W * MAP_H * 3) as usize];
        map.paint_disc(&mut buf, MAP_W, map.log_range());
        let high = viridis(1.0);
        let low = viridis(0.0);
        let (mut nh, mut nl) = (0.0, 0.0);
        for p in buf.chunks_exact(3) {
            if p == high {
                nh += 1.0;
            } else if p == low {
                nl += 1.0;
            }
        }
        let frac = (k * (k + 1)) as f64 / (m * (m + 1)) as f64;
        let r_in = MAP_R * frac.sqrt();
        let area = std::f64::consts::PI * MAP_R * MAP_R;
        let bound_in = 4.0 * (2.0 * r_in + 2.0);
        let bound_all = bound_in + 4.0 * (2.0 * MAP_R + 2.0);
        assert!(
            (nh - frac * area).abs() <= bound_in,
            "{nh} vs {}",
            frac * area
        );
        assert!(
            (nh + nl - area).abs() <= 4.0 * (2.0 * MAP_R + 2.0),
            "{} vs {area}",
            nh + nl
        );
        assert!((nl - (1.0 - frac) * area).abs() <= bound_all);
    }
}
