"""A project holds pieces (issue 41, step 1; flatweave.document.pieces): the
plies of a laminate or the panels of a product on one surface. A file of the
present format opens as a project of one piece, unchanged; pieces are added,
duplicated at another orientation, renamed, reordered, counted and deleted as
undoable edits; the active piece is the one the settings and result are of;
save, open and recovery keep every piece and its result."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from flatweave import FlattenSettings, flatten
from flatweave.files import decode_array
from flatweave.document import pieces as P
from flatweave.document.history import Document
from flatweave.document.project import (PROJECT_VERSION, load_project, new_project, project_problems,
                                        project_to_dict, save_project)
from flatweave.document.recovery import Session, find_orphans
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example

from tests.helpers import assert_refused_in_one_line

OLD = Path(__file__).parent / "data" / "projects"


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module")
def laminate(octant):
    """Three pieces, each solved: "ply 1" at 0 degrees, "ply 2" at +45, "ply 3" at 90 (a smaller region)."""
    p = new_project(octant, "laminate", spacing=0.12)
    p = P.rename(p, 0, "ply 1")
    p = P.duplicate(p, 0, "ply 2", angle_deg=45.0)
    small = replace(p.settings, angle_deg=90.0, spacing=0.15)
    p = P.add(p, "ply 3", settings=small)
    solved = []
    for k, piece in enumerate(p.pieces):
        solved.append(replace(piece, result=flatten(octant, piece.settings), sequence=k + 1))
    return P.with_pieces(p, solved, 1)


def test_a_version_4_project_opens_as_one_piece_unchanged():
    path = OLD / "v4-octant-region-solved.flatweave"
    raw = json.loads(path.read_text())
    assert raw["version"] == 4 and "pieces" not in raw
    p = load_project(path)
    assert len(p.pieces) == 1 and p.piece_name == raw["name"] == "octant" and p.piece_index == 0
    assert (p.quantity, p.sequence, p.others) == (1, None, ())
    assert p.result is not None and p.result_is_current and project_problems(p) == []
    assert p.result.mesh.n_nodes == raw["result"]["metrics"]["nodes"] == 92
    np.testing.assert_allclose(p.result.pattern.xy, raw["result"]["nodes"]["xy"], atol=1e-9)
    assert p.region_name == "region" and [c.name for c in p.candidates] == ["circle"]
    assert [d.name for d in p.settings.darts] == ["side"] and p.units == "cm"
    # saved again: version 6, the one piece holding what the old file held at its top, on the one source
    doc = project_to_dict(p)
    assert doc["version"] == PROJECT_VERSION >= 7 and doc["current"] == 0 and len(doc["pieces"]) == 1
    piece = doc["pieces"][0]
    assert piece["settings"] == raw["settings"] and piece["darts"] == raw["darts"]
    assert piece["candidates"] == raw["candidates"]
    for key in ("ij", "uv"):  # the result kept as what rebuilds it, its arrays encoded: the same values
        np.testing.assert_array_equal(decode_array(piece["result"]["nodes"][key], key), raw["result"]["nodes"][key])
    assert "settings" not in doc and "result" not in doc and "surface" not in doc
    assert doc["sources"] == [{"source": raw["source"], "surface": raw["surface"]}] and piece["source"] == 0


@pytest.mark.parametrize("name", ["v1-octant-solved", "v2-octant-yarn-solved", "v3-octant-dart-solved"])
def test_every_older_version_opens_as_one_piece(name):
    p = load_project(OLD / f"{name}.flatweave")
    assert len(p.pieces) == 1 and p.pieces[0].name == p.name and p.result_is_current


def test_pieces_are_added_duplicated_at_an_angle_renamed_moved_and_deleted(octant):
    p = new_project(octant, "tool", spacing=0.1)
    assert [x.name for x in p.pieces] == ["tool"]
    p = P.duplicate(p, 0, angle_deg=45.0)
    p = P.duplicate(p, "tool", angle_deg=-45.0)
    p = P.duplicate(p, 0, angle_deg=90.0)
    # each copy after its original, made active, at its angle
    assert [x.name for x in p.pieces] == ["tool", "tool +90", "tool -45", "tool +45"]
    assert [x.settings.angle_deg for x in p.pieces] == [0.0, 90.0, -45.0, 45.0]
    assert p.piece_name == "tool +90" and p.settings.angle_deg == 90.0 and p.piece_index == 1
    p = P.move(p, 1, 3)  # the active piece moves and stays active
    assert [x.name for x in p.pieces] == ["tool", "tool -45", "tool +45", "tool +90"] and p.piece_name == "tool +90"
    p = P.add(p)
    assert p.piece_name == "piece 5" and p.settings.darts == () and p.result is None
    p = P.rename(p, "piece 5", "cuff")
    p = P.set_quantity(P.set_sequence(p, "cuff", 3), "cuff", 2)
    assert (p.piece_name, p.sequence, p.quantity) == ("cuff", 3, 2)
    p = P.remove(p, "cuff")  # the active one gone: its neighbour (the last) active
    assert p.piece_name == "tool +90" and len(p.pieces) == 4
    p = P.select(p, 0)
    q = P.remove(p, 2)  # another one gone: the active stays
    assert q.piece_name == "tool" and [x.name for x in q.pieces] == ["tool", "tool -45", "tool +90"]


@pytest.mark.parametrize("edit, says", [
    (lambda p: P.rename(p, 1, "Tool"), "two pieces are named 'Tool'"),
    (lambda p: P.rename(p, 1, " "), "a piece's name must be"),
    (lambda p: P.rename(p, 1, "x" * 81), "a piece's name must be"),
    (lambda p: P.set_quantity(p, 0, 0), "quantity must be a whole number from 1"),
    (lambda p: P.set_quantity(p, 0, 2.5), "quantity must be a whole number from 1"),
    (lambda p: P.set_sequence(p, 0, -1), "sequence must be a whole number from 1"),
    (lambda p: P.select(p, 5), "no piece 5"),
    (lambda p: P.select(p, "sleeve"), "no piece is named 'sleeve'"),
    (lambda p: P.move(p, 0, 2), "no position 2"),
    (lambda p: P.duplicate(p, 0, angle_deg=float("nan")), "finite angle"),
    (lambda p: P.remove(P.remove(p, 1), 0), "at least one piece"),
])
def test_bad_piece_edits_are_one_line(octant, edit, says):
    p = P.duplicate(new_project(octant, "tool", spacing=0.1), 0, angle_deg=45.0)
    with pytest.raises(SettingsError, match=says) as exc:
        edit(p)
    assert "\n" not in str(exc.value)


def test_save_and_open_keep_every_piece_and_its_result(laminate, tmp_path):
    p = load_project(save_project(laminate, tmp_path / "lam.flatweave"))
    assert [x.name for x in p.pieces] == ["ply 1", "ply 2", "ply 3"] and p.piece_name == "ply 2"
    assert [x.sequence for x in p.pieces] == [1, 2, 3]
    assert [x.settings.angle_deg for x in p.pieces] == [0.0, 45.0, 90.0]
    for a, b in zip(laminate.pieces, p.pieces):
        assert b.result is not None and b.result.surface is p.surface
        np.testing.assert_array_equal(a.result.pattern.xy, b.result.pattern.xy)
        assert a.result.metrics["energy"] == b.result.metrics["energy"]
    assert p.result_is_current and project_problems(p) == []
    assert project_to_dict(p) == project_to_dict(laminate)  # bit for bit
    # the other pieces' results are current for their own settings too
    for k in range(3):
        q = P.select(p, k)
        assert q.result_is_current and project_problems(q) == []


def test_recovery_keeps_every_piece(laminate, tmp_path):
    session = Session(tmp_path)
    p = load_project(session.write(laminate))
    assert [x.name for x in p.pieces] == ["ply 1", "ply 2", "ply 3"] and p.piece_name == "ply 2"
    assert all(x.result is not None for x in p.pieces)
    session.close()
    assert not find_orphans(tmp_path)


def test_piece_edits_are_undoable_and_a_selection_is_not_an_undo_step(octant):
    doc = Document(new_project(octant, "tool", spacing=0.1))
    seen = []
    doc.subscribe(lambda project, change: seen.append(change))
    doc.duplicate_piece(0, angle_deg=45.0)
    assert doc.project.piece_name == "tool +45" and "pieces" in seen[-1].aspects
    doc.edit_settings("Spacing", spacing=0.08)  # an edit of the active piece: "tool +45"
    assert doc.select_piece("tool").cause == "select" and doc.project.settings.spacing == 0.1
    assert doc.select_piece("tool") is None  # already active
    doc.undo()  # the spacing edit, on the piece it was made on, made active again
    assert doc.project.piece_name == "tool +45" and doc.project.settings.spacing == 0.1
    doc.undo()  # the duplicate
    assert [x.name for x in doc.project.pieces] == ["tool"]
    doc.redo()
    doc.redo()
    assert doc.project.piece_name == "tool +45" and doc.project.settings.spacing == 0.08
    doc.rename_piece(1, "  bias   ply ")
    assert doc.project.pieces[1].name == "bias ply"
    doc.set_piece_quantity(1, 4)
    doc.move_piece(1, 0)
    assert [x.name for x in doc.project.pieces] == ["bias ply", "tool"] and doc.project.quantity == 4
    doc.remove_piece("tool")
    assert [x.name for x in doc.project.pieces] == ["bias ply"]
    with pytest.raises(SettingsError, match="at least one piece"):
        doc.remove_piece(0)


def test_a_result_goes_only_to_the_piece_it_was_solved_for(octant):
    """Two pieces of the same settings: a solve started on one is not attached once the other is active."""
    doc = Document(new_project(octant, "tool", spacing=0.15))
    doc.duplicate_piece(0, name="twin")
    source = doc.project  # "twin" active
    result = flatten(octant, source.settings)
    doc.select_piece("tool")
    assert not doc.attach_result(result, source) and doc.project.result is None
    doc.select_piece("twin")
    assert doc.attach_result(result, source) and doc.project.result is result


@pytest.mark.parametrize("damage, says", [
    (lambda d: d.update(pieces=[]), "pieces must be a list of 1 to"),
    (lambda d: d.update(pieces={}), "pieces must be a list of 1 to"),
    (lambda d: d.update(current=3), "current is 3, but the project has 1 pieces"),
    (lambda d: d.update(current="0"), "current"),
    (lambda d: d["pieces"].append(dict(d["pieces"][0])), "two pieces are named"),
    (lambda d: d["pieces"][0].update(quantity=0), "quantity must be a whole number"),
    (lambda d: d["pieces"][0].update(name=7), r"pieces\[0\].name must be a string"),
    (lambda d: d["pieces"][0].pop("settings"), "settings"),
])
def test_a_damaged_pieces_list_is_refused_in_one_line(octant, tmp_path, damage, says):
    doc = project_to_dict(new_project(octant, "tool", spacing=0.1))
    damage(doc)
    assert_refused_in_one_line(doc, tmp_path, says)


def test_a_new_project_is_one_piece_named_after_it(octant):
    p = new_project(octant, "hood", spacing=0.1)
    assert p.piece_name == "hood" and p.pieces[0].settings is p.settings
    assert FlattenSettings is type(p.pieces[0].settings)


def test_results_of_several_pieces_attach_as_one_edit_to_the_settings_they_were_made_from(octant):
    doc = Document(new_project(octant, "tool", spacing=0.15))
    doc.duplicate_piece(0, angle_deg=45.0)
    doc.duplicate_piece(0, angle_deg=90.0)
    source = doc.project
    results = {p.name: flatten(octant, p.settings) for p in source.pieces}
    doc.rename_piece("tool +90", "ninety")  # renamed meanwhile: its settings are the ones solved
    doc.select_piece("tool +45")
    doc.edit_settings("Spacing", spacing=0.2)  # edited meanwhile: its result answers nothing now
    n = len(doc.history)
    taken = doc.attach_results(results, source)
    assert taken == ["tool", "ninety"] and len(doc.history) == n + 1
    p = doc.project
    assert [x.name for x in p.pieces] == ["tool", "ninety", "tool +45"]  # each copy after its original
    assert [x.result is not None for x in p.pieces] == [True, True, False]
    assert p.pieces[0].result is results["tool"] and p.pieces[1].result is results["tool +90"]
    doc.undo()
    assert [x.result for x in doc.project.pieces] == [None, None, None]
    assert doc.attach_results({}, source) == [] and doc.attach_results(results, doc.project) == ["tool", "ninety"]


def test_a_material_chosen_from_the_table_brings_its_shear_angles_to_the_display(octant):
    """The colours and verdicts judge the active piece's cloth: choosing the glass twill (20 / 40 deg)
    for the active piece moves the display's angles with it in the same edit; a piece not active
    leaves them, and undo puts them back."""
    doc = Document(new_project(octant, "tool", spacing=0.15))
    doc.set_materials(doc.project.materials)  # the presets' table (no edit when it is already)
    assert (doc.project.shear_warning_deg, doc.project.shear_limit_deg) == (15.0, 30.0)
    doc.duplicate_piece(0, angle_deg=45.0)
    doc.use_material(0, "glass twill 290")  # not the active piece: the display stays
    assert doc.project.pieces[0].settings.material.name == "glass twill 290"
    assert (doc.project.shear_warning_deg, doc.project.shear_limit_deg) == (15.0, 30.0)
    n = len(doc.history)
    doc.use_material(1, "glass twill 290")  # the active one
    assert len(doc.history) == n + 1
    assert (doc.project.shear_warning_deg, doc.project.shear_limit_deg) == (20.0, 40.0)
    doc.undo()
    assert (doc.project.shear_warning_deg, doc.project.shear_limit_deg) == (15.0, 30.0)
