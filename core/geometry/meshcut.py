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

from flatweave.errors import SettingsError
from flatweave.geometry.meshfit import boundary_loops, edge_table, lscm, split_pinched

__all__ = ["cut_mesh", "closest_on_mesh", "project_to_mesh", "drawn_loop_on_mesh", "RINGS", "WELD"]

RINGS = 3        # rings of triangles grown round the inside side: the map holds the drawn loop
WELD = 1e-3      # of the median edge: new points this close are one (no slivers)
CANDIDATES = 24  # triangles (by nearest centroid) searched for a point's nearest
SIDE_SAMPLES = 8  # points projected along each drawn side at least (the cut follows the side's projection)
MAX_SIDE_SAMPLES = 2000  # and at most


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
                       what: str = "the region's outer loop") -> np.ndarray:
    """A loop drawn as points seen along ``view`` (a ``--region`` spec's
    ``points`` and ``view_direction``) as a loop3d on the mesh: each straight
    side between two drawn points projected along ``view`` at SIDE_SAMPLES
    points. A one-line SettingsError when a drawn point misses the mesh."""
    D = _loop_points(points, what)
    step = np.roll(D, -1, axis=0) - D
    # a point per mesh edge along each side at least: the cut joins them straight in the piece's flat map
    edge = float(np.median(np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1)))
    n = np.clip(np.ceil(np.linalg.norm(step, axis=1) / max(edge, 1e-300)), SIDE_SAMPLES, MAX_SIDE_SAMPLES)
    n = n.astype(np.int64)
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


def _loop_points(loop, what: str) -> np.ndarray:
    try:
        P = np.asarray(loop, dtype=float).reshape(-1, 3)
    except (TypeError, ValueError):
        raise SettingsError(f"{what} must be a list of [x, y, z] points") from None
    if len(P) < 3 or not np.isfinite(P).all():
        raise SettingsError(f"{what} needs 3 or more finite [x, y, z] points")
    return P


def _inside_side(V, F, P, name: str) -> np.ndarray:
    """(m,) bool: the triangles on the inside of the shortest edge paths through the loop's points."""
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    _, _, _, dist = closest_on_mesh(V, F, P)
    if dist.max() > 0.05 * size:
        far = int(np.argmax(dist))
        raise SettingsError(f"the loop drawn on {name} misses it: point {far + 1} is {dist[far]:.3g} from the mesh "
                            f"({100 * dist[far] / size:.1f} % of its size)")
    _, near = cKDTree(V).query(P)
    near = near[np.r_[True, near[1:] != near[:-1]]]
    if len(near) > 1 and near[-1] == near[0]:
        near = near[:-1]
    if len(np.unique(near)) < 3:
        raise SettingsError(f"the loop drawn on {name} is too small for its triangles (it meets fewer than 3 vertices)")
    uniq, inv, _ = edge_table(F)
    w = np.linalg.norm(V[uniq[:, 0]] - V[uniq[:, 1]], axis=1)
    G = sp.coo_matrix((np.r_[w, w], (np.r_[uniq[:, 0], uniq[:, 1]], np.r_[uniq[:, 1], uniq[:, 0]])),
                      shape=(len(V), len(V))).tocsr()
    # a path is at most a few times its straight gap: searching no farther keeps this local (a scan has 1e5 vertices)
    gap = np.linalg.norm(V[near] - V[np.roll(near, -1)], axis=1)
    _, pred = dijkstra(G, indices=near, return_predecessors=True, limit=4.0 * float(gap.max()) + 4.0 * float(w.max()))
    path = []
    for k in range(len(near)):  # a path per drawn segment: the loop's points, not a hot loop
        a, b = near[k], near[(k + 1) % len(near)]
        if pred[k, b] < 0 and a != b:  # farther round than the limit (a gap across a hole): search on
            pred[k] = dijkstra(G, indices=a, return_predecessors=True)[1]
            if pred[k, b] < 0:
                raise SettingsError(f"the loop drawn on {name} runs between parts of it that do not meet")
        seg, v = [], b
        while v != a and v >= 0:
            seg.append(v)
            v = pred[k, v]
        path += [a] + seg[::-1][:-1]
    path = np.asarray(path, dtype=np.int64)
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
    # the crossed triangles' pieces inside the loop, triangulated; their corners' parent triangles
    idx = np.flatnonzero(crossed)
    parts = shapely.intersection(tris[idx], poly)
    pieces = shapely.constrained_delaunay_triangles(parts)
    flat, parent = shapely.get_parts(pieces, return_index=True)
    coords, which = shapely.get_coordinates(shapely.get_exterior_ring(flat), return_index=True)
    coords = coords.reshape(-1, 4, 2)[:, :3]  # each triangle's ring: three corners and the first again
    parent_tri = idx[parent]
    # back to 3D through each corner's triangle (barycentric weights in the map)
    Tuv = tri_uv[parent_tri]
    e1, e2 = Tuv[:, 1] - Tuv[:, 0], Tuv[:, 2] - Tuv[:, 0]
    det = _signed_areas(Tuv)
    r = coords - Tuv[:, None, 0]
    s = (r[..., 0] * e2[:, None, 1] - r[..., 1] * e2[:, None, 0]) / det[:, None]
    t = (e1[:, None, 0] * r[..., 1] - e1[:, None, 1] * r[..., 0]) / det[:, None]
    Wt = np.stack([1 - s - t, s, t], axis=-1)  # (q, 3, 3)
    new_xyz = np.einsum("qcj,qjd->qcd", Wt, Vd[Fd[parent_tri]])
    # one vertex list: the disc's vertices, then the new points; points within WELD of each other are one
    kept = Fd[whole]
    all_uv = np.concatenate([uv, coords.reshape(-1, 2)])
    all_xyz = np.concatenate([Vd, new_xyz.reshape(-1, 3)])
    edge = np.linalg.norm(uv[Fd[:, 0]] - uv[Fd[:, 1]], axis=1)
    tol = WELD * float(np.median(edge))
    pairs = cKDTree(all_uv).query_pairs(tol, output_type="ndarray")
    G = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(all_uv),) * 2)
    _, rep = connected_components(G, directed=False)
    first = np.full(rep.max() + 1, len(all_uv))
    np.minimum.at(first, rep, np.arange(len(all_uv)))  # a cluster is its lowest index: an old vertex if it has one
    new_F = np.arange(len(Vd), len(all_uv)).reshape(-1, 3)
    out_F = first[rep[np.concatenate([kept, new_F])]]
    out_F = out_F[(out_F[:, 0] != out_F[:, 1]) & (out_F[:, 1] != out_F[:, 2]) & (out_F[:, 0] != out_F[:, 2])]
    # the winding of the map (lscm keeps the mesh's): a triangulated piece may come out either way
    sign = np.sign(_signed_areas(all_uv[out_F]))
    ref = np.sign(np.median(_signed_areas(tri_uv)))
    flip = sign == -ref
    out_F[flip] = out_F[flip][:, ::-1]
    out_F = out_F[sign != 0]
    if not len(out_F):
        raise SettingsError(f"the loop drawn on {name} encloses none of it")
    keep_v, out_F = np.unique(out_F, return_inverse=True)
    # where the piece's outline passes through a vertex twice (a hole of the scan touching the cut), the
    # fans meeting there become separate vertices, as clean_mesh does for the whole mesh
    Vp, Fp, _ = split_pinched(all_xyz[keep_v], out_F.reshape(-1, 3))
    return Vp, Fp
