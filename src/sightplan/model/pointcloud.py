"""Point clouds (PLY, LAS/LAZ): reading them whole or in chunks, and turning them into a surface of patches.

Coordinates are used as stored (LAS scale and offset applied). A cloud becomes a mesh (:func:`points_to_mesh`: a
voxel surface, or Poisson reconstruction through Open3D) and its elements are surface patches (:mod:`.patches`).
"""

from __future__ import annotations

import math
import struct
import time
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from ..errors import ModelError
from .formats import POINT_CLOUD_EXTENSIONS
from .patches import patch_faces, patch_options, patch_table
from .scene import Scene
from .summary import LoadReport
from .unpack import max_unpacked_bytes, too_big

#: Median nearest-neighbour distance × this = the default voxel spacing.
SPACING_PER_NN = 3.0

#: Largest voxel grid :func:`points_to_mesh` builds (nodes); beyond it a larger spacing is needed.
MAX_VOXELS = 400_000_000

MIN_POINTS = 10

MeshMethod = Literal["voxel", "poisson"]

# =========================================================================== point clouds
class PointCloud(NamedTuple):
    """points: (n, 3) float64 metres. normals: (n, 3) float64, or None when the file has none."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64] | None = None

def _check_file(path: Path) -> None:
    if not path.is_file():
        raise ModelError(f"point cloud file not found: {path}")
    if path.stat().st_size == 0:
        raise ModelError(f"{path.name} is empty")

def ply_header(path: str | Path) -> dict[str, int] | None:
    """Element counts of a PLY header ({'vertex': n, 'face': m, ...}), or None when it is no readable PLY header."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError:
        return None
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return None
    counts: dict[str, int] = {}
    for line in head[:end].decode("latin-1").splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "element":
            try:
                counts[parts[1]] = int(parts[2])
            except ValueError:
                return None
    return counts

def is_point_cloud(path: str | Path) -> bool:
    """True for LAS/LAZ files and for PLY files whose header declares vertices but no faces."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext in POINT_CLOUD_EXTENSIONS:
        return True
    if ext != ".ply":
        return False
    counts = ply_header(path)
    return counts is not None and counts.get("face", 0) == 0 and counts.get("tristrips", 0) == 0

def _read_ply_points(path: Path) -> PointCloud:
    from plyfile import PlyData

    try:
        ply = PlyData.read(str(path))
    except Exception as exc:  # plyfile raises PlyParseError, ValueError, EOFError, ...
        raise ModelError(f"{path.name} cannot be read as PLY: {type(exc).__name__}: {exc}") from exc
    names = [e.name for e in ply.elements]
    if "vertex" not in names:
        raise ModelError(f"{path.name} has no vertex element, so no points")
    vertex = ply["vertex"].data
    fields = vertex.dtype.names or ()
    if not {"x", "y", "z"} <= set(fields):
        raise ModelError(f"{path.name}: the vertices have no x, y, z properties (found {', '.join(fields) or 'none'})")
    points = np.column_stack([np.asarray(vertex[c], np.float64) for c in "xyz"]) if len(vertex) else np.zeros((0, 3))
    normals = None
    if {"nx", "ny", "nz"} <= set(fields) and len(vertex):
        normals = np.column_stack([np.asarray(vertex[c], np.float64) for c in ("nx", "ny", "nz")])
    return PointCloud(points, normals)

def _read_las_points(path: Path) -> tuple[PointCloud, str | None]:
    import laspy

    _check_las_header(path)
    _check_las_size(path)
    try:
        las = laspy.read(str(path))
        points = np.column_stack([np.asarray(las.x, np.float64), np.asarray(las.y, np.float64),
                                  np.asarray(las.z, np.float64)]) if len(las.points) else np.zeros((0, 3))
    except Exception as exc:  # laspy raises LaspyException, ValueError, OSError, lazrs errors, ...
        raise ModelError(f"{path.name} cannot be read as LAS/LAZ: {type(exc).__name__}: {exc}") from exc
    crs = None
    try:
        parsed = las.header.parse_crs()
        crs = parsed.to_string() if parsed is not None else None
    except Exception:  # a missing or malformed CRS record leaves the cloud usable
        crs = None
    return PointCloud(points, None), crs

def read_point_cloud(path: str | Path) -> PointCloud:
    """Points (and normals, when the file has them) of a PLY or LAS/LAZ file, in the file's units.

    LAS stores scaled integers: the real coordinates (X·scale + offset) are returned. A PLY
    file with faces gives its vertices. Every reader failure, a file without points and
    non-finite coordinates raise a ModelError.
    """
    path = Path(path)
    cloud, _ = _read_cloud(path)
    return PointCloud(check_points(cloud.points, path.name), cloud.normals)

_LAS_MIN_HEADER = 227  # bytes of a LAS 1.0–1.2 public header block

_VLR_HEADER = 54

def _check_las_header(path: Path) -> None:
    """A ModelError when the fixed part of a LAS header cannot be right (a corrupt file would send the reader
    through billions of records): signature, header size, offset to the points, number of VLRs."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(_LAS_MIN_HEADER)
    if len(head) < _LAS_MIN_HEADER or head[:4] != b"LASF":
        raise ModelError(f"{path.name} cannot be read as LAS/LAZ: no LAS header (the file starts {head[:4]!r})")
    header_size, offset, n_vlrs = struct.unpack_from("<HII", head, 94)
    if not (_LAS_MIN_HEADER <= header_size <= offset <= size and n_vlrs * _VLR_HEADER <= offset - header_size):
        raise ModelError(f"{path.name} cannot be read as LAS/LAZ: a corrupt header (header size {header_size}, "
                         f"points at byte {offset} of {size}, {n_vlrs} variable-length records)")

