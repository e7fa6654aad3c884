"""GUI tests of editing a drawn region as a curve dart is edited: a
dragged point re-solves as it moves (previews outside the document, the release
one edit that a preview answers), a double click on a side inserts a point, a
double click on a point or Delete removes it, every edit one undo step.

Clicks are real mouse events in the 3D view of the octant (the unit sphere);
where a point lands is checked against the ray-sphere intersection of its
pixel (tests.test_app_tools' oracle), how far the pattern reaches against the
angle from the ring's centre (plain geometry of the sphere)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from flatweave.geometry.region import cover_for, region_from_spec

from tests.test_app_region_tool import ring
from tests.test_app_run import RUN_TIMEOUT_MS, run_to_end, small_project
from tests.test_app_tools import CAMERA, click, pixel, ray_sphere, ready

CENTRE = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)


def reach_deg(xyz) -> float:
    """The largest angle (degrees) between the ring's centre and points on the sphere."""
    c = np.clip(np.asarray(xyz) @ CENTRE / np.linalg.norm(xyz, axis=1), -1.0, 1.0)
    return float(np.degrees(np.arccos(c)).max())


def drawn_window(make_window, qtbot, radius_deg=27):
    """A window with a six-point region drawn round the octant's middle, solved."""
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.view.look(*CAMERA)
    ready(qtbot, win)
    win.actions["tool_region"].trigger()
    pixels = [pixel(win.view, t) for t in ring(CENTRE, radius_deg, 6)]
    for x, y in pixels:
        click(qtbot, win.view, x, y)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, win.view, *pixels[0])
    assert win.project.settings.region.drawn is not None, win.last_hint
    return win


def to_qt(view, p) -> QPoint:
    return QPoint(int(round(p[0])), view.widget.height() - 1 - int(round(p[1])))


@pytest.mark.slow
def test_a_dragged_region_point_re_solves_as_it_moves(make_window, qtbot):
    win = drawn_window(make_window, qtbot)
    view, doc = win.view, win.document
    before, steps = win.project, len(doc.history)
    drawn = before.settings.region.drawn
    assert reach_deg(before.result.xyz) < 27.5  # the piece lies inside the ring drawn
    frames = []
    win.runner.frame.connect(frames.append)
    previews, adopted = win.runs.previews_started, win.runs.previews_adopted
    w = view.widget
    start = pixel(view, drawn.outer[0])
    qtbot.mousePress(w, Qt.MouseButton.LeftButton, pos=to_qt(view, start))
    last, previous = start, None
    for radius in (30, 33):  # the point moves out in two steps, held down: each position is previewed
        end = pixel(view, ring(CENTRE, radius, 6)[0])
        n0 = len(frames)
        for f in np.linspace(0, 1, 5)[1:]:
            qtbot.mouseMove(w, to_qt(view, [a + f * (b - a) for a, b in zip(last, end)]))
        last = end
        here = cover_for(win.surface, region_from_spec(win.surface, win.tool.dragged))

        def reached():  # a solved frame of this position's piece: inside it, and beyond the one before
            return next((f for f in frames[n0:] if not f.draping and f.iteration >= 1
                         and here.contains(f.uv).all()
                         and (reach_deg(f.xyz) > 27.5 if previous is None
                              else not previous.contains(f.uv).all())), None)
        qtbot.waitUntil(lambda: reached() is not None, timeout=RUN_TIMEOUT_MS)
        assert doc.project is before and len(doc.history) == steps  # previews are not edits
        previous = here
    expected = ray_sphere(view, *last)  # (the release's new piece may refit the view)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS) as blocker:
        qtbot.mouseRelease(w, Qt.MouseButton.LeftButton, pos=to_qt(view, last))
    after = win.project
    assert len(doc.history) == steps + 1 and doc.undo_label == "Move region point"
    assert blocker.args[0].result is after.result and after.result_is_current
    moved = after.settings.region.drawn
    np.testing.assert_allclose(moved.outer[0], expected, atol=1e-7)
    assert moved.outer[1:] == drawn.outer[1:]
    assert 28.5 < reach_deg(after.result.xyz) < 33.5  # into the spike (the mesh's spacing is 5.7 degrees)
    assert previous.contains(after.result.uv).all()
    assert after.result.pattern.area > before.result.pattern.area * 1.03
    # previews ran (one at least per position) and the last answered the edit
    assert win.runs.previews_started - previews >= 2 and win.runs.previews_adopted == adopted + 1
    win.actions["undo"].trigger()
    assert win.project is before and len(doc.history) == steps


