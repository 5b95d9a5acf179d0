//! The polarised measured-BRDF format of Baek et al. 2020 ("Image-based
//! acquisition and modeling of polarimetric reflectance", ACM TOG 39(4)),
//! read by Mitsuba 3's `measured_polarized` plugin
//! (`src/bsdfs/measured_polarized.cpp`, evaluated in the
//! `*_spectral_polarized` variants), written from a roks Mueller-matrix
//! BRDF table (`mueller.csv` of a run with `[tally] polarisation =
//! "mueller"`): `roks export-brdf --format pbsdf`, `roks brdf --export
//! pbsdf`.
//!
//! # The file
//!
//! A tensor file ([`super::rgl::tensor`], the container of Mitsuba's
//! `TensorFile`) with the fields the plugin reads:
//!
//! * `theta_h` (`f32`, shape `[1, THETA_H]`), `theta_d` (`[1, THETA_D]`),
//!   `phi_d` (`[1, PHI_D]`): the nodes of the isotropic Rusinkiewicz
//!   angles, radians, increasing;
//! * `wvls` (`u16`, `[5]`): the wavelengths in nm; the plugin holds a fixed
//!   array of five;
//! * `M` (`f32`, `[PHI_D, THETA_D, THETA_H, 5, 4, 4]`): the Mueller-matrix
//!   BRDF in sr⁻¹, row index before column index: the plugin multiplies
//!   it by the cosine itself (`value * cos_theta_o` at the end of its
//!   `eval`, `cos_theta_o` of Mitsuba's `wo`, which in radiance mode points
//!   to the light: the cosine of the incidence angle), so `M[..., 0, 0]` is the BRDF of unpolarised light (the
//!   `brdf` of `brdf.csv`, the `m00` of `mueller.csv`).
//!
//! The plugin interpolates `M` linearly in each of `phi_d`, `theta_d`,
//! `theta_h` and the wavelength (a `Marginal2D<Float, 4>` over the 4 x 4
//! elements, whose lookups at `(j/3, i/3)` are the nodes exactly), with the
//! weights clamped to `[0, 1]`: outside the nodes the end value holds.
//!
//! # Grid (resolution)
//!
//! * `theta_h`: [`THETA_H`] = 46 nodes `(k / 45)² 90°` (as MERL's bins,
//!   finer at the specular peak: 0.044° first step, 3.96° last);
//! * `theta_d`: [`THETA_D`] = 46 nodes every 2° from 0 to 90° (at
//!   `theta_h = 0` the incidence angle is `theta_d`, so a table's incidences
//!   at even degrees are nodes);
//! * `phi_d`: [`PHI_D`] = 73 nodes every 5° from -180° to 180° (the full
//!   circle: the plugin's `phi_d` is `atan2`, in `(-180°, 180°]`, and a
//!   clamped half range would be wrong for the other half).
//!
//! 154 588 nodes x 5 wavelengths x 16 elements x 4 bytes: 49.5 MB.
//!
//! # Angles and frames (the plugin's, read from its source)
//!
//! In Mitsuba's radiance mode `wo` points to the light and `si.wi` to the
//! viewer: the plugin names the light direction `wo_hat` ("light arrives
//! along `-wo_hat`") and the view direction `wi_hat`, turns both about the
//! normal so that the view is at azimuth 0, and computes
//! `directions_to_rusinkiewicz(light, view)`: `h = normalize(light +
//! view)`, `theta_h = acos(h_z)`, `theta_d = acos(h . light)`, and with
//! `b = normalize(n × h)`, `t = normalize(b × h)` and `light` projected
//! onto the plane normal to `h`, `phi_d = atan2(b . p, t . p)`.
//! [`rusinkiewicz`] is that function.
//!
//! The Stokes reference vectors of `M`, for the incident flight `-light`
//! (`xo_std`) and the reflected flight `view` (`xi_std`), are built by the
//! plugin from `zo = -light`, `to = normalize((light - view) × zo)`,
//! `xo = normalize(to × zo) × zo`, and likewise `zi = view`, `ti =
//! normalize((view - light) × zi)`, `xi = normalize(ti × zi) × zi`. With the
//! unit difference vector `D` (`light = cos(theta_d) h + sin(theta_d) D`,
//! `view = cos(theta_d) h - sin(theta_d) D`), `light - view = 2
//! sin(theta_d) D`, both `to` and `ti` are `normalize(h × D)` and `xo =
//! xi = -to = D × h` ([`plugin_reference`]): one vector for both flights,
//! normal to the plane of `light`, `view` and `h` (the s axis of the
//! reflection at a facet of normal `h`). The plugin then turns `M` into
//! Mitsuba's own frames with `mueller::rotate_mueller_basis(M, -light, xo,
//! stokes_basis(-light), view, xi, stokes_basis(view))` (`mueller.h`:
//! `R_out M R_inᵀ`, `R = rotator(angle)` of the signed angle from the
//! current to the target reference vector about the flight,
//! `[[1,0,0,0],[0,c,s,0],[0,-s,c,0],[0,0,0,1]]`, `c, s = cos, sin 2 angle`).
//!
//! roks's `mueller.csv` (frames of [`crate::optics::polarisation`], the
//! same Stokes convention as Mitsuba's: `S1 > 0` along the reference vector
//! `x`, `y = flight × x`, `S3 > 0` right circular) uses the reference
//! vector `normalize(ẑ × d)` of each flight `d` (at the pole the azimuthal
//! vector of the light's azimuth). Each node's matrix is therefore
//! `M_file = R(view: ẑ×view -> D×h) M_roks R(-light: ẑ×(-light) -> D×h)ᵀ`
//! ([`to_plugin_frames`]), the same rotation as Mitsuba's.
//!
//! # Resampling
//!
//! At each node ([`Resampler::node_value`]) the light and view directions are built
//! with `phi_h = 0` ([`node_directions`]; the BRDF is isotropic), raised to
//! just above the horizon where they are below it (at the same azimuth,
//! so that the interpolation towards the horizon sees the table's values),
//! and turned about the normal so that the light is at azimuth 0 (the
//! table's frame), at incidence `theta_i`. The two tabulated incidences
//! bracketing `theta_i` (the nearest alone outside them) are mixed
//! linearly in `theta_i`, each taken with the light turned about `ŷ` to
//! its own incidence and the view turned the other way by as much (so the
//! pair keeps its place relative to the mirror direction and a specular
//! peak stays a peak, where mixing the tables at a fixed view would split
//! it in two). Each takes the table's Mueller BRDF of the cell holding the
//! turned view ([`Resampler::incidence_mueller`]: the cell's `m00` times its
//! normalised matrix, averaged with its mirror image in the plane of
//! incidence, `S2, S3 -> -S2, -S3`: row and column signs `(1, 1, -1,
//! -1)`, as the other exports average the BRDF), turned into the plugin's
//! frame of the turned pair ([`to_plugin_frames`]); the frame `D × h` is
//! tied to the pair's geometry, so the mix is made in it. `theta_d = 0`
//! (light = view) and `theta_h = 0` have their limits: `D` and `b = ŷ` are
//! defined at every node.
//!
//! A tabulated normal incidence is taken as the mean of each ring of cells
//! ([`Resampler::new`]), turned to the view's azimuth. At `theta_i = 0` the
//! plugin's `phi_d` is ±180° for every view (`h` lies in the plane of the
//! normal and the view), so the file answers for the whole hemisphere from
//! the one row `phi_d = ±180°`, whose diagonal `theta_h = theta_d` holds
//! light at the normal: with the cells themselves, the reflectance read
//! back at normal incidence was that of one cell per band (the Monte Carlo
//! noise of about 32 cells instead of 2112: 2.1 % low for the default
//! scene at 200 000 photons, 51 standard errors); with the ring means it is
//! that of the whole table (+0.12 %; Mitsuba's own `eval` integrated over
//! the hemisphere, 0.699355 against the table's 0.699005).
//!
//! # Wavelengths
//!
//! A spectral run of exactly five wavelengths gives them (µm -> nm rounded
//! to the integer, as the `u16` field holds them; they must stay distinct).
//! A monochrome run (or a spectral run of one wavelength) is written as the
//! same table at [`GREY_NM`] = 450, 500, 550, 600, 650 nm, the wavelengths
//! of the Baek et al. dataset, with a note; other numbers of wavelengths
//! are refused ([`PbsdfRefusal`]).
//!
//! # Resampling error
//!
//! Between nodes the file's value is the plugin's linear interpolation of
//! node values, and each node holds the value of the Carlson cell it falls
//! into: at a cell's centre the file mixes the cell with its neighbours,
//! in angle and in incidence (between tabulated incidences the table itself
//! is interpolated). A flat (mirror) surface keeps its exact normalised
//! matrix at the specular direction: near `theta_h = 0` the frame `D × h`
//! is roks's `ẑ × d` for both flights, so every `phi_d` node holds the same
//! matrix there. [`check`] reads the file back and integrates `m00` over
//! the hemisphere against the table's reflectance.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec3;
use rayon::prelude::*;

