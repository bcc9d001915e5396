//! The first message a page gets: vol-render's options from clap's
//! definition (names, help, defaults, choices: the page keeps no list of
//! its own), the volume, its histogram, the startup view's effective
//! scene and the camera's orbit frame.

use crate::viewer::Viewer;
use clap::{ArgAction, Args, CommandFactory, ValueHint};
use glam::Vec3;
use serde_json::{json, Value};
use volscene::options::PATH_HEADING;
use volscene::{Error, Options};

/// Bins of the histogram sent to the page's transfer function editor.
pub const HISTOGRAM_BINS: usize = 256;

/// The hello message's header.
pub fn hello(viewer: &Viewer, save_dir: bool) -> Result<Value, Error> {
    let plan = viewer.plan(&viewer.startup)?;
    let meta = &viewer.source.volume.meta;
    let camera = camera(viewer, &plan)?;
    Ok(json!({
        "type": "hello",
        "version": env!("CARGO_PKG_VERSION"),
        "options": options(),
        "presets": volrender::tf::PRESETS,
        "scene": shortest(&plan.scene)?,
        "tf": tf_points(plan.tf.as_ref())?,
        "camera": camera,
        "volume": {
            "name": viewer.volume.display().to_string(),
            "dims": [meta.dims.x, meta.dims.y, meta.dims.z],
            "spacing": shortest(&meta.spacing)?,
            "type": format!("{:?}", meta.sample_type).to_lowercase(),
            "range": [meta.range.min, meta.range.max],
            "extent": shortest(&meta.world_extent())?,
            "origin": meta.geometry.origin,
        },
        "histogram": histogram(viewer),
        "save_dir": save_dir,
    }))
}

/// `value` as JSON with every f32 in its shortest form (`0.99`, not the
/// `0.9900000095367432` of its f64 widening): serialised as text, where
/// serde writes an f32 as an f32, and read back.
pub fn shortest<T: serde::Serialize + ?Sized>(value: &T) -> Result<Value, Error> {
    serde_json::to_string(value)
        .and_then(|text| serde_json::from_str(&text))
        .map_err(|e| Error::option(format!("the page's JSON: {e}")))
}

/// A 1D transfer function as the page's editor starts from it: its
/// domain (`null`: the volume's range), reference step, control points
/// `[value, r, g, b, opacity]` and constant ranges `[lo, hi, r, g, b,
/// opacity]`, colours 0-255 as in the TF text; `null` for none or a 2D
/// one (the editor is 1D).
pub fn tf_points(tf: Option<&volrender::tf::Tf>) -> Result<Value, Error> {
    let Some(volrender::tf::Tf::OneD(t)) = tf else {
        return Ok(Value::Null);
    };
    let rgb = |c: [f32; 3]| c.map(|v| (v * 255.0).round());
    let points: Vec<[f32; 5]> = t
        .points
        .iter()
        .map(|p| {
            let [r, g, b] = rgb(p.rgb);
            [p.value, r, g, b, p.alpha]
        })
        .collect();
    let ranges: Vec<[f32; 6]> = t
        .ranges
        .iter()
        .map(|q| {
            let [r, g, b] = rgb(q.rgb);
            [q.lo, q.hi, r, g, b, q.alpha]
        })
        .collect();
    Ok(json!({
        "domain": shortest(&t.domain.map(|(lo, hi)| [lo, hi]))?,
        "step": shortest(&t.reference_step)?,
        "points": shortest(&points)?,
        "ranges": shortest(&ranges)?,
    }))
}

/// Every option of vol-render as the page builds its form from it, but
/// the input selection (`--raw-*`, `--series`, ...), fixed when vol-view
/// opened the volume: taken from its one definition, not named here.
pub fn options() -> Value {
    let selection = volformats::Selection::augment_args(clap::Command::new("input"));
    let fixed = |id: &str| selection.get_arguments().any(|a| a.get_id().as_str() == id);
    let cmd = Options::command();
    let list: Vec<Value> = cmd
        .get_arguments()
        .filter(|a| !a.is_hide_set() && !fixed(a.get_id().as_str()))
        .map(|a| {
            let kind = match a.get_action() {
                ArgAction::SetTrue => "flag",
                ArgAction::Append => "list",
                _ if a.get_num_args().is_some_and(|n| n.min_values() == 0) => "optional",
                _ => "value",
            };
            json!({
                "id": a.get_id().as_str(),
                "long": a.get_long(),
                "help": a.get_help().map(|h| h.to_string()),
                "long_help": a.get_long_help().map(|h| h.to_string()),
                "heading": a.get_help_heading(),
                // The modes the option applies to (`null`: all): the
                // path tracer's options are refused in other modes.
                "modes": (a.get_help_heading() == Some(PATH_HEADING)).then_some(["path"]),
                "kind": kind,
                "defaults": a.get_default_values().iter()
                    .map(|v| v.to_string_lossy().into_owned()).collect::<Vec<_>>(),
                "choices": a.get_possible_values().iter()
                    .filter(|p| !p.is_hide_set())
                    .map(|p| p.get_name().to_string()).collect::<Vec<_>>(),
                "value_name": a.get_value_names().map(|v| v.iter().map(|s| s.to_string()).collect::<Vec<_>>()),
                "path": a.get_value_hint() == ValueHint::AnyPath,
            })
        })
        .collect();
    Value::Array(list)
}

