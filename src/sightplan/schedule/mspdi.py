"""MS Project XML (MSPDI, namespace ``http://schemas.microsoft.com/project``).

Each ``Project/Tasks/Task`` becomes a :class:`Task`: ``id`` = UID (stable across edits),
``code`` = ID (the row number), ``Start``/``Finish`` planned, ``ActualStart``/``ActualFinish``
actual, ``OutlineNumber`` → ``outline``, the parent from ``OutlineLevel`` (file order),
``Summary`` = 1 → ``summary``. The project summary task (UID 0) and blank rows
(``IsNull`` = 1) are skipped. Names are stripped of surrounding blanks. MSPDI assigns
no IFC elements: link it with a rules file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from ..errors import ScheduleError
from .tasks import Task, TaskTable, parse_task_date

NAMESPACE = "http://schemas.microsoft.com/project"


def _local(tag: str) -> tuple[str, str]:
    """(namespace, local name) of an ElementTree tag."""
    if tag.startswith("{"):
        ns, _, name = tag[1:].partition("}")
        return ns, name
    return "", tag


def read_mspdi(path: str | Path) -> TaskTable:
    """The tasks of an MS Project XML file (see the module docstring for the mapping)."""
    path = Path(path)
    source = path.name
    if not path.is_file():
        raise ScheduleError(f"schedule file not found: {path}")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ScheduleError(f"{source} is not readable XML: {exc}") from None
    except OSError as exc:
        raise ScheduleError(f"cannot read schedule {path}: {exc.strerror}") from None
    ns, name = _local(root.tag)
    if name != "Project" or ns not in ("", NAMESPACE):
        raise ScheduleError(f"{source} is not an MS Project XML file (root element {name!r}"
                            f"{f' in namespace {ns!r}' if ns else ''}, expected 'Project' in {NAMESPACE!r})")
    q = (lambda tag: f"{{{ns}}}{tag}") if ns else (lambda tag: tag)
    container = root.find(q("Tasks"))
    if container is None:
        raise ScheduleError(f"{source} has no <Tasks>: an MS Project XML file without tasks")

    tasks: list[Task] = []
    stack: list[tuple[int, str]] = []  # (outline level, uid) of the open ancestors
    for n, el in enumerate(container.findall(q("Task")), start=1):

        def text(tag: str, _el=el) -> str:
            child = _el.find(q(tag))
            return (child.text or "").strip() if child is not None else ""

        uid = text("UID")
        task_name = text("Name")
        if not uid:
            raise ScheduleError(f"{source}: task number {n} ({task_name!r}) has no UID")
        if uid == "0" or text("IsNull") == "1":
            continue
        outline = text("OutlineNumber")
        level_text = text("OutlineLevel")
        try:
            level = int(level_text) if level_text else (outline.count(".") + 1 if outline else 1)
        except ValueError:
            raise ScheduleError(f"{source}: task {uid!r} ({task_name!r}), OutlineLevel {level_text!r} is not a number") from None
        while stack and stack[-1][0] >= level:
            stack.pop()
        parent = stack[-1][1] if stack else ""
        stack.append((level, uid))

        def date(tag: str, _uid=uid, _name=task_name) -> object:
            return parse_task_date(text(tag), source, _uid, _name, tag)

        tasks.append(Task(
            id=uid, name=task_name, start=date("Start"), finish=date("Finish"),
            actual_start=date("ActualStart"), actual_finish=date("ActualFinish"),
            parent=parent, outline=outline, summary=text("Summary") == "1", code=text("ID"),
        ))
    if not tasks:
        raise ScheduleError(f"{source} has no tasks")
    return TaskTable(tuple(tasks), source, "mspdi")
