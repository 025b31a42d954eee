"""Plans as they may be flown: every frame moved and turned at random by the aircraft's pose error.

**What the numbers mean.** A :class:`PoseError` holds the same ``(h, v)`` metres as the flight checks'
position error (:data:`~.checks.safety.POSITION_ERROR`, the presets ``gnss`` ±1.5 m / ±0.5 m and ``rtk``
±0.1 m / ±0.1 m, the hovering accuracy that drone makers publish), and a heading error in degrees. The checks
take ``(h, v)`` as a worst case (a cylinder the aircraft never leaves). Here they are the 95 % bounds of a normal
error, as a published "±x m" is usually read:

- horizontally, 95 % of positions lie within ``h`` of the planned point: a circular normal error of standard
  deviation σ_h = h / √(−2 ln 0.05) = h / 2.4477 along each of x and y (its distance from the planned point
  follows a Rayleigh law, P(r ≤ h) = 1 − exp(−h² / 2σ_h²) = 0.95);
- vertically, 95 % lie within ±v: σ_v = v / 1.9600;
- the heading (yaw, a turn about the vertical through the camera's centre), 95 % within ±yaw degrees:
  σ_yaw = yaw / 1.9600. No maker publishes a heading accuracy beside the hovering accuracy, so the presets
  leave it at 0.

So the cylinder of the checks holds a draw's frame with probability 0.95 × 0.95 ≈ 0.90. Each frame is
perturbed independently of the others (no drift along a flight), by a seeded :class:`numpy.random.Generator`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanError
from .checks.safety import POSITION_ERROR, position_error
from .types import Mission, Plan

Z95 = 1.959963984540054  # a normal variable lies within ±1.96 σ with probability 0.95
R95 = math.sqrt(-2.0 * math.log(0.05))  # a circular 2-D normal lies within 2.4477 σ of its centre with probability 0.95
MAX_YAW_DEG = 180.0


@dataclass(frozen=True)
class PoseError:
    """horizontal_m, vertical_m: 95 % bounds of the position error (metres); yaw_deg: 95 % bound of the heading
    error (degrees). See the module docstring for the normal errors they stand for."""

    horizontal_m: float
    vertical_m: float
    yaw_deg: float = 0.0

    def __post_init__(self) -> None:
        h, v = position_error((self.horizontal_m, self.vertical_m))
        object.__setattr__(self, "horizontal_m", h)
        object.__setattr__(self, "vertical_m", v)
        yaw = float(self.yaw_deg)
        if not (math.isfinite(yaw) and 0 <= yaw <= MAX_YAW_DEG):
            raise PlanError(f"the heading error must be a number of degrees from 0 to {MAX_YAW_DEG:g}, "
                            f"got {self.yaw_deg!r}")
        object.__setattr__(self, "yaw_deg", yaw)

    @classmethod
    def parse(cls, value: object) -> PoseError:
        """From "H,V", "H,V,YAW", a preset name (``gnss``, ``rtk``, ``none``) optionally followed by ",YAW", or a
        sequence of two or three numbers; a PlanError names a bad value."""
        if isinstance(value, PoseError):
            return value
        parts = [p.strip() for p in value.split(",")] if isinstance(value, str) else list(np.atleast_1d(value))
        presets = ", ".join(POSITION_ERROR)
        usage = (f"the position error must be 'H,V' or 'H,V,YAW' (metres, metres, degrees) or a preset ({presets}) "
                 f"with an optional ',YAW', got {value!r}")
        if parts and isinstance(parts[0], str) and parts[0].lower() in POSITION_ERROR:
            if len(parts) > 2:
                raise PlanError(usage)
            hv: list = list(POSITION_ERROR[parts[0].lower()])
            yaw = parts[1] if len(parts) == 2 else 0.0
        elif len(parts) in (2, 3):
            hv, yaw = parts[:2], (parts[2] if len(parts) == 3 else 0.0)
        else:
            raise PlanError(usage)
        try:
            numbers = [float(x) for x in (*hv, yaw)]
        except (TypeError, ValueError):
            raise PlanError(usage) from None
        return cls(*numbers)

    @property
    def sigma(self) -> tuple[float, float, float]:
        """(σ_h per horizontal axis in metres, σ_v in metres, σ_yaw in degrees)."""
        return self.horizontal_m / R95, self.vertical_m / Z95, self.yaw_deg / Z95

    @property
    def zero(self) -> bool:
        return self.horizontal_m == 0 and self.vertical_m == 0 and self.yaw_deg == 0

    def to_dict(self) -> dict:
        s_h, s_v, s_yaw = self.sigma
        return {"horizontal_m": self.horizontal_m, "vertical_m": self.vertical_m, "yaw_deg": self.yaw_deg,
                "meaning": "95 % bounds of a normal error", "sigma_horizontal_m": s_h, "sigma_vertical_m": s_v,
                "sigma_yaw_deg": s_yaw}

    def label(self) -> str:
        text = f"±{self.horizontal_m:g} m / ±{self.vertical_m:g} m"
        return text + (f", heading ±{self.yaw_deg:g}°" if self.yaw_deg else "")


def perturbed_poses(plan: Plan, error: PoseError, samples: int, rng: np.random.Generator
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(samples, n, 3) camera centres and (samples, n, 3, 3) world-from-camera rotations: ``samples`` independent
    draws of every frame of ``plan`` under ``error``. The generator is read the same way whatever the error (one
    (samples, n, 4) block of standard normals: x, y, z, yaw), so a seed gives the same pattern at every size of
    error; a zero error gives the plan's poses exactly."""
    if samples < 1:
        raise PlanError(f"the number of perturbed samples must be at least 1, got {samples}")
    n = len(plan)
    s_h, s_v, s_yaw = error.sigma
    noise = rng.standard_normal((samples, n, 4))
    C = plan.C_world[None] + noise[..., :3] * np.array([s_h, s_h, s_v])
    R = np.broadcast_to(plan.R_world_camera, (samples, n, 3, 3)).copy()
    if s_yaw > 0:
        psi = np.radians(s_yaw * noise[..., 3])
        c, s = np.cos(psi), np.sin(psi)
        Rz = np.zeros((samples, n, 3, 3))
        Rz[..., 0, 0], Rz[..., 0, 1], Rz[..., 1, 0], Rz[..., 1, 1], Rz[..., 2, 2] = c, -s, s, c, 1.0
        R = np.einsum("snij,snjk->snik", Rz, R)
    return C, R


def perturbed_plan(plan: Plan, error: PoseError, samples: int, rng: np.random.Generator) -> Plan:
    """One plan of ``samples`` × n frames, sample after sample (frame ``j·n + f`` is sample j of frame f), from
    :func:`perturbed_poses`: what one engine pass casts. Its frames keep their cameras; it is one mission."""
    n = len(plan)
    C, R = perturbed_poses(plan, error, samples, rng)
    names = [f"{name}~{j}" for j in range(samples) for name in plan.frame_names]
    return Plan.build(dict(plan.cameras), R.reshape(-1, 3, 3), C.reshape(-1, 3),
                      frame_camera=list(plan.frame_camera) * samples, frame_names=names,
                      missions=(Mission("perturbed", 0, samples * n),),
                      parameters={"perturbed": {"error": error.to_dict(), "samples": samples, "frames": n}})
