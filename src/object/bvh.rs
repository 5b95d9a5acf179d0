//! A bounding-volume hierarchy over the boxes of an object's bounded solid
//! zones: a binary tree of axis-aligned boxes, split at the median of the
//! zones' box centres along the axis where they spread most, with at most
//! `LEAF_SIZE` (2) zones per leaf. Flights visit it nearest box first and skip
//! every box that starts beyond the best distance found so far.

use crate::geometry::body::{Aabb, Ray};

/// Most zones in a leaf.
const LEAF_SIZE: usize = 2;

/// Deepest tree the traversal stack holds: a median split halves the zones
/// at each level, so 64 levels hold any number of zones.
const MAX_DEPTH: usize = 64;

/// One node: a leaf (`count > 0`: items `items[first..first + count]`) or
/// an inner node (`count == 0`: children `first` and `first + 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    bounds: Aabb,
    first: u32,
    count: u32,
}

/// The hierarchy over items `0..n` given by their boxes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    /// Nodes, the root first (empty: no items).
    nodes: Vec<Node>,
    /// Item indices, in leaf order.
    items: Vec<u32>,
}

impl Bvh {
    /// The hierarchy over `boxes`: `(item, box)` pairs (finite boxes).
    #[must_use]
    pub fn new(boxes: &[(usize, Aabb)]) -> Self {
        let mut bvh = Self::default();
        if boxes.is_empty() {
            return bvh;
        }
        let mut work: Vec<(u32, Aabb)> = boxes
            .iter()
            .map(|&(i, b)| (u32::try_from(i).expect("fewer than 2^32 zones"), b))
            .collect();
        bvh.nodes.push(hull(&work));
        bvh.split(0, &mut work);
        bvh
    }

    /// Fill node `at` (whose box is set) with `work`.
    fn split(&mut self, at: usize, work: &mut [(u32, Aabb)]) {
        if work.len() <= LEAF_SIZE {
            self.nodes[at].first = self.items.len() as u32;
            self.nodes[at].count = work.len() as u32;
            self.items.extend(work.iter().map(|w| w.0));
            return;
        }
        let centre = |b: &Aabb| (b.min + b.max) * 0.5;
        let (lo, hi) = work.iter().fold(
            (glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY),
            |(lo, hi), (_, b)| (lo.min(centre(b)), hi.max(centre(b))),
        );
        let spread = hi - lo;
        let axis = if spread.x >= spread.y && spread.x >= spread.z {
            0
        } else if spread.y >= spread.z {
            1
        } else {
            2
        };
        // Ties by item index: the tree does not depend on the sort's internals.
        work.sort_unstable_by(|a, b| {
            centre(&a.1)[axis]
                .total_cmp(&centre(&b.1)[axis])
                .then(a.0.cmp(&b.0))
        });
        let (left, right) = work.split_at_mut(work.len() / 2);
        let first = self.nodes.len();
        self.nodes[at].first = first as u32;
        self.nodes.push(hull(left));
        self.nodes.push(hull(right));
        self.split(first, left);
        self.split(first + 1, right);
    }

    /// Visit the items whose boxes `ray` meets within `[0, bound]`, nearest
    /// box first: `visit(item, bound)` returns the new bound (at most the
    /// old), and boxes starting beyond it are skipped. Returns the last
    /// bound.
    pub fn traverse(
        &self,
        ray: &Ray,
        mut bound: f64,
        mut visit: impl FnMut(usize, f64) -> f64,
    ) -> f64 {
        let Some(root) = self.nodes.first() else {
            return bound;
        };
        let Some(t_root) = entry(&root.bounds, ray, bound) else {
            return bound;
        };
        let mut stack = [(0_u32, 0.0_f64); MAX_DEPTH];
        stack[0] = (0, t_root);
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (id, t_enter) = stack[depth];
            if t_enter > bound {
                continue;
            }
            let node = &self.nodes[id as usize];
            if node.count > 0 {
                let (first, count) = (node.first as usize, node.count as usize);
                for &item in &self.items[first..first + count] {
                    bound = visit(item as usize, bound);
                }
                continue;
            }
            let (a, b) = (node.first, node.first + 1);
            let ta = entry(&self.nodes[a as usize].bounds, ray, bound);
            let tb = entry(&self.nodes[b as usize].bounds, ray, bound);
            // The farther child first on the stack, so the nearer is popped first.
            let mut push = |id: u32, t: f64| {
                stack[depth] = (id, t);
                depth += 1;
            };
            match (ta, tb) {
                (Some(ta), Some(tb)) if ta <= tb => {
                    push(b, tb);
                    push(a, ta);
                }
                (Some(ta), Some(tb)) => {
                    push(a, ta);
                    push(b, tb);
                }
                (Some(ta), None) => push(a, ta),
                (None, Some(tb)) => push(b, tb),
                (None, None) => {}
            }
        }
        bound
    }

    /// Whether `test(item)` holds for some item of the leaves whose boxes
    /// contain `p` (among them every item whose own box contains `p`).
    pub fn any_containing(&self, p: glam::DVec3, mut test: impl FnMut(usize) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inside = |b: &Aabb| p.cmpge(b.min).all() && p.cmple(b.max).all();
        let mut stack = [0_u32; MAX_DEPTH];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let node = &self.nodes[stack[depth] as usize];
            if !inside(&node.bounds) {
                continue;
            }
            if node.count > 0 {
                let (first, count) = (node.first as usize, node.count as usize);
                if self.items[first..first + count]
                    .iter()
                    .any(|&item| test(item as usize))
                {
                    return true;
                }
                continue;
            }
            stack[depth] = node.first;
            stack[depth + 1] = node.first + 1;
            depth += 2;
        }
        false
    }
}

