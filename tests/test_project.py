"""Projects (flatweave.document.project) and the open document with undo (flatweave.document.history)."""

from __future__ import annotations

import json
import math
import os
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings as hsettings, strategies as st

from flatweave.files import decode_array, encode_array
from flatweave.method.darts import CurveDart, PlaneDart
from flatweave.document.history import Document
from flatweave.method.energy import YarnConstraint
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.reading.examples import example_path, load_example
from flatweave.method.lattice import MATERIALS, Material
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.document.project import (PROJECT_VERSION, Project, ProjectError, load_project, needs_new_drape,
                          project_from_dict, project_problems, project_to_dict, save_project,
                          settings_equal, warm_start, drops_a_dart)
from tests.helpers import NO_SPACE, FullDisk


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module")
def solved(octant):
    """A project with every kind of content: custom material, warp spacing, a
    plane and a curve dart, a yarn constraint, display choices and a result."""
    s = FlattenSettings(
        spacing=0.1, spacing_warp=0.11, material=Material("custom 300:200:5", 300.0, 200.0, 5.0),
        seed=(0.45, 0.55), angle_deg=10.0, tol=1e-8, max_iter=200,
        darts=(PlaneDart((1.0, 0.0, 0.0, -0.55), (0.5, 1.0, 0.0, 1.0, 0.0, 0.6), name="side"),
               CurveDart(np.array([[0.05, 0.8], [0.3, 0.75], [0.45, 0.7]]), name="curve")),
        yarns=(YarnConstraint("warp", 0, (0.0, 1.0, -1.0, 0.0), 50.0),))
    return Project(octant, s, name="octant", source=str(example_path("octant")), units="cm",
                   shear_warning_deg=12.5, shear_limit_deg=27.0, result=flatten(octant, s))


# ---------------------------------------------------------------------- the model
def test_project_validates_display_choices(octant):
    s = FlattenSettings(spacing=0.1)
    with pytest.raises(SettingsError, match="units"):
        Project(octant, s, units="furlong")
    with pytest.raises(SettingsError, match="below the limit"):
        Project(octant, s, shear_warning_deg=30, shear_limit_deg=30)
    with pytest.raises(SettingsError, match="between 0 and 90"):
        Project(octant, s, shear_warning_deg=10, shear_limit_deg=120)
    with pytest.raises(SettingsError, match="spacing"):
        Project(octant, FlattenSettings(spacing=-1.0))
    with pytest.raises(SettingsError, match="seed"):
        Project(octant, FlattenSettings(spacing=0.1, seed=(0.5, 1.5)))
    p = Project(octant, s)
    assert p.with_display(units="in").units == "in" and p.units == "m"  # a copy, the original unchanged
    with pytest.raises(SettingsError, match="tolerance"):
        p.with_settings(tol=0.0)


def test_result_is_current_follows_the_settings(solved):
    assert solved.result_is_current
    assert not solved.with_settings(tol=1e-6).result_is_current
    assert solved.with_display(units="mm").result_is_current  # display choices do not stale a result
    assert not replace(solved, result=None).result_is_current


def test_settings_equal_compares_curve_darts_by_value(solved):
    s = solved.settings
    copy = replace(s, darts=tuple(replace(d) if d.kind == "plane" else CurveDart(np.array(d.uv), name=d.name)
                                  for d in s.darts))
    assert copy.darts[1] is not s.darts[1] and settings_equal(s, copy)
    moved = replace(s, darts=(s.darts[0], CurveDart(s.darts[1].uv + 0.01, name="curve")))
    assert not settings_equal(s, moved)
    # no warp spacing means a warp spacing equal to the weft's
    assert settings_equal(FlattenSettings(spacing=0.1), FlattenSettings(spacing=0.1, spacing_warp=0.1))


