//! Round trips and malformed-input checks across the formats.

use crate::output::Sink;
use crate::{raw, thesis, vvol};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use volcore::scene::{NoiseKind, NoiseScene, SceneSource, ShapesScene};
use volcore::volume::TypedGrid;
use volcore::{
    BrickGeometry, Compression, Data, Dims, Layout, RegionSource, SampleType, SlicedGrid, Volume,
    VolumeMeta,
};

fn no_progress(_: u64) {}

fn meta(dims: Dims, t: SampleType, layout: Layout, c: Compression) -> VolumeMeta {
    VolumeMeta {
        dims,
        spacing: [1.0, 0.5, 2.0],
        sample_type: t,
        range: volcore::ValueRange::EMPTY,
        layout,
        compression: c,
        geometry: volcore::Geometry::IDENTITY,
        narrowed: None,
    }
}

fn write_file<R: RegionSource>(src: &R, m: VolumeMeta, path: &Path) {
    let mut f = std::fs::File::create(path).unwrap();
    vvol::write(src, m, Sink::File(&mut f), &no_progress).unwrap();
}

/// One volume in every layout: sliced, bricked and zstd-bricked `.vvol`
/// files, and a z-fastest sliced array in memory.
fn layout_copies<T: volcore::volume::IntoVolumeData>(
    dir: &Path,
    dims: Dims,
    brick: u32,
) -> Vec<Volume> {
    let scene = NoiseScene::new(dims, 9, NoiseKind::Gradient, 5.0, 3, 1000.0);
    let src = SceneSource::<T>::new(&scene);
    let g = BrickGeometry::new(dims, brick).unwrap();
    let forms = [
        (Layout::Sliced, Compression::None),
        (Layout::Bricked(g), Compression::None),
        (Layout::Bricked(g), Compression::Zstd(3)),
    ];
    let mut copies: Vec<Volume> = forms
        .iter()
        .enumerate()
        .map(|(i, &(l, c))| {
            let p = dir.join(format!("v{i}-{}-{dims}-{brick}.vvol", T::TYPE));
            write_file(&src, meta(dims, T::TYPE, l, c), &p);
            vvol::open(
                &p,
                vvol::OpenOptions {
                    verify: true,
                    ..Default::default()
                },
            )
            .unwrap()
        })
        .collect();
    let x_fastest = volcore::region::pack_sliced(&src);
    let mut z_fastest = vec![T::default(); x_fastest.len()];
    let [sx, sy, sz] = volcore::SliceOrder::ZFastest.strides(dims);
    for z in 0..dims.z {
        for y in 0..dims.y {
            for x in 0..dims.x {
                z_fastest[(x * sx + y * sy + z * sz) as usize] =
                    x_fastest[dims.index(x, y, z) as usize];
            }
        }
    }
    let grid = SlicedGrid::with_order(dims, volcore::SliceOrder::ZFastest, Data::Owned(z_fastest))
        .unwrap();
    copies.push(Volume {
        meta: copies[0].meta,
        data: T::into_data(TypedGrid::Sliced(grid)),
    });
    copies
}

fn random_points(dims: Dims, n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let d = dims.as_array().map(|v| v as f32);
    let mut pts: Vec<[f32; 3]> = (0..n)
        .map(|_| std::array::from_fn(|a| rng.f32() * (d[a] + 2.0) - 1.0))
        .collect();
    // Far faces, corners and brick seams exactly.
    pts.push([d[0] - 1.0, d[1] - 1.0, d[2] - 1.0]);
    pts.push([0.0, 0.0, 0.0]);
    for s in [3.0, 4.0, 7.0, 8.0, 7.5, 3.999] {
        pts.push([s, s.min(d[1] - 1.0), s.min(d[2] - 1.0)]);
    }
    pts
}

