"""The initial drape (paper 3.1) on every bundled example.

The issue's three criteria: weft and warp springs at rest length (except the
loop-closing ones the drape reports), no node outside the domain, and the mesh
covers the surface: every point lies within one cell diagonal of a node.
"""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from flatweave.method.drape import DrapeSettings, drape, refill
from flatweave.errors import SettingsError
from flatweave.reading.examples import example_names, load_example
from flatweave.method.lattice import DIAG, MATERIALS, build_mesh
from flatweave.geometry.quadrature import region_area


def dense_points(surface, n=200):
    dom = surface.domain
    g = np.linspace(0, 1, n)
    U, V = np.meshgrid(dom[0, 0] + g * np.ptp(dom[0]), dom[1, 0] + g * np.ptp(dom[1]))
    return surface.points(np.column_stack([U.ravel(), V.ravel()]))


def check_drape(surface, result, spacing):
    mesh, xyz = result.mesh, result.xyz
    # every node on the surface at its (u, v), inside the domain
    assert surface.in_domain(result.uv).all()
    assert np.allclose(surface.points(result.uv), xyz, atol=1e-12)
    # weft and warp springs at rest length except the reported loop closers
    length = np.linalg.norm(xyz[mesh.ends[:, 0]] - xyz[mesh.ends[:, 1]], axis=1)
    strain = np.abs(length / mesh.rest - 1)[mesh.kind != DIAG]
    off = strain >= 1e-6
    assert off.sum() == result.stats["loop_closing_springs"]
    assert off.sum() <= 0.01 * len(strain)
    # coverage
    d, _ = cKDTree(xyz).query(dense_points(surface))
    assert d.max() <= np.sqrt(2) * spacing
    # no two nodes on top of each other
    pairs = cKDTree(xyz).query_pairs(0.5 * spacing)
    assert not pairs


@pytest.mark.slow
@pytest.mark.parametrize("name", example_names())
@pytest.mark.parametrize("div", [10, 25, 60])
def test_drape_criteria_on_every_example(name, div):
    s = load_example(name)
    spacing = np.sqrt(region_area(s)) / div
    for angle in (0.0, 30.0):
        r = drape(s, DrapeSettings(spacing, angle_deg=angle), MATERIALS["woven"])
        check_drape(s, r, spacing)


def test_octant_pole_is_covered():
    s = load_example("octant")
    r = drape(s, DrapeSettings(0.05), MATERIALS["woven"])
    d = np.linalg.norm(r.xyz - [0, 0, 1], axis=1).min()
    assert d <= 0.05 * np.sqrt(2)


def test_seed_and_angle_are_honoured():
    s = load_example("garment")
    for seed, angle in [((0.5, 0.5), 0.0), ((0.3, 0.6), 45.0)]:
        r = drape(s, DrapeSettings(0.02, seed=seed, angle_deg=angle), MATERIALS["woven"])
        dom = s.domain
        uv0 = dom[:, 0] + np.array(seed) * np.ptp(dom, axis=1)
        i0 = np.flatnonzero((r.mesh.ij == 0).all(axis=1))[0]
        assert np.allclose(r.uv[i0], uv0)
        i1 = np.flatnonzero((r.mesh.ij == [0, 1]).all(axis=1))[0]
        ev = s.evaluate(uv0[None])
        e1 = ev.su[0] / np.linalg.norm(ev.su[0])
        e2 = np.cross(ev.normal[0], e1)
        chord = r.xyz[i1] - r.xyz[i0]
        measured = np.degrees(np.arctan2(chord @ e2, chord @ e1))
        assert abs(measured - angle) < 2.0  # chord vs tangent: O(spacing * curvature)


def test_geodesic_paths_drape_a_cylinder_at_rest():
    # on a developable surface geodesic threads give a drape with zero energy
    s = load_example("half_cylinder")
    r = drape(s, DrapeSettings(0.05, angle_deg=30, paths="geodesic"), MATERIALS["isotropic"])
    length = np.linalg.norm(r.xyz[r.mesh.ends[:, 0]] - r.xyz[r.mesh.ends[:, 1]], axis=1)
    diag = r.mesh.kind == DIAG
    # diagonals of a developed lattice are chords of the rolled-up plane: shorter by O(r^2 kappa^2)
    assert np.abs(length[diag] / r.mesh.rest[diag] - 1).max() < 2e-3


