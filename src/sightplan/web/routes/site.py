"""``/api/projects/{project_id}/models/{model_id}/site``: where a model stands on the earth, for the page's map: its
footprint in latitude/longitude, and the affine map from model metres to latitude/longitude that the page uses to draw
frames, missions and pilots, with its largest error over the site. A model without a georeference gets the same
answer about a stand-in origin at 0° N 0° E with model +Y as north, marked as such."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, File, HTTPException, Response, UploadFile
from fastapi.responses import FileResponse
from starlette.concurrency import run_in_threadpool

from ...geo import Georeference, GeoreferenceError
from ...model.footprint import footprint_rings
from ..basemap import SUFFIXES, TILE_MEDIA, prepare, read_info, read_tile
from ..deps import ProjectEdit, ProjectRead, SessionDep, StateDep, ready_model
from ..schemas import ErrorOut, ProjectBackgroundOut, ProjectBasemapOut, SiteOut
from ..services import load_scene
from ..storage import display_name
from ..uploads import receive_upload
from .viewer import NOT_FOUND, NOT_READY, PNG, _Cache

router = APIRouter(tags=["viewer"])
#: The affine fit covers the model and this much around it (m): the pilots' stations and a line-of-sight circle.
SITE_MARGIN_M = 600.0
_site_cache: _Cache = _Cache(8)
TILE = {200: {"description": "A PNG, JPEG or WebP tile", "content": {"image/png": {}, "image/jpeg": {}, "image/webp": {}}}}


def site_map(scene) -> dict[str, Any]:
    """The map's view of a scene: footprint rings (model x, y and latitude/longitude), the affine fit, and whether
    the georeference is the model's own."""
    note = ""
    try:
        geo = Georeference.from_scene_metadata(scene.metadata)
    except GeoreferenceError as exc:
        geo, note = None, str(exc)
    own = geo is not None
    if geo is None:
        geo = Georeference.from_origin(0.0, 0.0)
        note = note or "the model carries no georeference: the map shows model +Y as north about 0° N 0° E"
    lo, hi = scene.bounds()
    rings = footprint_rings(scene)
    z = float(lo[2])
    fit = geo.linear_fit(lo[:2] - SITE_MARGIN_M, hi[:2] + SITE_MARGIN_M, z)
    geodetic = []
    for ring in rings:
        lat, lon, _ = geo.to_geodetic(np.column_stack([ring, np.full(len(ring), z)]))
        geodetic.append(np.round(np.column_stack([lat, lon]), 9).tolist())
    centre = (lo + hi) / 2
    lat, lon, _ = geo.to_geodetic(centre[None])
    return {"georeferenced": own, "source": geo.source if own else "", "note": note,
            "centre_lat_lon": [float(lat[0]), float(lon[0])],
            "north_offset_deg": round(float(geo.north_offset_deg(centre[None])[0]), 4),
            "bounds": [np.round(lo, 4).tolist(), np.round(hi, 4).tolist()],
            "footprint_xy": [np.round(r, 4).tolist() for r in rings], "footprint_lat_lon": geodetic,
            "to_lat_lon": fit}


@router.get("/api/projects/{project_id}/models/{model_id}/site", response_model=SiteOut,
            summary="Where the model stands: its footprint in latitude/longitude, for the map",
            description="The union of the elements' outlines seen from above (the terrain left out), in model metres "
                        "and in WGS 84 latitude/longitude, and the affine map from model x, y to latitude/longitude "
                        "over the site (with its largest error) that the page draws frames and pilots with.",
            responses={**NOT_FOUND, **NOT_READY})
def model_site(project: ProjectRead, model_id: int, session: SessionDep, state: StateDep) -> SiteOut:
    model = ready_model(session, project.id, model_id)
    out = _site_cache.get(model.stored_name, lambda: site_map(load_scene(state.storage, model.stored_name)[0]))
    return SiteOut(model_id=model.id, **out)


# --------------------------------------------------------------------------- the project's own map background
def basemap_folder(state, project_id: int) -> Path:
    return state.storage.root / "basemaps" / str(project_id)


def basemap_out(info: dict[str, Any], base: str) -> ProjectBasemapOut:
    url = f"{base}/basemap/image.png" if info["kind"] == "image" else f"{base}/basemap/tiles/{{z}}/{{x}}/{{y}}"
    return ProjectBasemapOut(url=url, **{k: v for k, v in info.items() if k in ProjectBasemapOut.model_fields})


