"""Runs solves for the window: one :class:`~flatweave.app.worker.SolveThread` at a time,
a frame pump that hands the newest frame to the views at a bounded rate, and
the bookkeeping of Run, Pause/Resume, Stop and "run again with new settings".

A run that is replaced by a newer one (settings changed while it ran) is
abandoned: it stops at its next iteration without making a result, and the
new one starts as soon as its thread has ended, so two solves never run at once.
A stopped run is answered as soon as its last iterate's result is made (the
solve thread's iteration in progress runs out meanwhile and is discarded): the
runner is idle from then on, and a run started before that thread has ended
waits for it.
"""

from __future__ import annotations

import math
import time

from PySide6.QtCore import QCoreApplication, QEvent, QObject, QTimer, Signal

from flatweave.document.project import Project
from flatweave.method.solver import State

from flatweave.app.worker import RunOutcome, SolveThread

__all__ = ["Runner"]

FRAME_INTERVAL_MS = 30
"""The frame pump's period: at most about 33 frames a second reach the views."""
FRAME_SHARE = 0.06
"""At most about this share of a run goes into drawing its live frames: after a
frame that took the GUI c seconds (its slots and the repaint they asked for),
the next waits c (1 / FRAME_SHARE - 1); with ``flatweave.app.worker.PATTERN_SHARE`` for
the live patterns, a tenth of the run. With software OpenGL on a loaded 2-core
machine a frame can take 0.1 s, and drawing every one made the run 40 % longer
(docs/decisions/0030-dragged-points-preview-outside-the-document.md). The repaint is most of a frame's
cost (a 2,500-node frame: 20-30 ms in its slots, 40-80 ms repainting both views);
counting only the slots would spend three to four times the
share (docs/decisions/0044-live-frames-paced-first-frame-shows-the-v.md). None: every
pump period. The run's first live frame goes out at once (a re-solve's answer
starts there); the drape's frames are paced by the drape itself
(``flatweave.app.worker.DRAPE_FRAME_INTERVAL``), and a paused run shows its newest state at once."""
PAINT_WAIT_MS = 250
"""How long a frame's drawing waits for the repaint of the watched views (``Runner.watch_paints``)
before it counts as drawn without one (a hidden or minimised window paints nothing)."""


_PAINTED = QEvent.Type(QEvent.registerEventType())  # posted to the runner when the views have repainted

HOLD_FOR_FIRST_FRAME_MS = 300
"""A warm re-solve (an edit answered at once: a dart, a setting) holds the views' repaints until
its first frame, at most this long: the edit's own repaint (40-80 ms of software OpenGL on both
cores) would only delay the solve's first iteration, and the first live frame, a tenth of a second
later, repaints everything the edit changed
(docs/decisions/0044-live-frames-paced-first-frame-shows-the-v.md). 0: no hold."""


