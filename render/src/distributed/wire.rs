//! How a share's film travels between processes: rows of pixel records
//! behind a bitmap of the pixels that carry anything, and the composite
//! of such streams without building their films.

use super::composite::Composite;
use crate::film::{Film, Px};
use std::ops::Range;

/// Which per-pixel fields of a film travel between processes
/// ([`Film::encode_rows`]): the ray count and sample count always, the
/// others when the composite rule reads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fields {
    /// Premultiplied colour, as 4 × f32: exact for films of at most one
    /// ray per pixel (the ray caster's: each channel is one f32 added to
    /// zero); a path tracer's sums would be rounded.
    pub colour: bool,
    /// The mode's value (f64: an X-ray sum can pass f32's range).
    pub value: bool,
    /// The depth (f32).
    pub depth: bool,
}

impl Fields {
    /// Every field.
    pub const ALL: Fields = Fields {
        colour: true,
        value: true,
        depth: true,
    };

    /// The fields `how` reads (the others stay empty after compositing).
    pub fn for_composite(how: Composite) -> Fields {
        let (colour, value, depth) = match how {
            Composite::Over => (true, false, false),
            Composite::FirstHit => (true, true, true),
            Composite::Max | Composite::Min => (false, true, true),
            Composite::Sum => (false, true, false),
        };
        Fields {
            colour,
            value,
            depth,
        }
    }

    /// Bytes per pixel: ray count and sample count (u32 each), and the
    /// chosen fields.
    pub fn pixel_bytes(self) -> usize {
        8 + 16 * self.colour as usize + 8 * self.value as usize + 4 * self.depth as usize
    }
}

impl Px {
    /// Write the record of `fields` (see [`Film::encode_rows`]).
    #[inline]
    fn write(&self, rec: &mut [u8], fields: Fields) {
        rec[0..4].copy_from_slice(&self.count.to_le_bytes());
        rec[4..8].copy_from_slice(&self.samples.to_le_bytes());
        let mut at = 8;
        if fields.colour {
            for c in self.rgba {
                rec[at..at + 4].copy_from_slice(&(c as f32).to_le_bytes());
                at += 4;
            }
        }
        if fields.value {
            rec[at..at + 8].copy_from_slice(&self.value.to_le_bytes());
            at += 8;
        }
        if fields.depth {
            rec[at..at + 4].copy_from_slice(&self.depth.to_le_bytes());
        }
    }

    /// Read a record of `fields`; the fields left out are empty.
    #[inline]
    fn read(rec: &[u8], fields: Fields) -> Px {
        let u32_at =
            |at: usize| u32::from_le_bytes([rec[at], rec[at + 1], rec[at + 2], rec[at + 3]]);
        let mut px = Px {
            count: u32_at(0),
            samples: u32_at(4),
            ..Px::START
        };
        let mut at = 8;
        if fields.colour {
            px.rgba = std::array::from_fn(|c| f64::from(f32::from_bits(u32_at(at + 4 * c))));
            at += 16;
        }
        if fields.value {
            px.value = f64::from_bits(u64::from(u32_at(at)) | u64::from(u32_at(at + 4)) << 32);
            at += 8;
        }
        if fields.depth {
            px.depth = f32::from_bits(u32_at(at));
        }
        px
    }
}

/// A stream of pixel records ([`Film::encode_rows`]), checked.
struct Stream<'a> {
    /// One bit per pixel: whether it has a record.
    bits: &'a [u8],
    /// The records, in pixel order.
    records: &'a [u8],
    /// Bytes per record.
    size: usize,
}

impl<'a> Stream<'a> {
    /// `bytes` as a stream of `pixels` pixels of `fields`, or `None` when
    /// its length is not that of the records its bitmap announces, or a
    /// padding bit is set.
    fn parse(bytes: &'a [u8], pixels: usize, fields: Fields) -> Option<Stream<'a>> {
        let (bits, records) = bytes.split_at_checked(pixels.div_ceil(8))?;
        let pad = pixels % 8;
        if pad != 0 && bits.last().is_some_and(|&b| b >> pad != 0) {
            return None;
        }
        let present: usize = bits.iter().map(|b| b.count_ones() as usize).sum();
        let size = fields.pixel_bytes();
        (present.checked_mul(size)? == records.len()).then_some(Stream {
            bits,
            records,
            size,
        })
    }
}

/// The indices of the set bits of `bits` (least significant bit first),
/// in order.
fn ones(bits: &[u8]) -> impl Iterator<Item = usize> + '_ {
    bits.iter().enumerate().flat_map(|(i, &byte)| {
        let mut b = byte;
        std::iter::from_fn(move || {
            (b != 0).then(|| {
                let bit = b.trailing_zeros() as usize;
                b &= b - 1;
                i * 8 + bit
            })
        })
    })
}

