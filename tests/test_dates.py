"""Capture dates and schedules: strict parsing and the rules of Scene.at."""

from __future__ import annotations

import numpy as np
import pytest

from csv_schedule_reference import apply_csv_schedule
from sightplan.errors import ScheduleError
from sightplan.model.dates import parse_day
from sightplan.model.scene import ElementTable, Scene


def three_walls(start=None, finish=None, names=("a", "b", "c")) -> Scene:
    V, F, E = [], [], []
    for i in range(3):
        V.append(np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], float) + [2 * i, 0, 0])
        F.append(np.array([[0, 1, 2], [0, 2, 3]]) + 4 * i)
        E += [i, i]
    el = ElementTable.build(["g0", "g1", "g2"], name=list(names), start=start, finish=finish)
    return Scene.from_arrays(np.concatenate(V), np.concatenate(F), E, el)


@pytest.mark.parametrize(("text", "day"), [
    ("2024-05-01", "2024-05-01"),
    ("20240501", "2024-05-01"),
    ("2024-05-01T23:30", "2024-05-01"),
    ("2024-05-01T21:30-02:00", "2024-05-01"),  # 23:30 UTC
    ("2024-05-01T23:30-02:00", "2024-05-02"),  # 01:30 UTC the next day
])
def test_iso_dates_in_every_common_form(text, day):
    assert parse_day(text) == np.datetime64(day)


@pytest.mark.parametrize("text", ["01/05/2024", "next week", "", "99999-01-01", "2024-13-01"])
def test_non_dates_are_refused(text):
    with pytest.raises(ScheduleError, match="date|outside"):
        parse_day(text)


def test_compact_date_is_not_a_far_future_year():
    s = three_walls(finish=["2024-04-01", "2024-06-01", "2024-08-01"])
    assert list(s.at("20240501").present) == [True, False, False]


def test_half_dated_element_uses_its_other_date():
    s = three_walls(start=["2024-01-01", "2024-09-01", None], finish=["2024-02-01", None, None])
    at = s.at("2024-05-01")  # b only has a start (September): not there yet; c is undated: there
    assert list(at.present) == [True, False, True]
    assert list(s.at("2024-10-01").present) == [True, True, True]


def test_at_refuses_a_dated_scene_and_bad_options():
    s = three_walls(finish=["2024-04-01", "2024-06-01", "2024-08-01"])
    with pytest.raises(ScheduleError, match="already at 2024-05-01"):
        s.at("2024-05-01").at("2024-07-01")
    with pytest.raises(ScheduleError, match="basis"):
        s.at("2024-05-01", basis="Finish")
    with pytest.raises(ScheduleError, match="unscheduled"):
        s.at("2024-05-01", unscheduled="maybe")


def test_schedule_by_name_dates_every_element_of_that_name(tmp_path):
    s = three_walls(names=("wall", "wall", "slab"))
    csv = tmp_path / "s.csv"
    csv.write_text("name,start,finish\nwall,2024-01-01,2024-03-01\nslab,2024-01-01,2024-09-01\n")
    dated, link = apply_csv_schedule(s, csv)
    assert link["linked"] == 3 and link["names_shared_by_several_elements"] == 1
    assert list(dated.at("2024-04-01").present) == [True, True, False]


def test_schedule_with_a_bad_date_names_the_line(tmp_path):
    csv = tmp_path / "s.csv"
    csv.write_text("global_id,start,finish\ng0,2024-01-01,2024-03-01\ng1,2024-01-01,31/12/2024\n")
    with pytest.raises(ScheduleError, match=r"s\.csv:3"):
        apply_csv_schedule(three_walls(), csv)
