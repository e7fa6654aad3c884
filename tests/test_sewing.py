"""Seams kept in the project (issue 42): a piece split into panels that are pieces, a seam edit
re-splitting only the panels it touches, the file's ``sewings``, the cut files' notches and seam
allowances per seam, the ply book's seam table."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path

import ezdxf
import numpy as np
import pytest
from pypdf import PdfReader

from flatweave.document import pieces as P
from flatweave.document import sewing as S
from flatweave.document.checks import project_checks, seam_rows
from flatweave.document.cutfiles import export_pieces
from flatweave.document.history import Document
from flatweave.document.plybook import plybook_bytes
from flatweave.document.project import (PROJECT_VERSION, load_project, new_project, project_to_dict,
                                        save_project, settings_equal)
from flatweave.document.solving import solve_pieces
from flatweave.errors import SettingsError
from flatweave.export.registry import ExportOptions
from flatweave.geometry.numerics import polyline_distance
from flatweave.geometry.region import cover_for
from flatweave.method.seams import flat_sew_line
from flatweave.reading.examples import example_path, load_example

from tests.helpers import assert_refused_in_one_line

OLD = Path(__file__).parent / "data" / "projects"
LENGTH = 1.5  # the bundled half cylinder: its generators


def _generator(u: float, name: str) -> S.SeamLine:
    """A seam along the half cylinder's generator at u, drawn a little past both rims."""
    return S.SeamLine(name, np.array([[u, -0.05], [u, 1.05]]))


@pytest.fixture(scope="module")
def cylinder():
    return load_example("half_cylinder")


@pytest.fixture(scope="module")
def three(cylinder):
    """The half cylinder split by two generators into three panels, solved."""
    p = new_project(cylinder, "sleeve", str(example_path("half_cylinder")), spacing=0.06)
    p = S.add_seam(p, _generator(1 / 3, "left"))
    p = S.add_seam(p, _generator(2 / 3, "right"))
    solved, outcomes = solve_pieces(p, workers=1)
    assert [o.error for o in outcomes] == ["", "", ""]
    return solved


def test_the_first_seam_splits_the_piece_into_panels_that_replace_it(cylinder):
    p = new_project(cylinder, "sleeve", None, spacing=0.06)
    one = S.add_seam(p, _generator(0.4, "side"))
    assert [q.name for q in one.pieces] == ["panel 1", "panel 2"]
    (sewing,) = one.sewings
    assert sewing.name == "sleeve" and sewing.panels == ("panel 1", "panel 2") and sewing.region is None
    # the panels tile the piece: their (u, v) areas are 0.4 and 0.6 of the unit domain
    areas = [cover_for(cylinder, q.settings.region).polygon.area for q in one.pieces]
    np.testing.assert_allclose(areas, [0.4, 0.6], atol=1e-12)
    for q in one.pieces:  # each seeded well inside its own region
        cover = cover_for(cylinder, q.settings.region)
        assert cover.contains(cover.seed_uv(q.settings.seed)).all()
    with pytest.raises(SettingsError, match="is a panel already"):
        S.sew(one, "panel 1", [_generator(0.2, "x")])


def test_each_sew_line_of_a_developable_shape_has_equal_sides(three):
    rows = seam_rows(three)
    assert [(r.name, r.panels) for r in rows] == [("left", ("panel 1", "panel 3")), ("right", ("panel 3", "panel 2"))]
    for r in rows:
        assert r.solved and r.lengths[0] == pytest.approx(LENGTH, rel=1e-5)
        assert r.difference_pct < 0.01  # the target on a developable surface
    assert project_checks(three) == []


