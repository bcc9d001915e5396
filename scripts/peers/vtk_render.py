#!/usr/bin/env python3
"""Peer timing: the thesis benchmark scene rendered by VTK's CPU ray caster
(vtkFixedPointVolumeRayCastMapper), offscreen, printing ONE JSON line so the
benchmark script can put volkit's times beside VTK's from the same run.

Scene (the same geometry as `vol-render --tf shapes --shading phong --step 0.2
--size 700x700 --eye 1100,1100,1100 --look-at 0,0,0 --up 0,1,0 --fov 60`):
  - u8 volume, voxel (i,j,k) at world (i,j,k)*spacing (spacing from the .vol
    header, 1 for .raw), origin 0;
  - perspective camera at (1100,1100,1100) looking at the origin, view up
    +y, 60 degree vertical view angle, 700x700 pixels, black background;
  - transfer function 'shapes' with step edges, ranges half-open [lo, hi):
    85-95 red a=0.02, 95-100 blue a=0.3, 100-115 green a=0.6, else a=0.
    Opacity is per unit length (ScalarOpacityUnitDistance 1 = one voxel):
    VTK corrects every table entry to 1-(1-a)^(SampleDistance/1), the same
    correction volkit applies for its step;
  - trilinear interpolation, SampleDistance 0.2, AutoAdjustSampleDistances
    off, ImageSampleDistance 1 (one ray per pixel);
  - Phong shading with VTK 9's own defaults ambient 0.1, diffuse 0.7,
    specular 0.2, specular power 10, lit by the renderer's automatic white
    headlight (volkit's defaults are 0.25/0.65/0.35/24: --phong changes them;
    the weights do not change the cost, VTK shades through lookup tables).
VTK-specific differences worth knowing when comparing pictures: the mapper
samples the TF tables at integer values (u8 data: the interpolated value is
truncated to an integer before lookup), shades with normals precomputed per
voxel (central differences, quantised to a table of directions), composites
in 15-bit fixed point and writes the result as is, while volkit encodes its
linear result to sRGB (so VTK's PNG looks darker). VTK's pictures differ
slightly between 1 and 2 threads (its gradient pass splits z into slabs).

Input: VOLUME is a thesis .vol (26-byte little-endian header: u32 dims X,Y,Z;
f32 spacing x3; u8 layout 1=sliced/2=bricked; u8 brick size; sliced data has
z fastest, x slowest), sliced layout only, transposed with numpy to the
x-fastest order VTK needs; or a .raw u8 file, x fastest, with --dims X,Y,Z
(or a vol-gen name NAME_XxYxZ_u8.raw). Loading and transposing are timed
apart (load_s) and never count in a frame.

Timing: one warm-up frame (VTK builds its gradient and min/max space-leaping
volumes there; its time is warmup_s), then --repeat frames, each a full
renWin.Render() of an unchanged scene (VTK ray-casts on every Render; the
mapper's own ray-casting time per frame is in raycast_frames). render_s is
the median wall time of the counted frames.

Offscreen GL: with the pip wheel, vtkRenderWindow tries X first (warns
"bad X server connection") then falls back to EGL. This script sets
VTK_DEFAULT_OPENGL_WINDOW=vtkOSOpenGLRenderWindow (Debian's libosmesa6;
override it in the environment to choose otherwise) and LP_NUM_THREADS=N
(Mesa llvmpipe, which only draws the finished image as a texture).

Usage:
  python3 scripts/peers/vtk_render.py VOLUME [--dims X,Y,Z] [--threads N]
      [--repeat N] [--phong A,D,S,P] [-o last_frame.png]
Output (stdout, one line):
  {"peer":"vtk","vtk_version":"9.7.2","threads":2,"frames":[...],
   "render_s":...,"load_s":...,"size":"700x700",...}
Errors: one line `vtk_render.py: FILE: problem` on stderr, exit 2.
"""
import argparse
import json
import os
import re
import statistics
import struct
import sys
import time

import numpy as np

PROG = "vtk_render.py"
SIZE = 700
VOL_HEADER = 26


class InputError(Exception):
    """Bad input: reported as one line and exit status 2."""


def fail(what, problem):
    line = f"{PROG}: {what}: {problem}"
    print("".join(c if c.isprintable() else repr(c)[1:-1] for c in line), file=sys.stderr)
    sys.exit(2)


def parse_list(text, kind, count, what):
    try:
        vals = [kind(p) for p in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) != count:
        raise InputError(f"{what} must be {count} comma-separated numbers, got '{text}'")
    return vals


def check_dims(dims):
    if any(d < 1 or d > 65535 for d in dims):
        raise InputError(f"dims {dims} out of range 1-65535")
    return dims


