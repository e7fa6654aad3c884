"""The planar energy method the paper compares itself against (its reference [7]).

C. C. L. Wang, S. S.-F. Smith and M. M. F. Yuen, "Surface flattening based on
energy model", Computer-Aided Design 34 (2002). Our paper (section 1) describes
it as an improvement of McCartney et al.: the surface is triangulated, the
triangles are transformed onto the plane one by one, and because the flat
triangles cannot all keep their 3D edge lengths, the length differences are
treated as the energy of a spring-mass system whose springs are the triangle
edges; the springs' forces move the nodes in the plane to better positions.
The paper's Table 3 gives this method's boundary and area errors on the garment
panel (13.52 % / 4.10 %, with a dart 5.32 % / 3.84 %). This module implements
the method so that the comparison can be run on our surfaces with our metrics.

The stages (one function each):

1. :func:`tessellate`: a triangulation of the whole parameter domain by rows.
   Rows are iso-parameter curves spaced ``spacing * sqrt(3) / 2`` apart in
   3D arc length (measured along the stacking direction, averaged across the
   row); the points of a row are spaced ``spacing`` apart in arc length along
   it, every other row staggered by half a step, and consecutive rows are
   joined by a zipper (merge of the two rows' midpoints), so the triangles are
   close to equilateral with edges about ``spacing`` long and the number of
   triangles in a row may change (a cone, a pole). The first and last rows and
   the rows' end points lie on the region's boundary. Rows run along the
   direction whose boundary edge is degenerate (the sphere octant's pole is
   one point, not a fan of slivers). Coincident vertices are welded.
2. :func:`cut_darts`: darts (plane or curve, :mod:`flatweave.method.darts`) are cut into
   the triangulation along mesh edges: the shortest edge path from the
   dart's mouth to its tip that stays near the dart's curve (Dijkstra, with
   a cost that grows with the distance from the curve) is found, its interior
   vertices are moved onto the curve, and every vertex of the path except an
   end inside the region (the tip) is split in two: the triangles on one side
   of the path keep it and those on the other side get a copy. Triangles on
   the two sides then share no vertex along the cut.
3. :func:`unfold`: breadth-first from a seed triangle near the middle of
   each piece, every triangle is laid flat across the edge it shares with
   the triangle it was reached from: its third vertex is placed from the two
   already placed ones by its two 3D edge lengths (intersection of two
   circles), on the side opposite the triangle it came from. A vertex that
   has already been placed keeps its first position, so those triangles are
   distorted: that is the error the relaxation then spreads out.
4. :func:`relax`: the spring energy over the triangle edges in the plane,
   ``E = sum k/2 (l - L)^2`` (l the 2D length, L the 3D length, k = 1 for every
   edge), is minimised over the 2D positions.
5. :func:`flatten_planar`: the pattern (outline = the boundary loop of the
   flat triangulation, dart legs walked round as in :mod:`flatweave.method.pattern`) and
   the same metrics as :func:`flatweave.method.pipeline.compute_metrics` where they make
   sense: L3 and A3 are the exact boundary length and area of the surface
   (:mod:`flatweave.geometry.quadrature`), L2 and A2 those of the outline polygon.

Differences from Wang et al. (as far as their method is described to us; we
do not have their full text here, so this is our reading of it):

* **Minimiser.** Wang et al. release the energy by moving the nodes under the
  spring forces (a spring-mass system integrated in time, Newton's second
  law). A damped spring-mass system comes to rest at a minimum of the same
  energy, so we minimise the energy directly: Levenberg-Marquardt on the
  residuals sqrt(k) (l - L) with a sparse direct solve (default, ``"lm"``),
  or scipy's L-BFGS (``"lbfgs"``), run to convergence. This gives the method
  its best result for the energy it minimises, rather than whatever a time
  step and an iteration count would stop at; ``"none"`` keeps the unfolding
  alone (the state before any relaxation) for comparison.
* **No overlap penalty, no automatic cutting.** Wang et al. also describe a
  penalty against overlapping triangles and cutting lines suggested by the
  energy map. Neither is implemented; flipped triangles are counted in the
  metrics (``flipped_triangles``), and darts are given by the user exactly as
  for our method.
* **Outline.** The outline is the flat triangulation's boundary polygon, a
  chord polygon of the boundary curve: on a boundary of curvature kappa it is
  short by about (spacing kappa)^2 / 24 of its length (0.015 % and 0.02 % on
  the bundled cone and half cylinder at spacing 0.05, under 0.005 % on the
  others at theirs); the metrics also give the 3D length and area of the
  triangulation itself (``*_3d_mesh``).
* **Triangulation.** Wang et al. start from a given triangulated surface; we
  make one from the NURBS patch as described above (the paper, section 4:
  "we tessellate the NURBS surface of the garment patch").

What we observed: the relaxed result does not depend on the unfolding (from
the unfolding, or from the surface projected onto its best plane, LM ends at
the same energy and outline on the octant, saddle, garment and dome), so the
"error built up" by the unfolding is removed by the relaxation; what remains
is the minimum of the edge-spring energy. At a dart's tip the edge strain
concentrates and grows as the mesh is refined (a V cut in a membrane), so
``max_edge_strain_pct`` with a dart is the tip's.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.sparse.linalg import splu
from scipy.spatial import cKDTree

from flatweave.version import __version__
from flatweave.method.darts import RESULT_DART_KEYS
from flatweave.geometry.nurbs import boundary_distance
from flatweave.errors import SettingsError, SolverError
from flatweave.geometry.numerics import nan_word, outline_errors, require_finite
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.lattice import MATERIALS
from flatweave.method.metrics import judge, metric_limits
from flatweave.method.pipeline import check_result_finite
from flatweave.method.result import coverage_metrics
from flatweave.method.pattern import DartOpening, Pattern, Piece, resample_uv
from flatweave.geometry.numerics import polygon_area
from flatweave.geometry.quadrature import boundary_length, edge_lengths, region_area
from flatweave.geometry.region import cover_for

__all__ = ["PLANAR_SOLVERS", "PlanarSettings", "Tessellation", "Unfolding", "RelaxResult", "PlanarResult",
           "tessellate", "cut_darts", "unfold", "spring_energy", "relax", "flatten_planar",
           "planar_result_to_dict", "planar_pattern", "planar_metrics", "triangle_edges"]

PLANAR_SOLVERS = ("lm", "lbfgs", "none")
_SQRT3_2 = math.sqrt(3.0) / 2.0


@dataclass(frozen=True)
class PlanarSettings:
    """Settings of the planar method.

    spacing : edge length of the triangulation (3D arc length)
    darts : plane and curve darts (:mod:`flatweave.method.darts`), cut into the triangulation
    solver : "lm" (Levenberg-Marquardt, default), "lbfgs" or "none" (the unfolding only)
    tol : stop when an accepted step lowers the energy by less than tol times the energy
    max_iter, max_seconds : budgets of the relaxation
    max_nodes : refuse triangulations estimated larger than this, up front
    """

    spacing: float
    darts: tuple = ()
    solver: str = "lm"
    tol: float = 1e-10
    max_iter: int = 1000
    max_seconds: float = math.inf
    max_nodes: int = 2_000_000

    def check(self) -> None:
        if not (isinstance(self.spacing, (int, float)) and math.isfinite(self.spacing) and self.spacing > 0):
            raise SettingsError(f"spacing must be a positive number, got {self.spacing!r}")
        if self.solver not in PLANAR_SOLVERS:
            raise SettingsError(f"planar solver {self.solver!r} is not one of {', '.join(PLANAR_SOLVERS)}")
        if not (self.tol >= 0 and self.max_iter >= 0 and self.max_seconds > 0):
            raise SettingsError("tol and max-iter must be >= 0 and max-seconds > 0")


@dataclass(frozen=True)
class Tessellation:
    """A triangulated region.

    uv (n, 2), xyz (n, 3) : vertices (a vertex split by a dart appears twice,
        with the same uv and xyz)
    tri (t, 3) : triangles, counter-clockwise in (u, v)
    on_boundary (n,) : vertex lies on the region's boundary
    cuts : one dict per dart cut in: ``name``, ``kind``, ``chain`` (vertex ids
        from mouth to tip on the positive side), ``chain_neg`` (the same
        positions on the negative side; equal ids where a vertex was not
        split), ``mouth`` (the dart starts on the boundary)
    """

    uv: np.ndarray
    xyz: np.ndarray
    tri: np.ndarray
    on_boundary: np.ndarray
    cuts: tuple = ()

    @property
    def n_vertices(self) -> int:
        return len(self.uv)


# ----------------------------------------------------------------------------- tessellation

def _grid_uv(s: np.ndarray, r: np.ndarray, s_axis: int) -> np.ndarray:
    """(u, v) pairs from row coordinates s (along a row) and r (across rows)."""
    out = np.empty((len(s), 2))
    out[:, s_axis] = s
    out[:, 1 - s_axis] = r
    return out


def _zipper(ta: np.ndarray, tb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles joining two rows with fractions ta (na,) and tb (nb,) along them.

    Each triangle advances one row by one point; the advances are taken in the
    order of the midpoints of the rows' segments (a merge), so the rows are
    stitched evenly whatever their counts. Returns, per triangle, the local
    indices (i in row a, j in row b) it starts from and whether it advances
    row a (True: triangle a_i, a_i+1, b_j) or row b (a_i, b_j+1, b_j).
    """
    ka = 0.5 * (ta[:-1] + ta[1:])
    kb = 0.5 * (tb[:-1] + tb[1:])
    keys = np.concatenate([ka, kb])
    is_a = np.concatenate([np.ones(len(ka), bool), np.zeros(len(kb), bool)])
    order = np.argsort(keys, kind="stable")
    is_a = is_a[order]
    i = np.cumsum(is_a) - is_a  # a-advances before this event
    j = np.cumsum(~is_a) - (~is_a)
    return i, j, is_a


