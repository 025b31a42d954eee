"""Photograph-like renders (sightplan.loop.photo, .materials, the presets of render_plan): the lens's distortion
where the OpenCV model puts it, shadows where the geometry casts them, the same seed the same images, every preset
recorded, the IFC's styles read into materials; and (make bench) the distortion estimated back by the SfM."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
from PIL import Image
from scipy.ndimage import binary_erosion

from sightplan.camera.models import PinholeCamera
from sightplan.errors import SightplanError
from sightplan.loop import materials, photo
from sightplan.loop.photo import PRESETS, photo_options
from sightplan.loop.render import element_maps, read_renders, render_plan, surface_samples
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.types import Plan

LENS = (-0.15, 0.05, 0.002, -0.0015)


def opencv_pixel(cam: PinholeCamera, R: np.ndarray, C: np.ndarray, X: np.ndarray, k) -> np.ndarray:
    """The OpenCV model written out here, independently of sightplan.loop.photo: camera coordinates, normalised
    coordinates, k1 k2 radial and p1 p2 tangential terms, pixels (centres at +½)."""
    x_cam = (np.asarray(X, float) - C) @ R
    x, y = x_cam[..., 0] / x_cam[..., 2], x_cam[..., 1] / x_cam[..., 2]
    k1, k2, p1, p2 = k
    r2 = x**2 + y**2
    f = 1 + k1 * r2 + k2 * r2**2
    xd = x * f + 2 * p1 * x * y + p2 * (r2 + 2 * x**2)
    yd = y * f + p1 * (r2 + 2 * y**2) + 2 * p2 * x * y
    return np.stack([cam.fx * xd + cam.cx, cam.fy * yd + cam.cy], axis=-1)


def boxes(specs: list[tuple[tuple[float, float, float], tuple[float, float, float]]], names=None, classes=None
          ) -> Scene:
    """Closed axis-aligned boxes (lo, hi), one element each, outward normals."""
    vertices, faces, owner = [], [], []
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    for e, (lo, hi) in enumerate(specs):
        base = len(vertices)
        vertices += [tuple(np.where(np.array(s) == 1, hi, lo)) for s in itertools.product((0, 1), repeat=3)]
        for a, b, c, d in quads:
            faces += [[base + a, base + b, base + c], [base + a, base + c, base + d]]
            owner += [e, e]
    v, f = np.array(vertices, float), np.array(faces)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centre = np.array([np.mean(specs[o], axis=0) for o in owner])
    outward = np.einsum("ij,ij->i", n, tri.mean(1) - centre) > 0
    f = np.where(outward[:, None], f, f[:, ::-1])
    names = names or [f"box {i}" for i in range(len(specs))]
    table = ElementTable.build(names, ifc_class=classes)
    return Scene.from_arrays(v, f, np.array(owner), table)


R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # looking +Y, image x east, y down
R_DOWN = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])  # looking −Z, image x east, y south


# =========================================================================== the lens
def test_undistort_inverts_the_opencv_model():
    x, y = np.meshgrid(np.linspace(-0.7, 0.7, 15), np.linspace(-0.5, 0.5, 11))
    xd, yd = photo.distort(x, y, LENS)
    xu, yu = photo.undistort(xd, yd, LENS)
    assert np.abs(xu - x).max() < 1e-10 and np.abs(yu - y).max() < 1e-10


def test_each_pixels_ray_projects_back_onto_its_centre_through_the_opencv_model():
    """The world point 7 m along each pixel's lens ray, projected by the OpenCV model written out in this file,
    falls on that pixel's centre (within 1e-6 px)."""
    cam = PinholeCamera(80, 60, 60.0, 61.0, 41.3, 29.2)
    R = R_NORTH @ np.array([[math.cos(0.2), -math.sin(0.2), 0], [math.sin(0.2), math.cos(0.2), 0], [0, 0, 1]])
    C = np.array([1.0, -2.0, 0.5])
    dirs = photo.lens_directions(cam, R, LENS).astype(np.float64)
    X = C + 7.0 * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    px = opencv_pixel(cam, R, C, X, LENS).reshape(cam.height, cam.width, 2)
    u, v = np.meshgrid(np.arange(cam.width) + 0.5, np.arange(cam.height) + 0.5)
    assert np.abs(px[..., 0] - u).max() < 1e-3 and np.abs(px[..., 1] - v).max() < 1e-3  # float32 rays
    np.testing.assert_allclose(photo.project(cam, R, C, X, LENS), px.reshape(-1, 2), atol=1e-9)


