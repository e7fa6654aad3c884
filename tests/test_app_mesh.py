"""The window opens meshes (STL, OBJ, PLY, OFF): File > Open makes the mesh a
surface and a piece, the metrics say how far the surface is from the mesh, and
on request the 3D view draws the mesh coloured by each vertex's distance to the
surface, over the surface or beside it.

Truth from outside the window: the mesh is a sphere cap made here (its vertices
on the unit sphere), and the deviation the colours map must be the one core
reports (``metrics.fit_max_deviation`` of the run's result)."""

from __future__ import annotations

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

from flatweave.geometry.meshfit import FittedSurface, MeshFit, fit_deviation  # noqa: E402

RUN_TIMEOUT_MS = 90000


def sphere_cap_mesh(n: int = 24):
    """A cap of the unit sphere over the disk of radius 0.6 (a grid's triangles inside it)."""
    u, v = np.meshgrid(np.linspace(-0.6, 0.6, n), np.linspace(-0.6, 0.6, n), indexing="ij")
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
    x, y = u.ravel(), v.ravel()
    F = F[np.hypot(x[F].mean(1), y[F].mean(1)) < 0.6]
    used = np.unique(F)
    x, y = x[used], y[used]
    return np.stack([x, y, np.sqrt(1 - x * x - y * y)], 1), np.searchsorted(used, F)


@pytest.fixture
def cap_stl(tmp_path):
    V, F = sphere_cap_mesh()
    path = tmp_path / "cap.stl"
    path.write_bytes(trimesh.Trimesh(V, F, process=False).export(file_type="stl"))
    return path, V


def test_open_filter_lists_the_mesh_formats():
    from flatweave.app.files import open_filter

    first = open_filter().split(";;")[0]
    assert all(f"*{s}" in first for s in (".stl", ".obj", ".ply", ".off"))


@pytest.mark.slow
def test_open_an_stl_run_and_the_fit_numbers(make_window, qtbot, cap_stl):
    path, V = cap_stl
    win = make_window(example=None)
    assert not win.actions["show_fit_deviation"].isEnabled()
    assert win.open_file(path)
    surface = win.project.surface
    assert isinstance(surface, FittedSurface) and win.project.settings.region is not None
    fit = surface.fit
    # the cap's vertices are on the unit sphere; the surface follows them within its reported deviation
    assert fit.vertices == len(V) and 0 < fit.max_deviation < 1e-3 * fit.size
    assert win.actions["show_fit_deviation"].isEnabled() and win.actions["show_fit_mesh"].isEnabled()
    text = win.metrics.text("fit")
    assert f"{fit.max_deviation:.3g} m" in text and f"({100 * fit.max_deviation / fit.size:.3g} %)" in text
    assert f"mean {fit.mean_deviation:.3g} m" in text
    win.run()
    qtbot.waitUntil(lambda: win.project.result is not None and win.runner.state == "idle", timeout=RUN_TIMEOUT_MS)
    m = win.project.result.metrics
    assert m["fit_max_deviation"] == fit.max_deviation and m["fit_mean_deviation"] == fit.mean_deviation
    assert win.metrics.text("fit") == text  # the result's display keeps the surface's fit
    assert win.metrics.text("boundary") == f"{m['boundary_error_pct']:.3f} %"  # the piece's pattern is shown