use super::exporter::{
    BrdfFormat, Export, ExportError, ExportInput, ExportRefusal, Exporter, Notice, PbsdfRefusal,
    ZemaxGrid, fixed, one_file,
};
use super::resample::{CHECK_RINGS, FormatError, ReflectanceCheck, integrate_projected};
use super::rgl::tensor::{Data, Field, TensorFile};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::optics::polarisation::{hemisphere_reference, rotation};
use crate::outdir::file::ResultFile;
use crate::outdir::kind::FileKind;

/// Nodes of `theta_h`.
pub const THETA_H: usize = 46;
/// Nodes of `theta_d`.
pub const THETA_D: usize = 46;
/// Nodes of `phi_d`.
pub const PHI_D: usize = 73;
/// Wavelengths of a file (the plugin's fixed array).
pub const WAVELENGTHS: usize = 5;
/// The wavelengths (nm) a monochrome table is written at.
pub const GREY_NM: [u16; WAVELENGTHS] = [450, 500, 550, 600, 650];

/// Directions whose `z` is at most this are raised to it (horizon).
const HORIZON_Z: f64 = 1e-6;

/// `theta_h` of node `k` (radians): `(k / (THETA_H - 1))² 90°`.
#[must_use]
pub fn theta_h_node(k: usize) -> f64 {
    (k as f64 / (THETA_H - 1) as f64).powi(2) * FRAC_PI_2
}
/// `theta_d` of node `k` (radians): every 2°.
#[must_use]
pub fn theta_d_node(k: usize) -> f64 {
    k as f64 / (THETA_D - 1) as f64 * FRAC_PI_2
}
/// `phi_d` of node `k` (radians): every 5° from -180°.
#[must_use]
pub fn phi_d_node(k: usize) -> f64 {
    -PI + k as f64 / (PHI_D - 1) as f64 * 2.0 * PI
}

