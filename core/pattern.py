"""The 2D pattern (paper section 3.5).

The relaxed lattice is the 2D mesh: node M[i, j] sits at (j r_weft, i r_warp).
Its outline comes from the boundary approximation: points sampled evenly (in
arc length) along the region's boundary on the surface are each mapped into
the 2D frame of nearby nodes. A node's frame is the affine map of its lattice
neighbourhood: its weft vector W (to its row neighbours) and warp vector P (to
its column neighbours); a boundary point Q is written as
Q - M ~ a W + b P (least squares, i.e. in the plane of W and P, the paper's
plane through the two thread extensions) and placed at xy(M) + (a r_weft,
b r_warp).

Mapping through the single nearest node (the paper's rule) makes the outline
jump where the nearest node changes, so its perimeter grows as the sampling
gets denser. Here each point is mapped through its K nearest nodes and the
results blended with weights that fall off smoothly with distance and vanish
at the (K+1)-th nearest node, which keeps the outline continuous and its
perimeter independent of the sampling.

The outline keeps the boundary's corners: every corner of the domain is a
sample. The map from each 2D outline point to its 3D boundary point (and its
(u, v)) is kept: ``outline``, ``outline3d`` and ``outline_uv`` are parallel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from core.mesh import WARP, WEFT, SpringMesh
from core.nurbs import NurbsSurface
from core.quadrature import boundary_polyline, edge_lengths

__all__ = ["Pattern", "node_frames", "map_points", "make_pattern", "polygon_area", "polygon_perimeter"]

BLEND_K = 6  # nodes blended per boundary point


@dataclass(frozen=True)
class DartOpening:
    """A dart as it opens in the pattern.

    curve_uv (k, 2), curve3d (k, 3) : the dart on the surface, mouth to tip
    leg_a, leg_b (k, 2) : the curve mapped into 2D from each side (mouth to tip)
    mouth : the dart starts on the region's boundary (else it is a slit inside)
    """

    name: str
    kind: str
    curve_uv: np.ndarray
    curve3d: np.ndarray
    leg_a: np.ndarray
    leg_b: np.ndarray
    mouth: bool

    @property
    def leg_lengths(self) -> tuple[float, float]:
        return (float(np.linalg.norm(np.diff(self.leg_a, axis=0), axis=1).sum()),
                float(np.linalg.norm(np.diff(self.leg_b, axis=0), axis=1).sum()))

    @property
    def opening_deg(self) -> float:
        """Angle at the tip between the chords to the two mouth points."""
        tip = 0.5 * (self.leg_a[-1] + self.leg_b[-1])
        va, vb = self.leg_a[0] - tip, self.leg_b[0] - tip
        c = float(va @ vb / max(np.linalg.norm(va) * np.linalg.norm(vb), 1e-300))
        return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


@dataclass(frozen=True)
class Pattern:
    """A flat pattern piece.

    xy : (n, 2) 2D positions of the nodes (the relaxed lattice)
    outline : (k, 2) closed outline polygon (first point not repeated),
        counter-clockwise; darts that start on the boundary are walked round
        (up one leg, to the tip, down the other)
    outline3d : (k, 3) the points on the surface the outline points come from
    outline_uv : (k, 2) their parameters
    on_boundary : (k,) bool, outline points that lie on the region's boundary
    darts : the darts' openings; holes : closed 2D polygons of darts inside the piece
    """

    xy: np.ndarray
    outline: np.ndarray
    outline3d: np.ndarray
    outline_uv: np.ndarray
    on_boundary: np.ndarray | None = None
    darts: tuple = ()
    holes: tuple = ()

    @property
    def perimeter(self) -> float:
        """Length of the outline along the region's boundary (dart legs excluded)."""
        seg = np.linalg.norm(np.roll(self.outline, -1, axis=0) - self.outline, axis=1)
        if self.on_boundary is None:
            return float(seg.sum())
        return float(seg[self.on_boundary & np.roll(self.on_boundary, -1)].sum())

    @property
    def area(self) -> float:
        """Area inside the outline, less the holes."""
        return abs(polygon_area(self.outline)) - sum(abs(polygon_area(h)) for h in self.holes)


def polygon_area(poly: np.ndarray) -> float:
    """Signed area of a closed polygon (k, 2) (shoelace; positive if counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def polygon_perimeter(poly: np.ndarray) -> float:
    """Perimeter of a closed polygon (k, 2)."""
    return float(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1).sum())


def node_frames(mesh: SpringMesh, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-node lattice vectors on the surface, along the node's own springs.

    Returns W (n, 3), the change of position per lattice column (central
    difference where both weft springs exist, one-sided where one does),
    P (n, 3), the same per lattice row along warp springs, and ok (n,) bool,
    nodes that have both. Springs cut by a dart are not followed.
    """
    n = mesh.n_nodes

    def diff(kind):
        sel = mesh.kind == kind
        a, b = mesh.ends[sel, 0], mesh.ends[sel, 1]
        # orient every spring along +j (weft) or +i (warp)
        axis = 1 if kind == WEFT else 0
        flip = mesh.ij[b, axis] < mesh.ij[a, axis]
        a, b = np.where(flip, b, a), np.where(flip, a, b)
        fwd = np.full(n, -1)
        bwd = np.full(n, -1)
        fwd[a] = b
        bwd[b] = a
        hf, hb = fwd >= 0, bwd >= 0
        out = np.zeros_like(xyz)
        both = hf & hb
        out[both] = 0.5 * (xyz[fwd[both]] - xyz[bwd[both]])
        f = hf & ~hb
        out[f] = xyz[fwd[f]] - xyz[f]
        bk = hb & ~hf
        out[bk] = xyz[bk] - xyz[bwd[bk]]
        return out, hf | hb

    W, okw = diff(WEFT)
    P, okp = diff(WARP)
    return W, P, okw & okp


