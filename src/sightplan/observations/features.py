"""Simulated features for the stability of reconstruction (METRICS.md §5.1).

Corner features: a vertex of an element's mesh where two faces of that element meet
at more than 30°; vertices are merged on a 1 mm grid across elements, so a corner
shared by touching elements is one feature. Its normal is the angle-weighted mean of
the normals of the incident faces of the elements for which it is a corner (a corner
whose normals cancel, such as the rim of a zero-thickness sheet, is dropped).
Surface features: ``round(area × density)`` points drawn over all faces with
probability proportional to area, uniformly within each face, from a seeded generator.
Every feature is offset 1 mm along its normal and belongs to that side only.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numba as nb
import numpy as np
from numpy.typing import NDArray

from ..errors import ObservationsError
from ..model.cache import atomic_write, cache_root
from ..model.scene import Scene

CORNER_ANGLE_DEG = 30.0
MERGE_GRID_M = 0.001
OFFSET_M = 0.001
KIND_CORNER = 0
KIND_SURFACE = 1
#: Bump when the sampling changes, so cached feature sets are not reused.
SAMPLING_VERSION = 2


@dataclass(frozen=True)
class FeatureSet:
    """points: (N, 3) float64 metres (already offset 1 mm); normals: (N, 3) unit;
    kind: (N,) int8 (0 corner, 1 surface); element: (N,) int32 owning element (−1 for a
    corner shared by several elements); params: how they were made."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    kind: NDArray[np.int8]
    element: NDArray[np.int32]
    params: dict

    def __len__(self) -> int:
        return len(self.points)

    @property
    def key(self) -> str:
        h = hashlib.sha256(self.points.tobytes())
        h.update(self.normals.tobytes())
        return h.hexdigest()[:32]

    def save(self, path: str | Path | BinaryIO, compressed: bool = True) -> None:
        """Write the set as .npz (``compressed=False``: larger, but read back at disk speed)."""
        (np.savez_compressed if compressed else np.savez)(
            path, header=np.array(json.dumps({"format": "sightplan-features", "version": 1, "params": self.params})),
            points=self.points, normals=self.normals, kind=self.kind, element=self.element)

    @classmethod
    def load(cls, path: str | Path) -> FeatureSet:
        try:
            with np.load(path, allow_pickle=False) as z:
                header = json.loads(str(z["header"]))
                fs = cls(z["points"].astype(np.float64), z["normals"].astype(np.float64), z["kind"].astype(np.int8),
                         z["element"].astype(np.int32), header.get("params", {}))
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            raise ObservationsError(f"{path} is not a sightplan feature file: {exc}") from None
        if fs.points.ndim != 2 or fs.points.shape[1:] != (3,) or fs.normals.shape != fs.points.shape:
            raise ObservationsError(f"{path}: points and normals must both be (N, 3)")
        return fs


@nb.njit(nogil=True, cache=True)
def _corner_groups(order, group_start, normals, cos_limit):
    """For each group (sorted incidences of one merged vertex in one element): any pair of face normals apart by > limit."""
    n_groups = len(group_start) - 1
    out = np.zeros(n_groups, np.bool_)
    for g in range(n_groups):
        a, b = group_start[g], group_start[g + 1]
        found = False
        for i in range(a, b):
            fi = order[i]
            for j in range(i + 1, b):
                fj = order[j]
                c = normals[fi, 0] * normals[fj, 0] + normals[fi, 1] * normals[fj, 1] + normals[fi, 2] * normals[fj, 2]
                if c < cos_limit:
                    found = True
                    break
            if found:
                break
        out[g] = found
    return out


#: Faces per block of whole elements that the sampling handles at once: its memory grows with the block, not the model.
BLOCK_FACES = 1 << 16


def element_blocks(face_element: NDArray, block_faces: int = BLOCK_FACES) -> list[NDArray[np.int64]]:
    """Face indices in blocks of whole elements, each block about ``block_faces`` faces (an element with more
    faces is a block of its own)."""
    fe = np.asarray(face_element)
    if len(fe) == 0:
        return []
    grouped = bool(np.all(fe[1:] >= fe[:-1]))
    order = np.arange(len(fe)) if grouped else np.argsort(fe, kind="stable")
    sorted_fe = fe[order]
    starts = np.r_[np.flatnonzero(np.r_[True, sorted_fe[1:] != sorted_fe[:-1]]), len(fe)]  # each element's first face
    blocks, a = [], 0
    while a < len(fe):
        b = int(starts[np.searchsorted(starts, a + block_faces, side="right") - 1])  # the last start within a block
        if b <= a:  # one element longer than a block: a block of its own
            b = int(starts[np.searchsorted(starts, a, side="right")])
        blocks.append(order[a:b])
        a = b
    return blocks