/// The wavelengths (nm) of a file of tables at `wavelengths_um` (empty or
/// one: grey, [`GREY_NM`]), and whether they are the grey ones.
///
/// # Errors
/// Another number than 0, 1 or 5, or five that do not round to distinct
/// `u16` nanometres.
pub fn file_wavelengths(
    wavelengths_um: &[f64],
) -> Result<([u16; WAVELENGTHS], bool), PbsdfRefusal> {
    match wavelengths_um.len() {
        0 | 1 => Ok((GREY_NM, true)),
        WAVELENGTHS => {
            let nm: Vec<f64> = wavelengths_um.iter().map(|w| (w * 1e3).round()).collect();
            let ok = nm.iter().all(|&v| (1.0..=65535.0).contains(&v))
                && nm.windows(2).all(|p| p[0] < p[1]);
            if !ok {
                return Err(PbsdfRefusal::Nanometres(wavelengths_um.to_vec()));
            }
            Ok((std::array::from_fn(|k| nm[k] as u16), false))
        }
        n => Err(PbsdfRefusal::Wavelengths(n)),
    }
}

/// The plugin's `directions_to_rusinkiewicz(light, view)`: `(phi_d,
/// theta_h, theta_d)` in radians of unit `light` (towards the light) and
/// `view` (towards the viewer). At `h = ẑ` (`b` undefined) `b = ŷ`, the
/// limit of [`node_directions`].
#[must_use]
pub fn rusinkiewicz(light: DVec3, view: DVec3) -> (f64, f64, f64) {
    let h = (light + view).normalize();
    let b = DVec3::Z.cross(h).try_normalize().unwrap_or(DVec3::Y);
    let t = b.cross(h).normalize();
    let theta_d = h.dot(light).clamp(-1.0, 1.0).acos();
    let theta_h = h.z.clamp(-1.0, 1.0).acos();
    let p = (light - light.dot(h) * h).try_normalize().unwrap_or(t);
    let phi_d = b.dot(p).clamp(-1.0, 1.0).atan2(t.dot(p).clamp(-1.0, 1.0));
    (phi_d, theta_h, theta_d)
}

/// `(light, view, D)` of the Rusinkiewicz angles (radians) with `phi_h =
/// 0`: `h = (sin theta_h, 0, cos theta_h)`, `b = ŷ`, `t = b × h`, the unit
/// difference `D = cos(phi_d) t + sin(phi_d) b` and `light, view =
/// cos(theta_d) h ± sin(theta_d) D` (either may point below the horizon).
#[must_use]
pub fn node_directions(theta_h: f64, theta_d: f64, phi_d: f64) -> (DVec3, DVec3, DVec3) {
    let h = DVec3::new(theta_h.sin(), 0.0, theta_h.cos());
    let t = DVec3::Y.cross(h);
    let d = phi_d.cos() * t + phi_d.sin() * DVec3::Y;
    let (st, ct) = theta_d.sin_cos();
    (ct * h + st * d, ct * h - st * d, d)
}

/// The plugin's Stokes reference vector of both flights (`-light` in,
/// `view` out) for the half vector `h` and unit difference `d`: `d × h`
/// (see the module documentation).
#[must_use]
pub fn plugin_reference(h: DVec3, d: DVec3) -> DVec3 {
    d.cross(h).normalize()
}

/// `m` (row-major 4 x 4) with its incident reference vector turned from
/// `in_from` to `in_to` about `-light` and its outgoing one from
/// `out_from` to `out_to` about `view`: `R_out m R_inᵀ` (Mitsuba's
/// `rotate_mueller_basis`).
#[must_use]
pub fn rotate_basis(
    m: &[f64; 16],
    light: DVec3,
    in_from: DVec3,
    in_to: DVec3,
    view: DVec3,
    out_from: DVec3,
    out_to: DVec3,
) -> [f64; 16] {
    let rot = |(c, s): (f64, f64)| -> [f64; 16] {
        [
            1.0, 0.0, 0.0, 0.0, 0.0, c, s, 0.0, 0.0, -s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]
    };
    let r_in = rot(rotation(-light, in_from, in_to));
    let r_out = rot(rotation(view, out_from, out_to));
    let mut out = [0.0; 16];
    for i in 0..4 {
        for j in 0..4 {
            let mut v = 0.0;
            for k in 0..4 {
                for l in 0..4 {
                    // (R_out M R_inᵀ)_ij = Σ R_out[i][k] M[k][l] R_in[j][l]
                    v += r_out[4 * i + k] * m[4 * k + l] * r_in[4 * j + l];
                }
            }
            out[4 * i + j] = v;
        }
    }
    out
}