def test_a_seam_moved_re_solves_only_the_panels_it_touches(three):
    before = {q.name: q for q in three.pieces}
    moved = S.replace_seam(three, "sleeve", "right", _generator(0.75, "right"))
    after = {q.name: q for q in moved.pieces}
    assert set(after) == set(before)
    # left of the seam that did not move: as it was, solved (the active piece is made afresh at each read: its fields)
    kept, was = after["panel 1"], before["panel 1"]
    assert kept.settings is was.settings and kept.result is was.result
    assert settings_equal(after["panel 1"].result.settings, after["panel 1"].settings)
    for name in ("panel 2", "panel 3"):  # either side of the moved seam: new regions, results stale
        q = after[name]
        assert q.settings.region != before[name].settings.region
        assert not settings_equal(q.result.settings, q.settings)
        assert q.settings.spacing == before[name].settings.spacing  # its own settings kept
    # the middle panel changed: neither seam's sides are both solved until a solve answers the edit
    assert [r.solved for r in seam_rows(moved)] == [False, False]
    again, _ = solve_pieces(moved, pieces=["panel 2", "panel 3"], workers=1)
    assert all(r.solved and r.difference_pct < 0.01 for r in seam_rows(again))


def test_a_panels_own_settings_survive_a_re_split(three):
    p = P._changed(three, "panel 2", lambda q: replace(q, settings=replace(q.settings, angle_deg=30.0)))
    moved = S.replace_seam(p, "sleeve", "right", _generator(0.7, "right"))
    assert next(q for q in moved.pieces if q.name == "panel 2").settings.angle_deg == 30.0


def test_removing_a_seam_joins_its_panels_and_the_last_leaves_one_panel(three):
    joined = S.remove_seam(three, "sleeve", "left")
    assert len(joined.pieces) == 2 and len(joined.sewings[0].seams) == 1
    none = S.remove_seam(joined, "sleeve", 0)
    assert len(none.pieces) == 1 and none.sewings[0].seams == ()
    assert cover_for(none.surface, none.settings.region).polygon.area == pytest.approx(1.0, abs=1e-12)


def test_names_and_options_are_labels_and_renaming_a_panel_renames_it_in_its_shape(three):
    relabelled = S.edit_seam(three, "sleeve", "left", name="front", allowance_mm=15.0, notches=((1 / 3, 0.5),))
    # nothing re-split, nothing stale
    assert all(a.settings is b.settings and a.result is b.result for a, b in zip(relabelled.pieces, three.pieces))
    assert [r.name for r in seam_rows(relabelled)] == ["front", "right"]
    renamed = P.rename(three, "panel 3", "back")
    assert renamed.sewings[0].panels == ("panel 1", "back", "panel 2")
    assert seam_rows(renamed)[0].panels == ("panel 1", "back")


def test_a_deleted_panel_leaves_its_place_and_its_shape_goes_with_the_last(three):
    p = P.remove(three, "panel 3")
    assert p.sewings[0].panels == ("panel 1", None, "panel 2")
    assert [r.lengths for r in seam_rows(p)] == [(None, None), (None, None)]
    # a seam edit re-splits what is left: the deleted panel's place is taken by a new panel
    moved = S.replace_seam(p, "sleeve", "right", _generator(0.7, "right"))
    assert len(moved.sewings[0].panels) == 3 and None not in moved.sewings[0].panels
    gone = P.remove(P.add(P.remove(p, "panel 1"), "spare"), "panel 2")
    assert gone.sewings == ()  # its last panel deleted: the shape goes


def test_bad_seams_are_refused_in_one_line_and_change_nothing(three, cylinder):
    loop = S.SeamLine("knot", np.array([[0.1, 0.1], [0.3, 0.3], [0.3, 0.1], [0.1, 0.3]]))
    short = S.SeamLine("stub", np.array([[0.1, 0.5], [0.2, 0.5]]))
    sliver = _generator(0.34, "sliver")
    for seam, says in ((loop, "crosses itself"), (short, "does not reach"), (sliver, "cells")):
        with pytest.raises(SettingsError, match=says) as info:
            S.add_seam(three, seam, "panel 1" if seam is not sliver else "panel 3")
        assert "\n" not in str(info.value)
    with pytest.raises(SettingsError, match="allowance"):
        S.SeamLine("x", np.array([[0.0, 0.0], [1.0, 1.0]]), allowance_mm=-1.0)


