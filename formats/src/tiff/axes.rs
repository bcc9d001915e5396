//! The axes of multi-dimensional TIFF files: ImageJ hyperstacks (the
//! `channels=`, `slices=`, `frames=` of their description, pages in CZT
//! order) and OME-TIFF (the `Pixels` element of the OME-XML: sizes,
//! `DimensionOrder` and `PhysicalSizeX/Y/Z`). A file with several channels
//! or time points holds many 3D stacks; [`Axes::pages`] picks one.

use crate::stacks::TimeUnit;
use volcore::LengthUnit;

/// The non-spatial layout of a file's pages.
#[derive(Clone, Debug, PartialEq)]
pub struct Axes {
    /// Planes along z, channels and time points.
    pub z: u64,
    /// Channels.
    pub c: u64,
    /// Time points.
    pub t: u64,
    /// Page strides of z, c and t.
    pub strides: [u64; 3],
    /// Physical voxel size, when the file gives it.
    pub spacing: Option<[f32; 3]>,
    /// The unit of `spacing` (ImageJ `unit=`; OME `PhysicalSizeXUnit`,
    /// micrometres when absent, as the OME schema says).
    pub unit: LengthUnit,
    /// Where the axes came from (`ImageJ hyperstack`, `OME-TIFF`).
    pub source: &'static str,
    /// The axes as tifffile names them (`TZCYX`).
    pub names: String,
}

/// The value of `key=` in ImageJ description lines.
fn imagej_value(desc: &str, key: &str) -> Option<u64> {
    desc.lines()
        .find_map(|l| l.trim().strip_prefix(key)?.strip_prefix('='))
        .and_then(|v| v.trim().parse().ok())
}

/// The unit of an ImageJ description's `unit=` (ImageJ's `micron`,
/// `\u00B5m`, `nm`, ...). `pixel`, volkit's old `unit`, and words that
/// are not units of length state none.
pub fn imagej_unit(desc: &str) -> LengthUnit {
    if !desc.starts_with("ImageJ") {
        return LengthUnit::Unknown;
    }
    desc.lines()
        .find_map(|l| l.trim().strip_prefix("unit="))
        .and_then(|v| LengthUnit::parse(v.trim()))
        .unwrap_or_default()
}

/// The character references XML attributes use for `µ` and `Å`.
fn xml_unescape(v: &str) -> String {
    v.replace("&#181;", "\u{00B5}")
        .replace("&#xB5;", "\u{00B5}")
        .replace("&#xb5;", "\u{00B5}")
        .replace("&#197;", "Å")
        .replace("&#xC5;", "Å")
        .replace("&#8491;", "Å")
        .replace("&amp;", "&")
}

/// The value of attribute `name` in the XML tag text `tag`.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let mut rest = tag;
    loop {
        let i = rest.find(name)?;
        let before = rest[..i].chars().last();
        let after = &rest[i + name.len()..];
        let after_t = after.trim_start();
        if matches!(before, Some(c) if c.is_whitespace()) && after_t.starts_with('=') {
            let v = after_t[1..].trim_start();
            let q = v.chars().next()?;
            if q == '"' || q == '\'' {
                let end = v[1..].find(q)?;
                return Some(&v[1..1 + end]);
            }
            return None;
        }
        rest = after;
    }
}

