"""Missions replayed under their autopilots' rules (:mod:`sightplan.flight`): the rules as facts on one-waypoint
missions whose answer is known by hand, and every export of the templates on the Duplex and on the site fixture
read back by an independent reader (``json`` for ``.plan``, pymavlink's ``MAVWPLoader`` for WPL), flown, and its
photos compared with the plan's frames (model frame, through the georeference: not through the exporter)."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from pyproj import Proj

from sightplan.camera.catalogue import get_camera
from sightplan.export import export_plan
from sightplan.flight import Gimbal
from sightplan.flight.fidelity import flight_fidelity
from sightplan.flight.replay import simulate_items
from sightplan.flight.simulate import Item, local_items
from sightplan.formats import mavlink
from sightplan.formats.flight import build_flight
from sightplan.geo import Georeference
from sightplan.geometry.poses import gimbal_from_R
from sightplan.model.load import load_model
from sightplan.plan.checks.feasibility import FlightSettings
from sightplan.plan.templates.registry import plan_from_template
from site_fixture import write_basement_house

NAN3 = (math.nan, math.nan, math.nan)


def mission(*items: Item) -> list[Item]:
    return [Item(22, (0, 0, 0, 0, 0, 0, 10.0), (0.0, 0.0, 10.0)), *items]


def waypoint(north: float, hold: float = 0.0, accept: float = 0.0, yaw: float = 0.0) -> Item:
    return Item(16, (hold, accept, 0, yaw, 0, 0, 10.0), (0.0, north, 10.0))


PHOTO = Item(2000, (0, 0, 1, 0, 0, 0, 0), NAN3)


def mount(pitch: float) -> Item:
    return Item(205, (pitch, 0, 0, 0, 0, 0, 2), NAN3)


# ---- the rules, on missions known by hand ---------------------------------------------------------------------
def test_px4_takes_the_photo_as_it_enters_the_acceptance_radius():
    # navigator/mission_block.cpp, MissionBlock::is_mission_item_reached: param2 = 0 → NAV_ACC_RAD (2 m); the photo
    # item after the waypoint is reached in the same cycle, while the aircraft still flies at it
    rep = simulate_items(mission(waypoint(40.0), PHOTO), "px4", 5.0)
    (photo,) = rep.photos
    assert 40.0 - photo.xyz[1] == pytest.approx(2.0, abs=5.0 * 0.02)  # one replay step at 5 m/s
    # an explicit radius (param2) and a hold (param1): the photo waits until the aircraft is on the waypoint
    (photo,) = simulate_items(mission(waypoint(40.0, hold=1.0, accept=0.5), PHOTO), "px4", 5.0).photos
    assert photo.xyz == pytest.approx((0.0, 40.0, 10.0), abs=1e-6)


def test_px4_accepts_a_yaw_within_mis_yaw_err_and_ardupilot_within_2_degrees():
    # a 90° turn ordered at a waypoint already under the aircraft: PX4 shoots at 12° (MIS_YAW_ERR) short of it
    (photo,) = simulate_items(mission(waypoint(0.0, yaw=90.0), PHOTO), "px4", 5.0).photos
    assert 90.0 - photo.heading_deg == pytest.approx(12.0, abs=45.0 * 0.02)
    # ArduPilot: CONDITION_YAW is verified within 2° (mode_auto.cpp, ModeAuto::verify_yaw)
    items = [Item(22, (0, 0, 0, 0, 0, 0, 10.0), (0.0, 0.0, 10.0)), waypoint(0.0),
             Item(115, (90, 0, 0, 0, 0, 0, 0), NAN3), PHOTO, waypoint(0.0, hold=5.0)]
    (photo,) = simulate_items(items, "ardupilot", 5.0).photos
    assert 90.0 - photo.heading_deg == pytest.approx(2.0, abs=60.0 * 0.02)


def test_a_photo_right_after_a_gimbal_command_is_taken_while_it_moves():
    gimbal = Gimbal(rate_deg_s=30.0, settle_s=0.5)
    (photo,) = simulate_items(mission(waypoint(0.0, hold=1.0), mount(-90.0), PHOTO), "px4", 5.0, gimbal).photos
    assert photo.pitch_deg == 0.0 and not photo.gimbal_still  # DO_MOUNT_CONTROL is "reached" at once
    wait = Item(93, (gimbal.wait_s(90.0), -1, -1, -1, 0, 0, 0), NAN3)
    (photo,) = simulate_items(mission(waypoint(0.0, hold=1.0), mount(-90.0), wait, PHOTO), "px4", 5.0, gimbal).photos
    assert photo.pitch_deg == -90.0 and photo.gimbal_still
    assert gimbal.wait_s(90.0) == pytest.approx(3.5)  # 90° at 30°/s, then 0.5 s to settle


def test_ardupilot_drops_the_commands_a_short_hold_leaves_behind():
    # AP_Mission::advance_current_nav_cmd: the DO commands after a waypoint run while the next one flies; when that
    # one completes first (hold 0 at the same place), the rest never run
    turn = Item(115, (180, 0, 0, 0, 0, 0, 0), NAN3)
    rep = simulate_items([Item(22, (0, 0, 0, 0, 0, 0, 10.0), (0.0, 0.0, 10.0)), waypoint(0.0), turn, PHOTO,
                          waypoint(0.0, hold=0.0), waypoint(20.0)], "ardupilot", 5.0)
    assert rep.photos == [] and "dropped" in rep.notes[0]
    rep = simulate_items([Item(22, (0, 0, 0, 0, 0, 0, 10.0), (0.0, 0.0, 10.0)), waypoint(0.0), turn, PHOTO,
                          waypoint(0.0, hold=4.0), waypoint(20.0)], "ardupilot", 5.0)
    assert len(rep.photos) == 1 and rep.photos[0].heading_deg == pytest.approx(180.0, abs=2.0)


# ---- every export of every template, flown --------------------------------------------------------------------
TEMPLATES = [("facade", {}), ("orbit", {}), ("lawnmower", {"oblique_pitch_deg": -60.0})]


@pytest.fixture(scope="module")
def sites(tmp_path_factory):
    house = load_model(str(write_basement_house(tmp_path_factory.mktemp("site") / "house.ifc")), cache=False)[0]
    return {"sample": load_model("sample")[0], "basement house": house}


def file_commands(path):
    """The file's commands and home as an independent reader gives them: json for .plan, pymavlink for WPL."""
    if path.suffix == ".plan":
        doc = json.loads(path.read_text())["mission"]
        cmds = [SimpleNamespace(command=it["command"], frame=it["frame"],
                                params=tuple(math.nan if v is None else v for v in it["params"]))
                for it in doc["items"]]
        return cmds, tuple(doc["plannedHomePosition"]), doc
    mavwp = pytest.importorskip("pymavlink.mavwp")
    loader = mavwp.MAVWPLoader()
    n = loader.load(str(path))
    items = [loader.wp(k) for k in range(n)]
    cmds = [SimpleNamespace(command=w.command, frame=w.frame, params=(w.param1, w.param2, w.param3, w.param4, w.x, w.y,
                                                                       w.z)) for w in items[1:]]
    return cmds, (items[0].x, items[0].y, items[0].z), None


