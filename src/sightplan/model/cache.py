"""Tessellated scene cache: a second load of the same file with the same options is instant.

An entry is two files under the cache directory, named by the scene's content hash
(sha256 of the file bytes and the loader options, see :func:`content_hash`):
``<hash>.npz`` (vertices, faces, face_element, element table columns) and
``<hash>.json`` (load report, metadata, source). Entries are written atomically; an
entry that cannot be read back (truncated, edited, older format) is ignored and rebuilt.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import zipfile
import zlib
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .scene import ElementTable, Scene
from .summary import LoadReport

#: Bump when the tessellation or the element rules change, so old entries are not reused.
CACHE_FORMAT = 7  # 7: metadata carries the elements' surface styles
_COLUMNS = ("global_id", "name", "ifc_class", "discipline", "storey")


def content_hash(path: str | Path, options: dict) -> str:
    """Hex sha256 of the file's bytes followed by the canonical JSON of ``options``."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    h.update(b"\0")
    h.update(json.dumps({"cache_format": CACHE_FORMAT, **options}, sort_keys=True, default=str).encode())
    return h.hexdigest()


def cache_root() -> Path:
    """``$SIGHTPLAN_CACHE`` if set, else ``~/.cache/sightplan``. Every cache has its own folder under it:
    ``scenes`` (tessellated models), ``features`` (simulated feature sets), ``frames`` (per-frame observations) and
    ``views`` (the views of the report's pictures)."""
    env = os.environ.get("SIGHTPLAN_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "sightplan"


def default_cache_dir() -> Path:
    """Where tessellated scenes are cached: ``scenes`` under :func:`cache_root`."""
    return cache_root() / "scenes"


def _paths(key: str, cache_dir: Path) -> tuple[Path, Path]:
    return cache_dir / f"{key}.npz", cache_dir / f"{key}.json"


def atomic_write(target: Path, write) -> None:
    """Write ``target`` through ``write(fh)`` into a temporary file beside it, then rename: never half written."""
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=target.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def save_scene(scene: Scene, report: LoadReport, cache_dir: str | Path | None = None) -> Path:
    """Write ``scene`` (all elements present) and its report under ``scene.content_hash``; returns the .npz path."""
    directory = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    npz_path, json_path = _paths(scene.content_hash, directory)
    el = scene.elements
    arrays = {
        "vertices": scene.vertices,
        "faces": scene.faces,
        "face_element": scene.face_element,
        "tie_pairs": scene.tie_pairs(),
        "is_target": el.is_target,
        "start": el.start.astype("datetime64[s]").astype(np.int64),
        "finish": el.finish.astype("datetime64[s]").astype(np.int64),
        **{c: np.asarray(getattr(el, c), dtype=str) for c in _COLUMNS},
    }
    meta = {
        "cache_format": CACHE_FORMAT,
        "source": scene.source,
        "content_hash": scene.content_hash,
        "metadata": scene.metadata,
        "report": report.to_dict(),
    }
    atomic_write(npz_path, lambda fh: np.savez(fh, **arrays))
    atomic_write(json_path, lambda fh: fh.write(json.dumps(meta, default=str).encode()))
    return npz_path


def load_scene(key: str, cache_dir: str | Path | None = None, source: str | None = None
               ) -> tuple[Scene, LoadReport] | None:
    """The cached (scene, report) for ``key``, or None when absent or unreadable; ``source`` names the file it was
    asked for (the same bytes may have been cached from another path), else the cached name is kept."""
    directory = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    npz_path, json_path = _paths(key, directory)
    if not (npz_path.is_file() and json_path.is_file()):
        return None
    try:
        meta = json.loads(json_path.read_text())
        if meta.get("cache_format") != CACHE_FORMAT or meta.get("content_hash") != key:
            return None
        with np.load(npz_path, allow_pickle=False) as z:
            a = {k: z[k] for k in z.files}
        nat = np.iinfo(np.int64).min
        elements = ElementTable.build(
            global_id=a["global_id"].tolist(),
            **{c: a[c].tolist() for c in _COLUMNS[1:]},
            is_target=a["is_target"],
            start=np.where(a["start"] == nat, np.datetime64("NaT"), a["start"].astype("datetime64[s]")),
            finish=np.where(a["finish"] == nat, np.datetime64("NaT"), a["finish"].astype("datetime64[s]")),
        )
        scene = Scene.from_arrays(a["vertices"], a["faces"], a["face_element"], elements,
                                  meta["source"] if source is None else source, key, meta.get("metadata") or {})
        if "tie_pairs" in a:
            scene.set_tie_pairs(a["tie_pairs"])
        report = LoadReport.from_dict(meta["report"])
        if source is not None:
            report = replace(report, source=source)
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile, zlib.error, ModelError):
        return None  # a corrupt or foreign entry: the caller rebuilds and overwrites it
    return scene, report
