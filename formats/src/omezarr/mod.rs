//! OME-Zarr (NGFF) through `zarrs`: read and write NGFF 0.4 (Zarr v2)
//! and 0.5 (Zarr v3) images, written with a multiscale pyramid.
//!
//! Reading takes a dataset of the first multiscale (`--level N`, the
//! full resolution by default; its origin moved along the volume's axis
//! directions by what its translation adds to level 0's); `t` and
//! `c` axes are fixed with `--time-point` and `--channel` (required when longer
//! than one); the `z`, `y`, `x` axes give the volume (a missing `z` is one
//! slice). Spacing and origin come from the dataset's `scale` and
//! `translation` transformations (the multiscale's own ones applied
//! after); the axis directions volkit writes in its `volkit` attribute are
//! restored (NGFF has no rotations).
//!
//! Writing streams: slabs of whole chunk layers go out as they arrive,
//! and each pyramid level is computed from the slices of the level above
//! while they pass (the mean or max of the full-resolution voxels a
//! level's voxel stands for, kept as f64 sums between levels and rounded
//! once), so memory stays at one chunk layer and one f64 slice per
//! level. A level halves the axes less than twice as coarse as the
//! finest (`pyramid.rs`), so anisotropic data grows isotropic down the
//! pyramid; each level's scale records it. Chunks are zstd-compressed.
//!
//! Here: the metadata both sides share (the NGFF version, the pyramid's
//! downsampling, the group attributes of `.zattrs` or `zarr.json` and
//! their transformations); reading in `read.rs`, writing in `write.rs`.

mod pyramid;
mod read;
mod write;

pub use pyramid::{check_levels, halved_axes, max_levels, plan, LevelShape};
pub use read::{levels, open, stacks, LevelInfo, ZarrReader, MAX_CHUNK_BYTES, MAX_SLAB_BYTES};
pub(crate) use write::file_name;
pub use write::{multiscales, shard_slices, StoreSpec, ZarrWriter, SHARDS_DIR};

use crate::error::Error;
use serde_json::Value;
use std::path::Path;

/// Chunk edge of written arrays (voxels; smaller along short axes).
pub const CHUNK: u64 = 64;

/// Which NGFF version (and so which Zarr format) a writer produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Ngff {
    /// NGFF 0.4 on Zarr v2 (`.zgroup`, `.zattrs`, `.zarray`, chunks
    /// under `/`-separated keys): what napari-ome-zarr, Fiji's readers
    /// and every ome-zarr-py release read, so the default.
    #[default]
    V04,
    /// NGFF 0.5 on Zarr v3 (`zarr.json`, attributes under `ome`): read by
    /// ome-zarr-py 0.10 and later (zarr-python 3).
    V05,
}

impl Ngff {
    /// The version as NGFF writes it (`"0.4"`, `"0.5"`).
    pub fn version(self) -> &'static str {
        match self {
            Ngff::V04 => "0.4",
            Ngff::V05 => "0.5",
        }
    }
}

impl std::str::FromStr for Ngff {
    type Err = String;
    /// `0.4` or `0.5`.
    fn from_str(s: &str) -> std::result::Result<Ngff, String> {
        match s {
            "0.4" => Ok(Ngff::V04),
            "0.5" => Ok(Ngff::V05),
            other => Err(format!("'{other}' is not 0.4 or 0.5")),
        }
    }
}

/// How a pyramid level is computed from the one above.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Downsample {
    /// Mean of each 2×2×2 block (rounded for integers).
    #[default]
    Mean,
    /// Maximum of each block (keeps thin bright structures).
    Max,
}

impl std::str::FromStr for Downsample {
    type Err = String;
    /// `mean` or `max`.
    fn from_str(s: &str) -> std::result::Result<Downsample, String> {
        match s {
            "mean" => Ok(Downsample::Mean),
            "max" => Ok(Downsample::Max),
            other => Err(format!("'{other}' is not mean or max")),
        }
    }
}

fn zerr(e: impl std::fmt::Display) -> Error {
    Error::invalid(format!("zarr: {e}"))
}

