"""GUI tests of what the views show: the camera's framing of every
bundled surface and the wheel's zoom, strain colours per spring kind, coloured
cells for dense meshes, and the layout of the side panel, colour bars, grain
label and handles.

Geometry is read back from VTK (the renderer's world-to-display transform,
the colour functions) and Qt (widget sizes), not from the code's own numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.path import Path as PolygonPath
from PySide6.QtCore import QPoint, QPointF, Qt
from PySide6.QtGui import QWheelEvent
from PySide6.QtWidgets import QApplication, QScrollArea

from flatweave.app.camera import FILL, fit_view, home_view, project
from flatweave.app.colours import ramp, strain_range, strain_stops
from flatweave.app.presenter import surface_grid
from flatweave.app.view2d import segment_distances
from flatweave.app.view3d import bar_labels
from flatweave.app.viewbase import DENSE_PIXELS, SCALE_TITLES, THREAD, DIAGONAL, cell_springs
from flatweave.method.darts import CurveDart
from flatweave.reading.examples import example_names, load_example
from flatweave.method.metrics import spring_strain
from flatweave.app.tooleditors import YarnEditor

from tests.test_app_run import run_to_end, small_project

EXAMPLES = example_names()


def grid(name):
    _, xyz, normals = surface_grid(load_example(name))
    return xyz, normals


def least_spread_axis(points) -> np.ndarray:
    """The surface's mean normal up to sign: the axis of least spread of its points."""
    p = np.asarray(points).reshape(-1, 3)
    return np.linalg.eigh(np.cov((p - p.mean(axis=0)).T))[1][:, 0]


def framing(view, xyz) -> dict:
    """How the 3D view shows points ``xyz``: through VTK's world-to-display transform."""
    view.render_now()
    w, h = view.device_size()
    d = view.display_points(np.asarray(xyz).reshape(-1, 3))
    ext = np.ptp(d, axis=0)
    return {"w": w, "h": h, "pts": d, "fill": float(ext.max() / min(w, h)),
            "fill_x": float(ext[0] / (w * (1 - view.bar_column_fraction()))), "fill_y": float(ext[1] / h),
            "cos": float(abs(view.view_direction() @ least_spread_axis(xyz))),
            "centre": (d.min(axis=0) + d.max(axis=0)) / 2}


def camera_of(view):
    cam = view.plotter.renderer.GetActiveCamera()
    return np.array([*cam.GetPosition(), *cam.GetFocalPoint(), *cam.GetViewUp(), *cam.GetWindowCenter()])


def wheel(widget, x_vtk: float, y_vtk: float, steps: int) -> None:
    """Real Qt wheel events (``steps`` notches, > 0 towards the screen) at VTK display pixel (x, y)."""
    pos = QPointF(float(x_vtk), float(widget.height() - 1 - y_vtk))
    for _ in range(abs(steps)):
        ev = QWheelEvent(pos, widget.mapToGlobal(pos), QPoint(0, 0), QPoint(0, 120 if steps > 0 else -120),
                         Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase,
                         False)
        QApplication.sendEvent(widget, ev)


# ---------------------------------------------------------------------- framing, as numbers
@pytest.mark.parametrize("name", EXAMPLES)
@pytest.mark.parametrize("aspect", [0.69, 1.6])
def test_the_home_view_fills_its_region_at_three_quarters(name, aspect):
    xyz, normals = grid(name)
    direction, up = home_view(xyz, normals)
    assert abs(np.linalg.norm(direction) - 1) < 1e-12 and abs(direction @ up) < 1e-12
    assert 0.4 <= abs(direction @ least_spread_axis(xyz)) <= 0.95  # neither edge-on nor flat on
    if abs(direction[2]) < 0.95:
        assert up[2] > 0.3  # z up on screen
    region = (0.0, 0.85, 0.0, 1.0)
    frame = fit_view(xyz, direction, up, aspect, region)
    q = project(xyz, frame, aspect)
    lo, hi = q.min(axis=0), q.max(axis=0)
    assert lo[0] >= -1 - 1e-9 and hi[0] <= 0.7 + 1e-9 and lo[1] >= -1 - 1e-9 and hi[1] <= 1 + 1e-9
    fill = max((hi[0] - lo[0]) / (2 * 0.85), (hi[1] - lo[1]) / 2)
    assert fill == pytest.approx(FILL, abs=2e-3)
    np.testing.assert_allclose((lo + hi) / 2, [-0.15, 0.0], atol=1e-6)  # centred in the region