def test_a_rendered_marker_sits_where_the_opencv_model_projects_it(tmp_path):
    """A 0.3 m cube 6 m ahead and well off the axis (where the barrel distortion moves it by several pixels):
    the centroid of its pixels in the element map of the distorted render is within 0.5 px of the OpenCV
    projection of its centre, and over 2 px from the ideal pinhole's."""
    cam = PinholeCamera(200, 150, 120.0, 120.0, 100.0, 75.0)
    centre = np.array([3.0, 6.0, -1.8])  # camera coordinates (3, 1.8, 6): normalised (0.5, 0.3)
    scene = boxes([(tuple(centre - 0.15), tuple(centre + 0.15)), ((-20, 20, -20), (20, 21, 20))])
    plan = Plan.build(cam, R_NORTH[None], np.zeros((1, 3)))
    opts = photo_options("full", seed=0, distortion=LENS, sun=False, vignetting=0.0)
    r = render_plan(scene, plan, tmp_path / "r", photo_options=opts, texture_cell_m=0.05)
    ids = element_maps(tmp_path / "r")[0]
    v, u = np.nonzero(ids == 0)
    centroid = np.array([u.mean() + 0.5, v.mean() + 0.5])
    expected = opencv_pixel(cam, R_NORTH, np.zeros(3), centre, LENS)
    pinhole = opencv_pixel(cam, R_NORTH, np.zeros(3), centre, (0, 0, 0, 0))
    assert np.linalg.norm(centroid - expected) < 0.5
    assert np.linalg.norm(centroid - pinhole) > 2.0
    assert r.lens(0) == LENS and list(r.distortion.values()) == [LENS]
    cameras_txt = (tmp_path / "r" / "poses" / "cameras.txt").read_text().splitlines()[-1].split()
    assert cameras_txt[1] == "OPENCV" and [float(x) for x in cameras_txt[-4:]] == list(LENS)
    # the world points the renders saw are on the surfaces, through the lens's rays
    pts, els, _ = surface_samples(tmp_path / "r", stride=3)
    lo, hi = centre - 0.15, centre + 0.15
    on_marker = pts[els == 0]
    assert len(on_marker) and np.all((on_marker > lo - 1e-4) & (on_marker < hi + 1e-4))


# =========================================================================== the sun
def test_the_sun_of_a_date_time_and_latitude():
    """At noon of an equinox the sun stands 90° − latitude high in the south; at 9 h in June at 48° N it is in
    the south-east, 46.9° high; the model's +Y is north without a georeference."""
    s = photo.sun_enu("2025-03-20", 12.0, 48.0)
    assert math.degrees(math.asin(s[2])) == pytest.approx(42.0, abs=1.0) and s[1] < 0 and abs(s[0]) < 1e-9
    s = photo.sun_enu("2025-06-21", 9.0, 48.0)
    assert math.degrees(math.asin(s[2])) == pytest.approx(46.9, abs=0.5) and s[0] > 0 and s[1] < 0
    v, record = photo.sun_direction(photo_options("shaded", latitude_deg=48.0), {})
    assert record["source"] == "latitude given" and v[2] > 0
    v, record = photo.sun_direction(photo_options("shaded", sun_elevation_deg=30.0, sun_azimuth_deg=90.0), {})
    np.testing.assert_allclose(v, [math.cos(math.radians(30)), 0.0, 0.5], atol=1e-12)


def test_a_box_casts_its_shadow_where_the_geometry_says(tmp_path):
    """A 2 m box on the ground (x, y −1…1), the sun 40° high in the east (+X): its shadow on the ground reaches
    x = −1 − 2 / tan 40° = −3.383 m, between y = −1 and 1. Seen straight down from 10 m over (−2.5, 0) at
    f = 200 px (5 cm a pixel), the shadow's edges in the render lie within a pixel of where they fall."""
    scene = boxes([((-1, -1, 0), (1, 1, 2))], classes=["IfcWall"])
    cam = PinholeCamera(200, 200, 200.0, 200.0, 100.0, 100.0)
    C = np.array([-2.5, 0.0, 10.0])
    plan = Plan.build(cam, R_DOWN[None], C[None])
    opts = photo_options("shaded", texture=False, sun_elevation_deg=40.0, sun_azimuth_deg=90.0)
    r = render_plan(scene, plan, tmp_path / "r", photo_options=opts, texture_cell_m=0.1)
    assert r.photo["preset"] == "shaded" and r.photo["sun_position"]["elevation_deg"] == pytest.approx(40.0)
    assert r.photo["ground_z_m"] == pytest.approx(0.0)
    lum = np.asarray(Image.open(tmp_path / "r" / r.image_names[0]), float).mean(axis=2)
    x_edge = -1 - 2 / math.tan(math.radians(40))

    def u_of(x):  # the pixel column whose centre is at world x (fractional)
        return cam.cx + (x - C[0]) / (C[2] - 0.0) * cam.fx - 0.5

    def v_of(y):
        return cam.cy - (y - C[1]) / C[2] * cam.fy - 0.5

    row = lum[100]  # y = −0.025: through the shadow
    lit, dark = np.median(row[:40]), np.median(row[int(u_of(x_edge)) + 3:int(u_of(-1.0)) - 2])
    assert lit > 1.5 * dark  # a real shadow
    mid = 0.5 * (lit + dark)
    first_dark = int(np.argmax(row < mid))
    assert abs(first_dark - 0.5 - u_of(x_edge)) <= 1.0  # the edge between the last lit and the first dark pixel
    col = lum[:, int(round(u_of(-2.2)))]  # x = −2.2: across the shadow's width
    dark_rows = np.flatnonzero(col < mid)
    assert abs(dark_rows.min() - 0.5 - v_of(1.0)) <= 1.0 and abs(dark_rows.max() + 0.5 - v_of(-1.0)) <= 1.0
    assert (element_maps(tmp_path / "r")[0][100, :int(u_of(-1.0)) - 1] == -1).all()  # the ground is no element


