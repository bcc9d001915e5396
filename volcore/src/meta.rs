//! Volume metadata: everything about a volume except its samples.

use crate::brick::BrickGeometry;
use crate::dims::Dims;
use crate::sample::SampleType;
use crate::unit::LengthUnit;
use std::fmt;

/// How samples are ordered in storage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// One array, x fastest, then y, then z: index = x + X·(y + Y·z).
    Sliced,
    /// Cubic bricks; see [`BrickGeometry`] for the apron and brick order.
    Bricked(BrickGeometry),
}

impl Layout {
    /// Short name: `sliced` or `bricked:B`.
    pub fn describe(&self) -> String {
        match self {
            Layout::Sliced => "sliced".into(),
            Layout::Bricked(g) => format!("bricked:{}", g.brick()),
        }
    }
}

/// How bricks are compressed on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    /// Stored as is.
    None,
    /// Each brick compressed on its own with zstd at this level.
    Zstd(i32),
}

/// The smallest and largest sample value. NaN samples are ignored; a volume
/// of only NaNs has the empty range (`min > max`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueRange {
    /// Smallest non-NaN sample.
    pub min: f64,
    /// Largest non-NaN sample.
    pub max: f64,
}

impl ValueRange {
    /// The empty range, identity of [`ValueRange::merge`].
    pub const EMPTY: ValueRange = ValueRange {
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    /// Whether no sample contributed.
    pub fn is_empty(&self) -> bool {
        self.min > self.max
    }

    /// Widen to include `v` (NaN is ignored).
    #[inline]
    pub fn add(&mut self, v: f64) {
        if v < self.min {
            self.min = v;
        }
        if v > self.max {
            self.max = v;
        }
    }

    /// The union of two ranges.
    pub fn merge(self, o: ValueRange) -> ValueRange {
        ValueRange {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Range of a slice of samples, ignoring NaN.
    pub fn of<T: crate::Sample>(data: &[T]) -> ValueRange {
        let (min, max) = T::min_max(data);
        ValueRange { min, max }
    }
}

/// Where the voxel grid sits in the world (patient) frame, as ITK, DICOM
/// and NRRD put it: voxel `(i, j, k)` is at
/// `origin + D · (i·sx, j·sy, k·sz)`, where column `a` of the direction
/// matrix `D` is the unit world direction of index axis `a`. The world
/// frame is LPS (x to the patient's left, y posterior, z superior), the
/// frame of DICOM, ITK and MetaImage; readers of RAS formats (NIfTI,
/// NRRD `right-anterior-superior`) flip x and y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// World position of voxel `(0, 0, 0)`.
    pub origin: [f64; 3],
    /// Direction cosines, row-major: `direction[row][axis]`.
    pub direction: [[f64; 3]; 3],
    /// The unit of the origin and of the volume's spacing.
    pub unit: LengthUnit,
}

impl Default for Geometry {
    fn default() -> Self {
        Geometry::IDENTITY
    }
}

impl Geometry {
    /// Zero origin, axes along x, y, z.
    pub const IDENTITY: Geometry = Geometry {
        origin: [0.0; 3],
        direction: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        unit: LengthUnit::Unknown,
    };

    /// Whether origin and directions are those of [`Geometry::IDENTITY`]
    /// (whatever the unit).
    pub fn is_identity(&self) -> bool {
        self.origin == Geometry::IDENTITY.origin && self.direction == Geometry::IDENTITY.direction
    }

    /// The same geometry with its unit set to `unit` (the numbers kept).
    pub fn with_unit(mut self, unit: LengthUnit) -> Geometry {
        self.unit = unit;
        self
    }

    /// The same place in unit `to`: the origin multiplied by the factor
    /// from this unit to `to`, which is returned for the spacing. `None`
    /// when either unit is unknown.
    pub fn converted(&self, to: LengthUnit) -> Option<(Geometry, f64)> {
        let k = self.unit.factor_to(to)?;
        let mut g = *self;
        g.origin = self.origin.map(|v| v * k);
        g.unit = to;
        Some((g, k))
    }

    /// The unit world direction of index axis `a` (column `a`).
    pub fn axis(&self, a: usize) -> [f64; 3] {
        [
            self.direction[0][a],
            self.direction[1][a],
            self.direction[2][a],
        ]
    }

    /// A geometry from per-axis direction vectors of any non-zero length
    /// (they are normalised): `axes[a]` is the direction of index axis `a`.
    /// Fails on non-finite values, zero-length or parallel axes.
    pub fn from_axes(origin: [f64; 3], axes: [[f64; 3]; 3]) -> Result<Geometry, String> {
        if origin
            .iter()
            .chain(axes.iter().flatten())
            .any(|v| !v.is_finite())
        {
            return Err("origin or directions are not finite".into());
        }
        let mut direction = [[0.0; 3]; 3];
        for (a, v) in axes.iter().enumerate() {
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if n <= 1e-12 {
                return Err(format!("direction of axis {a} has zero length"));
            }
            for r in 0..3 {
                // `+ 0.0` turns -0 into 0 (printed as such).
                direction[r][a] = v[r] / n + 0.0;
            }
        }
        let g = Geometry {
            origin,
            direction,
            unit: LengthUnit::Unknown,
        };
        if g.determinant().abs() < 1e-6 {
            return Err("axis directions are parallel (the matrix is singular)".into());
        }
        Ok(g)
    }

    /// Determinant of the direction matrix (+1 or -1 for a rotation or a
    /// reflection).
    pub fn determinant(&self) -> f64 {
        let d = &self.direction;
        d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1])
            - d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0])
            + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0])
    }

    /// The same geometry in the frame with x and y negated (LPS ↔ RAS).
    pub fn flip_xy(&self) -> Geometry {
        let mut g = *self;
        for r in 0..2 {
            g.origin[r] = -g.origin[r] + 0.0;
            for a in 0..3 {
                g.direction[r][a] = -g.direction[r][a] + 0.0;
            }
        }
        g
    }

    /// World position of voxel index `ijk` with the given spacing.
    pub fn world(&self, spacing: [f32; 3], ijk: [f64; 3]) -> [f64; 3] {
        let s = [
            ijk[0] * spacing[0] as f64,
            ijk[1] * spacing[1] as f64,
            ijk[2] * spacing[2] as f64,
        ];
        let d = &self.direction;
        std::array::from_fn(|r| self.origin[r] + d[r][0] * s[0] + d[r][1] * s[1] + d[r][2] * s[2])
    }

    /// The geometry of a sub-volume starting at voxel `start`, with index
    /// axes mirrored where `flip` is set (`dims`: the sub-volume's size).
    pub fn cropped(
        &self,
        spacing: [f32; 3],
        start: [u64; 3],
        dims: [u64; 3],
        flip: [bool; 3],
    ) -> Geometry {
        let mut first = [start[0] as f64, start[1] as f64, start[2] as f64];
        for a in 0..3 {
            if flip[a] {
                first[a] += dims[a].saturating_sub(1) as f64;
            }
        }
        let mut g = *self;
        g.origin = self.world(spacing, first);
        for row in g.direction.iter_mut() {
            for (v, &f) in row.iter_mut().zip(&flip) {
                if f {
                    *v = -*v + 0.0;
                }
            }
        }
        g
    }

    /// The 3-letter orientation code of the index axes (DICOM/ITK style):
    /// for each axis the patient direction it points to most, `L`/`R`,
    /// `P`/`A`, `S`/`I` (e.g. `LPS` for the identity, `RAS` for a NIfTI
    /// in its usual orientation).
    pub fn orientation(&self) -> String {
        (0..3)
            .map(|a| {
                let v = self.axis(a);
                let r = (0..3)
                    .max_by(|&i, &j| v[i].abs().total_cmp(&v[j].abs()))
                    .unwrap_or(a);
                let pos = v[r] >= 0.0;
                match (r, pos) {
                    (0, true) => 'L',
                    (0, false) => 'R',
                    (1, true) => 'P',
                    (1, false) => 'A',
                    (_, true) => 'S',
                    (_, false) => 'I',
                }
            })
            .collect()
    }
}

