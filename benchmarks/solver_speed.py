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
  example (drape, solve, pattern, metrics), woven or isotropic; ``SURFACE-`` in
  front takes another example (``saddle-woven2500``), ``@ANGLE`` behind sets the
  weft angle (``woven2500@30``);
* ``sweepK``: issue 23's orientation sweep of the woven octant at spacing 0.025,
  K angles, 2 worker processes (``iterations`` is the sum over the solves,
  ``rejected`` the most iterations of one solve).

``rejected`` counts iterations whose step was rejected (EN unchanged).

One process per run, so no tree sees the other's caches.

``--same [--nodes 700] [--old TREE]`` prints instead the same-results table: every case of
``tests/test_solver_speed.py`` solved on the reference path (``reuse=False``) and on the quick path
of this tree (and of the old tree's, with ``--old``), with EN, errors, nodes and factorisations, and
whether the quick path is within the issue's tolerances.
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
    factorise = solver._Round.factorise

    def counted(*a, **k):  # SuperLU's or QDLDL's factorisations
        count[0] += 1
        return factorise(*a, **k)

    solver._Round.factorise = counted
    if case.startswith("sweep"):
        return sweep_child(int(case[5:]))
    name, _, rest = case.rpartition("-")
    rest, _, angle = rest.partition("@")
    s = load_example(name or "octant")
    material = "isotropic" if rest.startswith("iso") else "woven"
    nodes = 2500 if rest == "dart" else int(rest.lstrip("wovenis"))
    settings = FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material],
                               angle_deg=float(angle or 0.0))
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
            "rejected": _rejected(r.history), "EN": m["energy"], "boundary": m["boundary_error_pct"],
            "area": m["area_error_pct"], "nodes": m["nodes"]}


def _rejected(history) -> int:
    """Iterations whose step was rejected: EN unchanged from the iteration before."""
    return sum(1 for a, b in zip(history, history[1:]) if a == b)


def sweep_child(angles: int) -> dict:
    """issue 23's target: ``python -m core sweep octant --spacing 0.025 --angles K``, 2 workers."""
    from core.examples import load_example
    from core.mesh import MATERIALS
    from core.pipeline import FlattenSettings
    from core.sweep import sweep

    settings = FlattenSettings(0.025, material=MATERIALS["woven"])
    s = load_example("octant")
    t = time.perf_counter()
    r = sweep(s, settings, angles=angles, workers=2)
    seconds = time.perf_counter() - t
    its = [int(x.get("iterations", 0)) for x in r.rows]
    b = r.best
    return {"seconds": seconds, "solve": seconds, "F": 0, "it": sum(its), "rejected": max(its),
            "EN": b["energy"], "boundary": b["boundary_error_pct"], "area": b["area_error_pct"],
            "nodes": b["nodes"], "best_angle": b["angle_deg"]}


SAME_CURVE = [[1.0, 0.5], [0.75, 0.52], [0.45, 0.5]]  # tests/test_solver_speed.py's curve dart


def same_cases() -> list[str]:
    """The cases of tests/test_solver_speed.py: surface:material:dart:yarn[:warm]."""
    from core.examples import example_names

    cases = ["octant:woven:-:-", "octant:isotropic:-:-", "octant:woven:plane:-", "garment:woven:-:-",
             "saddle:woven:-:yarn", "saddle:isotropic:-:-", "cone:woven:-:-", "half_cylinder:woven:-:-",
             "half_cylinder:isotropic:plane:-"]
    cases += [f"{n}:{m}:curve:{y}" for n in example_names() for m, y in (("woven", "-"), ("woven", "yarn"),
                                                                         ("isotropic", "-"))]
    cases += [f"{n}:woven:curve:-:warm" for n in example_names() if n != "octant"]
    return cases


