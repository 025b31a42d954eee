"""sightplan benchmark: one command, `make bench` (or `python benchmarks/run.py --help`).

Prints one table, engine × resolution, and writes benchmarks/results.json (the machine, the
table's rows, every measurement behind them).

Rows
- engines: embree (CPU ray casting), gl (OpenGL rasteriser: a GPU's driver, or Mesa's llvmpipe
  on the CPU), trimesh (pure-numpy baseline), and embree on a dask cluster (--cluster, local:2).
- drone: 20 MP frames (DJI Phantom 4 Pro, 5472×3648) at resolution scale 1, 0.5 and 0.25,
  --frames of them spread evenly over 2,000 frames on rings around the model (the paper's P1:
  1,924 frames, 1.78 s per frame on a GPU; `--frames 2000` casts the whole ring plan).
- 360: equirectangular frames (Insta360 ONE RS 1-inch, 6528×3264) on a walk through the model.
- baseline: trimesh on --baseline-frames frames at scale 0.02, reported per ray and
  extrapolated to each resolution (its per-frame costs are spread over the rays too).

Columns: seconds per frame (casting, after an untimed small warm-up frame for JIT and shaders),
the paper's 1.78 s over ours (> 1: faster), peak memory, frames measured, million rays
(pixels) per second. Each cell runs in its own process (`--cell ENGINE:SCALE[:KIND]`), so its
peak memory is its own: the process's peak RSS (model, engine, observations), or for the dask
row the peak summed RSS of the client and its workers. A GPU's own memory is not counted.

Also: re-evaluation after moving 10 frames (per-frame cache), the scale-0.25 error against full
resolution, and how far gl's metrics lie from embree's on the same frames.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path

import numpy as np
import psutil
from rich import box
from rich.console import Console
from rich.table import Table

from sightplan import __version__
from sightplan.camera.catalogue import get_camera
from sightplan.engines import available_engines, make_engine
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.geometry.poses import R_from_gimbal
from sightplan.metrics import MetricParams, compute_metrics
from sightplan.model.load import load_model
from sightplan.observations.features import sample_features
from sightplan.observations.table import Observations
from sightplan.plan.templates.orbit import ring_poses
from sightplan.plan.types import Mission, Plan

PAPER_S_PER_FRAME_P1 = 57.0 * 60 / 1924  # 1.78 s
ENGINES = ("embree", "gl", "trimesh")
DRONE_SCALES = (1.0, 0.5, 0.25)
DRONE_CAMERA, PANO_CAMERA = "p4p", "one-rs-1inch"
RING_FRAMES = 2000  # the ring plan the drone frames are drawn from
WALK_FRAMES = 150  # the walk the 360° frames are drawn from
MOVED_FRAMES = 10
KINDS = ("drone", "360", "dask", "reeval")
METRIC_KEYS = ("VC", "VR", "R", "O")
CELL_PREFIX = "CELL "
WARMUP_SCALE = 0.1  # the untimed first frame (JIT, shaders) is cast at this scale at most
OTHERS_WARN = 0.2  # cores busy with other processes during a cell, above which it is flagged

console = Console()


def peak_rss_mb() -> float:
    """This process's peak resident memory so far (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def rss_mb() -> float:
    """This process's resident memory now (MB)."""
    return psutil.Process().memory_info().rss / 2**20


def emit(prefix: str, result: dict) -> None:
    """Hand a child process's result to its parent: one JSON line after ``prefix`` on stdout."""
    print(prefix + json.dumps(result, default=float), flush=True)


def run_script(script: str | Path, options: list[str], prefix: str, capture_stderr: bool = False
               ) -> tuple[subprocess.CompletedProcess, dict | None, float]:
    """Run a benchmark script in a fresh interpreter (so its peak RSS is its own): the finished
    process, the result it emitted last under ``prefix`` (None if none), and its wall seconds."""
    cmd = [sys.executable, str(Path(script).resolve()), *options]
    t = time.perf_counter()
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE if capture_stderr else None, text=True)
    wall = time.perf_counter() - t
    lines = [line for line in proc.stdout.splitlines() if line.startswith(prefix)]
    return proc, (json.loads(lines[-1][len(prefix):]) if lines else None), wall


