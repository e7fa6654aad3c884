"""GUI tests of seams (issue 42, the window's part): the Seam tool draws a seam by
clicks on the 3D view, which splits the piece into panels (one undoable edit); the
seams are drawn on the surface; Solve all solves the panels, and the Pieces tab's
Seams list reads each sew line's two sides off their flat patterns; Delete there
joins the panels again; a seam the split refuses is said in one line and changes
nothing. The list's options: a seam's Matched checkbox (clicked) makes Solve all
solve its panels to equal sides, and its Cost column says what that cost; its
Allowance (double-clicked and typed) sets the seam's allowance, a bad one refused
in one line. The Notch tool: a click on a seam notches it there, a click on the
notch removes it, a click away from the seams changes nothing.

Every click is a real mouse event (tests.test_app_tools' helpers). The half
cylinder (radius 0.5, length 1.5) develops exactly, so a generator's two sides
come out of their panels equal in length, and as long as it is on the surface:
1.5."""

from __future__ import annotations

from types import SimpleNamespace

import ezdxf
import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QAbstractItemView, QApplication, QLineEdit, QStyle, QStyleOptionViewItem

from flatweave.app import seampanel
from flatweave.app.tools import NOTCH_PIXELS, NotchTool, SeamTool
from flatweave.document.sewing import SeamLine, SeamRow, piece_sheet
from flatweave.document.project import new_project, settings_equal
from flatweave.export.registry import ExportOptions
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
    # the tests here solve with Solve all when they mean to; the panels a seam edit changes re-solve on their
    # own in test_a_seam_edit_re_solves_the_other_panels_it_changed
    win.solve_panels = False
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


def seam_sheet(project):
    """The active panel's sheet as its cut files draw it (allowance 10 mm but its seams' own)."""
    return piece_sheet(project, project.piece_name, 10.0)


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
    assert seams.isVisibleTo(panel)
    assert seams.rows() == [("seam 1", "", "-", "-", "default", "panel 1 / panel 2", "- / -")]
    assert seams.matched() == [False]

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
        assert cell[seampanel.PANELS] == " / ".join(row.panels)
        lengths = cell[seampanel.LENGTHS]
        assert lengths == " / ".join(f"{x:#.4g}" for x in row.lengths) and "-" not in lengths
        assert cell[seampanel.DIFFERENCE] == f"{row.difference_pct:.3f} %"
        assert cell[1] == "" and cell[3:5] == ("-", "default") and not row.matched  # not matched: no cost to say

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


def test_a_seam_edit_re_solves_the_other_panels_it_changed(window, qtbot):
    """Issue 42: editing a seam re-splits and re-solves the panels it touches, in Solve all's pool at once
    (the active panel by the window's own run when the edit started one: here the piece was never solved)."""
    win = window
    win.solve_panels = True
    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        draw(qtbot, win, generator(1 / 3))
    assert win.last_solve_all == "Panels the seam edit changed: 2 of 2 solved"
    p = win.project
    assert len(p.pieces) == 2 and all(settings_equal(x.result.settings, x.settings) for x in p.pieces)
    if win.runner.busy:
        qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS).wait()
    kept = {x.name: x.result for x in win.project.pieces}
    # a second seam splits one panel: the new panel is solved, a panel it did not touch keeps its result
    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        draw(qtbot, win, generator(2 / 3))
    if win.runner.busy:
        qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS).wait()
    p = win.project
    assert len(p.pieces) == 3
    untouched = [x for x in p.pieces if x.name in kept and x.result is kept[x.name]]
    assert len(untouched) == 1  # the panel left of seam 1, as it was
    assert all(r.solved and r.difference_pct < 0.01 for r in win.pieces_panel.seams.seam_rows())


