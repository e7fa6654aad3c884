"""The 3D view: an adapter that owns every pyvista / VTK object of the app.

The rest of the app hands it plain numpy arrays and Qt widgets get its
:attr:`SurfaceView.widget`; nothing else imports pyvista or VTK.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv
from pyvistaqt import QtInteractor

SURFACE_COLOR = "#d8c3a5"
EDGE_COLOR = "#3b3b3b"
BACKGROUND_BOTTOM = "#f7f7f5"
BACKGROUND_TOP = "#c9d3de"


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


class SurfaceView:
    """A pyvistaqt render widget showing one gridded surface.

    ``set_surface`` replaces the surface; ``update_points`` moves its points
    in place (for live updates). Call :meth:`close` before the owning window
    is destroyed.
    """

    def __init__(self, parent=None):
        # auto_update=False: we render when something changed, not on a timer.
        self._plotter = QtInteractor(parent, auto_update=False)
        self._plotter.set_background(BACKGROUND_BOTTOM, top=BACKGROUND_TOP)
        self._plotter.add_axes()
        self._surface: pv.PolyData | None = None
        self._boundary: pv.PolyData | None = None
        self._actors: list = []
        self._shape: tuple[int, int] | None = None
        self._closed = False

    # ------------------------------------------------------------------ access
    @property
    def widget(self):
        """The QWidget to put in a layout."""
        return self._plotter.interactor

    @property
    def surface_points(self) -> np.ndarray | None:
        """(nu * nv, 3) float, a copy of the shown surface's points (row i*nv + j), or None."""
        return None if self._surface is None else np.array(self._surface.points)

    @property
    def surface_shape(self) -> tuple[int, int] | None:
        """(nu, nv) of the shown grid, or None."""
        return self._shape

    # ------------------------------------------------------------------ content
    def set_surface(self, xyz: np.ndarray, normals: np.ndarray | None = None) -> None:
        """Show a new surface and fit the camera to it.

        xyz : (nu, nv, 3) float, grid points; normals : (nu, nv, 3) float or None,
        unit normals at them (used for smooth shading).
        """
        xyz = np.asarray(xyz, dtype=float)
        nu, nv = xyz.shape[:2]
        for actor in self._actors:
            self._plotter.remove_actor(actor, render=False)
        self._actors.clear()

        mesh = pv.PolyData(xyz.reshape(-1, 3).copy(), grid_faces(nu, nv))
        if normals is not None:
            mesh.point_data["Normals"] = np.asarray(normals, dtype=float).reshape(-1, 3)
            mesh.point_data.active_normals_name = "Normals"
        loop = grid_boundary(nu, nv)
        # lines= in the constructor: no vertex cells, so the grid points are not drawn
        boundary = pv.PolyData(mesh.points.copy(), lines=np.concatenate([[loop.size], loop]))

        surface_actor = self._plotter.add_mesh(
            mesh, color=SURFACE_COLOR, specular=0.2, name="surface",
            render=False, reset_camera=False)
        surface_actor.prop.interpolation = "phong"  # with the exact normals given
        self._actors.append(surface_actor)
        self._actors.append(self._plotter.add_mesh(
            boundary, color=EDGE_COLOR, line_width=2, name="boundary",
            render=False, reset_camera=False))
        self._surface, self._boundary, self._shape = mesh, boundary, (nu, nv)
        self._plotter.reset_camera()
        self._plotter.render()

    def update_points(self, xyz: np.ndarray, normals: np.ndarray | None = None) -> None:
        """Move the shown surface's points in place; xyz : (nu, nv, 3) of the current shape."""
        if self._surface is None or np.shape(xyz)[:2] != self._shape:
            self.set_surface(xyz, normals)
            return
        self._surface.points[:] = np.asarray(xyz, dtype=float).reshape(-1, 3)
        if normals is not None:
            self._surface.point_data["Normals"][:] = np.asarray(normals, dtype=float).reshape(-1, 3)
        self._boundary.points[:] = self._surface.points
        self._plotter.render()

    def reset_camera(self) -> None:
        self._plotter.reset_camera()
        self._plotter.render()

    # ------------------------------------------------------------------ output
    def is_ready(self) -> bool:
        """True once the GL window can render (wait for this before screenshots)."""
        rw = self._plotter.render_window
        return bool(rw is not None and rw.GetReadyForRendering())

    def render(self) -> None:
        self._plotter.render()

    def screenshot(self, path) -> None:
        """Write the 3D view (without the window around it) to an image file."""
        self._plotter.screenshot(str(path))

    def close(self) -> None:
        """Release the render window; safe to call twice."""
        if not self._closed:
            self._closed = True
            self._actors.clear()
            self._surface = self._boundary = None
            self._plotter.close()
