"""Shared helpers for the numeric tests (not a test module)."""

import numpy as np
from scipy.spatial import cKDTree


def resample_closed(poly: np.ndarray, n: int) -> np.ndarray:
    """n points evenly spaced in arc length along a closed polygon (k, 2)."""
    closed = np.vstack([poly, poly[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    t = np.linspace(0, s[-1], n, endpoint=False)
    return np.column_stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])])


def hausdorff(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Hausdorff distance between two dense point sets (k, 2)."""
    return max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max())


def rigid_align(a: np.ndarray, b: np.ndarray, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Resample two closed outlines and move b onto a by the best rotation and
    translation (Kabsch over every cyclic shift and both orientations).
    Returns (a_resampled, b_aligned), both dense (n, 2)."""
    A = resample_closed(a, n)
    B0 = resample_closed(b, n)
    best = None
    ca = A.mean(axis=0)
    for B in (B0, B0[::-1]):
        for shift in range(0, n, 2):
            Bs = np.roll(B, shift, axis=0)
            cb = Bs.mean(axis=0)
            H = (Bs - cb).T @ (A - ca)
            U, _, Vt = np.linalg.svd(H)
            R = (U @ Vt).T
            if np.linalg.det(R) < 0:
                continue
            moved = (Bs - cb) @ R.T + ca
            err = np.sum((moved - A) ** 2)
            if best is None or err < best[0]:
                best = (err, moved)
    return A, best[1]


def diameter(poly: np.ndarray) -> float:
    d = poly[:, None, :] - poly[None, :, :]
    return float(np.sqrt((d ** 2).sum(-1)).max())


def fit_circle(p: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Least-squares (algebraic) circle through points (k, 2): centre, radius, distances."""
    A = np.column_stack([2 * p, np.ones(len(p))])
    b = (p ** 2).sum(axis=1)
    c, *_ = np.linalg.lstsq(A, b, rcond=None)
    centre = c[:2]
    r = np.sqrt(c[2] + centre @ centre)
    return centre, r, np.linalg.norm(p - centre, axis=1)