def test_a_panel_exported_alone_carries_its_seams_notches(window, qtbot, tmp_path):
    """File > Export of the active panel draws what its cut files do: a notch at each end of its sew line
    (ASTM layer 4), cut from the seam's own allowance."""
    win = window
    draw(qtbot, win, generator(0.5))
    doc = win.document
    shape = win.project.sewings[0]
    doc.edit_seam(shape.name, "seam 1", label="Seam allowance of seam 1", allowance_mm=20.0)
    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        win.pieces_panel.solve_button.click()
    assert win.project.result_is_current
    dxf = tmp_path / "panel.dxf"
    with qtbot.waitSignal(win.export_finished, timeout=60000):
        assert win.export_to([dxf], ExportOptions(seam_allowance_mm=10.0))
    slits = [e for e in ezdxf.readfile(dxf).blocks if any(x.dxf.layer == "4" for x in e)]
    (block,) = slits
    notches = [x for x in block if x.dxftype() == "LINE" and x.dxf.layer == "4"]
    assert len(notches) == 2  # the sew line's two ends
    # each slit starts on the cut line 20 mm off the sew line (the seam's allowance, not the export's 10)
    sheet = seam_sheet(win.project)
    (piece,) = sheet.pieces
    starts = np.array([[n.dxf.start.x, n.dxf.start.y] for n in notches]) + piece.offset  # block to sheet
    np.testing.assert_allclose(distance_to(starts, np.vstack([piece.sew, piece.sew[:1]])), 20.0, atol=0.05)


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
            SeamRow("back", "back", "shirt", ("panel 2", "panel 3"), (1.0, 1.001), True, 12.34, 2.5e-6),
            SeamRow("side", "side", "shirt", ("panel 3", "panel 1"), (1.0, None))]
    monkeypatch.setattr(seampanel, "seam_rows", lambda project: rows)
    seams = seampanel.SeamList()
    qtbot.addWidget(seams)
    line = np.array([[0.0, 0.0], [1.0, 1.0]])
    shirt = SimpleNamespace(name="shirt", seams=(SeamLine("front", line), SeamLine("back", line, matched=True),
                                                 SeamLine("side", line, allowance_mm=15.0)))
    seams.set_project(SimpleNamespace(sewings=(shirt,), metres_per_unit=1.0, units="m"))
    assert seams.rows() == [("front", "", "0.995 %  !", "-", "default", "panel 1 / panel 2", "1.000 / 1.010"),
                            ("back", "", "0.100 %", "+2.5e-06", "default", "panel 2 / panel 3", "1.000 / 1.001"),
                            ("side", "", "-", "-", "15 mm", "panel 3 / panel 1", "1.000 / -")]
    assert seams.matched() == [False, True, False]
    assert "energy solved alone" in seams.table.item(1, seampanel.COST).toolTip()
    red = QColor(seampanel.OVER_COLOUR)
    column = seampanel.DIFFERENCE
    assert seams.table.item(0, column).foreground().color() == red
    assert seams.table.item(1, column).foreground().color() != red
    assert "over the tolerance" in seams.table.item(0, 0).toolTip()
    reported = []
    seams.seam_delete.connect(lambda sewing, seam: reported.append((sewing, seam)))
    assert not seams.delete.isEnabled()
    seams.table.selectRow(1)
    seams.delete.click()
    assert reported == [("shirt", "back")]


# ---------------------------------------------------------------------- the list's options, the Notch tool
GARMENT_SPACING = 0.03
GARMENT_CAMERA = ((0.0, 0.3, 1.4), (0.0, 0.3, 0.0), (0.0, 1.0, 0.0))  # in front of it


@pytest.fixture
def garment(make_window, qtbot):
    """A window on the bundled garment front (doubly curved, spacing 0.03, unsolved) seen from the front, split
    into four panels by two seams clicked across it: "seam 1" down its middle, "seam 2" across its waist (which
    cut each other: four sew lines); the Pieces tab shown."""
    surface = load_example("garment")
    win = make_window(new_project(surface, "garment", str(example_path("garment")), GARMENT_SPACING))
    win.solve_panels = False  # Solve all, clicked, solves them (as in the window fixture)
    win.view.look(*GARMENT_CAMERA)
    ready(qtbot, win)
    win.actions["tool_seam"].trigger()
    draw(qtbot, win, [(0.5, 0.003), (0.5, 0.5), (0.5, 0.997)])
    draw(qtbot, win, [(0.003, 0.45), (0.3, 0.48), (0.7, 0.52), (0.997, 0.55)])
    p = win.project
    assert len(p.pieces) == 4 and [s.name for s in p.sewings[0].seams] == ["seam 1", "seam 2"], win.last_hint
    win.actions["tool_seam"].trigger()  # the tool off
    win.side_tabs.setCurrentWidget(win.pieces_panel)
    return win


