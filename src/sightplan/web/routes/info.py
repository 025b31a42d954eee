"""``/api/info`` and ``/api/cameras``."""

from __future__ import annotations

from fastapi import APIRouter

from ...formats.registry import EXPORT_FORMATS
from ...plan.checks import battery
from ...version import __version__
from ..deps import StateDep
from ..schemas import CameraOut, InfoOut

router = APIRouter(prefix="/api", tags=["server"])
SINGLE_USER = "single-user mode on the loopback address: no login; anyone on this machine can use it"
TEAM = "team mode: log in with your account; you see the projects you are a member of"


@router.get("/info", response_model=InfoOut, summary="Server version, mode and limits")
def info(state: StateDep) -> InfoOut:
    cfg = state.config
    database = "embedded SQLite" if cfg.embedded else state.db.engine.dialect.name
    return InfoOut(version=__version__, mode="team" if cfg.team else "single-user", login=cfg.team,
                   message=TEAM if cfg.team else SINGLE_USER, database=database,
                   data_dir="" if cfg.team else str(cfg.data_dir),
                   max_upload_bytes=cfg.max_upload_bytes, templates=["facade", "orbit", "lawnmower", "bridge", "route"],
                   export_formats=list(EXPORT_FORMATS),
                   aircraft={k: v.name for k, v in {**battery.AIRCRAFT, **battery.ROVERS}.items()})


@router.get("/cameras", response_model=list[CameraOut], summary="The built-in camera catalogue")
def cameras() -> list[CameraOut]:
    from ...camera.catalogue import list_cameras
    from ...camera.models import PinholeCamera

    out = []
    for entry in list_cameras():
        cam = entry.camera()
        out.append(CameraOut(id=entry.id, name=entry.name, width=cam.width, height=cam.height,
                             model="pinhole" if isinstance(cam, PinholeCamera) else "equirectangular"))
    return out
