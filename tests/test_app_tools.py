"""GUI tests of the interactive tools: curve darts drawn by clicks in
the 3D view, plane darts placed with the widget, yarns picked by clicking a
node, the darts and yarns list, undo and redo, and saving.

Every click is a real mouse event on the 3D view's widget (Qt's y flipped to
VTK's), placed where the renderer projects a chosen world point. What the
tools make is checked against geometry the test computes on its own: the
octant is the unit sphere, so a click's point is the ray-sphere intersection
of the pixel's viewing ray. Small meshes (spacing 0.1 on the octant).
"""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from flatweave.method.darts import DartSet, PlaneDart, curve_dart_through
from flatweave.method.energy import yarn_nodes
from flatweave.document.project import project_problems, project_to_dict
from flatweave.app.tooleditors import PlaneEditor, YarnEditor

from tests.test_app_run import RUN_TIMEOUT_MS, run_to_end, small_project

CAMERA = ((2.4, 1.3, 1.5), (0.45, 0.45, 0.4), (0.0, 0.0, 1.0))
# three points across the octant: from near the equator by the x axis, over the middle, towards y
TARGETS = np.array([[0.93, 0.3, 0.2], [0.62, 0.58, 0.53], [0.3, 0.85, 0.45]])
TARGETS /= np.linalg.norm(TARGETS, axis=1, keepdims=True)


# ---------------------------------------------------------------------- helpers
def ready(qtbot, win):
    """Render the view and make the window active (key shortcuts go to the active window)."""
    win.view.render_now()
    qtbot.waitUntil(lambda: win.view.is_ready(), timeout=10000)
    win.activateWindow()
    qtbot.waitUntil(win.isActiveWindow, timeout=5000)


def pixel(view, xyz) -> tuple[int, int]:
    """The display pixel (VTK's, origin bottom left) where the renderer puts a world point."""
    x, y = view.display_point(xyz)
    return int(round(x)), int(round(y))


def click(qtbot, view, x: int, y: int, double: bool = False) -> None:
    """A real left click on the 3D view's widget at VTK display pixel (x, y)."""
    w = view.widget
    pos = QPoint(int(x), w.height() - 1 - int(y))
    if double:
        qtbot.mouseDClick(w, Qt.MouseButton.LeftButton, pos=pos)
    else:
        qtbot.mouseClick(w, Qt.MouseButton.LeftButton, pos=pos)


def drag(qtbot, view, a, b, steps: int = 12) -> None:
    """Press at display pixel a, move to b in steps, release there."""
    w = view.widget
    to_qt = lambda p: QPoint(int(round(p[0])), w.height() - 1 - int(round(p[1])))  # noqa: E731
    qtbot.mousePress(w, Qt.MouseButton.LeftButton, pos=to_qt(a))
    for f in np.linspace(0, 1, steps + 1)[1:]:
        qtbot.mouseMove(w, to_qt((a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))))
    qtbot.mouseRelease(w, Qt.MouseButton.LeftButton, pos=to_qt(b))


def ray_sphere(view, x: float, y: float, octant_only: bool = False) -> np.ndarray | None:
    """Where the viewing ray of display pixel (x, y) first meets the unit sphere
    (VTK's own display-to-world, solved by hand: an oracle independent of
    flatweave.geometry.curves); with ``octant_only`` the first meeting in the first octant."""
    ren = view.plotter.renderer
    ends = []
    for z in (0.0, 1.0):
        ren.SetDisplayPoint(float(x), float(y), z)
        ren.DisplayToWorld()
        w = np.array(ren.GetWorldPoint())
        ends.append(w[:3] / w[3])
    o, d = ends[0], ends[1] - ends[0]
    d /= np.linalg.norm(d)
    b = o @ d
    disc = b * b - (o @ o - 1.0)
    if disc < 0:
        return None
    for t in (-b - np.sqrt(disc), -b + np.sqrt(disc)):
        p = o + t * d
        if not octant_only or np.all(p >= -1e-12):
            return p
    return None


def format_plane(values) -> str:
    return ", ".join(repr(float(v)) for v in values)


