//! `colour.csv` and `colour_<theta>deg.png`: the colour of a spectral BRDF
//! per Carlson cell, for a spectral run whose wavelengths cover the visible
//! (0.38-0.78 µm, [`crate::optics::colour::covers_visible`]).
//!
//! # Formula
//! Per incidence and cell, the BRDF `f(λ_l)` (sr⁻¹) of each wavelength of
//! the run goes through the linear map of [`crate::optics::colour`]: CIE
//! 1931 XYZ under D65, `X = Σ_l w_X,l f(λ_l)` (likewise Y, Z), the weights
//! holding the D65 power, the 2-degree colour-matching functions at 5 nm, the
//! linear interpolation of `f` onto that grid and the normalisation that
//! gives the perfect white reflector `Y = 1`; then linear sRGB
//! `(r, g, b) = M · (X, Y, Z)` (IEC 61966-2-1). So a Lambertian white surface
//! (`f = 1/π` at every wavelength) has `Y = 1/π` in every cell and
//! `(r, g, b) ≈ (1, 1, 1)/π`: `X, Y, Z, r, g, b` are the colour of the BRDF in
//! sr⁻¹, not clipped (out-of-gamut components are below 0 or above the
//! others). Being linear in `f`, they are the XYZ and sRGB of the cell's
//! fraction divided by its projected solid angle.
//!
//! # Columns
//! `theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,X,Y,Z,r,g,b`: the
//! incidence and cell as in `brdf.csv` (cell centre in degrees, absolute
//! azimuth), then the colour (10 significant digits).
//!
//! # The picture
//! `colour_<theta>deg.png` ([`crate::plot::folder`], from `colour.csv`) is
//! the equal-area hemisphere map of `hemisphere_<theta>deg.png` painted
//! with each cell's colour ([`display_colours`]): its chromaticity at a
//! brightness that is the log of its luminance `Y` over four decades below
//! the brightest cell (linear sRGB divided by `Y`, times that brightness,
//! scaled down to fit in `[0, 1]` keeping the hue, then the sRGB transfer
//! function); cells without a photon are striped, with a key.

use std::fmt::Write as _;

use crate::optics::colour::{XyzWeights, xyz_to_linear_srgb};
use crate::transport::brdf::{BrdfResult, BrdfRun, IncidenceResult};

/// Columns of `colour.csv`.
pub const HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,X,Y,Z,r,g,b";

/// XYZ and linear sRGB (sR⁻¹) of the BRDF of one incidence of a spectral
/// run, per flat Carlson cell, from its results per wavelength (`lanes`,
/// in the run's order); `None` unless the wavelengths cover the visible.
#[must_use]
pub fn cell_colours(run: &BrdfRun, lanes: &[IncidenceResult]) -> Option<Vec<([f64; 3], [f64; 3])>> {
    let weights = XyzWeights::d65(&run.wavelengths_um)?;
    if lanes.len() != weights.len() {
        return None;
    }
    let grid = run.grid();
    let mut f = vec![0.0; lanes.len()];
    (0..grid.n_cells())
        .map(|flat| {
            let (band, cell) = grid.band_cell(flat);
            let proj = grid.projected_solid_angle(band, cell);
            for (v, r) in f.iter_mut().zip(lanes) {
                *v = r.tallies.carlson.mean(flat, r.tallies.photons) / proj;
            }
            let xyz = weights.xyz(&f)?;
            Some((xyz, xyz_to_linear_srgb(xyz)))
        })
        .collect()
}

/// `colour.csv` of a run; `None` for a monochrome run or wavelengths that do
/// not cover the visible.
#[must_use]
pub fn write(run: &BrdfRun, results: &BrdfResult) -> Option<String> {
    if run.wavelengths_um.is_empty() {
        return None;
    }
    let grid = run.grid();
    let mut s = String::with_capacity(160 * grid.n_cells() * run.theta_deg.len() + 100);
    s.push_str(HEADER);
    s.push('\n');
    for lanes in results.groups() {
        let colours = cell_colours(run, lanes)?;
        let r0 = &lanes[0];
        for (flat, (xyz, rgb)) in colours.iter().enumerate() {
            let (band, cell) = grid.band_cell(flat);
            let (theta, phi) = grid.centre(band, cell);
            let _ = write!(
                s,
                "{},{},{band},{cell},{},{}",
                r0.theta_i_deg,
                r0.phi_i_deg,
                theta.to_degrees(),
                phi.to_degrees()
            );
            for v in xyz.iter().chain(rgb) {
                let _ = write!(s, ",{v:.9e}");
            }
            s.push('\n');
        }
    }
    Some(s)
}

