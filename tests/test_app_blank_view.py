"""The 3D view stays drawn after a document of a very different size.

The views empty their overlays (darts, previews, yarns, a frame's node
spheres) in place when a new document opens. An emptied layer must hold no
bounds: VTK sets the camera's clipping range from the bounds of every visible
actor, so a layer that still reported the geometry it held before (a dart on
a piece a hundred units across) put the far plane a hundred units away and,
at VTK's near/far ratio of 1/1000, the near plane beyond a piece a
thousandth across: the 3D view showed only its axes and colour bars.

The pixels and the frustum are read back from the widget and VTK's camera
(tests/soak.py's checks, which the soak makes after every edit)."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from vtkmodules.vtkCommonCore import vtkMath
from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper

from flatweave.app.viewbase import polyline_cells, replace_geometry
from flatweave.method.darts import PlaneDart
from flatweave.reading.examples import load_example
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.document.project import new_project

from tests.soak import drawn_share, frustum, view_image


def scaled(surface: NurbsSurface, factor: float) -> NurbsSurface:
    return NurbsSurface(surface.degree_u, surface.degree_v, surface.knots_u, surface.knots_v,
                        surface.ctrlpts * factor, surface.weights)


def actor_of(poly):
    mapper = vtkPolyDataMapper()
    mapper.SetInputData(poly)
    actor = vtkActor()
    actor.SetMapper(mapper)
    return actor


@pytest.mark.parametrize("form", ["lines", "verts", "faces"])
def test_an_emptied_layer_reports_no_bounds(form):
    pts = np.array([[30.0, -33.0, -17.0], [82.0, 41.0, 8.0], [50.0, 0.0, 0.0]])
    poly = pv.PolyData()
    actor = actor_of(poly)
    full = {"lines": dict(lines=polyline_cells([pts], closed=False)[1]), "verts": dict(verts=True),
            "faces": dict(faces=np.array([3, 0, 1, 2]))}[form]
    replace_geometry(poly, pts, **full)
    np.testing.assert_allclose(actor.GetBounds(), [30, 82, -33, 41, -17, 8])
    empty = {"lines": dict(lines=np.zeros(0, dtype=np.int64)), "verts": dict(verts=True),
             "faces": dict(faces=None)}[form]
    replace_geometry(poly, np.zeros((0, 3)), **empty)
    assert poly.n_points == 0
    assert not vtkMath.AreBoundsInitialized(actor.GetBounds()), actor.GetBounds()
    replace_geometry(poly, pts[:2] * 0.5, lines=polyline_cells([pts[:2] * 0.5], closed=False)[1])
    np.testing.assert_allclose(actor.GetBounds(), [15, 41, -16.5, 20.5, -8.5, 4])  # filled again: the new geometry


def test_a_tiny_piece_after_a_large_one_with_a_dart_is_drawn(each_widget, make_window, qtbot):
    """The saddle a hundred times over with a plane dart across it, drawn; then the octant a
    thousandth of its size (it sits at the middle of where the dart was): the small piece is inside
    the frustum, not clipped, and covers a good share of the view."""
    win = make_window(new_project(scaled(load_example("saddle"), 100.0), "large", None, 10.0))
    win.dart_edit(win.document.add_dart, PlaneDart((1.0, 0.0, 0.0, 0.0), (-1, 1, -200, 200, -200, 200),
                                                   name="dart"))
    assert len(win.view.dart_curves) == 1 and np.ptp(win.view.dart_curves[0], axis=0).max() > 150
    win.view.render_now()  # the dart is drawn (the renderer has asked its actor for its bounds)
    win.set_project(new_project(scaled(load_example("octant"), 1e-3), "tiny", None, 1.2e-4))
    view = win.view
    view.render_now()
    assert view.dart_curves == []
    points = view.surface_points
    assert np.ptp(points, axis=0).max() < 0.0011
    inside, cut, n = frustum(view, points)
    near, far = view.plotter.renderer.GetActiveCamera().GetClippingRange()
    assert inside == n and cut == 0, f"{cut} of {n} points clipped by the range ({near:.4g}, {far:.4g})"
    assert far < 0.1  # the range is the tiny piece's, not the large one's
    bars = [(1.0 - view.bar_column_fraction(), 0.0, 1.0, 1.0), (0.0, 0.8, 0.2, 1.0)]  # colour bars, axes
    view.render()
    qtbot.waitUntil(lambda: drawn_share(view, view_image(view), bars) > 0.1, timeout=5000)
