//! The ray-casting study's measurements: each scene's reference and
//! knob sweep, and the shadow and ambient-occlusion studies, one CSV row
//! per setting.

use super::setup::{
    Scene, Sweep, ADAPTIVE_STEP, AO_AMBIENT, AO_REF_RAYS, BASE_ERT, BASE_STEP, REF_STEP,
    SHADOW_LIGHT, SHADOW_REF_STEP,
};
use crate::drive::{path_arg, psnr, render, strs, tool, Ctx, Timing};
use anyhow::{Context, Result};
use std::path::Path;

/// The knob of steps swept with `--preintegrated` (its values are steps).
pub const PREINTEGRATED: &str = "preintegrated";

/// The knob of adaptive steps' tolerances (`--adaptive TOL` at
/// [`ADAPTIVE_STEP`]).
pub const ADAPTIVE: &str = "adaptive";

/// The knob of frame-time budgets (`--budget SECONDS` at
/// [`BASE_STEP`]).
pub const BUDGET: &str = "budget";

/// One measured setting: a row of the CSV.
pub struct Row {
    /// Scene (or effect study) name.
    pub scene: String,
    /// The knob swept.
    pub knob: &'static str,
    /// Its value, as written in the CSV.
    pub value: String,
    /// Median frame time, seconds.
    pub median_s: f64,
    /// Fastest run, seconds.
    pub min_s: f64,
    /// Slowest run, seconds.
    pub max_s: f64,
    /// Samples taken.
    pub samples: u64,
    /// None when the image equals the reference.
    pub psnr_db: Option<f64>,
    /// Seconds of precomputation outside the frame time (an AO field).
    pub build_s: f64,
}

/// Generate, render the reference, sweep every knob; returns the rows.
pub fn run_scene(ctx: &Ctx, scene: &Scene, sweep: &Sweep) -> Result<Vec<Row>> {
    let vol = ctx.out.join(format!("{}.vvol", scene.name));
    let mut gen = scene.gen.clone();
    gen.extend(["-o".into(), path_arg(&vol)?, "--quiet".into()]);
    tool(ctx, "vol-gen", &gen)?;
    let mut view = scene.view.clone();
    if let Some(tf) = scene.tf_file {
        let tf_path = ctx.out.join(format!("{}.tf", scene.name));
        std::fs::write(&tf_path, tf)
            .with_context(|| format!("{}: cannot write", tf_path.display()))?;
        view.extend(["--tf".into(), path_arg(&tf_path)?]);
    }
    let reference = ctx.out.join(format!("{}-reference.pfm", scene.name));
    let ref_step = REF_STEP.pick(ctx.quick);
    say!(
        "vol-accuracy: {}: reference at step {}",
        scene.name,
        ref_step
    );
    let r = render(
        ctx,
        &vol,
        &view,
        &strs(&["--step", ref_step, "--no-ert"]),
        &reference,
        ctx.repeat,
    )?;
    // The reference is the first row (PSNR inf), so times can be compared
    // with it.
    let mut rows = vec![reference_row(&r, scene.name, ref_step.into())];

    // (knob, value as written in the CSV, vol-render arguments)
    let mut settings: Vec<(&'static str, String, Vec<String>)> = Vec::new();
    for s in &sweep.step {
        settings.push(("step", s.to_string(), strs(&["--step", s])));
    }
    if scene.tf_1d {
        for s in &sweep.step {
            let args = strs(&["--step", s, "--preintegrated"]);
            settings.push((PREINTEGRATED, s.to_string(), args));
        }
        for tol in &sweep.adaptive {
            let args = strs(&["--step", ADAPTIVE_STEP, "--adaptive", tol]);
            settings.push((ADAPTIVE, tol.to_string(), args));
        }
    }
    for b in &sweep.budget {
        let args = strs(&["--step", BASE_STEP, "--budget", b]);
        settings.push((BUDGET, b.to_string(), args));
    }
    for e in &sweep.ert {
        let a = if *e == "off" {
            strs(&["--no-ert"])
        } else {
            strs(&["--ert", e])
        };
        settings.push(("ert", e.to_string(), a));
    }
    for i in ["nearest", "trilinear"] {
        settings.push(("interp", i.into(), strs(&["--interp", i])));
    }
    for g in ["central", "analytic"] {
        settings.push(("gradient", g.into(), strs(&["--gradient", g])));
    }
    for c in &sweep.cell {
        settings.push(("cell", c.to_string(), strs(&["--cell", c])));
    }
    for t in &sweep.tile {
        settings.push(("tile", t.to_string(), strs(&["--tile", t])));
    }
    for t in &sweep.threads {
        settings.push(("threads", t.to_string(), strs(&["--threads", t])));
    }

    for (knob, value, args) in settings {
        // The base settings, except for the knob being swept.
        let mut all = Vec::new();
        if !matches!(knob, "step" | PREINTEGRATED | ADAPTIVE | BUDGET) {
            all.extend(strs(&["--step", BASE_STEP]));
        }
        if knob != "ert" {
            all.extend(strs(&["--ert", BASE_ERT]));
        }
        all.extend(args);
        let m = Measured {
            scene: scene.name,
            vol: &vol,
            view: &view,
            reference: &reference,
        };
        rows.push(m.row(ctx, knob, value, &all)?);
    }
    Ok(rows)
}

/// What every setting of one study is measured against.
struct Measured<'a> {
    scene: &'a str,
    vol: &'a Path,
    view: &'a [String],
    reference: &'a Path,
}

