"""Population rules for a warm dart re-solve, tried as prototypes (issue 20).

Run with the edge-churn rule off (``core.pipeline.EDGE_REFILL_SPACINGS = 0``, set
below): "today" in the tables is the paper's refill the rules are compared with.

    .venv/bin/python benchmarks/population_rules.py [--nodes 2500] [--repeat 3]
        [--rules cap1,uncovered,...] [--cases octant,garment] [--out FILE]

A dart re-solve on the 2,500-node woven octant spends about a third of its
time in rounds after its first refill: each refill adds a few nodes at the
edge where the net slid, starts a round, and the round lets a few others
slide out. Each rule below changes when the solver refills or deletes, and is
applied by patching ``core`` for the duration of its runs (nothing in ``core``
is changed):

- ``cap1``, ``cap2``: at most one (two) refills in a solve.
- ``uncovered``: a refill only while part of the region is farther than a
  cell diagonal from every node (``metrics["uncovered_pct"]``'s reach) -- the
  issue's "refill only where the dart uncovered the surface".
- ``small-covered``: a refill of at most max(4, 0.2 % of the nodes) nodes is
  skipped while the region is covered in that sense.
- ``gap10``, ``gap25``: a refilled node is kept only where it lands at least
  0.1 (0.25) of a spacing inside the domain's edge (the chord to the nearest of
  its projections onto the domain's four sides): hysteresis against the edge's
  churn, where a node placed a hair inside slides out in the next round.
- ``shallow10``, ``shallow25``: a refill whose every node lands within 0.1 (0.25)
  of a spacing of the edge is skipped while the region is covered (the rule
  ``core.pipeline.edge_churn`` took, at 0.1, without computing the refill twice).
- ``edge10``, ``edge25``: the same without the coverage test.
- ``dead1``: a position emptied once is never refilled (``dead_after`` 1).
- ``back10``, ``back25``: a position emptied earlier in the solve is refilled only
  where its node lands at least 0.1 (0.25) of a spacing inside the edge.
- ``margin``: a node is deleted only once it is beyond the (u, v) domain by
  more than half a spacing (its springs on the surface's extension counted
  whole), so that a node sliding just past the edge stays.
- ``coarse``: the warm state's nodes at even lattice positions re-solved with
  the dart at twice the spacing, carried to the fine lattice
  (:func:`core.multilevel.carry`) and solved there (``dead_after`` 1), as a
  coarse-to-fine start does from the drape.
- ``clip``: ``margin``, and each spring's stiffness weighted by the share of
  its (u, v) segment inside the domain (set at each build, i.e. each round;
  when a round converges and the weights at the nodes' places differ from
  the round's by more than 0.01, the population is built again): the
  issue's "boundary nodes a little beyond the region's edge, their springs
  counted by the part inside", with the weights lagged a round (their
  derivatives are not in the Newton step).
- ``cold``: no rule, but the same settings solved from the drape (the
  solve a project opened with the dart gets): how far today's own warm and
  cold results lie apart.

For every bundled surface and both materials a piece of about ``--nodes``
nodes is solved (no rule), then the curve dart of ``tests/test_solver_speed.py``
is added (and on the octant also its plane dart) and the piece re-solved warm
from the solved state, today and under each rule, alternating, ``--repeat``
times each: median seconds, iterations, the differences in EN, boundary and
area errors and nodes, the share left uncovered, and whether the rule's result
is within issue 20's tolerances of today's (EN within 0.1 % or lower, errors
within 0.02 points).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import datetime as _dt
import os
import platform
import sys
import time
from pathlib import Path
from unittest.mock import patch

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import core.multilevel as multilevel  # noqa: E402
import core.pipeline as pipeline  # noqa: E402
import core.solver as solver  # noqa: E402
from core.coverage import cell_diagonal, uncovered_share  # noqa: E402
from core.darts import CurveDart, PlaneDart  # noqa: E402
from core.examples import example_names, load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.pipeline import FlattenSettings, flatten, make_problem  # noqa: E402
from core.quadrature import region_area  # noqa: E402
from core.region import cover_for  # noqa: E402

pipeline.EDGE_REFILL_SPACINGS = 0.0  # "today": the paper's refill, which the rules change

PLANE = PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart")
CURVE = CurveDart(np.array([[1.0, 0.5], [0.75, 0.52], [0.45, 0.5]]), name="curve dart")


def _covered(run: solver._Run, at) -> bool:
    m = run.mesh
    xyz = at[0] if at is not None else run.problem.surface.points(run.uv)
    return uncovered_share(run.problem.surface, xyz, cell_diagonal(m.r_weft, m.r_warp)) == 0.0


def _capped(cap: int):
    refill = solver._Run.try_refill

    def try_refill(self, at=None):
        done = getattr(self, "_bench_refills", 0)
        if done >= cap:
            return False
        made = refill(self, at)
        self._bench_refills = done + made
        return made
    return patch.object(solver._Run, "try_refill", try_refill)


def _uncovered():
    refill = solver._Run.try_refill
    return patch.object(solver._Run, "try_refill", lambda self, at=None: not _covered(self, at) and refill(self, at))


def _small_covered():
    refill = solver._Run.try_refill

    def try_refill(self, at=None):
        ij, _ = self.problem.refill(self.mesh, self.uv, self.pop.dead(), at)
        if 0 < len(ij) <= max(4, 0.002 * self.mesh.n_nodes) and _covered(self, at):
            return False
        return refill(self, at)
    return patch.object(solver._Run, "try_refill", try_refill)


def _edge_chord(surface, uv: np.ndarray) -> np.ndarray:
    """(k,) the chord from each point to the domain's edge (:meth:`core.region.Cover.edge_chord`)."""
    return cover_for(surface).edge_chord(uv)


