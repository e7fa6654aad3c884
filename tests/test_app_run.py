"""GUI tests of solving in the window: Run, Stop, Pause, live updates, errors,
projects and settings edits. Small meshes (spacing 0.08-0.1 on the octant).

What the window shows is compared with what the core computes for the same
settings (flatweave.method.pipeline.flatten), and colours are read back through the VTK
colour functions the views use.
"""

from __future__ import annotations

import re
import time

import numpy as np
import pytest
from PySide6.QtCore import QTimer

from flatweave.app import runner as runner_module
from flatweave.app.colours import ramp, strain_range, strain_stops
from flatweave.app.view2d import nice_length
from flatweave.app.viewbase import SCALE_TITLES, THREAD
import flatweave.method.solver
from flatweave.method.drape import drape
from flatweave.reading.examples import example_path, load_example
from flatweave.method.metrics import spring_strain
from flatweave.method.pipeline import flatten
from flatweave.document.project import new_project, project_problems, project_to_dict
from tests.solver_gate import HeldSolver

RUN_TIMEOUT_MS = 60000


def small_project(spacing=0.1, **settings):
    surface = load_example("octant")
    p = new_project(surface, "octant", str(example_path("octant")), spacing)
    return p.with_settings(**settings) if settings else p


def run_to_end(qtbot, win, start=None, timeout=RUN_TIMEOUT_MS):
    """Start a run (win.run unless ``start`` is given) and wait for its outcome."""
    with qtbot.waitSignal(win.run_finished, timeout=timeout) as blocker:
        (start or win.run)()
    return blocker.args[0]


def pause_and_stop(qtbot, win):
    """Pause the run in flight, then stop it, and wait for its end."""
    win.actions["pause"].trigger()
    with qtbot.waitSignal(win.run_finished, timeout=10000):
        win.stop()


def shown_rgb(view):
    """(spring indices, rgb uint8) as a view colours them now."""
    return view.layer.spring_colours()


def expected_rgb(strain, kind):
    """Colours the paper's scheme gives these strains, on a scale per group of
    spring kinds (threads: weft and warp; diagonals): uint8 (m, 3)."""
    pct = 100 * np.asarray(strain)
    out = np.zeros((len(pct), 3), dtype=int)
    for group in (np.asarray(kind) != 2, np.asarray(kind) == 2):
        lo, hi = strain_range(pct[group])
        out[group] = np.rint(255 * ramp(pct[group], strain_stops(lo, hi))).astype(int)
    return out


# ---------------------------------------------------------------------- run
@pytest.mark.slow
def test_run_converges_and_matches_the_core(each_widget, make_window, qtbot, monkeypatch):
    # about 630 nodes. The solve is held after its first iteration until its live frame is on screen
    # (tests.solver_gate): a fast solve of a small piece can end within one pump of the runner, leaving
    # a single frame to show, and "live updates happened" would hang on the machine's speed
    gate = HeldSolver(monkeypatch, "fast", after=1, mode="block")
    win = make_window(small_project(0.05))
    live = []
    win.runner.frame.connect(lambda f: live.append(f) if not (f.final or f.draping) else None)

    def start():
        win.run()
        try:
            qtbot.waitUntil(lambda: bool(live), timeout=RUN_TIMEOUT_MS)  # a live frame of the solve is drawn
            assert win.runner.busy and win.view.layer.frame is live[0]  # while the run is still in flight
        finally:
            gate.release.set()

    outcome = run_to_end(qtbot, win, start=start)
    assert not outcome.stopped
    project = win.project
    r = project.result
    assert r is outcome.result and project.result_is_current and project_problems(project) == []
    assert r.metrics["solver_status"] == "converged"

    expected = flatten(project.surface, project.settings)  # the same path, outside the GUI
    assert r.mesh.n_nodes == expected.mesh.n_nodes and r.mesh.n_springs == expected.mesh.n_springs
    np.testing.assert_allclose(r.xyz, expected.xyz, atol=1e-12)

    # spring colours, 3D and pattern: the paper's red-green-blue of the core's strains
    idx, rgb = shown_rgb(win.view)
    np.testing.assert_array_equal(idx, np.arange(expected.mesh.n_springs))
    want = expected_rgb(spring_strain(expected.xyz, expected.mesh), expected.mesh.kind)
    assert np.abs(rgb.astype(int) - want).max() <= 1
    strain = spring_strain(expected.xyz, expected.mesh)
    for group in (expected.mesh.kind != 2, expected.mesh.kind == 2):  # threads, diagonals: a scale each
        springs = np.flatnonzero(group)
        assert tuple(rgb[springs[np.argmax(strain[springs])]]) == (255, 0, 0)  # highest tensile: pure red
        assert tuple(rgb[springs[np.argmin(strain[springs])]]) == (0, 0, 255)  # highest compressive: pure blue
    idx2, rgb2 = shown_rgb(win.pattern_view)
    np.testing.assert_array_equal(idx2, idx)
    np.testing.assert_array_equal(rgb2, rgb)
    assert win.view.colour_bar_title == SCALE_TITLES[THREAD]
    lo, hi = win.view.colour_bar_range
    thread = expected.mesh.kind != 2
    assert lo == pytest.approx(100 * strain[thread].min()) and hi == pytest.approx(100 * strain[thread].max())

    # the pattern view: the relaxed lattice and the core's outline
    pts = np.asarray(win.pattern_view.layer.springs[0].points)[:, :2]
    np.testing.assert_allclose(pts, expected.pattern.xy, atol=1e-12)
    outline = np.asarray(win.pattern_view.outline.points)[:, :2]
    np.testing.assert_allclose(outline, expected.pattern.outline, atol=1e-9)
    # headline metrics beside it
    assert win.metrics.text("boundary").startswith(f"{expected.metrics['boundary_error_pct']:.3f}")
    assert win.metrics.text("area").startswith(f"{expected.metrics['area_error_pct']:.3f}")
    assert win.metrics.text("status") == "converged"
    # live updates happened (the solve's live frame, then the result's), and the result is one undo step
    assert win.runner.frames_shown >= 2 and live and win.frame.final
    assert win.document.undo_label == "Solve"
    assert win.actions["run"].isEnabled() and not win.actions["stop"].isEnabled()


