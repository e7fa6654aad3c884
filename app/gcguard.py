"""Cyclic garbage collected in the GUI thread only, while a window is open.

Python runs its cyclic garbage collector in whatever thread happens to allocate when a
generation's count passes its threshold: a worker thread (the Cut plan's nesting, a solve)
then destroys whatever cycles hold, Qt widgets and VTK render windows of a closed window
among them, and Qt or VTK objects destroyed off the GUI thread crash the process (a
segmentation fault, seen in CI in the nesting thread's shapely calls). So while any window
is open the automatic collector is off and :class:`_Collector` runs the same collections,
by the same thresholds, from a timer in the GUI thread; when the last window closes it
collects once there and gives the collector back (docs/decisions/0073-garbage-collected-in-the-gui-thread.md).
"""

from __future__ import annotations

import gc

from PySide6.QtCore import QCoreApplication, QObject, QTimer

__all__ = ["acquire", "release", "CHECK_MS"]

CHECK_MS = 250  # how often the GUI thread looks at the collector's counts


class _Collector(QObject):
    def __init__(self, parent: QObject):
        super().__init__(parent)
        self.users = 0
        self.was_enabled = True
        self.timer = QTimer(self)
        self.timer.setInterval(CHECK_MS)
        self.timer.timeout.connect(self.check)

    def check(self) -> None:
        """Collect the youngest generation past its threshold and those below it (as Python would)."""
        t0, t1, t2 = gc.get_threshold()
        c0, c1, c2 = gc.get_count()
        if c0 > t0:
            gc.collect(2 if c2 > t2 else 1 if c1 > t1 else 0)


_collector: _Collector | None = None


def acquire() -> None:
    """A window opened: the automatic collector off (the first window), the GUI thread's timer on."""
    global _collector
    app = QCoreApplication.instance()
    if app is None:
        return
    if _collector is None or _collector.parent() is not app:
        _collector = _Collector(app)
    c = _collector
    c.users += 1
    if c.users == 1:
        c.was_enabled = gc.isenabled()
        gc.disable()
        c.timer.start()


def release() -> None:
    """A window closed: after the last one, one collection here and the automatic collector back."""
    c = _collector
    if c is None or c.users == 0:
        return
    c.users -= 1
    if c.users == 0:
        c.timer.stop()
        gc.collect()
        if c.was_enabled:
            gc.enable()
