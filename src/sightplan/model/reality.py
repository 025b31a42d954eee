"""Reality models: a reconstructed mesh or point cloud as the a-priori model of the site as it is.

A reconstruction has no objects, so its elements are surface *patches* (:func:`patch_faces`):
connected pieces of roughly equal area whose normals stay within an angle of each other, so
per-element metrics keep a meaning. A point cloud (PLY, LAS/LAZ) is first turned into a
surface (:func:`points_to_mesh`). :func:`combine` puts a BIM and a reality scene together,
the reality usually as occluder-only context (existing structures, scaffolding, terrain,
neighbours) that hides BIM elements but is not scored.

Units: metres, Z up (a glTF reality mesh is turned Z up as in :mod:`.mesh`). Point cloud
coordinates are used as stored (LAS scale and offset applied); ``origin_m`` shifts a
georeferenced cloud into a model's local frame.
"""

from __future__ import annotations

import hashlib
import json
import math
import struct
import time
from dataclasses import replace
from pathlib import Path
from typing import Literal, NamedTuple

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import ModelError
from .load import MESH_EXTENSIONS, POINT_CLOUD_EXTENSIONS, load_model
from .scene import ElementTable, Scene
from .summary import LoadReport
from .unpack import max_unpacked_bytes, too_big

#: Default patch area (m²): about a wall panel, so reality patches compare with BIM elements.
PATCH_AREA_M2 = 10.0
#: Default largest angle (°) between a face's normal and its patch seed's normal.
NORMAL_ANGLE_DEG = 30.0
#: Smooth regions and pieces below this share of the patch area join a neighbour (see :func:`patch_faces`).
SMALL_PATCH_SHARE = 0.25
PATCH_CLASS = "RealityPatch"
REALITY_MESH_EXTENSIONS: tuple[str, ...] = MESH_EXTENSIONS
#: Median nearest-neighbour distance × this = the default voxel spacing.
SPACING_PER_NN = 3.0
#: Largest voxel grid :func:`points_to_mesh` builds (nodes); beyond it a larger spacing is needed.
MAX_VOXELS = 400_000_000
MIN_POINTS = 10
MeshMethod = Literal["voxel", "poisson"]
RealityRole = Literal["occluder", "target"]
_VERTEX_QUANTUM_M = 1e-6  # coincident vertices (to a micrometre) are merged for face adjacency
_COS_MERGE = 1e-6  # small regions join neighbours whose mean normal is less than 90° away


def patch_ids(n: int) -> list[str]:
    """Element ids of ``n`` patches: 'patch 00001', 'patch 00002', ... (1-based)."""
    return [f"patch {i + 1:05d}" for i in range(n)]


def patch_table(n: int) -> ElementTable:
    """The element table of ``n`` reality patches: all targets, class RealityPatch, no discipline or dates."""
    ids = patch_ids(n)
    return ElementTable.build(global_id=ids, name=ids, ifc_class=[PATCH_CLASS] * n)


# =========================================================================== patches
def _face_adjacency(vertices: NDArray, faces: NDArray) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(k, 2) pairs of faces sharing an edge (coincident vertices merged) and (k,) the shared edge's length.

    An edge shared by more than two faces links them in a chain (all end up connected).
    """
    if len(faces) == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0)
    q = np.round(vertices / _VERTEX_QUANTUM_M).astype(np.int64)
    _, vid = np.unique(q, axis=0, return_inverse=True)
    vid = vid.reshape(-1)
    f = vid[faces]
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    ends = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces), dtype=np.int64), 3)
    edges.sort(axis=1)
    ok = edges[:, 0] != edges[:, 1]
    edges, ends, owner = edges[ok], ends[ok], owner[ok]
    key = edges[:, 0] * (int(vid.max()) + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    key, owner, ends = key[order], owner[order], ends[order]
    same = (key[1:] == key[:-1]) & (owner[1:] != owner[:-1])
    pairs = np.column_stack([owner[:-1][same], owner[1:][same]])
    e = ends[:-1][same]
    length = np.linalg.norm(vertices[e[:, 1]] - vertices[e[:, 0]], axis=1)
    return pairs, length


def _csr(pairs: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Symmetric adjacency lists of ``n`` nodes as (indptr, indices), neighbours in ascending order."""
    src = np.concatenate([pairs[:, 0], pairs[:, 1]])
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
    order = np.lexsort((dst, src))
    indptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
    return indptr, dst[order].astype(np.int64)


