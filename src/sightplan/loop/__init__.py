"""The closed loop: synthetic photographs of a plan, a real structure-from-motion run on them, and the predicted
metrics set beside what the reconstruction measured, per element and per frame."""

from .files import RECONSTRUCTION_FILES, Reconstruction, read_reconstruction, write_reconstruction

__all__ = ["RECONSTRUCTION_FILES", "Reconstruction", "read_reconstruction", "write_reconstruction"]