def basemap_info(state, project_id: int) -> dict[str, Any]:
    info = read_info(basemap_folder(state, project_id))
    if info is None:
        raise HTTPException(404, f"project {project_id} has no map background of its own")
    return info


@router.get("/api/projects/{project_id}/basemap", response_model=ProjectBackgroundOut,
            summary="The project's own map background (an orthomosaic or MBTiles); null when it has none",
            responses=NOT_FOUND)
def read_basemap(project: ProjectRead, state: StateDep) -> ProjectBackgroundOut:
    info = read_info(basemap_folder(state, project.id))
    return ProjectBackgroundOut(basemap=None if info is None else basemap_out(info, f"/api/projects/{project.id}"))


@router.post("/api/projects/{project_id}/basemap", response_model=ProjectBasemapOut,
            summary="Upload the project's map background: a GeoTIFF orthomosaic or raster MBTiles (editor or owner)",
            description="A GeoTIFF is placed by its own georeference (EPSG code; tie point and pixel scale, or a model "
                        "transformation) and shown at most 4096 px a side; an MBTiles file of PNG, JPEG or WebP tiles "
                        "is served tile by tile. It replaces the project's previous one and, on the project's map, "
                        "the server's basemap.",
            responses={**NOT_FOUND, 415: {"model": ErrorOut, "description": "Not a .tif, .tiff or .mbtiles file"},
                       422: {"model": ErrorOut, "description": "Not georeferenced, or not raster tiles"}})
async def upload_basemap(project: ProjectEdit, state: StateDep,
                         file: Annotated[UploadFile, File(description="GeoTIFF orthomosaic or MBTiles")]
                         ) -> ProjectBasemapOut:
    tmp, _ = await receive_upload(state, file, SUFFIXES, "map background (GeoTIFF or MBTiles)")
    folder = basemap_folder(state, project.id)
    staging = state.storage.temp_path("-basemap")
    try:
        info = await run_in_threadpool(prepare, tmp, staging, display_name(file.filename or "background"))
        state.storage.remove(folder)
        folder.parent.mkdir(parents=True, exist_ok=True)
        staging.replace(folder)
    finally:
        state.storage.remove(tmp, staging)
    return basemap_out(info, f"/api/projects/{project.id}")


@router.delete("/api/projects/{project_id}/basemap", status_code=204, response_class=Response,
               summary="Remove the project's map background (editor or owner)", responses=NOT_FOUND)
def delete_basemap(project: ProjectEdit, state: StateDep) -> Response:
    basemap_info(state, project.id)
    state.storage.remove(basemap_folder(state, project.id))
    return Response(status_code=204)


def basemap_image(state, project_id: int) -> FileResponse:
    if basemap_info(state, project_id)["kind"] != "image":
        raise HTTPException(404, "the project's map background is tiles, not one image")
    return FileResponse(basemap_folder(state, project_id) / "image.png", media_type="image/png",
                        headers={"Cache-Control": "private, max-age=300"})


def basemap_tile(state, project_id: int, z: int, x: int, y: int) -> Response:
    info = basemap_info(state, project_id)
    data = read_tile(basemap_folder(state, project_id), z, x, y) if info["kind"] == "tiles" else None
    if data is None:
        raise HTTPException(404, f"no tile {z}/{x}/{y} in the project's map background")
    return Response(data, media_type=TILE_MEDIA[info["format"]], headers={"Cache-Control": "private, max-age=300"})


@router.get("/api/projects/{project_id}/basemap/image.png", response_class=FileResponse,
            summary="The project's orthomosaic as one PNG", responses={**PNG, **NOT_FOUND})
def read_basemap_image(project: ProjectRead, state: StateDep) -> FileResponse:
    return basemap_image(state, project.id)


@router.get("/api/projects/{project_id}/basemap/tiles/{z}/{x}/{y}", response_class=Response,
            summary="One tile of the project's MBTiles (XYZ numbering)", responses={**TILE, **NOT_FOUND})
def read_basemap_tile(project: ProjectRead, state: StateDep, z: int, x: int, y: int) -> Response:
    return basemap_tile(state, project.id, z, x, y)
