"""The edge-churn rule against the paper's refill, and against the method's own spread (issue 20).

    .venv/bin/python benchmarks/edge_churn.py [--nodes 2500] [--repeat 3] [--cases octant,dome]
        [--cold] [--out FILE]

A refill whose every node would land within ``core.pipeline.EDGE_REFILL_SPACINGS``
of a spacing of the region's edge, while the region is covered, is not made
(:func:`core.pipeline.edge_churn`). For every bundled surface and both materials a
piece of about ``--nodes`` nodes is solved with the paper's refill (the rule
off), then the curve dart of ``tests/test_solver_speed.py`` (and on the octant
also its plane dart) is added and the piece re-solved warm, with the rule and
without, alternating, ``--repeat`` times: median seconds, iterations, refills,
and the rule's EN, boundary and area errors and nodes against the paper's refill.
``--cold`` adds the cold solves of ``tests/test_solver_speed.py``'s cases (every
bundled surface, plain, with darts and with a yarn), once each.

Where the rule's result is outside issue 20's tolerances of the paper's refill
(EN within 0.1 % or lower, errors within 0.02 points), the same solve without
the rule is run again from starts that should not matter, to show how far the
method's own result moves: on the reference path (``SolverOptions(reuse=False)``,
the path before issue 20's quicker steps) and, for a warm re-solve, from the
solved state nudged by 1e-9 of the domain. The row is marked ``as good`` when
the rule's EN and errors are each no worse than the worst of the paper's refill's
results (within the tolerances), ``**`` when not.
"""

from __future__ import annotations

import argparse
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

import core.pipeline as pipeline  # noqa: E402
import core.solver as solver  # noqa: E402
from core.examples import example_names, load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.pipeline import FlattenSettings, flatten  # noqa: E402
from core.quadrature import region_area  # noqa: E402
from tests.test_edge_churn import CURVE, PLANE, no_worse, within  # noqa: E402

def solve(surface, settings, rule: bool, initial=None, reference: bool = False):
    """(result, seconds, refills made) with the rule on or off; ``reference``: SolverOptions(reuse=False)."""
    made = FlattenSettings.solver_options
    refills = [0]
    try_refill = solver._Run.try_refill

    def counted(self, at=None):
        ok = try_refill(self, at)
        refills[0] += ok
        return ok

    with patch.object(pipeline, "EDGE_REFILL_SPACINGS", pipeline.EDGE_REFILL_SPACINGS if rule else 0.0), \
            patch.object(solver._Run, "try_refill", counted), \
            patch.object(FlattenSettings, "solver_options",
                         lambda self: dataclasses.replace(made(self), reuse=not reference)):
        t = time.perf_counter()
        r = flatten(surface, settings, initial=initial)
        return r, time.perf_counter() - t, refills[0]


def nudged(state):
    uv = state.uv + 1e-9 * np.sin(np.arange(state.uv.size)).reshape(state.uv.shape)
    return dataclasses.replace(state, uv=uv)


def compare(surface, settings, initial, repeat: int) -> str:
    times = {True: [], False: []}
    res = {}
    for _ in range(repeat):
        for rule in (False, True):
            r, t, n = solve(surface, settings, rule, initial)
            times[rule].append(t)
            res[rule] = (r, n)
    (a, na), (b, nb) = res[False], res[True]
    A, B = a.metrics, b.metrics
    mark = ""
    if not within(A, B):
        others = [solve(surface, settings, False, initial, reference=True)[0].metrics]
        if initial is not None:
            others.append(solve(surface, settings, False, nudged(initial))[0].metrics)
        mark = " as good" if no_worse([A] + others, B) else " **"
        spread = ", ".join(f"EN {o['energy'] / A['energy'] - 1:+.2e} bnd {o['boundary_error_pct']:.3f} "
                           f"area {o['area_error_pct']:.3f}" for o in [A] + others)
        mark += f" (the paper's refill, fast path, reference path{', nudged' if initial is not None else ''}: {spread})"
    return (f"{np.median(times[False]):.3f} | {np.median(times[True]):.3f} | {A['iterations']} / {B['iterations']} | "
            f"{na} / {nb} | {B['energy'] / A['energy'] - 1:+.2e} | {A['boundary_error_pct']:.3f}, "
            f"{B['boundary_error_pct'] - A['boundary_error_pct']:+.4f} | "
            f"{B['area_error_pct'] - A['area_error_pct']:+.4f} | {A['nodes']} / {B['nodes']} | "
            f"{B['uncovered_pct']:.3f} |{mark}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, default=2500)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cases", default=",".join(example_names()), help="surfaces, comma-separated")
    ap.add_argument("--cold", action="store_true", help="also the cold solves of tests/test_solver_speed.py's cases")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    lines = [f"## Edge churn against the paper's refill, {args.nodes:,} nodes ({_dt.date.today()}, "
             f"{platform.node()}, {os.cpu_count()} cores, load " + "{:.2f} {:.2f} {:.2f})".format(*os.getloadavg()),
             "", f"`benchmarks/edge_churn.py --nodes {args.nodes} --repeat {args.repeat}"
             f"{' --cold' if args.cold else ''}`: seconds are medians of {args.repeat} (the paper's refill and "
             "the rule alternating); refills made; the rule's result against the paper's refill.", "",
             "| case | s paper's | s rule | iterations | refills | EN rule/paper's - 1 | boundary %, rule - paper's | "
             "area, rule - paper's | nodes | uncovered % (rule) |", "|---|---:|---:|---|---|---:|---|---:|---|---:|"]
    print("\n".join(lines), flush=True)
    names = args.cases.split(",")
    for name in names:
        for material in ("woven", "isotropic"):
            s = load_example(name)
            settings = FlattenSettings(float(np.sqrt(region_area(s) / args.nodes)), material=MATERIALS[material])
            base = solve(s, settings, False)[0]
            for dart in (CURVE, PLANE) if name == "octant" else (CURVE,):
                row = f"| {name} {material}, warm {dart.name} | " + compare(
                    s, dataclasses.replace(settings, darts=(dart,)), base.state(), args.repeat)
                lines.append(row)
                print(row, flush=True)
    if args.cold:
        import tests.test_solver_speed as cases
        size = cases._settings
        with patch.object(cases, "_settings", lambda n, nodes, m="woven": size(n, args.nodes, m)):
            for c in [c if len(c) == 5 else c + (0.0,) for c in cases.CASES]:
                if c[0] not in names:
                    continue
                s, settings = cases._case(*c)
                what = ", ".join(x for x in (c[1], {"curve": "curve dart", True: "plane dart"}.get(c[2], ""),
                                             "yarn" if c[3] else "", f"weft {c[4]:g} deg" if c[4] else "") if x)
                row = f"| {c[0]} {what}, cold | " + compare(s, settings, None, 1)
                lines.append(row)
                print(row, flush=True)
    if args.out:
        with open(args.out, "a") as f:
            f.write("\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