impl Axes {
    /// Axes from an image description: ImageJ or OME-XML; `None` for a
    /// description without them (or with one 3D stack and no sizes).
    pub fn parse(desc: &str) -> Option<Axes> {
        if desc.starts_with("ImageJ") {
            let c = imagej_value(desc, "channels").unwrap_or(1).max(1);
            let t = imagej_value(desc, "frames").unwrap_or(1).max(1);
            let images = imagej_value(desc, "images").unwrap_or(1);
            let z = imagej_value(desc, "slices")
                .unwrap_or((images / c.saturating_mul(t)).max(1))
                .max(1);
            if c == 1 && t == 1 || planes(z, c, t).is_none() {
                return None;
            }
            let mut names = String::new();
            if t > 1 {
                names.push('T');
            }
            if z > 1 {
                names.push('Z');
            }
            if c > 1 {
                names.push('C');
            }
            names.push_str("YX");
            return Some(Axes {
                z,
                c,
                t,
                strides: [c, 1, c * z],
                spacing: None,
                unit: imagej_unit(desc),
                source: "ImageJ hyperstack",
                names,
            });
        }
        let start = desc.find("<Pixels").or_else(|| desc.find(":Pixels"))?;
        let tag = &desc[start..start + desc[start..].find('>')?];
        let size = |k: &str| {
            attr(tag, k)
                .and_then(|v| v.parse::<u64>().ok())
                .unwrap_or(1)
                .max(1)
        };
        let (z, c, t) = (size("SizeZ"), size("SizeC"), size("SizeT"));
        let order = attr(tag, "DimensionOrder").unwrap_or("XYZCT");
        // XY, then each of Z, C and T once; and a plane count a file can hold.
        let mut rest: Vec<char> = order.chars().skip(2).collect();
        rest.sort_unstable();
        if !order.starts_with("XY") || rest != ['C', 'T', 'Z'] || planes(z, c, t).is_none() {
            return None;
        }
        let mut strides = [0u64; 3];
        let mut s = 1u64;
        for ch in order.chars().skip(2) {
            match ch {
                'Z' => {
                    strides[0] = s;
                    s *= z;
                }
                'C' => {
                    strides[1] = s;
                    s *= c;
                }
                'T' => {
                    strides[2] = s;
                    s *= t;
                }
                _ => return None,
            }
        }
        if strides.contains(&0) {
            return None;
        }
        // Each size in its own unit, then all in the first stated one's.
        let phys = |k: &str| -> Option<(f64, LengthUnit)> {
            let v = attr(tag, k)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite() && *v > 0.0)?;
            let unit = match attr(tag, &format!("{k}Unit")) {
                None => LengthUnit::Micrometer,
                Some(u) => LengthUnit::parse(&xml_unescape(u))?,
            };
            Some((v, unit))
        };
        let sizes = [
            phys("PhysicalSizeX"),
            phys("PhysicalSizeY"),
            phys("PhysicalSizeZ"),
        ];
        let unit = sizes
            .iter()
            .flatten()
            .map(|s| s.1)
            .next()
            .unwrap_or_default();
        let in_unit = |s: Option<(f64, LengthUnit)>| -> Option<f32> {
            let (v, u) = s?;
            let k = if u == unit { 1.0 } else { u.factor_to(unit)? };
            Some((v * k) as f32).filter(|v| v.is_finite() && *v > 0.0)
        };
        let [px, py, pz] = sizes.map(in_unit);
        let spacing = (px.is_some() || py.is_some() || pz.is_some()).then(|| {
            let x = px.unwrap_or(1.0);
            [x, py.unwrap_or(x), pz.unwrap_or(x)]
        });
        // tifffile's names: slowest first.
        let mut names: String = order
            .chars()
            .skip(2)
            .filter(|ch| match ch {
                'Z' => z > 1,
                'C' => c > 1,
                _ => t > 1,
            })
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        names.push_str("YX");
        Some(Axes {
            z,
            c,
            t,
            strides,
            spacing,
            unit,
            source: "OME-TIFF",
            names,
        })
    }

    /// The page indices of the 3D stack at channel `c` and time `t`, in z
    /// order; an error naming the axes when a choice is missing or out of
    /// range.
    pub fn pages(
        &self,
        c: Option<u64>,
        t: Option<u64>,
        pages: usize,
    ) -> Result<Vec<usize>, String> {
        let need = self.z * self.c * self.t;
        if (pages as u64) < need {
            return Err(format!(
                "{} with axes {} ({} planes) has only {pages} pages",
                self.source, self.names, need
            ));
        }
        let pick = |v: Option<u64>, n: u64, what: &str, flag: &str| -> Result<u64, String> {
            match v {
                Some(i) if i < n => Ok(i),
                Some(i) => Err(format!(
                    "{flag} {i} asked for, but the file has {what} 0..{}",
                    n - 1
                )),
                None if n == 1 => Ok(0),
                None => Err(String::new()),
            }
        };
        let ci = pick(c, self.c, "channels", "--channel");
        let ti = pick(t, self.t, "time points", "--time-point");
        let (ci, ti) = match (ci, ti) {
            (Ok(c), Ok(t)) => (c, t),
            (Err(e), _) | (_, Err(e)) if !e.is_empty() => return Err(e),
            _ => {
                return Err(format!(
                    "{} with axes {} ({} slices, {} channels, {} time points) holds {} 3D stacks: pick one with{}{}",
                    self.source,
                    self.names,
                    self.z,
                    self.c,
                    self.t,
                    self.c * self.t,
                    if self.c > 1 { " --channel C" } else { "" },
                    if self.t > 1 { " --time-point T" } else { "" },
                ))
            }
        };
        Ok((0..self.z)
            .map(|z| (z * self.strides[0] + ci * self.strides[1] + ti * self.strides[2]) as usize)
            .collect())
    }
}

