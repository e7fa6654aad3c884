"""Small file helpers shared by every writer: atomic writes, JSON encoding."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from flatweave.errors import FlatweaveError

__all__ = ["atomic_write_bytes", "atomic_write_many", "json_bytes", "write_json"]


def atomic_write_bytes(path, data: bytes, before_replace=None) -> None:
    """Write ``data`` to ``path`` so readers see the old file or the whole new one.

    The bytes go to a temporary file in the same folder, are flushed to disk,
    and the file is renamed over ``path``. On any failure the temporary file
    is removed and a one-line FlatweaveError names the path and the reason.
    ``before_replace()``, if given, runs once the new file is safely on disk,
    just before the rename (to keep a backup of the old file only when the new
    one is sure to replace it); if it raises, nothing is renamed.
    """
    atomic_write_many([(path, data)], before_replace)


def atomic_write_many(items, before_replace=None) -> None:
    """Write several files, all or nothing: ``items`` is (path, bytes) pairs.

    Every file is first written in full to a temporary file beside its target
    and flushed to disk (where a full disk or a refused folder shows); only
    when all are there are they renamed into place. A failure before the
    renames removes every temporary file and leaves every target as it was.
    A rename that fails (rare: the folder was writable a moment before)
    leaves the targets renamed before it new, the rest as they were, and the
    one-line FlatweaveError names the files already written.
    """
    staged: list[tuple[Path, str]] = []
    try:
        for path, data in items:
            path = Path(path)
            staged.append((path, _stage(path, data)))
        if before_replace is not None:
            before_replace()
    except FlatweaveError:
        for _, tmp in staged:
            _remove(tmp)
        raise
    done: list[Path] = []
    for k, (path, tmp) in enumerate(staged):
        try:
            os.replace(tmp, path)
        except OSError as exc:
            for _, rest in staged[k:]:
                _remove(rest)
            already = f" ({', '.join(map(str, done))} already written)" if done else ""
            raise FlatweaveError(f"cannot write {path}: {exc.strerror or exc}{already}") from None
        done.append(path)


def _stage(path: Path, data: bytes) -> str:
    """Write ``data`` to a new temporary file beside ``path``, flushed to disk;
    its name. On failure nothing is left and a one-line FlatweaveError says why."""
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
    except OSError as exc:
        _remove(tmp)
        raise FlatweaveError(f"cannot write {path}: {exc.strerror or exc}") from None
    return tmp


def _remove(tmp: str) -> None:
    try:
        os.unlink(tmp)
    except OSError:
        pass


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
