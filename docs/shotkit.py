"""What the screenshot scripts in docs/ share: a Qt application on the X display
(xvfb-run), a wait that keeps the event loop turning, and a window that has
solved a bundled example. Imported by those scripts only (they put the
repository on ``sys.path`` first)."""

from __future__ import annotations

import os
import time
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "xcb")

from flatweave.app.nonefix import keep_none_alive

keep_none_alive()  # before any Qt call

from PySide6.QtCore import QEventLoop, QTimer  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

__all__ = ["Shot"]


class Shot:
    """The application, its event loop and ``wait``; ``solved_window`` opens one."""

    def __init__(self):
        self.app = QApplication.instance() or QApplication([])
        self.loop = QEventLoop()

    def wait(self, cond, timeout: float = 600.0) -> None:
        """Turn the event loop until ``cond()``. It blocks between events (a 20 ms timer wakes it to
        look again): a loop polling without waiting keeps a core busy, which halves a solve's speed
        on two cores (PARDISO factorises on both)."""
        t0 = time.perf_counter()
        tick = QTimer()
        tick.start(20)
        try:
            while not cond():
                self.loop.processEvents(QEventLoop.ProcessEventsFlag.WaitForMoreEvents)
                if time.perf_counter() - t0 > timeout:
                    raise TimeoutError("gave up waiting")
        finally:
            tick.stop()

    @staticmethod
    def save(pixmap, path) -> Path:
        """Write a grabbed ``pixmap`` to ``path`` (its folder made if missing): the path, or OSError
        (Qt's save only says False, which a script printing "wrote" would not notice)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if not pixmap.save(str(path)):
            raise OSError(f"cannot write {path}")
        return path

    def settle(self, seconds: float) -> None:
        t0 = time.perf_counter()
        self.wait(lambda: time.perf_counter() - t0 >= seconds)

    def window(self, path, size=(1600, 1000)):
        """A shown main window on the file ``path`` (a project, a job, a surface), not solved."""
        from flatweave.app.mainwindow import MainWindow

        win = MainWindow()
        win.resize(*size)
        win.move(0, 0)
        shown = []
        win.show_error = shown.append
        if not win.open_file(path) or shown:
            raise RuntimeError(f"{path} did not open: {shown}")
        win.show()
        self.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
        return win

    def picker_window(self, path, size=(1600, 1000)):
        """A shown main window that has opened the mesh ``path`` by File > Open's code path: (the
        window, its face picker, drawn)."""
        from flatweave.app.mainwindow import MainWindow

        win = MainWindow()
        win.resize(*size)
        win.move(0, 0)
        win.show()
        win.files.open_file(path)
        picker = win.files.face_picker
        self.wait(picker.view.is_ready)
        return win, picker

    def solved_window(self, example: str, spacing: float, size=(1600, 1000)):
        """A shown main window on ``example`` at ``spacing``, solved from the drape."""
        from flatweave.app.mainwindow import MainWindow
        from flatweave.reading.examples import example_path, load_example
        from flatweave.document.project import new_project

        win = MainWindow()
        win.resize(*size)
        win.move(0, 0)
        win.set_project(new_project(load_example(example), example, str(example_path(example)), spacing))
        win.show()
        self.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
        self.solve(win)
        return win

    def solve(self, win) -> None:
        """Run the window's solve and wait for its end."""
        done = []
        win.run_finished.connect(done.append)
        win.run()
        self.wait(lambda: done)

    def close_units_dialog(self, win) -> None:
        """Close the units-and-fit dialog a mesh opens with (its guess of the units taken)."""
        for w in self.app.topLevelWidgets():
            if w is not win and w.isVisible() and w.windowTitle().startswith("flatweave: units"):
                w.close()