def test_needs_new_drape_and_warm_start(solved):
    s = solved.settings
    for key, value in (("spacing", 0.09), ("seed", (0.5, 0.5)), ("angle_deg", 0.0), ("paths", "geodesic")):
        assert needs_new_drape(s, replace(s, **{key: value})), key
    for key, value in (("material", MATERIALS["woven"]), ("solver", "paper"), ("tol", 1e-6), ("darts", ()),
                       ("yarns", ())):
        assert not needs_new_drape(s, replace(s, **{key: value})), key
    state = warm_start(solved.with_settings(solver="paper"))
    assert state is not None and np.array_equal(state.uv, solved.result.uv)
    assert warm_start(solved.with_settings(spacing=0.09)) is None
    assert warm_start(replace(solved, result=None)) is None


def test_a_moved_or_deleted_dart_drapes_anew(solved):
    """A dart added warm-starts (its V opens from the mesh); one moved, reshaped or
    deleted does not, since the mesh still holds its old opening; labels do not count."""
    side, curve = solved.settings.darts
    extra = CurveDart(np.array([[0.95, 0.2], [0.7, 0.25]]), name="extra")
    assert warm_start(solved.with_settings(darts=(side, curve, extra))) is not None
    assert warm_start(solved.with_settings(darts=(curve, side))) is not None  # the same cuts, reordered
    assert warm_start(solved.with_settings(darts=(side, replace(curve, name="renamed", visible=False)))) is not None
    moved = replace(curve, uv=curve.uv + [0.0, 0.02])
    for darts in ((side, moved), (side,), (), (side, CurveDart(curve.uv[:2], name="curve"))):
        assert drops_a_dart(solved.settings, replace(solved.settings, darts=darts))
        assert warm_start(solved.with_settings(darts=darts)) is None
    assert not drops_a_dart(solved.settings, solved.settings)


# ---------------------------------------------------------------------- files
def test_save_then_load_restores_the_same_project(solved, tmp_path):
    path = save_project(solved, tmp_path / "job.flatweave")
    doc = json.loads(path.read_text())
    assert doc["format"] == "flatweave-project" and doc["version"] == PROJECT_VERSION
    assert doc["sources"][0]["surface"]["shape"]["type"] == "surface"
    [piece] = doc["pieces"]  # one piece: the project's own
    assert [d["kind"] for d in piece["darts"]] == ["plane", "curve"] and len(piece["yarns"]) == 1

    back = load_project(path)
    assert project_to_dict(back) == project_to_dict(solved)
    assert back.name == "octant" and back.units == "cm"
    assert (back.shear_warning_deg, back.shear_limit_deg) == (12.5, 27.0)
    assert back.settings.material == solved.settings.material and back.settings.spacing_warp == 0.11
    np.testing.assert_array_equal(back.surface.ctrlpts, solved.surface.ctrlpts)
    np.testing.assert_array_equal(back.surface.weights, solved.surface.weights)
    # the result: same mesh, positions, pattern (outline and dart legs) and metrics, bit for bit
    r0, r1 = solved.result, back.result
    np.testing.assert_array_equal(r1.mesh.ends, r0.mesh.ends)
    np.testing.assert_array_equal(r1.uv, r0.uv)
    np.testing.assert_array_equal(r1.xyz, r0.xyz)
    np.testing.assert_array_equal(r1.pattern.outline, r0.pattern.outline)
    assert len(r1.pattern.darts) == len(r0.pattern.darts) == 2
    for a, b in zip(r0.pattern.darts, r1.pattern.darts):
        np.testing.assert_array_equal(a.leg_a, b.leg_a)
        np.testing.assert_array_equal(a.leg_b, b.leg_b)
    assert r1.metrics == r0.metrics and r1.settings.solver == r0.settings.solver
    assert back.result_is_current and project_problems(back) == []


def test_a_project_without_result_keeps_default_warp_spacing(octant, tmp_path):
    p = Project(octant, FlattenSettings(spacing=0.07, solver="paper", max_seconds=5.0), name="x")
    back = load_project(save_project(p, tmp_path / "a.flatweave"))
    assert back.result is None and back.settings.spacing_warp is None
    assert back.settings == p.settings  # no arrays inside: dataclass equality applies
    assert project_to_dict(back) == project_to_dict(p)


