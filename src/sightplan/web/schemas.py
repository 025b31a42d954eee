"""Request and response bodies of the REST API."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

JobStatus = Literal["queued", "running", "done", "failed"]


def _utc(value: dt.datetime) -> dt.datetime:
    """Times are stored in UTC; a database without time zones (SQLite) gives them back naive."""
    return value if value.tzinfo is not None else value.replace(tzinfo=dt.UTC)


Time = Annotated[dt.datetime, AfterValidator(_utc)]


class Orm(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class ErrorOut(BaseModel):
    detail: str = Field(description="One readable message")


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
    aircraft: dict[str, str] = Field(default_factory=dict, description="Aircraft and rover presets of the plan form: "
                                                                       "id → name")


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
    kind: Literal["load_model", "evaluate", "link_schedule", "prep_reality"]
    model_id: int | None
    evaluation_id: int | None
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


Point2 = Annotated[list[float], Field(min_length=2, max_length=2)]
Point3 = Annotated[list[float], Field(min_length=3, max_length=3)]


class TemplatePlanIn(BaseModel):
    """A plan from a template around one of the project's models (as ``sightplan plan``), split into missions and
    checked with the flight settings given (defaults: a drone's, or a walker's for a route)."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field("", max_length=200, description="Default: the template's name")
    model_id: int
    template: Literal["facade", "orbit", "lawnmower", "bridge", "route"]
    camera: str = Field("p4p", description="A camera of the catalogue (GET /api/cameras)")
    safety_distance: float | None = Field(None, description="facade and bridge: distance to the model (m); also the "
                                                            "flight check's least distance. Default 10, 0.3 for a route")
    overlap: float = Field(0.8, ge=0, le=0.95, description="Image overlap, 0 ≤ l ≤ 0.95 (as the page's form)")
    footprint: Literal["box", "outline"] = "box"
    radius: list[float] = Field(default_factory=list, description="orbit: ring radii (m), one per ring (default: the "
                                                                  "targets' half-diagonal + the safety distance)")
    height: list[float] = Field(default_factory=list, description="orbit: ring heights (m), one per ring (default: by "
                                                                  "overlap from the minimum height to the safety "
                                                                  "distance above the top); bridge: heights of the side "
                                                                  "passes (default: by overlap)")
    step: float | None = Field(None, ge=0.01, description="orbit: degrees between frames (default: by overlap); "
                                                          "route: metres between frames")
    aim: Literal["centre", "surface"] = "centre"
    altitude: float | None = Field(None, description="lawnmower: camera height above the model's base (m)")
    gsd: float | None = Field(None, description="lawnmower: ground sampling distance on the model's top (m/px)")
    side_overlap: float = Field(0.7, ge=0, le=0.95, description="lawnmower: overlap between lines")
    oblique_pitch: float | None = Field(None, description="lawnmower: add crossed lines at this gimbal pitch (°)")
    axis: list[Point2] = Field(default_factory=list, description="bridge: points [x, y] of the axis, in order")
    under_deck: bool = Field(True, description="bridge: add a pass under the deck, looking up")
    deck_z: float | None = Field(None, description="bridge: height of the deck's underside (default: found)")
    points: list[Point3] = Field(default_factory=list, description="route: points [x, y, z] of the walked polyline")
    aircraft: str | None = Field(None, description="Aircraft preset (p4p, m3e, m300), rover preset for a route "
                                                   "(walker-360, spot, tracked), or 'none' for no battery check. "
                                                   "Default p4p, walker-360 for a route")
    vlos_radius: float | None = Field(None, description="Visual line-of-sight radius around the pilot (m); 0: no check. "
                                                        "Default 500, none for a route")
    ground_station: list[Point3] = Field(default_factory=list, description="Pilot positions [x, y, z] to choose from "
                                                                           "(default: the corners of the plan's region)")
    altitude_limit: float | None = Field(None, description="Altitude limit (m); 0: no check. Default 120, none for a "
                                                           "route")
    min_height: float | None = Field(None, ge=0, description="Least height of a waypoint above the ground under it "
                                                             "(m). Default 2, none for a route")
    split: bool = Field(True, description="Split into missions that keep line of sight and fit a battery")


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

    model_config = ConfigDict(extra="forbid")

    engine: Literal["auto", "embree", "gl", "trimesh"] = "auto"
    scale: float = Field(1.0, gt=0, le=1, description="Resolution scale s")
    omega: float = Field(625.0, ge=0, description="Visibility threshold Ω (px)")
    k: int = Field(3, ge=1)
    min_track: int = Field(5, ge=1)
    min_features: int = Field(50, ge=0)
    feature_density: float = Field(1.0, ge=0, le=100, description="Simulated features per m² of surface")
    seed: int = Field(0, ge=0)
    d_max: float = Field(1000.0, gt=0, le=100_000, description="Farthest distance a frame sees (m)")


class EvaluationIn(BaseModel):
    model_config = ConfigDict(extra="forbid")

    plan_id: int
    version: int | None = Field(None, description="Default: the plan's latest version")
    model_id: int | None = Field(None, description="Default: the plan's model")
    settings: SettingsIn = Field(default_factory=SettingsIn)
    date: str | None = Field(None, description="Capture date YYYY-MM-DD: only the elements built by the end of it exist "
                                               "(needs a linked schedule)")
    schedule_id: int | None = Field(None, description="Schedule dating the elements (default: the model's latest)")
    date_basis: Literal["finish", "start"] = Field("finish", description="Which schedule date builds an element")
    unscheduled: Literal["present", "absent"] = Field("present", description="Elements no schedule dates")
    reality_id: int | None = Field(None, description="A reality capture of the site (scaffolding, neighbours, what "
                                                     "stands): it hides what is behind it, and is not scored")


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
    url: str = Field(description="Read-only address of the shared plan (no login needed)")


class SharedPlanOut(BaseModel):
    plan: PlanOut
    evaluations: list[EvaluationOut]


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
