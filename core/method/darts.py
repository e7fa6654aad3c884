"""Darts (paper section 3.4): cuts in the spring mesh that release strain.

A dart removes the springs that cross it; their end nodes become positive
and negative dart nodes (by the side of the dart they lie on). During
minimisation a node may not pass through a dart (it is deleted, 3.3), and no
spring is formed across a dart when nodes are refilled.

* :class:`PlaneDart`: the intersection of a plane a x + b y + c z + d = 0 with
  the surface inside a bounding box. A spring crosses it when one end is in
  the box and the plane function changes sign between its ends (the paper's
  test, F[node1] F[node2] < 0).
* :class:`CurveDart`: a curve on the surface given by its (u, v) polyline
  (the biarc fit of a curve drawn in a view and projected onto the surface,
  :mod:`flatweave.geometry.curves`). The crossing test runs in the (u, v) domain, springs
  taken as straight segments there.

Both describe their curve on the surface from the mouth (the end on the
region's boundary, if any) to the tip, which the pattern needs to open the
dart into a V.

A dart also carries labels that never change a solve: its ``name`` and
whether it is drawn (``visible``). A curve dart drawn in the app keeps the
points the designer placed (``handles``, their (u, v)) and the direction it was
projected along (``view_dir``), so it can be edited and rebuilt
(:func:`curve_dart_through`).

Both kinds follow one protocol (:class:`Dart`): the crossing test
(``crosses``), the side of a node (``side``), the curve in (u, v)
(``curve_uv``), the file form (``to_dict`` / ``from_dict``) and flags the
callers branch on instead of the kind's name (``needs_xyz``,
``editable_points``, ``has_widget``). :data:`DART_KINDS` maps the ``kind``
string of files to the class; a new kind is a class and an entry there.
"""

from __future__ import annotations

import os
import weakref
from dataclasses import dataclass, field
from typing import Any

import math

import numpy as np

from flatweave.errors import SettingsError
from flatweave.files import parse_json, read_input
from flatweave.geometry.numerics import cumulative_length, interp_rows, nearest_segment, polyline_distance
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.nurbs import boundary_distance
from flatweave.geometry.curves import fit_biarcs, project_polyline

__all__ = ["Dart", "DART_KINDS", "RESULT_DART_KEYS", "CUT_DART_KEYS", "dart_from_dict", "PlaneDart", "CurveDart",
           "segments_cross", "segments_cross_brute", "SegmentGrid", "DartSet", "curve_dart", "curve_dart_from_file",
           "curve_dart_through", "dart_handles"]


