//! The Zemax / Radiant tabular BSDF text format (`.bsdf`), as OpticStudio's
//! tabular BSDF scatter model and other stray-light tools read it: writer
//! ([`ZemaxBsdf::from_table`], [`ZemaxBsdf::to_text`]) and reader
//! ([`ZemaxBsdf::parse`], [`ZemaxBsdf::eval`]).
//!
//! # Layout written
//!
//! ```text
//! # comment lines
//! Source  Measured
//! Symmetry  PlaneSymmetrical
//! SpectralContent  Monochrome
//! ScatterType  BRDF
//! SampleRotation  1
//! 0
//! AngleOfIncidence  <n>
//! <n angles, degrees>
//! ScatterAzimuth  <n>
//! <n angles, degrees, 0..180>
//! ScatterRadial  <n>
//! <n angles, degrees, from 0>
//!
//! Monochrome
//! DataBegin
//! TIS <reflectance>                 (per angle of incidence:)
//! <one line per azimuth: the BRDF (1/sr) at every radial angle>
//! DataEnd
//! ```
//!
//! A table of several light azimuths (`phi_i_deg`) is written
//! `Asymmetrical4D`:
//!
//! ```text
//! Symmetry  Asymmetrical4D
//! ...
//! SampleRotation  <n>
//! <n angles, degrees: the table's light azimuths phi_i_deg>
//! AngleOfIncidence  <m>
//! <m angles, degrees>
//! ScatterAzimuth  <n>
//! <n angles, degrees, 0..360>
//! ScatterRadial  <n>
//! <n angles, degrees, from 0>
//!
//! Monochrome
//! DataBegin
//! TIS <reflectance>     (per sample rotation, then angle of incidence:)
//! <one line per azimuth: the BRDF (1/sr) at every radial angle>
//! DataEnd
//! ```
//!
//! The order of the four angles is the format's: "for every Sample
//! Rotation, you can have data for multiple Angles of Incidence; for every
//! Angle of Incidence, you can have data for multiple Azimuth angles; and
//! so on"; `Asymmetrical4D` is its `Symmetry` value for data over the whole
//! azimuth circle at several sample rotations (R. Rykowski, "BSDF Data
//! Interchange File Format Specification", Radiant Imaging / Zemax
//! knowledge base article 229, 2008, Table 1 lines 2 and 5-12; "Zemax
//! Tabular BSDF data file format", Zemax support article 1500005486801,
//! section "Definition of angles and coordinate systems"). A block of
//! sample rotation `rho` is the table of light azimuth `phi_i_deg = rho`
//! ([`BrdfTable::azimuth`]) in its plane-of-incidence frame below: `rho` is
//! the azimuth of the light (its side of the plane of incidence) from the
//! sample's `+x` axis, counter-clockwise seen from above, as in `brdf.csv`
//! (a comment line of the file says so). The current Zemax article
//! describes the sample rotation as "the angle between the normal of the
//! plane of incidence and the +X local axis", which read literally is a
//! quarter turn from this, but names neither the normal's side nor the
//! angle's sense; the 2008 specification does not define it; libbsdf (the
//! independent reader of such files) reads it as the light's azimuth, as
//! written here (docs/src/exports.md, "SampleRotation").
//! No plane symmetry is assumed: the table is not averaged with its mirror
//! image. OpticStudio's own tabular BSDF model reads one sample rotation
//! only (Zemax knowledge base article 231, page 3, note 3); other readers of
//! the format take the rotations.
//!
//! `Symmetry` is written `Asymmetrical4D`, the spelling of the
//! specification's Table 1 and of the public writers (Ansys's BSDF
//! converter among them); its formatting notes spell it `ASymmetrical4D`,
//! the only spelling libbsdf takes (case-sensitively). The reader here
//! takes both (keywords in any letter case).
//!
//! `Source` can only be `Measured` in this format; a comment line says the
//! data are a roks Monte Carlo table. Numbers are printed with 7 significant
//! digits (`1.234567E-01`).
//!
//! # Angles
//!
//! `AngleOfIncidence` is the polar angle of the specular direction, equal to
//! the incidence angle `theta_i` for a BRDF; the blocks are the table's
//! tabulated incidence angles. `ScatterRadial` and `ScatterAzimuth` are
//! measured **from the specular direction** `s = (-sin theta_i, 0, cos
//! theta_i)` (local frame of [`BrdfTable`]: the light on the `+x` side): the
//! radial angle `r` is the angle between the scattered direction and `s`; the
//! azimuth `psi` turns counter-clockwise (seen from outside, looking back
//! along `-s`) from `e0 = (cos theta_i, 0, sin theta_i)`, the direction from
//! `s` toward the surface normal (toward `+x` at normal incidence), to
//! `e1 = (0, 1, 0)`:
//! `omega = cos r s + sin r (cos psi e0 + sin psi e1)`.
//! `PlaneSymmetrical` holds `psi` in `[0, 180]` degrees; `psi` and `-psi` are
//! mirror images in the plane of incidence. `Asymmetrical4D` holds `psi` in
//! `[0, 360]` degrees (360 is 0 again).
//!
//! # Values
//!
//! The BRDF in sr⁻¹ (radiance per irradiance), sampled at the grid's
//! directions from the table by
//! [`super::resample::symmetric_eval`] (`Asymmetrical4D`: by
//! [`BrdfTable::eval`] of the azimuth's table) (no averaging over
//! the grid cell: the table is piecewise constant on cells about 3 degrees
//! wide, the default grid steps are 2 degrees in azimuth and 1 degree in
//! radial angle); 0 at grid directions on or below the horizon (the default
//! radial angles run to 180 degrees so that every angle of incidence covers
//! the whole hemisphere). `TIS` is the table's directional-hemispherical
//! reflectance at that incidence, `∫ f cos(theta_o) dω` (dimensionless).
//!
//! [`ZemaxBsdf::eval`] interpolates bilinearly in `(psi, r)` within a block;
//! it does not interpolate between angles of incidence.

