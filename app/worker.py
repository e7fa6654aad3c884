"""The solve worker: :func:`flatweave.method.pipeline.flatten_iter` in a QThread.

The thread turns every solver snapshot into a :class:`~flatweave.app.frames.Frame`
(strain, shear, boundary and dart nodes, and at intervals the pattern) and
leaves the newest in a slot; the GUI takes it from there on its own timer
(:meth:`SolveThread.take_frame`), so a fast solver never floods the event loop
and the GUI always draws the latest state. Control is by flags checked between
snapshots (the generator yields every iteration):

* :meth:`request_stop`: the run ends at once with its last iterate: a helper
  thread makes that iterate a consistent result (its own pattern and metrics),
  marked as stopped and timed from the run's start to the Stop, without waiting
  for the iteration in progress (one iteration of a big run takes seconds),
  which is discarded when it ends. :meth:`abandon` ends the run without a
  result (a newer run replaces it).
* :meth:`pause` / :meth:`resume`: the thread waits between iterations.

Any exception ends the run with :attr:`failed` (a one-line message); the
traceback of one that is not a :class:`~flatweave.errors.FlatweaveError` (a bug,
not a user error) also goes to stderr for a bug report.

superqt's ``GeneratorWorker`` was the first choice; it is not used because it
hands back a ``RuntimeError`` (and subclasses) raised by the work as a warning
instead of its ``errored`` signal (so such a failure would never reach the
error dialog), swaps the process-wide warning filters from the worker thread
while it runs, and on abort drops the generator without letting it finish a
consistent result.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
import traceback
from dataclasses import dataclass, replace

from PySide6.QtCore import QThread, Signal

from flatweave.errors import FlatweaveError
from flatweave.method.result import FlattenResult
from flatweave.method.pipeline import flatten_iter, stopped_result
from flatweave.document.project import Project
from flatweave.method.solver import State

from flatweave.app.frames import Frame, FrameMaker

__all__ = ["SolveThread", "RunOutcome", "one_line"]

DRAPE_FRAME_INTERVAL = 1 / 15
"""Seconds between frames of the drape (the mesh laid so far) at least, and so
the longest wait for Stop or Pause during a drape; the drape spaces its
reports further when they are dear (at most a tenth of its time, see
flatweave.method.drape.REPORT_SHARE). Each frame has a new mesh (the views rebuild their
geometry). The most frequent interval that did not lengthen the run
(docs/decisions/0020-drape-frames-and-report-share.md)."""
PATTERN_INTERVAL = 0.25
"""Seconds between live patterns at least (more when a pattern is slow, see PATTERN_SHARE)."""
PATTERN_SHARE = 0.04
"""At most about this share of a run goes into its live patterns (a pattern's
cost sets the wait for the next one); with ``flatweave.app.runner.FRAME_SHARE`` for
drawing them, live frames stay within a tenth of the run."""
FIRST_PATTERN_AT_ONCE = False
"""The solve's first snapshot gets a pattern (after its frame without one is
published). Off: a live pattern is made only for a frame the GUI takes, and the
GUI takes the first frame at once, before a pattern could be ready, and the
next one only when the frames' share allows (flatweave.app.runner.FRAME_SHARE): in a
short re-solve that is never, so the first pattern cost the run 20-90 ms and
was seldom drawn (docs/decisions/0044-live-frames-paced-first-frame-shows-the-v.md)."""
FIRST_FRAME_WITH_PATTERN = True
"""The solve's first live frame waits for its own pattern and goes out once, with it: the
dart's opening (the V) in both views from the first frame, for one frame's drawing
(docs/decisions/0044-live-frames-paced-first-frame-shows-the-v.md). Only on meshes of at most
FIRST_PATTERN_NODES nodes, where a pattern takes a few tens of milliseconds."""
FIRST_PATTERN_NODES = 10_000


def one_line(exc: BaseException) -> str:
    """A one-line message for an exception: the text of a FlatweaveError, else
    the exception's type and first line."""
    if isinstance(exc, FlatweaveError):
        text = str(exc)
    else:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        text = f"{type(exc).__name__}: {first}" if first else type(exc).__name__
    return " ".join(text.split())


