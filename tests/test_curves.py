"""Curve darts (paper 3.4 B): projecting drawn curves onto surfaces, biarc fits.

Projections are checked against closed forms (the octant is a piece of the
unit sphere, the saddle is z = (x^2 - y^2)/2 over [-1, 1]^2) and against a
brute-force dense sampling of the surface; biarc fits against circles, lines,
a sine wave and random smooth curves, and their NURBS pieces against geomdl.
"""

import numpy as np
import pytest
from geomdl import NURBS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flatweave.geometry.curves import Biarcs, fit_biarcs, project_points, project_polyline
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example

VIEWS = {
    "down": (0.0, 0.0, -1.0),
    "oblique": (-0.5, -0.7, -1.0),
    "side": (-1.0, 0.0, 0.0),
    "low": (-0.2, -1.0, 0.15),
}


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module")
def saddle():
    return load_example("saddle")


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------- closed forms
def sphere_octant_hits(P, d):
    """Nearest t with |P + t d| = 1 and x, y, z >= 0 (NaN if none); and the
    discriminant (how far from grazing the line is)."""
    b = P @ d
    disc = b * b - (np.einsum("ij,ij->i", P, P) - 1)
    t = np.full(len(P), np.nan)
    for i in np.nonzero(disc >= 0)[0]:
        for ti in (-b[i] - np.sqrt(disc[i]), -b[i] + np.sqrt(disc[i])):
            if np.all(P[i] + ti * d >= -1e-12):
                t[i] = ti
                break
    return t, disc


def saddle_hits(P, d):
    """Nearest t with P + t d on z = (x^2 - y^2)/2, |x|, |y| <= 1 (NaN if none),
    and the discriminant of the quadratic."""
    A = (d[0] ** 2 - d[1] ** 2) / 2
    t = np.full(len(P), np.nan)
    disc = np.full(len(P), np.inf)
    for i, p in enumerate(P):
        B = p[0] * d[0] - p[1] * d[1] - d[2]
        C = (p[0] ** 2 - p[1] ** 2) / 2 - p[2]
        if abs(A) < 1e-14:
            roots = [-C / B]
        else:
            disc[i] = B * B - 4 * A * C
            if disc[i] < 0:
                continue
            r = np.sqrt(disc[i])
            roots = sorted([(-B - r) / (2 * A), (-B + r) / (2 * A)])
        for ti in roots:
            X = p + ti * d
            if abs(X[0]) <= 1 + 1e-12 and abs(X[1]) <= 1 + 1e-12:
                t[i] = ti
                break
    return t, disc


def line_distance(xyz, P, d):
    w = xyz - P
    return np.linalg.norm(w - (w @ d)[:, None] * d, axis=1)


def check_exact(surface, pr, P, d):
    """Every hit is on the surface, on its line, inside the domain, with t consistent."""
    h = pr.hit
    assert np.all(np.abs(surface.points(pr.uv[h]) - pr.xyz[h]) < 1e-10)
    assert np.all(line_distance(pr.xyz[h], P[h], d) < 1e-9)
    assert surface.in_domain(pr.uv[h]).all()
    assert np.allclose(P[h] + pr.t[h][:, None] * d, pr.xyz[h], atol=1e-9)
    assert np.all(np.isnan(pr.uv[~h])) and np.all(np.isnan(pr.xyz[~h])) and np.all(np.isnan(pr.t[~h]))


def random_rays(rng, lo, hi, d, n, back=3.0):
    return rng.uniform(lo, hi, (n, 3)) - back * d