/// Everything about a volume but its samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeMeta {
    /// Voxels per axis.
    pub dims: Dims,
    /// World distance between neighbouring voxels along x, y, z.
    pub spacing: [f32; 3],
    /// Stored sample type.
    pub sample_type: SampleType,
    /// Smallest and largest sample (may be empty when not yet known).
    pub range: ValueRange,
    /// Sample order in storage.
    pub layout: Layout,
    /// Per-brick compression (always `None` for sliced layouts).
    pub compression: Compression,
    /// Origin and axis directions in the world frame.
    pub geometry: Geometry,
    /// Set when the samples were narrowed on opening (an `f64` file read
    /// as `f32` for rendering): what they were and how far they moved.
    pub narrowed: Option<Narrowing>,
}

/// What opening a volume did to samples of a type the renderer does not
/// read (`f64`, held as `f32`, converted once).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Narrowing {
    /// The stored type.
    pub from: SampleType,
    /// The stored layout (the samples in memory are sliced).
    pub layout: Layout,
    /// The stored compression (the samples in memory are not compressed).
    pub compression: Compression,
    /// The largest absolute change a sample took (0 when every value was
    /// exact; infinite when one overflowed `f32`).
    pub largest_change: f64,
    /// The largest magnitude among the samples (to judge the change by).
    pub largest_magnitude: f64,
}

