"""Visibility engines: (scene, frames) → observations. One module per engine."""

from .base import D_MAX_M, Engine, EngineName
from .registry import available_engines, make_engine

__all__ = ["D_MAX_M", "Engine", "EngineName", "available_engines", "make_engine"]