def same_child(case: str, nodes: int, reuse_values: list[bool]) -> dict:
    """One case of the same-results table in this tree: the quick and/or the reference path."""
    import dataclasses

    import numpy as np

    import core.solver as solver
    from core.darts import CurveDart, PlaneDart
    from core.drape import drape
    from core.energy import YarnConstraint, yarn_plane
    from core.examples import load_example
    from core.mesh import MATERIALS
    from core.pipeline import FlattenSettings, flatten
    from core.quadrature import region_area

    name, material, dart, yarn, *warm = case.split(":")
    s = load_example(name)
    settings = FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material])
    initial = flatten(s, settings).state() if warm else None
    if dart != "-":
        d = (CurveDart(np.array(SAME_CURVE), name="curve dart") if dart == "curve"
             else PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart"))
        settings = dataclasses.replace(settings, darts=(d,))
    if yarn != "-":  # a weft yarn along the seed's row (as the tests)
        dr = drape(s, settings.drape_settings(), settings.material)
        row = np.flatnonzero(dr.mesh.ij[:, 0] == 0)
        row = row[np.argsort(dr.mesh.ij[row, 1])]
        seed = int(np.flatnonzero((dr.mesh.ij[:, 0] == 0) & (dr.mesh.ij[:, 1] == 0))[0])
        normal = s.evaluate(dr.uv[[seed]]).normal[0]
        settings = dataclasses.replace(settings, yarns=(
            YarnConstraint("weft", 0, yarn_plane(dr.xyz[[row[0], row[-1]]], normal), 1000.0),))
    count = [0]
    factorise = solver._Round.factorise

    def counted(*a, **k):
        count[0] += 1
        return factorise(*a, **k)

    solver._Round.factorise = counted
    made = FlattenSettings.solver_options
    out = {}
    for reuse in reuse_values:
        FlattenSettings.solver_options = lambda self, reuse=reuse: dataclasses.replace(made(self), reuse=reuse)
        count[0] = 0
        m = flatten(s, settings, initial=initial).metrics
        out["quick" if reuse else "ref"] = {"EN": m["energy"], "boundary": m["boundary_error_pct"],
                                            "area": m["area_error_pct"], "nodes": m["nodes"], "F": count[0],
                                            "status": m["solver_status"]}
    return out


def same_table(old: Path | None, new: Path, nodes: int) -> str:
    """Reference path, this tree's quick path and (with --old) the old tree's quick path, every case."""
    head = ("| case | EN ref | quick / ref - 1 | boundary % ref / quick | area % ref / quick | nodes ref / quick "
            "| F ref / quick | within |")
    lines = [head, "|" + "---|" * 8]
    if old is not None:
        lines[0] += " old quick / ref - 1 | old boundary % | old within |"
        lines[1] += "---|---|---|"

    def within(q, r):
        return (q["status"] == r["status"] == "converged" and q["EN"] <= r["EN"] * (1 + 1e-3)
                and abs(q["boundary"] - r["boundary"]) <= 0.02 and abs(q["area"] - r["area"]) <= 0.02
                and abs(q["nodes"] - r["nodes"]) <= 0.01 * r["nodes"])

    for case in same_cases():
        args = ["--same-child", case, "--nodes", str(nodes)]
        got = json.loads(subprocess.run([sys.executable, __file__, *args, "--tree", str(new), "--paths", "both"],
                                        capture_output=True, text=True, check=True, cwd=str(new)).stdout
                         .strip().splitlines()[-1])
        r, q = got["ref"], got["quick"]
        line = (f"| {case} | {r['EN']:.10g} | {q['EN'] / r['EN'] - 1:+.2e} | {r['boundary']:.4f} / "
                f"{q['boundary']:.4f} | {r['area']:.4f} / {q['area']:.4f} | {r['nodes']} / {q['nodes']} | "
                f"{r['F']} / {q['F']} | {'yes' if within(q, r) else '**no**'} |")
        if old is not None:
            o = json.loads(subprocess.run([sys.executable, __file__, *args, "--tree", str(old), "--paths", "quick"],
                                          capture_output=True, text=True, check=True, cwd=str(old)).stdout
                           .strip().splitlines()[-1])["quick"]
            line += f" {o['EN'] / r['EN'] - 1:+.2e} | {o['boundary']:.4f} | {'yes' if within(o, r) else '**no**'} |"
        lines.append(line)
        print(line, flush=True)
    return "\n".join(lines) + "\n"


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
    ap.add_argument("--same", action="store_true",
                    help="print the same-results table (reference / quick path, tests/test_solver_speed.py's cases)")
    ap.add_argument("--nodes", type=int, default=700, help="nodes of the --same cases")
    ap.add_argument("--same-child", help=argparse.SUPPRESS)
    ap.add_argument("--paths", default="both", help=argparse.SUPPRESS)
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--tree", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.same_child:
        sys.path.insert(0, str(args.tree))
        paths = {"both": [True, False], "quick": [True]}[args.paths]
        print(json.dumps(same_child(args.same_child, args.nodes, paths)))
        return 0
    if args.same:
        text = same_table(args.old, args.new, args.nodes)
        if args.out:
            args.out.write_text(text)
        return 0
    if args.child:  # one run, in the tree given
        sys.path.insert(0, str(args.tree))
        print(json.dumps(child(args.child)))
        return 0
    load = "load {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    lines = [f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, Python {sys.version.split()[0]}, "
             f"{load} at the start; {args.repeat} runs per tree, alternating, medians", "",
             "| case | tree | total s | solve s | factorisations | iterations | rejected | EN | boundary % | area % "
             "| nodes |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for case in args.cases.split(","):
        runs = {"old": [], "new": []}
        for _ in range(args.repeat):
            for name in ("old", "new"):
                runs[name].append(run(args.old if name == "old" else args.new, case))
        for name in ("old", "new"):
            rs, last = runs[name], runs[name][-1]
            lines.append(f"| {case} | {name} | {statistics.median(r['seconds'] for r in rs):.3f} | "
                         f"{statistics.median(r['solve'] for r in rs):.3f} | {last['F']} | {last['it']} | "
                         f"{last.get('rejected', '')} | "
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