class _PaintHold(QObject):
    """Keeps widgets from painting while held; repaints the ones that asked, when released."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self._widgets: list = []
        self._asked: list = []
        self._timer = QTimer(self, singleShot=True)
        self._timer.timeout.connect(self.release)

    def hold(self, widgets, ms: int) -> None:
        self.release()
        self._widgets = [w for w in widgets if w.isVisible()]
        for w in self._widgets:
            w.installEventFilter(self)
        if self._widgets:
            self._timer.start(ms)

    def release(self) -> None:
        self._timer.stop()
        widgets, self._widgets = self._widgets, []
        asked, self._asked = self._asked, []
        for w in widgets:
            w.removeEventFilter(self)
        for w in asked:
            w.update()

    def eventFilter(self, obj, event) -> bool:
        if event.type() == QEvent.Type.Paint:
            if obj not in self._asked:
                self._asked.append(obj)
            return True
        return False


class Runner(QObject):
    """Signals: ``frame(Frame)`` to draw; ``started(Project)``; ``finished(RunOutcome)``;
    ``failed(str)`` (one line); ``cancelled()`` when an abandoned run has ended
    and no other follows; ``state_changed(str)`` with "idle", "running",
    "paused" or "stopping". Every run that is not replaced ends with exactly one
    of ``finished``, ``failed`` and ``cancelled``; a stopped run's ``finished``
    (or ``failed``) comes when its last iterate's result is made, without waiting
    for its solve thread's iteration in progress."""

    frame = Signal(object)
    started = Signal(object)
    finished = Signal(object)
    failed = Signal(str)
    cancelled = Signal()
    state_changed = Signal(str)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.thread: SolveThread | None = None
        self._pending: tuple[Project, State | None] | None = None
        self._seen = 0
        self._outcome: RunOutcome | None = None
        self._error: str | None = None
        self._answered = False  # the thread's run was answered (stopped) before the thread ended
        self._timer = QTimer(self)
        self._timer.setInterval(FRAME_INTERVAL_MS)
        self._timer.timeout.connect(self.pump)
        self.frames_shown = 0
        self.frame_seconds: list[float] = []  # GUI time on each delivered frame, its repaint included
        self._next_frame = 0.0  # no live frame before this (perf_counter seconds)
        self._drawing = False  # a frame was handed out and its repaint has not been done yet
        self._live_shown = False  # the run in flight has shown a live frame of its solve (not the drape's)
        # the frame being drawn: (pump's start, its thread, GUI seconds in its slots); the paint's start
        self._drawing_for: tuple[float, SolveThread, float] | None = None
        self._paint_start: float | None = None
        self._watched: list = []  # the views' widgets, whose repaint ends a frame's drawing
        self._hold = _PaintHold(self)  # their repaints held while a warm re-solve's first frame comes
        self._paint_wait = QTimer(self, singleShot=True, interval=PAINT_WAIT_MS)
        self._paint_wait.timeout.connect(self._drawn)
        self.runs_started = 0
        self.last_history: list = []  # the history of the last run that ended
        self.last_pattern_seconds = 0.0  # its solve thread's time in live patterns (for the benchmark)
        self.last_start: tuple[Project, State | None] | None = None  # what the last run started from

    # ------------------------------------------------------------------ state
    @property
    def busy(self) -> bool:
        """A run is in flight (or queued): not a stopped run answered already whose thread runs out."""
        return self.thread is not None and (not self._answered or self._pending is not None)

    @property
    def active(self) -> bool:
        """A run is in flight that will deliver frames and an outcome (not abandoned, not answered)."""
        return self.thread is not None and not self.thread.abandoned and not self._answered

    @property
    def solving(self) -> Project | None:
        """The project the run in flight (or the one queued to follow it) solves; None when idle or abandoned."""
        if self._pending is not None:
            return self._pending[0]
        return self.last_start[0] if self.active else None

    @property
    def paused(self) -> bool:
        """Paused, or asked to pause (the solve waits after its current iteration)."""
        return self.thread is not None and self.thread.pause_requested

    @property
    def state(self) -> str:
        t = self.thread
        if not self.busy:
            return "idle"
        if t.stopping:
            return "stopping"
        return "paused" if t.pause_requested else "running"

    @property
    def history(self) -> list:
        return list(self.thread.history) if self.active else []

    @property
    def stop_point(self) -> tuple[int | None, float] | None:
        """The run in flight's Stop, once taken: (the last iterate's iteration, None during the drape;
        seconds from the run's start to the Stop). None with no Stop, or one that came after the run's
        own end."""
        return self.thread.stop_point if self.active else None

    @property
    def stage(self) -> str:
        return self.thread.stage if self.thread is not None else "idle"

    def watch_paints(self, widgets) -> None:
        """A frame counts as drawn when these widgets (the views) have repainted for it, and its cost
        is the GUI's time in its slots and in that repaint. Without them the frame's slots alone count."""
        self._watched = list(widgets)

    # ------------------------------------------------------------------ commands
    def start(self, project: Project, initial: State | None = None) -> None:
        """Solve ``project`` (warm-started from ``initial`` if given). A run in
        flight is abandoned and this one starts when it has ended."""
        if self.thread is not None:
            self._pending = (project, initial)
            self.thread.abandon()
            self.state_changed.emit(self.state)
            return
        self._launch(project, initial)

    def stop(self) -> None:
        """Stop the run now: its last iterate becomes its result (``finished`` once that is made,
        without waiting for the iteration in progress); ``stop_point`` says where it stopped."""
        self._pending = None
        if self.thread is not None and not self.thread.stopping:
            self.thread.request_stop()
            self.state_changed.emit(self.state)

    def pause(self) -> None:
        if self.thread is not None:
            self.thread.pause()
            self.state_changed.emit(self.state)

    def resume(self) -> None:
        if self.thread is not None:
            self.thread.resume()
            self.state_changed.emit(self.state)

    def toggle_pause(self) -> None:
        if self.paused:
            self.resume()
        else:
            self.pause()

    def cancel(self) -> None:
        """Abandon the run in flight (no result, no signal) and any queued one."""
        self._pending = None
        if self.thread is not None:
            self.thread.abandon()
            self.state_changed.emit(self.state)

    def shutdown(self, timeout_ms: int = 10000) -> bool:
        """Abandon any run and wait for its thread (at window close). True if none is left."""
        self._pending = None
        t = self.thread
        if t is None:
            return True
        t.abandon()
        done = t.wait(timeout_ms)
        if done:
            self._cleanup()
        return done

    # ------------------------------------------------------------------ internals
    def _launch(self, project: Project, initial: State | None) -> None:
        self.last_start = (project, initial)
        t = SolveThread(project, initial)
        t.succeeded.connect(self._on_succeeded)
        t.failed.connect(self._on_failed)
        t.stopped.connect(self._on_stopped)
        t.stop_failed.connect(self._on_stop_failed)
        t.paused_changed.connect(lambda _p: self.state_changed.emit(self.state))
        t.finished.connect(self._on_thread_finished)
        # the first live frame (a re-solve's answer starts there) goes out when it is made: the pump's period
        # would add 0-30 ms to it
        t.first_live.connect(self.pump)
        self.thread = t
        self._seen = 0
        self._drawn()  # a frame of an earlier run still waiting for its repaint paces nothing of this one
        self._next_frame = 0.0  # a new run's first frame goes out at once
        self._live_shown = False  # and so does its solve's first live frame, after the drape's
        self._outcome = None
        self._error = None
        self._answered = False
        self.runs_started += 1
        if initial is not None and HOLD_FOR_FIRST_FRAME_MS > 0:
            self._hold.hold(self._watched, HOLD_FOR_FIRST_FRAME_MS)
        t.start()
        self._timer.start()
        self.started.emit(project)
        self.state_changed.emit(self.state)

    def pump(self, final: bool = False) -> None:
        """Hand the newest frame (if there is a new one) to ``frame``'s slots
        (within the frames' share of the run, see FRAME_SHARE, unless ``final``)."""
        t = self.thread
        if t is None or t.abandoned or self._answered:  # an abandoned or answered run's frames belong to nobody
            return
        t0 = time.perf_counter()
        if t.stop_point is not None and not final:
            return  # stopped: the views keep the last live frame until the result's
        seq, frame = t.take_frame(self._seen)
        if frame is None:
            return
        first_live = not frame.draping and not frame.final and not self._live_shown
        if not final and not frame.draping and not t.pause_requested \
                and ((t0 < self._next_frame and not first_live) or self._drawing):
            # the frames' share of the run is spent for now (the newest frame waits in its slot); the solve's
            # first frame waits only for a drape frame being drawn (the drape's frames pace the drape's)
            return
        self._live_shown = self._live_shown or first_live
        self._seen = seq
        t.frames_from = math.inf  # no live frame is wanted while this one is drawn
        self._hold.release()  # the views repaint for this frame (and the edit before it)
        if self._drawing:
            self._drawn()  # the last frame's repaint has not come (it paints with this one's)
        self.frame.emit(frame)
        self.frames_shown += 1
        self._drawing = True
        self._drawing_for = (t0, t, time.perf_counter() - t0)
        self._paint_start = None
        watched = [w for w in self._watched if w.isVisible()]
        if not watched:
            QTimer.singleShot(0, self._drawn)
            return
        # the views repaint when the event loop next runs, after zero timers (Qt asks for a window's
        # update on a timer of its own): the frame is drawn when its repaint has been done
        for w in watched:
            w.installEventFilter(self)
        self._paint_wait.start()

    def eventFilter(self, obj, event) -> bool:
        if event.type() == QEvent.Type.Paint and self._drawing_for is not None and self._paint_start is None:
            self._paint_start = time.perf_counter()
            # delivered once the paint pass (both views) is over and the event loop runs again
            QCoreApplication.postEvent(self, QEvent(_PAINTED))
        return False

    def event(self, event) -> bool:
        if event.type() == _PAINTED:
            if self._paint_start is not None:  # else an earlier frame's, ended already
                self._drawn()
            return True
        return super().event(event)

    def _drawn(self) -> None:
        """The frame handed out is drawn (its repaint done, or not coming): the next may go after its share."""
        self._paint_wait.stop()
        for w in self._watched:
            w.removeEventFilter(self)
        drawing, self._drawing_for = self._drawing_for, None
        self._drawing = False
        if drawing is None:
            return
        t0, t, slots = drawing
        now = time.perf_counter()
        # the GUI's time on the frame: its slots, and the repaint (not the idle wait between them)
        cost = slots + (now - self._paint_start if self._paint_start is not None else 0.0)
        self._paint_start = None
        self.frame_seconds.append(cost)
        if t is not self.thread:
            return  # a frame of a run that has ended paces nothing
        self._next_frame = now + (0.0 if FRAME_SHARE is None else cost * (1 / FRAME_SHARE - 1))
        t.frames_from = self._next_frame  # the solve thread makes the next frame for then

    def _on_succeeded(self, outcome: RunOutcome) -> None:
        self._outcome = outcome

    def _on_failed(self, message: str) -> None:
        self._error = message

    def _on_stopped(self, outcome: RunOutcome) -> None:
        """A stopped run's answer, made from its last iterate: given now, the thread may run on."""
        t = self.thread
        if t is None or self.sender() is not t or t.abandoned or self._answered:
            return
        if outcome.result is not None:
            self.pump(final=True)  # the result's frame
        self._answer_early(t, outcome, None)

    def _on_stop_failed(self, message: str) -> None:
        t = self.thread
        if t is None or self.sender() is not t or t.abandoned or self._answered:
            return
        self._answer_early(t, None, message)

    def _answer_early(self, t: SolveThread, outcome: RunOutcome | None, error: str | None) -> None:
        self._answered = True
        self._timer.stop()
        self._hold.release()
        self.last_history = list(t.history)
        self.last_pattern_seconds = t.pattern_seconds
        if error is not None:
            self.failed.emit(error)
        else:
            self.finished.emit(outcome)
        self.state_changed.emit(self.state)

    def _on_thread_finished(self) -> None:
        t = self.thread
        if t is None or self.sender() is not t:
            return
        if self._answered:  # a stopped run, answered already: only what waits for its thread
            self._cleanup()
            if self._pending is not None:
                project, initial = self._pending
                self._pending = None
                self._launch(project, initial)
            else:
                self.state_changed.emit(self.state)
            return
        abandoned = t.abandoned
        if not abandoned:
            self.pump(final=True)  # the final frame (or the last live one)
        outcome, error = self._outcome, self._error
        self.last_history = list(t.history)
        self.last_pattern_seconds = t.pattern_seconds
        self._cleanup()
        if abandoned:
            # a replaced or cancelled run answers nobody, even if it ended just before it was abandoned
            # (its result would be set aside, and a late `finished` reads as the answer to a newer run)
            pass
        elif error is not None:
            self.failed.emit(error)
        elif outcome is not None:
            self.finished.emit(outcome)
        else:  # the thread died without a word (not an Exception): still say so
            self.failed.emit("the solve ended without a result or an error message (an internal error)")
        if self._pending is not None:
            project, initial = self._pending
            self._pending = None
            self._launch(project, initial)
        else:
            if abandoned:
                self.cancelled.emit()
            self.state_changed.emit(self.state)

    def _cleanup(self) -> None:
        self._timer.stop()
        self._hold.release()
        t, self.thread = self.thread, None
        if t is not None:
            t.wait()
            t.deleteLater()