#[test]
fn layouts_sample_identically_for_every_type() {
    let dir = tempfile::tempdir().unwrap();
    for (dims, brick) in [
        (Dims::new(19, 13, 11).unwrap(), 4),
        (Dims::new(1, 9, 9).unwrap(), 4),
        (Dims::new(1, 1, 1).unwrap(), 2),
        (Dims::new(33, 17, 8).unwrap(), 16),
    ] {
        let vols: Vec<Vec<Volume>> = vec![
            layout_copies::<u8>(dir.path(), dims, brick),
            layout_copies::<u16>(dir.path(), dims, brick),
            layout_copies::<i16>(dir.path(), dims, brick),
            layout_copies::<f32>(dir.path(), dims, brick),
        ];
        for copies in &vols {
            let reference = copies[0].to_f32_vec();
            assert_eq!(reference.len() as u64, dims.count());
            for v in &copies[1..] {
                let got = v.to_f32_vec();
                let bad = got
                    .iter()
                    .zip(&reference)
                    .position(|(a, b)| a.to_bits() != b.to_bits());
                assert!(
                    bad.is_none(),
                    "{}: first difference at sample {bad:?}",
                    v.meta
                );
                assert_eq!(v.meta.range, copies[0].meta.range);
                for p in random_points(dims, 500, 1) {
                    let a = copies[0].trilinear(p);
                    let b = v.trilinear(p);
                    assert_eq!(a.to_bits(), b.to_bits(), "{} at {p:?}", v.meta);
                }
            }
        }
    }
}

/// Every interior cell's [`volcore::Cursor::cross_diffs`], flattened, and
/// the same differences of the six cells fetched one by one with `cell`.
fn crosses(v: &Volume) -> (Vec<f32>, Vec<f32>) {
    struct Cross;
    impl volcore::VolumeVisitor for Cross {
        type Output = (Vec<f32>, Vec<f32>);
        fn visit<S: volcore::VoxelSource>(self, src: &S) -> Self::Output {
            use volcore::Cursor;
            let d = src.dims();
            let mut cur = src.cursor();
            let (mut fast, mut slow) = (Vec::new(), Vec::new());
            for k in 1..d.z.saturating_sub(2) {
                for j in 1..d.y.saturating_sub(2) {
                    for i in 1..d.x.saturating_sub(2) {
                        fast.extend(cur.cross_diffs(i, j, k).into_iter().flatten());
                        for (hi, lo) in [
                            ((i + 1, j, k), (i - 1, j, k)),
                            ((i, j + 1, k), (i, j - 1, k)),
                            ((i, j, k + 1), (i, j, k - 1)),
                        ] {
                            let a = cur.cell(hi.0, hi.1, hi.2);
                            let b = cur.cell(lo.0, lo.1, lo.2);
                            slow.extend((0..8).map(|c| a[c] - b[c]));
                        }
                    }
                }
            }
            (fast, slow)
        }
    }
    v.visit(Cross)
}

#[test]
fn cross_diffs_match_single_cells_in_every_layout() {
    let dir = tempfile::tempdir().unwrap();
    // Brick edge 4 puts many crosses against brick seams.
    let dims = Dims::new(19, 13, 11).unwrap();
    for copies in [
        layout_copies::<u8>(dir.path(), dims, 4),
        layout_copies::<i16>(dir.path(), dims, 4),
        layout_copies::<f32>(dir.path(), dims, 4),
    ] {
        let (reference, _) = crosses(&copies[0]);
        assert_eq!(reference.len(), 16 * 10 * 8 * 24);
        for v in &copies {
            let (fast, slow) = crosses(v);
            let bits = |x: &[f32]| x.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&fast), bits(&slow), "{}", v.meta);
            assert_eq!(bits(&fast), bits(&reference), "{}", v.meta);
        }
    }
}

