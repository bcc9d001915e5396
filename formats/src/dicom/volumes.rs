//! The volumes of one series: images that share a position belong to
//! different volumes (time points of an fMRI or perfusion run, cardiac
//! phases, diffusion directions, echoes, magnitude and phase), told
//! apart by the attributes scanners set, in dcm2niix's order of
//! precedence ([`KEYS`]). The split is found from the headers alone; the
//! volumes are then numbered along two axes, echoes and time points, as
//! `--echo E` and `--time-point T` pick them.

use super::header::{SliceHeader, VolumeKeys};
use super::{cross, dot};
use std::cmp::Ordering;

/// Two slices closer than this along the normal lie at one position (mm).
const SAME_POSITION_MM: f64 = 0.01;

/// One attribute that can tell volumes apart: its name, as messages and
/// `vol-info` say it, and its value in a slice's keys (empty: not stated).
struct Key {
    name: &'static str,
    value: fn(&VolumeKeys) -> Vec<f64>,
    /// Whether volumes told apart by this key are echoes (their own axis).
    echo: bool,
    /// Whether volumes told apart by this key follow one another in time
    /// (so RepetitionTime is their step).
    temporal: bool,
}

/// The keys, in dcm2niix's order of precedence.
const KEYS: [Key; 7] = [
    Key {
        name: "TemporalPositionIdentifier",
        value: |k| k.temporal_position.map(|v| v as f64).into_iter().collect(),
        echo: false,
        temporal: true,
    },
    Key {
        name: "AcquisitionNumber",
        value: |k| k.acquisition_number.map(|v| v as f64).into_iter().collect(),
        echo: false,
        temporal: true,
    },
    Key {
        name: "AcquisitionTime",
        value: |k| k.acquisition_time.into_iter().collect(),
        echo: false,
        temporal: true,
    },
    Key {
        name: "TriggerTime",
        value: |k| k.trigger_time.into_iter().collect(),
        echo: false,
        temporal: false,
    },
    Key {
        name: "diffusion b-value and direction",
        value: |k| {
            let mut v: Vec<f64> = k.b_value.into_iter().collect();
            if let Some(d) = k.b_vector {
                v.extend(d);
            }
            v
        },
        echo: false,
        temporal: false,
    },
    Key {
        name: "EchoNumbers",
        value: |k| {
            k.echo_number
                .map(|v| v as f64)
                .or(k.echo_time)
                .into_iter()
                .collect()
        },
        echo: true,
        temporal: false,
    },
    Key {
        name: "ImageType",
        // The text's bytes, as numbers: only equality and a stable order
        // matter.
        value: |k| k.image_type.bytes().map(f64::from).collect(),
        echo: false,
        temporal: false,
    },
];

/// A series' slices split into volumes.
#[derive(Clone, Debug)]
pub(super) struct Volumes {
    /// The volumes' slices (unsorted within each), echo-major: volume
    /// `e * time_points + t` is echo `e`, time point `t`.
    pub(super) volumes: Vec<Vec<SliceHeader>>,
    /// Echoes (1 when echoes are no axis of their own).
    pub(super) echoes: usize,
    /// Time points per echo.
    pub(super) time_points: usize,
    /// The attributes that told the volumes apart (empty for one volume).
    pub(super) split_by: Vec<&'static str>,
    /// The time between two time points in seconds: RepetitionTime, when
    /// the volumes follow one another in time and every slice states the
    /// same one.
    pub(super) time_step: Option<f64>,
}

impl Volumes {
    /// Volume `(echo, time point)`, or an error naming the range.
    pub(super) fn pick(
        &self,
        echo: Option<u64>,
        time: Option<u64>,
    ) -> Result<&[SliceHeader], String> {
        let describe = || self.describe();
        let e = match echo {
            Some(e) if e as usize >= self.echoes => {
                return Err(if self.echoes == 1 {
                    format!(
                        "--echo {e} asked for, but the series has no echoes of its own ({})",
                        describe()
                    )
                } else {
                    format!(
                        "--echo {e} asked for, but the series has echoes 0..{} ({})",
                        self.echoes - 1,
                        describe()
                    )
                })
            }
            Some(e) => e as usize,
            None if self.echoes > 1 => {
                return Err(format!(
                    "the series holds {}: pick one with --echo E (0..{})",
                    describe(),
                    self.echoes - 1
                ))
            }
            None => 0,
        };
        let t = match time {
            Some(t) if t as usize >= self.time_points => {
                return Err(format!(
                    "--time-point {t} asked for, but the series has {} (0..{})",
                    describe(),
                    self.time_points - 1
                ))
            }
            Some(t) => t as usize,
            None if self.time_points > 1 => {
                return Err(format!(
                    "the series holds {}: pick one with --time-point T (0..{})",
                    describe(),
                    self.time_points - 1
                ))
            }
            None => 0,
        };
        Ok(&self.volumes[e * self.time_points + t])
    }

