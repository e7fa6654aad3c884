"""The piece to cover: a NURBS patch and a region of its (u, v) domain.

A :class:`Region` is plain data: an outer loop and any number of holes,
closed polylines in (u, v) (the last point joins the first), and per loop
the indices of its corners (where the edges of a CAD face meet; found by the
turning angle when not given). It is part of the
:class:`~core.pipeline.FlattenSettings` (``settings.region``; None is the
whole domain), so project files, result files, undo and "is the result
current" see it like any other setting.

A :class:`Cover` is a surface with a region (None: the whole domain) and
owns what the stages derive from it, each computed once:

- ``area``: :func:`core.uvregion.region_area` (Green's theorem per knot cell)
  of the polygon region; the whole domain's is
  :func:`core.quadrature.region_area`, as before;
- ``boundary_length``: the length on the surface of every loop, each
  polyline segment's image integrated by Gauss-Legendre (8 nodes on pieces
  no longer than 1/64 of the domain); whole domain:
  :func:`core.quadrature.boundary_length`;
- :meth:`Cover.boundary_samples`: points even in arc length along every
  loop, corners kept (the outer loop and the holes separately), for the
  pattern's boundary approximation (paper 3.5); whole domain:
  :func:`core.pattern.boundary_samples`;
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

from core.errors import SettingsError
from core.nurbs import NurbsSurface

__all__ = ["Region", "Cover", "cover_for", "circle_loop", "region_from_cad_face", "CORNER_DEG"]

CORNER_DEG = 30.0
"""A loop vertex whose polyline turns by more than this (in (u, v)) is a
corner when a region does not list its corners."""

_PIECE = 1.0 / 64.0  # longest Gauss piece of a loop segment, as a fraction of the domain's size


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


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
    if len(p) < 3 or abs(_signed_area(p)) == 0.0:
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
    """

    loops: tuple
    corners: tuple = ()

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
            flip = (_signed_area(p) < 0) if k == 0 else (_signed_area(p) > 0)
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
        return {"loops": [[list(q) for q in p] for p in self.loops],
                "corners": [list(c) for c in self.corners] if self.corners else None}

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
        return region


def circle_loop(centre, radius, n: int = 256, hole: bool = True) -> np.ndarray:
    """(n, 2) a circle in (u, v) (clockwise for a hole, else counter-clockwise)."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    t = -t if hole else t
    return np.column_stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)])


def region_from_cad_face(face) -> Region | None:
    """The region of a :class:`core.cad.CadFace` (None for an untrimmed face:
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
            from core.quadrature import region_area
            return region_area(self.surface)
        from core.uvregion import region_area
        return float(region_area(self.surface, self._loops))

    @functools.cached_property
    def _loop_arcs(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per loop: (points (n, 2), cumulative arc length at each point and back at the start (n + 1,),
        per-segment (pieces' fine uv, their cumulative lengths)) for resampling."""
        from core.quadrature import gauss_legendre_01
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
            from core.quadrature import boundary_length
            return (boundary_length(self.surface),)
        return tuple(float(s[-1]) for _, s, _ in self._loop_arcs)

    @functools.cached_property
    def boundary_length(self) -> float:
        if self.region is None:
            from core.quadrature import boundary_length
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
        :func:`core.pattern.boundary_samples`'s."""
        if self.region is None:
            from core.pattern import boundary_samples
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
        from core.uvregion import region_polygon
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
        the domain (as :func:`core.darts._boundary_distance` for the whole domain)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        if self.region is None:
            from core.darts import _boundary_distance
            return _boundary_distance(self.surface, uv)
        import shapely
        dom = self.surface.domain
        size = dom[:, 1] - dom[:, 0]
        if "_ring" not in self.__dict__:
            self._ring = shapely.LinearRing((self._loops[0] - dom[:, 0]) / size)
            shapely.prepare(self._ring)
        q = (uv - dom[:, 0]) / size
        return shapely.distance(self._ring, shapely.points(q))

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
        from core.uvregion import region_polygon
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
        """:func:`core.coverage.coverage_grid` of the surface, restricted to the
        region (samples outside weigh nothing and never count as uncovered)."""
        from core.coverage import coverage_grid
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
