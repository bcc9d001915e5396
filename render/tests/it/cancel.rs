//! Cancellation: a raised [`Cancel`] flag stops a frame before its tiles
//! and a path-tracing render before its next pass, with
//! `RenderError::Cancelled`; a flag never raised changes nothing.

use crate::common;

use glam::Vec3;
use volrender::film::PathFilm;
use volrender::path::{Budget, MajorantMode, MediumSpec, PathLights, PathSettings, PathTracer};
use volrender::{render_tf, Cancel, Mode, RenderError, RenderSettings, Tf, TransferFunction};

#[test]
fn a_raised_flag_stops_a_frame_and_an_idle_one_changes_nothing() {
    let (v, ix) = common::shapes();
    let cam = common::orbit_camera();
    let tf = Tf::OneD(TransferFunction::preset("shapes", (0.0, 255.0)).unwrap());
    for mode in [Mode::Dvr, Mode::Mip, Mode::XraySum, Mode::Iso(50.0)] {
        let plain = RenderSettings {
            mode,
            step: 0.5,
            ..Default::default()
        };
        let idle = RenderSettings {
            cancel: Cancel::new(),
            ..plain.clone()
        };
        let a = render_tf(&v, Some(&ix), Some(&tf), &cam, &plain).unwrap();
        let b = render_tf(&v, Some(&ix), Some(&tf), &cam, &idle).unwrap();
        assert_eq!(a.rgba, b.rgba, "{mode:?}");
        let raised = Cancel::new();
        raised.cancel();
        let stopped = RenderSettings {
            cancel: raised.clone(),
            ..plain
        };
        let r = render_tf(&v, Some(&ix), Some(&tf), &cam, &stopped);
        assert!(matches!(r, Err(RenderError::Cancelled)), "{mode:?}");
        // Clones share the flag.
        assert!(raised.clone().is_cancelled());
    }
}

#[test]
fn a_flag_raised_after_a_pass_stops_the_path_tracer_there() {
    let (v, ix) = common::shapes();
    let cam = common::orbit_camera();
    let s = PathSettings {
        medium: MediumSpec::Density {
            scale: 0.02,
            albedo: Vec3::splat(0.8),
        },
        bounces: 4,
        g: 0.0,
        hybrid: None,
        majorant: MajorantMode::Grid,
        lights: PathLights {
            env: Vec3::splat(1.0),
            ..Default::default()
        },
        background: None,
        seed: 3,
        sampler: Default::default(),
        transmittance: Default::default(),
    };
    let cancel = Cancel::new();
    let pt = PathTracer::new(&v, &ix, &cam, &s)
        .unwrap()
        .with_cancel(cancel.clone());
    let mut acc = PathFilm::new(cam.width(), cam.height(), pt.key(0));
    let budget = Budget {
        spp: Some(64),
        ..Default::default()
    };
    let mut passes = 0;
    let r = pt.render(&mut acc, &budget, |_, _| {
        passes += 1;
        cancel.cancel();
    });
    assert!(matches!(r, Err(RenderError::Cancelled)));
    assert_eq!(passes, 1);
    // The first pass (a sixteenth of the count) stays, whole.
    assert_eq!(acc.spp(), 4);
}