/// Whether `path` is (or names) an OME-Zarr: a `.zarr` name, or a
/// directory holding Zarr metadata (a level's array too, which the
/// reader refuses naming its store and `--level`).
pub fn is_zarr(path: &Path) -> bool {
    let name = path
        .to_string_lossy()
        .trim_end_matches('/')
        .to_ascii_lowercase();
    name.ends_with(".zarr")
        || (path.is_dir()
            && (path.join("zarr.json").is_file()
                || path.join(".zattrs").is_file()
                || path.join(".zarray").is_file()
                || path.join(".zgroup").is_file()))
}

/// Whether `path` is a directory holding an OME-Zarr image: group
/// attributes (`.zattrs`, or `zarr.json` of NGFF 0.5) with `multiscales`.
/// What a write of the same name replaces; any other directory is not
/// its to replace.
pub fn is_image_store(path: &Path) -> bool {
    path.is_dir() && ome_attributes(path).is_some_and(|(a, _)| a.get("multiscales").is_some())
}

fn read_json(p: &Path) -> Option<Value> {
    serde_json::from_slice(&std::fs::read(p).ok()?).ok()
}

/// The group attributes: `zarr.json` (v3; NGFF 0.5 nests them under
/// `ome`) or `.zattrs` (v2, NGFF 0.4).
fn ome_attributes(root: &Path) -> Option<(Value, &'static str)> {
    if let Some(j) = read_json(&root.join("zarr.json")) {
        let a = j.get("attributes")?;
        let mut o = a.get("ome").cloned().unwrap_or_else(|| a.clone());
        if let (Some(obj), Some(v)) = (o.as_object_mut(), a.get("volkit")) {
            obj.insert("volkit".into(), v.clone());
        }
        return Some((o, "0.5"));
    }
    read_json(&root.join(".zattrs")).map(|a| (a, "0.4"))
}

fn floats(v: &Value) -> Option<Vec<f64>> {
    v.as_array()?.iter().map(|x| x.as_f64()).collect()
}

