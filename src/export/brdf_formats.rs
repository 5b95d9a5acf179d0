//! Export of a BRDF table (`brdf.csv` of `roks brdf`, read as a
//! [`BrdfTable`]) to the file formats other programs read
//! (`roks export-brdf`, `roks brdf --export`):
//!
//! * [`BrdfFormat::Zemax`]: the Zemax / Radiant tabular BSDF text format
//!   (`brdf.bsdf`; [`super::zemax`]), read by OpticStudio's tabular BSDF
//!   scatter model and other stray-light tools;
//! * [`BrdfFormat::Merl`]: the MERL binary format (`brdf.binary`;
//!   [`super::merl`]), read by graphics BRDF tools;
//! * [`BrdfFormat::Rgl`]: the RGL measured-BRDF tensor file
//!   (`brdf_rgl.bsdf`; [`super::rgl`], its own resampling onto the
//!   renderer's warped grid), read by Mitsuba 3 and pbrt-v4;
//! * [`BrdfFormat::Pbsdf`]: the polarised measured BRDF of Baek et al.
//!   2020 (`brdf.pbsdf`; [`super::pbsdf`]: the Mueller table resampled onto
//!   the Rusinkiewicz grid), read by Mitsuba 3's `measured_polarized`.
//!
//! Zemax and MERL resample the table with [`symmetric_eval`](super::resample::symmetric_eval) (in
//! [`super::resample`], which the formats share; this module only
//! dispatches to them): the table's BRDF
//! (constant over each Carlson cell, linear in the incidence angle between
//! tabulated angles, clamped outside them) averaged with its mirror image in
//! the plane of incidence. A statistically isotropic surface has a BRDF
//! symmetric about the plane of incidence, both formats assume it, and the
//! average of a cell and its mirror cell keeps every cell's share of the
//! reflectance while halving the Monte Carlo noise of the asymmetric part.
//!
//! [`reflectance_check`] reads an export back with the format's own reader
//! and integrates it over the hemisphere: the difference from the table's
//! reflectance is the resampling error of the export.
//!
//! # Spectral tables
//!
//! [`BrdfFormat::export_tables`] exports a monochrome table as before (one
//! file, [`BrdfFormat::file_name`], the same bytes as
//! [`BrdfFormat::export`]) and a spectral one ([`SpectralTables`](crate::optics::brdf_table::SpectralTables)) as:
//!
//! * **Zemax**: one `Monochrome` file per wavelength, named
//!   `brdf_<wavelength>um.bsdf` ([`BrdfFormat::spectral_file_names`]; the
//!   wavelength in µm, written by [`wavelength_labels`](zemax::wavelength_labels) with the same
//!   number of digits for every file of the set, so that the names sort
//!   as the wavelengths do: `brdf_0.38um.bsdf`, `brdf_0.40um.bsdf`, ...,
//!   or `brdf_03.0um.bsdf` ... `brdf_14.0um.bsdf`), each the export of
//!   that wavelength's table with a comment line giving the wavelength as
//!   in the `wavelength_um` column of `brdf.csv`. The format cannot hold a spectrum:
//!   its `SpectralContent` is `Monochrome` or `XYZ` (tristimulus) only
//!   (R. Rykowski, "BSDF Data Interchange File Format Specification",
//!   Radiant Imaging / Zemax knowledge base article 229, 2008, Table 1, line
//!   3; "Zemax Tabular BSDF data file format", Zemax support article
//!   1500005486801), and OpticStudio's tabular BSDF model reads an `XYZ`
//!   file as three separate monochrome distributions chosen by its
//!   `Tristimulus` parameter (Zemax knowledge base article 231, "How to Use
//!   Tabular BSDF Data to Define the Surface Scattering Distribution"), so
//!   a scatter model per wavelength is the format's way to a spectral BSDF.
//! * **MERL**: one file, `brdf.binary`, its red, green and blue channels
//!   the linear sRGB of the BRDF under D65 ([`merl::Merl::from_spectral`])
//!   when the wavelengths cover the visible 0.38-0.78 µm. Otherwise the
//!   export is refused ([`ExportRefusal`]): a MERL file has colour channels
//!   and nothing else, and filling them from wavelengths outside the
//!   visible (or with their grey mean) would make a file that reads as a
//!   colour it is not; the refusal names the way out (Zemax, one file per
//!   wavelength, or wavelengths covering the visible).