# ---------------------------------------------------------------- project_points
@pytest.mark.parametrize("view", list(VIEWS))
def test_octant_projection_matches_the_sphere(octant, view):
    d = unit(VIEWS[view])
    rng = np.random.default_rng(1)
    P = random_rays(rng, -0.2, 1.2, d, 600)
    pr = project_points(octant, P, VIEWS[view])  # any length
    check_exact(octant, pr, P, d)
    t, disc = sphere_octant_hits(P, d)
    clear = np.abs(disc) > 1e-9  # away from exact tangency
    assert np.array_equal(pr.hit[clear], ~np.isnan(t[clear]))
    both = pr.hit & ~np.isnan(t)
    assert np.all(np.abs(pr.t[both] - t[both]) < np.where(disc[both] > 1e-4, 1e-9, 1e-5))
    assert pr.hit.sum() > 100 and (~pr.hit).sum() > 50


@pytest.mark.parametrize("view", list(VIEWS))
def test_saddle_projection_takes_the_intersection_nearest_the_camera(saddle, view):
    d = unit(VIEWS[view])
    rng = np.random.default_rng(2)
    P = random_rays(rng, -1.3, 1.3, d, 600, back=4.0)
    pr = project_points(saddle, P, d)
    check_exact(saddle, pr, P, d)
    t, disc = saddle_hits(P, d)
    clear = np.abs(disc) > 1e-9
    assert np.array_equal(pr.hit[clear], ~np.isnan(t[clear]))
    both = pr.hit & ~np.isnan(t)
    assert np.all(np.abs(pr.t[both] - t[both]) < np.where(disc[both] > 1e-4, 1e-9, 1e-5))


def test_side_view_of_the_saddle_meets_it_twice_and_keeps_the_front(saddle):
    # seen along -y, the line (x, ., z) meets the saddle at y = +-sqrt(x^2 - 2 z)
    x = np.linspace(-0.75, 0.75, 7)  # both within |y| <= 1
    P = np.column_stack([x, np.full_like(x, 5.0), np.full_like(x, -0.2)])
    pr = project_points(saddle, P, (0, -1, 0))
    assert pr.hit.all()
    assert np.allclose(pr.xyz[:, 1], np.sqrt(x ** 2 + 0.4), atol=1e-12)
    # seen from the other side, the other one
    pr = project_points(saddle, P * [1, -1, 1], (0, 1, 0))
    assert np.allclose(pr.xyz[:, 1], -np.sqrt(x ** 2 + 0.4), atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("name,view", [("octant", "oblique"), ("octant", "side"),
                                       ("saddle", "side"), ("saddle", "low")])
def test_nearest_hit_against_dense_sampling(name, view):
    """No densely sampled surface point lies on the line (within the sampling
    distance) markedly nearer the camera than the reported hit, and the reported
    hit has samples next to it."""
    s = load_example(name)
    d = unit(VIEWS[view])
    n = 500
    dom = s.domain
    g = np.stack(np.meshgrid(np.linspace(*dom[0], n), np.linspace(*dom[1], n), indexing="ij"), -1)
    X = s.points(g.reshape(-1, 2))
    G = X.reshape(n, n, 3)
    spacing = max(np.linalg.norm(np.diff(G, axis=0), axis=2).max(),
                  np.linalg.norm(np.diff(G, axis=1), axis=2).max())
    rng = np.random.default_rng(3)
    P = random_rays(rng, X.min(axis=0), X.max(axis=0), d, 40, back=3.0)
    pr = project_points(s, P, d)
    assert pr.hit.sum() >= 15
    for i in np.nonzero(pr.hit)[0]:
        w = X - P[i]
        t = w @ d
        near = np.linalg.norm(w - t[:, None] * d, axis=1) < spacing
        assert near.any()
        # reported point has a sample within the sampling distance
        assert np.linalg.norm(X[near] - pr.xyz[i], axis=1).min() < 2 * spacing
        # and none markedly nearer the camera (the sampling's slack grows along a
        # glancing line)
        normal = s.evaluate(pr.uv[i:i + 1]).normal[0]
        slack = 2 * spacing / max(abs(normal @ d), 0.05)
        assert t[near].min() > pr.t[i] - slack


def test_lines_that_miss_are_reported_not_raised(octant, saddle):
    # beside the surface, and parallel to the saddle's plane far above it
    P = np.array([[3.0, 3.0, 5.0], [-2.0, 0.5, 5.0], [0.5, -0.01, 5.0]])
    pr = project_points(octant, P, (0, 0, -1))
    assert not pr.hit.any() and np.isnan(pr.uv).all() and np.isnan(pr.t).all()
    pr = project_points(saddle, [[0.0, -5.0, 3.0], [0.2, -5.0, 0.7]], (0, 1, 0))
    assert not pr.hit.any()
    # empty input
    pr = project_points(saddle, np.zeros((0, 3)), (0, 0, -1))
    assert pr.uv.shape == (0, 2) and pr.hit.shape == (0,)


def test_grazing_the_octant_rim_converges_or_misses(octant):
    # looking straight down, the rim z = 0 is a silhouette: lines at radius r
    phi = np.linspace(0.02, np.pi / 2 - 0.02, 9)
    for r in (1 - 1e-3, 1 - 1e-6, 1 - 1e-9, 1 - 1e-12, 1.0, 1 + 1e-9, 1 + 1e-6, 1 + 1e-3):
        P = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.full_like(phi, 2.0)])
        pr = project_points(octant, P, (0, 0, -1))
        check_exact(octant, pr, P, np.array([0.0, 0.0, -1.0]))
        if r < 1 - 1e-12:
            assert pr.hit.all()
        if r > 1 + 1e-10:
            assert not pr.hit.any()
        truth = np.column_stack([P[:, :2], np.full_like(phi, np.sqrt(max(1 - r * r, 0)))])
        assert np.all(np.linalg.norm(pr.xyz[pr.hit] - truth[pr.hit], axis=1) < 1e-5)
    # seen from the side (along -x) near the pole, where S_v vanishes
    for r in (1 - 1e-4, 1 - 1e-8, 1 + 1e-8):
        P = np.column_stack([np.full_like(phi, 3.0), r * np.cos(phi), r * np.sin(phi)])
        pr = project_points(octant, P, (-1, 0, 0))
        check_exact(octant, pr, P, np.array([-1.0, 0.0, 0.0]))
        assert pr.hit.all() if r < 1 else not pr.hit.any()
        truth = np.column_stack([np.full_like(phi, np.sqrt(max(1 - r * r, 0))), P[:, 1:]])
        assert np.all(np.linalg.norm(pr.xyz[pr.hit] - truth[pr.hit], axis=1) < 1e-4)


