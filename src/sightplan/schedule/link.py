"""Schedule → element dates: :func:`link_schedule`.

An element is linked to a task when the task names its GlobalId (or, for per-element
CSVs keyed by name, its name) or when a rule (:mod:`.rules`) selects it for the task.
Its dates are those of its tasks: the earliest start and the latest finish. Linking
replaces the scene's dates: elements no task links become unscheduled (NaT), and
``Scene.at(..., unscheduled=...)`` decides whether they stand.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from fnmatch import fnmatchcase
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import ModelError, ScheduleError
from ..model.ifc import open_ifc
from ..model.load import IFC_EXTENSIONS
from ..model.scene import Scene
from .rules import LinkRule, closest, parse_rules, read_rules
from .tasks import TaskTable, _fmt, task_label

SAMPLE = 5  #: how many ids a report or an error quotes
RulesArg = str | Path | Mapping | Sequence[LinkRule] | None


@dataclass(frozen=True)
class LinkReport:
    """How a schedule met a model. Counts of elements are of *target* elements only.

    ``linked_by_schedule``/``linked_by_rules``: targets linked through the schedule's own
    GlobalIds (or element names) / through rules (an element may be both).
    ``rule_elements``: targets each rule selects, in rule order. ``tasks_without_elements``:
    ids of non-summary tasks that link no element. ``missing_ids``: the first GlobalIds
    (or names) the schedule names that the model lacks, ``n_missing_ids`` all of them.
    ``first_date``/``last_date``: earliest start and latest finish of the linked targets.
    """

    schedule: str
    n_tasks: int
    n_rules: int
    n_targets: int
    linked: int
    unlinked: int
    unlinked_ids: tuple[str, ...]
    dated: int
    linked_by_schedule: int
    linked_by_rules: int
    rule_elements: tuple[int, ...]
    linked_task_ids: tuple[str, ...]
    tasks_without_elements: tuple[str, ...]
    n_schedule_ids: int
    n_missing_ids: int
    missing_ids: tuple[str, ...]
    first_date: np.datetime64 | None
    last_date: np.datetime64 | None
    prefer_actual: bool = False
    n_actual: int = 0
    warnings: tuple[str, ...] = field(default=())
    task_names: Mapping[str, str] = field(default_factory=dict, repr=False, compare=False)  #: id → name, for describe()

    def describe(self) -> list[str]:
        """The report as plain lines."""
        pct = 100.0 * self.linked / self.n_targets if self.n_targets else 0.0
        lines = [f"schedule {self.schedule}: {self.n_tasks} tasks" + (f", {self.n_rules} link rules" if self.n_rules else ""),
                 f"linked {self.linked} of {self.n_targets} target elements ({pct:.0f} %), {self.unlinked} unlinked"]
        if self.n_rules:
            lines.append(f"  {self.linked_by_schedule} through the schedule's own element ids, "
                         f"{self.linked_by_rules} through rules")
            lines += [f"  rule {i}: {n} elements" for i, n in enumerate(self.rule_elements, start=1)]
        if self.unlinked:
            lines.append(f"  unlinked: {_sample(self.unlinked_ids, self.unlinked)}")
        if self.first_date is not None and self.last_date is not None:
            basis = "actual dates where recorded, else planned" if self.prefer_actual else "planned dates"
            lines.append(f"dates {_fmt(self.first_date)} … {_fmt(self.last_date)} ({basis})")
            if self.prefer_actual:
                lines.append(f"  {self.n_actual} linked elements take at least one actual date")
        if self.dated < self.linked:
            lines.append(f"{self.linked - self.dated} linked elements have no date: their tasks have none")
        if self.tasks_without_elements:
            shown = [task_label(i, self.task_names.get(i, "")) for i in self.tasks_without_elements[:SAMPLE]]
            lines.append(f"{len(self.tasks_without_elements)} tasks link no element: "
                         f"{_sample(shown, len(self.tasks_without_elements))}")
        if self.n_missing_ids:
            lines.append(f"{self.n_missing_ids} of the {self.n_schedule_ids} element ids in the schedule are not in "
                         f"this model: {_sample(self.missing_ids, self.n_missing_ids)}")
        lines += [f"warning: {w}" for w in self.warnings]
        return lines


def _sample(ids: Sequence[str], total: int) -> str:
    shown = ", ".join(str(i) for i in ids[:SAMPLE])
    return shown + (f", … ({total - SAMPLE} more)" if total > SAMPLE else "")


def _as_rules(rules: RulesArg) -> tuple[LinkRule, ...]:
    if rules is None:
        return ()
    if isinstance(rules, str | Path):
        return read_rules(rules)
    if isinstance(rules, Mapping):
        return parse_rules(rules)
    out = tuple(rules)
    if not all(isinstance(r, LinkRule) for r in out):
        raise ScheduleError("rules must be a TOML file, its parsed table, or LinkRule records")
    return out


# ---------------------------------------------------------------------- IFC schema and properties
@lru_cache(maxsize=8)
def _entity_names(schema: str) -> tuple[str, ...]:
    import ifcopenshell.ifcopenshell_wrapper as wrapper

    try:
        return tuple(sorted(e.name() for e in wrapper.schema_by_name(schema).entities()))
    except (RuntimeError, IndexError, KeyError):
        return ()


def _canonical_class(rule: LinkRule, name: str, schema: str) -> str:
    from ..model.disciplines import lineage

    chain = lineage(schema, name)
    if not chain:
        raise ScheduleError(f"{rule.where}: ifc_class {name!r} is not an {schema} class"
                            f"{closest(name, _entity_names(schema))}")
    return chain[0]


class _Properties:
    """Property values of the scene's elements, read once from the IFC file."""

    def __init__(self, scene: Scene, model_path: Path) -> None:
        import ifcopenshell.util.element as uel

        try:
            f = open_ifc(model_path)
        except ModelError as exc:  # every way an IFC can be unreadable
            raise ScheduleError(f"the rules' properties cannot be read: {exc}") from None
        self.schema = f.schema_identifier
        self.values: list[dict[str, object]] = []
        found = 0
        for gid in scene.elements.global_id.tolist():
            try:
                element = f.by_guid(gid)
            except RuntimeError:  # not in this file
                self.values.append({})
                continue
            found += 1
            flat = {f"{pset}.{prop}": value for pset, props in uel.get_psets(element).items()
                    for prop, value in props.items() if prop != "id"}
            self.values.append(flat)
        if scene.n_elements and not found:
            raise ScheduleError(f"{model_path.name} holds none of the scene's elements: model_path must be the IFC "
                                "file the scene was loaded from")
        self.names = {n for v in self.values for n in v}


