"""Run, Pause/Resume, Stop and the re-run after a settings edit, and what the
window does with a run's end: a result is handed to the document (one undo
step), a failure is shown, an abandoned run leaves nothing behind.
"""

from __future__ import annotations

from PySide6.QtCore import QTimer

from core.project import Project, warm_start

from app.aspects import HISTORY, Aspect
from app.runner import Runner
from app.worker import RunOutcome

__all__ = ["RunControl", "RERUN_DELAY_MS", "NO_DOCUMENT", "NOT_SOLVED", "result_text", "status_text"]

RERUN_DELAY_MS = 250  # settings edits closer together than this make one re-run

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
        r = self.runner
        r.frame.connect(window.presenter.draw_frame)
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
        self.runner.start(self.window.document.project)

    def rerun(self) -> None:
        """Solve again after an edit: from the last result when the drape is unchanged."""
        if self.window.document is None:
            return
        project = self.window.document.project
        self.runner.start(project, warm_start(project))

    def toggle_pause(self) -> None:
        self.runner.toggle_pause()
        frame = self.window.presenter.frame
        if frame is not None and self.runner.busy:
            self.window.presenter.show_progress(frame)

    def stop(self) -> None:
        self.rerun_timer.stop()
        self.runner.stop()

    def abandon(self) -> None:
        """Another document: any run is abandoned, no re-run follows."""
        self.runner.cancel()
        self.rerun_timer.stop()

    def close(self) -> None:
        self.rerun_timer.stop()
        self.runner.shutdown()

    # ------------------------------------------------------------------ the document
    def before_change(self, cause: str, aspects: Aspect) -> None:
        """A run solving a project the document has left is cancelled (its result would be refused)."""
        if self.runner.active and (cause in HISTORY or cause == "reset") \
                and aspects & (Aspect.SURFACE | Aspect.SETTINGS):
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
        if (cause == "edit" and aspects & Aspect.SETTINGS and self.window.settings_panel.auto_rerun.isChecked()
                and (project.result is not None or self.runner.busy)):
            self.rerun_timer.start()

    # ------------------------------------------------------------------ a run's end
    def _started(self, project: Project) -> None:
        w = self.window
        w.presenter.first_nodes = None
        w.energy_plot.clear()
        if project.result is None or warm_start(project) is None:
            w.pattern_view.request_fit()
        w.progress.setText("Draping the mesh..." if warm_start(project) is None else "Starting...")
        w.update_actions()

    def _finished(self, outcome: RunOutcome) -> None:
        w = self.window
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
                w.energy_plot.set_history(self.runner.last_history)
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
        w.progress.setText("The run was cancelled; nothing of it was kept.")
        frame = w.presenter.frame
        if w.project is not None and frame is not None and not frame.final:
            w.presenter.show_result(w.project)
        w.update_actions()
