"""Binary glTF 2.0 (GLB) written directly: one primitive, positions as float32 offsets from a node translation.

Used for the web viewer's reality views: a point cloud's tiles (``POINTS``, with colours) and a reality mesh
(``TRIANGLES``). Coordinates come Z up and are stored Y up (:mod:`.axes`). The evaluation's coloured model, with a
node, material and metadata per element, is a scene graph and goes through trimesh (:mod:`sightplan.report.gltf`).
"""

from __future__ import annotations

import json
import struct

import numpy as np
from numpy.typing import ArrayLike

from ..version import __version__
from .axes import z_up_to_y_up

GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
FLOAT, UNSIGNED_BYTE, UNSIGNED_INT = 5126, 5121, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
POINTS, TRIANGLES = 0, 4


def pack_glb(gltf: dict, binary: bytes) -> bytes:
    """The GLB container: a 12-byte header, the JSON chunk and the binary chunk, each padded to 4 bytes."""
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return b"".join([struct.pack("<III", GLB_MAGIC, 2, total), struct.pack("<II", len(text), JSON_CHUNK), text,
                     struct.pack("<II", len(binary), BIN_CHUNK), binary])


def primitive_glb(positions: ArrayLike, centre: ArrayLike, *, colours: ArrayLike | None = None,
                  triangles: ArrayLike | None = None) -> bytes:
    """One node translated to ``centre`` holding one primitive: Z-up ``positions`` stored Y up as float32 offsets
    from ``centre``; ``colours`` (n, 3) uint8 as normalized COLOR_0; ``triangles`` (m, 3) vertex indices
    (a ``TRIANGLES`` primitive; without them, ``POINTS``)."""
    local = z_up_to_y_up(positions, centre).astype(np.float32)
    n = len(local)
    blobs = [local.tobytes()]
    offset = 12 * n
    accessors = [{"bufferView": 0, "componentType": FLOAT, "count": n, "type": "VEC3",
                  "min": local.min(axis=0).tolist() if n else [0, 0, 0],
                  "max": local.max(axis=0).tolist() if n else [0, 0, 0]}]
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": 12 * n, "target": ARRAY_BUFFER}]
    primitive: dict = {"attributes": {"POSITION": 0}, "mode": POINTS if triangles is None else TRIANGLES}
    if colours is not None:
        rgba = np.zeros((n, 4), np.uint8)  # 3 bytes a vertex, padded to 4 as glTF aligns vertex attributes
        rgba[:, :3] = colours
        blobs.append(rgba.tobytes())
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": 4 * n, "byteStride": 4,
                      "target": ARRAY_BUFFER})
        accessors.append({"bufferView": len(views) - 1, "componentType": UNSIGNED_BYTE, "normalized": True,
                          "count": n, "type": "VEC3"})
        primitive["attributes"]["COLOR_0"] = len(accessors) - 1
        offset += 4 * n
    if triangles is not None:
        index = np.ascontiguousarray(triangles, np.uint32).reshape(-1)
        blobs.append(index.tobytes())
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": 4 * len(index),
                      "target": ELEMENT_ARRAY_BUFFER})
        accessors.append({"bufferView": len(views) - 1, "componentType": UNSIGNED_INT, "count": len(index),
                          "type": "SCALAR"})
        primitive["indices"] = len(accessors) - 1
    binary = b"".join(blobs)
    translation = z_up_to_y_up(np.asarray(centre, np.float64))[0].tolist()
    gltf = {"asset": {"version": "2.0", "generator": f"sightplan {__version__}"},
            "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "translation": translation}],
            "meshes": [{"primitives": [primitive]}],
            "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": len(binary)}]}
    return pack_glb(gltf, binary)