/// `scale` and `translation` of a list of coordinate transformations.
fn transforms(v: Option<&Value>, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut scale = vec![1.0; n];
    let mut trans = vec![0.0; n];
    for t in v.and_then(|v| v.as_array()).into_iter().flatten() {
        match t.get("type").and_then(|x| x.as_str()) {
            Some("scale") => {
                if let Some(s) = t.get("scale").and_then(floats).filter(|s| s.len() == n) {
                    scale = s;
                }
            }
            Some("translation") => {
                if let Some(s) = t
                    .get("translation")
                    .and_then(floats)
                    .filter(|s| s.len() == n)
                {
                    trans = s;
                }
            }
            _ => {}
        }
    }
    (scale, trans)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reader::SliceReader;
    use serde_json::json;
    use std::sync::Arc;
    use volcore::{Dims, Geometry};
    use zarrs::array::Array;
    use zarrs::filesystem::FilesystemStore;

    /// Write a 70x5x67 u16 volume with three levels in `ngff`'s layout.
    /// The test volume's value at voxel (x, y, z).
    fn val(x: u64, y: u64, z: u64) -> u16 {
        (x + 100 * y + 1000 * z) as u16
    }

    fn write_pyramid(p: &Path, ngff: Ngff) -> (Dims, Geometry) {
        let dims = Dims::new(70, 5, 67).unwrap();
        let g = Geometry::from_axes(
            [1.0, 2.0, 3.0],
            [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        )
        .unwrap();
        let mut w =
            ZarrWriter::<u16>::create(p, dims, [0.5, 0.5, 2.0], &g, 3, Downsample::Mean, ngff)
                .unwrap();
        for z in 0..dims.z {
            let s: Vec<u16> = (0..dims.y)
                .flat_map(|y| (0..dims.x).map(move |x| val(x, y, z)))
                .collect();
            w.push(s).unwrap();
        }
        w.finish().unwrap();
        (dims, g)
    }

    /// Read back values, geometry and the level-1 mean of a written pyramid.
    fn check_pyramid(p: &Path, dims: Dims, g: &Geometry) {
        let r = open(p, None, None, None).unwrap();
        assert_eq!(r.info().dims, dims);
        assert_eq!(r.info().spacing, Some([0.5, 0.5, 2.0]));
        assert_eq!(&r.info().geometry, g);
        for z in [0, 63, 64, 66] {
            let s = r.read_slice(z).unwrap();
            assert_eq!(s.value((3 * 70 + 69) as usize), val(69, 3, z) as f64);
        }
        // z (2) is four times as coarse as x and y (0.5): level 1 halves
        // x and y alone, so (0,0,0) averages x 0..2, y 0..2 of slice 0.
        let a = Array::open(Arc::new(FilesystemStore::new(p).unwrap()), "/1").unwrap();
        assert_eq!(a.shape(), &[67, 3, 35]);
        let v: Vec<u16> = a
            .retrieve_array_subset::<Vec<u16>>(&[0..1, 0..1, 0..1])
            .unwrap();
        assert_eq!(v[0], (0.5f64 + 50.0).round() as u16);
    }

    /// The error reading slice 0 of the store at `p` gives.
    fn first_slice_error(p: &Path) -> String {
        let r = open(p, None, None, None).unwrap();
        match r.read_slice(0) {
            Ok(_) => panic!("a bad chunk read as data"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn chunk_decompressing_past_one_chunk_is_refused_for_both_versions() {
        for ngff in [Ngff::V04, Ngff::V05] {
            let dir = tempfile::tempdir().unwrap();
            let p = dir.path().join("v.ome.zarr");
            write_pyramid(&p, ngff);
            // Level 0's chunks are 64x5x64 u16 (40960 bytes); this zstd
            // frame of 16 MiB of zeros takes a few hundred bytes.
            let bomb = zstd::bulk::compress(&vec![0u8; 16 << 20], 3).unwrap();
            let chunk = match ngff {
                Ngff::V04 => p.join("0/0/0/0"),
                Ngff::V05 => p.join("0/c/0/0/0"),
            };
            assert!(chunk.is_file(), "{}", chunk.display());
            std::fs::write(&chunk, &bomb).unwrap();
            let e = first_slice_error(&p);
            assert!(e.contains("v.ome.zarr"), "{e}");
            assert!(
                e.contains("chunk [0, 0, 0]") && e.contains("more than the 40960 bytes"),
                "{e}"
            );
        }
    }

    #[test]
    fn chunk_stored_in_more_bytes_than_its_codecs_make_is_refused_unread() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        write_pyramid(&p, Ngff::V04);
        std::fs::write(p.join("0/0/0/0"), vec![7u8; 1 << 20]).unwrap();
        let e = first_slice_error(&p);
        assert!(
            e.contains("chunk [0, 0, 0] is stored in 1048576 bytes"),
            "{e}"
        );
    }

    #[test]
    fn chunk_shape_larger_than_a_reader_holds_is_refused_at_open() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        write_pyramid(&p, Ngff::V04);
        let meta = p.join("0/.zarray");
        let mut z: Value = serde_json::from_slice(&std::fs::read(&meta).unwrap()).unwrap();
        // 2^40 x 2^40 x 2^40 samples: the product overflows 64 bits.
        z["chunks"] = json!([1u64 << 40, 1u64 << 40, 1u64 << 40]);
        std::fs::write(&meta, z.to_string()).unwrap();
        let e = match open(&p, None, None, None) {
            Ok(_) => panic!("opened a store of impossible chunks"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains("v.ome.zarr") && e.contains("larger than the 2 GiB"),
            "{e}"
        );
        // Large but not overflowing: 2^20 x 2^10 x 2^10 u16 is 2 TiB.
        z["chunks"] = json!([1u64 << 20, 1u64 << 10, 1u64 << 10]);
        std::fs::write(&meta, z.to_string()).unwrap();
        assert!(open(&p, None, None, None).is_err());
    }

    #[test]
    fn ngff_05_pyramid_round_trips_with_scale_and_translation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        let (dims, g) = write_pyramid(&p, Ngff::V05);
        check_pyramid(&p, dims, &g);
        assert_eq!(
            open(&p, None, None, None).unwrap().info().format,
            "ome-zarr 0.5 (ZYX)"
        );
        let meta: Value =
            serde_json::from_slice(&std::fs::read(p.join("zarr.json")).unwrap()).unwrap();
        assert_eq!(meta["zarr_format"], 3);
        assert_eq!(meta["attributes"]["ome"]["version"], "0.5");
        let ds = &meta["attributes"]["ome"]["multiscales"][0]["datasets"];
        assert_eq!(ds.as_array().unwrap().len(), 3);
        assert_eq!(
            ds[1]["coordinateTransformations"][0]["scale"],
            json!([2.0, 1.0, 1.0])
        );
        assert!(!p.join(".zattrs").exists() && p.join("0/zarr.json").is_file());
    }

    #[test]
    fn ngff_04_pyramid_on_zarr_v2_round_trips_with_scale_and_translation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        let (dims, g) = write_pyramid(&p, Ngff::V04);
        check_pyramid(&p, dims, &g);
        assert_eq!(
            open(&p, None, None, None).unwrap().info().format,
            "ome-zarr 0.4 (ZYX)"
        );
        assert!(!p.join("zarr.json").exists());
        let group: Value =
            serde_json::from_slice(&std::fs::read(p.join(".zgroup")).unwrap()).unwrap();
        assert_eq!(group["zarr_format"], 2);
        let attrs: Value =
            serde_json::from_slice(&std::fs::read(p.join(".zattrs")).unwrap()).unwrap();
        let ms = &attrs["multiscales"][0];
        assert_eq!(ms["version"], "0.4");
        assert_eq!(ms["datasets"].as_array().unwrap().len(), 3);
        // Level 2 covers 4 voxels along x and y, one along z: scale x4,
        // x1, centred on the voxels it stands for.
        assert_eq!(
            ms["datasets"][2]["coordinateTransformations"][0]["scale"],
            json!([2.0, 2.0, 2.0])
        );
        assert_eq!(
            ms["datasets"][2]["coordinateTransformations"][1]["translation"],
            json!([3.0, 2.0 + 0.75, 1.0 + 0.75])
        );
        let zarray: Value =
            serde_json::from_slice(&std::fs::read(p.join("0/.zarray")).unwrap()).unwrap();
        assert_eq!(zarray["zarr_format"], 2);
        assert_eq!(zarray["dtype"], "<u2");
        assert_eq!(zarray["dimension_separator"], "/");
        assert_eq!(zarray["compressor"]["id"], "zstd");
        // Chunk keys are nested directories, z/y/x.
        assert!(p.join("0/1/0/0").is_file(), "chunk 1,0,0 of level 0");
    }

    /// Write `dims` of `val` (u8) as an isotropic pyramid of `levels`
    /// levels made by `down`, and read level `l` back whole, x fastest.
    fn pyramid_u8(
        p: &Path,
        dims: Dims,
        levels: u32,
        down: Downsample,
        val: impl Fn(u64, u64, u64) -> u8,
    ) -> Vec<Vec<u8>> {
        let g = Geometry::IDENTITY;
        let mut w =
            ZarrWriter::<u8>::create(p, dims, [1.0; 3], &g, levels, down, Ngff::V04).unwrap();
        for z in 0..dims.z {
            let s: Vec<u8> = (0..dims.y)
                .flat_map(|y| (0..dims.x).map(move |x| (x, y)))
                .map(|(x, y)| val(x, y, z))
                .collect();
            w.push(s).unwrap();
        }
        w.finish().unwrap();
        (0..levels)
            .map(|l| {
                let r = open(p, None, None, Some(l)).unwrap();
                (0..r.info().dims.z)
                    .flat_map(|z| {
                        let s = r.read_slice(z).unwrap();
                        (0..s.len()).map(move |i| s.value(i) as u8)
                    })
                    .collect()
            })
            .collect()
    }

    /// The mean of the samples of `val` over the block `lo..hi` (x, y, z).
    fn block_mean(val: &impl Fn(u64, u64, u64) -> u8, lo: [u64; 3], hi: [u64; 3]) -> f64 {
        let (mut sum, mut n) = (0f64, 0f64);
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    sum += f64::from(val(x, y, z));
                    n += 1.0;
                }
            }
        }
        sum / n
    }

    #[test]
    fn level_two_is_the_exact_mean_of_its_full_resolution_block_rounded_once() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        // Odd dims: the last blocks are cut short and averaged over what
        // they hold.
        let dims = Dims::new(11, 9, 10).unwrap();
        let val = |x: u64, y: u64, z: u64| ((x * 37 + y * 101 + z * 53 + x * y * z) % 251) as u8;
        let levels = pyramid_u8(&p, dims, 3, Downsample::Mean, val);
        let (l1, l2) = (&levels[1], &levels[2]);
        let [nx, ny, nz] = [3u64, 3, 3];
        assert_eq!(l2.len() as u64, nx * ny * nz);
        let mut two_step_differs = 0;
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let lo = [4 * x, 4 * y, 4 * z];
                    let hi = [(4 * x + 4).min(11), (4 * y + 4).min(9), (4 * z + 4).min(10)];
                    let exact = block_mean(&val, lo, hi).round();
                    let got = l2[((z * ny + y) * nx + x) as usize];
                    assert_eq!(f64::from(got), exact, "level 2 at {x},{y},{z}");
                    // What averaging level 1's rounded samples gives.
                    let (n1x, n1y) = (6u64, 5u64);
                    let mut s = 0f64;
                    let mut n = 0f64;
                    for zz in 2 * z..(2 * z + 2).min(5) {
                        for yy in 2 * y..(2 * y + 2).min(n1y) {
                            for xx in 2 * x..(2 * x + 2).min(n1x) {
                                s += f64::from(l1[((zz * n1y + yy) * n1x + xx) as usize]);
                                n += 1.0;
                            }
                        }
                    }
                    if (s / n).round() != exact {
                        two_step_differs += 1;
                    }
                }
            }
        }
        // The data is one where rounding twice gives other values.
        assert!(two_step_differs > 0, "the test data cannot tell");
        // max is exact either way: the largest of the 64.
        let levels = pyramid_u8(&p, dims, 3, Downsample::Max, val);
        let mut m = 0u8;
        for z in 0..4 {
            for y in 0..4 {
                for x in 0..4 {
                    m = m.max(val(x, y, z));
                }
            }
        }
        assert_eq!(levels[2][0], m);
    }

    #[test]
    fn a_level_reads_with_its_dims_spacing_and_origin_and_bad_levels_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        let (dims, g) = write_pyramid(&p, Ngff::V04);
        // Level 2 of 70x5x67 at 0.5, 0.5, 2: x and y halved twice.
        let r = open(&p, None, None, Some(2)).unwrap();
        let info = r.info();
        assert_eq!(info.dims.as_array(), [18, 2, 67]);
        assert_eq!(info.spacing, Some([2.0, 2.0, 2.0]));
        // Voxel (0,0,0) of level 2 is centred on voxels 0..4 along x and y
        // of level 0: 1.5 voxels of 0.5 along each, along the axes (y
        // points down here).
        let want = [
            g.origin[0] + 0.75 * g.axis(0)[0] + 0.75 * g.axis(1)[0],
            g.origin[1] + 0.75 * g.axis(0)[1] + 0.75 * g.axis(1)[1],
            g.origin[2] + 0.75 * g.axis(0)[2] + 0.75 * g.axis(1)[2],
        ];
        assert_eq!(info.geometry.origin, want);
        assert_eq!(info.geometry.direction, g.direction);
        // x 0..4, y 0..4 (5 voxels: all but y 4), slice 9.
        let mut sum = 0f64;
        for y in 0..4 {
            for x in 0..4 {
                sum += f64::from(val(x, y, 9));
            }
        }
        assert_eq!(r.read_slice(9).unwrap().value(0), (sum / 16.0).round());
        let _ = dims;
        let e = match open(&p, None, None, Some(3)) {
            Ok(_) => panic!("read a level past the last"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains("v.ome.zarr") && e.contains("--level 3") && e.contains("3 levels (0..2)"),
            "{e}"
        );
        // A level's array named as the input: read the store with --level.
        let e = match open(&p.join("1"), None, None, None) {
            Ok(_) => panic!("read a level's array as an image"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains("is level 1 of the OME-Zarr pyramid") && e.contains("--level 1"),
            "{e}"
        );
        let levels = levels(&p).unwrap();
        assert_eq!(levels.len(), 3);
        assert_eq!(levels[1].dims.as_array(), [35, 3, 67]);
        assert_eq!(levels[1].spacing, [1.0, 1.0, 2.0]);
    }
}
