"""GUI tests of the window telling the truth: Open, Examples and
Recover ask before discarding unsaved work; the line under Run, the status
bar, the energy plot and the title show the document as it is now; Ctrl+Z
after a committed settings field undoes the document's edit."""

from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QApplication, QFileDialog, QMessageBox

from flatweave.method.darts import PlaneDart
from flatweave.errors import FlatweaveError
from flatweave.reading.examples import example_path
from flatweave.document.project import load_project

from flatweave.app.actions import show_view_choices, view_choices
from flatweave.app.presenter import history_rows
from flatweave.app.runcontrol import NOT_SOLVED, result_text

from tests.test_app_recovery import click, write_orphan
from tests.test_app_run import run_to_end, small_project

Button = QMessageBox.StandardButton
DART = PlaneDart((1.0, 0.0, 0.0, -0.2), name="side")


class Questions:
    """Answers the window's modal questions with ``answers`` in turn and keeps their texts;
    a question with no answer left is cancelled (and recorded) so a test never hangs."""

    def __init__(self, *answers):
        self.answers = list(answers)
        self.texts: list[str] = []
        self.timer = QTimer(interval=30)
        self.timer.timeout.connect(self._poll)
        self.timer.start()

    def _poll(self) -> None:
        box = QApplication.activeModalWidget()
        if not isinstance(box, QMessageBox) or not box.isVisible():
            return
        self.texts.append(box.text())
        button = self.answers.pop(0) if self.answers else Button.Cancel
        box.button(button).click()

    def stop(self) -> None:
        self.timer.stop()


@pytest.fixture
def questions():
    made = []

    def make(*answers):  # one answerer at a time
        for old in made:
            old.stop()
        q = Questions(*answers)
        made.append(q)
        return q

    yield make
    for q in made:
        q.stop()


def dirty_window(make_window, example="saddle", path=None):
    """A window on ``example`` (saved to ``path`` if given) with a dart added, asking before it loses work."""
    win = make_window(example=example)
    if path is not None:
        assert win.save_to(path)
    win.document.add_dart(DART)
    assert win.document.unsaved_work and win.windowTitle().endswith(" *")
    win.confirm_close = True
    return win


# ---------------------------------------------------------------------- item 3: asking before discarding
def test_an_example_asks_before_discarding_unsaved_work(make_window, questions):
    win = dirty_window(make_window)
    before = win.project
    q = questions(Button.Cancel)
    assert not win.open_example("cone")
    assert q.texts == ["Save the changes to saddle before opening the example cone?"]
    assert win.project is before and win.document.can_undo and win.document.undo_label == "Add side"
    # the Examples menu asks the same way; Discard opens the example
    q = questions(Button.Discard)
    action = next(a for a in win.examples_menu.actions() if a.data() == "cone")
    action.trigger()
    assert len(q.texts) == 1 and "before opening the example cone" in q.texts[0]
    assert win.project.name == "cone" and not win.document.can_undo
    assert win.windowTitle() == "flatweave - cone"  # untouched: no "*"


def test_open_names_the_project_file_and_saves_first(make_window, questions, tmp_path):
    path = tmp_path / "saddle.flatweave"
    win = dirty_window(make_window, path=path)
    cone = example_path("cone")
    q = questions(Button.Save)
    assert win.open_file(cone)
    assert q.texts == [f"Save the changes to saddle.flatweave before opening {Path(cone).name}?"]
    assert [d.name for d in load_project(path).settings.darts] == ["side"]  # saved, then opened
    assert win.project.name == "cone" and not win.document.unsaved_work


def test_a_failed_or_cancelled_save_opens_nothing(make_window, questions, tmp_path, monkeypatch):
    path = tmp_path / "saddle.flatweave"
    win = dirty_window(make_window, path=path)
    before = win.project

    def full_disk(*_args, **_kwargs):
        raise FlatweaveError("no space left on the device")

    monkeypatch.setattr("flatweave.app.files.save_with_backups", full_disk)
    q = questions(Button.Save)
    assert not win.open_file(example_path("cone"))
    assert len(q.texts) == 1 and win.project is before and win.document.unsaved_work
    assert win.last_error == "Cannot save: no space left on the device"
    monkeypatch.undo()
    # never saved: Save asks where (Save As); cancelling that opens nothing either
    win2 = dirty_window(make_window, example="octant")
    before2 = win2.project
    monkeypatch.setattr(QFileDialog, "getSaveFileName", staticmethod(lambda *a, **k: ("", "")))
    q = questions(Button.Save)
    assert not win2.open_example("cone")
    assert q.texts == ["Save the changes to octant before opening the example cone?"]
    assert win2.project is before2 and win2.document.unsaved_work
    win.confirm_close = win2.confirm_close = False  # the test's end closes them


def test_file_open_asks_after_the_file_is_chosen(make_window, questions, monkeypatch):
    win = dirty_window(make_window)
    before = win.project
    cone = str(example_path("cone"))
    monkeypatch.setattr(QFileDialog, "getOpenFileName", staticmethod(lambda *a, **k: (cone, "")))
    q = questions(Button.Cancel)
    win.actions["open"].trigger()
    assert len(q.texts) == 1 and win.project is before
    q = questions(Button.Discard)
    win.actions["open"].trigger()
    assert len(q.texts) == 1 and win.project.name == "cone"


