"""Which engines exist, which are available here, and how to make one by name."""

from __future__ import annotations

from typing import get_args

from ..errors import EngineError
from .base import Engine, EngineName


def available_engines() -> list[str]:
    """Names of the engines that can run on this machine, best first.

    The OpenGL engine comes first when its driver is a GPU's; on a software rasteriser
    it is still available by name, after Embree.
    """
    from . import embree, gl

    names = ["embree"] if embree.available() else []
    if gl.available():
        if gl.hardware_available():
            names.insert(0, "gl")
        else:
            names.append("gl")
    try:
        import rtree  # noqa: F401  (trimesh's ray_triangle needs it)

        names.append("trimesh")
    except ImportError:
        pass
    return names


def best_engine() -> str:
    """What ``auto`` means on this machine: the OpenGL engine on a GPU, else Embree.

    Without a GPU device this never starts an OpenGL driver (that costs about a second).
    """
    from . import embree, gl

    if gl.hardware_available():
        return "gl"
    if embree.available():
        return "embree"
    avail = available_engines()
    if not avail:
        raise EngineError("no visibility engine is available: install embreex (or trimesh with rtree)")
    return avail[0]


def ray_engine_name(name: EngineName | str) -> str:
    """The engine to cast arbitrary rays (sight lines, reprojections) for a user's engine choice.

    Rasterisers draw frames, not single rays, so ``auto`` and ``gl`` mean Embree here.
    """
    if name in ("auto", "gl"):
        from . import embree

        return "embree" if embree.available() else "trimesh"
    return str(name)


def resolve_engine(name: EngineName | str) -> str:
    """The engine ``name`` means here (``auto``: :func:`best_engine`), without building anything."""
    valid = get_args(EngineName)
    if name not in valid:
        raise EngineError(f"unknown engine {name!r}; choose one of {', '.join(valid)}")
    return best_engine() if name == "auto" else str(name)


def make_engine(name: EngineName | str, scene, features=None, **kwargs) -> Engine:
    """An engine by name; ``auto`` picks the fastest available one."""
    name = resolve_engine(name)
    if name == "embree":
        from .embree import EmbreeEngine

        return EmbreeEngine(scene, features, **kwargs)
    if name == "gl":
        from .gl import GLEngine

        return GLEngine(scene, features, **kwargs)
    from .trimesh_ray import TrimeshEngine

    return TrimeshEngine(scene, features, **kwargs)
