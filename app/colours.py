"""Colour scales of the strain and shear displays, as plain numpy (no Qt, no VTK), and the
colours of the seams drawn over them and their notches (:data:`SEAM`, :data:`NOTCH`), and of a cut plan's
splices (:data:`SPLICE`).

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

__all__ = ["RED", "GREEN", "BLUE", "YELLOW", "PURPLE", "SEAM", "NOTCH", "SPLICE", "strain_range", "strain_stops",
           "shear_stops", "ramp", "SHEAR_SCALE_TOP", "STRAIN_NOISE_PCT"]

RED = (1.0, 0.0, 0.0)
GREEN = (0.0, 1.0, 0.0)
BLUE = (0.0, 0.0, 1.0)
YELLOW = (1.0, 0.9, 0.0)
PURPLE = (0.55, 0.0, 0.65)
SEAM = (0.9, 0.0, 0.75)
"""The seams' lines on the surface (issue 42): a magenta apart from every colour drawn with them, the
darts' near black, the scales' red, green, blue and purple, the surface's sand and a tool's orange preview."""
NOTCH = (0.1, 0.1, 0.1)
"""A notch on a seam: a dark bead on the seam's magenta, which shows on the sand, on the background and
among the scales' colours (a white one was lost on the light background round a panel)."""
SPLICE = (0.0, 0.78, 0.86)
"""A splice of the Cut plan's markers on the surface (issue 43): a cyan apart from the seams' magenta (a splice
is a cut the roll asks for, not a seam of the design), the darts' near black, the scales' pure green and blue,
the weft and warp arrows' red and blue and the surface's sand."""

SHEAR_SCALE_TOP = 1.5
"""The shear scale runs from 0 to this many times the limit angle (purple above the limit)."""

STRAIN_NOISE_PCT = 0.01
"""A strain scale never ends nearer zero than this many percent either side. Below it a strain
is no fact of the cloth: 0.01 % of a 1 m thread is 0.1 mm, finer than a cutter or a rule
resolves. A converged developable piece keeps strains far below it (the bundled ``cone`` at
spacing 0.05-0.1: threads within 5e-4 %; ``half_cylinder``: within 5e-12 %, rounding), which
a scale stretched to them painted full red and blue (the cone's diagonals, 0.02-0.07 %, are the
lattice's chords on a curved surface, and keep a scale of their own); a doubly curved piece's real strains lie
above it (the ``octant``'s threads reach -0.13 % and +0.044 %, its diagonals +-10 %), so its
scales still end at its extremes."""


def strain_range(strain: np.ndarray) -> tuple[float, float]:
    """(lo, hi) of a strain scale over ``strain`` in percent: the most compressive value
    (<= 0) and the most tensile (>= 0), widened to at least +-STRAIN_NOISE_PCT, so the
    scale never collapses nor stretches to numerical noise."""
    s = np.asarray(strain, dtype=float)
    s = s[np.isfinite(s)]
    lo = min(float(s.min()), 0.0) if s.size else 0.0
    hi = max(float(s.max()), 0.0) if s.size else 0.0
    return min(lo, -STRAIN_NOISE_PCT), max(hi, STRAIN_NOISE_PCT)


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
