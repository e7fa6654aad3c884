"""A region split into panels by seam lines (issue 42, its first stage).

A seam is a polyline in the surface's (u, v) domain (drawn like a curve dart, or
read from a file). It runs from the region's edge to its edge, from the edge to
another seam, or round a closed loop; a drawn end a little beyond the rim or
short of it (within :data:`SNAP` of the region's size) ends on the rim or the
seam it nearly reaches. The seams and the region's loops are noded together and
polygonised; each face inside the region is a :class:`Panel`: its own
:class:`~flatweave.geometry.region.Region` and, per seam that bounds it, its
**sew line** (the part of its outline along that seam, in (u, v)). Two panels
that meet at a seam have sew lines along the same (u, v) curve: what pairs
them when their patterns are sewn back together.

Refused in one line (:class:`~flatweave.errors.SettingsError`), nothing made: a
seam that crosses itself, one that leaves a free end inside a panel (it
reaches neither an edge nor another seam, so it splits nothing there), one
that misses the region, and a split that makes a panel smaller than
:data:`MIN_CELLS` lattice cells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flatweave.errors import SettingsError
from flatweave.geometry.curves import project_polyline
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.region import Region
from flatweave.geometry.uvregion import region_area, region_polygon

__all__ = ["Seam", "Panel", "SewLine", "Split", "split_region", "seam_from_spec", "MIN_CELLS", "SNAP"]

MIN_CELLS = 6
"""The fewest lattice cells (spacing squared each) a panel's area may hold: a
sliver below it gives the drape nothing to lay (issue 42)."""

SNAP = 0.02
"""A seam's free end this close to the rim or another seam (a fraction of the
region's (u, v) size) is taken to end there: a click a little short of the edge."""


@dataclass(frozen=True)
class Seam:
    """A seam line: ``name`` and its (u, v) polyline ``uv`` (k, 2); ``closed``
    when it runs round a loop (its last point joined to its first)."""

    name: str
    uv: np.ndarray
    closed: bool = False


@dataclass(frozen=True)
class Panel:
    """One panel of a split region.

    name : "panel 1", "panel 2", ... in order of the panels' lowest (u, then v) point
    region : its outline and holes in (u, v)
    sew : per sew line (:class:`SewLine`) along its outline, by name, its (u, v) polyline
    """

    name: str
    region: Region
    sew: dict


@dataclass(frozen=True)
class SewLine:
    """A stretch of a seam between its junctions (the rim, other seams): what two
    panels sew together along. ``name``: the seam's, or "NAME 1", "NAME 2", ...
    along a seam that others meet; ``uv`` (k, 2) its polyline; ``panels``: the
    names of the panels on its two sides (one where the seam only opens a piece,
    a tube's, say)."""

    name: str
    seam: str
    uv: np.ndarray
    panels: tuple


@dataclass(frozen=True)
class Split:
    """A region split by seams: its ``panels`` and the ``sews`` between them."""

    panels: tuple
    sews: tuple


def seam_from_spec(surface: NurbsSurface, spec, name: str) -> Seam:
    """A seam from its file's form: ``{"points": [[x, y, z], ...], "view_direction":
    [dx, dy, dz]}`` (drawn, projected onto the surface along the view, as a curve
    dart is) or ``{"uv": [[u, v], ...]}``; optional ``"name"`` (else ``name``) and
    ``"closed"`` (true: a loop). A one-line SettingsError naming what is wrong."""
    if not isinstance(spec, dict):
        raise SettingsError("a seam is an object: {\"points\": [[x, y, z], ...], \"view_direction\": [dx, dy, dz]} "
                            "or {\"uv\": [[u, v], ...]}")
    label = spec.get("name", name)
    if not isinstance(label, str) or not label.strip() or len(label) > 200:
        raise SettingsError('a seam\'s "name" must be a word or a few (at most 200 characters)')
    closed = spec.get("closed", False)
    if not isinstance(closed, bool):
        raise SettingsError(f'seam {label!r}: "closed" must be true or false')
    if "uv" in spec and "points" not in spec:
        uv = spec["uv"]
        try:
            uv = np.asarray(uv, dtype=float)
        except (TypeError, ValueError):
            raise SettingsError(f'seam {label!r}: "uv" must be a list of [u, v] numbers') from None
        if uv.ndim != 2 or uv.shape[1] != 2 or len(uv) < 2 or not np.isfinite(uv).all():
            raise SettingsError(f'seam {label!r}: "uv" must be at least two finite [u, v] points')
        return Seam(label, uv, closed)
    if "points" in spec and "uv" not in spec:
        view = spec.get("view_direction")
        try:
            view = np.asarray(view, dtype=float)
        except (TypeError, ValueError):
            view = np.zeros(0)
        if view.shape != (3,) or not np.isfinite(view).all() or not np.abs(view).max(initial=0.0) > 0:
            raise SettingsError(f'seam {label!r}: "view_direction" must be a nonzero [dx, dy, dz]')
        try:
            curve = project_polyline(surface, spec["points"], view / np.abs(view).max())
        except SettingsError as exc:
            raise SettingsError(f"seam {label!r}: {exc}") from None
        return Seam(label, curve.uv, closed)
    said = '"seam3d" opens a mesh along points on it; on a surface a seam is ' if "seam3d" in spec else "is "
    raise SettingsError(f"seam {label!r}: {said}{{\"points\": [[x, y, z], ...], \"view_direction\": "
                        f"[dx, dy, dz]}} or {{\"uv\": [[u, v], ...]}}")


