"""What a template is, as data: its parameters (a frozen dataclass whose fields carry their unit, bounds and help) and
the function that makes its frames.

A template module declares one :class:`Template`; :mod:`.registry` finds it. The command line's options
(:mod:`sightplan.cli.plan_cmd`), the web API's request schema (a union on ``template``) and the page's form
(``GET /api/templates``) are all generated from these declarations, so a template is described in one place.

A parameter is declared with :func:`param`::

    @dataclass(frozen=True)
    class OrbitParams(Params):
        step_deg: float | None = param(None, "degrees between frames (default: by overlap)", gt=0, le=180, cli="step")

Field names carry their unit (``_m``, ``_deg``, ``_m_px``); ``cli`` names the command-line option when several
templates share one (``--step`` is an orbit's degrees and a route's metres). Constructing a parameter object checks
every bound and choice and raises :class:`~sightplan.errors.PlanError` naming the parameter.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from ...camera.models import Camera
from ...errors import PlanError
from ...model.scene import Scene
from ..domain import MAX_COORDINATE_M, point_text, shown
from ..types import Plan

#: The most points or values one list parameter takes (a route's points, an orbit's radii).
MAX_POINTS = 10_000

#: How a parameter is entered (the page's form and the command line read it):
#: number, numbers (a list), choice, flag, points2 / points3 (picked or typed points), file (command line only).
Kind = Literal["number", "numbers", "choice", "flag", "points2", "points3", "file"]


@dataclass(frozen=True)
class ParamInfo:
    """A parameter's description: help text, unit, bounds, choices, how it is entered, and its command-line name."""

    help: str
    unit: str = ""
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    kind: Kind = "number"
    choices: tuple[str, ...] = ()
    cli: str | None = None  # the option's name without dashes; default: the field's name without its unit
    web: bool = True  # False: command line only (a local file)
    label: str = ""  # the form's label; default from the name
    pair: str = ""  # lists with the same pair name go together index by index (an orbit's ring: radius, height)

    def bounds_text(self) -> str:
        parts = [f"≥ {self.ge:g}" if self.ge is not None else "", f"> {self.gt:g}" if self.gt is not None else "",
                 f"≤ {self.le:g}" if self.le is not None else "", f"< {self.lt:g}" if self.lt is not None else ""]
        return ", ".join(p for p in parts if p)


_UNITS = {"_deg": "°", "_m_px": "m/px", "_m": "m"}


def unit_of(name: str) -> str:
    """The unit a field's name ends with ('' for none)."""
    return next((u for suffix, u in _UNITS.items() if name.endswith(suffix)), "")


def bare_name(name: str) -> str:
    """A field's name without its unit ("deck_z_m" → "deck_z")."""
    return next((name.removesuffix(s) for s in _UNITS if name.endswith(s)), name)


def label_of(name: str, info: ParamInfo) -> str:
    """A parameter's label on a form: its declared one, else its name without the unit ("deck_z_m" → "Deck z")."""
    return info.label or bare_name(name).replace("_", " ").capitalize()


def cli_name(name: str, info: ParamInfo) -> str:
    """A parameter's command-line option, without dashes: its declared one, else its name without the unit
    ("oblique_pitch_deg" → "oblique-pitch")."""
    return info.cli or bare_name(name).replace("_", "-")


def param(default: Any, help: str, *, ge: float | None = None, gt: float | None = None, le: float | None = None,
          lt: float | None = None, choices: tuple[str, ...] = (), kind: Kind | None = None, cli: str | None = None,
          web: bool = True, label: str = "", pair: str = "") -> Any:
    """A dataclass field holding a template parameter; a list or tuple default becomes an empty-tuple default."""
    if kind is None:
        kind = "choice" if choices else "flag" if isinstance(default, bool) else "number"
    info = ParamInfo(help=help, ge=ge, gt=gt, le=le, lt=lt, kind=kind, choices=tuple(choices), cli=cli, web=web,
                     label=label, pair=pair)
    return dataclasses.field(default=default, metadata={"param": info})


@dataclass(frozen=True)
class Params:
    """Base of every template's parameter dataclass: construction checks each value against its declaration."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            check_value(f.name, getattr(self, f.name), info_of(f))


def info_of(f: dataclasses.Field) -> ParamInfo:
    return f.metadata["param"]


def check_value(name: str, value: Any, info: ParamInfo) -> None:
    """A PlanError naming ``name`` when ``value`` breaks its bounds, choices or shape (None passes: the default)."""
    if value is None:
        return
    if info.kind == "choice":
        if value not in info.choices:
            raise PlanError(f"{name} must be one of {', '.join(repr(c) for c in info.choices)}, got {value!r}")
        return
    if info.kind in ("flag", "file"):
        return
    if info.kind in ("points2", "points3"):
        n = 2 if info.kind == "points2" else 3
        if len(value) > MAX_POINTS:
            raise PlanError(f"{name}: {len(value):,} points, more than the {MAX_POINTS:,} a template takes")
        for q in value:
            if len(q) != n or not all(math.isfinite(float(c)) for c in q):
                raise PlanError(f"each point of {name} must be {n} finite numbers, got {point_text(q)}")
            if not all(abs(float(c)) <= MAX_COORDINATE_M for c in q):
                raise PlanError(f"a point of {name} is out of range: {point_text(q)} (a coordinate is at most "
                                f"{MAX_COORDINATE_M / 1000:,.0f} km from the model's origin)")
        return
    if info.kind == "numbers" and len(value) > MAX_POINTS:
        raise PlanError(f"{name}: {len(value):,} values, more than the {MAX_POINTS:,} a template takes")
    for v in (value if info.kind == "numbers" else (value,)):
        if not math.isfinite(float(v)):
            raise PlanError(f"{name}: {shown(v)} is not a finite number")
        if ((info.ge is not None and v < info.ge) or (info.gt is not None and v <= info.gt)
                or (info.le is not None and v > info.le) or (info.lt is not None and v >= info.lt)):
            raise PlanError(f"{name} must be {info.bounds_text()}, got {shown(v)}")


#: builds a template's frames: (scene, camera, parameters, safety distance (m), least height (m)) → Plan
Builder = Callable[[Scene, Camera, Any, float, float], Plan]


@dataclass(frozen=True)
class Template:
    """A template: its name, a one-line summary, its parameter dataclass, its builder, whether it is walked (no
    line of sight, altitude limit or minimum height to keep), and its place in lists (``order``)."""

    name: str
    summary: str
    params: type[Params]
    build: Builder
    walked: bool = False
    order: int = 100

    def fields(self) -> list[tuple[str, ParamInfo, Any]]:
        """(name, declaration, default) per parameter, in declaration order."""
        return [(f.name, info_of(f), f.default) for f in dataclasses.fields(self.params)]

    def web_fields(self) -> list[tuple[str, ParamInfo, Any]]:
        """:meth:`fields` that the web application's request and form carry."""
        return [f for f in self.fields() if f[1].web]

    def make(self, values: dict[str, Any]) -> Params:
        """The parameters from ``values`` (unknown names refused; missing ones take their defaults), checked."""
        known = {f.name for f in dataclasses.fields(self.params)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise PlanError(f"the {self.name} template takes no {', '.join(unknown)}: it takes {', '.join(sorted(known))}")
        return self.params(**{k: _frozen(v) for k, v in values.items()})


def _frozen(v: Any) -> Any:
    """Lists (of lists) as tuples, so a parameter object stays hashable and immutable."""
    return tuple(_frozen(x) for x in v) if isinstance(v, (list, tuple)) else v
