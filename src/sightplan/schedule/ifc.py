"""The work schedule inside an IFC model: IFC4 and IFC4X3, and IFC2X3's equivalent relationships.

- Tasks: every ``IfcTask``, ordered from each ``IfcWorkSchedule`` (``IfcRelAssignsToControl`` or ``IfcRelNests``)
  down the ``IfcRelNests`` tree; tasks no schedule reaches follow. A task nesting others
  is a summary; ``outline`` numbers the nesting ('1.2'), ``parent`` is the nesting task.
- Ids: ``Identification`` when every task has a distinct one, else the task's GlobalId
  (``code`` is always the GlobalId).
- Dates (``IfcTaskTime``; IFC2X3 ``IfcScheduleTimeControl`` via ``IfcRelAssignsTasks``):
  planned = ``ScheduleStart``/``ScheduleFinish``, falling back to ``EarlyStart``/``EarlyFinish``;
  actual = ``ActualStart``/``ActualFinish``.
- Elements: ``IfcRelAssignsToProduct`` (task → product) and ``IfcRelAssignsToProcess``
  (products a task operates on). An aggregate (assembly, stair, roof) stands for its parts,
  recursively; its own GlobalId is kept only when it has a representation. A type product
  stands for its occurrences. A spatial container (storey, building, space) is a place, not
  an element: it links nothing and is listed in ``TaskTable.warnings``; an ``IfcSite`` links itself.
"""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import ifcopenshell.util.date as udate
import ifcopenshell.util.element as uel
import numpy as np

from ..errors import ModelError, ScheduleError
from ..model.ifc import open_ifc
from .tasks import NAT, Task, TaskTable, parse_task_date, task_label


def _open(path: Path) -> ifcopenshell.file:
    if not path.is_file():
        raise ScheduleError(f"schedule file not found: {path}")
    try:
        return open_ifc(path)  # an .ifczip is unpacked within the size limit
    except ModelError as exc:
        raise ScheduleError(str(exc)) from None


