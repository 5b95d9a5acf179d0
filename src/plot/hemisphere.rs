//! Equal-area maps of a quantity over the hemisphere of outgoing directions
//! ([`HemisphereMap`]): `hemisphere_*`, `dop_*` and `colour_*` pictures.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{TickFormat, encode_png, log_ticks, register_font, ticks};
use crate::tally::CarlsonGrid;

/// The two colours of the stripes that fill a cell without a value (no
/// photon, or a ratio without light): a pattern that no colour scale has,
/// explained by a key beside the colour bar.
pub const NO_VALUE: [[u8; 3]; 2] = [[190, 190, 190], [110, 110, 110]];

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

/// Normalised radius in the disc (0 centre, 1 rim) of polar angle `theta`
/// (radians): `sqrt(2) sin(theta / 2)`.
pub(super) fn equal_area_radius(theta: f64) -> f64 {
    std::f64::consts::SQRT_2 * (0.5 * theta).sin()
}

/// Paint the disc of centre `(cx, cy)` and radius `r` (pixels) into an RGB
/// buffer of `width` pixels per row: every pixel whose centre lies in the
/// disc takes the colour of the Carlson cell of `grid` holding its
/// direction (equal-area projection, see [`HemisphereMap`]), or the
/// [`NO_VALUE`] stripes where the cell has none.
pub(super) fn paint_disc(
    buf: &mut [u8],
    width: u32,
    (cx, cy, r): (f64, f64, f64),
    grid: &CarlsonGrid,
    colours: &[Option<[u8; 3]>],
) {
    let (y0, y1) = ((cy - r).floor().max(0.0) as u32, (cy + r).ceil() as u32);
    let (x0, x1) = ((cx - r).floor().max(0.0) as u32, (cx + r).ceil() as u32);
    let height = buf.len() as u32 / (3 * width);
    for py in y0..=y1.min(height - 1) {
        for px in x0..=x1.min(width - 1) {
            let (dx, dy) = (f64::from(px) + 0.5 - cx, cy - (f64::from(py) + 0.5));
            let rho = dx.hypot(dy) / r;
            if rho > 1.0 {
                continue;
            }
            let theta = 2.0 * (rho / std::f64::consts::SQRT_2).min(1.0).asin();
            let phi = dy.atan2(dx);
            let (st, ct) = theta.sin_cos();
            let dir = glam::DVec3::new(st * phi.cos(), st * phi.sin(), ct);
            if let Some(cell) = grid.locate(dir) {
                let c = colours[cell].unwrap_or(NO_VALUE[(((px + py) / 4) % 2) as usize]);
                let at = 3 * (py * width + px) as usize;
                buf[at..at + 3].copy_from_slice(&c);
            }
        }
    }
}

/// A quantity over the hemisphere of outgoing directions as an equal-area
/// polar map.
///
/// The hemisphere is drawn in the Lambert azimuthal equal-area projection:
/// the direction at polar angle `theta` and azimuth `phi` is at radius
/// `R sqrt(2) sin(theta / 2)` (the normal at the centre, the horizon on the
/// rim, `R` the disc's radius in pixels) and angle `phi`, counter-clockwise
/// from the right (`phi = 0`, +x). Equal areas on the picture are equal solid
/// angles, so every Carlson cell covers the same number of pixels. Each
/// pixel takes the colour of the cell holding its direction (see
/// [`MapScale`]); a cell without a value (NaN: no photon, or a ratio without
/// light) is striped in [`NO_VALUE`], with a key labelled
/// [`HemisphereMap::empty_label`]. Rings mark `theta = 30, 60, 90` degrees,
/// ticks every 30 degrees of azimuth; a white ring with a black outline
/// around the specular direction (open, so the cells there stay visible)
/// and a cross on the direction toward the light.
#[derive(Debug, Clone)]
pub struct HemisphereMap {
    /// Title (top line).
    pub title: String,
    /// The grid of `values`.
    pub grid: CarlsonGrid,
    /// The quantity per flat cell of `grid`, cells at absolute azimuths
    /// (a BRDF in 1/sr, or that of [`HemisphereMap::scale`]); NaN for none.
    pub values: Vec<f64>,
    /// How values map to colours.
    pub scale: MapScale,
    /// What a cell without a value means (the key's label, e.g. "no photon").
    pub empty_label: String,
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees); the specular direction is at `phi_i + 180`.
    pub phi_i_deg: f64,
}

