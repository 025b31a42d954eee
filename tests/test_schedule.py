"""Schedules: readers (IFC4 work schedules, MS Project XML, Primavera XER, CSV), link rules and linking.

Expected values come from the files themselves (read as text) or from small files written here.
"""

from __future__ import annotations

import ifcopenshell.api.aggregate
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.guid
import numpy as np
import pytest

from conftest import shared_file
from csv_schedule_reference import apply_csv_schedule
from sightplan.errors import ScheduleError
from sightplan.model.load import load_model
from sightplan.model.scene import ElementTable, Scene
from sightplan.schedule import (
    LinkRule,
    Task,
    TaskTable,
    date_range,
    link_schedule,
    parse_rules,
    read_csv,
    read_ifc,
    read_mspdi,
    read_rules,
    read_schedule,
    read_xer,
    task_finishes,
)

IFC4_EXAMPLE = ("ifc", "construction_scheduling_task.ifc")
MSPDI = ("schependomlaan", "Uitvoering Schependomlaan 18-02-2015.xml")
EVENTLOG = ("schependomlaan", "eventlog IFC schependomlaan.csv")
STEEL = ("schependomlaan", "BERNTS-Staalconstructie.ifc")


def D(text: str) -> np.datetime64:
    return np.datetime64(text, "s")


def scene_of(global_ids, ifc_class=None, name=None, storey=None, discipline=None, is_target=None) -> Scene:
    """One triangle per element, element table as given."""
    n = len(global_ids)
    V = np.concatenate([np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1]], float) + [2 * i, 0, 0] for i in range(n)])
    F = np.arange(3 * n).reshape(n, 3)
    el = ElementTable.build(list(global_ids), name=name, ifc_class=ifc_class, storey=storey, discipline=discipline,
                            is_target=is_target)
    return Scene.from_arrays(V, F, np.arange(n), el)


# ====================================================================== IFC4 work schedule (buildingSMART example)
# Values read from the file's text: #598 'Ground Level' (ScheduleStart 2010-09-20T08:00, no ScheduleFinish, EarlyFinish
# 2010-09-24T16:00) nests #615 'Slab (Standard)' → #621 'Slab #1' and #639 'Wall (Standard)' → #644/#662/#676/#690
# 'Wall #1..4'; the leaf tasks have only EarlyStart/EarlyFinish, 08:00–16:00 on 20, 21, 22, 23, 24 Sept 2010.
# IfcRelAssignsToProduct: #621 → #292 slab, #644 → #356, #662 → #385, #676 → #407, #690 → #429 walls, #598 → storey #265.
SLAB, WALLS = "20WrgxqpbDtferON_k1P2X", ["26tmERtwL8G8UQn5BoglEh", "2qqyx9mIf27vQuEGt7ts8$", "0edwXkNgP03AySQjQQlat2",
                                        "27D5wuD5z86hr07xvbZLKW"]


def test_ifc4_example_tasks_dates_and_nesting():
    tasks = read_ifc(shared_file(*IFC4_EXAMPLE))
    assert tasks.format == "ifc" and len(tasks) == 8
    assert tasks.names == ["Ground Level", "Slab (Standard)", "Slab #1", "Wall (Standard)",
                           "Wall #1", "Wall #2", "Wall #3", "Wall #4"]
    by_name = {t.name: t for t in tasks}
    ground = by_name["Ground Level"]
    assert ground.start == D("2010-09-20T08:00") and ground.finish == D("2010-09-24T16:00")  # EarlyFinish fallback
    assert by_name["Slab #1"].start == D("2010-09-20T08:00") and by_name["Slab #1"].finish == D("2010-09-20T16:00")
    assert by_name["Wall #3"].start == D("2010-09-23T08:00") and by_name["Wall #3"].finish == D("2010-09-23T16:00")
    assert np.isnat(tasks.actual_start).all() and np.isnat(tasks.actual_finish).all()
    # no Identification in the file: ids are the tasks' GlobalIds (#598 is 0HSpq15hDC2R2RlJos8Ql5)
    assert ground.id == "0HSpq15hDC2R2RlJos8Ql5" and ground.parent == "" and ground.summary
    assert by_name["Wall #2"].parent == by_name["Wall (Standard)"].id and by_name["Wall #2"].outline == "1.2.2"
    assert [t.summary for t in tasks] == [True, True, False, True, False, False, False, False]


def test_ifc4_example_element_assignments():
    tasks = read_ifc(shared_file(*IFC4_EXAMPLE))
    assigned = {t.name: t.global_ids for t in tasks if t.global_ids}
    assert assigned == {"Slab #1": (SLAB,), **{f"Wall #{i + 1}": (g,) for i, g in enumerate(WALLS)}}
    # the root task is assigned to the storey: a place, reported, linking nothing
    assert len(tasks.warnings) == 1 and "IfcBuildingStorey 'Ground Level'" in tasks.warnings[0]