#[test]
fn headers_round_trip() {
    let dims = Dims::new(40, 30, 20).unwrap();
    let g = BrickGeometry::new(dims, 8).unwrap();
    for t in SampleType::ALL {
        for (l, c) in [
            (Layout::Sliced, Compression::None),
            (Layout::Bricked(g), Compression::None),
            (Layout::Bricked(g), Compression::Zstd(-3)),
        ] {
            let mut m = meta(dims, t, l, c);
            m.range = volcore::ValueRange {
                min: -2.0,
                max: 9.5,
            };
            let h = vvol::Header::for_meta(m).unwrap();
            assert_eq!(vvol::Header::decode(&h.encode()).unwrap(), h);
        }
    }
    let th = thesis::ThesisHeader {
        dims,
        spacing: [1.0, 2.0, 3.0],
        layout: thesis::ThesisLayout::Bricked(16),
    };
    assert_eq!(thesis::ThesisHeader::decode(&th.encode()).unwrap(), th);
}

#[test]
fn stream_round_trip_and_stats() {
    let dims = Dims::new(31, 7, 5).unwrap();
    let scene = ShapesScene::new(dims, 3, 4, 5, 100.0);
    let src = SceneSource::<u8>::new(&scene);
    let mut buf: Vec<u8> = Vec::new();
    let stats = vvol::write(
        &src,
        meta(dims, SampleType::U8, Layout::Sliced, Compression::None),
        Sink::Stream(&mut buf),
        &no_progress,
    )
    .unwrap();
    assert_eq!(stats.bytes, buf.len() as u64);
    let v = vvol::read_stream(&mut buf.as_slice()).unwrap();
    assert_eq!(v.meta.range, stats.range);
    let want: Vec<f32> = volcore::region::pack_sliced(&src)
        .iter()
        .map(|&s| s as f32)
        .collect();
    assert_eq!(v.to_f32_vec(), want);
    // A truncated stream is an error, not a short volume.
    let cut = &buf[..buf.len() - 40];
    let e = vvol::read_stream(&mut &cut[..]).err().unwrap().to_string();
    assert!(e.contains("truncated"), "{e}");
}

#[test]
fn bricked_cannot_go_to_a_stream() {
    let dims = Dims::new(8, 8, 8).unwrap();
    let scene = ShapesScene::new(dims, 3, 4, 5, 100.0);
    let g = BrickGeometry::new(dims, 4).unwrap();
    let mut buf: Vec<u8> = Vec::new();
    let r = vvol::write(
        &SceneSource::<u8>::new(&scene),
        meta(dims, SampleType::U8, Layout::Bricked(g), Compression::None),
        Sink::Stream(&mut buf),
        &no_progress,
    );
    assert!(r.is_err());
}

fn sample_file(dir: &Path, layout: Layout, c: Compression) -> PathBuf {
    let dims = Dims::new(20, 20, 20).unwrap();
    let scene = ShapesScene::new(dims, 1, 6, 8, 100.0);
    let p = dir.join("s.vvol");
    write_file(
        &SceneSource::<u8>::new(&scene),
        meta(dims, SampleType::U8, layout, c),
        &p,
    );
    p
}

fn open_err(p: &Path, verify: bool) -> String {
    match vvol::open(
        p,
        vvol::OpenOptions {
            verify,
            ..Default::default()
        },
    ) {
        Ok(_) => panic!("{} opened but should not", p.display()),
        Err(e) => e.to_string(),
    }
}

fn patch(p: &Path, at: u64, bytes: &[u8]) {
    let mut f = std::fs::OpenOptions::new().write(true).open(p).unwrap();
    f.seek(SeekFrom::Start(at)).unwrap();
    f.write_all(bytes).unwrap();
}

fn reseal_header(p: &Path) {
    let mut b = std::fs::read(p).unwrap();
    let crc = crc32fast::hash(&b[..124]);
    b[124..128].copy_from_slice(&crc.to_le_bytes());
    std::fs::write(p, b).unwrap();
}