def test_refill_restores_deleted_nodes():
    s = load_example("octant")
    settings = DrapeSettings(0.05)
    r = drape(s, settings, MATERIALS["woven"])
    keep = r.mesh.ij[:, 1] < 5  # cut away the columns j >= 5
    ij, uv = refill(s, settings, r.mesh.ij[keep], r.uv[keep])
    assert len(ij) == np.sum(~keep)
    assert set(map(tuple, ij.tolist())) == set(map(tuple, r.mesh.ij[~keep].tolist()))
    # dead positions are never refilled
    dead = np.array([[0, 6], [1, 7]])
    ij2, _ = refill(s, settings, r.mesh.ij[keep], r.uv[keep], dead)
    assert not ({(0, 6), (1, 7)} & set(map(tuple, ij2.tolist())))


@pytest.mark.parametrize("kw, word", [
    (dict(spacing_weft=-1.0), "spacing"),
    (dict(spacing_weft=float("nan")), "spacing"),
    (dict(spacing_weft=0.1, seed=(1.5, 0.5)), "seed"),
    (dict(spacing_weft=0.1, paths="spiral"), "paths"),
    (dict(spacing_weft=0.1, angle_deg=float("inf")), "angle"),
])
def test_bad_settings(kw, word):
    with pytest.raises(SettingsError, match=word):
        drape(load_example("octant"), DrapeSettings(**kw), MATERIALS["woven"])


def test_oversize_mesh_is_refused_up_front(monkeypatch):
    # the node count, not the machine's memory, is the limit here (see test_hard_surfaces for memory)
    monkeypatch.setattr("flatweave.method.drape.available_memory", lambda: None)
    s = load_example("octant")
    with pytest.raises(SettingsError, match="nodes") as err:
        drape(s, DrapeSettings(1e-4, max_nodes=100_000), MATERIALS["woven"], area=region_area(s))
    assert "157,079,633" in str(err.value) and "0.00396" in str(err.value)


def test_progress_reports_the_mesh_as_it_grows_and_can_stop_the_drape(monkeypatch):
    # a report after every node: the pacing by the reports' own cost (REPORT_SHARE) depends on how
    # busy the machine is, and dropped the last report under load
    monkeypatch.setattr("flatweave.method.drape.REPORT_SHARE", 0.0)
    surface = load_example("octant")
    s = DrapeSettings(0.05, 0.05)
    plain = drape(surface, s, MATERIALS["woven"])
    seen = []
    watched = drape(surface, s, MATERIALS["woven"],
                    progress=lambda ij, uv, xyz: seen.append((ij.copy(), uv.copy(), xyz.copy())),
                    progress_interval=0.0)
    # watching changes nothing, and every report is a growing prefix of the drape
    np.testing.assert_array_equal(watched.mesh.ij, plain.mesh.ij)
    np.testing.assert_array_equal(watched.uv, plain.uv)
    counts = [len(ij) for ij, _, _ in seen]
    assert len(seen) >= 5 and counts == sorted(counts) and counts[-1] == plain.mesh.n_nodes
    final = {tuple(p): k for k, p in enumerate(plain.mesh.ij)}
    for ij, uv, xyz in seen:
        rows = [final[tuple(p)] for p in ij]  # every reported node is in the finished drape, where it stays
        np.testing.assert_allclose(uv, plain.uv[rows], atol=0)
        np.testing.assert_allclose(xyz, surface.points(uv), atol=1e-12)

    class Stop(Exception):
        pass

    def stop_at_100(ij, uv, xyz):
        if len(ij) >= 100:
            raise Stop

    with pytest.raises(Stop):
        drape(surface, s, MATERIALS["woven"], progress=stop_at_100, progress_interval=0.0)


def test_slow_progress_reports_come_less_often():
    """A report that takes t seconds is followed by at least REPORT_SHARE * t of
    drape before the next: slow viewers cost the drape at most a tenth."""
    import time

    from flatweave.method.drape import REPORT_SHARE

    surface = load_example("octant")
    s = DrapeSettings(0.02, 0.02)  # ~4,000 nodes: a drape long enough for several reports
    pause = 0.003
    spans = []

    def slow(ij, uv, xyz):
        t = time.perf_counter()
        if spans:
            spans[-1].append(t)
        time.sleep(pause)
        spans.append([time.perf_counter()])

    drape(surface, s, MATERIALS["woven"], progress=slow, progress_interval=0.0)
    gaps = [b - a for a, b in (x for x in spans if len(x) == 2)]  # end of one report to the start of the next
    print(f"{len(gaps)} gaps, shortest {1000 * min(gaps):.1f} ms")
    assert len(gaps) >= 3
    assert min(gaps) >= REPORT_SHARE * pause  # sleep() lasts at least `pause`, so the wait is at least this