@nb.njit(cache=True)
def _grow_regions(indptr, indices, normals, valid, cos_limit):  # pragma: no cover - compiled
    """Label faces by region growing: seeds in face order; a neighbour joins when its normal is within
    the angle of the seed's. Degenerate faces (``valid`` False) join any region and seed only at the end."""
    n = len(indptr) - 1
    label = np.full(n, -1, np.int32)
    stack = np.empty(max(n, 1), np.int64)
    regions = 0
    for second_pass in range(2):
        for seed in range(n):
            if label[seed] >= 0 or (second_pass == 0 and not valid[seed]):
                continue
            seed_ok = valid[seed]
            label[seed] = regions
            stack[0] = seed
            top = 1
            while top > 0:
                top -= 1
                f = stack[top]
                for k in range(indptr[f], indptr[f + 1]):
                    g = indices[k]
                    if label[g] >= 0:
                        continue
                    if valid[g]:
                        if not seed_ok:
                            continue
                        d = normals[seed, 0] * normals[g, 0] + normals[seed, 1] * normals[g, 1] + normals[seed, 2] * normals[g, 2]
                        if d < cos_limit:
                            continue
                    label[g] = regions
                    stack[top] = g
                    top += 1
            regions += 1
    return label, regions


def _dense(labels: NDArray) -> tuple[NDArray[np.int32], int]:
    """Labels renumbered 0..n-1 in the order of their first face."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inverse.reshape(-1)].astype(np.int32), len(first)


def _merge_small(labels: NDArray, pairs: NDArray, length: NDArray, area: NDArray, normal_sum: NDArray,
                 min_area: float, cos_merge: float, group: NDArray | None = None,
                 kept: NDArray | None = None) -> NDArray[np.int32]:
    """Merge regions smaller than ``min_area`` into the neighbour they share the longest boundary with.

    With ``kept`` (per face), a region without a kept face is merged whatever its area.
    Only into a neighbour of higher rank (holding a kept face, then larger, then lower
    label), whose mean normal has a dot product above ``cos_merge`` with its own and, when
    ``group`` is given, of the same group; repeated until stable.
    """
    labels, n = _dense(labels)
    for _ in range(32):
        region_area = np.bincount(labels, area, n)
        has_kept = np.ones(n, bool) if kept is None else np.bincount(labels, kept, n) > 0
        mean = np.stack([np.bincount(labels, normal_sum[:, i], n) for i in range(3)], axis=1)
        norm = np.linalg.norm(mean, axis=1, keepdims=True)
        mean = np.divide(mean, norm, out=np.zeros_like(mean), where=norm > 0)
        ra, rb = labels[pairs[:, 0]], labels[pairs[:, 1]]
        cross = ra != rb
        if not cross.any():
            break
        a = np.concatenate([ra[cross], rb[cross]]).astype(np.int64)
        b = np.concatenate([rb[cross], ra[cross]]).astype(np.int64)
        shared = np.concatenate([length[cross], length[cross]])
        keys, inverse = np.unique(a * n + b, return_inverse=True)
        total = np.bincount(inverse.reshape(-1), shared)
        a, b = keys // n, keys % n
        ka, kb = has_kept[a], has_kept[b]
        higher = (kb & ~ka) | ((kb == ka) & ((region_area[b] > region_area[a]) | ((region_area[b] == region_area[a]) & (b < a))))
        small = (region_area[a] < min_area) | ~ka
        ok = small & higher & (np.einsum("ij,ij->i", mean[a], mean[b]) > cos_merge)
        if group is not None:
            region_group = np.zeros(n, np.int64)
            region_group[labels] = group
            ok &= region_group[a] == region_group[b]
        if not ok.any():
            break
        a, b, total = a[ok], b[ok], total[ok]
        order = np.lexsort((b, -total, a))
        a, b = a[order], b[order]
        first = np.r_[True, a[1:] != a[:-1]]
        target = np.arange(n)
        target[a[first]] = b[first]
        for _ in range(64):  # targets are strictly larger, so following them ends
            nxt = target[target]
            if (nxt == target).all():
                break
            target = nxt
        labels, n = _dense(target[labels])
    return labels


def _bisect(idx: NDArray[np.int64], centroid: NDArray, area: NDArray, k: int, out: list[NDArray[np.int64]]) -> None:
    """Split faces ``idx`` into ``k`` parts of equal area by cuts across the longest extent of their centroids."""
    if k <= 1 or len(idx) < 2:
        out.append(idx)
        return
    c = centroid[idx]
    axis = int(np.argmax(np.ptp(c, axis=0)))
    o1, o2 = (a for a in range(3) if a != axis)
    order = np.lexsort((idx, c[:, o2], c[:, o1], c[:, axis]))
    cum = np.cumsum(area[idx][order])
    k1 = k // 2
    target = cum[-1] * k1 / k
    i = min(int(np.searchsorted(cum, target)), len(cum) - 1)
    if i > 0 and target - cum[i - 1] < cum[i] - target:
        i -= 1
    i = min(i, len(cum) - 2)
    _bisect(idx[order[: i + 1]], centroid, area, k1, out)
    _bisect(idx[order[i + 1:]], centroid, area, k - k1, out)


def patch_faces(vertices: ArrayLike, faces: ArrayLike, patch_area_m2: float = PATCH_AREA_M2,
                normal_angle_deg: float = NORMAL_ANGLE_DEG) -> tuple[NDArray[np.int32], int]:
    """Group faces into connected surface patches of about ``patch_area_m2``; returns ((F,) int32 patch, n_patches).

    1. Smooth regions: region growing over edge-adjacent faces (coincident vertices merged),
       seeds in face order; a face joins when its normal is within ``normal_angle_deg`` of
       the seed's. A region below ``SMALL_PATCH_SHARE`` × the patch area joins the larger
       neighbour it shares the longest boundary with among those whose mean normal is less
       than 90° from its own (noise, slivers and bevels merge; faces meeting at 90° or more,
       like a box's sides, never share a patch).
    2. A region of area A is cut into k = max(1, round(A / patch_area_m2)) parts of equal
       area by recursive cuts across the longest extent of its face centroids (a cut falls
       between faces, so a part is off by at most one face per cut).
    3. A part that is not connected keeps its largest connected piece; the other pieces, and
       parts below the small share, join the adjacent part of the same region they share the
       longest boundary with.

    Deterministic: patches are numbered in the order of their first face.
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    patch_area_m2, normal_angle_deg = patch_options(patch_area_m2, normal_angle_deg)
    if len(f) == 0:
        return np.zeros(0, np.int32), 0
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    area = 0.5 * double_area
    valid = double_area > 1e-12 * max(1.0, float(double_area.max()))
    normal = np.divide(cross, double_area[:, None], out=np.zeros_like(cross), where=valid[:, None])
    pairs, length = _face_adjacency(v, f)
    indptr, indices = _csr(pairs, len(f))
    min_area = SMALL_PATCH_SHARE * patch_area_m2

    region, _ = _grow_regions(indptr, indices, normal, valid, math.cos(math.radians(normal_angle_deg)))
    region = _merge_small(region, pairs, length, area, 0.5 * cross, min_area, _COS_MERGE)
    n_regions = int(region.max()) + 1

    centroid = tri.mean(axis=1)
    region_area = np.bincount(region, area, n_regions)
    order = np.argsort(region, kind="stable")
    starts = np.r_[0, np.cumsum(np.bincount(region, minlength=n_regions))]
    part = np.empty(len(f), np.int64)
    n_parts = 0
    for r in range(n_regions):
        idx = order[starts[r]:starts[r + 1]]
        pieces: list[NDArray[np.int64]] = []
        _bisect(idx, centroid, area, max(1, round(region_area[r] / patch_area_m2)), pieces)
        for p in pieces:
            part[p] = n_parts
            n_parts += 1

    # connected pieces of each part: the largest stays, the others join a neighbouring part of the region
    inside = part[pairs[:, 0]] == part[pairs[:, 1]]
    graph = coo_matrix((np.ones(int(inside.sum())), (pairs[inside, 0], pairs[inside, 1])), shape=(len(f), len(f)))
    n_pieces, piece = connected_components(graph, directed=False)
    piece_area = np.bincount(piece, area, n_pieces)
    piece_part = np.zeros(n_pieces, np.int64)
    piece_part[piece] = part
    by_part = np.lexsort((-piece_area, piece_part))
    largest = by_part[np.r_[True, piece_part[by_part][1:] != piece_part[by_part][:-1]]]
    kept = np.zeros(n_pieces, bool)
    kept[largest] = True
    piece = _merge_small(piece, pairs, length, area, 0.5 * cross, min_area, -2.0, group=region, kept=kept[piece])
    return _dense(piece)


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


def _check_las_size(path: Path) -> int:
    """The number of points a LAS/LAZ file declares, after checking what they need: a LAZ file's points may
    unpack to :func:`~sightplan.model.unpack.max_unpacked_bytes` at most, a LAS file's must fit in the file."""
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
    return count


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
            import laspy

            _check_las_header(self.path)
            self.n = _check_las_size(self.path)
            try:
                with laspy.open(str(self.path)) as reader:
                    self.has_colours = {"red", "green", "blue"} <= set(reader.header.point_format.dimension_names)
            except Exception as exc:  # laspy raises LaspyException, ValueError, OSError, ...
                raise ModelError(f"{self.name} cannot be read as LAS/LAZ: {type(exc).__name__}: {exc}") from exc
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


def patch_options(patch_area_m2: float | None, normal_angle_deg: float | None) -> tuple[float, float]:
    """The patch area (m²) and normal angle (°), defaults filled in, or a ModelError naming the bad one."""
    area = PATCH_AREA_M2 if patch_area_m2 is None else float(patch_area_m2)
    angle = NORMAL_ANGLE_DEG if normal_angle_deg is None else float(normal_angle_deg)
    if not (math.isfinite(area) and area > 0):
        raise ModelError(f"patch area must be a positive number of m², got {patch_area_m2!r}")
    if not 0 <= angle <= 180:
        raise ModelError(f"patch normal angle must be within 0–180°, got {normal_angle_deg!r}")
    return area, angle


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


def _shift(scene: Scene, origin_m: ArrayLike) -> Scene:
    origin = np.asarray(origin_m, np.float64).reshape(3)
    if not np.isfinite(origin).all():
        raise ModelError(f"origin_m must be three finite numbers, got {origin_m!r}")
    h = hashlib.sha256(scene.content_hash.encode())
    h.update(origin.tobytes())
    reality = dict(scene.metadata.get("reality") or {})
    reality["origin_m"] = origin.tolist()
    return replace(scene, vertices=scene.vertices - origin, content_hash=h.hexdigest(),
                   metadata={**scene.metadata, "reality": reality})


def load_reality(path: str | Path, patch_area_m2: float = PATCH_AREA_M2, spacing_m: float | None = None, *,
                 normal_angle_deg: float = NORMAL_ANGLE_DEG, method: MeshMethod = "voxel", solid: bool = False,
                 scale: float = 1.0, up: Literal["auto", "y", "z"] = "auto", origin_m: ArrayLike | None = None,
                 cache: bool = True, cache_dir: str | Path | None = None) -> Scene:
    """A reality model (mesh or point cloud) as a Scene of surface patches, all targets.

    .las/.laz and face-less .ply are point clouds, meshed by :func:`points_to_mesh`
    (``spacing_m``, ``method``, ``solid``); .obj/.ply/.stl/.gltf/.glb are meshes (``up`` as in
    :mod:`.mesh`). Elements are named 'patch 00001', ..., class RealityPatch, no discipline.
    ``origin_m`` (after ``scale``) is subtracted from every coordinate. Cached like :func:`load_model`.
    """
    path = Path(path).expanduser()
    if not path.is_file():
        raise ModelError(f"reality model file not found: {path}")
    common = {"elements": "patches", "patch_area_m2": patch_area_m2, "normal_angle_deg": normal_angle_deg, "scale": scale}
    if is_point_cloud(path):
        opts = {**common, "spacing_m": spacing_m, "method": method, "solid": solid}
    elif path.suffix.lower() in REALITY_MESH_EXTENSIONS:
        opts = {**common, "up": up}
    else:
        supported = ", ".join(REALITY_MESH_EXTENSIONS + POINT_CLOUD_EXTENSIONS)
        raise ModelError(f"{path.name}: unsupported reality model format {path.suffix or '(no extension)'!r}; "
                         f"supported: {supported}")
    scene, _ = load_model(path, cache=cache, cache_dir=cache_dir, **opts)
    if "reality" not in scene.metadata:
        scene = replace(scene, metadata={**scene.metadata, "reality": {
            "kind": "mesh", "patch_area_m2": float(patch_area_m2), "normal_angle_deg": float(normal_angle_deg)}})
    return scene if origin_m is None else _shift(scene, origin_m)


# =========================================================================== BIM + reality
def combine(bim: Scene, reality: Scene, reality_role: RealityRole = "occluder") -> Scene:
    """One scene of a BIM model and a reality model in the same frame.

    Elements: the BIM's first (their indices are unchanged), then the reality's. With
    ``reality_role="occluder"`` the reality elements are occluder-only (``is_target``
    False): they hide BIM elements behind them but do not count in ``z``; ``"target"``
    keeps them as they are. The BIM's metadata, source and date are kept; metadata
    ``"reality"`` records the reality source, role and element range. Reality elements have
    no schedule dates, so they exist at every date of :meth:`Scene.at` (default ``unscheduled``).
    """
    if reality_role not in ("occluder", "target"):
        raise ModelError(f"reality role must be 'occluder' or 'target', got {reality_role!r}")
    if reality.date is not None:
        raise ModelError("the reality scene has a date of its own; combine the undated reality model")
    _check_same_frame(bim, reality)
    z_bim = bim.n_elements
    rel = reality.elements
    is_target = np.zeros(len(rel), bool) if reality_role == "occluder" else rel.is_target
    elements = ElementTable(
        *(np.concatenate([getattr(bim.elements, c), getattr(rel, c)])
          for c in ("global_id", "name", "ifc_class", "discipline", "storey")),
        is_target=np.concatenate([bim.elements.is_target, is_target]),
        start=np.concatenate([bim.elements.start, rel.start]).astype("datetime64[s]"),
        finish=np.concatenate([bim.elements.finish, rel.finish]).astype("datetime64[s]"),
    )
    vertices = np.concatenate([bim.vertices, reality.vertices])
    faces = np.concatenate([bim.faces, reality.faces + len(bim.vertices)])
    face_element = np.concatenate([bim.face_element, reality.face_element + z_bim])
    h = hashlib.sha256(b"combine\0")
    for part in (bim.content_hash, reality.content_hash, reality_role):
        h.update(part.encode() + b"\0")
    record = {"source": reality.source, "content_hash": reality.content_hash, "role": reality_role,
              "elements": [z_bim, z_bim + len(rel)], "metadata": json.loads(json.dumps(reality.metadata, default=str))}
    scene = Scene.from_arrays(vertices, faces, face_element, elements, bim.source, h.hexdigest(),
                              {**bim.metadata, "reality": record})
    return replace(scene, present=np.concatenate([bim.present, reality.present]), date=bim.date)


def _check_same_frame(bim: Scene, reality: Scene) -> None:
    """A ModelError when the two scenes' boxes lie over 1 km and ten times their size apart (different frames)."""
    if len(bim.faces) == 0 or len(reality.faces) == 0:
        return
    a, b = bim.bounds(), reality.bounds()
    gap = float(np.linalg.norm(np.maximum(0.0, np.maximum(a[0] - b[1], b[0] - a[1]))))
    size = max(float(np.linalg.norm(a[1] - a[0])), float(np.linalg.norm(b[1] - b[0])))
    if gap > max(1000.0, 10 * size):
        raise ModelError(f"the reality model lies {gap:.0f} m from the BIM model: are they in the same frame? "
                         "(load_reality's origin_m moves a georeferenced reality into the model's frame)")
