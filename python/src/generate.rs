//! `volkit.generate`: vol-gen's procedural scenes, with vol-gen's scene
//! options (`volcore::scene::SceneSpec`, parsed by its own command-line
//! definition from the keyword arguments), generated into memory.

use crate::errors;
use crate::volume::{spacing_of, PyVolume};
use clap::{CommandFactory, FromArgMatches, Parser};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use serde_json::Value;
use volcore::region::RegionSource;
use volcore::scene::{Scene, SceneSource, SceneSpec};
use volcore::volume::IntoVolumeData;
use volcore::{Dims, Sample, SampleType, Volume};

/// vol-gen's scene options as a command line of their own.
#[derive(Parser, Debug)]
#[command(name = "vol-gen")]
struct GenArgs {
    #[command(flatten)]
    spec: SceneSpec,
}

/// Every sample of `scene` as `T`, x fastest, slices in parallel.
fn samples<T: Sample + IntoVolumeData>(scene: &dyn Scene, d: Dims) -> Result<Volume, String> {
    let src = SceneSource::<T>::new(scene);
    let (nx, ny) = (d.x as usize, d.y as usize);
    let mut out = vec![T::default(); d.count() as usize];
    out.par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(z, slab)| {
            for (y, row) in slab.chunks_exact_mut(nx).enumerate() {
                src.fill_row(0, y as u64, z as u64, row);
            }
        });
    Volume::from_samples(d, out).map_err(|e| e.to_string())
}

/// Generate vol-gen's procedural scene `scene` (shapes, spheres, noise,
/// solid, box, ramp, sphere, phantom) of `dims` voxels, in numpy order
/// (z, y, x), into memory: the same samples vol-gen writes. `type` is the
/// sample type (u8, u16, i16, f32; default u8, i16 for phantom),
/// `spacing` (z, y, x); `options` are vol-gen's scene options by its names
/// (seed, count, size, value, noise, period, octaves, margin, axis,
/// radius, edge), checked as vol-gen checks them. Save it with `save`.
#[pyfunction]
#[pyo3(signature = (scene, dims, *, r#type=None, spacing=None, **options))]
pub fn generate(
    py: Python<'_>,
    scene: &str,
    dims: [u64; 3],
    r#type: Option<&str>,
    spacing: Option<[f64; 3]>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyVolume> {
    crate::guard(|| {
        let mut pairs = vec![("scene".to_string(), Value::String(scene.to_string()))];
        pairs.extend(crate::value::pairs(options)?);
        let cmd = GenArgs::command();
        let (args, _) = volscene::pairs::command_args(&cmd, pairs).map_err(errors::scene)?;
        let argv = std::iter::once("vol-gen".to_string()).chain(args);
        let matches = cmd
            .try_get_matches_from(argv)
            .map_err(|e| errors::value(volscene::request::clap_message(&e)))?;
        let spec = GenArgs::from_arg_matches(&matches)
            .map_err(|e| errors::value(volscene::request::clap_message(&e)))?
            .spec;
        let [z, y, x] = dims;
        let d = Dims::new(x, y, z).map_err(|e| errors::value(format!("dims: {e}")))?;
        let asked = r#type
            .map(|t| t.parse::<SampleType>())
            .transpose()
            .map_err(|e| errors::value(format!("type: {e}")))?;
        let t = spec.sample_type(asked);
        spec.validate(t, d).map_err(errors::value)?;
        let spacing = spacing.map(spacing_of).transpose()?;
        let vol = crate::run(
            py,
            || {},
            || {
                let scene = spec.build(d);
                match t {
                    SampleType::U8 => samples::<u8>(scene.as_ref(), d),
                    SampleType::U16 => samples::<u16>(scene.as_ref(), d),
                    SampleType::I16 => samples::<i16>(scene.as_ref(), d),
                    SampleType::F32 => samples::<f32>(scene.as_ref(), d),
                    SampleType::F64 => Err(
                        "type f64: volumes in memory hold f64 as f32, so generate f32".to_string(),
                    ),
                }
            },
        )?;
        let mut vol = vol.map_err(errors::value)?;
        if let Some(s) = spacing {
            vol.meta.spacing = s;
        }
        Ok(PyVolume { vol, file: None })
    })
}
