"""Metrics: pure functions of Observations and parameters (METRICS.md)."""

from .elements import ElementMetrics, element_metrics
from .params import MetricParams
from .plan import Metrics, PlanMetrics, compute_metrics
from .robustness import DrawSummary, ElementSpread, Spread, summarize_draws
from .stability import FrameMetrics, frame_metrics, stable_feature_counts
from .triangulation import TriangulationAngles, triangulation_angles

__all__ = ["DrawSummary", "ElementMetrics", "ElementSpread", "FrameMetrics", "MetricParams", "Metrics", "PlanMetrics",
           "Spread", "TriangulationAngles", "compute_metrics", "element_metrics", "frame_metrics",
           "stable_feature_counts", "summarize_draws", "triangulation_angles"]