@pytest.mark.parametrize("site", [pytest.param("sample", marks=pytest.mark.bench), "basement house"])
def test_every_export_takes_its_photos_at_the_frames(sites, site, tmp_path):
    scene = sites[site]
    geo = Georeference.from_scene_metadata(scene.metadata)
    worst = {}
    for name, params in TEMPLATES:
        plan, _ = plan_from_template(name, scene, get_camera("p4p"), params, FlightSettings(safety_distance_m=10.0))
        takeoff = np.asarray(plan.parameters["takeoff_m"], float)
        heading, pitch, _ = gimbal_from_R(plan.R_world_camera)
        true_heading = geo.true_heading(plan.C_world, heading)
        # each autopilot in each container on the fixture; on the sample, each autopilot in its usual one
        pairs = [("px4", "qgc"), ("ardupilot", "wpl")] + ([("px4", "wpl"), ("ardupilot", "qgc")] if site != "sample" else [])
        for autopilot, fmt in pairs:
            suffix = {"qgc": ".plan", "wpl": ".waypoints"}[fmt]
            files = export_plan(plan, fmt, tmp_path / f"{name}_{autopilot}{suffix}", geo, takeoff,
                                autopilot=autopilot)
            xyz, head, tilt = [], [], []
            for path in files:
                cmds, home, _ = file_commands(path)
                rep = simulate_items(local_items(cmds, home), autopilot, 5.0)
                assert not rep.notes, (name, autopilot, path.name, rep.notes)
                assert all(p.gimbal_still for p in rep.photos), (name, autopilot, path.name)
                proj = Proj(proj="aeqd", lat_0=home[0], lon_0=home[1], datum="WGS84", units="m")
                for p in rep.photos:
                    lon, lat = proj(p.xyz[0], p.xyz[1], inverse=True)
                    xyz.append(geo.from_geodetic(lat, lon, home[2] + p.xyz[2])[0])
                    head.append(p.heading_deg)
                    tilt.append(p.pitch_deg)
            assert len(xyz) == len(plan), (name, autopilot, fmt)
            d = np.linalg.norm(np.array(xyz) - plan.C_world, axis=1)
            a = np.maximum(np.abs((np.array(head) - true_heading + 180) % 360 - 180), np.abs(np.array(tilt) - pitch))
            worst[(name, autopilot, fmt)] = (float(d.max()), float(a.max()))
    # 1e-7° of latitude in a WPL/.plan file is 1.1 cm; float32 headings in MAVLink are within 0.01°
    assert all(m <= 0.1 and deg <= 1.0 for m, deg in worst.values()), worst


