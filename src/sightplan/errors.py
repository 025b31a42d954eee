"""One error hierarchy for everything a user can get wrong.

The CLI prints a :class:`SightplanError` as one line and exits non-zero; the web API
maps it to a 4xx. Anything else escaping is a bug.
"""

from __future__ import annotations


class SightplanError(Exception):
    """Base of every error sightplan raises on purpose."""


class ModelError(SightplanError):
    """A model file that cannot be read, or that holds no usable geometry."""


class CameraError(SightplanError):
    """An unknown or impossible camera."""


class PlanError(SightplanError):
    """A plan file or pose set that is malformed, inconsistent or unsupported."""


class FormatVersionError(PlanError):
    """A file written by a newer format version than this sightplan reads."""


class ScheduleError(SightplanError):
    """A schedule or capture date that cannot be applied to the model."""


class EngineError(SightplanError):
    """A visibility engine that is unavailable or was given unusable input."""


class ObservationsError(SightplanError):
    """Observations that cannot be saved, loaded or merged as asked."""


class ReportError(SightplanError):
    """A report or export that cannot be written as asked (bad option, unwritable path, missing viewer files)."""