/// `m` from roks's frames (`ẑ × d` of each flight, the table's frame:
/// light at azimuth 0) into the plugin's (`reference` for both flights).
#[must_use]
pub fn to_plugin_frames(m: &[f64; 16], light: DVec3, view: DVec3, reference: DVec3) -> [f64; 16] {
    rotate_basis(
        m,
        light,
        hemisphere_reference(-light, 0.0),
        reference,
        view,
        hemisphere_reference(view, 0.0),
        reference,
    )
}

/// A table prepared for resampling onto the nodes: the table and, for a
/// tabulated normal incidence, its Mueller BRDF averaged over each ring of
/// cells ([`Resampler::new`]).
#[derive(Debug, Clone)]
pub struct Resampler<'a> {
    table: &'a BrdfTable,
    /// The tabulated incidence at `theta_i = 0` and, per band (index
    /// `band - 1`), the ring's mean matrix (sr⁻¹, roks's frames) toward
    /// the band's centre at azimuth 0 of the table's frame, incident
    /// reference vector `ŷ` ([`hemisphere_reference`] of the pole).
    pole: Option<(usize, Vec<[f64; 16]>)>,
}

impl<'a> Resampler<'a> {
    /// `table` with, if it has a tabulated normal incidence and a Mueller
    /// table, the ring means of that incidence: each cell's matrix is turned
    /// about the normal to azimuth 0 (for an isotropic surface lit at the
    /// normal, a turn about the normal changes nothing but the incident
    /// reference vector, which turns with it: that is rotated back to `ŷ`)
    /// and the `4 band` cells of the ring (equal projected solid angles)
    /// are averaged (why: the module documentation, "Resampling").
    #[must_use]
    pub fn new(table: &'a BrdfTable) -> Self {
        let pole = table
            .thetas_deg()
            .iter()
            .position(|&t| t == 0.0)
            .filter(|_| table.has_mueller())
            .map(|i| (i, pole_rings(table, i)));
        Self { table, pole }
    }

    /// The Mueller-matrix BRDF (sr⁻¹, row-major, roks's frames) of
    /// tabulated incidence `i` (light at azimuth 0) towards unit `dir` (`z >
    /// 0`): the cell's `m00` times its normalised matrix (at a tabulated
    /// normal incidence the ring's mean, turned to the azimuth of `dir`),
    /// averaged with the mirror image in the plane of incidence (`dir` with
    /// `y -> -y`, elements times the row and column signs `(1, 1, -1,
    /// -1)`). Zero where there is no cell; `None` without a Mueller table.
    #[must_use]
    pub fn incidence_mueller(&self, i: usize, dir: DVec3) -> Option<[f64; 16]> {
        let table = self.table;
        let phi_i = table.incidence(i).phi_i_deg.to_radians();
        let (s, c) = phi_i.sin_cos();
        let pole = self.pole.as_ref().filter(|(k, _)| *k == i);
        let cell = |d: DVec3| -> Option<[f64; 16]> {
            let turned = DVec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z);
            let Some(flat) = table.grid().locate(turned) else {
                return Some([0.0; 16]);
            };
            if let Some((_, rings)) = pole {
                let (band, _) = table.grid().band_cell(flat);
                return Some(ring_towards(&rings[band - 1], d));
            }
            let brdf = table.cell_brdf(i, flat);
            Some(
                table
                    .mueller(i, flat)?
                    .map(|v| if brdf == 0.0 { 0.0 } else { brdf * v }),
            )
        };
        let a = cell(dir)?;
        let b = cell(DVec3::new(dir.x, -dir.y, dir.z))?;
        let sign = [1.0, 1.0, -1.0, -1.0];
        Some(std::array::from_fn(|k| {
            0.5 * (a[k] + sign[k / 4] * sign[k % 4] * b[k])
        }))
    }

    /// The value of the file at one node, in the plugin's frames (see the
    /// module documentation, "Resampling").
    #[must_use]
    pub fn node_value(&self, theta_h: f64, theta_d: f64, phi_d: f64) -> [f64; 16] {
        let table = self.table;
        let (light, view, d) = node_directions(theta_h, theta_d, phi_d);
        let (light, view) = (above_horizon(light), above_horizon(view));
        // The table's frame: light at azimuth 0.
        let a = light.y.atan2(light.x);
        let (s, c) = (-a).sin_cos();
        let turn = |v: DVec3| DVec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z);
        let (light, view, d) = (turn(light), turn(view), turn(d));
        let theta_i = light.x.hypot(light.y).atan2(light.z);
        let thetas = table.thetas_deg();
        let mut out = [0.0; 16];
        for (k, w) in bracket(thetas, theta_i.to_degrees()) {
            if w == 0.0 {
                continue;
            }
            // Light to the tabulated incidence, view turned the other way: the
            // pair keeps its place relative to the mirror direction. The
            // light is set there exactly: turned, it would miss the pole of
            // a normal incidence by rounding (1e-18), and its Stokes
            // reference would be the azimuthal vector of a random azimuth
            // instead of the table's `ŷ`.
            let (theta_k, shift) = (thetas[k].to_radians(), theta_i - thetas[k].to_radians());
            let l = DVec3::new(theta_k.sin(), 0.0, theta_k.cos());
            let v = above_horizon(turn_y(view, -shift));
            let reference =
                plugin_reference((l + v).normalize(), (l - v).try_normalize().unwrap_or(d));
            let m = self.incidence_mueller(k, v).unwrap_or([0.0; 16]);
            let m = to_plugin_frames(&m, l, v, reference);
            for (o, x) in out.iter_mut().zip(m) {
                *o += w * x;
            }
        }
        out
    }
}