def test_the_old_px4_export_is_off_by_the_acceptance_radius(sites):
    """What the exports wrote before the replay (param1 = param2 = 0, the photo straight after the gimbal command)
    takes the facade's photos up to NAV_ACC_RAD (2 m) before the frames: refused unless forced."""
    scene = sites["sample"]
    geo = Georeference.from_scene_metadata(scene.metadata)
    plan, _ = plan_from_template("facade", scene, get_camera("p4p"), {}, FlightSettings(safety_distance_m=10.0))
    flight = build_flight(plan, geo, np.asarray(plan.parameters["takeoff_m"]), fmt="qgc")

    def unheld(f, wps):
        items = mavlink.mission_items(f, wps, "px4")
        return [{**d, "params": [0.0, 0.0, *d["params"][2:]]} if d["command"] == 16 else d for d in items
                if d["command"] != 93]

    old = flight_fidelity(flight, "px4", items_of=unheld)
    assert not old.faithful and 1.5 < old.position_m <= 2.0 + 0.1
    now = flight_fidelity(flight, "px4")
    assert now.faithful and now.taken == now.expected == len(plan)
    assert "largest deviation 0.00 m / 0.0°" in now.summary()


def test_dji_and_litchi_wait_for_the_gimbal_before_a_photo(sites, tmp_path):
    """DJI WPML and Litchi run a waypoint's actions one after the other: after every change of pitch, a wait (a
    ``hover`` action; a "stay for", type 0) comes before the photo."""
    import csv
    import zipfile
    from xml.etree import ElementTree as ET

    from geoid_support import require_geoid

    scene = sites["sample"]
    geo = Georeference.from_scene_metadata(scene.metadata)
    plan, _ = plan_from_template("lawnmower", scene, get_camera("m3e"), {"oblique_pitch_deg": -60.0},
                                 FlightSettings(safety_distance_m=10.0))
    takeoff = np.asarray(plan.parameters["takeoff_m"], float)
    require_geoid()
    waits = 0
    for path in export_plan(plan, "wpml", tmp_path / "l.kmz", geo, takeoff, aircraft="m3e"):
        doc = ET.fromstring(zipfile.ZipFile(path).read("wpmz/waylines.wpml"))
        funcs = [(a.findtext("{*}actionActuatorFunc"), a.find("{*}actionActuatorFuncParam"))
                 for a in doc.iter("{http://www.dji.com/wpmz/1.0.2}action")]
        pitch, settled = None, True
        for func, prm in funcs:
            if func == "gimbalRotate":
                p = float(prm.findtext("{*}gimbalPitchRotateAngle"))
                settled, pitch = settled and p == pitch, p
            elif func == "hover":
                assert float(prm.findtext("{*}hoverTime")) >= 0.5
                settled, waits = True, waits + 1
            elif func == "takePhoto":
                assert settled, path.name
    assert waits >= 2  # nadir and oblique legs
    stays = 0
    for path in export_plan(plan, "litchi", tmp_path / "l.csv", geo, takeoff):
        pitch = None
        for row in csv.DictReader(path.open(newline="")):
            settled = float(row["gimbalpitchangle"]) == pitch
            pitch = float(row["gimbalpitchangle"])
            for k in range(1, 16):
                kind, param = int(row[f"actiontype{k}"]), float(row[f"actionparam{k}"])
                if kind == 5:
                    settled, pitch = settled and param == pitch, param
                elif kind == 0:
                    settled, stays = param >= 500, stays + 1
                elif kind == 1:
                    assert settled, path.name
    assert stays >= 2


