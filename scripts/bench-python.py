"""Python against the CLI on the thesis scene (issue 44's targets).

Renders the thesis benchmark frame (vol-gen shapes 800^3 seed 2, bricked
32; 700x700, step 0.2, the shapes transfer function, Phong, eye
1100,1100,1100, fov 60: scripts/bench-render.sh's scene) with vol-render
and with volkit.render, ROUNDS interleaved rounds of --repeat REPEAT
frames each, and prints each side's median frame time (the reports'
render_s, the median of each run's frames) and their ratio, with the load
average. Also times opening a 2 GiB sliced .vvol.
Usage: python scripts/bench-python.py [DIM] [REPEAT] [ROUNDS]   (default 800 5 5),
with volkit installed (pip install ./python).
Environment: VOLKIT_BIN_DIR (default ../target/release), DIR (out/bench).
"""

import json
import os
import pathlib
import statistics
import subprocess
import sys
import time

import volkit

root = pathlib.Path(__file__).resolve().parent.parent
bin_dir = pathlib.Path(os.environ.get("VOLKIT_BIN_DIR", root / "target" / "release"))
out = pathlib.Path(os.environ.get("DIR", root / "out" / "bench"))
out.mkdir(parents=True, exist_ok=True)
dim = int(sys.argv[1]) if len(sys.argv) > 1 else 800
repeat = int(sys.argv[2]) if len(sys.argv) > 2 else 5
rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5

vol = out / f"shapes-{dim}-b32.vvol"
if not vol.exists():
    size = dim * 70 // 800
    subprocess.run([bin_dir / "vol-gen", "shapes", "--dims", f"{dim},{dim},{dim}", "--seed", "2", "--count", "70",
                    "--size", str(size), "--value", "100", "--layout", "bricked:32", "-o", vol, "--quiet"], check=True)
e = dim * 1100 // 800
scene = dict(tf="shapes", shading="phong", step=0.2, size="700x700", eye=[e, e, e], look_at=[0, 0, 0],
             up=[0, 1, 0], fov=60, repeat=repeat)
flags = ["--tf", "shapes", "--shading", "phong", "--step", "0.2", "--size", "700x700", "--eye", f"{e},{e},{e}",
         "--look-at", "0,0,0", "--up", "0,1,0", "--fov", "60", "--repeat", str(repeat)]
vol.read_bytes()  # warm the page cache

cli_s, py_s = [], []
for r in range(rounds):
    j = subprocess.run([bin_dir / "vol-render", vol, *flags, "-o", out / "cli.png", "--json"],
                       capture_output=True, text=True, check=True).stdout
    cli_s.append(json.loads(j)["render_s"])
    _, rep = volkit.render(str(vol), **scene)
    py_s.append(rep["render_s"])
    print(f"round {r}: cli {cli_s[-1]:.4f} s  python {py_s[-1]:.4f} s")
c, p = statistics.median(cli_s), statistics.median(py_s)
print(f"thesis scene {dim}^3, 700x700: cli median {c:.4f} s, python median {p:.4f} s, python/cli {p / c:.4f}")
print("load average:", open("/proc/loadavg").read().split()[:3])

# Opening a 2 GiB sliced .vvol.
big = out / "big-2g.vvol"
if not big.exists():
    raw = out / "big_2048x1024x1024_uint8.raw"
    with open(raw, "wb") as f:
        f.truncate(2048 * 1024 * 1024)
    subprocess.run([bin_dir / "vol-convert", raw, "-o", big, "--quiet"], check=True)
    raw.unlink()
times = []
for _ in range(7):
    t = time.perf_counter()
    v = volkit.open(big)
    times.append(time.perf_counter() - t)
    del v
print(f"open {big.stat().st_size / 2**30:.2f} GiB .vvol: median {statistics.median(times) * 1000:.2f} ms, "
      f"best {min(times) * 1000:.2f} ms")
