//! Pixel decoding: one slice's pixel data decoded (RLE Lossless here,
//! every other transfer syntax through `dicom-pixeldata`), masked to its
//! stored bits, rescaled and widened to the series' sample type.

use super::bad;
use super::header::{SliceHeader, Tile};
use crate::reader::CResult;
use crate::slice::{SliceData, SliceType};
use dicom_dictionary_std::tags;
use dicom_object::DefaultDicomObject;
use dicom_pixeldata::PixelDecoder;

pub(super) fn stored_type(bits: u16, signed: bool) -> SliceType {
    match (bits, signed) {
        (8, false) => SliceType::U8,
        (8, true) => SliceType::I8,
        (16, false) => SliceType::U16,
        (16, true) => SliceType::I16,
        (_, false) => SliceType::U32,
        (_, true) => SliceType::I32,
    }
}

/// The type that holds both (for slices rescaled differently).
pub(super) fn widest(a: SliceType, b: SliceType) -> SliceType {
    if a == b {
        a
    } else if a.is_integer() && b.is_integer() {
        SliceType::I32
    } else {
        SliceType::F64
    }
}

/// The file slice `s` is read from, opened (its pixel data in memory).
pub(super) fn open(s: &SliceHeader) -> CResult<DefaultDicomObject> {
    dicom_object::open_file(&s.path)
        .map_err(|e| bad(&s.path, format!("not a readable DICOM file: {e}")))
}

/// The decoded bytes of the frame slice `s` lies in (the whole frame, a
/// mosaic's tiles and all) from its opened file `obj`, as the file stores
/// its samples.
pub(super) fn frame_bytes(s: &SliceHeader, obj: &DefaultDicomObject) -> CResult<Vec<u8>> {
    let frame = s.pixels.frame;
    let syntax = obj.meta().transfer_syntax().trim_end_matches('\0');
    if syntax == RLE_LOSSLESS {
        // Decoded here: dicom-rs's RLE decoder panics on damaged
        // segment tables and short segments. RLE keeps one fragment per
        // frame.
        let fragment = obj
            .element(tags::PIXEL_DATA)
            .ok()
            .and_then(|e| e.value().fragments())
            .and_then(|f| f.get(frame as usize))
            .ok_or_else(|| {
                bad(
                    &s.path,
                    format!("RLE pixel data without a fragment for frame {frame}"),
                )
            })?;
        let (rows, cols) = frame_size(obj, s);
        let t = stored_type(s.bits_allocated, s.signed);
        return decode_rle(fragment, rows * cols, t.size())
            .map_err(|e| bad(&s.path, format!("cannot decode the RLE pixel data: {e}")));
    }
    if is_jpeg_ls(syntax) {
        let t = stored_type(s.bits_allocated, s.signed);
        let (rows, cols) = frame_size(obj, s);
        let data = frame_fragments(obj, frame)
            .map_err(|e| bad(&s.path, format!("JPEG-LS pixel data: {e}")))?;
        return decode_jpeg_ls(&data, rows, cols, t.size()).map_err(|e| {
            bad(
                &s.path,
                format!("cannot decode frame {frame} of the JPEG-LS pixel data: {e}"),
            )
        });
    }
    let px = obj.decode_pixel_data_frame(frame).map_err(|e| {
        bad(
            &s.path,
            format!("cannot decode frame {frame} of the pixel data: {e}"),
        )
    })?;
    px.frame_data(0).map(<[u8]>::to_vec).map_err(|e| {
        bad(
            &s.path,
            format!("cannot decode frame {frame} of the pixel data: {e}"),
        )
    })
}

/// The frame's Rows and Columns as the file states them (a mosaic's whole
/// grid; the slice's own size otherwise).
fn frame_size(obj: &DefaultDicomObject, s: &SliceHeader) -> (usize, usize) {
    let get = |tag| obj.get(tag).and_then(|e| e.to_int::<usize>().ok());
    match s.pixels.tile {
        Some(t) => (get(tags::ROWS).unwrap_or(0), t.frame_cols as usize),
        None => (s.rows as usize, s.cols as usize),
    }
}

