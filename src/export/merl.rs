//! The MERL binary BRDF format (Matusik, Pfister, Brand, McMillan 2003), as
//! graphics BRDF tools read it: writer ([`Merl::from_table`],
//! [`Merl::to_bytes`]) and reader ([`Merl::parse`], [`Merl::lookup`]).
//!
//! # Layout
//!
//! Little-endian: three `int32` dimensions `90, 90, 180` (theta_half,
//! theta_diff, phi_diff), then `3 x 90 x 90 x 180` `float64`, channel by
//! channel (red, green, blue), each channel with `phi_diff` fastest, then
//! `theta_diff`, then `theta_half`: index `k + 180 j + 180 90 i`. A stored
//! value times the channel scale [`SCALES`] (`1/1500`, `1.15/1500`,
//! `1.66/1500`) is the BRDF in sr⁻¹. A monochrome table is grey: the
//! three channels hold the same BRDF (different stored numbers).
//!
//! # Colour (spectral tables)
//!
//! A spectral table ([`SpectralTables`]) whose wavelengths cover the
//! visible ([`crate::optics::colour::covers_visible`]) fills the channels
//! with the linear sRGB of its BRDF under the CIE D65 illuminant
//! ([`Merl::from_spectral`]): channel `c` in a bin is
//! `Σ_l (M · w_l)_c f_l`, with `f_l` the table of wavelength `l`
//! resampled at the bin as below, `w_l` the XYZ weights of wavelength `l`
//! ([`XyzWeights::d65`]: D65 power, CIE 1931 2-degree colour-matching
//! functions, linear interpolation onto the 5 nm CIE grid, white `Y = 1`)
//! and `M` the sRGB matrix [`crate::optics::colour::XYZ_TO_SRGB`]. The
//! resampling is linear in the table's fractions with the same weights for
//! every wavelength (the tables share their grid and incidences), so this
//! is the resampling of the three per-cell colour tables
//! ([`srgb_tables`], the per-cell `(r, g, b)` of `colour.csv`): three
//! passes over the bins whatever the number of wavelengths (equal to
//! resampling each wavelength and then mapping to sRGB, to rounding; a unit
//! test checks it to 1e-12). So a grey spectrum (the same table at every
//! wavelength) gives the monochrome file's BRDF times the linear sRGB of
//! the D65 white, `xyz_to_linear_srgb(d65_white_xyz())`, `(1, 1, 1)`
//! within 1e-3.
//!
//! Linear sRGB is negative for colours outside the sRGB gamut (saturated
//! multiple reflections, e.g. in copper grooves); MERL files mark invalid
//! bins with negative values and renderers would take them as negative
//! radiance, so such components are stored as 0 and counted
//! ([`Clipped`], reported by the export's check).
//!
//! # Coordinates (Rusinkiewicz half/difference angles)
//!
//! With `omega_i` toward the light and `omega_o` toward the viewer, the half
//! vector `h = normalize(omega_i + omega_o)` has polar angle `theta_half`;
//! `omega_i` turned by `-phi_half` about the normal and by `-theta_half`
//! about `y` has polar angle `theta_diff` and azimuth `phi_diff`. The format
//! assumes an isotropic BRDF (no `phi_half`) obeying reciprocity
//! (`phi_diff` and `phi_diff + 180` degrees give the same value), so only
//! `phi_diff` in `[0, 180)` degrees is stored. Bins, as the reference reader
//! `BRDFRead.cpp` looks them up (truncation, clamped to the last bin):
//! `i = floor(sqrt(theta_half / 90 deg) 90)` (finer near the specular peak),
//! `j = floor(theta_diff / 90 deg 90)`, `k = floor(phi_diff / 180 deg 180)`.
//!
//! # Resampling
//!
//! [`Merl::from_table`] stores in each bin the table's BRDF at the bin's
//! centre in index space (`theta_half = ((i + 1/2) / 90)² 90 deg`,
//! `theta_diff = j + 1/2 deg`, `phi_diff = k + 1/2 deg`), the point that
//! the reference reader's truncation represents by the whole bin.
//!
//! The format needs a reciprocal BRDF, `f(omega_i, omega_o) =
//! f(omega_o, omega_i)` (one bin serves both), and the table is exact only
//! at its tabulated incidence angles: between them it is interpolated
//! linearly in `theta_i`, which smears a narrow specular peak into two and
//! is not reciprocal (for the default scene, `∫ f(theta_o; omega_i)
//! cos(theta_o) dω_o` differs from the reflectance by up to 4 %). Each bin
//! therefore holds the [`reciprocal_eval`] blend
//! `w f(theta_i; omega_o) + (1 - w) f(theta_o; omega_i)`, weighted toward the
//! direction whose polar angle is nearer a tabulated incidence angle
//! (`w = d_o / (d_i + d_o)`, `d` the distance in degrees to the nearest
//! tabulated angle): where the light is at a tabulated angle the file holds
//! the table's own BRDF, and it is reciprocal by construction. `f` is the
//! table's [`symmetric_eval`]. Bins whose centre puts a direction below the horizon hold the value at the
//! same azimuth just above the horizon, so that a valid direction pair that
//! falls into such a bin gets the table's value there. Incidences beyond the
//! table's largest angle take that angle's BRDF (the table clamps).