def test_line_tangent_inside_the_octant(octant):
    n = unit([1, 1, 1])
    d = unit(np.cross(n, [0, 0, 1]))
    for eps, hit in ((1e-3, True), (1e-6, True), (1e-9, True), (-1e-9, False), (-1e-3, False)):
        P = (1 - eps) * n - 3 * d
        pr = project_points(octant, P[None], d)
        assert pr.hit[0] == hit
        if hit:  # one of the two (close) intersections, never anywhere else
            assert np.linalg.norm(pr.xyz[0] - n) < 2 * np.sqrt(2 * eps) + 1e-6
            t, _ = sphere_octant_hits(P[None], d)
            assert pr.t[0] == pytest.approx(t[0], abs=1e-6 + 1e-3 * np.sqrt(eps))


def test_projection_onto_the_pole(octant):
    pr = project_points(octant, [[0.0, 0.0, 4.0], [1e-9, 1e-9, 4.0]], (0, 0, -1))
    assert pr.hit.all()
    assert np.allclose(pr.xyz, [[0, 0, 1], [1e-9, 1e-9, 1]], atol=1e-12)
    assert np.all(pr.uv[:, 0] < 1e-6)


def test_project_points_rejects_bad_input(octant):
    with pytest.raises(SettingsError):
        project_points(octant, [[0, 0, 1]], (0, 0, 0))
    with pytest.raises(SettingsError):
        project_points(octant, [[0, 0]], (0, 0, -1))
    with pytest.raises(SettingsError):
        project_points(octant, [[0, np.nan, 1]], (0, 0, -1))