@pytest.mark.slow
def test_deviation_map_and_mesh_beside(make_window, qtbot, cap_stl):
    path, V = cap_stl
    win = make_window(example=None)
    assert win.open_file(path)
    surface = win.project.surface
    view = win.view
    assert not view.fit_mesh_shown and view.fit_colour_range is None  # only on request
    win.actions["show_fit_deviation"].trigger()
    assert view.fit_mesh_shown
    lo, hi = view.fit_colour_range
    values = view.fit_deviation_values
    # the colours map core's deviations: their largest is the fit's, the range runs from 0 to it
    assert lo == 0.0 and abs(hi - surface.fit.max_deviation) < 1e-9
    assert abs(values.max() - surface.fit.max_deviation) < 1e-9
    assert abs(values.mean() - surface.fit.mean_deviation) < 1e-9
    # ... and they are distances of the mesh file's vertices (a check outside the fit's own numbers)
    mesh = surface.mesh
    assert np.allclose(np.sort(mesh.vertices, axis=0), np.sort(V, axis=0), atol=1e-6)  # STL stores float32
    assert np.allclose(values, fit_deviation(surface, mesh.uv, mesh.vertices))
    assert np.allclose(view.fit_mesh_offset, 0.0)  # over the surface
    view.render_now()

    before = view.plotter.renderer.GetActiveCamera().GetPosition()
    win.actions["show_fit_mesh"].trigger()
    off = view.fit_mesh_offset
    width = np.ptp(V @ (off / np.linalg.norm(off)))
    assert np.linalg.norm(off) > width  # beside, not overlapping
    assert view.plotter.renderer.GetActiveCamera().GetPosition() != before  # framed to show both
    win.actions["show_fit_deviation"].trigger()
    assert view.fit_mesh_shown and view.fit_colour_range is None  # plain, beside
    win.actions["show_fit_mesh"].trigger()
    assert not view.fit_mesh_shown

    win.open_example("octant")  # a NURBS surface: no mesh, the toggles are off
    assert not win.actions["show_fit_deviation"].isEnabled() and not view.fit_mesh_shown
    assert win.metrics.text("fit") == "-"


@pytest.mark.slow
def test_a_reopened_project_reads_its_mesh_again_on_request(make_window, qtbot, cap_stl, tmp_path):
    path, _ = cap_stl
    win = make_window(example=None)
    assert win.open_file(path)
    max_dev = win.project.surface.fit.max_deviation
    saved = tmp_path / "cap.flatweave"
    assert win.files.save_to(saved)
    win2 = make_window(example=None)
    assert win2.open_file(saved)
    surface = win2.project.surface
    assert surface.mesh is None and surface.fit.max_deviation == max_dev
    win2.actions["show_fit_deviation"].trigger()
    assert abs(win2.view.fit_colour_range[1] - max_dev) < 1e-9
    # the mesh gone: one line, and nothing drawn
    win3 = make_window(example=None)
    assert win3.open_file(saved)
    path.unlink()
    win3.actions["show_fit_deviation"].trigger()
    assert not win3.view.fit_mesh_shown
    assert "is not there any more" in win3.statusBar().currentMessage()
    win3.statusBar().clearMessage()
    win3.actions["show_weft"].trigger()  # another view change does not try again
    assert win3.statusBar().currentMessage() == ""
    win3.actions["show_fit_mesh"].trigger()  # the mesh's own toggles do
    assert "is not there any more" in win3.statusBar().currentMessage() and not win3.view.fit_mesh_shown


