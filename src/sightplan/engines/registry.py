"""Which engines exist, which are available here, and how to make one by name."""

from __future__ import annotations

from typing import get_args

from ..errors import EngineError
from .base import Engine, EngineName


def available_engines() -> list[str]:
    """Names of the engines that can run on this machine, best first."""
    from . import embree

    names = ["embree"] if embree.available() else []
    try:
        import rtree  # noqa: F401  (trimesh's ray_triangle needs it)

        names.append("trimesh")
    except ImportError:
        pass
    return names


def make_engine(name: EngineName | str, scene, features=None, **kwargs) -> Engine:
    """An engine by name; ``auto`` picks the fastest available one."""
    valid = get_args(EngineName)
    if name not in valid:
        raise EngineError(f"unknown engine {name!r}; choose one of {', '.join(valid)}")
    if name == "auto":
        avail = available_engines()
        if not avail:
            raise EngineError("no visibility engine is available: install embreex (or trimesh with rtree)")
        name = avail[0]
    if name == "embree":
        from .embree import EmbreeEngine

        return EmbreeEngine(scene, features, **kwargs)
    from .trimesh_ray import TrimeshEngine

    return TrimeshEngine(scene, features, **kwargs)
