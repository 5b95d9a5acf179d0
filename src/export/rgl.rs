//! The RGL measured-BRDF format (Dupuy & Jakob 2018, "An adaptive
//! parameterization for efficient material acquisition and rendering", ACM
//! TOG 37(6)): the `.bsdf` tensor files of the RGL material database, read
//! natively by Mitsuba 3's `measured` plugin (`src/bsdfs/measured.cpp`) and
//! by pbrt-v4's `MeasuredBxDF` (`src/pbrt/bxdfs.cpp`, loader in
//! `src/pbrt/bxdfs.cpp` `MeasuredBxDFData`), written from a roks BRDF table
//! (`roks export-brdf --format rgl`, `roks brdf --export rgl`).
//!
//! # What the renderer computes
//!
//! For incident `wi` (towards the light) and outgoing `wo`, with the half
//! vector `m = (wi + wo) / |wi + wo|`, the plugins evaluate
//!
//! ```text
//! f(wi, wo) cos(theta_o) = spectra(s) * ndf(u_m) / (4 sigma(u_wi)),
//! s = vndf_warp(theta_i)^-1(u_m)
//! ```
//!
//! where `u = (sqrt(2 theta / pi), (phi + pi) / 2 pi)` maps a direction to
//! the unit square (for an isotropic file the azimuth of `m` is taken
//! relative to that of `wi`), `ndf` and `sigma` are interpolated
//! bilinearly on their grids, and `spectra` bilinearly in the unit square of
//! uniform samples `s` of the `vndf` warp ([`warp::Warp`]), linearly in
//! `theta_i` and in the wavelength. With the `jacobian` flag set (always
//! here: pbrt-v4 applies the factor whatever the flag says) the factor
//! `ndf / (4 sigma)` is applied; `spectra` is the BRDF times
//! `cos(theta_o)` divided by it.
//!
//! # What roks writes
//!
//! * `ndf` (`2 x NDF_RES`, azimuth x `u_theta`): the distribution of micro
//!   normals `D(m)` (sr⁻¹, `∫ D cos(theta_m) dω = 1`), isotropic, from the
//!   facets of the micro surface ([`Ndf::from_mesh`]: every triangle's
//!   normal, weighted by its area, spread by a von Mises-Fisher kernel one
//!   Carlson band wide and averaged over the azimuth, evaluated at each
//!   node, so that the NDF is smooth between the nodes), mixed with a share [`DIFFUSE_SHARE`] of the
//!   uniform `D = 1/pi` so that it is positive everywhere (the multiply
//!   scattered light of a roks table reaches directions where no facet
//!   points). Height fields give their own triangles (an ensemble the
//!   triangles of all its realisations, pooled); other surfaces
//!   (bumps, bodies) the triangulated height map of vertical rays at
//!   [`MESH_RES`]² points per period (overhangs are not seen).
//! * `sigma` (`2 x SIGMA_RES`): the projected area `∫ D(m) max(0, wi.m) dω`
//!   of that NDF, integrated numerically ([`Ndf::projected_area`]).
//! * `vndf` (`1 x n_theta_i x VNDF_RES x VNDF_RES`): the visible normals
//!   `D(m) max(0, wi.m) / sigma(wi)` at the nodes of the unit square of
//!   `m`, times the Jacobian `2 pi² u_theta sin(theta_m)` of that square.
//! * `spectra` (`1 x n_theta_i x n_wavelengths x SAMPLE_RES x SAMPLE_RES`):
//!   at each node of the sample square the mean over the node's box (the
//!   points of the square nearer to it than to any other node:
//!   `box_average`, on [`BOX_SUBDIVISION`]² points per node spacing) of
//!   the integrand at each point `s`: the half vector `m` that the warp
//!   puts there ([`warp::Warp::sample`]), its mirror direction `wo`, and
//!   there the table's BRDF (constant over each Carlson cell, averaged
//!   with its mirror image in the plane of incidence, as for the Zemax and
//!   MERL exports: [`symmetric_eval`]) times `cos(theta_o)` times
//!   `4 sigma / ndf`; 0 below the horizon. The boxes tile the square, so
//!   no peak narrower than the nodes' spacing is lost. Each incidence and
//!   wavelength is then scaled so that the file's reflectance, integrated
//!   over the sample square as the renderers sample it
//!   ([`sample_space_reflectance`]), is the table's (scales 0.989 to 1.003
//!   for the grooves: the weight of `ds` varies within a box).
//! * `rgb` instead of `spectra` and `wavelengths` ([`Rgl::rgb_from_spectral`],
//!   `export-brdf --rgb`): the same, per channel, for the linear sRGB BRDF
//!   of `colour.csv`, negative (out of gamut) values written as 0; read by
//!   Mitsuba's RGB variants.
//! * `luminance` (same grid): the mean over the wavelengths of `spectra`,
//!   plus 10⁻³ of its largest value so that no sample cell where `f > 0`
//!   is nearly impossible; 0 at the nodes where `spectra` is 0 at every
//!   wavelength, so that no sample lands where `f = 0` (the renderers and
//!   `mitsuba.chi2` drop a sample of weight 0 while `pdf` counts it). The
//!   renderers sample the sample square in proportion to it, then the vndf
//!   warp, so that their samples follow `f cos(theta_o)`.
//! * `theta_i` (radians): the table's incidences; `phi_i = [0]` for a
//!   table of one light azimuth (isotropic; anisotropic files: below);
//!   `wavelengths` (nm): the run's; a monochrome run (no wavelengths) is
//!   written as a grey spectrum, the same table at 360 and 830 nm (the
//!   limits of the CIE observer), so that spectral renderers see the same
//!   value at every visible wavelength.
//! * `description`: the comment; `jacobian = [1]`.
//!
//! # Anisotropic files (several light azimuths)
//!
//! A table of several light azimuths is written as an anisotropic file over
//! the whole circle of light azimuths (reduction 1, the only one pbrt-v4
//! reads) when its azimuths are the whole circle (nothing assumed), 0 to
//! 180 (the rest filled by a half turn, assumed to leave the surface
//! unchanged) or 0 to 90 (filled by the mirrors about the xz and yz planes,
//! assumed symmetries) ([`layout`]; [`layout::symmetry_figure`] judges the
//! assumption), and refused otherwise. Then `phi_i` holds the layout's
//! nodes (radians, -pi to pi), and the reader takes the half vector's
//! azimuth absolute (the sample's frame):
//!
//! * `ndf` ([`NDF_PHI_RES`] x [`NDF_RES`]): the facets' kernel at each
//!   node's direction without the azimuth average
//!   ([`Ndf::from_mesh_anisotropic`]), mixed with [`TABLE_SHARE`]
//!   of the distribution of the half vectors of the table's own light
//!   ([`Ndf::with_half_vectors`]: the facets miss light that leaves after
//!   several reflections, and `spectra` then has no node where it goes);
//! * `sigma` ([`SIGMA_PHI_RES`] x [`SIGMA_RES`]): its projected area at
//!   each `(theta_i, phi_i)`;
//! * `vndf`, `luminance`, `spectra`: a block per `(phi_i, theta_i)` node
//!   with the light at the node's azimuth and the table of the run's
//!   azimuth it comes from in its own plane of incidence (the file's `wo`
//!   moved by the node's [`layout::Symmetry`], then turned by minus the
//!   run's azimuth), **not**
//!   averaged with its mirror image, each block scaled to its table's
//!   reflectance.
//!
//! [`check`] judges every incidence and light azimuth.
//!
//! # Resampling error
//!
//! The file's BRDF at a direction is the interpolation of the node values
//! of the four nodes around its point `s` of the sample square, times the
//! ratio of `ndf` there to its values over the nodes' boxes; each node
//! value is the mean of the table over its box. So at a cell's centre the
//! file mixes the table over the points within 1.5 node spacings of the
//! cell's `s`: it lies between the values of the cells around it when the
//! nodes are finer than the cells, as on the default grids
//! ([`SAMPLE_RES`]: what the tests measured). [`check`] reads the file back
//! and reports the integrated reflectance against the table's.

pub mod layout;
pub mod tensor;
pub mod warp;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::DVec3;
use rayon::prelude::*;

use super::Mesh;
use super::exporter::{
    BrdfFormat, Export, ExportError, ExportInput, Exporter, Notice, ZemaxGrid, fixed, one_file,
};
use super::resample::{FormatError, symmetric_eval};
use crate::optics::brdf_table::{BrdfTable, BrdfTables, rotate_z};
use crate::outdir::file::ResultFile;
use crate::outdir::kind::FileKind;
use layout::{Layout, LayoutError, Node};
use tensor::{Field, TensorFile};
use warp::{Warp, bilinear, midpoints};

/// Nodes of the NDF along `u_theta`.
pub const NDF_RES: usize = 128;
/// Nodes of `sigma` along `u_theta` of the incidence.
pub const SIGMA_RES: usize = 64;
/// Nodes of an anisotropic file's NDF along `u_phi` (2 degrees apart; the
/// first and the last are the same azimuth, -180 and 180 degrees).
pub const NDF_PHI_RES: usize = 181;
/// Nodes of an anisotropic file's `sigma` along `u_phi` of the incidence
/// (4 degrees apart).
pub const SIGMA_PHI_RES: usize = 91;
/// Bins of an anisotropic NDF's facet normals ([`Ndf::from_mesh_anisotropic`]):
/// polar angle over 0-90 degrees, azimuth over 360.
pub const NORMAL_BINS_2D: [usize; 2] = [180, 360];
/// Nodes of the vndf warp per side.
pub const VNDF_RES: usize = 64;
/// Nodes of `spectra` and `luminance` per side. With node values the mean
/// of the table over each node's box (`box_average`) the file spreads
/// the table over 1.5 node spacings; cells of the tests in
/// `python/tests/test_rgl.py` beyond their bound (Mitsuba's `eval` at the
/// centres; the Gaussian Al field at 40 degrees, near the horizon, where
/// the outgoing direction moves twice as fast as the half vector): 6 of
/// 2112 at 96 nodes, 2 at 128, none at 160. The default scene's file is
/// then 3.2 MB, written and checked in 2.8 s on 2 cores (1.3 MB and 0.5 s
/// at 96 nodes with the table's values at the nodes).
pub const SAMPLE_RES: usize = 160;
/// Share of the uniform NDF `1/pi` mixed into the facets' one.
pub const DIFFUSE_SHARE: f64 = 0.05;
/// Share of an anisotropic file's NDF given to the half vectors of the
/// table's own light ([`Ndf::with_half_vectors`]).
pub const TABLE_SHARE: f64 = 0.25;
/// Points per period side of the height map triangulated for surfaces that
/// are not height fields.
pub const MESH_RES: usize = 512;
/// Bins of the facet normals' polar angle over 0-90 degrees
/// ([`Ndf::from_mesh`]).
pub const NORMAL_BINS: usize = 4500;

