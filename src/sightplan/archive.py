"""Zip archives (a DJI ``.kmz``, an ``.ifczip``) read by counting, not by trusting.

An entry is inflated a block at a time and refused as soon as the bytes it has actually given pass the limit,
whatever size its header declares; a corrupt, encrypted or truncated archive is one error of the caller's class,
never a ``BadZipFile`` or ``zlib.error`` further up.
"""

from __future__ import annotations

import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from .errors import SightplanError

BLOCK = 1 << 20  # inflated per read: the memory an entry takes is its limit, not what its header says
#: What goes wrong reading a zip archive that is not one, or a broken one
BROKEN = (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, ValueError, OSError)


def open_zip(path: str | Path, error: type[SightplanError], what: str) -> zipfile.ZipFile:
    """``path`` as a zip archive; ``error`` naming ``what`` when it is not one."""
    try:
        return zipfile.ZipFile(path)
    except BROKEN as exc:
        raise error(f"{Path(path).name} is not a {what} (zip) archive: {_reason(exc)}") from None


def copy_entry(z: zipfile.ZipFile, info: zipfile.ZipInfo | str, dst: BinaryIO, limit: int,
               error: type[SightplanError], where: str, too_big: Callable[[int | None], str] | None = None) -> int:
    """Inflate entry ``info`` of ``z`` into ``dst`` a block at a time, counting the bytes; ``error`` once more than
    ``limit`` bytes come out (or the header declares more), or when the entry is broken. ``too_big(size)`` words the
    refusal (``size`` declared, None when counted). The bytes written."""
    if isinstance(info, str):
        info = z.getinfo(info)
    refuse = too_big or (lambda size: f"{where}: unpacks to more than {limit / 2**20:,.0f} MB: refused")
    if info.file_size > limit:
        raise error(refuse(info.file_size))
    written = 0
    try:
        with z.open(info) as src:
            while block := src.read(BLOCK):
                written += len(block)
                if written > limit:  # the header can lie: what counts is what comes out
                    raise error(refuse(None))
                dst.write(block)
    except BROKEN as exc:
        raise error(f"{where}: the archive is broken ({_reason(exc)})") from None
    return written


def read_entry(z: zipfile.ZipFile, info: zipfile.ZipInfo | str, limit: int, error: type[SightplanError],
               where: str, too_big: Callable[[int | None], str] | None = None) -> bytes:
    """The bytes of entry ``info``, inflated within ``limit`` (see :func:`copy_entry`)."""
    import io

    out = io.BytesIO()
    copy_entry(z, info, out, limit, error, where, too_big)
    return out.getvalue()


def _reason(exc: BaseException) -> str:
    return str(exc) or type(exc).__name__