/// Slice `s` cut from its decoded `frame` ([`frame_bytes`]), as samples of
/// type `out` (the series' type).
pub(super) fn slice_from_frame(
    s: &SliceHeader,
    frame: &[u8],
    out: SliceType,
) -> CResult<SliceData> {
    let t = stored_type(s.bits_allocated, s.signed);
    let n = s.rows as usize * s.cols as usize;
    let tiled;
    let bytes: &[u8] = match s.pixels.tile {
        Some(tile) => {
            tiled = cut_tile(frame, tile, s.rows as usize, s.cols as usize, t.size()).ok_or_else(
                || {
                    bad(
                        &s.path,
                        format!(
                            "mosaic frame of {} bytes holds no tile {} of {}x{} pixels",
                            frame.len(),
                            tile.index,
                            s.cols,
                            s.rows
                        ),
                    )
                },
            )?;
            &tiled
        }
        None => frame,
    };
    if bytes.len() < n * t.size() {
        return Err(bad(
            &s.path,
            format!(
                "pixel data holds {} bytes, {}x{} {}-bit pixels need {}",
                bytes.len(),
                s.cols,
                s.rows,
                s.bits_allocated,
                n * t.size()
            ),
        ));
    }
    let mut d = SliceData::from_bytes(t, &bytes[..n * t.size()], false);
    mask_bits(&mut d, s.bits_stored);
    let d = if s.rescale.is_identity() {
        d
    } else {
        s.rescale.apply(&d)
    };
    Ok(to_type(d, out))
}

/// Tile `tile` of a mosaic `frame` (rows of `tile.frame_cols` samples of
/// `size` bytes), each tile `rows` x `cols`: its rows copied out, or
/// `None` when the frame is too small to hold it.
fn cut_tile(frame: &[u8], tile: Tile, rows: usize, cols: usize, size: usize) -> Option<Vec<u8>> {
    let across = tile.across as usize;
    let (ty, tx) = (
        tile.index as usize / across.max(1),
        tile.index as usize % across.max(1),
    );
    let stride = (tile.frame_cols as usize).checked_mul(size)?;
    let row_bytes = cols.checked_mul(size)?;
    if across == 0 || across.checked_mul(row_bytes)? > stride {
        return None;
    }
    let mut out = Vec::with_capacity(rows.checked_mul(row_bytes)?);
    for r in 0..rows {
        let y = ty.checked_mul(rows)?.checked_add(r)?;
        let start = y.checked_mul(stride)?.checked_add(tx * row_bytes)?;
        out.extend_from_slice(frame.get(start..start.checked_add(row_bytes)?)?);
    }
    Some(out)
}

/// Whether slices of transfer syntax `uid` decode, where dicom-rs's
/// registry says whether it decodes them (`registry_decodes`): JPEG-LS
/// is decoded here, whatever the registry says.
pub(super) fn decodes(uid: &str, registry_decodes: bool) -> bool {
    registry_decodes || is_jpeg_ls(uid)
}

/// Whether `uid` is a JPEG-LS transfer syntax (lossless, or
/// near-lossless).
fn is_jpeg_ls(uid: &str) -> bool {
    matches!(
        uid.trim_end_matches('\0'),
        "1.2.840.10008.1.2.4.80" | "1.2.840.10008.1.2.4.81"
    )
}

/// The encapsulated bytes of `frame`: all fragments of a single-frame
/// image; one fragment per frame when there are as many as frames; else
/// the fragments the Basic Offset Table puts in the frame.
fn frame_fragments(obj: &DefaultDicomObject, frame: u32) -> Result<Vec<u8>, String> {
    let pixel_data = obj
        .element(tags::PIXEL_DATA)
        .map_err(|_| "no pixel data".to_string())?
        .value();
    let fragments = pixel_data
        .fragments()
        .ok_or("pixel data is not encapsulated")?;
    let frames = obj
        .get(tags::NUMBER_OF_FRAMES)
        .and_then(|e| e.to_int::<u32>().ok())
        .unwrap_or(1)
        .max(1);
    let k = frame as usize;
    if frames == 1 {
        return Ok(fragments.concat());
    }
    if fragments.len() == frames as usize {
        return fragments
            .get(k)
            .cloned()
            .ok_or_else(|| format!("no fragment for frame {frame}"));
    }
    let table = pixel_data.offset_table().unwrap_or(&[]);
    if table.len() != frames as usize || k >= table.len() {
        return Err(format!(
            "{} fragments for {frames} frames and no offset table to tell them apart",
            fragments.len()
        ));
    }
    // Offsets count from the first fragment's item tag; each fragment
    // takes an 8-byte item header besides its bytes.
    let start = u64::from(table[k]);
    let end = table.get(k + 1).map_or(u64::MAX, |&e| u64::from(e));
    let mut at = 0u64;
    let mut out = Vec::new();
    for f in fragments {
        if at >= start && at < end {
            out.extend_from_slice(f);
        }
        at = at.saturating_add(8 + f.len() as u64);
    }
    if out.is_empty() {
        return Err(format!(
            "the offset table puts no fragment in frame {frame}"
        ));
    }
    Ok(out)
}

