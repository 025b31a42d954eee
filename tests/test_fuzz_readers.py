"""Every reader fuzzed: any input gives a result or one clear error of sightplan's own (a SightplanError), never
another exception, and a result holds no NaN: it writes back as a plan file and exports to a map without one.

Each reader starts from a good file of its format and gets its numbers replaced by hostile ones (NaN, infinities,
1e308, huge counts, text), or its bytes cut short or overwritten. Bounded and repeatable: a few derandomised examples
per reader, so the whole file runs in seconds.
"""

from __future__ import annotations

import json
import re
import struct
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from sightplan.camera.catalogue import get_camera
from sightplan.errors import SightplanError
from sightplan.geo import Georeference
from sightplan.geometry.poses import R_from_gimbal
from sightplan.plan.types import Mission, Plan

EXAMPLES = 40
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck), phases=[Phase.explicit, Phase.generate])
GEO = Georeference.from_origin(47.3769, 8.5417, 408.0)
#: Numbers a careless user or an attacker writes
HOSTILE = ["NaN", "nan", "Infinity", "-inf", "1e308", "-1e308", "1e400", "1e-320", "0", "-0", "-1", "360.5",
           "-90.0000001", "18446744073709551617", "99999999999", "", "x", "1e9", "0.0001"]
NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])")


@pytest.fixture(autouse=True)
def small_photo_budget(monkeypatch):
    """A mission may take 2,000 photos here, not 100,000: the refusal above it is what is exercised, in moments."""
    from sightplan.plan import domain

    monkeypatch.setattr(domain, "MAX_MISSION_PHOTOS", 2000)


def small_plan() -> Plan:
    """Three frames on two missions around the origin, as a template would make them."""
    C = np.array([[0.0, -20.0, 12.0], [10.0, -20.0, 12.0], [20.0, -20.0, 15.0]])
    R = R_from_gimbal(np.array([0.0, 10.0, 350.0]), np.array([-30.0, -45.0, 0.0]), 0.0)
    return Plan.build(get_camera("m3e"), R, C, missions=(Mission("one", 0, 2), Mission("two", 2, 3)),
                      capture_time=np.array([1.7e9, 1.7e9 + 2, np.nan]), waypoints=C)


def mutations(text: str):
    """Strategy: ``text`` with up to four of its numbers replaced by hostile ones."""
    spans = [m.span() for m in NUMBER.finditer(text)]
    assert spans, "a sample with no number to replace"
    edits = st.lists(st.tuples(st.integers(0, len(spans) - 1), st.sampled_from(HOSTILE)), min_size=0, max_size=4)

    def apply(changes):
        out = text
        for k, value in sorted(dict(changes).items(), reverse=True):
            a, b = spans[k]
            out = out[:a] + value + out[b:]
        return out

    return edits.map(apply)


def damaged(data: bytes):
    """Strategy: ``data`` cut short, or with a few bytes overwritten (by hostile doubles and counts, or garbage)."""
    nasty = [struct.pack("<d", v) for v in (float("nan"), float("inf"), 1e308, -1e308)] + \
            [struct.pack("<Q", v) for v in (2**63, 2**40, 0)] + [b"\xff" * 4, b"\x00" * 4]
    cut = st.integers(0, len(data)).map(lambda n: data[:n])
    poke = st.lists(st.tuples(st.integers(0, max(len(data) - 8, 0)), st.sampled_from(nasty)), min_size=1,
                    max_size=4).map(lambda edits: _poked(data, edits))
    return st.one_of(cut, poke, st.binary(max_size=200))


def _poked(data: bytes, edits) -> bytes:
    out = bytearray(data)
    for at, value in edits:
        out[at:at + len(value)] = value[:len(out) - at]
    return bytes(out)


def sound(plan: Plan, tmp: Path) -> None:
    """A plan a reader returned: finite poses, and it writes as a plan file and a KML map with no NaN."""
    from sightplan.export import export_plan
    from sightplan.plan.format import read_plan, write_plan

    assert np.isfinite(plan.C_world).all() and np.isfinite(plan.R_world_camera).all()
    assert np.isfinite(np.asarray(plan.waypoints, float)).all()
    if len(plan) > 500:  # a trigger's thousands of photos: the numbers only, not a slow round trip
        json.dumps(plan.parameters, allow_nan=False, default=lambda v: np.asarray(v).tolist())
        return
    write_plan(plan, tmp / "back.json")  # refuses NaN anywhere in it, parameters included
    assert len(read_plan(tmp / "back.json")) == len(plan)
    if len(plan):
        try:
            paths = export_plan(plan, "kml", tmp / "map.kml", GEO, plan.C_world[0] - [0, 0, 10])
        except SightplanError:
            return
        assert all("nan" not in Path(p).read_text(encoding="utf-8").lower() for p in paths)


