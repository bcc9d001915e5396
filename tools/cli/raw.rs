//! The options that tell the tools how to read a headerless raw volume.

use crate::args::{dims3, sample_type};
use volcore::{Dims, SampleType};
use volformats::raw::RawSpec;

/// Raw-volume options, shared by the tools that read volumes
/// (`#[command(flatten)]`). Without `--raw-dims`, a raw file's shape comes
/// from its name (`NAME_XxYxZ_TYPE.raw`).
#[derive(clap::Args, Debug, Clone)]
pub struct RawArgs {
    /// Raw input: dimensions X,Y,Z (otherwise taken from NAME_XxYxZ_TYPE.raw).
    #[arg(long, value_parser = dims3)]
    pub raw_dims: Option<[u64; 3]>,
    /// Raw input: sample type (u8, u16, i16, f32).
    #[arg(long, default_value = "u8", value_parser = sample_type)]
    pub raw_type: SampleType,
    /// Raw input: samples are big-endian.
    #[arg(long)]
    pub raw_big_endian: bool,
    /// Raw input: bytes to skip before the samples.
    #[arg(long, default_value_t = 0)]
    pub raw_skip: u64,
}

impl RawArgs {
    /// The raw-file interpretation given on the command line, if
    /// `--raw-dims` was; the error names the option.
    pub fn spec(&self) -> Result<Option<RawSpec>, String> {
        let Some([x, y, z]) = self.raw_dims else {
            return Ok(None);
        };
        Ok(Some(RawSpec {
            dims: Dims::new(x, y, z).map_err(|e| format!("--raw-dims: {e}"))?,
            sample_type: self.raw_type,
            big_endian: self.raw_big_endian,
            skip: self.raw_skip,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        raw: RawArgs,
    }

    #[test]
    fn spec_only_with_dims() {
        let cli = Cli::parse_from(["t"]);
        assert!(cli.raw.spec().unwrap().is_none());
        let cli = Cli::parse_from([
            "t",
            "--raw-dims",
            "4,5,6",
            "--raw-type",
            "u16",
            "--raw-skip",
            "8",
        ]);
        let spec = cli.raw.spec().unwrap().unwrap();
        assert_eq!((spec.dims.x, spec.dims.y, spec.dims.z), (4, 5, 6));
        assert_eq!(
            (spec.sample_type, spec.skip, spec.big_endian),
            (SampleType::U16, 8, false)
        );
        assert!(Cli::try_parse_from(["t", "--raw-type", "u12"]).is_err());
    }
}
