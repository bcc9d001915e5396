//! Blinn-Phong lighting for shaded samples and surfaces.

use glam::Vec3;

/// A Blinn-Phong model with one directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// Unit direction towards the light, or `None` for a headlight (the
    /// light sits at the eye, so it comes from each ray's origin).
    pub light_dir: Option<Vec3>,
    /// Ambient weight.
    pub ambient: f32,
    /// Diffuse weight.
    pub diffuse: f32,
    /// Specular weight.
    pub specular: f32,
    /// Specular exponent.
    pub shininess: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting {
            light_dir: None,
            ambient: 0.25,
            diffuse: 0.65,
            specular: 0.35,
            shininess: 24.0,
        }
    }
}

impl Lighting {
    /// Shade `colour` at a point with (unnormalised) gradient `grad`, seen
    /// along unit `view_dir` (from the eye into the scene). Two-sided: the
    /// normal is flipped to face the viewer. `grad` must be nonzero.
    #[inline(always)]
    pub fn shade(&self, colour: Vec3, grad: Vec3, view_dir: Vec3) -> Vec3 {
        let to_eye = -view_dir;
        let mut n = -grad.normalize_or_zero();
        if n.dot(to_eye) < 0.0 {
            n = -n;
        }
        let l = self.light_dir.unwrap_or(to_eye);
        let diff = n.dot(l).max(0.0);
        let h = (l + to_eye).normalize_or_zero();
        let spec = if diff > 0.0 {
            let c = n.dot(h).max(0.0);
            // Whole exponents (the usual case) by multiplication, not powf.
            if self.shininess.fract() == 0.0 && (0.0..=256.0).contains(&self.shininess) {
                pow_whole(c, self.shininess as u32)
            } else {
                c.powf(self.shininess)
            }
        } else {
            0.0
        };
        colour * (self.ambient + self.diffuse * diff) + Vec3::splat(self.specular * spec)
    }
}

/// `x^n` by repeated squaring, inline (`powi` with an exponent known only
/// at run time becomes a library call).
#[inline(always)]
fn pow_whole(mut x: f32, mut n: u32) -> f32 {
    let mut r = 1.0;
    while n > 0 {
        if n & 1 == 1 {
            r *= x;
        }
        x *= x;
        n >>= 1;
    }
    r
}