def wait_run(qtbot, win, timeout=RUN_TIMEOUT_MS):
    """Wait for the re-run an edit starts (after the window's short delay) to finish."""
    with qtbot.waitSignal(win.run_finished, timeout=timeout) as blocker:
        pass
    return blocker.args[0]


def distance_to_polyline(p: np.ndarray, line: np.ndarray) -> float:
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(axis=1) / (ab * ab).sum(axis=1), 0, 1)
    return float(np.linalg.norm(a + t[:, None] * ab - p, axis=1).min())


def crossing_springs(result, dart) -> int:
    ends = result.mesh.ends
    return int(DartSet(result.surface, (dart,)).crossing(result.uv[ends[:, 0]], result.uv[ends[:, 1]]).sum())


@pytest.fixture
def solved(make_window, qtbot):
    """A window on the octant at spacing 0.1, solved, seen from CAMERA."""
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.view.look(*CAMERA)
    ready(qtbot, win)
    return win


# ---------------------------------------------------------------------- curve darts
@pytest.mark.slow
def test_a_three_click_curve_dart_lies_where_the_clicks_project_and_cuts(each_widget, solved, qtbot):
    win = solved
    view, doc = win.view, win.document
    before = win.project
    frames_before = win.runner.frames_shown
    win.actions["tool_curve_dart"].trigger()
    pixels = [pixel(view, t) for t in TARGETS]
    for k, (x, y) in enumerate(pixels):
        click(qtbot, view, x, y)
        assert len(win.tool.handles) == k + 1, win.last_hint
        assert len(view.layer_points("preview")) == k + 1  # the curve grows on the surface as it is drawn
    assert len(view.layer_lines("preview")) > 10
    assert doc.project is before  # nothing is an edit before Enter
    qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    assert len(win.project.settings.darts) == 1
    dart = win.project.settings.darts[0]
    assert dart.kind == "curve" and dart.name == "curve dart 1" and len(dart.handles) == 3
    np.testing.assert_allclose(dart.view_dir, view.view_direction())
    # Enter takes the preview's dart (same points, same view): the one a fresh projection and fit make
    fresh = curve_dart_through(win.surface, dart.handles, view.view_direction(), name=dart.name)
    np.testing.assert_array_equal(dart.uv, fresh.uv)
    assert dart.view_dir == fresh.view_dir
    assert len(view.layer_lines("preview")) == 0

    # each point is where its pixel's viewing ray meets the sphere, and the curve runs through them
    s = win.surface
    pts = s.points(dart.handles)
    curve = s.points(dart.uv)
    for (x, y), p in zip(pixels, pts):
        expected = ray_sphere(view, x, y)
        assert expected is not None
        np.testing.assert_allclose(p, expected, atol=1e-7)
        assert distance_to_polyline(p, curve) < 2e-3
    np.testing.assert_allclose(np.linalg.norm(curve, axis=1), 1.0, atol=1e-9)
    assert np.all(curve > -1e-9)  # in the first octant
    np.testing.assert_array_equal(view.dart_curves[0], curve)  # drawn on the surface

    # the edit re-runs from the current state, with live frames: springs cut, energy down
    outcome = wait_run(qtbot, win)
    after = win.project
    assert outcome.result is after.result and after.result_is_current and project_problems(after) == []
    assert win.runner.last_start[1] is not None  # a warm start, not a new drape
    np.testing.assert_array_equal(win.runner.last_start[1].uv, before.result.uv)
    assert win.runner.frames_shown > frames_before
    assert crossing_springs(before.result, dart) > 0
    assert crossing_springs(after.result, dart) == 0
    assert after.result.mesh.n_springs < before.result.mesh.n_springs
    assert after.result.metrics["energy"] < before.result.metrics["energy"]
    assert len(after.result.pattern.darts) == 1
    assert doc.undo_label == "Add curve dart 1"


