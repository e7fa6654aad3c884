"""Rosettes in the document (issue 41, item 1; flatweave.document.rosettes): a
project's table of tool rosettes, a piece oriented from one. The orientation is
the datum: the weft angle follows it when the seed moves or the rosette turns,
and a weft angle set directly turns the orientation. Each claim is checked
against the geometry itself (the 0 direction put in the tangent plane at the
seed, the weft measured from it), not against the code's own conversion."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from flatweave.document import pieces as P
from flatweave.document.history import Document
from flatweave.document.project import ProjectError, load_project, new_project, project_to_dict, save_project
from flatweave.document.rosettes import ToolRosette, orientation_text
from flatweave.errors import SettingsError
from flatweave.method.rosette import orientation_for, rosette, weft_for
from flatweave.reading.registry import open_path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "resources" / "jobs" / "dome-laminate.toml"
OLD = ROOT / "tests" / "data" / "projects" / "v4-octant-region-solved.flatweave"


@pytest.fixture(scope="module")
def dome_job():
    return open_path(EXAMPLE).project


def _orientation_seen(surface, seed, angle_deg, zero) -> float:
    """The weft's angle at ``seed`` from ``zero`` put in the tangent plane there, about the normal."""
    r = rosette(surface, seed, angle_deg)
    z = np.asarray(zero, dtype=float) - np.dot(zero, r.normal) * r.normal
    z /= np.linalg.norm(z)
    return math.degrees(math.atan2(np.dot(np.cross(z, r.weft), r.normal), np.dot(z, r.weft)))


def _close(a, b, tol=1e-6) -> bool:
    return abs((a - b + 180.0) % 360.0 - 180.0) < tol


def test_a_rosettes_values_are_checked_in_one_line():
    for bad, match in ((("", (0, 0, 0), (1, 0, 0)), "name"), (("r", (0, 0), (1, 0, 0)), "origin"),
                       (("r", (0, 0, 0), (0, 0, 0)), "direction"), (("r", (0, math.nan, 0), (1, 0, 0)), "finite"),
                       (("r", (0, 0, 0), "x"), "three")):
        with pytest.raises(SettingsError, match=match) as exc:
            ToolRosette(*bad)
        assert "\n" not in str(exc.value)
    r = ToolRosette("r", [1, 2, 3], np.array([0.0, 2.0, 0.0]))
    assert r.origin == (1.0, 2.0, 3.0) and r.zero == (0.0, 2.0, 0.0)  # kept as tuples: comparable, hashable


@pytest.mark.parametrize("seed", [(0.5, 0.5), (0.2, 0.7), (0.85, 0.15)])
def test_weft_for_lays_the_weft_at_the_orientation_from_the_projected_zero(dome_job, seed):
    s = dome_job.surface
    zero = (1.0, 0.3, 0.2)
    for orientation in (0.0, 45.0, -45.0, 90.0, 137.5):
        angle = weft_for(s, seed, zero, orientation)
        assert _close(_orientation_seen(s, seed, angle, zero), orientation)
        assert _close(orientation_for(s, seed, zero, angle), orientation, 1e-9)
    r = rosette(s, seed, 0.0)
    assert weft_for(s, seed, r.normal, 0.0) is None  # along the normal: no direction there


def test_the_job_s_plies_are_oriented_from_its_rosette(dome_job):
    assert [r.name for r in dome_job.rosettes] == ["rosette 1"]
    assert dome_job.rosettes[0].zero == (1.0, 0.0, 0.0)
    for k, piece in enumerate(dome_job.pieces):
        assert piece.rosette == "rosette 1" and piece.orientation == [0.0, 45.0, -45.0, 90.0][k % 4]
    assert orientation_text(dome_job.pieces[1]) == "+45 deg from rosette 1"
    assert orientation_text(dome_job.pieces[1], short=True) == "+45"


def test_rosettes_and_orientations_survive_save_and_open(dome_job, tmp_path):
    path = save_project(dome_job, tmp_path / "dome.flatweave")
    doc = json.loads(path.read_text())
    assert doc["rosettes"] == [{"name": "rosette 1", "origin": [0.0, 0.0, 0.0], "zero": [1.0, 0.0, 0.0]}]
    assert doc["pieces"][2]["rosette"] == "rosette 1" and doc["pieces"][2]["orientation"] == -45.0
    back = load_project(path)
    assert back.rosettes == dome_job.rosettes
    for a, b in zip(back.pieces, dome_job.pieces):
        assert (a.rosette, a.orientation, a.settings.angle_deg) == (b.rosette, b.orientation, b.settings.angle_deg)
    # a piece oriented from a rosette the file lacks: one line naming the file
    doc["rosettes"] = []
    bad = tmp_path / "bad.flatweave"
    bad.write_text(json.dumps(doc))
    with pytest.raises(ProjectError, match=r"bad\.flatweave.*'P01'.*rosette 1") as exc:
        load_project(bad)
    assert "\n" not in str(exc.value)


