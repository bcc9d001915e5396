//! ImageJ raw stacks: the files past 4 GiB that ImageJ writes as one
//! directory with every image back to back after it, read as the raw
//! data they are.

use super::axes::imagej_unit;
use super::read::{open_file, page_info, spacing_of, tiff_err};
use crate::error::Error;
use crate::reader::{At, CResult, ConvertError};
use crate::slice::SliceType;
use ::tiff::tags::Tag;
use std::path::Path;
use volcore::{Dims, LengthUnit};

/// Where the samples of an ImageJ "hyperstack" file lie when ImageJ wrote
/// only the first directory and stored all images back to back after it
/// (what ImageJ does for stacks past 4 GiB, and what its description's
/// `images=N` announces).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageJRaw {
    /// Dimensions: the first page's width and height, `images` slices.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SliceType,
    /// Byte offset of the first sample.
    pub offset: u64,
    /// The file's byte order.
    pub big_endian: bool,
    /// Spacing from the tags and description.
    pub spacing: Option<[f32; 3]>,
    /// The description's unit of length.
    pub unit: LengthUnit,
}

/// Detect an ImageJ file whose images follow each other without
/// directories of their own; `None` for every other TIFF.
pub fn imagej_raw(path: &Path) -> CResult<Option<ImageJRaw>> {
    let mut d = open_file(path, None)?;
    if d.more_images() {
        return Ok(None);
    }
    let desc = match d.find_tag(Tag::ImageDescription) {
        Ok(Some(v)) => v.into_string().unwrap_or_default(),
        _ => return Ok(None),
    };
    if !desc.starts_with("ImageJ") {
        return Ok(None);
    }
    let images: u64 = desc
        .lines()
        .find_map(|l| l.trim().strip_prefix("images="))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(1);
    if images <= 1 {
        return Ok(None);
    }
    let page = page_info(&mut d).at(path)?;
    let compression = d
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(tiff_err)
        .at(path)?
        .unwrap_or(1);
    if compression != 1 || page.channels != 1 {
        return Err(ConvertError::new(
            path,
            Error::invalid(format!(
                "ImageJ stack of {images} images with one directory must be uncompressed and single-channel"
            )),
        ));
    }
    let sample_type = page.sample_type().map_err(Error::invalid).at(path)?;
    if page.format == 2 && page.bits == 8 {
        return Err(ConvertError::new(
            path,
            Error::invalid("signed 8-bit ImageJ stacks are not supported"),
        ));
    }
    let offset = match d.find_tag(Tag::StripOffsets).map_err(tiff_err).at(path)? {
        Some(v) => v
            .into_u64_vec()
            .map_err(tiff_err)
            .at(path)?
            .first()
            .copied()
            .unwrap_or(0),
        None => 0,
    };
    let dims = Dims::new(page.width as u64, page.height as u64, images).at(path)?;
    let big_endian = matches!(d.byte_order(), ::tiff::tags::ByteOrder::BigEndian);
    let spacing = spacing_of(&mut d, None);
    Ok(Some(ImageJRaw {
        dims,
        sample_type,
        offset,
        big_endian,
        spacing,
        unit: imagej_unit(&desc),
    }))
}
