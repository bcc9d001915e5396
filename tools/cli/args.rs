//! Parsers for the argument forms the tools share.

use volcore::{LengthUnit, SampleType, Shard};

/// Parse `X,Y,Z` (also `XxYxZ`) into three positive integers.
pub fn dims3(s: &str) -> Result<[u64; 3], String> {
    let parts: Vec<&str> = s.split([',', 'x']).collect();
    let v: Vec<u64> = parts
        .iter()
        .map(|p| p.trim().parse::<u64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not X,Y,Z with whole numbers"))?;
    match v[..] {
        [x, y, z] if x > 0 && y > 0 && z > 0 => Ok([x, y, z]),
        [_, _, _] => Err(format!("'{s}': every dimension must be at least 1")),
        _ => Err(format!("'{s}' is not X,Y,Z")),
    }
}

/// Parse a sample type name (`u8`, `u16`, `i16`, `f32`, `f64`).
pub fn sample_type(s: &str) -> Result<SampleType, String> {
    s.parse()
}

/// Parse `--shard K/N`: shard K (from 0) of N.
pub fn shard(s: &str) -> Result<Shard, String> {
    s.parse()
}

/// Parse `x,y,z` into three positive finite floats.
pub fn spacing3(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not x,y,z with numbers"))?;
    match v[..] {
        [x, y, z] if [x, y, z].iter().all(|v| v.is_finite() && *v > 0.0) => Ok([x, y, z]),
        [_, _, _] => Err(format!("'{s}': spacing must be positive and finite")),
        _ => Err(format!("'{s}' is not x,y,z")),
    }
}

/// Parse a unit of length: `m`, `cm`, `mm`, `um` (or `µm`, `micron`),
/// `nm`, `angstrom`, NGFF names (`micrometer`), or `unknown` (state none).
pub fn length_unit(s: &str) -> Result<LengthUnit, String> {
    match LengthUnit::parse(s) {
        Some(u) if u != LengthUnit::Unknown || s.trim().eq_ignore_ascii_case("unknown") => Ok(u),
        _ => Err(format!(
            "'{s}' is not a unit of length: m, cm, mm, um, nm, angstrom or unknown"
        )),
    }
}

// The layout and compression parsers belong to the writers (the Python
// package's `save` takes the same names): re-exported for the tools.
pub use volformats::convert::choose::{compression, layout, LayoutArg};

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::Compression;

    #[test]
    fn parses_and_rejects() {
        assert_eq!(dims3("800,800,800").unwrap(), [800, 800, 800]);
        assert_eq!(dims3("2x3x4").unwrap(), [2, 3, 4]);
        assert!(dims3("0,1,1").is_err());
        assert!(dims3("1,1").is_err());
        assert!(dims3("a,b,c").is_err());
        assert_eq!(spacing3("1,0.5,2").unwrap(), [1.0, 0.5, 2.0]);
        assert!(spacing3("1,0,1").is_err());
        assert!(spacing3("1,nan,1").is_err());
        assert_eq!(layout("bricked:16").unwrap(), LayoutArg::Bricked(16));
        assert_eq!(layout("sliced").unwrap(), LayoutArg::Sliced);
        assert!(layout("bricked:1").is_err());
        assert!(layout("tiled").is_err());
        assert_eq!(compression("zstd:19").unwrap(), Compression::Zstd(19));
        assert!(compression("zstd:99").is_err());
        assert!(compression("gzip").is_err());
    }
}
