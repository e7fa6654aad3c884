"""The plane-dart re-solve's Newton matrices, factorised by QDLDL as the solver does and by MKL PARDISO.

    .venv/bin/python benchmarks/factorise_libs.py [--nodes 2500] [--repeat 3]

The suite's plane dart is added to a solved woven octant of about ``--nodes``
nodes and the piece re-solved warm once, keeping every matrix the fast solver
factorises (with the round it belongs to). Each is then factorised again, in
order, as ``core.solver._Round.factorise`` does (a new ``qdldl.Solver`` at a
round's first matrix, ``update`` after) and, if ``pypardiso`` can be imported,
by PARDISO as a symmetric indefinite matrix (mtype -2: analysis and
factorisation at a round's first matrix, the numeric phase after), each
followed by one solve. Prints the milliseconds per matrix (the minimum over
``--repeat`` passes), the totals, and PARDISO's largest relative residual.

PARDISO is not a dependency of the project (MKL is about 230 MB); to measure
it, install ``pypardiso`` in a throwaway environment that also holds this
project's requirements.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import core.solver as solver  # noqa: E402
from core.darts import PlaneDart  # noqa: E402
from core.examples import load_example  # noqa: E402
from core.pipeline import FlattenSettings, flatten  # noqa: E402
from core.quadrature import region_area  # noqa: E402

PLANE = PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart")


def matrices(nodes: int) -> list[tuple[int, sp.csc_matrix]]:
    """(round number, matrix) of every factorisation in one warm plane-dart re-solve."""
    s = load_example("octant")
    settings = FlattenSettings(float(np.sqrt(region_area(s) / nodes)))
    base = flatten(s, settings)
    with_dart = dataclasses.replace(settings, darts=(PLANE,))
    flatten(s, with_dart, initial=base.state())  # the dart's curve is remembered, as after a preview
    kept: list[tuple[object, sp.csc_matrix]] = []
    factorise = solver._Round.factorise

    def keep(self, A, quick=False):
        kept.append((self, A.copy()))
        return factorise(self, A, quick)

    solver._Round.factorise = keep
    try:
        flatten(s, with_dart, initial=base.state())
    finally:
        solver._Round.factorise = factorise
    rounds: dict[int, int] = {}
    return [(rounds.setdefault(id(r), len(rounds)), A) for r, A in kept]


def qdldl_pass(mats) -> list[float]:
    import qdldl
    out, last, ldl = [], None, None
    for rnd, A in mats:
        U = sp.triu(A, format="csc")
        b = np.ones(A.shape[0])
        t = time.perf_counter()
        if rnd != last:
            ldl, last = qdldl.Solver(U, upper=True), rnd
        else:
            ldl.update(U, upper=True)
        ldl.solve(b)
        out.append(time.perf_counter() - t)
    return out


def pardiso_pass(mats) -> tuple[list[float], float]:
    import pypardiso
    out, last, ps, worst = [], None, None, 0.0
    for rnd, A in mats:
        U = sp.triu(A, format="csr")
        b = np.ones(A.shape[0])
        t = time.perf_counter()
        if rnd != last:
            ps, last = pypardiso.PyPardisoSolver(mtype=-2), rnd
            ps.set_phase(12)
        else:
            ps.set_phase(22)
        ps._call_pardiso(U, b)
        ps.set_phase(33)
        x = ps._call_pardiso(U, b)
        out.append(time.perf_counter() - t)
        worst = max(worst, float(np.abs(A @ x - b).max() / np.abs(b).max()))
    return out, worst


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, default=2500)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    mats = matrices(args.nodes)
    print(f"{len(mats)} matrices, {mats[0][1].shape[0]} unknowns, {mats[0][1].nnz} entries, "
          f"{len({r for r, _ in mats})} rounds")
    passes = {"QDLDL": [qdldl_pass]}
    try:
        import pypardiso  # noqa: F401
        passes["PARDISO"] = [lambda m: pardiso_pass(m)[0]]
    except ImportError:
        print("pypardiso is not installed: QDLDL only")
    best = {}
    for _ in range(args.repeat):
        for name, (fn,) in passes.items():  # alternating
            t = fn(mats)
            best[name] = t if name not in best else np.minimum(best[name], t)
    print("| matrix | round | " + " | ".join(f"{n} ms" for n in passes) + " |")
    print("|---:|---:|" + "---:|" * len(passes))
    for k, (rnd, _) in enumerate(mats):
        print(f"| {k + 1} | {rnd + 1} | " + " | ".join(f"{1e3 * best[n][k]:.1f}" for n in passes) + " |")
    print("| total | | " + " | ".join(f"{1e3 * sum(best[n]):.1f}" for n in passes) + " |")
    if "PARDISO" in passes:
        print(f"PARDISO's largest relative residual: {pardiso_pass(mats)[1]:.1e}")


if __name__ == "__main__":
    main()