use std::fmt;

use super::exporter::{
    BrdfFormat, ExportError, ExportFile, ExportInput, ExportRefusal, Exporter, ZemaxGrid,
};
use super::resample::{FormatError, ReflectanceCheck};
use super::{merl, pbsdf, rgl, zemax};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::outdir::kind::FileKind;

/// The registry: one line per format, its variant of [`BrdfFormat`] and
/// the module's [`Exporter`]. Every per-format answer comes from there.
impl BrdfFormat {
    /// The format's module.
    #[must_use]
    pub fn exporter(self) -> &'static dyn Exporter {
        match self {
            Self::Zemax => &zemax::ZemaxFormat,
            Self::Merl => &merl::MerlFormat,
            Self::Rgl => &rgl::RglFormat,
            Self::Pbsdf => &pbsdf::PbsdfFormat,
        }
    }
}

impl BrdfFormat {
    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        self.exporter().name()
    }

    /// The file name `roks brdf --export` writes beside `brdf.csv`.
    #[must_use]
    pub fn file_name(self) -> &'static str {
        self.exporter().file_name()
    }

    /// The kind of file an export of this format is, to tell an existing
    /// one ([`crate::outdir::kind`]).
    #[must_use]
    pub fn file_kind(self) -> FileKind {
        self.exporter().file_kind()
    }

    /// The file's bytes for `table`; `comment` (one line) goes into the
    /// header of the formats that have one.
    ///
    /// # Errors
    /// A table the format cannot hold (RGL: light azimuths no file holds;
    /// pbsdf: a table without its Mueller table).
    pub fn export(self, table: &BrdfTable, comment: &str) -> Result<Vec<u8>, ExportError> {
        self.export_on(table, comment, ZemaxGrid::default())
    }

    /// [`export`](Self::export) with a Zemax file on `grid` (the other
    /// formats' grids are fixed).
    ///
    /// # Errors
    /// As [`export`](Self::export).
    pub fn export_on(
        self,
        table: &BrdfTable,
        comment: &str,
        grid: ZemaxGrid,
    ) -> Result<Vec<u8>, ExportError> {
        self.exporter().table_bytes(table, comment, grid)
    }
}

impl BrdfFormat {
    /// The file names `roks brdf --export` writes beside a spectral
    /// `brdf.csv` with wavelengths `wavelengths_um` (µm, increasing), one
    /// per wavelength: `brdf_<label>um.bsdf` for Zemax, the labels of
    /// [`wavelength_labels`](zemax::wavelength_labels); the other formats have one file for all
    /// wavelengths, [`file_name`](Self::file_name), repeated.
    #[must_use]
    pub fn spectral_file_names(self, wavelengths_um: &[f64]) -> Vec<String> {
        self.exporter().spectral_file_names(wavelengths_um)
    }

    /// Whether tables at `wavelengths_um` (µm, increasing; empty:
    /// monochrome) can be exported in this format (before tracing them).
    ///
    /// # Errors
    /// [`ExportRefusal::NotVisible`] for MERL of several wavelengths that do
    /// not cover the visible (one wavelength exports as a grey table);
    /// [`ExportRefusal::Pbsdf`] for pbsdf of other than 0, 1 or 5.
    pub fn check_wavelengths(self, wavelengths_um: &[f64]) -> Result<(), ExportRefusal> {
        self.exporter().check_wavelengths(wavelengths_um)
    }

    /// The files of `tables` in this format (see the module documentation):
    /// one for a monochrome table ([`export`](Self::export)); for a
    /// spectral one a Zemax file per wavelength (`comment` followed by the
    /// wavelength), one colour MERL file, one RGL or pbsdf file.
    ///
    /// # Errors
    /// A table the format cannot hold ([`ExportError::Refused`] and the
    /// like) or a writer's defect.
    pub fn export_tables(
        self,
        tables: &BrdfTables,
        comment: &str,
    ) -> Result<Vec<ExportFile>, ExportError> {
        self.export_tables_on(tables, comment, ZemaxGrid::default())
    }

