//! The path tracer's study: what samples and time buy. For each scene
//! (the dense and sparse spheres of `scripts/bench-path.sh`, with its
//! camera, sun, environment and albedo) and each bounce count (single
//! scattering and D = 8), a long reference render (grid majorant, its own
//! seed), then a progressive render continued from its state file through
//! 1, 2, 4, ... samples per pixel with the grid and with the global
//! majorant; every step's image is compared with the reference. PSNR is
//! −20 log10 RMSE, so PSNR against log spp is a log-log plot of the error:
//! an unbiased estimator climbs 10 dB per decade of samples (the
//! O(n^−1/2) line drawn beside the curves). Time is the sum of the passes'
//! render seconds (the volume load and index build are not in it).

use crate::drive::{path_arg, psnr, strs, tool, Ctx};
use crate::files::write_via_temp;
use crate::plot::{drawing_error, legend, seconds, write_png_svg, Chart, COLOURS};
use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

/// A scene of the study.
struct PathScene {
    /// Name in file names and the CSV.
    name: &'static str,
    /// `vol-gen` arguments (without `-o`).
    gen: Vec<String>,
    /// Extinction per world unit at value 255.
    scale: &'static str,
}

/// One measured step of a progressive render.
pub struct PathRow {
    scene: &'static str,
    bounces: u32,
    majorant: &'static str,
    spp: u64,
    /// Render seconds summed over the passes so far.
    seconds: f64,
    psnr_db: f64,
    /// The renderer's own estimate of its relative standard error.
    relative_error: f64,
    /// Extinction lookups per camera path in the last pass.
    lookups_per_path: f64,
}

/// PSNR (dB) at which an image counts as recognisable: the noise is
/// visible but no longer hides the shapes or the light.
pub const RECOGNISABLE_DB: f64 = 30.0;

/// Sizes of a full and a quick study.
struct Sizes {
    dims: u32,
    image: &'static str,
    reference_spp: u64,
    max_spp: u64,
}

fn sizes(quick: bool) -> Sizes {
    if quick {
        Sizes {
            dims: 32,
            image: "32x32",
            reference_spp: 256,
            max_spp: 32,
        }
    } else {
        Sizes {
            dims: 128,
            image: "256x256",
            reference_spp: 4096,
            max_spp: 1024,
        }
    }
}

fn scenes(dims: u32) -> Vec<PathScene> {
    let d = format!("{dims},{dims},{dims}");
    // The sparse scene's spheres keep their size relative to the volume.
    let size = (20 * dims / 128).max(2).to_string();
    vec![
        PathScene {
            name: "dense",
            gen: vec!["spheres".into(), "--dims".into(), d.clone()],
            scale: "0.1",
        },
        PathScene {
            name: "sparse",
            gen: vec![
                "spheres".into(),
                "--dims".into(),
                d,
                "--count".into(),
                "10".into(),
                "--size".into(),
                size,
                "--seed".into(),
                "1".into(),
            ],
            scale: "1",
        },
    ]
}

/// The view and lights of `scripts/bench-path.sh`, scaled to `dims`.
fn view(dims: u32, scene: &PathScene, image: &str) -> Vec<String> {
    let c = (dims - 1) as f64 / 2.0;
    let k = (dims - 1) as f64 / 127.0;
    let eye = [249.53, 198.92, 385.72].map(|e| c + (e - 63.5) * k);
    vec![
        "--mode".into(),
        "path".into(),
        "--density-scale".into(),
        scene.scale.into(),
        "--albedo".into(),
        "0.8".into(),
        "--sun=-1,-1.2,0.4:4".into(),
        "--env".into(),
        "0.1".into(),
        format!("--eye={:.3},{:.3},{:.3}", eye[0], eye[1], eye[2]),
        "--look-at".into(),
        format!("{c},{c},{c}"),
        "--up".into(),
        "0,1,0".into(),
        "--fov".into(),
        "45".into(),
        "--size".into(),
        image.into(),
    ]
}

/// What one `vol-render --mode path` call reported.
struct Pass {
    render_s: f64,
    relative_error: f64,
    lookups_per_path: f64,
    spp: u64,
}

