//! What the studies' plots share: the font, the colours, time labels,
//! writing a chart as PNG and SVG, and the legend box.

use anyhow::{anyhow, bail, Context, Result};
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// warning) when none is found and none was asked for: the CSV is still
/// written, the plot is skipped.
pub fn load_font(asked: Option<&Path>) -> Result<bool> {
    let candidates: Vec<PathBuf> = match asked {
        Some(p) => vec![p.to_path_buf()],
        None => [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
            "/Library/Fonts/Arial.ttf",
            "C:\\Windows\\Fonts\\arial.ttf",
        ]
        .iter()
        .map(PathBuf::from)
        .collect(),
    };
    for p in &candidates {
        if let Ok(bytes) = std::fs::read(p) {
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_err() {
                bail!("{}: not a usable TrueType font", p.display());
            }
            return Ok(true);
        }
    }
    if let Some(p) = asked {
        bail!("{}: cannot read font", p.display());
    }
    say!("vol-accuracy: no font found (give --font FILE.ttf): skipping the plots");
    Ok(false)
}

/// One colour per knob, in sweep order.
pub const COLOURS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// Draw into an RGB buffer and write it through volformats' PNG encoder
/// (the `image` crate the workspace already builds), so plotters needs no
/// `bitmap_encoder` and no second, older `image` of its own.
pub fn draw_png<F>(png: &Path, (w, h): (u32, u32), draw: F) -> Result<()>
where
    F: FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()>,
{
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    draw(BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area())
        .with_context(|| format!("{}: cannot draw", png.display()))?;
    volformats::image::write_png8(png, w, h, 3, &rgb)
        .with_context(|| format!("{}: cannot write", png.display()))
}

/// A time label with as many digits as its size needs.
pub fn seconds(x: f64) -> String {
    if x >= 10.0 {
        format!("{x:.0}")
    } else if x >= 1.0 {
        format!("{x:.1}")
    } else if x >= 0.1 {
        format!("{x:.2}")
    } else if x >= 0.01 {
        format!("{x:.3}")
    } else {
        format!("{x:.0e}")
    }
}

/// A chart that draws itself on any plotters backend (the PNG's bitmap
/// and the SVG).
pub trait Chart {
    /// Draw the whole chart on `root`.
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static;
}

/// Write `chart` as `png` and `svg`, `size` pixels each.
pub fn write_png_svg(png: &Path, svg: &Path, size: (u32, u32), chart: &impl Chart) -> Result<()> {
    draw_png(png, size, |root| chart.draw(root))?;
    let root = SVGBackend::new(svg, size).into_drawing_area();
    chart
        .draw(root)
        .with_context(|| format!("{}: cannot draw", svg.display()))
}

/// Rows and columns of a grid of `n` panels, at most three a row.
fn grid(n: usize) -> (usize, usize) {
    let cols = n.clamp(1, 3);
    (n.div_ceil(cols).max(1), cols)
}

/// The pixel size of a grid of `n` panels of `panel` pixels each, under
/// a title 60 pixels high.
pub fn grid_size(n: usize, (w, h): (u32, u32)) -> (u32, u32) {
    let (rows, cols) = grid(n);
    (cols as u32 * w, 60 + rows as u32 * h)
}

/// `root` under `title`, split into a grid of `n` panels (see
/// [`grid_size`]), row by row.
pub fn titled_grid<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    n: usize,
) -> Result<Vec<DrawingArea<DB, Shift>>>
where
    DB::ErrorType: 'static,
{
    let body = root
        .titled(title, ("sans-serif", 22))
        .map_err(drawing_error)?;
    Ok(body.split_evenly(grid(n)))
}

/// A plotters drawing error as an `anyhow` error.
pub fn drawing_error<E: std::error::Error + Send + Sync>(
    e: DrawingAreaErrorKind<E>,
) -> anyhow::Error {
    anyhow!("{e}")
}

/// The series' legend, in the lower right corner of `chart`.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 12))
        .draw()
        .map_err(drawing_error)
}
