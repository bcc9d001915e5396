//! TIFF stacks: reading slices (a directory of single-page files, a glob, a
//! list file, or one multipage TIFF or BigTIFF) and writing them back (one
//! multipage file, or a directory of single-page files), through the
//! `tiff` crate.
//!
//! Supported samples: 8-bit (unsigned; signed is widened to `i16`), 16 and
//! 32-bit unsigned and signed, 32 and 64-bit float; every compression
//! (zstd included), predictor, strip and tile layout and byte order the
//! crate decodes. Colour or multi-band slices are reduced to one channel
//! only on request ([`ChannelSel`]). ImageJ hyperstacks and OME-TIFF files
//! with several channels or time points give one 3D stack, picked with
//! `--channel` and `--time-point` ([`axes`]); OME-XML `PhysicalSizeX/Y/Z` give
//! the spacing.
//!
//! ImageJ stacks past 4 GiB, which ImageJ writes as one directory and all
//! images back to back (`images=N` in the description), are read as the
//! raw data they are.
//!
//! Spacing: x and y are the inverse of the XResolution and YResolution
//! tags (in whatever unit the file uses), z the `spacing=` of an ImageJ
//! description, or the x spacing when there is none (so that a stack
//! keeps its proportions whatever dpi its writer put in). Written files
//! carry the same tags, so spacing survives a round trip and Fiji shows
//! it. The unit of length is ImageJ's `unit=` or OME's
//! `PhysicalSizeXUnit` (micrometres when absent, per the OME schema);
//! plain TIFF states none (its resolution unit is for printing).

pub mod axes;
mod ifd_check;
mod imagej_raw;
mod read;
mod slice_files;

pub use imagej_raw::{imagej_raw, ImageJRaw};
pub use read::{open_files, stacks, PageInfo, TiffStackReader};
pub use slice_files::{glob_match, list_dir, list_file, list_glob, natural_cmp};

use ::tiff::encoder::colortype;
use ::tiff::encoder::{Rational, TiffEncoder, TiffKind};
use ::tiff::tags::{ResolutionUnit, Tag};
use std::io::{Seek, Write};
use volcore::{LengthUnit, Sample, SampleType};

/// How to turn colour or multi-band slices into one channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ChannelSel {
    /// Only single-channel slices are accepted.
    #[default]
    Single,
    /// Take this channel (0-based).
    Channel(u16),
    /// Rec. 601 luma of the first three channels: 0.299 R + 0.587 G + 0.114 B.
    Luma,
}

/// The best `n / d` approximation of `v` (positive, finite) with `n` and
/// `d` fitting in `u32` (continued fractions).
pub fn rational(v: f64) -> (u32, u32) {
    if !(v.is_finite() && v > 0.0) {
        return (1, 1);
    }
    let max = u32::MAX as f64;
    if v >= max {
        return (u32::MAX, 1);
    }
    let (mut h0, mut h1) = (0f64, 1f64);
    let (mut k0, mut k1) = (1f64, 0f64);
    let mut x = v;
    let mut best = (v.round().max(1.0), 1.0);
    for _ in 0..64 {
        let a = x.floor();
        let h2 = a * h1 + h0;
        let k2 = a * k1 + k0;
        if h2 > max || k2 > max {
            break;
        }
        best = (h2, k2);
        (h0, h1, k0, k1) = (h1, h2, k1, k2);
        let f = x - a;
        if f < 1e-15 {
            break;
        }
        x = 1.0 / f;
    }
    if best.0 < 1.0 {
        // v below 1 / u32::MAX
        return (1, u32::MAX);
    }
    (best.0 as u32, best.1 as u32)
}

/// Write one page (a z slice) of `width × height` samples, with resolution
/// tags for the x/y spacing and an optional image description.
pub fn write_page<T: Sample, W: Write + Seek, K: TiffKind>(
    enc: &mut TiffEncoder<W, K>,
    width: u32,
    height: u32,
    data: &[T],
    spacing: [f32; 3],
    description: Option<&str>,
) -> Result<(), String> {
    macro_rules! page {
        ($c:ty, $inner:ty) => {{
            let mut img = enc
                .new_image::<$c>(width, height)
                .map_err(|e| e.to_string())?;
            let (xn, xd) = rational(1.0 / spacing[0] as f64);
            let (yn, yd) = rational(1.0 / spacing[1] as f64);
            img.resolution_unit(ResolutionUnit::None);
            img.x_resolution(Rational { n: xn, d: xd });
            img.y_resolution(Rational { n: yn, d: yd });
            if let Some(d) = description {
                img.encoder()
                    .write_tag(Tag::ImageDescription, d)
                    .map_err(|e| e.to_string())?;
            }
            let samples: &[$inner] = bytemuck::cast_slice(data);
            img.write_data(samples).map_err(|e| e.to_string())
        }};
    }
    match T::TYPE {
        SampleType::U8 => page!(colortype::Gray8, u8),
        SampleType::U16 => page!(colortype::Gray16, u16),
        SampleType::I16 => page!(colortype::GrayI16, i16),
        SampleType::F32 => page!(colortype::Gray32Float, f32),
        SampleType::F64 => page!(colortype::Gray64Float, f64),
    }
}

/// The ImageJ-style description volkit writes on the first page: it gives
/// the z spacing and the unit of length to Fiji and back to volkit
/// (`micron` for µm, as ImageJ spells it; `unit` when none is stated).
pub fn imagej_description(spacing_z: f32, unit: LengthUnit) -> String {
    let unit = match unit {
        LengthUnit::Unknown => "unit",
        LengthUnit::Micrometer => "micron",
        LengthUnit::Angstrom => "angstrom",
        other => other.symbol(),
    };
    format!("ImageJ=1.11a\nspacing={spacing_z}\nunit={unit}\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rationals_round_trip_spacing() {
        for s in [1.0f32, 0.5, 0.3, 2.0, 0.001, 1234.5, 0.123456] {
            let (n, d) = rational(1.0 / s as f64);
            let back = (d as f64 / n as f64) as f32;
            assert_eq!(back, s, "{s}: {n}/{d}");
        }
        assert_eq!(rational(1.0), (1, 1));
        assert_eq!(rational(f64::NAN), (1, 1));
    }
}