def test_a_closed_mesh_says_it_needs_a_region_and_its_piece_is_drawn_on_it(make_window, qtbot, tmp_path):
    """A sphere: the window says in one line it needs a region and shows it to draw the piece on;
    twelve clicks round the ring z = 0.5, one taken back, and OK open the cap above the ring."""
    import math

    from PySide6.QtCore import QPoint, Qt
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    from flatweave.geometry.region import cover_for

    path = tmp_path / "ball.stl"
    path.write_bytes(trimesh.creation.icosphere(4).export(file_type="stl"))
    win = make_window(example=None)
    shown = []
    win.show_error = shown.append
    assert win.open_file(path) and not shown and win.project is None
    message = win.statusBar().currentMessage()
    assert "\n" not in message and "closed mesh" in message and "draw the piece" in message
    picker = win.files.face_picker
    qtbot.waitExposed(picker)
    qtbot.waitUntil(picker.view.is_ready, timeout=10000)
    view = picker.view
    view.plotter.camera_position = "xy"  # from above: the whole ring in sight
    view.plotter.reset_camera()
    view.render_now()
    assert not picker.ok_button.isEnabled()
    t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    z0 = 0.5
    ring = np.stack([math.sqrt(1 - z0 * z0) * np.cos(t), math.sqrt(1 - z0 * z0) * np.sin(t), z0 + 0 * t], 1)
    w = view.widget
    ratio = w.devicePixelRatioF()
    for p in [*ring, [0.0, 0.0, 1.0]]:
        c = vtkCoordinate()
        c.SetCoordinateSystemToWorld()
        c.SetValue(*p)
        x, y = c.GetComputedDoubleDisplayValue(view.plotter.renderer)
        qtbot.mouseClick(w, Qt.MouseButton.LeftButton,
                         pos=QPoint(int(round(x / ratio)), w.height() - 1 - int(round(y / ratio))))
    assert len(picker.points) == 13
    assert np.linalg.norm(picker.points[-1] - [0, 0, 1]) < 0.05  # the click's point on the mesh
    picker.back_button.click()
    assert len(picker.points) == 12 and picker.ok_button.isEnabled()
    assert np.abs(np.array(picker.points) - ring).max() < 0.05  # each click found the mesh under it
    picker.ok_button.click()
    qtbot.waitUntil(lambda: win.project is not None, timeout=60000)
    surface = win.project.surface
    assert isinstance(surface, FittedSurface) and "cut along a drawn loop" in surface.fit.repairs
    cover = cover_for(surface, win.project.settings.region)
    V, F = surface.mesh.vertices, surface.mesh.triangles
    assert V[:, 2].min() > z0 - 0.15  # the cap above the ring (the smaller side)
    mesh_area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    assert cover.area == pytest.approx(mesh_area, rel=3e-3)
    # between the caps above z0 + 0.1 and z0 - 0.1: the outline runs through the twelve clicks
    assert 2 * math.pi * (0.9 - z0) < cover.area < 2 * math.pi * (1.1 - z0)
    assert win.actions["show_fit_deviation"].isEnabled() and not shown


def test_meshfit_record_round_trip():
    fit = MeshFit("a.stl", 10, 12, 2.0, 0.001, 0.0002, (7, 7), ("merged 1 duplicate vertices",))
    assert MeshFit.from_dict(fit.to_dict()) == fit


def click_world(qtbot, view, p) -> None:
    """A real click on a picker's view where it shows world point ``p``."""
    from PySide6.QtCore import QPoint, Qt
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    c = vtkCoordinate()
    c.SetCoordinateSystemToWorld()
    c.SetValue(*p)
    x, y = c.GetComputedDoubleDisplayValue(view.plotter.renderer)
    w = view.widget
    ratio = w.devicePixelRatioF()
    qtbot.mouseClick(w, Qt.MouseButton.LeftButton,
                     pos=QPoint(int(round(x / ratio)), w.height() - 1 - int(round(y / ratio))))


@pytest.fixture
def dome_stl(tmp_path):
    """An open dome: the unit icosphere's triangles above z = -0.2 (a hemisphere and a band; 45 % map distortion)."""
    m = trimesh.creation.icosphere(4)
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    F = F[V[F].mean(axis=1)[:, 2] > -0.2]
    used = np.unique(F)
    path = tmp_path / "dome.stl"
    path.write_bytes(trimesh.Trimesh(V[used], np.searchsorted(used, F), process=False).export(file_type="stl"))
    return path