def cell_point(table, r: int, c: int, check: bool = False) -> QPoint:
    """The middle of cell (r, c) of ``table``'s viewport (scrolled into sight), or of its checkbox."""
    item = table.item(r, c)
    table.scrollToItem(item)
    rect = table.visualItemRect(item)
    if check:  # where the item delegate draws the checkbox, as the style places it
        opt = QStyleOptionViewItem()
        opt.initFrom(table.viewport())
        opt.rect = rect
        opt.features |= QStyleOptionViewItem.ViewItemFeature.HasCheckIndicator
        rect = table.style().subElementRect(QStyle.SubElement.SE_ItemViewItemCheckIndicator, opt, table)
    return rect.center()


def click_matched(qtbot, seams, r: int) -> None:
    """A real click on row ``r``'s Matched checkbox."""
    qtbot.mouseClick(seams.table.viewport(), Qt.MouseButton.LeftButton,
                     pos=cell_point(seams.table, r, seampanel.MATCHED, check=True))


def type_allowance(qtbot, seams, r: int, text: str) -> None:
    """Double-click row ``r``'s Allowance, type ``text`` over what it shows, Enter."""
    at = cell_point(seams.table, r, seampanel.ALLOWANCE)
    qtbot.mouseClick(seams.table.viewport(), Qt.MouseButton.LeftButton, pos=at)  # QTest's double click is
    qtbot.mouseDClick(seams.table.viewport(), Qt.MouseButton.LeftButton, pos=at)  # the second click alone
    editor = QApplication.focusWidget()
    assert isinstance(editor, QLineEdit) and seams.table.isAncestorOf(editor)
    editor.selectAll()
    qtbot.keyClick(editor, Qt.Key.Key_Delete)
    qtbot.keyClicks(editor, text)
    qtbot.keyClick(editor, Qt.Key.Key_Return)
    # the item delegate commits what was typed from the event loop
    qtbot.waitUntil(lambda: seams.table.state() != QAbstractItemView.State.EditingState, timeout=5000)


def test_matched_seams_solve_to_equal_sides_and_say_their_cost(garment, qtbot):
    win = garment
    doc, seams = win.document, win.pieces_panel.seams
    rows = seams.seam_rows()
    assert sorted({r.seam for r in rows}) == ["seam 1", "seam 2"] and len(rows) == 4  # each cut by the other
    assert seams.isVisible() and seams.matched() == [False] * 4

    first = next(k for k, r in enumerate(rows) if r.seam == "seam 1")
    revision = doc.revision
    click_matched(qtbot, seams, first)
    p = win.project
    assert [s.matched for s in p.sewings[0].seams] == [True, False]
    assert doc.undo_label == "Match seam 1" and doc.revision == revision + 1  # one undoable edit
    assert seams.matched() == [r.seam == "seam 1" for r in seams.seam_rows()]  # every sew line of the seam
    doc.undo()
    assert not win.project.sewings[0].seams[0].matched and seams.matched() == [False] * 4
    doc.redo()
    assert win.project is p and seams.matched() == [r.seam == "seam 1" for r in seams.seam_rows()]
    click_matched(qtbot, seams, next(k for k, r in enumerate(seams.seam_rows()) if r.seam == "seam 2"))
    assert [s.matched for s in win.project.sewings[0].seams] == [True, True] and doc.undo_label == "Match seam 2"
    assert seams.matched() == [True] * 4 and seams.rows()[0][seampanel.COST] == "-"  # not solved yet

    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        win.pieces_panel.solve_button.click()
    report = win.solve_all.report
    assert report is not None and report.reached and win.last_solve_all.endswith(report.message)
    assert win.last_solve_all.startswith("Solve all: 4 of 4 pieces solved")
    rows, cells = seams.seam_rows(), seams.rows()
    assert len(rows) == 4
    for row, cell in zip(rows, cells):
        assert row.matched and row.solved and row.difference_pct < 0.1, (row.name, row.difference_pct)
        assert cell[seampanel.DIFFERENCE] == f"{row.difference_pct:.3f} %"
        assert row.energy_cost is not None and cell[seampanel.COST] == f"{row.energy_cost:+.2g}"
        assert "energy solved alone" in seams.table.item(rows.index(row), seampanel.COST).toolTip()


