"""Link rules: which model elements a task builds, for schedules that name no elements.

A rules file is TOML with one ``[[link]]`` table per rule::

    [[link]]
    task = "Staalconstructie"              # exact task name; or task_id = "A1010"; or task_pattern = "Staal*"
    ifc_class = ["IfcBeam", "IfcColumn"]   # with subtypes
    storey = "Level 1*"                    # fnmatch pattern(s) on the storey name
    discipline = "S"                       # S, A, M, P, E ('' = unclassified)
    name = "HEA*"                          # fnmatch pattern(s) on the element name
    global_id = ["2O2Fr$t4X7Zf8NOew3FLOH"] # exact GlobalIds
    property = { "Pset_BeamCommon.LoadBearing" = true }   # needs the IFC file

Exactly one of ``task`` (every task of that exact name), ``task_id``, ``task_pattern``
(fnmatch on task names) names the task(s); at least one
condition selects elements. Conditions are ANDed; a list means any of its values. Patterns
are case-sensitive (``fnmatch.fnmatchcase``). A property is ``"Pset.Property"`` (property
and quantity sets, the type's included, as IfcOpenShell's ``get_psets`` reads them); a string
value is a pattern on the value's text, a boolean or number must be equal. Every rule
applies; an element several rules (or tasks) link takes the earliest start and the latest finish.
"""

from __future__ import annotations

import difflib
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ..errors import ScheduleError

TASK_KEYS = ("task", "task_id", "task_pattern")
CONDITION_KEYS = ("ifc_class", "storey", "discipline", "name", "global_id", "property")
DISCIPLINES = ("S", "A", "M", "P", "E", "")
PropertyValue = str | bool | int | float


@dataclass(frozen=True)
class LinkRule:
    """One ``[[link]]`` rule; ``number`` is its 1-based position in the file."""

    number: int
    task: str | None = None
    task_id: str | None = None
    task_pattern: str | None = None
    ifc_class: tuple[str, ...] = ()
    storey: tuple[str, ...] = ()
    discipline: tuple[str, ...] = ()
    name: tuple[str, ...] = ()
    global_id: tuple[str, ...] = ()
    properties: tuple[tuple[str, tuple[PropertyValue, ...]], ...] = ()  #: the ``property`` table
    source: str = ""

    @property
    def where(self) -> str:
        return f"{self.source + ': ' if self.source else ''}rule {self.number}"

    @property
    def task_selector(self) -> str:
        """``task = 'X'``, ``task_id = 'X'`` or ``task_pattern = 'X'``, as written."""
        for key in TASK_KEYS:
            if getattr(self, key) is not None:
                return f"{key} = {getattr(self, key)!r}"
        return ""


def closest(word: str, choices, n: int = 3) -> str:
    """' (closest: 'a', 'b')' for the nearest choices, or ''."""
    near = difflib.get_close_matches(word, list(choices), n=n, cutoff=0.6)
    return f" (closest: {', '.join(repr(c) for c in near)})" if near else ""


def _strings(value: object, where: str, key: str) -> tuple[str, ...]:
    values = value if isinstance(value, list) else [value]
    if not values or not all(isinstance(v, str) for v in values):
        raise ScheduleError(f"{where}: {key} must be a text or a list of texts, got {value!r}")
    return tuple(values)


def _rule(number: int, table: object, source: str) -> LinkRule:
    where = f"{source + ': ' if source else ''}rule {number}"
    if not isinstance(table, Mapping):
        raise ScheduleError(f"{where}: a [[link]] entry must be a table, got {table!r}")
    for key in table:
        if key not in TASK_KEYS + CONDITION_KEYS:
            raise ScheduleError(f"{where}: unknown key {key!r}{closest(key, TASK_KEYS + CONDITION_KEYS)}; "
                                f"allowed: {', '.join(TASK_KEYS + CONDITION_KEYS)}")
    selectors = [k for k in TASK_KEYS if k in table]
    if len(selectors) != 1:
        raise ScheduleError(f"{where}: name the task with exactly one of task, task_id, task_pattern "
                            f"(found {', '.join(selectors) or 'none'})")
    selector = selectors[0]
    if not isinstance(table[selector], str) or not table[selector]:
        raise ScheduleError(f"{where}: {selector} must be a non-empty text, got {table[selector]!r}")
    if not any(k in table for k in CONDITION_KEYS):
        raise ScheduleError(f"{where}: no condition selects elements; give at least one of {', '.join(CONDITION_KEYS)} "
                            "(name = \"*\" selects every element)")
    fields: dict = {selector: table[selector]}
    for key in ("ifc_class", "storey", "discipline", "name", "global_id"):
        if key in table:
            fields[key] = _strings(table[key], where, key)
    for d in fields.get("discipline", ()):
        if d not in DISCIPLINES:
            raise ScheduleError(f"{where}: discipline {d!r} is not one of {', '.join(repr(x) for x in DISCIPLINES)}")
    if "property" in table:
        props = table["property"]
        if not isinstance(props, Mapping) or not props:
            raise ScheduleError(f"{where}: property must be a table like {{ \"Pset_WallCommon.LoadBearing\" = true }}")
        parsed = []
        for pname, value in props.items():
            pset, dot, prop = pname.partition(".")
            if not dot or not pset or not prop:
                raise ScheduleError(f"{where}: property {pname!r} must be written \"PropertySet.Property\"")
            values = value if isinstance(value, list) else [value]
            if not values or not all(isinstance(v, str | bool | int | float) for v in values):
                raise ScheduleError(f"{where}: property {pname!r} must be a text, boolean or number "
                                    f"(or a list of them), got {value!r}")
            parsed.append((pname, tuple(values)))
        fields["properties"] = tuple(parsed)
    return LinkRule(number=number, source=source, **fields)


def parse_rules(data: Mapping, source: str = "") -> tuple[LinkRule, ...]:
    """Rules from parsed TOML (``{"link": [{...}, ...]}``), checked for unknown keys and wrong types."""
    if not isinstance(data, Mapping):
        raise ScheduleError(f"{source or 'rules'}: expected a table of [[link]] rules")
    unknown = [k for k in data if k != "link"]
    if unknown:
        raise ScheduleError(f"{source or 'rules'}: unknown top-level key {unknown[0]!r}{closest(unknown[0], ['link'])}; "
                            "a rules file holds [[link]] tables only")
    links = data.get("link")
    if not isinstance(links, list) or not links:
        raise ScheduleError(f"{source or 'rules'}: no [[link]] rules")
    return tuple(_rule(i, table, source) for i, table in enumerate(links, start=1))


def read_rules(path: str | Path) -> tuple[LinkRule, ...]:
    """The rules of a TOML rules file (see the module docstring for the format)."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except OSError as exc:
        raise ScheduleError(f"cannot read rules file {path}: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScheduleError(f"{path.name} is not valid TOML: {exc}") from None
    return parse_rules(data, path.name)
