"""The 3D view: the surface, the spring mesh on it coloured by strain (or its
cells by shear), boundary and dart nodes, the darts' curves and a colour bar,
and what the tools draw over them (:mod:`flatweave.app.tools`): the dart being drawn,
a curve dart's handles, a plane dart's plane and box widgets, constrained and
picked yarns.

It owns its pyvista and VTK objects; the rest of the app hands it numpy arrays
and :class:`~flatweave.app.frames.Frame` s (see :mod:`flatweave.app.viewbase`), and gets display
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
from vtkmodules.vtkRenderingCore import (vtkActor2D, vtkCellPicker, vtkColorTransferFunction, vtkCoordinate,
                                         vtkPolyDataMapper2D)

from flatweave.app.camera import fit_view, home_view
from flatweave.app.overlay import PREVIEW, LayerStyle
from flatweave.app.viewbase import SCALE_TITLES, ViewBase, ViewOptions, polyline_cells, replace_geometry, text_size

__all__ = ["SurfaceView", "FaceView", "MeshLoopView", "grid_faces", "grid_boundary", "bar_labels"]

SURFACE_COLOR = "#d8c3a5"
EDGE_COLOR = "#3b3b3b"
DART_COLOR = "#111111"
SELECTED_COLOR = "#d4145a"
YARN_COLOR = "#6a3d9a"
LOOP_COLOR = "#000000"
FAINT_COLOR = "#c8c8c8"
CHOSEN_COLOR = "#e08a1e"
MESH_COLOR = "#b9c4cf"  # the fitted-to mesh drawn plain (beside the surface)
MESH_EDGE_COLOR = "#55606b"
DEVIATION_STOPS = ((0.0, (0.19, 0.21, 0.58)), (0.5, (0.17, 0.64, 0.56)), (0.8, (0.99, 0.82, 0.18)),
                   (1.0, (0.85, 0.12, 0.12)))  # share of the largest deviation -> RGB: dark blue, teal, yellow, red
BESIDE_GAP = 0.15  # the mesh beside the surface: this share of its width between them
CLICK_SLOP = 4  # pixels: a press and release closer than this is a click (not a turn of the camera)
TEXT_COLOR = (0.1, 0.1, 0.1)
TOOL_PRIORITY = 10.0  # above the camera style (0) and VTK's widgets (0.5): tools see clicks first
VIEW_ANGLE = 30.0  # degrees, vertical (VTK's default)
WHEEL_ZOOM = 1.2  # per wheel step (VTK's trackball style dollies by 1.1 ** 2)
BAR_MARGIN = 8  # pixels between a colour bar and the view's right edge
BAR_PAD = 10  # pixels round a bar's text inside its frame
BAR_RATIO = 0.26  # of a bar's frame width: the colour swatch
BAR_SAMPLE_LABEL = "-00.00"  # the widest label the bars are sized for (format %-#6.3g)


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


def kept_grid_faces(keep: np.ndarray) -> np.ndarray:
    """VTK cell array of the quads of an (nu, nv) grid kept by ``keep``
    ((nu-1, nv-1) bool, quad (i, j) at ``keep[i, j]``): a trimmed piece."""
    keep = np.asarray(keep, dtype=bool)
    cells = grid_faces(keep.shape[0] + 1, keep.shape[1] + 1).reshape(-1, 5)
    return cells[keep.ravel()].ravel()


def grid_boundary(nu: int, nv: int) -> np.ndarray:
    """Indices of the boundary points of an (nu, nv) grid as one closed loop, (k,) int."""
    idx = np.arange(nu * nv).reshape(nu, nv)
    loop = np.concatenate([idx[:, 0], idx[-1, 1:], idx[-2::-1, -1], idx[0, -2:0:-1], idx[:1, 0]])
    return loop


def _scalar_bar() -> vtkScalarBarActor:
    bar = vtkScalarBarActor()
    bar.SetOrientationToVertical()
    bar.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    bar.SetBarRatio(BAR_RATIO)
    bar.DrawBackgroundOn()
    bar.GetBackgroundProperty().SetColor(1.0, 1.0, 1.0)
    bar.GetBackgroundProperty().SetOpacity(0.85)
    bar.SetLabelFormat("%-#6.3g")
    bar.SetVerticalTitleSeparation(6)
    bar.SetTextPad(4)
    bar.UnconstrainedFontSizeOn()
    for prop, size, bold in ((bar.GetTitleTextProperty(), 14, True), (bar.GetLabelTextProperty(), 13, False)):
        prop.SetColor(*TEXT_COLOR)
        prop.SetFontSize(size)
        prop.SetBold(bold)
        prop.SetItalic(False)
        prop.SetShadow(False)
    bar.GetTitleTextProperty().SetJustificationToCentered()
    bar.SetUseCustomLabels(True)
    bar.SetPickable(False)
    bar.SetVisibility(False)
    return bar


def bar_labels(lo: float, hi: float, gap: float = 0.09) -> list[float]:
    """The labelled values of a strain bar from ``lo`` (< 0) to ``hi`` (> 0):
    both ends, then 0 and the halves, each only if it is at least ``gap`` of
    the span from every label kept (an asymmetric scale's labels never overlap)."""
    span = max(hi - lo, 1e-300)
    kept = [lo, hi]
    for v in (0.0, lo / 2, hi / 2):
        if all(abs(v - k) >= gap * span for k in kept):
            kept.append(v)
    return sorted(kept)


class _Layer:
    """A named overlay layer's data and actors (see ``SurfaceView.draw``)."""

    def __init__(self, plotter, style: LayerStyle):
        self.style = style
        self.lines, self.points = pv.PolyData(), pv.PolyData()
        self.line_actor = plotter.add_mesh(self.lines, color=style.color, line_width=style.width, render=False,
                                           reset_camera=False, pickable=False)
        if style.marker == "square":
            # 2D squares placed at world points, drawn after the 3D scene: always visible
            self.point_actors = []
            for colour, size in ((style.edge, style.edge_size), (style.color, style.size)):
                world = vtkCoordinate()
                world.SetCoordinateSystemToWorld()
                mapper = vtkPolyDataMapper2D()
                mapper.SetInputData(self.points)
                mapper.SetTransformCoordinate(world)
                actor = vtkActor2D()
                actor.SetMapper(mapper)
                actor.GetProperty().SetColor(*pv.Color(colour).float_rgb)
                actor.GetProperty().SetPointSize(size)
                actor.SetPickable(False)
                plotter.renderer.AddViewProp(actor)
                self.point_actors.append(actor)
        else:
            self.point_actors = [plotter.add_mesh(self.points, color=style.color, point_size=style.size,
                                                  render_points_as_spheres=True, render=False, reset_camera=False,
                                                  pickable=False)]

    def remove(self, plotter) -> None:
        plotter.remove_actor(self.line_actor, render=False)
        for actor in self.point_actors:
            plotter.renderer.RemoveViewProp(actor)


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
        self.loops: list[np.ndarray] = []  # a trimmed piece's loops as drawn ((k, 3) each); [] untrimmed
        self._fit_points = np.zeros((0, 3))  # what the home view frames
        self.kept_cells = 0  # the surface's quads drawn (fewer than the grid's for a trimmed piece)

        def overlay(color, line_width=3.0, points=False, size=12.0):
            poly = pv.PolyData()
            kw = (dict(point_size=size, render_points_as_spheres=True) if points else dict(line_width=line_width))
            actor = p.add_mesh(poly, color=color, render=False, reset_camera=False, pickable=False, **kw)
            return poly, actor

        self._darts, self._dart_actor = overlay(DART_COLOR, 3.0)
        self._selected, self._selected_actor = overlay(SELECTED_COLOR, 5.0)
        self._yarns, self._yarns_actor = overlay(YARN_COLOR, 4.0)
        self._layers: dict[str, _Layer] = {}  # named overlay layers (draw), made on first use
        self.dart_curves: list = []  # the document's darts as drawn: (k, 3) each, or None when hidden
        self.selected_dart: int | None = None
        self.plane_widget: vtkImplicitPlaneWidget | None = None
        self.box_widget: vtkBoxWidget | None = None
        self.mouse_handler = None  # an object with press(x, y, double), move(x, y), release(x, y) -> bool
        iren = p.iren.interactor
        self._tool_tags = {event: iren.AddObserver(event, self._on_tool_event, TOOL_PRIORITY)
                           for event in ("LeftButtonPressEvent", "MouseMoveEvent", "LeftButtonReleaseEvent")}
        self._bars = [_scalar_bar(), _scalar_bar()]  # threads (or shear) above, diagonals below
        for bar in self._bars:
            p.renderer.AddViewProp(bar)
        self._bar = self._bars[0]
        self._bar_layout = None
        self._framed = None  # (size, camera) of the last home framing
        self._bar_width_px = self._bar_column()
        p.renderer.AddObserver("StartEvent", self._on_render_start)
        self.options = ViewOptions()
        self._home = (np.array([-1.0, 1.0, -1.0]) / np.sqrt(3.0), np.array([0.0, 0.0, 1.0]))
        self._fit_poly: pv.PolyData | None = None  # the mesh the surface was fitted to (set_fit_mesh)
        self._fit_actor = None
        self._fit_offset = np.zeros(3)
        self._fit_beside = False  # the camera frames the mesh beside the surface too
        self._surface_fit_points = None  # what the home view frames without it
        self._fit_ctf = vtkColorTransferFunction()
        self._fit_ctf.SetColorSpaceToRGB()
        self._fit_ctf.ClampingOn()
        self._fit_bar = _scalar_bar()  # the deviation's scale, left of the view (the right column is the frame's)
        self._fit_bar.SetLookupTable(self._fit_ctf)
        p.renderer.AddViewProp(self._fit_bar)
        self._wheel_tags = {event: iren.AddObserver(event, self._on_wheel, TOOL_PRIORITY)
                            for event in ("MouseWheelForwardEvent", "MouseWheelBackwardEvent")}

    # ------------------------------------------------------------------ access
    @property
    def surface_points(self) -> np.ndarray | None:
        """(nu * nv, 3) float, a copy of the shown surface's points (row i*nv + j), or None; a
        trimmed piece's cut quads add their points after these (``set_surface``'s ``cut``)."""
        return None if self._surface is None else np.array(self._surface.points)

    @property
    def surface_shape(self) -> tuple[int, int] | None:
        """(nu, nv) of the shown grid, or None."""
        return self._shape

    @property
    def colour_bar_title(self) -> str | None:
        """The first colour bar's title (threads, or shear), None when no bar is shown."""
        return self._bar.GetTitle() if self._bar.GetVisibility() else None

    @property
    def colour_bar_range(self) -> tuple[float, float]:
        return self.layer.active_scale.range

    @property
    def colour_bars(self) -> list[tuple[str, tuple[float, float]]]:
        """(title, (lo, hi)) of every colour bar shown, top to bottom."""
        return [(bar.GetTitle(), (float(bar.GetLookupTable().GetRange()[0]), float(bar.GetLookupTable().GetRange()[1])))
                for bar in self._bars if bar.GetVisibility()]

    def colour_bar_boxes(self) -> list[tuple[float, float, float, float]]:
        """(x0, y0, x1, y1) display pixels of every colour bar shown (its frame)."""
        w, h = self.device_size()
        out = []
        for bar in self._bars:
            if bar.GetVisibility():
                x, y = bar.GetPosition()
                bw, bh = bar.GetWidth(), bar.GetHeight()
                out.append((x * w, y * h, (x + bw) * w, (y + bh) * h))
        return out

    def title_size(self, title: str) -> tuple[int, int]:
        """(width, height) pixels of a colour bar title as drawn."""
        return text_size(self._bar.GetTitleTextProperty(), title, self._dpi())

    def _dpi(self) -> int:
        return int(self._plotter.render_window.GetDPI())

    def _bar_column(self) -> int:
        """The colour bars' frame width in pixels: room for the widest title and label."""
        title = max(self.title_size(line)[0] for t in SCALE_TITLES.values() for line in t.split("\n"))
        label = text_size(self._bar.GetLabelTextProperty(), BAR_SAMPLE_LABEL, self._dpi())[0]
        return int(max(title + 2 * BAR_PAD, (label + 2 * BAR_PAD) / (1.0 - BAR_RATIO)))

    def bar_column_fraction(self) -> float:
        """The share of the view's width the colour bars' column takes (the camera frames the rest)."""
        w = self.device_size()[0]
        return min(0.45, (self._bar_width_px + 2 * BAR_MARGIN) / w)

    # ------------------------------------------------------------------ content
    def set_surface(self, xyz: np.ndarray, normals: np.ndarray | None = None, keep: np.ndarray | None = None,
                    loops=None, fit: bool = True, cut=None) -> None:
        """Show a new surface, clear the mesh and fit the camera.

        xyz : (nu, nv, 3) float, grid points; normals : (nu, nv, 3) float or None,
        unit normals at them (used for smooth shading). A trimmed piece: ``keep``
        ((nu-1, nv-1) bool) the grid's quads drawn whole, ``cut`` the quads its
        loops cross, cut to it (``(points (m, 3), normals (m, 3), triangles (t, 3),
        cells (c,))``: triangles into the grid's points followed by these, the flat
        indices of the quads cut; :class:`flatweave.app.presenter.PieceCut`), and ``loops`` its
        boundary loops on the surface ((k, 3) each, closed implicitly), drawn
        as black lines instead of the grid's rim. ``kept_cells`` counts the quads
        drawn, whole or cut. ``fit`` False: the camera stays.
        """
        xyz = np.asarray(xyz, dtype=float)
        nu, nv = xyz.shape[:2]
        p = self._plotter
        for actor in self._surface_actors:
            p.remove_actor(actor, render=False)
        self._surface_actors.clear()

        faces = grid_faces(nu, nv) if keep is None else kept_grid_faces(keep)
        points = xyz.reshape(-1, 3)
        point_normals = None if normals is None else np.asarray(normals, dtype=float).reshape(-1, 3)
        if cut is not None:
            cut_points, cut_normals, triangles, cut_cells = cut
            triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
            faces = np.concatenate([faces, np.column_stack([np.full(len(triangles), 3), triangles]).ravel()])
            points = np.vstack([points, np.asarray(cut_points, dtype=float).reshape(-1, 3)])
            if point_normals is not None:
                point_normals = np.vstack([point_normals, np.asarray(cut_normals, dtype=float).reshape(-1, 3)])
        mesh = pv.PolyData(points.copy(), faces)
        if point_normals is not None:
            mesh.point_data["Normals"] = point_normals
            mesh.point_data.active_normals_name = "Normals"
        if loops is None:
            loop = grid_boundary(nu, nv)
            # lines= in the constructor: no vertex cells, so the grid points are not drawn
            boundary = pv.PolyData(xyz.reshape(-1, 3).copy(), lines=np.concatenate([[loop.size], loop]))
        else:
            pts, cells = polyline_cells([np.asarray(c, dtype=float).reshape(-1, 3) for c in loops], closed=True)
            boundary = pv.PolyData(pts, lines=cells) if len(pts) else pv.PolyData()
        self.loops = [] if loops is None else [np.asarray(c, dtype=float).reshape(-1, 3) for c in loops]
        self.kept_cells = int(mesh.n_cells) if cut is None else int(np.count_nonzero(keep)) + len(cut_cells)

        surface_actor = p.add_mesh(mesh, color=SURFACE_COLOR, specular=0.2, name=f"{self._name}-surface",
                                   render=False, reset_camera=False, pickable=False)
        surface_actor.prop.interpolation = "phong"  # with the exact normals given
        # the springs are chords a hair inside a convex surface: push the surface back in depth
        mapper = surface_actor.GetMapper()
        mapper.SetResolveCoincidentTopologyToPolygonOffset()
        mapper.SetRelativeCoincidentTopologyPolygonOffsetParameters(4.0, 600.0)
        self._surface_actors.append(surface_actor)
        if boundary.n_points:
            self._surface_actors.append(p.add_mesh(
                boundary, color=EDGE_COLOR if loops is None else LOOP_COLOR, line_width=2 if loops is None else 3,
                name=f"{self._name}-rim", render=False, reset_camera=False, pickable=False))
        self._surface, self._boundary, self._shape = mesh, boundary, (nu, nv)
        self.clear_frame()
        self.clear_overlays()
        self.clear_fit_mesh()
        self._apply_surface_visibility()
        self._fit_points = np.asarray(mesh.points)
        self._home = home_view(xyz, normals)
        used = np.zeros(len(points), dtype=bool)
        if keep is not None:
            used[kept_grid_faces(keep).reshape(-1, 5)[:, 1:].ravel()] = True
        if cut is not None:
            used[triangles.ravel()] = True
        if used.any():  # a trimmed piece: the camera frames the piece, not the whole patch
            self._fit_points = self._fit_points[used]
            self._home = home_view(self._fit_points, None if point_normals is None else point_normals[used])
        if fit:
            self.reset_camera()
        else:
            self.render()

    @property
    def home(self) -> tuple[np.ndarray, np.ndarray]:
        """(direction into the scene, view up) of the surface's home view (see :mod:`flatweave.app.camera`)."""
        return self._home

    def reset_camera(self) -> None:
        """Frame the surface from its home direction (a three-quarter view, z up)
        so it fills the view left of the colour bars."""
        if self._closed:
            return
        if self._surface is None:
            self._plotter.reset_camera(render=False)
        else:
            self._fit_home()
            self.update_density()
        self.render()

    def _fit_home(self) -> None:
        p = self._plotter
        w, h = self.device_size()
        frame = fit_view(np.asarray(self._fit_points), *self._home, aspect=w / h,
                         region=(0.0, 1.0 - self.bar_column_fraction(), 0.0, 1.0), view_angle=VIEW_ANGLE)
        cam = p.renderer.GetActiveCamera()
        cam.ParallelProjectionOff()
        cam.SetViewAngle(VIEW_ANGLE)
        cam.SetFocalPoint(*frame.focal_point)
        cam.SetPosition(*frame.position)
        cam.SetViewUp(*frame.view_up)
        cam.SetWindowCenter(*frame.window_center)
        p.renderer.ResetCameraClippingRange()
        self._framed = ((w, h), self._camera_state())

    def _camera_state(self) -> tuple:
        cam = self._plotter.renderer.GetActiveCamera()
        return (*cam.GetPosition(), *cam.GetFocalPoint(), *cam.GetViewUp(), *cam.GetWindowCenter(),
                cam.GetViewAngle(), cam.GetParallelProjection())

    def _refit_if_resized(self) -> None:
        """The view changed size while the camera still shows the home framing
        (nobody moved it): frame again for the new size (the window's first
        layout, a moved splitter, a resized window)."""
        framed = self._framed
        if framed is not None and self._surface is not None and framed[0] != self.device_size() \
                and framed[1] == self._camera_state():
            self._fit_home()
            self.update_density()

    # ------------------------------------------------------------------ the wheel
    def zoom_at(self, x: float, y: float, factor: float) -> None:
        """Move the camera ``factor`` times closer (< 1: away) to the point of its
        focal plane under display point (x, y), which stays under it."""
        cam = self._plotter.renderer.GetActiveCamera()
        origin, ray = self.pick_ray(x, y)
        focal = np.array(cam.GetFocalPoint())
        pos = np.array(cam.GetPosition())
        d = self.view_direction()
        along = float(np.dot(ray, d))
        target = origin + ray * (float(np.dot(focal - origin, d)) / along) if along > 1e-9 else focal
        cam.SetPosition(*(target + (pos - target) / factor))
        cam.SetFocalPoint(*(target + (focal - target) / factor))
        self._plotter.renderer.ResetCameraClippingRange()
        self.update_density()
        self.render()

    def _on_wheel(self, iren, event: str) -> None:
        if self._closed:
            return
        x, y = iren.GetEventPosition()
        self.zoom_at(x, y, WHEEL_ZOOM if event == "MouseWheelForwardEvent" else 1.0 / WHEEL_ZOOM)
        iren.GetCommand(self._wheel_tags[event]).SetAbortFlag(1)  # not the style's zoom as well

    def clear_frame(self) -> None:
        """Remove the mesh and colour bar (a new surface, or no result); the
        document's darts and constraints stay (see :meth:`set_darts`)."""
        self.layer.clear()
        for bar in self._bars:
            bar.SetVisibility(False)

    def show_frame(self, frame, options: ViewOptions) -> None:
        self.options = options
        self.layer.show(frame, frame.xyz, options)
        self.update_density()
        self._update_bar()
        self._apply_surface_visibility()
        self.render()

    def restyle(self, options: ViewOptions) -> None:
        self.options = options
        self.layer.restyle(options)
        self._update_bar()
        self._apply_surface_visibility()
        self._apply_fit_mesh()
        self.render()

    def _apply_surface_visibility(self) -> None:
        for actor in self._surface_actors[:1]:
            actor.SetVisibility(bool(self.options.surface))

    def _density_changed(self) -> None:
        self._update_bar()
        self.render()

    def _update_bar(self) -> None:
        """One colour bar per scale in use: shear, or threads and diagonals."""
        scales = [] if self.layer.frame is None else self.layer.shown_scales()
        for k, bar in enumerate(self._bars):
            if k >= len(scales):
                bar.SetVisibility(False)
                continue
            group, scale = scales[k]
            bar.SetLookupTable(scale.ctf)
            bar.SetMaximumNumberOfColors(512)
            bar.SetTitle(SCALE_TITLES[group])
            lo, hi = scale.range
            if group == "shear":
                values = [0.0, self.options.shear_warning_deg, self.options.shear_limit_deg, hi]
            else:
                values = bar_labels(lo, hi)
            labels = vtkDoubleArray()
            for v in values:
                labels.InsertNextValue(float(v))
            bar.SetCustomLabels(labels)
            bar.SetVisibility(True)
        self._bar_layout = None
        self._layout_bars()

    def _on_render_start(self, *_args) -> None:
        self._refit_if_resized()
        self._layout_bars()

    def _layout_bars(self) -> None:
        """Place the shown bars in the right-hand column, sized in pixels (so a
        title is never cut, whatever the view's size); only when the size or
        the bars shown changed."""
        w, h = self.device_size()
        shown = [bar for bar in self._bars if bar.GetVisibility()]
        key = (w, h, len(shown))
        if key == self._bar_layout:
            return
        self._bar_layout = key
        width = self._bar_width_px / w
        x = 1.0 - (self._bar_width_px + BAR_MARGIN) / w
        slots = [(0.1, 0.6)] if len(shown) == 1 else [(0.52, 0.43), (0.05, 0.43)]
        for bar, (y, height) in zip(shown, slots):
            bar.GetPositionCoordinate().SetValue(x, y)
            bar.SetWidth(width)
            bar.SetHeight(height)

    # ------------------------------------------------------------------ the mesh a surface was fitted to
    def set_fit_mesh(self, vertices, triangles, deviation) -> None:
        """Hold the mesh the shown surface was fitted to: ``vertices`` (n, 3),
        ``triangles`` (m, 3) and ``deviation`` (n,), each vertex's distance to the
        surface (:func:`flatweave.geometry.meshfit.vertex_deviation`). It is drawn as the
        options say (``fit_deviation``: coloured by it; ``fit_mesh``: beside the
        surface, else over it); a new surface drops it."""
        self.clear_fit_mesh(render=False)
        V = np.asarray(vertices, dtype=float).reshape(-1, 3)
        F = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        dev = np.asarray(deviation, dtype=float).reshape(-1)
        poly = pv.PolyData(V.copy(), np.column_stack([np.full(len(F), 3), F]).ravel())
        poly.point_data["deviation"] = dev
        top = max(float(dev.max()) if dev.size else 0.0, 1e-300)
        self._fit_ctf.RemoveAllPoints()
        for share, rgb in DEVIATION_STOPS:
            self._fit_ctf.AddRGBPoint(share * top, *rgb)
        actor = self._plotter.add_mesh(poly, color=MESH_COLOR, name=f"{self._name}-fit-mesh", render=False,
                                       reset_camera=False, pickable=False, edge_color=MESH_EDGE_COLOR)
        mapper = actor.GetMapper()
        mapper.SetLookupTable(self._fit_ctf)
        mapper.SetScalarModeToUsePointFieldData()
        mapper.SelectColorArray("deviation")
        mapper.UseLookupTableScalarRangeOn()
        # beside the surface the home view's right: its width and a gap away
        direction, up = self._home
        right = np.cross(direction, up)
        right /= max(float(np.linalg.norm(right)), 1e-300)
        along = V @ right if len(V) else np.zeros(1)
        surf = np.asarray(self._fit_points) @ right if len(self._fit_points) else along
        self._fit_offset = right * (float(surf.max() - along.min()) + BESIDE_GAP * float(np.ptp(along)))
        self._fit_poly, self._fit_actor = poly, actor
        self._surface_fit_points = np.asarray(self._fit_points)
        labels = vtkDoubleArray()
        for v in (0.0, 0.5 * top, top):
            labels.InsertNextValue(v)
        self._fit_bar.SetCustomLabels(labels)
        self._apply_fit_mesh()

    def clear_fit_mesh(self, render: bool = False) -> None:
        """Drop the fitted-to mesh (a new surface)."""
        if self._fit_actor is not None:
            self._plotter.remove_actor(self._fit_actor, render=False)
        if self._fit_beside and self._surface_fit_points is not None:
            self._fit_points = self._surface_fit_points
        self._fit_poly = self._fit_actor = self._surface_fit_points = None
        self._fit_beside = False
        self._fit_bar.SetVisibility(False)
        if render:
            self.render()

    @property
    def fit_mesh_shown(self) -> bool:
        """The fitted-to mesh is drawn (either option on, and a mesh held)."""
        return self._fit_actor is not None and bool(self._fit_actor.GetVisibility())

    @property
    def fit_deviation_values(self) -> np.ndarray | None:
        """(n,) the deviation the mesh's colours map (None without a mesh)."""
        return None if self._fit_poly is None else np.array(self._fit_poly.point_data["deviation"])

    @property
    def fit_colour_range(self) -> tuple[float, float] | None:
        """(lo, hi) of the deviation colour map while it is drawn, else None."""
        a = self._fit_actor
        if a is None or not a.GetVisibility() or not a.GetMapper().GetScalarVisibility():
            return None
        lo, hi = self._fit_ctf.GetRange()
        return float(lo), float(hi)

    @property
    def fit_mesh_offset(self) -> np.ndarray:
        """(3,) how far the mesh is moved from where it is (zero over the surface)."""
        return np.zeros(3) if self._fit_actor is None else np.array(self._fit_actor.GetPosition())

    def _apply_fit_mesh(self) -> None:
        a = self._fit_actor
        if a is None:
            return
        colour, beside = bool(self.options.fit_deviation), bool(self.options.fit_mesh)
        a.SetVisibility(colour or beside)
        a.GetMapper().SetScalarVisibility(colour)
        a.GetProperty().SetEdgeVisibility(not colour)
        a.SetPosition(*(self._fit_offset if beside else np.zeros(3)))
        self._fit_bar.SetVisibility(colour)
        if colour:
            self._fit_bar.SetTitle(f"deviation\n({self.options.units})")
            w, h = self.device_size()
            self._fit_bar.GetPositionCoordinate().SetValue(BAR_MARGIN / w, 0.05)
            self._fit_bar.SetWidth(self._bar_width_px / w)
            self._fit_bar.SetHeight(0.43)
        if beside != self._fit_beside:  # frame what is drawn: the surface, and the mesh beside it
            self._fit_beside = beside
            base = self._surface_fit_points
            self._fit_points = np.vstack([base, np.asarray(self._fit_poly.points) + self._fit_offset]) \
                if beside else base
            if self._surface is not None and not self._closed:
                self._fit_home()
                self.update_density()

    # ------------------------------------------------------------------ the document's darts and yarns
    def clear_overlays(self) -> None:
        """Remove darts, yarns, tool previews and widgets (they belonged to another surface)."""
        self.set_darts([], [], None, render=False)
        self.set_yarns([], render=False)
        self.clear_layers()
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

    # ------------------------------------------------------------------ overlay layers
    def draw(self, name: str, style: LayerStyle, lines=(), points=None, render: bool = True) -> None:
        """Draw overlay layer ``name`` in ``style``: polylines ``lines`` ((k, 3)
        each; closed loops when ``style.closed``) and marked ``points`` ((j, 3)).
        A call with neither clears the layer. A layer is made on its first
        draw and restyled when a later draw brings another style; the view
        knows nothing of who draws it (tools, dialogs, the presenter)."""
        layer = self._layers.get(name)
        if layer is None or layer.style != style:
            if layer is not None:
                layer.remove(self._plotter)
            layer = self._layers[name] = _Layer(self._plotter, style)
        pts, cells = polyline_cells([np.asarray(c, dtype=float).reshape(-1, 3) for c in lines], closed=style.closed)
        replace_geometry(layer.lines, pts, lines=cells)
        replace_geometry(layer.points, np.zeros((0, 3)) if points is None else np.reshape(points, (-1, 3)),
                         verts=True)
        if render:
            self.render()

    def clear_layers(self, names=None, render: bool = False) -> None:
        """Empty the named layers (None: every layer)."""
        for name in list(self._layers) if names is None else names:
            if name in self._layers:
                self.draw(name, self._layers[name].style, render=False)
        if render:
            self.render()

    def layer_lines(self, name: str) -> np.ndarray:
        """(k, 3) the points of layer ``name``'s lines drawn now (empty when none)."""
        layer = self._layers.get(name)
        return np.zeros((0, 3)) if layer is None else np.array(layer.lines.points).reshape(-1, 3)

    def layer_points(self, name: str) -> np.ndarray:
        """(j, 3) layer ``name``'s marked points drawn now (empty when none)."""
        layer = self._layers.get(name)
        return np.zeros((0, 3)) if layer is None else np.array(layer.points.points).reshape(-1, 3)

    def layer_look(self, name: str) -> dict:
        """How layer ``name``'s points are drawn, read back from VTK: ``size``
        (pixels), ``fill`` colour, ``overlay`` (over the 3D scene), ``round``;
        for square markers also ``edge_size`` and ``edge`` (the ring)."""
        layer = self._layers[name]
        fill = layer.point_actors[-1].GetProperty()
        look = {"size": fill.GetPointSize(), "fill": tuple(fill.GetColor()), "overlay": layer.style.marker == "square",
                "round": layer.style.marker != "square"}
        if layer.style.marker == "square":
            edge = layer.point_actors[0].GetProperty()
            look.update(edge_size=edge.GetPointSize(), edge=tuple(edge.GetColor()))
        return look

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


class FaceView(ViewBase):
    """The face picker's 3D view (:mod:`flatweave.app.facepicker`): every face of a CAD
    file as a triangle mesh, the chosen one highlighted and the others faint.
    A left click (a press and release on one spot; a drag turns the camera)
    on a face calls ``on_pick(index)``."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self._plotter.add_axes()
        self._actors: list = []
        self.chosen: int | None = None
        self.shift_pick = False  # whether the last pick was a shift-click
        self.on_pick: Callable[[int], None] | None = None
        self._press: tuple[int, int] | None = None
        self._face_picker = vtkCellPicker()
        self._face_picker.SetTolerance(0.0)
        self._face_picker.PickFromListOn()
        iren = self._plotter.iren.interactor
        for event, callback in (("LeftButtonPressEvent", self._on_press),
                                ("LeftButtonReleaseEvent", self._on_release)):
            # passive: called even while the camera style holds the mouse (it grabs the focus on a press)
            iren.GetCommand(iren.AddObserver(event, callback, TOOL_PRIORITY)).SetPassiveObserver(1)

    def set_faces(self, meshes) -> None:
        """Show the faces: ``meshes`` a (points (n, 3), triangles (m, 3) int) pair each."""
        p = self._plotter
        for actor in self._actors:
            p.remove_actor(actor, render=False)
        self._actors = []
        for k, (pts, tris) in enumerate(meshes):
            tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
            cells = np.column_stack([np.full(len(tris), 3), tris]).ravel()
            mesh = pv.PolyData(np.asarray(pts, dtype=float).reshape(-1, 3), cells)
            self._actors.append(p.add_mesh(mesh, color=FAINT_COLOR, name=f"{self._name}-face{k}", render=False,
                                           reset_camera=False, pickable=True, opacity=0.6))
        self.chosen = None
        p.reset_camera(render=False)
        self.render()

    def select(self, index: int | None, also=()) -> None:
        """Highlight face ``index`` (None: none) and the faces ``also``; the others are drawn faint."""
        self.chosen = index
        lit = set(also) | ({index} if index is not None else set())
        for k, actor in enumerate(self._actors):
            actor.prop.color = CHOSEN_COLOR if k in lit else FAINT_COLOR
            actor.prop.opacity = 1.0 if k in lit else 0.6
        self.render()

    def face_at(self, x: float, y: float) -> int | None:
        """The face under display point (x, y) (VTK's, origin bottom left), or None."""
        if not self._actors:
            return None
        picker = self._face_picker
        picker.InitializePickList()
        for actor in self._actors:
            picker.AddPickList(actor)
        # a ray exactly along an edge of the mesh (a regular mesh seen square on) can slip between its two
        # triangles in the cell locator: a quarter pixel aside, it meets one
        if not any(picker.Pick(float(x) + dx, float(y) + dy, 0.0, self._plotter.renderer)
                   for dx, dy in ((0.0, 0.0), (0.25, 0.25), (-0.25, -0.25))):
            return None
        actor = picker.GetActor()
        for k, a in enumerate(self._actors):
            if actor is not None and a.GetAddressAsString("vtkActor") == actor.GetAddressAsString("vtkActor"):
                return k
        return None

    def _on_press(self, iren, _event) -> None:
        self._press = iren.GetEventPosition()

    def _on_release(self, iren, _event) -> None:
        press, self._press = self._press, None
        if press is None or self._closed:
            return
        x, y = iren.GetEventPosition()
        if abs(x - press[0]) <= CLICK_SLOP and abs(y - press[1]) <= CLICK_SLOP:  # a click, not a camera drag
            self._clicked(iren, x, y)

    def _clicked(self, iren, x: int, y: int) -> None:
        k = self.face_at(x, y)
        self.shift_pick = bool(iren.GetShiftKey())  # the picker adds a face to its choice on a shift-click
        if k is not None and self.on_pick is not None:
            self.on_pick(k)

    def close(self) -> None:
        if not self._closed:
            self.on_pick = None
        super().close()


class MeshLoopView(FaceView):
    """The closed-mesh region picker's view (:mod:`flatweave.app.meshpicker`): the mesh,
    and the loop being drawn on it. A click on the mesh calls
    ``on_point(xyz)`` with the point under the cursor."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.on_point: Callable[[np.ndarray], None] | None = None
        self._loop = pv.PolyData()
        self._loop_actor = self._plotter.add_mesh(self._loop, color=PREVIEW.color, line_width=4, render=False,
                                                  reset_camera=False, pickable=False)
        self._loop_points = pv.PolyData()
        self._loop_points_actor = self._plotter.add_mesh(self._loop_points, color=PREVIEW.color, point_size=12,
                                                         render_points_as_spheres=True, render=False,
                                                         reset_camera=False, pickable=False)
        self.loop = np.zeros((0, 3))

    def set_mesh(self, vertices, triangles) -> None:
        self.set_faces([(vertices, triangles)])
        self.select(0)
        # a click on a scan of 10^5-10^6 triangles: a cell locator makes the pick logarithmic, not linear
        from vtkmodules.vtkCommonDataModel import vtkStaticCellLocator

        locator = vtkStaticCellLocator()
        locator.SetDataSet(self._actors[0].GetMapper().GetInput())
        locator.BuildLocator()
        self._face_picker.RemoveAllLocators()
        self._face_picker.AddLocator(locator)

    def point_at(self, x: float, y: float) -> np.ndarray | None:
        """(3,) the mesh's point under display point (x, y), or None off it."""
        if self.face_at(x, y) is None:
            return None
        return np.array(self._face_picker.GetPickPosition(), dtype=float)

    def set_loop(self, points, closed: bool = True) -> None:
        """Draw the loop's points and the polyline through them (closed from 3 points, unless not ``closed``:
        a seam)."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        self.loop = P.copy()
        pts, cells = polyline_cells([P], closed=closed and len(P) >= 3) if len(P) >= 2 else (np.zeros((0, 3)), None)
        replace_geometry(self._loop, pts, lines=cells)
        replace_geometry(self._loop_points, P, verts=True)
        self.render()

    def _clicked(self, iren, x: int, y: int) -> None:
        p = self.point_at(x, y)
        if p is not None and self.on_point is not None:
            self.on_point(p)

    def close(self) -> None:
        if not self._closed:
            self.on_point = None
        super().close()