# ---------------------------------------------------------------- project_polyline
def default_step(surface):
    """1/100 of the diagonal of the surface's bounding box (sampled finely; the
    surface's own box, smaller than its control net's)."""
    g = np.linspace(0, 1, 201)
    dom = surface.domain
    uv = np.stack(np.meshgrid(dom[0, 0] + g * np.ptp(dom[0]), dom[1, 0] + g * np.ptp(dom[1])), -1)
    return np.linalg.norm(np.ptp(surface.points(uv.reshape(-1, 2)), axis=0)) / 100


def check_curve(surface, curve, drawn, d, max_step):
    assert np.all(np.abs(surface.points(curve.uv) - curve.xyz) < 1e-10)
    assert surface.in_domain(curve.uv).all()
    # every point on the line through its place on the drawing
    i = curve.source_index
    f = (curve.source_param - i)[:, None]
    src = drawn[i] + f * (drawn[i + 1] - drawn[i])
    assert np.all(line_distance(curve.xyz, src, d) < 1e-9)
    assert np.all(np.diff(curve.source_param) > 0)
    assert np.all((i >= 0) & (i <= len(drawn) - 2))
    steps = np.linalg.norm(np.diff(curve.xyz, axis=0), axis=1)
    assert steps.max() <= max_step * (1 + 1e-9)


def test_polyline_from_beyond_the_rim_onto_the_octant(octant):
    t = np.linspace(0, 1, 15)
    drawn = np.column_stack([1.3 - 1.0 * t, 0.3 + 0.3 * np.sin(3 * t), np.full_like(t, 3.0)])
    d = np.array([0.0, 0.0, -1.0])
    c = project_polyline(octant, drawn, d)
    check_curve(octant, c, drawn, d, default_step(octant))
    assert c.complete and c.clipped and c.n_pieces == 1
    assert c.xyz[0, 2] < 1e-4                       # starts on the rim ...
    assert abs(np.linalg.norm(c.xyz[0]) - 1) < 1e-12
    assert np.allclose(c.xyz[-1], [drawn[-1, 0], drawn[-1, 1],
                                   np.sqrt(1 - drawn[-1, 0] ** 2 - drawn[-1, 1] ** 2)])  # ... ends where drawn


@pytest.mark.parametrize("view", ["oblique", "side"])
def test_polyline_on_the_octant_from_other_views(octant, view):
    d = unit(VIEWS[view])
    # draw a curve on the sphere, then move it back towards the camera
    s = np.linspace(0.1, 0.9, 9)
    on = np.column_stack([np.cos(s) * 0.6, np.sin(s) * 0.6, np.full_like(s, 0.0)])
    on[:, 2] = np.sqrt(1 - on[:, 0] ** 2 - on[:, 1] ** 2)
    drawn = on - 2.5 * d
    c = project_polyline(octant, drawn, d, max_step=0.01)
    check_curve(octant, c, drawn, d, 0.01)
    assert c.complete and not c.clipped
    assert np.allclose(c.xyz[[0, -1]], on[[0, -1]], atol=1e-12)


def test_polyline_partly_off_the_surface_keeps_the_longest_piece(saddle):
    drawn = np.array([[-0.8, -0.5, 2], [0.2, 0.0, 2], [0.5, 1.5, 2], [0.8, 0.0, 2], [0.9, -0.5, 2]], float)
    d = np.array([0.0, 0.0, -1.0])
    c = project_polyline(saddle, drawn, d)
    check_curve(saddle, c, drawn, d, default_step(saddle))
    assert default_step(saddle) < saddle.bbox_diagonal() / 100
    assert not c.complete and c.clipped and c.n_pieces == 2
    # the first piece (from (-0.8, -0.5) to the edge y = 1 at x = 0.4) is the longer
    assert np.allclose(c.xyz[0, :2], [-0.8, -0.5])
    assert np.allclose(c.xyz[-1, :2], [0.4, 1.0], atol=1e-7)
    assert set(np.unique(c.source_index)) == {0, 1}


