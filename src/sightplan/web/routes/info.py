"""``/api/info`` and ``/api/cameras``."""

from __future__ import annotations

from fastapi import APIRouter

from ...formats.registry import EXPORT_FORMATS, WRITERS
from ...metrics.glossary import glossary
from ...plan.checks import battery
from ...plan.templates.base import label_of, unit_of
from ...plan.templates.registry import TEMPLATES, default_flight
from ...version import __version__
from ..deps import StateDep
from ..schemas import BasemapOut, CameraOut, InfoOut, TemplateFieldOut, TemplateOut

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
                   max_upload_bytes=cfg.max_upload_bytes, templates=list(TEMPLATES),
                   export_formats=list(EXPORT_FORMATS),
                   export_format_help={f.name: f.help or f.label for f in WRITERS},
                   aircraft={k: v.name for k, v in {**battery.AIRCRAFT, **battery.ROVERS}.items()},
                   metric_help=glossary(),
                   basemap=BasemapOut(url=cfg.basemap_url, attribution=cfg.basemap_attribution)
                   if cfg.basemap_url else None)


@router.get("/templates", response_model=list[TemplateOut], summary="The plan templates and their parameters")
def templates() -> list[TemplateOut]:
    """Every template with its parameters as declared once in the library (name with its unit, kind, bounds,
    default, help): the page builds its form from this, as the command line builds ``sightplan plan``'s options."""
    out = []
    for t in TEMPLATES.values():
        fields = [TemplateFieldOut(name=name, label=label_of(name, info), kind=info.kind,
                                   unit=unit_of(name), help=info.help, default=default if default != () else None,
                                   ge=info.ge, gt=info.gt, le=info.le, lt=info.lt, choices=list(info.choices),
                                   pair=info.pair)
                  for name, info, default in t.web_fields()]
        out.append(TemplateOut(name=t.name, summary=t.summary, walked=t.walked,
                               safety_distance_m=default_flight(t.walked)["safety_distance_m"], fields=fields))
    return out


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
