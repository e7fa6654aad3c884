"""Population control in one solve: where nodes leave and come back, and what an iteration costs.

    .venv/bin/python benchmarks/population.py [--sizes 10000,40000] [--materials woven,isotropic]
        [--out benchmarks/results/population.md]

For every (material, size) on the octant, from the same drape:

1. the fast solver as users run it (population control on): every change of
   population, at its iteration and time, with the nodes deleted and refilled and
   the domain edge they lie nearest to (u0, u1, v0, v1, by (u, v));
2. per call medians of the Newton assembly (``_Normal.assemble_exact``), the
   residuals (``_residuals``), the factorisation (``_Round.factorise``) and a
   round's set-up (``_Round.__init__``), with population control and on a fixed
   population (``delete=False, refill=False``), the two runs alternating;
3. whether the live population is in lattice order at every snapshot (the order
   the refill and the drape give; a node order out of it would cost cache
   locality in the assembly and fill in the factorisation).

``--compare CASES`` instead runs ``core.pipeline.flatten`` with the refill rules
``--rules`` (``before``: every refill that finds nodes is made, as before
session 9; ``today``: a refill that repeats an earlier one, the same positions
added to the same population, is not made; ``refilled-once``: the candidate
tried and dropped, a refilled node deleted again is never refilled), alternating,
on CASES (``surface:material:nodes,...``): seconds, iterations, nodes, EN, the
boundary and area errors and the uncovered share.

``--trees OLD,NEW`` runs ``core.pipeline.flatten`` in each tree (a checkout of
the code before and after a change; this script runs there with ``--root``, one
process per tree and repeat, alternating) on ``--cases`` (``surface:material:
nodes[:dart]``; ``dart``: the curve dart of tests/test_solver_speed.py):
median seconds, iterations, the rejected Levenberg-Marquardt steps (iterations
whose energy is the one before), factorisations, nodes, EN, the boundary and
area errors and the uncovered share.

Timings depend on the load (2 cores, other work running): the one-minute load
average is printed before and after.
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

ROOT = Path(__file__).resolve().parent.parent
if "--root" in sys.argv:  # measure another tree (an old one, for --trees) with this script
    sys.path.insert(0, sys.argv[sys.argv.index("--root") + 1])
else:
    sys.path.insert(0, str(ROOT))

import core.solver as solver  # noqa: E402
from core.drape import drape  # noqa: E402
from core.examples import load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.pipeline import FlattenSettings, flatten, make_problem  # noqa: E402
from core.quadrature import region_area  # noqa: E402

TIMED = ((solver._Normal, "assemble_exact"), (solver, "_residuals"), (solver._Round, "factorise"),
         (solver._Round, "__init__"))


class Timer:
    """Wraps the functions in TIMED; ``calls[name]`` lists each call's seconds."""

    def __init__(self):
        self.calls: dict[str, list[float]] = {}
        self._saved = []

    def __enter__(self):
        for owner, name in TIMED:
            f = getattr(owner, name)
            self._saved.append((owner, name, f))

            def timed(*a, _f=f, _name=name, **k):
                t0 = time.perf_counter()
                try:
                    return _f(*a, **k)
                finally:
                    self.calls.setdefault(_name, []).append(time.perf_counter() - t0)

            setattr(owner, name, timed)
        return self

    def __exit__(self, *exc):
        for owner, name, f in self._saved:
            setattr(owner, name, f)


def nearest_edge(surface, uv: np.ndarray) -> np.ndarray:
    """(k,) index 0..3 of the domain edge (u0, u1, v0, v1) nearest each (u, v)."""
    d = surface.domain
    gaps = np.column_stack([uv[:, 0] - d[0, 0], d[0, 1] - uv[:, 0], uv[:, 1] - d[1, 0], d[1, 1] - uv[:, 1]])
    return np.argmin(np.abs(gaps), axis=1)


EDGES = ("u0", "u1", "v0", "v1")


def _sides(surface, uv: np.ndarray) -> str:
    if not len(uv):
        return ""
    counts = np.bincount(nearest_edge(surface, uv), minlength=4)
    return " ".join(f"{e} {c}" for e, c in zip(EDGES, counts, strict=True) if c)