/// The exponentially scaled modified Bessel function `exp(-x) I0(x)` for
/// `x >= 0`, by the polynomial approximations of Abramowitz & Stegun
/// 9.8.1 and 9.8.2 (relative error below 2e-7).
fn bessel_i0e(x: f64) -> f64 {
    if x < 3.75 {
        let t = (x / 3.75).powi(2);
        let i0 = 1.0
            + t * (3.515_622_9
                + t * (3.089_942_4
                    + t * (1.206_749_2 + t * (0.265_973_2 + t * (0.036_076_8 + t * 0.004_581_3)))));
        i0 * (-x).exp()
    } else {
        let t = 3.75 / x;
        (0.398_942_28
            + t * (0.013_285_92
                + t * (0.002_253_19
                    + t * (-0.001_575_65
                        + t * (0.009_162_81
                            + t * (-0.020_577_06
                                + t * (0.026_355_37 + t * (-0.016_476_33 + t * 0.003_923_77))))))))
            / x.sqrt()
    }
}

/// The angular width of the kernel of [`Ndf::from_mesh`] for a table of
/// `bands` Carlson bands: the width of a band, `90 / bands` degrees, in
/// radians. A band of outgoing directions is about twice as wide as the
/// half vectors that reach it, so the kernel is about two bands of
/// outgoing directions across: the NDF changes little within a cell.
#[must_use]
pub fn smoothing_for(bands: usize) -> f64 {
    FRAC_PI_2 / bands.max(1) as f64
}

/// The grey spectrum of a monochrome table: wavelengths (nm).
pub const GREY_NM: [f64; 2] = [360.0, 830.0];

/// `theta` (radians) of `u_theta`.
fn u2theta(u: f64) -> f64 {
    u * u * FRAC_PI_2
}
/// `u_theta` of `theta` (radians).
fn theta2u(theta: f64) -> f64 {
    (theta / FRAC_PI_2).max(0.0).sqrt()
}
/// Azimuth (radians) of `u_phi`.
fn u2phi(u: f64) -> f64 {
    (2.0 * u - 1.0) * PI
}
/// `u_phi` of an azimuth (radians), wrapped into `[0, 1)`.
fn phi2u(phi: f64) -> f64 {
    let u = (phi + PI) / TAU;
    u - u.floor()
}
/// The unit vector of `u = (u_theta, u_phi)`.
fn dir_of(u: [f64; 2]) -> DVec3 {
    let (st, ct) = u2theta(u[0]).sin_cos();
    let (sp, cp) = u2phi(u[1]).sin_cos();
    DVec3::new(cp * st, sp * st, ct)
}
/// `u` of a unit vector.
fn u_of(d: DVec3) -> [f64; 2] {
    [theta2u(d.z.clamp(-1.0, 1.0).acos()), phi2u(d.y.atan2(d.x))]
}

/// A distribution of micro normals tabulated at `rows x NDF_RES` nodes of
/// `(u_phi, u_theta)` (sr⁻¹, normalised: `∫ D cos(theta_m) dω = 1`): one
/// row for an isotropic NDF (averaged over the azimuth), [`NDF_PHI_RES`]
/// rows for an anisotropic one (in the sample frame, absolute azimuth).
#[derive(Debug, Clone, PartialEq)]
pub struct Ndf {
    /// `D` at the nodes `u_theta = k / (NDF_RES - 1)`, `u_phi = r / (rows -
    /// 1)` (`rows > 1`), `u_theta` fastest.
    pub values: Vec<f64>,
    /// Rows of `u_phi`: 1 for an isotropic NDF.
    pub rows: usize,
}

/// `∫ hat_k(u(theta)) g(theta) dω` over the upper hemisphere for each node
/// `k` of `n` nodes in `u_theta` (the tent of node `k`), by the midpoint
/// rule on 64 steps per interval.
fn tent_integrals(n: usize, g: impl Fn(f64) -> f64) -> Vec<f64> {
    let steps = 64;
    let du = 1.0 / (n - 1) as f64;
    let mut out = vec![0.0; n];
    for k in 0..n - 1 {
        for s in 0..steps {
            let t = (s as f64 + 0.5) / steps as f64;
            let u = (k as f64 + t) * du;
            let theta = u2theta(u);
            // dω = 2 pi sin(theta) dtheta, dtheta = pi u du.
            let w = TAU * theta.sin() * PI * u * du / steps as f64 * g(theta);
            out[k] += (1.0 - t) * w;
            out[k + 1] += t * w;
        }
    }
    out
}

impl Ndf {
    /// The uniform NDF `D = 1/pi` (a Lambertian micro surface's).
    #[must_use]
    pub fn uniform() -> Self {
        Self {
            values: vec![1.0 / PI; NDF_RES],
            rows: 1,
        }
    }

    /// The NDF of the upward-facing triangles of `meshes` (height fields,
    /// one per surface realisation, pooled: see the module documentation;
    /// `upward_facets`): every triangle's normal `n`, weighted
    /// by its area, spread over the sphere by the von Mises-Fisher kernel
    /// `exp(kappa (m.n - 1))` of angular width `smoothing` (radians,
    /// `kappa = 1 / smoothing²`), averaged over the azimuth about the
    /// surface normal (isotropic: `exp(kappa (cos(theta_m - theta_n) - 1))
    /// I0e(kappa sin theta_m sin theta_n)`), then mixed with
    /// [`DIFFUSE_SHARE`] of the uniform one.
    ///
    /// The normals' polar angles are first binned on [`NORMAL_BINS`] bins
    /// (0.02 degree); the kernel is evaluated at every node, so the NDF is
    /// as smooth as the kernel between its nodes: the renderer multiplies
    /// the interpolated `spectra` by the ratio of the NDF to its value at
    /// the sample nodes, which must change little from one node to the
    /// next. The spreading gives flat facets (a mirror spike) an NDF the
    /// renderer's grids can follow; [`smoothing_for`] matches it to the
    /// table's cells, which cannot resolve finer detail anyway.
    #[must_use]
    pub fn from_mesh(meshes: &[Mesh], smoothing: f64) -> Self {
        let mut bins = vec![0.0; NORMAL_BINS];
        let mut projected = 0.0;
        for (normal, area) in upward_facets(meshes) {
            let cos = normal.z / (2.0 * area);
            projected += area * cos;
            let bin = (cos.min(1.0).acos() / FRAC_PI_2 * NORMAL_BINS as f64) as usize;
            bins[bin.min(NORMAL_BINS - 1)] += area;
        }
        if projected == 0.0 {
            return Self::uniform();
        }
        let kappa = 1.0 / (smoothing * smoothing);
        let normals: Vec<(f64, f64)> = bins
            .iter()
            .enumerate()
            .filter(|(_, w)| **w > 0.0)
            .map(|(b, &w)| ((b as f64 + 0.5) / NORMAL_BINS as f64 * FRAC_PI_2, w))
            .collect();
        let n = NDF_RES;
        let mut values: Vec<f64> = (0..n)
            .map(|k| {
                let tm = u2theta(k as f64 / (n - 1) as f64);
                normals
                    .iter()
                    .map(|&(tn, w)| {
                        w * (kappa * ((tm - tn).cos() - 1.0)).exp()
                            * bessel_i0e(kappa * tm.sin() * tn.sin())
                    })
                    .sum()
            })
            .collect();
        // Normalise the interpolated D exactly: ∫ D cos dω = 1.
        let cos = tent_integrals(n, f64::cos);
        let norm: f64 = values.iter().zip(&cos).map(|(v, c)| v * c).sum();
        for v in &mut values {
            *v = (1.0 - DIFFUSE_SHARE) * *v / norm + DIFFUSE_SHARE / PI;
        }
        Self { values, rows: 1 }
    }

    /// The anisotropic NDF of the upward-facing triangles of `meshes`, at
    /// [`NDF_PHI_RES`] x [`NDF_RES`] nodes of `(u_phi, u_theta)` in the
    /// sample frame: as [`from_mesh`](Self::from_mesh) without the average
    /// over the azimuth, the kernel `exp(kappa (m.n - 1))` evaluated at each
    /// node's direction `m`. The normals are first binned on
    /// [`NORMAL_BINS_2D`] bins (0.5 x 1 degree), each bin's area-weighted
    /// mean normal standing for it; contributions below `exp(-40)` of a
    /// bin's weight are left out. Normalised exactly for the bilinear
    /// interpolation of the nodes, then mixed with [`DIFFUSE_SHARE`] of the
    /// uniform NDF.
    #[must_use]
    pub fn from_mesh_anisotropic(meshes: &[Mesh], smoothing: f64) -> Self {
        let [tb, pb] = NORMAL_BINS_2D;
        let mut area_of = vec![0.0; tb * pb];
        let mut sum_of = vec![DVec3::ZERO; tb * pb];
        for (normal, area) in upward_facets(meshes) {
            let n = normal / (2.0 * area);
            let t = ((n.z.min(1.0).acos() / FRAC_PI_2 * tb as f64) as usize).min(tb - 1);
            let q = ((phi2u(n.y.atan2(n.x)) * pb as f64) as usize).min(pb - 1);
            area_of[t * pb + q] += area;
            sum_of[t * pb + q] += area * n;
        }
        let normals: Vec<(DVec3, f64)> = area_of
            .iter()
            .zip(&sum_of)
            .filter(|(a, s)| **a > 0.0 && s.length() > 0.0)
            .map(|(&a, s)| (s.normalize(), a))
            .collect();
        let Some(mut ndf) = Self::kernel(&normals, smoothing) else {
            return Self::uniform().anisotropic();
        };
        for v in &mut ndf.values {
            *v = (1.0 - DIFFUSE_SHARE) * *v + DIFFUSE_SHARE / PI;
        }
        ndf
    }

