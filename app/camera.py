"""Framing the 3D view, as plain numpy (no Qt, no VTK): which way to look at a
surface and from how far, so that it shows its relief and fills the view.

:func:`home_view` picks the direction: tilted ``HOME_TILT_DEG`` from the
surface's mean normal (the point cloud's axis of least spread, turned to the
side the normals face, or up for a surface lying mostly flat; 25 to 52
degrees when that keeps the surface's planar sides from being seen edge-on),
round the normal to the azimuth that puts the camera between 20 and 60 degrees
above the horizon and shows most of the surface squarely (the mean of |normal . view|
over its points, so no part of it is seen edge-on), and then the front right
(+x, -y: the draughtsman's south-east isometric), so surfaces alike get the
same handedness; world z is up on screen unless the view looks nearly along z.

:func:`fit_view` places a perspective camera looking that way so that the
points' projection is centred in a region of the viewport (the 3D view keeps
its right-hand column for the colour bars) and fills ``fill`` of it in its
limiting dimension; the projection is exact (perspective included), found by
bisection on the distance. The camera's window centre shifts the picture
into the region, so the camera still turns about the surface's centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CameraFrame", "home_view", "fit_view", "project", "HOME_TILT_DEG", "FILL"]

HOME_TILT_DEG = 38.0  # between the view and the mean normal: a three-quarter view
TILT_STEPS = np.array([-13.0, -7.0, 0.0, 7.0, 14.0])  # tilts tried about it, at TILT_COST a degree off
TILT_COST = 1.5
FILL = 0.86  # of the region's limiting dimension
EDGE_ON, EDGE_ON_WEIGHT = 0.2, 300.0  # |normal . view| below this is edge-on; the share of such points costs
FACING_WEIGHT = 150.0  # and the mean |normal . view| (how squarely the surface faces the camera) gains
SIDE_EDGE_ON, SIDE_WEIGHT = 0.35, 120.0  # a planar side seen within asin(0.4) of its plane looks straight
DIAGONAL_WEIGHT = 40.0  # looking along a long axis (or square to it) costs this much
_Z = np.array([0.0, 0.0, 1.0])
_FRONT_RIGHT = np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)


@dataclass(frozen=True)
class CameraFrame:
    """A perspective camera: VTK's position, focal point, view up, window
    centre (ndc units, positive moves the picture left/down) and vertical view angle."""

    position: np.ndarray
    focal_point: np.ndarray
    view_up: np.ndarray
    window_center: tuple[float, float]
    view_angle: float

    @property
    def direction(self) -> np.ndarray:
        d = self.focal_point - self.position
        return d / np.linalg.norm(d)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


def mean_normal(points, normals=None) -> np.ndarray:
    """(3,) unit: the axis of least spread of ``points`` (k, 3), turned to the
    side ``normals`` (k, 3) face on average (or +z when they cancel out)."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 3:
        return _Z.copy()
    _, vecs = np.linalg.eigh(np.cov((p - p.mean(axis=0)).T))
    n = vecs[:, 0]
    m = np.zeros(3) if normals is None else np.nanmean(np.asarray(normals, dtype=float).reshape(-1, 3), axis=0)
    if abs(n[2]) >= 0.5:  # lying mostly flat: look from above, whatever side the normals face
        return n if n[2] > 0 else -n
    if np.linalg.norm(m) > 0.1:  # standing: look at the side the normals face
        return n if np.dot(n, m) >= 0 else -n
    return n if n[2] >= 0 else -n


