"""The materials table in the window (issue 41; flatweave.app.materialsdialog and the
Pieces tab's material box): a cell edited is checked by the Fabric it makes, a
refused value said in one line and the cell put back; presets and copies
added, a used material not deleted; a table exported and imported; OK makes
the edited table one undoable edit, and choosing the active piece's material
is one too."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLineEdit

from flatweave.app.materialsdialog import KEYS, MaterialsDialog
from flatweave.document import pieces as P
from flatweave.document.project import new_project
from flatweave.method.materials import FABRICS, Fabric
from flatweave.reading.examples import load_example

TWILL = "glass twill 290"
CARBON = "carbon plain weave 200"


@pytest.fixture(scope="module")
def octant():
    """The octant as a project of two pieces, the second cut from the carbon preset."""
    p = new_project(load_example("octant"), "octant", None, 0.1)
    p = P.add(p, "ply 2")
    return P.select(P.use_material(p, 1, CARBON), 0)


def dialog(qtbot, project) -> MaterialsDialog:
    d = MaterialsDialog(project)
    qtbot.addWidget(d)
    return d


def row_of(d: MaterialsDialog, name: str) -> int:
    return [f.name for f in d.table()].index(name)


def test_a_bad_cell_is_said_in_one_line_and_put_back(qtbot, octant):
    d = dialog(qtbot, octant)
    d.show()
    qtbot.waitExposed(d)
    r = row_of(d, CARBON)
    lock = KEYS.index("lock")
    before = d.row_texts()
    assert before[r][lock] == "30"
    # typed as a user does: the cell's editor opened, a lock angle below the warning angle entered
    d.grid.setCurrentCell(r, lock)
    d.grid.editItem(d.grid.item(r, lock))
    editors = [w for w in d.grid.findChildren(QLineEdit) if w.isVisible()]
    assert len(editors) == 1
    editor = editors[0]
    editor.selectAll()
    qtbot.keyClicks(editor, "10")
    qtbot.keyClick(editor, Qt.Key.Key_Return)  # the delegate commits in a queued call
    qtbot.waitUntil(lambda: d.status.text() != "", timeout=2000)
    assert "below the lock angle (10)" in d.status.text() and "\n" not in d.status.text()
    assert d.table() == octant.materials and d.row_texts() == before
    d.edit_cell(r, "roll", "wide")
    assert "roll width must be a number" in d.status.text() and d.table() == octant.materials
    d.edit_cell(r, "ratio", "500:500")
    assert "three numbers" in d.status.text() and d.table() == octant.materials
    d.edit_cell(row_of(d, TWILL), "name", " Garment  Woven")  # another row's name, case and spaces aside
    assert "two materials are named" in d.status.text() and d.table() == octant.materials
    d.edit_cell(r, "name", "carbon 2")  # a piece is cut from it: it keeps its name
    assert "keeps its name" in d.status.text() and d.row_texts() == before
    assert "Traceback" not in d.status.text()

    # a good value is taken, shown as the table writes it, and the kind follows the springs
    t = row_of(d, TWILL)
    d.edit_cell(t, "ratio", "100 : 100 : 50")
    assert d.table()[t].material.k_diag == 50.0 and d.row_texts()[t][1:3] == ["isotropic", "100:100:50"]
    d.edit_cell(t, "thickness", "")
    assert d.table()[t].thickness_mm is None and d.status.text() == ""


def test_a_used_material_is_not_deleted_an_unused_one_is(qtbot, octant):
    d = dialog(qtbot, octant)
    d.grid.selectRow(row_of(d, CARBON))
    d.delete_button.click()
    assert "not deleted" in d.status.text() and "ply 2" in d.status.text()
    assert d.table() == octant.materials
    d.grid.selectRow(row_of(d, TWILL))
    d.delete_button.click()
    assert TWILL not in [f.name for f in d.table()] and len(d.table()) == len(octant.materials) - 1
    actions = [a.text() for a in d.add_preset_button.menu().actions()]
    assert actions == [f"{TWILL} (woven)"]  # the only preset the table lacks now
    d.add_preset_button.menu().actions()[0].trigger()
    assert d.table()[-1] == FABRICS[TWILL] and not d.add_preset_button.isEnabled()


def test_export_then_import_round_trip(qtbot, octant, tmp_path):
    a = dialog(qtbot, octant)
    a.grid.selectRow(row_of(a, CARBON))
    a.add_copy_button.click()
    assert a.table()[row_of(a, CARBON) + 1].name == f"{CARBON} copy"
    a.edit_cell(row_of(a, CARBON), "roll", "999")
    a.edit_cell(row_of(a, f"{CARBON} copy"), "weight", "245")
    a._ask_path = lambda save: str(tmp_path / "shop") if save else ""
    a.export_button.click()
    path = tmp_path / "shop.json"
    assert json.loads(path.read_text())["format"] == "flatweave-materials"

    b = dialog(qtbot, octant)
    asked = []
    b._ask_path = lambda save: asked.append(save) or str(path)
    b.import_button.click()
    assert asked == [False]
    # same-named rows replaced in place, the new one added after the others
    assert {f.name: f for f in b.table()} == {f.name: f for f in a.table()} and len(b.table()) == len(a.table())
    assert b.table()[-1].name == f"{CARBON} copy" and b.table()[-1].areal_weight_gsm == 245.0
    assert b.table()[row_of(b, CARBON)].roll_width_mm == 999.0
    assert "1 added" in b.status.text()

    path.write_text("{not json")
    before = b.table()
    b.import_button.click()
    assert "Not imported" in b.status.text() and b.table() == before


def test_ok_makes_the_edited_table_one_undoable_edit(make_window, qtbot, octant):
    without = replace(octant, materials=tuple(f for f in octant.materials if f.name != TWILL))
    win = make_window(project=without)
    panel = win.pieces_panel
    shown = []
    win.show_error = shown.append
    undo = len(win.document.history)

    panel.materials_button.click()  # opened, nothing changed, OK: no edit
    d = panel.materials_dialog
    assert d is not None and d.isVisible()
    d.accept()
    assert len(win.document.history) == undo and win.project.materials == without.materials

    d = panel.open_materials()  # a preset added, then Cancel: nothing
    d.add_preset(TWILL)
    d.reject()
    assert len(win.document.history) == undo and win.project.fabric(TWILL) is None

    d = panel.open_materials()
    d.add_preset(TWILL)
    d.edit_cell(len(d.table()) - 1, "roll", "1000")
    d.edit_cell(row_of(d, CARBON), "warn", "12")  # a used row: its pieces take it in the same edit
    d.accept()
    assert not shown
    p = win.project
    assert len(win.document.history) == undo + 1 and win.document.undo_label == "Edit materials"
    assert p.fabric(TWILL) == replace(FABRICS[TWILL], roll_width_mm=1000.0)
    assert p.pieces[1].settings.material.warn_deg == 12.0 and p.fabric(CARBON).material.warn_deg == 12.0
    assert any(t.startswith(TWILL) for t in panel.materials())
    win.undo()
    assert win.project.materials == without.materials and win.project.pieces[1].settings.material.warn_deg == 15.0
    assert not any(t.startswith(TWILL) for t in panel.materials())


def test_the_material_box_cuts_the_active_piece_from_a_row_as_one_edit(make_window, qtbot, octant):
    win = make_window(project=octant)
    panel = win.pieces_panel
    old = win.project.settings.material
    assert panel.material.currentData() == old.name
    undo = len(win.document.history)
    i = panel.material.findData(TWILL)
    panel.material.setCurrentIndex(i)
    panel.material.activated.emit(i)
    p = win.project
    assert p.piece_index == 0 and p.settings.material == FABRICS[TWILL].material
    assert (p.settings.material.warn_deg, p.settings.material.lock_deg) == (20.0, 40.0)
    assert p.pieces[1].settings.material.name == CARBON  # the other piece keeps its own
    assert len(win.document.history) == undo + 1 and win.document.undo_label == f"Material {TWILL}"
    panel.list.setCurrentRow(1)  # the box follows the active piece
    assert panel.material.currentData() == CARBON
    panel.list.setCurrentRow(0)
    assert panel.material.currentData() == TWILL
    win.undo()
    assert win.project.settings.material == old and panel.material.currentData() == old.name


def test_a_material_the_table_lacks_is_shown_not_chosen(qtbot, octant):
    from flatweave.app.piecespanel import PiecesPanel

    odd = Fabric(replace(octant.settings.material, name="shop special"))
    p = replace(octant, settings=replace(octant.settings, material=odd.material))
    panel = PiecesPanel()
    qtbot.addWidget(panel)
    edits = []
    panel.piece_edit.connect(lambda *a: edits.append(a))
    panel.set_project(p)
    assert panel.materials()[0] == "shop special (not in the table)" and panel.material.currentIndex() == 0
    panel.material.activated.emit(0)
    assert edits == []
    panel.material.activated.emit(panel.material.findData(TWILL))
    assert len(edits) == 1 and edits[0][1](p).settings.material == FABRICS[TWILL].material
