"""What the pictures and viewers colour elements by, stated once: the metrics, their labels and units, the
traffic-light gradient (green good → yellow → red bad) between two bounds, the visibility classes, and each
element's colour. The glTF export, the HTML report and the web viewer's colours all come from here."""

from __future__ import annotations

import math
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from ..errors import ReportError
from ..metrics.elements import ElementMetrics
from .overview import OBSERVED_ONLY, OCCLUDER, UNSEEN, VISIBLE

ColourBy = Literal["visibility", "vr", "ssd", "orientation"]
COLOUR_BY: tuple[str, ...] = get_args(ColourBy)

# What each metric colours by, its unit, and whether a larger value is better.
METRIC_LABELS: dict[str, tuple[str, str, bool]] = {
    "visibility": ("visibility (seen ≥ Ω px / observed only / unseen)", "", True),
    "vr": ("VR_i, frames seeing the element by ≥ Ω px", "frames", True),
    "ssd": ("R_i, surface sampling distance", "m/px", False),
    "orientation": ("O_i, viewpoint orientation", "°", False),
}
OCCLUDER_ALPHA = 0.35
GRADIENT = (VISIBLE, OBSERVED_ONLY, UNSEEN)  # good → middle → bad, sRGB
VISIBILITY_CLASSES = ("visible", "observed", "unseen", "occluder")


def check_colour_by(colour_by: str) -> ColourBy:
    """``colour_by`` if it is a known metric, else a ReportError listing them."""
    if colour_by not in COLOUR_BY:
        raise ReportError(f"unknown metric to colour by: {colour_by!r}; choose one of {', '.join(COLOUR_BY)}")
    return colour_by  # type: ignore[return-value]


def parse_bounds(text: str) -> tuple[float, float]:
    """``"LO,HI"`` as two finite floats with LO < HI."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ReportError(f"bounds must be two numbers LO,HI (e.g. 0.002,0.01), got {text!r}") from None
    return check_bounds((lo, hi))


def check_bounds(bounds: tuple[float, float]) -> tuple[float, float]:
    lo, hi = float(bounds[0]), float(bounds[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ReportError(f"bounds must be finite numbers, got {lo:g},{hi:g}")
    if lo >= hi:
        raise ReportError(f"bounds need LO < HI, got {lo:g},{hi:g}")
    return lo, hi


# --------------------------------------------------------------------------- values and colours
def visibility_class(em: ElementMetrics) -> NDArray[np.int8]:
    """(z,) index into VISIBILITY_CLASSES: 0 visible, 1 observed only, 2 unseen, 3 occluder."""
    cls = np.full(len(em.is_target), 2, np.int8)
    cls[em.observed] = 1
    cls[em.visible] = 0
    cls[~em.is_target] = 3
    return cls


def element_values(em: ElementMetrics, colour_by: ColourBy) -> NDArray[np.float64]:
    """(z,) the value an element is coloured by; NaN for target elements the metric is undefined on."""
    if colour_by == "visibility":
        return visibility_class(em).astype(np.float64)
    if colour_by == "vr":
        return np.where(em.visible, em.VR, np.nan).astype(np.float64)
    return np.asarray(em.R if colour_by == "ssd" else em.O, np.float64)


def default_bounds(em: ElementMetrics, colour_by: ColourBy) -> tuple[float, float]:
    """The range of a gradient metric (vr, ssd, orientation) over the visible target elements."""
    v = element_values(em, colour_by)[em.visible & em.is_target]
    v = v[np.isfinite(v)]
    if not len(v):
        return (0.0, 1.0)
    lo, hi = float(v.min()), float(v.max())
    if hi <= lo:  # one value: it sits in the middle of the gradient
        pad = max(abs(lo) * 0.5, 1e-9)
        return (lo - pad, hi + pad)
    return (lo, hi)


def colour_bounds(em: ElementMetrics, colour_by: ColourBy,
                  bounds: tuple[float, float] | None = None) -> tuple[float, float] | None:
    """The gradient's ends: ``bounds`` checked, else the default range; None for ``visibility`` (which takes none)."""
    if colour_by == "visibility":
        if bounds is not None:
            raise ReportError("bounds apply to vr, ssd and orientation, not to visibility")
        return None
    return check_bounds(bounds) if bounds is not None else default_bounds(em, colour_by)


def traffic_light(badness: NDArray) -> NDArray[np.float64]:
    """(n, 3) sRGB in [0, 1]: 0 green (good), 0.5 yellow, 1 red (bad); clipped to [0, 1]."""
    t = np.clip(np.asarray(badness, np.float64), 0.0, 1.0)
    stops = np.array(GRADIENT)
    x = np.linspace(0.0, 1.0, len(stops))
    return np.column_stack([np.interp(t, x, stops[:, c]) for c in range(3)])


def metric_colours(em: ElementMetrics, colour_by: ColourBy = "visibility",
                   bounds: tuple[float, float] | None = None) -> NDArray[np.float64]:
    """(z, 4) sRGB colour and alpha per element, as the model is drawn in the glTF and the HTML report."""
    colour_by = check_colour_by(colour_by)
    ends = colour_bounds(em, colour_by, bounds)
    rgba = np.ones((len(em.is_target), 4))
    if ends is None:
        rgba[:, :3] = np.array((VISIBLE, OBSERVED_ONLY, UNSEEN, OCCLUDER))[visibility_class(em)]
    else:
        lo, hi = ends
        v = element_values(em, colour_by)
        higher_better = METRIC_LABELS[colour_by][2]
        with np.errstate(invalid="ignore"):
            badness = (hi - v) / (hi - lo) if higher_better else (v - lo) / (hi - lo)
        rgba[:, :3] = traffic_light(np.nan_to_num(badness, nan=1.0))
        rgba[~np.isfinite(v), :3] = UNSEEN
    rgba[~em.is_target, :3] = OCCLUDER
    rgba[~em.is_target, 3] = OCCLUDER_ALPHA
    return rgba


def srgb_to_linear(c: NDArray) -> NDArray[np.float64]:
    """glTF stores colour factors in linear light."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
