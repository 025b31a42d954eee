"""What will be flown: the exported missions replayed under their autopilots' rules (:mod:`.simulate`, with the
rules of :mod:`.px4` and :mod:`.ardupilot`), and every photo's pose compared with the frame it was meant to take
(:mod:`.fidelity`)."""

from .replay import simulate_file, simulate_items
from .simulate import Gimbal, PhotoPose, Replay

__all__ = ["Gimbal", "PhotoPose", "Replay", "simulate_file", "simulate_items"]