def numeric_table(columns: tuple[str, ...], left: tuple[str, ...], no_wrap: tuple[str, ...] = (), **kwargs) -> Table:
    """A rich table of these columns: the ``left`` ones (labels) left-aligned, the numbers right-aligned."""
    table = Table(**kwargs)
    for name in columns:
        table.add_column(name, justify="left" if name in left else "right", no_wrap=name in no_wrap)
    return table


class TreeMemory(threading.Thread):
    """Samples the summed RSS of this process and its descendants (dask workers) until stopped."""

    def __init__(self, interval_s: float = 0.05) -> None:
        super().__init__(daemon=True)
        self.interval_s = interval_s
        self.peak_bytes = 0
        self._stop_event = threading.Event()
        self._me = psutil.Process()

    def sample(self) -> None:
        total = 0
        for proc in [self._me, *self._me.children(recursive=True)]:
            try:
                total += proc.memory_info().rss
            except psutil.Error:
                pass
        self.peak_bytes = max(self.peak_bytes, total)

    def run(self) -> None:
        while not self._stop_event.wait(self.interval_s):
            self.sample()

    def stop(self) -> float:
        self._stop_event.set()
        self.join()
        self.sample()
        return self.peak_bytes / 2**20


# --- plans ---------------------------------------------------------------------------------------

def drone_plan(scene, camera, n_frames: int) -> Plan:
    """Rings at three heights and two distances, looking at the model's centre."""
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    half = float(np.hypot(*(hi - lo)[:2]) / 2)
    rings = [(half + d, hi[2] + h) for d in (8.0, 20.0) for h in (2.0, 10.0, 25.0)]
    per_ring = int(np.ceil(n_frames / len(rings)))
    C, heading, pitch = zip(*(ring_poses(centre, radius, z, per_ring) for radius, z in rings))
    C = np.concatenate(C)[:n_frames]
    R = R_from_gimbal(np.concatenate(heading)[:n_frames], np.concatenate(pitch)[:n_frames])
    return Plan.build(camera, R, C, missions=(Mission("rings", 0, len(C)),))


def walk_plan(scene, camera, n_frames: int) -> Plan:
    """A walk along the model's long axis at 1.6 m above each storey-ish level."""
    lo, hi = scene.bounds()
    t = np.linspace(0.05, 0.95, n_frames)
    axis = int(np.argmax((hi - lo)[:2]))
    C = np.tile((lo + hi) / 2, (n_frames, 1))
    C[:, axis] = lo[axis] + t * (hi - lo)[axis]
    levels = np.linspace(lo[2] + 1.6, max(lo[2] + 1.6, hi[2] - 1.5), 3)
    C[:, 2] = levels[np.arange(n_frames) % len(levels)]
    R = R_from_gimbal(np.zeros(n_frames), np.zeros(n_frames))
    return Plan.build(camera, R, C)


def spread(n_total: int, n: int) -> np.ndarray:
    """``n`` indices spread evenly over ``range(n_total)`` (all of them when n ≥ n_total)."""
    n = max(1, min(n, n_total))
    return ((np.arange(n) + 0.5) * n_total / n).astype(int)


def cell_plan(scene, kind: str, n: int) -> Plan:
    """The frames a cell casts: the same ones for every engine and resolution of a kind."""
    if kind == "360":
        plan = walk_plan(scene, get_camera(PANO_CAMERA), max(WALK_FRAMES, n))
    else:
        plan = drone_plan(scene, get_camera(DRONE_CAMERA), max(RING_FRAMES, n))
    return plan.subset(spread(len(plan), n))


def frame_size(kind: str, scale: float) -> tuple[int, int]:
    cam = get_camera(PANO_CAMERA if kind == "360" else DRONE_CAMERA)
    cam = cam.scaled(scale) if scale != 1 else cam
    return cam.width, cam.height


def plan_pixels(plan: Plan, scale: float) -> int:
    total = 0
    for i in range(len(plan)):
        cam = plan.camera_of(i)
        cam = cam.scaled(scale) if scale != 1 else cam
        total += cam.width * cam.height
    return total


# --- one cell, in its own process ----------------------------------------------------------------

def parse_spec(spec: str) -> tuple[str, float, str]:
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise ValueError(f"--cell wants ENGINE:SCALE[:KIND], got {spec!r}")
    engine, scale, kind = parts[0], float(parts[1]), parts[2] if len(parts) == 3 else "drone"
    if engine not in ENGINES or kind not in KINDS or not 0 < scale <= 1:
        raise ValueError(f"--cell {spec!r}: engine one of {ENGINES}, scale in (0, 1], kind one of {KINDS}")
    return engine, scale, kind


