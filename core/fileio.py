"""Small file helpers shared by every writer: atomic writes, JSON encoding."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from core.errors import FlatweaveError

__all__ = ["atomic_write_bytes", "atomic_write_text", "json_bytes", "write_json"]


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` so readers see the old file or the whole new one.

    The bytes go to a temporary file in the same folder, are flushed to disk,
    and the file is renamed over ``path``. On any failure the temporary file
    is removed and a one-line FlatweaveError names the path and the reason.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise FlatweaveError(f"cannot write {path}: {exc.strerror or exc}") from None
    try:
        os.chmod(tmp, _file_mode(path))
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise FlatweaveError(f"cannot write {path}: {exc.strerror or exc}") from None


def _file_mode(path: Path) -> int:
    """Permission bits for the new file: the old file's, else 0o666 less the umask
    (mkstemp's own 0o600 would hide exported patterns from other users)."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_text(path, text: str) -> None:
    """UTF-8 text version of :func:`atomic_write_bytes`."""
    atomic_write_bytes(path, text.encode("utf-8"))


def json_bytes(obj, path) -> bytes:
    """``obj`` as compact JSON (UTF-8). NaN and infinity are refused with a
    one-line FlatweaveError naming ``path`` (JSON has no such numbers)."""
    try:
        return json.dumps(obj, allow_nan=False, separators=(",", ":")).encode("utf-8")
    except ValueError:
        raise FlatweaveError(f"cannot write {path}: it would hold a number that is not finite "
                             f"(NaN or infinity); nothing was written") from None


def write_json(path, obj) -> None:
    """Write ``obj`` as JSON, atomically. NaN and infinity are refused."""
    atomic_write_bytes(path, json_bytes(obj, path))