use std::fmt::Write as _;

use glam::DVec3;

use rayon::prelude::*;

use super::exporter::{
    BrdfFormat, Export, ExportError, ExportFile, ExportInput, Exporter, ZemaxGrid, here, one_file,
};
use super::resample::{
    CHECK_RINGS, FormatError, ReflectanceCheck, integrate_projected, symmetric_eval,
};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::outdir::file::ResultFile;
use crate::outdir::kind::FileKind;

/// Default azimuth step of [`ZemaxBsdf::from_table`] (degrees).
pub const AZIMUTH_STEP_DEG: f64 = 2.0;
/// Default radial step of [`ZemaxBsdf::from_table`] (degrees).
pub const RADIAL_STEP_DEG: f64 = 1.0;

/// Grid directions with `z` at most this are on or below the horizon.
const HORIZON_Z: f64 = 1e-12;

/// The `Symmetry` of a Zemax file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// `PlaneSymmetrical`: one sample rotation, azimuths in `[0, 180]`.
    PlaneSymmetrical,
    /// `Asymmetrical4D`: any number of sample rotations, azimuths in
    /// `[0, 360]`.
    Asymmetrical4D,
}

impl Symmetry {
    /// The keyword in the file.
    #[must_use]
    pub fn keyword(self) -> &'static str {
        match self {
            Self::PlaneSymmetrical => "PlaneSymmetrical",
            Self::Asymmetrical4D => "Asymmetrical4D",
        }
    }

    /// The largest `ScatterAzimuth` (degrees).
    #[must_use]
    pub fn max_azimuth_deg(self) -> f64 {
        match self {
            Self::PlaneSymmetrical => 180.0,
            Self::Asymmetrical4D => 360.0,
        }
    }
}

/// A monochrome tabular BRDF in the Zemax layout: plane-symmetric, or
/// `Asymmetrical4D` with a block per sample rotation and angle of
/// incidence.
#[derive(Debug, Clone, PartialEq)]
pub struct ZemaxBsdf {
    /// `Symmetry`.
    pub symmetry: Symmetry,
    /// `SampleRotation` values (degrees): `[0]` for `PlaneSymmetrical`;
    /// for `Asymmetrical4D` the table's light azimuths `phi_i_deg`.
    pub rotation_deg: Vec<f64>,
    /// `AngleOfIncidence` values (degrees), ascending.
    pub aoi_deg: Vec<f64>,
    /// `ScatterAzimuth` values (degrees, in `[0, 180]`, `[0, 360]` for
    /// `Asymmetrical4D`), ascending.
    pub azimuth_deg: Vec<f64>,
    /// `ScatterRadial` values (degrees, `>= 0`), ascending.
    pub radial_deg: Vec<f64>,
    /// `TIS` per block: sample rotation `j`, angle of incidence `t` is
    /// block `j * aoi_deg.len() + t` (dimensionless).
    pub tis: Vec<f64>,
    /// BRDF (sr⁻¹) per block (as `tis`), azimuth-major:
    /// `brdf[k][a * radial_deg.len() + r]`.
    pub brdf: Vec<Vec<f64>>,
}

/// `0, step, 2 step, ... , max` (degrees).
pub(crate) fn steps(step: f64, max: f64) -> Vec<f64> {
    let n = (max / step).round() as usize;
    (0..=n).map(|i| i as f64 * step).collect()
}

/// `v` with 7 significant digits in the C form `d.ddddddE+XX`.
fn sci(v: f64) -> String {
    let s = format!("{v:.6e}");
    match s.split_once('e') {
        Some((m, e)) => {
            let e: i32 = e.parse().unwrap_or(0);
            format!("{m}E{e:+03}")
        }
        None => s,
    }
}

/// Specular direction `s`, and the azimuth axes `e0`, `e1` at incidence
/// `theta` (radians).
fn axes(theta: f64) -> (DVec3, DVec3, DVec3) {
    let (st, ct) = theta.sin_cos();
    (DVec3::new(-st, 0.0, ct), DVec3::new(ct, 0.0, st), DVec3::Y)
}

/// The unit direction (local frame) at azimuth `psi_deg` and radial angle
/// `r_deg` about the specular direction of incidence `aoi_deg` (degrees).
#[must_use]
pub fn direction(aoi_deg: f64, psi_deg: f64, r_deg: f64) -> DVec3 {
    let (s, e0, e1) = axes(aoi_deg.to_radians());
    let (sp, cp) = psi_deg.to_radians().sin_cos();
    let (sr, cr) = r_deg.to_radians().sin_cos();
    cr * s + sr * (cp * e0 + sp * e1)
}

/// `(psi, r)` in degrees of the direction `dir` (local frame, need not be
/// normalised) about the specular direction of incidence `aoi_deg`; `psi`
/// folded into `[0, 180]` (plane symmetry).
#[must_use]
pub fn angles(aoi_deg: f64, dir: DVec3) -> (f64, f64) {
    let (psi, r) = signed_angles(aoi_deg, dir);
    (psi.abs(), r)
}