@pytest.mark.slow
def test_a_click_that_misses_the_surface_adds_nothing(solved, qtbot):
    win = solved
    view, doc = win.view, win.document
    revision = doc.revision
    win.actions["tool_curve_dart"].trigger()
    corner = (8, 8)  # the view's bottom left corner: off the octant
    assert ray_sphere(view, *corner, octant_only=True) is None
    click(qtbot, view, *corner)
    assert win.tool.handles == [] and len(view.layer_points("preview")) == 0
    assert "missed the surface" in win.last_hint
    assert "missed the surface" in win.statusBar().currentMessage()
    # one point on the surface, then another miss: still one point; Enter refuses a one-point dart
    click(qtbot, view, *pixel(view, TARGETS[1]))
    click(qtbot, view, *corner)
    assert len(win.tool.handles) == 1
    qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    assert "at least two points" in win.last_hint
    qtbot.keyClick(view.widget, Qt.Key.Key_Escape)
    assert win.tool.handles == [] and len(view.layer_points("preview")) == 0
    assert doc.revision == revision and win.project.settings.darts == ()


def draw_dart(qtbot, win, targets=TARGETS):
    """Draw a curve dart through ``targets`` with the tool (clicks, then Enter) and wait for its re-run."""
    win.actions["tool_curve_dart"].trigger()
    for t in targets:
        click(qtbot, win.view, *pixel(win.view, t))
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(win.view.widget, Qt.Key.Key_Return)
    win.actions["tool_curve_dart"].trigger()  # the tool off again
    assert win.tool is None


@pytest.mark.slow
def test_a_double_click_finishes_the_dart(each_widget, solved, qtbot):
    win = solved
    win.actions["tool_curve_dart"].trigger()
    click(qtbot, win.view, *pixel(win.view, TARGETS[0]))
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, win.view, *pixel(win.view, TARGETS[2]), double=True)
    (dart,) = win.project.settings.darts
    assert len(dart.handles) == 2 and win.tool.handles == []


# ---------------------------------------------------------------------- plane darts
@pytest.mark.slow
def test_a_plane_dart_placed_with_the_widget(each_widget, solved, qtbot):
    win = solved
    view, panel = win.view, win.dart_panel
    before = win.project
    win.actions["tool_plane_dart"].trigger()
    tool = win.tool
    assert panel.editor(PlaneEditor).isVisible() and view.box_widget is not None
    # numbers typed in the panel move the widget
    panel.editor(PlaneEditor).plane_edit.setText("1, 0, 0, -0.4")
    panel.editor(PlaneEditor).plane_edit.editingFinished.emit()
    origin, normal = view.plane_widget_state()
    np.testing.assert_allclose(normal, [1, 0, 0], atol=1e-12)
    assert origin[0] == pytest.approx(0.4)
    # drag the plane along its normal, where it is outside the box (the box would take the press)
    drag(qtbot, view, pixel(view, (0.4, 0.85, 0.75)), pixel(view, (0.75, 0.85, 0.75)))
    origin, normal = view.plane_widget_state()
    assert origin[0] > 0.45, "the drag did not move the plane"
    n = normal / np.linalg.norm(normal)
    np.testing.assert_allclose(tool.plane, (*n, -n @ origin), atol=1e-12)
    assert panel.editor(PlaneEditor).plane_edit.text() == ", ".join(f"{v:.6g}" for v in tool.plane)
    # the preview is the plane's curve on the surface, inside the box
    curve = view.layer_lines("preview")
    assert len(curve) > 10
    np.testing.assert_allclose(curve @ n - n @ origin, 0.0, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(curve, axis=1), 1.0, atol=1e-9)
    box = np.array(tool.box)
    assert np.all(curve >= box[0::2] - 1e-9) and np.all(curve <= box[1::2] + 1e-9)
    assert win.project is before  # not applied yet
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.mouseClick(panel.editor(PlaneEditor).apply_button, Qt.MouseButton.LeftButton)
    (dart,) = win.project.settings.darts
    assert isinstance(dart, PlaneDart) and dart.name == "plane dart 1"
    np.testing.assert_allclose(dart.plane, tool.plane)
    np.testing.assert_allclose(dart.box, tool.box)
    assert win.tool is None and view.plane_widget is None and len(view.layer_lines("preview")) == 0
    after = win.project
    assert after.result_is_current and project_problems(after) == []
    assert crossing_springs(before.result, dart) > 0 and crossing_springs(after.result, dart) == 0
    assert after.result.metrics["energy"] < before.result.metrics["energy"]
    # edit it again in the widgets: the list's Edit puts it back, Apply replaces it (name kept)
    panel.dart_list.setCurrentRow(0)
    qtbot.mouseClick(panel.edit_dart, Qt.MouseButton.LeftButton)
    assert isinstance(win.tool, type(tool)) and win.tool.index == 0 and view.plane_widget is not None
    np.testing.assert_allclose(view.plane_widget_state()[1], n, atol=1e-12)
    panel.editor(PlaneEditor).plane_edit.setText(format_plane((*n, dart.plane[3] + 0.05)))
    panel.editor(PlaneEditor).plane_edit.editingFinished.emit()
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.mouseClick(panel.editor(PlaneEditor).apply_button, Qt.MouseButton.LeftButton)
    (edited,) = win.project.settings.darts
    assert edited.name == "plane dart 1" and win.document.undo_label == "Move plane dart 1"
    assert edited.plane[3] == pytest.approx(dart.plane[3] + 0.05)