def test_bar_labels_never_crowd():
    assert bar_labels(-1.0, 1.0) == [-1.0, -0.5, 0.0, 0.5, 1.0]
    labels = bar_labels(-0.107, 0.96)
    assert labels[0] == -0.107 and labels[-1] == 0.96 and -0.0535 not in labels
    assert np.diff(labels).min() >= 0.09 * (0.96 + 0.107) - 1e-12


# ---------------------------------------------------------------------- framing, in the window
@pytest.mark.slow
def test_every_example_opens_framed_and_reset_frames_it_again(make_window, qtbot):
    win = make_window()
    view = win.view
    seen = {}
    for name in EXAMPLES:
        assert win.open_example(name)
        xyz, _ = grid(name)
        f = framing(view, xyz)
        seen[name] = f
        x1 = f["w"] * (1 - view.bar_column_fraction())
        assert f["pts"][:, 0].min() >= 0 and f["pts"][:, 0].max() <= x1, name  # left of the colour bars
        assert f["pts"][:, 1].min() >= 0 and f["pts"][:, 1].max() <= f["h"], name
        assert f["fill"] >= 0.6, name
        assert max(f["fill_x"], f["fill_y"]) == pytest.approx(0.86, abs=0.02), name
        assert 0.4 <= f["cos"] <= 0.95, name
        home = camera_of(view)
        # turn, tilt and zoom the camera; Reset 3D view brings the framing back
        cam = view.plotter.renderer.GetActiveCamera()
        cam.Azimuth(70)
        cam.Elevation(25)
        cam.Zoom(3.0)
        win.actions["reset_view"].trigger()
        np.testing.assert_allclose(camera_of(view), home, atol=1e-9)
    print("\nframing:", "; ".join(f"{n} fill {f['fill']:.2f} (x {f['fill_x']:.2f}, y {f['fill_y']:.2f}), "
                                  f"|cos(view, normal)| {f['cos']:.2f} ({np.degrees(np.arccos(f['cos'])):.0f} deg)"
                                  for n, f in seen.items()))


def test_opening_a_project_frames_it(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))
    view = win.view
    view.render_now()
    home = camera_of(view)
    path = tmp_path / "octant.flatweave"
    win.save_to(path)
    view.plotter.renderer.GetActiveCamera().Azimuth(120)
    view.plotter.renderer.GetActiveCamera().Zoom(0.3)
    assert win.open_file(path)
    np.testing.assert_allclose(camera_of(view), home, atol=1e-9)
    assert framing(view, grid("octant")[0])["fill"] >= 0.6


@pytest.mark.slow
def test_the_wheel_zooms_about_the_cursor(each_widget, make_window, qtbot):
    win = make_window(example="saddle")
    view = win.view
    xyz, _ = grid("saddle")
    f0 = framing(view, xyz)
    cam = view.plotter.renderer.GetActiveCamera()
    d0 = cam.GetDistance()
    # at the model's centre: it stays in view, and comes closer
    cx, cy = f0["centre"]
    wheel(view.widget, cx, cy, 3)
    f1 = framing(view, xyz)
    assert cam.GetDistance() == pytest.approx(d0 / 1.2 ** 3, rel=1e-6)
    assert 0 <= f1["centre"][0] <= f1["w"] and 0 <= f1["centre"][1] <= f1["h"]
    assert f1["fill"] > f0["fill"] * 1.5
    # off the centre, over a corner of the surface: that point stays under the cursor
    win.actions["reset_view"].trigger()
    corner = xyz[5, 5]
    px = np.array(view.display_point(corner))
    focal = np.array(cam.GetFocalPoint())
    wheel(view.widget, *px, 2)
    view.render_now()
    # the point of the old focal plane under the cursor stays put; the corner, near it, moves little
    moved = np.array(view.display_point(corner)) - px
    assert np.linalg.norm(moved) < 0.2 * np.linalg.norm(px - f0["centre"])
    assert not np.allclose(cam.GetFocalPoint(), focal)  # the camera moved towards the cursor, not the middle
    # and out again: still in view
    wheel(view.widget, *px, -6)
    f2 = framing(view, xyz)
    inside = ((f2["pts"][:, 0] >= 0) & (f2["pts"][:, 0] <= f2["w"]) & (f2["pts"][:, 1] >= 0)
              & (f2["pts"][:, 1] <= f2["h"]))
    assert inside.all() and f2["fill"] < f0["fill"]


