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

from core.mesh import SpringMesh, lattice_index
from core.nurbs import NurbsSurface
from core.quadrature import boundary_polyline, edge_lengths

__all__ = ["Pattern", "node_frames", "map_points", "make_pattern", "polygon_area", "polygon_perimeter"]

BLEND_K = 6  # nodes blended per boundary point


@dataclass(frozen=True)
class Pattern:
    """A flat pattern piece.

    xy : (n, 2) 2D positions of the nodes (the relaxed lattice)
    outline : (k, 2) closed outline polygon (first point not repeated), counter-clockwise
    outline3d : (k, 3) the boundary points on the surface the outline points come from
    outline_uv : (k, 2) their parameters
    """

    xy: np.ndarray
    outline: np.ndarray
    outline3d: np.ndarray
    outline_uv: np.ndarray

    @property
    def perimeter(self) -> float:
        return polygon_perimeter(self.outline)

    @property
    def area(self) -> float:
        return abs(polygon_area(self.outline))


def polygon_area(poly: np.ndarray) -> float:
    """Signed area of a closed polygon (k, 2) (shoelace; positive if counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def polygon_perimeter(poly: np.ndarray) -> float:
    """Perimeter of a closed polygon (k, 2)."""
    return float(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1).sum())


def node_frames(mesh: SpringMesh, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-node lattice vectors on the surface.

    Returns W (n, 3), the change of position per lattice column (central
    difference where both row neighbours exist, one-sided where one does),
    P (n, 3), the same per lattice row, and ok (n,) bool, nodes that have both.
    """
    grid, off = lattice_index(mesh.ij)
    g = mesh.ij - off

    def diff(di, dj):
        fwd = grid[g[:, 0] + di, g[:, 1] + dj]
        bwd = grid[g[:, 0] - di, g[:, 1] - dj]
        hf, hb = fwd >= 0, bwd >= 0
        out = np.zeros_like(xyz)
        both = hf & hb
        out[both] = 0.5 * (xyz[fwd[both]] - xyz[bwd[both]])
        f = hf & ~hb
        out[f] = xyz[fwd[f]] - xyz[f]
        b = hb & ~hf
        out[b] = xyz[b] - xyz[bwd[b]]
        return out, hf | hb

    W, okw = diff(0, 1)
    P, okp = diff(1, 0)
    return W, P, okw & okp


def map_points(Q: np.ndarray, mesh: SpringMesh, xyz: np.ndarray, xy: np.ndarray,
               usable: np.ndarray | None = None, k: int = BLEND_K) -> np.ndarray:
    """Map 3D points Q (q, 3) near the mesh into the 2D pattern (q, 2).

    Each point is expressed in the lattice frames of its k nearest usable
    nodes and the k results are blended with weights (1 - (d/d_k+1)^2)^2,
    which vanish at the (k+1)-th nearest node (see the module docstring).
    """
    W, P, ok = node_frames(mesh, xyz)
    if usable is not None:
        ok &= usable
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        raise ValueError("no node has both a weft and a warp neighbour")
    k = min(k, idx.size - 1) if idx.size > 1 else 1
    dist, nn = cKDTree(xyz[idx]).query(Q, k=k + 1)
    dist, nn = dist.reshape(len(Q), k + 1), idx[nn.reshape(len(Q), k + 1)]
    # weights fall to zero at the (k+1)-th nearest node, so the blend is
    # continuous as Q moves and nodes enter or leave the nearest set
    w = np.clip(1.0 - (dist[:, :k] / np.maximum(dist[:, k:], 1e-300)) ** 2, 0.0, None) ** 2
    w[:, 0] += 1e-300
    w /= w.sum(axis=1, keepdims=True)
    dist, nn = dist[:, :k], nn[:, :k]
    # least squares d = a W + b P for every (point, node) pair
    d = Q[:, None, :] - xyz[nn]
    Wn, Pn = W[nn], P[nn]
    g11 = np.einsum("qkc,qkc->qk", Wn, Wn)
    g12 = np.einsum("qkc,qkc->qk", Wn, Pn)
    g22 = np.einsum("qkc,qkc->qk", Pn, Pn)
    r1 = np.einsum("qkc,qkc->qk", Wn, d)
    r2 = np.einsum("qkc,qkc->qk", Pn, d)
    det = g11 * g22 - g12 * g12
    a = (g22 * r1 - g12 * r2) / det
    b = (g11 * r2 - g12 * r1) / det
    cand = xy[nn] + np.stack([a * mesh.r_weft, b * mesh.r_warp], axis=-1)
    return np.einsum("qk,qkc->qc", w, cand)


def boundary_samples(surface: NurbsSurface, spacing: float, per_spacing: int = 4,
                     minimum: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """(uv, xyz) of points even in arc length along the boundary, corners included,
    about ``per_spacing`` points per mesh spacing (at least ``minimum`` per edge)."""
    lengths = edge_lengths(surface)
    n_edge = tuple(int(max(minimum, np.ceil(L / spacing * per_spacing))) for L in lengths)
    return boundary_polyline(surface, n_edge)


def make_pattern(surface: NurbsSurface, mesh: SpringMesh, xyz: np.ndarray,
                 samples: tuple[np.ndarray, np.ndarray] | None = None) -> Pattern:
    """The 2D pattern of a mesh state: relaxed lattice and outline."""
    xy = mesh.lattice_xy()
    if samples is None:
        samples = boundary_samples(surface, min(mesh.r_weft, mesh.r_warp))
    uv, Q = samples
    outline = map_points(Q, mesh, xyz, xy)
    if polygon_area(outline) < 0:  # report counter-clockwise
        outline, Q, uv = outline[::-1], Q[::-1], uv[::-1]
    return Pattern(xy=xy, outline=outline, outline3d=Q, outline_uv=uv)
