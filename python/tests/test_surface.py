"""The Python surface of issue 53 §2: writable decoded arrays, refused
selection keywords, psnr's kinds, messages in keyword terms, the render
docstring, the affine, and slicing a Volume."""

import math
import pathlib
import re

import numpy as np
import pytest

import volkit
from conftest import cli

DOCS = pathlib.Path(__file__).resolve().parents[2] / "docs" / "python.md"


def rotation():
    """An oblique direction matrix (rows and columns z, y, x)."""
    a, b = math.radians(30), math.radians(20)
    rz = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    return rz @ ry


# ---- writability


@pytest.mark.parametrize("name", ["x.nii.gz", "x.nrrd", "x.mha", "x.mhd", "bricked.vvol"])
def test_decoded_arrays_are_new_writable_arrays(tmp_path, name):
    a = np.arange(3 * 4 * 5, dtype=np.int16).reshape(3, 4, 5)
    path = tmp_path / name
    volkit.save(a, path, **({"layout": "bricked:4"} if name.startswith("bricked") else {}))
    v = volkit.open(path)
    assert not v.mapped
    arr = v.array()
    assert arr.flags.writeable, name
    arr[0, 0, 0] = 99
    # A new array: the volume is as it was.
    assert v.array()[0, 0, 0] == 0
    assert np.array_equal(np.asarray(v), a)


@pytest.mark.parametrize("name", ["x.nii", "x.vvol"])
def test_mapped_views_are_read_only(tmp_path, name):
    a = np.arange(3 * 4 * 5, dtype=np.uint8).reshape(3, 4, 5)
    volkit.save(a, tmp_path / name)
    v = volkit.open(tmp_path / name)
    assert v.mapped
    arr = v.array()
    assert not arr.flags.writeable
    with pytest.raises(ValueError):
        arr[0, 0, 0] = 1


def test_volume_in_memory_gives_writable_copies():
    a = np.zeros((2, 3, 4), np.float32)
    v = volkit.from_array(a)
    arr = v.array()
    assert arr.flags.writeable
    arr[:] = 5
    assert v.array().max() == 0


# ---- open's keywords


def test_selection_keywords_the_input_cannot_use_are_refused(tmp_path):
    a = np.zeros((2, 3, 4), np.uint8)
    nii, nrrd = tmp_path / "x.nii", tmp_path / "x.nrrd"
    volkit.save(a, nii)
    volkit.save(a, nrrd)
    with pytest.raises(ValueError, match=r"channel=1: a nifti input has none to pick"):
        volkit.open(nii, channel=1)
    with pytest.raises(ValueError, match=r'series="3": a nifti input has none to pick'):
        volkit.open(nii, series="3")
    with pytest.raises(ValueError, match=r"time_point=0: a nrrd input"):
        volkit.open(nrrd, time_point=0)
    with pytest.raises(ValueError, match=r"luma=True: a nrrd input"):
        volkit.open(nrrd, luma=True)
    with pytest.raises(ValueError, match=r"raw_dims.*a nifti input"):
        volkit.open(nii, raw_dims="4,3,2")
    # What applies still works: the one time point of a 3D NIfTI.
    assert volkit.open(nii, time_point=0).shape == (2, 3, 4)


# ---- psnr


def test_psnr_volume_means_volume_and_ambiguous_arrays_are_refused():
    rng = np.random.default_rng(5)
    a = rng.integers(0, 200, size=(64, 64, 4), dtype=np.uint8)
    b = a.copy()
    b[..., 3] += 1  # differs only in the plane an RGBA guess drops
    with pytest.raises(ValueError, match=r"pass kind='image' or kind='volume'"):
        volkit.psnr(a, b)
    for got in (
        volkit.psnr(volkit.from_array(a), volkit.from_array(b)),
        volkit.psnr(volkit.from_array(a), b),
        volkit.psnr(a, volkit.from_array(b)),
        volkit.psnr(a, b, kind="volume"),
    ):
        assert got["kind"] == "volume" and not got["identical"], got
    assert volkit.psnr(a, b, kind="image")["kind"] == "image"
    # Unambiguous arrays need no kind.
    assert volkit.psnr(a[..., 0], a[..., 0])["kind"] == "image"
    assert volkit.psnr(a[..., :2], b[..., :2])["kind"] == "volume"


# ---- messages


def test_messages_name_keywords_not_flags(tmp_path):
    a = (np.arange(2 * 3 * 4, dtype=np.int16).reshape(2, 3, 4) - 10) * 100
    with pytest.raises(OSError) as e:
        volkit.save(a, tmp_path / "x.nii", type="u8")
    msg = str(e.value)
    assert "pass window=lo:hi, window=auto or window=full" in msg, msg
    assert "--" not in msg
    with pytest.raises(ValueError) as e:
        volkit.open(tmp_path / "x.nii", time=1)
    assert str(e.value).startswith("time is gone: use time_point=T"), str(e.value)
    assert "seconds=S" in str(e.value)
    with pytest.raises(ValueError) as e:
        volkit.render(np.zeros((4, 4, 4), np.uint8), iso=10)
    assert str(e.value).endswith(": iso needs mode=iso"), str(e.value)
    with pytest.raises(ValueError) as e:
        volkit.render(np.zeros((4, 4, 4), np.uint8), mode="bogus")
    assert "invalid value 'bogus' for 'mode'" in str(e.value), str(e.value)