/// As [`angles`], `psi` in `[0, 360)` (no symmetry: `Asymmetrical4D`).
#[must_use]
pub fn angles_full(aoi_deg: f64, dir: DVec3) -> (f64, f64) {
    let (psi, r) = signed_angles(aoi_deg, dir);
    (if psi < 0.0 { psi + 360.0 } else { psi }, r)
}

/// `(psi, r)` of [`angles`], `psi` in `[-180, 180]`.
fn signed_angles(aoi_deg: f64, dir: DVec3) -> (f64, f64) {
    let d = dir.normalize_or_zero();
    let (s, e0, e1) = axes(aoi_deg.to_radians());
    let r = d.dot(s).clamp(-1.0, 1.0).acos().to_degrees();
    (d.dot(e1).atan2(d.dot(e0)).to_degrees(), r)
}

/// Index `i` and weight `w` of `x` in the ascending `grid`: the value is
/// `(1 - w) v[i] + w v[i + 1]`; clamped at the ends.
fn locate(grid: &[f64], x: f64) -> (usize, f64) {
    let n = grid.len();
    if n < 2 || x <= grid[0] {
        return (0, 0.0);
    }
    if x >= grid[n - 1] {
        return (n - 2, 1.0);
    }
    let i = grid.partition_point(|&g| g <= x) - 1;
    (i, (x - grid[i]) / (grid[i + 1] - grid[i]))
}

impl ZemaxBsdf {
    /// The symmetry `table` is written with: `Asymmetrical4D` when it has
    /// several light azimuths, else `PlaneSymmetrical`.
    #[must_use]
    pub fn symmetry_of(table: &BrdfTable) -> Symmetry {
        if table.azimuths_deg().len() > 1 {
            Symmetry::Asymmetrical4D
        } else {
            Symmetry::PlaneSymmetrical
        }
    }

    /// Resample `table` on the default grid: azimuth 0-180 degrees
    /// (0-360 for a table of several light azimuths, `Asymmetrical4D`) in
    /// steps of [`AZIMUTH_STEP_DEG`], radial 0-180 degrees in steps of
    /// [`RADIAL_STEP_DEG`], one block per tabulated incidence angle (and
    /// light azimuth).
    #[must_use]
    pub fn from_table(table: &BrdfTable) -> Self {
        Self::from_table_on(
            table,
            steps(AZIMUTH_STEP_DEG, Self::symmetry_of(table).max_azimuth_deg()),
            steps(RADIAL_STEP_DEG, 180.0),
        )
    }

    /// Resample `table` on the given azimuth and radial angles (degrees,
    /// ascending; azimuths in `[0, 180]`, or `[0, 360]` for a table of
    /// several light azimuths: [`symmetry_of`](Self::symmetry_of)).
    #[must_use]
    pub fn from_table_on(table: &BrdfTable, azimuth_deg: Vec<f64>, radial_deg: Vec<f64>) -> Self {
        let symmetry = Self::symmetry_of(table);
        let aoi_deg = table.angles_deg();
        let block = |aoi: f64, value: &dyn Fn(f64, DVec3) -> f64| -> Vec<f64> {
            azimuth_deg
                .iter()
                .flat_map(|&psi| radial_deg.iter().map(move |&r| (psi, r)))
                .map(|(psi, r)| {
                    let d = direction(aoi, psi, r);
                    if d.z <= HORIZON_Z {
                        0.0
                    } else {
                        value(aoi.to_radians(), d)
                    }
                })
                .collect()
        };
        let (rotation_deg, tables): (Vec<f64>, Vec<BrdfTable>) = match symmetry {
            Symmetry::PlaneSymmetrical => (vec![0.0], vec![table.clone()]),
            Symmetry::Asymmetrical4D => table
                .azimuths_deg()
                .iter()
                .enumerate()
                .map(|(k, &phi)| (phi, table.azimuth(k)))
                .unzip(),
        };
        let mut brdf = Vec::new();
        let mut tis = Vec::new();
        for t in &tables {
            for &aoi in &aoi_deg {
                brdf.push(match symmetry {
                    Symmetry::PlaneSymmetrical => {
                        block(aoi, &|theta, d| symmetric_eval(t, theta, d))
                    }
                    Symmetry::Asymmetrical4D => block(aoi, &|theta, d| t.eval(theta, d)),
                });
                tis.push(t.reflectance(aoi.to_radians()));
            }
        }
        Self {
            symmetry,
            rotation_deg,
            tis,
            aoi_deg,
            azimuth_deg,
            radial_deg,
            brdf,
        }
    }

    /// The angle of incidence (degrees) of block `k`.
    #[must_use]
    pub fn block_aoi_deg(&self, k: usize) -> f64 {
        self.aoi_deg[k % self.aoi_deg.len()]
    }

    /// The sample rotation (degrees) of block `k`.
    #[must_use]
    pub fn block_rotation_deg(&self, k: usize) -> f64 {
        self.rotation_deg[k / self.aoi_deg.len()]
    }

