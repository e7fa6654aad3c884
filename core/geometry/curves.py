"""Curve darts (paper section 3.4 B): projecting a drawn curve onto the surface
and approximating its (u, v) image by biarcs.

The designer draws a polyline in a 3D view. :func:`project_points` moves every
point P along its viewing line P + t d (d the unit view direction, from the
camera into the scene) to the first place the line meets the surface;
:func:`project_polyline` densifies the drawing first so consecutive projected
points are at most ``max_step`` apart on the surface, and keeps one connected
piece. :func:`fit_biarcs` approximates the resulting (u, v) polyline within a
tolerance by a G1 chain of circular arcs (biarcs), which converts exactly to
degree-2 rational pieces whose control polygons are isosceles triangles.

Projection
----------
All viewing lines are parallel, so the problem lives in the view plane: with
E (2, 3) an orthonormal basis of the plane normal to d, a line meets the
surface at (u, v) when F(u, v) = E (S(u, v) - P) = 0, and then
t = d . (S(u, v) - P). This is Newton in (u, v, t) on S - (P + t d) = 0 with t
eliminated exactly (t enters linearly, so the (u, v) part of the 3x3 Newton
step is the 2x2 step on F and t follows from the update).

Start points come from a coarse tessellation of the surface (a 64 x 64 grid,
cached per surface), projected to the view plane: every triangle containing the
line's trace, and every triangle within a margin of it (the margin bounds how far
the tessellation strays from the surface), gives a start (its nearest point).
The near-miss starts find intersections the flat triangles do not show: near the
silhouette, and between a boundary chord and the curved rim. From each start a
damped Newton (Levenberg-Marquardt, steps projected onto the parameter domain)
drives |F| down; a start counts only if |F| reaches ~1e-12 of the scene size,
so a line that misses converges to a closest approach with |F| > 0 and is a
miss, and a grazing line either converges (linearly, at a double root) or is a
miss - never a point elsewhere. Of the converged starts of a line the one of
smallest t (nearest the camera) wins.

Biarcs
------
Tangents at the data points come from circles through each point and its
neighbours an arc-length h away (exact on circles and lines). The chain is
grown greedily: from a joint, the farthest data point that one biarc reaches
within ``tol`` is found by galloping and bisection; the biarc between two
points with given tangents is the equal-leg one (legs d from each end along the
tangents, the joint in the middle of the two leg ends), so each arc's control
polygon is an isosceles triangle. Consecutive arcs lying on one circle (or
line) are merged, so a circular arc of data is one arc.
"""

from __future__ import annotations

import itertools
import weakref
from dataclasses import dataclass

import numpy as np

from flatweave.errors import SettingsError
from flatweave.geometry.numerics import rowdot as _dot2
from flatweave.geometry.numerics import unit_rows as _unit
from flatweave.geometry.nurbs import NurbsSurface

__all__ = ["Arc2", "Biarcs", "ProjectedCurve", "Projection", "fit_biarcs", "project_points",
           "project_polyline"]

_TESS_N = 64             # tessellation grid points per parameter direction
_CANDIDATES = 12         # Newton starts kept per line (nearest the camera first)
_NEWTON_PLAIN = 16        # plain Newton steps before the damped ones
_NEWTON_MAXIT = 80
_ACCEPT = 1e-12          # |F| accepted as a hit, relative to the scene size
_GRAZE = 0.15            # |n . d| below which a hit counts as glancing
_MAX_SWEEP = 0.9 * np.pi  # largest sweep of an arc the fit proposes
_MAX_POINTS = 1_000_000   # densified polyline size refused up front
_REACH = 1e6  # drawn points farther from the origin than this many times the surface's size are not drawn on it

_tess_cache: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # NurbsSurface -> Tessellation


# ====================================================================== results
@dataclass(frozen=True)
class Projection:
    """Points moved along the view direction onto the surface.

    uv : (k, 2) float, parameters of the hit (NaN where ``hit`` is False)
    xyz : (k, 3) float, S(uv), the hit points (NaN where missed)
    hit : (k,) bool, whether the viewing line meets the surface inside its domain
    t : (k,) float, xyz = P + t d with d the unit view direction (NaN where missed)
    """

    uv: np.ndarray
    xyz: np.ndarray
    hit: np.ndarray
    t: np.ndarray


@dataclass(frozen=True)
class ProjectedCurve:
    """A drawn polyline projected onto the surface: one connected piece.

    uv : (m, 2) float, parameters of the projected points, in order along the drawing
    xyz : (m, 3) float, S(uv)
    source_index : (m,) int, input segment [i, i+1] each point came from
    source_param : (m,) float, position along the drawing, i + fraction within segment i
    complete : bool, True when every part of the drawing that meets the surface is
        in this piece (drawn points beyond the rim at either end may be dropped);
        False when the projection broke into pieces (a miss in the middle, or a
        jump where one part of the surface hides another) and the longest was kept
    clipped : bool, True when some drawn points missed the surface
    n_pieces : int, number of connected pieces the projection had
    """

    uv: np.ndarray
    xyz: np.ndarray
    source_index: np.ndarray
    source_param: np.ndarray
    complete: bool
    clipped: bool
    n_pieces: int


@dataclass(frozen=True)
class Arc2:
    """One degree-2 rational Bezier piece (an arc or a line segment) in the plane.

    ctrlpts : (3, 2) float, start, apex, end (|start - apex| = |apex - end|)
    weights : (3,) float, (1, cos(sweep / 2), 1)
    """

    ctrlpts: np.ndarray
    weights: np.ndarray

    def evaluate(self, s) -> np.ndarray:
        """(n, 2) points at Bezier parameters s : (n,) in [0, 1]."""
        s = np.asarray(s, dtype=float).reshape(-1, 1)
        b = np.hstack([(1 - s) ** 2, 2 * s * (1 - s), s ** 2]) * self.weights
        return (b @ self.ctrlpts) / b.sum(axis=1, keepdims=True)