/// The time between time points an image description states, and its
/// unit: ImageJ's `finterval=` and `tunit=` (seconds when absent, as
/// ImageJ has it), or OME's `TimeIncrement` and `TimeIncrementUnit`
/// (seconds when absent, as the OME schema says). The unit is `None` when
/// the file names one volkit does not know.
pub fn time_step(desc: &str) -> (Option<f64>, Option<TimeUnit>) {
    let (v, unit) = if desc.starts_with("ImageJ") {
        let text = |key: &str| {
            desc.lines()
                .find_map(|l| l.trim().strip_prefix(key)?.strip_prefix('='))
                .map(str::trim)
        };
        (text("finterval"), text("tunit"))
    } else {
        let Some(start) = desc.find("<Pixels").or_else(|| desc.find(":Pixels")) else {
            return (None, None);
        };
        let Some(end) = desc[start..].find('>') else {
            return (None, None);
        };
        let tag = &desc[start..start + end];
        (attr(tag, "TimeIncrement"), attr(tag, "TimeIncrementUnit"))
    };
    let Some(step) = v.and_then(|v| v.parse().ok()).and_then(crate::stacks::step) else {
        return (None, None);
    };
    let unit = match unit {
        None => Some(TimeUnit::Second),
        Some(u) => TimeUnit::parse(&xml_unescape(u)),
    };
    (Some(step), unit)
}

/// The most image planes (pages) a hyperstack's axes may describe: far
/// more than any TIFF holds, small enough that every index product fits.
const MAX_PLANES: u64 = 1 << 40;

