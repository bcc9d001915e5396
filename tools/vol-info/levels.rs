//! The pyramid levels of an OME-Zarr input: how many, each one's dims
//! and spacing, and which one is described (`--level N`).

use serde_json::{json, Value};
use volformats::omezarr::LevelInfo;

/// The levels of the input (none: a format without levels) and the one
/// described.
pub struct Levels {
    /// Every level, full resolution first.
    pub all: Vec<LevelInfo>,
    /// The level described.
    pub level: u32,
    /// Whether `--level` picked it.
    pub given: bool,
}

impl Levels {
    /// The `levels` key (each level's `dims` and `spacing`, x, y, z) and
    /// the `level` key (the one described): `null` and `null` for an
    /// input without levels.
    pub fn json(levels: Option<&Levels>) -> Value {
        match levels {
            None => json!({ "levels": null, "level": null }),
            Some(l) => json!({
                "levels": l.all.iter().map(|v| json!({
                    "dims": v.dims.as_array(),
                    "spacing": v.spacing,
                })).collect::<Vec<_>>(),
                "level": l.level,
            }),
        }
    }

    /// The text lines (without indent): the count and which level is
    /// described, then one line per level.
    pub fn lines(&self) -> Vec<String> {
        let pick = if self.given {
            String::new()
        } else {
            "; pick another with --level N".to_string()
        };
        let mut out = vec![format!(
            "pyramid levels: {} (described: level {}{pick})",
            self.all.len(),
            self.level
        )];
        for (i, l) in self.all.iter().enumerate() {
            let s = l.spacing;
            out.push(format!(
                "  level {i}: {}x{}x{}, spacing {},{},{}",
                l.dims.x, l.dims.y, l.dims.z, s[0], s[1], s[2]
            ));
        }
        out
    }
}
