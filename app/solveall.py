"""Solve all, in the window (issue 41): every piece of the document solved in
worker processes (:func:`flatweave.document.matching.solve_all`: the pieces, then the panels of
matched seams solved to equal sides) from a
thread of its own, so the window stays live; each piece is reported as it
finishes (``piece_done(name, text)``), and at the end the results are attached
to the pieces they were solved for as one undoable edit
(:meth:`flatweave.document.history.Document.attach_results`: a piece edited
meanwhile keeps its own state). ``finished(summary)`` says what happened in
one line. Closing the window stops it: no piece starts after that, and the
window waits for those running. No VTK here."""

from __future__ import annotations

import threading

from PySide6.QtCore import QObject, Signal

from flatweave.document.matching import solve_all
from flatweave.document.project import settings_equal

__all__ = ["SolveAll"]


class SolveAll(QObject):
    piece_done = Signal(str, str)  # the piece's name, what became of it (one line)
    finished = Signal(str)  # one line: how many were solved, which failed
    _ended = Signal(object, object)  # (outcomes, the project solved): from the thread to this one

    def __init__(self, window):
        super().__init__(window)
        self.window = window
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.workers: int | None = None  # None: one per core, at most four
        self.report = None  # the last run's matched seams (flatweave.document.matching.MatchReport)
        self._some = None  # the pieces the run on solves (None: every piece)
        self.pending = False  # a seam edit came while a run was on: its stale panels next
        self._ended.connect(self._attach)

    @property
    def busy(self) -> bool:
        return self._thread is not None

    def start(self, pieces=None) -> bool:
        """Solve every piece of the document's project (or the ones named in ``pieces``); False when a
        run is on already or there is none."""
        doc = self.window.document
        if self.busy or doc is None:
            return False
        source = doc.project
        self._stop.clear()
        self.report = None
        self._some = None if pieces is None else list(pieces)
        self.pending = False

        def run():
            try:
                # the pieces, then the matched seams' panels solved to equal sides
                _, outcomes, self.report = solve_all(source, self._some, workers=self.workers, stop=self._stop,
                                                     on_done=lambda o: self.piece_done.emit(
                                                         o.name, f"failed: {o.error}" if o.error else o.result.status))
            except Exception as exc:  # a bug must not end the thread silently: it is said in one line
                outcomes = exc
            self._ended.emit(outcomes, source)

        self._thread = threading.Thread(target=run, name="flatweave-solve-all", daemon=True)
        self._thread.start()
        self.window.update_actions()
        return True

    def _attach(self, outcomes, source) -> None:
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join()
        doc = self.window.document
        if isinstance(outcomes, Exception):
            summary = f"Solve all failed: {type(outcomes).__name__}: {outcomes}"
        else:
            results = {o.name: o.result for o in outcomes if o.result is not None}
            taken = doc.attach_results(results, source) if doc is not None and results else []
            failed = [f"{o.name} ({o.error})" for o in outcomes if o.result is None]
            summary = (f"Solve all: {len(taken)} of {len(source.pieces)} pieces solved" if self._some is None else
                       f"Panels the seam edit changed: {len(taken)} of {len(outcomes)} solved")
            if len(results) > len(taken):
                summary += f", {len(results) - len(taken)} edited meanwhile (their results not taken)"
            if failed:
                summary += "; failed: " + "; ".join(failed)
            if self.report is not None and self.report.message:
                summary += f"; {self.report.message}"
        self.window.update_actions()
        self.finished.emit(" ".join(summary.split()))
        if self.pending:  # seams were edited while it ran: the panels they changed since
            self.solve_stale_panels()

    def solve_stale_panels(self, active: bool = True) -> bool:
        """Solve the panels of the document's shapes split by seams whose results a seam edit left stale
        (the active piece too unless ``active`` is False: the window's run answers its edit), after the
        run on now if one is; False when there is none to solve."""
        doc = self.window.document
        if doc is None:
            return False
        if self.busy:
            self.pending = True
            return False
        project = doc.project
        skip = None if active else project.piece_name
        names = {n for s in project.sewings for n in s.panels if n is not None and n != skip}
        stale = [p.name for p in project.pieces if p.name in names and not (
            p.result is not None and settings_equal(p.result.settings, p.settings))]
        return bool(stale) and self.start(stale)

    def close(self) -> None:
        """No piece starts any more; wait for those running (the window is closing)."""
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join()
