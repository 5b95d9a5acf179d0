//! The `phi_i` axis of an RGL file: how the light azimuths of a roks table
//! map onto the azimuth domains that Mitsuba 3's `measured` plugin (and
//! pbrt-v4's `MeasuredBxDF`) read.
//!
//! The reader treats a file of at most two `phi_i` nodes as isotropic;
//! otherwise it takes the azimuth of the light `phi_i = atan2(wi.y, wi.x)`
//! (in `[-180, 180]` degrees) as a parameter, interpolated linearly between
//! the nodes (clamped outside them), and
//! `reduction = rint(360 / (phi_last - phi_first))`. Mitsuba 3 also reads reductions 2 (a half turn of `wi`
//! and `wo` when `wi.y >= 0`) and 4 (mirrors when `wi.x >= 0` and
//! `wi.y >= 0`); pbrt-v4 refuses any reduction but 1 ("reduction N (!= 1) not
//! supported"). So roks writes every anisotropic file over the whole
//! circle, nodes from -180 to 180 degrees (reduction 1), and fills the
//! part of the circle a run did not trace from the symmetry the run's set
//! of azimuths implies ([`Layout::of`]):
//!
//! * one azimuth: the isotropic file (`phi_i = [0]`, outgoing azimuths
//!   relative to the light's);
//! * the whole circle, 0 and 180 among the azimuths and not all of them
//!   in `[0, 180]` (or exactly `{0, 180}`): node `a` at `a` (`a - 360`
//!   above 180), the 180 block at both -180 and 180; no symmetry assumed;
//! * 0 to 180 (first 0, last 180, at least three azimuths): node `a` holds
//!   azimuth `a`, node `a - 180` (for `a < 180`) azimuth `a` turned by a
//!   half turn ([`Symmetry::HalfTurn`]). The surface is assumed unchanged
//!   by a half turn;
//! * 0 to 90 (first 0, last 90, at least three): node `a` holds azimuth
//!   `a`; `180 - a` its mirror image about the yz plane
//!   ([`Symmetry::MirrorX`]), `-a` about the xz plane
//!   ([`Symmetry::MirrorY`]), `a - 180` its half turn (both mirrors). The
//!   surface is assumed mirror symmetric about the xz and the yz planes.
//!
//! Every other set is refused ([`ACCEPTED`] says what is accepted).
//! [`symmetry_figure`] judges a table against the symmetry its layout
//! assumes.

use crate::optics::brdf_table::BrdfTable;
use crate::tally::anisotropy::{Figure, Table, compare};

/// Which light azimuths the run traced, and so which symmetry fills the
/// rest of the circle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reduction {
    /// One light azimuth: an isotropic file.
    Isotropic,
    /// The whole circle: no symmetry assumed.
    Circle,
    /// 0 to 180 degrees: a half turn assumed to leave the surface
    /// unchanged.
    HalfTurn,
    /// 0 to 90 degrees: mirror symmetry about the xz and yz planes
    /// assumed.
    Quadrant,
}

/// How a file node's data come from the run's table at its azimuth: an
/// isometry of the sample frame (each is its own inverse), applied to the
/// light and to the outgoing direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// The table itself.
    Identity,
    /// A half turn about the normal: `(x, y) -> (-x, -y)`.
    HalfTurn,
    /// The mirror about the yz plane: `x -> -x` (azimuth `a -> 180 - a`).
    MirrorX,
    /// The mirror about the xz plane: `y -> -y` (azimuth `a -> -a`).
    MirrorY,
}

impl Symmetry {
    /// The direction `d` (sample frame) moved by this isometry.
    #[must_use]
    pub fn apply(self, d: glam::DVec3) -> glam::DVec3 {
        match self {
            Self::Identity => d,
            Self::HalfTurn => glam::DVec3::new(-d.x, -d.y, d.z),
            Self::MirrorX => glam::DVec3::new(-d.x, d.y, d.z),
            Self::MirrorY => glam::DVec3::new(d.x, -d.y, d.z),
        }
    }
}

