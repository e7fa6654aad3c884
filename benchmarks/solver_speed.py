"""Side-by-side timing of two source trees (issue 20): the dart re-solve and the octant.

    .venv/bin/python benchmarks/solver_speed.py --old /path/to/old/tree [--new TREE]
        [--repeat 5] [--cases dart,woven2500,woven10000,iso2500,iso10000] [--out FILE]

Every case runs in a fresh Python process of its tree, old and new alternating,
``--repeat`` times; the table gives medians (seconds) and, from the last run of
each tree, factorisations (SuperLU calls), iterations, EN, the boundary and
area errors and the node count. Cases:

* ``dart``: the woven octant at about 2,500 nodes solved, then the plane dart
  of ``benchmarks/suite.py`` added and the piece re-solved warm
  (``flatten(..., initial=)``); the time is that of the re-solve (the base
  solve is not timed);
* ``woven2500`` ... ``iso10000``: file to pattern, ``flatten`` of the octant
  example (drape, solve, pattern, metrics), woven or isotropic.

One process per run, so no tree sees the other's caches.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = ("dart", "woven2500", "woven10000", "iso2500", "iso10000")


def child(case: str) -> dict:
    """Run one case in this process (the tree on sys.path[0]) and report it."""
    import dataclasses

    import numpy as np

    import core.solver as solver
    from core.darts import PlaneDart
    from core.examples import load_example
    from core.mesh import MATERIALS
    from core.pipeline import FlattenSettings, flatten
    from core.quadrature import region_area

    count = [0]
    splu = solver.splu

    def counted(*a, **k):
        count[0] += 1
        return splu(*a, **k)

    solver.splu = counted
    s = load_example("octant")
    material = "isotropic" if case.startswith("iso") else "woven"
    nodes = 2500 if case == "dart" else int(case.lstrip("wovenis"))
    settings = FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material])
    initial = None
    if case == "dart":
        initial = flatten(s, settings).state()
        dart = PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart")
        settings = dataclasses.replace(settings, darts=(dart,))
    count[0] = 0
    t = time.perf_counter()
    r = flatten(s, settings, initial=initial)
    seconds = time.perf_counter() - t
    m = r.metrics
    return {"seconds": seconds, "solve": m["solve_seconds"], "F": count[0], "it": m["iterations"],
            "EN": m["energy"], "boundary": m["boundary_error_pct"], "area": m["area_error_pct"],
            "nodes": m["nodes"]}


def run(tree: Path, case: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", case, "--tree", str(tree)], capture_output=True,
                         text=True, check=True, cwd=str(tree))
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path)
    ap.add_argument("--new", type=Path, default=ROOT)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--out", type=Path)
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--tree", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:  # one run, in the tree given
        sys.path.insert(0, str(args.tree))
        print(json.dumps(child(args.child)))
        return 0
    load = "load {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    lines = [f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, Python {sys.version.split()[0]}, "
             f"{load} at the start; {args.repeat} runs per tree, alternating, medians", "",
             "| case | tree | total s | solve s | factorisations | iterations | EN | boundary % | area % | nodes |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for case in args.cases.split(","):
        runs = {"old": [], "new": []}
        for _ in range(args.repeat):
            for name in ("old", "new"):
                runs[name].append(run(args.old if name == "old" else args.new, case))
        for name in ("old", "new"):
            rs, last = runs[name], runs[name][-1]
            lines.append(f"| {case} | {name} | {statistics.median(r['seconds'] for r in rs):.3f} | "
                         f"{statistics.median(r['solve'] for r in rs):.3f} | {last['F']} | {last['it']} | "
                         f"{last['EN']:.10g} | {last['boundary']:.4f} | {last['area']:.4f} | {last['nodes']} |")
        print("\n".join(lines[-2:]), flush=True)
    lines.append("")
    lines.append("load {:.2f} {:.2f} {:.2f} at the end".format(*os.getloadavg()))
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
