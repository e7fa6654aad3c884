"""How much of the region the cloth covers, and where it does not.

A point of the region is *uncovered* when it lies farther than ``reach`` from
every node of the mesh; the pipeline uses a cell diagonal,
sqrt(r_weft^2 + r_warp^2), so a complete lattice leaves nothing uncovered
(every point of a cell is within half a diagonal of one of its corners, and
the strip between the outermost nodes and the edge is narrower than a
spacing). ``metrics["uncovered_pct"]`` is 100 times the uncovered share of the
region's area.

The region is sampled by the midpoint rule on a regular grid of the parameter
domain, weighted by the area element |S_u x S_v|, with cells about a third of
``reach`` across on the surface (at most :data:`MAX_SAMPLES` of them); the
distances come from one k-d tree query. The grid is made once per surface and
reach and kept while the surface lives.

:func:`uncovered_regions` groups the uncovered cells into connected regions:
the openings a mesh leaves (on negative curvature, the wedge between the two
sides of a cut that pulled apart), each with its area and outline in (u, v)
and on the surface: the piece an inserted gusset has to cover.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from flatweave.geometry.nurbs import NurbsSurface

__all__ = ["CoverageGrid", "cell_diagonal", "coverage_grid", "uncovered_points", "uncovered_share",
           "uncovered_regions", "UncoveredRegion", "MAX_SAMPLES"]

MAX_SAMPLES = 160_000
"""Largest number of sample cells of a coverage grid."""

_CELLS_PER_REACH = 3.0
_cache: "weakref.WeakKeyDictionary[NurbsSurface, dict]" = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class CoverageGrid:
    """Midpoint samples of the region: ``uv (nu * nv, 2)`` (row-major over
    (u, v)), their points ``xyz`` and area weights ``area`` (they sum to the
    region's area to the rule's accuracy), the grid's ``shape`` (nu, nv) and
    its parameter edges ``edges_u (nu + 1,)``, ``edges_v (nv + 1,)``."""

    uv: np.ndarray
    xyz: np.ndarray
    area: np.ndarray
    shape: tuple[int, int]
    edges_u: np.ndarray
    edges_v: np.ndarray
    # (samples,) bool: in a trimmed region (:meth:`flatweave.geometry.region.Cover.coverage_grid`)
    inside: np.ndarray | None = None


def cell_diagonal(r_weft: float, r_warp: float) -> float:
    """sqrt(r_weft^2 + r_warp^2): the reach of ``metrics["uncovered_pct"]``."""
    return float(np.hypot(r_weft, r_warp))


def coverage_grid(surface: NurbsSurface, reach: float) -> CoverageGrid:
    """The sample grid for ``reach`` (cells about reach / 3 across on the
    surface, at most :data:`MAX_SAMPLES`); cached per surface and reach."""
    reach = float(reach)
    if not (np.isfinite(reach) and reach > 0):
        raise ValueError(f"reach must be a positive number, got {reach!r}")
    per = _cache.setdefault(surface, {})
    key = float(f"{reach:.12g}")
    if key in per:
        return per[key]
    dom = surface.domain
    g = np.linspace(0.0, 1.0, 17)
    coarse = np.column_stack([a.ravel() for a in np.meshgrid(dom[0, 0] + g * (dom[0, 1] - dom[0, 0]),
                                                          dom[1, 0] + g * (dom[1, 1] - dom[1, 0]),
                                                          indexing="ij")])
    _, su, sv = surface.derivatives(coarse)
    # the longest iso-line in each direction, on the surface
    length_u = float(np.nanmax(np.linalg.norm(su, axis=1))) * float(dom[0, 1] - dom[0, 0])
    length_v = float(np.nanmax(np.linalg.norm(sv, axis=1))) * float(dom[1, 1] - dom[1, 0])
    nu = max(4, int(np.ceil(_CELLS_PER_REACH * length_u / reach)))
    nv = max(4, int(np.ceil(_CELLS_PER_REACH * length_v / reach)))
    if nu * nv > MAX_SAMPLES:
        f = np.sqrt(MAX_SAMPLES / (nu * nv))
        nu, nv = max(4, int(nu * f)), max(4, int(nv * f))
    eu = np.linspace(dom[0, 0], dom[0, 1], nu + 1)
    ev = np.linspace(dom[1, 0], dom[1, 1], nv + 1)
    cu, cv = 0.5 * (eu[1:] + eu[:-1]), 0.5 * (ev[1:] + ev[:-1])
    uv = np.column_stack([a.ravel() for a in np.meshgrid(cu, cv, indexing="ij")])
    S, su, sv = surface.derivatives(uv)
    da = float((eu[1] - eu[0]) * (ev[1] - ev[0]))
    area = np.linalg.norm(np.cross(su, sv), axis=1) * da
    area = np.where(np.isfinite(area), area, 0.0)
    grid = CoverageGrid(uv, S, area, (nu, nv), eu, ev)
    if len(per) > 8:  # a few spacings per surface at most
        per.clear()
    per[key] = grid
    return grid


def _far(grid: CoverageGrid, xyz: np.ndarray, reach: float) -> np.ndarray:
    """(samples,) bool: samples farther than ``reach`` from every node."""
    if len(xyz) == 0:
        return np.ones(len(grid.uv), dtype=bool) if grid.inside is None else grid.inside.copy()
    d = cKDTree(np.asarray(xyz, dtype=float)).query(grid.xyz, distance_upper_bound=reach)[0]
    return d > reach if grid.inside is None else (d > reach) & grid.inside


def uncovered_share(surface: NurbsSurface, xyz: np.ndarray, reach: float, grid: CoverageGrid | None = None) -> float:
    """Share (0..1) of the region's area farther than ``reach`` from every point of ``xyz (n, 3)``
    (``grid``: a region's own, :meth:`flatweave.geometry.region.Cover.coverage_grid`)."""
    grid = coverage_grid(surface, reach) if grid is None else grid
    far = _far(grid, xyz, reach)
    total = float(grid.area.sum())
    return float(grid.area[far].sum() / total) if total > 0 else 0.0


def uncovered_points(surface: NurbsSurface, xyz: np.ndarray, reach: float,
                     grid: CoverageGrid | None = None) -> np.ndarray:
    """(k, 2) parameters of the uncovered samples."""
    grid = coverage_grid(surface, reach) if grid is None else grid
    return grid.uv[_far(grid, xyz, reach)]


@dataclass(frozen=True)
class UncoveredRegion:
    """A connected uncovered region.

    area : on the surface; share : of the region's area (0..1)
    outline_uv (k, 2), outline3d (k, 3) : its outer boundary, closed (first
        point repeated), along the edges of the sample cells
    centre : (3,) the area-weighted mean of its samples
    width : the largest distance from one of its samples to the nearest node
    """

    area: float
    share: float
    outline_uv: np.ndarray
    outline3d: np.ndarray
    centre: np.ndarray
    width: float

    def to_dict(self) -> dict:
        return {"area": self.area, "share_pct": 100 * self.share, "outline_uv": self.outline_uv.tolist(),
                "outline3d": self.outline3d.tolist(), "centre": self.centre.tolist(), "width": self.width}


def _outline(mask: np.ndarray, eu: np.ndarray, ev: np.ndarray) -> np.ndarray:
    """The outer boundary of the cells ``mask (nu, nv)`` (one connected set)
    as a closed (u, v) polygon along cell edges."""
    from shapely.geometry import box
    from shapely.ops import unary_union

    # runs of cells along v, one box per run: few boxes to unite
    boxes = []
    for i in np.flatnonzero(mask.any(axis=1)):
        row = np.r_[False, mask[i], False].astype(np.int8)
        d = np.diff(row)
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            boxes.append(box(eu[i], ev[a], eu[i + 1], ev[b]))
    shape = unary_union(boxes)
    if shape.geom_type != "Polygon":
        shape = max(shape.geoms, key=lambda g: g.area)
    return np.asarray(shape.exterior.coords, dtype=float)


def uncovered_regions(surface: NurbsSurface, xyz: np.ndarray, reach: float,
                      min_share: float = 0.002, grid: CoverageGrid | None = None) -> list[UncoveredRegion]:
    """The connected uncovered regions of at least ``min_share`` of the
    region's area, largest first."""
    grid = coverage_grid(surface, reach) if grid is None else grid
    far = _far(grid, xyz, reach)
    if not far.any():
        return []
    mask = far.reshape(grid.shape)
    labels, n = ndimage.label(mask, structure=np.ones((3, 3)))
    flat = labels.ravel()
    total = float(grid.area.sum())
    areas = np.bincount(flat, grid.area, minlength=n + 1)
    tree = cKDTree(np.asarray(xyz, dtype=float)) if len(xyz) else None
    out = []
    for lab in np.argsort(-areas[1:]) + 1:
        if areas[lab] < min_share * total:
            break
        sel = flat == lab
        ring = _outline(labels == lab, grid.edges_u, grid.edges_v)
        w = grid.area[sel]
        centre = (grid.xyz[sel] * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300)
        width = float(tree.query(grid.xyz[sel])[0].max()) if tree is not None else float("inf")
        out.append(UncoveredRegion(float(areas[lab]), float(areas[lab] / total), ring, surface.points(ring),
                                   centre, width))
    return out
