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


def evaluation_scene(storage: Storage, session: Session, model_stored_name: str, settings: dict[str, Any]) -> Scene:
    scene = load_scene(storage, model_stored_name)[0]
    fourd = settings.get(FOURD_KEY)
    if fourd is not None:
        schedule = session.get(Schedule, fourd["schedule_id"])
        if schedule is None or schedule.status != "ready":
            raise SightplanError(f"schedule {fourd['schedule_id']} of the capture date was deleted or is not ready")
        scene = dated_scene(scene, storage.schedule_path(schedule.dates_name), fourd)
    reality_id = settings.get(REALITY_KEY)
    if reality_id is not None:
        from ..model.reality import combine, load_reality

        reality = session.get(Reality, reality_id)
        if reality is None or reality.status != "ready":
            raise SightplanError(f"reality capture {reality_id} was deleted or is not ready")
        try:
            real = load_reality(storage.reality_path(reality.stored_name), cache_dir=storage.cache)
        except SightplanError as exc:
            raise SightplanError(str(exc).replace(reality.stored_name, reality.original_name)) from None
        scene = combine(scene, real, "occluder")
    return scene
