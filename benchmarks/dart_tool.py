"""How long the app takes to answer a curve dart drawn with the tool: the
woven octant in the main window.

Measured by ``benchmarks/suite.py`` (case ``window_dart``, in a child
process under an X display: Xvfb here, Mesa's software OpenGL). Opens the
main window (1600x1000), solves, then draws a three-click curve dart across
the octant with real mouse events on the 3D view and presses Enter, as a
designer does; the re-solve warm-starts from the solved mesh, with the
window's own settings (the solve thread at the app's lower OS priority).
It measures:

* click_ms: the GUI's work for one click (viewing ray onto the surface,
  biarc preview), the median of the three;
* first_frame_s: Enter until the re-solve hands its first live frame to the views;
* vee_s: Enter until the first frame whose pattern has the dart's legs (the
  V in the pattern view);
* result_s: Enter until the re-solve's result is in the document;
* frames_share: the solve thread's time in live patterns plus the GUI
  thread's time drawing frames (their slots and repaints, as the runner
  counts them), over Enter to result.

A result is waited for on ``run_finished`` (no timer of the benchmark's wakes
the GUI thread then but the 10 ms tick of ``wait``): a loop that polled the
event loop instead would keep the GUI thread busy, and its Python would hold
the GIL the solve thread needs.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("QT_QPA_PLATFORM", "xcb")

from flatweave.app.nonefix import keep_none_alive

keep_none_alive()  # before any Qt call

from PySide6.QtCore import QEventLoop, QPoint, Qt, QTimer  # noqa: E402
from PySide6.QtTest import QTest  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from flatweave.app.mainwindow import MainWindow  # noqa: E402
from flatweave.reading.examples import example_path, load_example  # noqa: E402
from flatweave.document.project import new_project  # noqa: E402

CAMERA = ((2.4, 1.3, 1.5), (0.45, 0.45, 0.4), (0.0, 0.0, 1.0))
TARGETS = np.array([[0.93, 0.3, 0.2], [0.62, 0.58, 0.53], [0.3, 0.85, 0.45]])
TARGETS /= np.linalg.norm(TARGETS, axis=1, keepdims=True)


def wait(app, condition, timeout=600.0, signal=None):
    """Run the event loop until ``condition()``, sleeping between events as the
    window's own loop does: with ``signal``, only that signal wakes it to check;
    otherwise a 10 ms timer does."""
    t0 = time.perf_counter()
    if signal is not None:
        loop = QEventLoop()
        check = lambda *_a: loop.quit() if condition() else None  # noqa: E731
        signal.connect(check)
        give_up = QTimer(singleShot=True, interval=int(1000 * timeout))
        give_up.timeout.connect(loop.quit)
        give_up.start()
        try:
            while not condition():
                loop.exec()
                if not condition() and time.perf_counter() - t0 > timeout:
                    raise TimeoutError("gave up waiting")
        finally:
            give_up.stop()
            signal.disconnect(check)
        return
    waker = QTimer(interval=10)
    waker.start()
    try:
        while not condition():
            app.processEvents(QEventLoop.ProcessEventsFlag.WaitForMoreEvents)
            if time.perf_counter() - t0 > timeout:
                raise TimeoutError("gave up waiting")
    finally:
        waker.stop()


def qt_point(widget, xy):
    return QPoint(int(round(xy[0])), widget.height() - 1 - int(round(xy[1])))


def measure(spacing: float) -> dict:
    """Solve, draw the dart and press Enter once (after one such edit undone, to warm up)."""
    app = QApplication.instance() or QApplication([])
    win = MainWindow()
    win.resize(1600, 1000)
    surface = load_example("octant")
    win.set_project(new_project(surface, "octant", str(example_path("octant")), spacing))
    win.show()
    wait(app, lambda: win.view.is_ready() and win.pattern_view.is_ready())
    done = []
    win.run_finished.connect(lambda outcome: done.append(outcome))
    win.run()
    wait(app, lambda: done, signal=win.run_finished)
    base = win.project
    win.view.look(*CAMERA)
    win.view.render_now()
    win.activateWindow()
    wait(app, win.isActiveWindow, 10)
    widget = win.view.widget
    seen = []  # (time, frame) of every frame drawn
    win.runner.frame.connect(lambda f: seen.append((time.perf_counter(), f)))
    for attempt in range(2):  # the first warms up (and is undone)
        win.actions["tool_curve_dart"].setChecked(True)
        clicks = []
        for t in TARGETS:
            x, y = win.view.display_point(t)
            t0 = time.perf_counter()
            QTest.mouseClick(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier,
                             qt_point(widget, (x, y)))
            clicks.append(time.perf_counter() - t0)
        drawn0 = len(win.runner.frame_seconds)
        done.clear()
        seen.clear()
        t0 = time.perf_counter()
        QTest.keyClick(widget, Qt.Key.Key_Return)
        wait(app, lambda: done, signal=win.run_finished)
        total = time.perf_counter() - t0
        live = [t for t, f in seen if not f.final]
        vee = [t for t, f in seen if f.pattern is not None and len(f.pattern.darts)]
        r = win.project.result
        if not (len(win.project.settings.darts) == 1 and win.project.result_is_current):
            raise RuntimeError("the dart's re-solve did not end in a current result")
        gui = float(np.sum(win.runner.frame_seconds[drawn0:]))
        # a re-solve too short for a live frame shows the result first
        first = live[0] if live else seen[0][0] if seen else t0 + total
        out = {"result_s": total, "first_frame_s": first - t0, "vee_s": (vee[0] if vee else t0 + total) - t0,
               "frames_share": (gui + win.runner.last_pattern_seconds) / total,
               "click_ms": 1000 * float(np.median(clicks)), "nodes": float(r.mesh.n_nodes)}
        win.actions["tool_curve_dart"].setChecked(False)
        if attempt == 0:
            win.document.undo()
            if win.project.result is not base.result:
                raise RuntimeError("undo did not restore the solved result")
    win.close()
    return out
