"""Time the orientation sweep (issue 23: a 12-angle sweep on a 2,500-node piece in under 5 s).

    python benchmarks/sweep_speed.py [--repeat 3] [--out benchmarks/results/sweep_speed.md]

Each case runs in this process, alternating between the worker counts; medians of the repeats.
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
    args = ap.parse_args()
    workers = [int(w) for w in args.workers.split(",")]
    lines = [f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, Python {platform.python_version()}, "
             f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())} at the start; medians of {args.repeat}", "",
             "| case | nodes | workers | 12 angles s | solves | iterations (sum) | best angle | refined s | best |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, spacing, material in CASES:
        surface = load_example(name)
        s = FlattenSettings(spacing=spacing, material=MATERIALS[material])
        times = {w: [] for w in workers}
        refined = {w: [] for w in workers}
        last = {}
        for _ in range(args.repeat):
            for w in workers:
                t = time.perf_counter()
                r = sweep(surface, s, angles=12, workers=w)
                times[w].append(time.perf_counter() - t)
                t = time.perf_counter()
                rr = sweep(surface, s, angles=12, workers=w, refine=True)
                refined[w].append(time.perf_counter() - t)
                last[w] = (r, rr)
        for w in workers:
            r, rr = last[w]
            its = sum(int(x.get("iterations", 0)) for x in r.rows)
            lines.append(f"| {name}, {material} | {r.best['nodes']} | {w} | {statistics.median(times[w]):.2f} | "
                         f"{len(r.rows)} | {its} | {r.best['angle_deg']:.2f} | {statistics.median(refined[w]):.2f} | "
                         f"{rr.best['angle_deg']:.3f} |")
        print("\n".join(lines[-len(workers):]), flush=True)
    lines += ["", f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())} at the end"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
