"""Whether an export makes its photos where the plan was evaluated: each mission's items replayed
(:mod:`.simulate`) and every photo compared with its frame, in order."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .replay import simulate_items
from .simulate import DEFAULT_GIMBAL, Gimbal, Replay, local_items, local_projection

TOLERANCE_M = 0.1  # a photo farther than this from its frame…
TOLERANCE_DEG = 1.0  # …or turned more than this (heading or pitch) is not the frame that was evaluated


@dataclass
class Fidelity:
    """The replay of one or more missions against their frames: photos expected and taken, the largest position
    (m) and angle (°) deviation, the photos taken while the gimbal moved or settled, and the replay's notes."""

    autopilot: str
    expected: int = 0
    taken: int = 0
    position_m: float = 0.0
    angle_deg: float = 0.0
    gimbal_moving: int = 0
    time_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    deviations: list[tuple[float, float]] = field(default_factory=list)  # per photo: metres, degrees
    mission_times_s: list[float] = field(default_factory=list)  # per mission: take-off to landing, as replayed

    @property
    def faithful(self) -> bool:
        return (self.taken == self.expected and self.position_m <= TOLERANCE_M and self.angle_deg <= TOLERANCE_DEG
                and self.gimbal_moving == 0)

    def add(self, other: Fidelity) -> None:
        self.expected += other.expected
        self.taken += other.taken
        self.position_m = max(self.position_m, other.position_m)
        self.angle_deg = max(self.angle_deg, other.angle_deg)
        self.gimbal_moving += other.gimbal_moving
        self.time_s += other.time_s
        self.notes += other.notes
        self.deviations += other.deviations
        self.mission_times_s += other.mission_times_s

    def summary(self) -> str:
        """'simulated: N photos, largest deviation d m / a°' and what is wrong, for the export's line."""
        from ..formats.mavlink import AUTOPILOT_LABELS

        text = (f"simulated ({AUTOPILOT_LABELS.get(self.autopilot, self.autopilot)}): {self.taken} photos, largest "
                f"deviation {self.position_m:.2f} m / {self.angle_deg:.1f}°, "
                f"{max(self.mission_times_s, default=self.time_s) / 60:.1f} min take-off to landing")
        if self.taken != self.expected:
            text += f", {self.expected} expected"
        if self.gimbal_moving:
            text += f", {self.gimbal_moving} taken while the gimbal moved"
        return text


def replay_items(items: list[dict], home: tuple[float, float, float], autopilot: str, speed_m_s: float,
                 gimbal: Gimbal = DEFAULT_GIMBAL) -> Replay:
    """Replay the command dicts :func:`~sightplan.formats.mavlink.mission_items` writes, from ``home``."""
    from types import SimpleNamespace

    cmds = [SimpleNamespace(command=d["command"], frame=d["frame"], params=tuple(d["params"])) for d in items]
    return simulate_items(local_items(cmds, home), autopilot, speed_m_s, gimbal)


def flight_fidelity(flight, autopilot: str, gimbal: Gimbal = DEFAULT_GIMBAL, items_of=None) -> Fidelity:
    """Each mission of ``flight`` (a :class:`~sightplan.formats.flight.Flight`) written as
    :func:`~sightplan.formats.mavlink.mission_items` for ``autopilot`` (or by ``items_of(flight, waypoints)``),
    replayed from its take-off point, every photo compared with its frame."""
    from ..formats.mavlink import mission_items

    total = Fidelity(autopilot)
    for _, waypoints in flight.by_mission():
        items = items_of(flight, waypoints) if items_of else mission_items(flight, waypoints, autopilot, gimbal)
        home = flight.takeoff_of(waypoints[0].mission)
        rep = replay_items(items, (home.latitude_deg, home.longitude_deg, 0.0), autopilot, flight.speed_m_s, gimbal)
        want = [(wp, ph) for wp in waypoints for ph in wp.photos]
        one = Fidelity(autopilot, expected=len(want), taken=len(rep.photos), time_s=rep.time_s, notes=list(rep.notes),
                       mission_times_s=[rep.time_s])
        n = min(len(want), len(rep.photos))  # compared in order, as far as both go
        if n:
            wp_ll = np.array([(wp.longitude_deg, wp.latitude_deg, wp.altitude_m) for wp, _ in want[:n]])
            e, north = local_projection(home.latitude_deg, home.longitude_deg)(wp_ll[:, 0], wp_ll[:, 1])
            got = rep.photos[:n]
            d = np.linalg.norm(np.array([p.xyz for p in got]) - np.column_stack([e, north, wp_ll[:, 2]]), axis=1)
            turn = (np.array([p.heading_deg for p in got]) - [ph.heading_deg for _, ph in want[:n]] + 180.0) % 360.0
            tilt = np.abs(np.array([p.pitch_deg for p in got]) - [ph.pitch_deg for _, ph in want[:n]])
            a = np.maximum(np.abs(turn - 180.0), tilt)
            one.deviations = list(zip(d.tolist(), a.tolist()))
            one.position_m, one.angle_deg = float(d.max()), float(a.max())
            one.gimbal_moving = sum(not p.gimbal_still for p in got)
        total.add(one)
    return total


__all__ = ["TOLERANCE_DEG", "TOLERANCE_M", "Fidelity", "flight_fidelity", "replay_items"]