/// Light azimuths that no RGL file holds ([`Layout::of`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayoutError {
    /// An azimuth outside `[0, 360)` (degrees).
    #[error("the light azimuths {} deg are not all in [0, 360); {ACCEPTED}", listed(.0))]
    OutOfRange(Vec<f64>),
    /// A set that fills no domain (degrees, ascending).
    #[error("the light azimuths {} deg fill none of the azimuth domains of the RGL format; {ACCEPTED}", listed(.0))]
    NoDomain(Vec<f64>),
}

fn listed(azimuths_deg: &[f64]) -> String {
    azimuths_deg
        .iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One node of the file's `phi_i` axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    /// The file's `phi_i` (degrees, in `[-180, 180]`).
    pub phi_deg: f64,
    /// The index of the table's light azimuth whose data it holds (in
    /// [`crate::optics::brdf_table::BrdfTable::azimuths_deg`], ascending).
    pub azimuth: usize,
    /// How: the node's light and outgoing directions are those of the
    /// table's azimuth moved by this isometry.
    pub symmetry: Symmetry,
}

/// The `phi_i` axis of a file: its nodes, ascending.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The reader's domain.
    pub reduction: Reduction,
    /// The nodes, `phi_deg` ascending.
    pub nodes: Vec<Node>,
}

/// The light-azimuth sets an RGL file can hold (for the refusal of others).
pub const ACCEPTED: &str = "an RGL file holds one light azimuth (isotropic), or the whole circle (0 and 180 among azimuths in [0, 360); no symmetry assumed), or 0 to 180 (first 0, last 180, at least three; a half turn assumed to leave the surface unchanged), or 0 to 90 (first 0, last 90, at least three; mirror symmetry about the xz and yz planes assumed)";

impl Layout {
    /// The layout of a table's light azimuths `azimuths_deg` (degrees, each
    /// in `[0, 360)`, ascending as [`crate::optics::brdf_table::BrdfTable::azimuths_deg`]
    /// gives them; sorted here anyway).
    ///
    /// # Errors
    /// A set that fills none of the domains: the reason, one line, with
    /// [`ACCEPTED`].
    pub fn of(azimuths_deg: &[f64]) -> Result<Self, LayoutError> {
        let mut a = azimuths_deg.to_vec();
        a.sort_by(f64::total_cmp);
        let node = |phi_deg: f64, azimuth: usize, symmetry: Symmetry| Node {
            phi_deg,
            azimuth,
            symmetry,
        };
        if a.len() <= 1 {
            return Ok(Self {
                reduction: Reduction::Isotropic,
                nodes: vec![node(0.0, 0, Symmetry::Identity)],
            });
        }
        if a.iter().any(|x| !(0.0..360.0).contains(x)) {
            return Err(LayoutError::OutOfRange(a));
        }
        let has = |x: f64| a.contains(&x);
        let last = a[a.len() - 1];
        let direct = (0..a.len()).map(|k| {
            let phi = if a[k] > 180.0 { a[k] - 360.0 } else { a[k] };
            node(phi, k, Symmetry::Identity)
        });
        let (reduction, mut nodes): (Reduction, Vec<Node>) =
            if has(0.0) && last == 180.0 && a.len() >= 3 {
                let turned = (0..a.len() - 1).map(|k| node(a[k] - 180.0, k, Symmetry::HalfTurn));
                (Reduction::HalfTurn, direct.chain(turned).collect())
            } else if has(0.0) && last == 90.0 && a.len() >= 3 {
                let n = a.len();
                let mirror_x = (0..n - 1).map(|k| node(180.0 - a[k], k, Symmetry::MirrorX));
                let mirror_y = (1..n).map(|k| node(-a[k], k, Symmetry::MirrorY));
                let turned = (0..n - 1).map(|k| node(a[k] - 180.0, k, Symmetry::HalfTurn));
                let all = direct.chain(mirror_x).chain(mirror_y).chain(turned);
                (Reduction::Quadrant, all.collect())
            } else if has(0.0) && has(180.0) {
                let half = a.iter().position(|&x| x == 180.0).expect("has 180");
                let wrapped = std::iter::once(node(-180.0, half, Symmetry::Identity));
                (Reduction::Circle, direct.chain(wrapped).collect())
            } else {
                return Err(LayoutError::NoDomain(a));
            };
        nodes.sort_by(|p, q| p.phi_deg.total_cmp(&q.phi_deg));
        Ok(Self { reduction, nodes })
    }