def _value_matches(value: object, wanted: tuple[object, ...]) -> bool:
    for w in wanted:
        if isinstance(w, bool):
            if isinstance(value, bool | np.bool_) and bool(value) == w:
                return True
        elif isinstance(w, int | float):
            if isinstance(value, int | float) and not isinstance(value, bool) and np.isclose(float(value), float(w)):
                return True
        elif value is not None and fnmatchcase(str(value), str(w)):
            return True
    return False


def _model_ifc(scene: Scene, model_path: str | Path | None) -> Path | None:
    if model_path is not None:
        path = Path(model_path)
        if not path.is_file():
            raise ScheduleError(f"model file not found: {path}")
        return path
    source = Path(scene.source) if scene.source else None
    if source is not None and source.suffix.lower() in IFC_EXTENSIONS and source.is_file():
        return source
    return None


# ---------------------------------------------------------------------- rules → tasks and elements
def _rule_tasks(rule: LinkRule, tasks: TaskTable) -> list[int]:
    if rule.task is not None:
        hits = [i for i, t in enumerate(tasks) if t.name == rule.task]
        if not hits:
            raise ScheduleError(f"{rule.where}: no task of {tasks.source or 'the schedule'} is named {rule.task!r}"
                                f"{closest(rule.task, {t.name for t in tasks})}")
    elif rule.task_id is not None:
        hits = [i for i, t in enumerate(tasks) if t.id == rule.task_id]
        if not hits:
            raise ScheduleError(f"{rule.where}: no task of {tasks.source or 'the schedule'} has the id {rule.task_id!r}"
                                f"{closest(rule.task_id, tasks.ids)}")
    else:
        pattern = rule.task_pattern or ""
        hits = [i for i, t in enumerate(tasks) if fnmatchcase(t.name, pattern)]
        if not hits:
            raise ScheduleError(f"{rule.where}: task_pattern {pattern!r} matches no task name of "
                                f"{tasks.source or 'the schedule'}")
    return hits


