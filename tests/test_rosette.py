"""flatweave.method.rosette: the weft angle picked by a drag from the seed comes back as the
drape's rosette (flatweave.method.fibres.reference_direction), and its frame is the
surface's tangent plane (finite differences of the surface's points)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flatweave.reading.examples import load_example
from flatweave.method.rosette import angle_towards, rosette, rosette_arrows, seed_fraction


@pytest.mark.parametrize("example", ["octant", "saddle"])
def test_the_angle_towards_a_point_is_the_rosette_that_points_there(example):
    s = load_example(example)
    rng = np.random.default_rng(3)
    for seed in ((0.5, 0.5), (0.3, 0.7)):
        r0 = rosette(s, seed, 0.0)
        for a in rng.uniform(-179, 179, 6):
            # a point along the weft at a, lifted off the tangent plane: the lift is not seen
            p = r0.origin + 0.2 * (math.cos(math.radians(a)) * r0.e1 + math.sin(math.radians(a)) * r0.e2) \
                + 0.05 * r0.normal
            got = angle_towards(s, seed, p)
            assert abs((got - a + 180) % 360 - 180) < 1e-9
            r = rosette(s, seed, got)
            d = p - r.origin - (p - r.origin) @ r.normal * r.normal
            np.testing.assert_allclose(r.weft, d / np.linalg.norm(d), atol=1e-12)
    assert angle_towards(s, (0.5, 0.5), rosette(s, (0.5, 0.5), 0).origin + rosette(s, (0.5, 0.5), 0).normal) is None


def test_the_frame_is_the_tangent_plane_and_angle_zero_is_along_u():
    s = load_example("octant")
    seed = (0.4, 0.6)
    r = rosette(s, seed, 30.0)
    dom = np.asarray(s.domain)
    uv = dom[:, 0] + np.array(seed) * (dom[:, 1] - dom[:, 0])
    h = 1e-6 * (dom[:, 1] - dom[:, 0])
    su = (s.points((uv + [h[0], 0])[None])[0] - s.points((uv - [h[0], 0])[None])[0]) / (2 * h[0])
    sv = (s.points((uv + [0, h[1]])[None])[0] - s.points((uv - [0, h[1]])[None])[0]) / (2 * h[1])
    n = np.cross(su, sv)
    n /= np.linalg.norm(n)
    assert abs(r.weft @ n) < 1e-7 and abs(r.warp @ n) < 1e-7 and abs(r.weft @ r.warp) < 1e-12
    np.testing.assert_allclose(r.e1, su / np.linalg.norm(su), atol=1e-7)
    assert math.isclose(float(r.weft @ r.e1), math.cos(math.radians(30)), abs_tol=1e-12)
    np.testing.assert_allclose(s.points(uv[None])[0], r.origin, atol=1e-12)
    assert seed_fraction(s, uv) == pytest.approx(seed)
    weft, warp = rosette_arrows(r, 0.2)
    assert np.linalg.norm(weft[1] - weft[0]) == pytest.approx(0.2) and np.linalg.norm(warp[1] - warp[0]) == \
        pytest.approx(0.14)