@pytest.mark.slow
def test_stop_mid_run_leaves_a_consistent_state(make_window, qtbot, monkeypatch):
    # the paper's CG, held inside its 21st iteration (tests.solver_gate) until the Stop is answered: the
    # answer cannot have waited for the solve (nor for its iteration), whatever the machine's speed
    gate = HeldSolver(monkeypatch, "paper", after=20, mode="block")
    win = make_window(small_project(0.08, solver="paper", max_iter=100000))
    try:
        win.run()
        qtbot.waitUntil(gate.held.is_set, timeout=RUN_TIMEOUT_MS)
        assert len(win.runner.history) == 20
        last = win.runner.history[-1][0]
        assert win.actions["stop"].isEnabled() and not win.actions["run"].isEnabled()
        with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
            t0 = time.perf_counter()
            win.stop()
        latency = time.perf_counter() - t0
        print(f"\nstop took {1000 * latency:.0f} ms")
        assert not gate.release.is_set() and win.runner.thread.isRunning()  # answered while the solve was held
    finally:
        gate.release.set()
    outcome = blocker.args[0]
    assert outcome.stopped
    project = win.project
    r = project.result
    assert r is outcome.result and project_problems(project) == []
    n_iter = r.metrics["iterations"]
    assert 20 <= n_iter < 100000 and n_iter == last  # the last iterate before the Stop
    assert r.metrics["solver_status"] == f"stopped by the user at iteration {n_iter}"
    # the views show exactly the stopped state
    idx, rgb = shown_rgb(win.view)
    assert len(idx) == r.mesh.n_springs
    assert np.abs(rgb.astype(int) - expected_rgb(spring_strain(r.xyz, r.mesh), r.mesh.kind)).max() <= 1
    assert len(win.pattern_view.layer.springs[0].points) == r.mesh.n_nodes
    np.testing.assert_allclose(np.asarray(win.pattern_view.outline.points)[:, :2], r.pattern.outline)
    assert win.runner.state == "idle" and win.actions["run"].isEnabled()
    assert not win.actions["stop"].isEnabled() and not win.actions["pause"].isEnabled()
    # and it can run again
    win.document.edit_settings("Solver", solver="fast")
    outcome = run_to_end(qtbot, win, start=win.run)
    assert not outcome.stopped and win.project.result.metrics["solver_status"] == "converged"


@pytest.mark.slow
def test_pause_and_resume(make_window, qtbot, monkeypatch):
    # the paper's CG, held after 5 iterations (tests.solver_gate): it goes on making snapshots, one
    # every 10 ms or so, and never ends on its own, so Pause and Resume act on a run in flight
    gate = HeldSolver(monkeypatch, "paper", after=5, mode="repeat")
    win = make_window(small_project(0.08, solver="paper", max_iter=100000))
    try:
        win.run()
        qtbot.waitUntil(lambda: len(win.runner.history) >= 5, timeout=RUN_TIMEOUT_MS)
        win.actions["pause"].trigger()
        assert win.runner.state == "paused" and win.actions["pause"].text() == "&Resume"
        # the iteration in progress finishes, then the thread waits
        qtbot.waitUntil(lambda: win.runner.thread.paused, timeout=RUN_TIMEOUT_MS)
        n, made = len(win.runner.history), gate.snapshots
        qtbot.wait(400)
        assert len(win.runner.history) == n and gate.snapshots == made, "iterations went on while paused"
        win.actions["pause"].trigger()
        qtbot.waitUntil(lambda: len(win.runner.history) > n + 3, timeout=RUN_TIMEOUT_MS)
        assert win.runner.state == "running" and win.actions["pause"].text() == "&Pause"
        with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
            win.stop()
    finally:
        gate.release.set()


@pytest.mark.slow
def test_a_paused_run_shows_its_newest_iteration(make_window, qtbot, monkeypatch):
    """Live frames are made only when the GUI takes them, so most iterations get none; a
    pause still shows the iteration it stopped at, and a GUI that takes few frames has few
    made (not one an iteration)."""
    monkeypatch.setattr(runner_module, "FRAME_SHARE", 1e-4)  # the GUI takes a live frame seldom
    gate = HeldSolver(monkeypatch, "paper", after=8, mode="repeat")  # the run lasts until released
    win = make_window(small_project(0.05, solver="paper", max_iter=100000))
    try:
        win.run()
        qtbot.waitUntil(lambda: len(win.runner.history) >= 8, timeout=RUN_TIMEOUT_MS)
        win.actions["pause"].trigger()
        qtbot.waitUntil(lambda: win.runner.thread.paused, timeout=RUN_TIMEOUT_MS)
        last = win.runner.history[-1][0]
        qtbot.waitUntil(lambda: win.presenter.frame is not None and not win.presenter.frame.draping
                        and win.presenter.frame.iteration == last, timeout=RUN_TIMEOUT_MS)
        t = win.runner.thread
        assert 1 <= t.frames_made <= len(win.runner.history) // 2  # the pattern frames, the first and the pause's
        pause_and_stop(qtbot, win)
    finally:
        gate.release.set()


