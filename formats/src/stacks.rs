//! How many 3D volumes an input holds along its non-spatial axes: its
//! channels (colour TIFF samples, the C axis of an ImageJ hyperstack,
//! OME-TIFF or OME-Zarr) and time points (the T axis of those, the 4th
//! dimension of NIfTI), with the time step where the file states one.
//! Read from the headers alone, whatever `--channel` and `--time-point`
//! pick: what `vol-info` reports beside the one volume it describes
//! ([`crate::open::stacks`] reads them for any input). Below the readers,
//! which use its vocabulary, it uses none of them.

/// The sizes of an input's channel and time axes (1 where it has none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stacks {
    /// Channels.
    pub channels: u64,
    /// Time points.
    pub time_points: u64,
    /// Echoes (a multi-echo DICOM series; 1 for every other input).
    pub echoes: u64,
    /// Time between two time points, in `time_unit`, when the file states
    /// it (and has more than one time point).
    pub time_step: Option<f64>,
    /// The unit of `time_step`; `None` when the file states none (or one
    /// volkit does not know).
    pub time_unit: Option<TimeUnit>,
}

impl Default for Stacks {
    fn default() -> Self {
        Stacks {
            channels: 1,
            time_points: 1,
            echoes: 1,
            time_step: None,
            time_unit: None,
        }
    }
}

/// A unit of time, as microscopy and imaging files state them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    Day,
    Hour,
    Minute,
    Second,
    Millisecond,
    Microsecond,
    Nanosecond,
}

impl TimeUnit {
    /// A unit from its symbol or name in any of the spellings files use:
    /// OME's `s`, `ms`, `µs`; ImageJ's `sec`, `min`; NGFF's (UDUNITS)
    /// `second`, `millisecond`; plurals; any case.
    pub fn parse(s: &str) -> Option<TimeUnit> {
        let s = s.trim().to_ascii_lowercase();
        let one = |s: &str| {
            Some(match s {
                "d" | "day" => TimeUnit::Day,
                "h" | "hr" | "hour" => TimeUnit::Hour,
                "min" | "minute" => TimeUnit::Minute,
                "s" | "sec" | "second" => TimeUnit::Second,
                "ms" | "msec" | "millisecond" => TimeUnit::Millisecond,
                "\u{00B5}s" | "\u{03BC}s" | "us" | "usec" | "microsecond" => TimeUnit::Microsecond,
                "ns" | "nsec" | "nanosecond" => TimeUnit::Nanosecond,
                _ => return None,
            })
        };
        one(&s).or_else(|| one(s.strip_suffix('s')?))
    }

    /// The NGFF (UDUNITS) name, as `--json` gives it (`second`, ...).
    pub fn ngff_name(self) -> &'static str {
        match self {
            TimeUnit::Day => "day",
            TimeUnit::Hour => "hour",
            TimeUnit::Minute => "minute",
            TimeUnit::Second => "second",
            TimeUnit::Millisecond => "millisecond",
            TimeUnit::Microsecond => "microsecond",
            TimeUnit::Nanosecond => "nanosecond",
        }
    }

    /// Seconds in one of this unit (a 4D NIfTI states its time step in
    /// seconds).
    pub fn seconds(self) -> f64 {
        match self {
            TimeUnit::Day => 86_400.0,
            TimeUnit::Hour => 3_600.0,
            TimeUnit::Minute => 60.0,
            TimeUnit::Second => 1.0,
            TimeUnit::Millisecond => 1e-3,
            TimeUnit::Microsecond => 1e-6,
            TimeUnit::Nanosecond => 1e-9,
        }
    }

    /// The symbol, as text reports give it (`s`, `ms`, `µs`, ...).
    pub fn symbol(self) -> &'static str {
        match self {
            TimeUnit::Day => "d",
            TimeUnit::Hour => "h",
            TimeUnit::Minute => "min",
            TimeUnit::Second => "s",
            TimeUnit::Millisecond => "ms",
            TimeUnit::Microsecond => "\u{00B5}s",
            TimeUnit::Nanosecond => "ns",
        }
    }
}

/// A time step: positive and finite, else none.
pub(crate) fn step(v: f64) -> Option<f64> {
    (v.is_finite() && v > 0.0).then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_units_in_every_spelling() {
        for (s, u) in [
            ("s", TimeUnit::Second),
            ("sec", TimeUnit::Second),
            ("Seconds", TimeUnit::Second),
            ("second", TimeUnit::Second),
            ("ms", TimeUnit::Millisecond),
            ("millisecond", TimeUnit::Millisecond),
            ("µs", TimeUnit::Microsecond),
            ("min", TimeUnit::Minute),
            ("mins", TimeUnit::Minute),
            ("hr", TimeUnit::Hour),
            ("hrs", TimeUnit::Hour),
            ("days", TimeUnit::Day),
            ("h", TimeUnit::Hour),
            ("ns", TimeUnit::Nanosecond),
        ] {
            assert_eq!(TimeUnit::parse(s), Some(u), "{s}");
            assert_eq!(TimeUnit::parse(u.ngff_name()), Some(u));
            assert_eq!(TimeUnit::parse(u.symbol()), Some(u));
        }
        assert_eq!(TimeUnit::parse("furlong"), None);
        assert_eq!(TimeUnit::parse("Hz"), None);
        assert_eq!(step(0.0), None);
        assert_eq!(step(f64::NAN), None);
    }
}