def test_polyline_broken_where_the_surface_hides_itself(saddle):
    # seen from below at a slant, the front edge y = 1 hides part of the saddle:
    # the nearest hit jumps, so the projection has two pieces
    d = unit([0.0, -1.0, 0.3])
    a = np.array([-1.2, 0.0, 0.0]) - 6 * d
    drawn = np.array([a, a + [2.4, 0.0, 0.0]])
    c = project_polyline(saddle, drawn, d)
    check_curve(saddle, c, drawn, d, default_step(saddle))
    assert not c.complete and c.n_pieces >= 2


def test_polyline_needs_two_hits(octant):
    with pytest.raises(SettingsError):
        project_polyline(octant, [[3, 3, 5], [4, 3, 5]], (0, 0, -1))
    with pytest.raises(SettingsError):
        project_polyline(octant, [[0.5, 0.5, 5]], (0, 0, -1))
    with pytest.raises(SettingsError):
        project_polyline(octant, [[0.5, 0.5, 5], [0.6, 0.5, 5]], (0, 0, -1), max_step=0.0)


# ---------------------------------------------------------------- biarcs
def g1_jump(b: Biarcs) -> float:
    if b.count < 2:
        return 0.0
    te, ts = b.tangent_end[:-1], b.tangent[1:]
    return float(np.abs(np.arctan2(te[:, 0] * ts[:, 1] - te[:, 1] * ts[:, 0],
                                   np.einsum("ij,ij->i", te, ts))).max())


def check_chain(b: Biarcs, uv, tol):
    assert b.max_deviation(uv) <= tol
    assert g1_jump(b) < 1e-8
    assert np.all(b.end[:-1] == b.start[1:])
    assert np.all(b.start[0] == uv[0]) and np.all(b.end[-1] == uv[-1])
    assert np.all(np.abs(b.sweep) < np.pi)
    # each piece's end is where its start, tangent and sweep put it
    ends = b.points_at(np.arange(b.count), b.lengths)
    assert np.abs(ends - b.end).max() < 1e-12
    arcs = ~b.line
    r = np.linalg.norm(b.start[arcs] - b.centre[arcs], axis=1)
    assert np.allclose(r, b.radius[arcs], rtol=1e-9)


@pytest.mark.parametrize("direction", [1, -1])
def test_circular_arc_is_one_arc(direction):
    th = np.linspace(0.2, 0.2 + np.deg2rad(140), 200)[::direction]
    uv = np.column_stack([0.3 + 0.25 * np.cos(th), 0.4 + 0.25 * np.sin(th)])
    b = fit_biarcs(uv, 1e-6)
    check_chain(b, uv, 1e-6)
    assert b.count == 1 and not b.line[0]
    assert b.sweep[0] == pytest.approx(direction * np.deg2rad(140), abs=1e-12)
    assert b.radius[0] == pytest.approx(0.25, abs=1e-12)
    assert np.allclose(b.centre[0], [0.3, 0.4], atol=1e-12)
    assert b.max_deviation(uv) < 1e-13
    assert b.length() == pytest.approx(0.25 * np.deg2rad(140), abs=1e-12)


def test_long_circular_arc_is_two_arcs_of_it():
    th = np.linspace(0, np.deg2rad(300), 50)
    uv = np.column_stack([np.cos(th), np.sin(th)])
    b = fit_biarcs(uv, 1e-6)
    check_chain(b, uv, 1e-6)
    assert b.count == 2 and np.allclose(b.radius, 1, atol=1e-12) and np.allclose(b.centre, 0, atol=1e-12)