def _check_las_size(path: Path):
    """The LAS/LAZ file's header, after checking what its points need: a LAZ file's points may unpack to
    :func:`~sightplan.model.unpack.max_unpacked_bytes` at most, a LAS file's must fit in the file."""
    import laspy

    try:
        with laspy.open(str(path)) as reader:
            header = reader.header
            count, record = int(header.point_count), int(header.point_format.size)
            compressed = bool(header.are_points_compressed)
            offset = int(header.offset_to_point_data)
    except Exception as exc:  # laspy raises LaspyException, ValueError, OSError, ...
        raise ModelError(f"{path.name} cannot be read as LAS/LAZ: {type(exc).__name__}: {exc}") from exc
    need = count * record
    if compressed and need > max_unpacked_bytes():
        raise ModelError(too_big(f"{path.name} ({count:,} points)", need))
    if not compressed and need > path.stat().st_size - offset:
        raise ModelError(f"{path.name} cannot be read as LAS: it declares {count:,} points of {record} bytes, "
                         f"more than the file holds (truncated or corrupt)")
    return header

class PointChunkReader:
    """A PLY or LAS/LAZ point cloud read a chunk at a time, so files larger than memory can be streamed.

    ``n``: the number of points the file declares; ``has_colours``: whether it stores red,
    green and blue. :meth:`chunks` yields ``(points, colours)``: (k, 3) float64 coordinates as
    :func:`read_point_cloud` gives them (LAS scale and offset applied) and (k, 3) unsigned
    integer colours as stored (LAS: 16-bit channels, PLY: usually 8-bit; float PLY colours in
    0–1 come as 8-bit), or None. A PLY file is memory-mapped when binary; LAZ is decompressed
    chunk by chunk. Reader failures raise a ModelError; coordinates are not checked here.
    """

    _PLY_COLOURS = (("red", "green", "blue"), ("diffuse_red", "diffuse_green", "diffuse_blue"))

    def __init__(self, path: str | Path, chunk_points: int = 2_000_000) -> None:
        self.path = Path(path)
        self.name = self.path.name
        self.chunk_points = max(1, int(chunk_points))
        _check_file(self.path)
        ext = self.path.suffix.lower()
        self._ply_vertex = None
        self._ply_colours: tuple[str, ...] | None = None
        if ext in POINT_CLOUD_EXTENSIONS:

            _check_las_header(self.path)
            header = _check_las_size(self.path)
            self.n = int(header.point_count)
            self.has_colours = {"red", "green", "blue"} <= set(header.point_format.dimension_names)
            self._kind = "las"
        elif ext == ".ply":
            from plyfile import PlyData

            try:
                ply = PlyData.read(str(self.path))  # binary files are memory-mapped, not loaded
            except Exception as exc:  # plyfile raises PlyParseError, ValueError, EOFError, ...
                raise ModelError(f"{self.name} cannot be read as PLY: {type(exc).__name__}: {exc}") from exc
            if "vertex" not in [e.name for e in ply.elements]:
                raise ModelError(f"{self.name} has no vertex element, so no points")
            vertex = ply["vertex"].data
            fields = set(vertex.dtype.names or ())
            if not {"x", "y", "z"} <= fields:
                found = ", ".join(sorted(fields)) or "none"
                raise ModelError(f"{self.name}: the vertices have no x, y, z properties (found {found})")
            self._ply_vertex = vertex
            self._ply_colours = next((names for names in self._PLY_COLOURS if set(names) <= fields), None)
            self.n = len(vertex)
            self.has_colours = self._ply_colours is not None
            self._kind = "ply"
        else:
            raise ModelError(f"{self.name}: unsupported point cloud format {ext or '(no extension)'!r}; "
                             "supported: .ply, .las, .laz")

    def chunks(self):
        """Yield (points, colours or None) for consecutive runs of at most ``chunk_points`` points."""
        if self._kind == "las":
            yield from self._las_chunks()
        else:
            yield from self._ply_chunks()

    def _las_chunks(self):
        import laspy

        try:
            with laspy.open(str(self.path)) as reader:
                for pts in reader.chunk_iterator(self.chunk_points):
                    if len(pts) == 0:
                        continue
                    xyz = np.column_stack([np.asarray(pts.x, np.float64), np.asarray(pts.y, np.float64),
                                           np.asarray(pts.z, np.float64)])
                    rgb = (np.column_stack([np.asarray(pts.red), np.asarray(pts.green), np.asarray(pts.blue)])
                           if self.has_colours else None)
                    yield xyz, rgb
        except ModelError:
            raise
        except Exception as exc:  # a truncated file or a corrupt LAZ chunk
            raise ModelError(f"{self.name} cannot be read as LAS/LAZ: {type(exc).__name__}: {exc}") from exc

    def _ply_chunks(self):
        vertex = self._ply_vertex
        for i in range(0, self.n, self.chunk_points):
            try:
                part = np.asarray(vertex[i:i + self.chunk_points])
            except Exception as exc:  # a memory-mapped file shorter than its header says
                raise ModelError(f"{self.name} cannot be read as PLY: {type(exc).__name__}: {exc}") from exc
            xyz = np.column_stack([np.asarray(part[c], np.float64) for c in "xyz"])
            rgb = None
            if self._ply_colours is not None:
                rgb = np.column_stack([np.asarray(part[c]) for c in self._ply_colours])
                if rgb.dtype.kind == "f":
                    rgb = np.rint(np.clip(np.nan_to_num(rgb), 0.0, 1.0) * 255.0).astype(np.uint8)
                elif rgb.dtype.kind == "i":
                    rgb = np.clip(rgb, 0, None).astype(np.uint64)
            yield xyz, rgb

