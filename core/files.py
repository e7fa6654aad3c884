"""Small file helpers shared by every reader and writer: the one guarded way a
file is read (``read_input``, ``parse_json``), atomic writes, JSON encoding."""

from __future__ import annotations

import glob
import json
import os
import re
import stat
import tempfile
import time
from pathlib import Path

import numpy as np

from flatweave.errors import FlatweaveError

__all__ = ["exists", "check_output", "same_file", "atomic_write_bytes", "atomic_write_many", "json_bytes",
           "write_json", "check_input", "read_input", "parse_json", "check_json_depth", "READ_LIMITS", "MAX_JSON_DEPTH",
           "encode_array", "decode_array", "ARRAY_DTYPES"]

MB = 1 << 20
READ_LIMITS = {
    "small": 16 * MB,       # a region, a curve dart: a few thousand points at most
    "surface": 256 * MB,    # a geomdl JSON surface: a 1,000 x 1,000 rational net is about 60 MB
    "result": 1024 * MB,    # a result or project: 160,000 nodes was 83 MB of JSON (issue 44)
    "mesh": 2048 * MB,      # an ASCII STL of the 2,000,000 triangles meshes are allowed
    "cad": 2048 * MB,       # a STEP or IGES file
}
"""The most bytes read from one input file, by kind: checked from the file's
size before a byte is read, and again while reading (a file that grows)."""

_KIND_NAMES = {"small": "region or curve dart file", "surface": "surface file", "result": "result or project file",
               "mesh": "mesh file", "cad": "STEP or IGES file"}

MAX_JSON_DEPTH = 64
"""The deepest nesting of arrays and objects a JSON input may have (the deepest
of ours, a trimmed surface's containers of curves, is under 10)."""

