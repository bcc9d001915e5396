//! Sort-last data-parallel rendering in one process: the volume split
//! among N ranks' boxes, each box's share of every ray rendered on its
//! own, the films composited front to back in the split's order, against
//! the single frame. MIP, MinIP and iso-surfaces are bit for bit the same
//! for any N and any camera (inside the volume too); DVR and X-ray change
//! only the order of floating-point additions (segments are summed, then
//! combined), which costs no more than rounding: PSNR >= 60 dB; with
//! early ray termination, which each share applies on its own, a pixel may
//! keep up to 1 - threshold more of what lies behind (still >= 60 dB).

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{SceneSource, ShapesScene};
use volcore::{Dims, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::distributed::Fields;
use volrender::distributed::{composite_for, strip_rows, Split};
use volrender::film::Film;
use volrender::frame::{busy_cells, render_film};
use volrender::tf::{Tf, TransferFunction};
use volrender::{render_tf, Camera, Frame, Mode, Projection, RenderSettings};

/// Block edge of the split (voxels).
const BLOCK: u64 = 8;

fn scene() -> (Volume, MinMaxIndex) {
    let dims = Dims::new(64, 56, 72).unwrap();
    let s = ShapesScene::new(dims, 5, 14, 9, 100.0);
    let v = Volume::from_samples(dims, pack_sliced(&SceneSource::<u8>::new(&s))).unwrap();
    let ix = MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap();
    (v, ix)
}

fn cameras() -> Vec<(&'static str, Camera)> {
    let cam = |eye: Vec3, at: Vec3, p| Camera::look_at(eye, at, Vec3::Y, p, 96, 80).unwrap();
    vec![
        (
            "outside",
            cam(
                Vec3::new(140.0, 90.0, 160.0),
                Vec3::new(32.0, 28.0, 36.0),
                Projection::Perspective(40.0),
            ),
        ),
        (
            "inside",
            cam(
                Vec3::new(20.0, 30.0, 25.0),
                Vec3::new(60.0, 40.0, 70.0),
                Projection::Perspective(70.0),
            ),
        ),
        (
            "orthographic",
            cam(
                Vec3::new(-60.0, 20.0, 30.0),
                Vec3::new(32.0, 28.0, 36.0),
                Projection::Orthographic(90.0),
            ),
        ),
    ]
}

/// The frame rendered as `ranks` shares composited front to back, as the
/// MPI driver does it: the split weighted by the frame's busy cells, each
/// rank's film cut into row strips that travel as bytes (direct send),
/// each strip composited from every rank's, the strips gathered as bytes.
fn data_parallel(
    v: &Volume,
    ix: &MinMaxIndex,
    tf: &Tf,
    cam: &Camera,
    s: &RenderSettings,
    ranks: usize,
) -> Frame {
    let busy = busy_cells(v, ix, Some(tf), s).unwrap();
    let cell = u64::from(ix.cell_edge());
    let layout = Split::new(
        v.dims(),
        v.meta.spacing,
        BLOCK,
        Some((&busy, cell)),
        ranks,
        Some(cam),
    );
    let mut display = None;
    let films: Vec<Film> = (0..ranks)
        .map(|r| match layout.share(r) {
            Some(share) => {
                let (film, d) = render_film(v, Some(ix), Some(tf), cam, s, Some(&share)).unwrap();
                display = Some(d);
                film
            }
            None => Film::new(cam.width(), cam.height()),
        })
        .collect();
    let order = layout.front_to_back(cam);
    let how = composite_for(s.mode).unwrap();
    let fields = Fields::for_composite(how);
    let h = cam.height();
    let mut film = Film::new(cam.width(), h);
    for j in 0..ranks {
        let rows = strip_rows(h, ranks, j);
        let parts: Vec<Vec<u8>> = films
            .iter()
            .map(|f| {
                let mut bytes = Vec::new();
                f.encode_rows(rows.clone(), fields, &mut bytes);
                bytes
            })
            .collect();
        let ordered: Vec<&[u8]> = order.iter().map(|&r| &parts[r][..]).collect();
        let pixels = rows.len() * cam.width() as usize;
        let mut strip = Vec::new();
        Film::composite_records(&ordered, pixels, fields, how, &mut strip).unwrap();
        film.decode_rows(rows, fields, &strip).unwrap();
    }
    film.resolve(display.unwrap(), Vec3::ZERO)
}

fn psnr(a: &Frame, b: &Frame) -> f64 {
    let mut se = 0.0f64;
    let mut n = 0.0;
    for (p, q) in a.rgba.iter().zip(&b.rgba) {
        for c in 0..3 {
            se += (f64::from(p[c]) - f64::from(q[c])).powi(2);
            n += 1.0;
        }
    }
    if se == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (n / se).log10()
    }
}

