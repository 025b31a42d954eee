"""A calibrated prediction of per-element completeness from a plan's metrics (see ``docs/closed-loop.md``)."""
