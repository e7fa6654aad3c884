"""The tool's rosettes in the window (issue 41, item 1; flatweave.app.rosettesdialog):
the rows shown are the project's table; a rosette added at the active piece's
seed lies there along its weft; a cell is kept as typed and a row that makes no
rosette (not a number, a zero direction, a name taken) said in one red line
with OK off; a rosette pieces use keeps its name and is not deleted; and the
table OK hands over re-lays the plies oriented from a rosette turned."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QDialog, QLineEdit

from flatweave.app.rosettesdialog import KEYS, RosettesDialog
from flatweave.document.pieces import pieces_of, set_rosettes
from flatweave.document.project import new_project
from flatweave.document.rosettes import ToolRosette
from flatweave.errors import SettingsError
from flatweave.method.rosette import orientation_for, rosette
from flatweave.reading.examples import load_example
from flatweave.reading.registry import open_path

JOB = Path(__file__).resolve().parent.parent / "resources" / "jobs" / "dome-laminate.toml"


@pytest.fixture(scope="module")
def dome():
    """The bundled 24-ply dome: one rosette, "rosette 1", every ply oriented from it."""
    return open_path(JOB).project


@pytest.fixture(scope="module")
def octant():
    """The octant, no rosettes, its piece's seed off the middle and its weft at 30 degrees: a
    rosette added at the seed then points somewhere other than the surface's first direction."""
    p = new_project(load_example("octant"), "octant", None, 0.1)
    return replace(p, settings=replace(p.settings, seed=(0.3, 0.6), angle_deg=30.0))


def dialog(qtbot, project) -> RosettesDialog:
    d = RosettesDialog(project)
    qtbot.addWidget(d)
    return d


def one_line_error(d: RosettesDialog, *words: str) -> None:
    text = d.status.text()
    assert "\n" not in text and "Traceback" not in text and "#b00020" in d.status.styleSheet(), text
    for w in words:
        assert w in text, text
    assert not d.ok_button.isEnabled()


def test_the_rows_shown_are_the_project_rosettes(qtbot, dome):
    d = dialog(qtbot, dome)
    assert d.original == dome.rosettes and d.table() == dome.rosettes
    assert d.row_texts() == [["rosette 1", "0", "0", "0", "1", "0", "0", "24"]]
    assert d.ok_button.isEnabled() and d.status.text() == ""

    # a value shown with :g (six digits) is still handed back whole when its cell is not edited
    side = ToolRosette("side", (123.456789, -0.0, 5), (0, 0, 2))
    d = dialog(qtbot, replace(dome, rosettes=dome.rosettes + (side,)))
    assert d.row_texts()[1] == ["side", "123.457", "0", "5", "0", "0", "2", "0"]
    assert d.table()[1] == side and d.table()[1].origin[0] == 123.456789
    assert d.grid.item(1, KEYS.index("used")).toolTip() == "No piece is oriented from it"
    assert "P01" in d.grid.item(0, KEYS.index("used")).toolTip()


def test_add_at_the_seed_lies_along_the_active_piece_weft(qtbot, octant, dome):
    d = dialog(qtbot, octant)
    assert d.table() == () and "No rosettes yet" in d.status.text() and d.ok_button.isEnabled()
    d.add_button.click()
    d.add_at_seed()
    added = d.table()
    assert [r.name for r in added] == ["rosette 1", "rosette 2"]
    want = rosette(octant.surface, octant.settings.seed, 30.0)
    for r in added:
        assert np.allclose(r.origin, want.origin, rtol=0, atol=1e-9)
        assert np.allclose(r.zero, want.weft, rtol=0, atol=1e-9)
        # the active piece lies at 0 degrees from it
        assert abs(orientation_for(octant.surface, octant.settings.seed, r.zero, 30.0)) < 1e-6
    # not the surface's 0-degree direction: the weft angle was taken into account
    assert not np.allclose(added[0].zero, rosette(octant.surface, octant.settings.seed, 0.0).weft, atol=1e-3)
    assert d.row_texts()[1][KEYS.index("used")] == "0" and d.selected_row() == 1
    assert "Added 'rosette 2'" in d.status.text() and d.ok_button.isEnabled()

    d = dialog(qtbot, dome)  # the first free number: the table has "rosette 1"
    d.add_at_seed()
    assert [r.name for r in d.table()] == ["rosette 1", "rosette 2"]
    # the dome's pole: the evaluation's 1e-16 dust is shown (and kept) as 0
    assert d.row_texts()[1][1:7] == ["0", "0", "1", "1", "0", "0"] and d.table()[1].origin == (0.0, 0.0, 1.0)


def test_a_number_edited_is_what_the_table_hands_over(qtbot, dome):
    d = dialog(qtbot, dome)
    d.edit_cell(0, "oy", " 12.5 ")
    d.edit_cell(0, "dz", "-3e-1")
    r = d.table()[0]
    assert r.origin == (0.0, 12.5, 0.0) and r.zero == (1.0, 0.0, -0.3)
    assert d.row_texts()[0][1:7] == ["0", "12.5", "0", "1", "0", "-0.3"]
    assert d.status.text() == "" and d.ok_button.isEnabled() and d.table() != d.original


def test_a_number_typed_in_the_cell_editor(qtbot, dome):
    d = dialog(qtbot, dome)
    d.show()
    qtbot.waitExposed(d)
    c = KEYS.index("dx")
    d.grid.setCurrentCell(0, c)
    d.grid.editItem(d.grid.item(0, c))
    editors = [w for w in d.grid.findChildren(QLineEdit) if w.isVisible()]
    assert len(editors) == 1
    editors[0].selectAll()
    qtbot.keyClicks(editors[0], "2")
    qtbot.keyClick(editors[0], Qt.Key.Key_Return)  # the delegate commits in a queued call
    qtbot.waitUntil(lambda: d.table()[0].zero == (2.0, 0.0, 0.0), timeout=2000)
    assert d.row_texts()[0][c] == "2"