    /// The file's text; `comment` (one line, may be empty) is written as a
    /// `#` line after the roks line.
    #[must_use]
    pub fn to_text(&self, comment: &str) -> String {
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mut s = String::with_capacity(
            14 * self.brdf.len() * self.brdf.first().map_or(0, Vec::len) + 1024,
        );
        s.push_str(
            "# BRDF table generated by roks (Monte Carlo ray tracing of a rough surface), not measured\n",
        );
        if !comment.trim().is_empty() {
            let _ = writeln!(s, "# {}", comment.replace(['\n', '\r'], " "));
        }
        s.push_str("# ScatterAzimuth and ScatterRadial are measured from the specular direction; BRDF in 1/sr\n");
        if self.symmetry == Symmetry::Asymmetrical4D {
            s.push_str("# SampleRotation is the azimuth of the light from the sample's +x axis, counter-clockwise seen from above (degrees)\n");
        }
        let _ = writeln!(
            s,
            "Source  Measured\nSymmetry  {}\nSpectralContent  Monochrome\nScatterType  BRDF\nSampleRotation  {}\n{}",
            self.symmetry.keyword(),
            self.rotation_deg.len(),
            list(&self.rotation_deg)
        );
        let _ = writeln!(
            s,
            "AngleOfIncidence  {}\n{}",
            self.aoi_deg.len(),
            list(&self.aoi_deg)
        );
        let _ = writeln!(
            s,
            "ScatterAzimuth  {}\n{}",
            self.azimuth_deg.len(),
            list(&self.azimuth_deg)
        );
        let _ = writeln!(
            s,
            "ScatterRadial  {}\n{}",
            self.radial_deg.len(),
            list(&self.radial_deg)
        );
        s.push_str("\nMonochrome\nDataBegin\n");
        let nr = self.radial_deg.len();
        for (tis, block) in self.tis.iter().zip(&self.brdf) {
            let _ = writeln!(s, "TIS {}", sci(*tis));
            for row in block.chunks(nr.max(1)) {
                let line: Vec<String> = row.iter().map(|&v| sci(v)).collect();
                s.push_str(&line.join(" "));
                s.push('\n');
            }
        }
        s.push_str("DataEnd\n");
        s
    }

    /// Read the text of a `.bsdf` file; `name` names it in errors. Accepts
    /// what [`to_text`](Self::to_text) writes and the layout of the format
    /// description in general (comment lines, numbers spread over lines,
    /// keywords in any letter case), restricted to `Monochrome` and `BRDF`,
    /// and to `PlaneSymmetrical` with one sample rotation or
    /// `Asymmetrical4D` with distinct ascending rotations.
    ///
    /// # Errors
    /// A [`FormatError`] naming `name`, the line and the keyword.
    pub fn parse(text: &str, name: &str) -> Result<Self, FormatError> {
        let mut tokens = Tokens::new(text, name);
        let mut symmetry = Symmetry::PlaneSymmetrical;
        for (key, value) in [
            ("Source", None),
            ("Symmetry", Some("PlaneSymmetrical or Asymmetrical4D")),
            ("SpectralContent", Some("Monochrome")),
            ("ScatterType", Some("BRDF")),
        ] {
            tokens.keyword(key)?;
            let (line, v) = tokens.word(key)?;
            if key == "Symmetry" {
                if let Some(sym) = [Symmetry::PlaneSymmetrical, Symmetry::Asymmetrical4D]
                    .into_iter()
                    .find(|s| v.eq_ignore_ascii_case(s.keyword()))
                {
                    symmetry = sym;
                    continue;
                }
            }
            if let Some(want) = value.filter(|w| !v.eq_ignore_ascii_case(w)) {
                return Err(tokens.error(
                    line,
                    &format!("{key}: `{v}` is not supported (only {want})"),
                ));
            }
        }
        tokens.keyword("SampleRotation")?;
        let (line, n) = tokens.count("SampleRotation")?;
        if n != 1 && symmetry == Symmetry::PlaneSymmetrical {
            return Err(tokens.error(
                line,
                &format!(
                    "SampleRotation: {n} rotations, PlaneSymmetrical has 1 (several: Asymmetrical4D)"
                ),
            ));
        }
        let rotation_deg = tokens.numbers("SampleRotation", n)?;
        if n == 0 || !rotation_deg.windows(2).all(|w| w[0] < w[1]) {
            return Err(tokens.error(
                line,
                &format!("SampleRotation: the {n} rotations must be ascending, at least one"),
            ));
        }
        let mut lists = Vec::new();
        for (key, lo, hi) in [
            ("AngleOfIncidence", 0.0, 90.0),
            ("ScatterAzimuth", 0.0, symmetry.max_azimuth_deg()),
            ("ScatterRadial", 0.0, 180.0),
        ] {
            tokens.keyword(key)?;
            let (line, n) = tokens.count(key)?;
            let v = tokens.numbers(key, n)?;
            let ascending = v.windows(2).all(|w| w[0] < w[1]);
            if n == 0 || !ascending || v.iter().any(|x| !(lo..=hi).contains(x)) {
                return Err(tokens.error(
                    line,
                    &format!("{key}: the {n} angles must be ascending and in [{lo}, {hi}] degrees"),
                ));
            }
            lists.push(v);
        }
        let radial_deg = lists.pop().unwrap_or_default();
        let azimuth_deg = lists.pop().unwrap_or_default();
        let aoi_deg = lists.pop().unwrap_or_default();
        tokens.keyword("Monochrome")?;
        tokens.keyword("DataBegin")?;
        let per_block = azimuth_deg.len() * radial_deg.len();
        let (mut tis, mut brdf) = (Vec::new(), Vec::new());
        let blocks = rotation_deg
            .iter()
            .flat_map(|&rho| aoi_deg.iter().map(move |&aoi| (rho, aoi)));
        for (rho, aoi) in blocks {
            let aoi = if symmetry == Symmetry::Asymmetrical4D {
                format!("{aoi}, SampleRotation {rho}")
            } else {
                format!("{aoi}")
            };
            let key = format!("TIS (AngleOfIncidence {aoi})");
            tokens.keyword("TIS")?;
            let t = tokens.numbers(&key, 1)?[0];
            let block = tokens.numbers(&format!("data (AngleOfIncidence {aoi})"), per_block)?;
            if let Some(bad) = block.iter().chain([&t]).find(|v| **v < 0.0) {
                return Err(tokens.error(tokens.line(), &format!("{key}: negative value {bad}")));
            }
            tis.push(t);
            brdf.push(block);
        }
        tokens.keyword("DataEnd")?;
        Ok(Self {
            symmetry,
            rotation_deg,
            aoi_deg,
            azimuth_deg,
            radial_deg,
            tis,
            brdf,
        })
    }

