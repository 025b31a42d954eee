"""The range of every number a plan holds or a plan request gives: one domain, checked where numbers come in.

The plan file reader, every flight-format reader, the web API's request bodies and the command line refuse a
number outside its range with a :class:`~sightplan.errors.PlanError` that names the field and the value as given
(``NaN``, ``Infinity``, ``1e308``). A plan that passed holds nothing that can turn into NaN further on.

Bounds (inclusive unless said):

- coordinates (m, model frame): finite and within :data:`MAX_COORDINATE_M` of the origin (a projected grid's
  eastings and northings fit); checked against a model, within :func:`reach_m` of its bounding box (default
  :data:`DEFAULT_REACH_M`, ``$SIGHTPLAN_MAX_REACH_M``);
- latitude −90° to 90°, longitude −180° to 360°;
- heights and altitudes (m): within :data:`MAX_HEIGHT_M` of the datum or of the take-off;
- distances (a safety distance, a radius, a line-of-sight radius, an offset, a step, a margin, m): 0 to
  :data:`MAX_DISTANCE_M`;
- angles (°): finite, within :data:`MAX_ANGLE_DEG`; headings are normalised to [0°, 360°);
- speeds: above 0 up to :data:`MAX_SPEED_M_S`; a ground sampling distance above 0 up to :data:`MAX_GSD_M_PX`;
  an overlap 0 to :data:`MAX_OVERLAP`; a capture time 0 to :data:`MAX_TIME_S` (POSIX seconds);
- counts: 0 to :data:`MAX_COUNT`; frames of one plan: at most :data:`MAX_PLAN_FRAMES`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PlanError

MAX_COORDINATE_M = 1.0e7  # 10,000 km: larger than any projected grid's coordinates
DEFAULT_REACH_M = 5000.0  # how far from the model a plan's points may lie
MAX_HEIGHT_M = 20_000.0  # above or below the datum, or the take-off
MAX_DISTANCE_M = 100_000.0
MAX_ANGLE_DEG = 36_000.0  # a hundred turns: more is a typo, and loses precision when normalised
MAX_SPEED_M_S = 100.0
MAX_GSD_M_PX = 10.0
MAX_OVERLAP = 0.99
MAX_TIME_S = 253_402_300_799.0  # the last second of the year 9999
MAX_COUNT = 1_000_000
MAX_PLAN_FRAMES = 1_000_000  # a file or an edit with more frames is not a capture plan
MAX_MISSION_PHOTOS = 100_000  # photos a flight-app mission's triggers may take, counted before they are taken


def shown(value: Any) -> str:
    """A number as a user wrote it: ``NaN``, ``Infinity``, ``-Infinity``, ``1e308``, ``12.5``."""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        return repr(value)
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "Infinity" if v > 0 else "-Infinity"
    if v == int(v) and abs(v) < 1e16:
        return str(int(v))
    return repr(v).replace("e+", "e")


def _range_text(lo: float | None, hi: float | None, unit: str, lo_open: bool) -> str:
    u = f" {unit}" if unit and unit != "°" else unit
    if lo == 0 and lo_open:
        return f"a positive number{f' up to {shown(hi)}{u}' if hi is not None else ''}"
    if lo is not None and hi is not None:
        return f"{'above' if lo_open else 'from'} {shown(lo)}{u} {'up ' if lo_open else ''}to {shown(hi)}{u}"
    if lo is not None:
        return f"{'above' if lo_open else 'at least'} {shown(lo)}{u}"
    return f"at most {shown(hi)}{u}"


def number(name: str, value: Any, lo: float | None = None, hi: float | None = None, unit: str = "",
           lo_open: bool = False) -> float:
    """``value`` as a finite float within [``lo``, ``hi``] (``lo`` excluded when ``lo_open``); a PlanError naming
    ``name`` and the value as given otherwise."""
    if isinstance(value, bool):
        raise PlanError(f"{name}: {value!r} is not a number")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise PlanError(f"{name}: {value!r} is not a number") from None
    if not math.isfinite(v):
        raise PlanError(f"{name}: {shown(value)} is not a finite number")
    if (lo is not None and (v <= lo if lo_open else v < lo)) or (hi is not None and v > hi):
        raise PlanError(f"{name}: {shown(value)} is out of range: {_range_text(lo, hi, unit, lo_open)}")
    return v


def coordinate(name: str, value: Any) -> float:
    """A model-frame coordinate (m)."""
    return number(name, value, -MAX_COORDINATE_M, MAX_COORDINATE_M, "m")


def height(name: str, value: Any) -> float:
    """A height or altitude (m), above a datum or a take-off point."""
    return number(name, value, -MAX_HEIGHT_M, MAX_HEIGHT_M, "m")


def distance(name: str, value: Any, positive: bool = False) -> float:
    """A distance (m): 0 (or above 0 when ``positive``) to :data:`MAX_DISTANCE_M`."""
    return number(name, value, 0.0, MAX_DISTANCE_M, "m", lo_open=positive)


def speed(name: str, value: Any) -> float:
    """A speed (m/s), above 0."""
    return number(name, value, 0.0, MAX_SPEED_M_S, "m/s", lo_open=True)


def angle(name: str, value: Any) -> float:
    """An angle (°), finite and within :data:`MAX_ANGLE_DEG`."""
    return number(name, value, -MAX_ANGLE_DEG, MAX_ANGLE_DEG, "°")


def heading(name: str, value: Any) -> float:
    """A heading (°) normalised to [0, 360)."""
    return angle(name, value) % 360.0


def latitude(name: str, value: Any) -> float:
    return number(name, value, -90.0, 90.0, "°")


def longitude(name: str, value: Any) -> float:
    return number(name, value, -180.0, 360.0, "°")


def count(name: str, value: Any, hi: int = MAX_COUNT) -> int:
    """A whole count, 0 to ``hi``."""
    return int(number(name, value, 0, hi))


def capture_time(name: str, value: Any) -> float:
    """A capture time (POSIX seconds)."""
    return number(name, value, 0.0, MAX_TIME_S, "s")


def point_text(values: ArrayLike) -> str:
    """``[1e308, 0, 5]``: a point with each number as :func:`shown` writes it."""
    return "[" + ", ".join(shown(v) for v in np.asarray(values, float).reshape(-1)) + "]"


def first_bad(values: ArrayLike, lo: float, hi: float) -> int | None:
    """Index of the first row of ``values`` (n, …) with a value that is not finite or outside [lo, hi]; None."""
    a = np.asarray(values, float)
    if not a.size:
        return None
    rows = a.reshape(len(a), -1)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(rows) & (rows >= lo) & (rows <= hi)).all(axis=1)
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def check_points(points: ArrayLike, where: Callable[[int], str] | str, field: str = "position") -> NDArray[np.float64]:
    """(n, 3) model-frame points, every coordinate in range; the error names ``where(i)`` (or ``where``), ``field``
    and the point."""
    P = np.asarray(points, float).reshape(-1, 3)
    i = first_bad(P, -MAX_COORDINATE_M, MAX_COORDINATE_M)
    if i is not None:
        label = where if isinstance(where, str) else where(i)
        if not np.isfinite(P[i]).all():
            raise PlanError(f"{label}: field {field!r} is not finite: {point_text(P[i])}")
        raise PlanError(f"{label}: field {field!r} is out of range: {point_text(P[i])} (a coordinate is at most "
                        f"{MAX_COORDINATE_M / 1000:,.0f} km from the model's origin)")
    return P


def check_times(times: ArrayLike, where: Callable[[int], str]) -> None:
    """Capture times in range; NaN means unknown."""
    t = np.asarray(times, float).reshape(-1)
    known = ~np.isnan(t)
    i = first_bad(np.where(known, t, 0.0), 0.0, MAX_TIME_S)
    if i is not None:
        capture_time(f"{where(i)}: time", t[i])


def reach_m() -> float:
    """How far from the model's bounding box a plan's points may lie (m): ``$SIGHTPLAN_MAX_REACH_M``, else
    :data:`DEFAULT_REACH_M`."""
    try:
        v = float(os.environ.get("SIGHTPLAN_MAX_REACH_M", DEFAULT_REACH_M))
    except ValueError:
        return DEFAULT_REACH_M
    return v if math.isfinite(v) and v > 0 else DEFAULT_REACH_M


def check_near(points: ArrayLike, lo: ArrayLike, hi: ArrayLike, where: Callable[[int], str], field: str = "position",
               reach: float | None = None) -> None:
    """Every (n, 3) point within ``reach`` (default :func:`reach_m`) of the box [``lo``, ``hi``]; the error names
    ``where(i)`` and how far the point lies."""
    P = np.asarray(points, float).reshape(-1, 3)
    if not len(P):
        return
    reach = reach_m() if reach is None else reach
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    d = np.linalg.norm(np.maximum(np.maximum(lo - P, P - hi), 0.0), axis=1)
    far = np.flatnonzero(~(d <= reach))
    if len(far):
        i = int(far[0])
        raise PlanError(f"{where(i)}: {field} {point_text(P[i])} lies {d[i] / 1000:,.1f} km from the model, "
                        f"farther than the {reach / 1000:g} km a plan may reach (SIGHTPLAN_MAX_REACH_M)")


def check_plan_near_model(plan, lo: ArrayLike, hi: ArrayLike) -> None:
    """A plan's frames, waypoints and ground stations within reach of the model box [``lo``, ``hi``]."""
    names = plan.frame_names.tolist()
    check_near(plan.C_world, lo, hi, lambda i: f"frame {i} ({names[i]!r})")
    check_near(plan.waypoints, lo, hi, lambda i: f"waypoint {i}")
    stations = [(k, m.ground_station) for k, m in enumerate(plan.missions) if m.ground_station is not None]
    if stations:
        check_near([s for _, s in stations], lo, hi, lambda i: f"mission {stations[i][0]}", "ground_station")


def check_work(count: float, limit: float, what: str, change: str, unit: str = "frames") -> None:
    """Work estimated before work: refuse ``what``, which would make ``count`` ``unit`` (a template's frames, an
    optimiser's candidates, a mission file's photos), when that is more than ``limit``; the message names the
    parameter to ``change``. Every plan-making path calls this with its own estimate before it builds anything."""
    if not count <= limit:  # NaN too
        shown = f"{count:,.0f}" if count < 1e15 else f"{count:.3g}"
        raise PlanError(f"{what} would make {shown} {unit}, more than the {limit:,.0f} allowed; change {change}")


def check_finite_output(values: ArrayLike, what: str) -> None:
    """An export asserts, before it writes, that every number it writes is finite."""
    a = np.asarray(values, float)
    if a.size and not np.isfinite(a).all():
        raise PlanError(f"{what}: a value is not a finite number; nothing was written")