def test_nothing_to_lose_opens_without_asking(make_window, questions, tmp_path):
    win = make_window(example="saddle")
    win.confirm_close = True
    q = questions()  # any question would be recorded (and cancelled)
    assert win.open_example("cone") and win.open_file(example_path("octant"))
    assert q.texts == [] and win.project.name == "octant"


def test_recovering_into_unsaved_work_asks_first(make_window, questions, qtbot, tmp_path):
    folder = tmp_path / "crash"
    orphan = write_orphan(folder, small_project(0.12), "lost piece")
    win = dirty_window(make_window)
    before = win.project
    q = questions(Button.Cancel)
    win.check_recovery(folder)
    click(win.recovery_box, "Recover")
    assert len(q.texts) == 1 and "before recovering the autosaved lost piece" in q.texts[0]
    assert win.project is before and orphan.exists()  # kept: offered again later
    win.check_recovery(folder)
    q = questions(Button.Discard)
    click(win.recovery_box, "Recover")
    assert len(q.texts) == 1 and win.project.name == "lost piece" and not orphan.exists()
    win.confirm_close = False  # the recovered work is unsaved: the test's end closes it


# ---------------------------------------------------------------------- item 4: status text
@pytest.mark.slow
def test_status_text_follows_undo_redo_and_open(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))
    assert win.progress.text() == NOT_SOLVED
    run_to_end(qtbot, win)
    m = win.project.result.metrics
    solved = result_text(m)
    assert solved.startswith(f"Converged: {m['iterations']} iterations") and win.progress.text() == solved
    info = win.presenter.info_label
    assert info.text().startswith(f"{m['iterations']} iterations")
    win.actions["undo"].trigger()
    assert win.project.result is None
    assert win.progress.text() == NOT_SOLVED
    assert win.statusBar().currentMessage() == f"Undo Solve: {NOT_SOLVED}"
    assert "iterations" not in info.text() and "control points" in info.text()
    win.actions["redo"].trigger()
    assert win.progress.text() == solved and info.text().startswith(f"{m['iterations']} iterations")
    assert win.statusBar().currentMessage() == f"Redo Solve: {solved}"
    # a settings edit: the numbers are the last solve's, and said to be
    win.settings_panel.auto_rerun.setChecked(False)
    win.edit_settings("Tolerance", {"tol": 1e-8})
    assert win.progress.text().startswith("The settings changed since the last solve (Converged:")
    assert info.text().endswith("(settings changed since)")
    win.undo()
    path = tmp_path / "solved.flatweave"
    assert win.save_to(path)
    # another document: none of this one's numbers
    assert win.open_example("cone")
    assert win.progress.text() == NOT_SOLVED and "iterations" not in info.text()
    # a reopened solved project shows its stored result's status
    other = make_window(example=None)
    assert other.progress.text() == "Open a surface or pick an example, then Run."
    assert other.open_file(path)
    assert other.progress.text() == solved
    assert other.presenter.info_label.text().startswith(f"{m['iterations']} iterations")
    assert other.windowTitle() == "flatweave - solved.flatweave"


def test_history_rows_end_at_the_solvers_iteration_count():
    assert history_rows([]) == []
    assert history_rows([3.0, 2.0], 2) == [(1, 3.0, False), (2, 2.0, False)]
    rows = history_rows([5.0, 4.0, 3.0, 2.0, 1.0], 3)  # two refill rounds: five entries, three iterations
    assert [r[0] for r in rows] == [1.0, 1.5, 2.0, 2.5, 3.0] and [r[1] for r in rows] == [5, 4, 3, 2, 1]
    assert history_rows([2.0], 4) == [(4.0, 2.0, False)]
    assert [r[0] for r in history_rows([2.0, 1.0], None)] == [1, 2]  # no count known: one entry an iteration


@pytest.mark.slow
def test_the_energy_plot_counts_the_metrics_iterations(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))  # refills here: the trace has more entries than iterations
    run_to_end(qtbot, win)
    r = win.project.result
    n = r.metrics["iterations"]
    assert len(r.history) > n, "expected a solve with refill rounds"
    plot = win.energy_plot
    assert int(plot.iterations.max()) == n
    win.undo()
    win.redo()  # drawn from the stored result now
    assert len(plot.iterations) == len(r.history) and int(plot.iterations.max()) == n
    path = tmp_path / "solved.flatweave"
    assert win.save_to(path)
    other = make_window(example=None)
    assert other.open_file(path)
    assert int(other.energy_plot.iterations.max()) == other.project.result.metrics["iterations"] == n
    assert other.metrics.text("iterations") == str(n)