//!
//! # Several light azimuths
//!
//! The format holds an isotropic BRDF. A table of several light azimuths
//! (an anisotropic surface traced at `[light] phi_deg = [...]`) is written
//! as their average: [`BrdfTable::eval`] of such a table is the mean of the
//! azimuths' tables, each in its plane-of-incidence frame (the surface
//! turned to each tabulated azimuth in turn). [`azimuth_note`] says so, as
//! a warning when the azimuths disagree beyond their errors
//! ([`BrdfTable::anisotropy`], the figure of `summary.json`). A table of
//! one azimuth is written
//! exactly as before.

use glam::DVec3;
use rayon::prelude::*;

use super::exporter::{
    BrdfFormat, Clipped, Export, ExportError, ExportFile, ExportInput, ExportRefusal, Exporter,
    HEADING, Notice, ZemaxGrid, fixed, one_file,
};
use super::resample::{
    CHECK_RINGS, FormatError, ReflectanceCheck, integrate_projected, symmetric_eval,
};
use crate::optics::brdf_table::{BrdfTable, BrdfTables, SpectralTables};
use crate::optics::colour::XyzWeights;
use crate::optics::colour::covers_visible;
use crate::outdir::file::ResultFile;
use crate::outdir::kind::FileKind;

/// What a MERL export of `table` (several light azimuths: their average)
/// must tell: `None` for a table of one azimuth; else `(warning, line)`,
/// `warning` true when the azimuths disagree beyond their errors
/// ([`BrdfTable::anisotropy`]: `chi²/dof` above its bound, with the worst
/// pair of azimuths)
/// or when that cannot be judged (no cell pair maps exactly under the
/// azimuth differences), false (a note) when they agree. `line` is one
/// line, without a `warning:` or `note:` prefix.
#[must_use]
pub fn azimuth_note(table: &BrdfTable) -> Option<(bool, String)> {
    let az = table.azimuths_deg();
    if az.len() < 2 {
        return None;
    }
    let list = az
        .iter()
        .map(|a| format!("{a}"))
        .collect::<Vec<_>>()
        .join(", ");
    let head = format!(
        "merl: the table has {} light azimuths ({list} deg) and MERL holds an isotropic BRDF: the file is their average",
        az.len()
    );
    Some(match table.anisotropy() {
        Some(a) if a.figure.dof > 0 && !a.figure.isotropic() => {
            let worst = a
                .pairs
                .iter()
                .max_by(|p, q| p.figure.chi2_dof.total_cmp(&q.figure.chi2_dof))
                .expect("a figure with dof > 0 has a pair");
            (
                true,
                format!(
                    "{head}, but the surface is anisotropic: chi^2/dof = {:.3} over {} cell pairs (isotropic up to {:.3}), worst at theta_i {} deg between phi_i {} and {} deg (chi^2/dof = {:.3}); export zemax for an Asymmetrical4D file",
                    a.figure.chi2_dof,
                    a.figure.dof,
                    a.figure.bound,
                    worst.theta_i_deg,
                    worst.phi_a_deg,
                    worst.phi_b_deg,
                    worst.figure.chi2_dof
                ),
            )
        }
        Some(a) if a.figure.dof > 0 => (
            false,
            format!(
                "{head}; they agree within their errors (chi^2/dof = {:.3} over {} cell pairs, isotropic up to {:.3})",
                a.figure.chi2_dof, a.figure.dof, a.figure.bound
            ),
        ),
        _ => (
            true,
            format!(
                "{head}; its anisotropy cannot be judged (no Carlson cells map onto each other under the azimuth differences); export zemax for an Asymmetrical4D file"
            ),
        ),
    })
}

