//! Resampling images for a budgeted frame: a frame rendered smaller is
//! upsampled to the size asked for (bilinear, pixel centres aligned,
//! rows in parallel: `image`'s generic filter took several times as long
//! on a 512² RGBA float frame), and the error model measures what
//! sampling an image more coarsely and upsampling it lose. The per-pixel figures
//! (value, depth, samples) are taken from the nearest rendered pixel.

use rayon::prelude::*;
use volrender::Frame;

/// `frame` resampled to `width` x `height` (itself when the size is the
/// same); its totals stay those of the frame rendered. The colours go
/// straight into the new frame's buffer ([`bilinear_into`]) and the
/// per-pixel figures are gathered row by row, rows in parallel: a 700²
/// frame from 88² had taken 17-25 ms through a flat copy and a table of
/// nearest pixels, most of it faulting in buffers it then copied.
pub fn upsample_frame(frame: Frame, width: u32, height: u32) -> Frame {
    let (sw, sh) = (frame.width, frame.height);
    if (sw, sh) == (width, height) || sw == 0 || sh == 0 || width == 0 || height == 0 {
        return frame;
    }
    let (w, row) = (width as usize, sw as usize);
    let n = w * height as usize;
    let mut rgba = vec![[0.0f32; 4]; n];
    bilinear_into(
        frame.rgba.as_flattened(),
        4,
        (sw, sh),
        (width, height),
        rgba.as_flattened_mut(),
    );
    let near_x: Vec<usize> = (0..width).map(|x| nearest(x, width, sw)).collect();
    let mut value = vec![0.0f64; n];
    let mut depth = vec![0.0f32; n];
    let mut samples = vec![0u32; n];
    value
        .par_chunks_mut(w)
        .zip(depth.par_chunks_mut(w).zip(samples.par_chunks_mut(w)))
        .enumerate()
        .for_each(|(y, (value, (depth, samples)))| {
            let start = nearest(y as u32, height, sh) * row;
            for (i, &x) in near_x.iter().enumerate() {
                value[i] = frame.value[start + x];
                depth[i] = frame.depth[start + x];
                samples[i] = frame.samples[start + x];
            }
        });
    Frame {
        width,
        height,
        rgba,
        value,
        depth,
        samples,
        stats: frame.stats,
    }
}

/// Where output pixel `i` of `n` falls among `src` source pixels: the
/// lower neighbour, the upper one, and the upper one's weight.
fn taps(i: u32, n: u32, src: u32) -> (usize, usize, f32) {
    let x =
        ((f64::from(i) + 0.5) * f64::from(src) / f64::from(n) - 0.5).clamp(0.0, f64::from(src - 1));
    let lo = x.floor() as u32;
    let hi = (lo + 1).min(src - 1);
    (lo as usize, hi as usize, (x - f64::from(lo)) as f32)
}

/// `src` (`channels` floats per pixel, `from` = width x height)
/// resampled bilinearly to `to`, pixel centres aligned, edges clamped.
/// Empty when `src` does not hold the image or a size is zero.
pub fn bilinear(src: &[f32], channels: usize, from: (u32, u32), to: (u32, u32)) -> Vec<f32> {
    let ((sw, sh), (w, h)) = (from, to);
    if sw == 0 || sh == 0 || w == 0 || h == 0 || src.len() != sw as usize * sh as usize * channels {
        return Vec::new();
    }
    let mut out = vec![0.0f32; w as usize * h as usize * channels];
    bilinear_into(src, channels, from, to, &mut out);
    out
}

/// [`bilinear`] into `out` (`to` pixels of `channels` floats), rows in
/// parallel; nothing is written when a size is zero or a buffer does not
/// hold its image.
pub fn bilinear_into(
    src: &[f32],
    channels: usize,
    from: (u32, u32),
    to: (u32, u32),
    out: &mut [f32],
) {
    let ((sw, sh), (w, h)) = (from, to);
    let row = sw as usize * channels;
    let line = w as usize * channels;
    if sw == 0
        || sh == 0
        || w == 0
        || h == 0
        || src.len() != row * sh as usize
        || out.len() != line * h as usize
    {
        return;
    }
    let xs: Vec<(usize, usize, f32)> = (0..w).map(|x| taps(x, w, sw)).collect();
    out.par_chunks_mut(line).enumerate().for_each(|(y, line)| {
        let (y0, y1, fy) = taps(y as u32, h, sh);
        let (r0, r1) = (&src[y0 * row..][..row], &src[y1 * row..][..row]);
        for (px, &(x0, x1, fx)) in line.chunks_exact_mut(channels).zip(&xs) {
            for (c, v) in px.iter_mut().enumerate() {
                let top = r0[x0 * channels + c] * (1.0 - fx) + r0[x1 * channels + c] * fx;
                let bottom = r1[x0 * channels + c] * (1.0 - fx) + r1[x1 * channels + c] * fx;
                *v = top * (1.0 - fy) + bottom * fy;
            }
        }
    });
}

/// The source pixel (of `src`) nearest, centre to centre, to pixel `i`
/// of `n`.
fn nearest(i: u32, n: u32, src: u32) -> usize {
    let c = ((f64::from(i) + 0.5) * f64::from(src) / f64::from(n)).floor() as u32;
    c.min(src - 1) as usize
}