def test_save_is_atomic(solved, tmp_path, monkeypatch):
    path = tmp_path / "job.flatweave"
    first = Project(solved.surface, FlattenSettings(spacing=0.2), name="first")
    save_project(first, path)
    before = path.read_bytes()

    def broken_replace(src, dst):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(FlatweaveError) as err:
        save_project(solved, path)
    assert "\n" not in str(err.value) and "job.flatweave" in str(err.value)
    assert path.read_bytes() == before  # the old file is intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.flatweave"]  # no temporary left behind


@pytest.mark.parametrize("how", ["write", "fsync"])
def test_save_on_a_full_disk_keeps_the_previous_file(solved, tmp_path, monkeypatch, how):
    path = tmp_path / "job.flatweave"
    save_project(Project(solved.surface, FlattenSettings(spacing=0.2), name="first"), path)
    before = path.read_bytes()
    FullDisk(monkeypatch, how)
    with pytest.raises(FlatweaveError) as err:
        save_project(solved, path)
    monkeypatch.undo()
    assert str(err.value) == f"cannot write {path}: {NO_SPACE}"
    assert path.read_bytes() == before and load_project(path).name == "first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.flatweave"]  # no temporary left behind


def test_save_into_a_missing_folder_is_one_line(solved, tmp_path):
    with pytest.raises(FlatweaveError) as err:
        save_project(solved, tmp_path / "nope" / "x.flatweave")
    assert "\n" not in str(err.value) and "x.flatweave" in str(err.value)


def test_a_newer_version_is_refused_clearly(solved, tmp_path):
    doc = project_to_dict(replace(solved, result=None))
    doc["version"] = PROJECT_VERSION + 2
    path = tmp_path / "future.flatweave"
    path.write_text(json.dumps(doc))
    with pytest.raises(ProjectError) as err:
        load_project(path)
    msg = str(err.value)
    assert "\n" not in msg and "future.flatweave" in msg and "newer" in msg and str(PROJECT_VERSION + 2) in msg


def _valid_doc(octant) -> dict:
    return project_to_dict(Project(octant, FlattenSettings(spacing=0.1), name="o"))


