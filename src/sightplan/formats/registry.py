"""Every format, collected from the modules of :mod:`sightplan.formats`: a module that declares ``FORMAT`` (a
:class:`~.base.FlightFormat`) is a format, found without being listed anywhere. Loading
(:func:`~sightplan.plan.load.load_plan`), exporting (:func:`~sightplan.export.export_plan`), the command line and
the web API read these tables."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path
from typing import Literal

from ..errors import PlanError
from .base import FlightFormat


def discover() -> dict[str, FlightFormat]:
    """name → format, in list order (``order``, then name), from the ``FORMAT`` of every module of this package."""
    found: list[FlightFormat] = []
    for module in sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])):
        spec = getattr(importlib.import_module(f"{__package__}.{module}"), "FORMAT", None)
        if isinstance(spec, FlightFormat):
            found.append(spec)
    found.sort(key=lambda f: (f.order, f.name))
    names = [f.name for f in found]
    doubled = sorted({n for n in names if names.count(n) > 1})
    if doubled:
        raise RuntimeError(f"two format modules declare the format name(s) {', '.join(doubled)}")
    return {f.name: f for f in found}


FORMATS: dict[str, FlightFormat] = discover()
READERS: tuple[FlightFormat, ...] = tuple(f for f in FORMATS.values() if f.read is not None)

#: The formats :func:`~sightplan.plan.load.load_plan` reads (its ``fmt=``, besides "auto").
PLAN_FORMATS: tuple[str, ...] = tuple(f.name for f in READERS)
PlanFormat = Literal[PLAN_FORMATS]  # type: ignore[valid-type]  # built from the registry: see PLAN_FORMATS
#: The suffixes of the single files sightplan reads (not the files of a folder format such as COLMAP's).
FILE_SUFFIXES: tuple[str, ...] = tuple(dict.fromkeys(s for f in READERS if not f.folder for s in f.suffixes))


def reader(name: str) -> FlightFormat:
    """The format ``name`` as a reader; a PlanError naming the choices for a name that is not one."""
    spec = FORMATS.get(name)
    if spec is None or spec.read is None:
        raise PlanError(f"unknown plan format {name!r}; expected 'auto' or one of {', '.join(PLAN_FORMATS)}")
    return spec