@dataclass(frozen=True)
class Biarcs:
    """A G1 chain of n circular arcs and line segments in the (u, v) plane.

    start, end : (n, 2) float, end points (end[i] == start[i + 1])
    tangent : (n, 2) float, unit tangent at each start
    sweep : (n,) float, signed turning angle of each arc, |sweep| < pi
        (positive: turning counter-clockwise; 0 for a line)
    centre : (n, 2) float, NaN for lines
    radius : (n,) float, inf for lines
    line : (n,) bool, which pieces are straight
    """

    start: np.ndarray
    end: np.ndarray
    tangent: np.ndarray
    sweep: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    line: np.ndarray

    # ------------------------------------------------------------ derived
    @property
    def count(self) -> int:
        return int(self.sweep.shape[0])

    @property
    def chord(self) -> np.ndarray:
        """(n,) distance from start to end of each piece."""
        return np.linalg.norm(self.end - self.start, axis=1)

    @property
    def curvature(self) -> np.ndarray:
        """(n,) signed curvature (positive: centre to the left of the tangent)."""
        c = self.chord
        return np.where(c > 0, 2 * np.sin(self.sweep / 2) / np.where(c > 0, c, 1.0), 0.0)

    @property
    def lengths(self) -> np.ndarray:
        """(n,) arc length of each piece."""
        return self.chord / np.sinc(self.sweep / (2 * np.pi))

    @property
    def tangent_end(self) -> np.ndarray:
        """(n, 2) unit tangent at each end."""
        return _rotate(self.tangent, self.sweep)

    def length(self) -> float:
        """Total arc length."""
        return float(self.lengths.sum())

    # ------------------------------------------------------------ evaluation
    def points_at(self, index: np.ndarray, s: np.ndarray) -> np.ndarray:
        """(k, 2) points at arc length s (k,) along pieces index (k,)."""
        index = np.asarray(index, dtype=int)
        s = np.asarray(s, dtype=float)
        return _arc_points(self.start[index], self.tangent[index], self.curvature[index], s)

    def sample(self, spacing: float) -> np.ndarray:
        """(k, 2) points along the chain at most ``spacing`` apart (in arc length),
        including every joint and both ends."""
        if not (np.isfinite(spacing) and spacing > 0):
            raise SettingsError(f"sample spacing must be a positive number, got {spacing!r}")
        L = self.lengths
        n = np.maximum(1, np.ceil(L / spacing).astype(int))
        idx = np.repeat(np.arange(self.count), n)
        first = np.cumsum(n) - n
        frac = (np.arange(n.sum()) - np.repeat(first, n)) / np.repeat(n, n)
        pts = self.points_at(idx, frac * L[idx])
        return np.vstack([pts, self.end[-1:]])

    def segments(self, spacing: float) -> np.ndarray:
        """(k - 1, 2, 2) line segments of :meth:`sample` (for crossing tests)."""
        p = self.sample(spacing)
        return np.stack([p[:-1], p[1:]], axis=1)

    def distance(self, uv) -> np.ndarray:
        """(m,) distance from every point uv (m, 2) to the chain."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        out = np.empty(uv.shape[0])
        kappa, L = self.curvature, self.lengths
        step = max(1, 1_000_000 // max(self.count, 1))
        for a in range(0, uv.shape[0], step):
            d = _arc_distance(uv[a:a + step], self.start, self.end, self.tangent, kappa, L)
            out[a:a + step] = d.min(axis=1)
        return out

    def max_deviation(self, uv) -> float:
        """Largest distance from the points uv (m, 2) to the chain."""
        d = self.distance(uv)
        return float(d.max()) if d.size else 0.0

    def to_nurbs(self) -> list[Arc2]:
        """One degree-2 rational piece per arc: control polygon start, apex, end
        (an isosceles triangle; a line's apex is its midpoint), weights
        (1, cos(sweep/2), 1)."""
        half = self.sweep / 2
        leg = self.chord / (2 * np.cos(half))
        apex = self.start + leg[:, None] * self.tangent
        return [Arc2(np.array([self.start[i], apex[i], self.end[i]]),
                     np.array([1.0, np.cos(half[i]), 1.0])) for i in range(self.count)]


# ====================================================================== small geometry
def _perp(v: np.ndarray) -> np.ndarray:
    """(n, 2) vectors turned +90 degrees."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Signed angle (n,) in (-pi, pi] turning direction a (n, 2) into b (n, 2)."""
    return np.arctan2(_cross2(a, b), _dot2(a, b))


def _rotate(v: np.ndarray, ang: np.ndarray) -> np.ndarray:
    """(n, 2) vectors v rotated counter-clockwise by ang (n,)."""
    c, s = np.cos(ang), np.sin(ang)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def _arc_points(p0: np.ndarray, t0: np.ndarray, kappa: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(k, 2) points at arc length s (k,) along arcs from p0 (k, 2) with unit
    tangent t0 (k, 2) and signed curvature kappa (k,); exact for kappa = 0."""
    x = kappa * s
    along = s * np.sinc(x / np.pi)                         # sin(ks)/k
    across = s * np.sin(x / 2) * np.sinc(x / (2 * np.pi))   # (1 - cos(ks))/k
    return p0 + along[:, None] * t0 + across[:, None] * _perp(t0)


def _arc_distance(p: np.ndarray, start: np.ndarray, end: np.ndarray, tangent: np.ndarray,
                  kappa: np.ndarray, length: np.ndarray) -> np.ndarray:
    """(m, n) distance from points p (m, 2) to arcs (n,) given by start, end,
    unit start tangent, signed curvature and length; stable as kappa -> 0.

    With w = p - start, x = w . t, y = w . perp(t): the nearest point of the full
    circle is at arc length atan2(k x, 1 - k y) / k, and the distance to the
    circle is |k |w|^2 - 2 y| / (|k w - perp(t)| + 1). Points whose nearest
    circle point lies off the arc are nearest one of its ends.
    """
    w = p[:, None, :] - start[None, :, :]
    x = _dot2(w, tangent[None])
    y = _dot2(w, _perp(tangent)[None])
    k = kappa[None, :]
    ww = x * x + y * y
    circ = np.abs(k * ww - 2 * y) / (np.sqrt((k * x) ** 2 + (k * y - 1) ** 2) + 1)
    kz = k == 0
    s = np.where(kz, x, np.arctan2(k * x, 1 - k * y) / np.where(kz, 1.0, k))
    on = (s >= 0) & (s <= length[None, :])
    d_end = np.minimum(np.sqrt(ww), np.linalg.norm(p[:, None, :] - end[None, :, :], axis=2))
    return np.where(on, np.minimum(circ, d_end), d_end)


# ====================================================================== projection
@dataclass(frozen=True)
class Tessellation:
    """Grid triangulation of a surface.

    uv : (N*N, 2), xyz : (N*N, 3) vertices; tris : (T, 3) int vertex indices
    margin : bound on the distance between surface and triangles (scene units)
    scale : bounding-box diagonal of the surface
    """

    uv: np.ndarray
    xyz: np.ndarray
    tris: np.ndarray
    margin: float
    scale: float


def tessellation(surface: NurbsSurface) -> Tessellation:
    """The cached grid tessellation of ``surface``."""
    tess = _tess_cache.get(surface)
    if tess is not None:
        return tess
    n = _TESS_N
    dom = surface.domain
    gu = np.linspace(dom[0, 0], dom[0, 1], n)
    gv = np.linspace(dom[1, 0], dom[1, 1], n)
    U, V = np.meshgrid(gu, gv, indexing="ij")
    uv = np.column_stack([U.ravel(), V.ravel()])
    xyz = surface.points(uv)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    b, c, d = a + n, a + n + 1, a + 1
    tris = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    # how far the flat pieces stray: surface at cell centres and edge midpoints
    # against the bilinear / linear interpolation of the corners
    G = xyz.reshape(n, n, 3)
    mu, mv = 0.5 * (gu[:-1] + gu[1:]), 0.5 * (gv[:-1] + gv[1:])
    probes = [
        (np.meshgrid(mu, mv, indexing="ij"), 0.25 * (G[:-1, :-1] + G[1:, :-1] + G[:-1, 1:] + G[1:, 1:])),
        (np.meshgrid(mu, gv, indexing="ij"), 0.5 * (G[:-1, :] + G[1:, :])),
        (np.meshgrid(gu, mv, indexing="ij"), 0.5 * (G[:, :-1] + G[:, 1:])),
    ]
    dev = 0.0
    for (PU, PV), lin in probes:
        S = surface.points(np.column_stack([PU.ravel(), PV.ravel()]))
        dev = max(dev, float(np.max(np.linalg.norm(S - lin.reshape(-1, 3), axis=1))))
    scale = float(np.linalg.norm(xyz.max(axis=0) - xyz.min(axis=0)))
    scale = scale if scale > 0 else surface.bbox_diagonal()
    tess = Tessellation(uv, xyz, tris, 3.0 * dev + 1e-9 * scale, scale)
    _tess_cache[surface] = tess
    return tess


def _view_frame(view_dir) -> tuple[np.ndarray, np.ndarray]:
    """Unit view direction d (3,) and E (2, 3), an orthonormal basis of its normal plane."""
    d = np.asarray(view_dir, dtype=float).reshape(-1)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.any(d):
        raise SettingsError(f"view direction must be a non-zero 3-vector, got {view_dir!r}")
    d = d / np.abs(d).max()  # first to about 1: components like 1e308 do not overflow the norm
    d = d / np.linalg.norm(d)
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    return d, np.vstack([e1, e2])


def _check_points(points, what: str = "points") -> np.ndarray:
    P = np.asarray(points, dtype=float)
    if P.ndim == 1 and P.size == 3:
        P = P.reshape(1, 3)
    if P.ndim != 2 or P.shape[1] != 3:
        raise SettingsError(f"{what} must have shape (k, 3), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise SettingsError(f"{what} contain NaN or infinity")
    return P


def _candidates(q: np.ndarray, tess: Tessellation, E: np.ndarray, d: np.ndarray,
                P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton starts for the lines through q (k, 2) (their traces in the view plane).

    Returns (ray (c,) int, uv0 (c, 2), t0 (c,)): for each line, up to
    _CANDIDATES triangles within ``tess.margin`` of its trace, nearest the
    camera first, each with the parameters and depth of its point nearest the
    trace.
    """
    V2 = tess.xyz @ E.T                      # (nv, 2)
    A, B, C = (V2[tess.tris[:, r]] for r in range(3))
    lo = np.minimum(np.minimum(A, B), C) - tess.margin
    hi = np.maximum(np.maximum(A, B), C) + tess.margin
    rays, tris = [], []
    block = 64
    for a in range(0, q.shape[0], block):
        qc = q[a:a + block]
        sel = np.nonzero(np.all(hi >= qc.min(axis=0), axis=1) & np.all(lo <= qc.max(axis=0), axis=1))[0]
        if sel.size == 0:
            continue
        inside = ((qc[:, None, 0] >= lo[sel, 0]) & (qc[:, None, 0] <= hi[sel, 0])
                  & (qc[:, None, 1] >= lo[sel, 1]) & (qc[:, None, 1] <= hi[sel, 1]))
        r, c = np.nonzero(inside)
        rays.append(r + a)
        tris.append(sel[c])
    if not rays:
        return np.zeros(0, int), np.zeros((0, 2)), np.zeros(0)
    ray = np.concatenate(rays)
    tri = np.concatenate(tris)
    w, dist = _closest_on_triangles(q[ray], A[tri], B[tri], C[tri])
    keep = dist <= tess.margin
    ray, tri, w = ray[keep], tri[keep], w[keep]
    vid = tess.tris[tri]                     # (c, 3)
    uv0 = np.einsum("cr,crk->ck", w, tess.uv[vid])
    xyz0 = np.einsum("cr,crk->ck", w, tess.xyz[vid])
    t0 = (xyz0 - P[ray]) @ d
    order = np.lexsort((t0, ray))
    ray, uv0, t0 = ray[order], uv0[order], t0[order]
    first = np.searchsorted(ray, ray, side="left")
    rank = np.arange(ray.size) - first
    keep = rank < _CANDIDATES
    return ray[keep], uv0[keep], t0[keep]


def _closest_on_triangles(q: np.ndarray, A: np.ndarray, B: np.ndarray,
                          C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest point of 2D triangles (A, B, C) (c, 2) to points q (c, 2).

    Returns (w (c, 3) barycentric weights of the nearest point, dist (c,)).
    Degenerate (zero-area) triangles are treated as their three edges.
    """
    c = q.shape[0]
    area = _cross2(B - A, C - A)
    span = np.maximum(np.maximum(np.abs(B - A).max(axis=1), np.abs(C - A).max(axis=1)), 1e-300)
    good = np.abs(area) > 1e-12 * span ** 2
    sa = np.where(good, area, 1.0)
    wA = _cross2(C - B, q - B) / sa
    wB = _cross2(A - C, q - C) / sa
    wC = _cross2(B - A, q - A) / sa
    inside = good & (wA >= 0) & (wB >= 0) & (wC >= 0)
    w = np.column_stack([wA, wB, wC])
    dist = np.full(c, np.inf)
    dist[inside] = 0.0
    best = np.where(inside[:, None], w, 0.0)
    for (X, Y, ix, iy) in ((A, B, 0, 1), (B, C, 1, 2), (C, A, 2, 0)):
        e = Y - X
        ee = _dot2(e, e)
        s = np.clip(_dot2(q - X, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
        dd = np.linalg.norm(X + s[:, None] * e - q, axis=1)
        better = dd < dist
        dist = np.where(better, dd, dist)
        we = np.zeros((c, 3))
        we[:, ix] = 1 - s
        we[:, iy] = s
        best = np.where(better[:, None], we, best)
    return best, dist


def _solve_lines(surface: NurbsSurface, q: np.ndarray, E: np.ndarray, uv0: np.ndarray,
                 tol: np.ndarray, accept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton on F(u, v) = E S(u, v) - q = 0, iterates kept in the domain.

    q : (c, 2) traces of the lines; uv0 : (c, 2) starts; tol : (c,) |F| aimed
    at; accept : (c,) |F| that counts as a hit: a row below it stops when a
    step no longer helps (rounding), a row far above it when |F| settles (a
    line that misses, at its closest approach). Returns (uv (c, 2), |F| (c,)),
    the best iterate of each row.

    First plain Newton steps (bounded, projected onto the domain), taken even
    when |F| grows for a while: near a pole or a grazing line the path to the
    root curves and a monotone rule would crawl. Rows still unconverged then
    continue from their best iterate by Levenberg-Marquardt with Marquardt's
    scaling (damping raised when a step does not reduce |F|), which keeps
    going where the Jacobian is singular and settles on the closest approach
    (|F| > 0) when the line misses.
    """
    dom = surface.domain
    lo, hi = dom[:, 0], dom[:, 1]
    size = hi - lo
    c = uv0.shape[0]
    max_step = 0.2 * size

    def residual(x, rows):
        S, Su, Sv = surface.derivatives(x)
        F = S @ E.T - q[rows]
        J = np.stack([Su @ E.T, Sv @ E.T], axis=2)  # (n, 2, 2): columns d/du, d/dv
        return F, J

    def step_of(F, J, mu):
        """Damped Gauss-Newton steps (n, 2); mu = 0 is Newton."""
        G = np.einsum("nki,nkj->nij", J, J)
        g = np.einsum("nki,nk->ni", J, F)
        floor = 1e-12 * (G[:, 0, 0] + G[:, 1, 1]) + 1e-300
        a = G[:, 0, 0] + mu * np.maximum(G[:, 0, 0], floor)
        b = G[:, 0, 1]
        d = G[:, 1, 1] + mu * np.maximum(G[:, 1, 1], floor)
        det = a * d - b * b
        sing = ~(det > 1e-13 * (a * d))
        # singular: regularise lightly (towards the minimum-norm step)
        reg = np.where(sing, 1e-10 * (a + d) + 1e-300, 0.0)
        a, d = a + reg, d + reg
        det = a * d - b * b
        st = -np.column_stack([d * g[:, 0] - b * g[:, 1], a * g[:, 1] - b * g[:, 0]]) / det[:, None]
        factor = np.min(max_step / np.maximum(np.abs(st), 1e-300), axis=1, initial=1.0)
        return st * np.minimum(1.0, factor)[:, None]

    uv = np.clip(uv0, lo, hi)
    F, J = residual(uv, np.arange(c))
    f = np.linalg.norm(F, axis=1)
    best_uv, best_f = uv.copy(), f.copy()
    active = np.nonzero(f > tol)[0]
    finished = f <= tol
    # phase 1: plain Newton, non-monotone
    for _ in range(_NEWTON_PLAIN):
        if active.size == 0:
            break
        new = np.clip(uv[active] + step_of(F[active], J[active], 0.0), lo, hi)
        Fn, Jn = residual(new, active)
        fn = np.linalg.norm(Fn, axis=1)
        fin = np.isfinite(fn) & np.all(np.isfinite(Jn), axis=(1, 2))
        idx = active[fin]
        uv[idx], F[idx], J[idx], f[idx] = new[fin], Fn[fin], Jn[fin], fn[fin]
        better = f[idx] < best_f[idx]
        best_uv[idx[better]], best_f[idx[better]] = uv[idx[better]], f[idx[better]]
        stop = ~better & (best_f[idx] <= accept[idx]) | (best_f[idx] <= tol[idx])
        finished[idx[stop]] = True
        active = idx[~stop]
    # phase 2: Levenberg-Marquardt from the best iterate
    active = np.nonzero(~finished)[0]
    uv[active] = best_uv[active]
    if active.size:
        F[active], J[active] = residual(uv[active], active)
        f[active] = np.linalg.norm(F[active], axis=1)
    mu = np.zeros(c)
    for _ in range(_NEWTON_MAXIT):
        if active.size == 0:
            break
        new = np.clip(uv[active] + step_of(F[active], J[active], mu[active]), lo, hi)
        Fn, Jn = residual(new, active)
        fn = np.linalg.norm(Fn, axis=1)
        ok = np.isfinite(fn) & (fn < f[active]) & np.all(np.isfinite(Jn), axis=(1, 2))
        # a clear miss: the closest approach is reached, |F| hardly falls any more
        settled = ok & (fn > 0.999 * f[active]) & (fn > 1e3 * accept[active])
        acc = active[ok]
        uv[acc], F[acc], J[acc], f[acc] = new[ok], Fn[ok], Jn[ok], fn[ok]
        mu[acc] = np.where(mu[acc] > 1e-4, mu[acc] * 0.1, 0.0)
        rej = active[~ok]
        mu[rej] = np.maximum(mu[rej] * 10.0, 1e-4)
        moved = np.max(np.abs(new - uv[active]) / size, axis=1)
        stuck = settled | (~ok & ((mu[active] > 1e8) | (moved < 1e-17) | (f[active] <= accept[active])))
        active = active[(f[active] > tol[active]) & ~stuck]
    better = f < best_f
    best_uv[better], best_f[better] = uv[better], f[better]
    return best_uv, best_f


def _nearest_roots(surface: NurbsSurface, P: np.ndarray, q: np.ndarray, E: np.ndarray,
                   d: np.ndarray, scale: float, ray: np.ndarray, uv0: np.ndarray):
    """Newton from starts uv0 (c, 2) of lines ray (c,); per line, the converged
    root nearest the camera. Returns (rays (h,), uv (h, 2), xyz (h, 3), t (h,))."""
    if ray.size == 0:
        return ray, np.zeros((0, 2)), np.zeros((0, 3)), np.zeros(0)
    size = scale + np.linalg.norm(q[ray], axis=1)
    uv, f = _solve_lines(surface, q[ray], E, uv0, 1e-14 * size, _ACCEPT * size)
    good = f <= _ACCEPT * size
    ray, uv = ray[good], uv[good]
    S = surface.points(uv)
    t = (S - P[ray]) @ d
    order = np.lexsort((t, ray))
    ray, uv, S, t = ray[order], uv[order], S[order], t[order]
    first = np.ones(ray.size, dtype=bool)
    first[1:] = ray[1:] != ray[:-1]
    return ray[first], uv[first], S[first], t[first]


def project_points(surface: NurbsSurface, points, view_dir) -> Projection:
    """Move points along the view direction onto the surface.

    surface : NurbsSurface
    points : (k, 3) float, the drawn points P
    view_dir : (3,) float, direction from the camera into the scene (any length)

    Each P goes to the intersection of the line P + t d with the surface (inside
    its domain) of smallest t, i.e. nearest the camera; t may be negative (the
    line is a whole line). Lines that miss give hit = False and NaN elsewhere.
    Returns a :class:`Projection`.

    Where a line meets the surface at a glancing angle (near a silhouette fold
    two intersections lie close together, and the flat triangles may show only
    the farther), Newton is restarted from a ring of points around the root
    found, a cell and less away in (u, v), and a nearer root kept if found.
    """
    P = _check_points(points)
    d, E = _view_frame(view_dir)
    k = P.shape[0]
    uv_out = np.full((k, 2), np.nan)
    xyz_out = np.full((k, 3), np.nan)
    t_out = np.full(k, np.nan)
    hit = np.zeros(k, dtype=bool)
    if k == 0:
        return Projection(uv_out, xyz_out, hit, t_out)
    tess = tessellation(surface)
    q = P @ E.T
    ray, uv0, _ = _candidates(q, tess, E, d, P)
    r, uv, xyz, t = _nearest_roots(surface, P, q, E, d, tess.scale, ray, uv0)
    hit[r] = True
    uv_out[r], xyz_out[r], t_out[r] = uv, xyz, t
    # glancing hits: look for a nearer root across the fold
    if r.size:
        normal = surface.evaluate(uv).normal
        graze = r[np.abs(normal @ d) < _GRAZE]
        if graze.size:
            dom = surface.domain
            cell = (dom[:, 1] - dom[:, 0]) / (_TESS_N - 1)
            ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
            ring = np.concatenate([f * np.column_stack([np.cos(ang), np.sin(ang)]) for f in (0.3, 1.0, 2.0)])
            starts = (uv_out[graze][:, None, :] + ring[None] * cell).reshape(-1, 2)
            rr = np.repeat(graze, ring.shape[0])
            r2, uv2, xyz2, t2 = _nearest_roots(surface, P, q, E, d, tess.scale, rr, starts)
            nearer = t2 < t_out[r2]
            r2 = r2[nearer]
            uv_out[r2], xyz_out[r2], t_out[r2] = uv2[nearer], xyz2[nearer], t2[nearer]
    return Projection(uv_out, xyz_out, hit, t_out)


def _polyline_at(P: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(n, 3) points at positions s (n,) along the polyline P (k, 3): segment
    floor(s), fraction s - floor(s) (s = k - 1 is the last point)."""
    i = np.clip(np.floor(s).astype(int), 0, P.shape[0] - 2)
    f = (s - i)[:, None]
    return P[i] + f * (P[i + 1] - P[i])


def project_polyline(surface: NurbsSurface, points, view_dir, max_step: float | None = None
                     ) -> ProjectedCurve:
    """Project a drawn polyline onto the surface along the view direction.

    surface : NurbsSurface
    points : (k, 3) float, k >= 2, the drawn polyline
    view_dir : (3,) float, from the camera into the scene
    max_step : largest distance between consecutive projected points (scene
        units); default 1/100 of the diagonal of the surface's bounding box

    The drawing is densified (in the view plane), projected, and refined where
    consecutive projected points are more than ``max_step`` apart; where the
    drawing leaves the surface, the crossing is located by bisection (to 1e-9
    of the surface size in the view plane). The projection is split where lines
    miss and where it jumps (one part of the surface hiding another); the
    longest piece (in length on the surface) is returned, with
    ``complete=False`` if it had to choose. Raises :class:`SettingsError` when
    fewer than two points meet the surface.
    """
    P = _check_points(points, "polyline points")
    if P.shape[0] < 2:
        raise SettingsError(f"a polyline needs at least 2 points, got {P.shape[0]}")
    d, E = _view_frame(view_dir)
    scale = tessellation(surface).scale     # the surface's own size, not its control net's
    h = scale / 100.0 if max_step is None else float(max_step)
    if not (np.isfinite(h) and h > 0):
        raise SettingsError(f"max_step must be a positive number, got {max_step!r}")
    min_gap = 1e-9 * scale
    k = P.shape[0]
    h_refine = 0.997 * h                    # room for the thinning below
    reach = np.abs(P).max()
    if reach > _REACH * (scale + np.abs(surface.ctrlpts).max()):
        raise SettingsError(f"the drawn points reach {reach:.3g} from the origin, more than {_REACH:g} times the "
                            f"surface's size: they are not drawn on it")
    seg2 = np.linalg.norm(np.diff(P, axis=0) @ E.T, axis=1)
    n = np.maximum(1, np.ceil(seg2 / h)).astype(int)
    if n.sum() > _MAX_POINTS:
        raise SettingsError(f"max_step {h:g} would need {int(n.sum())} points; choose a larger step")
    s = np.concatenate([np.repeat(np.arange(k - 1), n)
                        + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n),
                        [k - 1.0]])
    pr = project_points(surface, _polyline_at(P, s), d)
    uv, xyz, hit = pr.uv, pr.xyz, pr.hit
    for _ in range(200):
        q = _polyline_at(P, s) @ E.T
        gap2 = np.linalg.norm(np.diff(q, axis=0), axis=1)
        gap3 = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
        both = hit[:-1] & hit[1:]
        long_ = both & (gap3 > h_refine) & (gap2 > min_gap) & (np.diff(s) > 1e-15 * k)
        edge = (hit[:-1] != hit[1:]) & (gap2 > min_gap) & (np.diff(s) > 1e-15 * k)
        if not (np.any(long_) or np.any(edge)):
            break
        ins = np.where(long_, np.minimum(np.ceil(np.where(both, gap3, 0) / h_refine) - 1, 64), 0)
        ins = np.maximum(ins, 7 * edge).astype(int)     # edges: 8-section search
        idx = np.nonzero(ins)[0]
        cnt = ins[idx]
        if s.size + cnt.sum() > _MAX_POINTS:
            raise SettingsError("the projected curve needs too many points; choose a larger max_step")
        j = np.repeat(idx, cnt)
        frac = (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1) / np.repeat(cnt + 1, cnt)
        s_new = s[j] + frac * (s[j + 1] - s[j])
        pn = project_points(surface, _polyline_at(P, s_new), d)
        s = np.concatenate([s, s_new])
        order = np.argsort(s, kind="stable")
        s = s[order]
        uv = np.concatenate([uv, pn.uv])[order]
        xyz = np.concatenate([xyz, pn.xyz])[order]
        hit = np.concatenate([hit, pn.hit])[order]
    # pieces: runs of hits, broken where a step on the surface is still too long
    gap3 = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    joined = hit[:-1] & hit[1:] & (gap3 <= h_refine)
    starts = np.nonzero(hit & np.concatenate([[True], ~joined]))[0]
    ends = np.nonzero(hit & np.concatenate([~joined, [True]]))[0]
    if starts.size == 0:
        raise SettingsError("the drawn curve does not meet the surface in this view")
    csum = np.concatenate([[0.0], np.cumsum(np.where(joined, gap3, 0.0))])
    lengths = csum[ends] - csum[starts]
    best = int(np.argmax(lengths))
    a, b = starts[best], ends[best] + 1
    if b - a < 2:
        raise SettingsError("fewer than 2 points of the drawn curve meet the surface in this view")
    # thin the clusters the bisection leaves near rims: at most one point per
    # 1/1000 of max_step of length (steps were refined to 0.997 max_step, and
    # thinning lengthens a step by less than 2/1000 of it)
    arc = csum[a:b] - csum[a]
    bins = np.floor(arc / (1e-3 * h))
    keep = np.concatenate([[True], bins[1:] != bins[:-1]])
    keep[-1] = True
    sel = np.arange(a, b)[keep]
    if sel.size >= 3 and arc[-1] - arc[keep][-2] < 1e-3 * h:
        sel = np.delete(sel, -2)             # the end's twin
    sk = s[sel]
    return ProjectedCurve(uv=uv[sel], xyz=xyz[sel],
                          source_index=np.clip(np.floor(sk).astype(int), 0, k - 2),
                          source_param=sk, complete=bool(starts.size == 1),
                          clipped=bool(not np.all(hit)), n_pieces=int(starts.size))


# ====================================================================== biarcs
def _circle_tangent(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """(n, 2) tangent (unnormalised, unoriented) at B of the circle through
    A, B, C (each (n, 2)); along the line when the three are collinear."""
    a, c = A - B, C - B
    return _dot2(a, a)[:, None] * c - _dot2(c, c)[:, None] * a


def _data_tangents(P: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(n, 2) unit tangents at the points P (n, 2) with cumulative chord length s.

    Interior points: circle through the point and its neighbours an arc length
    h = half the median spacing away on each side; ends: circle through the end
    and the next two such points. Exact for points on a circle or a line.
    Each tangent points forward along both adjacent segments.
    """
    n = P.shape[0]
    ds = np.diff(s)
    h = 0.5 * float(np.median(ds))
    fwd = np.searchsorted(s, s + h, side="left")
    bwd = np.searchsorted(s, s - h, side="right") - 1
    fwd_ok, bwd_ok = fwd <= n - 1, bwd >= 0
    fc, bc = np.minimum(fwd, n - 1), np.maximum(bwd, 0)
    fwd2 = np.minimum(np.searchsorted(s, s[fc] + h, side="left"), n - 1)
    bwd2 = np.maximum(np.searchsorted(s, s[bc] - h, side="right") - 1, 0)
    T = np.zeros((n, 2))
    mid = fwd_ok & bwd_ok
    T[mid] = _circle_tangent(P[bc[mid]], P[mid], P[fc[mid]])
    T[mid] *= np.sign(_dot2(T[mid], P[fc[mid]] - P[bc[mid]]))[:, None]
    st = ~bwd_ok & fwd_ok
    T[st] = np.where((fwd2[st] > fc[st])[:, None],
                     _circle_tangent(P[fwd2[st]], P[st], P[fc[st]]), P[fc[st]] - P[st])
    T[st] *= np.sign(_dot2(T[st], P[fc[st]] - P[st]))[:, None]
    en = bwd_ok & ~fwd_ok
    T[en] = np.where((bwd2[en] < bc[en])[:, None],
                     _circle_tangent(P[bwd2[en]], P[en], P[bc[en]]), P[en] - P[bc[en]])
    T[en] *= np.sign(_dot2(T[en], P[en] - P[bc[en]]))[:, None]
    none = ~fwd_ok & ~bwd_ok
    T[none] = P[-1] - P[0]
    T = _unit(T)
    # the tangent must point forward along both neighbouring segments, or no
    # biarc joins adjacent points; replace offenders by the segments' bisector
    u = _unit(np.diff(P, axis=0))
    u_out = np.vstack([u, u[-1:]])
    u_in = np.vstack([u[:1], u])
    bad = (_dot2(T, u_out) <= 1e-9) | (_dot2(T, u_in) <= 1e-9) | ~np.all(np.isfinite(T), axis=1)
    if np.any(bad):
        bis = u_out[bad] + u_in[bad]
        nb = np.linalg.norm(bis, axis=1)
        if np.any(nb < 1e-6):
            where = P[bad][np.argmin(nb)]
            raise SettingsError(f"the curve turns back on itself near (u, v) = ({where[0]:.6g}, {where[1]:.6g})")
        T[bad] = bis / nb[:, None]
    return T


def _biarc(P0: np.ndarray, T0: np.ndarray, P1: np.ndarray, T1: np.ndarray):
    """Equal-leg biarc from (P0, T0) to (P1, T1), unit tangents, each (2,).

    Returns (J, Tj, sweep1, sweep2) - the joint, its unit tangent and the two
    sweeps - or None when no such biarc exists (tangents against the chord).
    Legs of length d along T0 from P0 and back along T1 from P1 end at Q0, Q1
    with |Q0 Q1| = 2d; J is their midpoint, so P0 Q0 J and J Q1 P1 are
    isosceles and each is the control triangle of one arc.
    """
    V = P1 - P0
    b = V @ (T0 + T1)
    c = V @ V
    a = (T0 - T1) @ (T0 - T1)            # 2 (1 - T0.T1), without cancellation
    den = b + np.sqrt(b * b + a * c)
    if not den > 0:
        return None
    dleg = c / den
    Q0, Q1 = P0 + dleg * T0, P1 - dleg * T1
    J = 0.5 * (Q0 + Q1)
    Tj = Q1 - Q0
    nj = np.linalg.norm(Tj)
    if not (np.isfinite(dleg) and nj > 0):
        return None
    Tj = Tj / nj
    s1 = float(np.arctan2(_cross2(T0, Tj), _dot2(T0, Tj)))
    s2 = float(np.arctan2(_cross2(Tj, T1), _dot2(Tj, T1)))
    return J, Tj, s1, s2


def _arcs_distance(p, starts, ends, tangents, sweeps) -> np.ndarray:
    """(m,) distance from points p (m, 2) to the union of a few arcs given by
    starts, ends, tangents (n, 2) and sweeps (n,)."""
    chord = np.linalg.norm(ends - starts, axis=1)
    kappa = np.where(chord > 0, 2 * np.sin(sweeps / 2) / np.where(chord > 0, chord, 1.0), 0.0)
    L = chord / np.sinc(sweeps / (2 * np.pi))
    return _arc_distance(p, starts, ends, tangents, kappa, L).min(axis=1)


class _Fitter:
    """Greedy biarc chain over data points P (n, 2) with tangents T (n, 2)."""

    def __init__(self, P: np.ndarray, T: np.ndarray, tol: float):
        self.P, self.T, self.tol = P, T, tol
        u = _unit(np.diff(P, axis=0))                  # (n-1, 2) segment directions
        self.out_ang = _angle(T[:-1], u)                # tangent at i -> segment i
        self.in_ang = _angle(u, T[1:])                  # segment j-1 -> tangent at j
        turn = _angle(u[:-1], u[1:]) if u.shape[0] > 1 else np.zeros(0)
        self.cum = np.concatenate([[0.0], np.cumsum(turn)])  # turning from segment 0 to segment i

    def biarc(self, i: int, j: int):
        return _biarc(self.P[i], self.T[i], self.P[j], self.T[j])

    def fits(self, i: int, j: int) -> bool:
        """Whether one biarc from point i to point j is within tol of the points between."""
        ba = self.biarc(i, j)
        if ba is None:
            return False
        J, Tj, s1, s2 = ba
        if max(abs(s1), abs(s2)) > _MAX_SWEEP:
            return False
        data_turn = self.out_ang[i] + (self.cum[j - 1] - self.cum[i]) + self.in_ang[j - 1]
        if abs(s1 + s2 - data_turn) > 0.5 * np.pi:
            return False
        if j - i < 2:
            return True
        dist = _arcs_distance(self.P[i + 1:j], np.array([self.P[i], J]), np.array([J, self.P[j]]),
                              np.array([self.T[i], Tj]), np.array([s1, s2]))
        return bool(dist.max() <= self.tol)

    def joints(self) -> list[int]:
        """Indices of the biarc end points, 0 first and n - 1 last."""
        n = self.P.shape[0]
        out = [0]
        i = 0
        while i < n - 1:
            good, bad, step = i + 1, None, 2
            while good < n - 1:
                j = min(i + step, n - 1)
                if self.fits(i, j):
                    good = j
                    step *= 2
                else:
                    bad = j
                    break
            if bad is not None:
                while bad - good > 1:
                    mid = (good + bad) // 2
                    if self.fits(i, mid):
                        good = mid
                    else:
                        bad = mid
            out.append(good)
            i = good
        return out


def _merge(start, tangent, sweep, end) -> tuple[list, list, list, list]:
    """Merge consecutive arcs that lie on one circle (or line)."""
    S, T, W, E = [start[0]], [tangent[0]], [sweep[0]], [end[0]]
    for k in range(1, len(sweep)):
        p0, t0, p1 = S[-1], T[-1], end[k]
        chord = p1 - p0
        cl = np.linalg.norm(chord)
        total = W[-1] + sweep[k]
        if cl > 0 and abs(total) < _MAX_SWEEP:
            sw = 2 * float(np.arctan2(_cross2(t0, chord), _dot2(t0, chord)))
            t_end = _rotate(t0[None], np.array([sw]))[0]
            t_next = _rotate(tangent[k][None], np.array([sweep[k]]))[0]
            jump = abs(float(_angle(t_end[None], t_next[None])[0]))
            mid_dev = _arcs_distance(E[-1][None], p0[None], p1[None], t0[None], np.array([sw]))[0]
            if abs(sw - total) < 1e-9 and jump < 1e-11 and mid_dev < 1e-12 * max(cl, 1e-300):
                W[-1], E[-1] = sw, p1
                continue
        S.append(start[k])
        T.append(tangent[k])
        W.append(sweep[k])
        E.append(end[k])
    return S, T, W, E


def fit_biarcs(uv, tol: float) -> Biarcs:
    """Approximate an open polyline by a G1 chain of biarcs.

    uv : (m, 2) float, m >= 2, points along the curve (in order)
    tol : float > 0, largest distance allowed from any point to the chain

    Returns :class:`Biarcs` starting at uv[0] and ending at uv[-1], with
    ``max_deviation(uv) <= tol``. Arcs on one circle and collinear lines are
    merged. Raises :class:`SettingsError` for bad input or a curve that turns
    back on itself (a cusp).
    """
    P = np.asarray(uv, dtype=float)
    if P.ndim != 2 or P.shape[1] != 2:
        raise SettingsError(f"curve points must have shape (m, 2), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise SettingsError("curve points contain NaN or infinity")
    tol = float(tol)
    if not (np.isfinite(tol) and tol > 0):
        raise SettingsError(f"tolerance must be a positive number, got {tol!r}")
    if P.shape[0] < 2:
        raise SettingsError(f"a curve needs at least 2 points, got {P.shape[0]}")
    size = float(np.max(np.ptp(P, axis=0)))
    if not size > 0:
        raise SettingsError("all curve points coincide")
    step = np.linalg.norm(np.diff(P, axis=0), axis=1)
    keep = np.concatenate([[True], step > 1e-13 * size])
    keep[-1] = True
    if step[-1] <= 1e-13 * size and P.shape[0] > 2:
        keep[-2] = False                       # keep the exact last point, drop its twin
    P = P[keep]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    T = _data_tangents(P, s)
    fitter = _Fitter(P, T, tol)
    idx = fitter.joints()
    starts, tangents, sweeps, ends = [], [], [], []
    for i, j in itertools.pairwise(idx):
        J, Tj, s1, s2 = fitter.biarc(i, j)
        starts += [P[i], J]
        tangents += [T[i], Tj]
        sweeps += [s1, s2]
        ends += [J, P[j]]
    start, tangent, sweep, end = (np.array(x) for x in _merge(
        np.array(starts), np.array(tangents), np.array(sweeps), np.array(ends)))
    line = np.abs(sweep) < 1e-13
    sweep = np.where(line, 0.0, sweep)
    chord = np.linalg.norm(end - start, axis=1)
    kappa = np.where(line, 0.0, 2 * np.sin(sweep / 2) / np.where(chord > 0, chord, 1.0))
    with np.errstate(divide="ignore"):
        radius = np.where(line, np.inf, 1.0 / np.abs(np.where(line, 1.0, kappa)))
        centre = np.where(line[:, None], np.nan,
                          start + _perp(tangent) / np.where(line, 1.0, kappa)[:, None])
    return Biarcs(start=start, end=end, tangent=tangent, sweep=sweep, centre=centre,
                  radius=radius, line=line)