def map_points(Q: np.ndarray, mesh: SpringMesh, xyz: np.ndarray, xy: np.ndarray,
               usable: np.ndarray | None = None, k: int = BLEND_K, valid=None,
               frames=None) -> np.ndarray:
    """Map 3D points Q (q, 3) near the mesh into the 2D pattern (q, 2).

    Each point is expressed in the lattice frames of its k nearest usable
    nodes and the k results are blended with weights (1 - (d/d_k+1)^2)^2,
    which vanish at the (k+1)-th nearest node (see the module docstring).

    ``valid(rows (q, c), nodes (q, c)) -> (q, c) bool``, if given, vetoes
    point-node pairs (darts: a node across a dart from the point); the k
    nearest valid nodes are blended. Points with no valid node get NaN.
    """
    W, P, ok = frames if frames is not None else node_frames(mesh, xyz)
    if usable is not None:
        ok = ok & usable
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        raise ValueError("no node has both a weft and a warp neighbour")
    c = min(idx.size, 4 * (k + 1) if valid is not None else k + 1)
    dist, nn = cKDTree(xyz[idx]).query(Q, k=c)
    dist, nn = dist.reshape(len(Q), c), idx[nn.reshape(len(Q), c)]
    val = np.ones(dist.shape, dtype=bool)
    if valid is not None:
        rows = np.repeat(np.arange(len(Q))[:, None], c, axis=1)
        val = np.asarray(valid(rows, nn), dtype=bool)
    rank = np.cumsum(val, axis=1)
    sel = val & (rank <= k)
    # the blend's radius: the distance of the (k+1)-th valid node, or beyond the last one
    nxt = val & (rank == k + 1)
    radius = np.where(nxt.any(axis=1), np.max(np.where(nxt, dist, 0.0), axis=1),
                      1.5 * np.max(np.where(sel, dist, 0.0), axis=1))
    # weights fall to zero at that radius, so the blend is continuous as Q
    # moves and nodes enter or leave the nearest set
    w = np.where(sel, np.clip(1.0 - (dist / np.maximum(radius, 1e-300)[:, None]) ** 2, 0.0, None) ** 2, 0.0)
    first = np.argmax(sel, axis=1)
    w[np.arange(len(Q)), first] += np.where(sel.any(axis=1), 1e-300, 0.0)
    total = w.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = w / total
    # least squares d = a W + b P for every (point, node) pair
    d = Q[:, None, :] - xyz[nn]
    Wn, Pn = W[nn], P[nn]
    g11 = np.einsum("qkc,qkc->qk", Wn, Wn)
    g12 = np.einsum("qkc,qkc->qk", Wn, Pn)
    g22 = np.einsum("qkc,qkc->qk", Pn, Pn)
    r1 = np.einsum("qkc,qkc->qk", Wn, d)
    r2 = np.einsum("qkc,qkc->qk", Pn, d)
    det = g11 * g22 - g12 * g12
    det = np.where(det == 0, 1.0, det)
    a = (g22 * r1 - g12 * r2) / det
    b = (g11 * r2 - g12 * r1) / det
    cand = xy[nn] + np.stack([a * mesh.r_weft, b * mesh.r_warp], axis=-1)
    return np.einsum("qk,qkc->qc", np.where(sel, w, 0.0), cand) + np.where(total > 0, 0.0, np.nan)