def _size(poly) -> float:
    x0, y0, x1, y1 = poly.bounds
    return float(np.hypot(x1 - x0, y1 - y0))


def _seam_line(seam: Seam, region_poly, boundary, others, snap: float):
    """The seam as a shapely line clipped to the region, its free ends snapped
    onto the rim or another seam (``others``: the other seams as drawn) when within ``snap``."""
    import shapely
    from shapely.geometry import LineString, Point
    from shapely.ops import nearest_points

    uv = np.asarray(seam.uv, dtype=float)
    if uv.ndim != 2 or uv.shape[1] != 2 or len(uv) < 2 or not np.isfinite(uv).all():
        raise SettingsError(f"seam {seam.name!r} must be at least two finite (u, v) points")
    if seam.closed:
        uv = np.vstack([uv, uv[:1]])
    line = LineString(uv)
    if not line.is_simple:
        raise SettingsError(f"seam {seam.name!r} crosses itself; draw it without a loop")
    if seam.closed:
        return line
    # an end short of the rim (or of another seam) is carried on along its last direction to it
    targets = shapely.union_all([boundary, *others]) if others else boundary
    pts = [p for p in uv]
    for end, inner in ((0, 1), (-1, -2)):
        p = Point(uv[end])
        if not region_poly.covers(p):
            continue  # beyond the rim: the clip below ends it there
        gap = targets.distance(p)
        if gap <= 1e-12 * max(snap, 1e-300) or gap > snap:
            continue
        d = uv[end] - uv[inner]
        d = d / max(float(np.linalg.norm(d)), 1e-300)
        ray = LineString([uv[end], uv[end] + d * 2.0 * snap])
        hit = ray.intersection(targets)
        q = np.asarray(nearest_points(targets if hit.is_empty else hit, p)[0].coords[0])
        if end == 0:
            pts.insert(0, q)
        else:
            pts.append(q)
    clipped = LineString(np.asarray(pts)).intersection(region_poly)
    if clipped.is_empty or clipped.length <= 0:
        raise SettingsError(f"seam {seam.name!r} does not cross the region")
    return clipped


def _drawn(seam: Seam):
    """The seam's points as a shapely line (None when they are not points: _seam_line says why)."""
    from shapely.geometry import LineString

    uv = np.asarray(seam.uv, dtype=float)
    if uv.ndim != 2 or uv.shape[1] != 2 or len(uv) < 2 or not np.isfinite(uv).all():
        return None
    return LineString(np.vstack([uv, uv[:1]]) if seam.closed else uv)


def _parts(geom) -> list:
    import shapely

    out = []
    for g in shapely.get_parts(geom):
        if g.geom_type in ("MultiLineString", "GeometryCollection"):
            out.extend(_parts(g))
        elif g.geom_type == "LineString" and g.length > 0:
            out.append(g)
    return out


def _stretches(noded_parts, seams, lines, tol: float) -> list[tuple[str, str, "object"]]:
    """The seams cut at their junctions (with the rim and with each other): per
    stretch (its name, its seam's name, its shapely line). A seam of one stretch
    lends it its name; a seam of several numbers them from its first point."""
    out = []
    for seam, line in zip(seams, lines):
        mine = [g for g in noded_parts if line.distance(g.interpolate(0.5, normalized=True)) <= tol]
        mine.sort(key=lambda g: line.project(g.interpolate(0.5, normalized=True)))
        for k, g in enumerate(mine):
            out.append((seam.name if len(mine) == 1 else f"{seam.name} {k + 1}", seam.name, g))
    return out