def test_ifc4_example_linked_scene_between_two_task_finishes():
    path = shared_file(*IFC4_EXAMPLE)
    scene, report = load_model(path)
    assert report.unit_scale == pytest.approx(0.0254)  # inches
    tasks = read_schedule(path)
    dated, link = link_schedule(scene, tasks)
    assert link.linked == 5 and link.unlinked == 0 and link.n_targets == 5
    assert link.first_date == D("2010-09-20T08:00") and link.last_date == D("2010-09-24T16:00")
    gid = dated.elements.global_id
    site = gid[dated.elements.ifc_class == "IfcSite"][0]  # an occluder no task dates: always there
    # Wall #2 is finished on the 22nd, Wall #3 on the 23rd
    assert set(gid[dated.at("2010-09-22").present]) == {site, SLAB, WALLS[0], WALLS[1]}
    assert set(gid[dated.at("2010-09-22", unscheduled="absent").present]) == {SLAB, WALLS[0], WALLS[1]}
    assert dated.elements.start[list(gid).index(WALLS[2])] == D("2010-09-23T08:00")
    assert set(gid[dated.at("2010-09-24").present]) == {site, SLAB, *WALLS}
    with pytest.raises(ScheduleError, match="first element is built on 2010-09-20"):
        dated.at("2010-09-19", unscheduled="absent")
    assert [str(d) for d in task_finishes(tasks)] == ["2010-09-20", "2010-09-21", "2010-09-22", "2010-09-23", "2010-09-24"]
    assert date_range(tasks) == (D("2010-09-20T08:00"), D("2010-09-24T16:00"))


def _tasked_ifc(path, *, with_tasks: bool = True):
    """An IFC4 file: beams with Pset_BeamCommon, an assembly of two beams, typed columns, and a work schedule."""
    api = ifcopenshell.api
    f = api.project.create_file(version="IFC4")
    project = api.root.create_entity(f, ifc_class="IfcProject", name="P")
    storey = api.root.create_entity(f, ifc_class="IfcBuildingStorey", name="Level 1")
    api.aggregate.assign_object(f, products=[storey], relating_object=project)
    b1 = api.root.create_entity(f, ifc_class="IfcBeam", name="HEA 200")
    b2 = api.root.create_entity(f, ifc_class="IfcBeam", name="HEA 300")
    for beam, bearing in ((b1, True), (b2, False)):
        pset = api.pset.add_pset(f, product=beam, name="Pset_BeamCommon")
        api.pset.edit_pset(f, pset=pset, properties={"LoadBearing": bearing})
    assembly = api.root.create_entity(f, ifc_class="IfcElementAssembly", name="Truss")
    p1 = api.root.create_entity(f, ifc_class="IfcBeam", name="Chord")
    p2 = api.root.create_entity(f, ifc_class="IfcMember", name="Strut")
    api.aggregate.assign_object(f, products=[p1, p2], relating_object=assembly)
    ctype = api.root.create_entity(f, ifc_class="IfcColumnType", name="C1")
    c1 = api.root.create_entity(f, ifc_class="IfcColumn", name="Col A")
    c2 = api.root.create_entity(f, ifc_class="IfcColumn", name="Col B")
    api.type.assign_type(f, related_objects=[c1, c2], relating_type=ctype)
    api.spatial.assign_container(f, products=[b1, b2, assembly, c1, c2], relating_structure=storey)
    products = {"b1": b1, "b2": b2, "assembly": assembly, "p1": p1, "p2": p2, "c1": c1, "c2": c2, "storey": storey}
    if with_tasks:
        def guid():
            return ifcopenshell.guid.new()

        def task(name, ident, **times):
            return f.create_entity("IfcTask", GlobalId=guid(), Name=name, Identification=ident, IsMilestone=False,
                                   TaskTime=f.create_entity("IfcTaskTime", **times))

        root = task("Structure", "1", ScheduleStart="2024-03-01T08:00:00", ScheduleFinish="2024-03-29T17:00:00")
        t_b1 = task("Beam 1", "1.1", ScheduleStart="2024-03-04T08:00:00", ScheduleFinish="2024-03-05T17:00:00",
                    ActualStart="2024-03-06T08:00:00", ActualFinish="2024-03-08T17:00:00")
        t_b2 = task("Beam 2", "1.2", EarlyStart="2024-03-11T08:00:00", EarlyFinish="2024-03-12T17:00:00")
        t_truss = task("Truss", "1.3", ScheduleStart="2024-03-13T08:00:00", ScheduleFinish="2024-03-14T17:00:00")
        t_cols = task("Columns", "1.4", ScheduleStart="2024-03-15T08:00:00", ScheduleFinish="2024-03-18T17:00:00")
        ws = f.create_entity("IfcWorkSchedule", GlobalId=guid(), Name="Plan", CreationDate="2024-01-01T00:00:00",
                             StartTime="2024-03-01T00:00:00", PredefinedType="PLANNED")
        f.create_entity("IfcRelAssignsToControl", GlobalId=guid(), RelatedObjects=[root], RelatingControl=ws)
        f.create_entity("IfcRelNests", GlobalId=guid(), RelatingObject=root, RelatedObjects=[t_b1, t_b2, t_truss, t_cols])
        f.create_entity("IfcRelAssignsToProduct", GlobalId=guid(), RelatedObjects=[t_b1], RelatingProduct=b1)
        f.create_entity("IfcRelAssignsToProcess", GlobalId=guid(), RelatedObjects=[b2], RelatingProcess=t_b2)
        f.create_entity("IfcRelAssignsToProduct", GlobalId=guid(), RelatedObjects=[t_truss], RelatingProduct=assembly)
        f.create_entity("IfcRelAssignsToProduct", GlobalId=guid(), RelatedObjects=[t_cols], RelatingProduct=ctype)
        f.create_entity("IfcRelAssignsToProduct", GlobalId=guid(), RelatedObjects=[root], RelatingProduct=storey)
    f.write(str(path))
    return {k: v.GlobalId for k, v in products.items()}


