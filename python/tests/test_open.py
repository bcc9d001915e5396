"""open() reads what vol-convert reads, with its selection options: the
same samples and geometry as vol-convert's output."""

import pathlib

import numpy as np
import pytest

import volkit
from conftest import cli, cli_message

FIXTURES = pathlib.Path(__file__).resolve().parent.parent.parent / "tests" / "fixtures"


def via_cli(tmp_path, src, *flags):
    out = tmp_path / "cli.vvol"
    cli("vol-convert", src, *flags, "-o", out, "--quiet")
    return volkit.open(out)


@pytest.mark.parametrize(
    "name, selection, flags",
    [
        ("dicom_ct", {}, []),
        ("dicom_mr", {}, []),
        ("tifffile_hyperstack.tif", {"channel": 1, "time_point": 1}, ["--channel", "1", "--time-point", "1"]),
        ("tifffile_ome.ome.tif", {"channel": 0}, ["--channel", "0"]),
        ("nibabel_int16.nii.gz", {}, []),
        ("nibabel_f64.nii", {}, []),
    ],
)
def test_open_matches_vol_convert(tmp_path, name, selection, flags):
    src = FIXTURES / name
    v = volkit.open(src, **selection)
    w = via_cli(tmp_path, src, *flags)
    assert v.shape == w.shape and v.dtype == w.dtype
    np.testing.assert_array_equal(v.array(), w.array())
    assert v.spacing == w.spacing and v.origin == w.origin and v.direction == w.direction


def test_dicom_geometry_in_numpy_order():
    v = volkit.open(FIXTURES / "dicom_ct")
    assert v.shape == (10, 12, 16)
    np.testing.assert_allclose(v.spacing, (2.5, 0.8, 0.7), rtol=1e-6)
    np.testing.assert_allclose(v.origin, (12.5, -30, -40))
    assert v.range == (-1024.0, -384.0)


def test_selection_is_required_like_vol_convert(tmp_path):
    src = FIXTURES / "tifffile_hyperstack.tif"
    r = cli("vol-convert", src, "-o", tmp_path / "x.vvol", check=False)
    with pytest.raises(OSError) as e:
        volkit.open(src)
    assert str(e.value) == cli_message("vol-convert", r.stderr)
    with pytest.raises(ValueError, match="unknown option `chanel`"):
        volkit.open(src, chanel=1)


def test_raw_selection(tmp_path):
    a = np.arange(3 * 4 * 5, dtype=">u2").reshape(3, 4, 5)
    p = tmp_path / "data.bin"
    p.write_bytes(b"HEAD" + a.tobytes())
    v = volkit.open(p, raw_dims="5,4,3", raw_type="u16", raw_endian="big", raw_skip=4)
    np.testing.assert_array_equal(v.array(), a.astype(np.uint16))
    w = volkit.open(p, shape=(3, 4, 5), raw_type="uint16", raw_endian="big", raw_skip=4)
    np.testing.assert_array_equal(w.array(), a.astype(np.uint16))


def test_selection_keywords_are_the_command_line_flags():
    """open's keywords are the tools' input-selection flags, parsed by the
    same definition: the same names, values and errors."""
    from conftest import cli

    src = FIXTURES / "tifffile_hyperstack.tif"
    with pytest.raises(ValueError) as e:
        volkit.open(src, chanel=1)
    named = str(e.value).split("open takes ")[1].rstrip(")").split(", ")
    python_only = {"shape", "luma", "in_memory"}
    assert python_only <= set(named)
    flags = [k for k in named if k not in python_only]
    assert {"raw_dims", "raw_type", "raw_endian", "raw_skip", "series", "channel", "time_point", "level"} <= set(flags)
    for tool in ["vol-info", "vol-convert", "vol-render", "vol-index", "vol-psnr"]:
        help_text = cli(tool, "--help").stdout
        for k in flags:
            assert "--" + k.replace("_", "-") in help_text, (tool, k)
    with pytest.raises(ValueError, match="invalid value 'x' for 'channel'"):
        volkit.open(src, channel="x")
    with pytest.raises(ValueError, match="time_point=T"):
        volkit.open(src, time=1)
    v = volkit.open(src, **{"time-point": 1, "channel": 1})
    w = volkit.open(src, time_point=1, channel=1)
    np.testing.assert_array_equal(v.array(), w.array())


def test_level_reads_a_level_of_an_ome_zarr_pyramid_as_vol_convert_does(tmp_path):
    z = tmp_path / "ct.ome.zarr"
    cli("vol-convert", FIXTURES / "dicom_ct", "--pyramid", "3", "-o", z, "--quiet")
    # z (2.5) is over twice as coarse as x (0.7): level 1 halves y and x.
    shapes = [(10, 12, 16), (10, 6, 8), (5, 3, 4)]
    for level in range(3):
        v = volkit.open(z, level=level)
        w = via_cli(tmp_path, z, "--level", str(level))
        assert v.shape == shapes[level] == w.shape
        np.testing.assert_array_equal(v.array(), w.array())
        assert v.spacing == w.spacing and v.origin == w.origin and v.direction == w.direction
    np.testing.assert_array_equal(volkit.open(z).array(), volkit.open(z, level=0).array())
    # Past the last level: the file and how many levels it has.
    with pytest.raises(OSError, match="ct.ome.zarr.*has 3 levels"):
        volkit.open(z, level=3)
    # An input without levels refuses it, as the tools do (exit 2 there).
    src = FIXTURES / "nibabel_f64.nii"
    r = cli("vol-info", src, "--level", "1", check=False)
    assert r.returncode == 2
    with pytest.raises(ValueError, match="nifti input has no pyramid levels"):
        volkit.open(src, level=1)