def tessellate(surface: NurbsSurface, spacing: float, max_nodes: int = 2_000_000) -> Tessellation:
    """Triangulate the whole parameter domain with edges about ``spacing`` long
    (see the module docstring). Vectorised apart from a loop over rows."""
    if not (math.isfinite(spacing) and spacing > 0):
        raise SettingsError(f"spacing must be a positive number, got {spacing!r}")
    dom = surface.domain
    h = float(spacing)
    tiny = 1e-9 * surface.bbox_diagonal()
    lengths = edge_lengths(surface)  # 0: v = v0, 1: u = u1, 2: v = v1, 3: u = u0
    # rows are iso-v curves (s = u) unless an iso-u boundary edge is a point (a pole)
    s_axis = 1 if (lengths[1] < tiny or lengths[3] < tiny) and not (lengths[0] < tiny or lengths[2] < tiny) else 0
    r_axis = 1 - s_axis
    s0, s1 = dom[s_axis]
    r0, r1 = dom[r_axis]

    # arc length across the rows: |dS/dr| averaged along s, integrated in r
    ms, mr = 65, 257
    sg = np.linspace(s0, s1, ms)
    rg = np.linspace(r0, r1, mr)
    S_grid, R_grid = np.meshgrid(sg, rg, indexing="ij")
    _, Su, Sv = surface.derivatives(_grid_uv(S_grid.ravel(), R_grid.ravel(), s_axis))
    _check_points(np.hstack([Su, Sv]), "derivative samples", "triangulating", "derivative")
    dr = (Sv if r_axis == 1 else Su)
    ds = (Su if s_axis == 0 else Sv)
    speed_r = np.linalg.norm(dr, axis=1).reshape(ms, mr)
    speed_s = np.linalg.norm(ds, axis=1).reshape(ms, mr)
    g = np.trapezoid(speed_r, sg, axis=0) / (s1 - s0)
    G = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(rg))])
    # area estimate for the size check (same grid)
    jac = np.linalg.norm(np.cross(Su, Sv), axis=1).reshape(ms, mr)
    area = float(np.trapezoid(np.trapezoid(jac, rg, axis=1), sg))
    est = int(area / (_SQRT3_2 * h * h)) + 2 * int((lengths.sum()) / h) + 4
    if est > max_nodes:
        smallest = math.sqrt(area / (_SQRT3_2 * max_nodes))
        raise SettingsError(f"spacing {h:g} needs about {est:,} vertices, more than the limit of {max_nodes:,}; "
                            f"the smallest spacing that fits is about {smallest:.3g}")
    if G[-1] <= tiny:
        raise SettingsError("the surface has no extent across its rows (a degenerate patch)")
    n_rows = max(1, int(round(G[-1] / (_SQRT3_2 * h)))) + 1
    r_rows = np.interp(np.linspace(0.0, G[-1], n_rows), G, rg)
    r_rows[0], r_rows[-1] = r0, r1

    # arc length along every row (chord sums of a fine sampling)
    width = float(np.max(np.trapezoid(speed_s, sg, axis=0)))
    mfine = int(min(max(65, 8 * math.ceil(width / h) + 1), 20001))
    sf = np.linspace(s0, s1, mfine)
    P = surface.points(_grid_uv(np.tile(sf, n_rows), np.repeat(r_rows, mfine), s_axis)).reshape(n_rows, mfine, 3)
    _check_points(P, "row samples", "triangulating")
    C = np.concatenate([np.zeros((n_rows, 1)), np.cumsum(np.linalg.norm(np.diff(P, axis=1), axis=2), axis=1)],
                       axis=1)
    L_rows = C[:, -1]

    rows_s, rows_t = [], []
    for k in range(n_rows):
        Lk = L_rows[k]
        if Lk <= tiny:  # a pole: one point
            rows_s.append(np.array([0.5 * (s0 + s1)]))
            rows_t.append(np.array([0.5]))
            continue
        n = max(1, int(round(Lk / h)))
        if k % 2:  # staggered by half a step, ends on the boundary
            t = np.concatenate([[0.0], (np.arange(n) + 0.5) / n, [1.0]])
        else:
            t = np.arange(n + 1) / n
        s = np.interp(t * Lk, C[k], sf)
        s[0], s[-1] = s0, s1
        rows_s.append(s)
        rows_t.append(t)

    counts = np.array([len(s) for s in rows_s])
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    s_all = np.concatenate(rows_s)
    r_all = np.repeat(r_rows, counts)
    uv = _grid_uv(s_all, r_all, s_axis)
    tris = []
    for k in range(n_rows - 1):
        i, j, is_a = _zipper(rows_t[k], rows_t[k + 1])
        a0, b0 = start[k], start[k + 1]
        t3 = np.where(is_a[:, None],
                      np.column_stack([a0 + i, a0 + i + 1, b0 + j]),
                      np.column_stack([a0 + i, b0 + j + 1, b0 + j]))
        tris.append(t3)
    tri = np.concatenate(tris).astype(np.int64)
    if s_axis == 1:  # (s, r) = (v, u) is a reflection of (u, v): make them counter-clockwise in (u, v)
        tri = tri[:, [0, 2, 1]]
    xyz = surface.points(uv)
    _check_points(xyz, "vertices", "triangulating")
    on_b = (boundary_distance(surface, uv) < 1e-12)
    return _weld(Tessellation(uv, xyz, tri, on_b), tiny)