@pytest.mark.slow
def test_insert_and_delete_region_points(make_window, qtbot):
    win = drawn_window(make_window, qtbot)
    view, doc = win.view, win.document
    from flatweave.app.tools import RegionTool

    def tool():
        if not isinstance(win.tool, RegionTool):
            win.actions["tool_region"].trigger()
        return win.tool

    first = win.project
    outer = first.settings.region.drawn.outer
    # a double click half way along the side from point 2 to point 3 inserts a point there
    a, b = pixel(view, outer[1]), pixel(view, outer[2])
    mid = ((a[0] + b[0]) // 2, (a[1] + b[1]) // 2)
    tool()
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, view, *mid, double=True)
    inserted = win.project.settings.region.drawn
    assert doc.undo_label == "Insert region point", win.last_hint
    assert len(inserted.outer) == 7 and inserted.outer[:2] == outer[:2] and inserted.outer[3:] == outer[2:]
    np.testing.assert_allclose(inserted.outer[2], ray_sphere(view, *mid), atol=1e-7)
    assert win.tool.points == []  # the double click drew nothing
    # a double click on the new point deletes it again: the region drawn first
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, view, *pixel(view, inserted.outer[2]), double=True)
    assert doc.undo_label == "Delete region point" and win.project.settings.region.drawn.outer == outer
    # pick point 4 with a click, Delete removes it
    click(qtbot, tool().view, *pixel(view, outer[3]))
    assert win.tool.picked == (0, 3)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(view.widget, Qt.Key.Key_Delete)
    five = win.project.settings.region.drawn.outer
    assert five == outer[:3] + outer[4:] and doc.undo_label == "Delete region point"
    assert win.project.result_is_current
    # undo and redo, one step each
    doc.undo()
    assert win.project.settings.region.drawn.outer == outer
    doc.redo()
    assert win.project.settings.region.drawn.outer == five
    # a hole of three points: deleting one of its points deletes the hole
    hole = [pixel(view, t) for t in ring((1.05, 1, 0.95), 9, 3)]
    for p in hole:
        click(qtbot, tool().view, *p)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    assert win.project.settings.region.n_holes == 1 and doc.undo_label == "Draw hole"
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, tool().view, *hole[1], double=True)
    region = win.project.settings.region
    assert doc.undo_label == "Delete hole" and region.n_holes == 0 and region.drawn.outer == five
    # the outer loop keeps three points at least: a fourth deletion is refused, nothing changes
    for k in (4, 3):
        with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
            click(qtbot, tool().view, *pixel(view, five[k]), double=True)
    assert len(win.project.settings.region.drawn.outer) == 3
    revision = doc.revision
    click(qtbot, tool().view, *pixel(view, five[0]), double=True)
    assert "at least three points" in win.last_hint and doc.revision == revision