@pytest.mark.slow
def test_a_frames_cost_counts_the_repaint_it_asked_for(make_window, qtbot, monkeypatch):
    """The frames' share paces by the GUI's whole time on a frame: its slots and the views' repaint
    that follows them (Qt repaints after zero timers; counting the slots alone spent 3-4 times the share)."""
    import flatweave.app.canvas

    slow = 0.06
    paint = flatweave.app.canvas.Canvas.paintEvent

    def slow_paint(self, event):  # a repaint as dear as a big mesh's with software OpenGL
        time.sleep(slow)
        paint(self, event)

    monkeypatch.setattr(flatweave.app.canvas.Canvas, "paintEvent", slow_paint)
    # paced by the share, a 0.06 s paint allows a frame a second: the run is held after its first
    # iterations (tests.solver_gate) until two live frames are drawn, whatever the machine's speed
    # (a fast solve of a small piece drew only its result's)
    gate = HeldSolver(monkeypatch, "paper", after=3, mode="repeat")
    win = make_window(small_project(0.05, solver="paper", max_iter=150))
    if not isinstance(win.view.widget, flatweave.app.canvas.Canvas):
        pytest.skip("the views are not raster canvases here (a hardware OpenGL renderer): their paint is not slowed")
    costs = win.runner.frame_seconds
    costs.clear()  # the window's own frames before the run

    def start():
        win.run()
        try:
            qtbot.waitUntil(lambda: len(costs) >= 2, timeout=RUN_TIMEOUT_MS)  # two frames of the run drawn
        finally:
            gate.release.set()

    run_to_end(qtbot, win, start=start)
    qtbot.waitUntil(lambda: not win.runner._drawing, timeout=5000)  # the result's frame repainted too
    assert len(costs) >= 3
    assert np.median(costs) >= slow  # every frame repainted at least one view


def test_a_live_frame_is_made_only_once_the_gui_took_the_last(qtbot, monkeypatch):
    """With nobody taking frames the solve thread makes the run's first live frame and no other
    (a frame made while the last one waits for the GUI is never drawn and costs the solve)."""
    import flatweave.app.worker
    from flatweave.app.worker import SolveThread

    monkeypatch.setattr(flatweave.app.worker, "_lower_priority", lambda *a: None)  # this thread is the tests' own
    t = SolveThread(small_project(0.1))
    t.run()  # in this thread: no runner takes its frames
    assert len(t.history) >= 3 and t.stage == "done"
    assert t.frames_made == 1
    seq, frame = t.take_frame(0)
    assert frame is not None and frame.final


@pytest.mark.slow
def test_a_re_solve_keeps_the_pattern_view_until_it_has_a_pattern(make_window, qtbot, monkeypatch):
    """A live frame without a pattern (here the first of a warm re-run, told not to wait for its
    own): the 3D view draws it, the pattern view keeps the last result's pattern; a paused run's frame
    and a frame with the run's own pattern go to both views."""
    import flatweave.app.worker

    monkeypatch.setattr(flatweave.app.worker, "FIRST_FRAME_WITH_PATTERN", False)
    win = make_window(small_project(0.05, solver="paper", max_iter=5))
    first = run_to_end(qtbot, win).result
    p = win.presenter
    assert p.pattern_frame is not None and p.pattern_frame.final and p.pattern_frame.mesh is first.mesh
    gate = HeldSolver(monkeypatch, "paper", after=1, mode="repeat")  # the re-run lasts until released
    try:
        win.edit_settings("Solver", {"max_iter": 100000})  # a warm re-run
        qtbot.waitUntil(lambda: p.frame is not None and not p.frame.final, timeout=RUN_TIMEOUT_MS)
        live = p.frame
        assert win.runner.last_start[1] is not None and live.pattern is None and not live.draping
        assert win.view.layer.frame is live  # the 3D view shows the run
        assert p.pattern_frame.mesh is first.mesh and win.pattern_view.layer.frame is p.pattern_frame
        qtbot.waitUntil(lambda: p.frame.pattern is not None, timeout=RUN_TIMEOUT_MS)
        assert p.pattern_frame is p.frame and win.pattern_view.layer.frame is p.frame  # the run's own pattern
        win.actions["pause"].trigger()
        qtbot.waitUntil(lambda: win.runner.thread.paused, timeout=RUN_TIMEOUT_MS)
        last = win.runner.history[-1][0]
        qtbot.waitUntil(lambda: p.frame.iteration == last, timeout=RUN_TIMEOUT_MS)
        assert p.pattern_frame is p.frame  # a paused run shows its state in both views
        pause_and_stop(qtbot, win)
    finally:
        gate.release.set()
    assert p.pattern_frame.final and p.pattern_frame.mesh is win.project.result.mesh


@pytest.mark.slow
def test_a_re_solves_first_live_frame_brings_its_pattern(make_window, qtbot, monkeypatch):
    """The first live frame of a warm re-run carries its own pattern (a dart's V from the first
    frame), and both views draw it; the frames after it carry that pattern until a newer one."""
    win = make_window(small_project(0.05, solver="paper", max_iter=5))
    run_to_end(qtbot, win)
    p = win.presenter
    gate = HeldSolver(monkeypatch, "paper", after=1, mode="repeat")  # the re-run lasts until released
    try:
        win.edit_settings("Solver", {"max_iter": 100000})  # a warm re-run
        qtbot.waitUntil(lambda: p.frame is not None and not p.frame.final, timeout=RUN_TIMEOUT_MS)
        live = p.frame
        assert win.runner.last_start[1] is not None and not live.draping
        assert live.pattern is not None and live.pattern.outline.shape[0] > 3
        assert win.view.layer.frame is live and p.pattern_frame is live and win.pattern_view.layer.frame is live
        pause_and_stop(qtbot, win)
    finally:
        gate.release.set()


