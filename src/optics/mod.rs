//! Geometric-optics building blocks: Fresnel reflectance of smooth
//! interfaces, per-facet reflectance models of materials, BRDF tables,
//! polarisation, measured spectra (`spectrum`) and colour (`colour`).
//!
//! All quantities are dimensionless `f64` unless stated otherwise; angles
//! are given either as cosines (dimensionless) or in degrees where the name
//! says so.

pub mod brdf_table;
pub mod colour;
pub mod fresnel;
pub mod material;
pub mod polarisation;
pub mod spectrum;

pub use fresnel::{fresnel_sp, fresnel_unpolarised};
pub use material::{AngleTable, AngleTableError, Reflectance, ReflectanceError};