    /// The BRDF (sr⁻¹) of block `k` (sample rotation `k / m`, angle of
    /// incidence `k % m`, `m` angles; with one rotation the `k`-th angle)
    /// toward `dir` (local frame of the block's plane of incidence, need
    /// not be normalised): bilinear in `(psi, r)`, clamped at the grid's
    /// ends; 0 for `dir.z <= 0`.
    ///
    /// # Panics
    /// If `k` is not a block index.
    #[must_use]
    pub fn eval(&self, k: usize, dir: DVec3) -> f64 {
        if dir.z <= 0.0 {
            return 0.0;
        }
        let aoi = self.block_aoi_deg(k);
        let (psi, r) = match self.symmetry {
            Symmetry::PlaneSymmetrical => angles(aoi, dir),
            Symmetry::Asymmetrical4D => angles_full(aoi, dir),
        };
        let (ia, wa) = locate(&self.azimuth_deg, psi);
        let (ir, wr) = locate(&self.radial_deg, r);
        let nr = self.radial_deg.len();
        let b = &self.brdf[k];
        let at = |a: usize, r: usize| {
            let a = a.min(self.azimuth_deg.len() - 1);
            b[a * nr + r.min(nr - 1)]
        };
        let row = |a: usize| (1.0 - wr) * at(a, ir) + wr * at(a, ir + 1);
        (1.0 - wa) * row(ia) + wa * row(ia + 1)
    }
}

/// Whitespace-separated tokens with their line numbers, `#` lines skipped.
struct Tokens<'a> {
    name: &'a str,
    items: Vec<(usize, &'a str)>,
    pos: usize,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str, name: &'a str) -> Self {
        let mut items = Vec::new();
        let mut last_line = 1;
        for (i, l) in text.lines().enumerate() {
            last_line = i + 1;
            let l = l.trim_start_matches('\u{feff}');
            if l.trim_start().starts_with('#') {
                continue;
            }
            items.extend(l.split_whitespace().map(|t| (i + 1, t)));
        }
        Self {
            name,
            items,
            pos: 0,
            last_line,
        }
    }

    fn error(&self, line: usize, message: &str) -> FormatError {
        FormatError {
            file: self.name.to_owned(),
            message: format!("line {line}: {message}"),
        }
    }

    /// Line of the last token read (or of the end of the file).
    fn line(&self) -> usize {
        self.pos
            .checked_sub(1)
            .and_then(|p| self.items.get(p))
            .map_or(self.last_line, |t| t.0)
    }

    fn next(&mut self, key: &str) -> Result<(usize, &'a str), FormatError> {
        let t =
            self.items.get(self.pos).copied().ok_or_else(|| {
                self.error(self.last_line, &format!("{key}: unexpected end of file"))
            })?;
        self.pos += 1;
        Ok(t)
    }

    fn keyword(&mut self, key: &str) -> Result<(), FormatError> {
        let (line, t) = self.next(key)?;
        if t.eq_ignore_ascii_case(key) {
            Ok(())
        } else {
            Err(self.error(line, &format!("expected keyword {key}, found `{t}`")))
        }
    }

    fn word(&mut self, key: &str) -> Result<(usize, &'a str), FormatError> {
        self.next(key)
    }

    fn count(&mut self, key: &str) -> Result<(usize, usize), FormatError> {
        let (line, t) = self.next(key)?;
        t.parse::<usize>()
            .map(|n| (line, n))
            .map_err(|_| self.error(line, &format!("{key}: `{t}` is not a count")))
    }

    fn numbers(&mut self, key: &str, n: usize) -> Result<Vec<f64>, FormatError> {
        (0..n)
            .map(|i| {
                let (line, t) = self.next(key)?;
                match t.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(self.error(
                        line,
                        &format!(
                            "{key}: value {} of {n}: `{t}` is not a finite number",
                            i + 1
                        ),
                    )),
                }
            })
            .collect()
    }
}

/// The Zemax format's entry of the registry
/// ([`BrdfFormat::Zemax`]): a
/// monochrome table gives one file, a spectral one a file per wavelength;
/// each is read back with [`ZemaxBsdf::parse`], and a check off its table
/// names the coarsest finer grid that passes
/// ([`ZemaxGrid::finer_per_check`]).
#[derive(Debug, Clone, Copy)]
pub struct ZemaxFormat;

