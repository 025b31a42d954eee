"""``/api/projects/{project_id}/models/{model_id}/site``: where a model stands on the earth, for the page's map: its
footprint in latitude/longitude, and the affine map from model metres to latitude/longitude that the page uses to draw
frames, missions and pilots, with its largest error over the site. A model without a georeference gets the same
answer about a stand-in origin at 0° N 0° E with model +Y as north, marked as such."""

from __future__ import annotations

from typing import Any

import numpy as np
from fastapi import APIRouter

from ...geo import Georeference, GeoreferenceError
from ...model.footprint import footprint_rings
from ..deps import ProjectRead, SessionDep, StateDep, ready_model
from ..schemas import SiteOut
from ..services import load_scene
from .viewer import NOT_FOUND, NOT_READY, _Cache

router = APIRouter(tags=["viewer"])
#: The affine fit covers the model and this much around it (m): the pilots' stations and a line-of-sight circle.
SITE_MARGIN_M = 600.0
_site_cache: _Cache = _Cache(8)


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
