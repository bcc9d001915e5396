//! A 64-bit fingerprint of a volume file, for sidecar files (such as the
//! `.vidx` index) that must notice when their volume is replaced.
//!
//! What is hashed depends on what the format offers:
//!
//! - **`.vvol`**: the header (128 or 256 bytes) and the 32-byte trailer, as
//!   stored.
//!   The header fixes dimensions, type, spacing, layout and compression; the
//!   trailer holds the exact value range and a CRC-32 of the sample data
//!   (sliced) or of the brick table, whose entries carry each brick's CRC-32
//!   (bricked). Any change to a sample therefore changes the fingerprint
//!   (up to CRC-32 collisions), while only a few hundred bytes are read. A sliced,
//!   a bricked and a compressed copy of one volume have *different*
//!   fingerprints: a sidecar belongs to one file.
//! - **`.vol`** (thesis) and **`.raw`** carry no checksums. Their
//!   fingerprint hashes the header (the 26 bytes of a `.vol`; raw files have
//!   none), the file length, the modification time in nanoseconds and up to
//!   16 blocks of 4 KiB spread evenly over the file (all of it when smaller).
//!   This is **weaker**: an edit that keeps the length, lands between the
//!   sampled blocks and within the file system's timestamp granularity (a
//!   few milliseconds on Linux), or that restores the old modification time,
//!   goes unnoticed. In the other direction, copying the file without its
//!   timestamp (`cp` without `-p`) or `touch` makes a sidecar look stale,
//!   which costs a rebuild but never a wrong answer.
//!
//! The hash is FNV-1a (64-bit) followed by a bit mixer, written out here so
//! that fingerprints are the same on every run, build and platform (std's
//! hasher is randomly keyed). A tag for the kind of file is hashed first, so
//! files of different kinds never share a fingerprint by construction of
//! their inputs. It is not a cryptographic hash: it detects accidents, not
//! forgeries.

use crate::error::{truncated, Error, Result};
use crate::output_kind::FileKind;
use crate::{thesis, vvol};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::time::UNIX_EPOCH;

/// Size of the data blocks sampled from files without checksums.
const BLOCK: u64 = 4096;
/// Number of data blocks sampled from files without checksums.
const BLOCKS: u64 = 16;

/// FNV-1a, 64-bit, with a final mixing step.
struct Fnv64(u64);

impl Fnv64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    fn new(tag: &[u8]) -> Fnv64 {
        let mut h = Fnv64(Self::OFFSET);
        h.update(tag);
        h
    }

    fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(Self::PRIME);
        }
    }

    /// FNV-1a barely stirs the last bytes; a 64-bit finaliser (the one of
    /// SplitMix64) spreads every input bit over the whole result.
    fn finish(&self) -> u64 {
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// The fingerprint of the volume file at `path` (see the module docs for
/// what it covers). Fails if the file cannot be read, its kind is not known
/// from its extension, it is a stream (`-`), or its header or trailer is
/// damaged or disagrees with the file length.
pub fn fingerprint(path: &Path) -> Result<u64> {
    if path.as_os_str() == "-" {
        return Err(Error::invalid(
            "a stream has no fingerprint: write the volume to a file first",
        ));
    }
    match FileKind::of(path) {
        Some(FileKind::Vvol) => vvol_fingerprint(path),
        Some(FileKind::ThesisVol) => {
            // Validates the header against the file length.
            let header = thesis::open(path)?.header().encode();
            unchecked_fingerprint(path, b"volkit-fp1 vol", &header)
        }
        Some(FileKind::Raw) => unchecked_fingerprint(path, b"volkit-fp1 raw", &[]),
        None if path.is_dir() => dir_fingerprint(path),
        // Other formats (NRRD, MetaImage, NIfTI, TIFF, ...): the file as
        // for raw files (a detached data file is not covered).
        None => unchecked_fingerprint(path, b"volkit-fp1 file", &[]),
    }
}

/// Most directory entries a fingerprint walks.
const MAX_DIR_ENTRIES: usize = 1 << 20;

/// A directory (DICOM series, TIFF slices, OME-Zarr): the relative names,
/// lengths and modification times of every file below it, in name order.
fn dir_fingerprint(dir: &Path) -> Result<u64> {
    let mut entries = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d)? {
            let e = e?;
            if entries.len() + todo.len() >= MAX_DIR_ENTRIES {
                return Err(Error::invalid(format!(
                    "directory holds more than {MAX_DIR_ENTRIES} entries"
                )));
            }
            let m = e.metadata()?;
            if m.is_dir() {
                todo.push(e.path());
            } else {
                let nanos = match m.modified()?.duration_since(UNIX_EPOCH) {
                    Ok(t) => t.as_nanos() as i128,
                    Err(t) => -(t.duration().as_nanos() as i128),
                };
                let rel = e
                    .path()
                    .strip_prefix(dir)
                    .map(|p| p.to_path_buf())
                    .unwrap_or_default();
                entries.push((rel.to_string_lossy().into_owned(), m.len(), nanos));
            }
        }
    }
    entries.sort();
    let mut hash = Fnv64::new(b"volkit-fp1 dir");
    for (name, len, nanos) in &entries {
        hash.update(&(name.len() as u64).to_le_bytes());
        hash.update(name.as_bytes());
        hash.update(&len.to_le_bytes());
        hash.update(&nanos.to_le_bytes());
    }
    Ok(hash.finish())
}

