"""Cut a piece out of a mesh along loops drawn on it.

A designer's scan is rarely the piece: a bust open at its base, a last, a
mould. :func:`cut_mesh` keeps what lies inside a closed loop of 3D points drawn
on the mesh (any mesh: open, closed, or with handles elsewhere), with the
piece's outline following the drawn loop itself, not the nearest mesh edges:
the triangles the loop crosses are split. Loops drawn inside it are holes.

How. (1) The loop's points are joined by shortest edge paths, which split the
triangles into sides; the inside is the side that holds none of the mesh's own
boundary (a closed mesh: the smaller side by area). (2) That side grown by a
few rings of triangles is a disc holding the drawn loop; its least-squares
conformal map (:func:`flatweave.geometry.meshfit.lscm`) lays it flat. (3) The
loop's points go into the map through their nearest triangle (barycentric
weights), where the loop is a polygon; each triangle is clipped to it
(shapely), the pieces of a crossed triangle are triangulated (constrained
Delaunay), and every new point goes back to 3D by the weights of its triangle,
so it lies on the mesh. Points closer than a thousandth of an edge are welded,
so the loop passing next to a vertex leaves no sliver.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import shapely
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from flatweave.errors import SettingsError, SurfaceError
from flatweave.geometry.meshfit import boundary_loops, edge_table, lscm, split_pinched

__all__ = ["cut_mesh", "cut_seam", "closest_on_mesh", "project_to_mesh", "drawn_loop_on_mesh", "RINGS", "WELD"]

RINGS = 3        # rings of triangles grown round the inside side: the map holds the drawn loop
WELD = 1e-3      # of the median edge: new points this close are one (no slivers)
CANDIDATES = 24  # triangles (by nearest centroid) searched for a point's nearest
SIDE_SAMPLES = 8  # points projected along each drawn side at least (the cut follows the side's projection)
MAX_SIDE_SAMPLES = 2000  # and at most
SEARCHES = 16  # shortest-path searches run together (each keeps a row as long as the mesh)


def closest_on_mesh(V: np.ndarray, F: np.ndarray, P: np.ndarray):
    """The nearest point of triangles ``F`` to each point of ``P`` (k, 3),
    searched among the CANDIDATES triangles of nearest centroid.

    Returns (tri (k,) triangle index, w (k, 3) barycentric weights, xyz (k, 3), dist (k,)).
    """
    P = np.asarray(P, dtype=float).reshape(-1, 3)
    k = min(CANDIDATES, len(F))
    _, cand = cKDTree(V[F].mean(axis=1)).query(P, k=k)
    cand = np.asarray(cand).reshape(len(P), k)
    A, B, C = (V[F[cand, j]] for j in range(3))  # (k_points, k, 3)
    q = P[:, None, :]
    w, d = _closest_on_triangles3(q, A, B, C)
    best = np.argmin(d, axis=1)
    rows = np.arange(len(P))
    w = w[rows, best]
    tri = cand[rows, best]
    xyz = np.einsum("kj,kjd->kd", w, V[F[tri]])
    return tri, w, xyz, d[rows, best]


def project_to_mesh(V: np.ndarray, F: np.ndarray, P: np.ndarray, view) -> tuple[np.ndarray, np.ndarray]:
    """Move points along the view direction onto the mesh, as
    :func:`flatweave.geometry.curves.project_points` does onto a surface:
    each P goes to the hit of the line P + t d of smallest t (nearest the
    camera; t may be negative). Returns (xyz (k, 3), hit (k,) bool); a
    line that misses gets NaN.

    The triangles seen along d are searched by their projected centroids
    (a k-d tree in the view plane, within the largest projected
    triangle's reach), then hit exactly (barycentric in the view plane)."""
    P = np.asarray(P, dtype=float).reshape(-1, 3)
    d = np.asarray(view, dtype=float).reshape(3)
    d = d / np.linalg.norm(d)
    a = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    E = np.column_stack([a, np.cross(d, a)])  # (3, 2): the view plane
    T2 = (V @ E)[F]  # (m, 3, 2)
    c2 = T2.mean(axis=1)
    reach = float(np.linalg.norm(T2 - c2[:, None], axis=2).max())
    q = P @ E
    near = cKDTree(c2).query_ball_point(q, reach * (1 + 1e-9))
    counts = np.fromiter((len(n) for n in near), dtype=np.int64, count=len(q))
    xyz = np.full((len(P), 3), np.nan)
    if not counts.sum():
        return xyz, np.zeros(len(P), dtype=bool)
    tri = np.concatenate([np.asarray(n, dtype=np.int64) for n in near])
    row = np.repeat(np.arange(len(q)), counts)
    T = T2[tri]
    det = _signed_areas(T)
    r = q[row] - T[:, 0]
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
        t = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
    eps = 1e-12
    inside = (det != 0) & (s >= -eps) & (t >= -eps) & (s + t <= 1 + eps)
    row, tri, s, t = row[inside], tri[inside], s[inside], t[inside]
    W = np.column_stack([1 - s - t, s, t])
    X = np.einsum("kj,kjd->kd", W, V[F[tri]])
    depth = X @ d
    order = np.lexsort((depth, row))  # per point, its hits nearest the camera first
    row, X = row[order], X[order]
    first = np.r_[True, row[1:] != row[:-1]]
    xyz[row[first]] = X[first]
    return xyz, np.isfinite(xyz[:, 0])


def drawn_loop_on_mesh(V: np.ndarray, F: np.ndarray, points, view, name: str = "the mesh",
                       what: str = "the region's outer loop", closed: bool = True) -> np.ndarray:
    """A loop drawn as points seen along ``view`` (a ``--region`` spec's
    ``points`` and ``view_direction``) as a loop3d on the mesh: each straight
    side between two drawn points projected along ``view`` at SIDE_SAMPLES
    points (not ``closed``: an open polyline, a seam, ending at its last
    point). A one-line SettingsError when a drawn point misses the mesh."""
    D = _loop_points(points, what, 3 if closed else 2)
    if closed:
        step = np.roll(D, -1, axis=0) - D
    else:  # the last point a side of its own, of one sample: the polyline ends on it
        step = np.r_[np.diff(D, axis=0), np.zeros((1, 3))]
    # a point per mesh edge along each side at least: the cut joins them straight in the piece's flat map
    edge = float(np.median(np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1)))
    n = np.clip(np.ceil(np.linalg.norm(step, axis=1) / max(edge, 1e-300)), SIDE_SAMPLES, MAX_SIDE_SAMPLES)
    n = n.astype(np.int64)
    if not closed:
        n[-1] = 1
    side = np.repeat(np.arange(len(D)), n)
    frac = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    S = D[side] + (frac / n[side])[:, None] * step[side]
    xyz, hit = project_to_mesh(V, F, S, view)
    corners = hit[frac == 0]
    if not corners.all():
        raise SettingsError(f"{what} drawn on {name} misses it: point {int(np.argmin(corners)) + 1}, seen along "
                            f"the view direction, meets none of its triangles")
    return xyz[hit]  # a side's sample that slips past an edge of the mesh is left out, its neighbours kept


