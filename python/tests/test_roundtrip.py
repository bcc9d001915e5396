"""numpy array -> save -> open -> array() gives the same array back, for
every sample type and every format, with the geometry."""

import numpy as np
import pytest

import volkit

SPACING = (1.5, 0.8, 0.6)  # (z, y, x)
ORIGIN = (-40.0, 12.5, 3.25)
# Column j: array axis j's world direction, (z, y, x) components: a
# rotation by 90 degrees about z, and the z axis reversed.
DIRECTION = ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0))

TYPES = ["uint8", "uint16", "int16", "float32"]

# name, suffix, save options, whether the format stores spacing, and
# origin and direction.
FORMATS = [
    ("vvol-sliced", ".vvol", {}, True, True),
    ("vvol-bricked", ".vvol", {"layout": "bricked:8"}, True, True),
    ("vvol-zstd", ".vvol", {"layout": "bricked:8", "compress": "zstd:5"}, True, True),
    ("nifti", ".nii", {}, True, True),
    ("nifti-gz", ".nii.gz", {}, True, True),
    ("nrrd", ".nrrd", {}, True, True),
    ("nrrd-gzip", ".nrrd", {"compress": "gzip"}, True, True),
    ("metaimage", ".mha", {}, True, True),
    ("ome-zarr", ".ome.zarr", {}, True, False),
    ("tiff", ".tif", {}, False, False),
    ("raw", "_{x}x{y}x{z}_{t}.raw", {}, False, False),
]

RAW_TYPE = {"uint8": "uint8", "uint16": "uint16", "int16": "int16", "float32": "float32"}


def sample_array(dtype, shape=(7, 9, 11)):
    rng = np.random.default_rng(7)
    if dtype == "float32":
        a = rng.normal(10.0, 50.0, size=shape).astype(np.float32)
        a[0, 0, 0] = np.float32(1e-7)
        return a
    info = np.iinfo(dtype)
    return rng.integers(info.min, info.max, size=shape, endpoint=True, dtype=dtype)


@pytest.mark.parametrize("dtype", TYPES)
@pytest.mark.parametrize("fmt", FORMATS, ids=[f[0] for f in FORMATS])
def test_round_trip(tmp_path, dtype, fmt):
    name, suffix, opts, has_spacing, has_geometry = fmt
    a = sample_array(dtype)
    z, y, x = a.shape
    path = tmp_path / ("vol" + suffix.format(x=x, y=y, z=z, t=RAW_TYPE[dtype]))
    geometry = {"origin": ORIGIN, "direction": DIRECTION} if has_geometry else {}
    report = volkit.save(a, path, spacing=SPACING, **geometry, **opts)
    assert report["shape"] == list(a.shape)
    v = volkit.open(path)
    assert v.shape == a.shape
    assert v.dtype == a.dtype
    b = v.array()
    assert b.dtype == a.dtype and b.shape == a.shape
    np.testing.assert_array_equal(b, a)
    assert np.array_equal(np.asarray(v), a)
    if has_spacing:
        np.testing.assert_allclose(v.spacing, SPACING, rtol=1e-6)
    if has_geometry:
        np.testing.assert_allclose(v.origin, ORIGIN, atol=1e-6)
        np.testing.assert_allclose(v.direction, DIRECTION, atol=1e-6)
    # MetaImage has no unit field: read as the millimetres ITK assumes.
    assert v.unit == ("millimeter" if name == "metaimage" else None)


def test_save_keeps_layout_and_compression(tmp_path):
    a = sample_array("uint16", (20, 20, 20))
    volkit.save(a, tmp_path / "b.vvol", layout="bricked:8", compress="zstd")
    v = volkit.open(tmp_path / "b.vvol")
    assert v.layout == "bricked:8" and v.compression == "zstd:3"
    assert not v.mapped
    b = v.array()
    assert b.flags.writeable  # a decoded array is the caller's own
    np.testing.assert_array_equal(b, a)


@pytest.mark.parametrize(
    "dtype, values, stored",
    [
        ("int32", (0, 1000), "uint16"),
        ("int8", (-100, 100), "int16"),
        ("uint32", (0, 200), "uint8"),
    ],
)
def test_wide_types_become_the_smallest_stored_type(tmp_path, dtype, values, stored):
    """Types volkit does not store are narrowed as vol-convert does."""
    a = np.linspace(values[0], values[1], 5 * 6 * 7).reshape(5, 6, 7).astype(dtype)
    volkit.save(a, tmp_path / "w.vvol")
    v = volkit.open(tmp_path / "w.vvol")
    assert v.dtype == np.dtype(stored)
    np.testing.assert_array_equal(v.array(), a.astype(stored))


def test_float64_is_stored_exactly_and_read_as_float32(tmp_path):
    """float64 is a storage type: the file keeps it bit for bit; a Volume
    in memory holds it as float32, as the renderer reads it."""
    import json

    from conftest import cli

    a = np.linspace(-1.5, 2.25, 5 * 6 * 7).reshape(5, 6, 7) + 1e-9
    volkit.save(a, tmp_path / "w.vvol")
    cli("vol-convert", tmp_path / "w.vvol", "-o", tmp_path / "w_7x6x5_float64.raw", "--quiet")
    np.testing.assert_array_equal(np.fromfile(tmp_path / "w_7x6x5_float64.raw", "<f8").reshape(5, 6, 7), a)
    info = json.loads(cli("vol-info", tmp_path / "w.vvol", "--json").stdout)
    assert info["type"] == "f64"
    v = volkit.open(tmp_path / "w.vvol")
    assert v.dtype == np.float32
    np.testing.assert_array_equal(v.array(), a.astype(np.float32))


def test_window_narrows_like_vol_convert(tmp_path, vols):
    from conftest import cli

    cli("vol-convert", vols["sphere"], "--type", "u8", "--window", "0:4000", "-o", tmp_path / "cli.vvol", "--quiet")
    volkit.save(volkit.open(vols["sphere"]), tmp_path / "py.vvol", type="u8", window="0:4000")
    assert (tmp_path / "cli.vvol").read_bytes() == (tmp_path / "py.vvol").read_bytes()


def test_generate_matches_vol_gen(tmp_path, vols):
    v = volkit.generate("shapes", (40, 48, 64), seed=3, count=12, size=16, spacing=(1.5, 0.8, 1))
    w = volkit.open(vols["shapes"])
    np.testing.assert_array_equal(v.array(), w.array())
    assert v.spacing == w.spacing
    volkit.save(v, tmp_path / "g.vvol")
    assert volkit.psnr(tmp_path / "g.vvol", vols["shapes"])["identical"]


def test_from_array_and_save_a_volume(tmp_path):
    a = sample_array("int16")
    v = volkit.from_array(a, spacing=SPACING, origin=ORIGIN, direction=DIRECTION)
    assert v.path is None and v.shape == a.shape
    volkit.save(v, tmp_path / "v.nrrd")
    w = volkit.open(tmp_path / "v.nrrd")
    np.testing.assert_array_equal(w.array(), a)
    np.testing.assert_allclose(w.spacing, SPACING, rtol=1e-6)
    np.testing.assert_allclose(w.direction, DIRECTION, atol=1e-6)
