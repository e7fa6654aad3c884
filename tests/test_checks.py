"""The project's consistency checks (issue 41, item 6; flatweave.document.checks):
two plies at one sequence number, a material the table lacks, a region off the
tool, fibres that turn past the tolerance from a ply's orientation; none on a
consistent project of a developable piece; shown by the CLI's solve."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from flatweave import flatten
from flatweave.document import pieces as P
from flatweave.document.checks import FIBRE_TOL_DEG, project_checks
from flatweave.document.project import new_project
from flatweave.document.solving import solve_pieces
from flatweave.geometry.region import Region
from flatweave.method.fibres import result_fibres
from flatweave.reading.registry import open_path
from flatweave.reading.examples import load_example


def test_a_consistent_laminate_on_a_developable_tool_has_no_warnings():
    s = load_example("half_cylinder")
    p = new_project(s, "shell", spacing=0.2)
    p = P.set_sequence(P.duplicate(P.set_sequence(p, 0, 1), 0, angle_deg=90.0), 1, 2)
    solved = [replace(x, result=flatten(s, x.settings)) for x in p.pieces]
    p = P.with_pieces(p, solved, 0)
    assert project_checks(p) == []
    # a developable tool: the cloth's threads stay at the ply's orientation (no turn past the tolerance)
    assert all(np.nanmax(np.abs(result_fibres(x.result).deviation_deg)) < FIBRE_TOL_DEG for x in p.pieces)


def test_each_inconsistency_is_one_line_naming_its_pieces():
    s = load_example("octant")
    p = new_project(s, "tool", spacing=0.12)
    p = P.duplicate(P.set_sequence(p, 0, 3), 0, "twin")  # the copy keeps sequence 3
    p = P.add(p, "off the tool", settings=replace(p.settings, region=Region.from_loops(
        [(0.5, 0.5), (1.2, 0.5), (1.2, 1.2), (0.5, 1.2)])))
    p = P.set_materials(p, [f for f in p.materials if f.name != "woven"])  # the pieces' material dropped
    r = flatten(s, p.pieces[0].settings)
    p = P.with_pieces(p, (replace(p.pieces[0], result=r),) + p.pieces[1:], 0)
    warnings = project_checks(p)
    worst = float(np.nanmax(np.abs(result_fibres(r).deviation_deg)))
    assert worst > FIBRE_TOL_DEG  # the octant's fibres turn by 21.7 degrees from the seed's orientation
    assert warnings == [
        "pieces 'tool', 'twin' share sequence 3: a laminate lays one ply at each place in its stack",
        "piece 'tool' is cut from 'woven', which the materials table lacks",
        f"piece 'tool': its fibres turn up to {worst:.1f} deg from its orientation on the tool (tolerance 5 deg)",
        "piece 'twin' is cut from 'woven', which the materials table lacks",
        "piece 'off the tool' is cut from 'woven', which the materials table lacks",
        "piece 'off the tool' reaches beyond its surface: its region leaves the surface's domain",
    ]
    assert all("\n" not in w for w in warnings)
    assert project_checks(p, fibre_tol_deg=30.0) == warnings[:2] + warnings[3:]


@pytest.mark.slow
def test_the_pieces_tab_shows_the_checks(make_window):
    win = make_window(example="octant")
    panel = win.pieces_panel
    assert not panel.checks.isVisibleTo(panel)
    panel.duplicate_at(0, 45.0)
    win.piece_edit("Sequence", lambda p: P.set_sequence(P.set_sequence(p, 0, 1), 1, 1), False)
    assert panel.checks.isVisibleTo(panel) and "share sequence 1" in panel.checks.text()
    assert panel.checks.toolTip() == panel.checks.text()  # few: all listed


def test_many_checks_are_counted_under_the_list_and_listed_in_the_tip(make_window):
    """The bundled 24-ply job once solved warns of every ply's fibre turn: four lines under the list,
    the last counting the rest, and the tip holding all of them."""
    job = Path(__file__).resolve().parent.parent / "resources" / "jobs" / "dome-laminate.toml"
    solved, _ = solve_pieces(open_path(job).project, [f"P{k:02d}" for k in range(1, 9)], workers=1)
    warnings = project_checks(solved)
    assert len(warnings) == 8
    win = make_window(project=solved)
    lines = win.pieces_panel.checks.text().splitlines()
    assert lines[:3] == warnings[:3] and lines[3] == "... and 5 more (the tip lists them all)"
    assert win.pieces_panel.checks.toolTip().splitlines() == warnings