impl Exporter for ZemaxFormat {
    fn name(&self) -> &'static str {
        "zemax"
    }

    fn file_name(&self) -> &'static str {
        ResultFile::Zemax.name()
    }

    fn file_kind(&self) -> FileKind {
        FileKind::Zemax
    }

    fn format(&self) -> BrdfFormat {
        BrdfFormat::Zemax
    }

    fn one_file_per_wavelength(&self) -> bool {
        true
    }

    fn options(&self) -> &'static [&'static str] {
        &["--grid"]
    }

    fn spectral_file_names(&self, wavelengths_um: &[f64]) -> Vec<String> {
        wavelength_labels(wavelengths_um)
            .iter()
            .map(|w| format!("brdf_{w}um.bsdf"))
            .collect()
    }

    fn table_bytes(
        &self,
        table: &BrdfTable,
        comment: &str,
        grid: ZemaxGrid,
    ) -> Result<Vec<u8>, ExportError> {
        Ok(grid.export(table, comment))
    }

    fn build(&self, input: &ExportInput<'_>) -> Result<Export, ExportError> {
        let (grid, comment) = (input.grid, input.comment);
        Ok(Export::of(match input.tables {
            BrdfTables::Monochrome(t) => vec![one_file(self.format(), grid.export(t, comment))],
            BrdfTables::Spectral(spectral) => spectral
                .wavelengths_um()
                .par_iter()
                .zip(spectral.tables())
                .zip(self.spectral_file_names(spectral.wavelengths_um()))
                .map(|((&w, t), file_name)| ExportFile {
                    file_name,
                    wavelength_um: Some(w),
                    bytes: grid.export(t, &wavelength_comment(comment, w)),
                    clipped: None,
                })
                .collect(),
        }))
    }

    fn judge(&self, input: &ExportInput<'_>, export: &mut Export) -> Result<(), ExportError> {
        let grid = input.grid;
        let files = export.files.clone();
        for (file, table) in files.iter().zip(input.tables.tables()) {
            let check =
                self.check_table(table, &file.bytes)
                    .map_err(|error| ExportError::Unreadable {
                        format: self.format(),
                        error,
                    })?;
            let what = match file.wavelength_um {
                Some(w) => format!("{} ({w} um)", self.name()),
                None => self.name().to_owned(),
            };
            let remedy = |check: &[ReflectanceCheck], failing: &[usize]| {
                finer_remedies(grid, table, check, failing)
            };
            export.add_judged(what, check, &remedy);
        }
        Ok(())
    }

    fn check_table(
        &self,
        table: &BrdfTable,
        bytes: &[u8],
    ) -> Result<Vec<ReflectanceCheck>, FormatError> {
        let name = self.file_name();
        let text = std::str::from_utf8(bytes).map_err(|e| FormatError {
            file: name.into(),
            message: format!("not UTF-8 text: {e}"),
        })?;
        let z = ZemaxBsdf::parse(text, name)?;
        if table.azimuths_deg().len() > 1 {
            return Ok(azimuth_checks(table, &z));
        }
        Ok(table
            .angles_deg()
            .iter()
            .enumerate()
            .map(|(k, &deg)| {
                let file_r = integrate_projected(CHECK_RINGS, |d| z.eval(k, d));
                ReflectanceCheck::of_table(table, deg, file_r)
            })
            .collect())
    }
}

/// Per failing check (indices `failing` into `check`, the checks of the
/// file of `table` on `grid`) what would do better: the coarsest finer
/// grid that makes that incidence (and light azimuth) pass, or that none
/// does, or that the grid is already as fine as the search goes.
fn finer_remedies(
    grid: ZemaxGrid,
    table: &BrdfTable,
    check: &[ReflectanceCheck],
    failing: &[usize],
) -> Vec<String> {
    let found = grid.finer_per_check(table, failing);
    failing
        .iter()
        .zip(found)
        .map(|(&i, found)| {
            let here = here(&check[i]);
            match found {
                Some(g) => format!(
                    "the finer grid `--grid {},{}` of roks export-brdf passes {here}",
                    g.azimuth_step_deg, g.radial_step_deg
                ),
                None => match grid.searched().last() {
                    Some(f) => format!(
                        "no finer grid (to {},{} degrees) passes {here}: the difference is not the grid's",
                        f.azimuth_step_deg, f.radial_step_deg
                    ),
                    None => {
                        let f = ZemaxGrid::finest_searched();
                        format!(
                            "the grid {},{} is as fine as the search goes ({},{} degrees): no finer grid is tried",
                            grid.azimuth_step_deg,
                            grid.radial_step_deg,
                            f.azimuth_step_deg,
                            f.radial_step_deg
                        )
                    }
                },
            }
        })
        .collect()
}

/// The checks of an `Asymmetrical4D` file `z` of `table` (several light
/// azimuths): per incidence angle, then azimuth, block `j m + t` (sample
/// rotation `j`, angle `t` of `m`) integrated beside the reflectance of
/// azimuth `j`'s table.
fn azimuth_checks(table: &BrdfTable, z: &ZemaxBsdf) -> Vec<ReflectanceCheck> {
    let angles = table.angles_deg();
    let m = angles.len();
    let azimuths: Vec<BrdfTable> = (0..table.azimuths_deg().len())
        .map(|j| table.azimuth(j))
        .collect();
    angles
        .iter()
        .enumerate()
        .flat_map(|(t, &deg)| {
            azimuths
                .iter()
                .enumerate()
                .map(move |(j, a)| ReflectanceCheck {
                    phi_i_deg: Some(a.azimuths_deg()[0]),
                    ..ReflectanceCheck::of_table(
                        a,
                        deg,
                        integrate_projected(CHECK_RINGS, |d| z.eval(j * m + t, d)),
                    )
                })
        })
        .collect()
}

