"""array() of a sliced uncompressed file is a read-only view of its memory
map: no copy, and resident memory grows only with what is read."""

import os
import time

import numpy as np
import pytest

import volkit
from conftest import cli


def rss_bytes():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    pytest.skip("no /proc/self/status")


def assert_view(v):
    a = v.array()
    assert v.mapped
    assert not a.flags.writeable and not a.flags.owndata
    # The array's memory belongs to the Volume (the base), not to numpy.
    base = a
    while isinstance(base, np.ndarray) and base.base is not None:
        base = base.base
    assert base is v
    # Two arrays of one volume are views of the same memory.
    assert np.shares_memory(a, v.array())
    with pytest.raises(ValueError):
        a[0, 0, 0] = 1
    return a


@pytest.mark.parametrize("suffix", [".vvol", ".nii", "_13x11x9_uint16.raw"])
def test_sliced_files_are_mapped_views(tmp_path, suffix):
    a = np.arange(9 * 11 * 13, dtype=np.uint16).reshape(9, 11, 13)
    path = tmp_path / ("v" + suffix)
    volkit.save(a, path)
    v = volkit.open(path)
    view = assert_view(v)
    np.testing.assert_array_equal(view, a)


def test_a_view_outlives_its_volume(tmp_path):
    a = np.arange(4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6)
    volkit.save(a, tmp_path / "v.vvol")
    view = volkit.open(tmp_path / "v.vvol").array()
    import gc

    gc.collect()
    np.testing.assert_array_equal(view, a)


def test_compressed_nifti_is_decoded(tmp_path):
    a = np.arange(60, dtype=np.uint8).reshape(3, 4, 5)
    volkit.save(a, tmp_path / "v.nii.gz")
    v = volkit.open(tmp_path / "v.nii.gz")
    assert not v.mapped
    np.testing.assert_array_equal(v.array(), a)


def test_non_contiguous_arrays_save(tmp_path):
    a = np.arange(6 * 8 * 10, dtype=np.int16).reshape(6, 8, 10)[:, ::2, ::-1]
    volkit.save(a, tmp_path / "v.vvol")
    np.testing.assert_array_equal(volkit.open(tmp_path / "v.vvol").array(), a)


def test_two_gigabyte_file_opens_fast_and_small(tmp_path):
    """A 2 GiB sliced .vvol: open in < 0.05 s and resident memory up by
    < 50 MB, reading one slice through the view."""
    x, y, z = 2048, 1024, 1024
    raw = tmp_path / f"big_{x}x{y}x{z}_uint8.raw"
    with open(raw, "wb") as f:
        f.truncate(x * y * z)  # sparse: zeros, no disk blocks
    with open(raw, "r+b") as f:
        f.seek(x * y * 500 + 17)
        f.write(b"\x07")
    big = tmp_path / "big.vvol"
    cli("vol-convert", raw, "-o", big, "--quiet")
    raw.unlink()
    assert os.path.getsize(big) > 2 * 1024**3

    try:
        before = rss_bytes()
        times = []
        for _ in range(3):
            t = time.perf_counter()
            v = volkit.open(big)
            times.append(time.perf_counter() - t)
        a = v.array()
        assert a.shape == (z, y, x) and v.mapped
        assert int(a[500].max()) == 7 and int(a[500, 0, 17]) == 7
        grown = rss_bytes() - before
        print(f"2 GiB .vvol: open {min(times) * 1000:.2f} ms (best of 3), RSS +{grown / 1e6:.1f} MB")
        assert min(times) < 0.05, times
        assert grown < 50e6, grown
    finally:
        # pytest keeps the last runs' temporary folders: not 2 GiB each.
        big.unlink()