# ---------------------------------------------------------------------- strain colours
@pytest.fixture
def solved(make_window, qtbot):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    return win


@pytest.mark.slow
def test_threads_and_diagonals_have_colour_scales_of_their_own(solved):
    win = solved
    r = win.project.result
    pct = 100 * spring_strain(r.xyz, r.mesh)
    thread, diag = r.mesh.kind != 2, r.mesh.kind == 2
    assert np.abs(pct[diag]).max() > 10 * np.abs(pct[thread]).max()  # woven cloth: the case in point
    idx, rgb = win.view.layer.spring_colours()
    np.testing.assert_array_equal(idx, np.arange(r.mesh.n_springs))
    # the threads' colours are spread over the ramp, not one green
    t_rgb = rgb[thread].astype(float)
    assert t_rgb.std(axis=0).sum() > 60 and len(np.unique(rgb[thread], axis=0)) > 40
    assert tuple(rgb[thread][np.argmax(pct[thread])]) == (255, 0, 0)
    assert tuple(rgb[thread][np.argmin(pct[thread])]) == (0, 0, 255)
    # (one scale over every spring, as before, painted the threads almost alike)
    joint = 255 * ramp(pct[thread], strain_stops(*strain_range(pct)))
    assert joint.std(axis=0).sum() < 0.25 * t_rgb.std(axis=0).sum()
    # two colour bars, each over its own kind's range
    bars = win.view.colour_bars
    assert [t for t, _ in bars] == [SCALE_TITLES[THREAD], SCALE_TITLES[DIAGONAL]]
    np.testing.assert_allclose(bars[0][1], (pct[thread].min(), pct[thread].max()), rtol=1e-12)
    np.testing.assert_allclose(bars[1][1], (pct[diag].min(), pct[diag].max()), rtol=1e-12)
    # the pattern view colours alike
    idx2, rgb2 = win.pattern_view.layer.spring_colours()
    np.testing.assert_array_equal(rgb2, rgb)
    # the hover names the scale
    s = int(np.flatnonzero(r.mesh.kind == 0)[0])
    k = int(np.flatnonzero(win.view.layer.spring_index[0] == s)[0])
    text = win.view.layer.describe(win.view.layer.spring_actors[0], k)
    assert f"{pct[s]:+.4f} %" in text and "thread scale" in text
    # diagonals off: one bar, the threads'
    win.actions["show_diag"].trigger()
    assert [t for t, _ in win.view.colour_bars] == [SCALE_TITLES[THREAD]]


def test_dense_springs_are_drawn_as_coloured_cells(solved, qtbot):
    win = solved
    view, layer = win.view, win.view.layer
    r = win.project.result
    assert not layer.dense and view.spring_pixels() > DENSE_PIXELS
    assert all(a.GetVisibility() for a in layer.spring_actors) and not layer.strain_cell_actor.GetVisibility()
    # zoom out with the wheel until the springs are closer than DENSE_PIXELS on screen
    w, h = view.device_size()
    for _ in range(40):
        if view.spring_pixels() < DENSE_PIXELS:
            break
        wheel(view.widget, w / 3, h / 2, -1)
    assert view.spring_pixels() < DENSE_PIXELS and layer.dense
    assert layer.strain_cell_actor.GetVisibility() and not any(a.GetVisibility() for a in layer.spring_actors)
    assert [t for t, _ in view.colour_bars] == [SCALE_TITLES[THREAD]]  # cells show the threads
    # each cell: the signed thread strain of largest size among its four sides
    pct = 100 * spring_strain(r.xyz, r.mesh)
    got = np.asarray(layer.cells.cell_data["strain"])
    cs = cell_springs(r.mesh)
    for c, cell in enumerate(r.mesh.cells):
        sides = [s for s in cs[c, :4] if s >= 0]
        assert {tuple(sorted(r.mesh.ends[s])) for s in sides} <= {
            tuple(sorted((cell[a], cell[b]))) for a, b in ((0, 1), (1, 2), (3, 2), (0, 3))}
        want = pct[sides][np.argmax(np.abs(pct[sides]))]
        assert got[c] == pytest.approx(want)
    assert np.ptp(layer.thread_scale.map(got), axis=0).sum() > 200  # the cells' colours are spread too
    # zoom back in: springs again
    for _ in range(40):
        if view.spring_pixels() > DENSE_PIXELS:
            break
        wheel(view.widget, w / 3, h / 2, 1)
    assert not layer.dense and all(a.GetVisibility() for a in layer.spring_actors)
    # the pattern view decides for itself, after its own zoom
    pv_ = win.pattern_view
    assert not pv_.layer.dense
    pw, ph = pv_.device_size()
    for _ in range(40):
        if pv_.spring_pixels() < DENSE_PIXELS:
            break
        wheel(pv_.widget, pw / 2, ph / 2, -1)
    assert pv_.layer.dense and pv_.layer.strain_cell_actor.GetVisibility()


