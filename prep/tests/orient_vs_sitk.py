#!/usr/bin/env python3
"""volprep's --orient against SimpleITK's DICOMOrient, all 48 codes.

For small volumes (3x4x5, voxel value = linear index) with anisotropic
spacing, a non-zero origin and several directions (axis-aligned but
permuted and flipped, the identity, and oblique ones), every code's output
from `examples/orient_dump.rs` must equal `sitk.DICOMOrient(img, code)`:
the same voxels (exactly), dims, spacing, origin and direction (to 1e-9).
For axis-aligned inputs nibabel's `aff2axcodes` of the output's RAS affine
(what a NIfTI writer stores: LPS x and y negated) must name the code too;
for oblique inputs its letters are reported (nibabel picks axes its own
way) but not required.

Usage: python3 prep/tests/orient_vs_sitk.py [--dump PATH]
  --dump PATH   the orient_dump binary (default: $ORIENT_DUMP, else
                `cargo run --release -q -p volprep --example orient_dump`
                from the repository root). Needs SimpleITK and numpy;
                nibabel is optional.
Exit status 0 when everything matches, 1 on a mismatch, 2 on a setup error.
"""

import json
import math
import os
import subprocess
import sys

try:
    import numpy as np
    import SimpleITK as sitk
except ImportError as e:
    print(f"orient_vs_sitk: needs numpy and SimpleITK ({e})", file=sys.stderr)
    sys.exit(2)
try:
    import nibabel.orientations as nio
except ImportError:
    nio = None

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DIMS = (3, 4, 5)
SPACING = (0.5, 0.7, 2.0)
ORIGIN = (10.0, -5.0, 3.0)

PAIRS = [("L", "R"), ("P", "A"), ("S", "I")]


def all_codes():
    out = []
    for p in [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]:
        for signs in range(8):
            out.append("".join(PAIRS[p[a]][(signs >> a) & 1] for a in range(3)))
    return out


def rot(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    m = np.eye(3)
    i, j = [(1, 2), (0, 2), (0, 1)][axis]
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def cols(*axes):
    """A direction matrix whose column a is axes[a] (world vectors)."""
    return np.array(axes, dtype=float).T


def gram_schmidt(a, b):
    """An orthonormal direction whose first two columns follow a and b."""
    a = np.array(a, float)
    a /= np.linalg.norm(a)
    b = np.array(b, float)
    b -= a * (a @ b)
    b /= np.linalg.norm(b)
    return np.stack([a, b, np.cross(a, b)], axis=1)


CASES = [
    # name, direction (3x3, [row][axis]), axis-aligned?
    ("identity (LPS)", np.eye(3), True),
    ("permuted+flipped (ALI)", cols((0, -1, 0), (1, 0, 0), (0, 0, -1)), True),
    ("permuted (SRP)", cols((0, 0, 1), (-1, 0, 0), (0, 1, 0)), True),
    ("RAS (NIfTI usual)", cols((-1, 0, 0), (0, -1, 0), (0, 0, 1)), True),
    ("oblique 20 deg", rot(2, 20) @ rot(0, 10) @ cols((0, 0, 1), (-1, 0, 0), (0, 1, 0)), False),
    ("oblique 40 deg", rot(1, 40) @ rot(2, 35) @ cols((0, -1, 0), (1, 0, 0), (0, 0, -1)), False),
    ("45 deg (ties)", rot(2, 45), False),
    ("two axes nearest x", gram_schmidt((1, 0.9, 0.9), (1, -0.8, -0.3)), False),
]


def dump_cmd(args):
    exe = args.dump or os.environ.get("ORIENT_DUMP")
    if exe:
        return [exe]
    return ["cargo", "run", "--release", "-q", "-p", "volprep", "--example", "orient_dump", "--"]


def run_dump(cmd, direction, codes):
    argv = [str(v) for v in DIMS] + [repr(v) for v in SPACING] + [repr(v) for v in ORIGIN]
    argv += [repr(float(v)) for v in direction.ravel()]
    r = subprocess.run(cmd + argv + codes, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        print(f"orient_dump failed: {r.stderr.strip()}", file=sys.stderr)
        sys.exit(2)
    return {d["code"]: d for d in map(json.loads, r.stdout.splitlines())}


def sitk_image(direction):
    nx, ny, nz = DIMS
    a = np.arange(nx * ny * nz, dtype=np.float32).reshape(nz, ny, nx)
    img = sitk.GetImageFromArray(a)
    img.SetSpacing(SPACING)
    img.SetOrigin(ORIGIN)
    img.SetDirection(tuple(float(v) for v in direction.ravel()))
    return img


def ras_codes(d):
    """nibabel's aff2axcodes of the RAS affine a NIfTI writer would store."""
    lps = np.eye(4)
    lps[:3, :3] = np.array(d["direction"]).reshape(3, 3) * np.array(d["spacing"])
    lps[:3, 3] = d["origin"]
    ras = np.diag([-1.0, -1.0, 1.0, 1.0]) @ lps
    return "".join(nio.aff2axcodes(ras))


def main():
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dump")
    args = ap.parse_args()
    cmd = dump_cmd(args)
    codes = all_codes()
    assert len(set(codes)) == 48
    bad = 0
    for name, direction, aligned in CASES:
        ours = run_dump(cmd, direction, codes)
        img = sitk_image(direction)
        given = sitk.DICOMOrientImageFilter.GetOrientationFromDirectionCosines(img.GetDirection())
        nib_other = []
        for code in codes:
            s = sitk.DICOMOrient(img, code)
            o = ours[code]
            problems = []
            if list(s.GetSize()) != o["dims"]:
                problems.append(f"dims {o['dims']} vs sitk {list(s.GetSize())}")
            if not np.allclose(s.GetSpacing(), o["spacing"], rtol=0, atol=1e-12):
                problems.append(f"spacing {o['spacing']} vs sitk {s.GetSpacing()}")
            if not np.allclose(s.GetOrigin(), o["origin"], rtol=0, atol=1e-9):
                problems.append(f"origin {o['origin']} vs sitk {s.GetOrigin()}")
            if not np.allclose(s.GetDirection(), o["direction"], rtol=0, atol=1e-9):
                problems.append(f"direction {o['direction']} vs sitk {s.GetDirection()}")
            if not problems:
                want = sitk.GetArrayFromImage(s).ravel()
                got = np.array(o["voxels"], dtype=np.float32)
                if want.shape != got.shape or not np.array_equal(want, got):
                    problems.append("voxels differ")
            if nio is not None:
                nc = ras_codes(o)
                if nc != code:
                    if aligned:
                        problems.append(f"nibabel aff2axcodes says {nc}")
                    else:
                        nib_other.append(f"{code}->{nc}")
            for p in problems:
                print(f"MISMATCH {name} (given {given}) --orient {code}: {p}")
            bad += bool(problems)
        note = ""
        if nib_other:
            note = f"; nibabel names {len(nib_other)} codes differently (oblique): {' '.join(nib_other[:4])} ..."
        print(f"{name} (given {given}): 48 codes compared{note}")
    if nio is None:
        print("nibabel not installed: aff2axcodes not checked")
    if bad:
        print(f"{bad} mismatches")
        return 1
    print("all codes equal SimpleITK's DICOMOrient in voxels, dims, spacing, origin and direction")
    return 0


if __name__ == "__main__":
    sys.exit(main())