# ---------------------------------------------------------------------- yarns
@pytest.mark.slow
def test_a_yarn_picked_by_clicking_a_node(solved, qtbot):
    win = solved
    view, panel = win.view, win.dart_panel
    before = win.project
    r = before.result
    # a node in the middle of the piece, facing the camera
    node = int(np.argmin(np.linalg.norm(r.xyz - TARGETS[1], axis=1)))
    win.actions["tool_yarn"].trigger()
    click(qtbot, view, *pixel(view, r.xyz[node]))
    tool = win.tool
    assert tool.pending is not None and tool.pending.node == node, win.last_hint
    i, j = r.mesh.ij[node]
    row = np.flatnonzero(r.mesh.ij[:, 0] == i)
    assert len(row) > 3
    np.testing.assert_array_equal(np.sort(tool.nodes()), row)  # the weft row through the node
    np.testing.assert_allclose(view.layer_lines("picked yarn"), r.xyz[yarn_nodes(r.mesh, "weft", i)])
    # the warp column instead, chosen in the panel
    panel.editor(YarnEditor).kind.setFocus()
    qtbot.keyClick(panel.editor(YarnEditor).kind, Qt.Key.Key_Down)
    assert tool.pending.kind == "warp" and tool.pending.index == j
    col = yarn_nodes(r.mesh, "warp", j)
    np.testing.assert_array_equal(np.sort(tool.nodes()), np.flatnonzero(r.mesh.ij[:, 1] == j))
    np.testing.assert_allclose(view.layer_lines("picked yarn"), r.xyz[col])
    # the default plane: through the column's end points, containing the normal at the node
    plane = np.array(tool.plane)
    np.testing.assert_allclose(r.xyz[col[[0, -1]]] @ plane[:3] + plane[3], 0.0, atol=1e-12)
    normal = before.surface.evaluate(r.uv[node:node + 1]).normal[0]
    assert abs(plane[:3] @ normal) < 1e-12
    # turned by 10 degrees about that normal, weight typed in, Enter applies
    panel.editor(YarnEditor).angle.setValue(10.0)
    turned = np.array(tool.plane)
    cos = turned[:3] @ plane[:3]
    assert cos == pytest.approx(np.cos(np.radians(10.0)), abs=1e-9)
    assert len(view.layer_lines("preview")) > 10  # the plane's curve on the surface
    panel.editor(YarnEditor).k.setFocus()
    panel.editor(YarnEditor).k.selectAll()
    qtbot.keyClicks(panel.editor(YarnEditor).k, "20000")
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(panel.editor(YarnEditor).k, Qt.Key.Key_Return)
    (yarn,) = win.project.settings.yarns
    assert (yarn.kind, yarn.index, yarn.k) == ("warp", j, 20000.0)
    np.testing.assert_allclose(yarn.plane, turned)
    # kept by what was picked (the node's point), so a new drape finds the column again, and shown so
    np.testing.assert_array_equal(yarn.point, r.xyz[node])
    assert panel.yarn_list.count() == 1 and panel.yarn_list.item(0).text().startswith("warp through (")
    # the constraint changes the pattern and pulls the column towards its plane
    after = win.project.result
    assert win.project.result_is_current and project_problems(win.project) == []
    # the pattern is the relaxed lattice: its outline (mapped from the nodes on the surface) moves
    moved = max(distance_to_polyline(q, r.pattern.outline) for q in after.pattern.outline)
    assert moved > 2e-3, moved
    f = lambda res: np.abs(res.xyz[yarn_nodes(res.mesh, "warp", j)] @ turned[:3] + turned[3]).max()  # noqa: E731
    assert f(after) < 0.2 * f(r)
    # edited from the list: the stored plane is the angle's zero
    panel.yarn_list.setCurrentRow(0)
    qtbot.mouseClick(panel.edit_yarn, Qt.MouseButton.LeftButton)
    assert tool.pending is not None and tool.pending.replaces == 0 and not panel.editor(YarnEditor).kind.isEnabled()
    np.testing.assert_allclose(tool.plane, turned, atol=1e-12)
    panel.editor(YarnEditor).angle.setValue(-5.0)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.mouseClick(panel.editor(YarnEditor).apply_button, Qt.MouseButton.LeftButton)
    (edited,) = win.project.settings.yarns
    assert (edited.kind, edited.index, edited.k) == ("warp", j, 20000.0) and edited.point == yarn.point
    assert np.dot(edited.plane[:3], turned[:3]) == pytest.approx(np.cos(np.radians(5.0)), abs=1e-9)
    # listed and removable like darts
    panel.yarn_list.setCurrentRow(0)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.mouseClick(panel.remove_yarn, Qt.MouseButton.LeftButton)
    assert win.project.settings.yarns == () and panel.yarn_list.count() == 0


