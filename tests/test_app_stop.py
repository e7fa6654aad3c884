"""Stop in the window while one iteration of the solve takes long (as on a big mesh): the window
says at once that the run stopped, keeps the last live frame, and keeps the last iterate as the
result, timed from the run's start to the Stop, without waiting for the iteration in progress.

An iteration is made long deterministically: the solver's snapshot (the end of an iteration)
waits on a threading.Event the test sets, so nothing here depends on the machine's speed.
"""

from __future__ import annotations

import threading
import time

import pytest

import flatweave.app.worker
import flatweave.method.solver
from flatweave.app.runcontrol import result_text
from flatweave.document.project import project_problems
from tests.test_app_run import RUN_TIMEOUT_MS, small_project

BLOCK_AT = 10  # snapshots handed to the run before an iteration "takes long"
HOLD_MS = 600  # how long the run sits in that iteration before Stop


class SlowIteration:
    """Installs a solver whose iteration after the first BLOCK_AT snapshots waits for ``release``."""

    def __init__(self, monkeypatch):
        self.release = threading.Event()
        self.blocked = threading.Event()
        self.made: list[int] = []  # iterations of the snapshots handed to the run
        snapshot = flatweave.method.solver.Run.snapshot

        def slow(run, *args, **kwargs):
            if len(self.made) >= BLOCK_AT and not self.release.is_set():
                self.blocked.set()
                self.release.wait(60)
            snap = snapshot(run, *args, **kwargs)
            self.made.append(snap.iteration)
            return snap

        monkeypatch.setattr(flatweave.method.solver.Run, "snapshot", slow)


class Answers:
    """Counts the runner's answers (finished, failed, cancelled) and the frames handed to the views."""

    def __init__(self, win):
        self.finished, self.failed, self.cancelled, self.frames = [], [], [], []
        r = win.runner
        r.finished.connect(self.finished.append)
        r.failed.connect(self.failed.append)
        r.cancelled.connect(lambda: self.cancelled.append(True))
        r.frame.connect(self.frames.append)

    @property
    def count(self) -> int:
        return len(self.finished) + len(self.failed) + len(self.cancelled)


def _stopped_mid_iteration(make_window, qtbot, slow):
    """A window whose run sits HOLD_MS in an iteration; returns (window, answers, (t0, t1)): the run
    started between t0 and t1 (perf_counter seconds, just before and after Run)."""
    win = make_window(small_project(0.08, solver="paper", max_iter=100000))
    answers = Answers(win)
    t0 = time.perf_counter()
    win.run()
    t1 = time.perf_counter()
    qtbot.waitUntil(slow.blocked.is_set, timeout=RUN_TIMEOUT_MS)
    qtbot.wait(HOLD_MS)
    return win, answers, (t0, t1)


@pytest.mark.slow
def test_stop_is_shown_at_once_and_keeps_the_last_iterate(make_window, qtbot, monkeypatch):
    slow = SlowIteration(monkeypatch)
    try:
        win, answers, (run0, run1) = _stopped_mid_iteration(make_window, qtbot, slow)
        last = slow.made[-1]  # the last iterate the run handed out before the long iteration
        frames_before = len(answers.frames)
        shown = win.presenter.frame
        assert shown is not None and not shown.final and shown.iteration <= last

        stop0 = time.perf_counter()
        win.stop()
        stop1 = time.perf_counter()
        # the run's wall time from its start to the Stop lies within these bounds
        least, most = stop0 - run1, stop1 - run0
        # shown before the event loop even runs again (well within 0.3 s): stopped, where, and after how long
        text = win.progress.text()
        assert text.startswith(f"Stopped at iteration {last} after "), text
        said = float(text.split(" after ")[1].split(" s")[0])
        assert least - 0.005 <= said <= most + 0.005  # printed to 0.01 s
        assert win.metrics.text("status") == "stopped by the user"
        assert not win.actions["stop"].isEnabled() and not win.actions["pause"].isEnabled()
        assert win.presenter.frame is shown  # the last live frame stays

        # the result comes while the solver is still inside its iteration: the window did not wait for it
        qtbot.waitUntil(lambda: bool(answers.finished), timeout=10000)
        assert not slow.release.is_set() and win.runner.thread is not None and win.runner.thread.isRunning()
        outcome = answers.finished[0]
        r = outcome.result
        assert outcome.stopped and win.project.result is r and project_problems(win.project) == []
        assert r.metrics["iterations"] == last
        assert r.metrics["solver_status"] == f"stopped by the user at iteration {last}"
        # the run's own time, its start to the Stop (the long iteration included), not its pattern's
        assert r.metrics["seconds"] >= HOLD_MS / 1000 and least <= r.metrics["seconds"] <= most
        assert win.progress.text() == result_text(r.metrics)
        # after the Stop the views got the result's frame and nothing else
        after = answers.frames[frames_before:]
        assert len(after) == 1 and after[0].final and after[0].iteration == last
        assert win.runner.state == "idle" and win.actions["run"].isEnabled()
    finally:
        slow.release.set()

    # the iteration that ends after the Stop is discarded, and the run answers nothing more
    qtbot.waitUntil(lambda: win.runner.thread is None, timeout=RUN_TIMEOUT_MS)
    qtbot.wait(50)
    assert answers.count == 1 and win.project.result is r
    assert win.runner.last_history and win.runner.last_history[-1][0] == last


@pytest.mark.slow
def test_a_run_started_after_a_stop_waits_for_the_stopped_iteration(make_window, qtbot, monkeypatch):
    """Two solves never run at once: a run asked for while the stopped run's iteration runs out
    starts when its thread has ended, and ends with its own answer."""
    slow = SlowIteration(monkeypatch)
    try:
        win, answers, _ = _stopped_mid_iteration(make_window, qtbot, slow)
        win.stop()
        qtbot.waitUntil(lambda: bool(answers.finished), timeout=10000)
        started = win.runner.runs_started
        win.document.edit_settings("Solver", solver="fast", max_iter=200)  # auto re-run, queued
        qtbot.wait(200)
        assert win.runner.runs_started == started and win.runner.busy and win.runner.state == "stopping"
        with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
            slow.release.set()
    finally:
        slow.release.set()
    assert win.runner.runs_started == started + 1
    assert not blocker.args[0].stopped and win.project.result is blocker.args[0].result
    assert win.project.result_is_current and answers.count == 2 and not answers.failed


def test_a_stop_whose_result_cannot_be_made_fails_in_one_line(make_window, qtbot, monkeypatch):
    slow = SlowIteration(monkeypatch)

    def broken(*args, **kwargs):
        raise ValueError("no pattern today\nsecond line")

    monkeypatch.setattr(flatweave.app.worker, "stopped_result", broken)
    try:
        win, answers, _ = _stopped_mid_iteration(make_window, qtbot, slow)
        win.stop()
        qtbot.waitUntil(lambda: bool(answers.failed), timeout=10000)
        assert answers.failed == ["ValueError: no pattern today"]
        assert win.last_error == "Solve failed: ValueError: no pattern today"
        assert win.project.result is None and win.presenter.frame is None  # the document's own state
    finally:
        slow.release.set()
    qtbot.waitUntil(lambda: win.runner.thread is None, timeout=RUN_TIMEOUT_MS)
    qtbot.wait(50)
    assert answers.count == 1
