//! Reorientation (`--orient CODE`): permute and flip the index axes so
//! they point the way a three-letter code says, exactly (no
//! interpolation), updating the geometry so every voxel keeps its world
//! position.
//!
//! **Convention ("toward").** Letter `a` of the code names the world
//! direction output index axis `a` points to: `L`/`R`, `P`/`A`, `S`/`I`
//! for +x/−x, +y/−y, +z/−z of volkit's LPS world. So `LPS` is the
//! identity direction matrix and `RAS` is NIfTI's usual orientation. This
//! is the convention of SimpleITK's `DICOMOrient(img, CODE)` (ITK's
//! `DICOMOrientImageFilter`), of nibabel's `aff2axcodes` (which reads the
//! RAS affine a NIfTI writer stores; the letters are the same world
//! directions) and of [`volcore::Geometry::orientation`].
//!
//! **Which input axis each output axis reads.** As ITK does: the input's
//! own code is taken from its direction matrix by repeatedly picking the
//! largest absolute entry, assigning that index axis to that world axis,
//! and removing both ([`OrientCode::of_direction`]); an oblique input so
//! maps each index axis to its nearest world axis, one each. The output
//! axis whose letter shares a pair with an input axis's letter reads that
//! axis, flipped when the letters differ. The output's directions are the
//! input's columns permuted and negated (an oblique input stays oblique;
//! nothing is snapped to the world axes), its origin the world position
//! of the input voxel that becomes output voxel (0, 0, 0).
//!
//! **Streaming.** When output z is input z (flipped or not), output slice
//! `z` reads one input slice (window 1); when it comes from input x or y,
//! every output slice reads every input slice (window = input nz: the
//! chain then copies a large input to disk and maps it). A flipped z
//! reads the input from its last slice down: [`Stage::needs`] moves down
//! as output z moves up, so the source must take slice ranges in any
//! order (an exception to the "ends do not decrease" rule of `needs`).
//!
//! Speed (one thread, 512×512×300 f32, all output slices): x and y kept
//! or flipped 15–50 ms; x and y swapped 0.18 s; output z from input y
//! 0.04–0.17 s; output z from input x 0.8 s (each output slice is a
//! y–z plane: one sample per input cache line).

use crate::grid::Grid;
use crate::stage::{Slab, Stage};
use std::fmt;
use std::ops::Range;
use std::str::FromStr;
use volcore::Dims;

/// The letters of each world axis of the LPS frame: (toward +, toward −).
const LETTERS: [(u8, u8); 3] = [(b'L', b'R'), (b'P', b'A'), (b'S', b'I')];

/// The world axes' names, for messages.
const AXIS_NAMES: [&str; 3] = ["left-right", "anterior-posterior", "superior-inferior"];

/// What every refused code's message ends with.
const RULE: &str = "use three letters, one each from R/L, A/P, S/I, e.g. RAS or LPS";

/// A three-letter orientation code ("toward" convention, see the module
/// docs): one letter from each of R/L, A/P, S/I, in any order, stored in
/// upper case. 48 codes exist; `LPS` is the identity direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct OrientCode([u8; 3]);

/// The world axis a letter names and whether it points toward + (L, P, S).
fn letter_axis(c: u8) -> Option<(usize, bool)> {
    LETTERS.iter().enumerate().find_map(|(w, &(pos, neg))| {
        if c == pos {
            Some((w, true))
        } else if c == neg {
            Some((w, false))
        } else {
            None
        }
    })
}

impl OrientCode {
    /// The identity direction of volkit's (and ITK's, DICOM's) LPS world.
    pub const LPS: OrientCode = OrientCode(*b"LPS");

    /// The three upper-case letters.
    pub fn letters(&self) -> [u8; 3] {
        self.0
    }

