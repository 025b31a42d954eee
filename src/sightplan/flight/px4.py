"""PX4 multicopter missions, as ``src/modules/navigator`` runs them (the rules below name their functions).

- Items run strictly in order; an item is "reached" before the next one starts
  (``MissionBlock::is_mission_item_reached``). Camera, gimbal and other DO items are reached at once, in the same
  cycle: a photo after a waypoint is taken the moment that waypoint counts as reached.
- ``NAV_WAYPOINT`` is reached when the aircraft is within the acceptance radius horizontally (param2 when it is
  above zero, else ``NAV_ACC_RAD``, 2 m) and within ``NAV_MC_ALT_RAD`` (0.8 m) vertically; then its yaw (param4, if
  finite) within ``MIS_YAW_ERR`` (12°); then its hold time (param1, ``get_time_inside``) counted from the moment the
  position was reached. The aircraft keeps flying to the waypoint meanwhile: the setpoint changes only when the
  next positional item starts (``MissionBlock::mission_item_to_position_setpoint``).
- ``NAV_TAKEOFF`` is reached on altitude alone, within the altitude acceptance radius (half the take-off altitude
  when that is smaller). ``NAV_DELAY`` (93) keeps the setpoint for param1 seconds.
- A NaN yaw faces the direction of flight; yaw turns at ``MPC_YAWRAUTO_MAX`` (45°/s); the aircraft accelerates and
  brakes at ``MPC_ACC_HOR`` (3 m/s²).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..formats import mavlink as mav
from .simulate import MAX_TIME_S, Gimbal, Item, Replay, Vehicle, wrap180

NAV_DELAY = 93


@dataclass(frozen=True)
class Px4:
    acceptance_m: float = 2.0  # NAV_ACC_RAD
    alt_acceptance_m: float = 0.8  # NAV_MC_ALT_RAD
    yaw_error_deg: float = 12.0  # MIS_YAW_ERR
    yaw_rate_deg_s: float = 45.0  # MPC_YAWRAUTO_MAX
    accel_m_s2: float = 3.0  # MPC_ACC_HOR
    land_speed_m_s: float = 0.7  # MPC_LAND_SPEED: the whole descent of NAV_LAND and of a return


DEFAULTS = Px4()


def replay(items: list[Item], speed_m_s: float, gimbal: Gimbal, prm: Px4 = DEFAULTS) -> Replay:
    veh = Vehicle(speed_m_s, prm.accel_m_s2, prm.yaw_rate_deg_s, gimbal)
    out = Replay("px4")

    def run(until) -> bool:
        while not until():
            veh.step()
            if veh.t > MAX_TIME_S:
                return False
        return True

    for k, it in enumerate(items):
        c, p = it.command, it.params
        if c in (mav.NAV_RETURN_TO_LAUNCH, mav.NAV_LAND):  # home at the altitude it has (RTL), or there; landing
            veh.land((0.0, 0.0, 0.0) if c == mav.NAV_RETURN_TO_LAUNCH else it.xyz, ((0.0, prm.land_speed_m_s),))
            break
        if c in (mav.DO_MOUNT_CONTROL, mav.DO_GIMBAL_MANAGER_PITCHYAW):
            veh.aim_gimbal(p[0])
        elif c == mav.IMAGE_START_CAPTURE or (c == mav.DO_DIGICAM_CONTROL and p[4] == 1):
            out.photos.append(veh.photo(k))
        elif c == NAV_DELAY:
            t0, wait = veh.t, max(p[0], 0.0)
            run(lambda t0=t0, wait=wait: veh.t - t0 >= wait - 1e-9)
        elif c == mav.NAV_TAKEOFF:
            alt = it.xyz[2] if math.isfinite(it.xyz[2]) else p[6]
            veh.target = np.array([veh.p[0], veh.p[1], alt])
            veh.yaw_target = p[3] if math.isfinite(p[3]) else None
            radius = prm.alt_acceptance_m if not 0 < alt < prm.alt_acceptance_m else alt / 2
            if not run(lambda floor=alt - radius: veh.p[2] > floor):
                out.notes.append(f"item {k + 1}: the take-off altitude is never reached")
                break
        elif c == mav.NAV_WAYPOINT and math.isfinite(it.xyz[0]):
            target = np.array(it.xyz)
            veh.target = target
            yaw = p[3] if math.isfinite(p[3]) else None
            accept = p[1] if math.isfinite(p[1]) and p[1] > 1e-6 else prm.acceptance_m
            hold = max(p[0], 0.0) if math.isfinite(p[0]) else 0.0
            state = {"reached": None}

            def done(target=target, yaw=yaw, accept=accept, hold=hold, state=state) -> bool:
                if yaw is None:
                    b = veh.bearing_to(target)
                    if b is not None and float(np.hypot(*(target[:2] - veh.p[:2]))) > 1.0:
                        veh.yaw_target = b
                else:
                    veh.yaw_target = yaw
                d = target - veh.p
                if state["reached"] is None and math.hypot(d[0], d[1]) <= accept and abs(d[2]) <= prm.alt_acceptance_m:
                    state["reached"] = veh.t
                if state["reached"] is None:
                    return False
                if yaw is not None and abs(wrap180(yaw - veh.yaw)) >= prm.yaw_error_deg:
                    return False
                return veh.t - state["reached"] >= hold - 1e-9

            if not run(done):
                out.notes.append(f"item {k + 1}: the waypoint is never reached")
                break
        else:
            out.notes.append(f"item {k + 1}: command {c} is not replayed")
    out.time_s = veh.t
    return out
