"""Point clouds as OGC 3D Tiles 1.1 for the web viewer: an octree of point tiles with level of detail.

:func:`write_point_tiles` turns a reality capture (a LAS/LAZ/PLY file, or arrays of positions
and colours) into ``tileset.json`` and ``tiles/*.glb`` in a folder, so the browser draws a
100-million-point cloud by loading only the tiles the camera needs (``static/pointcloud.js``).

The tree
    An octree over the cloud's bounding cube. Refinement is additive (REFINE "ADD"): a tile
    adds its points to its ancestors', and every input point is written exactly once. The
    points of level ℓ are chosen so that levels 0..ℓ together hold exactly one point of each
    occupied cell of a ``grid``³ grid per level-ℓ node (cells of edge ``edge / 2^(ℓ + log2
    grid)``): each cell's representative is the point of smallest pseudo-random hash, so a
    level is a spatially uniform, unbiased subsample, and the representative of a cell is
    also the representative of every smaller cell holding it. A node keeps at most
    ``max_points_per_tile`` points: the excess (largest hashes) moves one level down. A node
    whose whole subtree fits in the budget is a leaf holding all of it.

Tiles
    Binary glTF 2.0 with one POINTS primitive: POSITION as float32 relative to the tile's
    centre, the centre as the node's translation (glTF is Y up: the tileset's Z-up model
    coordinates (x, y, z) are (x, z, −y) in a tile, as 3D Tiles prescribes), and, when the
    cloud has colours, COLOR_0 as normalized unsigned bytes (padded to 4 bytes per point).
    COLOR_0 holds the capture's 8-bit colours exactly as stored (sRGB-encoded, as scanners
    write them); the viewer decodes them. Tileset bounding volumes are axis-aligned boxes
    holding the tile's points and all its descendants'; geometricError is the cell edge of
    the node's level (the spacing of the points drawn when the node is not refined), 0 for
    leaves, so it halves per level.

Scaling
    Points are read in chunks and never handled one by one in Python: Morton codes (21 bits
    per axis), numpy sorts and compiled kernels. A cloud above ``bucket_points`` points is
    counted on a 128³ grid, split into octree nodes of at most that many points ("buckets"),
    written to temporary files beside the output and built one bucket at a time, so memory
    stays near ``bucket_points`` × about 120 bytes whatever the cloud's size (some 500 MB with
    the default 4 million); only the few points of the levels above the buckets are kept
    across them.

Errors: an unreadable file, a cloud without points, non-finite coordinates or bad options raise
:class:`~sightplan.errors.ModelError`.
"""

from __future__ import annotations

import json
import math
import shutil
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from ..geometry.glb import primitive_glb
from ..model.pointcloud import PointChunkReader, PointCloud
from ..version import __version__

#: Morton code bits per axis: 63-bit codes, the cube cut into 2^21 steps per axis.
DEPTH = 21
#: Default subsampling grid per node edge: levels 0..ℓ hold one point per occupied cell of grid³ per level-ℓ node.
GRID = 128
MAX_POINTS_PER_TILE = 100_000
CHUNK_POINTS = 2_000_000
#: Clouds above this many points are built bucket by bucket through temporary files.
BUCKET_POINTS = 4_000_000
#: Level of the counting grid that buckets are chosen on (at most log2 of the grid).
COUNT_LEVEL = 7
TILES_DIR = "tiles"
TILESET_NAME = "tileset.json"
_TMP_DIR = ".pointtiles-tmp"
_BOX_PAD = 1e-6  # of the cube edge, so float32 offsets stay inside their tile's box (twice that at the root)
_RECORD = np.dtype([("p", "<f8", (3,)), ("c", "u1", (3,))])
_SORTED_RECORD = np.dtype([("p", "<f8", (3,)), ("c", "u1", (3,)), ("l", "i1")])


@dataclass(frozen=True)
class PointTilesSummary:
    """What :func:`write_point_tiles` wrote."""

    tileset: str  #: path of tileset.json
    n_points: int
    n_tiles: int  #: tiles in tileset.json (tiles without content included)
    n_files: int  #: .glb files written
    depth: int  #: deepest tile level (the root is 0)
    max_tile_points: int  #: most points in one tile
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]]  #: (min, max) of the points, model frame
    colours: bool
    n_buckets: int  #: 1 when the cloud was built in memory in one piece
    elapsed_s: float

    def to_dict(self) -> dict:
        return asdict(self)