/// Render with `args` on top of `view`, writing `hdr` (and a PNG beside
/// it).
fn render(ctx: &Ctx, vol: &Path, view: &[String], args: &[String], hdr: &Path) -> Result<Pass> {
    let mut all = vec![path_arg(vol)?];
    all.extend(view.iter().cloned());
    all.extend(args.iter().cloned());
    all.extend([
        "-o".into(),
        path_arg(&hdr.with_extension("png"))?,
        "--hdr".into(),
        path_arg(hdr)?,
        "--json".into(),
        "--quiet".into(),
    ]);
    let out = tool(ctx, "vol-render", &all)?;
    let v: serde_json::Value =
        serde_json::from_str(out.trim()).context("vol-render did not print one JSON object")?;
    let num = |k: &str| {
        v[k].as_f64()
            .ok_or_else(|| anyhow!("vol-render JSON has no {k}"))
    };
    Ok(Pass {
        render_s: num("render_s")?,
        relative_error: num("relative_error").unwrap_or(f64::NAN),
        lookups_per_path: num("lookups_per_path")?,
        spp: v["spp"]
            .as_u64()
            .ok_or_else(|| anyhow!("vol-render JSON has no spp"))?,
    })
}

/// The whole path-tracing study; writes `path.csv`, `path.md` (the
/// summary table) and, with a font, `path-SCENE.png` and `.svg`.
pub fn run(ctx: &Ctx, font: bool) -> Result<()> {
    let quick = ctx.quick;
    let z = sizes(quick);
    let mut rows = Vec::new();
    for scene in scenes(z.dims) {
        let vol = ctx.out.join(format!("path-{}.vvol", scene.name));
        let mut gen = scene.gen.clone();
        gen.extend(["-o".into(), path_arg(&vol)?, "--quiet".into()]);
        tool(ctx, "vol-gen", &gen)?;
        let view = view(z.dims, &scene, z.image);
        let mut scene_rows = Vec::new();
        for bounces in [1u32, 8] {
            let tag = format!("path-{}-d{bounces}", scene.name);
            let reference = ctx.out.join(format!("{tag}-reference.pfm"));
            say!("vol-accuracy: {tag}: reference at {} spp", z.reference_spp);
            let b = bounces.to_string();
            // Its own seed: the reference's noise is independent of the
            // renders compared with it.
            render(
                ctx,
                &vol,
                &view,
                &strs(&["--bounces", &b, "--seed", "1000003"])
                    .into_iter()
                    .chain(["--spp".into(), z.reference_spp.to_string()])
                    .collect::<Vec<_>>(),
                &reference,
            )?;
            for majorant in ["grid", "global"] {
                let state = ctx.out.join(format!("{tag}-{majorant}.state"));
                if state.exists() {
                    std::fs::remove_file(&state)
                        .with_context(|| format!("{}: cannot remove", state.display()))?;
                }
                let (mut have, mut secs) = (0u64, 0.0f64);
                let mut target = 1u64;
                while target <= z.max_spp {
                    let hdr = ctx.out.join(format!("{tag}-{majorant}-{target}.pfm"));
                    let add = (target - have).to_string();
                    let pass = render(
                        ctx,
                        &vol,
                        &view,
                        &[
                            "--bounces".into(),
                            b.clone(),
                            "--majorant".into(),
                            majorant.into(),
                            "--spp".into(),
                            add,
                            "--accumulate".into(),
                            path_arg(&state)?,
                        ],
                        &hdr,
                    )?;
                    if pass.spp != target {
                        bail!("{tag}: the state holds {} spp, not {target}", pass.spp);
                    }
                    secs += pass.render_s;
                    have = target;
                    let p = psnr(ctx, &reference, &hdr)?.unwrap_or(f64::INFINITY);
                    say!(
                        "vol-accuracy: {tag} {majorant} {target} spp: {} s, PSNR {p:.2} dB",
                        seconds(secs)
                    );
                    scene_rows.push(PathRow {
                        scene: scene.name,
                        bounces,
                        majorant,
                        spp: target,
                        seconds: secs,
                        psnr_db: p,
                        relative_error: pass.relative_error,
                        lookups_per_path: pass.lookups_per_path,
                    });
                    target *= 2;
                }
            }
        }
        if font {
            plot(&ctx.out, scene.name, &scene_rows, quick)?;
        }
        rows.extend(scene_rows);
    }
    write_via_temp(&ctx.out.join("path.csv"), "partial", &csv(&rows))?;
    let md = summary(&rows);
    write_via_temp(&ctx.out.join("path.md"), "partial", &md)?;
    say!(
        "vol-accuracy: wrote {} and {}",
        ctx.out.join("path.csv").display(),
        ctx.out.join("path.md").display()
    );
    Ok(())
}

/// The CSV of every step.
fn csv(rows: &[PathRow]) -> String {
    let mut s = String::from(
        "scene,bounces,majorant,spp,seconds,psnr_db,relative_error,lookups_per_path\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{:.6},{:.3},{:.6},{:.4}",
            r.scene,
            r.bounces,
            r.majorant,
            r.spp,
            r.seconds,
            r.psnr_db,
            r.relative_error,
            r.lookups_per_path
        );
    }
    s
}