def test_ifc_reader_follows_process_aggregate_and_type_assignments(tmp_path):
    ids = _tasked_ifc(tmp_path / "m.ifc")
    tasks = read_schedule(tmp_path / "m.ifc")
    assert tasks.ids == ["1", "1.1", "1.2", "1.3", "1.4"]  # Identification, distinct: used as ids
    assert tasks["1.1"].global_ids == (ids["b1"],)
    assert tasks["1.2"].global_ids == (ids["b2"],)  # IfcRelAssignsToProcess
    assert set(tasks["1.3"].global_ids) == {ids["p1"], ids["p2"]}  # the assembly's parts (it has no shape of its own)
    assert set(tasks["1.4"].global_ids) == {ids["c1"], ids["c2"]}  # the type's occurrences
    assert tasks["1"].global_ids == () and "Level 1" in tasks.warnings[0]
    assert tasks["1.1"].actual_start == D("2024-03-06T08:00") and tasks["1.1"].actual_finish == D("2024-03-08T17:00")
    assert tasks["1.2"].start == D("2024-03-11T08:00")  # EarlyStart when there is no ScheduleStart
    assert tasks["1.3"].parent == "1" and tasks["1"].summary and not tasks["1.3"].summary


def test_link_prefers_actual_dates_when_asked(tmp_path):
    ids = _tasked_ifc(tmp_path / "m.ifc")
    tasks = read_ifc(tmp_path / "m.ifc")
    scene = scene_of([ids[k] for k in ("b1", "b2", "p1", "p2", "c1", "c2")])
    planned, report = link_schedule(scene, tasks)
    assert planned.elements.finish[0] == D("2024-03-05T17:00") and report.linked == 6
    actual, report = link_schedule(scene, tasks, prefer_actual=True)
    assert actual.elements.start[0] == D("2024-03-06T08:00") and actual.elements.finish[0] == D("2024-03-08T17:00")
    assert actual.elements.finish[1] == D("2024-03-12T17:00")  # no actual dates: planned
    assert report.n_actual == 1 and report.prefer_actual


def test_ifc_without_tasks_has_no_work_schedule(tmp_path):
    _tasked_ifc(tmp_path / "plain.ifc", with_tasks=False)
    with pytest.raises(ScheduleError, match="plain.ifc has no work schedule"):
        read_ifc(tmp_path / "plain.ifc")


# ====================================================================== MS Project XML
def test_mspdi_real_schedule_157_tasks():
    tasks = read_schedule(shared_file(*MSPDI))
    assert tasks.format == "mspdi" and len(tasks) == 157
    # from the XML text: <UID>10</UID><ID>6</ID><Name>Plaatsen bouwketen</Name>…<Start>2015-02-20T08:00:00</Start>
    # <Finish>2015-02-23T16:00:00</Finish>; UID 111 (ID 85) 'Staalconstuctie dak' 2015-07-13T08:00 → 2015-07-16T16:00;
    # UID 160 (ID 121) 'Zinken bekleding dakkapelen' 2015-08-28T08:00 → 2015-09-03T16:00
    for uid, row, name, start, finish in (
        ("10", "6", "Plaatsen bouwketen", "2015-02-20T08:00", "2015-02-23T16:00"),
        ("111", "85", "Staalconstuctie dak", "2015-07-13T08:00", "2015-07-16T16:00"),
        ("160", "121", "Zinken bekleding dakkapelen", "2015-08-28T08:00", "2015-09-03T16:00"),
    ):
        t = tasks[uid]
        assert (t.code, t.name, t.start, t.finish) == (row, name, D(start), D(finish))
    first, last = date_range(tasks)
    assert last == D("2015-12-17T16:00")  # the project's <FinishDate>
    assert first >= D("2015-02-18T08:00")  # the project's <StartDate>
    with pytest.raises(ScheduleError, match="MS Project schedule that names no elements: link it with a rules file"):
        link_schedule(scene_of(["a", "b"]), tasks)


