//! Fuzz targets for every volkit reader: one function per target that
//! feeds one input through the same code the tools run on a file.
//!
//! Each function must return (never panic, abort or hang) whatever the
//! bytes: errors are the expected outcome for most inputs. Readers that
//! take a path get the bytes written to a file named like the format in a
//! scratch directory, so the real open path (length checks, memory maps,
//! format sniffing) is what runs. Where a reader would go on to decode
//! samples, the function reads them all when the volume is small (at most
//! [`MAX_SAMPLES`]), so decoders of corrupt data are exercised too.
//!
//! `src/main.rs` is the AFL++ driver (`scripts/fuzz.sh`); `tests/corpus.rs`
//! runs the saved corpora and the regression inputs through these functions
//! as a normal test.

use std::io::Cursor;
use std::path::{Path, PathBuf};
use volformats::open::{open_input, ReadOptions};

/// Samples a target decodes at most from one input: larger volumes are
/// opened and checked but their samples are not read (it would only make
/// the fuzzer slow).
pub const MAX_SAMPLES: u64 = 1 << 20;

/// A fuzz target: one reader of the project.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// Native `.vvol`: header, brick table, samples, trailer; by path and
    /// as a stream.
    Vvol,
    /// The thesis `.vol` format.
    Thesis,
    /// Headerless raw samples: the Open SciVis name, the length checks, the
    /// stream reader. Input: a file name line, then the samples.
    Raw,
    /// NRRD, attached (by path and on a stream) with raw or gzip data.
    Nrrd,
    /// MetaImage `.mha` (data after the header) and `.mhd` headers.
    Mhd,
    /// TIFF and BigTIFF, single and multipage.
    Tiff,
    /// The `.vidx` index sidecar.
    Vidx,
    /// Transfer-function text.
    Tf,
    /// PFM float images.
    Pfm,
    /// PNG images as vol-psnr loads them.
    Png,
    /// vol-render scene files (TOML): a scene that reads must print and
    /// read back the same.
    Scene,
    /// `.vpart` parts of a sharded conversion: opened and checked, and a
    /// part of a one-shard job merged.
    Vpart,
    /// `.vidxpart` parts of a sharded index build: read, and a part of a
    /// one-shard build merged.
    Vidxpart,
    /// NIfTI-1 and NIfTI-2: the input as `.nii`, and gzipped (or as it is,
    /// when it is gzip already) as `.nii.gz`.
    Nifti,
    /// A DICOM series: the input is the middle file of a three-slice
    /// series whose first and last slices the target makes
    /// ([`dicom_slice`]); the directory is opened as a series, and the
    /// input alone as one file.
    Dicom,
    /// OME-Zarr, NGFF 0.4 (Zarr v2) and 0.5 (Zarr v3). Input: the group
    /// metadata, a NUL byte, the array metadata, a NUL byte, the bytes of
    /// chunk 0 ([`split_zarr`]).
    Omezarr,
    /// OME-TIFF XML and ImageJ descriptions. Input: one byte of layout
    /// (pages, sample type), then the description text, which the target
    /// puts in a small valid TIFF ([`tiff_with_description`]).
    Ometiff,
    /// Environment maps as vol-render loads them (`--env-map`): PFM when
    /// the input starts with `P`, else OpenEXR; a map that loads is
    /// sampled.
    Envmap,
    /// The Siemens CSA header (0029,1010) that mosaics are unpacked by:
    /// parsed, and a header that parses is asked for the mosaic's tile
    /// count and slice normal.
    Csa,
}

impl Target {
    /// Every target, in the order the README lists them.
    pub const ALL: [Target; 19] = [
        Target::Vvol,
        Target::Thesis,
        Target::Raw,
        Target::Nrrd,
        Target::Mhd,
        Target::Tiff,
        Target::Vidx,
        Target::Tf,
        Target::Pfm,
        Target::Png,
        Target::Scene,
        Target::Vpart,
        Target::Vidxpart,
        Target::Nifti,
        Target::Dicom,
        Target::Omezarr,
        Target::Ometiff,
        Target::Envmap,
        Target::Csa,
    ];

