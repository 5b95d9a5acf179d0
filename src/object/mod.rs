//! The macro level: a 3-D object made of cells (zones) bounded by quadrics.
//!
//! Cells are regions over named quadric surfaces (the same kernel and region
//! syntax as the micro level). A cell's fill is `void` (photons fly through
//! it) or `solid` (photons reflect where they would enter it). Space outside
//! every cell is open void; a photon that meets no solid escapes to infinity.
//! The surface a photon crosses into a solid names its wall, whose model
//! ([`wall::WallModel`]) decides the reflection: a descent into a micro
//! geometry (ROKS-RG), a tabulated BRDF, ideal specular/diffuse, or Fresnel.

pub mod source;
pub mod wall;

use glam::DVec3;

use crate::geometry::body::{Body, Ray};

/// A solid cell: where photons reflect.
#[derive(Clone, Debug)]
pub struct SolidCell {
    /// Cell name (from the scene).
    pub name: String,
    /// The solid.
    pub body: Body,
    /// Global surface index of each of the body's surfaces.
    pub surface_ids: Vec<usize>,
}

/// A void cell (kept to check that photon positions are covered once).
#[derive(Clone, Debug)]
pub struct VoidCell {
    /// Cell name (from the scene).
    pub name: String,
    /// Where the cell is.
    pub body: Body,
}

/// Where a flight enters a solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) direction.
    pub t: f64,
    /// Index into [`Object::solids`].
    pub cell: usize,
    /// Index into that cell's surfaces.
    pub surface: usize,
}

/// The geometry of a 3-D object.
#[derive(Clone, Debug)]
pub struct Object {
    /// Names of the scene's quadrics; a surface id indexes this list.
    pub surface_names: Vec<String>,
    /// Solid cells.
    pub solids: Vec<SolidCell>,
    /// Void cells.
    pub voids: Vec<VoidCell>,
}

impl Object {
    /// The nearest entry into any solid of the flight from `o` along unit
    /// `d`, or `None` if it escapes. `standing`: `(cell, surface)` it starts on.
    #[must_use]
    pub fn next_hit(&self, o: DVec3, d: DVec3, standing: Option<(usize, usize)>) -> Option<Hit> {
        let ray = Ray::new(o, d);
        let mut best: Option<Hit> = None;
        let mut t_max = f64::INFINITY;
        for (cell, solid) in self.solids.iter().enumerate() {
            let on = standing.and_then(|(c, s)| (c == cell).then_some(s));
            if let Some(e) = solid.body.first_entry(&ray, t_max, on) {
                t_max = e.t;
                best = Some(Hit {
                    t: e.t,
                    cell,
                    surface: e.surface,
                });
            }
        }
        best
    }

    /// The solid and void cells containing `p` (for checks of photon positions).
    #[must_use]
    pub fn cells_at(&self, p: DVec3) -> (Vec<usize>, Vec<usize>) {
        let solids = (0..self.solids.len())
            .filter(|&i| self.solids[i].body.contains(p))
            .collect();
        let voids = (0..self.voids.len())
            .filter(|&i| self.voids[i].body.contains(p))
            .collect();
        (solids, voids)
    }

    /// Global surface id of surface `surface` of solid `cell`.
    #[must_use]
    pub fn surface_id(&self, cell: usize, surface: usize) -> usize {
        self.solids[cell].surface_ids[surface]
    }
}
