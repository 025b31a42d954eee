"""sightplan's own JSON plan (:mod:`sightplan.plan.format`), as :func:`~sightplan.plan.load.load_plan` finds it."""

from __future__ import annotations

from ..plan.format import FORMAT_NAME, plan_from_dict
from ..plan.types import Plan
from .base import FlightFormat, ReadOptions, Source


def sniff(source: Source) -> bool:
    """Whether the JSON says it is a sightplan plan."""
    data = source.json()
    return isinstance(data, dict) and data.get("format") == FORMAT_NAME


def _read(source: Source, options: ReadOptions) -> Plan:
    return plan_from_dict(source.json())


FORMAT = FlightFormat(name="sightplan", label="sightplan", order=0, read=_read, suffixes=(".json",), sniff=sniff,
                      what=f"a sightplan plan ('format': {FORMAT_NAME!r})")