def cast(engine, plan: Plan, scale: float, warmup: bool) -> tuple[list, float, float]:
    """(frames, cast seconds, warm-up seconds): every frame of ``plan``, after an untimed small one."""
    def one(i, s=scale):
        return engine.observe(plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i], s)

    t = time.perf_counter()
    if warmup:
        one(0, min(scale, WARMUP_SCALE))
    warmup_s = time.perf_counter() - t
    t = time.perf_counter()
    frames = [one(i) for i in range(len(plan))]
    return frames, time.perf_counter() - t, warmup_s


def plan_metrics(scene, frames, n_features: int, meta: dict) -> dict:
    obs = Observations.from_frames(frames, scene.targets, scene.present, n_features, meta)
    return compute_metrics(obs, MetricParams()).plan.to_dict()


def run_cell(spec: str, args) -> dict:
    engine_name, scale, kind = parse_spec(spec)
    t = time.perf_counter()
    scene, _ = load_model(args.model, cache=args.scene_cache is not None, cache_dir=args.scene_cache)
    load_s = time.perf_counter() - t
    defaults = EvaluationSettings()
    features = sample_features(scene, defaults.feature_density, defaults.feature_seed)
    if engine_name == "trimesh":
        n = args.baseline_frames
    else:
        n = args.frames_360 if kind == "360" else args.frames
    plan = cell_plan(scene, "360" if kind == "360" else "drone", n)
    res = {"spec": spec, "engine": engine_name, "kind": kind, "scale": scale, "frames": len(plan),
           "rays": plan_pixels(plan, scale), "load_s": load_s, "rss_loaded_mb": rss_mb()}
    if kind == "dask":
        res.update(dask_cell(scene, features, plan, scale, args.cluster))
    elif kind == "reeval":
        res.update(reeval_cell(scene, features, plan, EvaluationSettings(engine=engine_name, scale=scale)))
    else:
        t = time.perf_counter()
        engine = make_engine(engine_name, scene, features, d_max=defaults.d_max)
        res["engine_build_s"] = time.perf_counter() - t
        with engine:
            frames, cast_s, warmup_s = cast(engine, plan, scale, warmup=engine_name != "trimesh")
        res.update(cast_s=cast_s, warmup_s=warmup_s, peak_rss_mb=peak_rss_mb(), threads=engine.threads)
        meta = {"engine": engine_name, "scale": scale, "d_max": defaults.d_max, "scene": scene.key,
                "features": features.key, "feature_params": features.params}
        res["metrics"] = plan_metrics(scene, frames, len(features), meta)
        if engine_name == "gl":
            res["renderer"] = engine.renderer  # the driver this engine drew with (no second context)
        if engine_name == "trimesh":  # embree on the very same frames, after the peak is taken
            with make_engine("embree", scene, features, d_max=defaults.d_max) as emb:
                res["embree_same_frames_cast_s"] = cast(emb, plan, scale, warmup=True)[1]
    if "cast_s" in res:
        res["s_per_frame"] = res["cast_s"] / res["frames"]
        res["rays_per_s"] = res["rays"] / res["cast_s"] if res["cast_s"] else None
    return res


