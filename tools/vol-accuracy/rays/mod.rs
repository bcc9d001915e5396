//! The ray-casting study: per scene, a reference render and a sweep of
//! every knob that trades accuracy for time (and on the scenes with
//! effects, the shadow and ambient-occlusion studies), then
//! `accuracy.csv` and a plot per study.

mod chart;
mod csv;
mod frontier;
mod measure;
mod setup;

use crate::drive::Ctx;
use crate::plot::load_font;
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// Run the study on every scene (or the one named `only`), plotting with
/// the font `font` names (or a system one); returns the table written.
pub fn run(ctx: &Ctx, only: Option<&str>, font: Option<&Path>) -> Result<Vec<PathBuf>> {
    let (scenes, sweep) = setup::study(ctx.quick);
    let scenes: Vec<setup::Scene> = match only {
        None => scenes,
        Some(want) => {
            let s: Vec<setup::Scene> = scenes.into_iter().filter(|s| s.name == want).collect();
            if s.is_empty() {
                bail!("unknown scene '{want}' (thesis, noise, boundary, ct)");
            }
            s
        }
    };
    let font = load_font(font)?;
    let mut rows = Vec::new();
    let mut by_scene = Vec::new();
    for scene in &scenes {
        let scene_rows = measure::run_scene(ctx, scene, &sweep)?;
        if font {
            chart::plot(&ctx.out, scene.name, &scene_rows, ctx.quick)?;
        }
        by_scene.push((scene.name, scene_rows.len()));
        rows.extend(scene_rows);
        if scene.effects {
            for study in [
                measure::shadow_study(ctx, scene, &sweep),
                measure::ao_study(ctx, scene, &sweep),
            ] {
                let effect_rows = measure::run_effect(ctx, scene, &study)?;
                if font {
                    chart::plot(&ctx.out, &study.name, &effect_rows, ctx.quick)?;
                }
                rows.extend(effect_rows);
            }
        }
    }
    let csv = ctx.out.join("accuracy.csv");
    csv::write_csv(&csv, &rows)?;
    say!("vol-accuracy: wrote {}", csv.display());
    // Each scene's own rows (its effect studies are other scenes).
    let tables: Vec<(&str, &[measure::Row])> = by_scene
        .iter()
        .map(|&(name, n)| {
            let at = rows.iter().position(|r| r.scene == name).unwrap_or(0);
            (name, &rows[at..(at + n).min(rows.len())])
        })
        .collect();
    let md = ctx.out.join("methods.md");
    frontier::write_table(&md, &tables)?;
    say!("vol-accuracy: wrote {}", md.display());
    Ok(vec![csv, md])
}