fn same_bits(a: &Frame, b: &Frame) -> bool {
    let bits = |f: &Frame| -> Vec<u32> {
        f.rgba
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .chain(f.value.iter().map(|v| (*v as f32).to_bits()))
            .chain(f.depth.iter().map(|d| d.to_bits()))
            .collect()
    };
    bits(a) == bits(b)
}

#[test]
fn shares_composited_equal_the_single_frame() {
    let (v, ix) = scene();
    let tf = Tf::OneD(TransferFunction::preset("shapes", (0.0, 255.0)).unwrap());
    let base = RenderSettings {
        step: 0.4,
        ..Default::default()
    };
    let modes = [
        (
            "mip",
            RenderSettings {
                mode: Mode::Mip,
                ..base.clone()
            },
        ),
        (
            "minip",
            RenderSettings {
                mode: Mode::Minip,
                ..base.clone()
            },
        ),
        (
            "iso",
            RenderSettings {
                mode: Mode::Iso(50.0),
                ..base.clone()
            },
        ),
        (
            "iso-phong-noess",
            RenderSettings {
                mode: Mode::Iso(80.0),
                shading: true,
                ess: false,
                ..base.clone()
            },
        ),
        (
            "xray",
            RenderSettings {
                mode: Mode::XraySum,
                ..base.clone()
            },
        ),
        // Early termination per share: a back share does not know the
        // opacity in front of it and runs on where the whole ray would
        // have stopped, so a pixel may differ by up to 1 - threshold of
        // its colour (73-197 dB on these cameras).
        (
            "dvr-ert",
            RenderSettings {
                shading: true,
                ..base.clone()
            },
        ),
        (
            "dvr-phong",
            RenderSettings {
                shading: true,
                ert: None,
                ..base.clone()
            },
        ),
        // A share's first sample reads the sample before it, so its
        // segment is composited once, by the share that holds its end.
        (
            "dvr-preintegrated",
            RenderSettings {
                ert: None,
                preintegrated: true,
                ..base.clone()
            },
        ),
    ];
    for (cname, cam) in cameras() {
        for (mname, s) in &modes {
            let whole = render_tf(&v, Some(&ix), Some(&tf), &cam, s).unwrap();
            let lit = (0..whole.rgba.len())
                .filter(|&i| whole.rgba[i][3] > 0.0 || !whole.value[i].is_nan())
                .count();
            assert!(
                lit > 100,
                "{cname} {mname}: only {lit} pixels show the volume"
            );
            for ranks in [1, 2, 3, 4, 7] {
                let got = data_parallel(&v, &ix, &tf, &cam, s, ranks);
                let what = format!("{cname} {mname} on {ranks} ranks");
                match s.mode {
                    Mode::Dvr | Mode::XraySum => {
                        let db = psnr(&got, &whole);
                        println!("{what}: {db:.1} dB");
                        assert!(db >= 60.0, "{what}: {db:.1} dB");
                    }
                    _ => assert!(same_bits(&got, &whole), "{what}: not bit for bit"),
                }
                if ranks == 1 {
                    assert!(same_bits(&got, &whole), "{what}: one share is the frame");
                }
            }
        }
    }
}
