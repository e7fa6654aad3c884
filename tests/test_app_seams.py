"""GUI tests of seams (issue 42, the window's part): the Seam tool draws a seam by
clicks on the 3D view, which splits the piece into panels (one undoable edit); the
seams are drawn on the surface; Solve all solves the panels, and the Pieces tab's
Seams list reads each sew line's two sides off their flat patterns; Delete there
joins the panels again; a seam the split refuses is said in one line and changes
nothing.

Every click is a real mouse event (tests.test_app_tools' helpers). The half
cylinder (radius 0.5, length 1.5) develops exactly, so a generator's two sides
come out of their panels equal in length, and as long as it is on the surface:
1.5."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor

from flatweave.app import seampanel
from flatweave.app.tools import SeamTool
from flatweave.document.sewing import SeamRow
from flatweave.document.project import new_project
from flatweave.reading.examples import example_path, load_example

from tests.test_app_run import RUN_TIMEOUT_MS
from tests.test_app_tools import click, pixel, ready

pytestmark = pytest.mark.slow

L = 1.5  # the half cylinder's length (v from 0 to 1)
SPACING = 0.1
CAMERA = ((0.9, -1.3, 2.2), (0.0, 0.75, 0.2), (0.0, 0.0, 1.0))  # above it, from its front corner


def half_cylinder(spacing: float = SPACING):
    surface = load_example("half_cylinder")
    return new_project(surface, "half_cylinder", str(example_path("half_cylinder")), spacing)


@pytest.fixture
def window(make_window, qtbot):
    """A window on the half cylinder (spacing 0.1, unsolved) seen from CAMERA, the Seam tool on."""
    win = make_window(half_cylinder())
    win.view.look(*CAMERA)
    ready(qtbot, win)
    win.actions["tool_seam"].trigger()
    assert isinstance(win.tool, SeamTool)
    return win


def draw(qtbot, win, uv_points) -> np.ndarray:
    """Click the surface at each (u, v) (at the nearest pixel), then Enter; the (u, v) the clicks placed."""
    for k, uv in enumerate(uv_points):
        click(qtbot, win.view, *pixel(win.view, win.surface.points(np.array([uv], float))[0]))
        assert len(win.tool.handles) == k + 1, win.last_hint
    placed = np.array(win.tool.handles)
    qtbot.keyClick(win.view.widget, Qt.Key.Key_Return)
    return placed


def distance_to(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(n,) each point's distance to the polyline ``line``."""
    a, ab = line[:-1], np.diff(line, axis=0)
    t = np.clip(np.einsum("nkc,kc->nk", points[:, None, :] - a, ab) / np.einsum("kc,kc->k", ab, ab), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - points[:, None, :], axis=2).min(axis=1)


def generator(u: float) -> list:
    """Three clicks along the generator at ``u``, from just inside one edge to just inside the other."""
    return [(u, 0.003), (u, 0.5), (u, 0.997)]


