use super::*;
use volcore::Dims;

fn img(w: u32, h: u32, color: usize, alpha: bool, depth: Depth, f: impl Fn(usize) -> f32) -> Image {
    let n = w as usize * h as usize * (color + alpha as usize);
    Image::new(w, h, color, alpha, depth, (0..n).map(f).collect()).unwrap()
}

fn rgb8(w: u32, h: u32, f: impl Fn(usize) -> f32) -> Image {
    img(w, h, 3, false, Depth::U8, f)
}

fn cmp(a: &Image, b: &Image) -> ImageComparison {
    compare_images(a, b, &ImageOptions::default()).unwrap()
}

fn close(a: f64, b: f64, tol: f64) {
    assert!((a - b).abs() <= tol, "{a} vs {b}");
}

#[test]
fn identical_images_are_infinite_psnr() {
    let a = rgb8(7, 5, |i| (i * 37 % 256) as f32);
    let c = cmp(&a, &a.clone());
    assert!(c.pooled.identical());
    assert_eq!(c.pooled.psnr, f64::INFINITY);
    assert_eq!((c.pooled.mse, c.pooled.max_abs), (0.0, 0.0));
    assert_eq!(c.pooled.count, 7 * 5 * 3);
}

/// One value off by one in a W×H RGB 8-bit image:
/// MSE = 1 / (3WH), PSNR = 10·log10(255² · 3WH).
#[test]
fn one_pixel_off_by_one_is_the_closed_form() {
    for (w, h) in [(1u32, 1u32), (8, 8), (64, 48), (641, 3)] {
        let a = rgb8(w, h, |i| (i % 200) as f32);
        let mut b = a.clone();
        let k = b.samples.len() / 2;
        b.samples[k] += 1.0;
        let c = cmp(&a, &b);
        let n = 3.0 * w as f64 * h as f64;
        assert_eq!(c.pooled.mse, 1.0 / n);
        close(
            c.pooled.psnr,
            10.0 * (255f64.powi(2) * n / 1.0).log10(),
            1e-12,
        );
        assert_eq!(c.pooled.differing, 1);
        assert_eq!(c.pooled.max_abs, 1.0);
    }
}

/// A constant offset d everywhere: PSNR = 20·log10(peak / d), for each
/// depth's peak.
#[test]
fn constant_offset_and_depth_conventions() {
    for d in [1.0f32, 3.0, 17.0, 100.0] {
        let a = rgb8(9, 4, |i| (i % 100) as f32);
        let b = rgb8(9, 4, |i| (i % 100) as f32 + d);
        let c = cmp(&a, &b);
        close(c.pooled.psnr, 20.0 * (255.0 / d as f64).log10(), 1e-12);
        assert_eq!((c.peak, c.peak_source), (255.0, PeakSource::Type));
        assert_eq!(c.pooled.differing_fraction, 1.0);
    }
    let a = img(5, 3, 1, false, Depth::U16, |i| (i * 1000) as f32);
    let b = img(5, 3, 1, false, Depth::U16, |i| (i * 1000 + 250) as f32);
    let c = cmp(&a, &b);
    assert_eq!(c.peak, 65535.0);
    close(c.pooled.psnr, 20.0 * (65535.0f64 / 250.0).log10(), 1e-12);

    let a = img(5, 3, 3, false, Depth::F32, |i| i as f32 / 64.0);
    let b = img(5, 3, 3, false, Depth::F32, |i| i as f32 / 64.0 + 0.125);
    let c = cmp(&a, &b);
    assert_eq!((c.peak, c.peak_source), (1.0, PeakSource::FloatDefault));
    close(c.pooled.psnr, 20.0 * (1.0f64 / 0.125).log10(), 1e-12);
    let opts = ImageOptions {
        range: Some(4.0),
        ..Default::default()
    };
    let c = compare_images(&a, &b, &opts).unwrap();
    assert_eq!((c.peak, c.peak_source), (4.0, PeakSource::Given));
    close(c.pooled.psnr, 20.0 * (4.0f64 / 0.125).log10(), 1e-12);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let opts = ImageOptions {
            range: Some(bad),
            ..Default::default()
        };
        assert!(matches!(
            compare_images(&a, &b, &opts),
            Err(Error::Invalid(_))
        ));
    }
}

