"""Primavera P6 XER: tab-separated tables (``%T`` table, ``%F`` fields, ``%R`` rows, ``%E`` end).

From the ``TASK`` table: ``id`` = ``task_code`` (the Activity ID users see; prefixed with
the project's short name when several projects share codes), ``code`` = ``task_id``,
``task_name``, planned ``target_start_date``/``target_end_date`` (falling back to
``early_start_date``/``early_end_date``), actual ``act_start_date``/``act_end_date``.
``outline`` is the activity's WBS path (``PROJWBS`` short names joined with '.', the
project node left out); ``task_type`` ``TT_WBS`` marks a summary. Other tables are
ignored. Dates are written ``2015-03-02 08:00``. The text is UTF-8 when it decodes
as such, else Windows-1252 (P6's usual export encoding). XER assigns no IFC elements.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from ..errors import ScheduleError
from .tasks import Task, TaskTable, parse_task_date

REQUIRED = ("task_id", "task_code", "task_name")


def decode(data: bytes) -> str:
    """UTF-8 (with or without BOM) when valid, else Windows-1252, else Latin-1 (never fails)."""
    for encoding in ("utf-8-sig", "cp1252"):
        try:
            return data.decode(encoding)
        except UnicodeDecodeError:
            continue
    return data.decode("latin-1")


def read_tables(path: str | Path) -> dict[str, list[dict[str, str]]]:
    """Every table of an XER file as {table name: [row as {field: text}]}."""
    path = Path(path)
    source = path.name
    try:
        text = decode(path.read_bytes())
    except OSError as exc:
        raise ScheduleError(f"cannot read schedule {path}: {exc.strerror}") from None
    lines = text.splitlines()
    first = next((ln for ln in lines if ln.strip()), "")
    if not first.startswith("ERMHDR"):
        raise ScheduleError(f"{source} is not a Primavera XER file (it does not start with ERMHDR)")
    tables: dict[str, list[dict[str, str]]] = {}
    table: str | None = None
    fields: list[str] | None = None
    for number, line in enumerate(lines, start=1):
        if not line.strip() or line.startswith("ERMHDR"):
            continue
        parts = line.split("\t")
        mark = parts[0].strip()
        if mark == "%T":
            table = parts[1].strip() if len(parts) > 1 else ""
            fields = None
            tables.setdefault(table, [])
        elif mark == "%F":
            fields = [p.strip() for p in parts[1:]]
        elif mark == "%R":
            if table is None or fields is None:
                raise ScheduleError(f"{source}:{number}: a %R row before its table's %T and %F lines")
            values = parts[1:]
            if len(values) > len(fields):
                raise ScheduleError(f"{source}:{number}: table {table} row has {len(values)} values for {len(fields)} fields")
            values += [""] * (len(fields) - len(values))
            tables[table].append(dict(zip(fields, values)))
        elif mark == "%E":
            break
        else:
            raise ScheduleError(f"{source}:{number}: unexpected line {line[:40]!r} (XER lines start with %T, %F, %R or %E)")
    return tables


def _wbs_paths(tables: dict[str, list[dict[str, str]]]) -> dict[str, str]:
    """wbs_id → 'A.B.C' path of WBS short names below the project node."""
    nodes = {r.get("wbs_id", ""): r for r in tables.get("PROJWBS", [])}
    paths: dict[str, str] = {}
    for wbs_id in nodes:
        names: list[str] = []
        current, guard = nodes.get(wbs_id), 0
        while current is not None and current.get("proj_node_flag", "N") != "Y" and guard < 100:
            names.append(current.get("wbs_short_name", "").strip())
            current, guard = nodes.get(current.get("parent_wbs_id", "")), guard + 1
        paths[wbs_id] = ".".join(reversed(names))
    return paths


def read_xer(path: str | Path) -> TaskTable:
    """The activities of a Primavera P6 XER file (see the module docstring for the mapping)."""
    path = Path(path)
    source = path.name
    if not path.is_file():
        raise ScheduleError(f"schedule file not found: {path}")
    tables = read_tables(path)
    rows = tables.get("TASK")
    if not rows:
        raise ScheduleError(f"{source} has no TASK table (no activities)")
    fields = set(rows[0])
    missing = [f for f in REQUIRED if f not in fields]
    if missing:
        raise ScheduleError(f"{source}: the TASK table lacks the field(s) {', '.join(missing)}")
    start_field = "target_start_date" if "target_start_date" in fields else "early_start_date"
    end_field = "target_end_date" if "target_end_date" in fields else "early_end_date"
    if start_field not in fields or end_field not in fields:
        raise ScheduleError(f"{source}: the TASK table has neither target_start_date/target_end_date "
                            "nor early_start_date/early_end_date")
    projects = {r.get("proj_id", ""): (r.get("proj_short_name") or r.get("proj_id", "")).strip()
                for r in tables.get("PROJECT", [])}
    codes = Counter(r["task_code"].strip() for r in rows)
    several = any(n > 1 for n in codes.values()) and len({r.get("proj_id", "") for r in rows}) > 1
    wbs = _wbs_paths(tables)
    tasks = []
    for r in rows:
        code = r["task_code"].strip() or r["task_id"].strip()
        if several:
            code = f"{projects.get(r.get('proj_id', ''), r.get('proj_id', ''))}/{code}"
        name = r["task_name"].strip()

        def date(field_name: str, _r=r, _code=code, _name=name):
            return parse_task_date(_r.get(field_name, ""), source, _code, _name, field_name)

        actual_start = date("act_start_date") if "act_start_date" in fields else None
        actual_finish = date("act_end_date") if "act_end_date" in fields else None
        start, finish = date(start_field), date(end_field)
        if np.isnat(start) and start_field != "early_start_date" and "early_start_date" in fields:
            start = date("early_start_date")  # no target date: the scheduled early date
        if np.isnat(finish) and end_field != "early_end_date" and "early_end_date" in fields:
            finish = date("early_end_date")
        tasks.append(Task(
            id=code, name=name, start=start, finish=finish, actual_start=actual_start, actual_finish=actual_finish,
            outline=wbs.get(r.get("wbs_id", ""), ""), summary=r.get("task_type", "").strip() == "TT_WBS",
            code=r["task_id"].strip(),
        ))
    return TaskTable(tuple(tasks), source, "xer")