    /// The anisotropic NDF (`NDF_PHI_RES x NDF_RES` nodes) of the weighted
    /// directions `normals` (unit, `z > 0`) spread by the von Mises-Fisher
    /// kernel `exp(kappa (m.n - 1))`, `kappa = 1 / smoothing²`, evaluated
    /// at each node (contributions below `exp(-40)` left out), normalised
    /// exactly for the bilinear interpolation of the nodes; `None` without
    /// a direction of positive weight.
    fn kernel(normals: &[(DVec3, f64)], smoothing: f64) -> Option<Self> {
        let mut normals: Vec<(f64, DVec3, f64)> = normals
            .iter()
            .filter(|(n, w)| *w > 0.0 && n.z > 0.0)
            .map(|&(n, w)| (n.z.clamp(-1.0, 1.0).acos(), n, w))
            .collect();
        if normals.is_empty() {
            return None;
        }
        let (rows, n) = (NDF_PHI_RES, NDF_RES);
        normals.sort_by(|a, b| a.0.total_cmp(&b.0));
        let thetas: Vec<f64> = normals.iter().map(|x| x.0).collect();
        let kappa = 1.0 / (smoothing * smoothing);
        let cut = 1.0 - 40.0 / kappa;
        let reach = cut.max(-1.0).acos();
        let mut values: Vec<f64> = (0..rows * n)
            .into_par_iter()
            .map(|idx| {
                let u = [
                    (idx % n) as f64 / (n - 1) as f64,
                    (idx / n) as f64 / (rows - 1) as f64,
                ];
                let m = dir_of(u);
                let tm = u2theta(u[0]);
                let lo = thetas.partition_point(|&t| t < tm - reach);
                let hi = thetas.partition_point(|&t| t <= tm + reach);
                normals[lo..hi]
                    .iter()
                    .map(|&(_, nn, w)| {
                        let d = m.dot(nn);
                        if d > cut {
                            w * (kappa * (d - 1.0)).exp()
                        } else {
                            0.0
                        }
                    })
                    .sum()
            })
            .collect();
        // ∫ hat_k(u_theta) hat_r(u_phi) cos dω = tent_k / (rows - 1), half
        // that for the first and the last row (the same azimuth).
        let cos = tent_integrals(n, f64::cos);
        let norm: f64 = values
            .iter()
            .enumerate()
            .map(|(idx, v)| {
                let r = idx / n;
                let w = if r == 0 || r == rows - 1 { 0.5 } else { 1.0 };
                v * cos[idx % n] * w / (rows - 1) as f64
            })
            .sum();
        if norm <= 0.0 {
            return None;
        }
        values.iter_mut().for_each(|v| *v /= norm);
        Some(Self { values, rows })
    }

    /// This anisotropic NDF mixed with the distribution of the half
    /// vectors `half` (unit, weighted) that a table's light takes
    /// (their von Mises-Fisher kernel, spread by `smoothing`): a share
    /// [`TABLE_SHARE`] of the result, the rest this NDF scaled down.
    #[must_use]
    pub fn with_half_vectors(&self, half: &[(DVec3, f64)], smoothing: f64) -> Self {
        let a = self.anisotropic();
        match Self::kernel(half, smoothing) {
            Some(h) => Self {
                values: a
                    .values
                    .iter()
                    .zip(&h.values)
                    .map(|(d, t)| (1.0 - TABLE_SHARE) * d + TABLE_SHARE * t)
                    .collect(),
                rows: a.rows,
            },
            None => a,
        }
    }

    /// This NDF on [`NDF_PHI_RES`] rows of `u_phi`: an isotropic one
    /// repeated, an anisotropic one as it is.
    #[must_use]
    pub fn anisotropic(&self) -> Self {
        if self.rows > 1 {
            return self.clone();
        }
        Self {
            values: (0..NDF_PHI_RES).flat_map(|_| self.values.clone()).collect(),
            rows: NDF_PHI_RES,
        }
    }

    /// `D` at `u_theta` (linear between the nodes).
    #[must_use]
    pub fn at(&self, u_theta: f64) -> f64 {
        let n = self.values.len();
        let x = u_theta.clamp(0.0, 1.0) * (n - 1) as f64;
        let k = (x as usize).min(n - 2);
        let t = x - k as f64;
        (1.0 - t) * self.values[k] + t * self.values[k + 1]
    }

    /// The projected area `sigma(theta_i) = ∫ D(m) max(0, wi.m) dω` of
    /// micro normals seen from incidence `theta_i` (radians), by the
    /// midpoint rule on 256 x 256 cells of the `u` square.
    #[must_use]
    pub fn projected_area(&self, theta_i: f64) -> f64 {
        let n = 256;
        let wi = DVec3::new(theta_i.sin(), 0.0, theta_i.cos());
        midpoints(n)
            .map(|u| {
                let m = dir_of(u);
                let jac = 2.0 * PI * PI * u[0] * u2theta(u[0]).sin();
                self.at(u[0]) * wi.dot(m).max(0.0) * jac
            })
            .sum::<f64>()
            / (n * n) as f64
    }
}

/// Rounded to `f32` and back: the value a reader of the file sees.
fn f32_round(v: f64) -> f64 {
    f64::from(v as f32)
}

/// The unit vector of polar angle `theta` and azimuth `phi` (radians):
/// `(sin theta cos phi, sin theta sin phi, cos theta)`, exactly
/// `(sin theta, 0, cos theta)` at `phi = 0` (the light at incidence
/// `theta`, azimuth `phi`; a cell's centre).
fn direction(theta: f64, phi: f64) -> DVec3 {
    let (sp, cp) = phi.sin_cos();
    DVec3::new(theta.sin() * cp, theta.sin() * sp, theta.cos())
}

/// The grids of an RGL file that depend on the NDF and the incidences
/// only, as the renderer interpolates them (values rounded to `f32`).
#[derive(Clone)]
struct Grids {
    /// Whether the file is isotropic (at most two `phi_i` nodes).
    isotropic: bool,
    /// `ndf` as written, `ndf_rows x NDF_RES`.
    ndf: Vec<f64>,
    ndf_rows: usize,
    /// `sigma` as written, `sigma_rows x SIGMA_RES`.
    sigma: Vec<f64>,
    sigma_rows: usize,
    /// Per incidence node (`phi_i` node `p`, `theta_i` node `k`: `p n_theta
    /// + k`), the vndf node values as written.
    vndf: Vec<Vec<f64>>,
    /// Per incidence node, the warp of its vndf.
    warps: Vec<Warp>,
}

impl Grids {
    fn ndf_at(&self, u: [f64; 2]) -> f64 {
        bilinear(&self.ndf, NDF_RES, self.ndf_rows, u)
    }
    /// `sigma` of the incidence `wi` at `theta_i`, `phi_i` (radians; the
    /// azimuth is not read for an isotropic file).
    fn sigma_at(&self, theta_i: f64, phi_i: f64) -> f64 {
        let v = if self.isotropic { 0.5 } else { phi2u(phi_i) };
        bilinear(
            &self.sigma,
            SIGMA_RES,
            self.sigma_rows,
            [theta2u(theta_i), v],
        )
    }
}

/// The vndf node values towards the light `wi` for the NDF `ndf` (as
/// interpolated from its grid `ndf_at`; the azimuth of `m` absolute, which
/// for the isotropic file's `wi` at azimuth 0 is the relative one).
fn vndf_nodes(wi: DVec3, ndf_at: impl Fn([f64; 2]) -> f64) -> Vec<f64> {
    let r = VNDF_RES;
    (0..r * r)
        .map(|k| {
            let u = [
                (k % r) as f64 / (r - 1) as f64,
                (k / r) as f64 / (r - 1) as f64,
            ];
            let m = dir_of(u);
            let jac = 2.0 * PI * PI * u[0] * u2theta(u[0]).sin();
            f32_round(ndf_at(u) * wi.dot(m).max(0.0) * jac)
        })
        .collect()
}

/// The projected area `∫ D(m) max(0, wi.m) dω` of the anisotropic NDF
/// `ndf` (its interpolated grid, `NDF_PHI_RES` rows) at the nodes of an
/// anisotropic `sigma` grid (`SIGMA_PHI_RES x SIGMA_RES`), by the midpoint
/// rule on 256 x 256 cells of the `u` square as [`Ndf::projected_area`].
fn anisotropic_sigma(ndf: &[f64]) -> Vec<f64> {
    let n = 256;
    let points: Vec<(DVec3, f64)> = midpoints(n)
        .map(|u| {
            let jac = 2.0 * PI * PI * u[0] * u2theta(u[0]).sin();
            (dir_of(u), bilinear(ndf, NDF_RES, NDF_PHI_RES, u) * jac)
        })
        .collect();
    (0..SIGMA_PHI_RES * SIGMA_RES)
        .into_par_iter()
        .map(|idx| {
            let wi = dir_of([
                (idx % SIGMA_RES) as f64 / (SIGMA_RES - 1) as f64,
                (idx / SIGMA_RES) as f64 / (SIGMA_PHI_RES - 1) as f64,
            ]);
            let sum: f64 = points.iter().map(|(m, d)| d * wi.dot(*m).max(0.0)).sum();
            f32_round(sum / (n * n) as f64)
        })
        .collect()
}