def _corruptions(octant, solved):
    good = _valid_doc(octant)
    full = json.dumps(project_to_dict(solved))

    def edit(fn):
        d = json.loads(json.dumps(good))
        fn(d)
        return json.dumps(d)

    def damage_nodes(d):
        nodes = d["pieces"][0]["result"]["nodes"]
        uv = decode_array(nodes["uv"], "uv")
        uv[3] = [7.0, 7.0]
        nodes["uv"] = encode_array(uv, "<f8")

    result_doc = json.loads(full)
    return {
        "empty": "",
        "not_json": "{ this is not json",
        "truncated": full[: len(full) // 2],
        "binary": b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe",
        "a_list": "[1, 2, 3]",
        "no_format": edit(lambda d: d.pop("format")),
        "other_format": edit(lambda d: d.update(format="something-else")),
        "result_file": json.dumps({"format": "flatweave-result", "version": 1}),
        "version_string": edit(lambda d: d.update(version="1")),
        "version_zero": edit(lambda d: d.update(version=0)),
        "no_surface": edit(lambda d: d["sources"][0].pop("surface")),
        "bad_surface": edit(lambda d: d["sources"][0]["surface"]["shape"]["data"][0].update(degree_u=-1)),
        "no_sources": edit(lambda d: d.pop("sources")),
        "sources_empty": edit(lambda d: d.update(sources=[])),
        "source_not_text": edit(lambda d: d["sources"][0].update(source=7)),
        "piece_source_missing": edit(lambda d: d["pieces"][0].update(source=1)),
        "piece_source_string": edit(lambda d: d["pieces"][0].update(source="0")),
        "negative_spacing": edit(lambda d: d["pieces"][0]["settings"].update(spacing=-0.1)),
        "spacing_string": edit(lambda d: d["pieces"][0]["settings"].update(spacing="0.1")),
        "missing_solver": edit(lambda d: d["pieces"][0]["settings"].pop("solver")),
        "unknown_solver": edit(lambda d: d["pieces"][0]["settings"].update(solver="magic")),
        "bad_material": edit(lambda d: d["pieces"][0]["settings"].update(material={"name": "x", "k_weft": 1})),
        "bad_dart": edit(lambda d: d["pieces"][0].update(darts=[{"kind": "zigzag"}])),
        "dart_plane_zero": edit(lambda d: d["pieces"][0].update(darts=[{"kind": "plane", "plane": [0, 0, 0, 1]}])),
        "curve_dart_one_point": edit(lambda d: d["pieces"][0].update(darts=[{"kind": "curve", "uv": [[0.1, 0.2]]}])),
        "bad_yarn": edit(lambda d: d["pieces"][0].update(
            yarns=[{"kind": "bias", "index": 0, "plane": [1, 0, 0, 0], "k": 1}])),
        "bad_units": edit(lambda d: d["display"].update(units="furlong")),
        "warning_above_limit": edit(lambda d: d["display"].update(shear_warning_deg=40)),
        "result_nodes_outside": (damage_nodes(result_doc), json.dumps(result_doc))[1],
        "result_not_object": edit(lambda d: d["pieces"][0].update(result=[1, 2])),
    }


CORRUPTIONS = ["empty", "not_json", "truncated", "binary", "a_list", "no_format", "other_format",
               "result_file", "version_string", "version_zero", "no_surface", "bad_surface", "no_sources",
               "sources_empty", "source_not_text", "piece_source_missing", "piece_source_string", "negative_spacing",
               "spacing_string", "missing_solver", "unknown_solver", "bad_material", "bad_dart",
               "dart_plane_zero", "curve_dart_one_point", "bad_yarn", "bad_units", "warning_above_limit",
               "result_nodes_outside", "result_not_object"]


def test_the_corruption_list_is_complete(octant, solved):
    assert sorted(_corruptions(octant, solved)) == sorted(CORRUPTIONS)


@pytest.mark.slow
@pytest.mark.parametrize("case", CORRUPTIONS)
def test_a_damaged_project_is_a_one_line_error(octant, solved, tmp_path, case):
    content = _corruptions(octant, solved)[case]
    path = tmp_path / f"{case}.flatweave"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(ProjectError) as err:
        load_project(path)
    msg = str(err.value)
    assert msg and "\n" not in msg and path.name in msg, msg


def test_a_missing_project_file_is_a_one_line_error(tmp_path):
    with pytest.raises(ProjectError) as err:
        load_project(tmp_path / "gone.flatweave")
    assert "\n" not in str(err.value) and "gone.flatweave" in str(err.value)


_JSON = st.recursive(st.none() | st.booleans() | st.integers(-10, 10) | st.floats(allow_nan=False, width=32)
                     | st.text(max_size=5), lambda inner: st.lists(inner, max_size=3)
                     | st.dictionaries(st.text(max_size=5), inner, max_size=3), max_leaves=6)


@hsettings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_projects_load_or_fail_in_one_line(octant, data):
    """Any entry replaced by any JSON value: a Project or a one-line ProjectError, nothing else."""
    doc = _valid_doc(octant)
    doc["darts"] = [{"kind": "plane", "name": "p", "plane": [1.0, 0.0, 0.0, -0.5], "box": None}]
    paths = []

    def walk(node, trail):
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for k, v in items:
            paths.append(trail + (k,))
            if len(trail) < 4:
                walk(v, trail + (k,))
    walk(doc, ())
    target = data.draw(st.sampled_from(paths))
    node = doc
    for k in target[:-1]:
        node = node[k]
    if data.draw(st.booleans()) and isinstance(node, dict):
        del node[target[-1]]
    else:
        node[target[-1]] = data.draw(_JSON)
    try:
        p = project_from_dict(json.loads(json.dumps(doc)), where="fuzz.flatweave")
    except ProjectError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("fuzz.flatweave")
    else:
        assert isinstance(p, Project)


# ---------------------------------------------------------------------- the document
@pytest.fixture
def doc(octant):
    return Document(Project(octant, FlattenSettings(spacing=0.1), name="octant"))


def test_undo_and_redo_restore_the_exact_projects(doc):
    seen = []
    doc.subscribe(lambda project, change: seen.append((project, change)))
    p0 = doc.project
    doc.edit_settings("Spacing", spacing=0.09)
    p1 = doc.project
    doc.edit_display("Units", units="mm")
    p2 = doc.project
    assert [c.aspects for _, c in seen] == [frozenset({"settings"}), frozenset({"display"})]
    assert doc.undo_label == "Units" and doc.can_undo and not doc.can_redo
    assert doc.undo() and doc.project is p1
    assert doc.undo() and doc.project is p0
    assert not doc.undo() and doc.project is p0
    assert doc.redo_label == "Spacing"
    assert doc.redo() and doc.project is p1
    assert doc.redo() and doc.project is p2 and not doc.can_redo
    assert [c.cause for _, c in seen] == ["edit", "edit", "undo", "undo", "redo", "redo"]
    # a new edit after an undo drops the redo branch
    doc.undo()
    doc.edit_settings("Angle", angle_deg=15.0)
    assert not doc.can_redo and doc.project.units == "m" and doc.project.settings.angle_deg == 15.0


def test_an_edit_that_changes_nothing_is_not_recorded(doc):
    assert doc.edit_settings("Same", spacing=0.1) is None
    assert not doc.can_undo and doc.revision == 0


def test_an_invalid_edit_leaves_the_document_alone(doc):
    p0 = doc.project
    with pytest.raises(SettingsError):
        doc.edit_settings("Bad", spacing=0.0)
    assert doc.project is p0 and not doc.can_undo


def test_a_solve_is_folded_into_the_edit_it_answers(doc, octant):
    p0 = doc.project
    doc.edit_settings("Spacing", spacing=0.12)
    source = doc.project
    result = flatten(octant, source.settings)
    assert doc.attach_result(result, source)
    assert doc.project.result is result and doc.project.result_is_current
    assert len(doc.history) == 1 and doc.undo_label == "Spacing"
    doc.undo()
    assert doc.project is p0 and doc.project.result is None  # the previous pattern, no re-solve
    doc.redo()
    assert doc.project.result is result


def test_a_solve_without_an_edit_is_its_own_step(doc, octant):
    source = doc.project
    result = flatten(octant, source.settings)
    assert doc.attach_result(result, source, label="Run")
    assert doc.undo_label == "Run" and doc.project.result is result
    doc.undo()
    assert doc.project is source


def test_a_stale_solve_is_refused(doc, octant):
    source = doc.project
    doc.edit_settings("Spacing", spacing=0.12)
    moved = doc.project
    assert not doc.attach_result(flatten(octant, source.settings), source)
    assert doc.project is moved and moved.result is None
    # display edits do not make a running solve stale
    source = doc.project
    doc.edit_display("Units", units="cm")
    assert doc.attach_result(flatten(octant, source.settings), source)
    assert doc.undo_label == "Solve" and doc.project.units == "cm"


def test_dirty_follows_the_saved_project(doc, tmp_path):
    assert doc.dirty  # never saved
    save_project(doc.project, tmp_path / "a.flatweave")
    doc.mark_saved(tmp_path / "a.flatweave")
    assert not doc.dirty and doc.path.name == "a.flatweave"
    doc.edit_settings("Tolerance", tol=1e-7)
    assert doc.dirty
    doc.undo()
    assert not doc.dirty  # back at the saved project
    doc.reset(load_project(tmp_path / "a.flatweave"), tmp_path / "a.flatweave")
    assert not doc.dirty and not doc.can_undo


def test_history_is_bounded(octant):
    d = Document(Project(octant, FlattenSettings(spacing=0.1)), limit=5)
    for k in range(12):
        d.edit_settings(f"Angle {k}", angle_deg=float(k + 1))
    assert len(d.history) == 5 and d.history[0].label == "Angle 7"
    while d.undo():
        pass
    assert d.project.settings.angle_deg == 7.0 and not math.isnan(d.project.settings.angle_deg)


def test_the_view_choices_travel_with_the_file_but_are_no_edit(octant, tmp_path):
    from flatweave.document.history import changed_aspects

    p = Project(octant, FlattenSettings(spacing=0.1), name="octant")
    viewed = replace(p, view=(("mode", "shear"), ("show_weft", False)))
    assert changed_aspects(p, viewed) == frozenset()  # view state: no undo step, no redraw of the document
    back = load_project(save_project(viewed, tmp_path / "v.flatweave"))
    assert dict(back.view) == {"mode": "shear", "show_weft": False}
    assert "view" not in project_to_dict(p)["display"]  # a project without view choices writes none
    doc = project_to_dict(viewed)
    doc["display"]["view"] = {"mode": 3}
    with pytest.raises(ProjectError) as exc:
        project_from_dict(doc)
    assert "display.view" in str(exc.value) and "\n" not in str(exc.value)


def test_the_shear_angles_are_the_materials_and_keep_a_result_current(octant):
    """The window's shear angles edit the material's; the result stays current and
    is judged by the new angles as a solve with that material would judge it."""
    doc = Document(Project(octant, FlattenSettings(spacing=0.1), name="octant"))
    r = flatten(octant, doc.project.settings)
    doc.attach_result(r, doc.project)
    before = doc.project
    lock = 0.5 * r.metrics["max_shear_deg"]  # some cells beyond it
    doc.edit_display("Shear angles", shear_warning_deg=0.25 * lock, shear_limit_deg=lock)
    p = doc.project
    assert (p.settings.material.warn_deg, p.settings.material.lock_deg) == (0.25 * lock, lock)
    assert p.result_is_current and p.result.metrics["energy"] == r.metrics["energy"]
    oracle = flatten(octant, p.settings)  # the same solve with the new material from scratch
    assert oracle.metrics["area_beyond_lock_pct"] > 0
    assert p.result.metrics["area_beyond_lock_pct"] == pytest.approx(oracle.metrics["area_beyond_lock_pct"], abs=1e-9)
    assert p.result.warnings == oracle.warnings and p.result.warnings != r.warnings
    assert p.result.mesh.material == p.settings.material
    assert doc.undo() and doc.project is before
    # a material with other angles brings them to the display, in the same edit
    m = Material("custom 400:400:2", 400.0, 400.0, 2.0, warn_deg=10.0, lock_deg=20.0)
    doc.edit_settings("Material", material=m)
    assert (doc.project.shear_warning_deg, doc.project.shear_limit_deg) == (10.0, 20.0)
    with pytest.raises(SettingsError):
        doc.edit_display("Shear angles", shear_warning_deg=25.0)
    assert doc.project.settings.material is m


def test_settings_keys_are_remembered_only_while_the_settings_live():
    """settings_equal keeps each settings object's key while it lives (a window compares the same
    ones many times an edit) and answers as before: a changed dart or value is another solve."""
    import gc

    from flatweave.document.project import _KEYS, settings_equal

    dart = CurveDart(np.array([[1.0, 0.5], [0.75, 0.52], [0.45, 0.5]]), name="a")
    a = FlattenSettings(0.05, darts=(dart,))
    n0 = len(_KEYS)
    assert settings_equal(a, FlattenSettings(0.05, darts=(replace(dart, name="b"),)))  # labels do not count
    assert not settings_equal(a, FlattenSettings(0.05, darts=(CurveDart(dart.uv[::-1], name="a"),)))
    assert not settings_equal(a, FlattenSettings(0.06, darts=(dart,)))
    assert settings_equal(a, a) and len(_KEYS) > n0
    del a
    gc.collect()
    assert len(_KEYS) == n0
