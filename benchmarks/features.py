"""The feature test on real sizes: `python benchmarks/features.py` (`--model M`, `--frames N`, `--no-reference`).

M: any model of `benchmarks/speed.py` (default the restaurant; `duplex`, `campus-1M` built in memory, ...).

On the drone rings of `benchmarks/speed.py` (Phantom 4 Pro at scale 0.25), per frame: the blocks of features the view
frustum keeps, the features that pass the geometric tests (each would cast a ray without a proof of occlusion), those
that still cast their own after one ray per block and the first big triangle behind it (the test on its own), and
after the triangles the frame's pixels hit too (the test inside `Engine.observe`), those seen, and the CPU seconds of
the test as `observe` runs it. With the reference (the default), every frame's set is compared with
`visible_features_reference` (one ray per feature) and the mismatches counted. Writes benchmarks/features.json.
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


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", default="restaurant", help="a model of benchmarks/speed.py (default restaurant)")
    p.add_argument("--frames", type=int, default=16)
    p.add_argument("--no-reference", action="store_true", help="do not compare with one ray per feature")
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
        if not args.no_reference:
            row["mismatches"] = len(np.setxor1d(seen, engine.visible_features_reference(cam, R, C)))
        rows.append(row)
        print(row, flush=True)
    mean = {k: float(np.mean([r[k] for r in rows])) for k in rows[0] if k != "frame"}
    result = {"model": args.model, "triangles": int(len(scene.faces)), "features": len(features), "scale": 0.25,
              "frames": rows, "mean": mean}
    Path(args.out).write_text(json.dumps(result, indent=1))
    print("per frame:", {k: round(v, 4) for k, v in mean.items()})
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
