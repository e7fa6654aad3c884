"""GUI tests of the views' render widgets (app/canvas.py): which one the app
picks, and that the raster canvas shows the scene as it is now, follows its
size, hands the mouse to VTK and renders once per paint pass.

Pixels are compared with VTK's own off-screen capture of the same render
window (pyvista's screenshot), never with a stored image.
"""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QPointF, Qt
from PySide6.QtGui import QWheelEvent
from PySide6.QtWidgets import QApplication

from flatweave.app import canvas
from flatweave.app.canvas import CanvasPlotter, GLPlotter, is_software_renderer, view_kind

from tests.test_app import run_app
from tests.test_app_run import run_to_end, small_project


@pytest.mark.parametrize("name, software", [
    ("llvmpipe (LLVM 15.0.6, 256 bits)", True),
    ("softpipe", True),
    ("Software Rasterizer", True),
    ("Mesa X11 swrast", True),
    ("GDI Generic", True),
    ("Microsoft Basic Render Driver", True),
    ("NVIDIA GeForce RTX 3080/PCIe/SSE2", False),
    ("AMD Radeon Pro 5500M OpenGL Engine", False),
    ("Mesa Intel(R) UHD Graphics 620 (KBL GT2)", False),
    ("Apple M2", False),
    ("", False),
])
def test_software_renderers_are_recognised(name, software):
    assert is_software_renderer(name) is software


def test_the_environment_chooses_the_widget(monkeypatch, qapp):
    monkeypatch.setenv("FLATWEAVE_VIEW", "gl")
    assert view_kind() == "gl"
    monkeypatch.setenv("FLATWEAVE_VIEW", " Canvas ")
    assert view_kind() == "canvas"
    monkeypatch.setenv("FLATWEAVE_VIEW", "vulkan")
    with pytest.raises(ValueError, match="FLATWEAVE_VIEW must be one of auto, gl, canvas"):
        view_kind()


def test_auto_chooses_by_the_renderer(monkeypatch, qapp):
    monkeypatch.delenv("FLATWEAVE_VIEW", raising=False)
    monkeypatch.setattr(canvas, "_chosen", None)
    name = canvas._qt_gl_renderer()
    assert view_kind() == ("canvas" if name is None or is_software_renderer(name) else "gl")
    for fake, kind in (("llvmpipe (LLVM 15.0.6, 256 bits)", "canvas"), ("NVIDIA GeForce GTX 1080/PCIe/SSE2", "gl"),
                       (None, "canvas")):
        monkeypatch.setattr(canvas, "_chosen", None)
        monkeypatch.setattr(canvas, "_qt_gl_renderer", lambda fake=fake: fake)
        assert view_kind() == kind


def test_the_app_command_lists_the_widget_kinds():
    from flatweave.app.choices import VIEW_KINDS
    from flatweave.app.choices import VIEW_KINDS as KINDS
    assert VIEW_KINDS == canvas.VIEW_KINDS == KINDS


