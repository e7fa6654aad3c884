"""The 3D view: the surface, the spring mesh on it coloured by strain (or its
cells by shear), boundary and dart nodes, the darts' curves and a colour bar.

It owns its pyvista objects; the rest of the app hands it numpy arrays and
:class:`~app.frames.Frame` s (see :mod:`app.viewbase`).
"""

from __future__ import annotations

import numpy as np
import pyvista as pv
from vtkmodules.vtkCommonCore import vtkDoubleArray
from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor

from app.viewbase import ViewBase, ViewOptions, polyline_cells, replace_geometry

__all__ = ["SurfaceView", "grid_faces", "grid_boundary"]

SURFACE_COLOR = "#d8c3a5"
EDGE_COLOR = "#3b3b3b"
DART_COLOR = "#111111"
TEXT_COLOR = (0.1, 0.1, 0.1)


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
        self._darts = pv.PolyData()
        self._dart_actor = p.add_mesh(self._darts, color=DART_COLOR, line_width=3, render=False,
                                      reset_camera=False, pickable=False)
        self._dart_curves: tuple = ()
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
        """Remove the mesh, darts and colour bar (a new surface, or no result)."""
        self.layer.clear()
        self._dart_curves = ()
        replace_geometry(self._darts, np.zeros((0, 3)))
        self._bar.SetVisibility(False)

    def show_frame(self, frame, options: ViewOptions, render: bool = True) -> None:
        self.options = options
        self.layer.show(frame, frame.xyz, options)
        if frame.dart_curves is not self._dart_curves:  # cached per run: redrawn once
            self._dart_curves = frame.dart_curves
            pts, cells = polyline_cells(frame.dart_curves, closed=False)
            replace_geometry(self._darts, pts, lines=cells)
        self._update_bar()
        self._apply_surface_visibility()
        if render:
            self.render()

    def restyle(self, options: ViewOptions, render: bool = True) -> None:
        self.options = options
        self.layer.restyle(options)
        self._update_bar()
        self._apply_surface_visibility()
        if render:
            self.render()

    def _apply_surface_visibility(self) -> None:
        for actor in self._surface_actors[:1]:
            actor.SetVisibility(bool(self.options.surface))
        self._dart_actor.SetVisibility(self.layer.frame is not None)

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
