"""The feature test on real sizes: `python benchmarks/features.py` (`--model M`, `--frames N`, `--no-reference`).

M: any model of `benchmarks/speed.py` (default the restaurant; `duplex`, `campus-1M` built in memory, ...).

On the drone rings of `benchmarks/speed.py` (Phantom 4 Pro at scale 0.25), per frame: the blocks of features the view
frustum keeps, the features that pass the geometric tests (each would cast a ray without a proof of occlusion), those
that still cast their own after one ray per block and the first big triangle behind it (the test on its own), and
after the triangles the frame's pixels hit too (the test inside `Engine.observe`), those seen, and the CPU seconds of
the test as `observe` runs it. With the reference (the default), every frame's set is compared with
`visible_features_reference` (one ray per feature) and the mismatches counted. With `--explain`, the hidden features
that still cast a ray are sorted by which triangle would have proven them (:func:`hidden_reasons`). Writes
benchmarks/features.json.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from run import cell_plan
from sightplan.engines import featurecull
from sightplan.engines.embree import EmbreeEngine
from sightplan.observations.features import cached_features
from speed import frame_rays, load

HERE = Path(__file__).resolve().parent


def frame_pixels(engine: EmbreeEngine, camera, R, C) -> tuple[np.ndarray, float, float]:
    """The triangle each pixel of the frame at scale 0.25 hits, as `Engine.observe` hands them to the feature test."""
    cam = camera.scaled(0.25)
    dirs, origin = frame_rays(engine, cam, R, C)
    prims = engine.first_hit(np.broadcast_to(origin, dirs.shape), dirs).reshape(cam.height, cam.width)
    return prims, cam.width / camera.width, cam.height / camera.height


def frame_counts(engine: EmbreeEngine, cam, R, C, pixels) -> dict:
    """The blocks kept, the features passing the geometric tests and those casting a ray, without and with the
    pixels' triangles."""
    index = engine.feature_index
    args = (C, R, cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, engine.d_max)
    planes = np.array([[cam.fx, 0.0, cam.cx], [-cam.fx, 0.0, cam.width - cam.cx], [0.0, cam.fy, cam.cy],
                       [0.0, -cam.fy, cam.height - cam.cy]]) @ R.T
    keep = featurecull._cull_blocks(index.block_lo, index.block_hi, C, planes, engine.d_max)
    return {"blocks_kept": int(keep.sum()), "candidates": len(index.candidates(*args)[0]),
            "rays_alone": len(index.candidates(*args, cover=engine.occluders)[0]),
            "rays": len(index.candidates(*args, cover=engine.occluders, pixels=pixels)[0])}


