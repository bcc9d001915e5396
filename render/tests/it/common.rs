//! The scene the effect tests (shadows, ambient occlusion) share: a small
//! shapes volume with its index, seen by an orbit camera.

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{Scene, SceneSource, ShapesScene};
use volcore::{Dims, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::{Camera, Projection};

/// 48 × 40 × 44 voxels of 12 shapes, and its index.
pub fn shapes() -> (Volume, MinMaxIndex) {
    let scene = ShapesScene::new(Dims::new(48, 40, 44).unwrap(), 2, 12, 14, 100.0);
    let v =
        Volume::from_samples(scene.dims(), pack_sliced(&SceneSource::<u8>::new(&scene))).unwrap();
    let ix = MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap();
    (v, ix)
}

/// A 40 × 36 perspective view of [`shapes`] from outside.
pub fn orbit_camera() -> Camera {
    Camera::orbit(
        Vec3::new(24.0, 20.0, 22.0),
        30.0,
        25.0,
        110.0,
        Projection::Perspective(40.0),
        40,
        36,
    )
    .unwrap()
}