/// The startup camera as an orbit (azimuth, elevation, distance around
/// the look-at point) and the orbit's frame: `front` (azimuth 0), `side`
/// (azimuth 90) and `up`, measured from the cameras the plan makes at
/// those angles, so the page turns the camera as `--orbit` does.
fn camera(viewer: &Viewer, plan: &volscene::Plan) -> Result<Value, Error> {
    let look_at = plan.resolved.look_at;
    let axis = |az: f32, el: f32| -> Result<Vec3, Error> {
        let mut o = viewer.startup.clone();
        o.eye = None;
        o.orbit = Some(Vec3::new(az, el, 1.0));
        o.look_at = Some(look_at);
        o.size = (1, 1);
        let p = viewer.plan(&o)?;
        Ok((p.camera.eye() - look_at).normalize_or_zero())
    };
    let (front, side, up) = (axis(0.0, 0.0)?, axis(90.0, 0.0)?, axis(0.0, 90.0)?);
    let orbit = match plan.resolved.orbit {
        Some(o) => o,
        None => {
            let d = plan.camera.eye() - look_at;
            let dist = d.length();
            let el = (d.dot(up) / dist.max(f32::MIN_POSITIVE))
                .clamp(-1.0, 1.0)
                .asin();
            let az = d.dot(side).atan2(d.dot(front));
            Vec3::new(az.to_degrees(), el.to_degrees(), dist)
        }
    };
    let (w, h) = viewer.startup.size;
    Ok(json!({
        "orbit": orbit.to_array(),
        "look_at": look_at.to_array(),
        "front": front.to_array(),
        "side": side.to_array(),
        "up": up.to_array(),
        "size": [w, h],
        "fov": viewer.startup.fov,
        "diagonal": glam::Vec3::from(viewer.source.volume.meta.world_extent()).length(),
    }))
}

/// The index's histogram in at most [`HISTOGRAM_BINS`] bins, `null`
/// without an index.
fn histogram(viewer: &Viewer) -> Value {
    let Some(ix) = viewer.source.index.as_ref() else {
        return Value::Null;
    };
    let h = ix.histogram();
    let counts = h.counts();
    let group = counts.len().div_ceil(HISTOGRAM_BINS).max(1);
    let merged: Vec<u64> = counts.chunks(group).map(|c| c.iter().sum()).collect();
    // The last group may be short: the bins' top as the page spaces them.
    let hi =
        h.lo() + (h.hi() - h.lo()) * (merged.len() * group) as f64 / counts.len().max(1) as f64;
    json!({"lo": h.lo(), "hi": hi, "counts": merged})
}

#[cfg(test)]
mod tests {
    use super::options;
    use serde_json::{json, Value};
    use volscene::options::PATH_HEADING;

    #[test]
    fn the_form_has_the_render_options_but_not_the_input_selection() {
        let v = options();
        let ids: Vec<&str> = v
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|o| o["id"].as_str())
            .collect();
        for want in ["tf", "mode", "step", "seconds"] {
            assert!(ids.contains(&want), "{want} missing: {ids:?}");
        }
        for fixed in ["raw_dims", "series", "channel", "time_point", "level"] {
            assert!(!ids.contains(&fixed), "{fixed} offered: {ids:?}");
        }
    }

    /// Issue 53 §7: each option under the heading `vol-render --help`
    /// prints it under, and the modes it applies to.
    #[test]
    fn options_carry_their_heading_and_modes() {
        let v = options();
        let by_id = |id: &str| {
            v.as_array()
                .unwrap()
                .iter()
                .find(|o| o["id"] == id)
                .unwrap_or_else(|| panic!("{id} missing"))
                .clone()
        };
        for id in ["ert", "tf", "step", "json"] {
            assert_eq!(by_id(id)["heading"], Value::Null, "{id}: {}", by_id(id));
            assert_eq!(by_id(id)["modes"], Value::Null, "{id}");
        }
        for id in ["spp", "seconds", "bounces", "tonemap"] {
            assert_eq!(by_id(id)["heading"], PATH_HEADING, "{id}");
            assert_eq!(by_id(id)["modes"], json!(["path"]), "{id}");
        }
    }
}
