"""A second, independent reader of a per-element CSV schedule (element GlobalId or name → start, finish dates),
kept beside the tests to cross-check ``sightplan.schedule`` (read_csv + link_schedule) against.

Columns (header row, case-insensitive): ``global_id`` (or ``guid``/``globalid``) or
``name``; ``start``; ``finish`` (or ``end``). Dates as ISO ``YYYY-MM-DD`` (a time may
follow). Elements the file does not name stay unscheduled.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from sightplan.errors import ScheduleError
from sightplan.model.dates import parse_datetime
from sightplan.model.scene import Scene

_ID_COLS = ("global_id", "globalid", "guid")


def _date(text: str, where: str) -> np.datetime64:
    text = (text or "").strip()
    if not text:
        return np.datetime64("NaT")
    return parse_datetime(text, where)


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
    index: dict[str, list[int]] = {}
    for i, k in enumerate(keys.tolist()):
        index.setdefault(k, []).append(i)  # a name may stand for several elements: the row dates them all
    start = scene.elements.start.copy()
    finish = scene.elements.finish.copy()
    linked: set[int] = set()
    unknown = []
    for line, row in enumerate(rows, start=2):
        key = (row.get(key_col) or "").strip()
        idx = index.get(key)
        if idx is None:
            unknown.append(key)
            continue
        start[idx] = _date(row.get(cols["start"], ""), f"{path}:{line}")
        finish[idx] = _date(row.get(finish_col, ""), f"{path}:{line}")
        linked.update(idx)
    if not linked:
        raise ScheduleError(f"the schedule {Path(path).name} links no element of the model "
                            f"({len(unknown)} rows name ids the model does not have)")
    elements = scene.elements.with_dates(start, finish)
    shared = sum(1 for idx in index.values() if len(idx) > 1) if not id_col else 0
    return replace(scene, elements=elements), {"linked": len(linked), "unknown_ids": unknown,
                                               "unlinked": int(scene.n_elements - len(linked)),
                                               "names_shared_by_several_elements": shared}
