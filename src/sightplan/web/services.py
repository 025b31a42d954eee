"""The library calls behind the API: load a stored model, build a plan from a template, read an uploaded plan,
rebuild a finished evaluation. No database here."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from ..errors import PlanError
from ..evaluate import Evaluation, EvaluationSettings
from ..metrics import MetricParams
from ..model.load import IFC_EXTENSIONS
from ..model.scene import Scene
from ..model.summary import LoadReport
from ..plan.site import with_site
from ..plan.templates.registry import TEMPLATES, WALKED, default_flight, plan_from_template
from ..plan.types import Plan
from .models import Plan as PlanRow
from .models import PlanVersion
from .schemas import OptimizeIn, SettingsIn, TemplatePlanBase
from .storage import Storage


def load_scene(storage: Storage, stored_name: str, progress=None) -> tuple[Scene, LoadReport]:
    """The stored model as a Scene (tessellated once, then from the data folder's cache)."""
    from ..model.load import load_model

    path = storage.model_path(stored_name)
    extra: dict[str, Any] = {}
    if progress is not None and path.suffix.lower() in IFC_EXTENSIONS:
        extra["progress"] = progress
    return load_model(path, cache=True, cache_dir=storage.scene_cache, **extra)


def report_summary(report: LoadReport) -> dict[str, Any]:
    """The load report as JSON, without the file path the server chose."""
    d = report.to_dict()
    d.pop("source", None)
    return d


FOURD_KEY = "fourd"  # the capture date of an evaluation, kept beside its settings
REALITY_KEY = "reality_id"  # the reality capture an evaluation takes as occluders
AS_FLOWN_KEY = "as_flown"  # the autopilot whose replay of the version's export is evaluated
ROBUSTNESS_KEY = "robustness"  # the position error and draws an evaluation's metrics are also spread under


def evaluation_settings(s: dict[str, Any]) -> EvaluationSettings:
    v = SettingsIn(**{k: x for k, x in s.items() if k not in (FOURD_KEY, REALITY_KEY, AS_FLOWN_KEY, ROBUSTNESS_KEY)})
    return EvaluationSettings(engine=v.engine, scale=v.scale, d_max=v.d_max, feature_density=v.feature_density,
                              feature_seed=v.seed, metric=MetricParams(omega=v.omega, k=v.k, min_track=v.min_track,
                                                                       min_features=v.min_features))


def save_element_dates(path: Path, start, finish) -> None:
    import numpy as np

    with open(path, "wb") as fh:
        np.savez(fh, start=np.asarray(start, "datetime64[s]").astype(np.int64),
                 finish=np.asarray(finish, "datetime64[s]").astype(np.int64))


def load_element_dates(path: Path):
    """Start and finish per element (``datetime64[s]``, NaT where the schedule gives none)."""
    import numpy as np

    with np.load(path) as z:
        return z["start"].astype("datetime64[s]"), z["finish"].astype("datetime64[s]")


def element_states(start, finish, date: str, basis: str, unscheduled: str) -> list[str]:
    """Each element at the end of ``date``: built, in_progress (started, not finished) or not_yet; an element the
    schedule does not date is built or not_yet as ``unscheduled`` says (as :meth:`Scene.at` counts them)."""
    import numpy as np

    from ..model.dates import parse_day

    end = (parse_day(date) + np.timedelta64(1, "D")).astype("datetime64[s]")
    first, second = (finish, start) if basis == "finish" else (start, finish)
    when = np.where(np.isnat(first), second, first)
    dated = ~np.isnat(when)
    built = np.where(dated, when < end, unscheduled == "present")
    started = ~np.isnat(start) & (start < end)
    states = np.where(built, "built", np.where(dated & started, "in_progress", "not_yet"))
    return states.tolist()


def dated_scene(scene: Scene, dates_path: Path, fourd: dict[str, Any]) -> Scene:
    """The scene with its schedule's element dates, as it stands at ``fourd["date"]``."""
    start, finish = load_element_dates(dates_path)
    if len(start) != scene.n_elements:
        raise PlanError(f"the schedule's dates are for {len(start)} elements, the model has {scene.n_elements}")
    undated = replace(scene, elements=scene.elements.with_dates(start, finish))
    return undated.at(fourd["date"], basis=fourd.get("basis", "finish"), unscheduled=fourd.get("unscheduled", "present"))


FLIGHT_KEY = "flight"  # the flight settings a plan was made with, recorded in its parameters


def _aircraft(name: str):
    from ..plan.checks import battery

    presets = {**battery.AIRCRAFT, **battery.ROVERS}
    if name.lower() == "none":
        return None
    if name not in presets:
        raise PlanError(f"unknown aircraft {name!r}: use one of {', '.join(presets)} or 'none'")
    return presets[name]


def flight_record(body: TemplatePlanBase | OptimizeIn) -> dict[str, Any]:
    """The flight settings of a template request, with a drone's defaults or a walker's for a walked route."""
    walked = getattr(body, "template", "") in WALKED
    d = default_flight(walked)
    given = {"safety_distance_m": body.safety_distance_m, "vlos_radius_m": body.vlos_radius_m,
             "altitude_limit_m": body.altitude_limit_m, "aircraft": body.aircraft}
    if not walked:  # a walked route keeps no minimum height
        given["min_height_m"] = body.min_height_m
    record = {k: v if v is not None else d[k] for k, v in given.items()}
    _aircraft(record["aircraft"])  # an unknown preset is refused before anything is planned
    if body.position_error is not None and not walked:
        from ..plan.checks.safety import position_error

        record["position_error_m"] = list(position_error(body.position_error))  # a bad value is refused here too
    return record


def ground_stations(scene: Scene, points: list | None, geodetic: list | None) -> list[list[float]]:
    """The pilot stations of a request: its model points, then its latitude/longitude points placed on the
    model's ground by the model's georeference (a model with none is refused, naming what to do)."""
    out = [list(map(float, p)) for p in points or []]
    if geodetic:
        from ..geo import Georeference, GeoreferenceError
        from ..plan.ground import stations_from_geodetic

        geo = Georeference.from_scene_metadata(scene.metadata)
        if geo is None:
            raise GeoreferenceError("ground stations by latitude/longitude need a georeferenced model "
                                    "(IfcMapConversion, or IfcSite RefLatitude/RefLongitude): give them as x, y, z")
        out += stations_from_geodetic(scene, geo, geodetic).tolist()
    return out


def flight_settings(record: dict[str, Any], ground_stations=None, **overrides):
    """FlightSettings from a recorded flight (``flight_record``); ``overrides`` (not None) replace its values."""
    import numpy as np

    from ..plan.checks.feasibility import FlightSettings

    r = record | {k: v for k, v in overrides.items() if v is not None}
    stations = np.array(ground_stations, float) if ground_stations is not None and len(ground_stations) else None
    return FlightSettings(safety_distance_m=float(r["safety_distance_m"]), vlos_radius_m=r["vlos_radius_m"] or None,
                          ground_stations=stations, altitude_limit_m=r["altitude_limit_m"] or None,
                          aircraft=_aircraft(r["aircraft"]), min_height_m=r.get("min_height_m"),
                          position_error_m=r.get("position_error_m"))


def template_plan(scene: Scene, body: TemplatePlanBase) -> Plan:
    """A plan from a template around ``scene``, split into missions and checked as ``sightplan plan`` does
    (:func:`~sightplan.plan.templates.registry.plan_from_template`), with the flight it was made with recorded.
    ``body`` is one of the requests generated from the templates' declarations; its template fields become the
    template's parameters."""
    from ..camera.catalogue import get_camera

    name = body.template
    record = flight_record(body)
    fields = {f for f, _, _ in TEMPLATES[name].web_fields()}
    params = TEMPLATES[name].make({f: getattr(body, f) for f in fields})
    plan, _ = plan_from_template(name, scene, get_camera(body.camera), params,
                                 flight_settings(record, ground_stations(scene, body.ground_station,
                                                                         body.ground_station_geo)), split=body.split)
    return replace(plan, parameters={**plan.parameters, FLIGHT_KEY: record})


def read_uploaded_plan(path: Path, camera: str | None, scene: Scene | None) -> Plan:
    """A plan from an uploaded file in any format ``load_plan`` reads; flight-app missions are placed with the
    model's georeference, from their file's take-off reference (:func:`~sightplan.plan.load.scene_placement`)."""
    from ..plan.load import load_plan, scene_placement

    kwargs: dict[str, Any] = scene_placement(scene) if scene is not None else {}
    plan = load_plan(path, camera=camera or None, **kwargs)
    return with_site(plan, scene) if scene is not None else plan


def checked_plan_json(data: Any) -> Plan:
    """An edited plan JSON validated exactly as a plan file is read (``read_plan`` parses, then ``plan_from_dict``)."""
    from ..plan.format import plan_from_dict

    try:
        return plan_from_dict(data)
    except (TypeError, ValueError) as exc:
        raise PlanError(f"the plan is not valid JSON: {exc}") from None


def rebuilt_evaluation(result: Path, settings: dict[str, Any], metrics_json: dict[str, Any]) -> Evaluation:
    """A finished evaluation from its saved observations: the metrics are recomputed, nothing is cast."""
    from ..metrics import compute_metrics
    from ..observations.table import Observations

    obs = Observations.load(result / "observations.npz")
    ev_settings = evaluation_settings(settings)
    meta = json.loads((result / "report.json").read_text(encoding="utf-8"))
    return Evaluation(obs, compute_metrics(obs, ev_settings.metric), ev_settings, str(meta["parameters"]["engine"]),
                      int(metrics_json.get("features", obs.n_features)),
                      {k: v for k, v in (meta.get("timings") or {}).items() if v is not None},
                      int(meta.get("cache_hits", 0)))


def add_plan_version(storage: Storage, session: Session, plan_row: PlanRow, data: Plan, note: str) -> Path:
    """Write ``data`` as the next version of ``plan_row`` (added to ``session`` if new): its file and its row, not yet
    committed. The path written; on a failure here the file is removed. The caller commits, and removes the file
    should the commit fail."""
    from ..plan.format import write_plan

    path = storage.plan_path(storage.new_name(".json"))
    try:
        session.add(plan_row)
        session.flush()
        number = (session.scalar(select(func.max(PlanVersion.number)).where(PlanVersion.plan_id == plan_row.id))
                  or 0) + 1
        write_plan(data, path)
        session.add(PlanVersion(plan_id=plan_row.id, number=number, stored_name=path.name, frames=len(data),
                                missions=len(data.missions), note=note[:500]))
    except BaseException:
        path.unlink(missing_ok=True)
        raise
    return path
