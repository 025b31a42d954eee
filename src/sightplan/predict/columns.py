"""The per-element predictors of completeness, from a plan's Observations, its metrics, its camera centres and the
simulated features (nothing is cast here).

- ``VR`` (frames), ``R`` (mm/px), ``O`` (degrees), ``pixels`` (over the plan): the plan's per-element metrics
  (METRICS.md §3), counted in the photographs' pixels: :func:`at_photo_size` first brings every frame to the
  photographs' size the predictor was fitted on, so a plan of 20 Mpx frames is judged as photographed at that size;
- ``seen_share``: the share of the element's own features that some frame sees (its surface seen, sampled at the
  feature density);
- ``tri_median``, ``tri_largest``, ``tri_matchable`` (degrees), ``triangulable`` (share), ``views`` (frames):
  :mod:`sightplan.metrics.triangulation`;
- ``stable_views``: the share of the frames that see the element (one pixel or more) that are stable (ν_f ≥ Λ,
  METRICS.md §5.4).

Every column has one entry per element of the scene's table (z,); NaN where undefined (R and O where VR = 0, the
feature columns where the element owns no feature or none is seen, ``stable_views`` where no frame sees it).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError
from ..metrics import MetricParams, Metrics, compute_metrics, triangulation_angles
from ..observations.table import Observations

#: The predictor columns, in order.
PREDICTOR_COLUMNS = ("VR", "R", "O", "pixels", "seen_share", "tri_median", "tri_largest", "tri_matchable",
                     "triangulable", "views", "stable_views")


def at_photo_size(obs: Observations, frame_pixels: NDArray, photo_pixels: float) -> Observations:
    """``obs`` with every frame's full-resolution pixels brought to ``photo_pixels`` a frame: frame f of
    ``frame_pixels[f]`` pixels (width × height) counts each element's pixels × a_f and its ρ × 1/√a_f, a_f =
    photo_pixels / frame_pixels[f] (a camera scaled by √a_f; the rays cast are the same)."""
    px = np.asarray(frame_pixels, float).reshape(-1)
    if len(px) != obs.n_frames:
        raise SightplanError(f"{len(px)} frame sizes for {obs.n_frames} frames")
    if not photo_pixels > 0 or not (px > 0).all():
        raise SightplanError("frame and photograph sizes must be positive numbers of pixels")
    a = photo_pixels / px
    return replace(obs, pixel_scale=obs.pixel_scale * a, sampling_focal_px=obs.sampling_focal_px * np.sqrt(a))


def predictor_columns(obs: Observations, centres: NDArray, feature_points: NDArray, feature_element: NDArray,
                      metrics: Metrics | None = None, params: MetricParams | None = None) -> dict[str, NDArray]:
    """The predictor columns (module docstring) of a plan with camera centres ``centres`` (n, 3) whose observations
    are ``obs`` (already at the photographs' size) and features the (N, 3) points owned by the (N,) elements;
    ``metrics``: ``obs``'s, when already computed."""
    metrics = metrics or compute_metrics(obs, params or MetricParams())
    em, fm = metrics.elements, metrics.frames
    tri = triangulation_angles(obs, centres, feature_points, feature_element)
    z = obs.n_elements
    seen = obs.count >= 1
    e, f = obs.element[seen], obs.frame[seen]
    views = np.bincount(e, minlength=z)
    stable = np.bincount(e, weights=fm.stable[f].astype(float), minlength=z)
    with np.errstate(invalid="ignore", divide="ignore"):
        stable_views = np.where(views > 0, stable / np.maximum(views, 1), np.nan)
    return {"VR": em.VR.astype(float), "R": 1000.0 * em.R, "O": em.O.astype(float),
            "pixels": em.pixels_total.astype(float), "seen_share": tri.seen_share, "tri_median": tri.median_deg,
            "tri_largest": tri.largest_deg, "tri_matchable": tri.matchable_deg, "triangulable": tri.triangulable,
            "views": tri.views, "stable_views": stable_views}