def test_straight_line_is_lines():
    uv = np.column_stack([np.linspace(0, 1, 50), np.linspace(0.2, 0.7, 50)])
    b = fit_biarcs(uv, 1e-6)
    check_chain(b, uv, 1e-6)
    assert b.count == 1 and b.line.all() and np.isinf(b.radius).all() and np.isnan(b.centre).all()
    b = fit_biarcs([[0, 0], [1, 1]], 1e-3)
    assert b.count == 1 and b.line[0] and b.length() == pytest.approx(np.sqrt(2))
    # duplicated points are ignored
    b = fit_biarcs([[0, 0], [0.5, 0.5], [0.5, 0.5], [1, 1]], 1e-3)
    assert b.count == 1 and b.line[0]


def test_straight_runs_between_bends_are_lines():
    # line, quarter circle, line
    a = np.column_stack([np.linspace(0, 1, 40), np.zeros(40)])
    th = np.linspace(-np.pi / 2, 0, 30)[1:]
    c = np.column_stack([1 + 0.3 * np.cos(th), 0.3 + 0.3 * np.sin(th)])
    e = np.column_stack([np.full(40, 1.3), np.linspace(0.3, 1.3, 40)])[1:]
    uv = np.vstack([a, c, e])
    b = fit_biarcs(uv, 1e-4)
    check_chain(b, uv, 1e-4)
    assert b.line.sum() >= 2 and b.count <= 7
    assert b.length() == pytest.approx(2 + 0.15 * np.pi, rel=1e-3)


@pytest.mark.parametrize("tol", [1e-2, 1e-3, 1e-4, 1e-6])
def test_sine_wave_within_tolerance(tol):
    x = np.linspace(0, 1, 400)
    uv = np.column_stack([x, 0.5 + 0.1 * np.sin(4 * np.pi * x)])
    b = fit_biarcs(uv, tol)
    check_chain(b, uv, tol)
    # far fewer arcs than points, more for tighter tolerances
    assert b.count <= {1e-2: 12, 1e-3: 30, 1e-4: 50, 1e-6: 250}[tol]
    exact_length = np.sum(np.linalg.norm(np.diff(np.column_stack(
        [np.linspace(0, 1, 100001), 0.5 + 0.1 * np.sin(4 * np.pi * np.linspace(0, 1, 100001))]), axis=0), axis=1))
    assert b.length() == pytest.approx(exact_length, rel=10 * tol + 1e-6)


def smooth_curve(coef: np.ndarray, n: int) -> np.ndarray:
    """A smooth open curve with no cusps: x = t + small waves, y = waves."""
    t = np.linspace(0, 1, n)
    k = np.arange(1, coef.shape[1] + 1)
    wx = (coef[0] / k ** 2) @ np.sin(np.pi * np.outer(k, t))
    wy = (coef[1] / k) @ np.sin(np.pi * np.outer(k, t) + 0.5)
    return np.column_stack([t + 0.25 * wx / np.pi, 0.3 * wy])


@pytest.mark.parametrize("tol", [1e-3, 1e-5])
def test_random_smooth_curves_within_tolerance(tol):
    rng = np.random.default_rng(7)
    for _ in range(4):
        uv = smooth_curve(rng.uniform(-1, 1, (2, 6)), 300)
        b = fit_biarcs(uv, tol)
        check_chain(b, uv, tol)
        assert b.count < 150


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(coef=st.lists(st.floats(-1, 1), min_size=10, max_size=10),
       n=st.integers(20, 250), tol_exp=st.floats(-6, -2), scale=st.floats(0.01, 100))
def test_property_random_curves(coef, n, tol_exp, scale):
    uv = scale * smooth_curve(np.array(coef).reshape(2, 5), n) + [3.0, -1.0]
    tol = scale * 10 ** tol_exp
    b = fit_biarcs(uv, tol)
    check_chain(b, uv, tol)
    assert b.count <= 2 * (n - 1)


