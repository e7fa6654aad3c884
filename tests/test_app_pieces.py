"""The window's Pieces tab (issue 41, step 3; flatweave.app.piecespanel): the
project's pieces listed with their state, a row selected makes that piece the
active one (the settings, views and result are then its own), and Add,
Duplicate at an angle, rename, Up, Down and Delete are undoable edits that
save and reopen with the project."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader

from tests.test_app_run import run_to_end

JOB = Path(__file__).resolve().parent.parent / "resources" / "jobs" / "dome-laminate.toml"

pytestmark = pytest.mark.slow


def test_plies_are_duplicated_at_angles_selected_renamed_moved_deleted_and_saved(make_window, qtbot, tmp_path):
    win = make_window(example="octant")
    shown = []
    win.show_error = shown.append
    panel = win.pieces_panel
    assert panel.rows() == ["octant   weft +0 deg   not solved"] and not panel.delete.isEnabled()
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
    row = other.pieces_panel.rows()[1]
    assert row.startswith("octant +45   weft +45 deg   ") and "%" in row
    assert other.pieces_panel.rows()[2] == "ply 90   weft +90 deg   not solved"
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
    assert win.metrics.text("boundary") == f"{p.result.metrics['boundary_error_pct']:.3f} %"  # shown at once
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


def _direction(polyline) -> np.ndarray:
    """An arrow's shaft direction: its tip (the second point) from its foot."""
    d = np.asarray(polyline[1]) - np.asarray(polyline[0])
    return d / np.linalg.norm(d)


def test_a_ply_is_shown_with_its_rosette_among_the_others_and_oriented_in_the_panel(make_window):
    """The job's plies: the active one's weft, warp and rosette 0-degree direction at its seed, the other
    23 plies' outlines faint; the Rosette and orientation boxes orient it as undoable edits."""
    win = make_window(example=None)
    shown = []
    win.show_error = shown.append
    assert win.open_file(JOB) and not shown
    panel, view = win.pieces_panel, win.view
    assert panel.rosette.currentText() == "rosette 1" and panel.orientation.value() == 0.0
    assert panel.orientation.isEnabled()
    others = view.layer_lines("other pieces")
    assert len(others) > 23 * 8  # 23 closed outlines, each sampled along its image on the tool
    weft, zero = view.layer_lines("piece weft"), view.layer_lines("piece zero")
    assert len(weft) == 5 and len(zero) == 5  # a shaft and a head each
    shaft = np.linalg.norm(np.asarray(weft[1]) - np.asarray(weft[0]))
    # both at the seed: the feet differ only by the hair each arrow is lifted off the surface (1 % of its length)
    assert np.linalg.norm(np.asarray(weft[0]) - np.asarray(zero[0])) < 0.01 * shaft
    assert _direction(weft) @ _direction(zero) > 1 - 1e-9  # P01 is at 0 degrees: its weft is the 0 direction

    panel.list.setCurrentRow(1)  # P02, +45: the weft 45 degrees from the 0 direction, which is drawn too
    weft, zero = view.layer_lines("piece weft"), view.layer_lines("piece zero")
    assert abs(np.degrees(np.arccos(_direction(weft) @ _direction(zero))) - 45.0) < 1e-6
    assert panel.orientation.value() == 45.0

    before = win.project.settings.angle_deg
    panel.set_orientation(90.0)  # what the orientation box asks when a value is entered
    assert win.project.orientation == 90.0 and win.project.piece_name == "P02"
    assert abs((win.project.settings.angle_deg - before - 45.0 + 180.0) % 360.0 - 180.0) < 1e-6
    assert panel.rows()[1] == "2. P02   +90 deg   not solved"
    weft, zero = view.layer_lines("piece weft"), view.layer_lines("piece zero")
    assert abs(_direction(weft) @ _direction(zero)) < 1e-9

    panel.choose_rosette(None)  # laid by its weft angle alone: the angle stays, no 0 direction drawn
    assert win.project.piece_rosette is None and panel.rows()[1].startswith("2. P02   weft ")
    assert not panel.orientation.isEnabled() and len(view.layer_lines("piece zero")) == 0
    win.undo()
    win.undo()
    assert win.project.orientation == 45.0 and win.project.settings.angle_deg == before

    # the rosette's 0-degree direction turned in the Rosettes dialog turns every ply tied to it, as one edit
    angles = [p.settings.angle_deg for p in win.project.pieces]
    dialog = panel.open_rosettes()
    assert dialog is not None and dialog.problem() == ""
    dialog.edit_cell(0, "dx", "0")
    dialog.edit_cell(0, "dy", "1")
    assert dialog.problem() == ""
    dialog.accept()
    assert win.project.rosettes[0].zero == (0.0, 1.0, 0.0) and not shown
    turned = [p.settings.angle_deg for p in win.project.pieces]
    assert sum(abs((a - b + 180.0) % 360.0 - 180.0) > 1.0 for a, b in zip(angles, turned)) == 24
    assert [p.orientation for p in win.project.pieces][:3] == [0.0, 45.0, -45.0]  # orientations are the datum
    win.undo()
    assert [p.settings.angle_deg for p in win.project.pieces] == angles