impl Film {
    /// Append the pixels of rows `rows` to `out` as one stream: how a
    /// share's film travels between processes. The stream is a bitmap of
    /// one bit per pixel (row order, least significant bit first, padded
    /// to a byte) saying which pixels carry anything, then one record of
    /// [`Fields::pixel_bytes`] little-endian bytes per such pixel (ray
    /// count, sample count, then the chosen fields; the totals are not
    /// included). A pixel that carries nothing (no samples, no colour, no
    /// value, no depth) is only its bit: it comes back as a pixel no ray
    /// reached, which resolves to the same frame and composites to the
    /// same pixel. Most of a share's pixels are such, so the stream is
    /// mostly the records of the pixels that matter.
    pub fn encode_rows(&self, rows: Range<u32>, fields: Fields, out: &mut Vec<u8>) {
        let w = self.width as usize;
        let px = (rows.start as usize * w).min(self.count.len())
            ..(rows.end as usize * w).min(self.count.len());
        let size = fields.pixel_bytes();
        let bits = out.len();
        out.resize(bits + px.len().div_ceil(8), 0);
        for (i, p) in px.enumerate() {
            let px = self.px(p);
            if px.carries_nothing() {
                continue;
            }
            out[bits + i / 8] |= 1 << (i % 8);
            let at = out.len();
            out.resize(at + size, 0);
            px.write(&mut out[at..], fields);
        }
    }

    /// Put the pixels of rows `rows` that a stream [`Film::encode_rows`]
    /// wrote with `fields` carries into this film, whose rows `rows` are
    /// still as [`Film::new`] made them (the pixels the stream leaves out
    /// stay so; the fields left out come back empty). `None`, with the
    /// film unchanged, when the rows are not the film's or the bytes are
    /// not such a stream of that many pixels.
    pub fn decode_rows(&mut self, rows: Range<u32>, fields: Fields, bytes: &[u8]) -> Option<()> {
        if rows.start > rows.end || rows.end > self.height {
            return None;
        }
        let w = self.width as usize;
        let first = rows.start as usize * w;
        let stream = Stream::parse(bytes, rows.len() * w, fields)?;
        for (i, rec) in ones(stream.bits).zip(stream.records.chunks_exact(stream.size)) {
            debug_assert!(self.px(first + i).carries_nothing(), "rows not empty");
            self.set(first + i, &Px::read(rec, fields));
        }
        Some(())
    }

