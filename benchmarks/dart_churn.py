"""Warm dart re-solves against a reference commit, side by side: same results, how much quicker.

    .venv/bin/python benchmarks/dart_churn.py [--ref 334c087] [--nodes 2500] [--repeat 3]
        [--out benchmarks/results/dart_churn.md]

For every bundled surface and both materials, a piece of about ``--nodes``
nodes is solved, then a dart is added and the piece re-solved warm from the
solved state (``core.pipeline.flatten`` with ``initial=``): the curve dart of
``tests/test_solver_speed.py`` on every surface, and its plane dart on the
octant. Each case runs in a child process on the reference tree (the commit
``--ref``, checked out into a temporary worktree) and on this tree, the two
alternating, ``--repeat`` re-solves each; the table gives the median seconds,
factorisations, iterations, nodes, EN and the boundary and area errors of
both, and whether the results agree within issue 20's tolerances (EN within
0.1 % or lower, errors within 0.02 points, nodes within 1 %).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import dataclasses, json, sys, time
import numpy as np
import core.solver as solver
from core.darts import CurveDart, PlaneDart
from core.examples import load_example
from core.mesh import MATERIALS
from core.pipeline import FlattenSettings, flatten
from core.quadrature import region_area
name, material, kind, nodes, repeat = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
s = load_example(name)
settings = FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material])
dart = (PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart") if kind == "plane" else
        CurveDart(np.array([[1.0, 0.5], [0.75, 0.52], [0.45, 0.5]]), name="curve dart"))
base = flatten(s, settings)
with_dart = dataclasses.replace(settings, darts=(dart,))
count = [0]
factorise = solver._Round.factorise
def counted(*a, **k):
    count[0] += 1
    return factorise(*a, **k)
solver._Round.factorise = counted
times = []
for _ in range(repeat):
    count[0] = 0
    t = time.perf_counter()
    r = flatten(s, with_dart, initial=base.state())
    times.append(time.perf_counter() - t)
m = r.metrics
print(json.dumps({"times": times, "factorisations": count[0], "iterations": m["iterations"], "nodes": m["nodes"],
                  "energy": m["energy"], "boundary": m["boundary_error_pct"], "area": m["area_error_pct"],
                  "status": m["solver_status"]}))
"""


def run(tree: Path, case, nodes: int, repeat: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    p = subprocess.run([sys.executable, "-c", CHILD, *case, str(nodes), str(repeat)], capture_output=True,
                       text=True, env=env, cwd=tree)
    if p.returncode != 0:
        raise RuntimeError(f"case {case} on {tree} failed:\n{p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def agree(new: dict, ref: dict) -> bool:
    return (new["status"] == ref["status"] == "converged" and new["energy"] <= ref["energy"] * (1 + 1e-3)
            and abs(new["boundary"] - ref["boundary"]) <= 0.02 and abs(new["area"] - ref["area"]) <= 0.02
            and abs(new["nodes"] - ref["nodes"]) <= 0.01 * ref["nodes"])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref", default="334c087")
    ap.add_argument("--nodes", type=int, default=2500)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from core.examples import example_names
    cases = [("octant", m, "plane") for m in ("woven", "isotropic")]
    cases += [(n, m, "curve") for n in example_names() for m in ("woven", "isotropic")]
    load = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        ref_tree = Path(tmp) / "ref"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(ref_tree), args.ref],
                       check=True)
        try:
            for case in cases:
                ref = run(ref_tree, case, args.nodes, args.repeat)
                new = run(ROOT, case, args.nodes, args.repeat)
                rows.append((case, ref, new))
                print(case, f"{statistics.median(ref['times']):.3f} -> {statistics.median(new['times']):.3f} s",
                      flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(ref_tree)], check=True)
    lines = [f"# Warm dart re-solves: {args.ref} against this tree", "",
             f"`benchmarks/dart_churn.py --ref {args.ref} --nodes {args.nodes} --repeat {args.repeat}`, "
             f"{_dt.date.today()}, {platform.machine()}, {os.cpu_count()} cores, load {load:.1f} at the start, "
             f"{os.getloadavg()[0]:.1f} at the end. Seconds: median of the re-solves (flatten with initial=, "
             "pattern and metrics included); the reference and this tree alternate, one case at a time.", "",
             "| surface, material, dart | seconds (ref -> new) | factorisations | iterations | nodes | "
             "EN (ref -> new) | boundary % | area % | agree |",
             "|---|---:|---:|---:|---:|---|---|---|---|"]
    for (name, material, kind), ref, new in rows:
        lines.append(
            f"| {name}, {material}, {kind} | {statistics.median(ref['times']):.3f} -> "
            f"{statistics.median(new['times']):.3f} | {ref['factorisations']} -> {new['factorisations']} | "
            f"{ref['iterations']} -> {new['iterations']} | {ref['nodes']} -> {new['nodes']} | "
            f"{ref['energy']:.6g} -> {new['energy']:.6g} | {ref['boundary']:.4f} -> {new['boundary']:.4f} | "
            f"{ref['area']:.4f} -> {new['area']:.4f} | {'yes' if agree(new, ref) else 'NO'} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
