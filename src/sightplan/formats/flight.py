"""Flight waypoints from a plan: the step every export shares (:func:`build_flight`), and what the writers share.

- Consecutive frames of one mission whose centres lie within 1 cm share one waypoint; each
  frame is one photo action there, in plan order.
- A photo's heading is the true heading (clockwise from true north, [0, 360)) of the frame's
  model heading (:func:`~sightplan.geometry.poses.gimbal_from_R`, converted with
  :meth:`~sightplan.geo.Georeference.true_heading`, so a georeference's north offset and grid
  convergence are included); its pitch is the gimbal pitch (up positive, −90 nadir). Drone
  gimbals keep the horizon level, so the flight formats refuse a roll beyond 1° and a pitch
  outside the format's range (its ``pitch_range``). A 360° (non-pinhole) camera has no gimbal: heading only, pitch 0.
- Take-off: each mission takes off from the ground under its own ground station
  (:attr:`Mission.ground_station`; see :func:`mission_takeoffs`); a mission without one, or every
  mission when ``per_mission_takeoff`` is False (a take-off point the user gave), from ``takeoff_m``.
- Heights: ``altitude_m`` is metres above the waypoint's mission's take-off point, the difference
  of the georeference heights of the waypoint and the take-off point (exactly z − z_takeoff for a
  projected georeference, within millimetres of it over a building site for a topocentric
  one); ``height_m`` is the absolute height in the georeference's vertical datum (above mean
  sea level: IfcSite's RefElevation or the map conversion's OrthogonalHeight). Writers that need
  WGS84 ellipsoidal heights add the EGM96 geoid undulation (:mod:`sightplan.geoid`).
- Footprints (the map formats): the four image-corner rays of a pinhole frame intersected with the
  horizontal plane at its mission's take-off height; a frame with a corner ray that does not reach it has
  none, and its waypoint lists it in ``footprint_skipped`` with the reason in ``footprint_note``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera.models import PinholeCamera
from ..errors import PlanError
from ..geo import Georeference
from ..geometry.poses import gimbal_from_R
from ..plan import domain
from ..plan.site import mission_takeoffs
from ..plan.types import Mission, Plan

SAME_POSITION_M = 0.01
ROLL_TOLERANCE_DEG = 1.0
FOOTPRINT_NOTE = ("no footprint for these frames: an image-corner ray does not reach the take-off plane "
                  "(or the camera is a 360° camera)")


@dataclass(frozen=True)
class Gimbal:
    """A gimbal's pitch slew rate and the time it needs to settle after reaching a new pitch: the writers size their
    waits after a change of pitch by it, and the replay (:mod:`sightplan.flight.simulate`) turns the gimbal by it."""

    rate_deg_s: float = 30.0
    settle_s: float = 0.5

    def wait_s(self, change_deg: float) -> float:
        """The time from a pitch command until the gimbal is still at its new pitch."""
        return abs(float(change_deg)) / self.rate_deg_s + self.settle_s


DEFAULT_GIMBAL = Gimbal()


@dataclass(frozen=True)
class Photo:
    """One photo action: plan frame ``frame`` taken with this true heading and gimbal pitch (degrees)."""

    frame: int
    name: str
    heading_deg: float
    pitch_deg: float
    roll_deg: float = 0.0


@dataclass(frozen=True)
class Waypoint:
    """Where the aircraft stops: position (model frame and WGS84), heights and the photos taken there.

    mission: index into :attr:`Flight.missions`. height_m: absolute, georeference datum.
    altitude_m: above the take-off point.
    """

    mission: int
    position_m: tuple[float, float, float]
    latitude_deg: float
    longitude_deg: float
    height_m: float
    altitude_m: float
    photos: tuple[Photo, ...]


@dataclass(frozen=True)
class Takeoff:
    """Where a mission takes off: model point, WGS84 latitude/longitude, height in the georeference's datum."""

    position_m: tuple[float, float, float]
    latitude_deg: float
    longitude_deg: float
    height_m: float