@pytest.mark.slow
def test_an_open_mesh_far_from_developable_asks_for_a_panel_which_is_cut_and_solved(make_window, qtbot, dome_stl):
    """The dome: the window asks for a panel; twelve clicks round the circle 40 degrees from the
    top and OK cut the cap out with its outline through the clicks; it solves within the limits."""
    from tests.test_app_run import run_to_end

    win = make_window(example=None)
    shown = []
    win.show_error = shown.append
    assert win.open_file(dome_stl) and not shown and win.project is None
    message = win.statusBar().currentMessage()
    assert "\n" not in message and "far from developable" in message
    picker = win.files.face_picker
    qtbot.waitExposed(picker)
    qtbot.waitUntil(picker.view.is_ready, timeout=10000)
    assert picker.whole_button is not None and "far from developable" in picker.label.text()
    view = picker.view
    view.plotter.camera_position = "xy"
    view.plotter.reset_camera()
    view.render_now()
    a = np.radians(40.0)
    t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.stack([np.sin(a) * np.cos(t), np.sin(a) * np.sin(t), np.cos(a) + 0 * t], 1)
    for p in ring:
        click_world(qtbot, view, p)
    assert len(picker.points) == 12 and np.abs(np.array(picker.points) - ring).max() < 0.05
    picker.ok_button.click()
    qtbot.waitUntil(lambda: win.project is not None, timeout=60000)
    surface = win.project.surface
    V = surface.mesh.vertices
    polar = np.arctan2(np.linalg.norm(V[:, :2], axis=1), V[:, 2])
    assert polar.max() < a + 0.02  # nothing outside the drawn ring
    for p in ring:  # the outline passes through every click (split triangles, not the nearest edges)
        assert np.linalg.norm(V - p, axis=1).min() < 0.02
    run_to_end(qtbot, win)
    r = win.project.result
    # the 40-degree cap's curvature (1.47 sr) accounts for about 6 % boundary error: within its limit
    assert r.metrics["boundary_error_pct"] < 8.0 and not any("boundary error" in w for w in r.warnings)
    assert r.usable and not shown and surface.fit.map_distortion < 0.15


def test_an_open_mesh_far_from_developable_can_still_be_opened_whole(make_window, qtbot, dome_stl):
    win = make_window(example=None)
    assert win.open_file(dome_stl) and win.project is None
    picker = win.files.face_picker
    qtbot.waitExposed(picker)
    picker.whole_button.click()
    qtbot.waitUntil(lambda: win.project is not None, timeout=30000)
    fit = win.project.surface.fit
    assert fit.map_distortion > 0.3 and "cut along a drawn loop" not in fit.repairs


def test_a_mesh_far_from_developable_on_the_command_line_opens_the_panel_picker(make_window, qtbot, dome_stl):
    from flatweave.app.main import build_parser, load_start_project, open_start
    from flatweave.app.meshpicker import MeshLoopPicker

    project, path, opened = load_start_project(build_parser().parse_args([str(dome_stl)]))
    assert project is None and opened.mesh.advice
    win = make_window(example=None)
    open_start(win, project, path, opened)
    assert isinstance(win.files.face_picker, MeshLoopPicker) and win.project is None


def test_a_mesh_takes_the_units_its_size_suggests_and_asks(make_window, qtbot, tmp_path):
    """A cap 300 units across: the project takes mm (never silently metres) and a non-modal question
    shows its size in each unit; choosing cm is one undoable edit."""
    from flatweave.app.meshdialog import MeshDialog

    V, F = sphere_cap_mesh()
    path = tmp_path / "cap_mm.stl"
    path.write_bytes(trimesh.Trimesh(V * 250.0, F, process=False).export(file_type="stl"))
    win = make_window(example=None)
    assert win.open_file(path) and win.project.units == "mm"
    dialog = win.files.mesh_dialog
    assert isinstance(dialog, MeshDialog) and dialog.isVisible()
    assert dialog.units.currentData() == "mm" and "carries no units" in dialog.label.text()
    texts = [dialog.units.itemText(k) for k in range(dialog.units.count())]
    size = win.project.surface.fit.size
    assert f"{size * 0.001:.3g} m across" in texts[dialog.units.findData("mm")]
    dialog.units.setCurrentIndex(dialog.units.findData("cm"))
    dialog.accept()
    assert win.project.units == "cm" and win.document.undo_label == "Units"


