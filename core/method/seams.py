"""Sew lines matched across seams (issue 42): the length each panel's flat pattern
gives a sew line, and the two sides' difference.

A panel's pattern outline is its region's boundary unrolled into the plane
(:mod:`flatweave.method.pattern`); the stretch of it whose (u, v) lie on a sew
line (:class:`flatweave.geometry.panels.SewLine`) is that panel's side of the seam, the
line the sewer matches with the other panel's. Its length is the sum of the
flat outline's segments between points on the sew line. The sew line's ends
are corners of both panels' regions (:func:`flatweave.geometry.panels.split_region`
makes them so), so each side's stretch runs exactly from end to end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatweave.geometry.numerics import cumulative_length, interp_rows, nearest_segments, polyline_distance

__all__ = ["SewMatch", "flat_sew_line", "flat_notches", "notches_along", "match_sews", "polyline_length",
           "MATCH_PCT", "MATCH_MM"]

MATCH_PCT = 0.5
"""A seam's two sides differing by more than this percentage of their mean
length, and by more than :data:`MATCH_MM`, is a warning (issue 42)."""
MATCH_MM = 2.0


@dataclass(frozen=True)
class SewMatch:
    """One sew line's two sides in the flat: ``name`` (the sew line's), ``seam``,
    ``panels`` (the two panel names) and their flat ``lengths`` (model units)."""

    name: str
    seam: str
    panels: tuple
    lengths: tuple

    @property
    def difference(self) -> float:
        """|length a - length b| (model units)."""
        return abs(self.lengths[0] - self.lengths[1])

    @property
    def difference_pct(self) -> float:
        """The difference as a percentage of the sides' mean length."""
        mean = 0.5 * (self.lengths[0] + self.lengths[1])
        return 100.0 * self.difference / mean if mean > 0 else 0.0

    def to_dict(self) -> dict:
        return {"name": self.name, "seam": self.seam, "panels": list(self.panels), "lengths": list(self.lengths),
                "difference": self.difference, "difference_pct": self.difference_pct}