/// Header plus trailer of a `.vvol` file, both validated.
fn vvol_fingerprint(path: &Path) -> Result<u64> {
    let mut f = File::open(path)?;
    let len = f.metadata()?.len();
    let h = vvol::read_header_from(&mut f)?;
    let mut header = vec![0u8; h.header_len as usize];
    f.seek(SeekFrom::Start(0))?;
    f.read_exact(&mut header).map_err(truncated("header"))?;
    let end = h.file_len().unwrap_or(u64::MAX);
    if end != len {
        return Err(Error::invalid(format!(
            "header describes {} ({end} bytes with header and trailer) but the file has {len} bytes",
            h.meta
        )));
    }
    let mut trailer = [0u8; vvol::TRAILER_LEN as usize];
    f.seek(SeekFrom::Start(len - vvol::TRAILER_LEN))?;
    f.read_exact(&mut trailer).map_err(truncated("trailer"))?;
    vvol::Trailer::decode(&trailer)?;
    let mut hash = Fnv64::new(b"volkit-fp1 vvol");
    hash.update(&header);
    hash.update(&trailer);
    Ok(hash.finish())
}

/// Tag, header, length, modification time and sampled blocks of a file
/// without checksums.
fn unchecked_fingerprint(path: &Path, tag: &[u8], header: &[u8]) -> Result<u64> {
    let mut f = File::open(path)?;
    let meta = f.metadata()?;
    let len = meta.len();
    let modified = meta.modified()?;
    // Signed nanoseconds from the epoch: also defined before 1970.
    let nanos: i128 = match modified.duration_since(UNIX_EPOCH) {
        Ok(d) => d.as_nanos() as i128,
        Err(e) => -(e.duration().as_nanos() as i128),
    };
    let mut hash = Fnv64::new(tag);
    hash.update(&(header.len() as u64).to_le_bytes());
    hash.update(header);
    hash.update(&len.to_le_bytes());
    hash.update(&nanos.to_le_bytes());
    let mut buf = vec![0u8; BLOCK as usize];
    for start in block_starts(len) {
        let n = BLOCK.min(len - start) as usize;
        f.seek(SeekFrom::Start(start))?;
        f.read_exact(&mut buf[..n])
            .map_err(truncated("sampled data"))?;
        hash.update(&buf[..n]);
    }
    Ok(hash.finish())
}

