//! DICOM folders as they really are (issue 53 §3): files that cannot join
//! a volume series (a secondary capture without ImagePositionPatient,
//! truncated, multi-frame, colour, compressed past what volkit decodes,
//! without SeriesInstanceUID, no DICOM at all) are skipped and listed with
//! their reasons, and the series that reads converts as from a clean
//! folder. The files are written here, byte by byte (explicit VR little
//! endian), so each test says exactly what a file lacks.

use crate::common::{fails, json, ok, python_json, run, tool};
use std::path::{Path, PathBuf};
use volkit_fuzz::dicom_element as element;

pub(crate) const EXPLICIT_LE: &str = "1.2.840.10008.1.2.1";
/// A transfer syntax volkit does not decode (dicom-rs knows its name).
const JPEG_XL: &str = "1.2.840.10008.1.2.4.110";
const CT_CLASS: &str = "1.2.840.10008.5.1.4.1.1.2";
const SC_CLASS: &str = "1.2.840.10008.5.1.4.1.1.7";
const CT_SERIES: &str = "1.2.826.0.1.3680043.8.498.53.1";
const SC_SERIES: &str = "1.2.826.0.1.3680043.8.498.53.2";
pub(crate) const COLS: u16 = 4;
pub(crate) const ROWS: u16 = 3;

/// A data set: (tag, VR, value) in any order; written sorted.
pub(crate) struct DataSet(Vec<(u32, [u8; 2], Vec<u8>)>);

impl DataSet {
    pub(crate) fn set(mut self, tag: u32, vr: &[u8; 2], value: impl AsRef<[u8]>) -> DataSet {
        self.0.retain(|e| e.0 != tag);
        self.0.push((tag, *vr, value.as_ref().to_vec()));
        self
    }

    pub(crate) fn without(mut self, tag: u32) -> DataSet {
        self.0.retain(|e| e.0 != tag);
        self
    }

    /// The Part 10 file, in transfer syntax `ts`: explicit VR little
    /// endian data set; pixel data encapsulated (one fragment) for any
    /// syntax but explicit VR little endian.
    pub(crate) fn file(mut self, ts: &str) -> Vec<u8> {
        let class = self.get(0x0008_0016);
        let instance = self.get(0x0008_0018);
        let mut meta = Vec::new();
        element(&mut meta, 0x0002_0001, b"OB", &[0, 1]);
        element(&mut meta, 0x0002_0002, b"UI", &class);
        element(&mut meta, 0x0002_0003, b"UI", &instance);
        element(&mut meta, 0x0002_0010, b"UI", ts.as_bytes());
        element(
            &mut meta,
            0x0002_0012,
            b"UI",
            b"1.2.826.0.1.3680043.8.498.1",
        );
        let mut out = vec![0u8; 128];
        out.extend_from_slice(b"DICM");
        element(
            &mut out,
            0x0002_0000,
            b"UL",
            &(meta.len() as u32).to_le_bytes(),
        );
        out.extend_from_slice(&meta);
        self.0.sort_by_key(|e| e.0);
        for (tag, vr, value) in &self.0 {
            if *tag == 0x7fe0_0010 && ts != EXPLICIT_LE {
                // Encapsulated: an empty offset table, one fragment.
                out.extend_from_slice(&[0xe0, 0x7f, 0x10, 0x00, b'O', b'B', 0, 0]);
                out.extend_from_slice(&u32::MAX.to_le_bytes());
                for (len, bytes) in [(0u32, &[][..]), (value.len() as u32, &value[..])] {
                    out.extend_from_slice(&[0xfe, 0xff, 0x00, 0xe0]);
                    out.extend_from_slice(&len.to_le_bytes());
                    out.extend_from_slice(bytes);
                }
                out.extend_from_slice(&[0xfe, 0xff, 0xdd, 0xe0, 0, 0, 0, 0]);
            } else {
                element(&mut out, *tag, vr, value);
            }
        }
        out
    }

