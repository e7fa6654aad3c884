"""Splices (issue 43): a piece wider than the roll split into parts that fit, by lines along the roll.

In the frame where a piece's grain (its warp) runs along the roll (x), its
width across the roll is its y extent; a line across it can only shorten that
if it runs along the roll (y = s). A splice at s cuts the piece there, the part
below reaching ``overlap / 2`` past it and the part above from as far below it
(composites overlap their plies by 25 mm at a splice; sewn garments give each
part its seam allowance: an overlap of twice that). With the roll's usable
width W, n splices make parts that fit when (n + 1) W - n overlap >= the
piece's width: the least such n is taken. Where they go is chosen among the
positions that keep every part within W (and no part under ``overlap``): the
sum over the splices of the piece's shear along each line is least (a splice
through a sheared area is where the laid cloth is most distorted and the
overlap least sure), with a small pull towards even parts so a piece with no
shear to go by is split evenly. A dynamic programme over positions every
``STEP_MM``, each splice's best predecessor the minimum over a sliding window.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from flatweave.errors import SettingsError

__all__ = ["splice_positions", "split_outline", "splices_needed", "check_positions", "STEP_MM", "EVEN_WEIGHT"]

STEP_MM = 1.0  # the positions tried, across the piece
EVEN_WEIGHT = 1e-3  # degrees of shear per mm away from the even split: a tie-break, no more


def splices_needed(width: float, usable: float, overlap: float) -> int:
    """The fewest splices that make parts of a piece ``width`` across fit ``usable`` (mm), the parts
    sharing ``overlap`` at each splice; a one-line SettingsError when no number does."""
    if width <= usable:
        return 0
    if usable <= overlap:
        raise SettingsError(f"the roll ({usable:.1f} mm usable) is not wider than the splice overlap "
                            f"({overlap:g} mm): no part of a spliced piece would fit")
    return int(math.ceil((width - usable) / (usable - overlap) - 1e-12))


def _shear_cost(y: np.ndarray, points: np.ndarray | None, shear: np.ndarray | None, reach: float) -> np.ndarray:
    """(g,) the mean |shear| (degrees) of the samples within ``reach`` of each line y = const."""
    if points is None or shear is None or not len(points):
        return np.zeros(len(y))
    py = np.asarray(points, dtype=float)[:, 1]
    s = np.abs(np.asarray(shear, dtype=float))
    order = np.argsort(py)
    py, s = py[order], s[order]
    csum = np.concatenate([[0.0], np.cumsum(s)])
    lo = np.searchsorted(py, y - reach, side="left")
    hi = np.searchsorted(py, y + reach, side="right")
    n = hi - lo
    return np.where(n > 0, (csum[hi] - csum[lo]) / np.maximum(n, 1), 0.0)


def splice_positions(outline: np.ndarray, usable: float, overlap: float, points=None, shear=None,
                     reach: float | None = None) -> list[float]:
    """The y of each splice (increasing) that splits ``outline`` ((k, 2) mm, grain along x) into the
    fewest parts each at most ``usable`` mm across, sharing ``overlap`` mm at each splice, through the
    least shear (``points`` (n, 2) mm and ``shear`` (n,) degrees: the piece's cells, in the same frame;
    ``reach``: how near a line a sample counts, default a fiftieth of the width). [] when it fits."""
    p = np.asarray(outline, dtype=float)
    y0, y1 = float(p[:, 1].min()), float(p[:, 1].max())
    n = splices_needed(y1 - y0, usable, overlap)
    if n == 0:
        return []
    half = 0.5 * overlap
    grid = np.arange(y0 + overlap, y1 - overlap + 0.5 * STEP_MM, STEP_MM)
    if not len(grid):
        raise SettingsError("the piece is too narrow to splice with that overlap")
    reach = (y1 - y0) / 50.0 if reach is None else reach
    even = y0 + (y1 - y0) * np.arange(1, n + 1) / (n + 1)
    base = _shear_cost(grid, points, shear, reach)
    inf = np.inf
    # cost[i][g]: the least cost with splice i at grid[g], splices 0..i-1 below it, every part so far fitting
    cost = np.where(grid + half - y0 <= usable, base + EVEN_WEIGHT * np.abs(grid - even[0]), inf)
    back = []
    near = int(math.floor((overlap + STEP_MM) / STEP_MM))  # the next splice at least an overlap (and a step) on
    far = int(math.floor((usable - overlap) / STEP_MM))  # and at most a usable width less the overlap
    for i in range(1, n):
        width = far - near + 1
        if width < 1:
            raise SettingsError("the roll is too narrow for the splices' overlaps")
        # the best predecessor of position g among g - far .. g - near: each window's argmin at once
        padded = np.concatenate([np.full(far, inf), cost])
        windows = sliding_window_view(padded, width)[: len(grid)]  # window g: padded[g .. g + width - 1]
        pick = np.argmin(windows, axis=1)
        arg = pick + np.arange(len(grid)) - far  # back in the grid's indices
        best = windows[np.arange(len(grid)), pick]
        arg = np.where(np.isfinite(best), arg, -1)
        cost = best + base + EVEN_WEIGHT * np.abs(grid - even[i])
        back.append(arg)
    cost = np.where(y1 - (grid - half) <= usable, cost, inf)
    if not np.isfinite(cost).any():
        raise SettingsError(f"no splices of the piece ({y1 - y0:.1f} mm across) give parts within the roll's "
                            f"{usable:.1f} mm with {overlap:g} mm overlaps")
    g = int(np.argmin(cost))
    out = [g]
    for arg in reversed(back):
        g = int(arg[g])
        out.append(g)
    return [float(grid[k]) for k in reversed(out)]


def check_positions(outline: np.ndarray, positions, usable: float, overlap: float, name: str) -> list[float]:
    """The splices at ``positions`` (mm from the outline's lowest y, any order), as y in its frame, when
    every part they make fits ``usable`` and each lies at least ``overlap`` from its neighbours and the
    piece's edges; else a one-line SettingsError naming the piece and what does not fit."""
    p = np.asarray(outline, dtype=float)
    y0, y1 = float(p[:, 1].min()), float(p[:, 1].max())
    try:
        at = sorted(float(v) for v in positions)
    except (TypeError, ValueError):
        raise SettingsError(f"{name}: splices are positions in mm across the piece") from None
    if not at or not all(math.isfinite(v) for v in at):
        raise SettingsError(f"{name}: splices are one or more finite positions in mm across the piece")
    ys = [y0 + v for v in at]
    edges = [y0] + ys + [y1]
    for k in range(len(edges) - 1):
        if edges[k + 1] - edges[k] < overlap:
            near = at[min(k, len(at) - 1)]  # the splice that bounds this too narrow part
            raise SettingsError(f"{name}: the splice at {near:.0f} mm is within the {overlap:g} mm overlap of "
                                f"its neighbour or the piece's edge (the piece is {y1 - y0:.0f} mm across)")
        lo = edges[k] - (0.5 * overlap if k > 0 else 0.0)
        hi = edges[k + 1] + (0.5 * overlap if k + 1 < len(edges) - 1 else 0.0)
        if hi - lo > usable:
            raise SettingsError(f"{name}: part {k + 1} of {len(edges) - 1} would be {hi - lo:.0f} mm across, wider "
                                f"than the roll ({usable:.0f} mm usable): splice it elsewhere or more")
    return ys


def split_outline(outline: np.ndarray, splices, overlap: float) -> list[np.ndarray]:
    """The parts of ``outline`` ((k, 2), grain along x) cut by lines y = s for each splice: part i between
    the splice below it less half the overlap and the one above it plus half; a band that holds two
    separate pieces of the outline gives each as a part. Counter-clockwise (k, 2) outlines, bottom to top."""
    from shapely.geometry import Polygon, box
    from shapely.geometry.polygon import orient

    poly = Polygon(np.asarray(outline, dtype=float))
    if not poly.is_valid:
        poly = poly.buffer(0)
    x0, y0, x1, y1 = poly.bounds
    cuts = [y0 - 1.0] + [float(s) for s in splices] + [y1 + 1.0]
    half = 0.5 * overlap
    parts = []
    for k in range(len(cuts) - 1):
        lo = cuts[k] - (half if k > 0 else 0.0)
        hi = cuts[k + 1] + (half if k + 1 < len(cuts) - 1 else 0.0)
        band = poly.intersection(box(x0 - 1.0, lo, x1 + 1.0, hi))
        geoms = [band] if band.geom_type == "Polygon" else [g for g in getattr(band, "geoms", [])
                                                            if g.geom_type == "Polygon"]
        for g in sorted((g for g in geoms if g.area > 0), key=lambda g: g.bounds[0]):
            parts.append(np.asarray(orient(g, 1.0).exterior.coords)[:-1])
    return parts
