//! The allocation guard: a DICOM file is walked element by element
//! before dicom-rs reads it, and refused when an element claims more
//! bytes than the file holds (dicom-rs would reserve them first).

use super::bad;
use crate::reader::{At, CResult};
use std::path::Path;

/// Where [`check_lengths`] reads a data set from: the file, or the inflated
/// data set of the deflated transfer syntax.
trait Walk: std::io::Read {
    /// Pass `n` bytes of value; errors when fewer are left.
    fn skip(&mut self, n: u64) -> std::io::Result<()>;
}

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

impl Walk for FileWalk {
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

/// An inflated stream: a value is skipped by reading it (its end is only
/// known by reaching it).
struct StreamWalk<R>(R);

impl<R: std::io::Read> std::io::Read for StreamWalk<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl<R: std::io::Read> Walk for StreamWalk<R> {
    fn skip(&mut self, n: u64) -> std::io::Result<()> {
        let mut part = std::io::Read::take(&mut self.0, n);
        let got = std::io::copy(&mut part, &mut std::io::sink())?;
        if got < n {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        Ok(())
    }
}

/// Read exactly `buf.len()` bytes; `false` at a clean end of the data
/// (no byte left), an error at a partial read.
fn read_or_end(r: &mut dyn Walk, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) if got == 0 => return Ok(false),
            Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

const UNDEFINED: u32 = u32::MAX;
const ITEM: (u16, u16) = (0xfffe, 0xe000);
const SEQUENCE_END: (u16, u16) = (0xfffe, 0xe0dd);

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

/// Walk the data elements of one encoding (explicit or implicit VR, byte
/// order) to the end of `r`, stepping into sequences and items and over
/// every other value (and pixel data fragments); the first value that
/// runs past the end of the data is an error.
fn walk_elements(r: &mut dyn Walk, explicit: bool, big: bool) -> Result<(), String> {
    let u16_of = |b: [u8; 2]| {
        if big {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        }
    };
    let u32_of = |b: [u8; 4]| {
        if big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    };
    let mut fragments = false;
    let mut pending: Option<(u16, u16)> = None;
    loop {
        let tag = match pending.take() {
            Some(t) => t,
            None => {
                let mut b = [0u8; 4];
                match read_or_end(r, &mut b) {
                    Ok(true) => (u16_of([b[0], b[1]]), u16_of([b[2], b[3]])),
                    // A data set that stops inside a tag is dicom-rs's to report.
                    _ => return Ok(()),
                }
            }
        };
        let name = format!("({:04X},{:04X})", tag.0, tag.1);
        let short = |r: &mut dyn Walk| -> Result<u32, String> {
            let mut b = [0u8; 2];
            r.read_exact(&mut b)
                .map_err(|_| format!("element {name} is truncated"))?;
            Ok(u16_of(b) as u32)
        };
        let long = |r: &mut dyn Walk| -> Result<u32, String> {
            let mut b = [0u8; 4];
            r.read_exact(&mut b)
                .map_err(|_| format!("element {name} is truncated"))?;
            Ok(u32_of(b))
        };
        // Items and delimiters have no VR, in either encoding.
        if tag.0 == 0xfffe {
            let len = long(r)?;
            if tag == ITEM && fragments && len != UNDEFINED {
                r.skip(len as u64).map_err(|_| {
                    format!("a pixel data fragment claims {len} bytes, past the end of the data")
                })?;
            } else if tag == SEQUENCE_END {
                fragments = false;
            }
            continue;
        }
        let (vr, len) = if explicit {
            let mut v = [0u8; 2];
            r.read_exact(&mut v)
                .map_err(|_| format!("element {name} is truncated"))?;
            let wide = !short_length_vr(&v);
            let len = if wide {
                short(r)?;
                long(r)?
            } else {
                short(r)?
            };
            (Some(v), len)
        } else {
            (None, long(r)?)
        };
        if len == UNDEFINED {
            // As dicom-rs reads it: undefined-length pixel data holds
            // fragments, any other undefined-length element (whatever its
            // VR) a sequence in the same encoding; items follow up to a
            // sequence delimiter.
            if tag == (0x7fe0, 0x0010) {
                fragments = true;
            }
            continue;
        }
        if vr.as_ref() == Some(b"SQ") {
            continue;
        }
        if vr.is_none() && len >= 8 {
            // Implicit VR: a value that starts with an item is a sequence.
            let mut b = [0u8; 4];
            r.read_exact(&mut b).map_err(|_| {
                format!("element {name} claims {len} bytes, past the end of the data")
            })?;
            let t = (u16_of([b[0], b[1]]), u16_of([b[2], b[3]]));
            if t == ITEM {
                pending = Some(t);
                continue;
            }
            r.skip(len as u64 - 4).map_err(|_| {
                format!("element {name} claims {len} bytes, past the end of the data")
            })?;
            continue;
        }
        // dicom-rs reads whole numbers of a binary VR's values: the
        // bytes of a length that is no multiple of their size are left
        // for the next element's header.
        let size = match vr.as_ref().map(|v| &v[..]) {
            Some(b"US" | b"OW" | b"SS") => 2,
            Some(b"FL" | b"OF" | b"SL" | b"OL" | b"UL" | b"AT") => 4,
            Some(b"FD" | b"OD" | b"SV" | b"OV" | b"UV") => 8,
            _ => 1,
        };
        r.skip(u64::from(len - len % size))
            .map_err(|_| format!("element {name} claims {len} bytes, past the end of the data"))?;
    }
}

/// Refuse a file any of whose data elements claims more bytes than the
/// file holds (more than its inflated data set, for the deflated transfer
/// syntax). dicom-rs reserves and zero-fills a value's declared length
/// before reading it: unchecked, a 600-byte file claiming a 4 GiB element
/// would take 4 GiB of memory.
pub(super) fn check_lengths(path: &Path) -> CResult<()> {
    use std::io::{Read, Seek, SeekFrom};
    let f = std::fs::File::open(path).at(path)?;
    let len = f.metadata().at(path)?.len();
    let mut w = FileWalk {
        r: std::io::BufReader::new(f),
        pos: 0,
        len,
    };
    // The preamble and DICM, then the meta group (explicit VR little endian).
    if len < 132 {
        return Ok(());
    }
    w.r.seek(SeekFrom::Start(132)).at(path)?;
    w.pos = 132;
    let fail = |e: String| bad(path, format!("damaged DICOM file: {e}"));
    // The meta group as dicom-rs reads it: elements while fewer bytes
    // than (0002,0000) gives have been read, whatever their tags.
    let mut head = [0u8; 12];
    if w.read_exact(&mut head).is_err() || head[..8] != [2, 0, 0, 0, b'U', b'L', 4, 0] {
        return Ok(());
    }
    let group_len = u64::from(u32::from_le_bytes([head[8], head[9], head[10], head[11]]));
    let mut ts = None;
    let mut read = 0u64;
    while read < group_len {
        let mut h = [0u8; 8];
        if w.read_exact(&mut h).is_err() {
            return Ok(());
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
                return Ok(());
            }
            (u32::from_le_bytes(l), 12)
        };
        if len == UNDEFINED {
            return Ok(());
        }
        let name = format!("({:04X},{:04X})", tag.0, tag.1);
        let past = || {
            fail(format!(
                "element {name} claims {len} bytes, past the end of the data"
            ))
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
    let ts = ts.unwrap_or_default();
    match ts.as_str() {
        "1.2.840.10008.1.2" => walk_elements(&mut w, false, false),
        "1.2.840.10008.1.2.2" => walk_elements(&mut w, true, true),
        "1.2.840.10008.1.2.1.99" | "1.2.840.10008.1.2.4.95" => {
            let mut s = StreamWalk(flate2::read::DeflateDecoder::new(w.r));
            walk_elements(&mut s, true, false)
        }
        _ => walk_elements(&mut w, true, false),
    }
    .map_err(fail)?;
    Ok(())
}
