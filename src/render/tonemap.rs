//! The PNG preview of a radiance image: exposure, tone curve, sRGB.
//!
//! The EXR keeps the linear radiances; only the 8-bit preview is tone-mapped.
//! A pixel's luminance is `Y = 0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709
//! weights, the linear sRGB primaries). Its exposed luminance is
//! `x = 2^EV Y`, and the tone curve `T` gives the display value
//! `y = T(x)` in `[0, 1]`; the pixel's channels are scaled by `y / Y`
//! (hue kept), clamped to `[0, 1]` and sRGB-encoded (IEC 61966-2-1) to
//! 8 bits. Curves ([`Tonemap`]):
//!
//! * `linear`: `T(x) = x` (so `x >= 1` is white);
//! * `log`: `T(x) = 1 + log10(x) / D` for `x > 0`: `x = 1` is white, `D`
//!   decades below it (`x = 10^-D`) black, evenly spaced in between;
//! * `filmic`: the ACES filmic fit of K. Narkowicz (2015),
//!   `T(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)`, which rolls
//!   highlights off toward white (`T(1) = 0.80`, `T(∞) = 1.03`, clamped).
//!
//! **Automatic exposure** (no `--exposure`): from the pixels whose luminance
//! is finite and `> 0` (the zero pixels of a dark background do not pull it
//! down), `2^EV = 1 / p_w`, `p_w` the 99.9th percentile (nearest rank) of
//! their luminances: the brightest 0.1 % are white (linear, log) or rolled
//! off (filmic), so a small bright spot (the lit apex of a cavity) keeps its
//! gradation while a single stray sample cannot darken the picture.
//! **Automatic decades** of the log curve (no `--decades`):
//! `D = log10(p_w / p_b)`, `p_b` their 1st percentile, clamped to `[1, 8]`:
//! the dimmest 1 % of the lit pixels are black. An image with no such pixel
//! stays black (EV 0).

use super::Image;

/// The tone curve of the preview (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Tonemap {
    /// `y = x`: radiance proportional to the displayed value (before sRGB).
    Linear,
    /// `y = 1 + log10(x) / D`: `D` decades of radiance from black to white.
    #[default]
    Log,
    /// ACES filmic fit (Narkowicz 2015): highlights rolled off.
    Filmic,
}

/// How to tone-map a preview: the curve, and the exposure and decades
/// (`None`: automatic, see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ToneSettings {
    /// The curve.
    pub tonemap: Tonemap,
    /// Exposure in stops (EV): radiance is multiplied by `2^EV`.
    pub exposure_ev: Option<f64>,
    /// Decades from white to black of the `log` curve (> 0).
    pub decades: Option<f64>,
}

/// The largest |EV| taken: `2^±1000` is still a finite f64.
pub const MAX_EV: f64 = 1000.0;

impl ToneSettings {
    /// Check the settings; `Err` is one line starting with the option.
    ///
    /// # Errors
    /// `--exposure` or `--decades` out of range, as a [`super::RenderError`].
    pub fn validate(&self) -> Result<(), super::RenderError> {
        use super::{RenderError, RenderProblem};
        if let Some(ev) = self
            .exposure_ev
            .filter(|ev| ev.is_nan() || ev.abs() > MAX_EV)
        {
            return Err(RenderError {
                option: Some("--exposure"),
                problem: RenderProblem::Exposure(ev),
            });
        }
        if let Some(d) = self
            .decades
            .filter(|d| d.is_nan() || *d <= 0.0 || *d > 300.0)
        {
            return Err(RenderError {
                option: Some("--decades"),
                problem: RenderProblem::Decades(d),
            });
        }
        Ok(())
    }
}

/// What a preview was made with: the exposure and decades used (given or
/// automatic), to print and to repeat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Applied {
    /// Exposure (stops).
    pub exposure_ev: f64,
    /// Decades of the log curve (the given or automatic value; also
    /// reported, though unused, for the other curves).
    pub decades: f64,
}

/// The percentile of the non-zero luminances made white by the automatic exposure.
pub const WHITE_PERCENTILE: f64 = 0.999;
/// The percentile of the non-zero luminances made black by the automatic decades.
pub const BLACK_PERCENTILE: f64 = 0.01;

