"""GUI tests of the interactive tools (issue 7): curve darts drawn by clicks in
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

from core.darts import DartSet, PlaneDart
from core.energy import yarn_nodes
from core.project import project_problems, project_to_dict

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
    core.curves); with ``octant_only`` the first meeting in the first octant."""
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
def test_a_three_click_curve_dart_lies_where_the_clicks_project_and_cuts(solved, qtbot):
    win = solved
    view, doc = win.view, win.document
    before = win.project
    frames_before = win.runner.frames_shown
    win.actions["tool_curve_dart"].trigger()
    pixels = [pixel(view, t) for t in TARGETS]
    for k, (x, y) in enumerate(pixels):
        click(qtbot, view, x, y)
        assert len(win.tool.handles) == k + 1, win.last_hint
        assert len(view.preview_points) == k + 1  # the curve grows on the surface as it is drawn
    assert len(view.preview_curve) > 10
    assert doc.project is before  # nothing is an edit before Enter
    qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    assert len(win.project.settings.darts) == 1
    dart = win.project.settings.darts[0]
    assert dart.kind == "curve" and dart.name == "curve dart 1" and len(dart.handles) == 3
    np.testing.assert_allclose(dart.view_dir, view.view_direction())
    assert len(view.preview_curve) == 0

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


def test_a_click_that_misses_the_surface_adds_nothing(solved, qtbot):
    win = solved
    view, doc = win.view, win.document
    revision = doc.revision
    win.actions["tool_curve_dart"].trigger()
    corner = (8, 8)  # the view's bottom left corner: off the octant
    assert ray_sphere(view, *corner, octant_only=True) is None
    click(qtbot, view, *corner)
    assert win.tool.handles == [] and len(view.preview_points) == 0
    assert "missed the surface" in win.last_hint
    assert "missed the surface" in win.statusBar().currentMessage()
    # one point on the surface, then another miss: still one point; Enter refuses a one-point dart
    click(qtbot, view, *pixel(view, TARGETS[1]))
    click(qtbot, view, *corner)
    assert len(win.tool.handles) == 1
    qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    assert "at least two points" in win.last_hint
    qtbot.keyClick(view.widget, Qt.Key.Key_Escape)
    assert win.tool.handles == [] and len(view.preview_points) == 0
    assert doc.revision == revision and win.project.settings.darts == ()