    /// Composite the streams of the same `pixels` pixels from several
    /// films ([`Film::encode_rows`] with `fields`), given front to back,
    /// into one stream appended to `out`: [`Film::composite`] without the
    /// films (no film is built for what only passes through). `None` when
    /// a part is not such a stream.
    pub fn composite_records(
        front_to_back: &[&[u8]],
        pixels: usize,
        fields: Fields,
        how: Composite,
        out: &mut Vec<u8>,
    ) -> Option<()> {
        let size = fields.pixel_bytes();
        let streams = front_to_back
            .iter()
            .map(|b| Stream::parse(b, pixels, fields))
            .collect::<Option<Vec<_>>>()?;
        // Per part, the next record to read.
        let mut next = vec![0usize; streams.len()];
        let bits = out.len();
        out.resize(bits + pixels.div_ceil(8), 0);
        for byte in 0..pixels.div_ceil(8) {
            let mut any = streams.iter().fold(0u8, |a, s| a | s.bits[byte]);
            while any != 0 {
                let bit = any.trailing_zeros();
                any &= any - 1;
                let mut acc = Px::START;
                for (s, at) in streams.iter().zip(&mut next) {
                    if s.bits[byte] >> bit & 1 == 1 {
                        acc.join(&Px::read(&s.records[*at * size..][..size], fields), how);
                        *at += 1;
                    }
                }
                if acc.carries_nothing() {
                    continue;
                }
                out[bits + byte] |= 1 << bit;
                let at = out.len();
                out.resize(at + size, 0);
                acc.write(&mut out[at..], fields);
            }
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Display;
    use crate::trace::RayResult;
    use glam::Vec3;

    #[test]
    fn rows_travel_as_bytes_and_come_back_bit_for_bit() {
        let (w, h) = (7u32, 5u32);
        let mut f = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                if (x + y) % 3 == 0 {
                    continue; // some pixels stay empty (NaN value and depth)
                }
                let v = (x * 10 + y) as f32 * 0.37;
                f.add(
                    x,
                    y,
                    &RayResult {
                        rgba: [v, v * 0.5, 0.1, 0.9],
                        value: f64::from(v) * 1e-3,
                        depth: v + 1.0,
                        samples: x + y,
                        ..RayResult::empty()
                    },
                );
            }
        }
        let fields = Fields::ALL;
        let mut back = Film::new(w, h);
        for rows in [0..2, 2..2, 2..5] {
            let mut bytes = Vec::new();
            f.encode_rows(rows.clone(), fields, &mut bytes);
            let n = rows.len() * w as usize;
            let present = (rows.start..rows.end)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .filter(|&(x, y)| (x + y) % 3 != 0)
                .count();
            assert_eq!(bytes.len(), n.div_ceil(8) + present * fields.pixel_bytes());
            // The wrong number of rows, a record short, a stray bit.
            let mut g = Film::new(w, h);
            let longer = rows.start..rows.end + 1;
            assert!(g.decode_rows(longer, fields, &bytes).is_none());
            if present > 0 {
                let short = &bytes[..bytes.len() - 1];
                assert!(g.decode_rows(rows.clone(), fields, short).is_none());
            }
            if !n.is_multiple_of(8) {
                let mut stray = bytes.clone();
                stray[n.div_ceil(8) - 1] |= 0x80;
                assert!(g.decode_rows(rows.clone(), fields, &stray).is_none());
            }
            back.decode_rows(rows, fields, &bytes).unwrap();
        }
        assert!(back.decode_rows(4..6, fields, &[]).is_none());
        let bits = |f: &Film| -> Vec<u64> {
            f.rgba
                .iter()
                .flat_map(|p| p.map(f64::to_bits))
                .chain(f.value.iter().map(|v| v.to_bits()))
                .chain(f.depth.iter().map(|d| u64::from(d.to_bits())))
                .chain(f.count.iter().chain(&f.samples).map(|&c| u64::from(c)))
                .collect()
        };
        assert_eq!((back.width, back.height), (w, h));
        assert_eq!(bits(&back), bits(&f));
        // Only what a composite reads: the rest comes back empty, and the
        // composite of the decoded film is the composite of the film.
        for how in [
            Composite::Over,
            Composite::FirstHit,
            Composite::Max,
            Composite::Min,
            Composite::Sum,
        ] {
            let fields = Fields::for_composite(how);
            let n = (w * h) as usize;
            let mut bytes = Vec::new();
            f.encode_rows(0..h, fields, &mut bytes);
            let mut g = Film::new(w, h);
            g.decode_rows(0..h, fields, &bytes).unwrap();
            let (a, b) = (Film::composite(&[&f], how), Film::composite(&[&g], how));
            assert_eq!(bits(&a), bits(&b), "{how:?}");
            // Compositing records is compositing films: a film over itself.
            let mut joined = Vec::new();
            Film::composite_records(&[&bytes, &bytes], n, fields, how, &mut joined).unwrap();
            let mut from_records = Film::new(w, h);
            from_records.decode_rows(0..h, fields, &joined).unwrap();
            let mut again = Vec::new();
            Film::composite(&[&g, &g], how).encode_rows(0..h, fields, &mut again);
            assert_eq!(joined, again, "{how:?}");
            let cut = &bytes[..bytes.len() - 1];
            assert!(Film::composite_records(&[&bytes, cut], n, fields, how, &mut joined).is_none());
            assert!(
                Film::composite_records(&[&bytes, &bytes], n + 8, fields, how, &mut joined)
                    .is_none()
            );
        }
    }

    /// A pixel whose ray brought nothing travels as its bit alone and
    /// resolves, and composites, as it was.
    #[test]
    fn empty_rays_travel_as_bits() {
        let mut f = Film::new(16, 2);
        for y in 0..2 {
            for x in 0..16 {
                let r = if x == 5 && y == 1 {
                    RayResult {
                        rgba: [0.5, 0.25, 0.0, 0.75],
                        value: 3.0,
                        depth: 2.0,
                        samples: 4,
                        ..RayResult::empty()
                    }
                } else {
                    RayResult::empty()
                };
                f.add(x, y, &r);
            }
        }
        let fields = Fields::ALL;
        let mut bytes = Vec::new();
        f.encode_rows(0..2, fields, &mut bytes);
        assert_eq!(bytes.len(), 4 + fields.pixel_bytes());
        let mut g = Film::new(16, 2);
        g.decode_rows(0..2, fields, &bytes).unwrap();
        let frame = |f: &Film| {
            let r = f.resolve(Display::Colour, Vec3::new(0.1, 0.2, 0.3));
            (r.rgba, r.samples)
        };
        assert_eq!(frame(&g), frame(&f));
        for how in [Composite::Over, Composite::Max, Composite::Sum] {
            let (a, b) = (
                Film::composite(&[&f, &f], how),
                Film::composite(&[&g, &g], how),
            );
            let show = |x: &Film| {
                x.resolve(Display::Grey { lo: 0.0, hi: 9.0 }, Vec3::ZERO)
                    .rgba
            };
            assert_eq!(show(&a), show(&b), "{how:?}");
        }
    }
}
