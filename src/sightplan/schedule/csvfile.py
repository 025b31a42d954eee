"""Schedules as CSV, in three forms told apart by their header row.

Header names are matched case-insensitively, ignoring spaces, '_' and '-' (``Task Start`` =
``task_start`` = ``TaskStart``). The delimiter is ',', ';' or tab, whichever the header uses most.
Text is UTF-8 (BOM allowed), else Windows-1252.

1. **Task list** — one row per task: ``task_id`` (or ``id``, ``task``, ``activity_id``),
   ``name``, ``start``, ``finish`` (or ``end``); optional ``actual_start``, ``actual_finish``,
   ``parent`` (a task id), ``outline`` (or ``wbs``), ``summary`` (1/true/yes) and
   ``global_ids`` (GlobalIds separated by ';', ',' or blanks).
2. **Element-to-task table** — one row per (element, task), like the Schependomlaan
   event log (``GUID, Task, TaskName, TaskStart, TaskFinish``): a ``global_id`` (or
   ``guid``) column *and* a task column (``task``, ``task_id``); ``task_name``, ``start``
   (``task_start``), ``finish`` (``task_finish``), optional actual dates. A task's rows
   must agree on its name and dates.
3. **Per-element schedule** — ``global_id``
   (or ``guid``) or ``name``, ``start``, ``finish``: every row is a task dating that element
   (or every element of that name); its id is the GlobalId or name.

Dates: ISO 8601 (``2015-03-02``, ``2015-03-02T08:00``) or day-first ``D-M-YYYY``
(``26-2-2015``, ``26.02.2015``); anything else is refused with the task and the text. Empty = no date.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from ..errors import ScheduleError
from .tasks import Task, TaskTable, parse_task_date
from .xer import decode

GID_COLS = ("globalid", "guid", "ifcguid", "elementguid", "elementglobalid")
TASK_COLS = ("taskid", "task", "activityid", "activity", "taskcode")
NAME_COLS = ("taskname", "activityname", "name")
START_COLS = ("start", "taskstart", "plannedstart", "startdate", "schedulestart", "targetstart")
FINISH_COLS = ("finish", "end", "taskfinish", "taskend", "plannedfinish", "finishdate", "enddate",
               "schedulefinish", "targetfinish")
ACTUAL_START_COLS = ("actualstart", "actstart", "actualstartdate")
ACTUAL_FINISH_COLS = ("actualfinish", "actualend", "actfinish", "actualfinishdate")
PARENT_COLS = ("parent", "parentid", "parenttask")
OUTLINE_COLS = ("outline", "outlinenumber", "wbs")
SUMMARY_COLS = ("summary",)
GIDS_COLS = ("globalids", "guids", "elements", "elementids")
_SPLIT = re.compile(r"[;,\s]+")


def _norm(header: str) -> str:
    return re.sub(r"[\s_\-]+", "", header.strip().lower())


def _pick(cols: dict[str, str], names: tuple[str, ...]) -> str | None:
    return next((cols[n] for n in names if n in cols), None)


def _rows(path: Path) -> tuple[list[str], list[tuple[int, dict[str, str]]]]:
    """(header, [(line number, row)]) with blank rows left out."""
    try:
        text = decode(path.read_bytes())
    except OSError as exc:
        raise ScheduleError(f"cannot read schedule {path}: {exc.strerror}") from None
    header = next((ln for ln in text.splitlines() if ln.strip()), "")
    if not header:
        raise ScheduleError(f"{path.name} is empty")
    delimiter = max(",;\t", key=lambda d: (header.count(d), d == ","))
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
    names: list[str] | None = None
    rows = []
    try:
        for values in reader:
            if not any(v.strip() for v in values):
                continue
            if names is None:
                names = [c.strip() for c in values]
                continue
            if len(values) > len(names):
                raise ScheduleError(f"{path.name}:{reader.line_num}: {len(values)} values for {len(names)} columns")
            rows.append((reader.line_num, {n: v.strip() for n, v in zip(names, values)}))
    except csv.Error as exc:
        raise ScheduleError(f"{path.name}:{reader.line_num} is not readable CSV: {exc}") from None
    if not rows:
        raise ScheduleError(f"{path.name} has no schedule rows")
    return names or [], rows


def read_csv(path: str | Path) -> TaskTable:
    """The tasks of a CSV schedule in any of the three forms (see the module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise ScheduleError(f"schedule file not found: {path}")
    source = path.name
    names, rows = _rows(path)
    cols = {_norm(n): n for n in names if n}
    gid, task = _pick(cols, GID_COLS), _pick(cols, TASK_COLS)
    start, finish = _pick(cols, START_COLS), _pick(cols, FINISH_COLS)
    if start is None or finish is None:
        raise ScheduleError(f"{source}: a CSV schedule needs a start and a finish column (found: {', '.join(names)})")
    if gid is not None and task is not None:
        return _element_task_table(source, rows, cols, gid, task, start, finish)
    task = task or cols.get("id")
    if task is not None:
        return _task_list(source, rows, cols, task, start, finish)
    key = gid or cols.get("name")
    if key is None:
        raise ScheduleError(f"{source}: a CSV schedule needs a task id column (task_id), a global_id column, "
                            f"or a name column (found: {', '.join(names)})")
    return _per_element(source, rows, key, by_id=gid is not None, start=start, finish=finish)


def _dates(source: str, row: dict[str, str], cols: dict[str, str], tid: str, name: str,
           start: str, finish: str) -> dict[str, np.datetime64]:
    a_start, a_finish = _pick(cols, ACTUAL_START_COLS), _pick(cols, ACTUAL_FINISH_COLS)
    out = {}
    for key, col in (("start", start), ("finish", finish), ("actual_start", a_start), ("actual_finish", a_finish)):
        out[key] = parse_task_date(row.get(col, "") if col else "", source, tid, name, col or key, day_first=True)
    return out


def _task_of(source: str, number: int, row: dict[str, str], id_col: str, name_col: str | None) -> tuple[str, str]:
    """(task id, task name) of a row; a row without a task id is refused."""
    tid = row.get(id_col, "")
    name = row.get(name_col, "") if name_col else ""
    if not tid:
        raise ScheduleError(f"{source}:{number}: the row ({name!r}) has no task id in column {id_col!r}")
    return tid, name


def _task_list(source: str, rows, cols: dict[str, str], id_col: str, start: str, finish: str) -> TaskTable:
    name_col = _pick(cols, NAME_COLS)
    parent_col, outline_col = _pick(cols, PARENT_COLS), _pick(cols, OUTLINE_COLS)
    summary_col, gids_col = _pick(cols, SUMMARY_COLS), _pick(cols, GIDS_COLS)
    tasks: list[Task] = []
    lines: dict[str, int] = {}
    for number, row in rows:
        tid, name = _task_of(source, number, row, id_col, name_col)
        if tid in lines:
            raise ScheduleError(f"{source}:{number}: task id {tid!r} is used again (first on line {lines[tid]})")
        lines[tid] = number
        tasks.append(Task(
            id=tid, name=name, **_dates(f"{source}:{number}", row, cols, tid, name, start, finish),
            parent=row.get(parent_col, "") if parent_col else "",
            outline=row.get(outline_col, "") if outline_col else "",
            summary=(row.get(summary_col, "") if summary_col else "").lower() in ("1", "true", "yes", "y"),
            global_ids=tuple(g for g in _SPLIT.split(row.get(gids_col, "") if gids_col else "") if g),
        ))
    return TaskTable(tuple(tasks), source, "csv")


def _element_task_table(source: str, rows, cols: dict[str, str], gid_col: str, task_col: str,
                        start: str, finish: str) -> TaskTable:
    name_col = _pick(cols, NAME_COLS[:2])  # 'name' would be the element's name here
    found: dict[str, dict] = {}
    for number, row in rows:
        tid, name = _task_of(source, number, row, task_col, name_col)
        values = {"name": name, **_dates(f"{source}:{number}", row, cols, tid, name, start, finish)}
        entry = found.get(tid)
        if entry is None:
            entry = found[tid] = {**values, "line": number, "gids": {}}
        else:
            for key, value in values.items():
                known = entry[key]
                empty = (value == "") if isinstance(value, str) else np.isnat(value)
                unknown = (known == "") if isinstance(known, str) else np.isnat(known)
                if empty:
                    continue
                if unknown:
                    entry[key] = value
                elif known != value:
                    raise ScheduleError(f"{source}:{number}: task {tid!r} has {key} {str(value)!r} here but "
                                        f"{str(known)!r} on line {entry['line']}")
        if row.get(gid_col):
            entry["gids"][row[gid_col]] = None
    tasks = tuple(Task(id=tid, name=e["name"], start=e["start"], finish=e["finish"], actual_start=e["actual_start"],
                       actual_finish=e["actual_finish"], global_ids=tuple(e["gids"])) for tid, e in found.items())
    return TaskTable(tasks, source, "csv")


def _per_element(source: str, rows, key_col: str, *, by_id: bool, start: str, finish: str) -> TaskTable:
    tasks: list[Task] = []
    used: set[str] = set()
    for number, row in rows:
        key = row.get(key_col, "")
        if not key:
            raise ScheduleError(f"{source}:{number}: the row has no {key_col!r}")
        tid = key if key not in used else f"{key} (line {number})"
        used.add(tid)
        dates = _dates(f"{source}:{number}", row, {}, key, "", start, finish)
        tasks.append(Task(id=tid, name=key, start=dates["start"], finish=dates["finish"],
                          global_ids=(key,) if by_id else (), element_names=() if by_id else (key,)))
    return TaskTable(tuple(tasks), source, "csv")
