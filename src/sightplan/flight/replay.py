"""A mission replayed by its autopilot's rules: the dispatch to :mod:`.px4` and :mod:`.ardupilot`, for items or a
file."""

from __future__ import annotations

from pathlib import Path

from ..errors import PlanError
from . import ardupilot, px4
from .simulate import DEFAULT_GIMBAL, Gimbal, Item, Replay, local_items

__all__ = ["read_mission", "simulate_file", "simulate_items"]


def simulate_items(items: list[Item], autopilot: str, speed_m_s: float, gimbal: Gimbal = DEFAULT_GIMBAL,
                   profile=None) -> Replay:
    """Replay ``items`` (from home, on the ground, nose north, gimbal level) under ``autopilot``'s rules."""
    module = {"px4": px4, "ardupilot": ardupilot}.get(autopilot)
    if module is None:
        raise PlanError(f"no replay for autopilot {autopilot!r}: px4 or ardupilot")
    return module.replay(items, speed_m_s, gimbal, profile or module.DEFAULTS)


def simulate_file(path: str | Path, autopilot: str | None = None, gimbal: Gimbal = DEFAULT_GIMBAL, profile=None) -> Replay:
    """Replay a QGroundControl ``.plan`` or ``QGC WPL 110`` file; ``autopilot`` defaults to the file's
    (``firmwareType``), else PX4 for ``.plan`` and ArduPilot for WPL."""
    items, _, autopilot, speed = read_mission(path, autopilot)
    return simulate_items(items, autopilot, speed, gimbal, profile)


def read_mission(path: str | Path, autopilot: str | None = None
                 ) -> tuple[list[Item], tuple[float, float, float], str, float]:
    """A ``.plan`` or WPL file's items (in its home's local frame), its home (latitude°, longitude°, height), the
    autopilot it is replayed for (``autopilot``, else the file's) and its speed."""
    import json

    from ..formats.mavlink import FIRMWARE_TYPES
    from ..formats.qgc import parse_qgc_plan
    from ..formats.wpl import parse_wpl

    path = Path(path)
    if path.suffix.lower() == ".plan":
        src = parse_qgc_plan(path)
        if autopilot is None:
            firmware = json.loads(path.read_text(encoding="utf-8")).get("mission", {}).get("firmwareType")
            autopilot = next((k for k, v in FIRMWARE_TYPES.items() if v == firmware), "px4")
    else:
        src = parse_wpl(path)
        autopilot = autopilot or "ardupilot"
    if src.home is None:
        raise PlanError(f"{path.name} has no home position: nothing to replay it from")
    return local_items(src.commands, src.home), src.home, autopilot, src.speed_m_s
