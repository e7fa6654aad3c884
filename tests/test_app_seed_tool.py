"""GUI test of the seed tool: the seed picked by a click inside the
drawn piece, the weft direction by a drag from it, the rosette drawn as two
arrows; a click outside the piece is refused with one line, nothing changed.

Clicks are real mouse events on the octant (the unit sphere): where they land
is the ray-sphere intersection of the pixel (tests.test_app_tools' oracle),
and the sphere's tangent plane at a point p is the plane normal to p."""

from __future__ import annotations

import numpy as np

from flatweave.method.fibres import reference_direction

from tests.test_app_region_edit import CENTRE, drawn_window
from tests.test_app_region_tool import ring
from tests.test_app_run import RUN_TIMEOUT_MS
from tests.test_app_tools import click, drag, pixel, ray_sphere


def tangent(o, p):
    """The unit direction from o towards p in the sphere's tangent plane at o."""
    n = o / np.linalg.norm(o)
    d = (p - o) - ((p - o) @ n) * n
    return d / np.linalg.norm(d)


def test_pick_the_seed_and_the_weft_direction(make_window, qtbot):
    win = drawn_window(make_window, qtbot)
    view, doc, s = win.view, win.document, win.surface
    win.actions["tool_seed"].trigger()
    assert win.tool.name == "seed"
    arrows = [view.layer_lines("weft arrow"), view.layer_lines("warp arrow")]
    seed_xyz = s.points(np.array([s.domain[:, 0] + np.array(win.project.settings.seed)
                                  * (s.domain[:, 1] - s.domain[:, 0])]))[0]
    assert len(arrows) == 2 and all(len(a) == 5 for a in arrows)
    for a in arrows:  # both start at the seed, across each other in its tangent plane
        assert np.linalg.norm(a[0] - seed_xyz) < 0.01
    weft, warp = (tangent(seed_xyz, a[1]) for a in arrows)
    assert abs(weft @ warp) < 1e-6

    # outside the piece: refused, nothing changes
    revision = doc.revision
    outside = np.array([0.95, 0.2, 0.2]) / np.linalg.norm([0.95, 0.2, 0.2])  # 38 degrees from the centre
    click(qtbot, view, *pixel(view, outside))
    assert "outside the piece's region" in win.last_hint and doc.revision == revision

    # a click inside: the seed goes under it, one edit that re-solves
    target = ring(CENTRE, 12, 6)[2]
    px = pixel(view, target)
    under = ray_sphere(view, *px)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        click(qtbot, view, *px)
    p = win.project
    assert doc.undo_label == "Move seed" and p.result_is_current
    dom = s.domain
    seed_uv = dom[:, 0] + np.array(p.settings.seed) * (dom[:, 1] - dom[:, 0])
    np.testing.assert_allclose(s.points(seed_uv[None])[0], under, atol=1e-7)
    assert np.linalg.norm(view.layer_lines("weft arrow")[0] - under) < 0.01

    # a drag from the seed turns the weft towards the cursor
    aim = ring(CENTRE, 20, 6)[4]
    end = pixel(view, aim)
    aimed = ray_sphere(view, *end)
    with qtbot.waitSignal(win.run_finished, timeout=RUN_TIMEOUT_MS):
        drag(qtbot, view, px, end)
    q = win.project
    assert doc.undo_label == "Seed and weft direction" and q.result_is_current
    np.testing.assert_allclose(reference_direction(s, q.settings), tangent(under, aimed), atol=3e-3)
    np.testing.assert_allclose(tangent(under, view.layer_lines("weft arrow")[1]), tangent(under, aimed), atol=3e-3)
    assert abs(q.settings.angle_deg - p.settings.angle_deg) > 5
    doc.undo()
    assert win.project.settings.angle_deg == p.settings.angle_deg
