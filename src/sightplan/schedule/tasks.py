"""Tasks of a construction schedule, whatever file they came from.

A :class:`TaskTable` is a tuple of :class:`Task` records plus where they came from.
Conventions:

- dates are ``numpy.datetime64[s]``, naive local site time as the file writes it
  (a time zone, where given, is converted to UTC); NaT where the file has none;
- ``start``/``finish`` are the planned dates, ``actual_start``/``actual_finish`` the
  recorded ones; a finish before its start is refused;
- ``id`` is the identifier a user writes (rules, reports), unique in the table;
  ``parent`` is the id of the enclosing summary task ('' at the top) and ``outline``
  the WBS outline number ('1.2.3') where the format has one;
- ``global_ids`` are the IFC GlobalIds the file itself assigns to the task;
  ``element_names`` are element names it assigns (per-element CSVs keyed by name).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import overload

import numpy as np
from numpy.typing import NDArray

from ..errors import ScheduleError
from ..model.dates import parse_datetime

NAT = np.datetime64("NaT", "s")
_DAY_FIRST = re.compile(r"^(\d{1,2})[-.](\d{1,2})[-.](\d{4})(?:[ T](\d{1,2}):(\d{2})(?::(\d{2}))?)?$")


def _as_date(value: object, where: str) -> np.datetime64:
    """NaT for None/''/NaT, else :func:`parse_datetime` (ISO text, date, datetime, datetime64)."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return NAT
    if isinstance(value, np.datetime64) and np.isnat(value):
        return NAT
    return parse_datetime(value, where)


def task_label(task_id: str, name: str = "") -> str:
    """``'A1010' ('Mobilize')``: how errors and reports name a task."""
    return f"{task_id!r} ({name!r})" if name and name != task_id else repr(task_id)


def parse_task_date(text: str | None, source: str, task: str, name: str, field_name: str,
                    *, day_first: bool = False) -> np.datetime64:
    """A task date from file text: NaT when empty, else strict ISO 8601 (or ``D-M-YYYY`` with ``day_first``).

    An unreadable date is a :class:`ScheduleError` naming the file, the task, the field and the text.
    """
    original = (text or "").strip()
    if not original:
        return NAT
    text = original
    expected = "YYYY-MM-DD or D-M-YYYY" if day_first else "YYYY-MM-DD"
    where = f"{source}: task {task_label(task, name)}, {field_name}"
    if day_first:
        m = _DAY_FIRST.match(original)
        if m:
            d, mo, y, hh, mm, ss = m.groups()
            text = f"{y}-{int(mo):02d}-{int(d):02d}" + (f"T{int(hh):02d}:{mm}:{ss or '00'}" if hh else "")
    try:
        return parse_datetime(text, where)
    except ScheduleError as exc:
        if text != original:  # a day-first date that is no date: name the text as written
            raise ScheduleError(f"{where} {original!r} is not a date (expected {expected})") from None
        raise ScheduleError(str(exc).replace("(expected YYYY-MM-DD)", f"(expected {expected})")) from None


@dataclass(frozen=True)
class Task:
    """One task (activity). See the module docstring for the conventions."""

    id: str
    name: str = ""
    start: np.datetime64 = NAT
    finish: np.datetime64 = NAT
    actual_start: np.datetime64 = NAT
    actual_finish: np.datetime64 = NAT
    parent: str = ""
    outline: str = ""
    summary: bool = False
    global_ids: tuple[str, ...] = ()
    element_names: tuple[str, ...] = ()
    code: str = ""  #: the format's other identifier: MSPDI ID (row), XER task_id, IFC GlobalId

    def __post_init__(self) -> None:
        object.__setattr__(self, "id", str(self.id))
        object.__setattr__(self, "name", "" if self.name is None else str(self.name))
        for name in ("start", "finish", "actual_start", "actual_finish"):
            object.__setattr__(self, name, _as_date(getattr(self, name), f"task {self.label}, {name}"))
        object.__setattr__(self, "global_ids", tuple(dict.fromkeys(str(g) for g in self.global_ids)))
        object.__setattr__(self, "element_names", tuple(dict.fromkeys(str(n) for n in self.element_names)))

    @property
    def label(self) -> str:
        return task_label(self.id, self.name)

    def dates(self, prefer_actual: bool = False) -> tuple[np.datetime64, np.datetime64]:
        """(start, finish): planned, or with ``prefer_actual`` the actual date wherever there is one."""
        if not prefer_actual:
            return self.start, self.finish
        start = self.start if np.isnat(self.actual_start) else self.actual_start
        finish = self.finish if np.isnat(self.actual_finish) else self.actual_finish
        return start, finish