# =========================================================================== determinism and presets
def small_scene() -> tuple[Scene, Plan]:
    scene = boxes([((-2, -1, 0), (2, 1, 3)), ((3, -1, 0), (4, 1, 1.5))], classes=["IfcWall", "IfcSlab"])
    cam = PinholeCamera(64, 48, 50.0, 50.0, 32.0, 24.0)
    C = np.array([[-1.0, -9.0, 2.0], [0.0, -9.0, 2.0]])
    return scene, Plan.build(cam, np.stack([R_NORTH, R_NORTH]), C)


def test_the_same_seed_gives_the_same_images_and_another_seed_other_noise(tmp_path):
    scene, plan = small_scene()
    images = {}
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        r = render_plan(scene, plan, tmp_path / name, photo_options=photo_options("full", seed=seed),
                        texture_cell_m=0.05)
        images[name] = [np.asarray(Image.open(r.directory / n)) for n in r.image_names]
    for a, b in zip(images["a"], images["b"], strict=True):
        np.testing.assert_array_equal(a, b)
    diff = [np.abs(a.astype(int) - c.astype(int)) for a, c in zip(images["a"], images["c"], strict=True)]
    assert all((d > 0).mean() > 0.5 for d in diff)  # noise and exposure everywhere
    np.testing.assert_array_equal(element_maps(tmp_path / "a")[0], element_maps(tmp_path / "c")[0])


@pytest.mark.parametrize("preset", PRESETS)
def test_each_preset_renders_and_records_itself(tmp_path, preset):
    scene, plan = small_scene()
    r = render_plan(scene, plan, tmp_path / "r", photo_options=photo_options(preset, seed=3), texture_cell_m=0.05)
    doc = json.loads((tmp_path / "r" / "render.json").read_text())
    assert doc["photo"]["preset"] == preset == r.preset and doc["photo"]["seed"] == 3
    assert doc["photo"]["materials"]["classes"] == {"plaster": 1, "concrete": 1}
    assert ("sun_position" in doc["photo"]) == (preset in ("shaded", "full"))
    assert ("distortion" in doc) == (preset == "full") and read_renders(tmp_path / "r").preset == preset
    img = np.asarray(Image.open(r.directory / r.image_names[0])).astype(float).mean(axis=2)
    wall = binary_erosion(element_maps(tmp_path / "r")[0] == 0, iterations=2)  # off the wall's edges
    bend = np.abs(np.diff(img, n=2, axis=1))[wall[:, 1:-1]].mean()  # the change of the change along the wall
    # flat: one colour per material, only the shading's smooth change with the view angle; else texture (or noise)
    assert (bend < 0.6) if preset == "flat" else (bend > 1.2)


def test_an_unknown_preset_is_refused():
    with pytest.raises(SightplanError, match="photo-realism preset"):
        photo_options("glossy")
    from sightplan.cli.camera_opts import DEFAULT_PRESET

    assert DEFAULT_PRESET == photo.DEFAULT_PRESET


# =========================================================================== materials
def test_materials_from_styles_then_names_then_ifc_class():
    styles = {"styles": [{"name": "Default Wall", "rgb": [0.5, 0.5, 0.5], "transparency": 0.0},
                         {"name": "Door - Panel", "rgb": [0.8, 0.6, 0.4], "transparency": 0.0},
                         {"name": "Glass", "rgb": [0.0, 0.5, 0.7], "transparency": 0.9}],
              "elements": {"w": [0, 0.0, "Masonry - Brick"], "d": [1, 0.0, ""], "g": [1, 0.35, ""],
                           "p": [0, 0.0, "Plasterboard"]}}
    scene = boxes([((i, 0, 0), (i + 0.5, 1, 1)) for i in range(5)], names=["w", "d", "g", "p", "s"],
                  classes=["IfcWallStandardCase", "IfcDoor", "IfcWindow", "IfcWall", "IfcSlab"])
    scene = Scene.from_arrays(scene.vertices, scene.faces, scene.face_element, scene.elements,
                              metadata={"styles": styles})
    m = materials.element_materials(scene)
    assert [m.names[k] for k in m.klass] == ["brick", "wood", "glass", "plaster", "concrete"]
    # a placeholder "Default …" style's grey is not the wall's colour; a real style's is
    np.testing.assert_allclose(m.colour[0], materials.CLASSES["brick"].colour)
    np.testing.assert_allclose(m.colour[1], [0.8, 0.6, 0.4])
    assert m.styled.tolist() == [False, True, False, False, False]


