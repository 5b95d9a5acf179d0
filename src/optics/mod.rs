//! Geometric-optics building blocks: Fresnel reflectance of smooth
//! interfaces and per-facet reflectance models of materials.
//!
//! All quantities are dimensionless `f64` unless stated otherwise; angles
//! are given either as cosines (dimensionless) or in degrees where the name
//! says so.

pub mod brdf_table;
pub mod fresnel;
pub mod material;
pub mod polarisation;
pub mod spectrum;

pub use fresnel::{fresnel_sp, fresnel_unpolarised};
pub use material::{AngleTable, Reflectance, ReflectanceError, TableError};