    /// [`export_tables`](Self::export_tables) with Zemax files on `grid`.
    ///
    /// # Errors
    /// As [`export_tables`](Self::export_tables).
    pub fn export_tables_on(
        self,
        tables: &BrdfTables,
        comment: &str,
        grid: ZemaxGrid,
    ) -> Result<Vec<ExportFile>, ExportError> {
        let input = ExportInput {
            grid,
            ..ExportInput::new(tables, comment)
        };
        Ok(self.exporter().build(&input)?.files)
    }
}

impl fmt::Display for BrdfFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Read an export back (`bytes` as written by [`BrdfFormat::export`]) and
/// integrate its BRDF times `cos(theta_o)` over the hemisphere at every
/// tabulated incidence angle of `table` by [`integrate_projected`](super::resample::integrate_projected) with
/// [`CHECK_RINGS`](super::resample::CHECK_RINGS) rings: the file's directional-hemispherical reflectance,
/// beside the table's ([`Exporter::check_table`] of the format's module).
///
/// Zemax: the file's `AngleOfIncidence` blocks, interpolated bilinearly in
/// (azimuth, radial) by [`zemax::ZemaxBsdf::eval`]; for a table of several
/// light azimuths (`Asymmetrical4D`) one check per incidence angle and
/// azimuth, in the table's order (angle, then azimuth), the block of sample
/// rotation `phi_i_deg` beside [`BrdfTable::azimuth`]'s reflectance. MERL:
/// the reference lookup [`merl::Merl::lookup`] (nearest bin, as the MERL
/// reader does) with the light at `theta_i`, one check per incidence angle
/// beside the table's (for several azimuths, their average's) reflectance.
///
/// # Errors
/// If the reader rejects `bytes`.
pub fn reflectance_check(
    table: &BrdfTable,
    format: BrdfFormat,
    bytes: &[u8],
) -> Result<Vec<ReflectanceCheck>, FormatError> {
    format.exporter().check_table(table, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::exporter::ExportRefusal;
    use crate::export::resample::integrate_projected;
    use crate::export::zemax::wavelength_labels;

    /// The tolerance is max(1 % of the table, 4 standard errors).
    #[test]
    fn reflectance_checks_pass_within_the_larger_of_1_percent_and_4_sigma() {
        let check = |file, table_stderr| ReflectanceCheck {
            theta_i_deg: 0.0,
            phi_i_deg: None,
            table: 0.5,
            file,
            table_stderr,
        };
        assert_eq!(check(0.5, 1e-4).tolerance(), 0.005);
        assert_eq!(check(0.5, 0.002).tolerance(), 0.008);
        assert!(check(0.5049, 1e-4).passes());
        assert!(!check(0.5051, 1e-4).passes());
        assert!(check(0.4921, 0.002).passes());
        assert!(!check(0.4919, 0.002).passes());
        // An absorbing surface: a file of 0 passes, anything else does not.
        let zero = |file| ReflectanceCheck {
            table: 0.0,
            ..check(file, 0.0)
        };
        assert!(zero(0.0).passes() && !zero(1e-9).passes());
    }

    /// A table on 4 bands at normal incidence, half the light spread
    /// evenly over the cells, one block per light azimuth of `phis`
    /// (degrees).
    fn flat_table(phis: &[f64]) -> BrdfTable {
        let g = crate::tally::CarlsonGrid::new(4).unwrap();
        let f = vec![0.5 / g.n_cells() as f64; g.n_cells()];
        let blocks = phis
            .iter()
            .map(|&p| (0.0, p, f.clone(), vec![0.0; f.len()]))
            .collect();
        BrdfTable::from_blocks(g, blocks, "t.csv").unwrap()
    }

    /// A table a format cannot hold is an error, never empty bytes (as
    /// `export_on` returned before): pbsdf without the Mueller table, rgl
    /// of light azimuths no RGL file holds; the formats that hold it give
    /// bytes that read back.
    #[test]
    fn an_export_that_cannot_be_made_is_an_error() {
        let one = flat_table(&[0.0]);
        let refused = BrdfFormat::Pbsdf.export(&one, "");
        assert!(
            matches!(
                refused,
                Err(ExportError::Pbsdf(
                    crate::export::exporter::PbsdfRefusal::NoMueller
                ))
            ),
            "{refused:?}"
        );
        let odd = flat_table(&[0.0, 45.0]);
        let refused = BrdfFormat::Rgl.export(&odd, "");
        assert!(
            matches!(
                &refused,
                Err(ExportError::Refused {
                    refusal: ExportRefusal::RglAzimuths(_),
                    ..
                })
            ),
            "{refused:?}"
        );
        for format in [BrdfFormat::Zemax, BrdfFormat::Merl] {
            let bytes = format.export(&one, "").unwrap();
            assert!(reflectance_check(&one, format, &bytes).is_ok(), "{format}");
        }
    }

    #[test]
    fn format_names_are_the_option_values() {
        use clap::ValueEnum as _;
        assert_eq!(BrdfFormat::from_str("zemax", false), Ok(BrdfFormat::Zemax));
        assert_eq!(BrdfFormat::from_str("MERL", true), Ok(BrdfFormat::Merl));
        assert!(BrdfFormat::from_str("pbrt", true).is_err());
        for f in BrdfFormat::value_variants() {
            assert_eq!(f.to_possible_value().unwrap().get_name(), f.name());
            assert_eq!(f.to_string(), f.name());
        }
    }

    #[test]
    fn wavelength_labels_sort_as_the_wavelengths() {
        let labels = |w: &[f64]| wavelength_labels(w);
        assert_eq!(labels(&[0.38, 0.4, 0.42]), ["0.38", "0.40", "0.42"]);
        assert_eq!(labels(&[3.0, 10.6]), ["03.0", "10.6"]);
        assert_eq!(labels(&[3.0, 8.0, 12.0]), ["03", "08", "12"]);
        assert_eq!(labels(&[0.55]), ["0.55"]);
        assert!(labels(&[]).is_empty());
        // Grid points are rounded to 1e-9 um: 9 decimals stay distinct.
        let grid: Vec<f64> = (0..=400)
            .map(|i| ((0.38 + f64::from(i) * 0.001) * 1e9).round() / 1e9)
            .chain([0.780_000_001, 0.780_000_002, 12.5])
            .collect();
        let l = labels(&grid);
        let mut sorted = l.clone();
        sorted.sort();
        assert_eq!(sorted, l, "lexical order is numeric order");
        sorted.dedup();
        assert_eq!(sorted.len(), grid.len(), "distinct");
        for (label, w) in l.iter().zip(&grid) {
            assert_eq!(label.parse::<f64>().unwrap(), *w, "{label}");
        }
        assert_eq!(
            BrdfFormat::Zemax.spectral_file_names(&[0.4, 0.41]),
            ["brdf_0.40um.bsdf", "brdf_0.41um.bsdf"]
        );
    }

    /// A wavelength whose decimal form is hundreds of digits long (1e-300
    /// um) gives every label its exponent form, distinct and short, rather
    /// than a file name too long for the file system.
    #[test]
    fn extreme_wavelengths_get_exponent_labels() {
        let l = wavelength_labels(&[1e-300, 0.5]);
        assert_eq!(l, ["1e-300", "5e-1"]);
        assert_eq!(wavelength_labels(&[0.5, 1e30]), ["5e-1", "1e30"]);
        for (label, w) in l.iter().zip([1e-300, 0.5]) {
            assert_eq!(label.parse::<f64>().unwrap(), w);
        }
    }

    /// Constants integrate exactly (`∫ cos dω = pi`); `∫ cos² dω = 2 pi / 3`
    /// to the midpoint rule's second-order error, `(pi/2 / n)² / 24` of the
    /// integrand's curvature, below 1e-4 for n = 64.
    #[test]
    fn quadrature_of_known_integrals() {
        let pi = std::f64::consts::PI;
        assert!((integrate_projected(64, |_| 1.0) - pi).abs() < 1e-13);
        let c2 = integrate_projected(64, |d| d.z);
        assert!((c2 - 2.0 * pi / 3.0).abs() < 1e-4, "{c2}");
        // Azimuthal structure integrates out: cos(phi) over whole sectors.
        assert!(integrate_projected(64, |d| d.x).abs() < 1e-13);
    }
}
