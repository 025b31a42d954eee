"""Large-model benchmark: `python benchmarks/large.py` (or `--quick`, `--help`).

Models
- campus: a synthetic 5,000,000-triangle model built in numpy — 50,000 columns of 100
  triangles each (26-sided prisms), 5 × 5 per building and 5 storeys high, in a 20 × 20
  grid of buildings over 300 m.
- ifc: a generated IFC4 file of the size of a large real project (about 430,000 IFC
  entities, 27 MB): a 30 × 30-bay steel frame of 6 storeys — columns, I-section beams and
  slabs as extruded area solids, ground-floor walls, faceted-brep cross bracing, with a
  property set and base quantities per element — loaded by sightplan's own IFC loader (IfcOpenShell tessellation).
For each model and engine (embree, gl): a plan of 16 20 MP frames (DJI Phantom 4 Pro) on rings
around the model at resolution scale 0.25, cast in consecutive batches with one engine;
the observations of the batches are merged and the metrics computed once. Every step runs
in its own process, so each peak RSS (ru_maxrss) is that step's alone. Each engine runs
with two batch sizes, and the peak is also taken after the first batch: the peak is the
model's (scene, features, engine) plus one frame's buffers, whatever the batch size; what
grows with the number of frames is the merged observation table ("obs MB": one row per
element and per feature seen in each frame).
Prints a table and writes benchmarks/large.json.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# benchmarks/run.py, beside this script: the same rings, memory probes, child processes and tables
from run import console, drone_plan, emit, numeric_table, peak_rss_mb, rss_mb, run_script
from sightplan.camera.catalogue import get_camera
from sightplan.engines import make_engine
from sightplan.evaluate import EvaluationSettings
from sightplan.metrics import compute_metrics
from sightplan.model.load import load_model
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.features import FeatureSet, sample_features
from sightplan.observations.table import Observations

RESULT_PREFIX = "RESULT "
# the columns of the observation table that grow with the number of frames
OBSERVATION_COLUMNS = ("frame", "element", "count", "depth_mean", "angle_mean", "pixel_scale", "sampling_focal_px",
                       "feature_frame", "feature_id")
ENGINES = ("embree", "gl")

# campus: columns of one 26-sided prism each (52 side + 2 × 24 cap triangles = 100)
PRISM_SIDES = 26
COLUMNS_PER_SIDE = 5  # per building, in x and in y
CAMPUS_STOREYS = 5
STOREY_M = 3.5
COLUMN_PITCH_M = 2.5
BUILDING_PITCH_M = 15.0

# ifc: bays × bays steel frame
BAY_M = 6.0
IFC_STOREY_M = 3.6
SLAB_M = 0.25


# ---------------------------------------------------------------- models
def prism(sides: int = PRISM_SIDES) -> tuple[np.ndarray, np.ndarray]:
    """A unit prism (radius 1, height 1): (2·sides, 3) vertices and (4·sides − 4, 3) outward-wound faces."""
    a = np.arange(sides) * 2 * np.pi / sides
    ring = np.stack([np.cos(a), np.sin(a)], axis=1)
    vertices = np.concatenate([np.c_[ring, np.zeros(sides)], np.c_[ring, np.ones(sides)]])
    i = np.arange(sides)
    j = (i + 1) % sides
    k = np.arange(1, sides - 1)
    faces = np.concatenate([
        np.stack([i, j, j + sides], axis=1), np.stack([i, j + sides, i + sides], axis=1),  # sides
        np.stack([np.zeros_like(k), k + 1, k], axis=1),  # bottom cap, facing down
        np.stack([np.full_like(k, sides), k + sides, k + 1 + sides], axis=1),  # top cap, facing up
    ])
    return vertices, faces


def campus_scene(n_elements: int, seed: int = 0) -> Scene:
    """``n_elements`` columns (100 triangles each) in buildings of 5 × 5 × 5 on a square grid."""
    unit_v, unit_f = prism()
    per_building = COLUMNS_PER_SIDE**2 * CAMPUS_STOREYS
    grid = int(np.ceil(np.sqrt(n_elements / per_building)))
    e = np.arange(n_elements)
    building, within = np.divmod(e, per_building)
    storey, in_storey = np.divmod(within, COLUMNS_PER_SIDE**2)
    cx, cy = np.divmod(in_storey, COLUMNS_PER_SIDE)
    by, bx = np.divmod(building, grid)
    radius = np.random.default_rng(seed).uniform(0.2, 0.4, n_elements)
    size = np.stack([radius, radius, np.full(n_elements, STOREY_M - 0.3)], axis=1)
    origin = np.stack([bx * BUILDING_PITCH_M + cx * COLUMN_PITCH_M, by * BUILDING_PITCH_M + cy * COLUMN_PITCH_M,
                       storey * STOREY_M], axis=1)
    vertices = (unit_v[None] * size[:, None] + origin[:, None]).reshape(-1, 3)
    faces = (unit_f[None] + len(unit_v) * e[:, None, None]).reshape(-1, 3)
    face_element = np.repeat(e, len(unit_f))
    elements = ElementTable.build(
        global_id=[f"column-{i:06d}" for i in range(n_elements)],
        name=[f"C{b}.{s}.{x}{y}" for b, s, x, y in zip(building, storey, cx, cy)],
        ifc_class=["IfcColumn"] * n_elements,
        discipline=["S"] * n_elements,
        storey=[f"Level {s}" for s in storey],
    )
    return Scene.from_arrays(vertices, faces, face_element, elements, source="synthetic campus")


def write_ifc(path: Path, bays: int, storeys: int) -> dict:
    """Write a bays × bays steel frame of ``storeys`` storeys as IFC4; its element and entity counts."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.unit
    from ifcopenshell.guid import new as guid

    f = ifcopenshell.api.project.create_file(version="IFC4")
    project = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="Generated steel frame")
    units = [ifcopenshell.api.unit.add_si_unit(f, unit_type=t) for t in ("LENGTHUNIT", "AREAUNIT", "VOLUMEUNIT")]
    ifcopenshell.api.unit.assign_unit(f, units=units)
    model = ifcopenshell.api.context.add_context(f, context_type="Model")
    body = ifcopenshell.api.context.add_context(f, context_type="Model", context_identifier="Body",
                                                target_view="MODEL_VIEW", parent=model)

    def point(x: float, y: float, z: float):
        return f.createIfcCartesianPoint((float(x), float(y), float(z)))

    def direction(x: float, y: float, z: float):
        return f.createIfcDirection((float(x), float(y), float(z)))

    def placement(relative_to, x: float = 0.0, y: float = 0.0, z: float = 0.0):
        return f.createIfcLocalPlacement(relative_to, f.createIfcAxis2Placement3D(point(x, y, z), None, None))

    site = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSite", name="Site")
    building = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuilding", name="Frame")
    site.ObjectPlacement = placement(None)
    building.ObjectPlacement = placement(site.ObjectPlacement)
    ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=project)
    ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)

    up, x_axis, y_axis = direction(0, 0, 1), direction(1, 0, 0), direction(0, 1, 0)
    origin = f.createIfcAxis2Placement3D(point(0, 0, 0), None, None)
    # beams: the profile's x along the other plan axis, its y up, extruded along the beam
    along_x = f.createIfcAxis2Placement3D(point(0, 0, 0), x_axis, y_axis)
    along_y = f.createIfcAxis2Placement3D(point(0, 0, 0), y_axis, direction(-1, 0, 0))
    column_profile = f.createIfcRectangleProfileDef("AREA", "400x400", None, 0.4, 0.4)
    beam_profile = f.createIfcIShapeProfileDef("AREA", "IPE400", None, 0.18, 0.4, 0.0086, 0.0135)
    slab_profile = f.createIfcRectangleProfileDef(
        "AREA", "bay", f.createIfcAxis2Placement2D(f.createIfcCartesianPoint((BAY_M / 2, BAY_M / 2)), None), BAY_M, BAY_M)
    wall_profile = f.createIfcRectangleProfileDef(
        "AREA", "wall", f.createIfcAxis2Placement2D(f.createIfcCartesianPoint((BAY_M / 2, 0.0)), None), BAY_M, 0.3)
    by_class: dict[str, list] = {}
    counter = {"n": 0}

    def element(ifc_class: str, name: str, where, item, kind: str, length: float, storey_products: list) -> None:
        """One product with its Body, a property set and base quantities."""
        rep = f.createIfcShapeRepresentation(body, "Body", kind, [item])
        product = f.create_entity(ifc_class, GlobalId=guid(), Name=name, ObjectPlacement=where,
                                  Representation=f.createIfcProductDefinitionShape(None, None, [rep]))
        common = ifc_class[3:]
        props = [f.createIfcPropertySingleValue("Reference", None, f.createIfcIdentifier(name), None),
                 f.createIfcPropertySingleValue("LoadBearing", None, f.createIfcBoolean(ifc_class != "IfcWall"), None),
                 f.createIfcPropertySingleValue("IsExternal", None, f.createIfcBoolean(ifc_class == "IfcWall"), None),
                 f.createIfcPropertySingleValue("FireRating", None, f.createIfcLabel("R60"), None)]
        f.createIfcRelDefinesByProperties(guid(), None, None, None, [product],
                                          f.createIfcPropertySet(guid(), None, f"Pset_{common}Common", None, props))
        quantities = [f.createIfcQuantityLength("Length", None, None, float(length), None),
                      f.createIfcQuantityCount("Count", None, None, 1.0, None)]
        f.createIfcRelDefinesByProperties(guid(), None, None, None, [product], f.createIfcElementQuantity(
            guid(), None, f"Qto_{common}BaseQuantities", None, None, quantities))
        storey_products.append(product)
        by_class.setdefault(ifc_class, []).append(product)
        counter["n"] += 1

    def extrusion(profile, position, depth: float):
        return f.createIfcExtrudedAreaSolid(profile, position, up, depth)

    def brace(dx: float, dy: float, dz: float, half: float = 0.08):
        """A faceted-brep bar of square section from the origin to (dx, dy, dz)."""
        a = np.array([dx, dy, dz], float)
        u = a / np.linalg.norm(a)
        v = np.cross(u, [0.0, 0.0, 1.0])
        v /= np.linalg.norm(v)
        w = np.cross(v, u)
        ring = [half * (sv * v + sw * w) for sv, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        pts = [point(*c) for c in ring] + [point(*(c + a)) for c in ring]
        quads = [(0, 3, 2, 1), (4, 5, 6, 7)] + [(i, (i + 1) % 4, (i + 1) % 4 + 4, i + 4) for i in range(4)]
        faces = [f.createIfcFace([f.createIfcFaceOuterBound(f.createIfcPolyLoop([pts[i] for i in q]), True)])
                 for q in quads]
        return f.createIfcFacetedBrep(f.createIfcClosedShell(faces))

    n = bays + 1
    height = IFC_STOREY_M - SLAB_M
    brace_m = float(np.hypot(BAY_M, height))
    for s in range(storeys):
        storey = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuildingStorey", name=f"Level {s}")
        storey.Elevation = s * IFC_STOREY_M
        storey.ObjectPlacement = placement(building.ObjectPlacement, 0.0, 0.0, s * IFC_STOREY_M)
        ifcopenshell.api.aggregate.assign_object(f, products=[storey], relating_object=building)
        here: list = []
        sp = storey.ObjectPlacement
        for i in range(n):
            for j in range(n):
                element("IfcColumn", f"C{s}-{i}-{j}", placement(sp, i * BAY_M, j * BAY_M),
                        extrusion(column_profile, origin, height), "SweptSolid", height, here)
        top = height - 0.2  # the beam's axis, 0.2 m below the slab
        for i in range(bays):
            for j in range(n):
                element("IfcBeam", f"BX{s}-{i}-{j}", placement(sp, i * BAY_M, j * BAY_M, top),
                        extrusion(beam_profile, along_x, BAY_M), "SweptSolid", BAY_M, here)
                element("IfcBeam", f"BY{s}-{j}-{i}", placement(sp, j * BAY_M, i * BAY_M, top),
                        extrusion(beam_profile, along_y, BAY_M), "SweptSolid", BAY_M, here)
        for i in range(bays):
            for j in range(bays):
                element("IfcSlab", f"S{s}-{i}-{j}", placement(sp, i * BAY_M, j * BAY_M, height),
                        extrusion(slab_profile, origin, SLAB_M), "SweptSolid", BAY_M, here)
        # the perimeter: walls on the ground storey, X bracing above
        for k in range(bays):
            for side, (x, y, dx, dy) in enumerate(((k * BAY_M, 0.0, 1, 0), (k * BAY_M, bays * BAY_M, 1, 0),
                                                   (0.0, k * BAY_M, 0, 1), (bays * BAY_M, k * BAY_M, 0, 1))):
                if s == 0:
                    wall_position = origin if dx else f.createIfcAxis2Placement3D(point(0, 0, 0), up, y_axis)
                    element("IfcWall", f"W{side}-{k}", placement(sp, x, y), extrusion(wall_profile, wall_position, height),
                            "SweptSolid", BAY_M, here)
                    continue
                element("IfcMember", f"X{s}-{side}-{k}a", placement(sp, x, y), brace(BAY_M * dx, BAY_M * dy, height),
                        "Brep", brace_m, here)
                element("IfcMember", f"X{s}-{side}-{k}b", placement(sp, x + BAY_M * dx, y + BAY_M * dy),
                        brace(-BAY_M * dx, -BAY_M * dy, height), "Brep", brace_m, here)
        f.createIfcRelContainedInSpatialStructure(guid(), None, None, None, here, storey)
    for ifc_class, products in by_class.items():
        material = f.createIfcMaterial("S355" if ifc_class in ("IfcColumn", "IfcBeam", "IfcMember") else "C30/37")
        f.createIfcRelAssociatesMaterial(guid(), None, None, None, products, material)
    f.write(str(path))
    return {"elements": counter["n"], "entities": len(list(f)), "bytes": path.stat().st_size,
            "by_class": {k: len(v) for k, v in sorted(by_class.items())}}


# ---------------------------------------------------------------- cases (each in its own process)
def features_path(workdir: Path, model: str) -> Path:
    return workdir / f"{model}-features.npz"


def ifc_path(workdir: Path) -> Path:
    return workdir / "frame.ifc"


def load_scene(args: argparse.Namespace) -> Scene:
    workdir = Path(args.workdir)
    if args.model == "campus":
        return campus_scene(args.elements)
    scene, _ = load_model(ifc_path(workdir), cache=True, cache_dir=workdir / "scenes")
    return scene


def case_write_ifc(args: argparse.Namespace) -> dict:
    t = time.perf_counter()
    info = write_ifc(ifc_path(Path(args.workdir)), args.bays, args.storeys)
    return {**info, "write_s": time.perf_counter() - t, "peak_rss_mb": peak_rss_mb()}


def case_prepare(args: argparse.Namespace) -> dict:
    """Build or load the model (the IFC through load_model, tessellating), then sample its features once."""
    workdir = Path(args.workdir)
    t = time.perf_counter()
    if args.model == "campus":
        scene = campus_scene(args.elements)
        out: dict = {"build_s": time.perf_counter() - t}
    else:
        shutil.rmtree(workdir / "scenes", ignore_errors=True)  # a real load, tessellating; the cache is for the runs
        scene, report = load_model(ifc_path(workdir), cache=True, cache_dir=workdir / "scenes")
        out = {"load_s": report.elapsed_s, "products": report.n_products, "skipped": len(report.skipped),
               "file_mb": ifc_path(workdir).stat().st_size / 2**20}
    out.update(elements=int(scene.targets.sum()), triangles=len(scene.faces), model_rss_mb=peak_rss_mb(),
               extent_m=[round(float(x), 1) for x in np.ptp(scene.bounds(), axis=0)])
    t = time.perf_counter()
    features = sample_features(scene)
    out.update(features=len(features), features_s=time.perf_counter() - t)
    features.save(features_path(workdir, args.model))
    out["peak_rss_mb"] = peak_rss_mb()
    return out


def case_eval(args: argparse.Namespace) -> dict:
    """Cast the plan in batches of ``args.batch`` frames with one engine; merge; compute the metrics."""
    workdir = Path(args.workdir)
    scene = load_scene(args)
    features = FeatureSet.load(features_path(workdir, args.model))
    if features.params.get("scene") != scene.key:
        raise RuntimeError("the saved features belong to another scene")
    plan = drone_plan(scene, get_camera("p4p"), args.frames)
    settings = EvaluationSettings(engine=args.engine, scale=args.scale)
    rss_model = peak_rss_mb()
    t = time.perf_counter()
    engine = make_engine(settings.engine, scene, features, d_max=settings.d_max, threads=settings.threads)
    # the gl engine tests features with exact rays through an Embree BVH built on first use: build it now
    engine.first_hit(np.zeros((1, 3), np.float32), np.array([[0.0, 0.0, 1.0]], np.float32))
    build_s = time.perf_counter() - t
    rss_engine = peak_rss_mb()
    meta = {"engine": engine.name, "scale": settings.scale, "d_max": settings.d_max, "scene": scene.key,
            "features": features.key, "feature_params": features.params}
    parts: list[Observations] = []
    peaks: list[float] = []
    now: list[float] = []
    frame_s: list[float] = []
    with engine:
        for a in range(0, len(plan), args.batch):
            batch = plan.subset(np.arange(a, min(a + args.batch, len(plan))))
            frames = []
            for i in range(len(batch)):
                t = time.perf_counter()
                frames.append(engine.observe(batch.camera_of(i), batch.R_world_camera[i], batch.C_world[i], settings.scale))
                frame_s.append(time.perf_counter() - t)
            parts.append(Observations.from_frames(frames, scene.targets, scene.present, len(features), meta))
            del frames
            peaks.append(peak_rss_mb())
            now.append(rss_mb())
    obs = Observations.concatenate(parts)
    metrics = compute_metrics(obs, settings.metric).plan
    cast_s = float(sum(frame_s))
    return {"engine": args.engine, "renderer": getattr(engine, "renderer", None), "batch": args.batch,
            "frames": len(plan), "engine_build_s": build_s, "first_frame_s": frame_s[0], "cast_s": cast_s,
            "s_per_frame": cast_s / len(plan), "frame_s": frame_s,
            "rss_model_mb": rss_model, "rss_engine_mb": rss_engine, "peak_first_batch_mb": peaks[0],
            "peak_rss_mb": peak_rss_mb(), "peak_after_batch_mb": peaks, "rss_after_batch_mb": now,
            "observation_rows": len(obs.frame), "feature_sightings": len(obs.feature_id),
            "observations_mb": sum(getattr(obs, k).nbytes for k in OBSERVATION_COLUMNS) / 2**20,
            "metrics": metrics.to_dict()}


CASES = {"write-ifc": case_write_ifc, "prepare": case_prepare, "eval": case_eval}


def run_case(case: str, args: argparse.Namespace, **extra) -> dict:
    """Run one case in a fresh interpreter; its JSON result, or {'error': ...}."""
    options = {"workdir": args.workdir, "elements": args.elements, "bays": args.bays, "storeys": args.storeys,
               "frames": args.frames, "scale": args.scale, **extra}
    argv = ["--case", case]
    for key, value in options.items():
        argv += [f"--{key}", str(value)]
    proc, result, wall = run_script(__file__, argv, RESULT_PREFIX)
    if result is None:
        result = {"error": f"no result (exit status {proc.returncode})"}
    result["wall_s"] = wall
    return result


def child(args: argparse.Namespace) -> int:
    try:
        result = CASES[args.case](args)
    except Exception as exc:  # reported to the parent as this configuration's result
        emit(RESULT_PREFIX, {"error": f"{type(exc).__name__}: {exc}"})
        raise
    emit(RESULT_PREFIX, result)
    return 0


# ---------------------------------------------------------------- report
def print_table(results: dict) -> None:
    console.width = max(console.width, 124)
    models = numeric_table(("model", "elements", "triangles", "features", "size", "load / build s", "features s",
                            "peak RSS MB"), left=("model", "size"), title="Models")
    for name, m in results["models"].items():
        if "error" in m:
            models.add_row(name, f"[red]{m['error']}[/red]", *[""] * 6)
            continue
        size = (f"{m['file_mb']:.1f} MB, {m['written']['entities']:,} entities" if "written" in m
                else f"{m['extent_m'][0]:.0f} m wide")
        models.add_row(name, f"{m['elements']:,}", f"{m['triangles']:,}", f"{m['features']:,}", size,
                       f"{m.get('load_s', m.get('build_s', 0.0)):.2f}", f"{m['features_s']:.1f}",
                       f"{m['peak_rss_mb']:,.0f}")
    console.print(models)
    runs = numeric_table(("model", "engine", "frames", "batch", "build s", "1st frame s", "s/frame", "RSS built MB",
                          "peak 1st batch MB", "peak MB", "obs MB", "VC"), left=("model", "engine"),
                         title=f"Evaluation (20 MP frames at scale {results['settings']['scale']}, "
                               f"{os.cpu_count()} CPU cores)")
    for r in results["runs"]:
        if "error" in r:
            runs.add_row(r["model"], r["engine"], str(results["settings"]["frames"]), str(r["batch"]),
                         f"[red]{r['error']}[/red]", *[""] * 7)
            continue
        runs.add_row(r["model"], r["engine"], str(r["frames"]), str(r["batch"]), f"{r['engine_build_s']:.1f}",
                     f"{r['first_frame_s']:.2f}", f"{r['s_per_frame']:.2f}", f"{r['rss_engine_mb']:,.0f}",
                     f"{r['peak_first_batch_mb']:,.0f}", f"{r['peak_rss_mb']:,.0f}", f"{r['observations_mb']:.1f}",
                     f"{r['metrics']['VC']:.4f}")
    console.print(runs)
    renderer = next((r["renderer"] for r in results["runs"] if r.get("renderer")), None)
    if renderer:
        console.print(f"gl renderer: {renderer}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true",
                    help="a smaller run: 5,000 columns (500k triangles), an 8 × 8-bay IFC of 3 storeys, 8 frames")
    ap.add_argument("--elements", type=int, help="campus columns, 100 triangles each (default 50,000)")
    ap.add_argument("--bays", type=int, help="IFC frame bays per side (default 30)")
    ap.add_argument("--storeys", type=int, help="IFC frame storeys (default 6)")
    ap.add_argument("--frames", type=int, help="frames per plan (default 16)")
    ap.add_argument("--batches", type=int, nargs="+", help="batch sizes, one run each (default: 4 and all frames)")
    ap.add_argument("--scale", type=float, default=0.25, help="resolution scale of the 20 MP frames")
    ap.add_argument("--engines", nargs="+", default=list(ENGINES), choices=ENGINES)
    ap.add_argument("--models", nargs="+", default=["campus", "ifc"], choices=["campus", "ifc"])
    ap.add_argument("--workdir", help="keep the generated IFC and features here (default: a temporary directory)")
    ap.add_argument("--out", default=str(Path(__file__).with_name("large.json")))
    ap.add_argument("--case", choices=sorted(CASES), help=argparse.SUPPRESS)
    ap.add_argument("--model", choices=["campus", "ifc"], help=argparse.SUPPRESS)
    ap.add_argument("--engine", choices=ENGINES, help=argparse.SUPPRESS)
    ap.add_argument("--batch", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    quick = args.quick
    for name, full, small in (("elements", 50_000, 5_000), ("bays", 30, 8), ("storeys", 6, 3), ("frames", 16, 8)):
        if getattr(args, name) is None:
            setattr(args, name, small if quick else full)
    if args.case:
        return child(args)
    batches = args.batches or sorted({min(4, args.frames), args.frames})

    with tempfile.TemporaryDirectory(prefix="sightplan-large-") as tmp:
        args.workdir = args.workdir or tmp
        Path(args.workdir).mkdir(parents=True, exist_ok=True)
        results: dict = {"settings": {"quick": quick, "elements": args.elements, "bays": args.bays,
                                      "storeys": args.storeys, "frames": args.frames, "scale": args.scale,
                                      "batches": batches, "camera": "p4p", "cpus": os.cpu_count()},
                         "models": {}, "runs": []}
        t_all = time.perf_counter()
        for model in args.models:
            written: dict = {}
            if model == "ifc":
                written = run_case("write-ifc", args)
                print(f"ifc: wrote {written.get('entities', 0):,} entities, {written.get('bytes', 0) / 2**20:.1f} MB "
                      f"in {written['wall_s']:.1f} s", flush=True)
            info = {"error": written["error"]} if "error" in written else run_case("prepare", args, model=model)
            if written:
                info["written"] = written
            results["models"][model] = info
            if "error" in info:
                print(f"{model}: {info['error']}", flush=True)
                continue
            print(f"{model}: {info['elements']:,} elements, {info['triangles']:,} triangles, {info['features']:,} features "
                  f"(ready in {info['wall_s']:.1f} s, peak {info['peak_rss_mb']:,.0f} MB)", flush=True)
            for engine in args.engines:
                for batch in batches:
                    r = {"model": model, **run_case("eval", args, model=model, engine=engine, batch=batch)}
                    r.setdefault("engine", engine)
                    r.setdefault("batch", batch)
                    results["runs"].append(r)
                    if "error" in r:
                        print(f"{model} {engine} batch {batch}: {r['error']}", flush=True)
                    else:
                        print(f"{model} {engine} batch {batch}: build {r['engine_build_s']:.1f} s, "
                              f"{r['s_per_frame']:.2f} s/frame, peak {r['peak_rss_mb']:,.0f} MB "
                              f"(wall {r['wall_s']:.0f} s)", flush=True)
        results["total_s"] = time.perf_counter() - t_all
    print_table(results)
    print(f"total {results['total_s']:.0f} s")
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
