"""A plain CSV schedule: element GlobalId (or name) → start, finish dates.

Columns (header row, case-insensitive): ``global_id`` (or ``guid``/``globalid``) or
``name``; ``start``; ``finish`` (or ``end``). Dates as ISO ``YYYY-MM-DD`` (a time may
follow). Elements the file does not name stay unscheduled.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import ScheduleError
from .scene import Scene

_ID_COLS = ("global_id", "globalid", "guid")


def _date(text: str, where: str) -> np.datetime64:
    text = (text or "").strip()
    if not text:
        return np.datetime64("NaT")
    try:
        return np.datetime64(text.replace(" ", "T")[:19], "s")
    except ValueError:
        raise ScheduleError(f"{where}: {text!r} is not a date (expected YYYY-MM-DD)") from None


def apply_csv_schedule(scene: Scene, path: str | Path) -> tuple[Scene, dict]:
    """The scene with start/finish dates from ``path``; and a link report (linked, unknown ids)."""
    from dataclasses import replace

    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as exc:
        raise ScheduleError(f"cannot read schedule {path}: {exc.strerror}") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ScheduleError(f"{path} is not a CSV schedule: {exc}") from None
    if not rows:
        raise ScheduleError(f"{path} has no schedule rows")
    cols = {c.strip().lower(): c for c in rows[0] if c}
    id_col = next((cols[c] for c in _ID_COLS if c in cols), None)
    key_col = id_col or cols.get("name")
    if key_col is None or "start" not in cols or not ({"finish", "end"} & set(cols)):
        raise ScheduleError(f"{path}: a CSV schedule needs columns global_id (or name), start and finish")
    finish_col = cols.get("finish") or cols["end"]
    keys = scene.elements.global_id if id_col else scene.elements.name
    index = {k: i for i, k in enumerate(keys.tolist())}
    start = scene.elements.start.copy()
    finish = scene.elements.finish.copy()
    linked: set[int] = set()
    unknown = []
    for line, row in enumerate(rows, start=2):
        key = (row.get(key_col) or "").strip()
        i = index.get(key)
        if i is None:
            unknown.append(key)
            continue
        start[i] = _date(row.get(cols["start"], ""), f"{path}:{line}")
        finish[i] = _date(row.get(finish_col, ""), f"{path}:{line}")
        linked.add(i)
    if not linked:
        raise ScheduleError(f"the schedule {Path(path).name} links no element of the model "
                            f"({len(unknown)} rows name ids the model does not have)")
    elements = scene.elements.with_dates(start, finish)
    return replace(scene, elements=elements), {"linked": len(linked), "unknown_ids": unknown,
                                               "unlinked": int(scene.n_elements - len(linked))}
