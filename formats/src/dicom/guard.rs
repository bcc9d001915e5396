//! The allocation guard: a DICOM file is read token by token with
//! dicom-rs's own data set reader before dicom-rs opens it, and refused
//! when an element (or a pixel data fragment) claims more bytes than are
//! left in the file: dicom-rs reserves and zero-fills a value's declared
//! length before reading it.
//!
//! The walk is dicom-rs's parser itself, so it reads every element as
//! dicom-rs will (implicit VR by the data dictionary, whole binary values,
//! undefined lengths as sequences): an earlier walk of volkit's own
//! disagreed with it on an implicit-VR file, which then took 1 GB.

use dicom_parser::dataset::read::DataSetReaderOptions;
use dicom_parser::dataset::{DataSetReader, DataToken};
use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
use std::cell::Cell;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::rc::Rc;

/// A file, with its length: a value is skipped by seeking, after checking
/// that it ends inside the file.
struct FileWalk {
    r: std::io::BufReader<std::fs::File>,
    pos: u64,
    len: u64,
}

impl std::io::Read for FileWalk {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.r.read(buf)?;
        self.pos += n as u64;
        Ok(n)
    }
}

impl FileWalk {
    /// Pass `n` bytes of value; errors when fewer are left.
    fn skip(&mut self, n: u64) -> std::io::Result<()> {
        if n > self.len.saturating_sub(self.pos) {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        let off = i64::try_from(n).map_err(|_| std::io::ErrorKind::UnexpectedEof)?;
        self.r.seek_relative(off)?;
        self.pos += n;
        Ok(())
    }
}

/// A reader that counts the bytes it hands on: what dicom-rs's decoder
/// has consumed of the data set, exactly (it reads from this, not
/// ahead of it).
struct Counted<R> {
    inner: R,
    read: Rc<Cell<u64>>,
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.read.set(self.read.get() + n as u64);
        Ok(n)
    }
}

const UNDEFINED: u32 = u32::MAX;

/// Whether explicit-VR elements of value representation `vr` carry a
/// 16-bit length: dicom-rs reads one for these and a 32-bit one (after
/// two reserved bytes) for every other, unknown VRs included (as UN).
fn short_length_vr(vr: &[u8; 2]) -> bool {
    matches!(
        vr,
        b"AE"
            | b"AS"
            | b"AT"
            | b"CS"
            | b"DA"
            | b"DS"
            | b"DT"
            | b"FL"
            | b"FD"
            | b"IS"
            | b"LO"
            | b"LT"
            | b"PN"
            | b"SH"
            | b"SL"
            | b"SS"
            | b"ST"
            | b"TM"
            | b"UI"
            | b"UL"
            | b"US"
    )
}

/// The deflated transfer syntaxes: the data set after the meta group is
/// one raw deflate stream.
const DEFLATED: [&str; 2] = ["1.2.840.10008.1.2.1.99", "1.2.840.10008.1.2.4.95"];

