//! The statistics against straightforward computations on the samples
//! held in memory.

use super::*;
use crate::reader::{Access, CResult, InputInfo, MemoryReader, SliceReader};
use std::sync::atomic::{AtomicU64, Ordering};
use volcore::{Dims, Geometry};

/// A reader over `all` (x fastest) split into slices of `dims`.
fn memory(name: &str, dims: Dims, all: SliceData) -> MemoryReader {
    let n = dims.slice_len() as usize;
    let slices = (0..dims.z as usize)
        .map(|z| all.gather(z * n..(z + 1) * n))
        .collect();
    MemoryReader::from_slices(Path::new(name), dims, slices, None, Geometry::IDENTITY).unwrap()
}

/// A memory reader that insists on being read front to back, once.
struct Sequential {
    inner: MemoryReader,
    next: AtomicU64,
}

impl SliceReader for Sequential {
    fn info(&self) -> &InputInfo {
        self.inner.info()
    }
    fn access(&self) -> Access {
        Access::Sequential
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        assert_eq!(self.next.fetch_add(1, Ordering::SeqCst), z, "out of order");
        self.inner.read_slice_into(z, reuse)
    }
    fn bytes_in(&self) -> u64 {
        0
    }
}

/// Statistics of `values` (with `mask`, `labels`) read from memory, or
/// as sequential streams.
fn stats_of(
    dims: Dims,
    values: &SliceData,
    mask: Option<&SliceData>,
    labels: Option<&SliceData>,
    sequential: bool,
) -> Result<Stats, StatsError> {
    let open = |name: &'static str, s: &SliceData| {
        let (dims, s) = (dims, s.clone());
        move || -> CResult<Box<dyn SliceReader>> {
            let r = memory(name, dims, s.clone());
            Ok(if sequential {
                Box::new(Sequential {
                    inner: r,
                    next: AtomicU64::new(0),
                })
            } else {
                Box::new(r)
            })
        }
    };
    let v = open("v", values);
    let m = mask.map(|m| open("m", m));
    let l = labels.map(|l| open("l", l));
    let inputs = Inputs {
        values: &v,
        mask: m.as_ref().map(|m| m as &dyn Opener),
        labels: l.as_ref().map(|l| l as &dyn Opener),
    };
    compute(&inputs, &Options::default(), &|_| {})
}

/// Neumaier's compensated sum: another method than the pairwise sums
/// under test, about as accurate as the data allow.
fn compensated(xs: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut c) = (0.0f64, 0.0f64);
    for x in xs {
        let t = sum + x;
        c += if sum.abs() >= x.abs() {
            (sum - t) + x
        } else {
            (x - t) + sum
        };
        sum = t;
    }
    sum + c
}

/// Mean and population SD of `xs` by the textbook two-pass formulas,
/// summed with compensation.
fn reference(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = compensated(xs.iter().copied()) / n;
    let var = compensated(xs.iter().map(|x| (x - mean) * (x - mean))) / n;
    (mean, var.sqrt())
}

fn assert_close(a: f64, b: f64, what: &str) {
    let tol = 1e-12 * a.abs().max(b.abs()).max(1e-300);
    assert!((a - b).abs() <= tol, "{what}: {a} against {b}");
}

/// Check `s` against the finite values `xs` of the set.
fn check(s: &Stats, xs: &[f64], what: &str) {
    let mut sorted = xs.to_vec();
    sorted.sort_by(|a, b| a.total_cmp(b));
    assert_eq!(s.moments.count, xs.len() as u64, "{what}");
    let (mean, sd) = reference(xs);
    assert_close(s.moments.mean().unwrap(), mean, what);
    assert_close(s.moments.sd(DDOF).unwrap(), sd, what);
    assert_eq!(
        s.moments.range(),
        Some((sorted[0], *sorted.last().unwrap())),
        "{what}"
    );
    for &(p, v) in &s.percentiles {
        let (lo, hi, g) = select::position(xs.len() as u64, p);
        let want = select::lerp(sorted[lo as usize], sorted[hi as usize], g);
        assert_eq!(v, want, "{what}: p{p}");
    }
    assert_eq!(s.percentiles.len(), PERCENTILES.len());
    let h = s.histogram.as_ref().unwrap();
    assert_eq!(h.total(), xs.len() as u64, "{what}");
}