/// A Markdown table: per scene, bounces and majorant, the PSNR at a few
/// sample counts, where the image becomes recognisable, what the last
/// step took, and the slope of PSNR against log10 spp over the second
/// half of the sweep (10 dB per decade for an O(n^−1/2) error).
fn summary(rows: &[PathRow]) -> String {
    let mut s = String::from(
        "| scene | D | majorant | PSNR 1 spp | PSNR 16 spp | PSNR max spp | spp to 30 dB | time to 30 dB | time at max spp | dB per decade | lookups/path |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut keys: Vec<(&str, u32, &str)> = Vec::new();
    for r in rows {
        if !keys.contains(&(r.scene, r.bounces, r.majorant)) {
            keys.push((r.scene, r.bounces, r.majorant));
        }
    }
    for (scene, bounces, majorant) in keys {
        let run: Vec<&PathRow> = rows
            .iter()
            .filter(|r| (r.scene, r.bounces, r.majorant) == (scene, bounces, majorant))
            .collect();
        let at = |spp: u64| {
            run.iter()
                .find(|r| r.spp == spp)
                .map_or("-".to_string(), |r| format!("{:.1}", r.psnr_db))
        };
        let Some(last) = run.last() else { continue };
        let first_ok = run.iter().find(|r| r.psnr_db >= RECOGNISABLE_DB);
        let _ = writeln!(
            s,
            "| {scene} | {bounces} | {majorant} | {} | {} | {:.1} ({} spp) | {} | {} | {} s | {} | {:.2} |",
            at(1),
            at(16),
            last.psnr_db,
            last.spp,
            first_ok.map_or("> max".to_string(), |r| r.spp.to_string()),
            first_ok.map_or("-".to_string(), |r| format!("{} s", seconds(r.seconds))),
            seconds(last.seconds),
            slope(&run).map_or("-".to_string(), |k| format!("{k:.1}")),
            last.lookups_per_path
        );
    }
    s
}

/// Least-squares slope of PSNR against log10 spp over the second half of
/// a run's steps.
fn slope(run: &[&PathRow]) -> Option<f64> {
    let tail = &run[run.len() / 2..];
    if tail.len() < 2 {
        return None;
    }
    let n = tail.len() as f64;
    let xs: Vec<f64> = tail.iter().map(|r| (r.spp as f64).log10()).collect();
    let ys: Vec<f64> = tail.iter().map(|r| r.psnr_db).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    (sxx > 0.0 && sxy.is_finite()).then(|| sxy / sxx)
}

/// PSNR against spp and against time for one scene, as PNG and SVG.
fn plot(out: &Path, scene: &str, rows: &[PathRow], smoke: bool) -> Result<()> {
    let png = out.join(format!("path-{scene}.png"));
    let svg = out.join(format!("path-{scene}.svg"));
    let chart = PathChart { scene, rows, smoke };
    write_png_svg(&png, &svg, (1100, 480), &chart)
}

/// One scene's plot: its name, its rows, and whether a quick run made it.
struct PathChart<'a> {
    scene: &'a str,
    rows: &'a [PathRow],
    smoke: bool,
}

