"""Can the plan be flown? Safety distance, visual line of sight, altitude and battery, per waypoint and per mission.

:func:`plan_flights` splits a plan into flyable missions: first where the pilot must move
to keep visual line of sight (each mission gets the candidate ground station that sees
the longest run of its waypoints), then where a battery runs out (the resume waypoint is
the first of the next mission). :func:`check_plan` only checks the missions as they are.
Both return a :class:`FeasibilityReport`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ...errors import PlanError
from ...model.scene import Scene
from .. import domain
from ..ground import (
    GROUND_STATION_HEIGHT_M,
    MIN_HEIGHT_M,
    Ground,
    ground_of,
    ground_z,
    has_terrain,
    targets_only,
    without_terrain,
)
from ..types import Mission, Plan
from .airspace import FAA_LIMIT_M, AltitudeReport, check_altitude, sight_lines
from .battery import AIRCRAFT, Aircraft, Rover, mission_time, split_by_battery, split_by_rover
from .safety import (
    CHECK_TOLERANCE_M,
    POSITION_ERROR,
    SafetyReport,
    check_safety,
    position_error,
    worst_segment_clearance,
)


@dataclass(frozen=True)
class FlightSettings:
    """safety_distance_m: least distance to the model; vlos_radius_m: how far the pilot may see the
    aircraft (None: no line-of-sight check, e.g. indoors); ground_stations: (k, 3) candidate pilot
    positions (None: the four corners of the plan's region, the first being the south-west one);
    altitude_limit_m: FAA §107.51 limit (None: no check); aircraft: battery model of a drone, or of a
    ground rover or walker (:class:`Rover`: no return leg, it resumes where it stopped), None: no battery check;
    min_height_m: least height of every waypoint and leg above the ground under it (the terrain, else the
    model's base; None: no check, and none for a rover). The safety distance applies to everything but the
    terrain, which has the minimum height instead. position_error_m: (horizontal, vertical) metres the aircraft
    may stray from its planned point (:data:`~.safety.POSITION_ERROR`); None: the aircraft's own (``rtk`` or
    ``gnss``), none for a rover or walker. The safety, minimum-height and altitude checks hold at its worst."""

    safety_distance_m: float = 5.0
    vlos_radius_m: float | None = 500.0
    ground_stations: NDArray[np.float64] | None = None
    altitude_limit_m: float | None = FAA_LIMIT_M
    aircraft: Aircraft | Rover | None = field(default_factory=lambda: AIRCRAFT["p4p"])
    min_height_m: float | None = MIN_HEIGHT_M
    position_error_m: tuple[float, float] | None = None

    @property
    def error(self) -> tuple[float, float]:
        """(h, v) position error in force: the one given, else the aircraft's (none for a rover or walker)."""
        if self.position_error_m is not None:
            return position_error(self.position_error_m)
        if isinstance(self.aircraft, Rover):
            return POSITION_ERROR["none"]
        return POSITION_ERROR["rtk" if getattr(self.aircraft, "rtk", False) else "gnss"]

    def __post_init__(self) -> None:
        if self.position_error_m is not None:
            object.__setattr__(self, "position_error_m", position_error(self.position_error_m))
        domain.distance("the safety distance", self.safety_distance_m, positive=True)
        if self.vlos_radius_m is not None:
            domain.distance("the VLOS radius", self.vlos_radius_m, positive=True)
            if self.safety_distance_m >= self.vlos_radius_m:
                raise PlanError(f"the safety distance ({self.safety_distance_m:g} m) is not less than the VLOS radius "
                                f"({self.vlos_radius_m:g} m): no waypoint could be both safe and in sight. "
                                "Lower --safety-distance or raise --vlos-radius")
        if self.ground_stations is not None:
            gs = np.asarray(self.ground_stations, float)
            if gs.ndim != 2 or gs.shape[1] != 3 or not len(gs) or not np.isfinite(gs).all():
                raise PlanError("ground stations must be finite (x, y, z) points")
            domain.check_points(gs, lambda i: f"ground station {i + 1}", "position")
        if self.altitude_limit_m is not None:
            domain.number("the altitude limit", self.altitude_limit_m, 0.0, domain.MAX_HEIGHT_M, "m", lo_open=True)
        if self.min_height_m is not None:
            domain.number("the minimum height", self.min_height_m, 0.0, domain.MAX_HEIGHT_M, "m")


@dataclass(frozen=True)
class MissionReport:
    """One flight: frames ``start`` (its resume waypoint) to ``stop``; ``time_s``/``distance_m`` from
    and back to ``ground_station`` (None without an aircraft); each check's verdict."""

    name: str
    start: int
    stop: int
    ground_station: NDArray[np.float64]
    time_s: float | None
    distance_m: float | None
    battery_ok: bool | None
    line_of_sight_ok: bool | None
    safety_ok: bool
    altitude_ok: bool | None
    height_ok: bool | None = None

    @property
    def ok(self) -> bool:
        return self.safety_ok and all(v is not False for v in (self.battery_ok, self.line_of_sight_ok, self.altitude_ok,
                                                               self.height_ok))


@dataclass(frozen=True)
class FeasibilityReport:
    """The plan (split when made by :func:`plan_flights`), one :class:`MissionReport` per mission,
    per-waypoint results ((n,) arrays, NaN/True where a check did not run) and every violation.
    height_above_ground_m: (n,) each waypoint's height above the ground under it (None without the check).
    batteries: how many charges the missions take, flown in order: short flights (from different ground
    stations) share a battery while their times add up to one battery's usable time; one per part for a rover;
    None without an aircraft."""

    plan: Plan
    missions: tuple[MissionReport, ...]
    safety: SafetyReport
    station_distance_m: NDArray[np.float64]
    in_sight: NDArray[np.bool_]
    altitude: AltitudeReport | None
    violations: tuple[str, ...]
    height_above_ground_m: NDArray[np.float64] | None = None
    batteries: int | None = None
    ground: Ground | None = None
    paths: tuple = ()  # one MissionPath per mission with waypoints: take-off, climb, return, landing
    error_m: tuple[float, float] = (0.0, 0.0)

    @property
    def ok(self) -> bool:
        return not self.violations

    @property
    def total_time_s(self) -> float | None:
        times = [m.time_s for m in self.missions]
        return None if any(t is None for t in times) else float(sum(times))

    def to_dict(self) -> dict:
        """A JSON-ready summary: missions, per-waypoint distances and the violations."""
        def num(v):
            return None if v is None or not np.isfinite(v) else round(float(v), 3)

        return {
            "ok": self.ok,
            "frames": len(self.plan),
            "total_time_s": num(self.total_time_s),
            "batteries": self.batteries,
            "missions": [{"name": m.name, "frames": [m.start, m.stop], "resume_waypoint": m.start,
                          "ground_station": [round(float(v), 3) for v in m.ground_station], "time_s": num(m.time_s),
                          "distance_m": num(m.distance_m), "battery_ok": m.battery_ok,
                          "line_of_sight_ok": m.line_of_sight_ok, "safety_ok": m.safety_ok,
                          "altitude_ok": m.altitude_ok, "height_ok": m.height_ok} for m in self.missions],
            "waypoints": [{"frame": i, "name": str(self.plan.frame_names[i]), "clearance_m": num(self.safety.waypoint_m[i]),
                           "station_distance_m": num(self.station_distance_m[i]), "in_sight": bool(self.in_sight[i]),
                           "over_altitude_limit_m": num(self.altitude.over_m[i]) if self.altitude else None,
                           "height_above_ground_m": None if self.height_above_ground_m is None
                           else num(self.height_above_ground_m[i])}
                          for i in range(len(self.plan))],
            "ground": None if self.ground is None else self.ground.to_dict(),
            "position_error_m": list(self.error_m),
            "trajectory": [p.to_dict() for p in self.paths],
            "violations": list(self.violations),
        }


STATION_STEP_M = 2.0  # a corner station too near the model moves away from the model's centre by this much…
STATION_STEPS = 100  # …up to this many times


def corner_stations(scene: Scene, plan: Plan, height_m: float = GROUND_STATION_HEIGHT_M, safety_m: float = 0.0,
                    error_m: tuple[float, float] = (0.0, 0.0), obstacles: Scene | None = None) -> NDArray[np.float64]:
    """(4, 3) pilot stations near the corners of the plan's region (its waypoints and the model's targets),
    south-west first, then south-east, north-east, north-west, ``height_m`` above the ground at each.

    With ``safety_m``, each is a place a pilot can take off from: a corner whose vertical climb, from the ground to
    the safety distance above the plan's highest waypoint and the model's top, comes nearer the model (terrain
    aside) than ``safety_m`` at the worst of the position error (a corner on a roof, inside the footprint, by a
    wall) moves away from the model's centre, :data:`STATION_STEP_M` at a time, until its climb is clear.
    ``obstacles``: the scene less its terrain, when the caller has it already."""
    box = targets_only(scene).bounds()
    lo = np.minimum(plan.C_world.min(axis=0), box[0])
    hi = np.maximum(plan.C_world.max(axis=0), box[1])
    xy = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    if safety_m > 0:
        obstacles = without_terrain(scene) if obstacles is None else obstacles
        top = max(float(plan.C_world[:, 2].max()), float(obstacles.bounds()[1][2])) + safety_m + error_m[1]
        centre = (box[0][:2] + box[1][:2]) / 2
        away = xy - centre
        away /= np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-9)
        k = np.arange(STATION_STEPS + 1)
        cand = (xy[:, None, :] + STATION_STEP_M * k[None, :, None] * away[:, None, :]).reshape(-1, 2)
        g = ground_z(scene, cand)
        bottom, up = np.column_stack([cand, g]), np.column_stack([cand, np.maximum(g, top)])
        ok = (worst_segment_clearance(obstacles, bottom, up, error_m) >= safety_m - CHECK_TOLERANCE_M).reshape(4, -1)
        first = np.where(ok.any(axis=1), ok.argmax(axis=1), 0)
        xy = cand.reshape(4, -1, 2)[np.arange(4), first]
    return np.column_stack([xy, ground_z(scene, xy) + height_m])