def test_a_bad_view_setting_is_a_one_line_error(monkeypatch):
    monkeypatch.setenv("FLATWEAVE_VIEW", "vulkan")
    proc = run_app("resources/surfaces/octant.json", "--quit", timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "FLATWEAVE_VIEW" in lines[0] and "'vulkan'" in lines[0], proc.stderr


# ---------------------------------------------------------------------- the canvas
@pytest.fixture
def canvas_window(monkeypatch, make_window, qtbot):
    monkeypatch.setenv("FLATWEAVE_VIEW", "canvas")
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    qtbot.wait(50)
    return win


def vtk_capture(view) -> np.ndarray:
    """(h, w, 3) pixels of the view's render window, rendered and read by VTK itself."""
    return np.asarray(view.plotter.screenshot(None, return_img=True))[:, :, :3]


def shown(qtbot, view) -> np.ndarray:
    """What the canvas shows once Qt has painted it."""
    view.widget.repaint()
    return view.widget.image()


@pytest.mark.slow
def test_the_canvas_shows_the_scene_as_it_is_now(canvas_window, qtbot):
    win = canvas_window
    before = {}
    for view in (win.view, win.pattern_view):
        assert isinstance(view.plotter, CanvasPlotter)
        img = before[view] = shown(qtbot, view)
        assert img.shape[:2] == (view.widget.height(), view.widget.width())
        np.testing.assert_array_equal(img, vtk_capture(view))
        assert img.reshape(-1, 3).std(axis=0).max() > 10  # a picture, not a blank
    # a change to the scene is on screen at the next paint (not one frame late)
    win.actions["mode_shear"].trigger()
    QApplication.processEvents()
    for view in (win.view, win.pattern_view):
        after = shown(qtbot, view)
        np.testing.assert_array_equal(after, vtk_capture(view))
        changed = (np.abs(after.astype(int) - before[view].astype(int)).sum(axis=2) > 30).mean()
        assert changed > 0.01, f"only {100 * changed:.2f} % of the pixels changed"


def test_the_canvas_follows_its_size(canvas_window, qtbot):
    win = canvas_window
    view = win.view
    w0 = view.widget.width()
    win.resize(win.width() - 200, win.height() - 100)
    qtbot.waitUntil(lambda: view.widget.width() != w0, timeout=5000)
    img = shown(qtbot, view)
    w, h = view.widget.width(), view.widget.height()
    assert tuple(view.plotter.render_window.GetSize()) == (w, h)
    assert img.shape[:2] == (h, w)
    assert tuple(view.plotter.iren.interactor.GetSize()) == (w, h)  # the interactor flips y with this height


@pytest.mark.slow
def test_one_paint_pass_renders_each_view_once(canvas_window, qtbot):
    win = canvas_window
    frame = win.frame
    QApplication.processEvents()
    counts = [win.view.widget.renders, win.pattern_view.widget.renders]
    win.runner.thread = _Busy()  # the window draws frames while a run is on
    try:
        for _ in range(3):  # a frame asks each view for a redraw more than once; the paint merges them
            win.presenter.draw_frame(frame)
            win.view.render()
            QApplication.processEvents()
    finally:
        win.runner.thread = None
    assert [win.view.widget.renders - counts[0], win.pattern_view.widget.renders - counts[1]] == [3, 3]


class _Busy:
    abandoned = stopping = False
    paused = pause_requested = False
    history = ()
    stage = "test"


def test_mouse_on_the_canvas_turns_and_zooms_the_camera(canvas_window, qtbot):
    view = canvas_window.view
    w = view.widget
    cam = view.plotter.renderer.GetActiveCamera()
    p0, f0 = np.array(cam.GetPosition()), np.array(cam.GetFocalPoint())
    a, b = QPoint(w.width() // 2, w.height() // 2), QPoint(w.width() // 2 + 120, w.height() // 2 + 40)
    qtbot.mousePress(w, Qt.MouseButton.LeftButton, pos=a)
    for f in np.linspace(0, 1, 8)[1:]:
        qtbot.mouseMove(w, QPoint(int(a.x() + f * (b.x() - a.x())), int(a.y() + f * (b.y() - a.y()))))
    qtbot.mouseRelease(w, Qt.MouseButton.LeftButton, pos=b)
    p1 = np.array(cam.GetPosition())
    # a turn about the focal point: the camera moved, its distance did not
    assert np.linalg.norm(p1 - p0) > 0.1 * np.linalg.norm(p0 - f0)
    assert np.linalg.norm(p1 - f0) == pytest.approx(np.linalg.norm(p0 - f0), rel=1e-6)
    np.testing.assert_allclose(cam.GetFocalPoint(), f0, atol=1e-12)
    # the wheel zooms: towards the focal point forward, away backward
    d1 = np.linalg.norm(p1 - f0)
    for delta in (120, -240):
        centre = QPointF(w.width() / 2, w.height() / 2)
        event = QWheelEvent(centre, w.mapToGlobal(centre), QPoint(0, 0), QPoint(0, delta),
                            Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase,
                            False)
        QApplication.sendEvent(w, event)
        d2 = np.linalg.norm(np.array(cam.GetPosition()) - f0)
        assert (d2 < d1) if delta > 0 else (d2 > d1)
        d1 = d2


def test_the_canvas_puts_clicks_where_vtk_sees_them(canvas_window, qtbot):
    """A press at Qt pixel (x, y) is VTK display pixel (x, height - 1 - y), with the modifiers."""
    view = canvas_window.view
    w = view.widget
    iren = view.plotter.iren.interactor
    seen = []

    def note(obj, _event):
        seen.append((obj.GetEventPosition(), obj.GetControlKey(), obj.GetShiftKey(), obj.GetRepeatCount()))
        obj.GetCommand(tag).SetAbortFlag(1)  # keep the camera still
    tag = iren.AddObserver("RightButtonPressEvent", note, 100.0)
    try:
        ctrl, shift = Qt.KeyboardModifier.ControlModifier, Qt.KeyboardModifier.ShiftModifier
        qtbot.mousePress(w, Qt.MouseButton.RightButton, ctrl, QPoint(17, 23))
        qtbot.mouseRelease(w, Qt.MouseButton.RightButton, ctrl, QPoint(17, 23))
        qtbot.mouseDClick(w, Qt.MouseButton.RightButton, shift, QPoint(40, 5))
    finally:
        iren.RemoveObserver(tag)
    h = w.height()
    assert seen[0] == ((17, h - 1 - 23), 1, 0, 0)
    assert seen[-1] == ((40, h - 1 - 5), 0, 1, 1)  # the double click's second press repeats


def test_a_closed_canvas_paints_without_vtk(canvas_window, qtbot):
    view = canvas_window.pattern_view
    widget = view.widget
    view.close()
    assert view.plotter._closed
    widget.repaint()  # no render window any more: a plain fill, no error
    view.close()  # twice is fine


def test_the_gl_widget_is_pyvistaqts(monkeypatch, make_window):
    from pyvistaqt import QtInteractor

    monkeypatch.setenv("FLATWEAVE_VIEW", "gl")
    win = make_window(small_project(0.1))
    assert isinstance(win.view.plotter, GLPlotter) and isinstance(win.view.plotter, QtInteractor)
