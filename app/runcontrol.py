"""Run, Pause/Resume, Stop and the re-run after a settings edit, and what the
window does with a run's end: a result is handed to the document (one undo
step), a failure is shown, an abandoned run leaves nothing behind.

Previews (a dart or region point being dragged): :meth:`RunControl.preview_dart`
(:meth:`~RunControl.preview_settings` for a region) solves the document's
project with one dart (the region) replaced, outside the document, warm from
the document's result (a new drape for a region), and shows its frames; each newer position
replaces the preview in flight (throttled, the newest wins). The release makes
the edit as usual; when its settings are the preview's, the preview in flight
(or its finished result) answers the edit instead of a new re-run, so the drag
is one undo step with one result.
"""

from __future__ import annotations

import time

from PySide6.QtCore import QCoreApplication, QEvent, QObject, QTimer

from flatweave.document.project import Project, settings_equal, warm_start

from flatweave.app.aspects import HISTORY, Aspect
from flatweave.app.plot import result_note
from flatweave.app.runner import Runner
from flatweave.app.worker import RunOutcome

__all__ = ["RunControl", "RERUN_DELAY_MS", "NO_DOCUMENT", "NOT_SOLVED", "result_text", "status_text"]

RERUN_DELAY_MS = 250  # settings edits closer together than this make one re-run
RERUN_AT_ONCE = True
"""An edit with no run in flight re-runs at once (the delay only merges the
edits that follow it while its run is in flight): Enter on a dart starts its
solve without waiting (docs/decisions/0030-dragged-points-preview-outside-the-document.md)."""
PREVIEW_INTERVAL_MS = 120
"""A preview in flight is replaced by a newer drag position once it has shown
a frame, or after this long without one (so a drag never only restarts solves)."""

NO_DOCUMENT = "Open a surface or pick an example, then Run."
NOT_SOLVED = "Not solved yet: Run (F5) drapes the mesh and solves it."


def result_text(metrics: dict) -> str:
    """One line on a solve from its metrics: status, iterations, nodes, EN, time."""
    m = metrics
    return (f"{str(m.get('solver_status', 'done')).capitalize()}: {m.get('iterations', 0)} iterations, "
            f"{m.get('nodes', 0):,} nodes, EN {m.get('energy', 0):.6g}, {m.get('seconds', 0.0):.2f} s.")


def status_text(project: Project | None) -> str:
    """The line under Run for the document as it is (no run in flight): its
    current result's numbers, or what to do next."""
    if project is None:
        return NO_DOCUMENT
    r = project.result
    if r is None or r.surface is not project.surface:
        return NOT_SOLVED
    if not project.result_is_current:
        return f"The settings changed since the last solve ({result_text(r.metrics)[:-1]}): Run (F5) to update."
    return result_text(r.metrics)


class _Soon(QObject):
    """A zero-delay single shot (``start``, ``stop``, ``isActive``) that runs ``callback`` from a posted event
    rather than a timer: Qt delivers posted events before timers, and a repaint (a low-priority posted event)
    after them, so an edit's re-run starts before the views repaint for the edit (its first iteration runs
    while they do; a zero timer waited for the repaint, 40-70 ms with software OpenGL;
    docs/decisions/0030-dragged-points-preview-outside-the-document.md)."""

    _TYPE = QEvent.Type(QEvent.registerEventType())

    def __init__(self, parent, callback):
        super().__init__(parent)
        self._callback = callback
        self._active = False

    def start(self) -> None:
        # a start after a stop may be answered by the event the stopped one posted: as soon, so the same
        self._active = True
        QCoreApplication.postEvent(self, QEvent(self._TYPE))

    def stop(self) -> None:
        self._active = False

    def isActive(self) -> bool:
        return self._active

    def event(self, ev) -> bool:
        if ev.type() != self._TYPE:
            return super().event(ev)
        if self._active:
            self._active = False
            self._callback()
        return True