def _stations(scene: Scene, plan: Plan, settings: FlightSettings, obstacles: Scene | None = None) -> NDArray[np.float64]:
    if settings.ground_stations is not None:
        return np.asarray(settings.ground_stations, float).reshape(-1, 3)
    return corner_stations(scene, plan, safety_m=settings.safety_distance_m, error_m=settings.error, obstacles=obstacles)


def _visible(scene: Scene, plan: Plan, stations: NDArray, radius: float) -> NDArray[np.bool_]:
    """(k, n) waypoint j within ``radius`` of station i and not hidden from it by the model."""
    _, in_range, unblocked = sight_lines(scene, plan.C_world, stations, radius)
    return in_range & unblocked


def split_by_line_of_sight(scene: Scene, plan: Plan, radius_m: float, stations: NDArray) -> Plan:
    """Each mission cut, in flight order, into runs that one ground station sees whole.

    From the first waypoint not yet flown, the station that sees the longest run from there
    takes that run (ties: the first station). A waypoint no station sees goes with the station
    nearest to it, and :func:`check_plan` reports it.
    """
    stations = np.asarray(stations, float).reshape(-1, 3)
    vis = _visible(scene, plan, stations, radius_m)
    unseen = np.flatnonzero(~vis.any(axis=0))
    if len(unseen):
        nearest = np.linalg.norm(plan.C_world[unseen, None, :] - stations[None], axis=2).argmin(axis=1)
        vis[nearest, unseen] = True
    missions = []
    for m in plan.missions:
        start, parts = m.start, []
        while start < m.stop:
            blocked = ~vis[:, start:m.stop]
            run = np.where(blocked.any(axis=1), blocked.argmax(axis=1), m.stop - start)  # seen in a row from start
            best = int(np.argmax(run))
            parts.append((start, start + int(run[best]), tuple(map(float, stations[best]))))
            start += int(run[best])
        for k, (a, b, gs) in enumerate(parts):
            missions.append(Mission(m.name if len(parts) == 1 else f"{m.name} ({k + 1})", a, b, gs))
    return replace(plan, missions=tuple(missions))


