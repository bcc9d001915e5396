//! Which [`Target`] an output path and the output options ask for: the
//! one set of rules `vol-convert -o` and any other writer (the Python
//! package's `save`) follow, with the same usage errors.

use super::writers::Target;
use crate::omezarr::{Downsample, Ngff};
use crate::thesis::ThesisLayout;
use crate::vvol::part;
use std::io::Write;
use std::path::{Path, PathBuf};
use volcore::{Compression, Shard};

/// A requested layout: sliced, or bricked with edge B.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutArg {
    /// x-fastest slices.
    Sliced,
    /// Cubic bricks of this edge.
    Bricked(u32),
}

impl LayoutArg {
    /// The name it is parsed from: `sliced` or `bricked:B`.
    pub fn name(self) -> String {
        match self {
            LayoutArg::Sliced => "sliced".into(),
            LayoutArg::Bricked(b) => format!("bricked:{b}"),
        }
    }
}

/// Parse `sliced` or `bricked:B` (`bricked` alone means B = 32).
pub fn layout(s: &str) -> Result<LayoutArg, String> {
    match s.split_once(':') {
        None if s == "sliced" => Ok(LayoutArg::Sliced),
        None if s == "bricked" => Ok(LayoutArg::Bricked(32)),
        Some(("bricked", b)) => {
            let b: u32 = b
                .parse()
                .map_err(|_| format!("'{s}': brick edge must be a whole number"))?;
            if !(volcore::brick::MIN_BRICK..=volcore::brick::MAX_BRICK).contains(&b) {
                return Err(format!(
                    "'{s}': brick edge must be {}..={}",
                    volcore::brick::MIN_BRICK,
                    volcore::brick::MAX_BRICK
                ));
            }
            Ok(LayoutArg::Bricked(b))
        }
        _ => Err(format!("'{s}' is not sliced or bricked:B")),
    }
}

/// Parse `none`, `zstd` or `zstd:LEVEL` (level -7..=22; default 3).
pub fn compression(s: &str) -> Result<Compression, String> {
    match s.split_once(':') {
        None if s == "none" => Ok(Compression::None),
        None if s == "zstd" => Ok(Compression::Zstd(3)),
        Some(("zstd", l)) => {
            let l: i32 = l
                .parse()
                .map_err(|_| format!("'{s}': zstd level must be a whole number"))?;
            if !(-7..=22).contains(&l) {
                return Err(format!("'{s}': zstd level must be -7..=22"));
            }
            Ok(Compression::Zstd(l))
        }
        _ => Err(format!("'{s}' is not none, zstd or zstd:LEVEL")),
    }
}

/// The `--compress` choices of an output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CompressArg {
    /// Per-brick compression of a .vvol (or none).
    Vvol(Compression),
    /// gzip/zlib for the header formats, at this deflate level (1-9).
    Gzip(u32),
}

impl CompressArg {
    /// Parse `none`, `zstd`, `zstd:LEVEL`, `gzip` or `gzip:LEVEL` (1 the
    /// fastest, 9 the smallest; `gzip` is level 6).
    pub fn parse(s: &str) -> Result<CompressArg, String> {
        if s == "gzip" {
            return Ok(CompressArg::Gzip(crate::gzip::DEFAULT_LEVEL));
        }
        if let Some(l) = s.strip_prefix("gzip:") {
            return match l.parse::<u32>() {
                Ok(l) if (1..=9).contains(&l) => Ok(CompressArg::Gzip(l)),
                _ => Err(format!("'{s}': gzip level must be 1..=9")),
            };
        }
        compression(s)
            .map(CompressArg::Vvol)
            .map_err(|e| format!("{e}, gzip or gzip:LEVEL"))
    }

    /// The name it is parsed from.
    pub fn name(self) -> String {
        match self {
            CompressArg::Vvol(Compression::None) => "none".into(),
            CompressArg::Vvol(Compression::Zstd(l)) => format!("zstd:{l}"),
            CompressArg::Gzip(l) => format!("gzip:{l}"),
        }
    }
}

/// How to write an output, besides its path (vol-convert's `--layout`,
/// `--compress`, `--pyramid`, `--downsample`, `--ngff`, `--shard`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputOptions {
    /// Sliced or bricked.
    pub layout: LayoutArg,
    /// Compression.
    pub compress: CompressArg,
    /// OME-Zarr pyramid levels (1: none).
    pub pyramid: u32,
    /// How each OME-Zarr level is made from the one above.
    pub downsample: Downsample,
    /// The OME-Zarr version asked for (`None`: the default, 0.4).
    pub ngff: Option<Ngff>,
    /// Write one shard's part.
    pub shard: Option<Shard>,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            layout: LayoutArg::Sliced,
            compress: CompressArg::Vvol(Compression::None),
            pyramid: 1,
            downsample: Downsample::Mean,
            ngff: None,
            shard: None,
        }
    }
}

/// A usage error about the output `path`: `path: message`.
fn usage_at(path: &Path, msg: impl std::fmt::Display) -> String {
    format!("{}: {msg}", path.display())
}

