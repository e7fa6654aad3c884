"""Reading and writing NURBS surfaces in geomdl's JSON exchange format.

The file format is the one ``geomdl.exchange.export_json`` writes for a single
surface::

    {"shape": {"type": "surface", "count": 1, "data": [{
        "type": "spline", "rational": true, "dimension": 3,
        "degree_u": 2, "degree_v": 1,
        "knotvector_u": [...], "knotvector_v": [...],
        "size_u": 3, "size_v": 2,
        "control_points": {"points": [[x, y, z], ...], "weights": [...]}}]}}

Control points are listed with v varying fastest: point ``[i, j]`` of the
(size_u, size_v) net is entry ``i * size_v + j``. ``points`` are Cartesian
(not multiplied by the weight); ``weights`` is optional (absent: all 1) and is
used whenever present, as geomdl does, whatever ``rational`` says. ``count``,
``rational``, ``dimension`` and the entry's ``type`` are optional, but checked
when present; ``delta``, ``name``, ``id`` and ``reversed`` are ignored.

Decisions about inputs geomdl would also accept:

- 2D control points ``[x, y]`` (geomdl's ``dimension: 2``) are read as a flat
  surface in the plane z = 0. Any other number of coordinates is an error.
- Knot vectors are kept as written. geomdl's importer rescales them to [0, 1];
  we do not, so parameters and derivative magnitudes are the file's own.
- Trimmed surfaces (a non-empty ``trims`` entry) are refused by
  :func:`load_surface` (ignoring the trim curves would give the wrong piece
  of fabric); :func:`load_trimmed_surface` (the ``.json`` reader's) reads
  them as a surface and its :class:`flatweave.geometry.region.Region`.
- Numbers must be JSON numbers (not strings, not booleans), finite (the
  ``NaN`` / ``Infinity`` literals Python's json accepts are refused, and so
  are overflowing literals such as ``1e999``) and of magnitude at most 1e100,
  so that evaluation cannot overflow. Integers (degrees, sizes) may be written
  as integral floats (``3.0``).

Every problem raises :class:`~flatweave.errors.SurfaceError` with a one-line
message naming the file (or the ``source`` label given) and the problem.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from flatweave.errors import SurfaceError
from flatweave.files import check_json_depth, read_input
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.errors import SettingsError
from flatweave.geometry.region import Region

__all__ = [
    "load_surface",
    "parse_surface_json",
    "surface_from_json_dict",
    "surface_to_json_dict",
    "save_surface",
    "dumps_surface",
]

MAX_ABS_VALUE = 1e100
"""Largest magnitude accepted for a coordinate, knot or weight."""

_TYPE_NAMES = {
    dict: "an object", list: "a list", str: "a string", bool: "a boolean",
    int: "an integer", float: "a number", type(None): "null",
}


# ---------------------------------------------------------------------- messages
def _one_line(text: str, limit: int = 300) -> str:
    """``text`` with line breaks and control characters flattened, cut to ``limit``."""
    flat = re.sub(r"[\x00-\x1f\x7f]+", " ", str(text))
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


def _describe(value: Any) -> str:
    """Short description of a JSON value for messages, e.g. ``a string '3'``."""
    kind = _TYPE_NAMES.get(type(value), type(value).__name__)
    if value is None or isinstance(value, (dict, list)):
        return kind
    shown = repr(value)
    return f"{kind} {shown if len(shown) <= 40 else shown[:37] + '...'}"



def _regular_points(value: list) -> np.ndarray | None:
    """(n, 3) float of a list of points that are all [x, y, z] (or all [x, y], z = 0) of JSON
    numbers, finite and within MAX_ABS_VALUE: the common case, read at once (a 400 x 400 net in
    0.1 s, not 1.4 s point by point); None when anything is off, for the point-by-point reading
    to name it."""
    first = value[0]
    dim = len(first) if type(first) is list else 0
    if dim not in (2, 3) or not all(type(r) is list and len(r) == dim for r in value) \
            or not all(type(x) in (int, float) for r in value for x in r):  # bool and str are not numbers
        return None
    try:
        pts = np.array(value, dtype=float)
    except (OverflowError, ValueError):
        return None
    if not np.isfinite(pts).all() or np.abs(pts).max() > MAX_ABS_VALUE:
        return None
    return pts if dim == 3 else np.column_stack([pts, np.zeros(len(pts))])

class _Reader:
    """Validates one surface record, raising SurfaceError prefixed with ``source``."""

    def __init__(self, source: str, allow_trims: bool = False):
        self.source = _one_line(source, 200)
        self.allow_trims = allow_trims
        self.trims = []  # the record's trim curves, when allowed

    def fail(self, problem: str) -> SurfaceError:
        return SurfaceError(_one_line(f"{self.source}: {problem}", 400))

    # -------------------------------------------------------------- structure
    def obj(self, value: Any, where: str) -> dict:
        if not isinstance(value, dict):
            raise self.fail(f"{where} must be a JSON object, got {_describe(value)}")
        return value

    def key(self, d: dict, key: str, where: str) -> Any:
        if key not in d:
            raise self.fail(f"missing key '{key}' in {where}")
        return d[key]

    def integer(self, value: Any, where: str, minimum: int) -> int:
        ok = type(value) is int or (type(value) is float and math.isfinite(value) and value.is_integer())
        if not ok:
            raise self.fail(f"{where} must be an integer, got {_describe(value)}")
        if abs(value) > 1e9:
            raise self.fail(f"{where} = {value!r} is out of range")
        if value < minimum:
            raise self.fail(f"{where} must be at least {minimum}, got {int(value)}")
        return int(value)

    def number(self, value: Any, where: str) -> float:
        if type(value) not in (int, float):
            raise self.fail(f"{where} must be a number, got {_describe(value)}")
        try:
            x = float(value)
        except OverflowError:
            raise self.fail(f"{where} is a number too large to represent") from None
        if not math.isfinite(x):
            raise self.fail(f"{where} is not a finite number ({value!r}); NaN and Infinity are not allowed")
        if abs(x) > MAX_ABS_VALUE:
            raise self.fail(f"{where} = {x:g} is too large (magnitude above {MAX_ABS_VALUE:g})")
        return x

    def vector(self, value: Any, where: str) -> np.ndarray:
        """(n,) float from a JSON list of numbers."""
        if not isinstance(value, list):
            raise self.fail(f"{where} must be a list of numbers, got {_describe(value)}")
        return np.array([self.number(x, f"{where}[{k}]") for k, x in enumerate(value)], dtype=float)

    def points2(self, value: Any, where: str) -> np.ndarray:
        """(n, 2) float from a JSON list of [u, v] pairs (a trim curve's)."""
        if not isinstance(value, list) or not all(isinstance(r, list) and len(r) == 2 for r in value):
            raise self.fail(f"{where} must be a list of [u, v] pairs, got {_describe(value)}")
        return np.array([[self.number(x, f"{where}[{k}]") for x in r] for k, r in enumerate(value)],
                        dtype=float).reshape(-1, 2)

    def point_list(self, value: Any, where: str) -> np.ndarray:
        """(n, 3) float from a JSON list of [x, y, z] (or [x, y], then z = 0)."""
        if not isinstance(value, list):
            raise self.fail(f"{where} must be a list of [x, y, z] points, got {_describe(value)}")
        if not value:
            raise self.fail(f"{where} is empty: no control points")
        pts = _regular_points(value)
        if pts is not None:
            return pts
        rows = []  # a fault somewhere: read point by point to name it
        dim = None
        for k, row in enumerate(value):
            if not isinstance(row, list):
                raise self.fail(f"{where}[{k}] must be a list [x, y, z], got {_describe(row)}")
            if len(row) not in (2, 3):
                plural = "s" if len(row) != 1 else ""
                raise self.fail(
                    f"{where}[{k}] has {len(row)} coordinate{plural}; control points must be 3D "
                    f"[x, y, z] (or 2D [x, y], read as z = 0)")
            if dim is None:
                dim = len(row)
            elif len(row) != dim:
                raise self.fail(
                    f"{where}[{k}] has {len(row)} coordinates but earlier points have {dim}; "
                    f"control points must all be 3D [x, y, z]")
            rows.append([self.number(x, f"{where}[{k}][{c}]") for c, x in enumerate(row)])
        pts = np.array(rows, dtype=float)
        if dim == 2:
            pts = np.column_stack([pts, np.zeros(len(pts))])
        return pts

    # -------------------------------------------------------------- the record
    def surface(self, doc: Any) -> NurbsSurface:
        doc = self.obj(doc, "the top level")
        shape = self.obj(self.key(doc, "shape", "the top level"), "'shape'")
        kind = self.key(shape, "type", "'shape'")
        if kind != "surface":
            if kind in ("curve", "volume"):
                raise self.fail(f"file holds a {kind}, not a surface (shape.type is '{kind}')")
            raise self.fail(f"shape.type must be 'surface', got {_describe(kind)}")
        data = self.key(shape, "data", "'shape'")
        if not isinstance(data, list):
            raise self.fail(f"shape.data must be a list of surfaces, got {_describe(data)}")
        if "count" in shape:
            count = self.integer(shape["count"], "shape.count", 0)
            if count != len(data):
                raise self.fail(f"shape.count is {count} but shape.data holds {len(data)} "
                                f"entr{'y' if len(data) == 1 else 'ies'}")
        if len(data) > 1:
            raise self.fail(f"file holds {len(data)} surfaces; flatweave reads one surface per file")
        if not data:
            raise self.fail("shape.data is empty: the file holds no surface")
        return self.record(self.obj(data[0], "shape.data[0]"))

    def record(self, rec: dict) -> NurbsSurface:
        where = "shape.data[0]"
        if "type" in rec and rec["type"] != "spline":
            raise self.fail(f"{where}.type must be 'spline', got {_describe(rec['type'])}")
        if "rational" in rec and not isinstance(rec["rational"], bool):
            raise self.fail(f"{where}.rational must be true or false, got {_describe(rec['rational'])}")
        if "trims" in rec:
            tdata = self.obj(rec["trims"], "trims").get("data", [])
            if not isinstance(tdata, list):
                raise self.fail(f"trims.data must be a list, got {_describe(tdata)}")
            if tdata and not self.allow_trims:
                raise self.fail("trimmed surfaces are not supported (the file has trim curves)")
            self.trims = list(tdata)

        deg = {d: self.integer(self.key(rec, f"degree_{d}", where), f"degree_{d}", 1) for d in "uv"}
        size = {d: self.integer(self.key(rec, f"size_{d}", where), f"size_{d}", 1) for d in "uv"}
        raw_knots = {d: self.key(rec, f"knotvector_{d}", where) for d in "uv"}
        cp = self.obj(self.key(rec, "control_points", where), "control_points")
        raw_points = self.key(cp, "points", "control_points")

        for d in "uv":
            if size[d] < deg[d] + 1:
                raise self.fail(
                    f"degree_{d} {deg[d]} is too high for size_{d} = {size[d]} control points "
                    f"(degree {deg[d]} needs at least {deg[d] + 1})")
        n_pts = size["u"] * size["v"]
        if isinstance(raw_points, list) and len(raw_points) != n_pts:
            raise self.fail(
                f"control point count mismatch: {len(raw_points)} points but size_u * size_v = "
                f"{size['u']} * {size['v']} = {n_pts}")
        pts = self.point_list(raw_points, "control_points.points")
        if "dimension" in rec:
            dim = self.integer(rec["dimension"], "dimension", 1)
            given = len(raw_points[0])
            if dim != given:
                raise self.fail(f"dimension is {dim} but control points have {given} coordinates")

        weights = None
        if "weights" in cp:
            weights = self.vector(cp["weights"], "control_points.weights")
            if weights.size != n_pts:
                raise self.fail(
                    f"weight count mismatch: {weights.size} weights for {n_pts} control points")
            bad = np.flatnonzero(weights <= 0)
            if bad.size:
                raise self.fail(
                    f"weights must be positive; control_points.weights[{bad[0]}] = {weights[bad[0]]:g}")

        knots = {}
        for d in "uv":
            k = self.vector(raw_knots[d], f"knotvector_{d}")
            need = size[d] + deg[d] + 1
            if k.size != need:
                raise self.fail(
                    f"knotvector_{d} has {k.size} knots; size_{d} = {size[d]} with degree_{d} = {deg[d]} "
                    f"needs {need}")
            dec = np.flatnonzero(np.diff(k) < 0)
            if dec.size:
                i = int(dec[0])
                raise self.fail(
                    f"knotvector_{d} is not in non-decreasing order: knot [{i}] = {k[i]:g} > "
                    f"knot [{i + 1}] = {k[i + 1]:g}")
            knots[d] = k

        nu, nv = size["u"], size["v"]
        try:
            return NurbsSurface(deg["u"], deg["v"], knots["u"], knots["v"],
                                pts.reshape(nu, nv, 3),
                                None if weights is None else weights.reshape(nu, nv))
        except SurfaceError as exc:
            raise self.fail(str(exc)) from None


# ---------------------------------------------------------------------- reading
def surface_from_json_dict(d: Any, source: str = "surface data") -> NurbsSurface:
    """Build a :class:`NurbsSurface` from an already parsed geomdl JSON document.

    Parameters
    ----------
    d : the object ``json.load`` returned (``{"shape": {...}}``)
    source : label used at the start of error messages (a file name)

    Raises
    ------
    SurfaceError : one line, ``"<source>: <problem>"``
    """
    return _Reader(source).surface(d)


def parse_surface_json(data: bytes | str, source: str = "surface data") -> NurbsSurface:
    """Parse geomdl JSON text (bytes or str) into a :class:`NurbsSurface`.

    Bytes must be UTF-8 (a leading byte-order mark is allowed). Raises
    :class:`SurfaceError` (one line, starting with ``source``) for every
    problem: empty input, binary data, invalid JSON (with line and column),
    and everything :func:`surface_from_json_dict` checks.
    """
    return _parse(data, _Reader(source))


def _parse(data, reader: "_Reader") -> NurbsSurface:
    if isinstance(data, (bytes, bytearray, memoryview)):
        raw = bytes(data)
        if not raw.strip():
            raise reader.fail("file is empty" if not raw else "file is empty (only whitespace)")
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise reader.fail(
                f"file is binary or not UTF-8 text, not JSON (byte 0x{raw[exc.start]:02x} at offset {exc.start})"
            ) from None
    elif isinstance(data, str):
        text = data[1:] if data.startswith("\ufeff") else data
    else:
        raise TypeError(f"parse_surface_json expects bytes or str, got {type(data).__name__}")
    if not text.strip():
        raise reader.fail("file is empty" if not text else "file is empty (only whitespace)")
    nul = text.find("\x00")
    if nul >= 0:
        raise reader.fail(f"file is binary (NUL byte at offset {nul}), not JSON text")
    check_json_depth(text.encode("utf-8", "surrogatepass"), reader.source, "NURBS surface file", SurfaceError)
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise reader.fail(f"not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})") from None
    except RecursionError:
        raise reader.fail("not usable JSON: nested too deeply") from None
    except ValueError as exc:  # e.g. an integer literal with too many digits
        raise reader.fail(f"not usable JSON: {exc}") from None
    return reader.surface(doc)


def load_surface(path: str | os.PathLike) -> NurbsSurface:
    """Read a single NURBS surface from a geomdl JSON file.

    Parameters
    ----------
    path : file name

    Returns
    -------
    NurbsSurface

    Raises
    ------
    SurfaceError : one line naming the file and the problem, for a file that
        cannot be read or does not hold exactly one valid untrimmed surface.
    """
    name, raw = _read_bytes(path)
    return parse_surface_json(raw, source=name)


def _read_bytes(path) -> tuple[str, bytes]:
    """(the path as given, the file's bytes); a one-line SurfaceError when it cannot be read."""
    name = os.fspath(path)
    return name, read_input(name, "surface", SurfaceError)


def load_trimmed_surface(path: str | os.PathLike):
    """``(surface, region)`` of a geomdl JSON file whose surface may have trim
    curves (``trims``); region is None without them (the whole domain), else
    a :class:`flatweave.geometry.region.Region`.

    Each trim is a closed loop: a ``spline`` curve (degree, knotvector,
    control_points with optional weights, in (u, v)), a ``freeform`` polyline
    (``points``) or a ``container`` of such curves chained end to end (each
    curve's start is a corner); ``reversed`` (geomdl's trim sense) reverses
    it. As in STEP and OpenNURBS, a counter-clockwise loop bounds the piece
    and a clockwise one is a hole; without a counter-clockwise loop the outer
    loop is the domain's edge. Curves are sampled at 64 points a knot span.
    """
    name, raw = _read_bytes(path)
    reader = _Reader(name, allow_trims=True)
    surface = _parse(raw, reader)
    if not reader.trims:
        return surface, None
    loops, corners = [], []
    for k, t in enumerate(reader.trims):
        pts, starts = _trim_loop(reader, reader.obj(t, f"trims.data[{k}]"), f"trims.data[{k}]")
        loops.append(pts)
        corners.append(starts)
    area = [0.5 * float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1)))
            for p in loops]
    outer = [k for k, a in enumerate(area) if a > 0]
    if len(outer) > 1:
        raise reader.fail(f"the trims have {len(outer)} outer (counter-clockwise) loops: flatweave reads one "
                          f"piece per surface")
    if outer:
        order = outer + [k for k in range(len(loops)) if k not in outer]
        out_loops, out_corners = [loops[k] for k in order], [corners[k] for k in order]
    else:
        (u0, u1), (v0, v1) = surface.domain
        out_loops = [np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])] + loops
        out_corners = [[0, 1, 2, 3]] + corners
    try:
        region = Region.from_loops(out_loops[0], out_loops[1:], corners=out_corners)
    except SettingsError as exc:
        raise reader.fail(f"trims: {exc}") from None
    return surface, region