def outcome(read, path: Path, tmp: Path) -> None:
    """``read(path)`` gives a sound result or one SightplanError with a message; nothing else escapes."""
    try:
        result = read(path)
    except SightplanError as exc:
        assert str(exc).strip(), "an error without a message"
        return
    if isinstance(result, Plan):
        sound(result, tmp)


@pytest.fixture(scope="module")
def samples(tmp_path_factory) -> dict[str, Path]:
    """A good file of every format, from the exporters where sightplan writes it, else written by hand."""
    from sightplan.export import export_plan
    from sightplan.plan.format import write_plan

    folder = tmp_path_factory.mktemp("samples")
    plan = small_plan()
    out = {}
    write_plan(plan, folder / "plan.json")
    out["sightplan"] = folder / "plan.json"
    for fmt, name in (("wpl", "m.waypoints"), ("qgc", "m.plan"), ("litchi", "m.csv"), ("wpml", "m.kmz")):
        paths = export_plan(plan, fmt, folder / name, GEO, [0.0, -25.0, 0.0], mission=0, faithful=False,
                            aircraft="m3e" if fmt == "wpml" else None)
        out[fmt] = Path(paths[0])
    (folder / "poses.csv").write_text("name,x,y,z,heading_deg,pitch_deg,roll_deg,camera,time\n"
                                      "a.jpg,1,2,30,90,-10,0,p4p,2024-05-01T10:00:00\n"
                                      "b.jpg,4.5,5,30,0,-90,0,,1714557601.5\n"
                                      "c.jpg,-1,0,2,180,0,0,,\n")
    out["csv"] = folder / "poses.csv"
    (folder / "schedule.csv").write_text("task_id,name,start,finish,actual_start,parent,global_ids\n"
                                         "1,Walls,2024-05-01,2024-05-20,2024-05-02,,0abc;1def\n"
                                         "2,Roof,26-5-2024,2024-06-10T08:00,,1,2ghi\n")
    out["schedule"] = folder / "schedule.csv"
    return out


# --------------------------------------------------------------------------- flight-app missions and plan files
def _loader(fmt: str):
    from sightplan.plan.load import load_plan

    return lambda path: load_plan(path, fmt=fmt, camera="m3e", georef=GEO, ground_z=0.0)


@pytest.mark.parametrize("fmt", ["sightplan", "wpl", "qgc", "litchi", "csv"])
def test_text_formats_with_hostile_numbers(samples, tmp_path, fmt):
    text = samples[fmt].read_text(encoding="utf-8")
    path = tmp_path / samples[fmt].name

    @FUZZ
    @given(mutations(text))
    def run(mutated):
        path.write_text(mutated, encoding="utf-8")
        outcome(_loader(fmt), path, tmp_path)

    run()


@pytest.mark.parametrize("fmt", ["sightplan", "wpl", "qgc", "litchi", "csv"])
def test_text_formats_cut_short_or_garbled(samples, tmp_path, fmt):
    data = samples[fmt].read_bytes()
    path = tmp_path / samples[fmt].name

    @FUZZ
    @given(damaged(data))
    def run(broken):
        path.write_bytes(broken)
        outcome(_loader(fmt), path, tmp_path)

    run()


def test_plan_json_with_hostile_structure(tmp_path):
    """JSON of the right shape with values of the wrong kind or size anywhere."""
    from sightplan.plan.format import plan_from_dict, plan_to_dict

    base = plan_to_dict(small_plan())
    leaves = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**70, 2**70), st.text(max_size=4),
                       st.none(), st.booleans(), st.lists(st.floats(), max_size=4))

    @FUZZ
    @given(st.sampled_from(["position", "rotation", "time", "heading_deg", "quaternion_wxyz", "camera", "name"]),
           st.integers(0, 2), leaves, st.sampled_from(["frames", "missions", "waypoints", "parameters", "cameras"]),
           leaves)
    def run(field, frame, value, top, other):
        d = json.loads(json.dumps(base))
        d["frames"][frame][field] = value
        if field in ("heading_deg", "quaternion_wxyz"):
            d["frames"][frame].pop("rotation", None)
        if other is not None and top != "frames":
            d[top] = other
        outcome(plan_from_dict, d, tmp_path)

    run()


def test_wpml_waylines_with_hostile_numbers(samples, tmp_path):
    with zipfile.ZipFile(samples["wpml"]) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    name = next(n for n in entries if n.endswith("waylines.wpml"))
    text = entries[name].decode("utf-8")
    path = tmp_path / "m.kmz"

    @FUZZ
    @given(mutations(text), st.booleans())
    def run(mutated, bare):
        if bare:  # a waylines.wpml on its own
            path.with_suffix(".wpml").write_text(mutated, encoding="utf-8")
            outcome(_loader("wpml"), path.with_suffix(".wpml"), tmp_path)
            return
        with zipfile.ZipFile(path, "w") as z:
            for n, data in entries.items():
                z.writestr(n, mutated.encode("utf-8") if n == name else data)
        outcome(_loader("wpml"), path, tmp_path)

    run()


