//! Scenes whose correct renders are known in closed form, and `solid`.

use super::{clip, Scene};
use crate::dims::Dims;

/// The thesis's `solid` scene: a constant value with a border of zeros
/// (5 voxels wide, narrower on axes too short for it).
pub struct SolidScene {
    dims: Dims,
    value: f32,
}

impl SolidScene {
    /// `value` inside a 5-voxel zero border.
    pub fn new(dims: Dims, value: f32) -> Self {
        SolidScene { dims, value }
    }
}

fn border(d: u64) -> u64 {
    5.min(d.saturating_sub(1) / 2)
}

impl Scene for SolidScene {
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        out.fill(0.0);
        let d = self.dims;
        let inside = |c: u64, n: u64| c >= border(n) && c < n - border(n);
        if !inside(y, d.y) || !inside(z, d.z) {
            return false;
        }
        let b = border(d.x) as i64;
        if let Some((a, e)) = clip(b, d.x as i64 - b, x0, out.len()) {
            out[a..e].fill(self.value);
            return true;
        }
        false
    }
}

/// A box of constant value `value` with `margin` empty voxels on every
/// side; with margin 0 the whole volume is one homogeneous medium, whose
/// transmittance along a ray is exactly `exp(−σ·length)`.
pub struct BoxScene {
    dims: Dims,
    margin: u64,
    value: f32,
}

impl BoxScene {
    /// A box `margin` voxels in from each face.
    pub fn new(dims: Dims, margin: u64, value: f32) -> Self {
        BoxScene {
            dims,
            margin,
            value,
        }
    }
}

impl Scene for BoxScene {
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        out.fill(0.0);
        let (d, m) = (self.dims, self.margin);
        let inside = |c: u64, n: u64| c >= m && c + m < n;
        if !inside(y, d.y) || !inside(z, d.z) {
            return false;
        }
        if let Some((a, e)) = clip(m as i64, d.x as i64 - m as i64, x0, out.len()) {
            out[a..e].fill(self.value);
            return true;
        }
        false
    }
}

/// A linear ramp from 0 at the first voxel to `value` at the last along
/// one axis (0 = x, 1 = y, 2 = z); trilinear interpolation reproduces it
/// exactly, and so does its gradient.
pub struct RampScene {
    dims: Dims,
    axis: usize,
    value: f32,
}

impl RampScene {
    /// A ramp along `axis` (clamped to 0..=2).
    pub fn new(dims: Dims, axis: usize, value: f32) -> Self {
        RampScene {
            dims,
            axis: axis.min(2),
            value,
        }
    }

    fn at(&self, c: u64) -> f32 {
        let n = self.dims.as_array()[self.axis];
        if n < 2 {
            0.0
        } else {
            (self.value as f64 * c as f64 / (n - 1) as f64) as f32
        }
    }
}

impl Scene for RampScene {
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        match self.axis {
            0 => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = self.at(x0 + i as u64);
                }
            }
            1 => out.fill(self.at(y)),
            _ => out.fill(self.at(z)),
        }
        true
    }
}

/// A single sphere at the volume's centre with a linear radial profile:
/// `value · max(0, 1 − r / radius)`. Its maximum is `value` at the centre
/// and the iso-surface of level `c` is the sphere of radius
/// `radius · (1 − c / value)`. With an edge width `w`
/// ([`SphereScene::with_edge`]) it is solid instead: `value` inside
/// `radius − w/2`, 0 outside `radius + w/2`, linear between, so the
/// gradient is `value / w` per voxel in that shell and 0 elsewhere.
pub struct SphereScene {
    dims: Dims,
    radius: f32,
    value: f32,
    edge: Option<f32>,
}

impl SphereScene {
    /// A sphere of outer radius `radius` voxels.
    pub fn new(dims: Dims, radius: f32, value: f32) -> Self {
        SphereScene {
            dims,
            radius: radius.max(f32::MIN_POSITIVE),
            value,
            edge: None,
        }
    }

    /// A solid sphere of radius `radius` whose surface is a linear ramp
    /// `edge` voxels wide (clamped to a small positive width).
    pub fn with_edge(dims: Dims, radius: f32, value: f32, edge: f32) -> Self {
        SphereScene {
            edge: Some(if edge.is_finite() {
                edge.max(1e-3)
            } else {
                1e-3
            }),
            ..SphereScene::new(dims, radius, value)
        }
    }

    /// The sphere's centre in voxel coordinates.
    pub fn centre(&self) -> [f64; 3] {
        self.dims.as_array().map(|n| (n - 1) as f64 / 2.0)
    }
}

impl Scene for SphereScene {
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        let c = self.centre();
        let dy = y as f64 - c[1];
        let dz = z as f64 - c[2];
        let r = self.radius as f64;
        for (i, o) in out.iter_mut().enumerate() {
            let dx = (x0 + i as u64) as f64 - c[0];
            let dist = (dx * dx + dy * dy + dz * dz).sqrt();
            let f = match self.edge {
                None => (1.0 - dist / r).max(0.0),
                Some(w) => {
                    let w = w as f64;
                    ((r + 0.5 * w - dist) / w).clamp(0.0, 1.0)
                }
            };
            *o = (self.value as f64 * f) as f32;
        }
        true
    }
}