def test_a_project_of_the_older_format_opens_with_no_rosettes():
    project = load_project(OLD)
    assert project.rosettes == () and all(p.rosette is None and p.orientation is None for p in project.pieces)
    assert "rosettes" not in project_to_dict(project)  # and saves as it was: no empty table written
    assert orientation_text(project.pieces[0]) == f"weft {project.settings.angle_deg:+g} deg"


def test_the_weft_follows_the_orientation_and_a_set_weft_turns_it(dome_job):
    doc = Document(P.select(dome_job, "P02"))  # +45
    zero = dome_job.rosettes[0].zero
    # the seed moved (a region redrawn moves it too): the orientation stays, the weft angle follows it
    doc.edit_settings("Move seed", seed=(0.3, 0.65))
    p = doc.project
    assert p.orientation == 45.0
    assert _close(_orientation_seen(p.surface, p.settings.seed, p.settings.angle_deg, zero), 45.0)
    assert not _close(p.settings.angle_deg, dome_job.pieces[1].settings.angle_deg, 1e-3)  # it did change
    # the weft angle set directly (the Seed tool's arrow): the orientation turns with it
    doc.edit_settings("Turn weft", angle_deg=p.settings.angle_deg + 10.0)
    assert _close(doc.project.orientation, 55.0, 1e-6)
    doc.undo()
    assert doc.project.orientation == 45.0


def test_a_rosette_turned_turns_every_ply_oriented_from_it_in_one_edit(dome_job):
    doc = Document(dome_job)
    before = [p.settings.angle_deg for p in dome_job.pieces]
    turned = ToolRosette("rosette 1", (0.0, 0.0, 1.0), (0.0, 1.0, 0.0))  # x to y
    doc.set_rosettes([turned])
    after = doc.project.pieces
    for p, a in zip(after, before):
        assert p.orientation in (0.0, 45.0, -45.0, 90.0)
        assert _close(_orientation_seen(doc.project.surface, p.settings.seed, p.settings.angle_deg, turned.zero),
                      p.orientation)
        assert not _close(p.settings.angle_deg, a, 1.0)
    assert doc.undo_label == "Edit rosettes"
    doc.undo()
    assert [p.settings.angle_deg for p in doc.project.pieces] == before
    with pytest.raises(SettingsError, match="P01.*rosette 1") as exc:  # a rosette in use cannot go
        doc.set_rosettes([])
    assert "\n" not in str(exc.value)
    with pytest.raises(SettingsError, match="two rosettes"):
        doc.set_rosettes([turned, replace(turned, origin=(1.0, 0.0, 0.0))])


def test_a_piece_is_oriented_unoriented_and_duplicated_at_another_orientation(dome_job):
    doc = Document(dome_job)
    doc.orient_piece("P03", None)  # its weft angle alone from now on: the angle stays
    p3 = doc.project.pieces[2]
    assert p3.rosette is None and p3.settings.angle_deg == dome_job.pieces[2].settings.angle_deg
    doc.orient_piece("P03", "rosette 1")  # oriented again, its fibres kept: read back as -45
    assert doc.project.pieces[2].orientation == -45.0
    doc.orient_piece("P03", "rosette 1", 30.0)
    p3 = doc.project.pieces[2]
    assert _close(_orientation_seen(doc.project.surface, p3.settings.seed, p3.settings.angle_deg,
                                    (1.0, 0.0, 0.0)), 30.0)
    doc.duplicate_piece("P02", None, -45.0)  # a tied ply's duplicate angle is its orientation
    copy = doc.project.pieces[2]
    assert (copy.name, copy.orientation, copy.rosette) == ("P02 -45", -45.0, "rosette 1")
    assert _close(_orientation_seen(doc.project.surface, copy.settings.seed, copy.settings.angle_deg,
                                    (1.0, 0.0, 0.0)), -45.0)
    with pytest.raises(SettingsError, match="no rosette is named 'R9'"):
        doc.orient_piece("P01", "R9", 0.0)


def test_a_project_made_new_has_no_rosettes_and_its_pieces_their_weft(dome_job):
    project = new_project(dome_job.surface, name="plain")
    assert project.rosettes == () and project.piece_rosette is None
    with pytest.raises(SettingsError, match="lacks"):
        replace(project, piece_rosette="R", orientation=0.0)
    with pytest.raises(SettingsError, match="orientation"):
        replace(project, piece_rosette="R", orientation=math.inf)