# ---------------------------------------------------------------------- the list, editing, undo, saving
@pytest.mark.slow
def test_dart_list_rename_hide_move_points_and_delete(solved, qtbot):
    win = solved
    view, panel, doc = win.view, win.dart_panel, win.document
    draw_dart(qtbot, win)
    runs = win.runner.runs_started
    # rename and hide: labels only, the result stays current, nothing re-runs
    panel.dart_list.item(0).setText("shoulder")
    assert win.project.settings.darts[0].name == "shoulder" and doc.undo_label == "Rename dart"
    panel.dart_list.item(0).setCheckState(Qt.CheckState.Unchecked)
    assert not win.project.settings.darts[0].visible and view.dart_curves == [None]
    assert win.project.result_is_current and win.runner.runs_started == runs and not win.runner.busy
    panel.dart_list.item(0).setCheckState(Qt.CheckState.Checked)
    # select it: its points become handles; drag the middle one across the surface
    panel.dart_list.setCurrentRow(0)
    dart = win.project.settings.darts[0]
    np.testing.assert_allclose(view.layer_points("handles"), win.surface.points(dart.handles))
    assert view.selected_dart == 0
    start = pixel(view, win.surface.points(dart.handles[1:2])[0])
    target = np.array([0.55, 0.5, 0.67])
    end = pixel(view, target / np.linalg.norm(target))
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        drag(qtbot, view, start, end)
    moved = win.project.settings.darts[0]
    assert moved.name == "shoulder" and doc.undo_label == "Move shoulder"
    np.testing.assert_array_equal(moved.handles[[0, 2]], dart.handles[[0, 2]])
    np.testing.assert_allclose(win.surface.points(moved.handles[1:2])[0], ray_sphere(view, *end), atol=1e-7)
    assert distance_to_polyline(ray_sphere(view, *end), win.surface.points(moved.uv)) < 2e-3
    assert crossing_springs(win.project.result, moved) == 0 and win.project.result_is_current
    np.testing.assert_allclose(view.layer_points("handles"), win.surface.points(moved.handles))
    # delete
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.mouseClick(panel.delete_dart, Qt.MouseButton.LeftButton)
    assert win.project.settings.darts == () and panel.dart_list.count() == 0
    assert len(view.layer_points("handles")) == 0 and view.dart_curves == []


