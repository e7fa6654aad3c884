"""Population control's invariants in a whole solve (the refill rules of
docs/decisions/0039-refill-rules-against-churn.md).

An isotropic piece loses and regains nodes at its edge round after round. The
per-iteration cost does not grow with that churn as long as the live population
stays in lattice order (the drape's and the refill's order: neighbours near in
memory, the pattern's dissection order computed from it), and the churn ends
because a position deleted twice is never refilled. Both are asserted here on
every snapshot of solves that do delete and refill. A refill that repeats an
earlier one (the same positions added to the same population) is not made: at
10,000 nodes the isotropic octant's last rounds refill and empty the same two
positions twice over, and end on the population they started from.
"""

from __future__ import annotations

import numpy as np
import pytest

import flatweave.method.pipeline as pipeline
import flatweave.method.solver as solver
from flatweave.method.drape import drape
from flatweave.reading.examples import load_example
from flatweave.method.lattice import MATERIALS
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten, make_problem
from flatweave.geometry.quadrature import region_area
from flatweave.method.solver import SolverOptions, State, iterate
from tests.test_solver_speed import _agree


def _solve(material: str, nodes: int):
    s = load_example("octant")
    st = FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material])
    d = drape(s, st.drape_settings(), st.material)
    gen = iterate(make_problem(s, st), State(d.mesh, d.uv), SolverOptions())
    snaps = []
    while True:
        try:
            snaps.append(next(gen))
        except StopIteration as done:
            return d, snaps, done.value


@pytest.mark.parametrize("material", ["woven", "isotropic"])
def test_the_population_stays_in_lattice_order_and_a_twice_deleted_position_stays_empty(material):
    d, snaps, res = _solve(material, 2_500)
    assert res.success
    deletions: dict[tuple[int, int], int] = {}
    live = set(map(tuple, d.mesh.ij.tolist()))
    refilled = 0
    for snap in snaps:
        ij = snap.mesh.ij
        assert (np.lexsort((ij[:, 1], ij[:, 0])) == np.arange(len(ij))).all(), snap.iteration
        now = set(map(tuple, ij.tolist()))
        for key in live - now:
            deletions[key] = deletions.get(key, 0) + 1
        back = now - live
        refilled += len(back)
        assert not [k for k in back if deletions.get(k, 0) >= 2], snap.iteration
        live = now
    assert deletions and refilled  # the case does exercise both
    assert res.deleted >= len(deletions) and res.added == refilled


@pytest.mark.slow
def test_a_repeated_refill_is_not_made_and_the_result_is_the_same(monkeypatch):
    # the paper's refill: the edge-churn rule already skips this piece's repeated edge refills (both runs
    # then take 9 iterations), so the check against repeats is tested on the churn it was made for
    monkeypatch.setattr(pipeline, "EDGE_REFILL_SPACINGS", 0.0)
    s = load_example("octant")
    st = FlattenSettings(float(np.sqrt(region_area(s) / 10_000)), material=MATERIALS["isotropic"])
    new = flatten(s, st, multilevel=0)  # from the drape: the churn this rule ends (a coarse start has little)
    refill = solver.Run.try_refill

    def every_refill(run, *a):  # before the check: no refill is known to repeat
        run.refills.clear()
        return refill(run, *a)

    monkeypatch.setattr(solver.Run, "try_refill", every_refill)
    old = flatten(s, st, multilevel=0)
    _agree(new, old)
    assert new.metrics["nodes"] == old.metrics["nodes"]
    assert new.metrics["iterations"] < old.metrics["iterations"]
    assert new.metrics["nodes_refilled"] < old.metrics["nodes_refilled"]
