"""Axis conventions, stated once: sightplan's scenes are Z up (metres); glTF, three.js and the viewers are Y up.

Model (x, y, z) is (x, z, −y) in a Y-up file, a right-handed turn of −90° about X, so north (+Y) points into the
screen (−Z) as glTF's front does. Every conversion in the package goes through these two functions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def z_up_to_y_up(points: ArrayLike, origin: ArrayLike | None = None) -> NDArray[np.float64]:
    """(n, 3) Z-up points, less ``origin`` (Z up, default none), as Y-up coordinates: (x, z, −y)."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    if origin is not None:
        p = p - np.asarray(origin, np.float64)
    return np.column_stack([p[:, 0], p[:, 2], -p[:, 1]])


def y_up_to_z_up(points: ArrayLike) -> NDArray[np.float64]:
    """(n, 3) Y-up points (glTF) as Z-up coordinates: (x, −z, y), the inverse of :func:`z_up_to_y_up`."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    return np.column_stack([p[:, 0], -p[:, 2], p[:, 1]])