@pytest.mark.parametrize(
    "flags, words",
    [
        ("--compress needs --layout bricked:B (compression is per brick)",
         "compress needs layout=bricked:B (compression is per brick)"),
        ("default 64 unless --seconds or --until-error decides", "default 64 unless seconds or until_error decides"),
        ("pick one with --time-point T (0..3)", "pick one with time_point=T (0..3)"),
        ("invalid value 'x' for '--mode <MODE>'", "invalid value 'x' for 'mode'"),
        ("use --type i16 or f32; --window auto", "use type=i16 or f32; window=auto"),
        ("--shard K/N is vol-convert's", "--shard K/N is vol-convert's"),  # not a keyword: kept
    ],
)
def test_flags_become_keywords(flags, words):
    from volkit._volkit import _python_words

    assert _python_words(flags) == words


# ---- docs


def test_render_docstring_lists_every_vol_render_option():
    doc = volkit.render.__doc__
    help_text = cli("vol-render", "--help").stdout
    flags = set(re.findall(r"^\s+(?:-\w, )?--([a-z][a-z0-9-]*)", help_text, re.M))
    # The program's own flags, not render options.
    flags -= {"help", "version", "print-scene", "completions", "man"}
    assert len(flags) > 30, flags
    missing = [f for f in sorted(flags) if f"{f.replace('-', '_')}=" not in doc]
    assert not missing, missing
    # In Python's words: keywords, and points in (z, y, x).
    assert "Camera position (z, y, x) (world units); needs look_at" in doc
    assert "--" not in doc.split("Options (")[1].replace("'--", "")


def test_docs_name_every_public_call():
    text = DOCS.read_text()
    for name in volkit.__all__:
        assert f"`volkit.{name}" in text or f"`{name}" in text, name
    assert "from_array(" in text and "affine" in text
    assert "writable" in text


# ---- affine


def test_affine_is_direction_times_spacing_and_origin():
    d = rotation()
    v = volkit.from_array(np.zeros((3, 4, 5), np.uint8), spacing=(2, 3, 4), origin=(10, 20, 30), direction=d)
    want = np.eye(4)
    want[:3, :3] = d * np.array([2, 3, 4])
    want[:3, 3] = (10, 20, 30)
    assert v.affine.shape == (4, 4)
    assert np.allclose(v.affine, want, atol=1e-6)


def test_affine_equals_nibabels_in_zyx_lps(tmp_path):
    nib = pytest.importorskip("nibabel")
    d = rotation()
    ras = np.eye(4)
    ras[:3, :3] = d * np.array([1.5, 0.8, 2.0])
    ras[:3, 3] = (-40.5, 12.25, 7.0)
    data = np.zeros((5, 6, 7), np.int16)  # nibabel's (x, y, z)
    path = tmp_path / "oblique.nii.gz"
    nib.save(nib.Nifti1Image(data, ras), str(path))
    v = volkit.open(path)
    assert v.shape == (7, 6, 5)
    lps = np.diag([-1.0, -1.0, 1.0, 1.0]) @ nib.load(str(path)).affine
    flip = np.zeros((4, 4))
    flip[0, 2] = flip[1, 1] = flip[2, 0] = flip[3, 3] = 1
    want = flip @ lps @ flip  # (z, y, x) in, (z, y, x) out
    assert np.allclose(v.affine, want, atol=1e-4), (v.affine, want)


# ---- slicing


def test_slicing_a_volume_moves_its_geometry():
    a = np.arange(6 * 7 * 8, dtype=np.int16).reshape(6, 7, 8)
    v = volkit.from_array(a, spacing=(2, 3, 4), origin=(10, 20, 30), direction=rotation())
    s = v[1:5, 2:7:2, ::-1]
    assert isinstance(s, volkit.Volume)
    assert np.array_equal(s.array(), a[1:5, 2:7:2, ::-1])
    # nibabel's slicer: the new affine is the old one times the map from
    # new indices to old (old = start + step * new).
    t = np.array([[1, 0, 0, 1], [0, 2, 0, 2], [0, 0, -1, 7], [0, 0, 0, 1]], float)
    assert np.allclose(s.affine, v.affine @ t, atol=1e-4)
    assert np.allclose(s.spacing, (2, 6, 4))
    # Fewer slices and `...` leave the other axes whole.
    z = v[2:4]
    assert isinstance(z, volkit.Volume) and z.shape == (2, 7, 8)
    assert np.allclose(z.affine, v.affine @ np.array([[1, 0, 0, 2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), atol=1e-4)
    x = v[..., 3:]
    assert isinstance(x, volkit.Volume) and np.array_equal(x.array(), a[..., 3:])
    assert np.allclose(x.origin, np.array(v.origin) + np.array(v.direction) @ np.array([0, 0, 3 * 4]))
    # An integer drops an axis: the plain array.
    p = v[3]
    assert isinstance(p, np.ndarray) and np.array_equal(p, a[3])
    assert np.array_equal(v[1, 2:4, 5], a[1, 2:4, 5])


def test_slicing_keeps_the_unit(tmp_path):
    a = np.zeros((4, 4, 4), np.uint8)
    volkit.save(a, tmp_path / "x.nii.gz", spacing=(1, 1, 1))
    v = volkit.open(tmp_path / "x.nii.gz")
    assert v[1:3].unit == v.unit