impl Grids {
    /// The grids of the NDF `ndf` at the incidences `thetas_rad` and the
    /// light azimuths of `layout`.
    fn new(
        ndf: &Ndf,
        thetas_rad: &[f64],
        layout: &Layout,
        half: &[(DVec3, f64)],
        smoothing: f64,
    ) -> Self {
        if layout.is_isotropic() {
            assert_eq!(ndf.rows, 1, "an isotropic file takes an isotropic NDF");
            let ndf_grid: Vec<f64> = (0..2)
                .flat_map(|_| ndf.values.iter().map(|&v| f32_round(v)))
                .collect();
            let sigma_row: Vec<f64> = (0..SIGMA_RES)
                .into_par_iter()
                .map(|k| f32_round(ndf.projected_area(u2theta(k as f64 / (SIGMA_RES - 1) as f64))))
                .collect();
            let sigma = [sigma_row.clone(), sigma_row].concat();
            let ndf_at = |u: [f64; 2]| bilinear(&ndf_grid, NDF_RES, 2, u);
            let vndf: Vec<Vec<f64>> = thetas_rad
                .iter()
                .map(|&t| vndf_nodes(direction(t, 0.0), ndf_at))
                .collect();
            return Self::finish(true, ndf_grid, 2, sigma, 2, vndf);
        }
        let file_ndf = ndf.anisotropic().with_half_vectors(half, smoothing);
        let ndf_grid: Vec<f64> = file_ndf.values.iter().map(|&v| f32_round(v)).collect();
        let sigma = anisotropic_sigma(&ndf_grid);
        let ndf_at = |u: [f64; 2]| bilinear(&ndf_grid, NDF_RES, NDF_PHI_RES, u);
        let vndf: Vec<Vec<f64>> = layout
            .nodes
            .iter()
            .flat_map(|node| {
                thetas_rad
                    .iter()
                    .map(move |&t| direction(t, node.phi_deg.to_radians()))
            })
            .collect::<Vec<_>>()
            .par_iter()
            .map(|&wi| vndf_nodes(wi, ndf_at))
            .collect();
        Self::finish(false, ndf_grid, NDF_PHI_RES, sigma, SIGMA_PHI_RES, vndf)
    }

    fn finish(
        isotropic: bool,
        ndf: Vec<f64>,
        ndf_rows: usize,
        sigma: Vec<f64>,
        sigma_rows: usize,
        vndf: Vec<Vec<f64>>,
    ) -> Self {
        let warps = vndf
            .iter()
            .map(|v| Warp::new(v, VNDF_RES, VNDF_RES))
            .collect();
        Self {
            isotropic,
            ndf,
            ndf_rows,
            sigma,
            sigma_rows,
            vndf,
            warps,
        }
    }
}

/// The half vectors of the light of `table` (several azimuths) at every
/// node of `layout` and incidence `thetas_rad`, in the file's frame: per
/// cell, the half vector between the node's `wi` and the cell's centre
/// (moved by the node's [`layout::Symmetry`]), weighted by the cell's
/// fraction over the incidence's reflectance (each incidence weighs the
/// same).
fn half_vectors(table: &BrdfTable, layout: &Layout, thetas_rad: &[f64]) -> Vec<(DVec3, f64)> {
    let grid = table.grid();
    let n = table.azimuths_deg().len();
    let mut out = Vec::new();
    for node in &layout.nodes {
        for (k, &theta) in thetas_rad.iter().enumerate() {
            let wi = direction(theta, node.phi_deg.to_radians());
            let fractions = table.fractions(k * n + node.azimuth);
            let total: f64 = fractions.iter().sum();
            if total <= 0.0 {
                continue;
            }
            for (flat, &f) in fractions.iter().enumerate() {
                if f <= 0.0 {
                    continue;
                }
                let (band, cell) = grid.band_cell(flat);
                let (t, p) = grid.centre(band, cell);
                let wo = node.symmetry.apply(direction(t, p));
                out.push(((wi + wo).normalize(), f / total));
            }
        }
    }
    out
}

/// Sub-cells of the `spectra` grid per node interval and side (even: no
/// sub-cell midpoint is equally near two nodes), at whose midpoints
/// `box_average` samples the table.
pub const BOX_SUBDIVISION: usize = 4;

/// The midpoints `s` of the [`BOX_SUBDIVISION`]² sub-cells of every cell
/// of the [`SAMPLE_RES`]² grid of `spectra` nodes, row by row (`x` fastest).
fn fine_points() -> impl Iterator<Item = [f64; 2]> {
    midpoints((SAMPLE_RES - 1) * BOX_SUBDIVISION)
}

/// The node values of `spectra` from the integrand `g` at the
/// `fine_points` (same order): at each node the mean of `g` over the
/// node's box, the points nearer to it than to any other node (half a
/// spacing either side; a quarter or half of that at the edges and
/// corners of the square). A node's box has the area of its bilinear tent,
/// and the boxes tile the square, so the integral of the interpolated
/// nodes over the square is the mean of `g` (the file's reflectance:
/// [`sample_space_reflectance`]), and a peak narrower than the node
/// spacing keeps its energy on the node nearest to it. Values at the nodes
/// alone missed such a peak (the grooves' retroreflection, one Carlson
/// cell wide, at a light azimuth whose NDF barely reaches it) and sent a
/// lone photon's cell, read at a node, a whole spacing around (the
/// Gaussian ensemble); tents as weights (twice as wide) blur the table
/// over two spacings, beyond the per-cell bound near the horizon.
fn box_average(g: impl Iterator<Item = f64>) -> Vec<f64> {
    let (r, k) = (SAMPLE_RES, BOX_SUBDIVISION);
    let n = (r - 1) * k;
    let mut sum = vec![0.0; r * r];
    let mut count = vec![0usize; r * r];
    for (idx, v) in g.enumerate() {
        let nearest = |x: usize| x / k + usize::from(x % k >= k / 2);
        let node = nearest(idx / n) * r + nearest(idx % n);
        sum[node] += v;
        count[node] += 1;
    }
    sum.iter().zip(&count).map(|(s, &c)| s / c as f64).collect()
}

/// An RGL file's contents before encoding (or after reading back).
#[derive(Debug, Clone)]
pub struct Rgl {
    /// Incidence angles (radians), ascending.
    pub theta_i: Vec<f64>,
    /// Light azimuths `phi_i` of the file (radians, ascending): `[0]` for
    /// an isotropic file; see [`layout`] for an anisotropic one.
    pub phi_i: Vec<f64>,
    /// Wavelengths (nm), ascending; empty for an RGB file.
    pub wavelengths_nm: Vec<f64>,
    /// `spectra[p n_theta + k][wavelength]` (`p` the `phi_i` node, `k`
    /// the `theta_i` node; an RGB file: `[..][channel]`, the `rgb` field):
    /// `SAMPLE_RES²` node values.
    pub spectra: Vec<Vec<Vec<f64>>>,
    /// The description.
    pub description: String,
    grids: Grids,
}

impl std::fmt::Debug for Grids {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Grids({} incidences)", self.vndf.len())
    }
}

impl Rgl {
    /// The RGL file of `tables` (one per wavelength `wavelengths_um`, µm;
    /// empty with one table: monochrome, written grey at [`GREY_NM`]) with
    /// the NDF `ndf`; see the module documentation. A table of several
    /// light azimuths gives an anisotropic file ([`Layout::of`]), which
    /// takes an anisotropic NDF ([`Ndf::from_mesh_anisotropic`]; an
    /// isotropic one is repeated over the azimuth).
    ///
    /// # Errors
    /// Light azimuths that no RGL file holds ([`Layout::of`]: the reason).
    pub fn from_tables(
        tables: &BrdfTables,
        ndf: &Ndf,
        description: &str,
    ) -> Result<Self, LayoutError> {
        let (wavelengths_nm, per_wavelength): (Vec<f64>, Vec<&BrdfTable>) =
            match tables.wavelengths_um() {
                [] => (GREY_NM.to_vec(), vec![&tables.tables()[0]; 2]),
                w => (
                    w.iter().map(|w| w * 1e3).collect(),
                    tables.tables().iter().collect(),
                ),
            };
        Self::build(&per_wavelength, wavelengths_nm, ndf, description)
    }

    /// The RGB file (field `rgb` instead of `spectra` and `wavelengths`, as
    /// Mitsuba 3's `measured` plugin reads in its RGB variants) of a
    /// spectral run: its channels are the linear sRGB (Rec. 709 primaries,
    /// D65 white) BRDF of `colour.csv` ([`super::merl::srgb_tables`]: CIE
    /// 1931 XYZ under D65 of the BRDF spectrum of each cell, then the sRGB
    /// matrix), negative (out of gamut) values written as 0. `None` unless
    /// the wavelengths cover the visible.
    ///
    /// # Errors
    /// As [`from_tables`](Self::from_tables).
    pub fn rgb_from_spectral(
        tables: &crate::optics::brdf_table::SpectralTables,
        ndf: &Ndf,
        description: &str,
    ) -> Result<Option<(Self, [BrdfTable; 3])>, LayoutError> {
        let Some(channels) = super::merl::srgb_tables(tables) else {
            return Ok(None);
        };
        let file = Self::build(
            &channels.iter().collect::<Vec<_>>(),
            Vec::new(),
            ndf,
            description,
        )?;
        Ok(Some((file, channels)))
    }