@pytest.mark.slow
def test_a_runs_first_live_frame_is_taken_when_it_is_made(make_window, qtbot, monkeypatch):
    """The first live frame reaches the views when the solve thread publishes it, not at the
    frame pump's next period (here never: the pump is stopped)."""
    win = make_window(small_project(0.05, solver="paper", max_iter=5))
    run_to_end(qtbot, win)
    p = win.presenter
    frames = []
    win.runner.frame.connect(frames.append)
    win.runner.started.connect(lambda _p: win.runner._timer.setInterval(10 ** 8))
    gate = HeldSolver(monkeypatch, "paper", after=1, mode="repeat")  # the re-run lasts until released
    try:
        win.edit_settings("Solver", {"max_iter": 100000})  # a warm re-run
        qtbot.waitUntil(lambda: any(not f.final for f in frames), timeout=RUN_TIMEOUT_MS)
        assert win.runner.busy and p.frame is frames[0] and not frames[0].draping
        pause_and_stop(qtbot, win)
    finally:
        gate.release.set()


@pytest.mark.slow
def test_the_progress_counts_nodes_from_each_lattices_start(make_window, qtbot, monkeypatch):
    """The progress line's "(+N since ...)" is the nodes refilled less those deleted on the lattice
    on screen: from the drape on a run's first lattice, from its own start on a coarse-to-fine run's
    finer level (not from the coarser lattice's count: that read +1,8xx on a 2,500-node piece), and
    from the warm start on a re-solve."""
    win = make_window(small_project(0.025))  # about 2,500 nodes: the run starts on a coarser lattice
    shown, seen = win.presenter.show_progress, []

    def record(frame):
        shown(frame)
        if not frame.draping:
            seen.append((frame.mesh.r_weft, frame.mesh.n_nodes, win.progress.text()))

    monkeypatch.setattr(win.presenter, "show_progress", record)
    snapshot = flatweave.method.solver.Run.snapshot

    def slow(self, *a, **k):  # iterations slower than the frame pump: every lattice is on screen a while
        time.sleep(0.03)
        return snapshot(self, *a, **k)

    monkeypatch.setattr(flatweave.method.solver.Run, "snapshot", slow)
    run_to_end(qtbot, win)
    r = win.project.result
    assert r.metrics["coarse_levels"] >= 1

    def counted(rows):  # (count in the text, what it counts from, the frame's nodes)
        out = []
        for _, n, text in rows:
            m = re.search(r"nodes \(([+-][\d,]+) since (.+)\)$", text)
            assert m, text
            out.append((int(m.group(1).replace(",", "")), m.group(2), n))
        return out

    first = counted([x for x in seen if x[0] == seen[0][0]])
    fine = counted([x for x in seen if x[0] == r.mesh.r_weft])
    assert seen[0][0] != r.mesh.r_weft and first and fine
    assert {since for _, since, _ in first} == {"the drape"}
    assert [c for c, _, _ in first] == [n - first[0][2] for _, _, n in first]
    assert {since for _, since, _ in fine} == {"this level's start"}
    assert [c for c, _, _ in fine] == [n - fine[0][2] for _, _, n in fine]
    assert fine[0][0] == 0
    seen.clear()
    run_to_end(qtbot, win, lambda: win.edit_settings("Solver", {"solver": "paper", "max_iter": 4}))
    assert win.runner.last_start[1] is not None  # a warm re-run, on the fine lattice
    assert seen and {since for _, since, _ in counted(seen)} == {"the warm start"}


@pytest.mark.slow
@pytest.mark.parametrize("hold_ms", [runner_module.HOLD_FOR_FIRST_FRAME_MS, 40])
def test_an_edits_repaint_waits_for_the_re_solves_first_frame(make_window, qtbot, monkeypatch, hold_ms):
    """A warm re-solve holds the views' repaints until its first frame comes (the frame repaints
    what the edit changed), at most HOLD_FOR_FIRST_FRAME_MS; then they repaint."""
    import threading

    from PySide6.QtCore import QEvent, QObject

    monkeypatch.setattr(runner_module, "HOLD_FOR_FIRST_FRAME_MS", hold_ms)
    win = make_window(small_project(0.05, solver="paper", max_iter=5))
    run_to_end(qtbot, win)
    paints, frames = [], []
    painted = threading.Event()  # a view painted since the edit

    class Spy(QObject):
        def eventFilter(self, obj, event):
            if event.type() == QEvent.Type.Paint:
                paints.append((time.perf_counter(), obj))
                painted.set()
            return False
    spy = Spy()
    for w in (win.view.widget, win.pattern_view.widget):
        w.installEventFilter(spy)
    if hold_ms < 100:  # a first frame slower than the hold: the views repaint when it is up
        import flatweave.app.worker

        made = flatweave.app.worker.SolveThread._live_frame

        def late(self, maker, snap):  # the first frame waits for a paint (none comes while the hold lasts)
            painted.wait(10)
            return made(self, maker, snap)
        monkeypatch.setattr(flatweave.app.worker.SolveThread, "_live_frame", late)
    win.runner.frame.connect(lambda f: frames.append(time.perf_counter()))
    gate = HeldSolver(monkeypatch, "paper", after=1, mode="repeat")  # the re-run lasts until released
    try:
        t0 = time.perf_counter()
        win.edit_settings("Solver", {"max_iter": 100000})  # a warm re-run
        qtbot.waitUntil(lambda: bool(frames and paints and paints[-1][0] > frames[0]), timeout=RUN_TIMEOUT_MS)
        first = frames[0]
        early = [t for t, _ in paints if t < first]
        assert all(t - t0 >= 0.9 * hold_ms / 1000 for t in early), (early, t0, first)  # none while held
        if hold_ms < 100:
            assert early  # the hold ran out first: the views painted the edit before the frame
        assert {w for t, w in paints if t > first} >= {win.view.widget}  # they paint again after it
        pause_and_stop(qtbot, win)
    finally:
        gate.release.set()


