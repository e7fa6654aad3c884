"""Colour scales of the strain and shear displays, as plain numpy (no Qt, no VTK).

A scale is a list of stops ``(value, (r, g, b))`` with values increasing and
colours in [0, 1]; between stops the colour is interpolated linearly in RGB,
outside them it is the end colour. The views build their VTK colour transfer
functions from the same stops, so :func:`ramp` is what the screen shows.

* strain (the paper's figures): pure blue at the highest compressive strain,
  pure green at zero, pure red at the highest tensile strain.
* shear: green at 0 degrees, yellow at the warning angle, red at the limit
  angle; beyond the limit a flat purple, so cells past it stand out.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RED", "GREEN", "BLUE", "YELLOW", "PURPLE", "strain_range", "strain_stops", "shear_stops",
           "ramp", "SHEAR_SCALE_TOP"]

RED = (1.0, 0.0, 0.0)
GREEN = (0.0, 1.0, 0.0)
BLUE = (0.0, 0.0, 1.0)
YELLOW = (1.0, 0.9, 0.0)
PURPLE = (0.55, 0.0, 0.65)

SHEAR_SCALE_TOP = 1.5
"""The shear scale runs from 0 to this many times the limit angle (purple above the limit)."""

_EPS = 1e-12


def strain_range(strain: np.ndarray) -> tuple[float, float]:
    """(lo, hi) of a strain scale: the most compressive value (<= 0) and the most
    tensile (>= 0), widened to at least +-1e-12 so the scale never collapses."""
    s = np.asarray(strain, dtype=float)
    s = s[np.isfinite(s)]
    lo = min(float(s.min()), 0.0) if s.size else 0.0
    hi = max(float(s.max()), 0.0) if s.size else 0.0
    return min(lo, -_EPS), max(hi, _EPS)


def strain_stops(lo: float, hi: float) -> list[tuple[float, tuple[float, float, float]]]:
    """Blue at ``lo`` (< 0), green at 0, red at ``hi`` (> 0)."""
    return [(float(lo), BLUE), (0.0, GREEN), (float(hi), RED)]


def shear_stops(warning: float, limit: float) -> list[tuple[float, tuple[float, float, float]]]:
    """Green at 0, yellow at ``warning``, red at ``limit``, purple just above it
    up to SHEAR_SCALE_TOP * limit (angles in degrees, 0 < warning < limit)."""
    jump = limit * (1.0 + 1e-9)
    return [(0.0, GREEN), (float(warning), YELLOW), (float(limit), RED), (jump, PURPLE),
            (SHEAR_SCALE_TOP * float(limit), PURPLE)]


def ramp(values: np.ndarray, stops) -> np.ndarray:
    """(k, 3) float RGB of ``values`` (k,) on the scale ``stops``."""
    x = np.asarray([s[0] for s in stops], dtype=float)
    c = np.asarray([s[1] for s in stops], dtype=float)
    v = np.asarray(values, dtype=float)
    return np.column_stack([np.interp(v, x, c[:, k]) for k in range(3)])