def test_export_says_how_its_photos_were_replayed(tmp_path):
    from test_cli import run_cli

    assert run_cli("plan", "orbit", "sample", "-o", "orbit.json", cwd=tmp_path).returncode == 0
    for autopilot, label in (("px4", "PX4"), ("ardupilot", "ArduPilot")):
        res = run_cli("export", "orbit.json", "--format", "qgc", "--autopilot", autopilot, "-o", f"{autopilot}.plan",
                      cwd=tmp_path)
        assert res.returncode == 0, res.stdout + res.stderr
        text = " ".join(res.stdout.split())  # the console wraps long lines
        files = text.count("wrote ")
        assert files >= 1 and text.count(f"simulated ({label}):") == files
        assert text.count("largest deviation 0.00 m / 0.0°") == files


def test_evaluate_as_flown_equals_the_plan_for_a_faithful_export_and_differs_for_an_unheld_one(tmp_path):
    """``evaluate --as-flown``: the replayed photos of a faithful export give the plan's metrics (the library's
    evaluation of the plan itself, here); the same file with PX4's holds and radii taken out (param1 = param2 = 0)
    takes its photos up to 2 m early, and the comparison says so."""
    from sightplan.evaluate import EvaluationSettings, evaluate
    from sightplan.plan.load import load_plan
    from test_cli import run_cli

    scene = load_model("sample")[0]
    assert run_cli("plan", "orbit", "sample", "-o", "orbit.json", cwd=tmp_path).returncode == 0
    assert run_cli("export", "orbit.json", "--format", "qgc", "--mission", "1", "-o", "m1.plan",
                   cwd=tmp_path).returncode == 0
    plan = load_plan(str(tmp_path / "orbit.json"))
    first = plan.missions[0]
    one = plan.subset(np.arange(first.start, first.stop))
    settings = EvaluationSettings(scale=0.1, engine="embree")
    res = run_cli("evaluate", "sample", "m1.plan", "--as-flown", "--scale", "0.1", "--engine", "embree",
                  "--no-picture", "--out", "faithful", cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    doc = json.loads((tmp_path / "faithful" / "as_flown.json").read_text())
    assert max(f["deviation_m"] for f in doc["frames"]) <= 0.02 and max(f["deviation_deg"] for f in doc["frames"]) < 0.1
    ref = evaluate(scene, one, settings, cache_dir=False).metrics.plan
    assert doc["as_flown"]["VC"] == ref.VC and doc["as_flown"]["VR"] == pytest.approx(ref.VR, rel=1e-3)
    assert doc["as_flown"]["VC"] == doc["planned"]["VC"]
    assert doc["as_flown"]["VR"] == pytest.approx(doc["planned"]["VR"], rel=1e-3)
    # the same mission without PX4's holds and radii
    path = tmp_path / "m1.plan"
    data = json.loads(path.read_text())
    for it in data["mission"]["items"]:
        if it["command"] == 16:
            it["params"][0] = it["params"][1] = 0
    (tmp_path / "unheld.plan").write_text(json.dumps(data))
    res = run_cli("evaluate", "sample", "unheld.plan", "--as-flown", "--scale", "0.1", "--engine", "embree",
                  "--no-picture", "--out", "unheld", cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    doc = json.loads((tmp_path / "unheld" / "as_flown.json").read_text())
    assert 1.5 < max(f["deviation_m"] for f in doc["frames"]) <= 2.1
    assert doc["as_flown"]["R"] != doc["planned"]["R"]  # the photos are nearer or farther than the frames
    assert "off their frames by up to" in " ".join(res.stdout.split())


def test_a_slower_gimbal_gets_longer_waits_and_still_shoots_still(sites, tmp_path):
    from test_cli import assert_clean_error, run_cli

    scene = sites["sample"]
    geo = Georeference.from_scene_metadata(scene.metadata)
    plan, _ = plan_from_template("lawnmower", scene, get_camera("p4p"), {"oblique_pitch_deg": -60.0},
                                 FlightSettings(safety_distance_m=10.0))
    slow = Gimbal(rate_deg_s=10.0, settle_s=1.0)
    report = []
    (path, *_) = export_plan(plan, "qgc", tmp_path / "slow.plan", geo, np.asarray(plan.parameters["takeoff_m"]),
                             report=report, gimbal=slow)
    assert all(r.simulated.faithful for r in report)
    # replayed with that gimbal, every photo is still; with the default (faster) gimbal the waits are no shorter
    cmds, home, _ = file_commands(path)
    rep = simulate_items(local_items(cmds, home), "px4", 5.0, slow)
    assert rep.photos and all(p.gimbal_still for p in rep.photos)
    holds = [c.params[0] for c in cmds if c.command == 16 and c.params[0] > 0]
    assert max(holds) >= 1.0 + 90.0 / 10.0 + 1.0  # the first pitch of a mission: 90° at 10°/s, then 1 s to settle
    assert_clean_error(run_cli("export", "x.json", "--format", "qgc", "--gimbal", "0,1", cwd=tmp_path), "--gimbal")


def test_a_mission_the_replay_flies_longer_than_a_battery_is_refused(sites, tmp_path):
    from sightplan.errors import PlanError

    scene = sites["sample"]
    geo = Georeference.from_scene_metadata(scene.metadata)
    plan, _ = plan_from_template("orbit", scene, get_camera("p4p"), {}, FlightSettings(safety_distance_m=10.0))
    takeoff = np.asarray(plan.parameters["takeoff_m"])
    report = []
    export_plan(plan, "qgc", tmp_path / "ok.plan", geo, takeoff, report=report)
    longest = max(t for r in report for t in r.simulated.mission_times_s)
    assert 30 < longest < 600 and "min take-off to landing" in report[0].summary()
    # the same plan, checked for an aircraft whose usable time is a minute less than the longest replayed mission
    checks = plan.parameters["checks"]
    craft = {**checks["settings"]["aircraft"], "flight_time_s": (longest - 60) / 0.75, "reserve": 0.25}
    short = replace_parameters(plan, {"checks": {**checks, "settings": {**checks["settings"], "aircraft": craft}}})
    with pytest.raises(PlanError, match="usable minutes"):
        export_plan(short, "qgc", tmp_path / "short.plan", geo, takeoff)
    assert not list(tmp_path.glob("short*"))  # refused before anything is written
    assert export_plan(short, "qgc", tmp_path / "short.plan", geo, takeoff, faithful=False)


def replace_parameters(plan, extra: dict):
    from dataclasses import replace

    return replace(plan, parameters={**plan.parameters, **extra})