MSPDI_SMALL = """<?xml version="1.0" encoding="UTF-8"?>
<Project xmlns="http://schemas.microsoft.com/project"><Name>t</Name><Tasks>
<Task><UID>0</UID><ID>0</ID><Name>t</Name><OutlineLevel>0</OutlineLevel><Summary>1</Summary>
  <Start>2024-01-01T08:00:00</Start><Finish>2024-12-31T17:00:00</Finish></Task>
<Task><UID>1</UID><ID>1</ID><Name>Shell</Name><OutlineNumber>1</OutlineNumber><OutlineLevel>1</OutlineLevel><Summary>1</Summary>
  <Start>2024-02-01T08:00:00</Start><Finish>2024-03-01T17:00:00</Finish></Task>
<Task><UID>7</UID><ID>2</ID><Name>Walls</Name><OutlineNumber>1.1</OutlineNumber><OutlineLevel>2</OutlineLevel><Summary>0</Summary>
  <Start>2024-02-01T08:00:00</Start><Finish>2024-02-10T17:00:00</Finish>
  <ActualStart>2024-02-03T08:00:00</ActualStart><ActualFinish>2024-02-14T12:00:00</ActualFinish></Task>
<Task><UID>8</UID><ID>3</ID><IsNull>1</IsNull></Task>
<Task><UID>9</UID><ID>4</ID><Name>Roof</Name><OutlineNumber>1.2</OutlineNumber><OutlineLevel>2</OutlineLevel><Summary>0</Summary>
  <Start>2024-02-12T08:00:00</Start><Finish>DATE</Finish></Task>
<Task><UID>12</UID><ID>5</ID><Name>Handover</Name><OutlineNumber>2</OutlineNumber><OutlineLevel>1</OutlineLevel>
  <Start>2024-03-05T08:00:00</Start><Finish>2024-03-05T08:00:00</Finish></Task>
</Tasks></Project>"""


def test_mspdi_outline_summary_and_actual_dates(tmp_path):
    path = tmp_path / "p.xml"
    path.write_text(MSPDI_SMALL.replace("DATE", "2024-03-01T17:00:00"))
    tasks = read_mspdi(path)
    assert tasks.ids == ["1", "7", "9", "12"]  # the project summary (UID 0) and the blank row are skipped
    assert [t.parent for t in tasks] == ["", "1", "1", ""]
    assert [t.summary for t in tasks] == [True, False, False, False]
    assert tasks["7"].outline == "1.1" and tasks["7"].code == "2"
    assert tasks["7"].dates(prefer_actual=True) == (D("2024-02-03T08:00"), D("2024-02-14T12:00"))
    assert [str(d) for d in task_finishes(tasks)] == ["2024-02-10", "2024-03-01", "2024-03-05"]  # summary left out
    assert [str(d) for d in task_finishes(tasks, prefer_actual=True)] == ["2024-02-14", "2024-03-01", "2024-03-05"]


def test_mspdi_finish_before_start_names_the_task(tmp_path):
    path = tmp_path / "p.xml"
    path.write_text(MSPDI_SMALL.replace("DATE", "2024-02-11T17:00:00"))
    with pytest.raises(ScheduleError, match=r"p\.xml: task '9' \('Roof'\) has its planned finish 2024-02-11 17:00 "
                                            r"before its start 2024-02-12 08:00"):
        read_mspdi(path)


def test_xml_that_is_not_ms_project_is_refused(tmp_path):
    path = tmp_path / "other.xml"
    path.write_text('<?xml version="1.0"?><Plan xmlns="urn:x"><Tasks/></Plan>')
    with pytest.raises(ScheduleError, match="not an MS Project XML file"):
        read_schedule(path)


# ====================================================================== Primavera XER
XER_SMALL = "\r\n".join([
    "ERMHDR\t19.12\t2024-04-01\tProject\tadmin\tdbxDatabaseNoName\tProject Management\tEUR",
    "%T\tPROJECT", "%F\tproj_id\tproj_short_name", "%R\t100\tTOWER",
    "%T\tPROJWBS", "%F\twbs_id\tproj_id\tparent_wbs_id\tproj_node_flag\twbs_short_name\twbs_name",
    "%R\t1\t100\t\tY\tTOWER\tTower", "%R\t2\t100\t1\tN\tSTR\tStructure", "%R\t3\t100\t2\tN\tL1\tLevel 1",
    "%T\tTASK",
    "%F\ttask_id\tproj_id\twbs_id\ttask_code\ttask_name\ttask_type\ttarget_start_date\ttarget_end_date"
    "\tearly_start_date\tearly_end_date\tact_start_date\tact_end_date",
    "%R\t5001\t100\t3\tA1000\tBéton – coulage dalle\tTT_Task\t2015-03-02 08:00\t2015-03-06 17:00\t\t\t2015-03-03 08:00\t",
    "%R\t5002\t100\t3\tA1010\tMontage poteaux\tTT_Task\t\t\t2015-03-09 08:00\t2015-03-13 17:00\t\t",
    "%R\t5003\t100\t2\tA1020\tStructure summary\tTT_WBS\t2015-03-02 08:00\t2015-03-13 17:00\t\t\t\t",
    "%T\tTASKRSRC", "%F\ttaskrsrc_id\ttask_id\trsrc_id", "%R\t1\t5001\t9",
    "%E",
]) + "\r\n"


