"""How long the app takes to answer a curve dart drawn with the tool: the woven
octant at about 2,500 nodes.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python benchmarks/dart_tool.py \
        [--spacing 0.025] [--repeat 3] [--out benchmarks/results/dart_tool.md]

Opens the main window (1600x1000), solves, then draws a three-click curve dart
across the octant with real mouse events on the 3D view and presses Enter, as a
designer does, and measures:

* click ms: the GUI's work for one click (viewing ray onto the surface, biarc
  preview; the median of the clicks);
* Enter to first frame: until the warm-started re-solve hands its first live
  frame to the views;
* Enter to result: until the re-solve's result is in the document;
* iterations, frames shown, longest event-loop gap (10 ms timer) during the re-solve.

* Enter to the first pattern with the dart's opening (the V in the pattern view);
* the share of the run in live frames: the solve thread's live patterns plus
  the GUI's time drawing frames (their slots and repaints, as the runner counts
  them), over Enter to result.

Each repeat undoes the dart first (undo restores the earlier result without a
solve), so every row answers the same edit. The window's behaviour is set per
row (variants, run alternately, medians at the end): "after" is the window as it
is (``DEFAULTS``: the app's own settings), with the solve thread at the app's
lower OS priority (``app.worker.SOLVE_NICENESS``, "nice 5") or at normal
priority; "no live frames" makes and draws no live frame and no live pattern,
only the result (what the frames cost: the line under the medians gives 1 - the
median without them / the median with them, the README's row); "live frames
in both views" draws a live frame without a pattern in the pattern view too
(``app.presenter.KEEP_PATTERN_FOR_LIVE_FRAMES`` off), and "no live frames, pump
on" keeps the runner's 30 ms pump running with nothing to draw. "before" is
session 6's settings on today's code (edits re-run after a 250 ms delay, live
patterns up to a seventh of the run, every frame drawn); to compare with an
older window, run that tree's own copy of this script. A result is waited for
on ``run_finished`` (no timer of the benchmark's wakes the GUI thread then but
the 10 ms tick that measures its gaps). Then a drag of the dart's middle point
across four positions: from each move to the first frame of that position's
preview, and from the release to the result in the document. Not a test:
numbers depend on the machine (software OpenGL under Xvfb here) and its load
(reported).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
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

from PySide6.QtCore import QEventLoop, QPoint, Qt, QTimer  # noqa: E402
from PySide6.QtTest import QTest  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from app import presenter, runcontrol, runner, worker as solve_worker  # noqa: E402
from app.mainwindow import MainWindow  # noqa: E402
from core.examples import example_path, load_example  # noqa: E402
from core.project import new_project  # noqa: E402

CAMERA = ((2.4, 1.3, 1.5), (0.45, 0.45, 0.4), (0.0, 0.0, 1.0))
TARGETS = np.array([[0.93, 0.3, 0.2], [0.62, 0.58, 0.53], [0.3, 0.85, 0.45]])
TARGETS /= np.linalg.norm(TARGETS, axis=1, keepdims=True)


POLL = False  # --poll: session 6's polling wait (to measure what it cost)


def wait(app, condition, timeout=600.0, signal=None):
    """Run the event loop until ``condition()``. It sleeps between events as the window's
    own loop does (a 10 ms timer wakes it to check; with ``signal``, only that signal
    does, as nothing of the benchmark's then runs Python on the GUI thread but its tick
    timer): a loop that polls instead keeps the GUI thread busy, and its Python holds the
    GIL the solve thread needs (session 6's version did, and its times were up to twice
    the window's)."""
    t0 = time.perf_counter()
    if signal is not None and not POLL:
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
    if POLL:
        while not condition():
            app.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 10)
            if time.perf_counter() - t0 > timeout:
                raise TimeoutError("gave up waiting")
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


DEFAULTS = {"rerun_at_once": runcontrol.RERUN_AT_ONCE, "first_pattern": solve_worker.FIRST_PATTERN_AT_ONCE,
            "first_frame_pattern": solve_worker.FIRST_FRAME_WITH_PATTERN,
            "pattern_share": solve_worker.PATTERN_SHARE, "frame_share": runner.FRAME_SHARE,
            "keep_pattern": presenter.KEEP_PATTERN_FOR_LIVE_FRAMES}
