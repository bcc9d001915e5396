//! What a conversion will write, known before any sample is read: the
//! output's dims and sample type, the OME-Zarr pyramid check, and the
//! bytes the run (or its shard) writes, for progress and disk space.
//! vol-convert and the Python package's `save` check the same way here.

use super::{output_grid, At, CResult, InputInfo, LayoutArg, OutputOptions, Plan, Target, Window};
use std::path::Path;
use volcore::SampleType;
use volprep::Grid;

/// The message for a value window without an output sample type.
pub const WINDOW_NEEDS_TYPE: &str = "--window needs --type (the output sample type)";

/// Refuse a value `window` without an output `sample_type` to map the
/// values to: the message is [`WINDOW_NEEDS_TYPE`].
pub fn check_window(
    window: Option<&Window>,
    sample_type: Option<SampleType>,
) -> Result<(), &'static str> {
    if window.is_some() && sample_type.is_none() {
        return Err(WINDOW_NEEDS_TYPE);
    }
    Ok(())
}

/// The output a conversion will write, before it runs.
#[derive(Clone, Debug)]
pub struct OutputSize {
    /// The output grid (after crop, units and the preprocessing stages).
    pub grid: Grid,
    /// The output sample type (f32 when it depends on the values).
    pub sample_type: SampleType,
    /// The sample bytes this run writes: the whole volume's, or the
    /// shard's share of its units (slices, brick layers, or chunk layers
    /// of an OME-Zarr pyramid's coarsest level).
    pub bytes: u64,
}

/// What converting `info`'s volume by `plan` into `out` (with options
/// `opts`, as `target` was made) writes; refuses an OME-Zarr pyramid
/// deeper than the output dims make before any sample is read.
pub fn output_size(
    info: &InputInfo,
    plan: &Plan,
    target: &Target,
    out: &Path,
    opts: &OutputOptions,
) -> CResult<OutputSize> {
    let (grid, sample_type) = output_grid(info, plan, target)?;
    let dims = grid.dims;
    let sample_type = sample_type.unwrap_or(SampleType::F32);
    let zarr = crate::omezarr::is_zarr(out);
    if zarr {
        crate::omezarr::check_levels(dims, grid.spacing.map(|v| v as f32), opts.pyramid).at(out)?;
    }
    let mut bytes = dims.count().saturating_mul(sample_type.size() as u64);
    if let Some(shard) = opts.shard {
        let (mine, units) = if zarr {
            let zs = crate::omezarr::shard_slices(
                dims,
                grid.spacing.map(|v| v as f32),
                opts.pyramid,
                shard,
            )
            .at(out)?;
            (zs.end - zs.start, dims.z)
        } else {
            let units = match opts.layout {
                LayoutArg::Sliced => dims.z,
                LayoutArg::Bricked(b) => dims.z.div_ceil(u64::from(b.max(1))),
            };
            let r = shard.units(units);
            (r.end - r.start, units)
        };
        bytes = (u128::from(bytes) * u128::from(mine) / u128::from(units.max(1))) as u64;
    }
    Ok(OutputSize {
        grid,
        sample_type,
        bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_needs_an_output_type() {
        let w: Window = "0:1".parse().unwrap();
        assert_eq!(check_window(Some(&w), None), Err(WINDOW_NEEDS_TYPE));
        assert_eq!(check_window(Some(&w), Some(SampleType::U8)), Ok(()));
        assert_eq!(check_window(None, None), Ok(()));
    }
}
