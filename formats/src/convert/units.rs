//! The unit of length of a conversion's output: the one asked for
//! (`--units`), else the input's; then, for an output that cannot state
//! it (NIfTI has no nanometre code, MetaImage no unit field at all), the
//! nearest unit it can, with the spacing and origin rescaled and a note
//! that says so. A unit is never written that a reader would misread.

use super::{Plan, Target};
use crate::error::{Error, Result};
use volcore::{Geometry, LengthUnit};

/// Spacing, geometry (with its unit) and notes of the output, from the
/// input's spacing and geometry (already cropped and flipped).
pub fn resolve(
    in_spacing: [f32; 3],
    geometry: Geometry,
    plan: &Plan,
    target: &Target,
) -> Result<([f32; 3], Geometry, Vec<String>)> {
    let mut notes = Vec::new();
    let mut spacing = in_spacing;
    let mut geometry = geometry;
    if let Some(to) = plan.unit {
        if geometry.unit == LengthUnit::Unknown {
            if to != LengthUnit::Unknown {
                notes.push(format!(
                    "the input states no unit of length: its spacing and origin are taken as {}",
                    to.symbol()
                ));
            }
            geometry.unit = to;
        } else if let Some((g, k)) = geometry.converted(to) {
            if k != 1.0 {
                notes.push(format!(
                    "spacing and origin converted from {} to {} (x{k})",
                    geometry.unit.symbol(),
                    to.symbol()
                ));
            }
            spacing = scaled(spacing, k)?;
            geometry = g;
        } else {
            // `--units unknown` on an input with a unit: drop the label.
            notes.push(format!(
                "the unit {} is not written: the output states no unit of length",
                geometry.unit.symbol()
            ));
            geometry.unit = LengthUnit::Unknown;
        }
    }
    if let Some(relabel) = plan.spacing {
        if relabel != spacing {
            let f = |v: [f32; 3]| format!("{},{},{}", v[0], v[1], v[2]);
            notes.push(format!(
                "--spacing relabels the voxels ({} becomes {}) without resampling them: --resample spacing:{} resamples",
                f(spacing),
                f(relabel),
                f(relabel)
            ));
        }
    }
    let mut spacing = plan.spacing.unwrap_or(spacing);
    if let Some((held, format)) = target.units() {
        let to = geometry.unit.nearest_in(held);
        if to != geometry.unit {
            if let Some((g, k)) = geometry.converted(to) {
                notes.push(format!(
                    "{format} cannot state {}: spacing and origin converted to {} (x{k})",
                    geometry.unit.symbol(),
                    to.symbol()
                ));
                spacing = scaled(spacing, k)?;
                geometry = g;
            }
        }
    }
    Ok((spacing, geometry, notes))
}

/// `spacing` times `k`, refused when a value leaves f32's finite,
/// positive numbers (a nanometre spacing in parsecs, say).
fn scaled(spacing: [f32; 3], k: f64) -> Result<[f32; 3]> {
    let out = spacing.map(|s| (s as f64 * k) as f32);
    if out.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(Error::invalid(format!(
            "spacing {spacing:?} times {k} is {out:?}: not a positive, finite f32"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn nifti() -> Target {
        Target::headed(&PathBuf::from("a.nii"), false).unwrap()
    }

    fn raw() -> Target {
        Target::Raw {
            path: PathBuf::from("a.raw"),
        }
    }

    #[test]
    fn nanometres_become_micrometres_for_nifti_and_are_kept_elsewhere() {
        let g = Geometry::IDENTITY.with_unit(LengthUnit::Nanometer);
        let mut g = g;
        g.origin = [100.0, 0.0, -50.0];
        let (sp, out, notes) = resolve([5.0, 5.0, 200.0], g, &Plan::default(), &nifti()).unwrap();
        assert_eq!(sp, [0.005, 0.005, 0.2]);
        assert_eq!(out.unit, LengthUnit::Micrometer);
        assert_eq!(out.origin, [0.1, 0.0, -0.05]);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].contains("NIfTI cannot state nm"), "{notes:?}");
        let (sp, out, notes) = resolve([5.0, 5.0, 200.0], g, &Plan::default(), &raw()).unwrap();
        assert_eq!(
            (sp, out.unit, notes.len()),
            ([5.0, 5.0, 200.0], LengthUnit::Nanometer, 0)
        );
    }

    #[test]
    fn asked_units_convert_or_label_and_say_so() {
        let um = Geometry::IDENTITY.with_unit(LengthUnit::Micrometer);
        let plan = Plan {
            unit: Some(LengthUnit::Millimeter),
            ..Plan::default()
        };
        let (sp, out, notes) = resolve([0.5, 0.5, 2.0], um, &plan, &raw()).unwrap();
        assert_eq!(sp, [0.0005, 0.0005, 0.002]);
        assert_eq!(out.unit, LengthUnit::Millimeter);
        assert!(notes[0].contains("from µm to mm"), "{notes:?}");
        let (sp, out, notes) = resolve([0.5, 0.5, 2.0], Geometry::IDENTITY, &plan, &raw()).unwrap();
        assert_eq!((sp, out.unit), ([0.5, 0.5, 2.0], LengthUnit::Millimeter));
        assert!(notes[0].contains("states no unit"), "{notes:?}");
        // An unknown unit is never converted, for any output.
        let (sp, out, notes) = resolve(
            [0.5, 0.5, 2.0],
            Geometry::IDENTITY,
            &Plan::default(),
            &nifti(),
        )
        .unwrap();
        assert_eq!(
            (sp, out.unit, notes.len()),
            ([0.5, 0.5, 2.0], LengthUnit::Unknown, 0)
        );
    }
}