def test_nurbs_pieces_are_the_arcs():
    x = np.linspace(0, 1, 200)
    uv = np.column_stack([x, 0.5 + 0.1 * np.sin(4 * np.pi * x)])
    b = fit_biarcs(uv, 1e-4)
    pieces = b.to_nurbs()
    assert len(pieces) == b.count
    s = np.linspace(0, 1, 21)
    for i, pc in enumerate(pieces):
        P, w = pc.ctrlpts, pc.weights
        assert P.shape == (3, 2) and w.shape == (3,)
        assert np.allclose(w, [1, np.cos(b.sweep[i] / 2), 1], rtol=0, atol=1e-15)
        assert np.allclose(P[[0, 2]], [b.start[i], b.end[i]], atol=0)
        legs = np.linalg.norm(P[1] - P[[0, 2]], axis=1)
        assert legs[0] == pytest.approx(legs[1], rel=1e-9)  # isosceles
        crv = NURBS.Curve()
        crv.degree = 2
        crv.ctrlpts = P.tolist()
        crv.weights = w.tolist()
        crv.knotvector = [0, 0, 0, 1, 1, 1]
        pts = np.array([crv.evaluate_single(float(t)) for t in s])
        assert np.abs(pts - pc.evaluate(s)).max() < 1e-14
        if not b.line[i]:  # on the circle, and on this arc
            assert np.allclose(np.linalg.norm(pts - b.centre[i], axis=1), b.radius[i], rtol=1e-10)
        near = np.min(np.linalg.norm(pts[:, None] - b.sample(1e-4)[None], axis=2), axis=1)
        assert near.max() < 1e-4
        assert b.max_deviation(pts) < 1e-12


def test_sample_and_segments():
    th = np.linspace(0, np.pi / 2, 100)
    uv = np.column_stack([np.cos(th), np.sin(th)])
    b = fit_biarcs(uv, 1e-6)
    p = b.sample(0.01)
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert steps.max() <= 0.01 and np.allclose(p[[0, -1]], uv[[0, -1]], atol=1e-15)
    assert np.allclose(np.linalg.norm(p, axis=1), 1, atol=1e-13)
    seg = b.segments(0.01)
    assert seg.shape == (len(p) - 1, 2, 2) and np.all(seg[1:, 0] == seg[:-1, 1])
    assert b.length() == pytest.approx(np.pi / 2, abs=1e-12)
    with pytest.raises(SettingsError):
        b.sample(0)


def test_fit_biarcs_rejects_bad_input():
    uv = np.column_stack([np.linspace(0, 1, 5), np.zeros(5)])
    for bad_tol in (0, -1, np.nan):
        with pytest.raises(SettingsError):
            fit_biarcs(uv, bad_tol)
    with pytest.raises(SettingsError):
        fit_biarcs(uv[:1], 1e-3)
    with pytest.raises(SettingsError):
        fit_biarcs(np.zeros((4, 2)), 1e-3)
    with pytest.raises(SettingsError):
        fit_biarcs(np.ones((4, 3)), 1e-3)
    with pytest.raises(SettingsError):  # doubles straight back: a cusp
        fit_biarcs([[0, 0], [1, 0], [0.5, 0]], 1e-3)


def test_drawn_dart_on_the_octant_end_to_end(octant):
    t = np.linspace(0, 1, 12)
    drawn = np.column_stack([1.2 - 0.9 * t, 0.1 + 0.5 * t + 0.1 * np.sin(np.pi * t), np.full_like(t, 2.0)])
    c = project_polyline(octant, drawn, (0, 0, -1))
    b = fit_biarcs(c.uv, 1e-3)
    check_chain(b, c.uv, 1e-3)
    assert b.count < len(c.uv) / 3
    uv = b.sample(1e-3)
    assert octant.in_domain(uv, tol=1e-3).all()
