//! JSON reports: one object per run, with one key vocabulary across the
//! tools (README, "JSON output"), on stdout, or on stderr when stdout
//! carries data (`-o -`).

use serde_json::{json, Value};
use volcore::VolumeMeta;

/// Print `v` on one line: on stderr when `stdout_has_data`, else stdout
/// (a closed stdout is returned as an error, which `run` ends quietly on).
pub fn emit(v: &Value, stdout_has_data: bool) -> std::io::Result<()> {
    if stdout_has_data {
        crate::noteln!("{v}");
        Ok(())
    } else {
        crate::outln!("{v}")
    }
}

/// The `unit` key: the NGFF name of the unit of length (`micrometer`,
/// `millimeter`, ...), or `null` when the volume states none.
pub fn unit(u: volcore::LengthUnit) -> Value {
    u.ngff_name().map_or(Value::Null, Value::from)
}

/// The keys that describe a volume: `dims`, `type`, `spacing`, `unit`, `origin`,
/// `direction` (rows), `orientation`, `layout`, `compression`, `min`,
/// `max` (`null` when no sample but NaN).
pub fn volume(m: &VolumeMeta) -> Value {
    // As the file stores it (f64, not the f32 it is held as).
    let m = &m.as_stored();
    let range = (!m.range.is_empty()).then_some((m.range.min, m.range.max));
    json!({
        "dims": m.dims.as_array(),
        "type": m.sample_type.name(),
        "spacing": m.spacing,
        "unit": unit(m.geometry.unit),
        "origin": m.geometry.origin,
        "direction": m.geometry.direction,
        "orientation": m.geometry.orientation(),
        "layout": m.layout.describe(),
        "compression": match m.compression {
            volcore::Compression::None => "none".to_string(),
            volcore::Compression::Zstd(l) => format!("zstd:{l}"),
        },
        "min": range.map(|r| r.0),
        "max": range.map(|r| r.1),
    })
}

/// Add every key of `extra` (an object) to `v` (an object).
pub fn merge(v: &mut Value, extra: Value) {
    if let (Some(o), Value::Object(e)) = (v.as_object_mut(), extra) {
        o.extend(e);
    }
}
