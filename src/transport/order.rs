//! The order in which the photons of a batch are traced: by the Morton
//! (Z-order) code of their entry points on the period.
//!
//! Photons entering near each other first visit the same part of the
//! surface, so tracing them one after the other keeps that part of a large
//! surface (many bumps, a fine height field) in the caches. The order only
//! changes when a history is computed, not what it is: every photon keeps
//! its own stream ([`super::rng::photon_rng`]), and the batch scores its
//! histories in photon index order afterwards, so every tally stays bit for
//! bit what the index order gives. Small surfaces, which stay in the
//! caches anyway, are traced in index order ([`pays`]).

use crate::micro::{MicroSurface, Relief};

/// Bytes of geometry (solids, heights) above which tracing in Morton order
/// pays: about a core's L2 cache. Below it the surface stays in the caches
/// anyway, and the order's buffers and sort would only cost time.
const ORDER_ABOVE_BYTES: usize = 1 << 20;

/// Whether `surface` is large enough for the Morton order to pay
/// (`ORDER_ABOVE_BYTES`, 1 MiB). Either order gives the same tallies.
#[must_use]
pub fn pays(surface: &MicroSurface) -> bool {
    let bytes = match &surface.relief {
        Relief::Solids(s) => std::mem::size_of_val(s.list.as_slice()),
        Relief::HeightField(f) => std::mem::size_of_val(f.h.as_slice()),
    };
    bytes > ORDER_ABOVE_BYTES
}

/// Bits of the entry coordinates `u`, `v` kept in a Morton code: a 256 x 256
/// grid over the period, finer than a batch's 4096 points.
const BITS: u32 = 8;

/// The Morton code of a point `(u, v)` of the unit square (`[0, 1)`; other
/// values are clamped to it): the bits of `floor(256 u)` and `floor(256 v)`
/// interleaved, `u` in the even bits. Points with nearby codes are near each
/// other on the square.
#[must_use]
#[inline]
pub fn morton(u: f64, v: f64) -> u16 {
    let cells = f64::from(1_u32 << BITS);
    // `as` saturates (NaN to 0): every input lands in 0..256.
    let quantise = |x: f64| ((x * cells) as u32).min((1 << BITS) - 1);
    let spread = |x: u32| {
        // 8 bits to the even positions of 16: abcdefgh -> 0a0b0c0d0e0f0g0h.
        let x = (x | (x << 4)) & 0x0f0f;
        let x = (x | (x << 2)) & 0x3333;
        (x | (x << 1)) & 0x5555
    };
    (spread(quantise(u)) | (spread(quantise(v)) << 1)) as u16
}

/// The positions `0..codes.len()` sorted by `codes`, equal codes in
/// increasing position: a stable two-pass radix sort (8 bits a pass).
#[must_use]
pub fn sorted_by_code(codes: &[u16]) -> Vec<u32> {
    assert!(
        u32::try_from(codes.len()).is_ok(),
        "sorted_by_code: more than 2^32 photons in a batch"
    );
    let mut order: Vec<u32> = (0..codes.len() as u32).collect();
    let mut next = vec![0_u32; codes.len()];
    for shift in [0, 8] {
        let digit = |i: u32| usize::from((codes[i as usize] >> shift) as u8);
        let mut start = [0_usize; 257];
        for &i in &order {
            start[digit(i) + 1] += 1;
        }
        for d in 0..256 {
            start[d + 1] += start[d];
        }
        for &i in &order {
            let d = digit(i);
            next[start[d]] = i;
            start[d] += 1;
        }
        std::mem::swap(&mut order, &mut next);
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// The code bit by bit: bit `2 k` is bit `k` of the u bin, bit `2 k + 1`
    /// bit `k` of the v bin.
    fn morton_by_bits(u: f64, v: f64) -> u16 {
        let cu = ((u * 256.0).floor().clamp(0.0, 255.0)) as u16;
        let cv = ((v * 256.0).floor().clamp(0.0, 255.0)) as u16;
        (0..8).fold(0, |code, k| {
            code | ((cu >> k) & 1) << (2 * k) | ((cv >> k) & 1) << (2 * k + 1)
        })
    }

    #[test]
    fn codes_interleave_the_cell_bits() {
        assert_eq!(morton(0.0, 0.0), 0);
        assert_eq!(morton(1.0 / 256.0, 0.0), 1);
        assert_eq!(morton(0.0, 1.0 / 256.0), 2);
        assert_eq!(morton(0.999_999, 0.999_999), u16::MAX);
        // Out of the square and NaN are clamped.
        assert_eq!(morton(-0.5, 2.0), morton(0.0, 0.999_999));
        assert_eq!(morton(f64::NAN, 0.0), 0);
        let mut rng = Pcg64Mcg::seed_from_u64(8);
        for _ in 0..10_000 {
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            assert_eq!(morton(u, v), morton_by_bits(u, v), "{u} {v}");
        }
        // The four quadrants of the square come in Z order.
        let q = [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)];
        let codes: Vec<u16> = q.iter().map(|&(u, v)| morton(u, v)).collect();
        assert!(codes.windows(2).all(|w| w[0] < w[1]), "{codes:?}");
    }

    #[test]
    fn radix_order_is_the_stable_sort() {
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        for n in [0, 1, 2, 17, 4096, 5000] {
            // Few distinct codes (many ties) and all codes.
            for range in [4_u16, u16::MAX] {
                let codes: Vec<u16> = (0..n).map(|_| rng.random_range(0..range)).collect();
                let mut want: Vec<u32> = (0..n as u32).collect();
                want.sort_by_key(|&i| (codes[i as usize], i));
                assert_eq!(sorted_by_code(&codes), want, "n {n} range {range}");
            }
        }
    }
}
