//! PNG pictures a person can read, and that tell the truth: titles,
//! labelled axes with units, unique tick labels, legends beside the data,
//! gaps where there is no data, a key for what has no value.
//!
//! Drawn with `plotters` into an RGB buffer and encoded by `image` (png
//! only). The font, DejaVu Sans, is embedded (assets/fonts, free licence), so
//! pictures look the same on every machine and need no system fonts.
//!
//! * [`line`](mod@line): line plots with error bars ([`LinePlot`]).
//! * [`hemisphere`]: equal-area maps over the hemisphere ([`HemisphereMap`]).
//! * [`mueller`]: the 4 x 4 grid of normalised Mueller elements
//!   ([`MuellerMaps`]).
//! * [`surface`]: the height map of a micro surface ([`SurfacePicture`]).
//! * [`folder`]: every picture of a result folder, made from its files
//!   (the one path of `roks brdf`, `merge`, `trace` and `plot`).

use std::sync::Once;

use plotters::prelude::*;

pub mod folder;
pub mod hemisphere;
pub mod line;
pub mod mueller;
pub mod surface;

pub use hemisphere::{HemisphereMap, MapScale, NO_VALUE, viridis};
pub use line::{Grid, LinePlot, Mark, Panel, Series};
pub use mueller::MuellerMaps;
pub use surface::SurfacePicture;

/// `surface.png`: the height map `map` of `scene`'s surface with its
/// statistics `stats`.
///
/// # Errors
/// If the picture cannot be drawn.
pub fn surface_png(
    scene: &crate::scene::micro::MicroScene,
    map: &crate::micro::surface_stats::HeightMap,
    stats: &crate::micro::surface_stats::SurfaceStats,
) -> anyhow::Result<Vec<u8>> {
    SurfacePicture {
        title: format!(
            "{}: the micro surface, one period ({} x {} scene units)",
            scene.name, scene.surface.size.x, scene.surface.size.y
        ),
        map,
        stats: crate::output::summary::Surface::new(stats, map.nx),
    }
    .to_png()
}

/// Why a picture could not be drawn: the drawing library's error on the
/// in-memory bitmap.
pub type DrawError = DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // Registering a valid embedded font cannot fail; ignore the impossible error.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A title as one line, or, past `width` characters, two: before and from
/// its first ` (` (the parenthesis on the second line).
#[must_use]
pub fn title_lines(title: &str, width: usize) -> Vec<String> {
    match title.find(" (") {
        Some(at) if title.chars().count() > width => {
            vec![title[..at].to_owned(), title[at + 1..].to_owned()]
        }
        _ => vec![title.to_owned()],
    }
}

/// An RGB buffer of `width x height` pixels as PNG bytes.
fn encode_png(width: u32, height: u32, buf: Vec<u8>) -> anyhow::Result<Vec<u8>> {
    let img = image::RgbImage::from_raw(width, height, buf)
        .ok_or_else(|| anyhow::anyhow!("plot: buffer size"))?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    Ok(crate::outdir::kind::mark_png(png))
}

/// A rectangle of pixels, `[x0, x1) x [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// Left edge.
    pub x0: i32,
    /// Top edge.
    pub y0: i32,
    /// One past the right edge.
    pub x1: i32,
    /// One past the bottom edge.
    pub y1: i32,
}

impl Rect {
    /// Whether the two rectangles share a pixel.
    #[must_use]
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// Whether pixel `(x, y)` is inside.
    #[must_use]
    pub fn contains(&self, (x, y): (i32, i32)) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// How the tick labels of one axis are written: fixed or exponent form
/// with `decimals` digits after the point; a logarithmic axis's ticks are
/// `log10` of the values and are labelled with `10^tick`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TickFormat {
    /// Exponent form (`2.5e-5`) instead of fixed (`0.25`).
    pub exponent: bool,
    /// Digits after the decimal point.
    pub decimals: usize,
    /// The axis is `log10` of the quantity.
    pub log: bool,
}

impl TickFormat {
    /// The fewest decimals (up to 12) that give every tick in `ticks` its
    /// own label, each reading back to its tick (within a thousandth of
    /// the smallest step); exponent form for quantities below 1e-3 or from
    /// 1e5 in magnitude (and always on a logarithmic axis).
    #[must_use]
    pub fn for_ticks(ticks: &[f64], log: bool) -> Self {
        let values: Vec<f64> = if log {
            ticks.iter().map(|t| 10f64.powf(*t)).collect()
        } else {
            ticks.to_vec()
        };
        let top = values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let exponent = log || (top > 0.0 && !(1e-3..1e5).contains(&top));
        let mut f = Self {
            exponent,
            decimals: 0,
            log,
        };
        let step = values
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min);
        while f.decimals < 12 {
            let labels: Vec<String> = ticks.iter().map(|&t| f.label(t)).collect();
            let mut sorted = labels.clone();
            sorted.sort();
            sorted.dedup();
            let exact = labels.iter().zip(&values).all(|(l, v)| {
                l.parse::<f64>()
                    .is_ok_and(|x| !step.is_finite() || (x - v).abs() <= 1e-3 * step)
            });
            if sorted.len() == labels.len() && exact {
                break;
            }
            f.decimals += 1;
        }
        f
    }

    /// The label of tick `t`.
    #[must_use]
    pub fn label(&self, t: f64) -> String {
        let v = if self.log { 10f64.powf(t) } else { t };
        let d = self.decimals;
        let s = if self.exponent {
            format!("{v:.d$e}")
        } else {
            format!("{v:.d$}")
        };
        // No "-0".
        if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
            s[1..].to_owned()
        } else {
            s
        }
    }
}

