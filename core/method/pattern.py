"""The 2D pattern (paper section 3.5).

The relaxed lattice is the 2D mesh: node M[i, j] sits at (j r_weft, i r_warp).
Its outline comes from the boundary approximation: points sampled evenly (in
arc length) along the region's boundary on the surface are each mapped into
the 2D frame of nearby nodes. A node's frame is the affine map of its lattice
neighbourhood: its weft vector W (to its row neighbours) and warp vector P (to
its column neighbours); a boundary point Q is written as
Q - M ~ a W + b P (least squares, i.e. in the plane of W and P, the paper's
plane through the two thread extensions) and placed at xy(M) + (a r_weft,
b r_warp). Every offset, the neighbours' and Q's, is first unrolled into the
node's tangent plane as a development would lay it (:func:`surface_offsets`):
the paper's projection onto the plane shortens an offset d by
|d| (kappa |d|)^2 / 6, which on a curved piece made the outline 0.07 % (a full
cylinder of five spacings' radius) to 2 % (the bundled half cylinder at
spacing 0.2) short of the development beyond the chords' own shortfall.

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

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from flatweave.geometry.nurbs import boundary_distance
from flatweave.errors import SettingsError
from flatweave.geometry.numerics import cumulative_length, interp_rows
from flatweave.method.lattice import WARP, WEFT, SpringMesh
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.quadrature import boundary_samples
from flatweave.geometry.numerics import polygon_area

__all__ = ["Pattern", "node_frames", "framed_nodes", "surface_offsets", "map_points", "make_pattern", "polygon_area",
           "polygon_perimeter"]

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
    pieces : every piece (darts may cut the mesh apart); the fields above are
        the largest piece's
    unmapped : outline and dart-leg points left out because no node lies on
        their side of the darts (a mesh shredded by crossing darts); 0 normally
    """

    xy: np.ndarray
    outline: np.ndarray
    outline3d: np.ndarray
    outline_uv: np.ndarray
    on_boundary: np.ndarray | None = None
    darts: tuple = ()
    holes: tuple = ()
    pieces: tuple = ()
    unmapped: int = 0

    @property
    def perimeter(self) -> float:
        """Length of the outline along the region's boundary (dart legs excluded),
        over all pieces."""
        if len(self.pieces) > 1 or (self.pieces and self.pieces[0].n_region_holes):
            return sum(p.perimeter for p in self.pieces)
        seg = np.linalg.norm(np.roll(self.outline, -1, axis=0) - self.outline, axis=1)
        if self.on_boundary is None:
            return float(seg.sum())
        return float(seg[self.on_boundary & np.roll(self.on_boundary, -1)].sum())

    @property
    def area(self) -> float:
        """Area inside the outline, less the holes, over all pieces."""
        if len(self.pieces) > 1:
            return sum(p.area for p in self.pieces)
        return abs(polygon_area(self.outline)) - sum(abs(polygon_area(h)) for h in self.holes)