@pytest.mark.slow
def test_a_dense_mesh_opens_as_cells_in_a_small_window(make_window, qtbot):
    win = make_window(small_project(0.04))
    win.resize(700, 500)
    qtbot.waitUntil(lambda: win.view.device_size()[1] < 450, timeout=5000)
    run_to_end(qtbot, win)
    win.view.reset_camera()
    assert win.view.spring_pixels() < DENSE_PIXELS and win.view.layer.dense
    assert win.view.layer.strain_cell_actor.GetVisibility()


# ---------------------------------------------------------------------- layout
def side_scroll(win) -> QScrollArea:
    return next(s for s in win.findChildren(QScrollArea) if s.widget().isAncestorOf(win.energy_plot))


@pytest.mark.slow
@pytest.mark.parametrize("size", [None, (1600, 1000)])
def test_the_darts_tab_leaves_the_energy_plot_room(make_window, qtbot, size):
    win = make_window(small_project(0.1))
    if size is not None:
        win.resize(*size)
    run_to_end(qtbot, win)
    win.side_tabs.setCurrentIndex(1)
    scroll = side_scroll(win)
    for editor in (lambda: win.actions["tool_plane_dart"].trigger(), win.dart_panel.editor(YarnEditor).show):
        editor()
        qtbot.wait(50)
        assert not scroll.verticalScrollBar().isVisible()
        plot = win.energy_plot
        assert plot.height() >= plot.sizeHint().height()
        plot.grab()  # paints it
        rects = [rect for _, rect in plot.text_rects]
        assert len(rects) >= 4
        for text, rect in plot.text_rects:
            assert plot.rect().toRectF().contains(rect), text
        for a in range(len(rects)):
            for b in range(a + 1, len(rects)):
                assert not rects[a].intersects(rects[b]), (plot.text_rects[a][0], plot.text_rects[b][0])
        if win.tool is not None:
            win.set_tool(None)
        win.dart_panel.editor(YarnEditor).hide()


@pytest.mark.slow
def test_colour_bar_titles_fit_their_frames(solved, qtbot):
    win = solved
    view = win.view
    for mode in ("mode_shear", "mode_strain"):
        win.actions[mode].trigger()
        for size in (None, (1000, 700)):
            if size is not None:
                win.resize(*size)
                qtbot.wait(50)
            view.render_now()
            w, h = view.device_size()
            boxes = view.colour_bar_boxes()
            titles = [t for t, _ in view.colour_bars]
            assert titles == (["shear (deg)"] if mode == "mode_shear" else
                              [SCALE_TITLES[THREAD], SCALE_TITLES[DIAGONAL]])
            for title, (x0, y0, x1, y1) in zip(titles, boxes):
                assert 0 <= x0 and x1 <= w - 1 and 0 <= y0 and y1 <= h, title
                for line in title.split("\n"):
                    tw, th = view.title_size(line)
                    assert tw + 8 <= x1 - x0, (line, tw, x1 - x0)  # the whole title, with room
    # the rendered bar: its frame's right edge has background to its right (nothing cut by the view's edge)
    img = view.plotter.screenshot(None, return_img=True) if hasattr(view.plotter, "screenshot") else None
    if img is not None and img.shape[1] == view.device_size()[0]:
        x1 = int(view.colour_bar_boxes()[0][2])
        assert x1 < img.shape[1] - 2