def _trim_curve(reader: "_Reader", c: dict, where: str) -> np.ndarray:
    kind = c.get("type", "spline")
    if kind == "freeform":
        pts = reader.points2(reader.key(c, "points", where), f"{where}.points")
    elif kind == "spline":
        from scipy.interpolate import BSpline
        p = reader.integer(reader.key(c, "degree", where), f"{where}.degree", 1)
        knots = reader.vector(reader.key(c, "knotvector", where), f"{where}.knotvector")
        cp = reader.obj(reader.key(c, "control_points", where), f"{where}.control_points")
        P = reader.points2(reader.key(cp, "points", f"{where}.control_points"), f"{where}.control_points.points")
        w = reader.vector(cp["weights"], f"{where}.control_points.weights") if "weights" in cp else np.ones(len(P))
        if len(knots) != len(P) + p + 1 or len(w) != len(P) or np.any(np.diff(knots) < 0) or np.any(w <= 0):
            raise reader.fail(f"{where}: a spline trim needs len(knotvector) = points + degree + 1, "
                              f"non-decreasing knots and positive weights")
        spans = np.unique(knots[p:len(P) + 1])
        t = np.unique(np.concatenate([np.linspace(a, b, 65) for a, b in zip(spans[:-1], spans[1:])]))
        h = BSpline(knots, np.column_stack([P * w[:, None], w]), p)(t)
        pts = h[:, :2] / h[:, 2:]
    else:
        raise reader.fail(f"{where}.type must be 'spline' or 'freeform', got {_describe(kind)}")
    if len(pts) < 2:
        raise reader.fail(f"{where} has fewer than 2 points")
    return pts[::-1] if c.get("reversed") in (1, True) else pts