/// Bins in theta_half.
pub const THETA_H: usize = 90;
/// Bins in theta_diff.
pub const THETA_D: usize = 90;
/// Bins in phi_diff (half of 360: reciprocity).
pub const PHI_D: usize = 180;
/// Values per channel.
pub const N: usize = THETA_H * THETA_D * PHI_D;
/// Stored value times scale = BRDF (sr⁻¹), red, green, blue.
pub const SCALES: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// Directions whose `z` is at most this are raised to it (horizon).
const HORIZON_Z: f64 = 1e-9;

/// A MERL BRDF: three channels of `N` values in sr⁻¹ (already scaled).
#[derive(Debug, Clone, PartialEq)]
pub struct Merl {
    /// BRDF (sr⁻¹), channel-major: `values[c * N + k + 180 j + 180 90 i]`.
    pub values: Vec<f64>,
}

/// Flat index of bin `(i, j, k)` within a channel.
#[must_use]
pub fn index(i: usize, j: usize, k: usize) -> usize {
    k + PHI_D * (j + THETA_D * i)
}

/// Rotate `v` by `angle` (radians) about the unit `axis` (Rodrigues, as the
/// reference reader's `rotate_vector`).
fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis * axis.dot(v) * (1.0 - c) + axis.cross(v) * s
}

/// `(omega_i, omega_o)` at the centre of bin `(i, j, k)` in index space,
/// with `phi_half = 0`; either may point below the horizon.
#[must_use]
pub fn bin_directions(i: usize, j: usize, k: usize) -> (DVec3, DVec3) {
    let th = ((i as f64 + 0.5) / THETA_H as f64).powi(2) * std::f64::consts::FRAC_PI_2;
    let td = (j as f64 + 0.5) / THETA_D as f64 * std::f64::consts::FRAC_PI_2;
    let pd = (k as f64 + 0.5) / PHI_D as f64 * std::f64::consts::PI;
    let diff = DVec3::new(td.sin() * pd.cos(), td.sin() * pd.sin(), td.cos());
    let wi = rotate(diff, DVec3::Y, th);
    let h = DVec3::new(th.sin(), 0.0, th.cos());
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wi, wo)
}

/// `d` with `z` raised to the horizon threshold (same azimuth), unit length.
fn above_horizon(d: DVec3) -> DVec3 {
    if d.z > HORIZON_Z {
        return d;
    }
    let flat = DVec3::new(d.x, d.y, 0.0).normalize_or(DVec3::X);
    (flat + DVec3::Z * HORIZON_Z).normalize()
}

/// `(theta, d)` of `light` toward `view` in the table's frame: the polar
/// angle of `light` (radians) and `view` turned about the normal so that
/// `light` is at azimuth 0.
fn table_frame(light: DVec3, view: DVec3) -> (f64, DVec3) {
    let (s, c) = (-light.y.atan2(light.x)).sin_cos();
    (
        // atan2 keeps the polar angle's digits near the normal (acos does not).
        light.x.hypot(light.y).atan2(light.z),
        DVec3::new(c * view.x - s * view.y, s * view.x + c * view.y, view.z),
    )
}

