"""Shared fixtures: the workspace's command-line tools (for comparing
volkit's results with theirs) and small volumes they make."""

import os
import pathlib
import subprocess

import pytest

HERE = pathlib.Path(__file__).resolve().parent
BIN = pathlib.Path(os.environ.get("VOLKIT_BIN_DIR", HERE.parent.parent / "target" / "release"))


def tool(name):
    """The path of a volkit binary; the tests need the workspace built."""
    p = BIN / name
    if not p.exists():
        pytest.fail(f"{p} not found: build the workspace (cargo build --release) or set VOLKIT_BIN_DIR")
    return str(p)


def cli(name, *args, check=True):
    """Run a tool; its CompletedProcess (text)."""
    r = subprocess.run([tool(name), *map(str, args)], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"{name} {' '.join(map(str, args))} failed ({r.returncode}): {r.stderr}")
    return r


def cli_message(name, stderr):
    """The one-line message a tool printed, without its `name: ` prefix,
    in Python's words (flags named as keywords, as volkit raises it)."""
    lines = [l for l in stderr.splitlines() if l.strip()]
    assert lines, f"{name} printed nothing on stderr"
    last = lines[-1]
    prefix = f"{name}: "
    assert last.startswith(prefix), last
    from volkit._volkit import _python_words

    return _python_words(last[len(prefix):])


def read_pfm(path):
    """A PFM file as a (H, W, 3) float32 array, rows from the top."""
    import numpy as np

    data = pathlib.Path(path).read_bytes()
    parts = data.split(b"\n", 3)
    assert parts[0] == b"PF", parts[0]
    w, h = map(int, parts[1].split())
    scale = float(parts[2])
    dtype = "<f4" if scale < 0 else ">f4"
    img = np.frombuffer(parts[3], dtype=dtype, count=w * h * 3).reshape(h, w, 3)
    return img[::-1].astype(np.float32)


@pytest.fixture(scope="session")
def vols(tmp_path_factory):
    """Small volumes made by vol-gen: shapes (u8, 64x48x40), a sphere
    (u16) and noise (bricked, zstd)."""
    d = tmp_path_factory.mktemp("vols")
    out = {
        "shapes": d / "shapes.vvol",
        "sphere": d / "sphere.vvol",
        "noise": d / "noise.vvol",
    }
    cli("vol-gen", "shapes", "--dims", "64,48,40", "--seed", "3", "--count", "12", "--size", "16",
        "--spacing", "1,0.8,1.5", "-o", out["shapes"], "--quiet")
    cli("vol-gen", "sphere", "--dims", "40,40,40", "--type", "u16", "--value", "4000", "-o", out["sphere"], "--quiet")
    cli("vol-gen", "noise", "--dims", "48,48,48", "--layout", "bricked:16", "--compress", "zstd",
        "-o", out["noise"], "--quiet")
    return out
