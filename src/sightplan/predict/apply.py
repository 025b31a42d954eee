"""Completeness predicted for an evaluated plan, per element, with its interval.

The model (by default the bundled one, :data:`.model.BUNDLED`) was fitted on closed loops whose photographs had
``info["photo_pixels"]`` pixels each and whose metrics used ``info["metric"]``'s Ω and k; the plan's observations
are brought to that size (:func:`.columns.at_photo_size`) and its metrics recomputed with those parameters before the
predictors are read, so the prediction answers: how complete would the loop's reconstruction of this plan be, with
photographs of that size and look. Elements no frame sees get no prediction (NaN), as the loop measures none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError
from ..metrics import MetricParams, compute_metrics
from ..observations.table import Observations
from .columns import at_photo_size, predictor_columns
from .model import CompletenessModel


@dataclass(frozen=True)
class CompletenessPrediction:
    """Per element (z,), indexed like the scene's element table: ``predicted`` completeness and the interval
    ``low``–``high`` (NaN where no frame sees the element or it is no target); ``level`` the interval's coverage;
    ``info`` what the model was fitted on (photographs, render scale, preset, models, its leave-one-model-out
    results)."""

    predicted: NDArray[np.float64]
    low: NDArray[np.float64]
    high: NDArray[np.float64]
    level: float
    photo_pixels: float
    info: dict

    def summary(self) -> dict:
        """The report's entry: what the model was fitted on and how it did on models it was not fitted on, the
        mean prediction over the seen elements."""
        seen = np.isfinite(self.predicted)
        lomo = self.info.get("lomo", {})
        return {"photo_pixels": self.photo_pixels, "interval_level": self.level,
                "photo_realism": self.info.get("photo_realism"), "render_scale": self.info.get("render_scale"),
                "fitted_on": self.info.get("fitted_on"), "lomo_r": lomo.get("r"), "lomo_slope": lomo.get("slope"),
                "elements_predicted": int(seen.sum()),
                "mean_predicted": float(self.predicted[seen].mean()) if seen.any() else None}


def predict_completeness(obs: Observations, frame_pixels: NDArray, centres: NDArray, feature_points: NDArray,
                         feature_element: NDArray, model: CompletenessModel | None = None) -> CompletenessPrediction:
    """The prediction (module docstring) for the plan whose frames of ``frame_pixels`` (n,) pixels (width ×
    height) at ``centres`` (n, 3) made ``obs``, with the features the observations were made with."""
    model = model or CompletenessModel.read()
    sizes = model.info.get("photo_pixels") or []
    if not sizes:
        raise SightplanError("the completeness model does not say the size of the photographs it was fitted on")
    photo = float(np.median(sizes))
    params = MetricParams(**model.info["metric"]) if "metric" in model.info else MetricParams()
    small = at_photo_size(obs, frame_pixels, photo)
    metrics = compute_metrics(small, params)
    cols = predictor_columns(small, centres, feature_points, feature_element, metrics=metrics)
    seen = metrics.elements.observed & obs.is_target
    p = np.where(seen, model.predict_columns(cols), np.nan)
    low, high = model.interval(np.where(seen, p, 0.0))
    return CompletenessPrediction(p, np.where(seen, low, np.nan), np.where(seen, high, np.nan), model.interval_level,
                                  photo, dict(model.info))