def _nested_tasks(task: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    """Tasks nested under ``task`` in their IfcRelNests order (IFC4 IsNestedBy, IFC2X3 IsDecomposedBy)."""
    rels = list(getattr(task, "IsNestedBy", None) or ()) + [
        r for r in getattr(task, "IsDecomposedBy", None) or () if r.is_a("IfcRelNests")]
    return [o for r in rels for o in r.RelatedObjects if o.is_a("IfcTask")]


def _ordered_tasks(f: ifcopenshell.file) -> list[tuple[ifcopenshell.entity_instance, ifcopenshell.entity_instance | None, str]]:
    """[(task, parent task or None, outline)] depth first from the work schedules, then the tasks they miss."""
    roots: list[ifcopenshell.entity_instance] = []
    controls = [r for r in f.by_type("IfcRelAssignsToControl") if r.RelatingControl.is_a("IfcWorkControl")]
    controls.sort(key=lambda r: (r.RelatingControl.id(), r.id()))
    for rel in controls:
        roots += [o for o in rel.RelatedObjects if o.is_a("IfcTask")]
    for rel in f.by_type("IfcRelNests"):  # not the standard's way, but some files nest root tasks in the schedule
        if rel.RelatingObject is not None and rel.RelatingObject.is_a("IfcWorkControl"):
            roots += [o for o in rel.RelatedObjects if o.is_a("IfcTask")]
    nested_ids = {c.id() for t in f.by_type("IfcTask") for c in _nested_tasks(t)}
    roots += sorted((t for t in f.by_type("IfcTask") if t.id() not in nested_ids), key=lambda t: t.id())
    roots += sorted(f.by_type("IfcTask"), key=lambda t: t.id())  # tasks only in a nesting cycle
    out: list[tuple] = []
    seen: set[int] = set()
    counter = 0

    def walk(task, parent, outline: str) -> None:
        seen.add(task.id())
        out.append((task, parent, outline))
        children = [c for c in _nested_tasks(task) if c.id() not in seen]
        for i, child in enumerate(children, start=1):
            if child.id() not in seen:
                walk(child, task, f"{outline}.{i}")

    for root in roots:
        if root.id() not in seen:
            counter += 1
            walk(root, None, str(counter))
    return out


def _date(value, source: str, tid: str, name: str, field_name: str) -> np.datetime64:
    if value is None:
        return NAT
    if isinstance(value, ifcopenshell.entity_instance):  # IFC2X3 IfcDateAndTime / IfcCalendarDate
        try:
            value = udate.ifc2datetime(value).isoformat()
        except Exception as exc:  # incomplete date entities
            raise ScheduleError(f"{source}: task {task_label(tid, name)}, {field_name} is not a date: {exc}") from None
    return parse_task_date(str(value), source, tid, name, field_name)


def _times(f: ifcopenshell.file) -> dict[int, ifcopenshell.entity_instance]:
    """Task step id → its time entity: IfcTaskTime (IFC4) or IfcScheduleTimeControl (IFC2X3)."""
    times: dict[int, ifcopenshell.entity_instance] = {}
    for rel in f.by_type("IfcRelAssignsTasks") if f.schema == "IFC2X3" else ():
        if rel.TimeForTask is not None:
            for o in rel.RelatedObjects:
                times.setdefault(o.id(), rel.TimeForTask)
    for t in f.by_type("IfcTask"):
        if getattr(t, "TaskTime", None) is not None:
            times[t.id()] = t.TaskTime
    return times


def _is_spatial(product: ifcopenshell.entity_instance) -> bool:
    """A site, building, storey, space or zone (IFC2X3 has no IfcSpatialElement: is_a is then False)."""
    return product.is_a("IfcSpatialElement") or product.is_a("IfcSpatialStructureElement")


def _expand(product: ifcopenshell.entity_instance, out: dict[str, None], depth: int = 0) -> None:
    """GlobalIds ``product`` stands for: itself and its aggregated parts, recursively."""
    if depth > 64:
        return
    parts = [o for r in getattr(product, "IsDecomposedBy", None) or () if r.is_a("IfcRelAggregates")
             for o in r.RelatedObjects]
    if not parts or getattr(product, "Representation", None) is not None:
        out[product.GlobalId] = None
    for part in parts:
        _expand(part, out, depth + 1)


def _assignments(f: ifcopenshell.file) -> dict[int, list[ifcopenshell.entity_instance]]:
    """Task step id → the products (or type products) it is assigned to."""
    products: dict[int, list] = {}
    for rel in f.by_type("IfcRelAssignsToProduct"):
        for task in rel.RelatedObjects:
            if task.is_a("IfcTask") and rel.RelatingProduct is not None:
                products.setdefault(task.id(), []).append(rel.RelatingProduct)
    for rel in f.by_type("IfcRelAssignsToProcess"):
        task = rel.RelatingProcess
        if task is not None and task.is_a("IfcTask"):
            products.setdefault(task.id(), []).extend(
                o for o in rel.RelatedObjects if o.is_a("IfcProduct") or o.is_a("IfcTypeProduct"))
    return products


def read_ifc(path: str | Path) -> TaskTable:
    """The work schedule of the IFC model at ``path`` (see the module docstring for the mapping)."""
    path = Path(path)
    f = _open(path)
    source = path.name
    ordered = _ordered_tasks(f)
    if not ordered:
        raise ScheduleError(f"{source} has no work schedule (no IfcTask)")
    idents = [str(getattr(t, "Identification", None) or getattr(t, "TaskId", None) or "").strip() for t, _, _ in ordered]
    use_ident = all(idents) and len(set(idents)) == len(idents)
    ids = {t.id(): (ident if use_ident else t.GlobalId) for (t, _, _), ident in zip(ordered, idents)}
    times = _times(f)
    assigned = _assignments(f)
    warnings: list[str] = []
    tasks: list[Task] = []
    for task, parent, outline in ordered:
        tid, name = ids[task.id()], (task.Name or "").strip()
        tt = times.get(task.id())

        def get(attr: str, _tt=tt):
            return getattr(_tt, attr, None) if _tt is not None else None

        start = _date(get("ScheduleStart") or get("EarlyStart"), source, tid, name,
                      "ScheduleStart" if get("ScheduleStart") else "EarlyStart")
        finish = _date(get("ScheduleFinish") or get("EarlyFinish"), source, tid, name,
                       "ScheduleFinish" if get("ScheduleFinish") else "EarlyFinish")
        gids: dict[str, None] = {}
        for product in assigned.get(task.id(), []):
            if product.is_a("IfcTypeObject"):
                for occurrence in uel.get_types(product):
                    _expand(occurrence, gids)
            elif _is_spatial(product) and not product.is_a("IfcSite"):
                warnings.append(f"task {task_label(tid, name)} is assigned to {product.is_a()} "
                                f"{product.Name or product.GlobalId!r}, a place rather than an element: it links nothing "
                                "(link the elements there with a rules file, e.g. storey = ...)")
            else:
                _expand(product, gids)
        tasks.append(Task(
            id=tid, name=name, start=start, finish=finish,
            actual_start=_date(get("ActualStart"), source, tid, name, "ActualStart"),
            actual_finish=_date(get("ActualFinish"), source, tid, name, "ActualFinish"),
            parent=ids[parent.id()] if parent is not None else "", outline=outline,
            summary=bool(_nested_tasks(task)), global_ids=tuple(gids), code=task.GlobalId,
        ))
    return TaskTable(tuple(tasks), source, "ifc", tuple(warnings))
