//! Height maps on disk: measured maps for `heightfield = { file = ... }` and
//! the files `roks export-heightfield` writes.
//!
//! All formats hold an `nx x ny` grid of heights; row `j` of the file is
//! `y = j * pixel` and column `i` is `x = i * pixel` (the first row is
//! `y = 0`, not flipped), vertex `(i, j)` of the periodic grid of
//! [`crate::micro::heightfield`]. The format is chosen by the extension
//! (case-insensitive):
//!
//! * `.exr`: OpenEXR, the first layer; the channel named `Y`, else the first
//!   channel (alphabetical order, as EXR stores them); `f16`, `f32` or `u32`
//!   samples. Written as one `f32` channel `Y` (ZIP).
//! * `.png`: 16-bit grayscale PNG, values `0..=65535` (read only; heights
//!   are `value * height_scale`, see the scene key).
//! * anything else: plain text, one row per line, heights separated by
//!   whitespace (or commas); empty lines and lines starting with `#` are
//!   ignored. Written with the shortest decimal form that reads back as the
//!   same `f64`, so a text round trip is exact.

use std::path::Path;

/// A grid of heights as read from a file (file units, before any scale).
#[derive(Clone, Debug, PartialEq)]
pub struct HeightGrid {
    /// Columns (x).
    pub nx: usize,
    /// Rows (y).
    pub ny: usize,
    /// Heights, row-major `h[j nx + i]`.
    pub h: Vec<f64>,
}

/// The formats, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// OpenEXR.
    Exr,
    /// 16-bit grayscale PNG.
    Png,
    /// Whitespace-separated text grid.
    Text,
}

impl Format {
    /// The format of `path` by its extension.
    #[must_use]
    pub fn of(path: &Path) -> Self {
        match path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .as_deref()
        {
            Some("exr") => Self::Exr,
            Some("png") => Self::Png,
            _ => Self::Text,
        }
    }
}

/// Why a height map cannot be read or written. One line without the path
/// (the caller puts the file and key in front).
#[derive(Debug, thiserror::Error)]
pub enum HeightMapError {
    /// The file cannot be read.
    #[error("cannot read: {0}")]
    Io(std::io::Error),
    /// A PNG the decoder refuses.
    #[error("PNG: {0}")]
    Png(image::ImageError),
    /// A PNG that is not 16-bit grayscale.
    #[error("PNG: {0:?} pixels, expected 16-bit grayscale")]
    PngColour(image::ColorType),
    /// An EXR the decoder refuses.
    #[error("EXR: {0}")]
    Exr(exr::error::Error),
    /// An EXR without channels.
    #[error("EXR: no channels")]
    ExrNoChannels,
    /// An EXR channel that does not fill its layer.
    #[error("EXR: channel {channel} has {samples} samples for {nx} x {ny} pixels (subsampled?)")]
    ExrSamples {
        /// The channel's name.
        channel: String,
        /// Its samples.
        samples: usize,
        /// Layer width.
        nx: usize,
        /// Layer height.
        ny: usize,
    },
    /// A text grid that is not UTF-8.
    #[error("not UTF-8 text")]
    NotUtf8,
    /// A word of a text grid that is not a number.
    #[error("line {line}: `{word}` is not a number")]
    Number {
        /// 1-based line.
        line: usize,
        /// The word.
        word: String,
    },
    /// A row of a text grid longer or shorter than the first.
    #[error("line {line}: {found} heights, the first row has {first}")]
    Ragged {
        /// 1-based line.
        line: usize,
        /// Heights on it.
        found: usize,
        /// Heights on the first row.
        first: usize,
    },
    /// Fewer than 2 x 2 heights.
    #[error("{nx} x {ny} heights: need at least 2 x 2")]
    TooSmall {
        /// Columns.
        nx: usize,
        /// Rows.
        ny: usize,
    },
    /// A height that is not finite (0-based row and column).
    #[error("height at row {row}, column {column} is not finite")]
    NotFinite {
        /// Row.
        row: usize,
        /// Column.
        column: usize,
    },
    /// PNG height maps are read only.
    #[error("writing PNG height maps is not supported (use .exr or .txt)")]
    PngWrite,
    /// The EXR encoder failed.
    #[error("writing EXR: {0}")]
    ExrWrite(exr::error::Error),
}