def dask_cell(scene, features, plan: Plan, scale: float, cluster: str) -> dict:
    """Embree on a dask cluster: warm the workers (engines, JIT) on a few frames, then time the plan."""
    from sightplan.distributed import connect, evaluate_distributed

    memory = TreeMemory()
    with ExitStack() as stack:
        t = time.perf_counter()
        client = connect(cluster, stack)
        start_s = time.perf_counter() - t
        workers = len(client.nthreads())
        local = cluster == "local" or cluster.startswith("local:")
        # a local cluster shares this machine's cores: split them between the workers
        threads = max(1, (os.cpu_count() or 1) // workers) if local else None
        settings = EvaluationSettings(engine="embree", scale=scale, threads=threads)
        memory.start()
        t = time.perf_counter()
        warm = plan.subset(np.arange(min(len(plan), 2 * workers)))
        evaluate_distributed(scene, warm, replace(settings, scale=min(scale, WARMUP_SCALE)), cluster=client,
                             batch_frames=1, features=features)
        warmup_s = time.perf_counter() - t
        batch = max(1, math.ceil(len(plan) / (4 * workers)))
        ev = evaluate_distributed(scene, plan, settings, cluster=client, batch_frames=batch, features=features)
        peak = memory.stop()
    return {"cast_s": ev.timings["cast_s"], "worker_cast_s": ev.timings["worker_cast_s"], "warmup_s": warmup_s,
            "cluster": cluster, "cluster_start_s": start_s, "workers": workers, "threads_per_worker": threads,
            "batch_frames": batch, "peak_rss_mb": peak, "peak_rss_client_mb": peak_rss_mb(),
            "metrics": ev.metrics.plan.to_dict()}


def reeval_cell(scene, features, plan: Plan, settings: EvaluationSettings) -> dict:
    """Evaluate the plan with a per-frame cache, move some frames up 1 m, evaluate again."""
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        evaluate(scene, plan, settings, cache_dir=tmp, features=features)
        first_s = time.perf_counter() - t
        C = plan.C_world.copy()
        moved = spread(len(plan), min(MOVED_FRAMES, len(plan)))
        C[moved, 2] += 1.0
        t = time.perf_counter()
        ev = evaluate(scene, replace(plan, C_world=C), settings, cache_dir=tmp, features=features)
        again_s = time.perf_counter() - t
    return {"first_s": first_s, "reevaluate_s": again_s, "moved": len(moved), "cache_hits": ev.cache_hits,
            "recast": ev.timings["frames_cast"], "peak_rss_mb": peak_rss_mb()}


# --- the table -----------------------------------------------------------------------------------

def machine() -> dict:
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "")
    except OSError:
        pass
    info = {"cpu_model": cpu or platform.processor() or platform.machine(), "cpu_cores": os.cpu_count(),
            "memory_gb": round(psutil.virtual_memory().total / 2**30, 1), "platform": platform.platform(),
            "python": platform.python_version(), "sightplan": __version__,
            "engines_available": available_engines(), "load_avg_1m_at_start": os.getloadavg()[0]}
    try:
        from sightplan.engines import gl

        probe = gl.probe()
        info.update(gl_renderer=probe["renderer"] or None, gl_hardware=probe["hardware"], gl_error=probe["error"] or None)
    except Exception as exc:  # no moderngl: the gl engine is simply absent
        info.update(gl_renderer=None, gl_hardware=False, gl_error=f"{type(exc).__name__}: {exc}")
    return info


def busy_cpu_s() -> float:
    """CPU seconds the whole machine has spent busy (or stolen by the hypervisor) since boot."""
    t = psutil.cpu_times()
    return sum(getattr(t, k, 0.0) for k in ("user", "nice", "system", "irq", "softirq", "steal"))


