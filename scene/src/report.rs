//! The figures of a render: one JSON object (what `vol-render --json`
//! prints, with the same keys for every caller) and the lines vol-render
//! prints for people without `--json`.

use crate::options::Options;
use crate::render::{Budgeted, Image, Rendered, Times, Traced};
use serde_json::{json, Value};
use std::path::Path;
use volrender::Frame;

/// A render's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The `--json` object.
    pub json: Value,
    /// The summary for people, one line each, without the tool's name.
    pub lines: Vec<String>,
}

/// What a data-parallel frame adds to the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Extra {
    /// A JSON object whose keys join the report's.
    pub json: Value,
    /// One line (without the tool's name), after the summary's first.
    pub line: String,
}

/// Where a render came from and went, for its report.
#[derive(Clone, Copy, Debug)]
pub struct Context<'a> {
    /// The options as resolved (the scene file merged).
    pub options: &'a Options,
    /// The volume's path.
    pub volume: &'a Path,
    /// The output PNG, when there is one (`null` in the JSON otherwise).
    pub output: Option<&'a Path>,
    /// The effective scene as JSON (the `scene` key).
    pub scene: &'a Value,
}

impl Context<'_> {
    /// The output's name for the summary.
    fn output_name(&self) -> String {
        self.output
            .map_or_else(|| "-".to_string(), |o| o.display().to_string())
    }
}

impl Rendered {
    /// The figures of this render.
    pub fn report(&self, cx: &Context) -> Report {
        let mut report = match &self.image {
            Image::Frame(f) => frame_report(cx, f, &self.times, None),
            Image::Path(t) => path_report(cx, t, &self.times),
        };
        if let Some(b) = &self.budget {
            add_budget(&mut report, b, self.times.render_s);
        }
        report
    }
}

/// What `--budget` chose, in the JSON (`budget`) and as a line: the step
/// and scale, the expected and measured seconds (the frame's with its
/// upsampling; the probes' apart) and the expected PSNR.
fn add_budget(report: &mut Report, b: &Budgeted, render_s: f64) {
    let c = &b.choice;
    let psnr = c.expected_psnr();
    report.json["budget"] = json!({
        "seconds": b.seconds,
        "step": c.step,
        "base_step": b.base_step,
        "step_factor": c.step_factor,
        "scale": c.scale,
        "rendered_width": c.width,
        "rendered_height": c.height,
        "expected_s": c.expected_s,
        "measured_s": render_s,
        "probe_s": b.probe_s,
        "upsample_s": b.upsample_s,
        "expected_psnr": psnr,
        "fits": c.fits,
        "model": {
            "fixed_s": b.model.cost.fixed_s,
            "per_sample_s": b.model.cost.per_sample_s,
            "probe_scale": b.model.cost.probe_scale,
            "dense_factor": b.model.cost.dense_factor,
            "samples_per_pixel": b.model.cost.samples_per_pixel,
            "at_step": b.model.cost.at_step,
            "step_order": b.model.error.order,
            "step_c2": b.model.error.step_c2,
            "scale_mse": b.model.error.scale_mse,
        },
    });
    report.lines.push(format!(
        "budget {} s: step {:.4} ({}x the base {:.4}), rendered {}x{} (scale {:.3}); expected {:.4} s, \
         measured {:.4} s after {:.4} s of probes; expected PSNR {}",
        b.seconds,
        c.step,
        c.step_factor,
        b.base_step,
        c.width,
        c.height,
        c.scale,
        c.expected_s,
        render_s,
        b.probe_s,
        psnr.map_or_else(|| "inf".to_string(), |p| format!("{p:.1} dB")),
    ));
    if !c.fits {
        report.lines.push(format!(
            "note: the budget is below the coarsest setting's expected {:.4} s with {:.4} s of \
             probes: rendered the coarsest",
            c.expected_s, b.probe_s
        ));
    }
}

