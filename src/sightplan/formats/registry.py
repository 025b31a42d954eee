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


def discover(folder: Path | None = None, package: str | None = None) -> dict[str, FlightFormat]:
    """name → format, in list order (``order``, then name), from the ``FORMAT`` of every module of this package (or of
    the package ``package`` in ``folder``)."""
    folder = folder or Path(__file__).parent
    package = package or __package__
    found: list[FlightFormat] = []
    for module in sorted(m.name for m in pkgutil.iter_modules([str(folder)])):
        spec = getattr(importlib.import_module(f"{package}.{module}"), "FORMAT", None)
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
WRITERS: tuple[FlightFormat, ...] = tuple(f for f in FORMATS.values() if f.write is not None)

#: The flight and map formats sightplan writes (``sightplan export --format``, the web API's ``format``).
EXPORT_FORMATS: tuple[str, ...] = tuple(f.name for f in WRITERS)
ExportFormat = Literal[EXPORT_FORMATS]  # type: ignore[valid-type]  # built from the registry: see EXPORT_FORMATS

#: The formats :func:`~sightplan.plan.load.load_plan` reads (its ``fmt=``, besides "auto").
PLAN_FORMATS: tuple[str, ...] = tuple(f.name for f in READERS)
PlanFormat = Literal[PLAN_FORMATS]  # type: ignore[valid-type]  # built from the registry: see PLAN_FORMATS
#: The suffixes of the single files sightplan reads (not the files of a folder format such as COLMAP's).
FILE_SUFFIXES: tuple[str, ...] = tuple(dict.fromkeys(s for f in READERS if not f.folder for s in f.suffixes))


def writer(name: str) -> FlightFormat:
    """The format ``name`` as a writer; a PlanError naming the choices for a name that is not one."""
    spec = FORMATS.get(name)
    if spec is None or spec.write is None:
        raise PlanError(f"unknown export format {name!r}; expected one of {', '.join(EXPORT_FORMATS)}")
    return spec


def export_choices() -> str:
    """The export formats, each with a few words on it: "qgc (QGroundControl .plan), …, kml, geojson"."""
    return ", ".join(f"{f.name} ({f.help})" if f.help else f.name for f in WRITERS)


def writers_with(field: str) -> tuple[str, ...]:
    """The names of the export formats whose ``field`` is set, e.g. "autopilot": those written for one autopilot."""
    return tuple(f.name for f in WRITERS if getattr(f, field))


def reader(name: str) -> FlightFormat:
    """The format ``name`` as a reader; a PlanError naming the choices for a name that is not one."""
    spec = FORMATS.get(name)
    if spec is None or spec.read is None:
        raise PlanError(f"unknown plan format {name!r}; expected 'auto' or one of {', '.join(PLAN_FORMATS)}")
    return spec