"""The app's own settings: the "after" variants run the window as it is."""
VARIANTS = {
    # name: what differs from the app's settings (DEFAULTS), the solve thread's nice value and live frames
    "before (nice 5)": {"rerun_at_once": False, "first_pattern": False, "first_frame_pattern": False,
                        "pattern_share": 1 / 7, "frame_share": None},
    "after (nice 5)": {},
    "after (normal priority)": {"nice": False},
    "after (no live frames)": {"live": False},
    "after (live frames in both views)": {"keep_pattern": False},
    "after (the V at once)": {"first_pattern": True, "keep_pattern": False},
    "after (first frame without its pattern)": {"first_frame_pattern": False},
    "after (no live frames, pump on)": {"live": False, "pump": True},
    "after (normal priority, no live frames)": {"nice": False, "live": False},
}


def set_variant(win, name, lower_priority):
    v = {**DEFAULTS, "nice": True, "live": True, "pump": None, **VARIANTS[name]}
    live = v["live"]
    runcontrol.RERUN_AT_ONCE = v["rerun_at_once"]
    runner.FRAME_SHARE = v["frame_share"]
    solve_worker.FIRST_PATTERN_AT_ONCE = v["first_pattern"] and live
    solve_worker.FIRST_FRAME_WITH_PATTERN = v["first_frame_pattern"] and live
    solve_worker.PATTERN_SHARE = v["pattern_share"]
    presenter.KEEP_PATTERN_FOR_LIVE_FRAMES = v["keep_pattern"]
    solve_worker.PATTERN_INTERVAL = 0.25 if live else 1e9
    global LIVE
    LIVE = live
    solve_worker._lower_priority = lower_priority if v["nice"] else (lambda *a: None)
    pump = live if v["pump"] is None else v["pump"]
    win.runner._timer.setInterval(30 if pump else 10 ** 8)  # the pump (the final frame is drawn at the end)


LIVE = True


def no_frames_wanted(win):
    """Without live frames the solve thread is told no frame is wanted (the pump that would say so is off)."""
    t = win.runner.thread
    if not LIVE and t is not None and hasattr(t, "frames_from"):
        t.frames_from = math.inf
        if hasattr(t, "first_live"):  # nor is the first live frame taken when it is made
            t.first_live.disconnect()