def _on_polyline(P: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point P (n, 2) at its nearest point of the polyline ``line`` (k, 2):
    (segment index (n,), fraction along it (n,))."""
    k, _ = nearest_segments(P, line)
    a, ab = line[k], line[k + 1] - line[k]
    t = np.einsum("nc,nc->n", P - a, ab) / np.maximum(np.einsum("nc,nc->n", ab, ab), 1e-300)
    return k, np.clip(t, 0.0, 1.0)


def _flat_run(result, uv_line: np.ndarray, tol: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The stretch of ``result``'s flat outline along the sew line ``uv_line``:
    (xy (k, 2), uv (k, 2)), in the outline's order; empty when none."""
    pieces = result.pattern.pieces or ()
    outlines = [(p.outline, p.outline_uv) for p in pieces] or [(result.pattern.outline, result.pattern.outline_uv)]
    outlines += [(h, h_uv) for p in pieces for h, h_uv in zip(p.holes[:p.n_region_holes], p.holes_uv)]
    line = np.asarray(uv_line, dtype=float)
    if tol is None:
        (u0, u1), (v0, v1) = result.surface.domain
        tol = 1e-7 * float(np.hypot(u1 - u0, v1 - v0))
    best = (np.zeros((0, 2)), np.zeros((0, 2)))
    for xy, uv in outlines:
        xy, uv = np.asarray(xy, dtype=float), np.asarray(uv, dtype=float)
        on = polyline_distance(uv, line) <= tol
        if on.sum() < 2:
            continue
        if on.all():  # the outline is the sew line, round a closed seam
            idx = np.r_[np.arange(len(on)), 0]
        else:  # the longest run of points on the line, the outline being closed: from just after a point off it
            start = int(np.flatnonzero(~on)[-1]) + 1
            order = np.roll(np.arange(len(on)), -start)
            runs, current = [], []
            for i in order:
                if on[i]:
                    current.append(i)
                elif current:
                    runs.append(current)
                    current = []
            if current:
                runs.append(current)
            idx = np.asarray(max(runs, key=len))
        if len(idx) > len(best[0]):
            best = (xy[idx], uv[idx])
    return best


def flat_sew_line(result, uv_line: np.ndarray, tol: float | None = None) -> np.ndarray:
    """(k, 2) the stretch of ``result``'s flat outline (or of a hole of its region,
    round a closed seam) along the sew line ``uv_line`` (its (u, v) polyline): the
    points whose (u, v) lie within ``tol`` of it (default 1e-7 of the domain's
    size), in the outline's order. Empty when the outline does not run along it."""
    return _flat_run(result, uv_line, tol)[0]


def notches_along(surface, uv_line: np.ndarray, every: float, per: int = 32) -> np.ndarray:
    """(k, 2) the (u, v) of notches on a sew line: its two ends (one, round a closed
    seam) and a point every ``every`` (model units) of its length on the surface
    from its first point."""
    line = np.asarray(uv_line, dtype=float)
    t = np.linspace(0.0, 1.0, per + 1)[None, :, None]
    fine = (line[:-1, None, :] * (1 - t) + line[1:, None, :] * t)[:, :-1].reshape(-1, 2)
    fine = np.vstack([fine, line[-1:]])
    P = surface.points(fine)
    s = cumulative_length(P)
    marks = np.r_[np.arange(0.0, s[-1], every), s[-1]] if every > 0 else np.r_[0.0, s[-1]]
    if np.array_equal(line[0], line[-1]):  # a closed seam: its end is its start, one notch
        marks = marks[:-1]
    return interp_rows(marks, s, fine)


def _along(uv: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(k,) how far along the polyline ``line`` (in (u, v) length) each point ``uv`` lies."""
    s = cumulative_length(line)
    k, t = _on_polyline(uv, line)
    return s[k] + t * (s[k + 1] - s[k])


def _from_the_lines_start(xy: np.ndarray, uv: np.ndarray, line: np.ndarray):
    """The run turned to go the sew line's way from its first point (a closed
    run, round a closed seam, also started there)."""
    closed = len(uv) > 2 and np.array_equal(uv[0], uv[-1])
    if closed:
        xy, uv = xy[:-1], uv[:-1]
        k0 = int(np.argmin(np.linalg.norm(uv - line[0], axis=1)))
        xy, uv = np.roll(xy, -k0, axis=0), np.roll(uv, -k0, axis=0)
        s = _along(uv, line)
        total = float(np.linalg.norm(np.diff(line, axis=0), axis=1).sum())
        if s[1] > 0.5 * total:  # the second point is near the line's end: the run goes the other way
            xy, uv = np.vstack([xy[:1], xy[1:][::-1]]), np.vstack([uv[:1], uv[1:][::-1]])
        return np.vstack([xy, xy[:1]]), np.vstack([uv, uv[:1]])
    if np.linalg.norm(uv[0] - line[0]) > np.linalg.norm(uv[-1] - line[0]):
        return xy[::-1], uv[::-1]
    return xy, uv


def flat_notches(result, uv_line: np.ndarray, notches_uv: np.ndarray, tol: float | None = None,
                 with_tangents: bool = False):
    """Where notches (their (u, v) on the sew line ``uv_line``) fall on ``result``'s
    flat pattern: (xy (k, 2), s (k,)), s the flat length along the sew line from
    its first point (the same end on both panels, whichever way each outline runs);
    ``with_tangents``: also the flat sew line's unit direction at each (k, 2), which
    a notch is cut across (at a seam's end, a corner, the outline turns)."""
    xy, uv = _flat_run(result, uv_line, tol)
    line = np.asarray(uv_line, dtype=float)
    if len(xy) < 2:
        nan = np.full((len(notches_uv), 2), np.nan)
        return (nan, nan[:, 0], nan) if with_tangents else (nan, nan[:, 0])
    xy, uv = _from_the_lines_start(xy, uv, line)
    s2 = cumulative_length(xy)
    # each notch on the run's (u, v) polyline: its segment and the fraction along it, the same in the flat
    k, tk = _on_polyline(np.asarray(notches_uv, dtype=float).reshape(-1, 2), uv)
    seg = xy[k + 1] - xy[k]
    out_xy = xy[k] + tk[:, None] * seg
    if with_tangents:
        tangent = seg / np.maximum(np.linalg.norm(seg, axis=1), 1e-300)[:, None]
        return out_xy, s2[k] + tk * (s2[k + 1] - s2[k]), tangent
    return out_xy, s2[k] + tk * (s2[k + 1] - s2[k])


def polyline_length(p: np.ndarray) -> float:
    """The length of the polyline ``p`` (k, d); 0 for fewer than two points."""
    return float(cumulative_length(p)[-1]) if len(p) > 1 else 0.0


def match_sews(split, results: dict) -> list[SewMatch]:
    """Each sew line of ``split`` (a :class:`flatweave.geometry.panels.Split`) that
    two panels share, with its flat length in each (``results``: per panel name,
    its FlattenResult)."""
    out = []
    for sew in split.sews:
        if len(sew.panels) != 2 or any(p not in results for p in sew.panels):
            continue
        lengths = tuple(polyline_length(flat_sew_line(results[p], sew.uv)) for p in sew.panels)
        out.append(SewMatch(sew.name, sew.seam, tuple(sew.panels), lengths))
    return out
