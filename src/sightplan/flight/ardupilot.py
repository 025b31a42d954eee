"""ArduPilot Copter missions, as ``libraries/AP_Mission/AP_Mission.cpp`` and ``ArduCopter/mode_auto.cpp`` run them.

- Positional (NAV) commands run one at a time. When one completes, ``AP_Mission::advance_current_nav_cmd`` starts
  the next NAV command *and* the first DO or CONDITION command between the two; the others follow one by one
  (``AP_Mission::advance_current_do_cmd``), a CONDITION command holding back the ones after it until it is
  verified. When the NAV command completes first, the DO commands not yet run are dropped.
- ``NAV_WAYPOINT`` completes once the aircraft is at it (a waypoint whose next leg has no length, or with a hold
  time, is a stop) and its hold time (param1) has passed (``ModeAuto::verify_nav_wp``). ``NAV_TAKEOFF`` completes
  at its altitude.
- Starting a waypoint sets the yaw by ``WP_YAW_BEHAVIOR`` (default 2: face the next waypoint; held when the
  waypoint is less than 2 m away); ``CONDITION_YAW`` (param1, absolute) turns to a heading at ``ATC_SLEW_YAW``
  (60°/s) and is verified within 2° (``ModeAuto::verify_yaw``); ``CONDITION_DELAY`` is verified after param1
  seconds. The aircraft accelerates and brakes at ``WPNAV_ACCEL`` (2.5 m/s²).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..formats import mavlink as mav
from .simulate import MAX_TIME_S, Gimbal, Item, Replay, Vehicle, wrap180

NAV_DELAY, CONDITION_DELAY = 93, 112
NAV = mav.POSITIONAL | {NAV_DELAY}
CONDITIONS = {CONDITION_DELAY, mav.CONDITION_YAW}


@dataclass(frozen=True)
class ArduCopter:
    yaw_rate_deg_s: float = 60.0  # ATC_SLEW_YAW
    yaw_done_deg: float = 2.0  # ModeAuto::verify_yaw
    accel_m_s2: float = 2.5  # WPNAV_ACCEL
    look_ahead_m: float = 2.0  # closer than this, WP_YAW_BEHAVIOR holds the yaw
    descent_m_s: float = 1.5  # WPNAV_SPEED_DN, down to…
    land_alt_low_m: float = 10.0  # …LAND_ALT_LOW, then…
    land_speed_m_s: float = 0.5  # …LAND_SPEED to the ground


DEFAULTS = ArduCopter()


def replay(items: list[Item], speed_m_s: float, gimbal: Gimbal, prm: ArduCopter = DEFAULTS) -> Replay:
    veh = Vehicle(speed_m_s, prm.accel_m_s2, prm.yaw_rate_deg_s, gimbal)
    out = Replay("ardupilot")
    navs = [k for k, it in enumerate(items) if it.command in NAV]
    prev = -1
    for j in navs:
        it, p = items[j], items[j].params
        queue = list(range(prev + 1, j))
        prev = j
        if it.command in (mav.NAV_RETURN_TO_LAUNCH, mav.NAV_LAND):  # home (RTL), or there; landing
            veh.land((0.0, 0.0, 0.0) if it.command == mav.NAV_RETURN_TO_LAUNCH else it.xyz,
                     ((prm.land_alt_low_m, prm.descent_m_s), (0.0, prm.land_speed_m_s)))
            break
        state = {"q": 0, "started": None, "reached": None, "fixed_yaw": False}
        target = np.array(it.xyz) if math.isfinite(it.xyz[0]) else veh.p.copy()
        if it.command == mav.NAV_TAKEOFF:
            target = np.array([veh.p[0], veh.p[1], it.xyz[2] if math.isfinite(it.xyz[2]) else p[6]])
        veh.target = target

        def run_do(queue=queue, state=state) -> None:
            while state["q"] < len(queue):
                k = queue[state["q"]]
                c, q = items[k].command, items[k].params
                if c in CONDITIONS:
                    if state["started"] is None:
                        state["started"] = veh.t
                        if c == mav.CONDITION_YAW:
                            veh.yaw_target = q[0] % 360.0
                            state["fixed_yaw"] = True
                    if c == mav.CONDITION_YAW and abs(wrap180(q[0] - veh.yaw)) > prm.yaw_done_deg:
                        return
                    if c == CONDITION_DELAY and veh.t - state["started"] < q[0] - 1e-9:
                        return
                    state["started"] = None
                elif c in (mav.DO_MOUNT_CONTROL, mav.DO_GIMBAL_MANAGER_PITCHYAW):
                    veh.aim_gimbal(q[0])
                elif c == mav.IMAGE_START_CAPTURE or (c == mav.DO_DIGICAM_CONTROL and q[4] == 1):
                    out.photos.append(veh.photo(k))
                state["q"] += 1

        def nav_done(it=it, target=target, state=state) -> bool:
            if not state["fixed_yaw"]:
                d = float(np.hypot(*(target[:2] - veh.p[:2])))
                b = veh.bearing_to(target)
                if b is not None and d > prm.look_ahead_m:
                    veh.yaw_target = b
            if it.command == NAV_DELAY:
                if state["reached"] is None:
                    state["reached"] = veh.t
                return veh.t - state["reached"] >= max(it.params[0], 0.0) - 1e-9
            if float(np.linalg.norm(target - veh.p)) > 1e-3:
                return False
            if state["reached"] is None:
                state["reached"] = veh.t
            hold = max(it.params[0], 0.0) if it.command == mav.NAV_WAYPOINT and math.isfinite(it.params[0]) else 0.0
            return veh.t - state["reached"] >= hold - 1e-9

        run_do()
        while not nav_done():
            veh.step()
            run_do()
            if veh.t > MAX_TIME_S:
                out.notes.append(f"item {j + 1}: never completed")
                out.time_s = veh.t
                return out
        dropped = queue[state["q"]:]
        if dropped:
            out.notes.append(f"items {', '.join(str(k + 1) for k in dropped)} were dropped: waypoint item {j + 1} "
                             "completed before them")
    out.time_s = veh.t
    return out