def _read_cloud(path: Path) -> tuple[PointCloud, str | None]:
    _check_file(path)
    ext = path.suffix.lower()
    if ext in POINT_CLOUD_EXTENSIONS:
        return _read_las_points(path)
    if ext == ".ply":
        return _read_ply_points(path), None
    raise ModelError(f"{path.name}: unsupported point cloud format {ext or '(no extension)'!r}; supported: .ply, .las, .laz")

def check_points(points: ArrayLike, name: str = "the point cloud") -> NDArray[np.float64]:
    """(n, 3) float64 points, or a ModelError for a wrong shape, no points or non-finite coordinates."""
    pts = np.asarray(points, np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ModelError(f"{name}: points must be (n, 3), got {pts.shape}")
    if len(pts) == 0:
        raise ModelError(f"{name} has no points")
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        raise ModelError(f"{name}: {int(bad.sum())} of {len(pts)} points have non-finite coordinates (NaN or inf)")
    return pts

def default_spacing(points: ArrayLike, sample: int = 200_000, seed: int = 0) -> float:
    """Voxel spacing (m) for :func:`points_to_mesh`: ``SPACING_PER_NN`` × the median nearest-neighbour distance.

    For points scattered at random (Poisson) over a surface, 3 × the median distance puts
    about two points in each node's cell and leaves 14 % of the cells empty, gaps the
    closing bridges; 2 × leaves 41 % empty and many holes. Estimated on a seeded random
    subset of at most ``sample`` points (distances are to neighbours within the whole
    cloud); coincident points are ignored.
    """
    from scipy.spatial import cKDTree

    pts = check_points(points)
    if len(pts) < 2:
        raise ModelError("the point cloud is too sparse to mesh: it needs at least two distinct points")
    tree = cKDTree(pts)
    query = pts if len(pts) <= sample else pts[np.random.default_rng(seed).choice(len(pts), sample, replace=False)]
    k = min(len(pts), 8)
    dist, _ = tree.query(query, k=k)
    dist = dist[:, 1:]
    first = np.where(dist > 0, dist, np.inf).min(axis=1)
    first = first[np.isfinite(first)]
    if len(first) == 0:
        raise ModelError("the point cloud is too sparse to mesh: all its points coincide")
    return SPACING_PER_NN * float(np.median(first))

def points_to_mesh(points: ArrayLike, spacing_m: float | None = None, method: MeshMethod = "voxel", *,
                   normals: ArrayLike | None = None, solid: bool = False) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    """A closed-enough triangle surface of a point cloud for visibility; returns ((V, 3) float64, (F, 3) int32).

    ``"voxel"`` (default): points mark the nodes of a grid of ``spacing_m`` (default
    :func:`default_spacing`) nearest to them; a binary closing with a 3×3×3 cube fills gaps of
    up to two nodes; a Gaussian of half a node softens the steps, and marching cubes
    (scikit-image) takes the 0.5 level. Winding normals face away from the occupied nodes.
    Surface offset: each side of a sampled surface lies 0 to 1 spacing outside it (the node
    rounding), on average about half a spacing. A surface is a shell about one spacing thick
    with a face on either side (so rooms scanned from inside stay open); gaps wider than
    about two spacings, and convex corners without points, stay open as pinholes through
    the shell. ``solid`` fills enclosed cavities instead (pinholes do not stop it), for
    objects captured from outside only. Isolated nodes vanish.

    ``"poisson"``: screened Poisson reconstruction with Open3D (when installed), at an octree
    depth matching ``spacing_m``, trimmed to within two spacings of the points. It needs
    outward normals: the file's, else estimated ones turned toward the space connected to the
    outside of the cloud (objects captured from outside; indoor clouds should carry normals).
    """
    pts = check_points(points)
    if len(pts) < MIN_POINTS:
        raise ModelError(f"the point cloud is too sparse to mesh: {len(pts)} points, at least {MIN_POINTS} needed")
    s = default_spacing(pts) if spacing_m is None else float(spacing_m)
    if not (math.isfinite(s) and s > 0):
        raise ModelError(f"spacing must be a positive number of metres, got {spacing_m!r}")
    if method == "voxel":
        return _voxel_surface(pts, s, solid)
    if method == "poisson":
        return _poisson_surface(pts, s, None if normals is None else np.asarray(normals, np.float64))
    raise ModelError(f"point cloud meshing method must be 'voxel' or 'poisson', got {method!r}")

_PAD = 3  # empty nodes around the occupancy grid

_CUBE = np.ones((3, 3, 3), bool)

def _occupancy(pts: NDArray[np.float64], s: float) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Closed occupancy grid of the points at spacing ``s`` and the world position of node (0, 0, 0)."""
    lo = pts.min(axis=0)
    extent = pts.max(axis=0) - lo
    shape = np.floor(extent / s + 0.5).astype(np.int64) + 2 * _PAD + 1
    if float(np.prod(shape.astype(float))) > MAX_VOXELS:
        raise ModelError(f"the point cloud spans {extent[0]:.1f} × {extent[1]:.1f} × {extent[2]:.1f} m: at a spacing of "
                         f"{s:.3g} m that is {np.prod(shape.astype(float)):.3g} voxels, more than {MAX_VOXELS:.0e}; "
                         "give a larger spacing")
    idx = np.rint((pts - lo) / s).astype(np.int64) + _PAD
    occupied = np.zeros(tuple(shape), bool)
    occupied[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    ring = _CUBE.copy()
    ring[1, 1, 1] = False
    isolated = occupied & ~ndimage.binary_dilation(occupied, structure=ring)
    n_occupied = int(occupied.sum())
    if isolated.sum() > 0.5 * n_occupied:
        raise ModelError(f"the point cloud is too sparse to mesh at a spacing of {s:.3g} m: {int(isolated.sum())} of "
                         f"{n_occupied} occupied voxels have no occupied neighbour; give a larger spacing "
                         f"(about {SPACING_PER_NN:g} × the typical distance between points)")
    return ndimage.binary_closing(occupied, structure=_CUBE), lo - _PAD * s

def _voxel_surface(pts: NDArray[np.float64], s: float, solid: bool) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    from skimage.measure import marching_cubes

    occupied, origin = _occupancy(pts, s)
    if solid:  # cavities of the shell thickened by one node (so pinholes do not leak), thinned back
        thick = ndimage.binary_dilation(occupied, structure=_CUBE)
        occupied |= ndimage.binary_erosion(ndimage.binary_fill_holes(thick), structure=_CUBE)
    field = ndimage.gaussian_filter(occupied.astype(np.float32), sigma=0.5)
    if field.max() <= 0.5:
        raise ModelError(f"the point cloud is too sparse to mesh at a spacing of {s:.3g} m: no surface remains")
    verts, faces, _, _ = marching_cubes(field, 0.5, spacing=(s, s, s), allow_degenerate=False)
    vertices = verts.astype(np.float64) + origin
    return vertices, np.ascontiguousarray(faces[:, ::-1], dtype=np.int32)  # wind away from the occupied side

def _orient_outward(pts: NDArray[np.float64], normals: NDArray[np.float64], s: float) -> NDArray[np.float64]:
    """Flip normals to point into the empty space connected to the outside of the cloud's box.

    The shell is thickened by one node so pinholes do not let the outside in; a normal whose
    two sides are both outside or both enclosed (indoor surfaces) keeps its direction.
    """
    occupied, origin = _occupancy(pts, s)
    empty = ~ndimage.binary_dilation(occupied, structure=_CUBE)
    labels, _ = ndimage.label(empty)
    border = np.unique(np.concatenate([labels[[0, -1]].ravel(), labels[:, [0, -1]].ravel(), labels[:, :, [0, -1]].ravel()]))
    outside = np.isin(labels, border[border > 0])
    shape = np.array(outside.shape)

    def is_outside(q: NDArray) -> NDArray[np.bool_]:
        idx = np.clip(np.rint((q - origin) / s).astype(np.int64), 0, shape - 1)
        return outside[idx[:, 0], idx[:, 1], idx[:, 2]]

    plus, minus = is_outside(pts + 2.5 * s * normals), is_outside(pts - 2.5 * s * normals)
    return np.where((minus & ~plus)[:, None], -normals, normals)

def _poisson_surface(pts: NDArray[np.float64], s: float,
                     normals: NDArray | None) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    try:
        import open3d as o3d
    except ImportError:
        raise ModelError("the 'poisson' method needs Open3D (pip install open3d); the default 'voxel' method does not") from None
    from scipy.spatial import cKDTree

    centre = pts.mean(axis=0)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts - centre))
    if normals is None or normals.shape != pts.shape or not np.isfinite(normals).all():
        cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=3 * s, max_nn=30))
        normals = _orient_outward(pts, np.asarray(cloud.normals, np.float64), s)
    cloud.normals = o3d.utility.Vector3dVector(np.ascontiguousarray(normals, np.float64))
    extent = float(np.ptp(pts, axis=0).max())
    depth = int(np.clip(math.ceil(math.log2(max(extent / s, 2.0))), 5, 12))
    mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=depth)
    vertices = np.asarray(mesh.vertices, np.float64) + centre
    faces = np.asarray(mesh.triangles, np.int64)
    near, _ = cKDTree(pts).query(vertices, k=1)
    faces = faces[(near[faces] <= 2 * s).all(axis=1)]  # Poisson closes gaps with surfaces far from any point
    if len(faces) == 0:
        raise ModelError("Poisson reconstruction produced no surface near the points")
    return vertices, faces.astype(np.int32)

# =========================================================================== loading
def reality_options(path: str | Path, *, elements: str = "patches", patch_area_m2: float | None = None,
                    normal_angle_deg: float | None = None, spacing_m: float | None = None, method: MeshMethod = "voxel",
                    solid: bool = False, scale: float = 1.0) -> dict:
    """The point cloud loader options that change the scene, canonicalised (part of the content hash).

    A point cloud has no objects: ``elements`` may be 'patches' or the mesh default
    'objects' (both meaning patches).
    """
    if elements not in ("patches", "objects"):
        raise ModelError(f"{Path(path).name} is a point cloud: its elements are surface patches "
                         f"(elements='patches'), not {elements!r}")
    if method not in ("voxel", "poisson"):
        raise ModelError(f"point cloud meshing method must be 'voxel' or 'poisson', got {method!r}")
    if not (math.isfinite(scale) and scale > 0):
        raise ModelError(f"scale must be a positive number, got {scale!r}")
    if spacing_m is not None and not (math.isfinite(spacing_m) and spacing_m > 0):
        raise ModelError(f"spacing must be a positive number of metres, got {spacing_m!r}")
    area, angle = patch_options(patch_area_m2, normal_angle_deg)
    return {"loader": "point cloud", "elements": "patches", "patch_area_m2": area, "normal_angle_deg": angle,
            "spacing_m": None if spacing_m is None else float(spacing_m), "method": method, "solid": bool(solid),
            "scale": float(scale)}

def load_point_cloud(path: str | Path, **options) -> tuple[Scene, LoadReport]:
    """A point cloud file (PLY without faces, LAS, LAZ) as a Scene of surface patches, with its load report.

    ``options``: see :func:`reality_options`. The cloud is meshed by :func:`points_to_mesh`.
    """
    from .cache import content_hash

    t0 = time.perf_counter()
    path = Path(path)
    opts = reality_options(path, **options)
    cloud, crs = _read_cloud(path)
    points = check_points(cloud.points, path.name) * opts["scale"]
    spacing = default_spacing(points) if opts["spacing_m"] is None else opts["spacing_m"]
    vertices, faces = points_to_mesh(points, spacing, opts["method"], normals=cloud.normals, solid=opts["solid"])
    face_element, n = patch_faces(vertices, faces, opts["patch_area_m2"], opts["normal_angle_deg"])
    if not opts["solid"]:
        face_element, n = merge_shell_sides(vertices, faces, face_element, spacing)
    fmt = path.suffix.lower().lstrip(".")
    metadata = {"schema": fmt, "unit_scale": opts["scale"], "georeference": None, "crs": crs,
                "reality": {"kind": "point cloud", "n_points": len(points), "spacing_m": spacing, "method": opts["method"],
                            "solid": opts["solid"], "surface_offset_m": 0.5 * spacing if opts["method"] == "voxel" else None,
                            "patch_area_m2": opts["patch_area_m2"], "normal_angle_deg": opts["normal_angle_deg"]}}
    scene = Scene.from_arrays(vertices, faces, face_element, patch_table(n), str(path), content_hash(path, opts), metadata)
    warnings = (f"coordinates reach {np.abs(points).max():.0f} m from the origin (georeferenced?): "
                "give origin_m to load_reality to move them into the model's frame",) if np.abs(points).max() > 1e5 else ()
    report = LoadReport(source=str(path), schema=fmt, unit_scale=opts["scale"], n_products=n, n_elements=n,
                        n_targets=n, n_triangles=len(faces), warnings=warnings, elapsed_s=time.perf_counter() - t0)
    return scene, report

def merge_shell_sides(vertices: NDArray, faces: NDArray, face_element: NDArray, spacing_m: float,
                      share: float = 0.3) -> tuple[NDArray[np.int32], int]:
    """One element for both sides of a thin shell: (face_element, n) with paired patches merged.

    A voxel surface of a scanned sheet has a face on each side, about one spacing apart and
    facing away from each other. Each face is paired with the nearest face within 1.5
    spacings whose normal points the other way; a patch joins the patch that holds most of
    its faces' partners when they are at least ``share`` of its faces. Elements are then
    renumbered by first face, so an element is one patch of surface, seen from either side.
    """
    from scipy.spatial import cKDTree

    fe = np.asarray(face_element, np.int64)
    n = int(fe.max()) + 1 if len(fe) else 0
    if n < 2:
        return fe.astype(np.int32), n
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    centre = tri.mean(axis=1)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    k = min(12, len(centre))
    dist, idx = cKDTree(centre).query(centre, k=k, distance_upper_bound=1.5 * spacing_m)
    found = np.isfinite(dist)
    safe = np.where(found, idx, 0)
    opposite = found & (np.einsum("fj,fkj->fk", normal, normal[safe]) < -0.5)
    has = opposite.any(axis=1)
    partner = safe[np.arange(len(fe)), np.argmax(opposite, axis=1)]
    parent = np.arange(n)

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    size = np.bincount(fe, minlength=n)
    pairs = np.stack([fe[has], fe[partner[has]]], axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    if len(pairs):
        keys, counts = np.unique(pairs, axis=0, return_counts=True)
        order = np.lexsort((-counts, keys[:, 0]))  # per patch, its most frequent partner first
        keys, counts = keys[order], counts[order]
        first = np.r_[True, keys[1:, 0] != keys[:-1, 0]]
        for (p, q), c in zip(keys[first], counts[first]):
            if c >= share * size[p]:
                a, b = root(int(p)), root(int(q))
                if a != b:
                    parent[max(a, b)] = min(a, b)
    roots = np.array([root(i) for i in range(n)])  # the smallest patch number of each group: first-face order kept
    labels, new = np.unique(roots, return_inverse=True)
    return new[fe].astype(np.int32), len(labels)