impl Narrowing {
    /// One line for the user: what was converted and by how much it moved
    /// (`None` when no value changed).
    pub fn note(&self) -> Option<String> {
        let e = self.largest_change;
        if e == 0.0 || e.is_nan() {
            return None;
        }
        let m = self.largest_magnitude;
        let rel = if m > 0.0 && m.is_finite() { e / m } else { 0.0 };
        Some(format!(
            "{} values rounded to f32: the largest change is {e:.3e} ({rel:.1e} of the largest magnitude {m:.6e})",
            self.from
        ))
    }
}

impl VolumeMeta {
    /// The volume as its file stores it: the type, layout and compression
    /// it had before opening narrowed it (itself when nothing was).
    pub fn as_stored(&self) -> VolumeMeta {
        match self.narrowed {
            Some(n) => VolumeMeta {
                sample_type: n.from,
                layout: n.layout,
                compression: n.compression,
                ..*self
            },
            None => *self,
        }
    }

    /// Metadata for a sliced, uncompressed volume with unit spacing.
    pub fn sliced(dims: Dims, sample_type: SampleType) -> VolumeMeta {
        VolumeMeta {
            dims,
            spacing: [1.0; 3],
            sample_type,
            range: ValueRange::EMPTY,
            layout: Layout::Sliced,
            compression: Compression::None,
            geometry: Geometry::IDENTITY,
            narrowed: None,
        }
    }

    /// The far corner of the volume's box in world units,
    /// `(dims − 1)·spacing` per axis (the box starts at the origin: voxel
    /// `(i, j, k)` sits at `(i·sx, j·sy, k·sz)`).
    pub fn world_extent(&self) -> [f32; 3] {
        let d = self.dims.as_array();
        std::array::from_fn(|a| (d[a] - 1) as f32 * self.spacing[a])
    }

    /// The box's diagonal in world units, in f64 (`None` when the extent
    /// [`VolumeMeta::world_extent`] is not a finite f32 on some axis).
    pub fn world_diagonal(&self) -> Option<f64> {
        let e = self.world_extent();
        e.iter().all(|c| c.is_finite()).then(|| {
            e.iter()
                .map(|&c| (c as f64) * (c as f64))
                .sum::<f64>()
                .sqrt()
        })
    }

    /// The smallest of the three voxel spacings.
    pub fn min_spacing(&self) -> f32 {
        self.spacing.iter().copied().fold(f32::INFINITY, f32::min)
    }
}

impl fmt::Display for VolumeMeta {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {} {} spacing {},{},{}",
            self.dims,
            self.sample_type,
            self.layout.describe(),
            self.spacing[0],
            self.spacing[1],
            self.spacing[2]
        )?;
        if self.geometry.unit != LengthUnit::Unknown {
            write!(f, " {}", self.geometry.unit.symbol())?;
        }
        if let Compression::Zstd(l) = self.compression {
            write!(f, " zstd:{l}")?;
        }
        if let Some(n) = self.narrowed {
            write!(f, " (stored as {})", n.from)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_maps_and_flips() {
        let g = Geometry::from_axes(
            [10.0, 20.0, 30.0],
            [[-2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]],
        )
        .unwrap();
        assert_eq!(g.axis(0), [-1.0, 0.0, 0.0]);
        assert_eq!(g.world([2.0, 1.0, 0.5], [1.0, 2.0, 4.0]), [8.0, 22.0, 32.0]);
        assert_eq!(g.orientation(), "RPS");
        assert_eq!(Geometry::IDENTITY.orientation(), "LPS");
        assert_eq!(Geometry::IDENTITY.flip_xy().orientation(), "RAS");
        assert_eq!(g.determinant(), -1.0);
        // Cropping from voxel 1 along x, mirrored in z over 3 slices.
        let c = g.cropped([2.0, 1.0, 0.5], [1, 0, 0], [4, 4, 3], [false, false, true]);
        assert_eq!(c.origin, [8.0, 20.0, 31.0]);
        assert_eq!(c.axis(2), [0.0, 0.0, -1.0]);
        assert!(Geometry::from_axes(
            [0.0; 3],
            [[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
        )
        .is_err());
        assert!(Geometry::from_axes(
            [f64::NAN, 0.0, 0.0],
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        )
        .is_err());
    }
}