/// The tick positions plotters labels on a linear axis over `lo..hi` with
/// at most `n` labels (its bold key points).
#[must_use]
pub fn ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    use plotters::coord::ranged1d::{BoldPoints, Ranged};
    use plotters::coord::types::RangedCoordf64;
    RangedCoordf64::from(lo..hi).key_points(BoldPoints(n))
}

/// Ticks of a logarithmic axis over `lo..hi` (`log10` of the quantity),
/// at most about `n`: whole decades when the range holds two or more
/// (every k-th when too many), else the 1-2-5 (or 1..9) multiples inside
/// it, else the linear ticks of the range.
#[must_use]
pub fn log_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let (a, b) = (lo.ceil() as i64, (hi + 1e-9).floor() as i64);
    if b - a >= 1 {
        let step = ((b - a + 1) as usize).div_ceil(n.max(1)).max(1);
        return (a..=b).step_by(step).map(|d| d as f64).collect();
    }
    for mantissas in [
        &[1.0, 2.0, 5.0][..],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ] {
        let t: Vec<f64> = ((lo.floor() as i64)..=(hi.ceil() as i64))
            .flat_map(|k| {
                mantissas
                    .iter()
                    .map(move |m| (m * 10f64.powi(k as i32)).log10())
            })
            .filter(|t| (lo..=hi).contains(t))
            .collect();
        if t.len() >= 2 {
            return t;
        }
    }
    ticks(lo, hi, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unique(labels: &[String]) -> bool {
        let mut s = labels.to_vec();
        s.sort();
        s.dedup();
        s.len() == labels.len()
    }

    /// Tick labels are unique on every kind of range, including the narrow
    /// one of reflectance.png (2e-5 to 3e-5, which a fixed 5-decimal
    /// format labelled 0.00003 four times) and a log axis under a decade.
    #[test]
    fn tick_labels_are_unique() {
        for (lo, hi, log) in [
            (2.1e-5, 3.05e-5, false),
            (0.0, 1.0, false),
            (-90.0, 90.0, false),
            (0.999_99, 1.000_01, false),
            (1e5, 1e5 + 3.0, false),
            (-6.0, 2.0, true),
            (-4.7, -4.5, true),
            (-300.0, -290.0, true),
        ] {
            let t = if log {
                log_ticks(lo, hi, 8)
            } else {
                ticks(lo, hi, 8)
            };
            assert!(t.len() >= 2, "{lo}..{hi}: {t:?}");
            let f = TickFormat::for_ticks(&t, log);
            let labels: Vec<String> = t.iter().map(|&v| f.label(v)).collect();
            assert!(unique(&labels), "{lo}..{hi}: {labels:?}");
            // Readable: short.
            assert!(labels.iter().all(|l| l.len() <= 12), "{labels:?}");
        }
        // Decades on a log axis; 1-2-5 under two decades.
        assert_eq!(
            log_ticks(-6.2, 2.0, 10),
            [-6.0, -5.0, -4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0]
        );
        assert_eq!(
            log_ticks(-12.0, 3.0, 8),
            [-12.0, -10.0, -8.0, -6.0, -4.0, -2.0, 0.0, 2.0]
        );
        let f = TickFormat::for_ticks(&log_ticks(-4.7, -4.1, 8), true);
        let l: Vec<String> = log_ticks(-4.7, -4.1, 8)
            .iter()
            .map(|&t| f.label(t))
            .collect();
        assert_eq!(l, ["2e-5", "5e-5"]);
        // The old formatter's case: four labels 0.00003.
        let f = TickFormat::for_ticks(&[2.5e-5, 2.75e-5, 3e-5, 3.25e-5], false);
        assert_eq!(f.label(2.75e-5), "2.75e-5");
        assert_eq!(
            TickFormat::for_ticks(&[-1.0, 0.0, 1.0], false).label(-0.0),
            "0"
        );
    }

    #[test]
    fn long_titles_take_two_lines() {
        assert_eq!(title_lines("a: b (c)", 80), ["a: b (c)"]);
        let long = format!("{}: BRDF ({})", "x".repeat(40), "y".repeat(60));
        assert_eq!(
            title_lines(&long, 80),
            [
                format!("{}: BRDF", "x".repeat(40)),
                format!("({})", "y".repeat(60))
            ]
        );
    }

    #[test]
    fn rectangles() {
        let a = Rect {
            x0: 0,
            y0: 0,
            x1: 10,
            y1: 10,
        };
        let b = Rect {
            x0: 10,
            y0: 0,
            x1: 20,
            y1: 10,
        };
        assert!(!a.overlaps(&b) && a.overlaps(&a));
        assert!(a.contains((9, 9)) && !a.contains((10, 5)));
    }
}
