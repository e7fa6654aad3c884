"""GUI tests of faults: an exception or a NaN in the worker, a cancelled run,
a second Run while one is in flight, a full disk under File > Export and
File > Save. After each the document must be as it was (or hold a complete,
consistent result) and the app must go on working.

Solves are small (the octant at spacing 0.1, about 440 nodes); nothing here
depends on how fast the machine is.
"""

from __future__ import annotations

import threading

import pytest

import flatweave.app.runner
import flatweave.method.pipeline
from flatweave.app.frames import FrameMaker
from flatweave.app.worker import SolveThread
from flatweave.export.registry import FORMATS, ExportOptions
from flatweave.document.project import load_project, project_problems, project_to_dict
from tests.helpers import NO_SPACE, FullDisk, SurfaceFault
from tests.test_app_run import RUN_TIMEOUT_MS, run_to_end, shown_rgb, small_project


def snapshot(win):
    """What must survive a failed run: the project, its content, the undo history."""
    doc = win.document
    return doc.project, project_to_dict(doc.project), doc.history, doc.can_redo, doc.dirty


def assert_unchanged(win, before):
    project, content, history, can_redo, dirty = before
    doc = win.document
    assert doc.project is project and project_to_dict(doc.project) == content
    assert len(doc.history) == len(history) and all(a is b for a, b in zip(doc.history, history))
    assert (doc.can_redo, doc.dirty) == (can_redo, dirty)
    assert project_problems(doc.project) == []


def assert_shows_the_document(win):
    """The views are back to the document's own result (not a live frame of a run)."""
    r = win.project.result
    idx, _ = shown_rgb(win.view)
    assert win.frame is not None and win.frame.final
    assert len(idx) == r.mesh.n_springs and len(win.pattern_view.layer.springs[0].points) == r.mesh.n_nodes


def assert_usable(win, qtbot):
    """Idle, Run enabled, and a new run converges and is attached."""
    assert win.runner.state == "idle" and win.runner.thread is None and win.actions["run"].isEnabled()
    outcome = run_to_end(qtbot, win)
    assert not outcome.stopped and win.project.result is outcome.result and win.project.result_is_current
    assert outcome.result.metrics["solver_status"] == "converged" and project_problems(win.project) == []


def solved_window(make_window, qtbot):
    """A window whose document has history: a solve, then an edit that leaves the result stale."""
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.document.edit_settings("Tolerance", tol=1e-8)
    assert win.document.undo_label == "Tolerance" and not win.project.result_is_current
    return win


# ---------------------------------------------------------------------- the worker
@pytest.mark.slow
def test_an_exception_in_the_worker_mid_run_changes_nothing(make_window, qtbot, monkeypatch, capsys):
    win = solved_window(make_window, qtbot)
    before = snapshot(win)
    calls = []

    def breaking(self, snap, pattern=None):  # the worker's live frames (made when the GUI takes one)
        calls.append(snap.iteration)
        raise ValueError("frames broke\nsecond line")

    monkeypatch.setattr(FrameMaker, "from_snapshot", breaking)
    # the run's first live frame breaks, mid-run (the result's frame is made otherwise): a short re-run
    # may make no second live frame at all (none is made while the last waits for the GUI)
    with qtbot.waitSignal(win.run_failed, timeout=RUN_TIMEOUT_MS) as blocker:
        win.run()
    assert blocker.args[0] == "ValueError: frames broke" and len(calls) == 1 and calls[0] >= 1
    qtbot.waitUntil(lambda: win.error_box is not None and win.error_box.isVisible())
    assert win.error_box.text() == "Solve failed: ValueError: frames broke" == win.last_error
    assert "Traceback" in capsys.readouterr().err  # a bug, not a user error: its traceback is kept
    assert_unchanged(win, before)
    assert_shows_the_document(win)
    assert win.progress.text() == "Solve failed: ValueError: frames broke"
    monkeypatch.undo()
    assert_usable(win, qtbot)


