"""GUI tests of the region tool: a ply boundary drawn by clicks in the
3D view on the octant (the unit sphere), closed by a click on its first point,
a hole drawn inside it, undo and redo, save and reopen.

Every click is a real mouse event; each placed point is checked against the
ray-sphere intersection of its pixel's viewing ray (tests.test_app_tools'
oracle, independent of flatweave.geometry.curves)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PySide6.QtCore import Qt

from flatweave.app.tools import RegionTool
from flatweave.geometry.region import cover_for

from tests.test_app_run import RUN_TIMEOUT_MS, run_to_end, small_project
from tests.test_app_tools import CAMERA, click, drag, pixel, ray_sphere, ready


def ring(centre, radius_deg, n):
    c = np.asarray(centre, float) / np.linalg.norm(centre)
    a = np.cross(c, [0.0, 0.0, 1.0])
    a /= np.linalg.norm(a)
    b = np.cross(c, a)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = math.radians(radius_deg)
    return math.cos(r) * c + math.sin(r) * (np.cos(t)[:, None] * a + np.sin(t)[:, None] * b)


@pytest.mark.slow
def test_draw_a_region_and_a_hole_undo_and_reopen(make_window, qtbot, tmp_path):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.view.look(*CAMERA)
    ready(qtbot, win)
    view, doc = win.view, win.document
    before = win.project
    win.actions["tool_region"].trigger()
    targets = ring((1, 1, 1), 27, 6)
    pixels = [pixel(view, t) for t in targets]
    for k, (x, y) in enumerate(pixels):
        click(qtbot, view, x, y)
        assert len(win.tool.points) == k + 1, win.last_hint
    assert len(view.layer_lines("preview")) > 50  # the closed loop on the surface, as drawn so far
    assert doc.project is before  # nothing is an edit before the loop closes
    seen = view.view_direction() / np.linalg.norm(view.view_direction())
    rays = [ray_sphere(view, x, y) for x, y in pixels]
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, view, *pixels[0])  # a click on the first point closes the loop
    region = win.project.settings.region
    assert region is not None and region.n_holes == 0 and doc.undo_label == "Draw region"
    drawn = region.drawn
    assert drawn.form == "points" and len(drawn.outer) == 6
    np.testing.assert_allclose(drawn.view_direction, seen)
    for ray, p in zip(rays, np.array(drawn.outer)):
        np.testing.assert_allclose(p, ray, atol=1e-7)  # each point under its pixel
    loop = win.surface.points(np.asarray(region.loops[0]))
    np.testing.assert_allclose(np.linalg.norm(loop, axis=1), 1.0, atol=1e-9)  # on the sphere
    r = win.project.result
    cover = cover_for(win.surface, region)
    assert win.project.settings.seed == cover.default_seed
    assert r is not None and win.project.result_is_current and cover.contains(r.uv).all()
    assert r.metrics["area_3d"] < 0.6 * before.result.metrics["area_3d"]

    # drag a point outwards: the piece re-solves larger; undo puts it back
    assert len(view.layer_points("handles")) == 6  # the drawn points, to drag
    area0 = r.metrics["area_3d"]
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        drag(qtbot, view, pixel(view, drawn.outer[0]), pixel(view, ring((1, 1, 1), 33, 6)[0]))
    moved = win.project.settings.region
    assert doc.undo_label == "Move region point" and moved.drawn.outer[1:] == drawn.outer[1:]
    assert np.linalg.norm(np.subtract(moved.drawn.outer[0], drawn.outer[0])) > 0.05
    assert win.project.result.metrics["area_3d"] > area0 * 1.02
    assert win.project.result.pattern.area > r.pattern.area * 1.02
    doc.undo()  # the edit's result comes back with it: no re-run
    assert win.project.settings.region == region and win.project.result is r

    # a hole: a loop inside the region (the undo may have ended the tool)
    if not isinstance(win.tool, RegionTool):
        win.actions["tool_region"].trigger()
    hole_px = [pixel(view, t) for t in ring((1.05, 1, 0.95), 9, 5)]
    for x, y in hole_px:
        click(qtbot, view, x, y)
    assert len(win.tool.points) == 5, win.last_hint
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        qtbot.keyClick(view.widget, Qt.Key.Key_Return)
    holed = win.project.settings.region
    assert holed.n_holes == 1 and doc.undo_label == "Draw hole" and len(holed.drawn.holes) == 1
    assert holed.drawn.outer == drawn.outer
    assert win.project.result.pattern.pieces[0].n_region_holes == 1

    # undo and redo the hole
    doc.undo()
    assert win.project.settings.region == region
    doc.redo()
    assert win.project.settings.region == holed

    # save and reopen: the drawn form comes back
    assert win.save_to(tmp_path / "ply")
    other = make_window(example="saddle")
    assert other.open_file(tmp_path / "ply.flatweave")
    assert other.project.settings.region == holed
    assert other.project.settings.region.drawn == holed.drawn


def test_a_region_too_small_is_refused_and_nothing_changes(make_window, qtbot):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    win.view.look(*CAMERA)
    ready(qtbot, win)
    revision = win.document.revision
    win.actions["tool_region"].trigger()
    for t in ring((1, 1, 1), 6, 4):
        click(qtbot, win.view, *pixel(win.view, t))
    qtbot.keyClick(win.view.widget, Qt.Key.Key_Return)
    assert "under 6 cells" in win.last_hint
    assert win.document.revision == revision and win.project.settings.region is None
