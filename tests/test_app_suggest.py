"""Tools > Suggest darts in the window: suggest, preview, accept one, undo."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from PySide6.QtCore import Qt

from flatweave.method.lattice import MATERIALS

from tests.test_app_run import run_to_end, small_project


@pytest.mark.slow
def test_suggest_preview_accept_and_undo(qtbot, make_window):
    # a 5 degree warning angle: the octant's 9.5 degree shear warns, so darts are wanted
    # (with the preset's 15 degrees every metric is within its limits and none is suggested)
    win = make_window(small_project(0.1, material=replace(MATERIALS["woven"], warn_deg=5.0)))
    run_to_end(qtbot, win)
    before = win.document.project
    assert before.result_is_current and not before.settings.darts
    assert win.actions["suggest_darts"].isEnabled()
    shown_before = np.array(win.presenter.frame.pattern.xy, copy=True)

    win.actions["suggest_darts"].trigger()
    box = win.suggest_box
    qtbot.waitUntil(lambda: not box.busy and box.list.count() > 0, timeout=120000)
    first = box.proposals[0]
    assert first.dart.auto and box.list.count() == len(box.proposals) >= 1
    assert "energy -" in box.list.item(0).text()

    # the preview: the dart on the surface, its re-solved piece in both views
    assert len(win.view.layer_lines("suggested dart")) == len(first.dart.uv)
    assert np.allclose(win.view.layer_lines("suggested dart"), before.surface.points(first.dart.uv))
    assert win.presenter.frame.mesh.n_nodes == first.result.mesh.n_nodes
    assert not np.array_equal(win.presenter.frame.pattern.xy, shown_before) or \
        len(win.presenter.frame.pattern.darts) == 1
    assert len(win.presenter.frame.pattern.darts) == 1
    assert win.document.project is before  # previews are not edits

    for k in range(1, box.list.count()):  # accept the first only
        box.list.item(k).setCheckState(Qt.CheckState.Unchecked)
    runs_before = win.runner.state
    box.apply()
    after = win.document.project
    assert [d.name for d in after.settings.darts] == [first.dart.name]
    assert after.settings.darts[0].auto
    assert after.result_is_current  # the proposal's own re-solve, no new solve
    assert after.result.metrics["energy"] == first.metrics["energy"]
    qtbot.wait(400)  # longer than the re-run delay: no solve starts
    assert win.runner.state == runs_before == "idle"
    assert win.view.layer_lines("suggested dart").size == 0

    assert win.document.undo()
    assert win.document.project is before
    assert not win.document.project.settings.darts
    assert win.document.redo()
    assert win.document.project.settings.darts[0].auto


def test_a_previewed_result_is_judged_on_its_own(qtbot, make_window):
    """The metrics panel's status and warnings under a preview (a suggested dart's re-solved piece) are
    the previewed result's, not the document's: its numbers and its verdict agree."""
    from flatweave.app.frames import FrameMaker
    from flatweave.method.pipeline import flatten
    from flatweave.method.settings import FlattenSettings
    from flatweave.reading.examples import load_example

    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.settings_panel.shear_warning.setValue(5.0)  # the octant's 9.5 degrees of shear now warn
    labels = win.metrics.labels
    assert "with warnings" in labels["status"].text() and "shear" in labels["warnings"].text()
    # a developable piece previewed: within every limit
    other = flatten(load_example("half_cylinder"), FlattenSettings(spacing=0.2))
    win.presenter.draw_frame(FrameMaker(other.surface, other.settings).from_result(other))
    assert labels["status"].text() == "converged" and labels["warnings"].text() == "none"
    win.presenter.show_result(win.document.project)  # back to the document's
    assert "with warnings" in labels["status"].text()


def test_suggest_needs_a_current_result(qtbot, make_window):
    win = make_window(small_project(0.1))
    assert not win.actions["suggest_darts"].isEnabled()
    box = win.suggest_dialog()
    assert "Solve first" in box.status.text() and box.list.count() == 0
    box.close()


@pytest.mark.slow
def test_best_orientation_table_plot_and_apply(qtbot, make_window):
    from flatweave.app.sweepdialog import COLUMNS
    from flatweave.method.settings import FlattenSettings

    win = make_window(small_project(0.15))
    win.settings_panel.auto_rerun.setChecked(False)
    box = win.sweep_dialog()
    box.angles.setValue(4)
    box.go.click()
    qtbot.waitUntil(lambda: not box.busy and box.table.rowCount() == 4, timeout=120000)
    rows = box.result.rows
    assert [box.table.item(i, 0).text() for i in range(4)] == [f"{r['angle_deg']:.2f}" for r in rows]
    assert box.table.horizontalHeaderItem(3).text() == COLUMNS[3][1]
    # the plot: one point per angle, higher shear drawn higher up (smaller y)
    pts = box.plot.points()
    assert len(pts) == 4
    by_angle = sorted((r for r in rows), key=lambda r: r["angle_deg"])
    s = [r["max_shear_deg"] for r in by_angle]
    hi, lo = int(np.argmax(s)), int(np.argmin(s))
    assert pts[hi][1] < pts[lo][1]
    grab = box.plot.grab()
    assert grab.width() > 0
    # choose the second row and apply: one settings edit, undoable
    box.table.selectRow(1)
    before = win.document.project
    box.apply()
    after = win.document.project
    assert after.settings.angle_deg == rows[1]["angle_deg"]
    assert after.settings == FlattenSettings(**{**before.settings.__dict__, "angle_deg": rows[1]["angle_deg"],
                                                 "seed": tuple(rows[1]["seed"])})
    assert win.document.undo() and win.document.project is before


def test_a_background_call_reports_one_line_and_never_raises(qtbot):
    from flatweave.app.background import BackgroundCall
    from flatweave.errors import SettingsError

    got = []
    call = BackgroundCall(lambda value, error: got.append((value, error)))

    def boom():
        raise ZeroDivisionError("division by zero\nsecond line")

    def refused():
        raise SettingsError("the spacing must be positive")

    for fn in (lambda: 42, boom, refused):
        call.start(fn, "test-call")
        qtbot.waitUntil(lambda: not call.busy, timeout=5000)
        qtbot.wait(20)  # the queued signal
    assert got == [(42, None), (None, "internal error: ZeroDivisionError: division by zero"),
                   (None, "the spacing must be positive")]