/// Labels of the wavelengths `wavelengths_um` (µm, positive and finite)
/// for file names that sort as the wavelengths do: each in decimal with as
/// many decimals as the longest of their shortest round-trip forms needs,
/// and its integer part padded with zeros to the widest one's
/// (`[0.38, 0.4, 0.42]` -> `0.38, 0.40, 0.42`; `[3.0, 10.6]` -> `03.0,
/// 10.6`; `[3.0, 8.0, 12.0]` -> `03, 08, 12`). Distinct wavelengths get
/// distinct labels: a shortest form with at most that many decimals is the
/// nearest such decimal to its value, so the padded form is the same digits.
/// Should a label pass [`crate::output::LABEL_DIGITS`] characters (such as
/// `[1e-300, 0.5]`), every label is the shortest exponent form instead
/// (`1e-300, 5e-1`: distinct, though no longer sorting as the wavelengths).
#[must_use]
pub fn wavelength_labels(wavelengths_um: &[f64]) -> Vec<String> {
    let labels = padded_labels(wavelengths_um);
    if labels.iter().any(|l| l.len() > crate::output::LABEL_DIGITS) {
        return wavelengths_um.iter().map(|w| format!("{w:e}")).collect();
    }
    labels
}

/// The padded decimal labels of [`wavelength_labels`].
fn padded_labels(wavelengths_um: &[f64]) -> Vec<String> {
    let decimals = wavelengths_um
        .iter()
        .map(|w| w.to_string().split_once('.').map_or(0, |(_, f)| f.len()))
        .max()
        .unwrap_or(0);
    let fixed: Vec<String> = wavelengths_um
        .iter()
        .map(|w| format!("{w:.decimals$}"))
        .collect();
    let int_width = |s: &str| s.find('.').unwrap_or(s.len());
    let width = fixed.iter().map(|s| int_width(s)).max().unwrap_or(0);
    fixed
        .into_iter()
        .map(|s| format!("{}{s}", "0".repeat(width - int_width(&s))))
        .collect()
}

/// The comment of a spectral table's Zemax file of wavelength
/// `wavelength_um` (µm).
#[must_use]
pub fn wavelength_comment(comment: &str, wavelength_um: f64) -> String {
    if comment.trim().is_empty() {
        format!("wavelength {wavelength_um} um")
    } else {
        format!("{comment}; wavelength {wavelength_um} um")
    }
}

impl Default for ZemaxGrid {
    fn default() -> Self {
        Self {
            azimuth_step_deg: AZIMUTH_STEP_DEG,
            radial_step_deg: RADIAL_STEP_DEG,
        }
    }
}

impl ZemaxGrid {
    /// The grid of steps `azimuth_step_deg` and `radial_step_deg` (degrees),
    /// each in (0, 90] and dividing 180 into whole steps (to 1e-9).
    ///
    /// # Errors
    /// The first step that is not.
    pub fn new(azimuth_step_deg: f64, radial_step_deg: f64) -> Result<Self, f64> {
        for step in [azimuth_step_deg, radial_step_deg] {
            let n = 180.0 / step;
            if !(step > 0.0 && step <= 90.0) || (n - n.round()).abs() > 1e-9 * n {
                return Err(step);
            }
        }
        Ok(Self {
            azimuth_step_deg,
            radial_step_deg,
        })
    }

    /// The Zemax file of `table` on this grid, with `comment`.
    #[must_use]
    pub fn export(self, table: &BrdfTable, comment: &str) -> Vec<u8> {
        let max_azimuth = ZemaxBsdf::symmetry_of(table).max_azimuth_deg();
        ZemaxBsdf::from_table_on(
            table,
            steps(self.azimuth_step_deg, max_azimuth),
            steps(self.radial_step_deg, 180.0),
        )
        .to_text(comment)
        .into_bytes()
    }

    /// The finest grid the search for a finer grid tries: an eighth of
    /// the default steps, 0.25 x 0.125 degrees (an `Asymmetrical4D` block
    /// of 1441 x 1441 values, about 29 MB of text per incidence and
    /// azimuth); a search from a finer grid than the default would
    /// otherwise write files of gigabytes.
    #[must_use]
    pub fn finest_searched() -> Self {
        Self {
            azimuth_step_deg: AZIMUTH_STEP_DEG / 8.0,
            radial_step_deg: RADIAL_STEP_DEG / 8.0,
        }
    }

    /// The grids [`finer_per_check`](Self::finer_per_check) tries, coarsest
    /// first: this grid's steps halved once, twice and three times, as
    /// far as [`finest_searched`](Self::finest_searched) (none for a grid
    /// already that fine).
    #[must_use]
    pub fn searched(self) -> Vec<Self> {
        let floor = Self::finest_searched();
        (1..=3)
            .map(|k| {
                let f = f64::from(1 << k);
                Self {
                    azimuth_step_deg: self.azimuth_step_deg / f,
                    radial_step_deg: self.radial_step_deg / f,
                }
            })
            .take_while(|g| {
                g.azimuth_step_deg >= floor.azimuth_step_deg * (1.0 - 1e-9)
                    && g.radial_step_deg >= floor.radial_step_deg * (1.0 - 1e-9)
            })
            .collect()
    }

