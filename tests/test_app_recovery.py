"""GUI tests of never losing work: autosave after a solve and on the timer,
recovery after the app is killed (SIGKILL), backups on save, and the
question on closing with unsaved work. Core side: tests/test_recovery.py."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest
from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QApplication, QMessageBox

from flatweave.document.project import load_project, project_problems, project_to_dict
from flatweave.document.recovery import backup_paths, find_orphans

from tests.test_app_run import run_to_end, small_project

REPO = Path(__file__).resolve().parents[1]


def recovery_files(folder: Path) -> list[Path]:
    return sorted(folder.glob("session-*.flatweave"))


def click(box: QMessageBox, text: str) -> None:
    [button] = [b for b in box.buttons() if b.text().replace("&", "") == text]
    button.click()


def test_a_solve_is_autosaved_and_a_save_clears_it(make_window, qtbot, recovery_dir, tmp_path):
    win = make_window(small_project(0.12))
    assert win.session is not None and not recovery_files(recovery_dir)  # nothing done: nothing to save
    run_to_end(qtbot, win)
    win.last_autosave.result(timeout=30)
    [path] = recovery_files(recovery_dir)
    saved = load_project(path)
    assert project_to_dict(saved) == project_to_dict(win.files.as_saved(win.project))  # the solved document, all of it
    assert saved.result is not None and project_problems(saved) == []
    assert json.loads(path.read_text())["recovery"]["document_path"] is None
    # saving it: nothing left to recover; the save itself is a project
    assert win.save_to(tmp_path / "piece.flatweave")
    win.last_autosave.result(timeout=30)
    assert not recovery_files(recovery_dir)


@pytest.mark.slow
def test_the_timer_autosaves_only_what_changed(make_window, qtbot, recovery_dir, tmp_path):
    win = make_window(small_project(0.12))
    assert win.save_to(tmp_path / "piece.flatweave")
    win.files.autosave_timer.setInterval(50)
    qtbot.wait(200)
    assert not recovery_files(recovery_dir)  # saved: nothing to recover
    win.edit_display("Units", {"units": "cm"})
    qtbot.waitUntil(lambda: bool(recovery_files(recovery_dir)), timeout=5000)
    win.last_autosave.result(timeout=30)
    [path] = recovery_files(recovery_dir)
    assert load_project(path).units == "cm"
    assert json.loads(path.read_text())["recovery"]["document_path"] == str(tmp_path / "piece.flatweave")
    writes = win.session.writes
    qtbot.wait(300)
    assert win.session.writes == writes  # unchanged since: no rewrite every tick


def test_saving_keeps_backups_of_earlier_saves(make_window, tmp_path):
    win = make_window(small_project(0.12))
    path = tmp_path / "piece.flatweave"
    for units in ("mm", "cm", "in"):
        win.edit_display("Units", {"units": units})
        assert win.save_to(path)
    assert load_project(path).units == "in"
    assert [load_project(b).units for b in backup_paths(path)[:2]] == ["cm", "mm"]


def start_killable_app(recovery: Path, *args) -> subprocess.Popen:
    env = {**os.environ, "FLATWEAVE_RECOVERY_DIR": str(recovery)}
    return subprocess.Popen([sys.executable, "-m", "flatweave.app.main", *map(str, args)], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def wait_for_solved_autosave(folder: Path, proc: subprocess.Popen, timeout: float = 180.0) -> Path:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        assert proc.poll() is None, f"the app ended early: {proc.stderr.read()}"
        for path in recovery_files(folder):
            try:
                if (json.loads(path.read_text()).get("pieces") or [{}])[0].get("result") is not None:
                    return path
            except (OSError, ValueError):
                pass  # a rename in flight
        time.sleep(0.2)
    raise AssertionError("no autosave of the solved document appeared")


@pytest.mark.slow
def test_work_survives_the_app_being_killed(make_window, qtbot, recovery_dir, tmp_path):
    """Run a solve in a real flatweave process, SIGKILL it once the solve is
    autosaved, then start again: the work is offered back and recovered."""
    folder = tmp_path / "crash"
    with start_killable_app(folder, "resources/surfaces/octant.json", "--spacing", "0.12", "--run") as proc:
        autosaved = wait_for_solved_autosave(folder, proc)
        saved_doc = json.loads(autosaved.read_text())
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    assert autosaved.exists() and saved_doc["pieces"][0]["result"]["metrics"]["solver_status"] == "converged"

    win = make_window(example="octant")
    offered = win.check_recovery(folder)
    assert offered is not None and offered.path == autosaved
    box = win.recovery_box
    assert box is not None and box.isVisible() and "octant" in box.text()
    assert win.check_recovery(folder) is None  # one question at a time
    click(box, "Recover")
    doc = win.document
    r = doc.project.result
    assert r is not None and r.mesh.n_nodes == saved_doc["pieces"][0]["result"]["metrics"]["nodes"]
    assert r.metrics["energy"] == saved_doc["pieces"][0]["result"]["metrics"]["energy"]
    assert project_problems(doc.project) == []
    assert doc.unsaved_work and win.windowTitle().endswith("*")  # recovered work is not saved yet
    assert len(win.energy_plot.iterations) == len(saved_doc["pieces"][0]["result"]["history"]) > 0
    assert not autosaved.exists()  # the crashed session's file is gone...
    [own] = recovery_files(recovery_dir)  # ...because this session's autosave holds the work now
    assert project_to_dict(load_project(own)) == project_to_dict(win.files.as_saved(doc.project))
    assert win.pattern_view.outline is not None  # and it is on screen


def write_orphan(folder: Path, project, name: str) -> Path:
    """A recovery file whose session is gone (no lock held)."""
    from flatweave.document.recovery import Session

    s = Session(folder)
    s.write(replace(project, name=name))
    path = s.path
    os.close(s._fd)  # the process "dies": the lock goes, the files stay
    s._fd = None
    return path


def test_discard_and_later(make_window, qtbot, tmp_path):
    folder = tmp_path / "crash"
    p = small_project(0.12)
    later = write_orphan(folder, p, "later piece")
    win = make_window(p)
    win.check_recovery(folder)
    assert "later piece" in win.recovery_box.text()
    click(win.recovery_box, "Later")
    assert later.exists() and win.recovery_box is None and win.document.project.name == "octant"
    win.check_recovery(folder)  # offered again at the next check
    click(win.recovery_box, "Discard")
    assert not later.exists() and find_orphans(folder) == []
    assert win.document.project.name == "octant"  # the open document untouched


@pytest.mark.slow
def test_closing_with_unsaved_work_asks_first(make_window, qtbot, recovery_dir, tmp_path):
    win = make_window(small_project(0.12))
    win.confirm_close = True
    win.edit_display("Units", {"units": "cm"})
    answers = []

    def answer(button):
        def go():
            box = QApplication.activeModalWidget()
            assert isinstance(box, QMessageBox) and "Save the changes" in box.text()
            answers.append(button)
            box.button(button).click()
        return go

    QTimer.singleShot(200, answer(QMessageBox.StandardButton.Cancel))
    win.close()
    assert answers == [QMessageBox.StandardButton.Cancel] and win.isVisible() and win.session is not None
    QTimer.singleShot(200, answer(QMessageBox.StandardButton.Discard))
    win.close()
    assert not win.isVisible() and win.session is None
    assert not recovery_files(recovery_dir)  # a chosen discard leaves nothing behind


def test_a_clean_window_closes_without_asking(make_window):
    win = make_window(small_project(0.12))
    win.confirm_close = True
    assert not win.document.unsaved_work
    win.close()  # would block on a question if it asked
    assert not win.isVisible()


def test_an_unusable_recovery_folder_turns_autosave_off_with_a_message(make_window, monkeypatch, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("FLATWEAVE_RECOVERY_DIR", str(blocker / "recovery"))
    win = make_window(small_project(0.12))
    assert win.session is None and win.recovery_problem.startswith("Autosave is off")
    assert "\n" not in win.recovery_problem
    assert win.autosave() is None and win.check_recovery() is None