@dataclass(frozen=True)
class Flight:
    """A plan as flight waypoints, ready for a writer.

    takeoffs: one per mission (same order as ``missions``). ``takeoff_*``: the take-off of the first
    mission with waypoints (the only one where a flight holds a single mission).
    """

    plan: Plan
    georef: Georeference
    missions: tuple[Mission, ...]
    waypoints: tuple[Waypoint, ...]
    takeoff_m: tuple[float, float, float]
    takeoff_latitude_deg: float
    takeoff_longitude_deg: float
    takeoff_height_m: float
    speed_m_s: float
    fmt: str
    takeoffs: tuple[Takeoff, ...] = ()
    paths: tuple[tuple[float, float] | None, ...] = ()  # per mission: (climb, return) heights above its take-off

    def path_of(self, mission: int) -> tuple[float, float] | None:
        """(climb height, return height) in metres above mission index ``mission``'s take-off point, as the checks
        recorded them (:mod:`~sightplan.plan.trajectory`); None when the plan records none for that take-off."""
        return self.paths[mission] if 0 <= mission < len(self.paths) else None

    def takeoff_of(self, mission: int) -> Takeoff:
        """The take-off of mission index ``mission`` (the flight's own when none was recorded per mission)."""
        if 0 <= mission < len(self.takeoffs):
            return self.takeoffs[mission]
        return Takeoff(self.takeoff_m, self.takeoff_latitude_deg, self.takeoff_longitude_deg, self.takeoff_height_m)

    def by_mission(self) -> list[tuple[int, list[Waypoint]]]:
        """(mission number, 1-based as in the file names; its waypoints) for every mission with waypoints."""
        out: dict[int, list[Waypoint]] = {}
        for wp in self.waypoints:
            out.setdefault(wp.mission, []).append(wp)
        return [(m + 1, wps) for m, wps in sorted(out.items())]


def _frame_list(plan: Plan, idx: ArrayLike, limit: int = 5) -> str:
    idx = [int(i) for i in np.atleast_1d(idx)]
    names = ", ".join(str(plan.frame_names[i]) for i in idx[:limit])
    return names + (f" and {len(idx) - limit} more" if len(idx) > limit else "")


def wrap180(deg: float) -> float:
    """An angle in [−180, 180)."""
    return (float(deg) + 180.0) % 360.0 - 180.0


def same_angle(a: float, b: float, tol: float = 1e-6) -> bool:
    return abs(wrap180(a - b)) <= tol