/// The reciprocal blend stored by [`Merl::from_table`] for light from `wi`
/// seen from `wo` (unit vectors above the horizon):
/// `w f(theta_i; omega_o) + (1 - w) f(theta_o; omega_i)` with `f` the
/// table's [`symmetric_eval`] and `w = d_o / (d_i + d_o)` (1/2 if both are
/// 0), `d_i`, `d_o` the distances of `theta_i`, `theta_o` from the nearest
/// tabulated incidence angle. See the module documentation.
#[must_use]
pub fn reciprocal_eval(table: &BrdfTable, wi: DVec3, wo: DVec3) -> f64 {
    // Within 1e-9 degrees (the rounding of a computed polar angle) an angle
    // counts as tabulated.
    let distance = |theta: f64| {
        let deg = theta.to_degrees();
        let d = table
            .thetas_deg()
            .iter()
            .map(|t| (t - deg).abs())
            .fold(f64::INFINITY, f64::min);
        if d < 1e-9 { 0.0 } else { d }
    };
    let (ti, out) = table_frame(wi, wo);
    let (to, inc) = table_frame(wo, wi);
    let (di, d_o) = (distance(ti), distance(to));
    let w = if di + d_o > 0.0 {
        d_o / (di + d_o)
    } else {
        0.5
    };
    let mut v = 0.0;
    if w > 0.0 {
        v += w * symmetric_eval(table, ti, out);
    }
    if w < 1.0 {
        v += (1.0 - w) * symmetric_eval(table, to, inc);
    }
    v
}

/// `table` resampled at the bin centres (one channel, sR⁻¹; see the
/// module documentation). Bins are computed in parallel; the result does
/// not depend on the number of threads.
#[must_use]
pub fn resample(table: &BrdfTable) -> Vec<f64> {
    (0..THETA_H)
        .into_par_iter()
        .flat_map_iter(|i| {
            (0..THETA_D).flat_map(move |j| {
                (0..PHI_D).map(move |k| {
                    let (wi, wo) = bin_directions(i, j, k);
                    reciprocal_eval(table, above_horizon(wi), above_horizon(wo))
                })
            })
        })
        .collect()
}

/// The per-cell linear sRGB tables of a spectral table (red, green, blue):
/// channel `c` has in every cell the fraction `Σ_l (M · w_l)_c
/// fraction_l` (see the module documentation), so its BRDF is the cell's
/// linear sRGB of `colour.csv` and its reflectance the linear sRGB of the
/// reflectance spectrum. `None` unless the wavelengths cover the visible.
/// The tables may hold negative fractions (out of gamut); they are for
/// resampling ([`BrdfTable::eval`], [`BrdfTable::reflectance`]) only.
#[must_use]
pub fn srgb_tables(tables: &SpectralTables) -> Option<[BrdfTable; 3]> {
    let weights = XyzWeights::d65(tables.wavelengths_um())?.srgb_weights();
    Some([0, 1, 2].map(|c| {
        let channel: Vec<f64> = weights.iter().map(|w| w[c]).collect();
        tables.linear_combination(&channel)
    }))
}

impl Merl {
    /// Resample `table` at the bin centres (see the module documentation):
    /// three equal channels.
    #[must_use]
    pub fn from_table(table: &BrdfTable) -> Self {
        let grey = resample(table);
        let mut values = Vec::with_capacity(3 * N);
        for _ in 0..3 {
            values.extend_from_slice(&grey);
        }
        Self { values }
    }

    /// The colour MERL of a spectral table: channel `c` the resampled
    /// [`srgb_tables`] `c`, negative values stored as 0 (counted in
    /// [`Clipped`]). `None` unless the wavelengths cover the visible.
    #[must_use]
    pub fn from_spectral(tables: &SpectralTables) -> Option<(Self, Clipped)> {
        let channels = srgb_tables(tables)?;
        let mut values = Vec::with_capacity(3 * N);
        let mut clipped = Clipped::default();
        for t in &channels {
            for v in resample(t) {
                if v < 0.0 {
                    clipped.values += 1;
                    clipped.most_negative = clipped.most_negative.min(v);
                    values.push(0.0);
                } else {
                    values.push(v);
                }
            }
        }
        Some((Self { values }, clipped))
    }

    /// The file's bytes.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(12 + 8 * self.values.len());
        for d in [THETA_H, THETA_D, PHI_D] {
            b.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for (c, chunk) in self.values.chunks(N).enumerate() {
            for v in chunk {
                b.extend_from_slice(&(v / SCALES[c]).to_le_bytes());
            }
        }
        b
    }