def _orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Twice the signed area of triangles (a, b, c), row-wise (k, 2) -> (k,)."""
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def segments_cross(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray,
                   grid: "SegmentGrid | None" = None) -> np.ndarray:
    """(m,) bool: does segment p (m, 2) cross the polyline of segments q (k, 2)?

    A crossing needs the ends of p strictly on opposite sides of a dart
    segment (a node lying exactly on the dart counts as on its positive
    side, so the spring is cut on one side only) and the dart segment to
    reach p (its end points touching p count: a dart ending exactly on a
    spring cuts it).

    Only the pairs whose bounding boxes touch are tested (two segments that
    meet share a point of both boxes), found through a uniform grid over the
    dart (``grid``, a :class:`SegmentGrid` of q, kept by a dart between
    calls; built here if not given). :func:`segments_cross_brute` tests
    every pair; the two agree wherever the orientation signs are those of
    exact arithmetic (rounding can make colinear, disjoint segments "cross"
    in the brute force; their boxes do not touch).
    """
    m = len(p0)
    out = np.zeros(m, dtype=bool)
    if m == 0 or len(q0) == 0:
        return out
    g = grid if grid is not None else SegmentGrid(q0, q1)
    # only springs near the dart's extent (a NaN end is never near); column by column, as
    # np.all(axis=1) over (m, 2) costs 6x more
    (x0, y0), (x1, y1), (lx, ly), (hx, hy) = p0.T, p1.T, g.lo, g.hi
    near = np.flatnonzero(((x0 >= lx) | (x1 >= lx)) & ((y0 >= ly) | (y1 >= ly))
                          & ((x0 <= hx) | (x1 <= hx)) & ((y0 <= hy) | (y1 <= hy)))
    if near.size == 0:
        return out
    if near.size * len(q0) <= _DENSE_PAIRS:
        out[near] = _cross_dense(p0[near], p1[near], q0, q1)
        return out
    a, b = p0[near], p1[near]
    plo, phi = np.minimum(a, b), np.maximum(a, b)
    size = np.max(phi - plo, axis=1)
    e = g.level(float(np.median(size)))
    c = 2.0 ** e
    i0, i1 = g.cell(plo, c), g.cell(phi, c)
    w = i1 - i0 + 1
    many = w[:, 0] * w[:, 1] > _MAX_CELLS  # a spring as long as the dart: every segment, as before
    if many.any():
        idx = near[many]
        out[idx] = _cross_dense(p0[idx], p1[idx], q0, q1)
    few = np.flatnonzero(~many)
    item, key = _expand(i0[few], w[few], g.shape(c)[1])
    skey, sseg = g.table(e)
    left = np.searchsorted(skey, key, "left")
    cnt = np.searchsorted(skey, key, "right") - left
    spr = few[np.repeat(item, cnt)]
    seg = sseg[np.repeat(left, cnt) + _ramp(cnt)]
    key = np.repeat(key, cnt)
    # each touching pair once: in the cell of its boxes' common lower corner
    slo, shi, qlo, qhi = plo[spr], phi[spr], g.qlo[seg], g.qhi[seg]
    corner = g.cell(np.maximum(slo, qlo), c)
    ny = g.shape(c)[1]
    touch = ((corner[:, 0] * ny + corner[:, 1]) == key) & (slo[:, 0] <= qhi[:, 0]) & (slo[:, 1] <= qhi[:, 1]) \
        & (shi[:, 0] >= qlo[:, 0]) & (shi[:, 1] >= qlo[:, 1])
    spr, seg = spr[touch], seg[touch]
    hit = _cross_pairs(a[spr], b[spr], q0[seg], q1[seg])
    out[near[spr[hit]]] = True
    return out


_DENSE_PAIRS = 20_000  # below this many (spring, segment) pairs the grid costs more than it saves
_MAX_CELLS = 64


def _cross_pairs(a, b, c, d) -> np.ndarray:
    """The crossing test of segment pairs (a, b) x (c, d), row by row (broadcasting)."""
    sa = _orient(c, d, a) >= 0
    sb = _orient(c, d, b) >= 0
    oc = _orient(a, b, c)
    od = _orient(a, b, d)
    return (sa != sb) & (oc * od <= 0) & ~((oc == 0) & (od == 0))


def _cross_dense(p0, p1, q0, q1) -> np.ndarray:
    """(m,) every segment p against every segment q, in chunks of bounded memory."""
    out = np.zeros(len(p0), dtype=bool)
    step = max(1, 2_000_000 // max(len(q0), 1))
    for s in range(0, len(p0), step):
        hit = _cross_pairs(p0[s:s + step, None, :], p1[s:s + step, None, :], q0[None], q1[None])
        out[s:s + step] = hit.any(axis=1)
    return out


def segments_cross_brute(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """:func:`segments_cross` testing every pair (within the dart's bounding box): the reference."""
    out = np.zeros(len(p0), dtype=bool)
    if len(p0) == 0 or len(q0) == 0:
        return out
    lo, hi = np.minimum(q0, q1).min(axis=0), np.maximum(q0, q1).max(axis=0)
    near = np.flatnonzero(np.all(np.maximum(p0, p1) >= lo, axis=1) & np.all(np.minimum(p0, p1) <= hi, axis=1))
    out[near] = _cross_dense(p0[near], p1[near], q0, q1)
    return out


def _ramp(cnt: np.ndarray) -> np.ndarray:
    """0, 1, .., cnt[0] - 1, 0, 1, .., cnt[1] - 1, ...: positions within runs of lengths cnt."""
    total = int(cnt.sum())
    return np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)


