"""The closed loop: synthetic photographs of a plan, a real structure-from-motion run on them, and the predicted
metrics set beside what the reconstruction measured, per element and per frame."""

from .files import RECONSTRUCTION_FILES, Reconstruction, read_reconstruction, write_reconstruction
from .measure import ReconstructionMeasures, measure_reconstruction, reconstruction_reality, validate_reconstruction
from .reconstruct import reconstruct
from .render import Renders, element_maps, read_renders, render_plan
from .run import LoopResult, loop
from .study import LoopStudy, fit_logistic, loop_study

__all__ = ["RECONSTRUCTION_FILES", "LoopResult", "LoopStudy", "Reconstruction", "ReconstructionMeasures", "Renders",
           "element_maps", "fit_logistic", "loop", "loop_study", "measure_reconstruction", "read_reconstruction",
           "read_renders", "reconstruct", "reconstruction_reality", "render_plan", "validate_reconstruction",
           "write_reconstruction"]