    pub(crate) fn get(&self, tag: u32) -> Vec<u8> {
        self.0
            .iter()
            .find(|e| e.0 == tag)
            .map(|e| e.2.clone())
            .unwrap_or_default()
    }
}

pub(crate) fn us(v: u16) -> [u8; 2] {
    v.to_le_bytes()
}

/// Slice `z` of the CT series (SeriesNumber 3): 4x3 u16 pixels, 2.5 mm
/// apart, HU rescale.
pub(crate) fn ct_slice(z: u32) -> DataSet {
    let pixels: Vec<u8> = (0..COLS as u32 * ROWS as u32)
        .flat_map(|i| ((i * 7 + z * 100) as u16).to_le_bytes())
        .collect();
    DataSet(Vec::new())
        .set(0x0008_0016, b"UI", CT_CLASS)
        .set(0x0008_0018, b"UI", format!("{CT_SERIES}.{}", z + 1))
        .set(0x0008_0060, b"CS", "CT")
        .set(0x0020_000e, b"UI", CT_SERIES)
        .set(0x0020_0011, b"IS", "3")
        .set(0x0020_0013, b"IS", (z + 1).to_string())
        .set(0x0020_0032, b"DS", format!("-10\\-20\\{}", z as f64 * 2.5))
        .set(0x0020_0037, b"DS", "1\\0\\0\\0\\1\\0")
        .set(0x0028_0002, b"US", us(1))
        .set(0x0028_0004, b"CS", "MONOCHROME2")
        .set(0x0028_0010, b"US", us(ROWS))
        .set(0x0028_0011, b"US", us(COLS))
        .set(0x0028_0030, b"DS", "0.5\\0.5")
        .set(0x0028_0100, b"US", us(16))
        .set(0x0028_0101, b"US", us(12))
        .set(0x0028_0102, b"US", us(11))
        .set(0x0028_0103, b"US", us(0))
        .set(0x0028_1052, b"DS", "-1024")
        .set(0x0028_1053, b"DS", "1")
        .set(0x7fe0_0010, b"OW", pixels)
}

/// A secondary capture (a dose report's screenshot): an image of its own
/// series without ImagePositionPatient or ImageOrientationPatient.
pub(crate) fn secondary_capture() -> DataSet {
    ct_slice(0)
        .set(0x0008_0016, b"UI", SC_CLASS)
        .set(0x0008_0018, b"UI", format!("{SC_SERIES}.1"))
        .set(0x0008_0060, b"CS", "OT")
        .set(0x0020_000e, b"UI", SC_SERIES)
        .set(0x0020_0011, b"IS", "99")
        .without(0x0020_0032)
        .without(0x0020_0037)
}

/// A folder of the CT series' `n` slices (shuffled names).
pub(crate) fn ct_folder(dir: &Path, n: u32) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    for z in 0..n {
        let name = format!("IM{:04}.dcm", (z * 7) % n);
        std::fs::write(dir.join(name), ct_slice(z).file(EXPLICIT_LE)).unwrap();
    }
    dir.to_path_buf()
}

/// The bytes vol-convert writes for `input` as raw (with `extra` flags),
/// and its stderr.
pub(crate) fn convert(input: &Path, extra: &[&str]) -> (Vec<u8>, String) {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o.raw");
    let o = run(tool("vol-convert")
        .arg(input)
        .args(extra)
        .arg("-o")
        .arg(&out));
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    (std::fs::read(&out).unwrap(), err)
}

pub(crate) fn info_json(input: &Path, extra: &[&str]) -> serde_json::Value {
    json(&ok(tool("vol-info").arg(input).args(extra).arg("--json")))
}

