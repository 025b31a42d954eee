"""MAVLink exports for one flight controller (``autopilot=``): what the aircraft accepts and does.

Every template plan that is cheap to build is exported as a QGroundControl ``.plan`` and as a
``QGC WPL 110`` file for ArduPilot and for PX4, and every item of every file is checked against the
command × frame table of the firmware it is written for (facts from the autopilots' own sources,
written below as data). The files are read back with readers that are not sightplan's: ``json`` and
MAVSDK's QGroundControl importer for ``.plan``, pymavlink's ``MAVWPLoader`` for WPL; and with
sightplan's own importer, which must give back the plan's positions (1 cm) and headings (0.01°).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sightplan.camera.catalogue import get_camera
from sightplan.export import export_plan, file_summary
from sightplan.formats.mavlink import ARDUPILOT_STOP_HOLD_S
from sightplan.geo import Georeference
from sightplan.geometry.poses import gimbal_from_R
from sightplan.optimize import OptimizeSettings, Targets, optimize
from sightplan.plan import Plan
from sightplan.plan.load import load_plan
from sightplan.plan.templates import bridge, facade_grid, indoor_route, lawnmower, orbit
from test_exports import GEOREFS, TAKEOFF, angle_diff, facade_plan
from test_templates import box_scene
from test_templates_extra import bridge_scene

# ---- what each autopilot accepts ---------------------------------------------------------------------------
#
# ArduPilot, libraries/AP_Mission/AP_Mission.cpp:
# - AP_Mission::mavlink_int_to_mission_cmd takes the commands of its switch and answers
#   MAV_MISSION_UNSUPPORTED to any other;
# - it reads the frame only of the commands that AP_Mission::stored_in_location lists (they carry a
#   location): MAV_FRAME_MISSION (2), GLOBAL (0) and GLOBAL_INT (5) as absolute heights, GLOBAL_RELATIVE_ALT
#   (3) and its _INT (6) above home, GLOBAL_TERRAIN_ALT (10) and its _INT (11) above terrain (in builds with
#   terrain); any other frame is MAV_MISSION_UNSUPPORTED_FRAME. The other commands are taken in any frame.
# - AP_Mission::sanity_check_params refuses a NaN parameter, except param4 of NAV_WAYPOINT, NAV_LAND,
#   NAV_TAKEOFF and NAV_VTOL_TAKEOFF and param3-4 of NAV_VTOL_LAND, and any infinite one.
# DO_GIMBAL_MANAGER_PITCHYAW (1000) and IMAGE_START/STOP_CAPTURE (2000/2001) are in the switch of current
# releases (run by AP_Mission::start_command_camera and start_command_do_gimbal_manager_pitchyaw in
# AP_Mission_Commands.cpp); older releases lack them.
ANY_FRAME = None
AP_LOCATION_FRAMES = frozenset({0, 2, 3, 5, 6, 10, 11})
AP_WITH_LOCATION = {16, 17, 18, 19, 21, 22, 30, 31, 82, 84, 85, 92, 94, 179, 189, 191, 201}
AP_WITHOUT_LOCATION = {20, 83, 93, 112, 114, 115, 177, 178, 181, 182, 183, 184, 193, 194, 202, 203, 205, 206, 207,
                       208, 210, 211, 212, 213, 215, 216, 222, 223, 1000, 2000, 2001, 3000, 42600}
ARDUPILOT_ACCEPTED: dict[int, frozenset[int] | None] = {
    **{c: AP_LOCATION_FRAMES for c in AP_WITH_LOCATION}, **{c: ANY_FRAME for c in AP_WITHOUT_LOCATION}}
AP_NAN_ALLOWED = {16: {3}, 21: {3}, 22: {3}, 84: {3}, 85: {2, 3}}
# ArduCopter/mode_auto.cpp, ModeAuto::start_command (a command it does not know is skipped), plus the camera and
# gimbal commands that AP_Mission::start_command runs itself (AP_Mission_Commands.cpp)
COPTER_RUNS = {16, 17, 18, 19, 20, 21, 22, 31, 82, 84, 85, 92, 93, 94, 112, 114, 115, 178, 179, 189, 201, 205, 42600,
               202, 203, 206, 531, 532, 1000, 2000, 2001, 2500, 2501}

# PX4, src/modules/mavlink/mavlink_mission.cpp, MavlinkMissionManager::parse_mavlink_mission_item: an item in
# MAV_FRAME_GLOBAL (0) or GLOBAL_RELATIVE_ALT (3) (GLOBAL_INT 5 and RELATIVE_ALT_INT 6 in MISSION_ITEM_INT
# uploads) must be one of the positional commands, one in MAV_FRAME_MISSION (2) one of the others
# (MAV_MISSION_UNSUPPORTED otherwise); any other frame is MAV_MISSION_UNSUPPORTED_FRAME. CONDITION_YAW (115) is in
# neither list.
PX4_GLOBAL_FRAMES = frozenset({0, 3, 5, 6})
PX4_IN_GLOBAL_FRAMES = {16, 17, 19, 21, 22, 31, 80, 84, 85, 195, 201, 212, 400, 4501, 5000, 5001, 5002, 5003, 5004, 5100}
PX4_IN_MISSION_FRAME = {20, 80, 93, 112, 114, 177, 178, 179, 187, 189, 196, 197, 200, 201, 203, 204, 205, 206, 211, 212,
                        214, 260, 400, 530, 532, 534, 1000, 1001, 2000, 2001, 2003, 2500, 2501, 3000, 42600}
PX4_ACCEPTED: dict[int, frozenset[int]] = {
    c: (PX4_GLOBAL_FRAMES if c in PX4_IN_GLOBAL_FRAMES else frozenset()) | (
        frozenset({2}) if c in PX4_IN_MISSION_FRAME else frozenset())
    for c in PX4_IN_GLOBAL_FRAMES | PX4_IN_MISSION_FRAME}

NAV = {16, 20, 21, 22}
AUTOPILOTS = ("ardupilot", "px4")


def refusal(autopilot: str, command: int, frame: int, params: list[float]) -> str | None:
    """Why ``autopilot`` refuses this mission item, or None when it takes it."""
    if autopilot == "px4":
        frames = PX4_ACCEPTED.get(command)
        if frames is None:
            return f"command {command}: MAV_MISSION_UNSUPPORTED"
        return None if frame in frames else f"command {command} in frame {frame}: not accepted (frames {sorted(frames)})"
    if command not in ARDUPILOT_ACCEPTED:
        return f"command {command}: MAV_MISSION_UNSUPPORTED"
    frames = ARDUPILOT_ACCEPTED[command]
    if frames is not ANY_FRAME and frame not in frames:
        return f"command {command} in frame {frame}: MAV_MISSION_UNSUPPORTED_FRAME"
    for k, v in enumerate(params[:4]):
        if math.isinf(v) or (math.isnan(v) and k not in AP_NAN_ALLOWED.get(command, set())):
            return f"command {command}: param{k + 1} = {v}"
    if command not in COPTER_RUNS:
        return f"command {command}: Copter's auto mode skips it"
    return None


def test_the_tables_say_what_the_report_says():
    # Copter takes a CONDITION_YAW, PX4 refuses it; PX4 takes gimbal, camera and RTL items only in MAV_FRAME_MISSION
    assert refusal("ardupilot", 115, 2, [90, 0, 0, 0]) is None
    assert "UNSUPPORTED" in refusal("px4", 115, 2, [90, 0, 0, 0])
    for command in (205, 2000, 20):
        assert refusal("px4", command, 2, [0, 0, 1, 0]) is None
        assert refusal("px4", command, 3, [0, 0, 1, 0]) is not None
        assert refusal("ardupilot", command, 3, [0, 0, 1, 0]) is None
    assert refusal("ardupilot", 16, 1, [0, 0, 0, 0]) is not None  # MAV_FRAME_LOCAL_NED: no location frame
    assert refusal("ardupilot", 16, 3, [0, 0, 0, math.nan]) is None  # a NaN yaw: "unchanged"


# ---- the template plans --------------------------------------------------------------------------------------


def template_plans() -> dict[str, Plan]:
    """Every template on a small box (the bridge on a deck with piers), an optimised plan on the box, and the exports'
    facade fixture."""
    p4p, box = get_camera("p4p"), box_scene()
    return {
        "fixture": facade_plan(),
        "facade": facade_grid(box, p4p, 10.0),
        "lawnmower": lawnmower(box, p4p, altitude_m=30, oblique_pitch_deg=-60),
        "orbit": orbit(box, p4p, [25.0, 18.0], [10.0, 14.0], aim="surface"),
        "bridge": bridge(bridge_scene(), p4p, [[0, 0], [60, 0]], offset_m=15, clearance_below_m=2.5),
        "indoor 360": indoor_route(get_camera("theta-z1"), [[0, -20, 1.5], [0, -5, 1.5], [10, -5, 1.5]], 2.0),
        # an optimised plan: views in LKH order, missions cut where no safe leg is left
        "optimised": optimize(box, p4p, Targets(k=2), settings=OptimizeSettings(scale=0.05, cache_dir=False)).plan,
    }


@pytest.fixture(scope="module")
def plans() -> dict[str, Plan]:
    return template_plans()


def expected(plan: Plan, georef: Georeference) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The plan's centres, true headings and pitches (numbers known without the exporter), and its number of stops:
    runs of frames of one mission at one place (1 cm) with one heading."""
    h, p, _ = gimbal_from_R(plan.R_world_camera)
    mission = np.zeros(len(plan), int)
    for k, m in enumerate(plan.missions):
        mission[m.start:m.stop] = k
    C = np.asarray(plan.C_world)
    new = np.ones(len(plan), bool)
    new[1:] = ((mission[1:] != mission[:-1]) | (np.linalg.norm(np.diff(C, axis=0), axis=1) > 0.01)
               | (np.abs((h[1:] - h[:-1] + 180) % 360 - 180) > 1e-6))
    return C, georef.true_heading(C, h), p, int(new.sum())


