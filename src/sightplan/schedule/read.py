"""One entry point for every schedule file: :func:`read_schedule` dispatches by extension, then by content."""

from __future__ import annotations

from pathlib import Path

from ..errors import ScheduleError
from .csvfile import read_csv
from .ifc import read_ifc
from .mspdi import read_mspdi
from .tasks import TaskTable
from .xer import read_xer

READERS = {".xml": read_mspdi, ".xer": read_xer, ".csv": read_csv, ".tsv": read_csv, ".txt": read_csv,
           ".ifc": read_ifc, ".ifczip": read_ifc}


def _sniff(path: Path):
    with open(path, "rb") as fh:
        head = fh.read(512).lstrip(b"\xef\xbb\xbf \t\r\n")
    if head.startswith(b"ERMHDR"):
        return read_xer
    if head.startswith(b"ISO-10303-21"):
        return read_ifc
    if head.startswith(b"<"):
        return read_mspdi
    return read_csv


def read_schedule(path: str | Path | None, model_path: str | Path | None = None) -> TaskTable:
    """The tasks of a schedule file: ``.xml`` MS Project XML, ``.xer`` Primavera P6, ``.csv`` CSV,
    ``.ifc`` the work schedule inside an IFC model; other extensions are recognised by content.

    ``model_path``: the IFC model the schedule is for; with ``path=None`` (or ``"model"``)
    the model's own work schedule is read.
    """
    if path is None or str(path) == "model":
        if model_path is None:
            raise ScheduleError("no schedule given: pass a schedule file, or model_path to read the model's own work schedule")
        return read_ifc(model_path)
    path = Path(path).expanduser()
    if not path.is_file():
        raise ScheduleError(f"schedule file not found: {path}")
    reader = READERS.get(path.suffix.lower()) or _sniff(path)
    return reader(path)