def _check_points(xyz: np.ndarray, what: str, when: str, kind: str = "point") -> None:
    """SolverError unless every point (or derivative) of the surface is finite."""
    require_finite("the surface evaluation", xyz.reshape(-1, xyz.shape[-1]), what, when=f" while {when}",
                   state=f"returned a non-finite {kind}")


def _weld(t: Tessellation, tol: float) -> Tessellation:
    """Merge vertices that coincide in 3D (a degenerate edge that is not a
    single row), drop triangles that became degenerate and unused vertices."""
    pairs = cKDTree(t.xyz).query_pairs(tol, output_type="ndarray")
    tri = t.tri
    if len(pairs):
        n = t.n_vertices
        g = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = connected_components(g, directed=False)
        first = np.full(label.max() + 1, n)
        np.minimum.at(first, label, np.arange(n))
        tri = first[label][tri]
    ok = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
    a, b, c = (t.xyz[tri[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    ok &= area > tol * tol
    tri = tri[ok]
    used = np.zeros(t.n_vertices, bool)
    used[tri.ravel()] = True
    new = np.cumsum(used) - 1
    return Tessellation(t.uv[used], t.xyz[used], new[tri], t.on_boundary[used], t.cuts)


def triangle_edges(tri: np.ndarray) -> np.ndarray:
    """(m, 2) the unique undirected edges of triangles (t, 3), smaller id first."""
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e.sort(axis=1)
    return np.unique(e, axis=0)


def _neighbours(tri: np.ndarray, n: int) -> np.ndarray:
    """(t, 3): the triangle across local edge k (tri[k] -> tri[k+1]) of each triangle, -1 on the boundary."""
    t = len(tri)
    a = tri.ravel()
    b = tri[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * n + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    _, counts = np.unique(ks, return_counts=True)
    if counts.size and counts.max() > 2:
        raise SettingsError("the triangulation has an edge shared by more than two triangles")
    same = np.flatnonzero(ks[1:] == ks[:-1])
    nbr = np.full(3 * t, -1, dtype=np.int64)
    h1, h2 = order[same], order[same + 1]
    nbr[h1] = h2 // 3
    nbr[h2] = h1 // 3
    return nbr.reshape(t, 3)


# ----------------------------------------------------------------------------- darts

def cut_darts(surface: NurbsSurface, tess: Tessellation, darts, spacing: float) -> Tessellation:
    """Cut every dart into the triangulation along a path of mesh edges (see the
    module docstring). Returns a new :class:`Tessellation` with the split
    vertices and one entry per dart in ``cuts``."""
    for dart in darts:
        tess = _cut_one(surface, tess, dart, spacing)
    return tess


def _cut_one(surface: NurbsSurface, tess: Tessellation, dart, h: float) -> Tessellation:
    cuv = resample_uv(surface, np.asarray(dart.curve_uv(surface), dtype=float), h / 8)
    if len(cuv) < 2:
        raise SettingsError(f"{dart.name} does not meet the surface (inside its box)")
    c3 = surface.points(cuv)
    curve_len = float(np.linalg.norm(np.diff(c3, axis=0), axis=1).sum())
    if curve_len < h:
        raise SettingsError(f"{dart.name} is {curve_len:.3g} long on the surface, shorter than the spacing {h:g}")
    uv, xyz, tri, onb = tess.uv.copy(), tess.xyz.copy(), tess.tri, tess.on_boundary
    n = len(uv)
    ends_on_edge = boundary_distance(surface, cuv[[0, -1]]) < 1e-6
    tree = cKDTree(c3)
    dist, near = tree.query(xyz, distance_upper_bound=3 * h)
    edges = triangle_edges(tri)

    def end_vertex(p3, boundary):
        cand = np.flatnonzero(onb if boundary else ~onb)
        k = int(np.argmin(np.linalg.norm(xyz[cand] - p3, axis=1)))
        return int(cand[k])

    src = end_vertex(c3[0], bool(ends_on_edge[0]))
    dst = end_vertex(c3[-1], bool(ends_on_edge[1]))
    if src == dst:
        raise SettingsError(f"{dart.name} is too short for the spacing {h:g}")
    # path cost: edge length, growing with the ends' distance from the curve;
    # interior path vertices may not lie on the region's boundary
    a, b = edges[:, 0], edges[:, 1]
    L = np.linalg.norm(xyz[a] - xyz[b], axis=1)
    with np.errstate(invalid="ignore"):
        cost = L * (1.0 + 20.0 * ((dist[a] + dist[b]) / (2 * h)) ** 2)
    inner_ok = ~onb.copy()
    inner_ok[[src, dst]] = True
    keep = np.isfinite(cost) & inner_ok[a] & inner_ok[b]
    G = sparse.coo_matrix((cost[keep], (a[keep], b[keep])), shape=(n, n)).tocsr()
    _, pred = dijkstra(G, directed=False, indices=src, return_predecessors=True)
    if pred[dst] < 0:
        raise SettingsError(f"{dart.name}: no path of mesh edges follows it at spacing {h:g}")
    chain = [dst]
    while chain[-1] != src:
        chain.append(int(pred[chain[-1]]))
    chain = np.array(chain[::-1])

    # move the interior path vertices onto the curve, and an end on the boundary
    # along its boundary edge to the curve's end (not a corner), unless a triangle would fold
    movable = chain[~onb[chain]]
    target = cuv[tree.query(xyz[movable])[1]]
    for i, e in ((0, 0), (-1, -1)):
        v = chain[i]
        goal = _slide_target(surface, uv[v], cuv[e]) if onb[v] and ends_on_edge[i] else None
        if goal is not None:
            movable = np.append(movable, v)
            target = np.vstack([target, goal])
    if len(movable):
        old_uv = uv[movable].copy()
        uv[movable] = target
        xyz[movable] = surface.points(target)
        area0 = _uv_area(tess.uv, tri)
        for _ in range(len(movable) + 1):
            bad = _uv_area(uv, tri) < 0.2 * area0
            if not bad.any():
                break
            back = np.isin(movable, tri[bad].ravel()) & np.any(uv[movable] != old_uv, axis=1)
            if not back.any():
                break
            uv[movable[back]] = old_uv[back]
            xyz[movable[back]] = surface.points(old_uv[back])

    # split: at every path vertex except an end inside the region, the fan of
    # triangles around it falls into pieces separated by the path's edges
    path_edges = {(min(p, q), max(p, q)) for p, q in zip(chain[:-1], chain[1:])}
    split = [v for i, v in enumerate(chain)
             if not ((i == 0 and not ends_on_edge[0]) or (i == len(chain) - 1 and not ends_on_edge[1]))]
    order = np.argsort(tri.ravel(), kind="stable")
    first = np.searchsorted(tri.ravel()[order], np.arange(n + 1))
    tri = tri.copy()
    new_uv, new_xyz, new_onb = [], [], []
    copy_of = {}
    cent_uv = uv[tri].mean(axis=1)
    cent_xyz = xyz[tri].mean(axis=1)
    for v in split:
        fan = order[first[v]:first[v + 1]] // 3
        parent = {int(t): int(t) for t in fan}

        def find(x):
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        # triangles of the fan sharing an edge (v, w) that is not a path edge are joined
        by_w = {}
        for t in fan:
            for w in tri[t]:
                if w != v and (min(v, w), max(v, w)) not in path_edges:
                    by_w.setdefault(int(w), []).append(int(t))
        for ts in by_w.values():
            for t in ts[1:]:
                parent[find(t)] = find(ts[0])
        groups = {}
        for t in fan:
            groups.setdefault(find(int(t)), []).append(int(t))
        if len(groups) < 2:
            continue
        # the group on the dart's positive side keeps the vertex
        sides = {gid: float(np.mean(dart.side(cent_uv[ts], cent_xyz[ts]))) for gid, ts in groups.items()}
        keeper = max(sides, key=sides.get)
        for gid, ts in groups.items():
            if gid == keeper:
                continue
            nv = n + len(new_uv)
            new_uv.append(uv[v])
            new_xyz.append(xyz[v])
            new_onb.append(onb[v])
            for t in ts:
                tri[t][tri[t] == v] = nv
            copy_of[v] = nv
    if not copy_of:
        raise SettingsError(f"{dart.name} does not cut the triangulation at spacing {h:g}")
    if new_uv:
        uv = np.vstack([uv, new_uv])
        xyz = np.vstack([xyz, new_xyz])
        onb = np.concatenate([onb, new_onb])
    chain_neg = np.array([copy_of.get(int(v), int(v)) for v in chain])
    cut = {"name": dart.name, "kind": dart.kind, "chain": chain, "chain_neg": chain_neg,
           "mouth": bool(ends_on_edge[0])}
    return Tessellation(uv, xyz, tri, onb, tess.cuts + (cut,))


def _sides(surface: NurbsSurface, uv: np.ndarray, rel: float = 1e-12) -> set:
    """The domain sides (2 axis + end: 0 u = u0, 1 u = u1, 2 v = v0, 3 v = v1) a
    parameter point lies on, within ``rel`` of the domain's size."""
    dom = surface.domain
    tol = rel * np.ptp(dom, axis=1)
    return {2 * ax + end for ax in (0, 1) for end in (0, 1) if abs(uv[ax] - dom[ax, end]) <= tol[ax]}


def _slide_target(surface: NurbsSurface, uv_vertex: np.ndarray, uv_end: np.ndarray):
    """Where a boundary vertex may slide to reach a dart's end on the boundary:
    the end put exactly on the vertex's side, or None (a corner, another side)."""
    sv = _sides(surface, uv_vertex)
    if len(sv) != 1 or not sv <= _sides(surface, uv_end, 1e-6):
        return None
    side = next(iter(sv))
    out = np.array(uv_end, dtype=float)
    out[side // 2] = surface.domain[side // 2, side % 2]
    return out


def _uv_area(uv: np.ndarray, tri: np.ndarray) -> np.ndarray:
    a, b, c = uv[tri[:, 0]], uv[tri[:, 1]], uv[tri[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


# ----------------------------------------------------------------------------- unfolding

@dataclass(frozen=True)
class Unfolding:
    """The triangles laid flat one by one.

    xy (n, 2) : vertex positions; order (t,) : triangles in the order they
    were laid; via (t, 2) : the shared edge (vertex ids) each triangle was
    reached across (-1 for seeds); placed (t,) : the vertex each triangle
    placed (-1 if its third vertex had been placed before; for a seed its
    third vertex); seeds : one seed triangle per piece; clamped : placements
    whose two circles did not meet (the vertex went on the shared edge's line)
    """

    xy: np.ndarray
    order: np.ndarray
    via: np.ndarray
    placed: np.ndarray
    seeds: tuple
    clamped: int


def _place(pa, pb, la, lb, po):
    """The point at distances la from pa and lb from pb, on the side of line
    pa-pb away from po. Returns (x, y, clamped)."""
    dx, dy = pb[0] - pa[0], pb[1] - pa[1]
    d = math.hypot(dx, dy)
    if d == 0.0:
        return pa[0] + la, pa[1], True
    ex, ey = dx / d, dy / d
    x = (la * la - lb * lb + d * d) / (2.0 * d)
    y2 = la * la - x * x
    clamped = y2 < 0.0
    y = math.sqrt(y2) if not clamped else 0.0
    # away from po: po lies on the side sign(cross(e, po - pa)); go to the other
    side = ex * (po[1] - pa[1]) - ey * (po[0] - pa[0])
    sgn = -1.0 if side > 0 else 1.0
    return pa[0] + x * ex - sgn * y * ey, pa[1] + x * ey + sgn * y * ex, clamped


def unfold(xyz: np.ndarray, tri: np.ndarray, seeds=None, uv: np.ndarray | None = None) -> Unfolding:
    """Lay the triangles flat, breadth-first from one seed triangle per piece.

    seeds : seed triangles (default: per connected piece, the triangle whose
    (u, v) centroid is nearest the piece's mean centroid, or the 3D one
    without ``uv``). O(t): one pass over the triangles.
    """
    n, t = len(xyz), len(tri)
    nbr = _neighbours(tri, n)
    if seeds is None:
        seeds = _default_seeds(tri, nbr, uv if uv is not None else xyz)
    tl = tri.tolist()
    nl = nbr.tolist()
    X = xyz.tolist()
    xy = [None] * n
    visited = [False] * t
    order, via, placed = [], [[-1, -1]] * t, [-1] * t
    clamped = 0

    def dist(i, j):
        a, b = X[i], X[j]
        return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)

    for s in seeds:
        s = int(s)
        if visited[s]:
            continue
        a, b, c = tl[s]
        # a new piece: its first edge along +x, the third vertex counter-clockwise
        # (pieces are moved apart later); a vertex shared with a piece laid
        # before (the pieces touch at a point) stays and the seed is moved to it
        lab = dist(a, b)
        x, y, cl = _place((0.0, 0.0), (lab, 0.0), dist(a, c), dist(b, c), (0.5 * lab, -1.0))
        fresh = {a: (0.0, 0.0), b: (lab, 0.0), c: (x, y)}
        known = [v for v in (a, b, c) if xy[v] is not None]
        dx, dy = (xy[known[0]][0] - fresh[known[0]][0], xy[known[0]][1] - fresh[known[0]][1]) if known else (0, 0)
        for v in (a, b, c):
            if xy[v] is None:
                xy[v] = (fresh[v][0] + dx, fresh[v][1] + dy)
        clamped += cl
        placed[s] = c if c not in known else -1
        visited[s] = True
        order.append(s)
        queue = deque([s])
        while queue:
            cur = queue.popleft()
            tc = tl[cur]
            for k in range(3):
                nb = nl[cur][k]
                if nb < 0 or visited[nb]:
                    continue
                visited[nb] = True
                p, q, o = tc[k], tc[(k + 1) % 3], tc[(k + 2) % 3]
                tn = tl[nb]
                r = tn[0] if tn[0] != p and tn[0] != q else (tn[1] if tn[1] != p and tn[1] != q else tn[2])
                if xy[r] is None:
                    x, y, cl = _place(xy[p], xy[q], dist(p, r), dist(q, r), xy[o])
                    xy[r] = (x, y)
                    clamped += cl
                    placed[nb] = r
                via[nb] = [p, q]
                order.append(nb)
                queue.append(nb)
    out = np.array([p if p is not None else (np.nan, np.nan) for p in xy], dtype=float)
    return Unfolding(out, np.array(order, dtype=np.int64), np.array(via, dtype=np.int64),
                     np.array(placed, dtype=np.int64), tuple(int(s) for s in seeds), int(clamped))


def _default_seeds(tri: np.ndarray, nbr: np.ndarray, coords: np.ndarray) -> list[int]:
    """Per connected piece of the triangle graph, the triangle nearest its middle."""
    t = len(tri)
    rows = np.repeat(np.arange(t), 3)
    cols = nbr.ravel()
    ok = cols >= 0
    g = sparse.coo_matrix((np.ones(ok.sum()), (rows[ok], cols[ok])), shape=(t, t))
    ncomp, label = connected_components(g, directed=False)
    cent = coords[tri].mean(axis=1)
    seeds = []
    sizes = np.bincount(label, minlength=ncomp)
    for c in np.argsort(-sizes):
        idx = np.flatnonzero(label == c)
        mid = cent[idx].mean(axis=0)
        seeds.append(int(idx[np.argmin(np.linalg.norm(cent[idx] - mid, axis=1))]))
    return seeds


# ----------------------------------------------------------------------------- energy and relaxation

def spring_energy(xy: np.ndarray, edges: np.ndarray, rest: np.ndarray, k: np.ndarray | float = 1.0):
    """E = sum k/2 (l - L)^2 over the edges and its gradient (n, 2) in the 2D positions."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    d = xy[edges[:, 0]] - xy[edges[:, 1]]
    l = np.sqrt(np.einsum("ij,ij->i", d, d))
    res = l - rest
    kk = np.broadcast_to(np.asarray(k, dtype=float), res.shape)
    E = 0.5 * float(np.sum(kk * res * res))
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(l > 0, kk * res / l, 0.0)[:, None] * d  # dE/dx_a for every edge
    n = len(xy)
    gx = np.bincount(edges[:, 0], weights=f[:, 0], minlength=n) - np.bincount(edges[:, 1], weights=f[:, 0], minlength=n)
    gy = np.bincount(edges[:, 0], weights=f[:, 1], minlength=n) - np.bincount(edges[:, 1], weights=f[:, 1], minlength=n)
    return E, np.column_stack([gx, gy])


@dataclass(frozen=True)
class RelaxResult:
    xy: np.ndarray
    energy: float
    energy_start: float
    nit: int
    nfev: int
    message: str
    seconds: float
    history: tuple = ()


def relax(xy0: np.ndarray, edges: np.ndarray, rest: np.ndarray, k: np.ndarray | float = 1.0,
          solver: str = "lm", tol: float = 1e-10, max_iter: int = 1000,
          max_seconds: float = math.inf) -> RelaxResult:
    """Minimise :func:`spring_energy` over the 2D positions, from xy0.

    "lm": Levenberg-Marquardt on the residuals sqrt(k) (l - L): the Gauss-Newton
    matrix J^T J (2x2 blocks per edge) plus lambda diag(J^T J), factorised by
    SuperLU; a step is accepted when it lowers the energy, lambda follows the
    gain ratio (Nielsen's rule). Stops when an accepted step lowers the energy
    by less than ``tol`` times the energy, or the energy is negligible
    (1e-24 of sum k L^2). "lbfgs": scipy's L-BFGS-B with the same gradient.
    "none": no relaxation. A start whose energy or gradient is not finite
    raises :class:`~flatweave.errors.SolverError`.
    """
    t0 = time.perf_counter()
    xy = np.asarray(xy0, dtype=float).copy()
    n = len(xy)
    kk = np.broadcast_to(np.asarray(k, dtype=float), rest.shape).astype(float)
    E0, g = spring_energy(xy, edges, rest, kk)
    if not (math.isfinite(E0) and np.isfinite(g).all()):
        what = "energy" if not math.isfinite(E0) else "energy's gradient"
        word = nan_word(np.append(E0, g))
        raise SolverError(f"the planar {what} became {word} in the unfolded start (non-finite positions or rest "
                          f"lengths); the solve stopped and nothing was changed")
    floor = 1e-24 * float(np.sum(kk * rest * rest))
    if solver == "none" or E0 <= floor or max_iter == 0:
        return RelaxResult(xy, E0, E0, 0, 1, "no relaxation" if solver == "none" else "converged",
                           time.perf_counter() - t0, (E0,))
    if solver == "lbfgs":
        from scipy.optimize import minimize

        nfev = [0]

        def fun(x):
            nfev[0] += 1
            e, gr = spring_energy(x.reshape(-1, 2), edges, rest, kk)
            return e, gr.ravel()

        res = minimize(fun, xy.ravel(), jac=True, method="L-BFGS-B",
                       options={"maxiter": max_iter, "maxfun": 20 * max_iter + 100, "ftol": tol,
                                "gtol": 1e-14, "maxcor": 20})
        return RelaxResult(res.x.reshape(-1, 2), float(res.fun), E0, int(res.nit), nfev[0],
                           "converged" if res.success else str(res.message), time.perf_counter() - t0)
    if solver != "lm":
        raise SettingsError(f"planar solver {solver!r} is not one of {', '.join(PLANAR_SOLVERS)}")

    a, b = edges[:, 0], edges[:, 1]
    sq = np.sqrt(kk)
    # sparsity of J^T J: a 2x2 block per (a, a), (b, b), (a, b), (b, a)
    ia = np.stack([2 * a, 2 * a + 1], axis=1)
    ib = np.stack([2 * b, 2 * b + 1], axis=1)
    cols_e = np.concatenate([ia, ib], axis=1)  # (m, 4): the unknowns of each residual
    R = np.repeat(cols_e, 4, axis=1).ravel()
    C = np.tile(cols_e, (1, 4)).ravel()
    lam, nu = 1e-3, 2.0
    E, nit, nfev, msg = E0, 0, 1, "iteration limit"
    history = [E0]
    J = _jacobian(xy, a, b, sq)
    while nit < max_iter:
        if time.perf_counter() - t0 > max_seconds:
            msg = f"stopped at the time budget ({max_seconds:g} s)"
            break
        nit += 1
        vals = np.einsum("mi,mj->mij", J, J).ravel()
        A = sparse.coo_matrix((vals, (R, C)), shape=(2 * n, 2 * n)).tocsc()
        A.sum_duplicates()
        grad = g.ravel()
        dgl = A.diagonal()
        dmax = float(dgl.max()) if len(dgl) else 1.0
        accepted = False
        while True:
            M = A + sparse.diags(lam * dgl + 1e-12 * dmax, format="csc")
            try:
                lu = splu(M, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options={"SymmetricMode": True})
                step = -lu.solve(grad)
            except RuntimeError:  # singular: damp harder
                lam *= 10.0
                if lam > 1e16:
                    break
                continue
            xn = xy + step.reshape(-1, 2)
            En, gn = spring_energy(xn, edges, rest, kk)
            nfev += 1
            pred = -(grad @ step + 0.5 * step @ (A @ step))
            rho = (E - En) / pred if pred > 0 else -1.0
            if En < E and rho > 0:
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
                accepted = True
                break
            lam *= nu
            nu *= 2.0
            if lam > 1e16:
                break
        if not accepted:
            msg = "converged (no further decrease)"
            break
        drop = E - En
        xy, E, g = xn, En, gn
        history.append(E)
        J = _jacobian(xy, a, b, sq)
        if drop <= tol * E or E <= floor:
            msg = "converged"
            break
    return RelaxResult(xy, E, E0, nit, nfev, msg, time.perf_counter() - t0, tuple(history))


def _jacobian(xy, a, b, sq):
    """(m, 4) rows of dr/d(xa, ya, xb, yb) for r = sqrt(k) (l - L)."""
    d = xy[a] - xy[b]
    l = np.sqrt(np.einsum("ij,ij->i", d, d))
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(l[:, None] > 0, d / l[:, None], 0.0)
    return sq[:, None] * np.concatenate([u, -u], axis=1)


# ----------------------------------------------------------------------------- the whole method

@dataclass(frozen=True)
class PlanarResult:
    """A piece flattened by the planar method.

    tess : the (cut) triangulation; edges (m, 2), rest (m,) : its edges and 3D lengths
    unfolding : the triangles laid flat; relax : the relaxation
    xy (n, 2) : final 2D positions (pieces moved apart); pattern : outline etc.
    metrics : dict (the keys of :func:`flatweave.method.pipeline.compute_metrics` that apply, and more)
    """

    surface: NurbsSurface
    settings: PlanarSettings
    tess: Tessellation
    edges: np.ndarray
    rest: np.ndarray
    unfolding: Unfolding
    relax: RelaxResult
    xy: np.ndarray
    pattern: Pattern
    metrics: dict
    stats: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    status: str = ""  # the solver's and the pattern's (flatweave.method.metrics.Verdict.status)


def flatten_planar(surface: NurbsSurface, settings: PlanarSettings, area: float | None = None) -> PlanarResult:
    """Tessellate, cut the darts, unfold, relax, build the pattern and its metrics."""
    settings.check()
    t0 = time.perf_counter()
    h = float(settings.spacing)
    tess = tessellate(surface, h, settings.max_nodes)
    if settings.darts:
        tess = cut_darts(surface, tess, settings.darts, h)
        _check_points(tess.xyz, "vertices", "cutting the darts")
    t_tess = time.perf_counter() - t0
    edges = triangle_edges(tess.tri)
    rest = np.linalg.norm(tess.xyz[edges[:, 0]] - tess.xyz[edges[:, 1]], axis=1)
    t1 = time.perf_counter()
    unf = unfold(tess.xyz, tess.tri, uv=tess.uv)
    t_unf = time.perf_counter() - t1
    if np.isnan(unf.xy).any():
        raise SettingsError("some vertices were not reached by the unfolding (isolated vertices)")
    rr = relax(unf.xy, edges, rest, 1.0, settings.solver, settings.tol, settings.max_iter, settings.max_seconds)
    xy = _separate_pieces(rr.xy, tess.tri, h)
    pattern = planar_pattern(tess, xy)
    metrics = planar_metrics(surface, tess, edges, rest, xy, pattern, area=area)
    metrics.update({
        "energy": rr.energy, "energy_unfolded": rr.energy_start, "iterations": rr.nit,
        "energy_evaluations": rr.nfev, "solver_status": rr.message, "clamped_placements": unf.clamped,
        "tessellate_seconds": t_tess, "unfold_seconds": t_unf, "solve_seconds": rr.seconds,
        "seconds": time.perf_counter() - t0,
    })
    check_result_finite(tess.uv, tess.xyz, pattern, metrics)
    metrics["total_curvature"] = cover_for(surface).total_curvature
    # the spring method's limits; the planar metrics have no thread strain or cell shear to judge
    verdict = judge(metrics, settings, metric_limits(MATERIALS["isotropic"],
                                                     total_curvature=metrics["total_curvature"]))
    return PlanarResult(surface, settings, tess, edges, rest, unf, rr, xy, pattern, metrics,
                        {"seeds": list(unf.seeds)}, verdict.warnings, verdict.status)


def _separate_pieces(xy: np.ndarray, tri: np.ndarray, gap: float) -> np.ndarray:
    """Move the pieces (connected parts) side by side along x, largest first."""
    n = len(xy)
    g = sparse.coo_matrix((np.ones(3 * len(tri)), (tri[:, [0, 1, 2]].ravel(), tri[:, [1, 2, 0]].ravel())),
                          shape=(n, n))
    ncomp, label = connected_components(g, directed=False)
    if ncomp == 1:
        return xy
    xy = xy.copy()
    sizes = np.bincount(label, minlength=ncomp)
    x_at = None
    for c in np.argsort(-sizes):
        idx = label == c
        lo, hi = xy[idx].min(axis=0), xy[idx].max(axis=0)
        if x_at is None:
            x_at = hi[0] + 2 * gap
            continue
        xy[idx] += np.array([x_at - lo[0], 0.0])
        x_at += hi[0] - lo[0] + 2 * gap
    return xy


def _boundary_loops(tri: np.ndarray) -> list[np.ndarray]:
    """Closed loops of the boundary half-edges of counter-clockwise triangles
    (vertex ids). Each boundary half-edge is used once; where the boundary
    touches itself at a vertex, the walk takes any unused outgoing half-edge."""
    a = tri.ravel()
    b = tri[:, [1, 2, 0]].ravel()
    n = int(tri.max()) + 1
    is_b = ~np.isin(a * n + b, b * n + a)
    out = {}
    for p, q in zip(a[is_b].tolist(), b[is_b].tolist()):
        out.setdefault(p, []).append(q)
    loops = []
    for p0 in list(out):
        while out.get(p0):
            loop = [p0]
            q = out[p0].pop()
            while q != p0 and out.get(q):
                loop.append(q)
                q = out[q].pop()
            loops.append(np.array(loop))
    return loops


def planar_pattern(tess: Tessellation, xy: np.ndarray) -> Pattern:
    """The :class:`flatweave.method.pattern.Pattern` of a flat triangulation: per piece the
    outer boundary loop (dart legs included: a dart that opens on the boundary
    is walked up one leg and down the other), inner loops as holes."""
    tri = tess.tri
    n = len(xy)
    g = sparse.coo_matrix((np.ones(3 * len(tri)), (tri.ravel(), tri[:, [1, 2, 0]].ravel())), shape=(n, n))
    _, label = connected_components(g, directed=False)
    by_piece = {}
    for loop in _boundary_loops(tri):
        by_piece.setdefault(int(label[loop[0]]), []).append(loop)
    pieces = []
    for comp, loops in by_piece.items():
        areas = [polygon_area(xy[lp]) if len(lp) > 2 else 0.0 for lp in loops]
        # the outer loop is the one enclosing the most (counter-clockwise); others are holes
        k = int(np.argmax(areas))
        outer = loops[k]
        holes = tuple(xy[lp] for i, lp in enumerate(loops) if i != k)
        nodes = np.flatnonzero(label == comp)
        pieces.append(Piece(xy[outer], tess.xyz[outer], tess.uv[outer], tess.on_boundary[outer], nodes, holes))
    pieces.sort(key=lambda p: -abs(polygon_area(p.outline)))
    openings = []
    for cut in tess.cuts:
        ch, chn = cut["chain"], cut["chain_neg"]
        openings.append(DartOpening(cut["name"], cut["kind"], tess.uv[ch], tess.xyz[ch], xy[ch], xy[chn],
                                    cut["mouth"]))
    main = pieces[0]
    return Pattern(xy, main.outline, main.outline3d, main.outline_uv, main.on_boundary, tuple(openings),
                   main.holes, tuple(pieces))


def planar_metrics(surface: NurbsSurface, tess: Tessellation, edges: np.ndarray, rest: np.ndarray,
                   xy: np.ndarray, pattern: Pattern, area: float | None = None) -> dict:
    """Boundary and area errors (as :func:`flatweave.method.pipeline.compute_metrics`: L3 and
    A3 exact on the surface, L2 and A2 of the outline), coverage
    (:func:`flatweave.method.pipeline.coverage_metrics`, the median edge length as the spacing), edge strain,
    flips, sizes."""
    L3 = boundary_length(surface)
    A3 = region_area(surface) if area is None else area
    h = float(np.median(rest)) if len(rest) else 1.0  # the edges' length: about the spacing
    l2 = np.linalg.norm(xy[edges[:, 0]] - xy[edges[:, 1]], axis=1)
    strain = np.abs(l2 / rest - 1.0)
    a2 = _uv_area(xy, tess.tri)
    P = tess.xyz[tess.tri]
    a3 = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    # boundary edges of the triangulation that lie on the region's boundary (not on a dart)
    L3_mesh = 0.0
    for p in pattern.pieces:
        o3 = p.outline3d
        seg = np.linalg.norm(np.roll(o3, -1, axis=0) - o3, axis=1)
        L3_mesh += float(seg[p.on_boundary & np.roll(p.on_boundary, -1)].sum())
    return {
        **outline_errors(pattern.perimeter, L3, pattern.area, A3),
        **coverage_metrics(surface, tess.xyz, h, h),
        "boundary_length_3d_mesh": L3_mesh, "area_3d_mesh": float(a3.sum()),
        "max_edge_strain_pct": float(100 * strain.max(initial=0.0)),
        "mean_edge_strain_pct": float(100 * strain.mean()) if strain.size else 0.0,
        "flipped_triangles": int(np.sum(a2 <= 0)),
        "nodes": int(len(xy)), "triangles": int(len(tess.tri)), "edges": int(len(edges)),
        "pieces": len(pattern.pieces),
    }


def planar_result_to_dict(result: PlanarResult, surface_source: str | None = None) -> dict:
    """The result file of the planar method: like the spring method's (metrics,
    nodes, pattern, darts), with triangles and edges instead of springs and cells."""
    s = result.settings
    tess, pattern, xy = result.tess, result.pattern, result.xy
    l2 = np.linalg.norm(xy[result.edges[:, 0]] - xy[result.edges[:, 1]], axis=1)
    darts = [d.to_dict(RESULT_DART_KEYS) for d in s.darts]
    out_darts = []
    for d, op, cut in zip(darts, pattern.darts, tess.cuts):
        e = dict(d)
        e.update({"curve_uv": op.curve_uv.tolist(), "curve": op.curve3d.tolist(), "mouth_on_boundary": op.mouth,
                  "leg_lengths": list(op.leg_lengths), "opening_deg": op.opening_deg,
                  "positive_nodes": cut["chain"].tolist(), "negative_nodes": cut["chain_neg"].tolist()})
        out_darts.append(e)
    return {
        "format": "flatweave-result",
        "version": 1,
        "flatweave": __version__,
        "method": "planar",
        "surface": surface_source,
        "settings": {"method": "planar", "spacing": s.spacing, "solver": s.solver, "tol": s.tol,
                     "max_iter": s.max_iter,
                     "max_seconds": s.max_seconds if math.isfinite(s.max_seconds) else None,
                     "max_nodes": s.max_nodes, "darts": darts},
        "metrics": result.metrics,
        "nodes": {"uv": tess.uv.tolist(), "xyz": tess.xyz.tolist(), "xy": xy.tolist(),
                  "on_boundary": tess.on_boundary.tolist()},
        "triangles": tess.tri.tolist(),
        "edges": {"ends": result.edges.tolist(), "rest": result.rest.tolist(), "length": l2.tolist(),
                  "strain": (l2 / result.rest - 1.0).tolist()},
        "pattern": {
            "outline": pattern.outline.tolist(),
            "outline3d": pattern.outline3d.tolist(),
            "outline_uv": pattern.outline_uv.tolist(),
            "on_boundary": pattern.on_boundary.tolist(),
            "pieces": [pc.to_dict() for pc in pattern.pieces],
        },
        "darts": out_darts,
        "status": result.status,
        "warnings": list(result.warnings),
    }