/// Estimated peak memory (bytes) of [`read`] on `path`, from what the file
/// declares without decoding it: the grid size in a PNG or EXR header
/// (`Some((nx, ny))`) with the decoded samples (up to 4 bytes) and the
/// heights (8 bytes) per pixel beside the file; for a text grid, whose size
/// is bounded by the file's, 5 times the file (every height takes at least
/// two characters and becomes 8 bytes). The error is one line without the path.
pub fn read_memory_bytes(path: &Path) -> Result<(u64, Option<(usize, usize)>), HeightMapError> {
    crate::limits::require_regular(path).map_err(HeightMapError::Io)?;
    let file = std::fs::metadata(path).map_err(HeightMapError::Io)?.len();
    let size = match Format::of(path) {
        Format::Png => {
            let (w, h) = image::ImageReader::open(path)
                .map_err(HeightMapError::Io)?
                .with_guessed_format()
                .map_err(HeightMapError::Io)?
                .into_dimensions()
                .map_err(HeightMapError::Png)?;
            Some((w as usize, h as usize))
        }
        Format::Exr => {
            let meta =
                exr::meta::MetaData::read_from_file(path, false).map_err(HeightMapError::Exr)?;
            meta.headers
                .first()
                .map(|h| (h.layer_size.width(), h.layer_size.height()))
        }
        Format::Text => None,
    };
    let bytes = match size {
        Some((nx, ny)) => crate::limits::product(&[nx as u64, ny as u64, 12]).saturating_add(file),
        None => file.saturating_mul(5),
    };
    Ok((bytes, size))
}

/// Read a height grid; the error is one line without the path.
///
/// # Errors
/// A [`HeightMapError`].
pub fn read(path: &Path) -> Result<HeightGrid, HeightMapError> {
    let bytes = crate::limits::read_input_capped(path, crate::limits::max_data_bytes())
        .map_err(HeightMapError::Io)?;
    let grid = match Format::of(path) {
        Format::Exr => read_exr(&bytes)?,
        Format::Png => read_png(&bytes)?,
        Format::Text => read_text(&bytes)?,
    };
    check(grid)
}

/// The checks of every height grid read ([`read`]) or given as an array:
/// at least 2 x 2 samples, every height finite.
///
/// # Errors
/// [`HeightMapError::TooSmall`] or [`HeightMapError::NotFinite`].
pub fn check(grid: HeightGrid) -> Result<HeightGrid, HeightMapError> {
    if grid.nx < 2 || grid.ny < 2 {
        return Err(HeightMapError::TooSmall {
            nx: grid.nx,
            ny: grid.ny,
        });
    }
    if let Some(k) = grid.h.iter().position(|z| !z.is_finite()) {
        return Err(HeightMapError::NotFinite {
            row: k / grid.nx,
            column: k % grid.nx,
        });
    }
    Ok(grid)
}

fn read_text(bytes: &[u8]) -> Result<HeightGrid, HeightMapError> {
    let text = std::str::from_utf8(bytes).map_err(|_| HeightMapError::NotUtf8)?;
    let mut h = Vec::new();
    let (mut nx, mut ny) = (0, 0);
    for (line_no, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let before = h.len();
        for word in line.split(|c: char| c.is_whitespace() || c == ',') {
            if word.is_empty() {
                continue;
            }
            h.push(word.parse::<f64>().map_err(|_| HeightMapError::Number {
                line: line_no + 1,
                word: word.to_owned(),
            })?);
        }
        let n = h.len() - before;
        if ny == 0 {
            nx = n;
        } else if n != nx {
            return Err(HeightMapError::Ragged {
                line: line_no + 1,
                found: n,
                first: nx,
            });
        }
        ny += 1;
    }
    Ok(HeightGrid { nx, ny, h })
}

fn read_png(bytes: &[u8]) -> Result<HeightGrid, HeightMapError> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(HeightMapError::Png)?;
    let image::DynamicImage::ImageLuma16(gray) = img else {
        return Err(HeightMapError::PngColour(img.color()));
    };
    let (nx, ny) = (gray.width() as usize, gray.height() as usize);
    let h = gray.into_raw().into_iter().map(f64::from).collect();
    Ok(HeightGrid { nx, ny, h })
}