def _closest_on_triangles3(q, A, B, C):
    """Barycentric weights (..., 3) of the nearest point of 3D triangles (A, B, C) to q, and the distance (...)."""
    e1, e2, r = B - A, C - A, q - A
    d11, d12, d22 = (e1 * e1).sum(-1), (e1 * e2).sum(-1), (e2 * e2).sum(-1)
    r1, r2 = (r * e1).sum(-1), (r * e2).sum(-1)
    det = d11 * d22 - d12 * d12
    good = det > 1e-24 * np.maximum(d11 * d22, 1e-300)
    sdet = np.where(good, det, 1.0)
    s = (d22 * r1 - d12 * r2) / sdet
    t = (d11 * r2 - d12 * r1) / sdet
    inside = good & (s >= 0) & (t >= 0) & (s + t <= 1)
    w = np.stack([1 - s - t, s, t], axis=-1)
    dist = np.where(inside, np.linalg.norm(r - s[..., None] * e1 - t[..., None] * e2, axis=-1), np.inf)
    w = np.where(inside[..., None], w, 0.0)
    for X, Y, ix, iy in ((A, B, 0, 1), (B, C, 1, 2), (C, A, 2, 0)):
        e = Y - X
        ee = (e * e).sum(-1)
        h = np.clip(((q - X) * e).sum(-1) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
        dd = np.linalg.norm(X + h[..., None] * e - q, axis=-1)
        better = dd < dist
        dist = np.where(better, dd, dist)
        we = np.zeros(w.shape)
        we[..., ix] = 1 - h
        we[..., iy] = h
        w = np.where(better[..., None], we, w)
    return w, dist


def _loop_points(loop, what: str, at_least: int = 3) -> np.ndarray:
    try:
        P = np.asarray(loop, dtype=float).reshape(-1, 3)
    except (TypeError, ValueError):
        raise SettingsError(f"{what} must be a list of [x, y, z] points") from None
    if len(P) < at_least or not np.isfinite(P).all():
        raise SettingsError(f"{what} needs {at_least} or more finite [x, y, z] points")
    return P


def _check_near(V, F, P, what: str) -> None:
    """A one-line SettingsError when a drawn point is off the mesh by more than 5 % of its size."""
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    _, _, _, dist = closest_on_mesh(V, F, P)
    if dist.max() > 0.05 * size:
        far = int(np.argmax(dist))
        raise SettingsError(f"{what} misses it: point {far + 1} is {dist[far]:.3g} from the mesh "
                            f"({100 * dist[far] / size:.1f} % of its size)")


def _inside_side(V, F, P, name: str) -> np.ndarray:
    """(m,) bool: the triangles on the inside of the shortest edge paths through the loop's points."""
    _check_near(V, F, P, f"the loop drawn on {name}")
    _, near = cKDTree(V).query(P)
    near = near[np.r_[True, near[1:] != near[:-1]]]
    if len(near) > 1 and near[-1] == near[0]:
        near = near[:-1]
    if len(np.unique(near)) < 3:
        raise SettingsError(f"the loop drawn on {name} is too small for its triangles (it meets fewer than 3 vertices)")
    uniq, inv, _ = edge_table(F)
    G, w = _edge_graph(V, uniq)
    path = _join_vertices(V, G, near, float(w.max()), True, f"the loop drawn on {name}")
    n = len(V)
    ends = np.sort(np.column_stack([path, np.roll(path, -1)]), axis=1)
    cut_keys = np.unique(ends[:, 0] * n + ends[:, 1])
    edge_key = uniq[:, 0] * n + uniq[:, 1]
    cut_edge = np.isin(edge_key, cut_keys)
    # triangles meet across the uncut edges they share
    tri_of = np.repeat(np.arange(len(F)), 3)
    order = np.argsort(inv, kind="stable")
    counts = np.bincount(inv, minlength=len(uniq))
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    two = (counts == 2) & ~cut_edge
    t0, t1 = tri_of[order[starts[two]]], tri_of[order[starts[two] + 1]]
    A = sp.coo_matrix((np.ones(len(t0)), (t0, t1)), shape=(len(F), len(F)))
    n_sides, labels = connected_components(A, directed=False)
    if n_sides < 2:
        raise SettingsError(f"the loop drawn on {name} does not cut it in two; draw a closed loop on it")
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = np.bincount(labels, 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1), minlength=n_sides)
    rim = np.zeros(n_sides, dtype=bool)  # the sides that hold some of the mesh's own boundary
    rim[labels[tri_of[order[starts[counts == 1]]]]] = True
    inner = np.flatnonzero(~rim & (area > 0))
    side = int(inner[np.argmax(area[inner])]) if rim.any() and len(inner) else int(np.argmin(area))
    return labels == side


