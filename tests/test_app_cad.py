"""The window opens STEP and IGES files: a file with several faces shows the
face picker (a click on a face in its 3D view chooses it), the trimmed piece
is drawn with its loops, and the project keeps the face's surface, region and
source, so it reopens without the CAD file."""

from __future__ import annotations


import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from tests.helpers import needs_ocp
pytestmark = needs_ocp

RUN_TIMEOUT_MS = 90000


def moved(cf, shape, dx):
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location
    t = gp_Trsf()
    t.SetTranslation(gp_Vec(dx, 0.0, 0.0))
    return shape.Moved(TopLoc_Location(t))


@pytest.fixture
def three_faces(tmp_path):
    """A STEP file with three faces side by side (two with holes)."""
    from tests import cadfiles as cf
    shape = cf.compound(cf.face_circle_hole(), moved(cf, cf.face_mixed_outer(), 70.0),
                        moved(cf, cf.face_rational_hole(), 140.0))
    return cf.write_step(shape, tmp_path / "three.step")


def click(qtbot, view, x, y):
    w = view.widget
    qtbot.mouseClick(w, Qt.MouseButton.LeftButton, pos=QPoint(int(round(x)), w.height() - 1 - int(round(y))))


@pytest.mark.slow
def test_pick_a_face_by_clicking_run_export_save_and_reopen(make_window, qtbot, tmp_path, three_faces):
    from flatweave.export.registry import ExportOptions
    from flatweave.app.facepicker import face_mesh

    win = make_window()
    before = win.project
    assert win.open_file(three_faces)
    picker = win.files.face_picker
    assert picker is not None and win.project is before  # nothing opened yet
    qtbot.waitExposed(picker)
    qtbot.waitUntil(picker.view.is_ready, timeout=10000)
    assert picker.list.count() == 3 and "trimmed" in picker.list.item(0).text()
    assert picker.face is None and not picker.ok_button.isEnabled()
    picker.view.render_now()

    # a point of face 1's mesh, near its middle, where the view shows face 1
    pts, tris = face_mesh(picker.opened.cad.faces[1])
    centroids = pts[tris].mean(axis=1)
    order = np.argsort(np.linalg.norm(centroids - centroids.mean(axis=0), axis=1))
    for k in order[:50]:
        x, y = picker.view.display_point(centroids[k])
        if picker.view.face_at(x, y) == 1:
            break
    else:
        pytest.fail("face 1 is nowhere in the picker's view")
    click(qtbot, picker.view, x, y)
    assert picker.face == 1 and picker.list.currentRow() == 1 and picker.ok_button.isEnabled()

    picker.ok_button.click()
    qtbot.waitUntil(lambda: win.files.face_picker is None, timeout=5000)
    project = win.project
    face = project.settings.region
    assert face is not None and face.n_holes == 0  # face_mixed_outer: corners, no hole
    assert project.source == f"{three_faces}#face=1" and project.name == "three face 1"
    assert project.units == "mm"
    # the trimmed piece: fewer quads than the whole grid, and its loop drawn
    assert len(win.view.loops) == 1 and 0 < win.view.kept_cells < 59 * 59

    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        win.run()
    assert blocker.args[0].result is not None and not blocker.args[0].stopped
    assert win.project.result is not None
    # the numbers shown are the piece's (its area and boundary, not the whole patch's)
    assert win.frame.stats["area_error_pct"] < 5.0 and win.frame.stats["boundary_error_pct"] < 5.0
    dxf = tmp_path / "piece.dxf"
    with qtbot.waitSignal(win.export_finished, timeout=60000):
        assert win.export_to([dxf], ExportOptions())
    assert dxf.stat().st_size > 0

    saved = tmp_path / "piece.flatweave"
    assert win.save_to(saved)
    three_faces.unlink()
    win2 = make_window(example=None)
    assert win2.open_file(saved)
    p2 = win2.project
    assert p2.source == project.source and p2.name == project.name
    assert p2.settings.region is not None
    for a, b in zip(p2.settings.region.arrays(), project.settings.region.arrays()):
        np.testing.assert_allclose(a, b)
    assert len(win2.view.loops) == 1 and win2.view.kept_cells == win.view.kept_cells


def test_choose_from_the_list_cancel_and_single_face(make_window, qtbot, tmp_path, three_faces):
    from tests import cadfiles as cf

    win = make_window()
    before = win.project
    assert win.open_file(three_faces)
    picker = win.files.face_picker
    picker.list.setCurrentRow(2)
    assert picker.face == 2 and picker.ok_button.isEnabled()
    picker.reject()
    qtbot.waitUntil(lambda: win.files.face_picker is None, timeout=5000)
    assert win.project is before

    one = cf.write_step(cf.face_circle_hole(), tmp_path / "hole.step")
    assert win.open_file(one)
    assert win.files.face_picker is None
    region = win.project.settings.region
    assert region is not None and region.n_holes == 1 and win.project.source == str(one)
    assert len(win.view.loops) == 2 and win.view.kept_cells < 59 * 59


def test_a_file_of_several_faces_on_the_command_line_opens_the_face_picker(make_window, qtbot, three_faces):
    """``flatweave PART.step`` (as a file manager passes it) opens the face picker over an empty window,
    as File > Open does; with --run it is one line, status 2."""
    from flatweave.app.facepicker import FacePicker
    from flatweave.app.main import build_parser, load_start_project, main, open_start

    args = build_parser().parse_args([str(three_faces)])
    project, path, opened = load_start_project(args)
    assert project is None and path is None and len(opened.cad.faces) == 3
    win = make_window(example=None)
    open_start(win, project, path, opened)
    picker = win.files.face_picker
    assert isinstance(picker, FacePicker) and picker.isVisible() and win.project is None
    picker.chosen.emit(1)
    qtbot.waitUntil(lambda: win.project is not None, timeout=30000)
    assert win.project.source.endswith("#face=1")
    assert main([str(three_faces), "--run"]) == 2