def _with_junction_corners(outer, holes, stretches, tol: float) -> Region:
    """The panel's region, its corners those the turning angle finds and every
    end of a sew line on its loops: the outline's samples then hold each sew
    line's ends (a seam meeting another mid-way turns no corner on the far
    side, where the sew lines either side of it end)."""
    plain = Region.from_loops(outer, holes, corners=[None] * (1 + len(holes)))
    ends = np.array([c for _, _, g in stretches for c in (g.coords[0], g.coords[-1])], dtype=float).reshape(-1, 2)
    corners = []
    for p, found in zip(plain.arrays(), plain.corners):
        d = np.linalg.norm(p[:, None, :] - ends[None, :, :], axis=2).min(axis=1) if len(ends) else np.full(len(p), 1.0)
        corners.append(sorted(set(int(i) for i in found) | set(int(i) for i in np.flatnonzero(d <= tol))))
    return Region.from_loops(outer, holes, corners=corners)


def split_region(surface: NurbsSurface, region: Region | None, seams, spacing: float | None) -> "Split":
    """The panels ``seams`` (a sequence of :class:`Seam`) split ``region`` (None:
    the whole domain) of ``surface`` into, each at least :data:`MIN_CELLS` cells of
    ``spacing`` (model units) in area, and their sew lines. A one-line
    SettingsError when a seam crosses itself, misses the region, leaves a free
    end inside a panel, or a panel is a sliver (``spacing`` None: not checked,
    a split that was made before read again). No seams: the region itself,
    one panel."""
    import shapely
    from shapely.ops import polygonize

    seams = list(seams)
    names = [s.name for s in seams]
    if len(set(names)) != len(names):
        raise SettingsError("two seams have the same name")
    if region is None:
        (u0, u1), (v0, v1) = surface.domain
        region = Region.from_loops([(u0, v0), (u1, v0), (u1, v1), (u0, v1)])
    poly = region_polygon(region.arrays())
    if poly.is_empty:
        raise SettingsError("the region to split is empty")
    boundary = poly.boundary
    snap = SNAP * _size(poly)
    drawn = [_drawn(s) for s in seams]
    lines = [_seam_line(seam, poly, boundary, [d for j, d in enumerate(drawn) if j != k and d is not None], snap)
             for k, seam in enumerate(seams)]
    if not lines:
        return Split((Panel("panel 1", region, {}),), ())
    noded = shapely.union_all([boundary, *lines])
    faces = [f for f in shapely.get_parts(polygonize(_parts(noded)))
             if poly.contains(f.representative_point()) and f.area > 0]
    # a seam with a free end inside a panel bounds no panel along that end: its length is not all on outlines
    outlines = shapely.union_all([f.boundary for f in faces])
    tol = 1e-9 * _size(poly)
    for seam, line in zip(seams, lines):
        loose = line.difference(outlines.buffer(tol, cap_style="flat"))
        if loose.length > 1e-6 * line.length:
            end = np.asarray(_parts(loose)[0].coords[-1])
            raise SettingsError(f"seam {seam.name!r} does not reach an edge or another seam (a free end near "
                                f"u {end[0]:.4g}, v {end[1]:.4g} splits nothing): carry it on to the edge or a seam")
    faces.sort(key=lambda f: (round(f.bounds[0], 12), round(f.bounds[1], 12)))
    stretches = _stretches(_parts(noded), seams, lines, tol)
    panels = []
    for k, face in enumerate(faces):
        from shapely.geometry.polygon import orient

        f = orient(face, 1.0)
        outer = np.asarray(f.exterior.coords)[:-1]
        holes = [np.asarray(r.coords)[:-1] for r in f.interiors]
        reg = _with_junction_corners(outer, holes, stretches, tol)
        cells = math.inf if spacing is None else region_area(surface, reg.arrays()) / (spacing * spacing)
        if cells < MIN_CELLS:
            x, y = face.representative_point().coords[0]
            raise SettingsError(f"the seams make a panel of {cells:.1f} cells (near u {x:.4g}, v {y:.4g}), under "
                                f"the {MIN_CELLS} a panel needs at spacing {spacing:g}: move the seams apart")
        ring = face.boundary
        sew = {name: np.asarray(g.coords) for name, _, g in stretches
               if ring.distance(g.interpolate(0.5, normalized=True)) <= tol}
        panels.append(Panel(f"panel {k + 1}", reg, sew))
    sews = []
    for name, seam_name, g in stretches:
        sides = tuple(p.name for p in panels if name in p.sew)
        sews.append(SewLine(name, seam_name, np.asarray(g.coords), sides))
    return Split(tuple(panels), tuple(sews))