def _rows(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``a[idx]`` for an index array ``idx`` of any shape: rows gathered by ``np.take``, several
    times quicker than fancy indexing for (n, 2) and (n, 3) arrays."""
    return np.take(a, idx, axis=0)


def polygon_perimeter(poly: np.ndarray) -> float:
    """Perimeter of a closed polygon (k, 2)."""
    return float(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1).sum())


def surface_offsets(d: np.ndarray, normals: np.ndarray, turn: np.ndarray | None = None) -> np.ndarray:
    """(..., 3) offsets ``d`` (..., 3) from nodes to points on the surface,
    each unrolled into its node's tangent plane: where a development puts the
    point relative to the node (the inverse of the exponential map).

    ``normals`` (..., 3) are the nodes' unit normals and ``turn`` (..., 3, 3),
    if given, the change of the normal per unit of tangent offset there (the
    shape operator as a 3D matrix, :func:`node_frames`). With h the point's
    height over the tangent plane and p its projection on it, the length is
    the arc of the normal section taken as a circle tangent to the plane,
    s = |d| asin(x) / x (x = h / |d|), exact along a cylinder's circle; the
    geodesic to the point leaves that section sideways by (h / 3) of the
    normal's turn along p across p, which ``turn`` puts back. Both to third
    order in |d|; the projection alone falls short by |d| (kappa |d|)^2 / 6
    (1.2 % of an offset two lattice steps long on the bundled half cylinder at
    spacing 0.2), and without the sideways term an offset of (2, 1) spacings on
    a cylinder of five spacings' radius lands 0.02 spacings off (7e-4 with it).
    """
    h = np.einsum("...c,...c->...", d, normals)
    chord = np.sqrt(np.einsum("...c,...c->...", d, d))
    p = d - h[..., None] * normals
    rho = np.sqrt(np.einsum("...c,...c->...", p, p))
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.clip(np.abs(h) / chord, 0.0, 1.0)
        s = np.where(x > 1e-4, chord * np.arcsin(x) / np.where(x > 1e-4, x, 1.0), chord * (1.0 + x * x / 6.0))
        scale = np.where(rho > 0, s / rho, 0.0)
        out = p * np.where(np.isfinite(scale), scale, 0.0)[..., None]
        if turn is not None:
            t = np.einsum("...ij,...j->...i", turn, p)
            unit = p / np.where(rho > 0, rho, 1.0)[..., None]
            side = t - np.einsum("...c,...c->...", t, unit)[..., None] * unit
            out -= (h / 3.0)[..., None] * np.where(np.isfinite(side), side, 0.0)
    return out


def framed_nodes(mesh: SpringMesh) -> np.ndarray:
    """(n,) bool: the nodes with a weft and a warp spring, which are the ones :func:`node_frames` gives
    both frames (its ``ok``), found from the springs alone (a pattern needs at least one)."""
    weft = np.zeros(mesh.n_nodes, dtype=bool)
    warp = np.zeros(mesh.n_nodes, dtype=bool)
    weft[mesh.ends[mesh.kind == WEFT].ravel()] = True
    warp[mesh.ends[mesh.kind == WARP].ravel()] = True
    return weft & warp


def node_frames(mesh: SpringMesh, xyz: np.ndarray, normals: np.ndarray | None = None):
    """Per-node lattice frames on the surface, along the node's own springs:
    (W, P, ok, N, turn).

    W (n, 3) is the change of position per lattice column (the mean of the
    forward and backward neighbours' offsets where both weft springs exist,
    the one there is otherwise), P (n, 3) the same per lattice row along warp
    springs, ok (n,) bool the nodes that have both, N (n, 3) the unit normals
    (``normals``, the surface's at the nodes, or else the cross product of the
    chords to the neighbours) and turn (n, 3, 3) the change of N per unit of
    tangent offset, from the neighbours' normals (zero where a neighbour has
    no normal). Offsets are unrolled into the node's tangent plane
    (:func:`surface_offsets`), so W and P are tangent and as long as the arcs
    to the neighbours. Springs cut by a dart are not followed.
    """
    n = mesh.n_nodes
    own = np.arange(n)

    def neighbours(kind):
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
        far, near = np.where(fwd >= 0, fwd, own), np.where(bwd >= 0, bwd, own)
        # the step per lattice unit: central where both neighbours are there, one-sided otherwise
        per = np.where((fwd >= 0) & (bwd >= 0), 0.5, 1.0)
        return fwd, bwd, far, near, per

    nbrs = [neighbours(WEFT), neighbours(WARP)]
    chords = [(xyz[far] - xyz[near]) * per[:, None] for _, _, far, near, per in nbrs]
    if normals is None:
        normals = np.cross(chords[0], chords[1])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            normals = np.where(length > 0, normals / length, 0.0)
    has = np.einsum("ij,ij->i", normals, normals) > 0.5
    # the shape operator from the frames' tangent parts and the normals' changes along them
    tangent = [c - np.einsum("ij,ij->i", c, normals)[:, None] * normals for c in chords]
    dN = [(normals[far] - normals[near]) * per[:, None] for _, _, far, near, per in nbrs]
    g11 = np.einsum("ij,ij->i", tangent[0], tangent[0])
    g12 = np.einsum("ij,ij->i", tangent[0], tangent[1])
    g22 = np.einsum("ij,ij->i", tangent[1], tangent[1])
    det = g11 * g22 - g12 * g12
    good = has & (det > 0)
    for _, _, far, near, _ in nbrs:
        good &= has[far] & has[near]
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = 1.0 / np.where(good, det, 1.0)
    dual_w = (g22 * inv)[:, None] * tangent[0] - (g12 * inv)[:, None] * tangent[1]
    dual_p = (g11 * inv)[:, None] * tangent[1] - (g12 * inv)[:, None] * tangent[0]
    turn = dN[0][:, :, None] * dual_w[:, None, :] + dN[1][:, :, None] * dual_p[:, None, :]
    turn[~good] = 0.0

    def diff(fwd, bwd):
        hf, hb = fwd >= 0, bwd >= 0
        out = np.zeros_like(xyz)
        f = np.flatnonzero(hf)
        out[f] = surface_offsets(xyz[fwd[f]] - xyz[f], normals[f], turn[f])
        b = np.flatnonzero(hb)
        back = -surface_offsets(xyz[bwd[b]] - xyz[b], normals[b], turn[b])
        both = hf[b]
        out[b[both]] = 0.5 * (out[b[both]] + back[both])
        out[b[~both]] = back[~both]
        return out, hf | hb

    W, okw = diff(*nbrs[0][:2])
    P, okp = diff(*nbrs[1][:2])
    return W, P, okw & okp, normals, turn


def _usable_tree(xyz: np.ndarray, frames) -> cKDTree | None:
    """The k-d tree :func:`map_points` searches: the nodes with both frames (None if none has)."""
    idx = np.flatnonzero(frames[2])
    return cKDTree(xyz[idx]) if idx.size else None


def map_points(Q: np.ndarray, mesh: SpringMesh, xyz: np.ndarray, xy: np.ndarray,
               usable: np.ndarray | None = None, k: int = BLEND_K, valid=None,
               frames=None, nearest: bool = False, _candidates: int | None = None, tree=None):
    """Map 3D points Q (q, 3) near the mesh into the 2D pattern (q, 2).

    Each point is expressed in the lattice frames of its k nearest usable
    nodes and the k results are blended with weights (1 - (d/d_k+1)^2)^2,
    which vanish at the (k+1)-th nearest node (see the module docstring).

    ``valid(rows (q, c), nodes (q, c)) -> (q, c) bool``, if given, vetoes
    point-node pairs (darts: a node across a dart from the point); the k
    nearest valid nodes are blended. The 4 (k + 1) nearest nodes are the
    candidates; for a point with no valid one among them (a mesh cut into
    narrow strips by many darts) the search widens until it finds one or has
    tried every node. Points with no valid node at all get NaN.
    ``tree``: the k-d tree of the usable nodes' xyz (those with both frames, and ``usable``;
    :func:`_usable_tree`), if the caller has it.
    """
    W, P, ok, N, turn = frames if frames is not None else node_frames(mesh, xyz)
    if usable is not None:
        ok = ok & usable
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        raise ValueError("no node has both a weft and a warp neighbour")
    c = min(idx.size, _candidates or (4 * (k + 1) if valid is not None else k + 1))
    if tree is None:
        tree = cKDTree(xyz[idx])
    elif tree.n != idx.size:
        raise ValueError("the k-d tree given is not of the usable nodes")
    dist, nn = tree.query(Q, k=c)
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
    # (unselected entries may be inf, past the last node: kept out of the ratio)
    ratio = np.where(sel, dist, 0.0) / np.maximum(radius, 1e-300)[:, None]
    w = np.where(sel, np.clip(1.0 - ratio ** 2, 0.0, None) ** 2, 0.0)
    first = np.argmax(sel, axis=1)
    w[np.arange(len(Q)), first] += np.where(sel.any(axis=1), 1e-300, 0.0)
    total = w.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = w / total
    # least squares d = a W + b P for every (point, node) pair
    d = surface_offsets(Q[:, None, :] - _rows(xyz, nn), _rows(N, nn), turn[nn])
    Wn, Pn = _rows(W, nn), _rows(P, nn)
    g11 = np.einsum("qkc,qkc->qk", Wn, Wn)
    g12 = np.einsum("qkc,qkc->qk", Wn, Pn)
    g22 = np.einsum("qkc,qkc->qk", Pn, Pn)
    r1 = np.einsum("qkc,qkc->qk", Wn, d)
    r2 = np.einsum("qkc,qkc->qk", Pn, d)
    det = g11 * g22 - g12 * g12
    det = np.where(det == 0, 1.0, det)
    a = (g22 * r1 - g12 * r2) / det
    b = (g11 * r2 - g12 * r1) / det
    cand = _rows(xy, nn) + np.stack([a * mesh.r_weft, b * mesh.r_warp], axis=-1)
    out = np.einsum("qk,qkc->qc", np.where(sel, w, 0.0), cand) + np.where(total > 0, 0.0, np.nan)
    near = np.where(sel.any(axis=1), nn[np.arange(len(Q)), first], -1)
    lost = np.flatnonzero(near < 0)
    if lost.size and valid is not None and c < idx.size:  # widen the search for those points only
        def valid_lost(rows, nodes):
            return valid(lost[rows], nodes)
        more, more_near = map_points(Q[lost], mesh, xyz, xy, usable, k, valid_lost, (W, P, ok, N, turn), True,
                                     _candidates=4 * c, tree=tree)
        out[lost], near[lost] = more, more_near
    if nearest:
        return out, near
    return out


@dataclass(frozen=True)
class Piece:
    """One connected piece of a pattern (darts may cut a mesh in several).

    outline (k, 2), outline3d (k, 3), outline_uv (k, 2), on_boundary (k,) :
    as in :class:`Pattern`; nodes : indices of the mesh nodes of the piece;
    holes : closed 2D polygons inside the piece: first the region's holes
        (a trimmed face's inner loops, clockwise; ``n_region_holes`` of them,
        part of the boundary), then the darts lying inside the piece.
    holes_uv : the (u, v) of the region's holes' points, one array per region
        hole (what a sew line along a hole is found by; not kept in result files)
    """

    outline: np.ndarray
    outline3d: np.ndarray
    outline_uv: np.ndarray
    on_boundary: np.ndarray
    nodes: np.ndarray
    holes: tuple = ()
    n_region_holes: int = 0
    holes_uv: tuple = ()

    @property
    def perimeter(self) -> float:
        """Length along the region's boundary: the outline (dart legs excluded) and the region's holes."""
        seg = np.linalg.norm(np.roll(self.outline, -1, axis=0) - self.outline, axis=1)
        out = float(seg[self.on_boundary & np.roll(self.on_boundary, -1)].sum())
        if self.n_region_holes:
            out += sum(polygon_perimeter(h) for h in self.holes[:self.n_region_holes])
        return out

    @property
    def area(self) -> float:
        return abs(polygon_area(self.outline)) - sum(abs(polygon_area(h)) for h in self.holes)

    @property
    def sew_length(self) -> float:
        """Length of every sew line: the outline with its dart legs, and the holes."""
        return float(sum(polygon_perimeter(r) for r in (self.outline, *self.holes)))

    def to_dict(self) -> dict:
        """The piece in result files. ``perimeter_outline`` runs along the region's
        boundary only (what boundary_error_pct measures), ``sew_length`` along
        every sew line (dart legs and holes too)."""
        out = {"outline": self.outline.tolist(), "outline3d": self.outline3d.tolist(),
               "on_boundary": self.on_boundary.tolist(), "holes": [h.tolist() for h in self.holes],
               "nodes": self.nodes.tolist(), "area": self.area,
               "perimeter_outline": self.perimeter, "sew_length": self.sew_length}
        if self.n_region_holes:
            out["region_holes"] = self.n_region_holes  # the first holes are the face's inner loops
        return out


def make_pattern(surface: NurbsSurface, mesh: SpringMesh, xyz: np.ndarray,
                 samples: tuple[np.ndarray, np.ndarray] | None = None, darts=None,
                 uv: np.ndarray | None = None, hole_samples=(), cover=None) -> Pattern:
    """The 2D pattern of a mesh state: relaxed lattice and outline.

    With ``darts`` (a :class:`flatweave.method.darts.DartSet`, and the nodes' ``uv``),
    boundary points are mapped only through nodes on their own side of every
    dart, and each dart's curve is mapped twice, from its positive and from
    its negative side, so on a doubly curved surface it opens into a V. The
    outline walks round every dart that opens on the boundary (up one leg,
    to the tip, down the other); a dart with both ends on the boundary is a
    cut, and the outline of each piece follows it from one end to the other.
    Darts inside the region become holes.

    ``samples`` are the outer boundary's (uv, xyz) (default: the domain's,
    :func:`boundary_samples`); ``hole_samples`` a list of (uv, xyz) of the
    region's holes (a trimmed face, :meth:`flatweave.geometry.region.Cover.boundary_samples`):
    each is mapped like the outline and becomes a hole of the piece it lies in
    (the first ``n_region_holes`` holes; their length counts in the perimeter).
    ``cover`` (a trimmed :class:`flatweave.geometry.region.Cover`): each dart's curve is
    clipped to the region, and its mouth is where it meets the outer loop.
    """
    xy = mesh.lattice_xy()
    spacing = min(mesh.r_weft, mesh.r_warp)
    if samples is None:
        samples = boundary_samples(surface, spacing)
    buv, Q = samples
    # the surface's normals where the caller has the nodes' (u, v)
    frames = node_frames(mesh, xyz, surface.evaluate(uv).normal if uv is not None else None)
    tree = _usable_tree(xyz, frames)  # one for every map_points call
    if darts is None or len(darts) == 0:
        sheet = _same_sheet(surface, mesh, xyz, uv, buv, spacing) if uv is not None else None
        outline = map_points(Q, mesh, xyz, xy, frames=frames, valid=sheet, tree=tree)
        piece, lost = _finite_piece(Piece(outline, Q, buv, np.ones(len(Q), dtype=bool), np.arange(mesh.n_nodes)))
        if piece is None:
            raise SettingsError("no point of the boundary maps into the pattern: the mesh is too broken "
                                "to flatten; try a smaller spacing")
        piece = _oriented(piece)
        if hole_samples:
            (piece,), more = _region_holes([piece], hole_samples, surface, mesh, xyz, xy, frames, uv, spacing,
                                           None, np.zeros(mesh.n_nodes, dtype=np.int64), tree)
            lost += more
        return Pattern(xy, piece.outline, piece.outline3d, piece.outline_uv, piece.on_boundary, (), piece.holes,
                       (piece,), lost)
    uv = np.asarray(uv, dtype=float)
    # the darts: curves and both sides' legs
    openings, ends = [], []
    trimmed = cover is not None and cover.trimmed
    for dart in darts.darts:
        raw = dart.curve_uv(surface)
        if trimmed:
            raw = cover.clip_curve(raw)
            if len(raw) >= 2 and cover.edge_distance(raw[-1:])[0] < cover.edge_distance(raw[:1])[0]:
                raw = raw[::-1]  # mouth first: the end on the region's edge
        cuv = resample_uv(surface, raw, spacing / 4)
        if len(cuv) < 2:
            continue
        c3 = surface.points(cuv)
        legs = {}
        others = DartSetView(darts, exclude=dart)
        for sgn in (1, -1):
            def valid_side(rows, nn, sgn=sgn, dart=dart, others=others, cuv=cuv):
                nodes = nn.ravel()
                # each node's side once (a node is a candidate of many curve points)
                each, back = np.unique(nodes, return_inverse=True)
                ok = dart.side(_rows(uv, each), _rows(xyz, each))[back] == sgn
                ok &= ~others.crossing(_rows(cuv, rows.ravel()), _rows(uv, nodes))
                return ok.reshape(rows.shape)
            legs[sgn] = map_points(c3, mesh, xyz, xy, valid=valid_side, frames=frames, tree=tree)
        on_edge = (cover.edge_distance(cuv[[0, -1]]) if trimmed else boundary_distance(surface, cuv[[0, -1]])) < 1e-6
        openings.append(DartOpening(dart.name, dart.kind, cuv, c3, legs[1], legs[-1], bool(on_edge[0])))
        ends.append((dart, cuv, c3, legs, on_edge))
    # boundary samples at a dart's end are replaced by the legs' ends
    keep = np.ones(len(Q), dtype=bool)
    for _, cuv, c3, _, on_edge in ends:
        for e in np.flatnonzero(on_edge):
            keep &= np.linalg.norm(Q - c3[-e], axis=1) >= spacing / 8
    buv, Q = buv[keep], Q[keep]

    sheet = _same_sheet(surface, mesh, xyz, uv, buv, spacing)

    # plane darts test the points on the surface: each boundary point and node put there once, not
    # once per (point, candidate node) pair (a point's evaluation does not depend on its batch)
    bxyz, nxyz = _on_surface(surface, darts, buv), _on_surface(surface, darts, uv)

    def visible(rows, nn):  # the node is on the point's side of every dart, and on its sheet
        r, n_ = rows.ravel(), nn.ravel()
        xa, xb = (_rows(bxyz, r), _rows(nxyz, n_)) if bxyz is not None else (None, None)
        return ~darts.crossing(_rows(buv, r), _rows(uv, n_), xa, xb).reshape(rows.shape) & sheet(rows, nn)

    B2, near = map_points(Q, mesh, xyz, xy, valid=visible, frames=frames, nearest=True, tree=tree)
    comp = _components(mesh)
    bcomp = np.where(near >= 0, comp[np.maximum(near, 0)], -1)
    # dart ends on the boundary, as events on the boundary polygon's segments
    nb = len(Q)
    events = {}  # segment index -> list of (t, dart k, end 0 or -1)
    for k, (dart, cuv, c3, legs, on_edge) in enumerate(ends):
        for e in (0, -1):
            if on_edge[e]:
                i, t = _nearest_segment_t(buv, cuv[e])
                events.setdefault(i, []).append((t, k, e))
    for lst in events.values():
        lst.sort()
    pieces, visited = [], np.zeros(nb, dtype=bool)
    for start in range(nb):
        if visited[start] or bcomp[start] < 0:
            continue
        pts2, pts3, ptsuv, flags = [], [], [], []
        i, after = start, -1.0  # walk from boundary sample i; events past t = after
        for _ in range(4 * nb + 4 * len(ends) + 8):
            if after < 0:
                if visited[i] and i == start and pts2:
                    break
                visited[i] = True
                pts2.append(B2[i]), pts3.append(Q[i]), ptsuv.append(buv[i]), flags.append(True)
            ev = [x for x in events.get(i, []) if x[0] > after]
            if not ev:
                i, after = (i + 1) % nb, -1.0
                if i == start:
                    break
                continue
            t, k, e = ev[0]
            dart, cuv, c3, legs, on_edge = ends[k]
            side = int(dart.side(buv[i:i + 1], Q[i:i + 1])[0])
            here = legs[side] if e == 0 else legs[side][::-1]
            path_uv = cuv if e == 0 else cuv[::-1]
            path3 = c3 if e == 0 else c3[::-1]
            if on_edge[0] and on_edge[-1]:
                # a cut: follow it to its other end and go on along the boundary there
                pts2 += list(here)
                pts3 += list(path3)
                ptsuv += list(path_uv)
                flags += [True] + [False] * (len(here) - 2) + [True]
                j, tj = _nearest_segment_t(buv, path_uv[-1])
                i, after = j, tj
            else:
                # up one leg to the tip and down the other
                other = legs[-side]
                pts2 += list(here) + list(other[::-1])
                pts3 += list(path3) + list(path3[::-1])
                ptsuv += list(path_uv) + list(path_uv[::-1])
                flags += [True] + [False] * (2 * len(here) - 2) + [True]
                after = t
        nodes = np.flatnonzero(comp == bcomp[start])
        pieces.append(Piece(np.array(pts2), np.array(pts3), np.array(ptsuv), np.array(flags), nodes))
    # darts inside the region: holes of the piece they lie in
    holes_all = []
    for dart, cuv, c3, legs, on_edge in ends:
        if not on_edge.any():
            hole = np.vstack([legs[1], legs[-1][::-1]])
            holes_all.append(hole)
            _, nn = cKDTree(xyz).query(c3[len(c3) // 2])
            for n_, p in enumerate(pieces):
                if comp[nn] == comp[p.nodes[0]] if len(p.nodes) else False:
                    pieces[n_] = Piece(p.outline, p.outline3d, p.outline_uv, p.on_boundary, p.nodes,
                                       p.holes + (hole,))
                    break
    # points no node maps (no node on their side of the darts) are left out
    unmapped = 0
    kept = []
    for p in pieces:
        p, lost = _finite_piece(p)
        unmapped += lost
        if p is not None:
            kept.append(p)
    if not kept:
        raise SettingsError(f"the {len(darts)} darts leave no piece of fabric that can be flattened "
                            f"({mesh.n_nodes} nodes); remove some darts or use a smaller spacing")
    finite_openings = []
    for o in openings:
        good = np.isfinite(o.leg_a).all(axis=1) & np.isfinite(o.leg_b).all(axis=1)
        unmapped += int((~good).sum())
        if good.sum() >= 2:
            finite_openings.append(DartOpening(o.name, o.kind, o.curve_uv[good], o.curve3d[good], o.leg_a[good],
                                               o.leg_b[good], o.mouth))
    if hole_samples:
        kept, more = _region_holes(kept, hole_samples, surface, mesh, xyz, xy, frames, uv, spacing, darts, comp,
                                   tree)
        unmapped += more
    pieces = sorted((_oriented(p) for p in kept), key=lambda p: -abs(polygon_area(p.outline)))
    main = pieces[0]
    return Pattern(xy, main.outline, main.outline3d, main.outline_uv, main.on_boundary,
                   tuple(finite_openings), main.holes, tuple(pieces), unmapped)


def _same_sheet(surface: NurbsSurface, mesh: SpringMesh, xyz: np.ndarray, uv: np.ndarray,
                buv: np.ndarray, spacing: float):
    """``valid(rows, nodes)`` for :func:`map_points`: the nodes on boundary point's own sheet.

    Where a surface closes on itself (a tube's seam) or folds back until two of
    its parts touch, a boundary point's nearest nodes in 3D can lie on the
    other part: near in space but far along the lattice, and blending them
    puts the point halfway between the two. For each point the candidate
    nearest to it in (u, v) (scaled to the unit square) is on its sheet; any
    other candidate counts only if its lattice distance from that one is at
    most what their 3D distance allows with threads near rest length and
    cells sheared by up to 60 degrees (2 d / spacing), plus 1. On a surface
    that does not touch itself every candidate passes and the outline is
    unchanged.
    """
    dom = surface.domain
    size = dom[:, 1] - dom[:, 0]
    # one contiguous array per coordinate: the (point, candidate) arrays are made component by component
    # (the arithmetic of np.linalg.norm over the last axis, x0^2 + x1^2 (+ x2^2), several times quicker)
    u, v, bu, bv = uv[:, 0].copy(), uv[:, 1].copy(), buv[:, 0].copy(), buv[:, 1].copy()
    i, j = mesh.ij[:, 0].copy(), mesh.ij[:, 1].copy()
    x, y, z = xyz[:, 0].copy(), xyz[:, 1].copy(), xyz[:, 2].copy()
    take = np.take

    def valid(rows: np.ndarray, nn: np.ndarray) -> np.ndarray:
        du = (take(u, nn) - take(bu, rows)) / size[0]
        dv = (take(v, nn) - take(bv, rows)) / size[1]
        anchor = nn[np.arange(len(nn)), np.argmin(np.sqrt(du * du + dv * dv), axis=1)][:, None]
        steps = np.maximum(np.abs(take(i, nn) - take(i, anchor)), np.abs(take(j, nn) - take(j, anchor)))
        dx, dy, dz = (take(c, nn) - take(c, anchor) for c in (x, y, z))
        return steps <= 2.0 * np.sqrt(dx * dx + dy * dy + dz * dz) / spacing + 1

    return valid


def _finite_piece(p: Piece) -> tuple[Piece | None, int]:
    """The piece without outline points that did not map (NaN) and holes'
    NaN points; None if fewer than 3 outline points are left. Also the count
    of outline points left out."""
    good = np.isfinite(p.outline).all(axis=1)
    holes = tuple(h[np.isfinite(h).all(axis=1)] for h in p.holes)
    holes = tuple(h for h in holes if len(h) >= 3)
    lost = int((~good).sum())
    if good.sum() < 3:
        return None, lost
    if lost == 0 and len(holes) == len(p.holes):
        return p, 0
    n_region = sum(1 for h in (h[np.isfinite(h).all(axis=1)] for h in p.holes[:p.n_region_holes]) if len(h) >= 3)
    return Piece(p.outline[good], p.outline3d[good], p.outline_uv[good], p.on_boundary[good], p.nodes, holes,
                 n_region), lost


def _oriented(p: Piece) -> Piece:
    """The piece with its outline counter-clockwise."""
    if polygon_area(p.outline) >= 0:
        return p
    return Piece(p.outline[::-1], p.outline3d[::-1], p.outline_uv[::-1], p.on_boundary[::-1], p.nodes, p.holes,
                 p.n_region_holes, p.holes_uv)


def _region_holes(pieces, hole_samples, surface, mesh, xyz, xy, frames, uv, spacing, darts, comp, tree=None):
    """The pieces with the region's holes mapped into the plane (clockwise),
    each put first among the holes of the piece its nearest node belongs to;
    also the count of hole points no node maps."""
    pieces = list(pieces)
    lost = 0
    for huv, hq in hole_samples:
        valid = None
        if uv is not None:
            sheet = _same_sheet(surface, mesh, xyz, uv, huv, spacing)
            if darts is not None and len(darts):
                def valid(rows, nn, huv=huv, sheet=sheet):
                    return ~darts.crossing(huv[rows.ravel()], uv[nn.ravel()]).reshape(rows.shape) & sheet(rows, nn)
            else:
                valid = sheet
        h2, near = map_points(hq, mesh, xyz, xy, valid=valid, frames=frames, nearest=True, tree=tree)
        good = np.isfinite(h2).all(axis=1)
        lost += int((~good).sum())
        h2, h_uv = h2[good], np.asarray(huv, dtype=float)[good]
        if len(h2) < 3:
            continue
        if polygon_area(h2) > 0:
            h2, h_uv = h2[::-1], h_uv[::-1]
        c = np.bincount(comp[near[near >= 0]]).argmax()
        for n_, p in enumerate(pieces):
            if len(p.nodes) and comp[p.nodes[0]] == c:
                k = p.n_region_holes
                pieces[n_] = replace(p, holes=p.holes[:k] + (h2,) + p.holes[k:], n_region_holes=k + 1,
                                     holes_uv=p.holes_uv[:k] + (h_uv,))
                break
    return pieces, lost


def _components(mesh: SpringMesh) -> np.ndarray:
    """(n,) connected-component label of every node of the spring graph."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = mesh.n_nodes
    g = coo_matrix((np.ones(mesh.n_springs), (mesh.ends[:, 0], mesh.ends[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def _on_surface(surface: NurbsSurface, darts, uv: np.ndarray) -> np.ndarray | None:
    """S(uv) (n, 3) if a dart of ``darts`` tests points on the surface (a plane dart), else None."""
    return surface.points(uv) if any(d.needs_xyz for d in darts.darts) else None


def _nearest_segment_t(poly: np.ndarray, p: np.ndarray) -> tuple[int, float]:
    """(i, t): the closed polygon's segment (i, i+1) nearest to p and where along it."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
    d = np.linalg.norm(a + t[:, None] * ab - p, axis=1)
    i = int(np.argmin(d))
    return i, float(t[i])


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
            if d.needs_xyz and xa is None:
                xa, xb = self.inner.surface.points(uva), self.inner.surface.points(uvb)
            out |= d.crosses(uva, uvb, xa, xb)
        return out


def resample_uv(surface: NurbsSurface, uv: np.ndarray, step: float) -> np.ndarray:
    """Resample a (u, v) polyline evenly in arc length on the surface, about ``step`` apart."""
    if len(uv) < 2:
        return uv
    s = cumulative_length(surface.points(uv))
    if s[-1] == 0:
        return uv[:1]
    n = max(2, int(np.ceil(s[-1] / step)) + 1)
    return interp_rows(np.linspace(0.0, s[-1], n), s, uv)
