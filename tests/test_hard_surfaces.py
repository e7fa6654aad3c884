"""Hard surfaces and settings: each gives a valid result or
a clear one-line message, and no solve runs without a budget.

A valid result: finite numbers everywhere, every node inside the domain, a
pattern of positive area close to the surface's (the metrics say how close),
finite metrics. The surfaces are built here from their definitions; the
spacings are coarse so the whole file runs in well under a minute.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from math import comb

import numpy as np
import pytest

import flatweave.method.drape
from flatweave.method.drape import (BYTES_PER_NODE, DrapeSettings, available_memory, drape, estimate_node_count,
                                    node_limit)
from flatweave.errors import FlatweaveError, SettingsError, SurfaceError
from flatweave.reading.examples import example_path, load_example
from flatweave.method.lattice import MATERIALS
from flatweave.geometry.nurbs import MAX_SIZE, MIN_SIZE, NurbsSurface
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten, make_problem
from flatweave.geometry.quadrature import region_area
from flatweave.method.solver import SolverOptions, State, minimize
from flatweave.geometry.surface_json import save_surface


# ---------------------------------------------------------------------- surfaces
def bezier_net(f, degree: int, a: float, b: float) -> np.ndarray:
    """Control points of the degree-``degree`` Bezier curve equal to the
    polynomial curve f on [a, b] (exact: interpolation at degree + 1 points)."""
    t = np.linspace(0.0, 1.0, degree + 1)
    B = np.array([[comb(degree, i) * x ** i * (1 - x) ** (degree - i) for i in range(degree + 1)] for x in t])
    return np.linalg.solve(B, np.array([f(a + x * (b - a)) for x in t], dtype=float))


def extruded(profile: np.ndarray, degree: int, width: float = 1.0) -> NurbsSurface:
    """The Bezier curve ``profile`` (k, 3) swept along y by ``width``."""
    P = np.stack([profile + [0.0, y, 0.0] for y in (0.0, width)], axis=1)
    return NurbsSurface(degree, 1, [0] * (degree + 1) + [1] * (degree + 1), [0, 0, 1, 1], P)


def cusp() -> NurbsSurface:
    """S(u, v) = (u^2, v, u^3), u in [-1, 1]: a semicubical cusp along u = 0
    (the middle of the domain), where S_u = 0 and the surface turns back on itself."""
    return extruded(bezier_net(lambda u: [u * u, 0.0, u ** 3], 3, -1.0, 1.0), 3)


def bowtie() -> NurbsSurface:
    """Two triangles touching at one point: the middle row of the net (the
    line u = 0.5 of the domain) collapses to the origin."""
    P = np.array([[[-1, -1, 0], [-1, 1, 0]], [[0, 0, 0], [0, 0, 0]], [[1, -1, 0], [1, 1, 0]]], float)
    return NurbsSurface(1, 1, [0, 0, 0.5, 1, 1], [0, 0, 1, 1], P)


def tube(degrees: float = 360.0, radius: float = 0.5, length: float = 1.0) -> NurbsSurface:
    """A circular tube (exact rational quadratic) of the given opening angle
    around the z axis: at 360 degrees its edges u = 0 and u = 1 coincide in 3D."""
    k = int(np.ceil(degrees / 90.0 - 1e-9))
    half = np.radians(degrees) / (2 * k)
    w = np.cos(half)
    angles = np.linspace(0.0, np.radians(degrees), 2 * k + 1)
    r = np.where(np.arange(2 * k + 1) % 2 == 1, radius / w, radius)
    ring = np.column_stack([r * np.cos(angles), r * np.sin(angles), np.zeros(2 * k + 1)])
    P = np.stack([ring + [0.0, 0.0, z] for z in (0.0, length)], axis=1)
    W = np.repeat(np.where(np.arange(2 * k + 1) % 2 == 1, w, 1.0)[:, None], 2, axis=1)
    inner = np.repeat(np.arange(1, k) / k, 2)
    return NurbsSurface(2, 1, np.concatenate([[0, 0, 0], inner, [1, 1, 1]]), [0, 0, 1, 1], P, W)


def strip(length: float = 10.0, width: float = 0.1, sag: float = 0.0) -> NurbsSurface:
    """A length x width strip (100:1 by default), bent along its length into
    z = sag (x - length / 2)^2 (a developable surface)."""
    prof = bezier_net(lambda x: [x, 0.0, sag * (x - length / 2) ** 2], 2, 0.0, length)
    return extruded(prof, 2, width)


def scaled(s: NurbsSurface, k: float, offset: float = 0.0) -> NurbsSurface:
    return NurbsSurface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.ctrlpts * k + offset, s.weights)


# ---------------------------------------------------------------------- checks
def assert_valid(surface: NurbsSurface, r, area_error_pct: float | None = None) -> None:
    """A usable result: finite, inside the domain, a pattern of positive area, finite metrics."""
    for a in (r.uv, r.xyz, r.pattern.xy, r.pattern.outline):
        assert np.all(np.isfinite(a))
    assert surface.in_domain(r.uv).all()
    assert r.pattern.area > 0
    floats = {k: v for k, v in r.metrics.items() if isinstance(v, float)}
    assert floats and all(math.isfinite(v) for v in floats.values()), floats
    if area_error_pct is not None:
        assert r.metrics["area_error_pct"] < area_error_pct


def refused(fn, *words, kind=SettingsError) -> str:
    """The one-line message ``fn()`` raises; it must contain every word."""
    with pytest.raises(kind) as info:
        fn()
    msg = str(info.value)
    assert msg and "\n" not in msg and len(msg) < 400
    for w in words:
        assert w in msg, msg
    return msg


# ---------------------------------------------------------------------- a pole
def test_pole_is_covered_and_flattened():
    s = load_example("octant")  # the edge u = 0 is the north pole
    r = flatten(s, FlattenSettings(0.1))
    assert_valid(s, r, area_error_pct=2.0)
    assert r.solve.success
    assert np.linalg.norm(r.xyz - [0, 0, 1], axis=1).min() < 0.1 * np.sqrt(2)


@pytest.mark.parametrize("seed", [(0.0, 0.0), (0.0, 1.0), (0.01, 0.01)])
def test_seed_at_or_beside_the_pole_is_refused_clearly(seed):
    # from the pole every thread runs out of the 90 degree wedge at once
    refused(lambda: flatten(load_example("octant"), FlattenSettings(0.1, seed=seed)),
            "no complete cell", f"seed ({seed[0]:g}, {seed[1]:g})", "move the seed inward")


@pytest.mark.slow
@pytest.mark.parametrize("name, seed", [
    ("garment", (0.01, 0.01)), ("garment", (0.0, 0.0)), ("garment", (1.0, 1.0)),
    ("octant", (1.0, 1.0)), ("octant", (0.05, 0.05))])
def test_seed_near_the_boundary_gives_a_valid_result(name, seed):
    s = load_example(name)
    r = flatten(s, FlattenSettings(0.15 if name == "octant" else 0.05, seed=seed))
    assert_valid(s, r, area_error_pct=3.0)
    i0 = np.flatnonzero((r.mesh.ij == 0).all(axis=1))
    assert len(i0) == 1  # the seed node stays where it was put
    dom = s.domain
    assert np.allclose(r.uv[i0[0]], dom[:, 0] + np.array(seed) * (dom[:, 1] - dom[:, 0]))


def test_corner_seed_on_a_saddle_is_refused_clearly():
    # at a corner one thread runs along an edge and leaves the surface at once
    refused(lambda: flatten(load_example("saddle"), FlattenSettings(0.2, seed=(0.0, 0.0))),
            "no complete cell", "move the seed inward")


# ---------------------------------------------------------------------- cusps, pinches, seams
@pytest.mark.parametrize("seed", [(0.5, 0.5), (0.25, 0.5)])
def test_cusp_is_refused_with_the_share_covered(seed):
    s = cusp()
    assert np.allclose(s.evaluate([[0.5, 0.3]]).su, 0.0)  # the cusp line is in the middle of the domain
    msg = refused(lambda: flatten(s, FlattenSettings(0.05, seed=seed)), "covers only", "cusp")
    assert 40 <= int(msg.split("covers only ")[1].split(" %")[0]) <= 70


def test_pinch_is_refused_from_either_side_or_at_the_point():
    s = bowtie()
    refused(lambda: flatten(s, FlattenSettings(0.1, seed=(0.25, 0.5))), "covers only", "pinch")
    refused(lambda: flatten(s, FlattenSettings(0.1, seed=(0.5, 0.5))), "no complete cell", "seed")


@pytest.mark.slow
@pytest.mark.parametrize("spacing, seed, tol", [
    (0.1, (0.5, 0.5), 0.5), (0.1, (0.0, 0.3), 0.5), (0.05, (0.9, 0.5), 0.1), (0.4, (0.5, 0.5), 25.0)])
def test_closed_tube_edges_touching_in_3d(spacing, seed, tol):
    """The seam u = 0 / u = 1 of a full tube: boundary points there are mapped
    through nodes of their own side, so the pattern is the unrolled tube."""
    s = tube(360.0)
    assert np.allclose(s.points([[0.0, 0.4]]), s.points([[1.0, 0.4]]))
    r = flatten(s, FlattenSettings(spacing, seed=seed))
    assert_valid(s, r, area_error_pct=tol)
    if spacing <= 0.1:  # the weft runs round the tube: the pattern is the circumference long
        assert np.ptp(r.pattern.outline, axis=0).max() == pytest.approx(np.pi, rel=0.02)


def test_tube_whose_edges_almost_touch():
    s = tube(355.0)
    gap = np.linalg.norm(s.points([[0.0, 0.5]]) - s.points([[1.0, 0.5]]))
    assert gap < 0.5 * 0.1  # closer than half a spacing
    r = flatten(s, FlattenSettings(0.1))
    assert_valid(s, r, area_error_pct=0.5)


# ---------------------------------------------------------------------- long and thin
@pytest.mark.slow
def test_long_thin_strip_100_to_1():
    s = strip(sag=0.05)
    r = flatten(s, FlattenSettings(0.02))
    assert_valid(s, r, area_error_pct=1e-3)  # developable: the pattern is exact
    assert r.metrics["max_thread_strain_pct"] < 1e-3
    assert np.ptp(r.pattern.xy, axis=0).max() > 9.5


def test_strip_narrower_than_the_spacing_says_which_spacing_works():
    s = strip()
    msg = refused(lambda: flatten(s, FlattenSettings(0.3)), "too large for this surface", "below about")
    suggested = float(msg.split("below about ")[1])
    assert suggested == pytest.approx(0.05, rel=0.05)  # half the strip's width
    assert_valid(s, flatten(s, FlattenSettings(0.95 * suggested)))


# ---------------------------------------------------------------------- spacing vs size
@pytest.mark.slow
@pytest.mark.parametrize("spacing", [1.0, 5.0, 1e6])
def test_spacing_larger_than_the_surface(spacing):
    s = load_example("octant")
    msg = refused(lambda: flatten(s, FlattenSettings(spacing)), "too large for this surface", "below about")
    suggested = float(msg.split("below about ")[1])
    assert_valid(s, flatten(s, FlattenSettings(0.95 * suggested)))


def test_too_fine_is_refused_up_front_by_node_count(monkeypatch):
    monkeypatch.setattr(flatweave.method.drape, "available_memory", lambda: 10 ** 12)  # 1 TB: max_nodes binds
    s = load_example("octant")
    msg = refused(lambda: flatten(s, FlattenSettings(1e-4, max_nodes=100_000)),
                  "157,079,633 nodes", "limit of 100,000 nodes", "smallest spacing that fits is about 0.00396")
    assert "TB of memory" in msg  # 157 million nodes at 12 kB


def test_too_fine_for_the_memory_is_refused_up_front(monkeypatch):
    s = load_example("octant")
    area = region_area(s)
    monkeypatch.setattr(flatweave.method.drape, "available_memory", lambda: 2_000_000_000)
    limit, memory = node_limit(2_000_000)
    assert limit == 2_000_000_000 // BYTES_PER_NODE < 2_000_000 and memory == 2e9
    spacing = 0.9 * math.sqrt(area / limit)  # fewer nodes than max_nodes, more than the memory holds
    msg = refused(lambda: flatten(s, FlattenSettings(spacing)), "2 GB available", f"{limit:,} nodes",
                  "of memory", "smallest spacing that fits")
    need = estimate_node_count(area, spacing, spacing)
    assert f"{need:,} nodes" in msg
    smallest = float(msg.split("fits is about ")[1])
    assert estimate_node_count(area, smallest, smallest) <= limit * 1.01
    # the drape itself sees the same limit (the pipeline passes the area)
    refused(lambda: drape(s, DrapeSettings(spacing), MATERIALS["woven"], area=area), "available")


def test_memory_limit_falls_back_to_max_nodes(monkeypatch):
    monkeypatch.setattr(flatweave.method.drape, "available_memory", lambda: None)
    assert node_limit(123) == (123, None)
    monkeypatch.setattr(flatweave.method.drape, "available_memory", lambda: 10 ** 15)
    assert node_limit(2_000_000)[0] == 2_000_000


def test_available_memory_reads_meminfo_or_falls_back(monkeypatch):
    real = available_memory()
    assert real is None or real > 0
    try:
        with open("/proc/meminfo") as fh:
            kb = next(int(x.split()[1]) for x in fh if x.startswith("MemAvailable:"))
    except (OSError, StopIteration):
        kb = None
    if kb is not None:  # it changes by the moment: the same to within a tenth
        assert real == pytest.approx(kb * 1024, rel=0.1)
    opened = open

    def no_proc(path, *a, **k):
        if str(path).startswith("/proc/"):
            raise FileNotFoundError(path)
        return opened(path, *a, **k)

    monkeypatch.setattr("builtins.open", no_proc)
    fallback = available_memory()
    assert fallback is None or fallback > 0


# ---------------------------------------------------------------------- budgets
@pytest.mark.parametrize("solver", ["fast", "paper"])
def test_iteration_budget_stops_and_is_reported(solver):
    s = load_example("octant")
    r = flatten(s, FlattenSettings(0.1, solver=solver, max_iter=2))
    assert r.solve.status == 1 and r.metrics["iterations"] == 2
    assert r.metrics["solver_status"] == "stopped at the iteration budget (2)"
    assert_valid(s, r)


@pytest.mark.parametrize("solver", ["fast", "paper"])
def test_time_budget_stops_and_is_reported(solver):
    s = load_example("octant")
    r = flatten(s, FlattenSettings(0.1, solver=solver, max_seconds=0.0))
    assert r.solve.status == 2 and r.metrics["iterations"] == 0
    assert r.metrics["solver_status"] == "stopped at the time budget (0 s)"
    assert_valid(s, r)


def test_fast_solver_stops_at_its_budgets_directly():
    s = load_example("garment")
    settings = FlattenSettings(0.05)
    d = drape(s, settings.drape_settings(), settings.material)
    problem = make_problem(s, settings)
    r = minimize(problem, State(d.mesh, d.uv), SolverOptions("fast", max_iter=1))
    assert r.status == 1 and r.nit == 1 and "iteration budget" in r.message
    r = minimize(problem, State(d.mesh, d.uv), SolverOptions("fast", max_seconds=0.0))
    assert r.status == 2 and r.nit == 0 and "time budget" in r.message


# ---------------------------------------------------------------------- scale and position
def test_size_limits_at_construction():
    g = load_example("garment")
    for k, word in ((1e-300, "no usable area"), (1e-45, "too small"), (1e45, "too large"), (1e300, "overflow")):
        refused(lambda: scaled(g, k), word, kind=SurfaceError)
    scaled(g, 10 * MIN_SIZE / g.bbox_diagonal())
    scaled(g, 0.1 * MAX_SIZE / g.bbox_diagonal())
    refused(lambda: scaled(g, 1.0, offset=1e13), "too little for double precision", kind=SurfaceError)


@pytest.mark.slow
@pytest.mark.parametrize("k, offset", [(1e-30, 0.0), (1e30, 0.0), (1.0, 1e6), (1e3, -1e8)])
def test_far_scales_and_positions_give_the_same_pattern(k, offset):
    g = load_example("garment")
    ref = flatten(g, FlattenSettings(0.05))
    s = scaled(g, k, offset)
    r = flatten(s, FlattenSettings(0.05 * k))
    assert_valid(s, r)
    assert r.mesh.n_nodes == ref.mesh.n_nodes
    assert r.metrics["area_error_pct"] == pytest.approx(ref.metrics["area_error_pct"], rel=1e-3)
    assert r.pattern.area / k ** 2 == pytest.approx(ref.pattern.area, rel=1e-6)


def test_paper_line_search_does_not_depend_on_the_scale():
    """The line search's give-up step was an absolute 1e-30: at 1e30 the first
    trial step is already below it and the solver stopped at once."""
    g = load_example("garment")
    out = []
    for k in (1.0, 1e30):
        s = scaled(g, k)
        settings = FlattenSettings(0.05 * k)
        d = drape(s, settings.drape_settings(), settings.material)
        r = minimize(make_problem(s, settings), State(d.mesh, d.uv), SolverOptions("paper", max_iter=10))
        assert r.nit == 10
        out.append(r.fun / k ** 2)
    assert out[1] == pytest.approx(out[0], rel=1e-6)


def test_surface_with_no_area_is_refused_at_flatten():
    # control points on a line: the surface is a segment
    t = np.linspace(0.0, 1.0, 3)
    P = np.stack([np.stack([np.array([a + 0.5 * b, 2 * a + b, 0.0]) for b in t]) for a in t])
    s = NurbsSurface(2, 2, [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1], P)
    refused(lambda: flatten(s, FlattenSettings(0.1)), "no usable area", "not a sheet")


def test_extreme_weights_are_refused():
    g = load_example("garment")
    W = np.ones(g.shape)
    W[0, 0] = 1e20
    refused(lambda: NurbsSurface(g.degree_u, g.degree_v, g.knots_u, g.knots_v, g.ctrlpts, W),
            "ratio", kind=SurfaceError)
    W[0, 0] = 1e6  # large but usable
    s = NurbsSurface(g.degree_u, g.degree_v, g.knots_u, g.knots_v, g.ctrlpts, W)
    assert_valid(s, flatten(s, FlattenSettings(0.05)))


# ---------------------------------------------------------------------- through the CLI
def run_cli(*args):
    p = subprocess.run([sys.executable, "-m", "flatweave", *args], capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


@pytest.mark.slow
@pytest.mark.parametrize("make, args, word", [
    ("cusp", ["--spacing", "0.05"], "covers only"),
    ("line", ["--spacing", "0.1"], "no usable area"),
    ("octant", ["--spacing", "0.1", "--seed", "0,0"], "no complete cell"),
    ("octant", ["--spacing", "5"], "too large for this surface"),
])
def test_hard_surfaces_through_the_cli(tmp_path, make, args, word):
    if make == "octant":
        path = example_path("octant")
    else:
        path = tmp_path / f"{make}.json"
        if make == "cusp":
            save_surface(cusp(), path)
        else:  # a flat strip of zero width: its points lie on a line
            path.write_text(json.dumps({"shape": {"type": "surface", "data": [{
                "degree_u": 1, "degree_v": 1, "knotvector_u": [0, 0, 1, 1], "knotvector_v": [0, 0, 1, 1],
                "size_u": 2, "size_v": 2,
                "control_points": {"points": [[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]]}}]}}))
    out = tmp_path / "r.json"
    code, _, err = run_cli("flatten", str(path), *args, "--out", str(out))
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("flatweave: error:"), err
    assert word in lines[0] and "Traceback" not in err
    assert not out.exists()


def test_every_refusal_is_a_flatweave_error():
    # the GUI and the CLI catch FlatweaveError: nothing above may raise anything else
    for fn in (lambda: flatten(cusp(), FlattenSettings(0.05)),
               lambda: flatten(load_example("octant"), FlattenSettings(50.0)),
               lambda: scaled(load_example("garment"), 1e-300)):
        with pytest.raises(FlatweaveError):
            fn()
