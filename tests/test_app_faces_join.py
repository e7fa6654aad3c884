"""The face picker joins faces: a shift-click adds a face to the choice (a
second one takes it out), OK opens the faces joined into one surface
(flatweave.reading.cadjoin.join_faces), and the project keeps the fitted surface and which
faces it joins, so it reopens without the CAD file."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from tests.helpers import needs_ocp

pytestmark = needs_ocp  # Open CASCADE makes and reads the STEP files (a dev dependency)

RUN_TIMEOUT_MS = 90000


@pytest.fixture
def fillet_file(tmp_path):
    from tests import cadfiles as cf
    from tests.test_faces_join import fillet_shell
    return cf.write_step(fillet_shell(), tmp_path / "fillet.step")


def click(qtbot, view, x, y, shift=False):
    w = view.widget
    qtbot.mouseClick(w, Qt.MouseButton.LeftButton,
                     Qt.KeyboardModifier.ShiftModifier if shift else Qt.KeyboardModifier.NoModifier,
                     QPoint(int(round(x)), w.height() - 1 - int(round(y))))


def spot_of(picker, index):
    """A display point where the picker's view shows face ``index``."""
    from flatweave.app.facepicker import face_mesh
    pts, tris = face_mesh(picker.opened.cad.faces[index])
    centroids = pts[tris].mean(axis=1)
    for k in np.argsort(np.linalg.norm(centroids - centroids.mean(axis=0), axis=1))[:80]:
        x, y = picker.view.display_point(centroids[k])
        if picker.view.face_at(x, y) == index:
            return x, y
    pytest.fail(f"face {index} is nowhere in the picker's view")


@pytest.mark.slow
def test_shift_click_two_faces_join_them_run_save_and_reopen(make_window, qtbot, tmp_path, fillet_file):
    from flatweave.geometry.meshfit import FittedSurface
    from tests.test_faces_join import L1, R, W

    win = make_window()
    assert win.open_file(fillet_file)
    picker = win.files.face_picker
    qtbot.waitExposed(picker)
    qtbot.waitUntil(picker.view.is_ready, timeout=10000)
    picker.view.render_now()
    spots = {k: spot_of(picker, k) for k in (0, 1)}

    click(qtbot, picker.view, *spots[0])
    assert picker.faces == (0,) and picker.ok_button.text() == "OK"
    click(qtbot, picker.view, *spots[1], shift=True)
    assert picker.faces == (0, 1) and picker.ok_button.text() == "Join and open"
    assert {picker.list.row(i) for i in picker.list.selectedItems()} == {0, 1}
    click(qtbot, picker.view, *spots[1], shift=True)  # a second shift-click takes it out
    assert picker.faces == (0,)
    click(qtbot, picker.view, *spots[1], shift=True)
    assert picker.faces == (0, 1)

    picker.ok_button.click()
    qtbot.waitUntil(lambda: win.files.face_picker is None, timeout=5000)
    project = win.project
    assert isinstance(project.surface, FittedSurface) and project.surface.fit.faces == (0, 1)
    assert project.source == f"{fillet_file}#faces=0,1" and project.name == "fillet faces 0,1"
    assert project.units == "mm"
    fit = project.surface.fit
    assert fit.max_deviation < 1e-3 * fit.size
    # the joined piece: the plate and the fillet, its outline drawn
    from flatweave.geometry.region import cover_for
    cover = cover_for(project.surface, project.settings.region)
    assert cover.area == pytest.approx(W * (L1 + math.pi * R / 2), rel=1e-3)
    assert len(win.view.loops) == 1

    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        win.run()
    assert blocker.args[0].result is not None and not blocker.args[0].stopped
    assert win.frame.stats["area_error_pct"] < 1.0

    saved = tmp_path / "joined.flatweave"
    assert win.save_to(saved)
    fillet_file.unlink()
    win2 = make_window(example=None)
    assert win2.open_file(saved)
    p2 = win2.project
    assert p2.source == project.source and p2.surface.fit == fit
    assert np.array_equal(p2.surface.ctrlpts, project.surface.ctrlpts)
    assert p2.settings.region == project.settings.region
    assert len(win2.view.loops) == 1


def test_joining_faces_that_do_not_meet_shows_one_line(make_window, qtbot, fillet_file, monkeypatch):
    win = make_window()
    before = win.project
    errors = []
    monkeypatch.setattr(win, "show_error", errors.append)
    assert win.open_file(fillet_file)
    picker = win.files.face_picker
    picker.list.setCurrentRow(0)
    picker.select(2, add=True)
    assert picker.faces == (0, 2)
    picker.ok_button.click()
    qtbot.waitUntil(lambda: bool(errors), timeout=60000)
    assert "do not make one piece" in errors[0] and "\n" not in errors[0]
    assert win.project is before
