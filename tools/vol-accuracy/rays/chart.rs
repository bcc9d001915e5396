//! The ray-casting study's plot: PSNR against median time, one panel per
//! knob, as PNG and SVG.

use super::frontier::frontier;
use super::measure::{Row, ADAPTIVE, BUDGET, PREINTEGRATED};
use super::setup::{BASE_ERT, BASE_STEP};
use crate::plot::{drawing_error, grid_size, seconds, titled_grid, write_png_svg, Chart, COLOURS};
use anyhow::{bail, Result};
use plotters::prelude::*;
use std::path::Path;

/// Knobs whose values are kinds, not amounts: drawn as labelled markers,
/// never joined by lines.
fn categorical(knob: &str) -> bool {
    matches!(knob, "interp" | "gradient" | "shadows off" | "AO off")
}

/// Whether `value` is the base setting of `knob` (what every other panel
/// uses): marked with a ring.
fn is_default(knob: &str, value: &str) -> bool {
    matches!(
        (knob, value),
        ("step", BASE_STEP)
            | ("ert", BASE_ERT)
            | ("interp", "trilinear")
            | ("gradient", "central")
            | ("cell", "8")
            | ("tile", "16")
    )
}

/// Draw PSNR against median time for one scene, one panel per knob, as
/// PNG and SVG; `smoke` marks a quick run's plot as a smoke test.
pub fn plot(out: &Path, scene: &str, rows: &[Row], smoke: bool) -> Result<()> {
    let png = out.join(format!("accuracy-{scene}.png"));
    let svg = out.join(format!("accuracy-{scene}.svg"));
    let knobs = knobs_of(rows);
    let size = grid_size(knobs.len(), (400, 330));
    write_png_svg(&png, &svg, size, &RayChart { scene, rows, smoke })
}

/// One study's plot: its scene name, its rows, and whether a quick run
/// made it.
struct RayChart<'a> {
    scene: &'a str,
    rows: &'a [Row],
    smoke: bool,
}

/// The curves drawn in `knob`'s panel: its own, and for the step the
/// same steps pre-integrated, adaptive steps' tolerances and frame-time
/// budgets.
fn curves(knob: &'static str) -> Vec<&'static str> {
    match knob {
        "step" => vec!["step", PREINTEGRATED, ADAPTIVE, BUDGET],
        k => vec![k],
    }
}

/// The knobs with a finite PSNR that have a panel, in sweep order.
fn knobs_of(rows: &[Row]) -> Vec<&'static str> {
    let mut knobs: Vec<&'static str> = Vec::new();
    for r in rows.iter().filter(|r| r.psnr_db.is_some()) {
        if !matches!(r.knob, PREINTEGRATED | ADAPTIVE | BUDGET) && !knobs.contains(&r.knob) {
            knobs.push(r.knob);
        }
    }
    knobs
}