@dataclass(frozen=True)
class TaskTable:
    """The tasks of one schedule file, in file order (IFC: work-schedule nesting order).

    ``source``: the file name; ``format``: 'ifc', 'mspdi', 'xer' or 'csv';
    ``warnings``: what the reader could read but not use (shown in link reports).
    Validates on construction: unique ids, known parents, no finish before its start.
    """

    tasks: tuple[Task, ...]
    source: str = ""
    format: str = ""
    warnings: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "tasks", tuple(self.tasks))
        object.__setattr__(self, "warnings", tuple(self.warnings))
        where = self.source or "schedule"
        seen: set[str] = set()
        for t in self.tasks:
            if not isinstance(t, Task):
                raise ScheduleError(f"{where}: a task table holds Task records, got {type(t).__name__}")
            if t.id in seen:
                raise ScheduleError(f"{where}: task id {t.id!r} is used by more than one task")
            seen.add(t.id)
            for kind, s, f in (("planned", t.start, t.finish), ("actual", t.actual_start, t.actual_finish)):
                if not np.isnat(s) and not np.isnat(f) and f < s:
                    raise ScheduleError(f"{where}: task {t.label} has its {kind} finish {_fmt(f)} before its start {_fmt(s)}")
        for t in self.tasks:
            if t.parent and t.parent not in seen:
                raise ScheduleError(f"{where}: task {t.label} has parent {t.parent!r}, which is no task of the schedule")

    # ------------------------------------------------------------------ access
    def __len__(self) -> int:
        return len(self.tasks)

    def __iter__(self) -> Iterator[Task]:
        return iter(self.tasks)

    @overload
    def __getitem__(self, key: int) -> Task: ...
    @overload
    def __getitem__(self, key: str) -> Task: ...

    def __getitem__(self, key: int | str) -> Task:
        """A task by position or by id."""
        if isinstance(key, str):
            for t in self.tasks:
                if t.id == key:
                    return t
            raise KeyError(key)
        return self.tasks[key]

    def named(self, name: str) -> list[Task]:
        """Every task whose name is exactly ``name``."""
        return [t for t in self.tasks if t.name == name]

    @property
    def ids(self) -> list[str]:
        return [t.id for t in self.tasks]

    @property
    def names(self) -> list[str]:
        return [t.name for t in self.tasks]

    def _column(self, name: str) -> NDArray[np.datetime64]:
        return np.array([getattr(t, name) for t in self.tasks], dtype="datetime64[s]").reshape(len(self.tasks))

    @property
    def start(self) -> NDArray[np.datetime64]:
        """(n,) planned starts."""
        return self._column("start")

    @property
    def finish(self) -> NDArray[np.datetime64]:
        """(n,) planned finishes."""
        return self._column("finish")

    @property
    def actual_start(self) -> NDArray[np.datetime64]:
        return self._column("actual_start")

    @property
    def actual_finish(self) -> NDArray[np.datetime64]:
        return self._column("actual_finish")

    def dates(self, prefer_actual: bool = False) -> tuple[NDArray[np.datetime64], NDArray[np.datetime64]]:
        """(n,) starts and finishes: planned, or actual wherever there is one with ``prefer_actual``."""
        start, finish = self.start, self.finish
        if prefer_actual:
            a_start, a_finish = self.actual_start, self.actual_finish
            start = np.where(np.isnat(a_start), start, a_start)
            finish = np.where(np.isnat(a_finish), finish, a_finish)
        return start, finish

    @property
    def global_ids(self) -> set[str]:
        """Every GlobalId some task is assigned to."""
        return {g for t in self.tasks for g in t.global_ids}


def _fmt(d: np.datetime64) -> str:
    s = str(d)
    return s[:10] if s.endswith("T00:00:00") else s.replace("T", " ")[:16]


def _dates_of(tasks: TaskTable, task_ids: Iterable[str] | None, prefer_actual: bool,
              skip_summary: bool = False) -> tuple[NDArray[np.datetime64], NDArray[np.datetime64]]:
    """(start, finish) arrays of the chosen tasks."""
    wanted = None if task_ids is None else set(task_ids)
    chosen = np.array([(wanted is None or t.id in wanted) and not (skip_summary and t.summary) for t in tasks],
                      bool).reshape(len(tasks))
    start, finish = tasks.dates(prefer_actual)
    return start[chosen], finish[chosen]


def date_range(tasks: TaskTable, *, prefer_actual: bool = False,
               task_ids: Iterable[str] | None = None) -> tuple[np.datetime64, np.datetime64]:
    """(first start, last finish) of the schedule as ``datetime64[s]``; a task's missing date falls back to its other one.

    ``task_ids``: only these tasks (e.g. ``LinkReport.linked_task_ids``). Raises when no task has a date.
    """
    start, finish = _dates_of(tasks, task_ids, prefer_actual)
    start, finish = np.where(np.isnat(start), finish, start), np.where(np.isnat(finish), start, finish)
    if np.isnat(start).all():
        raise ScheduleError(f"{tasks.source or 'the schedule'}: no task has a date")
    return start[~np.isnat(start)].min(), finish[~np.isnat(finish)].max()


def task_finishes(tasks: TaskTable, *, prefer_actual: bool = False,
                  task_ids: Iterable[str] | None = None) -> NDArray[np.datetime64]:
    """Sorted distinct finish days (``datetime64[D]``) of the tasks: the dates at which the site changes.

    Summary tasks are left out (their finish is a child's finish). ``task_ids``: only these tasks.
    """
    _, finish = _dates_of(tasks, task_ids, prefer_actual, skip_summary=True)
    return np.unique(finish[~np.isnat(finish)].astype("datetime64[D]"))
