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
SAMPLING_VERSION = 1


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


@nb.njit(cache=True)
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


def corner_features(scene: Scene, angle_deg: float = CORNER_ANGLE_DEG) -> tuple[NDArray, NDArray, NDArray]:
    """(k, 3) positions (not yet offset), (k, 3) unit normals, (k,) owning element (−1 if shared)."""
    faces, fe = scene.faces, scene.face_element
    if len(faces) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32)
    normals = scene.face_normals()
    tri = scene.vertices[faces]  # (F, 3, 3)
    # interior angle of each face at each of its corners (for the angle-weighted normal)
    e1 = np.roll(tri, -1, axis=1) - tri
    e2 = np.roll(tri, 1, axis=1) - tri
    l1 = np.linalg.norm(e1, axis=2)
    l2 = np.linalg.norm(e2, axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cosang = np.einsum("fkc,fkc->fk", e1, e2) / (l1 * l2)
    ang = np.arccos(np.clip(np.nan_to_num(cosang, nan=1.0), -1, 1))  # (F, 3)
    # merged vertex id per incidence
    grid = np.round(scene.vertices / MERGE_GRID_M).astype(np.int64)
    _, vid = np.unique(grid, axis=0, return_inverse=True)
    vid = vid.ravel()
    inc_vertex = vid[faces].ravel()  # (3F,)
    inc_face = np.repeat(np.arange(len(faces)), 3)
    inc_angle = ang.ravel()
    inc_elem = fe[inc_face].astype(np.int64)
    valid = np.linalg.norm(normals[inc_face], axis=1) > 0
    inc_vertex, inc_face, inc_angle, inc_elem = inc_vertex[valid], inc_face[valid], inc_angle[valid], inc_elem[valid]
    # groups of (merged vertex, element)
    order = np.lexsort((inc_elem, inc_vertex))
    gv, ge = inc_vertex[order], inc_elem[order]
    new_group = np.r_[True, (gv[1:] != gv[:-1]) | (ge[1:] != ge[:-1])]
    group_start = np.r_[np.flatnonzero(new_group), len(order)]
    is_corner_group = _corner_groups(inc_face[order], group_start, normals, np.cos(np.radians(angle_deg)))
    group_of = np.cumsum(new_group) - 1
    corner_inc = is_corner_group[group_of]  # incidences (in sorted order) of corner groups
    cv = gv[corner_inc]
    cf = inc_face[order][corner_inc]
    cw = inc_angle[order][corner_inc]
    ce = ge[corner_inc]
    if len(cv) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32)
    uv, inv = np.unique(cv, return_inverse=True)
    nsum = np.zeros((len(uv), 3))
    np.add.at(nsum, inv, normals[cf] * cw[:, None])
    length = np.linalg.norm(nsum, axis=1)
    # position: the mean of the merged vertices' coordinates
    pos = np.zeros((len(uv), 3))
    cnt = np.bincount(inv, minlength=len(uv)).astype(float)
    # coordinates of one original vertex per incidence
    orig_vertex = faces.ravel()[valid][order][corner_inc]
    np.add.at(pos, inv, scene.vertices[orig_vertex])
    pos /= cnt[:, None]
    emin = np.full(len(uv), np.iinfo(np.int64).max)
    emax = np.full(len(uv), -1)
    np.minimum.at(emin, inv, ce)
    np.maximum.at(emax, inv, ce)
    owner = np.where(emin == emax, emin, -1).astype(np.int32)
    keep = length > 1e-9
    return pos[keep], nsum[keep] / length[keep, None], owner[keep]


#: More surface features than this would take gigabytes before a frame is cast (~160 bytes each while drawn):
#: a density typed wrong, refused before anything is allocated.
MAX_FEATURES = 20_000_000


def surface_features(scene: Scene, density_per_m2: float, seed: int) -> tuple[NDArray, NDArray, NDArray]:
    """(N, 3) positions, (N, 3) winding normals, (N,) elements of area-weighted random surface points."""
    areas = scene.face_areas()
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
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    tri = scene.vertices[scene.faces[face]]
    pts = (1 - s)[:, None] * tri[:, 0] + (s * (1 - r2))[:, None] * tri[:, 1] + (s * r2)[:, None] * tri[:, 2]
    return pts, scene.face_normals()[face], scene.face_element[face].astype(np.int32)


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