/// Rec. 709 luminance of a linear RGB pixel.
#[must_use]
pub fn luminance(p: &[f32; 3]) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// Nearest-rank percentile `q` (in `(0, 1]`) of sorted, non-empty `v`.
fn percentile(v: &[f64], q: f64) -> f64 {
    let n = v.len();
    v[((q * n as f64).ceil() as usize).clamp(1, n) - 1]
}

/// The exposure and decades `s` asks for, the automatic ones computed from
/// `img` (see the module documentation).
#[must_use]
pub fn resolve(img: &Image, s: &ToneSettings) -> Applied {
    let mut lit: Vec<f64> = img
        .rgb
        .iter()
        .map(luminance)
        .filter(|y| y.is_finite() && *y > 0.0)
        .collect();
    lit.sort_by(f64::total_cmp);
    let (black, white) = if lit.is_empty() {
        (1.0, 1.0)
    } else {
        (
            percentile(&lit, BLACK_PERCENTILE),
            percentile(&lit, WHITE_PERCENTILE),
        )
    };
    Applied {
        exposure_ev: s
            .exposure_ev
            .unwrap_or_else(|| if lit.is_empty() { 0.0 } else { -white.log2() }),
        decades: s
            .decades
            .unwrap_or_else(|| (white / black).log10().clamp(1.0, 8.0)),
    }
}

/// The tone curve `T(x)` of `t` for exposed luminance `x >= 0`, with
/// `decades` for the log curve; in `[0, 1]`.
#[must_use]
pub fn curve(t: Tonemap, x: f64, decades: f64) -> f64 {
    let y = match t {
        Tonemap::Linear => x,
        Tonemap::Log => {
            if x > 0.0 {
                1.0 + x.log10() / decades
            } else {
                0.0
            }
        }
        Tonemap::Filmic => x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14),
    };
    if y.is_finite() {
        y.clamp(0.0, 1.0)
    } else {
        // x = inf: white for the rising curves.
        if x > 0.0 { 1.0 } else { 0.0 }
    }
}