    /// The file of one table per channel (`wavelengths_nm` the channels'
    /// wavelengths; empty: RGB), each normalised to the reflectance of its
    /// table (see the module documentation).
    fn build(
        per_channel: &[&BrdfTable],
        wavelengths_nm: Vec<f64>,
        ndf: &Ndf,
        description: &str,
    ) -> Result<Self, LayoutError> {
        let layout = Layout::of(per_channel[0].azimuths_deg())?;
        let thetas: Vec<f64> = per_channel[0]
            .angles_deg()
            .iter()
            .map(|d| d.to_radians())
            .collect();
        let ni = thetas.len();
        let half = if layout.is_isotropic() {
            Vec::new()
        } else {
            half_vectors(per_channel[0], &layout, &thetas)
        };
        let smoothing = smoothing_for(per_channel[0].bands());
        let grids = Grids::new(ndf, &thetas, &layout, &half, smoothing);
        // The BRDF of channel `w` at file node `node`, incidence `theta`,
        // towards `wo` (the file's frame): isotropic, averaged with its
        // mirror image in the plane of incidence; anisotropic, the node's
        // azimuth's table towards `wo` moved by the node's isometry (onto
        // the run's light) and turned by minus the run's azimuth (into its
        // plane of incidence), not averaged.
        let per_azimuth: Vec<Vec<BrdfTable>> = if layout.is_isotropic() {
            Vec::new()
        } else {
            (0..per_channel[0].azimuths_deg().len())
                .map(|j| per_channel.iter().map(|t| t.azimuth(j)).collect())
                .collect()
        };
        let channel = |w: usize, node: &Node| -> &BrdfTable {
            if layout.is_isotropic() {
                per_channel[w]
            } else {
                &per_azimuth[node.azimuth][w]
            }
        };
        let eval = |w: usize, node: &Node, theta: f64, wo: DVec3| -> f64 {
            if layout.is_isotropic() {
                symmetric_eval(per_channel[w], theta, wo)
            } else {
                let a = per_channel[0].azimuths_deg()[node.azimuth].to_radians();
                channel(w, node).eval(theta, rotate_z(node.symmetry.apply(wo), -a))
            }
        };
        let spectra = (0..layout.nodes.len() * ni)
            .into_par_iter()
            .map(|flat| {
                let (node, theta) = (&layout.nodes[flat / ni], thetas[flat % ni]);
                let phi = node.phi_deg.to_radians();
                let wi = direction(theta, phi);
                let factor = 4.0 * grids.sigma_at(theta, phi);
                let fine: Vec<(DVec3, f64)> = fine_points()
                    .map(|s| {
                        let u = grids.warps[flat].sample(s);
                        let m = dir_of(u);
                        (2.0 * wi.dot(m) * m - wi, factor / grids.ndf_at(u))
                    })
                    .collect();
                (0..per_channel.len())
                    .map(|w| {
                        box_average(fine.iter().map(|&(wo, scale)| {
                            if wo.z <= 0.0 {
                                0.0
                            } else {
                                (eval(w, node, theta, wo) * wo.z * scale).max(0.0)
                            }
                        }))
                    })
                    .collect()
            })
            .collect();
        let thetas_copy = thetas.clone();
        let mut file = Self {
            theta_i: thetas,
            phi_i: layout
                .nodes
                .iter()
                .map(|n| n.phi_deg.to_radians())
                .collect(),
            wavelengths_nm,
            spectra,
            description: description.into(),
            grids,
        };
        file.normalise(|flat, w| {
            channel(w, &layout.nodes[flat / ni]).reflectance(thetas_copy[flat % ni])
        });
        Ok(file)
    }

    /// Normalise each incidence node `flat` and channel `w` to the table's
    /// reflectance `want(flat, w)`: the interpolation between the nodes does
    /// not keep the integral near a narrow peak (a few % at a mirror spike).
    fn normalise(&mut self, want: impl Fn(usize, usize) -> f64) {
        let refl = sample_space_reflectance(self, BOX_SUBDIVISION);
        for (flat, per_k) in self.spectra.iter_mut().enumerate() {
            for (w, values) in per_k.iter_mut().enumerate() {
                let want = want(flat, w);
                if refl[flat][w] > 0.0 && want > 0.0 {
                    let scale = want / refl[flat][w];
                    values.iter_mut().for_each(|v| *v *= scale);
                }
            }
        }
    }

    /// The `luminance` node values of incidence node `k` (`p n_theta + k`).
    fn luminance(&self, k: usize) -> Vec<f64> {
        let spectra = &self.spectra[k];
        let n = spectra.len() as f64;
        let mean: Vec<f64> = (0..SAMPLE_RES * SAMPLE_RES)
            .map(|i| spectra.iter().map(|s| s[i]).sum::<f64>() / n)
            .collect();
        let max = mean.iter().copied().fold(0.0, f64::max);
        if max > 0.0 {
            // Nodes where every wavelength is 0 stay 0: a sample cell whose
            // four nodes are all 0 has f = 0, and a positive pdf there
            // would send samples of zero weight, which a renderer (and
            // `mitsuba.chi2`) drops while `pdf` still counts them.
            mean.iter()
                .map(|&v| if v > 0.0 { v + 1e-3 * max } else { 0.0 })
                .collect()
        } else {
            vec![1.0; mean.len()]
        }
    }

    /// The tensor file.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let (np, ni) = (self.phi_i.len(), self.theta_i.len());
        let (nw, r) = (self.spectra[0].len(), SAMPLE_RES);
        let flat = |v: Vec<Vec<f64>>| v.concat();
        let luminance = flat((0..np * ni).map(|k| self.luminance(k)).collect());
        let spectra = flat(self.spectra.iter().map(|s| s.concat()).collect());
        let mut fields = vec![
            Field::f32("theta_i", &[ni], &self.theta_i),
            Field::f32("phi_i", &[np], &self.phi_i),
            Field::f32("ndf", &[self.grids.ndf_rows, NDF_RES], &self.grids.ndf),
            Field::f32(
                "sigma",
                &[self.grids.sigma_rows, SIGMA_RES],
                &self.grids.sigma,
            ),
            Field::f32(
                "vndf",
                &[np, ni, VNDF_RES, VNDF_RES],
                &self.grids.vndf.concat(),
            ),
            Field::f32("luminance", &[np, ni, r, r], &luminance),
        ];
        if self.wavelengths_nm.is_empty() {
            fields.push(Field::f32("rgb", &[np, ni, 3, r, r], &spectra));
        } else {
            fields.push(Field::f32("spectra", &[np, ni, nw, r, r], &spectra));
            fields.push(Field::f32("wavelengths", &[nw], &self.wavelengths_nm));
        }
        fields.push(Field::bytes("description", self.description.as_bytes()));
        fields.push(Field::bytes("jacobian", &[1]));
        tensor::write(&fields)
    }

    /// Read a file written by [`to_bytes`](Self::to_bytes) (isotropic or
    /// anisotropic, spectral or RGB, on this module's grids); `file` names
    /// it in errors.
    ///
    /// # Errors
    /// A field missing, of the wrong type or shape.
    pub fn parse(bytes: &[u8], file: &str) -> Result<Self, FormatError> {
        let t = TensorFile::parse(bytes, file)?;
        let wrong = |what: &str| FormatError {
            file: file.into(),
            message: format!("{what} (roks reads back the files it writes: its own grid sizes)"),
        };
        let widen = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
        let (_, theta) = t.f32("theta_i", 1)?;
        let (_, phi) = t.f32("phi_i", 1)?;
        let rgb = t.f32("rgb", 5).is_ok();
        let wl: &[f32] = if rgb { &[] } else { t.f32("wavelengths", 1)?.1 };
        let (np, ni, nw) = (phi.len(), theta.len(), if rgb { 3 } else { wl.len() });
        let isotropic = np <= 2;
        if np == 2 {
            return Err(wrong("phi_i has two nodes"));
        }
        let (ndf_rows, sigma_rows) = if isotropic {
            (2, 2)
        } else {
            (NDF_PHI_RES, SIGMA_PHI_RES)
        };
        let r = SAMPLE_RES;
        let field = |name: &str, shape: &[usize]| -> Result<Vec<f64>, FormatError> {
            let (s, v) = t.f32(name, shape.len())?;
            if s != shape {
                return Err(wrong(&format!(
                    "field {name} has shape {s:?}, expected {shape:?}"
                )));
            }
            Ok(widen(v))
        };
        let ndf = field("ndf", &[ndf_rows, NDF_RES])?;
        let sigma = field("sigma", &[sigma_rows, SIGMA_RES])?;
        let vndf = field("vndf", &[np, ni, VNDF_RES, VNDF_RES])?;
        field("luminance", &[np, ni, r, r])?;
        let spectra = field(if rgb { "rgb" } else { "spectra" }, &[np, ni, nw, r, r])?;
        if t.bytes("jacobian")? != [1] {
            return Err(wrong("jacobian is not [1]"));
        }
        let description = String::from_utf8_lossy(t.bytes("description")?).into_owned();
        let vndf: Vec<Vec<f64>> = vndf
            .chunks(VNDF_RES * VNDF_RES)
            .map(<[f64]>::to_vec)
            .collect();
        Ok(Self {
            theta_i: widen(theta),
            phi_i: widen(phi),
            wavelengths_nm: widen(wl),
            spectra: spectra
                .chunks(nw * r * r)
                .map(|s| s.chunks(r * r).map(<[f64]>::to_vec).collect())
                .collect(),
            description,
            grids: Grids::finish(isotropic, ndf, ndf_rows, sigma, sigma_rows, vndf),
        })
    }

    /// `f(wi, wo) cos(theta_o)` of the file at incidence node `k` (`p
    /// n_theta + k'`: `phi_i` node `p`, `theta_i` node `k'`; for an
    /// isotropic file the `theta_i` node) towards `wo` (unit, the file's
    /// frame; an isotropic file's light is on the `+x` side), per
    /// wavelength: the renderer's evaluation (module documentation) at a
    /// node of `phi_i` and `theta_i`.
    #[must_use]
    pub fn eval_cos(&self, k: usize, wo: DVec3) -> Vec<f64> {
        let nw = self.spectra[k].len();
        if wo.z <= 0.0 {
            return vec![0.0; nw];
        }
        let ni = self.theta_i.len();
        let (theta, phi) = (self.theta_i[k % ni], self.phi_i[k / ni]);
        let wi = direction(theta, phi);
        let m = (wi + wo).normalize();
        let u = u_of(m);
        let s = self.grids.warps[k].invert(u);
        let scale = self.grids.ndf_at(u) / (4.0 * self.grids.sigma_at(theta, phi));
        self.spectra[k]
            .iter()
            .map(|sp| bilinear(sp, SAMPLE_RES, SAMPLE_RES, s) * scale)
            .collect()
    }
}

