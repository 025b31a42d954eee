"""Ground rovers and walkers: routes split by time and distance, worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from sightplan.camera.catalogue import get_camera
from sightplan.errors import PlanError
from sightplan.plan.checks import ROVERS, MissionTime, Rover, split_by_rover
from sightplan.plan.types import Mission, Plan

THETA = get_camera("theta-z1")


def route(xs, missions=None) -> Plan:
    """Frames at (x, 0, 1.6) for each x, one mission unless ``missions`` says otherwise."""
    C = np.column_stack([np.asarray(xs, float), np.zeros(len(xs)), np.full(len(xs), 1.6)])
    return Plan.build(THETA, np.tile(np.eye(3), (len(xs), 1, 1)), C, missions=missions)


def spans(plan: Plan) -> list[tuple[int, int]]:
    return [(m.start, m.stop) for m in plan.missions]


def check_parts(plan: Plan, split: Plan, times: list[MissionTime], rover: Rover) -> None:
    """Every frame kept once and in order, missions consecutive, every part within both limits."""
    assert len(split) == len(plan)
    np.testing.assert_array_equal(split.C_world, plan.C_world)
    covered = np.concatenate([np.arange(t.start, t.stop) for t in times])
    np.testing.assert_array_equal(covered, np.arange(len(plan)))
    assert [(t.start, t.stop) for t in times] == spans(split)
    for t in times:
        assert t.time_s <= rover.usable_s + 1e-9
        assert t.distance_m <= rover.usable_m + 1e-9


def test_split_by_time_along_a_straight_route():
    # 11 frames 10 m apart (100 m). 1 m/s, 5 s a shot, 60 s a battery, no reserve.
    # Part 1 from frame 0: b frames take 10·(b − 1) + 5·b s: b = 4 → 50 s (b = 5 → 65 s).
    # Part 2 resumes at frame 3: each frame costs a 10 m leg and a shot, 15 s: 4 frames → 60 s exactly.
    # Part 3: frames 8–10, 45 s. Distances 30, 40, 30 m: the whole 100 m route.
    rover = Rover("test", speed_m_s=1.0, capture_s=5.0, limit_time_s=60.0, reserve=0.0)
    plan = route(np.arange(11) * 10.0)
    split, times = split_by_rover(plan, rover)
    assert spans(split) == [(0, 4), (4, 8), (8, 11)]
    assert [t.time_s for t in times] == pytest.approx([50, 60, 45])
    assert [t.distance_m for t in times] == pytest.approx([30, 40, 30])
    assert [m.name for m in split.missions] == ["mission 1 (1)", "mission 1 (2)", "mission 1 (3)"]
    check_parts(plan, split, times, rover)


def test_split_by_distance_with_a_reserve():
    # 50 m of range, half kept back: 25 m a part. Part 1: frames 0–2 (20 m; frame 3 would make 30 m);
    # later parts start with the 10 m leg from where the last one stopped: 2 frames (20 m) each
    rover = Rover("test", speed_m_s=1.0, capture_s=0.0, limit_distance_m=50.0, reserve=0.5)
    plan = route(np.arange(11) * 10.0)
    split, times = split_by_rover(plan, rover)
    assert spans(split) == [(0, 3), (3, 5), (5, 7), (7, 9), (9, 11)]
    assert [t.distance_m for t in times] == pytest.approx([20] * 5)
    assert sum(t.distance_m for t in times) == pytest.approx(100.0)
    check_parts(plan, split, times, rover)


def test_split_where_either_limit_binds_first():
    # frames at x = 0, 10, 20, 21, 22, 23, 24, 25; 1 m/s, 5 s a shot, 40 s and 15 m a part.
    # Part 1: frames 0, 1 (10 m, 20 s); frame 2 would need 20 m > 15 m: the distance binds.
    # Part 2 resumes at x = 10: frames 2–6 cover 14 m and take 14 + 5·5 = 39 s; frame 7 would take 45 s: time binds.
    # Part 3: frame 7, 1 m and 6 s.
    rover = Rover("test", speed_m_s=1.0, capture_s=5.0, limit_time_s=40.0, limit_distance_m=15.0, reserve=0.0)
    plan = route([0, 10, 20, 21, 22, 23, 24, 25])
    split, times = split_by_rover(plan, rover)
    assert spans(split) == [(0, 2), (2, 7), (7, 8)]
    assert [t.time_s for t in times] == pytest.approx([20, 39, 6])
    assert [t.distance_m for t in times] == pytest.approx([10, 14, 1])
    check_parts(plan, split, times, rover)


def test_missions_are_split_separately_and_kept_whole_when_they_fit():
    # two missions of 3 frames 10 m apart (the 100 m between them is not walked): 1 m/s, 0 s shots, 25 m a part.
    # Each fits whole (20 m) and keeps its name.
    rover = Rover("test", speed_m_s=1.0, capture_s=0.0, limit_distance_m=25.0, reserve=0.0)
    plan = route([0, 10, 20, 120, 130, 140], missions=(Mission("a", 0, 3), Mission("b", 3, 6)))
    split, times = split_by_rover(plan, rover)
    assert [(m.name, m.start, m.stop) for m in split.missions] == [("a", 0, 3), ("b", 3, 6)]
    assert [t.distance_m for t in times] == pytest.approx([20, 20])
    check_parts(plan, split, times, rover)
    # with 15 m a part each mission splits after its second frame; the parts keep their mission's name
    split, times = split_by_rover(plan, Rover("test", speed_m_s=1.0, capture_s=0.0, limit_distance_m=15.0, reserve=0.0))
    assert [(m.name, m.start, m.stop) for m in split.missions] == [("a (1)", 0, 2), ("a (2)", 2, 3), ("b (1)", 3, 5),
                                                                   ("b (2)", 5, 6)]
    assert [t.distance_m for t in times] == pytest.approx([10, 10, 10, 10])


def test_a_frame_that_cannot_fit_is_refused():
    slow_shot = Rover("test", speed_m_s=1.0, capture_s=10.0, limit_time_s=9.0, reserve=0.0)
    with pytest.raises(PlanError, match="frame 0 does not fit"):
        split_by_rover(route([0, 10]), slow_shot)
    # frame 1 is 100 m from frame 0, where the walker stopped: more than the 50 m range
    short_range = Rover("test", speed_m_s=1.0, capture_s=0.0, limit_distance_m=50.0, reserve=0.0)
    with pytest.raises(PlanError, match=r"frame 1 does not fit.*100\.0 m"):
        split_by_rover(route([0, 100]), short_range)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"speed_m_s": 1.0}, "time limit, a distance limit or both"),
    ({"speed_m_s": 0.0, "limit_time_s": 60.0}, "speed"),
    ({"speed_m_s": 1.0, "limit_time_s": -1.0}, "limit_time_s"),
    ({"speed_m_s": 1.0, "limit_distance_m": 0.0}, "limit_distance_m"),
    ({"speed_m_s": 1.0, "limit_time_s": 60.0, "reserve": 1.0}, "reserve"),
    ({"speed_m_s": 1.0, "limit_time_s": 60.0, "capture_s": -1.0}, "capture"),
])
def test_rover_refuses_impossible_values(kwargs, match):
    with pytest.raises(PlanError, match=match):
        Rover("test", **kwargs)


def test_presets_split_a_long_walk():
    # the walker: 0.8 m/s, 3 s a shot, 60 min less 10 % = 3240 s. 401 frames 2 m apart (800 m):
    # part 1: b frames take 2·(b − 1)/0.8 + 3·b = 5.5·b − 2.5 s ≤ 3240 → b = 589 > 401: one part, 800/0.8 + 1203 = 2203 s
    walker = ROVERS["walker-360"]
    plan = route(np.arange(401) * 2.0)
    split, times = split_by_rover(plan, walker)
    assert spans(split) == [(0, 401)]
    assert times[0].time_s == pytest.approx(2203.0)
    # the tracked rover: 0.5 m/s, 2 s a shot, 3 h and 5 km less 20 %: 8640 s and 4000 m.
    # 1001 frames 5 m apart (5 km): each frame after the first costs a 10 s leg and a 2 s shot, so time binds:
    # part 1: 12·(b − 1) + 2 ≤ 8640 → b = 720 (8630 s, 3595 m); part 2: the other 281 frames, 12 s each (3372 s, 1405 m)
    tracked = ROVERS["tracked"]
    plan = route(np.arange(1001) * 5.0)
    split, times = split_by_rover(plan, tracked)
    assert spans(split) == [(0, 720), (720, 1001)]
    assert [t.time_s for t in times] == pytest.approx([8630, 3372])
    assert [t.distance_m for t in times] == pytest.approx([3595, 1405])
    check_parts(plan, split, times, tracked)


def test_short_walks_share_a_battery_and_a_part_cut_at_its_limit_takes_the_next():
    """Missions of 20 m, 20 m and 5 m on 50 m a battery: all three share one (45 m); a fourth walk of 20 m takes a
    second. A walk cut where its battery ran out fills that battery."""
    from sightplan.plan.checks.feasibility import battery_count

    rover = Rover("test", speed_m_s=1.0, capture_s=0.0, limit_distance_m=50.0, reserve=0.0)

    def count(xs, missions):
        _, times = split_by_rover(route(xs, missions=missions), rover)
        return battery_count(times, rover)

    three = [0, 10, 20, 100, 110, 120, 200, 205]
    assert count(three, (Mission("a", 0, 3), Mission("b", 3, 6), Mission("c", 6, 8))) == 1
    assert count(three + [300, 310, 320], (Mission("a", 0, 3), Mission("b", 3, 6), Mission("c", 6, 8),
                                           Mission("d", 8, 11))) == 2
    # 30 m steps: each part holds one step (two would be 60 m), and 20 m left is too little for the next
    assert count([0, 30, 60, 90], (Mission("long", 0, 4),)) == 3
