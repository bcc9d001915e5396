//! `--resample SPEC`: what the user asks for, and the grid it gives.

use crate::grid::Grid;
use std::path::PathBuf;
use std::str::FromStr;
use volcore::Dims;

/// The most voxels a resampled output may have (2^40).
pub const MAX_OUTPUT_VOXELS: u64 = 1 << 40;

/// The output grid `--resample` asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum ResampleSpec {
    /// `spacing:S` or `spacing:X,Y,Z`: new spacing (in the input's unit
    /// once the caller has converted it), dims from the box.
    Spacing([f64; 3]),
    /// `dims:NX,NY,NZ`: new dims, spacing from the box.
    Dims([u64; 3]),
    /// `like:FILE`: the whole grid of another volume (read by the caller).
    Like(PathBuf),
}

impl FromStr for ResampleSpec {
    type Err = String;

    /// Parses `spacing:S`, `spacing:X,Y,Z`, `dims:NX,NY,NZ` or `like:FILE`;
    /// a refusal is one line naming the offending value.
    fn from_str(s: &str) -> Result<ResampleSpec, String> {
        let forms = "spacing:S, spacing:X,Y,Z, dims:NX,NY,NZ or like:FILE";
        let Some((kind, rest)) = s.split_once(':') else {
            return Err(format!("resample spec '{s}' is not one of {forms}"));
        };
        match kind {
            "spacing" => {
                let parts: Vec<&str> = rest.split(',').collect();
                if parts.len() != 1 && parts.len() != 3 {
                    return Err(format!(
                        "'{s}': spacing takes one value or three (X,Y,Z), not {}",
                        parts.len()
                    ));
                }
                let mut v = [0.0; 3];
                for (a, p) in parts.iter().enumerate() {
                    let x: f64 = p
                        .trim()
                        .parse()
                        .map_err(|_| format!("'{s}': spacing '{p}' is not a number"))?;
                    if !x.is_finite() || x <= 0.0 {
                        return Err(format!(
                            "'{s}': spacing {p} must be a positive finite number"
                        ));
                    }
                    v[a] = x;
                }
                if parts.len() == 1 {
                    v = [v[0]; 3];
                }
                Ok(ResampleSpec::Spacing(v))
            }
            "dims" => {
                let parts: Vec<&str> = rest.split(',').collect();
                if parts.len() != 3 {
                    return Err(format!(
                        "'{s}': dims takes three values (NX,NY,NZ), not {}",
                        parts.len()
                    ));
                }
                let mut v = [0u64; 3];
                for (a, p) in parts.iter().enumerate() {
                    let n: u64 = p
                        .trim()
                        .parse()
                        .map_err(|_| format!("'{s}': dim '{p}' is not a whole number"))?;
                    if n == 0 {
                        return Err(format!("'{s}': dim {p} must be at least 1"));
                    }
                    v[a] = n;
                }
                Ok(ResampleSpec::Dims(v))
            }
            "like" => {
                if rest.is_empty() {
                    return Err(format!("'{s}': like: needs a file name"));
                }
                Ok(ResampleSpec::Like(PathBuf::from(rest)))
            }
            _ => Err(format!(
                "resample spec '{s}': unknown kind '{kind}', use {forms}"
            )),
        }
    }
}

