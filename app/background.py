"""One core call off the GUI thread, its outcome back on it: the dialogs over
core helpers (Tools > Suggest darts, Solve > Best orientation) share this.

The call runs in a plain daemon ``threading.Thread`` (core code, no Qt in it);
``done(value, error)`` is emitted from that thread and, connected queued,
reaches the dialog on the GUI thread: the value and None, or None and one line
(:func:`flatweave.app.worker.one_line`; an unexpected exception is also printed, since
it is a bug). A fault never leaves the thread, so it never takes the window down.
"""

from __future__ import annotations

import sys
import threading
import traceback
from collections.abc import Callable

from PySide6.QtCore import QObject, Qt, Signal

from flatweave.app.worker import one_line
from flatweave.errors import FlatweaveError

__all__ = ["BackgroundCall"]


class BackgroundCall(QObject):
    """``start(fn, name)`` runs ``fn()``; ``done(value, error)`` on the GUI thread."""

    done = Signal(object, object)

    def __init__(self, slot: Callable[[object, object], None], parent: QObject | None = None):
        super().__init__(parent)
        self.done.connect(slot, Qt.ConnectionType.QueuedConnection)
        self.thread: threading.Thread | None = None

    @property
    def busy(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    def start(self, fn: Callable[[], object], name: str) -> None:
        def work():
            try:
                value = fn()
            except Exception as exc:  # every failure reaches the dialog as one line
                if not isinstance(exc, FlatweaveError):
                    traceback.print_exc(file=sys.stderr)
                    self.done.emit(None, f"internal error: {one_line(exc)}")
                else:
                    self.done.emit(None, one_line(exc))
            else:
                self.done.emit(value, None)

        self.thread = threading.Thread(target=work, name=name, daemon=True)
        self.thread.start()