/// What rendering RGB pixels (`w` x `h`) `factor` (even, or 1) times
/// smaller would see: each smaller pixel takes the image at its centre,
/// the mean of the 2x2 pixels around it (a partial last row or column
/// of smaller pixels is dropped).
pub fn centre_samples(rgb: &[f32], (w, h): (u32, u32), factor: u32) -> (Vec<f32>, (u32, u32)) {
    let f = factor.max(1) as usize;
    let (w, h) = (w as usize, h as usize);
    let (sw, sh) = ((w / f).max(1), (h / f).max(1));
    // The pixels either side of a smaller pixel's centre.
    let around = |i: usize, n: usize| {
        let lo = (i * f + f / 2)
            .saturating_sub(usize::from(f > 1))
            .min(n - 1);
        (lo, (i * f + f / 2).min(n - 1))
    };
    let mut out = vec![0.0f32; sw * sh * 3];
    for by in 0..sh {
        let (y0, y1) = around(by, h);
        for bx in 0..sw {
            let (x0, x1) = around(bx, w);
            for c in 0..3 {
                let at = |x: usize, y: usize| rgb[(y * w + x) * 3 + c];
                out[(by * sw + bx) * 3 + c] =
                    0.25 * (at(x0, y0) + at(x1, y0) + at(x0, y1) + at(x1, y1));
            }
        }
    }
    (out, (sw as u32, sh as u32))
}

/// The squared error that rendering the RGB image `rgb` (`w` x `h`)
/// `factor` times smaller and upsampling it back would add, estimated by
/// doing so (`0` when the image does not hold `w` x `h` pixels).
pub fn down_up_mse(rgb: &[f32], (w, h): (u32, u32), factor: u32) -> f64 {
    if rgb.len() != w as usize * h as usize * 3 || w == 0 || h == 0 {
        return 0.0;
    }
    let (small, size) = centre_samples(rgb, (w, h), factor);
    let back = bilinear(&small, 3, size, (w, h));
    super::model::mse(rgb, &back)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_frame_stays_flat_and_keeps_its_totals() {
        let mut f = Frame {
            width: 4,
            height: 2,
            rgba: vec![[0.25, 0.5, 0.75, 1.0]; 8],
            value: (0..8).map(f64::from).collect(),
            depth: vec![f32::NAN; 8],
            samples: vec![3; 8],
            stats: Default::default(),
        };
        f.stats.samples = 24;
        let g = upsample_frame(f, 8, 4);
        assert_eq!((g.width, g.height, g.rgba.len()), (8, 4, 32));
        assert!(g
            .rgba
            .iter()
            .all(|p| (p[1] - 0.5).abs() < 1e-6 && (p[3] - 1.0).abs() < 1e-6));
        assert_eq!(g.stats.samples, 24);
        // Nearest: the top-left 2x2 block is value 0, the next is 1.
        assert_eq!(&g.value[..4], &[0.0, 0.0, 1.0, 1.0]);
        assert_eq!(g.value[8], 0.0);
        assert_eq!(g.value[24], 4.0);
    }

    #[test]
    fn a_frame_upsamples_as_its_colours_do_and_takes_the_nearest_figures() {
        let (sw, sh) = (7u32, 5u32);
        let n = (sw * sh) as usize;
        // Uneven colours, from a multiplicative hash of the channel.
        let c = |k: usize| ((k as u64 * 2_654_435_761) % 1000) as f32 / 1000.0;
        let f = Frame {
            width: sw,
            height: sh,
            rgba: (0..n)
                .map(|i| [c(4 * i), c(4 * i + 1), c(4 * i + 2), c(4 * i + 3)])
                .collect(),
            value: (0..n).map(|i| i as f64).collect(),
            depth: (0..n).map(|i| i as f32 * 0.5).collect(),
            samples: (0..n as u32).collect(),
            stats: Default::default(),
        };
        let flat: Vec<f32> = f.rgba.iter().flatten().copied().collect();
        let want = bilinear(&flat, 4, (sw, sh), (19, 11));
        let g = upsample_frame(f, 19, 11);
        let got: Vec<f32> = g.rgba.iter().flatten().copied().collect();
        assert_eq!(got, want);
        for y in 0..11u32 {
            for x in 0..19u32 {
                let i = (y * 19 + x) as usize;
                let src = nearest(y, 11, sh) * sw as usize + nearest(x, 19, sw);
                assert_eq!(g.value[i], src as f64);
                assert_eq!(g.depth[i], src as f32 * 0.5);
                assert_eq!(g.samples[i], src as u32);
            }
        }
        // Pixel (18, 10) is the bottom-right corner's.
        assert_eq!(g.value[11 * 19 - 1], (n - 1) as f64);
    }

    #[test]
    fn bilinear_doubles_a_ramp_between_its_samples() {
        // 0, 10, 20 across: doubled, the centres fall a quarter between.
        let src = [0.0, 10.0, 20.0];
        let out = bilinear(&src, 1, (3, 1), (6, 1));
        let want = [0.0, 2.5, 7.5, 12.5, 17.5, 20.0];
        for (o, w) in out.iter().zip(want) {
            assert!((o - w).abs() < 1e-5, "{out:?}");
        }
        assert!(bilinear(&src, 1, (4, 1), (6, 1)).is_empty());
    }

    #[test]
    fn down_and_up_loses_detail_not_flat_colour() {
        let flat = vec![100.0f32; 3 * 64];
        assert!(down_up_mse(&flat, (8, 8), 2) < 1e-6);
        let stripes: Vec<f32> = (0..64)
            .flat_map(|i| {
                let v = if i % 2 == 0 { 0.0 } else { 255.0 };
                [v, v, v]
            })
            .collect();
        // Sampled between the stripes: flat grey, every pixel 127.5 off.
        let e2 = down_up_mse(&stripes, (8, 8), 2);
        assert!((e2 - 127.5 * 127.5).abs() < 1e-3, "{e2}");
        // A smooth ramp comes back nearly whole.
        let ramp: Vec<f32> = (0..64).flat_map(|i| [(i % 8) as f32; 3]).collect();
        assert!(down_up_mse(&ramp, (8, 8), 2) < 0.2);
    }
}