/// Decode one JPEG-LS frame of `rows` x `cols` grey samples of `size`
/// bytes into little-endian samples.
fn decode_jpeg_ls(data: &[u8], rows: usize, cols: usize, size: usize) -> Result<Vec<u8>, String> {
    let w = u32::try_from(cols).map_err(|_| "too wide".to_string())?;
    let h = u32::try_from(rows).map_err(|_| "too tall".to_string())?;
    let (samples, _, _) =
        jpegls::decode(&without_fill_before_eoi(data), w, h).map_err(|e| e.to_string())?;
    match size {
        1 => samples
            .iter()
            .map(|&v| u8::try_from(v).map_err(|_| format!("sample {v} in 8-bit pixel data")))
            .collect(),
        2 => Ok(samples.iter().flat_map(|v| v.to_le_bytes()).collect()),
        _ => Err("JPEG-LS holds at most 16-bit samples".into()),
    }
}

/// `data` with the fill bytes (0xFF) JPEG allows before a marker removed
/// from before its closing EOI (DCMTK pads its JPEG-LS fragments to an
/// even length so): pure_jpegls expects EOI right after the scan. Within
/// a JPEG-LS scan a 0xFF byte is never followed by another, so a run of
/// them before EOI is fill.
fn without_fill_before_eoi(data: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    let end = data.len() - data.iter().rev().take_while(|&&b| b == 0).count();
    let body = &data[..end];
    if !body.ends_with(&[0xFF, 0xD9]) {
        return data.into();
    }
    let fill = body[..end - 2]
        .iter()
        .rev()
        .take_while(|&&b| b == 0xFF)
        .count();
    if fill == 0 {
        return data.into();
    }
    let mut out = body[..end - 2 - fill].to_vec();
    out.extend_from_slice(&[0xFF, 0xD9]);
    out.into()
}

