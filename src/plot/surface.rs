//! The picture of a micro surface ([`SurfacePicture`], `surface.png` of
//! `roks brdf` and `roks stats --png`): its height map seen from above with
//! its statistics.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{TickFormat, encode_png, register_font, ticks, viridis};
use crate::micro::surface_stats::HeightMap;
use crate::output::summary::Surface;

/// Picture size and layout (pixels).
const W: u32 = 980;
const H: u32 = 640;
/// The map's largest side and its top-left corner.
const SIDE: u32 = 520;
const MAP_X: u32 = 90;
const MAP_Y: u32 = 60;
/// Colour bar.
const BAR_X: u32 = 640;

/// A height map seen from above: viridis on height (linear, lowest to
/// highest), x to the right and y up in scene units, a colour bar of
/// heights and the statistics of the map (`roks stats`).
#[derive(Debug, Clone)]
pub struct SurfacePicture<'a> {
    /// Title (top line).
    pub title: String,
    /// The heights (scene units).
    pub map: &'a HeightMap,
    /// Their statistics, as `summary.json` gives them.
    pub stats: Surface<f64>,
}

impl SurfacePicture<'_> {
    /// Picture pixels `(width, height)` of the map: the longer side
    /// [`SIDE`], the aspect of the cell.
    fn map_pixels(&self) -> (u32, u32) {
        let (lx, ly) = (
            self.map.dx * self.map.nx as f64,
            self.map.dy * self.map.ny as f64,
        );
        if lx >= ly {
            (SIDE, ((f64::from(SIDE) * ly / lx).round() as u32).max(1))
        } else {
            (((f64::from(SIDE) * lx / ly).round() as u32).max(1), SIDE)
        }
    }

    /// The lowest and highest height (one unit about a flat map).
    fn range(&self) -> (f64, f64) {
        let (lo, hi) = self
            .map
            .h
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &h| {
                (a.min(h), b.max(h))
            });
        if !lo.is_finite() {
            (0.0, 1.0)
        } else if hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
            (lo - 0.5, hi + 0.5)
        } else {
            (lo, hi)
        }
    }

    /// The statistics as lines of text.
    #[must_use]
    pub fn stats_lines(&self) -> Vec<String> {
        let s = &self.stats;
        let num = |x: Option<f64>| x.map_or_else(|| "undefined".to_owned(), |v| format!("{v:.4}"));
        let mut lines = vec![
            format!("height map {} x {} samples", self.map.nx, self.map.ny),
            format!("σ (RMS height) = {}", num(s.sigma)),
            format!("τ (correlation length) = {}", num(s.tau)),
            format!("σ/τ = {}", num(s.sigma_over_tau)),
            format!("RMS slope = {}", num(s.rms_slope)),
            format!("mean height = {}", num(s.mean_height)),
            format!(
                "lowest / highest = {} / {}",
                num(s.min_height),
                num(s.max_height)
            ),
            "lengths in scene units".to_owned(),
        ];
        if let Some(u) = &s.undefined {
            lines.push(format!("τ {}", u.tau));
        }
        lines
    }

    /// Render to PNG bytes (980 x 640 pixels).
    ///
    /// # Errors
    /// If drawing or encoding fails.
    pub fn to_png(&self) -> anyhow::Result<Vec<u8>> {
        register_font();
        let mut buf = vec![255u8; (W * H * 3) as usize];
        let (pw, ph) = self.map_pixels();
        let (lo, hi) = self.range();
        let (nx, ny) = (self.map.nx, self.map.ny);
        for py in 0..ph {
            // y up: the top row of the picture is the largest y.
            let iy = ((f64::from(ph - 1 - py) + 0.5) / f64::from(ph) * ny as f64) as usize;
            for px in 0..pw {
                let ix = ((f64::from(px) + 0.5) / f64::from(pw) * nx as f64) as usize;
                let h = self.map.h[iy.min(ny - 1) * nx + ix.min(nx - 1)];
                let c = viridis((h - lo) / (hi - lo));
                let at = 3 * ((MAP_Y + py) * W + MAP_X + px) as usize;
                buf[at..at + 3].copy_from_slice(&c);
            }
        }
        for py in 0..SIDE {
            let c = viridis(f64::from(SIDE - 1 - py) / f64::from(SIDE - 1));
            for px in BAR_X..BAR_X + 24 {
                let at = 3 * ((MAP_Y + py) * W + px) as usize;
                buf[at..at + 3].copy_from_slice(&c);
            }
        }
        self.overlay(&mut buf, (pw, ph), (lo, hi))
            .map_err(|e| anyhow::anyhow!("surface picture: {e}"))?;
        encode_png(W, H, buf)
    }

    fn overlay(
        &self,
        buf: &mut [u8],
        (pw, ph): (u32, u32),
        (lo, hi): (f64, f64),
    ) -> Result<(), super::DrawError> {
        let root = BitMapBackend::with_buffer(buf, (W, H)).into_drawing_area();
        root.draw(&Text::new(
            self.title.clone(),
            (W as i32 / 2, 22),
            text(18, HPos::Center, VPos::Center),
        ))?;
        self.draw_map_axes(&root, (pw, ph))?;
        draw_height_bar(&root, (lo, hi))?;
        let y0 = MAP_Y as i32;
        for (k, l) in self.stats_lines().iter().enumerate() {
            root.draw(&Text::new(
                l.clone(),
                (BAR_X as i32 + 110, y0 + 10 + 24 * k as i32),
                text(14, HPos::Left, VPos::Center),
            ))?;
        }
        root.present()?;
        Ok(())
    }

    /// The frame of the map (`pw x ph` pixels), its x and y ticks in
    /// scene units, and the axis labels.
    fn draw_map_axes(
        &self,
        root: &DrawingArea<BitMapBackend<'_>, Shift>,
        (pw, ph): (u32, u32),
    ) -> Result<(), super::DrawError> {
        let (x0, y0) = (MAP_X as i32, MAP_Y as i32);
        let (x1, y1) = (x0 + pw as i32, y0 + ph as i32);
        root.draw(&Rectangle::new(
            [(x0 - 1, y0 - 1), (x1, y1)],
            BLACK.stroke_width(1),
        ))?;
        let (lx, ly) = (
            self.map.dx * self.map.nx as f64,
            self.map.dy * self.map.ny as f64,
        );
        let tx = ticks(0.0, lx, 6);
        let fx = TickFormat::for_ticks(&tx, false);
        for t in &tx {
            let x = x0 + (t / lx * f64::from(pw)).round() as i32;
            root.draw(&PathElement::new(
                vec![(x, y1), (x, y1 + 6)],
                BLACK.stroke_width(1),
            ))?;
            root.draw(&Text::new(
                fx.label(*t),
                (x, y1 + 9),
                text(13, HPos::Center, VPos::Top),
            ))?;
        }
        let ty = ticks(0.0, ly, 6);
        let fy = TickFormat::for_ticks(&ty, false);
        for t in &ty {
            let y = y1 - (t / ly * f64::from(ph)).round() as i32;
            root.draw(&PathElement::new(
                vec![(x0 - 7, y), (x0 - 1, y)],
                BLACK.stroke_width(1),
            ))?;
            root.draw(&Text::new(
                fy.label(*t),
                (x0 - 10, y),
                text(13, HPos::Right, VPos::Center),
            ))?;
        }
        root.draw(&Text::new(
            "x (scene units)",
            ((x0 + x1) / 2, y1 + 30),
            text(14, HPos::Center, VPos::Top),
        ))?;
        root.draw(&Text::new(
            "y (scene units)",
            (x0 - 60, (y0 + y1) / 2),
            ("sans-serif", 14)
                .into_font()
                .color(&BLACK)
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        ))?;
        Ok(())
    }
}