/// Both panels on any backend: one curve per (bounces, majorant), the
/// grid solid and the global majorant dashed, and the n^−1/2 line
/// through the first single-scattering grid point.
impl Chart for PathChart<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (scene, rows, smoke) = (self.scene, self.rows, self.smoke);
        root.fill(&WHITE).map_err(drawing_error)?;
        let finite: Vec<&PathRow> = rows.iter().filter(|r| r.psnr_db.is_finite()).collect();
        if finite.is_empty() {
            bail!("no finite PSNR to plot");
        }
        let title = if smoke {
            format!("path-{scene}: SMOKE TEST (quick run: tiny sizes; not a result)")
        } else {
            format!(
                "Path tracing, {scene} spheres: PSNR against the reference, by samples and by time"
            )
        };
        let body = root
            .titled(&title, ("sans-serif", 20))
            .map_err(drawing_error)?;
        let (p0, p1) = finite.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
            (a.min(r.psnr_db), b.max(r.psnr_db))
        });
        let (p0, p1) = ((p0 - 3.0).floor(), (p1 + 3.0).ceil());
        let max_spp = finite.iter().map(|r| r.spp).max().unwrap_or(1) as f64;
        let (t0, t1) = finite.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
            (a.min(r.seconds), b.max(r.seconds))
        });
        let (t0, t1) = ((t0 * 0.7).max(1e-6), (t1 * 1.4).max(t0 * 2.0));
        let panels = body.split_evenly((1, 2));
        let curves: Vec<(u32, &str)> = vec![(1, "grid"), (1, "global"), (8, "grid"), (8, "global")];
        for (panel, by_time) in panels.iter().zip([false, true]) {
            let x_of = |r: &PathRow| if by_time { r.seconds } else { r.spp as f64 };
            let (x0, x1) = if by_time {
                (t0, t1)
            } else {
                (0.8, max_spp * 1.25)
            };
            let mut chart = ChartBuilder::on(panel)
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d((x0..x1).log_scale(), p0..p1)
                .map_err(drawing_error)?;
            chart
                .configure_mesh()
                .x_desc(if by_time {
                    "render time (s, log)"
                } else {
                    "samples per pixel (log)"
                })
                .y_desc("PSNR (dB)")
                .x_labels(6)
                .y_labels(8)
                .x_label_formatter(&|x| {
                    if by_time {
                        seconds(*x)
                    } else {
                        format!("{x:.0}")
                    }
                })
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(drawing_error)?;
            for (i, (bounces, majorant)) in curves.iter().enumerate() {
                let colour = COLOURS[(i / 2) % COLOURS.len()];
                let pts: Vec<(f64, f64)> = finite
                    .iter()
                    .filter(|r| r.bounces == *bounces && r.majorant == *majorant)
                    .map(|r| (x_of(r), r.psnr_db))
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let label = format!("D = {bounces}, {majorant} majorant");
                let style = colour.stroke_width(2);
                if *majorant == "grid" {
                    chart
                        .draw_series(LineSeries::new(pts.clone(), style))
                        .map_err(drawing_error)?
                        .label(label)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
                } else {
                    chart
                        .draw_series(DashedLineSeries::new(pts.clone(), 6, 4, style))
                        .map_err(drawing_error)?
                        .label(label)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 8, y)], style));
                }
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(drawing_error)?;
            }
            // The O(n^-1/2) line: +10 dB per decade of samples (or of time,
            // which grows with them), through the first D = 1 grid point.
            if let Some(r) = finite
                .iter()
                .find(|r| r.bounces == 1 && r.majorant == "grid")
            {
                let (xa, ya) = (x_of(r), r.psnr_db);
                let xb = x1;
                let line = vec![(xa, ya), (xb, ya + 10.0 * (xb / xa).log10())];
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        line,
                        BLACK.mix(0.5).stroke_width(1),
                    )))
                    .map_err(drawing_error)?
                    .label("error ∝ n^-1/2 (10 dB per decade)")
                    .legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.5).stroke_width(1))
                    });
            }
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("recognisable: {RECOGNISABLE_DB:.0} dB"),
                    (x0 * 1.1, RECOGNISABLE_DB + 0.4),
                    ("sans-serif", 12).into_font().color(&BLACK.mix(0.6)),
                )))
                .map_err(drawing_error)?;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(x0, RECOGNISABLE_DB), (x1, RECOGNISABLE_DB)],
                    BLACK.mix(0.25).stroke_width(1),
                )))
                .map_err(drawing_error)?;
            legend(&mut chart)?;
        }
        root.present().map_err(drawing_error)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(spp: u64, psnr_db: f64) -> PathRow {
        PathRow {
            scene: "dense",
            bounces: 1,
            majorant: "grid",
            spp,
            seconds: spp as f64 * 0.01,
            psnr_db,
            relative_error: 0.1,
            lookups_per_path: 1.0,
        }
    }

    #[test]
    fn slope_of_an_n_to_the_minus_half_error_is_ten_db_per_decade() {
        let rows: Vec<PathRow> = (0..10)
            .map(|k| {
                let n = 1u64 << k;
                row(n, 20.0 + 10.0 * (n as f64).log10())
            })
            .collect();
        let refs: Vec<&PathRow> = rows.iter().collect();
        let k = slope(&refs).unwrap();
        assert!((k - 10.0).abs() < 1e-9, "{k}");
        assert_eq!(slope(&refs[..2]), None);
    }

    #[test]
    fn summary_names_where_the_image_becomes_recognisable() {
        let rows: Vec<PathRow> = [(1, 18.0), (2, 21.0), (4, 24.0), (8, 27.5), (16, 30.5)]
            .into_iter()
            .map(|(n, p)| row(n, p))
            .collect();
        let md = summary(&rows);
        let line = md.lines().nth(2).unwrap();
        assert!(
            line.starts_with("| dense | 1 | grid | 18.0 | 30.5 | 30.5 (16 spp) | 16 | 0.16 s |"),
            "{line}"
        );
        let never = summary(&rows[..3]);
        assert!(never.contains("> max"), "{never}");
    }
}
