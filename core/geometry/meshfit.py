"""A triangle mesh made into a NURBS surface and a region (the file is read by
:mod:`flatweave.reading.meshes`).

The engine works on a parametric surface; a mesh becomes one in four steps:

1. **read** (:func:`flatweave.reading.meshes.read_mesh`): trimesh parses the file after a cheap check
   of what its header claims against the file's size (:func:`flatweave.reading.meshes.check_mesh_file`:
   a truncated binary STL or a header claiming gigabytes is refused at once,
   before anything is allocated);
2. **repair and check** (:func:`clean_mesh`): duplicate vertices merged,
   degenerate and repeated triangles dropped, the winding made consistent; a
   mesh with NaN coordinates, no triangles, non-manifold edges, no consistent
   orientation or several parts (unless one is chosen) is refused in one line;
3. **parameterise** (:func:`lscm`): a free-boundary least-squares conformal
   map (Levy et al. 2002) of the mesh into the plane, a sparse linear least
   squares problem solved with scipy; a developable mesh maps isometrically,
   up to one scale;
4. **fit** (:func:`fit_bspline`): a bicubic B-spline surface (C2) over the
   map's bounding box, by least squares through the vertices (and, at a
   small share of the weight, the triangles' centroids and the edges'
   midpoints, which keep a fine net from swinging between vertices) with a
   small thin-plate smoothing term (it also extends the surface smoothly
   over the parts of the box the map does not reach), refined to a
   tolerance (:func:`mesh_surface`).

The region (:class:`flatweave.geometry.region.Region`) is the map's boundary: the outer
loop and the holes of the mesh, in the surface's (u, v). The distance from
every vertex to the surface point it maps to (an upper bound of its distance
to the surface) gives :class:`MeshFit`'s largest and mean deviation, reported
by ``info``, in the result file's metrics and in the project file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree
from scipy.sparse.csgraph import connected_components

from flatweave.errors import SettingsError, SurfaceError
from flatweave.geometry.nurbs import NurbsSurface, basis_functions
from flatweave.geometry.numerics import polygon_area
from flatweave.geometry.region import Region

__all__ = ["MeshFit", "FittedSurface", "MeshPiece", "MAX_TRIANGLES", "clean_mesh", "lscm", "fit_bspline",
           "mesh_surface", "boundary_loops", "open_ends", "fit_deviation", "SeveralParts", "NeedsRegion", "NonManifold",
           "FitTolerance", "clamped_knots",
           "edge_table",
           "map_distortion", "MAP_DISTORTION_LIMIT", "MAX_COORDINATE", "with_fit", "FitMesh", "vertex_deviation",
           "weld_parts", "densify", "split_pinched", "check_coordinates", "used_vertices",
           "MAX_FIT_TRIANGLES", "TooDetailed"]


MAX_TRIANGLES = 2_000_000
"""Most triangles a mesh file may have: read, repaired and checked (``info``) in
about 16 s here, a panel drawn on it and cut out (docs/decisions/0066-mesh-limits-read-and-fit.md)."""

MAX_FIT_TRIANGLES = 500_000
"""Most triangles of one piece mapped and fitted as a surface (the whole mesh,
or a panel cut from it): about 27 s here and 2.2 GB (benchmarks/results/limits.md), most of it the conformal
map's sparse factorisation, which grows as n^1.6. A larger piece is refused in
one line asking for a panel (:class:`TooDetailed`)."""

FIT_TOL = 2e-4
"""The fit is refined until its largest deviation is below this fraction of
the mesh's bounding-box diagonal (or the control net reaches
:data:`MAX_CTRL`)."""

MAX_CTRL = 96  # control points per direction at most
MAX_CTRL_STATED = 128  # ... when a tolerance is stated (--fit-tolerance): the user asked for the detail
VERTICES_PER_CTRL = 1.0  # the net stops refining below this many vertices per control point ...
BETWEEN_SHARE = 0.02  # the share of the fit's weight on points between the vertices (centroids, midpoints)
SWING = 1.25  # a finer net whose deviation between the vertices exceeds the coarsest's this much is not taken
NOISE_CORRELATION = 0.5  # neighbours' fit residuals correlating less than this are noise, not missed detail
VERTICES_PER_CTRL_STATED = 0.25  # ... or this many when a tolerance is stated (the roughness term holds the rest)
MAX_COORDINATE = 1e30  # a vertex farther from the origin than this is a broken file, not a model
MAP_DISTORTION_LIMIT = 0.15
"""A mesh whose conformal map changes areas more than this (MeshFit.map_distortion)
is one no single piece covers well: a panel drawn on it is advised. The sphere's
octant (the paper's example, which flattens within every warning limit) measures
0.057, a 60-degree cap 0.14, a hemisphere 0.34."""
SMOOTH = 1e-5  # weight of the roughness term against the mean squared distance (both in model units squared)


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class MeshFit:
    """How the surface made from a mesh follows it (model units).

    source : the mesh file
    vertices, triangles : of the part made a surface, after repair
    size : the mesh's bounding-box diagonal
    max_deviation, mean_deviation : largest and mean distance from a vertex
        to the surface point it maps to
    ctrl : (nu, nv), the fitted control net
    repairs : what was repaired, e.g. ``("merged 120 duplicate vertices",)``
    faces : the CAD file's faces joined into this mesh (``--faces``), else ()
    between_deviation : the largest distance from the triangles' centroids and
        the edges' midpoints to the surface (the flat facets' own sagitta
        included): how far the surface strays between the vertices
    tolerance : the largest deviation stated (``--fit-tolerance``), which the fit
        meets, or None when the default was aimed at (:data:`FIT_TOL` of the size)
    map_distortion : how far the mesh's least-squares conformal map changes
        its triangles' areas (the area-weighted mean of |scaled flat area /
        area - 1|): 0 for a developable piece; above MAP_DISTORTION_LIMIT one
        piece of fabric cannot cover it well and a panel should be drawn on it
    """

    source: str
    vertices: int
    triangles: int
    size: float
    max_deviation: float
    mean_deviation: float
    ctrl: tuple = (0, 0)
    repairs: tuple = ()
    faces: tuple = ()
    map_distortion: float = 0.0
    tolerance: float | None = None
    between_deviation: float = 0.0

    def metrics(self) -> dict:
        """The keys the result file's metrics get (the deviations in model units and as percent of the
        mesh's size, the judged one: :data:`flatweave.method.metrics.FIT_DEVIATION_PCT`)."""
        size = self.size if self.size > 0 else float("inf")
        return {"fit_max_deviation": self.max_deviation, "fit_mean_deviation": self.mean_deviation,
                "fit_max_deviation_pct": 100.0 * self.max_deviation / size,
                "fit_mean_deviation_pct": 100.0 * self.mean_deviation / size}

    def to_dict(self) -> dict:
        return {"source": self.source, "vertices": self.vertices, "triangles": self.triangles, "size": self.size,
                "max_deviation": self.max_deviation, "mean_deviation": self.mean_deviation,
                "ctrl": list(self.ctrl), "repairs": list(self.repairs),
                **({"faces": [int(i) for i in self.faces]} if self.faces else {}),
                **({"map_distortion": self.map_distortion} if self.map_distortion else {}),
                **({"tolerance": self.tolerance} if self.tolerance is not None else {}),
                **({"between_deviation": self.between_deviation} if self.between_deviation else {})}

    @classmethod
    def from_dict(cls, d) -> "MeshFit":
        try:
            return cls(str(d["source"]), int(d["vertices"]), int(d["triangles"]), float(d["size"]),
                       float(d["max_deviation"]), float(d["mean_deviation"]), tuple(int(x) for x in d.get("ctrl", ())),
                       tuple(str(x) for x in d.get("repairs", ())), tuple(int(x) for x in d.get("faces", ())),
                       float(d.get("map_distortion", 0.0)),
                       None if d.get("tolerance") is None else float(d["tolerance"]),
                       float(d.get("between_deviation", 0.0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise SettingsError(f"a mesh fit record is malformed: {exc}") from None

    def describe(self) -> str:
        of = f" of faces {', '.join(map(str, self.faces))}" if self.faces else ""
        return (f"fit to {self.triangles} triangles{of}: max deviation {self.max_deviation:.4g} "
                f"({100 * self.max_deviation / self.size:.3g} % of the mesh's size {self.size:.4g}), "
                f"mean {self.mean_deviation:.4g} ({100 * self.mean_deviation / self.size:.3g} %)")


@dataclass(frozen=True, eq=False)
class FitMesh:
    """The mesh a surface was fitted to: vertices (n, 3), triangles (m, 3) and
    uv (n, 2), where on the surface each vertex maps (the deviation's pairs)."""

    vertices: np.ndarray
    triangles: np.ndarray
    uv: np.ndarray


class FittedSurface(NurbsSurface):
    """A :class:`NurbsSurface` fitted to a mesh; ``fit`` says how closely,
    ``mesh`` (:class:`FitMesh`, or None for a reopened project until
    :func:`fit_mesh` reads it again) is the mesh itself."""

    def __init__(self, *args, fit: MeshFit, mesh: FitMesh | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.fit = fit
        self.mesh = mesh

    def __getstate__(self):  # a pickled copy (the sweep's workers) needs the surface, not the mesh
        state = self.__dict__.copy()
        state["mesh"] = None
        return state


@dataclass(frozen=True)
class MeshPiece:
    """A mesh made a surface: the surface, its region, the map.

    surface : FittedSurface over [0, 1]^2
    region : the map's boundary loops in (u, v) (outer first, then holes)
    vertices (n, 3), triangles (m, 3), uv (n, 2) : the repaired mesh and
        every vertex's (u, v)
    deviation (n,) : per vertex distance to the surface (for a colour map)
    """

    surface: FittedSurface
    region: object
    vertices: np.ndarray
    triangles: np.ndarray
    uv: np.ndarray
    deviation: np.ndarray

    @property
    def fit(self) -> MeshFit:
        return self.surface.fit


class SeveralParts(SurfaceError):
    """A mesh of several parts and none chosen; ``n_parts`` says how many."""

    def __init__(self, message: str, n_parts: int):
        super().__init__(message)
        self.n_parts = n_parts


class NonManifold(SurfaceError):
    """A mesh with edges of more than two triangles: it cannot be covered
    whole, but a panel drawn away from those edges can be cut from it."""


class FitTolerance(SettingsError):
    """A stated fit tolerance the fit cannot meet (the message says why)."""


class NeedsRegion(SurfaceError):
    """A closed mesh, or one with handles: it cannot be covered whole."""


class TooDetailed(SurfaceError):
    """A piece of more than :data:`MAX_FIT_TRIANGLES` triangles: a panel drawn
    on the mesh (or a smaller one) can be fitted."""


# --------------------------------------------------------------------------- repair and checks
def used_vertices(F: np.ndarray, n: int | None = None) -> np.ndarray:
    """The sorted indices of the vertices triangles ``F`` use (``np.unique(F)``,
    by a mask: linear, where numpy's hash-based unique took 6 s on the
    6,000,000 corners of a 2,000,000-triangle mesh)."""
    F = np.asarray(F)
    if F.size == 0:
        return np.zeros(0, dtype=np.int64)
    mask = np.zeros(int(F.max()) + 1 if n is None else n, dtype=bool)
    mask[F.ravel()] = True
    return np.flatnonzero(mask)


def _edges(F: np.ndarray) -> np.ndarray:
    """(3m, 2) directed edges of the triangles, edge k of triangle t at row 3t + k."""
    return np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)


def edge_table(F: np.ndarray):
    """Undirected edges: (unique (e, 2) sorted pairs, per directed edge its
    undirected index (3m,), faces per undirected edge (e,))."""
    E = _edges(F)
    n = int(F.max()) + 1
    key = np.minimum(E[:, 0], E[:, 1]) * n + np.maximum(E[:, 0], E[:, 1])  # one int64 per edge: a fast unique
    uniq, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    return np.stack([uniq // n, uniq % n], axis=1), inv.reshape(-1), count


def _orient(F: np.ndarray, name: str, table=None) -> tuple[np.ndarray, np.ndarray]:
    """The triangles wound consistently within each part (triangles sharing
    an edge traverse it in opposite senses); returns (F, the flipped rows' mask).
    ``table``: :func:`edge_table` of ``F`` when it is at hand.
    SurfaceError when a part cannot be oriented (a Moebius strip)."""
    m = len(F)
    E = _edges(F)
    _, inv, count = edge_table(F) if table is None else table
    # pairs of triangles across each interior edge (two directed edges per undirected one)
    order = np.argsort(inv, kind="stable")
    inner = count[inv[order]] == 2
    d = order[inner].reshape(-1, 2)  # directed-edge rows of the two sides
    ta, tb = d[:, 0] // 3, d[:, 1] // 3
    same = np.all(E[d[:, 0]] == E[d[:, 1]], axis=1)  # same sense: one of them must flip
    G = sp.coo_matrix((np.ones(2 * len(ta)), (np.r_[ta, tb], np.r_[tb, ta])), shape=(m, m)).tocsr()
    from scipy.sparse.csgraph import breadth_first_order
    # a spanning tree from triangle 0 (one part: clean_mesh chose it); a triangle's flip relative to its
    # parent is "same sense across their shared edge", accumulated to the root by pointer jumping
    _, pred = breadth_first_order(G, 0, directed=False, return_predecessors=True)
    pred = np.where(pred < 0, -1, pred).astype(np.int64)
    key = np.minimum(ta, tb) * m + np.maximum(ta, tb)
    order = np.argsort(key)
    key, same_sorted = key[order], same[order]
    child = np.nonzero(pred >= 0)[0]
    q = np.minimum(child, pred[child]) * m + np.maximum(child, pred[child])
    acc = np.zeros(m, dtype=bool)
    acc[child] = same_sorted[np.searchsorted(key, q)]
    p = pred.copy()
    while np.any(p >= 0):
        live = np.nonzero(p >= 0)[0]
        acc[live] ^= acc[p[live]]
        p[live] = p[p[live]]
    flip = acc
    F = F.copy()
    F[flip] = F[flip][:, ::-1]
    E = _edges(F)
    bad = np.all(E[d[:, 0]] == E[d[:, 1]], axis=1)
    if np.any(bad):
        raise SurfaceError(f"{name} cannot be oriented (its triangles' winding cannot be made consistent, "
                           f"as on a Moebius strip)")
    return F, flip


def _flipped_table(table, flip: np.ndarray):
    """:func:`edge_table` of the triangles after the rows ``flip`` marks were
    reversed ((a, b, c) to (c, b, a)): the same undirected edges, a reversed
    row's directed edges being its old edges 1, 0 and 2."""
    edges, inv, count = table
    inv = inv.reshape(-1, 3).copy()
    inv[flip] = inv[flip][:, [1, 0, 2]]
    return edges, inv.reshape(-1), count


def check_coordinates(V: np.ndarray, name: str = "the mesh") -> None:
    """A one-line SurfaceError when vertices ``V`` (the ones triangles use) have NaN or infinite
    coordinates, or any beyond MAX_COORDINATE (their squares would overflow)."""
    finite = np.isfinite(V).all(axis=1)
    if not finite.all():
        raise SurfaceError(f"{name} has {int((~finite).sum())} vertices with NaN or infinite coordinates")
    big = float(np.abs(V).max(initial=0.0))
    if big > MAX_COORDINATE:  # its squares overflow long before a model gets there
        raise SurfaceError(f"{name} has coordinates up to {big:.3g}: no model is that large (the limit is "
                           f"{MAX_COORDINATE:g} units)")


def clean_mesh(V, F, name: str = "the mesh", component: int | None = None, aside: list | None = None):
    """Repair and check a mesh; returns (V, F, repairs).

    Merges vertices that coincide (to 1e-9 of the mesh's size), drops
    triangles with a repeated vertex or no area and repeated triangles, and
    winds the triangles consistently. Refuses in one line: NaN or infinite
    coordinates, no triangles, an edge of more than two triangles, a mesh of
    several parts unless ``component`` (0 = the largest) picks one;
    ``component`` may also be a point (3,), for the part nearest it.

    ``aside``: a list to set the triangles of non-manifold edges aside
    instead of refusing them (a panel cut elsewhere on the mesh does not
    need them): the ends of those edges are appended to it, so that a
    piece cut from the rest can be checked not to reach them.
    """
    V = np.asarray(V, dtype=float)
    F = np.asarray(F, dtype=np.int64)
    repairs = []
    if len(F) == 0:
        raise SurfaceError(f"{name} has no triangles")
    used = used_vertices(F)
    check_coordinates(V[used], name)
    V = V[used]
    F = np.searchsorted(used, F)
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    if not size > 0:
        raise SurfaceError(f"{name}: all its vertices are at one point")
    # merge coincident vertices (an STL repeats every vertex in each of its triangles)
    q = np.round((V - V.min(axis=0)) / (1e-9 * size)).astype(np.int64)
    _, first, inv = np.unique(np.ascontiguousarray(q).view(np.dtype((np.void, 24))).ravel(),
                              return_index=True, return_inverse=True)  # rows as bytes: a 1-D unique
    inv = inv.reshape(-1)
    if len(first) < len(V):
        repairs.append(f"merged {len(V) - len(first)} duplicate vertices")
    V, F = V[first], inv[F]
    # degenerate triangles: a repeated vertex, or (numerically) no area
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    degenerate = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0]) | (area2 <= 1e-14 * size * size)
    if degenerate.any():
        repairs.append(f"dropped {int(degenerate.sum())} degenerate triangles")
        F = F[~degenerate]
    if len(F) == 0:
        raise SurfaceError(f"{name} has no triangles with an area")
    n_v = len(V)
    Fs = np.sort(F, axis=1)
    _, keep = np.unique((Fs[:, 0] * n_v + Fs[:, 1]) * n_v + Fs[:, 2], return_index=True)
    if len(keep) < len(F):
        repairs.append(f"dropped {len(F) - len(keep)} repeated triangles")
        F = F[np.sort(keep)]
    edges, inv_e, count = edge_table(F)
    if count.max() > 2 and aside is not None:
        bad = count > 2
        aside.extend(V[np.unique(edges[bad])])
        on_bad = bad[inv_e].reshape(-1, 3).any(axis=1)
        repairs.append(f"set aside {int(on_bad.sum())} triangles at {int(bad.sum())} non-manifold edges")
        F = F[~on_bad]
        if len(F) == 0:
            raise SurfaceError(f"{name} has no triangles off its non-manifold edges")
        edges, inv_e, count = edge_table(F)
    if count.max() > 2:
        n_bad = int((count > 2).sum())
        raise NonManifold(f"{name} has {n_bad} non-manifold edge{'s' if n_bad != 1 else ''} "
                           f"(shared by more than two triangles); repair the mesh or keep one sheet")
    # parts: triangles joined through edges
    tri = np.repeat(np.arange(len(F)), 3)
    order = np.argsort(inv_e, kind="stable")
    inner = count[inv_e[order]] == 2
    pairs = tri[order[inner]].reshape(-1, 2)
    G = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(F), len(F)))
    n_parts, labels = connected_components(G, directed=False)
    if n_parts > 1:
        sizes = np.bincount(labels)
        rank = np.argsort(-sizes, kind="stable")
        if component is None:
            listed = ", ".join(str(int(s)) for s in sizes[rank[:5]]) + (", ..." if n_parts > 5 else "")
            raise SeveralParts(f"{name} has {n_parts} separate parts ({listed} triangles): choose one with "
                               f"--face N (0 = the largest, to {n_parts - 1})", n_parts)
        if np.ndim(component) == 1:  # a point on the part wanted (a loop drawn on it)
            _, v = cKDTree(V).query(np.asarray(component, dtype=float).reshape(3))
            t = int(np.flatnonzero((F == v).any(axis=1))[0])
            component = int(np.flatnonzero(rank == labels[t])[0])
        if not 0 <= component < n_parts:
            raise SettingsError(f"{name} has {n_parts} parts; --face must be 0 to {n_parts - 1}")
        F = F[labels == rank[component]]
        repairs.append(f"part {component} of {n_parts}")
    elif component is not None and np.ndim(component) == 0 and component != 0:  # a point: the only part
        raise SettingsError(f"{name} has one part; --face must be 0")
    used = used_vertices(F)
    same = n_parts == 1 and len(used) == len(V)  # F as edge_table saw it: its table holds
    V, F = V[used], np.searchsorted(used, F)
    table = (edges, inv_e, count) if same else edge_table(F)
    F, flip = _orient(F, name, table)
    flipped = int(flip.sum())
    if flipped and flipped < len(F):
        repairs.append(f"re-wound {flipped} triangles")
    V, F, n_split = split_pinched(V, F, table=_flipped_table(table, flip))
    if n_split:
        repairs.append(f"split {n_split} vertices where separate fans of triangles touched")
    return V, F, tuple(repairs)


def split_pinched(V: np.ndarray, F: np.ndarray, cut: np.ndarray | None = None,
                  table=None) -> tuple[np.ndarray, np.ndarray, int]:
    """A vertex whose triangles form several fans (joined through it alone, as
    where two holes of a scan touch) becomes one vertex per fan, at the same
    place. ``cut`` (e,) bool, over :func:`edge_table`'s edges: edges the
    triangles do not meet across (a seam), so the mesh opens along them.
    ``table``: :func:`edge_table` of ``F`` when it is at hand.
    Returns (V, F, how many vertices were split)."""
    m = len(F)
    corner_vertex = F.ravel()
    _, inv, count = edge_table(F) if table is None else table
    order = np.argsort(inv, kind="stable")
    inner = count[inv[order]] == 2
    if cut is not None:
        inner &= ~np.asarray(cut, dtype=bool)[inv[order]]
    d = order[inner].reshape(-1, 2)  # the two directed-edge rows (3 t + k) of each interior edge
    nxt = lambda r: 3 * (r // 3) + (r % 3 + 1) % 3  # noqa: E731  (the corner at the edge's end)
    a1, b1, a2, b2 = d[:, 0], nxt(d[:, 0]), d[:, 1], nxt(d[:, 1])
    same = corner_vertex[a1] == corner_vertex[a2]  # the two rows run the edge in the same sense
    # join the corners of each edge's two triangles that hold the same vertex
    i = np.r_[a1, b1]
    j = np.r_[np.where(same, a2, b2), np.where(same, b2, a2)]
    G = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(3 * m, 3 * m))
    n_fans, fan = connected_components(G, directed=False)
    # (vertex, fan) pairs as one int64 key, in the order of the vertex, then the fan (a 1-D unique is fast)
    keys, new_id = np.unique(corner_vertex.astype(np.int64) * n_fans + fan, return_inverse=True)
    if len(keys) == len(V):
        return V, F, 0
    vertex = keys // n_fans
    n_split = int(len(keys) - len(np.unique(vertex)))
    return V[vertex], new_id.reshape(-1).reshape(m, 3), n_split


def boundary_loops(F: np.ndarray, name: str = "the mesh") -> list[np.ndarray]:
    """The boundary loops of a consistently wound manifold mesh, each an
    array of vertex indices in the boundary's sense (the mesh on its left)."""
    E = _edges(F)
    _, inv, count = edge_table(F)
    B = E[count[inv] == 1]
    if len(B) == 0:
        return []
    nxt = {}
    starts, ends = B[:, 0], B[:, 1]
    if len(np.unique(starts)) < len(starts):
        raise SurfaceError(f"{name} has a non-manifold vertex (two parts of its boundary touch at a vertex); "
                           f"repair the mesh")
    nxt = dict(zip(starts.tolist(), ends.tolist()))
    loops, seen = [], set()
    for s in starts.tolist():
        if s in seen:
            continue
        loop, v = [], s
        while v not in seen:
            seen.add(v)
            loop.append(v)
            v = nxt[v]
        loops.append(np.asarray(loop, dtype=np.int64))
    return loops


# --------------------------------------------------------------------------- the map
def lscm(V: np.ndarray, F: np.ndarray, pins: tuple[int, int] | None = None) -> np.ndarray:
    """(n, 2) free-boundary least-squares conformal map of a disk-like mesh.

    Per triangle the map's v gradient should be its u gradient turned by 90
    degrees about the normal; the squared misfits, weighted by area, are
    minimised with two vertices pinned (far apart on the boundary, unless
    given). The map keeps the triangles' orientation.
    """
    n, m = len(V), len(F)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    nrm = np.cross(b - a, c - a)
    dbl = np.linalg.norm(nrm, axis=1)  # twice the area
    nrm /= dbl[:, None]
    e1 = (b - a) / np.linalg.norm(b - a, axis=1)[:, None]
    e2 = np.cross(nrm, e1)
    # gradient of the hat function of corner k: n x (opposite edge) / (2A), in the frame (e1, e2)
    opp = [c - b, a - c, b - a]
    g = np.stack([np.cross(nrm, o) / dbl[:, None] for o in opp], axis=1)  # (m, 3, 3)
    gx, gy = g @ e1[:, :, None], g @ e2[:, :, None]
    gx, gy = gx[..., 0], gy[..., 0]  # (m, 3): d(phi_k)/dx, d(phi_k)/dy
    w = np.sqrt(0.5 * dbl)[:, None]
    # n x grad u - grad v = 0: x row: -du/dy - dv/dx, y row: du/dx - dv/dy
    rows = np.repeat(np.arange(2 * m).reshape(m, 2), 3, axis=1).reshape(m, 2, 3)  # (m, 2, 3)
    cols = F[:, None, :].repeat(2, axis=1)
    Au = np.stack([-gy * w, gx * w], axis=1)
    Av = np.stack([-gx * w, -gy * w], axis=1)
    A = sp.csr_matrix((np.r_[Au.ravel(), Av.ravel()], (np.r_[rows.ravel(), rows.ravel()],
                                                      np.r_[cols.ravel(), cols.ravel() + n])), shape=(2 * m, 2 * n))
    if pins is None:
        loops = boundary_loops(F)
        ring = max(loops, key=len) if loops else np.arange(n)
        p0 = ring[np.argmax(np.linalg.norm(V[ring] - V[ring[0]], axis=1))]
        p1 = ring[np.argmax(np.linalg.norm(V[ring] - V[p0], axis=1))]
        pins = (int(p0), int(p1))
    p0, p1 = pins
    fixed_idx = np.array([p0, p1, p0 + n, p1 + n])
    d = float(np.linalg.norm(V[p1] - V[p0]))
    fixed_val = np.array([0.0, d, 0.0, 0.0])
    # the free unknowns interleaved (u_i, v_i side by side) and the normal equations factored in SuperLU's
    # symmetric mode with a minimum-degree ordering of A + A^T: a third less fill and time than the default
    # (docs/decisions/0034-meshes-fitted-by-lscm-and-p-splines.md)
    free = np.setdiff1d(np.arange(n), pins)
    free = np.stack([free, free + n], axis=1).ravel()
    Af = A[:, free]
    rhs = -(A[:, fixed_idx] @ fixed_val)
    N = (Af.T @ Af).tocsc()
    from scipy.sparse.linalg import splu
    x = np.empty(2 * n)
    x[fixed_idx] = fixed_val
    lu = splu(N, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    x[free] = lu.solve(Af.T @ rhs)
    uv = np.stack([x[:n], x[n:]], axis=1)
    if not np.isfinite(uv).all():
        raise SurfaceError("the mesh could not be mapped to the plane (the conformal map is singular)")
    return uv


# --------------------------------------------------------------------------- the fit
def clamped_knots(n_ctrl: int, p: int = 3) -> np.ndarray:
    """The clamped, uniform knot vector on [0, 1] of a degree-``p`` B-spline with
    ``n_ctrl`` control points (the fit's first net, refined from there)."""
    inner = np.linspace(0.0, 1.0, n_ctrl - p + 1)
    return np.r_[np.zeros(p), inner, np.ones(p)]


def _design(knots: np.ndarray, n_ctrl: int, x: np.ndarray, p: int = 3):
    spans = np.clip(np.searchsorted(knots, x, side="right") - 1, p, n_ctrl - 1)
    N = basis_functions(knots, p, spans, x, order=0)[0]
    return spans - p, N  # first control index, (n, p+1) values


def _second_differences(nu: int, nv: int):
    """The roughness of a control net: the sum of its squared second
    differences (d2/du2, twice d2/dudv, d2/dv2), divided by the number of
    control points, as a matrix on the flattened (nu, nv) grid. On a smooth
    surface it shrinks as h^4 with the knot spacing h (a P-spline penalty), so
    refining the net weakens its pull while it still fixes the control points
    no vertex reaches (the box's corners outside the map)."""
    def d2(k):
        return sp.diags([np.ones(k - 2), -2 * np.ones(k - 2), np.ones(k - 2)], [0, 1, 2], shape=(k - 2, k))

    def d1(k):
        return sp.diags([-np.ones(k - 1), np.ones(k - 1)], [0, 1], shape=(k - 1, k))
    Iu, Iv = sp.identity(nu), sp.identity(nv)
    Duu = sp.kron(d2(nu), Iv)
    Dvv = sp.kron(Iu, d2(nv))
    Duv = sp.kron(d1(nu), d1(nv))
    return ((Duu.T @ Duu + 2 * Duv.T @ Duv + Dvv.T @ Dvv) / (nu * nv)).tocsr()


def fit_bspline(uv: np.ndarray, X: np.ndarray, nu: int, nv: int, smooth: float = SMOOTH,
                knots: tuple | None = None, weights: np.ndarray | None = None) -> np.ndarray:
    """(nu, nv, 3) control net of the bicubic B-spline over [0, 1]^2 that
    minimises the (``weights``-)weighted mean of |S(uv_i) - X_i|^2 + smooth *
    (thin-plate energy), on the knot vectors ``knots`` = (ku, kv) (default
    uniform, clamped)."""
    ku, kv = knots if knots is not None else (clamped_knots(nu), clamped_knots(nv))
    iu, Nu = _design(ku, nu, uv[:, 0])
    iv, Nv = _design(kv, nv, uv[:, 1])
    n = len(uv)
    rows = np.repeat(np.arange(n), 16)
    cols = ((iu[:, None, None] + np.arange(4)[None, :, None]) * nv + (iv[:, None, None] + np.arange(4)[None, None, :]))
    vals = Nu[:, :, None] * Nv[:, None, :]
    B = sp.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=(n, nu * nv))
    if weights is None:
        M = (B.T @ B) / n + smooth * _second_differences(nu, nv)
        rhs = (B.T @ X) / n
    else:
        w = np.asarray(weights, dtype=float) / float(np.sum(weights))
        Bw = sp.diags(w) @ B
        M = (B.T @ Bw) + smooth * _second_differences(nu, nv)
        rhs = Bw.T @ X
    from scipy.sparse.linalg import splu
    # symmetric positive definite: a symmetric ordering and no pivoting (4x faster than the default at 96 x 96)
    lu = splu(M.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    C = lu.solve(np.ascontiguousarray(rhs))
    return C.reshape(nu, nv, 3)


def fit_deviation(surface: NurbsSurface, uv: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(n,) distance from each X_i to S(uv_i)."""
    return np.linalg.norm(surface.points(uv) - X, axis=1)


def _normalise_map(uv: np.ndarray) -> tuple[np.ndarray, float]:
    """The map turned to its principal axes (longer along u) and scaled into
    [0, 1]^2; returns (uv, aspect = extent v / extent u)."""
    c = uv - uv.mean(axis=0)
    _, vec = np.linalg.eigh(c.T @ c)
    R = vec[:, ::-1]  # major axis first
    if np.linalg.det(R) < 0:  # a rotation, never a mirror: the orientation stays
        R[:, 1] = -R[:, 1]
    q = c @ R
    lo, hi = q.min(axis=0), q.max(axis=0)
    ext = hi - lo
    return (q - lo) / ext, float(ext[1] / ext[0])


def map_distortion(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> float:
    """The area-weighted mean of |s A_flat / A - 1| over the triangles of a
    flat map ``uv`` of mesh (V, F), s the one scale that makes the total areas
    equal: 0 when the map keeps every area (a developable piece)."""
    a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    e1, e2 = uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]
    a2 = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    total = float(a3.sum())
    if total <= 0 or a2.sum() <= 0:
        return 0.0
    s = total / float(a2.sum())
    return float(np.abs(s * a2 - a3).sum() / total)


def mesh_surface(V, F, source: str = "", name: str = "the mesh", repairs: tuple = (), faces: tuple = (),
                 tolerance: float | None = None) -> MeshPiece:
    """A repaired, consistently wound, one-part mesh (:func:`clean_mesh`)
    made a :class:`MeshPiece`: surface, region, map and deviations.

    The control net is refined (1.5 times per direction) until the largest
    vertex deviation is at most ``tolerance`` (model units; default
    :data:`FIT_TOL` of the mesh's size) or the net reaches its limits
    (:data:`MAX_CTRL` a side, :data:`VERTICES_PER_CTRL`; the ``_STATED``
    ones with a stated tolerance); of the nets tried that do not swing
    between the vertices (:data:`SWING`), the one nearest the vertices is
    kept. A stated tolerance that is not met is a one-line
    :class:`FitTolerance` error saying why (a fold of the map, a swing
    between too few vertices, noise, or detail finer than the net); the
    default one, not met, leaves the deviation to be judged with the result.

    A closed mesh, or one of higher genus, is refused (it needs a region); a
    piece of more than :data:`MAX_FIT_TRIANGLES` triangles too (:class:`TooDetailed`).
    """
    stated = tolerance is not None
    if stated and not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance > 0):
        raise SettingsError(f"the fit tolerance must be a positive number of model units, got {tolerance!r:.40}")

    V = np.asarray(V, dtype=float)
    F = np.asarray(F, dtype=np.int64)
    if len(F) > MAX_FIT_TRIANGLES:
        if any(r.startswith("cut along") for r in repairs):
            raise TooDetailed(f"the piece cut from {name} has {len(F):,} triangles, more than the "
                              f"{MAX_FIT_TRIANGLES:,} one piece is fitted from: draw a smaller panel, or "
                              f"decimate the mesh")
        raise TooDetailed(f"{name} has {len(F):,} triangles, more than the {MAX_FIT_TRIANGLES:,} one piece is "
                          f"fitted from: draw a panel on it (--region), or decimate the mesh")
    loops = boundary_loops(F, name)
    E = edge_table(F)[0]
    chi = len(V) - len(E) + len(F)
    genus = (2 - chi - len(loops)) // 2
    if not loops:
        raise NeedsRegion(f"{name} is a closed mesh (no boundary): it needs a region to flatten; "
                          f"give --region with a loop3d drawn on it, or cut the piece out of the mesh")
    if genus > 0:
        raise NeedsRegion(f"{name} has genus {genus} (handles): it needs a region to flatten; "
                          f"give --region with a loop3d drawn on it, or cut the piece out of the mesh")
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    raw = lscm(V, F)
    uv, aspect = _normalise_map(raw)
    # control net: a few vertices per knot cell, more along the longer side, refined to FIT_TOL
    n_cells = max(len(V) / 8.0, 16.0)
    cu = math.sqrt(n_cells / max(aspect, 1e-3))
    base = min(max(int(cu), 4), 24) + 3
    tol = float(tolerance) if stated else FIT_TOL * size
    top = MAX_CTRL_STATED if stated else MAX_CTRL
    per_ctrl = VERTICES_PER_CTRL_STATED if stated else VERTICES_PER_CTRL
    nu = base
    nv = min(max(int(round((base - 3) * aspect)), 4), top - 3) + 3
    # between the vertices too: the triangles' centroids and the edges' midpoints join the fit with a small
    # share of its weight (BETWEEN_SHARE: they lie on the flat facets, off a smooth shape by the facets' sagitta)
    # so that a net finer than the vertices pin cannot swing between them; a net whose largest distance there
    # grows past SWING times the coarsest net's is not taken
    between_uv = np.concatenate([uv[F].mean(axis=1), 0.5 * (uv[E[:, 0]] + uv[E[:, 1]])])
    between_xyz = np.concatenate([V[F].mean(axis=1), 0.5 * (V[E[:, 0]] + V[E[:, 1]])])
    samples_uv, samples = np.concatenate([uv, between_uv]), np.concatenate([V, between_xyz])
    weights = np.r_[np.ones(len(V)), np.full(len(between_uv), BETWEEN_SHARE * len(V) / len(between_uv))]
    best, first_between, swung = None, None, False
    while True:
        knots = (clamped_knots(nu), clamped_knots(nv))
        C = fit_bspline(samples_uv, samples, nu, nv, knots=knots, weights=weights)
        surf = NurbsSurface(3, 3, *knots, C)
        every = fit_deviation(surf, samples_uv, samples)
        dev, between = every[:len(V)], every[len(V):]
        first_between = float(between.max()) if first_between is None else first_between
        steady = float(between.max()) <= max(SWING * first_between, tol)
        swung = swung or not steady
        if steady and (best is None or dev.max() < best[0]):
            best = (float(dev.max()), nu, nv, knots, C, surf, dev, between)
        if (steady and dev.max() <= tol) or max(nu, nv) >= top or nu * nv * per_ctrl > len(V):
            break
        nu = min(int(nu * 1.5), top)
        nv = min(max(int(round((nu - 3) * aspect)), 4), top - 3) + 3
    worst, nu, nv, knots, C, surf, dev, between = best
    if stated and worst > tol:
        why = _why_not_met(V, F, uv, V - surf.points(uv), between[:len(F)], (nu, nv), swung)
        raise FitTolerance(f"{name}: the surface fitted to it is up to {worst:.3g} from its vertices "
                           f"({100 * worst / size:.3g} % of its size {size:.4g}), over the fit tolerance "
                           f"{tol:.3g}: {why}")
    fit = MeshFit(str(source), len(V), len(F), size, worst, float(dev.mean()), (nu, nv), tuple(repairs),
                  tuple(int(i) for i in faces), map_distortion(V, F, raw), float(tolerance) if stated else None,
                  float(between.max()))
    surface = FittedSurface(3, 3, *knots, C, fit=fit, mesh=FitMesh(V, F, uv))
    loops_uv = [uv[lp] for lp in loops]
    areas = [abs(polygon_area(p)) for p in loops_uv]
    k = int(np.argmax(areas))
    outer = loops_uv[k]
    holes = [p for i, p in enumerate(loops_uv) if i != k and areas[i] > 1e-12]
    region = Region.from_loops(outer, holes)
    return MeshPiece(surface, region, V, F, uv, dev)


END_SHARE = 0.25  # a boundary loop at least this share of the longest one's length is an open end, not a hole


def open_ends(V: np.ndarray, F: np.ndarray) -> int:
    """How many open ends a manifold mesh has: its boundary loops at least
    END_SHARE of the longest one's length (a tube has two; a scan with small
    holes, one). 0 for a closed mesh."""
    loops = boundary_loops(F)
    if not loops:
        return 0
    lengths = np.array([np.linalg.norm(V[lp] - V[np.roll(lp, -1)], axis=1).sum() for lp in loops])
    return int((lengths >= END_SHARE * lengths.max()).sum())


def _why_not_met(V, F, uv, residual, between, ctrl: tuple, pinned: bool) -> str:
    """Why a fit stops short of its tolerance (``residual`` (n, 3): vertex
    minus surface point; ``between`` (m,): distance at each triangle's
    centroid): the surface swings between vertices too few to pin it
    (``pinned``: a finer net met the vertices only); the map folds at the
    worst vertex (a triangle of its fan flipped); the worst vertex stands out
    of its neighbours (noise: their residuals share less than
    NOISE_CORRELATION of its own); or the net ran out of control points."""
    dev = np.linalg.norm(residual, axis=1)
    k = int(np.argmax(dev))
    where = f"near ({V[k, 0]:.4g}, {V[k, 1]:.4g}, {V[k, 2]:.4g})"
    fan = np.flatnonzero((F == k).any(axis=1))
    T = uv[F]
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    signed = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    if np.any(np.sign(signed[fan]) == -np.sign(np.sum(signed))):
        return f"its flat map folds over itself {where}; cut the piece there or draw a smaller one"
    if pinned:
        t = int(np.argmax(between)) if between.max() > dev[k] else int(fan[0])
        x, y, z = V[F[t]].mean(axis=0)
        return (f"the detail near ({x:.4g}, {y:.4g}, {z:.4g}) is finer than its {len(V)} vertices pin (a finer "
                f"net than {ctrl[0]} x {ctrl[1]} control points swings between them); give a larger tolerance or "
                f"a finer mesh")
    # smooth detail the net misses leaves a residual the worst vertex's neighbours share; noise, one of its own
    ring = np.setdiff1d(np.unique(F[fan]), [k])
    corr = float(np.mean(residual[ring] @ residual[k]) / max(float(residual[k] @ residual[k]), 1e-300))
    if corr < NOISE_CORRELATION:
        return (f"the vertex {where} stands out of its neighbours (noise: their deviations share {corr:.0%} of "
                f"its own); smooth the scan or give a larger tolerance")
    return (f"the detail {where} is finer than {ctrl[0]} x {ctrl[1]} control points follow; draw a smaller "
            f"piece or give a larger tolerance")


# --------------------------------------------------------------------------- meshes of several CAD faces
def weld_parts(parts, shared, normals=None):
    """One mesh of several: ``parts`` a list of (vertices (n_k, 3), triangles
    (m_k, 3)); ``shared[k]`` part k's edges as (edge id, vertex indices along
    it) pairs; ``normals`` None or per part (n_k, 3) unit normals at its
    vertices. Vertices at the same position of an edge with the same id are
    one vertex (at their mean): the faces' tessellations meet there, whatever
    their edges' tolerances. Returns (V, F, N): N the welded unit normals,
    turned where needed to the side the triangles' winding says, or None.
    The caller still merges coincident vertices (:func:`clean_mesh`)."""
    offsets = np.cumsum([0] + [len(v) for v, _ in parts])
    V = np.vstack([np.asarray(v, float).reshape(-1, 3) for v, _ in parts])
    F = np.vstack([np.asarray(f, np.int64).reshape(-1, 3) + offsets[k] for k, (_, f) in enumerate(parts)])
    N = None
    if normals is not None:
        N = []
        for (v, f), nk in zip(parts, normals):
            v, f, nk = np.asarray(v, float), np.asarray(f, np.int64), np.asarray(nk, float)
            tri_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
            agree = np.sum(tri_n * nk[f].sum(axis=1))
            N.append(nk if agree >= 0 else -nk)  # the file's normal convention or the winding's: the winding's
        N = np.vstack(N)
    by_edge = {}
    for k, edges in enumerate(shared):
        for e, nodes in edges:
            by_edge.setdefault(e, []).append(np.asarray(nodes, np.int64) + offsets[k])
    a, b = [], []
    for chains in by_edge.values():  # an edge's chains: same length when they come from one discretisation
        first = chains[0]
        for other in chains[1:]:
            if len(other) == len(first):
                a.append(first)
                b.append(other)
    n = len(V)
    if a:
        a, b = np.concatenate(a), np.concatenate(b)
        G = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
        _, label = connected_components(G, directed=False)
        count = np.bincount(label)
        V = np.stack([np.bincount(label, V[:, d]) / count for d in range(3)], axis=1)
        if N is not None:
            N = np.stack([np.bincount(label, N[:, d]) for d in range(3)], axis=1)
        F = label[F]
    if N is not None:
        N = N / np.maximum(np.linalg.norm(N, axis=1), 1e-300)[:, None]
    return V, F, N


def _zip(left, right, apex, P, out) -> None:
    """Triangles between two chains of point indices that start at a
    triangle's base corners (left at a, right at b) and run to its ``apex``
    (neither holds it): each step joins the next point of the side whose new
    cross edge is shorter, then the last points close on the apex."""
    i = j = 0
    while i < len(left) - 1 or j < len(right) - 1:
        go_left = j == len(right) - 1 or (i < len(left) - 1 and np.sum((P[left[i + 1]] - P[right[j]]) ** 2)
                                          <= np.sum((P[left[i]] - P[right[j + 1]]) ** 2))
        if go_left:
            out.append((left[i], right[j], left[i + 1]))
            i += 1
        else:
            out.append((left[i], right[j], right[j + 1]))
            j += 1
    out.append((left[i], right[j], apex))


def densify(V: np.ndarray, F: np.ndarray, h: float, max_triangles: int = MAX_TRIANGLES // 4, passes: int = 8,
            normals=None):
    """The mesh with its edges longer than ``h`` split into equal pieces no
    longer than ``h`` and the triangles along them made anew, so that the fit
    has vertices inside long flat triangles (Open CASCADE makes two triangles
    of a rectangle and needles along a cylinder). A triangle with split edges
    is filled by a strip from its edge with the fewest pieces to the opposite
    corner, choosing the shorter diagonal at each step; a few passes make its
    long cross edges short too. Without ``normals`` the new vertices lie on
    the triangles; with the (n, 3) unit normals of the surface at the
    vertices, a point at t along an edge p0 p1 is lifted by 4 t (1 - t) s
    along the mean normal, s = -(p1 - p0).(n0 - n1) / 8 (the sagitta of a
    circle through p0, p1 with those normals, to O(angle^4)), and gets the
    interpolated normal. (A loop per long triangle: a tessellation has few;
    the short ones are kept as they are.) Returns (V, F, N), N None without
    normals."""
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    N = None if normals is None else np.asarray(normals, float)
    for _ in range(passes):
        uniq, inv, _ = edge_table(F)
        length = np.linalg.norm(V[uniq[:, 0]] - V[uniq[:, 1]], axis=1)
        k = np.maximum(np.ceil(length / h * (1 - 1e-9)), 1).astype(np.int64)
        if k.max() == 1 or len(F) + 2 * int((k - 1).sum()) > max_triangles:
            break
        base = len(V) + np.r_[0, np.cumsum(k - 1)[:-1]]  # edge e's inner points: base[e] .. base[e] + k[e] - 2
        t = np.concatenate([np.arange(1, n) / n for n in k[k > 1]])
        e_of = np.repeat(np.nonzero(k > 1)[0], k[k > 1] - 1)
        p0, p1 = V[uniq[e_of, 0]], V[uniq[e_of, 1]]
        new = (1 - t)[:, None] * p0 + t[:, None] * p1
        if N is not None:
            n0, n1 = N[uniq[e_of, 0]], N[uniq[e_of, 1]]
            mean = n0 + n1
            mean /= np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
            sag = -np.sum((p1 - p0) * (n0 - n1), axis=1) / 8
            # an edge of the tessellation turns by its angle (0.08 rad) at most: normals further apart are a
            # crease, or faces wound against each other; no lift there
            sag[np.sum(n0 * n1, axis=1) < 0.866] = 0.0
            new += (4 * t * (1 - t) * sag)[:, None] * mean
            n_new = (1 - t)[:, None] * n0 + t[:, None] * n1
            N = np.vstack([N, n_new / np.maximum(np.linalg.norm(n_new, axis=1), 1e-300)[:, None]])
        V = np.vstack([V, new])
        tri_edges = inv.reshape(-1, 3)
        busy = (k[tri_edges] > 1).any(axis=1)
        out = []

        def chain(a, b, e):  # the points of edge e from corner a to corner b, both ends included
            inner = list(range(base[e], base[e] + k[e] - 1))
            return [a] + (inner if uniq[e, 0] == a else inner[::-1]) + [b]
        for tri, eds in zip(F[busy].tolist(), tri_edges[busy].tolist()):
            r = min(range(3), key=lambda q: (k[eds[q]], length[eds[q]]))  # its edge with the fewest pieces: the base
            a, b, c = tri[r], tri[(r + 1) % 3], tri[(r + 2) % 3]
            e0, e1, e2 = eds[r], eds[(r + 1) % 3], eds[(r + 2) % 3]
            left, right = chain(a, c, e2)[:-1], chain(b, c, e1)[:-1]
            bottom = chain(a, b, e0)
            if len(bottom) > 2:  # every edge split: a fan from the base onto the left side's first point
                for s in range(len(bottom) - 1):
                    out.append((bottom[s], bottom[s + 1], left[1]))
                _zip(left[1:], right, c, V, out)
            else:
                _zip(left, right, c, V, out)
        F = np.vstack([F[~busy], np.asarray(out, np.int64).reshape(-1, 3)])
    return V, F, N


def with_fit(surface: NurbsSurface, fit: MeshFit) -> FittedSurface:
    """``surface`` as a :class:`FittedSurface` carrying ``fit`` (a project reopened)."""
    return FittedSurface(surface.degree_u, surface.degree_v, surface.knots_u, surface.knots_v, surface.ctrlpts,
                         surface.weights if surface.rational else None, fit=fit)


def vertex_deviation(surface: NurbsSurface, mesh: FitMesh) -> np.ndarray:
    """(n,) each mesh vertex's distance to the surface point it maps to: the
    numbers ``MeshFit`` summarises (its max and mean), for a colour map."""
    return fit_deviation(surface, mesh.uv, mesh.vertices)