def boundary_samples(surface: NurbsSurface, spacing: float, per_spacing: int = 4,
                     minimum: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """(uv, xyz) of points even in arc length along the boundary, corners included,
    about ``per_spacing`` points per mesh spacing (at least ``minimum`` per edge)."""
    lengths = edge_lengths(surface)
    n_edge = tuple(int(max(minimum, np.ceil(L / spacing * per_spacing))) for L in lengths)
    return boundary_polyline(surface, n_edge)


def make_pattern(surface: NurbsSurface, mesh: SpringMesh, xyz: np.ndarray,
                 samples: tuple[np.ndarray, np.ndarray] | None = None, darts=None,
                 uv: np.ndarray | None = None) -> Pattern:
    """The 2D pattern of a mesh state: relaxed lattice and outline.

    With ``darts`` (a :class:`core.darts.DartSet`, and the nodes' ``uv``),
    boundary points are mapped only through nodes on their own side of every
    dart, and each dart's curve is mapped twice, from its positive and from
    its negative side, so on a doubly curved surface it opens into a V.
    """
    xy = mesh.lattice_xy()
    spacing = min(mesh.r_weft, mesh.r_warp)
    if samples is None:
        samples = boundary_samples(surface, spacing)
    buv, Q = samples
    frames = node_frames(mesh, xyz)
    have_darts = darts is not None and len(darts) > 0
    valid = None
    if have_darts:
        def valid(rows, nn):  # the node is on the point's side of every dart
            return ~darts.crossing(qv[rows.ravel()], uv[nn.ravel()]).reshape(rows.shape)
        qv = buv
    outline = map_points(Q, mesh, xyz, xy, valid=valid, frames=frames)
    out_uv, out3d, on_b = list(buv), list(Q), [True] * len(Q)
    out2d = list(outline)
    openings, holes = [], []
    if have_darts:
        inserts = []
        for dart in darts.darts:
            cuv = _resample_uv(surface, dart.curve_uv(surface), spacing / 4)
            if len(cuv) < 2:
                continue
            c3 = surface.points(cuv)
            legs = {}
            for sgn in (1, -1):
                def valid_side(rows, nn, sgn=sgn, dart=dart):
                    nodes = nn.ravel()
                    ok = dart.side(uv[nodes], xyz[nodes]) == sgn
                    others = DartSetView(darts, exclude=dart)
                    ok &= ~others.crossing(cuv[rows.ravel()], uv[nodes])
                    return ok.reshape(rows.shape)
                legs[sgn] = map_points(c3, mesh, xyz, xy, valid=valid_side, frames=frames)
            mouth = _boundary_distance(surface, cuv[:1])[0] < 1e-6
            openings.append(DartOpening(dart.name, dart.kind, cuv, c3, legs[1], legs[-1], bool(mouth)))
            if mouth:
                inserts.append((cuv, c3, legs, dart))
            else:
                holes.append(np.vstack([legs[1], legs[-1][::-1]]))
        # walk round each dart that opens on the boundary
        for cuv, c3, legs, dart in inserts:
            # boundary samples at the mouth itself are replaced by the legs' ends
            near = [k for k in range(len(out3d))
                    if on_b[k] and np.linalg.norm(out3d[k] - c3[0]) < spacing / 8]
            for k in reversed(near):
                del out2d[k], out_uv[k], out3d[k], on_b[k]
            bu = np.array(out_uv)
            i = _nearest_segment(bu, cuv[0], np.array(on_b))
            first = int(dart.side(bu[i:i + 1], np.array(out3d)[i:i + 1])[0])
            a, b = legs[first], legs[-first]
            pts2 = list(a) + list(b[::-1])
            pts_uv = list(cuv) + list(cuv[::-1])
            pts3 = list(c3) + list(c3[::-1])
            flags = [True] + [False] * (2 * len(cuv) - 2) + [True]
            out2d[i + 1:i + 1] = pts2
            out_uv[i + 1:i + 1] = pts_uv
            out3d[i + 1:i + 1] = pts3
            on_b[i + 1:i + 1] = flags
    outline, Q, buv, on_b = np.array(out2d), np.array(out3d), np.array(out_uv), np.array(on_b)
    if polygon_area(outline) < 0:  # report counter-clockwise
        outline, Q, buv, on_b = outline[::-1], Q[::-1], buv[::-1], on_b[::-1]
    return Pattern(xy=xy, outline=outline, outline3d=Q, outline_uv=buv, on_boundary=on_b,
                   darts=tuple(openings), holes=tuple(holes))


class DartSetView:
    """A DartSet without one of its darts."""

    def __init__(self, darts, exclude):
        self.inner = darts
        self.exclude = exclude

    def crossing(self, uva, uvb):
        out = np.zeros(len(uva), dtype=bool)
        xa = xb = None
        for d in self.inner.darts:
            if d is self.exclude:
                continue
            if d.kind == "plane" and xa is None:
                xa, xb = self.inner.surface.points(uva), self.inner.surface.points(uvb)
            out |= d.crosses(uva, uvb, xa, xb)
        return out


def _boundary_distance(surface: NurbsSurface, uv: np.ndarray) -> np.ndarray:
    dom = surface.domain
    t = (uv - dom[:, 0]) / np.ptp(dom, axis=1)
    return np.min(np.column_stack([t, 1 - t]), axis=1)


def _nearest_segment(poly: np.ndarray, p: np.ndarray, on_boundary: np.ndarray) -> int:
    """Index i of the closed polygon's boundary segment (i, i+1) nearest to p."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
    d = np.linalg.norm(a + t[:, None] * ab - p, axis=1)
    d[~(on_boundary & np.roll(on_boundary, -1))] = np.inf
    return int(np.argmin(d))


def _resample_uv(surface: NurbsSurface, uv: np.ndarray, step: float) -> np.ndarray:
    """Resample a (u, v) polyline evenly in arc length on the surface, about ``step`` apart."""
    if len(uv) < 2:
        return uv
    P = surface.points(uv)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    if s[-1] == 0:
        return uv[:1]
    n = max(2, int(np.ceil(s[-1] / step)) + 1)
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(t, s, uv[:, 0]), np.interp(t, s, uv[:, 1])])
