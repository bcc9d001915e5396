"""volkit.save with preprocessing keywords: the same stages and bytes as
vol-convert's flags of the same names (issue 52)."""

import numpy as np
import pytest

import volkit
from conftest import cli

CASES = [
    {"resample": "spacing:1.5", "kernel": "bspline3"},
    {"resample": "dims:9,20,14", "kernel": "nearest", "no_antialias": True},
    {"orient": "PIR"},
    {"smooth": "gauss:1,2,0.5"},
    {"median": 1},
    {"clamp": "-5:30"},
    {"threshold": "0:20"},
    {"orient": "SAR", "resample": "spacing:0.8", "smooth": "gauss:1", "clamp": "0:40", "background": -3},
]


def flags(kw):
    out = []
    for k, v in kw.items():
        flag = "--" + k.replace("_", "-")
        if v is True:
            out.append(flag)
        else:
            out += [flag, str(v)]
    return out


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    d = tmp_path_factory.mktemp("prep")
    rng = np.random.default_rng(3)
    a = rng.normal(10.0, 20.0, size=(12, 17, 21)).astype(np.float32)
    path = d / "src.nii"
    volkit.save(a, path, spacing=(2.0, 0.7, 0.5), origin=(5.0, -3.0, 1.0))
    return d, path


@pytest.mark.parametrize("kw", CASES, ids=lambda kw: "-".join(kw))
def test_save_with_preprocessing_equals_vol_convert(source, kw):
    d, src = source
    ours = d / "py.nii"
    volkit.save(volkit.open(src), ours, **kw)
    theirs = d / "cli.nii"
    cli("vol-convert", src, *flags(kw), "-q", "-o", theirs)
    assert ours.read_bytes() == theirs.read_bytes()


def test_unknown_preprocessing_keyword_is_refused(source, tmp_path):
    d, src = source
    with pytest.raises(ValueError, match="resample"):
        volkit.save(volkit.open(src), tmp_path / "o.nii", resmaple="spacing:1")
    with pytest.raises(ValueError, match="lanczos3"):
        volkit.save(volkit.open(src), tmp_path / "o.nii", resample="spacing:1", kernel="sinc")
    assert not (tmp_path / "o.nii").exists()


def test_preprocess_in_memory_equals_save(source, tmp_path):
    d, src = source
    kw = {"orient": "RAS", "resample": "spacing:1", "smooth": "gauss:0.8"}
    v = volkit.preprocess(volkit.open(src), **kw)
    path = tmp_path / "o.nii"
    volkit.save(volkit.open(src), path, **kw)
    back = volkit.open(path)
    np.testing.assert_array_equal(v.array(), back.array())
    np.testing.assert_allclose(v.spacing, back.spacing)
    np.testing.assert_allclose(v.origin, back.origin, atol=1e-5)
    # A numpy array works too, and a threshold makes a uint8 mask.
    a = np.arange(4 * 5 * 6, dtype=np.int16).reshape(4, 5, 6)
    m = volkit.preprocess(a, threshold="10:50").array()
    np.testing.assert_array_equal(m, ((a >= 10) & (a <= 50)).astype(np.uint8))
