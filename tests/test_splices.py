"""Splices (issue 43, item 2): a piece wider than the roll split by lines along the roll into the fewest
parts that fit, sharing the overlap, placed away from sheared areas, mapped back onto the surface."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from shapely.geometry import Polygon
from shapely.ops import unary_union

from flatweave.cli import main
from flatweave.document.cutplan import project_items, splice_curves, splice_items
from flatweave.document.project import load_project, new_project, save_project
from flatweave.document.solving import solve_pieces
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example
from flatweave.studies.splices import splice_positions, splices_needed, split_outline

from tests.helpers import rectangle



@pytest.mark.parametrize("width, usable, overlap, n", [(1000, 1270, 25, 0), (1593, 1270, 25, 1), (2540, 1270, 25, 2),
                                                       (2515, 1270, 25, 1), (2516, 1270, 25, 2)])
def test_the_fewest_splices_that_make_the_parts_fit(width, usable, overlap, n):
    assert splices_needed(width, usable, overlap) == n
    # n splices give parts of at most usable across; n - 1 would not
    assert (n + 1) * usable - n * overlap >= width
    assert n == 0 or n * usable - (n - 1) * overlap < width


def test_parts_fit_cover_the_piece_and_share_the_overlap():
    piece = rectangle(800.0, 2600.0)
    at = splice_positions(piece, 1270.0, 25.0)
    assert len(at) == 2
    parts = split_outline(piece, at, 25.0)
    assert len(parts) == 3
    assert all(np.ptp(p[:, 1]) <= 1270.0 + 1e-9 for p in parts)
    polys = [Polygon(p) for p in parts]
    assert unary_union(polys).area == pytest.approx(800.0 * 2600.0, rel=1e-12)  # nothing lost
    for a, b in zip(polys, polys[1:]):  # each splice shared by the parts either side, an overlap wide
        assert a.intersection(b).area == pytest.approx(800.0 * 25.0, rel=1e-9)
    # the parts' areas add up to the piece's and an overlap's band per splice
    assert sum(q.area for q in polys) == pytest.approx(800.0 * 2600.0 + 2 * 800.0 * 25.0, rel=1e-12)


def test_a_splice_keeps_out_of_a_sheared_band_when_it_can():
    piece = rectangle(500.0, 2000.0)
    y = np.linspace(0.0, 2000.0, 401)
    points = np.column_stack([np.full_like(y, 250.0), y])
    shear = np.where((y > 900.0) & (y < 1100.0), 25.0, 2.0)
    (alone,) = splice_positions(piece, 1270.0, 25.0)
    (placed,) = splice_positions(piece, 1270.0, 25.0, points, shear)
    assert 900.0 < alone < 1100.0  # with nothing to go by: near the middle
    assert shear[np.abs(y - placed) <= 40.0].max() == 2.0  # no sheared sample within its reach (a fiftieth)
    assert placed + 12.5 <= 1270.0 and 2000.0 - (placed - 12.5) <= 1270.0  # both parts still fit


def test_a_roll_narrower_than_the_overlap_is_one_line():
    with pytest.raises(SettingsError, match="not wider than the splice overlap") as info:
        splice_positions(rectangle(100.0, 3000.0), 20.0, 25.0)
    assert "\n" not in str(info.value)


@pytest.fixture(scope="module")
def sleeve(tmp_path_factory):
    """The half cylinder (1.5 m along its axis, pi/2 m round its arch), woven, its warp along the axis:
    1.57 m across a 1 m roll."""
    p = new_project(load_example("half_cylinder"), "sleeve", "half_cylinder", spacing=0.05)
    p, _ = solve_pieces(p, workers=1)
    return save_project(p, tmp_path_factory.mktemp("sleeve") / "sleeve.flatweave")


def test_a_splice_along_the_roll_on_a_cylinder_is_a_generator(sleeve):
    """On the developable half cylinder a line along the warp in the flat is a generator on the surface:
    its points keep one x and z (the axis is y)."""
    project = load_project(sleeve)
    items, _ = project_items(project, "sleeve.flatweave", 0.0)
    spliced, (report,) = splice_items(items, 1000.0, 25.0)
    assert [it.item.name for it in spliced] == ["sleeve part 1 of 2", "sleeve part 2 of 2"]
    assert report.width == pytest.approx(np.pi * 500.0, rel=2e-3)
    (curve,) = splice_curves(project.result, report, 1000.0)
    assert len(curve) > 100
    assert np.ptp(curve[:, 1]) > 1.4  # along the whole axis
    assert np.ptp(curve[:, 0]) < 1e-3 and np.ptp(curve[:, 2]) < 1e-3  # one generator (1 mm)
    np.testing.assert_allclose(np.hypot(curve[:, 0], curve[:, 2]), 0.5, atol=1e-6)  # on the surface


def test_nest_splices_what_the_roll_cannot_hold(sleeve, tmp_path, capsys):
    table = tmp_path / "m.csv"
    assert main(["nest", str(sleeve), "--roll-width", "1000", "--time-limit", "1", "--export", str(table),
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "spliced into 2 parts" in err and "25 mm overlap" in err
    rows = list(csv.DictReader(table.read_text().splitlines()))
    assert sorted(r["name"] for r in rows) == ["sleeve part 1 of 2", "sleeve part 2 of 2"]


def test_splices_given_by_the_user_are_taken_when_every_part_fits(sleeve, tmp_path, capsys):
    project = load_project(sleeve)
    items, _ = project_items(project, "sleeve.flatweave", 0.0)
    spliced, (report,) = splice_items(items, 1000.0, 25.0, {"sleeve": [700.0]})
    assert report.asked and [round(y - report.start, 9) for y in report.positions] == [700.0]
    widths = sorted(float(np.ptp(_across(it.item.outline, report.frame_deg))) for it in spliced)
    assert widths == pytest.approx(sorted([700.0 + 12.5, report.width - 700.0 + 12.5]), abs=1e-6)
    for placed, says in (([200.0], "part 2 of 2 would be"), ([10.0], "within the 25 mm overlap"),
                         ([700.0, 710.0], "within the 25 mm overlap")):
        with pytest.raises(SettingsError, match=says) as info:
            splice_items(items, 1000.0, 25.0, {"sleeve": placed})
        assert "\n" not in str(info.value)
    with pytest.raises(SettingsError, match="no piece to nest is named 'coat'"):
        splice_items(items, 1000.0, 25.0, {"coat": [700.0]})
    assert main(["nest", str(sleeve), "--roll-width", "1000", "--time-limit", "1", "--splice", "sleeve=800",
                 "--quiet"]) == 0
    assert "spliced as asked into 2 parts at 800 mm" in capsys.readouterr().err


def _across(outline: np.ndarray, frame_deg: float) -> np.ndarray:
    """The outline's y in the frame turned by -frame_deg (across the roll)."""
    a = np.radians(-frame_deg)
    return np.sin(a) * outline[:, 0] + np.cos(a) * outline[:, 1]