    /// The target's name (its corpus directory, and the driver's argument).
    pub fn name(self) -> &'static str {
        match self {
            Target::Vvol => "vvol",
            Target::Thesis => "thesis",
            Target::Raw => "raw",
            Target::Nrrd => "nrrd",
            Target::Mhd => "mhd",
            Target::Tiff => "tiff",
            Target::Vidx => "vidx",
            Target::Tf => "tf",
            Target::Pfm => "pfm",
            Target::Png => "png",
            Target::Scene => "scene",
            Target::Vpart => "vpart",
            Target::Vidxpart => "vidxpart",
            Target::Nifti => "nifti",
            Target::Dicom => "dicom",
            Target::Omezarr => "omezarr",
            Target::Ometiff => "ometiff",
            Target::Envmap => "envmap",
            Target::Csa => "csa",
        }
    }

    /// The target called `name`.
    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }
}

/// Feed one input to `target`; `scratch` is a directory the function may
/// write its temporary files into.
pub fn run(target: Target, data: &[u8], scratch: &Path) {
    match target {
        Target::Vvol => vvol(data, scratch),
        Target::Thesis => thesis(data, scratch),
        Target::Raw => raw(data, scratch),
        Target::Nrrd => nrrd(data, scratch),
        Target::Mhd => mhd(data, scratch),
        Target::Tiff => tiff(data, scratch),
        Target::Vidx => vidx(data),
        Target::Tf => tf(data),
        Target::Pfm => pfm(data),
        Target::Png => png(data, scratch),
        Target::Scene => scene(data),
        Target::Vpart => vpart(data, scratch),
        Target::Vidxpart => vidxpart(data),
        Target::Nifti => nifti(data, scratch),
        Target::Dicom => dicom(data, scratch),
        Target::Omezarr => omezarr(data, scratch),
        Target::Ometiff => ometiff(data, scratch),
        Target::Envmap => envmap(data, scratch),
        Target::Csa => csa(data),
    }
}

/// Write `data` to `scratch/name` and return the path; `None` if the
/// scratch directory cannot be written (nothing to fuzz then).
fn file(scratch: &Path, name: &str, data: &[u8]) -> Option<PathBuf> {
    let p = scratch.join(name);
    std::fs::write(&p, data).ok().map(|()| p)
}

/// Read every sample of a small volume (decoding compressed bricks).
fn touch_volume(v: &volcore::Volume) {
    if v.dims().count() <= MAX_SAMPLES {
        let s = v.to_f32_vec();
        std::hint::black_box(s);
        let _ = v.error();
    }
}

/// Open `path` the way vol-convert does and read every slice of a small
/// input, then the end of the input (trailers, checksums).
fn convert_input(path: &Path) {
    convert_input_with(path, &ReadOptions::default());
}

/// [`convert_input`] with options (a channel and time point picked).
fn convert_input_with(path: &Path, opts: &ReadOptions) {
    let Ok(reader) = open_input(path, opts) else {
        return;
    };
    let info = reader.info().clone();
    if info.dims.count() > MAX_SAMPLES {
        return;
    }
    for z in 0..info.dims.z {
        if reader.read_slice(z).is_err() {
            return;
        }
    }
    let _ = reader.finish();
}

/// `data` with its `.vvol` header checksum made right, so that the fuzzer
/// reaches the checks behind it (a hostile file computes its CRC too).
fn with_header_crc(data: &[u8]) -> Option<Vec<u8>> {
    let n = volformats::vvol::HEADER_LEN as usize;
    if data.len() < n || data[..8] != volformats::vvol::MAGIC {
        return None;
    }
    let mut b = data.to_vec();
    let crc = crc32fast::hash(&b[..n - 4]);
    b[n - 4..n].copy_from_slice(&crc.to_le_bytes());
    (b != data).then_some(b)
}

fn vvol(data: &[u8], scratch: &Path) {
    vvol_one(data, scratch);
    if let Some(fixed) = with_header_crc(data) {
        vvol_one(&fixed, scratch);
    }
}

fn vvol_one(data: &[u8], scratch: &Path) {
    use volformats::vvol;
    if let Ok(v) = vvol::read_stream(&mut Cursor::new(data)) {
        touch_volume(&v);
    }
    let Some(p) = file(scratch, "fuzz.vvol", data) else {
        return;
    };
    for verify in [true, false] {
        let opts = vvol::OpenOptions {
            verify,
            cache_bytes: 1 << 20,
            in_memory: false,
        };
        if let Ok(v) = vvol::open(&p, opts) {
            touch_volume(&v);
        }
    }
    let _ = volformats::fingerprint(&p);
    convert_input(&p);
}

