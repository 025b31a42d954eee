"""Point cloud streaming benchmark: `python benchmarks/pointcloud.py` (or `--quick`, `--help`).

Clouds: a synthetic site — a 40 × 20 m building, 15 m high (four walls and a roof), on 120 × 120 m
of rolling ground, points spread uniformly by area with colours — of 10 and 100 million points,
generated in chunks of 2 million and written as LAS 1.2 (point format 2: millimetre coordinates,
16-bit colours) with laspy.

Conversion: `sightplan.report.pointtiles.write_point_tiles` reads each LAS file in chunks and writes
its 3D Tiles, in a fresh process (`--convert`), so the peak resident memory (ru_maxrss) is the
conversion's alone ("of which before": the process's memory before it, Python and the imports). Columns:
seconds, points per second, peak memory, tiles, depth, largest tile.

Browser: the largest tileset drawn by web/static/pointcloud.js in Debian's chromium (Playwright,
WebGL on SwiftShader, i.e. the CPU, 960 × 540) through tests/fixtures/pointcloud.html: the camera
stands at 20 km, 300 m, 90 m and 30 m from the site until no tile is loading, then orbits for 4 s;
columns: points drawn, tiles drawn and loaded, median and 95th-percentile time between frames.
Prints two tables and writes benchmarks/pointcloud.json.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import json
import shutil
import sys
import threading
import time
import urllib.parse
from pathlib import Path

import laspy
import numpy as np
from rich.console import Console

# benchmarks/run.py, beside this script: the child processes, memory probes and tables
from run import emit, machine, numeric_table, peak_rss_mb, rss_mb, run_script

RESULT_PREFIX = "RESULT "
ROOT = Path(__file__).resolve().parents[1]
CHUNK = 2_000_000
SEED = 7
DISTANCES_M = (20_000, 300, 90, 30)
VIEW = (960, 540)
CHROMIUM = "/usr/bin/chromium"
console = Console(width=150)


def site_chunk(n: int, index: int) -> tuple[np.ndarray, np.ndarray]:
    """Chunk ``index`` of the site: (n, 3) positions and (n, 3) uint8 colours, the same for the same (n, index)."""
    rng = np.random.default_rng([SEED, index])
    area = np.array([120 * 120, 2 * 40 * 15, 2 * 20 * 15, 40 * 20], float)
    part = rng.choice(4, n, p=area / area.sum())
    u, v, side = rng.random(n), rng.random(n), rng.integers(0, 2, n)
    x = np.select([part == 0, part == 1, part == 2], [u * 120 - 60, u * 40 - 20, np.where(side, 20.0, -20.0)], u * 40 - 20)
    y = np.select([part == 0, part == 1, part == 2], [v * 120 - 60, np.where(side, 10.0, -10.0), u * 20 - 10], v * 20 - 10)
    z = np.select([part == 0, part == 1, part == 2], [0.3 * np.sin(u * 7) * np.cos(v * 5), v * 15, v * 15], 15.0)
    colour = np.array([[0, 0, 0], [200, 180, 150], [200, 180, 150], [170, 60, 50]], np.uint8)[part]
    ground = part == 0
    colour[ground] = np.column_stack([80 + 60 * v[ground], 130 + 60 * u[ground], np.full(ground.sum(), 60)]).astype(np.uint8)
    return np.column_stack([x, y, z]), colour


def write_las(path: Path, n: int) -> float:
    """Write the n-point site as LAS in chunks; returns the seconds it took."""
    t0 = time.perf_counter()
    header = laspy.LasHeader(point_format=2, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([0.0, 0.0, 0.0])
    with laspy.open(str(path), mode="w", header=header) as writer:
        for i, start in enumerate(range(0, n, CHUNK)):
            pts, rgb = site_chunk(min(CHUNK, n - start), i)
            record = laspy.ScaleAwarePointRecord.zeros(len(pts), header=header)
            record.x, record.y, record.z = pts[:, 0], pts[:, 1], pts[:, 2]
            record.red, record.green, record.blue = (rgb.astype(np.uint16) * 257).T
            writer.write_points(record)
    return time.perf_counter() - t0


def convert_child(source: str, out: str) -> None:
    """In this process: convert, then emit the summary with the seconds and the peak memory."""
    from sightplan.report.pointtiles import write_point_tiles

    write_point_tiles(np.zeros((1, 3)), Path(out).parent / "warm-up")  # compiles (or loads) the kernels
    shutil.rmtree(Path(out).parent / "warm-up")
    start_mb = rss_mb()
    t0 = time.perf_counter()
    summary = write_point_tiles(source, out)
    emit(RESULT_PREFIX, {**summary.to_dict(), "seconds": time.perf_counter() - t0, "start_rss_mb": start_mb,
                         "peak_rss_mb": peak_rss_mb()})


# --------------------------------------------------------------------------- the browser
class _Handler(http.server.SimpleHTTPRequestHandler):
    """/vendor/ from web/node_modules, /static/ from the package, /page/ from tests/fixtures, /data/ the tileset."""

    def translate_path(self, path: str) -> str:
        path = path.split("?", 1)[0]
        for prefix, folder in (("/vendor/", ROOT / "web" / "node_modules"), ("/static/", ROOT / "src/sightplan/web/static"),
                               ("/page/", ROOT / "tests" / "fixtures")):
            if path.startswith(prefix):
                return str(folder / path[len(prefix):])
        return super().translate_path(path)

    def log_message(self, *args) -> None:
        pass


class _Server(http.server.ThreadingHTTPServer):
    daemon_threads = True

    def handle_error(self, request, client_address) -> None:
        """Downloads cut short when the browser closes are not reported."""


def browser_frames(folder: Path, budget: int | None) -> list[dict]:
    """Points drawn and frame times at each distance, the tileset at ``folder``/data/tileset.json."""
    from playwright.sync_api import sync_playwright

    server = _Server(("127.0.0.1", 0), functools.partial(_Handler, directory=str(folder)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    options = {} if budget is None else {"pointBudget": budget}
    url = f"http://127.0.0.1:{server.server_address[1]}/page/pointcloud.html?options={urllib.parse.quote(json.dumps(options))}"
    args = ["--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-gpu-sandbox", "--no-sandbox"]
    rows = []
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=args)
            page = browser.new_page(viewport={"width": VIEW[0], "height": VIEW[1]})
            page.goto(url)
            page.wait_for_function("window.harness !== undefined", timeout=60_000)
            if page.evaluate("harness.ready") is not True:
                raise RuntimeError("the tileset did not load")
            for d in DISTANCES_M:
                settled = page.evaluate(f"harness.settle({d}, 60000)")
                orbit = page.evaluate(f"harness.orbit({d}, 0.8, 4000)")
                times = np.array(orbit["times"][1:])
                rows.append({"distance_m": d, "settle_ms": settled["ms"], "settled": settled["settled"],
                             "points_drawn": settled["pointsVisible"], "tiles_drawn": settled["tilesVisible"],
                             "orbit_max_points": orbit["maxVisible"], "tiles_loaded": orbit["tilesLoaded"],
                             "points_loaded": orbit["pointsLoaded"], "error_target": orbit["errorTarget"],
                             "frames": len(times), "median_ms": float(np.median(times)),
                             "p95_ms": float(np.percentile(times, 95))})
            browser.close()
    finally:
        server.shutdown()
        server.server_close()
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="10e6,100e6", help="points of each cloud, comma-separated (default 10e6,100e6)")
    ap.add_argument("--quick", action="store_true", help="one cloud of 2 million points")
    ap.add_argument("--work", default=str(ROOT / ".bench" / "pointcloud"), help="folder for the LAS files and tiles")
    ap.add_argument("--budget", type=int, default=None, help="the viewer's point budget (default: pointcloud.js's)")
    ap.add_argument("--no-browser", action="store_true")
    ap.add_argument("--keep", action="store_true", help="keep the LAS files and tiles")
    ap.add_argument("--convert", nargs=2, metavar=("SOURCE", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.convert:
        convert_child(*args.convert)
        return 0
    sizes = [2_000_000] if args.quick else [int(float(s)) for s in args.sizes.split(",")]
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in sizes:
        las = work / f"site-{n}.las"
        write_s = write_las(las, n) if not las.exists() else None
        out = work / f"tiles-{n}"
        shutil.rmtree(out, ignore_errors=True)
        proc, result, wall = run_script(__file__, ["--convert", str(las), str(out / "data")], RESULT_PREFIX)
        if result is None:
            console.print(f"[red]conversion of {n:,} points failed (exit {proc.returncode})")
            return 1
        result.pop("tileset")  # a path under --work
        rows.append({"points": n, "las_mb": las.stat().st_size / 2**20, "las_write_s": write_s, **result})
        console.print(f"{n:,} points: {result['seconds']:.1f} s, peak {result['peak_rss_mb']:.0f} MB")
    table = numeric_table(("points", "LAS MB", "convert s", "M points/s", "peak MB", "of which before", "buckets", "tiles",
                           "depth", "largest tile"), left=(), title="LAS → 3D Tiles (write_point_tiles)")
    for r in rows:
        table.add_row(f"{r['points']:,}", f"{r['las_mb']:.0f}", f"{r['seconds']:.1f}", f"{r['points'] / r['seconds'] / 1e6:.2f}",
                      f"{r['peak_rss_mb']:.0f}", f"{r['start_rss_mb']:.0f}", str(r["n_buckets"]), f"{r['n_tiles']:,}",
                      str(r["depth"]), f"{r['max_tile_points']:,}")
    console.print(table)
    frames = []
    if not args.no_browser:
        largest = max(sizes)
        frames = browser_frames(work / f"tiles-{largest}", args.budget)
        table = numeric_table(("distance m", "points drawn", "tiles drawn", "max drawn in orbit", "tiles loaded",
                               "error target px", "frames", "median ms", "p95 ms"), left=(),
                              title=f"{largest:,} points in chromium (SwiftShader, {VIEW[0]}×{VIEW[1]})")
        for f in frames:
            table.add_row(f"{f['distance_m']:,}", f"{f['points_drawn']:,}", str(f["tiles_drawn"]), f"{f['orbit_max_points']:,}",
                          str(f["tiles_loaded"]), f"{f['error_target']:.1f}", str(f["frames"]), f"{f['median_ms']:.1f}",
                          f"{f['p95_ms']:.1f}")
        console.print(table)
    (Path(__file__).with_name("pointcloud.json")).write_text(json.dumps(
        {"machine": machine(), "conversion": rows, "browser": frames}, indent=1, default=float))
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
