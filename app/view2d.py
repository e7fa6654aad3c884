"""The pattern view: the relaxed mesh in the plane with the same colouring as
the 3D view, the outline of every piece and its holes, the darts' legs, the
grain line and a scale bar in the model's units.

A second pyvista render widget with a parallel camera and 2D interaction
(drag pans, wheel zooms) rather than a QPainter canvas: it reuses the 3D
view's mesh layer, colour scales and hover picking unchanged, redraws 10k
coloured springs in place in a few milliseconds, and zooms without redrawing
anything in Python.
"""

from __future__ import annotations

import math

import numpy as np
import pyvista as pv
import shapely
from vtkmodules.vtkRenderingCore import vtkTextActor

from flatweave.app.viewbase import ViewBase, ViewOptions, polyline_cells, replace_geometry, text_size

__all__ = ["PatternView", "nice_length", "segment_distances"]

OUTLINE_COLOR = "#111111"
GRAIN_COLOR = "#444444"
LEG_COLORS = ((0.85, 0.0, 0.0), (0.0, 0.0, 0.85))  # positive side (leg a), negative side (leg b)


def nice_length(limit: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``limit`` (> 0)."""
    if not (limit > 0 and math.isfinite(limit)):
        return 1.0
    p = 10.0 ** math.floor(math.log10(limit))
    return max(m * p for m in (1.0, 2.0, 5.0) if m * p <= limit * (1 + 1e-12))


def segment_distances(p: np.ndarray, a: np.ndarray, b: np.ndarray, cap: float = np.inf) -> np.ndarray:
    """(k,) distance from each point ``p`` (k, 2) to the nearest segment a[i]-b[i]
    (s, 2 each; a point where a[i] == b[i]), or ``cap`` when none is nearer.

    The segments go into a shapely STRtree and every point asks it for its
    nearest: several times quicker than a dense (points x segments) array for
    the grain label's candidates against a pattern's outline and darts."""
    if not len(a) or not len(p):
        return np.full(len(p), cap)
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    dot = np.all(a == b, axis=1)
    geoms = np.empty(len(a), dtype=object)
    geoms[dot] = shapely.points(a[dot])
    geoms[~dot] = shapely.linestrings(np.stack([a[~dot], b[~dot]], axis=1))
    tree = shapely.STRtree(geoms)
    d = np.full(len(p), np.inf)
    (i, _), dist = tree.query_nearest(shapely.points(np.asarray(p, dtype=float)), return_distance=True,
                                      all_matches=False, max_distance=None if math.isinf(cap) else cap)
    d[i] = dist
    return np.minimum(d, cap)


def _text(size: int, bold: bool = False) -> vtkTextActor:
    t = vtkTextActor()
    prop = t.GetTextProperty()
    prop.SetColor(0.1, 0.1, 0.1)
    prop.SetFontSize(size)
    prop.SetBold(bold)
    prop.SetBackgroundColor(1.0, 1.0, 1.0)
    prop.SetBackgroundOpacity(0.75)
    prop.SetJustificationToCentered()
    prop.SetVerticalJustificationToTop()
    t.GetPositionCoordinate().SetCoordinateSystemToWorld()
    t.SetPickable(False)
    t.SetVisibility(False)
    return t


class PatternView(ViewBase):
    """The 2D pattern. ``show_frame`` draws a frame (outline from its pattern,
    when it has one); ``fit`` frames the pattern; ``clear_frame`` empties it."""

    def __init__(self, parent=None):
        super().__init__(parent)
        p = self._plotter
        p.enable_parallel_projection()
        p.enable_2d_style()
        self.outline = pv.PolyData()
        self.legs = [pv.PolyData(), pv.PolyData()]
        self.grain = pv.PolyData()
        self.scale_bar = pv.PolyData()
        self._outline_actor = p.add_mesh(self.outline, color=OUTLINE_COLOR, line_width=2.5, render=False,
                                         reset_camera=False, pickable=False)
        self._leg_actors = [p.add_mesh(leg, color=c, line_width=3, render=False, reset_camera=False,
                                       pickable=False) for leg, c in zip(self.legs, LEG_COLORS)]
        self._grain_actor = p.add_mesh(self.grain, color=GRAIN_COLOR, line_width=2, render=False,
                                       reset_camera=False, pickable=False)
        self._bar_actor = p.add_mesh(self.scale_bar, color=OUTLINE_COLOR, line_width=2.5, render=False,
                                     reset_camera=False, pickable=False)
        self.scale_label = _text(14, bold=True)
        self.grain_label = _text(13)
        self.grain_label.GetTextProperty().SetJustificationToLeft()
        self.grain_label.GetTextProperty().SetVerticalJustificationToCentered()
        for t in (self.scale_label, self.grain_label):
            p.renderer.AddViewProp(t)
        self.options = ViewOptions()
        self._grain = None
        self._grain_segments = (np.zeros((0, 2)), np.zeros((0, 2)))  # what the grain label keeps clear of
        for event in ("MouseWheelForwardEvent", "MouseWheelBackwardEvent"):  # after the style's zoom
            p.iren.interactor.AddObserver(event, self._on_wheel, -1.0)
        self.scale_length: float | None = None
        self._fit_pending = True
        self._pattern = None
        self._z = 0.0

    # ------------------------------------------------------------------ content
    def clear_frame(self) -> None:
        self.layer.clear()
        for poly in (self.outline, *self.legs, self.grain, self.scale_bar):
            replace_geometry(poly, np.zeros((0, 3)))
        for t in (self.scale_label, self.grain_label):
            t.SetVisibility(False)
        self._pattern = None
        self._grain = None
        self.scale_length = None
        self._fit_pending = True

    def request_fit(self) -> None:
        """Frame the pattern when the next frame is drawn."""
        self._fit_pending = True

    def show_frame(self, frame, options: ViewOptions) -> None:
        self.options = options
        new_topology = frame.topology != self.layer.topology
        spacing = float(min(frame.mesh.r_weft, frame.mesh.r_warp))
        self._z = 1e-3 * spacing  # the outline and legs sit just above the mesh
        pts = np.column_stack([frame.xy, np.zeros(len(frame.xy))])
        self.layer.show(frame, pts, options)
        if frame.pattern is not None and frame.pattern is not self._pattern:
            self._pattern = frame.pattern
            self._draw_pattern(frame.pattern)
        if new_topology or frame.final or self.scale_length is None:
            self._draw_guides(frame)
        if self._fit_pending:
            # the drape's frames grow: frame the pattern again when the solve's first frame comes
            self._fit_pending = bool(frame.draping)
            self.fit(render=False)
        elif new_topology:
            self.update_density()
        self.render()

    def restyle(self, options: ViewOptions) -> None:
        units_changed = options.units != self.options.units
        self.options = options
        self.layer.restyle(options)
        if units_changed and self.layer.frame is not None:
            self._draw_guides(self.layer.frame)
        self.render()

    def fit(self, render: bool = True) -> None:
        """Fit the camera to the pattern and its scale bar, looking down z, +y up.

        (Set directly: pyvista's view_xy / reset_camera gather every actor's
        bounds in Python, too slow under load; docs/decisions/0009-window-on-software-opengl.md.)"""
        if self._closed:
            return
        polys = [p for p in (self.outline, self.scale_bar, *self.layer.springs) if p.n_points]
        if not polys:
            return
        lo = np.min([np.asarray(p.points).min(axis=0) for p in polys], axis=0)
        hi = np.max([np.asarray(p.points).max(axis=0) for p in polys], axis=0)
        centre = (lo + hi) / 2
        half = np.maximum((hi - lo) / 2, 1e-12)
        w, h = self.device_size()  # the widget's: the canvas's render window takes it only when it paints
        aspect = w / h if w > 0 and h > 0 else 1.0
        cam = self._plotter.renderer.GetActiveCamera()
        cam.ParallelProjectionOn()
        depth = 10.0 * float(max(half[0], half[1]))
        cam.SetFocalPoint(centre[0], centre[1], 0.0)
        cam.SetPosition(centre[0], centre[1], depth)
        cam.SetViewUp(0.0, 1.0, 0.0)
        cam.SetParallelScale(1.12 * max(half[1], half[0] / aspect))
        self._plotter.renderer.ResetCameraClippingRange()
        self._zoomed()
        if render:
            self.render()

    def _zoomed(self) -> None:
        """The scale on screen changed: the label's size in model units and the springs' density did."""
        if self.grain_label.GetVisibility():
            self._place_grain_label()
        self.update_density()

    def _on_wheel(self, *_args) -> None:
        if not self._closed:
            self._zoomed()

    # ------------------------------------------------------------------ the grain label
    def _obstacles(self, frame) -> list[np.ndarray]:
        """What the grain label must not cover: the darts' legs and nodes, and the outline, as (k, 2) polylines."""
        lines = []
        pattern = frame.pattern if frame.pattern is not None else self._pattern
        if pattern is not None:
            for d in pattern.darts:
                lines.extend([np.asarray(d.leg_a, dtype=float), np.asarray(d.leg_b, dtype=float)])
            pieces = pattern.pieces if len(pattern.pieces) else ()
            loops = [p.outline for p in pieces] + [h for p in pieces for h in p.holes]
            if not pieces:
                loops = [pattern.outline, *pattern.holes]
            lines.extend(np.vstack([loop, loop[:1]]) for loop in (np.asarray(lp, dtype=float) for lp in loops)
                         if len(loop) >= 2)
        nodes = np.concatenate([frame.dart_positive, frame.dart_negative]) if len(frame.xy) else []
        if len(nodes):
            lines.extend(frame.xy[np.asarray(nodes, dtype=np.int64)][:, None, :])  # each node a one-point line
        return [line[np.all(np.isfinite(line), axis=1)] for line in lines if len(line)]

    def _label_size(self) -> tuple[float, float]:
        """(width, height) of the grain label in model units at the current zoom."""
        w, h = text_size(self.grain_label.GetTextProperty(), self.grain_label.GetInput() or "",
                         int(self._plotter.render_window.GetDPI()))
        ppu = self.pixels_per_unit()
        return (w + 6) / ppu, (h + 4) / ppu

    def _place_grain_label(self) -> None:
        """Put the grain label beside the grain line where it is farthest from the
        darts (legs and nodes) and the outline: along the line, on either side."""
        if getattr(self, "_grain", None) is None:
            return
        cx, cy, half, z = self._grain
        w, h = self._label_size()
        gap = 0.4 * h
        ts = np.linspace(-0.8, 0.8, 17)
        right = np.repeat([True, False], len(ts))
        t = np.tile(ts, 2)
        x0 = np.where(right, cx + gap, cx - gap - w)
        y = cy + t * half
        f = np.array([(fx, fy) for fx in (0.0, 0.5, 1.0) for fy in (-0.5, 0.0, 0.5)])
        pts = np.stack([x0[:, None] + f[None, :, 0] * w, y[:, None] + f[None, :, 1] * h], axis=-1)  # (c, 9, 2)
        flat = pts.reshape(-1, 2)
        cap = 3.0 * h  # clearances beyond this count alike
        clear = segment_distances(flat, *self._grain_segments, cap).reshape(len(x0), -1).min(axis=1)
        score = np.minimum(clear, cap) - 0.05 * h * np.abs(t - 0.1) - np.where(right, 0.0, 0.02 * h)
        k = int(np.argmax(score))
        best = (float(x0[k]), float(y[k]), bool(right[k]), float(clear[k]))
        x0, y, right, clear = best
        prop = self.grain_label.GetTextProperty()
        if right:
            prop.SetJustificationToLeft()
            self.grain_label.GetPositionCoordinate().SetValue(x0, y, z)
        else:
            prop.SetJustificationToRight()
            self.grain_label.GetPositionCoordinate().SetValue(x0 + w, y, z)
        self._grain_box = (x0, y - h / 2, x0 + w, y + h / 2)

    def grain_label_box(self) -> tuple[float, float, float, float] | None:
        """(x0, y0, x1, y1) in model units: the grain label's box as placed (None when not shown)."""
        return getattr(self, "_grain_box", None) if self.grain_label.GetVisibility() else None

    # ------------------------------------------------------------------ pieces
    def _draw_pattern(self, pattern) -> None:
        z = self._z
        loops = []
        pieces = pattern.pieces if len(pattern.pieces) else ()
        for piece in pieces:
            loops.append(piece.outline)
            loops.extend(piece.holes)
        if not pieces:
            loops = [pattern.outline, *pattern.holes]
        pts, cells = polyline_cells(loops, closed=True)
        pts[:, 2] = 2 * z
        replace_geometry(self.outline, pts, lines=cells)
        for k, poly in enumerate(self.legs):
            legs = [d.leg_a if k == 0 else d.leg_b for d in pattern.darts]
            lp, lc = polyline_cells(legs, closed=False)
            lp[:, 2] = 3 * z
            replace_geometry(poly, lp, lines=lc)

    def _extent(self, frame) -> tuple[np.ndarray, np.ndarray]:
        """(min xy, max xy) of the pattern: its outline if known, else its nodes."""
        pts = frame.pattern.outline if frame.pattern is not None and len(frame.pattern.outline) else frame.xy
        if not len(pts):
            return np.zeros(2), np.ones(2)
        return pts.min(axis=0), pts.max(axis=0)

    def _draw_guides(self, frame) -> None:
        """The grain line (warp direction, +y of the lattice) through the pattern's
        middle, and a scale bar under it labelled in the model's units."""
        lo, hi = self._extent(frame)
        size = hi - lo
        z = 2 * self._z
        cx, cy = (lo + hi) / 2
        half = 0.3 * size[1]
        head = 0.04 * max(size[1], 1e-12)
        shaft = [[cx, cy - half], [cx, cy + half]]
        heads = [[[cx - head * 0.6, cy + half - head], [cx, cy + half], [cx + head * 0.6, cy + half - head]],
                 [[cx - head * 0.6, cy - half + head], [cx, cy - half], [cx + head * 0.6, cy - half + head]]]
        gp, gc = polyline_cells([shaft, *heads], closed=False)
        gp[:, 2] = z
        replace_geometry(self.grain, gp, lines=gc)
        self.grain_label.SetInput("grain (warp)")
        self._grain = (float(cx), float(cy), float(half), float(z))
        lines = self._obstacles(frame)
        starts = [ln[:-1] if len(ln) > 1 else ln for ln in lines]
        ends = [ln[1:] if len(ln) > 1 else ln for ln in lines]
        self._grain_segments = ((np.vstack(starts), np.vstack(ends)) if lines else
                                (np.zeros((0, 2)), np.zeros((0, 2))))
        self._place_grain_label()
        self.grain_label.SetVisibility(True)

        length = nice_length(0.4 * max(size[0], 1e-12))
        self.scale_length = length
        y = lo[1] - 0.08 * max(size[1], 1e-12)
        x0 = lo[0]
        tick = 0.025 * max(size[1], 1e-12)
        bar = [[x0, y], [x0 + length, y]]
        ticks = [[[x0, y - tick], [x0, y + tick]], [[x0 + length, y - tick], [x0 + length, y + tick]]]
        sp, sc = polyline_cells([bar, *ticks], closed=False)
        sp[:, 2] = z
        replace_geometry(self.scale_bar, sp, lines=sc)
        self.scale_label.SetInput(f"{length:g} {self.options.units}")
        self.scale_label.GetPositionCoordinate().SetValue(x0 + length / 2, y - 1.5 * tick, z)
        self.scale_label.SetVisibility(True)
