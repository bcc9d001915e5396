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
}

impl Target {
    /// Every target, in the order the README lists them.
    pub const ALL: [Target; 13] = [
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
    let Ok(reader) = open_input(path, &ReadOptions::default()) else {
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
