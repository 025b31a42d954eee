"""The plan as it will be flown: a MAVLink export (QGroundControl ``.plan``, ``QGC WPL 110``) replayed under its
autopilot's rules (:mod:`.simulate`), each photo's pose becoming a frame (:func:`as_flown_plan`), so that it can be
evaluated beside the frames the file names (``sightplan evaluate MODEL EXPORT --as-flown``).

DJI WPML and Litchi run a waypoint's actions in order after stopping on it; their photos are the file's frames."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import PlanError
from ..geo import Georeference
from ..geometry.poses import R_from_gimbal, gimbal_from_R
from ..plan.types import Plan
from .replay import read_mission, simulate_items
from .simulate import DEFAULT_GIMBAL, Gimbal, Replay, local_projection

MAVLINK_SUFFIXES = (".plan", ".waypoints", ".txt", ".mission")


def photo_poses(replay: Replay, home: tuple[float, float, float], georef: Georeference
                ) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) model centres and (n, 3, 3) rotations of a replay's photos, taken from ``home`` (latitude°,
    longitude°, height in the georeference's datum): position, true heading and gimbal pitch, roll 0."""
    xyz = np.array([p.xyz for p in replay.photos], float).reshape(-1, 3)
    lon, lat = local_projection(home[0], home[1])(xyz[:, 0], xyz[:, 1], inverse=True)
    C = georef.from_geodetic(lat, lon, home[2] + xyz[:, 2])
    heading = georef.model_heading(C, np.array([p.heading_deg for p in replay.photos]))
    return C, R_from_gimbal(heading, np.array([p.pitch_deg for p in replay.photos]))


def as_flown_plan(path: str | Path, plan: Plan, georef: Georeference, autopilot: str | None = None,
                  gimbal: Gimbal = DEFAULT_GIMBAL) -> tuple[Plan, Replay]:
    """``plan`` (the file read as frames, :func:`~sightplan.plan.load.load_plan`) with every frame moved to where
    the replay of ``path`` takes its photo: position, heading and gimbal pitch (roll 0). The photos must match the
    frames one for one, in order; a replay that takes more or fewer is refused, naming both counts."""
    path = Path(path)
    if path.suffix.lower() not in MAVLINK_SUFFIXES:
        raise PlanError(f"--as-flown replays MAVLink missions (.plan, .waypoints); {path.name} is not one. DJI WPML "
                        "and Litchi missions take their photos on their waypoints: evaluate the file as it is")
    items, home, autopilot, speed = read_mission(path, autopilot)
    rep = simulate_items(items, autopilot, speed, gimbal)
    if len(rep.photos) != len(plan):
        why = f" ({rep.notes[0]})" if rep.notes else ""
        raise PlanError(f"the replay of {path.name} takes {len(rep.photos)} photos, the file names {len(plan)} "
                        f"frames{why}: they cannot be compared frame by frame")
    C, R = photo_poses(rep, home, georef)
    flown = replace(plan, C_world=C, R_world_camera=R,
                    parameters={**plan.parameters, "as_flown": {"file": path.name, "autopilot": rep.autopilot,
                                                               "flight_time_s": round(rep.time_s, 1)}})
    return flown, rep


def deviations(plan: Plan, flown: Plan) -> tuple[np.ndarray, np.ndarray]:
    """(n,) metres and (n,) degrees (the larger of the heading's and the pitch's) between each frame and its photo."""
    d = np.linalg.norm(flown.C_world - plan.C_world, axis=1)
    h0, p0, _ = gimbal_from_R(plan.R_world_camera)
    h1, p1, _ = gimbal_from_R(flown.R_world_camera)
    a = np.maximum(np.abs((h1 - h0 + 180.0) % 360.0 - 180.0), np.abs(p1 - p0))
    return d, a


def as_flown_of_plan(plan: Plan, georef: Georeference, takeoff_m, autopilot: str, speed_m_s: float = 5.0,
                     gimbal: Gimbal = DEFAULT_GIMBAL) -> tuple[Plan, list[Replay]]:
    """``plan`` as ``autopilot`` flies sightplan's own export of it (:func:`~sightplan.formats.mavlink.mission_items`,
    each mission from its take-off point): every frame moved to where its photo is taken in the replay."""
    from ..formats.flight import build_flight
    from ..formats.mavlink import mission_items
    from .fidelity import replay_items

    flight = build_flight(plan, georef, takeoff_m, fmt="qgc", speed_m_s=speed_m_s)
    C, R = plan.C_world.copy(), plan.R_world_camera.copy()
    replays = []
    for _, wps in flight.by_mission():
        home = flight.takeoff_of(wps[0].mission)
        rep = replay_items(mission_items(flight, wps, autopilot, gimbal), (home.latitude_deg, home.longitude_deg, 0.0),
                           autopilot, flight.speed_m_s, gimbal)
        photos = [ph for wp in wps for ph in wp.photos]
        if len(rep.photos) != len(photos):
            raise PlanError(f"the replay of mission {wps[0].mission + 1} takes {len(rep.photos)} photos for "
                            f"{len(photos)} frames{': ' + rep.notes[0] if rep.notes else ''}")
        idx = np.array([ph.frame for ph in photos])
        C[idx], R[idx] = photo_poses(rep, (home.latitude_deg, home.longitude_deg, home.height_m), georef)
        replays.append(rep)
    flown = replace(plan, C_world=C, R_world_camera=R,
                    parameters={**plan.parameters, "as_flown": {"autopilot": autopilot, "speed_m_s": flight.speed_m_s,
                                                               "flight_time_s": round(sum(r.time_s for r in replays), 1)}})
    return flown, replays
