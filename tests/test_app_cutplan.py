"""The window's Cut plan (issue 43, item 5; flatweave.app.cutplanview): Solve > Nest pieces on the roll
shows the panel and nests the document's solved pieces in a thread, a marker per material, drawn as it
improves; every copy is placed, the numbers shown are the marker's and the outlines painted lie on the
roll; Stop keeps the best marker so far; a roll narrower than a piece, or no piece solved, is one line and
no marker; the marker goes stale when the pieces change, and never edits the document; closing the window
while nesting stops it. A piece wider than the roll is spliced: the active piece's splices are drawn on its
surface, and the table's positions typed by hand (or splice lines dragged in the splice view) re-nest with the
parts they imply. The dock's settings, the splices placed by hand and the mirror pairs are the project's cut
plan: undoable edits, saved with it."""

from __future__ import annotations

import multiprocessing
import os
from dataclasses import replace

import numpy as np
import pytest
from flatweave.app.cutplanview import MIRROR_TIP, STALE, STOPPED
from flatweave.document import pieces as P
from flatweave.document.cutplan import splice_curves
from flatweave.document.cutsettings import CutPlanSettings
from flatweave.document.project import load_project, save_project
from flatweave.studies.nesting import marker_problems
from PySide6.QtCore import QPoint, Qt

from tests.helpers import solved_kit

pytestmark = pytest.mark.slow

NEST_TIMEOUT_MS = 180000  # a shared, slow machine: the engine's child process starts in seconds at worst
ROLL_MM = 2500.0


@pytest.fixture(scope="module")
def kit():
    """Three solved pieces (tests.helpers.solved_kit): two woven octant plies of 2 copies each, an
    isotropic half-cylinder panel; units m, so each piece is about 1.6 m across."""
    return solved_kit()


def copies_by_material(project) -> dict[str, int]:
    out: dict[str, int] = {}
    for piece in project.pieces:
        out[piece.settings.material.name] = out.get(piece.settings.material.name, 0) + piece.quantity
    return out


def cut_plan(make_window, project, seconds: int = 1):
    """A window on ``project``, its Cut plan set to the 2500 mm roll, ``seconds`` per material, one engine thread."""
    win = make_window(project)
    panel = win.cut_plan
    panel.workers = 1  # a shared machine: one engine thread
    panel.set_roll_width(ROLL_MM)
    panel.time_limit.setValue(seconds)
    return win, panel