    /// Read a MERL file's bytes; `name` names it in errors. The dimensions
    /// must be `90 x 90 x 180` and the length exactly theirs; values must be
    /// finite (MERL's own measurements mark invalid bins with negative
    /// values, which are kept).
    ///
    /// # Errors
    /// A [`FormatError`] naming `name` and what is wrong.
    pub fn parse(bytes: &[u8], name: &str) -> Result<Self, FormatError> {
        let fail = |message: String| FormatError {
            file: name.to_owned(),
            message,
        };
        if bytes.len() < 12 {
            return Err(fail(format!(
                "{} bytes: too short for the three int32 dimensions",
                bytes.len()
            )));
        }
        let dim = |k: usize| {
            let mut four = [0u8; 4];
            four.copy_from_slice(&bytes[4 * k..4 * k + 4]);
            i32::from_le_bytes(four)
        };
        let dims = [dim(0), dim(1), dim(2)];
        if dims != [THETA_H as i32, THETA_D as i32, PHI_D as i32] {
            return Err(fail(format!(
                "dimensions {} x {} x {}, expected {THETA_H} x {THETA_D} x {PHI_D}",
                dims[0], dims[1], dims[2]
            )));
        }
        let expected = 12 + 8 * 3 * N;
        if bytes.len() != expected {
            return Err(fail(format!(
                "{} bytes, expected {expected} (12 + 8 x 3 x {N})",
                bytes.len()
            )));
        }
        let mut values = Vec::with_capacity(3 * N);
        for (n, b) in bytes[12..].chunks_exact(8).enumerate() {
            let mut eight = [0u8; 8];
            eight.copy_from_slice(b);
            let v = f64::from_le_bytes(eight);
            if !v.is_finite() {
                return Err(fail(format!(
                    "value {n} (channel {}, bin {}) is not finite",
                    n / N,
                    n % N
                )));
            }
            values.push(v * SCALES[n / N]);
        }
        Ok(Self { values })
    }

    /// The BRDF (sr⁻¹, red, green, blue) for light from `wi` seen from `wo`
    /// (unit vectors, local frame, `z` the normal), looked up as the
    /// reference reader `BRDFRead.cpp` does: half/difference angles, then
    /// the bin by truncation, `phi_diff < 0` folded by `+180` degrees.
    #[must_use]
    pub fn lookup(&self, wi: DVec3, wo: DVec3) -> [f64; 3] {
        let h = ((wi + wo) * 0.5).normalize();
        let theta_h = h.z.clamp(-1.0, 1.0).acos();
        let phi_h = h.y.atan2(h.x);
        let tmp = rotate(wi, DVec3::Z, -phi_h);
        let diff = rotate(tmp, DVec3::Y, -theta_h);
        let theta_d = diff.z.clamp(-1.0, 1.0).acos();
        let mut phi_d = diff.y.atan2(diff.x);
        let half_pi = std::f64::consts::FRAC_PI_2;
        let i = if theta_h <= 0.0 {
            0
        } else {
            ((theta_h / half_pi * THETA_H as f64 * THETA_H as f64).sqrt() as usize).min(THETA_H - 1)
        };
        let j = ((theta_d / half_pi * THETA_D as f64).max(0.0) as usize).min(THETA_D - 1);
        if phi_d < 0.0 {
            phi_d += std::f64::consts::PI;
        }
        let k = ((phi_d / std::f64::consts::PI * PHI_D as f64).max(0.0) as usize).min(PHI_D - 1);
        let at = index(i, j, k);
        [0, 1, 2].map(|c| self.values[c * N + at])
    }
}

/// The MERL format's entry of the registry
/// ([`BrdfFormat::Merl`]): one
/// file, grey for a monochrome table (or a run of one wavelength), the
/// linear sRGB of the BRDF under D65 for a spectral one covering the
/// visible (refused otherwise: [`ExportRefusal::NotVisible`]).
#[derive(Debug, Clone, Copy)]
pub struct MerlFormat;

/// What a check off its table can do about a MERL file.
const FIXED: &str = "the MERL grid is fixed by its format; export zemax for a finer one";

