//! What each sampling method costs to reach an error: the frontier of a
//! scene's settings (the fastest at each PSNR), and the time a method's
//! curve needs for a PSNR, written as `methods.md`.

use super::measure::{Row, ADAPTIVE, BUDGET, PREINTEGRATED};
use crate::files::write_via_temp;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The methods compared: (knob, name in tables).
pub const METHODS: [(&str, &str); 4] = [
    ("step", "step"),
    (PREINTEGRATED, "pre-integrated"),
    (ADAPTIVE, "adaptive"),
    (BUDGET, "budget"),
];

/// PSNR levels the table reports the time for.
pub const LEVELS_DB: [f64; 3] = [40.0, 45.0, 50.0];

/// The rows no faster row beats in PSNR, fastest first: what the scene's
/// best setting is at each time (rows equal to the reference left out).
pub fn frontier(rows: &[Row]) -> Vec<&Row> {
    let mut finite: Vec<&Row> = rows.iter().filter(|r| r.psnr_db.is_some()).collect();
    finite.sort_by(|a, b| a.median_s.total_cmp(&b.median_s));
    let mut best = f64::NEG_INFINITY;
    finite
        .into_iter()
        .filter(|r| {
            let p = r.psnr_db.unwrap_or(f64::NEG_INFINITY);
            let better = p > best;
            best = best.max(p);
            better
        })
        .collect()
}

/// The median time `knob`'s curve needs to reach `db`: interpolated
/// between the fastest point at or above it and the slowest faster point
/// below it, linearly in PSNR and log time; `None` when no point reaches
/// it.
pub fn time_to(rows: &[Row], knob: &str, db: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.knob == knob)
        .filter_map(|r| r.psnr_db.map(|p| (r.median_s, p)))
        .filter(|(t, p)| *t > 0.0 && p.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (i, &(t1, p1)) = pts.iter().enumerate().find(|(_, (_, p))| *p >= db)?;
    let below = pts[..i].iter().rev().find(|(_, p)| *p < db);
    Some(match below {
        Some(&(t0, p0)) if p1 > p0 => {
            let f = (db - p0) / (p1 - p0);
            (t0.ln() + f * (t1.ln() - t0.ln())).exp()
        }
        _ => t1,
    })
}

/// Write `methods.md`: per scene and method, the time to each of
/// [`LEVELS_DB`] and the best PSNR reached, with its time.
pub fn write_table(path: &Path, scenes: &[(&str, &[Row])]) -> Result<()> {
    let mut s = String::from(
        "| scene | method | time to 40 dB | time to 45 dB | time to 50 dB | best PSNR (time) |\n\
         |---|---|---|---|---|---|\n",
    );
    for (scene, rows) in scenes {
        for (knob, name) in METHODS {
            let best = rows
                .iter()
                .filter(|r| r.knob == knob)
                .filter_map(|r| r.psnr_db.map(|p| (p, r.median_s)))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            let Some((db, t)) = best else { continue };
            let _ = write!(s, "| {scene} | {name} |");
            for level in LEVELS_DB {
                let cell = time_to(rows, knob, level).map_or("–".into(), |t| format!("{t:.4} s"));
                let _ = write!(s, " {cell} |");
            }
            let _ = writeln!(s, " {db:.2} dB ({t:.4} s) |");
        }
    }
    write_via_temp(path, "md.partial", &s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(knob: &'static str, t: f64, db: Option<f64>) -> Row {
        Row {
            scene: "s".into(),
            knob,
            value: String::new(),
            median_s: t,
            min_s: t,
            max_s: t,
            samples: 0,
            psnr_db: db,
            build_s: 0.0,
        }
    }

    #[test]
    fn time_to_interpolates_in_log_time_and_says_when_nothing_reaches() {
        let rows = vec![
            row("step", 0.01, Some(30.0)),
            row("step", 0.04, Some(40.0)),
            row("step", 0.16, Some(50.0)),
            row("other", 0.001, Some(60.0)),
        ];
        assert!((time_to(&rows, "step", 40.0).unwrap() - 0.04).abs() < 1e-12);
        assert!((time_to(&rows, "step", 45.0).unwrap() - 0.08).abs() < 1e-12);
        assert!((time_to(&rows, "step", 35.0).unwrap() - 0.02).abs() < 1e-12);
        assert_eq!(time_to(&rows, "step", 55.0), None);
        assert_eq!(time_to(&rows, "step", 20.0), Some(0.01));
    }

    #[test]
    fn the_frontier_keeps_only_settings_no_faster_one_beats() {
        let rows = vec![
            row("a", 0.3, Some(45.0)),
            row("a", 0.1, Some(40.0)),
            row("b", 0.2, Some(38.0)),
            row("b", 0.05, Some(30.0)),
            row("reference", 1.0, None),
        ];
        let f: Vec<f64> = frontier(&rows).iter().map(|r| r.median_s).collect();
        assert_eq!(f, [0.05, 0.1, 0.3]);
    }
}