def test_xer_tasks_in_windows_1252(tmp_path):
    path = tmp_path / "p.xer"
    path.write_bytes(XER_SMALL.encode("cp1252"))  # 'é' and '–' as single cp1252 bytes: not UTF-8
    tasks = read_schedule(path)
    assert tasks.format == "xer" and tasks.ids == ["A1000", "A1010", "A1020"]
    a = tasks["A1000"]
    assert (a.name, a.code, a.outline) == ("Béton – coulage dalle", "5001", "STR.L1")
    assert a.start == D("2015-03-02T08:00") and a.finish == D("2015-03-06T17:00")
    assert a.actual_start == D("2015-03-03T08:00") and np.isnat(a.actual_finish)
    assert tasks["A1010"].start == D("2015-03-09T08:00")  # no target dates: early dates
    assert tasks["A1020"].summary and not a.summary
    path.write_bytes(XER_SMALL.encode("utf-8"))
    assert read_xer(path)["A1000"].name == "Béton – coulage dalle"


@pytest.mark.parametrize("name, text, reader, message", [
    ("p.xml", MSPDI_SMALL.replace("DATE", "1-3-2024"), read_mspdi,
     r"p\.xml: task '9' \('Roof'\), Finish '1-3-2024' is not a date"),
    ("p.xer", XER_SMALL.replace("2015-03-06 17:00", "06/03/2015"), read_xer,
     r"p\.xer: task 'A1000' \('Béton – coulage dalle'\), target_end_date '06/03/2015' is not a date"),
])
def test_unreadable_date_names_the_task_and_the_text(tmp_path, name, text, reader, message):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ScheduleError, match=message):
        reader(path)


def test_xer_needs_the_header_and_the_task_table(tmp_path):
    path = tmp_path / "p.xer"
    path.write_text("%T\tTASK\n")
    with pytest.raises(ScheduleError, match="not a Primavera XER file"):
        read_xer(path)
    path.write_text("ERMHDR\t19.12\n%T\tPROJECT\n%F\tproj_id\n%R\t1\n%E\n")
    with pytest.raises(ScheduleError, match="has no TASK table"):
        read_xer(path)


# ====================================================================== CSV
def test_csv_task_list(tmp_path):
    path = tmp_path / "tasks.csv"
    path.write_text("Task ID;Name;Start;Finish;Actual Start;Actual Finish;Parent;Global IDs\n"
                    "S;Shell;2024-02-01;2024-03-01;;;;\n"
                    "W;Walls;2024-02-01;2024-02-10;2024-02-02;2024-02-12;S;g0 g1\n"
                    "R;Roof;3-3-2024;15-3-2024;;;S;g2\n")
    tasks = read_csv(path)
    assert tasks.ids == ["S", "W", "R"] and tasks["W"].global_ids == ("g0", "g1") and tasks["R"].parent == "S"
    assert tasks["R"].start == D("2024-03-03") and tasks["R"].finish == D("2024-03-15")  # day-first D-M-YYYY
    assert tasks["W"].actual_finish == D("2024-02-12")
    dated, report = link_schedule(scene_of(["g0", "g1", "g2", "g3"]), tasks)
    assert report.linked == 3 and report.unlinked_ids == ("g3",) and report.tasks_without_elements == ("S",)
    assert list(dated.at("2024-03-01").present) == [True, True, False, True]