def lattice_sorted(ij: np.ndarray) -> bool:
    return bool((np.lexsort((ij[:, 1], ij[:, 0])) == np.arange(len(ij))).all())


def run(surface, problem, d, population: bool) -> dict:
    """One solve from the drape; its population changes and per-call times."""
    opts = solver.SolverOptions(refill=population, delete=population)
    changes = []
    in_order = True
    with Timer() as timer:
        t0 = time.perf_counter()
        gen = solver.iterate(problem, solver.State(d.mesh, d.uv), opts)
        prev = {tuple(k): u for k, u in zip(d.mesh.ij.tolist(), d.uv, strict=True)}
        while True:
            try:
                snap = next(gen)
            except StopIteration as done:
                res = done.value
                break
            in_order &= lattice_sorted(snap.mesh.ij)
            if not snap.population_changed:
                continue
            now = {tuple(k): u for k, u in zip(snap.mesh.ij.tolist(), snap.uv, strict=True)}
            gone = np.array([prev[k] for k in prev.keys() - now.keys()]).reshape(-1, 2)
            new = np.array([now[k] for k in now.keys() - prev.keys()]).reshape(-1, 2)
            changes.append({"iteration": snap.iteration, "seconds": snap.seconds, "nodes": len(now),
                            "deleted": len(gone), "refilled": len(new), "deleted_at": _sides(surface, gone),
                            "refilled_at": _sides(surface, new), "energy": snap.energy})
            prev = now
        secs = time.perf_counter() - t0
    medians = {name: (len(v), float(np.median(v))) for name, v in timer.calls.items()}
    return {"seconds": secs, "iterations": res.nit, "nodes": res.mesh.n_nodes, "energy": res.fun,
            "changes": changes, "medians": medians, "in_order": in_order}


class RefilledOnce:
    """The candidate refill rule tried in session 9 (docs/decisions.md, "Population churn"), patched
    in: a position whose node came from a refill counts double when it loses it, so a refilled node
    deleted again is never refilled (today: every position gets two deletions)."""

    def __enter__(self):
        self._record, self._refill = solver._Population.record, solver._Run.try_refill

        def record(pop, ij):
            born = getattr(pop, "born", set())
            for key in map(tuple, ij.tolist()):
                pop.counts[key] = pop.counts.get(key, 0) + (2 if key in born else 1)
            pop.deleted += len(ij)

        def try_refill(run, at=None, _refill=self._refill):
            before = set(map(tuple, run.mesh.ij.tolist()))
            added = _refill(run, at)
            if added:
                run.pop.born = getattr(run.pop, "born", set()) | (set(map(tuple, run.mesh.ij.tolist())) - before)
            return added

        solver._Population.record, solver._Run.try_refill = record, try_refill
        return self

    def __exit__(self, *exc):
        solver._Population.record, solver._Run.try_refill = self._record, self._refill


class RepeatsRefills:
    """The refill before session 9's repeat check: every refill that finds nodes is made."""

    def __enter__(self):
        self._refill = solver._Run.try_refill

        def try_refill(run, at=None, _refill=self._refill):
            run.refills.clear()
            return _refill(run, at)

        solver._Run.try_refill = try_refill
        return self

    def __exit__(self, *exc):
        solver._Run.try_refill = self._refill


class _Today:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        pass


RULES = {"before": RepeatsRefills, "today": None, "refilled-once": RefilledOnce}