/// The incident reference vector of light along `-ẑ` after a turn by `phi`
/// (radians) about the normal of the pole's `ŷ`: `(-sin phi, cos phi, 0)`.
fn turned_pole_reference(phi: f64) -> DVec3 {
    hemisphere_reference(-DVec3::Z, phi)
}

/// Per band, the mean Mueller BRDF of the ring of tabulated incidence `i`
/// (`theta_i = 0`) toward azimuth 0 of the table's frame (see
/// [`Resampler::new`]).
fn pole_rings(table: &BrdfTable, i: usize) -> Vec<[f64; 16]> {
    let grid = table.grid();
    let phi_i = table.incidence(i).phi_i_deg.to_radians();
    (1..=grid.bands())
        .map(|band| {
            let (theta, _) = grid.centre(band, 0);
            let view = DVec3::new(theta.sin(), 0.0, theta.cos());
            let out_ref = hemisphere_reference(view, 0.0);
            let n = grid.cells_in_band(band);
            let mut sum = [0.0; 16];
            for cell in 0..n {
                let flat = grid.index(band, cell);
                let brdf = table.cell_brdf(i, flat);
                let Some(m) = table.mueller(i, flat).filter(|_| brdf != 0.0) else {
                    continue;
                };
                // The cell's azimuth in the table's frame; turned by minus
                // that, the view is at azimuth 0 and the incident
                // reference vector `ŷ` at `-alpha`.
                let alpha = grid.centre(band, cell).1 - phi_i;
                let m = m.map(|v| brdf * v);
                let m = rotate_basis(
                    &m,
                    DVec3::Z,
                    turned_pole_reference(-alpha),
                    DVec3::Y,
                    view,
                    out_ref,
                    out_ref,
                );
                for (s, v) in sum.iter_mut().zip(m) {
                    *s += v;
                }
            }
            sum.map(|v| v / n as f64)
        })
        .collect()
}

/// A ring mean of [`pole_rings`] (view at azimuth 0, incident reference
/// `ŷ`) turned to the azimuth of unit `dir`: the incident reference turns
/// with the view and is rotated back to `ŷ`.
fn ring_towards(mean: &[f64; 16], dir: DVec3) -> [f64; 16] {
    let phi = dir.y.atan2(dir.x);
    let out_ref = hemisphere_reference(dir, 0.0);
    rotate_basis(
        mean,
        DVec3::Z,
        turned_pole_reference(phi),
        DVec3::Y,
        dir,
        out_ref,
        out_ref,
    )
}

/// The tabulated incidences bracketing `theta_deg` and their weights
/// (linear; the nearest end alone outside the tabulated range).
fn bracket(thetas: &[f64], theta_deg: f64) -> [(usize, f64); 2] {
    let upper = thetas.partition_point(|&t| t <= theta_deg);
    if upper == 0 {
        [(0, 1.0), (0, 0.0)]
    } else if upper >= thetas.len() {
        [(thetas.len() - 1, 1.0), (0, 0.0)]
    } else {
        let (a, b) = (thetas[upper - 1], thetas[upper]);
        let w = ((theta_deg - a) / (b - a)).clamp(0.0, 1.0);
        [(upper - 1, 1.0 - w), (upper, w)]
    }
}

/// `d` raised to [`HORIZON_Z`] at the same azimuth when it is at or below
/// it.
fn above_horizon(d: DVec3) -> DVec3 {
    if d.z > HORIZON_Z {
        return d;
    }
    let flat = DVec3::new(d.x, d.y, 0.0).normalize_or(DVec3::X);
    (flat + DVec3::Z * HORIZON_Z).normalize()
}

/// `d` turned about `ŷ` by `angle` (radians): a positive angle lowers the
/// polar angle of a direction on the `+x` side and raises it on the `-x`
/// side.
fn turn_y(d: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    DVec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

/// A pbsdf file: the fields of the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct Pbsdf {
    /// `theta_h` nodes (radians).
    pub theta_h: Vec<f32>,
    /// `theta_d` nodes (radians).
    pub theta_d: Vec<f32>,
    /// `phi_d` nodes (radians).
    pub phi_d: Vec<f32>,
    /// Wavelengths (nm).
    pub wvls: Vec<u16>,
    /// `M[phi_d][theta_d][theta_h][wvl][4][4]` (sr⁻¹).
    pub m: Vec<f32>,
}