def _rule_mask(rule: LinkRule, scene: Scene, schema: str, props: _Properties | None) -> NDArray[np.bool_]:
    from ..model.disciplines import lineage

    el = scene.elements
    mask = np.ones(len(el), bool)
    if rule.ifc_class:
        wanted = {_canonical_class(rule, c, schema) for c in rule.ifc_class}
        classes = {c: bool(wanted.intersection(lineage(schema, c))) for c in set(el.ifc_class.tolist())}
        mask &= np.array([classes[c] for c in el.ifc_class.tolist()], bool).reshape(len(el))
    for values, column in ((rule.storey, el.storey), (rule.name, el.name)):
        if values:
            mask &= np.array([any(fnmatchcase(v, p) for p in values) for v in column.tolist()], bool).reshape(len(el))
    if rule.discipline:
        mask &= np.isin(el.discipline.astype(str), list(rule.discipline))
    if rule.global_id:
        mask &= np.isin(el.global_id.astype(str), list(rule.global_id))
    for pname, wanted_values in rule.properties:
        assert props is not None
        if pname not in props.names:
            raise ScheduleError(f"{rule.where}: no element of the model has the property {pname!r}"
                                f"{closest(pname, sorted(props.names))}")
        mask &= np.array([pname in v and _value_matches(v[pname], wanted_values) for v in props.values], bool
                         ).reshape(len(el))
    return mask


