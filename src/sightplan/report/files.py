"""Writing a report's files: the output path checked before any work, and bytes written in one step."""

from __future__ import annotations

from pathlib import Path

from ..errors import ReportError


def check_writable(path: str | Path) -> Path:
    """``path`` if a file can be written there, else a ReportError; creates its folder, leaves no file behind."""
    path = Path(path)
    if path.is_dir():
        raise ReportError(f"cannot write {path}: it is a folder")
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if ancestor.exists() and not ancestor.is_dir():
        raise ReportError(f"cannot write {path}: {ancestor} is not a folder")
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "ab"):
            pass
    except OSError as exc:
        raise ReportError(f"cannot write {path}: {exc.strerror or exc}") from None
    if not existed:
        path.unlink(missing_ok=True)
    return path


def write_bytes(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` (creating its folder); an OSError becomes one ReportError line."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(data, str):
            path.write_text(data, encoding="utf-8")
        else:
            path.write_bytes(data)
    except OSError as exc:
        raise ReportError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path
