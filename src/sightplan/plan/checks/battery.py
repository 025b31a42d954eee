"""Flight time and battery: split a plan into missions that each fit one battery.

A leg between two points is flown with a trapezoidal speed profile: it accelerates at
``accel`` up to the cruise speed, then brakes; horizontal and vertical moves run at the
same time, so the leg takes the longer of the two. Each photo costs ``capture_s`` of
hovering. A mission flies from the ground station to its first waypoint, through its
waypoints, and back; it fits when that time stays within the battery's flight time less
the reserve.
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
    the usable flight time. Frames are neither reordered nor dropped.
    """
    gs = np.asarray(ground_station, float).reshape(3)
    C = plan.C_world
    missions, times = [], []
    for m in plan.missions:
        start = m.start
        part = 1
        while start < m.stop:
            stop = start + 1
            if mission_time(C[start:stop], gs, ac)[0] > ac.usable_s:
                raise PlanError(f"waypoint {start} cannot be reached and flown back from the ground station on one "
                                f"battery ({ac.usable_s / 60:.1f} min usable)")
            while stop < m.stop and mission_time(C[start:stop + 1], gs, ac)[0] <= ac.usable_s:
                stop += 1  # the whole prefix is re-timed: fine for plans of thousands of waypoints
            t, dist = mission_time(C[start:stop], gs, ac)
            name = m.name if (start == m.start and stop == m.stop) else f"{m.name} ({part})"
            missions.append(Mission(name, start, stop))
            times.append(MissionTime(name, start, stop, t, dist))
            start, part = stop, part + 1
    return replace(plan, missions=tuple(missions)), times