impl Pbsdf {
    /// The file of `tables` (each with its Mueller table attached).
    ///
    /// # Errors
    /// [`PbsdfRefusal`]: several light azimuths, a number of wavelengths
    /// other than 1 or 5, or no Mueller table.
    pub fn from_tables(tables: &BrdfTables) -> Result<Self, PbsdfRefusal> {
        let azimuths = tables.azimuths_deg().len();
        if azimuths > 1 {
            return Err(PbsdfRefusal::Azimuths(azimuths));
        }
        let (wvls, grey) = file_wavelengths(tables.wavelengths_um())?;
        let t = tables.tables();
        if !t.iter().all(BrdfTable::has_mueller) {
            return Err(PbsdfRefusal::NoMueller);
        }
        let per_wavelength: Vec<Resampler> = if grey {
            vec![Resampler::new(&t[0]); WAVELENGTHS]
        } else {
            t.iter().map(Resampler::new).collect()
        };
        let m: Vec<f32> = (0..PHI_D)
            .into_par_iter()
            .flat_map_iter(|p| {
                let phi_d = phi_d_node(p);
                let mut row = Vec::with_capacity(THETA_D * THETA_H * WAVELENGTHS * 16);
                for q in 0..THETA_D {
                    for r in 0..THETA_H {
                        let mut done: Option<[f64; 16]> = None;
                        for (w, table) in per_wavelength.iter().enumerate() {
                            // A grey file repeats the first wavelength's node.
                            let v = match done {
                                Some(v) if grey && w > 0 => v,
                                _ => table.node_value(theta_h_node(r), theta_d_node(q), phi_d),
                            };
                            done = Some(v);
                            row.extend(v.iter().map(|&x| x as f32));
                        }
                    }
                }
                row
            })
            .collect();
        Ok(Self {
            theta_h: (0..THETA_H).map(|k| theta_h_node(k) as f32).collect(),
            theta_d: (0..THETA_D).map(|k| theta_d_node(k) as f32).collect(),
            phi_d: (0..PHI_D).map(|k| phi_d_node(k) as f32).collect(),
            wvls: wvls.to_vec(),
            m,
        })
    }

    /// The tensor file's bytes.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let axis = |name: &str, v: &[f32]| Field {
            name: name.into(),
            shape: vec![1, v.len()],
            data: Data::F32(v.to_vec()),
        };
        super::rgl::tensor::write(&[
            axis("theta_h", &self.theta_h),
            axis("theta_d", &self.theta_d),
            axis("phi_d", &self.phi_d),
            Field {
                name: "wvls".into(),
                shape: vec![self.wvls.len()],
                data: Data::U16(self.wvls.clone()),
            },
            Field {
                name: "M".into(),
                shape: vec![
                    self.phi_d.len(),
                    self.theta_d.len(),
                    self.theta_h.len(),
                    self.wvls.len(),
                    4,
                    4,
                ],
                data: Data::F32(self.m.clone()),
            },
        ])
    }

    /// Read a file back, with the checks of the plugin's loader (field
    /// types and shapes, five wavelengths) and increasing nodes.
    ///
    /// # Errors
    /// A file the plugin would refuse, naming `file`.
    pub fn parse(bytes: &[u8], file: &str) -> Result<Self, FormatError> {
        let t = TensorFile::parse(bytes, file)?;
        let err = |message: String| FormatError {
            file: file.into(),
            message,
        };
        let axis = |name: &str| -> Result<Vec<f32>, FormatError> {
            let (shape, v) = t.f32(name, 2)?;
            if shape[0] != 1 || v.len() < 2 || v.windows(2).any(|p| p[0] >= p[1]) {
                return Err(err(format!(
                    "field {name}: expected [1, n] increasing nodes, shape {shape:?}"
                )));
            }
            Ok(v.to_vec())
        };
        let (theta_h, theta_d, phi_d) = (axis("theta_h")?, axis("theta_d")?, axis("phi_d")?);
        let wvls = match t.fields.get("wvls") {
            Some(Field {
                shape,
                data: Data::U16(v),
                ..
            }) if shape.len() == 1 && v.len() == WAVELENGTHS => v.clone(),
            _ => return Err(err("field wvls: expected 5 u16 wavelengths".into())),
        };
        let (shape, m) = t.f32("M", 6)?;
        if shape[..] != [phi_d.len(), theta_d.len(), theta_h.len(), WAVELENGTHS, 4, 4] {
            return Err(err(format!(
                "field M: shape {shape:?} does not fit the axes"
            )));
        }
        Ok(Self {
            theta_h,
            theta_d,
            phi_d,
            wvls,
            m: m.to_vec(),
        })
    }

    /// The file's matrix (sr⁻¹, row-major, the plugin's frames) at the
    /// angles (radians) of wavelength index `w`, interpolated as the plugin
    /// does: linearly in each angle between the nodes that bracket it,
    /// weights clamped to `[0, 1]`; `m00` at least 0.
    #[must_use]
    pub fn eval(&self, phi_d: f64, theta_h: f64, theta_d: f64, w: usize) -> [f64; 16] {
        let weights = |nodes: &[f32], x: f64| -> (usize, f64) {
            let k = nodes
                .partition_point(|&n| f64::from(n) <= x)
                .clamp(1, nodes.len() - 1)
                - 1;
            let (a, b) = (f64::from(nodes[k]), f64::from(nodes[k + 1]));
            (k, ((x - a) / (b - a)).clamp(0.0, 1.0))
        };
        let (p, wp) = weights(&self.phi_d, phi_d);
        let (q, wq) = weights(&self.theta_d, theta_d);
        let (r, wr) = weights(&self.theta_h, theta_h);
        let (nd, nh, nw) = (self.theta_d.len(), self.theta_h.len(), self.wvls.len());
        let mut out = [0.0; 16];
        for (dp, fp) in [(0, 1.0 - wp), (1, wp)] {
            for (dq, fq) in [(0, 1.0 - wq), (1, wq)] {
                for (dr, fr) in [(0, 1.0 - wr), (1, wr)] {
                    let f = fp * fq * fr;
                    if f == 0.0 {
                        continue;
                    }
                    let at = ((((p + dp) * nd + q + dq) * nh + r + dr) * nw + w) * 16;
                    for (o, &v) in out.iter_mut().zip(&self.m[at..at + 16]) {
                        *o += f * f64::from(v);
                    }
                }
            }
        }
        out[0] = out[0].max(0.0);
        out
    }
}