/// The process's peak resident memory in MiB (Linux; `None` elsewhere).
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// The figures of a ray-cast frame; `extra` adds a data-parallel job's.
pub fn frame_report(cx: &Context, frame: &Frame, t: &Times, extra: Option<&Extra>) -> Report {
    let cli = cx.options;
    let s = &frame.stats;
    let (load_s, index_s, render_s) = (t.load_s, t.index_s, t.render_s);
    let mpix = (frame.width as f64 * frame.height as f64) / 1e6;
    let mut v = json!({
        "tool": "vol-render",
        "input": cx.volume.display().to_string(),
        "output": cx.output.map(|o| o.display().to_string()),
        "mode": format!("{:?}", cli.mode).to_lowercase(),
        "width": frame.width,
        "height": frame.height,
        "threads": rayon::current_num_threads(),
        "rays": s.rays,
        "samples": s.samples,
        "skips": s.skips,
        "culled_blocks": s.culled_blocks,
        "load_s": load_s,
        "index_s": index_s,
        "render_s": render_s,
        "render_runs_s": t.runs,
        "samples_per_s": s.samples as f64 / render_s.max(1e-12),
        "ert": !cli.no_ert,
        "ess": !cli.no_ess,
        "peak_rss_mb": peak_rss_mb(),
        "scene": cx.scene,
    });
    if let (Some(r), Some(obj)) = (extra, v.as_object_mut()) {
        if let Some(more) = r.json.as_object() {
            obj.extend(more.clone());
        }
    }
    if cli.mode == crate::options::ModeArg::Dvr {
        v["table_s"] = s.table_s.into();
        v["table_bytes"] = s.table_bytes.into();
    }
    let e = &s.effects;
    let field_cell = cli
        .ao_field_cell
        .unwrap_or(volrender::effects::ao::DEFAULT_AO_FIELD_CELL);
    // Each effect's counters, only when it is on.
    if cli.shadows.is_some() {
        v["shadow_rays"] = e.shadow_rays.into();
        v["shadow_samples"] = e.shadow_samples.into();
        v["shadow_grids"] = e.shadow_grids.into();
        v["shadow_grid_s"] = e.shadow_grid_s.into();
        v["shadow_grid_bytes"] = e.shadow_grid_bytes.into();
        v["shadow_grid_samples"] = e.shadow_grid_samples.into();
    }
    if cli.ao.is_some() || cli.ao_field.is_some() {
        v["ao_rays"] = e.ao_rays.into();
        v["ao_samples"] = e.ao_samples.into();
        v["ao_grid_s"] = e.ao_grid_s.into();
        v["ao_grid_bytes"] = e.ao_grid_bytes.into();
        v["ao_grid_samples"] = e.ao_grid_samples.into();
    }
    if cli.ao_field.is_some() {
        v["ao_field_s"] = e.ao_field_s.into();
        v["ao_field_bytes"] = e.ao_field_bytes.into();
        v["ao_field_samples"] = e.ao_field_samples.into();
        v["ao_field_cell"] = field_cell.into();
    }
    let mut lines = vec![format!(
        "{} {}x{} in {:.3} s ({:.1} Mpix/s), {} rays, {:.1} M samples, {} skips; load {:.2} s, index {:.2} s",
        cx.output_name(),
        frame.width,
        frame.height,
        render_s,
        mpix / render_s.max(1e-12),
        s.rays,
        s.samples as f64 / 1e6,
        s.skips,
        load_s,
        index_s
    )];
    if let Some(r) = extra {
        lines.push(r.line.clone());
    }
    if cli.shadows.is_some() {
        lines.push(format!(
            "shadows: {} shadow rays, {:.1} M shadow samples; {} grids ({:.1} MB, built in {:.3} s)",
            e.shadow_rays,
            e.shadow_samples as f64 / 1e6,
            e.shadow_grids,
            e.shadow_grid_bytes as f64 / 1e6,
            e.shadow_grid_s
        ));
    }
    if cli.ao.is_some() || cli.ao_field.is_some() {
        lines.push(format!(
            "ambient occlusion: {} rays, {:.1} M grid reads; occlusion grid {:.1} MB built in {:.3} s{}",
            e.ao_rays,
            e.ao_samples as f64 / 1e6,
            e.ao_grid_bytes as f64 / 1e6,
            e.ao_grid_s,
            if cli.ao_field.is_some() {
                format!(
                    "; field (points every {} voxels) {:.1} MB precomputed in {:.3} s (not in the frame time)",
                    field_cell,
                    e.ao_field_bytes as f64 / 1e6,
                    e.ao_field_s
                )
            } else {
                String::new()
            }
        ));
    }
    Report { json: v, lines }
}

/// The figures of a path-traced render.
pub fn path_report(cx: &Context, traced: &Traced, t: &Times) -> Report {
    let cli = cx.options;
    let (acc, n) = (&traced.acc, &traced.counters);
    let render_s = t.render_s;
    let threads = rayon::current_num_threads();
    let paths_per_s = n.paths as f64 / render_s.max(1e-12);
    let lookups_per_path = n.density_lookups as f64 / n.paths.max(1) as f64;
    let error = acc.relative_error();
    let json = json!({
        "tool": "vol-render",
        "input": cx.volume.display().to_string(),
        "output": cx.output.map(|o| o.display().to_string()),
        "mode": "path",
        "width": acc.width(),
        "height": acc.height(),
        "threads": threads,
        "spp": acc.spp(),
        "spp_added": traced.spp_added,
        "paths": n.paths,
        "real_collisions": n.real_collisions,
        "null_collisions": n.null_collisions,
        "majorant_cells": n.majorant_cells,
        "empty_cells": n.empty_cells,
        "empty_jumps": n.empty_jumps,
        "culled_paths": n.culled_paths,
        "voxel_cells": n.voxel_cells,
        "density_lookups": n.density_lookups,
        "shadow_rays": n.shadow_rays,
        "scatter_events": n.scatter_events,
        "surface_events": n.surface_events,
        "bounce_rays": n.bounce_rays,
        "capped": n.capped,
        "truncated": n.truncated,
        "non_finite": n.non_finite,
        "majorant": cli.majorant,
        "sampler": cli.sampler,
        "transmittance": cli.transmittance,
        "empty_cell_fraction": traced.empty_fraction,
        "load_s": t.load_s,
        "index_s": t.index_s,
        "render_s": render_s,
        "paths_per_s": paths_per_s,
        "paths_per_s_per_core": paths_per_s / threads.max(1) as f64,
        "lookups_per_path": lookups_per_path,
        "relative_error": error,
        "peak_rss_mb": peak_rss_mb(),
        "scene": cx.scene,
    });
    let mut lines = vec![format!(
        "{} {}x{} path traced: {} spp ({} added) in {:.3} s, {:.2} M paths/s, {:.1} lookups per path{}; load {:.2} s, index {:.2} s",
        cx.output_name(),
        acc.width(),
        acc.height(),
        acc.spp(),
        traced.spp_added,
        render_s,
        paths_per_s / 1e6,
        lookups_per_path,
        error.map_or(String::new(), |e| format!(", error {:.2}%", e * 100.0)),
        t.load_s,
        t.index_s
    )];
    if n.truncated + n.non_finite > 0 {
        lines.push(format!(
            "{} tracking calls hit the collision limit, {} samples were not finite (dropped)",
            n.truncated, n.non_finite
        ));
    }
    Report { json, lines }
}