def number_text(v: float, digits: int = 6) -> str:
    """``v`` with at most ``digits`` decimals, trailing zeros dropped ("0" for zero and minus zero)."""
    text = f"{float(v):.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def build_flight(plan: Plan, georef: Georeference, takeoff_m: ArrayLike, *, fmt: str, speed_m_s: float = 5.0,
                 mission: int | None = None, per_mission_takeoff: bool = True,
                 pitch_range: tuple[float, float] | None = None, label: str | None = None) -> Flight:
    """The plan's frames grouped into waypoints with photo actions; see the module docstring.

    mission: index (from 0) into ``plan.missions`` of the only mission to keep; file names number
    missions from 1 (``stem_m01``…). per_mission_takeoff: each mission takes off from its ground
    station (see :func:`mission_takeoffs`); False: all from ``takeoff_m``. pitch_range: the gimbal's
    (lowest, highest) pitch, e.g. the format's or a DJI aircraft's; None: any pitch and roll (a map).
    label: the format's name in messages (default ``fmt``).
    Raises :class:`PlanError` naming the frames a drone cannot take in format ``fmt``.
    """
    label = label or fmt
    if not isinstance(georef, Georeference):
        raise PlanError(f"a {label} export needs a Georeference, got {type(georef).__name__}")
    n = len(plan)
    if n == 0:
        raise PlanError("the plan has no frames to export")
    T = np.asarray(takeoff_m, float).reshape(-1)
    if T.shape != (3,) or not np.isfinite(T).all():
        raise PlanError(f"the take-off point must be three finite numbers (x, y, z) in the model frame, got {takeoff_m!r}")
    domain.speed("the flight speed", speed_m_s)
    missions = plan.missions or (Mission("mission 1", 0, n),)
    if mission is not None:
        if not (isinstance(mission, (int, np.integer)) and 0 <= mission < len(missions)):
            raise PlanError(f"mission index {mission!r} asked for; the plan has {len(missions)} mission(s), "
                            f"indices 0 to {len(missions) - 1}")
    keep = np.zeros(n, bool)
    mission_of = np.zeros(n, int)
    for k, m in enumerate(missions):
        mission_of[m.start:m.stop] = k
        if mission is None or k == mission:
            keep[m.start:m.stop] = True

    heading_m, pitch, roll = gimbal_from_R(plan.R_world_camera)
    pinhole = np.array([isinstance(plan.camera_of(i), PinholeCamera) for i in range(n)])
    pitch = np.where(pinhole, pitch, 0.0)
    roll = np.where(pinhole, roll, 0.0)
    if pitch_range is not None:
        bad = np.flatnonzero(keep & (np.abs(roll) > ROLL_TOLERANCE_DEG))
        if len(bad):
            raise PlanError(f"frame(s) {_frame_list(plan, bad)} have a camera roll of {roll[bad[0]]:+.1f}°: drone gimbals keep "
                            f"the horizon level (|roll| ≤ {ROLL_TOLERANCE_DEG:g}°), so {label} cannot fly them")
        lo, hi = pitch_range
        bad = np.flatnonzero(keep & ((pitch < lo - 1e-9) | (pitch > hi + 1e-9)))
        if len(bad):
            raise PlanError(f"frame(s) {_frame_list(plan, bad)} have a gimbal pitch of {pitch[bad[0]]:+.1f}°, outside "
                            f"{label}'s range {lo:g}° to {hi:+g}°")
    C = np.asarray(plan.C_world, float)
    true_heading = georef.true_heading(C, heading_m)
    lat, lon, h = georef.to_geodetic(C)
    starts = mission_takeoffs(plan, T, per_mission_takeoff)
    s_lat, s_lon, s_h = georef.to_geodetic(np.array(starts))
    takeoffs = tuple(Takeoff(tuple(float(v) for v in p), float(a), float(b), float(c))
                     for p, a, b, c in zip(starts, s_lat, s_lon, s_h))

    waypoints: list[Waypoint] = []
    current: list[int] = []

    def close() -> None:
        if not current:
            return
        i = current[0]
        photos = tuple(Photo(j, str(plan.frame_names[j]), float(true_heading[j]), float(pitch[j]), float(roll[j]))
                       for j in current)
        waypoints.append(Waypoint(int(mission_of[i]), tuple(float(v) for v in C[i]), float(lat[i]), float(lon[i]),
                                  float(h[i]), float(h[i] - takeoffs[mission_of[i]].height_m), photos))
        current.clear()

    for i in range(n):
        if not keep[i]:
            close()
            continue
        if current and (mission_of[i] != mission_of[current[0]]
                        or np.linalg.norm(C[i] - C[current[0]]) > SAME_POSITION_M):
            close()
        current.append(i)
    close()
    _check_finite(label, waypoints, takeoffs)
    paths = _recorded_paths(plan, missions, starts)
    first = takeoffs[waypoints[0].mission] if waypoints else Takeoff((float(T[0]), float(T[1]), float(T[2])),
                                                                     *(float(v[0]) for v in georef.to_geodetic(T)))
    return Flight(plan=plan, georef=georef, missions=tuple(missions), waypoints=tuple(waypoints),
                  takeoff_m=first.position_m, takeoff_latitude_deg=first.latitude_deg,
                  takeoff_longitude_deg=first.longitude_deg, takeoff_height_m=first.height_m, speed_m_s=float(speed_m_s),
                  fmt=fmt, takeoffs=takeoffs, paths=paths)


def _check_finite(label: str, waypoints: list[Waypoint], takeoffs: tuple[Takeoff, ...]) -> None:
    """Every number a writer will write is finite: a place the georeference cannot convert is refused, never written
    as ``nan``."""
    for t in takeoffs:
        domain.check_finite_output([t.latitude_deg, t.longitude_deg, t.height_m], f"a {label} export: a take-off point")
    for wp in waypoints:
        values = [wp.latitude_deg, wp.longitude_deg, wp.height_m, wp.altitude_m]
        values += [v for p in wp.photos for v in (p.heading_deg, p.pitch_deg, p.roll_deg)]
        name = wp.photos[0].name if wp.photos else "?"
        domain.check_finite_output(values, f"a {label} export: the waypoint of frame {name!r} at "
                                           f"{domain.point_text(wp.position_m)} cannot be placed on the earth")


