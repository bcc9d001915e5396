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
        self.for_view(view_dir)
            .shade_normal(colour, grad.normalize_or_zero())
    }

    /// What shading along one viewing direction needs, worked out once per
    /// ray rather than per sample.
    #[inline(always)]
    pub fn for_view(&self, view_dir: Vec3) -> ViewLight {
        let to_eye = -view_dir;
        let l = self.light_dir.unwrap_or(to_eye);
        let whole = self.shininess.fract() == 0.0 && (0.0..=256.0).contains(&self.shininess);
        ViewLight {
            model: *self,
            to_eye,
            l,
            h: (l + to_eye).normalize_or_zero(),
            whole_exponent: whole.then_some(self.shininess as u32),
        }
    }
}

/// Blinn-Phong for one viewing direction (see [`Lighting::for_view`]).
#[derive(Clone, Copy, Debug)]
pub struct ViewLight {
    model: Lighting,
    /// Unit vector towards the eye.
    to_eye: Vec3,
    /// Unit vector towards the light.
    l: Vec3,
    /// The half vector.
    h: Vec3,
    /// The specular exponent when it is a whole number up to 256 (the
    /// usual case: then by multiplication, not `powf`).
    whole_exponent: Option<u32>,
}

impl ViewLight {
    /// Shade `colour` at a point whose unit gradient is `unit_grad` (or
    /// zero). Two-sided: the normal is flipped to face the viewer.
    #[inline(always)]
    pub fn shade_normal(&self, colour: Vec3, unit_grad: Vec3) -> Vec3 {
        let m = &self.model;
        let mut n = -unit_grad;
        if n.dot(self.to_eye) < 0.0 {
            n = -n;
        }
        let diff = n.dot(self.l).max(0.0);
        let spec = if diff > 0.0 {
            let c = n.dot(self.h).max(0.0);
            match self.whole_exponent {
                Some(e) => pow_whole(c, e),
                None => c.powf(m.shininess),
            }
        } else {
            0.0
        };
        colour * (m.ambient + m.diffuse * diff) + Vec3::splat(m.specular * spec)
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