def compare(cases: str, repeat: int, rules: str = "before,today") -> str:
    """Refill rules side by side, alternating (markdown table)."""
    rows = []
    for case in cases.split(","):
        name, material, nodes = case.split(":")
        s = load_example(name)
        st = FlattenSettings(float(np.sqrt(region_area(s) / int(nodes))), material=MATERIALS[material])
        got = {rule: [] for rule in rules.split(",")}
        for _ in range(repeat):
            for variant in got:
                with (RULES[variant] or _Today)():
                    t0 = time.perf_counter()
                    r = flatten(s, st)
                    got[variant].append((time.perf_counter() - t0, r.metrics))
        for variant, runs in got.items():
            m = runs[0][1]
            secs = float(np.median([t for t, _ in runs]))
            rows.append([f"{name}, {material}, ~{int(nodes):,}", variant, f"{secs:.2f}", m["iterations"],
                         f"{m['nodes']:,}", f"{m['energy']:.6e}", f"{m['boundary_error_pct']:.4f}",
                         f"{m['area_error_pct']:.4f}", f"{m['uncovered_pct']:.3f}", m["nodes_refilled"]])
        print(table(HEAD_CMP, rows[-len(got):]), flush=True)
    return table(HEAD_CMP, rows)


HEAD_CMP = ["case", "rule", "file to pattern s (median)", "iterations", "nodes", "EN", "boundary error %",
            "area error %", "uncovered %", "refilled"]


CURVE = ((1.0, 0.5), (0.75, 0.52), (0.45, 0.5))  # tests/test_solver_speed.py's CURVE


def measure(cases: str) -> list[dict]:
    """Each case solved once in this process's tree (``--root``): one dict per case."""
    import json

    from core.darts import CurveDart

    count = [0]
    factorise = solver._Round.factorise

    def counted(*a, **k):
        count[0] += 1
        return factorise(*a, **k)

    solver._Round.factorise = counted
    out = []
    for case in cases.split(","):
        name, material, nodes, *dart = case.split(":")
        s = load_example(name)
        st = FlattenSettings(float(np.sqrt(region_area(s) / int(nodes))), material=MATERIALS[material],
                             darts=(CurveDart(np.array(CURVE), name="curve dart"),) if dart else ())
        count[0] = 0
        t0 = time.perf_counter()
        r = flatten(s, st)
        secs = time.perf_counter() - t0
        h = np.asarray(r.history)
        m = r.metrics
        out.append({"case": case, "seconds": secs, "iterations": m["iterations"],
                    "rejected": int((np.diff(h) == 0).sum()) if len(h) > 1 else 0, "factorisations": count[0],
                    "nodes": m["nodes"], "energy": m["energy"], "boundary": m["boundary_error_pct"],
                    "area": m["area_error_pct"], "uncovered": m["uncovered_pct"], "status": m["solver_status"]})
        print(json.dumps(out[-1]), flush=True)
    return out


HEAD_TREES = ["case", "tree", "s (median)", "iterations", "rejected", "factorisations", "nodes", "EN",
              "boundary error %", "area error %", "uncovered %"]


def trees(paths: str, cases: str, repeat: int) -> str:
    """Each case in each tree, alternating, ``repeat`` times (a process per tree and run)."""
    import json
    import subprocess

    names = paths.split(",")
    rows = []
    for case in cases.split(","):
        got = {p: [] for p in names}
        for _ in range(repeat):
            for p in names:
                done = subprocess.run([sys.executable, __file__, "--root", p, "--measure", case],
                                      capture_output=True, text=True, check=True)
                got[p].append(json.loads(done.stdout.strip().splitlines()[-1]))
        for p, runs in got.items():
            m = runs[0]
            same = all({k: v for k, v in r.items() if k != "seconds"} == {k: v for k, v in m.items() if k != "seconds"}
                       for r in runs)
            name, material, nodes, *dart = case.split(":")
            rows.append([f"{name}, {material}, ~{int(nodes):,}" + (", curve dart" if dart else ""),
                         p if same else f"{p} (repeats differ: the first shown)",
                         f"{np.median([r['seconds'] for r in runs]):.2f}", m["iterations"], m["rejected"],
                         m["factorisations"], f"{m['nodes']:,}", f"{m['energy']:.6e}", f"{m['boundary']:.4f}",
                         f"{m['area']:.4f}", f"{m['uncovered']:.3f}"])
        print(table(HEAD_TREES, rows[-len(names):]), flush=True)
    return table(HEAD_TREES, rows)


