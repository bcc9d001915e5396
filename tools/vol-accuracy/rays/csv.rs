//! The ray-casting study's table: `accuracy.csv`, one row per setting.

use super::measure::Row;
use crate::files::write_via_temp;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// Write the CSV under a temporary name, then rename.
pub fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut s = String::from("scene,knob,value,median_s,min_s,max_s,samples,psnr_db,build_s\n");
    for r in rows {
        let p = r.psnr_db.map_or("inf".to_string(), |p| format!("{p:.3}"));
        let _ = writeln!(
            s,
            "{},{},{},{:.6},{:.6},{:.6},{},{},{:.6}",
            r.scene, r.knob, r.value, r.median_s, r.min_s, r.max_s, r.samples, p, r.build_s
        );
    }
    write_via_temp(path, "csv.partial", &s)
}