def _edge_gap(spacings: float):
    """A refilled node only where it lands at least ``spacings`` of a spacing inside the edge."""
    refill = solver.Problem.refill

    def gapped(self, mesh, uv, dead_ij, at=None):
        ij, new = refill(self, mesh, uv, dead_ij, at)
        if len(ij):
            ok = _edge_chord(self.surface, new) >= spacings * min(mesh.r_weft, mesh.r_warp)
            ij, new = ij[ok], new[ok]
        return ij, new
    return patch.object(solver.Problem, "refill", gapped)


def _shallow(spacings: float):
    """A refill skipped when every node it adds would land within ``spacings`` of a spacing of the
    edge while the region is covered (``uncovered``'s test): the edge's churn, not a hole."""
    refill = solver._Run.try_refill

    def try_refill(self, at=None):
        ij, new = self.problem.refill(self.mesh, self.uv, self.pop.dead(), at)
        if len(ij):
            m = self.mesh
            shallow = _edge_chord(self.problem.surface, new) < spacings * min(m.r_weft, m.r_warp)
            if shallow.all() and _covered(self, at):
                return False
        return refill(self, at)
    return patch.object(solver._Run, "try_refill", try_refill)


def _edge_churn(spacings: float):
    """A refill that would add only nodes landing within ``spacings`` of a spacing of the edge
    finds nothing (no coverage test: each such position is within a spacing and a tenth of the
    nodes it hangs on, inside a cell diagonal)."""
    refill = solver.Problem.refill

    def churn(self, mesh, uv, dead_ij, at=None):
        ij, new = refill(self, mesh, uv, dead_ij, at)
        if len(ij) and (_edge_chord(self.surface, new) < spacings * min(mesh.r_weft, mesh.r_warp)).all():
            return ij[:0], new[:0]
        return ij, new
    return patch.object(solver.Problem, "refill", churn)


def _dead_once():
    """A position that lost its node once in the solve is never refilled (``dead_after`` 1)."""
    init = solver._Population.__init__
    return patch.object(solver._Population, "__init__", lambda self, dead_after=2: init(self, 1))


def _back(spacings: float):
    """A position that lost its node earlier in the solve is refilled only where its node lands at
    least ``spacings`` of a spacing inside the edge (hysteresis for a node coming back)."""
    try_refill = solver._Run.try_refill

    def back(self, at=None):
        refill = self.problem.refill

        def filtered(mesh, uv, dead_ij, at=None):
            ij, new = refill(mesh, uv, dead_ij, at)
            if len(ij):
                before = np.array([self.pop.counts.get(k, 0) > 0 for k in map(tuple, ij.tolist())])
                shallow = _edge_chord(self.problem.surface, new) < spacings * min(mesh.r_weft, mesh.r_warp)
                ij, new = ij[~(before & shallow)], new[~(before & shallow)]
            return ij, new

        with patch.object(self.problem, "refill", filtered):
            return try_refill(self, at)
    return patch.object(solver._Run, "try_refill", back)


