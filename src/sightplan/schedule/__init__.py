"""Construction schedules: read tasks from IFC, MS Project XML, Primavera XER or CSV, and date a model's elements.

``read_schedule(path)`` → :class:`TaskTable`; ``link_schedule(scene, tasks, rules)`` →
(dated :class:`~sightplan.model.Scene`, :class:`LinkReport`). Rules files (TOML) link
tasks to elements by class, storey, discipline, name or property; see :mod:`.rules`.
"""

from .csvfile import read_csv
from .ifc import read_ifc
from .link import LinkReport, link_schedule
from .mspdi import read_mspdi
from .read import read_schedule
from .rules import LinkRule, parse_rules, read_rules
from .tasks import Task, TaskTable, date_range, task_finishes
from .xer import read_xer

__all__ = [
    "LinkReport", "LinkRule", "Task", "TaskTable", "date_range", "link_schedule", "parse_rules", "read_csv", "read_ifc",
    "read_mspdi", "read_rules", "read_schedule", "read_xer", "task_finishes",
]