#[test]
fn malformed_vvol_files_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let g = BrickGeometry::new(Dims::new(20, 20, 20).unwrap(), 8).unwrap();

    // Truncated.
    let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
    let len = std::fs::metadata(&p).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&p)
        .unwrap()
        .set_len(len - 100)
        .unwrap();
    assert!(open_err(&p, false).contains("file has"));
    std::fs::write(&p, b"\x89VVOL").unwrap();
    assert!(open_err(&p, false).contains("truncated"));

    // A lying header: bigger dims than the file holds (resealed so only the
    // length check can catch it).
    let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
    patch(&p, 16, &4000u64.to_le_bytes());
    patch(&p, 88, &(4000u64 * 20 * 20).to_le_bytes());
    reseal_header(&p);
    assert!(open_err(&p, false).contains("file has"));

    // Dimensions whose product overflows, and zero dimensions.
    for (x, y, z) in [(1u64 << 24, 1 << 24, 1 << 24), (0, 20, 20)] {
        let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
        for (a, v) in [x, y, z].iter().enumerate() {
            patch(&p, 16 + 8 * a as u64, &v.to_le_bytes());
        }
        reseal_header(&p);
        assert!(open_err(&p, false).contains("dimensions"));
    }

    // A damaged header without resealing.
    let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
    patch(&p, 40, &3.0f32.to_le_bytes());
    assert!(open_err(&p, false).contains("header is damaged"));

    // Flipped sample byte: found only with verification.
    let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
    patch(&p, vvol::HEADER_LEN + 4000, &[0xAB]);
    assert!(vvol::open(&p, Default::default()).is_ok());
    assert!(open_err(&p, true).contains("checksum"));

    // Brick table pointing outside the file.
    for c in [Compression::None, Compression::Zstd(1)] {
        let p = sample_file(dir.path(), Layout::Bricked(g), c);
        patch(&p, vvol::HEADER_LEN + 24, &(1u64 << 40).to_le_bytes());
        assert!(open_err(&p, false).contains("outside"));
    }

    // A damaged compressed brick: caught by verification.
    let p = sample_file(dir.path(), Layout::Bricked(g), Compression::Zstd(1));
    let (h, _) = vvol::read_header(&p).unwrap();
    patch(&p, h.data_offset + 5, &[0x55, 0x66]);
    assert!(open_err(&p, true).contains("checksum"));
    // Without verification, sampling reads zeros there and reports it.
    let v = vvol::open(&p, Default::default()).unwrap();
    let _ = v.to_f32_vec();
    assert!(v.error().is_some());

    // Damaged geometry (version 2 block), and a singular direction matrix
    // resealed.
    let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
    patch(&p, 130, &[1]);
    assert!(open_err(&p, false).contains("geometry is damaged"));
    let p = sample_file(dir.path(), Layout::Sliced, Compression::None);
    patch(&p, 152, &0f64.to_le_bytes());
    patch(&p, 176, &0f64.to_le_bytes());
    patch(&p, 200, &0f64.to_le_bytes());
    let mut b = std::fs::read(&p).unwrap();
    let crc = crc32fast::hash(&b[128..252]);
    b[252..256].copy_from_slice(&crc.to_le_bytes());
    std::fs::write(&p, b).unwrap();
    assert!(open_err(&p, false).contains("zero length"));

    // Not a vvol at all.
    std::fs::write(&p, vec![7u8; 300]).unwrap();
    assert!(open_err(&p, false).contains("bad magic"));
}