impl Exporter for MerlFormat {
    fn name(&self) -> &'static str {
        "merl"
    }

    fn file_name(&self) -> &'static str {
        ResultFile::Merl.name()
    }

    fn file_kind(&self) -> FileKind {
        FileKind::Merl
    }

    fn format(&self) -> BrdfFormat {
        BrdfFormat::Merl
    }

    fn check_wavelengths(&self, wavelengths_um: &[f64]) -> Result<(), ExportRefusal> {
        match (wavelengths_um.first(), wavelengths_um.last()) {
            // One wavelength is a monochrome table: a grey MERL file.
            (Some(&first), Some(&last))
                if wavelengths_um.len() > 1 && !covers_visible(wavelengths_um) =>
            {
                Err(ExportRefusal::NotVisible { first, last })
            }
            _ => Ok(()),
        }
    }

    fn table_bytes(
        &self,
        table: &BrdfTable,
        _comment: &str,
        _grid: ZemaxGrid,
    ) -> Result<Vec<u8>, ExportError> {
        Ok(Merl::from_table(table).to_bytes())
    }

    fn build(&self, input: &ExportInput<'_>) -> Result<Export, ExportError> {
        let format = self.format();
        let spectral = match input.tables {
            BrdfTables::Monochrome(t) => {
                return Ok(Export::of(vec![one_file(
                    format,
                    Merl::from_table(t).to_bytes(),
                )]));
            }
            BrdfTables::Spectral(s) => s,
        };
        let refused = |refusal| ExportError::Refused {
            option: input.option,
            format,
            refusal,
        };
        self.check_wavelengths(spectral.wavelengths_um())
            .map_err(refused)?;
        // A run of one wavelength exports as a monochrome one: grey.
        if spectral.wavelengths_um().len() == 1 {
            let bytes = Merl::from_table(&spectral.tables()[0]).to_bytes();
            return Ok(Export::of(vec![one_file(format, bytes)]));
        }
        let (m, clipped) = Merl::from_spectral(spectral).ok_or_else(|| {
            let w = spectral.wavelengths_um();
            refused(ExportRefusal::NotVisible {
                first: w[0],
                last: w[w.len() - 1],
            })
        })?;
        Ok(Export::of(vec![ExportFile {
            clipped: Some(clipped),
            ..one_file(format, m.to_bytes())
        }]))
    }

    fn judge(&self, input: &ExportInput<'_>, export: &mut Export) -> Result<(), ExportError> {
        let unreadable = |error| ExportError::Unreadable {
            format: self.format(),
            error,
        };
        let tables = input.tables;
        match tables.spectral() {
            Some(s) if s.wavelengths_um().len() > 1 => {
                let file = export.files[0].clone();
                let check = colour_reflectance_check(s, &file.bytes).map_err(unreadable)?;
                self.judge_colour(export, &check, file.clipped);
            }
            _ => {
                // Several light azimuths: the file is their average.
                let mean;
                let table = match tables.spectral() {
                    Some(s) => {
                        mean = s.mean();
                        &mean
                    }
                    None => &tables.tables()[0],
                };
                match azimuth_note(table) {
                    Some((true, line)) => export.notices.push(Notice::Warning(line)),
                    Some((false, line)) => export.notices.push(Notice::Aside(line)),
                    None => {}
                }
                let files = export.files.clone();
                for (file, table) in files.iter().zip(tables.tables()) {
                    let check = self.check_table(table, &file.bytes).map_err(unreadable)?;
                    let what = match file.wavelength_um {
                        Some(w) => format!("{} ({w} um)", self.name()),
                        None => self.name().to_owned(),
                    };
                    export.add_judged(what, check, &fixed(FIXED.into()));
                }
            }
        }
        Ok(())
    }

    fn check_table(
        &self,
        table: &BrdfTable,
        bytes: &[u8],
    ) -> Result<Vec<ReflectanceCheck>, FormatError> {
        let m = Merl::parse(bytes, self.file_name())?;
        Ok(table
            .angles_deg()
            .iter()
            .map(|&deg| {
                let theta = deg.to_radians();
                let light = DVec3::new(theta.sin(), 0.0, theta.cos());
                let file_r = integrate_projected(CHECK_RINGS, |d| m.lookup(light, d)[0]);
                ReflectanceCheck::of_table(table, deg, file_r)
            })
            .collect())
    }
}