class RunControl:
    """Solves for the window: ``runner`` (one worker thread at a time) and the
    re-run timer. ``window`` gives the document, the presenter, the progress
    label, ``files.autosave``, ``show_error``, ``update_actions`` and the
    ``run_finished`` / ``run_failed`` signals."""

    def __init__(self, window):
        self.window = window
        self.runner = Runner(window)
        self.last_outcome: RunOutcome | None = None
        self.rerun_timer = QTimer(window, singleShot=True, interval=RERUN_DELAY_MS)
        self.rerun_timer.timeout.connect(self.rerun)
        self.now_timer = _Soon(window, self.rerun)  # an edit's re-run at once, after its listeners
        # previews: the newest requested (None: none), the one the runner was given, its finished outcome
        self._preview_wanted: Project | None = None
        self._preview_started: Project | None = None
        self._preview_started_at = 0.0
        self._preview_frames = 0
        self._preview_outcome: RunOutcome | None = None
        self.preview_timer = QTimer(window, singleShot=True, interval=PREVIEW_INTERVAL_MS)
        self.preview_timer.timeout.connect(self._launch_preview)
        self.previews_started = 0  # previews asked of the runner (for the tests and the benchmark)
        self.previews_adopted = 0  # previews that answered the edit made at the release
        r = self.runner
        r.frame.connect(window.presenter.draw_frame)
        r.watch_paints([window.view.widget, window.pattern_view.widget])  # a frame's repaint is its cost too
        r.frame.connect(self._preview_frame)
        r.started.connect(self._started)
        r.finished.connect(self._finished)
        r.failed.connect(self._failed)
        r.cancelled.connect(self._cancelled)
        r.state_changed.connect(lambda _s: window.update_actions())

    # ------------------------------------------------------------------ commands
    def run(self) -> None:
        """Solve the document's project from a new drape."""
        if self.window.document is None:
            return
        self.rerun_timer.stop()
        self.now_timer.stop()
        self._drop_preview()
        self.runner.start(self.window.document.project)

    def rerun(self) -> None:
        """Solve again after an edit: from the last result when the drape is unchanged."""
        if self.window.document is None:
            return
        self.rerun_timer.stop()
        self.now_timer.stop()
        project = self.window.document.project
        if self._adopt_preview(project):
            return
        self._drop_preview()
        self.runner.start(project, warm_start(project))

    def toggle_pause(self) -> None:
        self.runner.toggle_pause()
        frame = self.window.presenter.frame
        if frame is not None and self.runner.busy:
            self.window.presenter.show_progress(frame)

    def stop(self) -> None:
        self.rerun_timer.stop()
        self.now_timer.stop()
        if self.previewing:
            self.end_preview()
            return
        self.runner.stop()
        point = self.runner.stop_point
        if point is None:  # no run, or one that ended its own way first: its answer says so
            return
        # said at once: the result of the last iterate follows when its pattern is made, and the
        # iteration in progress (seconds, on a big mesh) is not waited for
        iteration, seconds = point
        w = self.window
        if iteration is None:
            text = f"Stopped during the drape after {seconds:.2f} s."
        else:
            text = f"Stopped at iteration {iteration} after {seconds:.2f} s: making the pattern of that iterate..."
        w.progress.setText(text)
        w.statusBar().showMessage(text, 8000)
        w.metrics.labels["status"].setText("stopped by the user")
        w.metrics.labels["status"].setStyleSheet("")

    def abandon(self) -> None:
        """Another document: any run is abandoned, no re-run follows."""
        self._drop_preview()
        self.runner.cancel()
        self.rerun_timer.stop()
        self.now_timer.stop()

    def close(self) -> None:
        self._drop_preview()
        self.rerun_timer.stop()
        self.now_timer.stop()
        self.runner.shutdown()

    # ------------------------------------------------------------------ previews
    @property
    def previewing(self) -> bool:
        """A preview is wanted, in flight or finished and not yet answered by an edit."""
        return self._preview_wanted is not None or self._preview_started is not None \
            or self._preview_outcome is not None

    def preview_dart(self, index: int, dart) -> bool:
        """Solve the document's project with dart ``index`` replaced by ``dart``
        (not an edit), from a new drape, replacing any preview
        in flight. False (nothing starts) with no result to start from, with
        "auto re-run" off, or while a run that is not a preview is in flight."""
        doc = self.window.document
        if doc is None or warm_start(doc.project) is None or not 0 <= index < len(doc.project.settings.darts):
            return False
        darts = list(doc.project.settings.darts)
        darts[index] = dart
        return self.preview_settings(darts=tuple(darts))

    def preview_settings(self, **changes) -> bool:
        """Solve the document's project with these settings changed (not an edit;
        a dragged region point: ``region`` and ``seed``), from the document's
        result when the drape is unchanged, else from a new drape; as
        :meth:`preview_dart` otherwise (the newest wins, the release's edit adopts it).
        False with no result on screen to replace, "auto re-run" off, or a run that is not a
        preview in flight. Settings equal to the document's, its result current (a point
        dragged back onto its spot), start no solve: a preview in flight is dropped and the
        views show the document's result."""
        doc = self.window.document
        if doc is None or not self.window.settings_panel.auto_rerun.isChecked():
            return False
        project = doc.project
        if project.result is None or project.result.surface is not project.surface:
            return False
        if self.runner.active and self._preview_started is None and self.runner.last_start[1] is None:
            return False  # a new drape the designer asked for goes on (a warm re-run gives way)
        wanted = project.with_settings(**changes)
        if project.result_is_current and settings_equal(wanted.settings, project.settings):
            # back where the document is (a point dragged back onto its own spot): its result is the answer;
            # a solve of it would take 0 iterations and show no iteration's frame
            if self.previewing:
                self.end_preview()
            return True
        self._preview_wanted = wanted
        self._preview_outcome = None
        if self._preview_started is None or self._preview_frames or \
                time.perf_counter() - self._preview_started_at >= PREVIEW_INTERVAL_MS / 1000:
            self._launch_preview()
        elif not self.preview_timer.isActive():
            left = PREVIEW_INTERVAL_MS / 1000 - (time.perf_counter() - self._preview_started_at)
            self.preview_timer.start(max(1, int(1000 * left)))
        return True

    def end_preview(self) -> None:
        """The drag ended without an edit: the preview is dropped and the views
        go back to the document."""
        had_run = self._preview_started is not None
        self._drop_preview()
        if had_run and self.runner.busy:
            self.runner.cancel()  # its frames are no longer shown
        project = self.window.project
        if project is None:
            return
        self.window.presenter.show_result(project)
        self.window.progress.setText(status_text(project))
        if not project.result_is_current and self.window.settings_panel.auto_rerun.isChecked():
            self.now_timer.start()  # the preview replaced the re-run of an earlier edit: run it again

    def _launch_preview(self) -> None:
        self.preview_timer.stop()
        project, self._preview_wanted = self._preview_wanted, None
        doc = self.window.document
        if project is None or doc is None:
            return
        self._preview_started = project
        self._preview_started_at = time.perf_counter()
        self._preview_frames = 0
        self.previews_started += 1
        # as the edit's own re-run would start, so the release's result is the one Enter gives: a moved
        # dart drapes anew (flatweave.document.project.warm_start; the old opening is a worse start). Starting from the
        # previous position's mid-solve state was measured too: after four positions, 148 iterations to a
        # higher energy instead of 11 (docs/decisions/0030-dragged-points-preview-outside-the-document.md).
        self.runner.start(project, warm_start(project))

    def _preview_frame(self, frame) -> None:
        """A frame of the run in flight: a position waiting for the preview to show something may go now."""
        if self._preview_started is None or frame.draping:
            return
        self._preview_frames += 1
        if self._preview_wanted is not None:
            self._launch_preview()

    def _drop_preview(self) -> None:
        self.preview_timer.stop()
        self._preview_wanted = self._preview_started = self._preview_outcome = None

    def _adopt_preview(self, project: Project) -> bool:
        """The edit ``project`` is what the newest preview solves: its run in
        flight (or its finished result) answers the edit. True if so."""
        started, outcome = self._preview_started, self._preview_outcome
        if self._preview_wanted is not None or started is None or started.surface is not project.surface \
                or not settings_equal(started.settings, project.settings):
            return False  # a newer position was never solved, or the edit is another one
        in_flight = self.runner.busy and self.runner.solving is started
        if outcome is None and not in_flight:
            return False
        self._drop_preview()
        self.previews_adopted += 1
        if outcome is not None:
            self._finished(outcome)  # its result answers the edit now
        else:
            self.window.progress.setText("Solving the moved dart...")
        return True

    # ------------------------------------------------------------------ the document
    def before_change(self, cause: str, aspects: Aspect) -> None:
        """A run solving a project the document has left is cancelled (its result would be refused):
        another document, an undo or redo to other settings, or another piece made active."""
        left = (cause in HISTORY or cause == "reset") and aspects & (Aspect.SURFACE | Aspect.SETTINGS)
        if self.runner.active and (left or cause == "select"):
            self.runner.cancel()

    def after_change(self, project: Project, cause: str, aspects: Aspect, label: str = "") -> None:
        """A settings edit re-runs (after a short delay) when "auto re-run" is on and there is
        a result or a run to replace. With no run in flight, the line under Run
        (and, after an undo or redo, the status bar) says what the document holds now."""
        if not self.runner.active:
            text = status_text(project)
            self.window.progress.setText(text)
            if cause in HISTORY:
                self.window.statusBar().showMessage(f"{cause.capitalize()} {label}: {text}" if label else text, 8000)
        if cause != "edit" and self.previewing:
            self.end_preview()  # undo, redo, another document: the drag's preview is gone
        # an edit that brings its own answer (a suggested dart's re-solve) needs no run
        if (cause == "edit" and aspects & Aspect.SETTINGS and self.window.settings_panel.auto_rerun.isChecked()
                and not project.result_is_current and (project.result is not None or self.runner.busy)):
            # at once (after the other listeners) when nothing is in flight or a preview may answer it;
            # otherwise after a quiet spell, so a burst of edits makes one run
            if RERUN_AT_ONCE and (not self.runner.busy or self._preview_started is not None) \
                    and not self.rerun_timer.isActive():
                self.now_timer.start()
            else:
                self.now_timer.stop()
                self.rerun_timer.start()

    # ------------------------------------------------------------------ a run's end
    def _started(self, project: Project) -> None:
        w = self.window
        draped = warm_start(project) is None
        w.presenter.first_nodes = w.presenter.first_spacing = None
        w.presenter.started_from = "the drape" if draped else "the warm start"
        w.energy_plot.clear()
        if project.result is None or draped:
            w.pattern_view.request_fit()
        w.progress.setText("Draping the mesh..." if draped else "Starting...")
        w.update_actions()

    def _finished(self, outcome: RunOutcome) -> None:
        w = self.window
        if self._preview_started is not None and outcome.source is self._preview_started:
            # a preview ran to its end before the release: kept (on screen) for the edit to come
            self._preview_outcome = outcome
            w.progress.setText("Preview of the moved point (release to keep it).")
            w.update_actions()
            return
        self.last_outcome = outcome
        r = outcome.result
        if r is None:
            w.progress.setText("Stopped before the first iteration; nothing changed.")
            w.presenter.show_result(w.project)
        else:
            m = r.metrics
            label = "Stop" if outcome.stopped else "Solve"
            attached = w.document.attach_result(r, outcome.source, label=label)
            if attached:
                w.energy_plot.set_history(self.runner.last_history, result_note(m))
                w.files.autosave()
                text = result_text(m)
            else:
                text = "The settings changed during the run; its result was set aside."
                w.presenter.show_result(w.project)
            w.progress.setText(text)
            w.statusBar().showMessage(text, 8000)
        w.update_actions()
        w.run_finished.emit(outcome)

    def _failed(self, message: str) -> None:
        w = self.window
        self._drop_preview()
        w.show_error(f"Solve failed: {message}")
        w.progress.setText(f"Solve failed: {message}")
        if w.project is not None:
            w.presenter.show_result(w.project)  # back to the document's own state
        w.update_actions()
        w.run_failed.emit(message)

    def _cancelled(self) -> None:
        """A run was abandoned (undo, another document, ``Runner.cancel``) and none
        follows: nothing of it is kept, and views still showing its live frames
        go back to the document."""
        w = self.window
        self._preview_started = None
        w.progress.setText("The run was cancelled; nothing of it was kept.")
        frame = w.presenter.frame
        if w.project is not None and frame is not None and not frame.final:
            w.presenter.show_result(w.project)
        w.update_actions()
