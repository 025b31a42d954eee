"""The formats sightplan reads and writes. Each format's reader is a module of this package that declares its
``FORMAT`` (:mod:`.registry` collects them; :func:`sightplan.plan.load.load_plan` reads through it); the writers
are in ``sightplan.export``, with what the formats share here: MAVLink's command and frame numbers (QGroundControl
``.plan``, QGC WPL), DJI's WPML namespaces and aircraft enumerations, KML's namespace; the names of the formats
written. This module itself is light to import: the command line builds its options from it."""

from __future__ import annotations

from typing import Literal, get_args

#: The flight and map formats sightplan writes (``sightplan export --format``, the web API's ``format``).
ExportFormat = Literal["qgc", "wpl", "wpml", "litchi", "kml", "geojson"]
EXPORT_FORMATS: tuple[str, ...] = get_args(ExportFormat)
#: The autopilots a MAVLink file (qgc, wpl) is written for.
Autopilot = Literal["px4", "ardupilot"]