def load_vol(path):
    """A sliced thesis .vol as an x-fastest (Z,Y,X) array, and its spacing."""
    size = os.path.getsize(path)
    if size < VOL_HEADER:
        raise InputError(f"{size} bytes, shorter than the 26-byte .vol header")
    with open(path, "rb") as f:
        head = f.read(VOL_HEADER)
    x, y, z = check_dims(list(struct.unpack_from("<3I", head, 0)))
    spacing = struct.unpack_from("<3f", head, 12)
    layout = head[24]
    if layout == 2:
        raise InputError("bricked .vol is not supported; write a sliced one (vol-convert or vol-gen --layout sliced)")
    if layout != 1:
        raise InputError(f"unknown layout byte {layout} (1 sliced, 2 bricked)")
    if not all(np.isfinite(s) and s > 0 for s in spacing):
        raise InputError(f"spacing {spacing} must be positive and finite")
    want = VOL_HEADER + x * y * z
    if size != want:
        raise InputError(f"{size} bytes, but dims {x}x{y}x{z} need {want}")
    src = np.memmap(path, dtype=np.uint8, mode="r", offset=VOL_HEADER, shape=(x, y, z))
    out = np.empty((z, y, x), dtype=np.uint8)
    step = 32  # slabs of x: a strided copy that stays cache-friendly
    for x0 in range(0, x, step):
        out[:, :, x0:x0 + step] = src[x0:x0 + step].transpose(2, 1, 0)
    del src
    return out, [float(s) for s in spacing]


def load_raw(path, dims_arg):
    if dims_arg:
        dims = parse_list(dims_arg, int, 3, "--dims")
    else:
        m = re.search(r"_(\d+)x(\d+)x(\d+)_([a-z0-9]+)\.raw$", os.path.basename(path))
        if not m:
            raise InputError("needs --dims X,Y,Z (or a name like NAME_XxYxZ_u8.raw)")
        if m.group(4) != "u8":
            raise InputError(f"sample type {m.group(4)} is not supported (u8 only)")
        dims = [int(g) for g in m.groups()[:3]]
    x, y, z = check_dims(dims)
    size = os.path.getsize(path)
    if size != x * y * z:
        raise InputError(f"{size} bytes, but u8 dims {x}x{y}x{z} need {x * y * z}")
    return np.fromfile(path, dtype=np.uint8).reshape(z, y, x), [1.0, 1.0, 1.0]


def pin_threads(n):
    cpus = sorted(os.sched_getaffinity(0))
    if n < 1 or n > len(cpus):
        fail(f"--threads {n}", f"this process may use 1-{len(cpus)} CPUs")
    os.sched_setaffinity(0, cpus[:n])
    os.environ["LP_NUM_THREADS"] = str(n)


def check_options(args):
    """Option problems, before the slow load: returns the Phong weights."""
    if not 1 <= args.repeat <= 1000:
        fail(f"--repeat {args.repeat}", "must be 1-1000")
    try:
        phong = parse_list(args.phong, float, 4, "--phong")
    except InputError:
        fail(f"--phong {args.phong}", "needs four comma-separated numbers A,D,S,P")
    if not all(np.isfinite(v) and v >= 0 for v in phong):
        fail("--phong", "weights must be finite and non-negative")
    if args.output:
        out_dir = os.path.dirname(os.path.abspath(args.output))
        if not args.output.lower().endswith(".png"):
            fail(args.output, "the output must be a .png")
        if not os.path.isdir(out_dir) or not os.access(out_dir, os.W_OK):
            fail(args.output, f"cannot write into {out_dir}")
    pin_threads(args.threads)
    return phong


