"""The piece to cover: a NURBS patch and a region of its (u, v) domain.

A :class:`Region` is plain data: an outer loop and any number of holes,
closed polylines in (u, v) (the last point joins the first), and per loop
the indices of its corners (where the edges of a CAD face meet; found by the
turning angle when not given). It is part of the
:class:`~flatweave.method.pipeline.FlattenSettings` (``settings.region``; None is the
whole domain), so project files, result files, undo and "is the result
current" see it like any other setting.

A :class:`Cover` is a surface with a region (None: the whole domain) and
owns what the stages derive from it, each computed once:

- ``area``: :func:`flatweave.geometry.uvregion.region_area` (Green's theorem per knot cell)
  of the polygon region; the whole domain's is
  :func:`flatweave.geometry.quadrature.region_area`;
- ``boundary_length``: the length on the surface of every loop, each
  polyline segment's image integrated by Gauss-Legendre (8 nodes on pieces
  no longer than 1/64 of the domain); whole domain:
  :func:`flatweave.geometry.quadrature.boundary_length`;
- :meth:`Cover.boundary_samples`: points even in arc length along every
  loop, corners kept (the outer loop and the holes separately), for the
  pattern's boundary approximation (paper 3.5); whole domain:
  :func:`flatweave.method.pattern.boundary_samples`;
- :meth:`Cover.contains`: vectorised point-in-region test (shapely
  ``intersects_xy``: points on a loop count as inside);
- ``default_seed``: the point of the region farthest from its boundary (the
  pole of inaccessibility, shapely ``polylabel``, in (u, v) scaled by the
  surface's mean iso-line lengths), as fractions of the domain; whole domain:
  (0.5, 0.5).

For the whole domain every value is today's function's, so untrimmed
results are bit-identical.
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass

import numpy as np

from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.numerics import polygon_area
from flatweave.geometry.curves import fit_biarcs, project_points, project_polyline
from flatweave.geometry.curves import tessellation
from flatweave.geometry.uvregion import region_area
from flatweave.geometry.quadrature import gauss_legendre_01
from flatweave.geometry.uvregion import region_polygon
from flatweave.geometry.coverage import coverage_grid
from flatweave.geometry.quadrature import region_area as whole_surface_area
from flatweave.geometry.quadrature import boundary_length
from flatweave.geometry.quadrature import boundary_samples
from flatweave.geometry.nurbs import boundary_distance

__all__ = ["Region", "RegionDrawing", "Cover", "cover_for", "circle_loop", "region_from_cad_face", "region_from_spec",
           "region_from_drawing", "offset_region", "check_region", "check_region_size", "region_record",
           "loops_on_surface", "CORNER_DEG", "MIN_CELLS", "LOOP_CHORD_TOL"]

CORNER_DEG = 30.0
"""A loop vertex whose polyline turns by more than this (in (u, v)) is a
corner when a region does not list its corners."""

_PIECE = 1.0 / 64.0  # longest Gauss piece of a loop segment, as a fraction of the domain's size


def _clean_loop(loop, what: str) -> np.ndarray:
    try:
        p = np.asarray(loop, dtype=float).reshape(-1, 2)
    except (TypeError, ValueError):
        raise SettingsError(f"{what} must be a list of (u, v) pairs") from None
    if not np.isfinite(p).all():
        raise SettingsError(f"{what} has a non-finite (u, v)")
    if len(p) > 1 and np.all(p[-1] == p[0]):
        p = p[:-1]
    keep = np.r_[True, np.any(p[1:] != p[:-1], axis=1)]  # no repeated points
    p = p[keep]
    if len(p) < 3 or abs(polygon_area(p)) == 0.0:
        raise SettingsError(f"{what} must enclose an area (3 or more distinct points)")
    return p


@dataclass(frozen=True)
class Region:
    """A region of a surface's (u, v) domain.

    loops : tuple of loops, each a tuple of (u, v) float pairs; the outer loop
        first (counter-clockwise), then the holes (clockwise); closed
        implicitly
    corners : per loop, a tuple of point indices that are corners (0 is
        always one); empty: found by the turning angle (:data:`CORNER_DEG`)
    drawn : how the region was drawn (:class:`RegionDrawing`: the points and
        view direction, or the (u, v) fractions, and the offset), or None;
        a label for editing, the loops are what every stage uses
    """

    loops: tuple
    corners: tuple = ()
    drawn: "RegionDrawing | None" = None

    @classmethod
    def from_loops(cls, outer, holes=(), corners=None) -> "Region":
        """A region from an outer (u, v) polyline and holes (any sense: the
        outer loop is made counter-clockwise, the holes clockwise);
        ``corners`` optional, per loop the indices of its corners (or None:
        found by the turning angle)."""
        loops = [_clean_loop(outer, "the region's outer loop")]
        loops += [_clean_loop(h, f"hole {k + 1} of the region") for k, h in enumerate(holes)]
        fixed, flips = [], []
        for k, p in enumerate(loops):
            flip = (polygon_area(p) < 0) if k == 0 else (polygon_area(p) > 0)
            fixed.append(p[::-1] if flip else p)
            flips.append(flip)
        corner_t = ()
        if corners is not None:
            if len(corners) != len(loops):
                raise SettingsError(f"the region has {len(loops)} loops but corners for {len(corners)}")
            out = []
            scale = np.maximum(np.ptp(fixed[0], axis=0), 1e-300)
            for p, c, flip in zip(fixed, corners, flips):
                n = len(p)
                if c is None:  # this loop's corners by the turning angle
                    out.append(tuple(int(i) for i in _turning_corners(p, scale)))
                    continue
                idx = np.unique(np.asarray(c, dtype=np.int64) % n)
                if flip:  # point i of the reversed loop was point n - 1 - i
                    idx = np.unique((n - 1 - idx) % n)
                idx = np.unique(np.r_[0, idx]) if len(idx) == 0 or idx[0] != 0 else idx
                out.append(tuple(int(i) for i in idx))
            corner_t = tuple(out)
        return cls(tuple(tuple(map(tuple, p.tolist())) for p in fixed), corner_t)

    def arrays(self) -> list[np.ndarray]:
        """The loops as (n, 2) float arrays."""
        return [np.asarray(p, dtype=float) for p in self.loops]

    @property
    def n_holes(self) -> int:
        return len(self.loops) - 1

    def to_dict(self) -> dict:
        """The region in project and result files."""
        out = {"loops": [[list(q) for q in p] for p in self.loops],
               "corners": [list(c) for c in self.corners] if self.corners else None}
        if self.drawn is not None:
            out["drawn"] = self.drawn.to_dict()
        return out

    @classmethod
    def from_dict(cls, d) -> "Region":
        """The inverse of :meth:`to_dict` (also accepts ``{"outer": ..., "holes": [...]}``);
        a one-line SettingsError on a malformed entry."""
        if not isinstance(d, dict):
            raise SettingsError(f"a region must be an object with loops, got {type(d).__name__}")
        if "loops" in d:
            loops = d["loops"]
            if not isinstance(loops, list) or not loops:
                raise SettingsError("a region's loops must be a non-empty list of (u, v) polylines")
            outer, holes = loops[0], loops[1:]
        elif "outer" in d:
            outer, holes = d["outer"], d.get("holes", [])
            if not isinstance(holes, list):
                raise SettingsError("a region's holes must be a list of (u, v) polylines")
        else:
            raise SettingsError("a region needs 'loops' (outer loop first) or 'outer' and 'holes'")
        corners = d.get("corners")
        region = cls.from_loops(outer, holes)
        if corners is not None:
            if not (isinstance(corners, list) and len(corners) == len(region.loops)
                    and all(isinstance(c, list) and all(isinstance(i, int) and not isinstance(i, bool)
                                                        and 0 <= i < len(p) for i in c)
                            for c, p in zip(corners, region.loops))):
                raise SettingsError("a region's corners must be, per loop, a list of point indices")
            region = cls(region.loops, tuple(tuple(sorted(set([0] + c))) for c in corners))
        if d.get("drawn") is not None:
            from dataclasses import replace
            try:
                region = replace(region, drawn=RegionDrawing.from_dict(d["drawn"]))
            except SettingsError as exc:
                raise SettingsError(f"the region's drawn form: {exc}") from None
        return region


def circle_loop(centre, radius, n: int = 256, hole: bool = True) -> np.ndarray:
    """(n, 2) a circle in (u, v) (clockwise for a hole, else counter-clockwise)."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    t = -t if hole else t
    return np.column_stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)])