/// The NDF of a micro surface (see the module documentation), spread by
/// `smoothing` radians: [`Ndf::from_mesh`], or with `anisotropic`
/// [`Ndf::from_mesh_anisotropic`].
#[must_use]
pub fn surface_ndf(
    surfaces: &[&crate::micro::MicroSurface],
    smoothing: f64,
    anisotropic: bool,
) -> Ndf {
    let meshes: Vec<Mesh> = surfaces
        .iter()
        .map(|surface| match surface.heightfield() {
            Some(field) => super::field_mesh(field),
            None => super::height_field_mesh(surface, MESH_RES),
        })
        .collect();
    if anisotropic {
        Ndf::from_mesh_anisotropic(&meshes, smoothing)
    } else {
        Ndf::from_mesh(&meshes, smoothing)
    }
}

/// The upward-facing triangles of `meshes`, in order: each one's normal
/// `(b - a) x (c - a)` (length twice its area) and its area; triangles of
/// no area or facing down (overhangs seen from below) left out.
fn upward_facets(meshes: &[Mesh]) -> impl Iterator<Item = (DVec3, f64)> + '_ {
    meshes.iter().flat_map(|mesh| {
        mesh.faces.iter().filter_map(move |f| {
            let p = f.map(|k| {
                let v = mesh.vertices[k as usize];
                DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
            });
            let normal = (p[1] - p[0]).cross(p[2] - p[0]);
            let area = 0.5 * normal.length();
            (area > 0.0 && normal.z > 0.0).then_some((normal, area))
        })
    })
}

/// The directional-hemispherical reflectance of an RGL file read back, per
/// incidence node (`p n_theta + k`, as [`Rgl::spectra`]) and wavelength:
/// its `f cos(theta_o)` integrated over the hemisphere by the midpoint
/// rule on `rings` rings of equal polar width times `4 rings` azimuth
/// sectors, each cell weighted by its solid angle.
#[must_use]
pub fn reflectance(file: &Rgl, rings: usize) -> Vec<Vec<f64>> {
    let sectors = 4 * rings;
    let dtheta = FRAC_PI_2 / rings as f64;
    let dphi = TAU / sectors as f64;
    let nw = file.spectra[0].len();
    (0..file.spectra.len())
        .map(|k| {
            let per_ring: Vec<Vec<f64>> = (0..rings)
                .into_par_iter()
                .map(|i| {
                    let (a, b) = (i as f64 * dtheta, (i + 1) as f64 * dtheta);
                    let solid = (a.cos() - b.cos()) * dphi;
                    let (s, c) = (0.5 * (a + b)).sin_cos();
                    let mut sum = vec![0.0; nw];
                    for j in 0..sectors {
                        let phi = (j as f64 + 0.5) * dphi;
                        let wo = DVec3::new(s * phi.cos(), s * phi.sin(), c);
                        for (acc, v) in sum.iter_mut().zip(file.eval_cos(k, wo)) {
                            *acc += v * solid;
                        }
                    }
                    sum
                })
                .collect();
            (0..nw)
                .map(|w| per_ring.iter().map(|r| r[w]).sum())
                .collect()
        })
        .collect()
}

/// The directional-hemispherical reflectance of an RGL file read back, per
/// incidence node (`p n_theta + k`, as [`Rgl::spectra`]) and wavelength,
/// integrated over the sample square as the renderers sample it: at the
/// midpoint `s` of every one of `subdivision`² sub-cells per cell of the
/// `spectra` nodes (the writer: [`BOX_SUBDIVISION`], the points of its
/// boxes; [`check`]: [`CHECK_SUBDIVISION`]) the interpolated
/// `spectra` times `ndf / (4 sigma)` (the renderers' `f cos(theta_o)`)
/// over the density of the outgoing direction per unit of `s` (the vndf
/// warp's normalised density at the half vector over the Jacobian
/// `2 pi² u_theta sin(theta_m) 4 (wi.m)` of the half vector's square and
/// the mirror reflection, as Mitsuba's `measured` computes its `pdf`),
/// directions below the horizon dropped. This is the expectation of
/// Mitsuba's `sample` weight; unlike a rule on cells of equal solid angle
/// ([`reflectance`]) it resolves peaks narrower than the cells (the
/// grooves' whole-circle file at 60 degrees, normalised here to the
/// table's 0.8: 0.809 on 0.5-degree cells, 0.80007 on 0.125-degree ones,
/// and Mitsuba's own `sample` weights average 0.79999 ± 0.00003).
#[must_use]
pub fn sample_space_reflectance(file: &Rgl, subdivision: usize) -> Vec<Vec<f64>> {
    let ni = file.theta_i.len();
    let n = (SAMPLE_RES - 1) * subdivision;
    let count = (n * n) as f64;
    (0..file.spectra.len())
        .into_par_iter()
        .map(|k| {
            let (theta, phi) = (file.theta_i[k % ni], file.phi_i[k / ni]);
            let wi = direction(theta, phi);
            let warp = &file.grids.warps[k];
            let four_sigma = 4.0 * file.grids.sigma_at(theta, phi);
            let mut sum = vec![0.0; file.spectra[k].len()];
            for s in midpoints(n) {
                let u = warp.sample(s);
                let m = dir_of(u);
                let cos = wi.dot(m);
                let wo = 2.0 * cos * m - wi;
                let jacobian = (2.0 * PI * PI * u[0] * u2theta(u[0]).sin()).max(1e-6) * 4.0 * cos;
                let density = warp.eval(u) / jacobian;
                if wo.z <= 0.0 || density <= 0.0 {
                    continue;
                }
                let weight = file.grids.ndf_at(u) / four_sigma / density;
                for (acc, sp) in sum.iter_mut().zip(&file.spectra[k]) {
                    *acc += bilinear(sp, SAMPLE_RES, SAMPLE_RES, s) * weight;
                }
            }
            sum.iter().map(|v| v / count).collect()
        })
        .collect()
}

/// Sub-cells per cell of the `spectra` nodes and side of the midpoint rule
/// of [`check`] ([`sample_space_reflectance`]): other points than the
/// writer's normalisation on [`BOX_SUBDIVISION`], so that the check reports
/// the rule's own error (the grooves' whole-circle file: up to 4.7e-4
/// relative, where Mitsuba's `sample` weights put it 8.9e-4 off; the
/// default scene: up to 5e-5) besides any change in the bytes read back.
pub const CHECK_SUBDIVISION: usize = 6;

/// Rings of [`reflectance`] when it cross-checks
/// [`sample_space_reflectance`] (cells of 0.5 degree: enough for a smooth
/// file, 1.2 % off for the grooves' facets).
pub const CHECK_RINGS: usize = 180;

/// Read `bytes` back and compare the reflectance of every incidence (and
/// light azimuth, in the order of [`BrdfTable::thetas_deg`]: angle, then
/// azimuth) and wavelength with the tables' (`[wavelength][incidence]`; a
/// monochrome table: one row, from the file's first wavelength).
///
/// # Errors
/// If the file does not read back.
pub fn check(
    tables: &BrdfTables,
    bytes: &[u8],
    file: &str,
) -> Result<Vec<Vec<super::resample::ReflectanceCheck>>, FormatError> {
    check_channels(&tables.tables().iter().collect::<Vec<_>>(), bytes, file)
}

/// [`check`] of a file with one channel per table of `channels` (an RGB
/// file: the tables of [`Rgl::rgb_from_spectral`]). Each light azimuth is
/// judged at the first `phi_i` node that holds it ([`Layout::of`]).
///
/// # Errors
/// If the file does not read back, or its `phi_i` nodes are not those of
/// the tables' azimuths.
pub fn check_channels(
    channels: &[&BrdfTable],
    bytes: &[u8],
    file: &str,
) -> Result<Vec<Vec<super::resample::ReflectanceCheck>>, FormatError> {
    let rgl = Rgl::parse(bytes, file)?;
    let error = |message: String| FormatError {
        file: file.into(),
        message,
    };
    let azimuths = channels[0].azimuths_deg();
    let layout = Layout::of(azimuths).map_err(|e| error(e.to_string()))?;
    let nodes: Vec<f64> = layout.nodes.iter().map(|n| n.phi_deg).collect();
    let in_file: Vec<f64> = rgl.phi_i.iter().map(|p| p.to_degrees()).collect();
    if nodes.len() != in_file.len()
        || nodes
            .iter()
            .zip(&in_file)
            .any(|(a, b)| (a - b).abs() > 1e-4)
    {
        return Err(error(format!(
            "phi_i {in_file:?} deg is not the layout {nodes:?} deg of the table's light azimuths"
        )));
    }
    let r = sample_space_reflectance(&rgl, CHECK_SUBDIVISION);
    let ni = rgl.theta_i.len();
    let several = azimuths.len() > 1;
    Ok(channels
        .iter()
        .enumerate()
        .map(|(w, table)| {
            let per_azimuth: Vec<BrdfTable> = if several {
                (0..azimuths.len()).map(|j| table.azimuth(j)).collect()
            } else {
                Vec::new()
            };
            table
                .angles_deg()
                .iter()
                .enumerate()
                .flat_map(|(k, &deg)| {
                    let (per_azimuth, layout, r) = (&per_azimuth, &layout, &r);
                    (0..azimuths.len()).map(move |j| {
                        let t = if several { &per_azimuth[j] } else { *table };
                        let p = layout
                            .nodes
                            .iter()
                            .position(|n| n.azimuth == j)
                            .expect("every azimuth has a node");
                        super::resample::ReflectanceCheck {
                            phi_i_deg: several.then_some(azimuths[j]),
                            ..super::resample::ReflectanceCheck::of_table(t, deg, r[p * ni + k][w])
                        }
                    })
                })
                .collect()
        })
        .collect())
}

/// The RGL format's entry of the registry
/// ([`BrdfFormat::Rgl`]): one file
/// of every wavelength (a monochrome table written grey; an RGB file of a
/// spectral run covering the visible with [`ExportInput::rgb`]) with the
/// NDF of the micro surface's realisations pooled ([`surface_ndf`]; none:
/// the uniform NDF, with a note), a note or a warning on the symmetry an
/// anisotropic file assumes, and read back per wavelength (or channel)
/// and incidence ([`check`]).
#[derive(Debug, Clone, Copy)]
pub struct RglFormat;