/// The chart itself, on any backend: a title, then one panel per knob on
/// shared axes (time on a log scale, spread from the fastest to the
/// slowest run as a bar; the reference's time as a dashed line).
impl Chart for RayChart<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (scene, rows, smoke) = (self.scene, self.rows, self.smoke);
        root.fill(&WHITE).map_err(drawing_error)?;
        let finite: Vec<&Row> = rows.iter().filter(|r| r.psnr_db.is_some()).collect();
        if finite.is_empty() {
            bail!("no setting differs from the reference: nothing to plot");
        }
        let reference = rows.iter().find(|r| r.knob == "reference");
        let (mut t0, mut t1, mut p0, mut p1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for r in &finite {
            let p = r.psnr_db.unwrap_or(0.0);
            t0 = t0.min(r.min_s);
            t1 = t1.max(r.max_s);
            p0 = p0.min(p);
            p1 = p1.max(p);
        }
        if let Some(r) = reference {
            t1 = t1.max(r.median_s);
        }
        let t0 = (t0 * 0.7).max(1e-6);
        let t1 = (t1 * 1.4).max(t0 * 2.0);
        let (p0, p1) = ((p0 - 3.0).floor(), (p1 + 4.0).ceil());
        let title = if smoke {
            format!("{scene}: SMOKE TEST (quick run: tiny sizes, one run each; not a result)")
        } else {
            format!(
                "What accuracy costs: {scene} (PSNR against the reference{})",
                reference.map_or(String::new(), |r| format!(" {}", r.value))
            )
        };
        let knobs = knobs_of(rows);
        let panels = titled_grid(&root, &title, knobs.len())?;
        for ((i, knob), area) in knobs.iter().enumerate().zip(panels.iter()) {
            let colour = COLOURS[i % COLOURS.len()];
            let mut chart = ChartBuilder::on(area)
                .caption(*knob, ("sans-serif", 17))
                .margin(10)
                .x_label_area_size(38)
                .y_label_area_size(48)
                .build_cartesian_2d((t0..t1).log_scale(), p0..p1)
                .map_err(drawing_error)?;
            chart
                .configure_mesh()
                .x_desc("median frame time (s, log)")
                .y_desc("PSNR (dB)")
                .x_labels(5)
                .y_labels(6)
                .x_label_formatter(&|x| seconds(*x))
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(drawing_error)?;
            if let Some(r) = reference {
                let dashes: Vec<(f64, f64)> = (0..12)
                    .flat_map(|k| {
                        let a = p0 + (p1 - p0) * (2 * k) as f64 / 24.0;
                        let b = p0 + (p1 - p0) * (2 * k + 1) as f64 / 24.0;
                        [(r.median_s, a), (r.median_s, b)]
                    })
                    .collect();
                chart
                    .draw_series(dashes.chunks(2).map(|d| {
                        PathElement::new(vec![d[0], d[1]], BLACK.mix(0.5).stroke_width(1))
                    }))
                    .map_err(drawing_error)?;
                // Left of the line, so it stays inside the panel.
                chart
                    .draw_series(std::iter::once(Text::new(
                        format!("reference {} s", seconds(r.median_s)),
                        (r.median_s / 2.4, p1 - 0.4),
                        ("sans-serif", 12).into_font().color(&BLACK.mix(0.6)),
                    )))
                    .map_err(drawing_error)?;
            }
            for (j, curve) in curves(knob).into_iter().enumerate() {
                let colour = if j == 0 {
                    colour
                } else {
                    COLOURS[(i + 2 + j) % COLOURS.len()]
                };
                let knob = &curve;
                let pts: Vec<&&Row> = finite.iter().filter(|r| r.knob == *knob).collect();
                // Spread of the runs: a bar from the fastest to the slowest.
                chart
                    .draw_series(pts.iter().map(|r| {
                        let y = r.psnr_db.unwrap_or(0.0);
                        PathElement::new(vec![(r.min_s, y), (r.max_s, y)], colour.stroke_width(1))
                    }))
                    .map_err(drawing_error)?;
                if !categorical(knob) {
                    chart
                        .draw_series(LineSeries::new(
                            pts.iter().map(|r| (r.median_s, r.psnr_db.unwrap_or(0.0))),
                            colour.stroke_width(2),
                        ))
                        .map_err(drawing_error)?;
                }
                chart
                    .draw_series(pts.iter().map(|r| {
                        Circle::new((r.median_s, r.psnr_db.unwrap_or(0.0)), 4, colour.filled())
                    }))
                    .map_err(drawing_error)?;
                chart
                    .draw_series(pts.iter().filter(|r| is_default(knob, &r.value)).map(|r| {
                        Circle::new(
                            (r.median_s, r.psnr_db.unwrap_or(0.0)),
                            8,
                            BLACK.stroke_width(2),
                        )
                    }))
                    .map_err(drawing_error)?;
                // Value labels beside their markers, cycling through three heights
                // so neighbours at nearly the same time do not overlap.
                let lift = (p1 - p0) / 24.0;
                chart
                    .draw_series(pts.iter().enumerate().map(|(j, r)| {
                        let dy = lift * [1.5, -1.0, 3.5][j % 3];
                        let mut label = r.value.clone();
                        if *knob == PREINTEGRATED {
                            label.push_str(" pre");
                        }
                        if *knob == ADAPTIVE {
                            label = format!("tol {label}");
                        }
                        if is_default(knob, &r.value) {
                            label.push_str(" (default)");
                        }
                        if r.build_s > 0.0 {
                            label.push_str(&format!(" (+{} s build)", seconds(r.build_s)));
                        }
                        Text::new(
                            label,
                            (r.median_s * 1.06, r.psnr_db.unwrap_or(0.0) + dy),
                            ("sans-serif", 12).into_font().color(&colour.mix(0.9)),
                        )
                    }))
                    .map_err(drawing_error)?;
            }
            if *knob == "step" {
                // The frontier: the fastest setting of any knob at each
                // PSNR, as a thin grey line.
                let front: Vec<(f64, f64)> = frontier(rows)
                    .iter()
                    .map(|r| (r.median_s, r.psnr_db.unwrap_or(0.0)))
                    .collect();
                chart
                    .draw_series(LineSeries::new(front, BLACK.mix(0.35).stroke_width(1)))
                    .map_err(drawing_error)?;
            }
        }
        root.present().map_err(drawing_error)?;
        Ok(())
    }
}