fn random_volume(t: SliceType, n: usize, rng: &mut fastrand::Rng) -> SliceData {
    match t {
        SliceType::U8 => SliceData::U8((0..n).map(|_| rng.u8(..)).collect()),
        SliceType::I8 => SliceData::I8((0..n).map(|_| rng.i8(..)).collect()),
        SliceType::U16 => SliceData::U16((0..n).map(|_| rng.u16(..)).collect()),
        SliceType::I16 => SliceData::I16((0..n).map(|_| rng.i16(-3000..3000)).collect()),
        SliceType::U32 => SliceData::U32((0..n).map(|_| rng.u32(..)).collect()),
        SliceType::I32 => SliceData::I32((0..n).map(|_| rng.i32(..)).collect()),
        SliceType::F32 => SliceData::F32((0..n).map(|_| rng.f32() * 2e3 - 5e2).collect()),
        SliceType::F64 => SliceData::F64((0..n).map(|_| 1e6 + rng.f64() * 1e-3).collect()),
    }
}

fn all_values(s: &SliceData) -> Vec<f64> {
    (0..s.len()).map(|i| s.value(i)).collect()
}

const TYPES: [SliceType; 8] = [
    SliceType::U8,
    SliceType::I8,
    SliceType::U16,
    SliceType::I16,
    SliceType::U32,
    SliceType::I32,
    SliceType::F32,
    SliceType::F64,
];

#[test]
fn every_type_matches_a_plain_computation() {
    let mut rng = fastrand::Rng::with_seed(53);
    // Slices of 1 << 14: several blocks of 64 slices.
    let dims = Dims::new(128, 128, 70).unwrap();
    for t in TYPES {
        let v = random_volume(t, dims.count() as usize, &mut rng);
        let s = stats_of(dims, &v, None, None, false).unwrap();
        assert_eq!(s.sample_type, t);
        assert_eq!(s.counts.voxels, dims.count());
        check(&s, &all_values(&v), t.name());
        // Read as a stream: the same figures.
        let q = stats_of(dims, &v, None, None, true).unwrap();
        assert_eq!(q, s, "{t}");
    }
}

#[test]
fn percentiles_of_few_and_repeated_values_are_exact() {
    let dims = Dims::new(5, 1, 1).unwrap();
    for v in [
        SliceData::F64(vec![1.0, 2.0, 3.0, 4.0, 10.0]),
        SliceData::F32(vec![-0.5, -0.5, -0.5, 7.25, 7.25]),
        SliceData::I32(vec![i32::MIN, -1, 0, 1, i32::MAX]),
        SliceData::U16(vec![9, 9, 9, 9, 9]),
    ] {
        let s = stats_of(dims, &v, None, None, false).unwrap();
        check(&s, &all_values(&v), &format!("{v:?}"));
    }
    // np.percentile([1, 2, 3, 4, 10], [1, 50, 99]) = [1.04, 3, 9.76]
    let s = stats_of(
        dims,
        &SliceData::U8(vec![4, 1, 10, 3, 2]),
        None,
        None,
        false,
    )
    .unwrap();
    let p: Vec<f64> = s.percentiles.iter().map(|p| p.1).collect();
    assert!(
        (p[0] - 1.04).abs() < 1e-12 && p[3] == 3.0 && (p[6] - 9.76).abs() < 1e-12,
        "{p:?}"
    );
}