fn thesis(data: &[u8], scratch: &Path) {
    let Some(p) = file(scratch, "fuzz.vol", data) else {
        return;
    };
    if let Ok(f) = volformats::thesis::open(&p) {
        if f.header().dims.count() <= MAX_SAMPLES {
            if let Ok(v) = f.load() {
                touch_volume(&v);
            }
        }
    }
    convert_input(&p);
}

fn raw(data: &[u8], scratch: &Path) {
    use volformats::raw;
    let split = data.iter().position(|&b| b == b'\n').unwrap_or(data.len());
    let (name, samples) = (&data[..split], data.get(split + 1..).unwrap_or(&[]));
    let name = String::from_utf8_lossy(name);
    let Some((dims, _)) = raw::parse_name(Path::new(name.as_ref())) else {
        return;
    };
    // The file under a name of the same shape and type, so the real open
    // path reads dims and type from it.
    let stem = Path::new(name.as_ref())
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ty = stem.rsplit('_').next().unwrap_or("u8");
    let file_name = format!("fuzz_{}x{}x{}_{ty}.raw", dims.x, dims.y, dims.z);
    if let Some(p) = file(scratch, &file_name, samples) {
        convert_input(&p);
    }
}

fn nrrd(data: &[u8], scratch: &Path) {
    // As on standard input: the header, then the lines and bytes it skips.
    let mut r = Cursor::new(data);
    let _ = volformats::nrrd::read_stream_header(&mut r);
    if let Some(p) = file(scratch, "fuzz.nrrd", data) {
        convert_input(&p);
    }
}

fn mhd(data: &[u8], scratch: &Path) {
    if let Some(p) = file(scratch, "fuzz.mha", data) {
        convert_input(&p);
    }
}

fn tiff(data: &[u8], scratch: &Path) {
    if let Some(p) = file(scratch, "fuzz.tif", data) {
        convert_input(&p);
    }
}

fn vidx(data: &[u8]) {
    let _ = volindex::MinMaxIndex::read_from(&mut Cursor::new(data), None);
}

fn vpart(data: &[u8], scratch: &Path) {
    use volformats::vvol::part;
    let Some(p) = file(scratch, "fuzz.vpart", data) else {
        return;
    };
    let Ok(mut parts) = part::open_parts(&[p]) else {
        return;
    };
    if parts[0].header.data_len > MAX_SAMPLES * 4 {
        return;
    }
    let out = scratch.join("merged.vvol");
    if let Ok(mut f) = std::fs::File::create(&out) {
        let _ = part::merge(&mut parts, &mut f, &out, &|_| {});
    }
}

fn vidxpart(data: &[u8]) {
    use volindex::shard::{merge_parts, IndexPart};
    if let Ok(p) = IndexPart::read_from(&mut Cursor::new(data), data.len() as u64) {
        let _ = merge_parts(vec![p]);
    }
}

fn tf(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let _ = volrender::tf::parse::parse(&text);
}

fn csa(data: &[u8]) {
    use volformats::dicom::csa::CsaHeader;
    if let Ok(h) = CsaHeader::parse(data) {
        let _ = h.number("NumberOfImagesInMosaic");
        let _ = h.vector("SliceNormalVector");
    }
}

fn pfm(data: &[u8]) {
    let _ = volcompare::pfm::decode_pfm(data);
}

fn png(data: &[u8], scratch: &Path) {
    if let Some(p) = file(scratch, "fuzz.png", data) {
        let _ = volcompare::Image::load(&p);
    }
}

fn scene(data: &[u8]) {
    use volscene::file::{to_toml, Scene};
    let text = String::from_utf8_lossy(data);
    let Ok(s) = Scene::parse(&text) else {
        return;
    };
    // What --print-scene writes must read back as the same scene.
    let printed = match to_toml(&s) {
        Ok(t) => t,
        Err(e) => panic!("a scene that reads does not print: {e}"),
    };
    match Scene::parse(&printed) {
        Ok(back) => assert_eq!(back, s, "printed scene reads back different:\n{printed}"),
        Err(e) => panic!("printed scene does not read back: {e}\n{printed}"),
    }
}

fn nifti(data: &[u8], scratch: &Path) {
    use std::io::Write;
    if let Some(p) = file(scratch, "fuzz.nii", data) {
        convert_input(&p);
        // A 4D header asks for a time point: the spec of the second.
        let _ = volformats::nifti::open(&p, Some(1));
    }
    // The same header through gzip (or the input itself when it is gzip).
    let gz = if data.starts_with(&[0x1f, 0x8b]) {
        data.to_vec()
    } else {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        if e.write_all(data).is_err() {
            return;
        }
        match e.finish() {
            Ok(b) => b,
            Err(_) => return,
        }
    };
    if let Some(p) = file(scratch, "fuzz.nii.gz", &gz) {
        convert_input(&p);
    }
}