def test_kmz_cut_short_or_garbled(samples, tmp_path):
    data = samples["wpml"].read_bytes()
    path = tmp_path / "m.kmz"

    @FUZZ
    @given(damaged(data))
    def run(broken):
        path.write_bytes(broken)
        outcome(_loader("wpml"), path, tmp_path)

    run()


def triggered_missions(folder: Path) -> dict[str, Path]:
    """Missions whose photos come from triggers, counts and layers: a QGroundControl plan with a StructureScan, a
    distance trigger and a photo count, and a DJI wayline with a distance trigger and a ranged action group."""
    lat, lon = 47.398, 8.5461
    item = lambda command, frame, params, n: {"type": "SimpleItem", "command": command, "frame": frame,  # noqa: E731
                                              "params": params, "autoContinue": True, "doJumpId": n}
    scan = {"type": "ComplexItem", "complexItemType": "StructureScan", "version": 3, "EntranceAltitude": 50,
            "GimbalPitch": 0, "Layers": 2, "ScanBottomAlt": 50, "StartFromTop": True, "StructureHeight": 100,
            "CameraCalc": {"AdjustedFootprintFrontal": 25, "AdjustedFootprintSide": 25, "DistanceToSurface": 50,
                           "CameraName": "Manual (no camera specs)", "DistanceToSurfaceRelative": True, "version": 1},
            "polygon": [[lat, lon + 0.0003], [lat - 0.0001, lon + 0.0008], [lat - 0.0006, lon + 0.0006],
                        [lat - 0.0005, lon + 0.0001]]}
    mission = {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl", "geoFence": {}, "rallyPoints": {},
               "mission": {"cruiseSpeed": 15, "firmwareType": 12, "hoverSpeed": 5, "vehicleType": 2, "version": 2,
                           "plannedHomePosition": [lat, lon, 488.25],
                           "items": [item(22, 3, [0, 0, 0, None, lat, lon, 30], 1), scan,
                                     item(206, 2, [5, 0, 1, 0, 0, 0, 0], 20),
                                     item(16, 3, [0, 0, 0, None, lat + 0.0005, lon, 30], 21),
                                     item(2000, 2, [0, 0, 3, 0, 0, 0, 0], 22),
                                     item(20, 2, [0, 0, 0, 0, 0, 0, 0], 23)]}}
    (folder / "scan.plan").write_text(json.dumps(mission, indent=1))
    group = ("<wpml:actionGroup><wpml:actionGroupId>{g}</wpml:actionGroupId><wpml:actionGroupStartIndex>{a}"
             "</wpml:actionGroupStartIndex><wpml:actionGroupEndIndex>{b}</wpml:actionGroupEndIndex><wpml:actionTrigger>"
             "<wpml:actionTriggerType>{kind}</wpml:actionTriggerType><wpml:actionTriggerParam>{param}"
             "</wpml:actionTriggerParam></wpml:actionTrigger><wpml:action><wpml:actionActuatorFunc>takePhoto"
             "</wpml:actionActuatorFunc></wpml:action></wpml:actionGroup>")
    marks = "".join(
        f"<Placemark><Point><coordinates>{lon + 0.0002 * k!r},{lat!r}</coordinates></Point><wpml:index>{k}</wpml:index>"
        f"<wpml:executeHeight>20</wpml:executeHeight>"
        + (group.format(g=0, a=0, b=2, kind="multipleDistance", param=10) if k == 0 else "")
        + (group.format(g=1, a=1, b=2, kind="reachPoint", param=0) if k == 1 else "") + "</Placemark>"
        for k in range(3))
    doc = ("<kml xmlns='http://www.opengis.net/kml/2.2' xmlns:wpml='http://www.dji.com/wpmz/1.0.6'><Document>"
           f"<wpml:missionConfig><wpml:takeOffRefPoint>{lat!r},{lon!r},500</wpml:takeOffRefPoint></wpml:missionConfig>"
           "<Folder><wpml:executeHeightMode>relativeToStartPoint</wpml:executeHeightMode><wpml:waylineId>0"
           f"</wpml:waylineId><wpml:autoFlightSpeed>5</wpml:autoFlightSpeed>{marks}</Folder></Document></kml>")
    (folder / "waylines.wpml").write_text(doc)
    return {"qgc": folder / "scan.plan", "wpml": folder / "waylines.wpml"}