def merge_single_frames(plan: Plan, obstacles: Scene | None = None, safety_distance_m: float | None = None,
                        error_m: tuple[float, float] = (0.0, 0.0)) -> Plan:
    """Each one-frame mission joined to the mission before it (else after it) when that one has the same ground
    station: flying on to one more waypoint needs no flight of its own. The joined mission keeps the other's name.
    With ``obstacles``, only where the leg that joins them keeps ``safety_distance_m`` from them at the worst of the
    position error ``error_m`` (h, v), as :func:`~.safety.check_safety` will measure it: a leg a router cut for
    passing too near is not joined again."""
    missions = list(plan.missions)

    def safe(a: int, b: int) -> bool:
        if obstacles is None or safety_distance_m is None:
            return True
        leg = worst_segment_clearance(obstacles, plan.C_world[a:a + 1], plan.C_world[b:b + 1], error_m)
        return bool(leg[0] >= safety_distance_m - CHECK_TOLERANCE_M)

    k = 0
    while k < len(missions):
        m = missions[k]
        if m.stop - m.start == 1 and m.ground_station is not None:
            for j in (k - 1, k + 1):
                if (0 <= j < len(missions) and missions[j].ground_station == m.ground_station
                        and safe(*((missions[j].stop - 1, m.start) if j < k else (m.start, missions[j].start)))):
                    o = missions[j]
                    missions[min(j, k)] = Mission(o.name, min(o.start, m.start), max(o.stop, m.stop), o.ground_station)
                    del missions[max(j, k)]
                    k = max(min(j, k) - 1, 0)
                    break
            else:
                k += 1
        else:
            k += 1
    return plan if len(missions) == len(plan.missions) else replace(plan, missions=tuple(missions))