@pytest.mark.slow
def test_the_drape_is_shown_live_and_stop_ends_it(make_window, qtbot, monkeypatch):
    """The mesh is drawn as it is laid, and Stop (or Pause) acts during the drape."""
    import flatweave.method.drape

    slow_add = flatweave.method.drape._Builder.add

    laid = [0]

    def add(self, *args):  # a slow drape, so the test can act in the middle of it
        slow_add(self, *args)
        laid[0] = max(laid[0], len(self.ij))
        time.sleep(0.2)  # the bands add a drape in few batches (a dozen here): each waits longer

    monkeypatch.setattr(flatweave.method.drape._Builder, "add", add)
    win = make_window(small_project(0.04))
    frames = []
    win.runner.frame.connect(frames.append)
    win.run()
    qtbot.waitUntil(lambda: sum(f.draping for f in frames) >= 3, timeout=RUN_TIMEOUT_MS)
    assert win.progress.text().startswith("Draping") and "nodes laid" in win.progress.text()
    assert win.metrics.text("status") == "draping..."
    shown = win.view.layer.spring_colours()[0]
    assert len(shown) == frames[-1].mesh.n_springs > 0  # the partial mesh is on screen
    win.actions["pause"].trigger()
    qtbot.waitUntil(lambda: win.runner.thread.paused, timeout=5000)
    n = len(frames)
    qtbot.wait(300)
    assert len(frames) == n, "the drape went on while paused"
    win.actions["pause"].trigger()
    qtbot.waitUntil(lambda: len(frames) > n, timeout=5000)
    counts = [f.stats["nodes"] for f in frames if f.draping]
    assert counts == sorted(counts) and counts[-1] > counts[0]
    with qtbot.waitSignal(win.run_finished, timeout=10000) as blocker:
        win.stop()
    outcome = blocker.args[0]
    assert outcome.stopped and outcome.result is None and not any(not f.draping for f in frames)
    monkeypatch.undo()
    full = drape(win.project.surface, win.project.settings.drape_settings(), win.project.settings.material)
    assert laid[0] < full.mesh.n_nodes  # the drape was stopped in the middle, not run to its end
    assert win.project.result is None and project_problems(win.project) == []
    assert win.runner.state == "idle" and win.actions["run"].isEnabled()


