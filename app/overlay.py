"""How an overlay layer of the 3D view looks (:meth:`flatweave.app.view3d.SurfaceView.draw`).

A layer is drawn by whoever owns it (a tool, a dialog, the presenter) under a
name; the view keeps no list of who draws what. This module holds no VTK, so a
tool declares its layers without touching the view's objects.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["LayerStyle", "PREVIEW", "HANDLES"]


@dataclass(frozen=True)
class LayerStyle:
    """One layer's look.

    color : its lines' and round points' colour (any colour pyvista reads)
    width : line width (pixels); size : point size (pixels)
    closed : the lines are closed loops
    marker : "round" (spheres among the surface's nodes) or "square" (2D
        squares ringed in ``edge``, drawn over everything: a draggable handle)
    edge, edge_size : a square marker's ring colour (RGB 0-1) and size (pixels)
    """

    color: str | tuple = "#ff7f00"
    width: float = 3.0
    size: float = 12.0
    closed: bool = False
    marker: str = "round"
    edge: tuple = (0.07, 0.07, 0.07)
    edge_size: float = 17.0

    def __post_init__(self):
        if self.marker not in ("round", "square"):
            raise ValueError(f"marker must be 'round' or 'square', got {self.marker!r}")


PREVIEW = LayerStyle("#ff7f00", width=5.0, size=13.0)  # what a tool would make: a dart's curve, clicked points
HANDLES = LayerStyle((1.0, 1.0, 1.0), size=11.0, marker="square")  # white squares ringed in black