def mavwp_items(path) -> list:
    mavwp = pytest.importorskip("pymavlink.mavwp")
    loader = mavwp.MAVWPLoader()
    n = loader.load(str(path))
    return [loader.wp(k) for k in range(n)]


# ---- every command of every export is accepted ---------------------------------------------------------------


@pytest.mark.parametrize("autopilot", AUTOPILOTS)
def test_every_export_is_accepted_by_its_autopilot(tmp_path, plans, autopilot):
    georef, _ = GEOREFS["projected"]
    checked = 0
    for name, plan in plans.items():
        for fmt, ext in (("qgc", "plan"), ("wpl", "waypoints")):
            folder = tmp_path / f"{name}_{fmt}".replace(" ", "_")
            folder.mkdir()
            paths = export_plan(plan, fmt, folder / f"x.{ext}", georef, TAKEOFF, autopilot=autopilot)
            assert len(paths) == max(1, len(plan.missions))
            for path in paths:
                if fmt == "qgc":
                    doc = json.loads(path.read_text())
                    assert doc["mission"]["firmwareType"] == {"ardupilot": 3, "px4": 12}[autopilot]
                    rows = [(it["command"], it["frame"], it["params"]) for it in doc["mission"]["items"]]
                else:
                    items = mavwp_items(path)
                    assert (items[0].command, items[0].frame) == (16, 0)  # home, absolute
                    rows = [(w.command, w.frame, [w.param1, w.param2, w.param3, w.param4]) for w in items]
                for command, frame, params in rows:
                    why = refusal(autopilot, command, frame, params)
                    assert why is None, f"{name}, {path.name}: {why}"
                    checked += 1
                commands = {r[0] for r in rows}
                assert commands <= {16, 20, 21, 22, 93, 112, 115, 205, 2000}
                assert (115 in commands) == (autopilot == "ardupilot")
    assert checked > 2000


