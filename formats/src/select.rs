//! What to read from an input that holds more than one volume, or cannot
//! describe itself: the one definition of the input-selection flags every
//! tool that opens a volume takes (`--raw-*`, `--series`, `--channel`,
//! `--time-point`, `--echo`, `--level`), flattened into each tool's command line, so an error
//! that names one of these flags names a flag the tool has.

use crate::open::ReadOptions;
use crate::raw::RawSpec;
use crate::tiff::ChannelSel;

/// The input-selection flags (with the `clap` feature they serialise,
/// under the flags' ids, for vol-render's printed scene).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args, serde::Serialize))]
pub struct Selection {
    /// How to read a headerless raw volume.
    #[cfg_attr(feature = "clap", command(flatten))]
    #[cfg_attr(feature = "clap", serde(flatten))]
    pub raw: RawSpec,
    /// DICOM folder with several series: the series to read, by any ID
    /// vol-info lists, series number, SeriesInstanceUID, or a unique
    /// prefix of it; `all` (vol-convert): every series, each into the
    /// file `-o`'s template names.
    #[cfg_attr(feature = "clap", arg(long, value_name = "SERIES"))]
    pub series: Option<String>,
    /// Multichannel input (colour TIFF samples, the C axis of an ImageJ
    /// hyperstack, OME-TIFF or OME-Zarr): the channel to read, from 0
    /// (colour: 0 is red).
    #[cfg_attr(feature = "clap", arg(long, value_name = "C"))]
    pub channel: Option<u16>,
    /// Input with a time axis (4D NIfTI, ImageJ hyperstack, OME-TIFF,
    /// OME-Zarr, a DICOM time series: fMRI, diffusion, cardiac phases):
    /// the time point to read, from 0.
    /// `all` (vol-convert): every volume, into one 4D NIfTI.
    #[cfg_attr(feature = "clap", arg(long = "time-point", value_name = "T|all"))]
    pub time_point: Option<TimePoint>,
    /// Multi-echo DICOM series: the echo to read, from 0 (`vol-info`
    /// lists the echoes); other inputs have no echo axis and refuse it.
    #[cfg_attr(feature = "clap", arg(long, value_name = "E"))]
    pub echo: Option<u64>,
    /// Philips DICOM with a private scale slope (2005,100E): `displayed`
    /// values (RescaleSlope/Intercept, DICOM's; the default) or `precise`
    /// ones (dcm2niix's); a note says which was applied.
    #[cfg_attr(
        feature = "clap",
        arg(
            long = "philips-scale",
            value_enum,
            value_name = "VALUES",
            default_value_t
        )
    )]
    pub philips_scale: crate::dicom::PhilipsScale,
    /// OME-Zarr pyramid: the level to read, 0 (full resolution, the
    /// default) to the coarsest; other inputs have no levels and refuse it.
    #[cfg_attr(feature = "clap", arg(long, value_name = "N"))]
    pub level: Option<u32>,
    /// The old spelling of --time-point (and of vol-render's --seconds):
    /// refused, naming both.
    #[cfg_attr(
        feature = "clap",
        arg(
            long = "time",
            hide = true,
            value_name = "T",
            allow_hyphen_values = true
        )
    )]
    #[cfg_attr(feature = "clap", serde(skip))]
    pub old_time: Option<String>,
}

/// `--time-point`: one time point (from 0), or every one (`all`, which
/// only vol-convert writes: one 4D NIfTI).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimePoint {
    /// This time point, from 0.
    At(u64),
    /// Every time point.
    All,
}

impl std::str::FromStr for TimePoint {
    type Err = String;
    fn from_str(s: &str) -> Result<TimePoint, String> {
        if s.eq_ignore_ascii_case("all") {
            return Ok(TimePoint::All);
        }
        s.parse()
            .map(TimePoint::At)
            .map_err(|_| format!("{s:?} is no time point: give one from 0, or all"))
    }
}

impl std::fmt::Display for TimePoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TimePoint::At(t) => write!(f, "{t}"),
            TimePoint::All => write!(f, "all"),
        }
    }
}

/// A time point prints as its number, `all` as the word (a printed
/// scene's `time-point`).
#[cfg(feature = "clap")]
impl serde::Serialize for TimePoint {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            TimePoint::At(t) => s.serialize_u64(*t),
            TimePoint::All => s.serialize_str("all"),
        }
    }
}

/// Why `--time-point all` is refused by every tool but vol-convert.
pub const ALL_TIME_POINTS_CONVERT_ONLY: &str = "--time-point all writes every volume and is vol-convert's (into one 4D NIfTI); here pick one: --time-point T";

/// Why `--series all` is refused by every tool but vol-convert.
pub const ALL_SERIES_CONVERT_ONLY: &str = "--series all converts every series and is vol-convert's (one file per series, named by a template); here pick one: --series ID";

/// The one-line answer to `--time` (or a scene file's `time`): what it
/// was split into.
pub const TIME_RENAMED: &str = "--time is gone: use --time-point T to pick a time point of 4D data, or --seconds S for vol-render's path-tracing time budget";

impl Selection {
    /// The read options these flags ask for (colour TIFF: one channel when
    /// `--channel` is given, else single-channel input only); an error for
    /// the old `--time`.
    pub fn read_options(&self) -> Result<ReadOptions, String> {
        if self.old_time.is_some() {
            return Err(TIME_RENAMED.to_string());
        }
        if self.time_point == Some(TimePoint::All) {
            return Err(ALL_TIME_POINTS_CONVERT_ONLY.to_string());
        }
        if self.series.as_deref() == Some("all") {
            return Err(ALL_SERIES_CONVERT_ONLY.to_string());
        }
        Ok(ReadOptions {
            raw: self.raw,
            channel: self.channel.map_or(ChannelSel::Single, ChannelSel::Channel),
            time: self.time_index(),
            series: self.series.clone(),
            echo: self.echo,
            philips: self.philips_scale,
            level: self.level,
            ..ReadOptions::default()
        })
    }

    /// The one time point asked for, `None` without `--time-point` (or
    /// with `all`).
    pub fn time_index(&self) -> Option<u64> {
        match self.time_point {
            Some(TimePoint::At(t)) => Some(t),
            _ => None,
        }
    }

    /// These flags with time point `t` instead of `--time-point all`.
    pub fn at_time(&self, t: u64) -> Selection {
        Selection {
            time_point: Some(TimePoint::At(t)),
            ..self.clone()
        }
    }

    /// Whether any selection was given (beyond the raw defaults).
    pub fn is_given(&self) -> bool {
        self.raw.is_given()
            || self.series.is_some()
            || self.channel.is_some()
            || self.time_point.is_some()
            || self.echo.is_some()
            || self.level.is_some()
            || self.old_time.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_old_time_flag_is_refused_naming_both_new_ones() {
        let s = Selection {
            old_time: Some("3".into()),
            ..Selection::default()
        };
        let e = s.read_options().unwrap_err();
        assert!(e.contains("--time-point") && e.contains("--seconds"), "{e}");
        let s = Selection {
            channel: Some(2),
            time_point: Some(TimePoint::At(1)),
            ..Selection::default()
        };
        let o = s.read_options().unwrap();
        assert_eq!((o.channel, o.time), (ChannelSel::Channel(2), Some(1)));
        let all = Selection {
            time_point: Some("all".parse().unwrap()),
            ..Selection::default()
        };
        assert!(all.read_options().unwrap_err().contains("vol-convert"));
        assert_eq!(all.at_time(4).read_options().unwrap().time, Some(4));
        assert!("x".parse::<TimePoint>().is_err());
    }
}
