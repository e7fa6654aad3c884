"""The 3D view: the surface, the spring mesh on it coloured by strain (or its
cells by shear), boundary and dart nodes, the darts' curves and a colour bar,
and what the tools draw over them (:mod:`app.tools`): the dart being drawn,
a curve dart's handles, a plane dart's plane and box widgets, constrained and
picked yarns.

It owns its pyvista and VTK objects; the rest of the app hands it numpy arrays
and :class:`~app.frames.Frame` s (see :mod:`app.viewbase`), and gets display
coordinates, viewing rays and widget values back as numpy arrays. Left-button
events go to ``mouse_handler`` first (a tool), which may take them from the
camera.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import pyvista as pv
from vtkmodules.vtkCommonCore import vtkDoubleArray
from vtkmodules.vtkInteractionWidgets import vtkBoxWidget, vtkImplicitPlaneWidget
from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor

from app.viewbase import ViewBase, ViewOptions, polyline_cells, replace_geometry

__all__ = ["SurfaceView", "grid_faces", "grid_boundary"]

SURFACE_COLOR = "#d8c3a5"
EDGE_COLOR = "#3b3b3b"
DART_COLOR = "#111111"
SELECTED_COLOR = "#d4145a"
PREVIEW_COLOR = "#ff7f00"
YARN_COLOR = "#6a3d9a"
PICK_COLOR = "#00a0d0"
TEXT_COLOR = (0.1, 0.1, 0.1)
TOOL_PRIORITY = 10.0  # above the camera style (0) and VTK's widgets (0.5): tools see clicks first


def grid_faces(nu: int, nv: int) -> np.ndarray:
    """VTK cell array of the quads of an (nu, nv) point grid.

    Point (i, j) has index ``i * nv + j``. Returns ((nu-1)(nv-1) * 5,) int:
    ``[4, a, b, c, d, 4, ...]`` with each quad ordered counter-clockwise in (i, j).
    """
    idx = np.arange(nu * nv).reshape(nu, nv)
    a = idx[:-1, :-1].ravel()
    b = idx[1:, :-1].ravel()
    c = idx[1:, 1:].ravel()
    d = idx[:-1, 1:].ravel()
    return np.column_stack([np.full_like(a, 4), a, b, c, d]).ravel()


def grid_boundary(nu: int, nv: int) -> np.ndarray:
    """Indices of the boundary points of an (nu, nv) grid as one closed loop, (k,) int."""
    idx = np.arange(nu * nv).reshape(nu, nv)
    loop = np.concatenate([idx[:, 0], idx[-1, 1:], idx[-2::-1, -1], idx[0, -2:0:-1], idx[:1, 0]])
    return loop


def _scalar_bar() -> vtkScalarBarActor:
    bar = vtkScalarBarActor()
    bar.SetOrientationToVertical()
    coord = bar.GetPositionCoordinate()
    coord.SetCoordinateSystemToNormalizedViewport()
    coord.SetValue(0.87, 0.1)
    bar.SetWidth(0.125)
    bar.SetHeight(0.55)
    bar.SetBarRatio(0.28)
    bar.DrawBackgroundOn()
    bar.GetBackgroundProperty().SetColor(1.0, 1.0, 1.0)
    bar.GetBackgroundProperty().SetOpacity(0.85)
    bar.SetLabelFormat("%-#6.3g")
    bar.SetVerticalTitleSeparation(8)
    bar.UnconstrainedFontSizeOn()
    for prop, size, bold in ((bar.GetTitleTextProperty(), 15, True), (bar.GetLabelTextProperty(), 13, False)):
        prop.SetColor(*TEXT_COLOR)
        prop.SetFontSize(size)
        prop.SetBold(bold)
        prop.SetItalic(False)
        prop.SetShadow(False)
    bar.SetUseCustomLabels(True)
    bar.SetPickable(False)
    return bar


class SurfaceView(ViewBase):
    """The 3D view. ``set_surface`` shows a new surface (and clears the mesh);
    ``show_frame`` draws a frame; ``restyle`` applies new view options."""

    def __init__(self, parent=None):
        super().__init__(parent)
        p = self._plotter
        p.add_axes()
        self._surface: pv.PolyData | None = None
        self._boundary: pv.PolyData | None = None
        self._surface_actors: list = []
        self._shape: tuple[int, int] | None = None
        def overlay(color, line_width=3.0, points=False, size=12.0):
            poly = pv.PolyData()
            kw = (dict(point_size=size, render_points_as_spheres=True) if points else dict(line_width=line_width))
            actor = p.add_mesh(poly, color=color, render=False, reset_camera=False, pickable=False, **kw)
            return poly, actor

        self._darts, self._dart_actor = overlay(DART_COLOR, 3.0)
        self._selected, self._selected_actor = overlay(SELECTED_COLOR, 5.0)
        self._yarns, self._yarns_actor = overlay(YARN_COLOR, 4.0)
        self._pick, self._pick_actor = overlay(PICK_COLOR, 6.0)
        self._pick_node, self._pick_node_actor = overlay(PICK_COLOR, points=True, size=16.0)
        self._preview, self._preview_actor = overlay(PREVIEW_COLOR, 5.0)
        self._preview_points, self._preview_points_actor = overlay(PREVIEW_COLOR, points=True, size=13.0)
        self._handles, self._handles_actor = overlay(SELECTED_COLOR, points=True, size=15.0)
        self.dart_curves: list = []  # the document's darts as drawn: (k, 3) each, or None when hidden
        self.selected_dart: int | None = None
        self.plane_widget: vtkImplicitPlaneWidget | None = None
        self.box_widget: vtkBoxWidget | None = None
        self.mouse_handler = None  # an object with press(x, y, double), move(x, y), release(x, y) -> bool
        iren = p.iren.interactor
        self._tool_tags = {event: iren.AddObserver(event, self._on_tool_event, TOOL_PRIORITY)
                           for event in ("LeftButtonPressEvent", "MouseMoveEvent", "LeftButtonReleaseEvent")}
        self._bar = _scalar_bar()
        self._bar.SetVisibility(False)
        p.renderer.AddViewProp(self._bar)
        self.options = ViewOptions()
        self._home = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)

    # ------------------------------------------------------------------ access
    @property
    def surface_points(self) -> np.ndarray | None:
        """(nu * nv, 3) float, a copy of the shown surface's points (row i*nv + j), or None."""
        return None if self._surface is None else np.array(self._surface.points)

    @property
    def surface_shape(self) -> tuple[int, int] | None:
        """(nu, nv) of the shown grid, or None."""
        return self._shape

    @property
    def colour_bar_title(self) -> str | None:
        return self._bar.GetTitle() if self._bar.GetVisibility() else None

    @property
    def colour_bar_range(self) -> tuple[float, float]:
        return self.layer.active_scale.range

    # ------------------------------------------------------------------ content
    def set_surface(self, xyz: np.ndarray, normals: np.ndarray | None = None) -> None:
        """Show a new surface, clear the mesh and fit the camera.

        xyz : (nu, nv, 3) float, grid points; normals : (nu, nv, 3) float or None,
        unit normals at them (used for smooth shading).
        """
        xyz = np.asarray(xyz, dtype=float)
        nu, nv = xyz.shape[:2]
        p = self._plotter
        for actor in self._surface_actors:
            p.remove_actor(actor, render=False)
        self._surface_actors.clear()

        mesh = pv.PolyData(xyz.reshape(-1, 3).copy(), grid_faces(nu, nv))
        if normals is not None:
            mesh.point_data["Normals"] = np.asarray(normals, dtype=float).reshape(-1, 3)
            mesh.point_data.active_normals_name = "Normals"
        loop = grid_boundary(nu, nv)
        # lines= in the constructor: no vertex cells, so the grid points are not drawn
        boundary = pv.PolyData(mesh.points.copy(), lines=np.concatenate([[loop.size], loop]))

        surface_actor = p.add_mesh(mesh, color=SURFACE_COLOR, specular=0.2, name=f"{self._name}-surface",
                                   render=False, reset_camera=False, pickable=False)
        surface_actor.prop.interpolation = "phong"  # with the exact normals given
        # the springs are chords a hair inside a convex surface: push the surface back in depth
        mapper = surface_actor.GetMapper()
        mapper.SetResolveCoincidentTopologyToPolygonOffset()
        mapper.SetRelativeCoincidentTopologyPolygonOffsetParameters(4.0, 600.0)
        self._surface_actors.append(surface_actor)
        self._surface_actors.append(p.add_mesh(
            boundary, color=EDGE_COLOR, line_width=2, name=f"{self._name}-rim",
            render=False, reset_camera=False, pickable=False))
        self._surface, self._boundary, self._shape = mesh, boundary, (nu, nv)
        self.clear_frame()
        self.clear_overlays()
        self._apply_surface_visibility()
        self._home = self._home_direction(normals)
        self.reset_camera()

    @staticmethod
    def _home_direction(normals) -> np.ndarray:
        """A viewing direction for a new surface: along its mean normal, raised a
        little so its relief shows (an isometric view if the normals cancel out)."""
        d = np.zeros(3) if normals is None else np.asarray(normals, dtype=float).reshape(-1, 3).mean(axis=0)
        if np.linalg.norm(d) < 0.3:
            d = np.array([1.0, 1.0, 1.0])
        d = d / np.linalg.norm(d) + np.array([0.0, 0.0, 0.35])
        return d / np.linalg.norm(d)

    def reset_camera(self) -> None:
        """Look at the surface from its home direction, z up."""
        if self._closed:
            return
        p = self._plotter
        d = self._home
        up = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.95 else np.array([0.0, 1.0, 0.0])
        cam = p.renderer.GetActiveCamera()
        cam.SetFocalPoint(0.0, 0.0, 0.0)
        cam.SetPosition(*d)
        cam.SetViewUp(*up)
        p.reset_camera(render=False)
        cam.SetWindowCenter(0.1, 0.0)  # the piece a little left of the middle: the colour bar is on the right
        cam.Zoom(1.02)
        self.render()

    def clear_frame(self) -> None:
        """Remove the mesh and colour bar (a new surface, or no result); the
        document's darts and constraints stay (see :meth:`set_darts`)."""
        self.layer.clear()
        self._bar.SetVisibility(False)

    def show_frame(self, frame, options: ViewOptions) -> None:
        self.options = options
        self.layer.show(frame, frame.xyz, options)
        self._update_bar()
        self._apply_surface_visibility()
        self.render()

    def restyle(self, options: ViewOptions) -> None:
        self.options = options
        self.layer.restyle(options)
        self._update_bar()
        self._apply_surface_visibility()
        self.render()

    def _apply_surface_visibility(self) -> None:
        for actor in self._surface_actors[:1]:
            actor.SetVisibility(bool(self.options.surface))

    def _update_bar(self) -> None:
        if self.layer.frame is None:
            self._bar.SetVisibility(False)
            return
        scale = self.layer.active_scale
        self._bar.SetLookupTable(scale.ctf)
        self._bar.SetMaximumNumberOfColors(512)
        labels = vtkDoubleArray()
        if self.options.mode == "shear":
            self._bar.SetTitle("shear (deg)")
            values = [0.0, self.options.shear_warning_deg, self.options.shear_limit_deg, scale.range[1]]
        else:
            self._bar.SetTitle("strain (%)")
            lo, hi = scale.range
            values = [lo, lo / 2, 0.0, hi / 2, hi]
        for v in values:
            labels.InsertNextValue(float(v))
        self._bar.SetCustomLabels(labels)
        self._bar.SetVisibility(True)

    # ------------------------------------------------------------------ the document's darts and yarns
    def clear_overlays(self) -> None:
        """Remove darts, yarns, tool previews and widgets (they belonged to another surface)."""
        self.set_darts([], [], None, render=False)
        self.set_yarns([], render=False)
        self.set_preview(render=False)
        self.set_handles(render=False)
        self.set_picked_yarn(render=False)
        self.hide_plane_widget()
        self.hide_box_widget()

    def set_darts(self, curves, visible, selected: int | None = None, render: bool = True) -> None:
        """Draw the document's darts: ``curves`` (k, 3) each on the surface,
        ``visible`` a flag each; dart ``selected`` (if any, and shown) stands out."""
        curves = [np.asarray(c, dtype=float).reshape(-1, 3) for c in curves]
        visible = [bool(v) for v in visible]
        self.dart_curves = [c if v else None for c, v in zip(curves, visible)]
        self.selected_dart = selected
        shown = [c for k, (c, v) in enumerate(zip(curves, visible)) if v and k != selected]
        pts, cells = polyline_cells(shown, closed=False)
        replace_geometry(self._darts, pts, lines=cells)
        sel = [curves[selected]] if selected is not None and 0 <= selected < len(curves) and visible[selected] else []
        pts, cells = polyline_cells(sel, closed=False)
        replace_geometry(self._selected, pts, lines=cells)
        if render:
            self.render()

    def set_yarns(self, polylines, render: bool = True) -> None:
        """Draw the constrained yarns (each (k, 3), its nodes in order)."""
        pts, cells = polyline_cells(polylines, closed=False)
        replace_geometry(self._yarns, pts, lines=cells)
        if render:
            self.render()

    # ------------------------------------------------------------------ what the tools draw
    def set_preview(self, curve=None, points=None, render: bool = True) -> None:
        """The tool's preview: a curve on the surface (k, 3) and marked points (j, 3); None clears."""
        pts, cells = polyline_cells([] if curve is None else [curve], closed=False)
        replace_geometry(self._preview, pts, lines=cells)
        replace_geometry(self._preview_points, np.zeros((0, 3)) if points is None else points, verts=True)
        if render:
            self.render()

    @property
    def preview_curve(self) -> np.ndarray:
        """(k, 3) the preview curve drawn now (empty when none)."""
        return np.array(self._preview.points).reshape(-1, 3)

    @property
    def preview_points(self) -> np.ndarray:
        return np.array(self._preview_points.points).reshape(-1, 3)

    def set_handles(self, points=None, render: bool = True) -> None:
        """A curve dart's handles (h, 3) as draggable dots; None hides them."""
        replace_geometry(self._handles, np.zeros((0, 3)) if points is None else points, verts=True)
        if render:
            self.render()

    @property
    def handle_points(self) -> np.ndarray:
        return np.array(self._handles.points).reshape(-1, 3)

    def set_picked_yarn(self, polyline=None, node=None, render: bool = True) -> None:
        """Highlight a picked yarn (its nodes in order, (k, 3)) and the picked node (3,)."""
        pts, cells = polyline_cells([] if polyline is None else [polyline], closed=False)
        replace_geometry(self._pick, pts, lines=cells)
        replace_geometry(self._pick_node, np.zeros((0, 3)) if node is None else np.reshape(node, (1, 3)), verts=True)
        if render:
            self.render()

    @property
    def picked_yarn_points(self) -> np.ndarray:
        return np.array(self._pick.points).reshape(-1, 3)

    # ------------------------------------------------------------------ plane dart widgets
    def show_plane_widget(self, origin, normal, bounds, on_change: Callable) -> None:
        """A plane the user moves (drag the plane along its normal, the arrow to
        turn it, the centre to slide it); ``on_change(origin, normal)`` while it moves."""
        self.hide_plane_widget()
        w = vtkImplicitPlaneWidget()
        w.SetInteractor(self._plotter.iren.interactor)
        w.SetCurrentRenderer(self._plotter.renderer)
        w.SetPlaceFactor(1.0)
        w.PlaceWidget(*[float(b) for b in bounds])
        w.SetOrigin(*[float(x) for x in origin])
        w.SetNormal(*[float(x) for x in normal])
        w.DrawPlaneOn()
        w.OutlineTranslationOff()
        w.ScaleEnabledOff()
        w.TubingOff()
        w.GetPlaneProperty().SetColor(1.0, 0.5, 0.0)
        w.GetPlaneProperty().SetOpacity(0.25)
        w.GetOutlineProperty().SetOpacity(0.15)

        def moved(widget, _event):
            on_change(np.array(widget.GetOrigin()), np.array(widget.GetNormal()))
        w.AddObserver("InteractionEvent", moved)
        w.On()
        self.plane_widget = w
        self.render()

    def set_plane_widget(self, origin, normal) -> None:
        if self.plane_widget is not None:
            self.plane_widget.SetOrigin(*[float(x) for x in origin])
            self.plane_widget.SetNormal(*[float(x) for x in normal])
            self.render()

    def plane_widget_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(origin, unit normal) of the plane widget, or None when it is not shown."""
        w = self.plane_widget
        return None if w is None else (np.array(w.GetOrigin()), np.array(w.GetNormal()))

    def hide_plane_widget(self) -> None:
        if self.plane_widget is not None:
            self.plane_widget.Off()
            self.plane_widget.SetInteractor(None)
            self.plane_widget = None
            self.render()

    def show_box_widget(self, bounds, on_change: Callable) -> None:
        """An axis-aligned box the user resizes (face handles) and moves (centre);
        ``on_change(bounds)`` while it changes, bounds (xmin, xmax, ymin, ymax, zmin, zmax)."""
        self.hide_box_widget()
        w = vtkBoxWidget()
        w.SetInteractor(self._plotter.iren.interactor)
        w.SetCurrentRenderer(self._plotter.renderer)
        w.SetPlaceFactor(1.0)
        w.RotationEnabledOff()
        w.PlaceWidget(*[float(b) for b in bounds])
        w.GetOutlineProperty().SetColor(1.0, 0.5, 0.0)

        def changed(widget, _event):
            on_change(self.box_widget_bounds())
        w.AddObserver("InteractionEvent", changed)
        w.On()
        self.box_widget = w
        self.render()

    def set_box_widget(self, bounds) -> None:
        if self.box_widget is not None:
            self.box_widget.PlaceWidget(*[float(b) for b in bounds])
            self.render()

    def box_widget_bounds(self) -> tuple | None:
        if self.box_widget is None:
            return None
        poly = pv.PolyData()
        self.box_widget.GetPolyData(poly)
        return tuple(float(b) for b in poly.bounds)

    def hide_box_widget(self) -> None:
        if self.box_widget is not None:
            self.box_widget.Off()
            self.box_widget.SetInteractor(None)
            self.box_widget = None
            self.render()

    # ------------------------------------------------------------------ camera and picking
    def pick_ray(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray]:
        """The viewing ray through display point (x, y) (VTK's, origin bottom
        left): its point on the near clipping plane and its direction (unit,
        into the scene). For a perspective camera every pixel has its own ray."""
        ren = self._plotter.renderer
        ends = []
        for z in (0.0, 1.0):
            ren.SetDisplayPoint(float(x), float(y), z)
            ren.DisplayToWorld()
            w = np.array(ren.GetWorldPoint(), dtype=float)
            ends.append(w[:3] / w[3])
        d = ends[1] - ends[0]
        return ends[0], d / np.linalg.norm(d)

    def view_direction(self) -> np.ndarray:
        """(3,) unit direction from the camera into the scene (its direction of projection)."""
        d = np.array(self._plotter.renderer.GetActiveCamera().GetDirectionOfProjection(), dtype=float)
        return d / np.linalg.norm(d)

    def display_points(self, xyz) -> np.ndarray:
        """(k, 2) display coordinates (VTK's, origin bottom left) of world points (k, 3)."""
        xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
        return np.array([self.display_point(p) for p in xyz]).reshape(-1, 2)

    def look(self, position, focal_point, view_up) -> None:
        """Put the camera at ``position`` looking at ``focal_point``, ``view_up`` up."""
        cam = self._plotter.renderer.GetActiveCamera()
        cam.SetPosition(*[float(x) for x in position])
        cam.SetFocalPoint(*[float(x) for x in focal_point])
        cam.SetViewUp(*[float(x) for x in view_up])
        self._plotter.renderer.ResetCameraClippingRange()
        self.render()

    def _on_tool_event(self, iren, event: str) -> None:
        handler = self.mouse_handler
        if handler is None or self._closed:
            return
        x, y = iren.GetEventPosition()
        if event == "LeftButtonPressEvent":
            taken = handler.press(x, y, iren.GetRepeatCount() > 0)
        elif event == "MouseMoveEvent":
            taken = handler.move(x, y)
        else:
            taken = handler.release(x, y)
        if taken:  # the camera (and any widget) does not see this event
            iren.GetCommand(self._tool_tags[event]).SetAbortFlag(1)

    def close(self) -> None:
        if not self._closed:
            self.mouse_handler = None
            self.hide_plane_widget()
            self.hide_box_widget()
        super().close()