def _edge_graph(V: np.ndarray, edges: np.ndarray, keep: np.ndarray | None = None):
    """The mesh's edges (e, 2) as a symmetric sparse graph weighted by their
    lengths (only the ``keep`` ones, if given); returns (graph, lengths (e,))."""
    w = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1)
    e, we = (edges, w) if keep is None else (edges[keep], w[keep])
    G = sp.coo_matrix((np.r_[we, we], (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                      shape=(len(V), len(V))).tocsr()
    return G, w


def _join_vertices(V, G, near: np.ndarray, longest_edge: float, closed: bool, what: str) -> np.ndarray:
    """The vertices, in order, of the shortest paths in ``G`` from each of
    ``near`` (vertex indices) to the next (and from the last back to the
    first if ``closed``); a vertex where two paths meet is listed once."""
    nxt = np.roll(near, -1)
    # a path is at most a few times its straight gap: searching no farther keeps this local (a scan has 1e5 vertices)
    gap = np.linalg.norm(V[near] - V[nxt], axis=1)
    if not closed:
        gap = gap[:-1]
    limit = 4.0 * float(gap.max(initial=0.0)) + 4.0 * longest_edge
    n_paths = len(near) if closed else len(near) - 1
    path = []
    for k in range(n_paths):  # a path per drawn segment: the drawn points, not a hot loop
        if k % SEARCHES == 0:  # the searches a few at a time: each row is as long as the mesh
            _, pred = dijkstra(G, indices=near[k:min(k + SEARCHES, n_paths)], return_predecessors=True,
                               limit=limit)
            pred = np.atleast_2d(pred)
        row = pred[k % SEARCHES]
        a, b = near[k], nxt[k]
        if row[b] < 0 and a != b:  # farther round than the limit (a gap across a hole): search on
            row = dijkstra(G, indices=a, return_predecessors=True)[1]
            if row[b] < 0:
                raise SettingsError(f"{what} runs between parts of it that do not meet")
        seg, v = [], b
        while v != a and v >= 0:
            seg.append(v)
            v = row[v]
        path += [a] + seg[::-1][:-1]
    if not closed:
        path.append(near[-1])
    return np.asarray(path, dtype=np.int64)


def _signed_areas(T: np.ndarray) -> np.ndarray:
    """(m,) twice the signed areas of 2D triangles T (m, 3, 2)."""
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    return e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]


def _grow(F: np.ndarray, keep: np.ndarray, rings: int) -> np.ndarray:
    """``keep`` (m,) bool grown by ``rings`` rings of triangles sharing a vertex."""
    n = int(F.max()) + 1
    for _ in range(rings):
        touched = np.zeros(n, dtype=bool)
        touched[F[keep].ravel()] = True
        keep = touched[F].any(axis=1)
    return keep


def _clipped(tris, tri_uv: np.ndarray, idx: np.ndarray, poly) -> tuple[np.ndarray, np.ndarray]:
    """The parts of the map's triangles ``idx`` (``tris`` their shapely
    polygons, ``tri_uv`` (m, 3, 2) their corners) inside ``poly``,
    triangulated (constrained Delaunay): (corners (q, 3, 2), parent triangle (q,))."""
    parts = shapely.get_parts(shapely.intersection(tris[idx], poly), return_index=True)
    keep = (shapely.get_type_id(parts[0]) == 3) & (shapely.area(parts[0]) > 1e-9 * shapely.area(tris[idx][parts[1]]))
    pieces = shapely.constrained_delaunay_triangles(parts[0][keep])
    flat, parent = shapely.get_parts(pieces, return_index=True)
    coords = shapely.get_coordinates(shapely.get_exterior_ring(flat)).reshape(-1, 4, 2)[:, :3]
    return coords, idx[parts[1][keep][parent]]  # each triangle's ring: three corners and the first again


def _welded(Vd, uv, Fd, kept, coords, parent_tri):
    """One mesh of the triangles ``kept`` (of ``Fd``, on vertices ``Vd`` laid
    at ``uv``) and the new ones ``coords`` ((q, 3, 2) in the map, each inside
    its ``parent_tri``, taken to 3D by its barycentric weights there); new
    points within WELD of a median edge of another point, or of each other,
    are one (the lowest index: an old vertex if there is one), degenerate
    triangles go, and every triangle is wound as the map.
    Returns (xyz, uv, triangles (f, 3), rows kept (len(kept) + q,) bool)."""
    tri_uv = uv[Fd]
    Tuv = tri_uv[parent_tri]
    e1, e2 = Tuv[:, 1] - Tuv[:, 0], Tuv[:, 2] - Tuv[:, 0]
    det = _signed_areas(Tuv)
    r = coords - Tuv[:, None, 0]
    s = (r[..., 0] * e2[:, None, 1] - r[..., 1] * e2[:, None, 0]) / det[:, None]
    t = (e1[:, None, 0] * r[..., 1] - e1[:, None, 1] * r[..., 0]) / det[:, None]
    Wt = np.stack([1 - s - t, s, t], axis=-1)  # (q, 3, 3)
    new_xyz = np.einsum("qcj,qjd->qcd", Wt, Vd[Fd[parent_tri]])
    all_uv = np.concatenate([uv, coords.reshape(-1, 2)])
    all_xyz = np.concatenate([Vd, new_xyz.reshape(-1, 3)])
    edge = np.linalg.norm(uv[Fd[:, 0]] - uv[Fd[:, 1]], axis=1)
    tol = WELD * float(np.median(edge))
    pairs = cKDTree(all_uv).query_pairs(tol, output_type="ndarray")
    G = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(all_uv),) * 2)
    _, rep = connected_components(G, directed=False)
    first = np.full(rep.max() + 1, len(all_uv))
    np.minimum.at(first, rep, np.arange(len(all_uv)))
    new_F = np.arange(len(Vd), len(all_uv)).reshape(-1, 3)
    out_F = first[rep[np.concatenate([kept, new_F])]]
    # the winding of the map (lscm keeps the mesh's): a triangulated piece may come out either way
    sign = np.sign(_signed_areas(all_uv[out_F]))
    rows = (out_F[:, 0] != out_F[:, 1]) & (out_F[:, 1] != out_F[:, 2]) & (out_F[:, 0] != out_F[:, 2]) & (sign != 0)
    ref = np.sign(np.median(_signed_areas(tri_uv)))
    flip = sign == -ref
    out_F[flip] = out_F[flip][:, ::-1]
    return all_xyz, all_uv, out_F[rows], rows