def _trim_loop(reader: "_Reader", t: dict, where: str):
    """(points (n, 2), corner indices) of one trim loop."""
    if t.get("type") == "container":
        data = reader.key(t, "data", where)
        if not isinstance(data, list) or not data:
            raise reader.fail(f"{where}.data must be a non-empty list of curves")
        curves = [_trim_curve(reader, reader.obj(c, f"{where}.data[{i}]"), f"{where}.data[{i}]")
                  for i, c in enumerate(data)]
        if t.get("reversed") in (1, True):
            curves = [c[::-1] for c in curves[::-1]]
    else:
        curves = [_trim_curve(reader, t, where)]
    starts, pieces, n = [], [], 0
    for c in curves:
        starts.append(n)
        pieces.append(c[:-1])
        n += len(c) - 1
    pts = np.vstack(pieces)
    if not np.allclose(curves[-1][-1], curves[0][0], atol=1e-6 * max(1.0, float(np.ptp(pts, axis=0).max()))):
        raise reader.fail(f"{where}: the trim loop is not closed (it ends away from its start)")
    return pts, (starts if len(curves) > 1 else None)


# ---------------------------------------------------------------------- writing
def surface_to_json_dict(surface: NurbsSurface) -> dict:
    """The geomdl JSON document of ``surface`` (plain Python lists and floats).

    Weights are written, and ``rational`` is true, unless every weight is 1.
    """
    nu, nv = surface.shape
    w = np.asarray(surface.weights, dtype=float)
    rational = bool(np.any(w != 1.0))
    cp: dict[str, Any] = {"points": surface.ctrlpts.reshape(nu * nv, 3).tolist()}
    if rational:
        cp["weights"] = w.reshape(nu * nv).tolist()
    rec = {
        "type": "spline",
        "rational": rational,
        "dimension": 3,
        "degree_u": int(surface.degree_u),
        "degree_v": int(surface.degree_v),
        "knotvector_u": np.asarray(surface.knots_u, dtype=float).tolist(),
        "knotvector_v": np.asarray(surface.knots_v, dtype=float).tolist(),
        "size_u": int(nu),
        "size_v": int(nv),
        "control_points": cp,
    }
    return {"shape": {"type": "surface", "count": 1, "data": [rec]}}


