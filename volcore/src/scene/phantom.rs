//! `phantom`: a CT-like head in Hounsfield units, for tests and studies
//! that need what scanners produce: air around a body, a soft-tissue
//! medium that is mostly but not wholly transparent, a closed bone shell,
//! small dense and low-contrast details, partial-volume edges and noise.
//!
//! The head is a stack of ellipsoids in the volume's normalised
//! coordinates (each axis from −1 to 1 across the volume; the long axis is
//! z, superior up; the face looks toward −y, as in the LPS patient frame),
//! painted in order over air (−1000 HU): skin, skull, brain, ventricles,
//! lesions, a calcification, the petrous bones, the eyes and a sinus. Each
//! edge is a linear ramp [`PHANTOM_EDGE`] voxels wide (a scanner's
//! partial-volume blur), and every voxel carries triangular noise of
//! standard deviation [`PHANTOM_NOISE_SD`] HU hashed from the seed and the
//! voxel's index.

use super::{clip, hash64, Scene};
use crate::dims::Dims;

/// Hounsfield units of air, the phantom's background.
pub const PHANTOM_AIR: f32 = -1000.0;

/// Width of each structure's edge, voxels.
pub const PHANTOM_EDGE: f64 = 1.5;

/// Standard deviation of the phantom's noise, HU.
pub const PHANTOM_NOISE_SD: f64 = 10.0;

/// One structure: an ellipsoid (centre and semi-axes in normalised
/// coordinates, turned by `turn` degrees about z) of one tissue.
struct Part {
    centre: [f64; 3],
    semi: [f64; 3],
    turn: f64,
    hu: f64,
}

const fn part(centre: [f64; 3], semi: [f64; 3], turn: f64, hu: f64) -> Part {
    Part {
        centre,
        semi,
        turn,
        hu,
    }
}

/// The head, in painting order (later parts cover earlier ones).
const PARTS: [Part; 15] = [
    part([0.0, 0.0, 0.0], [0.74, 0.90, 0.94], 0.0, 30.0), // skin and muscle
    part([0.0, 0.0, 0.02], [0.69, 0.85, 0.89], 0.0, 1100.0), // skull
    part([0.0, 0.0, 0.02], [0.64, 0.80, 0.84], 0.0, 35.0), // brain
    part([-0.12, 0.05, 0.15], [0.07, 0.28, 0.12], 15.0, 8.0), // left ventricle
    part([0.12, 0.05, 0.15], [0.07, 0.28, 0.12], -15.0, 8.0), // right ventricle
    part([0.0, 0.05, -0.05], [0.03, 0.10, 0.08], 0.0, 8.0), // third ventricle
    part([0.30, -0.30, 0.30], [0.12, 0.10, 0.11], 30.0, 70.0), // tumour
    part([0.30, -0.30, 0.30], [0.035, 0.035, 0.035], 0.0, 450.0), // calcification
    part([-0.35, 0.35, -0.10], [0.08, 0.06, 0.07], 0.0, 75.0), // haemorrhage
    part([-0.10, -0.45, 0.45], [0.05, 0.05, 0.05], 0.0, 45.0), // low-contrast lesion
    part([-0.55, 0.10, -0.35], [0.08, 0.12, 0.06], 0.0, 1300.0), // left petrous bone
    part([0.55, 0.10, -0.35], [0.08, 0.12, 0.06], 0.0, 1300.0), // right petrous bone
    part([-0.25, -0.78, -0.25], [0.10, 0.10, 0.10], 0.0, 15.0), // left eye
    part([0.25, -0.78, -0.25], [0.10, 0.10, 0.10], 0.0, 15.0), // right eye
    part([0.0, -0.72, -0.45], [0.16, 0.10, 0.10], 0.0, -900.0), // sinus
];