def cut_mesh(V: np.ndarray, F: np.ndarray, loop3d, name: str = "the mesh", holes3d=()) -> tuple[np.ndarray, np.ndarray]:
    """The piece of mesh (V, F) inside the closed loop ``loop3d`` ((k, 3) points
    drawn on it, in order), less the loops ``holes3d`` drawn inside it; the
    triangles the loops cross are split (see the module docstring).

    Returns (V, F) of the piece, wound as the mesh. A one-line SettingsError
    when a loop misses the mesh, crosses itself, does not cut it in two, or
    encloses handles (no flat map holds it).
    """
    V = np.asarray(V, dtype=float)
    F = np.asarray(F, dtype=np.int64)
    P = _loop_points(loop3d, "a mesh region's loop3d")
    H = [_loop_points(h, f"hole {k + 1} of a mesh region") for k, h in enumerate(holes3d)]
    disc = _grow(F, _inside_side(V, F, P, name), RINGS)
    used, Fd = np.unique(F[disc], return_inverse=True)
    Fd = Fd.reshape(-1, 3)
    Vd, Fd, _ = split_pinched(V[used], Fd)  # the disc's rim may touch a hole of the scan at a vertex
    loops = boundary_loops(Fd, name)
    chi = len(Vd) - len(edge_table(Fd)[0]) + len(Fd)
    if (2 - chi - len(loops)) // 2 > 0:
        raise SettingsError(f"the loop drawn on {name} encloses a handle: no flat piece covers it; "
                            f"draw a smaller loop")
    uv = lscm(Vd, Fd)
    tri_uv = uv[Fd]  # (m, 3, 2)

    def to_map(Q):
        tri, w, _, _ = closest_on_mesh(Vd, Fd, Q)
        return np.einsum("kj,kjd->kd", w, tri_uv[tri])

    outer = to_map(P)
    rings_uv = [to_map(h) for h in H]
    poly = shapely.Polygon(outer, rings_uv)
    if not poly.is_valid:
        why = shapely.is_valid_reason(poly).split("[")[0].strip()
        raise SettingsError(f"the loop drawn on {name} crosses itself or a hole leaves it ({why})")
    tris = shapely.polygons(np.concatenate([tri_uv, tri_uv[:, :1]], axis=1))
    shapely.prepare(poly)
    whole = shapely.contains_properly(poly, tris)
    crossed = ~whole & shapely.intersects(poly, tris)
    coords, parent_tri = _clipped(tris, tri_uv, np.flatnonzero(crossed), poly)
    all_xyz, all_uv, out_F, _ = _welded(Vd, uv, Fd, Fd[whole], coords, parent_tri)
    if not len(out_F):
        raise SettingsError(f"the loop drawn on {name} encloses none of it")
    keep_v, out_F = np.unique(out_F, return_inverse=True)
    # where the piece's outline passes through a vertex twice (a hole of the scan touching the cut), the
    # fans meeting there become separate vertices, as clean_mesh does for the whole mesh
    Vp, Fp, _ = split_pinched(all_xyz[keep_v], out_F.reshape(-1, 3))
    return Vp, Fp