def _split_battery(plan: Plan, default_station: NDArray, aircraft: Aircraft) -> Plan:
    """Battery split of each mission from its own ground station (the default one where it has none)."""
    out = []
    for m in plan.missions:
        gs = np.asarray(m.ground_station if m.ground_station is not None else default_station, float)
        sub = replace(plan.subset(np.arange(m.start, m.stop)), missions=(Mission(m.name, 0, m.stop - m.start),))
        split, _ = split_by_battery(sub, gs, aircraft)
        out.extend(Mission(p.name, m.start + p.start, m.start + p.stop, tuple(map(float, gs))) for p in split.missions)
    return replace(plan, missions=tuple(out))


def _continues(before: str, name: str) -> bool:
    """Whether mission ``name`` is the battery part that follows ``before`` on the same route."""
    a, b = re.fullmatch(r"(.*) \((\d+)\)", before), re.fullmatch(r"(.*) \((\d+)\)", name)
    return bool(a and b and a.group(1) == b.group(1) and int(b.group(2)) == int(a.group(2)) + 1)


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Half-open index ranges of the True runs of ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def _span(a: int, b: int) -> str:
    return f"waypoint {a} is" if b == a + 1 else f"waypoints {a}–{b - 1} are"


def plan_flights(scene: Scene, plan: Plan, settings: FlightSettings) -> FeasibilityReport:
    """Split ``plan`` into missions that keep line of sight and fit a battery, then check it."""
    stations = _stations(scene, plan, settings)
    if settings.vlos_radius_m is not None:
        plan = merge_single_frames(split_by_line_of_sight(scene, plan, settings.vlos_radius_m, stations),
                                   without_terrain(scene), settings.safety_distance_m, settings.error)
    if isinstance(settings.aircraft, Rover):
        plan = split_by_rover(plan, settings.aircraft)[0]
    elif settings.aircraft is not None:
        plan = _split_battery(plan, stations[0], settings.aircraft)
    return check_plan(scene, plan, settings)


