"""Warm re-solve after a dart, this tree against another one, alternating.

    .venv/bin/python benchmarks/curve_dart.py --old /tmp/flatweave-old [--rounds 5] [--repeat 3] [--out FILE]

Two cases of issue 20's core target (a warm re-solve after a dart at about
2,500 nodes):

* curve: the woven octant at spacing 0.025 (about 2,500 nodes), then a curve
  dart through the three points the window test clicks
  (tests/test_app_tools.py ``TARGETS``), drawn along minus their mean (as a
  view from outside would), re-solved from the converged state;
* plane: benchmarks/suite.py's plane dart added to the converged 2,500-node
  woven octant.

Each round runs one child process per tree (``--old`` first, then this one,
the order swapped every round), and each child times ``--repeat`` warm
re-solves of both cases and reports the median; the table gives the median
over the rounds and the results of both trees (they must agree), with the
median process CPU time beside the wall time (on a shared machine the wall
time carries the other jobs' load). ``--old`` is
the root of a copy of the other tree (e.g. ``git archive a0de682 | tar -x -C
DIR``). The one-minute load average is printed with the timings.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TARGETS = [[0.93, 0.3, 0.2], [0.62, 0.58, 0.53], [0.3, 0.85, 0.45]]


def child(repeat: int) -> dict:
    """Run in a child process with the tree's root first on sys.path."""
    import dataclasses

    import numpy as np

    from core.darts import PlaneDart, curve_dart_through
    from core.examples import load_example
    from core.pipeline import FlattenSettings, flatten
    from core.project import new_project
    from core.quadrature import region_area

    s = load_example("octant")
    out = {}
    # the curve dart of the window test
    p = new_project(s, "octant", "x", 0.025)
    base = flatten(s, p.settings)
    T = np.array(TARGETS)
    T /= np.linalg.norm(T, axis=1, keepdims=True)
    U, V = np.linspace(*s.domain[0], 400), np.linspace(*s.domain[1], 400)
    G = np.stack(np.meshgrid(U, V, indexing="ij"), -1).reshape(-1, 2)
    P = s.points(G)
    handles = np.array([G[np.argmin(np.linalg.norm(P - t, axis=1))] for t in T])
    curve = dataclasses.replace(p.settings, darts=(curve_dart_through(s, handles, -T.mean(0)),))
    plane_base_settings = FlattenSettings(float(np.sqrt(region_area(s) / 2_500)))
    plane_base = flatten(s, plane_base_settings)
    plane = dataclasses.replace(plane_base_settings,
                                darts=(PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart"),))
    for name, settings, b in (("curve", curve, base), ("plane", plane, plane_base)):
        times, cpu, r = [], [], None
        for _ in range(repeat):
            t, c = time.perf_counter(), time.process_time()
            r = flatten(s, settings, initial=b.state())
            times.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
        m = r.metrics
        out[name] = {"seconds": float(np.median(times)), "cpu": float(np.median(cpu)),
                     "iterations": m["iterations"], "nodes": m["nodes"],
                     "energy": m["energy"], "boundary": m["boundary_error_pct"], "area": m["area_error_pct"],
                     "deleted": m["nodes_deleted"], "refilled": m["nodes_refilled"], "base_nodes": b.metrics["nodes"]}
    return out


def run_tree(root: Path, repeat: int) -> dict:
    code = (f"import sys, json; sys.path.insert(0, {str(root)!r}); sys.path.insert(1, {str(ROOT / 'benchmarks')!r}); "
            f"import curve_dart; print(json.dumps(curve_dart.child({repeat})))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root)
    if p.returncode != 0:
        raise RuntimeError(f"child in {root} failed:\n{p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def load() -> str:
    return "{:.2f}".format(os.getloadavg()[0])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="root of the tree to compare with")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    import numpy as np

    trees = {"old": args.old.resolve(), "new": ROOT}
    runs: dict[str, list[dict]] = {"old": [], "new": []}
    loads = [load()]
    for k in range(args.rounds):
        for name in (("old", "new") if k % 2 == 0 else ("new", "old")):
            runs[name].append(run_tree(trees[name], args.repeat))
            loads.append(load())
            print(name, {c: round(v["seconds"], 3) for c, v in runs[name][-1].items()}, "load", loads[-1], flush=True)
    lines = [f"Warm re-solve after a dart, {args.rounds} alternating rounds x {args.repeat} re-solves "
             f"(medians); one-minute load {', '.join(loads)}", "",
             "| case | old (s) | new (s) | old / new | CPU old / new (s) | iterations old / new | nodes old / new | "
             "EN new / old - 1 | boundary % old / new | area % old / new | -deleted / +refilled old, new |",
             "|---|---:|---:|---:|---|---|---|---:|---|---|---|"]
    for case in ("curve", "plane"):
        o = float(np.median([r[case]["seconds"] for r in runs["old"]]))
        n = float(np.median([r[case]["seconds"] for r in runs["new"]]))
        co = float(np.median([r[case].get("cpu", np.nan) for r in runs["old"]]))
        cn = float(np.median([r[case]["cpu"] for r in runs["new"]]))
        a, b = runs["old"][-1][case], runs["new"][-1][case]
        lines.append(f"| {case} dart ({a['base_nodes']:,} nodes) | {o:.3f} | {n:.3f} | {o / n:.2f} | "
                     f"{co:.3f} / {cn:.3f} | "
                     f"{a['iterations']} / {b['iterations']} | {a['nodes']} / {b['nodes']} | "
                     f"{b['energy'] / a['energy'] - 1:.2g} | {a['boundary']:.4f} / {b['boundary']:.4f} | "
                     f"{a['area']:.4f} / {b['area']:.4f} | -{a['deleted']}/+{a['refilled']}, "
                     f"-{b['deleted']}/+{b['refilled']} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