def test_two_seams_split_the_half_cylinder_into_three_panels_that_sew_back(window, qtbot):
    win = window
    doc, view, panel = win.document, win.view, win.pieces_panel
    seams = panel.seams
    before = win.project
    assert not seams.isVisibleTo(panel) and len(view.layer_lines("seams")) == 0

    placed = draw(qtbot, win, generator(1 / 3))
    p = win.project
    assert [x.name for x in p.pieces] == ["panel 1", "panel 2"] and len(p.sewings) == 1
    assert doc.undo_label == "Add seam 1" and "2 panels" in win.last_hint
    seam = p.sewings[0].seams[0]
    assert seam.name == "seam 1"
    assert distance_to(placed, seam.uv).max() < 1e-3  # through the clicked points
    np.testing.assert_allclose(placed[:, 0], 1 / 3, atol=5e-3)  # each within a pixel of its target
    assert sorted(seam.uv[[0, -1], 1]) == [0.0, 1.0]  # from edge to edge
    drawn = view.layer_lines("seams")  # along the surface (x^2 + z^2 = 0.25), over its whole length
    assert len(drawn) > 100
    np.testing.assert_allclose(np.hypot(drawn[:, 0], drawn[:, 2]), 0.5, atol=1e-9)
    np.testing.assert_allclose([drawn[:, 1].min(), drawn[:, 1].max()], [0.0, L], atol=1e-9)
    np.testing.assert_allclose(drawn[:, 0], win.surface.points(np.array([[1 / 3, 0.5]]))[0, 0], atol=5e-3)
    assert seams.isVisibleTo(panel) and seams.rows() == [("seam 1", "panel 1 / panel 2", "- / -", "-")]

    doc.undo()  # the piece comes back whole
    q = win.project
    assert [x.name for x in q.pieces] == ["half_cylinder"] and q.sewings == () and q.settings.region is None
    assert q is before
    assert len(view.layer_lines("seams")) == 0 and not seams.isVisibleTo(panel)
    doc.redo()
    assert win.project is p and len(view.layer_lines("seams")) == len(drawn)

    win.actions["tool_seam"].trigger()  # the undo ended the tool
    assert isinstance(win.tool, SeamTool)
    draw(qtbot, win, generator(2 / 3))
    p = win.project
    assert sorted(x.name for x in p.pieces) == ["panel 1", "panel 2", "panel 3"]
    assert len(p.sewings) == 1 and [s.name for s in p.sewings[0].seams] == ["seam 1", "seam 2"]
    assert sorted(p.sewings[0].panels) == ["panel 1", "panel 2", "panel 3"]
    assert len(view.layer_lines("seams")) == 2 * len(drawn)
    assert [r[0] for r in seams.rows()] == ["seam 1", "seam 2"]

    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        panel.solve_button.click()
    assert win.last_solve_all == "Solve all: 3 of 3 pieces solved"
    rows = seams.seam_rows()
    cells = seams.rows()
    assert len(rows) == 2 and len(cells) == 2
    mm = 1000.0 * win.project.metres_per_unit
    for row, cell in zip(rows, cells):
        assert len(row.panels) == 2 and row.panels[0] != row.panels[1] and row.solved
        assert all(np.isfinite(x) for x in row.lengths)
        assert row.difference_pct < 0.01 and not row.over(mm)  # developable: the sides agree
        np.testing.assert_allclose(row.lengths, L, rtol=1e-3)  # as long as on the surface
        assert cell[1] == " / ".join(row.panels)
        assert cell[2] == " / ".join(f"{x:#.4g}" for x in row.lengths) and "-" not in cell[2]
        assert cell[3] == f"{row.difference_pct:.3f} %"

    # Delete on the second sew line: its seam goes, the panels either side join
    seams.table.selectRow(1)
    assert seams.delete.isEnabled()
    seams.delete.click()
    p = win.project
    assert len(p.pieces) == 2 and [s.name for s in p.sewings[0].seams] == ["seam 1"]
    assert doc.undo_label == "Delete seam 2"
    assert [r[0] for r in seams.rows()] == ["seam 1"]
    assert len(view.layer_lines("seams")) == len(drawn)
    if win.runner.busy:  # a panel whose region changed re-solves when it was the active one
        qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS).wait()
    doc.undo()
    assert len(win.project.pieces) == 3 and len(seams.rows()) == 2


def test_a_seam_the_split_refuses_is_one_line_and_changes_nothing(window, qtbot):
    win = window
    doc = win.document
    revision, before = doc.revision, win.project

    draw(qtbot, win, [(0.3, 0.4), (0.55, 0.6)])  # both ends inside the piece: it splits nothing
    assert "does not reach an edge" in win.last_hint and win.last_hint.startswith("Cannot make the seam: ")
    assert "\n" not in win.last_hint
    assert doc.revision == revision and win.project is before and win.project.sewings == ()
    assert len(win.tool.handles) == 2  # kept, to carry on or take back
    qtbot.keyClick(win.view.widget, Qt.Key.Key_Escape)
    assert win.tool.handles == []

    draw(qtbot, win, [(0.45, 0.005), (0.85, 0.8), (0.85, 0.2), (0.45, 0.995)])  # edge to edge, across itself
    assert "crosses itself" in win.last_hint and "\n" not in win.last_hint
    assert doc.revision == revision and win.project is before
    assert len(win.view.layer_lines("seams")) == 0


def test_a_sew_line_over_the_tolerance_is_marked_and_red(qtbot, monkeypatch):
    """Sides 1 and 1.01 m long (1 % and 10 mm apart: over 0.5 % and 2 mm) are marked; 1 and 1.001 m (0.1 %)
    are not; a side not solved shows "-"."""
    rows = [SeamRow("front", "front", "shirt", ("panel 1", "panel 2"), (1.0, 1.01)),
            SeamRow("back", "back", "shirt", ("panel 2", "panel 3"), (1.0, 1.001)),
            SeamRow("side", "side", "shirt", ("panel 3", "panel 1"), (1.0, None))]
    monkeypatch.setattr(seampanel, "seam_rows", lambda project: rows)
    seams = seampanel.SeamList()
    qtbot.addWidget(seams)
    seams.set_project(SimpleNamespace(sewings=("shirt",), metres_per_unit=1.0, units="m"))
    assert seams.rows() == [("front", "panel 1 / panel 2", "1.000 / 1.010", "0.995 %  !"),
                            ("back", "panel 2 / panel 3", "1.000 / 1.001", "0.100 %"),
                            ("side", "panel 3 / panel 1", "1.000 / -", "-")]
    red = QColor(seampanel.OVER_COLOUR)
    assert seams.table.item(0, 3).foreground().color() == red and seams.table.item(1, 3).foreground().color() != red
    assert "over the tolerance" in seams.table.item(0, 0).toolTip()
    reported = []
    seams.seam_delete.connect(lambda sewing, seam: reported.append((sewing, seam)))
    assert not seams.delete.isEnabled()
    seams.table.selectRow(1)
    seams.delete.click()
    assert reported == [("shirt", "back")]