def check_plan(scene: Scene, plan: Plan, settings: FlightSettings) -> FeasibilityReport:
    """Every check on ``plan``'s missions as they are; a mission without a ground station uses the first candidate."""
    if len(plan) == 0:
        raise PlanError("the plan has no frames to check")
    error = settings.error
    obstacles = without_terrain(scene)
    # the first candidate station, only for the missions that record none (finding it measures many climbs)
    default = _stations(scene, plan, settings, obstacles)[0] if any(m.ground_station is None for m in plan.missions) \
        else None
    station_of = [np.asarray(m.ground_station if m.ground_station is not None else default, float) for m in plan.missions]
    safety = check_safety(obstacles, plan, settings.safety_distance_m, error)
    violations = list(safety.violations)
    dist = np.full(len(plan), np.nan)
    in_sight = np.ones(len(plan), bool)
    los_ok: list[bool | None] = [None] * len(plan.missions)
    if settings.vlos_radius_m is not None and plan.missions:
        # each waypoint against its own mission's station: one engine for every sight line
        gs_of = np.concatenate([np.repeat(station_of[k][None], m.stop - m.start, axis=0) for k, m in enumerate(plan.missions)])
        stations, which = np.unique(gs_of, axis=0, return_inverse=True)
        d, near, clear = sight_lines(scene, plan.C_world, stations, settings.vlos_radius_m)
        cols = np.arange(len(plan))
        dist, in_sight = d[which.ravel(), cols], (near & clear)[which.ravel(), cols]
        for k, m in enumerate(plan.missions):
            los_ok[k] = bool(in_sight[m.start:m.stop].all())
        far = ~in_sight & (dist > settings.vlos_radius_m)
        for a, b in _runs(far):
            violations.append(f"{_span(a, b)} beyond the {settings.vlos_radius_m:g} m VLOS radius of the ground station "
                              f"(up to {dist[a:b].max():.0f} m away)")
        for a, b in _runs(~in_sight & ~far):
            violations.append(f"{_span(a, b)} hidden from the ground station by the model")
    altitude = None
    if settings.altitude_limit_m is not None:
        ground = ground_z(scene, plan.C_world)  # the ground under each waypoint
        altitude = check_altitude(scene, plan, settings.altitude_limit_m, ground_z=ground, error_v_m=error[1])
        violations += altitude.violations
    above, low_wp, low_leg = None, np.zeros(len(plan), bool), np.zeros(max(len(plan) - 1, 0), bool)
    if settings.min_height_m is not None and not isinstance(settings.aircraft, Rover):
        above, low_wp, low_leg, found = check_min_height(scene, plan, settings.min_height_m, error[1])
        violations += found
    paths: list = []
    path_ok = [True] * len(plan.missions)
    if not isinstance(settings.aircraft, Rover) and plan.missions:
        paths, path_ok, found = check_paths(scene, obstacles, plan, station_of, settings)
        violations += found
    reports = []
    for k, m in enumerate(plan.missions):
        sl = slice(m.start, m.stop)
        t = d = ok_battery = None
        ac = settings.aircraft
        if isinstance(ac, Rover) and m.stop > m.start:
            # a rover resumes where it stopped: a battery part after the first of its route walks on from the
            # frame before it (split_by_rover names the parts "route (1)", "route (2)", …)
            resumes = k > 0 and _continues(plan.missions[k - 1].name, m.name)
            route = plan.C_world[m.start - 1 if resumes else m.start:m.stop]
            d = float(np.linalg.norm(np.diff(route, axis=0), axis=1).sum())
            t = d / ac.speed_m_s + ac.capture_s * (m.stop - m.start)
            ok_battery = t <= ac.usable_s and d <= ac.usable_m
            if not ok_battery:
                violations.append(f"route {m.name!r} takes {t / 60:.1f} min over {d:.0f} m, more than one battery of "
                                  f"{ac.name!r}")
        elif ac is not None and m.stop > m.start:
            t, d = mission_time(plan.C_world[sl], station_of[k], ac)
            ok_battery = t <= ac.usable_s
            if not ok_battery:
                violations.append(f"mission {m.name!r} takes {t / 60:.1f} min, more than one battery "
                                  f"({ac.usable_s / 60:.1f} min usable)")
        seg = safety.segment_worst_m[m.start:max(m.stop - 1, m.start)]
        lim = settings.safety_distance_m - CHECK_TOLERANCE_M
        safety_ok = bool((safety.waypoint_worst_m[sl] >= lim).all() and not (seg < lim).any())
        alt_ok = None if altitude is None else bool((altitude.over_m[sl] <= 0).all())
        height_ok = None if above is None else bool(not low_wp[sl].any() and not low_leg[m.start:max(m.stop - 1, m.start)].any())
        safety_ok = safety_ok and path_ok[k]
        reports.append(MissionReport(m.name, m.start, m.stop, station_of[k], t, d, ok_battery, los_ok[k], safety_ok, alt_ok,
                                     height_ok))
    return FeasibilityReport(plan, tuple(reports), safety, dist, in_sight, altitude, tuple(violations), above,
                             battery_count(reports, settings.aircraft), ground_of(scene), tuple(paths), error)