    /// For output index axis `a`: the world axis it points along (0 x, 1
    /// y, 2 z) and whether it points toward + (L, P, S).
    pub fn axis(&self, a: usize) -> (usize, bool) {
        // Every stored letter is valid (FromStr, of_direction and all
        // build only valid codes).
        letter_axis(self.0[a]).unwrap_or((a, true))
    }

    /// All 48 codes (the permutations of the world axes, each with both
    /// signs), in a fixed order.
    pub fn all() -> Vec<OrientCode> {
        const PERMS: [[usize; 3]; 6] = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        let mut v = Vec::with_capacity(48);
        for p in PERMS {
            for signs in 0..8u8 {
                v.push(OrientCode(std::array::from_fn(|a| {
                    let (pos, neg) = LETTERS[p[a]];
                    if signs >> a & 1 == 0 {
                        pos
                    } else {
                        neg
                    }
                })));
            }
        }
        v
    }

    /// The code of a direction matrix (`direction[row][axis]`, LPS world)
    /// as ITK's `DICOMOrientation::DirectionCosinesToOrientation` finds
    /// it: take the largest absolute entry (on a tie the last in row-major
    /// order), give its index axis (column) that world axis (row) and the
    /// entry's sign, drop its row and column, repeat. Unlike a per-column
    /// choice this always names each world axis once, also for oblique
    /// matrices.
    pub fn of_direction(direction: &[[f64; 3]; 3]) -> OrientCode {
        let mut code = *b"LPS";
        let mut row_used = [false; 3];
        let mut col_used = [false; 3];
        for _ in 0..3 {
            let mut best: Option<(usize, usize)> = None;
            let mut best_v = f64::NEG_INFINITY;
            for (r, row) in direction.iter().enumerate() {
                for (c, &v) in row.iter().enumerate() {
                    if row_used[r] || col_used[c] {
                        continue;
                    }
                    // `>=`: ITK's multimap keeps equal keys in insertion
                    // (row-major) order and takes the last.
                    if v.abs() >= best_v {
                        best_v = v.abs();
                        best = Some((r, c));
                    }
                }
            }
            let Some((r, c)) = best else { break };
            row_used[r] = true;
            col_used[c] = true;
            let (pos, neg) = LETTERS[r];
            code[c] = if direction[r][c] > 0.0 { pos } else { neg };
        }
        OrientCode(code)
    }
}

impl fmt::Display for OrientCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for &c in &self.0 {
            write!(f, "{}", c as char)?;
        }
        Ok(())
    }
}

impl FromStr for OrientCode {
    type Err = String;

    /// Three letters, one from each of R/L, A/P, S/I, any order, any
    /// case. Refused codes get one line naming the flag, the valid letters
    /// and the rule.
    fn from_str(s: &str) -> Result<OrientCode, String> {
        let shown = if s.is_empty() { "''" } else { s };
        let n = s.chars().count();
        if n != 3 {
            return Err(format!("--orient {shown}: {n} letters; {RULE}"));
        }
        let mut letters = [0u8; 3];
        let mut seen: [Option<u8>; 3] = [None; 3];
        for (i, ch) in s.chars().enumerate() {
            let up = ch.to_ascii_uppercase();
            let axis = u8::try_from(up).ok().and_then(letter_axis);
            let Some((w, _)) = axis else {
                return Err(format!(
                    "--orient {shown}: {ch} is not one of R, L, A, P, S, I; {RULE}"
                ));
            };
            let up = up as u8;
            if let Some(prev) = seen[w] {
                return Err(format!(
                    "--orient {shown}: {} and {} both name the {} axis; {RULE}",
                    prev as char, up as char, AXIS_NAMES[w]
                ));
            }
            seen[w] = Some(up);
            letters[i] = up;
        }
        Ok(OrientCode(letters))
    }
}

/// How an orientation maps the input onto the output: output index axis
/// `a` reads input axis `axes[a]`, mirrored when `flip[a]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientPlan {
    /// The input axis each output axis reads.
    pub axes: [usize; 3],
    /// Whether each output axis runs against its input axis.
    pub flip: [bool; 3],
    /// The grid read.
    pub input: Grid,
    /// The grid written: dims and spacing permuted, direction columns
    /// permuted and negated, origin at the input voxel that becomes
    /// output voxel (0, 0, 0).
    pub output: Grid,
}