def own_cpu_s() -> float:
    """CPU seconds of this process and its waited-for descendants (the cells)."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def run_child(spec: str, args, scene_cache: str) -> dict:
    options = ["--cell", spec, "--model", args.model, "--frames", str(args.frames), "--frames-360", str(args.frames_360),
               "--baseline-frames", str(args.baseline_frames), "--cluster", args.cluster, "--scene-cache", scene_cache]
    busy, own = busy_cpu_s(), own_cpu_s()
    proc, res, wall = run_script(__file__, options, CELL_PREFIX, capture_stderr=True)
    # cores kept busy by other processes meanwhile: > 0.2 or so and the cell's timings are inflated
    others = max(0.0, (busy_cpu_s() - busy) - (own_cpu_s() - own)) / wall
    if proc.returncode != 0 or res is None:
        tail = "\n".join((proc.stderr or proc.stdout).strip().splitlines()[-8:])
        console.print(f"[red]cell {spec} failed (exit {proc.returncode}):[/red]\n{tail}", markup=True, highlight=False)
        return {"spec": spec, "error": tail or f"exit {proc.returncode}", "process_s": wall, "other_cpu_cores": others}
    res.update(process_s=wall, other_cpu_cores=others)
    return res


def row_for(label: str, engine: str, kind: str, scale: float, cell: dict, extrapolate: bool = False) -> dict:
    width, height = frame_size("360" if kind == "360" else "drone", scale)
    row = {"label": label, "engine": engine, "camera": "360" if kind == "360" else "drone", "scale": scale, "width": width,
           "height": height, "megapixels": width * height / 1e6, "spec": cell["spec"]}
    if "error" in cell:
        return {**row, "error": cell["error"]}
    rays_per_s = cell["rays_per_s"]
    s_per_frame = width * height / rays_per_s if extrapolate else cell["s_per_frame"]
    return {**row, "s_per_frame": s_per_frame, "ratio_to_paper": PAPER_S_PER_FRAME_P1 / s_per_frame,
            "peak_rss_mb": cell["peak_rss_mb"], "frames": cell["frames"], "mrays_per_s": rays_per_s / 1e6,
            "extrapolated": extrapolate, "measured_scale": cell["scale"], "other_cpu_cores": cell["other_cpu_cores"]}


def fmt_seconds(s: float) -> str:
    return f"{s:.3g}" if s < 100 else f"{s:,.0f}" if s < 1e5 else f"{s:.1e}"


def fmt_small(x: float) -> str:
    return f"{x:.3g}" if x >= 0.01 else f"{x:.1e}"


def print_table(rows: list[dict], info: dict, args) -> None:
    drone, pano = frame_size("drone", 1.0), frame_size("360", 1.0)
    columns = ("engine", "frame", "scale", "s/frame", "× paper", "peak MB", "frames", "Mrays/s")
    table = numeric_table(columns, left=("engine", "frame"), no_wrap=columns[1:],
                          title=f"sightplan on {args.model}: {info['cpu_model']}, {info['cpu_cores']} cores",
                          box=box.SIMPLE_HEAD, collapse_padding=True, caption_justify="left",
                          caption=(f"20 MP: {drone[0]}×{drone[1]} at the scale given; 360°: {pano[0]}×{pano[1]}. "
                                   f"× paper: the paper's {PAPER_S_PER_FRAME_P1:.2f} s per 20 MP frame (GPU) over ours, "
                                   f"> 1 is faster. gl: {info.get('gl_renderer') or 'unavailable'}. "
                                   f"† per ray on {args.baseline_frames} frame(s) at scale {args.baseline_scale:g}, "
                                   "extrapolated; peak memory at that scale. "
                                   "Dask: peak summed memory of client and workers."))
    last = None
    for r in rows:
        if last is not None and r["label"] != last:
            table.add_section()
        last = r["label"]
        label = r["label"].replace(" on dask ", " on\ndask ") + ("†" if r.get("extrapolated") else "")
        head = [label, "20 MP" if r["camera"] == "drone" else "360°", f"{r['scale']:g}"]
        if "error" in r:
            table.add_row(*head, "[red]failed[/red]", "", "", "", "")
            continue
        frames = f"{r['frames']}" + (f" @{r['measured_scale']:g}" if r["extrapolated"] else "")
        table.add_row(*head, fmt_seconds(r["s_per_frame"]), fmt_small(r["ratio_to_paper"]),
                      f"{r['peak_rss_mb']:,.0f}", frames, fmt_small(r["mrays_per_s"]))
    console.print(table)


def pct_diff(a: dict, b: dict) -> dict:
    """|a − b| / |b| in percent, per metric (None where b is 0)."""
    return {k: (abs(a[k] - b[k]) / abs(b[k]) * 100 if b.get(k) else None) for k in METRIC_KEYS}


def fmt_pct(d: dict) -> str:
    return ", ".join(f"{k} {v:.2f} %" for k, v in d.items() if v is not None)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default="sample", help="IFC or mesh (default: the bundled Duplex)")
    ap.add_argument("--frames", type=int, default=40,
                    help="drone frames per cell, spread over a 2,000-frame ring plan (default 40; the paper's P1: 1,924)")
    ap.add_argument("--frames-360", type=int, default=4, help="360° frames per cell (default 4)")
    ap.add_argument("--baseline-frames", type=int, default=2, help="frames for the trimesh baseline (default 2)")
    ap.add_argument("--baseline-scale", type=float, default=0.02, help="resolution scale of the trimesh baseline (default 0.02)")
    ap.add_argument("--engines", default=None,
                    help=f"comma-separated, from {','.join(ENGINES)} (default: every available one)")
    ap.add_argument("--cluster", default="local:2",
                    help="dask cluster for the embree-on-dask row: local:N or tcp://host:port; 'none' to skip")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results.json")))
    ap.add_argument("--cell", help=argparse.SUPPRESS)
    ap.add_argument("--scene-cache", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    for name in ("frames", "frames_360", "baseline_frames"):
        if getattr(args, name) < 1:
            ap.error(f"--{name.replace('_', '-')} must be ≥ 1")
    if not 0 < args.baseline_scale <= 1:
        ap.error("--baseline-scale must be in (0, 1]")

    if args.cell:
        try:
            parse_spec(args.cell)
        except ValueError as exc:
            ap.error(str(exc))
        res = run_cell(args.cell, args)
        emit(CELL_PREFIX, res)
        return 0

    available = available_engines()
    if args.engines:
        engines = [e.strip() for e in args.engines.split(",") if e.strip()]
        for e in engines:
            if e not in ENGINES:
                ap.error(f"unknown engine {e!r}: choose from {', '.join(ENGINES)}")
            if e not in available:
                ap.error(f"engine {e!r} is not available here (available: {', '.join(available)})")
    else:
        engines = [e for e in ENGINES if e in available]
    with_dask = "embree" in engines and args.cluster.lower() not in ("", "none")
    info = machine()
    console.print(f"machine: {info['cpu_model']}, {info['cpu_cores']} cores, {info['memory_gb']} GB; "
                  f"OpenGL: {info['gl_renderer'] or 'none'}", highlight=False)

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as scene_cache:
        t = time.perf_counter()
        scene, _ = load_model(args.model, cache=True, cache_dir=scene_cache)  # cells read it back from here
        load_s = time.perf_counter() - t
        console.print(f"model {args.model}: {int(scene.targets.sum())} elements, {len(scene.faces):,} triangles, "
                      f"loaded in {load_s:.1f} s", highlight=False)
        specs = []
        for e in engines:
            if e == "trimesh":
                specs += [f"trimesh:{args.baseline_scale:g}:drone", f"trimesh:{args.baseline_scale:g}:360"]
            else:
                specs += [f"{e}:{s:g}:drone" for s in DRONE_SCALES] + [f"{e}:1:360"]
        if with_dask:
            specs.append("embree:1:dask")
        reeval_engine = next((e for e in engines if e != "trimesh"), None)
        if reeval_engine:
            specs.append(f"{reeval_engine}:1:reeval")
        specs.sort(key=lambda s: s.startswith("trimesh"))  # the slow baseline last
        cells = {}
        for spec in specs:
            console.print(f"  {spec:<22} …", end="", highlight=False)
            cell = cells[spec] = run_child(spec, args, scene_cache)
            if "error" in cell:
                continue
            what = (f"{cell['s_per_frame']:.3g} s/frame over {cell['frames']} frames" if "s_per_frame" in cell
                    else f"re-evaluation {cell['reevaluate_s']:.1f} s")
            console.print(f" {what} ({cell['process_s']:.0f} s in all; other processes: "
                          f"{cell['other_cpu_cores']:.2f} cores)", highlight=False)

    rows = []
    for e in engines:
        if e == "trimesh":
            drone, pano = cells[f"trimesh:{args.baseline_scale:g}:drone"], cells[f"trimesh:{args.baseline_scale:g}:360"]
            rows += [row_for(e, e, "drone", s, drone, extrapolate=True) for s in DRONE_SCALES]
            rows.append(row_for(e, e, "360", 1.0, pano, extrapolate=True))
        else:
            rows += [row_for(e, e, "drone", s, cells[f"{e}:{s:g}:drone"]) for s in DRONE_SCALES]
            rows.append(row_for(e, e, "360", 1.0, cells[f"{e}:1:360"]))
    if with_dask:
        rows.append(row_for(f"embree on dask {args.cluster}", "embree", "drone", 1.0, cells["embree:1:dask"]))
        rows[-1]["cluster"] = args.cluster
    console.print()
    print_table(rows, info, args)

    results = {"model": args.model, "triangles": int(len(scene.faces)), "elements": int(scene.targets.sum()),
               "load_s": load_s, "machine": info,
               "settings": {"engines": engines, "frames": args.frames, "frames_360": args.frames_360,
                            "baseline_frames": args.baseline_frames, "baseline_scale": args.baseline_scale,
                            "cluster": args.cluster if with_dask else None, "ring_plan_frames": RING_FRAMES,
                            "walk_plan_frames": WALK_FRAMES},
               "paper_s_per_frame": PAPER_S_PER_FRAME_P1, "table": rows}
    ok = {spec: c for spec, c in cells.items() if "error" not in c}
    # what the old cases reported, from the cells
    ratios = {"paper_s_per_frame": PAPER_S_PER_FRAME_P1}
    base = ok.get(f"trimesh:{args.baseline_scale:g}:drone")
    base_frame_s = None
    if base:
        w, h = frame_size("drone", 1.0)
        base_frame_s = w * h / base["rays_per_s"]
        ratios["baseline_s_per_20mp_frame"] = base_frame_s
        ratios["speedup_vs_baseline_same_frames"] = base["cast_s"] / base["embree_same_frames_cast_s"]
    lines = []
    for e in engines:
        full = ok.get(f"{e}:1:drone")
        if e == "trimesh" or not full:
            continue
        ratios[f"{e}_speedup_vs_paper"] = PAPER_S_PER_FRAME_P1 / full["s_per_frame"]
        text = (f"{e} 20 MP frame: {full['s_per_frame']:.3f} s, {ratios[f'{e}_speedup_vs_paper']:.2f}× the paper's speed "
                f"({PAPER_S_PER_FRAME_P1:.2f} s on a GPU)")
        if base_frame_s:
            ratios[f"{e}_speedup_vs_baseline"] = base_frame_s / full["s_per_frame"]
            text += f", {ratios[f'{e}_speedup_vs_baseline']:,.0f}× the trimesh baseline ({base_frame_s:,.0f} s extrapolated)"
        lines.append(text + ".")
    if base:
        lines.append(f"trimesh against embree on the same {base['frames']} frames at scale {args.baseline_scale:g}: "
                     f"{ratios['speedup_vs_baseline_same_frames']:,.0f}× slower.")
    results["ratios"] = ratios
    full, quarter = ok.get("embree:1:drone"), ok.get("embree:0.25:drone")
    if full and quarter:
        results["scale_0.25_error_pct"] = pct_diff(quarter["metrics"], full["metrics"])
        lines.append(f"scale 0.25 against full resolution (embree, same {full['frames']} frames): "
                     + fmt_pct(results["scale_0.25_error_pct"]) + ".")
    gl_full = ok.get("gl:1:drone")
    if full and gl_full:
        results["gl_vs_embree_pct"] = {"drone_20mp": pct_diff(gl_full["metrics"], full["metrics"])}
        lines.append("gl against embree, 20 MP drone frames: " + fmt_pct(results["gl_vs_embree_pct"]["drone_20mp"]) + ".")
        if ok.get("gl:1:360") and ok.get("embree:1:360"):
            results["gl_vs_embree_pct"]["360"] = pct_diff(ok["gl:1:360"]["metrics"], ok["embree:1:360"]["metrics"])
            lines.append("gl against embree, 360° frames: " + fmt_pct(results["gl_vs_embree_pct"]["360"]) + ".")
    reeval = ok.get(f"{reeval_engine}:1:reeval") if reeval_engine else None
    if reeval:
        results["reevaluate"] = {k: reeval[k] for k in ("engine", "frames", "moved", "first_s", "reevaluate_s",
                                                        "cache_hits", "recast")}
        lines.append(f"re-evaluation ({reeval_engine}, 20 MP) after moving {reeval['moved']} of {reeval['frames']} frames: "
                     f"{reeval['reevaluate_s']:.1f} s ({reeval['cache_hits']} frames from the cache), "
                     f"against {reeval['first_s']:.1f} s the first time.")
    busy = sorted(spec for spec, c in cells.items() if c["other_cpu_cores"] > OTHERS_WARN)
    if busy:
        lines.append(f"[yellow]note: other processes kept more than {OTHERS_WARN:g} of the {info['cpu_cores']} cores busy "
                     f"during {', '.join(busy)}: those timings are slower than on an idle machine.[/yellow]")
    for line in lines:
        console.print(line, highlight=False)
    results["cells"] = list(cells.values())
    results["total_s"] = time.perf_counter() - t0
    Path(args.out).write_text(json.dumps(results, indent=2, default=float, ensure_ascii=False) + "\n")
    console.print(f"{len(rows)} rows in {results['total_s']:.0f} s; wrote {args.out}", highlight=False)
    return 0 if all("error" not in c for c in cells.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