@pytest.mark.slow
def test_a_nan_mid_run_is_a_one_line_error_and_changes_nothing(make_window, qtbot, monkeypatch, capsys):
    win = solved_window(make_window, qtbot)
    before = snapshot(win)
    fault = SurfaceFault(monkeypatch)  # the surface gives NaN at one node from iteration 4 of the worker's solve
    monkeypatch.setattr(flatweave.method.pipeline, "iterate", fault.arm_after(3, flatweave.method.pipeline.iterate))
    with qtbot.waitSignal(win.run_failed, timeout=RUN_TIMEOUT_MS) as blocker:
        win.run()
    message = blocker.args[0]
    assert message == ("the energy became NaN at iteration 4 (the surface evaluation returned a non-finite point "
                       "at 1 node); the solve stopped and nothing was changed")
    assert fault.hits >= 1 and not fault.armed
    qtbot.waitUntil(lambda: win.error_box is not None and win.error_box.isVisible())
    assert win.error_box.text() == f"Solve failed: {message}" and "\n" not in win.error_box.text()
    assert "Traceback" not in capsys.readouterr().err  # a user-facing error, not a bug
    assert_unchanged(win, before)
    assert_shows_the_document(win)
    monkeypatch.undo()
    assert_usable(win, qtbot)


@pytest.mark.slow
def test_cancel_mid_run_keeps_the_document_and_redraws_it(make_window, qtbot):
    win = solved_window(make_window, qtbot)
    # the paper's CG at a new spacing: a new drape and thousands of iterations
    win.document.edit_settings("Solver", spacing=0.08, solver="paper", max_iter=100000)
    before = snapshot(win)
    ended = []
    win.run_finished.connect(ended.append)
    win.run_failed.connect(ended.append)
    win.run()
    qtbot.waitUntil(lambda: len(win.runner.history) >= 3 and win.frame is not None and not win.frame.final,
                    timeout=RUN_TIMEOUT_MS)
    win.runner.cancel()
    assert not win.runner.active and win.runner.state == "stopping" and not win.actions["run"].isEnabled()
    qtbot.waitUntil(lambda: win.runner.state == "idle", timeout=10000)
    qtbot.wait(100)
    assert ended == []  # an abandoned run reports nothing and attaches nothing
    assert_unchanged(win, before)
    # the views no longer show the abandoned run's last live frame, nor its progress
    assert_shows_the_document(win)
    assert "iteration" not in win.progress.text() and "cancelled" in win.progress.text()
    win.document.edit_settings("Solver", solver="fast")
    assert_usable(win, qtbot)


@pytest.mark.slow
def test_a_run_is_never_started_twice_at_once(make_window, qtbot, monkeypatch):
    alive, peak, made = [0], [0], []
    lock = threading.Lock()

    class Counted(SolveThread):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            made.append(self)

        def run(self):
            with lock:
                alive[0] += 1
                peak[0] = max(peak[0], alive[0])
            try:
                super().run()
            finally:
                with lock:
                    alive[0] -= 1

    monkeypatch.setattr(flatweave.app.runner, "SolveThread", Counted)
    win = make_window(small_project(0.1))
    finished = []
    win.run_finished.connect(finished.append)
    win.run()
    first = win.runner.thread
    assert win.runner.runs_started == 1 and made == [first]
    # Run is disabled while a run is in flight: its shortcut and menu entry do nothing
    assert not win.actions["run"].isEnabled()
    win.actions["run"].trigger()
    assert win.runner.runs_started == 1 and win.runner.thread is first and not first.abandoned
    # calling run() (or the runner) again at once queues the newest and abandons the one in flight
    last = win.project.with_settings(tol=1e-8)
    win.run()
    win.run()
    win.runner.start(last)
    assert win.runner.thread is first and first.abandoned and win.runner.runs_started == 1 and len(made) == 1
    qtbot.waitUntil(lambda: len(finished) == 1 and win.runner.state == "idle", timeout=RUN_TIMEOUT_MS)
    qtbot.wait(100)
    assert len(finished) == 1 and len(made) == 2 and win.runner.runs_started == 2
    assert peak[0] == 1 and alive[0] == 0
    assert finished[0].source is last  # only the newest request ran to the end
    # its settings differ from the document's (it was started behind the document's back): set aside
    assert win.project.result is None
    assert_usable(win, qtbot)