/// Pseudo-random 8-bit RGB pairs whose PSNR scikit-image 0.26.0 (numpy
/// 2.4.6) computed with `skimage.metrics.peak_signal_noise_ratio(a, b)` on
/// uint8 arrays of shape (H, W, 3) built from the same formulas (sample
/// index i over the flattened array), printed with `repr`. Python is not
/// needed to run this test.
#[test]
fn matches_scikit_image_to_1e_6_db() {
    let case1 = |i: u64| {
        let a = (i * 7919 + 13) % 256;
        let b = (a as i64 + ((i * i * 131 + 7) % 11) as i64 - 5).clamp(0, 255);
        (a as f32, b as f32)
    };
    let case2 = |i: u64| {
        let a = (i * 31 + 7) % 256;
        (
            a as f32,
            if i.is_multiple_of(97) { 255 - a } else { a } as f32,
        )
    };
    let case3 = |i: u64| {
        (
            ((i * 7919 + 13) % 256) as f32,
            ((i * 104729 + 3) % 256) as f32,
        )
    };
    type Pair = dyn Fn(u64) -> (f32, f32);
    let cases: [(u32, u32, &Pair, f64); 3] = [
        (64, 48, &case1, 40.39159387485094),
        (33, 17, &case2, 23.847087666183718),
        (20, 10, &case3, 7.677125203438088),
    ];
    for (w, h, f, want) in cases {
        let a = rgb8(w, h, |i| f(i as u64).0);
        let b = rgb8(w, h, |i| f(i as u64).1);
        let got = cmp(&a, &b).pooled.psnr;
        assert!(
            (got - want).abs() < 1e-6,
            "{w}x{h}: {got} vs skimage {want}"
        );
    }
}

#[test]
fn alpha_is_ignored_unless_asked_for() {
    let a = img(4, 4, 3, true, Depth::U8, |i| (i % 256) as f32);
    // Only alpha differs, by 10.
    let b = img(4, 4, 3, true, Depth::U8, |i| {
        (i % 256) as f32 + if i % 4 == 3 { 10.0 } else { 0.0 }
    });
    let c = cmp(&a, &b);
    assert!(c.pooled.identical());
    assert_eq!(c.channels, vec!["R", "G", "B"]);
    assert_eq!(c.pooled.count, 48);
    let with = ImageOptions {
        alpha: true,
        ..Default::default()
    };
    let c = compare_images(&a, &b, &with).unwrap();
    assert_eq!(c.channels, vec!["R", "G", "B", "A"]);
    assert_eq!(c.pooled.count, 64);
    assert_eq!(c.pooled.mse, 100.0 / 4.0);
    assert_eq!(c.per_channel[3].mse, 100.0);
    assert!(c.per_channel[..3].iter().all(|m| m.identical()));
    // RGBA against RGB: fine without alpha, a mismatch with it.
    let rgb = img(4, 4, 3, false, Depth::U8, |i| {
        let (p, c) = (i / 3, i % 3);
        ((p * 4 + c) % 256) as f32
    });
    assert!(cmp(&a, &rgb).pooled.identical());
    assert!(matches!(
        compare_images(&a, &rgb, &with),
        Err(Error::Mismatch(_))
    ));
}

#[test]
fn per_channel_and_luma() {
    let a = rgb8(6, 5, |i| (i % 50) as f32);
    // +8 in G only.
    let b = rgb8(6, 5, |i| {
        (i % 50) as f32 + if i % 3 == 1 { 8.0 } else { 0.0 }
    });
    let opts = ImageOptions {
        luma: true,
        ..Default::default()
    };
    let c = compare_images(&a, &b, &opts).unwrap();
    assert!(c.per_channel[0].identical() && c.per_channel[2].identical());
    assert_eq!(c.per_channel[1].mse, 64.0);
    close(
        c.per_channel[1].psnr,
        20.0 * (255.0f64 / 8.0).log10(),
        1e-12,
    );
    assert_eq!(c.pooled.mse, 64.0 / 3.0);
    let luma = c.luma.unwrap();
    close(luma.psnr, 20.0 * (255.0 / (0.7152 * 8.0f64)).log10(), 1e-9);
    assert_eq!(c.headline(), &luma);
    // Grey images: luma is the grey channel.
    let g = img(3, 3, 1, false, Depth::U8, |i| i as f32);
    let g2 = img(3, 3, 1, false, Depth::U8, |i| i as f32 + 2.0);
    let c = compare_images(&g, &g2, &opts).unwrap();
    assert_eq!(c.luma.unwrap().mse, 4.0);
    assert_eq!(c.channels, vec!["Y"]);
}

#[test]
fn error_map_is_the_worst_channel_per_pixel() {
    let a = rgb8(3, 2, |_| 100.0);
    let b = rgb8(3, 2, |i| 100.0 + [0.0, 5.0, -9.0][i % 3] * (i / 3) as f32);
    let opts = ImageOptions {
        error_map: true,
        ..Default::default()
    };
    let c = compare_images(&a, &b, &opts).unwrap();
    assert_eq!(c.error_map.unwrap(), vec![0.0, 9.0, 18.0, 27.0, 36.0, 45.0]);
    assert!(cmp(&a, &b).error_map.is_none());
}

