"""GUI tests: the window, its surface, menus and errors, and the command.

Real windows on the Xvfb display that pytest-xvfb starts. Asserts are on data
(the mesh the view holds, the window's state, exit codes and the pixels of a
written PNG), not on golden images. Solves in the window: tests/test_app_run.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QImage

from flatweave.app.presenter import GRID_POINTS
from flatweave.app.view3d import grid_boundary, grid_faces
from flatweave.reading.examples import example_names, example_path
from flatweave.geometry.surface_json import load_surface

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def window(make_window):
    """The main window on the octant example, shown and ready to render."""
    return make_window(example="octant")


def expected_grid(surface, n=GRID_POINTS):
    """(n * n, 3) points of the surface on an n x n grid over its domain, u slowest."""
    (u0, u1), (v0, v1) = surface.domain
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
    return surface.points(np.column_stack([u.ravel(), v.ravel()]))


def image_array(path) -> np.ndarray:
    """(h, w, 3) uint8 pixels of an image file, read back with Qt."""
    img = QImage(str(path))
    assert not img.isNull(), f"{path} is not a readable image"
    img = img.convertToFormat(QImage.Format.Format_RGB888)
    h, w, stride = img.height(), img.width(), img.bytesPerLine()
    raw = np.frombuffer(img.constBits(), np.uint8, count=h * stride).reshape(h, stride)
    return raw[:, : w * 3].reshape(h, w, 3).copy()


# ---------------------------------------------------------------------- pure helpers
def test_grid_faces_and_boundary():
    faces = grid_faces(3, 4).reshape(-1, 5)
    assert faces.shape == (6, 5) and np.all(faces[:, 0] == 4)
    assert set(faces[:, 1:].ravel()) == set(range(12))
    loop = grid_boundary(3, 4)
    assert loop[0] == loop[-1]
    assert len(set(loop)) == len(loop) - 1 == 2 * (3 + 4) - 4
    idx = np.arange(12).reshape(3, 4)
    assert set(loop) == set(idx[0]) | set(idx[-1]) | set(idx[:, 0]) | set(idx[:, -1])


# ---------------------------------------------------------------------- the window
@pytest.mark.slow
def test_window_shows_the_example_surface(window):
    surface = load_surface(example_path("octant"))
    pts = window.view.surface_points
    assert window.view.surface_shape == (GRID_POINTS, GRID_POINTS)
    assert pts.shape == (GRID_POINTS * GRID_POINTS, 3)
    # the mesh points lie on the NURBS surface: core's evaluation at the same grid
    np.testing.assert_allclose(pts, expected_grid(surface), atol=1e-12)
    # and, independently of any evaluator, on the unit sphere in the first octant
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-9)
    assert np.all(pts >= -1e-12)
    assert "octant" in window.windowTitle()
    assert window.surface_name == "octant"
    assert window.actions["reset_view"].isEnabled()


def test_examples_menu_lists_the_examples(window):
    names = [a.data() for a in window.examples_menu.actions()]
    assert names == example_names()


def test_open_another_example(window):
    other = next(n for n in example_names() if n != "octant")
    assert window.open_file(example_path(other))
    assert window.surface_name == Path(example_path(other)).stem
    assert other in window.windowTitle()
    surface = load_surface(example_path(other))
    np.testing.assert_allclose(window.view.surface_points, expected_grid(surface), atol=1e-12)


def test_examples_menu_action_opens_the_example(window):
    action = next(a for a in window.examples_menu.actions() if a.data() == "saddle")
    action.trigger()
    assert window.surface_name == Path(example_path("saddle")).stem
    pts = window.view.surface_points
    # saddle z = (x^2 - y^2) / 2, exactly
    np.testing.assert_allclose(pts[:, 2], (pts[:, 0] ** 2 - pts[:, 1] ** 2) / 2, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("content", [
    None,  # missing file
    "{ this is not json",
    json.dumps({"shape": {"type": "curve", "count": 1, "data": []}}),
])
def test_bad_file_shows_an_error_and_keeps_the_surface(window, qtbot, tmp_path, content):
    path = tmp_path / "bad.json"
    if content is not None:
        path.write_text(content)
    old_surface, old_points = window.surface, window.view.surface_points

    assert not window.open_file(path)

    message = window.last_error
    assert message and "\n" not in message and "bad.json" in message
    qtbot.waitUntil(lambda: window.error_box is not None and window.error_box.isVisible())
    assert window.error_box.text() == message
    # shown without blocking: not application-modal, and open_file has returned
    assert window.error_box.windowModality() != Qt.WindowModality.ApplicationModal
    assert window.surface is old_surface and window.surface_name == "octant"
    np.testing.assert_array_equal(window.view.surface_points, old_points)


@pytest.mark.slow
def test_window_grab_is_not_blank(each_widget, window):
    window.view.render()
    img = window.grab().toImage().convertToFormat(QImage.Format.Format_RGB888)
    assert img.width() > 400 and img.height() > 300
    h, w, stride = img.height(), img.width(), img.bytesPerLine()
    raw = np.frombuffer(img.constBits(), np.uint8, count=h * stride).reshape(h, stride)
    pixels = raw[:, : w * 3].reshape(h, w, 3)
    centre = pixels[h // 4: 3 * h // 4, w // 4: 3 * w // 4].reshape(-1, 3).astype(float)
    assert centre.std(axis=0).max() > 10, "the 3D area looks blank"


# ---------------------------------------------------------------------- the command
def run_app(*args, timeout=120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "flatweave.app.main", *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout, env=os.environ.copy())


@pytest.mark.slow
def test_startup_smoke_writes_a_screenshot(tmp_path):
    out = tmp_path / "x.png"
    proc = run_app("resources/surfaces/octant.json", "--screenshot", out, "--quit")
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    pixels = image_array(out)
    h, w, _ = pixels.shape
    assert w >= 400 and h >= 300
    assert pixels.reshape(-1, 3).astype(float).std(axis=0).max() > 10, "blank screenshot"
    # the surface is drawn in the middle of the 3D area: many distinct colours there
    centre = pixels[h // 4: 3 * h // 4, w // 4: 3 * w // 4].reshape(-1, 3)
    assert len(np.unique(centre, axis=0)) > 50


def test_bad_surface_file_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2, 3]")
    proc = run_app(bad, "--quit", timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.json" in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


def test_missing_surface_file_exits_2(tmp_path):
    proc = run_app(tmp_path / "nope.json", "--quit", timeout=60)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


@pytest.mark.slow
@pytest.mark.parametrize("view", ["auto", "gl", "canvas"])
def test_scripted_run_writes_a_screenshot_of_the_solved_piece(tmp_path, view):
    out = tmp_path / "run.png"
    proc = run_app("resources/surfaces/octant.json", "--spacing", "0.1", "--run", "--screenshot", out,
                   "--quit", "--size", "1200x800", "--view", view)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    pixels = image_array(out).astype(int)
    h, w, _ = pixels.shape
    assert (w, h) == (1200, 800)
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    # the strain colours are on screen: pure-ish red, green and blue springs
    assert ((r > 200) & (g < 60) & (b < 60)).sum() > 20, "no tensile (red) springs drawn"
    assert ((b > 200) & (r < 60) & (g < 60)).sum() > 20, "no compressive (blue) springs drawn"
    assert ((g > 200) & (r < 80) & (b < 80)).sum() > 200, "no zero-strain (green) springs drawn"


@pytest.mark.slow
def test_scripted_run_that_fails_exits_1_with_one_line(tmp_path):
    out = tmp_path / "never.png"
    proc = run_app("resources/surfaces/octant.json", "--spacing", "0.0001", "--run", "--screenshot", out,
                   "--quit")
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "nodes" in lines[0] and lines[0].startswith("flatweave: error:"), proc.stderr
    assert not out.exists()


@pytest.mark.slow
def test_opening_a_project_from_the_command_line(tmp_path):
    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten
    from flatweave.document.project import Project, save_project

    surface = load_surface(example_path("octant"))
    s = FlattenSettings(spacing=0.1)
    save_project(Project(surface, s, name="o", result=flatten(surface, s)), tmp_path / "o.flatweave")
    proc = run_app(tmp_path / "o.flatweave", "--screenshot", tmp_path / "o.png", "--quit", "--size", "1000x700")
    assert proc.returncode == 0, proc.stderr
    pixels = image_array(tmp_path / "o.png").astype(int)
    assert ((pixels[..., 1] > 200) & (pixels[..., 0] < 80) & (pixels[..., 2] < 80)).sum() > 200
    bad = tmp_path / "bad.flatweave"
    bad.write_text("{")
    proc = run_app(bad, "--quit", timeout=60)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "bad.flatweave" in proc.stderr


# ---------------------------------------------------------------------- the actions table
def test_menus_and_toolbar_come_from_the_actions_table(window):
    from PySide6.QtWidgets import QToolBar

    from flatweave.app.actions import MENUS, action_specs
    from flatweave.app.tooling import tool_specs

    ACTIONS = action_specs()
    assert window.action_specs == ACTIONS
    assert list(window.actions) == [spec.key for spec in ACTIONS]
    assert [a.text() for a in window.menuBar().actions()] == list(MENUS)
    by_action = {a: key for key, a in window.actions.items()}
    for title, menu in window.menus.items():
        keys = [by_action[a] for a in menu.actions() if a in by_action]
        assert sorted(keys) == sorted(s.key for s in ACTIONS if s.menu == title), title
    toolbar = window.findChild(QToolBar)
    keys = [by_action[a] for a in toolbar.actions() if not a.isSeparator()]
    assert sorted(keys) == sorted(s.key for s in ACTIONS if s.toolbar is not None)
    for t in (t for t in tool_specs() if t.key):  # a tool's row gives its action, menus, toolbar and panel buttons
        a = window.actions[t.key]
        assert a.isCheckable() and a.shortcut().toString() == t.shortcut
        assert a in window.menus[t.menu].actions() and a in toolbar.actions()
        assert not t.panel_button or getattr(window.dart_panel, t.panel_button).defaultAction() is a


def test_actions_follow_the_state(make_window):
    win = make_window(example=None)
    enabled = {key for key, a in win.actions.items() if a.isEnabled()}
    assert enabled == {"open", "quit", "mode_strain", "mode_shear", "mode_fibre", "show_weft", "show_warp",
                       "show_diag", "show_surface", "show_nodes"}
    assert not win.settings_panel.isEnabled() and not win.dart_panel.isEnabled()
    assert win.open_example("octant")
    enabled = {key for key, a in win.actions.items() if a.isEnabled()}
    assert {"run", "save", "save_as", "reset_view", "fit_pattern", "tool_curve_dart", "tool_yarn"} <= enabled
    assert not enabled & {"pause", "stop", "export", "undo", "redo", "tool_finish", "tool_cancel", "tool_back"}
    win.actions["tool_curve_dart"].trigger()
    assert win.actions["tool_curve_dart"].isChecked()
    assert all(win.actions[k].isEnabled() for k in ("tool_finish", "tool_cancel", "tool_back"))
    win.actions["tool_plane_dart"].trigger()
    assert win.actions["tool_plane_dart"].isChecked() and not win.actions["tool_curve_dart"].isChecked()
    assert not win.actions["tool_back"].isEnabled() and win.actions["tool_finish"].isEnabled()
    win.actions["tool_cancel"].trigger()
    assert win.tool is None and not any(win.actions[t].isChecked() for t in ("tool_plane_dart", "tool_curve_dart"))
    win.document.edit_settings("Tolerance", tol=1e-7)
    assert win.actions["undo"].isEnabled() and win.actions["undo"].text() == "&Undo Tolerance"