impl Exporter for RglFormat {
    fn name(&self) -> &'static str {
        "rgl"
    }

    fn file_name(&self) -> &'static str {
        ResultFile::Rgl.name()
    }

    fn file_kind(&self) -> FileKind {
        FileKind::Rgl
    }

    fn format(&self) -> BrdfFormat {
        BrdfFormat::Rgl
    }

    fn uses_surfaces(&self) -> bool {
        true
    }

    fn options(&self) -> &'static [&'static str] {
        &["--scene", "--rgb"]
    }

    fn check_run(&self, wavelengths_um: &[f64], azimuths_deg: &[f64]) -> Result<(), ExportError> {
        if azimuths_deg.len() > 1 {
            Layout::of(azimuths_deg).map_err(ExportError::RunAzimuths)?;
        }
        self.check_wavelengths(wavelengths_um)
            .map_err(|refusal| ExportError::Run {
                format: self.format(),
                refusal,
            })
    }

    fn table_bytes(
        &self,
        table: &BrdfTable,
        comment: &str,
        _grid: ZemaxGrid,
    ) -> Result<Vec<u8>, ExportError> {
        let tables = BrdfTables::Monochrome(table.clone());
        Rgl::from_tables(&tables, &Ndf::uniform(), comment)
            .map(|r| r.to_bytes())
            .map_err(|e| ExportError::Refused {
                option: "--format",
                format: self.format(),
                refusal: e.into(),
            })
    }

    fn build(&self, input: &ExportInput<'_>) -> Result<Export, ExportError> {
        let (tables, comment) = (input.tables, input.comment);
        let layout =
            Layout::of(tables.azimuths_deg()).map_err(|reason| ExportError::RglAzimuths {
                file: tables.tables()[0].file().to_owned(),
                option: input.option,
                reason,
            })?;
        let mut export = Export::default();
        export.notices.extend(symmetry_note(tables, &layout));
        let ndf = match input.surfaces {
            [_, ..] => surface_ndf(
                input.surfaces,
                smoothing_for(tables.tables()[0].bands()),
                !layout.is_isotropic(),
            ),
            [] => {
                export.notices.push(Notice::Note(
                    "rgl: no micro scene (--scene) for the NDF: the uniform NDF 1/pi is written; the file's values are the same, its importance sampling follows the table alone".into(),
                ));
                Ndf::uniform()
            }
        };
        let defect = |error| ExportError::Defect {
            format: self.format(),
            error,
        };
        let rgb_file = match tables.spectral().filter(|_| input.rgb) {
            Some(s) => Rgl::rgb_from_spectral(s, &ndf, comment).map_err(defect)?,
            None => None,
        };
        let bytes = match rgb_file {
            Some((file, _)) => file.to_bytes(),
            None => Rgl::from_tables(tables, &ndf, comment)
                .map_err(defect)?
                .to_bytes(),
        };
        export.files = vec![one_file(self.format(), bytes)];
        Ok(export)
    }

    fn judge(&self, input: &ExportInput<'_>, export: &mut Export) -> Result<(), ExportError> {
        let tables = input.tables;
        let name = self.file_name();
        let bytes = &export.files[0].bytes;
        // The channels of an RGB file: made when the tables cover the visible.
        let channels = tables
            .spectral()
            .filter(|_| input.rgb)
            .and_then(super::merl::srgb_tables);
        let checks = match &channels {
            Some(channels) => check_channels(&channels.iter().collect::<Vec<_>>(), bytes, name),
            None => check(tables, bytes, name),
        }
        .map_err(|error| ExportError::Unreadable {
            format: self.format(),
            error,
        })?;
        let remedy = fixed(format!(
            "the rgl grids are fixed ({SAMPLE_RES} x {SAMPLE_RES} samples per incidence); export zemax for a finer one"
        ));
        for (k, check) in checks.into_iter().enumerate() {
            let what = match (channels.is_some(), tables.wavelengths_um().get(k)) {
                (true, _) => format!("{} ({} channel)", self.name(), ["red", "green", "blue"][k]),
                (false, Some(w)) => format!("{} ({w} um)", self.name()),
                (false, None) => self.name().to_owned(),
            };
            export.add_judged(what, check, &remedy);
        }
        Ok(())
    }

    fn check_table(
        &self,
        table: &BrdfTable,
        bytes: &[u8],
    ) -> Result<Vec<super::resample::ReflectanceCheck>, FormatError> {
        let checks = check(
            &BrdfTables::Monochrome(table.clone()),
            bytes,
            self.file_name(),
        )?;
        Ok(checks.into_iter().next().unwrap_or_default())
    }
}