# ---- headings read back by pymavlink --------------------------------------------------------------------------


def fly_ardupilot(items) -> list[tuple[float, float, float, float, float]]:
    """(lat, lon, alt above home, heading, pitch) of each photo, as Copter flies the items: a NAV_WAYPOINT's yaw is
    dropped and the yaw reset by every waypoint it starts, so a photo's heading is a CONDITION_YAW given after the
    first command that follows the last waypoint; the photo must then be taken holding in place: the next
    positional item is a waypoint at the same place with a hold time."""
    photos, at, heading, pitch, after_nav = [], None, None, None, 0
    for k, w in enumerate(items[1:], start=1):
        if w.command in NAV:
            at, heading, after_nav = (w.x, w.y, w.z), None, 0
            continue
        after_nav += 1
        if w.command == 115:
            assert (w.param2, w.param3, w.param4) == (0, 0, 0)  # default rate, shortest turn, absolute
            assert after_nav > 1, "the first command after a waypoint starts before the next one resets the yaw"
            heading = w.param1
        elif w.command == 205:
            pitch = w.param1
        elif w.command == 2000:
            assert heading is not None, "a photo with no CONDITION_YAW since the last waypoint"
            nxt = next(x for x in items[k + 1:] if x.command in NAV)
            assert nxt.command == 16 and (nxt.x, nxt.y, nxt.z) == at and nxt.param1 >= ARDUPILOT_STOP_HOLD_S
            photos.append((*at, heading, pitch))
    return photos