impl OrientPlan {
    /// Whether the output is the input (no axis moves or flips).
    pub fn is_identity(&self) -> bool {
        self.axes == [0, 1, 2] && self.flip == [false; 3]
    }

    /// The input voxel that output voxel `out` holds (`out` inside the
    /// output's dims).
    pub fn input_index(&self, out: [u64; 3]) -> [u64; 3] {
        let n = dims3(self.input.dims);
        let mut ijk = [0u64; 3];
        for ((&b, &f), &t) in self.axes.iter().zip(&self.flip).zip(&out) {
            ijk[b] = if f {
                n[b].saturating_sub(1).saturating_sub(t)
            } else {
                t
            };
        }
        ijk
    }
}

/// Dims as an array, axis by axis.
fn dims3(d: Dims) -> [u64; 3] {
    [d.x, d.y, d.z]
}

/// The plan that makes `input`'s index axes point as `code` says (see
/// the module docs for how axes are matched; the same as SimpleITK's
/// `DICOMOrient`).
pub fn plan(input: &Grid, code: OrientCode) -> OrientPlan {
    let given = OrientCode::of_direction(&input.geometry.direction);
    let mut axes = [0, 1, 2];
    let mut flip = [false; 3];
    for a in 0..3 {
        let (w, pos) = code.axis(a);
        for b in 0..3 {
            let (gw, gpos) = given.axis(b);
            if gw == w {
                axes[a] = b;
                flip[a] = gpos != pos;
            }
        }
    }
    let n = dims3(input.dims);
    // The input voxel that becomes output (0, 0, 0): the far end of
    // every flipped axis.
    let mut corner = [0.0f64; 3];
    for a in 0..3 {
        if flip[a] {
            corner[axes[a]] = n[axes[a]].saturating_sub(1) as f64;
        }
    }
    let mut geometry = input.geometry;
    geometry.origin = input.world(corner);
    for a in 0..3 {
        let sign = if flip[a] { -1.0 } else { 1.0 };
        for r in 0..3 {
            // `+ 0.0` turns -0 into 0 (printed as such).
            geometry.direction[r][a] = sign * input.geometry.direction[r][axes[a]] + 0.0;
        }
    }
    let out_n: [u64; 3] = std::array::from_fn(|a| n[axes[a]]);
    let output = Grid {
        dims: Dims {
            x: out_n[0],
            y: out_n[1],
            z: out_n[2],
        },
        spacing: std::array::from_fn(|a| input.spacing[axes[a]]),
        geometry,
    };
    OrientPlan {
        axes,
        flip,
        input: *input,
        output,
    }
}

/// Where one output coordinate along an output axis reads: the input
/// slice it adds and the offset inside the slice it adds.
#[derive(Clone, Copy, Debug, Default)]
struct Step {
    z: u64,
    off: usize,
}

/// Output rows gathered together when x moves across input rows or
/// slices: one input cache line then serves several output rows.
const BLOCK: usize = 16;

/// The orientation stage: an exact permutation and mirroring of the
/// input's axes (see the module docs). Values are copied, never
/// computed; the border rule does not arise.
pub struct Orient {
    plan: OrientPlan,
    /// Per output x, per output y: where it reads.
    xs: Vec<Step>,
    ys: Vec<Step>,
}

impl Orient {
    /// The stage that orients `input` as `code` says, or `None` when
    /// `input` is already so oriented (the caller adds no stage).
    pub fn new(input: Grid, code: OrientCode) -> Option<Orient> {
        let plan = plan(&input, code);
        if plan.is_identity() {
            return None;
        }
        let steps = |a: usize| -> Vec<Step> {
            let n = dims3(plan.output.dims)[a];
            (0..n).map(|t| step(&plan, a, t)).collect()
        };
        let xs = steps(0);
        let ys = steps(1);
        Some(Orient { plan, xs, ys })
    }

