//! `--clamp`, `--threshold` and `--mask`: stages that map each voxel on
//! its own (window 1, output grid = input grid).
//!
//! Bounds compare in f64 against the f32 sample, so `v ∈ [lo, hi]` is
//! the real-number test; a bound written out becomes the nearest f32.
//! The caller rounds to the output type afterwards (the threshold's 0/1
//! to u8).

use crate::grid::Grid;
use crate::stage::{Slab, Stage};
use std::ops::Range;

/// Parse `LO:HI` for `flag` (`--clamp`, `--threshold`): two numbers,
/// negative allowed (`-1000:400`), `inf`/`-inf` for an open side;
/// refuses NaN and LO > HI, in one line naming the flag.
pub fn parse_range(flag: &str, s: &str) -> Result<(f64, f64), String> {
    let bad = |why: &str| format!("{flag} {s}: {why}");
    // The separator is the first ':' not at the start (a leading '-' is
    // a sign, never a ':', so the first ':' splits).
    let Some((a, b)) = s.split_once(':') else {
        return Err(bad("expected LO:HI (for example -1000:400)"));
    };
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| bad(&format!("{:?} is not a number (expected LO:HI)", t.trim())))
    };
    let (lo, hi) = (num(a)?, num(b)?);
    if lo.is_nan() || hi.is_nan() {
        return Err(bad("NaN is no bound"));
    }
    if lo > hi {
        return Err(bad(&format!("LO {lo} is above HI {hi}")));
    }
    Ok((lo, hi))
}

/// Refuse a mask whose grid is not the output grid before the mask
/// stage, naming both grids.
pub fn check_mask_grid(mask: &Grid, out: &Grid, mask_path: &str) -> Result<(), String> {
    if mask.same_as(out) {
        Ok(())
    } else {
        Err(format!(
            "--mask {mask_path}: the mask's grid {} is not the grid it masks, {}",
            mask.describe(),
            out.describe()
        ))
    }
}

/// Input z slices for output slices `zs` of a window-1 stage on `grid`.
fn same_slices(grid: &Grid, zs: Range<u64>) -> Range<u64> {
    let nz = grid.dims.z;
    zs.start.min(nz)..zs.end.min(nz)
}

/// `--clamp LO:HI`: values below LO become LO, above HI become HI (as
/// f32); NaN stays NaN; nothing is rescaled.
pub struct Clamp {
    /// The grid (in and out).
    pub grid: Grid,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

impl Stage for Clamp {
    fn name(&self) -> &str {
        "clamp"
    }
    fn output(&self) -> Grid {
        self.grid
    }
    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        same_slices(&self.grid, zs)
    }
    fn window(&self) -> u64 {
        1
    }
    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        let (lo, hi) = (self.lo, self.hi);
        let (lo32, hi32) = (lo as f32, hi as f32);
        for (o, &v) in out.iter_mut().zip(input.slice(z)) {
            let w = v as f64;
            *o = if w < lo {
                lo32
            } else if w > hi {
                hi32
            } else {
                v
            };
        }
        Ok(())
    }
}

/// `--threshold LO:HI`: 1.0 where LO ≤ v ≤ HI, 0.0 elsewhere and for NaN.
pub struct Threshold {
    /// The grid (in and out).
    pub grid: Grid,
    /// Lower bound (inside).
    pub lo: f64,
    /// Upper bound (inside).
    pub hi: f64,
}

impl Stage for Threshold {
    fn name(&self) -> &str {
        "threshold"
    }
    fn output(&self) -> Grid {
        self.grid
    }
    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        same_slices(&self.grid, zs)
    }
    fn window(&self) -> u64 {
        1
    }
    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        let (lo, hi) = (self.lo, self.hi);
        for (o, &v) in out.iter_mut().zip(input.slice(z)) {
            let w = v as f64;
            *o = if w >= lo && w <= hi { 1.0 } else { 0.0 };
        }
        Ok(())
    }
}

/// Reads mask slice `z` (the caller opened the file and checked its grid
/// with [`check_mask_grid`]); errors are one line naming the file.
pub type MaskReader = Box<dyn Fn(u64) -> Result<Vec<f32>, String> + Send + Sync>;

/// `--mask FILE`: voxels where the mask is 0 (+0 or −0) become
/// `background`; the others (NaN included) keep their value.
pub struct Mask {
    grid: Grid,
    background: f32,
    read: MaskReader,
}

impl Mask {
    /// A mask stage on `grid` whose mask slices come from `read`.
    pub fn new(grid: Grid, background: f32, read: MaskReader) -> Mask {
        Mask {
            grid,
            background,
            read,
        }
    }
}

