"""A small IFC4 house with a basement, standing in a terrain box: the numbers tests can rely on.

:func:`write_basement_house` writes (metres, world coordinates, every element an axis-aligned box):

- footprint 12 × 8 m: x 0..12, y 0..8; exterior walls 0.3 m thick, inside that rectangle;
- storeys "Basement" (elevation -3.3), "Ground Floor" (0.0), "First Floor" (3.0);
- Basement: floor slab -3.5..-3.3 (basement floor at -3.3), four walls -3.3..0.0, no doors;
- Ground Floor: slab -0.2..0.0, four walls 0.0..3.0, an exterior door in the south wall
  (x 2.5..3.5, y 0.1..0.2, z 0.0..2.1), an interior door clear of the outline (x 5.5..6.5,
  y 3.95..4.05, z 0.0..2.1), a window in the east wall (x 11.8..11.9, y 3.4..4.6, z 1.0..2.2);
- First Floor: slab 2.8..3.0, four walls 3.0..6.0, an IfcRoof 6.0..6.3 (house top 6.3);
- terrain: the IfcSite's own Body, x -34..46, y -36..44, z -3.15..-0.15 (terrain top -0.15);
  the loader keeps it as an occluder (``is_target`` False); the targets' lowest point is -3.5;
- georeferenced (default): site at 51°50'16.8" N, 5°52'12" E (51.8380, 5.8700), RefElevation
  10.0 m, model context TrueNorth (0, 1). Without it the site has no RefLatitude/RefLongitude.

No openings are cut: doors and windows overlap their walls' volumes.
"""

from __future__ import annotations

import pathlib

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import numpy as np

FOOTPRINT = (12.0, 8.0)
WALL_T = 0.3
TERRAIN = ((-34.0, -36.0, -3.15), (46.0, 44.0, -0.15))
STOREYS = {"Basement": -3.3, "Ground Floor": 0.0, "First Floor": 3.0}


def _walls(z0: float, z1: float) -> dict[str, tuple]:
    """The four exterior walls (name suffix → (lo, hi) corners) between heights z0 and z1."""
    x, y, t = *FOOTPRINT, WALL_T
    return {
        "South": ((0, 0, z0), (x, t, z1)),
        "North": ((0, y - t, z0), (x, y, z1)),
        "West": ((0, t, z0), (t, y - t, z1)),
        "East": ((x - t, t, z0), (x, y - t, z1)),
    }


def _box_rep(f: ifcopenshell.file, body, lo, hi):
    """A Body representation: the box with world corners lo, hi (the product sits at the world origin)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    centre = f.createIfcAxis2Placement2D(f.createIfcCartesianPoint(((x0 + x1) / 2, (y0 + y1) / 2)))
    profile = f.createIfcRectangleProfileDef("AREA", None, centre, x1 - x0, y1 - y0)
    solid = f.createIfcExtrudedAreaSolid(
        profile, f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, float(z0)))),
        f.createIfcDirection((0.0, 0.0, 1.0)), z1 - z0)
    return f.createIfcShapeRepresentation(body, "Body", "SweptSolid", [solid])


def _product(f, body, ifc_class: str, name: str, lo, hi, **attributes):
    """A product with a box Body, placed at the world origin."""
    product = ifcopenshell.api.root.create_entity(f, ifc_class=ifc_class, name=name, **attributes)
    ifcopenshell.api.geometry.edit_object_placement(f, product=product, matrix=np.eye(4), is_si=True)
    ifcopenshell.api.geometry.assign_representation(f, product=product, representation=_box_rep(f, body, lo, hi))
    return product


def write_basement_house(path: pathlib.Path, *, georeferenced: bool = True,
                         true_north: tuple[float, float] = (0.0, 1.0)) -> pathlib.Path:
    """Write the house described in the module docstring to ``path`` (IFC4, metres) and return ``path``;
    ``true_north``: the model context's TrueNorth (true north's direction in the model's x, y)."""
    api = ifcopenshell.api
    f = api.project.create_file(version="IFC4")
    project = api.root.create_entity(f, ifc_class="IfcProject", name="Basement House")
    api.unit.assign_unit(f, units=[api.unit.add_si_unit(f, unit_type="LENGTHUNIT")])
    model = api.context.add_context(f, context_type="Model")
    body = api.context.add_context(f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW",
                                   parent=model)

    site = api.root.create_entity(f, ifc_class="IfcSite", name="Site")
    api.aggregate.assign_object(f, products=[site], relating_object=project)
    api.geometry.edit_object_placement(f, product=site, matrix=np.eye(4), is_si=True)
    api.geometry.assign_representation(f, product=site, representation=_box_rep(f, body, *TERRAIN))
    if georeferenced:
        site.RefLatitude = (51, 50, 16, 800000)  # 51.8380 N
        site.RefLongitude = (5, 52, 12, 0)  # 5.8700 E
        site.RefElevation = 10.0
        model.TrueNorth = f.createIfcDirection(tuple(float(v) for v in true_north))

    building = api.root.create_entity(f, ifc_class="IfcBuilding", name="House")
    api.aggregate.assign_object(f, products=[building], relating_object=site)
    api.geometry.edit_object_placement(f, product=building, matrix=np.eye(4), is_si=True)
    storeys = {}
    for name, elevation in STOREYS.items():
        storey = storeys[name] = api.root.create_entity(f, ifc_class="IfcBuildingStorey", name=name)
        storey.Elevation = elevation
        api.aggregate.assign_object(f, products=[storey], relating_object=building)
        matrix = np.eye(4)
        matrix[2, 3] = elevation
        api.geometry.edit_object_placement(f, product=storey, matrix=matrix, is_si=True)

    x, y = FOOTPRINT
    contents = {  # storey → [(class, name, lo, hi, attributes)]
        "Basement": [("IfcSlab", "Basement Slab", (0, 0, -3.5), (x, y, -3.3), {"predefined_type": "FLOOR"})],
        "Ground Floor": [
            ("IfcSlab", "Ground Floor Slab", (0, 0, -0.2), (x, y, 0.0), {"predefined_type": "FLOOR"}),
            ("IfcDoor", "Front Door", (2.5, 0.1, 0.0), (3.5, 0.2, 2.1), {}),
            ("IfcDoor", "Interior Door", (5.5, 3.95, 0.0), (6.5, 4.05, 2.1), {}),
            ("IfcWindow", "East Window", (11.8, 3.4, 1.0), (11.9, 4.6, 2.2), {}),
        ],
        "First Floor": [
            ("IfcSlab", "First Floor Slab", (0, 0, 2.8), (x, y, 3.0), {"predefined_type": "FLOOR"}),
            ("IfcRoof", "Roof", (0, 0, 6.0), (x, y, 6.3), {}),
        ],
    }
    for storey, (z0, z1) in zip(STOREYS, ((-3.3, 0.0), (0.0, 3.0), (3.0, 6.0))):
        contents[storey] += [("IfcWall", f"{storey} Wall {side}", lo, hi, {})
                             for side, (lo, hi) in _walls(z0, z1).items()]
    for storey, items in contents.items():
        products = [_product(f, body, cls, name, lo, hi, **attrs) for cls, name, lo, hi, attrs in items]
        api.spatial.assign_container(f, products=products, relating_structure=storeys[storey])

    path = pathlib.Path(path)
    f.write(str(path))
    return path
