//! The unit of length of a volume's spacing and origin.
//!
//! Formats spell units in their own words (NIfTI a code, OME-TIFF a
//! symbol such as `µm`, ImageJ `micron`, OME-Zarr the NGFF name
//! `micrometer`, NRRD free text); [`LengthUnit::parse`] reads them all
//! and each writer spells the unit its own way. A volume whose source
//! says nothing has [`LengthUnit::Unknown`]: its numbers are kept, and no
//! unit is claimed for them.

use std::fmt;

/// A unit of length, or none stated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LengthUnit {
    /// The source states no unit (raw data, plain TIFF, NIfTI code 0).
    #[default]
    Unknown,
    /// 1e-10 m.
    Angstrom,
    /// 1e-9 m.
    Nanometer,
    /// 1e-6 m.
    Micrometer,
    /// 1e-3 m.
    Millimeter,
    /// 1e-2 m.
    Centimeter,
    /// 1 m.
    Meter,
}

impl LengthUnit {
    /// Every stated unit, smallest first.
    pub const KNOWN: [LengthUnit; 6] = [
        LengthUnit::Angstrom,
        LengthUnit::Nanometer,
        LengthUnit::Micrometer,
        LengthUnit::Millimeter,
        LengthUnit::Centimeter,
        LengthUnit::Meter,
    ];

    /// Read a unit as formats and people write it: the symbol (`mm`,
    /// `µm`, `um`, `nm`, `Å`), the name in English or NGFF spelling
    /// (`micrometer`, `micrometre`, `micron`, `microns`), any case. An
    /// empty string and `pixel` (ImageJ's "no unit") are
    /// [`LengthUnit::Unknown`]; anything else is `None` (not a length
    /// unit volkit knows).
    pub fn parse(s: &str) -> Option<LengthUnit> {
        let t = s.trim().trim_matches('"').trim();
        // Both micro signs (U+00B5 and Greek mu U+03BC) and ImageJ's
        // escaped form.
        let t = t
            .replace(['\u{00B5}', '\u{03BC}'], "u")
            .replace("\\u00B5", "u")
            .replace("\\u00b5", "u");
        if t == "Å" || t == "\u{212B}" {
            return Some(LengthUnit::Angstrom);
        }
        let l = t.to_ascii_lowercase();
        Some(match l.as_str() {
            "" | "pixel" | "pixels" | "px" | "unknown" => LengthUnit::Unknown,
            "angstrom" | "angstroms" | "a" => LengthUnit::Angstrom,
            "nm" | "nanometer" | "nanometers" | "nanometre" | "nanometres" => LengthUnit::Nanometer,
            "um" | "micrometer" | "micrometers" | "micrometre" | "micrometres" | "micron"
            | "microns" => LengthUnit::Micrometer,
            "mm" | "millimeter" | "millimeters" | "millimetre" | "millimetres" => {
                LengthUnit::Millimeter
            }
            "cm" | "centimeter" | "centimeters" | "centimetre" | "centimetres" => {
                LengthUnit::Centimeter
            }
            "m" | "meter" | "meters" | "metre" | "metres" => LengthUnit::Meter,
            _ => return None,
        })
    }

    /// Metres per unit (`None` for [`LengthUnit::Unknown`]).
    pub fn metres(self) -> Option<f64> {
        Some(match self {
            LengthUnit::Unknown => return None,
            LengthUnit::Angstrom => 1e-10,
            LengthUnit::Nanometer => 1e-9,
            LengthUnit::Micrometer => 1e-6,
            LengthUnit::Millimeter => 1e-3,
            LengthUnit::Centimeter => 1e-2,
            LengthUnit::Meter => 1.0,
        })
    }

    /// The number one of `self` is in units of `to` (1000 from mm to
    /// µm), exact for the powers of ten between these units; `None` when
    /// either is unknown.
    pub fn factor_to(self, to: LengthUnit) -> Option<f64> {
        let exp = |u: LengthUnit| -> Option<i32> {
            Some(match u {
                LengthUnit::Unknown => return None,
                LengthUnit::Angstrom => -10,
                LengthUnit::Nanometer => -9,
                LengthUnit::Micrometer => -6,
                LengthUnit::Millimeter => -3,
                LengthUnit::Centimeter => -2,
                LengthUnit::Meter => 0,
            })
        };
        let d = exp(self)? - exp(to)?;
        // 10^d as an exact f64 for d >= 0; a division by the exact 10^-d
        // otherwise (0.001 is not exact, 1/1000 rounds once).
        Some(if d >= 0 {
            10f64.powi(d)
        } else {
            1.0 / 10f64.powi(-d)
        })
    }