# ---------------------------------------------------------------------- linking
def link_schedule(scene: Scene, tasks: TaskTable, rules: RulesArg = None, *,
                  model_path: str | Path | None = None, prefer_actual: bool = False) -> tuple[Scene, LinkReport]:
    """The scene with start/finish dates from ``tasks``, and how the link went.

    ``rules``: a TOML rules file, its parsed table, or :class:`LinkRule` records (see
    :mod:`sightplan.schedule.rules`). ``model_path``: the IFC the scene was loaded from,
    needed by property conditions (default: the scene's source when it is an IFC file).
    ``prefer_actual``: a task's actual start/finish, where recorded, replaces the planned one.

    Raises :class:`ScheduleError` for an invalid rule (naming its number and the bad value)
    and when nothing links: a schedule whose GlobalIds are all foreign to the model was made
    for another model and needs a rules file.
    """
    rule_list = _as_rules(rules)
    el = scene.elements
    z = len(el)
    source = tasks.source or "the schedule"

    # ---- validate and evaluate the rules first: a bad rule is reported whatever else happens
    props: _Properties | None = None
    if any(r.properties for r in rule_list):
        ifc = _model_ifc(scene, model_path)
        if ifc is None:
            first = next(r for r in rule_list if r.properties)
            raise ScheduleError(f"{first.where}: property conditions need the IFC file: pass model_path")
        props = _Properties(scene, ifc)
    schema = str(scene.metadata.get("schema") or (props.schema if props else "") or "IFC4")
    rule_hits = [(_rule_tasks(r, tasks), _rule_mask(r, scene, schema, props)) for r in rule_list]

    # ---- (element, task) pairs
    by_gid: dict[str, list[int]] = {}
    by_name: dict[str, list[int]] = {}
    for i, (g, n) in enumerate(zip(el.global_id.tolist(), el.name.tolist())):
        by_gid.setdefault(g, []).append(i)
        by_name.setdefault(n, []).append(i)
    pair_e: list[int] = []
    pair_t: list[int] = []
    named: dict[str, bool] = {}  # element id the schedule names → is it in the model
    for ti, task in enumerate(tasks):
        for key, index in ((task.global_ids, by_gid), (task.element_names, by_name)):
            for k in key:
                hit = index.get(k)
                named[k] = named.get(k, False) or hit is not None
                if hit:
                    pair_e.extend(hit)
                    pair_t.extend([ti] * len(hit))
    n_schedule_pairs = len(pair_e)
    by_schedule = np.zeros(z, bool)
    by_schedule[pair_e] = True
    by_rules = np.zeros(z, bool)
    for task_idx, mask in rule_hits:
        idx = np.flatnonzero(mask)
        by_rules[idx] = True
        for ti in task_idx:
            pair_e.extend(idx.tolist())
            pair_t.extend([ti] * len(idx))
    missing = [k for k, ok in named.items() if not ok]

    if not pair_e:
        raise ScheduleError(_nothing_linked(source, tasks, rule_list, named, missing))

    # ---- dates: earliest start and latest finish over each element's tasks
    e = np.asarray(pair_e, np.int64)
    t = np.asarray(pair_t, np.int64)
    t_start, t_finish = tasks.dates(prefer_actual)
    big = np.iinfo(np.int64).max
    s_vals = t_start.astype(np.int64)[t]
    s_vals[np.isnat(t_start[t])] = big
    start_acc = np.full(z, big, np.int64)
    np.minimum.at(start_acc, e, s_vals)
    finish_acc = np.full(z, np.iinfo(np.int64).min, np.int64)  # the int64 of NaT: NaT loses every max
    np.maximum.at(finish_acc, e, t_finish.astype(np.int64)[t])
    start_acc[start_acc == big] = np.iinfo(np.int64).min
    start = start_acc.astype("datetime64[s]")
    finish = finish_acc.astype("datetime64[s]")
    dated_scene = replace(scene, elements=el.with_dates(start, finish))

    # ---- report
    linked = np.zeros(z, bool)
    linked[e] = True
    targets = el.is_target
    has_date = ~np.isnat(start) | ~np.isnat(finish)
    actual = np.zeros(z, bool)
    if prefer_actual:
        task_actual = ~np.isnat(tasks.actual_start) | ~np.isnat(tasks.actual_finish)
        np.logical_or.at(actual, e, task_actual[t])
    first = np.where(np.isnat(start), finish, start)[linked & targets & has_date]
    last = np.where(np.isnat(finish), start, finish)[linked & targets & has_date]
    used_tasks = set(t.tolist())
    warnings = list(tasks.warnings)
    for rule, (_, mask) in zip(rule_list, rule_hits):
        if not (mask & targets).any():
            warnings.append(f"rule {rule.number} ({rule.task_selector}) selects no target element")
    if n_schedule_pairs == 0 and named:
        warnings.append(f"none of the {len(named)} element ids in the schedule is in this model: only the rules link")
    report = LinkReport(
        schedule=source, n_tasks=len(tasks), n_rules=len(rule_list), n_targets=int(targets.sum()),
        linked=int((linked & targets).sum()), unlinked=int((~linked & targets).sum()),
        unlinked_ids=tuple(el.global_id[~linked & targets].tolist()),
        dated=int((linked & targets & has_date).sum()),
        linked_by_schedule=int((by_schedule & targets).sum()), linked_by_rules=int((by_rules & targets).sum()),
        rule_elements=tuple(int((mask & targets).sum()) for _, mask in rule_hits),
        linked_task_ids=tuple(tk.id for i, tk in enumerate(tasks) if i in used_tasks),
        tasks_without_elements=tuple(tk.id for i, tk in enumerate(tasks) if i not in used_tasks and not tk.summary),
        n_schedule_ids=len(named), n_missing_ids=len(missing), missing_ids=tuple(missing[:SAMPLE]),
        first_date=first.min() if len(first) else None, last_date=last.max() if len(last) else None,
        prefer_actual=prefer_actual, n_actual=int((actual & linked & targets).sum()), warnings=tuple(warnings),
        task_names={tk.id: tk.name for i, tk in enumerate(tasks) if i not in used_tasks},
    )
    return dated_scene, report


def _nothing_linked(source: str, tasks: TaskTable, rules: Sequence[LinkRule], named: dict[str, bool],
                    missing: list[str]) -> str:
    """The plain explanation of a schedule that links no element."""
    rules_note = " and no rule selects any element" if rules else ""
    if named:
        kind = "GlobalIds" if any(t.global_ids for t in tasks) else "element names"
        first = ", ".join(missing[:3]) + (", …" if len(missing) > 3 else "")
        return (f"the schedule {source} names {len(named)} {kind} and none is in this model ({first}){rules_note}: "
                "it was made for another model; link it with a rules file")
    if rules:
        return f"the rules link no element of this model to {source}: every rule selects no element"
    kind = {"mspdi": "an MS Project", "xer": "a Primavera XER", "csv": "a CSV", "ifc": "an IFC"}.get(tasks.format, "a")
    return f"the schedule {source} is {kind} schedule that names no elements: link it with a rules file"