impl MerlFormat {
    /// The checks of a colour file per channel (`check`: per incidence,
    /// red, green and blue), and the count of clipped components.
    fn judge_colour(
        &self,
        export: &mut Export,
        check: &[[ReflectanceCheck; 3]],
        clipped: Option<Clipped>,
    ) {
        let format = self.name();
        for (c, channel) in ["red", "green", "blue"].iter().enumerate() {
            let channel_check: Vec<_> = check.iter().map(|k| k[c]).collect();
            if c == 0 {
                export.notices.push(Notice::Table(format!(
                    "{format}: {HEADING}, linear sRGB under D65"
                )));
            }
            export.add_check(
                format!("{format} ({channel})"),
                Some(format!("{channel}:")),
                channel_check,
                &fixed(FIXED.into()),
            );
        }
        if let Some(clip) = clipped.filter(|c| c.values > 0) {
            export.notices.push(Notice::Table(format!(
                "{format}: {} values had a negative linear sRGB component (out of gamut), stored as 0; the most negative {:.3e} 1/sr",
                clip.values, clip.most_negative
            )));
        }
    }
}

/// [`reflectance_check`](super::brdf_formats::reflectance_check) of a
/// colour MERL file (`bytes` written by [`Merl::from_spectral`] for
/// `tables`): per tabulated incidence and channel (red, green, blue), the
/// channel of the file integrated over the hemisphere beside the linear
/// sRGB of the table's reflectance spectrum (the reflectance of
/// [`srgb_tables`]). Clipped negative components make the file's value
/// larger than the table's.
///
/// # Errors
/// If the reader rejects `bytes`, or the wavelengths do not cover the
/// visible.
pub fn colour_reflectance_check(
    tables: &SpectralTables,
    bytes: &[u8],
) -> Result<Vec<[ReflectanceCheck; 3]>, FormatError> {
    let name = MerlFormat.file_name();
    let channels = srgb_tables(tables).ok_or_else(|| FormatError {
        file: name.into(),
        message: "the wavelengths do not cover the visible: no colour".into(),
    })?;
    let weights = crate::optics::colour::XyzWeights::d65(tables.wavelengths_um())
        .map(|w| w.srgb_weights())
        .unwrap_or_default();
    let m = Merl::parse(bytes, name)?;
    Ok(tables.tables()[0]
        .angles_deg()
        .iter()
        .map(|&deg| {
            let theta = deg.to_radians();
            let light = DVec3::new(theta.sin(), 0.0, theta.cos());
            [0, 1, 2].map(|c| ReflectanceCheck {
                theta_i_deg: deg,
                phi_i_deg: None,
                table: channels[c].reflectance(theta),
                file: integrate_projected(CHECK_RINGS, |d| m.lookup(light, d)[c]),
                table_stderr: weights
                    .iter()
                    .zip(tables.tables())
                    .map(|(w, t)| w[c].abs() * t.reflectance_stderr(theta))
                    .sum(),
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lookup of a bin centre's own directions finds that bin, for every
    /// bin whose directions are above the horizon (the two are independent
    /// code paths: rotations forward and back).
    #[test]
    fn bin_centres_look_up_their_own_bin() {
        let mut m = Merl {
            values: vec![0.0; 3 * N],
        };
        for (n, v) in m.values[..N].iter_mut().enumerate() {
            *v = n as f64;
        }
        let mut checked = 0;
        for i in 0..THETA_H {
            for j in 0..THETA_D {
                for k in (0..PHI_D).step_by(7) {
                    let (wi, wo) = bin_directions(i, j, k);
                    assert!((wi.length() - 1.0).abs() < 1e-14 && (wo.length() - 1.0).abs() < 1e-14);
                    if wi.z > 0.0 && wo.z > 0.0 {
                        assert_eq!(
                            m.lookup(wi, wo)[0],
                            index(i, j, k) as f64,
                            "bin {i} {j} {k}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > N / 7 / 2, "{checked}");
    }

    /// The colour path (resampling the three per-cell linear sRGB tables)
    /// equals resampling every wavelength and then mapping to linear sRGB,
    /// bin by bin, to 1e-12 of the size of the terms summed (`Σ_l |(M
    /// w_l)_c f_l|`: the sRGB matrix has negative entries, so a channel can
    /// be a difference of larger terms); and each cell of the sRGB tables is
    /// the linear sRGB of the cell's BRDF spectrum as `colour.csv` computes
    /// it (XYZ, then the matrix).
    #[test]
    fn colour_equals_per_wavelength_resampling_then_srgb() {
        use crate::optics::colour::{XyzWeights, xyz_to_linear_srgb};
        use crate::tally::CarlsonGrid;
        let ws = vec![0.38, 0.5, 0.62, 0.7, 0.78];
        let grid = CarlsonGrid::new(4).unwrap();
        let n = grid.n_cells();
        // Per wavelength a different, lumpy BRDF at 0, 35 and 70 degrees.
        let tables: Vec<BrdfTable> = (0..ws.len())
            .map(|l| {
                let blocks = [0.0, 35.0, 70.0]
                    .iter()
                    .enumerate()
                    .map(|(i, &t)| {
                        let f: Vec<f64> = (0..n)
                            .map(|c| {
                                let x = (c * 7 + i * 3 + l * 5) % 11;
                                0.8 * (x as f64 + 0.5) / (11.0 * n as f64)
                            })
                            .collect();
                        (t, 0.0, f, vec![0.0; n])
                    })
                    .collect();
                BrdfTable::from_blocks(grid, blocks, "t").unwrap()
            })
            .collect();
        let spectral = SpectralTables::new(ws.clone(), tables, "t").unwrap();
        let srgb = XyzWeights::d65(&ws).unwrap().srgb_weights();
        let channels = srgb_tables(&spectral).unwrap();
        // Per cell: colour.csv's formula.
        let weights = XyzWeights::d65(&ws).unwrap();
        for i in 0..3 {
            for flat in 0..n {
                let f: Vec<f64> = spectral
                    .tables()
                    .iter()
                    .map(|t| t.cell_brdf(i, flat))
                    .collect();
                let rgb = xyz_to_linear_srgb(weights.xyz(&f).unwrap());
                for c in 0..3 {
                    let got = channels[c].cell_brdf(i, flat);
                    assert!(
                        (got - rgb[c]).abs() <= 1e-12 * rgb[c].abs().max(1.0),
                        "{got} {}",
                        rgb[c]
                    );
                }
            }
        }
        // Bin by bin.
        let per_wavelength: Vec<Vec<f64>> = spectral.tables().iter().map(resample).collect();
        let (m, _) = Merl::from_spectral(&spectral).unwrap();
        let mut compared = 0;
        for c in 0..3 {
            let colour = resample(&channels[c]);
            for bin in 0..N {
                let terms = per_wavelength.iter().zip(&srgb).map(|(v, w)| w[c] * v[bin]);
                let (sum, size) = terms.fold((0.0, 0.0), |(s, a), t| (s + t, a + t.abs()));
                assert!(
                    (colour[bin] - sum).abs() <= 1e-12 * size,
                    "channel {c} bin {bin}: {} vs {sum}",
                    colour[bin]
                );
                assert_eq!(m.values[c * N + bin], colour[bin].max(0.0));
                compared += usize::from(size > 0.0);
            }
        }
        assert!(compared > N, "{compared}");
    }

    /// Reciprocity fold: swapping light and viewer is phi_diff + 180 deg,
    /// the same bin.
    #[test]
    fn swapped_directions_share_a_bin() {
        let mut m = Merl {
            values: vec![0.0; 3 * N],
        };
        for (n, v) in m.values.iter_mut().enumerate() {
            *v = n as f64;
        }
        let wi = DVec3::new(0.3, 0.2, 0.9).normalize();
        let wo = DVec3::new(-0.5, 0.1, 0.7).normalize();
        assert_eq!(m.lookup(wi, wo), m.lookup(wo, wi));
    }
}
