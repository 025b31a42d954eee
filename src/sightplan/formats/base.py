"""What a format is to sightplan: the record every format module declares as ``FORMAT``
(:class:`FlightFormat`), which :mod:`.registry` collects, what its reader is given (:class:`Source`,
:class:`ReadOptions`) and what its writer is given besides the flight (:class:`Target`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..camera.models import Camera
from ..geo import Georeference
from ..plan.format import read_json
from ..plan.types import Plan
from .flight import Flight


@dataclass(frozen=True)
class ReadOptions:
    """What :func:`~sightplan.plan.load.load_plan` passes every reader.

    camera: the camera of frames the file names none for (CSV rows, flight-app missions); georef: where a file in
    latitude/longitude lies in the model frame; ground_z: the model-frame height of the site's ground, where a
    flight-app mission takes off when its file has no usable take-off reference; takeoff_z: a model-frame take-off
    height the user gives, which replaces the file's reference (:func:`~.reading.place_takeoff`)."""

    camera: Camera | str | dict | None = None
    georef: Georeference | None = None
    ground_z: float | None = None
    takeoff_z: float | None = None


class Source:
    """A file or folder being read: its path and what sniffing it took from it, read once and kept for the reader
    (the first bytes, the parsed JSON)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._head: bytes | None = None
        self._json: Any = None
        self._parsed = False

    @property
    def suffix(self) -> str:
        return self.path.suffix.lower()

    def head(self) -> bytes:
        """The first 64 bytes (empty when unreadable)."""
        if self._head is None:
            try:
                with self.path.open("rb") as f:
                    self._head = f.read(64)
            except OSError:
                self._head = b""
        return self._head

    def json(self) -> Any:
        """The parsed JSON content; PlanError when unreadable or not JSON."""
        if not self._parsed:
            self._json = read_json(self.path)
            self._parsed = True
        return self._json


@dataclass(frozen=True)
class Target:
    """What one export is written for, as the format's ``prepare`` decided before any flight is built: the autopilot
    (MAVLink formats), the aircraft's name (for the user) and the format's own description of it (``vehicle``, for
    its writer, e.g. a DJI aircraft), the gimbal's pitch range when it is not the format's, a note for the user."""

    autopilot: str | None = None
    aircraft: str | None = None
    vehicle: Any = None
    pitch_range: tuple[float, float] | None = None
    note: str | None = None
    gimbal: Any = None  # the gimbal's slew rate and settling time (sightplan.flight.Gimbal) the waits are sized for


@dataclass(frozen=True)
class FlightFormat:
    """One format sightplan reads or writes: a flight-app mission, a map, or the poses of a flown capture.

    name: the format's name in ``load_plan(fmt=)`` and ``sightplan export --format``. label: its short name in
    messages ("frames that QGroundControl cannot fly"). order: its place in lists (the CLI's choices, the web API's).

    Reading: ``read(source, options)`` makes a Plan. ``suffixes``: the file suffixes it claims, ``folder``: whether
    it reads a folder. ``sniff(source)``: whether the content is this format, for a suffix several formats claim
    (a format without one takes the suffix when no other's sniff says yes). ``what``: what such content is, for
    the message when no sniff says yes. ``uses_camera``: the reader takes ``options.camera`` itself (otherwise a
    camera given replaces the file's cameras).

    Writing: ``write(flight, path, target)`` writes the files and returns them; ``suffix`` is the suffix of the files
    written and ``media_type`` their MIME type. ``prepare(plan, aircraft, speed_m_s)``, before any flight is built,
    decides the :class:`Target` (and refuses what the format cannot fly); ``aircraft_choice``: it takes the aircraft
    the user names (``aircraft=``, ``--aircraft``). ``autopilot``: for a format written for one autopilot
    (MAVLink), the default one. ``per_mission``: one file (or more) per mission, each from its own take-off point.
    ``pitch_range``: the gimbal pitches (degrees) it can fly, rolled frames refused too; None: any frame (maps).
    ``title``: what a file is, for the user ("QGroundControl plan"; default ``label``); ``help``: a few words after
    the name in the list of choices ("QGroundControl .plan"); ``settings``: what the user must set in the app.
    """

    name: str
    label: str
    order: int = 100
    # reading
    read: Callable[[Source, ReadOptions], Plan] | None = None
    suffixes: tuple[str, ...] = ()
    folder: bool = False
    sniff: Callable[[Source], bool] | None = None
    what: str = ""
    uses_camera: bool = False
    # writing
    write: Callable[[Flight, Path, Target], list[Path]] | None = None
    suffix: str = ""
    media_type: str = "application/octet-stream"
    prepare: Callable[[Plan, str | None, float], Target] | None = None
    aircraft_choice: bool = False
    autopilot: str | None = None
    per_mission: bool = False
    pitch_range: tuple[float, float] | None = None
    title: str = ""
    help: str = ""
    settings: tuple[str, ...] = ()