impl Target {
    /// The target `out` names with options `o`, or the usage error (one
    /// line, naming `out`) when they do not go together. `stdout` is where
    /// `-` writes (a sliced `.vvol` stream); without it `-` is refused.
    pub fn for_output(
        out: &Path,
        o: &OutputOptions,
        stdout: Option<Box<dyn Write + Send>>,
    ) -> Result<Target, String> {
        let text = out.to_string_lossy();
        let ext = out
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        // A file of that name is refused when checked, as not a directory.
        let zarr_out = crate::omezarr::is_zarr(out);
        if let Some(shard) = o.shard.filter(|_| !zarr_out) {
            if ext != part::EXTENSION {
                return Err(usage_at(
                    out,
                    "with --shard the output is one part of a .vvol: name it NAME.vpart (then vol-convert --merge the parts -o NAME.vvol)",
                ));
            }
            let compression = match o.compress {
                CompressArg::Vvol(c) => c,
                CompressArg::Gzip(_) => {
                    return Err(usage_at(
                        out,
                        "--compress gzip does not apply to .vvol parts",
                    ))
                }
            };
            let brick = match o.layout {
                LayoutArg::Sliced if compression != Compression::None => {
                    return Err(usage_at(
                        out,
                        "--compress needs --layout bricked:B (compression is per brick)",
                    ))
                }
                LayoutArg::Sliced => None,
                LayoutArg::Bricked(b) => Some(b),
            };
            return Ok(Target::VvolPart {
                path: out.to_path_buf(),
                brick,
                compression,
                shard,
            });
        }
        if ext == part::EXTENSION {
            return Err(usage_at(
                out,
                ".vpart files are the parts of a sharded conversion: add --shard K/N",
            ));
        }
        if !zarr_out {
            if o.pyramid > 1 {
                return Err(usage_at(
                    out,
                    "--pyramid applies to OME-Zarr output (NAME.ome.zarr)",
                ));
            }
            if o.ngff.is_some() {
                return Err(usage_at(
                    out,
                    "--ngff applies to OME-Zarr output (NAME.ome.zarr)",
                ));
            }
        }
        let gzip = match o.compress {
            CompressArg::Gzip(l) => Some(l),
            CompressArg::Vvol(_) => None,
        };
        if let Some(t) = Target::headed(out, gzip.is_some()) {
            let t = t.with_deflate_level(gzip.unwrap_or(crate::gzip::DEFAULT_LEVEL));
            if o.layout != LayoutArg::Sliced {
                return Err(usage_at(
                    out,
                    "NIfTI, NRRD and MetaImage output is sliced only: drop --layout",
                ));
            }
            if matches!(o.compress, CompressArg::Vvol(Compression::Zstd(_))) {
                return Err(usage_at(
                    out,
                    "--compress zstd applies to bricked .vvol output: use --compress gzip",
                ));
            }
            return Ok(t);
        }
        if gzip.is_some() {
            return Err(usage_at(
                out,
                "--compress gzip applies to NIfTI, NRRD and MetaImage output",
            ));
        }
        let compress = match o.compress {
            CompressArg::Vvol(c) => c,
            CompressArg::Gzip(_) => Compression::None,
        };
        let sliced_only = |what: &str| -> Result<(), String> {
            if o.layout != LayoutArg::Sliced {
                return Err(usage_at(
                    out,
                    format!("{what} output is sliced only: drop --layout"),
                ));
            }
            Ok(())
        };
        let no_compress = |what: &str| -> Result<(), String> {
            if compress != Compression::None {
                return Err(usage_at(
                    out,
                    format!("--compress applies to bricked .vvol output, not {what}"),
                ));
            }
            Ok(())
        };
        if zarr_out {
            sliced_only("OME-Zarr")?;
            no_compress("OME-Zarr (chunks are zstd)")?;
            return Ok(Target::OmeZarr {
                path: PathBuf::from(text.trim_end_matches('/')),
                levels: o.pyramid,
                downsample: o.downsample,
                ngff: o.ngff.unwrap_or_default(),
                shard: o.shard,
            });
        }
        if text == "-" {
            sliced_only("stdout (a .vvol stream)")?;
            no_compress("a stream")?;
            return match stdout {
                Some(w) => Ok(Target::VvolStream(w)),
                None => Err(usage_at(out, "standard output is not available here")),
            };
        }
        if text.ends_with('/') {
            sliced_only("TIFF directory")?;
            no_compress("TIFF")?;
            return Ok(Target::TiffDir {
                path: out.to_path_buf(),
            });
        }
        match ext.as_str() {
            "vvol" => {
                let brick = match o.layout {
                    LayoutArg::Sliced => None,
                    LayoutArg::Bricked(b) => Some(b),
                };
                if brick.is_none() && compress != Compression::None {
                    return Err(usage_at(
                        out,
                        "--compress needs --layout bricked:B (compression is per brick)",
                    ));
                }
                Ok(Target::Vvol {
                    path: out.to_path_buf(),
                    brick,
                    compression: compress,
                })
            }
            "vol" => {
                no_compress(".vol")?;
                let layout = match o.layout {
                    LayoutArg::Sliced => ThesisLayout::Sliced,
                    LayoutArg::Bricked(b) if b <= 255 => ThesisLayout::Bricked(b as u8),
                    LayoutArg::Bricked(b) => {
                        return Err(usage_at(
                            out,
                            format!("the .vol format takes bricks up to 255, not {b}"),
                        ))
                    }
                };
                Ok(Target::Thesis {
                    path: out.to_path_buf(),
                    layout,
                })
            }
            "raw" => {
                sliced_only(".raw")?;
                no_compress(".raw")?;
                Ok(Target::Raw {
                    path: out.to_path_buf(),
                })
            }
            "tif" | "tiff" => {
                sliced_only("TIFF")?;
                no_compress("TIFF")?;
                Ok(Target::Tiff {
                    path: out.to_path_buf(),
                })
            }
            _ => Err(usage_at(
                out,
                "unknown output type: use .vvol, .vol, .raw, .tif, .nii, .nii.gz, .hdr, .nrrd, .nhdr, .mha, .mhd, .ome.zarr, a directory ending in /, or -",
            )),
        }
    }
}