    /// The plan this stage carries out.
    pub fn plan(&self) -> &OrientPlan {
        &self.plan
    }
}

/// Where output coordinate `t` along output axis `a` reads.
fn step(plan: &OrientPlan, a: usize, t: u64) -> Step {
    let n = dims3(plan.input.dims);
    let b = plan.axes[a];
    let v = if plan.flip[a] {
        n[b].saturating_sub(1).saturating_sub(t)
    } else {
        t
    };
    match b {
        0 => Step {
            z: 0,
            off: v as usize,
        },
        1 => Step {
            z: 0,
            off: (v * n[0]) as usize,
        },
        _ => Step { z: v, off: 0 },
    }
}

impl Stage for Orient {
    fn name(&self) -> &str {
        "orient"
    }

    fn output(&self) -> Grid {
        self.plan.output
    }

    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        let nz = self.plan.input.dims.z;
        if self.plan.axes[2] != 2 {
            return 0..nz;
        }
        let end = zs.end.min(nz);
        let start = zs.start.min(end);
        if self.plan.flip[2] {
            nz - end..nz - start
        } else {
            start..end
        }
    }

    fn window(&self) -> u64 {
        if self.plan.axes[2] == 2 {
            1
        } else {
            self.plan.input.dims.z
        }
    }

    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        let c = step(&self.plan, 2, z);
        let nxo = self.xs.len();
        if self.plan.axes[0] == 0 {
            // Output x walks an input row: copy rows (reversed when x flips).
            for (y, dst) in out.chunks_exact_mut(nxo).enumerate() {
                let r = self.ys[y];
                let start = c.off + r.off;
                let row = &input.slice(c.z + r.z)[start..start + nxo];
                if self.plan.flip[0] {
                    for (d, s) in dst.iter_mut().zip(row.iter().rev()) {
                        *d = *s;
                    }
                } else {
                    dst.copy_from_slice(row);
                }
            }
        } else if self.plan.axes[1] == 0 {
            // Output y walks an input row (a transpose): for a block of
            // output rows, each output x reads one run of an input row.
            let flip_y = self.plan.flip[1];
            for (bi, block) in out.chunks_mut(BLOCK * nxo).enumerate() {
                let rows = block.len() / nxo;
                let ys = &self.ys[bi * BLOCK..bi * BLOCK + rows];
                let lo = if flip_y { ys[rows - 1].off } else { ys[0].off };
                for (x, st) in self.xs.iter().enumerate() {
                    let start = c.off + st.off + lo;
                    let run = &input.slice(c.z + st.z)[start..start + rows];
                    let dst = block[x..].iter_mut().step_by(nxo);
                    if flip_y {
                        for (d, v) in dst.zip(run.iter().rev()) {
                            *d = *v;
                        }
                    } else {
                        for (d, v) in dst.zip(run) {
                            *d = *v;
                        }
                    }
                }
            }
        } else if self.plan.axes[0] == 1 {
            // Output x walks an input column, output y the slices: gather
            // blocks of output rows, each row from its own slice.
            let mut src: [(&[f32], usize); BLOCK] = [(&[], 0); BLOCK];
            for (bi, block) in out.chunks_mut(BLOCK * nxo).enumerate() {
                let rows = block.len() / nxo;
                for (r, s) in src.iter_mut().enumerate().take(rows) {
                    let st = self.ys[bi * BLOCK + r];
                    *s = (input.slice(c.z + st.z), c.off + st.off);
                }
                for (x, st) in self.xs.iter().enumerate() {
                    for (r, &(sl, base)) in src.iter().enumerate().take(rows) {
                        block[r * nxo + x] = sl[base + st.off];
                    }
                }
            }
        } else {
            // Output x walks the input slices, output y an input column:
            // look each slice up once, then gather blocks of output rows.
            let slices: Vec<&[f32]> = self.xs.iter().map(|st| input.slice(st.z)).collect();
            for (bi, block) in out.chunks_mut(BLOCK * nxo).enumerate() {
                let rows = block.len() / nxo;
                let ys = &self.ys[bi * BLOCK..bi * BLOCK + rows];
                for (x, sl) in slices.iter().enumerate() {
                    for (r, st) in ys.iter().enumerate() {
                        block[r * nxo + x] = sl[c.off + st.off];
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{Chain, Source};
    use volcore::Geometry;

    /// A 3x4x5 grid whose axes point (in LPS) to A, L, I (a permuted,
    /// flipped axis-aligned direction), with anisotropic spacing and a
    /// non-zero origin.
    fn grid() -> Grid {
        let g = Geometry::from_axes(
            [10.0, -5.0, 3.0],
            [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
        )
        .unwrap();
        Grid {
            dims: Dims::new(3, 4, 5).unwrap(),
            spacing: [0.5, 0.7, 2.0],
            geometry: g,
        }
    }

    /// Voxel values = their linear index.
    fn values(d: Dims) -> Vec<Vec<f32>> {
        (0..d.z)
            .map(|k| {
                (0..d.slice_len())
                    .map(|i| (k * d.slice_len() + i) as f32)
                    .collect()
            })
            .collect()
    }

    /// The stage's output, all slices, run through a chain.
    fn oriented(input: Grid, stage: Orient) -> Vec<Vec<f32>> {
        let src = values(input.dims);
        let source: Source<'_, String> =
            Box::new(move |zs: Range<u64>| Ok(zs.map(|z| src[z as usize].clone()).collect()));
        let out = stage.output();
        let dir = std::env::temp_dir();
        let mut chain = Chain::new(input, source, vec![Box::new(stage)], &dir);
        // Ask slice by slice, upwards, as a writer does.
        (0..out.dims.z)
            .map(|z| chain.slices(z..z + 1).unwrap().slice(z).to_vec())
            .collect()
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-9)
    }

    #[test]
    fn all_48_codes_move_every_voxel_to_its_place() {
        // Also an identity-direction grid, and one larger than the
        // gather's block of 16 rows along every axis but z (and not a
        // multiple of it).
        let mut id = grid();
        id.geometry = Geometry::IDENTITY;
        let mut big = grid();
        big.dims = Dims::new(17, 35, 6).unwrap();
        for input in [grid(), id, big] {
            let n = input.dims;
            for code in OrientCode::all() {
                let p = plan(&input, code);
                let out = p.output;
                assert_eq!(out.geometry.orientation(), code.to_string(), "{code}");
                assert_eq!(OrientCode::of_direction(&out.geometry.direction), code);
                assert_eq!(out.dims.count(), n.count());
                let Some(stage) = Orient::new(input, code) else {
                    assert!(p.is_identity(), "{code}");
                    assert_eq!(input.geometry.orientation(), code.to_string());
                    continue;
                };
                assert_eq!(stage.window(), if p.axes[2] == 2 { 1 } else { n.z });
                let slices = oriented(input, stage);
                for k in 0..out.dims.z {
                    for j in 0..out.dims.y {
                        for i in 0..out.dims.x {
                            let src = p.input_index([i, j, k]);
                            let want = (src[0] + n.x * (src[1] + n.y * src[2])) as f32;
                            let got = slices[k as usize][(i + out.dims.x * j) as usize];
                            assert_eq!(got, want, "{code} at {i},{j},{k}");
                            let w = [i as f64, j as f64, k as f64];
                            let s = src.map(|v| v as f64);
                            assert!(close(out.world(w), input.world(s)), "{code} at {w:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_identity_plan_adds_no_stage() {
        let g = grid();
        let own = OrientCode::of_direction(&g.geometry.direction);
        assert_eq!(own.to_string(), "ALI");
        assert!(Orient::new(g, own).is_none());
        assert!(Orient::new(g, "ali".parse().unwrap()).is_none());
        let mut id = g;
        id.geometry = Geometry::IDENTITY;
        assert!(Orient::new(id, OrientCode::LPS).is_none());
        assert!(Orient::new(id, "RAS".parse().unwrap()).is_some());
    }

    #[test]
    fn codes_parse_in_any_order_and_case() {
        let all = OrientCode::all();
        assert_eq!(all.len(), 48);
        let mut names: Vec<String> = all.iter().map(|c| c.to_string()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), 48);
        for c in &all {
            let s = c.to_string();
            assert_eq!(s.parse::<OrientCode>().unwrap(), *c);
            assert_eq!(s.to_lowercase().parse::<OrientCode>().unwrap(), *c);
        }
        assert_eq!("pIr".parse::<OrientCode>().unwrap().to_string(), "PIR");
    }

    #[test]
    fn bad_codes_are_refused_with_the_rule() {
        let err = |s: &str| s.parse::<OrientCode>().unwrap_err();
        assert_eq!(
            err("RRS"),
            "--orient RRS: R and R both name the left-right axis; \
             use three letters, one each from R/L, A/P, S/I, e.g. RAS or LPS"
        );
        assert!(err("rls").contains("R and L both name the left-right axis"));
        assert!(err("SAI").contains("S and I both name the superior-inferior axis"));
        assert!(err("RA").starts_with("--orient RA: 2 letters;"));
        assert!(err("RASL").starts_with("--orient RASL: 4 letters;"));
        assert!(err("").starts_with("--orient '': 0 letters;"));
        assert!(err("RAX").starts_with("--orient RAX: X is not one of R, L, A, P, S, I;"));
        assert!(err("RAé").contains("é is not one of"));
        for s in ["RRS", "RA", "RAX", "", "RAé", "XYZ"] {
            assert!(err(s).contains("one each from R/L, A/P, S/I"), "{s}");
        }
    }

    #[test]
    fn oblique_inputs_pick_the_nearest_axes_as_itk_does() {
        // (Expected codes checked against SimpleITK 2.5's
        // DICOMOrientImageFilter.GetOrientationFromDirectionCosines.)
        // Axes 40° from x and y: each still nearest its own.
        let (s, c) = 40f64.to_radians().sin_cos();
        let d = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(OrientCode::of_direction(&d).to_string(), "LPS");
        // Columns 0 and 1 both nearest x: a per-column choice would name
        // x twice; the greedy one takes the largest entry (0.9, x of
        // column 1) first and leaves y to column 0.
        let d = [[0.8, 0.9, 0.0], [0.6, 0.1, 0.0], [0.0, 0.0, -1.0]];
        assert_eq!(OrientCode::of_direction(&d).to_string(), "PLI");
        // Ties go to the last entry in row-major order, as in ITK: x of
        // column 1 before x of column 0.
        let d = [[0.9, 0.9, 0.0], [0.5, 0.1, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(OrientCode::of_direction(&d).to_string(), "PLS");
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let d = [[h, -h, 0.0], [h, h, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(OrientCode::of_direction(&d).to_string(), "LPS");
    }

    #[test]
    fn needs_maps_z_and_reads_everything_when_z_moves() {
        let g = grid(); // ALI
        let o = Orient::new(g, "ALS".parse().unwrap()).unwrap();
        assert_eq!(o.needs(0..2), 3..5);
        assert_eq!(o.needs(4..5), 0..1);
        assert_eq!(o.window(), 1);
        let o = Orient::new(g, "ARI".parse().unwrap()).unwrap();
        assert_eq!(o.needs(1..3), 1..3);
        let o = Orient::new(g, "AIL".parse().unwrap()).unwrap();
        assert_eq!(o.needs(1..2), 0..5);
        assert_eq!(o.window(), 5);
    }
}