def region_from_cad_face(face) -> Region | None:
    """The region of a :class:`flatweave.reading.cad.CadFace` (None for an untrimmed face:
    its whole domain, so it takes today's path)."""
    if not face.trimmed:
        return None
    return Region.from_loops(face.loops_uv[0], face.loops_uv[1:], corners=list(face.loop_breaks))


# ---------------------------------------------------------------------- the cover
def _turning_corners(p: np.ndarray, scale: np.ndarray) -> np.ndarray:
    q = p / scale
    a = q - np.roll(q, 1, axis=0)
    b = np.roll(q, -1, axis=0) - q
    cos = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
    idx = np.flatnonzero(cos < math.cos(math.radians(CORNER_DEG)))
    return np.unique(np.r_[0, idx])


CURVATURE_SAMPLES = 1000
"""Points along the region's boundary of :attr:`Cover.total_curvature` (the octant's pi / 2 and
the saddle's -2 pi / 3 to 5 digits)."""


class Cover:
    """A surface and a region of its domain (None: the whole domain); see the
    module docstring. Use :func:`cover_for` to share one per (surface, region)."""

    def __init__(self, surface: NurbsSurface, region: Region | None = None):
        self.surface = surface
        self.region = region
        if region is not None:
            dom = surface.domain
            size = dom[:, 1] - dom[:, 0]
            loops = region.arrays()
            tol = 1e-3 * size
            for k, p in enumerate(loops):
                if np.any(p < dom[:, 0] - tol) or np.any(p > dom[:, 1] + tol):
                    what = "outer loop" if k == 0 else f"hole {k}"
                    raise SettingsError(f"the region's {what} leaves the surface's domain "
                                        f"u [{dom[0, 0]:g}, {dom[0, 1]:g}], v [{dom[1, 0]:g}, {dom[1, 1]:g}]")
            self._loops = [np.clip(p, dom[:, 0], dom[:, 1]) for p in loops]
            self._corners = [np.asarray(c, dtype=np.int64) for c in region.corners] if region.corners else \
                [_turning_corners(p, size) for p in self._loops]
        self._samples: dict = {}
        self._grids: dict = {}

    @property
    def trimmed(self) -> bool:
        return self.region is not None

    @property
    def loops(self) -> list[np.ndarray]:
        """The loops in (u, v): the region's, or the domain's rectangle (counter-clockwise)."""
        if self.region is not None:
            return [p.copy() for p in self._loops]
        (u0, u1), (v0, v1) = self.surface.domain
        return [np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]], dtype=float)]

    # -- area and length
    @functools.cached_property
    def area(self) -> float:
        if self.region is None:
            return whole_surface_area(self.surface)
        return float(region_area(self.surface, self._loops))

    @functools.cached_property
    def total_curvature(self) -> float:
        """The integral of the Gaussian curvature over the region (dimensionless:
        pi / 2 on a sphere's octant, 0 on a developable piece, -2 pi / 3 on the
        saddle z = (x^2 - y^2) / 2 over [-1, 1]^2), by Gauss-Bonnet from the
        region's loops: 2 pi (1 - holes) less the loops' turning in the surface's
        tangent planes (each loop sampled at :data:`CURVATURE_SAMPLES` points,
        the region on its left). From the edge, not the interior, so that bumps
        a sampling could miss cannot upset it: what the boundary and area error
        limits scale with (:func:`flatweave.method.metrics.metric_limits`)."""
        L = self.boundary_length
        if not (np.isfinite(L) and L > 0):
            return 0.0
        outer, holes = self.boundary_samples(L / CURVATURE_SAMPLES, per_spacing=1, minimum=64)
        size = float(np.ptp(outer[1], axis=0).max()) or 1.0
        turning = 0.0
        for k, (uv, xyz) in enumerate([outer, *holes]):
            area = 0.5 * float(np.sum(uv[:, 0] * np.roll(uv[:, 1], -1) - np.roll(uv[:, 0], -1) * uv[:, 1]))
            if (area < 0) == (k == 0):  # the region on the loop's left: the outer loop counter-clockwise
                uv, xyz = uv[::-1], xyz[::-1]
            step = np.linalg.norm(np.roll(xyz, -1, axis=0) - xyz, axis=1)
            keep = step > 1e-12 * size  # a pole: the loop's points there are one point
            uv, xyz = uv[keep], xyz[keep]
            if len(xyz) < 3:
                continue
            n = self.surface.evaluate(uv).normal
            e_in = xyz - np.roll(xyz, 1, axis=0)
            e_out = np.roll(xyz, -1, axis=0) - xyz
            a = e_in - np.einsum("ij,ij->i", e_in, n)[:, None] * n
            b = e_out - np.einsum("ij,ij->i", e_out, n)[:, None] * n
            turning += float(np.arctan2(np.einsum("ij,ij->i", n, np.cross(a, b)), np.einsum("ij,ij->i", a, b)).sum())
        return float(2.0 * math.pi * (1 - len(holes)) - turning)

    @functools.cached_property
    def _loop_arcs(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per loop: (points (n, 2), cumulative arc length at each point and back at the start (n + 1,),
        per-segment (pieces' fine uv, their cumulative lengths)) for resampling."""
        x, w = gauss_legendre_01(8)
        dom = self.surface.domain
        size = dom[:, 1] - dom[:, 0]
        out = []
        for p in self._loops:
            q = np.roll(p, -1, axis=0)
            m = np.maximum(1, np.ceil(np.max(np.abs(q - p) / size, axis=1) / _PIECE).astype(int))
            seg = np.repeat(np.arange(len(p)), m)
            k = np.arange(len(seg)) - np.repeat(np.cumsum(m) - m, m)
            t0, t1 = k / m[seg], (k + 1) / m[seg]
            d = q[seg] - p[seg]
            tt = (t0[:, None] + (t1 - t0)[:, None] * x[None, :])  # (pieces, 8)
            uv = p[seg][:, None, :] + tt[..., None] * d[:, None, :]
            _, su, sv = self.surface.derivatives(uv.reshape(-1, 2))
            dd = np.repeat(d, len(x), axis=0)
            speed = np.linalg.norm(su * dd[:, :1] + sv * dd[:, 1:], axis=1).reshape(-1, len(x))
            piece_len = (speed @ w) * (t1 - t0)
            cum_piece = np.r_[0.0, np.cumsum(piece_len)]
            # arc length at each polyline point: at the start of its first piece
            first = np.cumsum(m) - m
            s = np.r_[cum_piece[first], cum_piece[-1]]
            out.append((p, s, (seg, t0, t1, cum_piece)))
        return out

    @functools.cached_property
    def loop_lengths(self) -> tuple[float, ...]:
        """Length on the surface of each loop (outer first)."""
        if self.region is None:
            return (boundary_length(self.surface),)
        return tuple(float(s[-1]) for _, s, _ in self._loop_arcs)

    @functools.cached_property
    def boundary_length(self) -> float:
        if self.region is None:
            return boundary_length(self.surface)
        return float(sum(self.loop_lengths))

    def _at_arc(self, k: int, targets: np.ndarray) -> np.ndarray:
        """(u, v) on loop k at arc lengths ``targets`` from its first point."""
        p, _, (seg, t0, t1, cum) = self._loop_arcs[k]
        q = np.roll(p, -1, axis=0)
        j = np.clip(np.searchsorted(cum, targets, side="right") - 1, 0, len(seg) - 1)
        span = cum[j + 1] - cum[j]
        f = np.where(span > 0, (targets - cum[j]) / np.where(span > 0, span, 1.0), 0.0)
        t = t0[j] + np.clip(f, 0.0, 1.0) * (t1[j] - t0[j])
        return p[seg[j]] + t[:, None] * (q[seg[j]] - p[seg[j]])

    def boundary_samples(self, spacing: float, per_spacing: int = 4, minimum: int = 64):
        """``(outer, holes)``: ``outer = (uv (k, 2), xyz (k, 3))`` even in arc
        length along the outer loop with its corners kept, about
        ``per_spacing`` points per ``spacing``; ``holes`` a list of the same
        for each hole. The whole domain's outer samples are
        :func:`flatweave.method.pattern.boundary_samples`'s."""
        if self.region is None:
            return boundary_samples(self.surface, spacing, per_spacing, minimum), []
        key = (float(spacing), int(per_spacing), int(minimum))
        hit = self._samples.get(key)
        if hit is None:
            loops = []
            for k, (p, s, _) in enumerate(self._loop_arcs):
                corners = self._corners[k]
                L = s[-1]
                n_total = int(max(minimum, math.ceil(L / spacing * per_spacing)))
                starts = s[corners]
                ends = np.r_[starts[1:], L]
                parts = []
                for a, b in zip(starts, ends):
                    n_e = int(max(1, round((b - a) / L * n_total))) if L > 0 else 1
                    parts.append(a + (b - a) * np.arange(n_e) / n_e)
                uv = self._at_arc(k, np.concatenate(parts))
                uv[np.searchsorted(np.concatenate(parts), starts)] = p[corners]  # corners exact
                loops.append((uv, self.surface.points(uv)))
            if len(self._samples) >= 16:
                self._samples.clear()
            hit = self._samples[key] = (loops[0], loops[1:])
        (uv, xyz), holes = hit
        return (uv.copy(), xyz.copy()), [(h[0].copy(), h[1].copy()) for h in holes]

    # -- inside
    @functools.cached_property
    def polygon(self):
        """The region as a valid shapely (Multi)Polygon in (u, v) (prepared)."""
        import shapely
        poly = region_polygon(self.loops)
        shapely.prepare(poly)
        return poly

    def contains(self, uv: np.ndarray) -> np.ndarray:
        """(n,) bool: the points lie in the region (its loops count as inside;
        the whole domain: :meth:`NurbsSurface.in_domain`)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if self.region is None:
            return self.surface.in_domain(uv)
        import shapely
        out = np.zeros(len(uv), dtype=bool)
        ok = np.isfinite(uv).all(axis=1)
        if ok.any():
            out[ok] = shapely.intersects_xy(self.polygon, uv[ok, 0], uv[ok, 1])
        return out

    def edge_distance(self, uv: np.ndarray) -> np.ndarray:
        """(k,) distance of parameter points to the outer loop, in fractions of
        the domain (as :func:`flatweave.method.darts.boundary_distance` for the whole domain)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if self.region is None:
            return boundary_distance(self.surface, uv)
        import shapely
        dom = self.surface.domain
        size = dom[:, 1] - dom[:, 0]
        if "_ring" not in self.__dict__:
            self._ring = shapely.LinearRing((self._loops[0] - dom[:, 0]) / size)
            shapely.prepare(self._ring)
        q = (uv - dom[:, 0]) / size
        return shapely.distance(self._ring, shapely.points(q))

    def edge_chord(self, uv: np.ndarray) -> np.ndarray:
        """(k,) distance on the surface (the chord) from parameter points to the region's edge:
        to the nearest, in the domain's fractions, of the points on its loops (holes too), or of
        the point's four projections onto the domain's sides. Near the edge (the use: a node
        within a fraction of a spacing) the chord is the distance along the surface; farther
        from it, or where the chart is far from conformal, it may only be more."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if len(uv) == 0:
            return np.zeros(0)
        dom = self.surface.domain
        if self.region is None:
            near = np.repeat(uv[None], 4, axis=0)
            near[0, :, 0], near[1, :, 0] = dom[0, 0], dom[0, 1]
            near[2, :, 1], near[3, :, 1] = dom[1, 0], dom[1, 1]
        else:
            import shapely
            size = dom[:, 1] - dom[:, 0]
            if "_rings" not in self.__dict__:
                self._rings = [shapely.LinearRing((p - dom[:, 0]) / size) for p in self._loops]
            pts = shapely.points((uv - dom[:, 0]) / size)
            near = np.empty((len(self._rings), len(uv), 2))
            for k, ring in enumerate(self._rings):
                at = shapely.line_interpolate_point(ring, shapely.line_locate_point(ring, pts))
                near[k] = shapely.get_coordinates(at) * size + dom[:, 0]
        p = self.surface.points(np.concatenate([uv, near.reshape(-1, 2)]))
        k = len(uv)
        return np.linalg.norm(p[k:].reshape(-1, k, 3) - p[None, :k], axis=2).min(axis=0)

    def clip_curve(self, uv: np.ndarray) -> np.ndarray:
        """The longest run of a (u, v) polyline inside the region, each end
        where it was cut moved onto the region's edge (bisection on the
        segment that crosses it); the polyline itself for the whole domain."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if self.region is None or len(uv) < 2:
            return uv
        inside = self.contains(uv)
        if inside.all() or not inside.any():
            return uv if inside.all() else uv[:0]
        edges = np.flatnonzero(np.diff(np.r_[0, inside.astype(np.int8), 0]))
        runs = edges.reshape(-1, 2)  # [start, stop) of each inside run
        a, b = runs[np.argmax(runs[:, 1] - runs[:, 0])]
        out = [uv[a:b]]

        def crossing(p_in, p_out):
            lo, hi = 0.0, 1.0  # fractions from p_in towards p_out: lo inside, hi outside
            for _ in range(52):
                mid = 0.5 * (lo + hi)
                if self.contains((p_in + mid * (p_out - p_in))[None])[0]:
                    lo = mid
                else:
                    hi = mid
            return p_in + lo * (p_out - p_in)

        if a > 0:
            out.insert(0, crossing(uv[a], uv[a - 1])[None])
        if b < len(uv):
            out.append(crossing(uv[b - 1], uv[b])[None])
        return np.vstack(out)

    def seed_uv(self, seed) -> np.ndarray:
        dom = self.surface.domain
        return dom[:, 0] + np.asarray(seed, dtype=float) * (dom[:, 1] - dom[:, 0])

    @functools.cached_property
    def default_seed(self) -> tuple[float, float]:
        """The seed (fractions of the domain): the region's point farthest from its boundary."""
        if self.region is None:
            return (0.5, 0.5)
        import shapely
        from shapely.ops import polylabel
        dom = self.surface.domain
        size = dom[:, 1] - dom[:, 0]
        g = np.linspace(0.0, 1.0, 9)
        uv = np.column_stack([a.ravel() for a in np.meshgrid(dom[0, 0] + g * size[0], dom[1, 0] + g * size[1])])
        _, su, sv = self.surface.derivatives(uv)
        scale = np.array([np.nanmean(np.linalg.norm(su, axis=1)), np.nanmean(np.linalg.norm(sv, axis=1))])
        scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0 / size)
        poly = region_polygon([(p - dom[:, 0]) * scale for p in self._loops])
        parts = [poly] if poly.geom_type == "Polygon" else list(shapely.get_parts(poly))
        parts = [q for q in parts if q.geom_type == "Polygon"]
        big = max(parts, key=lambda q: q.area)
        c = polylabel(big, tolerance=1e-4 * max(math.sqrt(big.area), 1e-300))
        uv0 = np.array([c.x, c.y]) / scale + dom[:, 0]
        f = (uv0 - dom[:, 0]) / size
        return (float(np.clip(f[0], 0, 1)), float(np.clip(f[1], 0, 1)))

    # -- coverage
    def coverage_grid(self, reach: float):
        """:func:`flatweave.geometry.coverage.coverage_grid` of the surface, restricted to the
        region (samples outside weigh nothing and never count as uncovered)."""
        grid = coverage_grid(self.surface, reach)
        if self.region is None:
            return grid
        key = float(f"{float(reach):.12g}")
        hit = self._grids.get(key)
        if hit is None or hit[0] is not grid:
            from dataclasses import replace
            inside = self.contains(grid.uv)
            hit = self._grids[key] = (grid, replace(grid, area=np.where(inside, grid.area, 0.0), inside=inside))
        return hit[1]


_covers: "weakref.WeakKeyDictionary[NurbsSurface, dict]" = weakref.WeakKeyDictionary()


def cover_for(surface: NurbsSurface, region: Region | None = None) -> Cover:
    """The shared :class:`Cover` of ``surface`` and ``region`` (made once,
    kept while the surface lives; a few regions per surface)."""
    per = _covers.setdefault(surface, {})
    hit = per.get(region)
    if hit is None:
        if len(per) >= 8:
            per.clear()
        hit = per[region] = Cover(surface, region)
    return hit


# ---------------------------------------------------------------------- drawn regions
MIN_CELLS = 6
"""A region must hold at least this many mesh cells (spacing_weft x spacing_warp) of area."""

_FAN_DEG = 2.0      # angle between the geodesics of an offset's rounded corner
_OFFSET_PIECE = 1.0 / 512.0  # longest loop segment an offset starts from, as a fraction of the domain
_FORMS = ("points", "uv", "outer")


def _floats_rows(value, width: int, what: str) -> tuple:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or a.ndim != 2 or a.shape[1] != width:
        kind = "[x, y, z]" if width == 3 else "[s, t]" if width == 2 else "values"
        raise SettingsError(f"{what} must be a list of {kind} points")
    if not np.isfinite(a).all():
        raise SettingsError(f"{what} has a non-finite coordinate")
    if width == 3 and len(a) < 3:  # (u, v) loops: Region.from_loops says what is wrong
        raise SettingsError(f"{what} needs at least 3 points, got {len(a)}")
    return tuple(tuple(float(x) for x in r) for r in a)


@dataclass(frozen=True)
class RegionDrawing:
    """How a region was drawn, kept so a project can show and edit it.

    form : "points" (points in space projected along ``view_direction``, the
        loop between them following the surface as a curve dart's does),
        "uv" (polygons in fractions of the domain) or "outer" (polygons in
        domain coordinates)
    outer, holes : the outer loop's points and each hole's (tuples of tuples)
    view_direction : (3,) unit direction the points were projected along
        (form "points"), else None
    offset : distance the boundary was moved on the surface (positive
        outwards), model units
    tolerance : biarc tolerance in parameter units (form "points"), or None
        (1e-5 of the domain)
    """

    form: str
    outer: tuple
    holes: tuple = ()
    view_direction: tuple | None = None
    offset: float = 0.0
    tolerance: float | None = None

    def to_dict(self) -> dict:
        """The drawing in the ``--region`` file's form (a valid spec for :func:`region_from_spec`)."""
        key = {"points": "points", "uv": "uv", "outer": "outer"}[self.form]
        out: dict = {key: [list(p) for p in self.outer]}
        if self.view_direction is not None:
            out["view_direction"] = list(self.view_direction)
        if self.holes:
            out["holes"] = [[list(p) for p in h] for h in self.holes]
        if self.offset:
            out["offset"] = self.offset
        if self.tolerance is not None:
            out["tolerance"] = self.tolerance
        return out

    @classmethod
    def from_dict(cls, d) -> "RegionDrawing":
        """A drawing from a ``--region`` spec: ``{"points": [[x, y, z], ...], "view_direction":
        [dx, dy, dz]}``, ``{"uv": [[s, t], ...]}`` (fractions of the domain) or ``{"outer": [[u, v],
        ...]}``, each with optional ``"holes"`` (a list of loops in the same form) and ``"offset"``."""
        if not isinstance(d, dict):
            raise SettingsError(f"a region must be a JSON object, got {type(d).__name__}")
        forms = [f for f in _FORMS if f in d]
        if len(forms) != 1:
            raise SettingsError("a region needs exactly one of 'points' (with 'view_direction'), "
                                "'uv' (fractions of the domain) or 'outer' (domain coordinates)")
        form = forms[0]
        width = 3 if form == "points" else 2
        outer = _floats_rows(d[form], width, "the region's outer loop")
        holes = d.get("holes", [])
        if not isinstance(holes, list):
            raise SettingsError("a region's holes must be a list of loops")
        holes = tuple(_floats_rows(h, width, f"hole {k + 1} of the region") for k, h in enumerate(holes))
        view = None
        if form == "points":
            v = d.get("view_direction")
            try:
                v = np.asarray(v, dtype=float).reshape(-1) if v is not None else None
            except (TypeError, ValueError):
                v = None
            if v is None or v.shape != (3,) or not np.isfinite(v).all() or not np.linalg.norm(v) > 0:
                raise SettingsError("a drawn region needs 'view_direction': a non-zero [dx, dy, dz]")
            view = tuple(float(x) for x in v / np.linalg.norm(v))
        elif "view_direction" in d:
            raise SettingsError(f"'view_direction' is for a region of 'points', not of '{form}'")
        offset = d.get("offset", 0.0)
        if isinstance(offset, bool) or not isinstance(offset, (int, float)) or not math.isfinite(offset):
            raise SettingsError(f"a region's offset must be a number, got {offset!r:.40}")
        tol = d.get("tolerance")
        if tol is not None and (isinstance(tol, bool) or not isinstance(tol, (int, float)) or not tol > 0
                                or not math.isfinite(tol)):
            raise SettingsError(f"a region's tolerance must be a positive number, got {tol!r:.40}")
        return cls(form, outer, holes, view, float(offset), None if tol is None else float(tol))


def _loop_name(k: int) -> str:
    return "outer loop" if k == 0 else f"hole {k}"


def _drawn_loop(surface: NurbsSurface, pts: np.ndarray, view: np.ndarray, tol: float, what: str):
    """(uv (n, 2), corner indices) of a loop through points projected along ``view``: per side the
    projection of the straight segment between two drawn points, fitted by biarcs in (u, v) within
    ``tol`` (as a curve dart's curve), the drawn points' projections its corners."""

    pr = project_points(surface, pts, view)
    if not pr.hit.all():
        k = int(np.flatnonzero(~pr.hit)[0]) + 1
        raise SettingsError(f"point {k} of the region's {what} misses the surface along the view direction")
    closed = np.vstack([pts, pts[:1]])
    curve = project_polyline(surface, closed, view)
    if curve.clipped or not curve.complete:
        raise SettingsError(f"the region's {what} leaves the surface between its points "
                            "(seen along the view direction)")
    dom = surface.domain
    size = float(np.max(dom[:, 1] - dom[:, 0]))
    parts, corners, n = [], [], 0
    k = len(pts)
    for i in range(k):
        inner = (curve.source_param > i) & (curve.source_param < i + 1)
        side = np.vstack([pr.uv[i], curve.uv[inner], pr.uv[(i + 1) % k]])
        if np.max(np.abs(side[-1] - side[0])) <= 1e-12 * size and len(side) <= 2:
            raise SettingsError(f"points {i + 1} and {(i + 1) % k + 1} of the region's {what} "
                                "land on one place of the surface")
        uv = fit_biarcs(side, tol).sample(size / 1000)
        uv[0], uv[-1] = side[0], side[-1]
        corners.append(n)
        parts.append(uv[:-1])
        n += len(uv) - 1
    return np.clip(np.vstack(parts), dom[:, 0], dom[:, 1]), corners


def check_region(surface: NurbsSurface, region: Region) -> None:
    """SettingsError (one line) unless every loop is simple and inside the domain, and every hole
    lies inside the outer loop without touching it or another hole."""
    import shapely

    dom = surface.domain
    size = dom[:, 1] - dom[:, 0]
    loops = region.arrays()
    for k, p in enumerate(loops):
        if np.any(p < dom[:, 0] - 1e-9 * size) or np.any(p > dom[:, 1] + 1e-9 * size):
            raise SettingsError(f"the region's {_loop_name(k)} leaves the surface's domain")
        if not shapely.LinearRing(p).is_simple:
            raise SettingsError(f"the region's {_loop_name(k)} crosses itself")
    polys = [shapely.Polygon(p) for p in loops]
    for k in range(1, len(polys)):
        if not polys[0].contains(polys[k]):
            where = "crosses or touches" if polys[0].intersects(polys[k]) else "lies outside"
            raise SettingsError(f"hole {k} of the region {where} the outer loop")
        for j in range(1, k):
            if polys[j].intersects(polys[k]):
                raise SettingsError(f"holes {j} and {k} of the region overlap")


def check_region_size(surface: NurbsSurface, region: Region | None, spacing: float,
                      spacing_warp: float | None = None) -> None:
    """SettingsError unless the region holds :data:`MIN_CELLS` cells of the mesh at the spacing."""
    if region is None:
        return
    cell = float(spacing) * float(spacing_warp if spacing_warp is not None else spacing)
    area = cover_for(surface, region).area
    if not area >= MIN_CELLS * cell:
        raise SettingsError(f"the region's area {area:.4g} is under {MIN_CELLS} cells at spacing {spacing:g} "
                            f"({MIN_CELLS * cell:.4g}); draw it larger or choose a smaller spacing")


def region_from_drawing(surface: NurbsSurface, drawing: RegionDrawing) -> Region:
    """The :class:`Region` of a drawing (remembering it): its loops on the surface, checked
    (:func:`check_region`), then offset by ``drawing.offset`` (:func:`offset_region`)."""
    dom = surface.domain
    size = dom[:, 1] - dom[:, 0]
    raw = [drawing.outer, *drawing.holes]
    loops, corners = [], []
    for k, pts in enumerate(raw):
        p = np.asarray(pts, dtype=float)
        what = _loop_name(k)
        if drawing.form == "points":
            tol = drawing.tolerance if drawing.tolerance is not None else 1e-5 * float(np.max(size))
            uv, c = _drawn_loop(surface, p, np.asarray(drawing.view_direction), tol, what)
        else:
            if drawing.form == "uv":
                bad = np.flatnonzero(np.any((p < -1e-12) | (p > 1 + 1e-12), axis=1))
                if len(bad):
                    raise SettingsError(f"point {int(bad[0]) + 1} of the region's {what} lies outside the surface "
                                        f"(fractions of the domain run from 0 to 1)")
                p = dom[:, 0] + np.clip(p, 0.0, 1.0) * size
            uv, c = p, None
        loops.append(uv)
        corners.append(c)
    # the loops' senses are fixed by from_loops; corners given for the drawn points only
    region = Region.from_loops(loops[0], loops[1:], corners=corners if drawing.form == "points" else None)
    check_region(surface, region)
    from dataclasses import replace
    if drawing.offset:
        region = offset_region(surface, region, drawing.offset)
    return replace(region, drawn=drawing)


def region_from_spec(surface: NurbsSurface, spec, offset: float | None = None) -> Region:
    """The region of a ``--region`` file's JSON (:meth:`RegionDrawing.from_dict`'s forms, or
    :meth:`Region.to_dict`'s ``loops``), its boundary moved by ``offset`` on the surface (model
    units, positive outwards; added to the spec's own ``offset``). The one entry point of the
    CLI and the app's region tool."""
    if isinstance(spec, dict) and "loops" in spec:
        region = Region.from_dict(spec)
        check_region(surface, region)
        if region.drawn is not None and offset is None:
            return region
        base = region.drawn.offset if region.drawn is not None else 0.0
        return region if not offset else offset_region(surface, region, float(offset), base)
    drawing = RegionDrawing.from_dict(spec)
    if offset:
        from dataclasses import replace
        drawing = replace(drawing, offset=drawing.offset + float(offset))
    return region_from_drawing(surface, drawing)


# -- offsets along the surface
def _geodesics(surface: NurbsSurface, uv: np.ndarray, vel: np.ndarray, length: float, steps: int) -> np.ndarray:
    """(n, 2) end points of the geodesics from ``uv`` with unit (in the surface's metric) (u, v)
    velocities ``vel``, after arc length ``length``: RK4 on u''^k = -g^{kl} S_l . S_ij u'^i u'^j."""
    dom = surface.domain

    def accel(x, w):
        x = np.clip(x, dom[:, 0], dom[:, 1])
        ev = surface.evaluate(x, second=True, normals=False)
        su, sv = ev.su, ev.sv
        E, F, G = np.einsum("ij,ij->i", su, su), np.einsum("ij,ij->i", su, sv), np.einsum("ij,ij->i", sv, sv)
        a = (ev.suu * (w[:, :1] ** 2) + 2 * ev.suv * (w[:, :1] * w[:, 1:]) + ev.svv * (w[:, 1:] ** 2))
        b0, b1 = np.einsum("ij,ij->i", su, a), np.einsum("ij,ij->i", sv, a)
        det = E * G - F * F
        ok = det > 1e-300
        det = np.where(ok, det, 1.0)
        return np.where(ok[:, None], -np.column_stack([(G * b0 - F * b1) / det, (E * b1 - F * b0) / det]), 0.0)

    h = length / steps
    x, w = uv.copy(), vel.copy()
    live = np.ones(len(x), dtype=bool)  # a geodesic that leaves the domain stops on its edge
    for _ in range(steps):
        if not live.any():
            break
        xs, ws = x[live], w[live]
        with np.errstate(all="ignore"):
            k1x, k1w = ws, accel(xs, ws)
            k2x, k2w = ws + 0.5 * h * k1w, accel(xs + 0.5 * h * k1x, ws + 0.5 * h * k1w)
            k3x, k3w = ws + 0.5 * h * k2w, accel(xs + 0.5 * h * k2x, ws + 0.5 * h * k2w)
            k4x, k4w = ws + h * k3w, accel(xs + h * k3x, ws + h * k3w)
            xn = xs + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
            wn = ws + h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w)
        ok = np.isfinite(xn).all(axis=1) & np.isfinite(wn).all(axis=1)
        out = ~ok | np.any((xn < dom[:, 0]) | (xn > dom[:, 1]), axis=1)
        xn = np.where(ok[:, None], np.clip(xn, dom[:, 0], dom[:, 1]), xs)
        idx = np.flatnonzero(live)
        x[idx], w[idx] = xn, np.where(ok[:, None], wn, ws)
        live[idx[out]] = False
    return x