/// The output grid of `--resample spacing:` or `dims:` (`like:` is the
/// other file's grid, which the caller reads).
///
/// The convention: the output keeps the input's directions and its
/// physical box. The box runs from the first voxel's outer face to the
/// last voxel's, so its extent along index axis a is `n_a·s_a`.
/// `spacing:` gives `n'_a = max(1, round(n_a·s_a / s'_a))`; `dims:` gives
/// `s'_a = n_a·s_a / n'_a`. The new box is centred on the old one:
/// `origin' = origin + D·(((n_a − 1)·s_a − (n'_a − 1)·s'_a) / 2)` per axis
/// (D: the direction matrix, column a = axis a). Spacings are in the
/// input's unit. An output over 2^40 voxels is refused.
pub fn target_grid(input: &Grid, spec: &ResampleSpec) -> Result<Grid, String> {
    let n = input.dims.as_array();
    let s = input.spacing;
    let extent: [f64; 3] = std::array::from_fn(|a| n[a] as f64 * s[a]);
    let (dims, spacing): ([u64; 3], [f64; 3]) = match spec {
        ResampleSpec::Spacing(t) => {
            if let Some(a) = (0..3).find(|&a| !t[a].is_finite() || t[a] <= 0.0) {
                return Err(format!(
                    "resample spacing {} must be a positive finite number",
                    t[a]
                ));
            }
            let d: [f64; 3] = std::array::from_fn(|a| (extent[a] / t[a]).round().max(1.0));
            if d.iter()
                .any(|v| !v.is_finite() || *v > MAX_OUTPUT_VOXELS as f64)
            {
                return Err(format!(
                    "resampling {} to spacing {},{},{} gives {}x{}x{} voxels, over the limit of 2^40",
                    input.dims, t[0], t[1], t[2], d[0], d[1], d[2]
                ));
            }
            (d.map(|v| v as u64), *t)
        }
        ResampleSpec::Dims(d) => {
            if let Some(a) = (0..3).find(|&a| d[a] == 0) {
                return Err(format!("resample dims {} must be at least 1", d[a]));
            }
            (*d, std::array::from_fn(|a| extent[a] / d[a] as f64))
        }
        ResampleSpec::Like(p) => {
            return Err(format!(
                "like:{}: the caller reads the other file's grid",
                p.display()
            ))
        }
    };
    let count = dims[0]
        .checked_mul(dims[1])
        .and_then(|v| v.checked_mul(dims[2]));
    if count.is_none_or(|c| c > MAX_OUTPUT_VOXELS) {
        return Err(format!(
            "the resampled output would be {}x{}x{} voxels, over the limit of 2^40",
            dims[0], dims[1], dims[2]
        ));
    }
    let dims = Dims::new(dims[0], dims[1], dims[2]).map_err(|e| format!("resample: {e}"))?;
    let nd = dims.as_array();
    let shift: [f64; 3] =
        std::array::from_fn(|a| ((n[a] - 1) as f64 * s[a] - (nd[a] - 1) as f64 * spacing[a]) / 2.0);
    let mut geometry = input.geometry;
    let d = &input.geometry.direction;
    for (o, row) in geometry.origin.iter_mut().zip(d) {
        *o += row[0] * shift[0] + row[1] * shift[1] + row[2] * shift[2];
    }
    Ok(Grid {
        dims,
        spacing,
        geometry,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::Geometry;

    #[test]
    fn specs_parse_and_bad_values_are_named() {
        assert_eq!(
            "spacing:1".parse::<ResampleSpec>(),
            Ok(ResampleSpec::Spacing([1.0; 3]))
        );
        assert_eq!(
            "spacing:0.5,1,2".parse::<ResampleSpec>(),
            Ok(ResampleSpec::Spacing([0.5, 1.0, 2.0]))
        );
        assert_eq!(
            "dims:4,5,6".parse::<ResampleSpec>(),
            Ok(ResampleSpec::Dims([4, 5, 6]))
        );
        assert_eq!(
            "like:a.nii".parse::<ResampleSpec>(),
            Ok(ResampleSpec::Like("a.nii".into()))
        );
        for (bad, names) in [
            ("spacing:0", "0"),
            ("spacing:-1", "-1"),
            ("spacing:NaN", "NaN"),
            ("spacing:inf", "inf"),
            ("spacing:1,x,2", "x"),
            ("spacing:1,2", "spacing:1,2"),
            ("dims:0,1,1", "0"),
            ("dims:1,1", "dims:1,1"),
            ("dims:1,-2,1", "-2"),
            ("like:", "like:"),
            ("size:1", "size"),
            ("1,1,1", "1,1,1"),
        ] {
            let e = bad.parse::<ResampleSpec>().unwrap_err();
            assert!(e.contains(names) && !e.contains('\n'), "{bad}: {e}");
        }
    }

    #[test]
    fn huge_output_is_refused() {
        let g = Grid::new(
            Dims::new(1000, 1000, 1000).unwrap(),
            [1.0; 3],
            Geometry::IDENTITY,
        );
        let e = target_grid(&g, &ResampleSpec::Spacing([0.01; 3])).unwrap_err();
        assert!(e.contains("100000x100000x100000"), "{e}");
    }
}