def fly_px4(items) -> list[tuple[float, float, float, float, float]]:
    """As PX4 flies the items: the heading is the yaw (param4) of the last waypoint."""
    photos, at, heading, pitch = [], None, None, None
    for w in items[1:]:
        if w.command in NAV:
            at, heading = (w.x, w.y, w.z), w.param4
        elif w.command == 205:
            pitch = w.param1
        elif w.command == 2000:
            photos.append((*at, heading, pitch))
    return photos


@pytest.mark.parametrize("autopilot", AUTOPILOTS)
def test_wpl_headings_read_back_with_pymavlink(tmp_path, plans, autopilot):
    for kind, (georef, _) in GEOREFS.items():
        for name, plan in plans.items():
            C, heading, pitch, stops = expected(plan, georef)
            folder = tmp_path / f"{kind}_{name}".replace(" ", "_")
            folder.mkdir()
            photos, yaws, waypoints = [], 0, 0
            for path in export_plan(plan, "wpl", folder / "x.waypoints", georef, TAKEOFF, autopilot=autopilot):
                items = mavwp_items(path)
                home = items[0]
                assert all(w.frame == (3 if w.command in NAV - {20} else 2) for w in items[1:])
                got = fly_ardupilot(items) if autopilot == "ardupilot" else fly_px4(items)
                photos += [(lat, lon, home.z + alt, h, p) for lat, lon, alt, h, p in got]
                yaws += sum(w.command == 115 for w in items)
                # the stops: waypoints followed by a photo (PX4; the climb, the return and home are not stops)
                waypoints += sum(w.command == 16 and items[k + 1].command == 2000 for k, w in enumerate(items[1:-1], 1))
            assert len(photos) == len(plan), name
            xyz = georef.from_geodetic(*np.array([g[:3] for g in photos]).T)
            np.testing.assert_allclose(xyz, C, atol=0.01, err_msg=name)
            worst = max(angle_diff(g[3], h) for g, h in zip(photos, heading))
            assert worst < 0.01, (name, worst)
            np.testing.assert_allclose([g[4] for g in photos], pitch, atol=0.01, err_msg=name)
            if autopilot == "ardupilot":
                assert yaws == stops, name  # one CONDITION_YAW per heading held at a waypoint
            else:
                assert yaws == 0 and waypoints == stops, name  # one waypoint per heading, photos at one place repeat it


# ---- sightplan's own import -------------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt, ext", [("qgc", "plan"), ("wpl", "waypoints")])
@pytest.mark.parametrize("autopilot", AUTOPILOTS)
def test_round_trip_keeps_positions_and_headings(tmp_path, plans, autopilot, fmt, ext):
    georef, _ = GEOREFS["topocentric"]
    for name, plan in plans.items():
        folder = tmp_path / name.replace(" ", "_")
        folder.mkdir()
        paths = export_plan(plan, fmt, folder / f"x.{ext}", georef, TAKEOFF, autopilot=autopilot)
        back = [load_plan(p, georef=georef, camera="p4p") for p in paths]
        np.testing.assert_allclose(np.vstack([b.C_world for b in back]), plan.C_world, atol=0.01, err_msg=name)
        h0, p0, _ = gimbal_from_R(plan.R_world_camera)
        h1, p1, _ = (np.concatenate(v) for v in zip(*(gimbal_from_R(b.R_world_camera) for b in back)))
        assert max(angle_diff(a, b) for a, b in zip(h0, h1)) < 0.01, name
        np.testing.assert_allclose(p1, p0, atol=0.01, err_msg=name)
        for b in back:  # the waypoints repeated in place for the headings are one waypoint again
            wp = b.waypoints
            assert len(wp) and (np.linalg.norm(np.diff(wp, axis=0), axis=1) > 0.01).all(), name