def qt_point(widget, xy):
    return QPoint(int(round(xy[0])), widget.height() - 1 - int(round(xy[1])))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--spacing", type=float, default=0.025)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--variants", default=";".join(VARIANTS),
                    help="names from VARIANTS, separated by commas (or by semicolons when a name has a comma)")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--poll", action="store_true", help="wait by polling the event loop (session 6's benchmark)")
    ap.add_argument("--no-drag", action="store_true")
    args = ap.parse_args()
    global POLL
    POLL = args.poll
    variants = [v.strip() for v in args.variants.split(";" if ";" in args.variants else ",") if v.strip()]

    app = QApplication.instance() or QApplication([])
    win = MainWindow()
    win.resize(1600, 1000)
    surface = load_example("octant")
    win.set_project(new_project(surface, "octant", str(example_path("octant")), args.spacing))
    win.show()
    wait(app, lambda: win.view.is_ready() and win.pattern_view.is_ready())
    done = []
    win.run_finished.connect(lambda outcome: done.append(outcome))
    win.runner.started.connect(lambda _p: no_frames_wanted(win))
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
    rows = []
    lower_priority = solve_worker._lower_priority
    for _ in range(args.repeat):
        for name in variants:
            set_variant(win, name, lower_priority)
            win.actions["tool_curve_dart"].setChecked(True)
            clicks = []
            for t in TARGETS:
                x, y = win.view.display_point(t)
                t0 = time.perf_counter()
                QTest.mouseClick(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier,
                                 qt_point(widget, (x, y)))
                clicks.append(time.perf_counter() - t0)
            ticks = []
            timer = QTimer(interval=10)
            timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
            shown0, drawn0 = win.runner.frames_shown, len(win.runner.frame_seconds)
            done.clear()
            seen.clear()
            timer.start()
            t0, c0 = time.perf_counter(), time.process_time()
            QTest.keyClick(widget, Qt.Key.Key_Return)
            wait(app, lambda: done, signal=win.run_finished)
            total, cpu = time.perf_counter() - t0, time.process_time() - c0
            timer.stop()
            live = [(t, f) for t, f in seen if not f.final]
            vee = [t for t, f in seen if f.pattern is not None and len(f.pattern.darts)]
            r = win.project.result
            assert len(win.project.settings.darts) == 1 and win.project.result_is_current
            gaps = np.diff(ticks) if len(ticks) > 1 else np.zeros(1)
            gui = float(np.sum(win.runner.frame_seconds[drawn0:]))
            rows.append({"variant": name, "load": os.getloadavg()[0], "nodes": r.mesh.n_nodes,
                         "click_ms": 1000 * float(np.median(clicks)),
                         "first_s": live[0][0] - t0 if live else math.nan,
                         "vee_s": vee[0] - t0 if vee else math.nan, "total_s": total, "cpu_s": cpu,
                         "iterations": r.metrics["iterations"], "frames": win.runner.frames_shown - shown0,
                         "frame_share": (gui + win.runner.last_pattern_seconds) / total,
                         "gap_ms": 1000 * float(gaps.max()),
                         "energy": (base.result.metrics["energy"], r.metrics["energy"])})
            print(rows[-1], flush=True)
            win.actions["tool_curve_dart"].setChecked(False)
            win.document.undo()
            assert win.project.result is base.result
    drags = None if args.no_drag else drag_rows(app, win, done, seen, lower_priority, args.repeat)
    win.close()

    lines = [
        "# Drawing a curve dart in the app: time to the re-solved pattern",
        "",
        f"`benchmarks/dart_tool.py --spacing {args.spacing:g} --repeat {args.repeat}"
        f"{' --poll' if args.poll else ''}`, "
        f"{_dt.date.today().isoformat()}, "
        f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        "Xvfb with Mesa software OpenGL, window 1600x1000. The woven octant, solved, then a "
        "three-click curve dart across it and Enter; the re-solve warm-starts from the solved mesh. "
        "Variants alternate, one row each per repeat.",
        "",
        "| variant | load | nodes | click (ms) | Enter to first live frame (s) | Enter to the V (s) | "
        "Enter to result (s) | CPU (s) | iterations | frames shown | live frames' share | "
        "longest event-loop gap (ms) | energy before -> after |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for row in rows:
        lines.append(f"| {row['variant']} | {row['load']:.1f} | {row['nodes']:,} | "
                     f"{row['click_ms']:.0f} | {row['first_s']:.2f} | {row['vee_s']:.2f} | {row['total_s']:.2f} | "
                     f"{row['cpu_s']:.2f} | "
                     f"{row['iterations']} | {row['frames']} | {100 * row['frame_share']:.0f} % | "
                     f"{row['gap_ms']:.0f} | {row['energy'][0]:.4g} -> {row['energy'][1]:.4g} |")
    lines += ["", "Medians:", "",
              "| variant | Enter to first live frame (s) | Enter to the V (s) | Enter to result (s) | CPU (s) | "
              "live frames' share | longest gap (ms) |", "|---|---:|---:|---:|---:|---:|---:|"]
    for name in variants:
        sel = [r for r in rows if r["variant"] == name]
        med = lambda k: float(np.nanmedian([r[k] for r in sel]))  # noqa: E731
        lines.append(f"| {name} | {med('first_s'):.2f} | {med('vee_s'):.2f} | {med('total_s'):.3f} | "
                     f"{med('cpu_s'):.3f} | "
                     f"{100 * med('frame_share'):.0f} % | {med('gap_ms'):.0f} |")
    totals = {name: float(np.median([r["total_s"] for r in rows if r["variant"] == name])) for name in variants}
    cpus = {name: float(np.median([r["cpu_s"] for r in rows if r["variant"] == name])) for name in variants}
    if "after (nice 5)" in totals and "after (no live frames)" in totals:
        cost = 1 - totals["after (no live frames)"] / totals["after (nice 5)"]
        cpu_cost = 1 - cpus["after (no live frames)"] / cpus["after (nice 5)"]
        lines += ["", f"Live frames' cost: {100 * cost:.1f} % of Enter to result (1 - the median without live "
                  f"frames / the median with them); in the process's CPU time, {100 * cpu_cost:.1f} %."]
    if drags:
        lines += ["", "Dragging the dart's middle point (the \"after (nice 5)\" window), four positions a drag, "
                  f"{args.repeat} drags:", "",
                  "| move to that position's first frame (s, median) | (max) | release to result (s, median) | "
                  "(max) | previews started a drag |", "|---:|---:|---:|---:|---:|",
                  f"| {np.median(drags['move']):.2f} | {np.max(drags['move']):.2f} | "
                  f"{np.median(drags['release']):.2f} | {np.max(drags['release']):.2f} | "
                  f"{np.median(drags['previews']):.0f} |"]
    lines += ["", "Load: the one-minute load average when the re-solve ended (this benchmark included; the "
              "rest is other work on the shared machine). The V: the first frame whose pattern has the dart's "
              "legs. Live frames' share: the solve thread's time in live patterns plus the GUI thread's time "
              "drawing frames (the result's own frame included, the only one in the \"no live frames\" rows), over "
              "Enter to result. CPU: the process's CPU time from Enter to the result, every thread (the GUI's, the "
              "solve's, the software renderer's); steadier than the wall times on a shared machine. "
              "The same re-solve in core alone: benchmarks/results/curve_dart.md "
              "(`benchmarks/curve_dart.py`)."]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


def drag_rows(app, win, done, seen, lower_priority, repeat) -> dict:
    """Drag the middle point of the dart (drawn once) through four positions, waiting at each
    for its preview's first frame; then release and wait for the result."""
    set_variant(win, "after (nice 5)", lower_priority)
    widget = win.view.widget
    win.actions["tool_curve_dart"].setChecked(True)
    for t in TARGETS:
        QTest.mouseClick(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier,
                         qt_point(widget, win.view.display_point(t)))
    done.clear()
    QTest.keyClick(widget, Qt.Key.Key_Return)
    wait(app, lambda: done, signal=win.run_finished)
    win.actions["tool_curve_dart"].setChecked(False)
    win.dart_panel.dart_list.setCurrentRow(0)
    wait(app, lambda: win.tool is not None, 10)
    s = win.surface
    out = {"move": [], "release": [], "previews": []}
    spots = [np.array(p) / np.linalg.norm(p) for p in ([0.55, 0.5, 0.67], [0.72, 0.42, 0.55],
                                                       [0.5, 0.62, 0.6], [0.6, 0.52, 0.6], [0.66, 0.47, 0.58])]
    for k in range(repeat):
        # four of the five spots, never the one the drag starts from (where the last drag ended): a position
        # back at the document's dart re-solves in 0 iterations (no frame with iteration >= 1 comes), and a
        # release there is no edit (no result comes); session 8's second drag waited for those
        path = [spots[(4 * k + j) % len(spots)] for j in range(4)]
        dart = win.project.settings.darts[0]
        here = win.view.display_point(s.points(dart.handles[1:2])[0])
        previews = win.runs.previews_started
        QTest.mousePress(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, qt_point(widget, here))
        for p in path:
            there = win.view.display_point(p)
            seen.clear()
            t0 = time.perf_counter()
            for f in (0.25, 0.5, 0.75, 1.0):
                QTest.mouseMove(widget, qt_point(widget, here + f * (np.asarray(there) - here)))
                app.processEvents()
            here = np.asarray(there)
            wait(app, lambda: any(not f.draping and f.iteration >= 1
                                  and np.min(np.linalg.norm(f.dart_curves[0] - p, axis=1)) < 0.01 for _, f in seen),
                 60)
            out["move"].append(time.perf_counter() - t0)
        done.clear()
        t0 = time.perf_counter()
        QTest.mouseRelease(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, qt_point(widget, here))
        wait(app, lambda: done, 120, signal=win.run_finished)
        out["release"].append(time.perf_counter() - t0)
        out["previews"].append(win.runs.previews_started - previews)
        print("drag", out, win.runs.previews_adopted, win.runner.runs_started, flush=True)
        wait(app, lambda: win.tool is not None, 10)
    return out


if __name__ == "__main__":
    sys.exit(main())