def cut_seam(V: np.ndarray, F: np.ndarray, seam3d, name: str = "the mesh") -> tuple[np.ndarray, np.ndarray]:
    """The mesh (V, F) opened along a seam drawn on it: ``seam3d`` (k >= 2, 3)
    points in order, running from one of its boundary loops to another (a
    tube, a sleeve, a leg scan: from one open end to the other), so that one
    flat piece covers it.

    The seam runs along mesh edges: the shortest edge paths through the drawn
    points' nearest vertices, kept off the mesh's boundary, then from its first
    and last point on to the nearest boundary vertex (a seam drawn a little
    short of an end still reaches it; where a path crosses itself, its loop is
    dropped). Each vertex along it becomes two, one per side, at the same
    place: the piece's outline runs up one side and down the other, so both
    sides are the same 3D polyline and unroll to the same length.

    Returns (V, F) of the opened mesh, wound as the mesh, with one boundary
    loop fewer. A one-line SettingsError when a point misses the mesh, the
    mesh has fewer than two boundary loops (closed, or a disc already), or
    both ends of the seam are on the same loop.
    """
    V = np.asarray(V, dtype=float)
    F = np.asarray(F, dtype=np.int64)
    what = f"the seam drawn on {name}"
    P = _loop_points(seam3d, "a seam", 2)
    loops = boundary_loops(F, name)
    if len(loops) < 2:
        kind = "is closed" if not loops else "has one (it opens flat as it is)"
        raise SettingsError(f"a seam runs from one of a mesh's boundary loops to another (a tube's two ends); "
                            f"{name} {kind}: draw a region on it instead")
    _check_near(V, F, P, what)
    # the drawn points joined straight and put on the mesh, at an edge's length apart: the cut follows them
    edge = float(np.median(np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1)))
    step = np.diff(P, axis=0)
    n = np.clip(np.ceil(np.linalg.norm(step, axis=1) / max(edge, 1e-300)), 1, MAX_SIDE_SAMPLES).astype(np.int64)
    side = np.repeat(np.arange(len(step)), n)
    frac = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / n[side]
    P = closest_on_mesh(V, F, np.r_[P[side] + frac[:, None] * step[side], P[-1:]])[2]
    loop_of = np.full(len(V), -1)
    for k, lp in enumerate(loops):
        loop_of[lp] = k
    edges = edge_table(F)[0]
    inner = loop_of < 0
    interior = np.flatnonzero(inner)
    if not len(interior):
        raise SettingsError(f"{name} is all edge (every vertex on its boundary): there is nothing to cut a seam in")
    # between its ends the seam keeps off the boundary: touching it there would cut a piece off
    G_in, w = _edge_graph(V, edges, keep=inner[edges].all(axis=1))
    _, j = cKDTree(V[interior]).query(P)
    near = interior[j]
    near = near[np.r_[True, near[1:] != near[:-1]]]
    middle = _join_vertices(V, G_in, near, float(w.max()), False, what)
    G, _ = _edge_graph(V, edges)
    dist, pred = dijkstra(G, indices=[middle[0], middle[-1]], return_predecessors=True)
    rim = np.flatnonzero(~inner)
    ends = []
    for k in (0, 1):  # each end on to its nearest boundary vertex (the first the search meets)
        t = int(rim[np.argmin(dist[k, rim])])
        if not np.isfinite(dist[k, t]):
            raise SettingsError(f"{what} is on a part of it with no boundary")
        walk = [t]
        while walk[-1] != middle[-k]:
            walk.append(int(pred[k, walk[-1]]))
        ends.append(walk)
    path = _loop_erased(ends[0] + middle[1:-1].tolist() + ends[1][::-1])
    a, b = loop_of[path[0]], loop_of[path[-1]]
    if a == b:
        raise SettingsError(f"{what} starts and ends on the same boundary loop of it (a seam runs from one "
                            f"open end to another: draw it from end to end)")
    Vc, Fc = _split_along(V, F, path, P, what)
    if len(boundary_loops(Fc, name)) != len(loops) - 1:  # the cut joined the two loops into one
        raise SettingsError(f"{what} does not open it into one piece (it strays from the mesh's edges near it; "
                            f"draw it with more points)")
    return Vc, Fc


