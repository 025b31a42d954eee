"""Observations: what engines produce and the only thing metrics read.

A sparse element×frame table (one row per element seen in a frame) and a sparse
feature×frame visibility list. Small, saveable, mergeable across batches.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import ObservationsError

FORMAT_VERSION = 1


@dataclass(frozen=True)
class FrameObservation:
    """What one frame sees, before it is placed in a plan-wide table.

    element: (k,) int32 elements hit. count: (k,) int64 rendered pixels.
    depth_mean: (k,) float64 mean ray distance in metres. angle_mean: (k,) float64 mean θ in degrees.
    features: (q,) int32 indices of the features observed in the frame.
    pixel_scale: full-resolution pixels per rendered pixel (1 at full resolution).
    sampling_focal_px: the full-resolution camera's pixels per radian (√(fx·fy) or W/2π).
    """

    element: NDArray[np.int32]
    count: NDArray[np.int64]
    depth_mean: NDArray[np.float64]
    angle_mean: NDArray[np.float64]
    features: NDArray[np.int32]
    pixel_scale: float
    sampling_focal_px: float


def _frame_rows(frame: NDArray, index: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The rows of the frames ``index`` (in that order) of a table sorted by ``frame``, and how many each has."""
    lo = np.searchsorted(frame, index, side="left")
    sizes = np.searchsorted(frame, index, side="right") - lo
    starts = np.cumsum(sizes) - sizes  # where each frame's rows begin in the output
    return np.arange(int(sizes.sum()), dtype=np.int64) + np.repeat(lo - starts, sizes), sizes


