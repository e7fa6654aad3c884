"""Small vectorised numerics the core modules share.

Row-wise products and unit vectors, distances to polylines, arc length and
resampling along a polyline, the finiteness check of results and its
one-line message, and the boundary and area errors of a pattern's outline.
Each exists once here so that the solver, the pipeline, the darts and the
planar method compute them the same way, to the last bit.
"""

from __future__ import annotations

import numpy as np

from core.errors import SolverError

__all__ = ["rowdot", "unit_rows", "polyline_sq_distances", "polyline_distance", "nearest_segment",
           "cumulative_length", "interp_rows", "resample_at_lengths", "nonfinite_rows", "nan_word",
           "require_finite", "outline_errors"]


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


def polyline_sq_distances(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n, k - 1) squared distances of points p (n, d) to each segment of the
    polyline ``line`` (k, d) (the foot clamped to the segment; a segment of
    zero length is its first point)."""
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(np.einsum("nkj,kj->nk", p[:, None, :] - a[None], ab)
                / np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-300), 0, 1)
    foot = a[None] + t[..., None] * ab[None]
    return np.einsum("nkj,nkj->nk", p[:, None, :] - foot, p[:, None, :] - foot)


def polyline_distance(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n,) distance of points p (n, d) to the polyline ``line`` (k, d)."""
    return np.sqrt(polyline_sq_distances(p, line).min(axis=1))


def nearest_segment(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n,) index of the segment of ``line`` nearest to each point of p."""
    return np.argmin(polyline_sq_distances(p, line), axis=1)


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
