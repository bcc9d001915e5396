//! Heat maps with a colour scale (errors for vol-psnr, samples per pixel
//! for vol-render).
//!
//! [`render_heatmap`] maps values from 0 to their largest finite value
//! through a perceptual colour map (viridis: dark purple for 0, yellow for
//! the maximum) and draws, to the right of the map, a vertical scale bar
//! labelled with the scale's range in a tiny built-in 3×5 pixel font (drawn
//! at twice that size). No font files, no text-rendering dependency.

use super::png::write_png8;
use crate::error::{Error, Result};
use std::path::Path;

/// Viridis at t = 0, 1/8, 2/8, …, 1; colours in between are interpolated
/// linearly.
const VIRIDIS: [[u8; 3]; 9] = [
    [0x44, 0x01, 0x54],
    [0x47, 0x2d, 0x7b],
    [0x3b, 0x52, 0x8b],
    [0x2c, 0x72, 0x8e],
    [0x21, 0x91, 0x8c],
    [0x28, 0xae, 0x80],
    [0x5e, 0xc9, 0x62],
    [0xad, 0xdc, 0x30],
    [0xfd, 0xe7, 0x25],
];

/// The viridis colour at `t` in 0..=1 (clamped; NaN counts as 1).
pub fn viridis(t: f32) -> [u8; 3] {
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (VIRIDIS.len() - 1) as f32;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    let (lo, hi) = (VIRIDIS[i], VIRIDIS[i + 1]);
    std::array::from_fn(|c| (lo[c] as f32 + (hi[c] as f32 - lo[c] as f32) * f).round() as u8)
}

/// 3×5 glyphs, five rows of three bits from the top, the left pixel in the
/// high bit of each row.
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b001, 0b001, 0b001],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
        '+' => [0b000, 0b010, 0b111, 0b010, 0b000],
        'E' => [0b111, 0b100, 0b110, 0b100, 0b111],
        ' ' => [0; 5],
        _ => return None,
    })
}

/// Font pixels per glyph pixel.
const FONT_SCALE: usize = 2;
/// Horizontal advance per character, in image pixels.
const ADVANCE: usize = 4 * FONT_SCALE;
/// Glyph height in image pixels.
const GLYPH_H: usize = 5 * FONT_SCALE;
const BAR_GAP: usize = 8;
const BAR_W: usize = 16;
const LABEL_GAP: usize = 4;
/// The canvas is at least this tall, so the bar and labels stay legible
/// under small maps.
const MIN_HEIGHT: usize = 64;

/// A value as a short label the built-in font can draw: up to four
/// significant digits, `E` notation for very small or large values.
pub fn scale_label(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() {
        return "-".to_string();
    }
    let e = v.abs().log10().floor() as i32;
    if (-3..5).contains(&e) {
        let decimals = (3 - e).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.2E}")
    }
}