def check_paths(scene: Scene, obstacles: Scene, plan: Plan, station_of: list[NDArray], settings: FlightSettings
                ) -> tuple[list, list[bool], list[str]]:
    """Each mission's take-off, flight out, return and landing (:mod:`~sightplan.plan.trajectory`), from the ground
    under its station, against the model (at the worst of the position error) and the minimum height; the paths,
    a verdict per mission and the violations."""
    from ..trajectory import PARTS, Transit, mission_paths

    stations = np.asarray(station_of, float).reshape(-1, 3)
    takeoffs = np.column_stack([stations[:, :2], ground_z(scene, stations)])
    transit = Transit(scene, obstacles, settings.safety_distance_m, settings.error, settings.min_height_m)
    flown = [k for k, m in enumerate(plan.missions) if m.stop > m.start]
    paths = mission_paths(transit, plan.C_world, [plan.missions[k] for k in flown], takeoffs[flown])
    ok = [True] * len(plan.missions)
    violations: list[str] = []
    if not paths:
        return paths, ok, violations
    seg = np.stack([p.segments() for p in paths])  # (missions, parts, 2, 3)
    clear = transit.clear(seg).reshape(len(paths), len(PARTS))
    low = np.full((len(paths), 2), np.inf)  # the flights out and home above the ground, at the worst of the error
    if settings.min_height_m is not None:
        level = seg[:, [1, 4]].reshape(-1, 2, 3)
        low = (level[:, 0, 2] - settings.error[1] - transit.ground_tops(level[:, 0], level[:, 1])).reshape(-1, 2)
    for k, p, c, h in zip(flown, paths, clear, low):
        for part, d in zip(PARTS, c):
            if d < settings.safety_distance_m - CHECK_TOLERANCE_M:
                ok[k] = False
                violations.append(f"mission {p.name!r}: the {part} passes {max(d, 0.0):.2f} m from the model at the "
                                  f"worst (safety distance {settings.safety_distance_m:g} m); take-off at "
                                  f"{p.takeoff_m[0]:.1f},{p.takeoff_m[1]:.1f}")
        for part, above in zip(("flight out", "flight home"), h):
            if settings.min_height_m is not None and above < settings.min_height_m - CHECK_TOLERANCE_M:
                ok[k] = False
                violations.append(f"mission {p.name!r}: the {part} comes down to {above:+.2f} m above the ground "
                                  f"(minimum {settings.min_height_m:g} m)")
    return paths, ok, violations


def battery_count(missions, aircraft) -> int | None:
    """Charges for the missions flown (or walked) in order: a battery takes consecutive missions while their times
    (and a rover's distances) add up to its usable time (and distance). A rover's part cut where its battery ran out
    fills one, so the next part takes a new one."""
    if aircraft is None:
        return None
    limit_d = aircraft.usable_m if isinstance(aircraft, Rover) else np.inf
    count, left, left_d = 0, 0.0, 0.0
    for m in missions:
        if m.time_s is None or m.stop <= m.start:
            continue
        d = (m.distance_m or 0.0) if isinstance(aircraft, Rover) else 0.0
        if count == 0 or m.time_s > left or d > left_d:
            count, left, left_d = count + 1, aircraft.usable_s, limit_d
        left -= m.time_s
        left_d -= d
    return count


LEG_SAMPLE_M = 0.5  # legs are checked against uneven terrain at points this far apart


def check_min_height(scene: Scene, plan: Plan, min_height_m: float, error_v_m: float = 0.0
                     ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], list[str]]:
    """Each waypoint's height above the ground under it, which waypoints and which legs within a mission come lower
    than ``min_height_m`` when the aircraft strays ``error_v_m`` below them, and the violations. Over flat ground a
    leg is as high as its lower end; over terrain it is sampled every ``LEG_SAMPLE_M``."""
    C = plan.C_world
    above = C[:, 2] - ground_z(scene, C[:, :2])
    tol = CHECK_TOLERANCE_M + error_v_m  # the comparisons below are of the nominal heights
    low_wp = above < min_height_m - tol
    error_note = f" less the ±{error_v_m:g} m vertical position error" if error_v_m else ""
    violations = [f"{_span(a, b)} less than {min_height_m:g} m above the ground{error_note} (lowest "
                  f"{above[a:b].min() - error_v_m:+.2f} m)" for a, b in _runs(low_wp)]
    low_leg = np.zeros(max(len(C) - 1, 0), bool)
    if has_terrain(scene):
        legs = [i for m in plan.missions for i in range(m.start, max(m.stop - 1, m.start))]
        if legs:
            legs = np.asarray(legs)
            n = np.maximum(2, np.ceil(np.linalg.norm(C[legs + 1] - C[legs], axis=1) / LEG_SAMPLE_M).astype(int) + 1)
            owner = np.repeat(np.arange(len(legs)), n)
            t = np.concatenate([np.linspace(0.0, 1.0, k) for k in n])
            P = C[legs[owner]] + t[:, None] * (C[legs[owner] + 1] - C[legs[owner]])
            clear = np.full(len(legs), np.inf)
            np.minimum.at(clear, owner, P[:, 2] - ground_z(scene, P[:, :2]))
            bad = clear < min_height_m - tol
            bad &= ~(low_wp[legs] | low_wp[legs + 1])  # a low end is reported already
            low_leg[legs[bad]] = True
            violations += [f"leg {legs[j]}→{legs[j] + 1} comes down to {clear[j] - error_v_m:+.2f} m above the ground"
                           f"{error_note} (minimum {min_height_m:g} m)" for j in np.flatnonzero(bad)]
    return above, low_wp, low_leg, violations