/// Series of the DICOM target's slices.
pub const DICOM_SERIES: &str = "1.2.826.0.1.3680043.10.1234.1";
/// Columns and rows of the DICOM target's slices.
pub const DICOM_SIZE: (u16, u16) = (4, 3);

/// One DICOM element, explicit VR little endian, its value padded to an
/// even length (with NUL for UIDs and binary values, else a space); the
/// DICOM folder tests write their files with it too.
pub fn dicom_element(out: &mut Vec<u8>, tag: u32, vr: &[u8; 2], value: &[u8]) {
    let mut v = value.to_vec();
    if v.len() % 2 == 1 {
        v.push(if matches!(vr, b"UI" | b"OB" | b"OW") {
            0
        } else {
            b' '
        });
    }
    out.extend_from_slice(&((tag >> 16) as u16).to_le_bytes());
    out.extend_from_slice(&(tag as u16).to_le_bytes());
    out.extend_from_slice(vr);
    if matches!(vr, b"OB" | b"OW" | b"OF" | b"SQ" | b"UT" | b"UN") {
        out.extend_from_slice(&[0, 0]);
        out.extend_from_slice(&(v.len() as u32).to_le_bytes());
    } else {
        out.extend_from_slice(&(v.len() as u16).to_le_bytes());
    }
    out.extend_from_slice(&v);
}

/// A valid single-frame DICOM file (explicit VR little endian, CT,
/// [`DICOM_SIZE`] 16-bit unsigned pixels, series [`DICOM_SERIES`]) at
/// `z` mm along the normal: the fixed first and last slices of the DICOM
/// target (z = 0 and 2), and the seed of its middle slice (z = 1).
pub fn dicom_slice(z: u32) -> Vec<u8> {
    const SOP_CLASS: &[u8] = b"1.2.840.10008.5.1.4.1.1.2";
    const EXPLICIT_LE: &[u8] = b"1.2.840.10008.1.2.1";
    let instance = format!("{DICOM_SERIES}.{}", z + 1);
    let (cols, rows) = DICOM_SIZE;
    let mut meta = Vec::new();
    dicom_element(&mut meta, 0x0002_0001, b"OB", &[0, 1]);
    dicom_element(&mut meta, 0x0002_0002, b"UI", SOP_CLASS);
    dicom_element(&mut meta, 0x0002_0003, b"UI", instance.as_bytes());
    dicom_element(&mut meta, 0x0002_0010, b"UI", EXPLICIT_LE);
    dicom_element(
        &mut meta,
        0x0002_0012,
        b"UI",
        b"1.2.826.0.1.3680043.10.1234",
    );
    let mut out = vec![0u8; 128];
    out.extend_from_slice(b"DICM");
    let meta_len = (meta.len() as u32).to_le_bytes();
    dicom_element(&mut out, 0x0002_0000, b"UL", &meta_len);
    out.extend_from_slice(&meta);
    let us = |v: u16| v.to_le_bytes();
    dicom_element(&mut out, 0x0008_0016, b"UI", SOP_CLASS);
    dicom_element(&mut out, 0x0008_0018, b"UI", instance.as_bytes());
    dicom_element(&mut out, 0x0008_0060, b"CS", b"CT");
    dicom_element(
        &mut out,
        0x0020_000d,
        b"UI",
        b"1.2.826.0.1.3680043.10.1234.2",
    );
    dicom_element(&mut out, 0x0020_000e, b"UI", DICOM_SERIES.as_bytes());
    dicom_element(&mut out, 0x0020_0013, b"IS", (z + 1).to_string().as_bytes());
    dicom_element(
        &mut out,
        0x0020_0032,
        b"DS",
        format!("0\\0\\{z}").as_bytes(),
    );
    dicom_element(&mut out, 0x0020_0037, b"DS", b"1\\0\\0\\0\\1\\0");
    dicom_element(&mut out, 0x0028_0002, b"US", &us(1));
    dicom_element(&mut out, 0x0028_0004, b"CS", b"MONOCHROME2");
    dicom_element(&mut out, 0x0028_0010, b"US", &us(rows));
    dicom_element(&mut out, 0x0028_0011, b"US", &us(cols));
    dicom_element(&mut out, 0x0028_0030, b"DS", b"0.5\\0.5");
    dicom_element(&mut out, 0x0028_0100, b"US", &us(16));
    dicom_element(&mut out, 0x0028_0101, b"US", &us(12));
    dicom_element(&mut out, 0x0028_0102, b"US", &us(11));
    dicom_element(&mut out, 0x0028_0103, b"US", &us(0));
    dicom_element(&mut out, 0x0028_1052, b"DS", b"-1024");
    dicom_element(&mut out, 0x0028_1053, b"DS", b"1");
    let pixels: Vec<u8> = (0..cols as u32 * rows as u32)
        .flat_map(|i| ((i * 300 + z * 1000) as u16).to_le_bytes())
        .collect();
    dicom_element(&mut out, 0x7fe0_0010, b"OW", &pixels);
    out
}

