"""What an autopilot does with a MAVLink mission: a replay of its items under the firmware's rules, giving the pose
of every photo (:func:`~sightplan.flight.replay.simulate_items`, :func:`~sightplan.flight.replay.simulate_file`).

The aircraft is a point that flies straight at its current position setpoint, at most ``speed_m_s`` and braking at
``accel_m_s2`` so as to stop on it (v = min(v_max, √(2·a·d)), the speed rising by at most a·dt a step); its yaw
turns toward its yaw setpoint at ``yaw_rate_deg_s`` and the gimbal's pitch toward its target at ``rate_deg_s``
(:class:`Gimbal`). A photo takes the pose of that instant. Which item runs when, and what counts as reached, is the
autopilot's (:mod:`.px4`, :mod:`.ardupilot`): each rule there names the source file and function it comes from.
Parameters are the firmwares' defaults and can be replaced (``dataclasses.replace``).

What is left out: wind, the position controller's tracking error (the GNSS error is the plan's position error, see
:mod:`sightplan.plan.checks.safety`), turns cut at corners (the aircraft is taken to stop at every waypoint, which
both firmwares do at waypoints with a hold time or a zero-length next leg), and the camera's own trigger latency.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..formats.flight import DEFAULT_GIMBAL, Gimbal, wrap180

__all__ = ["DEFAULT_GIMBAL", "DT_S", "Gimbal", "Item", "PhotoPose", "Replay", "Vehicle", "local_items", "local_projection",
           "wrap180"]

DT_S = 0.02  # the replay's time step
MAX_TIME_S = 4 * 3600.0  # a replay that runs longer is a mission that never ends (a waypoint never reached)


@dataclass(frozen=True)
class Item:
    """One mission item in the local frame of the home point: ``xyz`` east, north, up metres above home (NaN for
    an item without a position)."""

    command: int
    params: tuple[float, ...]
    xyz: tuple[float, float, float] = (math.nan, math.nan, math.nan)


@dataclass(frozen=True)
class PhotoPose:
    """Where and how a photo was taken: time (s), position (east, north, up, metres from home), true heading and
    gimbal pitch (degrees), the pitch the gimbal was sent to, and whether it was still moving or settling."""

    time_s: float
    xyz: tuple[float, float, float]
    heading_deg: float
    pitch_deg: float
    pitch_target_deg: float
    gimbal_still: bool
    item: int


@dataclass
class Replay:
    """A mission replayed: every photo's pose in order, the time flown, and notes (an item never reached…)."""

    autopilot: str
    photos: list[PhotoPose] = field(default_factory=list)
    time_s: float = 0.0
    notes: list[str] = field(default_factory=list)