@contextlib.contextmanager
def _margin(spacings: float = 0.5):
    made = make_problem

    def make(surface, settings):
        p = made(surface, settings)
        dom = surface.domain
        g = np.linspace(0.0, 1.0, 9)
        uv = np.column_stack([a.ravel() for a in np.meshgrid(dom[0, 0] + g * (dom[0, 1] - dom[0, 0]),
                                                              dom[1, 0] + g * (dom[1, 1] - dom[1, 0]))])
        _, su, sv = surface.derivatives(uv)
        # half a spacing in (u, v) where the chart is longest: at least half a spacing on the surface
        p._bench_margin = np.array([spacings * settings.spacing / np.linalg.norm(su, axis=1).max(),
                                    spacings * settings.spacing / np.linalg.norm(sv, axis=1).max()])
        return p

    def invalid(self, uv_old, uv_new, xyz_old=None, xyz_new=None):
        dom, d = self.surface.domain, self._bench_margin
        bad = np.any((uv_new < dom[:, 0] - d) | (uv_new > dom[:, 1] + d), axis=1)
        if self._invalid is not None:
            bad |= (self._invalid(uv_old, uv_new) if xyz_old is None
                    else self._invalid(uv_old, uv_new, xyz_old, xyz_new))
        return bad

    with patch.object(pipeline, "make_problem", make), patch.object(solver.Problem, "invalid", invalid):
        yield


def _inside_share(a: np.ndarray, b: np.ndarray, dom: np.ndarray) -> np.ndarray:
    """(m,) the share of each (u, v) segment a -> b inside the box ``dom`` (Liang-Barsky clipping)."""
    t0, t1 = np.zeros(len(a)), np.ones(len(a))
    d = b - a
    for k in range(2):
        with np.errstate(divide="ignore", invalid="ignore"):
            lo = (dom[k, 0] - a[:, k]) / d[:, k]
            hi = (dom[k, 1] - a[:, k]) / d[:, k]
        flat = d[:, k] == 0
        inside = (a[:, k] >= dom[k, 0]) & (a[:, k] <= dom[k, 1])
        enter, leave = np.minimum(lo, hi), np.maximum(lo, hi)
        t0 = np.where(flat, np.where(inside, t0, 1.0), np.maximum(t0, enter))
        t1 = np.where(flat, np.where(inside, t1, 0.0), np.minimum(t1, leave))
    return np.clip(t1 - t0, 0.0, 1.0)


@contextlib.contextmanager
def _clip():
    with _margin(), _weighted():
        yield


@contextlib.contextmanager
def _weighted():
    made = pipeline.make_problem  # the margin's, when entered within it

    def make(surface, settings):
        p = made(surface, settings)
        build, dom = p.build, surface.domain

        def weighted(ij, uv):
            mesh = build(ij, uv)
            uv = np.asarray(uv, dtype=float)
            w = _inside_share(uv[mesh.ends[:, 0]], uv[mesh.ends[:, 1]], dom)
            return dataclasses.replace(mesh, k=mesh.k * np.maximum(w, 1e-6))

        p.build = weighted
        p._bench_full_k = build
        return p

    refill = solver._Run.try_refill

    def try_refill(self, at=None):
        if refill(self, at):
            return True
        dom = self.problem.surface.domain
        w = _inside_share(self.uv[self.mesh.ends[:, 0]], self.uv[self.mesh.ends[:, 1]], dom)
        full = self.problem._bench_full_k(self.mesh.ij, self.uv)
        if len(full.k) != len(self.mesh.k):
            return False
        now = self.mesh.k / np.maximum(full.k, 1e-300)
        if np.abs(np.maximum(w, 1e-6) - now).max() <= 0.01:
            return False
        self.mesh = self.problem.build(self.mesh.ij, self.uv)
        return True

    with patch.object(pipeline, "make_problem", make), patch.object(solver._Run, "try_refill", try_refill):
        yield


def _coarse_flatten(surface, settings, initial):
    """The ``coarse`` rule's re-solve: the even nodes at twice the spacing, then the fine lattice."""
    coarse = pipeline._coarser(settings)
    cproblem = make_problem(surface, coarse)
    even = (initial.mesh.ij % 2 == 0).all(axis=1)
    cij, cuv = initial.mesh.ij[even] // 2, initial.uv[even]
    sol = solver.minimize(cproblem, solver.State(cproblem.build(cij, cuv), cuv),
                          dataclasses.replace(coarse.solver_options(), dead_after=1))
    fine = multilevel.carry(surface, make_problem(surface, settings), sol.mesh, sol.uv, settings.material)
    with patch.object(pipeline, "_carried", lambda options, stats: dataclasses.replace(options, dead_after=1)):
        r = flatten(surface, settings, initial=fine)
    r.metrics["iterations"] += sol.nit
    return r