/// Offsets of the blocks sampled from a file of `len` bytes: every block
/// when the file holds at most [`BLOCKS`] of them, otherwise the first, the
/// last and evenly spaced ones between.
fn block_starts(len: u64) -> Vec<u64> {
    let count = len.div_ceil(BLOCK);
    if count <= BLOCKS {
        return (0..count).map(|i| i * BLOCK).collect();
    }
    let last = len - BLOCK;
    (0..BLOCKS)
        .map(|i| (u128::from(last) * u128::from(i) / u128::from(BLOCKS - 1)) as u64)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::Sink;
    use std::path::PathBuf;
    use volcore::scene::{SceneSource, ShapesScene};
    use volcore::{BrickGeometry, Compression, Dims, Layout, SampleType, ValueRange, VolumeMeta};

    fn no_progress(_: u64) {}

    fn scene(dims: Dims, seed: u64) -> ShapesScene {
        ShapesScene::new(dims, seed, 6, 8, 100.0)
    }

    /// A shapes volume as `.vvol` in the given layout and compression.
    fn vvol_file(dir: &Path, name: &str, seed: u64, layout: Layout, c: Compression) -> PathBuf {
        let dims = Dims::new(33, 20, 17).unwrap();
        let scene = scene(dims, seed);
        let meta = VolumeMeta {
            dims,
            spacing: [1.0; 3],
            sample_type: SampleType::U8,
            range: ValueRange::EMPTY,
            layout,
            compression: c,
            geometry: volcore::Geometry::IDENTITY,
            narrowed: None,
        };
        let p = dir.join(name);
        let mut f = File::create(&p).unwrap();
        vvol::write(
            &SceneSource::<u8>::new(&scene),
            meta,
            Sink::File(&mut f),
            &no_progress,
        )
        .unwrap();
        p
    }

    fn layouts() -> Vec<(Layout, Compression)> {
        let g = BrickGeometry::new(Dims::new(33, 20, 17).unwrap(), 8).unwrap();
        vec![
            (Layout::Sliced, Compression::None),
            (Layout::Bricked(g), Compression::None),
            (Layout::Bricked(g), Compression::Zstd(3)),
        ]
    }

    #[test]
    fn vvol_same_file_same_fingerprint_other_seed_different() {
        let dir = tempfile::tempdir().unwrap();
        let mut all = Vec::new();
        for (i, (l, c)) in layouts().into_iter().enumerate() {
            let a = vvol_file(dir.path(), &format!("a{i}.vvol"), 1, l, c);
            let b = vvol_file(dir.path(), &format!("b{i}.vvol"), 1, l, c);
            let other = vvol_file(dir.path(), &format!("c{i}.vvol"), 2, l, c);
            let fa = fingerprint(&a).unwrap();
            assert_eq!(fa, fingerprint(&a).unwrap(), "layout {i}: not repeatable");
            // Same contents in another file: same fingerprint (no time in it).
            assert_eq!(fa, fingerprint(&b).unwrap(), "layout {i}: copies differ");
            assert_ne!(fa, fingerprint(&other).unwrap(), "layout {i}: seeds agree");
            all.push(fa);
        }
        // Sliced, bricked and compressed copies are different files.
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), 3);
    }

    /// A truncated file, a damaged header and a damaged trailer are
    /// errors, not fingerprints.
    #[test]
    fn vvol_rejects_damaged_and_truncated_files() {
        let dir = tempfile::tempdir().unwrap();
        let (l, c) = layouts()[1];
        let p = vvol_file(dir.path(), "t.vvol", 1, l, c);
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 1]).unwrap();
        let e = fingerprint(&p).unwrap_err().to_string();
        assert!(e.contains("file has"), "{e}");
        let mut hdr = bytes.clone();
        hdr[20] ^= 1;
        std::fs::write(&p, &hdr).unwrap();
        let e = fingerprint(&p).unwrap_err().to_string();
        assert!(e.contains("header"), "{e}");
        let mut tr = bytes;
        let n = tr.len();
        tr[n - 32] = b'X';
        std::fs::write(&p, &tr).unwrap();
        let e = fingerprint(&p).unwrap_err().to_string();
        assert!(e.contains("trailer"), "{e}");
    }

    fn raw_bytes(seed: u64, dims: Dims) -> Vec<u8> {
        volcore::region::pack_sliced(&SceneSource::<u8>::new(&scene(dims, seed)))
    }

    #[test]
    fn raw_and_thesis_fingerprints_follow_contents_length_and_time() {
        let dir = tempfile::tempdir().unwrap();
        let dims = Dims::new(40, 40, 40).unwrap(); // 64000 bytes: all sampled
        let a = dir.path().join("a_40x40x40_uint8.raw");
        std::fs::write(&a, raw_bytes(1, dims)).unwrap();
        let fa = fingerprint(&a).unwrap();
        assert_eq!(fa, fingerprint(&a).unwrap());
        // Another seed, even if the modification time happens to match.
        let b = dir.path().join("b_40x40x40_uint8.raw");
        std::fs::write(&b, raw_bytes(2, dims)).unwrap();
        let t = std::fs::metadata(&a).unwrap().modified().unwrap();
        File::options()
            .write(true)
            .open(&b)
            .unwrap()
            .set_modified(t)
            .unwrap();
        assert_ne!(fa, fingerprint(&b).unwrap());
        // The same bytes with another modification time.
        std::fs::write(&b, raw_bytes(1, dims)).unwrap();
        let later = t + std::time::Duration::from_nanos(1);
        let fb = File::options().write(true).open(&b).unwrap();
        fb.set_modified(later).unwrap();
        assert_ne!(fa, fingerprint(&b).unwrap());
        fb.set_modified(t).unwrap();
        assert_eq!(fa, fingerprint(&b).unwrap());

        // Thesis .vol: regenerated with another seed.
        let v1 = dir.path().join("one.vol");
        let v2 = dir.path().join("two.vol");
        for (p, seed) in [(&v1, 1), (&v2, 2)] {
            let s = scene(dims, seed);
            let mut f = File::create(p).unwrap();
            thesis::write(
                &SceneSource::<u8>::new(&s),
                [1.0; 3],
                thesis::ThesisLayout::Sliced,
                &mut f,
                &no_progress,
            )
            .unwrap();
            f.set_modified(t).unwrap();
        }
        let f1 = fingerprint(&v1).unwrap();
        assert_eq!(f1, fingerprint(&v1).unwrap());
        assert_ne!(f1, fingerprint(&v2).unwrap());
        // The same bytes as .vol and as .raw: different tags.
        let r = dir.path().join("one_40x40x40_uint8.raw");
        std::fs::copy(&v1, &r).unwrap();
        assert_ne!(f1, fingerprint(&r).unwrap());
    }

    #[test]
    fn sampled_blocks_cover_both_ends() {
        assert!(block_starts(0).is_empty());
        assert_eq!(block_starts(1), vec![0]);
        assert_eq!(
            block_starts(BLOCK * 3 + 1),
            vec![0, BLOCK, 2 * BLOCK, 3 * BLOCK]
        );
        let len = 800 * 800 * 800 + 26;
        let s = block_starts(len);
        assert_eq!(s.len(), BLOCKS as usize);
        assert_eq!((s[0], s[s.len() - 1]), (0, len - BLOCK));
        assert!(s.windows(2).all(|w| w[0] + BLOCK <= w[1]));
    }

    #[test]
    fn streams_have_no_fingerprint_other_files_and_directories_do() {
        assert!(fingerprint(Path::new("-")).is_err());
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.nrrd");
        std::fs::write(&p, b"NRRD0004").unwrap();
        let a = fingerprint(&p).unwrap();
        std::fs::write(&p, b"NRRD0005").unwrap();
        assert_ne!(fingerprint(&p).unwrap(), a);
        let series = dir.path().join("series");
        std::fs::create_dir(&series).unwrap();
        std::fs::write(series.join("1.dcm"), b"a").unwrap();
        let d1 = fingerprint(&series).unwrap();
        std::fs::write(series.join("2.dcm"), b"b").unwrap();
        assert_ne!(fingerprint(&series).unwrap(), d1);
        let e = fingerprint(&dir.path().join("missing.vvol")).unwrap_err();
        assert!(matches!(e, Error::Io(_)), "{e}");
    }

    /// The hash itself is fixed: these values must never change, or every
    /// existing sidecar file would look stale.
    #[test]
    fn hash_is_stable() {
        assert_eq!(Fnv64(Fnv64::OFFSET).0, 0xcbf2_9ce4_8422_2325);
        let mut h = Fnv64::new(b"");
        h.update(b"a");
        assert_eq!(h.0, 0xaf63_dc4c_8601_ec8c); // published FNV-1a 64 of "a"
        let mut h = Fnv64::new(b"volkit");
        h.update(b"fingerprint");
        assert_eq!(h.finish(), STABLE);
    }

    // Cross-checked with an independent implementation of the same steps.
    const STABLE: u64 = 0xc9c2_5d98_cfce_007a;
}
