"""The scene an evaluation ran against: the stored model, at its capture date (a linked schedule), with a reality
capture as occluders. The worker, the report and the viewer all take it from here, so they agree."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from ..errors import SightplanError
from ..model.scene import Scene
from .models import Reality, Schedule
from .services import FOURD_KEY, REALITY_KEY, dated_scene, load_scene
from .storage import Storage


def evaluation_scene(storage: Storage, session: Session, model_stored_name: str, settings: dict[str, Any],
                     project_id: int) -> Scene:
    """The evaluation's scene; its schedule and reality capture must still be project ``project_id``'s own."""
    scene = load_scene(storage, model_stored_name)[0]
    fourd = settings.get(FOURD_KEY)
    if fourd is not None:
        schedule = session.get(Schedule, fourd["schedule_id"])
        if schedule is None or schedule.project_id != project_id or schedule.status != "ready":
            raise SightplanError(f"schedule {fourd['schedule_id']} of the capture date was deleted or is not ready")
        scene = dated_scene(scene, storage.schedule_path(schedule.dates_name), fourd)
    reality_id = settings.get(REALITY_KEY)
    if reality_id is not None:
        from ..model.reality import combine, load_reality

        reality = session.get(Reality, reality_id)
        if reality is None or reality.project_id != project_id or reality.status != "ready":
            raise SightplanError(f"reality capture {reality_id} was deleted or is not ready")
        try:
            real = load_reality(storage.reality_path(reality.stored_name), cache_dir=storage.scene_cache)
        except SightplanError as exc:
            raise SightplanError(str(exc).replace(reality.stored_name, reality.original_name)) from None
        scene = combine(scene, real, "occluder")
    return scene


def evaluations_using(session: Session, project_id: int, key: str, ident: int) -> list[int]:
    """Ids of the project's evaluations whose scene takes schedule (``FOURD_KEY``) or reality capture
    (``REALITY_KEY``) ``ident``."""
    from sqlalchemy import select

    from .models import Evaluation

    out = []
    for ev_id, settings in session.execute(select(Evaluation.id, Evaluation.settings)
                                           .where(Evaluation.project_id == project_id)):
        value = (settings or {}).get(key)
        if (value.get("schedule_id") if isinstance(value, dict) else value) == ident:
            out.append(ev_id)
    return out