class Vehicle:
    """The point aircraft: position, speed along its way, yaw, gimbal pitch and the time."""

    def __init__(self, speed_m_s: float, accel_m_s2: float, yaw_rate_deg_s: float, gimbal: Gimbal,
                 heading_deg: float = 0.0, pitch_deg: float = 0.0) -> None:
        self.p = np.zeros(3)
        self.v = 0.0
        self.vmax, self.accel, self.yaw_rate, self.gimbal = speed_m_s, accel_m_s2, yaw_rate_deg_s, gimbal
        self.yaw, self.pitch, self.pitch_target = heading_deg, pitch_deg, pitch_deg
        self.pitch_reached_at = 0.0
        self.t = 0.0
        self.target = self.p.copy()
        self.yaw_target: float | None = None

    def step(self, dt: float = DT_S) -> None:
        d_vec = self.target - self.p
        d = float(np.linalg.norm(d_vec))
        if d > 1e-9:
            self.v = min(self.v + self.accel * dt, self.vmax, math.sqrt(2.0 * self.accel * d))
            move = min(self.v * dt, d)
            self.p = self.p + d_vec / d * move
            if move >= d:
                self.v = 0.0
        else:
            self.v = 0.0
        if self.yaw_target is not None:
            err = wrap180(self.yaw_target - self.yaw)
            turn = max(-self.yaw_rate * dt, min(self.yaw_rate * dt, err))
            self.yaw = (self.yaw + turn) % 360.0
        err = self.pitch_target - self.pitch
        if err != 0.0:
            reach = self.gimbal.rate_deg_s * dt
            if abs(err) <= reach + 1e-9:  # arrives within this step, at the exact time
                self.pitch = self.pitch_target
                self.pitch_reached_at = self.t + abs(err) / self.gimbal.rate_deg_s
            else:
                self.pitch += math.copysign(reach, err)
        self.t += dt

    def aim_gimbal(self, pitch_deg: float) -> None:
        if pitch_deg != self.pitch_target:
            self.pitch_target = float(pitch_deg)
            if self.pitch == self.pitch_target:
                self.pitch_reached_at = self.t

    def photo(self, item: int) -> PhotoPose:
        still = self.pitch == self.pitch_target and self.t - self.pitch_reached_at >= self.gimbal.settle_s - 1e-9
        return PhotoPose(self.t, (float(self.p[0]), float(self.p[1]), float(self.p[2])), self.yaw % 360.0,
                         self.pitch, self.pitch_target, bool(still), item)

    def land(self, xyz: tuple[float, float, float] | None, stages: tuple[tuple[float, float], ...]) -> None:
        """Fly level to above ``xyz`` (None: where it is; NaN coordinates likewise), then descend to the ground
        (z = 0, the take-off's height) at each stage's speed below each stage's height: ((above_m, speed), …)."""
        if xyz is not None and math.isfinite(xyz[0]) and math.isfinite(xyz[1]):
            self.target = np.array([xyz[0], xyz[1], self.p[2]])
            while float(np.linalg.norm(self.target - self.p)) > 1e-3 and self.t < MAX_TIME_S:
                self.step()
        vmax = self.vmax
        for above, speed in stages:
            floor = min(above, self.p[2]) if above > 0 else 0.0
            self.vmax = min(vmax, speed)
            self.target = np.array([self.p[0], self.p[1], floor])
            while self.p[2] - floor > 1e-3 and self.t < MAX_TIME_S:
                self.step()
        self.vmax = vmax

    def bearing_to(self, xyz: NDArray) -> float | None:
        d = np.asarray(xyz[:2]) - self.p[:2]
        return None if float(np.hypot(*d)) < 1e-6 else math.degrees(math.atan2(d[0], d[1])) % 360.0


def local_projection(latitude_deg: float, longitude_deg: float):
    """The replay's east-north frame at a home point: pyproj's azimuthal equidistant projection there (WGS 84,
    metres); ``proj(lon, lat)`` gives east, north and ``proj(e, n, inverse=True)`` the way back."""
    from pyproj import Proj

    return Proj(proj="aeqd", lat_0=latitude_deg, lon_0=longitude_deg, datum="WGS84", units="m")


def local_items(commands: list, home: tuple[float, float, float]) -> list[Item]:
    """MAVLink commands (``command``, ``frame``, ``params`` with latitude, longitude, altitude in params 5–7) →
    :class:`Item` in the east-north-up frame of ``home`` (latitude°, longitude°, absolute height m): an azimuthal
    equidistant projection at home (pyproj), heights above home (frames 3/6 as they are, 0/5 less home's)."""
    from ..formats.mavlink import POSITIONAL

    proj = local_projection(home[0], home[1])
    out = []
    for c in commands:
        params = tuple(float(v) for v in c.params)
        xyz = (math.nan, math.nan, math.nan)
        if c.command in POSITIONAL and math.isfinite(params[4]) and math.isfinite(params[5]) and any(params[4:6]):
            e, n = proj(params[5], params[4])
            z = params[6] - home[2] if c.frame in (0, 5) else params[6]
            xyz = (float(e), float(n), float(z))
        out.append(Item(int(c.command), params, xyz))
    return out
