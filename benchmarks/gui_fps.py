"""Live-update frame rate of the app: the woven octant at about 2,500 nodes.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python benchmarks/gui_fps.py \
        [--spacing 0.025] [--view auto|gl|canvas] [--out benchmarks/results/gui_fps.md]

Opens the main window (1600x1000) with the views' render widget the app
chooses (or ``--view``'s, see app/canvas.py), runs solves exactly as the Run
button does and measures:

* run s: from pressing Run to the result, drape included; seconds: from the
  first frame on screen to the result (the span the rates below are over);
* drape s / solve s: Run to the first solver frame, and from there to the result;
* snapshots/s: solver iterations per second (what there is to show);
* run frames/s: new states handed to the views (the frame pump takes the
  newest at most every 30 ms) per second from pressing Run to the result: the
  live update rate a user sees; frames/s: the same from the first frame on;
  drape frames/s: frames of the drape (the mesh laid so far, at most every
  1/15 s, see app/worker.py) per second of drape; solve frames/s: over the
  solve alone;
* 3D and pattern repaints/s: renders of each view (both views repaint in
  one paint pass);
* draw ms: the window's Python work per frame (copying arrays into the views);
* paint ms: one view's paint (the render, and for the canvas reading its
  pixels back and drawing them), median;
* longest event-loop gap: between ticks of a 10 ms timer, whole run.

A "replay" row feeds the frames of a recorded solve to the window as fast as
the event loop takes them, with no solver competing for the CPU: the GUI's own
ceiling. Not a timed test: numbers depend on the machine (software OpenGL under
Xvfb here).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("QT_QPA_PLATFORM", "xcb")

from app.nonefix import keep_none_alive

keep_none_alive()  # before any Qt call

from PySide6.QtCore import QTimer  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from app.canvas import view_kind  # noqa: E402
from app.frames import FrameMaker  # noqa: E402
from app.mainwindow import MainWindow  # noqa: E402
from app.choices import VIEW_KINDS  # noqa: E402
from core.examples import example_path, load_example  # noqa: E402
from core.pipeline import flatten_iter  # noqa: E402
from core.project import new_project  # noqa: E402


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


WIDGETS = {"gl": "pyvistaqt's OpenGL widget (FLATWEAVE_VIEW=gl)",
           "canvas": "the raster canvas (FLATWEAVE_VIEW=canvas)"}


class _FakeBusy:
    """Stands in for a running solve thread during the replay."""
    stopping = False
    paused = pause_requested = False
    history = ()
    stage = "replay"


def markdown(rows) -> str:
    cols = ["case", "nodes", "springs", "iterations", "run s", "drape s", "solve s", "seconds", "snapshots/s",
            "run frames/s", "frames/s", "drape frames/s", "solve frames/s", "3D repaints/s", "pattern repaints/s",
            "draw ms", "paint ms", "gap ms"]
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, "")
            cells.append(f"{v:,}" if isinstance(v, int) else f"{v:.1f}" if isinstance(v, float) else str(v))
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spacing", type=float, default=0.025)
    ap.add_argument("--paper-iterations", type=int, default=60, help="iteration budget of the paper solver row")
    ap.add_argument("--repeat", type=int, default=3, help="fast-solver runs (one row each)")
    ap.add_argument("--view", choices=VIEW_KINDS, default=None,
                    help="the views' render widget (FLATWEAVE_VIEW; default: as the app chooses)")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results" / "gui_fps.md")
    args = ap.parse_args(argv)

    if args.view:
        os.environ["FLATWEAVE_VIEW"] = args.view
    app = QApplication.instance() or QApplication(["gui_fps"])
    kind = view_kind()
    win = MainWindow()
    win.resize(1600, 1000)
    surface = load_example("octant")
    project = new_project(surface, "octant", str(example_path("octant")), args.spacing)
    win.set_project(project)
    win.show()
    probe = Probe(app, win)
    probe.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready(), 30)

    rows = []
    for _ in range(args.repeat):
        rows.append(live_run(probe, win, project, "fast solver"))
        print(markdown(rows[-1:]), flush=True)
    rows.append(live_run(probe, win, project.with_settings(solver="paper", max_iter=args.paper_iterations),
                         f"paper solver ({args.paper_iterations} it.)"))
    rows.append(replay(probe, win, project, "replay, no solver"))
    print(markdown(rows[-2:]), flush=True)
    win.close()

    table = markdown(rows)
    stamp = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    load = os.getloadavg() if hasattr(os, "getloadavg") else ("?",)
    text = (f"# Live-update frame rate of the app\n\n"
            f"`python benchmarks/gui_fps.py --spacing {args.spacing:g}` under Xvfb (1600x1000 window), {stamp}, "
            f"{platform.python_implementation()} {platform.python_version()}, {os.cpu_count()} cores, "
            f"load average {load[0]:.2f} at the end, Mesa software OpenGL (llvmpipe), "
            f"views drawn by {WIDGETS[kind]}. "
            f"Woven octant, spacing {args.spacing:g}.\n\n{table}\n\n"
            "Columns: see the script's docstring. frames/s counts new states handed to the views; "
            "repaints/s counts renders of each view, which is what a user sees move. "
            "Live, the views keep up with the solver (repaints/s close to snapshots/s); "
            "the replay row is the ceiling of the GUI itself on this machine.\n")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print(f"\nwritten to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