# ---- MAVSDK's QGroundControl importer --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def mavsdk_mission_raw():
    """MAVSDK's MissionRaw plugin on a system discovered over the loopback (a second MAVSDK instance plays the
    autopilot); skipped when MAVSDK is missing or cannot start here."""
    mavsdk = pytest.importorskip("mavsdk")
    try:
        from mavsdk import ComponentType, Configuration, Mavsdk
        from mavsdk.plugins.mission_raw import MissionRaw
    except ImportError as exc:
        pytest.skip(f"this mavsdk ({getattr(mavsdk, '__version__', '?')}) has no native MissionRaw binding: {exc}")
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    try:
        vehicle = Mavsdk(Configuration.create_with_component_type(ComponentType.AUTOPILOT))
        vehicle.server_component()
        ground = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    except Exception as exc:  # the native library cannot load or start
        pytest.skip(f"MAVSDK cannot start: {exc}")
    try:
        if int(vehicle.add_any_connection(f"udpout://127.0.0.1:{port}")) or int(
                ground.add_any_connection(f"udpin://127.0.0.1:{port}")):
            pytest.skip("MAVSDK cannot open a loopback UDP connection")
        system = ground.first_autopilot(10.0)
        if system is None:
            pytest.skip("MAVSDK found no system on the loopback")
        yield MissionRaw(system)
    finally:
        ground.destroy()
        vehicle.destroy()


@pytest.mark.parametrize("autopilot", AUTOPILOTS)
def test_plan_read_back_with_mavsdk(tmp_path, mavsdk_mission_raw, autopilot):
    georef, offset = GEOREFS["projected"]
    plan = facade_plan()
    C, heading, pitch, _ = expected(plan, georef)
    photos, home_h = [], float(georef.to_geodetic(TAKEOFF)[2][0])
    for path in export_plan(plan, "qgc", tmp_path / "facade.plan", georef, TAKEOFF, autopilot=autopilot):
        imported = mavsdk_mission_raw.import_qgroundcontrol_mission(str(path))
        items = imported.mission_items
        doc = json.loads(path.read_text())["mission"]["items"]
        assert [(it.command, it.frame) for it in items] == [(d["command"], d["frame"]) for d in doc]
        assert [it.seq for it in items] == list(range(len(items)))
        at = yaw = tilt = None
        for it in items:  # what would be uploaded: MISSION_ITEM_INT, latitude/longitude in 1e-7 degrees
            assert refusal(autopilot, it.command, it.frame, [it.param1, it.param2, it.param3, it.param4]) is None
            if it.command in NAV:
                at, yaw = (it.x * 1e-7, it.y * 1e-7, home_h + it.z), it.param4
            elif it.command == 115:
                yaw = it.param1
            elif it.command == 205:
                tilt = it.param1
            elif it.command == 2000:
                assert (it.param1, it.param2, it.param3) == (0, 0, 1)
                photos.append((*at, yaw, tilt))
    assert len(photos) == len(plan)
    xyz = georef.from_geodetic(*np.array([g[:3] for g in photos]).T)
    np.testing.assert_allclose(xyz, C, atol=0.02)  # 1e-7° of latitude is 1.1 cm
    assert max(angle_diff(g[3], h) for g, h in zip(photos, heading)) < 0.01  # float32 parameters
    np.testing.assert_allclose([g[4] for g in photos], pitch, atol=0.01)


def test_file_summary_names_the_autopilot():
    assert file_summary("qgc") == "QGroundControl plan for PX4"
    assert file_summary("wpl") == "QGC WPL 110 waypoints for ArduPilot"
    assert file_summary("qgc", "ardupilot") == "QGroundControl plan for ArduPilot"
    assert file_summary("wpml", "px4") == "DJI WPML"
