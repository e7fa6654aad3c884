"""The coarse-to-fine start (flatweave.method.multilevel).

A large piece is solved first at twice the spacing (and that one from a
coarser level again), the solution refined onto the fine lattice, and the
fine solve started there. The truth it is held to: on a plane the refined
coarse drape is the fine drape (both are the exact square lattice), a
stretched lattice carried on past its edge keeps its stretch, and on the
bundled surfaces the fine result is the one a solve from the drape reaches
(the population tests' tolerances, as tests/test_solver_speed.py holds the quick path).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import flatweave.method.pipeline as pipeline
from flatweave.method import multilevel
from flatweave.method.drape import drape
from flatweave.reading.examples import example_names, load_example
from flatweave.method.energy import YarnConstraint
from flatweave.method.lattice import MATERIALS
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import _coarser, flatten, flatten_iter
from flatweave.geometry.quadrature import region_area
from flatweave.geometry.region import Region, cover_for

L = 2.0


def plane() -> NurbsSurface:
    """S(u, v) = (L u, L v, 0): a plane whose parametrisation is a similarity."""
    P = np.array([[[0, 0, 0], [0, L, 0]], [[L, 0, 0], [L, L, 0]]], dtype=float)
    return NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], P)


def _settings(name: str, nodes: int, material: str = "woven") -> tuple[NurbsSurface, FlattenSettings]:
    s = load_example(name)
    return s, FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material])


def _drain(gen):
    """A flatten_iter run to its end: (its snapshots, its result)."""
    snaps = []
    while True:
        try:
            snaps.append(next(gen))
        except StopIteration as done:
            return snaps, done.value


def _assert_same_result(f: dict, r: dict) -> None:
    """The "same result" of metrics ``f`` against the reference's ``r``: energy within
    0.1 % (or lower), boundary and area errors within 0.02 points, nodes within 1 %."""
    assert f["energy"] <= r["energy"] * (1 + 1e-3)
    assert abs(f["boundary_error_pct"] - r["boundary_error_pct"]) <= 0.02
    assert abs(f["area_error_pct"] - r["area_error_pct"]) <= 0.02
    assert abs(f["nodes"] - r["nodes"]) <= 0.01 * r["nodes"]


def test_levels_grow_with_the_piece_and_keep_the_coarsest_large_enough():
    assert multilevel.levels_for(multilevel.MIN_NODES - 1) == 0
    previous = 0
    for n in (multilevel.MIN_NODES, 10_000, 40_000, 160_000, 640_000):
        k = multilevel.levels_for(n)
        assert k >= max(previous, 1)
        coarsest = n / 4 ** k
        assert multilevel.COARSEST_NODES <= coarsest < 4 * multilevel.COARSEST_NODES or k == 1
        previous = k


def test_a_refined_coarse_drape_on_a_plane_is_the_fine_drape():
    s = plane()
    h = 0.05
    settings = FlattenSettings(h, seed=(0.37, 0.61), angle_deg=20.0)
    coarse = drape(s, dataclasses.replace(settings, spacing=2 * h).drape_settings(), settings.material)
    fine = drape(s, settings.drape_settings(), settings.material)
    ij, uv = multilevel.refine(s, coarse.mesh, coarse.uv)
    fine_at = {tuple(p): q for p, q in zip(fine.mesh.ij.tolist(), fine.uv)}
    common = [i for i, p in enumerate(ij.tolist()) if tuple(p) in fine_at]
    # every refined node is a node of the fine lattice, at its place
    assert len(common) == len(ij)
    assert len(ij) > 3 * coarse.mesh.n_nodes
    got = uv[common]
    want = np.array([fine_at[tuple(p)] for p in ij[common].tolist()])
    assert np.abs(got - want).max() < 1e-12
    # sorted by lattice row, then column, as the solver's populations are
    assert (np.lexsort((ij[:, 1], ij[:, 0])) == np.arange(len(ij))).all()


def test_refined_nodes_lie_on_the_chords_midpoints_of_a_curved_surface():
    s, settings = _settings("octant", 600)
    coarse = flatten(s, dataclasses.replace(settings, spacing=2 * settings.spacing))
    ij, uv = multilevel.refine(s, coarse.mesh, coarse.uv)
    at = {tuple(p): i for i, p in enumerate(ij.tolist())}
    xyz = s.points(uv)
    # a node between two coarse neighbours along a weft: equidistant from both, to the curvature's second order
    gaps = []
    for (i, j) in coarse.mesh.ij[:200].tolist():
        m, a, b = at.get((2 * i, 2 * j + 1)), at.get((2 * i, 2 * j)), at.get((2 * i, 2 * j + 2))
        if m is not None and a is not None and b is not None:
            da, db = np.linalg.norm(xyz[m] - xyz[a]), np.linalg.norm(xyz[m] - xyz[b])
            gaps.append(abs(da - db) / (da + db))
    assert len(gaps) > 50
    assert max(gaps) < 1e-3


def test_a_stretched_lattice_carried_on_keeps_its_stretch():
    s = plane()
    h = 0.04
    ii, jj = np.meshgrid(np.arange(-5, 6), np.arange(-5, 6), indexing="ij")
    ij = np.column_stack([ii.ravel(), jj.ravel()])
    stretch = np.array([[1.05, 0.02], [-0.01, 0.97]])  # an even strain, and a little shear
    uv = 0.5 + h * ij @ stretch.T
    inner = (np.abs(ij) <= 3).all(axis=1)
    out_ij, out_uv = multilevel.extend(s, ij[inner], uv[inner], passes=2)
    # the two rings taken away come back at the same places, corners and all
    want = {tuple(p): q for p, q in zip(ij.tolist(), uv)}
    back = [tuple(p) for p in out_ij.tolist()]
    assert set(back) <= set(want)
    assert len(back) >= inner.sum() + 2 * 4 * 7  # both rings' sides at least (corners need a line through them)
    assert np.abs(out_uv - np.array([want[p] for p in back])).max() < 1e-12


def test_a_line_is_not_carried_across_a_dart_or_out_of_the_region():
    s = plane()
    h = 0.04
    ii, jj = np.meshgrid(np.arange(-3, 4), np.arange(-3, 4), indexing="ij")
    ij = np.column_stack([ii.ravel(), jj.ravel()])
    uv = 0.5 + h * ij

    def separated(a, b):  # a dart along u = 0.5 + 3.5 h, beyond the last column
        return (a[:, 1] - (0.5 + 3.5 * h)) * (b[:, 1] - (0.5 + 3.5 * h)) < 0

    out_ij, _ = multilevel.extend(s, ij, uv, separated=separated, passes=1)
    assert out_ij[:, 1].max() == 3  # nothing past the dart
    assert out_ij[:, 1].min() == -4 and out_ij[:, 0].min() == -4 and out_ij[:, 0].max() == 4
    out_ij, _ = multilevel.extend(s, ij, uv, inside=lambda q: q[:, 0] < 0.5 + 3.5 * h, passes=1)
    assert out_ij[:, 0].max() == 3  # nothing outside the region


@pytest.mark.slow
def test_a_large_piece_starts_from_coarser_levels_and_reaches_the_same_result():
    s, settings = _settings("octant", 8_000)
    auto = flatten(s, settings)
    plain = flatten(s, settings, multilevel=0)
    k = multilevel.levels_for(region_area(s) / settings.spacing ** 2)
    assert k >= 1
    assert auto.metrics["coarse_levels"] == k and plain.metrics["coarse_levels"] == 0
    assert auto.metrics["coarse_iterations"] > 0
    assert auto.mesh.r_weft == settings.spacing
    f, r = auto.metrics, plain.metrics
    assert f["solver_status"] == "converged"
    _assert_same_result(f, r)
    # the population control had little left to do
    assert f["nodes_deleted"] < r["nodes_deleted"] / 4


@pytest.mark.slow
@pytest.mark.parametrize("nodes", [2_500, 10_000])
@pytest.mark.parametrize("name", example_names())
def test_coarse_levels_solved_to_a_looser_tolerance_reach_the_same_result(name, nodes, monkeypatch):
    """A coarser level's solution is only the next level's start (``pipeline.COARSE_TOL``): solved to
    1e-6 instead of the settings' 1e-9, every bundled example, woven and isotropic, ends where it did
    (measured: energy to 6e-13, errors and nodes identical), in no more iterations."""
    for material in ("woven", "isotropic"):
        s, settings = _settings(name, nodes, material)
        loose = flatten(s, settings)
        monkeypatch.setattr(pipeline, "COARSE_TOL", 0.0)  # every level to the settings' tolerance
        tight = flatten(s, settings)
        monkeypatch.undo()
        f, r = loose.metrics, tight.metrics
        assert f["solver_status"] == r["solver_status"] == "converged"
        scale = 0.5 * float(np.dot(tight.mesh.k, tight.mesh.rest ** 2))
        assert abs(f["energy"] - r["energy"]) <= 1e-9 * r["energy"] + 1e-12 * scale
        assert abs(f["boundary_error_pct"] - r["boundary_error_pct"]) <= 1e-3
        assert abs(f["area_error_pct"] - r["area_error_pct"]) <= 1e-3
        assert f["nodes"] == r["nodes"]
        assert f["iterations"] <= r["iterations"]


@pytest.mark.slow
def test_the_coarse_levels_snapshots_come_first_each_with_its_own_mesh():
    s, settings = _settings("octant", 3_000)
    snaps, result = _drain(flatten_iter(s, settings, multilevel=2))
    spacings = [snap.mesh.r_weft for snap in snaps]
    for snap in snaps:
        assert len(snap.uv) == snap.mesh.n_nodes and len(snap.strain) == snap.mesh.n_springs
    h = settings.spacing
    levels = sorted(set(spacings), reverse=True)
    assert levels == pytest.approx([4 * h, 2 * h, h])
    assert spacings == sorted(spacings, reverse=True)  # coarsest first, never back
    assert result.mesh.r_weft == h


def test_a_run_stopped_on_a_coarse_level_gives_a_result_on_the_settings_lattice():
    s, settings = _settings("octant", 3_000)
    seen = []

    def stop_third(snap):
        seen.append(snap.mesh.r_weft)
        return len(seen) == 3

    r = flatten(s, settings, callback=stop_third, multilevel=2)
    assert seen[-1] == pytest.approx(4 * settings.spacing)
    assert r.metrics["solver_status"].startswith("stopped")
    assert r.mesh.r_weft == settings.spacing
    # its springs are about their rest length (a coarse state built with fine rest lengths is 100 % long)
    lengths = np.linalg.norm(r.xyz[r.mesh.ends[:, 0]] - r.xyz[r.mesh.ends[:, 1]], axis=1)
    assert np.median(np.abs(lengths / r.mesh.rest - 1)) < 0.05


def test_a_yarn_held_by_index_holds_the_nearest_coarse_row():
    _, settings = _settings("octant", 3_000)
    y = YarnConstraint("weft", 3, (0.0, 0.0, 1.0, -0.5), 10.0)
    c = _coarser(dataclasses.replace(settings, yarns=(y,)))
    assert c.spacing == 2 * settings.spacing and c.yarns[0].index == 1
    assert c.yarns[0].plane == y.plane


@pytest.mark.slow
def test_the_paper_solver_and_warm_starts_never_start_coarse():
    s, settings = _settings("octant", 8_000)
    paper = flatten(s, dataclasses.replace(settings, solver="paper", max_iter=1))
    assert paper.metrics["coarse_levels"] == 0
    warm = flatten(s, dataclasses.replace(settings, max_iter=1), initial=paper.state())
    assert warm.metrics["coarse_levels"] == 0


@pytest.mark.slow
def test_a_developable_piece_whose_coarse_drape_holds_is_draped_on_its_own_lattice():
    s, settings = _settings("half_cylinder", 8_000)
    auto = flatten(s, settings)
    plain = flatten(s, settings, multilevel=0)
    # the coarse level kept its population (its few iterations bend the drape's chords into arcs),
    # so the fine drape is the start, not a refined net
    (dropped,) = auto.drape_stats["dropped"]
    assert dropped["converged"] and dropped["deleted"] == dropped["added"] == 0
    assert auto.metrics["coarse_levels"] == 0
    assert auto.metrics["iterations"] == plain.metrics["iterations"] + dropped["iterations"]
    assert auto.metrics["energy"] == plain.metrics["energy"]
    assert np.array_equal(auto.uv, plain.uv)
    # and it is the development: no strain, the outline and area exact
    for key in ("max_thread_strain_pct", "boundary_error_pct", "area_error_pct"):
        assert abs(auto.metrics[key]) < 1e-5


@pytest.mark.slow
def test_a_piece_whose_coarse_drape_keeps_its_population_is_draped_on_its_own_lattice():
    # the saddle's coarse solve converges from its drape in a few iterations, no node deleted or
    # refilled: the drape held, and the fine drape (not a carried net) is where the fine solve starts
    s, settings = _settings("saddle", 2_500)
    assert multilevel.levels_for(region_area(s) / settings.spacing ** 2) == 1
    snaps, auto = _drain(flatten_iter(s, settings))
    plain = flatten(s, settings, multilevel=0)
    (dropped,) = auto.drape_stats["dropped"]
    assert dropped["iterations"] > 0 and dropped["converged"]
    assert dropped["deleted"] == dropped["added"] == 0
    assert auto.metrics["coarse_levels"] == 0 and auto.metrics["coarse_iterations"] == dropped["iterations"]
    assert np.array_equal(auto.uv, plain.uv) and auto.metrics["energy"] == plain.metrics["energy"]
    # the dropped solve's snapshots were shown first, and the count runs on over both solves
    spacings = [sn.mesh.r_weft for sn in snaps]
    assert spacings[0] == pytest.approx(2 * settings.spacing) and spacings[-1] == settings.spacing
    assert spacings == sorted(spacings, reverse=True)
    its = [sn.iteration for sn in snaps]
    assert its == sorted(its) and its[-1] == auto.metrics["iterations"]
    assert auto.metrics["iterations"] == plain.metrics["iterations"] + dropped["iterations"]
    # then the result's EN, with the springs bent where the nodes ended, where it differs from the last
    assert list(auto.history)[:len(snaps)] == [sn.energy for sn in snaps]
    assert auto.history[-1] == auto.metrics["energy"] and len(auto.history) - len(snaps) in (0, 1)


@pytest.mark.slow
@pytest.mark.parametrize("name, material", [("octant", "woven"), ("octant", "isotropic"),
                                            ("garment", "woven")])
def test_a_small_piece_whose_drape_does_not_hold_starts_coarse_and_reaches_the_same_result(name, material,
                                                                                           monkeypatch):
    # the paper's refill: under the edge-churn rule each path may leave out another node on the edge (the
    # octant woven's coarse start and its drape one each, 0.012 points of boundary error either way);
    # tests/test_edge_churn.py checks the coarse start under the rule against the paper's refill
    monkeypatch.setattr(pipeline, "EDGE_REFILL_SPACINGS", 0.0)
    s, settings = _settings(name, 2_500, material)
    auto = flatten(s, settings)
    plain = flatten(s, settings, multilevel=0)
    assert auto.metrics["coarse_levels"] == 1 and "dropped" not in auto.drape_stats
    (level,) = auto.drape_stats["levels"]
    assert level["deleted"] or level["added"]  # why it was carried
    f, r = auto.metrics, plain.metrics
    assert f["solver_status"] == "converged"
    _assert_same_result(f, r)


@pytest.mark.slow
def test_a_carried_level_that_keeps_its_population_carries_on(monkeypatch):
    # only a solve from its own drape shows that the drape holds: a level carried from a coarser one
    # that keeps every node is carried on again (its start was a refined net, not a drape). With the
    # paper's refill: under the edge-churn rule the coarsest level here skips an edge refill, and the
    # middle level then deletes 16 nodes, so the case no longer shows a level that keeps its population
    monkeypatch.setattr(pipeline, "EDGE_REFILL_SPACINGS", 0.0)
    s, settings = _settings("saddle", 10_000, "isotropic")
    auto = flatten(s, settings)
    plain = flatten(s, settings, multilevel=0)
    coarsest, middle = auto.drape_stats["levels"]
    assert coarsest["deleted"] or coarsest["added"]
    assert middle["converged"] and middle["deleted"] == middle["added"] == 0
    assert auto.metrics["coarse_levels"] == 2 and "dropped" not in auto.drape_stats
    f, r = auto.metrics, plain.metrics
    _assert_same_result(f, r)


@pytest.mark.slow
def test_a_trimmed_piece_with_a_hole_starts_coarse_and_reaches_the_same_result():
    s = load_example("octant")
    square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)[::-1]  # a hole runs clockwise
    region = Region.from_loops(square, [np.stack([0.45 + 0.15 * np.cos(t), 0.5 + 0.15 * np.sin(t)], 1)])
    cover = cover_for(s, region)
    settings = FlattenSettings(float(np.sqrt(cover.area / 3_000)), region=region, seed=cover.default_seed)
    coarse = flatten(s, settings, multilevel=1)
    plain = flatten(s, settings, multilevel=0)
    assert coarse.metrics["coarse_levels"] == 1
    assert cover.contains(coarse.uv).all()  # no node in the hole or outside
    f, r = coarse.metrics, plain.metrics
    # the same minimum, or a fuller population: the drape's path (44 iterations, 255 nodes deleted on
    # the way, positions deleted twice never refilled) keeps fewer edge nodes than the coarse start
    # (a handful more, the surface as covered); EN then counts their springs too
    fuller = f["nodes"] > r["nodes"] and f["uncovered_pct"] <= r["uncovered_pct"]
    # or as many nodes on another edge population: with bent springs (decision 0057) both keep 3,009
    # nodes, the coarse start's EN 0.25 % higher, its outline within 0.005 points
    other = f["nodes"] == r["nodes"] and f["energy"] <= r["energy"] * (1 + 5e-3)
    assert f["energy"] <= r["energy"] * (1 + 1e-3) or fuller or other
    assert abs(f["boundary_error_pct"] - r["boundary_error_pct"]) <= 0.02
    assert abs(f["area_error_pct"] - r["area_error_pct"]) <= 0.02
    assert abs(f["nodes"] - r["nodes"]) <= 0.01 * r["nodes"]


@pytest.mark.slow
def test_one_iteration_count_and_energy_trace_over_the_levels():
    s, settings = _settings("octant", 3_000)
    snaps, result = _drain(flatten_iter(s, settings, multilevel=2))
    its = [sn.iteration for sn in snaps]
    assert its == sorted(its) and its[-1] == result.metrics["iterations"]
    assert result.metrics["coarse_iterations"] < result.metrics["iterations"]
    # the snapshots' energies, then the result's (springs bent where the nodes ended, summed by the
    # metrics) where it differs from the last, if only in its last bits (pipeline._ended)
    assert list(result.history)[:len(snaps)] == [sn.energy for sn in snaps]
    assert result.history[-1] == result.metrics["energy"] and len(result.history) - len(snaps) in (0, 1)
    assert "history" not in result.drape_stats["levels"][0]  # the trace is the result's, once


@pytest.mark.slow
@pytest.mark.parametrize("budget", [3, 9])
def test_the_iteration_budget_is_the_whole_runs(budget):
    """A budget of N iterations stops a coarse-to-fine run after N iterations in all, wherever
    they fell (on a coarse level, or on the fine one after the levels' share), and says N."""
    s, settings = _settings("octant", 3_000)
    snaps, result = _drain(flatten_iter(s, dataclasses.replace(settings, max_iter=budget), multilevel=2))
    m = result.metrics
    assert m["iterations"] == budget == snaps[-1].iteration
    assert m["solver_status"] == f"stopped at the iteration budget ({budget})"
    assert result.status.startswith(f"stopped at the iteration budget ({budget})")


def test_a_carried_start_never_refills_a_position_its_solve_emptied():
    from flatweave.method.solver import SolverOptions, _Population
    from flatweave.errors import SettingsError
    once, twice = _Population(1), _Population(2)
    for pop in (once, twice):
        pop.record(np.array([[3, -4]]))
    assert once.dead().tolist() == [[3, -4]] and once.all_dead(np.array([[3, -4]]))
    assert twice.dead().shape == (0, 2) and not twice.all_dead(np.array([[3, -4]]))
    with pytest.raises(SettingsError, match="dead_after"):
        SolverOptions(dead_after=0)
    # the pipeline asks it of every level carried from a coarser one, and only of those
    from flatweave.method.pipeline import _carried
    opts = SolverOptions()
    level = {"iterations": 0, "solve_seconds": 0.0, "refine_seconds": 0.0}
    assert _carried(opts, {"levels": [level]}).dead_after == 1 and _carried(opts, {}).dead_after == 2
