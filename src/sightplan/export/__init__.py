"""Exports of a plan to flight apps and maps: :func:`export_plan`.

The formats (:data:`EXPORT_FORMATS`) are the writers of :mod:`sightplan.formats`, one module each, found by
:mod:`sightplan.formats.registry`; each module's ``FORMAT`` says what :func:`export_plan` needs: the suffix,
whether it writes a file per mission, the autopilot or aircraft it is written for, the gimbal pitches it flies.
Flight apps get a file (or more) per mission; maps (``kml``, ``geojson``) one file with every mission.

All share :func:`~sightplan.formats.flight.build_flight`: frames at one place become one waypoint
with several photo actions, headings are true headings, altitudes are above the mission's take-off
point: its own ground station (or the take-off point given for all).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from numpy.typing import ArrayLike

from ..errors import PlanError
from ..formats.base import Target
from ..formats.flight import Flight, Takeoff, build_flight, mission_paths
from ..formats.mavlink import AUTOPILOT_LABELS, Autopilot, resolve_autopilot
from ..formats.registry import EXPORT_FORMATS, FORMATS, WRITERS, ExportFormat, writer
from ..formats.wpml import AircraftError  # importable from here: export_plan raises it
from ..geo import Georeference
from ..plan.types import Plan

if TYPE_CHECKING:
    from ..flight.fidelity import Fidelity
    from ..flight.simulate import Gimbal

EXTENSIONS = {f.name: f.suffix for f in WRITERS}


def file_summary(fmt: str, autopilot: str | None = None, aircraft: str | None = None) -> str:
    """What a file of format ``fmt`` is for, e.g. "QGroundControl plan for PX4" (the autopilot for MAVLink formats,
    the aircraft's name for DJI WPML and Litchi when given)."""
    spec = FORMATS.get(fmt)
    what = (spec.title or spec.label) if spec is not None else fmt
    if spec is not None and spec.autopilot:
        return f"{what} for {AUTOPILOT_LABELS[resolve_autopilot(autopilot, spec.autopilot)]}"
    if aircraft:
        return f"{what} for {aircraft}"
    return what


@dataclass(frozen=True)
class ExportedFile:
    """A file :func:`export_plan` wrote, and what its user must know: the aircraft it is for (DJI WPML, Litchi), the
    lowest waypoint above its take-off point, where to take off, and the app settings it needs."""

    path: Path
    fmt: str
    aircraft: str | None
    autopilot: str | None
    lowest_altitude_m: float  # model metres (z) above the waypoint's take-off point
    takeoff: Takeoff | None
    settings: tuple[str, ...] = ()
    simulated: Fidelity | None = None  # the replay of its missions (MAVLink formats)

    def summary(self) -> str:
        """'(what it is for): lowest waypoint …; settings' for the CLI's ``wrote PATH`` line."""
        bits = [f"lowest waypoint {self.lowest_altitude_m:+.1f} m above take-off"]
        if self.simulated is not None:
            bits.append(self.simulated.summary())
        if self.takeoff is not None:
            bits.append(f"take off at {self.takeoff.latitude_deg:.6f},{self.takeoff.longitude_deg:.6f}")
        bits += list(self.settings)
        return f"({file_summary(self.fmt, self.autopilot, self.aircraft)}): " + "; ".join(bits)


def export_plan(plan: Plan, fmt: ExportFormat, path: str | Path, georef: Georeference, takeoff_m: ArrayLike,
                speed_m_s: float = 5.0, mission: int | None = None, autopilot: Autopilot | None = None,
                aircraft: str | None = None, per_mission_takeoff: bool = True,
                report: list[ExportedFile] | None = None, faithful: bool = True, gimbal: Gimbal | None = None
                ) -> list[Path]:
    """Write ``plan`` for a flight app or a map; returns the files written.

    georef: where the model frame lies on the Earth. takeoff_m: (3,) model-frame take-off (home)
    point on the ground; altitudes are measured from it. per_mission_takeoff: each mission takes off
    from the ground under its own ground station instead (:func:`~sightplan.plan.site.mission_takeoffs`;
    missions without one from ``takeoff_m``): the default; False for a take-off point the user gave. speed_m_s: flight
    speed between waypoints. mission: index (from 0) into ``plan.missions`` of the only mission to
    write, to ``path`` itself; all missions when None (``qgc``, ``wpl``, ``wpml`` and ``litchi`` write
    a file per mission, numbered from 1: ``stem_m01``…).
    autopilot: for ``qgc`` and ``wpl``, the flight controller the file is for, ``"px4"`` or
    ``"ardupilot"`` (they accept different commands and frames; see :mod:`sightplan.formats.mavlink`); None: PX4
    for ``qgc``, ArduPilot for ``wpl`` (the format's ``autopilot``). Ignored by the other formats.
    aircraft: for ``wpml``, a key of :data:`~sightplan.formats.wpml.AIRCRAFT`; None: the aircraft that
    carries the plan's camera (a camera none carries is refused, naming the choices).
    report: a list to which an :class:`ExportedFile` is appended per file written.
    faithful: for ``qgc`` and ``wpl``, every mission is first replayed under its autopilot's rules
    (:mod:`sightplan.flight`); a photo more than 0.1 m or 1° from its frame, or taken while the gimbal moves,
    refuses the export (a PlanError naming it) unless ``faithful`` is False. gimbal: its slew rate and settling
    time (:class:`~sightplan.flight.simulate.Gimbal`), which size every format's waits after a change of pitch.
    Raises :class:`~sightplan.errors.PlanError` naming the frames a drone cannot take in that
    format (gimbal pitch out of range, a rolled camera), and for ``wpml`` an aircraft, speed or pitch
    DJI cannot fly (:class:`~sightplan.formats.wpml.AircraftError`).
    """
    spec = writer(fmt)
    if spec.autopilot:
        autopilot = resolve_autopilot(autopilot, spec.autopilot)
    path = Path(path)
    if not path.parent.is_dir():
        raise PlanError(f"cannot write {path}: the folder {path.parent} does not exist")
    target = spec.prepare(plan, aircraft, speed_m_s) if spec.prepare is not None else Target()
    target = replace(target, autopilot=autopilot if spec.autopilot else None, gimbal=gimbal)
    pitch_range = target.pitch_range or spec.pitch_range
    settings = spec.settings + ((target.note,) if target.note else ())

    def build(m: int | None) -> Flight:
        return build_flight(plan, georef, takeoff_m, fmt=fmt, speed_m_s=speed_m_s, mission=m,
                            per_mission_takeoff=per_mission_takeoff, pitch_range=pitch_range, label=spec.label)

    # a file per mission with frames (numbered from 1, as Flight.by_mission numbers them), each flight built once
    numbers = [k + 1 for k, m in enumerate(plan.missions) if m.stop > m.start] \
        if spec.per_mission and mission is None else []
    if len(numbers) > 1:
        paths = mission_paths(path, numbers, several=True)
        jobs = [(build(m - 1), paths[m]) for m in numbers]
    else:
        jobs = [(build(mission), path)]
    replays: list[Fidelity | None] = [None] * len(jobs)
    if spec.autopilot:
        from ..flight.fidelity import flight_fidelity
        from ..flight.simulate import DEFAULT_GIMBAL

        replays = [flight_fidelity(flight, autopilot, gimbal or DEFAULT_GIMBAL) for flight, _ in jobs]
        off = next((r for r in replays if not r.faithful), None)
        if off is not None and faithful:
            raise ReplayRefusal(f"the {fmt} export would not take its photos at the frames: {off.summary()}"
                            f"{'; ' + off.notes[0] if off.notes else ''}; export it anyway with --force (force=true on the web)")
        long = _longer_than_a_battery(plan, [f for f, _ in jobs], replays, speed_m_s)
        if long and faithful:
            raise ReplayRefusal(f"{long}; split the plan into shorter missions, fly faster (--speed), or export it "
                            "anyway with --force (force=true on the web)")
    written: list[Path] = []
    try:
        for (flight, out), replay in zip(jobs, replays):
            files = spec.write(flight, out, target)
            written += files
            if report is not None:
                start = flight.takeoff_of(flight.waypoints[0].mission) if spec.per_mission else None
                lowest = min(w.position_m[2] - flight.takeoff_of(w.mission).position_m[2] for w in flight.waypoints)
                report += [ExportedFile(Path(f), fmt, target.aircraft, autopilot, lowest, start, settings, replay)
                           for f in files]
    except OSError as exc:
        raise PlanError(f"cannot write {path}: {exc.strerror or exc}") from None
    return written


class ReplayRefusal(PlanError):
    """An export refused because its replay takes photos off their frames or outlasts a battery."""


def _longer_than_a_battery(plan: Plan, flights: list[Flight], replays: list, speed_m_s: float) -> str | None:
    """Why a replayed mission (take-off to landing, at the export's speed and with its stops) outlasts the usable
    time of the aircraft the plan was checked for; None when each fits, or when the plan names no aircraft."""
    from ..plan.checks.battery import Aircraft
    from ..plan.checks.gate import CHECKS_KEY, recorded_settings

    if CHECKS_KEY not in plan.parameters:
        return None
    craft = recorded_settings(plan).aircraft
    if not isinstance(craft, Aircraft):
        return None
    for flight, replay in zip(flights, replays):
        for (m, _), t in zip(flight.by_mission(), replay.mission_times_s):
            if t > craft.usable_s:
                name = flight.missions[m].name
                return (f"mission {name!r} flies {t / 60:.1f} min in the replay ({replay.autopilot}, "
                        f"{speed_m_s:g} m/s, take-off to landing with every stop), more than the {craft.name}'s "
                        f"{craft.usable_s / 60:.1f} usable minutes ({craft.flight_time_s / 60:.0f} min less the "
                        f"{craft.reserve:.0%} reserve)")
    return None


__all__ = ["EXPORT_FORMATS", "EXTENSIONS", "AircraftError", "Autopilot", "ExportFormat", "ExportedFile", "ReplayRefusal",
           "export_plan", "file_summary"]