def _expand(i0: np.ndarray, w: np.ndarray, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """(item, key): every cell of the boxes from cell i0 (n, 2) spanning w (n, 2) cells, keyed ix * ny + iy."""
    cnt = w[:, 0] * w[:, 1]
    item = np.repeat(np.arange(len(i0)), cnt)
    r = _ramp(cnt)
    wy = w[item, 1]
    return item, (i0[item, 0] + r // wy) * ny + i0[item, 1] + r % wy


class SegmentGrid:
    """The segments q0 -> q1 (k, 2) of a dart, binned in uniform grids of
    cell size 2**e over their bounding box (one table per e, made when first
    asked): the candidates of :func:`segments_cross`."""

    def __init__(self, q0: np.ndarray, q1: np.ndarray):
        self.qlo, self.qhi = np.minimum(q0, q1), np.maximum(q0, q1)
        self.lo, self.hi = self.qlo.min(axis=0), self.qhi.max(axis=0)
        ext = float(np.max(self.hi - self.lo))
        seg = float(np.median(np.max(self.qhi - self.qlo, axis=1)))
        # cells no smaller than a typical dart segment (nor than a 4096th of the dart)
        self._floor = self._exp(max(seg, ext / 4096, 1e-300))
        self._tables: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._shapes: dict[float, tuple[int, int]] = {}

    @staticmethod
    def _exp(x: float) -> int:
        return int(np.ceil(np.log2(x))) if x > 0 and np.isfinite(x) else -1074

    def level(self, size: float) -> int:
        """The grid (its exponent) for items of typical extent ``size``."""
        return max(self._floor, self._exp(size) if size > 0 else self._floor)

    def shape(self, c: float) -> tuple[int, int]:
        """(nx, ny): the grid's cells along u and v at cell size c (a power of two)."""
        hit = self._shapes.get(c)
        if hit is None:
            n = np.floor((self.hi - self.lo) / c).astype(np.int64) + 1
            hit = self._shapes[c] = (int(n[0]), int(n[1]))
        return hit

    def cell(self, x: np.ndarray, c: float) -> np.ndarray:
        """(n, 2) int: the cells of points x (n, 2), clamped to the grid (a box
        reaching beyond the dart's box keeps every cell it shares with it)."""
        nx, ny = self.shape(c)
        i = np.floor((x - self.lo) / c)
        np.clip(i[:, 0], 0, nx - 1, out=i[:, 0])
        np.clip(i[:, 1], 0, ny - 1, out=i[:, 1])
        return i.astype(np.int64)

    def table(self, e: int) -> tuple[np.ndarray, np.ndarray]:
        """(keys, segments): every (cell, segment) of grid e, sorted by cell."""
        hit = self._tables.get(e)
        if hit is None:
            c = 2.0 ** e
            i0 = self.cell(self.qlo, c)
            seg, key = _expand(i0, self.cell(self.qhi, c) - i0 + 1, self.shape(c)[1])
            order = np.argsort(key, kind="stable")
            hit = self._tables[e] = (key[order], seg[order])
        return hit


class Dart:
    """What every kind of dart provides (PlaneDart, CurveDart).

    kind : the kind's name in files (a key of :data:`DART_KINDS`)
    name, visible : labels that never change a solve
    needs_xyz : the crossing test and the side need the nodes on the surface
        (``xa``, ``xb``, ``xyz``), not only their (u, v)
    editable_points : the dart is edited by dragging its drawn (u, v) points
    has_widget : the dart is edited by a 3D widget (a plane and its box)

    crosses(uva, uvb, xa, xb) -> (m,) bool : springs from a to b crossing it
    side(uv, xyz) -> (n,) int8 : +1 / -1, the side of the dart a node is on
    curve_uv(surface, n) -> (k, 2) : its curve in (u, v), mouth to tip
    to_dict(keys=None) -> dict : the file form (all fields, or only ``keys``)
    from_dict(item, read, what, name, visible) : the inverse (a classmethod;
        ``read`` supplies typed reads with one-line errors, see
        :func:`dart_from_dict`)
    """

    kind: str
    name: str
    visible: bool
    needs_xyz: bool = False
    editable_points: bool = False
    has_widget: bool = False

    def crosses(self, uva, uvb, xa, xb) -> np.ndarray:
        raise NotImplementedError

    def side(self, uv, xyz) -> np.ndarray:
        raise NotImplementedError

    def curve_uv(self, surface: NurbsSurface, n: int = 256) -> np.ndarray:
        raise NotImplementedError

    def _fields(self) -> dict:
        """The kind's own entries of the file form, between ``name`` and ``visible``."""
        raise NotImplementedError

    def to_dict(self, keys=None) -> dict:
        """The dart as a JSON object: kind, name, the kind's fields, visible
        (project files); ``keys`` keeps only those (in this order), e.g.
        :data:`RESULT_DART_KEYS` for result files, :data:`CUT_DART_KEYS` for
        what decides the cut."""
        out = {"kind": self.kind, "name": self.name, **self._fields(), "visible": bool(self.visible)}
        return out if keys is None else {k: v for k, v in out.items() if k in keys}


RESULT_DART_KEYS = ("kind", "name", "plane", "box", "uv", "auto")
"""A dart's entries in a result file's settings (no labels beyond its name)."""
CUT_DART_KEYS = ("kind", "plane", "box", "uv")
"""What a dart's cut depends on."""


@dataclass(frozen=True)
class PlaneDart(Dart):
    """plane : (a, b, c, d); box : (xmin, xmax, ymin, ymax, zmin, zmax) or None (no limit);
    name, visible : labels (see the module docstring)."""

    plane: tuple[float, float, float, float]
    box: tuple[float, float, float, float, float, float] | None = None
    name: str = "plane dart"
    kind: str = field(default="plane", init=False)
    visible: bool = True
    needs_xyz = True  # the plane function is evaluated at the nodes on the surface
    has_widget = True

    def __post_init__(self):
        _check_labels(self)
        p = np.asarray(self.plane, dtype=float)
        if p.shape != (4,) or not np.all(np.isfinite(p)) or not np.any(p[:3]):
            raise SettingsError(f"plane dart {self.plane!r} must be four numbers A,B,C,D with (A,B,C) != 0")
        if self.box is not None:
            b = np.asarray(self.box, dtype=float)
            if b.shape != (6,) or not np.all(np.isfinite(b)) or np.any(b[0::2] > b[1::2]):
                raise SettingsError(f"plane dart box {self.box!r} must be XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX")

    def _fields(self) -> dict:
        return {"plane": [float(x) for x in self.plane],
                "box": None if self.box is None else [float(x) for x in self.box]}

    @classmethod
    def from_dict(cls, item: dict, read, what: str, name: str, visible: bool) -> "PlaneDart":
        box = item.get("box")
        return cls(read.numbers(read.get(item, "plane", what), 4, f"{what}.plane"),
                   None if box is None else read.numbers(box, 6, f"{what}.box"), name=name, visible=visible)

    def F(self, xyz: np.ndarray) -> np.ndarray:
        """The plane function at ``xyz``, scaled by the normal's largest component (the same plane and
        sides; coefficients like 1e308 do not overflow)."""
        p = np.asarray(self.plane, dtype=float)
        p = p / np.abs(p[:3]).max()
        return xyz @ p[:3] + p[3]

    def in_box(self, xyz: np.ndarray) -> np.ndarray:
        if self.box is None:
            return np.ones(len(xyz), dtype=bool)
        b = self.box  # column by column: np.all(axis=1) over (m, 3) costs several times more
        x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
        return (x >= b[0]) & (x <= b[1]) & (y >= b[2]) & (y <= b[3]) & (z >= b[4]) & (z <= b[5])

    def crosses(self, uva, uvb, xa, xb) -> np.ndarray:
        """(m,) bool: springs from a to b crossing the dart: one end in the box
        and the ends on opposite sides of the plane. The paper's test is
        F[a] F[b] < 0; here a point on the plane (F = 0) counts as on its
        positive side, as for curve darts, so a node on the dart keeps the
        springs to one side only and stepping off to the other side crosses."""
        return (self.in_box(xa) | self.in_box(xb)) & ((self.F(xa) >= 0) != (self.F(xb) >= 0))

    def side(self, uv, xyz) -> np.ndarray:
        """(n,) +1 / -1: the side of the plane (on it counts as +1)."""
        return np.where(self.F(xyz) >= 0, 1, -1).astype(np.int8)

    def curve_uv(self, surface: NurbsSurface, n: int = 256) -> np.ndarray:
        """(k, 2) the dart's curve in (u, v), from the mouth to the tip.

        Zero crossings of F(S(u, v)) on the edges of an n x n parameter grid,
        refined by Newton onto F = 0, kept inside the box, chained into a
        polyline (the longest chain when the plane cuts the surface more than
        once). Remembered per surface (the grid costs about 60 ms; every
        pattern of a piece with the dart needs the curve again).
        """
        per = _curve_cache.get(surface)
        if per is None:
            per = _curve_cache[surface] = {}
        key = (tuple(float(x) for x in self.plane), None if self.box is None else tuple(self.box), int(n))
        hit = per.get(key)
        if hit is None:
            if len(per) >= 64:
                per.clear()
            hit = per[key] = self._curve_uv(surface, n)
        return hit.copy()

    def _curve_uv(self, surface: NurbsSurface, n: int) -> np.ndarray:
        dom = surface.domain
        u = np.linspace(dom[0, 0], dom[0, 1], n)
        v = np.linspace(dom[1, 0], dom[1, 1], n)
        U, V = np.meshgrid(u, v, indexing="ij")
        F = self.F(surface.points(np.column_stack([U.ravel(), V.ravel()]))).reshape(n, n)
        pts = []
        for axis in (0, 1):
            f0 = F[:-1, :] if axis == 0 else F[:, :-1]
            f1 = F[1:, :] if axis == 0 else F[:, 1:]
            i, j = np.nonzero((f0 < 0) != (f1 < 0))
            t = f0[i, j] / (f0[i, j] - f1[i, j])
            if axis == 0:
                pts.append(np.column_stack([u[i] + t * (u[i + 1] - u[i]), v[j]]))
            else:
                pts.append(np.column_stack([u[i], v[j] + t * (v[j + 1] - v[j])]))
        P = np.concatenate(pts) if pts else np.zeros((0, 2))
        if len(P) == 0:
            return P
        P = _newton_onto_level(surface, self.F, P)
        P = P[self.in_box(surface.points(P))]
        return _chain(P, 3.0 * np.max(np.ptp(dom, axis=1)) / n, surface)


_curve_cache: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # NurbsSurface -> {(plane, box, n): uv}


def _check_labels(dart) -> None:
    if not isinstance(dart.name, str):
        raise SettingsError(f"a dart's name must be text, got {dart.name!r:.40}")
    if not isinstance(dart.visible, (bool, np.bool_)):
        raise SettingsError(f"a dart's visibility must be true or false, got {dart.visible!r:.40}")


def _newton_onto_level(surface, F, uv: np.ndarray, steps: int = 6) -> np.ndarray:
    """Move points along the gradient of F(S(u, v)) onto its zero level."""
    dom = surface.domain
    for _ in range(steps):
        S, Su, Sv = surface.derivatives(uv)
        f = F(S)
        grad = np.column_stack([F(S + Su) - F(S), F(S + Sv) - F(S)])  # F is affine
        gg = np.einsum("ij,ij->i", grad, grad)
        ok = gg > 0
        uv[ok] -= (f[ok] / gg[ok])[:, None] * grad[ok]
        uv = np.clip(uv, dom[:, 0], dom[:, 1])
    return uv


def _chain(P: np.ndarray, link: float, surface: NurbsSurface) -> np.ndarray:
    """Order scattered curve points into polylines by nearest neighbours; the
    longest chain, oriented from its end nearest the domain boundary."""
    from scipy.spatial import cKDTree

    P = np.unique(np.round(P, 12), axis=0)
    if len(P) < 2:
        return P
    tree = cKDTree(P)
    unused = np.ones(len(P), dtype=bool)
    chains = []
    while unused.any():
        start = int(np.flatnonzero(unused)[0])
        chain = [start]
        unused[start] = False
        for direction in (0, 1):
            cur = chain[-1] if direction == 0 else chain[0]
            while True:
                d, idx = tree.query(P[cur], k=min(8, len(P)))
                nxt = next((int(j) for dd, j in zip(np.atleast_1d(d), np.atleast_1d(idx))
                            if unused[j] and dd <= link), None)
                if nxt is None:
                    break
                unused[nxt] = False
                if direction == 0:
                    chain.append(nxt)
                else:
                    chain.insert(0, nxt)
                cur = nxt
        chains.append(chain)
    best = P[max(chains, key=len)]
    if boundary_distance(surface, best[-1:])[0] < boundary_distance(surface, best[:1])[0]:
        best = best[::-1]
    return best


@dataclass(frozen=True)
class CurveDart(Dart):
    """A dart along a (u, v) polyline, ordered from its mouth to its tip.

    uv : (k, 2) points of the curve in the parameter domain (k >= 2)
    name, visible : labels (see the module docstring)
    auto : a label: the dart was suggested (:mod:`flatweave.studies.autodarts`), not drawn
    handles : (h, 2) (u, v) of the points the designer placed, in drawing
        order, or None (a dart from a file); h >= 2
    view_dir : (3,) the direction the drawing was projected along, or None
    """

    uv: np.ndarray
    name: str = "curve dart"
    kind: str = field(default="curve", init=False)
    handles: np.ndarray | None = None
    view_dir: tuple[float, float, float] | None = None
    visible: bool = True
    auto: bool = False
    editable_points = True

    def __post_init__(self):
        _check_labels(self)
        uv = np.asarray(self.uv, dtype=float)
        if uv.ndim != 2 or uv.shape[1] != 2 or len(uv) < 2 or not np.all(np.isfinite(uv)):
            raise SettingsError("a curve dart needs at least two finite (u, v) points")
        object.__setattr__(self, "uv", uv)
        if self.handles is not None:
            h = np.asarray(self.handles, dtype=float)
            if h.ndim != 2 or h.shape[1] != 2 or len(h) < 2 or not np.all(np.isfinite(h)):
                raise SettingsError("a curve dart's handles must be at least two finite (u, v) points")
            object.__setattr__(self, "handles", h)
        if self.view_dir is not None:
            d = np.asarray(self.view_dir, dtype=float).reshape(-1)
            if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.linalg.norm(d) > 0:
                raise SettingsError(f"a curve dart's view direction must be a non-zero 3-vector, "
                                    f"got {self.view_dir!r:.60}")
            object.__setattr__(self, "view_dir", tuple(float(x) for x in d))

    def _fields(self) -> dict:
        out = {"uv": np.asarray(self.uv, dtype=float).tolist()}
        if self.handles is not None:
            out["handles"] = np.asarray(self.handles, dtype=float).tolist()
        if self.view_dir is not None:
            out["view_dir"] = [float(x) for x in self.view_dir]
        if self.auto:
            out["auto"] = True
        return out

    @classmethod
    def from_dict(cls, item: dict, read, what: str, name: str, visible: bool) -> "CurveDart":
        pts = read.points(read.get(item, "uv", what), f"{what}.uv")
        handles = item.get("handles")
        view = item.get("view_dir")
        return cls(pts, name=name, visible=visible,
                   handles=None if handles is None else read.points(handles, f"{what}.handles"),
                   view_dir=None if view is None else read.numbers(view, 3, f"{what}.view_dir"),
                   auto=item.get("auto", False) is True)

    def crosses(self, uva, uvb, xa, xb) -> np.ndarray:
        return segments_cross(uva, uvb, self.uv[:-1], self.uv[1:], self._grid())

    def _grid(self) -> SegmentGrid:
        """The dart's segments binned for :func:`segments_cross`, made once (the dart is frozen)."""
        g = self.__dict__.get("_segment_grid")
        if g is None:
            g = SegmentGrid(self.uv[:-1], self.uv[1:])
            object.__setattr__(self, "_segment_grid", g)
        return g

    def side(self, uv, xyz) -> np.ndarray:
        """(n,) +1 / -1: left or right of the nearest dart segment in (u, v)."""
        a, b = self.uv[:-1], self.uv[1:]
        k = nearest_segment(uv, self.uv)
        s = _orient(a[k], b[k], uv)
        return np.where(s >= 0, 1, -1).astype(np.int8)

    def curve_uv(self, surface: NurbsSurface, n: int = 256) -> np.ndarray:
        return self.uv


DART_KINDS: dict[str, type] = {"plane": PlaneDart, "curve": CurveDart}
"""The kinds of dart, by the ``kind`` string of files."""


def dart_from_dict(item: Any, read, what: str) -> Dart:
    """A dart from its file form (:meth:`Dart.to_dict`).

    ``read`` does the typed reads and makes the errors (the project reader,
    :class:`flatweave.document.project._Fields`): ``obj``, ``get``, ``string``, ``numbers``,
    ``points`` and ``fail``; a value a dart refuses (SettingsError) comes back
    as ``read.fail`` naming the entry ``what``.
    """
    item = read.obj(item, what)
    kind = read.get(item, "kind", what)
    name = read.string(item.get("name", f"{kind} dart"), f"{what}.name")
    visible = item.get("visible", True)  # absent in files written before darts could be hidden
    if not isinstance(visible, bool):
        raise read.fail(f"{what}.visible must be true or false, got {visible!r:.40}")
    cls = DART_KINDS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        kinds = " or ".join(repr(k) for k in DART_KINDS)
        raise read.fail(f"{what}.kind must be {kinds}, got {kind!r:.40}")
    try:
        return cls.from_dict(item, read, what, name, visible)
    except SettingsError as exc:
        raise read.fail(f"{what}: {exc}") from None


class DartSet:
    """The darts of a piece, with the operations the mesh and solver need."""

    def __init__(self, surface: NurbsSurface, darts=()):
        self.surface = surface
        self.darts = tuple(darts)

    def __len__(self) -> int:
        return len(self.darts)

    def crossing(self, uva, uvb, xa=None, xb=None) -> np.ndarray:
        """(m,) bool: segments (in uv; their 3D ends for plane darts) crossing any dart.

        xa, xb : the segments' ends on the surface, S(uva) and S(uvb), if the
        caller has them (plane darts need them; they are evaluated otherwise).
        """
        out = np.zeros(len(uva), dtype=bool)
        if not self.darts or len(uva) == 0:
            return out
        if any(d.needs_xyz for d in self.darts):
            xa = self.surface.points(uva) if xa is None else xa
            xb = self.surface.points(uvb) if xb is None else xb
        for d in self.darts:
            out |= d.crosses(uva, uvb, xa, xb)
        return out

    def keep_springs(self, uv: np.ndarray, xyz: np.ndarray | None = None):
        """A ``keep(ends, kind)`` for :func:`flatweave.method.lattice.build_mesh`: drop crossing springs.

        The nodes are put on the surface once (``xyz``, if not given, and only
        for plane darts), not once per spring end."""
        if xyz is None and any(d.needs_xyz for d in self.darts):
            xyz = self.surface.points(uv)

        def keep(ends, kind):
            a, b = ends[:, 0], ends[:, 1]
            xa, xb = (xyz[a], xyz[b]) if xyz is not None else (None, None)
            return ~self.crossing(uv[a], uv[b], xa, xb)
        return keep

    def dart_nodes(self, curves3d, uv: np.ndarray, xyz: np.ndarray, reach: float) -> list[dict]:
        """Per dart, its positive and negative nodes: the nodes along the cut
        (within ``reach``, one cell diagonal, of the dart's curve), by side.

        (The ends of the springs a dart removed, as the paper defines them; a
        node that sat exactly on the dart and stepped off it was deleted, so
        the nodes along the cut are found by distance, not from the springs.)
        """
        out = []
        for d, curve in zip(self.darts, curves3d):
            dist = polyline_distance(xyz, curve)
            near = np.flatnonzero(dist <= reach)
            side = d.side(uv[near], xyz[near]) if len(near) else np.zeros(0, np.int8)
            out.append({"positive": near[side > 0], "negative": near[side < 0]})
        return out


def curve_dart(surface: NurbsSurface, points, view_dir, tol: float | None = None,
               name: str = "curve dart") -> CurveDart:
    """A curve dart from a polyline drawn in a view (paper 3.4 B).

    points (k, 3) are projected onto the surface along view_dir (from the
    camera into the scene), the (u, v) curve is approximated by biarcs within
    ``tol`` (parameter units; default 1/1000 of the domain), and the biarcs
    are sampled densely. An end within 1 % of the domain's size from its edge
    (a drawing that starts beyond the rim ends there, and a grazing view
    locates the rim only roughly) is extended onto the edge; the curve is
    oriented from the end nearer the boundary (the mouth).
    """

    dom = surface.domain
    size = float(np.max(np.ptp(dom, axis=1)))
    proj = project_polyline(surface, points, view_dir)
    biarcs = fit_biarcs(proj.uv, 1e-3 * size if tol is None else tol)
    uv = biarcs.sample(size / 500)
    uv = np.clip(uv, dom[:, 0], dom[:, 1])
    for e in (0, -1):  # ends at the rim go onto it exactly
        t = (uv[e] - dom[:, 0]) / np.ptp(dom, axis=1)
        gap = np.array([t[0], 1 - t[0], t[1], 1 - t[1]])
        k = int(np.argmin(gap))
        if gap[k] < 0.01:
            ax, bound = k // 2, dom[k // 2, k % 2]
            end = uv[e].copy()
            end[ax] = bound
            uv = np.vstack([end, uv]) if e == 0 else np.vstack([uv, end])
    if boundary_distance(surface, uv[-1:])[0] < boundary_distance(surface, uv[:1])[0]:
        uv = uv[::-1]
    return CurveDart(uv, name)


def curve_dart_through(surface: NurbsSurface, handles, view_dir, tol: float | None = None,
                       name: str = "curve dart", visible: bool = True) -> CurveDart:
    """A curve dart through points on the surface: the polyline through
    S(handles) projected along ``view_dir`` and fitted by biarcs
    (:func:`curve_dart`), remembering the handles and the direction.

    handles : (h, 2) (u, v) of points on the surface, in drawing order, h >= 2.
    The points must be seen from ``view_dir`` (nothing of the surface in front
    of them): each is its own projection, so the curve passes through every one.
    """
    h = np.asarray(handles, dtype=float)
    if h.ndim != 2 or h.shape[1] != 2 or len(h) < 2 or not np.all(np.isfinite(h)):
        raise SettingsError("a curve dart needs at least two points on the surface")
    dom = surface.domain
    h = np.clip(h, dom[:, 0], dom[:, 1])
    if np.all(np.ptp(surface.points(h), axis=0) == 0):
        raise SettingsError("a curve dart needs two different points")
    dart = curve_dart(surface, surface.points(h), view_dir, tol=tol, name=name)
    size = float(np.max(np.ptp(dom, axis=1)))
    off = polyline_distance(h, dart.uv) > 5e-3 * size + (0.0 if tol is None else 2.0 * tol)
    if off.any():
        k = int(np.flatnonzero(off)[0]) + 1
        raise SettingsError(f"the dart's point {k} is hidden from this direction or the curve leaves the "
                            "surface before it; turn the view so every point shows")
    d = np.asarray(view_dir, dtype=float).reshape(-1)
    return CurveDart(dart.uv, name=name, handles=h, view_dir=tuple(d / np.linalg.norm(d)), visible=visible)


def dart_handles(surface: NurbsSurface, dart: CurveDart, count: int = 5) -> np.ndarray:
    """(h, 2) handles for editing a curve dart: its own, or (a dart from a file,
    which has none) ``count`` points evenly spaced along it on the surface,
    both ends included."""
    if dart.handles is not None:
        return np.array(dart.handles)
    s = cumulative_length(surface.points(dart.uv))
    if s[-1] <= 0:
        return dart.uv[[0, -1]].copy()
    return interp_rows(np.linspace(0.0, s[-1], count), s, dart.uv)


def curve_dart_from_file(surface: NurbsSurface, path, name: str = "curve dart") -> CurveDart:
    """Read a curve dart file: JSON ``{"points": [[x, y, z], ...], "view_direction":
    [dx, dy, dz], "tolerance": T (optional, parameter units)}``."""
    d = parse_json(read_input(path, "small", SettingsError), os.fspath(path), "curve dart file", SettingsError)
    try:
        points = np.asarray(d["points"], dtype=float)
        view = np.asarray(d["view_direction"], dtype=float)
        tol = d.get("tolerance")
    except OSError as exc:
        raise SettingsError(f"cannot read curve dart {path}: {exc.strerror or exc}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise SettingsError(f"curve dart {path} must be JSON with 'points' (a list of [x, y, z]) and "
                            f"'view_direction' ([dx, dy, dz]): {exc}") from None
    if points.ndim != 2 or points.shape[1] != 3 or view.shape != (3,):
        raise SettingsError(f"curve dart {path}: 'points' must be [[x, y, z], ...] and 'view_direction' [dx, dy, dz]")
    if tol is not None:
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not math.isfinite(tol) or tol <= 0:
            raise SettingsError(f"curve dart {path}: 'tolerance' must be a positive number of parameter units, "
                                f"got {tol!r:.40}")
        tol = float(tol)
    return curve_dart(surface, points, view, tol=tol, name=name)