def table(head, rows) -> str:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10000")
    ap.add_argument("--materials", default="woven,isotropic")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "population.md"))
    ap.add_argument("--compare", default=None, help="surface:material:nodes,...")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--rules", default="before,today", help="refill rules to compare: " + ",".join(RULES))
    ap.add_argument("--trees", default=None, help="OLD,NEW: checkouts to compare on --cases")
    ap.add_argument("--cases", default="octant:isotropic:10000", help="surface:material:nodes[:dart],...")
    ap.add_argument("--root", default=None, help="the tree this process measures (set by --trees)")
    ap.add_argument("--measure", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.measure:
        measure(args.measure)
        return 0
    load0 = os.getloadavg()[0]
    if args.trees:
        text = trees(args.trees, args.cases, args.repeat)
        load1 = os.getloadavg()[0]
        head = (f"# Trees {args.trees} ({_dt.date.today().isoformat()})\n\n"
                f"`benchmarks/population.py --trees {args.trees} --cases {args.cases} --repeat {args.repeat}`; "
                f"{platform.node()}, {os.cpu_count()} cores, load {load0:.2f} before, {load1:.2f} after; "
                "alternating runs.\n\n")
        Path(args.out).write_text(head + text + "\n")
        return 0
    if args.compare:
        text = compare(args.compare, args.repeat, args.rules)
        load1 = os.getloadavg()[0]
        head = (f"# Refill rules {args.rules} ({_dt.date.today().isoformat()})\n\n"
                f"`benchmarks/population.py --compare {args.compare} --repeat {args.repeat} --rules {args.rules}`; "
                f"{platform.node()}, "
                f"{os.cpu_count()} cores, load {load0:.2f} before, {load1:.2f} after; alternating runs.\n\n")
        Path(args.out).write_text(head + text + "\n")
        return 0
    surface = load_example("octant")
    parts = []
    summary = []
    for nodes in (int(s) for s in args.sizes.split(",")):
        for material in args.materials.split(","):
            st = FlattenSettings(float(np.sqrt(region_area(surface) / nodes)), material=MATERIALS[material])
            d = drape(surface, st.drape_settings(), st.material)
            problem = make_problem(surface, st)
            fixed = run(surface, problem, d, population=False)
            pop = run(surface, problem, d, population=True)
            name = f"octant, {material}, {d.mesh.n_nodes:,} nodes"
            ms = {k: f"{1e3 * v[1]:.1f} ({v[0]})" for k, v in pop["medians"].items()}
            mf = {k: f"{1e3 * v[1]:.1f} ({v[0]})" for k, v in fixed["medians"].items()}
            for label, r, m in (("population control", pop, ms), ("fixed population", fixed, mf)):
                summary.append([name, label, f"{r['seconds']:.2f}", r["iterations"], len(r["changes"]),
                                f"{r['nodes']:,}", f"{r['energy']:.6e}", *(m.get(k, "-") for _, k in TIMED),
                                "yes" if r["in_order"] else "no"])
            rows = [[c["iteration"], f"{c['seconds']:.2f}", f"{c['nodes']:,}", c["deleted"], c["deleted_at"],
                     c["refilled"], c["refilled_at"], f"{c['energy']:.5e}"] for c in pop["changes"]]
            parts.append(f"### {name}: population changes\n\n" + table(
                ["iteration", "s", "nodes", "deleted", "deleted near", "refilled", "refilled near", "EN"], rows))
            print(parts[-1], flush=True)
    load1 = os.getloadavg()[0]
    head = ["case", "run", "solve s", "iterations", "population changes", "nodes", "EN",
            *(f"{k} ms (calls)" for _, k in TIMED), "lattice order"]
    text = (f"# Population control in one solve ({_dt.date.today().isoformat()})\n\n"
            f"`benchmarks/population.py --sizes {args.sizes} --materials {args.materials}`; "
            f"{platform.node()}, {os.cpu_count()} cores, load {load0:.2f} before, {load1:.2f} after. "
            "Per call medians in ms (calls in the run).\n\n" + table(head, summary) + "\n\n"
            + "\n\n".join(parts) + "\n")
    print(table(head, summary))
    Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