/// Black sans-serif text of `size` pixels anchored at `(h, v)`.
fn text(size: u32, h: HPos, v: VPos) -> TextStyle<'static> {
    ("sans-serif", size)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(h, v))
}

/// The colour bar of heights `lo..=hi` (scene units): frame, label and
/// ticks.
fn draw_height_bar(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    (lo, hi): (f64, f64),
) -> Result<(), super::DrawError> {
    let (bx, by0, by1) = (BAR_X as i32, MAP_Y as i32, MAP_Y as i32 + SIDE as i32 - 1);
    root.draw(&Rectangle::new(
        [(bx - 1, by0 - 1), (bx + 24, by1 + 1)],
        BLACK.stroke_width(1),
    ))?;
    root.draw(&Text::new(
        "height (scene units)",
        (bx + 12, by0 - 14),
        text(14, HPos::Center, VPos::Center),
    ))?;
    let th: Vec<f64> = ticks(lo, hi, 6)
        .into_iter()
        .filter(|t| (lo..=hi).contains(t))
        .collect();
    let fh = TickFormat::for_ticks(&th, false);
    for t in &th {
        let y = by1 - ((t - lo) / (hi - lo) * f64::from(SIDE - 1)).round() as i32;
        root.draw(&PathElement::new(
            vec![(bx + 24, y), (bx + 30, y)],
            BLACK.stroke_width(1),
        ))?;
        root.draw(&Text::new(
            fh.label(*t),
            (bx + 33, y),
            text(13, HPos::Left, VPos::Center),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(nx: usize, ny: usize, dx: f64, dy: f64) -> HeightMap {
        HeightMap {
            nx,
            ny,
            dx,
            dy,
            h: (0..nx * ny).map(|k| (k % nx) as f64 * dx).collect(),
            periodic: true,
        }
    }

    fn picture(map: &HeightMap) -> SurfacePicture<'_> {
        let stats = Surface::new(&crate::micro::surface_stats::surface_stats(map), map.nx);
        SurfacePicture {
            title: "test".into(),
            map,
            stats,
        }
    }

    /// A ramp rising along x: the left column is the lowest colour, the
    /// right the highest; an oblong cell keeps its aspect; the statistics
    /// are listed.
    #[test]
    fn the_map_shows_heights_in_place() {
        let m = map(64, 32, 1.0, 1.0);
        let p = picture(&m);
        assert_eq!(p.map_pixels(), (SIDE, SIDE / 2));
        let img = image::load_from_memory(&p.to_png().unwrap())
            .unwrap()
            .to_rgb8();
        let mid = MAP_Y + SIDE / 4;
        assert_eq!(img.get_pixel(MAP_X + 2, mid).0, viridis(0.0));
        assert_eq!(img.get_pixel(MAP_X + SIDE - 3, mid).0, viridis(1.0));
        assert!(
            p.stats_lines()
                .iter()
                .any(|l| l.starts_with("σ (RMS height)"))
        );
    }
}
