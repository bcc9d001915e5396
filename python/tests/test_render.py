"""volkit.render gives vol-render --hdr's float image bit for bit, and
vol-render --json's figures; psnr gives vol-psnr --json's."""

import json

import numpy as np
import pytest

import volkit
from conftest import cli, read_pfm

# (volume, vol-render flags, the same as keyword arguments). Points and
# directions are x,y,z on the command line and (z, y, x) in Python
# (issue 53 §2): the same render either way.
CASES = {
    "dvr-phong": (
        "shapes",
        ["--tf", "shapes", "--shading", "phong", "--size", "96x80", "--orbit", "30,20,150"],
        dict(tf="shapes", shading="phong", size="96x80", orbit=[30, 20, 150]),
    ),
    "dvr-shadows-ao": (
        "shapes",
        ["--tf", "shapes", "--light", "1,2,3", "--shadows", "grid:2", "--ao", "4", "--size", "64x64"],
        dict(tf="shapes", light=(3, 2, 1), shadows="grid:2", ao="4", size=(64, 64)),
    ),
    "mip": (
        "sphere",
        ["--mode", "mip", "--ortho", "--size", "64x48"],
        dict(mode="mip", ortho=True, size="64x48"),
    ),
    "iso": (
        "sphere",
        ["--mode", "iso", "--iso", "2000", "--size", "72x72", "--eye", "80,60,90", "--look-at", "18,20,24",
         "--up", "0.2,0,1"],
        dict(mode="iso", iso=2000, size="72x72", eye=[90, 60, 80], look_at=[24, 20, 18], up=(1, 0, 0.2)),
    ),
    "compressed-noise": (
        "noise",
        ["--tf", "auto", "--size", "64x64", "--step", "0.7"],
        dict(tf="auto", size="64x64", step=0.7),
    ),
    "path": (
        "shapes",
        ["--mode", "path", "--tf", "shapes", "--env", "1", "--spp", "6", "--seed", "11", "--size", "48x40"],
        dict(mode="path", tf="shapes", env=1, spp=6, seed=11, size="48x40"),
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_render_matches_vol_render(tmp_path, vols, case):
    name, flags, kwargs = CASES[case]
    pfm = tmp_path / "cli.pfm"
    r = cli("vol-render", vols[name], *flags, "--hdr", pfm, "-o", tmp_path / "cli.png", "--json")
    want = read_pfm(pfm)
    figures = json.loads(r.stdout)
    img, report = volkit.render(volkit.open(vols[name]), **kwargs)
    assert img.dtype == np.float32 and img.shape == want.shape
    assert np.array_equal(img, want, equal_nan=True)
    for key in ("mode", "width", "height", "rays", "samples", "skips", "spp", "paths"):
        if key in figures:
            assert report[key] == figures[key], key
    # The effective scene, but for the files the command line wrote.
    files = ("output", "hdr")
    assert {k: v for k, v in report["scene"].items() if k not in files} == {
        k: v for k, v in figures["scene"].items() if k not in files
    }
    # The path given directly renders the same.
    img2, _ = volkit.render(str(vols[name]), **kwargs)
    assert np.array_equal(img2, want, equal_nan=True)


def test_render_an_array_and_alpha(vols):
    v = volkit.open(vols["shapes"])
    a = v.array().copy()
    img, _ = volkit.render(a, tf="shapes", size="32x32")
    ref, _ = volkit.render(volkit.from_array(a), tf="shapes", size="32x32")
    assert np.array_equal(img, ref)
    rgba, _ = volkit.render(v, tf="shapes", size="32x32", alpha=True)
    assert rgba.shape == (32, 32, 4)
    assert 0.0 <= rgba[..., 3].min() and rgba[..., 3].max() <= 1.0


def test_scene_file_with_overrides(tmp_path, vols):
    scene = tmp_path / "s.toml"
    scene.write_text(f'volume = "{vols["shapes"]}"\ntf = "shapes"\nsize = [40, 30]\nshading = "phong"\n')
    pfm = tmp_path / "cli.pfm"
    cli("vol-render", "--scene", scene, "--size", "50x20", "--hdr", pfm, "-o", tmp_path / "cli.png")
    img, report = volkit.render(scene=scene, size=[50, 20])
    assert img.shape == (20, 50, 3)
    assert np.array_equal(img, read_pfm(pfm))


def test_accumulate_continues_a_path_traced_state(tmp_path, vols):
    state = tmp_path / "pt.state"
    opts = dict(mode="path", tf="shapes", env=1, seed=5, size="24x24")
    volkit.render(vols["shapes"], spp=3, accumulate=state, **opts)
    img, report = volkit.render(vols["shapes"], spp=3, accumulate=state, **opts)
    assert report["spp"] == 6 and report["spp_added"] == 3
    once, _ = volkit.render(vols["shapes"], spp=6, **opts)
    assert np.array_equal(img, once)


def test_psnr_matches_vol_psnr(tmp_path, vols):
    v = volkit.open(vols["shapes"])
    b = v.array().astype(np.int16)
    b[3:9, 4:6, 10:30] += 9
    volkit.save(b.astype(np.uint8), tmp_path / "b.vvol", spacing=v.spacing)
    want = json.loads(cli("vol-psnr", vols["shapes"], tmp_path / "b.vvol", "--json").stdout)
    got = volkit.psnr(v, tmp_path / "b.vvol")
    for key in ("psnr", "identical", "mse", "max_abs", "differing", "differing_fraction", "count", "nonfinite", "peak"):
        assert got[key] == want[key], key
    # Images: two renders written by vol-render.
    for i, size in enumerate(["40x40", "40x40"]):
        cli("vol-render", vols["shapes"], "--tf", "shapes", "--size", size, "--orbit", f"{30 + 7 * i},20,150",
            "--hdr", tmp_path / f"i{i}.pfm", "-o", tmp_path / f"i{i}.png")
    for ext in ("pfm", "png"):
        a, c = tmp_path / f"i0.{ext}", tmp_path / f"i1.{ext}"
        want = json.loads(cli("vol-psnr", a, c, "--json").stdout)
        got = volkit.psnr(a, c)
        assert got["psnr"] == want["psnr"] and got["mse"] == want["mse"] and got["kind"] == "image"
    # The float image as arrays gives the same figures as the files.
    arrays = volkit.psnr(read_pfm(tmp_path / "i0.pfm"), read_pfm(tmp_path / "i1.pfm"), kind="image")
    want = json.loads(cli("vol-psnr", tmp_path / "i0.pfm", tmp_path / "i1.pfm", "--json").stdout)
    assert arrays["psnr"] == want["psnr"] and arrays["count"] == want["count"]


def test_index_matches_vol_index(tmp_path, vols):
    out = tmp_path / "s.vidx"
    cli("vol-index", vols["shapes"], "-o", out, "--quiet")
    ix = volkit.index(vols["shapes"], tmp_path / "py.vidx")
    assert out.read_bytes() == (tmp_path / "py.vidx").read_bytes()
    summary = json.loads(cli("vol-index", vols["shapes"], "-o", tmp_path / "t.vidx", "--json").stdout)
    assert ix.cells == summary["cells"] and ix.levels == summary["levels"]
    assert ix.range == (summary["min"], summary["max"])
    counts, lo, hi = ix.histogram()
    assert counts.sum() == 64 * 48 * 40
    # An index file vol-render accepts.
    img, _ = volkit.render(vols["shapes"], tf="shapes", size="16x16", index=tmp_path / "py.vidx")
    assert img.shape == (16, 16, 3)


def test_a_frame_budget_keeps_the_size_and_states_its_choice(vols):
    # Nothing fits a nanosecond: the coarsest setting, upsampled to the
    # size asked for; an hour fits the finest.
    img, report = volkit.render(vols["shapes"], tf="shapes", size="80x64", budget=1e-9)
    assert img.shape == (64, 80, 3) and np.isfinite(img).all()
    b = report["budget"]
    assert b["fits"] is False and b["step_factor"] == 8.0
    assert (b["rendered_width"], b["rendered_height"]) == (10, 8)
    _, report = volkit.render(vols["shapes"], tf="shapes", size="80x64", budget=3600)
    assert report["budget"]["fits"] is True and report["budget"]["scale"] == 1.0
    with pytest.raises(ValueError, match="budget"):
        volkit.render(vols["shapes"], tf="shapes", budget=0)