#[test]
fn nan_and_infinities_are_counted_apart() {
    let dims = Dims::new(3, 2, 1).unwrap();
    let v = SliceData::F32(vec![
        1.0,
        f32::NAN,
        3.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        5.0,
    ]);
    let s = stats_of(dims, &v, None, None, false).unwrap();
    assert_eq!(
        s.counts,
        Counts {
            voxels: 6,
            nan: 1,
            infinite: 2
        }
    );
    check(&s, &[1.0, 3.0, 5.0], "nan");
    assert_eq!(s.histogram.as_ref().unwrap().nan_count(), 1);
    // Nothing finite: counts, and nothing else.
    let v = SliceData::F64(vec![f64::NAN; 6]);
    let s = stats_of(dims, &v, None, None, false).unwrap();
    assert_eq!((s.counts.voxels, s.counts.nan), (6, 6));
    assert_eq!((s.moments.mean(), s.moments.sd(DDOF)), (None, None));
    assert!(s.percentiles.is_empty() && s.histogram.is_none());
}

#[test]
fn a_mask_keeps_its_non_zero_voxels_and_an_empty_one_gives_no_figures() {
    let mut rng = fastrand::Rng::with_seed(5);
    let dims = Dims::new(40, 30, 20).unwrap();
    let n = dims.count() as usize;
    let v = random_volume(SliceType::I16, n, &mut rng);
    let keep: Vec<u8> = (0..n).map(|_| rng.u8(..4) / 3).collect();
    let s = stats_of(dims, &v, Some(&SliceData::U8(keep.clone())), None, false).unwrap();
    let xs: Vec<f64> = (0..n)
        .filter(|&i| keep[i] != 0)
        .map(|i| v.value(i))
        .collect();
    assert_eq!(s.counts.voxels, xs.len() as u64);
    check(&s, &xs, "mask");
    let none = SliceData::F32(vec![0.0; n]);
    let s = stats_of(dims, &v, Some(&none), None, false).unwrap();
    assert_eq!(s.counts, Counts::default());
    assert_eq!(s.moments.mean(), None);
    assert!(s.percentiles.is_empty() && s.histogram.is_none());
}

#[test]
fn labels_get_their_own_figures() {
    let mut rng = fastrand::Rng::with_seed(9);
    let dims = Dims::new(33, 17, 9).unwrap();
    let n = dims.count() as usize;
    let v = random_volume(SliceType::F64, n, &mut rng);
    // Labels 0, 2 and 1000 as f32 whole numbers; a mask drops some voxels.
    let labels: Vec<f32> = (0..n).map(|i| [0.0, 2.0, 1000.0][i * 7 % 3]).collect();
    let keep: Vec<u8> = (0..n).map(|i| (i % 5 != 0) as u8).collect();
    let s = stats_of(
        dims,
        &v,
        Some(&SliceData::U8(keep.clone())),
        Some(&SliceData::F32(labels.clone())),
        false,
    )
    .unwrap();
    let got = s.labels.as_ref().unwrap();
    assert_eq!(
        got.iter().map(|l| l.label).collect::<Vec<_>>(),
        [0, 2, 1000]
    );
    for l in got {
        let xs: Vec<f64> = (0..n)
            .filter(|&i| keep[i] != 0 && labels[i] as i64 == l.label)
            .map(|i| v.value(i))
            .collect();
        assert_eq!(l.counts.voxels, xs.len() as u64);
        let (mean, sd) = reference(&xs);
        assert_close(l.moments.mean().unwrap(), mean, "label mean");
        assert_close(l.moments.sd(DDOF).unwrap(), sd, "label sd");
        assert_eq!(l.volume([0.5, 2.0, 3.0]), 3.0 * xs.len() as f64);
    }
    let total: u64 = got.iter().map(|l| l.counts.voxels).sum();
    assert_eq!(total, s.counts.voxels);
}

