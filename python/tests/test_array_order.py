"""Every entry point that takes a numpy array reads it in its logical (C,
z-y-x) order, whatever its memory layout (issue 53 §1): Fortran-ordered,
transposed, strided, negative-stride and non-contiguous arrays give what
the same data in C order gives, for every dtype each entry point accepts.

Before the fix, Fortran-contiguous arrays (np.asfortranarray, a.T of a C
array) were read in memory order, silently scrambling the samples."""

import numpy as np
import pytest

import volkit

# What from_array (and render, psnr and index, through it) accepts.
VOLUME_TYPES = ["uint8", "uint16", "int16", "float32"]
# What save (and preprocess) accepts.
SAVE_TYPES = ["uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"]

SHAPE = (4, 5, 6)  # (z, y, x): every axis a different length


def logical(dtype, shape=SHAPE, seed=53):
    """Samples that differ along every axis, in C order."""
    rng = np.random.default_rng(seed)
    dt = np.dtype(dtype)
    if dt.kind == "f":
        return rng.normal(10.0, 50.0, size=shape).astype(dt)
    info = np.iinfo(dt)
    lo, hi = max(int(info.min), -30000), min(int(info.max), 60000)
    return rng.integers(lo, hi, size=shape, endpoint=True).astype(dt)


def _embed(a, axis, step=1, order="C"):
    """`a` as a view into a bigger array (of `order`) along `axis`: every
    `step`-th element, from 1 on."""
    shape = list(a.shape)
    shape[axis] = a.shape[axis] * step + 1
    big = np.zeros(shape, dtype=a.dtype, order=order)
    where = [slice(None)] * a.ndim
    where[axis] = slice(1, None, step)
    big[tuple(where)] = a
    return big[tuple(where)]


def layouts(a):
    """The same logical data as `a` (C order) in other memory layouts,
    each checked to be the layout it claims to be."""
    assert a.flags.c_contiguous
    flip = (slice(None, None, -1),) * a.ndim
    out = {
        "c": a,
        "fortran": np.asfortranarray(a),
        # a.T of a C array of the transposed shape: F-contiguous.
        "transposed": np.ascontiguousarray(a.T).T,
        # First two axes swapped: neither C nor F contiguous (3D).
        "swapped": np.ascontiguousarray(np.swapaxes(a, 0, 1)).swapaxes(0, 1),
        "strided": _embed(a, 0, step=2),
        "negative": np.ascontiguousarray(a[::-1])[::-1],
        "negative-all": np.ascontiguousarray(a[flip])[flip],
        "noncontiguous": _embed(a, a.ndim - 1),
        "fortran-sliced": _embed(a, 0, order="F"),
        "readonly": a.copy(),
    }
    out["readonly"].flags.writeable = False
    for name in ("fortran", "transposed"):
        f = out[name].flags
        assert f.f_contiguous and not f.c_contiguous, name
    for name in ("strided", "noncontiguous", "fortran-sliced") + (("swapped",) if a.ndim == 3 else ()):
        f = out[name].flags
        assert not f.c_contiguous and not f.f_contiguous, name
    assert out["negative"].strides[0] < 0 and max(out["negative-all"].strides) < 0
    for name, v in out.items():
        assert v.dtype == a.dtype and v.shape == a.shape, name
        assert np.array_equal(v, a), name
    return out


LAYOUTS = list(layouts(logical("uint8")))


def each_layout(dtype, shape=SHAPE):
    a = logical(dtype, shape)
    return a, layouts(a)


# --- save -> open -> array ------------------------------------------------

FORMATS = {"nii": ".nii", "vvol": ".vvol", "nrrd": ".nrrd"}


@pytest.mark.parametrize("fmt", list(FORMATS))
@pytest.mark.parametrize("dtype", SAVE_TYPES)
def test_save_open(tmp_path, fmt, dtype):
    a, arrays = each_layout(dtype)
    ref_path = tmp_path / ("c" + FORMATS[fmt])
    volkit.save(a, ref_path)
    ref = volkit.open(ref_path).array()
    assert ref.shape == a.shape
    assert np.array_equal(ref, a.astype(ref.dtype)), "C order round trip"
    if dtype in VOLUME_TYPES:
        assert ref.dtype == a.dtype
    for name, v in arrays.items():
        p = tmp_path / (name + FORMATS[fmt])
        volkit.save(v, p)
        got = volkit.open(p).array()
        assert got.dtype == ref.dtype and np.array_equal(got, ref), f"{name}: {got.ravel()[:6]} != {ref.ravel()[:6]}"
        assert p.read_bytes() == ref_path.read_bytes(), name


