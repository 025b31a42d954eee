"""sightplan: create and evaluate reality capture plans against 4D building models.

The public API, in the order of the data flow: model → scene at a date → plan →
engine → Observations → metrics → reports.
"""

from .camera import Camera, EquirectangularCamera, PinholeCamera, get_camera, list_cameras
from .engines import Engine, EngineName, available_engines, make_engine
from .errors import (
    CameraError,
    EngineError,
    FormatVersionError,
    ModelError,
    ObservationsError,
    PlanError,
    ScheduleError,
    SightplanError,
)
from .evaluate import Evaluation, EvaluationSettings, evaluate
from .metrics import MetricParams, Metrics, PlanMetrics, compute_metrics
from .model import ElementTable, LoadReport, Scene, load_model, sample_model_path, summarize
from .observations import FrameObservation, Observations
from .observations.features import FeatureSet, sample_features
from .optimize import optimize
from .plan import Mission, Plan, R_from_gimbal, gimbal_from_R, read_plan, write_plan
from .plan.load import load_plan
from .plan.ring import ring_plan
from .report import write_report
from .version import __version__

__all__ = [
    "__version__", "Camera", "CameraError", "ElementTable", "Engine", "EngineError", "EngineName", "EquirectangularCamera",
    "Evaluation", "EvaluationSettings", "FeatureSet", "FormatVersionError", "FrameObservation", "LoadReport",
    "MetricParams", "Metrics", "Mission", "ModelError", "Observations", "ObservationsError", "PinholeCamera", "Plan",
    "PlanError", "PlanMetrics", "R_from_gimbal", "Scene", "ScheduleError", "SightplanError", "available_engines",
    "compute_metrics", "evaluate", "gimbal_from_R", "get_camera", "list_cameras", "load_model", "load_plan",
    "make_engine", "optimize", "read_plan", "ring_plan", "sample_features", "sample_model_path", "summarize", "write_plan",
    "write_report",
]