#[test]
fn bad_labels_and_mismatched_dims_are_refused() {
    let dims = Dims::new(4, 4, 2).unwrap();
    let v = SliceData::U8(vec![1; 32]);
    let mut frac = vec![1.0f32; 32];
    frac[20] = 2.5;
    let e = stats_of(dims, &v, None, Some(&SliceData::F32(frac)), false).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("l: label value 2.5 is not a whole number"),
        "{e}"
    );
    let e = stats_of(
        dims,
        &v,
        None,
        Some(&SliceData::F64(vec![f64::NAN; 32])),
        false,
    )
    .unwrap_err();
    assert!(e.to_string().contains("NaN is not a whole number"), "{e}");
    // Too many labels: every voxel its own, past the limit.
    let big = Dims::new(300, 300, 1).unwrap();
    let many = SliceData::U32((0..90_000).collect());
    let e = stats_of(
        big,
        &SliceData::U8(vec![0; 90_000]),
        None,
        Some(&many),
        false,
    )
    .unwrap_err();
    assert!(matches!(e, StatsError::TooManyLabels(_)), "{e}");
    assert!(e.to_string().starts_with("l: more than 65536"), "{e}");
    // A mask of other dims: a mismatch naming both.
    let mask = memory("m", Dims::new(4, 4, 3).unwrap(), SliceData::U8(vec![1; 48]));
    let mask = std::sync::Mutex::new(Some(mask));
    let open_mask =
        || -> CResult<Box<dyn SliceReader>> { Ok(Box::new(mask.lock().unwrap().take().unwrap())) };
    let open_v = || -> CResult<Box<dyn SliceReader>> { Ok(Box::new(memory("v", dims, v.clone()))) };
    let inputs = Inputs {
        values: &open_v,
        mask: Some(&open_mask),
        labels: None,
    };
    let e = compute(&inputs, &Options::default(), &|_| {}).unwrap_err();
    assert!(matches!(e, StatsError::Mismatch(_)));
    assert_eq!(
        e.to_string(),
        "m: the mask has 4x4x3 voxels but v has 4x4x2: they must match"
    );
}

#[test]
fn figures_do_not_depend_on_the_thread_count() {
    let mut rng = fastrand::Rng::with_seed(11);
    let dims = Dims::new(256, 64, 300).unwrap();
    let n = dims.count() as usize;
    let v = random_volume(SliceType::F32, n, &mut rng);
    let labels = SliceData::U8((0..n).map(|i| (i / 5000 % 7) as u8).collect());
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| stats_of(dims, &v, None, Some(&labels), false).unwrap())
    };
    let one = run(1);
    for threads in [2, 3, 8] {
        assert_eq!(run(threads), one, "{threads} threads");
    }
}

#[test]
fn histograms_follow_the_vidx_rule() {
    // u8: one bin per value.
    let dims = Dims::new(4, 1, 1).unwrap();
    let s = stats_of(dims, &SliceData::U8(vec![0, 3, 3, 255]), None, None, false).unwrap();
    let h = s.histogram.unwrap();
    assert_eq!((h.lo(), h.hi(), h.bins()), (0.0, 256.0, 256));
    assert_eq!((h.counts()[3], h.counts()[255]), (2, 1));
    // i32: integer widths from the minimum.
    let s = stats_of(
        dims,
        &SliceData::I32(vec![10, 11, 1009, 500]),
        None,
        None,
        false,
    )
    .unwrap();
    let h = s.histogram.unwrap();
    assert_eq!((h.lo(), h.hi(), h.bins()), (10.0, 1010.0, 250));
    assert_eq!((h.counts()[0], h.counts()[249]), (2, 1));
    // f64: 256 bins over the finite range.
    let s = stats_of(
        dims,
        &SliceData::F64(vec![-1.0, 0.0, 0.5, 3.0]),
        None,
        None,
        false,
    )
    .unwrap();
    let h = s.histogram.unwrap();
    assert_eq!(
        (h.lo(), h.hi(), h.bins(), h.counts()[255]),
        (-1.0, 3.0, 256, 1)
    );
}