/// `(file, kind)` of every skipped file vol-info --json lists.
pub(crate) fn skipped(j: &serde_json::Value) -> Vec<(String, String)> {
    j["skipped"]
        .as_array()
        .unwrap_or_else(|| panic!("no skipped list: {j}"))
        .iter()
        .map(|s| {
            (
                s["file"].as_str().unwrap().to_string(),
                s["kind"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

#[test]
fn ct_with_a_secondary_capture_reads_the_ct_and_lists_the_capture() {
    let d = tempfile::tempdir().unwrap();
    let clean = ct_folder(&d.path().join("clean"), 20);
    let mixed = ct_folder(&d.path().join("mixed"), 20);
    std::fs::write(
        mixed.join("dose-report.dcm"),
        secondary_capture().file(EXPLICIT_LE),
    )
    .unwrap();
    // Described, with the capture in the skipped table; exit 0.
    let text = ok(tool("vol-info").arg(&mixed));
    assert!(text.contains("dicom series (CT, 20 images)"), "{text}");
    // One slice is one image (issue 53 §6).
    let one = ct_folder(&d.path().join("one"), 1);
    let single = ok(tool("vol-info").arg(&one));
    assert!(single.contains("dicom series (CT, 1 image)"), "{single}");
    let row = text
        .lines()
        .find(|l| l.contains("dose-report.dcm"))
        .unwrap_or_else(|| panic!("capture not listed: {text}"));
    assert!(row.contains("image without ImagePositionPatient"), "{row}");
    assert!(text.contains("1 file skipped:"), "{text}");
    for extra in [&[][..], &["--series", "3"][..]] {
        let j = info_json(&mixed, extra);
        assert_eq!(j["dims"], serde_json::json!([4, 3, 20]), "{j}");
        assert_eq!(
            skipped(&j),
            vec![("dose-report.dcm".to_string(), "missing".to_string())]
        );
        // Converted as the clean folder is, bit for bit; one note.
        let (want, _) = convert(&clean, extra);
        let (got, err) = convert(&mixed, extra);
        assert!(got == want, "the skipped capture changed the volume");
        let notes: Vec<&str> = err.lines().filter(|l| l.contains("skipped")).collect();
        assert_eq!(notes.len(), 1, "{err}");
        assert!(
            notes[0].contains("1 file (1 no ImagePositionPatient)"),
            "{err}"
        );
    }
    // The clean folder lists no skipped file.
    assert_eq!(info_json(&clean, &[])["skipped"], serde_json::json!([]));
    // The capture's own series cannot be picked: its file was skipped.
    fails(
        tool("vol-info").arg(&mixed).args(["--series", "99"]),
        "no series 99",
    );
}

/// The implicit-VR file the fuzzer found: an element dicom-rs read with
/// the dictionary's VR claims 1 GiB (dicom-rs reserved it before the
/// guard read the file as dicom-rs does).
fn hostile_implicit_vr() -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions/dicom/f43f9f4edf6e29e6");
    std::fs::read(p).unwrap()
}

#[test]
fn files_that_cannot_join_a_series_are_skipped_with_their_reasons() {
    let d = tempfile::tempdir().unwrap();
    let clean = ct_folder(&d.path().join("clean"), 6);
    let junk = ct_folder(&d.path().join("junk"), 6);
    let mut truncated = ct_slice(9)
        .set(0x0020_000e, b"UI", SC_SERIES)
        .file(EXPLICIT_LE);
    truncated.truncate(truncated.len() - 5);
    // Each in the CT's own series, at a position of its own: only the
    // reason keeps it out.
    let frames: Vec<u8> = (0..2 * COLS as u32 * ROWS as u32)
        .flat_map(|i| (i as u16).to_le_bytes())
        .collect();
    let files: Vec<(&str, Vec<u8>, &str, &str)> = vec![
        ("a-truncated.dcm", truncated, "damaged", "truncated"),
        (
            "b-multiframe.dcm",
            ct_slice(20)
                .set(0x0028_0008, b"IS", "2")
                .set(0x7fe0_0010, b"OW", &frames)
                .file(EXPLICIT_LE),
            "multi-frame",
            "multi-frame image (2 frames)",
        ),
        (
            "c-colour.dcm",
            ct_slice(21)
                .set(0x0028_0002, b"US", us(3))
                .set(0x0028_0004, b"CS", "RGB")
                .file(EXPLICIT_LE),
            "colour",
            "3 samples per pixel",
        ),
        (
            "d-jxl.dcm",
            ct_slice(22).file(JPEG_XL),
            "transfer-syntax",
            "JPEG XL Lossless (1.2.840.10008.1.2.4.110)",
        ),
        (
            "e-no-series.dcm",
            ct_slice(23).without(0x0020_000e).file(EXPLICIT_LE),
            "missing",
            "image without SeriesInstanceUID",
        ),
        (
            "f-notes.txt",
            b"not DICOM at all\n".to_vec(),
            "not-dicom",
            "no DICM marker",
        ),
        (
            "g-hostile.dcm",
            hostile_implicit_vr(),
            "damaged",
            "claims 1073747968 bytes",
        ),
        (
            "h-palette.dcm",
            ct_slice(24)
                .set(0x0028_0004, b"CS", "PALETTE COLOR")
                .file(EXPLICIT_LE),
            "colour",
            "PhotometricInterpretation PALETTE COLOR",
        ),
    ];
    for (name, bytes, _, _) in &files {
        std::fs::write(junk.join(name), bytes).unwrap();
    }
    let start = std::time::Instant::now();
    let j = info_json(&junk, &[]);
    assert!(
        start.elapsed().as_secs_f64() < 5.0,
        "the scan took {:?}",
        start.elapsed()
    );
    assert_eq!(j["dims"], serde_json::json!([4, 3, 6]), "{j}");
    let want: Vec<(String, String)> = files
        .iter()
        .map(|(n, _, k, _)| (n.to_string(), k.to_string()))
        .collect();
    assert_eq!(skipped(&j), want, "{j}");
    for (s, (name, _, _, why)) in j["skipped"].as_array().unwrap().iter().zip(&files) {
        let reason = s["reason"].as_str().unwrap();
        assert!(reason.contains(why), "{name}: {reason}");
    }
    // The text table: one row a file, with its reason.
    let text = ok(tool("vol-info").arg(&junk));
    assert!(text.contains("8 files skipped:"), "{text}");
    for (name, _, _, why) in &files {
        let row = text.lines().find(|l| l.contains(name)).unwrap_or_default();
        assert!(row.contains(why), "{name} in: {text}");
    }
    // The series converts as the clean folder does.
    let (want, _) = convert(&clean, &[]);
    let (got, err) = convert(&junk, &[]);
    assert!(got == want, "skipped files changed the volume");
    assert_eq!(
        err.lines().filter(|l| l.contains("skipped")).count(),
        1,
        "{err}"
    );
    assert!(err.contains("skipped 8 files"), "{err}");
}

#[test]
fn without_a_readable_series_the_error_says_why_in_one_line() {
    let d = tempfile::tempdir().unwrap();
    // Nothing but a capture and a colour image.
    let none = d.path().join("none");
    std::fs::create_dir(&none).unwrap();
    std::fs::write(none.join("sc.dcm"), secondary_capture().file(EXPLICIT_LE)).unwrap();
    std::fs::write(
        none.join("rgb.dcm"),
        ct_slice(0).set(0x0028_0002, b"US", us(3)).file(EXPLICIT_LE),
    )
    .unwrap();
    for t in ["vol-info", "vol-convert"] {
        let mut cmd = tool(t);
        cmd.arg(&none);
        if t == "vol-convert" {
            cmd.arg("-o").arg(d.path().join("o.raw"));
        }
        let e = fails(&mut cmd, "no readable DICOM series");
        assert!(
            e.contains(
                "2 files (1 colour, 1 no ImagePositionPatient; first: rgb.dcm: colour image"
            ),
            "{e}"
        );
    }
    // Two series, neither a volume (a missing slice, two slices at one
    // position): vol-info names the first one's problem, exit 1.
    let two = ct_folder(&d.path().join("two"), 6);
    std::fs::remove_file(two.join("IM0002.dcm")).unwrap();
    for z in 0..2 {
        let f = secondary_capture()
            .set(0x0008_0018, b"UI", format!("{SC_SERIES}.{z}"))
            .set(0x0020_0032, b"DS", "0\\0\\0")
            .set(0x0020_0037, b"DS", "1\\0\\0\\0\\1\\0");
        std::fs::write(two.join(format!("sc{z}.dcm")), f.file(EXPLICIT_LE)).unwrap();
    }
    let e = fails(tool("vol-info").arg(&two), "no readable DICOM series");
    assert!(
        e.contains("2 series cannot be read (first: #3") && e.contains("missing"),
        "{e}"
    );
    // A series picked by --series: only its own problem is the error, and
    // the skipped files are named after it.
    std::fs::write(two.join("sc.txt"), b"x").unwrap();
    let e = fails(
        tool("vol-info").arg(&two).args(["--series", "3"]),
        "1 slice is missing",
    );
    assert!(e.contains("1 file (1 not DICOM; first: sc.txt"), "{e}");
}

/// The folder of pydicom's bundled test files (78 files: CT, MR, RT dose,
/// colour, JPEG 2000 and JPEG-LS, multi-frame, truncated, no meta group,
/// reports), copied into one folder; `None` without pydicom outside CI.
fn pydicom_folder(dir: &Path) -> Option<usize> {
    let script = format!(
        r#"
import json, os, shutil, sys
try:
    import pydicom.data
except ImportError as e:
    print("SKIP", e); sys.exit(0)
src = os.path.join(os.path.dirname(pydicom.data.__file__), "test_files")
n = 0
for f in sorted(os.listdir(src)):
    if f.endswith(".dcm"):
        shutil.copy(os.path.join(src, f), {dir:?}); n += 1
print(json.dumps({{"files": n}}))
"#,
        dir = dir.to_string_lossy()
    );
    let j = python_json(&script, "pip install pydicom")?;
    j["files"].as_u64().map(|n| n as usize)
}

#[test]
fn pydicoms_test_files_in_one_folder_are_listed_not_refused() {
    let d = tempfile::tempdir().unwrap();
    let Some(n) = pydicom_folder(d.path()) else {
        return;
    };
    assert!(n > 50, "only {n} pydicom test files");
    let j = info_json(d.path(), &[]);
    let series = j["series"].as_array().unwrap_or_else(|| panic!("{j}"));
    let skipped = skipped(&j);
    let readable = series.iter().filter(|s| s["problem"].is_null()).count();
    assert!(readable >= 1, "{j}");
    // Every file is either in a series or skipped, once.
    let images: u64 = series.iter().map(|s| s["images"].as_u64().unwrap()).sum();
    assert_eq!(images as usize + skipped.len(), n, "{j}");
    // The bad files pydicom ships are each skipped for their reason.
    for (file, kind) in [
        ("MR_truncated.dcm", "damaged"),
        ("rtplan_truncated.dcm", "damaged"),
        ("no_meta.dcm", "not-dicom"),
        // JPEG 2000 decodes now; this one has no position.
        ("JPEG2000.dcm", "missing"),
        ("SC_rgb.dcm", "colour"),
        ("examples_palette.dcm", "colour"),
        ("rtdose.dcm", "multi-frame"),
        ("test-SR.dcm", "no-image"),
    ] {
        if !d.path().join(file).exists() {
            continue;
        }
        assert!(
            skipped.contains(&(file.to_string(), kind.to_string())),
            "{file} not skipped as {kind}: {j}"
        );
    }
    // The text listing exits 0 too, and picks a readable series.
    let text = ok(tool("vol-info").arg(d.path()));
    assert!(text.contains("files skipped:"), "{text}");
    let pick = series.iter().find(|s| s["problem"].is_null()).unwrap();
    let uid = pick["uid"].as_str().unwrap();
    ok(tool("vol-info").arg(d.path()).args(["--series", uid]));
}

/// A signed CT series (i16 samples, rescaled to i32 values by its slope
/// and intercept) that does not fit u8: the message names the type the
/// files store, not the i32 the rescale widened it to (issue 53 §2).
#[test]
fn a_rescaled_series_that_does_not_fit_names_the_stored_type() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("ct");
    std::fs::create_dir_all(&dir).unwrap();
    for z in 0..3 {
        let slice = ct_slice(z).set(0x0028_0103, b"US", us(1));
        std::fs::write(dir.join(format!("IM{z}.dcm")), slice.file(EXPLICIT_LE)).unwrap();
    }
    let err = fails(
        tool("vol-convert")
            .arg(&dir)
            .args(["--type", "u8", "-o"])
            .arg(d.path().join("o.raw")),
        "i16 values rescaled to -1024..",
    );
    assert!(
        err.contains("do not fit u8") && !err.contains("i32"),
        "{err}"
    );
}

/// Slice `z` of time point `t` and echo `e` (from 1) of an MR run
/// (SeriesNumber 5): 4x3 u16 pixels that say `z`, `t` and `e`; each slice
/// acquired at its own second, AcquisitionNumber per time point, TR 2 s.
fn mr_slice(z: u32, t: u32, e: u32) -> DataSet {
    let pixels: Vec<u8> = (0..COLS as u32 * ROWS as u32)
        .flat_map(|i| ((i + z * 16 + t * 256 + e * 4096) as u16).to_le_bytes())
        .collect();
    let seconds = 36000 + t * 20 + z;
    ct_slice(z)
        .set(0x0008_0016, b"UI", "1.2.840.10008.5.1.4.1.1.4")
        .set(0x0008_0018, b"UI", format!("{MR_SERIES}.{z}.{t}.{e}"))
        .set(0x0008_0032, b"TM", tm(seconds))
        .set(0x0008_0060, b"CS", "MR")
        .set(0x0018_0080, b"DS", "2000")
        .set(0x0028_0101, b"US", us(16))
        .set(0x0028_0102, b"US", us(15))
        .set(0x0018_0086, b"IS", e.to_string())
        .set(0x0020_000e, b"UI", MR_SERIES)
        .set(0x0020_0011, b"IS", "5")
        .set(0x0020_0012, b"IS", (t + 1).to_string())
        .without(0x0028_1052)
        .without(0x0028_1053)
        .set(0x7fe0_0010, b"OW", pixels)
}

const MR_SERIES: &str = "1.2.826.0.1.3680043.8.498.64.5";

/// Seconds since midnight as a DICOM TM (`HHMMSS`).
fn tm(s: u32) -> String {
    format!("{:02}{:02}{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// A folder of an MR run: every slice of `times` time points and
/// `echoes` echoes, in shuffled file order.
pub(crate) fn mr_folder(dir: &Path, slices: u32, times: u32, echoes: u32) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut k = 0u32;
    for t in 0..times {
        for e in 1..=echoes {
            for z in 0..slices {
                let name = format!("MR{:05}.dcm", (k * 7919) % 100_000);
                std::fs::write(dir.join(name), mr_slice(z, t, e).file(EXPLICIT_LE)).unwrap();
                k += 1;
            }
        }
    }
    dir.to_path_buf()
}

#[test]
fn a_time_series_is_volumes_picked_with_time_point() {
    let d = tempfile::tempdir().unwrap();
    let run = mr_folder(&d.path().join("run"), 4, 3, 1);
    // Before issue 64: "A and B lie at the same position".
    let j = info_json(&run, &[]);
    assert_eq!(j["time_points"], 3, "{j}");
    assert_eq!(j["time_step"], 2.0, "{j}");
    assert_eq!(j["time_unit"], "second", "{j}");
    assert_eq!(j["dims"], serde_json::json!([4, 3, 4]), "{j}");
    let text = ok(tool("vol-info").arg(&run));
    assert!(text.contains("time points: 3 (step 2 s)"), "{text}");
    assert!(text.contains("--time-point T"), "{text}");
    // Each time point equals the same slices written as a folder alone.
    for t in 0..3u32 {
        let alone = d.path().join(format!("alone{t}"));
        std::fs::create_dir_all(&alone).unwrap();
        for z in 0..4 {
            let f = mr_slice(z, t, 1).set(0x0020_0012, b"IS", "1");
            std::fs::write(alone.join(format!("{z}.dcm")), f.file(EXPLICIT_LE)).unwrap();
        }
        let (want, _) = convert(&alone, &[]);
        let (got, _) = convert(&run, &["--time-point", &t.to_string()]);
        assert_eq!(got, want, "time point {t}");
        assert_eq!(got.len(), 4 * 3 * 4 * 2);
        // The pixels say which time point they are.
        assert_eq!(
            u16::from_le_bytes([got[0], got[1]]),
            (t * 256 + 4096) as u16
        );
    }
    let mut cmd = tool("vol-convert");
    cmd.arg(&run).arg("-o").arg(d.path().join("x.raw"));
    let e = fails(&mut cmd, "pick one with --time-point T (0..2)");
    assert!(
        e.contains("3 time points (by AcquisitionNumber), TR 2 s"),
        "{e}"
    );
    assert!(!d.path().join("x.raw").exists());
    let mut cmd = tool("vol-convert");
    cmd.arg(&run)
        .args(["--time-point", "3", "-o"])
        .arg(d.path().join("x.raw"));
    fails(&mut cmd, "--time-point 3 asked for");
    // No echo axis here.
    let mut cmd = tool("vol-info");
    cmd.arg(&run).args(["--echo", "1", "--time-point", "0"]);
    fails(&mut cmd, "no echoes of its own");
}

#[test]
fn echoes_are_an_axis_of_their_own() {
    let d = tempfile::tempdir().unwrap();
    let run = mr_folder(&d.path().join("me"), 3, 2, 2);
    let j = info_json(&run, &[]);
    assert_eq!(
        (j["echoes"].as_u64(), j["time_points"].as_u64()),
        (Some(2), Some(2)),
        "{j}"
    );
    let text = ok(tool("vol-info").arg(&run));
    assert!(
        text.contains("echoes: 2") && text.contains("--echo E"),
        "{text}"
    );
    for (e, t) in [(0u32, 1u32), (1, 0), (1, 1)] {
        let (got, _) = convert(
            &run,
            &["--echo", &e.to_string(), "--time-point", &t.to_string()],
        );
        assert_eq!(
            u16::from_le_bytes([got[0], got[1]]),
            (t * 256 + (e + 1) * 4096) as u16,
            "echo {e} time point {t}"
        );
    }
    let mut cmd = tool("vol-convert");
    cmd.arg(&run)
        .args(["--time-point", "0", "-o"])
        .arg(d.path().join("x.raw"));
    fails(&mut cmd, "pick one with --echo E (0..1)");
    // --echo means a DICOM echo: other inputs refuse it as a usage error.
    let nii = d.path().join("a.nii");
    ok(tool("vol-convert")
        .arg(&run)
        .args(["--echo", "0", "--time-point", "0", "-o"])
        .arg(&nii));
    let o = run_cmd(tool("vol-info").arg(&nii).args(["--echo", "0"]));
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("has no echo axis") && err.lines().count() == 1,
        "{err}"
    );
}

fn run_cmd(cmd: &mut std::process::Command) -> std::process::Output {
    run(cmd)
}

#[test]
fn a_series_is_its_uid_with_its_number_and_splits_into_sub_series() {
    let d = tempfile::tempdir().unwrap();
    let clean = ct_folder(&d.path().join("clean"), 5);
    // A localizer in the CT's series: another orientation.
    let mixed = ct_folder(&d.path().join("mixed"), 5);
    for k in 0..2u32 {
        let f = ct_slice(k)
            .set(0x0008_0018, b"UI", format!("{CT_SERIES}.90{k}"))
            .set(0x0020_0032, b"DS", format!("{}\\-20\\0", k as f64 * 5.0))
            .set(0x0020_0037, b"DS", "0\\1\\0\\0\\0\\-1");
        std::fs::write(mixed.join(format!("loc{k}.dcm")), f.file(EXPLICIT_LE)).unwrap();
    }
    let j = json(&ok(tool("vol-info").arg(&mixed).arg("--json")));
    let ids: Vec<&str> = j["series"]
        .as_array()
        .unwrap_or_else(|| panic!("no series list: {j}"))
        .iter()
        .map(|s| s["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["3-1", "3-2"], "{j}");
    assert_eq!(j["series"][0]["images"], 5);
    assert_eq!(j["series"][1]["images"], 2);
    assert!(j["series"][1]["problem"].is_null(), "{j}");
    let (want, _) = convert(&clean, &[]);
    for sel in ["3-1".to_string(), format!("{CT_SERIES}-1")] {
        let (got, _) = convert(&mixed, &["--series", &sel]);
        assert_eq!(got, want, "--series {sel}");
    }
    let (loc, _) = convert(&mixed, &["--series", "3-2"]);
    assert_eq!(loc.len(), 4 * 3 * 2 * 2);
    let mut cmd = tool("vol-convert");
    cmd.arg(&mixed)
        .args(["--series", "3", "-o"])
        .arg(d.path().join("x.raw"));
    fails(&mut cmd, "is ambiguous");
    // Two SeriesNumbers under one UID are two series (before: one, and
    // --series 4 answered "no series 4").
    let two = ct_folder(&d.path().join("two"), 4);
    for z in 0..3u32 {
        let f = ct_slice(z)
            .set(0x0008_0018, b"UI", format!("{CT_SERIES}.4.{z}"))
            .set(0x0020_0011, b"IS", "4");
        std::fs::write(two.join(format!("n4-{z}.dcm")), f.file(EXPLICIT_LE)).unwrap();
    }
    let j = info_json(&two, &[]);
    assert_eq!(j["series"].as_array().map(Vec::len), Some(2), "{j}");
    let (four, _) = convert(&two, &["--series", "4"]);
    let (three, _) = convert(&two, &["--series", "3"]);
    assert_eq!((four.len(), three.len()), (4 * 3 * 3 * 2, 4 * 3 * 4 * 2));
}

#[test]
fn a_philips_private_scale_is_named_and_either_convention_offered() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("philips");
    std::fs::create_dir_all(&dir).unwrap();
    for z in 0..3 {
        let f = ct_slice(z)
            .set(0x2005_0010, b"LO", "Philips MR Imaging DD 001 ")
            .set(0x2005_100e, b"FL", 2.5f32.to_le_bytes());
        std::fs::write(dir.join(format!("{z}.dcm")), f.file(EXPLICIT_LE)).unwrap();
    }
    // Displayed values by default (stored - 1024), and the note says so.
    let j = info_json(&dir, &[]);
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(-1024.0), Some(-747.0)),
        "{j}"
    );
    let (_, err) = convert(&dir, &[]);
    assert!(
        err.contains("Philips private scale slope (2005,100E) present")
            && err.contains("--philips-scale precise"),
        "{err}"
    );
    // dcm2niix's precise values: displayed / (RescaleSlope x 2.5).
    // Stored as f32 samples, so compared within f32 rounding.
    let j = info_json(&dir, &["--philips-scale", "precise"]);
    let near = |key: &str, want: f64| j[key].as_f64().is_some_and(|v| (v - want).abs() < 1e-4);
    assert!(near("min", -409.6) && near("max", -298.8), "{j}");
    let (_, err) = convert(&dir, &["--philips-scale", "precise"]);
    assert!(err.contains("applied: wrote the precise values"), "{err}");
    // Without the private tag: no note.
    let plain = ct_folder(&d.path().join("plain"), 3);
    let (_, err) = convert(&plain, &[]);
    assert!(!err.contains("Philips"), "{err}");
}
