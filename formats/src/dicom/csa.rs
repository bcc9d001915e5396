//! Siemens' CSA header (the private element (0029,1010) "CSA Image
//! Header Info"): a binary list of named elements, each with a few text
//! items. Read with every count and length checked against the bytes, so
//! a damaged header gives an error, never a long loop or a large
//! allocation.
//!
//! Two layouts exist. CSA2 starts `SV10`, four bytes, then the element
//! count; CSA1 starts with the count. Each element is a 64-byte name, its
//! VM, a 4-byte VR, a type code, its item count and a check word; each
//! item is four words (its length is the second in CSA2, the first less
//! the first element's item count in CSA1), then its text, padded to 4
//! bytes.

use std::collections::BTreeMap;

/// The most elements, and items per element, a CSA header may claim
/// (scanners write about 100 elements of 6 items; nibabel's bound).
const MAX_COUNT: u32 = 1000;

/// A parsed CSA header: each element's name and its non-empty items, as
/// text.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CsaHeader {
    elements: BTreeMap<String, Vec<String>>,
}

/// Little-endian reading over the header's bytes, every read checked.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| {
                format!(
                    "ends at byte {} where {n} more are needed",
                    self.bytes.len()
                )
            })?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn word(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
}

/// Text up to its first NUL, trimmed.
fn c_text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).trim().to_string()
}

impl CsaHeader {
    /// Parse a CSA1 or CSA2 header, or say where it is damaged.
    pub fn parse(bytes: &[u8]) -> Result<CsaHeader, String> {
        let csa2 = bytes.starts_with(b"SV10");
        let mut c = Cursor {
            bytes,
            at: if csa2 { 8 } else { 0 },
        };
        let count = c.word()?;
        c.word()?;
        if !(1..=MAX_COUNT).contains(&count) {
            return Err(format!("claims {count} elements (1 to {MAX_COUNT})"));
        }
        let mut elements = BTreeMap::new();
        let mut first_items = None;
        for _ in 0..count {
            let name = c_text(c.take(64)?);
            let vm = c.word()?;
            c.take(4 + 4)?; // VR, type code
            let items = c.word()?;
            c.word()?; // check word (77 or 205)
            if items > MAX_COUNT {
                return Err(format!("element {name:?} claims {items} items"));
            }
            let first = *first_items.get_or_insert(items);
            let mut values = Vec::new();
            for _ in 0..items {
                let head = [c.word()?, c.word()?, c.word()?, c.word()?];
                let len = if csa2 {
                    head[1]
                } else {
                    // CSA1 states the length less the first element's
                    // item count; a negative one ends the element.
                    match head[0].checked_sub(first) {
                        Some(l) => l,
                        None => break,
                    }
                } as usize;
                let text = c_text(c.take(len)?);
                c.take((4 - len % 4) % 4)?;
                if !text.is_empty() && (vm == 0 || values.len() < vm as usize) {
                    values.push(text);
                }
            }
            elements.insert(name, values);
        }
        Ok(CsaHeader { elements })
    }

    /// The items of element `name`, empty when it is absent.
    pub fn items(&self, name: &str) -> &[String] {
        self.elements.get(name).map_or(&[], Vec::as_slice)
    }

    /// Element `name`'s first item as a number.
    pub fn number(&self, name: &str) -> Option<f64> {
        self.items(name).first()?.parse().ok()
    }

    /// Element `name`'s first three items as a finite vector.
    pub fn vector(&self, name: &str) -> Option<[f64; 3]> {
        let v: Vec<f64> = self
            .items(name)
            .iter()
            .map_while(|s| s.parse().ok())
            .collect();
        (v.len() >= 3 && v[..3].iter().all(|x: &f64| x.is_finite())).then(|| [v[0], v[1], v[2]])
    }
}