@pytest.mark.slow
def test_a_dragged_dart_point_re_solves_as_it_moves(solved, qtbot):
    """While a dart's point is dragged the pattern follows it (previews, not
    edits); the release makes one edit whose result is the final position's."""
    win = solved
    view, panel, doc = win.view, win.dart_panel, win.document
    draw_dart(qtbot, win)
    panel.dart_list.setCurrentRow(0)
    before, steps = win.project, len(doc.history)
    dart = before.settings.darts[0]
    s = win.surface
    frames = []
    win.runner.frame.connect(frames.append)
    runs, previews, adopted = win.runner.runs_started, win.runs.previews_started, win.runs.previews_adopted
    w = view.widget
    to_qt = lambda p: QPoint(int(p[0]), w.height() - 1 - int(p[1]))  # noqa: E731
    start = pixel(view, s.points(dart.handles[1:2])[0])
    targets = [np.array(t) / np.linalg.norm(t) for t in ([0.55, 0.5, 0.67], [0.72, 0.42, 0.55], [0.5, 0.62, 0.6])]
    qtbot.mousePress(w, Qt.MouseButton.LeftButton, pos=to_qt(start))
    last, seen = start, []
    for k, t in enumerate(targets):
        end = pixel(view, t)
        for f in np.linspace(0, 1, 5)[1:]:  # a few moves on the way: intermediate positions may be dropped
            qtbot.mouseMove(w, to_qt([a + round(f * (b - a)) for a, b in zip(last, end)]))
        last = end
        point = ray_sphere(view, *end)
        moved = curve_dart_through(s, win.tool.handles, view.view_direction())
        n0, final_wanted = len(frames), k < len(targets) - 1

        def solved_here():  # this position's solved pattern (the last position: a live frame of its solve)
            return next((fr for fr in frames[n0:] if (fr.final or not final_wanted) and not fr.draping
                         and fr.iteration >= 1 and distance_to_polyline(point, fr.dart_curves[0]) < 2e-3), None)
        qtbot.waitUntil(lambda: solved_here() is not None, timeout=RUN_TIMEOUT_MS)
        fr = solved_here()
        assert doc.project is before and len(doc.history) == steps  # previews are not edits
        if final_wanted:  # the shown pattern is cut along the dart as it is now
            ends = fr.mesh.ends
            assert int(DartSet(s, (moved,)).crossing(fr.uv[ends[:, 0]], fr.uv[ends[:, 1]]).sum()) == 0
            assert fr.pattern is not None and len(fr.pattern.darts) == 1
            seen.append((moved, fr))
    # the pattern changed with the point: each position's mesh is cut along its own dart only
    for (d_a, _), (_, f_b) in zip(seen, seen[1:]):
        ends = f_b.mesh.ends
        assert int(DartSet(s, (d_a,)).crossing(f_b.uv[ends[:, 0]], f_b.uv[ends[:, 1]]).sum()) > 0
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        qtbot.mouseRelease(w, Qt.MouseButton.LeftButton, pos=to_qt(last))
    after = win.project
    final = after.settings.darts[0]
    assert len(doc.history) == steps + 1 and doc.undo_label == "Move curve dart 1"
    assert blocker.args[0].result is after.result and after.result_is_current
    np.testing.assert_allclose(s.points(final.handles[1:2])[0], ray_sphere(view, *last), atol=1e-7)
    np.testing.assert_array_equal(final.handles[[0, 2]], dart.handles[[0, 2]])
    assert crossing_springs(after.result, final) == 0 and crossing_springs(after.result, dart) > 0
    # the previews ran (at least one per position) and the last one answered the edit: no run after the release
    assert win.runs.previews_started - previews >= len(targets) and win.runs.previews_adopted == adopted + 1
    assert win.runner.runs_started - runs <= win.runs.previews_started - previews
    # one undo step goes back to the dart and the result before the drag
    win.actions["undo"].trigger()
    assert win.project is before and len(doc.history) == steps


