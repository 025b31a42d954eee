"""Georeferencing against conversions known independently of pyproj's use here."""

from __future__ import annotations

import math

import ifcopenshell
import ifcopenshell.api
import ifcopenshell.api.georeference
import numpy as np
import pytest

from conftest import shared_file
from sightplan.geo import Georeference, GeoreferenceError, resolve_georeference
from sightplan.model.ifc import load_ifc
from test_model_ifc import make_ifc

WGS84_A = 6378137.0


def test_utm_central_meridian_at_45_degrees_to_the_centimetre():
    # UTM zone 31N: on the central meridian (3°E) the northing is k0 × the meridian arc; at 45°N the
    # WGS84 meridian arc is 4,984,944.378 m (geodesy tables), so N = 0.9996 × that = 4,982,950.400 m.
    g = Georeference.from_map_conversion("EPSG:32631", 500000.0, 4982950.400, 0.0)
    lat, lon, h = g.to_geodetic([[0.0, 0.0, 0.0]])
    assert abs(lat[0] - 45.0) * 111_132 < 0.01  # metres per degree of latitude at 45°
    assert abs(lon[0] - 3.0) * 78_847 < 0.01
    assert h[0] == 0.0


def test_map_conversion_rotation_and_offset_in_web_mercator():
    # EPSG:3857 is spherical: E = a·λ, N = a·ln(tan(π/4 + φ/2)) — a closed form independent of PROJ.
    lat0, lon0 = 47.3977507, 8.5456075
    E0 = WGS84_A * math.radians(lon0)
    N0 = WGS84_A * math.log(math.tan(math.pi / 4 + math.radians(lat0) / 2))
    theta = math.radians(30.0)  # model +X points 30° north of grid east
    g = Georeference.from_map_conversion("EPSG:3857", E0, N0, 400.0, math.cos(theta), math.sin(theta))
    x, y, z = 120.0, -35.0, 12.5
    E = E0 + x * math.cos(theta) - y * math.sin(theta)
    N = N0 + x * math.sin(theta) + y * math.cos(theta)
    lat_expected = math.degrees(2 * math.atan(math.exp(N / WGS84_A)) - math.pi / 2)
    lon_expected = math.degrees(E / WGS84_A)
    lat, lon, h = g.to_geodetic([[x, y, z]])
    assert lat[0] == pytest.approx(lat_expected, abs=1e-9)  # 1e-9° ≈ 0.1 mm
    assert lon[0] == pytest.approx(lon_expected, abs=1e-9)
    assert h[0] == pytest.approx(412.5)
    np.testing.assert_allclose(g.from_geodetic(lat, lon, h), [[x, y, z]], atol=1e-6)
    # model +Y is 30° anticlockwise of grid north, and grid north is true north; web mercator maps
    # ellipsoidal coordinates with spherical formulas, so it is not quite conformal: angles differ by < 0.1°
    assert g.north_offset_deg([[x, y, z]])[0] == pytest.approx(330.0, abs=0.1)


def test_topocentric_origin_offset_and_north():
    g = Georeference.from_origin(41.8744, -87.6394, 180.0, north_deg=90.0, origin_m=(5.0, 5.0, 0.0))
    # model +Y points east: 100 m along +Y from the origin is 100 m east on the ground
    lat, lon, h = g.to_geodetic([[5.0, 5.0, 0.0], [5.0, 105.0, 0.0]])
    assert lat[0] == pytest.approx(41.8744) and lon[0] == pytest.approx(-87.6394) and h[0] == pytest.approx(180.0)
    metres_per_deg_lon = math.pi / 180 * 6378137.0 * math.cos(math.radians(41.8744)) / math.sqrt(
        1 - 0.00669437999014 * math.sin(math.radians(41.8744)) ** 2)
    assert (lon[1] - lon[0]) * metres_per_deg_lon == pytest.approx(100.0, abs=0.01)
    assert lat[1] == pytest.approx(lat[0], abs=1e-8)
    assert h[1] - h[0] == pytest.approx(100.0**2 / (2 * 6_371_000), abs=0.003)  # the plane rises off the curved Earth
    assert g.true_heading([[5.0, 5.0, 0.0]], [0.0])[0] == pytest.approx(90.0, abs=1e-6)
    pts = np.array([[-300.0, 40.0, 20.0], [250.0, -80.0, 3.0]])
    np.testing.assert_allclose(g.from_geodetic(*g.to_geodetic(pts)), pts, atol=1e-6)


def test_dict_round_trip_and_opensfm_reference():
    for g in (Georeference.from_origin(52.5, 13.4, 34.0, 12.0, (1, 2, 3)),
              Georeference.from_map_conversion("EPSG:32633", 390000, 5820000, 30.0, 0.8, 0.6, 1.0002)):
        back = Georeference.from_dict(g.to_dict())
        pts = np.array([[10.0, 20.0, 5.0]])
        np.testing.assert_allclose(np.array(back.to_geodetic(pts)), np.array(g.to_geodetic(pts)), atol=1e-12)
    osfm = Georeference.from_dict({"reference_lla": {"latitude": 52.52, "longitude": 13.40, "altitude": 40.0}})
    lat, lon, h = osfm.to_geodetic([[0.0, 0.0, 0.0]])
    assert (lat[0], lon[0], h[0]) == pytest.approx((52.52, 13.40, 40.0))


