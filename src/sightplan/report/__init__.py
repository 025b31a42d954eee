"""Reports of an evaluation: JSON, per-element and per-frame CSV."""

from .tables import element_rows, frame_rows, report_dict, write_report

__all__ = ["element_rows", "frame_rows", "report_dict", "write_report"]