@pytest.mark.slow
def test_a_dart_point_dragged_back_onto_its_spot_shows_the_document(solved, qtbot):
    """A point dragged away and back onto the spot the document's dart has
    starts no solve there (its answer is the document's result, which the views
    show again), and the release there is no edit."""
    win = solved
    view, doc = win.view, win.document
    draw_dart(qtbot, win)
    win.dart_panel.dart_list.setCurrentRow(0)
    qtbot.waitUntil(lambda: win.tool is not None, timeout=5000)
    before, steps = win.project, len(doc.history)
    w = view.widget
    to_qt = lambda p: QPoint(int(p[0]), w.height() - 1 - int(p[1]))  # noqa: E731
    start = pixel(view, win.surface.points(before.settings.darts[0].handles[1:2])[0])
    away = pixel(view, np.array([0.55, 0.5, 0.67]) / np.linalg.norm([0.55, 0.5, 0.67]))
    qtbot.mousePress(w, Qt.MouseButton.LeftButton, pos=to_qt(start))
    # the pick at the press's own pixel: the dart through it is the document's only if the press hit the handle
    # exactly, so the spot to come back to is the one a first move there makes the document's (released below)
    qtbot.mouseMove(w, to_qt(away))
    qtbot.waitUntil(lambda: win.runs.previews_started > 0 and win.runner.busy, timeout=RUN_TIMEOUT_MS)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.mouseRelease(w, Qt.MouseButton.LeftButton, pos=to_qt(away))
    moved, steps = win.project, steps + 1
    assert len(doc.history) == steps and moved.result_is_current
    qtbot.waitUntil(lambda: win.tool is not None and not win.runner.busy, timeout=RUN_TIMEOUT_MS)
    frames = []
    win.runner.frame.connect(frames.append)
    qtbot.mousePress(w, Qt.MouseButton.LeftButton, pos=to_qt(away))
    qtbot.mouseMove(w, to_qt(start))  # away from the document's spot: a preview solves there
    qtbot.waitUntil(lambda: win.runs.previewing and win.runner.busy, timeout=RUN_TIMEOUT_MS)
    started = win.runs.previews_started
    qtbot.mouseMove(w, to_qt(away))  # back onto it: no solve, the preview in flight is dropped
    assert win.runs.previews_started == started and not win.runs.previewing
    qtbot.waitUntil(lambda: not win.runner.busy, timeout=RUN_TIMEOUT_MS)
    assert win.presenter.frame.final and win.presenter.frame.mesh is moved.result.mesh
    qtbot.mouseRelease(w, Qt.MouseButton.LeftButton, pos=to_qt(away))
    qtbot.wait(100)
    assert win.project is moved and len(doc.history) == steps and win.runs.previews_started == started
    assert not win.runner.busy and not win.runs.previewing


