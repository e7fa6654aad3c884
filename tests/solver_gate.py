"""A solver run that lasts until the test lets it go (not a test module).

Window tests that need a run in flight (live frames, Pause, Stop, a camera drag during a solve) make
it last this way, never by hoping the real solve is slow enough: on a busy machine a "long" solve
can still end before the test looks, and on a quiet one it can end sooner than expected.

``HeldSolver(monkeypatch, "paper", after=5)`` registers, under the solver's own name, an entry of the
solver registry (:mod:`flatweave.method.solvers`) whose ``"module:function"`` is :func:`held` here. It runs the
real solver and, after that run's first ``after`` snapshots, holds the run until ``release`` is set:

* ``mode="block"``: the solve thread waits inside an iteration (its next snapshot does not come);
* ``mode="repeat"``: the solve thread goes on making snapshots of the state it holds, each after a
  real energy and gradient evaluation and a short wait on ``release``: a run in flight that keeps
  the solve thread working, makes live frames, answers Pause and Stop between its snapshots, and
  never ends on its own.

Once released the real solver goes on from where it was held: the held snapshots change nothing of
its state, so the run's result is the real solver's. Every run of the solver is held until the
first release (the event stays set); ``after`` counts each run's own snapshots. A hold gives up
after ``timeout`` seconds so that a failing test cannot hang the session.
"""

from __future__ import annotations

import dataclasses
import threading
import time

import flatweave.method.solvers
from flatweave.method.energy import Energy
from flatweave.method.metrics import spring_strain
from flatweave.method.solver import Snapshot

__all__ = ["HeldSolver", "held"]

_GATES: dict[str, HeldSolver] = {}  # solver name -> the gate its registry entry runs through


class HeldSolver:
    """Holds the runs of solver ``name`` after ``after`` snapshots until :attr:`release` is set.

    ``held`` is set once a run is being held; ``held_snapshots`` counts the snapshots made while held
    (repeat mode); ``snapshots`` counts every snapshot handed out, real or held."""

    def __init__(self, monkeypatch, name: str = "paper", after: int = 1, mode: str = "repeat",
                 step: float = 0.01, timeout: float = 120.0):
        assert mode in ("block", "repeat"), mode
        entry = flatweave.method.solvers.solver_entry(name)
        assert entry.iterative, f"{name} is not an iterative solver"
        self.name, self.after, self.mode, self.step, self.timeout = name, after, mode, step, timeout
        self.inner = entry.run  # the real solver, imported now (the entry is replaced below)
        self.release = threading.Event()
        self.held = threading.Event()
        self.snapshots = 0
        self.held_snapshots = 0
        monkeypatch.setitem(_GATES, name, self)
        held_entry = dataclasses.replace(entry, target=f"{__name__}:held")
        monkeypatch.setitem(flatweave.method.solvers._BY_NAME, name, held_entry)

    def _hold(self, run):
        """Generator: the held part of a run (nothing in ``run`` changes)."""
        self.held.set()
        deadline = time.monotonic() + self.timeout
        if self.mode == "block":
            self.release.wait(self.timeout)
            return
        energy = Energy(run.problem.surface, run.mesh, run.terms)
        while not self.release.is_set() and time.monotonic() < deadline:
            E, _ = energy.value_and_grad(run.uv)  # the solve thread works as a solve's would
            xyz = run.problem.surface.points(run.uv)
            snap = Snapshot(run.nit, E, run.nfev, run.mesh, run.uv.copy(), xyz, spring_strain(xyz, run.mesh),
                            False, time.perf_counter() - run.t0)
            self.release.wait(self.step)
            self.held_snapshots += 1
            self.snapshots += 1
            yield snap


def held(run):
    """The registry's function for a held solver: the real one, held after ``after`` snapshots."""
    gate = _GATES[run.options.method]
    inner = gate.inner(run)
    made = 0
    try:
        for snap in inner:
            gate.snapshots += 1
            yield snap
            made += 1
            if made == gate.after and not gate.release.is_set():
                yield from gate._hold(run)
    finally:
        inner.close()
