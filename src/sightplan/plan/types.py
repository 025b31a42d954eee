"""The Plan: ordered frames (camera + pose), grouped into missions."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera
from ..errors import PlanError
from ..geometry.poses import check_rotations
from .domain import check_points, check_times


@dataclass(frozen=True)
class Mission:
    """Frames ``start`` (inclusive) to ``stop`` (exclusive) of the plan, flown as one flight.

    ``ground_station``: (x, y, z) model-frame position of the pilot for this flight, where
    line-of-sight and battery checks measure from; None where not set (the plan's default).
    """

    name: str
    start: int
    stop: int
    ground_station: tuple[float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class Plan:
    """Frames in capture order (missions concatenated in flight order).

    cameras: camera id → camera model.
    frame_camera: (n,) object, the camera id of each frame.
    R_world_camera: (n, 3, 3) float64 world-from-camera rotations (OpenCV camera axes).
    C_world: (n, 3) float64 camera centres, metres, model's local frame.
    frame_names: (n,) object, e.g. image file names.
    capture_time: (n,) float64 seconds (POSIX) or NaN where unknown.
    missions: consecutive frame ranges covering 0..n.
    waypoints: (m, 3) float64 flight waypoints, metres (may be empty).
    parameters: the template parameters that made the plan, or the import's source.
    """

    cameras: dict[str, Camera]
    frame_camera: NDArray[np.object_]
    R_world_camera: NDArray[np.float64]
    C_world: NDArray[np.float64]
    frame_names: NDArray[np.object_]
    capture_time: NDArray[np.float64]
    missions: tuple[Mission, ...]
    waypoints: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    parameters: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.C_world)
        C = np.asarray(self.C_world)
        if C.ndim != 2 or C.shape[1] != 3:
            raise PlanError(f"C_world must be (n, 3), got {C.shape}")
        check_points(C, lambda i: f"frame {i}")  # the domain of plan numbers: nothing downstream can make NaN
        check_points(self.waypoints, lambda i: f"waypoint {i}")
        check_times(self.capture_time, lambda i: f"frame {i}")
        for m in self.missions:
            if m.ground_station is not None:
                check_points(m.ground_station, f"mission {m.name!r}", "ground_station")
        check_rotations(self.R_world_camera)
        if len(self.R_world_camera) != n:
            raise PlanError(f"{len(self.R_world_camera)} rotations for {n} positions")
        for name in ("frame_camera", "frame_names", "capture_time"):
            if len(getattr(self, name)) != n:
                raise PlanError(f"{name} has {len(getattr(self, name))} entries for {n} frames")
        unknown = set(self.frame_camera.tolist()) - set(self.cameras)
        if unknown:
            raise PlanError(f"frames use undefined camera(s): {', '.join(sorted(map(str, unknown)))}")
        pos = 0
        for m in self.missions:
            if m.start != pos or m.stop < m.start:
                raise PlanError(f"mission {m.name!r} covers frames {m.start}..{m.stop}; missions must be consecutive from 0")
            pos = m.stop
        if self.missions and pos != n:
            raise PlanError(f"missions cover {pos} frames, the plan has {n}")

    @classmethod
    def build(
        cls,
        camera: Camera | dict[str, Camera],
        R_world_camera: NDArray,
        C_world: NDArray,
        frame_camera: list[str] | None = None,
        frame_names: list[str] | None = None,
        capture_time: NDArray | None = None,
        missions: tuple[Mission, ...] | None = None,
        waypoints: NDArray | None = None,
        parameters: dict | None = None,
    ) -> Plan:
        """Convenience constructor: one camera for all frames unless ``frame_camera`` says otherwise."""
        C = np.asarray(C_world, float).reshape(-1, 3)
        R = np.asarray(R_world_camera, float).reshape(-1, 3, 3)
        n = len(C)
        cams = camera if isinstance(camera, dict) else {camera.name or "camera": camera}
        if frame_camera is None:
            if len(cams) != 1:
                raise PlanError("several cameras given: say which camera each frame uses")
            frame_camera = [next(iter(cams))] * n
        names = frame_names if frame_names is not None else [f"frame_{i:05d}" for i in range(n)]
        obj = lambda xs: np.array(list(xs) + [None], dtype=object)[:-1]  # noqa: E731  (keeps 1-D object arrays)
        return cls(
            cameras=dict(cams),
            frame_camera=obj(frame_camera),
            R_world_camera=R,
            C_world=C,
            frame_names=obj(map(str, names)),
            capture_time=np.full(n, np.nan) if capture_time is None else np.asarray(capture_time, float),
            missions=missions if missions is not None else (Mission("mission 1", 0, n),),
            waypoints=np.zeros((0, 3)) if waypoints is None else np.asarray(waypoints, float).reshape(-1, 3),
            parameters=parameters or {},
        )

    def __len__(self) -> int:
        return len(self.C_world)

    def camera_of(self, i: int) -> Camera:
        return self.cameras[self.frame_camera[i]]

    def subset(self, index: NDArray) -> Plan:
        """The plan restricted to frames ``index`` (in that order), one mission."""
        idx = np.asarray(index, int)
        return replace(
            self, frame_camera=self.frame_camera[idx], R_world_camera=self.R_world_camera[idx], C_world=self.C_world[idx],
            frame_names=self.frame_names[idx], capture_time=self.capture_time[idx], missions=(Mission("subset", 0, len(idx)),),
        )

    def frame_keys(self) -> list[str]:
        """(n,) hex digests of each frame's camera and pose, for per-frame caches."""
        keys = []
        for i in range(len(self)):
            h = hashlib.sha256(repr(sorted(self.camera_of(i).to_dict().items())).encode())
            h.update(np.round(self.R_world_camera[i], 12).tobytes())
            h.update(np.round(self.C_world[i], 9).tobytes())
            keys.append(h.hexdigest()[:32])
        return keys