fn dicom(data: &[u8], scratch: &Path) {
    let dir = scratch.join("series");
    let _ = std::fs::remove_dir_all(&dir);
    if std::fs::create_dir(&dir).is_err() {
        return;
    }
    for (name, bytes) in [
        ("1.dcm", dicom_slice(0)),
        ("2.dcm", data.to_vec()),
        ("3.dcm", dicom_slice(2)),
    ] {
        if std::fs::write(dir.join(name), bytes).is_err() {
            return;
        }
    }
    convert_input(&dir);
    convert_input(&dir.join("2.dcm"));
}

/// The three parts of an `omezarr` input: group metadata, array metadata
/// and chunk 0, separated by the first two NUL bytes (JSON holds none);
/// missing parts are empty.
pub fn split_zarr(data: &[u8]) -> (&[u8], &[u8], &[u8]) {
    let mut parts = data.splitn(3, |&b| b == 0);
    let group = parts.next().unwrap_or(&[]);
    let array = parts.next().unwrap_or(&[]);
    let chunk = parts.next().unwrap_or(&[]);
    (group, array, chunk)
}

/// An `omezarr` input of the three parts (see [`split_zarr`]).
pub fn join_zarr(group: &[u8], array: &[u8], chunk: &[u8]) -> Vec<u8> {
    [group, &[0], array, &[0], chunk].concat()
}

