//! The fixed binary tree over batch indices that every `roks brdf` run sums
//! its batch tallies over, so that any split of the run (threads, shards)
//! gives the same sums bit for bit.
//!
//! Floating-point addition is not associative, so "the same photons" is not
//! enough: the sums must also be added in the same association. A shard cannot
//! know how the single run associates its sums unless that association is a
//! function of the batch indices alone. So a run reduces its batch tallies over
//! a **fixed dyadic tree** on batch indices, whatever the split:
//!
//! * node `(level l, index j)` covers batches `[j 2^l, (j + 1) 2^l) ∩ [0, B)`;
//! * a leaf `(0, b)` is batch `b`'s tally (photons summed in index order);
//! * an inner node is `left + right` (left accumulator, right added into it),
//!   or just `left` when `right` lies wholly past `B`;
//! * the result is the root `(K, 0)`, `2^K >= B`.
//!
//! [`DyadicSum`] computes this with a stack (a binary counter): push nodes in
//! batch order and siblings are combined as soon as both are present. A shard
//! pushes its own batches and stops with a short stack of at most
//! `2 log2 B` complete nodes: these values are bit-identical to the same
//! nodes in the single run, because each depends only on its own batches.
//! Pushing the nodes of all shards, in photon order, into one [`DyadicSum`]
//! gives the root bit for bit, for any split on batch boundaries (2, 3, 7
//! shards...), not only power-of-two ones.
//!
//! The tree is generic over the value summed: it knows nothing of what a
//! tally holds (the caller passes the addition, e.g. [`super::Merge::merge`]).
//! Its leaves are batches of [`BATCH`] photons: here, below both the
//! transport that traces them and the shards that split a run into them.

/// Photons per batch: the unit of parallel work and of summation order (a
/// leaf of the batch tree; a shard is whole batches).
pub const BATCH: u64 = 4096;

/// Why nodes cannot be pushed onto a [`DyadicSum`], or do not make its
/// root: the node (level, index) and the batch concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TreeError {
    /// A node past the run's batches, or above its root.
    #[error("tree node ({level}, {index}) outside the run's {batches} batches")]
    Outside {
        /// The node's level.
        level: u32,
        /// The node's index.
        index: u64,
        /// The run's batches.
        batches: u64,
    },
    /// A node that does not start where the previous one ended.
    #[error("tree node ({level}, {index}) does not follow batch {previous}")]
    Gap {
        /// The node's level.
        level: u32,
        /// The node's index.
        index: u64,
        /// The last batch of the previous node.
        previous: u128,
    },
    /// The nodes pushed do not cover every batch.
    #[error("the shards do not cover every batch of the run")]
    Uncovered,
}

/// A complete node of the fixed dyadic tree over batch indices.
#[derive(Debug, Clone, PartialEq)]
pub struct Node<T> {
    /// Height above the leaves (0: one batch).
    pub level: u32,
    /// Position among the nodes of this level.
    pub index: u64,
    /// The sum of the batches it covers, associated as the tree says.
    pub value: T,
}

impl<T> Node<T> {
    /// First batch covered.
    #[must_use]
    pub fn start(&self) -> u128 {
        u128::from(self.index) << self.level
    }
    /// One past the last batch covered, before clipping to the run.
    #[must_use]
    pub fn end(&self) -> u128 {
        u128::from(self.index + 1) << self.level
    }
}

/// The fixed-tree reduction of `batches` batch tallies (see the module doc):
/// push complete nodes in batch order.
#[derive(Debug, Clone)]
pub struct DyadicSum<T> {
    batches: u64,
    root_level: u32,
    stack: Vec<Node<T>>,
}

impl<T> DyadicSum<T> {
    /// An empty reduction over a run of `batches` batches (>= 1).
    #[must_use]
    pub fn new(batches: u64) -> Self {
        Self {
            batches,
            root_level: batches.max(1).next_power_of_two().trailing_zeros(),
            stack: Vec::new(),
        }
    }

    /// Push a complete node (a leaf: `level` 0, `index` the batch); it must
    /// start where the previous node ended. `merge(left, right)` adds right
    /// into left.
    ///
    /// # Errors
    /// [`TreeError::Gap`] if the node is not contiguous with the previous
    /// one, [`TreeError::Outside`] if it lies past the run.
    pub fn push(&mut self, node: Node<T>, merge: &impl Fn(&mut T, &T)) -> Result<(), TreeError> {
        self.push_with(node, &|left, right| merge(left, right), &mut drop)
    }

    /// [`DyadicSum::push`] with `merge(left, right)` free to change `right`
    /// (e.g. to clear it while adding it), and each right node's value, once
    /// merged, handed to `spent` (e.g. to tally the next batch into it).
    ///
    /// # Errors
    /// As [`DyadicSum::push`].
    pub fn push_with(
        &mut self,
        node: Node<T>,
        merge: &impl Fn(&mut T, &mut T),
        spent: &mut impl FnMut(T),
    ) -> Result<(), TreeError> {
        if node.start() >= u128::from(self.batches) || node.level > self.root_level {
            return Err(TreeError::Outside {
                level: node.level,
                index: node.index,
                batches: self.batches,
            });
        }
        if let Some(top) = self.stack.last() {
            let end = top.end().min(u128::from(self.batches));
            if node.start() != end {
                return Err(TreeError::Gap {
                    level: node.level,
                    index: node.index,
                    previous: end.saturating_sub(1),
                });
            }
        }
        self.stack.push(node);
        self.reduce(merge, spent);
        Ok(())
    }

