//! The input-selection flags every tool that opens a volume takes:
//! [`volformats::Selection`] itself (`--raw-dims`, `--raw-type`,
//! `--raw-endian`, `--raw-skip`, `--series`, `--channel`,
//! `--time-point`, `--level`), flattened into each tool's command line, so every
//! tool reads an input the same way and every reader's error names flags
//! the tool has.

use std::path::Path;
pub use volformats::raw::RawSpec;
use volformats::ReadOptions;
pub use volformats::Selection;

/// The read options `sel` asks for of the `inputs` they will read; the
/// old `--time` is a usage error (exit 2) naming `--time-point` and
/// `--seconds`, and so is a selection an input cannot have (`--level` of
/// anything but an OME-Zarr: see [`volformats::open::check_applies`]).
pub fn read_options(sel: &Selection, inputs: &[&Path]) -> anyhow::Result<ReadOptions> {
    let opts = sel.read_options().map_err(crate::usage)?;
    for p in inputs {
        volformats::open::check_applies(p, &opts).map_err(|e| crate::usage(e.to_string()))?;
    }
    Ok(opts)
}

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

    #[derive(Parser)]
    struct Tool {
        #[command(flatten)]
        input: Selection,
    }

    #[test]
    fn selection_flags_parse_and_the_old_time_is_refused() {
        let t = Tool::parse_from(["t", "--channel", "2", "--time-point", "3", "--series", "4"]);
        let o = read_options(&t.input, &[]).unwrap();
        assert_eq!((o.time, o.series.as_deref()), (Some(3), Some("4")));
        let t = Tool::parse_from(["t", "--time", "3"]);
        let e = read_options(&t.input, &[]).unwrap_err().to_string();
        assert!(
            e.contains("--time-point T") && e.contains("--seconds S"),
            "{e}"
        );
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