def test_the_project_file_keeps_the_seams_bit_for_bit(three, tmp_path):
    p = S.edit_seam(three, "sleeve", "left", allowance_mm=12.5, notches=((1 / 3, 0.25),), matched=True)
    path = save_project(p, tmp_path / "sleeve.flatweave")
    doc = json.loads(path.read_text())
    assert doc["version"] == PROJECT_VERSION >= 7
    (entry,) = doc["sewings"]
    assert entry["panels"] == ["panel 1", "panel 3", "panel 2"] and entry["source"] == 0
    assert entry["seams"][0]["allowance_mm"] == 12.5 and entry["seams"][0]["matched"] is True
    back = load_project(path)
    assert project_to_dict(back) == project_to_dict(p)
    assert [r.lengths for r in seam_rows(back)] == [r.lengths for r in seam_rows(p)]


@pytest.mark.parametrize("damage, says", [
    (lambda d: d["sewings"][0]["panels"].pop(), "split it into 3 panels, but it names 2"),
    (lambda d: d["sewings"][0]["panels"].__setitem__(0, "nobody"), "not a piece of the project"),
    (lambda d: d["sewings"][0]["seams"][0].__setitem__("uv", [[0.1, 0.1], [0.3, 0.3], [0.3, 0.1], [0.1, 0.3]]),
     "crosses itself"),
    (lambda d: d["sewings"][0].__setitem__("source", 5), "sources"),
])
def test_a_damaged_sewing_is_named_in_one_line(three, tmp_path, damage, says):
    doc = project_to_dict(three)
    damage(doc)
    assert_refused_in_one_line(doc, tmp_path, says)


def test_a_version_6_project_opens_with_no_seams():
    p = load_project(OLD / "v6-kit-two-sources-solved.flatweave")
    assert p.sewings == () and [q.name for q in p.pieces] == ["cap", "cap +45", "side"]
    assert p.pieces[0].result is not None and p.pieces[2].result is not None and p.pieces[1].result is None


def test_a_seam_drawn_through_the_document_is_one_undo_step(cylinder):
    doc = Document(new_project(cylinder, "sleeve", None, spacing=0.06))
    original = doc.project
    seen = []
    doc.subscribe(lambda project, change: seen.append(change.aspects))
    doc.add_seam(_generator(0.5, "middle"))
    assert "seams" in seen[-1] and "pieces" in seen[-1] and len(doc.project.pieces) == 2
    doc.edit_seam("sleeve", "middle", label="Rename seam", name="centre back")
    assert seen[-1] == frozenset({"seams"})
    doc.undo()
    doc.undo()
    assert doc.project is original


def _dxf_notches(path: Path) -> dict:
    """Per block (a piece), its notch slits on the ASTM notch layer 4, as (2, 2) arrays."""
    dxf = ezdxf.readfile(path)
    out = {}
    for block in dxf.blocks:
        slits = [np.array([[e.dxf.start.x, e.dxf.start.y], [e.dxf.end.x, e.dxf.end.y]])
                 for e in block if e.dxftype() == "LINE" and e.dxf.layer == "4"]
        if slits:
            out[block.name] = slits
    return out