def test_issue_example(tmp_path):
    a = np.arange(120, dtype=np.uint8).reshape(4, 5, 6)
    volkit.save(np.asfortranarray(a), tmp_path / "o.nii")
    assert list(volkit.open(tmp_path / "o.nii").array()[0, 0, :6]) == [0, 1, 2, 3, 4, 5]


@pytest.mark.parametrize("dtype", SAVE_TYPES)
def test_preprocess(dtype):
    a, arrays = each_layout(dtype)
    ref = volkit.preprocess(a).array()
    for name, v in arrays.items():
        got = volkit.preprocess(v).array()
        assert got.dtype == ref.dtype and np.array_equal(got, ref), name


# --- from_array, and what takes an array as a volume -----------------------


@pytest.mark.parametrize("dtype", VOLUME_TYPES)
@pytest.mark.parametrize("shape", [SHAPE, SHAPE[1:]], ids=["3d", "2d"])
def test_from_array(dtype, shape):
    a, arrays = each_layout(dtype, shape)
    for name, v in arrays.items():
        got = volkit.from_array(v).array()
        assert got.dtype == a.dtype and np.array_equal(got.reshape(a.shape), a), name


def scrambled(a):
    """What the Fortran-order bug read: `a`'s Fortran memory order taken
    as C order (to check a test can tell the two apart)."""
    return np.asfortranarray(a).ravel(order="K").reshape(a.shape)


@pytest.mark.parametrize("mode", ["mip", "dvr"])
@pytest.mark.parametrize("dtype", VOLUME_TYPES)
def test_render(dtype, mode):
    a, arrays = each_layout(dtype, (6, 7, 8))
    opts = dict(mode=mode, size="16x12", tf="auto")
    ref, _ = volkit.render(a, **opts)
    assert ref.max() > 0
    assert not np.array_equal(volkit.render(scrambled(a), **opts)[0], ref)
    for name, v in arrays.items():
        img, _ = volkit.render(v, **opts)
        assert np.array_equal(img, ref, equal_nan=True), name
        img, _ = volkit.render(volkit.from_array(v), **opts)
        assert np.array_equal(img, ref, equal_nan=True), name


@pytest.mark.parametrize("dtype", VOLUME_TYPES)
def test_psnr_volumes(dtype):
    a, arrays = each_layout(dtype)
    other = logical(dtype, seed=54)
    ref = volkit.psnr(a, other)
    assert not ref["identical"]
    for name, v in arrays.items():
        same = volkit.psnr(a, v)
        assert same["identical"] and same["differing"] == 0, name
        assert volkit.psnr(v, a)["identical"], name
        got = volkit.psnr(v, other)
        for key in ("psnr", "mse", "max_abs", "differing", "count", "peak"):
            assert got[key] == ref[key], (name, key)


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "float32", "float64"])
@pytest.mark.parametrize("shape", [(5, 6), (5, 6, 3), (5, 6, 4)], ids=["grey", "rgb", "rgba"])
def test_psnr_images(dtype, shape):
    a, arrays = each_layout(dtype, shape)
    other = logical(dtype, shape, seed=54)
    ref = volkit.psnr(a, other, kind="image")
    assert ref["kind"] == "image" and not ref["identical"]
    for name, v in arrays.items():
        assert volkit.psnr(a, v, kind="image")["identical"], name
        got = volkit.psnr(v, other, kind="image")
        assert got["psnr"] == ref["psnr"] and got["mse"] == ref["mse"], name


@pytest.mark.parametrize("dtype", VOLUME_TYPES)
def test_index(tmp_path, dtype):
    a, arrays = each_layout(dtype, (8, 10, 12))
    ref = volkit.index(a, tmp_path / "c.vidx", cell=4)
    want = (tmp_path / "c.vidx").read_bytes()
    volkit.index(scrambled(a), tmp_path / "s.vidx", cell=4)
    assert (tmp_path / "s.vidx").read_bytes() != want
    for name, v in arrays.items():
        ix = volkit.index(v, tmp_path / f"{name}.vidx", cell=4)
        assert ix.range == ref.range, name
        assert (tmp_path / f"{name}.vidx").read_bytes() == want, name


def test_broadcast_arrays(tmp_path):
    """Zero strides (np.broadcast_to, read-only) read as the copied data."""
    row = logical("uint16", (6,))
    b = np.broadcast_to(row, SHAPE)
    assert 0 in b.strides and not b.flags.writeable
    c = np.ascontiguousarray(b)
    assert np.array_equal(volkit.from_array(b).array(), c)
    volkit.save(b, tmp_path / "b.nii")
    assert np.array_equal(volkit.open(tmp_path / "b.nii").array(), c)
    assert volkit.psnr(b, c)["identical"]
