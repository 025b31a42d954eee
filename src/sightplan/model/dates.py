"""Dates as users write them, parsed strictly (ISO 8601) into numpy datetimes.

``2024-05-01``, ``20240501`` and ``2024-05-01T08:00`` are accepted; a time zone is
converted to UTC. Anything else is a :class:`~sightplan.errors.ScheduleError` naming the text.
"""

from __future__ import annotations

import datetime as dt

import numpy as np

from ..errors import ScheduleError


def parse_datetime(text: object, where: str = "date") -> np.datetime64:
    """A ``datetime64[s]`` (UTC, naive) from ISO 8601 text, a date, a datetime or a datetime64."""
    if isinstance(text, np.datetime64):
        if np.isnat(text):
            raise ScheduleError(f"{where} is not a date (NaT)")
        return text.astype("datetime64[s]")
    if isinstance(text, dt.datetime):
        value = text
    elif isinstance(text, dt.date):
        value = dt.datetime(text.year, text.month, text.day)
    elif isinstance(text, str) and text.strip():
        s = text.strip().replace(" ", "T", 1)
        try:
            value = dt.datetime.fromisoformat(s.replace("Z", "+00:00"))
        except ValueError:
            raise ScheduleError(f"{where} {text!r} is not a date (expected YYYY-MM-DD)") from None
    else:
        raise ScheduleError(f"{where} {text!r} is not a date (expected YYYY-MM-DD)")
    if value.tzinfo is not None:
        value = value.astimezone(dt.UTC).replace(tzinfo=None)
    if not 1800 <= value.year <= 2300:
        raise ScheduleError(f"{where} {text!r} is outside the years 1800–2300")
    return np.datetime64(value.replace(microsecond=0), "s")


def parse_day(text: object, where: str = "capture date") -> np.datetime64:
    """A ``datetime64[D]`` from the same inputs as :func:`parse_datetime`."""
    return parse_datetime(text, where).astype("datetime64[D]")