    /// The symbol: `Å`, `nm`, `µm`, `mm`, `cm`, `m` (empty when unknown).
    /// What vol-info prints, OME-TIFF and NRRD hold.
    pub fn symbol(self) -> &'static str {
        match self {
            LengthUnit::Unknown => "",
            LengthUnit::Angstrom => "Å",
            LengthUnit::Nanometer => "nm",
            LengthUnit::Micrometer => "µm",
            LengthUnit::Millimeter => "mm",
            LengthUnit::Centimeter => "cm",
            LengthUnit::Meter => "m",
        }
    }

    /// The OME-NGFF (UDUNITS-2) name: `micrometer`, `millimeter`, ...
    /// (`None` when unknown). Also the `--json` spelling.
    pub fn ngff_name(self) -> Option<&'static str> {
        Some(match self {
            LengthUnit::Unknown => return None,
            LengthUnit::Angstrom => "angstrom",
            LengthUnit::Nanometer => "nanometer",
            LengthUnit::Micrometer => "micrometer",
            LengthUnit::Millimeter => "millimeter",
            LengthUnit::Centimeter => "centimeter",
            LengthUnit::Meter => "meter",
        })
    }

    /// The code in a `.vvol` header (0 unknown, 1 Å ... 6 m).
    pub fn code(self) -> u8 {
        match self {
            LengthUnit::Unknown => 0,
            LengthUnit::Angstrom => 1,
            LengthUnit::Nanometer => 2,
            LengthUnit::Micrometer => 3,
            LengthUnit::Millimeter => 4,
            LengthUnit::Centimeter => 5,
            LengthUnit::Meter => 6,
        }
    }

    /// The unit with `.vvol` code `c`.
    pub fn from_code(c: u8) -> Option<LengthUnit> {
        match c {
            0 => Some(LengthUnit::Unknown),
            1..=6 => Some(LengthUnit::KNOWN[c as usize - 1]),
            _ => None,
        }
    }

    /// Of the stated units in `held`, the one closest to `self` by
    /// scale (the larger on a tie): the unit an output format that
    /// cannot hold `self` converts to. `self` if held or unknown.
    pub fn nearest_in(self, held: &[LengthUnit]) -> LengthUnit {
        if self == LengthUnit::Unknown || held.contains(&self) {
            return self;
        }
        let Some(m) = self.metres() else {
            return self;
        };
        held.iter()
            .copied()
            .filter_map(|u| u.metres().map(|um| (u, (um / m).log10().abs())))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(b.0.code().cmp(&a.0.code())))
            .map_or(self, |(u, _)| u)
    }
}

impl fmt::Display for LengthUnit {
    /// The NGFF name, or `unknown`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.ngff_name().unwrap_or("unknown"))
    }
}

#[cfg(test)]
mod tests {
    use super::LengthUnit as U;

    #[test]
    fn spellings_of_formats_parse() {
        for (s, u) in [
            ("µm", U::Micrometer),
            ("\u{03BC}m", U::Micrometer),
            ("micron", U::Micrometer),
            ("\\u00B5m", U::Micrometer),
            ("micrometer", U::Micrometer),
            ("nm", U::Nanometer),
            ("\"mm\"", U::Millimeter),
            ("Millimetre", U::Millimeter),
            ("m", U::Meter),
            ("Å", U::Angstrom),
            ("pixel", U::Unknown),
            ("", U::Unknown),
        ] {
            assert_eq!(U::parse(s), Some(u), "{s}");
        }
        assert_eq!(U::parse("furlong"), None);
        assert_eq!(U::parse("s"), None);
    }

    #[test]
    fn factors_are_exact_powers_of_ten() {
        assert_eq!(U::Millimeter.factor_to(U::Micrometer), Some(1000.0));
        assert_eq!(U::Nanometer.factor_to(U::Micrometer), Some(1.0 / 1000.0));
        assert_eq!(U::Meter.factor_to(U::Angstrom), Some(1e10));
        assert_eq!(U::Micrometer.factor_to(U::Micrometer), Some(1.0));
        assert_eq!(U::Unknown.factor_to(U::Meter), None);
        // 0.5 nm is 0.0005 µm, the same number as written by hand.
        assert_eq!(0.5 * U::Nanometer.factor_to(U::Micrometer).unwrap(), 0.0005);
    }

    #[test]
    fn codes_round_trip_and_nearest_units_are_chosen_by_scale() {
        for u in std::iter::once(U::Unknown).chain(U::KNOWN) {
            assert_eq!(U::from_code(u.code()), Some(u));
        }
        assert_eq!(U::from_code(7), None);
        let nifti = [U::Meter, U::Millimeter, U::Micrometer];
        assert_eq!(U::Nanometer.nearest_in(&nifti), U::Micrometer);
        assert_eq!(U::Angstrom.nearest_in(&nifti), U::Micrometer);
        assert_eq!(U::Centimeter.nearest_in(&nifti), U::Millimeter);
        assert_eq!(U::Millimeter.nearest_in(&nifti), U::Millimeter);
        assert_eq!(U::Unknown.nearest_in(&nifti), U::Unknown);
    }
}
