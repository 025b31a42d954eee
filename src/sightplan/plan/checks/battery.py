"""Flight time and battery: split a plan into missions that each fit one battery.

A leg between two points is flown with a trapezoidal speed profile: it accelerates at
``accel`` up to the cruise speed, then brakes; horizontal and vertical moves run at the
same time, so the leg takes the longer of the two. Each photo costs ``capture_s`` of
hovering. A mission flies from the ground station to its first waypoint, through its
waypoints, and back; it fits when that time stays within the battery's flight time less
the reserve. Ground rovers and walkers (:class:`Rover`) move at a constant speed from
frame to frame and resume where they stopped (:func:`split_by_rover`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ...errors import PlanError
from ..types import Mission, Plan


@dataclass(frozen=True)
class Aircraft:
    """Speeds in m/s, acceleration in m/s², times in s, reserve as a share of the flight time."""

    name: str
    horizontal_speed: float
    vertical_speed: float
    accel: float
    flight_time_s: float
    capture_s: float = 2.0
    reserve: float = 0.25
    rtk: bool = False  # positions by RTK: the checks' position error is POSITION_ERROR["rtk"], else "gnss"

    def __post_init__(self) -> None:
        for k in ("horizontal_speed", "vertical_speed", "accel", "flight_time_s"):
            if not getattr(self, k) > 0:
                raise PlanError(f"aircraft {self.name!r}: {k} must be positive, got {getattr(self, k)}")
        if not 0 <= self.reserve < 1 or self.capture_s < 0:
            raise PlanError(f"aircraft {self.name!r}: reserve must be in [0, 1) and capture time ≥ 0")

    @property
    def usable_s(self) -> float:
        return self.flight_time_s * (1 - self.reserve)


# Editable presets: cruise speeds kept below the maxima for photogrammetry; flight times as published (hover).
AIRCRAFT = {
    "p4p": Aircraft("DJI Phantom 4 Pro V2.0", 8.0, 3.0, 2.0, 30 * 60),
    "m3e": Aircraft("DJI Mavic 3 Enterprise", 10.0, 4.0, 2.5, 45 * 60),
    "m300": Aircraft("DJI Matrice 300 RTK with Zenmuse P1", 10.0, 4.0, 2.5, 40 * 60),
    # the same aircraft flying with an RTK fix (a base station or a network): ±0.1 m position error
    "m3e-rtk": Aircraft("DJI Mavic 3 Enterprise with the RTK module", 10.0, 4.0, 2.5, 45 * 60, rtk=True),
    "m300-rtk": Aircraft("DJI Matrice 300 RTK with Zenmuse P1, RTK fix", 10.0, 4.0, 2.5, 40 * 60, rtk=True),
}


def leg_time(distance: NDArray, speed: float, accel: float) -> NDArray[np.float64]:
    """(k,) seconds to cover (k,) distances from rest to rest with a trapezoidal speed profile."""
    d = np.asarray(distance, float)
    ramp = speed * speed / accel  # distance spent accelerating and braking at full speed
    return np.where(d >= ramp, d / speed + speed / accel, 2 * np.sqrt(d / accel))


def legs_time(a: NDArray, b: NDArray, ac: Aircraft) -> NDArray[np.float64]:
    """(k,) seconds from each point of a to the matching point of b (horizontal and vertical together)."""
    rel = np.asarray(b, float) - np.asarray(a, float)
    th = leg_time(np.hypot(rel[:, 0], rel[:, 1]), ac.horizontal_speed, ac.accel)
    tv = leg_time(np.abs(rel[:, 2]), ac.vertical_speed, ac.accel)
    return np.maximum(th, tv)


@dataclass(frozen=True)
class MissionTime:
    name: str
    start: int
    stop: int
    time_s: float
    distance_m: float


def mission_time(C: NDArray, ground_station: NDArray, ac: Aircraft) -> tuple[float, float]:
    """Seconds and metres to fly the (k, 3) waypoints from and back to the ground station, photos included."""
    path = np.concatenate([ground_station[None], C, ground_station[None]])
    t = legs_time(path[:-1], path[1:], ac).sum() + ac.capture_s * len(C)
    return float(t), float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def split_by_battery(plan: Plan, ground_station: NDArray, ac: Aircraft) -> tuple[Plan, list[MissionTime]]:
    """The plan with each mission cut, in flight order, into battery-sized missions; their times.

    A new mission starts (the resume waypoint) where adding the next waypoint would exceed
    the usable flight time. A last part of one frame takes frames from the part before it,
    so no battery flies out for a single photo where two balanced parts fit. Frames are
    neither reordered nor dropped.
    """
    gs = np.asarray(ground_station, float).reshape(3)[None]
    missions, times = [], []
    for m in plan.missions:
        C = plan.C_world[m.start:m.stop]
        out = legs_time(gs, C, ac)  # ground station → each waypoint
        back = legs_time(C, gs, ac)  # each waypoint → ground station
        along = np.concatenate([[0.0], np.cumsum(legs_time(C[:-1], C[1:], ac))])  # first waypoint → each, in order
        a, parts = 0, []
        while a < len(C):
            # flight time of the part a..b for every b ≥ a; it ends before the first b that no longer fits
            t = out[a] + (along[a:] - along[a]) + back[a:] + ac.capture_s * np.arange(1, len(C) - a + 1)
            if t[0] > ac.usable_s:
                raise PlanError(f"waypoint {m.start + a} cannot be reached and flown back from the ground station on one "
                                f"battery ({ac.usable_s / 60:.1f} min usable)")
            over = np.flatnonzero(t > ac.usable_s)
            b = a + (int(over[0]) if len(over) else len(C) - a)  # exclusive
            parts.append((a, b))
            a = b
        if len(parts) > 1 and parts[-1][1] - parts[-1][0] == 1:
            a0, end = parts[-2][0], parts[-1][1]
            for cut in range((a0 + end + 1) // 2, end - 1):  # the most even cut that both halves fit
                times_ = [out[a] + along[b - 1] - along[a] + back[b - 1] + ac.capture_s * (b - a)
                          for a, b in ((a0, cut), (cut, end))]
                if max(times_) <= ac.usable_s:
                    parts[-2:] = [(a0, cut), (cut, end)]
                    break
        for part, (a, b) in enumerate(parts, start=1):
            name = m.name if len(parts) == 1 else f"{m.name} ({part})"
            missions.append(Mission(name, m.start + a, m.start + b))
            t_part, dist = mission_time(C[a:b], gs[0], ac)
            times.append(MissionTime(name, m.start + a, m.start + b, t_part, dist))
    return replace(plan, missions=tuple(missions)), times


@dataclass(frozen=True)
class Rover:
    """A ground rover or a walking person: speed in m/s, ``capture_s`` standing still per frame.

    limit_time_s / limit_distance_m: what one battery (or one walk) allows, at least one of
    them; ``reserve`` is the share of each limit kept back.
    """

    name: str
    speed_m_s: float
    capture_s: float = 2.0
    limit_time_s: float | None = None
    limit_distance_m: float | None = None
    reserve: float = 0.1

    def __post_init__(self) -> None:
        if not self.speed_m_s > 0:
            raise PlanError(f"rover {self.name!r}: the speed must be positive, got {self.speed_m_s}")
        if not self.capture_s >= 0:
            raise PlanError(f"rover {self.name!r}: the capture time must be ≥ 0, got {self.capture_s}")
        if self.limit_time_s is None and self.limit_distance_m is None:
            raise PlanError(f"rover {self.name!r}: give a time limit, a distance limit or both")
        for k in ("limit_time_s", "limit_distance_m"):
            v = getattr(self, k)
            if v is not None and not v > 0:
                raise PlanError(f"rover {self.name!r}: {k} must be positive, got {v}")
        if not 0 <= self.reserve < 1:
            raise PlanError(f"rover {self.name!r}: the reserve must be in [0, 1), got {self.reserve}")

    @property
    def usable_s(self) -> float:
        return np.inf if self.limit_time_s is None else self.limit_time_s * (1 - self.reserve)

    @property
    def usable_m(self) -> float:
        return np.inf if self.limit_distance_m is None else self.limit_distance_m * (1 - self.reserve)


# Editable presets: capture speeds well below the maxima; limits from one battery (or one walk).
ROVERS = {
    # a person walking slowly with a 360° camera on a pole, stopping for each shot; one camera battery ≈ 1 h of use
    "walker-360": Rover("Person walking with a 360° camera", 0.8, 3.0, limit_time_s=60 * 60),
    # Boston Dynamics Spot with Spot CAM: about 90 min per battery, 1.6 m/s at most
    "spot": Rover("Boston Dynamics Spot with Spot CAM", 1.0, 2.0, limit_time_s=90 * 60, reserve=0.2),
    # a small tracked rover: about 3 h per battery, range about 5 km on site surfaces
    "tracked": Rover("Small tracked rover", 0.5, 2.0, limit_time_s=3 * 60 * 60, limit_distance_m=5000.0, reserve=0.2),
}


def split_by_rover(plan: Plan, rover: Rover) -> tuple[Plan, list[MissionTime]]:
    """The plan with each mission cut, in frame order, into parts that fit ``rover``'s limits; their times.

    The route runs straight from frame to frame. There is no return leg: the rover (or
    walker) changes battery where it stopped and resumes from there, so a part's route
    starts at the previous part's last frame (at its own first frame for a mission's first
    part). A part's time is its route over the speed plus ``capture_s`` per frame; it must
    keep within the usable time and the usable distance. Frames are neither reordered nor
    dropped.
    """
    missions, times = [], []
    v, t_max, d_max = rover.speed_m_s, rover.usable_s, rover.usable_m
    for m in plan.missions:
        C = plan.C_world[m.start:m.stop]
        D = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(C, axis=0), axis=1))])  # route length to each frame
        T = D / v + rover.capture_s * np.arange(1, len(C) + 1)  # time to each frame's shot, from the mission's start
        a, part = 0, 1
        while a < len(C):
            origin = max(a - 1, 0)
            # a part ending with frame b: D[b] − D[origin] ≤ d_max and T[b] − T[origin] (+ one shot if a = 0) ≤ t_max
            t0 = T[origin] - (rover.capture_s if a == 0 else 0.0)
            tol = 1e-9 * max(1.0, float(D[-1]), float(T[-1]))
            fits = min(np.searchsorted(D, D[origin] + d_max + tol, side="right"),
                       np.searchsorted(T, t0 + t_max + tol, side="right"))
            if fits <= a:
                usable = " and ".join(f"{x:g} {unit}" for x, unit in ((t_max, "s"), (d_max, "m")) if np.isfinite(x))
                raise PlanError(f"frame {m.start + a} does not fit one battery of {rover.name!r}: it alone takes "
                                f"{T[a] - t0:.1f} s over {D[a] - D[origin]:.1f} m, {usable} usable")
            b = fits  # exclusive
            name = m.name if (a == 0 and b == len(C)) else f"{m.name} ({part})"
            missions.append(replace(m, name=name, start=m.start + a, stop=m.start + b))  # keeps the mission's other fields
            times.append(MissionTime(name, m.start + a, m.start + b, float(T[b - 1] - t0), float(D[b - 1] - D[origin])))
            a, part = b, part + 1
    return replace(plan, missions=tuple(missions)), times
