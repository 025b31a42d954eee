"""``sightplan render MODEL PLAN -o images/`` and ``sightplan reconstruct images/ -o recon/``: synthetic photographs
of a plan, and a structure-from-motion run on them registered to the model."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..engines.base import EngineName
from .base import ENGINE_HELP, app, console
from .camera_opts import DEFAULT_PRESET, FocalOpt, PhotoRealismOpt, PlanCameraOpt, SeedOpt, cli_camera
from .errors import friendly_errors, writable_folder
from .fourd import (
    ActualOpt,
    BasisOpt,
    DateOpt,
    RulesOpt,
    ScheduleOpt,
    UnscheduledOpt,
    check_date_options,
    dated_scene,
)
from .loading import georef_kwargs, load_with_progress, print_warnings, refuse_if_far
from .stages import StageDisplay

#: a render's stages as the progress lines name them
RENDER_STAGES = {"engine": "building the engine", "frames": "rendering frames",
                 "writing": "writing the element maps and depths"}


@app.command("render")
@friendly_errors
def render_command(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    plan: Annotated[str, typer.Argument(help="Plan file (any format `sightplan evaluate` reads); pinhole cameras")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for the images, render.json, the true poses "
                                                          "(poses/, COLMAP text) and the element maps")] = Path("images"),
    scale: Annotated[float, typer.Option(help="Resolution scale s: images of (s·W)×(s·H) pixels")] = 1.0,
    engine: Annotated[EngineName, typer.Option(help=ENGINE_HELP)] = "embree",
    camera: PlanCameraOpt = None,
    focal_mm: FocalOpt = None,
    transform: Annotated[Path | None, typer.Option(help="JSON 4×4 similarity from the poses' frame to the model's")] = None,
    texture_cell: Annotated[float | None, typer.Option(
        help="Finest texture cell (m); default 6 × the plan's typical surface sampling distance")] = None,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    photo_realism: PhotoRealismOpt = DEFAULT_PRESET,
    seed: SeedOpt = 0,
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
    threads: Annotated[int | None, typer.Option(help="Worker threads (default: all cores)")] = None,
) -> None:
    """Render each frame of a plan as an 8-bit image: every element in its own world-fixed texture, exact intrinsics,
    with the true poses and the per-pixel element map beside the images."""
    from ..loop.photo import photo_options
    from ..loop.render import render_plan
    from ..plan.load import load_plan

    check_date_options(date_basis, unscheduled)
    writable_folder(out, "--out")
    scene, _ = load_with_progress(console, model, cache)
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    the_plan = load_plan(plan, camera=cli_camera(camera, focal_mm), transform=transform, **georef_kwargs(scene))
    refuse_if_far(scene, the_plan)
    print_warnings(console, the_plan.parameters.get("warnings", []))
    with StageDisplay(console, RENDER_STAGES, transient=False) as display:
        renders = render_plan(scene, the_plan, out, scale=scale, engine=engine, texture_cell_m=texture_cell,
                              threads=threads, stages=display, photo_options=photo_options(photo_realism, seed))
    cam = renders.camera(0)
    console.print(f"rendered {len(renders)} frames ({cam.width}×{cam.height} px, engine {renders.engine}, texture cell "
                  f"{renders.texture_cell_m:.3g} m, photo-realism {renders.preset}, seed {seed}) into {out}",
                  highlight=False)
    if renders.blank_frames:
        shown = ", ".join(renders.frame_names[i] for i in renders.blank_frames[:10])
        more = "…" if len(renders.blank_frames) > 10 else ""
        console.print(f"[yellow]warning:[/] {len(renders.blank_frames)} frame(s) show no element (sky only): "
                      f"{shown}{more}", highlight=False)
    else:
        console.print("blank frames: none", highlight=False)


@app.command("reconstruct")
@friendly_errors
def reconstruct_command(
    images: Annotated[Path, typer.Argument(help="A folder written by `sightplan render`")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for points.npz, registration.json, sparse/ "
                                                          "(the COLMAP model in the model's frame) and database.db")
                   ] = Path("recon"),
    matcher: Annotated[str, typer.Option(
        help="Feature matching: exhaustive (every pair), spatial (each frame with the views that see most of the "
             "same surface, round corners too, from the true poses and depths), sequential (neighbours in plan "
             "order), auto (exhaustive up to 60 images, spatial beyond)")] = "auto",
    threads: Annotated[int | None, typer.Option(
        help="CPU threads for SIFT and matching (default: all cores); the mapping uses one, so the result is the "
        "same whatever the count")] = None,
    verbose: Annotated[bool, typer.Option(help="Show COLMAP's own log")] = False,
) -> None:
    """Structure from motion on rendered frames (pycolmap: SIFT, matching, incremental mapping, on the CPU),
    registered to the model by a similarity fitted to the true camera poses."""
    from ..loop.reconstruct import reconstruct
    from ..loop.render import read_renders

    renders = read_renders(images)
    writable_folder(out, "--out")
    with StageDisplay(console, {"sfm": "structure from motion"}, transient=False) as display:
        step = [""]  # the step reconstruct names last, shown beside the run's count of work units
        counts = [0, 3 * len(renders)]

        def named(text: str) -> None:
            step[0] = text
            display("sfm", *counts, text)

        def units(i: int, n: int) -> None:
            counts[:] = [i, n]
            display("sfm", i, n, step[0])

        rec = reconstruct(images, out, matcher=matcher, threads=threads, verbose=verbose, progress=units,
                          stage=named)
    t = rec.info.get("timings_s", {})
    console.print(f"registered {rec.n_registered}/{len(rec.frame_names)} frames, {len(rec.points):,} points "
                  f"(matcher {rec.info.get('matcher')}; extraction {t.get('extract_s', 0):.1f} s, matching "
                  f"{t.get('match_s', 0):.1f} s, mapping {t.get('map_s', 0):.1f} s)", highlight=False)
    console.print(f"registration residual {rec.residual_m:.4g} m = {100 * rec.residual_share:.3g} % of the scene's "
                  f"size ({rec.scene_size_m:.1f} m); similarity scale {rec.scale:.4g}", highlight=False)
    missing = [rec.frame_names[i] for i in range(len(rec.frame_names)) if not rec.registered[i]]
    if missing:
        console.print(f"[yellow]warning:[/] {len(missing)} frame(s) not registered: {', '.join(missing[:10])}"
                      f"{'…' if len(missing) > 10 else ''}", highlight=False)
    console.print(f"wrote {out / 'points.npz'}, {out / 'registration.json'}, {out / 'sparse'}", highlight=False)
