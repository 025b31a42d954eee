"""The data folder. Every file name in it is chosen by the server (a random hex name and a known suffix); nothing a
client sends becomes part of a path."""

from __future__ import annotations

import os
import shutil
import uuid
from collections.abc import AsyncIterator
from pathlib import Path

from ..formats.registry import FILE_SUFFIXES
from ..model.load import SUPPORTED_EXTENSIONS


class UploadTooLarge(Exception):
    """An upload over the server's limit (the partial file is already removed)."""

    def __init__(self, limit_bytes: int) -> None:
        super().__init__(f"the upload is larger than the server's limit of {limit_bytes / 1024 / 1024:g} MB "
                         "(sightplan serve --max-upload-mb)")


def safe_suffix(original_name: str, allowed: tuple[str, ...]) -> str | None:
    """The lower-case suffix of a client's file name when it is one of ``allowed`` (``.ifc``…), else None.
    Only the suffix is ever used; the rest of the name is kept as metadata."""
    name = original_name.replace("\\", "/").rsplit("/", 1)[-1].lower()
    for suffix in sorted(allowed, key=len, reverse=True):
        if name.endswith(suffix) and len(name) > len(suffix):
            return suffix
    return None


def display_name(original_name: str) -> str:
    """The client's file name as metadata: its last part, printable, at most 255 characters."""
    name = original_name.replace("\\", "/").rsplit("/", 1)[-1]
    return "".join(c for c in name if c.isprintable())[:255] or "upload"


class Storage:
    """``models/``, ``plans/``, ``schedules/``, ``evaluations/``, ``tmp/`` and the caches under one root."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.models = root / "models"
        self.plans = root / "plans"
        self.evaluations = root / "evaluations"
        self.tmp = root / "tmp"
        self.cache = root / "cache"
        self.schedules = root / "schedules"
        self.reality = root / "reality"
        for folder in (self.models, self.plans, self.evaluations, self.tmp, self.cache, self.schedules, self.reality):
            folder.mkdir(parents=True, exist_ok=True)

    @staticmethod
    def new_name(suffix: str = "") -> str:
        return uuid.uuid4().hex + suffix

    def model_path(self, stored_name: str) -> Path:
        return self.models / stored_name

    def plan_path(self, stored_name: str) -> Path:
        return self.plans / stored_name

    def reality_path(self, stored_name: str) -> Path:
        """An uploaded capture, or its prepared view (a tileset folder or a .glb)."""
        return self.reality / stored_name

    def schedule_path(self, stored_name: str) -> Path:
        return self.schedules / stored_name

    @property
    def scene_cache(self) -> Path:
        """Tessellated models (and reality models), as ``scenes`` under a command line's cache root: the same layout."""
        return self.cache / "scenes"

    @property
    def frame_cache(self) -> Path:
        """Per-frame observations by content digest: re-evaluating an edited plan casts only the frames that changed."""
        return self.cache / "frames"

    def evaluation_dir(self, result_dir: str) -> Path:
        return self.evaluations / result_dir

    def temp_path(self, suffix: str = "") -> Path:
        return self.tmp / self.new_name(suffix)

    async def receive(self, chunks: AsyncIterator[bytes], suffix: str, limit_bytes: int) -> tuple[Path, int]:
        """Stream an upload into a new file in ``tmp/``; returns it and its size. Over the limit the partial file is
        removed and :class:`UploadTooLarge` raised."""
        path = self.temp_path(suffix)
        size = 0
        try:
            with open(path, "wb") as fh:
                async for chunk in chunks:
                    size += len(chunk)
                    if size > limit_bytes:
                        raise UploadTooLarge(limit_bytes)
                    fh.write(chunk)
        except BaseException:
            path.unlink(missing_ok=True)
            raise
        return path, size

    def adopt(self, temp: Path, target: Path) -> None:
        """Move a finished file from ``tmp/`` to its place (atomic on one file system)."""
        os.replace(temp, target)

    def remove(self, *paths: Path) -> None:
        for path in paths:
            if path.is_dir():
                shutil.rmtree(path, ignore_errors=True)
            else:
                path.unlink(missing_ok=True)

    def clear_tmp(self) -> None:
        """Leftovers of uploads cut off by a previous stop."""
        for path in self.tmp.iterdir():
            self.remove(path)


MODEL_SUFFIXES: tuple[str, ...] = SUPPORTED_EXTENSIONS
PLAN_SUFFIXES: tuple[str, ...] = FILE_SUFFIXES