SOLVE_NICENESS = 5
"""The solve thread's nice value: the lowest that keeps the window answering a
camera drag during a solve (docs/decisions/0010-solve-thread-at-nice-5.md)."""


def _lower_priority(niceness: int = SOLVE_NICENESS) -> None:
    """Make the calling thread yield the CPU to the GUI thread (and the software
    GL renderer's threads) when they compete: on Linux a thread has its own
    nice value (raised to ``niceness``, never lowered). Elsewhere, or if
    refused, nothing changes."""
    if hasattr(os, "setpriority") and hasattr(threading, "get_native_id") and sys.platform.startswith("linux"):
        try:
            tid = threading.get_native_id()
            os.setpriority(os.PRIO_PROCESS, tid, max(os.getpriority(os.PRIO_PROCESS, tid), niceness))
        except OSError:
            pass


class _DrapeStopped(Exception):
    """Raised from the drape's progress report to end a drape on Stop."""


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended: its result (None if stopped before the first iteration)
    and the project it started from."""

    result: FlattenResult | None
    source: Project
    stopped: bool


class SolveThread(QThread):
    """One solve of ``project`` (from ``initial`` if given, else a new drape).

    Signals (queued to the GUI thread): ``succeeded(RunOutcome)`` for a
    finished run, ``failed(str)`` with a one-line message, ``stopped(RunOutcome)``
    for a run stopped by :meth:`request_stop` (from the helper thread, as soon as
    the last iterate's result is made, possibly before the solve thread ends) or
    ``stop_failed(str)`` when that result cannot be made, ``paused_changed(bool)``,
    and ``first_live()`` when the run's first live frame is published. A run emits
    exactly one of the four answers, an abandoned run none; ``QThread.finished``
    comes after it (the thread waits for its helper).
    """

    succeeded = Signal(object)
    failed = Signal(str)
    stopped = Signal(object)
    stop_failed = Signal(str)
    paused_changed = Signal(bool)
    first_live = Signal()  # the run's first live frame is out: the GUI takes it now, not at its next pump

    def __init__(self, project: Project, initial: State | None = None, parent=None):
        super().__init__(parent)
        self.project = project
        self.initial = initial
        self._stop = threading.Event()
        self._abandon = threading.Event()
        self._running = threading.Event()  # set while not paused
        self._running.set()
        self._waiting = False
        self._lock = threading.Lock()
        self._frame: Frame | None = None
        self._frame_seq = 0
        self._taken_seq = 0  # the newest frame the GUI has taken
        self._live_seq = 0  # the newest live frame published
        self.history: list[tuple[int, float, bool]] = []  # (iteration, energy, population changed)
        self.stage = "starting"
        self.pattern_seconds = 0.0
        self.frames_from = -math.inf
        """The GUI takes the next live frame from this time on (perf_counter seconds; inf while it draws
        one): the runner's frame budget (``flatweave.app.runner.FRAME_SHARE``). A snapshot's frame is made only when
        the GUI will take it before the next snapshot comes (a frame costs about 5 ms of a 35 ms iteration
        at 2,500 nodes, and most were never drawn; docs/decisions/0044-live-frames-paced-first-frame-shows-the-v.md)."""
        self._unframed = None  # the newest snapshot whose frame was not made (made if the run pauses)
        self.frames_made = 0  # live frames made (for the tests and the benchmark)
        self.started_at = time.perf_counter()  # the run's start (perf_counter s): a stopped run's time counts from it
        self.stop_point: tuple[int | None, float] | None = None
        """Once a Stop was taken: (the last iterate's iteration, None during the drape; seconds from
        the run's start to the Stop)."""
        self._last = None  # the newest snapshot: the last iterate (under the lock, with ``history``)
        self._claimed = False  # the run answered its own way (finished or failed): a Stop comes too late
        self._maker: FrameMaker | None = None
        self._finisher: threading.Thread | None = None  # makes a stopped run's result

    # ------------------------------------------------------------------ control (GUI thread)
    def request_stop(self) -> None:
        """End the run with its last iterate, now: ``stop_point`` is set and a helper thread makes
        the result (``stopped``) while the iteration in progress, if any, runs out and is discarded.
        A run that has answered its own way (finished, failed) or been abandoned keeps that answer."""
        with self._lock:
            if not (self._stop.is_set() or self._claimed):
                seconds = time.perf_counter() - self.started_at
                snap, history = self._last, [e for _, e, _ in self.history]
                self.stop_point = (None if snap is None else snap.iteration, seconds)
                self._finisher = threading.Thread(target=self._finish_stopped, args=(snap, history, seconds),
                                                  name="flatweave-stopped-result", daemon=True)
                self._finisher.start()
            self._stop.set()
        self._running.set()

    def abandon(self) -> None:
        self._abandon.set()
        self._stop.set()
        self._running.set()

    def pause(self) -> None:
        """Ask the thread to wait after its current iteration (``paused`` turns
        True, and ``paused_changed(True)`` is emitted, once it does)."""
        if not self._stop.is_set():
            self._running.clear()

    def resume(self) -> None:
        self._running.set()

    @property
    def pause_requested(self) -> bool:
        return not self._running.is_set()

    @property
    def paused(self) -> bool:
        """The thread is waiting between iterations (not merely asked to)."""
        return self._waiting

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    @property
    def abandoned(self) -> bool:
        return self._abandon.is_set()

    def take_frame(self, seen: int) -> tuple[int, Frame | None]:
        """(sequence number, frame) of the newest frame, or (seen, None) if there is
        none newer than sequence number ``seen``."""
        with self._lock:
            if self._frame_seq == seen:
                return seen, None
            self._taken_seq = self._frame_seq
            return self._frame_seq, self._frame

    # ------------------------------------------------------------------ the thread
    def _publish(self, frame: Frame, live: bool = False, final: bool = False) -> None:
        with self._lock:
            if self._stop.is_set() and not final:
                return  # after a Stop the views keep the last live frame until the result's frame
            first = live and self._live_seq == 0
            self._frame = frame
            self._frame_seq += 1
            if live:
                self._live_seq = self._frame_seq
        if first:
            self.first_live.emit()

    def run(self) -> None:
        _lower_priority()
        try:
            outcome = self._solve()
        except Exception as exc:  # everything reaches the GUI as one line
            with self._lock:  # a stopped run's answer is its last iterate, whatever its next iteration did
                answer = not self._stop.is_set()
                self._claimed = self._claimed or answer
            if answer and not self._abandon.is_set():
                if not isinstance(exc, FlatweaveError):  # a bug, not a user error: keep its traceback
                    traceback.print_exc(file=sys.stderr)
                self.failed.emit(one_line(exc))
            outcome = None
        finally:
            with self._lock:
                finisher = self._finisher
            if finisher is not None:  # its answer goes out before this thread's end
                finisher.join()
        if outcome is not None and not self._abandon.is_set():
            self.succeeded.emit(outcome)

    def _wait_if_paused(self, maker: FrameMaker | None = None) -> None:
        if not self._running.is_set():
            snap, self._unframed = self._unframed, None
            if snap is not None and maker is not None:  # a paused run shows its newest state
                self._publish(self._live_frame(maker, snap))
            self._waiting = True
            self.paused_changed.emit(True)
            self._running.wait()
            self._waiting = False
            self.paused_changed.emit(False)

    def _solve(self) -> RunOutcome | None:
        p = self.project
        surface, settings = p.surface, p.settings
        maker = self._maker = FrameMaker(surface, settings)
        self.stage = "draping" if self.initial is None else "starting from the last result"
        t0 = time.perf_counter()

        def drape_frame(mesh, uv, xyz):  # the mesh laid so far; Stop and Pause work here too
            self._wait_if_paused()
            if self._stop.is_set():
                raise _DrapeStopped
            if mesh.n_springs:
                self._publish(maker.frame(mesh, uv, xyz, 0, math.nan, time.perf_counter() - t0))

        gen = flatten_iter(surface, settings, self.initial, area=maker.A3, drape_progress=drape_frame,
                           drape_interval=DRAPE_FRAME_INTERVAL)
        pattern = None
        pattern_stats: dict = {}
        next_pattern = -math.inf if FIRST_PATTERN_AT_ONCE else time.perf_counter() + PATTERN_INTERVAL
        step = 0.0  # the last snapshot's wait (how soon the next one comes)
        try:
            while True:
                self._wait_if_paused(maker)
                if self._stop.is_set():
                    break
                t_next = time.perf_counter()
                try:
                    snap = next(gen)
                except _DrapeStopped:
                    break
                except StopIteration as done:
                    with self._lock:
                        if self._stop.is_set():  # stopped while finishing: answered by the last iterate
                            break
                        self._claimed = True
                    result: FlattenResult = done.value
                    self.stage = "done"
                    self._publish(maker.from_result(result), final=True)
                    return RunOutcome(result, p, stopped=False)
                with self._lock:
                    if self._stop.is_set():  # an iteration that ended after the Stop is not the run's
                        break
                    self._last = snap
                    self.history.append((snap.iteration, snap.energy, snap.population_changed))
                self.stage = "solving"
                now = time.perf_counter()
                step = now - t_next
                if self.frames_made and (now + step < self.frames_from or self._live_seq > self._taken_seq):
                    # the GUI would not take its frame before the next snapshot's, or has not taken the last one
                    # yet (the run's first: it was busy repainting for the edit; a newer frame made meanwhile cost
                    # the solve 7-30 ms and was never drawn). The first is made at once: the drape's frames'
                    # share paces the drape's, not the solve's first
                    self._unframed = snap
                    continue
                self._unframed = None
                first = self.frames_made == 0
                frame = self._live_frame(maker, snap)
                waits = first and FIRST_FRAME_WITH_PATTERN and snap.mesh.n_nodes <= FIRST_PATTERN_NODES
                if waits or now >= next_pattern:
                    if first and not waits:  # out at once: the views need not wait for its pattern
                        self._publish(frame, live=True)
                    t_pattern = time.perf_counter()
                    pattern = maker.pattern(snap.mesh, snap.uv, snap.xyz)
                    pattern_stats = maker.pattern_stats(pattern)
                    cost = time.perf_counter() - t_pattern
                    self.pattern_seconds += cost
                    next_pattern = t_pattern + max(PATTERN_INTERVAL, cost * (1 / PATTERN_SHARE - 1))
                if pattern is not None:  # the newest pattern rides on later frames (the GUI may skip frames)
                    frame = replace(frame, pattern=pattern, stats={**frame.stats, **pattern_stats})
                self._publish(frame, live=True)
        finally:
            gen.close()
        return None  # stopped (answered by the helper thread) or abandoned

    def _live_frame(self, maker: FrameMaker, snap) -> Frame:
        self.frames_made += 1
        return maker.from_snapshot(snap)

    def _finish_stopped(self, snap, history: list, seconds: float) -> None:
        """The helper thread of a Stop: the answer of a run stopped at snapshot ``snap`` (None:
        before its first iteration, no result) after ``seconds``, unless the run is abandoned."""
        _lower_priority()
        try:
            result = None if snap is None else self._stopped_result(snap, history, seconds)
        except Exception as exc:
            if not self._abandon.is_set():
                if not isinstance(exc, FlatweaveError):
                    traceback.print_exc(file=sys.stderr)
                self.stop_failed.emit(one_line(exc))
            return
        if not self._abandon.is_set():
            self.stopped.emit(RunOutcome(result, self.project, stopped=True))

    def _stopped_result(self, snap, history: list, seconds: float) -> FlattenResult:
        """The last iterate as a result (:func:`flatweave.method.pipeline.stopped_result`): the run's settings
        and solver, its iterations, the status 'stopped', and the run's time up to the Stop (not
        the time its pattern took). Its frame is published for the views. A FrameMaker of its own:
        the solve thread may still be using the run's."""
        p, run_maker = self.project, self._maker
        result = stopped_result(p.surface, p.settings, snap, area=run_maker.A3,
                                message=f"stopped by the user at iteration {snap.iteration}", history=history,
                                seconds=seconds)
        maker = FrameMaker(p.surface, p.settings, run_maker.L3, run_maker.A3)
        self._publish(maker.from_result(result), final=True)
        return result