def build_scene(vtk, data, spacing, threads, phong):
    from vtkmodules.util.numpy_support import numpy_to_vtk

    z, y, x = data.shape
    image = vtk.vtkImageData()
    image.SetDimensions(x, y, z)
    image.SetSpacing(*spacing)
    image.SetOrigin(0.0, 0.0, 0.0)
    scalars = numpy_to_vtk(data.reshape(-1), deep=False, array_type=vtk.VTK_UNSIGNED_CHAR)
    image.GetPointData().SetScalars(scalars)

    # 'shapes': flat ranges [lo, hi) with step edges just below each bound.
    ranges = [(85, 95, (1, 0, 0), 0.02), (95, 100, (0, 0, 1), 0.3), (100, 115, (0, 1, 0), 0.6)]
    eps = 1e-3
    opacity = vtk.vtkPiecewiseFunction()
    colour = vtk.vtkColorTransferFunction()
    opacity.AddPoint(0.0, 0.0)
    opacity.AddPoint(255.0, 0.0)
    colour.AddRGBPoint(0.0, 0, 0, 0)
    colour.AddRGBPoint(255.0, 0, 0, 0)
    for lo, hi, rgb, a in ranges:
        if lo == 85:
            opacity.AddPoint(lo - eps, 0.0)
            colour.AddRGBPoint(lo - eps, 0, 0, 0)
        opacity.AddPoint(lo, a)
        opacity.AddPoint(hi - eps, a)
        colour.AddRGBPoint(lo, *rgb)
        colour.AddRGBPoint(hi - eps, *rgb)
    opacity.AddPoint(115.0, 0.0)
    colour.AddRGBPoint(115.0, 0, 0, 0)

    prop = vtk.vtkVolumeProperty()
    prop.SetColor(colour)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(1.0)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOn()
    prop.SetAmbient(phong[0])
    prop.SetDiffuse(phong[1])
    prop.SetSpecular(phong[2])
    prop.SetSpecularPower(phong[3])

    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(image)
    mapper.SetNumberOfThreads(threads)
    mapper.AutoAdjustSampleDistancesOff()
    mapper.LockSampleDistanceToInputSpacingOff()
    mapper.SetSampleDistance(0.2)
    mapper.SetImageSampleDistance(1.0)
    mapper.SetBlendModeToComposite()

    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)

    ren = vtk.vtkRenderer()
    ren.SetBackground(0, 0, 0)
    ren.AddVolume(volume)
    cam = ren.GetActiveCamera()
    cam.SetPosition(1100, 1100, 1100)
    cam.SetFocalPoint(0, 0, 0)
    cam.SetViewUp(0, 1, 0)
    cam.SetViewAngle(60)
    # Rays run from the near to the far plane: cover the whole volume (the
    # default far plane, 1000, would cut it).
    ren.ResetCameraClippingRange()

    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.SetSize(SIZE, SIZE)
    win.AddRenderer(ren)
    return win, ren, mapper, scalars


def write_png(vtk, win, path):
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(win)
    grab.ReadFrontBufferOff()
    grab.Update()
    tmp = path + ".tmp.png"
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(tmp)
    writer.SetInputConnection(grab.GetOutputPort())
    vtk.vtkObject.GlobalWarningDisplayOff()  # failures: our one line only
    writer.Write()
    vtk.vtkObject.GlobalWarningDisplayOn()
    if writer.GetErrorCode() != 0 or not os.path.exists(tmp):
        raise InputError("could not write the PNG")
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("volume", metavar="VOLUME", help="sliced thesis .vol, or u8 x-fastest .raw")
    ap.add_argument("--dims", help=".raw only: X,Y,Z")
    ap.add_argument("--threads", type=int, default=len(os.sched_getaffinity(0)),
                    help="ray-casting threads; the process is pinned to this many CPUs (default: all)")
    ap.add_argument("--repeat", type=int, default=5, help="timed frames after one warm-up (default 5)")
    ap.add_argument("--phong", default="0.1,0.7,0.2,10",
                    help="ambient,diffuse,specular,power (default VTK's 0.1,0.7,0.2,10; volkit's: 0.25,0.65,0.35,24)")
    ap.add_argument("-o", "--output", help="write the last frame as PNG")
    ap.error = lambda message: fail("usage", message)  # one line, exit 2
    args = ap.parse_args()

    phong = check_options(args)
    path = args.volume
    try:
        t0 = time.perf_counter()
        if path.lower().endswith(".vol"):
            data, spacing = load_vol(path)
        elif path.lower().endswith(".raw"):
            data, spacing = load_raw(path, args.dims)
        else:
            raise InputError("not a .vol or .raw file")
        load_s = time.perf_counter() - t0
    except InputError as e:
        fail(path, e)
    except OSError as e:
        fail(path, e.strerror or e)
    except MemoryError:
        fail(path, "not enough memory for the volume")

    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
    import vtk

    vtk.vtkMultiThreader.SetGlobalMaximumNumberOfThreads(args.threads)
    vtk.vtkMultiThreader.SetGlobalDefaultNumberOfThreads(args.threads)
    win, ren, mapper, _keep = build_scene(vtk, data, spacing, args.threads, phong)
    cam = ren.GetActiveCamera()

    t0 = time.perf_counter()
    win.Render()
    warmup_s = time.perf_counter() - t0
    frames, raycast = [], []
    for _ in range(args.repeat):
        cam.Modified()
        t0 = time.perf_counter()
        win.Render()
        frames.append(time.perf_counter() - t0)
        raycast.append(mapper.GetTimeToDraw())
    if args.output:
        try:
            write_png(vtk, win, args.output)
        except InputError as e:
            fail(args.output, e)

    print(json.dumps({
        "peer": "vtk",
        "vtk_version": vtk.vtkVersion.GetVTKVersion(),
        "threads": args.threads,
        "frames": [round(t, 4) for t in frames],
        "render_s": round(statistics.median(frames), 4),
        "raycast_frames": [round(t, 4) for t in raycast],
        "warmup_s": round(warmup_s, 3),
        "load_s": round(load_s, 3),
        "size": f"{SIZE}x{SIZE}",
        "dims": list(data.shape[::-1]),
        "image_sample_distance": mapper.GetImageSampleDistance(),
        "gl_window": win.GetClassName(),
    }))


if __name__ == "__main__":
    main()