/// The display colour (8-bit sRGB) of each cell for the picture (see the
/// module docs), from its XYZ and linear sRGB (as `colour.csv` holds them).
#[must_use]
pub fn display_colours(colours: &[([f64; 3], [f64; 3])]) -> Vec<[u8; 3]> {
    let top = colours.iter().map(|c| c.0[1]).fold(0.0, f64::max);
    let (hi, lo) = if top > 0.0 {
        (top.log10(), top.log10() - 4.0)
    } else {
        (0.0, -4.0)
    };
    colours
        .iter()
        .map(|&([_, y, _], rgb)| {
            if !(y > 0.0) {
                return [0, 0, 0];
            }
            let brightness = ((y.log10() - lo) / (hi - lo)).clamp(0.0, 1.0);
            let c = rgb.map(|v| (v / y).max(0.0) * brightness);
            let m = c.iter().copied().fold(1.0, f64::max);
            crate::optics::colour::srgb8(c.map(|v| v / m))
        })
        .collect()
}

/// File name of the colour map of incidence `theta_i_deg`.
#[must_use]
pub fn colour_file(theta_i_deg: f64) -> String {
    format!("colour_{}deg.png", super::number_label(theta_i_deg))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneFile;
    use crate::scene::micro::MicroScene;

    fn scene(material: &str, wavelengths: &str) -> MicroScene {
        let text = format!(
            "[surface]\nsize = [10.0, 10.0]\nmaterial = \"m\"\n[materials.m]\n{material}\n[light]\ntheta_deg = [0, 30]\nphotons = 4096\nwavelengths_um = {wavelengths}\n[tally]\nbands = 4\n"
        );
        let scene_file = SceneFile {
            file: "t.toml".into(),
            dir: ".".into(),
        };
        MicroScene::from_str(&text, scene_file, "t".into()).unwrap()
    }

    /// A flat mirror of constant reflectance 0.5: every wavelength puts
    /// the same fraction `f` in each cell (0.5 in all, shared between the
    /// cells that meet at the specular direction), so each cell's XYZ is
    /// `f / proj` times D65's white point (Y = 1 for the perfect white
    /// reflector) and its sRGB that of the white point.
    #[test]
    fn a_grey_mirror_has_the_white_point() {
        let s = scene(
            "reflectance = 0.5",
            "{ from = 0.38, to = 0.78, step = 0.02 }",
        );
        let run = s.brdf_run();
        let results = run.trace_whole(&s.surface, &|_| {});
        assert_eq!(results.len(), 2 * 21);
        let grid = run.grid();
        let white = crate::optics::colour::d65_white_xyz();
        let white_rgb = xyz_to_linear_srgb(white);
        for lanes in results.groups() {
            assert_eq!(lanes.len(), 21);
            let colours = cell_colours(&run, lanes).unwrap();
            let t = &lanes[0].tallies;
            let mut total = 0.0;
            for (flat, (xyz, rgb)) in colours.iter().enumerate() {
                let (band, cell) = grid.band_cell(flat);
                let f = t.carlson.mean(flat, t.photons);
                total += f;
                let expect = f / grid.projected_solid_angle(band, cell);
                for c in 0..3 {
                    let tol = 1e-12 * expect.max(1.0);
                    assert!(
                        (xyz[c] - expect * white[c]).abs() <= tol,
                        "cell {flat}: {xyz:?}"
                    );
                    assert!(
                        (rgb[c] - expect * white_rgb[c]).abs() <= tol,
                        "cell {flat}: {rgb:?}"
                    );
                }
            }
            assert!((total - 0.5).abs() < 1e-12, "{total}");
        }
        let text = write(&run, &results).unwrap();
        assert_eq!(text.lines().next(), Some(HEADER));
        assert_eq!(text.lines().count(), 1 + 2 * grid.n_cells());
    }

    #[test]
    fn no_colour_without_the_visible() {
        let s = scene("reflectance = 0.5", "[0.45, 0.55, 0.65]");
        let run = s.brdf_run();
        let results = run.trace_whole(&s.surface, &|_| {});
        assert!(write(&run, &results).is_none());
    }
}