/// Colour scale of a [`HemisphereMap`].
#[derive(Debug, Clone, PartialEq)]
pub enum MapScale {
    /// Viridis on `log10` of a BRDF (1/sr), over at most 4 decades below
    /// the largest value; smaller positive values take the lowest colour.
    LogBrdf,
    /// Given display colours per cell (a colour map): `values` holds the
    /// quantity whose log10 the colour bar's range shows (four decades
    /// below its largest value), labelled `label`; the bar is a grey ramp.
    Rgb {
        /// Colour-bar label (without "log": the bar says it).
        label: String,
        /// 8-bit sRGB per flat cell.
        colours: Vec<[u8; 3]>,
    },
    /// Viridis on a linear quantity over `[lo, hi]` (e.g. the degree of
    /// polarisation over the range of its values), labelled `label`.
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
const MAP_W: u32 = 780;
const MAP_H: u32 = 720;
const MAP_R: f64 = 260.0;
const MAP_CX: f64 = 330.0;
const MAP_CY: f64 = 390.0;
const BAR_X: (u32, u32) = (655, 680);
const BAR_Y: (u32, u32) = (170, 570);
/// The key of cells without a value: a striped square below the bar.
const KEY: (i32, i32, i32) = (655, 610, 22);

impl HemisphereMap {
    /// Colour range: `(lo, hi)` of a linear scale; `(log10 lo, log10 hi)`
    /// otherwise, the largest value and at most 4 decades below it, down to
    /// the smallest positive value; one decade about a constant; `(-1, 0)`
    /// if nothing is positive.
    fn range(&self) -> (f64, f64) {
        if let MapScale::Linear { lo, hi, .. } = &self.scale {
            return if hi > lo {
                (*lo, *hi)
            } else {
                (*lo - 0.5, *lo + 0.5)
            };
        }
        let pos = self
            .values
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

    /// Whether cell values are shown on a log scale.
    fn log(&self) -> bool {
        !matches!(self.scale, MapScale::Linear { .. })
    }

    /// The colour of every cell (`None`: no value).
    #[must_use]
    pub fn cell_colours(&self) -> Vec<Option<[u8; 3]>> {
        let (lo, hi) = self.range();
        self.values
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                if v.is_nan() {
                    return None;
                }
                Some(match &self.scale {
                    MapScale::Rgb { colours, .. } => colours[k],
                    MapScale::Linear { .. } => viridis((v - lo) / (hi - lo)),
                    MapScale::LogBrdf if v > 0.0 => viridis((v.log10() - lo) / (hi - lo)),
                    MapScale::LogBrdf => viridis(0.0),
                })
            })
            .collect()
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

    /// Render to PNG bytes (780 x 720 pixels).
    ///
    /// # Errors
    /// If drawing or encoding fails.
    pub fn to_png(&self) -> anyhow::Result<Vec<u8>> {
        encode_png(MAP_W, MAP_H, self.to_buffer()?)
    }

    /// The picture as an RGB buffer.
    fn to_buffer(&self) -> anyhow::Result<Vec<u8>> {
        register_font();
        let (w, h) = (MAP_W, MAP_H);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        let colours = self.cell_colours();
        paint_disc(&mut buf, w, (MAP_CX, MAP_CY, MAP_R), &self.grid, &colours);
        // Colour bar from lo (bottom) to hi (top).
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
        if colours.iter().any(Option::is_none) {
            let (kx, ky, ks) = KEY;
            for py in ky..ky + ks {
                for px in kx..kx + ks {
                    let at = 3 * (py as u32 * w + px as u32) as usize;
                    buf[at..at + 3].copy_from_slice(&NO_VALUE[(((px + py) / 4) % 2) as usize]);
                }
            }
        }
        self.overlay(&mut buf, colours.iter().any(Option::is_none))
            .map_err(|e| anyhow::anyhow!("hemisphere map: {e}"))?;
        Ok(buf)
    }

    /// Rings, ticks, markers, labels, title, the colour bar's scale and the
    /// key of cells without a value.
    fn overlay(&self, buf: &mut [u8], key: bool) -> Result<(), super::DrawError> {
        let root = BitMapBackend::with_buffer(buf, (MAP_W, MAP_H)).into_drawing_area();
        self.draw_axes(&root)?;
        self.draw_heading(&root)?;
        self.draw_colour_bar(&root, key)?;
        root.present()?;
        Ok(())
    }

    /// Black or white sans-serif text of `size` pixels, anchored at `h`
    /// and centred vertically on its position.
    fn text(size: u32, colour: RGBColor, h: HPos) -> TextStyle<'static> {
        ("sans-serif", size)
            .into_font()
            .color(&colour)
            .pos(Pos::new(h, VPos::Center))
    }