/// The RLE Lossless transfer syntax.
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// Decode one RLE Lossless frame of `pixels` grey samples of `size` bytes
/// into little-endian samples (DICOM PS3.5 annex G): a 64-byte header of
/// the segment count and up to 15 offsets, then one PackBits segment per
/// byte of a sample, the most significant first. Every offset and run is
/// checked against the frame.
fn decode_rle(frame: &[u8], pixels: usize, size: usize) -> Result<Vec<u8>, String> {
    let word = |i: usize| -> u32 {
        frame
            .get(4 * i..4 * i + 4)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if frame.len() < 64 {
        return Err(format!(
            "a frame of {} bytes has no RLE header",
            frame.len()
        ));
    }
    let segments = word(0) as usize;
    if segments != size {
        return Err(format!(
            "{segments} segments for {}-bit samples (expected {size})",
            size * 8
        ));
    }
    let mut out = vec![0u8; pixels * size];
    for seg in 0..segments {
        let start = word(1 + seg) as usize;
        let end = if seg + 1 < segments {
            word(2 + seg) as usize
        } else {
            frame.len()
        };
        if start < 64 || start > end || end > frame.len() {
            return Err(format!(
                "segment {seg} at bytes {start}..{end} lies outside the {}-byte frame",
                frame.len()
            ));
        }
        // Segment 0 holds the most significant bytes.
        let byte = size - 1 - seg;
        let mut data = &frame[start..end];
        let mut p = 0usize;
        while p < pixels {
            let Some((&h, rest)) = data.split_first() else {
                return Err(format!("segment {seg} ends after {p} of {pixels} samples"));
            };
            data = rest;
            let h = h as i8;
            if h >= 0 {
                let n = h as usize + 1;
                let lit = data
                    .get(..n)
                    .ok_or_else(|| format!("segment {seg} ends inside a literal run"))?;
                for &b in lit.iter().take(pixels - p) {
                    out[p * size + byte] = b;
                    p += 1;
                }
                data = &data[n..];
            } else if h != -128 {
                let n = 1 - h as isize;
                let (&b, rest) = data
                    .split_first()
                    .ok_or_else(|| format!("segment {seg} ends inside a repeat run"))?;
                data = rest;
                for _ in 0..(n as usize).min(pixels - p) {
                    out[p * size + byte] = b;
                    p += 1;
                }
            }
        }
    }
    Ok(out)
}

/// Keep the BitsStored low bits (sign-extended for signed pixels).
fn mask_bits(d: &mut SliceData, bits: u16) {
    macro_rules! unsigned {
        ($v:expr, $w:expr) => {
            if (bits as u32) < $w {
                let m = (1u64 << bits) - 1;
                $v.iter_mut().for_each(|x| *x = (*x as u64 & m) as _);
            }
        };
    }
    macro_rules! signed {
        ($v:expr, $t:ty, $w:expr) => {
            if (bits as u32) < $w {
                let sh = $w - bits as u32;
                $v.iter_mut().for_each(|x| *x = ((*x << sh) as $t) >> sh);
            }
        };
    }
    match d {
        SliceData::U8(v) => unsigned!(v, 8),
        SliceData::U16(v) => unsigned!(v, 16),
        SliceData::U32(v) => unsigned!(v, 32),
        SliceData::I8(v) => signed!(v, i8, 8),
        SliceData::I16(v) => signed!(v, i16, 16),
        SliceData::I32(v) => signed!(v, i32, 32),
        _ => {}
    }
}

/// `d` as type `t` (same values; `t` is at least as wide).
fn to_type(d: SliceData, t: SliceType) -> SliceData {
    if d.sample_type() == t {
        return d;
    }
    let n = d.len();
    match t {
        SliceType::I32 => SliceData::I32((0..n).map(|i| d.value(i) as i32).collect()),
        _ => SliceData::F64((0..n).map(|i| d.value(i)).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_bytes_before_eoi_are_dropped_and_nothing_else() {
        let strip = |b: &[u8]| without_fill_before_eoi(b).into_owned();
        assert_eq!(strip(&[1, 0xFF, 0xFF, 0xD9]), [1, 0xFF, 0xD9]);
        assert_eq!(strip(&[1, 0xFF, 0xFF, 0xFF, 0xD9, 0]), [1, 0xFF, 0xD9]);
        assert_eq!(strip(&[1, 0xFF, 0xD9]), [1, 0xFF, 0xD9]);
        assert_eq!(strip(&[1, 0xFF, 0xD9, 0]), [1, 0xFF, 0xD9, 0]);
        assert_eq!(strip(&[0xFF, 0xD9]), [0xFF, 0xD9]);
        assert_eq!(strip(&[]), Vec::<u8>::new());
        assert_eq!(strip(&[0xFF, 0x00, 0x12]), [0xFF, 0x00, 0x12]);
    }

    #[test]
    fn types_widen_to_hold_every_slice() {
        assert_eq!(widest(SliceType::I32, SliceType::U16), SliceType::I32);
        assert_eq!(widest(SliceType::I32, SliceType::F64), SliceType::F64);
        assert_eq!(widest(SliceType::I16, SliceType::I16), SliceType::I16);
        let mut d = SliceData::I16(vec![0x0fff, 0x0800, 0x07ff]);
        mask_bits(&mut d, 12);
        assert_eq!(d, SliceData::I16(vec![-1, -2048, 2047]));
        let mut d = SliceData::U16(vec![0xf0ff]);
        mask_bits(&mut d, 12);
        assert_eq!(d, SliceData::U16(vec![0x00ff]));
    }

    #[test]
    fn mosaic_tiles_are_cut_row_major_and_bounded() {
        // A 6x4 frame of u8, tiles of 3x2: two across, two down.
        let frame: Vec<u8> = (0..24).collect();
        let tile = |index| Tile {
            index,
            across: 2,
            frame_cols: 6,
        };
        assert_eq!(
            cut_tile(&frame, tile(0), 2, 3, 1),
            Some(vec![0, 1, 2, 6, 7, 8])
        );
        assert_eq!(
            cut_tile(&frame, tile(1), 2, 3, 1),
            Some(vec![3, 4, 5, 9, 10, 11])
        );
        assert_eq!(
            cut_tile(&frame, tile(3), 2, 3, 1),
            Some(vec![15, 16, 17, 21, 22, 23])
        );
        // Past the frame's end, or wider than a row: none.
        assert_eq!(cut_tile(&frame, tile(4), 2, 3, 1), None);
        assert_eq!(cut_tile(&frame, tile(0), 2, 4, 1), None);
        // 16-bit samples: two bytes each.
        let wide: Vec<u8> = (0..48).collect();
        assert_eq!(
            cut_tile(&wide, tile(1), 1, 3, 2),
            Some(vec![6, 7, 8, 9, 10, 11])
        );
    }
}