_KINDS = ((stat.S_ISFIFO, "a pipe (FIFO)"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder"))


def exists(path) -> bool:
    """Whether ``path`` names something, False for a name the system cannot even look up (too long,
    a NUL in it), where ``Path.exists`` raises: the reader then says why in one line."""
    try:
        return Path(path).exists()
    except (OSError, ValueError):
        return False


def check_input(path, limit: str, error=FlatweaveError) -> int:
    """The size of the regular file ``path``, which may be read as a ``limit`` kind
    of input (a key of :data:`READ_LIMITS`); else ``error`` (a FlatweaveError
    type) in one line naming the file: missing, unreadable, not a regular file
    (a pipe, a device, a folder: never opened, so nothing blocks or reads for
    ever) or larger than the kind's limit. Symbolic links are followed."""
    name = os.fspath(path)
    try:
        st = os.stat(name)
    except FileNotFoundError:
        raise error(_line(f"{name}: no such file")) from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the name
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise error(_line(f"{name}: cannot read file: {reason}")) from None
    for test, what in _KINDS:
        if test(st.st_mode):
            raise error(_line(f"{name} is {what}, not a file"))
    cap = READ_LIMITS[limit]
    if st.st_size > cap:
        raise error(_line(f"{name} is {st.st_size / MB:,.0f} MB, more than the {cap / MB:,.0f} MB read from "
                          f"a {_KIND_NAMES[limit]}"))
    return st.st_size


def read_input(path, limit: str, error=FlatweaveError) -> bytes:
    """The bytes of the regular file ``path``, checked first by :func:`check_input`
    and read to at most the kind's limit; ``error`` in one line otherwise."""
    name = os.fspath(path)
    check_input(name, limit, error)
    cap = READ_LIMITS[limit]
    try:
        with open(name, "rb") as fh:
            raw = fh.read(cap + 1)
    except OSError as exc:
        raise error(_line(f"{name}: cannot read file: {exc.strerror or type(exc).__name__}")) from None
    if len(raw) > cap:
        raise error(_line(f"{name} grew past the {cap / MB:,.0f} MB read from a {_KIND_NAMES[limit]} while it "
                          f"was read"))
    return raw


_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)


def parse_json(raw: bytes, name: str, what: str, error=FlatweaveError):
    """``raw`` parsed as JSON (UTF-8, a byte-order mark allowed); ``error`` in one
    line naming ``name`` and ``what`` it should be on text that is not JSON or
    nests deeper than :data:`MAX_JSON_DEPTH` (found by counting brackets
    outside strings before parsing, so no parser recursion is reached)."""
    check_json_depth(raw, name, what, error)
    try:
        return json.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise error(_line(f"{name}: not a {what} (binary data, not JSON text)")) from None
    except json.JSONDecodeError as exc:
        raise error(_line(f"{name}: not a {what} (invalid JSON at line {exc.lineno}, column {exc.colno}: "
                          f"{exc.msg})")) from None
    except (RecursionError, ValueError) as exc:
        raise error(_line(f"{name}: not a {what} ({type(exc).__name__})")) from None


def check_json_depth(raw: bytes, name: str, what: str, error=FlatweaveError) -> None:
    """``error`` in one line if the JSON text ``raw`` nests arrays and objects more
    than :data:`MAX_JSON_DEPTH` deep (brackets counted outside strings)."""
    bare = _JSON_STRING.sub(b'""', raw)
    codes = np.frombuffer(bare, dtype=np.uint8)
    step = np.isin(codes, (0x5B, 0x7B)).astype(np.int32) - np.isin(codes, (0x5D, 0x7D)).astype(np.int32)
    if len(step) and int(np.cumsum(step).max()) > MAX_JSON_DEPTH:
        raise error(_line(f"{name}: not a {what}: JSON nested more than {MAX_JSON_DEPTH} levels deep"))


def check_output(path, error=FlatweaveError) -> Path:
    """``path`` if a file may be written there: nothing there yet, or a regular file (replaced
    atomically). A pipe, a device, a socket or a folder there is never replaced (the rename
    would put an ordinary file in its place: ``--out /dev/null`` run as root): one line."""
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return path
    except (OSError, ValueError) as exc:
        raise error(_line(f"cannot write {path}: {getattr(exc, 'strerror', None) or exc}")) from None
    for test, what in _KINDS:
        if test(st.st_mode):
            raise error(_line(f"cannot write {path}: it is {what}, not a file, and is not replaced"))
    return path


def same_file(a, b) -> bool:
    """Whether ``a`` and ``b`` name one file (both there: the same inode; else the same absolute path)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        try:
            return Path(a).resolve() == Path(b).resolve()
        except (OSError, ValueError, RuntimeError):
            return False


def _line(text: str, limit: int = 400) -> str:
    """One line, at most ``limit`` characters (a 300-character file name stays readable)."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


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
    items = [(check_output(path), data) for path, data in items]  # before a byte is written anywhere
    try:
        for path, data in items:
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


STALE_SECONDS = 60.0  # a temporary file of a save this old is a killed save's (a save writes and renames at once)


def _sweep_stale(folder: Path, name: str) -> None:
    """Remove the temporary files earlier saves of ``name`` left in ``folder`` when killed mid-way
    (``.NAME.*.tmp`` older than :data:`STALE_SECONDS`)."""
    now = time.time()
    try:
        for tmp in folder.glob(f".{glob.escape(name)}.*.tmp"):
            try:
                if now - tmp.lstat().st_mtime > STALE_SECONDS and tmp.is_file():
                    tmp.unlink()
            except OSError:
                pass
    except OSError:
        pass


def _stage(path: Path, data: bytes) -> str:
    """Write ``data`` to a new temporary file beside ``path``, flushed to disk;
    its name. On failure nothing is left and a one-line FlatweaveError says why.
    A killed save's stale temporary files of the same name go first."""
    folder = path.parent if str(path.parent) else Path(".")
    _sweep_stale(folder, path.name)
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


ARRAY_DTYPES = ("<f8", "<f4", "<i4", "<i8", "|u1")
"""The element types an encoded array may have: little-endian float64, float32, int32, int64, and bytes."""


def encode_array(a, dtype: str) -> dict:
    """``a`` as a JSON object holding it compactly: ``{"dtype": dtype, "shape": [...], "zlib_base64": TEXT}``,
    TEXT the base64 of the zlib-compressed (level 6) bytes of ``a`` in ``dtype`` (one of :data:`ARRAY_DTYPES`),
    C order. Decoded by :func:`decode_array` or, anywhere, by ``numpy.frombuffer(zlib.decompress(
    base64.b64decode(TEXT)), dtype).reshape(shape)``. A value that is not finite is a ValueError (JSON would
    refuse it too)."""
    import base64
    import zlib

    if dtype not in ARRAY_DTYPES:
        raise ValueError(f"an encoded array's dtype is one of {', '.join(ARRAY_DTYPES)}, not {dtype!r}")
    arr = np.ascontiguousarray(np.asarray(a), dtype=np.dtype(dtype))
    if arr.dtype.kind == "f" and not np.isfinite(arr).all():
        raise ValueError("an array to encode holds a number that is not finite (NaN or infinity)")
    return {"dtype": dtype, "shape": list(arr.shape),
            "zlib_base64": base64.b64encode(zlib.compress(arr.tobytes(), 6)).decode("ascii")}


def decode_array(value, what: str, error=FlatweaveError) -> np.ndarray:
    """The array a file holds as ``value``: a JSON list (nested lists of numbers, the older form) or an
    :func:`encode_array` object. A one-line ``error`` naming ``what`` for anything else: an unknown dtype,
    a shape that is not whole numbers, data that does not decompress to exactly that many elements (read
    no further than that, so a small file cannot expand to a large one)."""
    import base64
    import binascii
    import zlib

    if isinstance(value, list):
        try:
            return np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise error(f"{what} must be numbers") from None
    if not isinstance(value, dict) or value.get("dtype") not in ARRAY_DTYPES \
            or not isinstance(value.get("shape"), list) or not isinstance(value.get("zlib_base64"), str):
        raise error(f"{what} must be a list of numbers or an encoded array ({{dtype, shape, zlib_base64}})")
    shape = value["shape"]
    if len(shape) > 4 or not all(isinstance(k, int) and not isinstance(k, bool) and 0 <= k < 2 ** 40 for k in shape):
        raise error(f"{what}: an encoded array's shape must be up to four whole numbers")
    dtype = np.dtype(value["dtype"])
    size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if size > READ_LIMITS["mesh"]:
        raise error(f"{what}: an encoded array of {size / MB:,.0f} MB is past what a file may hold")
    try:
        raw = zlib.decompressobj().decompress(base64.b64decode(value["zlib_base64"], validate=True), size + 1)
    except (binascii.Error, zlib.error, ValueError):
        raise error(f"{what}: its encoded data is damaged (not base64 of zlib data)") from None
    if len(raw) > size:
        raise error(f"{what}: its encoded data holds more than the {size:,} bytes its shape and dtype ask for")
    if len(raw) < size:
        raise error(f"{what}: its encoded data holds {len(raw):,} bytes, its shape and dtype ask for {size:,}")
    return np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