/// A part placed in voxel coordinates.
struct Placed {
    hu: f64,
    centre: [f64; 3],
    /// Inverse semi-axes, per voxel.
    inv_semi: [f64; 3],
    /// cos and sin of the turn about z.
    cos: f64,
    sin: f64,
    /// The shortest semi-axis in voxels: turns the normalised radius into
    /// a distance for the edge ramp.
    scale: f64,
    /// Half-widths of the box around the part and its edge, voxels.
    reach: [f64; 3],
}

impl Placed {
    /// How much of the voxel at offset `d` from the centre the part
    /// covers: 1 inside, 0 past the edge, a linear ramp across it.
    #[inline]
    fn cover(&self, d: [f64; 3]) -> f64 {
        let lx = self.cos * d[0] + self.sin * d[1];
        let ly = -self.sin * d[0] + self.cos * d[1];
        let u = [
            lx * self.inv_semi[0],
            ly * self.inv_semi[1],
            d[2] * self.inv_semi[2],
        ];
        let r = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        let dist = (r - 1.0) * self.scale;
        (0.5 - dist / PHANTOM_EDGE).clamp(0.0, 1.0)
    }
}

/// The CT-like head phantom (see the module docs).
pub struct PhantomScene {
    dims: Dims,
    seed: u64,
    parts: Vec<Placed>,
}

impl PhantomScene {
    /// The phantom filling `dims`, its noise drawn from `seed`.
    pub fn new(dims: Dims, seed: u64) -> Self {
        let d = dims.as_array();
        // Voxel centres run from 0 to n − 1: the normalised axis maps −1
        // and 1 onto the volume's outer faces.
        let half: [f64; 3] = std::array::from_fn(|a| d[a] as f64 / 2.0);
        let parts = PARTS
            .iter()
            .map(|p| {
                let semi: [f64; 3] = std::array::from_fn(|a| (p.semi[a] * half[a]).max(0.5));
                let (sin, cos) = p.turn.to_radians().sin_cos();
                let margin = PHANTOM_EDGE + 1.0;
                // The turned ellipse's bounding half-widths in x and y.
                let bx = ((semi[0] * cos).powi(2) + (semi[1] * sin).powi(2)).sqrt();
                let by = ((semi[0] * sin).powi(2) + (semi[1] * cos).powi(2)).sqrt();
                Placed {
                    hu: p.hu,
                    centre: std::array::from_fn(|a| half[a] * (1.0 + p.centre[a]) - 0.5),
                    inv_semi: semi.map(|s| 1.0 / s),
                    cos,
                    sin,
                    scale: semi[0].min(semi[1]).min(semi[2]),
                    reach: [bx + margin, by + margin, semi[2] + margin],
                }
            })
            .collect();
        PhantomScene { dims, seed, parts }
    }
}

/// Triangular noise of standard deviation [`PHANTOM_NOISE_SD`] from one
/// 64-bit hash (two 32-bit uniforms summed).
#[inline]
fn noise(h: u64) -> f64 {
    let u1 = (h >> 32) as f64 / 4_294_967_296.0;
    let u2 = (h & 0xFFFF_FFFF) as f64 / 4_294_967_296.0;
    // u1 + u2 − 1 is triangular on (−1, 1) with variance 1/6.
    (u1 + u2 - 1.0) * PHANTOM_NOISE_SD * 6f64.sqrt()
}

impl Scene for PhantomScene {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        let mut row = vec![PHANTOM_AIR as f64; out.len()];
        for p in &self.parts {
            let dy = y as f64 - p.centre[1];
            let dz = z as f64 - p.centre[2];
            if dy.abs() > p.reach[1] || dz.abs() > p.reach[2] {
                continue;
            }
            let a = (p.centre[0] - p.reach[0]).floor() as i64;
            let e = (p.centre[0] + p.reach[0]).ceil() as i64 + 1;
            let Some((a, e)) = clip(a, e, x0, out.len()) else {
                continue;
            };
            for (i, v) in row[a..e].iter_mut().enumerate() {
                let dx = (x0 + (a + i) as u64) as f64 - p.centre[0];
                let w = p.cover([dx, dy, dz]);
                if w > 0.0 {
                    *v += w * (p.hu - *v);
                }
            }
        }
        let base = self.dims.index(x0, y, z);
        for (i, (o, v)) in out.iter_mut().zip(&row).enumerate() {
            *o = (v + noise(hash64(self.seed, base + i as u64))) as f32;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: &PhantomScene, x: u64, y: u64, z: u64) -> f32 {
        let mut row = vec![0f32; 1];
        s.fill_row(x, y, z, &mut row);
        row[0]
    }