/// An RGB canvas.
struct Canvas {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

impl Canvas {
    fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y * self.width + x);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    fn text(&mut self, x0: usize, y0: usize, s: &str, c: [u8; 3]) {
        for (k, ch) in s.chars().enumerate() {
            let Some(rows) = glyph(ch) else { continue };
            for (gy, bits) in rows.iter().enumerate() {
                for gx in 0..3 {
                    if bits & (0b100 >> gx) != 0 {
                        for dy in 0..FONT_SCALE {
                            for dx in 0..FONT_SCALE {
                                self.set(
                                    x0 + k * ADVANCE + gx * FONT_SCALE + dx,
                                    y0 + gy * FONT_SCALE + dy,
                                    c,
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}

/// A rendered heat map: the RGB pixels and the range its scale shows.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatMap {
    /// Canvas width: the map plus the scale bar and its labels.
    pub width: u32,
    /// Canvas height: the map's, but at least 64.
    pub height: u32,
    /// 8-bit RGB, rows from the top down.
    pub rgb: Vec<u8>,
    /// The value the bottom of the scale stands for (0).
    pub min: f64,
    /// The value the top of the scale stands for: the largest finite value.
    pub max: f64,
}

/// Draw `values` (`width × height`, rows from the top down, non-negative
/// errors) as a viridis heat map from 0 to the largest finite value, with
/// a labelled scale bar on the right. Non-finite values get the top colour.
pub fn render_heatmap(values: &[f32], width: u32, height: u32) -> Result<HeatMap> {
    let (w, h) = (width as usize, height as usize);
    if w == 0 || h == 0 || w.checked_mul(h) != Some(values.len()) {
        return Err(Error::invalid(format!(
            "{} values do not make a {width}x{height} map",
            values.len()
        )));
    }
    let max = values
        .iter()
        .filter(|v| v.is_finite())
        .fold(0f32, |m, &v| m.max(v)) as f64;
    let labels = [scale_label(max), scale_label(0.0)];
    let label_w = labels.iter().map(|l| l.len()).max().unwrap_or(1) * ADVANCE;
    let bar_x = w + BAR_GAP;
    let label_x = bar_x + BAR_W + LABEL_GAP;
    let cw = label_x + label_w + LABEL_GAP;
    let ch = h.max(MIN_HEIGHT);
    let too_large = || Error::invalid("the heat map is too large");
    let (cw32, ch32) = (
        u32::try_from(cw).map_err(|_| too_large())?,
        u32::try_from(ch).map_err(|_| too_large())?,
    );
    let mut c = Canvas {
        width: cw,
        height: ch,
        rgb: vec![
            255;
            cw.checked_mul(ch)
                .and_then(|n| n.checked_mul(3))
                .ok_or_else(too_large)?
        ],
    };
    for (y, row) in values.chunks_exact(w).enumerate() {
        for (x, &v) in row.iter().enumerate() {
            let t = if !v.is_finite() {
                1.0
            } else if max > 0.0 {
                (v as f64 / max) as f32
            } else {
                0.0
            };
            c.set(x, y, viridis(t));
        }
    }
    for y in 0..ch {
        let col = viridis(1.0 - y as f32 / (ch - 1) as f32);
        for x in bar_x..bar_x + BAR_W {
            c.set(x, y, col);
        }
    }
    c.text(label_x, 0, &labels[0], [0, 0, 0]);
    c.text(label_x, ch - GLYPH_H, &labels[1], [0, 0, 0]);
    Ok(HeatMap {
        width: cw32,
        height: ch32,
        rgb: c.rgb,
        min: 0.0,
        max,
    })
}

/// Render a heat map of `values` (see [`render_heatmap`]) and write it as
/// an 8-bit RGB PNG at `path`; returns it.
pub fn write_heatmap(path: &Path, values: &[f32], width: u32, height: u32) -> Result<HeatMap> {
    let map = render_heatmap(values, width, height)?;
    write_png8(path, map.width, map.height, 3, &map.rgb)?;
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_map_ends_and_is_monotone_in_lightness() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[8]);
        assert_eq!(viridis(-3.0), VIRIDIS[0]);
        assert_eq!(viridis(f32::NAN), VIRIDIS[8]);
        let lum = |c: [u8; 3]| 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = lum(viridis(i as f32 / 100.0));
            assert!(l >= last, "viridis gets darker at {i}");
            last = l;
        }
    }

    #[test]
    fn labels_fit_the_font() {
        for (v, s) in [
            (0.0, "0"),
            (41.0, "41"),
            (255.0, "255"),
            (0.5, "0.5"),
            (0.01234, "0.01234"),
            (9.81, "9.81"),
            (65535.0, "65535"),
            (123456.0, "1.23E5"),
            (1.5e-6, "1.50E-6"),
        ] {
            assert_eq!(scale_label(v), s);
            assert!(s.chars().all(|c| glyph(c).is_some()));
        }
    }

    #[test]
    fn heat_map_has_bar_labels_and_colours() {
        let values = vec![0.0, 1.0, 2.0, f32::INFINITY, 4.0, 0.0];
        let m = render_heatmap(&values, 3, 2).unwrap();
        assert_eq!(m.height, 64);
        assert_eq!(m.max, 4.0);
        let px = |x: usize, y: usize| {
            let i = 3 * (y * m.width as usize + x);
            [m.rgb[i], m.rgb[i + 1], m.rgb[i + 2]]
        };
        assert_eq!(px(0, 0), viridis(0.0));
        assert_eq!(px(2, 0), viridis(0.5));
        assert_eq!(px(0, 1), viridis(1.0));
        assert_eq!(px(1, 1), viridis(1.0));
        // Below the map: background; the bar: top colour at the top.
        assert_eq!(px(0, 10), [255; 3]);
        assert_eq!(px(3 + BAR_GAP, 0), viridis(1.0));
        assert_eq!(px(3 + BAR_GAP, 63), viridis(0.0));
        // Some black label pixels at the top and the bottom.
        let label_x = 3 + BAR_GAP + BAR_W + LABEL_GAP;
        let dark = |y0: usize| {
            (y0..y0 + GLYPH_H)
                .flat_map(|y| (label_x..m.width as usize).map(move |x| (x, y)))
                .any(|(x, y)| px(x, y) == [0, 0, 0])
        };
        assert!(dark(0) && dark(64 - GLYPH_H));
        assert!(render_heatmap(&values, 4, 2).is_err());
        // All zero: no division by zero, everything at the bottom colour.
        let z = render_heatmap(&[0.0; 4], 2, 2).unwrap();
        assert_eq!(z.max, 0.0);
        assert_eq!(&z.rgb[..3], &viridis(0.0));
    }

    #[test]
    fn png8_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.png");
        let m = write_heatmap(&p, &[0.0, 3.0, 1.0, 2.0], 2, 2).unwrap();
        let back = image::open(&p).unwrap().to_rgb8();
        assert_eq!((back.width(), back.height()), (m.width, m.height));
        assert_eq!(back.as_raw(), &m.rgb);
        assert!(write_png8(&p, 2, 2, 5, &[0; 20]).is_err());
        assert!(write_png8(&p, 2, 2, 1, &[0; 3]).is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "a failed write left a file behind");
    }
}