fn read_exr(bytes: &[u8]) -> Result<HeightGrid, HeightMapError> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(HeightMapError::Exr)?;
    let layer = image.layer_data;
    let channels = &layer.channel_data.list;
    let channel = channels
        .iter()
        .find(|c| c.name.to_string() == "Y")
        .or_else(|| channels.first())
        .ok_or(HeightMapError::ExrNoChannels)?;
    let h: Vec<f64> = match &channel.sample_data {
        FlatSamples::F16(v) => v.iter().map(|x| f64::from(x.to_f32())).collect(),
        FlatSamples::F32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        FlatSamples::U32(v) => v.iter().map(|&x| f64::from(x)).collect(),
    };
    let (nx, ny) = (layer.size.width(), layer.size.height());
    if h.len() != nx * ny {
        return Err(HeightMapError::ExrSamples {
            channel: channel.name.to_string(),
            samples: h.len(),
            nx,
            ny,
        });
    }
    Ok(HeightGrid { nx, ny, h })
}

/// The grid as a file of `format` (EXR: one `f32` channel `Y`, so heights are
/// rounded to `f32`; text: exact). PNG is not written.
///
/// # Errors
/// [`HeightMapError::PngWrite`], or the EXR encoder's failure.
pub fn write(grid: &HeightGrid, format: Format, comment: &str) -> Result<Vec<u8>, HeightMapError> {
    match format {
        Format::Text => {
            let mut out = String::new();
            for line in comment.lines() {
                out.push_str("# ");
                out.push_str(line);
                out.push('\n');
            }
            for row in grid.h.chunks(grid.nx) {
                let words: Vec<String> = row.iter().map(|z| format!("{z:?}")).collect();
                out.push_str(&words.join(" "));
                out.push('\n');
            }
            Ok(out.into_bytes())
        }
        Format::Exr => write_exr(grid),
        Format::Png => Err(HeightMapError::PngWrite),
    }
}

fn write_exr(grid: &HeightGrid) -> Result<Vec<u8>, HeightMapError> {
    use exr::prelude::*;
    let samples: Vec<f32> = grid.h.iter().map(|&z| z as f32).collect();
    let channel = AnyChannel::new("Y", FlatSamples::F32(samples));
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        (grid.nx, grid.ny),
        LayerAttributes {
            software_name: Some(Text::from(crate::outdir::kind::EXR_SOFTWARE)),
            ..LayerAttributes::named("height")
        },
        encoding,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    let mut buf = std::io::Cursor::new(Vec::new());
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(&mut buf)
        .map_err(HeightMapError::ExrWrite)?;
    Ok(buf.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> HeightGrid {
        let (nx, ny) = (5, 3);
        let h = (0..nx * ny)
            .map(|k| (k as f64 * 0.37).sin() * 1e3 + 1.0 / (k as f64 + 3.0))
            .collect();
        HeightGrid { nx, ny, h }
    }

    #[test]
    fn text_round_trip_is_exact() {
        let g = grid();
        let bytes = write(&g, Format::Text, "a comment\nover two lines").unwrap();
        assert_eq!(read_text(&bytes).unwrap(), g);
    }

    #[test]
    fn exr_round_trip_rounds_to_f32_only() {
        let g = grid();
        let back = read_exr(&write(&g, Format::Exr, "").unwrap()).unwrap();
        assert_eq!((back.nx, back.ny), (g.nx, g.ny));
        for (a, b) in g.h.iter().zip(&back.h) {
            assert_eq!(*b, f64::from(*a as f32));
        }
    }

    #[test]
    fn png_16_bit_values_are_read_as_counts() {
        let (w, h) = (4u32, 3u32);
        let raw: Vec<u16> = (0..w * h).map(|k| (k * 5000 + 7) as u16).collect();
        let img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, raw.clone()).unwrap();
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
        let g = read_png(bytes.get_ref()).unwrap();
        assert_eq!((g.nx, g.ny), (4, 3));
        assert_eq!(g.h, raw.iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
        // 8-bit grayscale is refused with a one-line reason.
        let img8 = image::ImageBuffer::<image::Luma<u8>, _>::from_raw(2, 2, vec![0u8; 4]).unwrap();
        let mut b8 = std::io::Cursor::new(Vec::new());
        img8.write_to(&mut b8, image::ImageFormat::Png).unwrap();
        let e = read_png(b8.get_ref()).unwrap_err();
        assert!(matches!(e, HeightMapError::PngColour(_)), "{e}");
        assert!(e.to_string().contains("16-bit grayscale"), "{e}");
    }

    #[test]
    fn ragged_text_is_an_error_naming_the_line() {
        let e = read_text(b"# c\n1 2 3\n4 5\n").unwrap_err().to_string();
        assert_eq!(e, "line 3: 2 heights, the first row has 3");
        let e = read_text(b"1 x\n").unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("`x`"), "{e}");
    }
}
