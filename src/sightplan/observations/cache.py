"""Per-frame observation cache: re-evaluating a plan re-casts only the frames that changed.

Each frame's observation is one small ``.npz`` named by a digest of everything that
determines it: the scene at its date, the feature set, the camera, the pose and the
engine parameters. Unreadable entries are ignored and recomputed.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from ..model.cache import cache_root
from .table import FrameObservation


def default_cache_dir() -> Path:
    """Where frames are cached: ``frames`` under :func:`~sightplan.model.cache.cache_root`."""
    return cache_root() / "frames"


class FrameCache:
    """A directory of per-frame observations keyed by content digests."""

    def __init__(self, directory: str | Path | None = None) -> None:
        self.directory = Path(directory) if directory is not None else default_cache_dir()
        self.hits = 0
        self.misses = 0

    @staticmethod
    def context_key(*parts: object) -> str:
        """Digest of the evaluation context shared by all frames (scene, features, engine, parameters)."""
        return hashlib.sha256(repr(parts).encode()).hexdigest()[:24]

    def _path(self, context: str, frame_key: str) -> Path:
        return self.directory / context[:2] / f"{context}-{frame_key}.npz"

    def get(self, context: str, frame_key: str) -> FrameObservation | None:
        path = self._path(context, frame_key)
        try:
            with np.load(path, allow_pickle=False) as z:
                fo = FrameObservation(z["element"], z["count"], z["depth_mean"], z["angle_mean"], z["features"],
                                      float(z["pixel_scale"]), float(z["sampling_focal_px"]))
        except (OSError, ValueError, KeyError):
            self.misses += 1
            return None
        self.hits += 1
        return fo

    def put(self, context: str, frame_key: str, fo: FrameObservation) -> None:
        path = self._path(context, frame_key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
            np.savez(tmp, element=fo.element, count=fo.count, depth_mean=fo.depth_mean, angle_mean=fo.angle_mean,
                     features=fo.features, pixel_scale=fo.pixel_scale, sampling_focal_px=fo.sampling_focal_px)
            os.replace(tmp, path)
        except OSError:
            pass  # a cache that cannot be written only costs time