def test_brick_is_a_repetitive_pattern_and_plaster_low_contrast():
    """Along a wall at 5 mm a pixel: brick repeats every 0.24 m (its autocorrelation peaks there) and has far more
    contrast than plaster; glass is all but featureless."""
    u = np.arange(0, 4.0, 0.005)
    points = np.stack([u, np.zeros_like(u), np.full_like(u, 1.0333)], axis=1)
    normals = np.tile([0.0, -1.0, 0.0], (len(u), 1))
    seeds = np.full(len(u), np.uint64(11))
    fp = np.full(len(u), 0.005)

    def lum(name):
        colour = np.tile(materials.CLASSES[name].colour, (len(u), 1))
        return materials.class_albedo(name, points, normals, seeds, colour, 0.03, fp).mean(axis=1)

    brick, plaster, glass = lum("brick"), lum("plaster"), lum("glass")
    b = brick - brick.mean()
    ac = np.correlate(b, b, "full")[len(b) - 1:]
    lag = 30 + int(np.argmax(ac[30:80]))  # between 0.15 m and 0.4 m
    assert lag * 0.005 == pytest.approx(0.24, abs=0.01)
    assert brick.std() / brick.mean() > 2 * plaster.std() / plaster.mean()
    assert glass.std() < 0.01


# =========================================================================== the SfM estimates the lens back
def lens_field_difference(cam: PinholeCamera, a, b, step: int = 10) -> tuple[float, float]:
    """The largest and the RMS distance (px) between where two lenses put the same ray, over a grid of the
    image (its corners included)."""
    u, v = np.meshgrid(np.arange(0, cam.width + 1, step), np.arange(0, cam.height + 1, step))
    x, y = photo.undistort((u.ravel() - cam.cx) / cam.fx, (v.ravel() - cam.cy) / cam.fy, a)
    xb, yb = photo.distort(x, y, b)
    d = np.hypot(cam.fx * xb + cam.cx - u.ravel(), cam.fy * yb + cam.cy - v.ravel())
    return float(d.max()), float(np.sqrt(np.mean(d**2)))


@pytest.mark.bench
def test_the_sfm_estimates_the_lens_distortion_back(tmp_path):
    """The textured box building of tests/test_loop_reconstruct.py, 24 frames round it at 400 × 300 px through the
    default lens (k1 −0.06, k2 0.015, p1 0.0008, p2 −0.0005), full preset (noise, exposure, blur): every frame
    registers and the OPENCV camera's bundle adjustment gives k1 back within 0.01, and a lens that puts the rays
    within 0.5 px RMS (2 px at the very corners) of where the true one does; no correction at all would be 2.9 px
    RMS and 9 px at the corners. Tolerance: k1 moves a corner pixel by about 0.4 · Δk1 · f px (a normalised radius²
    of 0.4 at the corner, f = 320 px), so 0.01 is 1.3 px; k2 and the tangential terms trade off against k1 and
    each other and are not separately observable at this reprojection error (0.2 px mean; one run here gave p1
    −0.0013 for 0.0008), so the whole mapping is compared instead, at the SIFT keypoints' own accuracy (a few
    tenths of a pixel). About 35 s on 2 cores: make bench."""
    pytest.importorskip("pycolmap")
    from sightplan.loop.reconstruct import reconstruct
    from test_loop_reconstruct import box_building, orbit

    plan = orbit(24)
    r = render_plan(box_building(), plan, tmp_path / "images", photo_options=photo_options("full", seed=3))
    rec = reconstruct(r.directory, tmp_path / "recon", threads=2)
    assert rec.n_registered == 24 and rec.info["camera_model"] == "OPENCV"
    assert rec.info["photo_realism"] == "full" and rec.info["photo_seed"] == 3
    (true,) = rec.info["distortion"]["true"].values()
    (estimated,) = rec.info["distortion"]["estimated"].values()
    assert abs(estimated[0] - true[0]) < 0.01
    worst, rms = lens_field_difference(r.camera(0), tuple(true), tuple(estimated))
    assert rms < 0.5 and worst < 2.0
