//! The IFD validator: a TIFF file's directory chain walked before the
//! decoder sees it, refusing an entry whose values claim more bytes than
//! the whole file.

use crate::error::Error;
use std::io::{Read, Seek};

/// Bytes per value of TIFF field type `t`; `None` for a type the decoder
/// does not know (it skips those entries).
fn type_bytes(t: u16) -> Option<u64> {
    match t {
        1 | 2 | 6 | 7 => Some(1),
        3 | 8 => Some(2),
        4 | 9 | 11 | 13 => Some(4),
        5 | 10 | 12 | 16..=18 => Some(8),
        _ => None,
    }
}

/// Walk the directory chain of the TIFF file in `r` (`file_len` bytes) and
/// refuse an entry whose values take more bytes than the whole file: no
/// file can hold them, so the directory is damaged. Checked before the
/// decoder sees the file because `tiff` 0.11 answers an ASCII entry past
/// its limits with a `dbg!` line on stderr before its error; every entry
/// it could reach is within the file here, hence within its limits
/// (see `read::limits`). Structural damage (a directory outside the file, a
/// cycle) stops the walk and is left to the decoder to report.
pub(super) fn check_directories<R: Read + Seek>(r: &mut R, file_len: u64) -> Result<(), Error> {
    use std::io::SeekFrom;
    let mut head = [0u8; 16];
    r.rewind()?;
    if file_len < 16 || r.read_exact(&mut head).is_err() {
        return Ok(());
    }
    let big_endian = match &head[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return Ok(()),
    };
    let u16_at = |b: &[u8], o: usize| {
        let v = [b[o], b[o + 1]];
        if big_endian {
            u16::from_be_bytes(v)
        } else {
            u16::from_le_bytes(v)
        }
    };
    let uint_at = |b: &[u8], o: usize, n: usize| {
        let mut v = [0u8; 8];
        if big_endian {
            v[8 - n..].copy_from_slice(&b[o..o + n]);
            u64::from_be_bytes(v)
        } else {
            v[..n].copy_from_slice(&b[o..o + n]);
            u64::from_le_bytes(v)
        }
    };
    // Classic: 2-byte entry counts, 12-byte entries, 4-byte counts and
    // offsets; BigTIFF: 8, 20, 8.
    let (count_len, entry_len, word, mut next) = match u16_at(&head, 2) {
        42 => (2usize, 12usize, 4usize, uint_at(&head, 4, 4)),
        43 => (8, 20, 8, uint_at(&head, 8, 8)),
        _ => return Ok(()),
    };
    let mut seen = std::collections::HashSet::new();
    let mut walked = 0u64;
    let mut buf = vec![0u8; 256 * entry_len];
    let mut page = 0u64;
    while next != 0 && next < file_len && seen.insert(next) {
        r.seek(SeekFrom::Start(next))?;
        let mut c = [0u8; 8];
        if r.read_exact(&mut c[..count_len]).is_err() {
            return Ok(());
        }
        let entries = uint_at(&c, 0, count_len);
        let dir_len = entries
            .checked_mul(entry_len as u64)
            .and_then(|b| b.checked_add((count_len + word) as u64));
        match dir_len {
            Some(b) if b <= file_len - next => walked += b,
            _ => return Ok(()),
        }
        // Directories do not overlap: together they fit in the file.
        if walked > file_len {
            return Err(Error::invalid(
                "the directories overlap (damaged directory?)",
            ));
        }
        let mut left = entries;
        while left > 0 {
            let n = left.min(256) as usize;
            let chunk = &mut buf[..n * entry_len];
            if r.read_exact(chunk).is_err() {
                return Ok(());
            }
            for e in chunk.chunks_exact(entry_len) {
                let Some(size) = type_bytes(u16_at(e, 2)) else {
                    continue;
                };
                let count = uint_at(e, 4, word);
                if count.checked_mul(size).is_none_or(|b| b > file_len) {
                    return Err(Error::invalid(format!(
                        "page {page}: tag {} holds {count} values of {size} bytes, more than the whole file ({file_len} bytes; damaged directory?)",
                        u16_at(e, 0)
                    )));
                }
            }
            left -= n as u64;
        }
        let mut w = [0u8; 8];
        if r.read_exact(&mut w[..word]).is_err() {
            return Ok(());
        }
        next = uint_at(&w, 0, word);
        page += 1;
    }
    Ok(())
}