def hidden_reasons(engine: EmbreeEngine, cam, R, C, pixels) -> dict:
    """Of the features that cast a ray (with the pixels' triangles): those seen, those hidden, and which triangle, had
    the test tried it, would have proven a hidden one occluded (`featurecull._covers`, the test's own proof):

    - own_hit: the first triangle its own ray hits (an oracle: what a perfect choice of triangle would spare);
    - own_pixel_is_hit: its pixel's triangle, already tried, is that very triangle;
    - neighbours: the triangle of one of the three other pixels nearest its image point;
    - big_own: the first big triangle (`big_triangles`) along its own sight line.

    own_hit_seen counts the seen features their own first triangle would "prove" hidden: none, or the proof is unsound.
    """
    index, cover = engine.feature_index, engine.occluders
    prims, sx, sy = pixels
    h, w = prims.shape
    cand, dirs, dist = index.candidates(C, R, cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, engine.d_max,
                                        cover=cover, pixels=pixels)
    origin = (np.asarray(C, np.float64) - engine.centre).astype(np.float32)
    seen = engine._seen_from(origin, dirs, dist)
    rel = engine.features.points[cand] - C
    own = cover.first_hit(np.broadcast_to(origin, dirs.shape), dirs)
    big = cover.big_hit(np.broadcast_to(origin, dirs.shape), dirs) if cover.big_hit else np.full(len(cand), -1)
    cam_xyz = rel @ R
    x = (cam.fx * cam_xyz[:, 0] / cam_xyz[:, 2] + cam.cx) * sx
    y = (cam.fy * cam_xyz[:, 1] / cam_xyz[:, 2] + cam.cy) * sy
    tags = np.full(featurecull.SETUP_CACHE, -1, np.int64)
    table = np.empty((featurecull.SETUP_CACHE + 1, 17))
    featurecull._no_cover(table[featurecull.SETUP_CACHE])

    def proves(f: int, j: int) -> bool:
        row = featurecull._cover_row(cover.vertices, cover.faces, int(f), C, cover.centre, tags, table)
        return bool(featurecull._covers(table[row], *rel[j], featurecull._inside_at(dist[j])))

    counts = dict.fromkeys(("own_hit", "own_hit_seen", "own_pixel_is_hit", "neighbours", "big_own"), 0)
    for j in range(len(cand)):
        if seen[j]:
            counts["own_hit_seen"] += proves(own[j], j)
            continue
        xi, yi = min(int(x[j]), w - 1), min(int(y[j]), h - 1)
        counts["own_hit"] += proves(own[j], j)
        counts["own_pixel_is_hit"] += int(prims[yi, xi] == own[j])
        step_x, step_y = (1 if x[j] - xi >= 0.5 else -1), (1 if y[j] - yi >= 0.5 else -1)
        near = {prims[min(max(yi + a, 0), h - 1), min(max(xi + b, 0), w - 1)]
                for a, b in ((0, step_x), (step_y, 0), (step_y, step_x))} - {prims[yi, xi]}
        counts["neighbours"] += any(proves(f, j) for f in near)
        counts["big_own"] += proves(big[j], j)
    return {"rays": len(cand), "seen": int(seen.sum()), "hidden": int((~seen).sum()), **counts}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", default="restaurant", help="a model of benchmarks/speed.py (default restaurant)")
    p.add_argument("--frames", type=int, default=16)
    p.add_argument("--no-reference", action="store_true", help="do not compare with one ray per feature")
    p.add_argument("--explain", action="store_true", help="sort the hidden features that cast a ray by what would prove"
                   " them (hidden_reasons; slow: one Python call per feature)")
    p.add_argument("--out", default=str(HERE / "features.json"))
    args = p.parse_args()
    scene = load(args.model, None)  # the campus models are built in memory
    features = cached_features(scene, 1.0, 0)
    engine = EmbreeEngine(scene, features)
    plan = cell_plan(scene, "drone", args.frames)
    rows = []
    for i in range(len(plan)):
        cam, R, C = plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i]
        pixels = frame_pixels(engine, cam, R, C)
        engine.visible_features(cam, R, C, pixels=pixels)  # the first frame compiles
        t = time.process_time()
        seen = engine.visible_features(cam, R, C, pixels=pixels)
        row = {"frame": i, "cpu_s": time.process_time() - t, "seen": len(seen),
               **frame_counts(engine, cam, R, C, pixels)}
        if args.explain:
            row["hidden_reasons"] = hidden_reasons(engine, cam, R, C, pixels)
        if not args.no_reference:
            row["mismatches"] = len(np.setxor1d(seen, engine.visible_features_reference(cam, R, C)))
        rows.append(row)
        print(row, flush=True)
    mean = {k: float(np.mean([r[k] for r in rows])) for k in rows[0] if k not in ("frame", "hidden_reasons")}
    if args.explain:
        mean.update({f"hidden_{k}": float(np.mean([r["hidden_reasons"][k] for r in rows]))
                     for k in rows[0]["hidden_reasons"]})
    result = {"model": args.model, "triangles": int(len(scene.faces)), "features": len(features), "scale": 0.25,
              "frames": rows, "mean": mean}
    Path(args.out).write_text(json.dumps(result, indent=1))
    print("per frame:", {k: round(v, 4) for k, v in mean.items()})
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
