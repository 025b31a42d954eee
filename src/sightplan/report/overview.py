"""A picture of the model coloured by visibility, with the plan's camera positions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..camera.models import PinholeCamera
from ..engines.base import Engine
from ..metrics.elements import ElementMetrics
from ..plan.poses import R_from_gimbal
from ..plan.types import Plan

VISIBLE = (0.20, 0.66, 0.33)
OBSERVED_ONLY = (0.98, 0.76, 0.18)
UNSEEN = (0.86, 0.20, 0.18)
OCCLUDER = (0.72, 0.72, 0.72)
BACKGROUND = (1.0, 1.0, 1.0)


def visibility_colours(em: ElementMetrics) -> NDArray[np.float64]:
    """(z, 3) RGB in [0, 1]: visible green, observed-only yellow, unseen red, occluders grey."""
    colours = np.tile(np.array(UNSEEN), (len(em.is_target), 1))
    colours[em.observed] = OBSERVED_ONLY
    colours[em.visible] = VISIBLE
    colours[~em.is_target] = OCCLUDER
    return colours


def overview_camera(points: NDArray, width: int = 1200, height: int = 800) -> tuple[PinholeCamera, NDArray, NDArray]:
    """A camera looking down at 35° from the south-west, as close as it can be with all (k, 3) points in view."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = (lo + hi) / 2
    cam = PinholeCamera(width, height, 1.1 * width, 1.1 * width, width / 2, height / 2, "overview")
    R = R_from_gimbal(45.0, -35.0, 0.0)[0]
    rel = (points - centre) @ R  # corner coordinates in camera axes, camera at the centre
    # a corner fits when |x| / (z + d) ≤ (W/2)/fx (and likewise for y): solve for the distance d
    d = max(np.max(np.abs(rel[:, 0]) * cam.fx / (0.47 * width) - rel[:, 2]),
            np.max(np.abs(rel[:, 1]) * cam.fy / (0.47 * height) - rel[:, 2]), 1.0)
    return cam, R, centre - d * R[:, 2]


def render_overview(engine: Engine, colours: NDArray, plan: Plan | None, path: str | Path,
                    title: str = "") -> Path:
    """Write a PNG of the scene shaded and coloured per element; camera centres as dots."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lo, hi = engine.scene.bounds()
    points = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    if plan is not None and len(plan):
        points = np.concatenate([points, plan.C_world])
    cam, R, C = overview_camera(points)
    ids, dist, cos = engine.shaded_view(cam, R, C)
    hit = ids >= 0
    img = np.ones((cam.height, cam.width, 3)) * BACKGROUND
    shade = 0.4 + 0.6 * cos[hit]
    img[hit] = colours[ids[hit]] * shade[:, None]
    fig, ax = plt.subplots(figsize=(cam.width / 100, cam.height / 100), dpi=100)
    ax.imshow(img, interpolation="nearest")
    if plan is not None and len(plan):
        rel = (plan.C_world - C) @ R  # camera-frame coordinates of every frame centre
        front = rel[:, 2] > 0
        u = cam.fx * rel[front, 0] / rel[front, 2] + cam.cx - 0.5
        v = cam.fy * rel[front, 1] / rel[front, 2] + cam.cy - 0.5
        ax.scatter(u, v, s=6, c="#1f4e9e", marker="o", linewidths=0, label="frames")
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in (VISIBLE, OBSERVED_ONLY, UNSEEN, OCCLUDER)]
    ax.legend(handles, ["visible (≥ Ω px)", "observed only", "unseen", "occluder"], loc="lower right", fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()
    fig.tight_layout(pad=0.2)
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out
