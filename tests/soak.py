"""Soak test: a thousand random edits through the window's command layer.

Not part of the default test run (pytest collects ``test_*.py`` only). Run it
on a display, e.g.::

    xvfb-run -a -s '-screen 0 1600x1000x24' .venv/bin/python tests/soak.py [--edits 1000] [--seed 1]

It opens the octant example in a real MainWindow and makes random edits the
way the GUI makes them (``MainWindow.edit_settings`` / ``edit_display`` /
``dart_edit`` over the document's dart and yarn edits / ``delete_dart`` /
``undo`` / ``redo`` / ``run`` / ``rerun`` / ``stop`` / ``toggle_pause`` /
``save_to`` / ``open_file`` / ``autosave``): darts added, edited and removed,
settings and display changed, runs started, paused and stopped at random
moments, projects saved and reopened. Between edits the event loop runs for a
random 0-300 ms, so edits land mid-run as a designer's would.

After every edit it asserts the document is consistent
(``core.project.project_problems``; a result marked current was made with the
current settings; the undo stack within its limit; at most one solve thread
alive; Run enabled exactly when idle) and records the process's resident
memory. At the end it fits a line to the memory of the second half of the
edits and fails if it grows by more than ``--max-growth`` MB per 100 edits.
It prints a table and writes it to ``benchmarks/results/soak.md``; exit
status 0 when every check held.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import random
import sys
import tempfile
import threading
import time
import traceback
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


class Soak:
    def __init__(self, win, rng: random.Random, folder: Path):
        self.win = win
        self.rng = rng
        self.folder = folder
        self.counts: Counter = Counter()
        self.errors: Counter = Counter()
        self.max_threads = 0
        self.saved: Path | None = None
        self.outcomes: Counter = Counter()
        self.with_result = 0
        win.run_finished.connect(self._finished)
        win.run_failed.connect(lambda _m: self.outcomes.update(["failed"]))

    def _finished(self, outcome) -> None:
        if outcome.result is None:
            self.outcomes["stopped before a result"] += 1
        else:
            self.outcomes["stopped" if outcome.stopped else "converged or on a budget"] += 1

    # ------------------------------------------------------------------ helpers
    @property
    def doc(self):
        return self.win.document

    def pump(self, ms: float) -> None:
        from PySide6.QtWidgets import QApplication
        end = time.perf_counter() + ms / 1000.0
        while True:
            QApplication.processEvents()
            if time.perf_counter() >= end:
                return
            time.sleep(0.005)

    def settle(self, timeout: float = 120.0) -> None:
        """Let any run finish (or stop it after ``timeout``)."""
        end = time.perf_counter() + timeout
        while self.win.runner.busy and time.perf_counter() < end:
            self.pump(20)
        if self.win.runner.busy:
            self.win.stop()
            while self.win.runner.busy:
                self.pump(20)

    # ------------------------------------------------------------------ the edits
    def edit(self) -> str:
        from core.darts import CurveDart, PlaneDart
        from core.energy import YarnConstraint
        from core.mesh import MATERIALS

        win, rng, doc = self.win, self.rng, self.doc
        darts = doc.project.settings.darts
        kinds = ["curve dart", "plane dart", "remove dart", "rename dart", "hide dart", "yarn", "remove yarn",
                 "spacing", "material", "angle", "tolerance", "solver", "units", "shear angles", "run",
                 "rerun", "stop", "pause", "undo", "undo", "redo", "save", "open", "autosave"]
        kind = rng.choice(kinds)
        if kind == "curve dart":
            v0 = rng.uniform(0.2, 0.8)
            depth = rng.uniform(0.2, 0.5)
            bend = rng.uniform(-0.1, 0.1)
            t = np.linspace(0.0, 1.0, 6)
            uv = np.column_stack([depth * t, v0 + bend * t ** 2])
            win.dart_edit(doc.add_dart, CurveDart(uv, name=f"curve {self.counts[kind]}"))
        elif kind == "plane dart":
            c = rng.uniform(0.3, 0.7)
            axis = rng.randrange(3)
            normal = [0.0, 0.0, 0.0]
            normal[axis] = 1.0
            box = (0.0, 1.0, 0.0, 1.0, 0.0, 1.0)
            box = list(box)
            other = (axis + 1) % 3
            box[2 * other + 1] = rng.uniform(0.3, 0.7)  # the box ends inside: the dart has a tip
            win.dart_edit(doc.add_dart, PlaneDart((*normal, -c), tuple(box), name=f"plane {self.counts[kind]}"))
        elif kind == "remove dart" and darts:
            win.delete_dart(rng.randrange(len(darts)))
        elif kind == "rename dart" and darts:
            win.dart_edit(doc.rename_dart, rng.randrange(len(darts)), f"renamed {rng.randrange(1000)}")
        elif kind == "hide dart" and darts:
            i = rng.randrange(len(darts))
            win.dart_edit(doc.set_dart_visible, i, not darts[i].visible)
        elif kind == "yarn":
            win.dart_edit(doc.add_yarn, YarnConstraint(rng.choice(["weft", "warp"]), rng.randrange(-2, 3),
                                                        (0.0, 0.0, 1.0, -rng.uniform(0.2, 0.6)),
                                                        rng.choice([10.0, 100.0])))
        elif kind == "remove yarn" and doc.project.settings.yarns:
            win.dart_edit(doc.remove_yarn, rng.randrange(len(doc.project.settings.yarns)))
        elif kind == "spacing":
            s = rng.choice([0.09, 0.1, 0.11, 0.12, 0.14])
            win.edit_settings("Spacing", {"spacing": s, "spacing_warp": s})
        elif kind == "material":
            win.edit_settings("Material", {"material": MATERIALS[rng.choice(sorted(MATERIALS))]})
        elif kind == "angle":
            win.edit_settings("Weft angle", {"angle_deg": rng.choice([0.0, 15.0, 30.0, 45.0])})
        elif kind == "tolerance":
            win.edit_settings("Tolerance", {"tol": rng.choice([1e-4, 1e-6, 1e-8])})
        elif kind == "solver":
            # the paper's scheme is slow: a time budget keeps each of its runs short
            win.edit_settings("Solver", {"solver": rng.choice(["fast", "fast", "paper"]), "max_seconds": 5.0})
        elif kind == "units":
            win.edit_display("Units", {"units": rng.choice(["mm", "cm", "m", "in"])})
        elif kind == "shear angles":
            w = rng.uniform(5, 20)
            win.edit_display("Shear angles", {"shear_warning_deg": w, "shear_limit_deg": w + rng.uniform(5, 20)})
        elif kind == "run":
            win.run()
            if rng.random() < 0.5:  # half the runs are left to finish, half are cut short by what follows
                self.settle()
        elif kind == "rerun":
            win.rerun()
            if rng.random() < 0.5:
                self.settle()
        elif kind == "stop":
            win.stop()
        elif kind == "pause":
            if win.runner.busy:
                win.toggle_pause()
                self.pump(rng.uniform(0, 200))
                if win.runner.paused:
                    win.toggle_pause()
        elif kind == "undo":
            win.undo()
        elif kind == "redo":
            win.redo()
        elif kind == "save":
            self.saved = self.folder / "soak.flatweave"
            if not win.save_to(self.saved):
                self.errors["save failed"] += 1
        elif kind == "open" and self.saved is not None:
            if not win.open_file(self.saved):
                self.errors["open failed"] += 1
        elif kind == "autosave":
            pending = win.autosave()
            if pending is not None:
                pending.result(timeout=60)
        else:
            kind = f"{kind} (nothing to do)"
        self.counts[kind] += 1
        return kind

    # ------------------------------------------------------------------ the checks
    def check(self) -> list[str]:
        from core.project import project_problems, settings_equal
        from app.worker import SolveThread

        problems = []
        win, doc = self.win, self.doc
        p = doc.project
        self.with_result += p.result is not None
        problems += project_problems(p)
        if p.result is not None and p.result_is_current and not settings_equal(p.result.settings, p.settings):
            problems.append("a result marked current was made with other settings")
        if len(doc.history) > doc.limit:
            problems.append(f"the undo stack holds {len(doc.history)} > {doc.limit} edits")
        from shiboken6 import isValid  # a finished thread's C++ side may be gone already (deleteLater)
        alive = [o for o in gc.get_objects() if isinstance(o, SolveThread) and isValid(o) and o.isRunning()] \
            if self.counts.total() % 25 == 0 else []
        self.max_threads = max(self.max_threads, len(alive))
        if len(alive) > 1:
            problems.append(f"{len(alive)} solve threads run at once")
        if win.actions["run"].isEnabled() != (win.runner.state == "idle"):
            problems.append(f"Run enabled={win.actions['run'].isEnabled()} while the runner is {win.runner.state}")
        if win.error_box is not None:  # a refused edit or a failed solve: note it, close the box
            self.errors[(win.last_error or "?").split(":")[0][:60]] += 1
            win.error_box.close()
        return problems


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edits", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--max-growth", type=float, default=5.0, metavar="MB",
                        help="fail if memory grows by more than this per 100 edits over the second half")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "soak.md")
    args = parser.parse_args(argv)

    os.environ.setdefault("QT_QPA_PLATFORM", "xcb")
    folder = Path(tempfile.mkdtemp(prefix="flatweave-soak-"))
    os.environ["FLATWEAVE_RECOVERY_DIR"] = str(folder / "recovery")

    from app.nonefix import keep_none_alive

    keep_none_alive()  # before any Qt call
    from PySide6.QtWidgets import QApplication

    from app.mainwindow import MainWindow
    from core.examples import example_path, load_example
    from core.project import new_project

    app = QApplication.instance() or QApplication(["soak"])
    win = MainWindow()
    win.resize(1200, 800)
    surface = load_example("octant")
    win.set_project(new_project(surface, "octant", str(example_path("octant")), 0.12))
    win.show()
    rng = random.Random(args.seed)
    soak = Soak(win, rng, folder)
    soak.pump(500)
    base_threads = threading.active_count()

    t0 = time.perf_counter()
    memory, failures = [], []
    for k in range(args.edits):
        try:
            kind = soak.edit()
        except Exception as exc:  # an edit that raised is a bug: record it, go on
            failures.append(f"edit {k}: {type(exc).__name__}: {exc}")
            traceback.print_exc()
            kind = "raised"
        soak.pump(rng.uniform(0, 300))
        for problem in soak.check():
            failures.append(f"edit {k} ({kind}): {problem}")
        if threading.active_count() > base_threads + 4:
            failures.append(f"edit {k}: {threading.active_count()} threads (started with {base_threads})")
        memory.append(rss_mb())
        if (k + 1) % 100 == 0:
            print(f"{k + 1:5d} edits  {time.perf_counter() - t0:7.1f} s  RSS {memory[-1]:7.1f} MB  "
                  f"nodes {win.project.result.mesh.n_nodes if win.project.result else 0:5d}  "
                  f"failures {len(failures)}", flush=True)
    soak.settle()
    for problem in soak.check():
        failures.append(f"at the end: {problem}")
    seconds = time.perf_counter() - t0

    mem = np.array(memory)
    half = len(mem) // 2
    slope = float(np.polyfit(np.arange(half, len(mem)), mem[half:], 1)[0]) * 100 if len(mem) >= 20 else 0.0
    grew = slope > args.max_growth
    if grew:
        failures.append(f"memory grows {slope:.2f} MB per 100 edits over the second half "
                        f"(limit {args.max_growth:g})")
    win.close()
    leftovers = sorted(p.name for p in (folder / "recovery").glob("*")) if (folder / "recovery").exists() else []
    if leftovers:
        failures.append(f"recovery files left after a normal close: {leftovers}")

    lines = [
        "# Soak test",
        "",
        f"`tests/soak.py --edits {args.edits} --seed {args.seed}`, {time.strftime('%Y-%m-%d %H:%M')}, "
        f"{platform.node()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f} at the end.",
        "",
        "| measure | value |",
        "|---|---|",
        f"| edits | {args.edits} in {seconds:.0f} s |",
        f"| consistency failures | {len(failures)} |",
        f"| memory (RSS) first / at half / last / max | {mem[0]:.0f} / {mem[half]:.0f} / {mem[-1]:.0f} / "
        f"{mem.max():.0f} MB |",
        f"| memory trend over the second half | {slope:+.2f} MB per 100 edits (limit {args.max_growth:g}) |",
        f"| solve threads alive at once (sampled) | at most {soak.max_threads} |",
        f"| runs started | {win.runner.runs_started} (ended: "
        + ", ".join(f"{k} {v}" for k, v in soak.outcomes.most_common()) + "; the rest were replaced by "
        "a newer run or cancelled by an undo) |",
        f"| edits after which the document held a result | {soak.with_result} |",
        f"| undo stack at the end | {len(win.document.history)} (limit {win.document.limit}) |",
        "",
        "Edits made: " + ", ".join(f"{k} {v}" for k, v in sorted(soak.counts.items())) + ".",
        "",
        "Errors shown to the user (refused edits, failed solves; expected, not failures): "
        + (", ".join(f"{k!r} {v}" for k, v in soak.errors.most_common()) or "none") + ".",
        "",
    ]
    if failures:
        lines += ["Failures:", ""] + [f"- {f}" for f in failures[:50]] + [""]
    text = "\n".join(lines)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    app.processEvents()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