def test_csv_element_to_task_table_like_the_eventlog(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("BuildingGUID,GUID,ifcClass,Task,Resource,TaskName,TaskStart,TaskFinish\n"
                    "B,g0,Slab,T1,floor,Pour slab,26-2-2015,27-2-2015\n"
                    "B,g0,Slab,T2,floor,Cure slab,2-3-2015,4-3-2015\n"
                    "B,g1,Wall,T2,wall,Cure slab,2-3-2015,4-3-2015\n"
                    "B,gX,Wall,T3,wall,Ghost,5-3-2015,6-3-2015\n")
    tasks = read_schedule(path)
    assert tasks.ids == ["T1", "T2", "T3"] and tasks["T2"].global_ids == ("g0", "g1") and tasks["T2"].name == "Cure slab"
    dated, report = link_schedule(scene_of(["g0", "g1", "g2"]), tasks)
    # g0 is in two tasks: earliest start, latest finish
    assert dated.elements.start[0] == D("2015-02-26") and dated.elements.finish[0] == D("2015-03-04")
    assert report.n_schedule_ids == 3 and report.n_missing_ids == 1 and report.missing_ids == ("gX",)
    assert report.tasks_without_elements == ("T3",)
    text = "\n".join(report.describe())
    assert "linked 2 of 3 target elements" in text and "1 of the 3 element ids in the schedule are not in this model: gX" in text


def test_csv_element_to_task_rows_must_agree(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("GUID,Task,TaskName,TaskStart,TaskFinish\ng0,T1,A,1-3-2015,2-3-2015\ng1,T1,A,1-3-2015,9-3-2015\n")
    with pytest.raises(ScheduleError, match=r"log\.csv:3: task 'T1' has finish .*2015-03-09.* on line 2"):
        read_csv(path)


def test_real_eventlog_reads_73_tasks_and_3505_global_ids():
    tasks = read_schedule(shared_file(*EVENTLOG))
    assert len(tasks) == 73 and len(tasks.global_ids) == 3505  # as the data README states
    first = tasks["ST00060"]  # the file's first row: ...,ST00060,liftputvloer_(#5715),Stellen bruggetjes,26-2-2015,27-2-2015
    assert first.name == "Stellen bruggetjes" and first.start == D("2015-02-26") and first.finish == D("2015-02-27")


def test_per_element_csv_dates_like_apply_csv_schedule(tmp_path):
    scene = scene_of(["g0", "g1", "g2"], name=["wall", "wall", "slab"])
    by_id, by_name = tmp_path / "ids.csv", tmp_path / "names.csv"
    by_id.write_text("global_id,start,finish\ng0,2024-01-01,2024-03-01\ng2,2024-01-01,2024-09-01\ngZ,2024-01-01,2024-02-01\n")
    by_name.write_text("name,start,finish\nwall,2024-01-01,2024-03-01\nslab,2024-01-01,2024-09-01\n")
    for path in (by_id, by_name):
        old, _ = apply_csv_schedule(scene, path)
        new, report = link_schedule(scene, read_csv(path))
        assert np.array_equal(old.elements.start, new.elements.start, equal_nan=True)
        assert np.array_equal(old.elements.finish, new.elements.finish, equal_nan=True)
    assert report.linked == 3 and report.n_schedule_ids == 2


def test_csv_unreadable_date_names_the_line_task_and_text(tmp_path):
    path = tmp_path / "tasks.csv"
    path.write_text("task_id,name,start,finish\nT1,Walls,2024-01-01,2024-02-01\nT2,Roof,2024-02-01,31/12/2024\n")
    with pytest.raises(ScheduleError, match=r"tasks\.csv:3: task 'T2' \('Roof'\), finish '31/12/2024' is not a date"):
        read_csv(path)


def test_csv_finish_before_start_names_the_task(tmp_path):
    path = tmp_path / "tasks.csv"
    path.write_text("task_id,name,start,finish\nT1,Walls,2024-03-01,2024-02-01\n")
    with pytest.raises(ScheduleError, match=r"task 'T1' \('Walls'\) has its planned finish 2024-02-01 before its start"):
        read_csv(path)


def test_read_schedule_dispatches_by_content_when_the_extension_is_unknown(tmp_path):
    xer = tmp_path / "export.p6"
    xer.write_text(XER_SMALL, encoding="utf-8")
    xml = tmp_path / "export.mpp-xml"
    xml.write_text(MSPDI_SMALL.replace("DATE", "2024-03-01T17:00:00"))
    assert read_schedule(xer).format == "xer" and read_schedule(xml).format == "mspdi"
    with pytest.raises(ScheduleError, match="not found"):
        read_schedule(tmp_path / "missing.csv")


# ====================================================================== tasks table
def test_task_table_validates_ids_parents_and_dates():
    with pytest.raises(ScheduleError, match="task id 'a' is used by more than one task"):
        TaskTable((Task("a"), Task("a")), "s")
    with pytest.raises(ScheduleError, match="parent 'zz'"):
        TaskTable((Task("a", parent="zz"),), "s")
    with pytest.raises(ScheduleError, match=r"s: task 'a' \('Pour'\) has its actual finish"):
        TaskTable((Task("a", "Pour", actual_start="2024-01-02", actual_finish="2024-01-01"),), "s")
    with pytest.raises(ScheduleError, match="no task has a date"):
        date_range(TaskTable((Task("a"),), "s"))


# ====================================================================== rules
def rules_file(tmp_path, text: str):
    path = tmp_path / "rules.toml"
    path.write_text(text)
    return path


def small_tasks() -> TaskTable:
    return TaskTable((Task("1", "Steel frame", "2024-03-01", "2024-03-10"), Task("2", "Walls", "2024-03-11", "2024-03-20"),
                      Task("3", "Walls", "2024-03-15", "2024-03-25")), "plan.csv", "csv")


def test_rules_by_class_with_subtypes_storey_discipline_and_name(tmp_path):
    scene = scene_of(["b", "bs", "c", "w1", "w2", "f"],
                     ifc_class=["IfcBeam", "IfcBeamStandardCase", "IfcColumn", "IfcWall", "IfcWallStandardCase",
                                "IfcFurnishingElement"],
                     name=["HEA 200", "IPE 300", "HEA 200", "W1", "W2", "Chair"],
                     storey=["Level 1", "Level 1", "Level 2", "Level 1", "Level 2", "Level 1"],
                     discipline=["S", "S", "S", "A", "A", ""], is_target=[True] * 5 + [False])
    scene = Scene.from_arrays(scene.vertices, scene.faces, scene.face_element, scene.elements, metadata={"schema": "IFC4"})
    path = rules_file(tmp_path, """
[[link]]
task = "Steel frame"
ifc_class = ["IfcBeam", "IfcColumn"]   # IfcBeamStandardCase is an IfcBeam
discipline = "S"

[[link]]
task = "Walls"                          # two tasks of that name: earliest start, latest finish
ifc_class = "IfcWall"
storey = "Level 2*"

[[link]]
task_pattern = "Steel*"
name = "HEA*"
storey = ["Level 1"]
""")
    dated, report = link_schedule(scene, small_tasks(), path)
    assert report.rule_elements == (3, 1, 1) and report.linked == 4 and report.unlinked_ids == ("w1",)
    assert report.linked_by_rules == 4 and report.linked_by_schedule == 0
    el = dated.elements
    assert el.finish[0] == D("2024-03-10") and el.finish[1] == D("2024-03-10")
    assert el.start[4] == D("2024-03-11") and el.finish[4] == D("2024-03-25")
    assert np.isnat(el.finish[3]) and np.isnat(el.finish[5])
    assert report.tasks_without_elements == ()
    assert any("rule 3: 1 elements" in line for line in report.describe())


@pytest.mark.parametrize(("body", "message"), [
    ('task = "Steel frme"\nifc_class = "IfcBeam"', r"rule 1: no task of plan\.csv is named 'Steel frme' \(closest: 'Steel fr"),
    ('task_id = "9"\nifc_class = "IfcBeam"', r"rule 1: no task of plan\.csv has the id '9'"),
    ('task_pattern = "Roof*"\nifc_class = "IfcBeam"', r"rule 1: task_pattern 'Roof\*' matches no task name"),
    ('task = "Walls"\nifc_class = "IfcBeem"', r"rule 1: ifc_class 'IfcBeem' is not an IFC4 class \(closest: 'IfcBeam'"),
    ('task = "Walls"\nifc_clas = "IfcBeam"', r"rule 1: unknown key 'ifc_clas' \(closest: 'ifc_class'\)"),
    ('task = "Walls"', r"rule 1: no condition selects elements"),
    ('task = "Walls"\ntask_id = "2"\nname = "*"', r"rule 1: name the task with exactly one of"),
    ('task = "Walls"\ndiscipline = "X"', r"rule 1: discipline 'X' is not one of"),
    ('task = "Walls"\nproperty = { LoadBearing = true }', r"rule 1: property 'LoadBearing' must be written"),
])
def test_bad_rules_name_the_rule_and_the_value(tmp_path, body, message):
    path = rules_file(tmp_path, "[[link]]\n" + body + "\n")
    with pytest.raises(ScheduleError, match=message):
        link_schedule(scene_of(["a"], ifc_class=["IfcBeam"]), small_tasks(), path)


def test_rules_file_errors(tmp_path):
    with pytest.raises(ScheduleError, match="not valid TOML"):
        read_rules(rules_file(tmp_path, "[[link]\ntask = 1\n"))
    with pytest.raises(ScheduleError, match="unknown top-level key 'links'"):
        read_rules(rules_file(tmp_path, '[[links]]\ntask = "Walls"\nname = "*"\n'))
    rules = parse_rules({"link": [{"task": "Walls", "name": "W*"}]})
    assert rules == (LinkRule(number=1, task="Walls", name=("W*",)),)


def test_rule_that_selects_nothing_is_a_warning_unless_nothing_links(tmp_path):
    scene = scene_of(["a", "b"], ifc_class=["IfcBeam", "IfcWall"])
    rules = [{"task": "Walls", "ifc_class": "IfcWall"}, {"task": "Steel frame", "ifc_class": "IfcSlab"}]
    _, report = link_schedule(scene, small_tasks(), {"link": rules})
    assert report.linked == 1 and any("rule 2 (task = 'Steel frame') selects no target element" in w for w in report.warnings)
    with pytest.raises(ScheduleError, match="the rules link no element of this model"):
        link_schedule(scene, small_tasks(), {"link": rules[1:]})


def test_property_rules_read_the_ifc_and_report_typos(tmp_path):
    ids = _tasked_ifc(tmp_path / "m.ifc", with_tasks=False)
    scene = scene_of([ids["b1"], ids["b2"], ids["c1"]], ifc_class=["IfcBeam", "IfcBeam", "IfcColumn"])
    rule = '[[link]]\ntask = "Steel frame"\nifc_class = "IfcBeam"\nproperty = {{ "Pset_BeamCommon.{}" = true }}\n'
    dated, report = link_schedule(scene, small_tasks(), rules_file(tmp_path, rule.format("LoadBearing")),
                                  model_path=tmp_path / "m.ifc")
    assert report.linked == 1 and dated.elements.finish[0] == D("2024-03-10") and np.isnat(dated.elements.finish[1])
    with pytest.raises(ScheduleError, match=r"rule 1: no element of the model has the property "
                                            r"'Pset_BeamCommon.LoadBaering' \(closest: 'Pset_BeamCommon.LoadBearing'"):
        link_schedule(scene, small_tasks(), rules_file(tmp_path, rule.format("LoadBaering")), model_path=tmp_path / "m.ifc")
    with pytest.raises(ScheduleError, match="rule 1: property conditions need the IFC file: pass model_path"):
        link_schedule(scene, small_tasks(), rules_file(tmp_path, rule.format("LoadBearing")))


# ====================================================================== real models: the steel structure
@pytest.fixture(scope="module")
def steel():
    path = shared_file(*STEEL)
    scene, _ = load_model(path)
    return path, scene


@pytest.mark.slow
def test_steel_beams_and_columns_linked_to_the_steel_task(steel, tmp_path):
    path, scene = steel
    tasks = read_schedule(shared_file(*MSPDI))
    rules = rules_file(tmp_path, '[[link]]\ntask = "Staalconstuctie dak"\nifc_class = ["IfcBeam", "IfcColumn"]\n')
    dated, report = link_schedule(scene, tasks, rules, model_path=path)
    classes = scene.elements.ifc_class
    expected = int(np.isin(classes, ["IfcBeam", "IfcColumn"]).sum())
    assert expected == 742 + 56  # as the data README counts them
    assert report.linked == expected and report.rule_elements == (expected,)
    frame = np.isin(dated.elements.ifc_class, ["IfcBeam", "IfcColumn"])
    assert (dated.elements.start[frame] == D("2015-07-13T08:00")).all()
    assert (dated.elements.finish[frame] == D("2015-07-16T16:00")).all()
    assert np.isnat(dated.elements.finish[~frame]).all()
    with pytest.raises(ScheduleError, match="no element of the model exists on 2015-07-15"):
        dated.at("2015-07-15", unscheduled="absent")
    assert dated.at("2015-07-16", unscheduled="absent").targets.sum() == expected
    # a property condition on the Tekla property sets narrows the same rule
    grade = rules_file(tmp_path, '[[link]]\ntask = "Staalconstuctie dak"\nifc_class = ["IfcBeam", "IfcColumn"]\n'
                                 'property = { "Tekla Common.Grade" = "S235*" }\n')
    _, narrowed = link_schedule(scene, tasks, grade, model_path=path)
    assert 0 < narrowed.linked <= expected


@pytest.mark.slow
def test_eventlog_against_the_steel_model_says_it_was_made_for_another_model(steel):
    _, scene = steel
    with pytest.raises(ScheduleError, match=r"names 3505 GlobalIds and none is in this model \(3iHy1LOhfAtfLt80\$LZBqn, "
                                            r".*\): it was made for another model; link it with a rules file"):
        link_schedule(scene, read_schedule(shared_file(*EVENTLOG)))


def test_ifc2x3_schedule_time_control_and_day_first_mistakes(tmp_path):
    f = ifcopenshell.api.project.create_file(version="IFC2X3")
    org = f.createIfcOrganization(Name="sightplan tests")
    f.createIfcPersonAndOrganization(f.createIfcPerson(FamilyName="Tester"), org)
    f.createIfcApplication(org, "1", "sightplan tests", "sightplan")
    ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="P")
    wall = ifcopenshell.api.root.create_entity(f, ifc_class="IfcWall", name="W")
    guid = ifcopenshell.guid.new

    def when(y, m, d, h):
        return f.createIfcDateAndTime(f.createIfcCalendarDate(d, m, y), f.createIfcLocalTime(h, 0, 0.0))

    task = f.create_entity("IfcTask", GlobalId=guid(), Name="Wall", TaskId="A1", IsMilestone=False)
    times = f.create_entity("IfcScheduleTimeControl", GlobalId=guid(), ScheduleStart=when(2012, 5, 2, 8),
                            ScheduleFinish=when(2012, 5, 4, 17), ActualStart=f.createIfcCalendarDate(3, 5, 2012))
    schedule = f.create_entity("IfcWorkSchedule", GlobalId=guid(), Name="WS", CreationDate=when(2012, 1, 1, 0),
                               StartTime=when(2012, 5, 1, 0))
    f.create_entity("IfcRelAssignsTasks", GlobalId=guid(), RelatedObjects=[task], RelatingControl=schedule, TimeForTask=times)
    f.create_entity("IfcRelAssignsToProcess", GlobalId=guid(), RelatedObjects=[wall], RelatingProcess=task)
    f.write(str(tmp_path / "x3.ifc"))
    (t,) = read_ifc(tmp_path / "x3.ifc")
    assert (t.id, t.start, t.finish, t.actual_start) == ("A1", D("2012-05-02T08:00"), D("2012-05-04T17:00"), D("2012-05-03"))
    assert t.global_ids == (wall.GlobalId,)
    # a month-first date read day-first is refused, quoting the text as written
    path = tmp_path / "t.csv"
    path.write_text("task_id,name,start,finish\nT1,Walls,2-26-2015,3-1-2015\n")
    with pytest.raises(ScheduleError, match=r"task 'T1' \('Walls'\), start '2-26-2015' is not a date \(expected YYYY-MM-DD or"):
        read_csv(path)