#[test]
fn mismatched_images_are_mismatches() {
    let a = rgb8(4, 4, |_| 0.0);
    let mismatch = |b: &Image| {
        let e = compare_images(&a, b, &ImageOptions::default()).unwrap_err();
        assert!(matches!(e, Error::Mismatch(_)), "{e}");
        e.to_string()
    };
    assert!(mismatch(&rgb8(4, 5, |_| 0.0)).contains("4x4"));
    assert!(mismatch(&img(4, 4, 3, false, Depth::U16, |_| 0.0)).contains("16-bit"));
    assert!(mismatch(&img(4, 4, 1, false, Depth::U8, |_| 0.0)).contains("grey"));
}

#[test]
fn nan_in_float_images() {
    let a = img(2, 1, 1, false, Depth::F32, |i| [f32::NAN, 0.5][i]);
    let c = cmp(&a, &a.clone());
    assert!(c.pooled.identical());
    let b = img(2, 1, 1, false, Depth::F32, |i| [1.0, 0.25][i]);
    let c = cmp(&a, &b);
    assert_eq!((c.pooled.differing, c.pooled.nonfinite), (2, 1));
    assert_eq!(c.pooled.mse, 0.0625);
}

fn vol<T: volcore::volume::OpenSample>(d: [u64; 3], f: impl Fn(u64) -> T) -> Volume {
    let dims = Dims::new(d[0], d[1], d[2]).unwrap();
    Volume::from_samples(dims, (0..dims.count()).map(f).collect()).unwrap()
}

#[test]
fn volumes_of_any_type() {
    let d = [13, 7, 5];
    let a = vol(d, |i| (i % 200) as u8);
    let c = compare_volumes(&a, &a, &VolumeOptions::default()).unwrap();
    assert!(c.metrics.identical());
    assert_eq!(c.metrics.psnr, f64::INFINITY);
    assert_eq!(c.metrics.count, 13 * 7 * 5);
    // One voxel off by 3.
    let b = vol(d, |i| (i % 200) as u8 + (i == 77) as u8 * 3);
    let c = compare_volumes(&a, &b, &VolumeOptions::default()).unwrap();
    assert_eq!((c.peak, c.peak_source), (255.0, PeakSource::Type));
    assert_eq!(c.metrics.mse, 9.0 / 455.0);
    assert_eq!((c.metrics.max_abs, c.metrics.differing), (3.0, 1));
    // i16 peak is 65535; mixed types compare as values.
    let a = vol(d, |i| i as i16 - 200);
    let b = vol(d, |i| (i as i16 - 200) as f32 + 5.0);
    let c = compare_volumes(&a, &b, &VolumeOptions::default()).unwrap();
    assert_eq!(c.peak, 65535.0);
    assert_eq!((c.type_a, c.type_b), (SampleType::I16, SampleType::F32));
    close(c.metrics.psnr, 20.0 * (65535.0f64 / 5.0).log10(), 1e-9);
    // f32: the reference's value range, or --range.
    let a = vol(d, |i| i as f32 * 0.5 + 10.0);
    let b = vol(d, |i| i as f32 * 0.5 + 10.25);
    let c = compare_volumes(&a, &b, &VolumeOptions::default()).unwrap();
    assert_eq!(c.reference_range, Some((10.0, 10.0 + 454.0 * 0.5)));
    assert_eq!((c.peak, c.peak_source), (227.0, PeakSource::ReferenceRange));
    let opts = VolumeOptions {
        range: Some(2.0),
        ..Default::default()
    };
    let c = compare_volumes(&a, &b, &opts).unwrap();
    close(c.metrics.psnr, 20.0 * (2.0f64 / 0.25).log10(), 1e-12);
    let flat = vol(d, |_| 3.0f32);
    let c = compare_volumes(&flat, &a, &VolumeOptions::default()).unwrap();
    assert_eq!(c.peak_source, PeakSource::FloatDefault);
}

#[test]
fn volume_error_map_and_mismatch() {
    let a = vol([4, 3, 6], |i| i as u16);
    let b = vol([4, 3, 6], |i| {
        i as u16 + if i % 12 == 5 { (i / 12) as u16 } else { 0 }
    });
    let opts = VolumeOptions {
        error_map: true,
        ..Default::default()
    };
    let c = compare_volumes(&a, &b, &opts).unwrap();
    let mut want = vec![0.0f32; 12];
    want[5] = 5.0;
    assert_eq!(c.error_map.unwrap(), want);
    let other = vol([4, 3, 5], |i| i as u16);
    assert!(matches!(
        compare_volumes(&a, &other, &opts),
        Err(Error::Mismatch(_))
    ));
}

/// The figures do not depend on how many threads share the work.
#[test]
fn volume_figures_do_not_depend_on_threads() {
    let d = [700, 9, 4];
    let a = vol(d, |i| ((i * 2654435761) % 1000) as f32 * 1e-3);
    let b = vol(d, |i| ((i * 40503) % 997) as f32 * 1e-3);
    let run = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| compare_volumes(&a, &b, &VolumeOptions::default()).unwrap())
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(5));
}