/// The preview's 8-bit sRGB bytes (3 per pixel, row-major) of `img`, and
/// the exposure and decades used. Non-finite or negative channels are 0.
#[must_use]
pub fn map(img: &Image, s: &ToneSettings) -> (Vec<u8>, Applied) {
    let applied = resolve(img, s);
    let gain = applied.exposure_ev.exp2();
    let bytes = img
        .rgb
        .iter()
        .flat_map(|p| {
            let clean = p.map(|c| {
                let c = f64::from(c);
                if c.is_finite() && c > 0.0 { c } else { 0.0 }
            });
            let y = 0.2126 * clean[0] + 0.7152 * clean[1] + 0.0722 * clean[2];
            let x = y * gain;
            let scale = if x > 0.0 {
                curve(s.tonemap, x, applied.decades) / y
            } else {
                0.0
            };
            clean.map(|c| {
                let v = (c * scale).clamp(0.0, 1.0);
                let v = if v.is_finite() { v } else { 0.0 };
                (crate::optics::colour::srgb_encode(v) * 255.0).round() as u8
            })
        })
        .collect();
    (bytes, applied)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::colour::srgb_encode;

    fn grey(values: &[f32]) -> Image {
        Image {
            width: values.len(),
            height: 1,
            rgb: values.iter().map(|&v| [v; 3]).collect(),
        }
    }

    fn byte(v: f64) -> u8 {
        (srgb_encode(v) * 255.0).round() as u8
    }

    /// Linear with a given exposure: byte = sRGB(min(2^EV L, 1)); grey
    /// channels stay equal (their luminance weights sum to 1).
    #[test]
    fn linear_exposure_is_a_gain() {
        let img = grey(&[0.0, 0.01, 0.05, 0.2, 1.0]);
        let s = ToneSettings {
            tonemap: Tonemap::Linear,
            exposure_ev: Some(2.0),
            decades: None,
        };
        let (b, a) = map(&img, &s);
        assert_eq!(a.exposure_ev, 2.0);
        for (k, &l) in [0.0_f64, 0.01, 0.05, 0.2, 1.0].iter().enumerate() {
            let want = byte((4.0 * l).min(1.0));
            for c in 0..3 {
                // Rec. 709 weights of a grey pixel sum to 1 up to rounding.
                assert!(
                    b[3 * k + c].abs_diff(want) <= 1,
                    "{k}: {} vs {want}",
                    b[3 * k + c]
                );
            }
        }
    }

    /// Automatic exposure: the 99.9th percentile of the non-zero pixels is
    /// white and the 1st black, whatever the number of zero pixels; an
    /// all-black image stays black.
    #[test]
    fn automatic_exposure_ignores_zero_pixels() {
        // 2050 pixels k 1e-4 (k = 1..2050), 8000 zeros: nearest ranks
        // ceil(0.999 * 2050) = 2048 and ceil(0.01 * 2050) = 21.
        let px = |k: u16| f32::from(k) * 1e-4;
        let mut v: Vec<f32> = (1..=2050).map(px).collect();
        v.extend(std::iter::repeat_n(0.0, 8000));
        let img = grey(&v);
        let a = resolve(&img, &ToneSettings::default());
        let white = luminance(&[px(2048); 3]);
        assert!((a.exposure_ev + white.log2()).abs() < 1e-12, "{a:?}");
        let black = luminance(&[px(21); 3]);
        assert!((a.decades - (white / black).log10()).abs() < 1e-12, "{a:?}");
        let black = grey(&[0.0; 6]);
        let (b, a) = map(&black, &ToneSettings::default());
        assert!(b.iter().all(|&x| x == 0));
        assert_eq!(a.exposure_ev, 0.0);
        // Uniform: white for every curve's automatic exposure but filmic's roll-off.
        let (b, _) = map(&grey(&[0.3; 4]), &ToneSettings::default());
        assert!(b.iter().all(|&x| x == 255));
    }

    /// Log: x = 10^(-D/2) is mid-grey in display value (y = 0.5), x = 10^-D
    /// and below black, x >= 1 white.
    #[test]
    fn log_curve_spaces_decades_evenly() {
        let s = ToneSettings {
            tonemap: Tonemap::Log,
            exposure_ev: Some(0.0),
            decades: Some(4.0),
        };
        let img = grey(&[1e-5, 1e-4, 1e-3, 1e-2, 1.0, 7.0]);
        let (b, _) = map(&img, &s);
        let want = [0.0, 0.0, 0.25, 0.5, 1.0, 1.0].map(byte);
        for (k, w) in want.iter().enumerate() {
            assert!(b[3 * k].abs_diff(*w) <= 1, "{k}: {} vs {w}", b[3 * k]);
        }
        assert_eq!(curve(Tonemap::Log, 1e-2, 4.0), 0.5);
    }

    /// Filmic: the published curve at x = 0.18, 1 and 10.
    #[test]
    fn filmic_is_the_aces_fit() {
        let aces = |x: f64| x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
        for x in [0.18, 1.0, 10.0] {
            assert_eq!(curve(Tonemap::Filmic, x, 1.0), aces(x).min(1.0));
        }
        assert!((curve(Tonemap::Filmic, 1.0, 1.0) - 0.8038).abs() < 1e-4);
        assert_eq!(curve(Tonemap::Filmic, 0.0, 1.0), 0.0);
    }

    /// A coloured pixel keeps its hue: channels scaled by one factor.
    #[test]
    fn colour_is_scaled_not_per_channel() {
        let img = Image {
            width: 1,
            height: 1,
            rgb: vec![[0.02, 0.01, 0.0]],
        };
        let s = ToneSettings {
            tonemap: Tonemap::Log,
            exposure_ev: Some(0.0),
            decades: Some(4.0),
        };
        let (b, _) = map(&img, &s);
        let y = 0.2126 * 0.02 + 0.7152 * 0.01;
        let k = curve(Tonemap::Log, y, 4.0) / y;
        assert_eq!(b[0], byte(0.02 * k));
        assert_eq!(b[1], byte(0.01 * k));
        assert_eq!(b[2], 0);
    }

    #[test]
    fn bad_settings_are_refused() {
        let bad = |ev, d| {
            ToneSettings {
                tonemap: Tonemap::Log,
                exposure_ev: ev,
                decades: d,
            }
            .validate()
        };
        assert!(
            bad(Some(f64::NAN), None)
                .unwrap_err()
                .to_string()
                .starts_with("--exposure:")
        );
        assert!(bad(Some(2000.0), None).is_err());
        assert_eq!(bad(None, Some(0.0)).unwrap_err().option, Some("--decades"));
        assert!(bad(Some(-3.5), Some(5.0)).is_ok());
    }
}