/// Read a pbsdf file of `tables` back (`bytes`, named `file` in errors)
/// and integrate its `m00` times `cos(theta_o)` over the hemisphere
/// ([`integrate_projected`], [`CHECK_RINGS`] rings) at each tabulated
/// incidence, per table (one for a monochrome table, written grey; five for
/// a spectral one): the file's reflectance of unpolarised light beside the
/// table's.
///
/// # Errors
/// If the file does not read back.
pub fn check(
    tables: &BrdfTables,
    bytes: &[u8],
    file: &str,
) -> Result<Vec<Vec<ReflectanceCheck>>, FormatError> {
    let p = Pbsdf::parse(bytes, file)?;
    Ok(tables
        .tables()
        .iter()
        .enumerate()
        .map(|(w, table)| {
            table
                .thetas_deg()
                .iter()
                .map(|&deg| {
                    let theta = deg.to_radians();
                    let light = DVec3::new(theta.sin(), 0.0, theta.cos());
                    let file_r = integrate_projected(CHECK_RINGS, |view| {
                        let (pd, th, td) = rusinkiewicz(light, view);
                        p.eval(pd, th, td, w)[0]
                    });
                    ReflectanceCheck::of_table(table, deg, file_r)
                })
                .collect()
        })
        .collect())
}

/// The pbsdf format's entry of the registry
/// ([`BrdfFormat::Pbsdf`]): one
/// file of tables with their Mueller tables attached, one light azimuth,
/// one wavelength (written grey at [`GREY_NM`], with a note) or five; read
/// back as the reflectance of its `m00` per wavelength and incidence.
#[derive(Debug, Clone, Copy)]
pub struct PbsdfFormat;