def _winding(points: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """(m,) winding number of the closed polyline ``ring`` around each point."""
    out = np.zeros(len(points))
    for k in range(0, len(points), 64):
        p = points[k:k + 64, None, :]
        a = ring[None] - p
        b = np.roll(ring, -1, axis=0)[None] - p
        cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
        dot = np.einsum("mnk,mnk->mn", a, b)
        out[k:k + 64] = np.arctan2(cross, dot).sum(axis=1) / (2 * np.pi)
    return np.rint(out)


def _offset_filled(surface: NurbsSurface, loop: np.ndarray, e: float, steps: int):
    """The region of the counter-clockwise ``loop`` grown by ``e`` (shrunk if negative) on the
    surface: every segment's points moved along the surface normal to it by geodesics of length
    |e|, fans of geodesics round the vertices; the raw ring's part of winding number >= 1 (the
    true offset: swallowtails and loops of a crossing ring cancel)."""
    import shapely

    dom = surface.domain
    size = dom[:, 1] - dom[:, 0]
    q = np.roll(loop, -1, axis=0)
    m = np.maximum(1, np.ceil(np.max(np.abs(q - loop) / size, axis=1) / _OFFSET_PIECE).astype(int))
    seg = np.repeat(np.arange(len(loop)), m)
    t = (np.arange(len(seg)) - np.repeat(np.cumsum(m) - m, m)) / m[seg]
    P = loop[seg] + t[:, None] * (q[seg] - loop[seg])
    d_out = np.roll(P, -1, axis=0) - P
    d_in = P - np.roll(P, 1, axis=0)
    ev = surface.evaluate(P, normals=False)
    su, sv = ev.su, ev.sv
    N = np.cross(su, sv)
    N /= np.maximum(np.linalg.norm(N, axis=1), 1e-300)[:, None]

    def unit(v):
        return v / np.maximum(np.linalg.norm(v, axis=1), 1e-300)[:, None]

    T_in = unit(su * d_in[:, :1] + sv * d_in[:, 1:])
    T_out = unit(su * d_out[:, :1] + sv * d_out[:, 1:])
    n_in = unit(np.cross(T_in, N))
    turn = np.arctan2(np.einsum("ij,ij->i", N, np.cross(T_in, T_out)), np.einsum("ij,ij->i", T_in, T_out))
    nf = np.maximum(1, np.ceil(np.abs(turn) / math.radians(_FAN_DEG)).astype(int))
    idx = np.repeat(np.arange(len(P)), nf + 1)
    j = np.arange(len(idx)) - np.repeat(np.cumsum(nf + 1) - (nf + 1), nf + 1)
    phi = turn[idx] * j / nf[idx]
    n3 = np.cos(phi)[:, None] * n_in[idx] + np.sin(phi)[:, None] * np.cross(N[idx], n_in[idx])
    # the (u, v) velocity of the 3D tangent direction n3: g^{-1} [S_u . n, S_v . n]
    a, b = np.einsum("ij,ij->i", su[idx], n3), np.einsum("ij,ij->i", sv[idx], n3)
    E = np.einsum("ij,ij->i", su, su)[idx]
    F = np.einsum("ij,ij->i", su, sv)[idx]
    G = np.einsum("ij,ij->i", sv, sv)[idx]
    det = np.maximum(E * G - F * F, 1e-300)
    vel = np.column_stack([(G * a - F * b) / det, (E * b - F * a) / det]) * math.copysign(1.0, e)
    ring = np.clip(_geodesics(surface, P[idx], vel, abs(e), steps), dom[:, 0], dom[:, 1])
    keep = np.r_[True, np.any(np.abs(np.diff(ring, axis=0)) > 1e-14 * size, axis=1)]
    ring = ring[keep]
    lines = shapely.union_all(shapely.LineString(np.vstack([ring, ring[:1]])))  # noded at every crossing
    faces = np.asarray(shapely.get_parts(shapely.polygonize(shapely.get_parts(lines))))
    if len(faces) == 0:
        return shapely.Polygon()
    probe = np.array([[f.representative_point().x, f.representative_point().y] for f in faces])
    keep = _winding(probe, ring) >= 1
    if e < 0 and keep.any():
        # an offset inwards past the loop's own width turns the ring inside out, and its fans can
        # enclose faces of winding 1 again: those lie nearer the loop than |e| (chords are shorter
        # than geodesics, so 0.9 |e| keeps every true face short of very strong curvature)
        from scipy.spatial import cKDTree
        near, _ = cKDTree(surface.points(P)).query(surface.points(probe[keep]))
        keep[np.flatnonzero(keep)[near < 0.9 * abs(e)]] = False
    return shapely.union_all(faces[keep])


def offset_region(surface: NurbsSurface, region: Region | None, distance: float, base: float = 0.0) -> Region:
    """``region`` (None: the whole domain) with its boundary moved by ``distance`` along the surface
    (model units; positive outwards, negative inwards), clipped to the domain: the outer loop grown
    and the holes shrunk by ``distance`` (:func:`_offset_filled`). The result remembers the drawing
    with its offset (``base`` + ``distance``). One-line SettingsError when the offset leaves nothing
    or splits the region."""
    import shapely

    d = float(distance)
    size = surface.bbox_diagonal()
    if not math.isfinite(d) or abs(d) > size:  # beyond the surface's size: nothing left, or all of it
        raise SettingsError(f"the region offset must be a distance from {-size:.4g} to {size:.4g} (the surface's "
                            f"size), got {distance!r:.30}")
    dom = surface.domain
    box = shapely.box(dom[0, 0], dom[1, 0], dom[0, 1], dom[1, 1])
    if region is None:
        loops = [np.array([[dom[0, 0], dom[1, 0]], [dom[0, 1], dom[1, 0]], [dom[0, 1], dom[1, 1]],
                           [dom[0, 0], dom[1, 1]]], dtype=float)]
    else:
        loops = region.arrays()
    if d == 0.0:
        return region
    steps = int(max(4, math.ceil(abs(d) / (tessellation(surface).scale / 256.0))))
    try:
        grown = _offset_filled(surface, loops[0], d, steps).intersection(box)
        holes = [_offset_filled(surface, h[::-1], -d, steps) for h in loops[1:]]
        if holes:
            grown = grown.difference(shapely.union_all(holes))
    except shapely.errors.GEOSException as exc:  # a degenerate ring: say so in one line
        raise SettingsError(f"an offset of {d:g} cannot be formed on this region ({exc})") from None
    parts = [g for g in shapely.get_parts(grown) if g.geom_type == "Polygon" and g.area > 0]
    if not parts:
        raise SettingsError(f"an offset of {d:g} leaves nothing of the region")
    if len(parts) > 1:
        raise SettingsError(f"an offset of {d:g} splits the region into {len(parts)} pieces")
    poly = shapely.geometry.polygon.orient(parts[0], 1.0)
    out = Region.from_loops(np.asarray(poly.exterior.coords), [np.asarray(r.coords) for r in poly.interiors])
    drawn = region.drawn if region is not None else None
    from dataclasses import replace
    if drawn is not None:
        out = replace(out, drawn=replace(drawn, offset=base + d) if base + d != drawn.offset else drawn)
    return out


LOOP_CHORD_TOL = 1e-4
"""Largest distance of a chord of a region's loop on the surface from the loop's image there,
relative to the loops' size on the surface (the diagonal of their bounding box):
:func:`loops_on_surface`'s default."""

_LOOP_PIECES = 64  # a loop segment starts cut into pieces of at most 1/64 of the domain (and half the mean knot span)
_LOOP_ROUNDS = 40  # halvings of a piece at most (2^-40 of its start)


def _segment_sq_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) squared distance of points p (n, 3) to the segments a -> b (n, 3) each."""
    ab, ap = b - a, p - a
    t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    r = ap - t[:, None] * ab
    return np.einsum("ij,ij->i", r, r)


def loops_on_surface(surface: NurbsSurface, region: Region,
                     rel_tol: float = LOOP_CHORD_TOL) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per loop of ``region`` (outer first): ``(uv (k, 2), xyz (k, 3))``, the loop sampled along
    its image on the surface, closed implicitly. ``uv`` is the loop's own polyline (clipped to the
    domain) with points added on its segments, its own points among them in order, so it bounds the
    same region; ``xyz = surface.points(uv)``. A segment is halved until the image of the middle of
    every piece lies within ``rel_tol`` times the diagonal of the loops' bounding box on the surface
    of the chord between the images of the piece's ends (pieces start at most 1/64 of the domain
    and half the mean knot span long, so a bend between two checks is not missed).

    A loop's own points alone draw a straight (u, v) segment, such as a CAD trim edge whose curve
    on the face is a line, as one chord through the surface; its image is the edge's 3D curve."""
    dom = surface.domain
    size = dom[:, 1] - dom[:, 0]
    loops = [np.clip(p, dom[:, 0], dom[:, 1]) for p in region.arrays()]
    start = np.vstack(loops)
    delta = np.vstack([np.roll(p, -1, axis=0) - p for p in loops])
    which = np.repeat(np.arange(len(loops)), [len(p) for p in loops])
    spans = np.array([np.count_nonzero(np.diff(np.unique(k[(k >= lo) & (k <= hi)])))
                      for k, (lo, hi) in ((surface.knots_u, dom[0]), (surface.knots_v, dom[1]))])
    step = size / np.maximum(_LOOP_PIECES, 2 * spans)
    m = np.maximum(1, np.ceil(np.max(np.abs(delta) / np.maximum(step, 1e-300), axis=1))).astype(np.int64)
    seg = np.repeat(np.arange(len(start)), m)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(m) - m, m)
    ta, tb = k / m[seg], (k + 1) / m[seg]
    xa = surface.points(start[seg] + ta[:, None] * delta[seg])
    xb = np.roll(xa, -1, axis=0)  # a segment's last piece ends where the next one starts
    last = np.cumsum(m) - 1
    xb[last] = surface.points(start[seg[last]] + delta[seg[last]])
    tol = rel_tol * float(np.linalg.norm(np.ptp(xa, axis=0)))
    active = np.arange(len(seg))
    for _ in range(_LOOP_ROUNDS):
        if not active.size or not tol > 0:
            break
        s = seg[active]
        tm = 0.5 * (ta[active] + tb[active])
        xm = surface.points(start[s] + tm[:, None] * delta[s])
        split = _segment_sq_distance(xm, xa[active], xb[active]) > tol * tol
        idx, tm, xm = active[split], tm[split], xm[split]
        n = len(seg)  # the second halves go to the end; the order is restored once, below
        seg, ta, tb = np.r_[seg, seg[idx]], np.r_[ta, tm], np.r_[tb, tb[idx]]
        xa, xb = np.vstack([xa, xm]), np.vstack([xb, xb[idx]])
        tb[idx], xb[idx] = tm, xm
        active = np.r_[idx, n + np.arange(len(idx))]
    order = np.lexsort((ta, seg))
    seg, ta = seg[order], ta[order]
    uv = start[seg] + ta[:, None] * delta[seg]
    xyz = xa[order]
    cut = np.flatnonzero(np.diff(which[seg])) + 1
    return list(zip(np.split(uv, cut), np.split(xyz, cut)))