    /// `120 time points (AcquisitionNumber), TR 2 s`, `2 echoes`, `1
    /// volume`: what the volumes are and what told them apart.
    pub(super) fn describe(&self) -> String {
        let mut parts = Vec::new();
        if self.echoes > 1 {
            parts.push(format!("{} echoes", self.echoes));
        }
        if self.time_points > 1 || self.echoes == 1 {
            parts.push(format!(
                "{} time point{}",
                self.time_points,
                if self.time_points == 1 { "" } else { "s" }
            ));
        }
        let mut s = parts.join(" x ");
        if !self.split_by.is_empty() {
            s.push_str(&format!(" (by {})", self.split_by.join(", ")));
        }
        if let Some(tr) = self.time_step {
            s.push_str(&format!(", TR {tr} s"));
        }
        s
    }
}

/// The position index of each slice: slices within [`SAME_POSITION_MM`]
/// along the normal share one; and how many positions there are.
fn positions(slices: &[SliceHeader]) -> (Vec<usize>, usize) {
    let Some(first) = slices.first() else {
        return (Vec::new(), 0);
    };
    let o = first.orientation;
    let normal = cross([o[0], o[1], o[2]], [o[3], o[4], o[5]]);
    let along: Vec<f64> = slices.iter().map(|s| dot(s.position, normal)).collect();
    let mut order: Vec<usize> = (0..slices.len()).collect();
    order.sort_by(|&a, &b| along[a].total_cmp(&along[b]));
    let mut id = vec![0; slices.len()];
    let mut next = 0;
    let mut last = f64::NEG_INFINITY;
    for &i in &order {
        if along[i] - last > SAME_POSITION_MM {
            next += 1;
            last = along[i];
        }
        id[i] = next - 1;
    }
    (id, next)
}

/// Group slice indices by the values of `keys` (in the keys' order).
fn group(slices: &[SliceHeader], keys: &[usize]) -> Vec<(Vec<Vec<f64>>, Vec<usize>)> {
    let mut groups: Vec<(Vec<Vec<f64>>, Vec<usize>)> = Vec::new();
    for (i, s) in slices.iter().enumerate() {
        let v: Vec<Vec<f64>> = keys.iter().map(|&k| (KEYS[k].value)(&s.keys)).collect();
        match groups.iter_mut().find(|(g, _)| *g == v) {
            Some((_, members)) => members.push(i),
            None => groups.push((v, vec![i])),
        }
    }
    groups.sort_by(|a, b| compare(&a.0, &b.0));
    groups
}

fn compare(a: &[Vec<f64>], b: &[Vec<f64>]) -> Ordering {
    for (x, y) in a.iter().zip(b) {
        for (p, q) in x.iter().zip(y) {
            match p.total_cmp(q) {
                Ordering::Equal => {}
                o => return o,
            }
        }
        match x.len().cmp(&y.len()) {
            Ordering::Equal => {}
            o => return o,
        }
    }
    Ordering::Equal
}

/// How many slices share a position with an earlier one of their group.
fn duplicates(groups: &[(Vec<Vec<f64>>, Vec<usize>)], pos: &[usize], n_pos: usize) -> usize {
    let mut seen = vec![false; n_pos];
    let mut dups = 0;
    for (_, members) in groups {
        seen.iter_mut().for_each(|s| *s = false);
        for &i in members {
            if std::mem::replace(&mut seen[pos[i]], true) {
                dups += 1;
            }
        }
    }
    dups
}