def test_nest_places_every_copy_on_the_roll_and_shows_the_markers_numbers(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, kit)
    assert not win.cut_plan_dock.isVisible()
    assert win.actions["nest"].isEnabled()  # pieces are solved
    revision, history = win.document.revision, win.document.history
    progress, failed = [], []
    panel.progress.connect(lambda material, marker: progress.append((material, marker)))
    panel.failed.connect(failed.append)
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS) as ended:
        win.actions["nest"].trigger()  # Solve > Nest pieces on the roll
        assert win.cut_plan_dock.isVisible() and panel.busy
        assert not panel.nest_button.isEnabled() and panel.stop_button.isEnabled()
        assert not win.nest_pieces()  # one Nest at a time
    assert not failed and not panel.busy and panel.nest_button.isEnabled() and not panel.stop_button.isEnabled()
    assert progress, "no marker was drawn while the engine ran"  # live: each better marker was handed over
    assert win.document.revision == revision and win.document.history == history  # a view: the document untouched

    want = copies_by_material(kit)
    assert sorted(panel.markers) == sorted(want) == ["isotropic", "woven"]
    assert ended.args[0] == panel.last_summary and ended.args[0].startswith("Cut plan: ")
    assert win.statusBar().currentMessage() == panel.last_summary
    for material, marker in panel.markers.items():
        panel.choose_material(material)
        assert panel.view.marker is marker and panel.roll_width.value() == ROLL_MM
        assert marker_problems(marker) == [] and not marker.stopped
        assert len(marker.placements) == want[material] == sum(it.quantity for it in marker.items)
        assert marker.roll_width == ROLL_MM
        assert panel.number("length").startswith(f"{marker.length / 1000:.3f} m")
        assert panel.number("utilisation") == f"{100 * marker.utilisation:.2f} %"
        assert panel.number("waste") == f"{marker.waste / 1e6:.3f} m\u00b2"
        assert panel.number("placed").startswith(f"{want[material]} of {want[material]} copies")
        assert panel.number("time").startswith(f"{marker.seconds:.1f} s")
        assert f"{marker.length / 1000:.3f} m" in panel.last_summary
        # what the widget paints: every copy, inside the roll's rectangle, the marker's outlines scaled
        painted = panel.view.painted()
        assert [name for name, _ in painted] == [marker.items[p.item].name for p in marker.placements]
        roll = panel.view.roll_rect()
        assert roll is not None and roll.width() > 50 and roll.height() > 50
        assert roll.width() / roll.height() == pytest.approx(marker.length / marker.roll_width, rel=1e-9)
        scale = roll.height() / marker.roll_width
        for (_, pixels), outline in zip(painted, marker.outlines()):
            assert pixels[:, 0].min() >= roll.left() - 0.5 and pixels[:, 0].max() <= roll.right() + 0.5
            assert pixels[:, 1].min() >= roll.top() - 0.5 and pixels[:, 1].max() <= roll.bottom() + 0.5
            # the roll's y runs up the screen: a piece is drawn face up, as the marker's files have it
            np.testing.assert_allclose(pixels[:, 0], roll.left() + outline[:, 0] * scale, atol=1e-9)
            np.testing.assert_allclose(pixels[:, 1], roll.bottom() - outline[:, 1] * scale, atol=1e-9)
    assert panel.left_out == [] and not panel.left_label.isVisible()
    assert panel.state.text() == "Nested 2 materials" and not panel.stale

    # the pieces change: the marker stays, said stale; an undo brings the same pieces back
    win.pieces_panel.rename(0, "lid")
    assert panel.stale and panel.state.text().startswith(STALE[0].upper() + STALE[1:])
    assert panel.view.stale and panel.view.marker is not None
    win.undo()
    assert not panel.stale and panel.state.text() == "Nested 2 materials"
    win.pieces_panel.list.setCurrentRow(2)  # another piece active: the same pieces
    assert not panel.stale
    # the cut plan's settings change (a gap typed): the marker was nested without it, so stale too
    win.document.set_cut_plan(replace(win.document.project.cut_plan, gap_mm=7.0), "Gap")
    assert panel.stale and panel.view.stale
    win.undo()
    assert not panel.stale
    win.set_project(kit)  # another document: nothing of the last one's shown
    assert panel.markers == {} and panel.view.marker is None and panel.number("length") == "-"


def test_stop_keeps_the_best_marker_so_far(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, kit, seconds=60)
    ended = []
    panel.failed.connect(ended.append)
    with qtbot.waitSignal(panel.progress, timeout=NEST_TIMEOUT_MS) as first:
        panel.nest_button.click()
    material = first.args[0]
    assert material == "woven"  # the first in laying order; the one shown, live
    assert panel.shown_material() == "woven" and panel.view.marker is not None
    with qtbot.waitSignal(panel.finished, timeout=30000) as done:  # at once, not the minute asked
        panel.stop_button.click()
        assert not panel.stop_button.isEnabled()
    assert not ended and STOPPED in done.args[0]
    marker = panel.markers["woven"]
    assert marker.stopped and marker_problems(marker) == []
    assert len(marker.placements) == copies_by_material(kit)["woven"]
    assert panel.view.marker is marker
    assert STOPPED in panel.state.text().casefold() and STOPPED in panel.number("time")
    assert "isotropic" not in panel.markers  # not reached: not nested
    panel.choose_material("isotropic")
    assert panel.view.marker is None and panel.view.message == "isotropic: not nested (stopped)"
    assert panel.number("length") == "-"


def test_a_piece_wider_than_the_roll_is_spliced_and_a_roll_narrower_than_a_splice_refused(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, P.add(kit, "extra"))  # an unsolved piece too: left out
    panel.set_roll_width(1000.0)  # the octant's plies are about 1.5 m across: two parts each
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS) as done:
        panel.nest_button.click()
    assert "spliced (wider than the roll)" in done.args[0]
    marker = panel.markers["woven"]
    assert marker_problems(marker) == [] and marker.roll_width == 1000.0
    assert all(" part " in it.name for it in marker.items)
    assert [len(r.parts) for r in panel.spliced["woven"]] == [2, 2]
    assert "Spliced, wider than the roll" in panel.left_label.text() and "extra" in panel.left_label.text()

    panel.set_roll_width(20.0)  # not wider than the 25 mm overlap: no part would fit
    with qtbot.waitSignal(panel.failed, timeout=NEST_TIMEOUT_MS) as failed:
        panel.nest_button.click()
    message = failed.args[0]
    assert "not wider than the splice overlap" in message and "\n" not in message
    assert panel.markers == {} and panel.view.marker is None and panel.view.painted() == []
    assert all(panel.number(key) == "-" for key in panel.numbers)
    assert panel.state.text() == message and "splice overlap" in panel.view.message
    assert panel.left_out == ["extra"] and "extra" in panel.left_label.text()
    assert "splice overlap" in win.statusBar().currentMessage()

    bare = make_window(example="octant")  # nothing solved: the menu's Nest is off, the panel's says why
    assert not bare.actions["nest"].isEnabled()
    with qtbot.waitSignal(bare.cut_plan.failed, timeout=NEST_TIMEOUT_MS) as failed:
        assert bare.cut_plan.nest()
    assert failed.args[0].startswith("no piece is solved") and bare.cut_plan.left_out == ["octant"]