def region_record(surface: NurbsSurface, region: Region) -> dict:
    """The region in a result file: ``loops_uv`` and ``loops_xyz``, per loop (outer first) the
    loop sampled along the surface (:func:`loops_on_surface`; parallel lists, the loop's own
    points among them), and its drawn form."""
    loops = loops_on_surface(surface, region)
    return {"loops_uv": [uv.tolist() for uv, _ in loops],
            "loops_xyz": [xyz.tolist() for _, xyz in loops],
            "drawn": region.drawn.to_dict() if region.drawn is not None else None}


def with_offset(surface: NurbsSurface, region: Region, distance: float, spacing: float,
                spacing_warp: float | None = None, seed=None) -> tuple[Region, tuple[float, float]]:
    """(region, seed) of a drawn ``region`` re-made with its boundary offset by ``distance``
    in all (model units along the surface, positive outwards; replacing the drawing's own
    offset, not added to it), checked as a drawn region is (:func:`check_region_size` at the
    spacing); ``seed`` kept when it lies inside the new region, else its default seed. One-line
    SettingsError when the region was not drawn or the offset cannot be made."""
    from dataclasses import replace

    if region is None or region.drawn is None:
        raise SettingsError("only a drawn region (the region tool, or --region) can be offset")
    d = float(distance)
    if not math.isfinite(d):
        raise SettingsError(f"the region offset must be a finite distance, got {distance!r}")
    new = region_from_drawing(surface, replace(region.drawn, offset=d))
    check_region_size(surface, new, spacing, spacing_warp)
    cover = cover_for(surface, new)
    if seed is not None and cover.contains(cover.seed_uv(seed)[None])[0]:
        return new, tuple(seed)
    return new, cover.default_seed