_NUMBER_LIST = re.compile(r"\[([^\[\]{}\"]*)\]")


def dumps_surface(surface: NurbsSurface) -> str:
    """geomdl JSON text of ``surface``: indented, one control point per line.

    Floats are written with ``repr`` precision, so reading the text back gives
    bit-identical arrays.
    """
    text = json.dumps(surface_to_json_dict(surface), indent=2, allow_nan=False)
    # put every innermost list of numbers on one line
    return _NUMBER_LIST.sub(lambda m: "[" + " ".join(m.group(1).split()) + "]", text) + "\n"


def save_surface(surface: NurbsSurface, path: str | os.PathLike) -> None:
    """Write ``surface`` to ``path`` in geomdl's JSON format (UTF-8).

    ``geomdl.exchange.import_json`` reads the file (it rescales the knot
    vectors to [0, 1]); :func:`load_surface` gives back identical arrays.
    The file is written to a temporary name first and then renamed, so an
    existing file is never left half-written. Raises ``OSError`` when the
    file cannot be written.
    """
    if not isinstance(surface, NurbsSurface):
        raise TypeError(f"save_surface expects a NurbsSurface, got {type(surface).__name__}")
    target = Path(path)
    text = dumps_surface(surface)
    tmp = target.with_name(target.name + ".tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()