#[test]
fn thesis_vol_round_trips_both_layouts() {
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(23, 17, 9).unwrap();
    let scene = ShapesScene::new(dims, 2, 8, 7, 100.0);
    let src = SceneSource::<u8>::new(&scene);
    let want = volcore::region::pack_sliced(&src);
    for layout in [
        thesis::ThesisLayout::Sliced,
        thesis::ThesisLayout::Bricked(4),
        thesis::ThesisLayout::Bricked(16),
    ] {
        let p = dir.path().join("t.vol");
        let mut f = std::fs::File::create(&p).unwrap();
        thesis::write(&src, [1.0, 1.0, 2.0], layout, &mut f, &no_progress).unwrap();
        drop(f);
        let t = thesis::open(&p).unwrap();
        assert_eq!(t.header().layout, layout);
        let v = t.load().unwrap();
        assert_eq!(v.meta.spacing, [1.0, 1.0, 2.0]);
        let got: Vec<u8> = v.to_f32_vec().iter().map(|&f| f as u8).collect();
        assert_eq!(got, want, "{layout:?}");
        // Opened to sample: a sliced file in place (mapped, z fastest),
        // sampling as the copy does, bit for bit, with the same range.
        let opened = t.volume().unwrap();
        let in_place = layout == thesis::ThesisLayout::Sliced;
        let is_mapped = match &opened.data {
            volcore::VolumeData::U8(TypedGrid::Sliced(g)) => {
                assert_eq!(g.order() == volcore::SliceOrder::ZFastest, in_place);
                g.is_mapped()
            }
            _ => false,
        };
        assert_eq!(is_mapped, in_place, "{layout:?}");
        assert_eq!(opened.meta.range, v.meta.range);
        assert_eq!(opened.meta.spacing, [1.0, 1.0, 2.0]);
        assert_eq!(opened.to_f32_vec(), v.to_f32_vec());
        for p in random_points(dims, 2000, 3) {
            assert_eq!(opened.trilinear(p).to_bits(), v.trilinear(p).to_bits());
        }
        // Truncated file is rejected by length.
        let len = std::fs::metadata(&p).unwrap().len();
        std::fs::OpenOptions::new()
            .write(true)
            .open(&p)
            .unwrap()
            .set_len(len - 1)
            .unwrap();
        assert!(thesis::open(&p).is_err());
    }
}

#[test]
fn thesis_layout_matches_the_documented_offsets() {
    // Hand-built 3x3x3 bricked file with B = 2: n = ceil(2/1) = 2 per axis,
    // eight bricks of 8 bytes; voxel (x,y,z) stored at brick (x∧1..) etc.
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(3, 3, 3).unwrap();
    let value = |x: u64, y: u64, z: u64| (x * 9 + y * 3 + z) as u8;
    let h = thesis::ThesisHeader {
        dims,
        spacing: [1.0; 3],
        layout: thesis::ThesisLayout::Bricked(2),
    };
    let mut bytes = h.encode().to_vec();
    for bx in 0..2u64 {
        for by in 0..2u64 {
            for bz in 0..2u64 {
                for i in 0..2u64 {
                    for j in 0..2u64 {
                        for k in 0..2u64 {
                            bytes.push(value(bx + i, by + j, bz + k));
                        }
                    }
                }
            }
        }
    }
    let p = dir.path().join("h.vol");
    std::fs::write(&p, &bytes).unwrap();
    let v = thesis::open(&p).unwrap().load().unwrap();
    let got = v.to_f32_vec();
    for z in 0..3 {
        for y in 0..3 {
            for x in 0..3 {
                assert_eq!(got[dims.index(x, y, z) as usize], value(x, y, z) as f32);
            }
        }
    }
    // The sliced variant: z fastest.
    let h = thesis::ThesisHeader {
        dims,
        spacing: [1.0; 3],
        layout: thesis::ThesisLayout::Sliced,
    };
    let mut bytes = h.encode().to_vec();
    for x in 0..3 {
        for y in 0..3 {
            for z in 0..3 {
                bytes.push(value(x, y, z));
            }
        }
    }
    std::fs::write(&p, &bytes).unwrap();
    let v = thesis::open(&p).unwrap().load().unwrap();
    assert_eq!(
        v.to_f32_vec()[dims.index(2, 1, 0) as usize],
        value(2, 1, 0) as f32
    );
}

