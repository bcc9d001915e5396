"""A short tour of volkit, typed: python/ci.sh runs it and type-checks it
with mypy against the package's stubs (volkit/__init__.pyi), so the
stubs keep saying what the functions take.

Usage: python tour.py [DIR]   (writes sphere.nii.gz into DIR, default a
temporary folder)"""

import sys
import tempfile
from typing import Any, Dict

import numpy as np
import numpy.typing as npt

import volkit


def tour(out_dir: str) -> Dict[str, Any]:
    """Make, save, reopen, slice, render and compare a volume."""
    vol: volkit.Volume = volkit.generate("sphere", (32, 32, 32), type="u16", value=4000)
    path = f"{out_dir}/sphere.nii.gz"
    volkit.save(vol, path)
    back = volkit.open(path, time_point=0)
    samples: npt.NDArray[Any] = back.array()  # decoded: a new, writable array
    samples[0, 0, 0] = 1
    crop: volkit.Volume = back[4:28, 4:28, 4:28]  # a Volume whose origin moved
    plane: npt.NDArray[Any] = back[16]  # an integer drops an axis: an array
    affine: npt.NDArray[np.float64] = crop.affine
    # Points are (z, y, x), as every other value.
    img, report = volkit.render(crop, tf="auto", eye=(100.0, 12.0, 12.0), look_at=(12.0, 12.0, 12.0), size=(48, 48))
    same: Dict[str, Any] = volkit.psnr(back, vol)
    made = volkit.from_array(plane[np.newaxis], spacing=crop.spacing, origin=crop.origin)
    return {
        "crop_origin": crop.origin,
        "affine_origin": affine[:3, 3].tolist(),
        "image": img.shape,
        "rays": report["rays"],
        "identical": same["identical"],
        "plane": made.shape,
    }


if __name__ == "__main__":
    if len(sys.argv) > 1:
        print(tour(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as d:
            print(tour(d))
