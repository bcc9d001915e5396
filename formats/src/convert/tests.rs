use super::*;
use crate::open::{open_input, ReadOptions};
use crate::reader::MemoryReader;
use volcore::{Compression, Dims};

fn ramp(d: Dims) -> Vec<u16> {
    (0..d.count()).map(|i| (i * 7 % 65536) as u16).collect()
}

fn read_back(path: &Path) -> Vec<f32> {
    let r = open_input(path, &ReadOptions::default()).unwrap();
    let d = r.info().dims;
    let mut out = Vec::new();
    for z in 0..d.z {
        let s = r.read_slice(z).unwrap();
        out.extend((0..s.len()).map(|i| s.value(i) as f32));
    }
    out
}

fn run(samples: &[u16], d: Dims, plan: &Plan, target: Target) -> Report {
    let r = Box::new(MemoryReader::new(d, samples));
    convert(r, plan, target, &|_| {}).unwrap()
}

#[test]
fn every_output_round_trips() {
    let tmp = tempfile::tempdir().unwrap();
    let d = Dims::new(13, 11, 9).unwrap();
    let v = ramp(d);
    let want: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    let targets = [
        Target::Vvol {
            path: tmp.path().join("a.vvol"),
            brick: None,
            compression: Compression::None,
        },
        Target::Vvol {
            path: tmp.path().join("b.vvol"),
            brick: Some(4),
            compression: Compression::None,
        },
        Target::Vvol {
            path: tmp.path().join("c.vvol"),
            brick: Some(5),
            compression: Compression::Zstd(3),
        },
        Target::Raw {
            path: tmp.path().join("d_13x11x9_uint16.raw"),
        },
        Target::Tiff {
            path: tmp.path().join("e.tif"),
        },
        Target::TiffDir {
            path: tmp.path().join("f"),
        },
    ];
    for t in targets {
        let p = t.path().to_path_buf();
        let rep = run(&v, d, &Plan::default(), t);
        assert_eq!(rep.dims, d);
        assert_eq!(read_back(&p), want, "{}", p.display());
    }
    let names: Vec<String> = std::fs::read_dir(tmp.path().join("f"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.contains(&"slice_0008.tif".to_string()), "{names:?}");
    // Nothing temporary is left behind.
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .filter_map(|e| {
            let n = e.unwrap().file_name().to_string_lossy().into_owned();
            n.starts_with('.').then_some(n)
        })
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn crop_flip_and_window() {
    let tmp = tempfile::tempdir().unwrap();
    let d = Dims::new(6, 5, 4).unwrap();
    let v: Vec<u16> = (0..d.count()).map(|i| i as u16 * 100).collect();
    let plan = Plan {
        crop: Some([1..5, 0..5, 1..4]),
        flip: [true, false, true],
        sample_type: Some(volcore::SampleType::U8),
        window: Some(Window::Range(0.0, 11900.0)),
        ..Plan::default()
    };
    let p = tmp.path().join("o.vvol");
    let rep = run(
        &v,
        d,
        &plan,
        Target::Vvol {
            path: p.clone(),
            brick: Some(2),
            compression: Compression::Zstd(1),
        },
    );
    assert_eq!(rep.dims, Dims::new(4, 5, 3).unwrap());
    let got = read_back(&p);
    let m = ValueMap::Linear {
        lo: 0.0,
        hi: 11900.0,
    };
    for z in 0..3u64 {
        for y in 0..5u64 {
            for x in 0..4u64 {
                let (xi, yi, zi) = (1 + (3 - x), y, 1 + (2 - z));
                let src = v[d.index(xi, yi, zi) as usize] as f64;
                let want = m.apply::<u8>(src) as f32;
                assert_eq!(got[(x + 4 * (y + 5 * z)) as usize], want);
            }
        }
    }
}

#[test]
fn narrowing_without_window_fails_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let d = Dims::new(4, 4, 4).unwrap();
    let v = ramp(d);
    let p = tmp.path().join("x.vvol");
    let plan = Plan {
        sample_type: Some(volcore::SampleType::U8),
        ..Plan::default()
    };
    let r = Box::new(MemoryReader::new(d, &v));
    let e = convert(
        r,
        &plan,
        Target::Vvol {
            path: p.clone(),
            brick: None,
            compression: Compression::None,
        },
        &|_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("--window"), "{e}");
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn auto_window_uses_percentiles() {
    let tmp = tempfile::tempdir().unwrap();
    let d = Dims::new(10, 10, 10).unwrap();
    // 1000 values 0..999; 0.5 % tails: lo = 4, hi = 995.
    let v: Vec<u16> = (0..1000).collect();
    let plan = Plan {
        sample_type: Some(volcore::SampleType::U8),
        window: Some(Window::Auto(0.5)),
        ..Plan::default()
    };
    let p = tmp.path().join("a.raw");
    let rep = run(&v, d, &plan, Target::Raw { path: p.clone() });
    assert_eq!(rep.map, ValueMap::Linear { lo: 4.0, hi: 995.0 });
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(bytes[0], 0);
    assert_eq!(bytes[999], 255);
}