@pytest.mark.parametrize(("d", "message"), [
    ({"kind": "projected", "crs": "EPSG:999999", "eastings_m": 0, "northings_m": 0}, "unknown coordinate reference"),
    ({"kind": "projected", "crs": "EPSG:4326", "eastings_m": 0, "northings_m": 0}, "not a projected CRS"),
    ({"kind": "projected", "crs": "EPSG:32631", "northings_m": 0}, "eastings_m"),
    ({"kind": "topocentric", "latitude_deg": 95, "longitude_deg": 0}, "out of range"),
    ({"kind": "topocentric", "latitude_deg": float("nan"), "longitude_deg": 0}, "finite"),
    ({"kind": "mercator"}, "unknown georeference kind"),
])
def test_bad_georeferences_name_the_problem(d, message):
    with pytest.raises(GeoreferenceError, match=message):
        Georeference.from_dict(d)


def test_missing_georeference_says_what_to_set():
    with pytest.raises(GeoreferenceError, match="--origin"):
        resolve_georeference(None, None, what="a KML export")


def test_ifc_map_conversion_to_wgs84(tmp_path):
    path = make_ifc(tmp_path / "geo.ifc", unit="mm")
    f = ifcopenshell.open(str(path))
    ifcopenshell.api.georeference.add_georeferencing(f)
    ifcopenshell.api.georeference.edit_georeferencing(
        f, projected_crs={"Name": "EPSG:32631"},
        coordinate_operation={"Eastings": 500000000.0, "Northings": 4982950400.0, "OrthogonalHeight": 12000.0,
                              "XAxisAbscissa": 0.0, "XAxisOrdinate": 1.0, "Scale": 1.0})
    f.write(str(path))
    scene, _ = load_ifc(path)
    g = Georeference.from_scene_metadata(scene.metadata)
    assert g.kind == "projected" and g.source == "IfcMapConversion"
    # the model's +X is grid north: model (0, 0) is (45°N, 3°E); model +X 1 km is ~1 km north
    lat, lon, h = g.to_geodetic([[0.0, 0.0, 0.0], [1000.0, 0.0, 0.0]])
    assert abs(lat[0] - 45.0) * 111_132 < 0.01 and abs(lon[0] - 3.0) * 78_847 < 0.01 and h[0] == pytest.approx(12.0)
    assert (lat[1] - lat[0]) * 111_132 == pytest.approx(1000 / 0.9996, rel=1e-3)  # UTM scale on the central meridian
    assert g.north_offset_deg([[0.0, 0.0, 0.0]])[0] == pytest.approx(270.0, abs=1e-6)  # +Y points west


def test_ifc_site_latitude_and_true_north(tmp_path):
    path = make_ifc(tmp_path / "site.ifc")
    f = ifcopenshell.open(str(path))
    site = f.by_type("IfcSite")[0]
    site.RefLatitude, site.RefLongitude, site.RefElevation = (51, 30, 0, 0), (-0, -7, -30, 0), 25.0
    ctx = [c for c in f.by_type("IfcGeometricRepresentationContext") if not c.is_a("IfcGeometricRepresentationSubContext")][0]
    ctx.TrueNorth = f.createIfcDirection((-0.5, math.sqrt(3) / 2))  # north is 30° anticlockwise of +Y
    f.write(str(path))
    scene, _ = load_ifc(path)
    g = Georeference.from_scene_metadata(scene.metadata)
    assert g.kind == "topocentric"
    assert (g.latitude_deg, g.longitude_deg, g.height_m) == pytest.approx((51.5, -0.125, 25.0))
    assert g.north_deg == pytest.approx(30.0)  # so model +Y has true heading 30°
    assert g.true_heading([[0.0, 0.0, 0.0]], [0.0])[0] == pytest.approx(30.0, abs=1e-6)


def test_duplex_site_is_chicago():
    from sightplan.model.load import load_model

    scene, _ = load_model(shared_file("ifc/duplex.ifc"))
    g = Georeference.from_scene_metadata(scene.metadata)
    # IfcSite: 41°52'27.84"N, 87°38'21.839999"W
    assert g.latitude_deg == pytest.approx(41 + 52 / 60 + 27.84 / 3600)
    assert g.longitude_deg == pytest.approx(-(87 + 38 / 60 + 21.839999 / 3600))


def test_ifc2x3_map_conversion_with_a_zero_abscissa(tmp_path):
    import ifcopenshell.api.pset

    path = make_ifc(tmp_path / "revit.ifc", version="IFC2X3")
    f = ifcopenshell.open(str(path))
    project = f.by_type("IfcProject")[0]
    conv = ifcopenshell.api.pset.add_pset(f, product=project, name="ePSet_MapConversion")
    ifcopenshell.api.pset.edit_pset(f, pset=conv, properties={
        "Eastings": 500000.0, "Northings": 4982950.4, "OrthogonalHeight": 0.0, "XAxisAbscissa": 0.0, "XAxisOrdinate": 1.0})
    crs = ifcopenshell.api.pset.add_pset(f, product=project, name="ePSet_ProjectedCRS")
    ifcopenshell.api.pset.edit_pset(f, pset=crs, properties={"Name": "EPSG:32631"})
    f.write(str(path))
    scene, _ = load_ifc(path)
    g = Georeference.from_scene_metadata(scene.metadata)
    assert g.x_axis == (0.0, 1.0)  # model +X is grid north: a zero abscissa is a value, not a missing one
    lat, lon, _ = g.to_geodetic([[0.0, 0.0, 0.0], [1000.0, 0.0, 0.0]])
    assert (lat[1] - lat[0]) * 111_132 == pytest.approx(1000 / 0.9996, rel=1e-3) and abs(lon[1] - lon[0]) < 1e-6