/// Check the lengths of the file at `path` before dicom-rs reads it, and
/// return its transfer syntax UID (empty when the meta group gives none).
///
/// The meta group is walked here, as dicom-rs reads it (elements while
/// fewer bytes than (0002,0000) gives have been read); the data set after
/// it through dicom-rs's own token reader, which hands over each
/// element's header before reading its value: a value that claims more
/// bytes than are left is an error, before anything is reserved. So each
/// value dicom-rs reserves afterwards is at most the file's size (the
/// inflated data set's, for the deflated transfer syntaxes). A file that
/// is no Part 10 file, or whose meta group dicom-rs cannot read, passes:
/// dicom-rs refuses it without reserving anything.
pub(super) fn check_lengths(path: &Path) -> Result<String, String> {
    let f = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let len = f.metadata().map_err(|e| e.to_string())?.len();
    let mut w = FileWalk {
        r: std::io::BufReader::new(f),
        pos: 0,
        len,
    };
    if len < 132 {
        return Ok(String::new());
    }
    w.r.seek(SeekFrom::Start(132)).map_err(|e| e.to_string())?;
    w.pos = 132;
    let Some(ts) = meta_group(&mut w)? else {
        return Ok(String::new());
    };
    let Some(syntax) = TransferSyntaxRegistry.get(&ts) else {
        return Ok(ts);
    };
    if !syntax.can_decode_dataset() {
        return Ok(ts);
    }
    let start = w.pos;
    if DEFLATED.contains(&ts.as_str()) {
        // The inflated length first (read, not held), then the walk.
        let mut counter = flate2::read::DeflateDecoder::new(w.r);
        let total = std::io::copy(&mut counter, &mut std::io::sink())
            .map_err(|e| format!("the deflated data set cannot be inflated: {e}"))?;
        let mut f = counter.into_inner();
        f.seek(SeekFrom::Start(start)).map_err(|e| e.to_string())?;
        walk_data_set(flate2::read::DeflateDecoder::new(f), total, syntax)?;
    } else {
        walk_data_set(w.r, len - start, syntax)?;
    }
    Ok(ts)
}

/// Walk the meta group (from after `DICM`) and return its transfer
/// syntax UID; `None` when the group is not one dicom-rs reads (it then
/// refuses the file itself), an error when an element runs past the end
/// of the file.
fn meta_group(w: &mut FileWalk) -> Result<Option<String>, String> {
    // (0002,0000) with a length of 4, whatever its VR: dicom-rs takes any
    // (a fuzzed file's `UI` group length of 16 MB made it reserve and
    // zero-fill values for seconds where a `UL` check let it pass).
    let mut head = [0u8; 8];
    if w.read_exact(&mut head).is_err() || head[..4] != [2, 0, 0, 0] {
        return Ok(None);
    }
    let four = if short_length_vr(&[head[4], head[5]]) {
        head[6..8] == [4, 0]
    } else {
        let mut l = [0u8; 4];
        w.read_exact(&mut l).is_ok() && l == [4, 0, 0, 0]
    };
    let mut value = [0u8; 4];
    if !four || w.read_exact(&mut value).is_err() {
        return Ok(None);
    }
    let group_len = u64::from(u32::from_le_bytes(value));
    let mut ts = None;
    let mut read = 0u64;
    while read < group_len {
        let mut h = [0u8; 8];
        if w.read_exact(&mut h).is_err() {
            return Ok(None);
        }
        let tag = (
            u16::from_le_bytes([h[0], h[1]]),
            u16::from_le_bytes([h[2], h[3]]),
        );
        let short = short_length_vr(&[h[4], h[5]]) && tag.0 != 0xfffe;
        let (len, header) = if short {
            (u32::from(u16::from_le_bytes([h[6], h[7]])), 8)
        } else {
            let mut l = [0u8; 4];
            if w.read_exact(&mut l).is_err() {
                return Ok(None);
            }
            (u32::from_le_bytes(l), 12)
        };
        if len == UNDEFINED {
            return Ok(None);
        }
        let past = || {
            format!(
                "element ({:04X},{:04X}) claims {len} bytes, past the end of the file",
                tag.0, tag.1
            )
        };
        if tag == (0x0002, 0x0010) && len <= 64 {
            let mut b = vec![0u8; len as usize];
            w.read_exact(&mut b).map_err(|_| past())?;
            ts = Some(
                String::from_utf8_lossy(&b)
                    .trim_end_matches(['\0', ' '])
                    .to_string(),
            );
        } else {
            w.skip(u64::from(len)).map_err(|_| past())?;
        }
        read += header + u64::from(len);
    }
    Ok(Some(ts.unwrap_or_default()))
}

