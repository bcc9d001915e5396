//! The `.vvol` trailer (`FORMAT.md`): its layout and codec, apart from
//! the header's so that the stream reader ([`crate::stream`]) checks a
//! streamed file's trailer without the rest of [`crate::vvol`].

use crate::error::{Error, Result};
use volcore::ValueRange;

/// First eight bytes of the trailer.
pub const TRAILER_MAGIC: [u8; 8] = *b"VVOLEND\0";
/// Size of the trailer.
pub const TRAILER_LEN: u64 = 32;
/// The flag saying a value range is stored (header and trailer).
pub(crate) const FLAG_RANGE: u32 = 1;

/// The decoded trailer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trailer {
    /// CRC-32 of the samples (sliced) or of the brick table (bricked).
    pub crc32: u32,
    /// Exact value range of the samples.
    pub range: ValueRange,
}

impl Trailer {
    /// Encode as 32 bytes.
    pub fn encode(&self) -> [u8; TRAILER_LEN as usize] {
        let mut b = [0u8; TRAILER_LEN as usize];
        b[0..8].copy_from_slice(&TRAILER_MAGIC);
        b[8..12].copy_from_slice(&self.crc32.to_le_bytes());
        let flags = if self.range.is_empty() { 0 } else { FLAG_RANGE };
        b[12..16].copy_from_slice(&flags.to_le_bytes());
        b[16..24].copy_from_slice(&self.range.min.to_le_bytes());
        b[24..32].copy_from_slice(&self.range.max.to_le_bytes());
        b
    }

    /// Decode 32 bytes.
    pub fn decode(b: &[u8]) -> Result<Trailer> {
        if b.len() < TRAILER_LEN as usize || b[0..8] != TRAILER_MAGIC {
            return Err(Error::invalid(
                "trailer is missing or damaged (file truncated?)",
            ));
        }
        let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or_default());
        let flags = u32::from_le_bytes([b[12], b[13], b[14], b[15]]);
        Ok(Trailer {
            crc32: u32::from_le_bytes([b[8], b[9], b[10], b[11]]),
            range: if flags & FLAG_RANGE != 0 {
                ValueRange {
                    min: f(16),
                    max: f(24),
                }
            } else {
                ValueRange::EMPTY
            },
        })
    }
}
