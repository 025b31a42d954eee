"""The box building the optimiser's tests plan around, and the camera they plan with."""

from __future__ import annotations

import numpy as np
import trimesh

from sightplan.camera.models import PinholeCamera
from sightplan.model.scene import ElementTable, Scene

# 600 × 400 px, 73.7° wide: at 10 m a frame covers 15 × 10 m
CAM = PinholeCamera(600, 400, 400.0, 400.0, 300.0, 200.0, "test 600x400")
FACES = ("south", "east", "north", "west", "roof")


def box_building(size: float = 8.0) -> Scene:
    """An 8 m cube standing on the ground: four walls and a roof, each its own element; the floor an occluder."""
    mesh = trimesh.creation.box((size, size, size))
    mesh.apply_translation((size / 2, size / 2, size / 2))
    n = mesh.face_normals
    element = np.select([n[:, 1] < -0.9, n[:, 0] > 0.9, n[:, 1] > 0.9, n[:, 0] < -0.9, n[:, 2] > 0.9], range(5), 5)
    table = ElementTable.build([f"face-{k}" for k in range(6)], name=[*FACES, "floor"],
                               ifc_class=["IfcWall"] * 4 + ["IfcRoof", "IfcSlab"], is_target=[True] * 5 + [False])
    return Scene.from_arrays(mesh.vertices, mesh.faces, element, table)