/// Read the data set in `source` (`total` bytes) with dicom-rs's token
/// reader, as dicom-object does (default options); before each value
/// and each pixel data fragment is read, its length is checked against
/// the bytes left. A token dicom-rs cannot read is an error too (the
/// file's pixel data would not decode either), in dicom-rs's words.
fn walk_data_set(
    source: impl Read + 'static,
    total: u64,
    ts: &dicom_transfer_syntax_registry::TransferSyntax,
) -> Result<(), String> {
    let read = Rc::new(Cell::new(0u64));
    let counted = Counted {
        inner: source,
        read: Rc::clone(&read),
    };
    let tokens = DataSetReader::new_with_ts_options(counted, ts, DataSetReaderOptions::default())
        .map_err(|e| super::chain(&e))?;
    let mut fragments = false;
    for token in tokens {
        let token = token.map_err(|e| super::chain(&e))?;
        let claim = match &token {
            DataToken::ElementHeader(h) => h.len.get().map(|n| (h.tag.to_string(), n)),
            DataToken::PixelSequenceStart => {
                fragments = true;
                None
            }
            DataToken::SequenceEnd => {
                fragments = false;
                None
            }
            DataToken::ItemStart { len } if fragments => {
                len.get().map(|n| ("a pixel data fragment".to_string(), n))
            }
            _ => None,
        };
        if let Some((what, n)) = claim {
            let left = total.saturating_sub(read.get());
            if u64::from(n) > left {
                return Err(format!(
                    "{} claims {n} bytes where {left} are left in the file",
                    if what.starts_with('(') {
                        format!("element {what}")
                    } else {
                        what
                    }
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repo(p: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(p)
    }

    /// The fuzzer's implicit-VR input: its (0000,0000) group length is a
    /// UL of 51 bytes, of which dicom-rs reads 12 whole values and takes
    /// the rest for the next header, which then claims 1 GiB. The old
    /// walk of volkit's own skipped all 51 bytes and let it through;
    /// dicom-rs then reserved the gigabyte.
    #[test]
    fn the_implicit_vr_element_dicom_rs_would_reserve_a_gigabyte_for_is_refused() {
        let start = std::time::Instant::now();
        let e = check_lengths(&repo("fuzz/regressions/dicom/f43f9f4edf6e29e6")).unwrap_err();
        assert!(e.contains("claims 1073747968 bytes"), "{e}");
        assert!(start.elapsed().as_secs_f64() < 0.5, "{:?}", start.elapsed());
    }

    /// The second round's hang: a group length (0002,0000) of VR `UI`
    /// (16 MB), which dicom-rs takes as a `UL`; the check gave up on it
    /// and dicom-rs then zero-filled the group's claimed values for
    /// seconds. Read as dicom-rs reads it, an element past the end shows.
    #[test]
    fn a_group_length_of_another_vr_is_walked_as_dicom_rs_walks_it() {
        let start = std::time::Instant::now();
        let e = check_lengths(&repo("fuzz/regressions/dicom/0a2a9cbdc20dbdcf")).unwrap_err();
        assert!(e.contains("past the end of the file"), "{e}");
        assert!(start.elapsed().as_secs_f64() < 0.5, "{:?}", start.elapsed());
    }

    #[test]
    fn whole_files_pass_and_give_their_transfer_syntax() {
        let dir = repo("tests/fixtures/dicom_ct");
        for e in std::fs::read_dir(dir).unwrap() {
            let ts = check_lengths(&e.unwrap().path()).unwrap();
            assert_eq!(ts, "1.2.840.10008.1.2.1");
        }
    }

    #[test]
    fn a_truncated_pixel_data_value_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let src = std::fs::read_dir(repo("tests/fixtures/dicom_ct"))
            .unwrap()
            .next()
            .unwrap()
            .unwrap()
            .path();
        let mut b = std::fs::read(src).unwrap();
        b.truncate(b.len() - 3);
        let p = dir.path().join("t.dcm");
        std::fs::write(&p, b).unwrap();
        let e = check_lengths(&p).unwrap_err();
        assert!(e.contains("(7FE0,0010) claims"), "{e}");
    }
}