    /// Rings of constant theta, azimuth ticks and their labels, and the
    /// markers of the specular direction and of the direction toward the
    /// light.
    fn draw_axes(
        &self,
        root: &DrawingArea<BitMapBackend<'_>, Shift>,
    ) -> Result<(), super::DrawError> {
        let text = Self::text;
        let (cx, cy) = (MAP_CX.round() as i32, MAP_CY.round() as i32);
        // Rings of constant theta; labels along phi = 90 degrees.
        for (deg, colour) in [(30.0, WHITE), (60.0, WHITE), (90.0, BLACK)] {
            let r = (MAP_R * equal_area_radius(f64::to_radians(deg))).round() as i32;
            root.draw(&Circle::new((cx, cy), r, colour.stroke_width(1)))?;
            root.draw(&Text::new(
                format!("θ = {deg}°"),
                (cx, cy - r + 11),
                text(13, WHITE, HPos::Center),
            ))?;
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
            ))?;
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
            ))?;
        }
        // Specular direction and the direction toward the light.
        let spec = Self::pixel(self.theta_i_deg, self.phi_i_deg + 180.0);
        root.draw(&Circle::new(spec, 15, BLACK.stroke_width(4)))?;
        root.draw(&Circle::new(spec, 15, WHITE.stroke_width(2)))?;
        let light = Self::pixel(self.theta_i_deg, self.phi_i_deg);
        if self.theta_i_deg > 0.0 {
            for (a, b) in [((-7, -7), (7, 7)), ((-7, 7), (7, -7))] {
                let p = |d: (i32, i32)| (light.0 + d.0, light.1 + d.1);
                root.draw(&PathElement::new(vec![p(a), p(b)], BLACK.stroke_width(4)))?;
                root.draw(&PathElement::new(vec![p(a), p(b)], WHITE.stroke_width(2)))?;
            }
        }
        Ok(())
    }

    /// The title and, below it, the legend of the projection and markers.
    fn draw_heading(
        &self,
        root: &DrawingArea<BitMapBackend<'_>, Shift>,
    ) -> Result<(), super::DrawError> {
        let text = Self::text;
        let title = super::title_lines(&self.title, 80);
        for (k, l) in title.iter().enumerate() {
            root.draw(&Text::new(
                l.clone(),
                (MAP_W as i32 / 2, 18 + 20 * k as i32),
                text(if k == 0 { 17 } else { 14 }, BLACK, HPos::Center),
            ))?;
        }
        let below = 50 + 16 * (title.len() as i32 - 1);
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
                (MAP_W as i32 / 2, below + 17 * k as i32),
                text(13, BLACK, HPos::Center),
            ))?;
        }
        Ok(())
    }

    /// The colour bar's frame, label, scale and ticks, and (`key`: some
    /// cell has no value) the key of the cells without a value.
    fn draw_colour_bar(
        &self,
        root: &DrawingArea<BitMapBackend<'_>, Shift>,
        key: bool,
    ) -> Result<(), super::DrawError> {
        let text = Self::text;
        let (lo, hi) = self.range();
        let (bx0, bx1) = (BAR_X.0 as i32, BAR_X.1 as i32);
        let (by0, by1) = (BAR_Y.0 as i32, BAR_Y.1 as i32);
        root.draw(&Rectangle::new(
            [(bx0 - 1, by0 - 1), (bx1 + 1, by1 + 1)],
            BLACK.stroke_width(1),
        ))?;
        let (label, kind) = match &self.scale {
            MapScale::LogBrdf => ("BRDF (1/sr)".to_string(), "log scale"),
            MapScale::Linear { label, .. } => (label.clone(), "linear scale"),
            MapScale::Rgb { label, .. } => (label.clone(), "log scale"),
        };
        root.draw(&Text::new(
            label,
            ((bx0 + bx1) / 2, by0 - 28),
            text(14, BLACK, HPos::Center),
        ))?;
        root.draw(&Text::new(
            kind.to_string(),
            ((bx0 + bx1) / 2, by0 - 12),
            text(12, BLACK, HPos::Center),
        ))?;
        let y_of = |l: f64| by1 - ((l - lo) / (hi - lo) * f64::from(by1 - by0)).round() as i32;
        for (l, label) in self.bar_ticks() {
            let y = y_of(l);
            root.draw(&PathElement::new(
                vec![(bx1 + 1, y), (bx1 + 6, y)],
                BLACK.stroke_width(1),
            ))?;
            root.draw(&Text::new(label, (bx1 + 9, y), text(13, BLACK, HPos::Left)))?;
        }
        if key {
            let (kx, ky, ks) = KEY;
            root.draw(&Rectangle::new(
                [(kx - 1, ky - 1), (kx + ks, ky + ks)],
                BLACK.stroke_width(1),
            ))?;
            root.draw(&Text::new(
                self.empty_label.clone(),
                (kx - 20, ky + ks + 14),
                text(13, BLACK, HPos::Left),
            ))?;
        }
        Ok(())
    }

    /// The colour bar's ticks: position on the bar's range and label
    /// (unique; on a log scale [`log_ticks`]).
    #[must_use]
    pub fn bar_ticks(&self) -> Vec<(f64, String)> {
        let (lo, hi) = self.range();
        let mut t: Vec<f64> = if self.log() {
            log_ticks(lo, hi, 8)
        } else {
            ticks(lo, hi, 6)
        };
        t.retain(|v| (lo - 1e-9..=hi + 1e-9).contains(v));
        let f = TickFormat::for_ticks(&t, self.log());
        t.iter().map(|&v| (v, f.label(v))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant_map(m: usize, v: f64, theta_i_deg: f64) -> HemisphereMap {
        let grid = CarlsonGrid::new(m).unwrap();
        HemisphereMap {
            title: "test".into(),
            grid,
            values: vec![v; grid.n_cells()],
            scale: MapScale::LogBrdf,
            empty_label: "no photon".into(),
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
        for (flat, v) in map.values.iter_mut().enumerate() {
            if map.grid.band_cell(flat).0 <= k {
                *v = 10.0;
            }
        }
        let mut buf = vec![255u8; (MAP_W * MAP_H * 3) as usize];
        paint_disc(
            &mut buf,
            MAP_W,
            (MAP_CX, MAP_CY, MAP_R),
            &map.grid,
            &map.cell_colours(),
        );
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

    /// A cell without a value is striped in colours far from every colour
    /// of the scale (the viridis bar), and the key explains it: the map's
    /// pixels at such a cell are NO_VALUE colours, the key square holds
    /// both, and a map with every cell valued has no key.
    #[test]
    fn cells_without_photons_are_not_on_the_scale() {
        for c in NO_VALUE {
            for k in 0..=1000 {
                let v = viridis(f64::from(k) / 1000.0);
                let d: f64 = (0..3)
                    .map(|i| (f64::from(c[i]) - f64::from(v[i])).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(d > 60.0, "{c:?} near viridis {v:?}");
            }
        }
        let mut map = constant_map(8, 0.3, 0.0);
        // The whole outer band has no photon.
        let outer: Vec<usize> = (0..map.grid.n_cells())
            .filter(|&f| map.grid.band_cell(f).0 == 8)
            .collect();
        for &f in &outer {
            map.values[f] = f64::NAN;
        }
        let img = image::load_from_memory(&map.to_png().unwrap())
            .unwrap()
            .to_rgb8();
        // theta = 88 degrees: in band 8 of 8.
        for phi in [200.0, 250.0, 300.0] {
            let (x, y) = HemisphereMap::pixel(88.0, phi);
            assert!(
                NO_VALUE.contains(&img.get_pixel(x as u32, y as u32).0),
                "phi {phi}"
            );
        }
        let (kx, ky, ks) = KEY;
        let key: Vec<[u8; 3]> = (ky..ky + ks)
            .flat_map(|y| (kx..kx + ks).map(move |x| (x, y)))
            .map(|(x, y)| img.get_pixel(x as u32, y as u32).0)
            .collect();
        assert!(NO_VALUE.iter().all(|c| key.contains(c)));
        // Nothing missing: no key.
        let full = constant_map(8, 0.3, 0.0);
        let img = image::load_from_memory(&full.to_png().unwrap())
            .unwrap()
            .to_rgb8();
        assert!(!(ky..ky + ks).any(|y| img.get_pixel(kx as u32 + 2, y as u32).0 == NO_VALUE[1]));
    }

    /// A linear scale spans the given range (the data's, e.g. DoP 0 to
    /// 0.18, not 0 to 1) with unique labels inside it; a log bar's labels
    /// are unique too, even under a decade.
    #[test]
    fn bar_ticks_fit_the_range_and_are_unique() {
        let mut map = constant_map(4, 0.1, 0.0);
        map.scale = MapScale::Linear {
            label: "degree of polarisation".into(),
            lo: 0.0,
            hi: 0.18,
        };
        let t = map.bar_ticks();
        assert!(t.len() >= 3, "{t:?}");
        assert!(t.iter().all(|(v, _)| (0.0..=0.18).contains(v)));
        for m in [&map, &constant_map(4, 0.1, 0.0)] {
            let ticks = m.bar_ticks();
            let labels: Vec<&str> = ticks.iter().map(|t| t.1.as_str()).collect();
            let mut u = labels.clone();
            u.sort();
            u.dedup();
            assert_eq!(u.len(), labels.len(), "{labels:?}");
        }
    }
}