def test_the_allowance_is_typed_in_the_list_and_a_bad_one_refused(garment, qtbot):
    win = garment
    doc, seams = win.document, win.pieces_panel.seams
    rows = seams.seam_rows()
    k = next(k for k, r in enumerate(rows) if r.seam == "seam 2")
    type_allowance(qtbot, seams, k, "12.5")
    seam = win.project.sewings[0].seams[1]
    assert seam.allowance_mm == 12.5 and doc.undo_label == "Seam allowance of seam 2"
    assert win.project.sewings[0].seams[0].allowance_mm is None
    assert [c[seampanel.ALLOWANCE] for c in seams.rows()] == ["12.5 mm" if r.seam == "seam 2" else "default"
                                                              for r in seams.seam_rows()]

    revision, before = doc.revision, win.project
    for bad in ("wide", "150", "-1"):
        type_allowance(qtbot, seams, k, bad)
        assert doc.revision == revision and win.project is before, bad
        assert "\n" not in win.last_error and win.last_error.startswith("Seam allowance of seam 2: "), bad
        assert win.statusBar().currentMessage() == win.last_error
        assert seams.rows()[k][seampanel.ALLOWANCE] == "12.5 mm"  # shown as it is
    type_allowance(qtbot, seams, k, "12.5 mm")  # the same: no edit
    assert doc.revision == revision

    type_allowance(qtbot, seams, k, "")  # empty: the export's again
    assert win.project.sewings[0].seams[1].allowance_mm is None and seams.rows()[k][seampanel.ALLOWANCE] == "default"
    doc.undo()
    assert win.project is before and seams.rows()[k][seampanel.ALLOWANCE] == "12.5 mm"


def test_the_notch_tool_adds_a_notch_on_a_seam_and_removes_it(window, qtbot):
    win = window
    doc, view = win.document, win.view
    draw(qtbot, win, generator(1 / 3))
    win.actions["tool_notch"].trigger()
    assert isinstance(win.tool, NotchTool)
    seam = win.project.sewings[0].seams[0]
    assert seam.notches == () and len(view.layer_points("notches")) == 0

    # a click a few pixels beside the seam puts a notch on it, at its point nearest the click on screen
    a, b = view.display_points(win.surface.points(np.array([[1 / 3, 0.45], [1 / 3, 0.55]])))
    across = np.array([a[1] - b[1], b[0] - a[0]]) / np.hypot(*(b - a))  # across the seam on screen
    x, y = pixel(view, win.surface.points(np.array([[1 / 3, 0.5]]))[0])
    click(qtbot, view, *np.round((x, y) + 4 * across))
    seam = win.project.sewings[0].seams[0]
    assert len(seam.notches) == 1 and doc.undo_label == "Add notch", win.last_hint
    notch = np.array(seam.notches)
    assert distance_to(notch, np.asarray(seam.uv))[0] < 1e-9  # on the seam
    assert abs(notch[0, 1] - 0.5) < 0.02  # beside the click
    np.testing.assert_allclose(view.layer_points("notches"), win.surface.points(notch))  # drawn
    at = view.display_points(win.surface.points(notch))[0]
    assert np.hypot(at[0] - x, at[1] - y) <= 4.5
    assert win.project.result_is_current == (win.project.result is not None)  # a label: no solve

    # a click on the notch removes it
    revision = doc.revision
    click(qtbot, view, int(round(at[0])) + 2, int(round(at[1])))
    assert win.project.sewings[0].seams[0].notches == () and doc.undo_label == "Remove notch"
    assert doc.revision == revision + 1 and len(view.layer_points("notches")) == 0
    doc.undo()
    assert win.project.sewings[0].seams[0].notches == seam.notches and len(view.layer_points("notches")) == 1
    doc.redo()

    # a double click on the seam is one notch (its second press would take it back)
    revision = doc.revision
    click(qtbot, view, x, y)
    click(qtbot, view, x, y, double=True)
    assert len(win.project.sewings[0].seams[0].notches) == 1 and doc.revision == revision + 1
    doc.undo()

    # a click away from the seam changes nothing, and says so
    revision, before = doc.revision, win.project
    far = pixel(view, win.surface.points(np.array([[0.8, 0.5]]))[0])
    click(qtbot, view, *far)
    assert doc.revision == revision and win.project is before
    assert win.last_hint.startswith("No seam there") and "\n" not in win.last_hint
    click(qtbot, view, *np.round((x, y) + (NOTCH_PIXELS + 3) * across))  # just beyond the tolerance
    assert doc.revision == revision and win.last_hint.startswith("No seam there")
