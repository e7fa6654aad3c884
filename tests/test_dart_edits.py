"""The core side of the interactive tools: curve darts through drawn
points, their labels in the project file, the document's dart and yarn edits,
and the yarn's default plane and its turning angle. No Qt."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from flatweave.method.darts import CurveDart, PlaneDart, curve_dart_through, dart_handles
from flatweave.document.history import Document, changed_aspects, unique_name
from flatweave.method.energy import YarnConstraint, turn_plane, yarn_index, yarn_nodes, yarn_plane
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.document.project import (Project, ProjectError, labels_equal, load_project, project_to_dict,
                                        save_project, settings_equal)

VIEW = -np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)  # from a camera on the octant's diagonal, into the scene
HANDLES = np.array([[0.2, 0.1], [0.45, 0.45], [0.6, 0.85]])


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module")
def solved(octant):
    s = FlattenSettings(spacing=0.1)
    return Project(octant, s, name="octant", result=flatten(octant, s))


def _distance(p, line):
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(axis=1) / (ab * ab).sum(axis=1), 0, 1)
    return float(np.linalg.norm(a + t[:, None] * ab - p, axis=1).min())


# ---------------------------------------------------------------------- curve darts through points
def test_curve_dart_through_its_points(octant):
    d = curve_dart_through(octant, HANDLES, VIEW * 3.0, name="front")
    np.testing.assert_array_equal(d.handles, HANDLES)
    np.testing.assert_allclose(d.view_dir, VIEW)  # stored as a unit vector
    assert d.name == "front" and d.visible
    curve = octant.points(d.uv)
    for p in octant.points(HANDLES):
        assert _distance(p, curve) < 1e-3
    # between the points it is the chords projected along the view: each curve point
    # lies on a line along VIEW through a chord of consecutive points (checked in the
    # view plane: the curve's trace is the drawn polyline's trace, to the biarc fit's
    # tolerance, 1/1000 of the parameter domain, which the octant stretches up to pi/2 times)
    E = np.linalg.svd(np.eye(3) - np.outer(VIEW, VIEW))[0][:, :2].T
    trace, drawn = curve @ E.T, octant.points(HANDLES) @ E.T
    assert max(_distance(q, drawn) for q in trace) < 1e-3 * np.pi / 2 + 1e-3


def test_a_point_hidden_from_the_view_is_refused():
    s = load_example("half_cylinder")  # axis along y, radius 0.5, z >= 0
    seen = np.array([[0.25, 0.2], [0.4, 0.5]])  # x < 0: facing a camera on the -x side
    d = curve_dart_through(s, seen, (1.0, 0.0, 0.0))
    assert len(d.uv) > 2
    behind = np.array([[0.25, 0.2], [0.75, 0.8]])  # the second point is behind the near side
    with pytest.raises(SettingsError, match="point 2 is hidden"):
        curve_dart_through(s, behind, (1.0, 0.0, 0.0))
    with pytest.raises(SettingsError, match="two different points"):
        curve_dart_through(s, np.array([[0.3, 0.3], [0.3, 0.3]]), (1.0, 0.0, 0.0))


def test_handles_of_a_dart_without_drawn_points(octant):
    plain = CurveDart(np.column_stack([np.linspace(0.1, 0.9, 40), np.full(40, 0.5)]))
    h = dart_handles(octant, plain)
    assert h.shape == (5, 2)
    np.testing.assert_allclose(h[[0, -1]], plain.uv[[0, -1]])
    steps = np.linalg.norm(np.diff(octant.points(h), axis=0), axis=1)
    np.testing.assert_allclose(steps, steps.mean(), rtol=0.02)  # evenly spaced on the surface
    drawn = curve_dart_through(octant, HANDLES, VIEW)
    np.testing.assert_array_equal(dart_handles(octant, drawn), HANDLES)


def test_bad_dart_labels_are_refused():
    with pytest.raises(SettingsError, match="handles"):
        CurveDart(np.zeros((2, 2)) + [[0, 0], [1, 1]], handles=np.zeros((1, 2)))
    with pytest.raises(SettingsError, match="view direction"):
        CurveDart(np.array([[0.0, 0.0], [1.0, 1.0]]), view_dir=(0.0, 0.0, 0.0))
    with pytest.raises(SettingsError, match="true or false"):
        PlaneDart((1.0, 0.0, 0.0, 0.0), visible="no")


# ---------------------------------------------------------------------- labels and the project file
def test_labels_never_stale_a_result(solved, octant):
    d = curve_dart_through(octant, HANDLES, VIEW, name="a")
    s = replace(solved.settings, darts=(d,))
    for label in (dict(name="b"), dict(visible=False), dict(handles=HANDLES[::-1]), dict(view_dir=(0, 0, -1))):
        t = replace(s, darts=(replace(d, **label),))
        assert settings_equal(s, t) and not labels_equal(s, t), label
    moved = replace(s, darts=(replace(d, uv=d.uv + 0.01),))
    assert not settings_equal(s, moved)
    old = replace(solved, settings=s)
    new = replace(solved, settings=replace(s, darts=(replace(d, name="b"),)))
    assert changed_aspects(old, new) == {"labels"}


def test_darts_with_labels_round_trip_and_old_files_read(solved, octant, tmp_path):
    darts = (curve_dart_through(octant, HANDLES, VIEW, name="front", visible=False),
             PlaneDart((0.0, 1.0, 0.0, -0.5), (0.0, 1.0, 0.0, 1.0, 0.0, 0.5), name="side"),
             CurveDart(np.array([[0.1, 0.9], [0.3, 0.7]]), name="from a file"))
    p = replace(solved, settings=replace(solved.settings, darts=darts), result=None)
    back = load_project(save_project(p, tmp_path / "a.flatweave"))
    assert project_to_dict(back) == project_to_dict(p)
    b = back.settings.darts
    assert [d.name for d in b] == ["front", "side", "from a file"] and [d.visible for d in b] == [False, True, True]
    np.testing.assert_array_equal(b[0].handles, HANDLES)
    assert b[0].view_dir == darts[0].view_dir and b[2].handles is None and b[2].view_dir is None
    # a version-1 file written before darts had these keys still opens: visible, no drawn points
    doc = json.loads((tmp_path / "a.flatweave").read_text())
    for item in doc["pieces"][0]["darts"]:
        for key in ("visible", "handles", "view_dir"):
            item.pop(key, None)
    (tmp_path / "old.flatweave").write_text(json.dumps(doc))
    old = load_project(tmp_path / "old.flatweave")
    assert all(d.visible for d in old.settings.darts) and old.settings.darts[0].handles is None
    assert settings_equal(old.settings, p.settings)
    doc["pieces"][0]["darts"][0]["visible"] = "yes"
    (tmp_path / "bad.flatweave").write_text(json.dumps(doc))
    with pytest.raises(ProjectError, match=r"bad.flatweave: piece 'octant': darts\[0\].visible must be true or false"):
        load_project(tmp_path / "bad.flatweave")


# ---------------------------------------------------------------------- the document's edits
def test_dart_and_yarn_edits_undo_exactly(solved, octant):
    doc = Document(solved)
    states = [project_to_dict(doc.project)]
    steps = [
        lambda: doc.add_dart(curve_dart_through(octant, HANDLES, VIEW, name="front")),
        lambda: doc.add_dart(PlaneDart((0.0, 1.0, 0.0, -0.5), name="side")),
        lambda: doc.rename_dart(0, "  new   name "),
        lambda: doc.set_dart_visible(1, False),
        lambda: doc.replace_dart(0, curve_dart_through(octant, HANDLES + 0.05, VIEW, name="new name")),
        lambda: doc.add_yarn(YarnConstraint("weft", 1, (0.0, 0.0, 1.0, -0.3), 100.0)),
        lambda: doc.replace_yarn(0, YarnConstraint("weft", 1, (0.0, 0.0, 1.0, -0.4), 100.0)),
        lambda: doc.remove_dart(1),
        lambda: doc.remove_yarn(0),
    ]
    for step in steps:
        assert step() is not None
        states.append(project_to_dict(doc.project))
    assert doc.project.settings.darts[0].name == "new name"
    labels = [e.label for e in doc.history]
    assert labels == ["Add front", "Add side", "Rename dart", "Hide dart", "Edit dart", "Constrain weft row 1",
                      "Edit yarn constraint", "Delete side", "Remove weft row 1 constraint"]
    # a rename and a hide keep the result current; nothing waits for a solve after them
    assert [e.answers_solve for e in doc.history][2:4] == [False, False]
    for k in range(len(steps), 0, -1):
        assert doc.undo()
        assert project_to_dict(doc.project) == states[k - 1]
    for k in range(1, len(steps) + 1):
        assert doc.redo()
        assert project_to_dict(doc.project) == states[k]


def test_rename_and_hide_keep_the_result_current(solved, octant):
    doc = Document(replace(solved, settings=replace(solved.settings, darts=(PlaneDart((0.0, 1.0, 0.0, -0.5)),))))
    doc.rename_dart(0, "x")
    doc.set_dart_visible(0, False)
    assert doc.project.result is solved.result  # same result object, and it still answers the settings
    assert replace(doc.project, result=flatten(octant, doc.project.settings)).result_is_current


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.remove_dart(3), "no dart 3"),
    (lambda d: d.rename_dart(0, "   "), "needs a name"),
    (lambda d: d.set_dart_visible(-1, True), "no dart -1"),
    (lambda d: d.remove_yarn(0), "no yarn constraint 0"),
])
def test_bad_edits_are_one_line_errors_and_change_nothing(solved, edit, message):
    doc = Document(replace(solved, settings=replace(solved.settings, darts=(PlaneDart((0.0, 1.0, 0.0, -0.5)),))))
    before, revision = doc.project, doc.revision
    with pytest.raises(SettingsError, match=message):
        edit(doc)
    assert doc.project is before and doc.revision == revision and not doc.can_redo


def test_unique_names():
    assert unique_name("curve dart", []) == "curve dart 1"
    assert unique_name("curve dart", ["curve dart 1", "curve dart 3"]) == "curve dart 2"


# ---------------------------------------------------------------------- yarns
def test_yarn_nodes_follow_the_lattice(solved):
    r = solved.result
    node = int(np.argmin(np.linalg.norm(r.xyz - r.xyz.mean(axis=0), axis=1)))
    i, j = r.mesh.ij[node]
    assert yarn_index(r.mesh, node, "weft") == i and yarn_index(r.mesh, node, "warp") == j
    row = yarn_nodes(r.mesh, "weft", int(i))
    assert set(row) == set(np.flatnonzero(r.mesh.ij[:, 0] == i)) and node in row
    assert np.all(np.diff(r.mesh.ij[row, 1]) > 0)  # in order along the row
    col = yarn_nodes(r.mesh, "warp", int(j))
    assert np.all(np.diff(r.mesh.ij[col, 0]) > 0)


def test_the_default_plane_and_its_angle():
    ends = np.array([[1.0, 0.0, 0.2], [0.0, 1.0, 0.4]])
    normal = np.array([0.2, 0.3, 1.0])
    plane = np.array(yarn_plane(ends, normal))
    assert np.linalg.norm(plane[:3]) == pytest.approx(1.0)
    np.testing.assert_allclose(ends @ plane[:3] + plane[3], 0.0, atol=1e-14)
    assert abs(plane[:3] @ normal) < 1e-14
    anchor = np.array([0.6, 0.6, 0.9])
    np.testing.assert_allclose(turn_plane(plane, anchor, normal, 0.0), plane, atol=1e-14)
    np.testing.assert_allclose(turn_plane(plane, anchor, normal, 360.0), plane, atol=1e-12)
    for angle in (10.0, -35.0, 90.0):
        t = np.array(turn_plane(plane, anchor, normal, angle))
        assert t[:3] @ plane[:3] == pytest.approx(np.cos(np.radians(angle)), abs=1e-12)
        assert abs(t[:3] @ normal) < 1e-12  # still contains the normal
        foot = anchor - (plane[:3] @ anchor + plane[3]) * plane[:3]
        assert abs(t[:3] @ foot + t[3]) < 1e-12  # turned about the normal through the anchor's foot
    # positive angles turn counter-clockwise seen from where the normal points
    t = np.array(turn_plane(plane, anchor, normal, 30.0))
    assert np.cross(plane[:3], t[:3]) @ normal > 0
    with pytest.raises(SettingsError, match="coincide"):
        yarn_plane(np.array([ends[0], ends[0]]), normal)
    with pytest.raises(SettingsError, match="along the surface normal"):
        yarn_plane(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), np.array([0.0, 0.0, 1.0]))