def test_pieces_of_another_file_join_the_project_on_their_own_surface(make_window, qtbot, tmp_path):
    """Pieces > Add > from a file: the half cylinder's piece joins the octant's on its own surface (one
    undoable edit, nothing asked: nothing is replaced); selecting a piece shows its surface; Solve all
    solves each on its own; saved and reopened, the project holds two sources."""
    from flatweave import flatten
    from flatweave.document.pieces import sources_of
    from flatweave.reading.examples import example_path

    win = make_window(example="octant")
    shown = []
    win.show_error = shown.append
    octant = win.project.surface
    octant_view = win.view.surface_points.copy()
    win.files.may_replace = lambda doing: pytest.fail(f"asked about unsaved work while {doing}")
    assert win.files.open_file(example_path("half_cylinder"), add=True) and not shown
    p = win.project
    assert [x.name for x in p.pieces] == ["octant", "half_cylinder"] and p.piece_name == "half_cylinder"
    assert p.surface is not octant and p.pieces[0].surface is octant and len(sources_of(p)) == 2
    assert win.pieces_panel.rows()[1].startswith("half_cylinder   weft +0 deg")
    cyl_view = win.view.surface_points
    assert cyl_view is not None and (cyl_view.shape != octant_view.shape or not np.allclose(cyl_view, octant_view))
    assert len(win.view.layer_lines("other pieces")) == 0  # the octant's piece is not on this surface
    win.undo()  # the addition is one step
    assert len(win.project.pieces) == 1 and win.project.surface is octant
    win.redo()
    assert [x.name for x in win.project.pieces] == ["octant", "half_cylinder"]

    with qtbot.waitSignal(win.solve_all.finished, timeout=120000):
        win.pieces_panel.solve_button.click()
    for piece in win.project.pieces:
        alone = flatten(piece.surface, piece.settings)
        assert piece.result is not None and (piece.result.pattern.xy == alone.pattern.xy).all()
    # the active piece's result is shown at once, as a run's is (it was drawn only on reselecting)
    m = win.project.result.metrics
    assert win.metrics.text("boundary") == f"{m['boundary_error_pct']:.3f} %"
    win.pieces_panel.list.setCurrentRow(0)
    assert win.project.surface is octant and win.project.result_is_current
    assert np.allclose(win.view.surface_points, octant_view)

    path = tmp_path / "two.flatweave"
    assert win.files.save_to(path) and not shown
    del win.files.may_replace
    assert win.open_file(path) and not shown
    back = win.project
    assert len(sources_of(back)) == 2 and back.pieces[1].surface is not back.pieces[0].surface
    assert all(x.result is not None and x.result.surface is x.surface for x in back.pieces)