def test_the_title_has_a_star_only_after_an_edit(make_window, tmp_path):
    win = make_window(example="octant")
    assert win.windowTitle() == "flatweave - octant"
    assert win.open_file(example_path("saddle"))
    assert win.windowTitle() == "flatweave - saddle"
    win.edit_display("Units", {"units": "cm"})
    assert win.windowTitle() == "flatweave - saddle *"
    win.undo()  # back to what was opened, but the edit happened: the window may still have work...
    assert win.windowTitle().startswith("flatweave - saddle")
    path = tmp_path / "piece.flatweave"
    assert win.save_to(path) and win.windowTitle() == "flatweave - piece.flatweave"
    assert win.open_file(path) and win.windowTitle() == "flatweave - piece.flatweave"


# ---------------------------------------------------------------------- item 5: Ctrl+Z after a committed field
def type_and_commit(qtbot, edit, text):
    edit.setFocus()
    qtbot.waitUntil(edit.hasFocus)
    edit.selectAll()
    qtbot.keyClicks(edit, text)
    qtbot.keyClick(edit, Qt.Key.Key_Return)


def focus_window(qtbot, win):
    win.activateWindow()
    win.raise_()
    qtbot.waitUntil(lambda: QApplication.activeWindow() is win, timeout=5000)


def test_ctrl_z_after_a_committed_field_undoes_the_document(make_window, qtbot):
    win = make_window(small_project(0.1))
    focus_window(qtbot, win)
    win.settings_panel.auto_rerun.setChecked(False)
    spacing = win.settings_panel.spacing
    type_and_commit(qtbot, spacing, "0.12")
    assert win.project.settings.spacing == 0.12 and win.document.undo_label == "Weft spacing"
    assert spacing.hasFocus()
    qtbot.keyClick(spacing, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert win.project.settings.spacing == 0.1 and not win.document.can_undo
    assert spacing.text() == "0.1"
    qtbot.keyClick(spacing, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert win.project.settings.spacing == 0.12 and spacing.text() == "0.12"
    qtbot.keyClick(spacing, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    qtbot.keyClick(spacing, Qt.Key.Key_Y, Qt.KeyboardModifier.ControlModifier)
    assert win.project.settings.spacing == 0.12
    # while typing, Ctrl+Z is the field's own: the typing goes, the document stays
    spacing.selectAll()
    qtbot.keyClicks(spacing, "0.3")
    qtbot.keyClick(spacing, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert win.project.settings.spacing == 0.12 and spacing.text() != "0.3"


def test_ctrl_z_after_a_committed_spin_box_undoes_the_document(make_window, qtbot):
    win = make_window(small_project(0.1))
    focus_window(qtbot, win)
    win.settings_panel.auto_rerun.setChecked(False)
    angle = win.settings_panel.angle
    type_and_commit(qtbot, angle.lineEdit(), "30")
    assert win.project.settings.angle_deg == 30.0 and win.document.undo_label == "Weft angle"
    qtbot.keyClick(QApplication.focusWidget(), Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert win.project.settings.angle_deg == 0.0 and not win.document.can_undo
    assert angle.value() == 0.0 and angle.text().startswith("0.0")


# ---------------------------------------------------------------------- item 9: the view comes back with the project
@pytest.mark.slow
def test_the_view_mode_comes_back_with_the_project(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    undo_label, revision = win.document.undo_label, win.document.revision
    win.actions["mode_shear"].trigger()
    win.actions["show_diag"].trigger()  # off
    assert win.document.revision == revision  # view choices are no edit
    path = tmp_path / "shear.flatweave"
    assert win.save_to(path) and win.document.undo_label == undo_label
    other = make_window(example=None)
    assert not other.actions["mode_shear"].isChecked()
    assert other.open_file(path)
    assert other.actions["mode_shear"].isChecked() and not other.actions["mode_strain"].isChecked()
    assert not other.actions["show_diag"].isChecked() and other.actions["show_weft"].isChecked()
    assert other.view_options.mode == "shear" and not other.view_options.diag
    assert other.view.colour_bar_title == "shear (deg)"
    assert other.windowTitle() == "flatweave - shear.flatweave"  # restoring the view is no edit
    # a project saved without view choices leaves the window's as they are
    assert other.open_file(example_path("saddle")) and other.view_options.mode == "shear"


@pytest.mark.slow
def test_view_choices_read_from_and_shown_on_the_actions(make_window, qtbot):
    """The window's half of keeping the view with the project (whatever core stores)."""
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    assert view_choices(win.actions) == {"mode": "strain", "weft": True, "warp": True, "diag": True,
                                         "surface": True, "nodes": True}
    win.actions["mode_shear"].trigger()
    win.actions["show_nodes"].trigger()  # off
    choices = view_choices(win.actions)
    assert choices["mode"] == "shear" and choices["nodes"] is False
    other = make_window(small_project(0.1))
    run_to_end(qtbot, other)
    show_view_choices(other.actions, {**choices, "unknown": 3, "weft": "not a bool"})
    assert other.actions["mode_shear"].isChecked() and not other.actions["mode_strain"].isChecked()
    assert other.view_options.mode == "shear" and not other.view_options.nodes and other.view_options.weft
    assert other.view.colour_bar_title == "shear (deg)"
    assert view_choices(other.actions) == choices
    assert other.document.undo_label == "Solve" and len(other.document.history) == 1  # no edit of the document