fn omezarr(data: &[u8], scratch: &Path) {
    let (group, array, chunk) = split_zarr(data);
    let root = scratch.join("fuzz.zarr");
    let _ = std::fs::remove_dir_all(&root);
    let meta: Option<serde_json::Value> = serde_json::from_slice(array).ok();
    let v3 = meta
        .as_ref()
        .and_then(|m| m.get("zarr_format"))
        .and_then(|f| f.as_u64())
        == Some(3);
    // Chunk 0 under every key layout a store of its rank may use.
    let rank = meta
        .as_ref()
        .and_then(|m| m.get("shape"))
        .and_then(|s| s.as_array())
        .map_or(3, |s| s.len().clamp(1, 8));
    let zeros = |sep: &str| vec!["0"; rank].join(sep);
    let mut files: Vec<(String, &[u8])> = if v3 {
        vec![
            ("zarr.json".into(), group),
            ("0/zarr.json".into(), array),
            (format!("0/c/{}", zeros("/")), chunk),
            (format!("0/c.{}", zeros(".")), chunk),
        ]
    } else {
        vec![
            (".zgroup".into(), br#"{"zarr_format":2}"#),
            (".zattrs".into(), group),
            ("0/.zarray".into(), array),
        ]
    };
    files.push((format!("0/{}", zeros("/")), chunk));
    files.push((format!("0/{}", zeros(".")), chunk));
    for (name, bytes) in files {
        let p = root.join(name);
        if let Some(d) = p.parent() {
            if std::fs::create_dir_all(d).is_err() {
                return;
            }
        }
        if std::fs::write(&p, bytes).is_err() {
            return;
        }
    }
    // A channel and time point picked, so 5D images open too.
    let opts = ReadOptions {
        channel: volformats::tiff::ChannelSel::Channel(0),
        time: Some(0),
        ..ReadOptions::default()
    };
    convert_input_with(&root, &opts);
}

/// A small valid little-endian TIFF of `pages` pages of 3 × 2 samples
/// (type by `kind`: 0 u8, 1 u16, 2 f32, 3 i16), the first page carrying
/// `desc` as its ImageDescription; the `ometiff` target's file.
pub fn tiff_with_description(pages: u16, kind: u8, desc: &[u8]) -> Vec<u8> {
    let (w, h) = (3u32, 2u32);
    let (bits, format): (u16, u16) = match kind % 4 {
        0 => (8, 1),
        1 => (16, 1),
        2 => (32, 3),
        _ => (16, 2),
    };
    let page_bytes = w * h * bits as u32 / 8;
    let pages = pages.max(1) as u32;
    let mut desc = desc.to_vec();
    desc.push(0);
    // Layout: header, description, the pages' samples, then the IFDs.
    let mut out = Vec::new();
    out.extend_from_slice(b"II*\0");
    out.extend_from_slice(&0u32.to_le_bytes()); // the first IFD, set below
    let desc_at = out.len() as u32;
    out.extend_from_slice(&desc);
    if out.len() % 2 == 1 {
        out.push(0);
    }
    let data_at = out.len() as u32;
    for p in 0..pages {
        for i in 0..w * h {
            let v = p * 16 + i;
            match (bits, format) {
                (8, _) => out.push(v as u8),
                (16, _) => out.extend_from_slice(&(v as u16).to_le_bytes()),
                _ => out.extend_from_slice(&(v as f32).to_le_bytes()),
            }
        }
    }
    let first_ifd = out.len() as u32;
    out[4..8].copy_from_slice(&first_ifd.to_le_bytes());
    for p in 0..pages {
        // (tag, type, count, value): type 3 SHORT, 4 LONG, 2 ASCII.
        let mut entries: Vec<(u16, u16, u32, u32)> = vec![
            (256, 4, 1, w),
            (257, 4, 1, h),
            (258, 3, 1, bits as u32),
            (259, 3, 1, 1),
            (262, 3, 1, 1),
        ];
        if p == 0 {
            // Up to four bytes sit in the entry itself.
            let value = if desc.len() <= 4 {
                let mut b = [0u8; 4];
                b[..desc.len()].copy_from_slice(&desc);
                u32::from_le_bytes(b)
            } else {
                desc_at
            };
            entries.push((270, 2, desc.len() as u32, value));
        }
        entries.extend([
            (273, 4, 1, data_at + p * page_bytes),
            (277, 3, 1, 1),
            (278, 4, 1, h),
            (279, 4, 1, page_bytes),
            (339, 3, 1, format as u32),
        ]);
        let here = out.len() as u32;
        let next = if p + 1 < pages {
            here + 2 + 12 * entries.len() as u32 + 4
        } else {
            0
        };
        out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
        for (tag, ty, count, value) in entries {
            out.extend_from_slice(&tag.to_le_bytes());
            out.extend_from_slice(&ty.to_le_bytes());
            out.extend_from_slice(&count.to_le_bytes());
            if ty == 3 {
                out.extend_from_slice(&(value as u16).to_le_bytes());
                out.extend_from_slice(&[0, 0]);
            } else {
                out.extend_from_slice(&value.to_le_bytes());
            }
        }
        out.extend_from_slice(&next.to_le_bytes());
    }
    out
}

fn ometiff(data: &[u8], scratch: &Path) {
    let Some((&layout, desc)) = data.split_first() else {
        return;
    };
    let pages = 1 + (layout & 0x0f) as u16;
    let text = String::from_utf8_lossy(desc);
    if let Some(a) = volformats::tiff::axes::Axes::parse(&text) {
        let _ = a.pages(Some(0), Some(0), pages as usize);
    }
    let tif = tiff_with_description(pages, layout >> 4, desc);
    if let Some(p) = file(scratch, "fuzz.tif", &tif) {
        let opts = ReadOptions {
            channel: volformats::tiff::ChannelSel::Channel(0),
            time: Some(0),
            ..ReadOptions::default()
        };
        convert_input_with(&p, &opts);
        convert_input(&p);
    }
}

fn envmap(data: &[u8], scratch: &Path) {
    let name = if data.first() == Some(&b'P') {
        "fuzz.pfm"
    } else {
        "fuzz.exr"
    };
    let Some(p) = file(scratch, name, data) else {
        return;
    };
    let Ok(map) = volscene::path::load_env_map(&p) else {
        return;
    };
    // Draw a few directions, and look a few up.
    for i in 0..4 {
        for j in 0..4 {
            let (u, v) = (i as f32 / 3.0, j as f32 / 3.0);
            if let Some(s) = map.sample(u, v) {
                std::hint::black_box(map.radiance_pdf(s.dir));
            }
        }
    }
    std::hint::black_box(map.luminance_integral());
}