def test_a_fit_tolerance_given_in_the_window_refits_the_piece_as_one_undoable_edit(make_window, qtbot, tmp_path):
    """The dialog's fit tolerance refits the surface (the same map, so the region and anything drawn on it
    stay); Undo brings the first fit back; a tolerance the mesh cannot meet, or not a number, changes nothing."""
    V, F = sphere_cap_mesh()
    path = tmp_path / "cap_mm.stl"
    path.write_bytes(trimesh.Trimesh(V * 250.0, F, process=False).export(file_type="stl"))
    win = make_window(example=None)
    assert win.open_file(path)
    first = win.project.surface
    assert first.fit.tolerance is None
    tol = 0.5 * first.fit.max_deviation
    dialog = win.files.mesh_dialog
    dialog.tolerance.setText("-1")
    dialog.accept()
    assert dialog.isVisible() and "positive length" in dialog.error.text() and win.project.surface is first
    dialog.tolerance.setText(f"{tol:g}")
    dialog.accept()
    fit = win.project.surface.fit
    assert fit.tolerance == pytest.approx(tol, rel=1e-5) and fit.max_deviation <= fit.tolerance
    assert win.project.settings.region is not None and win.document.undo_label == "Fit tolerance"
    win.undo()
    assert win.project.surface is first
    errors = []
    win.show_error = errors.append
    assert not win.files.refit_mesh(win.document, 1e-12)
    assert win.project.surface is first and "over the fit tolerance" in errors[-1]


def test_a_tube_opens_its_picker_for_a_seam_and_is_opened_along_the_seam_drawn(make_window, qtbot, tmp_path):
    """A mesh open at two ends (an open cylinder, ``tests.test_meshseam.tube``): File > Open shows the
    picker drawing a seam; two clicks on its near side, from end to end, and OK open it along that line
    into one piece, which solves to the cylinder's development (issue 40 item 4)."""
    from flatweave.app.meshpicker import MeshLoopPicker
    from tests.test_app_run import run_to_end
    from tests.test_meshseam import H, R, tube

    path = tmp_path / "sleeve.stl"
    path.write_bytes(trimesh.Trimesh(*tube(), process=False).export(file_type="stl"))
    win = make_window(example=None)
    shown = []
    win.show_error = shown.append
    assert win.open_file(path) and not shown and win.project is None
    assert "open at 2 ends" in win.statusBar().currentMessage() and "draw a seam" in win.statusBar().currentMessage()
    picker = win.files.face_picker
    assert isinstance(picker, MeshLoopPicker) and picker.seam and "Draw a seam" in picker.label.text()
    qtbot.waitExposed(picker)
    qtbot.waitUntil(picker.view.is_ready, timeout=10000)
    view = picker.view
    view.plotter.camera_position = "yz"  # seen from +x: the side at x = R in front
    view.plotter.reset_camera()
    view.render_now()
    ends = np.array([[R, 0.0, 4.0], [R, 0.0, H - 4.0]])  # on an edge of the mesh, seen square on
    for p in ends:  # each exactly over an edge of the mesh: the pick still meets a triangle
        click_world(qtbot, view, p)
    assert len(picker.points) == 2 and np.abs(np.array(picker.points) - ends).max() < 1.0
    assert picker.ok_button.isEnabled()
    picker.seam_button.click()  # a panel's outline needs 3 points: OK waits
    assert not picker.ok_button.isEnabled() and "round it" in picker.label.text()
    picker.seam_button.click()
    picker.ok_button.click()
    qtbot.waitUntil(lambda: win.project is not None, timeout=60000)
    surface = win.project.surface
    assert "cut along a drawn seam" in surface.fit.repairs and surface.fit.map_distortion < 1e-3
    run_to_end(qtbot, win)
    r = win.project.result
    m = r.metrics
    assert r.status == "converged" and not shown, r.warnings
    assert abs(m["area_error_signed_pct"]) < 0.02 and abs(m["boundary_error_signed_pct"]) < 0.02
    assert m["area_3d"] == pytest.approx(2 * np.pi * R * H, rel=1e-4)
