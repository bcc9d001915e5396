"""vol-view's interactivity on a volume, measured in a real browser:
Playwright drives the system's Chromium through a 1 s drag of a 512x512
view and reads the page's own figures. For each build given (a folder of
vol-view), REPEAT rounds alternate between the builds.

    python3 bench_view.py --chromium /usr/bin/chromium --scene s.toml \
        --bin new=target/release [--bin old=/work/bt-old/release] [--repeat 5]

Per build and round: the first full frame (from navigation start), the
previews drawn per second of dragging, input-to-pixels of each preview
(median), the full frame after the release, and the last preview's note.
Prints one JSON object: the rounds, each build's medians and the load
average before and after.
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import time
from pathlib import Path

from playwright.sync_api import sync_playwright


def start(bin_dir, scene):
    proc = subprocess.Popen([str(bin_dir / "vol-view"), "--scene", str(scene)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    m = re.search(r"(http://\S+)", line)
    if not m:
        proc.kill()
        raise SystemExit(f"vol-view printed no address: {line!r} {proc.stderr.read()!r}")
    return proc, m.group(1)


def wait_full(page, timeout=60000):
    page.wait_for_function(
        "() => { const S = window.volview; const h = S.last && S.last.header;"
        " return h && h.seq === S.seq && !h.preview && h.final; }", timeout=timeout)


def one_round(browser, bin_dir, scene):
    proc, url = start(bin_dir, scene)
    try:
        ctx = browser.new_context(viewport={"width": 1000, "height": 960}, device_scale_factor=1,
                                  bypass_csp=True)
        page = ctx.new_page()
        page.goto(url)
        page.wait_for_function("window.volview.stats.firstFull != null", timeout=60000)
        wait_full(page)
        first = page.evaluate("volview.stats.firstFull")
        box = page.locator("#view").bounding_box()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        page.mouse.move(x, y)
        page.mouse.down()
        before = page.evaluate("volview.stats.previews")
        t0 = time.perf_counter()
        for i in range(30):
            page.mouse.move(x + 6 * (i + 1), y + 2 * (i + 1))
            time.sleep(1.0 / 30)
        drag_s = time.perf_counter() - t0
        previews = page.evaluate("volview.stats.previews") - before
        note = page.evaluate("document.getElementById('overlay').textContent")
        page.mouse.up()
        wait_full(page)
        lat = page.evaluate("volview.stats.latencies")
        stop = page.evaluate("volview.stats.stopToFull[volview.stats.stopToFull.length - 1]")
        ctx.close()
        return {
            "first_full_ms": first,
            "previews_per_s": previews / drag_s,
            "drag_median_ms": statistics.median(lat) if lat else None,
            "stop_to_full_ms": stop,
            "note": note,
        }
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    ap.add_argument("--scene", required=True, type=Path)
    ap.add_argument("--bin", action="append", required=True,
                    help="NAME=FOLDER holding vol-view (repeatable)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    builds = [(b.split("=", 1)[0], Path(b.split("=", 1)[1]).resolve()) for b in args.bin]
    rounds = {name: [] for name, _ in builds}
    load_before = os.getloadavg()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=args.chromium, args=["--no-sandbox"])
        for _ in range(args.repeat):
            for name, folder in builds:
                rounds[name].append(one_round(browser, folder, args.scene.resolve()))
        browser.close()
    medians = {}
    for name, rs in rounds.items():
        medians[name] = {k: statistics.median(r[k] for r in rs if r[k] is not None)
                         for k in ["first_full_ms", "previews_per_s", "drag_median_ms",
                                   "stop_to_full_ms"]}
    print(json.dumps({"scene": str(args.scene), "rounds": rounds, "medians": medians,
                      "load_before": load_before, "load_after": os.getloadavg(),
                      "cores": os.cpu_count()}, indent=1))


if __name__ == "__main__":
    main()
