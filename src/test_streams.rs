//! Deterministic number streams for the unit tests' randomised sweeps: a
//! 64-bit LCG (Knuth's MMIX constants), so a sweep draws the same cases on
//! every machine without a generator of its own.

/// 53-bit integers, the high bits of the LCG's state after each step.
pub(crate) fn bits(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        state >> 11
    }
}

/// Numbers in [0, 1), multiples of 2^-53.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut next = bits(seed);
    move || next() as f64 / (1u64 << 53) as f64
}
