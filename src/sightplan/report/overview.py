"""A picture of the model coloured by visibility, with the plan's camera positions.

It reads a :class:`~sightplan.engines.views.SceneView` (made at the engine stage) and the
metrics; it casts no ray itself.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..engines.views import SceneView
from ..metrics.elements import ElementMetrics

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


LEGEND = ((VISIBLE, "visible (≥ Ω px)"), (OBSERVED_ONLY, "observed only"), (UNSEEN, "unseen"), (OCCLUDER, "occluder"))


def shaded_image(view: SceneView, colours: NDArray) -> NDArray[np.float64]:
    """(H, W, 3) RGB: each pixel in its element's colour, darkened where the surface is seen at a grazing angle."""
    hit = view.element >= 0
    img = np.ones((view.camera.height, view.camera.width, 3)) * BACKGROUND
    img[hit] = colours[view.element[hit]] * (0.4 + 0.6 * view.shade[hit])[:, None]
    return img


def _legend(target, **kwargs) -> None:
    from matplotlib.patches import Rectangle

    target.legend([Rectangle((0, 0), 1, 1, color=c) for c, _ in LEGEND], [label for _, label in LEGEND], fontsize=8,
                  **kwargs)


def draw_overview(view: SceneView, colours: NDArray, path: str | Path, camera_centres: NDArray | None = None,
                  title: str = "") -> Path:
    """Write a PNG of ``view`` with each element in its (z, 3) colour, shaded; camera centres as dots."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    cam = view.camera
    fig = Figure(figsize=(cam.width / 100, cam.height / 100), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.imshow(shaded_image(view, colours), interpolation="nearest")
    if camera_centres is not None and len(camera_centres):
        u, v = view.project(camera_centres)
        ax.scatter(u, v, s=6, c="#1f4e9e", marker="o", linewidths=0)
    _legend(ax, loc="lower right")
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()
    fig.tight_layout(pad=0.2)
    out = Path(path)
    fig.savefig(out)
    return out


def draw_storeys(views: list[tuple[str, SceneView]], colours: NDArray, path: str | Path, title: str = "") -> Path | None:
    """Write one PNG with a cutaway panel per storey, elements in their (z, 3) colours; None without storeys."""
    if not views:
        return None
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    cols = min(3, len(views))
    rows = int(np.ceil(len(views) / cols))
    cam = views[0][1].camera
    fig = Figure(figsize=(cols * cam.width / 200, rows * cam.height / 200 + 0.4), dpi=100)
    FigureCanvasAgg(fig)
    for k, (name, view) in enumerate(views):
        ax = fig.add_subplot(rows, cols, k + 1)
        ax.imshow(shaded_image(view, colours), interpolation="nearest")
        ax.set_title(name, fontsize=9)
        ax.set_axis_off()
    _legend(fig, loc="lower center", ncol=4)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    out = Path(path)
    fig.savefig(out)
    return out