def home_view(points, normals=None, tilt_deg: float = HOME_TILT_DEG) -> tuple[np.ndarray, np.ndarray]:
    """(direction, view_up): unit (3,) each, the camera's direction into the
    scene and the screen's up for a three-quarter view of ``points`` (k, 3),
    or of a grid of points (nu, nv, 3), whose curved planar sides are then not
    seen edge-on (as straight lines) either; ``normals`` like ``points``
    (see the module docstring)."""
    n = mean_normal(points, normals)
    a = _unit(np.cross(n, _Z if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])))
    b = np.cross(n, a)
    phi, tilt = (x.ravel() for x in np.meshgrid(np.radians(np.arange(0.0, 360.0, 5.0)),
                                                np.asarray(tilt_deg + TILT_STEPS, dtype=float)))
    t = np.radians(tilt)[:, None]
    side = np.cos(phi)[:, None] * a[None, :] + np.sin(phi)[:, None] * b[None, :]
    towards = np.cos(t) * n[None, :] + np.sin(t) * side
    elevation = np.degrees(np.arcsin(np.clip(towards[:, 2], -1.0, 1.0)))
    score = np.maximum(0.0, 20.0 - elevation) ** 2 + np.maximum(0.0, elevation - 60.0) ** 2
    score = score + TILT_COST * np.abs(tilt - tilt_deg)
    score = score - 15.0 * (towards @ _FRONT_RIGHT)
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) >= 3:  # between the two long axes, when there are two: the length and the profile both show
        vals, vecs = np.linalg.eigh(np.cov((p - p.mean(axis=0)).T))
        if vals[2] > 1.15 * vals[1]:
            long_axis = _unit(vecs[:, 2] - np.dot(vecs[:, 2], n) * n)
            score = score + DIAGONAL_WEIGHT * (2.0 * (side @ long_axis) ** 2 - 1.0) ** 2
    grid = np.asarray(points, dtype=float)
    if grid.ndim == 3 and min(grid.shape[:2]) >= 3:  # no curved, planar side of the grid seen edge-on
        size = float(np.ptp(p, axis=0).max()) if len(p) else 1.0
        for side_pts in (grid[0], grid[-1], grid[:, 0], grid[:, -1]):
            c = side_pts[np.all(np.isfinite(side_pts), axis=1)]
            if len(c) < 3:
                continue
            sv, vt = np.linalg.svd(c - c.mean(axis=0), full_matrices=False)[1:]
            if sv[0] > 1e-6 * size * math.sqrt(len(c)) and sv[1] > 0.05 * sv[0] and sv[2] < 0.2 * sv[1]:
                flat = np.abs(towards @ vt[2])
                score = score + SIDE_WEIGHT * np.maximum(0.0, 1.0 - flat / SIDE_EDGE_ON)
    if normals is not None:  # no part of the surface seen edge-on
        nrm = np.asarray(normals, dtype=float).reshape(-1, 3)
        nrm = nrm[np.all(np.isfinite(nrm), axis=1)]
        if len(nrm):
            facing = np.abs(nrm @ towards.T)
            score = score + EDGE_ON_WEIGHT * (facing < EDGE_ON).mean(axis=0) - FACING_WEIGHT * facing.mean(axis=0)
    eye = towards[int(np.argmin(score))]  # from the surface towards the camera
    direction = -eye
    up = _Z if abs(direction[2]) < 0.95 else _unit(np.cross(np.cross(direction, _FRONT_RIGHT), direction))
    up = _unit(up - np.dot(up, direction) * direction)
    return direction, up


def project(points, frame: CameraFrame, aspect: float) -> np.ndarray:
    """(k, 2) normalised device coordinates (-1..1 across the viewport, y up)
    of ``points`` (k, 3) for ``frame`` in a viewport of width/height ``aspect``,
    as VTK's perspective projection gives them."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    d = frame.direction
    up = _unit(frame.view_up - np.dot(frame.view_up, d) * d)
    right = np.cross(d, up)
    rel = p - frame.position
    depth = rel @ d
    tan = math.tan(math.radians(frame.view_angle) / 2)
    x = (rel @ right) / depth / (tan * aspect) - frame.window_center[0]
    y = (rel @ up) / depth / tan - frame.window_center[1]
    return np.column_stack([x, y])


def fit_view(points, direction, view_up, aspect: float, region=(0.0, 1.0, 0.0, 1.0), fill: float = FILL,
             view_angle: float = 30.0) -> CameraFrame:
    """A camera looking along ``direction`` (``view_up`` up) at ``points``
    (k, 3) whose projection is centred in ``region`` (x0, x1, y0, y1 as
    fractions of a viewport of width/height ``aspect``) and spans ``fill`` of
    the region's width or height, whichever limits."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if not len(p):
        p = np.zeros((1, 3))
    d = _unit(direction)
    up = _unit(np.asarray(view_up, dtype=float) - np.dot(view_up, d) * d)
    right = np.cross(d, up)
    focal = (p.min(axis=0) + p.max(axis=0)) / 2
    rel = p - focal
    x, y, z = rel @ right, rel @ up, rel @ d
    size = max(float(np.ptp(p, axis=0).max()), 1e-12)
    tan = math.tan(math.radians(view_angle) / 2)
    x0, x1, y0, y1 = region
    half_w, half_h = (x1 - x0) * fill, (y1 - y0) * fill  # ndc half-sizes wanted (ndc spans 2)

    def spans(dist):
        depth = dist + z
        sx, sy = x / depth / (tan * aspect), y / depth / tan
        return sx, sy

    def too_big(dist):
        sx, sy = spans(dist)
        return max(np.ptp(sx) / 2 / half_w, np.ptp(sy) / 2 / half_h) > 1.0

    lo = float(max(-z.min(), 0.0)) + 1e-6 * size  # the camera in front of every point
    hi = lo + 1e3 * size
    if too_big(lo):
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if too_big(mid) else (lo, mid)
    dist = hi
    sx, sy = spans(dist)
    centre = ((sx.min() + sx.max()) / 2, (sy.min() + sy.max()) / 2)
    target = (x0 + x1 - 1.0, y0 + y1 - 1.0)  # the region's centre in ndc
    wc = (float(centre[0] - target[0]), float(centre[1] - target[1]))
    return CameraFrame(focal - dist * d, focal, up, wc, float(view_angle))