def test_closing_the_window_while_nesting_stops_it(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, kit, seconds=60)
    with qtbot.waitSignal(panel.progress, timeout=NEST_TIMEOUT_MS):
        assert win.nest_pieces()
    thread = panel.thread
    assert thread is not None and thread.is_alive()
    win.close()  # stops the Nest and waits for it
    assert not panel.busy and not thread.is_alive()
    assert not [p for p in multiprocessing.active_children() if p.name == "flatweave-nest"]


def across(outline: np.ndarray, frame_deg: float) -> np.ndarray:
    """The outline's y in the frame turned by -frame_deg (across the roll, as tests.test_splices has it)."""
    a = np.radians(-frame_deg)
    return np.sin(a) * outline[:, 0] + np.cos(a) * outline[:, 1]


def drawn_splices(win, report) -> np.ndarray:
    """What the "splices" layer should hold for ``report`` of the window's active piece."""
    project = win.project
    return np.vstack(splice_curves(project.result, report, 1000.0 * project.metres_per_unit))


def test_splices_are_drawn_on_the_active_piece_and_placed_by_hand_in_the_table(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, kit)
    panel.set_roll_width(1000.0)  # the octant's plies (about 1.57 m across) in two parts each; the side too
    assert win.select_piece("cap")
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        panel.nest_button.click()
    view = win.view
    reports = {r.name: r for r in panel.spliced["woven"]}
    assert sorted(reports) == ["cap", "cap +45"] and not any(r.asked for r in reports.values())
    assert panel.piece_splices() == [reports["cap"]]
    # on the surface: the octant is a sphere's, radius 1 m, and the layer is the splice's curve through the result
    drawn = view.layer_lines("splices")
    assert len(drawn) > 50
    np.testing.assert_allclose(np.linalg.norm(drawn, axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(drawn, drawn_splices(win, reports["cap"]), atol=1e-12)
    assert len(view.layer_lines("seams")) == 0  # a layer of its own

    assert win.select_piece("cap +45")  # another piece active: its splices
    np.testing.assert_allclose(view.layer_lines("splices"), drawn_splices(win, reports["cap +45"]), atol=1e-12)
    assert win.select_piece("side")
    (side,) = panel.spliced["isotropic"]
    np.testing.assert_allclose(view.layer_lines("splices"), drawn_splices(win, side), atol=1e-12)
    assert win.select_piece("cap")

    # the table: the shown material's spliced pieces, their widths and splices from the edge, chosen
    panel.choose_material("woven")
    rows = panel.splice_rows()
    assert [row[0] for row in rows] == ["cap", "cap +45"] and all(row[3] == "chosen" for row in rows)
    for row in rows:
        r = reports[row[0]]
        assert row[1] == f"{round(r.width, 1):g} mm"
        assert [float(x) for x in row[2].split(",")] == pytest.approx([y - r.start for y in r.positions], abs=0.05)
    assert panel.splices.isVisibleTo(panel) and not panel.reset_splices_button.isEnabled()

    # a position typed: nested again with the parts it implies, drawn where it now is
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        panel.splices.item(0, 2).setText("700")
    assert win.project.cut_plan.splice_map() == {"cap": [700.0]} and win.document.undo_label == "Splices"
    report = next(r for r in panel.spliced["woven"] if r.name == "cap")
    assert report.asked and [y - report.start for y in report.positions] == pytest.approx([700.0])
    marker = panel.markers["woven"]
    assert marker_problems(marker) == []
    widths = {it.name: float(np.ptp(across(it.outline, report.frame_deg))) for it in marker.items
              if it.name.startswith("cap part")}
    assert widths == pytest.approx({"cap part 1 of 2": 700.0 + 12.5, "cap part 2 of 2": report.width - 700.0 + 12.5},
                                   abs=1e-6)
    panel.choose_material("woven")  # the Nest showed each material as it nested it
    assert panel.splice_rows()[0][2:] == ("700", "by hand") and panel.splice_rows()[1][3] == "chosen"
    np.testing.assert_allclose(view.layer_lines("splices"), drawn_splices(win, report), atol=1e-12)
    assert panel.reset_splices_button.isEnabled()

    # a position that leaves a part too wide: one line, and nothing else changes
    errors = []
    panel.input_error.connect(errors.append)
    panel.splices.item(0, 2).setText("100")
    assert len(errors) == 1 and "part 2 of 2 would be" in errors[0] and "\n" not in errors[0]
    assert panel.splice_error.text() == errors[0] and errors[0] in win.statusBar().currentMessage()
    assert not panel.busy and panel.markers["woven"] is marker
    assert win.project.cut_plan.splice_map() == {"cap": [700.0]} and win.document.undo_label == "Splices"
    assert panel.splice_rows()[0][2] == "700"
    panel.splices.item(0, 2).setText("seven")  # not a number: likewise
    assert len(errors) == 2 and "not a list of positions" in errors[1] and panel.markers["woven"] is marker

    # Reset: the chosen splices again
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        panel.reset_splices_button.click()
    panel.choose_material("woven")
    assert win.project.cut_plan.splices == () and not any(r.asked for r in panel.spliced["woven"])
    assert win.document.undo_label == "Reset splices"
    assert panel.splice_error.text() == "" and all(row[3] == "chosen" for row in panel.splice_rows())

    # the pieces change: the splices are no longer the marker's, nor drawn; another document drops them
    win.pieces_panel.rename(0, "lid")
    assert panel.stale and len(view.layer_lines("splices")) == 0
    win.undo()
    assert not panel.stale and len(view.layer_lines("splices")) > 50
    win.set_project(kit)
    assert len(view.layer_lines("splices")) == 0 and panel.splice_rows() == []


def type_into(qtbot, box, text: str) -> None:
    """``text`` typed over a spin box's value, then Enter (the boxes take a value on Enter, not each key)."""
    box.setFocus()
    box.lineEdit().selectAll()
    qtbot.keyClicks(box, text)
    qtbot.keyClick(box, Qt.Key.Key_Return)


def test_the_settings_typed_in_the_dock_are_the_projects_cut_plan(make_window, qtbot, kit, tmp_path):
    win = make_window(kit)
    panel = win.cut_plan
    assert panel.plan == CutPlanSettings() and panel.shown_material() == "woven"
    assert panel.gap.value() == 0.0 and panel.roll_width.value() == panel.default_width("woven")
    asked = []
    panel.plan_edited.connect(lambda plan, label: asked.append(label))

    type_into(qtbot, panel.gap, "3.5")
    assert win.project.cut_plan.gap_mm == 3.5 and win.document.undo_label == "Gap"
    type_into(qtbot, panel.roll_width, "1800")
    plan = win.project.cut_plan
    assert plan.width_for("woven") == 1800.0 and plan.width_for("isotropic") is None
    assert win.document.undo_label == "Roll width" and asked == ["Gap", "Roll width"]
    panel.choose_material("isotropic")  # the width shown is the shown material's
    assert panel.roll_width.value() == panel.default_width("isotropic")
    panel.choose_material("woven")
    assert panel.roll_width.value() == 1800.0

    # an undo puts each back and the box follows; a redo again; showing the plan is no edit
    win.undo()
    assert win.project.cut_plan.width_for("woven") is None and panel.roll_width.value() == panel.default_width("woven")
    assert panel.gap.value() == 3.5
    win.undo()
    assert win.project.cut_plan == CutPlanSettings() and panel.gap.value() == 0.0
    win.redo()
    win.redo()
    assert win.project.cut_plan == plan and panel.gap.value() == 3.5 and panel.roll_width.value() == 1800.0
    assert asked == ["Gap", "Roll width"] and win.document.undo_label == "Roll width"

    # the others too; a width refused is one line and nothing changes
    panel.time_limit.setValue(7)
    panel.allowance.setValue(4.0)
    panel.overlap.setValue(30.0)
    plan = win.project.cut_plan
    assert (plan.seconds, plan.allowance_mm, plan.overlap_mm) == (7.0, 4.0, 30.0)
    assert asked[2:] == ["Time limit", "Seam allowance", "Splice overlap"]
    errors = []
    panel.input_error.connect(errors.append)
    assert not panel.set_roll_width(0.0)
    assert len(errors) == 1 and errors[0].startswith("Roll width: ") and "\n" not in errors[0]
    assert win.project.cut_plan == plan and panel.roll_width.value() == 1800.0

    # saved with the project: another window on the file shows them
    path = save_project(win.project, tmp_path / "kit.flatweave")
    again = make_window(load_project(path)).cut_plan
    assert again.plan == plan and again.shown_material() == "woven"
    assert (again.roll_width.value(), again.gap.value(), again.time_limit.value(), again.allowance.value(),
            again.overlap.value()) == (1800.0, 3.5, 7, 4.0, 30.0)
    again.choose_material("isotropic")
    assert again.roll_width.value() == again.default_width("isotropic")


def test_a_splice_placed_by_hand_is_saved_with_the_project_and_nested_again(make_window, qtbot, kit, tmp_path):
    win, panel = cut_plan(make_window, kit)
    panel.set_roll_width(1000.0)
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        panel.nest_button.click()
    panel.choose_material("woven")
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        assert panel.place_splices("cap", "700")
    assert win.project.cut_plan.splice_map() == {"cap": [700.0]}

    path = save_project(win.project, tmp_path / "spliced.flatweave")
    reopened = load_project(path)
    assert reopened.cut_plan == win.project.cut_plan
    win2 = make_window(reopened)  # a reset: no marker, the plan's settings shown
    panel2 = win2.cut_plan
    panel2.workers = 1
    assert panel2.markers == {} and panel2.splice_rows() == []
    assert panel2.roll_width.value() == 1000.0 and panel2.time_limit.value() == 1
    with qtbot.waitSignal(panel2.finished, timeout=NEST_TIMEOUT_MS):
        panel2.nest_button.click()
    panel2.choose_material("woven")
    rows = panel2.splice_rows()
    assert [row[0] for row in rows] == ["cap", "cap +45"]
    assert rows[0][2:] == ("700", "by hand") and rows[1][3] == "chosen"
    report = next(r for r in panel2.spliced["woven"] if r.name == "cap")
    assert report.asked and [y - report.start for y in report.positions] == pytest.approx([700.0])
    assert marker_problems(panel2.markers["woven"]) == []

    # Reset: one edit of the plan, and nested with the chosen ones; an undo brings the hand-placed back
    with qtbot.waitSignal(panel2.finished, timeout=NEST_TIMEOUT_MS):
        assert panel2.reset_splices("woven")
    assert win2.project.cut_plan.splices == () and win2.document.undo_label == "Reset splices"
    win2.undo()
    assert win2.project.cut_plan.splice_map() == {"cap": [700.0]}
    panel2.choose_material("woven")
    assert panel2.reset_splices_button.isEnabled()


def test_mirror_pairs_cut_half_a_pieces_copies_mirrored(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, kit)
    assert panel.mirror_rows() == [("cap", False), ("cap +45", False), ("side", False)]
    assert panel.mirror_list.item(0).toolTip().startswith("cap: a left and a right panel")
    assert "half its copies cut as the mirror image" in MIRROR_TIP
    panel.mirror_list.item(0).setCheckState(Qt.CheckState.Checked)  # as a click on its box
    assert win.project.cut_plan.mirror == ("cap",) and win.document.undo_label == "Mirror pairs"
    assert panel.mirror_rows()[0] == ("cap", True)

    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        panel.nest_button.click()
    panel.choose_material("woven")
    marker = panel.markers["woven"]
    assert marker_problems(marker) == [] and panel.view.marker is marker
    cap = [k for k, it in enumerate(marker.items) if it.name == "cap"]
    assert len(cap) == 1 and marker.items[cap[0]].mirror
    copies = [p for p in marker.placements if p.item == cap[0]]
    assert len(copies) == kit.pieces[0].quantity == 2 and sum(p.mirrored for p in copies) == 1
    assert not any(p.mirrored for p in marker.placements if p.item != cap[0])
    if os.environ.get("FLATWEAVE_SHOT"):  # a look at the mirrored copies (drawn with a dashed edge)
        win.show_cut_plan()
        win.cut_plan_dock.grab().save(os.environ["FLATWEAVE_SHOT"].replace(".png", "_mirror.png"))
    # what the view paints is the mirrored copy's reflected outline
    for (_, pixels), outline in zip(panel.view.painted(), marker.outlines()):
        np.testing.assert_allclose(pixels, panel.view.to_pixels(outline), atol=1e-9)

    win.undo()  # the row follows the plan
    assert win.project.cut_plan.mirror == () and panel.mirror_rows()[0] == ("cap", False)


def test_a_splice_dragged_in_the_splice_view_is_placed_there(make_window, qtbot, kit):
    win, panel = cut_plan(make_window, kit)
    panel.set_roll_width(1000.0)
    win.show_cut_plan()
    win.resize(1400, 900)
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        panel.nest_button.click()
    panel.choose_material("woven")
    view = panel.splice_view
    qtbot.waitUntil(lambda: view.isVisible() and view.to_pixels([(0.0, 0.0)]).size > 0, timeout=10000)
    assert view.report.name == "cap"  # the first row when none is selected
    panel.splices.selectRow(1)
    assert view.report.name == "cap +45"
    panel.splices.selectRow(0)
    report = view.report
    assert report.name == "cap" and view.positions() == pytest.approx([y - report.start for y in report.positions])

    if os.environ.get("FLATWEAVE_SHOT"):  # a look at the dock: FLATWEAVE_SHOT=/tmp/cutplan_dock.png
        win.cut_plan_dock.grab().save(os.environ["FLATWEAVE_SHOT"])

    def pixel(mm_from_edge: float) -> QPoint:
        x = float(view.outline[:, 0].mean())
        px, py = view.to_pixels([(x, report.start + mm_from_edge)])[0]
        return QPoint(round(px), round(py))

    # dragged with the mouse to 800 mm from the edge: the plan has it, the parts follow
    at = view.line_pixels(0)
    mm_per_px = 1.0 / (view.to_pixels([(0.0, 0.0)])[0, 1] - view.to_pixels([(0.0, 1.0)])[0, 1])
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(round(at.x()), round(at.y())))
    qtbot.mouseMove(view, pos=pixel(800.0))
    dragged = view.positions()[0]
    assert dragged == pytest.approx(800.0, abs=0.5 * mm_per_px + 0.1)  # drawn where the mouse is, live
    with qtbot.waitSignal(panel.finished, timeout=NEST_TIMEOUT_MS):
        qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=pixel(800.0))
    (placed,) = win.project.cut_plan.splice_map()["cap"]
    assert placed == pytest.approx(dragged, abs=1.0) and win.document.undo_label == "Splices"
    panel.choose_material("woven")
    report = next(r for r in panel.spliced["woven"] if r.name == "cap")
    assert report.asked and [y - report.start for y in report.positions] == pytest.approx([placed], abs=1e-6)
    marker = panel.markers["woven"]
    assert marker_problems(marker) == []
    widths = {it.name: float(np.ptp(across(it.outline, report.frame_deg))) for it in marker.items
              if it.name.startswith("cap part")}
    assert widths == pytest.approx({"cap part 1 of 2": placed + 12.5, "cap part 2 of 2": report.width - placed + 12.5},
                                   abs=1e-6)
    assert panel.splice_rows()[0][3] == "by hand"
    view = panel.splice_view
    qtbot.waitUntil(lambda: view.report is report, timeout=10000)
    assert view.positions() == pytest.approx([placed], abs=1e-6)

    # dragged to where part 2 would be wider than the roll: said while dragging, refused in one line, snapped back
    errors = []
    panel.input_error.connect(errors.append)
    at = view.line_pixels(0)
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(round(at.x()), round(at.y())))
    qtbot.mouseMove(view, pos=pixel(100.0))
    assert view.positions()[0] == pytest.approx(100.0, abs=0.5 * mm_per_px + 0.1)
    assert any(hi - lo > view.usable for lo, hi in view.parts())
    revision = win.document.revision
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=pixel(100.0))
    assert len(errors) == 1 and "part 2 of 2 would be" in errors[0] and "\n" not in errors[0]
    assert panel.splice_error.text() == errors[0] and not panel.busy and panel.markers["woven"] is marker
    assert win.document.revision == revision and win.project.cut_plan.splice_map() == {"cap": [placed]}
    assert view.positions() == pytest.approx([placed], abs=1e-6) and view.line_pixels(0) == at
    assert view.drag_splice(0, 50.0) == [50.0] and len(errors) == 2  # without a mouse, likewise
    assert win.project.cut_plan.splice_map() == {"cap": [placed]}