/// The symmetry an anisotropic RGL file of `tables` assumes ([`layout`]),
/// judged from the table: a note naming the assumption, or a warning when
/// the table contradicts it beyond its 4-sigma bound
/// ([`layout::symmetry_figure`]); `None` for a file that assumes nothing.
fn symmetry_note(tables: &BrdfTables, layout: &Layout) -> Option<Notice> {
    use layout::{Reduction, symmetry_figure};
    let assumed = match layout.reduction {
        Reduction::Isotropic | Reduction::Circle => return None,
        Reduction::HalfTurn => {
            "a half turn leaves the surface unchanged (the table at 180 deg is the one at 0 turned)"
        }
        Reduction::Quadrant => {
            "the surface is mirror symmetric about the xz and yz planes (the table at 0 deg symmetric about the plane of incidence, the one at 90 deg too)"
        }
    };
    let tables: Vec<&BrdfTable> = tables.tables().iter().collect();
    let figure = symmetry_figure(&tables, layout.reduction);
    let judged = format!(
        "chi^2/dof = {:.3} over {} cell pairs, bound {:.3}",
        figure.chi2_dof, figure.dof, figure.bound
    );
    Some(if figure.dof > 0 && !figure.isotropic() {
        Notice::Warning(format!(
            "rgl: the file assumes {assumed}, but the table departs from it: {judged}; trace the whole circle (0 and 180 among light.phi_deg, azimuths beyond 180) for a file that assumes nothing"
        ))
    } else {
        Notice::Note(format!(
            "rgl: the file assumes {assumed}; the table agrees ({judged})"
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::brdf_table::BrdfTable;

    /// A mesh of one tilted square: all normals at `theta`.
    fn tilted(theta: f64) -> Mesh {
        let z = theta.tan() as f32;
        Mesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, z],
                [1.0, 1.0, z],
                [0.0, 1.0, 0.0],
            ],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// The index of the largest of `values`.
    fn peak_node(values: &[f64]) -> usize {
        (0..values.len())
            .max_by(|&a, &b| values[a].total_cmp(&values[b]))
            .unwrap()
    }

    /// The tabulated NDF is normalised (∫ D cos dω = 1) and puts the
    /// facets' weight at their angle: a surface of 30-degree facets has its
    /// peak at the node nearest 30 degrees.
    #[test]
    fn ndf_of_facets_is_normalised_and_peaks_at_their_angle() {
        let ndf = Ndf::from_mesh(&[tilted(30f64.to_radians())], 0.02);
        let cos = tent_integrals(NDF_RES, f64::cos);
        let total: f64 = ndf.values.iter().zip(&cos).map(|(v, c)| v * c).sum();
        assert!((total - 1.0).abs() < 1e-8, "{total}");
        let peak = peak_node(&ndf.values);
        let u = theta2u(30f64.to_radians()) * (NDF_RES - 1) as f64;
        assert!((peak as f64 - u).abs() <= 1.0, "{peak} vs {u}");
        // sigma(0) of a normalised NDF is 1 (∫ D cos dω), and sigma grows
        // as 1/cos for a flat-ish surface seen obliquely: here only check
        // the exact identity at normal incidence.
        let s0 = ndf.projected_area(0.0);
        assert!((s0 - 1.0).abs() < 2e-3, "{s0}");
        // ∫ D (wi.m) dω = cos(theta_i) for a normalised isotropic NDF, so
        // sigma (which drops the negative part) is at least that.
        for t in [0.3, 0.8, 1.2] {
            assert!(ndf.projected_area(t) >= t.cos() - 2e-3, "{t}");
        }
    }

    /// The NDF of several realisations pools their facets: a flat square
    /// and one tilted 30 degrees give an NDF with weight at both angles
    /// (each alone at one only, the other at the uniform floor of
    /// [`DIFFUSE_SHARE`]), isotropic and anisotropic alike.
    #[test]
    fn ndf_pools_every_realisation() {
        let node = |deg: f64| (theta2u(deg.to_radians()) * (NDF_RES - 1) as f64).round() as usize;
        let floor = DIFFUSE_SHARE / PI;
        let (flat, tilt) = (tilted(0.0), tilted(30f64.to_radians()));
        let iso = |meshes: &[Mesh]| Ndf::from_mesh(meshes, 0.05).values;
        let both = iso(&[flat.clone(), tilt.clone()]);
        assert!(both[node(0.0)] > 10.0 * floor && both[node(30.0)] > 10.0 * floor);
        assert!(iso(&[flat.clone()])[node(30.0)] < 1.01 * floor);
        assert!(iso(&[tilt.clone()])[node(0.0)] < 1.01 * floor);
        let aniso = Ndf::from_mesh_anisotropic(&[flat, tilt], 0.05);
        let row = |phi_deg: f64| {
            (phi2u(phi_deg.to_radians()) * (NDF_PHI_RES - 1) as f64).round() as usize
        };
        assert!(aniso.values[row(0.0) * NDF_RES + node(0.0)] > 10.0 * floor);
        assert!(aniso.values[row(180.0) * NDF_RES + node(30.0)] > 10.0 * floor);
    }

    /// The anisotropic NDF of a plane tilted 30 degrees about y (normals at
    /// theta 30, azimuth 180) is normalised for the bilinear interpolation
    /// of its nodes (∫ D cos dω = 1 by the midpoint rule on 512² cells of
    /// the `u` square, to 2e-3), peaks at the node nearest (30, 180) and
    /// is the uniform share alone a quarter turn away. An azimuth-averaged
    /// NDF (the isotropic kernel) would be equal at 0 and 180.
    #[test]
    fn anisotropic_ndf_keeps_the_azimuth() {
        let ndf = Ndf::from_mesh_anisotropic(&[tilted(30f64.to_radians())], 0.05);
        assert_eq!(ndf.rows, NDF_PHI_RES);
        let n = 512;
        let total: f64 = midpoints(n)
            .map(|u| {
                let jac = 2.0 * PI * PI * u[0] * u2theta(u[0]).sin();
                bilinear(&ndf.values, NDF_RES, NDF_PHI_RES, u) * u2theta(u[0]).cos() * jac
            })
            .sum::<f64>()
            / (n * n) as f64;
        assert!((total - 1.0).abs() < 2e-3, "{total}");
        let at = |ndf: &Ndf, theta_deg: f64, phi_deg: f64| {
            bilinear(
                &ndf.values,
                NDF_RES,
                NDF_PHI_RES,
                [theta2u(theta_deg.to_radians()), phi2u(phi_deg.to_radians())],
            )
        };
        let peak = peak_node(&ndf.values);
        let (row, col) = (peak / NDF_RES, peak % NDF_RES);
        let u = theta2u(30f64.to_radians()) * (NDF_RES - 1) as f64;
        assert!((col as f64 - u).abs() <= 1.0, "{col} vs {u}");
        assert!(row == 0 || row == NDF_PHI_RES - 1, "row {row}");
        let floor = DIFFUSE_SHARE / PI;
        assert!((at(&ndf, 30.0, 90.0) / floor - 1.0).abs() < 1e-6);
        assert!(at(&ndf, 30.0, 180.0) > 100.0 * at(&ndf, 30.0, 0.0));
    }

    /// `bessel_i0e` against I0 from its power series `sum (x/2)^2k / k!²`
    /// (to 1e-6 relative, the stated accuracy of the approximation).
    #[test]
    fn bessel_i0e_matches_the_series() {
        for x in [0.0f64, 0.5, 2.0, 3.7, 3.8, 10.0, 50.0] {
            let (mut term, mut sum) = (1.0f64, 1.0f64);
            for k in 1..400 {
                term *= (x / 2.0).powi(2) / f64::from(k * k);
                sum += term;
            }
            let want = sum * (-x).exp();
            assert!((bessel_i0e(x) / want - 1.0).abs() < 1e-6, "{x}");
        }
    }

    /// The NDF of a flat mirror (all normals up) is the kernel itself,
    /// smooth between the nodes: from one node to the next it changes by
    /// less than a factor 2 wherever it holds more than 1e-3 of its peak
    /// (the factor the renderer's interpolation of the NDF ratio can
    /// follow), and it falls by half near `smoothing * sqrt(2 ln 2)`.
    #[test]
    fn ndf_of_a_mirror_is_smooth() {
        let smoothing = smoothing_for(32);
        let ndf = Ndf::from_mesh(&[tilted(0.0)], smoothing);
        let peak = ndf.values[0];
        for w in ndf.values.windows(2) {
            if w[0] > 1e-3 * peak {
                assert!(w[1] / w[0] > 0.5 && w[1] / w[0] <= 1.0 + 1e-12, "{w:?}");
            }
        }
        let half = (0..NDF_RES)
            .map(|k| u2theta(k as f64 / (NDF_RES - 1) as f64))
            .find(|&t| ndf.at(theta2u(t)) - DIFFUSE_SHARE / PI < 0.5 * (peak - DIFFUSE_SHARE / PI))
            .unwrap();
        let want = smoothing * (2.0 * 2f64.ln()).sqrt();
        assert!((half / want - 1.0).abs() < 0.15, "{half} vs {want}");
    }

    /// `luminance` is 0 exactly at the nodes where `spectra` is 0 at every
    /// wavelength (below the horizon of a Lambertian table: some at every
    /// incidence) and at least 10⁻³ of its largest value elsewhere, so that
    /// no sample lands where f = 0 and none is nearly impossible where f > 0.
    #[test]
    fn luminance_is_zero_exactly_where_spectra_are() {
        let grid = crate::tally::carlson::CarlsonGrid::new(8).unwrap();
        let fr: Vec<f64> = (0..grid.n_cells())
            .map(|flat| {
                let (band, cell) = grid.band_cell(flat);
                0.5 * grid.projected_solid_angle(band, cell) / PI
            })
            .collect();
        let blocks = [0.0, 70.0]
            .iter()
            .map(|&t| (t, 0.0, fr.clone(), vec![1e-4; fr.len()]))
            .collect();
        let table = BrdfTable::from_blocks(grid, blocks, "lambert").unwrap();
        let file =
            Rgl::from_tables(&BrdfTables::Monochrome(table), &Ndf::uniform(), "lambert").unwrap();
        for k in 0..2 {
            let lum = file.luminance(k);
            let max = lum.iter().copied().fold(0.0, f64::max);
            let mut zeros = 0;
            for (i, &l) in lum.iter().enumerate() {
                if file.spectra[k].iter().all(|s| s[i] == 0.0) {
                    assert_eq!(l, 0.0, "{k} {i}");
                    zeros += 1;
                } else {
                    assert!(l >= 1e-3 * max / (1.0 + 1e-3), "{k} {i}: {l}");
                }
            }
            assert!(zeros > 0, "{k}");
        }
    }

    /// A Lambertian table (f = rho / pi) written and read back evaluates
    /// to rho cos(theta_o) / pi everywhere (to the f32 rounding and the
    /// piecewise-linear interpolation of the NDF ratio), and its
    /// reflectance is rho.
    #[test]
    fn lambertian_round_trip() {
        let grid = crate::tally::carlson::CarlsonGrid::new(16).unwrap();
        let rho = 0.6;
        let fr: Vec<f64> = (0..grid.n_cells())
            .map(|flat| {
                let (band, cell) = grid.band_cell(flat);
                rho * grid.projected_solid_angle(band, cell) / PI
            })
            .collect();
        let blocks = [0.0, 40.0, 70.0]
            .iter()
            .map(|&t| (t, 0.0, fr.clone(), vec![1e-4; fr.len()]))
            .collect();
        let table = BrdfTable::from_blocks(grid, blocks, "lambert").unwrap();
        let tables = BrdfTables::Monochrome(table);
        let ndf = Ndf::uniform();
        let bytes = Rgl::from_tables(&tables, &ndf, "lambert")
            .unwrap()
            .to_bytes();
        let back = Rgl::parse(&bytes, "lambert.bsdf").unwrap();
        assert_eq!(back.description, "lambert");
        assert_eq!(back.wavelengths_nm, GREY_NM);
        for k in 0..3 {
            for wo in [
                DVec3::new(0.3, 0.1, 0.9).normalize(),
                DVec3::new(-0.7, -0.2, 0.5).normalize(),
            ] {
                let v = back.eval_cos(k, wo);
                let want = rho / PI * wo.z;
                assert!(
                    (v[0] / want - 1.0).abs() < 0.02,
                    "{k} {wo}: {v:?} vs {want}"
                );
                assert_eq!(v[0], v[1], "grey");
            }
        }
        let checks = check(&tables, &bytes, "lambert.bsdf").unwrap();
        for c in &checks[0] {
            assert!((c.file / rho - 1.0).abs() < 0.01, "{c:?}");
        }
        // The writer normalises by the integral over the sample square; the
        // midpoint rule on cells of equal solid angle is an independent
        // quadrature of the same file (no warp, no Jacobian): for this
        // smooth BRDF both are rho within the rule's error.
        for (k, r) in reflectance(&back, CHECK_RINGS).iter().enumerate() {
            assert!((r[0] / rho - 1.0).abs() < 2e-3, "{k}: {r:?} vs {rho}");
        }
    }

    /// The integrand at the fine points, 0 but at one point: a peak
    /// narrower than the node spacing.
    fn spike(at: usize) -> Vec<f64> {
        let n = fine_points().count();
        (0..n)
            .map(|k| if k == at { n as f64 } else { 0.0 })
            .collect()
    }

    /// The integral over the unit square of the bilinear interpolation of
    /// node values, by the exact rule for tents (a node's tent integrates
    /// to the area of its cells' quarters).
    fn integral_of_interpolation(values: &[f64]) -> f64 {
        let (r, h) = (SAMPLE_RES, 1.0 / (SAMPLE_RES - 1) as f64);
        values
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let edge = |i: usize| if i == 0 || i == r - 1 { 0.5 } else { 1.0 };
                v * edge(k % r) * edge(k / r) * h * h
            })
            .sum()
    }

    #[test]
    fn box_average_keeps_a_peak_between_the_nodes() {
        let n = (SAMPLE_RES - 1) * BOX_SUBDIVISION;
        // A point between nodes (10, 20) and (11, 21), nearest the first,
        // and one in the corner sub-cell of the square.
        for (x, y) in [(10 * BOX_SUBDIVISION + 1, 20 * BOX_SUBDIVISION), (0, 0)] {
            let g = spike(y * n + x);
            let mean: f64 = g.iter().sum::<f64>() / g.len() as f64;
            let nodes = box_average(g.into_iter());
            // Energy: the interpolation integrates to the integrand's mean
            // (1), whereas values at the nodes alone would give 0.
            let got = integral_of_interpolation(&nodes);
            assert!((got - mean).abs() < 1e-12, "({x}, {y}): {got} vs {mean}");
            // Place: all of it on the node nearest the point.
            let lit: Vec<usize> = (0..nodes.len()).filter(|&k| nodes[k] > 0.0).collect();
            let node = |i: usize| {
                let c = (i as f64 + 0.5) / n as f64;
                (c * (SAMPLE_RES - 1) as f64).round() as usize
            };
            let nearest = node(y) * SAMPLE_RES + node(x);
            assert_eq!(lit, vec![nearest], "({x}, {y})");
        }
    }
}