impl Measured<'_> {
    /// Render with `args` on top of the view, time it, compare it with the
    /// reference: one row.
    fn row(&self, ctx: &Ctx, knob: &'static str, value: String, args: &[String]) -> Result<Row> {
        let name = self.scene;
        let hdr = ctx
            .out
            .join(format!("{name}-{}-{value}.pfm", knob.replace(' ', "-")));
        let r = render(ctx, self.vol, self.view, args, &hdr, ctx.repeat)?;
        let psnr_db = psnr(ctx, self.reference, &hdr)?;
        say!(
            "vol-accuracy: {name} {knob}={value}: {:.4} s, PSNR {}",
            r.median_s,
            psnr_db.map_or("inf".to_string(), |p| format!("{p:.2} dB"))
        );
        Ok(Row {
            scene: name.into(),
            knob,
            value,
            median_s: r.median_s,
            min_s: r.min_s,
            max_s: r.max_s,
            samples: r.samples,
            psnr_db,
            build_s: r.build_s,
        })
    }
}

/// One effect's study: the scene seen at the base step and termination
/// with `extra` on top, a reference render, and the settings compared
/// with it.
pub struct EffectStudy {
    /// Scene name in the CSV and file names.
    pub name: String,
    /// Arguments on top of the scene's view.
    extra: Vec<String>,
    /// The reference's value (as written in the CSV) and arguments.
    reference: (String, Vec<String>),
    /// (knob, value, arguments) per point.
    settings: Vec<(&'static str, String, Vec<String>)>,
}

/// What shadows cost and buy: lit by one directional light; the reference
/// casts shadow rays at a fine shadow step, the points are shadows off,
/// shadow rays at coarser steps, and light grids at each divisor.
pub fn shadow_study(ctx: &Ctx, scene: &Scene, sweep: &Sweep) -> EffectStudy {
    let ref_step = SHADOW_REF_STEP.pick(ctx.quick);
    let mut settings: Vec<(&'static str, String, Vec<String>)> =
        vec![("shadows off", "off".into(), Vec::new())];
    for st in &sweep.shadow_steps {
        settings.push((
            "shadow rays",
            st.to_string(),
            strs(&["--shadows", "ray", "--shadow-step", st]),
        ));
    }
    for d in &sweep.shadow_grids {
        settings.push((
            "shadow grid",
            d.to_string(),
            vec!["--shadows".into(), format!("grid:{d}")],
        ));
    }
    EffectStudy {
        name: format!("{}-shadows", scene.name),
        extra: strs(&["--light", SHADOW_LIGHT]),
        reference: (
            format!("ray:{ref_step}"),
            strs(&["--shadows", "ray", "--shadow-step", ref_step]),
        ),
        settings,
    }
}

/// What ambient occlusion costs and buys: one directional light and a
/// strong ambient term; the reference occludes with many directions per
/// shaded sample, the points are AO off, N sampled directions, and fields
/// of K directions (whose precomputation is timed apart).
pub fn ao_study(ctx: &Ctx, scene: &Scene, sweep: &Sweep) -> EffectStudy {
    let ref_rays = AO_REF_RAYS.pick(ctx.quick);
    let mut settings: Vec<(&'static str, String, Vec<String>)> =
        vec![("AO off", "off".into(), Vec::new())];
    for n in &sweep.ao_rays {
        settings.push(("AO rays", n.to_string(), strs(&["--ao", n])));
    }
    for k in &sweep.ao_fields {
        settings.push(("AO field", k.to_string(), strs(&["--ao-field", k])));
    }
    for c in &sweep.ao_field_cells {
        settings.push((
            "AO field cell",
            c.to_string(),
            strs(&["--ao-field", "32", "--ao-field-cell", c]),
        ));
    }
    EffectStudy {
        name: format!("{}-ao", scene.name),
        extra: strs(&["--light", SHADOW_LIGHT, "--ambient", AO_AMBIENT]),
        reference: (format!("rays:{ref_rays}"), strs(&["--ao", ref_rays])),
        settings,
    }
}

/// Run an effect study of `scene` (whose volume the main study made).
pub fn run_effect(ctx: &Ctx, scene: &Scene, study: &EffectStudy) -> Result<Vec<Row>> {
    let name = study.name.as_str();
    let vol = ctx.out.join(format!("{}.vvol", scene.name));
    let mut view = scene.view.clone();
    if scene.tf_file.is_some() {
        let tf_path = ctx.out.join(format!("{}.tf", scene.name));
        view.extend(["--tf".into(), path_arg(&tf_path)?]);
    }
    view.extend(strs(&["--step", BASE_STEP, "--ert", BASE_ERT]));
    view.extend(study.extra.iter().cloned());
    let reference = ctx.out.join(format!("{name}-reference.pfm"));
    let (ref_value, ref_args) = &study.reference;
    say!("vol-accuracy: {name}: reference {}", ref_args.join(" "));
    let r = render(ctx, &vol, &view, ref_args, &reference, ctx.repeat)?;
    let mut rows = vec![reference_row(&r, name, ref_value.clone())];
    let m = Measured {
        scene: name,
        vol: &vol,
        view: &view,
        reference: &reference,
    };
    for (knob, value, args) in &study.settings {
        rows.push(m.row(ctx, knob, value.clone(), args)?);
    }
    Ok(rows)
}

/// The row of a study's reference (PSNR inf) timed `t`, written first so
/// the other times can be compared with it.
fn reference_row(t: &Timing, scene: &str, value: String) -> Row {
    Row {
        scene: scene.into(),
        knob: "reference",
        value,
        median_s: t.median_s,
        min_s: t.min_s,
        max_s: t.max_s,
        samples: t.samples,
        psnr_db: None,
        build_s: t.build_s,
    }
}