def test_segment_distances_are_the_nearest_segments_or_the_cap():
    """The grain label's clearances (a k-d-like tree of segments) against every point-segment distance."""
    rng = np.random.default_rng(7)
    p = rng.random((200, 2))
    a = rng.random((400, 2))
    b = a + 0.03 * rng.standard_normal((400, 2))
    b[::9] = a[::9]  # points (a dart node is a one-point line)
    ab = b - a
    t = np.clip(((p[:, None] - a[None]) * ab[None]).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0, 1)
    brute = np.linalg.norm(p[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(axis=1)
    for cap in (np.inf, 0.04, 0.005):
        np.testing.assert_allclose(segment_distances(p, a, b, cap), np.minimum(brute, cap), rtol=0, atol=1e-12)
    assert (segment_distances(p, a[:0], b[:0], 0.1) == 0.1).all()


@pytest.mark.slow
def test_the_grain_label_keeps_clear_of_darts(make_window, qtbot):
    dart = CurveDart(np.array([[1.0, 0.5], [0.7, 0.5], [0.42, 0.52]]), name="front")
    win = make_window(small_project(0.08, darts=(dart,)))
    run_to_end(qtbot, win)
    pv_ = win.pattern_view
    pattern = win.project.result.pattern
    assert len(pattern.darts) == 1
    x0, y0, x1, y1 = pv_.grain_label_box()
    samples = np.array([[x, y] for x in np.linspace(x0, x1, 9) for y in np.linspace(y0, y1, 5)])
    frame = win.frame
    avoid = np.vstack([pattern.darts[0].leg_a, pattern.darts[0].leg_b,
                       frame.xy[frame.dart_positive], frame.xy[frame.dart_negative]])
    gap = np.linalg.norm(samples[:, None, :] - avoid[None, :, :], axis=2).min()
    assert gap >= 0.3 * (y1 - y0), gap  # a clear margin round the label
    assert PolygonPath(pattern.outline).contains_points(samples).all()  # inside the piece
    # and still clear after zooming the pattern
    pw, ph = pv_.device_size()
    wheel(pv_.widget, pw / 2, ph / 2, 3)
    x0, y0, x1, y1 = pv_.grain_label_box()
    samples = np.array([[x, y] for x in np.linspace(x0, x1, 9) for y in np.linspace(y0, y1, 5)])
    assert np.linalg.norm(samples[:, None, :] - avoid[None, :, :], axis=2).min() >= 0.3 * (y1 - y0)


@pytest.mark.slow
def test_curve_dart_handles_stand_out_from_dart_nodes(make_window, qtbot):
    dart = CurveDart(np.array([[1.0, 0.5], [0.7, 0.5], [0.42, 0.52]]), name="front",
                     handles=np.array([[1.0, 0.5], [0.7, 0.5], [0.42, 0.52]]))
    win = make_window(small_project(0.08, darts=(dart,)))
    run_to_end(qtbot, win)
    win.dart_panel.dart_list.setCurrentRow(0)
    view = win.view
    assert len(view.layer_points("handles")) == 3
    style = view.layer_look("handles")
    nodes = view.layer.node_actors
    node_size = max(a.GetProperty().GetPointSize() for a in nodes)
    node_colours = [tuple(a.GetProperty().GetColor()) for a in nodes]
    assert style["size"] > node_size and style["edge_size"] >= style["size"] + 4
    assert style["fill"] not in node_colours and style["edge"] not in node_colours
    assert style["overlay"] and not style["round"] and all(a.GetProperty().GetRenderPointsAsSpheres() for a in nodes)
    # on screen: a white square ringed in black at each handle, over whatever is there
    img = view.plotter.screenshot(None, return_img=True)
    h = img.shape[0]
    for p in view.layer_points("handles"):
        x, y = (int(round(c)) for c in view.display_point(p))
        if not (10 < x < img.shape[1] - 10 and 10 < y < h - 10):
            continue
        assert img[h - 1 - y, x].min() > 200, img[h - 1 - y, x]
        ring = img[h - 1 - y, x + 7]
        assert ring.max() < 80, ring
