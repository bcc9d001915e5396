"""Bad input raises the right exception with the tools' one-line message;
an interrupted render raises KeyboardInterrupt."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import volkit
from conftest import cli, cli_message


def test_missing_file(tmp_path):
    missing = tmp_path / "nope.vvol"
    r = cli("vol-convert", missing, "-o", tmp_path / "x.vvol", check=False)
    with pytest.raises(FileNotFoundError) as e:
        volkit.open(missing)
    assert str(e.value) == cli_message("vol-convert", r.stderr)


def test_bad_render_option_is_value_error(tmp_path, vols):
    r = cli("vol-render", vols["shapes"], "--iso", "10", "-o", tmp_path / "x.png", check=False)
    assert r.returncode != 0
    with pytest.raises(ValueError) as e:
        volkit.render(vols["shapes"], iso=10)
    assert str(e.value) == cli_message("vol-render", r.stderr)


def test_bad_render_value_and_unknown_option(vols):
    with pytest.raises(ValueError, match="invalid value 'bogus' for 'mode'"):
        volkit.render(vols["shapes"], mode="bogus")
    with pytest.raises(ValueError, match="unknown option `no_such`"):
        volkit.render(vols["shapes"], no_such=1)
    with pytest.raises(ValueError, match="not a finite number"):
        volkit.render(vols["shapes"], step=float("nan"))


def test_bad_transfer_function_file_is_os_error(tmp_path, vols):
    tf = tmp_path / "bad.tf"
    tf.write_text("range 1 2 nonsense\n")
    r = cli("vol-render", vols["shapes"], "--tf", tf, "-o", tmp_path / "x.png", check=False)
    with pytest.raises((OSError, ValueError)) as e:
        volkit.render(vols["shapes"], tf=str(tf))
    assert str(e.value) == cli_message("vol-render", r.stderr)


def test_bad_output_name_is_value_error(tmp_path):
    a = np.zeros((2, 3, 4), np.uint8)
    r = cli("vol-convert", "-", "-o", tmp_path / "x.xyz", check=False)
    with pytest.raises(ValueError) as e:
        volkit.save(a, tmp_path / "x.xyz")
    assert str(e.value) == cli_message("vol-convert", r.stderr)
    with pytest.raises(ValueError, match="compress needs layout=bricked"):
        volkit.save(a, tmp_path / "x.vvol", compress="zstd")
    assert not (tmp_path / "x.vvol").exists()


def test_bad_arrays(tmp_path):
    with pytest.raises(ValueError, match="3D array"):
        volkit.save(np.zeros((2, 2, 2, 2), np.uint8), tmp_path / "x.vvol")
    with pytest.raises(ValueError, match="complex128"):
        volkit.save(np.zeros((2, 2, 2), complex), tmp_path / "x.vvol")
    with pytest.raises(ValueError, match="spacing must be positive"):
        volkit.save(np.zeros((2, 2, 2), np.uint8), tmp_path / "x.vvol", spacing=(1, 0, 1))


def test_generate_checks_like_vol_gen(tmp_path):
    r = cli("vol-gen", "phantom", "--dims", "8,8,8", "--type", "u8", "-o", tmp_path / "x.vvol", check=False)
    with pytest.raises(ValueError) as e:
        volkit.generate("phantom", (8, 8, 8), type="u8")
    assert str(e.value) == cli_message("vol-gen", r.stderr)
    with pytest.raises(ValueError, match="invalid value 'cube'"):
        volkit.generate("cube", (8, 8, 8))


def test_psnr_mismatch(vols):
    with pytest.raises(ValueError, match="dimensions differ"):
        volkit.psnr(vols["shapes"], vols["sphere"])


def test_interrupted_render_raises_keyboard_interrupt(vols):
    """SIGINT during a long path-traced render: KeyboardInterrupt at the
    next pass, not at the end of the render. (A time budget makes short
    passes; a sample count is done in sixteen passes.)"""
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        volkit.render(vols["shapes"], mode="path", tf="shapes", env=1, seconds=300, size="64x64")
    took = time.perf_counter() - start
    timer.cancel()
    assert took < 20, took
    # A ray-cast frame stops between tiles.
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        volkit.render(vols["shapes"], tf="shapes", shading="phong", ao="16", size="2000x2000", step=0.05, repeat=1000)
    took = time.perf_counter() - start
    timer.cancel()
    assert took < 20, took
    # The next call works (nothing is left cancelled).
    img, _ = volkit.render(vols["shapes"], tf="shapes", size="8x8")
    assert img.shape == (8, 8, 3)


def test_interrupted_save_raises_and_leaves_no_file(tmp_path):
    # Random samples: gzip takes seconds over them, so the signal comes
    # while the conversion runs.
    a = np.random.default_rng(1).integers(0, 255, size=(400, 512, 512), dtype=np.uint8)
    out = tmp_path / "big.nii.gz"
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        volkit.save(a, out)
    timer.cancel()
    assert not out.exists()
    volkit.save(a[:2], tmp_path / "ok.vvol")
    assert (tmp_path / "ok.vvol").exists()
