"""Live-update frame rate of the app: the woven octant solved in the main window.

Measured by ``benchmarks/suite.py`` (case ``gui_live_fps``, in a child
process under an X display: Xvfb here, Mesa's software OpenGL). Opens the
main window (1600x1000) with the views' render widget the app chooses, runs
a solve exactly as the Run button does (after one run to warm up) and
measures:

* run_fps: new states handed to the views (the frame pump takes the newest
  at most every 30 ms) per second from pressing Run to the result: the live
  update rate a user sees; solve_fps: the same over the solve alone (after the drape);
* paint_ms: one view's paint (the render, and for the canvas reading its
  pixels back and drawing them), median;
* gap_ms: the longest event-loop gap (between ticks of a 10 ms timer), whole run;
* replay_fps: the frames of a recorded solve fed to the window as fast as
  the event loop takes them, with no solver competing for the CPU: the GUI's
  own ceiling on this machine.
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

from PySide6.QtCore import QTimer  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from flatweave.app.frames import FrameMaker  # noqa: E402
from flatweave.app.mainwindow import MainWindow  # noqa: E402
from flatweave.reading.examples import example_path, load_example  # noqa: E402
from flatweave.method.pipeline import flatten_iter  # noqa: E402
from flatweave.document.project import new_project  # noqa: E402


class Probe:
    """Counts repaints of both views and event-loop ticks."""

    def __init__(self, app, win):
        self.app, self.win = app, win
        self.ticks: list[float] = []
        self.paints = {"3d": [], "2d": []}
        for key, view in (("3d", win.view), ("2d", win.pattern_view)):
            widget = view.widget
            name = "paintGL" if hasattr(widget, "paintGL") else "paintEvent"  # pyvistaqt's widget or the canvas
            original = getattr(widget, name)

            def paint(*args, original=original, key=key):
                t = time.perf_counter()
                original(*args)
                self.paints[key].append((t, time.perf_counter() - t))
            setattr(widget, name, paint)
        self.timer = QTimer()
        self.timer.setInterval(10)
        self.timer.timeout.connect(lambda: self.ticks.append(time.perf_counter()))

    def reset(self):
        self.ticks.clear()
        for v in self.paints.values():
            v.clear()
        self.win.runner.frame_seconds.clear()
        self.win.runner.frames_shown = 0

    def wait(self, cond, timeout=600.0):
        t_end = time.perf_counter() + timeout
        while not cond():
            if time.perf_counter() > t_end:
                raise SystemExit("benchmark: timed out")
            self.app.processEvents()
            time.sleep(0.001)

    def summary(self, label, t0, t1, snapshots, frames, draw_s, nodes, springs):
        span = max(t1 - t0, 1e-9)
        inside = np.array([t for t in self.ticks if t0 <= t <= t1])
        gaps = np.diff(np.concatenate([[t0], inside, [t1]]))
        rep = {k: [d for (t, d) in v if t0 <= t <= t1] for k, v in self.paints.items()}
        paint = np.concatenate([np.array(v) for v in rep.values()]) if any(rep.values()) else np.zeros(1)
        return {"case": label, "nodes": nodes, "springs": springs, "seconds": span,
                "snapshots/s": snapshots / span, "frames/s": frames / span,
                "3D repaints/s": len(rep["3d"]) / span, "pattern repaints/s": len(rep["2d"]) / span,
                "draw ms": 1000 * float(np.median(draw_s)) if len(draw_s) else float("nan"),
                "paint ms": 1000 * float(np.median(paint)), "gap ms": 1000 * float(gaps.max())}


def live_run(probe, win, project, label):
    win.set_project(project)
    probe.wait(lambda: True, 0)
    for _ in range(50):
        probe.app.processEvents()
        time.sleep(0.01)
    probe.reset()
    first = {}
    done = {}

    solve_frames, drape_frames = [], []

    def on_frame(f):
        first.setdefault("t", time.perf_counter())
        (drape_frames if f.draping else solve_frames).append(time.perf_counter())
    win.runner.frame.connect(on_frame)
    win.run_finished.connect(lambda o: done.setdefault("o", (o, time.perf_counter())))
    win.run_failed.connect(lambda m: done.setdefault("o", (m, time.perf_counter())))
    probe.timer.start()
    t_start = time.perf_counter()
    win.run()
    probe.wait(lambda: "o" in done)
    probe.timer.stop()
    win.runner.frame.disconnect(on_frame)
    outcome, t1 = done["o"]
    if isinstance(outcome, str):
        raise SystemExit(f"benchmark: the run failed: {outcome}")
    r = outcome.result
    snapshots = len(win.runner.last_history)
    row = probe.summary(label, first.get("t", t_start), t1, snapshots, win.runner.frames_shown,
                        np.array(win.runner.frame_seconds), r.metrics["nodes"], r.metrics["springs"])
    # the gap over the whole run, drape included
    inside = np.array([t for t in probe.ticks if t_start <= t <= t1])
    row["gap ms"] = 1000 * float(np.diff(np.concatenate([[t_start], inside, [t1]])).max())
    row["iterations"] = r.metrics["iterations"]
    row["run s"] = t1 - t_start  # Run pressed to result, drape included
    row["run frames/s"] = win.runner.frames_shown / max(t1 - t_start, 1e-9)
    if solve_frames:
        row["drape s"] = solve_frames[0] - t_start
        row["solve s"] = t1 - solve_frames[0]
        row["solve frames/s"] = (len(solve_frames) - 1) / max(t1 - solve_frames[0], 1e-9)
        row["drape frames/s"] = len(drape_frames) / max(solve_frames[0] - t_start, 1e-9)
    return row


def replay(probe, win, project, label):
    """Frames of a recorded solve, drawn back to back through the window's own slot."""
    surface, settings = project.surface, project.settings
    maker = FrameMaker(surface, settings)
    frames = []
    gen = flatten_iter(surface, settings, area=maker.A3)
    k = 0
    while True:
        try:
            snap = next(gen)
        except StopIteration:
            break
        k += 1
        frames.append(maker.from_snapshot(snap, maker.pattern(snap.mesh, snap.uv, snap.xyz) if k % 4 == 1 else None))
    frames = (frames * (1 + 60 // max(len(frames), 1)))[:60]
    win.set_project(project)
    win.runner.thread = _FakeBusy()  # the window draws live frames while a run is on
    probe.reset()
    probe.timer.start()
    draw = []
    t0 = time.perf_counter()
    for f in frames:
        t = time.perf_counter()
        win.presenter.draw_frame(f)
        draw.append(time.perf_counter() - t)
        probe.app.processEvents()  # one pass: paints what the frame changed
    t1 = time.perf_counter()
    probe.timer.stop()
    win.runner.thread = None
    return probe.summary(label, t0, t1, 0, len(frames), np.array(draw), frames[-1].stats["nodes"],
                         frames[-1].stats["springs"])


class _FakeBusy:
    """Stands in for a running solve thread during the replay."""
    stopping = abandoned = False
    paused = pause_requested = False
    stop_point = None
    history = ()
    stage = "replay"


def measure(spacing: float) -> dict:
    """One live run (after one to warm up) and a replay, in this process's QApplication."""
    app = QApplication.instance() or QApplication(["gui_fps"])
    win = MainWindow()
    win.resize(1600, 1000)
    surface = load_example("octant")
    project = new_project(surface, "octant", str(example_path("octant")), spacing)
    win.set_project(project)
    win.show()
    probe = Probe(app, win)
    probe.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready(), 30)
    live_run(probe, win, project, "warm-up")
    row = live_run(probe, win, project, "fast solver")
    ceiling = replay(probe, win, project, "replay, no solver")
    win.close()
    return {"run_fps": row["run frames/s"], "solve_fps": row.get("solve frames/s", 0.0),
            "replay_fps": ceiling["frames/s"], "paint_ms": row["paint ms"], "gap_ms": row["gap ms"],
            "nodes": float(row["nodes"])}
