//! The ray-casting study's set-up: its scenes (how each volume is made
//! and looked at), the values swept per knob, and the base and reference
//! settings.

use crate::drive::strs;

/// One scene of a study: how to make the volume and how to look at it.
pub struct Scene {
    /// Short name used in file names and the CSV.
    pub name: &'static str,
    /// vol-gen arguments (without -o).
    pub gen: Vec<String>,
    /// vol-render arguments shared by every render of this scene.
    pub view: Vec<String>,
    /// Transfer function file contents to write, or None for a preset.
    pub tf_file: Option<&'static str>,
    /// Also study shadows and ambient occlusion (as the scenes
    /// `NAME-shadows` and `NAME-ao`).
    pub effects: bool,
    /// Its transfer function is 1D: the step is swept pre-integrated too,
    /// and adaptive steps' tolerance is swept.
    pub tf_1d: bool,
}

/// The values swept for each knob.
pub struct Sweep {
    /// Steps, swept as they are and (1D transfer functions) with
    /// `--preintegrated`.
    pub step: Vec<&'static str>,
    /// Tolerances of adaptive steps (`--adaptive`), each at
    /// [`ADAPTIVE_STEP`] (scenes with a 1D transfer function).
    pub adaptive: Vec<&'static str>,
    /// Frame-time budgets, seconds (`--budget`, at base step
    /// [`BASE_STEP`]: steps from a quarter to 8 times it).
    pub budget: Vec<&'static str>,
    pub ert: Vec<&'static str>,
    pub cell: Vec<&'static str>,
    pub tile: Vec<&'static str>,
    pub threads: Vec<&'static str>,
    /// Shadow-ray steps and light-grid divisors (scenes with `shadows`).
    pub shadow_steps: Vec<&'static str>,
    pub shadow_grids: Vec<&'static str>,
    /// AO directions sampled and field directions (scenes with effects).
    pub ao_rays: Vec<&'static str>,
    pub ao_fields: Vec<&'static str>,
    /// Spacings of a 32-direction field's points, voxels (the default 8
    /// is the `AO field` panel's K = 32 point).
    pub ao_field_cells: Vec<&'static str>,
}

/// The noise scene's transfer function: empty below 110, a thin blue haze
/// up to 150, an orange shell from 150 to 190, opaque white cores above.
pub const NOISE_TF: &str = "# vol-accuracy: transfer function for the noise scene
domain 0 255
step 1
point 0   0 0 0 0
point 110 0 0 0 0
point 150 40 90 220 0.02
point 170 240 150 40 0.15
point 200 250 240 220 0.5
point 255 255 255 255 0.9
";

/// A setting with a full-study and a quick-study value.
pub struct FullQuick {
    /// The full study's value.
    pub full: &'static str,
    /// The quick study's value.
    pub quick: &'static str,
}

impl FullQuick {
    /// The value for a quick (or full) study.
    pub fn pick(&self, quick: bool) -> &'static str {
        if quick {
            self.quick
        } else {
            self.full
        }
    }
}

/// Base settings of every render that is not the reference.
pub const BASE_STEP: &str = "0.2";
pub const BASE_ERT: &str = "0.99";
/// The step adaptive steps refine from: the finest of the step sweep, so
/// the tolerance alone sets how far strides coarsen it.
pub const ADAPTIVE_STEP: &str = "0.05";
/// Reference step.
pub const REF_STEP: FullQuick = FullQuick {
    full: "0.01",
    quick: "0.02",
};
/// Light for the effect studies: one directional light.
pub const SHADOW_LIGHT: &str = "1,2,0.5";
/// The shadow study's reference shadow step.
pub const SHADOW_REF_STEP: FullQuick = FullQuick {
    full: "0.05",
    quick: "0.1",
};
/// Ambient light of the AO study (strong, so occlusion shows).
pub const AO_AMBIENT: &str = "0.6";
/// The AO study's reference: directions per shaded sample.
pub const AO_REF_RAYS: FullQuick = FullQuick {
    full: "256",
    quick: "64",
};

