"""Panels sewn back together (issue 42): on a developable surface split by seams, the two sides
of every sew line come out of their panels' flat patterns equal in length (target: within
0.01 %) and a notch placed on the seam falls at the same length along both (target: within
0.1 mm). Truth from outside the code: the half cylinder develops exactly, so a sew line's flat
length is its length on the surface (a generator's stretch from v = 0.3 of the 1.5 m long
cylinder is 0.45 m)."""

from __future__ import annotations

import numpy as np
import pytest

from flatweave.geometry.panels import Seam, split_region
from flatweave.geometry.region import cover_for
from flatweave.method.pipeline import flatten
from flatweave.method.seams import flat_notches, flat_sew_line, match_sews, notches_along, polyline_length
from flatweave.method.settings import FlattenSettings
from flatweave.reading.examples import load_example

L = 1.5
SPACING = 0.05


def line(a, b, n: int = 40) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) * np.asarray(a, float) + t * np.asarray(b, float)


@pytest.fixture(scope="module")
def sewn():
    """The half cylinder cut along two generators and a helix between them: four panels, each flattened."""
    cyl = load_example("half_cylinder")
    seams = [Seam("g1", line((1 / 3, 0), (1 / 3, 1))), Seam("g2", line((2 / 3, 0), (2 / 3, 1))),
             Seam("helix", line((1 / 3, 0.3), (2 / 3, 0.7)))]
    split = split_region(cyl, None, seams, spacing=SPACING)
    results = {}
    for p in split.panels:
        cover = cover_for(cyl, p.region)
        results[p.name] = flatten(cyl, FlattenSettings(SPACING, seed=cover.default_seed, region=p.region),
                                  area=cover.area)
    return cyl, split, results


def test_four_panels_each_developed(sewn):
    cyl, split, results = sewn
    assert len(split.panels) == 4
    for r in results.values():
        assert r.status == "converged"
        assert r.metrics["boundary_error_pct"] < 1e-3 and r.metrics["area_error_pct"] < 1e-3


def test_every_sew_lines_two_sides_are_equal_in_length(sewn):
    cyl, split, results = sewn
    matches = {m.name: m for m in match_sews(split, results)}
    # the helix meets each generator: g1 and g2 in two stretches each, the helix one
    assert sorted(matches) == ["g1 1", "g1 2", "g2 1", "g2 2", "helix"]
    for m in matches.values():
        assert m.difference_pct < 0.01, m
    # a developable surface: the flat lengths are the lengths on it (the generators' stretches: 0.3 L, 0.7 L)
    assert sorted(round(m.lengths[0], 6) for m in matches.values() if m.seam != "helix") == \
        pytest.approx([0.3 * L, 0.3 * L, 0.7 * L, 0.7 * L], rel=1e-5)
    d = matches["helix"].to_dict()
    assert d["panels"] == list(matches["helix"].panels) and d["difference_pct"] == matches["helix"].difference_pct


def test_notches_fall_at_the_same_length_along_both_sides(sewn):
    cyl, split, results = sewn
    for sew in split.sews:
        marks = notches_along(cyl, sew.uv, every=0.1)
        assert len(marks) >= 6
        a_xy, a = flat_notches(results[sew.panels[0]], sew.uv, marks)
        b_xy, b = flat_notches(results[sew.panels[1]], sew.uv, marks)
        assert np.abs(a - b).max() < 1e-4, sew.name  # 0.1 mm, the cylinder in metres
        assert a[0] == 0.0 and np.all(np.diff(a) > 0)
        assert np.allclose(np.diff(a)[:-1], 0.1, atol=1e-4)  # every 0.1 m of the seam, 0.1 m in the flat
        # the notch lies on the panel's flat sew line (its own outline)
        run = flat_sew_line(results[sew.panels[0]], sew.uv)
        assert polyline_length(run) == pytest.approx(a[-1], rel=1e-9)
        assert np.isfinite(a_xy).all() and np.isfinite(b_xy).all()


def test_a_closed_seams_two_sides_the_disc_and_the_hole_match():
    """A ring seam cuts a disc out of the cylinder: the disc's outline and the other panel's hole are the
    two sides, equal in length, their notches at the same lengths from the ring's first point."""
    cyl = load_example("half_cylinder")
    t = np.linspace(0, 2 * np.pi, 96, endpoint=False)
    ring = np.column_stack([0.5 + 0.2 * np.cos(t), 0.5 + 0.25 * np.sin(t)])
    split = split_region(cyl, None, [Seam("ring", ring, closed=True)], spacing=SPACING)
    results = {}
    for p in split.panels:
        cover = cover_for(cyl, p.region)
        results[p.name] = flatten(cyl, FlattenSettings(SPACING, seed=cover.default_seed, region=p.region),
                                  area=cover.area)
    (m,) = match_sews(split, results)
    assert m.difference_pct < 0.01 and m.lengths[0] > 1.0
    sew = split.sews[0]
    marks = notches_along(cyl, sew.uv, every=0.1)
    a = flat_notches(results[sew.panels[0]], sew.uv, marks)[1]
    b = flat_notches(results[sew.panels[1]], sew.uv, marks)[1]
    assert np.abs(a - b).max() < 1e-4 and a[0] == 0.0 and np.all(np.diff(a) > 0)