def _grid_keys(scene: Scene) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]] | None:
    """(lowest grid cell, extents) of the vertices on the 1 mm merge grid and the strides that pack a cell into one
    int64 in (x, y, z) lexicographic order; None when the model is too large for 63 bits (then vertices are merged
    through one unique over every vertex)."""
    if len(scene.vertices) == 0:
        return None
    lo = np.round(scene.vertices.min(axis=0) / MERGE_GRID_M).astype(np.int64)
    hi = np.round(scene.vertices.max(axis=0) / MERGE_GRID_M).astype(np.int64)
    span = hi - lo + 1
    if float(span[0]) * float(span[1]) * float(span[2]) >= 2.0**62:
        return None
    return lo, span, np.array([span[1] * span[2], span[2], 1], np.int64)


def _block_corners(scene: Scene, idx: NDArray, grid, vid: NDArray | None, cos_limit: float):
    """The corner groups of the faces ``idx`` (whole elements): per (merged vertex, element) where two of the
    element's faces meet at more than the corner angle, its vertex key, element, angle-weighted normal sum
    (float32), sum of the angles, sum of vertex positions and incidence count."""
    faces = scene.faces[idx]
    tri = scene.vertices[faces]  # (b, 3, 3) float64: edges of small faces far from the origin keep their precision
    e1 = np.roll(tri, -1, axis=1) - tri
    e2 = np.roll(tri, 1, axis=1) - tri
    del tri
    n = np.cross(e1[:, 0], e2[:, 0])  # (b − a) × (c − a)
    length = np.linalg.norm(n, axis=1)
    valid = length > 0
    normals = (n / np.where(valid, length, 1.0)[:, None]).astype(np.float32)
    l1 = np.linalg.norm(e1, axis=2)
    l2 = np.linalg.norm(e2, axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cosang = np.einsum("fkc,fkc->fk", e1, e2) / (l1 * l2)
    del e1, e2
    ang = np.arccos(np.clip(np.nan_to_num(cosang, nan=1.0), -1, 1)).astype(np.float32)  # (b, 3)
    corner = faces.ravel()
    if vid is None:
        cell = np.round(scene.vertices[corner] / MERGE_GRID_M).astype(np.int64) - grid[0]
        key = cell @ grid[2]
    else:
        key = vid[corner]
    inc_face = np.repeat(np.arange(len(faces)), 3)
    keep = valid[inc_face]
    key, inc_face, corner = key[keep], inc_face[keep], corner[keep]
    inc_angle = ang.ravel()[keep]
    inc_elem = scene.face_element[idx][inc_face]
    order = np.lexsort((key, inc_elem))
    key, inc_elem, inc_face, corner, inc_angle = key[order], inc_elem[order], inc_face[order], corner[order], \
        inc_angle[order]
    new = np.r_[True, (key[1:] != key[:-1]) | (inc_elem[1:] != inc_elem[:-1])]
    group_start = np.r_[np.flatnonzero(new), len(key)].astype(np.int64)
    is_corner = _corner_groups(inc_face, group_start, normals, cos_limit)
    sel = is_corner[np.cumsum(new) - 1]
    if not sel.any():
        return None
    starts = np.flatnonzero(new[sel])
    w = normals[inc_face[sel]] * inc_angle[sel, None]
    nsum = np.add.reduceat(w, starts, axis=0)
    wsum = np.add.reduceat(inc_angle[sel].astype(np.float64), starts)
    psum = np.add.reduceat(scene.vertices[corner[sel]], starts, axis=0)
    count = np.diff(np.r_[starts, sel.sum()])
    return key[sel][starts], inc_elem[sel][starts].astype(np.int32), nsum, wsum, psum, count


def corner_features(scene: Scene, angle_deg: float = CORNER_ANGLE_DEG, block_faces: int = BLOCK_FACES
                    ) -> tuple[NDArray, NDArray, NDArray]:
    """(k, 3) positions (not yet offset), (k, 3) unit normals, (k,) owning element (−1 if shared).

    Streamed over blocks of whole elements (:func:`element_blocks`), so memory grows with the block, not the model:
    each block yields its corner groups (a merged vertex of one element), and the groups of one merged vertex are
    then summed across elements."""
    empty = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32)
    if len(scene.faces) == 0:
        return empty
    grid = _grid_keys(scene)
    vid = None
    if grid is None:  # a site kilometres wide in every axis: one unique over every vertex, in the same order
        _, vid = np.unique(np.round(scene.vertices / MERGE_GRID_M).astype(np.int64), axis=0, return_inverse=True)
        vid = vid.ravel().astype(np.int64)
    cos_limit = float(np.cos(np.radians(angle_deg)))
    fields: list[list[NDArray]] = [[] for _ in range(6)]  # key, element, normal sum, angle sum, position sum, count
    for idx in element_blocks(scene.face_element, block_faces):
        part = _block_corners(scene, idx, grid, vid, cos_limit)
        if part is not None:
            for store, column in zip(fields, part):
                store.append(column)
    if not fields[0]:
        return empty

    def joined(k: int) -> NDArray:
        """One field of every block in one array, its pieces let go at once (so two copies never coexist)."""
        out = np.concatenate(fields[k])
        fields[k].clear()
        return out

    key = joined(0)
    order = np.argsort(key, kind="stable")
    key = key[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    del key
    nrm = np.add.reduceat(joined(2)[order].astype(np.float64), starts, axis=0)
    weight = np.add.reduceat(joined(3)[order], starts)
    pos = np.add.reduceat(joined(4)[order], starts, axis=0)
    pos /= np.add.reduceat(joined(5)[order], starts)[:, None]
    elem = joined(1)[order]
    del order
    owner = np.where(np.minimum.reduceat(elem, starts) == np.maximum.reduceat(elem, starts), elem[starts], -1)
    del elem
    length = np.linalg.norm(nrm, axis=1)
    keep = length > 1e-6 * weight  # normals that cancel (a zero-thickness sheet's rim) leave float32 noise: none
    return pos[keep], nrm[keep] / length[keep, None], owner[keep].astype(np.int32)


#: More surface features than this would take gigabytes before a frame is cast (~160 bytes each while drawn):
#: a density typed wrong, refused before anything is allocated.
MAX_FEATURES = 20_000_000


def _face_areas(scene: Scene, block_faces: int = BLOCK_FACES) -> NDArray[np.float64]:
    """(F,) triangle areas, a block of faces at a time (never a (F, 3, 3) array)."""
    out = np.empty(len(scene.faces))
    for a in range(0, len(scene.faces), block_faces):
        tri = scene.vertices[scene.faces[a:a + block_faces]]
        out[a:a + len(tri)] = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return out


def surface_features(scene: Scene, density_per_m2: float, seed: int) -> tuple[NDArray, NDArray, NDArray]:
    """(N, 3) positions, (N, 3) winding normals, (N,) elements of area-weighted random surface points."""
    areas = _face_areas(scene)
    total = float(areas.sum())
    if not total * density_per_m2 <= MAX_FEATURES:
        raise ObservationsError(f"a feature density of {density_per_m2:g} per m² over the model's {total:,.0f} m² "
                                f"gives {total * density_per_m2:,.0f} features, more than the {MAX_FEATURES:,} "
                                f"allowed; lower the feature density (at most {MAX_FEATURES / total:.3g} per m² here)")
    n = int(round(total * density_per_m2))
    if n == 0 or total == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32)
    rng = np.random.default_rng(seed)
    face = rng.choice(len(areas), size=n, p=areas / total)
    del areas
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    tri = scene.vertices[scene.faces[face]]
    pts = (1 - s)[:, None] * tri[:, 0] + (s * (1 - r2))[:, None] * tri[:, 1] + (s * r2)[:, None] * tri[:, 2]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, length, out=np.zeros_like(nrm), where=length > 0)
    return pts, nrm, scene.face_element[face].astype(np.int32)