/// A CSA2 header of `elements` (name, items), laid out as Siemens writes
/// one (six item slots at least, each padded to 4 bytes): what tests and
/// the fuzz target build mosaics with.
pub fn write_csa2(elements: &[(&str, &[&str])]) -> Vec<u8> {
    let mut out = b"SV10\x04\x03\x02\x01".to_vec();
    let word = |out: &mut Vec<u8>, w: u32| out.extend_from_slice(&w.to_le_bytes());
    word(&mut out, elements.len() as u32);
    word(&mut out, 77);
    for (name, items) in elements {
        let mut n = [0u8; 64];
        n[..name.len().min(63)].copy_from_slice(&name.as_bytes()[..name.len().min(63)]);
        out.extend_from_slice(&n);
        word(&mut out, items.len() as u32);
        out.extend_from_slice(b"DS\0\0");
        word(&mut out, 3);
        word(&mut out, 6.max(items.len() as u32));
        word(&mut out, 77);
        for k in 0..6.max(items.len()) {
            let text = items.get(k).copied().unwrap_or("");
            let len = text.len() as u32;
            for w in [len, len, 77, len] {
                word(&mut out, w);
            }
            out.extend_from_slice(text.as_bytes());
            out.resize(out.len() + (4 - text.len() % 4) % 4, 0);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        write_csa2(&[
            ("NumberOfImagesInMosaic", &["48"]),
            ("SliceNormalVector", &["0", "0.00523632", "0.99998629"]),
            ("Empty", &[]),
        ])
    }

    #[test]
    fn a_csa2_header_gives_its_numbers_and_vectors() {
        let h = CsaHeader::parse(&sample()).unwrap();
        assert_eq!(h.number("NumberOfImagesInMosaic"), Some(48.0));
        assert_eq!(
            h.vector("SliceNormalVector"),
            Some([0.0, 0.00523632, 0.99998629])
        );
        assert!(h.items("Empty").is_empty());
        assert_eq!(h.number("Absent"), None);
    }

    #[test]
    fn a_csa1_header_reads_its_odd_lengths() {
        // CSA1: no SV10; an item's first word is its length plus the
        // first element's item count.
        let mut b = Vec::new();
        for w in [1u32, 77] {
            b.extend_from_slice(&w.to_le_bytes());
        }
        let mut name = [0u8; 64];
        name[..5].copy_from_slice(b"Slice");
        b.extend_from_slice(&name);
        for w in [1u32, 0x4453, 3, 2, 77] {
            b.extend_from_slice(&w.to_le_bytes());
        }
        for (k, text) in [b"12\0\0".as_slice(), b""].iter().enumerate() {
            let len: u32 = if k == 0 { 3 } else { 0 };
            for w in [len + 2, len, 77, len] {
                b.extend_from_slice(&w.to_le_bytes());
            }
            b.extend_from_slice(text);
        }
        let h = CsaHeader::parse(&b).unwrap();
        assert_eq!(h.number("Slice"), Some(12.0));
    }

    #[test]
    fn every_cut_of_a_header_is_refused_or_read_never_overrun() {
        let whole = sample();
        for n in 0..whole.len() {
            // A cut header is an error (or, cut in trailing padding, the
            // same header); it never reads past the bytes.
            if let Ok(h) = CsaHeader::parse(&whole[..n]) {
                assert_eq!(h, CsaHeader::parse(&whole).unwrap());
            }
        }
    }

    #[test]
    fn every_byte_of_a_header_set_to_an_extreme_parses_or_is_refused() {
        // Counts and lengths at 0, 0x7F, 0x80 and 0xFF in every byte: the
        // parser returns (bounded loops, checked lengths), whatever it
        // makes of them, and what it reads stays within the bytes.
        let whole = sample();
        for i in 0..whole.len() {
            for v in [0x00, 0x7F, 0x80, 0xFF] {
                let mut b = whole.clone();
                b[i] = v;
                if let Ok(h) = CsaHeader::parse(&b) {
                    let total: usize = h.elements.values().map(Vec::len).sum();
                    assert!(total <= b.len(), "byte {i} = {v:#x}");
                    let _ = (
                        h.number("NumberOfImagesInMosaic"),
                        h.vector("SliceNormalVector"),
                    );
                }
            }
        }
    }

    #[test]
    fn counts_past_the_bound_are_refused_before_any_loop() {
        let mut b = b"SV10\x04\x03\x02\x01".to_vec();
        b.extend_from_slice(&u32::MAX.to_le_bytes());
        b.extend_from_slice(&77u32.to_le_bytes());
        let e = CsaHeader::parse(&b).unwrap_err();
        assert!(e.contains("elements"), "{e}");
        let mut b = sample();
        // The first element's item count (after SV10, 8 bytes of counts,
        // a 64-byte name and three words).
        b[8 + 8 + 64 + 12..8 + 8 + 64 + 16].copy_from_slice(&5000u32.to_le_bytes());
        assert!(CsaHeader::parse(&b).unwrap_err().contains("items"));
    }
}
