//! The tables of a DICOM input's listing: the files its scan skipped
//! (file and reason, in text or JSON), and the column padding every
//! table of vol-info shares (series, skipped files, --labels).

use serde_json::json;
use std::path::Path;
use volformats::dicom::{shown, Skipped};

/// `rows` as lines, each column padded to its widest cell (in
/// characters), two spaces apart, trailing blanks trimmed.
pub fn columns<const N: usize>(rows: &[[String; N]]) -> Vec<String> {
    let widths: Vec<usize> = (0..N)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    rows.iter()
        .map(|r| {
            r.iter()
                .zip(&widths)
                .map(|(cell, w)| format!("{cell:<w$}"))
                .collect::<Vec<_>>()
                .join("  ")
                .trim_end()
                .to_string()
        })
        .collect()
}

/// The skipped files as text lines (without indent): `3 files skipped:`,
/// then a FILE / REASON table indented by two; nothing when none was.
/// File names are shown relative to the input and escaped, like the
/// reasons, so no control character reaches the terminal.
pub fn skipped_lines(input: &Path, skipped: &[Skipped]) -> Vec<String> {
    if skipped.is_empty() {
        return Vec::new();
    }
    let mut rows = vec![["FILE".to_string(), "REASON".to_string()]];
    rows.extend(skipped.iter().map(|s| {
        [
            volcore::text::escape(&shown(input, &s.path)),
            volcore::text::escape(&s.reason.to_string()),
        ]
    }));
    let n = skipped.len();
    let mut lines = vec![format!(
        "{n} file{} skipped:",
        if n == 1 { "" } else { "s" }
    )];
    lines.extend(columns(&rows).into_iter().map(|l| format!("  {l}")));
    lines
}

/// The skipped files for `--json`: one object each, `file` (as the
/// input names it), `kind` (see `SkipReason::key`) and `reason`.
pub fn skipped_json(input: &Path, skipped: &[Skipped]) -> serde_json::Value {
    skipped
        .iter()
        .map(|s| {
            json!({
                "file": shown(input, &s.path),
                "kind": s.reason.key(),
                "reason": s.reason.to_string(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use volformats::dicom::SkipReason;

    #[test]
    fn columns_pad_to_the_widest_cell() {
        let rows = [
            ["A".to_string(), "BB".to_string()],
            ["ccc".to_string(), "d".to_string()],
        ];
        assert_eq!(columns(&rows), ["A    BB", "ccc  d"]);
    }

    #[test]
    fn skipped_files_are_a_table_with_escaped_names() {
        let dir = Path::new("/in");
        let s = vec![
            Skipped {
                path: dir.join("dose.dcm"),
                reason: SkipReason::Missing("ImagePositionPatient"),
            },
            Skipped {
                path: dir.join("a\x1b[2Jb"),
                reason: SkipReason::NotDicom,
            },
        ];
        let lines = skipped_lines(dir, &s);
        assert_eq!(lines[0], "2 files skipped:");
        assert_eq!(lines[1], "  FILE       REASON");
        assert_eq!(lines[2], "  dose.dcm   image without ImagePositionPatient");
        assert!(lines[3].starts_with("  a\\x1b[2Jb  not a DICOM file"));
        assert!(skipped_lines(dir, &[]).is_empty());
        let j = skipped_json(dir, &s);
        assert_eq!(j[0]["file"], "dose.dcm");
        assert_eq!(j[0]["kind"], "missing");
        assert_eq!(j[1]["kind"], "not-dicom");
    }
}