#[test]
fn raw_round_trips_and_reads_big_endian() {
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(6, 5, 4).unwrap();
    let scene = NoiseScene::new(dims, 1, NoiseKind::Value, 3.0, 2, 3000.0);
    let src = SceneSource::<u16>::new(&scene);
    let want = volcore::region::pack_sliced(&src);
    let p = dir.path().join("n_6x5x4_uint16.raw");
    let mut f = std::fs::File::create(&p).unwrap();
    raw::write(&src, &mut f, &no_progress).unwrap();
    drop(f);
    let v = crate::open_volume(&p, Default::default(), None).unwrap();
    let got: Vec<u16> = v.to_f32_vec().iter().map(|&f| f as u16).collect();
    assert_eq!(got, want);
    // Big-endian with a 3-byte header (unaligned, so read and swapped).
    let mut be = vec![1u8, 2, 3];
    for s in &want {
        be.extend_from_slice(&s.to_be_bytes());
    }
    let q = dir.path().join("be.raw");
    std::fs::write(&q, &be).unwrap();
    let spec = raw::RawSpec {
        endian: raw::Endian::Big,
        skip: 3,
        ..raw::RawSpec::new(dims, SampleType::U16)
    };
    let layout = spec.resolve(&q).unwrap();
    let v = raw::open(&q, layout).unwrap();
    let got: Vec<u16> = v.to_f32_vec().iter().map(|&f| f as u16).collect();
    assert_eq!(got, want);
    // The same through the shared open path (read, not mapped).
    let opts = crate::ReadOptions {
        raw: spec,
        ..Default::default()
    };
    let v = crate::open(&q, &opts).unwrap();
    let got: Vec<u16> = v.to_f32_vec().iter().map(|&f| f as u16).collect();
    assert_eq!(got, want);
    let spec = layout;
    // Wrong length.
    std::fs::write(&q, &be[..be.len() - 1]).unwrap();
    assert!(raw::open(&q, spec)
        .err()
        .unwrap()
        .to_string()
        .contains("file has"));
}

/// A source that refuses rows outside the window it was given, standing in
/// for a converter that holds only a few slices in memory.
struct Windowed<'a, R> {
    inner: &'a R,
    lo: std::sync::atomic::AtomicU64,
    hi: std::sync::atomic::AtomicU64,
}

impl<R: RegionSource> RegionSource for Windowed<'_, R> {
    type Sample = R::Sample;
    fn dims(&self) -> Dims {
        self.inner.dims()
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [R::Sample]) {
        use std::sync::atomic::Ordering::Relaxed;
        assert!(
            (self.lo.load(Relaxed)..self.hi.load(Relaxed)).contains(&z),
            "row at z = {z} outside the announced window"
        );
        self.inner.fill_row(x0, y, z, out)
    }
}

#[test]
fn incremental_writer_reads_only_the_announced_slices() {
    use std::sync::atomic::Ordering::Relaxed;
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(21, 9, 70).unwrap();
    let scene = ShapesScene::new(dims, 5, 9, 8, 100.0);
    let src = SceneSource::<u16>::new(&scene);
    let g = BrickGeometry::new(dims, 8).unwrap();
    for (l, c) in [
        (Layout::Sliced, Compression::None),
        (Layout::Bricked(g), Compression::None),
        (Layout::Bricked(g), Compression::Zstd(3)),
    ] {
        let m = meta(dims, SampleType::U16, l, c);
        let whole = dir.path().join("whole.vvol");
        write_file(&src, m, &whole);
        let win = Windowed {
            inner: &src,
            lo: 0.into(),
            hi: 0.into(),
        };
        let part = dir.path().join("part.vvol");
        let mut f = std::fs::File::create(&part).unwrap();
        let mut w = vvol::VvolWriter::new(Sink::File(&mut f), m, &no_progress).unwrap();
        let mut units = 0;
        loop {
            let zs = w.next_slices();
            if zs.is_empty() {
                break;
            }
            if let Layout::Bricked(g) = l {
                assert!(zs.end - zs.start <= g.stored_edge() as u64);
            }
            win.lo.store(zs.start, Relaxed);
            win.hi.store(zs.end, Relaxed);
            w.write_next(&win).unwrap();
            units += 1;
        }
        w.finish().unwrap();
        drop(f);
        assert!(units >= 1);
        assert_eq!(
            std::fs::read(&whole).unwrap(),
            std::fs::read(&part).unwrap(),
            "{l:?}"
        );
    }
}