@pytest.mark.parametrize("fmt", ["qgc", "wpml"])
def test_triggers_counts_and_layers_with_hostile_numbers(tmp_path, fmt):
    """A trigger every 1e-320 m, a billion layers or photos, an action group up to index 1e18: refused at once."""
    good = triggered_missions(tmp_path)[fmt]
    outcome(_loader(fmt), good, tmp_path)  # the sample itself reads
    text = good.read_text()
    path = tmp_path / f"fuzzed{good.suffix}"

    @FUZZ
    @given(mutations(text))
    def run(mutated):
        path.write_text(mutated)
        outcome(_loader(fmt), path, tmp_path)

    run()


# --------------------------------------------------------------------------- reconstructions
def test_colmap_text_with_hostile_numbers(tmp_path):
    from test_plan_imports import _known_poses, _write_colmap_text_by_hand

    _write_colmap_text_by_hand(tmp_path / "good", *_known_poses())
    files = {n: (tmp_path / "good" / n).read_text() for n in ("cameras.txt", "images.txt")}
    folder = tmp_path / "m"
    folder.mkdir()

    @FUZZ
    @given(st.sampled_from(sorted(files)), st.data())
    def run(which, data):
        for n, text in files.items():
            (folder / n).write_text(data.draw(mutations(text)) if n == which else text)
        outcome(_loader("colmap"), folder, tmp_path)

    run()


def test_colmap_binary_damaged(tmp_path):
    from test_plan_imports import _known_poses, _write_colmap_binary_by_hand

    (tmp_path / "good").mkdir()
    _write_colmap_binary_by_hand(tmp_path / "good", *_known_poses())
    files = {n: (tmp_path / "good" / n).read_bytes() for n in ("cameras.bin", "images.bin")}
    folder = tmp_path / "m"
    folder.mkdir()

    @FUZZ
    @given(st.sampled_from(sorted(files)), st.data())
    def run(which, data):
        for n, blob in files.items():
            (folder / n).write_bytes(data.draw(damaged(blob)) if n == which else blob)
        outcome(_loader("colmap"), folder, tmp_path)

    run()


def test_opensfm_with_hostile_numbers(tmp_path):
    from test_plan_imports import _synthetic_opensfm

    text = _synthetic_opensfm(tmp_path).read_text()
    path = tmp_path / "reconstruction.json"

    @FUZZ
    @given(mutations(text))
    def run(mutated):
        path.write_text(mutated)
        outcome(_loader("opensfm"), path, tmp_path)

    run()


# --------------------------------------------------------------------------- schedules and point clouds
def test_csv_schedule_with_hostile_values(samples, tmp_path):
    from sightplan.schedule.csvfile import read_csv

    text = samples["schedule"].read_text()
    path = tmp_path / "schedule.csv"
    dates = st.sampled_from(["9999-99-99", "0000-01-01", "1-13-2024", "2024-02-30", "99999-01-01", "", "x",
                             "2024-05-01T25:00", "-1"])

    @FUZZ
    @given(mutations(text), st.lists(dates, max_size=2))
    def run(mutated, more):
        for value in more:  # dates replaced too, not only their numbers
            mutated = mutated.replace("2024-05-01", value, 1)
        path.write_text(mutated)
        outcome(read_csv, path, tmp_path)

    run()


@pytest.mark.parametrize("compressed", [False, True])
def test_las_laz_headers_damaged(tmp_path, compressed):
    laspy = pytest.importorskip("laspy")
    if compressed and not laspy.LazBackend.detect_available():
        pytest.skip("no LAZ backend")
    from sightplan.model.pointcloud import read_point_cloud

    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales, header.offsets = np.array([0.01, 0.01, 0.01]), np.zeros(3)
    las = laspy.LasData(header)
    las.x, las.y, las.z = (np.arange(20, dtype=float) + k for k in range(3))
    good = tmp_path / f"good.{'laz' if compressed else 'las'}"
    las.write(str(good))
    data = good.read_bytes()
    path = tmp_path / f"cloud.{'laz' if compressed else 'las'}"
    head = 375  # the public header block and a little more: sizes, counts, scales, offsets, bounds

    @FUZZ
    @given(st.lists(st.tuples(st.integers(0, head - 8), st.sampled_from(
        [struct.pack("<d", v) for v in (float("nan"), float("inf"), 1e308, 0.0)]
        + [struct.pack("<I", v) for v in (0, 2**32 - 1, 10**9)] + [b"\xff\xff", b"\x00\x00"])), min_size=1,
        max_size=4), st.integers(len(data) // 2, len(data)))
    def run(edits, keep):
        path.write_bytes(_poked(data, edits)[:keep])
        try:
            cloud = read_point_cloud(path)
        except SightplanError as exc:
            assert str(exc).strip()
            return
        assert np.isfinite(cloud.points).all()

    run()