def _split_along(V, F, path: np.ndarray, P: np.ndarray, what: str):
    """The mesh opened along the drawn seam ``P`` (k, 3), which runs near the
    edge path ``path`` from one boundary vertex to another: the strip of
    triangles round the path is mapped flat (LSCM), the seam drawn in the map
    from the path's first vertex through P's points to its last, the strip's
    triangles the seam crosses split along it (as :func:`cut_mesh` splits
    those its loop crosses), and the triangles on its two sides no longer
    meet. Returns (V, F)."""
    on_path = np.zeros(len(V), dtype=bool)
    on_path[path] = True
    for rings in range(RINGS, 0, -1):  # a thin tube: fewer rings, so that the strip does not wrap round it
        strip = _grow(F, on_path[F].any(axis=1), rings - 1)
        used, Fd = np.unique(F[strip], return_inverse=True)
        Fd = Fd.reshape(-1, 3)
        try:
            ring = boundary_loops(Fd)
        except SurfaceError:  # pinched: it touches itself round the tube
            continue
        if len(ring) == 1 and len(used) - len(edge_table(Fd)[0]) + len(Fd) == 1:
            break
    else:
        raise SettingsError(f"{what} cannot be opened: the tube is too thin for its triangles (a strip of "
                            f"them along the seam wraps round it)")
    Vd = V[used]
    uv = lscm(Vd, Fd)
    tri_uv = uv[Fd]
    local = np.full(len(V), -1)
    local[used] = np.arange(len(used))
    a, b = local[path[0]], local[path[-1]]
    tri, w, _, _ = closest_on_mesh(Vd, Fd, P)
    drawn = np.einsum("kj,kjd->kd", w, tri_uv[tri])
    loop = ring[0]
    # the drawn points in the strip's inside: one drawn past an end lands on the strip's edge, where the
    # seam's end (a, b) takes its place
    edge = float(np.median(np.linalg.norm(uv[Fd[:, 0]] - uv[Fd[:, 1]], axis=1)))
    outline = shapely.LinearRing(uv[loop])
    inside = shapely.contains_xy(shapely.Polygon(outline), drawn[:, 0], drawn[:, 1]) & \
        (shapely.distance(outline, shapely.points(drawn)) > 0.1 * edge)
    curve = np.concatenate([uv[[a]], drawn[inside], uv[[b]]])
    step = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    curve = curve[np.r_[True, step > WELD * edge]]
    curve[-1] = uv[b]  # (the last drawn point near the end: the end kept, not the point)
    line = shapely.LineString(curve)
    if not line.is_simple:
        raise SettingsError(f"{what} crosses itself")
    i, j = int(np.flatnonzero(loop == a)[0]), int(np.flatnonzero(loop == b)[0])
    arc_ab = np.r_[loop[i:], loop[:i]][:(j - i) % len(loop) + 1]  # the strip's outline from a round to b
    arc_ba = np.r_[loop[j:], loop[:j]][:(i - j) % len(loop) + 1]
    halves = [shapely.Polygon(np.concatenate([uv[arc_ab], curve[::-1][1:-1]])),
              shapely.Polygon(np.concatenate([uv[arc_ba], curve[1:-1]]))]
    strip_area = 0.5 * float(np.abs(_signed_areas(tri_uv)).sum())
    if not all(h.is_valid for h in halves) or abs(sum(h.area for h in halves) - strip_area) > 1e-6 * strip_area:
        raise SettingsError(f"{what} strays from the mesh's edges near it (it leaves the strip of triangles "
                            f"round it); draw it with more points")
    tris = shapely.polygons(np.concatenate([tri_uv, tri_uv[:, :1]], axis=1))
    whole = [shapely.contains_properly(h, tris) for h in halves]
    crossed = np.flatnonzero(~(whole[0] | whole[1]))
    clipped = [_clipped(tris, tri_uv, crossed, h) for h in halves]
    coords = np.concatenate([c for c, _ in clipped])
    parent = np.concatenate([p for _, p in clipped])
    kept = np.concatenate([Fd[whole[0]], Fd[whole[1]]])
    side = np.r_[np.zeros(whole[0].sum()), np.ones(whole[1].sum()), np.zeros(len(clipped[0][0])),
                 np.ones(len(clipped[1][0]))].astype(np.int64)
    xyz, _, Fs, rows = _welded(Vd, uv, Fd, kept, coords, parent)
    side = side[rows]
    # back into the whole mesh: the strip's old vertices are the mesh's, its new ones follow them
    to_global = np.r_[used, len(V) + np.arange(len(xyz) - len(Vd))]
    V_all = np.concatenate([V, xyz[len(Vd):]])
    used_v, F_all = np.unique(np.concatenate([F[~strip], to_global[Fs]]), return_inverse=True)
    F_all = F_all.reshape(-1, 3)
    tri_side = np.r_[np.full((~strip).sum(), -1), side]
    # the edges between a triangle on one side of the seam and one on the other are cut
    _, inv, count = edge_table(F_all)
    order = np.argsort(inv, kind="stable")
    rows = order[count[inv[order]] == 2].reshape(-1, 2)  # the two directed rows (3 t + k) of each interior edge
    s0, s1 = tri_side[rows[:, 0] // 3], tri_side[rows[:, 1] // 3]
    cut = np.zeros(len(count), dtype=bool)
    cut[inv[rows[:, 0]]] = (np.minimum(s0, s1) == 0) & (np.maximum(s0, s1) == 1)
    Vc, Fc, _ = split_pinched(V_all[used_v], F_all, cut)
    return Vc, Fc


def _loop_erased(path: list[int]) -> np.ndarray:
    """``path`` (vertex indices) with every loop it makes dropped: where a
    vertex comes again, what lies between its two visits goes."""
    out: list[int] = []
    at: dict[int, int] = {}
    for v in path:  # the seam's vertices: a few hundred, not a hot loop
        if v in at:
            for u in out[at[v] + 1:]:
                del at[u]
            del out[at[v] + 1:]
        else:
            at[v] = len(out)
            out.append(v)
    return np.asarray(out, dtype=np.int64)