#[test]
fn geometry_round_trips_and_version_1_and_2_files_stay_readable() {
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(9, 7, 5).unwrap();
    let scene = ShapesScene::new(dims, 3, 4, 3, 100.0);
    let src = SceneSource::<u16>::new(&scene);
    let g = volcore::Geometry::from_axes(
        [-120.5, 30.25, 7.0],
        [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
    )
    .unwrap()
    .with_unit(volcore::LengthUnit::Micrometer);
    for layout in [
        Layout::Sliced,
        Layout::Bricked(BrickGeometry::new(dims, 4).unwrap()),
    ] {
        let mut m = meta(dims, SampleType::U16, layout, Compression::None);
        m.geometry = g;
        let p = dir.path().join("g.vvol");
        write_file(&src, m, &p);
        let v = vvol::open(&p, Default::default()).unwrap();
        assert_eq!(v.meta.geometry, g);
        assert_eq!(v.meta.spacing, [1.0, 0.5, 2.0]);
    }
    // A version 2 file (geometry, no unit): read with no unit stated.
    let p = dir.path().join("g.vvol");
    let mut b = std::fs::read(&p).unwrap();
    assert_eq!(b[224], volcore::LengthUnit::Micrometer.code());
    b[8..10].copy_from_slice(&2u16.to_le_bytes());
    b[224] = 0;
    let reseal = |b: &mut Vec<u8>| {
        let crc = crc32fast::hash(&b[..124]);
        b[124..128].copy_from_slice(&crc.to_le_bytes());
        let crc = crc32fast::hash(&b[128..252]);
        b[252..256].copy_from_slice(&crc.to_le_bytes());
    };
    reseal(&mut b);
    let v2 = dir.path().join("old-v2.vvol");
    std::fs::write(&v2, &b).unwrap();
    let v = vvol::open(&v2, Default::default()).unwrap();
    assert_eq!(v.meta.geometry, g.with_unit(volcore::LengthUnit::Unknown));
    // Version 3 with a unit code it does not know: refused by name.
    b[8..10].copy_from_slice(&3u16.to_le_bytes());
    b[224] = 77;
    reseal(&mut b);
    std::fs::write(&v2, &b).unwrap();
    let Err(e) = vvol::open(&v2, Default::default()) else {
        panic!("a unit code of 77 was read");
    };
    let e = e.to_string();
    assert!(e.contains("unknown unit of length code 77"), "{e}");
    // A version 1 file (128-byte header, no geometry): identity, zero origin.
    let m = meta(dims, SampleType::U16, Layout::Sliced, Compression::None);
    let p = dir.path().join("v2.vvol");
    write_file(&src, m, &p);
    let b = std::fs::read(&p).unwrap();
    let mut v1 = b[..128].to_vec();
    v1[8..10].copy_from_slice(&1u16.to_le_bytes());
    v1[10..12].copy_from_slice(&128u16.to_le_bytes());
    v1[80..88].copy_from_slice(&128u64.to_le_bytes());
    let crc = crc32fast::hash(&v1[..124]);
    v1[124..128].copy_from_slice(&crc.to_le_bytes());
    v1.extend_from_slice(&b[256..]);
    let q = dir.path().join("v1.vvol");
    std::fs::write(&q, &v1).unwrap();
    let a = vvol::open(&p, Default::default()).unwrap();
    let old = vvol::open(
        &q,
        vvol::OpenOptions {
            verify: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(old.meta.geometry.is_identity());
    assert_eq!(old.to_f32_vec(), a.to_f32_vec());
    let s = vvol::read_stream(&mut v1.as_slice()).unwrap();
    assert_eq!(s.to_f32_vec(), a.to_f32_vec());
    assert!(crate::fingerprint(&q).is_ok());
}

/// An uncompressed NIfTI is mapped in place, a gzipped one or a scaled
/// one read into memory, with the same samples and geometry either way;
/// slices of any type from memory convert as a file's would.
#[test]
fn nifti_is_mapped_when_its_samples_can_be_used_as_stored() {
    use crate::convert::{convert, Plan, SliceData, Target};
    use crate::reader::MemoryReader;
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(5, 4, 3).unwrap();
    let want: Vec<i16> = (0..60).map(|v| v * 37 - 900).collect();
    let geometry = volcore::Geometry::from_axes(
        [10.0, -4.0, 2.5],
        [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 2.0]],
    )
    .unwrap();
    let slices = want
        .chunks(20)
        .map(|c| SliceData::I16(c.to_vec()))
        .collect::<Vec<_>>();
    let write = |name: &str| {
        let p = dir.path().join(name);
        let r = MemoryReader::from_slices(
            Path::new("memory"),
            dims,
            slices.clone(),
            Some([0.5, 1.0, 2.0]),
            geometry,
        )
        .unwrap();
        let t = Target::for_output(&p, &Default::default(), None).unwrap();
        convert(Box::new(r), &Plan::default(), t, &|_| {}).unwrap();
        p
    };
    for (name, mapped) in [("a.nii", true), ("b.nii.gz", false)] {
        let v = crate::open(&write(name), &Default::default()).unwrap();
        let is_mapped = match &v.data {
            volcore::VolumeData::I16(TypedGrid::Sliced(g)) => g.is_mapped(),
            _ => panic!("{name}: not sliced i16"),
        };
        assert_eq!(is_mapped, mapped, "{name}");
        let got: Vec<i16> = v.to_f32_vec().iter().map(|&f| f as i16).collect();
        assert_eq!(got, want, "{name}");
        assert_eq!(v.meta.spacing, [0.5, 1.0, 2.0], "{name}");
        for r in 0..3 {
            assert_eq!(v.meta.geometry.origin[r], geometry.origin[r], "{name}");
            for c in 0..3 {
                let d = v.meta.geometry.direction[r][c] - geometry.direction[r][c];
                assert!(d.abs() < 1e-6, "{name}");
            }
        }
        assert_eq!((v.meta.range.min, v.meta.range.max), (-900.0, 1283.0));
    }
    // Slices that do not make the volume are refused.
    let short = slices[..2].to_vec();
    assert!(MemoryReader::from_slices(
        Path::new("m"),
        dims,
        short,
        None,
        volcore::Geometry::IDENTITY
    )
    .is_err());
    // Output names and options that do not go together, as vol-convert
    // refuses them.
    let opts = crate::convert::OutputOptions {
        compress: crate::convert::CompressArg::parse("zstd").unwrap(),
        ..Default::default()
    };
    let e = Target::for_output(&dir.path().join("c.vvol"), &opts, None)
        .err()
        .unwrap();
    assert!(e.ends_with("--compress needs --layout bricked:B (compression is per brick)"));
    let e = Target::for_output(Path::new("-"), &Default::default(), None)
        .err()
        .unwrap();
    assert_eq!(e, "-: standard output is not available here");
}

#[test]
fn module_guide_lists_every_module() {
    // lib.rs's guide is where a reader starts: a module missing from it
    // is a module nobody finds.
    let lib = include_str!("lib.rs");
    let guide: String = lib
        .lines()
        .filter_map(|l| l.strip_prefix("//!"))
        .collect::<Vec<_>>()
        .join("\n");
    for line in lib.lines() {
        let Some(name) = line
            .strip_prefix("pub mod ")
            .and_then(|l| l.strip_suffix(';'))
        else {
            continue;
        };
        assert!(
            guide.contains(&format!("[`{name}`]")),
            "lib.rs's module guide does not name `{name}`"
        );
    }
}
