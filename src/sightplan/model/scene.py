"""The scene: one triangle soup for the whole model plus an element table.

Element indices are dense (0..z-1) and stable: :meth:`Scene.at` drops the faces of
elements not built by a date but keeps the element table, so observations made at
different dates index the same elements.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..errors import ModelError, ScheduleError
from .ties import coincident_face_pairs, remap_pairs

DateBasis = Literal["finish", "start"]
Discipline = Literal["S", "A", "M", "P", "E", ""]


@dataclass(frozen=True)
class ElementTable:
    """Per-element attributes, every column of shape (z,).

    ``start``/``finish`` are ``datetime64[s]`` with NaT where no schedule dates the
    element. ``is_target`` is False for occluder-only elements (terrain, furniture):
    they hide what is behind them but do not count in ``z``.
    """

    global_id: NDArray[np.object_]
    name: NDArray[np.object_]
    ifc_class: NDArray[np.object_]
    discipline: NDArray[np.object_]
    storey: NDArray[np.object_]
    is_target: NDArray[np.bool_]
    start: NDArray[np.datetime64]
    finish: NDArray[np.datetime64]

    def __post_init__(self) -> None:
        n = len(self.global_id)
        for name in ("name", "ifc_class", "discipline", "storey", "is_target", "start", "finish"):
            if len(getattr(self, name)) != n:
                raise ModelError(f"element table column {name!r} has {len(getattr(self, name))} rows, expected {n}")

    def __len__(self) -> int:
        return len(self.global_id)

    @classmethod
    def build(
        cls,
        global_id: list[str],
        name: list[str] | None = None,
        ifc_class: list[str] | None = None,
        discipline: list[str] | None = None,
        storey: list[str] | None = None,
        is_target: list[bool] | NDArray[np.bool_] | None = None,
        start: list | None = None,
        finish: list | None = None,
    ) -> ElementTable:
        """Build a table from plain lists; missing columns get empty strings / NaT / True."""
        n = len(global_id)

        def col(values: list[str] | None) -> NDArray[np.object_]:
            arr = np.empty(n, dtype=object)
            arr[:] = [""] * n if values is None else [str(v) if v is not None else "" for v in values]
            return arr

        def dates(values: list | None) -> NDArray[np.datetime64]:
            if values is None:
                return np.full(n, np.datetime64("NaT"), dtype="datetime64[s]")
            return np.array(values, dtype="datetime64[s]")

        return cls(
            global_id=col(global_id),
            name=col(name),
            ifc_class=col(ifc_class),
            discipline=col(discipline),
            storey=col(storey),
            is_target=np.ones(n, bool) if is_target is None else np.asarray(is_target, bool),
            start=dates(start),
            finish=dates(finish),
        )

    def with_dates(self, start: NDArray[np.datetime64], finish: NDArray[np.datetime64]) -> ElementTable:
        """A copy with new (z,) schedule dates."""
        return replace(self, start=np.asarray(start, "datetime64[s]"), finish=np.asarray(finish, "datetime64[s]"))


@dataclass(frozen=True)
class Scene:
    """Triangles of every element that exists, in metres in the model's local frame.

    vertices: (V, 3) float64 metres. faces: (F, 3) int32 vertex indices.
    face_element: (F,) int32 dense element index of each face.
    present: (z,) bool, the elements that exist in this scene (all, or those built by
    ``date``). Invariant: every face belongs to a present element.
    content_hash: hex digest of the source file (or geometry), for caches.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int32]
    face_element: NDArray[np.int32]
    elements: ElementTable
    present: NDArray[np.bool_]
    source: str = ""
    content_hash: str = ""
    date: np.datetime64 | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        v, f, fe = self.vertices, self.faces, self.face_element
        if v.ndim != 2 or v.shape[1] != 3:
            raise ModelError(f"vertices must be (V, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ModelError(f"faces must be (F, 3), got {f.shape}")
        if fe.shape != (len(f),):
            raise ModelError(f"face_element must be ({len(f)},), got {fe.shape}")
        if len(self.present) != len(self.elements):
            raise ModelError("present mask and element table differ in length")
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ModelError("faces index vertices that do not exist")
        if len(fe) and (fe.min() < 0 or fe.max() >= len(self.elements)):
            raise ModelError("face_element indexes elements that do not exist")
        if not np.isfinite(v).all():
            raise ModelError("the model has non-finite vertex coordinates")

    @classmethod
    def from_arrays(
        cls,
        vertices: NDArray,
        faces: NDArray,
        face_element: NDArray,
        elements: ElementTable,
        source: str = "",
        content_hash: str | None = None,
        metadata: dict | None = None,
    ) -> Scene:
        v = np.ascontiguousarray(vertices, dtype=np.float64)
        f = np.ascontiguousarray(faces, dtype=np.int32)
        fe = np.ascontiguousarray(face_element, dtype=np.int32)
        if content_hash is None:
            h = hashlib.sha256()
            for a in (v, f, fe):
                h.update(a.tobytes())
            h.update("\0".join(elements.global_id.tolist()).encode())
            content_hash = h.hexdigest()
        return cls(v, f, fe, elements, np.ones(len(elements), bool), source, content_hash, None, metadata or {})

    # ------------------------------------------------------------------ queries
    @property
    def n_elements(self) -> int:
        return len(self.elements)

    @property
    def targets(self) -> NDArray[np.bool_]:
        """(z,) bool: present elements that count in the metrics."""
        return self.present & self.elements.is_target

    @property
    def key(self) -> str:
        """Hash of the geometry and of which elements exist: the cache key of this scene."""
        h = hashlib.sha256(self.content_hash.encode())
        h.update(np.packbits(self.present).tobytes())
        h.update(np.packbits(self.elements.is_target).tobytes())
        return h.hexdigest()[:32]

    def bounds(self) -> NDArray[np.float64]:
        """(2, 3) min and max corner of the vertices that faces use, in metres; zeros when the scene is empty.
        Computed once per scene object (a copy is returned)."""
        known = self.__dict__.get("_bounds")
        if known is None:
            if len(self.faces) == 0:
                known = np.zeros((2, 3))
            else:
                used = np.zeros(len(self.vertices), bool)
                used[self.faces.ravel()] = True
                v = self.vertices[used] if not used.all() else self.vertices
                known = np.stack([v.min(0), v.max(0)])
            object.__setattr__(self, "_bounds", known)
        return known.copy()

    def face_normals(self) -> NDArray[np.float64]:
        """(F, 3) unit winding normals (zero for degenerate faces)."""
        tri = self.vertices[self.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.divide(n, length, out=np.zeros_like(n), where=length > 0)

    def face_areas(self) -> NDArray[np.float64]:
        """(F,) triangle areas in m²."""
        tri = self.vertices[self.faces]
        return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)

    def tie_pairs(self) -> NDArray[np.int32]:
        """(k, 2) face index pairs of different elements on one surface (METRICS.md §2, :mod:`.ties`): found once
        per scene object (or read from the scene cache) and kept on it. A scene made with ``dataclasses.replace``
        finds its own, so changed faces never meet stale pairs."""
        pairs = self.__dict__.get("_tie_pairs")
        if pairs is None:
            pairs = coincident_face_pairs(self.vertices, self.faces, self.face_element)
            self.set_tie_pairs(pairs)
        return pairs

    def has_tie_pairs(self) -> bool:
        """Whether :meth:`tie_pairs` is known already (found, cached or remapped), so asking costs nothing."""
        return self.__dict__.get("_tie_pairs") is not None

    def set_tie_pairs(self, pairs: NDArray) -> None:
        """Attach pairs known for exactly these faces (from the cache, or remapped from a superset)."""
        pairs = np.asarray(pairs, np.int32).reshape(-1, 2)
        if len(pairs) and (pairs.min() < 0 or pairs.max() >= len(self.faces)):
            raise ModelError("tie pairs index faces that do not exist")
        object.__setattr__(self, "_tie_pairs", pairs)

    # ------------------------------------------------------------------ subsets
    def with_present(self, present: NDArray[np.bool_]) -> Scene:
        """The scene with only the faces of ``present`` elements (indices unchanged)."""
        present = np.asarray(present, bool) & self.present
        keep = present[self.face_element]
        out = replace(self, faces=self.faces[keep], face_element=self.face_element[keep], present=present)
        known = self.__dict__.get("_tie_pairs")
        if known is not None:
            out.set_tie_pairs(remap_pairs(known, keep))
        object.__setattr__(out, "_derived_from", self.__dict__.get("_derived_from", self))  # its ground is ours
        return out

    def at(self, date: str | np.datetime64, basis: DateBasis = "finish",
           unscheduled: Literal["present", "absent"] = "present") -> Scene:
        """The scene as it stands at the end of ``date``.

        An element exists when its schedule date (``finish`` by default, ``start`` as an
        option) is on or before ``date``; an element with only the other date falls back
        to it. Elements that no schedule dates exist at every date (``unscheduled="present"``)
        or never (``"absent"``). Call it on the undated scene: a dated scene has lost the
        faces of what was not yet built.
        """
        from .dates import parse_day

        if basis not in ("finish", "start"):
            raise ScheduleError(f"date basis must be 'finish' or 'start', got {basis!r}")
        if unscheduled not in ("present", "absent"):
            raise ScheduleError(f"unscheduled elements must be 'present' or 'absent', got {unscheduled!r}")
        if self.date is not None:
            raise ScheduleError(f"this scene is already at {self.date}; call at() on the undated scene")
        day = parse_day(date)
        end_of_day = (day + np.timedelta64(1, "D")).astype("datetime64[s]")
        first, second = (self.elements.finish, self.elements.start) if basis == "finish" else \
            (self.elements.start, self.elements.finish)
        when = np.where(np.isnat(first), second, first)
        dated = ~np.isnat(when)
        built = np.where(dated, when < end_of_day, unscheduled == "present")
        scene = self.with_present(built)
        if not scene.targets.any():
            first_day = when[dated & self.elements.is_target].min() if (dated & self.elements.is_target).any() else None
            hint = f"; the first element is built on {str(first_day)[:10]}" if first_day is not None else ""
            raise ScheduleError(f"no element of the model exists on {day}{hint}")
        out = replace(scene, date=day)
        object.__setattr__(out, "_derived_from", scene.__dict__.get("_derived_from", self))
        return out

    def __getstate__(self) -> dict:
        """What pickles: not the scene this one was derived from (kept only to share its ground), nor the vertex
        tree the flight checks keep on it (rebuilt where needed)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_derived_from", "_vertex_tree")}
