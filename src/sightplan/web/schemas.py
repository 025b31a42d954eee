"""Request and response bodies of the REST API."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any, Literal, Union

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, create_model
from pydantic.json_schema import SkipJsonSchema

from ..plan.domain import (
    MAX_COORDINATE_M,
    MAX_COUNT,
    MAX_DISTANCE_M,
    MAX_HEIGHT_M,
)
from ..plan.templates.base import MAX_POINTS, ParamInfo, Template, unit_of
from ..plan.templates.registry import TEMPLATES
from .errors import MAX_ID

JobStatus = Literal["queued", "running", "done", "failed"]


def _utc(value: dt.datetime) -> dt.datetime:
    """Times are stored in UTC; a database without time zones (SQLite) gives them back naive."""
    return value if value.tzinfo is not None else value.replace(tzinfo=dt.UTC)


Time = Annotated[dt.datetime, AfterValidator(_utc)]


#: A database id: past a 64-bit integer it names nothing
Id = Annotated[int, Field(ge=-MAX_ID - 1, le=MAX_ID)]
#: Request bodies refuse NaN and infinities ("not a finite number"), whatever a field's bounds
STRICT = ConfigDict(extra="forbid", allow_inf_nan=False)


class Orm(BaseModel):
    model_config = ConfigDict(from_attributes=True)


def _no_default(schema: dict) -> None:
    schema.pop("default", None)


class ErrorOut(BaseModel):
    """Every error answer: one message, and with an export refused for its flight checks the violations."""

    detail: str = Field(description="One readable message")
    violations: list[str] | SkipJsonSchema[None] = Field(
        None, description="An export refused for its flight checks (409): each violation; absent otherwise",
        json_schema_extra=_no_default)


class BasemapOut(BaseModel):
    url: str = Field(description="XYZ tile URL template ({z}, {x}, {y} or {-y})")
    attribution: str = Field(description="The credit to show on the map")


class InfoOut(BaseModel):
    name: str = "sightplan"
    version: str
    mode: Literal["single-user", "team"] = "single-user"
    login: bool = Field(False, description="Whether requests need a login (never in single-user mode, always in team "
                                           "mode)")
    message: str
    database: str = Field(description="'embedded SQLite' or the database's dialect")
    data_dir: str
    max_upload_bytes: int
    templates: list[str]
    export_formats: list[str]
    export_format_help: dict[str, str] = Field(default_factory=dict, description="What each export format is for: "
                                                                                 "name → a few words (the page's menu)")
    metric_help: dict[str, dict[str, str]] = Field(default_factory=dict, description=(
        "What each metric means (label, unit, one sentence with the default thresholds): the page's labels"))
    aircraft: dict[str, str] = Field(default_factory=dict, description="Aircraft and rover presets of the plan form: "
                                                                       "id → name")
    basemap: BasemapOut | None = Field(None, description="The map's background tiles set by whoever runs the server; "
                                                         "none: a plain grid")


class ProjectIn(BaseModel):
    name: str = Field(min_length=1, max_length=200)


class ProjectOut(Orm):
    id: int
    name: str
    created_at: Time
    role: Literal["viewer", "editor", "owner"] | None = Field(None, description="Your role (team mode)")


class ModelOut(Orm):
    id: int
    project_id: int
    original_name: str = Field(description="The uploaded file's name, kept as metadata only")
    size_bytes: int
    status: Literal["queued", "loading", "ready", "failed"]
    error: str | None
    elements: int | None
    targets: int | None
    triangles: int | None
    skipped: int | None = Field(description="Products without usable geometry (see load_report)")
    georeferenced: bool | None
    created_at: Time


class ModelDetailOut(ModelOut):
    load_report: dict[str, Any] | None


class JobOut(Orm):
    id: int
    project_id: int
    kind: Literal["load_model", "evaluate", "link_schedule", "prep_reality", "optimize"]
    model_id: int | None
    evaluation_id: int | None
    plan_id: int | None = Field(None, description="The plan an optimisation made, once done")
    schedule_id: int | None = None
    reality_id: int | None = None
    status: JobStatus
    progress_done: float
    progress_total: float
    message: str
    error: str | None
    created_at: Time
    started_at: Time | None
    finished_at: Time | None


class ModelUploadOut(BaseModel):
    model: ModelOut
    job: JobOut


Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE_M, le=MAX_COORDINATE_M, allow_inf_nan=False)]
Point2 = Annotated[list[Coordinate], Field(min_length=2, max_length=2)]
Point3 = Annotated[list[Coordinate], Field(min_length=3, max_length=3)]
LatLon = Annotated[list[Annotated[float, Field(ge=-180, le=360, allow_inf_nan=False)]], Field(min_length=2, max_length=2)]


class FlightIn(BaseModel):
    """The flight settings a plan request (a template's, an optimisation's) is split and checked with (defaults: a
    drone's, or a walker's for a walked route)."""

    model_config = STRICT

    aircraft: str | None = Field(None, description="Aircraft preset (p4p, m3e, m300), rover preset for a route "
                                                   "(walker-360, spot, tracked), or 'none' for no battery check. "
                                                   "Default p4p, walker-360 for a route")
    vlos_radius_m: float | None = Field(None, ge=0, le=MAX_DISTANCE_M, description=(
        "Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route"))
    ground_station: list[Point3] = Field(default_factory=list, max_length=100, description=(
        "Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)"))
    ground_station_geo: list[LatLon] = Field(default_factory=list, max_length=100, description=(
        "Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's "
        "georeference, 1.5 m up; with ground_station, candidates to choose from"))
    position_error: str | None = Field(None, max_length=40, description=(
        "How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), "
        "'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. "
        "Default: the aircraft's"))
    altitude_limit_m: float | None = Field(None, ge=0, le=MAX_HEIGHT_M, description=(
        "Altitude limit (m); 0: no check. Default 120, none for a route"))
    min_height_m: float | None = Field(None, ge=0, le=MAX_HEIGHT_M, description=(
        "Least height of a waypoint above the ground under it (m). Default 2, none for a route"))


class TemplatePlanBase(FlightIn):
    """What every template request holds besides the template's own parameters: the model, the camera, and the
    flight settings the plan is split and checked with."""

    name: str = Field("", max_length=200, description="Default: the template's name")
    model_id: Id
    camera: str = Field("p4p", max_length=200, description="A camera of the catalogue (GET /api/cameras)")
    safety_distance_m: float | None = Field(None, gt=0, le=MAX_DISTANCE_M, description=(
        "Distance to the model the facade and bridge templates keep (m); also the flight check's least distance. "
        "Default 10, 0.3 for a route"))
    split: bool = Field(True, description="Split into missions that keep line of sight and fit a battery")


def _param_field(name: str, info: ParamInfo, default: Any) -> tuple[Any, Any]:
    """The request field of a template parameter: its type, bounds and description from its declaration."""
    unit = unit_of(name)
    about = info.help + (f" ({unit})" if unit else "")
    bounds = {k: v for k in ("ge", "gt", "le", "lt") if (v := getattr(info, k)) is not None}
    if info.kind == "choice":
        return Literal[info.choices], Field(default, description=about)  # type: ignore[valid-type]
    if info.kind == "flag":
        return bool, Field(default, description=about)
    if info.kind in ("points2", "points3"):
        point = Point2 if info.kind == "points2" else Point3
        return list[point], Field(default_factory=list, max_length=MAX_POINTS,
                                  description=f"points {'[x, y]' if point is Point2 else '[x, y, z]'} of {info.help}")
    if info.kind == "numbers":
        return list[Annotated[float, Field(**bounds)]], Field(default_factory=list, max_length=MAX_POINTS,
                                                              description=about)
    return (float if default is not None else float | None), Field(default, description=about, **bounds)


def _template_request(t: Template) -> type[BaseModel]:
    fields: dict[str, Any] = {"template": (Literal[t.name], Field(description=t.summary))}  # type: ignore[valid-type]
    for name, info, default in t.web_fields():
        fields[name] = _param_field(name, info, default)
    return create_model(f"{t.name.capitalize()}PlanIn", __base__=TemplatePlanBase,
                        __doc__=f"A plan from the {t.name} template ({t.summary}).", **fields)


#: A plan from a template around one of the project's models (as ``sightplan plan``): one request body per template,
#: told apart by ``template``, each generated from the template's parameter declaration
TEMPLATE_REQUESTS: dict[str, type[BaseModel]] = {n: _template_request(t) for n, t in TEMPLATES.items()}
TemplatePlanIn = Annotated[Union[tuple(TEMPLATE_REQUESTS.values())], Field(discriminator="template")]  # noqa: UP007


class TemplateFieldOut(BaseModel):
    name: str = Field(description="The request field (its unit in its name: _m, _deg, _m_px)")
    label: str
    kind: str = Field(description="number, numbers, choice, flag, points2 or points3")
    unit: str = Field(description="'m', '°', 'm/px' or ''")
    help: str
    default: Any = None
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    choices: list[str] = Field(default_factory=list)
    pair: str = Field("", description="Lists with the same pair name go together index by index, one row each (an "
                                      "orbit's ring: radius_m[i] with height_m[i]); '' for none")


class TemplateOut(BaseModel):
    name: str
    summary: str
    walked: bool = Field(description="Walked or driven indoors: no line of sight, altitude limit or minimum height")
    safety_distance_m: float = Field(description="The default least distance to the model (m)")
    fields: list[TemplateFieldOut]


class OptimizeIn(FlightIn):
    """An optimised plan around one of the project's models (as ``sightplan optimize``): the fewest views that give
    every target element k serving views (≥ Ω px, SSD and angle within bounds), within a budget, routed and checked."""

    name: str = Field("", max_length=200, description="Default: 'optimised (k = …)'")
    model_id: Id
    camera: str = Field("p4p", max_length=200, description="A perspective camera of the catalogue (GET /api/cameras)")
    safety_distance_m: float = Field(10.0, gt=0, le=1000, description="Least distance to the model (m)")
    k: int = Field(3, ge=1, le=50, description="Views each target element needs")
    max_ssd_m_px: float | None = Field(None, gt=0, le=1, description="Coarsest surface sampling distance a view may "
                                                                     "have (m/px); default: the camera's at the safety "
                                                                     "distance × 1.5")
    max_angle_deg: float = Field(45.0, gt=0, le=90, description="Widest angle to the surface (°)")
    budget_frames: int | None = Field(None, ge=1, le=100_000, description="At most this many frames")
    budget_minutes: float | None = Field(None, gt=0, le=10_000, description="At most this many minutes of flight")
    batteries: int | None = Field(None, ge=1, le=1000, description="At most this many battery charges")
    scale: float = Field(0.25, gt=0, le=1, description="Resolution scale the candidates are cast at")


class PlanVersionOut(Orm):
    number: int
    frames: int
    missions: int
    note: str
    created_at: Time


class PlanOut(Orm):
    id: int
    project_id: int
    model_id: int | None
    name: str
    source: str
    created_at: Time
    latest_version: int
    versions: list[PlanVersionOut]


class SettingsIn(BaseModel):
    """Evaluation settings (``sightplan evaluate``'s options of the same names)."""

    model_config = STRICT

    engine: Literal["auto", "embree", "gl", "trimesh"] = "auto"
    scale: float = Field(1.0, gt=0, le=1, description="Resolution scale s")
    omega: float = Field(625.0, ge=0, le=1e9, description="Visibility threshold Ω (px)")
    k: int = Field(3, ge=1, le=MAX_COUNT)
    min_track: int = Field(5, ge=1, le=MAX_COUNT)
    min_features: int = Field(50, ge=0, le=MAX_COUNT)
    feature_density: float = Field(1.0, ge=0, le=100, description="Simulated features per m² of surface")
    seed: int = Field(0, ge=0, le=2**32 - 1)
    d_max: float = Field(1000.0, gt=0, le=100_000, description="Farthest distance a frame sees (m)")


class EvaluationIn(BaseModel):
    model_config = STRICT

    plan_id: Id
    version: Id | None = Field(None, description="Default: the plan's latest version")
    model_id: Id | None = Field(None, description="Default: the plan's model")
    settings: SettingsIn = Field(default_factory=SettingsIn)
    date: str | None = Field(None, description="Capture date YYYY-MM-DD: only the elements built by the end of it exist "
                                               "(needs a linked schedule)")
    schedule_id: Id | None = Field(None, description="Schedule dating the elements (default: the model's latest)")
    date_basis: Literal["finish", "start"] = Field("finish", description="Which schedule date builds an element")
    unscheduled: Literal["present", "absent"] = Field("present", description="Elements no schedule dates")
    reality_id: Id | None = Field(None, description="A reality capture of the site (scaffolding, neighbours, what "
                                                     "stands): it hides what is behind it, and is not scored")
    as_flown: Literal["px4", "ardupilot"] | None = Field(None, description=(
        "Evaluate the photos where this autopilot takes them: the version's MAVLink export replayed under its rules "
        "(as `sightplan evaluate --as-flown`)"))
    position_error: str | None = Field(None, max_length=40, description=(
        "Also evaluate draws with every frame moved by a normal error whose 95 % bounds are 'H,V' metres (and ',YAW' "
        "degrees), or 'gnss' / 'rtk' (as `sightplan evaluate --position-error`): each metric's 5th-95th percentile "
        "band goes into metrics.robustness"))
    draws: int | None = Field(None, ge=2, le=256, description="With position_error: the number of draws (default 32)")


class EvaluationOut(Orm):
    id: int
    project_id: int
    plan_id: int
    plan_version: int
    model_id: int
    status: JobStatus
    progress_done: int
    progress_total: int
    settings: dict[str, Any]
    metrics: dict[str, Any] | None = Field(description="The plan metrics (as report.json's 'metrics') once done")
    error: str | None
    created_at: Time
    started_at: Time | None
    finished_at: Time | None


class EvaluationStartOut(BaseModel):
    evaluation: EvaluationOut
    job: JobOut


class ElementsOut(BaseModel):
    evaluation_id: int
    elements: list[dict[str, Any]] = Field(description="One row per target element, the columns of elements.csv")


class CameraOut(BaseModel):
    id: str
    name: str
    model: Literal["pinhole", "equirectangular"]
    width: int
    height: int


# --------------------------------------------------------------------------- accounts (team mode)
Role = Literal["viewer", "editor", "owner"]


class LoginIn(BaseModel):
    username: str = Field(max_length=64)
    password: str = Field(max_length=1024)


class UserOut(BaseModel):
    username: str
    projects: dict[int, Role] = Field(default_factory=dict, description="Your role in each project you belong to")


class PasswordIn(BaseModel):
    old_password: str = Field(max_length=1024)
    new_password: str = Field(max_length=1024)


class TokenIn(BaseModel):
    name: str = Field("", max_length=200, description="What the token is for")


class TokenOut(Orm):
    id: int
    name: str
    created_at: Time
    last_used_at: Time | None


class NewTokenOut(TokenOut):
    token: str = Field(description="The secret: shown once, send it as 'Authorization: Bearer <token>'")


class MemberIn(BaseModel):
    username: str = Field(max_length=64)
    role: Role


class RoleIn(BaseModel):
    role: Role


class MemberOut(BaseModel):
    user_id: int
    username: str
    role: Role


class ShareLinkOut(Orm):
    id: int
    plan_id: int
    created_at: Time
    revoked_at: Time | None


class NewShareLinkOut(ShareLinkOut):
    token: str = Field(description="The link's secret, shown once")
    url: str = Field(description="The share view: a read-only page of the plan (its model, map, metrics, feedback and "
                                 "checks), no login needed")
    api_url: str = Field(description="The same plan as JSON (GET), with its versions and evaluations below it")


class SharedPlanOut(BaseModel):
    plan: PlanOut
    evaluations: list[EvaluationOut]
    model: ModelOut | None = Field(None, description="The plan's model, if it has one")


# --------------------------------------------------------------------------- the viewer's data
class ElementTableOut(BaseModel):
    """A model's element table, one list per column, indexed by element."""

    model_id: int
    count: int = Field(description="Number of elements")
    global_id: list[str]
    name: list[str]
    ifc_class: list[str]
    discipline: list[str]
    storey: list[str]
    target: list[bool] = Field(description="Whether the element counts in the metrics (else an occluder)")
    triangles: list[int] = Field(description="Triangles of each element")


class MissionGeometryOut(BaseModel):
    name: str
    start: int = Field(description="First frame (index)")
    stop: int = Field(description="One past the last frame")
    ground_station: list[float] | None = Field(description="Pilot position [x, y, z] (model frame, m), if chosen")


class LatLonFitOut(BaseModel):
    """lat, lon = origin_lat_lon + matrix · ([x, y] − origin_xy), within max_error_m of the exact transform."""

    origin_xy: list[float] = Field(description="Model x, y (m) the fit is centred on")
    origin_lat_lon: list[float] = Field(description="Latitude, longitude (°) there")
    matrix: list[list[float]] = Field(description="[[dlat/dx, dlat/dy], [dlon/dx, dlon/dy]] (° per m)")
    max_error_m: float = Field(description="Largest distance between the fit and the exact transform over the site (m)")


class ProjectBasemapOut(BaseModel):
    """A project's own map background."""

    kind: Literal["image", "tiles"] = Field(description="image: an orthomosaic stretched over its corners; tiles: "
                                                        "MBTiles served tile by tile")
    name: str = Field(description="The uploaded file's name (or the MBTiles' own)")
    url: str = Field(description="The image, or the tile URL template ({z}/{x}/{y})")
    corners: list[list[float]] | None = Field(None, description="image: [lon, lat] of its top-left, top-right, "
                                                                "bottom-right and bottom-left corners")
    width_px: int | None = Field(None, description="image: the orthomosaic's width (px)")
    height_px: int | None = Field(None, description="image: the orthomosaic's height (px)")
    bounds: list[float] | None = Field(None, description="tiles: [west, south, east, north] (°), when the file says")
    min_zoom: int | None = None
    max_zoom: int | None = None
    format: str | None = Field(None, description="tiles: png, jpg or webp")
    attribution: str = ""


class ProjectBackgroundOut(BaseModel):
    basemap: ProjectBasemapOut | None = Field(description="The project's own map background; null when it has none")


class SiteOut(BaseModel):
    """Where a model stands on the earth, for the map."""

    model_id: int
    georeferenced: bool = Field(description="Whether the model carries its own georeference; if not, the map is "
                                            "drawn about 0° N 0° E with model +Y as north")
    source: str = Field(description="Where the georeference comes from (IfcMapConversion, the site's latitude)")
    note: str = Field(description="Why the model counts as not georeferenced, if it does")
    centre_lat_lon: list[float] = Field(description="Latitude, longitude (°) of the model's centre")
    north_offset_deg: float = Field(description="True heading of model +Y at the centre (°)")
    bounds: list[list[float]] = Field(description="The model's [min, max] corners, model frame (m)")
    footprint_xy: list[list[list[float]]] = Field(description="Outer rings of the footprint, [x, y] (m), closed")
    footprint_lat_lon: list[list[list[float]]] = Field(description="The same rings as [latitude, longitude] (°)")
    to_lat_lon: LatLonFitOut


class PlanGeometryOut(BaseModel):
    """A plan version's frames and missions, in the model's frame (metres, Z up)."""

    plan_id: int
    version: int
    frames: int = Field(description="Number of frames")
    model_id: int | None
    name: list[str] = Field(description="Frame names")
    camera: list[str] = Field(description="Each frame's camera id (a key of `cameras`)")
    position: list[list[float]] = Field(description="Camera centres [x, y, z] (m)")
    rotation: list[list[float]] = Field(description="R_world_camera per frame, row-major (9 numbers): columns are "
                                                    "the camera's right, down and forward axes")
    cameras: dict[str, dict[str, Any]] = Field(description="Camera models by id, with hfov_deg and vfov_deg for a "
                                                           "pinhole")
    missions: list[MissionGeometryOut]
    waypoints: list[list[float]] = Field(description="Flight waypoints [x, y, z] (m), when they differ from frames")
    parameters: dict[str, Any] = Field(description="The plan's parameters (template settings, checks, take-off)")
    north_offset_deg: float | None = Field(None, description=(
        "Degrees to add to a model heading (clockwise from model +Y) to get the true heading, at the frames' centre, "
        "from the plan's georeference (map grid convergence included); null without one"))


class FlightChecksOut(BaseModel):
    """The flight checks of a plan version's missions as they are, for drawing."""

    plan_id: int
    version: int
    model_id: int
    ok: bool = Field(description="Every check passed")
    safety_distance_m: float
    vlos_radius_m: float | None
    total_time_s: float | None = Field(description="Flight time of all missions (s)")
    clearance_m: list[float | None] = Field(description="Each waypoint's distance to the model (m)")
    segment_clearance_m: list[float | None] = Field(description="Each leg's distance to the model (m)")
    unsafe_frames: list[int] = Field(description="Waypoints closer than the safety distance")
    unsafe_segments: list[int] = Field(description="Legs closer than the safety distance")
    in_sight: list[bool] = Field(description="Each waypoint within the VLOS radius of its mission's ground station")
    missions: list[dict[str, Any]] = Field(description="Per mission: ground station, time, distance and verdicts, "
                                                       "as `sightplan check --json`")
    violations: list[str] = Field(description="Every violation, one sentence each")
    ground: dict[str, Any] | None = Field(None, description="The site's ground the checks used: its level (model "
                                                            "frame, m), where it comes from and why")
    position_error_m: list[float] = Field(default_factory=list, description="The position error the checks hold at: "
                                                                            "horizontal, vertical (m)")
    trajectory: list[dict[str, Any]] = Field(default_factory=list, description=(
        "Per mission: its take-off point, climb and return heights, and the checked flight out (take-off, climb, "
        "over the first waypoint, the first waypoint) and home (the last waypoint, up, over the take-off, "
        "landing) as [x, y, z] polylines (model frame, m)"))


# --------------------------------------------------------------------------- plan files, evaluations' feedback
class PlanCameraOut(BaseModel):
    model: Literal["pinhole", "equirectangular"]
    name: str = ""
    width: int = Field(description="Image width (px)")
    height: int = Field(description="Image height (px)")
    fx: float | None = Field(None, description="Focal length (px), pinhole only")
    fy: float | None = Field(None, description="Focal length (px), pinhole only")
    cx: float | None = Field(None, description="Principal point (px), pinhole only")
    cy: float | None = Field(None, description="Principal point (px), pinhole only")


class PlanFrameOut(BaseModel):
    name: str
    camera: str = Field(description="Id of the frame's camera in 'cameras'")
    position: list[float] = Field(description="Camera centre [x, y, z] (model frame, m)")
    rotation: list[list[float]] = Field(description="World-from-camera rotation, 3 × 3, OpenCV camera axes")
    time: float | None = Field(None, description="Capture time (s, POSIX), when known")


class PlanMissionOut(BaseModel):
    name: str
    frames: list[int] = Field(description="[start, stop): the mission's frames")
    ground_station: list[float] | None = Field(None, description="Pilot position [x, y, z] (model frame, m)")


class PlanFileOut(BaseModel):
    """A plan in sightplan's JSON plan format, version 1 (as ``sightplan plan`` writes it)."""

    model_config = ConfigDict(extra="allow")

    format: str
    version: int
    units: Literal["m"]
    frame_convention: str
    cameras: dict[str, PlanCameraOut]
    missions: list[PlanMissionOut]
    frames: list[PlanFrameOut]
    waypoints: list[list[float]] = Field(description="Flight waypoints [x, y, z] (model frame, m)")
    parameters: dict[str, Any] = Field(description="The template's settings, the checks, the take-off point; keys "
                                                   "carry their unit")
    georeference: dict[str, Any] | None = None


class MetricLabelOut(BaseModel):
    label: str
    unit: str
    higher_better: bool
    bounds: list[float] | None = Field(description="Default colour bounds [low, high] in the metric's unit")
    classes: list[str] | None = None


class FeedbackElementsOut(BaseModel):
    global_id: list[str]
    name: list[str]
    ifc_class: list[str]
    storey: list[str]
    target: list[bool]


class FeedbackMetricsOut(BaseModel):
    visibility: list[int] = Field(description="0 visible (≥ Ω px), 1 observed only, 2 unseen, 3 occluder")
    vr: list[int | None] = Field(description="VR_i: frames that see the element by ≥ Ω px")
    ssd: list[float | None] = Field(description="R_i: surface sampling distance (m/px)")
    orientation: list[float | None] = Field(description="O_i: mean angle to the surface (°)")
    frames_observed: list[int]
    pixels_total: list[float | None] = Field(description="Pixels on the element over all frames")


class FeedbackColoursOut(BaseModel):
    gradient: list[str] = Field(description="Traffic-light gradient, worst to best, as #rrggbb")
    unseen: str
    occluder: str
    classes: list[str]
    gradient_rgb: list[list[float]] = Field(description="The same colours as sRGB floats 0–1")
    unseen_rgb: list[float]
    occluder_rgb: list[float]
    classes_rgb: list[list[float]]


class FeedbackFramesOut(BaseModel):
    name: list[str]
    nu: list[float] = Field(description="ν_f: the frame's stability (share of its features on stable tracks)")
    stable: list[bool] = Field(description="ν_f ≥ Λ")
    features_observed: list[int]
    elements_visible: list[int]
    pixels_on_targets: list[float | None]


class FeedbackParamsOut(BaseModel):
    omega: float = Field(description="Visibility threshold Ω (px)")
    k: int
    min_track: int
    min_features: int


class FeedbackMissionOut(BaseModel):
    name: str
    start: int
    stop: int


class FeedbackOut(BaseModel):
    """Everything the viewer colours from: per-element and per-frame values of an evaluation."""

    colour_by: str
    elements: FeedbackElementsOut
    metrics: FeedbackMetricsOut
    labels: dict[str, MetricLabelOut] = Field(description="Per colour metric: label, unit, direction, bounds")
    colours: FeedbackColoursOut
    cameras: list[list[float]] = Field(description="Camera centres in the viewer's frame (Y up, m)")
    frames: FeedbackFramesOut
    params: FeedbackParamsOut
    metric_help: dict[str, dict[str, str]] = Field(default_factory=dict, description=(
        "What each metric means with this evaluation's thresholds (Ω, k, Y, Λ): label, unit and one sentence"))
    plan_metrics: dict[str, Any] | None = Field(description="The plan metrics, as report.json's 'metrics'")
    missions: list[FeedbackMissionOut]
    evaluation_id: int
    plan_id: int
    plan_version: int
    model_id: int | None


class ElementRowOut(BaseModel):
    """An element's row of the per-element metrics (the columns of elements.csv); null values for an occluder."""

    model_config = ConfigDict(extra="allow")

    index: int
    global_id: str
    name: str
    ifc_class: str
    storey: str
    visibility: str
    VR_i: int | None
    R_i_m_per_px: float | None
    O_i_deg: float | None
    frames_observed: int | None
    pixels_total: float | None


class BestFrameOut(BaseModel):
    frame: int
    name: str
    pixels: float = Field(description="Pixels of the element in the frame")
    ssd_m_per_px: float
    angle_deg: float
    depth_m: float
    counts: bool = Field(description="Whether the frame sees the element by ≥ Ω px")


class ElementDetailOut(BaseModel):
    evaluation_id: int
    element: ElementRowOut
    target: bool
    omega_px: float
    best_frames: list[BestFrameOut]