/// Split `slices` (one series, one size and orientation) into volumes:
/// the keys are taken in order of precedence, each kept when it sets
/// apart slices that share a position without cutting the series into
/// more volumes than it has slices per position; what no key tells apart,
/// or volumes that do not cover the same positions, is an error naming
/// two slices.
pub(super) fn split(slices: Vec<SliceHeader>) -> Result<Volumes, String> {
    let (pos, n_pos) = positions(&slices);
    let n = slices.len();
    if n_pos == n {
        return Ok(Volumes {
            volumes: vec![slices],
            echoes: 1,
            time_points: 1,
            split_by: Vec::new(),
            time_step: None,
        });
    }
    // With every position covered once per volume.
    let expected = n.div_ceil(n_pos.max(1));
    let mut chosen: Vec<usize> = Vec::new();
    let mut groups = group(&slices, &chosen);
    let mut dups = duplicates(&groups, &pos, n_pos);
    for k in 0..KEYS.len() {
        if dups == 0 {
            break;
        }
        let mut with = chosen.clone();
        with.push(k);
        let g = group(&slices, &with);
        let d = duplicates(&g, &pos, n_pos);
        if d < dups && g.len() <= expected {
            chosen = with;
            groups = g;
            dups = d;
        }
    }
    if dups > 0 {
        let (a, b) = first_clash(&slices, &groups, &pos);
        return Err(format!(
            "{} and {} lie at the same position and no attribute tells their volumes apart (tried {})",
            a.display(),
            b.display(),
            KEYS.iter().map(|k| k.name).collect::<Vec<_>>().join(", ")
        ));
    }
    if let Some((_, short)) = groups.iter().find(|(_, m)| m.len() != n_pos) {
        let first = &slices[short[0]];
        return Err(format!(
            "the series' volumes (by {}) do not all cover its {n_pos} positions: the one of {} has {} slice{}",
            chosen.iter().map(|&k| KEYS[k].name).collect::<Vec<_>>().join(", "),
            first.path.display(),
            short.len(),
            if short.len() == 1 { "" } else { "s" }
        ));
    }
    let echo_key = chosen.iter().position(|&k| KEYS[k].echo);
    let echoes = match echo_key {
        Some(e) => {
            let mut values: Vec<&Vec<f64>> = groups.iter().map(|(v, _)| &v[e]).collect();
            values.sort_by(|a, b| compare(std::slice::from_ref(a), std::slice::from_ref(b)));
            values.dedup();
            values.len()
        }
        None => 1,
    };
    // Echo-major order: the echo key first, then the others in precedence.
    if let Some(e) = echo_key {
        groups.sort_by(|a, b| compare(&a.0[e..=e], &b.0[e..=e]).then_with(|| compare(&a.0, &b.0)));
    }
    if !groups.len().is_multiple_of(echoes) {
        return Err(format!(
            "the series' {} volumes do not divide into its {echoes} echoes evenly",
            groups.len()
        ));
    }
    let time_points = groups.len() / echoes;
    let temporal = chosen.iter().any(|&k| KEYS[k].temporal);
    let tr = slices[0].keys.repetition_time;
    let time_step = tr
        .filter(|_| temporal && time_points > 1)
        .filter(|t| t.is_finite() && *t > 0.0)
        .filter(|t| slices.iter().all(|s| s.keys.repetition_time == Some(*t)))
        .map(|t| t / 1000.0);
    let mut slots: Vec<Option<SliceHeader>> = slices.into_iter().map(Some).collect();
    let volumes = groups
        .into_iter()
        .map(|(_, members)| {
            members
                .into_iter()
                .filter_map(|i| slots[i].take())
                .collect()
        })
        .collect();
    Ok(Volumes {
        volumes,
        echoes,
        time_points,
        split_by: chosen.iter().map(|&k| KEYS[k].name).collect(),
        time_step,
    })
}

/// Two slices of one group at one position.
fn first_clash<'a>(
    slices: &'a [SliceHeader],
    groups: &[(Vec<Vec<f64>>, Vec<usize>)],
    pos: &[usize],
) -> (&'a std::path::Path, &'a std::path::Path) {
    for (_, members) in groups {
        for (j, &a) in members.iter().enumerate() {
            if let Some(&b) = members[j + 1..].iter().find(|&&b| pos[b] == pos[a]) {
                return (&slices[a].path, &slices[b].path);
            }
        }
    }
    (&slices[0].path, &slices[0].path)
}

#[cfg(test)]
mod tests {
    use super::super::header::PixelSource;
    use super::*;
    use crate::rescale::Rescale;
    use std::path::PathBuf;

    fn slice(z: f64, keys: VolumeKeys) -> SliceHeader {
        SliceHeader {
            path: PathBuf::from(format!("z{z}-{:?}.dcm", keys.acquisition_number)),
            series: "1.2".into(),
            series_number: Some(1),
            description: String::new(),
            modality: "MR".into(),
            rows: 2,
            cols: 2,
            position: [0.0, 0.0, z],
            orientation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            pixel_spacing: [1.0, 1.0],
            rescale: Rescale {
                slope: 1.0,
                intercept: 0.0,
            },
            bits_allocated: 16,
            bits_stored: 16,
            signed: false,
            pixels: PixelSource::default(),
            keys,
            stack: None,
            sidecar: Default::default(),
            philips_scale: None,
        }
    }

