//! The options that tell the tools how to read a headerless raw volume:
//! [`volformats::raw::RawSpec`] itself, flattened into each tool's
//! command line (`--raw-dims`, `--raw-type`, `--raw-endian`, `--raw-skip`),
//! so every tool reads raw input the same way.

pub use volformats::raw::RawSpec;

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use volformats::convert::SliceType;
    use volformats::raw::Endian;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        raw: RawSpec,
    }

    #[test]
    fn one_option_set() {
        let cli = Cli::parse_from(["t"]);
        assert!(!cli.raw.is_given());
        let cli = Cli::parse_from([
            "t",
            "--raw-dims",
            "4,5,6",
            "--raw-type",
            "int32",
            "--raw-skip",
            "8",
            "--raw-endian",
            "big",
        ]);
        let spec = cli.raw;
        let d = spec.dims.unwrap();
        assert_eq!((d.x, d.y, d.z), (4, 5, 6));
        assert_eq!(
            (spec.sample_type, spec.skip, spec.endian),
            (Some(SliceType::I32), 8, Endian::Big)
        );
        assert!(Cli::try_parse_from(["t", "--raw-type", "u12"]).is_err());
        assert!(Cli::try_parse_from(["t", "--raw-dims", "0,1,1"]).is_err());
    }
}
