//! Adaptive steps: per level-0 macrocell, how many of the frame's steps
//! one DVR sample may stand for (`--adaptive TOL`).
//!
//! A cell's value range, mapped through the transfer function's table,
//! bounds how much a sample's optical depth and light per step can change
//! inside the cell ([`Variation`]). A sample standing for `s` steps
//! assumes its classification holds over them: for a classification that
//! changes by `V` (per step) across a cell of length `ℓ`, that misses
//! about `s·V / 2` of optical depth per crossing, or `s·V / (2ℓ)` per unit
//! length. So a cell gets the largest power of two `s` with
//! `s·V / (2ℓ) ≤ TOL`, up to [`MAX_STRIDE_LOG2`]: cells where the transfer
//! function is constant over the range (`V = 0`), whose integral is the
//! closed form `1 − (1 − α)^s` the stretched opacity gives, get the most.
//!
//! Cells the frame makes transparent are marked [`LOOK_UP`]: they are
//! skipped when skipping is on, and without it the march looks up the
//! cell of every sample in them, as it does after a skip, so the first
//! sample in each visible cell is the same either way and skipping stays
//! exact (see [`crate::trace::march`]).

use crate::classify::variation::Variation;
use rayon::prelude::*;
use volindex::MinMaxIndex;

/// The most steps (as a power of two) one sample stands for: 64.
pub const MAX_STRIDE_LOG2: u8 = 6;

/// The mark of a transparent cell: one step per sample, and the march
/// looks up the cell of each.
pub const LOOK_UP: u8 = u8::MAX;

/// Per level-0 cell of `index` (x fastest): `log2` of the steps one
/// sample there stands for, under tolerance `tol` (optical depth per unit
/// length, > 0) for a frame whose classification varies as `variation`
/// says, with cells `cell_length` world units across (their shortest
/// side); [`LOOK_UP`] where `transparent[cell]`.
pub fn stride_log2s(
    index: &MinMaxIndex,
    variation: &Variation,
    transparent: &[bool],
    tol: f32,
    cell_length: f32,
) -> Vec<u8> {
    let Some(level) = index.levels().first() else {
        return Vec::new();
    };
    // `s·V / (2ℓ) ≤ TOL`: `s ≤ 2·TOL·ℓ / V`.
    let budget = 2.0 * f64::from(tol) * f64::from(cell_length);
    level
        .min()
        .par_iter()
        .zip(level.max())
        .enumerate()
        .map(|(i, (&lo, &hi))| {
            if transparent.get(i).copied().unwrap_or(true) {
                return LOOK_UP;
            }
            stride_log2(budget, variation.over(lo, hi))
        })
        .collect()
}

/// The largest `log2 s` (0 ..= [`MAX_STRIDE_LOG2`]) with `s·v ≤ budget`.
fn stride_log2(budget: f64, v: f64) -> u8 {
    if v.is_nan() || budget.is_nan() || budget <= 0.0 {
        return 0;
    }
    if v <= 0.0 {
        return MAX_STRIDE_LOG2;
    }
    let mut log = 0;
    while log < MAX_STRIDE_LOG2 && f64::from(2u32 << log) * v <= budget {
        log += 1;
    }
    log
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No variation: the longest stride; otherwise the largest power of
    /// two within the budget; none for NaN or an unbounded variation.
    #[test]
    fn strides_are_the_largest_power_of_two_in_budget() {
        assert_eq!(stride_log2(1.0, 0.0), MAX_STRIDE_LOG2);
        assert_eq!(stride_log2(1.0, 1.0), 0);
        assert_eq!(stride_log2(1.0, 0.5), 1);
        assert_eq!(stride_log2(1.0, 0.49), 1);
        assert_eq!(stride_log2(1.0, 0.25), 2);
        assert_eq!(stride_log2(1.0, 1e-9), MAX_STRIDE_LOG2);
        assert_eq!(stride_log2(1.0, f64::INFINITY), 0);
        assert_eq!(stride_log2(1.0, f64::NAN), 0);
        assert_eq!(stride_log2(0.0, 0.0), 0);
    }
}