    fn reduce(&mut self, merge: &impl Fn(&mut T, &mut T), spent: &mut impl FnMut(T)) {
        while let Some(top) = self.stack.last() {
            if top.level >= self.root_level {
                break;
            }
            if top.index % 2 == 1 {
                let n = self.stack.len();
                let sibling = n >= 2 && {
                    let below = &self.stack[n - 2];
                    below.level == top.level && below.index + 1 == top.index
                };
                if !sibling {
                    break;
                }
                let mut right = self.stack.pop().expect("two nodes");
                let left = self.stack.last_mut().expect("two nodes");
                merge(&mut left.value, &mut right.value);
                spent(right.value);
                left.level += 1;
                left.index /= 2;
            } else if top.end() >= u128::from(self.batches) {
                // The right sibling is empty: the parent is this node.
                let top = self.stack.last_mut().expect("non-empty");
                top.level += 1;
                top.index /= 2;
            } else {
                break;
            }
        }
    }

    /// The complete nodes so far, in batch order (what a shard stores).
    #[must_use]
    pub fn into_nodes(self) -> Vec<Node<T>> {
        self.stack
    }

    /// The root: the sum over all batches.
    ///
    /// # Errors
    /// [`TreeError::Uncovered`] if the pushed nodes do not cover every batch.
    pub fn finish(mut self) -> Result<T, TreeError> {
        match (self.stack.pop(), self.stack.is_empty()) {
            (Some(root), true) if root.level == self.root_level && root.index == 0 => {
                Ok(root.value)
            }
            _ => Err(TreeError::Uncovered),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tree sum of leaves `vals` by pushing leaves, and by pushing the nodes of
    /// contiguous pieces, must agree bit for bit.
    fn tree(vals: &[f64], cuts: &[usize]) -> (f64, f64) {
        let add = |a: &mut f64, b: &f64| *a += b;
        let n = vals.len() as u64;
        let mut whole = DyadicSum::new(n);
        for (b, &v) in vals.iter().enumerate() {
            whole
                .push(
                    Node {
                        level: 0,
                        index: b as u64,
                        value: v,
                    },
                    &add,
                )
                .unwrap();
        }
        let mut merged = DyadicSum::new(n);
        let mut bounds = vec![0];
        bounds.extend_from_slice(cuts);
        bounds.push(vals.len());
        for w in bounds.windows(2) {
            let mut part = DyadicSum::new(n);
            for (b, &value) in vals.iter().enumerate().take(w[1]).skip(w[0]) {
                part.push(
                    Node {
                        level: 0,
                        index: b as u64,
                        value,
                    },
                    &add,
                )
                .unwrap();
            }
            for node in part.into_nodes() {
                merged.push(node, &add).unwrap();
            }
        }
        (whole.finish().unwrap(), merged.finish().unwrap())
    }

    #[test]
    fn any_split_reproduces_the_tree() {
        let mut x = 0.1_f64;
        let vals: Vec<f64> = (0..40)
            .map(|i| {
                x = (x * 7.13 + 0.37).fract();
                x * 10f64.powi(i % 7 - 3)
            })
            .collect();
        for n in 1..=vals.len() {
            let v = &vals[..n];
            // Every split into at most three pieces.
            for a in 1..n {
                let (w, m) = tree(v, &[a]);
                assert_eq!(w.to_bits(), m.to_bits(), "n {n}, cut {a}");
                for b in a + 1..n {
                    let (w, m) = tree(v, &[a, b]);
                    assert_eq!(w.to_bits(), m.to_bits(), "n {n}, cuts {a} {b}");
                }
            }
            // Every batch its own shard.
            let cuts: Vec<usize> = (1..n).collect();
            let (w, m) = tree(v, &cuts);
            assert_eq!(w.to_bits(), m.to_bits(), "n {n}, singletons");
        }
    }

    #[test]
    fn missing_or_overlapping_nodes_are_refused() {
        let add = |a: &mut f64, b: &f64| *a += b;
        let mut s = DyadicSum::new(4);
        s.push(
            Node {
                level: 0,
                index: 0,
                value: 1.0,
            },
            &add,
        )
        .unwrap();
        let gap = s.push(
            Node {
                level: 0,
                index: 2,
                value: 1.0,
            },
            &add,
        );
        assert_eq!(
            gap,
            Err(TreeError::Gap {
                level: 0,
                index: 2,
                previous: 0
            })
        );
        assert_eq!(
            gap.unwrap_err().to_string(),
            "tree node (0, 2) does not follow batch 0"
        );
        assert_eq!(s.clone().finish(), Err(TreeError::Uncovered));
        s.push(
            Node {
                level: 0,
                index: 1,
                value: 1.0,
            },
            &add,
        )
        .unwrap();
        let again = s.push(
            Node {
                level: 0,
                index: 1,
                value: 1.0,
            },
            &add,
        );
        assert!(matches!(again, Err(TreeError::Gap { previous: 1, .. })));
        let past = s.push(
            Node {
                level: 0,
                index: 4,
                value: 1.0,
            },
            &add,
        );
        assert_eq!(
            past.unwrap_err().to_string(),
            "tree node (0, 4) outside the run's 4 batches"
        );
    }
}