    #[test]
    fn tissues_sit_where_the_head_puts_them() {
        let d = Dims::new(128, 128, 128).unwrap();
        let s = PhantomScene::new(d, 1);
        // Away from edges a value is its tissue's within the noise's bound.
        let tol = (PHANTOM_NOISE_SD * 6f64.sqrt()) as f32 + 0.5;
        // Corner: air.
        assert!((at(&s, 0, 0, 0) - PHANTOM_AIR).abs() < tol);
        // Brain, above the third ventricle and between the others.
        assert!((at(&s, 64, 72, 80) - 35.0).abs() < tol);
        // The third ventricle: fluid, 27 HU below the brain.
        assert!((at(&s, 64, 66, 61) - 8.0).abs() < tol);
        // On the x axis, inside the skull's shell: bone.
        let x_skull = (64.0 * (1.0 + 0.665)) as u64;
        assert!(at(&s, x_skull, 64, 65) > 700.0);
        // The calcification's centre.
        let c = |n: f64| (64.0 * (1.0 + n) - 0.5).round() as u64;
        assert!((at(&s, c(0.30), c(-0.30), c(0.30)) - 450.0).abs() < tol);
        // The sinus: air inside the head.
        assert!(at(&s, c(0.0), c(-0.72), c(-0.45)) < -800.0);
    }

    #[test]
    fn noise_has_the_stated_spread_and_follows_the_seed() {
        let d = Dims::new(64, 64, 64).unwrap();
        let (a, b) = (PhantomScene::new(d, 1), PhantomScene::new(d, 2));
        let mut ra = vec![0f32; 64];
        let mut rb = vec![0f32; 64];
        let mut n = 0.0;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for z in 0..4 {
            for y in 0..4 {
                a.fill_row(0, y, z, &mut ra);
                b.fill_row(0, y, z, &mut rb);
                assert_ne!(ra, rb);
                for &v in ra.iter().take(4) {
                    let e = v as f64 - PHANTOM_AIR as f64;
                    sum += e;
                    sum2 += e * e;
                    n += 1.0;
                }
            }
        }
        let mean = sum / n;
        let sd = (sum2 / n - mean * mean).sqrt();
        assert!(mean.abs() < 4.0, "mean {mean}");
        assert!((sd - PHANTOM_NOISE_SD).abs() < 3.0, "sd {sd}");
        let bound = (PHANTOM_NOISE_SD * 6f64.sqrt()) as f32;
        assert!(ra.iter().all(|v| (v - PHANTOM_AIR).abs() <= bound));
    }

    #[test]
    fn edges_ramp_over_the_stated_width() {
        // Along +x from the centre, the values climb from brain to bone
        // over about PHANTOM_EDGE voxels, never overshooting either.
        let d = Dims::new(200, 200, 200).unwrap();
        let s = PhantomScene::new(d, 3);
        let mut row = vec![0f32; 200];
        s.fill_row(0, 100, 102, &mut row);
        let inner: f64 = 100.0 * (1.0 + 0.64) - 0.5;
        let lo = inner.floor() as usize - 3;
        let band: Vec<f32> = row[lo..lo + 7].to_vec();
        let tol = 4.0 * PHANTOM_NOISE_SD as f32;
        assert!((band[0] - 35.0).abs() < tol, "{band:?}");
        assert!((band[6] - 1100.0).abs() < tol, "{band:?}");
        let between = band
            .iter()
            .filter(|&&v| v > 35.0 + tol && v < 1100.0 - tol)
            .count();
        assert!((1..=3).contains(&between), "{band:?}");
    }
}
