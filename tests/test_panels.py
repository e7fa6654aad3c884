"""A region split into panels by seams (issue 42, first stage: flatweave.geometry.panels).
Truth from outside the code: the half cylinder's exact area (pi R L) and generator length (L)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flatweave.errors import SettingsError
from flatweave.geometry.panels import MIN_CELLS, Seam, split_region
from flatweave.geometry.uvregion import region_area
from flatweave.reading.examples import load_example

R, L = 0.5, 1.5  # the bundled half cylinder's radius and length


@pytest.fixture(scope="module")
def cyl():
    return load_example("half_cylinder")


def line(a, b, n: int = 40) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) * np.asarray(a, float) + t * np.asarray(b, float)


def length_3d(surface, uv: np.ndarray, per: int = 64) -> float:
    """The (u, v) polyline's length on the surface, each segment sampled ``per`` times."""
    t = np.linspace(0.0, 1.0, per + 1)[None, :, None]
    pts = (uv[:-1, None, :] * (1 - t) + uv[1:, None, :] * t).reshape(-1, 2)
    P = surface.points(pts).reshape(len(uv) - 1, per + 1, 3)
    return float(np.linalg.norm(np.diff(P, axis=1), axis=2).sum())


def test_two_generators_make_three_panels_covering_the_cylinder_whose_sew_lines_are_its_length(cyl):
    seams = [Seam("s1", line((1 / 3, 0), (1 / 3, 1))), Seam("s2", line((2 / 3, 0), (2 / 3, 1)))]
    split = split_region(cyl, None, seams, spacing=0.05)
    panels = split.panels
    assert [p.name for p in panels] == ["panel 1", "panel 2", "panel 3"]
    assert [(s.name, s.seam, s.panels) for s in split.sews] == [("s1", "s1", ("panel 1", "panel 2")),
                                                                 ("s2", "s2", ("panel 2", "panel 3"))]
    areas = [region_area(cyl, p.region.arrays()) for p in panels]
    assert sum(areas) == pytest.approx(math.pi * R * L, rel=1e-9)
    assert [sorted(p.sew) for p in panels] == [["s1"], ["s1", "s2"], ["s2"]]
    for p in panels:
        for name, uv in p.sew.items():
            assert length_3d(cyl, uv) == pytest.approx(L, rel=1e-9)
    # the two sides of a seam are the same (u, v) curve
    assert np.array_equal(panels[0].sew["s1"], panels[1].sew["s1"])


def test_a_helix_seam_splits_the_cylinder_in_two_with_equal_sew_lines(cyl):
    panels = split_region(cyl, None, [Seam("helix", line((0.2, 0.0), (0.8, 1.0)))], spacing=0.05).panels
    assert len(panels) == 2
    l1, l2 = (length_3d(cyl, p.sew["helix"]) for p in panels)
    assert l1 == pytest.approx(l2, rel=1e-12) and l1 > L  # longer than a generator: it winds round
    assert sum(region_area(cyl, p.region.arrays()) for p in panels) == pytest.approx(math.pi * R * L, rel=1e-9)


def test_a_closed_seam_cuts_a_panel_out_leaving_a_hole(cyl):
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = np.column_stack([0.5 + 0.2 * np.cos(t), 0.5 + 0.2 * np.sin(t)])
    panels = split_region(cyl, None, [Seam("ring", ring, closed=True)], spacing=0.05).panels
    holes = sorted(p.region.n_holes for p in panels)
    assert holes == [0, 1]
    inner = next(p for p in panels if p.region.n_holes == 0)
    outer = next(p for p in panels if p.region.n_holes == 1)
    assert length_3d(cyl, inner.sew["ring"]) == pytest.approx(length_3d(cyl, outer.sew["ring"]), rel=1e-9)


def test_a_t_junction_and_ends_drawn_short_or_beyond_the_rim(cyl):
    # the branch is listed first and stops a little short of the seam it meets: it is carried on to it
    seams = [Seam("branch", line((0.0, 0.5), (0.49, 0.5))), Seam("main", line((0.5, -0.2), (0.5, 0.99)))]
    split = split_region(cyl, None, seams, spacing=0.05)
    panels = {p.name: p for p in split.panels}
    assert len(panels) == 3
    # the branch meets the main seam half way: main in two stretches, each between the right panel and one left
    sews = {s.name: s for s in split.sews}
    assert sorted(sews) == ["branch", "main 1", "main 2"]
    right = next(p for p in panels.values() if "branch" not in p.sew)
    assert sorted(right.sew) == ["main 1", "main 2"]
    assert sews["main 1"].panels != sews["main 2"].panels and all(right.name in s.panels for s in (sews["main 1"],
                                                                                                  sews["main 2"]))
    total = sum(length_3d(cyl, sews[n].uv) for n in ("main 1", "main 2"))
    assert total == pytest.approx(L, rel=1e-9)  # clipped and snapped: rim to rim
    assert length_3d(cyl, sews["main 1"].uv) == pytest.approx(L / 2, rel=1e-9)


@pytest.mark.parametrize("seams, says", [
    ([Seam("dangle", line((0.5, 0.0), (0.5, 0.5)))], "seam 'dangle' does not reach an edge or another seam"),
    ([Seam("zigzag", np.array([[0.2, 0.0], [0.8, 1.0], [0.8, 0.0], [0.2, 1.0]]))], "seam 'zigzag' crosses itself"),
    ([Seam("away", line((2.0, 2.0), (3.0, 3.0)))], "seam 'away' does not cross the region"),
    ([Seam("a", line((0.5, 0), (0.5, 1))), Seam("b", line((0.5005, 0), (0.5005, 1)))], "under the 6 a panel needs"),
    ([Seam("a", line((0.5, 0), (0.5, 1))), Seam("a", line((0.2, 0), (0.2, 1)))], "two seams have the same name"),
    ([Seam("nan", np.array([[0.5, 0.0], [np.nan, 1.0]]))], "seam 'nan' must be at least two finite"),
])
def test_bad_seams_are_one_line(cyl, seams, says):
    with pytest.raises(SettingsError, match=says) as exc:
        split_region(cyl, None, seams, spacing=0.05)
    assert "\n" not in str(exc.value)
    assert MIN_CELLS == 6


def test_no_seams_is_the_region_itself(cyl):
    (panel,) = split_region(cyl, None, [], spacing=0.05).panels
    assert panel.sew == {} and region_area(cyl, panel.region.arrays()) == pytest.approx(math.pi * R * L, rel=1e-9)
