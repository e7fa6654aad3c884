"""A moved or deleted dart: re-solve from the old result's mesh, or drape anew?

    .venv/bin/python benchmarks/moved_dart.py [--spacing 0.025] [--repeat 3] [--out FILE]

The woven octant is solved with a straight curve dart from the edge u = 1 at
v = 0.5 to (0.55, 0.5). The dart is then moved (its mouth and tip shifted in v)
or deleted, and the new settings are solved twice: warm from the old result's
state (the old dart's opening still in the mesh) and from a new drape. The
table gives median seconds, energy, boundary and area errors and iterations of
both; ``core.project.warm_start`` takes a new drape for these edits.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from core.darts import CurveDart  # noqa: E402
from core.examples import load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.pipeline import FlattenSettings, flatten  # noqa: E402


def dart(v: float) -> CurveDart:
    return CurveDart(np.array([[1.0, v], [0.55, v]]), name="dart")


def timed(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def cells(seconds, r):
    m = r.metrics
    return (f"{seconds:.2f} | {m['energy']:.5f} | {m['boundary_error_pct']:.3f} | {m['area_error_pct']:.3f} | "
            f"{m.get('iterations')}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spacing", type=float, default=0.025)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    surface = load_example("octant")
    base = flatten(surface, FlattenSettings(args.spacing, material=MATERIALS["woven"], darts=(dart(0.5),)))
    lines = [f"woven octant, spacing {args.spacing}, {base.mesh.n_nodes} nodes, dart at v = 0.5 solved: "
             f"energy {base.metrics['energy']:.5f}, boundary {base.metrics['boundary_error_pct']:.3f} %, "
             f"area {base.metrics['area_error_pct']:.3f} %; load {os.getloadavg()[0]:.1f}; medians of {args.repeat}",
             "",
             "| edit | warm s | energy | boundary % | area % | it | new drape s | energy | boundary % | area % | it |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, darts in (("moved to v = 0.52", (dart(0.52),)), ("moved to v = 0.55", (dart(0.55),)),
                         ("moved to v = 0.65", (dart(0.65),)), ("deleted", ())):
        settings = dataclasses.replace(base.settings, darts=darts)
        tw, warm = timed(lambda: flatten(surface, settings, initial=base.state()), args.repeat)
        tf, fresh = timed(lambda: flatten(surface, settings), args.repeat)
        lines.append(f"| {label} | {cells(tw, warm)} | {cells(tf, fresh)} |")
        print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