@pytest.mark.slow
def test_undo_and_redo_restore_the_exact_documents(solved, qtbot):
    win = solved
    doc = win.document
    states = [project_to_dict(win.project)]
    draw_dart(qtbot, win)
    states.append(project_to_dict(win.project))
    win.dart_panel.dart_list.item(0).setText("front")
    states.append(project_to_dict(win.project))
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        doc.add_dart(PlaneDart((0.0, 1.0, 0.0, -0.5), (0.0, 1.0, 0.0, 1.0, 0.0, 0.5), name="side"))
    states.append(project_to_dict(win.project))
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        win.edit_settings("Tolerance", {"tol": 1e-7})
    states.append(project_to_dict(win.project))
    assert len(doc.history) >= 5  # the first solve, then the four edits above
    runs = win.runner.runs_started
    for k in range(len(states) - 1, 0, -1):
        qtbot.keyClick(win, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
        assert project_to_dict(win.project) == states[k - 1], k
        assert win.dart_panel.dart_names() == [d["name"] for d in states[k - 1]["pieces"][0]["darts"]]
    for k in range(1, len(states)):
        qtbot.keyClick(win, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
        assert project_to_dict(win.project) == states[k], k
    assert win.runner.runs_started == runs and not win.runner.busy  # undo and redo never solve


@pytest.mark.slow
def test_a_saved_project_with_darts_and_yarns_reopens_identically(solved, qtbot, make_window, tmp_path):
    win = solved
    doc = win.document
    draw_dart(qtbot, win)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        doc.add_dart(PlaneDart((0.0, 1.0, 0.0, -0.5), (0.0, 1.0, 0.0, 1.0, 0.0, 0.5), name="side"))
    doc.set_dart_visible(1, False)
    r = win.project.result
    node = int(np.argmin(np.linalg.norm(r.xyz - TARGETS[2], axis=1)))
    win.actions["tool_yarn"].trigger()
    win.tool.pick(node, "warp")
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        win.finish_tool()
    saved = project_to_dict(win.files.as_saved(win.project))  # as the file keeps it (view choices too)
    [piece] = saved["pieces"]
    assert len(piece["darts"]) == 2 and len(piece["yarns"]) == 1 and piece["darts"][1]["visible"] is False
    assert win.save_to(tmp_path / "darts")

    other = make_window(example="saddle")
    assert other.open_file(tmp_path / "darts.flatweave")
    assert project_to_dict(other.project) == saved
    assert other.project.result_is_current and not other.document.dirty
    assert other.dart_panel.dart_names() == ["curve dart 1", "side"]
    assert other.dart_panel.dart_checks() == [True, False]
    assert other.dart_panel.yarn_list.count() == 1
    assert other.view.dart_curves[1] is None
    np.testing.assert_array_equal(other.view.dart_curves[0], win.view.dart_curves[0])
    d0 = other.project.settings.darts[0]
    np.testing.assert_array_equal(d0.handles, win.project.settings.darts[0].handles)
    assert d0.view_dir == win.project.settings.darts[0].view_dir


@pytest.mark.slow
def test_a_click_just_off_the_rim_goes_onto_the_rim(solved, qtbot):
    win = solved
    view = win.view
    rim = np.array([np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0])  # on the octant's equator edge
    x0, y0 = view.display_point(rim)
    x1, y1 = view.display_point(rim - [0.0, 0.0, 0.1])  # below the rim: off the surface
    step = np.array([x1 - x0, y1 - y0]) / np.hypot(x1 - x0, y1 - y0)
    x, y = (int(round(v)) for v in np.array([x0, y0]) + 6 * step)
    assert ray_sphere(view, x, y, octant_only=True) is None  # a miss...
    win.actions["tool_curve_dart"].trigger()
    click(qtbot, view, x, y)
    assert len(win.tool.handles) == 1, win.last_hint  # ...taken onto the rim
    uv = win.tool.handles[0]
    dom = win.surface.domain
    assert np.min(np.abs(uv[:, None] - dom)) < 1e-12  # exactly on the domain's edge
    p = win.surface.points(uv[None])[0]
    assert abs(p[2]) < 1e-9 and np.hypot(*(np.array(view.display_point(p)) - [x, y])) <= 10.5
    assert "on the edge" in win.last_hint


def test_a_tool_error_is_a_one_line_message(solved, qtbot, monkeypatch):
    win = solved
    import flatweave.app.tools

    def broken(*_args):
        raise ZeroDivisionError("float division by zero\nsecond line")
    monkeypatch.setattr(flatweave.app.tools, "pick_surface", broken)
    revision = win.document.revision
    win.actions["tool_curve_dart"].trigger()
    click(qtbot, win.view, *pixel(win.view, TARGETS[0]))
    assert win.last_error == "curve dart: ZeroDivisionError: float division by zero"
    assert win.tool is not None and win.document.revision == revision  # the tool and document are intact
    monkeypatch.undo()
    click(qtbot, win.view, *pixel(win.view, TARGETS[0]))
    assert len(win.tool.handles) == 1


@pytest.mark.slow
def test_enter_in_a_settings_field_commits_the_field_not_the_dart(solved, qtbot):
    win = solved
    win.actions["tool_curve_dart"].trigger()
    for t in TARGETS[:2]:
        click(qtbot, win.view, *pixel(win.view, t))
    win.side_tabs.setCurrentWidget(win.settings_panel)
    field = win.settings_panel.tol
    field.setFocus()
    field.selectAll()
    qtbot.keyClicks(field, "1e-07")
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(field, Qt.Key.Key_Return)
    assert win.project.settings.tol == 1e-7
    assert win.project.settings.darts == () and len(win.tool.handles) == 2  # still drawing
