"""Model loading: IFC and meshes into one :class:`Scene`.

IfcOpenShell and trimesh are imported only when a file of their kind is loaded.
"""

from .load import SUPPORTED_EXTENSIONS, load_model, resolve_model_path, sample_model_path
from .scene import DateBasis, ElementTable, Scene
from .summary import LoadReport, SkippedProduct, summarize

__all__ = [
    "SUPPORTED_EXTENSIONS",
    "DateBasis",
    "ElementTable",
    "LoadReport",
    "Scene",
    "SkippedProduct",
    "load_model",
    "resolve_model_path",
    "sample_model_path",
    "summarize",
]