    /// Whether the file is isotropic (one `phi_i` node).
    #[must_use]
    pub fn is_isotropic(&self) -> bool {
        self.reduction == Reduction::Isotropic
    }

    /// The reader's `reduction` of this layout's `phi_i` nodes, as Mitsuba 3
    /// and pbrt-v4 compute it: `rint(360 / (last - first))` (0 for an
    /// isotropic file; 1, the whole circle, for every other).
    #[must_use]
    pub fn reduction_factor(&self) -> u32 {
        let (first, last) = (
            self.nodes[0].phi_deg,
            self.nodes[self.nodes.len() - 1].phi_deg,
        );
        if self.nodes.len() <= 2 {
            0
        } else {
            (360.0 / (last - first)).round() as u32
        }
    }
}

/// How far the tables `tables` (one per channel, several light azimuths)
/// depart from the symmetry a file of `reduction` assumes, over every
/// angle and channel, as the anisotropy figure of `summary.json`
/// ([`crate::tally::anisotropy`]: `chi² = Σ (f_a − f_b)² / (s_a² + s_b²)`
/// over the cell pairs with `s_a² + s_b² > 0`, bound `1 + 4 sqrt(2/dof)`):
///
/// * half turn: the table at 0 degrees against the one at 180 turned by a
///   half turn ([`crate::tally::anisotropy::compare`], the pair (0, 180) of
///   the figure `summary.json` states);
/// * quadrant: the table at 0 degrees against its own mirror image about
///   the xz plane (`y -> -y`, which keeps its light), and the table at 90
///   degrees against its mirror image about the yz plane (`x -> -x`),
///   each pair of mirror cells once (a cell on the plane is its own image
///   and not counted);
/// * otherwise no assumption: a figure of no cell.
#[must_use]
pub fn symmetry_figure(tables: &[&BrdfTable], reduction: Reduction) -> Figure {
    let (mut chi2, mut dof) = (0.0, 0);
    for table in tables {
        let az = table.azimuths_deg();
        let n = az.len();
        let grid = table.grid();
        let find = |x: f64| az.iter().position(|&a| a == x);
        let angles = table.thetas_deg().len() / n.max(1);
        for t in 0..angles {
            let at = |k: usize| Table {
                phi_deg: az[k],
                fraction: table.fractions(t * n + k),
                stderr: table.fraction_stderrs(t * n + k),
            };
            match (reduction, find(0.0), find(180.0), find(90.0)) {
                (Reduction::HalfTurn, Some(a), Some(b), _) => {
                    let f = compare(grid, &at(a), &at(b));
                    chi2 += f.chi2;
                    dof += f.dof;
                }
                (Reduction::Quadrant, Some(a), _, Some(b)) => {
                    // Cell k of band j (centre at k 90/j degrees) mirrors
                    // to 4j - k about the xz plane, to 2j - k about yz.
                    for (k, turns) in [(a, 4), (b, 2)] {
                        let x = at(k);
                        for j in 1..=grid.bands() {
                            let cells = 4 * j;
                            for c in 0..cells {
                                let m = (turns * j + cells - c) % cells;
                                if m <= c {
                                    continue;
                                }
                                let (p, q) = (grid.index(j, c), grid.index(j, m));
                                let var = x.stderr[p].powi(2) + x.stderr[q].powi(2);
                                if var > 0.0 {
                                    chi2 += (x.fraction[p] - x.fraction[q]).powi(2) / var;
                                    dof += 1;
                                }
                            }
                        }
                    }
                }
                _ => {}
            }
        }
    }
    Figure::new(chi2, dof)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phis(l: &Layout) -> Vec<(f64, usize, Symmetry)> {
        l.nodes
            .iter()
            .map(|n| (n.phi_deg, n.azimuth, n.symmetry))
            .collect()
    }

    /// The accepted sets give files over the whole circle (reduction 1 by
    /// the reader's formula, the only one pbrt-v4 reads), with the data of
    /// each node from the azimuth and isometry stated in the module
    /// documentation; each isometry takes the run's light azimuth onto the
    /// node's.
    #[test]
    fn accepted_sets_fill_the_whole_circle() {
        use Symmetry::{HalfTurn as H, Identity as I, MirrorX as X, MirrorY as Y};
        let l = Layout::of(&[30.0]).unwrap();
        assert_eq!(
            (l.reduction, phis(&l)),
            (Reduction::Isotropic, vec![(0.0, 0, I)])
        );
        assert_eq!(l.reduction_factor(), 0);

        let l = Layout::of(&[0.0, 90.0, 180.0, 270.0]).unwrap();
        assert_eq!(l.reduction, Reduction::Circle);
        assert_eq!(
            phis(&l),
            vec![
                (-180.0, 2, I),
                (-90.0, 3, I),
                (0.0, 0, I),
                (90.0, 1, I),
                (180.0, 2, I)
            ]
        );
        let l = Layout::of(&[0.0, 180.0]).unwrap();
        assert_eq!(phis(&l), vec![(-180.0, 1, I), (0.0, 0, I), (180.0, 1, I)]);

        let l = Layout::of(&[0.0, 45.0, 90.0, 135.0, 180.0]).unwrap();
        assert_eq!(l.reduction, Reduction::HalfTurn);
        assert_eq!(
            phis(&l),
            vec![
                (-180.0, 0, H),
                (-135.0, 1, H),
                (-90.0, 2, H),
                (-45.0, 3, H),
                (0.0, 0, I),
                (45.0, 1, I),
                (90.0, 2, I),
                (135.0, 3, I),
                (180.0, 4, I)
            ]
        );

        let l = Layout::of(&[90.0, 0.0, 45.0]).unwrap();
        assert_eq!(l.reduction, Reduction::Quadrant);
        assert_eq!(
            phis(&l),
            vec![
                (-180.0, 0, H),
                (-135.0, 1, H),
                (-90.0, 2, Y),
                (-45.0, 1, Y),
                (0.0, 0, I),
                (45.0, 1, I),
                (90.0, 2, I),
                (135.0, 1, X),
                (180.0, 0, X)
            ]
        );
        for set in [
            &[0.0, 90.0, 180.0, 270.0][..],
            &[0.0, 45.0, 90.0, 135.0, 180.0],
            &[0.0, 45.0, 90.0],
        ] {
            let l = Layout::of(set).unwrap();
            assert_eq!(l.reduction_factor(), 1, "{set:?}");
            for n in &l.nodes {
                let a = set[n.azimuth].to_radians();
                let moved = n.symmetry.apply(glam::DVec3::new(a.cos(), a.sin(), 0.0));
                let node = n.phi_deg.to_radians();
                assert!(
                    (moved - glam::DVec3::new(node.cos(), node.sin(), 0.0)).length() < 1e-12,
                    "{set:?} {n:?}"
                );
            }
        }
    }

    /// Sets that fill no domain are refused with the list of what is
    /// accepted: no 0, no 180 nor 90 at the end, two azimuths of a half
    /// turn or a quadrant (the reader would take two nodes as isotropic).
    #[test]
    fn other_sets_are_refused() {
        for set in [
            &[0.0, 90.0][..],
            &[0.0, 45.0],
            &[30.0, 120.0, 210.0],
            &[0.0, 45.0, 135.0],
            &[0.0, 90.0, 270.0],
            &[10.0, 180.0, 300.0],
        ] {
            let e = Layout::of(set).unwrap_err().to_string();
            assert!(e.contains(ACCEPTED), "{set:?}: {e}");
        }
    }
}
