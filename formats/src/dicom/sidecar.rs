//! What a DICOM series says about its acquisition, as a BIDS sidecar
//! (the JSON dcm2niix writes beside each NIfTI), under BIDS's names and
//! units: times in seconds (DICOM states milliseconds), AcquisitionTime
//! as `HH:MM:SS.ffffff`. Read from a series' first slice (an enhanced
//! file's first frame, whose functional groups come first).

use super::header::{seconds_of_day, Attrs};
use dicom_core::Tag;
use dicom_dictionary_std::tags;
use serde_json::{Map, Value};

/// Text attributes, under their BIDS (and DICOM) names.
const TEXT: [(&str, Tag); 9] = [
    ("Modality", tags::MODALITY),
    ("Manufacturer", tags::MANUFACTURER),
    ("ManufacturersModelName", tags::MANUFACTURER_MODEL_NAME),
    ("SeriesDescription", tags::SERIES_DESCRIPTION),
    ("ProtocolName", tags::PROTOCOL_NAME),
    ("BodyPartExamined", tags::BODY_PART_EXAMINED),
    ("PatientPosition", tags::PATIENT_POSITION),
    ("ConvolutionKernel", tags::CONVOLUTION_KERNEL),
    ("ScanningSequence", tags::SCANNING_SEQUENCE),
];

/// Numbers kept in their DICOM unit (T, mm, degrees, mAs, mA).
const NUMBER: [(&str, Tag); 6] = [
    ("MagneticFieldStrength", tags::MAGNETIC_FIELD_STRENGTH),
    ("SliceThickness", tags::SLICE_THICKNESS),
    ("SpacingBetweenSlices", tags::SPACING_BETWEEN_SLICES),
    ("FlipAngle", tags::FLIP_ANGLE),
    ("XRayExposure", tags::EXPOSURE),
    ("XRayTubeCurrent", tags::X_RAY_TUBE_CURRENT),
];

/// Times DICOM states in ms and BIDS in seconds: (name, tags tried in
/// order).
const SECONDS: [(&str, &[Tag]); 4] = [
    ("EchoTime", &[tags::ECHO_TIME, tags::EFFECTIVE_ECHO_TIME]),
    ("RepetitionTime", &[tags::REPETITION_TIME]),
    ("InversionTime", &[tags::INVERSION_TIME]),
    ("ExposureTime", &[tags::EXPOSURE_TIME]),
];

/// The sidecar of the slice whose attributes `a` gives: only what the
/// file states.
pub(super) fn of(a: &Attrs) -> Map<String, Value> {
    let mut m = Map::new();
    for (name, tag) in TEXT {
        if let Some(v) = a.text(tag).filter(|v| !v.is_empty()) {
            m.insert(name.into(), Value::String(volcore::text::escape(&v)));
        }
    }
    for (name, tag) in NUMBER {
        if let Some(v) = a.first_float(tag).and_then(finite) {
            m.insert(name.into(), v);
        }
    }
    for (name, tags) in SECONDS {
        if let Some(v) = tags
            .iter()
            .find_map(|&t| a.first_float(t))
            .and_then(|ms| finite(ms / 1000.0))
        {
            m.insert(name.into(), v);
        }
    }
    for (name, tag) in [
        ("SeriesNumber", tags::SERIES_NUMBER),
        ("EchoNumber", tags::ECHO_NUMBERS),
    ] {
        if let Some(n) = a.int(tag) {
            m.insert(name.into(), n.into());
        }
    }
    // An enhanced file states the time with its date (a DT:
    // YYYYMMDDHHMMSS.FFFFFF, perhaps with a zone).
    let date_time = || {
        a.text(tags::ACQUISITION_DATE_TIME)
            .or_else(|| a.text(tags::FRAME_ACQUISITION_DATE_TIME))
            .and_then(|dt| {
                dt.get(8..)
                    .map(|t| t.split(['+', '-']).next().unwrap_or("").to_string())
            })
    };
    if let Some(t) = a
        .text(tags::ACQUISITION_TIME)
        .or_else(date_time)
        .and_then(|t| seconds_of_day(&t))
    {
        m.insert("AcquisitionTime".into(), Value::String(clock(t)));
    }
    let image_type = a
        .text(tags::IMAGE_TYPE)
        .or_else(|| a.text(tags::FRAME_TYPE))
        .unwrap_or_default();
    if !image_type.is_empty() {
        let parts = image_type
            .split('\\')
            .map(|p| Value::String(volcore::text::escape(p.trim())))
            .collect();
        m.insert("ImageType".into(), Value::Array(parts));
    }
    m
}

/// A JSON number for a finite value.
fn finite(v: f64) -> Option<Value> {
    serde_json::Number::from_f64(v).map(Value::Number)
}

/// Seconds since midnight as BIDS writes a time: `HH:MM:SS.ffffff`.
fn clock(s: f64) -> String {
    let micros = (s * 1e6).round() as u64;
    let (whole, frac) = (micros / 1_000_000, micros % 1_000_000);
    format!(
        "{:02}:{:02}:{:02}.{frac:06}",
        whole / 3600,
        whole / 60 % 60,
        whole % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_print_as_bids_clocks() {
        assert_eq!(clock(36930.25), "10:15:30.250000");
        assert_eq!(clock(0.0), "00:00:00.000000");
        assert!(finite(f64::NAN).is_none());
    }
}