@pytest.mark.slow
def test_the_event_loop_runs_during_a_solve(each_widget, make_window, qtbot, monkeypatch):
    """While a solve runs (its thread working and making snapshots), the window's event loop runs:
    a 10 ms timer ticks while the solve goes on and between its live frames, three live frames
    arrive, and the camera moves when dragged mid-run."""
    # ~650 nodes, the paper's scheme for 150 iterations. After its first 5 the run is held
    # (tests.solver_gate): its thread goes on evaluating the energy and making snapshots of that state
    # until the test has seen all it checks, then the real solve goes on to its end. No check hangs on
    # the run lasting long enough, nor on how long the event loop's gaps are on this machine.
    gate = HeldSolver(monkeypatch, "paper", after=5, mode="repeat")
    win = make_window(small_project(0.05, solver="paper", max_iter=150))
    live = []  # when each live frame of the solve reached the views
    win.runner.frame.connect(lambda f: live.append(time.perf_counter()) if not (f.final or f.draping) else None)
    ticks = []  # (time, the solve's snapshots so far) at each tick
    timer = QTimer()
    timer.setInterval(10)
    timer.timeout.connect(lambda: ticks.append((time.perf_counter(), gate.snapshots)))
    moved = {}
    iren = win.view.plotter.iren.interactor
    cam = win.view.plotter.renderer.GetActiveCamera()

    def drag_step():
        """One mouse event per call, as a hand dragging the camera would send them."""
        if not win.runner.busy or not live or "by" in moved:
            return
        w, h = win.view.plotter.window_size
        step = moved.setdefault("step", 0)
        x = w // 2 + 15 * step
        iren.SetEventInformation(x, h // 2, 0, 0)
        if step == 0:
            moved["before"] = np.array(cam.GetPosition())
            iren.InvokeEvent("LeftButtonPressEvent")
        elif step < 6:
            iren.InvokeEvent("MouseMoveEvent")
        else:
            iren.InvokeEvent("LeftButtonReleaseEvent")
            moved["by"] = float(np.linalg.norm(np.array(cam.GetPosition()) - moved["before"]))
            moved["busy"] = win.runner.busy
        moved["step"] = step + 1

    dragger = QTimer()
    dragger.setInterval(30)
    dragger.timeout.connect(drag_step)
    finished = []
    win.run_finished.connect(finished.append)
    dragger.start()
    timer.start()
    t0 = time.perf_counter()
    try:
        win.run()
        qtbot.waitUntil(lambda: len(live) >= 3 and "by" in moved, timeout=RUN_TIMEOUT_MS)
        assert win.runner.busy and not finished  # all of it while the run was in flight
        t1 = time.perf_counter()
    finally:
        gate.release.set()
    qtbot.waitUntil(lambda: bool(finished), timeout=RUN_TIMEOUT_MS)
    timer.stop()
    dragger.stop()
    assert finished[0].result is not None and not finished[0].stopped
    inside = [(t, n) for t, n in ticks if t0 <= t <= t1]
    gaps = np.diff([t0] + [t for t, _ in inside] + [t1])
    print(f"\nheld run {t1 - t0:.2f} s, {len(inside)} ticks, longest event-loop gap {1000 * gaps.max():.0f} ms, "
          f"{len(live)} live frames, {gate.snapshots} snapshots")

    # the timer ticked while the solve went on (the ticks saw its snapshot count grow), not only before
    # or after it, and between every two live frames (drawing frames does not hold the event loop)
    assert len({n for _, n in inside if n > 0}) >= 3, inside
    held_live = [x for x in live if x <= t1]  # the live frames of the held run
    for a, b in zip(held_live, held_live[1:]):
        assert any(a < t < b for t, _ in inside), "no timer tick between two live frames"
    assert moved.get("busy") and moved["by"] > 1e-3, "the camera did not move during the run"


@pytest.mark.slow
def test_a_worker_exception_reaches_a_dialog(make_window, qtbot, monkeypatch):
    import flatweave.app.worker as worker

    real = worker.flatten_iter

    def exploding(surface, settings, initial=None, area=None, **options):
        gen = real(surface, settings, initial, area, **options)
        yield next(gen)
        yield next(gen)
        raise RuntimeError("the solver exploded\nsecond line")

    win = make_window(small_project(0.1))
    before = win.project
    monkeypatch.setattr(worker, "flatten_iter", exploding)
    with qtbot.waitSignal(win.run_failed, timeout=RUN_TIMEOUT_MS) as blocker:
        win.run()
    assert blocker.args[0] == "RuntimeError: the solver exploded"
    assert win.last_error == "Solve failed: RuntimeError: the solver exploded"
    qtbot.waitUntil(lambda: win.error_box is not None and win.error_box.isVisible())
    assert win.error_box.text() == win.last_error and not win.error_box.isModal()
    # the document is untouched and the views are back to it (no result: nothing drawn)
    assert win.project is before and win.project.result is None and not win.document.can_undo
    assert len(shown_rgb(win.view)[0]) == 0 and win.frame is None
    assert win.runner.state == "idle" and win.actions["run"].isEnabled()
    # the app stays usable: the next run works
    monkeypatch.setattr(worker, "flatten_iter", real)
    outcome = run_to_end(qtbot, win)
    assert outcome.result is not None and win.project.result_is_current


def test_a_refused_setting_is_a_one_line_error_from_the_run(make_window, qtbot):
    win = make_window(small_project(0.1))
    win.document.edit_settings("Max nodes", max_nodes=50)
    with qtbot.waitSignal(win.run_failed, timeout=RUN_TIMEOUT_MS) as blocker:
        win.run()
    msg = blocker.args[0]
    assert "\n" not in msg and "more than the limit of 50" in msg and "smallest spacing" in msg


# ---------------------------------------------------------------------- edits
@pytest.mark.slow
def test_a_settings_change_re_runs(make_window, qtbot):
    win = make_window(small_project(0.1))
    first = run_to_end(qtbot, win).result
    runs = win.runner.runs_started

    # a new spacing typed into the panel: a new drape, folded into the edit
    edit = win.settings_panel.spacing
    edit.setText("0.09")
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        edit.editingFinished.emit()
    r = blocker.args[0].result
    assert win.runner.runs_started == runs + 1 and win.runner.last_start[1] is None  # drape anew
    assert r.settings.spacing == 0.09 and win.project.result is r and win.project.result_is_current
    assert r.mesh.n_nodes > first.mesh.n_nodes
    assert win.document.undo_label == "Weft spacing" and len(win.document.history) == 2

    # a new tolerance from the panel: warm-started from the last result
    win.settings_panel.tol.setText("1e-7")
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        win.settings_panel.tol.editingFinished.emit()
    assert win.runner.last_start[1] is not None
    assert blocker.args[0].result.settings.tol == 1e-7 and win.project.result_is_current

    # undo goes back to the earlier results without solving again
    runs = win.runner.runs_started
    win.actions["undo"].trigger()
    assert win.project.result is r
    win.actions["undo"].trigger()
    assert win.project.result is first and win.project.settings.spacing == 0.1
    assert win.settings_panel.spacing.text() == "0.1"
    qtbot.wait(2 * 250 + 100)  # longer than the re-run delay
    assert win.runner.runs_started == runs and not win.runner.busy
    assert len(shown_rgb(win.view)[0]) == first.mesh.n_springs


@pytest.mark.slow
def test_settings_edits_during_a_run_restart_it(make_window, qtbot):
    win = make_window(small_project(0.08, solver="paper", max_iter=100000))
    run_to_end(qtbot, win, start=lambda: (win.run(), QTimer.singleShot(300, win.stop)))
    win.run()
    qtbot.waitUntil(lambda: len(win.runner.history) >= 3, timeout=RUN_TIMEOUT_MS)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        win.edit_settings("Solver", {"solver": "fast"})
    # the paper run was abandoned (no result from it) and the fast one answered the edit
    r = blocker.args[0].result
    assert r.settings.solver == "fast" and r.metrics["solver_status"] == "converged"
    assert win.project.result is r and win.document.undo_label == "Solver"


def test_a_bad_value_in_the_panel_snaps_back(make_window, qtbot):
    win = make_window(small_project(0.1))
    p0 = win.project
    win.settings_panel.spacing.setText("0")
    win.settings_panel.spacing.editingFinished.emit()
    assert win.project is p0 and "spacing" in win.last_error and "\n" not in win.last_error
    assert win.settings_panel.spacing.text() == "0.1"
    win.settings_panel.shear_warning.setValue(40.0)  # above the limit (30)
    assert win.project is p0 and "below the limit" in win.last_error
    assert win.settings_panel.shear_warning.value() == 15.0


@pytest.mark.slow
def test_display_settings_restyle_without_a_solve(make_window, qtbot):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    runs = win.runner.runs_started
    win.settings_panel.units.setCurrentIndex(win.settings_panel.units.findData("cm"))
    win.settings_panel.units.activated.emit(win.settings_panel.units.currentIndex())
    assert win.project.units == "cm" and win.pattern_view.scale_label.GetInput().endswith(" cm")
    assert win.pattern_view.scale_label.GetInput() == f"{nice_length(0.4 * _width(win)):g} cm"
    win.actions["mode_shear"].trigger()
    assert win.view.colour_bar_title == "shear (deg)"
    assert win.view.colour_bar_range == (0.0, 1.5 * 30.0)
    win.settings_panel.shear_limit.setValue(20.0)
    assert win.project.shear_limit_deg == 20.0 and win.view.colour_bar_range == (0.0, 30.0)
    assert win.project.settings.material.lock_deg == 20.0 and win.project.result_is_current  # the material's angle
    qtbot.wait(400)
    assert win.runner.runs_started == runs and not win.runner.busy


def _width(win):
    o = win.project.result.pattern.outline
    return float(o[:, 0].max() - o[:, 0].min())


@pytest.mark.slow
def test_kind_toggles_and_the_colour_range(make_window, qtbot):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    r = win.project.result
    strain = spring_strain(r.xyz, r.mesh)
    win.actions["show_diag"].trigger()  # off
    assert not win.view.layer.spring_actors[2].GetVisibility()
    assert win.view.layer.spring_actors[0].GetVisibility()
    thread = r.mesh.kind != 2
    lo, hi = win.view.colour_bar_range
    assert lo == pytest.approx(100 * strain[thread].min()) and hi == pytest.approx(100 * strain[thread].max())
    win.actions["show_surface"].trigger()
    assert not win.view._surface_actors[0].GetVisibility()
    win.actions["show_nodes"].trigger()
    assert not any(a.GetVisibility() for a in win.view.layer.node_actors)


@pytest.mark.slow
def test_hover_shows_the_spring_or_cell_value(each_widget, make_window, qtbot):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    r = win.project.result
    strain = spring_strain(r.xyz, r.mesh)
    view = win.view
    view.render()
    # the middle of a weft spring near the middle of the piece (seen face-on)
    weft = np.flatnonzero(r.mesh.kind == 0)
    mid = 0.5 * (r.xyz[r.mesh.ends[weft, 0]] + r.xyz[r.mesh.ends[weft, 1]])
    s = weft[np.argmin(np.linalg.norm(mid - r.xyz.mean(axis=0), axis=1))]
    x, y = view.display_point(0.5 * (r.xyz[r.mesh.ends[s, 0]] + r.xyz[r.mesh.ends[s, 1]]))
    text = view.describe_at(x, y)
    assert text is not None and text.startswith(f"weft spring {s} ") and f"{100 * strain[s]:+.4f} %" in text
    # through a real mouse move event, into the status bar
    iren = view.plotter.iren.interactor
    iren.SetEventInformation(int(round(x)), int(round(y)), 0, 0)
    view._last_pick = 0.0
    iren.InvokeEvent("MouseMoveEvent")
    assert win._hover_label.text() == view.describe_at(int(round(x)), int(round(y)))
    assert "spring" in win._hover_label.text()
    # shear mode: cells
    win.actions["mode_shear"].trigger()
    view.render()
    c = np.argmin(np.linalg.norm(r.xyz[r.mesh.cells].mean(axis=1) - r.xyz.mean(axis=0), axis=1))
    x, y = view.display_point(r.xyz[r.mesh.cells[c]].mean(axis=0))
    text = view.describe_at(x, y)
    assert text is not None and text.startswith("cell ") and "shear" in text


# ---------------------------------------------------------------------- projects
@pytest.mark.slow
def test_save_then_open_restores_the_document(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.edit_display("Units", {"units": "cm"})
    win.edit_display("Shear warning angle", {"shear_warning_deg": 12.0})
    saved = project_to_dict(win.files.as_saved(win.project))  # as the file keeps it (view choices too)
    idx, rgb = shown_rgb(win.view)
    path = tmp_path / "job"
    assert win.save_to(path)
    assert (tmp_path / "job.flatweave").exists() and not win.windowTitle().endswith("*")
    assert win.windowTitle() == "flatweave - job.flatweave"

    other = make_window(example="saddle")
    assert other.open_file(tmp_path / "job.flatweave")
    assert project_to_dict(other.project) == saved
    assert other.project.result_is_current and not other.document.can_undo and not other.document.dirty
    idx2, rgb2 = shown_rgb(other.view)
    np.testing.assert_array_equal(idx2, idx)
    np.testing.assert_array_equal(rgb2, rgb)
    assert other.settings_panel.units.currentData() == "cm"
    assert other.settings_panel.shear_warning.value() == 12.0
    np.testing.assert_allclose(np.asarray(other.pattern_view.outline.points)[:, :2],
                               win.project.result.pattern.outline)


def test_opening_a_damaged_project_keeps_the_document(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))
    before = win.project
    bad = tmp_path / "bad.flatweave"
    bad.write_text('{"format": "flatweave-project", "version": 99}')
    assert not win.open_file(bad)
    assert win.project is before
    assert "newer" in win.last_error and "bad.flatweave" in win.last_error and "\n" not in win.last_error


@pytest.mark.slow
def test_opening_another_surface_mid_run_abandons_it(make_window, qtbot):
    win = make_window(small_project(0.08, solver="paper", max_iter=100000))
    finished = []
    win.run_finished.connect(finished.append)
    win.run()
    qtbot.waitUntil(lambda: len(win.runner.history) >= 3, timeout=RUN_TIMEOUT_MS)
    assert win.open_example("saddle")
    assert win.surface_name == "saddle" and win.project.result is None
    drawn = []
    win.runner.frame.connect(drawn.append)
    qtbot.waitUntil(lambda: win.runner.state == "idle", timeout=10000)
    qtbot.wait(100)
    assert drawn == [] and finished == []  # nothing of the old run reached the new document
    assert win.frame is None and len(shown_rgb(win.view)[0]) == 0
    assert win.actions["run"].isEnabled() and not win.document.can_undo


@pytest.mark.slow
def test_undo_mid_run_cancels_it_and_shows_the_earlier_result(make_window, qtbot):
    win = make_window(small_project(0.1))
    first = run_to_end(qtbot, win).result
    win.settings_panel.auto_rerun.setChecked(True)
    # a new drape solved by the paper's CG: thousands of iterations
    win.document.edit_settings("Solver", spacing=0.08, solver="paper", max_iter=100000)
    qtbot.waitUntil(lambda: win.runner.busy and len(win.runner.history) >= 3, timeout=RUN_TIMEOUT_MS)
    win.actions["undo"].trigger()
    assert win.project.result is first and not win.runner.active
    idx, rgb = shown_rgb(win.view)
    assert len(idx) == first.mesh.n_springs
    assert np.abs(rgb.astype(int) - expected_rgb(spring_strain(first.xyz, first.mesh), first.mesh.kind)).max() <= 1
    qtbot.waitUntil(lambda: win.runner.state == "idle", timeout=10000)
    assert win.project.result is first and win.document.redo_label == "Solver"
    # the document is consistent, the panel does not show the cancelled run's progress,
    # and the app goes on: Run solves the restored settings again
    assert project_problems(win.project) == [] and win.project.result_is_current
    assert win.progress.text() == "The run was cancelled; nothing of it was kept."
    assert win.frame.final and len(shown_rgb(win.view)[0]) == first.mesh.n_springs
    win.settings_panel.auto_rerun.setChecked(False)
    outcome = run_to_end(qtbot, win)
    assert win.project.result is outcome.result and outcome.result.metrics["solver_status"] == "converged"
    assert project_problems(win.project) == [] and win.document.undo_label == "Solve"


# ---------------------------------------------------------------------- export
def test_export_needs_a_result(make_window):
    win = make_window(small_project(0.1))
    assert not win.actions["export"].isEnabled()


@pytest.mark.slow
def test_export_dialog_writes_every_format(make_window, qtbot, tmp_path):
    from flatweave.export.registry import FORMATS, ExportOptions, export_bytes

    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.edit_display("Units", {"units": "cm"})
    assert win.actions["export"].isEnabled()
    win.actions["export"].trigger()
    dialog = win.export_box
    qtbot.waitUntil(dialog.isVisible)
    assert dialog.fields["units"].currentData() == "cm"  # the model's units by default
    # the format follows the suffix, and choosing a format changes the suffix
    dialog.path.setText(str(tmp_path / "piece.svg"))
    dialog.path.textEdited.emit(dialog.path.text())
    assert dialog.format.currentData() == ".svg"
    dialog.format.setCurrentIndex(dialog.format.findData(".pdf"))
    dialog.format.activated.emit(dialog.format.currentIndex())
    assert dialog.path.text() == str(tmp_path / "piece.pdf")
    dialog.every_format.setChecked(True)
    dialog.fields["seam_allowance_mm"].setValue(15.0)
    dialog.fields["paper"].setCurrentIndex(dialog.fields["paper"].findData("letter"))
    assert dialog.fields["dxf_variant"].currentData() == "astm" and dialog.fields["obj_texture"].currentData() == "none"
    dialog.fields["dxf_variant"].setCurrentIndex(dialog.fields["dxf_variant"].findData("layered"))
    dialog.fields["obj_texture"].setCurrentIndex(dialog.fields["obj_texture"].findData("checker"))
    with qtbot.waitSignal(win.export_finished, timeout=60000) as blocker:
        dialog.export_button.click()
    written = blocker.args[0]
    assert sorted(p.name for p in written) == sorted(f"piece{s}" for s in FORMATS)
    assert all(p.stat().st_size > 0 for p in written)
    assert str(tmp_path) in win.statusBar().currentMessage() and "piece.dxf" in win.progress.text()
    # the same bytes as the core writes for these options (formats without timestamps)
    options = ExportOptions(seam_allowance_mm=15.0, units="cm", paper="letter", name="octant",
                            dxf_variant="layered", obj_texture="checker")
    assert win.export_options == options
    r = win.project.result
    for suffix in (".svg", ".vtp"):
        assert (tmp_path / f"piece{suffix}").read_bytes() == export_bytes(r, suffix, options), suffix
    # the checker OBJ names its material file after the file it is written to
    assert b"mtllib piece.mtl" in (tmp_path / "piece.obj").read_bytes()
    assert (tmp_path / "piece.pdf").read_bytes().startswith(b"%PDF")
    assert b"SECTION" in (tmp_path / "piece.dxf").read_bytes()[:200]
    assert b"$INSUNITS" in (tmp_path / "piece.dxf").read_bytes()  # the layered variant chosen in the dialog
    assert (tmp_path / "piece.mtl").exists()  # the checker texture's material beside the OBJ
    qtbot.waitUntil(lambda: win.export_thread is None, timeout=5000)  # the thread ends after its signal
    assert win.actions["export"].isEnabled()


def test_export_failure_is_a_one_line_error(make_window, qtbot, tmp_path):
    from flatweave.export.registry import ExportOptions

    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    target = tmp_path / "missing" / "p.dxf"
    with qtbot.waitSignal(win.export_failed, timeout=30000) as blocker:
        assert win.export_to([target], ExportOptions())
    msg = blocker.args[0]
    assert "\n" not in msg and "p.dxf" in msg and "does not exist" in msg
    assert win.last_error == f"Export failed: {msg}" and not target.exists()
    qtbot.waitUntil(lambda: win.export_thread is None, timeout=5000)
    assert win.actions["export"].isEnabled()