RULES = {"cap1": lambda: _capped(1), "cap2": lambda: _capped(2), "uncovered": _uncovered,
         "small-covered": _small_covered,
         "gap10": lambda: _edge_gap(0.1), "gap25": lambda: _edge_gap(0.25),
         "shallow10": lambda: _shallow(0.1), "shallow25": lambda: _shallow(0.25),
         "edge10": lambda: _edge_churn(0.1), "edge25": lambda: _edge_churn(0.25),
         "dead1": _dead_once, "back10": lambda: _back(0.1), "back25": lambda: _back(0.25),
         "margin": _margin, "clip": _clip,
         "coarse": None, "cold": None}


def re_solve(rule: str | None, surface, settings, initial):
    if rule == "coarse":
        return _coarse_flatten(surface, settings, initial)
    if rule == "cold":
        return flatten(surface, settings)
    with (RULES[rule]() if rule else contextlib.nullcontext()):
        return flatten(surface, settings, initial=initial)


def within(a: dict, b: dict) -> bool:
    return (b["energy"] <= a["energy"] * (1 + 1e-3) and abs(b["boundary_error_pct"] - a["boundary_error_pct"]) <= 0.02
            and abs(b["area_error_pct"] - a["area_error_pct"]) <= 0.02)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, default=2500)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--rules", default=",".join(RULES))
    ap.add_argument("--cases", default=",".join(example_names()), help="surfaces, comma-separated")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    rules = [r for r in args.rules.split(",") if r]
    for r in rules:
        if r not in RULES:
            raise SystemExit(f"unknown rule {r!r}; the rules are {', '.join(RULES)}")
    lines = [f"## Population rules for a warm dart re-solve, {args.nodes:,} nodes "
             f"({_dt.date.today()}, {platform.node()}, {os.cpu_count()} cores, load "
             "{:.2f} {:.2f} {:.2f})".format(*os.getloadavg()), "",
             f"`benchmarks/population_rules.py --nodes {args.nodes} --repeat {args.repeat}`: medians of "
             f"{args.repeat} re-solves each, today's and the rule's alternating; ** a result outside issue 20's "
             "tolerances of today's.", "",
             "| case | rule | s today | s rule | iterations | EN rule/today - 1 | boundary %, rule - today | "
             "area, rule - today | nodes | uncovered % (rule) |", "|---|---|---:|---:|---|---:|---|---:|---|---:|"]
    print("\n".join(lines), flush=True)
    for name in args.cases.split(","):
        for material in ("woven", "isotropic"):
            s = load_example(name)
            settings = FlattenSettings(float(np.sqrt(region_area(s) / args.nodes)), material=MATERIALS[material])
            base = flatten(s, settings)
            for dart in (CURVE, PLANE) if name == "octant" else (CURVE,):
                with_dart = dataclasses.replace(settings, darts=(dart,))
                for rule in rules:
                    times: dict = {None: [], rule: []}
                    results = {}
                    for _ in range(args.repeat):
                        for r in (None, rule):
                            t = time.perf_counter()
                            results[r] = re_solve(r, s, with_dart, base.state())
                            times[r].append(time.perf_counter() - t)
                    a, b = results[None].metrics, results[rule].metrics
                    row = (f"| {name} {material} {dart.name}{'' if within(a, b) else ' **'} | {rule} | "
                           f"{np.median(times[None]):.3f} | {np.median(times[rule]):.3f} | "
                           f"{a['iterations']} / {b['iterations']} | {b['energy'] / a['energy'] - 1:+.2e} | "
                           f"{a['boundary_error_pct']:.3f}, {b['boundary_error_pct'] - a['boundary_error_pct']:+.4f} | "
                           f"{b['area_error_pct'] - a['area_error_pct']:+.4f} | {a['nodes']} / {b['nodes']} | "
                           f"{b['uncovered_pct']:.3f} |")
                    lines.append(row)
                    print(row, flush=True)
    if args.out:
        with open(args.out, "a") as f:
            f.write("\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