def test_the_cut_files_notch_both_sides_of_each_seam_and_take_its_own_allowance(three, tmp_path):
    p = S.edit_seam(three, "sleeve", "left", allowance_mm=25.0, notches=((1 / 3, 0.5),))
    written, left = export_pieces(p, tmp_path / "cut", formats=(".dxf",),
                                  options=ExportOptions(seam_allowance_mm=10.0), notch_every_mm=500.0)
    assert left == []
    notches = _dxf_notches(written[0])
    counts = {name: len(v) for name, v in notches.items()}
    # panel 1 has one sew line ("left": its 2 ends, the 500 mm marks at 500 and 1000, and the user's at the
    # middle, 750 mm), panel 2 one ("right": ends and two marks); the middle panel both
    assert sorted(counts.values()) == [4, 5, 9], counts
    # the allowance along "left" is 25 mm on both its panels, 10 mm elsewhere (the sheet's cut line)
    sewing = p.sewings[0]
    left_line = next(line for line in S.split_of(sewing).sews if line.seam == "left")
    for name in ("panel 1", "panel 3"):
        piece = next(q for q in p.pieces if q.name == name)
        sheet = S.piece_sheet(p, name, 10.0)
        (sp,) = sheet.pieces
        flat = flat_sew_line(piece.result, left_line.uv) * 1000.0 + sp.offset
        inner = flat[len(flat) // 4: 3 * len(flat) // 4]  # away from the corners
        d = polyline_distance(inner, np.vstack([sp.cut, sp.cut[:1]]))
        np.testing.assert_allclose(d, 25.0, atol=0.05)
        far = sp.sew[polyline_distance(sp.sew, flat) > 50.0]  # the rest of its outline: the default 10 mm
        np.testing.assert_allclose(polyline_distance(far, np.vstack([sp.cut, sp.cut[:1]])), 10.0, atol=0.05)


def test_the_ply_book_lists_the_seams_with_their_lengths(three):
    pdf = PdfReader(io.BytesIO(plybook_bytes(three)))
    text = pdf.pages[0].extract_text()
    assert "Seams: sew lines matched" in text
    for r in seam_rows(three):
        assert r.name in text and f"{r.lengths[0] * 1000:.1f}" in text


def test_a_shapes_seams_follow_its_panels_when_added_to_a_project_or_refitted(three, cylinder):
    """Adding another project's panels brings their shape (its panels renamed as they are); a refit of
    the surface (the same (u, v) map: a mesh fitted again) moves the shape with its panels."""
    other = new_project(load_example("octant"), "cap", None, spacing=0.1)
    both = P.add_from(other, three)
    assert [s.name for s in both.sewings] == ["sleeve"]
    assert set(both.sewings[0].panels) <= {p.name for p in both.pieces}
    again = P.add_from(both, three)  # its pieces' names taken: numbered, and its shape names them so
    (first, second) = again.sewings
    assert second.name == "sleeve 2" and not set(first.panels) & set(second.panels)
    assert all(again.pieces[P.index_of(again, n)].surface is second.surface for n in second.panels)
    refit = load_example("half_cylinder")  # another object, the same surface
    moved = P.resurface(three, three.surface, refit)
    assert moved.sewings[0].surface is refit and all(p.surface is refit for p in moved.pieces)
    assert [r.lengths for r in seam_rows(moved)] == [(None, None)] * 2  # the results were the old surface's


@pytest.mark.parametrize("spec, says", [
    ({"uv": [[0.5, -0.1], [0.5, 1.1]], "notches": [[0.7, 0.5]]}, "lies off the seam"),
    ({"uv": [[0.5, -0.1], [0.5, 1.1]], "allowance_mm": "wide"}, "seam allowance"),
    ({"uv": [[0.5, -0.1], [0.5, 1.1]], "matched": "yes"}, "true or false"),
    ({"uv": [[0.5, -0.1], [0.5, 1.1]], "stitch": 3}, "unknown key 'stitch'"),
])
def test_a_seam_files_options_are_checked_in_one_line(cylinder, spec, says):
    with pytest.raises(SettingsError, match=says) as info:
        S.seam_line_from_spec(cylinder, spec, "seam 1")
    assert "\n" not in str(info.value)
    good = S.seam_line_from_spec(cylinder, {"uv": [[0.5, -0.1], [0.5, 1.1]], "notches": [[0.5005, 0.5]],
                                            "allowance_mm": 12, "matched": True}, "seam 1")
    assert good.notches == ((0.5005, 0.5),) and good.allowance_mm == 12 and good.matched
