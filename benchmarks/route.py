"""Routing benchmark: how long the optimiser's route takes to order 60, 80 and 100 candidate views of a model.

    python benchmarks/route.py [--model sample]

The views are a fixed random draw (seed 0) of the model's candidates at 10 m for the P4P; the take-off is 20 m
south-west of their box. Prints the seconds for the three routes and how many missions had to end at a leg no
order could keep safe.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sightplan.camera.catalogue import get_camera
from sightplan.model.load import load_model
from sightplan.optimize import candidate_views, order_views


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default="sample")
    args = ap.parse_args(argv)
    scene = load_model(args.model)[0]
    cands = candidate_views(scene, get_camera("p4p"), 10.0)
    C = cands.plan.C_world[np.random.default_rng(0).choice(len(cands.plan), min(100, len(cands.plan)), replace=False)]
    takeoff = C.min(axis=0) - [20.0, 20.0, 0.0]
    t = time.perf_counter()
    cuts = 0
    for n in (60, 80, 100):
        cuts += len(order_views(scene, C[:n], takeoff, 10.0, runs=2)[1])
    print(f"{args.model}: {len(scene.faces):,} triangles; 3 routes of 60/80/100 views in {time.perf_counter() - t:.1f} s; "
          f"{cuts} missions ended at an unsafe leg")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
