"""The window's Pieces tab (issue 41, step 3; flatweave.app.piecespanel): the
project's pieces listed with their state, a row selected makes that piece the
active one (the settings, views and result are then its own), and Add,
Duplicate at an angle, rename, Up, Down and Delete are undoable edits that
save and reopen with the project."""

from __future__ import annotations

import pytest
from pypdf import PdfReader

from tests.test_app_run import run_to_end

pytestmark = pytest.mark.slow


def test_plies_are_duplicated_at_angles_selected_renamed_moved_deleted_and_saved(make_window, qtbot, tmp_path):
    win = make_window(example="octant")
    shown = []
    win.show_error = shown.append
    panel = win.pieces_panel
    assert panel.rows() == ["octant   +0 deg   not solved"] and not panel.delete.isEnabled()
    run_to_end(qtbot, win)
    m = win.project.result.metrics
    assert win.project.result_is_current
    assert panel.rows()[0].endswith(f"{m['boundary_error_pct']:.2f} % / {m['area_error_pct']:.2f} %")
    assert "converged" in panel.list.item(0).toolTip()
    first = win.project.result

    menu = {a.text(): a for a in panel.duplicate.menu().actions()}
    menu["at +45 deg"].trigger()  # a copy of the selected piece, its weft turned 45 degrees, made active
    p = win.project
    assert [x.name for x in p.pieces] == ["octant", "octant +45"] and p.piece_index == 1
    assert p.settings.angle_deg == 45.0 and p.result is None
    assert win.settings_panel.angle.value() == 45.0  # the settings shown are the active piece's
    assert "not solved" in panel.rows()[1] and panel.list.currentRow() == 1
    run_to_end(qtbot, win)  # the active piece solves: the +45 ply
    assert win.project.result_is_current and win.project.result.settings.angle_deg == 45.0

    panel.list.setCurrentRow(0)  # selecting a row makes that piece active: its own result again
    p = win.project
    assert p.piece_index == 0 and p.result is first and p.result_is_current and p.settings.angle_deg == 0.0
    assert win.settings_panel.angle.value() == 0.0
    panel.duplicate_at(0, 90.0)
    panel.rename(1, "  ply   90 ")
    assert [x.name for x in win.project.pieces] == ["octant", "ply 90", "octant +45"]
    assert win.project.pieces[1].settings.angle_deg == 90.0
    panel.list.setCurrentRow(1)
    panel.down.click()
    assert [x.name for x in win.project.pieces] == ["octant", "octant +45", "ply 90"]
    assert win.project.piece_name == "ply 90" and panel.list.currentRow() == 2
    panel.delete.click()
    assert [x.name for x in win.project.pieces] == ["octant", "octant +45"]
    win.undo()  # the delete undone: the piece back, active
    assert [x.name for x in win.project.pieces] == ["octant", "octant +45", "ply 90"]
    assert win.project.piece_name == "ply 90"

    panel.rename(2, "Octant")  # the same name as another piece: refused in one line, nothing changed
    assert shown and "two pieces are named" in shown[-1] and "\n" not in shown[-1]
    assert [x.name for x in win.project.pieces] == ["octant", "octant +45", "ply 90"]

    # a run of one piece stops when another is selected: its result would answer nothing shown
    with qtbot.waitSignal(win.runner.cancelled, timeout=30000):
        win.run()  # "ply 90", unsolved
        panel.list.setCurrentRow(0)
    assert win.project.piece_name == "octant" and win.project.result is first
    assert win.project.pieces[2].result is None

    assert win.save_to(tmp_path / "plies")
    other = make_window(example=None)
    assert other.open_file(tmp_path / "plies.flatweave")
    q = other.project
    assert [x.name for x in q.pieces] == ["octant", "octant +45", "ply 90"] and q.piece_name == "octant"
    assert [x.result is not None for x in q.pieces] == [True, True, False]
    assert other.pieces_panel.rows()[1].startswith("octant +45   +45 deg   ") and "%" in other.pieces_panel.rows()[1]
    assert other.pieces_panel.rows()[2] == "ply 90   +90 deg   not solved"
    other.pieces_panel.list.setCurrentRow(1)
    assert other.project.result_is_current and other.project.settings.angle_deg == 45.0


def test_solve_all_solves_every_piece_in_workers_while_the_window_stays_live(make_window, qtbot, tmp_path):
    """Three plies at 0, +45 and 90 degrees; Solve all: each is reported as it finishes, the results
    come as one undoable edit, each the one the piece gets alone; a piece edited meanwhile keeps its state.
    Then File > Export ply book and Export all pieces write the book and every piece's cut files."""
    from flatweave import flatten

    win = make_window(example="octant")
    panel = win.pieces_panel
    panel.duplicate_at(0, 45.0)
    panel.duplicate_at(1, 90.0)
    panel.list.setCurrentRow(0)
    assert [x.result for x in win.project.pieces] == [None, None, None]
    reported = []
    win.solve_all.piece_done.connect(lambda name, text: reported.append((name, text)))
    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        panel.solve_button.click()
        assert win.solve_all.busy and not panel.solve_button.isEnabled()  # the window is live meanwhile
        assert panel.solve_button.text() == "Solving all..."
        panel.rename(2, "ply 90")  # a label: the piece keeps its settings, so its result is taken
    assert sorted(n for n, _ in reported) == ["octant", "octant +45", "octant +90"]
    assert all(text == "converged" for _, text in reported)
    assert win.last_solve_all == "Solve all: 3 of 3 pieces solved" and panel.solve_button.isEnabled()
    p = win.project
    assert p.result_is_current and [x.name for x in p.pieces] == ["octant", "octant +45", "ply 90"]
    for piece in p.pieces:
        alone = flatten(p.surface, piece.settings)
        assert piece.result is not None and (piece.result.pattern.xy == alone.pattern.xy).all()
    assert all(row.endswith("%") for row in panel.rows())

    book = tmp_path / "plies.pdf"
    win.exports.ask_book_path = lambda start: str(book)
    with qtbot.waitSignal(win.export_finished, timeout=120000):
        win.actions["export_book"].trigger()
    pages = PdfReader(str(book)).pages
    assert len(pages) == 1 + 3
    assert [p.extract_text().splitlines()[0] for p in pages[1:]] == ["octant", "octant +45", "ply 90"]
    qtbot.waitUntil(lambda: not win.exports.busy and win.actions["export_pieces"].isEnabled())
    folder = tmp_path / "cut"
    win.exports.ask_folder = lambda start: str(folder)
    with qtbot.waitSignal(win.export_finished, timeout=300000):
        win.actions["export_pieces"].trigger()
    assert sorted(x.name for x in folder.glob("*.svg")) == ["octant.svg", "octant_45.svg", "ply_90.svg"]
    assert len(list(folder.glob("*.dxf"))) == 1 and len(list(folder.glob("*.pdf"))) == 3
    assert "Exported" in win.progress.text()
    win.undo()  # Solve all is one step
    assert [x.result for x in win.project.pieces] == [None, None, None]


def test_a_job_file_opens_in_the_window_as_its_plies(make_window):
    """File > Open on the bundled 24-ply job: the project of its plies, listed in the Pieces tab."""
    from pathlib import Path

    win = make_window(example=None)
    shown = []
    win.show_error = shown.append
    job = Path(__file__).resolve().parent.parent / "resources" / "jobs" / "dome-laminate.toml"
    assert win.open_file(job) and not shown
    assert len(win.project.pieces) == 24 and win.project.piece_name == "P01"
    rows = win.pieces_panel.rows()
    assert rows[0] == "1. P01   +0 deg   not solved" and rows[23].startswith("24. P24   ")