def _recorded_paths(plan: Plan, missions: tuple[Mission, ...], starts: list) -> tuple[tuple[float, float] | None, ...]:
    """Each mission's recorded (climb, return) heights above its take-off point, where the plan records them for
    the take-off point the export uses (within 0.5 m)."""
    from ..plan.trajectory import recorded_paths

    rec = recorded_paths(plan.parameters)
    flown = [k for k, m in enumerate(missions) if m.stop > m.start]
    out: list[tuple[float, float] | None] = [None] * len(missions)
    if len(rec) != len(flown):
        return tuple(out)
    for k, r in zip(flown, rec):
        T = np.asarray(starts[k], float)
        if np.linalg.norm(np.asarray(r["takeoff_m"]) - T) <= 0.5:
            out[k] = (r["climb_z_m"] - float(T[2]), r["return_z_m"] - float(T[2]))
    return tuple(out)


def mission_paths(path: Path, numbers: list[int], *, several: bool) -> dict[int, Path]:
    """One output path per mission number: ``path`` itself, or ``stem_m01.ext``… when there are several."""
    if not several:
        return {numbers[0]: path} if numbers else {}
    return {m: path.with_name(f"{path.stem}_m{m:02d}{path.suffix}") for m in numbers}


def write_missions(flight: Flight, path: Path, text: Callable[[list[Waypoint]], str]) -> list[Path]:
    """One text file per mission of ``flight`` (:func:`mission_paths`), each the ``text`` of its waypoints."""
    groups = flight.by_mission()
    paths = mission_paths(path, [m for m, _ in groups], several=len(groups) > 1)
    for m, wps in groups:
        paths[m].write_text(text(wps), encoding="utf-8")
    return [paths[m] for m, _ in groups]


def footprint(plan: Plan, i: int, plane_z: float) -> NDArray[np.float64] | None:
    """(4, 3) model-frame corners where frame ``i``'s image-corner rays meet the plane z = ``plane_z``, in image
    order (top-left, top-right, bottom-right, bottom-left); None for a 360° camera or when a ray misses the plane."""
    cam = plan.camera_of(i)
    if not isinstance(cam, PinholeCamera):
        return None
    u = np.array([0.0, cam.width, cam.width, 0.0])
    v = np.array([0.0, 0.0, cam.height, cam.height])
    d_cam = np.stack([(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, np.ones(4)], axis=1)
    d = d_cam @ np.asarray(plan.R_world_camera[i]).T
    C = np.asarray(plan.C_world[i], float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (plane_z - C[2]) / d[:, 2]
    if not (np.isfinite(t).all() and (t > 0).all()):
        return None
    return C + t[:, None] * d


def footprints(flight: Flight, wp: Waypoint) -> tuple[list[tuple[str, np.ndarray]], list[str]]:
    """([(frame name, (5, 3) closed lon/lat/height ring, counter-clockwise)], [frame names without one]) of a
    waypoint's photos; heights in the georeference's datum."""
    rings, skipped = [], []
    plane_z = flight.takeoff_of(wp.mission).position_m[2]
    for photo in wp.photos:
        corners = footprint(flight.plan, photo.frame, plane_z)
        if corners is None:
            skipped.append(photo.name)
            continue
        lat, lon, h = flight.georef.to_geodetic(corners)
        ring = np.stack([lon, lat, h], axis=1)
        x, y = ring[:, 0], ring[:, 1]
        if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
            ring = ring[::-1]
        rings.append((photo.name, np.vstack([ring, ring[:1]])))
    return rings, skipped


def waypoint_properties(flight: Flight, number: int, index: int, wp: Waypoint) -> tuple[dict, list[tuple[str, np.ndarray]]]:
    """A waypoint's properties on a map (``kind`` "waypoint", the frames without a footprint noted) and its
    footprints (:func:`footprints`)."""
    rings, skipped = footprints(flight, wp)
    props = {"kind": "waypoint", "mission": flight.missions[wp.mission].name, "mission_number": number, "waypoint": index,
             "altitude_m": wp.altitude_m, "height_m": wp.height_m,
             "frames": [p.name for p in wp.photos], "heading_deg": [p.heading_deg for p in wp.photos],
             "pitch_deg": [p.pitch_deg for p in wp.photos]}
    if skipped:
        props.update({"footprint_skipped": skipped, "footprint_note": FOOTPRINT_NOTE})
    return props, rings