/// Where `ray` enters the finite box `b` within `[0, bound]` (slab test).
///
/// A ray parallel to a face and exactly in its plane gets a NaN slab, which
/// the comparisons below take as a miss: the boxes are widened (see
/// [`super::zone`]) so no zone reaches their faces.
#[inline]
fn entry(b: &Aabb, ray: &Ray, bound: f64) -> Option<f64> {
    let t1 = (b.min - ray.o) * ray.inv_d;
    let t2 = (b.max - ray.o) * ray.inv_d;
    let near = t1.min(t2).max_element().max(0.0);
    let far = t1.max(t2).min_element().min(bound);
    (near <= far).then_some(near)
}

/// The smallest box holding every box of `work`.
fn hull(work: &[(u32, Aabb)]) -> Node {
    let bounds = work.iter().fold(
        Aabb {
            min: glam::DVec3::INFINITY,
            max: glam::DVec3::NEG_INFINITY,
        },
        |acc, (_, b)| Aabb {
            min: acc.min.min(b.min),
            max: acc.max.max(b.max),
        },
    );
    Node {
        bounds,
        first: 0,
        count: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Unit cubes along x at 0, 2, 4, ...
    fn row(n: usize) -> Vec<(usize, Aabb)> {
        (0..n)
            .map(|i| {
                let x = 2.0 * i as f64;
                (
                    i,
                    Aabb {
                        min: DVec3::new(x, 0.0, 0.0),
                        max: DVec3::new(x + 1.0, 1.0, 1.0),
                    },
                )
            })
            .collect()
    }

    #[test]
    fn visits_boxes_nearest_first_and_stops_at_the_bound() {
        let bvh = Bvh::new(&row(100));
        // Along -x from x = 500: the last cube is met first.
        let ray = Ray::new(DVec3::new(500.0, 0.5, 0.5), DVec3::NEG_X);
        let mut seen = Vec::new();
        bvh.traverse(&ray, f64::INFINITY, |i, b| {
            seen.push(i);
            b
        });
        assert_eq!(seen.len(), 100);
        // Nearest leaf first (descending x; within a leaf, its own order).
        for (k, &i) in seen.iter().enumerate() {
            assert!((99 - i).abs_diff(k) < LEAF_SIZE, "{seen:?}");
        }
        // A hit in the first cube (at t = 302) ends the walk after its leaf.
        let mut n = 0;
        bvh.traverse(&ray, f64::INFINITY, |_, b| {
            n += 1;
            b.min(302.0)
        });
        assert!(n <= 2, "{n}");
        // A ray missing every cube visits none.
        let miss = Ray::new(DVec3::new(500.0, 5.0, 0.5), DVec3::NEG_X);
        bvh.traverse(&miss, f64::INFINITY, |_, _| panic!("visited"));
    }

    #[test]
    fn point_queries_find_the_boxes_holding_the_point() {
        let bvh = Bvh::new(&row(37));
        for i in 0..37 {
            let p = DVec3::new(2.0 * i as f64 + 0.5, 0.5, 0.5);
            let mut hits = Vec::new();
            assert!(!bvh.any_containing(p, |j| {
                hits.push(j);
                false
            }));
            assert!(hits.contains(&i) && hits.len() <= LEAF_SIZE, "{hits:?}");
        }
        assert!(!bvh.any_containing(DVec3::new(1.5, 5.0, 0.5), |_| true));
        assert!(!Bvh::new(&[]).any_containing(DVec3::ZERO, |_| true));
    }
}