    fn fmri(volumes: i64, slices: u32) -> Vec<SliceHeader> {
        let mut v = Vec::new();
        for t in 0..volumes {
            for z in 0..slices {
                v.push(slice(
                    z as f64 * 3.0,
                    VolumeKeys {
                        acquisition_number: Some(t + 1),
                        // Each slice acquired at its own time.
                        acquisition_time: Some(t as f64 * 2.0 + z as f64 * 0.05),
                        repetition_time: Some(2000.0),
                        ..VolumeKeys::default()
                    },
                ));
            }
        }
        v.reverse();
        v
    }

    #[test]
    fn one_volume_stays_whole() {
        let v = split(fmri(1, 5)).unwrap();
        assert_eq!((v.echoes, v.time_points, v.volumes.len()), (1, 1, 1));
        assert!(v.split_by.is_empty());
        assert_eq!(v.time_step, None);
    }

    #[test]
    fn time_points_split_by_acquisition_number_not_by_slice_times() {
        let v = split(fmri(4, 5)).unwrap();
        assert_eq!((v.echoes, v.time_points), (1, 4));
        assert_eq!(v.split_by, ["AcquisitionNumber"]);
        assert_eq!(v.time_step, Some(2.0));
        for (t, vol) in v.volumes.iter().enumerate() {
            assert_eq!(vol.len(), 5);
            assert!(vol
                .iter()
                .all(|s| s.keys.acquisition_number == Some(t as i64 + 1)));
        }
        assert_eq!(v.describe(), "4 time points (by AcquisitionNumber), TR 2 s");
        assert_eq!(
            v.pick(None, Some(2)).unwrap()[0].keys.acquisition_number,
            Some(3)
        );
        let e = v.pick(None, None).unwrap_err();
        assert!(e.contains("--time-point T (0..3)"), "{e}");
        let e = v.pick(None, Some(4)).unwrap_err();
        assert!(e.contains("--time-point 4") && e.contains("(0..3)"), "{e}");
        assert!(v.pick(Some(1), Some(0)).unwrap_err().contains("no echoes"));
    }

    #[test]
    fn echoes_are_their_own_axis() {
        // Two echoes by three time points of four slices.
        let mut all = Vec::new();
        for t in 0..3 {
            for e in [1, 2] {
                for z in 0..4 {
                    all.push(slice(
                        z as f64,
                        VolumeKeys {
                            acquisition_number: Some(t),
                            echo_number: Some(e),
                            ..VolumeKeys::default()
                        },
                    ));
                }
            }
        }
        let v = split(all).unwrap();
        assert_eq!((v.echoes, v.time_points), (2, 3));
        assert_eq!(v.split_by, ["AcquisitionNumber", "EchoNumbers"]);
        let vol = v.pick(Some(1), Some(2)).unwrap();
        assert!(vol
            .iter()
            .all(|s| s.keys.echo_number == Some(2) && s.keys.acquisition_number == Some(2)));
        assert!(v
            .pick(None, Some(0))
            .unwrap_err()
            .contains("--echo E (0..1)"));
        assert_eq!(
            v.describe(),
            "2 echoes x 3 time points (by AcquisitionNumber, EchoNumbers)"
        );
    }

    #[test]
    fn diffusion_directions_and_phases_split() {
        let mut all = Vec::new();
        for (b, d) in [
            (0.0, [0.0, 0.0, 0.0]),
            (1000.0, [1.0, 0.0, 0.0]),
            (1000.0, [0.0, 1.0, 0.0]),
        ] {
            for z in 0..3 {
                all.push(slice(
                    z as f64,
                    VolumeKeys {
                        b_value: Some(b),
                        b_vector: Some(d),
                        repetition_time: Some(3000.0),
                        ..VolumeKeys::default()
                    },
                ));
            }
        }
        let v = split(all).unwrap();
        assert_eq!(v.time_points, 3);
        assert_eq!(v.split_by, ["diffusion b-value and direction"]);
        // Not a time series: no time step.
        assert_eq!(v.time_step, None);
        assert_eq!(v.volumes[0][0].keys.b_value, Some(0.0));
    }

    #[test]
    fn what_no_key_tells_apart_is_refused_naming_two_files() {
        let all = vec![
            slice(0.0, VolumeKeys::default()),
            slice(0.0, VolumeKeys::default()),
            slice(1.0, VolumeKeys::default()),
        ];
        let e = split(all).unwrap_err();
        assert!(
            e.contains("lie at the same position") && e.contains(".dcm and "),
            "{e}"
        );
    }

    #[test]
    fn a_volume_short_of_a_slice_is_refused() {
        let mut all = fmri(3, 4);
        all.remove(0);
        let e = split(all).unwrap_err();
        assert!(
            e.contains("do not all cover its 4 positions") && e.contains("has 3 slices"),
            "{e}"
        );
    }
}