impl Stage for Mask {
    fn name(&self) -> &str {
        "mask"
    }
    fn output(&self) -> Grid {
        self.grid
    }
    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        same_slices(&self.grid, zs)
    }
    fn window(&self) -> u64 {
        1
    }
    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        let m = (self.read)(z)?;
        let s = input.slice(z);
        if m.len() != s.len() {
            return Err(format!(
                "--mask: slice {z} of the mask holds {} samples, not the {} of a {}x{} slice",
                m.len(),
                s.len(),
                self.grid.dims.x,
                self.grid.dims.y
            ));
        }
        for ((o, &v), &k) in out.iter_mut().zip(s).zip(&m) {
            *o = if k == 0.0 { self.background } else { v };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{Chain, Source};
    use volcore::{Dims, Geometry};

    fn grid(d: [u64; 3]) -> Grid {
        Grid {
            dims: Dims::new(d[0], d[1], d[2]).unwrap(),
            spacing: [1.0; 3],
            geometry: Geometry::IDENTITY,
        }
    }

    const VALS: [f32; 12] = [
        -2000.0,
        -1000.0,
        -999.5,
        -0.0,
        0.0,
        f32::NAN,
        399.0,
        400.0,
        400.25,
        f32::INFINITY,
        f32::NEG_INFINITY,
        7.0,
    ];

    /// `stage` over a 4x3x2 volume whose slices both hold `VALS`.
    fn run(stage: Box<dyn Stage>) -> Vec<f32> {
        let g = stage.output();
        let source: Source<'_, String> =
            Box::new(|zs: Range<u64>| Ok(zs.map(|_| VALS.to_vec()).collect()));
        let mut c = Chain::new(g, source, vec![stage], &std::env::temp_dir());
        let s = c.slices(0..2).unwrap();
        let mut out = s.slice(0).to_vec();
        out.extend_from_slice(s.slice(1));
        out
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn parse_range_reads_signed_bounds_and_refuses_bad_ones() {
        assert_eq!(parse_range("--clamp", "-1000:400"), Ok((-1000.0, 400.0)));
        assert_eq!(parse_range("--clamp", "-5:-1"), Ok((-5.0, -1.0)));
        assert_eq!(parse_range("--threshold", "0.5:0.5"), Ok((0.5, 0.5)));
        assert_eq!(
            parse_range("--clamp", "-inf:3"),
            Ok((f64::NEG_INFINITY, 3.0))
        );
        for bad in ["400:-1000", "nan:1", "1:NaN", "1", "a:2", "1:2:3", ":"] {
            let e = parse_range("--threshold", bad).unwrap_err();
            assert!(e.starts_with(&format!("--threshold {bad}: ")), "{e}");
        }
    }

    #[test]
    fn clamp_is_exact_and_keeps_nan() {
        let g = grid([4, 3, 2]);
        let out = run(Box::new(Clamp {
            grid: g,
            lo: -1000.0,
            hi: 400.0,
        }));
        let want: Vec<f32> = VALS
            .iter()
            .map(|&v| {
                if v.is_nan() {
                    v
                } else {
                    v.clamp(-1000.0, 400.0)
                }
            })
            .collect();
        assert_eq!(bits(&out[..12]), bits(&want));
        assert_eq!(bits(&out[12..]), bits(&want));
        assert_eq!(out[2], -999.5);
        assert_eq!(out[8], 400.0);
        assert_eq!(out[9], 400.0);
        assert_eq!(out[10], -1000.0);
    }

    #[test]
    fn threshold_is_one_inside_zero_outside_and_for_nan() {
        let g = grid([4, 3, 2]);
        let out = run(Box::new(Threshold {
            grid: g,
            lo: -1000.0,
            hi: 400.0,
        }));
        let want = [0., 1., 1., 1., 1., 0., 1., 1., 0., 0., 0., 1.];
        assert_eq!(&out[..12], &want);
        assert_eq!(&out[12..], &want);
    }

    #[test]
    fn mask_sets_background_where_the_mask_is_zero() {
        let g = grid([4, 3, 2]);
        let mask = |z: u64| -> Vec<f32> {
            let mut m = vec![1.0f32; 12];
            m[0] = 0.0;
            m[3] = -0.0;
            m[5] = f32::NAN; // NaN is not 0: keeps the (NaN) value
            m[11] = if z == 1 { 0.0 } else { 2.5 };
            m
        };
        let out = run(Box::new(Mask::new(g, -7.0, Box::new(move |z| Ok(mask(z))))));
        let mut want0 = VALS.to_vec();
        want0[0] = -7.0;
        want0[3] = -7.0;
        let mut want1 = want0.clone();
        want1[11] = -7.0;
        assert_eq!(bits(&out[..12]), bits(&want0));
        assert_eq!(bits(&out[12..]), bits(&want1));
        // A reader's error passes through in one line.
        let g2 = grid([4, 3, 2]);
        let m = Mask::new(g2, 0.0, Box::new(|_| Err("m.nii: truncated".into())));
        let v = VALS.to_vec();
        let slab = Slab::new(0, g2.dims, vec![&v[..]]);
        let mut o = vec![0.0; 12];
        assert_eq!(m.run(0, &slab, &mut o), Err("m.nii: truncated".into()));
        let m = Mask::new(g2, 0.0, Box::new(|_| Ok(vec![1.0; 5])));
        assert!(m.run(0, &slab, &mut o).unwrap_err().contains("5 samples"));
    }

    #[test]
    fn a_mask_on_another_grid_is_refused_naming_both() {
        let a = grid([4, 3, 2]);
        let b = grid([4, 3, 3]);
        assert!(check_mask_grid(&a, &a, "m.nii").is_ok());
        let e = check_mask_grid(&b, &a, "m.nii").unwrap_err();
        assert!(e.starts_with("--mask m.nii: "), "{e}");
        assert!(
            e.contains(&a.describe()) && e.contains(&b.describe()),
            "{e}"
        );
        assert!(!e.contains('\n'));
    }
}
