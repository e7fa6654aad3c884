"""Small vectorised numerics the core modules share.

Row-wise products and unit vectors, distances to polylines, arc length and
resampling along a polyline, the finiteness check of results and its
one-line message, and the boundary and area errors of a pattern's outline.
Each exists once here so that the solver, the pipeline, the darts and the
planar method compute them the same way, to the last bit.
"""

from __future__ import annotations

import math

import numpy as np

from flatweave.errors import SolverError

__all__ = ["rowdot", "unit_rows", "polyline_sq_distances", "polyline_distance", "nearest_segment", "nearest_segments",
           "cumulative_length", "interp_rows", "resample_at_lengths", "nonfinite_rows", "nan_word",
           "require_finite", "outline_errors", "solve2"]


def rowdot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dot products along the last axis of (..., d) arrays, summed component
    by component from the first (for d = 3 the arithmetic of
    ``x0 y0 + x1 y1 + x2 y2``; faster than ``einsum`` on short rows)."""
    out = x[..., 0] * y[..., 0]
    for c in range(1, x.shape[-1]):
        out = out + x[..., c] * y[..., c]
    return out


def unit_rows(v: np.ndarray) -> np.ndarray:
    """Rows of v (n, k) scaled to unit length (zero rows stay zero)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def solve2(J: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve J d = -F for stacks of 2x2 systems; returns (d (k, 2), ok (k,))."""
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    det = a * d - b * c
    scale = np.abs(a * d) + np.abs(b * c) + 1e-300
    ok = np.abs(det) > 1e-14 * scale
    det = np.where(ok, det, 1.0)
    du = -(d * F[:, 0] - b * F[:, 1]) / det
    dv = -(-c * F[:, 0] + a * F[:, 1]) / det
    return np.column_stack([du, dv]), ok


def _seg_sq_distances(p, a, ab, abab):
    """Squared distances of points p to segments a -> a + ab (abab = |ab|^2),
    broadcast, component by component (one arithmetic for the brute force and
    the candidates of :func:`nearest_segments`, so both give the same bits)."""
    d = p - a
    t = np.clip(rowdot(d, ab) / np.maximum(abab, 1e-300), 0, 1)
    r = d - t[..., None] * ab
    return rowdot(r, r)


def polyline_sq_distances(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n, k - 1) squared distances of points p (n, d) to each segment of the
    polyline ``line`` (k, d) (the foot clamped to the segment; a segment of
    zero length is its first point)."""
    a = line[:-1]
    ab = line[1:] - a
    return _seg_sq_distances(p[:, None, :], a[None], ab[None], rowdot(ab, ab)[None])


def nearest_segments(p: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index, squared distance), both (n,): the segment of ``line`` (k, d)
    nearest to each point of p (n, d), the first of equals, as the argmin of
    :func:`polyline_sq_distances` gives it.

    Long inputs go through a k-d tree of the segments' midpoints: a point's
    few nearest midpoints give a best distance, and a segment whose midpoint
    is farther than that plus the longest half segment cannot be nearer; a
    point for which that does not rule out every segment beyond the few is
    measured against all of them.
    """
    p = np.asarray(p, dtype=float)
    line = np.asarray(line, dtype=float)
    k = len(line) - 1
    few = min(k, _FEW)
    if len(p) * k <= _BRUTE_PAIRS or few == k or not (np.all(np.isfinite(line)) and np.all(np.isfinite(p))):
        d2 = polyline_sq_distances(p, line)
        i = np.argmin(d2, axis=1)
        return i, d2[np.arange(len(p)), i]
    from scipy.spatial import cKDTree

    a = line[:-1]
    ab = line[1:] - a
    abab = rowdot(ab, ab)
    half = 0.5 * float(np.sqrt(abab.max()))
    dist, cand = cKDTree(a + 0.5 * ab).query(p, k=few)
    cand = np.sort(cand, axis=1)  # the first of equals is the lowest index, as argmin's
    d2 = _seg_sq_distances(p[:, None, :], a[cand], ab[cand], abab[cand])
    j = np.argmin(d2, axis=1)
    rows = np.arange(len(p))
    i, best = cand[rows, j], d2[rows, j]
    # every segment beyond the few has its midpoint at least dist[:, -1] away
    margin = 1e-9 * (np.sqrt(best) + half) + 1e-300
    unsure = np.flatnonzero(~(dist[:, -1] - half > np.sqrt(best) + margin))
    if unsure.size:
        d2 = polyline_sq_distances(p[unsure], line)
        ju = np.argmin(d2, axis=1)
        i[unsure], best[unsure] = ju, d2[np.arange(unsure.size), ju]
    return i, best


_FEW = 12
_BRUTE_PAIRS = 50_000


def polyline_distance(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n,) distance of points p (n, d) to the polyline ``line`` (k, d)."""
    return np.sqrt(nearest_segments(p, line)[1])


def nearest_segment(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n,) index of the segment of ``line`` nearest to each point of p."""
    return nearest_segments(p, line)[0]


def cumulative_length(P: np.ndarray) -> np.ndarray:
    """(k,) arc length along the polyline P (k, d) at its points, from 0."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])


def interp_rows(at: np.ndarray, s: np.ndarray, values: np.ndarray) -> np.ndarray:
    """(m, c) values (k, c), given at increasing positions s (k,), linearly
    interpolated at positions ``at`` (m,), column by column."""
    return np.column_stack([np.interp(at, s, values[:, c]) for c in range(values.shape[1])])


def resample_at_lengths(P: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``values`` (k, c) attached to the polyline P (k, d), at arc lengths ``at``."""
    return interp_rows(at, cumulative_length(P), values)


# ---------------------------------------------------------------------- finiteness
def nonfinite_rows(arr) -> np.ndarray:
    """(n,) bool: rows of ``arr`` (n, ...) holding a NaN or an infinity."""
    arr = np.asarray(arr, dtype=float)
    if not arr.size:
        return np.zeros(len(arr), dtype=bool)
    return ~np.isfinite(arr.reshape(len(arr), -1)).all(axis=1)


def nan_word(x) -> str:
    """'NaN' if any of ``x`` is NaN, else 'infinite'."""
    return "NaN" if np.isnan(np.asarray(x, dtype=float)).any() else "infinite"


def require_finite(what: str, arr, unit: str, when: str = "", state: str | None = None) -> None:
    """SolverError unless every row of ``arr`` is finite, in one line:
    "{what} is NaN at 3 of 1,200 {unit}{when}; the solve stopped and nothing
    was changed" (``state`` replaces "is NaN" / "are infinite")."""
    bad = nonfinite_rows(arr)
    if bad.any():
        n = int(bad.sum())
        state = state if state is not None else f"{'is' if n == 1 else 'are'} {nan_word(arr)}"
        raise SolverError(f"{what} {state} at {n:,} of {len(bad):,} {unit}{when}; "
                          f"the solve stopped and nothing was changed")


# ---------------------------------------------------------------------- outline errors
def outline_errors(L2: float, L3: float, A2: float, A3: float) -> dict:
    """Boundary and area errors of a pattern (paper Table 3):
    boundary_error_pct = 100 |L2 - L3| / L3 with L3 the boundary length on the
    surface and L2 the outline's perimeter; area_error_pct likewise with A3
    the region's area and A2 the area inside the outline; the signed values
    (``*_signed_pct``) and the four lengths and areas."""
    return {"boundary_error_pct": 100 * abs(L2 - L3) / L3,
            "area_error_pct": 100 * abs(A2 - A3) / A3,
            "boundary_error_signed_pct": 100 * (L2 - L3) / L3,
            "area_error_signed_pct": 100 * (A2 - A3) / A3,
            "boundary_length_3d": L3, "boundary_length_2d": L2, "area_3d": A3, "area_2d": A2}


def polygon_area(poly: np.ndarray) -> float:
    """Signed area of a closed polygon (k, 2) (shoelace; positive if counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def rotate(points, deg: float) -> np.ndarray:
    """(k, 2) ``points`` turned ``deg`` degrees counter-clockwise about the origin."""
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]])