def sample_features(scene: Scene, density_per_m2: float = 1.0, seed: int = 0, corners: bool = True) -> FeatureSet:
    """All simulated features of the scene (targets and occluders alike), offset 1 mm along their normals."""
    if not (density_per_m2 >= 0 and np.isfinite(density_per_m2)):
        raise ObservationsError(f"feature density must be ≥ 0 per m², got {density_per_m2}")
    parts = [corner_features(scene)] if corners else []
    parts.append(surface_features(scene, density_per_m2, seed))
    pts = np.concatenate([p[0] for p in parts]).reshape(-1, 3)
    nrm = np.concatenate([p[1] for p in parts]).reshape(-1, 3)
    elem = np.concatenate([p[2] for p in parts]).astype(np.int32)
    kind = np.concatenate([np.full(len(p[0]), KIND_CORNER if i == 0 and corners else KIND_SURFACE, np.int8)
                           for i, p in enumerate(parts)])
    return FeatureSet(pts + OFFSET_M * nrm, nrm, kind, elem,
                      {"density_per_m2": density_per_m2, "seed": seed, "corners": corners,
                       "corner_angle_deg": CORNER_ANGLE_DEG, "scene": scene.key})


def cached_features(scene: Scene, density_per_m2: float = 1.0, seed: int = 0, cache_dir: str | Path | None = None
                    ) -> FeatureSet:
    """:func:`sample_features` of ``scene``, sampled once and kept beside the scene cache.

    The file, under ``cache_dir`` (default ``features`` under :func:`~sightplan.model.cache.cache_root`), is keyed
    by the scene's key (model, loader options, capture date) and the sampling parameters; an unreadable or stale
    file is sampled again and replaced.
    """
    directory = Path(cache_dir) if cache_dir is not None else cache_root() / "features"
    name = hashlib.sha256(json.dumps([SAMPLING_VERSION, scene.key, float(density_per_m2), int(seed)]).encode())
    path = directory / f"features-{name.hexdigest()[:40]}.npz"
    if path.is_file():
        try:
            fs = FeatureSet.load(path)
            if fs.params.get("scene") == scene.key and len(fs.kind) == len(fs.points) == len(fs.element):
                return fs
        except ObservationsError:
            pass  # sampled again below
    fs = sample_features(scene, density_per_m2, seed)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda fh: fs.save(fh, compressed=False))
    except OSError:
        pass  # a read-only cache folder only costs the sampling next time
    return fs
