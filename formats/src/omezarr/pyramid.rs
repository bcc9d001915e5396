//! The shape of an OME-Zarr pyramid: which axes each level halves. An
//! axis already at least twice as coarse as the finest one is left whole
//! until the others catch up, so anisotropic data (0.5×0.5×2) becomes
//! isotropic down the pyramid (1×1×2, 2×2×2, 4×4×4), not more anisotropic.

use crate::error::Error;
use volcore::Dims;

/// One level of a pyramid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LevelShape {
    /// Voxels along x, y, z.
    pub dims: Dims,
    /// Full-resolution voxels one voxel of the level stands for along x,
    /// y, z (powers of two; 1, 1, 1 at level 0).
    pub factor: [u64; 3],
    /// Whether the level halves x, y, z of the level above (none at
    /// level 0).
    pub halves: [bool; 3],
}

/// The axes the level after one of `dims` and `spacing` (x, y, z)
/// halves: of the axes longer than one voxel, each whose spacing is less
/// than twice the finest of theirs. The finest is always halved, so a
/// level with an axis longer than one voxel is always followed by a
/// smaller one; a spacing that is not positive and finite counts as 1.
pub fn halved_axes(dims: Dims, spacing: [f64; 3]) -> [bool; 3] {
    let d = dims.as_array();
    let s = spacing.map(|v| if v.is_finite() && v > 0.0 { v } else { 1.0 });
    let long = [0, 1, 2].map(|a| d[a] > 1);
    let finest = (0..3)
        .filter(|&a| long[a])
        .map(|a| s[a])
        .fold(f64::INFINITY, f64::min);
    [0, 1, 2].map(|a| long[a] && s[a] < 2.0 * finest)
}

/// Every level `dims` with voxel `spacing` makes: level 0, then each
/// made by [`halved_axes`] of the one above (rounding up), until one
/// would be a single voxel along every axis (that voxel is no level).
fn all_levels(dims: Dims, spacing: [f32; 3]) -> Vec<LevelShape> {
    let mut out = vec![LevelShape {
        dims,
        factor: [1; 3],
        halves: [false; 3],
    }];
    // Each level halves at least one axis longer than one voxel: at most
    // 3 × 64 levels before every axis is one voxel.
    loop {
        let last = out[out.len() - 1];
        let sp = [0, 1, 2].map(|a| f64::from(spacing[a]) * last.factor[a] as f64);
        let halves = halved_axes(last.dims, sp);
        let d = last.dims.as_array();
        let next = [0, 1, 2].map(|a| if halves[a] { d[a].div_ceil(2) } else { d[a] });
        if !halves.contains(&true) || next == [1, 1, 1] {
            return out;
        }
        let Ok(dims) = Dims::new(next[0], next[1], next[2]) else {
            return out;
        };
        out.push(LevelShape {
            dims,
            factor: [0, 1, 2].map(|a| last.factor[a] << u64::from(halves[a])),
            halves,
        });
    }
}

/// The most pyramid levels `dims` with `spacing` makes (see
/// [`all_levels`]; the full resolution always is one).
pub fn max_levels(dims: Dims, spacing: [f32; 3]) -> u32 {
    all_levels(dims, spacing).len() as u32
}

/// The first `levels` levels (at least one) of `dims` with `spacing`;
/// more than [`max_levels`] is refused, saying how many it makes.
pub fn plan(dims: Dims, spacing: [f32; 3], levels: u32) -> crate::error::Result<Vec<LevelShape>> {
    let mut all = all_levels(dims, spacing);
    let most = all.len() as u32;
    if levels > most {
        let d = all[all.len() - 1].dims;
        return Err(Error::invalid(format!(
            "--pyramid {levels}: a {dims} volume makes at most {most} pyramid level{} (each halves the axes less than twice as coarse as the finest; the last is {}x{}x{})",
            if most == 1 { "" } else { "s" },
            d.x,
            d.y,
            d.z
        )));
    }
    all.truncate(levels.max(1) as usize);
    Ok(all)
}

/// Refuse more pyramid levels than [`max_levels`] (see [`plan`]).
pub fn check_levels(dims: Dims, spacing: [f32; 3], levels: u32) -> crate::error::Result<()> {
    plan(dims, spacing, levels).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dims(l: &[LevelShape]) -> Vec<[u64; 3]> {
        l.iter().map(|l| l.dims.as_array()).collect()
    }

    #[test]
    fn isotropic_data_halves_every_axis_until_one_voxel() {
        let d = Dims::new(64, 64, 20).unwrap();
        // 64, 32, 16, 8, 4, 2 along x: six levels; a seventh would be 1x1x1.
        assert_eq!(max_levels(d, [1.0; 3]), 6);
        let l = plan(d, [1.0; 3], 6).unwrap();
        assert_eq!(l[1].dims.as_array(), [32, 32, 10]);
        assert_eq!(l[5].factor, [32, 32, 32]);
        let e = plan(d, [1.0; 3], 9).unwrap_err().to_string();
        assert!(e.contains("at most 6") && e.contains("2x2x1"), "{e}");
        assert_eq!(max_levels(Dims::new(1, 1, 1).unwrap(), [1.0; 3]), 1);
        assert_eq!(max_levels(Dims::new(2, 1, 1).unwrap(), [1.0; 3]), 1);
        assert_eq!(max_levels(Dims::new(3, 1, 1).unwrap(), [1.0; 3]), 2);
        assert!(check_levels(Dims::new(1, 1, 1).unwrap(), [1.0; 3], 2).is_err());
    }

    #[test]
    fn a_coarse_axis_waits_until_the_others_catch_up() {
        // 0.5 x 0.5 x 2: x and y halve twice alone, then all three.
        let d = Dims::new(64, 64, 16).unwrap();
        let l = plan(d, [0.5, 0.5, 2.0], 4).unwrap();
        assert_eq!(
            dims(&l),
            [[64, 64, 16], [32, 32, 16], [16, 16, 16], [8, 8, 8]]
        );
        assert_eq!(l[1].halves, [true, true, false]);
        assert_eq!(l[3].factor, [8, 8, 2]);
        // Just under twice as coarse: halved with the others.
        assert_eq!(halved_axes(d, [1.0, 1.0, 1.9]), [true; 3]);
        assert_eq!(halved_axes(d, [1.0, 2.0, 4.0]), [true, false, false]);
        // An axis of one voxel is never halved, nor counted as finest.
        let flat = Dims::new(64, 64, 1).unwrap();
        assert_eq!(halved_axes(flat, [4.0, 4.0, 0.1]), [true, true, false]);
        // Bad spacing counts as 1: progress is still made.
        assert_eq!(halved_axes(d, [f64::NAN, 0.0, 1.0]), [true; 3]);
        // A long thin axis keeps halving alone once the others are 1.
        assert_eq!(max_levels(Dims::new(2, 2, 64).unwrap(), [1.0; 3]), 6);
    }
}
