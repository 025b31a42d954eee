"""Feasibility checks of a plan against the model (flight safety)."""

from .airspace import AltitudeReport, LineOfSightReport, check_altitude, check_line_of_sight, default_ground_station
from .battery import AIRCRAFT, ROVERS, Aircraft, MissionTime, Rover, mission_time, split_by_battery, split_by_rover
from .safety import SafetyReport, check_safety, point_distances, segment_distances

__all__ = [
    "AIRCRAFT", "ROVERS", "Aircraft", "AltitudeReport", "LineOfSightReport", "MissionTime", "Rover", "SafetyReport",
    "check_altitude", "check_line_of_sight", "check_safety", "default_ground_station", "mission_time", "point_distances",
    "segment_distances", "split_by_battery", "split_by_rover",
]
