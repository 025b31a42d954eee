"""The sample project a fresh server can start with: the bundled Duplex, a facade-grid plan around it (the quick
start's plan), and its evaluation, queued on the worker so the page shows it running."""

from __future__ import annotations

import shutil

from sqlalchemy import select

from .deps import ServerState
from .models import Job, Model, Plan, Project
from .schemas import TEMPLATE_REQUESTS, SettingsIn

SAMPLE_PROJECT = "Duplex sample"


def ensure_sample_project(state: ServerState, scale: float = 0.25) -> int | None:
    """Create the sample project unless a project of that name exists; returns the evaluation's job id (None when
    nothing was made)."""
    from ..model.load import sample_model_path
    from .routes.evaluations import queue_evaluation
    from .routes.plans import commit_version
    from .services import load_scene, template_plan

    storage = state.storage
    with state.db.session() as s:
        if s.scalars(select(Project).where(Project.name == SAMPLE_PROJECT)).first() is not None:
            return None
        source = sample_model_path()
        stored = storage.new_name(source.suffix.lower())
        shutil.copyfile(source, storage.model_path(stored))
        project = Project(name=SAMPLE_PROJECT)
        s.add(project)
        s.flush()
        model = Model(project_id=project.id, original_name=source.name, stored_name=stored,
                      size_bytes=source.stat().st_size)
        s.add(model)
        s.flush()
        load = Job(project_id=project.id, kind="load_model", model_id=model.id, message="queued")
        s.add(load)
        s.commit()
        project_id, model_id, load_id = project.id, model.id, load.id
    state.worker.run(load_id)  # in this thread: the plan needs the model
    body = TEMPLATE_REQUESTS["facade"](name="facade grid, 8 m", model_id=model_id, template="facade", camera="p4p",
                                       safety_distance_m=8.0, overlap=0.8)
    with state.db.session() as s:
        if s.get(Model, model_id).status != "ready":  # type: ignore[union-attr]
            return None
        scene = load_scene(storage, stored)[0]
        plan = commit_version(state, s, Plan(project_id=project_id, model_id=model_id, name=body.name,
                                             source="template facade (p4p)"), template_plan(scene, body),
                              "facade template")
        version = s.scalars(select(Plan).where(Plan.id == plan.id)).one().versions[0]
        job_id = queue_evaluation(state, s, version, model_id, SettingsIn(scale=scale).model_dump())[1].id
    return job_id
