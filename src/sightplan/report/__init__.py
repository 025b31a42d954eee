"""Reports of an evaluation: JSON, per-element and per-frame CSV, a coloured glTF, one HTML page."""

from .gltf import write_gltf
from .html import write_html
from .tables import element_rows, frame_rows, report_dict, write_report

__all__ = ["element_rows", "frame_rows", "report_dict", "write_gltf", "write_html", "write_report"]