@pytest.mark.slow
def test_the_region_offset_in_the_settings_panel(make_window, qtbot, tmp_path):
    """Region offset d (model units along the surface): on the unit sphere the outer loop's
    farthest point from the ring's centre moves out by d radians (a vertex's fan is a circle of
    geodesic radius d about it); one edit, undone in one step, saved and reopened."""
    win = drawn_window(make_window, qtbot)
    doc, field = win.document, win.settings_panel.region_offset
    before = win.project
    drawn = before.settings.region.drawn
    assert field.isEnabled() and field.value() == 0.0
    base = reach_deg(win.surface.points(np.asarray(before.settings.region.loops[0])))
    assert abs(base - 27.0) < 0.1  # the drawn vertices lie on the 27 degree ring (to the pixel)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        field.setText("0.05")
        field.editingFinished.emit()
    p = win.project
    region = p.settings.region
    assert doc.undo_label == "Region offset" and region.drawn.offset == 0.05 and p.result_is_current
    assert region.drawn.outer == drawn.outer  # the points drawn stay; the boundary moves
    grown = reach_deg(win.surface.points(np.asarray(region.loops[0])))
    assert abs(grown - (base + math.degrees(0.05))) < 0.03, (base, grown)
    assert p.result.pattern.area > before.result.pattern.area
    # an offset that leaves too little is refused in one line, nothing changes
    revision = doc.revision
    field.setText("-0.4")
    field.editingFinished.emit()
    assert win.last_error.startswith("Region offset:") and "\n" not in win.last_error
    assert doc.revision == revision and field.value() == 0.05
    # save and reopen: the drawing, its offset and the loops come back
    assert win.save_to(tmp_path / "offset")
    other = make_window(example="saddle")
    assert other.open_file(tmp_path / "offset.flatweave")
    assert other.project.settings.region == region and other.settings_panel.region_offset.value() == 0.05
    doc.undo()
    assert win.project.settings.region == before.settings.region and field.value() == 0.0


def test_several_candidate_regions_one_active(make_window, qtbot, tmp_path):
    """Keep a copy of the drawn region, draw another in its place, switch between them
    (the piece re-solves), rename, hide, delete; saved and reopened; undo."""
    win = drawn_window(make_window, qtbot)
    view, doc, panel = win.view, win.document, win.dart_panel.regions
    first = win.project.settings.region
    assert panel.isVisible() and panel.names() == ["region"] and not panel.use.isEnabled()
    panel.keep.click()
    assert panel.names() == ["region", "region 2"] and doc.undo_label == "Keep region"
    assert len(view.layer_lines("kept regions")) > 50  # the kept copy drawn on the surface (under the active one)
    # draw a smaller region elsewhere: it replaces the active one, the copy stays
    from flatweave.app.tools import RegionTool
    if not isinstance(win.tool, RegionTool):
        win.actions["tool_region"].trigger()
    small = [pixel(view, t) for t in ring((1.0, 0.45, 0.75), 12, 5)]
    for p in small:
        click(qtbot, view, *p)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    second = win.project.settings.region
    assert second != first and win.project.candidates[0].region == first, win.last_hint
    area_second = win.project.result.pattern.area
    # rename both, then use the kept one: they swap, the piece re-solves as the first
    panel.list.item(0).setText("small ply")
    panel.list.item(1).setText("large ply")
    assert panel.names() == ["small ply", "large ply"] and win.project.region_name == "small ply"
    panel.list.setCurrentRow(1)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        panel.use.click()
    p = win.project
    assert p.settings.region == first and p.region_name == "large ply" and doc.undo_label == "Use large ply"
    assert p.candidates[0].name == "small ply" and p.candidates[0].region == second and p.result_is_current
    assert p.result.pattern.area > 1.5 * area_second
    # hide the kept one: nothing drawn, no solve
    revision, result = doc.revision, p.result
    panel.list.item(1).setCheckState(Qt.CheckState.Unchecked)
    assert doc.undo_label == "Hide small ply" and len(view.layer_lines("kept regions")) == 0
    assert doc.revision == revision + 1 and win.project.result is result
    # saved and reopened: names, regions and visibility come back
    assert win.save_to(tmp_path / "plies")
    other = make_window(example="saddle")
    assert other.open_file(tmp_path / "plies.flatweave")
    assert other.dart_panel.regions.names() == ["large ply", "small ply"]
    assert other.project.candidates == win.project.candidates and other.project.settings.region == first
    # a name already taken is refused in one line; delete; undo brings it back
    panel.list.item(1).setText("large ply")
    assert "already a region called" in win.last_error and panel.names() == ["large ply", "small ply"]
    panel.list.setCurrentRow(1)
    panel.delete.click()
    assert win.project.candidates == () and panel.names() == ["large ply"]
    doc.undo()
    assert [c.name for c in win.project.candidates] == ["small ply"]