def test_the_pipeline_shows_the_drape_as_the_solver_will_build_it():
    from flatweave.method.darts import PlaneDart
    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten_iter, make_problem

    surface = load_example("octant")
    s = FlattenSettings(spacing=0.08, solver="none", darts=(PlaneDart((1.0, 0.0, 0.0, -0.5)),))
    meshes = []
    gen = flatten_iter(surface, s, drape_progress=lambda mesh, uv, xyz: meshes.append((mesh, uv)),
                       drape_interval=0.0)
    with pytest.raises(StopIteration):
        next(gen)
    assert meshes
    problem = make_problem(surface, s)
    cut = 0
    for mesh, uv in meshes:
        built = problem.build(mesh.ij, uv)  # the same springs: those across the dart are cut
        np.testing.assert_array_equal(mesh.ends, built.ends)
        cut += build_mesh(mesh.ij, mesh.r_weft, mesh.r_warp, s.material).n_springs - mesh.n_springs
    assert cut > 0  # the dart did cut springs in what was shown


@pytest.mark.parametrize("name, angle", [("octant", 0.0), ("garment", 30.0), ("saddle", 45.0)])
def test_fronts_found_near_the_last_front_are_those_of_the_whole_lattice(monkeypatch, name, angle):
    """Every front is looked for only around the nodes the last one placed: it
    must be the front a scan of the whole lattice finds, positions, order and
    configurations."""
    import flatweave.method.drape as D

    near = D._Builder._valid_near
    fronts = []

    def checked(self, new):
        pos, V = near(self, new)
        every, V_every = self._valid_everywhere()
        np.testing.assert_array_equal(pos, every)
        np.testing.assert_array_equal(V, V_every)
        fronts.append(len(pos))
        return pos, V

    monkeypatch.setattr(D._Builder, "_valid_near", checked)
    s = load_example(name)
    spacing = np.sqrt(region_area(s)) / 40
    r = drape(s, DrapeSettings(spacing, angle_deg=angle), MATERIALS["woven"])
    check_drape(s, r, spacing)
    assert len(fronts) > 20


def _brute_far(xyz, P, r):
    """At least r from every node and, for the later of every close pair, from each other."""
    want = cKDTree(xyz).query(P, distance_upper_bound=r)[0] >= r if len(P) else np.ones(0, bool)
    idx = np.flatnonzero(want)
    for i, j in sorted(cKDTree(P[idx]).query_pairs(r)) if len(idx) > 1 else []:
        want[idx[max(i, j)]] = False
    return want


def test_the_near_node_test_is_the_brute_force_one():
    """The drape's k-d tiers (old, middle, newest nodes) answer "at least half a
    spacing from every node and from each other" as a search over all nodes
    does, whatever the sizes of the batches added between the questions."""
    from flatweave.method.drape import _Builder

    s = load_example("octant")
    b = _Builder(s, DrapeSettings(0.02))
    rng = np.random.default_rng(3)
    dom = s.domain
    placed, refused = 0, 0
    for step, size in enumerate(rng.choice([1, 2, 3, 40, 300], size=60)):
        uv = dom[:, 0] + rng.random((size, 2)) * np.ptp(dom, axis=1)
        b.add(np.column_stack([np.full(size, step), np.arange(size)]), uv, 2)
        placed += size
        P = s.points(dom[:, 0] + rng.random((50, 2)) * np.ptp(dom, axis=1))
        P[:10] = b.xyz[rng.integers(0, placed, 10)] + 0.003 * rng.normal(size=(10, 3))  # near nodes
        P[10:14] = P[14:18] + 0.002  # near each other
        got = b.far_from_mesh(P)
        np.testing.assert_array_equal(got, _brute_far(b.xyz, P, 0.01))
        refused += int((~got).sum())
    assert {"old", "mid", "new"} <= set(b.trees) or len(b.trees) >= 2
    assert refused > 100


def test_a_drape_asks_the_near_node_test_as_brute_force_answers(monkeypatch):
    import flatweave.method.drape as D

    tiered = D._Builder.far_from_mesh
    calls = []

    def checked(self, P):
        got = tiered(self, P)
        np.testing.assert_array_equal(got, _brute_far(self.xyz, P, 0.5 * self.rmin))
        calls.append(len(P))
        return got

    monkeypatch.setattr(D._Builder, "far_from_mesh", checked)
    s = load_example("octant")
    drape(s, DrapeSettings(np.sqrt(region_area(s)) / 40), MATERIALS["woven"])
    # the paths and the Node Filling rounds ask it once a step (the Two-Neighbour bands ask their own
    # tiered test, checked against brute force in tests/test_drape_band.py): 33 calls on this drape
    assert len(calls) > 20