def test_a_bad_row_turns_ok_off_with_one_red_line(qtbot, dome):
    d = dialog(qtbot, dome)
    d.edit_cell(0, "ox", "ten")
    one_line_error(d, "Row 1", "origin x must be a number", "'ten'")
    assert d.row_texts()[0][1] == "ten"  # kept as typed, to be put right
    with pytest.raises(SettingsError, match="row 1"):
        d.table()
    d.accept()  # Return in a cell asks for OK all the same: refused
    assert d.result() != QDialog.DialogCode.Accepted
    d.edit_cell(0, "ox", "")
    one_line_error(d, "origin x needs a number")
    d.edit_cell(0, "ox", "0")
    assert d.status.text() == "" and d.ok_button.isEnabled() and d.table() == dome.rosettes

    d.edit_cell(0, "dx", "0")
    one_line_error(d, "Row 1", "0-degree direction must be a direction, not [0, 0, 0]")
    d.edit_cell(0, "dx", "nan")
    one_line_error(d, "finite")
    d.edit_cell(0, "dx", "1")
    assert d.ok_button.isEnabled() and d.table() == dome.rosettes

    d.add_at_seed()
    d.edit_cell(1, "name", "  ROSETTE   1 ")  # another row's name, case and spaces aside
    one_line_error(d, "Rows 1 and 2 are both named 'ROSETTE 1'")
    d.edit_cell(1, "name", " ")
    one_line_error(d, "Row 2", "name must be a line")
    d.edit_cell(1, "name", "flange  datum")
    assert d.ok_button.isEnabled() and d.status.text() == ""
    assert [r.name for r in d.table()] == ["rosette 1", "flange datum"]


def test_a_used_rosette_is_not_deleted_an_unused_one_is(qtbot, dome):
    d = dialog(qtbot, dome)
    d.select_row(0)
    d.delete_button.click()
    assert "not deleted" in d.status.text() and "P01" in d.status.text() and "P24" in d.status.text()
    assert "\n" not in d.status.text() and d.table() == dome.rosettes and d.grid.rowCount() == 1
    assert d.ok_button.isEnabled()  # a refusal, not a bad table

    d.add_at_seed()
    d.select_row(1)
    assert d.delete_selected()
    assert d.table() == dome.rosettes and d.grid.rowCount() == 1 and "Deleted 'rosette 2'" in d.status.text()

    d.add_at_seed()  # a bad new row can go too, and OK comes back
    d.edit_cell(1, "dz", "x")
    assert not d.ok_button.isEnabled()
    d.select_row(1)
    d.delete_button.click()
    assert d.table() == dome.rosettes and d.ok_button.isEnabled()


def test_a_used_rosette_keeps_its_name(qtbot, dome):
    d = dialog(qtbot, dome)
    name = d.grid.item(0, KEYS.index("name"))
    assert not name.flags() & Qt.ItemFlag.ItemIsEditable and "keeps its name" in name.toolTip()
    assert d.grid.item(0, KEYS.index("dx")).flags() & Qt.ItemFlag.ItemIsEditable
    assert not d.grid.item(0, KEYS.index("used")).flags() & Qt.ItemFlag.ItemIsEditable
    d.edit_cell(0, "name", "rosette A")  # set from code all the same: refused and put back
    assert "keeps its name" in d.status.text() and "P01" in d.status.text()
    assert d.table() == dome.rosettes and d.row_texts()[0][0] == "rosette 1"
    d.edit_cell(0, "used", "3")  # a count, not a value
    assert d.row_texts()[0][KEYS.index("used")] == "24" and d.table() == dome.rosettes

    d.add_at_seed()  # a new rosette's name is the user's to choose
    assert d.grid.item(1, KEYS.index("name")).flags() & Qt.ItemFlag.ItemIsEditable


def test_a_rosette_turned_re_lays_its_plies(qtbot, dome):
    d = dialog(qtbot, dome)
    d.edit_cell(0, "dx", "0")  # 0 degrees turned from +x to +y: 90 degrees about z
    d.edit_cell(0, "dy", "1")
    table = d.table()
    assert table[0].zero == (0.0, 1.0, 0.0)
    edited = set_rosettes(dome, table)
    before, after = pieces_of(dome), pieces_of(edited)
    assert len(after) == 24 and edited.rosettes == table
    for a, b in zip(before, after):
        assert b.rosette == a.rosette == "rosette 1" and b.orientation == a.orientation
        assert b.settings.angle_deg != a.settings.angle_deg
        assert abs((b.settings.angle_deg - a.settings.angle_deg) % 360.0 - 90.0) < 1e-6


def test_ok_and_cancel_as_a_window_modal_dialog(qtbot, dome):
    d = dialog(qtbot, dome)
    got = []
    d.accepted.connect(lambda: got.append(d.table()))
    d.open()
    qtbot.waitExposed(d)
    assert d.isModal() and d.isVisible()
    d.edit_cell(0, "oz", "7")
    d.ok_button.click()
    assert got == [(replace(dome.rosettes[0], origin=(0.0, 0.0, 7.0)),)] and not d.isVisible()

    d = dialog(qtbot, dome)
    d.accepted.connect(lambda: got.append("no"))
    d.open()
    d.edit_cell(0, "oz", "8")
    d.reject()
    assert len(got) == 1 and d.result() == QDialog.DialogCode.Rejected