/// The default (or quick) scenes and the values swept.
pub fn study(quick: bool) -> (Vec<Scene>, Sweep) {
    // The thesis scene is 800³ with shapes of size 70 and the eye at
    // (1100, 1100, 1100) looking at the origin; scale all three together.
    let (n, size, img, noise_n, ct_n) = if quick {
        (48u32, 4u32, "64x64", 48u32, 48u32)
    } else {
        (256, 22, "256x256", 128, 192)
    };
    let eye = (1100.0 * f64::from(n) / 800.0).round();
    let thesis = Scene {
        name: "thesis",
        gen: strs(&["shapes", "--seed", "2", "--count", "70", "--value", "100"])
            .into_iter()
            .chain([
                "--size".into(),
                size.to_string(),
                "--dims".into(),
                format!("{n},{n},{n}"),
            ])
            .collect(),
        view: vec![
            "--tf".into(),
            "shapes".into(),
            "--shading".into(),
            "phong".into(),
            "--eye".into(),
            format!("{eye},{eye},{eye}"),
            "--look-at".into(),
            "0,0,0".into(),
            "--fov".into(),
            "60".into(),
            "--size".into(),
            img.into(),
        ],
        tf_file: None,
        effects: true,
        tf_1d: true,
    };
    let noise = Scene {
        name: "noise",
        gen: vec![
            "noise".into(),
            "--dims".into(),
            format!("{noise_n},{noise_n},{noise_n}"),
        ],
        view: vec![
            "--shading".into(),
            "phong".into(),
            "--size".into(),
            img.into(),
        ],
        tf_file: Some(NOISE_TF),
        effects: false,
        tf_1d: true,
    };
    // The same kind of volume through a 2D transfer function: the
    // boundary preset (opacity rising with the gradient magnitude), whose
    // classification reads a gradient at every sample.
    let boundary = Scene {
        name: "boundary",
        gen: vec![
            "noise".into(),
            "--dims".into(),
            format!("{noise_n},{noise_n},{noise_n}"),
        ],
        view: vec![
            "--tf".into(),
            "boundary".into(),
            "--shading".into(),
            "phong".into(),
            "--size".into(),
            img.into(),
        ],
        tf_file: None,
        effects: false,
        tf_1d: false,
    };
    // A CT-like head (air, skin, a closed skull, brain, small lesions, in
    // Hounsfield units with noise) through the `ct` preset: dense where
    // the thesis scene is sparse, so shadow and occlusion rays cross
    // semi-transparent tissue and stop in bone.
    let ct = Scene {
        name: "ct",
        gen: vec![
            "phantom".into(),
            "--dims".into(),
            format!("{ct_n},{ct_n},{ct_n}"),
        ],
        view: vec![
            "--tf".into(),
            "ct".into(),
            "--shading".into(),
            "phong".into(),
            // The head's long axis is z: look at its face from 30 degrees
            // to the side, close enough for the head to fill the frame.
            "--up".into(),
            "0,0,1".into(),
            "--orbit".into(),
            format!("30,15,{:.0}", 1.1 * 3f64.sqrt() * f64::from(ct_n - 1)),
            "--size".into(),
            img.into(),
        ],
        tf_file: None,
        effects: true,
        tf_1d: true,
    };
    let sweep = if quick {
        Sweep {
            step: vec!["0.05", "0.2", "0.8", "1.6"],
            adaptive: vec!["0.01", "0.1"],
            budget: vec!["0.01", "0.04"],
            ert: vec!["0.9", "0.99", "off"],
            cell: vec!["4", "16"],
            tile: vec!["8", "32"],
            threads: vec!["1", "2"],
            shadow_steps: vec!["0.5", "2"],
            shadow_grids: vec!["2", "4"],
            ao_rays: vec!["4", "16"],
            ao_fields: vec!["16", "32"],
            ao_field_cells: vec!["4"],
        }
    } else {
        Sweep {
            step: vec!["0.05", "0.1", "0.2", "0.4", "0.8", "1.6"],
            adaptive: vec!["0.001", "0.003", "0.01", "0.03", "0.1", "0.3"],
            budget: vec!["0.005", "0.01", "0.02", "0.04", "0.08", "0.16", "0.32"],
            ert: vec!["0.9", "0.95", "0.99", "0.999", "off"],
            cell: vec!["4", "8", "16", "32"],
            tile: vec!["8", "16", "32", "64"],
            threads: vec!["1", "2"],
            shadow_steps: vec!["0.2", "0.5", "1", "2"],
            shadow_grids: vec!["1", "2", "4"],
            ao_rays: vec!["4", "8", "16", "32"],
            ao_fields: vec!["16", "32", "64"],
            ao_field_cells: vec!["2", "4", "16"],
        }
    };
    (vec![thesis, noise, boundary, ct], sweep)
}