    /// Per check of `failing` (indices into the [`reflectance_check`](super::brdf_formats::reflectance_check) of
    /// this grid's file of `table`: per incidence angle, then light
    /// azimuth), the coarsest of the [`searched`](Self::searched) grids
    /// whose file passes that check ([`ReflectanceCheck::passes`]); `None`
    /// where none does (the difference there does not come from the grid).
    /// Each check is judged on its own: a block that passes on a finer grid
    /// is named with it even where another block passes on none. The finer
    /// files are written only while a check is unresolved.
    #[must_use]
    pub fn finer_per_check(self, table: &BrdfTable, failing: &[usize]) -> Vec<Option<Self>> {
        let mut found: Vec<Option<Self>> = vec![None; failing.len()];
        for grid in self.searched() {
            if found.iter().all(Option::is_some) {
                break;
            }
            let Ok(checks) = ZemaxFormat.check_table(table, &grid.export(table, "")) else {
                continue;
            };
            for (slot, &i) in found.iter_mut().zip(failing) {
                if slot.is_none() && checks.get(i).is_some_and(ReflectanceCheck::passes) {
                    *slot = Some(grid);
                }
            }
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_c_form() {
        assert_eq!(sci(0.0), "0.000000E+00");
        assert_eq!(sci(0.063_75), "6.375000E-02");
        assert_eq!(sci(1234.5678), "1.234568E+03");
        assert_eq!(sci(3.0e-105), "3.000000E-105");
    }

    /// `direction` and `angles` invert each other; radial angle 0 is the
    /// specular direction, azimuth 0 turns toward the normal, 90 toward +y.
    #[test]
    fn angles_about_the_specular_direction() {
        for aoi in [0.0, 30.0, 85.0] {
            let s = direction(aoi, 0.0, 0.0);
            let t = aoi.to_radians();
            assert!((s - DVec3::new(-t.sin(), 0.0, t.cos())).length() < 1e-15);
            // Radial aoi at azimuth 0 reaches the normal (toward +x at 0).
            if aoi > 0.0 {
                assert!((direction(aoi, 0.0, aoi) - DVec3::Z).length() < 1e-14);
            }
            assert!(direction(aoi, 90.0, 10.0).y > 0.0);
            for psi in [0.0, 45.0, 120.0, 180.0] {
                for r in [1.0, 20.0, 89.0, 150.0] {
                    let (p, q) = angles(aoi, direction(aoi, psi, r));
                    assert!(
                        (p - psi).abs() < 1e-9 && (q - r).abs() < 1e-9,
                        "{aoi} {psi} {r}: {p} {q}"
                    );
                }
            }
            // Plane symmetry: the mirror image has the same angles.
            let d = direction(aoi, 60.0, 40.0);
            let m = DVec3::new(d.x, -d.y, d.z);
            let (a, b) = (angles(aoi, d), angles(aoi, m));
            assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12);
        }
    }

    #[test]
    fn bilinear_between_nodes() {
        let z = ZemaxBsdf {
            symmetry: Symmetry::PlaneSymmetrical,
            rotation_deg: vec![0.0],
            aoi_deg: vec![0.0],
            azimuth_deg: vec![0.0, 180.0],
            radial_deg: vec![0.0, 10.0, 90.0],
            tis: vec![0.5],
            brdf: vec![vec![1.0, 2.0, 3.0, 1.0, 4.0, 5.0]],
        };
        // Azimuth 90 (halfway), radial 5 (halfway between 1 and 2 / 1 and 4).
        let d = direction(0.0, 90.0, 5.0);
        let expect = 0.5 * (1.5 + 2.5);
        assert!((z.eval(0, d) - expect).abs() < 1e-12, "{}", z.eval(0, d));
        assert_eq!(z.eval(0, DVec3::new(1.0, 0.0, -0.1)), 0.0);
        let back = ZemaxBsdf::parse(&z.to_text("x"), "z.bsdf").unwrap();
        assert_eq!(back, z);
    }

    /// The `Symmetry` line of an `Asymmetrical4D` file is exactly the one
    /// the guide's `sed` line rewrites for libbsdf (which takes only
    /// `ASymmetrical4D`, compared case-sensitively); the rewritten file
    /// reads back the same here (keywords in any letter case).
    #[test]
    fn asymmetrical_spelling_for_libbsdf() {
        let z = ZemaxBsdf {
            symmetry: Symmetry::Asymmetrical4D,
            rotation_deg: vec![0.0, 90.0],
            aoi_deg: vec![0.0],
            azimuth_deg: vec![0.0, 180.0, 360.0],
            radial_deg: vec![0.0, 90.0],
            tis: vec![0.5, 0.25],
            brdf: vec![vec![1.0, 2.0, 3.0, 4.0, 1.0, 2.0], vec![5.0; 6]],
        };
        let text = z.to_text("");
        let line = "Symmetry  Asymmetrical4D";
        assert_eq!(text.lines().filter(|l| *l == line).count(), 1, "{text}");
        // sed 's/^Symmetry  Asymmetrical4D$/Symmetry  ASymmetrical4D/'
        let libbsdf: String = text
            .lines()
            .map(|l| {
                if l == line {
                    "Symmetry  ASymmetrical4D"
                } else {
                    l
                }
            })
            .map(|l| format!("{l}\n"))
            .collect();
        assert_ne!(libbsdf, text);
        assert_eq!(ZemaxBsdf::parse(&libbsdf, "z.bsdf").unwrap(), z);
    }
}