# ---------------------------------------------------------------------- files
@pytest.mark.slow
def test_export_on_a_full_disk_leaves_no_partial_file(make_window, qtbot, tmp_path, monkeypatch):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    old = tmp_path / "piece.dxf"
    old.write_bytes(b"previous export")
    paths = [tmp_path / f"piece{s}" for s in FORMATS]
    before = snapshot(win)
    win.last_autosave.result(timeout=30)  # the solve's autosave: done before the disk fills up
    FullDisk(monkeypatch, "write", fail_on=2)  # room for the DXF, not for the SVG
    with qtbot.waitSignal(win.export_failed, timeout=60000) as blocker:
        assert win.export_to(paths, ExportOptions())
    message = blocker.args[0]
    assert message == f"cannot write {tmp_path / 'piece.svg'}: {NO_SPACE}"
    qtbot.waitUntil(lambda: win.error_box is not None and win.error_box.isVisible())
    assert win.error_box.text() == f"Export failed: {message}"
    qtbot.waitUntil(lambda: win.export_thread is None, timeout=5000)
    monkeypatch.undo()
    assert old.read_bytes() == b"previous export"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["piece.dxf"]  # nothing partial, no temporary files
    assert_unchanged(win, before)
    # the app goes on: the same export with room on the disk writes every file
    assert win.actions["export"].isEnabled()
    with qtbot.waitSignal(win.export_finished, timeout=60000) as blocker:
        assert win.export_to(paths, ExportOptions())
    assert blocker.args[0] == paths and all(p.stat().st_size > 100 for p in paths)


def test_save_on_a_full_disk_keeps_the_document_dirty(make_window, qtbot, tmp_path, monkeypatch):
    win = make_window(small_project(0.1))
    path = tmp_path / "job.flatweave"
    assert win.save_to(path) and not win.document.dirty
    saved = path.read_bytes()
    win.document.edit_settings("Tolerance", tol=1e-8)
    assert win.document.dirty and win.windowTitle().endswith(" *")
    FullDisk(monkeypatch, "fsync")
    assert not win.save_to(path)
    monkeypatch.undo()
    assert win.last_error == f"Cannot save: cannot write {path}: {NO_SPACE}"
    qtbot.waitUntil(lambda: win.error_box is not None and win.error_box.isVisible())
    assert win.error_box.text() == win.last_error
    assert win.document.dirty and win.windowTitle().endswith(" *") and win.document.path == path
    assert path.read_bytes() == saved and sorted(p.name for p in tmp_path.iterdir()) == ["job.flatweave"]
    # with room on the disk the same save works
    assert win.save_to(path) and not win.document.dirty
    assert load_project(path).settings.tol == 1e-8


@pytest.mark.parametrize("error", [ValueError("Out of range float values are not JSON compliant: nan"),
                                   OSError(5, "Input/output error")])
def test_an_unexpected_save_failure_is_still_a_one_line_error(make_window, monkeypatch, error, capsys):
    import flatweave.app.files

    win = make_window(small_project(0.1))
    win.document.edit_settings("Tolerance", tol=1e-8)

    def failing(project, path):
        raise error

    monkeypatch.setattr(flatweave.app.files, "save_with_backups", failing)
    assert not win.save_to("x.flatweave")
    assert win.last_error == f"Cannot save: {type(error).__name__}: {str(error).splitlines()[0]}"
    assert win.document.dirty and win.document.path is None