/// `z · c · t` when at most [`MAX_PLANES`].
fn planes(z: u64, c: u64, t: u64) -> Option<u64> {
    z.checked_mul(c)?
        .checked_mul(t)
        .filter(|&n| n <= MAX_PLANES)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Damaged or hostile axes: a repeated letter, or plane counts past
    /// what any file holds (whose index products would overflow).
    #[test]
    fn impossible_axes_are_no_axes() {
        let ome = |order: &str, z: &str, c: &str, t: &str| {
            format!(
                r#"<OME><Image><Pixels DimensionOrder="{order}" SizeZ="{z}" SizeC="{c}" SizeT="{t}" /></Image></OME>"#
            )
        };
        assert!(Axes::parse(&ome("XYZCT", "2", "3", "4")).is_some());
        assert!(Axes::parse(&ome("XYZCTZ", "2", "1", "1")).is_none());
        assert!(Axes::parse(&ome("XYZZT", "2", "3", "1")).is_none());
        assert!(Axes::parse(&ome("XYCZT", "4294967296", "4294967296", "1")).is_none());
        assert!(Axes::parse(&ome("XYZCT", "4294967296", "1", "4294967296")).is_none());
        let ij = |body: &str| format!("ImageJ=1.54f\n{body}");
        assert!(Axes::parse(&ij("channels=4294967296\nframes=4294967296\n")).is_none());
        assert!(Axes::parse(&ij("channels=4\nslices=4611686018427387904\n")).is_none());
        assert!(Axes::parse(&ij("channels=2\nslices=3\n")).is_some());
    }

    #[test]
    fn time_steps_of_imagej_and_ome_descriptions() {
        let ij = "ImageJ=1.11a\nimages=6\nframes=3\nchannels=2\nfinterval=0.5\n";
        assert_eq!(time_step(ij), (Some(0.5), Some(TimeUnit::Second)));
        let ij = "ImageJ=1.11a\nframes=3\nfinterval=2\ntunit=min\n";
        assert_eq!(time_step(ij), (Some(2.0), Some(TimeUnit::Minute)));
        assert_eq!(time_step("ImageJ=1.11a\nframes=3\n"), (None, None));
        let ome = |extra: &str| {
            format!(
                r#"<OME><Image><Pixels DimensionOrder="XYZCT" SizeZ="2" SizeT="4"{extra}/></Image></OME>"#
            )
        };
        assert_eq!(
            time_step(&ome(r#" TimeIncrement="2.5""#)),
            (Some(2.5), Some(TimeUnit::Second))
        );
        assert_eq!(
            time_step(&ome(r#" TimeIncrement="40" TimeIncrementUnit="ms""#)),
            (Some(40.0), Some(TimeUnit::Millisecond))
        );
        assert_eq!(
            time_step(&ome(r#" TimeIncrement="40" TimeIncrementUnit="&#181;s""#)),
            (Some(40.0), Some(TimeUnit::Microsecond))
        );
        assert_eq!(time_step(&ome(r#" TimeIncrement="0""#)), (None, None));
        assert_eq!(time_step(&ome("")), (None, None));
    }

    #[test]
    fn imagej_hyperstacks_pick_one_stack() {
        let d = "ImageJ=1.11a\nimages=80\nchannels=2\nslices=10\nframes=4\nhyperstack=true\nmode=grayscale\n";
        let a = Axes::parse(d).unwrap();
        assert_eq!((a.z, a.c, a.t), (10, 2, 4));
        assert_eq!(a.names, "TZCYX");
        let e = a.pages(None, None, 80).unwrap_err();
        assert!(
            e.contains("TZCYX") && e.contains("--channel C --time-point T"),
            "{e}"
        );
        assert_eq!(a.pages(Some(1), Some(2), 80).unwrap()[..3], [41, 43, 45]);
        assert!(a
            .pages(Some(2), Some(0), 80)
            .unwrap_err()
            .contains("channels 0..1"));
        assert!(Axes::parse("ImageJ=1.11a\nimages=10\nslices=10\nspacing=2\n").is_none());
    }

    #[test]
    fn ome_xml_sizes_order_and_physical_sizes() {
        let x = r#"<?xml version="1.0"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image ID="Image:0"><Pixels ID="Pixels:0" DimensionOrder="XYCZT" Type="uint16" SizeX="64" SizeY="32" SizeZ="5" SizeC="3" SizeT="1" PhysicalSizeX="0.25" PhysicalSizeY="0.25" PhysicalSizeZ="1.5"><Channel ID="Channel:0:0"/></Pixels></Image></OME>"#;
        let a = Axes::parse(x).unwrap();
        assert_eq!((a.z, a.c, a.t), (5, 3, 1));
        assert_eq!(a.spacing, Some([0.25, 0.25, 1.5]));
        assert_eq!(a.names, "ZCYX");
        assert!(a.pages(None, None, 15).unwrap_err().contains("--channel C"));
        assert_eq!(a.pages(Some(2), None, 15).unwrap(), vec![2, 5, 8, 11, 14]);
        let one = x.replace("SizeC=\"3\"", "SizeC=\"1\"");
        let a = Axes::parse(&one).unwrap();
        assert_eq!(a.pages(None, None, 5).unwrap(), vec![0, 1, 2, 3, 4]);
    }
}