# =========================================================================== sources
class _ArraySource:
    """Arrays in memory, handed out in chunks like a file."""

    def __init__(self, positions: ArrayLike, colours: ArrayLike | None, chunk_points: int) -> None:
        pts = np.asarray(positions)
        if pts.ndim != 2 or pts.shape[1] != 3 or not (np.issubdtype(pts.dtype, np.number) and pts.dtype.kind != "c"):
            raise ModelError(f"point positions must be an (n, 3) array of numbers, got shape {pts.shape} of {pts.dtype}")
        self.points = pts
        self.colours = None
        if colours is not None:
            rgb = np.asarray(colours)
            if rgb.shape != pts.shape or rgb.dtype.kind not in "ui":
                raise ModelError(f"point colours must be an (n, 3) array of integers 0–255 like the positions {pts.shape}, "
                                 f"got shape {rgb.shape} of {rgb.dtype}")
            self.colours = rgb
        self.name = "the point cloud"
        self.n = len(pts)
        self.has_colours = self.colours is not None
        self.chunk_points = chunk_points

    def chunks(self) -> Iterator[tuple[NDArray, NDArray | None]]:
        for i in range(0, self.n, self.chunk_points):
            j = i + self.chunk_points
            yield (np.asarray(self.points[i:j], np.float64),
                   None if self.colours is None else self.colours[i:j])


def _open_source(source, colours: ArrayLike | None, chunk_points: int):
    if isinstance(source, PointCloud):  # read_point_cloud's (points, normals): the normals are not drawn
        source = source.points
    if isinstance(source, (str, Path)):
        if colours is not None:
            raise ModelError("colours are read from the point cloud file; give colours only with position arrays")
        return PointChunkReader(source, chunk_points)
    if isinstance(source, tuple) and len(source) == 2:
        if colours is not None:
            raise ModelError("colours given twice: as the pair's second array and as colours=")
        source, colours = source
    return _ArraySource(source, colours, chunk_points)


@dataclass
class _Cloud:
    """The source with what a first pass over it found; chunks come shifted and with 8-bit colours."""

    source: object
    origin: NDArray[np.float64]
    n: int
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    colour_shift: bool  # True: 16-bit colour channels, scaled to 8 bits

    def chunks(self) -> Iterator[tuple[NDArray[np.float64], NDArray[np.uint8] | None]]:
        for pts, rgb in self.source.chunks():
            if self.origin.any():
                pts = pts - self.origin
            yield pts, _eight_bit(rgb, self.colour_shift)