impl Exporter for PbsdfFormat {
    fn name(&self) -> &'static str {
        "pbsdf"
    }

    fn file_name(&self) -> &'static str {
        ResultFile::Pbsdf.name()
    }

    fn file_kind(&self) -> FileKind {
        FileKind::Pbsdf
    }

    fn format(&self) -> BrdfFormat {
        BrdfFormat::Pbsdf
    }

    fn needs_mueller(&self) -> bool {
        true
    }

    fn check_wavelengths(&self, wavelengths_um: &[f64]) -> Result<(), ExportRefusal> {
        file_wavelengths(wavelengths_um)
            .map(|_| ())
            .map_err(ExportRefusal::from)
    }

    fn check_run(&self, wavelengths_um: &[f64], azimuths_deg: &[f64]) -> Result<(), ExportError> {
        let format = self.format();
        let count = azimuths_deg.len();
        let refusal = if count > 1 {
            Err(ExportRefusal::Azimuths { format, count })
        } else {
            self.check_wavelengths(wavelengths_um)
        };
        refusal.map_err(|refusal| ExportError::Run { format, refusal })
    }

    fn check_table_file(&self, tables: &BrdfTables, csv: &str) -> Result<(), ExportError> {
        let azimuths = tables.azimuths_deg().len();
        if azimuths > 1 {
            // An isotropic format: refused as docs/src/exports.md says.
            return Err(ExportError::FileRefused {
                format: self.format(),
                file: csv.to_owned(),
                reason: PbsdfRefusal::Azimuths(azimuths).to_string(),
            });
        }
        Ok(())
    }

    fn table_bytes(
        &self,
        table: &BrdfTable,
        _comment: &str,
        _grid: ZemaxGrid,
    ) -> Result<Vec<u8>, ExportError> {
        let tables = BrdfTables::Monochrome(table.clone());
        Ok(Pbsdf::from_tables(&tables)
            .map_err(ExportError::Pbsdf)?
            .to_bytes())
    }

    fn build(&self, input: &ExportInput<'_>) -> Result<Export, ExportError> {
        let file = Pbsdf::from_tables(input.tables).map_err(ExportError::Pbsdf)?;
        let mut export = Export::of(vec![one_file(self.format(), file.to_bytes())]);
        if input.tables.wavelengths_um().len() <= 1 {
            export.notices.push(Notice::Note(format!(
                "pbsdf: a table of one wavelength, written at the five wavelengths {GREY_NM:?} nm that Mitsuba's measured_polarized holds: the same Mueller BRDF at each"
            )));
        }
        Ok(export)
    }

    fn judge(&self, input: &ExportInput<'_>, export: &mut Export) -> Result<(), ExportError> {
        let tables = input.tables;
        let checks = check(tables, &export.files[0].bytes, self.file_name()).map_err(|error| {
            ExportError::Unreadable {
                format: self.format(),
                error,
            }
        })?;
        let remedy = fixed(format!(
            "the pbsdf grid is fixed ({THETA_H} x {THETA_D} x {PHI_D} nodes of theta_h, theta_d, phi_d)"
        ));
        for (k, check) in checks.into_iter().enumerate() {
            let what = match tables.wavelengths_um().get(k) {
                Some(w) => format!("{} ({w} um)", self.name()),
                None => self.name().to_owned(),
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
        let checks = check(
            &BrdfTables::Monochrome(table.clone()),
            bytes,
            self.file_name(),
        )?;
        Ok(checks.into_iter().next().unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The node directions give back their angles through the plugin's
    /// Rusinkiewicz mapping (away from the degenerate `theta_d = 0`, where
    /// `phi_d` is undefined), and `D × h` is normal to light and view.
    #[test]
    fn node_directions_invert_the_plugins_angles() {
        for &(th, td, pd) in &[
            (0.3, 0.7, 0.4),
            (1.2, 0.2, -2.9),
            (0.01, 1.0, 3.0),
            (0.0, 0.5, -1.0),
        ] {
            let (l, v, d) = node_directions(th, td, pd);
            let (p, h, t) = rusinkiewicz(l, v);
            assert!((h - th).abs() < 1e-9 && (t - td).abs() < 1e-9, "{h} {t}");
            if th > 0.0 {
                assert!((p - pd).abs() < 1e-9, "{p} vs {pd}");
            }
            let hv = DVec3::new(th.sin(), 0.0, th.cos());
            let x = plugin_reference(hv, d);
            assert!(x.dot(l).abs() < 1e-12 && x.dot(v).abs() < 1e-12);
        }
    }

    /// The plugin's own construction of its reference vectors (from
    /// `light - view`) gives `±(D × h)`, the same Stokes frame.
    #[test]
    fn plugin_reference_is_the_plugins_construction() {
        let (l, v, d) = node_directions(0.4, 0.6, 1.1);
        let h = (l + v).normalize();
        let zo = -l;
        let to = (l - v).cross(zo).normalize();
        let xo = to.cross(zo).normalize().cross(zo);
        let zi = v;
        let ti = (v - l).cross(zi).normalize();
        let xi = ti.cross(zi).normalize().cross(zi);
        let x = plugin_reference(h, d);
        assert!((xo.dot(x).abs() - 1.0).abs() < 1e-12);
        assert!((xi.dot(x).abs() - 1.0).abs() < 1e-12);
    }

    /// Rotating into other frames and back is the identity; a rotation by
    /// 90 degrees negates S1 and S2 (the rotator of twice 90 degrees).
    #[test]
    fn frame_rotation_round_trips() {
        let m: [f64; 16] = std::array::from_fn(|k| (k as f64 * 0.37).sin());
        let light = DVec3::new(0.5, 0.2, 0.8).normalize();
        let view = DVec3::new(-0.3, 0.4, 0.7).normalize();
        let a = hemisphere_reference(-light, 0.0);
        let b = hemisphere_reference(view, 0.0);
        let xa = DVec3::new(1.0, -0.5, 0.3).cross(light).normalize();
        let xb = DVec3::new(0.2, 0.9, -0.1).cross(view).normalize();
        let there = rotate_basis(&m, light, a, xa, view, b, xb);
        let back = rotate_basis(&there, light, xa, a, view, xb, b);
        for k in 0..16 {
            assert!((back[k] - m[k]).abs() < 1e-12, "{k}");
        }
        // m00, m03, m30 and m33 are unchanged by rotations, the rest not.
        for k in [0, 3, 12, 15] {
            assert!((there[k] - m[k]).abs() < 1e-12, "{k}");
        }
        assert!((0..16).any(|k| (there[k] - m[k]).abs() > 1e-3));
        let quarter = rotate_basis(&m, light, a, a, view, b, view.cross(b));
        for k in 0..16 {
            let s = if (1..3).contains(&(k / 4)) { -1.0 } else { 1.0 };
            assert!((quarter[k] - s * m[k]).abs() < 1e-12, "{k}");
        }
    }

    #[test]
    fn wavelengths_five_or_grey() {
        assert_eq!(file_wavelengths(&[]).unwrap(), (GREY_NM, true));
        assert_eq!(file_wavelengths(&[0.55]).unwrap(), (GREY_NM, true));
        assert_eq!(
            file_wavelengths(&[0.45, 0.5, 0.55, 0.6, 0.65]).unwrap(),
            ([450, 500, 550, 600, 650], false)
        );
        assert_eq!(
            file_wavelengths(&[0.4, 0.5, 0.6, 0.7, 0.8, 0.9]),
            Err(PbsdfRefusal::Wavelengths(6))
        );
        assert!(matches!(
            file_wavelengths(&[0.4, 0.4001, 0.6, 0.7, 0.8]),
            Err(PbsdfRefusal::Nanometres(_))
        ));
    }
}