@dataclass(frozen=True)
class Observations:
    """Sparse observations of a plan's n frames over a scene's z elements.

    Rows (m,): ``frame`` int32, ``element`` int32, ``count`` int64 rendered pixels,
    ``depth_mean`` float64 metres, ``angle_mean`` float64 degrees.
    Per frame (n,): ``pixel_scale`` (full-resolution pixels per rendered pixel),
    ``sampling_focal_px`` (pixels per radian of the full-resolution camera).
    Per element (z,): ``is_target`` — present elements that count in ``z``;
    ``present`` — elements that existed (targets and occluders).
    Features: ``feature_frame``/``feature_id`` (q,) int32 pairs, one per observation of a
    simulated feature in a frame; ``n_features``.
    """

    n_frames: int
    frame: NDArray[np.int32]
    element: NDArray[np.int32]
    count: NDArray[np.int64]
    depth_mean: NDArray[np.float64]
    angle_mean: NDArray[np.float64]
    pixel_scale: NDArray[np.float64]
    sampling_focal_px: NDArray[np.float64]
    is_target: NDArray[np.bool_]
    present: NDArray[np.bool_]
    feature_frame: NDArray[np.int32]
    feature_id: NDArray[np.int32]
    n_features: int
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        m = len(self.frame)
        for name in ("element", "count", "depth_mean", "angle_mean"):
            if len(getattr(self, name)) != m:
                raise ObservationsError(f"observation column {name!r} has {len(getattr(self, name))} rows, expected {m}")
        for name in ("pixel_scale", "sampling_focal_px"):
            if len(getattr(self, name)) != self.n_frames:
                raise ObservationsError(f"{name} has {len(getattr(self, name))} entries for {self.n_frames} frames")
        if len(self.feature_frame) != len(self.feature_id):
            raise ObservationsError("feature_frame and feature_id differ in length")
        if m and (self.frame.max() >= self.n_frames or self.element.max() >= self.n_elements):
            raise ObservationsError("observation rows index frames or elements out of range")

    @property
    def n_elements(self) -> int:
        return len(self.is_target)

    @property
    def pixels(self) -> NDArray[np.float64]:
        """(m,) |γ_{i,f}| in full-resolution pixels."""
        return self.count * self.pixel_scale[self.frame]

    @property
    def ssd(self) -> NDArray[np.float64]:
        """(m,) surface sampling distance ρ_{i,f} in metres per pixel."""
        return self.depth_mean / self.sampling_focal_px[self.frame]

    # ----------------------------------------------------------- construction
    @classmethod
    def from_frames(
        cls,
        frames: list[FrameObservation],
        is_target: NDArray[np.bool_],
        present: NDArray[np.bool_],
        n_features: int,
        meta: dict | None = None,
    ) -> Observations:
        """Stack per-frame observations in plan order."""
        n = len(frames)
        sizes = np.array([len(f.element) for f in frames], dtype=np.int64)
        fsizes = np.array([len(f.features) for f in frames], dtype=np.int64)
        cat = lambda name, dtype: (np.concatenate([getattr(f, name) for f in frames]).astype(dtype)  # noqa: E731
                                   if n else np.zeros(0, dtype))
        return cls(
            n_frames=n,
            frame=np.repeat(np.arange(n, dtype=np.int32), sizes),
            element=cat("element", np.int32),
            count=cat("count", np.int64),
            depth_mean=cat("depth_mean", np.float64),
            angle_mean=cat("angle_mean", np.float64),
            pixel_scale=np.array([f.pixel_scale for f in frames], dtype=np.float64),
            sampling_focal_px=np.array([f.sampling_focal_px for f in frames], dtype=np.float64),
            is_target=np.asarray(is_target, bool),
            present=np.asarray(present, bool),
            feature_frame=np.repeat(np.arange(n, dtype=np.int32), fsizes),
            feature_id=cat("features", np.int32),
            n_features=int(n_features),
            meta=meta or {},
        )

    def frame_observation(self, f: int) -> FrameObservation:
        """Row ``f`` back as a :class:`FrameObservation` (rows are sorted by frame)."""
        lo, hi = np.searchsorted(self.frame, [f, f + 1])
        flo, fhi = np.searchsorted(self.feature_frame, [f, f + 1])
        return FrameObservation(self.element[lo:hi], self.count[lo:hi], self.depth_mean[lo:hi], self.angle_mean[lo:hi],
                                self.feature_id[flo:fhi], float(self.pixel_scale[f]), float(self.sampling_focal_px[f]))

    def select_frames(self, index: NDArray) -> Observations:
        """Observations of the frames ``index`` only, renumbered 0..len(index)−1 in that order.

        Selecting frames (plan editing, optimisation) needs no new ray casting.
        """
        index = np.asarray(index, int)
        frames = [self.frame_observation(int(f)) for f in index]
        return Observations.from_frames(frames, self.is_target, self.present, self.n_features, dict(self.meta))

    def take_frames(self, index: NDArray) -> Observations:
        """:meth:`select_frames` in a few array operations (for many selections of one large table, as the draws
        of :mod:`sightplan.robustness` make); a frame may be taken more than once."""
        index = np.asarray(index, np.int64).reshape(-1)
        if len(index) and (index.min() < 0 or index.max() >= self.n_frames):
            raise ObservationsError(f"frame index out of range 0..{self.n_frames - 1}")
        rows, sizes = _frame_rows(self.frame, index)
        frows, fsizes = _frame_rows(self.feature_frame, index)
        new = np.arange(len(index), dtype=np.int32)
        return replace(
            self, n_frames=len(index), frame=np.repeat(new, sizes), element=self.element[rows], count=self.count[rows],
            depth_mean=self.depth_mean[rows], angle_mean=self.angle_mean[rows], pixel_scale=self.pixel_scale[index],
            sampling_focal_px=self.sampling_focal_px[index], feature_frame=np.repeat(new, fsizes),
            feature_id=self.feature_id[frows], meta=dict(self.meta),
        )

    @staticmethod
    def concatenate(parts: list[Observations]) -> Observations:
        """Merge batches of consecutive frames (of the same scene and features) into one table."""
        if not parts:
            raise ObservationsError("nothing to merge")
        first = parts[0]
        context = ("scene", "features", "engine", "scale", "d_max")
        for p in parts[1:]:
            same = p.n_elements == first.n_elements and p.n_features == first.n_features
            if not same or not np.array_equal(p.is_target, first.is_target) or not np.array_equal(p.present, first.present):
                raise ObservationsError("cannot merge observations of different scenes or capture dates")
            differs = [k for k in context if p.meta.get(k) != first.meta.get(k)]
            if differs:
                raise ObservationsError(f"cannot merge observations made with a different {', '.join(differs)}")
        offsets = np.cumsum([0] + [p.n_frames for p in parts[:-1]])
        return replace(
            first,
            n_frames=int(sum(p.n_frames for p in parts)),
            frame=np.concatenate([p.frame + o for p, o in zip(parts, offsets)]).astype(np.int32),
            element=np.concatenate([p.element for p in parts]),
            count=np.concatenate([p.count for p in parts]),
            depth_mean=np.concatenate([p.depth_mean for p in parts]),
            angle_mean=np.concatenate([p.angle_mean for p in parts]),
            pixel_scale=np.concatenate([p.pixel_scale for p in parts]),
            sampling_focal_px=np.concatenate([p.sampling_focal_px for p in parts]),
            feature_frame=np.concatenate([p.feature_frame + o for p, o in zip(parts, offsets)]).astype(np.int32),
            feature_id=np.concatenate([p.feature_id for p in parts]),
        )

    # ------------------------------------------------------------------- files
    _ARRAYS = ("frame", "element", "count", "depth_mean", "angle_mean", "pixel_scale", "sampling_focal_px",
               "is_target", "present", "feature_frame", "feature_id")

    def save(self, path: str | Path) -> None:
        """Write a compressed ``.npz`` (arrays plus a JSON header)."""
        header = {"format": "sightplan-observations", "version": FORMAT_VERSION, "n_frames": self.n_frames,
                  "n_features": self.n_features, "meta": self.meta}
        np.savez_compressed(path, header=np.array(json.dumps(header)), **{k: getattr(self, k) for k in self._ARRAYS})

    @classmethod
    def load(cls, path: str | Path) -> Observations:
        try:
            with np.load(path, allow_pickle=False) as z:
                header = json.loads(str(z["header"]))
                arrays = {k: z[k] for k in cls._ARRAYS}
            if not isinstance(header, dict) or header.get("format") != "sightplan-observations":
                raise ObservationsError(f"{path} is not a sightplan observations file")
            if header.get("version", 0) > FORMAT_VERSION:
                raise ObservationsError(f"{path} was written by a newer sightplan "
                                        f"(format {header['version']} > {FORMAT_VERSION})")
            return cls(n_frames=int(header["n_frames"]), n_features=int(header["n_features"]),
                       meta=header.get("meta", {}), **arrays)
        except ObservationsError:
            raise
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ObservationsError(f"{path} is not a sightplan observations file: {exc}") from None
