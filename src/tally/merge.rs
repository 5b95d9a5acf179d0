//! Adding tallies field by field: [`Merge`] for the sums a tally is made of
//! (counts, weights, per-bin vectors, optional parts), and
//! [`merge_fields!`](crate::merge_fields) to derive it for a tally struct
//! from one list of its fields, so that `merge` and `merge_clearing` cannot
//! drift apart and a new field is one edit.
//!
//! Both methods add `other` into `self` in the order of the field list and,
//! within a vector, bin by bin: the same additions in the same order, so
//! `merge_clearing` gives the sums of `merge` bit for bit.

/// Sums that can be added into each other.
pub trait Merge {
    /// Add `other` into `self`.
    ///
    /// # Panics
    /// If the layouts differ (bin counts, present parts).
    fn merge(&mut self, other: &Self);

    /// [`Merge::merge`] (the same sums bit for bit), leaving `other` all
    /// zero with its layout: a fresh tally for the next batch, cleared in
    /// the same pass.
    ///
    /// # Panics
    /// As [`Merge::merge`].
    fn merge_clearing(&mut self, other: &mut Self);
}

impl Merge for u64 {
    fn merge(&mut self, other: &Self) {
        *self += *other;
    }
    fn merge_clearing(&mut self, other: &mut Self) {
        *self += std::mem::take(other);
    }
}

impl Merge for f64 {
    fn merge(&mut self, other: &Self) {
        *self += *other;
    }
    fn merge_clearing(&mut self, other: &mut Self) {
        *self += std::mem::take(other);
    }
}

/// Bin by bin.
impl Merge for Vec<f64> {
    fn merge(&mut self, other: &Self) {
        assert_eq!(self.len(), other.len(), "Merge: bin counts differ");
        for (a, b) in self.iter_mut().zip(other) {
            *a += b;
        }
    }
    fn merge_clearing(&mut self, other: &mut Self) {
        assert_eq!(self.len(), other.len(), "Merge: bin counts differ");
        super::accumulator::add_clearing(self, other);
    }
}

/// A part present in both or in neither (e.g. lattice replicates).
impl<T: Merge> Merge for Option<T> {
    fn merge(&mut self, other: &Self) {
        match (self, other) {
            (Some(a), Some(b)) => a.merge(b),
            (None, None) => {}
            _ => panic!("Merge: a part present in one tally only"),
        }
    }
    fn merge_clearing(&mut self, other: &mut Self) {
        match (self, other) {
            (Some(a), Some(b)) => a.merge_clearing(b),
            (None, None) => {}
            _ => panic!("Merge: a part present in one tally only"),
        }
    }
}

/// Implement [`Merge`](crate::tally::Merge) for a struct from the list of
/// its summed fields, in the order they are added; fields after `same` are
/// layout (e.g. a component count) and must be equal in both.
///
/// ```ignore
/// merge_fields!(Replicates { same count; sum reflected, carlson, inplane });
/// ```
#[macro_export]
macro_rules! merge_fields {
    ($ty:ty { $(same $($same:ident),+ ;)? sum $($field:ident),+ $(,)? }) => {
        impl $crate::tally::Merge for $ty {
            fn merge(&mut self, other: &Self) {
                $($(assert_eq!(
                    self.$same,
                    other.$same,
                    concat!(stringify!($ty), "::merge: ", stringify!($same), " differs")
                );)+)?
                $($crate::tally::Merge::merge(&mut self.$field, &other.$field);)+
            }
            fn merge_clearing(&mut self, other: &mut Self) {
                $($(assert_eq!(
                    self.$same,
                    other.$same,
                    concat!(stringify!($ty), "::merge_clearing: ", stringify!($same), " differs")
                );)+)?
                $($crate::tally::Merge::merge_clearing(&mut self.$field, &mut other.$field);)+
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, PartialEq)]
    struct Pair {
        kind: usize,
        n: u64,
        w: f64,
        bins: Vec<f64>,
        extra: Option<Vec<f64>>,
    }
    crate::merge_fields!(Pair { same kind; sum n, w, bins, extra });

    fn pair(x: f64) -> Pair {
        Pair {
            kind: 2,
            n: 3,
            w: x,
            bins: vec![x, 2.0 * x, 0.1],
            extra: Some(vec![x]),
        }
    }

    #[test]
    fn merge_adds_every_field_and_clearing_agrees_bit_for_bit() {
        let mut a = pair(0.1);
        a.merge(&pair(0.2));
        assert_eq!(a.n, 6);
        assert_eq!(a.w, 0.1 + 0.2);
        assert_eq!(a.bins, vec![0.1 + 0.2, 0.2 + 0.4, 0.1 + 0.1]);
        assert_eq!(a.extra, Some(vec![0.1 + 0.2]));
        let mut c = pair(0.1);
        let mut b = pair(0.2);
        c.merge_clearing(&mut b);
        assert_eq!(c, a);
        assert_eq!(
            b,
            Pair {
                kind: 2,
                n: 0,
                w: 0.0,
                bins: vec![0.0; 3],
                extra: Some(vec![0.0]),
            }
        );
    }

    #[test]
    #[should_panic(expected = "kind differs")]
    fn different_layouts_are_refused() {
        let mut a = pair(1.0);
        let mut b = pair(1.0);
        b.kind = 4;
        a.merge(&b);
    }

    #[test]
    #[should_panic(expected = "present in one tally only")]
    fn a_part_in_one_tally_only_is_refused() {
        let mut a = pair(1.0);
        let mut b = pair(1.0);
        b.extra = None;
        a.merge_clearing(&mut b);
    }

    #[test]
    #[should_panic(expected = "bin counts differ")]
    fn different_bin_counts_are_refused() {
        let mut a = pair(1.0);
        let mut b = pair(1.0);
        b.bins.push(0.0);
        a.merge(&b);
    }
}