def _eight_bit(rgb: NDArray | None, shift: bool) -> NDArray[np.uint8] | None:
    if rgb is None:
        return None
    if shift:
        return ((rgb.astype(np.uint32) + 128) // 257).astype(np.uint8)
    return rgb.astype(np.uint8, copy=False)


def _scan(source, origin: NDArray[np.float64]) -> _Cloud:
    """Bounds, point count and colour depth in one pass; a ModelError for no points or non-finite ones."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    n = bad = 0
    cmax = 0
    for pts, rgb in source.chunks():
        if len(pts) == 0:
            continue
        n += len(pts)
        finite = np.isfinite(pts).all(axis=1)
        if not finite.all():
            bad += int((~finite).sum())
            pts = pts[finite]
            if len(pts) == 0:
                continue
        pts = pts - origin
        lo = np.minimum(lo, pts.min(axis=0))
        hi = np.maximum(hi, pts.max(axis=0))
        if rgb is not None and len(rgb):
            if rgb.dtype.kind == "i" and rgb.min() < 0:
                raise ModelError(f"{source.name}: colours must not be negative")
            cmax = max(cmax, int(rgb.max()))
    if n == 0:
        raise ModelError(f"{source.name} has no points")
    if bad:
        raise ModelError(f"{source.name}: {bad} of {n} points have non-finite coordinates (NaN or inf)")
    if cmax > 65535:
        raise ModelError(f"{source.name}: colour values reach {cmax}; 8- or 16-bit channels are expected")
    return _Cloud(source, origin, n, lo, hi, cmax > 255)


# =========================================================================== compiled kernels
@nb.njit(cache=True)
def _morton(pos, lo, scale, depth):  # pragma: no cover - compiled
    """Morton codes (x, y, z bits interleaved, x highest) of points quantised to 2^depth steps per axis."""
    n = pos.shape[0]
    out = np.empty(n, np.int64)
    top = (1 << depth) - 1
    for i in range(n):
        code = 0
        for a in range(3):
            q = int(math.floor((pos[i, a] - lo[a]) * scale))
            q = min(max(q, 0), top)
            v = np.uint64(q)
            v = (v | (v << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
            v = (v | (v << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
            v = (v | (v << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
            v = (v | (v << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
            v = (v | (v << np.uint64(2))) & np.uint64(0x1249249249249249)
            code |= np.int64(v) << (2 - a)
        out[i] = code
    return out


@nb.njit(cache=True)
def _mix(x):  # pragma: no cover - compiled
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@nb.njit(cache=True)
def _hash_points(bits):  # pragma: no cover - compiled
    """A pseudo-random 64-bit hash of each point's coordinates (their float64 bits): the same point, the same hash."""
    n = bits.shape[0]
    out = np.empty(n, np.uint64)
    for i in range(n):
        x = _mix(bits[i, 0] ^ np.uint64(0x9E3779B97F4A7C15))
        x = _mix(x ^ bits[i, 1])
        out[i] = _mix(x ^ bits[i, 2])
    return out


@nb.njit(cache=True)
def _common_digits(a, b, depth):  # pragma: no cover - compiled
    """How many leading octal digits (octree levels) two Morton codes share."""
    x = a ^ b
    c = 0
    while c < depth and (x >> (3 * (depth - 1 - c))) == 0:
        c += 1
    return c


@nb.njit(cache=True)
def _first_rep_level(code, h, depth):  # pragma: no cover - compiled
    """For points sorted by Morton code: the coarsest level k at which each point is its level-k cell's
    representative (smallest hash, ties to the first), depth + 1 when never (a duplicate in its finest cell).

    A point is its cell's representative once the cell no longer holds the nearest point of smaller hash
    on either side in code order (all nearest smaller values, one stack pass).
    """
    n = code.shape[0]
    shared = np.full(n, -1, np.int8)  # most levels shared with a smaller-hash neighbour
    stack = np.empty(n, np.int64)
    top = 0
    for i in range(n):
        while top > 0 and h[stack[top - 1]] > h[i]:
            j = stack[top - 1]
            top -= 1
            c = _common_digits(code[j], code[i], depth)
            if c > shared[j]:
                shared[j] = c
        if top > 0:
            c = _common_digits(code[stack[top - 1]], code[i], depth)
            if c > shared[i]:
                shared[i] = c
        stack[top] = i
        top += 1
    return (shared + 1).astype(np.int8)


def _hash(pos: NDArray[np.float64]) -> NDArray[np.uint64]:
    return _hash_points(np.ascontiguousarray(pos, np.float64).view(np.uint64))


# =========================================================================== the octree
@dataclass
class _Frame:
    """The octree's cube and the options every step shares."""

    lo: NDArray[np.float64]
    edge: float
    g: int  # log2 of the grid
    budget: int

    @property
    def scale(self) -> float:
        return float(2**DEPTH / self.edge)

    @property
    def max_level(self) -> int:
        return DEPTH - self.g

    def codes(self, pos: NDArray[np.float64]) -> NDArray[np.int64]:
        return _morton(np.ascontiguousarray(pos, np.float64), self.lo, self.scale, DEPTH)

    def error(self, level: int) -> float:
        """The spacing of the points drawn when a level-``level`` node is not refined: its cells' edge."""
        return self.edge / 2 ** (level + self.g)

    def levels(self, code: NDArray[np.int64], h: NDArray[np.uint64]) -> NDArray[np.int8]:
        """Each sorted point's level before budgets: levels 0..ℓ hold one point per occupied cell of level ℓ + g."""
        k = _first_rep_level(code, h, DEPTH).astype(np.int16)
        return np.clip(k - self.g, 0, self.max_level).astype(np.int8)


def _rank_in_groups(group: NDArray, h: NDArray[np.uint64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(order, rank): positions sorted by (group, hash), and each one's rank by hash within its group."""
    order = np.lexsort((h, group))
    g = group[order]
    first = np.r_[True, g[1:] != g[:-1]]
    start = np.maximum.accumulate(np.where(first, np.arange(len(g)), 0))
    return order, np.arange(len(g)) - start


def _cap(level: NDArray[np.int8], h: NDArray[np.uint64], key_of, ell: int, budget: int) -> None:
    """Move level-``ell`` points beyond ``budget`` per node (largest hashes first) to level ``ell`` + 1, in place."""
    idx = np.flatnonzero(level == ell)
    if len(idx) <= budget:
        return
    keys = key_of(idx)
    order, rank = _rank_in_groups(keys, h[idx])
    level[idx[order[rank >= budget]]] = ell + 1


def _rows(a: NDArray, index: NDArray[np.int64]) -> NDArray:
    """The rows ``index`` of a 2-D array (np.take on the first axis: faster than fancy indexing for row gathers)."""
    return np.take(a, index, axis=0)


def _runs(key: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Starts and lengths of the runs of equal values in a sorted array."""
    starts = np.r_[0, np.flatnonzero(key[1:] != key[:-1]) + 1] if len(key) else np.zeros(0, np.int64)
    return starts, np.diff(np.r_[starts, len(key)])


@dataclass
class _Node:
    level: int
    key: int
    leaf: bool
    box: NDArray[np.float64]  # (2, 3) min, max of the subtree's points
    start: int = 0  # content: [start, start + count) of the level-sorted arrays
    count: int = 0


def _build_bucket(frame: _Frame, pos: NDArray, rgb: NDArray | None, code: NDArray[np.int64], h: NDArray[np.uint64],
                  level: NDArray[np.int8], top: int, writer: _TileWriter) -> tuple[dict, NDArray] | None:
    """Tiles of one bucket (a level-``top`` node; points sorted by code, all of level ≥ ``top``): its tile JSON
    and the (min, max) corners of its points, or None without points."""
    n = len(code)
    if n == 0:
        return None
    budget = frame.budget
    level = level.copy()
    act = np.arange(n)
    nodes: list[_Node] = []
    for ell in range(top, frame.max_level + 1):
        if len(act) == 0:
            break
        shift = 3 * (DEPTH - ell)
        key = code[act] >> shift
        starts, sizes = _runs(key)
        gid = np.repeat(np.arange(len(starts)), sizes)
        leaf = (sizes <= budget) | (ell == frame.max_level)
        p = _rows(pos, act)
        box = np.stack([np.stack([np.minimum.reduceat(p[:, a], starts) for a in range(3)], axis=1),
                        np.stack([np.maximum.reduceat(p[:, a], starts) for a in range(3)], axis=1)], axis=1)
        del p
        leaf_pt = leaf[gid]
        level[act[leaf_pt]] = ell
        own = ~leaf_pt & (level[act] == ell)
        own_count = np.bincount(gid[own], minlength=len(starts))
        if (own_count > budget).any():
            idx = np.flatnonzero(own & (own_count > budget)[gid])
            order, rank = _rank_in_groups(gid[idx], h[act[idx]])
            demote = idx[order[rank >= budget]]
            level[act[demote]] = ell + 1
            own[demote] = False
        nodes.extend(_Node(ell, int(k), bool(lf), b) for k, lf, b in zip(key[starts], leaf, box))
        act = act[~leaf_pt & ~own]
    # content: points sorted by (level, code) are contiguous per node
    by_level = np.argsort(level, kind="stable")
    lev_sorted = level[by_level]
    spos = _rows(pos, by_level)
    srgb = None if rgb is None else _rows(rgb, by_level)
    level_start = np.searchsorted(lev_sorted, np.arange(frame.max_level + 2))
    key_cache: dict[int, NDArray[np.int64]] = {}
    for node in nodes:
        lo_i, hi_i = level_start[node.level], level_start[node.level + 1]
        if node.level not in key_cache:
            key_cache[node.level] = code[by_level[lo_i:hi_i]] >> 3 * (DEPTH - node.level)
        keys = key_cache[node.level]
        a = int(np.searchsorted(keys, node.key, "left"))
        b = int(np.searchsorted(keys, node.key, "right"))
        node.start, node.count = lo_i + a, b - a
    del key_cache, by_level
    tiles: dict[tuple[int, int], dict] = {}
    root = None
    for node in nodes:
        tile = writer.tile(node, spos, srgb)
        tiles[(node.level, node.key)] = tile
        if node.level == top:
            root = tile, node.box
        else:
            tiles[(node.level - 1, node.key >> 3)]["children"].append(tile)
    for tile in tiles.values():
        if not tile["children"]:
            del tile["children"]
    return root


class _TileWriter:
    """Writes tile contents (.glb) and makes their tileset.json entries; counts what it wrote."""

    def __init__(self, out_dir: Path, frame: _Frame) -> None:
        self.dir = out_dir / TILES_DIR
        self.dir.mkdir(parents=True, exist_ok=True)
        self.frame = frame
        self.pad = _BOX_PAD * frame.edge
        self.n_tiles = self.n_files = self.max_points = self.depth = self.n_points = 0

    def box_json(self, box: NDArray[np.float64], level: int) -> list[float]:
        """A 3D Tiles box around the (min, max) corners, padded a little less on each level so boxes nest strictly."""
        centre = (box[0] + box[1]) / 2
        half = (box[1] - box[0]) / 2 + self.pad * (1 + 0.5**level)
        return [*map(float, centre), float(half[0]), 0.0, 0.0, 0.0, float(half[1]), 0.0, 0.0, 0.0, float(half[2])]

    def tile(self, node: _Node, pos: NDArray, rgb: NDArray | None) -> dict:
        """The tile JSON of ``node`` (children to be added), its content split into a chain of tiles with the
        same box when it is over the budget (only a node at the deepest level, of coincident points, can be)."""
        budget = self.frame.budget
        parts = max(1, math.ceil(node.count / budget))
        error = 0.0 if node.leaf else self.frame.error(node.level)
        if parts > 1:  # a leaf at the deepest level: errors fall to 0 along the chain
            error = self.frame.error(node.level)
        first = None
        parent = None
        for j in range(parts):
            tile: dict = {"boundingVolume": {"box": self.box_json(node.box, node.level)},
                          "geometricError": error * (parts - 1 - j) / parts if parts > 1 else error, "children": []}
            a = node.start + j * budget
            b = min(node.start + node.count, a + budget)
            if b > a:
                name = f"L{node.level}-{node.key:x}" + (f"-{j}" if parts > 1 else "") + ".glb"
                self.write(name, pos[a:b], None if rgb is None else rgb[a:b], node.box)
                tile["content"] = {"uri": f"{TILES_DIR}/{name}"}
            self.n_tiles += 1
            self.depth = max(self.depth, node.level)
            if parent is None:
                first = tile
            else:
                parent["children"].append(tile)
                if j == parts - 1:
                    del tile["children"]
            parent = tile
        return first

    def write(self, name: str, pos: NDArray[np.float64], rgb: NDArray[np.uint8] | None, box: NDArray[np.float64]) -> None:
        centre = (box[0] + box[1]) / 2
        (self.dir / name).write_bytes(primitive_glb(pos, centre, colours=rgb))
        self.n_files += 1
        self.n_points += len(pos)
        self.max_points = max(self.max_points, len(pos))


# =========================================================================== buckets
def _choose_buckets(counts: NDArray[np.int64], count_level: int, bucket_points: int
                    ) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """(buckets, split nodes) as (level, key) in Morton order: nodes of at most ``bucket_points`` points (or
    cells of the counting grid), and the nodes above them."""
    pyramid = [counts]
    for _ in range(count_level):
        pyramid.append(pyramid[-1].reshape(-1, 8).sum(axis=1))
    pyramid.reverse()
    buckets: list[tuple[int, int]] = []
    split: list[tuple[int, int]] = []

    def visit(level: int, key: int) -> None:
        c = pyramid[level][key]
        if c == 0:
            return
        if c <= bucket_points or level == count_level:
            buckets.append((level, key))
            return
        split.append((level, key))
        for child in range(8):
            visit(level + 1, key * 8 + child)

    visit(0, 0)
    return buckets, split


def _read_records(path: Path, dtype: np.dtype) -> NDArray:
    return np.fromfile(path, dtype) if path.exists() else np.zeros(0, dtype)


def write_point_tiles(source: str | Path | ArrayLike | tuple, out_dir: str | Path, *, colours: ArrayLike | None = None,
                      origin_m: ArrayLike | None = None, max_points_per_tile: int = MAX_POINTS_PER_TILE, grid: int = GRID,
                      chunk_points: int = CHUNK_POINTS, bucket_points: int = BUCKET_POINTS) -> PointTilesSummary:
    """Write a point cloud as a 3D Tiles 1.1 tileset: ``out_dir/tileset.json`` and ``out_dir/tiles/*.glb``.

    ``source``: a .las/.laz/.ply file (read in chunks of ``chunk_points``; colours from its red,
    green, blue), an (n, 3) array of positions with optional (n, 3) 8-bit ``colours``, a
    (positions, colours) pair, or a :class:`~sightplan.model.pointcloud.PointCloud`. Coordinates
    are metres in the model's frame; ``origin_m`` is subtracted from each (a georeferenced cloud
    moved into the model's frame). 16-bit colour channels (LAS) are scaled to 8 bits; a cloud
    whose colour values all stay within 0–255 is taken as 8-bit.

    ``max_points_per_tile``: no tile holds more. ``grid``: a power of two, the subsampling grid
    per node edge (a flat surface gives about ``grid``² points per node). ``bucket_points``:
    above this the cloud is built bucket by bucket through temporary files in ``out_dir``
    (bounded memory). Existing ``tiles/*.glb`` in ``out_dir`` are replaced; tileset.json is
    written last, so a reader never finds it before its tiles.
    """
    t0 = time.perf_counter()
    budget, chunk_points, bucket_points = int(max_points_per_tile), int(chunk_points), int(bucket_points)
    if budget < 1 or chunk_points < 1 or bucket_points < 1:
        raise ModelError("max_points_per_tile, chunk_points and bucket_points must be positive")
    g = int(round(math.log2(grid))) if grid > 0 else -1
    if not 1 <= g <= 12 or 2**g != grid:
        raise ModelError(f"grid must be a power of two from 2 to 4096, got {grid!r}")
    origin = np.zeros(3) if origin_m is None else np.asarray(origin_m, np.float64).reshape(3)
    if not np.isfinite(origin).all():
        raise ModelError(f"origin_m must be three finite numbers, got {origin_m!r}")
    cloud = _scan(_open_source(source, colours, chunk_points), origin)
    extent = float((cloud.hi - cloud.lo).max())
    frame = _Frame(lo=cloud.lo.copy(), edge=extent if extent > 0 else 1.0, g=g, budget=budget)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tiles_dir = out / TILES_DIR
    if tiles_dir.is_dir():
        for old in tiles_dir.glob("*.glb"):
            old.unlink()
    writer = _TileWriter(out, frame)
    has_colours = cloud.source.has_colours
    if cloud.n <= bucket_points:
        root, n_buckets = _build_in_memory(cloud, frame, writer), 1
    else:
        tmp = out / _TMP_DIR
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir()
        try:
            root, n_buckets = _build_out_of_core(cloud, frame, writer, tmp, bucket_points)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    if writer.n_points != cloud.n:  # every point is written once: anything else is a bug
        raise AssertionError(f"wrote {writer.n_points} of {cloud.n} points")
    root["refine"] = "ADD"
    tileset = {"asset": {"version": "1.1", "generator": f"sightplan {__version__}",
                         "extras": {"sightplan": {"points": cloud.n, "colours": "sRGB 8-bit" if has_colours else None,
                                                  "origin_m": origin.tolist(), "up": "Z"}}},
               "geometricError": frame.edge, "root": root}
    path = out / TILESET_NAME
    tmp_path = path.with_suffix(".json.part")
    tmp_path.write_text(json.dumps(tileset, separators=(",", ":")))
    tmp_path.replace(path)
    return PointTilesSummary(
        tileset=str(path), n_points=cloud.n, n_tiles=writer.n_tiles, n_files=writer.n_files, depth=writer.depth,
        max_tile_points=writer.max_points, bounds=(tuple(map(float, cloud.lo)), tuple(map(float, cloud.hi))),
        colours=bool(has_colours), n_buckets=n_buckets, elapsed_s=time.perf_counter() - t0)


def _sorted_bucket(frame: _Frame, pos: NDArray, rgb: NDArray | None):
    """A bucket's points sorted by Morton code, with codes and hashes."""
    code = frame.codes(pos)
    order = np.argsort(code, kind="stable")
    code = code[order]
    pos = _rows(pos, order)
    rgb = None if rgb is None else _rows(rgb, order)
    return pos, rgb, code, _hash(pos)


def _build_in_memory(cloud: _Cloud, frame: _Frame, writer: _TileWriter) -> dict:
    parts = list(cloud.chunks())
    pos = parts[0][0] if len(parts) == 1 else np.concatenate([p for p, _ in parts])
    rgb = None
    if parts[0][1] is not None:
        rgb = parts[0][1] if len(parts) == 1 else np.concatenate([c for _, c in parts])
    del parts
    pos, rgb, code, h = _sorted_bucket(frame, pos, rgb)
    return _build_bucket(frame, pos, rgb, code, h, frame.levels(code, h), 0, writer)[0]


def _build_out_of_core(cloud: _Cloud, frame: _Frame, writer: _TileWriter, tmp: Path,
                       bucket_points: int) -> tuple[dict, int]:
    """Count, distribute to bucket files, level each bucket (setting aside the points of the levels above it),
    cap the upper nodes, then build each bucket and the upper nodes."""
    count_level = min(COUNT_LEVEL, frame.g)
    shift = 3 * (DEPTH - count_level)
    counts = np.zeros(8**count_level, np.int64)
    for pos, _ in cloud.chunks():
        counts += np.bincount(frame.codes(pos) >> shift, minlength=len(counts))
    buckets, split = _choose_buckets(counts, count_level, bucket_points)
    del counts
    bucket_of_cell = np.full(8**count_level, -1, np.int32)
    for i, (lev, key) in enumerate(buckets):
        s = 3 * (count_level - lev)
        bucket_of_cell[key << s:(key + 1) << s] = i
    files = [tmp / f"b{i}.bin" for i in range(len(buckets))]
    for pos, rgb in cloud.chunks():
        b = bucket_of_cell[frame.codes(pos) >> shift]
        order = np.argsort(b, kind="stable")
        rec = np.empty(len(pos), _RECORD)
        rec["p"] = pos[order]
        if rgb is not None:
            rec["c"] = rgb[order]
        else:
            rec["c"] = 0
        starts, sizes = _runs(b[order])
        for s, m in zip(starts, sizes):
            with open(files[b[order[s]]], "ab") as fh:
                rec[s:s + m].tofile(fh)

    # pass 1: per bucket, levels; points above the bucket's level set aside (at most the budget per level)
    upper: list[tuple] = []
    for i, (top, _key) in enumerate(buckets):
        rec = _read_records(files[i], _RECORD)
        pos, rgb, code, h = _sorted_bucket(frame, np.ascontiguousarray(rec["p"]),
                                           np.ascontiguousarray(rec["c"]) if cloud.source.has_colours else None)
        del rec
        level = frame.levels(code, h)
        for ell in range(top):  # every level-ell point of the bucket lies in one node above it
            _cap(level, h, lambda idx: np.zeros(len(idx), np.int64), ell, frame.budget)
        up = level < top
        if up.any():
            upper.append((pos[up], None if rgb is None else rgb[up], code[up], h[up], level[up]))
        keep = ~up
        out = np.empty(int(keep.sum()), _SORTED_RECORD)
        out["p"], out["l"] = pos[keep], level[keep]
        out["c"] = 0 if rgb is None else rgb[keep]
        out.tofile(files[i])
    # the upper nodes: at most the budget each, the excess one level down (into a bucket below the deepest)
    if upper:
        u_pos, u_code, u_h, u_level = (np.concatenate([u[k] for u in upper]) for k in (0, 2, 3, 4))
        u_rgb = None if upper[0][1] is None else np.concatenate([u[1] for u in upper])
    else:
        u_pos, u_rgb = np.zeros((0, 3)), None
        u_code, u_h, u_level = np.zeros(0, np.int64), np.zeros(0, np.uint64), np.zeros(0, np.int8)
    del upper
    for ell in range(max((lev for lev, _ in buckets), default=0)):
        _cap(u_level, u_h, lambda idx, e=ell: u_code[idx] >> 3 * (DEPTH - e), ell, frame.budget)
    u_bucket = bucket_of_cell[u_code >> shift].astype(np.int64)  # the buckets partition the occupied cells
    del bucket_of_cell
    moved = u_level >= np.array([lev for lev, _ in buckets], np.int64)[u_bucket] if len(u_code) else np.zeros(0, bool)

    # pass 2: each bucket's tiles, with the points the upper nodes moved down into it
    children: dict[tuple[int, int], tuple[dict, NDArray]] = {}  # built nodes not yet under a parent: tile, box
    for i, (top, key) in enumerate(buckets):
        rec = _read_records(files[i], _SORTED_RECORD)
        files[i].unlink(missing_ok=True)
        pos = np.ascontiguousarray(rec["p"])
        rgb = np.ascontiguousarray(rec["c"]) if cloud.source.has_colours else None
        level = np.ascontiguousarray(rec["l"])
        del rec
        code = frame.codes(pos)
        h = _hash(pos)
        extra = np.flatnonzero(moved & (u_bucket == i))
        if len(extra):
            pos = np.concatenate([pos, u_pos[extra]])
            rgb = None if rgb is None else np.concatenate([rgb, u_rgb[extra]])
            code = np.concatenate([code, u_code[extra]])
            h = np.concatenate([h, u_h[extra]])
            level = np.concatenate([level, np.full(len(extra), top, np.int8)])
            order = np.argsort(code, kind="stable")
            pos, code, h, level = pos[order], code[order], h[order], level[order]
            rgb = None if rgb is None else rgb[order]
        built = _build_bucket(frame, pos, rgb, code, h, level, top, writer)
        if built is not None:
            children[(top, key)] = built
    del pos, rgb, code, h, level

    # the upper nodes' tiles, from the deepest up: boxes enclose their points and their children's boxes
    stay = ~moved
    u_pos, u_code, u_level = u_pos[stay], u_code[stay], u_level[stay]
    u_rgb = None if u_rgb is None else u_rgb[stay]
    order = np.lexsort((u_code, u_level))
    u_pos, u_code, u_level = u_pos[order], u_code[order], u_level[order]
    u_rgb = None if u_rgb is None else u_rgb[order]
    for lev, key in sorted(split, key=lambda s: -s[0]):
        a, b = (int(np.searchsorted(u_level, lev, side)) for side in ("left", "right"))
        keys = u_code[a:b] >> 3 * (DEPTH - lev)
        s, e = a + int(np.searchsorted(keys, key, "left")), a + int(np.searchsorted(keys, key, "right"))
        kids = [children.pop((lev + 1, key * 8 + c)) for c in range(8) if (lev + 1, key * 8 + c) in children]
        boxes = [box for _, box in kids]
        if e > s:
            boxes.append(np.stack([u_pos[s:e].min(axis=0), u_pos[s:e].max(axis=0)]))
        if not boxes:
            continue
        box = np.stack([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])
        node = _Node(lev, key, False, box, s, e - s)
        tile = writer.tile(node, u_pos, u_rgb)
        if kids:
            tile["children"] = [t for t, _ in kids]
        else:
            del tile["children"]
        children[(lev, key)] = tile, box
    return children[(0, 0)][0], len(buckets)
