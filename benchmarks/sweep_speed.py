"""Time the orientation sweep (issue 23: a 12-angle sweep on a 2,500-node piece in under 5 s).

    python benchmarks/sweep_speed.py [--repeat 3] [--out benchmarks/results/sweep_speed.md]
    python benchmarks/sweep_speed.py --old /tmp/sweep_old.py   # a pool per sweep (git show a0de682:core/sweep.py)

Each case runs in this process, alternating between the worker counts (and, with --old, between that
module's sweep, which makes a pool per sweep, and ours, which keeps a warm pool); medians of the repeats.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from core.examples import load_example
from core.mesh import MATERIALS
from core.pipeline import FlattenSettings
from core.sweep import sweep

CASES = [("octant", 0.025, "woven"), ("garment", 0.02, "woven"), ("saddle", 0.05, "woven")]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--out", default=None)
    ap.add_argument("--old", default=None, help="a sweep.py to time against ours, alternating")
    ap.add_argument("--cases", default=",".join(c[0] for c in CASES))
    args = ap.parse_args()
    workers = [int(w) for w in args.workers.split(",")]
    sweeps = {"": sweep}
    if args.old:
        import importlib

        # importable by name: its workers (forkserver once our pool's threads run) unpickle its _solve_row
        sys.path.append(str(Path(args.old).resolve().parent))
        old = importlib.import_module(Path(args.old).stem)
        sweeps = {"old ": old.sweep, "new ": sweep}
    variants = [(k, w) for w in workers for k in sweeps]
    lines = [f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, Python {platform.python_version()}, "
             f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())} at the start; medians of {args.repeat}", "",
             "| case | nodes | workers | 12 angles s | solves | iterations (sum) | best angle | refined s | best |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, spacing, material in CASES:
        if name not in args.cases.split(","):
            continue
        surface = load_example(name)
        s = FlattenSettings(spacing=spacing, material=MATERIALS[material])
        times = {v: [] for v in variants}
        refined = {v: [] for v in variants}
        last = {}
        for _ in range(args.repeat):
            for v in variants:
                fn = sweeps[v[0]]
                t = time.perf_counter()
                r = fn(surface, s, angles=12, workers=v[1])
                times[v].append(time.perf_counter() - t)
                t = time.perf_counter()
                rr = fn(surface, s, angles=12, workers=v[1], refine=True)
                refined[v].append(time.perf_counter() - t)
                last[v] = (r, rr)
        rows0 = last[variants[0]][0].rows
        for v in variants:
            r, rr = last[v]
            assert r.rows == rows0, "the sweeps' rows differ"
            its = sum(int(x.get("iterations", 0)) for x in r.rows)
            lines.append(f"| {name}, {material} | {r.best['nodes']} | {v[0]}{v[1]} | "
                         f"{statistics.median(times[v]):.2f} | {len(r.rows)} | {its} | {r.best['angle_deg']:.2f} | "
                         f"{statistics.median(refined[v]):.2f} | {rr.best['angle_deg']:.3f} |")
        print("\n".join(lines[-len(variants):]), flush=True)
    lines += ["", f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())} at the end"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
