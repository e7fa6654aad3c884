"""The accelerated geometric predicates give the brute force's answers.

``flatweave.method.darts.segments_cross`` (a grid over the dart's segments) against
``segments_cross_brute`` (every pair), and ``flatweave.geometry.numerics.nearest_segments`` (a
k-d tree of segment midpoints) against the argmin of
``polyline_sq_distances``: on random segments, and on coordinates that are
multiples of 1/8 (exact arithmetic: touching ends, colinear overlaps, nodes on
the dart, zero-length segments).
"""

import numpy as np
import pytest

from flatweave.method.darts import CurveDart, SegmentGrid, _cross_pairs, segments_cross, segments_cross_brute
from flatweave.geometry.numerics import nearest_segment, nearest_segments, polyline_distance, polyline_sq_distances


def _cases(seed, n, dyadic):
    rng = np.random.default_rng(seed)
    for t in range(n):
        k = int(rng.integers(2, 400))
        q = np.cumsum(rng.normal(size=(k, 2)) * rng.choice([0.01, 0.1, 1.0]), axis=0)
        m = int(rng.integers(0, 3000))
        p0 = rng.uniform(q.min(0) - 0.2, q.max(0) + 0.2, size=(m, 2))
        p1 = p0 + rng.normal(size=(m, 2)) * rng.choice([0.001, 0.02, 0.3, 3.0])
        if dyadic:
            q, p0, p1 = (np.round(x * 8) / 8 for x in (q, p0, p1))
            if m:  # springs along, onto and ending on the dart's own segments
                j = rng.integers(0, k - 1, size=m // 4)
                p0[: m // 4] = q[j]
                p1[: m // 4] = np.where(rng.random((m // 4, 1)) < 0.5, q[j + 1], 2 * q[j + 1] - q[j])
        yield q, p0, p1


@pytest.mark.slow
@pytest.mark.parametrize("dyadic", [False, True])
def test_segments_cross_is_the_brute_force(dyadic):
    hits = 0
    for q, p0, p1 in _cases(3 if dyadic else 4, 60, dyadic):
        fast = segments_cross(p0, p1, q[:-1], q[1:])
        np.testing.assert_array_equal(fast, segments_cross_brute(p0, p1, q[:-1], q[1:]))
        hits += int(fast.sum())
    assert hits > 1000  # the cases do cross


def test_segments_cross_edge_cases():
    q = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0]])
    p0 = np.array([[0.5, -1], [0.5, 0], [0.5, 1], [1, 0], [3, 0], [-1, 0], [0.5, 0], [1.5, 0.5], [2, 1], [2, 2]])
    p1 = np.array([[0.5, 1], [0.5, 1], [0.5, 2], [1, -1], [4, 0], [0.5, 0], [1.5, 0], [2.5, 0.5], [2, 2], [2, 3]])
    # through; from on the dart (+ side) to +; clear; from a vertex to -; beyond, colinear; colinear
    # overlap; along it; across the last segment; from its tip outward; clear of the tip
    want = [True, False, False, True, False, False, False, True, False, False]
    grid = SegmentGrid(q[:-1], q[1:])
    np.testing.assert_array_equal(segments_cross(p0, p1, q[:-1], q[1:], grid), want)
    np.testing.assert_array_equal(segments_cross_brute(p0, p1, q[:-1], q[1:]), want)
    # many copies go through the grid (not the small-input dense path)
    reps = 5000
    big = segments_cross(np.tile(p0, (reps, 1)), np.tile(p1, (reps, 1)), q[:-1], q[1:], grid)
    np.testing.assert_array_equal(big, np.tile(want, reps))
    nan = segments_cross(np.full((3000, 2), np.nan), np.zeros((3000, 2)), q[:-1], q[1:])
    assert not nan.any()


@pytest.mark.slow
def test_segments_cross_keeps_pairs_whose_boxes_touch():
    """Where the brute force and the grid may differ: rounding in colinear,
    disjoint segments (coordinates like 0.05); the grid answers as exact
    arithmetic does, which a pair test restricted to touching boxes shows."""
    for q, p0, p1 in _cases(6, 30, dyadic=False):
        q, p0, p1 = (np.round(x * 20) / 20 for x in (q, p0, p1))
        fast = segments_cross(p0, p1, q[:-1], q[1:])
        a, b, c, d = p0[:, None], p1[:, None], q[None, :-1], q[None, 1:]
        touch = np.all((np.minimum(a, b) <= np.maximum(c, d)) & (np.maximum(a, b) >= np.minimum(c, d)), axis=-1)
        ref = (_cross_pairs(a, b, c, d) & touch).any(axis=1) if len(p0) else np.zeros(0, bool)
        np.testing.assert_array_equal(fast, ref)


def test_curve_dart_keeps_its_grid_and_answers_the_same():
    uv = np.column_stack([np.linspace(0.1, 0.9, 200), 0.5 + 0.2 * np.sin(np.linspace(0, 6, 200))])
    dart = CurveDart(uv)
    rng = np.random.default_rng(7)
    a = rng.uniform(0, 1, (5000, 2))
    b = a + rng.normal(size=a.shape) * 0.03
    first = dart.crosses(a, b, None, None)
    assert dart._grid() is dart._grid()
    np.testing.assert_array_equal(first, segments_cross_brute(a, b, uv[:-1], uv[1:]))
    np.testing.assert_array_equal(dart.crosses(a, b, None, None), first)
    assert 50 < first.sum() < 5000


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_nearest_segments_is_the_argmin(dim):
    rng = np.random.default_rng(10 + dim)
    for t in range(60):
        k = int(rng.integers(2, 500))
        q = np.cumsum(rng.normal(size=(k, dim)) * rng.choice([0.01, 0.1, 1.0]), axis=0)
        m = int(rng.integers(1, 4000))
        p = rng.uniform(q.min(0) - 0.5, q.max(0) + 0.5, size=(m, dim))
        if t % 3 == 0:  # exact ties: points and curves on a grid of 1/8, repeated points
            q, p = np.round(q * 8) / 8, np.round(p * 8) / 8
            q[k // 2] = q[k // 2 - 1]
            p[: min(m, k)] = q[: min(m, k)]
        d2 = polyline_sq_distances(p, q)
        i, best = nearest_segments(p, q)
        ref = np.argmin(d2, axis=1)
        np.testing.assert_array_equal(i, ref)
        np.testing.assert_array_equal(best, d2[np.arange(m), ref])
        np.testing.assert_array_equal(nearest_segment(p, q), ref)
        np.testing.assert_array_equal(polyline_distance(p, q), np.sqrt(d2.min(axis=1)))


def test_nearest_segments_with_nan_points():
    q = np.column_stack([np.linspace(0, 1, 300), np.zeros(300)])
    p = np.random.default_rng(1).uniform(0, 1, (400, 2))
    p[7] = np.nan
    d2 = polyline_sq_distances(p, q)
    np.testing.assert_array_equal(nearest_segments(p, q)[0], np.argmin(d2, axis=1))
